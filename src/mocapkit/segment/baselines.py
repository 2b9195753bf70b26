"""Baseline segmenters that the ARMA segmenter of :mod:`mocapkit.segment` is compared against.

Every class follows :class:`~mocapkit.segment.base.Segmenter`: ``fit(X)`` then ``predict()`` (or
``fit_predict(X)``) returns the cut frames, a sorted ``int64`` array of 0-based frames ``c`` with
``0 < c < n`` (a new segment starts at frame ``c``). ``X`` is a ``(n,)`` or ``(n, d)`` float array,
e.g. limb angles in degrees at 120 Hz, root-relative joint positions, or a univariate benchmark
series. Lengths and widths are given in frames; the defaults are chosen for motion capture at
120 Hz, where an action lasts several seconds (one second is 120 frames).

* :class:`PCASegmenter` -- the PCA method of Barbič et al. (2004): a cut where the projection error
  of a growing window onto its first ``r`` principal components suddenly rises faster.
* :class:`KMeansSegmenter` -- K-means clusters of the frames, smoothed labels, cuts where the label
  changes.
* :class:`MLPSegmenter` -- a supervised per-frame classifier (the seed paper's back-propagation
  network) trained on labelled takes, smoothed labels, cuts where the label changes.
* :class:`KernelCPDSegmenter` -- :class:`ruptures.KernelCPD` with a Gaussian (RBF) kernel.
* :class:`PELTSegmenter` -- :class:`ruptures.Pelt` (``"l2"`` or ``"rbf"`` cost).
* :class:`ClaSPSegmenter` -- :class:`claspy.segmentation.BinaryClaSPSegmentation`.

The number of cuts is never an input, except through the explicit ``n_cuts`` parameter of the
change-point adapters (:class:`KernelCPDSegmenter`, :class:`PELTSegmenter`,
:class:`ClaSPSegmenter`), which exists only for a separately reported "known number of segments"
mode; its default ``None`` means "unknown".

Penalties of the ruptures adapters
----------------------------------
With ``pen=None`` the penalty is fixed a priori, without looking at any labels, as

    ``pen = pen_scale * v * log(m)``,

where ``m`` is the number of analysed frames and ``v`` is a robust estimate of the cost that one
frame of a stationary stretch contributes at the time scale of ``min_size``: the (standardised)
signal is cut into consecutive blocks of ``w = min_size`` analysed frames, the squared distance
between the means of neighbouring blocks is measured in the feature space of the cost (the signal
itself for ``"l2"``, the RBF feature space for ``"rbf"``, i.e. the biased squared MMD), and
``v = w / 2 * median`` of these distances. For a stationary stretch ``v`` estimates the long-run
variance (``sum`` over channels), so the rule is a BIC-type ``v log m`` penalty that also holds for
autocorrelated signals, where the short-term variance would under-penalise; the median ignores the
few block pairs that straddle a change. ``pen_scale`` is a fixed constant set on synthetic
stationary series (see the class docstrings), not on benchmark labels.

The optional packages ruptures and claspy are imported only when an adapter is fitted; without them
an :class:`~mocapkit.errors.InvalidParameterError` explains how to install them.

References
----------
J. Barbič, A. Safonova, J.-Y. Pan, C. Faloutsos, J. K. Hodgins, N. S. Pollard, "Segmenting motion
capture data into distinct behaviors", *Proc. Graphics Interface*, 2004, pp. 185--194.

R. Killick, P. Fearnhead, I. A. Eckley, "Optimal detection of changepoints with a linear
computational cost", *J. Am. Stat. Assoc.* 107(500), 2012, pp. 1590--1598.

S. Arlot, A. Celisse, Z. Harchaoui, "A kernel multiple change-point algorithm via model selection",
*J. Mach. Learn. Res.* 20(162), 2019.

K. Haynes, I. A. Eckley, P. Fearnhead, "Computationally efficient changepoint detection for a range
of penalties", *J. Comput. Graph. Stat.* 26(1), 2017, pp. 134--143 (CROPS).

A. Ermshaus, P. Schäfer, U. Leser, "ClaSP: parameter-free time series segmentation", *Data Min.
Knowl. Disc.* 37, 2023, pp. 1262--1300.
"""

