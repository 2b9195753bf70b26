"""Naive reference implementations of the PLA methods, written from the specification only.

Nothing here imports ``mocapkit``: every function works on plain numpy arrays so that the tests can
compare the package against code that shares none of its implementation.  The references are
deliberately simple (O(n²): every candidate segment is re-evaluated from scratch over all of its
samples) and follow the wording of the specification line by line:

* quaternion signals are made hemisphere-continuous first (sample ``i`` is negated when its dot
  product with the already continuous sample ``i-1`` is negative); vector signals are used as is;
* the time axis is the timestamps; segment ``k`` covers the samples with times in
  ``(T[k-1], T[k]]``; the first sample is the first point, the last sample's time the last point's;
* ``max_segment_length L``: a sample ``n`` with ``n - anchor_index > L`` is rejected exactly like a
  threshold violation.

Each ``ref_*`` function returns ``(indices, values)``: the sample indices at whose times the points
lie and the point values (the RAW input rows for SW, fastSW and anglesw; extrapolated points in the
hemisphere-continuous domain for CPLR and the Swing Filter).

The second half holds brute-force checkers of the guarantees every method promises.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

POS_METHODS = ("sw", "fastsw", "anglesw")
ALL_METHODS = ("sw", "fastsw", "cplr", "swing", "anglesw")


# --------------------------------------------------------------------------------------------
# small quaternion helpers (scalar-first w, x, y, z)
# --------------------------------------------------------------------------------------------


def hemisphere_continuous_ref(q: np.ndarray) -> np.ndarray:
    """Plain loop: negate sample i when <q_i, (continuous) q_{i-1}> < 0."""
    q = np.array(q, dtype=np.float64, copy=True)
    for i in range(1, q.shape[0]):
        p = q[i - 1]
        c = q[i]
        dot = float(c[0]) * float(p[0]) + float(c[1]) * float(p[1]) + float(c[2]) * float(p[2]) + float(
            c[3]
        ) * float(p[3])
        if dot < 0.0:
            q[i] = -c
    return q


def prepare(values: np.ndarray, kind: str) -> np.ndarray:
    values = np.asarray(values, dtype=np.float64)
    if kind == "quaternion":
        return hemisphere_continuous_ref(values)
    return values.copy()


def _unit(q: np.ndarray) -> np.ndarray:
    """``q / |q|`` along the last axis, element-wise in a fixed order (so equal rows give equal
    results whatever the array's shape: no BLAS / pairwise reductions)."""
    q = np.asarray(q, dtype=np.float64)
    ss = q[..., 0] * q[..., 0]
    for k in range(1, q.shape[-1]):
        ss = ss + q[..., k] * q[..., k]
    return q / np.sqrt(ss)[..., None]


def quat_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle (radians) between quaternions of any non-zero norm.

    ``2·acos|<a,b>|`` of the normalised quaternions, evaluated in the equivalent well-conditioned
    form ``4·atan2(|a − s·b|, |a + s·b|)`` with ``s = sign(<a,b>)``.
    """
    a = _unit(a)
    b = _unit(b)
    dot = np.sum(a * b, axis=-1)
    s = np.where(dot < 0.0, -1.0, 1.0)[..., None]
    return 4.0 * np.arctan2(np.linalg.norm(a - s * b, axis=-1), np.linalg.norm(a + s * b, axis=-1))


def slerp_ref(q0: np.ndarray, q1: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Textbook SLERP along the shortest arc between the normalised ``q0`` and ``q1``.

    ``q0`` and ``q1`` are single quaternions (4,), ``f`` an array of fractions; returns (len(f), 4)
    unit quaternions (except when both ends are the same rotation: then ``q0`` as given).
    """
    a = _unit(np.asarray(q0, dtype=np.float64))
    b = _unit(np.asarray(q1, dtype=np.float64))
    f = np.atleast_1d(np.asarray(f, dtype=np.float64))
    if float(np.dot(a, b)) < 0.0:
        b = -b
    omega = 2.0 * math.atan2(float(np.linalg.norm(a - b)), float(np.linalg.norm(a + b)))
    if omega == 0.0:
        # the same rotation at both ends: the arc is that rotation itself.  Return q0 exactly as
        # given (not re-normalised) so that a sample bit-identical to q0 is at angle exactly 0.
        return np.tile(np.asarray(q0, dtype=np.float64), (f.shape[0], 1))
    if omega < 1e-12:
        out = (1.0 - f)[:, None] * a + f[:, None] * b
        return _unit(out)
    so = math.sin(omega)
    w0 = np.sin((1.0 - f) * omega) / so
    w1 = np.sin(f * omega) / so
    return w0[:, None] * a + w1[:, None] * b


# --------------------------------------------------------------------------------------------
# reference algorithms
# --------------------------------------------------------------------------------------------


def _too_long(n: int, anchor: int, max_len: int | None) -> bool:
    return max_len is not None and n - anchor > max_len


def _sw_ssr(t: np.ndarray, X: np.ndarray, a: int, n: int) -> float:
    """Eq. 5: SSR of the samples strictly between a and n against the line from sample a to n."""
    beta = (X[n] - X[a]) / (t[n] - t[a])
    tj = t[a + 1 : n] - t[a]
    yj = X[a + 1 : n] - X[a]
    r = yj - tj[:, None] * beta[None, :]
    return float(np.sum(r * r))


def _pos_segmentation(t, X, accept, max_len):
    """Generic SW loop: ``accept(a, n)`` says whether the segment anchor a -> sample n is fine."""
    N = t.shape[0]
    pts = [0]
    a = 0
    for n in range(1, N):
        ok = (not _too_long(n, a, max_len)) and accept(a, n)
        if not ok:
            # sample n-1 becomes a point (the new anchor); sample n starts the new segment
            a = n - 1
            pts.append(a)
    if pts[-1] != N - 1:
        pts.append(N - 1)
    return np.asarray(pts, dtype=np.int64)


def ref_sw(times, values, kind, threshold, max_len=None):
    """Sliding window (SW == fastSW mathematically): points are original samples."""
    t = np.asarray(times, dtype=np.float64)
    raw = np.asarray(values, dtype=np.float64)
    X = prepare(raw, kind)
    th = float(threshold)
    idx = _pos_segmentation(t, X, lambda a, n: _sw_ssr(t, X, a, n) <= th, max_len)
    return idx, raw[idx].copy()


def ref_anglesw(times, values, kind, threshold_deg, max_len=None):
    """SW with the segment accepted while every inner sample is within the angle of the SLERP."""
    assert kind == "quaternion"
    t = np.asarray(times, dtype=np.float64)
    raw = np.asarray(values, dtype=np.float64)
    X = prepare(raw, kind)
    th = math.radians(float(threshold_deg))

    def accept(a, n):
        if n - a < 2:
            return True
        f = (t[a + 1 : n] - t[a]) / (t[n] - t[a])
        dec = slerp_ref(X[a], X[n], f)
        return bool(np.all(quat_angle(X[a + 1 : n], dec) <= th))

    idx = _pos_segmentation(t, X, accept, max_len)
    return idx, raw[idx].copy()


def _ls_slope(tj: np.ndarray, yj: np.ndarray) -> np.ndarray:
    """Least-squares slope of a line through the origin: Σ t y / Σ t² per dimension."""
    return np.sum(tj[:, None] * yj, axis=0) / np.sum(tj * tj)


def ref_cplr(times, values, kind, threshold, max_len=None):
    """Connected piecewise linear regression through the anchor (no intercept)."""
    t = np.asarray(times, dtype=np.float64)
    X = prepare(values, kind)
    th = float(threshold)
    N = t.shape[0]
    a, ta, xa = 0, t[0], X[0].copy()
    idx, vals = [0], [xa.copy()]
    seg: list[int] = []  # sample indices of the current segment (all after the anchor)

    def end_value(samples, t_end):
        s = np.asarray(samples)
        beta = _ls_slope(t[s] - ta, X[s] - xa)
        return xa + beta * (t_end - ta)

    for n in range(1, N):
        cand = seg + [n]
        if _too_long(n, a, max_len):
            ok = False
        elif len(cand) == 1:
            ok = True
        else:
            s = np.asarray(cand)
            tj = t[s] - ta
            yj = X[s] - xa
            beta = _ls_slope(tj, yj)
            r = yj - tj[:, None] * beta[None, :]
            ok = float(np.sum(r * r)) <= th
        if ok:
            seg = cand
            continue
        end = end_value(seg, t[n - 1])
        idx.append(n - 1)
        vals.append(end.copy())
        a, ta, xa = n - 1, t[n - 1], end
        seg = [n]
    if N > 1:
        idx.append(N - 1)
        vals.append(end_value(seg, t[N - 1]))
    return np.asarray(idx, dtype=np.int64), np.asarray(vals)


def ref_swing(times, values, kind, threshold, max_len=None):
    """Swing filter with per-dimension slope bounds through the anchor."""
    t = np.asarray(times, dtype=np.float64)
    X = prepare(values, kind)
    eps = float(threshold)
    N = t.shape[0]
    a, ta, xa = 0, t[0], X[0].copy()
    idx, vals = [0], [xa.copy()]
    seg: list[int] = []
    lo = hi = None

    def end_value(samples, t_end):
        s = np.asarray(samples)
        beta = _ls_slope(t[s] - ta, X[s] - xa)
        beta = np.minimum(np.maximum(beta, lo), hi)  # clamp into [l, u]
        return xa + beta * (t_end - ta)

    for n in range(1, N):
        tn = t[n] - ta
        yn = X[n] - xa
        s_lo = (yn - eps) / tn
        s_hi = (yn + eps) / tn
        if _too_long(n, a, max_len):
            ok = False
        elif not seg:
            ok = True
        else:
            ok = bool(np.all((s_lo <= hi) & (s_hi >= lo)))
        if ok:
            if not seg:
                lo, hi = s_lo.copy(), s_hi.copy()
            else:
                lo, hi = np.maximum(lo, s_lo), np.minimum(hi, s_hi)
            seg.append(n)
            continue
        end = end_value(seg, t[n - 1])
        idx.append(n - 1)
        vals.append(end.copy())
        a, ta, xa = n - 1, t[n - 1], end
        # sample n is the first sample after the new anchor: always joins, initialises the bounds
        tn = t[n] - ta
        yn = X[n] - xa
        lo, hi = (yn - eps) / tn, (yn + eps) / tn
        seg = [n]
    if N > 1:
        idx.append(N - 1)
        vals.append(end_value(seg, t[N - 1]))
    return np.asarray(idx, dtype=np.int64), np.asarray(vals)


REFERENCES = {
    "sw": ref_sw,
    "fastsw": ref_sw,
    "cplr": ref_cplr,
    "swing": ref_swing,
    "anglesw": ref_anglesw,
}


def ref_compress(times, values, kind, method, threshold, max_len=None):
    return REFERENCES[method](times, values, kind, threshold, max_len)


# --------------------------------------------------------------------------------------------
# brute-force checkers of the guarantees
# --------------------------------------------------------------------------------------------


def structure_problems(times, n_samples, indices, point_times, max_len=None) -> list[str]:
    """Connected segments: first sample first, last sample last, increasing, gaps <= L."""
    out = []
    idx = np.asarray(indices)
    if idx.ndim != 1 or idx.size == 0:
        return [f"indices must be a non-empty 1-D array, got shape {idx.shape}"]
    if idx[0] != 0:
        out.append(f"first point is sample {idx[0]}, not 0")
    if idx[-1] != n_samples - 1:
        out.append(f"last point is sample {idx[-1]}, not {n_samples - 1}")
    if np.any(np.diff(idx) <= 0):
        out.append(f"indices not strictly increasing: {idx.tolist()}")
    if max_len is not None and idx.size > 1 and np.diff(idx).max() > max_len:
        out.append(f"a segment spans {np.diff(idx).max()} > {max_len} samples")
    if not np.array_equal(np.asarray(point_times), np.asarray(times)[idx]):
        out.append("point times are not the times of the point samples")
    return out


def linear_decode(pt, pv, times) -> np.ndarray:
    """Linear interpolation between consecutive points (per dimension)."""
    pt = np.asarray(pt, dtype=np.float64)
    pv = np.asarray(pv, dtype=np.float64)
    times = np.asarray(times, dtype=np.float64)
    if pt.shape[0] == 1:
        return np.repeat(pv, times.shape[0], axis=0)
    return np.stack([np.interp(times, pt, pv[:, d]) for d in range(pv.shape[1])], axis=1)


def segment_ssrs(times, X, indices, point_values) -> list[tuple[float, float]]:
    """For each segment: (SSR of its samples in (T[k-1], T[k]) against the straight line between
    the two points, Σ y² of those samples relative to the start point — a scale for float slack).

    The sample at the end point itself is included (for point-preserving methods its residual is
    exactly the distance of the point to the sample, i.e. 0)."""
    t = np.asarray(times, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    out = []
    for k in range(1, len(indices)):
        a, b = int(indices[k - 1]), int(indices[k])
        va, vb = np.asarray(point_values[k - 1]), np.asarray(point_values[k])
        tj = t[a + 1 : b + 1] - t[a]
        yj = X[a + 1 : b + 1] - va
        beta = (vb - va) / (t[b] - t[a])
        r = yj - tj[:, None] * beta[None, :]
        out.append((float(np.sum(r * r)), float(np.sum(yj * yj))))
    return out


def to_scipy(q: np.ndarray) -> Rotation:
    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))  # scalar-last


def from_scipy(r: Rotation) -> np.ndarray:
    q = r.as_quat()
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def scipy_slerp_decode(pt, pv, times) -> Rotation:
    """SLERP decode of the (normalised) points at ``times`` with scipy (shortest arc)."""
    pt = np.asarray(pt, dtype=np.float64)
    pv = np.asarray(pv, dtype=np.float64)
    if pt.shape[0] == 1:
        return to_scipy(np.repeat(pv, len(times), axis=0))
    return Slerp(pt, to_scipy(pv))(np.asarray(times, dtype=np.float64))


def scipy_deviation_deg(times, values, pt, pv) -> np.ndarray:
    """Angle (degrees) between every original sample and the SLERP decode at its time."""
    dec = scipy_slerp_decode(pt, pv, times)
    orig = to_scipy(values)
    return np.degrees((orig.inv() * dec).magnitude())
