"""Angle-bounded sliding window: every sample within a maximum angle of the SLERP reconstruction.

Not in the fastSW paper; mocapkit's answer to "``--max-angle DEG``". Like SW/fastSW the segment
points are original samples (so they stay unit quaternions and decode by SLERP). A segment runs from
the anchor ``q_a`` (the last segment point) to the newest sample ``q_n``. It is accepted while every
buffered sample ``q_j`` (``a < j < n``) lies within ``θ_max`` of ``slerp(q_a, q_n, f_j)`` with
``f_j = (t_j − t_a)/(t_n − t_a)`` — exactly the reconstruction the decoder will produce — using the
rotation angle of Eq. 2. Otherwise ``s_{n-1}`` becomes a segment point (greedy, online).

Work per sample is O(n) with ``n`` the current segment length; with a maximum segment length ``L``
it is bounded by ``L`` SLERP evaluations per sample, and memory by ``L`` buffered samples. The
check stops at the first violating sample, and the sample that failed last time is checked first
(the error usually grows where it was already large), so rejected candidates cost O(1) in practice.

State: ``sc = [t_anchor, t_prev, n, last_failed_j]``, ``qa`` (normalised anchor), ``qp``
(normalised previous sample), ``qn``, ``tmp`` (scratch) and a buffer ``bt (cap,)``, ``bq (cap, 4)`` of the
normalised samples after the anchor. Calling convention as in :mod:`mocapkit.pla.fastsw`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.quat import _angle_between, _slerp_unit


def new_state(capacity: int) -> tuple[np.ndarray, ...]:
    return np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4), np.empty(capacity), np.empty((capacity, 4))


@numba.njit(cache=True, inline="always")
def _deviation(sc, qa, tmp, bt, bq, j, t, qn) -> float:
    f = (bt[j] - sc[0]) / (t - sc[0])
    _slerp_unit(qa, qn, f, tmp)
    return _angle_between(bq[j, 0], bq[j, 1], bq[j, 2], bq[j, 3], tmp[0], tmp[1], tmp[2], tmp[3])


@numba.njit(cache=True, inline="always")
def _normalised(x, q) -> None:
    nrm = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for d in range(4):
        q[d] = x[d] / nrm


@numba.njit(cache=True, inline="always")
def start(sc, qa, qp, qn, tmp, bt, bq, t, x) -> None:
    _normalised(x, qa)
    _normalised(x, qp)
    sc[0] = t
    sc[1] = t
    sc[2] = 0.0
    sc[3] = -1.0


@numba.njit(cache=True, inline="always")
def step(sc, qa, qp, qn, tmp, bt, bq, t, x, thr, maxlen) -> bool:
    """``thr`` in radians; ``x`` a quaternion (any norm, hemisphere-continuous).

    ``True`` when ``s_{n-1}`` became a segment point. The buffer must hold ``n`` samples.
    """
    n = int(sc[2]) + 1
    _normalised(x, qn)
    ok = maxlen <= 0 or n <= maxlen
    if ok and n > 1:
        first = int(sc[3])
        if first >= 0 and first < n - 1 and _deviation(sc, qa, tmp, bt, bq, first, t, qn) > thr:
            ok = False
        else:
            for j in range(n - 1):
                if _deviation(sc, qa, tmp, bt, bq, j, t, qn) > thr:
                    ok = False
                    sc[3] = j
                    break
    if ok:
        bt[n - 1] = t
        for d in range(4):
            bq[n - 1, d] = qn[d]
            qp[d] = qn[d]
        sc[1] = t
        sc[2] = n
        return False
    sc[0] = sc[1]
    for d in range(4):
        qa[d] = qp[d]
        qp[d] = qn[d]
        bq[0, d] = qn[d]
    bt[0] = t
    sc[1] = t
    sc[2] = 1.0
    sc[3] = -1.0
    return True


@numba.njit(cache=True)
def flush(sc, qa, qp, qn, tmp, bt, bq) -> bool:
    if sc[2] <= 0.0:
        return False
    sc[0] = sc[1]
    for d in range(4):
        qa[d] = qp[d]
    sc[2] = 0.0
    return True


@numba.njit(cache=True)
def batch(t, X, thr, maxlen):
    """Whole-array angle-bounded SW (``thr`` in radians); returns segment point indices."""
    N = X.shape[0]
    idx = np.empty(N, dtype=np.int64)
    if N == 0:
        return idx
    sc = np.zeros(4)
    qa = np.zeros(4)
    qp = np.zeros(4)
    qn = np.zeros(4)
    tmp = np.zeros(4)
    bt = np.empty(N)
    bq = np.empty((N, 4))
    start(sc, qa, qp, qn, tmp, bt, bq, t[0], X[0])
    idx[0] = 0
    m = 1
    for i in range(1, N):
        if step(sc, qa, qp, qn, tmp, bt, bq, t[i], X[i], thr, maxlen):
            idx[m] = i - 1
            m += 1
    if flush(sc, qa, qp, qn, tmp, bt, bq):
        idx[m] = N - 1
        m += 1
    return idx[:m]
