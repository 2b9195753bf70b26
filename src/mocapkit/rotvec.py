"""Rotation vectors (the logarithm of a unit quaternion) — the space the clip codec works in.

``v = θ·u`` for the rotation by ``θ`` about the unit axis ``u``. The exponential map is 1-Lipschitz
from rotation vectors (Euclidean norm) to rotations (angle between them): its differential has singular
values 1 (along ``v``) and ``sin(θ/2)/(θ/2) ≤ 1`` (across), so two rotation vectors ``|Δv|`` apart give
rotations at most ``|Δv|`` radians apart. A per-component error of at most ``τ`` on the three
components thus turns a rotation by at most ``√3·τ`` — the bound the codec's budget uses.
"""

from __future__ import annotations

import numpy as np

from mocapkit.quat import hemisphere_continuous

SMALL = 1e-12  # below this angle the series limits are used (sin(θ/2)/θ -> 1/2)


def log_map(q: np.ndarray) -> np.ndarray:
    """``(N, 4)`` scalar-first quaternions (any norm) -> ``(N, 3)`` rotation vectors, continuous in time:
    the quaternions are first made hemisphere-continuous, so angles run past π instead of jumping."""
    q = hemisphere_continuous(np.asarray(q, dtype=np.float64))
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    xyz = q[..., 1:]
    s = np.linalg.norm(xyz, axis=-1)
    theta = 2.0 * np.arctan2(s, q[..., 0])
    f = np.where(s > SMALL, theta / np.maximum(s, SMALL), 2.0)
    return xyz * f[..., None]


def exp_map(v: np.ndarray) -> np.ndarray:
    """``(..., 3)`` rotation vectors -> ``(..., 4)`` unit scalar-first quaternions."""
    v = np.asarray(v, dtype=np.float64)
    theta = np.linalg.norm(v, axis=-1)
    half = 0.5 * theta
    f = np.where(theta > SMALL, np.sin(half) / np.maximum(theta, SMALL), 0.5)
    out = np.empty(v.shape[:-1] + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = v * f[..., None]
    return out
