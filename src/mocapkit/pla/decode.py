"""Decoding segment points back to a signal at arbitrary times."""

from __future__ import annotations

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.quat import normalize, slerp


def reconstruct_points(
    point_times: np.ndarray, point_values: np.ndarray, times: np.ndarray, kind: str = "quaternion"
) -> np.ndarray:
    """Interpolate between consecutive segment points at ``times``.

    Quaternion points are normalised first (CPLR and Swing Filter points are not unit length) and
    joined by SLERP along the shortest arc, as in Section 4 of the fastSW paper; vector points are
    joined linearly. ``times`` must lie within the points' time span.
    """
    pt = np.asarray(point_times, dtype=np.float64)
    pv = np.asarray(point_values, dtype=np.float64)
    t = np.asarray(times, dtype=np.float64)
    if pt.ndim != 1 or pv.shape[0] != pt.shape[0] or pt.shape[0] == 0:
        raise InvalidParameterError("segment points need matching (M,) times and (M, D) values, M >= 1")
    if np.any(np.diff(pt) <= 0):
        raise InvalidParameterError("segment point times must be strictly increasing")
    if t.size and (t.min() < pt[0] or t.max() > pt[-1]):
        raise InvalidParameterError(
            f"requested times [{float(t.min())!r}, {float(t.max())!r}] s reach outside the segment points' "
            f"span [{float(pt[0])!r}, {float(pt[-1])!r}] s"
        )
    if pt.shape[0] == 1:
        v = normalize(pv) if kind == "quaternion" else pv
        return np.repeat(v, t.shape[0], axis=0)
    k = np.clip(np.searchsorted(pt, t, side="right") - 1, 0, pt.shape[0] - 2)
    f = (t - pt[k]) / (pt[k + 1] - pt[k])
    if kind == "quaternion":
        return slerp(pv[k], pv[k + 1], f)
    return pv[k] + f[:, None] * (pv[k + 1] - pv[k])


def reconstruct(compressed, times: np.ndarray | None = None) -> np.ndarray:
    """Decode a :class:`~mocapkit.pla.base.Compressed` at ``times`` (default: its points' own span
    is required to contain them; pass the original signal's times to get one value per sample)."""
    if times is None:
        raise InvalidParameterError("reconstruct needs the times to decode at")
    return reconstruct_points(compressed.times, compressed.values, times, compressed.kind)
