"""Quaternion maths shared by every layer.

Conventions: scalar-first ``(w, x, y, z)`` in every public function; arrays of shape ``(..., 4)``.
Inputs need not be unit length: every angle computation normalises internally, nothing else does.
Euler-angle conversions delegate to :mod:`scipy.spatial.transform` (which is scalar-last; the
conversion happens here and nowhere else).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation


def normalize(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return ``q / |q|`` along the last axis (a new array)."""
    q = np.asarray(q, dtype=np.float64)
    out: NDArray[np.float64] = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return out


@numba.njit(cache=True)
def _hemisphere_signs(q: NDArray[np.float64]) -> NDArray[np.float64]:
    n = q.shape[0]
    s = np.ones(n)
    for i in range(1, n):
        dot = q[i, 0] * q[i - 1, 0] + q[i, 1] * q[i - 1, 1] + q[i, 2] * q[i - 1, 2] + q[i, 3] * q[i - 1, 3]
        # negate when the dot with the *continuous* previous sample (s[i-1]·q[i-1]) is negative
        s[i] = -1.0 if s[i - 1] * dot < 0.0 else 1.0
    return s


@numba.njit(cache=True)
def dot4(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """Dot product of two 4-vectors (shared by the streaming and batch code so both round alike)."""
    d: float = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    return d


def hemisphere_continuous(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Flip signs so consecutive quaternions have a non-negative dot product.

    ``q`` and ``-q`` are the same rotation; PLA interpolates component-wise, so a sign jump between
    two samples would look like a huge step. Each sample is negated when its dot product with the
    (already continuous) previous sample is negative. Values are otherwise unchanged (exact negation).
    """
    q = np.ascontiguousarray(q, dtype=np.float64)
    if q.shape[0] == 0:
        return q.copy()
    return q * _hemisphere_signs(q)[:, None]


@numba.njit(cache=True, inline="always")
def _angle_between(a0: float, a1: float, a2: float, a3: float, b0: float, b1: float, b2: float, b3: float
                   ) -> float:
    """Rotation angle (radians) between two quaternions of any non-zero norm (Eq. 2, stable form)."""
    na = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3)
    nb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3)
    a0 /= na
    a1 /= na
    a2 /= na
    a3 /= na
    b0 /= nb
    b1 /= nb
    b2 /= nb
    b3 /= nb
    if a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3 < 0.0:
        b0 = -b0
        b1 = -b1
        b2 = -b2
        b3 = -b3
    d0 = a0 - b0
    d1 = a1 - b1
    d2 = a2 - b2
    d3 = a3 - b3
    s0 = a0 + b0
    s1 = a1 + b1
    s2 = a2 + b2
    s3 = a3 + b3
    return 4.0 * math.atan2(
        math.sqrt(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3), math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
    )


def angular_distance(q0: NDArray[np.float64], q1: NDArray[np.float64], degrees: bool = False) -> NDArray[np.float64]:
    """Angle of the shortest rotation between ``q0`` and ``q1`` (Eq. 2 of the fastSW paper).

    Eq. 2 is ``2·arccos(|<q0, q1>|)`` for unit quaternions. It is evaluated here in the equivalent,
    well-conditioned form ``4·atan2(|q0 − s·q1|, |q0 + s·q1|)`` with ``s = sign(<q0, q1>)`` after
    normalising both, because ``arccos`` loses half the digits near 0 (a 1-ulp error in the dot
    product reads as 1e-6°): identical samples give exactly 0.
    """
    a = normalize(q0)
    b = normalize(q1)
    a, b = np.broadcast_arrays(a, b)
    s = np.where(np.einsum("...i,...i->...", a, b) < 0.0, -1.0, 1.0)[..., None]
    d = np.linalg.norm(a - s * b, axis=-1)
    p = np.linalg.norm(a + s * b, axis=-1)
    ang: NDArray[np.float64] = 4.0 * np.arctan2(d, p)
    return np.degrees(ang) if degrees else ang


@numba.njit(cache=True, inline="always")
def _slerp_unit(a: NDArray[np.float64], b: NDArray[np.float64], f: float, out: NDArray[np.float64]) -> None:
    """SLERP between unit quaternions ``a`` and ``b`` (shortest arc) at fraction ``f`` into ``out``."""
    c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    sg = 1.0
    if c < 0.0:
        sg = -1.0
    d2 = 0.0
    s2 = 0.0
    for k in range(4):
        d = a[k] - sg * b[k]
        s = a[k] + sg * b[k]
        d2 += d * d
        s2 += s * s
    if d2 == 0.0:  # the same point: return it exactly (no rounding from the weights)
        for k in range(4):
            out[k] = a[k]
        return
    om = 2.0 * math.atan2(math.sqrt(d2), math.sqrt(s2))  # angle between a and sg*b on S^3
    so = math.sin(om)
    if so < 1e-12:
        w0 = 1.0 - f
        w1 = f
    else:
        w0 = math.sin((1.0 - f) * om) / so
        w1 = math.sin(f * om) / so
    nn = 0.0
    for k in range(4):
        out[k] = w0 * a[k] + w1 * sg * b[k]
        nn += out[k] * out[k]
    nn = math.sqrt(nn)
    for k in range(4):
        out[k] /= nn


def slerp(q0: NDArray[np.float64], q1: NDArray[np.float64], f: NDArray[np.float64]) -> NDArray[np.float64]:
    """Batched spherical linear interpolation along the shortest arc.

    Parameters
    ----------
    q0, q1
        ``(..., 4)`` quaternions (normalised here).
    f
        ``(...)`` fractions; 0 gives ``q0``, 1 gives ``q1`` (or ``-q1``, the same rotation).

    Returns
    -------
    ``(..., 4)`` unit quaternions.
    """
    a = normalize(q0)
    b = normalize(q1)
    f = np.asarray(f, dtype=np.float64)
    a, b = np.broadcast_arrays(a, b)
    c = np.einsum("...i,...i->...", a, b)
    sg = np.where(c < 0.0, -1.0, 1.0)[..., None]
    b = b * sg
    om = 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    so = np.sin(om)
    small = so < 1e-12
    safe = np.where(small, 1.0, so)
    w0 = np.where(small, 1.0 - f, np.sin((1.0 - f) * om) / safe)
    w1 = np.where(small, f, np.sin(f * om) / safe)
    out = w0[..., None] * a + w1[..., None] * b
    out = out / np.linalg.norm(out, axis=-1, keepdims=True)
    return np.where((om == 0.0)[..., None], a, out)  # equal ends: exactly that point


def multiply(q0: NDArray[np.float64], q1: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product ``q0 ⊗ q1`` (scalar-first)."""
    a = np.asarray(q0, dtype=np.float64)
    b = np.asarray(q1, dtype=np.float64)
    w0, x0, y0, z0 = np.moveaxis(a, -1, 0)
    w1, x1, y1, z1 = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
            w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
            w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
            w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
        ],
        axis=-1,
    )


def to_scipy(q: NDArray[np.float64]) -> Rotation:
    """Scalar-first quaternions to a scipy ``Rotation`` (which is scalar-last)."""
    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))


def from_scipy(r: Rotation) -> NDArray[np.float64]:
    """A scipy ``Rotation`` to scalar-first unit quaternions."""
    q = r.as_quat()
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def from_euler(order: str, angles: NDArray[np.float64], degrees: bool = True) -> NDArray[np.float64]:
    """Euler angles to scalar-first quaternions.

    ``order`` follows scipy: upper case (``"ZXY"``) is intrinsic, lower case extrinsic.
    """
    return from_scipy(Rotation.from_euler(order, angles, degrees=degrees))


def to_euler(order: str, q: NDArray[np.float64], degrees: bool = True) -> NDArray[np.float64]:
    """Scalar-first quaternions to Euler angles in ``order`` (scipy's convention)."""
    angles: NDArray[np.float64] = to_scipy(q).as_euler(order, degrees=degrees)
    return angles
