"""The common shape of every segmenter: ``fit(X)`` then ``predict()``, or ``fit_predict(X)``."""

from __future__ import annotations

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError


def as_signal(X, min_len: int = 2) -> np.ndarray:
    """``X`` as a float64 ``(n, d)`` array (a 1-D series becomes ``(n, 1)``); finite, ``n >= min_len``."""
    a = np.asarray(X, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise InvalidSignalError(f"expected a (frames,) or (frames, channels) array, got shape {a.shape}")
    if a.shape[0] < min_len:
        raise InvalidSignalError(f"need at least {min_len} frames, got {a.shape[0]}")
    if a.shape[1] == 0:
        raise InvalidSignalError("the signal has no channels")
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise InvalidSignalError(f"non-finite value at frame {i}, channel {j}")
    return a


class Segmenter:
    """Base class: ``fit(X)`` stores what ``predict()`` needs; ``predict()`` returns the cuts.

    A cut ``c`` (0-based, ``0 < c < n``) means a new segment starts at frame ``c``. The cuts are a
    sorted ``int64`` array without duplicates; an empty array means one segment.
    """

    n_frames_: int
    cuts_: np.ndarray

    def fit(self, X) -> Segmenter:  # pragma: no cover - overridden
        """Segment ``X`` and keep the cuts in ``self.cuts_``."""
        raise NotImplementedError

    def predict(self) -> np.ndarray:
        """A copy of the cuts found by the last :meth:`fit`; :class:`InvalidParameterError` before it."""
        cuts = getattr(self, "cuts_", None)
        if cuts is None:
            raise InvalidParameterError(f"{type(self).__name__}: call fit(X) before predict()")
        return cuts.copy()

    def fit_predict(self, X) -> np.ndarray:
        return self.fit(X).predict()


def clean_cuts(cuts, n: int) -> np.ndarray:
    """Sorted unique int64 cuts strictly inside ``(0, n)``."""
    c = np.unique(np.asarray(cuts, dtype=np.int64).ravel())
    return c[(c > 0) & (c < n)]
