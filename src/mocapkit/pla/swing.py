"""Swing Filter (Elmeleegy et al., VLDB 2009): connected PLA with a per-sample L∞ bound ε.

Per dimension ``d`` the filter keeps an upper slope ``u_d`` and a lower slope ``l_d`` of lines
through the anchor (the last segment point). A new sample at ``t`` (relative to the anchor) with
value ``y_d`` admits the slopes ``[(y_d − ε)/t, (y_d + ε)/t]``; it joins the segment when that
interval meets ``[l_d, u_d]`` in every dimension, which then shrinks to the intersection ("swings").
Otherwise the segment ends at the time of the previous sample: its slope is the least-squares slope
through the anchor, ``mean(t·y_d)/mean(t²)``, clamped into ``[l_d, u_d]``, so every sample of the
segment lies within ε of the line in every dimension. The end point anchors the next segment.

State: ``sc = [t_anchor, t_prev, mean(t²), n]``, ``av`` (anchor), ``tym``, ``up``, ``lo``. Calling
convention as in :mod:`mocapkit.pla.fastsw` (the emitted point is the new anchor).
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, ...]:
    return np.zeros(4), np.zeros(dim), np.zeros(dim), np.zeros(dim), np.zeros(dim)


@numba.njit(cache=True, inline="always")
def start(sc, av, tym, up, lo, t, x) -> None:
    sc[0] = t
    sc[1] = t
    sc[2] = 0.0
    sc[3] = 0.0
    for d in range(x.shape[0]):
        av[d] = x[d]


@numba.njit(cache=True, inline="always")
def _restart(sc, av, tym, up, lo, t, x, eps) -> None:
    """``s_n`` as the first sample of a segment anchored at ``(sc[0], av)``: initial bounds."""
    tn = t - sc[0]
    sc[2] = tn * tn
    for d in range(x.shape[0]):
        y = x[d] - av[d]
        tym[d] = tn * y
        up[d] = (y + eps) / tn
        lo[d] = (y - eps) / tn
    sc[1] = t
    sc[3] = 1.0


@numba.njit(cache=True, inline="always")
def _end(sc, av, tym, up, lo) -> None:
    """Move the anchor to ``t_prev`` along the least-squares slope clamped into ``[l, u]``."""
    tp = sc[1] - sc[0]
    for d in range(av.shape[0]):
        s = tym[d] / sc[2]
        if s > up[d]:
            s = up[d]
        if s < lo[d]:
            s = lo[d]
        av[d] = av[d] + s * tp
    sc[0] = sc[1]


@numba.njit(cache=True, inline="always")
def step(sc, av, tym, up, lo, t, x, eps, maxlen) -> bool:
    D = x.shape[0]
    n = sc[3] + 1.0
    if n == 1.0:
        _restart(sc, av, tym, up, lo, t, x, eps)
        return False
    tn = t - sc[0]
    ok = maxlen <= 0 or n <= maxlen
    if ok:
        for d in range(D):
            y = x[d] - av[d]
            if (y + eps) / tn < lo[d] or (y - eps) / tn > up[d]:
                ok = False
                break
    if ok:
        rn = 1.0 / n
        sc[2] = sc[2] + (tn * tn - sc[2]) * rn
        for d in range(D):
            y = x[d] - av[d]
            hi = (y + eps) / tn
            lw = (y - eps) / tn
            if hi < up[d]:
                up[d] = hi
            if lw > lo[d]:
                lo[d] = lw
            tym[d] = tym[d] + (tn * y - tym[d]) * rn
        sc[1] = t
        sc[3] = n
        return False
    _end(sc, av, tym, up, lo)
    _restart(sc, av, tym, up, lo, t, x, eps)
    return True


@numba.njit(cache=True)
def flush(sc, av, tym, up, lo) -> bool:
    if sc[3] <= 0.0:
        return False
    _end(sc, av, tym, up, lo)
    sc[3] = 0.0
    return True


@numba.njit(cache=True)
def batch(t, X, eps, maxlen):
    """Whole-array Swing Filter; returns ``(indices, values)`` of the segment points."""
    N, D = X.shape
    idx = np.empty(N, dtype=np.int64)
    vals = np.empty((N, D))
    if N == 0:
        return idx, vals
    sc = np.zeros(4)
    av = np.zeros(D)
    tym = np.zeros(D)
    up = np.zeros(D)
    lo = np.zeros(D)
    start(sc, av, tym, up, lo, t[0], X[0])
    idx[0] = 0
    vals[0] = av
    m = 1
    for i in range(1, N):
        if step(sc, av, tym, up, lo, t[i], X[i], eps, maxlen):
            idx[m] = i - 1
            vals[m] = av
            m += 1
    if flush(sc, av, tym, up, lo):
        idx[m] = N - 1
        vals[m] = av
        m += 1
    return idx[:m], vals[:m]
