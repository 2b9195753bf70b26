"""Decode a ``.mkc`` clip's bytes: the whole motion, or one instant (random access by block).

:class:`Clip` checks the container (:mod:`mocapkit.clip.container`) and the header's fields, then decodes
blocks on demand: :meth:`Clip.decode` decodes every block (and checks the file's final checksum);
:meth:`Clip.pose_at` decodes only the block(s) holding the instant asked for — the cost a game runtime
pays per pose — and keeps the last few decoded blocks, so playback reads each block once. It opens no
file: ``mocapkit.jobs.readers`` reads one (:mod:`mocapkit.io.formats.mkc`) and decodes it here.
"""

from __future__ import annotations

import math
import os
import re
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from mocapkit.clip.codec import entropy_decode, steps_table, unpack_block, unpack_pose
from mocapkit.clip.container import BOUND_METRICS, ClipFile
from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.rotvec import exp_into
from mocapkit.skeleton import MAX_JOINT_FRAMES, POSITION_CHANNELS, ROTATION_CHANNELS, Motion, Skeleton

CACHE_BLOCKS = 4
THREADS = os.cpu_count() or 1  # blocks decoded at once by decode_arrays
_CHANNELS = set(POSITION_CHANNELS + ROTATION_CHANNELS)
HEADER_KEYS = {"generator", "source", "frames", "start_time", "frame_time", "times", "unit_cm", "skeleton", "tracks",
               "keyframes", "bound", "blocks"}
SKELETON_KEYS = {"names", "parents", "offsets", "channels", "end_sites"}
FRAME_TIME_RANGE = (1e-6, 1e6)  # s: what the BVH reader accepts
UNIT_CM_RANGE = (1e-6, 1e6)  # cm per length unit: what --unit-cm accepts
UNIT_QUATERNION_TOL = 1e-6  # a constant rotation is stored as the unit quaternion it is
MIN_BASE_STEP = 1e-200  # every level's step (down to 2^-60 of it) stays a normal double
MAX_TEXT = 4096  # characters of a name, the generator or the source
_BAD_NAME = re.compile(r"[\s{}]")  # a BVH joint name is one token without braces


