"""How good is the online angle-bounded encoder? Compare it with the offline optimum and with the
paper's methods tuned to the same maximum angle.

The offline optimum is the fewest segment points, drawn from the samples, such that every sample is
within the bound of the SLERP decode — a shortest path over the DAG of valid segments
``(a, e)``, ``e − a ≤ L`` (Imai–Iri's min-# problem with the decoder's own error). Each candidate
segment is checked exactly (every sample in it), so the cost is O(n·L²): an evaluation tool, not an
encoder.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.motion import Signal
from mocapkit.pla import compress_to, evaluate
from mocapkit.pla.base import Compressed, prepared_values
from mocapkit.quat import _angle_between, _slerp_unit


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


def optimal_max_angle(signal: Signal, max_angle_deg: float, max_segment_length: int = 200) -> Compressed:
    """The fewest sample points keeping every sample within ``max_angle_deg`` of the SLERP decode."""
    X = prepared_values(signal)
    Q = X / np.linalg.norm(X, axis=1, keepdims=True)
    idx = _optimal_indices(signal.times, Q, math.radians(max_angle_deg), int(max_segment_length))
    return Compressed("optimal", float(max_angle_deg), max_segment_length, "quaternion", len(signal),
                      idx, signal.times[idx], signal.values[idx])


def compare(signals: dict[str, Signal], angles=(0.5, 1.0, 2.0, 5.0), max_segment_length: int = 200) -> list[dict]:
    """Points needed at each bound: optimum, anglesw (online), and each paper method tuned."""
    rows = []
    for deg in angles:
        tot = {"max_angle_deg": deg, "n_samples": sum(len(s) for s in signals.values())}
        worst = {}
        for name, sig in signals.items():
            runs = {"optimal": optimal_max_angle(sig, deg, max_segment_length)}
            for m in ("anglesw", "fastsw", "cplr", "swing"):
                runs[m] = compress_to(sig, m, max_angle=deg, max_segment_length=max_segment_length)
            for m, c in runs.items():
                tot[m] = tot.get(m, 0) + c.n_points
                worst[m] = max(worst.get(m, 0.0), evaluate(sig, c).max_deg)
        for m, w in worst.items():
            tot[f"{m}_max_deg"] = w
        rows.append(tot)
    return rows
