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

State: ``fs = [t_anchor, t_prev, q_anchor(4, normalised), q_prev(4, as given)]``,
``st = [n, prev_index, anchor_index, last_failed_j]`` and a buffer ``bt (cap,)``, ``bq (cap, 4)``
of normalised samples after the anchor.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.quat import _angle_between, _slerp_unit


def new_state(capacity: int):
    return (
        np.zeros(10),
        np.array([-1, -1, -1, 0], dtype=np.int64),
        np.empty(capacity),
        np.empty((capacity, 4)),
    )


@numba.njit(cache=True)
def _segment_ok(fs, bt, bq, m, t, qn, thr, first) -> int:
    """Return -1 when every buffered sample is within ``thr`` radians, else the failing index."""
    qa = fs[2:6]
    tot = t - fs[0]
    tmp = np.empty(4)
    if first >= 0 and first < m:
        f = (bt[first] - fs[0]) / tot
        _slerp_unit(qa, qn, f, tmp)
        if _angle_between(bq[first, 0], bq[first, 1], bq[first, 2], bq[first, 3],
                          tmp[0], tmp[1], tmp[2], tmp[3]) > thr:
            return first
    for j in range(m):
        f = (bt[j] - fs[0]) / tot
        _slerp_unit(qa, qn, f, tmp)
        if _angle_between(bq[j, 0], bq[j, 1], bq[j, 2], bq[j, 3], tmp[0], tmp[1], tmp[2], tmp[3]) > thr:
            return j
    return -1


@numba.njit(cache=True)
def step(fs, st, bt, bq, t, x, idx, thr, maxlen, out) -> int:
    """``thr`` is the bound in radians; ``x`` a quaternion (any norm, hemisphere-continuous)."""
    nrm = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    qn = np.empty(4)
    for d in range(4):
        qn[d] = x[d] / nrm
    n = st[0]
    if n < 0:
        fs[0] = t
        fs[1] = t
        for d in range(4):
            fs[2 + d] = qn[d]
            fs[6 + d] = x[d]
            out[d] = x[d]
        st[0] = 0
        st[1] = idx
        st[2] = idx
        st[3] = -1
        return idx
    n += 1
    ok = maxlen <= 0 or n <= maxlen
    if ok and n > 1:
        fail = _segment_ok(fs, bt, bq, n - 1, t, qn, thr, st[3])
        if fail >= 0:
            ok = False
            st[3] = fail
    if ok:
        bt[n - 1] = t
        for d in range(4):
            bq[n - 1, d] = qn[d]
            fs[6 + d] = x[d]
        fs[1] = t
        st[0] = n
        st[1] = idx
        return -1
    emitted = st[1]
    fs[0] = fs[1]
    nrm = math.sqrt(fs[6] * fs[6] + fs[7] * fs[7] + fs[8] * fs[8] + fs[9] * fs[9])
    for d in range(4):
        out[d] = fs[6 + d]
        fs[2 + d] = fs[6 + d] / nrm
        fs[6 + d] = x[d]
        bq[0, d] = qn[d]
    bt[0] = t
    fs[1] = t
    st[0] = 1
    st[1] = idx
    st[2] = emitted
    st[3] = -1
    return emitted


@numba.njit(cache=True)
def flush(fs, st, out) -> int:
    if st[0] <= 0 or st[1] == st[2]:
        return -1
    for d in range(4):
        out[d] = fs[6 + d]
    st[2] = st[1]
    st[0] = 0
    return st[1]


@numba.njit(cache=True)
def batch(t, X, thr, maxlen):
    """Whole-array angle-bounded SW (``thr`` in radians); returns segment point indices."""
    N = X.shape[0]
    fs = np.zeros(10)
    st = np.array([-1, -1, -1, 0], dtype=np.int64)
    bt = np.empty(max(N, 1))
    bq = np.empty((max(N, 1), 4))
    out = np.empty(4)
    idx = np.empty(N, dtype=np.int64)
    m = 0
    for i in range(N):
        e = step(fs, st, bt, bq, t[i], X[i], i, thr, maxlen, out)
        if e >= 0:
            idx[m] = e
            m += 1
    e = flush(fs, st, out)
    if e >= 0:
        idx[m] = e
        m += 1
    return idx[:m]
