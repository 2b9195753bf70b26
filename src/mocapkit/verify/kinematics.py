"""Forward kinematics in plain NumPy: world positions and rotation matrices of every joint and the world
positions of the End Sites, from a skeleton and the local rotations and translations of each frame.

``R_j = R_parent · r_j`` and ``p_j = p_parent + R_parent · t_j`` (a root's parent is the identity at the
origin); an End Site of joint ``j`` with offset ``o`` is at ``p_j + R_j · o``. One ``einsum`` over all
frames per joint, joints in index order (parents come first in a :class:`~mocapkit.skeleton.Skeleton`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` matrices of scalar-first quaternions ``(..., 4)`` (normalised first)."""
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    rows = [[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


@dataclass(frozen=True)
class WorldPose:
    """``positions`` ``(N, J, 3)``, ``rotations`` ``(N, J, 3, 3)`` and ``end_sites`` ``(N, E, 3)`` in the
    skeleton's length unit."""

    positions: np.ndarray
    rotations: np.ndarray
    end_sites: np.ndarray


def world_pose(skeleton, rotations: np.ndarray, translations: np.ndarray) -> WorldPose:
    """The world pose of every frame of local ``rotations`` ``(N, J, 4)`` and ``translations`` ``(N, J, 3)``."""
    parents = [int(p) for p in skeleton.parents]
    local = rotation_matrices(rotations)
    t = np.asarray(translations, dtype=np.float64)
    n, joints = t.shape[0], len(parents)
    pos = np.empty((n, joints, 3))
    rot = np.empty((n, joints, 3, 3))
    for j, p in enumerate(parents):
        if p < 0:
            rot[:, j], pos[:, j] = local[:, j], t[:, j]
        else:
            rot[:, j] = np.einsum("nab,nbc->nac", rot[:, p], local[:, j])
            pos[:, j] = pos[:, p] + np.einsum("nab,nb->na", rot[:, p], t[:, j])
    ends = np.empty((n, len(skeleton.end_sites), 3))
    for e, (j, off) in enumerate(skeleton.end_sites):
        ends[:, e] = pos[:, int(j)] + np.einsum("nab,b->na", rot[:, int(j)], np.asarray(off, dtype=np.float64))
    return WorldPose(pos, rot, ends)
