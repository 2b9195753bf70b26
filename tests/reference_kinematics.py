"""Independent references for skeletal tests: forward kinematics by scipy rotations (no mocapkit
kinematics) and the Khronos glTF validator that `make test` installs."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]


def naive_positions(motion) -> np.ndarray:
    """World joint positions frame by frame, joint by joint (scipy rotations, Python loops)."""
    sk = motion.skeleton
    N, J = motion.n_frames, sk.n_joints
    out = np.zeros((N, J, 3))
    for f in range(N):
        world = [None] * J
        for j in range(J):
            r = Rotation.from_quat(motion.rotations[f, j][[1, 2, 3, 0]])
            p = sk.parents[j]
            if p < 0:
                world[j], out[f, j] = r, motion.translations[f, j]
            else:
                world[j] = world[p] * r
                out[f, j] = out[f, p] + world[p].apply(motion.translations[f, j])
    return out


def naive_end_sites(motion) -> np.ndarray:
    """``(N, E, 3)`` world End Site positions: scipy rotations composed root to joint (batched over
    frames), no mocapkit kinematics."""
    sk = motion.skeleton
    N, J = motion.n_frames, sk.n_joints
    P = np.zeros((N, J, 3))
    world = [None] * J
    for j in range(J):
        local = Rotation.from_quat(motion.rotations[:, j][:, [1, 2, 3, 0]])
        p = sk.parents[j]
        if p < 0:
            world[j], P[:, j] = local, motion.translations[:, j]
        else:
            world[j] = world[p] * local
            P[:, j] = P[:, p] + world[p].apply(motion.translations[:, j])
    out = np.zeros((N, len(sk.end_sites), 3))
    for e, (j, off) in enumerate(sk.end_sites):
        out[:, e] = P[:, j] + world[j].apply(np.asarray(off, dtype=np.float64))
    return out


def gltf_validator() -> tuple[str, Path]:
    """``(node, node_modules)`` of the Khronos validator; skips where node/npm are missing."""
    node = shutil.which("node")
    mods = ROOT / ".venv" / "node" / "node_modules"
    if node is None:
        pytest.skip("node is not installed")
    if not (mods / "gltf-validator").is_dir():
        if shutil.which("npm") is None:
            pytest.skip("npm is not installed, so `make test` could not install the glTF validator")
        pytest.fail(f"gltf-validator missing in {mods}: `make test` installs it")
    return node, mods
