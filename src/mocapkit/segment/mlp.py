"""Supervised segmentation by a per-frame classifier: the seed paper's back-propagation network ("BP-net"),
a multilayer perceptron (:class:`sklearn.neural_network.MLPClassifier`) trained on labelled takes; labels
smoothed and short runs merged, cuts where the label changes. scikit-learn is imported when the network
is trained."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.segment._common import float_param, int_param
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts
from mocapkit.segment.labelruns import cuts_at_label_changes, merge_short_runs, mode_filter

__all__ = ["MLPSegmenter"]


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
        signals: list[np.ndarray] = []
        labels: list[np.ndarray] = []
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
        self.train = list(zip(signals, labels, strict=True))
        try:
            self.hidden_layer_sizes = tuple(
                int_param(h, "hidden_layer_sizes[...]", 1) for h in hidden_layer_sizes
            )
        except TypeError:
            raise InvalidParameterError("hidden_layer_sizes must be a tuple of ints") from None
        if not self.hidden_layer_sizes:
            raise InvalidParameterError("hidden_layer_sizes must name at least one layer")
        self.max_iter = int_param(max_iter, "max_iter", 1)
        self.tol = float_param(tol, "tol")
        self.context = int_param(context, "context", 0)
        self.smooth = int_param(smooth, "smooth", 0)
        self.min_segment = int_param(min_segment, "min_segment", 1)
        self.random_state = int_param(random_state, "random_state", 0)
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

    def fit(self, X) -> MLPSegmenter:
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
        codes = mode_filter(codes, len(self.classes_), self.smooth)
        codes = merge_short_runs(codes, self.min_segment)
        n = x.shape[0]
        self.n_frames_ = n
        self.labels_ = self.classes_[codes]
        self.cuts_ = clean_cuts(cuts_at_label_changes(codes), n)
        return self
