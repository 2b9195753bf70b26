"""The automatic knot cost: the segmentation whose weakest knot stands out most from its residual.

Why not a noise model. A penalty derived from the white-noise level (``K = σ̂·(O + 1 + 2 ln n)/√n``)
prices a knot at what it gains on *white noise*. On real recordings the residual of a piecewise
parabola is mostly *model error* — air drag on a ball, a marker wobbling on a hand, a static marker's
slow drift — correlated over tens to hundreds of samples and far above the white noise (σ̂ ≈ 0.03 mm
on the Qualisys juggling take, where a flight deviates from a parabola by millimetres). Priced at the
white noise, every wiggle of that error buys a knot (hundreds per ball, flights cut in pieces, a
static marker's drift cut too).

The cost. Work with the additive form of Eq. 2, ``SSR + λ·N_k`` (solved exactly by
:func:`mocapkit.filters.additive.solve_additive`), ``λ`` in squared signal units. As ``λ`` decreases,
the optimal knot count ``k(λ)`` steps up through the vertices of the lower convex hull of the
least-SSR-versus-knots curve ``S(k)``. Every knot of the optimum at ``λ`` gains at least ``λ``; the
largest ``λ`` at which ``k`` is still optimal is the gain ``g_k`` of its weakest knots.

The criterion: **the knot count whose weakest knot gains the most relative to the residual it
leaves**, ``max_k g_k / σ²_LR(k)``, where ``σ²_LR(k)`` is the long-run variance of the residual of the
``k``-knot fit (:func:`long_run_variance`: its variance times ``(1 + ρ)/(1 − ρ)``, ρ its lag-1
autocorrelation within chunks — an AR(1) model, i.e. the variance per *effective* sample of a
correlated residual). A polynomial piece fitted to residual with long-run variance ``σ²_LR`` gains about
``(O + 1)·σ²_LR`` by chance; ``g_k/σ²_LR`` is the weakest knot's gain in those units — a signal-to-noise
ratio that needs no noise model, because the noise is whatever the fit leaves behind, correlation
included. Fewer knots than the structure needs leave structure in the residual (a large, highly
correlated ``σ²_LR``: low ratio); more knots than it needs are bought by the residual itself (their
gain is a few ``σ²_LR``: low ratio); the ratio peaks at the knee of ``S(k)`` where the structure ends.
``k = 0`` competes with ``S(0)/σ²_LR(0)`` — the effective sample size of the single polynomial's
residual, i.e. what a knot would have to gain to explain everything: white or correlated noise, a
static marker's drift (no structure, a residual of ~white noise: thousands) keep ``k = 0``; a
constant (``S(0) = 0``) gets no knot. A count whose fit leaves no residual at all (a noise-free
piecewise polynomial; ``σ²_LR = 0``) is infinitely significant: the fewest such knots win.

Every chunk keeps a residual degree of freedom. A chunk of exactly ``O + 1`` valid samples is
interpolated: its residual is 0 whatever the data, so it says nothing about the noise and a knot that
creates it would look infinitely significant (six noisy samples of one parabola, cut into two exact
parabolas of three samples each). The automatic mode therefore only considers chunks of at least
``O + 2`` valid samples (``MIN_RESIDUAL_DOF = 1`` per component), the same rule for 1-D and 3-D
signals; a residual of zero then means that the data really are piecewise polynomial. Pieces of
``O + 1`` samples are left to an explicit ``K``. The least count is a necessary condition, not a small
sample test: with fewer than about ``4·(O + 2)`` samples the residual variance of a fit rests on a few
degrees of freedom and a knot may still win by chance. Within the chosen count's exact range of ``λ`` (its two hull
slopes, found by intersection as in CROPS, Haynes, Eckley and Fearnhead 2017) ``λ`` is the geometric
centre: the most robust cost for that segmentation.

What bounds the search. Costs below the white-noise floor ``(O + 1)·D·σ̂²`` (σ̂ from the MAD of the
``(O + 1)``-th differences, :func:`noise_sigma`; or 1e-12 of the signal's magnitude, for rounding) are
not searched. ``k(λ)`` is measured on a geometric grid (factor ``step``, default 2) from the lower end
of ``k = 0``'s range (exact, by Dinkelbach's iteration from the best single knot's gain) down to the
floor: about ``log2(S(0)/floor)`` exact solutions. When knots are closer than about ``2(O + 1)``
samples most differences straddle one and σ̂ is inflated (a noise-free signal with 5-sample pieces);
then the finest fit searched leaves a residual variance (SSR over its degrees of freedom) below σ̂²/4
— on white or AR(1) noise it stays near σ̂² (measured 0.5–0.95) — and the grid goes on down to the
floor of that residual, until it no longer drops by 4. Pieces of 4 samples (O = 2) are still often
missed.

Why it does not depend on the recording's length. Eq. 2's ``sqrt(SSR)`` grows like ``σ√n``, so a
knot that lowers the SSR by ``Δ`` lowers ``sqrt(SSR)`` by about ``Δ/(2σ√n)``: the same ``K`` buys fewer
knots per second in a longer take, and a ``K`` that suits a 10 s take is wrong for a 20 s one. ``λ``
prices the SSR itself, which adds up over chunks, so the knots of one part of the signal do not depend
on how much signal surrounds it; ``g_k`` and ``σ²_LR`` are per-knot and per-sample quantities that do not
change when the same pattern repeats for longer. The ``K`` of Eq. 2 that makes the same trade-off at
the solution, ``K = λ/(2·sqrt(SSR))``, is reported (it does shrink as ``1/√n``, as it must).

Units: ``λ``, the gains and ``σ²_LR`` all scale with the square of the signal's unit; the knots chosen do
not depend on mm versus m. Limits: noise whose correlation time approaches the record's length
(AR(1) with ρ = 0.99 over a few hundred samples) is indistinguishable from slow motion and may get
knots; the test suite checks white noise and AR(1) noise of ρ = 0.9 over 2,000 samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import comb

from mocapkit.filters.additive import solve_additive
from mocapkit.filters.chunks import PiecewisePolynomial, chunk_ssr, ssr_scan


def noise_sigma(y: np.ndarray, order: int = 2) -> float:
    """Robust white-noise level of a piecewise polynomial signal: differencing ``O + 1`` times removes
    every polynomial of order ``O`` and leaves white noise multiplied by ``sqrt(C(2(O+1), O+1))``; the
    MAD of what is left (/0.6745) ignores the few differences that straddle a knot. NaN rows are
    skipped (differences are taken within runs of valid samples only), components are pooled."""
    Y = np.asarray(y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    d = Y
    for _ in range(order + 1):
        d = np.diff(d, axis=0)
    d = d[np.isfinite(d).all(axis=1)].ravel()
    if d.size == 0:
        return 0.0
    return float(np.median(np.abs(d - np.median(d))) / 0.6745 / math.sqrt(comb(2 * (order + 1), order + 1)))


@dataclass(frozen=True)
class KnotCostChoice:
    """The automatic choice: ``knot_cost`` (λ, squared signal units), the knot count it gives, the
    range ``(lo, hi)`` of λ over which that count is optimal, the white-noise floor of the search,
    the solutions per part at ``knot_cost``, the path ``[(λ, knots, SSR)]`` that was measured, and
    the chosen count's ``significance`` (``g_k / σ²_LR``)."""

    knot_cost: float
    n_knots: int
    range: tuple[float, float]
    floor: float
    solutions: tuple[PiecewisePolynomial, ...]
    path: tuple[tuple[float, int, float], ...]
    significance: float = math.inf

    @property
    def ssr(self) -> float:
        return float(sum(s.ssr for s in self.solutions))

    @property
    def penalty(self) -> float:
        """Eq. 2's ``K`` with the same marginal trade-off at the solution: ``λ/(2·sqrt(SSR))``."""
        return self.knot_cost / (2.0 * math.sqrt(self.ssr)) if self.ssr > 0 else 0.0


