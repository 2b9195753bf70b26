"""Sliding window (SW) PLA with connected segments, as used by the fastSW paper (Keogh et al.).

The segment runs from the last segment point (an original sample) to the newest sample ``s_n``
with slope ``β_d = y_dn / t_n`` (Eq. 4 of the fastSW paper). Its SSR (Eq. 5) is recomputed from the
buffered samples ``s_1..s_{n-1}`` at every new sample: O(n) time and memory per sample. When it
exceeds the threshold, ``s_{n-1}`` becomes a segment point and the new segment starts there.

Eq. 5 also sums ``j = n``, whose residual is zero by construction; it is left out here because in
floating point ``y − (y/t)·t`` can be one ulp off zero, which at threshold 0 would wrongly end every
segment. With this, SW and fastSW decide identically wherever the two float evaluations of the same
SSR do not straddle the threshold (the ties are documented and tested in ``tests/test_pla.py``).

State: ``fs = [t_anchor, t_prev, anchor(D), prev(D)]``, ``st = [n, prev_index, anchor_index]`` and a
buffer ``bt (cap,)``, ``bx (cap, D)`` of the samples after the anchor.
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int, capacity: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return (
        np.zeros(2 + 2 * dim),
        np.array([-1, -1, -1], dtype=np.int64),
        np.empty(capacity),
        np.empty((capacity, dim)),
    )


@numba.njit(cache=True)
def step(fs, st, bt, bx, t, x, idx, th, maxlen, out) -> int:
    """Process one sample; return the index of an emitted segment point or -1.

    The buffer must hold at least ``n`` samples (the caller grows it when ``st[0] == len(bt)``).
    """
    D = x.shape[0]
    av = 2
    pv = 2 + D
    n = st[0]
    if n < 0:
        fs[0] = t
        fs[1] = t
        for d in range(D):
            fs[av + d] = x[d]
            fs[pv + d] = x[d]
            out[d] = x[d]
        st[0] = 0
        st[1] = idx
        st[2] = idx
        return idx
    n += 1
    tn = t - fs[0]
    ssr = 0.0
    if maxlen <= 0 or n <= maxlen:
        for d in range(D):  # slope, Eq. 4 (``out`` is scratch until a point is emitted)
            out[d] = (x[d] - fs[av + d]) / tn
        for j in range(n - 1):  # Eq. 5 over s_1..s_{n-1}
            tj = bt[j] - fs[0]
            for d in range(D):
                r = (bx[j, d] - fs[av + d]) - out[d] * tj
                ssr += r * r
        if ssr <= th:
            bt[n - 1] = t
            for d in range(D):
                bx[n - 1, d] = x[d]
                fs[pv + d] = x[d]
            fs[1] = t
            st[0] = n
            st[1] = idx
            return -1
    emitted = st[1]
    fs[0] = fs[1]
    for d in range(D):
        out[d] = fs[pv + d]
        fs[av + d] = fs[pv + d]
        fs[pv + d] = x[d]
        bx[0, d] = x[d]
    bt[0] = t
    fs[1] = t
    st[0] = 1
    st[1] = idx
    st[2] = emitted
    return emitted


@numba.njit(cache=True)
def flush(fs, st, out) -> int:
    if st[0] <= 0 or st[1] == st[2]:
        return -1
    D = out.shape[0]
    for d in range(D):
        out[d] = fs[2 + D + d]
    st[2] = st[1]
    st[0] = 0
    return st[1]


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array SW; returns the indices of the segment points."""
    N, D = X.shape
    fs = np.zeros(2 + 2 * D)
    st = np.array([-1, -1, -1], dtype=np.int64)
    bt = np.empty(max(N, 1))
    bx = np.empty((max(N, 1), D))
    out = np.empty(D)
    idx = np.empty(N, dtype=np.int64)
    m = 0
    for i in range(N):
        e = step(fs, st, bt, bx, t[i], X[i], i, th, maxlen, out)
        if e >= 0:
            idx[m] = e
            m += 1
    e = flush(fs, st, out)
    if e >= 0:
        idx[m] = e
        m += 1
    return idx[:m]
