"""The compiled DTW kernels of :mod:`mocapkit.segment.similarity` (kept apart so that importing
:mod:`mocapkit.segment` does not import numba)."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def dtw_kernel(a, b, band):
    """Eq. 8 row by row with two rows of r; ``steps[e, f]`` is the predecessor chosen (1 diagonal,
    2 from (e−1, f), 3 from (e, f−1); ties in that order; 0 at the start and outside the band)."""
    m, n, d = a.shape[0], b.shape[0], a.shape[1]
    inf = np.inf
    prev = np.full(n, inf)
    cur = np.full(n, inf)
    steps = np.zeros((m, n), dtype=np.int8)
    width = band * (min(m, n) - 1)
    for e in range(m):
        if band < 0 or m == 1:
            lo, hi = 0, n - 1
        else:  # |e (n−1) − f (m−1)| <= width
            lo = -((width - e * (n - 1)) // (m - 1))  # ceil((e (n−1) − width) / (m−1))
            hi = (e * (n - 1) + width) // (m - 1)
            lo = max(lo, 0)
            hi = min(hi, n - 1)
        for f in range(n):
            cur[f] = inf
        for f in range(lo, hi + 1):
            s = 0.0
            for k in range(d):
                t = a[e, k] - b[f, k]
                s += t * t
            dist = math.sqrt(s)
            if e == 0 and f == 0:
                cur[f] = dist
                continue
            best = inf
            step = 0
            if e > 0 and f > 0 and prev[f - 1] < best:
                best = prev[f - 1]
                step = 1
            if e > 0 and prev[f] < best:
                best = prev[f]
                step = 2
            if f > 0 and cur[f - 1] < best:
                best = cur[f - 1]
                step = 3
            cur[f] = dist + best
            steps[e, f] = step
        prev, cur = cur, prev
    return prev[n - 1], steps


@numba.njit(cache=True)
def backtrack(steps):
    m, n = steps.shape
    out = np.empty((m + n - 1, 2), dtype=np.int64)
    e, f, k = m - 1, n - 1, 0
    while True:
        out[k, 0] = e
        out[k, 1] = f
        k += 1
        if e == 0 and f == 0:
            break
        s = steps[e, f]
        if s == 1:
            e -= 1
            f -= 1
        elif s == 2:
            e -= 1
        else:
            f -= 1
    return out[:k][::-1].copy()
