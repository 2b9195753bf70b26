"""Orientation given as a rotation matrix or as Euler angles, turned into scalar-first quaternions.

Conventions (checked against the vendor's documentation):

- **Rotation matrix** (Xsens ``Mat[i][j]`` columns): ``Mat[i][j]`` is row ``i``, column ``j`` of
  ``R_GS``, the rotation of a sensor-frame vector into the global frame (``x_G = R_GS x_S``), the same
  rotation as the quaternion ``q_GS`` Xsens outputs. MT Manager lists the entries column-major
  (``Mat[1][1], Mat[2][1], Mat[3][1], Mat[1][2], ...``), the order of the DCM output ``a..i`` of the
  protocol. Sources: Xsens "MTi and MTx User Manual and Technical Documentation" (MT0100P), section
  4.3.3 "Rotation Matrix orientation output mode"; Xsens knowledge base "Orientation output
  specifications"; opensim-core ``XsensDataReader.cpp`` reads the nine columns the same way.
- **Euler angles** (Xsens ``Roll, Pitch, Yaw``, degrees): ``R_GS = Rz(yaw) · Ry(pitch) · Rx(roll)``, the
  aerospace / Tait-Bryan Z-Y'-X'' sequence (same sources), i.e. scipy's intrinsic ``"ZYX"`` with
  angles ``(yaw, pitch, roll)``.

scipy.spatial.transform.Rotation does the conversion; the sign of each quaternion is the one scipy
returns (``q`` and ``-q`` are the same rotation). A matrix that is not a rotation (determinant not
+1 or columns not orthonormal within :data:`MATRIX_TOLERANCE`) is an error naming its line: scipy
would silently replace it by the nearest rotation.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from mocapkit.errors import MocapFormatError

__all__ = ["MATRIX_TOLERANCE", "euler_note", "matrices_to_quaternions", "matrix_note", "quaternions_from_euler",
           "quaternions_from_matrices"]

#: Largest accepted ``|R Rᵀ − I|`` entry (exports round the entries to about 6 digits).
MATRIX_TOLERANCE = 1e-3


def _scalar_first(q_xyzw: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(q_xyzw[:, [3, 0, 1, 2]])


def matrices_to_quaternions(rows: np.ndarray, src: str, line_nos: Sequence[int],
                            names: Sequence[str]) -> tuple[np.ndarray, float]:
    """``(N, 9)`` row-major matrices ``R11, R12, ..., R33`` -> ``((N, 4) w,x,y,z, largest |R·Rᵀ − I|)``."""
    m = np.asarray(rows, dtype=np.float64).reshape(-1, 3, 3)
    if len(m) == 0:
        return np.zeros((0, 4)), 0.0
    dev = np.abs(m @ np.transpose(m, (0, 2, 1)) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(m)
    bad = np.flatnonzero(~(dev <= MATRIX_TOLERANCE) | ~(det > 0))
    if bad.size:
        k = int(bad[0])
        raise MocapFormatError(
            src, int(line_nos[k]), f"{', '.join(names[:1])}..{names[-1]} is not a rotation matrix "
            f"(|R·Rᵀ − I| = {dev[k]:.3g}, det = {det[k]:.3g})",
        )
    return _scalar_first(Rotation.from_matrix(m).as_quat()), float(dev.max())


def matrix_note(names: Sequence[str], dev: float) -> str:
    """How a matrix became quaternions (``meta["conversion"]``)."""
    return (f"rotation matrix {names[0]}..{names[-1]} (R_GS, Mat[row][col]) -> quaternion by "
            f"scipy Rotation.from_matrix; largest |R·Rᵀ − I| {dev:.2g}")


def quaternions_from_matrices(rows: np.ndarray, src: str, line_nos: Sequence[int],
                              names: Sequence[str]) -> tuple[np.ndarray, str]:
    """``(N, 9)`` row-major matrices ``R11, R12, ..., R33`` -> ``((N, 4) w,x,y,z, description)``."""
    q, dev = matrices_to_quaternions(rows, src, line_nos, names)
    return q, matrix_note(names, dev)


def euler_note(names: Sequence[str], degrees: bool) -> str:
    """How Euler angles became quaternions (``meta["conversion"]``)."""
    unit = "degrees" if degrees else "radians"
    return (f"Euler angles {', '.join(names)} ({unit}) -> quaternion of Rz(yaw)·Ry(pitch)·Rx(roll) by "
            "scipy Rotation.from_euler('ZYX', [yaw, pitch, roll])")


def quaternions_from_euler(rpy: np.ndarray, degrees: bool, names: Sequence[str]) -> tuple[np.ndarray, str]:
    """``(N, 3)`` roll, pitch, yaw -> ``((N, 4) w,x,y,z, description)`` with R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    a = np.asarray(rpy, dtype=np.float64).reshape(-1, 3)
    if len(a) == 0:
        return np.zeros((0, 4)), euler_note(names, degrees)
    q = _scalar_first(Rotation.from_euler("ZYX", a[:, ::-1], degrees=degrees).as_quat())
    return q, euler_note(names, degrees)
