"""An original against its decode, sample by sample: the angle of every IMU sample (after the SLERP decode
of the compressed points at the original's samples, never across a lost packet) and, for skeletons, the
world distance of every joint and End Site and ACL's shell metric (the points ``d`` along each joint's
three local axes), in centimetres. Each comparison keeps its whole error array, its largest value and
where that is, and its mean."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapkit.verify.kinematics import WorldPose, world_pose
from mocapkit.verify.quaternions import angle_deg, interpolate


def decode_runs(at: np.ndarray, point_at: np.ndarray, points: np.ndarray, gap_before: np.ndarray | None = None
                ) -> np.ndarray:
    """``(m, 4)`` SLERP decode at ``at`` of the points (at increasing ``point_at``), NaN rows where ``at`` lies
    outside every run of points with no lost packet between them (``gap_before[k]``: a packet was lost
    before point ``k``; the decode never bridges it)."""
    at = np.asarray(at, dtype=np.float64)
    out = np.full((len(at), 4), np.nan)
    if len(point_at) == 0:
        return out
    gaps = np.zeros(len(point_at), dtype=bool) if gap_before is None else np.asarray(gap_before, dtype=bool)
    starts = [0, *np.flatnonzero(gaps[1:]) + 1, len(point_at)]
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        lo, hi = np.searchsorted(at, point_at[a], "left"), np.searchsorted(at, point_at[b - 1], "right")
        if hi > lo:
            out[lo:hi] = interpolate(at[lo:hi], point_at[a:b], points[a:b])
    return out


@dataclass(frozen=True)
class ImuComparison:
    """One sensor: ``errors_deg`` ``(n,)`` with NaN at the samples the decode leaves out."""

    name: str
    times: np.ndarray
    errors_deg: np.ndarray

    def summary(self) -> dict:
        ok = np.isfinite(self.errors_deg)
        out = {"name": self.name, "samples": len(self.times), "compared_samples": int(ok.sum()),
               "samples_not_decoded": int((~ok).sum()), "max_deg": None, "mean_deg": None, "max_at": None}
        if ok.any():
            k = int(np.nanargmax(self.errors_deg))
            out.update(max_deg=float(self.errors_deg[k]), mean_deg=float(self.errors_deg[ok].mean()),
                       max_at={"sample": k, "time_s": float(self.times[k])})
        return out


def compare_imu(name: str, times: np.ndarray, original: np.ndarray, decoded: np.ndarray) -> ImuComparison:
    """The angle between each original sample and its decode (NaN rows of ``decoded``: not compared)."""
    err = np.full(len(times), np.nan)
    ok = np.isfinite(decoded).all(axis=1)
    if ok.any():
        err[ok] = angle_deg(np.asarray(original, dtype=np.float64)[ok], decoded[ok])
    return ImuComparison(name, np.asarray(times, dtype=np.float64), err)


def end_site_names(skeleton) -> list[str]:
    """``"<joint> End Site"`` for each End Site (numbered after the first when a joint has several)."""
    seen: dict[int, int] = {}
    names = []
    for j, _ in skeleton.end_sites:
        k = seen.get(int(j), 0)
        seen[int(j)] = k + 1
        names.append(f"{skeleton.names[int(j)]} End Site" + (f" {k + 1}" if k else ""))
    return names


def _extreme(err: np.ndarray, times: np.ndarray, names: list[str]) -> dict:
    """Max and mean of ``err`` ``(N, K)``, and the frame, time and name of the max."""
    if err.size == 0:
        return {"max_cm": None, "mean_cm": None, "max_at": None}
    f, k = np.unravel_index(int(np.argmax(err)), err.shape)
    return {"max_cm": float(err[f, k]), "mean_cm": float(err.mean()),
            "max_at": {"frame": int(f), "time_s": float(times[f]), "point": names[k]}}


@dataclass(frozen=True)
class SkeletalComparison:
    """Errors in cm: ``joints`` ``(N, J)``, ``end_sites`` ``(N, E)``, ``shell`` ``(N, J)``."""

    times: np.ndarray
    joint_names: list[str]
    end_site_names: list[str]
    joints: np.ndarray
    end_sites: np.ndarray
    shell: np.ndarray
    shell_distance_cm: float

    def summary(self) -> dict:
        both = np.concatenate([self.joints, self.end_sites], axis=1)
        pos = _extreme(both, self.times, self.joint_names + self.end_site_names)
        if pos["max_at"] is not None:
            pos["max_at"]["kind"] = "joint" if int(np.argmax(both)) % both.shape[1] < len(self.joint_names) \
                else "end_site"
        return {"positions": pos, "joints": _extreme(self.joints, self.times, self.joint_names),
                "end_sites": _extreme(self.end_sites, self.times, self.end_site_names),
                "shell": {**_extreme(self.shell, self.times, self.joint_names),
                          "shell_distance_cm": self.shell_distance_cm}}


def shell_errors(a: WorldPose, b: WorldPose, d: float) -> np.ndarray:
    """ACL's shell metric ``(N, J)``: per joint and frame the largest distance between the original's and the
    decode's points ``p + d · R · e_x``, ``... e_y``, ``... e_z`` (``R`` the joint's world rotation)."""
    out = np.zeros(a.positions.shape[:2])
    for axis in range(3):
        pa = a.positions + d * a.rotations[..., :, axis]
        pb = b.positions + d * b.rotations[..., :, axis]
        np.maximum(out, np.linalg.norm(pb - pa, axis=-1), out=out)
    return out


def compare_skeletal(original, decoded, unit_cm: float, shell_distance_cm: float) -> SkeletalComparison:
    """Two motions of one skeleton and frame count (``mocapkit.skeleton.Motion``, lengths in the same file
    unit, ``unit_cm`` cm each) compared frame by frame."""
    a = world_pose(original.skeleton, original.rotations, original.translations)
    b = world_pose(decoded.skeleton, decoded.rotations, decoded.translations)  # its own End Site offsets
    joints = np.linalg.norm(b.positions - a.positions, axis=-1) * unit_cm
    ends = np.linalg.norm(b.end_sites - a.end_sites, axis=-1) * unit_cm
    shell = shell_errors(a, b, shell_distance_cm / unit_cm) * unit_cm
    return SkeletalComparison(np.asarray(original.times, dtype=np.float64), list(original.skeleton.names),
                              end_site_names(original.skeleton), joints, ends, shell, float(shell_distance_cm))

