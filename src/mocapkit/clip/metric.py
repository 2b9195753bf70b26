"""Position error of a decoded skeletal motion: every point drawn, or as ACL measures it.

``joint+end`` (the default of ``compress``): the world-space distance between the original and the
decoded position of every joint and every End Site (the tips a BVH or ASF skeleton draws beyond its
leaf joints: a leaf's own rotation moves them) in every frame. ``joint``: the joints only. ``shell``:
ACL's error metric — for every bone and frame the largest distance between the original and the
decoded positions of three *virtual points* at distance ``d`` along the bone's local x, y and z axes
(``p_j + d·R_j·e_a``); it also sees a bone's own rotation (which moves no joint when the bone is a
leaf). All are computed from float64 forward kinematics of the two motions.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mocapkit.clip.container import BOUND_METRICS
from mocapkit.errors import InvalidParameterError
from mocapkit.skeleton import Motion, forward_kinematics

METRICS = BOUND_METRICS  # ("joint+end", "joint", "shell"): what a clip's header may name
DEFAULT_METRIC = "joint+end"
DEFAULT_SHELL_CM = 3.0  # ACL's default virtual-vertex distance


def check_metric(metric: str) -> str:
    if metric not in METRICS:
        raise InvalidParameterError(f"error metric must be one of {', '.join(METRICS)}, got {metric!r}")
    return metric


def errors_from_fk(P0, R0, P1, R1, shell_distance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(joint, shell)`` errors, each ``(N, J)``, from world positions ``P`` ``(N, J, 3)`` and world
    rotation matrices ``R`` ``(N, J, 3, 3)`` of the original (0) and the decoded (1) motion."""
    dP = P1 - P0
    joint = np.sqrt(np.einsum("nja,nja->nj", dP, dP))
    dR = (R1 - R0) * shell_distance  # column a: the moved axis point's offset change
    shell = np.zeros_like(joint)
    for a in range(3):
        v = dP + dR[..., :, a]
        np.maximum(shell, np.sqrt(np.einsum("nja,nja->nj", v, v)), out=shell)
    return joint, shell


def end_errors_from_fk(skeleton, P0, R0, P1, R1) -> np.ndarray:
    """``(N, E)`` distances of the End Sites ``p_j + R_j·offset`` of the original (0) and decoded (1)
    world positions and rotations (:func:`errors_from_fk`'s arguments)."""
    N = P0.shape[0]
    out = np.zeros((N, len(skeleton.end_sites)))
    for e, (j, off) in enumerate(skeleton.end_sites):
        off = np.asarray(off, dtype=np.float64)
        d = (P1[:, j] - P0[:, j]) + np.einsum("nab,b->na", R1[:, j] - R0[:, j], off)
        out[:, e] = np.sqrt(np.einsum("na,na->n", d, d))
    return out


def end_site_errors(original: Motion, decoded: Motion) -> np.ndarray:
    """``(N, E)`` world-space error of every End Site in every frame (file units)."""
    P0, R0 = forward_kinematics(original)
    P1, R1 = forward_kinematics(decoded)
    return end_errors_from_fk(original.skeleton, P0, R0, P1, R1)


def end_site_arrays(skeleton) -> tuple[np.ndarray, np.ndarray]:
    """The End Sites as arrays: their joints ``(E,)`` int64 and offsets ``(E, 3)``."""
    ends = skeleton.end_sites
    return (np.array([j for j, _ in ends], dtype=np.int64),
            np.array([off for _, off in ends], dtype=np.float64).reshape(len(ends), 3))


