"""Encode a skeletal motion as a ``.mkc`` clip whose decoded motion keeps every point within a bound.

1. **Tracks** (one per joint and kind): *default* (the identity rotation / the joint's offset in every
   frame: nothing stored), *constant* (one value, stored exactly; also a track whose values fit in its
   tolerance corridor), *animated* (rotation vectors, :mod:`~mocapkit.rotvec`, or translations).
2. **Budget** (:mod:`~mocapkit.clip.budget`): every track's tolerance ``τ`` from the hierarchy, such
   that the worst case (all errors aligned) keeps every point of the metric (joints, End Sites or shell
   points) within the bound.
3. **Blocks** of ``block_frames`` frames, each coded on its own (random access). In every block every
   animated track gets keyframes on a grid (:mod:`~mocapkit.clip.keys`) at ``S0 = 4`` times its
   worst-case tolerance first, with the grid step (``2τ``, ``√2τ`` or ``τ``) and predictor order (1 or
   2) that cost fewest estimated bits.
4. **Check once, repair locally**: the blocks are decoded exactly as a reader decodes them and forward
   kinematics gives every point's error in every frame; in a block where a point exceeds the bound,
   only the tracks that move that point are re-encoded, √2 tighter, and only that block is checked
   again. At ``S0·2^(−r/2) ≤ 1`` a track is within its worst-case budget, so the repair ends.
5. **Entropy stage** per block (:mod:`~mocapkit.clip.codec`), container (:mod:`mocapkit.clip.container`), and a
   final check of the written bytes by the reader (:class:`~mocapkit.clip.decoder.Clip`) alone.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocapkit import __version__
from mocapkit.clip.budget import track_tolerances
from mocapkit.clip.codec import ENTROPY, entropy_encode, pack_block, steps_table, unpack_block
from mocapkit.clip.container import mkc_bytes
from mocapkit.clip.decoder import Clip
from mocapkit.clip.keys import choose_keys
from mocapkit.clip.metric import check_metric, end_errors_from_fk, end_site_arrays, errors_from_fk, worst_point_errors
from mocapkit.errors import BoundViolationError, InvalidParameterError
from mocapkit.rotvec import exp_map, log_map
from mocapkit.skeleton import Motion, forward_kinematics

DEFAULT_BLOCK_FRAMES = 512
START_LEVELS = 4
FLOOR_LEVELS = 3  # repair goes down to 2^(-3/2) of the worst-case tolerance at most (float slack)


@dataclass
class _Track:
    joint: int
    kind: str  # "rotation" | "translation"
    cls: str  # "default" | "constant" | "animated"
    value: np.ndarray | None = None  # constant value (quaternion or translation)
    x: np.ndarray | None = None  # (N, 3) values of an animated track
    tol: float = math.inf  # worst-case per-component tolerance
    base: float = 0.0  # grid step at level 0


@dataclass
class EncodedClip:
    """The file's bytes and what the encoder measured on them."""

    data: bytes
    report: dict = field(default_factory=dict)


def _tracks(motion: Motion) -> list[_Track]:
    sk = motion.skeleton
    out = []
    for j in range(sk.n_joints):
        q = motion.rotations[:, j]
        if np.all(q == q[0]):
            if not np.array_equal(q[0], [1.0, 0.0, 0.0, 0.0]):
                out.append(_Track(j, "rotation", "constant", value=q[0].copy()))
        else:
            out.append(_Track(j, "rotation", "animated", x=log_map(q)))
        p = motion.translations[:, j]
        if np.all(p == p[0]):
            if not np.array_equal(p[0], sk.offsets[j]):
                out.append(_Track(j, "translation", "constant", value=p[0].copy()))
        else:
            out.append(_Track(j, "translation", "animated", x=np.ascontiguousarray(p)))
    return out