from __future__ import annotations

import heapq
import importlib
import math
import warnings
from typing import Any, Sequence

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts

__all__ = [
    "PCASegmenter",
    "KMeansSegmenter",
    "MLPSegmenter",
    "KernelCPDSegmenter",
    "PELTSegmenter",
    "ClaSPSegmenter",
    "BASELINES",
]


# --------------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------------


def _int_param(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidParameterError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise InvalidParameterError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def _float_param(value: Any, name: str, *, positive: bool = True) -> float:
    if isinstance(value, bool):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or (positive and v <= 0.0) or (not positive and v < 0.0):
        bound = "> 0" if positive else ">= 0"
        raise InvalidParameterError(f"{name} must be finite and {bound}, got {value!r}")
    return v


def _optional_n_cuts(value: Any) -> int | None:
    return None if value is None else _int_param(value, "n_cuts", 0)


def _optional_module(module: str, package: str, owner: str) -> Any:
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InvalidParameterError(
            f"{owner} needs the optional {package!r} package: pip install 'mocapkit[segment]'"
        ) from None


def _standardise(x: np.ndarray) -> np.ndarray:
    """Each channel centred and scaled to unit standard deviation; a constant channel (standard deviation at most
    1e-8 of its level) becomes 0."""
    mu = x.mean(axis=0)
    sd = x.std(axis=0)
    const = sd <= 1e-8 * np.maximum(1.0, np.abs(mu))  # rounding-level wiggle counts as constant
    sd = np.where(const, 1.0, sd)
    z = (x - mu) / sd
    z[:, const] = 0.0
    return z


# --------------------------------------------------------------------------------------------------
# label helpers shared by the K-means and MLP segmenters
# --------------------------------------------------------------------------------------------------


def _mode_filter(codes: np.ndarray, n_classes: int, width: int) -> np.ndarray:
    """Majority vote over the ``2 * (width // 2) + 1`` frames centred on each frame (clipped at the
    ends); a frame keeps its own label when that label is among the most frequent ones, otherwise it
    takes the most frequent label with the lowest code."""
    n = codes.size
    half = width // 2
    if half == 0 or n == 0:
        return codes.copy()
    counts = np.zeros((n + 1, n_classes), dtype=np.int64)
    np.cumsum(np.eye(n_classes, dtype=np.int64)[codes], axis=0, out=counts[1:])
    idx = np.arange(n)
    window = counts[np.minimum(idx + half + 1, n)] - counts[np.maximum(idx - half, 0)]
    best = window.argmax(axis=1)
    keep = window[idx, codes] >= window[idx, best]
    return np.where(keep, codes, best)


def _merge_short_runs(codes: np.ndarray, min_len: int) -> np.ndarray:
    """Relabel runs shorter than ``min_len`` frames.

    The shortest run (the earliest among equals) is repeatedly given the label of its longer
    neighbour (the preceding one on a tie, the only one at either end), and neighbouring runs with
    the same label are joined, until every run has ``min_len`` frames or only one run is left.
    """
    n = codes.size
    if n == 0 or min_len <= 1:
        return codes.copy()
    change = np.flatnonzero(np.diff(codes)) + 1
    starts = np.concatenate(([0], change)).tolist()
    lengths = np.diff(np.concatenate((starts, [n]))).tolist()
    values = codes[starts].tolist()
    k = len(starts)
    prev = list(range(-1, k - 1))
    nxt = list(range(1, k + 1))
    nxt[-1] = -1
    alive = [True] * k
    n_alive = k
    heap = [(lengths[i], starts[i], i) for i in range(k)]
    heapq.heapify(heap)
    while heap and n_alive > 1:
        length, _, i = heapq.heappop(heap)
        if not alive[i] or length != lengths[i]:
            continue  # stale entry
        if length >= min_len:
            break
        p, q = prev[i], nxt[i]
        if p < 0:
            j = q
        elif q < 0:
            j = p
        else:
            j = p if lengths[p] >= lengths[q] else q
        # run i is absorbed by run j
        lengths[j] += lengths[i]
        starts[j] = min(starts[j], starts[i])
        alive[i] = False
        n_alive -= 1
        if j == p:
            nxt[p] = q
            if q >= 0:
                prev[q] = p
            other = q
        else:
            prev[q] = p
            if p >= 0:
                nxt[p] = q
            other = p
        if other >= 0 and values[other] == values[j]:  # the run beyond i has j's label: join it
            lengths[j] += lengths[other]
            starts[j] = min(starts[j], starts[other])
            alive[other] = False
            n_alive -= 1
            if other == nxt[j]:
                nxt[j] = nxt[other]
                if nxt[other] >= 0:
                    prev[nxt[other]] = j
            else:
                prev[j] = prev[other]
                if prev[other] >= 0:
                    nxt[prev[other]] = j
        heapq.heappush(heap, (lengths[j], starts[j], j))
    out = np.empty_like(codes)
    for i in range(k):
        if alive[i]:
            out[starts[i] : starts[i] + lengths[i]] = values[i]
    return out


def _cuts_at_label_changes(codes: np.ndarray) -> np.ndarray:
    return (np.flatnonzero(np.diff(codes)) + 1).astype(np.int64)


# --------------------------------------------------------------------------------------------------
# 1. PCA (Barbič et al. 2004)
# --------------------------------------------------------------------------------------------------


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
        self.k_init = _int_param(k_init, "k_init", 2)
        self.tau = _float_param(tau, "tau")
        if self.tau > 1.0:
            raise InvalidParameterError(f"tau must be in (0, 1], got {tau!r}")
        self.step = _int_param(step, "step", 1)
        self.lag = _int_param(lag, "lag", 1)
        if self.lag % self.step:
            raise InvalidParameterError(f"lag ({lag}) must be a multiple of step ({step})")
        self.R = _float_param(R, "R", positive=False)
        self.min_segment = _int_param(min_segment, "min_segment", 1)

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

    def fit(self, X) -> "PCASegmenter":
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


# --------------------------------------------------------------------------------------------------
# 2. K-means
# --------------------------------------------------------------------------------------------------


class KMeansSegmenter(Segmenter):
    """Frames clustered by K-means; cuts where the smoothed cluster label changes.

    The channels are standardised (zero mean, unit variance; constant channels are dropped to zero)
    and each frame is one point for :class:`sklearn.cluster.KMeans`. The labels are smoothed by a
    majority vote over ``smooth`` frames, then runs shorter than ``min_segment`` frames are merged
    into a neighbour: the shortest run (the earliest among equals) takes the label of its longer
    neighbour (the preceding one on a tie), neighbouring runs of the same label join, and this is
    repeated until every run is at least ``min_segment`` frames long. A cut is placed where the
    label changes.

    Parameters
    ----------
    n_clusters
        Number of clusters. Default ``None``: the ``k`` in ``2..max_clusters`` with the highest mean
        silhouette, each ``k`` clustered on (and scored on) at most ``subsample`` frames drawn
        without replacement with ``random_state``; the chosen ``k`` is then fitted on all frames.
        With fewer than two distinct frames a single cluster is used.
    max_clusters
        Largest ``k`` tried when ``n_clusters`` is ``None``. Default ``10``.
    smooth
        Width of the majority-vote filter in frames (an odd window of ``2 * (smooth // 2) + 1``
        frames; ``0`` or ``1`` disables it). Default ``61`` (0.5 s at 120 Hz).
    min_segment
        Shortest run kept, in frames. Default ``120`` (1 s at 120 Hz).
    subsample
        Frames used for choosing ``k``. Default ``2000``.
    n_init
        K-means restarts (``sklearn.cluster.KMeans(n_init=...)``). Default ``10``.
    random_state
        Seed for K-means and the subsample. Default ``0``.

    Attributes
    ----------
    n_frames_ : int
    cuts_ : numpy.ndarray
    n_clusters_ : int
        Clusters used.
    labels_ : numpy.ndarray
        Per-frame cluster after smoothing and merging.
    silhouettes_ : dict[int, float]
        Mean silhouette of each ``k`` tried (empty when ``n_clusters`` was given).
    """

    def __init__(
        self,
        n_clusters: int | None = None,
        max_clusters: int = 10,
        smooth: int = 61,
        min_segment: int = 120,
        subsample: int = 2000,
        n_init: int = 10,
        random_state: int = 0,
    ) -> None:
        self.n_clusters = None if n_clusters is None else _int_param(n_clusters, "n_clusters", 1)
        self.max_clusters = _int_param(max_clusters, "max_clusters", 2)
        self.smooth = _int_param(smooth, "smooth", 0)
        self.min_segment = _int_param(min_segment, "min_segment", 1)
        self.subsample = _int_param(subsample, "subsample", 10)
        self.n_init = _int_param(n_init, "n_init", 1)
        self.random_state = _int_param(random_state, "random_state", 0)

    def _choose_k(self, z: np.ndarray, n_distinct: int) -> tuple[int, dict[int, float]]:
        from sklearn.cluster import KMeans
        from sklearn.metrics import silhouette_score

        n = z.shape[0]
        rng = np.random.default_rng(self.random_state)
        sub = z if n <= self.subsample else z[np.sort(rng.choice(n, self.subsample, replace=False))]
        scores: dict[int, float] = {}
        k_max = min(self.max_clusters, n_distinct, sub.shape[0] - 1)
        for k in range(2, k_max + 1):
            km = KMeans(n_clusters=k, n_init=self.n_init, random_state=self.random_state)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # duplicate points: fewer distinct clusters than k
                labels = km.fit_predict(sub)
            if np.unique(labels).size < 2:
                continue
            scores[k] = float(silhouette_score(sub, labels))
        if not scores:
            return 1, scores
        return max(scores, key=lambda k: (scores[k], -k)), scores

    def fit(self, X) -> "KMeansSegmenter":
        """Cluster the frames of ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        KMeansSegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value.
        """
        from sklearn.cluster import KMeans

        x = as_signal(X)
        n = x.shape[0]
        z = _standardise(x)
        n_distinct = np.unique(z, axis=0).shape[0]
        scores: dict[int, float] = {}
        if self.n_clusters is None:
            k, scores = self._choose_k(z, n_distinct)
        else:
            k = min(self.n_clusters, n_distinct)
        if k <= 1:
            codes = np.zeros(n, dtype=np.int64)
        else:
            km = KMeans(n_clusters=k, n_init=self.n_init, random_state=self.random_state)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                codes = km.fit_predict(z).astype(np.int64)
        codes = _merge_short_runs(_mode_filter(codes, max(k, 1), self.smooth), self.min_segment)
        self.n_frames_ = n
        self.n_clusters_ = k
        self.silhouettes_ = scores
        self.labels_ = codes
        self.cuts_ = clean_cuts(_cuts_at_label_changes(codes), n)
        return self


# --------------------------------------------------------------------------------------------------
# 3. MLP (supervised per-frame classifier)
# --------------------------------------------------------------------------------------------------


def _frame_features(x: np.ndarray, context: int) -> np.ndarray:
    """Each frame's channels, plus (``context > 0``) the mean and the velocity over the frames
    ``t - context .. t + context`` (clipped at the ends): ``(x[t+c] - x[t-c]) / (2c)``."""
    if context == 0:
        return x
    n = x.shape[0]
    idx = np.arange(n)
    lo = np.maximum(idx - context, 0)
    hi = np.minimum(idx + context, n - 1)
    csum = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    mean = (csum[hi + 1] - csum[lo]) / (hi - lo + 1)[:, None]
    span = np.maximum(hi - lo, 1)[:, None]
    velocity = (x[hi] - x[lo]) / span
    return np.hstack([x, mean, velocity])


class MLPSegmenter(Segmenter):
    """A per-frame action classifier trained on labelled takes; cuts where the label changes.

    The seed paper's "BP-net": a multilayer perceptron
    (:class:`sklearn.neural_network.MLPClassifier`, trained by back-propagation) maps each frame's
    features to an action label. The network is trained once, on the first :meth:`fit`, on the
    labelled takes given as ``train``; :meth:`fit` then labels every frame of ``X``, smooths the
    labels by a majority vote over ``smooth`` frames, merges runs shorter than ``min_segment``
    frames into a neighbour (the rule of :class:`KMeansSegmenter`) and cuts where the label
    changes. For a benchmark, train on every take but the one segmented (leave one take out).

    Parameters
    ----------
    train
        The labelled takes (required, no default): a sequence of ``(X_i, labels_i)`` pairs, ``X_i``
        an ``(n_i,)`` or ``(n_i, d)`` array (the same ``d`` for all, and for the signals given to
        :meth:`fit`) and ``labels_i`` one label per frame (ints or strings); at least two distinct
        labels overall.
    hidden_layer_sizes
        Hidden layers of the network. Default ``(32,)``.
    max_iter
        Training epochs at most. Default ``1000``.
    tol
        Training stops when the loss improves by less than ``tol`` for 10 epochs. Default ``1e-4``.
    context
        ``0`` (default): the input is the frame's channels only, as in the seed paper. ``c > 0``:
        the mean and the velocity of each channel over the ``2c + 1`` frames centred on the frame
        are appended (edge-clipped windows), tripling the input.
    smooth
        Width of the majority-vote filter in frames (``0`` or ``1`` disables it). Default ``61``
        (0.5 s at 120 Hz).
    min_segment
        Shortest run kept, in frames. Default ``120`` (1 s at 120 Hz).
    random_state
        Seed of the network's initialisation and of the shuffling of the training frames.
        Default ``0``.

    Attributes
    ----------
    n_frames_ : int
    cuts_ : numpy.ndarray
    labels_ : numpy.ndarray
        Per-frame label of the fitted signal after smoothing and merging (the training label type).
    classes_ : numpy.ndarray
        The labels seen in training.
    model_ : sklearn.neural_network.MLPClassifier
        The trained network (its input is standardised with the training frames' mean and std).

    Notes
    -----
    The input channels are standardised with the mean and standard deviation of all training frames.
    """

    def __init__(
        self,
        train: Sequence[tuple[Any, Any]],
        hidden_layer_sizes: tuple[int, ...] = (32,),
        max_iter: int = 1000,
        tol: float = 1e-4,
        context: int = 0,
        smooth: int = 61,
        min_segment: int = 120,
        random_state: int = 0,
    ) -> None:
        try:
            pairs = list(train)
        except TypeError:
            raise InvalidParameterError("train must be a sequence of (X, labels) pairs") from None
        if not pairs:
            raise InvalidParameterError("train must hold at least one labelled take")
        signals, labels = [], []
        for i, pair in enumerate(pairs):
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise InvalidParameterError(f"train[{i}] must be an (X, labels) pair")
            x = as_signal(pair[0])
            y = np.asarray(pair[1])
            if y.ndim != 1 or y.shape[0] != x.shape[0]:
                raise InvalidParameterError(
                    f"train[{i}]: {x.shape[0]} frames but labels of shape {y.shape}"
                )
            if signals and x.shape[1] != signals[0].shape[1]:
                raise InvalidParameterError(
                    f"train[{i}] has {x.shape[1]} channels, train[0] has {signals[0].shape[1]}"
                )
            signals.append(x)
            labels.append(y)
        if np.unique(np.concatenate(labels)).size < 2:
            raise InvalidParameterError("train must hold at least two distinct labels")
        self.train = list(zip(signals, labels))
        try:
            self.hidden_layer_sizes = tuple(
                _int_param(h, "hidden_layer_sizes[...]", 1) for h in hidden_layer_sizes
            )
        except TypeError:
            raise InvalidParameterError("hidden_layer_sizes must be a tuple of ints") from None
        if not self.hidden_layer_sizes:
            raise InvalidParameterError("hidden_layer_sizes must name at least one layer")
        self.max_iter = _int_param(max_iter, "max_iter", 1)
        self.tol = _float_param(tol, "tol")
        self.context = _int_param(context, "context", 0)
        self.smooth = _int_param(smooth, "smooth", 0)
        self.min_segment = _int_param(min_segment, "min_segment", 1)
        self.random_state = _int_param(random_state, "random_state", 0)
        self.model_: Any = None

    def _train(self) -> None:
        from sklearn.neural_network import MLPClassifier

        feats = np.vstack([_frame_features(x, self.context) for x, _ in self.train])
        y = np.concatenate([lab for _, lab in self.train])
        self._mu = feats.mean(axis=0)
        sd = feats.std(axis=0)
        self._sd = np.where(sd > 0, sd, 1.0)
        model = MLPClassifier(
            hidden_layer_sizes=self.hidden_layer_sizes,
            max_iter=self.max_iter,
            tol=self.tol,
            random_state=self.random_state,
        )
        model.fit((feats - self._mu) / self._sd, y)
        self.model_ = model
        self.classes_ = model.classes_

    def fit(self, X) -> "MLPSegmenter":
        """Train (first call only), label the frames of ``X`` and store the cuts.

        Parameters
        ----------
        X
            ``(n,)`` or ``(n, d)`` array of finite values, ``n >= 2``.

        Returns
        -------
        MLPSegmenter
            ``self``, with ``cuts_`` and ``n_frames_`` set.

        Raises
        ------
        InvalidSignalError
            ``X`` is not 1-D or 2-D, has fewer than 2 frames or a non-finite value, or not the
            training's number of channels.
        """
        x = as_signal(X)
        d_train = self.train[0][0].shape[1]
        if x.shape[1] != d_train:
            raise InvalidSignalError(
                f"expected {d_train} channels (as in training), got {x.shape[1]}"
            )
        if self.model_ is None:
            self._train()
        feats = (_frame_features(x, self.context) - self._mu) / self._sd
        proba = self.model_.predict_proba(feats)
        codes = proba.argmax(axis=1).astype(np.int64)
        codes = _mode_filter(codes, len(self.classes_), self.smooth)
        codes = _merge_short_runs(codes, self.min_segment)
        n = x.shape[0]
        self.n_frames_ = n
        self.labels_ = self.classes_[codes]
        self.cuts_ = clean_cuts(_cuts_at_label_changes(codes), n)
        return self


# --------------------------------------------------------------------------------------------------
# penalty scale shared by the ruptures adapters
# --------------------------------------------------------------------------------------------------


def _median_gamma(z: np.ndarray, max_points: int = 1000) -> float:
    """``1 / median`` squared distance between (at most ``max_points`` evenly spaced) frames."""
    from scipy.spatial.distance import pdist

    stride = max(1, -(-z.shape[0] // max_points))
    med = float(np.median(pdist(z[::stride], metric="sqeuclidean")))
    return 1.0 / med if med > 0.0 else 1.0


def _rbf(a: np.ndarray, b: np.ndarray | None, gamma: float) -> np.ndarray:
    """Gaussian kernel between the rows of ``a`` and ``b`` (``b is None``: of ``a`` with itself,
    with a unit diagonal), with ruptures' clipping of ``gamma * |x - y|^2`` to ``[0.01, 100]``."""
    other = a if b is None else b
    sq = (a * a).sum(1)[:, None] + (other * other).sum(1)[None, :] - 2.0 * a @ other.T
    k = np.exp(-np.clip(gamma * np.maximum(sq, 0.0), 1e-2, 1e2))
    if b is None:
        np.fill_diagonal(k, 1.0)
    return k


def _block_scale(z: np.ndarray, width: int, gamma: float | None) -> float:
    """``width / 2`` times the median squared distance between the means of neighbouring blocks of
    ``width`` frames, in the signal space (``gamma is None``) or in the RBF feature space."""
    width = max(int(width), 2)
    n_blocks = z.shape[0] // width
    if n_blocks < 2:
        return 0.0
    blocks = z[: n_blocks * width].reshape(n_blocks, width, z.shape[1])
    if gamma is None:
        means = blocks.mean(axis=1)
        dist = ((means[1:] - means[:-1]) ** 2).sum(axis=1)
    else:
        self_sim = np.array([_rbf(b, None, gamma).mean() for b in blocks])
        cross = np.array(
            [_rbf(blocks[j], blocks[j + 1], gamma).mean() for j in range(n_blocks - 1)]
        )
        dist = np.maximum(self_sim[:-1] + self_sim[1:] - 2.0 * cross, 0.0)
    return 0.5 * width * float(np.median(dist))


def _per_frame_cost(z: np.ndarray, gamma: float | None) -> float:
    """Cost per frame of the whole signal as one segment (for ``l2``: total variance)."""
    if gamma is None:
        return float(z.var(axis=0).sum())
    stride = max(1, -(-z.shape[0] // 1000))
    sub = z[::stride]
    return float(1.0 - _rbf(sub, None, gamma).mean())


def _auto_penalty(z: np.ndarray, width: int, gamma: float | None, pen_scale: float) -> float:
    """The a-priori penalty ``pen_scale * v * log(m)`` of the module docstring; ``0`` for a
    signal with no variation at all."""
    total = _per_frame_cost(z, gamma)
    if total <= 1e-12:
        return 0.0
    v = max(_block_scale(z, width, gamma), 1e-6 * total)
    return pen_scale * v * math.log(z.shape[0])


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

        def fit(self, signal: np.ndarray) -> "PrefixSumCost":
            z = np.asarray(signal, dtype=np.float64)
            z = z.reshape(-1, 1) if z.ndim == 1 else z
            self.signal = z
            m = z.shape[0]
            if self.gamma is None:
                self._c1 = np.vstack([np.zeros((1, z.shape[1])), np.cumsum(z, axis=0)])
                self._c2 = np.concatenate([[0.0], np.cumsum((z * z).sum(axis=1))])
            else:
                gram = _rbf(z, None, self.gamma)
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


def _downsample(x: np.ndarray, k: int) -> np.ndarray:
    return x[::k] if k > 1 else x


# --------------------------------------------------------------------------------------------------
# 4. kernel change-point detection (ruptures.KernelCPD)
# --------------------------------------------------------------------------------------------------


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
        Penalty per cut. Default ``None``: the a-priori rule of the module docstring,
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
        ``None`` (default): the number of cuts is unknown and chosen by the penalty. An integer: the
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
        self.pen = None if pen is None else _float_param(pen, "pen")
        self.pen_scale = _float_param(pen_scale, "pen_scale")
        self.min_size = _int_param(min_size, "min_size", 1)
        self.n_cuts = _optional_n_cuts(n_cuts)
        self.downsample = _int_param(downsample, "downsample", 1)
        self.gamma = None if gamma is None else _float_param(gamma, "gamma")

    def fit(self, X) -> "KernelCPDSegmenter":
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
        rpt = _optional_module("ruptures", "ruptures", type(self).__name__)
        n = x.shape[0]
        z = _standardise(_downsample(x, self.downsample))
        m = z.shape[0]
        size = max(1, -(-self.min_size // self.downsample))
        gamma = self.gamma if self.gamma is not None else _median_gamma(z)
        self.gamma_ = gamma
        self.pen_ = None
        self.n_frames_ = n
        bkps: list[int] = []
        max_cuts = m // size - 1
        if self.n_cuts is not None:
            k = min(self.n_cuts, max_cuts)
            if k > 0 and np.ptp(z) > 0:  # a constant signal has no change to place
                algo = rpt.KernelCPD(kernel="rbf", min_size=size, params={"gamma": gamma})
                bkps = algo.fit(z).predict(n_bkps=k)
        elif max_cuts >= 1:
            pen = self.pen
            if pen is None:
                pen = _auto_penalty(z, size, gamma, self.pen_scale)
            self.pen_ = pen
            if pen > 0.0:
                algo = rpt.KernelCPD(kernel="rbf", min_size=size, params={"gamma": gamma})
                bkps = algo.fit(z).predict(pen=pen)
        self.cuts_ = clean_cuts(np.asarray(bkps[:-1], dtype=np.int64) * self.downsample, n)
        return self


# --------------------------------------------------------------------------------------------------
# 5. PELT (ruptures.Pelt)
# --------------------------------------------------------------------------------------------------


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
        Penalty per cut. Default ``None``: the a-priori rule of the module docstring,
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
        ``None`` (default): unknown, chosen by the penalty. An integer: the known number of cuts,
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
        self.pen = None if pen is None else _float_param(pen, "pen")
        self.pen_scale = _float_param(pen_scale, "pen_scale")
        self.min_size = _int_param(min_size, "min_size", 1)
        self.jump = _int_param(jump, "jump", 1)
        self.n_cuts = _optional_n_cuts(n_cuts)
        self.downsample = _int_param(downsample, "downsample", 1)

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

    def fit(self, X) -> "PELTSegmenter":
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
        rpt = _optional_module("ruptures", "ruptures", type(self).__name__)
        n = x.shape[0]
        z = _standardise(_downsample(x, self.downsample))
        m = z.shape[0]
        if self.model == "rbf" and m > self._MAX_RBF_FRAMES:
            raise InvalidParameterError(
                f"model='rbf' keeps an m x m Gram matrix; m = {m} analysed frames exceeds "
                f"{self._MAX_RBF_FRAMES}: raise downsample"
            )
        size = max(1, -(-self.min_size // self.downsample))
        gamma = _median_gamma(z) if self.model == "rbf" else None
        self.n_frames_ = n
        self.pen_ = 0.0
        bkps: list[int] = [m]
        if m >= 2 * size:
            cost = _prefix_cost(rpt.base.BaseCost, self.model, gamma)
            algo = rpt.Pelt(custom_cost=cost, min_size=size, jump=self.jump).fit(z)
            auto = _auto_penalty(z, size, gamma, self.pen_scale)
            if self.n_cuts is not None:
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


# --------------------------------------------------------------------------------------------------
# 6. ClaSP (claspy)
# --------------------------------------------------------------------------------------------------


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
        Threads of claspy. Default ``-1`` (all cores).
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
        self.n_cuts = _optional_n_cuts(n_cuts)
        if isinstance(window_size, str):
            if window_size not in ("suss", "fft", "acf"):
                raise InvalidParameterError(
                    f"window_size must be 'suss', 'fft', 'acf' or an int, got {window_size!r}"
                )
            self.window_size: str | int = window_size
        else:
            self.window_size = _int_param(window_size, "window_size", 3)
        if validation not in ("significance_test", "score_threshold", None):
            raise InvalidParameterError(
                "validation must be 'significance_test', 'score_threshold' or None, "
                f"got {validation!r}"
            )
        self.validation = validation
        self.threshold: str | float = (
            threshold if threshold == "default" else _float_param(threshold, "threshold")
        )
        self.n_estimators = _int_param(n_estimators, "n_estimators", 1)
        self.k_neighbours = _int_param(k_neighbours, "k_neighbours", 1)
        self.excl_radius = _int_param(excl_radius, "excl_radius", 1)
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
        self.downsample = _int_param(downsample, "downsample", 1)
        if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
            raise InvalidParameterError(f"n_jobs must be a non-zero integer, got {n_jobs!r}")
        self.n_jobs = int(n_jobs)
        self.random_state = _int_param(random_state, "random_state", 0)

    def fit(self, X) -> "ClaSPSegmenter":
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
        seg_module = _optional_module("claspy.segmentation", "claspy", type(self).__name__)
        n = x.shape[0]
        xs = _downsample(x, self.downsample)
        z = _standardise(xs)
        z = z[:, np.any(z != 0.0, axis=0)]
        self.n_frames_ = n
        self.window_size_ = None
        cuts = np.zeros(0, dtype=np.int64)
        m = z.shape[0]
        if z.shape[1] > 0 and m >= 6 * self.excl_radius and self.n_cuts != 0:
            known = self.n_cuts is not None
            clasp = seg_module.BinaryClaSPSegmentation(
                n_segments=self.n_cuts + 1 if known else "learn",
                n_estimators=self.n_estimators,
                window_size=self.window_size,
                k_neighbours=self.k_neighbours,
                distance=self.distance,
                early_stopping=not known,
                validation=None if known else self.validation,
                threshold=self.threshold,
                excl_radius=self.excl_radius,
                n_jobs=self.n_jobs,
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


BASELINES: dict[str, type[Segmenter]] = {
    "pca": PCASegmenter,
    "kmeans": KMeansSegmenter,
    "mlp": MLPSegmenter,
    "kernelcpd": KernelCPDSegmenter,
    "pelt": PELTSegmenter,
    "clasp": ClaSPSegmenter,
}
"""Name -> class of every baseline segmenter."""
