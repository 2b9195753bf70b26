"""K-means segmentation: the standardised frames clustered by :class:`sklearn.cluster.KMeans` (``k`` by
the mean silhouette unless given), labels smoothed and short runs merged, cuts where the label changes.
scikit-learn is imported when the segmenter is fitted."""

from __future__ import annotations

import warnings

import numpy as np

from mocapkit.segment._common import int_param, standardise
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts
from mocapkit.segment.labelruns import cuts_at_label_changes, merge_short_runs, mode_filter

__all__ = ["KMeansSegmenter"]


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
        self.n_clusters = None if n_clusters is None else int_param(n_clusters, "n_clusters", 1)
        self.max_clusters = int_param(max_clusters, "max_clusters", 2)
        self.smooth = int_param(smooth, "smooth", 0)
        self.min_segment = int_param(min_segment, "min_segment", 1)
        self.subsample = int_param(subsample, "subsample", 10)
        self.n_init = int_param(n_init, "n_init", 1)
        self.random_state = int_param(random_state, "random_state", 0)

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

    def fit(self, X) -> KMeansSegmenter:
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
        z = standardise(x)
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
        codes = merge_short_runs(mode_filter(codes, max(k, 1), self.smooth), self.min_segment)
        self.n_frames_ = n
        self.n_clusters_ = k
        self.silhouettes_ = scores
        self.labels_ = codes
        self.cuts_ = clean_cuts(cuts_at_label_changes(codes), n)
        return self
