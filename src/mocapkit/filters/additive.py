"""The exact optimum of the additive knot cost ``SSR + λ·N_k`` (PELT).

Eq. 2 of the seed report, ``sqrt(SSR) + K·N_k``, couples all chunks through the square root; the
additive form ``SSR + λ·N_k`` does not, so its optimum is an optimal-partitioning recursion
``F(e) = min_s F(s) + SSR[s, e) + λ`` (``F(0) = −λ``: the first chunk carries no knot), solved exactly
with PELT's pruning (Killick, Fearnhead and Eckley 2012): the SSR of least-squares polynomial fits is
superadditive, ``SSR[s, e') ≥ SSR[s, e) + SSR[e, e')``, so a start ``s`` with ``F(s) + SSR[s, e) > F(e)``
can never again be optimal — once at least ``m`` valid samples follow ``e`` (``m``, the shortest chunk
allowed, is ``O + 1`` by default; the automatic mode asks for ``O + 2``, see
:mod:`mocapkit.filters.penalty`). Every candidate start keeps its own QR factorisation, updated by one Givens rotation
per sample (as in :mod:`mocapkit.filters.chunks`); work is O(n·L·O²) with L the typical chunk length, O(n²)
for a signal without any knot.

Used by the automatic mode (:mod:`mocapkit.filters.penalty`): a penalty in SSR units is the same
for a short and a long recording, and a take twice as long gets the same knots per cycle.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.chunks import PiecewisePolynomial, as_2d, build


@numba.njit(cache=True)
def _pelt(t, Y, order, lam, scale, msize):
    n = t.shape[0]
    D = Y.shape[1]
    p = order + 1
    valid = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        ok = True
        for d in range(D):
            if Y[i, d] != Y[i, d]:
                ok = False
        valid[i + 1] = valid[i] + (1 if ok else 0)
    F = np.full(n + 1, np.inf)
    F[0] = -lam
    arg = np.full(n + 1, -1, dtype=np.int64)
    # candidate starts, each with its own QR state (R: p*p, qy: p*D, rss: D; compacted in place)
    cs = np.empty(n + 1, dtype=np.int64)
    death = np.empty(n + 1, dtype=np.int64)  # first e at which the prune condition held (-1: never)
    W = p * p + p * D + D
    S = np.zeros((n + 1, W))
    ssr_c = np.zeros(n + 1)
    x = np.empty(p)
    y = np.empty(D)
    cs[0] = 0
    death[0] = -1
    m = 1
    oq = p * p
    orss = p * p + p * D
    for e in range(1, n + 1):
        i = e - 1
        ok = valid[e] > valid[e - 1]
        best = np.inf
        barg = -1
        for c in range(m):
            s = cs[c]
            st = S[c]
            if ok:
                tau = (t[i] - t[s]) / scale
                v = 1.0
                for j in range(p):
                    x[j] = v
                    v *= tau
                for d in range(D):
                    y[d] = Y[i, d]
                # Givens update of this candidate's QR with the row (x, y)
                for a in range(p):
                    xa = x[a]
                    if xa == 0.0:
                        continue
                    raa = st[a * p + a]
                    r = math.sqrt(raa * raa + xa * xa)
                    cc = raa / r
                    sn = xa / r
                    st[a * p + a] = r
                    for b in range(a + 1, p):
                        u = st[a * p + b]
                        w = x[b]
                        st[a * p + b] = cc * u + sn * w
                        x[b] = -sn * u + cc * w
                    for d in range(D):
                        u = st[oq + a * D + d]
                        w = y[d]
                        st[oq + a * D + d] = cc * u + sn * w
                        y[d] = -sn * u + cc * w
                tot = 0.0
                for d in range(D):
                    st[orss + d] += y[d] * y[d]
                    tot += st[orss + d]
                ssr_c[c] = tot
            if valid[e] - valid[s] >= msize:
                val = F[s] + ssr_c[c] + lam
                if val < best:
                    best = val
                    barg = s
        F[e] = best
        arg[e] = barg
        # prune: F(s) + SSR[s, e) > F(e), effective once msize valid samples follow that e
        k = 0
        for c in range(m):
            keep = True
            if death[c] >= 0:
                if valid[e] - valid[death[c]] >= msize:
                    keep = False
            elif best < np.inf and valid[e] - valid[cs[c]] >= msize and F[cs[c]] + ssr_c[c] > best:
                death[c] = e
            if keep:
                if k != c:
                    cs[k] = cs[c]
                    death[k] = death[c]
                    ssr_c[k] = ssr_c[c]
                    S[k, :] = S[c, :]
                k += 1
        m = k
        # e becomes a candidate start (if the samples before it can be chunked)
        if e < n and F[e] < np.inf:
            cs[m] = e
            death[m] = -1
            ssr_c[m] = 0.0
            S[m, :] = 0.0
            m += 1
    return F, arg


def solve_additive(t, y, order: int = 2, knot_cost: float = 1.0, penalty: float | None = None,
                   min_size: int | None = None) -> PiecewisePolynomial:
    """Global optimum of ``SSR + λ·N_k`` (``λ = knot_cost``, in squared signal units) over all knot
    sets whose chunks hold at least ``min_size`` valid samples (default and least ``order + 1``; a
    signal with fewer than ``min_size`` but at least ``order + 1`` valid samples is one chunk).

    The returned :class:`PiecewisePolynomial` carries ``penalty`` (Eq. 2's ``K`` used for its
    ``loss``; default ``λ / (2·sqrt(SSR))``, the ``K`` whose trade-off equals ``λ`` at this solution).
    """
    t, Y = as_2d(t, y)
    if order < 0 or not (knot_cost >= 0 and math.isfinite(knot_cost)):
        raise InvalidParameterError("order must be >= 0 and the knot cost a finite number >= 0")
    n = t.shape[0]
    nv = int((~np.isnan(Y).any(axis=1)).sum())
    if nv < order + 1:
        raise InvalidParameterError(f"need at least {order + 1} valid samples for order {order}")
    msize = order + 1 if min_size is None else int(min_size)
    if msize < order + 1:
        raise InvalidParameterError(f"min_size must be >= order + 1 = {order + 1}, got {min_size!r}")
    msize = min(msize, nv)
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    F, arg = _pelt(t, Y, order, float(knot_cost), 64.0 * dt, msize)
    if not np.isfinite(F[n]):
        raise InvalidParameterError(f"no chunking with {msize} valid samples per chunk")
    knots = [n]
    e = n
    while e > 0:
        e = int(arg[e])
        knots.append(e)
    pp = build(t, Y, sorted(knots), order, 0.0)
    K = penalty if penalty is not None else (knot_cost / (2.0 * math.sqrt(pp.ssr)) if pp.ssr > 0 else 0.0)
    return PiecewisePolynomial(pp.knots, pp.pieces, pp.order, pp.ssr, float(K))
