"""fastSW: sliding-window PLA in O(1) time and memory per sample.

Algorithm 1 and Eq. 4–13 of the fastSW paper (Sensors 2021, 21, 5180). The segment runs from the
last segment point (an original sample) to the newest sample ``s_n``; its slope (Eq. 4) is
``β_d = y_dn / t_n``. The SSR of the samples ``s_1..s_{n-1}`` against that line (Eq. 5; ``s_n`` has
zero residual) is obtained from running means (Eq. 7–12) as Eq. 13 with the means of the first
``n − 1`` samples (Algorithm 1, line 8). When the SSR exceeds the threshold, the previous sample
``s_{n-1}`` becomes a segment point and the new segment starts there.

The mean updates multiply by ``1/n`` instead of dividing by ``n`` three times per dimension
(Algorithm 1, lines 10–13): the same quantity, one division per sample.

State (O(1) in the segment length): ``sc = [t_anchor, t_prev, mean(t²), n]`` and the length-D
arrays ``av`` (anchor), ``pv`` (previous sample), ``tym`` (mean t·y), ``y2m`` (mean y²).
Every method module shares this calling convention: ``start`` takes the first sample; ``step``
returns ``True`` when the *previous* sample's time became a segment point, ``flush`` returns
``True`` when the last sample's time became the final point; either way the point is then the
anchor, ``(sc[0], av)``. (No separate output array: a store to an array that may alias the state
makes the compiled loop ~7× slower.)
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, ...]:
    return np.zeros(4), np.zeros(dim), np.zeros(dim), np.zeros(dim), np.zeros(dim)


@numba.njit(cache=True, inline="always")
def start(sc, av, pv, tym, y2m, t, x) -> None:
    """The very first sample is the initial segment point."""
    sc[0] = t
    sc[1] = t
    sc[2] = 0.0
    sc[3] = 0.0
    for d in range(x.shape[0]):
        av[d] = x[d]
        pv[d] = x[d]
        tym[d] = 0.0
        y2m[d] = 0.0


@numba.njit(cache=True, inline="always")
def step(sc, av, pv, tym, y2m, t, x, th, maxlen) -> bool:
    """Algorithm 1, PROCESS_SAMPLE: ``True`` when ``s_{n-1}`` became a segment point."""
    D = x.shape[0]
    n = sc[3] + 1.0  # line 2
    tn = t - sc[0]  # line 4
    t2 = sc[2]
    ssr = 0.0  # line 3
    for d in range(D):  # lines 5-8
        y = x[d] - av[d]
        beta = y / tn
        ssr += (y2m[d] - 2.0 * beta * tym[d] + beta * beta * t2) * (n - 1.0)
    if ssr <= th and (maxlen <= 0 or n <= maxlen):  # line 9
        rn = 1.0 / n
        sc[2] = t2 + (tn * tn - t2) * rn  # line 10 (Eq. 12)
        for d in range(D):
            y = x[d] - av[d]
            tym[d] = tym[d] + (tn * y - tym[d]) * rn  # line 12 (Eq. 11)
            y2m[d] = y2m[d] + (y * y - y2m[d]) * rn  # line 13 (Eq. 10)
            pv[d] = x[d]  # line 14
        sc[1] = t
        sc[3] = n
        return False  # line 15
    # lines 16-25: s_{n-1} becomes the new segment point, s_n starts the new segment
    sc[0] = sc[1]
    tn = t - sc[0]  # line 19
    sc[2] = tn * tn  # line 20
    for d in range(D):
        av[d] = pv[d]
        y = x[d] - av[d]  # line 22
        tym[d] = tn * y  # line 23
        y2m[d] = y * y  # line 24
        pv[d] = x[d]
    sc[1] = t
    sc[3] = 1.0  # line 18
    return True


@numba.njit(cache=True)
def flush(sc, av, pv, tym, y2m) -> bool:
    """End of stream: the last sample becomes the final point unless it already is one."""
    if sc[3] <= 0.0:
        return False
    sc[0] = sc[1]
    for d in range(av.shape[0]):
        av[d] = pv[d]
    sc[3] = 0.0
    return True


@numba.njit(cache=True)
def _run(t, X, th, maxlen, idx) -> int:
    N, D = X.shape
    sc = np.zeros(4)
    av = np.zeros(D)
    pv = np.zeros(D)
    tym = np.zeros(D)
    y2m = np.zeros(D)
    if N == 0:
        return 0
    start(sc, av, pv, tym, y2m, t[0], X[0])
    idx[0] = 0
    m = 1
    for i in range(1, N):
        if step(sc, av, pv, tym, y2m, t[i], X[i], th, maxlen):
            idx[m] = i - 1
            m += 1
    if flush(sc, av, pv, tym, y2m):
        idx[m] = N - 1
        m += 1
    return m


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array fastSW; returns the indices of the segment points (a subset of the samples)."""
    idx = np.empty(X.shape[0], dtype=np.int64)
    m = _run(t, X, th, maxlen, idx)
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
        # C-contiguous typed views/buffers: an 'A'-layout slice makes the inner loop ~2x slower
        xc = np.ascontiguousarray(X[c])
        loc = np.empty(N, dtype=np.int64)
        m = _run(t, xc, th, maxlen, loc)
        counts[c] = m
        idx[c, :m] = loc[:m]
    return counts, idx
