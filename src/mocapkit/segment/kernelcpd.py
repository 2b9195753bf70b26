"""Kernel change-point detection with a Gaussian kernel: an adapter of :class:`ruptures.KernelCPD`
(penalised, or with a known number of cuts). ruptures is imported when the segmenter is fitted.

Reference: S. Arlot, A. Celisse, Z. Harchaoui, "A kernel multiple change-point algorithm via model
selection", *J. Mach. Learn. Res.* 20(162), 2019.
"""

from __future__ import annotations

import numpy as np

from mocapkit.segment._common import float_param, int_param, optional_module, optional_n_cuts, standardise, take_every
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts
from mocapkit.segment.cpdpenalty import auto_penalty, median_gamma

__all__ = ["KernelCPDSegmenter"]


class KernelCPDSegmenter(Segmenter):
    """Kernel change-point detection, Gaussian kernel: an adapter of :class:`ruptures.KernelCPD`.

    The channels are standardised; the kernel is ``exp(-gamma ||x - y||^2)`` with ``gamma`` from the
    median heuristic on at most 1,000 evenly spaced frames (passed to ruptures explicitly, so that
    no ``n x n`` Gram matrix is built in Python). The segmentation minimises the kernel cost plus
    ``pen`` per cut (ruptures' C implementation of PELT), or, when ``n_cuts`` is given, the kernel
    cost with exactly ``n_cuts`` cuts (dynamic programming).

    Parameters
    ----------
    pen
        Penalty per cut. Default ``None``: the a-priori rule of :mod:`mocapkit.segment.cpdpenalty`,
        ``pen_scale * v * log(m)`` with ``v`` measured in the RBF feature space.
    pen_scale
        Constant of the a-priori penalty. Default ``4.0`` (``1`` would be BIC for independent
        samples), set on stationary synthetic series, 10 of each kind: 4 channels of AR(1) noise
        (coefficient 0.5, 0.9, 0.95) or of sinusoids (periods 20--200 frames) plus noise, 2,000 and
        6,000 frames. With ``4.0`` this segmenter puts 0.2 spurious cuts per series at most (on the
        6,000-frame sinusoids) and :class:`PELTSegmenter` none; with ``1.0`` they put up to 0.9
        and 7.1.
    min_size
        Shortest segment in input frames. Default ``120`` (1 s at 120 Hz).
    n_cuts
        ``None`` (default): the number of cuts is unknown and chosen by the a-priori penalty.
        ``"auto"``: the penalty is read off this signal's own cost curve without labels
        (:func:`mocapkit.segment.autok.curve_penalty`, the slope heuristic). An integer: the
        known number of cuts; exactly that many are returned if ``min_size`` allows it (otherwise as
        many as it allows).
    downsample
        Analyse every ``downsample``-th frame only (the cost of kernel PELT grows with the square of
        the length); cuts are mapped back to input frames (``cut * downsample``). Default ``1``.
    gamma
        Kernel bandwidth of the standardised signal. Default ``None`` (median heuristic).

    Attributes
    ----------
    n_frames_ : int
    cuts_ : numpy.ndarray
    pen_ : float or None
        Penalty used (``None`` in the ``n_cuts`` mode).
    gamma_ : float
        Kernel bandwidth used.
    """

    def __init__(
        self,
        pen: float | None = None,
        pen_scale: float = 4.0,
        min_size: int = 120,
        n_cuts: int | None = None,
        downsample: int = 1,
        gamma: float | None = None,
    ) -> None:
        self.pen = None if pen is None else float_param(pen, "pen")
        self.pen_scale = float_param(pen_scale, "pen_scale")
        self.min_size = int_param(min_size, "min_size", 1)
        self.n_cuts = optional_n_cuts(n_cuts)
        self.downsample = int_param(downsample, "downsample", 1)
        self.gamma = None if gamma is None else float_param(gamma, "gamma")

    def fit(self, X) -> KernelCPDSegmenter:
        """Segment ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        KernelCPDSegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value.
        InvalidParameterError
            The optional package is missing.
        """
        x = as_signal(X)
        rpt = optional_module("ruptures", "ruptures", type(self).__name__)
        n = x.shape[0]
        z = standardise(take_every(x, self.downsample))
        m = z.shape[0]
        size = max(1, -(-self.min_size // self.downsample))
        gamma = self.gamma if self.gamma is not None else median_gamma(z)
        self.gamma_ = gamma
        self.pen_ = None
        self.n_frames_ = n
        bkps: list[int] = []
        max_cuts = m // size - 1
        if self.n_cuts == "auto":
            from mocapkit.segment.autok import curve_penalty

            pen = curve_penalty(z, size, "rbf", gamma) if max_cuts >= 1 else None
            self.pen_ = pen
            if pen is not None and pen > 0.0:
                algo = rpt.KernelCPD(kernel="rbf", min_size=size, params={"gamma": gamma})
                bkps = algo.fit(z).predict(pen=pen)
        elif self.n_cuts is not None:
            k = min(self.n_cuts, max_cuts)
            if k > 0 and np.ptp(z) > 0:  # a constant signal has no change to place
                algo = rpt.KernelCPD(kernel="rbf", min_size=size, params={"gamma": gamma})
                bkps = algo.fit(z).predict(n_bkps=k)
        elif max_cuts >= 1:
            pen = self.pen
            if pen is None:
                pen = auto_penalty(z, size, gamma, self.pen_scale)
            self.pen_ = pen
            if pen > 0.0:
                algo = rpt.KernelCPD(kernel="rbf", min_size=size, params={"gamma": gamma})
                bkps = algo.fit(z).predict(pen=pen)
        self.cuts_ = clean_cuts(np.asarray(bkps[:-1], dtype=np.int64) * self.downsample, n)
        return self
