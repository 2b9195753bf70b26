"""Rotation vectors (the logarithm of a unit quaternion) — the space the clip codec works in.

``v = θ·u`` for the rotation by ``θ`` about the unit axis ``u``. The exponential map is 1-Lipschitz
from rotation vectors (Euclidean norm) to rotations (angle between them): its differential has singular
values 1 (along ``v``) and ``sin(θ/2)/(θ/2) ≤ 1`` (across), so two rotation vectors ``|Δv|`` apart give
rotations at most ``|Δv|`` radians apart. A per-component error of at most ``τ`` on the three
components thus turns a rotation by at most ``√3·τ`` — the bound the codec's budget uses.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from mocapkit.quat import hemisphere_continuous

SMALL = 1e-12  # below this angle log_map uses its series limit


def log_map(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(N, 4)`` scalar-first quaternions (any norm) -> ``(N, 3)`` rotation vectors, continuous in time:
    the quaternions are first made hemisphere-continuous, so angles run past π instead of jumping."""
    q = hemisphere_continuous(np.asarray(q, dtype=np.float64))
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    xyz = q[..., 1:]
    s = np.linalg.norm(xyz, axis=-1)
    theta = 2.0 * np.arctan2(s, q[..., 0])
    f = np.where(s > SMALL, theta / np.maximum(s, SMALL), 2.0)
    v: NDArray[np.float64] = xyz * f[..., None]
    return v


HALF_PI = math.pi / 2
# Taylor coefficients (−1)^k/(2k+1)! and (−1)^k/(2k)!, k >= 1: 8 terms of sin(h)/h and cos(h) on
# [0, 0.8] (remainder < 3e-18) and 11 terms of sin(x), cos(x) on |x| <= π/2 (remainder < 2e-18)
_S = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 12)]
_C = [(-1.0) ** k / math.factorial(2 * k) for k in range(1, 12)]
S1, S2, S3, S4, S5, S6, S7, S8, S9, S10, S11 = _S
C1, C2, C3, C4, C5, C6, C7, C8, C9, C10, C11 = _C


@numba.njit(cache=True, nogil=True)
def exp_into(x: float, y: float, z: float, out: NDArray[np.float64]) -> None:
    """One rotation vector -> ``out[:4]`` (scalar-first); every exponential map of mocapkit is this
    function, so the encoder's check and every reader round alike. ``sin`` and ``cos`` of the half
    angle ``h`` are series (within 4e-16 of libm's, tested) for ``h ≤ π`` — the range of
    :func:`log_map` — and libm's beyond."""
    theta = math.sqrt(x * x + y * y + z * z)
    h = 0.5 * theta
    if h < 0.8:
        u = h * h
        f = 0.5 * (1.0 + u * (S1 + u * (S2 + u * (S3 + u * (S4 + u * (S5 + u * (S6 + u * (S7 + u * S8))))))))
        c = 1.0 + u * (C1 + u * (C2 + u * (C3 + u * (C4 + u * (C5 + u * (C6 + u * (C7 + u * C8)))))))
    elif h <= math.pi:
        t = h - HALF_PI  # sin h = cos t, cos h = −sin t
        u = t * t
        c = -t * (1.0 + u * (S1 + u * (S2 + u * (S3 + u * (S4 + u * (S5 + u * (S6 + u * (S7 + u * (S8 + u * (S9
                  + u * (S10 + u * S11)))))))))))
        f = (1.0 + u * (C1 + u * (C2 + u * (C3 + u * (C4 + u * (C5 + u * (C6 + u * (C7 + u * (C8 + u * (C9
             + u * (C10 + u * C11))))))))))) / theta
    else:
        f = math.sin(h) / theta
        c = math.cos(h)
    out[0] = c
    out[1] = x * f
    out[2] = y * f
    out[3] = z * f


@numba.njit(cache=True)
def _exp_rows(v: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    for i in range(v.shape[0]):
        exp_into(v[i, 0], v[i, 1], v[i, 2], out[i])


def exp_map(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 3)`` rotation vectors -> ``(..., 4)`` unit scalar-first quaternions."""
    v = np.asarray(v, dtype=np.float64)
    flat = np.ascontiguousarray(v.reshape(-1, 3))
    out = np.empty((flat.shape[0], 4))
    _exp_rows(flat, out)
    return out.reshape(v.shape[:-1] + (4,))
