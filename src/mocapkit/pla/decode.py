"""Decoding segment points back to a signal at arbitrary times."""

from __future__ import annotations

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.quat import slerp


def unit_quaternions(q: np.ndarray) -> np.ndarray:
    """``q / |q|`` row by row without overflow or underflow: each row is first divided by its largest
    magnitude, so ``1e300`` or ``1e-200`` components normalise exactly like ``1``. A zero row, or one
    that is not finite, is an :class:`InvalidParameterError` naming the row (a decoder never writes
    a zero-norm or NaN quaternion)."""
    q = np.asarray(q, dtype=np.float64)
    if not np.all(np.isfinite(q)):
        i = int(np.flatnonzero(~np.isfinite(q).all(axis=-1))[0])
        raise InvalidParameterError(f"segment point {i}: {q[i].tolist()!r} is not finite")
    scale = np.abs(q).max(axis=-1, keepdims=True)
    if np.any(scale == 0.0):
        i = int(np.flatnonzero(scale[..., 0] == 0.0)[0])
        raise InvalidParameterError(f"segment point {i}: zero-norm quaternion {q[i].tolist()!r}")
    u = q / scale
    return u / np.sqrt(np.einsum("...i,...i->...", u, u))[..., None]


def reconstruct_points(
    point_times: np.ndarray, point_values: np.ndarray, times: np.ndarray, kind: str = "quaternion"
) -> np.ndarray:
    """Interpolate between consecutive segment points at ``times``.

    Quaternion points are normalised first (CPLR and Swing Filter points are not unit length) and
    joined by SLERP along the shortest arc, as in Section 4 of the fastSW paper; vector points are
    joined linearly. ``times`` must lie within the points' time span.
    """
    pt = np.asarray(point_times, dtype=np.float64)
    pv = np.asarray(point_values, dtype=np.float64)
    t = np.asarray(times, dtype=np.float64)
    if pt.ndim != 1 or pv.ndim != 2 or pv.shape[0] != pt.shape[0] or pt.shape[0] == 0:
        raise InvalidParameterError("segment points need matching (M,) times and (M, D) values, M >= 1")
    if kind == "quaternion" and pv.shape[1] != 4:
        raise InvalidParameterError(f"quaternion segment points have 4 values, got {pv.shape[1]}")
    if not (np.all(np.isfinite(pt)) and np.all(np.isfinite(t))):
        raise InvalidParameterError("segment point times and decode times must be finite")
    if np.any(np.diff(pt) <= 0):
        i = int(np.flatnonzero(np.diff(pt) <= 0)[0]) + 1
        raise InvalidParameterError(f"segment point times must be strictly increasing: point {i} at "
                                    f"{float(pt[i])!r} s is not after {float(pt[i - 1])!r} s")
    if kind == "quaternion":
        pv = unit_quaternions(pv)  # also refuses NaN/inf and zero-norm points
    elif not np.all(np.isfinite(pv)):
        raise InvalidParameterError("segment point values must be finite")
    if t.size and (t.min() < pt[0] or t.max() > pt[-1]):
        raise InvalidParameterError(
            f"requested times [{float(t.min())!r}, {float(t.max())!r}] s reach outside the segment points' "
            f"span [{float(pt[0])!r}, {float(pt[-1])!r}] s"
        )
    if pt.shape[0] == 1:
        return np.repeat(pv, t.shape[0], axis=0)
    k = np.clip(np.searchsorted(pt, t, side="right") - 1, 0, pt.shape[0] - 2)
    f = (t - pt[k]) / (pt[k + 1] - pt[k])
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        out = slerp(pv[k], pv[k + 1], f) if kind == "quaternion" else pv[k] + f[:, None] * (pv[k + 1] - pv[k])
    if not np.all(np.isfinite(out)):  # e.g. vector points so far apart that their difference overflows
        i = int(np.flatnonzero(~np.isfinite(out).all(axis=-1))[0])
        raise InvalidParameterError(f"the decoded value at {float(t[i])!r} s is not finite (points out of range)")
    return out


def reconstruct(compressed, times: np.ndarray | None = None) -> np.ndarray:
    """Decode a :class:`~mocapkit.pla.base.Compressed` at ``times`` (default: its points' own span
    is required to contain them; pass the original signal's times to get one value per sample)."""
    if times is None:
        raise InvalidParameterError("reconstruct needs the times to decode at")
    return reconstruct_points(compressed.times, compressed.values, times, compressed.kind)