Parts = Sequence[tuple[np.ndarray, np.ndarray]]


MIN_RESIDUAL_DOF = 1
"""Residual degrees of freedom per component that every chunk keeps in the automatic mode (module
docstring): chunks hold at least ``order + 1 + MIN_RESIDUAL_DOF`` valid samples."""


def _solve(parts: Parts, order: int, lam: float) -> tuple[int, float, tuple[PiecewisePolynomial, ...]]:
    sols = tuple(solve_additive(t, Y, order, lam, min_size=order + 1 + MIN_RESIDUAL_DOF) for t, Y in parts)
    return int(sum(s.n_knots for s in sols)), float(sum(s.ssr for s in sols)), sols


def choose_knot_cost(parts: Parts, order: int = 2, step: float = 2.0) -> KnotCostChoice:
    """The knot cost λ of the segmentation whose weakest knot gains most relative to the long-run
    variance of its residual (module docstring).

    Parameters
    ----------
    parts
        ``[(t (N,), Y (N, D))]``: the gap-free parts of one signal (λ is shared; knots and SSR are
        summed over the parts). Every part must hold at least ``order + 1`` valid samples; every chunk
        of the result holds at least ``order + 1 + MIN_RESIDUAL_DOF`` (a shorter part is one chunk).
    order
        Polynomial order ``O``.
    step
        Factor between neighbouring λ of the search grid (> 1).
    """
    if not step > 1.0:
        raise ValueError("step must be > 1")
    S0 = float(sum(chunk_ssr(t, Y, 0, t.shape[0], order) for t, Y in parts))
    D = parts[0][1].shape[1]
    sig = [noise_sigma(Y, order) for _, Y in parts]
    w = [int(np.isfinite(Y).all(axis=1).sum()) for _, Y in parts]
    sigma2 = float(np.average(np.square(sig), weights=w)) if sum(w) else 0.0
    # below the white noise, or below rounding (1e-12 of the signal's magnitude per sample)
    size = max(float(np.nanmax(np.abs(Y))) if np.isfinite(Y).any() else 0.0 for _, Y in parts)
    rounding = sum(w) * D * (1e-12 * size) ** 2
    floor = max((order + 1) * D * sigma2, rounding)
    cache: dict[float, tuple[int, float, tuple]] = {}

    def solve(lam: float):
        if lam not in cache:
            cache[lam] = _solve(parts, order, lam)
        return cache[lam]

    if S0 <= floor:  # a constant (or a signal below its own noise floor): no knot can pay
        lam = 2.0 * floor if floor > 0 else 1.0
        k, ssr, sols = solve(lam)
        return KnotCostChoice(lam, k, (S0, math.inf), floor, sols, ((lam, k, ssr),))
    # lower end of k = 0's range, lam0 = max_k (S0 - S(k))/k, by Dinkelbach's iteration from the gain
    # of the best single knot (a lower bound of it)
    lam0 = floor
    for t, Y in parts:
        lam0 = max(lam0, chunk_ssr(t, Y, 0, t.shape[0], order) - _best_split_ssr(t, Y, order))
    for _ in range(100):
        k, ssr, _ = solve(lam0)
        if k == 0 or ssr + lam0 * k >= S0 * (1 - 1e-12):
            break
        lam0 = (S0 - ssr) / k
    # grid from lam0 down to the floor, with the knot count each λ really gives: at lam0 that may be
    # k > 0 (a tie with k = 0: all of its knots gain exactly lam0, e.g. two equal steps)
    grid = [(lam0, solve(lam0)[0])]
    lam = lam0 / step
    while True:
        while lam >= floor:
            grid.append((lam, solve(lam)[0]))
            lam /= step
        # σ̂ is inflated when knots are closer than about 2(O + 1) samples (then most (O+1)-th
        # differences straddle one): the finest fit searched shows it by a residual variance far below
        # σ̂², and the search goes on down to the floor of that residual
        _, ssr_f, sols_f = solve(grid[-1][0])
        dof_f = _residual_dof(parts, sols_f)
        fine = max((order + 1) * D * ssr_f / dof_f if dof_f > 0 else 0.0, rounding)
        if not fine < floor / 4.0:
            break
        floor = fine
    top: dict[int, float] = {0: lam0}  # the largest grid λ giving k: about the gain of k's weakest knot
    for la, k in grid:
        top[k] = max(top.get(k, 0.0), la)
    # k = 0 is judged on the residual of the single polynomial: above S0 no knot can pay
    zero = solve(lam0)[2] if grid[0][1] == 0 else solve(2.0 * S0)[2]
    signif = {0: _significance(S0, long_run_variance(parts, zero))}
    for k, la in top.items():
        if k > 0:
            signif[k] = _significance(la, long_run_variance(parts, solve(la)[2]))
    best = max(signif, key=lambda k: (signif[k], -k))
    # the exact range of the chosen count: hull slopes to its neighbours on the grid
    ks = sorted(top)
    if best == 0:
        lo, hi = lam0, S0
    else:
        i = ks.index(best)
        ssr_of = {k: S0 if k == 0 else solve(top[k])[1] for k in ks}
        hi = _refine(solve, best, ssr_of[best], ks[i - 1], ssr_of[ks[i - 1]], keep="lo")
        lo = (_refine(solve, ks[i + 1], ssr_of[ks[i + 1]], best, ssr_of[best], keep="hi") if i + 1 < len(ks)
              else floor)
        lo = min(lo, hi)
    lam = math.sqrt(lo * hi)
    k, ssr, sols = solve(lam)
    path = tuple(sorted(((la, kk, s) for la, (kk, s, _) in cache.items()), reverse=True))
    return KnotCostChoice(lam, k, (lo, hi), floor, sols, path, signif[best])


