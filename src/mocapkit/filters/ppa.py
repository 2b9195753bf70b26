"""The seed report's iterative knot algorithm (Lippi, Avizzano, Ruffaldi), Section 2.3, steps i–xii.

i–iii: order ``O``, penalty ``K`` and an initial knot set (a knot every ``init_chunk`` samples);
iv–v: fit every chunk independently (discontinuous at knots) and compute ``L = sqrt(SSR) + K·N_k``
(Eq. 2); vi–vii: for each knot, left to right, remove it if that lowers ``L``; viii–ix: for each chunk
(those present when the pass starts), split it if that lowers ``L`` — at the split point that
minimises the two halves' SSR (the report does not say where to split; the best point is the natural
reading and is found exactly by one forward and one backward QR scan); x: for each knot, move it to the
position between its neighbours that minimises the SSR of the two adjacent chunks (the current position
is a candidate, so ``L`` cannot grow); xi–xii: repeat until the improvement of ``L`` over a whole
iteration is below ``tol``. Every chunk keeps at least ``O + 1`` valid samples. The result is a local
optimum; :func:`mocapkit.filters.exact.solve_exact` gives the global one.

Extensions the report lists as future work: real timestamps (polynomials in seconds), vector signals
with knots shared by all components (the SSR is summed over components), and NaN samples left out of
the fits (:func:`mocapkit.filters.fit` also cuts the signal at long gaps).
"""

from __future__ import annotations

import math

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.chunks import PiecewisePolynomial, as_2d, build, chunk_ssr, ssr_scan


def _best_split(t, Y, a, b, order):
    """Best split point ``s`` of ``[a, b)`` and the two halves' SSR (``None`` if too short)."""
    p = order + 1
    fwd, cf = ssr_scan(t, Y, a, b, order, True)  # fwd[m] = SSR[a, a+m)
    bwd, cb = ssr_scan(t, Y, a, b, order, False)  # bwd[m] = SSR[b-m, b)
    n = b - a
    best = (None, math.inf)
    for m in range(1, n):
        if cf[m] < p or cb[n - m] < p:
            continue
        v = fwd[m] + bwd[n - m]
        if v < best[1]:
            best = (a + m, v)
    return best


def fit_iterative(t, y, order: int = 2, penalty: float = 1.0, init_chunk: int | None = None,
                  tol: float = 1e-9, max_iter: int = 200) -> tuple[PiecewisePolynomial, list[float]]:
    """Run the iterative algorithm; return the result and the loss after every pass.

    Parameters
    ----------
    t, y
        Times in seconds (strictly increasing) and values ``(N,)`` or ``(N, D)``.
    order
        Polynomial order ``O`` of every chunk (step i).
    penalty
        ``K`` (step ii), in the units of ``sqrt(SSR)``, i.e. of the signal.
    init_chunk
        Samples per chunk of the initial knot set (step iii); default ``max(10·(O+1), N/20)``.
    tol
        Stop when an iteration improves ``L`` by less than this (step xi).
    """
    t, Y = as_2d(t, y)
    n = t.shape[0]
    p = order + 1
    if order < 0 or not (penalty >= 0 and math.isfinite(penalty)):
        raise InvalidParameterError("order must be >= 0 and the penalty a finite number >= 0")
    if int((~np.isnan(Y).any(axis=1)).sum()) < p:
        raise InvalidParameterError(f"need at least {p} valid samples for order {order}")
    if init_chunk is None:
        init_chunk = max(10 * p, n // 20)
    if init_chunk < p:
        raise InvalidParameterError(f"the initial chunk must hold at least order+1 = {p} samples")
    valid = np.concatenate([[0], np.cumsum(~np.isnan(Y).any(axis=1))])

    def nvalid(a, b):
        return int(valid[b] - valid[a])

    knots = [0]
    for k in range(init_chunk, n, init_chunk):
        if nvalid(knots[-1], k) >= p and nvalid(k, n) >= p:
            knots.append(k)
    knots.append(n)
    ssr = [chunk_ssr(t, Y, a, b, order) for a, b in zip(knots[:-1], knots[1:], strict=True)]

    def loss(total, nk):
        return math.sqrt(max(total, 0.0)) + penalty * nk

    L = loss(sum(ssr), len(knots) - 2)
    history = [L]
    for _ in range(max_iter):
        L_start = L
        # vi. remove
        i = 1
        while i < len(knots) - 1:
            a, k, c = knots[i - 1], knots[i], knots[i + 1]
            merged = chunk_ssr(t, Y, a, c, order)
            total = sum(ssr) - ssr[i - 1] - ssr[i] + merged
            cand = loss(total, len(knots) - 3)
            if cand < L:
                del knots[i]
                ssr[i - 1:i + 1] = [merged]
                L = cand
            else:
                i += 1
        history.append(L)
        # viii. split (the chunks present at the start of the pass)
        i = 0
        while i < len(knots) - 1:
            a, b = knots[i], knots[i + 1]
            s, v = _best_split(t, Y, a, b, order)
            if s is not None:
                total = sum(ssr) - ssr[i] + v
                cand = loss(total, len(knots) - 1)
                if cand < L:
                    knots.insert(i + 1, s)
                    ssr[i:i + 1] = [chunk_ssr(t, Y, a, s, order), chunk_ssr(t, Y, s, b, order)]
                    L = loss(sum(ssr), len(knots) - 2)
                    i += 2
                    continue
            i += 1
        history.append(L)
        # x. move
        for i in range(1, len(knots) - 1):
            a, c = knots[i - 1], knots[i + 1]
            s, v = _best_split(t, Y, a, c, order)
            if s is not None and v < ssr[i - 1] + ssr[i]:
                knots[i] = s
                ssr[i - 1], ssr[i] = chunk_ssr(t, Y, a, s, order), chunk_ssr(t, Y, s, c, order)
        L = loss(sum(ssr), len(knots) - 2)
        history.append(L)
        # xi. stop
        if abs(L_start - L) < tol:
            break
    return build(t, Y, knots, order, penalty), history
