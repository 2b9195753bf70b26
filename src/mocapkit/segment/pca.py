"""PCA segmentation of Barbič et al. (2004): a cut where the projection error of a growing window onto
its first ``r`` principal components suddenly rises faster (a new behaviour adds dimensions).

Reference: J. Barbič, A. Safonova, J.-Y. Pan, C. Faloutsos, J. K. Hodgins, N. S. Pollard, "Segmenting
motion capture data into distinct behaviors", *Proc. Graphics Interface*, 2004, pp. 185--194.
"""

from __future__ import annotations

import math

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment._common import float_param, int_param
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts

__all__ = ["PCASegmenter"]


class PCASegmenter(Segmenter):
    """Barbič et al.'s (2004) PCA segmentation: a cut where the intrinsic dimension rises.

    The take is scanned from the start of the current segment. ``r`` is the number of principal
    components that explain a fraction ``tau`` of the variance of the segment's first ``k_init``
    frames. A window ``[start, start + i)`` then grows by ``step`` frames at a time; ``e_i`` is its
    projection error with ``r`` components (the sum over its frames of the squared distance to the
    ``r``-dimensional principal affine subspace of the window, i.e. the sum of the ``D - r``
    smallest eigenvalues of the window's scatter matrix). Inside one behaviour ``e_i`` grows at a
    constant rate; when a new behaviour enters the window it grows faster. The derivative
    ``d_i = e_i - e_{i-lag}`` is taken for every window length ``i >= lag`` (``e_0 = 0``), and a cut
    is declared at frame ``start + i`` as soon as ``i >= k_init + lag`` and

        ``d_i > mean(d) + R * std(d)``,

    mean and (population) standard deviation taken over all ``d_j`` with ``lag <= j < i`` of the
    current segment: the derivatives of the first ``k_init`` frames are a warm-up that is never
    tested (the paper's start ``i0`` of the tests is here ``k_init + lag``). The scan then restarts
    at the cut with a new ``r``. The window's first and second moments are accumulated ``step``
    frames at a time (about a reference pose, for accuracy), so each step costs ``O(step D^2)`` plus
    one symmetric eigenvalue problem of size ``D``.

    Parameters
    ----------
    k_init
        Frames used to choose ``r``, and length of the warm-up of the derivative statistics.
        Default ``240`` (2 s at 120 Hz; the paper's ``k``).
    tau
        Fraction of variance that the ``r`` components must explain, in ``(0, 1]``. Default ``0.9``
        (the paper's value).
    step
        Frames added to the window per step (the paper adds one). Default ``5``: a 4,579 x 93 take
        then takes well under a second, and a cut is located to within 5 frames (1/24 s).
    lag
        Frames between the two errors of a derivative (the paper's ``l``); a positive multiple of
        ``step``. Default ``60`` (the paper's value, 0.5 s at 120 Hz).
    R
        Threshold in standard deviations of the derivative (the paper's ``k_sigma``).
        Default ``3.0``.
    min_segment
        No cut leaves fewer than this many frames after it (a segment is already at least
        ``k_init + lag`` frames long by construction). Default ``120`` (1 s at 120 Hz).

    Attributes
    ----------
    n_frames_ : int
        Frames of the fitted signal.
    cuts_ : numpy.ndarray
        The cuts found by :meth:`fit`.
    scans_ : list of dict
        One entry per scanned segment: ``start`` (first frame), ``r``, ``lengths`` (window lengths
        ``i``), ``errors`` (``e_i``), ``cut`` (frame or ``None``).

    Notes
    -----
    ``r`` is capped at ``D - 1`` so that the residual subspace is never empty; for a univariate
    series ``r = 0`` and ``e_i`` is the window's scatter about its mean (a variance detector). A
    derivative must also exceed the mean by ``1e-9`` times the window's per-frame variance times
    ``lag``, so that round-off in an exactly low-rank or constant signal is never taken for a cut.

    The method is kept as published, including its weakness: the statistics of ``d`` come from
    strongly overlapping windows, so on stationary full-rank noise the test still fires about once
    per 1,000 frames.
    """

    def __init__(
        self,
        k_init: int = 240,
        tau: float = 0.9,
        step: int = 5,
        lag: int = 60,
        R: float = 3.0,
        min_segment: int = 120,
    ) -> None:
        self.k_init = int_param(k_init, "k_init", 2)
        self.tau = float_param(tau, "tau")
        if self.tau > 1.0:
            raise InvalidParameterError(f"tau must be in (0, 1], got {tau!r}")
        self.step = int_param(step, "step", 1)
        self.lag = int_param(lag, "lag", 1)
        if self.lag % self.step:
            raise InvalidParameterError(f"lag ({lag}) must be a multiple of step ({step})")
        self.R = float_param(R, "R", positive=False)
        self.min_segment = int_param(min_segment, "min_segment", 1)

    @staticmethod
    def _rank(block: np.ndarray, tau: float) -> int:
        """Fewest components explaining ``tau`` of the variance of ``block`` (at most ``D - 1``)."""
        y = block - block.mean(axis=0)
        w = np.clip(np.linalg.eigvalsh(y.T @ y)[::-1], 0.0, None)
        total = w.sum()
        dim = block.shape[1]
        if total <= 0.0:
            return 0
        share = np.cumsum(w) / total
        r = int(np.argmax(share >= tau * (1.0 - 1e-12))) + 1
        return min(r, dim - 1)

    @staticmethod
    def _projection_error(
        s1: np.ndarray, s2: np.ndarray, length: int, r: int
    ) -> tuple[float, float]:
        """Projection error with ``r`` components and trace of the scatter of a window whose
        (reference-centred) sum is ``s1`` and sum of outer products ``s2``."""
        scatter = s2 - np.outer(s1, s1) / length
        dim = scatter.shape[0]
        w = np.linalg.eigvalsh(scatter)
        return max(float(w[: dim - r].sum()), 0.0), max(float(np.trace(scatter)), 0.0)

    def _scan(self, x: np.ndarray, start: int) -> dict:
        seg = x[start:]
        m, dim = seg.shape
        k = min(self.k_init, m)
        ref = seg[:k].mean(axis=0)
        r = self._rank(seg[:k], self.tau)
        step, lag = self.step, self.lag
        first_test = max(self.k_init + lag, self.min_segment)
        s1 = np.zeros(dim)
        s2 = np.zeros((dim, dim))
        lengths: list[int] = []
        errors: list[float] = []
        n_d, mean_d, m2_d = 0, 0.0, 0.0
        length = 0
        cut = None
        while length + step <= m:
            block = seg[length : length + step] - ref
            s1 += block.sum(axis=0)
            s2 += block.T @ block
            length += step
            e, trace = self._projection_error(s1, s2, length, r)
            lengths.append(length)
            errors.append(e)
            if length < lag:
                continue
            back = length - lag
            d = e - (errors[back // step - 1] if back > 0 else 0.0)
            if length >= first_test and n_d >= 2 and m - length >= self.min_segment:
                std = math.sqrt(m2_d / n_d)
                floor = 1e-9 * trace / length * lag
                if d - mean_d > self.R * std and d - mean_d > floor:
                    cut = start + length
                    break
            n_d += 1  # Welford update of the derivative statistics
            delta = d - mean_d
            mean_d += delta / n_d
            m2_d += delta * (d - mean_d)
        return {
            "start": start,
            "r": r,
            "lengths": np.asarray(lengths, dtype=np.int64),
            "errors": np.asarray(errors),
            "cut": cut,
        }

    def fit(self, X) -> PCASegmenter:
        """Scan ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        PCASegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value.
        """
        x = as_signal(X)
        n = x.shape[0]
        cuts: list[int] = []
        scans: list[dict] = []
        start = 0
        while n - start > self.k_init + self.lag:
            scan = self._scan(x, start)
            scans.append(scan)
            if scan["cut"] is None:
                break
            cuts.append(scan["cut"])
            start = scan["cut"]
        self.n_frames_ = n
        self.scans_ = scans
        self.cuts_ = clean_cuts(cuts, n)
        return self
