"""Offline optimum for a guaranteed maximum angle: the fewest segment points, drawn from the
samples, such that every sample is within the bound of the SLERP decode.

A shortest path over the DAG of valid segments ``(a, e)``, ``e − a ≤ L`` (the min-# problem of
Imai and Iri, with the decoder's own error as the criterion). Each candidate segment is checked
exactly, every sample in it, so the cost is O(n·L²) — for files, not for a sensor: the online
``anglesw`` stays within a few percent of it (see the README).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.motion import Signal
from mocapkit.pla.base import MAX_SEGMENT_LENGTH_LIMIT, Compressed, prepared_values
from mocapkit.quat import _angle_between, _slerp_unit

DEFAULT_MAX_SEGMENT_LENGTH = 200


@numba.njit(cache=True)
def _optimal_indices(t, Q, thr, L):
    n = Q.shape[0]
    INF = 1 << 60
    cost = np.full(n, INF, dtype=np.int64)
    prev = np.full(n, -1, dtype=np.int64)
    cost[0] = 1
    tmp = np.empty(4)
    for a in range(n - 1):
        if cost[a] == INF:
            continue
        qa = Q[a]
        for e in range(a + 1, min(n, a + L + 1)):
            if cost[a] + 1 >= cost[e]:
                continue
            ok = True
            tot = t[e] - t[a]
            for j in range(a + 1, e):
                _slerp_unit(qa, Q[e], (t[j] - t[a]) / tot, tmp)
                if _angle_between(Q[j, 0], Q[j, 1], Q[j, 2], Q[j, 3], tmp[0], tmp[1], tmp[2], tmp[3]) > thr:
                    ok = False
                    break
            if ok:
                cost[e] = cost[a] + 1
                prev[e] = a
    m = cost[n - 1]
    idx = np.empty(m, dtype=np.int64)
    k = n - 1
    for i in range(m - 1, -1, -1):
        idx[i] = k
        k = prev[k]
    return idx


def optimal_max_angle(signal: Signal, max_angle_deg: float, max_segment_length: int | None = None) -> Compressed:
    """The fewest sample points keeping every sample within ``max_angle_deg`` of the SLERP decode."""
    if signal.kind != "quaternion":
        raise InvalidParameterError("the offline optimum works on quaternion signals only")
    L = DEFAULT_MAX_SEGMENT_LENGTH if max_segment_length is None else int(max_segment_length)
    if not 1 <= L <= MAX_SEGMENT_LENGTH_LIMIT:
        raise InvalidParameterError(
            f"max segment length must be an integer in 1..{MAX_SEGMENT_LENGTH_LIMIT}, got {max_segment_length!r}")
    X = prepared_values(signal)
    Q = X / np.linalg.norm(X, axis=1, keepdims=True)
    idx = _optimal_indices(signal.times, Q, math.radians(max_angle_deg), L)
    return Compressed("optimal", float(max_angle_deg), L, "quaternion", len(signal),
                      idx, signal.times[idx], signal.values[idx])
