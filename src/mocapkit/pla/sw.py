"""Sliding window (SW) PLA with connected segments, as used by the fastSW paper (Keogh et al.).

The segment runs from the last segment point (an original sample) to the newest sample ``s_n``
with slope ``β_d = y_dn / t_n`` (Eq. 4 of the fastSW paper). Its SSR (Eq. 5) is recomputed from the
buffered samples ``s_1..s_{n-1}`` at every new sample: O(n) time and memory per sample. When it
exceeds the threshold, ``s_{n-1}`` becomes a segment point and the new segment starts there.

Eq. 5 also sums ``j = n``, whose residual is zero by construction; it is left out here because in
floating point ``y − (y/t)·t`` can be one ulp off zero, which at threshold 0 would wrongly end every
segment. With this, SW and fastSW decide identically wherever the two float evaluations of the same
SSR do not straddle the threshold (the ties are documented and tested in the test suite).

State: ``sc = [t_anchor, t_prev, n]``, ``av`` (anchor), ``pv`` (previous sample) and a buffer
``bt (cap,)``, ``bx (cap, D)`` of the samples after the anchor. Calling
convention as in :mod:`mocapkit.pla.fastsw`.
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int, capacity: int) -> tuple[np.ndarray, ...]:
    return np.zeros(3), np.zeros(dim), np.zeros(dim), np.empty(capacity), np.empty((capacity, dim))


@numba.njit(cache=True, inline="always")
def start(sc, av, pv, bt, bx, t, x) -> None:
    sc[0] = t
    sc[1] = t
    sc[2] = 0.0
    for d in range(x.shape[0]):
        av[d] = x[d]
        pv[d] = x[d]


@numba.njit(cache=True, inline="always")
def step(sc, av, pv, bt, bx, t, x, th, maxlen) -> bool:
    """``True`` when ``s_{n-1}`` became a segment point. The buffer must hold ``n`` samples."""
    D = x.shape[0]
    n = int(sc[2]) + 1
    tn = t - sc[0]
    if maxlen <= 0 or n <= maxlen:
        ssr = 0.0
        for d in range(D):
            beta = (x[d] - av[d]) / tn  # slope, Eq. 4
            for j in range(n - 1):  # Eq. 5 over s_1..s_{n-1}
                r = (bx[j, d] - av[d]) - beta * (bt[j] - sc[0])
                ssr += r * r
        if ssr <= th:
            bt[n - 1] = t
            for d in range(D):
                bx[n - 1, d] = x[d]
                pv[d] = x[d]
            sc[1] = t
            sc[2] = n
            return False
    sc[0] = sc[1]
    for d in range(D):
        av[d] = pv[d]
        pv[d] = x[d]
        bx[0, d] = x[d]
    bt[0] = t
    sc[1] = t
    sc[2] = 1.0
    return True


@numba.njit(cache=True)
def flush(sc, av, pv, bt, bx) -> bool:
    if sc[2] <= 0.0:
        return False
    sc[0] = sc[1]
    for d in range(av.shape[0]):
        av[d] = pv[d]
    sc[2] = 0.0
    return True


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array SW; returns the indices of the segment points."""
    N, D = X.shape
    idx = np.empty(N, dtype=np.int64)
    if N == 0:
        return idx
    sc = np.zeros(3)
    av = np.zeros(D)
    pv = np.zeros(D)
    bt = np.empty(N)
    bx = np.empty((N, D))
    start(sc, av, pv, bt, bx, t[0], X[0])
    idx[0] = 0
    m = 1
    for i in range(1, N):
        if step(sc, av, pv, bt, bx, t[i], X[i], th, maxlen):
            idx[m] = i - 1
            m += 1
    if flush(sc, av, pv, bt, bx):
        idx[m] = N - 1
        m += 1
    return idx[:m]
