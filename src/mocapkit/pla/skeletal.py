"""Whole-skeleton compression: every joint's local rotation is a quaternion stream, every animated
local translation a 3-D vector stream, each compressed with the PLA methods.

Error in the user's terms (``max_position_error``): every joint's *world-space* position in every
frame stays within the bound (and every End Site's with ``end_sites=True``, what ``compress`` asks by
default: the reach below covers End Sites, which a joint's own rotation moves too). A rotation error ``δ`` at joint
``i`` moves every descendant ``k`` by at most ``2·sin(δ/2)·|p_k − p_i|``, and errors of a chain add up (triangle
inequality, distances being kept by rotations), so with ``reach_i`` = the largest distance from joint ``i`` to any of
its descendants or end sites (over all frames, from forward kinematics) and ``H`` the largest number of
animated joints on a root-to-leaf chain, budgets of ``E/H`` per joint — angle
``2·asin(E/(2·H·reach_i))`` for its rotation (encoded with the angle-bounded SW, which guarantees it)
and ``E/H`` for its translation (Swing Filter with ``ε = E/(H·√3)``) — guarantee ``E`` everywhere. That
allocation is safe but pessimistic, since errors seldom align: every track therefore starts at ``2H``
times its safe budget, one forward kinematics of the decoded motion finds the joints beyond ``E``, and
only the tracks that move them are tightened (by √2) and re-encoded, until none is beyond or every
such track is back within its safe budget — the same check is run on the final result.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mocapkit.errors import BoundViolationError, InvalidParameterError, UnreachableTargetError
from mocapkit.motion import Signal
from mocapkit.pla.base import Compressed, check_method, compress
from mocapkit.pla.decode import reconstruct, reconstruct_points, unit_quaternions
from mocapkit.quat import slerp
from mocapkit.skeleton import Motion, forward_kinematics

BOUND_TOL = 1e-9  # relative slack when checking the position bound (float rounding of two FK runs)


@dataclass
class SkeletalCompressed:
    """Keyframes of every animated track of a motion."""

    motion: Motion
    method: str
    rotations: dict[int, Compressed] = field(default_factory=dict)  # joint -> quaternion track
    translations: dict[int, Compressed] = field(default_factory=dict)  # joint -> vector track
    info: dict = field(default_factory=dict)

    @property
    def n_keyframes(self) -> int:
        return sum(c.n_points for c in self.rotations.values()) + sum(c.n_points for c in self.translations.values())

    @property
    def n_samples(self) -> int:
        return sum(c.n_samples for c in self.rotations.values()) + sum(c.n_samples for c in self.translations.values())

    @property
    def icr(self) -> float:
        """Keyframes / original samples over all tracks (Eq. 1 of the fastSW paper, pooled)."""
        return self.n_keyframes / max(self.n_samples, 1)

    def bytes_raw(self) -> int:
        """Every frame of every track as float32: 16 bytes a rotation, 12 a translation."""
        n = self.motion.n_frames
        return n * (16 * len(self.rotations) + 12 * len(self.translations))

    def bytes_out(self) -> int:
        """Keyframes as float32 time + value (what the glTF buffer holds, without padding)."""
        return sum(20 * c.n_points for c in self.rotations.values()) + sum(
            16 * c.n_points for c in self.translations.values()
        )

    def decode(self) -> Motion:
        """Full-rate motion (SLERP / linear between keyframes) at the original frame times."""
        m = self.motion
        rot = m.rotations.copy()
        trans = m.translations.copy()
        _decode_tracks(self.rotations, m.times, rot)
        _decode_tracks(self.translations, m.times, trans)
        return Motion(m.skeleton, m.times, rot, trans, channel_values=None, source=m.source, meta=dict(m.meta))


def _decode_tracks(tracks: dict[int, Compressed], times: np.ndarray, out: np.ndarray) -> None:
    """``out[:, j] = reconstruct(tracks[j], times)`` for every track; tracks with the same keyframe
    times are decoded in one batch (the same SLERP / linear formula over a joint axis), so the Python
    work per call is per distinct keyframe-time set, not per joint (10,000-joint chains)."""
    groups: dict[tuple, list[int]] = {}
    for j, c in tracks.items():
        groups.setdefault((c.kind, c.times.shape[0], c.times.tobytes()), []).append(j)
    for (kind, _, _), js in groups.items():
        if len(js) == 1:
            out[:, js[0]] = reconstruct(tracks[js[0]], times)
            continue
        pt = tracks[js[0]].times
        pv = np.stack([tracks[j].values for j in js], axis=1)  # (M, T, D)
        M, T, D = pv.shape
        if kind != "quaternion":
            out[:, js] = reconstruct_points(pt, pv.reshape(M, T * D), times, kind).reshape(-1, T, D)
            continue
        pv = unit_quaternions(pv.reshape(M * T, D)).reshape(M, T, D)  # also refuses NaN and zero norms
        # one check of the span and order, as reconstruct_points does, on the shared times
        reconstruct_points(pt, pv[:, 0], np.array([times.min(), times.max()]), kind)
        if M == 1:
            out[:, js] = pv[0][None]
            continue
        k = np.clip(np.searchsorted(pt, times, side="right") - 1, 0, M - 2)
        f = (times - pt[k]) / (pt[k + 1] - pt[k])
        out[:, js] = slerp(pv[k], pv[k + 1], f[:, None])


def animated_tracks(motion: Motion) -> tuple[list[int], list[int]]:
    """Joints whose rotation / translation varies (or is animated by the file's channels)."""
    sk = motion.skeleton
    rot = [j for j in range(sk.n_joints) if sk.rotation_order(j) or np.ptp(motion.rotations[:, j], axis=0).max() > 0]
    tr = [j for j in range(sk.n_joints) if sk.has_position(j)]
    return rot, tr


def position_errors(original: Motion, decoded: Motion, end_sites: bool = False) -> np.ndarray:
    """``(N, J)`` world-space distance of every joint in every frame (file units); with ``end_sites``
    ``(N, J + E)``: the End Sites' distances follow the joints'."""
    if not end_sites:
        return np.linalg.norm(forward_kinematics(decoded)[0] - forward_kinematics(original)[0], axis=-1)
    P0, _, E0 = forward_kinematics(original, end_sites=True)
    P1, _, E1 = forward_kinematics(decoded, end_sites=True)
    return np.linalg.norm(np.concatenate([P1 - P0, E1 - E0], axis=1), axis=-1)


REACH_EXACT_BUDGET = 20_000_000  # joint-pair distances computed exactly at most (else a safe upper bound)


def _reach(motion: Motion) -> np.ndarray:
    """Per joint, the largest distance (over frames) to any descendant joint or end site.

    Exact (every descendant's distance, one NumPy batch per joint over its subtree, a contiguous run
    of the depth-first order) while the number of joint-descendant pairs times frames stays within
    :data:`REACH_EXACT_BUDGET`; beyond (deep chains of thousands of joints) the triangle-inequality
    bound ``reach_i <= max_c (max_t |p_c - p_i| + reach_c)`` over children ``c`` and end sites, computed
    leaves first in one pass. A larger reach only gives a joint a smaller angle budget, so the
    position guarantee holds either way. No recursion: any depth works."""
    sk = motion.skeleton
    P, _, E = forward_kinematics(motion, end_sites=True)
    J, N = sk.n_joints, motion.n_frames
    parents = sk.parents.tolist()
    reach = np.zeros(J)
    order = sk.depth_first()
    size = np.ones(J, dtype=np.int64)
    for j in reversed(order):
        if parents[j] >= 0:
            size[parents[j]] += size[j]
    if int(size.sum() - J) * N <= REACH_EXACT_BUDGET:
        pos = np.empty(J, dtype=np.int64)
        pos[order] = np.arange(J)
        order_arr = np.asarray(order, dtype=np.int64)
        end_order = sorted(range(len(sk.end_sites)), key=lambda e: pos[sk.end_sites[e][0]])
        end_pos = np.array([pos[sk.end_sites[e][0]] for e in end_order], dtype=np.int64)
        ends = np.asarray(end_order, dtype=np.int64)
        for j in range(J):
            a, b = int(pos[j]), int(pos[j] + size[j])
            r = 0.0
            if b - a > 1:
                r = float(np.linalg.norm(P[:, order_arr[a + 1:b]] - P[:, j:j + 1], axis=-1).max())
            lo, hi = np.searchsorted(end_pos, [a, b])
            if hi > lo:
                r = max(r, float(np.linalg.norm(E[:, ends[lo:hi]] - P[:, j:j + 1], axis=-1).max()))
            reach[j] = r
        return reach
    for e, (j, _) in enumerate(sk.end_sites):
        reach[j] = max(reach[j], float(np.linalg.norm(E[:, e] - P[:, j], axis=-1).max()))
    for j in reversed(order):  # children before parents
        p = parents[j]
        if p >= 0:
            reach[p] = max(reach[p], float(np.linalg.norm(P[:, j] - P[:, p], axis=-1).max()) + reach[j])
    return reach


def _chain_depth(motion: Motion, rot: list[int], tr: list[int]) -> int:
    """Largest number of animated tracks on a root-to-joint chain (one pass, parents first)."""
    sk = motion.skeleton
    count = np.zeros(sk.n_joints, dtype=np.int64)
    count[list(rot)] += 1
    count[list(tr)] += 1
    for j, p in enumerate(sk.parents.tolist()):
        if p >= 0:
            count[j] += count[p]
    return max(1, int(count.max())) if (rot or tr) else 1


def _signals(motion: Motion, rot: list[int], tr: list[int]):
    rs = {j: Signal(motion.times, motion.rotations[:, j], "quaternion", name=motion.skeleton.names[j]) for j in rot}
    ts = {j: Signal(motion.times, motion.translations[:, j], "vector", name=motion.skeleton.names[j]) for j in tr}
    return rs, ts


def compress_motion(
    motion: Motion,
    method: str = "fastsw",
    *,
    threshold: float | None = None,
    target_icr: float | None = None,
    max_position_error: float | None = None,
    max_segment_length: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    end_sites: bool = False,
) -> SkeletalCompressed:
    """Compress every track of ``motion``.

    Parameters
    ----------
    method
        PLA method for the rotation tracks; translation tracks use the matching rule of
        :func:`_translation_rule`. With ``max_position_error`` rotations use ``anglesw`` (its bound
        is an angle) and translations the Swing Filter, whatever is asked; the report says so.
    threshold
        The method's own threshold, the same for every rotation track.
    target_icr
        Pooled ICR over all tracks; one threshold found by bisection.
    max_position_error
        Bound on every joint's world position error in every frame, in file units (see module notes);
        with ``end_sites`` every End Site's too.
    progress
        Called as ``progress(done, total)`` after each full compression of the searches (bisection
        steps of ``target_icr`` and ``max_position_error``).
    """
    method = check_method(method)
    given = [x is not None for x in (threshold, target_icr, max_position_error)]
    if sum(given) != 1:
        raise InvalidParameterError("give exactly one of threshold, target ICR, max position error")
    rot, tr = animated_tracks(motion)
    rs, ts = _signals(motion, rot, tr)
    out = SkeletalCompressed(motion, method)
    if threshold is not None:
        size = _size(motion)
        for j, sg in rs.items():
            out.rotations[j] = compress(sg, method, threshold, max_segment_length)
        tm, tt = _translation_rule(method, threshold, size)
        for j, sg in ts.items():
            out.translations[j] = compress(sg, tm, tt, max_segment_length)
        out.info = {"mode": "threshold", "threshold": threshold, "translation_method": tm, "translation_threshold": tt}
        return out
    if target_icr is not None:
        return _to_icr(motion, method, target_icr, rs, ts, max_segment_length, progress)
    assert max_position_error is not None  # exactly one of the three is given (checked above)
    return _to_position_bound(motion, float(max_position_error), rs, ts, max_segment_length, progress, end_sites)


def _size(motion: Motion) -> float:
    """Characteristic length of the skeleton: the largest reach from a root (file units)."""
    r = _reach(motion)
    roots = [j for j in range(motion.skeleton.n_joints) if motion.skeleton.parents[j] < 0]
    return max((float(r[j]) for j in roots), default=1.0) or 1.0


def _translation_rule(method: str, th: float, size: float) -> tuple[str, float]:
    """The translation tracks' method and threshold matching a rotation threshold: a translation
    error of ``δ·size`` weighs like a rotation error of ``δ`` radians seen at the skeleton's size, so
    SSR thresholds scale by ``size²``, the Swing Filter's ε by ``size``, and an angle (anglesw, which
    needs quaternions) becomes a Swing Filter ε of ``size·θ``."""
    if method == "anglesw":
        return "swing", size * math.radians(th)
    if method == "swing":
        return "swing", size * th
    return method, size * size * th


def _to_icr(motion, method, target, rs, ts, maxlen, progress=None) -> SkeletalCompressed:
    """One threshold for every track (translations mapped by :func:`_translation_rule`), found by
    bisection on the pooled ICR."""
    if not (0.0 < target <= 1.0):
        raise InvalidParameterError(f"target ICR must be in (0, 1], got {target!r}")
    lo, hi = (-9.0, math.log10(360.0)) if method == "anglesw" else (-15.0, 6.0)
    size = _size(motion)

    def run(lg: float) -> SkeletalCompressed:
        th = 10.0**lg
        out = SkeletalCompressed(motion, method)
        for j, sg in rs.items():
            out.rotations[j] = compress(sg, method, th, maxlen)
        tm, tt = _translation_rule(method, th, size)
        for j, sg in ts.items():
            out.translations[j] = compress(sg, tm, tt, maxlen)
        out.info = {"mode": "target_icr", "target": target, "threshold": th,
                    "translation_method": tm, "translation_threshold": tt}
        return out

    tick = progress or (lambda done, total: None)
    best = run(hi)
    tick(1, 41)
    if best.icr > target:
        raise UnreachableTargetError(f"ICR {target:g} is out of reach: the loosest threshold gives {best.icr:.4g}")
    for i in range(40):
        mid = 0.5 * (lo + hi)
        c = run(mid)
        tick(i + 2, 41)
        if c.icr <= target:
            hi, best = mid, c
        else:
            lo = mid
    return best


def _to_position_bound(motion, E, rs, ts, maxlen, progress=None, end_sites=False) -> SkeletalCompressed:
    """Check once, repair locally: every track starts at ``START_SCALE`` times its safe budget
    (module notes); one forward kinematics finds the joints beyond ``E``; only the tracks that move
    them (their ancestors' rotations, their own and their ancestors' translations) are tightened by
    √2 and re-encoded, and the check runs again. At scale ≤ 1 a track is within its safe budget, so
    the repair ends; the result is checked like every other. With ``end_sites`` the End Sites are
    checked too (``reach`` already covers them; an End Site is also moved by its joint's rotation)."""
    if not (math.isfinite(E) and E > 0):
        raise InvalidParameterError(f"max position error must be a positive number, got {E!r}")
    reach = _reach(motion)
    H = _chain_depth(motion, list(rs), list(ts))
    P0, _, E0 = forward_kinematics(motion, end_sites=True)  # the original's positions, computed once
    ends = [j for j, _ in motion.skeleton.end_sites] if end_sites else []
    if not end_sites:
        E0 = E0[:, :0]
    J = motion.skeleton.n_joints
    floor = 1e-9 * max(1.0, float(np.abs(P0).max()))  # far above float64 FK round-off (~1e-15 relative)
    if E < floor:
        raise InvalidParameterError(f"max position error {E:g} is below what float64 forward kinematics "
                                    f"resolves on this skeleton ({floor:.3g} in its length unit)")
    start = 2.0 * H  # errors of a chain seldom align: start near E per track, not E/H
    safe_level = math.ceil(2.0 * math.log2(start))  # scale = start·2^(−level/2) <= 1 from here on
    level = {("r", j): 0 for j in rs} | {("t", j): 0 for j in ts}
    out = SkeletalCompressed(motion, "anglesw")

    def encode(key) -> None:
        kind, j = key
        share = start * 2.0 ** (-level[key] / 2.0) * E / H
        if kind == "t":
            out.translations[j] = compress(ts[j], "swing", share / math.sqrt(3.0), maxlen)
        elif reach[j] <= 0:  # nothing hangs below this joint: its rotation moves no position
            out.rotations[j] = compress(rs[j], "anglesw", 180.0, maxlen)
        else:
            out.rotations[j] = compress(
                rs[j], "anglesw", math.degrees(2.0 * math.asin(min(1.0, share / (2.0 * reach[j])))), maxlen
            )

    parents = motion.skeleton.parents.tolist()

    def movers(k: int) -> set:
        if k >= J:  # an End Site: its joint's rotation and what moves its joint
            k = ends[k - J]
            return movers(k) | ({("r", k)} & level.keys())
        found = {("t", k)} & level.keys()
        p = parents[k]
        while p >= 0:
            found |= {("r", p), ("t", p)} & level.keys()
            p = parents[p]
        return found

    tick = progress or (lambda done, total: None)
    for key in level:
        encode(key)
    rounds = 0
    while True:
        P1, _, E1 = forward_kinematics(out.decode(), end_sites=True)
        if not end_sites:
            E1 = E1[:, :0]
        worst = np.linalg.norm(np.concatenate([P1 - P0, E1 - E0], axis=1), axis=-1).max(axis=0)
        err = float(worst.max())
        bad = np.flatnonzero(worst > E * (1 - 1e-6))  # a margin for the rounding of written files
        keys = {k for j in bad.tolist() for k in movers(j) if level[k] < safe_level}
        rounds += 1
        if rounds <= safe_level:  # progress: one step a round (an estimate: rounds seldom exceed it)
            tick(rounds, safe_level + 1)
        if not keys:
            break
        for key in keys:
            level[key] += 1
            encode(key)
    done = min(rounds, safe_level) + 1
    tick(done, done)  # the last step: the estimated total becomes the real one
    if err > E * (1 + BOUND_TOL):  # cannot happen if the analysis holds: report, never hide
        raise BoundViolationError(f"the safe allocation gives {err:.6g} > {E:g}")
    out.info = {"mode": "max_position_error", "bound": E, "chain_depth": H, "repair_rounds": rounds,
                "tightened_tracks": sum(v > 0 for v in level.values()), "max_position_error": err}
    return out


def verify_position_bound(motion: Motion, comp: SkeletalCompressed, bound: float, end_sites: bool = False) -> float:
    """Independent check by forward kinematics of the decoded motion (joints, and End Sites with
    ``end_sites``); returns the max error."""
    err = float(position_errors(motion, comp.decode(), end_sites).max())
    if err > bound * (1 + BOUND_TOL):
        raise BoundViolationError(f"world position error {err:.6g} exceeds the bound {bound:g}")
    return err


def report(comp: SkeletalCompressed, unit_cm: float | None = None) -> dict:
    """The numbers of a skeletal compression (positions in cm when ``unit_cm`` is known)."""
    from mocapkit.quat import angular_distance

    m = comp.motion
    dec = comp.decode()
    perr = position_errors(m, dec)
    eerr = position_errors(m, dec, end_sites=True)[:, m.skeleton.n_joints:]
    k = unit_cm if unit_cm is not None else float("nan")
    per_track = [angular_distance(m.rotations[:, j], dec.rotations[:, j], degrees=True) for j in comp.rotations]
    ang = np.concatenate(per_track) if per_track else np.zeros(1)
    return {
        "method": comp.method,
        **{k2: v for k2, v in comp.info.items() if k2 != "max_position_error"},
        "n_frames": m.n_frames,
        "n_joints": m.skeleton.n_joints,
        "rotation_tracks": len(comp.rotations),
        "translation_tracks": len(comp.translations),
        "keyframes": comp.n_keyframes,
        "icr": comp.icr,
        "max_position_error": float(perr.max()),
        "mean_position_error": float(perr.mean()),
        "max_position_error_cm": float(perr.max()) * k,
        "mean_position_error_cm": float(perr.mean()) * k,
        "max_end_site_error_cm": float(eerr.max(initial=0.0)) * k,
        "unit_cm": unit_cm,
        "aad_deg": float(ang.mean()),
        "max_deg": float(ang.max()),
        "bytes_raw": comp.bytes_raw(),
        "bytes_out": comp.bytes_out(),
        "ratio": comp.bytes_raw() / max(comp.bytes_out(), 1),
    }