def _best_split_ssr(t: np.ndarray, Y: np.ndarray, order: int) -> float:
    """Least SSR of two chunks of at least ``order + 1 + MIN_RESIDUAL_DOF`` valid samples each
    (``inf`` if the part is too short to split)."""
    n = t.shape[0]
    fwd, cf = ssr_scan(t, Y, 0, n, order, True)  # fwd[m] = SSR[0, m)
    bwd, cb = ssr_scan(t, Y, 0, n, order, False)  # bwd[m] = SSR[n - m, n)
    m = np.arange(1, n)
    ok = (cf[m] >= order + 1 + MIN_RESIDUAL_DOF) & (cb[n - m] >= order + 1 + MIN_RESIDUAL_DOF)
    return float((fwd[m] + bwd[n - m])[ok].min()) if ok.any() else math.inf


def _residual_dof(parts: Parts, sols: Sequence[PiecewisePolynomial]) -> int:
    """Residual degrees of freedom of a fit: valid samples minus coefficients, per piece and component."""
    dof = 0
    for (_, Y), sol in zip(parts, sols, strict=True):
        ok = np.isfinite(Y).all(axis=1)
        dof += sum(max(int(ok[pc.i0:pc.i1].sum()) - pc.coeffs.shape[0], 0) for pc in sol.pieces) * Y.shape[1]
    return dof


