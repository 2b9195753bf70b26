"""Swing Filter (Elmeleegy et al., VLDB 2009): connected PLA with a per-sample L∞ bound ε.

Per dimension ``d`` the filter keeps an upper slope ``u_d`` and a lower slope ``l_d`` of lines
through the anchor (the last segment point). A new sample at ``t`` (relative to the anchor) with
value ``y_d`` admits the slopes ``[(y_d − ε)/t, (y_d + ε)/t]``; it joins the segment when that
interval meets ``[l_d, u_d]`` in every dimension, which then shrinks to the intersection ("swings").
Otherwise the segment ends at the time of the previous sample: its slope is the least-squares slope
through the anchor, ``mean(t·y_d)/mean(t²)``, clamped into ``[l_d, u_d]``, so every sample of the
segment lies within ε of the line in every dimension. The end point anchors the next segment.

State: ``fs = [t_anchor, t_prev, mean(t²), anchor(D), mean(t·y)(D), u(D), l(D)]``,
``st = [n, prev_index, anchor_index]``.
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(3 + 4 * dim), np.array([-1, -1, -1], dtype=np.int64)


@numba.njit(cache=True)
def _start(fs, D, t, x, eps) -> None:
    """First sample of a segment (relative to the current anchor)."""
    av = 3
    tym = 3 + D
    up = 3 + 2 * D
    lo = 3 + 3 * D
    tn = t - fs[0]
    fs[2] = tn * tn
    for d in range(D):
        y = x[d] - fs[av + d]
        fs[tym + d] = tn * y
        fs[up + d] = (y + eps) / tn
        fs[lo + d] = (y - eps) / tn
    fs[1] = t


@numba.njit(cache=True)
def step(fs, st, t, x, idx, eps, maxlen, out) -> int:
    D = x.shape[0]
    av = 3
    tym = 3 + D
    up = 3 + 2 * D
    lo = 3 + 3 * D
    n = st[0]
    if n < 0:
        fs[0] = t
        fs[1] = t
        for d in range(D):
            fs[av + d] = x[d]
            out[d] = x[d]
        st[0] = 0
        st[1] = idx
        st[2] = idx
        return idx
    n += 1
    if n == 1:
        _start(fs, D, t, x, eps)
        st[0] = 1
        st[1] = idx
        return -1
    tn = t - fs[0]
    ok = maxlen <= 0 or n <= maxlen
    if ok:
        for d in range(D):
            y = x[d] - fs[av + d]
            if (y + eps) / tn < fs[lo + d] or (y - eps) / tn > fs[up + d]:
                ok = False
                break
    if ok:
        fs[2] = fs[2] + (tn * tn - fs[2]) / n
        for d in range(D):
            y = x[d] - fs[av + d]
            hi = (y + eps) / tn
            lw = (y - eps) / tn
            if hi < fs[up + d]:
                fs[up + d] = hi
            if lw > fs[lo + d]:
                fs[lo + d] = lw
            fs[tym + d] = fs[tym + d] + (tn * y - fs[tym + d]) / n
        fs[1] = t
        st[0] = n
        st[1] = idx
        return -1
    emitted = st[1]
    _end_point(fs, D, out)
    for d in range(D):
        fs[av + d] = out[d]
    fs[0] = fs[1]
    _start(fs, D, t, x, eps)
    st[0] = 1
    st[1] = idx
    st[2] = emitted
    return emitted


@numba.njit(cache=True)
def _end_point(fs, D, out) -> None:
    """Value at ``t_prev`` of the line with the least-squares slope clamped into ``[l, u]``."""
    av = 3
    tym = 3 + D
    up = 3 + 2 * D
    lo = 3 + 3 * D
    tp = fs[1] - fs[0]
    for d in range(D):
        s = fs[tym + d] / fs[2]
        if s > fs[up + d]:
            s = fs[up + d]
        if s < fs[lo + d]:
            s = fs[lo + d]
        out[d] = fs[av + d] + s * tp


@numba.njit(cache=True)
def flush(fs, st, out) -> int:
    if st[0] <= 0:
        return -1
    _end_point(fs, out.shape[0], out)
    st[2] = st[1]
    st[0] = 0
    return st[1]


@numba.njit(cache=True)
def batch(t, X, eps, maxlen):
    """Whole-array Swing Filter; returns ``(indices, values)`` of the segment points."""
    N, D = X.shape
    fs = np.zeros(3 + 4 * D)
    st = np.array([-1, -1, -1], dtype=np.int64)
    out = np.empty(D)
    idx = np.empty(N, dtype=np.int64)
    vals = np.empty((N, D))
    m = 0
    for i in range(N):
        e = step(fs, st, t[i], X[i], i, eps, maxlen, out)
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