def position_errors(original: Motion, decoded: Motion, shell_distance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(joint, shell)`` errors ``(N, J)`` in file units; ``shell_distance`` in file units too."""
    if not (np.isfinite(shell_distance) and shell_distance > 0):
        raise InvalidParameterError(f"shell distance must be a positive number, got {shell_distance!r}")
    P0, R0 = forward_kinematics(original)
    P1, R1 = forward_kinematics(decoded)
    return errors_from_fk(P0, R0, P1, R1, shell_distance)


@numba.njit(cache=True)
def _quat_matrix(w, x, y, z, m):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    m[0, 0] = 1 - 2 * (y * y + z * z)
    m[0, 1] = 2 * (x * y - w * z)
    m[0, 2] = 2 * (x * z + w * y)
    m[1, 0] = 2 * (x * y + w * z)
    m[1, 1] = 1 - 2 * (x * x + z * z)
    m[1, 2] = 2 * (y * z - w * x)
    m[2, 0] = 2 * (x * z - w * y)
    m[2, 1] = 2 * (y * z + w * x)
    m[2, 2] = 1 - 2 * (x * x + y * y)


def worst_errors(parents, rot, trans, P0, R0, shell_distance, shell):
    """Per joint, the largest error over the given frames (``shell`` or joint metric) of the motion
    with local ``rot`` ``(n, J, 4)`` / ``trans`` ``(n, J, 3)`` against world ``P0``/``R0`` — forward
    kinematics frame by frame, compiled (the encoder's repair check; the final check uses
    :func:`position_errors`)."""
    n = rot.shape[0]
    none = np.zeros(0, dtype=np.int64)
    return worst_point_errors(parents, rot, trans, P0, R0, shell_distance, shell, none, np.zeros((0, 3)),
                              np.zeros((n, 0, 3)))[0]


@numba.njit(cache=True)
def worst_point_errors(parents, rot, trans, P0, R0, shell_distance, shell, end_joint, end_off, E0):
    """:func:`worst_errors` per joint ``(J,)`` and, for the End Sites (joints ``end_joint`` ``(E,)``,
    offsets ``end_off`` ``(E, 3)``, original world positions ``E0`` ``(n, E, 3)``), the largest
    distance of each over the frames ``(E,)``."""
    n, J = rot.shape[0], rot.shape[1]
    out = np.zeros(J)
    out_end = np.zeros(end_joint.shape[0])
    R = np.empty((J, 3, 3))
    P = np.empty((J, 3))
    L = np.empty((3, 3))
    for f in range(n):
        for j in range(J):
            _quat_matrix(rot[f, j, 0], rot[f, j, 1], rot[f, j, 2], rot[f, j, 3], L)
            p = parents[j]
            if p < 0:
                for a in range(3):
                    P[j, a] = trans[f, j, a]
                    for b in range(3):
                        R[j, a, b] = L[a, b]
            else:
                for a in range(3):
                    P[j, a] = (
                        P[p, a]
                        + R[p, a, 0] * trans[f, j, 0]
                        + R[p, a, 1] * trans[f, j, 1]
                        + R[p, a, 2] * trans[f, j, 2]
                    )
                    for b in range(3):
                        R[j, a, b] = R[p, a, 0] * L[0, b] + R[p, a, 1] * L[1, b] + R[p, a, 2] * L[2, b]
            dx = P[j, 0] - P0[f, j, 0]
            dy = P[j, 1] - P0[f, j, 1]
            dz = P[j, 2] - P0[f, j, 2]
            if shell:
                e = 0.0
                for a in range(3):
                    ex = dx + shell_distance * (R[j, 0, a] - R0[f, j, 0, a])
                    ey = dy + shell_distance * (R[j, 1, a] - R0[f, j, 1, a])
                    ez = dz + shell_distance * (R[j, 2, a] - R0[f, j, 2, a])
                    e = max(e, math.sqrt(ex * ex + ey * ey + ez * ez))
            else:
                e = math.sqrt(dx * dx + dy * dy + dz * dz)
            if e > out[j]:
                out[j] = e
        for k in range(end_joint.shape[0]):
            j = end_joint[k]
            e = 0.0
            for a in range(3):
                d = (
                    P[j, a]
                    + R[j, a, 0] * end_off[k, 0]
                    + R[j, a, 1] * end_off[k, 1]
                    + R[j, a, 2] * end_off[k, 2]
                    - E0[f, k, a]
                )
                e += d * d
            e = math.sqrt(e)
            if e > out_end[k]:
                out_end[k] = e
    return out, out_end
