"""BVH (Biovision hierarchy) reading and writing.

Reading accepts what real exporters write: any per-joint channel order and count (3 or 6, also
rotation-only subsets), ``End Site`` blocks, several ``ROOT``s, CRLF and tabs, braces on the same line
as a name, joint names with ``:`` or ``.``, numbers glued together (``0.0-7.5``) and a missing final
newline. A ``Frames:`` count that disagrees with the data is an error, or with ``strict=False`` the
data rows are taken and the discrepancy is recorded in ``motion.meta["warnings"]``.

Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers` (sign, digits, one point, exponent;
no ``0_5``, no ``nan``/``inf``: BVH has no missing-value convention) and ``|value| <=``
:data:`~mocapkit.io.text.numbers.MAX_ABS`; an error names the line and the field (``OFFSET y of joint
LeftArm``, ``frame 12, Zrotation of joint Hips``). ``Frame Time`` must lie in ``[1e-6, 1e6]`` s (a rate
of at most 1 MHz and at least one frame in 11.6 days). The frame block is validated in bulk (one
character-class scan, then NumPy's C parser, whose accepted spelling over those characters is
exactly the grammar), so checking costs little over parsing.

End of file: a file cut in the middle of a frame is recognised when its last line has *no final
newline*. Fewer values than channels on that line is an error ("the last frame is incomplete"); with
``strict=False`` the frame is dropped and a warning recorded. A last line with the right count whose
last value has fewer decimals (or exponent digits) than every one of the up to 100 lines before it in
the same column (``-0`` where the column reads ``-0.124044``) is read, with a warning: it may have been
cut after a digit. Both notes go to ``motion.meta["warnings"]`` (with the other findings such as a
``Frames:`` mismatch under ``strict=False``) and are also issued with :func:`warnings.warn` (category
:class:`~mocapkit.errors.MocapWarning`).

Sizes: the hierarchy is parsed and written without recursion (any depth), the work is linear in the
number of joints, and a file whose frames times joints would build more than
:data:`~mocapkit.skeleton.MAX_JOINT_FRAMES` joint-frames without a value in the file for each is
refused before anything is allocated. A non-regular input (device, pipe) is read in chunks and
refused at the first NUL byte (``/dev/zero``) or beyond 1 GiB.

Conventions: rotation channels are intrinsic Euler angles in degrees in the listed order (``Zrotation
Xrotation Yrotation`` is ``R = Rz·Rx·Ry``); a joint's position channels *replace* the corresponding
component of its ``OFFSET`` (the offset is the rest pose; Perception Neuron files animate all joints
this way and root positions are absolute). The values as read are kept in ``motion.channel_values``
so that writing reproduces every channel to the written precision.
"""

from __future__ import annotations

import io
import re
import warnings
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError, MocapWarning
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.text.input import read_input
from mocapkit.io.text.numbers import MAX_ABS, NUMBER_RE, looks_cut, parse_number
from mocapkit.skeleton import MAX_JOINT_FRAMES, POSITION_CHANNELS, ROTATION_CHANNELS, Motion, Skeleton

_VALID_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS
_CANON = {c.lower(): c for c in _VALID_CHANNELS}
_NUMERIC_LINE = re.compile(r"^[0-9eE+\-.\s]*$")
_BAD_CHAR = re.compile(r"[^0-9eE+\-. \t\n]")  # anything a frame line cannot hold
_NUMBER_CHARS = b"0123456789eE+-. \t\n"
_MOTION_LINE = re.compile(r"^[ \t]*MOTION", re.IGNORECASE | re.MULTILINE)
_UINT = re.compile(r"\+?\d{1,18}")

MIN_FRAME_TIME = 1e-6  # s: a rate of at most 1 MHz
MAX_FRAME_TIME = 1e6  # s
_MAX_INDENT = 32  # deeper joints are written with this indentation (linear file size for any depth)


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------


