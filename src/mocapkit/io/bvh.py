"""BVH (Biovision hierarchy) reading and writing.

Reading accepts what real exporters write: any per-joint channel order and count (3 or 6, also
rotation-only subsets), ``End Site`` blocks, several ``ROOT``s, CRLF and tabs, braces on the same line
as a name, joint names with ``:`` or ``.``, numbers glued together (``0.0-7.5``) and a missing final
newline. A ``Frames:`` count that disagrees with the data is an error, or with ``strict=False`` the
data rows are taken and the discrepancy is recorded in ``motion.meta["warnings"]``.

Conventions: rotation channels are intrinsic Euler angles in degrees in the listed order (``Zrotation
Xrotation Yrotation`` is ``R = Rz·Rx·Ry``); a joint's position channels *replace* the corresponding
component of its ``OFFSET`` (the offset is the rest pose; Perception Neuron files animate all joints
this way and root positions are absolute). The values as read are kept in ``motion.channel_values``
so that writing reproduces every channel to the written precision.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from mocapkit.errors import MocapFormatError
from mocapkit.io.atomic import atomic_write_text
from mocapkit.quat import to_scipy
from mocapkit.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Motion, Skeleton

_VALID_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS
_CANON = {c.lower(): c for c in _VALID_CHANNELS}
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_NUMERIC_LINE = re.compile(r"^[0-9eE+\-.\s]*$")


class _Tokens:
    """Tokens of the hierarchy part with their 1-based line numbers."""

    def __init__(self, lines: list[str], path: str):
        self.path = path
        self.toks: list[tuple[str, int]] = []
        self.motion_line = None
        for i, line in enumerate(lines, start=1):
            s = line.strip()
            if s.upper().startswith("MOTION"):
                self.motion_line = i
                break
            for tok in s.replace("{", " { ").replace("}", " } ").split():
                self.toks.append((tok, i))
        self.pos = 0

    def peek(self) -> tuple[str, int]:
        if self.pos >= len(self.toks):
            line = self.toks[-1][1] if self.toks else 1
            raise MocapFormatError(self.path, line, "unexpected end of the hierarchy (missing '}' or MOTION)")
        return self.toks[self.pos]

    def next(self) -> tuple[str, int]:
        t = self.peek()
        self.pos += 1
        return t

    def expect(self, word: str) -> int:
        tok, line = self.next()
        if tok.upper() != word.upper():
            raise MocapFormatError(self.path, line, f"expected {word!r}, found {tok!r}")
        return line

    def number(self, what: str) -> float:
        tok, line = self.next()
        try:
            return float(tok)
        except ValueError:
            raise MocapFormatError(self.path, line, f"{what}: {tok!r} is not a number") from None

    def more(self) -> bool:
        return self.pos < len(self.toks)


def _parse_joint(tk: _Tokens, name: str, parent: int, out: dict) -> None:
    j = len(out["names"])
    if name in out["names"]:
        raise MocapFormatError(tk.path, tk.toks[tk.pos - 1][1], f"joint name {name!r} is used twice")
    out["names"].append(name)
    out["parents"].append(parent)
    out["offsets"].append((0.0, 0.0, 0.0))
    out["channels"].append(())
    tk.expect("{")
    seen_offset = False
    while True:
        tok, line = tk.next()
        up = tok.upper()
        if up == "}":
            break
        if up == "OFFSET":
            out["offsets"][j] = (tk.number("OFFSET x"), tk.number("OFFSET y"), tk.number("OFFSET z"))
            seen_offset = True
        elif up == "CHANNELS":
            ntok, nline = tk.next()
            try:
                n = int(ntok)
            except ValueError:
                raise MocapFormatError(tk.path, nline, f"CHANNELS count {ntok!r} is not an integer") from None
            if not 0 <= n <= 6:
                raise MocapFormatError(tk.path, nline, f"CHANNELS count {n} is not between 0 and 6")
            chans = []
            for _ in range(n):
                c, cl = tk.next()
                canon = _CANON.get(c.lower())
                if canon is None:
                    raise MocapFormatError(
                        tk.path, cl, f"unknown channel {c!r} of joint {name!r} (expected one of {', '.join(_VALID_CHANNELS)})"
                    )
                if canon in chans:
                    raise MocapFormatError(tk.path, cl, f"channel {canon} repeated in joint {name!r}")
                chans.append(canon)
            out["channels"][j] = tuple(chans)
        elif up == "JOINT":
            child, _ = tk.next()
            _parse_joint(tk, child, j, out)
        elif up == "END":
            tk.expect("Site")
            tk.expect("{")
            tk.expect("OFFSET")
            off = (tk.number("End Site OFFSET x"), tk.number("End Site OFFSET y"), tk.number("End Site OFFSET z"))
            tk.expect("}")
            out["end_sites"].append((j, off))
        else:
            raise MocapFormatError(tk.path, line, f"unexpected {tok!r} in joint {name!r}")
    if not seen_offset:
        raise MocapFormatError(tk.path, line, f"joint {name!r} has no OFFSET")


def _split_lines(text: str) -> list[str]:
    text = text.lstrip("\ufeff")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text.split("\n")


def read_bvh(path: str | Path, strict: bool = True) -> Motion:
    """Read a BVH file into a :class:`~mocapkit.skeleton.Motion` (see the module notes)."""
    path = str(path)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise MocapFormatError(path, None, f"not UTF-8 text (byte {e.start})") from None
    except OSError as e:
        raise MocapFormatError(path, None, e.strerror or str(e)) from None
    return parse_bvh(text, path, strict=strict)


def parse_bvh(text: str, path: str = "<bvh>", strict: bool = True) -> Motion:
    lines = _split_lines(text)
    if not any(s.strip() for s in lines):
        raise MocapFormatError(path, None, "empty file")
    tk = _Tokens(lines, path)
    if not tk.more():
        raise MocapFormatError(path, 1, "no HIERARCHY section")
    tk.expect("HIERARCHY")
    out: dict = {"names": [], "parents": [], "offsets": [], "channels": [], "end_sites": []}
    while tk.more():
        tok, line = tk.next()
        if tok.upper() != "ROOT":
            raise MocapFormatError(path, line, f"expected ROOT or MOTION, found {tok!r}")
        name, _ = tk.next()
        _parse_joint(tk, name, -1, out)
    if not out["names"]:
        raise MocapFormatError(path, tk.motion_line or len(lines), "the hierarchy has no ROOT")
    if tk.motion_line is None:
        raise MocapFormatError(path, len(lines), "no MOTION section")
    skel = Skeleton(
        names=tuple(out["names"]),
        parents=np.array(out["parents"]),
        offsets=np.array(out["offsets"], dtype=np.float64),
        channels=tuple(out["channels"]),
        end_sites=tuple(out["end_sites"]),
    )
    values, frame_time, warn = _parse_motion(lines, tk.motion_line, skel.n_channels, path, strict)
    motion = motion_from_channels(skel, values, frame_time, source=path)
    if warn:
        motion.meta["warnings"] = warn
    return motion


def _header_value(lines: list[str], i: int, key: str, path: str) -> str:
    if i >= len(lines):
        raise MocapFormatError(path, i, f"missing '{key}' line")
    s = lines[i].strip()
    if not s.lower().replace(" ", "").startswith(key.lower().replace(" ", "")):
        raise MocapFormatError(path, i + 1, f"expected '{key} ...', found {s[:40]!r}")
    return s.split(":", 1)[1].strip() if ":" in s else s[len(key):].strip()


def _parse_motion(lines, motion_line, n_channels, path, strict):
    i = motion_line  # index of the line after MOTION (0-based)
    while i < len(lines) and not lines[i].strip():
        i += 1
    v = _header_value(lines, i, "Frames:", path)
    try:
        n_frames = int(v)
    except ValueError:
        raise MocapFormatError(path, i + 1, f"Frames: {v!r} is not an integer") from None
    if n_frames < 0:
        raise MocapFormatError(path, i + 1, f"Frames: {n_frames} is negative")
    i += 1
    v = _header_value(lines, i, "Frame Time:", path)
    try:
        frame_time = float(v)
    except ValueError:
        raise MocapFormatError(path, i + 1, f"Frame Time: {v!r} is not a number") from None
    if not (frame_time > 0 and np.isfinite(frame_time)):
        raise MocapFormatError(path, i + 1, f"Frame Time must be a positive number, got {v!r}")
    first = i + 1  # 0-based index of the first data line
    data = lines[first:]
    while data and not data[-1].strip():
        data.pop()
    warn = []
    values = None
    # fastest path: NumPy's C text reader on the whole block. It accepts a subset of what the paths
    # below accept (no "1_0", no non-ASCII digits) and reads the same values; it silently skips blank
    # lines, which are errors here, so those go to the paths below, as does any other failure.
    if data and all(ln and not ln.isspace() for ln in data):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                values = np.loadtxt(data, dtype=np.float64, comments=None, ndmin=2)
        except Exception:
            values = None
        if values is not None and values.shape != (len(data), n_channels):
            values = None
    if values is None:
        # fast path: every line has exactly the channel count of plain numbers
        split = [ln.split() for ln in data]
        if all(len(s) == n_channels for s in split):
            try:
                values = np.array(split, dtype=np.float64).reshape(len(data), n_channels)
            except ValueError:
                values = None
    if values is None:
        rows = []
        for k, ln in enumerate(data):
            lineno = first + k + 1
            s = ln.strip()
            if not s:
                raise MocapFormatError(path, lineno, "blank line inside the motion data")
            if not _NUMERIC_LINE.match(s):
                bad = next(t for t in s.split() if not _NUMERIC_LINE.match(t))
                raise MocapFormatError(path, lineno, f"{bad[:30]!r} is not a number")
            nums = _NUM.findall(s)
            if "".join(nums) != "".join(s.split()):
                raise MocapFormatError(path, lineno, f"cannot read the numbers in {s[:60]!r}")
            if len(nums) != n_channels:
                raise MocapFormatError(
                    path, lineno, f"expected {n_channels} channel values (from the hierarchy), got {len(nums)}"
                )
            rows.append([float(x) for x in nums])
        values = np.array(rows, dtype=np.float64).reshape(len(rows), n_channels)
    if not np.all(np.isfinite(values)):
        k = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0])
        raise MocapFormatError(path, first + k + 1, "NaN or infinite channel value")
    if values.shape[0] != n_frames:
        msg = f"header says Frames: {n_frames} but {values.shape[0]} data lines follow"
        if strict:
            raise MocapFormatError(path, first - 1, msg + " (--no-strict, or strict=False, takes the data lines)")
        warn.append(msg + f"; took the {values.shape[0]} data lines")
    if values.shape[0] == 0:
        raise MocapFormatError(path, first, "no motion frames")
    return values, frame_time, warn


def motion_from_channels(skel: Skeleton, values: np.ndarray, frame_time: float, source: str = "") -> Motion:
    """Build a Motion from BVH channel values ``(N, C)`` (degrees; positions replace offsets)."""
    N = values.shape[0]
    J = skel.n_joints
    axis = {"X": 0, "Y": 1, "Z": 2}
    rot = np.empty((N, J, 4))
    trans = np.broadcast_to(skel.offsets, (N, J, 3)).copy()
    pos_joint, pos_axis, pos_col = [], [], []
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}  # rotation order -> (joints, columns)
    col = 0
    for j, chans in enumerate(skel.channels):
        order = ""
        rcols = []
        for c in chans:
            if c in POSITION_CHANNELS:
                pos_joint.append(j)
                pos_axis.append("XYZ".index(c[0]))
                pos_col.append(col)
            else:
                order += c[0]
                rcols.append(col)
            col += 1
        if order:
            g = groups.setdefault(order, ([], []))
            g[0].append(j)
            g[1].append(rcols)
        else:
            rot[:, j] = (1.0, 0.0, 0.0, 0.0)
    if pos_col:
        trans[:, pos_joint, pos_axis] = values[:, pos_col]
    # Intrinsic Euler angles to scalar-first quaternions for all joints of one order at once: the
    # product of the elementary quaternions e0·e1·e2 computed with exactly the operations of scipy's
    # Rotation.from_euler(order, angles, degrees=True) (same values bit for bit, signed zeros and
    # NaNs included, no sign canonicalisation) without its per-element cost. Quaternions are
    # (x, y, z, w) here as in scipy; 0.0 stands for a component that is +0.0 in every frame.
    for order, (joints, cols) in groups.items():
        if any(a == b for a, b in zip(order, order[1:])):
            Rotation.from_euler(order, values[:, cols[0]], degrees=True)  # raises scipy's error, as before
        half = np.asarray(values[:, cols], dtype=np.float64)  # (N, joints, len(order)), a new array
        np.deg2rad(half, out=half)
        half /= 2.0
        with np.errstate(invalid="ignore"):  # cos/sin of ±inf give NaN quietly, as in scipy
            cos = np.cos(half)
            sin = np.sin(half, out=half)
        p = [0.0, 0.0, 0.0, cos[..., 0]]
        p[axis[order[0]]] = sin[..., 0]
        for i in range(1, len(order)):
            e = [0.0, 0.0, 0.0, cos[..., i]]
            e[axis[order[i]]] = sin[..., i]
            cross = [p[1] * e[2] - p[2] * e[1], p[2] * e[0] - p[0] * e[2], p[0] * e[1] - p[1] * e[0]]
            r = [p[3] * e[k] + e[3] * p[k] + cross[k] for k in range(3)]
            r.append(p[3] * e[3] - p[0] * e[0] - p[1] * e[1] - p[2] * e[2])
            p = r
        q = np.empty((N, len(joints), 4))
        q[..., 0] = p[3]
        q[..., 1] = p[0]
        q[..., 2] = p[1]
        q[..., 3] = p[2]
        rot[:, joints] = q
    times = np.arange(N) * frame_time
    return Motion(skel, times, rot, trans, channel_values=values, source=source, meta={"frame_time": frame_time})


def channels_from_motion(motion: Motion) -> np.ndarray:
    """BVH channel values ``(N, C)`` for a motion: Euler angles (degrees, unwrapped over time so the
    channels are continuous) in each joint's order, and positions from the local translations."""
    skel = motion.skeleton
    cols = []
    for j, chans in enumerate(skel.channels):
        order = skel.rotation_order(j)
        eul = None
        if order:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # gimbal lock: scipy still returns a valid decomposition
                eul = to_scipy(motion.rotations[:, j]).as_euler(order, degrees=True)
            eul = np.degrees(np.unwrap(np.radians(eul), axis=0))
        k = 0
        for c in chans:
            if c in POSITION_CHANNELS:
                cols.append(motion.translations[:, j, "XYZ".index(c[0])])
            else:
                cols.append(eul[:, k])
                k += 1
    if not cols:
        return np.zeros((motion.n_frames, 0))
    return np.stack(cols, axis=1)