def _significance(gain: float, lrv: float) -> float:
    """``gain / σ²_LR`` as a Python float; a fit that leaves no residual (``σ²_LR = 0``: every piece
    exact) makes any positive gain infinitely significant."""
    gain, lrv = float(gain), float(lrv)
    if lrv > 0.0:
        return gain / lrv
    return math.inf if gain > 0.0 else 0.0


def long_run_variance(parts: Parts, sols: Sequence[PiecewisePolynomial]) -> float:
    """Long-run variance per sample and component of the residual of a fit, ``σ²·(1 + ρ)/(1 − ρ)``:
    σ² the residual variance (SSR over the degrees of freedom left), ρ its lag-1 autocorrelation
    taken within chunks (an AR(1) model of the residual; ρ clipped to ``[0, 1 − 1/n]``, so that the
    effective sample size ``n·(1 − ρ)/(1 + ρ)`` lies between about 1 and n). 0 when the fit leaves
    no residual (see :func:`_significance`)."""
    num = den = ssr = 0.0
    n = dof = 0
    for (t, Y), sol in zip(parts, sols, strict=True):
        D = Y.shape[1]
        for pc in sol.pieces:
            yy = Y[pc.i0:pc.i1]
            r = yy - np.polynomial.polynomial.polyval(t[pc.i0:pc.i1] - pc.t0, pc.coeffs).T
            ok = np.isfinite(r).all(axis=1)
            both = ok[1:] & ok[:-1]
            num += float((r[1:][both] * r[:-1][both]).sum())
            den += float((r[ok] ** 2).sum())
            n += int(ok.sum())
            dof += max(int(ok.sum()) - pc.coeffs.shape[0], 0) * D
        ssr += sol.ssr
    if den <= 0.0 or dof <= 0:
        return 0.0
    rho = min(max(num / den, 0.0), 1.0 - 1.0 / max(n, 2))
    return ssr / dof * (1.0 + rho) / (1.0 - rho)


def _refine(solve, k_lo: int, s_lo: float, k_hi: int, s_hi: float, keep: str) -> float:
    """The λ at which the optimum switches between two hull vertices: ``k_hi`` knots (fewer; larger
    λ) and ``k_lo`` knots (more). With ``keep="lo"`` the switch out of ``k_lo`` towards fewer knots
    (the upper end of ``k_lo``'s range), with ``keep="hi"`` the switch out of ``k_hi`` towards more
    knots (the lower end of ``k_hi``'s range). Vertices found in between replace the other end, as in
    the CROPS algorithm; the result is the slope ``(S(k_hi) − S(k_lo))/(k_lo − k_hi)`` of adjacent
    vertices."""
    lam = 0.0
    for _ in range(200):
        lam = (s_hi - s_lo) / (k_lo - k_hi)
        if not lam > 0:
            return 0.0
        k, s, _ = solve(lam)
        if k in (k_lo, k_hi) or not k_hi < k < k_lo:
            return lam
        if abs((s + lam * k) - (s_hi + lam * k_hi)) <= 1e-12 * max(1.0, s_hi):
            return lam  # a tie: three vertices on one line
        if keep == "lo":
            k_hi, s_hi = k, s
        else:
            k_lo, s_lo = k, s
    return lam
