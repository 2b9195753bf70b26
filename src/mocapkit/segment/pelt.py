"""Penalised least-cost segmentation by PELT: an adapter of :class:`ruptures.Pelt` with an ``"l2"`` or
``"rbf"`` cost evaluated in constant time from prefix sums, and a CROPS search of the penalty for a known
number of cuts. ruptures is imported when the segmenter is fitted.

References: R. Killick, P. Fearnhead, I. A. Eckley, "Optimal detection of changepoints with a linear
computational cost", *J. Am. Stat. Assoc.* 107(500), 2012, pp. 1590--1598. K. Haynes, I. A. Eckley,
P. Fearnhead, "Computationally efficient changepoint detection for a range of penalties", *J. Comput.
Graph. Stat.* 26(1), 2017, pp. 134--143 (CROPS).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment._common import float_param, int_param, optional_module, optional_n_cuts, standardise, take_every
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts
from mocapkit.segment.cpdpenalty import auto_penalty, median_gamma, rbf_kernel

__all__ = ["PELTSegmenter"]


def _prefix_cost(base_cost: type, model: str, gamma: float | None) -> Any:
    """A ruptures cost equal to ruptures' ``"l2"`` (``gamma is None``) or ``"rbf"`` cost, whose
    ``error(start, end)`` takes constant time from prefix sums (ruptures' own costs recompute each
    segment, which makes its Python PELT quadratic in the segment lengths)."""

    class PrefixSumCost(base_cost):
        """Segment cost from prefix sums: ``l2`` = squared deviations from the segment mean;
        ``rbf`` = ``len - sum(K[seg, seg]) / len`` with the clipped Gaussian kernel of ruptures."""

        def __init__(self) -> None:
            self.min_size = 1
            self.gamma = gamma

        @property
        def model(self) -> str:
            return model

        def fit(self, signal: np.ndarray) -> PrefixSumCost:
            z = np.asarray(signal, dtype=np.float64)
            z = z.reshape(-1, 1) if z.ndim == 1 else z
            self.signal = z
            m = z.shape[0]
            if self.gamma is None:
                self._c1 = np.vstack([np.zeros((1, z.shape[1])), np.cumsum(z, axis=0)])
                self._c2 = np.concatenate([[0.0], np.cumsum((z * z).sum(axis=1))])
            else:
                gram = rbf_kernel(z, None, self.gamma)
                np.cumsum(gram, axis=0, out=gram)
                np.cumsum(gram, axis=1, out=gram)
                self._cum = gram  # _cum[i - 1, j - 1] = sum of K[:i, :j]
            self.n_samples = m
            return self

        def _block(self, a: int, b: int) -> float:
            return 0.0 if a == 0 or b == 0 else float(self._cum[a - 1, b - 1])

        def error(self, start: int, end: int) -> float:
            length = end - start
            if length <= 0:
                return 0.0
            if self.gamma is None:
                s1 = self._c1[end] - self._c1[start]
                val = (self._c2[end] - self._c2[start]) - float(s1 @ s1) / length
            else:
                within = (
                    self._block(end, end)
                    - self._block(start, end)
                    - self._block(end, start)
                    + self._block(start, start)
                )
                val = length - within / length
            return max(val, 0.0)

    return PrefixSumCost()


class PELTSegmenter(Segmenter):
    """Penalised least-cost segmentation by PELT: an adapter of :class:`ruptures.Pelt`.

    The channels are standardised. ``model="l2"`` (default) detects changes of the mean (cost: the
    squared deviations from the segment mean); ``model="rbf"`` detects changes of the distribution
    (Gaussian-kernel cost, ``gamma`` by the median heuristic). ruptures' PELT is written in Python,
    so only every ``jump``-th frame is a candidate cut, and it is given (as ``custom_cost``) a cost
    equal to ruptures' ``"l2"`` / ``"rbf"`` cost but evaluated in constant time from prefix sums
    (ruptures' own costs re-sum every segment: about 20 s instead of 1 s on a stationary
    4,579-frame take).

    With ``n_cuts`` given, the penalty is searched as in CROPS (Haynes et al. 2017): the number of
    cuts of the optimal penalised segmentation does not increase with the penalty, and between two
    penalties giving ``k_lo > k_hi`` cuts with costs ``Q_lo < Q_hi`` the next penalty tried is
    ``(Q_hi - Q_lo) / (k_lo - k_hi)``. If no penalty gives exactly ``n_cuts`` cuts (a count off the
    lower convex hull of cost against cuts), the segmentation with the fewest cuts above ``n_cuts``
    is taken and its cheapest cuts to remove (the least increase of cost) are removed one at a time.

    Parameters
    ----------
    model
        ``"l2"`` (default) or ``"rbf"``. The ``"rbf"`` cost keeps an ``m x m`` matrix of prefix
        sums of the Gram matrix (``m`` analysed frames), so it refuses ``m > 8000`` (0.5 GB): use
        ``downsample``.
    pen
        Penalty per cut. Default ``None``: the a-priori rule of :mod:`mocapkit.segment.cpdpenalty`,
        ``pen_scale * v * log(m)`` (``v`` in the space of ``model``).
    pen_scale
        Constant of the a-priori penalty. Default ``4.0`` (as :class:`KernelCPDSegmenter`; set on
        stationary synthetic series, not on benchmark labels).
    min_size
        Shortest segment in input frames. Default ``120`` (1 s at 120 Hz).
    jump
        Only every ``jump``-th analysed frame may be a cut. Default ``5`` (1/24 s at 120 Hz): a
        4,579-frame take then takes about 1 s with ``"l2"`` and 2 s with ``"rbf"`` even without any
        change (no pruning); the work grows as ``(m / jump)^2`` in that worst case.
    n_cuts
        ``None`` (default): unknown, chosen by the a-priori penalty. ``"auto"``: the penalty is read
        off this signal's own cost curve without labels (:func:`mocapkit.segment.autok.curve_penalty`,
        the slope heuristic). An integer: the known number of cuts,
        returned exactly when ``min_size`` and ``jump`` allow it.
    downsample
        Analyse every ``downsample``-th frame only; cuts are mapped back (``cut * downsample``).
        Default ``1``.

    Attributes
    ----------
    n_frames_ : int
    cuts_ : numpy.ndarray
    pen_ : float
        Penalty of the returned segmentation (in the ``n_cuts`` mode: the last one tried).
    """

    _MAX_RBF_FRAMES = 8000

    def __init__(
        self,
        model: str = "l2",
        pen: float | None = None,
        pen_scale: float = 4.0,
        min_size: int = 120,
        jump: int = 5,
        n_cuts: int | None = None,
        downsample: int = 1,
    ) -> None:
        if model not in ("l2", "rbf"):
            raise InvalidParameterError(f"model must be 'l2' or 'rbf', got {model!r}")
        self.model = model
        self.pen = None if pen is None else float_param(pen, "pen")
        self.pen_scale = float_param(pen_scale, "pen_scale")
        self.min_size = int_param(min_size, "min_size", 1)
        self.jump = int_param(jump, "jump", 1)
        self.n_cuts = optional_n_cuts(n_cuts)
        self.downsample = int_param(downsample, "downsample", 1)

    @staticmethod
    def _run(algo: Any, pen: float) -> tuple[list[int], float]:
        bkps = algo.predict(pen=pen)
        return bkps, float(algo.cost.sum_of_costs(bkps))

    @staticmethod
    def _prune(algo: Any, bkps: list[int], k: int) -> list[int]:
        """Remove cuts, cheapest first, until ``k`` are left (``bkps`` ends with ``m``)."""
        bkps = list(bkps)
        while len(bkps) - 1 > k:
            bounds = [0] + bkps
            best, best_i = math.inf, 0
            for i in range(1, len(bounds) - 1):
                a, b, c = bounds[i - 1], bounds[i], bounds[i + 1]
                rise = algo.cost.error(a, c) - algo.cost.error(a, b) - algo.cost.error(b, c)
                if rise < best:
                    best, best_i = rise, i - 1
            del bkps[best_i]
        return bkps

    def _known_count(self, algo: Any, k: int, pen0: float) -> list[int]:
        lo = hi = None  # (pen, bkps, cost) with more than / fewer than k cuts
        pen = pen0
        for _ in range(40):  # bracket
            bkps, cost = self._run(algo, pen)
            got = len(bkps) - 1
            self.pen_ = pen
            if got == k:
                return bkps
            if got > k:
                lo = (pen, bkps, cost)
                if hi is not None:
                    break
                pen *= 4.0
            else:
                hi = (pen, bkps, cost)
                if lo is not None:
                    break
                pen /= 4.0
        if lo is None:  # even the smallest penalty gives fewer than k cuts
            return hi[1] if hi is not None else [algo.n_samples]
        if hi is None:
            return self._prune(algo, lo[1], k)
        for _ in range(40):  # CROPS refinement
            k_lo, k_hi = len(lo[1]) - 1, len(hi[1]) - 1
            pen = (hi[2] - lo[2]) / (k_lo - k_hi)
            if not pen > 0.0:
                break
            bkps, cost = self._run(algo, pen)
            got = len(bkps) - 1
            self.pen_ = pen
            if got == k:
                return bkps
            if got in (k_lo, k_hi):
                break  # no count between k_hi and k_lo: k is off the hull
            if got > k:
                lo = (pen, bkps, cost)
            else:
                hi = (pen, bkps, cost)
        return self._prune(algo, lo[1], k)

    def fit(self, X) -> PELTSegmenter:
        """Segment ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        PELTSegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value.
        InvalidParameterError
            The optional package is missing or ``model='rbf'`` gets more than 8,000 analysed frames.
        """
        x = as_signal(X)
        rpt = optional_module("ruptures", "ruptures", type(self).__name__)
        n = x.shape[0]
        z = standardise(take_every(x, self.downsample))
        m = z.shape[0]
        if self.model == "rbf" and m > self._MAX_RBF_FRAMES:
            raise InvalidParameterError(
                f"model='rbf' keeps an m x m Gram matrix; m = {m} analysed frames exceeds "
                f"{self._MAX_RBF_FRAMES}: raise downsample"
            )
        size = max(1, -(-self.min_size // self.downsample))
        gamma = median_gamma(z) if self.model == "rbf" else None
        self.n_frames_ = n
        self.pen_ = 0.0
        bkps: list[int] = [m]
        if m >= 2 * size:
            cost = _prefix_cost(rpt.base.BaseCost, self.model, gamma)
            algo = rpt.Pelt(custom_cost=cost, min_size=size, jump=self.jump).fit(z)
            auto = auto_penalty(z, size, gamma, self.pen_scale)
            if self.n_cuts == "auto":
                from mocapkit.segment.autok import curve_penalty

                pen = curve_penalty(z, size, self.model, gamma)
                self.pen_ = 0.0 if pen is None else pen
                if pen is not None and pen > 0.0:
                    bkps = algo.predict(pen=pen)
            elif isinstance(self.n_cuts, int):  # a known count (optional_n_cuts: None, "auto" or an int)
                if self.n_cuts > 0:
                    pen0 = self.pen if self.pen is not None else auto
                    if pen0 <= 0.0:  # no variation: any penalty is as good as another
                        pen0 = 1.0
                    bkps = self._known_count(algo, self.n_cuts, pen0)
            else:
                pen = self.pen if self.pen is not None else auto
                self.pen_ = pen
                if pen > 0.0:
                    bkps = algo.predict(pen=pen)
        self.cuts_ = clean_cuts(np.asarray(bkps[:-1], dtype=np.int64) * self.downsample, n)
        return self
