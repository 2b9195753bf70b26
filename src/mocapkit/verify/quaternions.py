"""Spherical linear interpolation of unit quaternions and the angle between two orientations, in plain
NumPy (scalar-first ``w, x, y, z``; any non-zero length: every quaternion is normalised first)."""

from __future__ import annotations

import numpy as np


def normalised(q: np.ndarray) -> np.ndarray:
    """``q / |q|`` row by row."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def slerp(q0: np.ndarray, q1: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``(m, 4)`` rotations at fractions ``f`` ``(m,)`` of the shortest arc from ``q0`` to ``q1`` (each ``(m, 4)``).

    ``q1`` is negated where ``q0 · q1 < 0`` (the same rotation, the shorter way round); the weights are
    ``sin((1 - f) θ) / sin θ`` and ``sin(f θ) / sin θ`` with ``θ`` the half-angle between the two, and a
    normalised linear blend where ``θ`` is so small that the two agree to rounding.
    """
    a, b = normalised(q0), normalised(q1)
    f = np.asarray(f, dtype=np.float64)[:, None]
    d = np.einsum("ij,ij->i", a, b)
    b = np.where(d[:, None] < 0, -b, b)
    d = np.abs(d)
    # the half-angle from the chord and the sum: accurate for tiny and for large angles alike
    theta = 2.0 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))[:, None]
    s = np.sin(theta)
    tiny = s[:, 0] < 1e-12
    with np.errstate(invalid="ignore", divide="ignore"):
        wa = np.where(tiny[:, None], 1.0 - f, np.sin((1.0 - f) * theta) / s)
        wb = np.where(tiny[:, None], f, np.sin(f * theta) / s)
    return normalised(wa * a + wb * b)


def angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(m,)`` rotation angle in degrees between orientations ``a`` and ``b`` (each ``(m, 4)``), in [0, 180]:
    ``4 · atan2(|a − s b|, |a + s b|)`` with ``s`` the sign of ``a · b`` (no ``acos`` of a dot product,
    which loses small angles)."""
    a, b = normalised(a), normalised(b)
    s = np.where(np.einsum("ij,ij->i", a, b) < 0, -1.0, 1.0)[:, None]
    return np.degrees(4.0 * np.arctan2(np.linalg.norm(a - s * b, axis=1), np.linalg.norm(a + s * b, axis=1)))


def interpolate(at: np.ndarray, point_at: np.ndarray, points: np.ndarray) -> np.ndarray:
    """SLERP of ``points`` ``(M, 4)`` placed at increasing ``point_at`` ``(M,)``, evaluated at ``at`` ``(m,)``
    (all within ``[point_at[0], point_at[-1]]``); one point gives itself everywhere."""
    at = np.asarray(at, dtype=np.float64)
    point_at = np.asarray(point_at, dtype=np.float64)
    if len(point_at) == 1:
        return np.repeat(normalised(points), len(at), axis=0)
    k = np.clip(np.searchsorted(point_at, at, side="right") - 1, 0, len(point_at) - 2)
    f = (at - point_at[k]) / (point_at[k + 1] - point_at[k])
    return slerp(points[k], points[k + 1], f)