def write_bvh(path: str | Path, motion: Motion, precision: int = 6, use_channel_values: bool = True) -> None:
    """Write a BVH file atomically. Channel values come from ``motion.channel_values`` when present
    (exact reproduction of a file that was read) unless ``use_channel_values=False``; otherwise they
    are computed from the rotations and translations."""
    skel = motion.skeleton
    out = ["HIERARCHY"]
    children = {j: skel.children(j) for j in range(skel.n_joints)}
    ends: dict[int, list] = {}
    for j, off in skel.end_sites:
        ends.setdefault(j, []).append(off)

    def num(x: float) -> str:
        return f"{x:.{precision}f}"

    def emit(j: int, depth: int) -> None:
        ind = "\t" * depth
        kw = "ROOT" if skel.parents[j] < 0 else "JOINT"
        out.append(f"{ind}{kw} {skel.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET " + " ".join(num(v) for v in skel.offsets[j]))
        if skel.channels[j]:
            out.append(f"{ind}\tCHANNELS {len(skel.channels[j])} " + " ".join(skel.channels[j]))
        for k in children[j]:
            emit(k, depth + 1)
        for off in ends.get(j, []):
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET " + " ".join(num(v) for v in off))
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    for j in range(skel.n_joints):
        if skel.parents[j] < 0:
            emit(j, 0)
    vals = motion.channel_values if (use_channel_values and motion.channel_values is not None) else channels_from_motion(motion)
    out.append("MOTION")
    out.append(f"Frames: {motion.n_frames}")
    out.append(f"Frame Time: {motion.frame_time:.{max(precision, 6)}g}")
    fmt = f"%.{precision}f"
    body = "\n".join(" ".join(fmt % v for v in row) for row in vals.tolist())
    atomic_write_text(path, "\n".join(out) + "\n" + body + "\n")
