"""CPLR: connected piecewise linear regression, O(1) time and memory per sample.

Grützmacher et al., Sensors 2018 (ref. [16] of the fastSW paper), as summarised in Section 2 of the
fastSW paper. Each segment is a least-squares line *without intercept* through the last segment
point (the anchor), so consecutive segments connect. With ``t_j, y_dj`` relative to the anchor and
running means ``mean(t²)``, ``mean(t·y_d)``, ``mean(y_d²)`` (updated as Eq. 10–12 of the fastSW
paper), the regression slope is ``β_d = mean(t·y_d) / mean(t²)`` and the segment SSR is

    SSR_n = n · Σ_d ( mean(y_d²) − mean(t·y_d)² / mean(t²) ),

which is Eq. 13 with ``β_d`` resolved (fastSW paper, note after Eq. 13). When adding ``s_n`` would
make the SSR exceed the threshold, the segment ends at the time of ``s_{n-1}`` at the value of its
regression line (an extrapolated point, generally not a sample and not unit length); that point is
the anchor of the next segment, which starts with ``s_n``. A one-sample segment is always accepted.

State: ``sc = [t_anchor, t_prev, mean(t²), n]``, ``av`` (anchor), ``tym``, ``y2m``. Calling
convention as in :mod:`mocapkit.pla.fastsw` (the emitted point is the new anchor).
"""

from __future__ import annotations

import numba
import numpy as np


def new_state(dim: int) -> tuple[np.ndarray, ...]:
    return np.zeros(4), np.zeros(dim), np.zeros(dim), np.zeros(dim)


@numba.njit(cache=True, inline="always")
def start(sc, av, tym, y2m, t, x) -> None:
    sc[0] = t
    sc[1] = t
    sc[2] = 0.0
    sc[3] = 0.0
    for d in range(x.shape[0]):
        av[d] = x[d]
        tym[d] = 0.0
        y2m[d] = 0.0


@numba.njit(cache=True, inline="always")
def _restart(sc, av, tym, y2m, t, x) -> None:
    """``s_n`` as the only sample of a new segment anchored at ``(sc[0], av)``."""
    tn = t - sc[0]
    sc[2] = tn * tn
    for d in range(x.shape[0]):
        y = x[d] - av[d]
        tym[d] = tn * y
        y2m[d] = y * y
    sc[1] = t
    sc[3] = 1.0


@numba.njit(cache=True, inline="always")
def _end(sc, av, tym) -> None:
    """Move the anchor to the segment's regression line at ``t_prev``."""
    tp = sc[1] - sc[0]
    for d in range(av.shape[0]):
        av[d] = av[d] + tym[d] / sc[2] * tp
    sc[0] = sc[1]


@numba.njit(cache=True, inline="always")
def step(sc, av, tym, y2m, t, x, th, maxlen) -> bool:
    D = x.shape[0]
    n = sc[3] + 1.0
    tn = t - sc[0]
    rn = 1.0 / n
    t2 = sc[2] + (tn * tn - sc[2]) * rn
    ok = maxlen <= 0 or n <= maxlen
    if ok and n > 1.0:
        ssr = 0.0
        for d in range(D):
            y = x[d] - av[d]
            ty = tym[d] + (tn * y - tym[d]) * rn
            y2 = y2m[d] + (y * y - y2m[d]) * rn
            ssr += (y2 - ty * ty / t2) * n
        ok = ssr <= th
    if ok:
        sc[2] = t2
        for d in range(D):
            y = x[d] - av[d]
            tym[d] = tym[d] + (tn * y - tym[d]) * rn
            y2m[d] = y2m[d] + (y * y - y2m[d]) * rn
        sc[1] = t
        sc[3] = n
        return False
    _end(sc, av, tym)
    _restart(sc, av, tym, y2m, t, x)
    return True


@numba.njit(cache=True)
def flush(sc, av, tym, y2m) -> bool:
    if sc[3] <= 0.0:
        return False
    _end(sc, av, tym)
    sc[3] = 0.0
    return True


@numba.njit(cache=True)
def batch(t, X, th, maxlen):
    """Whole-array CPLR; returns ``(indices, values)`` of the segment points."""
    N, D = X.shape
    idx = np.empty(N, dtype=np.int64)
    vals = np.empty((N, D))
    if N == 0:
        return idx, vals
    sc = np.zeros(4)
    av = np.zeros(D)
    tym = np.zeros(D)
    y2m = np.zeros(D)
    start(sc, av, tym, y2m, t[0], X[0])
    idx[0] = 0
    vals[0] = av
    m = 1
    for i in range(1, N):
        if step(sc, av, tym, y2m, t[i], X[i], th, maxlen):
            idx[m] = i - 1
            vals[m] = av
            m += 1
    if flush(sc, av, tym, y2m):
        idx[m] = N - 1
        vals[m] = av
        m += 1
    return idx[:m], vals[:m]