class Clip:
    """A decoded clip header with lazy blocks: ``Clip(name, data=bytes)``; ``name`` (the file's path, or
    any label) names the clip in errors."""

    def __init__(self, name: str | os.PathLike, *, data: bytes) -> None:
        self.file = ClipFile(name, data=data)
        self.path = self.file.path
        h = self.file.header
        self.header = h
        missing, extra = HEADER_KEYS - h.keys(), h.keys() - HEADER_KEYS
        if missing or extra:
            raise self._bad(
                f"header fields {sorted(missing)} missing" if missing else f"unknown header fields {sorted(extra)}"
            )
        for key in ("generator", "source"):
            self._text(h[key], key)
        self.n_frames = self._int(h.get("frames"), "frames", 1)
        if sum(b.frames for b in self.file.blocks) != self.n_frames:
            raise self._bad("the blocks do not cover the clip's frames")
        self.unit_cm = self._opt_float(h.get("unit_cm"), "unit_cm")
        if self.unit_cm is not None and not UNIT_CM_RANGE[0] <= self.unit_cm <= UNIT_CM_RANGE[1]:
            raise self._bad(
                f"header field unit_cm: {self.unit_cm!r} cm is not between {UNIT_CM_RANGE[0]:g} and "
                f"{UNIT_CM_RANGE[1]:g}"
            )
        self.skeleton = self._skeleton(h.get("skeleton"))
        if self.n_frames * self.skeleton.n_joints > MAX_JOINT_FRAMES:
            raise self._bad(f"header field frames: {self.n_frames} frames of {self.skeleton.n_joints} joints are more "
                            f"than {MAX_JOINT_FRAMES:,} joint-frames")
        self.times = self._times(h)
        self._tracks(h.get("tracks"))
        self._block_sizes()
        self._int(h["keyframes"], "keyframes", 0, self.n_frames * len(self.animated))
        self._bound(h["bound"])
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._starts = np.array([b.first for b in self.file.blocks], dtype=np.int64)

    # ---------------------------------------------------------------- header checks
    def _bad(self, problem: str) -> MocapFormatError:
        return MocapFormatError(self.path, None, problem)

    def _int(self, v, what: str, lo: int = 0, hi: int | None = None) -> int:
        if type(v) is not int or v < lo or (hi is not None and v > hi):
            raise self._bad(
                f"header field {what}: expected an integer in [{lo}, {hi if hi is not None else '∞'}], got {v!r}"
            )
        return v

    def _float(self, v, what: str) -> float:
        if type(v) not in (int, float) or not math.isfinite(v) or abs(v) > 1e12:
            raise self._bad(f"header field {what}: expected a finite number, got {v!r}")
        return float(v)

    def _text(self, v, what: str) -> str:
        if not isinstance(v, str) or len(v) > MAX_TEXT:
            raise self._bad(
                f"header field {what}: expected a string of at most {MAX_TEXT} characters, got {str(v)[:60]!r}"
            )
        return v

    def _bound(self, b) -> None:
        if b is None:
            return
        if not isinstance(b, dict) or b.keys() != {"metric", "value", "shell_distance"}:
            raise self._bad(f"header field bound: expected {{metric, value, shell_distance}}, got {str(b)[:80]!r}")
        if b["metric"] not in BOUND_METRICS:
            raise self._bad(
                f"header field bound.metric: {str(b['metric'])[:40]!r} is not one of {', '.join(BOUND_METRICS)}"
            )
        for key in ("value", "shell_distance"):
            if not self._float(b[key], f"bound.{key}") > 0:
                raise self._bad(f"header field bound.{key} must be positive, got {b[key]!r}")

    def _block_sizes(self) -> None:
        """A block's payload holds two varints a track at least and, per track, a key (a gap and three
        residuals of at most 10 bytes each) per frame at most."""
        T = len(self.animated)
        for i, e in enumerate(self.file.blocks):
            lo, hi = 2 * T, T * (20 + 40 * e.frames)
            if not lo <= e.raw <= hi:
                raise self._bad(f"block {i}: raw length {e.raw} is not between {lo} and {hi} bytes for {T} tracks "
                                f"of {e.frames} frames")

    def _opt_float(self, v, what: str) -> float | None:
        return None if v is None else self._float(v, what)

    def _floats(self, v, n: int, what: str) -> list[float]:
        if not isinstance(v, list) or len(v) != n:
            raise self._bad(f"header field {what}: expected {n} numbers, got {v!r}")
        return [self._float(x, what) for x in v]

    def _skeleton(self, s) -> Skeleton:
        if not isinstance(s, dict):
            raise self._bad("header has no skeleton")
        if s.keys() != SKELETON_KEYS:
            raise self._bad(f"header field skeleton: expected the fields {sorted(SKELETON_KEYS)}, got {sorted(s)[:10]}")
        names, parents, offsets, channels = (s[k] for k in ("names", "parents", "offsets", "channels"))
        if not isinstance(names, list) or not names or not all(isinstance(x, str) for x in names):
            raise self._bad("skeleton names must be a non-empty list of strings")
        for x in names:
            if not x or len(x) > MAX_TEXT or _BAD_NAME.search(x):
                raise self._bad(f"skeleton names: joint name {x[:60]!r} cannot be a BVH joint name (empty, too long, "
                                "or holds blanks or braces)")
        J = len(names)
        for what, v in (("parents", parents), ("offsets", offsets), ("channels", channels)):
            if not isinstance(v, list) or len(v) != J:
                raise self._bad(f"skeleton {what} must list {J} joints")
        par = [self._int(p, "parents", -1, J - 1) for p in parents]
        off = [self._floats(o, 3, f"offsets of {names[j]!r}") for j, o in enumerate(offsets)]
        ch = []
        for j, c in enumerate(channels):
            if (
                not isinstance(c, list)
                or not all(isinstance(x, str) and x in _CHANNELS for x in c)
                or len(set(c)) != len(c)
            ):
                raise self._bad(f"skeleton channels of {names[j]!r} are not BVH channel names: {c!r}")
            ch.append(tuple(c))
        ends: list[tuple[int, tuple[float, float, float]]] = []
        for e in s["end_sites"] if isinstance(s["end_sites"], list) else [None]:
            if not (isinstance(e, list) and len(e) == 2):
                raise self._bad(f"skeleton end site {str(e)[:60]!r} is not [joint, [x, y, z]]")
            j = self._int(e[0], "end site joint", 0, J - 1)
            ex, ey, ez = self._floats(e[1], 3, "end site offset")
            ends.append((j, (ex, ey, ez)))
        if len({j for j, _ in ends}) != len(ends):
            raise self._bad("skeleton end_sites: a joint has two End Sites (BVH holds one)")
        meta = {}
        if self.header.get("unit_cm") is not None:
            meta["length_unit_cm"] = self._float(self.header["unit_cm"], "unit_cm")
        try:
            return Skeleton(tuple(names), np.array(par, dtype=np.int64), np.array(off, dtype=np.float64).reshape(J, 3),
                            tuple(ch), tuple(ends), meta=meta)
        except InvalidSignalError as e:
            raise self._bad(f"skeleton: {e}") from None

    def _times(self, h) -> np.ndarray:
        if h.get("times") is not None:
            t = np.array(self._floats(h["times"], self.n_frames, "times"))
            if self.n_frames > 1 and np.any(np.diff(t) <= 0):
                raise self._bad("times are not strictly increasing")
        t0 = self._float(h.get("start_time"), "start_time")
        dt = self._float(h.get("frame_time"), "frame_time")
        lo, hi = FRAME_TIME_RANGE
        if not lo <= dt <= hi:
            raise self._bad(f"header field frame_time: {dt!r} s is not between {lo:g} and {hi:g} s")
        if h.get("times") is not None:
            self.frame_time = float((t[-1] - t[0]) / max(self.n_frames - 1, 1)) or 1.0
            if self.n_frames > 1 and not lo <= self.frame_time <= hi:
                raise self._bad(f"header field times: a mean frame time of {self.frame_time!r} s is not between "
                                f"{lo:g} and {hi:g} s")
            return t
        self.frame_time = dt
        t = t0 + np.arange(self.n_frames) * dt
        if self.n_frames > 1 and not (np.all(np.diff(t) > 0) and abs(t[-1]) <= 1e12):
            raise self._bad(f"header fields start_time/frame_time: frames at {t0!r} + k·{dt!r} s are not distinct "
                            "finite times")
        return t

    def _tracks(self, tracks) -> None:
        J = self.skeleton.n_joints
        if not isinstance(tracks, list):
            raise self._bad("header has no track table")
        self.rest_rotations = np.tile([1.0, 0.0, 0.0, 0.0], (J, 1))
        self.rest_translations = self.skeleton.offsets.copy()
        self.animated: list[tuple[int, str]] = []  # (joint, kind) in payload order
        bases = []
        seen = set()
        for i, t in enumerate(tracks):
            if not isinstance(t, dict):
                raise self._bad(f"track {i} is not an object")
            if t.keys() - {"joint", "kind", "class", "value", "base_step"}:
                raise self._bad(f"header field tracks[{i}]: unknown fields {sorted(t.keys())[:8]}")
            j = self._int(t.get("joint"), f"tracks[{i}].joint", 0, J - 1)
            kind, cls = t.get("kind"), t.get("class")
            if kind not in ("rotation", "translation") or cls not in ("constant", "animated") or (j, kind) in seen:
                raise self._bad(f"track {i}: kind {kind!r} / class {cls!r} of joint {j} is not valid or repeated")
            seen.add((j, kind))
            if cls == "constant":
                if kind == "rotation":
                    q = np.array(self._floats(t.get("value"), 4, f"tracks[{i}].value"))
                    if not abs(math.sqrt(float(q @ q)) - 1.0) <= UNIT_QUATERNION_TOL:
                        raise self._bad(f"header field tracks[{i}].value: {q.tolist()} is not a unit quaternion")
                    self.rest_rotations[j] = q
                else:
                    self.rest_translations[j] = self._floats(t.get("value"), 3, f"tracks[{i}].value")
            else:
                b = self._float(t.get("base_step"), f"tracks[{i}].base_step")
                if not MIN_BASE_STEP <= b:
                    raise self._bad(
                        f"header field tracks[{i}].base_step: {b!r} is not a step of at least {MIN_BASE_STEP:g}"
                    )
                self.animated.append((j, kind))
                bases.append(b)
        self.dims = np.full(len(self.animated), 3, dtype=np.int64)
        self._joints = np.array([j for j, _ in self.animated], dtype=np.int64)
        self._is_rot = np.array([k == "rotation" for _, k in self.animated], dtype=np.bool_)
        self.steps = steps_table(np.array(bases))

    # ---------------------------------------------------------------- decoding
    def _block_values(self, i: int) -> np.ndarray:
        e = self.file.blocks[i]
        where = f"{self.path} (block {i})"
        raw = entropy_decode(self.file.block(i), e.raw, where)
        return unpack_block(raw, e.frames, self.dims, self.steps, where)

    def block_values(self, i: int) -> np.ndarray:
        """``(n, 3·T)`` decoded values (rotation vectors, translations) of the animated tracks in block
        ``i``; the last :data:`CACHE_BLOCKS` blocks asked for are kept."""
        if i in self._cache:
            self._cache.move_to_end(i)
            return self._cache[i]
        v = self._block_values(i)
        self._cache[i] = v
        if len(self._cache) > CACHE_BLOCKS:
            self._cache.popitem(last=False)
        return v

    def decode_arrays(self, out: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(N, J, 4)`` and translations ``(N, J, 3)`` of every frame (every block
        decoded, the final checksum checked) — what a runtime needs, without the model's checks.
        ``out``: float64 C-ordered arrays of those shapes to write into (a runtime's reused buffers)."""
        self.file.check_all()
        N, J = self.n_frames, self.skeleton.n_joints
        if out is None:
            rot, trans = np.empty((N, J, 4)), np.empty((N, J, 3))
        else:
            rot, trans = out
            if (
                rot.shape != (N, J, 4)
                or trans.shape != (N, J, 3)
                or rot.dtype != np.float64
                or trans.dtype != np.float64
                or not (rot.flags.c_contiguous and trans.flags.c_contiguous)
            ):
                raise ValueError(f"out must be float64 C arrays of shapes {(N, J, 4)} and {(N, J, 3)}")

        def one(i: int) -> None:  # blocks are independent: decoded on every core (the kernels drop the GIL)
            e = self.file.blocks[i]
            where = f"{self.path} (block {i})"
            unpack_pose(entropy_decode(self.file.block(i), e.raw, where), e.frames, self.steps, self._joints,
                        self._is_rot, self.rest_rotations, self.rest_translations, rot[e.first:e.first + e.frames],
                        trans[e.first:e.first + e.frames], where)

        if len(self.file.blocks) == 1 or THREADS == 1:
            for i in range(len(self.file.blocks)):
                one(i)
        else:
            with ThreadPoolExecutor(max_workers=THREADS) as pool:
                list(pool.map(one, range(len(self.file.blocks))))
        return rot, trans

    def decode(self) -> Motion:
        """The whole motion at its frame times, as a :class:`~mocapkit.skeleton.Motion`."""
        rot, trans = self.decode_arrays()
        meta = {"frame_time": self.frame_time, "format": "mkc"}
        return Motion(self.skeleton, self.times, rot, trans, channel_values=None, source=self.path, meta=meta)

    def pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(J, 4)`` and translations ``(J, 3)`` at time ``t`` (seconds; clamped to the
        clip): linear in rotation vectors / translations between the two frames around ``t``, which
        are decoded from their block(s) only."""
        f = float(np.interp(t, self.times, np.arange(self.n_frames, dtype=np.float64)))
        a = int(math.floor(f))
        b = min(a + 1, self.n_frames - 1)
        w = f - a
        va = self._frame_values(a)
        vals = va if (w == 0.0 or b == a) else va + (self._frame_values(b) - va) * w
        rot = np.empty((1, self.skeleton.n_joints, 4))
        trans = np.empty((1, self.skeleton.n_joints, 3))
        _pose(vals[None], self._joints, self._is_rot, self.rest_rotations, self.rest_translations, rot, trans)
        return rot[0], trans[0]

    def _frame_values(self, frame: int) -> np.ndarray:
        i = int(np.searchsorted(self._starts, frame, side="right") - 1)
        return self.block_values(i)[frame - self.file.blocks[i].first]

    def info(self) -> dict:
        """What the clip holds (header fields, counts, sizes); no block is decoded."""
        h = self.header
        classes = {
            "rotation": {"default": 0, "constant": 0, "animated": 0},
            "translation": {"default": 0, "constant": 0, "animated": 0},
        }
        listed = {(t["joint"], t["kind"]): t["class"] for t in h["tracks"]}
        for j in range(self.skeleton.n_joints):
            for kind in ("rotation", "translation"):
                classes[kind][listed.get((j, kind), "default")] += 1
        return {"format": "mkc", "version": 1, "file": self.path, "bytes": self.file.size, "frames": self.n_frames,
                "joints": self.skeleton.n_joints, "frame_time": self.frame_time,
                "duration_s": float(self.times[-1] - self.times[0]), "unit_cm": self.unit_cm,
                "blocks": len(self.file.blocks), "tracks": classes, "bound": h.get("bound"),
                "keyframes": h.get("keyframes"), "source": h.get("source")}


@numba.njit(cache=True, nogil=True)
def _pose(vals, joints, is_rot, rest_rot, rest_trans, rot, trans):
    """Poses of a block's frames: the rest pose, then the animated tracks' values (rotation vectors
    through :func:`~mocapkit.rotvec.exp_into`, translations; 3 columns a track)."""
    J = rest_rot.shape[0]
    for f in range(vals.shape[0]):
        for j in range(J):
            for a in range(4):
                rot[f, j, a] = rest_rot[j, a]
            for a in range(3):
                trans[f, j, a] = rest_trans[j, a]
        for c in range(joints.shape[0]):
            j = joints[c]
            if is_rot[c]:
                exp_into(vals[f, 3 * c], vals[f, 3 * c + 1], vals[f, 3 * c + 2], rot[f, j])
            else:
                trans[f, j, 0] = vals[f, 3 * c]
                trans[f, j, 1] = vals[f, 3 * c + 1]
                trans[f, j, 2] = vals[f, 3 * c + 2]
