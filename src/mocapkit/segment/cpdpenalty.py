"""The a-priori penalty of the ruptures adapters (:mod:`mocapkit.segment.kernelcpd`,
:mod:`mocapkit.segment.pelt`) and the Gaussian kernel they share.

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
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["auto_penalty", "block_scale", "median_gamma", "per_frame_cost", "rbf_kernel"]


def median_gamma(z: np.ndarray, max_points: int = 1000) -> float:
    """``1 / median`` squared distance between (at most ``max_points`` evenly spaced) frames."""
    from scipy.spatial.distance import pdist

    stride = max(1, -(-z.shape[0] // max_points))
    med = float(np.median(pdist(z[::stride], metric="sqeuclidean")))
    return 1.0 / med if med > 0.0 else 1.0


def rbf_kernel(a: np.ndarray, b: np.ndarray | None, gamma: float) -> np.ndarray:
    """Gaussian kernel between the rows of ``a`` and ``b`` (``b is None``: of ``a`` with itself,
    with a unit diagonal), with ruptures' clipping of ``gamma * |x - y|^2`` to ``[0.01, 100]``."""
    other = a if b is None else b
    sq = (a * a).sum(1)[:, None] + (other * other).sum(1)[None, :] - 2.0 * a @ other.T
    k = np.exp(-np.clip(gamma * np.maximum(sq, 0.0), 1e-2, 1e2))
    if b is None:
        np.fill_diagonal(k, 1.0)
    return k


def block_scale(z: np.ndarray, width: int, gamma: float | None) -> float:
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
        self_sim = np.array([rbf_kernel(b, None, gamma).mean() for b in blocks])
        cross = np.array(
            [rbf_kernel(blocks[j], blocks[j + 1], gamma).mean() for j in range(n_blocks - 1)]
        )
        dist = np.maximum(self_sim[:-1] + self_sim[1:] - 2.0 * cross, 0.0)
    return 0.5 * width * float(np.median(dist))


def per_frame_cost(z: np.ndarray, gamma: float | None) -> float:
    """Cost per frame of the whole signal as one segment (for ``l2``: total variance)."""
    if gamma is None:
        return float(z.var(axis=0).sum())
    stride = max(1, -(-z.shape[0] // 1000))
    sub = z[::stride]
    return float(1.0 - rbf_kernel(sub, None, gamma).mean())


def auto_penalty(z: np.ndarray, width: int, gamma: float | None, pen_scale: float) -> float:
    """The a-priori penalty ``pen_scale * v * log(m)`` of the module docstring; ``0`` for a
    signal with no variation at all."""
    total = per_frame_cost(z, gamma)
    if total <= 1e-12:
        return 0.0
    v = max(block_scale(z, width, gamma), 1e-6 * total)
    return pen_scale * v * math.log(z.shape[0])