def encode_clip(motion: Motion, bound: float, *, metric: str = "shell", shell_distance: float = 1.0,
                unit_cm: float | None = None, block_frames: int = DEFAULT_BLOCK_FRAMES, source: str = "",
                entropy: str = "zstd", progress: Callable[[int, int], None] | None = None) -> EncodedClip:
    """Encode ``motion`` so that no joint or End Site (``metric="joint+end"``), joint (``"joint"``) or
    shell point (``"shell"``, at ``shell_distance`` along each joint's local axes) moves by more than
    ``bound`` in any frame.

    ``bound`` and ``shell_distance`` are in the motion's length unit; ``unit_cm`` (cm per unit) is
    recorded in the file. ``entropy``: ``"zstd"`` (fast to decode), ``"lzma"`` (a few % smaller) or
    ``"smallest"`` per block. Raises :class:`~mocapkit.errors.BoundViolationError` rather than return a
    file that the reader would decode beyond the bound.
    """
    t_start = time.perf_counter()
    check_metric(metric)
    if not (math.isfinite(bound) and bound > 0):
        raise InvalidParameterError(f"max position error must be a positive number, got {bound!r}")
    if not (math.isfinite(shell_distance) and shell_distance > 0):
        raise InvalidParameterError(f"shell distance must be a positive number, got {shell_distance!r}")
    if entropy not in ENTROPY:
        raise InvalidParameterError(f"entropy stage must be one of {', '.join(ENTROPY)}, got {entropy!r}")
    if not (isinstance(block_frames, int) and block_frames >= 2):
        raise InvalidParameterError(f"block length must be an integer >= 2 frames, got {block_frames!r}")
    sk, N = motion.skeleton, motion.n_frames
    P0, R0, E0 = forward_kinematics(motion, end_sites=True)
    with_ends = metric == "joint+end"
    end_joint, end_off = end_site_arrays(sk)
    if not with_ends:
        end_joint, end_off, E0 = end_joint[:0], end_off[:0], E0[:, :0]
    floor = 1e-9 * max(1.0, float(np.abs(P0).max()))
    if bound < floor:
        raise InvalidParameterError(f"max position error {bound:g} is below what float64 forward kinematics "
                                    f"resolves on this skeleton ({floor:.3g} in its length unit)")
    tracks = _tracks(motion)
    anim = [t for t in tracks if t.cls == "animated"]
    rt, tt = track_tolerances(sk, P0, [t.joint for t in anim if t.kind == "rotation"],
                              [t.joint for t in anim if t.kind == "translation"], bound, metric, shell_distance,
                              ends=E0)
    finite = [v for v in rt.values() if math.isfinite(v)]
    free_rot = min(finite) if finite else 1e-3  # a rotation no point of the metric sees: still kept close
    for t in anim:
        t.tol = (rt if t.kind == "rotation" else tt)[t.joint]
        if not math.isfinite(t.tol):
            t.tol = free_rot
        assert t.x is not None  # _tracks gives every animated track its values
        lo, hi = t.x.min(axis=0), t.x.max(axis=0)
        if np.all(hi - lo <= 2.0 * t.tol):  # one value fits the corridor: a constant track
            mid = 0.5 * (lo + hi)
            t.cls, t.value = "constant", (exp_map(mid) if t.kind == "rotation" else mid)
        t.base = 2.0 * t.tol * 2.0 ** (START_LEVELS / 2)
    anim = [t for t in anim if t.cls == "animated"]
    if anim and max(float(np.abs(t.x).max()) / t.base for t in anim if t.x is not None) >= 2.0**40:
        raise InvalidParameterError(f"max position error {bound:g} is too small for the range of this motion's values")
    starts = list(range(0, N, block_frames))
    spans = [(a, min(a + block_frames, N)) for a in starts]
    if len(spans) > 1 and spans[-1][1] - spans[-1][0] < 2:  # no one-frame last block
        spans[-2] = (spans[-2][0], N)
        spans.pop()
    B, T = len(spans), len(anim)
    dims = np.full(T, 3, dtype=np.int64)
    table = steps_table(np.array([t.base for t in anim]))
    r = np.zeros((B, T), dtype=np.int64)
    keys: list[list] = [[None] * T for _ in range(B)]

    # the points each track moves: the subtree of its joint (a joint's own rotation moves only its shell)
    parents = sk.parents.tolist()
    by_joint: dict[int, list[int]] = {}
    for c, t in enumerate(anim):
        by_joint.setdefault(t.joint, []).append(c)

    def movers(k: int, own_rotation: bool) -> list[int]:
        out = [c for c in by_joint.get(k, []) if anim[c].kind == "translation" or own_rotation]
        p = parents[k]
        while p >= 0:
            out.extend(by_joint.get(p, []))
            p = parents[p]
        return out

    rot_dec = np.empty((N, sk.n_joints, 4))
    rot_dec[:] = motion.rotations  # default and constant tracks are overwritten below
    tr_dec = np.empty((N, sk.n_joints, 3))
    tr_dec[:] = motion.translations
    for t in tracks:
        if t.cls == "constant":
            (rot_dec if t.kind == "rotation" else tr_dec)[:, t.joint] = t.value

    rot_cols = np.array([c for c, t in enumerate(anim) if t.kind == "rotation"], dtype=np.int64)
    rot_joints = np.array([anim[c].joint for c in rot_cols], dtype=np.int64)
    tr_cols = [c for c, t in enumerate(anim) if t.kind == "translation"]

    def encode_block(b: int, cols) -> None:
        a, e = spans[b]
        for c in cols:
            keys[b][c] = choose_keys(anim[c].x[a:e], table[c], int(r[b, c]))
        payload = pack_block(e - a, [keys[b][c] for c in range(T)])
        vals = unpack_block(payload, e - a, dims, table, "<encoder>").reshape(e - a, T, 3)
        rot_dec[a:e, rot_joints] = exp_map(vals[:, rot_cols])
        for c in tr_cols:
            tr_dec[a:e, anim[c].joint] = vals[:, c]

    parents_arr = sk.parents.astype(np.int64)
    margin = bound * (1.0 - 1e-9)  # the final check runs numpy's forward kinematics, rounding differently

    tick = progress or (lambda done, total: None)
    for b in range(B):
        encode_block(b, range(T))
        tick(b + 1, B)
    pending = list(range(B))
    rounds = 0
    while pending:
        again = []
        for b in pending:
            a, e = spans[b]
            err, err_end = worst_point_errors(parents_arr, rot_dec[a:e], tr_dec[a:e], P0[a:e], R0[a:e], shell_distance,
                                              metric == "shell", end_joint, end_off, E0[a:e])
            bad = np.flatnonzero(err > margin)
            bad_end = np.flatnonzero(err_end > margin)
            if bad.size == 0 and bad_end.size == 0:
                continue
            cols = sorted({c for k in bad.tolist() for c in movers(k, metric == "shell")}
                          | {c for k in end_joint[bad_end].tolist() for c in movers(k, True)})
            if not cols or r[b, cols].max() >= START_LEVELS + FLOOR_LEVELS:
                raise BoundViolationError(
                    f"frames {a}..{e - 1}: error {max(err.max(), err_end.max(initial=0)):.6g} > {bound:g} "
                    "even within the worst-case budget"
                )
            r[b, cols] += 1
            encode_block(b, cols)
            again.append(b)
        pending = again
        rounds += 1

    payloads = [pack_block(e - a, [keys[b][c] for c in range(T)]) for b, (a, e) in enumerate(spans)]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:  # zstd and LZMA release the GIL
        coded = list(pool.map(lambda p: entropy_encode(p, entropy), payloads))
    blocks = [(a, e - a, len(p), c) for (a, e), p, c in zip(spans, payloads, coded, strict=True)]
    n_keys = sum(len(keys[b][c][2]) for b in range(B) for c in range(T))
    header = _header(motion, tracks, anim, unit_cm, source, n_keys)
    header["bound"] = {"metric": metric, "value": bound, "shell_distance": shell_distance}
    data = mkc_bytes(header, blocks)
    t_enc = time.perf_counter() - t_start

    # the guarantee: decode the bytes alone, as any reader does, and measure
    dec = Clip("<encoded clip>", data=data).decode()
    P1, R1 = forward_kinematics(dec)
    je, se = errors_from_fk(P0, R0, P1, R1, shell_distance)
    ee = end_errors_from_fk(sk, P0, R0, P1, R1)  # every End Site, whatever the metric
    worst = float({"shell": se, "joint": je}.get(metric, np.maximum(je.max(), ee.max(initial=0))).max())
    if worst > bound:
        raise BoundViolationError(f"the written clip decodes to a {metric} error of {worst:.6g} > {bound:g}")
    k = unit_cm if unit_cm is not None else float("nan")
    report: dict[str, Any] = {
        "format": "mkc", "bytes": len(data), "error_metric": metric, "bound": bound,
        "shell_distance": shell_distance, "unit_cm": unit_cm,
        "max_joint_error": float(je.max()), "mean_joint_error": float(je.mean()),
        "max_shell_error": float(se.max()), "mean_shell_error": float(se.mean()),
        "max_end_site_error": float(ee.max(initial=0)),
        "max_joint_error_cm": float(je.max()) * k, "max_shell_error_cm": float(se.max()) * k,
        "max_end_site_error_cm": float(ee.max(initial=0)) * k,
        "frames": N, "joints": sk.n_joints, "blocks": B, "keyframes": n_keys,
        "tracks": {cls: sum(t.cls == cls for t in tracks) for cls in ("constant", "animated")},
        "default_tracks": 2 * sk.n_joints - len(tracks), "repair_rounds": rounds,
        "repaired_track_blocks": int((r > 0).sum()), "encode_s": t_enc,
        "bytes_raw_float32": N * sk.n_joints * 28,
    }
    report["ratio"] = report["bytes_raw_float32"] / len(data)
    return EncodedClip(data, report)


