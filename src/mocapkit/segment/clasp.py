"""Classification Score Profile (ClaSP) segmentation: an adapter of
:class:`claspy.segmentation.BinaryClaSPSegmentation` (claspy >= 0.2.7), imported when the segmenter is
fitted.

Reference: A. Ermshaus, P. Schäfer, U. Leser, "ClaSP: parameter-free time series segmentation", *Data
Min. Knowl. Disc.* 37, 2023, pp. 1262--1300.
"""

from __future__ import annotations

import warnings

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment._common import float_param, int_param, optional_module, optional_n_cuts, standardise, take_every
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts

__all__ = ["ClaSPSegmenter"]


class ClaSPSegmenter(Segmenter):
    """Classification Score Profile segmentation: an adapter of
    :class:`claspy.segmentation.BinaryClaSPSegmentation` (claspy >= 0.2.7).

    The installed claspy handles multivariate series (one window size, the smallest found over the
    channels; the distances of the channels are averaged), so ``X`` is passed whole after dropping
    constant channels and standardising the others. claspy learns the number of segments by a
    significance test on each candidate split. With ``n_cuts`` given, ``n_segments = n_cuts + 1``
    and the test is switched off (``validation=None``) so that ``n_cuts`` cuts are returned unless
    no admissible position is left; claspy's early stopping of the ensemble is then switched off as
    well (it stops at the first model whose split validates, and without a test every split does).
    A fresh claspy object is built for every :meth:`fit` (claspy overwrites some of its parameters
    while fitting).

    Parameters
    ----------
    n_cuts
        ``None`` (default): unknown, learned by claspy. An integer: the known number of cuts.
    window_size
        ``"suss"`` (default), ``"fft"``, ``"acf"`` (claspy's window-size methods) or a number of
        analysed frames.
    validation
        ``"significance_test"`` (default), ``"score_threshold"`` or ``None`` (accept every split).
        Ignored in the ``n_cuts`` mode.
    threshold
        ``"default"`` (claspy's: p-value ``1e-15`` for one channel, ``1e-30`` for several; score
        ``0.75``) or a number.
    n_estimators
        ClaSP models in the ensemble. Default ``10`` (claspy's).
    k_neighbours
        Neighbours of the k-NN classifier. Default ``3`` (claspy's).
    excl_radius
        Shortest segment in window sizes. Default ``5`` (claspy's).
    distance
        claspy's distance name. Default ``"znormed_euclidean_distance"``.
    downsample
        Analyse every ``downsample``-th frame only; cuts are mapped back (``cut * downsample``).
        Default ``1``.
    n_jobs
        Threads of claspy. Default ``-1``: all the threads numba may use (``NUMBA_NUM_THREADS``; claspy
        itself would ask for every core, which numba refuses when that variable is lower).
    random_state
        claspy's seed. Default ``2357`` (claspy's).

    Attributes
    ----------
    n_frames_ : int
    cuts_ : numpy.ndarray
    window_size_ : int or None
        Window size claspy used (in analysed frames).

    Notes
    -----
    The first fit in a process compiles claspy's numba kernels (about 10--20 s); later fits of
    4,579 x 4 takes take well under a second. Series with fewer than ``6 * excl_radius`` analysed
    frames (too short for two segments of claspy's smallest window of 3) get no cut.
    """

    def __init__(
        self,
        n_cuts: int | None = None,
        window_size: str | int = "suss",
        validation: str | None = "significance_test",
        threshold: str | float = "default",
        n_estimators: int = 10,
        k_neighbours: int = 3,
        excl_radius: int = 5,
        distance: str = "znormed_euclidean_distance",
        downsample: int = 1,
        n_jobs: int = -1,
        random_state: int = 2357,
    ) -> None:
        known = optional_n_cuts(n_cuts)
        if isinstance(known, str):  # "auto": a penalty read off a cost curve, which ClaSP has not
            raise InvalidParameterError(
                f"n_cuts={known!r} is not a ClaSP mode: None (claspy learns the number of cuts) or an integer"
            )
        self.n_cuts = known
        if isinstance(window_size, str):
            if window_size not in ("suss", "fft", "acf"):
                raise InvalidParameterError(
                    f"window_size must be 'suss', 'fft', 'acf' or an int, got {window_size!r}"
                )
            self.window_size: str | int = window_size
        else:
            self.window_size = int_param(window_size, "window_size", 3)
        if validation not in ("significance_test", "score_threshold", None):
            raise InvalidParameterError(
                "validation must be 'significance_test', 'score_threshold' or None, "
                f"got {validation!r}"
            )
        self.validation = validation
        self.threshold: str | float = (
            threshold if threshold == "default" else float_param(threshold, "threshold")
        )
        self.n_estimators = int_param(n_estimators, "n_estimators", 1)
        self.k_neighbours = int_param(k_neighbours, "k_neighbours", 1)
        self.excl_radius = int_param(excl_radius, "excl_radius", 1)
        if self.excl_radius <= self.k_neighbours:
            raise InvalidParameterError(
                f"excl_radius ({excl_radius}) must exceed k_neighbours ({k_neighbours})"
            )
        if distance not in (
            "znormed_euclidean_distance",
            "cinvariant_euclidean_distance",
            "euclidean_distance",
        ):
            raise InvalidParameterError(f"unknown claspy distance {distance!r}")
        self.distance = distance
        self.downsample = int_param(downsample, "downsample", 1)
        if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
            raise InvalidParameterError(f"n_jobs must be a non-zero integer, got {n_jobs!r}")
        self.n_jobs = int(n_jobs)
        self.random_state = int_param(random_state, "random_state", 0)

    def _threads(self) -> int:
        """``n_jobs``, with ``-1`` (any value below 1) as numba's thread limit."""
        if self.n_jobs >= 1:
            return self.n_jobs
        from numba import config

        return int(config.NUMBA_NUM_THREADS)

    def fit(self, X) -> ClaSPSegmenter:
        """Segment ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        ClaSPSegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value.
        InvalidParameterError
            The optional package is missing.
        """
        x = as_signal(X)
        seg_module = optional_module("claspy.segmentation", "claspy", type(self).__name__)
        n = x.shape[0]
        xs = take_every(x, self.downsample)
        z = standardise(xs)
        z = z[:, np.any(z != 0.0, axis=0)]
        self.n_frames_ = n
        self.window_size_ = None
        cuts: np.ndarray = np.zeros(0, dtype=np.int64)
        m = z.shape[0]
        if z.shape[1] > 0 and m >= 6 * self.excl_radius and self.n_cuts != 0:
            known = self.n_cuts is not None
            clasp = seg_module.BinaryClaSPSegmentation(
                n_segments=self.n_cuts + 1 if self.n_cuts is not None else "learn",
                n_estimators=self.n_estimators,
                window_size=self.window_size,
                k_neighbours=self.k_neighbours,
                distance=self.distance,
                early_stopping=not known,
                validation=None if known else self.validation,
                threshold=self.threshold,
                excl_radius=self.excl_radius,
                n_jobs=self._threads(),
                random_state=self.random_state,
            )
            series = np.ascontiguousarray(z[:, 0] if z.shape[1] == 1 else z)
            with warnings.catch_warnings():
                # claspy warns, and returns no cut, when the series is shorter than two segments
                warnings.simplefilter("ignore", UserWarning)
                found = clasp.fit_predict(series)
            self.window_size_ = int(clasp.window_size)
            cuts = np.asarray(found, dtype=np.int64) * self.downsample
        self.cuts_ = clean_cuts(cuts, n)
        return self
