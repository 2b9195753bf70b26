"""Skeleton panels of the scene: world joint positions by forward kinematics, in centimetres, and
each decoded joint's distance to the same joint of its original (the error the page colours by)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapkit.skeleton import Motion, forward_kinematics
from mocapkit.view.arrays import encode_array

#: suffixes read by :func:`load_skeleton` (glTF through the glTF reader, the rest through ``load_motion``)
GLTF_SUFFIXES = (".glb", ".gltf")


def load_skeleton(path: Path, asf: Path | None, strict: bool, rate: float | None = None
                  ) -> tuple[Motion, float | None, float | None]:
    """AMC files take ``asf`` and ``rate``. ``(motion, unit_cm or None when the file does not say, bound in cm or
    None)``."""
    from mocapkit.io.loaders import load_motion

    info = None
    if path.suffix.lower() in GLTF_SUFFIXES:
        from mocapkit.io.formats.gltf import read_gltf

        motion = read_gltf(path)
    elif path.suffix.lower() == ".mkc":  # one read of the clip: its motion and its header's bound and unit
        from mocapkit.jobs.readers import open_clip

        clip = open_clip(path)
        motion, info = clip.decode(), clip.info()
    else:
        motion = load_motion(path, asf=asf, rate=rate, strict=strict)
    unit = motion.skeleton.meta.get("length_unit_cm")
    bound = None
    if info is not None:
        b = info.get("bound") or {}
        if isinstance(b, dict) and b.get("value") is not None:
            bound = float(b["value"]) * float(info["unit_cm"])
        unit = info["unit_cm"] if unit is None else unit
    return motion, (None if unit is None else float(unit)), bound


def world_positions(motion: Motion, unit_cm: float) -> np.ndarray:
    """``(n, J, 3)`` joint positions in cm."""
    pos, _ = forward_kinematics(motion)
    return np.asarray(pos, dtype=np.float64) * unit_cm


def up_axis(motion: Motion) -> str:
    """The file's vertical axis: ``"z"`` when its reader says so (MVNX), else ``"y"`` (BVH, ASF/AMC, glTF)."""
    for meta in (motion.skeleton.meta, getattr(motion, "meta", None) or {}):
        if str(meta.get("up_axis", "")).lower() == "z":
            return "z"
    return "y"


def same_skeleton(a: Motion, b: Motion) -> bool:
    """A decode of ``a``: the same joint names in the same order and the same parents."""
    return list(a.skeleton.names) == list(b.skeleton.names) and list(a.skeleton.parents) == list(b.skeleton.parents)


def joint_errors(original: np.ndarray, decoded: np.ndarray) -> np.ndarray:
    """``(n, J)`` distance of each decoded joint to the original joint at the same frame."""
    return np.linalg.norm(decoded - original, axis=-1)


def skeleton_panel(pid: str, path: Path, motion: Motion, positions: np.ndarray, *, role: str = "original",
                   decoded_from: str | None = None, error: np.ndarray | None = None,
                   bound: float | None = None, up: str | None = None) -> dict:
    """The panel dict of docs/viewer.md (``kind: "skeleton"``); ``up`` defaults to :func:`up_axis`."""
    return {
        "id": pid, "kind": "skeleton", "file": str(path), "name": path.name, "up": up or up_axis(motion),
        "times": encode_array(motion.times, "float64"),
        "joints": list(motion.skeleton.names), "parents": [int(p) for p in motion.skeleton.parents],
        "unit": "cm", "positions": encode_array(positions), "role": role, "decoded_from": decoded_from,
        "error": None if error is None else encode_array(error),
        "max_error": None if error is None or error.size == 0 else float(error.max()),
        "bound": bound,
    }
