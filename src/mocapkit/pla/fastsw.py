"""fastSW: sliding-window PLA in O(1) time and memory per sample.

Algorithm 1 and Eq. 4–13 of the fastSW paper (Sensors 2021, 21, 5180). The segment runs from the
last segment point (an original sample) to the newest sample ``s_n``; its slope (Eq. 4) is
``β_d = y_dn / t_n``. The SSR of the samples ``s_1..s_{n-1}`` against that line (Eq. 5; ``s_n`` has
zero residual) is obtained from running means (Eq. 7–12) as Eq. 13 with the means of the first
``n − 1`` samples (Algorithm 1, line 8). When the SSR exceeds the threshold, the previous sample
``s_{n-1}`` becomes a segment point and the new segment starts there.

State (O(1) in the segment length): a float array ``fs`` =
``[t_anchor, t_prev, mean(t²), anchor(D), prev(D), mean(t·y)(D), mean(y²)(D)]`` and an int array
``st`` = ``[n, prev_index, anchor_index]`` (``n = -1`` before the first sample).
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, np.ndarray]:
    fs = np.zeros(3 + 4 * dim)
    st = np.array([-1, -1, -1], dtype=np.int64)
    return fs, st


@numba.njit(cache=True)
def step(fs, st, t, x, idx, th, maxlen, out) -> int:
    """Process one sample (Algorithm 1, PROCESS_SAMPLE); return the index of an emitted point or -1.

    The emitted point's values are written into ``out`` (the sample's values, as processed).
    """
    D = x.shape[0]
    av = 3
    pv = 3 + D
    tym = 3 + 2 * D
    y2m = 3 + 3 * D
    n = st[0]
    if n < 0:  # the very first sample is the initial segment point
        fs[0] = t
        fs[1] = t
        fs[2] = 0.0
        for d in range(D):
            fs[av + d] = x[d]
            fs[pv + d] = x[d]
            fs[tym + d] = 0.0
            fs[y2m + d] = 0.0
            out[d] = x[d]
        st[0] = 0
        st[1] = idx
        st[2] = idx
        return idx
    n += 1  # line 2
    tn = t - fs[0]  # line 4
    ssr = 0.0  # line 3
    t2 = fs[2]
    for d in range(D):  # lines 5-8
        y = x[d] - fs[av + d]
        beta = y / tn
        ssr += (fs[y2m + d] - 2.0 * beta * fs[tym + d] + beta * beta * t2) * (n - 1)
    if ssr <= th and (maxlen <= 0 or n <= maxlen):  # line 9
        fs[2] = t2 + (tn * tn - t2) / n  # line 10 (Eq. 12)
        for d in range(D):
            y = x[d] - fs[av + d]
            fs[tym + d] = fs[tym + d] + (tn * y - fs[tym + d]) / n  # line 12 (Eq. 11)
            fs[y2m + d] = fs[y2m + d] + (y * y - fs[y2m + d]) / n  # line 13 (Eq. 10)
            fs[pv + d] = x[d]  # line 14
        fs[1] = t
        st[0] = n
        st[1] = idx
        return -1  # line 15
    # lines 16-25: s_{n-1} becomes the new segment point, s_n starts the new segment
    emitted = st[1]
    fs[0] = fs[1]
    for d in range(D):
        out[d] = fs[pv + d]
        fs[av + d] = fs[pv + d]
    st[2] = emitted
    tn = t - fs[0]  # line 19
    fs[2] = tn * tn  # line 20
    for d in range(D):
        y = x[d] - fs[av + d]  # line 22
        fs[tym + d] = tn * y  # line 23
        fs[y2m + d] = y * y  # line 24
        fs[pv + d] = x[d]
    fs[1] = t
    st[0] = 1  # line 18
    st[1] = idx
    return emitted


@numba.njit(cache=True)
def flush(fs, st, out) -> int:
    """End of stream: the last sample becomes the final segment point (unless it already is one)."""
    if st[0] <= 0 or st[1] == st[2]:
        return -1
    D = out.shape[0]
    for d in range(D):
        out[d] = fs[3 + D + d]
    st[2] = st[1]
    st[0] = 0
    return st[1]


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array fastSW; returns the indices of the segment points (a subset of the samples)."""
    N, D = X.shape
    fs = np.zeros(3 + 4 * D)
    st = np.array([-1, -1, -1], dtype=np.int64)
    out = np.empty(D)
    idx = np.empty(N, dtype=np.int64)
    m = 0
    for i in range(N):
        e = step(fs, st, t[i], X[i], i, th, maxlen, out)
        if e >= 0:
            idx[m] = e
            m += 1
    e = flush(fs, st, out)
    if e >= 0:
        idx[m] = e
        m += 1
    return idx[:m]


@numba.njit(cache=True, parallel=True)
def batch_many(t, X, th, maxlen):
    """fastSW over many channels sharing one time axis: ``X`` is ``(C, N, D)``.

    Returns ``(counts (C,), idx (C, N))``: channel ``c``'s points are ``idx[c, :counts[c]]``.
    Channels run in parallel (numba ``prange``).
    """
    C, N, D = X.shape
    counts = np.zeros(C, dtype=np.int64)
    idx = np.empty((C, N), dtype=np.int64)
    for c in numba.prange(C):
        fs = np.zeros(3 + 4 * D)
        st = np.array([-1, -1, -1], dtype=np.int64)
        out = np.empty(D)
        m = 0
        for i in range(N):
            e = step(fs, st, t[i], X[c, i], i, th, maxlen, out)
            if e >= 0:
                idx[c, m] = e
                m += 1
        e = flush(fs, st, out)
        if e >= 0:
            idx[c, m] = e
            m += 1
        counts[c] = m
    return counts, idx
