"""The exact optimum of the seed report's loss, ``sqrt(SSR) + K·N_k`` (Eq. 2).

Chunks are independent, so for every number of interior knots ``k`` the least SSR of the first ``e``
samples, ``C[k][e] = min_s C[k-1][s] + SSR[s, e)``, is a segment-neighbourhood dynamic programme; the
global optimum is the best ``k`` on the final column (the loss is not additive in ``SSR``, so a single
penalised pass such as PELT would only find the convex hull of the ``SSR(k)`` curve).

Exact pruning, given an incumbent loss ``L*`` (the iterative algorithm's, so the result is never worse
than it): a state with ``sqrt(C[k][e]) + K·k > L*`` cannot complete to a better solution (SSR only
grows, knots only add), so it is dropped; therefore ``k ≤ L*/K`` and, scanning chunk starts ``s``
backwards from ``e`` (with the chunk SSR updated by one Givens rotation per sample), the scan stops
once ``SSR[s, e) ≥ max_k (L* − K·k)²``. Every chunk must hold at least ``O + 1`` valid samples.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.chunks import PiecewisePolynomial, _add_sample, as_2d, build


@numba.njit(cache=True)
def _dp(t, Y, order, K, L_star, kmax):
    n = t.shape[0]
    D = Y.shape[1]
    p = order + 1
    INF = np.inf
    C = np.full((kmax + 1, n + 1), INF)
    arg = np.full((kmax + 1, n + 1), -1, dtype=np.int64)
    # limits (L* - K k)^2 per level: a state above it cannot beat the incumbent
    lim = np.empty(kmax + 1)
    for k in range(kmax + 1):
        r = L_star - K * k
        lim[k] = r * r if r > 0 else -1.0
    R = np.zeros((p, p))
    qy = np.zeros((p, D))
    rss = np.zeros(D)
    x = np.empty(p)
    y = np.empty(D)
    lim_max = 0.0  # for a chunk starting after sample 0 there is at least one knot: lim[1]
    for k in range(1, kmax + 1):
        if lim[k] > lim_max:
            lim_max = lim[k]
    # k = 0: the single chunk [0, e), by one forward scan
    cnt = 0
    span = t[n - 1] - t[0]
    if span <= 0.0:
        span = 1.0
    for e in range(1, n + 1):
        if _add_sample(t, Y, e - 1, t[0], span, R, qy, x, y, rss, p, D):
            cnt += 1
        if cnt >= p:
            ssr = 0.0
            for d in range(D):
                ssr += rss[d]
            bound0 = lim[0] if e == n else (lim[1] if kmax >= 1 else -1.0)
            if ssr <= bound0:
                C[0, e] = ssr
                arg[0, e] = 0
    for e in range(1, n + 1):
        # scan chunk starts s = e-1, e-2, ... with the SSR of [s, e) updated one row at a time
        R[:, :] = 0.0
        qy[:, :] = 0.0
        rss[:] = 0.0
        cnt = 0
        t0 = t[e - 1]
        span = t[e - 1] - t[0]
        if span <= 0.0:
            span = 1.0
        for s in range(e - 1, -1, -1):
            if _add_sample(t, Y, s, t0, span, R, qy, x, y, rss, p, D):
                cnt += 1
            if cnt < p:
                continue
            ssr = 0.0
            for d in range(D):
                ssr += rss[d]
            if ssr > lim_max:
                break
            # a state before the end (e < n) will need at least one more knot: its bound is lim[k+1]
            if s == 0:
                continue  # the single chunk [0, e) comes from the forward scan above
            for k in range(1, kmax + 1):
                prev = C[k - 1, s]
                if prev == INF:
                    continue
                c = prev + ssr
                bound = lim[k] if e == n else (lim[k + 1] if k < kmax else -1.0)
                if c <= bound and c < C[k, e]:
                    C[k, e] = c
                    arg[k, e] = s
    return C, arg


def solve_exact(t, y, order: int = 2, penalty: float = 1.0, incumbent: PiecewisePolynomial | None = None,
                max_knots: int | None = None) -> PiecewisePolynomial:
    """Global optimum of ``sqrt(SSR) + K·N_k`` over all knot sets (chunks ≥ ``order+1`` samples).

    Parameters
    ----------
    t, y
        Times (seconds, strictly increasing) and values ``(N,)`` or ``(N, D)`` (shared knots; NaN rows
        are left out of the fits).
    incumbent
        A known solution (e.g. from :func:`mocapkit.filters.ppa.fit_iterative`); its loss bounds the
        search. Without one, the single-chunk fit is used.
    """
    t, Y = as_2d(t, y)
    if order < 0 or penalty < 0 or not math.isfinite(penalty):
        raise InvalidParameterError("order must be >= 0 and the penalty a finite number >= 0")
    n = t.shape[0]
    valid = int((~np.isnan(Y).any(axis=1)).sum())
    if valid < order + 1:
        raise InvalidParameterError(f"need at least {order + 1} valid samples for order {order}")
    if incumbent is None:
        incumbent = build(t, Y, [], order, penalty)
    L_star = incumbent.loss * (1 + 1e-12) + 1e-300
    cap = n // (order + 1) - 1
    # L*/K may overflow to inf for a tiny (denormal) K: compare as floats before converting
    kmax = cap if penalty == 0 or L_star / penalty >= cap else min(cap, int(L_star / penalty) + 1)
    if max_knots is not None:
        kmax = min(kmax, int(max_knots))
    kmax = max(kmax, 0)
    C, arg = _dp(t, Y, order, float(penalty), float(L_star), kmax)
    last = C[:, n]
    losses = np.sqrt(np.maximum(last, 0.0)) + penalty * np.arange(kmax + 1)
    if not np.isfinite(losses).any() or losses.min() > incumbent.loss:
        return incumbent
    k = int(np.argmin(losses))
    knots = [n]
    e = n
    for level in range(k, -1, -1):
        s = int(arg[level, e])
        knots.append(s)
        e = s
    return build(t, Y, sorted(knots), order, penalty)


def ssr_curve(t, y, order: int = 2, max_knots: int = 20) -> np.ndarray:
    """Least SSR for ``k = 0..max_knots`` interior knots (no pruning by an incumbent)."""
    t, Y = as_2d(t, y)
    C, _ = _dp(t, Y, order, 0.0, np.inf, int(max_knots))
    return C[:, t.shape[0]]
