"""One entry point for the piecewise polynomial filter: gaps, the automatic penalty, the solver."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.chunks import PiecewisePolynomial, as_2d
from mocapkit.filters.exact import solve_exact
from mocapkit.filters.penalty import choose_knot_cost
from mocapkit.filters.ppa import fit_iterative

#: highest polynomial order accepted: beyond it the chunk fits are ill-conditioned (powers of the
#: time offset span hundreds of decades) and no motion signal needs it
MAX_ORDER = 10


@dataclass(frozen=True)
class FilterResult:
    """Pieces of every gap-free part of a signal (a long NaN gap ends a part)."""

    parts: tuple[PiecewisePolynomial, ...]
    penalty: float  # K of Eq. 2 (automatic mode: the K with the same trade-off as knot_cost)
    order: int
    solver: str
    iterative_loss: float | None  # the iterative algorithm's loss (sum over parts); None in automatic mode
    unfitted: tuple[tuple[float, float], ...] = ()  # time ranges of parts too short to fit (NaN out)
    knot_cost: float | None = None  # automatic mode: λ of SSR + λ·N_k (squared signal units)

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
    for a, b in zip(idx[:-1], idx[1:], strict=True):
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
        ``K`` of Eq. 2 (signal units). ``None``: automatic mode — the knot cost λ of the additive
        loss ``SSR + λ·N_k`` is chosen by :func:`mocapkit.filters.penalty.choose_knot_cost` (the
        segmentation whose weakest knot gains most relative to the long-run variance of its
        residual; independent of the recording's length) and that loss is minimised exactly over
        chunks of at least ``order + 2`` valid samples, so that every chunk keeps a residual degree
        of freedom (a shorter part is one chunk; ``solver`` is then ``"auto"``; ``penalty`` of the
        result is the equivalent ``K``).
    solver
        ``"iterative"`` (the seed's local algorithm) or ``"exact"`` (global optimum, seeded with the
        iterative result so it is never worse); ignored in automatic mode.
    max_gap
        NaN gaps longer than this (seconds) cut the signal into independently filtered parts;
        default 10 median sample intervals.
    """
    t, Y = as_2d(t, y)
    if solver not in ("iterative", "exact"):
        raise InvalidParameterError(f"solver must be 'iterative' or 'exact', got {solver!r}")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 0 <= order <= MAX_ORDER:
        raise InvalidParameterError(f"the order must be an integer in 0..{MAX_ORDER}, got {order!r}")
    if init_chunk is not None and not (isinstance(init_chunk, (int, np.integer)) and init_chunk >= 1):
        raise InvalidParameterError(f"the initial chunk length must be an integer >= 1, got {init_chunk!r}")
    if max_gap is None:
        max_gap = 10.0 * float(np.median(np.diff(t))) if t.shape[0] > 1 else 1.0
    elif not (math.isfinite(float(max_gap)) and float(max_gap) > 0):
        raise InvalidParameterError(f"the maximum gap must be a finite number > 0, got {max_gap!r}")
    if penalty is not None and not (float(penalty) >= 0 and math.isfinite(float(penalty))):
        raise InvalidParameterError(f"the penalty must be a finite number >= 0, got {penalty!r}")
    ranges = []
    unfitted = []
    for a, b in split_at_gaps(t, Y, max_gap):
        if int((~np.isnan(Y[a:b]).any(axis=1)).sum()) < order + 1:
            unfitted.append((float(t[a]), float(t[b - 1])))  # too few samples: NaN in evaluate, reported
        else:
            ranges.append((a, b))
    if not ranges:
        raise InvalidParameterError(f"no part of the signal has {order + 1} consecutive valid samples")
    if penalty is None:
        ch = choose_knot_cost([(t[a:b], Y[a:b]) for a, b in ranges], order)
        K = ch.penalty
        parts = [_shift(PiecewisePolynomial(s.knots, s.pieces, s.order, s.ssr, K), a)
                 for s, (a, _) in zip(ch.solutions, ranges, strict=True)]
        return FilterResult(tuple(parts), K, order, "auto", None, tuple(unfitted), ch.knot_cost)
    K = float(penalty)
    parts = []
    it_loss = 0.0
    for a, b in ranges:
        it, _ = fit_iterative(t[a:b], Y[a:b], order, K, init_chunk=init_chunk)
        it_loss += it.loss
        res = solve_exact(t[a:b], Y[a:b], order, K, incumbent=it) if solver == "exact" else it
        parts.append(_shift(res, a))
    return FilterResult(tuple(parts), K, order, solver, it_loss, tuple(unfitted))


def _shift(pp: PiecewisePolynomial, a: int) -> PiecewisePolynomial:
    from mocapkit.filters.chunks import Piece

    pieces = tuple(Piece(p.i0 + a, p.i1 + a, p.t0, p.t1, p.coeffs) for p in pp.pieces)
    return PiecewisePolynomial(pp.knots + a, pieces, pp.order, pp.ssr, pp.penalty)