class _Tokens:
    """Tokens of the hierarchy part (the text before the MOTION line) with their 1-based line numbers."""

    def __init__(self, header: str, path: str):
        self.path = path
        self.toks: list[tuple[str, int]] = []
        for i, line in enumerate(header.split("\n"), start=1):
            if "{" in line or "}" in line:
                line = line.replace("{", " { ").replace("}", " } ")
            for tok in line.split():
                self.toks.append((tok, i))
        self.pos = 0

    def next(self) -> tuple[str, int]:
        if self.pos >= len(self.toks):
            line = self.toks[-1][1] if self.toks else 1
            raise MocapFormatError(self.path, line, "unexpected end of the hierarchy (missing '}' or MOTION)")
        t = self.toks[self.pos]
        self.pos += 1
        return t

    def expect(self, word: str) -> int:
        tok, line = self.next()
        if tok.upper() != word.upper():
            raise MocapFormatError(self.path, line, f"expected {word!r}, found {tok[:40]!r}")
        return line

    def number(self, field: str) -> float:
        tok, line = self.next()
        return parse_number(tok, self.path, line, field)

    def more(self) -> bool:
        return self.pos < len(self.toks)


def _parse_hierarchy(tk: _Tokens) -> dict:
    """ROOT blocks with their joints, end sites, offsets and channels; an explicit stack, no recursion."""
    path = tk.path
    out: dict = {"names": [], "parents": [], "offsets": [], "channels": [], "end_sites": []}
    names, parents, offsets, channels = out["names"], out["parents"], out["offsets"], out["channels"]
    index: dict[str, int] = {}
    has_offset: list[bool] = []

    def open_joint(name: str, line: int, parent: int) -> int:
        if name in index:
            raise MocapFormatError(path, line, f"joint name {name!r} is used twice")
        j = len(names)
        index[name] = j
        names.append(name)
        parents.append(parent)
        offsets.append((0.0, 0.0, 0.0))
        channels.append(())
        has_offset.append(False)
        tk.expect("{")
        return j

    tk.expect("HIERARCHY")
    while tk.more():
        tok, line = tk.next()
        if tok.upper() != "ROOT":
            raise MocapFormatError(path, line, f"expected ROOT or MOTION, found {tok[:40]!r}")
        name, nline = tk.next()
        stack = [open_joint(name, nline, -1)]
        while stack:
            j = stack[-1]
            name = names[j]
            tok, line = tk.next()
            up = tok.upper()
            if up == "}":
                if not has_offset[j]:
                    raise MocapFormatError(path, line, f"joint {name!r} has no OFFSET")
                stack.pop()
            elif up == "OFFSET":
                offsets[j] = tuple(tk.number(f"OFFSET {a} of joint {name}") for a in "xyz")
                has_offset[j] = True
            elif up == "CHANNELS":
                ntok, nline = tk.next()
                if not _UINT.fullmatch(ntok):
                    raise MocapFormatError(
                        path, nline, f"CHANNELS count {ntok[:40]!r} of joint {name!r} is not an integer"
                    )
                n = int(ntok)
                if not 0 <= n <= 6:
                    raise MocapFormatError(path, nline, f"CHANNELS count {n} of joint {name!r} is not between 0 and 6")
                chans: list[str] = []
                for _ in range(n):
                    c, cl = tk.next()
                    canon = _CANON.get(c.lower())
                    if canon is None:
                        raise MocapFormatError(
                            path,
                            cl,
                            f"unknown channel {c[:40]!r} of joint {name!r} "
                            f"(expected one of {', '.join(_VALID_CHANNELS)})",
                        )
                    if canon in chans:
                        raise MocapFormatError(path, cl, f"channel {canon} repeated in joint {name!r}")
                    chans.append(canon)
                channels[j] = tuple(chans)
            elif up == "JOINT":
                child, cline = tk.next()
                stack.append(open_joint(child, cline, j))
            elif up == "END":
                tk.expect("Site")
                tk.expect("{")
                tk.expect("OFFSET")
                off = tuple(tk.number(f"End Site OFFSET {a} of joint {name}") for a in "xyz")
                tk.expect("}")
                out["end_sites"].append((j, off))
            else:
                raise MocapFormatError(path, line, f"unexpected {tok[:40]!r} in joint {name!r}")
    return out


