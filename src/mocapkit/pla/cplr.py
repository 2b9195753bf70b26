"""CPLR: connected piecewise linear regression, O(1) time and memory per sample.

Grützmacher et al., Sensors 2018 (ref. [16] of the fastSW paper), as summarised in Section 2 of the
fastSW paper. Each segment is a least-squares line *without intercept* through the last segment
point (the anchor), so consecutive segments connect. With ``t_j, y_dj`` relative to the anchor and
running means ``mean(t²)``, ``mean(t·y_d)``, ``mean(y_d²)`` (updated as Eq. 10–12 of the fastSW
paper), the regression slope is ``β_d = mean(t·y_d) / mean(t²)`` and the segment SSR is

    SSR_n = n · Σ_d ( mean(y_d²) − mean(t·y_d)² / mean(t²) ),

which is Eq. 13 with ``β_d`` resolved (fastSW paper, note after Eq. 13). When adding ``s_n`` would
make the SSR exceed the threshold, the segment ends at the time of ``s_{n-1}`` at the value of its
regression line (an extrapolated point, generally not a sample and not unit length); that point is
the anchor of the next segment, which starts with ``s_n``.

State: ``fs = [t_anchor, t_prev, mean(t²), anchor(D), mean(t·y)(D), mean(y²)(D)]``,
``st = [n, prev_index, anchor_index]``.
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(3 + 3 * dim), np.array([-1, -1, -1], dtype=np.int64)


@numba.njit(cache=True)
def step(fs, st, t, x, idx, th, maxlen, out) -> int:
    D = x.shape[0]
    av = 3
    tym = 3 + D
    y2m = 3 + 2 * D
    n = st[0]
    if n < 0:
        fs[0] = t
        fs[1] = t
        fs[2] = 0.0
        for d in range(D):
            fs[av + d] = x[d]
            fs[tym + d] = 0.0
            fs[y2m + d] = 0.0
            out[d] = x[d]
        st[0] = 0
        st[1] = idx
        st[2] = idx
        return idx
    n += 1
    tn = t - fs[0]
    t2 = fs[2] + (tn * tn - fs[2]) / n
    ok = maxlen <= 0 or n <= maxlen
    if ok and n > 1:
        ssr = 0.0
        for d in range(D):
            y = x[d] - fs[av + d]
            ty = fs[tym + d] + (tn * y - fs[tym + d]) / n
            y2 = fs[y2m + d] + (y * y - fs[y2m + d]) / n
            ssr += (y2 - ty * ty / t2) * n
        ok = ssr <= th
    if ok:
        fs[2] = t2
        for d in range(D):
            y = x[d] - fs[av + d]
            fs[tym + d] = fs[tym + d] + (tn * y - fs[tym + d]) / n
            fs[y2m + d] = fs[y2m + d] + (y * y - fs[y2m + d]) / n
        fs[1] = t
        st[0] = n
        st[1] = idx
        return -1
    # end the segment at t_prev on its regression line; that point anchors the next segment
    emitted = st[1]
    tp = fs[1] - fs[0]
    for d in range(D):
        out[d] = fs[av + d] + fs[tym + d] / fs[2] * tp
        fs[av + d] = out[d]
    fs[0] = fs[1]
    tn = t - fs[0]
    fs[2] = tn * tn
    for d in range(D):
        y = x[d] - fs[av + d]
        fs[tym + d] = tn * y
        fs[y2m + d] = y * y
    fs[1] = t
    st[0] = 1
    st[1] = idx
    st[2] = emitted
    return emitted


@numba.njit(cache=True)
def flush(fs, st, out) -> int:
    if st[0] <= 0:
        return -1
    D = out.shape[0]
    tp = fs[1] - fs[0]
    for d in range(D):
        out[d] = fs[3 + d] + fs[3 + D + d] / fs[2] * tp
    st[2] = st[1]
    st[0] = 0
    return st[1]


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array CPLR; returns ``(indices, values)`` of the segment points."""
    N, D = X.shape
    fs = np.zeros(3 + 3 * D)
    st = np.array([-1, -1, -1], dtype=np.int64)
    out = np.empty(D)
    idx = np.empty(N, dtype=np.int64)
    vals = np.empty((N, D))
    m = 0
    for i in range(N):
        e = step(fs, st, t[i], X[i], i, th, maxlen, out)
        if e >= 0:
            idx[m] = e
            vals[m] = out
            m += 1
    e = flush(fs, st, out)
    if e >= 0:
        idx[m] = e
        vals[m] = out
        m += 1
    return idx[:m], vals[:m]