def _header(motion: Motion, tracks: list[_Track], anim: list[_Track], unit_cm, source: str, n_keys: int) -> dict:
    sk, N = motion.skeleton, motion.n_frames
    t = motion.times
    dt = motion.frame_time
    # a regular clip stores its rate only (its times to within 1e-9 of a frame, e.g. k/120 vs k·(1/120))
    uniform = bool(np.abs(t - (t[0] + np.arange(N) * dt)).max() <= 1e-9 * dt)
    table = []
    for tr in tracks:  # animated tracks in the order of the block payloads
        if tr.cls == "constant":
            assert tr.value is not None  # a constant track holds its value
            table.append(
                {"joint": tr.joint, "kind": tr.kind, "class": "constant", "value": [float(v) for v in tr.value]}
            )
        elif tr.cls == "animated":
            table.append({"joint": tr.joint, "kind": tr.kind, "class": "animated", "base_step": tr.base})
    assert [x for x in tracks if x.cls == "animated"] == anim
    return {
        "generator": f"mocapkit {__version__}", "source": source, "frames": N,
        "start_time": float(t[0]), "frame_time": float(dt), "times": None if uniform else [float(v) for v in t],
        "unit_cm": unit_cm,
        "skeleton": {"names": list(sk.names), "parents": sk.parents.tolist(), "offsets": sk.offsets.tolist(),
                     "channels": [list(c) for c in sk.channels],
                     "end_sites": [[int(j), [float(v) for v in off]] for j, off in sk.end_sites]},
        "tracks": table, "keyframes": n_keys,
    }
