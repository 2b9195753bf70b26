"""Keyframes on a quantisation grid, inside a tolerance corridor (the clip codec's track encoder).

A track (``x``, ``(n, D)``: rotation vectors or translations of one block of frames) is approximated by
line segments joined at keyframes whose values lie on the grid ``k·step`` (integers ``k`` are what the
file stores). Greedy, one pass: from the last key ``(a, y_a)`` the segment is extended frame by frame
while, for every component, the slopes that keep every sample ``t ∈ (a, b]`` within ``tol`` —
``[(x_t − tol − y_a)/(t − a), (x_t + tol − y_a)/(t − a)]``, intersected over ``t`` (the Swing Filter's
cone, O(1) per sample) — are not empty; the key is put at the last ``b`` where the cone, times
``b − a``, still holds a grid value in every component (the grid value nearest the sample is taken).
The first key is the sample rounded to the grid, so with ``step ≤ 2·tol`` every sample of the track,
keys included, decodes within ``tol`` per component. The first and last frames are always keys, so
blocks decode on their own.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.clip.codec import residual_cost
from mocapkit.errors import InvalidParameterError


@numba.njit(cache=True)
def _corridor(x, tol, step):
    n, D = x.shape
    idx = np.empty(n, np.int64)
    q = np.empty((n, D), np.int64)
    ya = np.empty(D)
    lo = np.empty(D)
    hi = np.empty(D)
    cand = np.empty(D, np.int64)
    for c in range(D):
        k = math.floor(x[0, c] / step + 0.5)
        q[0, c] = k
        ya[c] = k * step
    idx[0] = 0
    K = 1
    a = 0
    while a < n - 1:
        for c in range(D):
            lo[c] = -np.inf
            hi[c] = np.inf
        best = -1
        for b in range(a + 1, n):
            dt = b - a
            empty = False
            for c in range(D):
                lo_c = (x[b, c] - tol - ya[c]) / dt
                hi_c = (x[b, c] + tol - ya[c]) / dt
                if lo_c > lo[c]:
                    lo[c] = lo_c
                if hi_c < hi[c]:
                    hi[c] = hi_c
                if lo[c] > hi[c]:
                    empty = True
            if empty:
                break
            ok = True
            for c in range(D):
                kmin = math.ceil((ya[c] + lo[c] * dt) / step)
                kmax = math.floor((ya[c] + hi[c] * dt) / step)
                if kmin > kmax:
                    ok = False
                    break
                k = math.floor(x[b, c] / step + 0.5)
                cand[c] = min(max(k, kmin), kmax)
            if ok:
                best = b
                for c in range(D):
                    q[K, c] = cand[c]
        if best < 0:  # only by rounding at step ≈ 2·tol: the next sample, rounded, is a key
            best = a + 1
            for c in range(D):
                q[K, c] = math.floor(x[best, c] / step + 0.5)
        idx[K] = best
        for c in range(D):
            ya[c] = q[K, c] * step
        K += 1
        a = best
    return idx[:K].copy(), q[:K].copy()


def corridor_keys(x: np.ndarray, tol: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Keys of one track: ``(frames (K,) int64 from 0 to n − 1, grid integers (K, D) int64)``.

    ``step`` must be at most ``2·tol`` (the first key is a rounded sample); grid integers must fit
    comfortably in 53 bits (``|x|/step < 2**50``).
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] == 0:
        raise InvalidParameterError(f"a track is (n, D) with n >= 1, got {x.shape}")
    if not (tol > 0 and 0 < step <= 2.0 * tol and math.isfinite(step)):
        raise InvalidParameterError(f"need 0 < step <= 2·tol, got step {step!r}, tol {tol!r}")
    if np.abs(x).max() / step >= 2.0**50:
        raise InvalidParameterError(f"step {step:g} is too fine for values up to {np.abs(x).max():g}")
    return _corridor(x, float(tol), float(step))


@numba.njit(cache=True)
def choose_keys(x, steps, r):
    """Keys of one track in one block at repair level ``r`` (tolerance ``steps[r]/2``, ``steps`` the
    track's grid step per level): of the grid steps ``steps[r..r+2]`` (``2τ``, ``√2τ``, ``τ``) and the
    predictor orders 1 and 2, the pair with the fewest estimated bits (``Σ log2(1 + |residual|)`` plus a
    bit per value and ``log2`` of every key gap). Returns ``(level, order, frames, grid integers)``."""
    tol = steps[r] * 0.5
    best_bits = np.inf
    best_level, best_order = r, 1
    best_f, best_q = _corridor(x, tol, steps[r])
    for level in range(r, r + 3):
        f, q = _corridor(x, tol, steps[level])
        gap_bits = 0.0
        for i in range(1, f.shape[0]):
            gap_bits += math.log2(f[i] - f[i - 1])
        for order in (1, 2):
            bits = residual_cost(f, q, order) + q.size + gap_bits
            if bits < best_bits:
                best_bits, best_level, best_order, best_f, best_q = bits, level, order, f, q
    return best_level, best_order, best_f, best_q
