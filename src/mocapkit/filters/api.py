"""One entry point for the piecewise polynomial filter: gaps, the automatic penalty, the solver."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import comb

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.chunks import PiecewisePolynomial, as_2d
from mocapkit.filters.exact import solve_exact
from mocapkit.filters.ppa import fit_iterative


def noise_sigma(y: np.ndarray, order: int = 2) -> float:
    """Robust noise level of a piecewise polynomial signal: differencing ``O + 1`` times removes every
    polynomial of order ``O`` and leaves white noise multiplied by ``sqrt(C(2(O+1), O+1))``; the MAD
    of what is left (/0.6745) ignores the few differences that straddle a knot. NaN rows are skipped
    (differences are taken within runs of valid samples only), components are pooled."""
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


def auto_penalty(y: np.ndarray, order: int = 2) -> float:
    """``K`` from the noise level: ``K = σ̂·(O + 1 + 2·ln n)/√n``.

    A knot placed in pure noise lowers the SSR by about ``σ²·(O + 1 + 2 ln n)`` (the ``O + 1`` extra
    coefficients plus the best of ~n positions), i.e. ``sqrt(SSR) ≈ σ√n`` by about
    ``σ (O + 1 + 2 ln n)/(2√n)``; ``K`` is twice that, so noise alone does not buy knots while a real
    discontinuity (which lowers the SSR by far more) does.
    """
    Y = np.asarray(y, dtype=np.float64)
    n = int(np.isfinite(Y.reshape(Y.shape[0], -1)).all(axis=1).sum())
    sigma = noise_sigma(Y, order)
    if n < 2 or sigma == 0.0:
        return 0.0
    return sigma * (order + 1 + 2 * math.log(n)) / math.sqrt(n)


@dataclass(frozen=True)
class FilterResult:
    """Pieces of every gap-free part of a signal (a long NaN gap ends a part)."""

    parts: tuple[PiecewisePolynomial, ...]
    penalty: float
    order: int
    solver: str
    iterative_loss: float  # the iterative algorithm's loss (sum over parts), for the gap to the optimum
    unfitted: tuple[tuple[float, float], ...] = ()  # time ranges of parts too short to fit (NaN out)

    @property
    def loss(self) -> float:
        return float(sum(p.loss for p in self.parts))

    @property
    def n_knots(self) -> int:
        return int(sum(p.n_knots for p in self.parts))

    @property
    def pieces(self):
        return tuple(pc for p in self.parts for pc in p.pieces)

    def evaluate(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Values at ``t``; NaN for times inside a long gap (between parts)."""
        t = np.asarray(t, dtype=np.float64)
        D = self.parts[0].pieces[0].coeffs.shape[1]
        out = np.full((t.shape[0], D), np.nan)
        for p in self.parts:
            sel = (t >= p.pieces[0].t0) & (t <= p.pieces[-1].t1)
            if sel.any():
                out[sel] = p.evaluate(t[sel], derivative)
        return out


def split_at_gaps(t: np.ndarray, Y: np.ndarray, max_gap: float) -> list[tuple[int, int]]:
    """Index ranges of the parts between NaN gaps longer than ``max_gap`` seconds (short gaps stay:
    their samples are simply left out of the fits, without bridging anything)."""
    ok = ~np.isnan(Y).any(axis=1)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return []
    parts = []
    start = idx[0]
    for a, b in zip(idx[:-1], idx[1:]):
        if t[b] - t[a] > max_gap:
            parts.append((int(start), int(a) + 1))
            start = b
    parts.append((int(start), int(idx[-1]) + 1))
    return parts


def fit(t, y, order: int = 2, penalty: float | None = None, solver: str = "exact", max_gap: float | None = None,
        init_chunk: int | None = None) -> FilterResult:
    """Filter ``y(t)`` by piecewise polynomials of order ``order``.

    Parameters
    ----------
    penalty
        ``K`` of Eq. 2 (signal units); ``None`` chooses :func:`auto_penalty`.
    solver
        ``"iterative"`` (the seed's local algorithm) or ``"exact"`` (global optimum, seeded with the
        iterative result so it is never worse).
    max_gap
        NaN gaps longer than this (seconds) cut the signal into independently filtered parts;
        default 10 median sample intervals.
    """
    t, Y = as_2d(t, y)
    if solver not in ("iterative", "exact"):
        raise InvalidParameterError(f"solver must be 'iterative' or 'exact', got {solver!r}")
    if max_gap is None:
        max_gap = 10.0 * float(np.median(np.diff(t))) if t.shape[0] > 1 else 1.0
    K = auto_penalty(Y, order) if penalty is None else float(penalty)
    parts = []
    unfitted = []
    it_loss = 0.0
    for a, b in split_at_gaps(t, Y, max_gap):
        if int((~np.isnan(Y[a:b]).any(axis=1)).sum()) < order + 1:
            unfitted.append((float(t[a]), float(t[b - 1])))  # too few samples: NaN in evaluate, reported
            continue
        it, _ = fit_iterative(t[a:b], Y[a:b], order, K, init_chunk=init_chunk)
        it_loss += it.loss
        res = solve_exact(t[a:b], Y[a:b], order, K, incumbent=it) if solver == "exact" else it
        parts.append(_shift(res, a))
    if not parts:
        raise InvalidParameterError(f"no part of the signal has {order + 1} consecutive valid samples")
    return FilterResult(tuple(parts), K, order, solver, it_loss, tuple(unfitted))


def _shift(pp: PiecewisePolynomial, a: int) -> PiecewisePolynomial:
    from mocapkit.filters.chunks import Piece

    pieces = tuple(Piece(p.i0 + a, p.i1 + a, p.t0, p.t1, p.coeffs) for p in pp.pieces)
    return PiecewisePolynomial(pp.knots + a, pieces, pp.order, pp.ssr, pp.penalty)