def read_bvh(path: str | Path, strict: bool = True) -> Motion:
    """Read a BVH file into a :class:`~mocapkit.skeleton.Motion` (see the module notes)."""
    path = str(path)
    data = read_input(path, "BVH file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise MocapFormatError(path, None, f"not UTF-8 text (byte {e.start})") from None
    del data
    return parse_bvh(text, path, strict=strict)


def parse_bvh(text: str, path: str = "<bvh>", strict: bool = True) -> Motion:
    """Parse the text of a BVH file; ``path`` names it in errors (see the module notes)."""
    text = text.lstrip("\ufeff")
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    if not text.strip():
        raise MocapFormatError(path, None, "empty file")
    m = _MOTION_LINE.search(text)
    header = text if m is None else text[: m.start()]
    tk = _Tokens(header, path)
    if not tk.more():
        raise MocapFormatError(path, 1, "no HIERARCHY section")
    out = _parse_hierarchy(tk)
    motion_line = header.count("\n") + 1  # 1-based line of MOTION
    if m is None:
        raise MocapFormatError(path, motion_line - 1 if text.endswith("\n") else motion_line, "no MOTION section")
    if not out["names"]:
        raise MocapFormatError(path, motion_line, "the hierarchy has no ROOT")
    skel = Skeleton(
        names=tuple(out["names"]),
        parents=np.array(out["parents"], dtype=np.int64),
        offsets=np.array(out["offsets"], dtype=np.float64).reshape(-1, 3),
        channels=tuple(out["channels"]),
        end_sites=tuple(out["end_sites"]),
    )
    del out, tk, header
    values, frame_time, warn, cut = _parse_motion(text, m.end(), motion_line, skel, path, strict)
    motion = motion_from_channels(skel, values, frame_time, source=path)
    if warn or cut:
        motion.meta["warnings"] = cut + warn
    for w in cut:  # a possibly cut file is also a Python warning (the other notes are only recorded)
        warnings.warn(f"{path}: {w}", MocapWarning, stacklevel=3)
    return motion


def _next_line(text: str, pos: int) -> tuple[str, int]:
    """The line starting at ``pos`` (without its newline) and the position after it."""
    end = text.find("\n", pos)
    if end < 0:
        return text[pos:], len(text)
    return text[pos:end], end + 1


def _header_value(text: str, pos: int, lineno: int, key: str, path: str) -> tuple[str, int, int]:
    """Value of the ``key`` line at or after ``pos`` (blank lines skipped), its line number and the
    position after it."""
    while True:
        if pos >= len(text):
            raise MocapFormatError(path, lineno - 1, f"missing '{key}' line")
        line, nxt = _next_line(text, pos)
        if line.strip():
            break
        pos, lineno = nxt, lineno + 1
    s = line.strip()
    if not s.lower().replace(" ", "").startswith(key.lower().replace(" ", "")):
        raise MocapFormatError(path, lineno, f"expected '{key} ...', found {s[:40]!r}")
    v = s.split(":", 1)[1].strip() if ":" in s else s[len(key):].strip()
    return v, lineno, nxt


def _column_names(skel: Skeleton) -> list[str]:
    return [f"{c} of joint {skel.names[j]}" for j, chans in enumerate(skel.channels) for c in chans]


def _field(skel: Skeleton, frame: int, col: int) -> str:
    names = _column_names(skel)
    what = names[col] if 0 <= col < len(names) else f"value {col + 1}"
    return f"frame {frame}, {what}"


def _strict_rows(data: str, first: int, skel: Skeleton, path: str, frame0: int = 1) -> list[list[float]]:
    """Line by line (glued numbers, exact diagnostics); ``first`` = file line of ``data``'s line 1,
    ``frame0`` its frame number."""
    C = skel.n_channels
    rows = []
    for k, s in enumerate(data.split("\n"), start=frame0 - 1):
        lineno = first + k - frame0 + 1
        s = s.strip()
        if not s:
            raise MocapFormatError(path, lineno, "blank line inside the motion data")
        toks = s.split()
        if not _NUMERIC_LINE.match(s):
            c = next(i for i, t in enumerate(toks) if not _NUMERIC_LINE.match(t))
            raise MocapFormatError(path, lineno, f"{_field(skel, k + 1, c)}: {toks[c][:30]!r} is not a number")
        nums: list[str] = []
        for t in toks:
            found = NUMBER_RE.findall(t)
            if "".join(found) != t:
                raise MocapFormatError(
                    path, lineno, f"{_field(skel, k + 1, len(nums))}: cannot read the numbers in {t[:40]!r}"
                )
            nums.extend(found)
        if len(nums) != C:
            raise MocapFormatError(path, lineno, f"expected {C} channel values (from the hierarchy), got {len(nums)}")
        rows.append([parse_number(t, path, lineno, _field(skel, k + 1, c)) for c, t in enumerate(nums)])
    return rows


def _only_number_chars(data: str) -> bool:
    """True when ``data`` holds only digits, ``eE+-.``, blanks, tabs and newlines (fast, in C)."""
    try:
        raw = data.encode("ascii")
    except UnicodeEncodeError:
        return False
    return not raw.translate(None, _NUMBER_CHARS)


def _count_values(line: str) -> int:
    return sum(len(NUMBER_RE.findall(t)) or 1 for t in line.split())


def _parse_motion(text: str, pos: int, motion_line: int, skel: Skeleton, path: str, strict: bool):
    """Frames, frame time and the frame block after the MOTION keyword at ``pos``."""
    _, pos = _next_line(text, pos)  # rest of the MOTION line
    v, fl, pos = _header_value(text, pos, motion_line + 1, "Frames:", path)
    if not _UINT.fullmatch(v):
        raise MocapFormatError(path, fl, f"Frames: {v[:40]!r} is not a non-negative integer")
    n_frames = int(v)
    v, tl, pos = _header_value(text, pos, fl + 1, "Frame Time:", path)
    frame_time = parse_number(v, path, tl, "Frame Time")
    if not MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME:
        rate = "not a positive time" if frame_time <= 0 else f"a rate of {1.0 / frame_time:.6g} Hz"
        raise MocapFormatError(
            path, tl, f"Frame Time {v[:40]} s ({rate}) is not between {MIN_FRAME_TIME:g} and {MAX_FRAME_TIME:g} s"
        )
    first = tl + 1  # file line of the first data line
    C, J = skel.n_channels, skel.n_joints
    data = text[pos:].rstrip()
    end = len(text)
    while end > pos and text[end - 1] in " \t\f\v":
        end -= 1
    final_newline = end > pos and text[end - 1] == "\n"
    check_cut = not final_newline
    warn: list[str] = []
    cut: list[str] = []
    if not data:
        raise MocapFormatError(path, tl, "no motion frames")
    if C == 0:
        raise MocapFormatError(path, first, "the hierarchy has no channels, but motion data follows")
    n_lines = data.count("\n") + 1
    if n_lines * J > max(MAX_JOINT_FRAMES, n_lines * C):
        raise MocapFormatError(
            path, first, f"{n_lines} frame lines × {J} joints ({C} channels) is more than this reader builds "
            f"(at most {MAX_JOINT_FRAMES:,} joint-frames unless there is a channel value per joint-frame)"
        )
    # blank lines: NumPy skips them, so the row count below disagrees and the line-by-line path names them
    bad = None if _only_number_chars(data) else _BAD_CHAR.search(data)
    if bad is not None:  # a character no number holds (nan, inf, 0_5...): name the line, the token and its column
        lstart = data.rfind("\n", 0, bad.start()) + 1
        line, _ = _next_line(data, lstart)
        k = data.count("\n", 0, lstart)
        _strict_rows(line, first + k, skel, path, frame0=k + 1)  # raises, naming the token
        raise MocapFormatError(path, first + k, f"unexpected character {data[bad.start()]!r} in the motion data")
    values = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values = np.loadtxt(io.StringIO(data), dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        values = None
    if values is not None and values.shape != (n_lines, C):
        values = None
    last_start = data.rfind("\n") + 1
    if values is None:
        # NumPy's parser refused (glued numbers, a wrong count, a malformed token): line by line, which
        # names the line; an incomplete last line without a final newline is a cut frame.
        if not final_newline:
            k = _count_values(data[last_start:])
            if k < C:
                msg = (f"the last frame (line {first + n_lines - 1}) is incomplete: {k} of {C} values before the "
                       "end of the file, which has no final newline (cut short?)")
                if strict:
                    raise MocapFormatError(path, first + n_lines - 1, msg + "; strict=False (--no-strict) drops it")
                cut.append(msg + "; dropped it")
                check_cut = False
                data = data[: max(last_start - 1, 0)]
                n_lines -= 1
                if n_lines == 0:
                    raise MocapFormatError(path, first, "no complete motion frame")
        values = np.array(_strict_rows(data, first, skel, path), dtype=np.float64).reshape(n_lines, C)
    badv = ~(np.abs(values) <= MAX_ABS)
    if badv.any():
        r, c = (int(x[0]) for x in np.nonzero(badv))
        x = float(values[r, c])
        what = "not finite" if not np.isfinite(x) else f"out of range (|value| > {MAX_ABS:g})"
        raise MocapFormatError(path, first + r, f"{_field(skel, r + 1, c)}: {x!r} is {what}")
    if check_cut:
        w = _cut_value_warning(data, last_start, first + n_lines - 1, skel)
        if w:
            cut.append(w)
    if values.shape[0] != n_frames:
        msg = f"header says Frames: {n_frames} but {values.shape[0]} data lines follow"
        if strict:
            raise MocapFormatError(path, fl, msg + " (--no-strict, or strict=False, takes the data lines)")
        warn.append(msg + f"; took the {values.shape[0]} data lines")
    return values, frame_time, warn, cut


def _cut_value_warning(data: str, last_start: int, lineno: int, skel: Skeleton) -> str | None:
    """A warning when the last value of a file without a final newline is shorter than its column."""
    last = data[last_start:].split()
    if not last:
        return None
    col = len(last) - 1
    start = last_start
    column = []
    for _ in range(100):
        if start == 0:
            break
        prev = data.rfind("\n", 0, start - 1) + 1
        toks = data[prev:start - 1].split()
        start = prev
        if len(toks) == len(last):
            column.append(toks[col])
    if looks_cut(last[col], column):
        what = _column_names(skel)[col] if col < skel.n_channels else "last value"
        return (f"line {lineno}, {what}: the file has no final newline and its last value {last[col][:30]!r} is "
                f"shorter than others of its column (the {len(column)} lines before it): it may be cut short")
    return None


def motion_from_channels(skel: Skeleton, values: np.ndarray, frame_time: float, source: str = "") -> Motion:
    """Build a Motion from BVH channel values ``(N, C)`` (degrees; positions replace offsets)."""
    N = values.shape[0]
    J = skel.n_joints
    axis = {"X": 0, "Y": 1, "Z": 2}
    rot = np.empty((N, J, 4))
    trans = np.broadcast_to(skel.offsets, (N, J, 3)).copy()
    pos_joint, pos_axis, pos_col = [], [], []
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}  # rotation order -> (joints, columns)
    no_rot = []
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
            no_rot.append(j)
    if no_rot:
        rot[:, no_rot] = (1.0, 0.0, 0.0, 0.0)
    if pos_col:
        trans[:, pos_joint, pos_axis] = values[:, pos_col]
    # Intrinsic Euler angles to scalar-first quaternions for all joints of one order at once: the
    # product of the elementary quaternions e0·e1·e2 computed with exactly the operations of scipy's
    # Rotation.from_euler(order, angles, degrees=True) (same values bit for bit, signed zeros and
    # NaNs included, no sign canonicalisation) without its per-element cost. Quaternions are
    # (x, y, z, w) here as in scipy; 0.0 stands for a component that is +0.0 in every frame.
    for order, (joints, cols) in groups.items():
        if any(a == b for a, b in pairwise(order)):
            from scipy.spatial.transform import Rotation  # scipy only for a bad order: reading imports none

            Rotation.from_euler(order, values[:, cols[0]], degrees=True)  # raises scipy's error, as before
        half = np.asarray(values[:, cols], dtype=np.float64)  # (N, joints, len(order)), a new array
        np.deg2rad(half, out=half)
        half /= 2.0
        with np.errstate(invalid="ignore"):  # cos/sin of ±inf give NaN quietly, as in scipy
            cos = np.cos(half)
            sin = np.sin(half, out=half)
        p: list[Any] = [0.0, 0.0, 0.0, cos[..., 0]]  # floats and (N,) arrays
        p[axis[order[0]]] = sin[..., 0]
        for i in range(1, len(order)):
            e: list[Any] = [0.0, 0.0, 0.0, cos[..., i]]
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


# --------------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------------


PARTIAL_AXIS_TOL_DEG = 1e-6
"""A joint with fewer than three rotation channels may turn at most this much about a missing axis."""


def channels_from_motion(motion: Motion) -> np.ndarray:
    """BVH channel values ``(N, C)`` for a motion: Euler angles (degrees, unwrapped over time so the
    channels are continuous) in each joint's order, and positions from the local translations."""
    from mocapkit.quat import to_scipy  # scipy and numba for writing only: reading a BVH imports neither

    skel = motion.skeleton
    cols = []
    for j, chans in enumerate(skel.channels):
        order = skel.rotation_order(j)
        eul = None
        if order:
            # a joint with one or two rotation channels: decompose in its order completed by the
            # missing axes, which must then turn by (numerically) nothing
            full = order + "".join(a for a in "XYZ" if a not in order.upper())
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # gimbal lock: scipy still returns a valid decomposition
                eul = to_scipy(motion.rotations[:, j]).as_euler(full, degrees=True)
            if len(order) < 3:
                off = np.abs(eul[:, len(order):])
                if off.size and off.max() > PARTIAL_AXIS_TOL_DEG:
                    f, a = np.unravel_index(int(np.argmax(off)), off.shape)
                    raise InvalidSignalError(
                        f"joint {skel.names[j]!r} has the rotation channels {order} only, but at frame {f} it "
                        f"turns {off[f, a]:.3g} degrees about {full[len(order) + a]}: BVH cannot hold that "
                        "(write .glb, or give the joint three rotation channels)")
                eul = eul[:, :len(order)]
            eul = np.degrees(np.unwrap(np.radians(eul), axis=0))
        k = 0
        for c in chans:
            if c in POSITION_CHANNELS:
                cols.append(motion.translations[:, j, "XYZ".index(c[0])])
            else:
                assert eul is not None  # a rotation channel gives the joint a rotation order
                cols.append(eul[:, k])
                k += 1
    if not cols:
        return np.zeros((motion.n_frames, 0))
    return np.stack(cols, axis=1)


_BAD_NAME = re.compile(r"[\s{}]")


def _check_writable(motion: Motion, vals: np.ndarray) -> None:
    """Refuse what would write a BVH file that cannot be read back as the same motion."""
    skel = motion.skeleton
    for n in skel.names:
        if not n or _BAD_NAME.search(n):
            raise InvalidSignalError(f"joint name {n!r} cannot be written to BVH (empty, or holds blanks or braces)")
    bad = ~(np.abs(skel.offsets) <= MAX_ABS)
    if bad.any():
        j = int(np.flatnonzero(bad.any(axis=1))[0])
        raise InvalidSignalError(
            f"OFFSET of joint {skel.names[j]!r} is not finite or too large: {skel.offsets[j].tolist()}"
        )
    for j, off in skel.end_sites:
        if not all(abs(float(x)) <= MAX_ABS for x in off):
            raise InvalidSignalError(
                f"End Site OFFSET of joint {skel.names[j]!r} is not finite or too large: {list(off)}"
            )
    if vals.shape != (motion.n_frames, skel.n_channels):
        raise InvalidSignalError(
            f"channel values have shape {vals.shape}, expected {(motion.n_frames, skel.n_channels)}"
        )
    bad = ~(np.abs(vals) <= MAX_ABS)
    if bad.any():
        r, c = (int(x[0]) for x in np.nonzero(bad))
        raise InvalidSignalError(f"{_field(skel, r + 1, c)}: {float(vals[r, c])!r} is not finite or too large to write")
    ft = motion.frame_time
    if not MIN_FRAME_TIME <= ft <= MAX_FRAME_TIME:
        raise InvalidSignalError(f"frame time {ft!r} s is not between {MIN_FRAME_TIME:g} and {MAX_FRAME_TIME:g} s")


def write_bvh(path: str | Path, motion: Motion, precision: int = 6, use_channel_values: bool = True) -> None:
    """Write a BVH file atomically. Channel values come from ``motion.channel_values`` when present
    (exact reproduction of a file that was read) unless ``use_channel_values=False``; otherwise they
    are computed from the rotations and translations.

    The hierarchy is written with an explicit stack (any depth), indented one tab a level up to
    32 levels (deeper joints keep that indentation, so the file size stays linear in the number of
    joints). Non-finite or huge values, and joint names BVH cannot hold, raise
    :class:`~mocapkit.errors.InvalidSignalError` before anything is written.
    """
    if isinstance(precision, bool) or not isinstance(precision, (int, np.integer)) or not 0 <= precision <= 17:
        raise InvalidParameterError(f"precision must be an integer number of decimals from 0 to 17, got {precision!r}")
    skel = motion.skeleton
    vals = (
        motion.channel_values
        if (use_channel_values and motion.channel_values is not None)
        else channels_from_motion(motion)
    )
    vals = np.asarray(vals, dtype=np.float64).reshape(motion.n_frames, -1)
    _check_writable(motion, vals)
    out = ["HIERARCHY"]
    kids = skel.children_lists()
    ends: dict[int, list] = {}
    for j, off in skel.end_sites:
        ends.setdefault(j, []).append(off)

    def num(x: float) -> str:
        return f"{x:.{precision}f}"

    stack = [(j, 0, False) for j in range(skel.n_joints - 1, -1, -1) if skel.parents[j] < 0]
    while stack:
        j, depth, closing = stack.pop()
        ind = "\t" * min(depth, _MAX_INDENT)
        if closing:
            for off in ends.get(j, []):
                out.append(f"{ind}\tEnd Site")
                out.append(f"{ind}\t{{")
                out.append(f"{ind}\t\tOFFSET " + " ".join(num(v) for v in off))
                out.append(f"{ind}\t}}")
            out.append(f"{ind}}}")
            continue
        kw = "ROOT" if skel.parents[j] < 0 else "JOINT"
        out.append(f"{ind}{kw} {skel.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET " + " ".join(num(v) for v in skel.offsets[j]))
        if skel.channels[j]:
            out.append(f"{ind}\tCHANNELS {len(skel.channels[j])} " + " ".join(skel.channels[j]))
        stack.append((j, depth, True))
        stack.extend((k, depth + 1, False) for k in reversed(kids[j]))
    out.append("MOTION")
    out.append(f"Frames: {motion.n_frames}")
    out.append(f"Frame Time: {motion.frame_time:.{max(precision, 6)}g}")
    fmt = f"%.{precision}f"
    body = "\n".join(" ".join(fmt % v for v in row) for row in vals.tolist())
    atomic_write_text(path, "\n".join(out) + "\n" + body + "\n")
