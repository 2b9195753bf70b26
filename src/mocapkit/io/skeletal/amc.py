"""Acclaim ASF (skeleton) and AMC (motion) files, as written by the CMU Graphics Lab mocap database.

Reading
-------
:func:`read_asf` parses a skeleton file into a :class:`~mocapkit.skeleton.Skeleton`;
:func:`read_amc` parses a motion file against that skeleton into a :class:`~mocapkit.skeleton.Motion`;
:func:`read_asf_amc` does both. :func:`write_amc` writes a motion back as AMC.

Accepted syntax: ``#`` comments; commas and parentheses are whitespace (Acclaim spec); CRLF, LF or CR
line ends, a UTF-8 byte-order mark, a missing final newline and trailing blank lines. ASF sections
``:version``, ``:name``, ``:units`` (``mass``, ``length``, ``angle deg|rad``; default 1, 1, deg),
``:documentation`` (free text up to the next ``:`` keyword), ``:root`` (``order`` — any arrangement
of ``TX TY TZ RX RY RZ`` —, ``axis``, ``position``, ``orientation``), ``:bonedata`` (``begin`` …
``end`` blocks with ``id``, ``name``, ``direction``, ``length``, ``axis ax ay az XYZ``, ``dof`` — any
subset of ``rx ry rz`` —, ``limits`` one ``(lo hi)`` pair per dof over one or several lines,
``bodymass``, ``cofmass``) and ``:hierarchy`` (``begin``, ``parent child child …`` lines, ``end``);
other ``:`` sections (``:skin``…) are skipped. AMC: header keywords ``:FULLY-SPECIFIED``,
``:DEGREES``, ``:RADIANS``, then per frame a line with the frame number followed by one line
``bone v1 v2 …`` per bone that has dofs (values in the bone's dof order; the root's in its
``order``). Frame numbers must be consecutive. Translation dofs on bones (``tx ty tz``) and the
bone-length dof ``l`` are not supported (CMU never uses them) and are reported as errors.

Anything malformed raises :class:`~mocapkit.errors.MocapFormatError` with the file and the 1-based
line (``None`` when the problem concerns the whole file).

Numbers (ASF lengths, directions, axis angles, limits, units; AMC values) follow the strict grammar
of :mod:`mocapkit.io.text.numbers`: no ``0_5``, no ``nan``, no ``inf`` (neither format has a missing-value
convention; the one exception is the Acclaim ``(-inf inf)`` of ASF ``limits``, meaning no limit), and
``|value| <= MAX_ABS``; the error names the line and the field (``bone lfemur``, ``length``).
``:units length`` must lie in ``[1e-6, 1e6]`` and the frame rate in ``[1e-6, 1e6]`` Hz. The hierarchy
is walked with explicit stacks (no recursion, any depth) and the work is linear in the number of
bones. A frame count times bone count that would build more than
:data:`~mocapkit.skeleton.MAX_JOINT_FRAMES` joint-frames without a value per joint-frame is refused.

End of file: an AMC file cut short is recognised when it has no final newline. A last bone line with
too few values, a cut bone name or a last frame without all its bones is an error that says so; a
last value ending with ``.``, ``e``, ``E``, ``+`` or ``-`` (``-4.`` for ``-4.29897``) is an error too. A last
line with the right count whose last value has fewer decimals (or exponent digits) than that value in
every one of the up to 100 earlier lines of the bone (``-0`` for ``-0.124044``) or, the values being
written with varying decimals (``%g``, as the CMU files), fewer significant characters than the
longest of them (``-4.2989`` for ``-4.29897``; see :func:`mocapkit.io.text.numbers.cut_kind`) is read with a
warning (``Motion.meta["warnings"]`` and :func:`warnings.warn`, category
:class:`~mocapkit.errors.MocapWarning`). Line ends (LF, CRLF, CR) make no difference.

Model mapping
-------------
* Every ASF bone becomes a joint located at the bone's *start*; the root is joint 0 and is named
  ``"root"``. Joints are in depth-first order of the ``:hierarchy`` (children in the order listed).
* Rest pose: every local rotation is the identity, and every joint frame is aligned with the ASF
  world frame (ASF ``direction`` vectors are given in world coordinates).
* Offset of a joint (relative to its parent joint) = the *parent bone's* ``direction × length``.
  The root has no direction/length, so children of the root have offset 0; the root's own offset
  is the ASF ``:root position``.
* Local rotation of a bone joint::

      L = C · M · C⁻¹

  with ``C`` the rotation of the bone's ``axis`` line and ``M`` the AMC dof rotation. Both are
  Euler rotations about the *fixed* (world/parent) axes applied in the listed order, i.e. the matrix
  of ``axis a b c XYZ`` is ``C = Rz(c)·Ry(b)·Rx(a)`` and the matrix of dofs ``rx ry rz`` with values
  ``(x, y, z)`` is ``M = Rz(z)·Ry(y)·Rx(x)`` (scipy: ``Rotation.from_euler("xyz", …)``, lower case =
  extrinsic); a subset such as ``rx rz`` gives ``M = Rz·Rx``. This is the CMU viewer/amc_to_matrix
  convention. Axis values pair with the letters of the axis order (``axis a b c ZYX`` is
  ``Rx(c)·Ry(b)·Rz(a)``); for the usual ``XYZ`` that is ``x, y, z``.
* The world rotation of a bone is the product of the ``L`` of its ancestors and itself
  (``W_b = W_parent · C_b·M_b·C_b⁻¹``, the root's ``W = C_root·M_root·C_root⁻¹``), and a bone's end
  (its children's joint position) is ``start + W_b · direction·length`` — exactly what
  :func:`mocapkit.skeleton.forward_kinematics` computes from the arrays of this module.
* Root: translation = ASF ``position`` + AMC ``TX TY TZ`` (world coordinates); rotation
  ``C_root·M_root·C_root⁻¹`` with ``C_root`` from ``orientation`` in the ``axis`` order and
  ``M_root`` from the AMC ``RX RY RZ`` values composed about fixed axes in the ``order`` listed
  (``RX RY RZ`` → ``Rz·Ry·Rx``).
* Bones without dofs (CMU ``lhipjoint``, ``rhipjoint``) get ``L = C·I·C⁻¹ = I``.
* Leaf bones get an end site at their ``direction × length``.
* ``Skeleton.channels`` make the motion writable as BVH: the root has
  ``Xposition Yposition Zposition Zrotation Yrotation Xrotation`` and every other joint
  ``Zrotation Yrotation Xrotation`` (BVH intrinsic Z-Y-X: ``R = Rz·Ry·Rx``), also bones with no
  dofs. ``Motion.channel_values`` is ``None``: AMC values are not BVH channel values (they are
  angles in the bone's ``axis`` frame). The raw AMC values are kept in
  ``Motion.meta["amc_values"]`` (``{bone: (N, k) array}``).

Units
-----
Lengths stay in ASF units in every array. ``:units length u`` is the number of file length units
per inch (Acclaim spec: ``length 2.54`` = data in cm, local units inches), so one unit is
``2.54 / u`` cm; CMU writes ``length 0.45``, i.e. one unit is 1/0.45 inch = 5.6444 cm (CMU's own
conversion to metres is ``(1/0.45)·2.54/100``). This is stored as
``Skeleton.meta["length_unit_cm"]`` (override with ``read_asf(..., length_unit_cm=...)``). The AMC
root translation is in the same units as the bone lengths. Angles: the ASF ``angle`` unit applies to
``axis``/``orientation``/``limits``; AMC values are in degrees with ``:DEGREES``, radians with
``:RADIANS``, otherwise in the ASF's angle unit. ``Motion.times = arange(N) / rate`` (CMU: 120 Hz)
and ``Motion.meta["frame_time"] = 1 / rate``.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapError, MocapFormatError, MocapWarning
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.text.numbers import MAX_ABS, cut_kind, parse_number
from mocapkit.quat import from_scipy, multiply, to_scipy
from mocapkit.skeleton import MAX_JOINT_FRAMES, Motion, Skeleton

__all__ = [
    "CMU_RATE",
    "DEFAULT_MAX_RESIDUAL_DEG",
    "ROOT_CHANNELS",
    "JOINT_CHANNELS",
    "load_amc_for_cli",
    "project_onto_dofs",
    "read_amc",
    "read_amc_text",
    "read_asf",
    "read_asf_amc",
    "read_asf_text",
    "write_amc",
]

#: Frame rate of the CMU database (Hz), the default rate of :func:`read_amc`.
CMU_RATE = 120.0
MIN_RATE, MAX_RATE = 1e-6, 1e6  # Hz: frame times from 1 µs to 11.6 days
#: ``:units length`` accepted (file units per inch; CMU 0.45): lengths in cm stay far from overflow.
MIN_LENGTH_UNIT, MAX_LENGTH_UNIT = 1e-6, 1e6
ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")

_ROOT_NAME = "root"
_ROOT_TOKENS = ("TX", "TY", "TZ", "RX", "RY", "RZ")
_BONE_DOFS = ("rx", "ry", "rz")
_UNSUPPORTED_DOFS = ("tx", "ty", "tz", "l")
_AXIS_ORDER_RE = re.compile(r"^[XYZ]{3}$")
_LINE_SPLIT_RE = re.compile(r"\r\n|\r|\n")
_WS_TRANS = str.maketrans({",": " ", "(": " ", ")": " "})
_SURROGATE_RE = re.compile("[\udc80-\udcff]")


# --------------------------------------------------------------------------------------------------
# text helpers
# --------------------------------------------------------------------------------------------------


def _short(text: str, limit: int = 60) -> str:
    text = str(text)
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def _read_bytes(path: str | Path) -> tuple[str, bytes | bytearray]:
    from mocapkit.io.text.input import read_input

    return str(Path(path)), read_input(path, "text file")


def _decode(data: bytes | bytearray) -> str:
    """Bytes to text; undecodable bytes become lone surrogates, reported only where they matter."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    return data.decode("utf-8", errors="surrogateescape")


def _lines(text: str) -> list[str]:
    if text.startswith("\ufeff"):
        text = text[1:]
    return _LINE_SPLIT_RE.split(text)


def _check_text(src: str, ln: int, line: str) -> None:
    if not line.isascii():
        m = _SURROGATE_RE.search(line)
        if m is not None:
            byte = ord(m.group()) - 0xDC00
            raise MocapFormatError(src, ln, f"not UTF-8 text: byte 0x{byte:02x} cannot be decoded")
        if "\x00" in line:
            raise MocapFormatError(src, ln, "NUL byte in the text")
    elif "\x00" in line:
        raise MocapFormatError(src, ln, "NUL byte in the text")


def _number(src: str, ln: int, tok: str, what: str, allow_inf: bool = False) -> float:
    """One value by the strict grammar of :mod:`mocapkit.io.text.numbers` (``|v| <= MAX_ABS``); ``inf``
    spelled out only where ``allow_inf`` (ASF limits: the Acclaim ``(-inf inf)`` convention)."""
    word = tok.lower().lstrip("+-")
    if word == "nan":
        raise MocapFormatError(src, ln, f"{what} is NaN")
    if word in ("inf", "infinity"):
        if allow_inf:
            return -math.inf if tok.startswith("-") else math.inf
        raise MocapFormatError(src, ln, f"{what} is infinite ({_short(tok)})")
    return parse_number(tok, src, ln, what)


def _numbers(src: str, ln: int, toks: list[str], n: int, what: str) -> tuple[float, ...]:
    if len(toks) != n:
        raise MocapFormatError(src, ln, f"{what}: expected {n} number{'s' if n != 1 else ''}, got {len(toks)}")
    return tuple(_number(src, ln, t, what) for t in toks)


def _euler(order: str, angles, degrees: bool) -> Rotation:
    """Rotation about fixed axes applied in ``order`` (e.g. ``"XYZ"`` → ``Rz·Ry·Rx``)."""
    a = np.asarray(angles, dtype=np.float64)
    return Rotation.from_euler(order.lower(), a, degrees=degrees)


# --------------------------------------------------------------------------------------------------
# ASF
# --------------------------------------------------------------------------------------------------


class _Bone:
    __slots__ = ("line", "fields", "id", "name", "direction", "length", "axis", "axis_order", "dofs",
                 "limits", "last_key", "end_line")

    def __init__(self, line: int) -> None:
        self.line = line
        self.fields: dict[str, int] = {}
        self.id: int | None = None
        self.name = ""  # until its 'name' line (then in fields)
        self.direction: tuple[float, float, float] | None = None
        self.length: float | None = None
        self.axis: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.axis_order = "XYZ"
        self.dofs: tuple[str, ...] = ()
        self.limits: list[tuple[float, float]] = []
        self.last_key: str | None = None
        self.end_line: int | None = None


_SECTIONS = ("version", "name", "units", "documentation", "root", "bonedata", "hierarchy")


def read_asf(path: str | Path, length_unit_cm: float | None = None) -> Skeleton:
    """Read an Acclaim skeleton file (see the module docstring for the model mapping).

    Parameters
    ----------
    path
        The ``.asf`` file.
    length_unit_cm
        Centimetres per ASF length unit; default ``2.54 / (:units length)`` (CMU: 2.54/0.45).
    """
    src, data = _read_bytes(path)
    return read_asf_text(_decode(data), src, length_unit_cm=length_unit_cm)


def read_asf_text(text: str, source: str = "<asf>", length_unit_cm: float | None = None) -> Skeleton:
    """Parse the text of an ASF file; ``source`` names it in error messages."""
    if length_unit_cm is not None:
        try:
            cm = float(length_unit_cm)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"length_unit_cm must be a positive number, got {length_unit_cm!r}") from None
        if not (math.isfinite(cm) and cm > 0):
            raise InvalidParameterError(f"length_unit_cm must be a positive number, got {length_unit_cm!r}")
    src = str(source)
    return _guarded(lambda state: _parse_asf(text, src, length_unit_cm, state), src)


def _guarded(parse, src: str):
    """Run ``parse(state)``; any other error it raises becomes a ``MocapFormatError`` at the line
    ``state["line"]`` being read."""
    state = {"line": None}
    try:
        return parse(state)
    except MocapError as exc:
        if isinstance(exc, MocapFormatError):
            raise
        raise MocapFormatError(src, state["line"], str(exc)) from None
    except (ValueError, IndexError, KeyError, TypeError, OverflowError, ZeroDivisionError,
            UnicodeError) as exc:
        raise MocapFormatError(src, state["line"], f"cannot parse: {exc}") from None


def _parse_asf(text: str, src: str, length_unit_cm: float | None, state: dict) -> Skeleton:
    lines = _lines(text)
    seen: dict[str, int] = {}
    section: str | None = None
    units: dict[str, Any] = {"mass": 1.0, "length": 1.0, "angle": "deg"}  # angle: "deg" or "rad"
    unit_lines: dict[str, int] = {}
    root: dict = {}
    root_lines: dict[str, int] = {}
    bones: list[_Bone] = []
    bone_lines: dict[str, int] = {}  # name -> line of its 'begin'
    cur: _Bone | None = None
    hier_state = 0  # 0 before begin, 1 inside, 2 after end
    hier_begin = 0
    hier: list[tuple[int, str, list[str]]] = []
    version = name = None

    for ln, raw in enumerate(lines, 1):
        state["line"] = ln
        if section == "documentation" and not raw.lstrip().startswith(":"):
            continue
        body = raw.split("#", 1)[0]
        toks = body.translate(_WS_TRANS).split()
        if not toks:
            continue
        _check_text(src, ln, body)
        t0 = toks[0]
        if t0.startswith(":"):
            kw = t0[1:].lower()
            if cur is not None:
                raise MocapFormatError(
                    src, ln, f"{_short(t0)} inside the bone block opened by 'begin' on line {cur.line} (missing 'end')"
                )
            if section == "hierarchy" and hier_state == 1:
                raise MocapFormatError(src, ln, f"{_short(t0)} inside the :hierarchy block (missing 'end')")
            if kw in seen:
                raise MocapFormatError(src, ln, f"section :{kw} appears twice (first on line {seen[kw]})")
            if kw in _SECTIONS:
                seen[kw] = ln
            section = kw if kw in _SECTIONS else "?"
            if kw == "version":
                version = " ".join(toks[1:]) or None
            elif kw == "name":
                name = " ".join(toks[1:]) or None
            elif kw in ("units", "root", "bonedata", "hierarchy") and len(toks) > 1:
                raise MocapFormatError(src, ln, f"unexpected {_short(' '.join(toks[1:]))} after :{kw}")
            continue
        if section is None:
            raise MocapFormatError(src, ln, f"{_short(body.strip())} before the first ':' section keyword")
        if section in ("version", "name"):
            raise MocapFormatError(src, ln, f"unexpected line {_short(body.strip())} after :{section}")
        if section == "?":
            continue
        key = t0.lower()
        args = toks[1:]
        if section == "units":
            if key in unit_lines:
                raise MocapFormatError(src, ln, f"unit {key!r} given twice (first on line {unit_lines[key]})")
            if key in ("mass", "length"):
                (v,) = _numbers(src, ln, args, 1, f"units {key}")
                if v <= 0:
                    raise MocapFormatError(src, ln, f"units {key} must be positive, got {args[0]}")
                if key == "length" and not MIN_LENGTH_UNIT <= v <= MAX_LENGTH_UNIT:
                    raise MocapFormatError(
                        src, ln, f"units length {args[0]} is not between {MIN_LENGTH_UNIT:g} and {MAX_LENGTH_UNIT:g}"
                    )
                units[key] = v
            elif key == "angle":
                if len(args) != 1 or args[0].lower() not in ("deg", "rad"):
                    raise MocapFormatError(src, ln, f"units angle must be 'deg' or 'rad', got {_short(' '.join(args))}")
                units["angle"] = args[0].lower()
            else:
                raise MocapFormatError(src, ln, f"unknown unit {_short(t0)} (expected mass, length or angle)")
            unit_lines[key] = ln
        elif section == "root":
            if key in root_lines:
                raise MocapFormatError(src, ln, f":root {key} given twice (first on line {root_lines[key]})")
            if key == "order":
                root_order = tuple(a.upper() for a in args)
                if not root_order:
                    raise MocapFormatError(src, ln, ":root order is empty")
                bad = [a for a in root_order if a not in _ROOT_TOKENS]
                if bad:
                    raise MocapFormatError(
                        src, ln, f":root order: unknown token {_short(bad[0])} (expected TX TY TZ RX RY RZ)"
                    )
                if len(set(root_order)) != len(root_order):
                    raise MocapFormatError(src, ln, ":root order names a channel twice")
                root["order"] = root_order
            elif key == "axis":
                if len(args) != 1 or not _AXIS_ORDER_RE.match(args[0].upper()) or len(set(args[0].upper())) != 3:
                    raise MocapFormatError(
                        src, ln, f":root axis must be an order such as XYZ, got {_short(' '.join(args))}"
                    )
                root["axis"] = args[0].upper()
            elif key in ("position", "orientation"):
                root[key] = _numbers(src, ln, args, 3, f":root {key}")
            else:
                raise MocapFormatError(
                    src, ln, f"unknown :root field {_short(t0)} (expected order, axis, position, orientation)"
                )
            root_lines[key] = ln
        elif section == "bonedata":
            cur = _bone_line(src, ln, key, t0, args, toks, cur, bones, bone_lines)
        elif section == "hierarchy":
            if key == "begin" and not args:
                if hier_state != 0:
                    raise MocapFormatError(src, ln, "second 'begin' in :hierarchy")
                hier_state = 1
                hier_begin = ln
            elif key == "end" and not args:
                if hier_state != 1:
                    raise MocapFormatError(src, ln, "'end' without 'begin' in :hierarchy")
                hier_state = 2
            else:
                if hier_state == 0:
                    raise MocapFormatError(src, ln, f"{_short(body.strip())} before 'begin' in :hierarchy")
                if hier_state == 2:
                    raise MocapFormatError(src, ln, f"{_short(body.strip())} after 'end' of :hierarchy")
                if not args:
                    raise MocapFormatError(src, ln, f"hierarchy line names the parent {_short(t0)} but no children")
                hier.append((ln, t0, args))
    state["line"] = None

    if cur is not None:
        raise MocapFormatError(src, cur.line, "bone block not closed by 'end' before the end of the file")
    if "root" not in seen:
        raise MocapFormatError(src, None, "no :root section")
    if "order" not in root:
        raise MocapFormatError(src, seen["root"], ":root has no 'order' line")
    if "bonedata" not in seen:
        raise MocapFormatError(src, None, "no :bonedata section")
    if bones and "hierarchy" not in seen:
        raise MocapFormatError(src, None, "no :hierarchy section")
    if "hierarchy" in seen and hier_state == 0:
        raise MocapFormatError(src, seen["hierarchy"], ":hierarchy has no 'begin'")
    if hier_state == 1:
        raise MocapFormatError(src, hier_begin, ":hierarchy 'begin' not closed by 'end' before the end of the file")

    # ---- hierarchy ----
    by_name = {b.name: b for b in bones}
    parent_of: dict[str, tuple[str, int]] = {}
    children: dict[str, list[str]] = {_ROOT_NAME: []}
    for b in bones:
        children[b.name] = []
    for ln, par, kids in hier:
        if par != _ROOT_NAME and par not in by_name:
            raise MocapFormatError(src, ln, f"hierarchy names an unknown bone {_short(par)} (not in :bonedata)")
        for kid in kids:
            if kid == _ROOT_NAME:
                raise MocapFormatError(src, ln, "the root cannot be the child of a bone")
            if kid not in by_name:
                raise MocapFormatError(src, ln, f"hierarchy names an unknown bone {_short(kid)} (not in :bonedata)")
            if kid == par:
                raise MocapFormatError(src, ln, f"bone {_short(kid)} is listed as its own child (cycle)")
            if kid in parent_of:
                raise MocapFormatError(
                    src, ln, f"bone {_short(kid)} has two parents: {_short(parent_of[kid][0])} "
                    f"(line {parent_of[kid][1]}) and {_short(par)}"
                )
            parent_of[kid] = (par, ln)
            children[par].append(kid)
    for b in bones:
        if b.name not in parent_of:
            raise MocapFormatError(
                src, b.fields["name"], f"bone {_short(b.name)} is not attached anywhere in :hierarchy"
            )
    # cycles: with one parent each, a bone that does not reach the root lies on (or hangs off) a
    # cycle. Each bone is walked up once: a walk stops at a bone already known to reach the root.
    reaches = {_ROOT_NAME}
    for b in bones:
        path = [b.name]
        seen_here = {b.name}
        p = parent_of[b.name][0]
        while p not in reaches:
            if p in seen_here:
                cyc = path[path.index(p):] + [p]
                raise MocapFormatError(
                    src, parent_of[p][1], "cycle in :hierarchy: " + " -> ".join(reversed(cyc))
                )
            path.append(p)
            seen_here.add(p)
            p = parent_of[p][0]
        reaches.update(path)

    order: list[str] = []
    stack = [_ROOT_NAME]
    while stack:
        n = stack.pop()
        order.append(n)
        stack.extend(reversed(children[n]))
    index = {n: i for i, n in enumerate(order)}

    # ---- arrays ----
    J = len(order)
    parents = np.full(J, -1, dtype=np.int64)
    offsets = np.zeros((J, 3))
    position = tuple(root.get("position", (0.0, 0.0, 0.0)))
    offsets[0] = position
    for n in order[1:]:
        par = parent_of[n][0]
        parents[index[n]] = index[par]
        if par != _ROOT_NAME:
            pb = by_name[par]
            offsets[index[n]] = np.asarray(pb.direction) * pb.length
    end_sites: list[tuple[int, tuple[float, float, float]]] = []
    for n in order[1:]:
        if not children[n]:
            b = by_name[n]
            x, y, z = (float(v) for v in np.asarray(b.direction) * b.length)
            end_sites.append((index[n], (x, y, z)))
    if not np.all(np.isfinite(offsets)) or not all(math.isfinite(v) for _, o in end_sites for v in o):
        raise MocapFormatError(src, None, "a bone's direction × length overflows")
    channels = tuple(ROOT_CHANNELS if j == 0 else JOINT_CHANNELS for j in range(J))

    deg = units["angle"] == "deg"
    asf_info: dict[str, Any] = {
        "version": version,
        "name": name,
        "units": dict(units),
        "root": {
            "order": root["order"],
            "axis": root.get("axis", "XYZ"),
            "position": position,
            "orientation": tuple(root.get("orientation", (0.0, 0.0, 0.0))),
        },
        "bones": {
            b.name: {
                "id": b.id,
                "direction": b.direction,
                "length": b.length,
                "axis": b.axis,
                "axis_order": b.axis_order,
                "dofs": b.dofs,
                "limits": tuple(b.limits),
            }
            for b in bones
        },
        "bone_order": tuple(b.name for b in bones),
        "source": src,
    }
    # axis rotations C (scalar-first quaternions), root first
    c_quats = {_ROOT_NAME: from_scipy(_euler(asf_info["root"]["axis"], asf_info["root"]["orientation"], deg))}
    for b in bones:
        c_quats[b.name] = from_scipy(_euler(b.axis_order, b.axis, deg))
    asf_info["axis_quat"] = {k: tuple(float(x) for x in v) for k, v in c_quats.items()}

    cm = 2.54 / units["length"] if length_unit_cm is None else float(length_unit_cm)
    meta = {"format": "asf", "length_unit_cm": cm, "asf": asf_info}
    return Skeleton(tuple(order), parents, offsets, channels, tuple(end_sites), meta)


def _bone_line(src: str, ln: int, key: str, t0: str, args: list[str], toks: list[str],
               cur: _Bone | None, bones: list[_Bone], first_line: dict[str, int]) -> _Bone | None:
    if key == "begin" and not args:
        if cur is not None:
            raise MocapFormatError(src, ln, f"'begin' inside the bone block opened on line {cur.line} (missing 'end')")
        return _Bone(ln)
    if cur is None:
        raise MocapFormatError(
            src, ln, f"{_short(' '.join(toks))} outside a bone block ('begin' … 'end') in :bonedata"
        )
    if key == "end" and not args:
        if "name" not in cur.fields:
            raise MocapFormatError(src, ln, f"bone block (line {cur.line}) has no 'name'")
        for field in ("direction", "length"):
            if getattr(cur, field) is None:
                raise MocapFormatError(src, ln, f"bone {_short(cur.name)} (line {cur.line}) has no '{field}'")
        if "limits" in cur.fields and len(cur.limits) != len(cur.dofs):
            raise MocapFormatError(
                src, ln, f"bone {_short(cur.name)}: {len(cur.limits)} limit pair(s) for {len(cur.dofs)} dof(s)"
            )
        if cur.name in first_line:
            raise MocapFormatError(
                src, cur.fields["name"], f"bone {_short(cur.name)} defined twice (first at line {first_line[cur.name]})"
            )
        cur.end_line = ln
        bones.append(cur)
        first_line[cur.name] = cur.line
        return None
    # a continuation line of 'limits': numbers only
    if cur.last_key == "limits" and _looks_numeric(t0):
        _add_limits(src, ln, toks, cur)
        return cur
    if key in cur.fields:
        raise MocapFormatError(src, ln, f"bone field {key!r} given twice (first on line {cur.fields[key]})")
    if key == "id":
        if len(args) != 1 or not args[0].isascii() or not args[0].lstrip("+-").isdigit():
            raise MocapFormatError(src, ln, f"bone id must be an integer, got {_short(' '.join(args))}")
        cur.id = int(args[0])
    elif key == "name":
        if len(args) != 1:
            raise MocapFormatError(src, ln, f"bone name must be one word, got {_short(' '.join(args))}")
        if args[0] == _ROOT_NAME:
            raise MocapFormatError(src, ln, "a bone cannot be named 'root' (the name of the :root)")
        cur.name = args[0]
    elif key == "direction":
        x, y, z = _numbers(src, ln, args, 3, "direction")
        cur.direction = (x, y, z)
    elif key == "length":
        (v,) = _numbers(src, ln, args, 1, "length")
        if v < 0:
            raise MocapFormatError(src, ln, f"bone length must not be negative, got {args[0]}")
        cur.length = v
    elif key == "axis":
        if len(args) != 4:
            raise MocapFormatError(
                src, ln, f"axis: expected three angles and an order such as XYZ, got {_short(' '.join(args))}"
            )
        x, y, z = _numbers(src, ln, args[:3], 3, "axis")
        o = args[3].upper()
        if not _AXIS_ORDER_RE.match(o) or len(set(o)) != 3:
            raise MocapFormatError(src, ln, f"axis order must be a permutation of XYZ, got {_short(args[3])}")
        cur.axis, cur.axis_order = (x, y, z), o
    elif key == "dof":
        dofs = tuple(a.lower() for a in args)
        if not dofs:
            raise MocapFormatError(src, ln, "dof line without dofs")
        for d in dofs:
            if d in _UNSUPPORTED_DOFS:
                raise MocapFormatError(src, ln, f"dof {d!r} is not supported (only rx, ry, rz on bones)")
            if d not in _BONE_DOFS:
                raise MocapFormatError(src, ln, f"unknown dof {_short(d)} (expected rx, ry, rz)")
        if len(set(dofs)) != len(dofs):
            raise MocapFormatError(src, ln, "a dof is listed twice")
        if "limits" in cur.fields:
            raise MocapFormatError(src, ln, "'dof' after 'limits' (limits pair with the dofs listed before)")
        cur.dofs = dofs
    elif key == "limits":
        cur.fields[key] = ln
        cur.last_key = key
        _add_limits(src, ln, args, cur)
        return cur
    elif key in ("bodymass", "cofmass"):
        for a in args:
            _number(src, ln, a, key)
        if not args:
            raise MocapFormatError(src, ln, f"{key} without a value")
    else:
        raise MocapFormatError(src, ln, f"unknown bone field {_short(t0)}")
    cur.fields[key] = ln
    cur.last_key = key
    return cur


def _looks_numeric(tok: str) -> bool:
    t = tok.lower().lstrip("+-")
    return bool(t) and (t[0].isdigit() or t[0] == "." or t.startswith("inf"))


def _add_limits(src: str, ln: int, toks: list[str], cur: _Bone) -> None:
    if len(toks) % 2 or not toks:
        raise MocapFormatError(src, ln, f"limits: expected '(lo hi)' pairs, got {_short(' '.join(toks))}")
    vals = [_number(src, ln, t, "limits", allow_inf=True) for t in toks]
    for i in range(0, len(vals), 2):
        lo, hi = vals[i], vals[i + 1]
        if lo > hi:
            raise MocapFormatError(src, ln, f"limits: lower bound {toks[i]} exceeds upper bound {toks[i + 1]}")
        cur.limits.append((lo, hi))
    if len(cur.limits) > len(cur.dofs):
        raise MocapFormatError(src, ln, f"limits: more pairs than the {len(cur.dofs)} dof(s) of the bone")


# --------------------------------------------------------------------------------------------------
# AMC
# --------------------------------------------------------------------------------------------------


def _check_rate(rate) -> float:
    try:
        r = float(rate)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"rate must be a finite positive number of Hz, got {rate!r}") from None
    if not (math.isfinite(r) and r > 0):
        raise InvalidParameterError(f"rate must be a finite positive number of Hz, got {rate!r}")
    if not MIN_RATE <= r <= MAX_RATE:
        raise InvalidParameterError(f"rate must be between {MIN_RATE:g} and {MAX_RATE:g} Hz, got {rate!r}")
    return r


def _asf_of(skeleton_or_asf_path) -> Skeleton:
    if isinstance(skeleton_or_asf_path, Skeleton):
        sk = skeleton_or_asf_path
        if not isinstance(sk.meta.get("asf"), dict):
            raise InvalidParameterError("the skeleton was not read from an ASF file (read it with read_asf)")
        return sk
    if isinstance(skeleton_or_asf_path, (str, Path)):
        return read_asf(skeleton_or_asf_path)
    raise InvalidParameterError(
        f"expected a Skeleton from read_asf or the path of an .asf file, got {type(skeleton_or_asf_path).__name__}"
    )


def read_amc(path: str | Path, skeleton_or_asf_path: Skeleton | str | Path, rate: float = CMU_RATE) -> Motion:
    """Read an AMC motion file against its ASF skeleton.

    Parameters
    ----------
    path
        The ``.amc`` file.
    skeleton_or_asf_path
        A skeleton returned by :func:`read_asf`, or the path of the ``.asf`` file.
    rate
        Frame rate in Hz (AMC files do not store it; CMU: 120).
    """
    r = _check_rate(rate)
    sk = _asf_of(skeleton_or_asf_path)
    src, data = _read_bytes(path)
    return read_amc_text(_decode(data), sk, src, rate=r)


def read_asf_amc(asf: str | Path, amc: str | Path, rate: float = CMU_RATE) -> Motion:
    """``read_amc(amc, read_asf(asf), rate)``."""
    return read_amc(amc, read_asf(asf), rate=rate)


def read_amc_text(text: str, skeleton: Skeleton, source: str = "<amc>", rate: float = CMU_RATE) -> Motion:
    """Parse the text of an AMC file against ``skeleton`` (from :func:`read_asf`)."""
    r = _check_rate(rate)
    sk = _asf_of(skeleton)
    src = str(source)
    return _guarded(lambda state: _parse_amc(text, src, sk, r, state), src)


def _parse_amc(text: str, src: str, sk: Skeleton, rate: float, state: dict) -> Motion:
    asf = sk.meta["asf"]
    root_order = tuple(asf["root"]["order"])
    ndof = {_ROOT_NAME: len(root_order)}
    for n, b in asf["bones"].items():
        ndof[n] = len(b["dofs"])
    required = frozenset(n for n, k in ndof.items() if k > 0)
    values: dict[str, list] = {n: [] for n in required}
    lines = _lines(text)

    header: dict[str, int] = {}
    frame_numbers: list[int] = []
    frame_lines: list[int] = []
    seen: set[str] = set()
    isfinite = math.isfinite

    end = len(text)
    while end and text[end - 1] in " \t\f\v":
        end -= 1
    final_newline = end == 0 or text[end - 1] in "\r\n"
    last_line = len(lines)  # a line cut short can only be the last one, when there is no final newline

    def cut(ln: int | None) -> str:
        return (
            ""
            if final_newline or ln != last_line
            else " (the file ends on this line without a final newline: cut short?)"
        )

    def close_frame(at_end: bool = False) -> None:
        if not required <= seen:
            missing = sorted(required - seen)
            raise MocapFormatError(
                src, frame_lines[-1],
                f"frame {frame_numbers[-1]} has no line for bone(s) {', '.join(missing[:5])}"
                + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
                + (" (the file ends without a final newline: cut short?)" if at_end and not final_newline else ""),
            )

    for ln, line in enumerate(lines, 1):
        if "#" in line:
            line = line.split("#", 1)[0]
        toks = line.split()
        if not toks:
            continue
        state["line"] = ln
        if not line.isascii() or "\x00" in line:
            _check_text(src, ln, line)
        t0 = toks[0]
        if t0[0] == ":":
            kw = t0.upper()
            if frame_numbers:
                raise MocapFormatError(src, ln, f"header keyword {_short(t0)} after the first frame")
            if kw not in (":FULLY-SPECIFIED", ":DEGREES", ":RADIANS"):
                raise MocapFormatError(
                    src, ln, f"unknown keyword {_short(t0)} (expected :FULLY-SPECIFIED, :DEGREES or :RADIANS)"
                )
            if len(toks) > 1:
                raise MocapFormatError(src, ln, f"unexpected {_short(' '.join(toks[1:]))} after {t0}")
            if kw in header:
                raise MocapFormatError(src, ln, f"{t0} given twice (first on line {header[kw]})")
            header[kw] = ln
            continue
        if len(toks) == 1 and t0.isascii() and t0.isdigit() and t0 not in ndof:
            if len(t0) > 18:
                raise MocapFormatError(src, ln, f"frame number {_short(t0)} is too large")
            num = int(t0)
            if frame_numbers:
                close_frame()
                if num != frame_numbers[-1] + 1:
                    raise MocapFormatError(
                        src, ln,
                        f"frame number {num} does not follow frame {frame_numbers[-1]} (line {frame_lines[-1]})",
                    )
            frame_numbers.append(num)
            frame_lines.append(ln)
            seen = set()
            continue
        k = ndof.get(t0)
        if k is None:
            if len(toks) == 1:
                raise MocapFormatError(
                    src, ln, f"{_short(t0)} is neither a frame number nor a bone of the skeleton{cut(ln)}"
                )
            raise MocapFormatError(src, ln, f"unknown bone {_short(t0)} (not in the skeleton){cut(ln)}")
        if not frame_numbers:
            raise MocapFormatError(src, ln, f"bone line {_short(t0)} before the first frame number")
        if t0 in seen:
            raise MocapFormatError(src, ln, f"bone {_short(t0)} appears twice in frame {frame_numbers[-1]}")
        if len(toks) - 1 != k:
            raise MocapFormatError(
                src, ln, f"bone {_short(t0)} has {k} dof(s) but the line holds {len(toks) - 1} value(s){cut(ln)}"
            )
        seen.add(t0)
        if k == 0:
            continue
        vals = None
        if line.isascii() and "_" not in line:
            try:
                vals = [float(t) for t in toks[1:]]
            except ValueError:
                vals = None
            else:
                if not all(map(isfinite, vals)):
                    vals = None
        if vals is None:  # slow path: find and report the offending token
            try:
                vals = [_number(src, ln, t, f"bone {t0}") for t in toks[1:]]
            except MocapFormatError as exc:
                if not cut(ln):
                    raise
                raise MocapFormatError(src, ln, exc.problem + cut(ln)) from None
        values[t0].append(vals)
    state["line"] = None
    if not frame_numbers:
        raise MocapFormatError(src, None, "no frames (expected a frame number line such as '1')")
    close_frame(at_end=True)

    N = len(frame_numbers)
    J = sk.n_joints
    n_values = N * sum(ndof[n] for n in required)
    if N * J > max(MAX_JOINT_FRAMES, n_values):
        raise MocapFormatError(
            src, None, f"{N} frames × {J} bones is more than this reader builds (at most {MAX_JOINT_FRAMES:,} "
            "joint-frames unless there is a value per joint-frame)"
        )
    notes = []
    if not final_newline:
        found = _cut_note(lines, last_line, ndof)
        if found is not None and found[0] == "end":
            raise MocapFormatError(src, last_line, found[1])
        if found is not None:
            note = found[1]
            notes.append(note)
            warnings.warn(f"{src}: {note}", MocapWarning, stacklevel=4)
    if ":DEGREES" in header and ":RADIANS" in header:
        raise MocapFormatError(src, header[":RADIANS"], ":RADIANS contradicts :DEGREES")
    if ":DEGREES" in header:
        deg = True
    elif ":RADIANS" in header:
        deg = False
    else:
        deg = asf["units"]["angle"] == "deg"

    arrays = {n: np.asarray(v, dtype=np.float64).reshape(N, ndof[n]) for n, v in values.items()}
    for n, a in arrays.items():  # magnitudes in bulk (the per-line fast path checked finiteness only)
        big = np.flatnonzero(~(np.abs(a) <= MAX_ABS).all(axis=1))
        if big.size:
            _report_value(src, lines, frame_lines[int(big[0])], n)
    rotations = np.zeros((N, J, 4))
    rotations[:, :, 0] = 1.0  # allocated after the size check above
    translations = np.broadcast_to(sk.offsets, (N, J, 3)).copy()

    # root
    if _ROOT_NAME in arrays:
        rv = arrays[_ROOT_NAME]
        t_idx = {a: i for i, a in enumerate(root_order) if a[0] == "T"}
        for c, axis in enumerate(("TX", "TY", "TZ")):
            if axis in t_idx:
                translations[:, 0, c] = sk.offsets[0, c] + rv[:, t_idx[axis]]
        r_cols = [i for i, a in enumerate(root_order) if a[0] == "R"]
        if r_cols:
            seq = "".join(root_order[i][1] for i in r_cols)
            rotations[:, 0] = _conjugated(asf["axis_quat"][_ROOT_NAME], _euler(seq, rv[:, r_cols], deg))
    for n, b in asf["bones"].items():
        if not b["dofs"]:
            continue
        seq = "".join(d[1] for d in b["dofs"])
        rotations[:, sk.index(n)] = _conjugated(asf["axis_quat"][n], _euler(seq, arrays[n], deg))
    if not np.all(np.isfinite(translations)):
        raise MocapFormatError(src, None, "root translation overflows")

    frame_time = 1.0 / rate
    meta = {
        "format": "amc",
        "frame_time": frame_time,
        "first_frame": frame_numbers[0],
        "angle_unit": "deg" if deg else "rad",
        "fully_specified": ":FULLY-SPECIFIED" in header,
        "length_unit_cm": sk.meta.get("length_unit_cm"),
        "amc_values": arrays,
    }
    if notes:
        meta["warnings"] = notes
    try:
        return Motion(sk, np.arange(N) / rate, rotations, translations, None, src, meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


def _report_value(src: str, lines: list[str], frame_line: int, bone: str) -> None:
    """Raise the strict-number error of the first bad value of ``bone`` in the frame at ``frame_line``."""
    for ln in range(frame_line + 1, len(lines) + 1):
        toks = lines[ln - 1].split("#", 1)[0].split()
        if toks and toks[0] == bone:
            for t in toks[1:]:
                _number(src, ln, t, f"bone {bone}")
    raise MocapFormatError(src, frame_line, f"bone {bone}: a value is out of range (|value| > {MAX_ABS:g})")


def _cut_note(lines: list[str], last: int, ndof: dict[str, int]) -> tuple[str, str] | None:
    """``(kind, note)`` when the file's last line (no final newline) is a bone line whose last value looks
    cut short against the same value in the up to 100 earlier lines of that bone
    (:func:`mocapkit.io.text.numbers.cut_kind`: ``"end"`` for ``-4.``, ``"shorter"``/``"short"`` for a value
    shorter than those lines)."""
    toks = lines[last - 1].split("#", 1)[0].split()
    if len(toks) < 2 or ndof.get(toks[0]) != len(toks) - 1:
        return None
    column = []
    span = 100 * (len(ndof) + 1)
    for ln in range(last - 1, max(last - 1 - span, 0), -1):
        t = lines[ln - 1].split("#", 1)[0].split()
        if t and t[0] == toks[0] and len(t) == len(toks):
            column.append(t[-1])
            if len(column) == 100:
                break
    kind = cut_kind(toks[-1], column)
    if kind is None:
        return None
    if kind == "end":
        return kind, (f"bone {toks[0]}: the last value {_short(toks[-1])} ends like a number cut short and the file "
                      "ends there without a final newline: it was cut short (delete this line to read the rest)")
    how = "every value" if kind == "shorter" else "others"
    return kind, (f"line {last}, bone {toks[0]}: the file has no final newline and its last value {_short(toks[-1])} "
                  f"is shorter than {how} of its column (the {len(column)} lines of that bone before it): "
                  "it may be cut short")


def _conjugated(c_quat, m: Rotation) -> np.ndarray:
    """Scalar-first quaternions of ``C · M · C⁻¹``."""
    c = to_scipy(np.asarray(c_quat, dtype=np.float64))
    q = from_scipy(c * m * c.inv())
    return q.reshape(-1, 4)


# --------------------------------------------------------------------------------------------------
# CLI hook
# --------------------------------------------------------------------------------------------------


def companion_asf(amc: str | Path) -> Path | None:
    """The CMU companion skeleton an AMC take is read with when none is given: ``<stem>.asf`` or
    ``<subject>.asf`` beside it (``86_01.amc`` -> ``86.asf``), when it exists, else None."""
    amc = Path(amc)
    stem = amc.stem
    cands = [stem, stem.split("_", 1)[0]]
    for c in dict.fromkeys(cands):
        for suffix in (".asf", ".ASF"):
            p = amc.with_name(c + suffix)
            if p.is_file():
                return p
    return None


def load_amc_for_cli(path: str | Path, asf: str | Path | None = None, rate: float | None = None) -> Motion:
    """Loader used by the command line.

    ``asf`` defaults to the CMU companion next to the AMC file: ``<stem>.asf`` or
    ``<subject>.asf`` (``86_01.amc`` → ``86.asf``); another subject's skeleton is never picked
    silently. ``rate`` defaults to 120 Hz (CMU).
    """
    p = Path(path)
    if asf is None:
        found = companion_asf(p)
        if found is None:
            subject = p.stem.split("_", 1)[0]
            raise InvalidParameterError(
                f"{p}: no ASF skeleton given and neither {p.stem}.asf nor {subject}.asf is next to it; "
                "pass the skeleton file (.asf) explicitly"
            )
        asf = found
    return read_amc(p, asf, rate=CMU_RATE if rate is None else rate)


# --------------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------------


def _fmt(v: float) -> str:
    if v == 0.0:
        return "0"
    return repr(float(v))


#: Default largest projection residual (degrees) that :func:`write_amc` accepts: a BVH written with
#: d decimals carries up to ~1.5·10^-d degrees of rounding in a composed rotation (1e-6° at the
#: usual 6, 0.015° at 2), while a real loss — a rotation about an axis the bone has no dof for, a
#: skeleton that is not the ASF's — is degrees. 0.1° moves the end of a 50 cm limb by 0.9 mm, below
#: the accuracy of any motion capture.
DEFAULT_MAX_RESIDUAL_DEG = 0.1

_AXIS_COMPONENT = {"x": 1, "y": 2, "z": 3}


def project_onto_dofs(q: np.ndarray, seq: str) -> tuple[np.ndarray, np.ndarray]:
    """Closest rotation that dofs ``seq`` can express, and how far ``q`` is from it.

    Parameters
    ----------
    q
        ``(N, 4)`` scalar-first quaternions (normalised here).
    seq
        The dof axes in the bone's order, lower case (``""``, ``"x"``, ``"xz"``, ``"xyz"``…): the
        rotation of angles ``(a, b, …)`` is ``… · R_seq[1](b) · R_seq[0](a)`` (fixed axes, the AMC
        convention of :func:`read_amc`).

    Returns
    -------
    angles, residual
        ``(N, len(seq))`` degrees in ``[-180, 180]`` and ``(N,)`` degrees: the angle between ``q`` and
        the rotation of ``angles``, the smallest such angle over all angle values (exact, closed
        form). One dof about axis ``e``: the quaternion nearest ``q`` among ``(cos θ/2, sin θ/2 e)``
        maximises ``|w cos θ/2 + q_e sin θ/2|``. Two dofs: ``⟨q, q_j(b) ⊗ q_i(a)⟩ = uᵀ A v`` with
        ``u = (cos a/2, sin a/2)``, ``v = (cos b/2, sin b/2)`` and a 2×2 matrix ``A`` from ``q``, so
        the optimum is ``A``'s leading singular pair and the residual ``2·atan2(σ₂, σ₁)``. Three
        dofs: the Euler decomposition (residual at rounding level). No dof: the rotation's angle.
    """
    q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    N, k = q.shape[0], len(seq)
    if k == 0:
        return np.zeros((N, 0)), np.degrees(2 * np.arctan2(np.linalg.norm(q[:, 1:], axis=1), np.abs(q[:, 0])))
    if k == 3:
        r = to_scipy(q)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # gimbal lock: scipy still returns a valid decomposition
            ang = r.as_euler(seq, degrees=True)
        return ang, np.degrees((_euler(seq, ang, True).inv() * r).magnitude())
    if k == 1:
        i = _AXIS_COMPONENT[seq]
        sign = np.where(q[:, 0] < 0, -1.0, 1.0)
        w, c = sign * q[:, 0], sign * q[:, i]
        other = np.linalg.norm(np.delete(q[:, 1:], i - 1, axis=1), axis=1)
        ang = np.degrees(2 * np.arctan2(c, w))
        return ang[:, None], np.degrees(2 * np.arctan2(other, np.hypot(w, c)))
    if k != 2:
        raise InvalidParameterError(f"dofs {seq!r}: expected up to 3 of x, y, z")
    basis = {}
    for ax in seq:
        e = np.zeros(4)
        e[_AXIS_COMPONENT[ax]] = 1.0
        basis[ax] = (np.array([1.0, 0, 0, 0]), e)
    A = np.empty((N, 2, 2))
    for a in range(2):
        for b in range(2):
            A[:, a, b] = q @ multiply(basis[seq[1]][b], basis[seq[0]][a])
    U, S, Vt = np.linalg.svd(A)
    u, v = U[:, :, 0], Vt[:, 0, :]
    ang = np.degrees(2 * np.stack([np.arctan2(u[:, 1], u[:, 0]), np.arctan2(v[:, 1], v[:, 0])], axis=1))
    ang = (ang + 180.0) % 360.0 - 180.0  # a 360° turn of one angle flips the quaternion's sign only
    return ang, np.degrees(2 * np.arctan2(S[:, 1], S[:, 0]))


def _continuous(ang: np.ndarray) -> np.ndarray:
    """Dof angles (degrees, ``(N, k)``) made continuous over frames without changing any rotation.

    Three dofs: of the two Euler solutions ``(a, b, c)`` and ``(a + 180, 180 − b, c + 180)`` each frame
    takes the one nearer (modulo 360°) to the previous frame's; then every column is unwrapped, so
    a root that turns keeps counting past ±180° as CMU files do.
    """
    ang = np.array(ang, dtype=np.float64)
    if ang.shape[1] == 3 and ang.shape[0] > 1:
        alt = ang + np.array([180.0, 0.0, 180.0])
        alt[:, 1] = 180.0 - ang[:, 1]
        alt = (alt + 180.0) % 360.0 - 180.0

        def dist(x, y):
            return float(np.abs((x - y + 180.0) % 360.0 - 180.0).sum())

        prev = ang[0]
        for n in range(1, ang.shape[0]):
            if dist(alt[n], prev) < dist(ang[n], prev):
                ang[n] = alt[n]
            prev = ang[n]
    if ang.shape[0] > 1 and ang.shape[1]:
        ang = np.degrees(np.unwrap(np.radians(ang), axis=0))
    return ang


def write_amc(path: str | Path, motion: Motion, asf_skeleton: Skeleton,
              max_residual_deg: float = DEFAULT_MAX_RESIDUAL_DEG) -> dict:
    """Write ``motion`` as an AMC file for ``asf_skeleton`` (from :func:`read_asf`), in degrees.

    Each bone's rotation in its ``axis`` frame, ``M = C⁻¹ · L · C``, is projected onto the bone's dofs
    (:func:`project_onto_dofs`: the closest rotation the dofs can express); bones without dofs are
    checked against the identity. The angles are made continuous over frames (:func:`_continuous`),
    so values read from an AMC come back as they were. The largest residual is returned; if it exceeds
    ``max_residual_deg`` (default :data:`DEFAULT_MAX_RESIDUAL_DEG`) nothing is written and
    :class:`~mocapkit.errors.InvalidSignalError` names the joint, frame and degrees. The root
    translation written is the motion's root translation minus the ASF root position. Frames are
    numbered from 1.

    Returns
    -------
    dict
        ``max_residual_deg``, ``joint``, ``frame`` (1-based) of the largest residual, and
        ``per_joint`` (joint → its largest residual in degrees).
    """
    try:
        limit = float(max_residual_deg)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"max_residual_deg must be a number of degrees, got {max_residual_deg!r}") from None
    if not limit >= 0:
        raise InvalidParameterError(f"max_residual_deg must be >= 0, got {max_residual_deg!r}")
    sk = _asf_of(asf_skeleton)
    asf = sk.meta["asf"]
    msk = motion.skeleton
    names = set(msk.names)
    missing = [n for n in (_ROOT_NAME, *asf["bones"]) if n not in names]
    if missing:
        raise InvalidParameterError(f"the motion has no joint(s) {missing[:5]} of the ASF skeleton")
    N = motion.n_frames
    cols: dict[str, np.ndarray] = {}
    residuals: dict[str, np.ndarray] = {}
    dof_text: dict[str, str] = {}

    def dof_angles(name: str, seq: str, q: np.ndarray) -> np.ndarray:
        c = to_scipy(np.asarray(asf["axis_quat"][name], dtype=np.float64))
        m = from_scipy(c.inv() * to_scipy(q) * c).reshape(N, 4)
        ang, res = project_onto_dofs(m, seq)
        residuals[name] = res
        dof_text[name] = " ".join("r" + a for a in seq) or "none"
        return _continuous(ang)

    root_order = tuple(asf["root"]["order"])
    rq = motion.rotations[:, msk.index(_ROOT_NAME)]
    rseq = "".join(a[1].lower() for a in root_order if a[0] == "R")
    rang = dof_angles(_ROOT_NAME, rseq, rq)
    trans = motion.translations[:, msk.index(_ROOT_NAME)] - np.asarray(asf["root"]["position"])
    root_cols = []
    ri = 0
    for a in root_order:
        if a[0] == "T":
            root_cols.append(trans[:, "XYZ".index(a[1])])
        else:
            root_cols.append(rang[:, ri])
            ri += 1
    cols[_ROOT_NAME] = np.stack(root_cols, axis=1) if root_cols else np.zeros((N, 0))
    for n, b in asf["bones"].items():
        seq = "".join(d[1] for d in b["dofs"])
        ang = dof_angles(n, seq, motion.rotations[:, msk.index(n)])
        if b["dofs"]:
            cols[n] = ang
    per_joint = {n: float(r.max()) if r.size else 0.0 for n, r in residuals.items()}
    worst = max(per_joint, key=per_joint.__getitem__)
    frame = int(np.argmax(residuals[worst])) if N else 0
    report = {"max_residual_deg": per_joint[worst], "joint": worst, "frame": frame + 1, "per_joint": per_joint,
              "limit_deg": limit}
    if per_joint[worst] > limit:
        over = {n: int((r > limit).sum()) for n, r in residuals.items() if (r > limit).any()}
        others = ", ".join(
            f"{n} ({k} frame{'s' if k > 1 else ''})" for n, k in sorted(over.items(), key=lambda x: -x[1])
        )
        raise InvalidSignalError(
            f"joint {worst!r} frame {frame + 1}: the rotation is {per_joint[worst]:.3g} deg away from the closest one "
            f"its dofs ({dof_text[worst]}) can express (allowed {limit:g} deg); over the limit: {others}"
        )
    # bones in ASF hierarchy order (root first), as CMU files list them
    order = [n for n in sk.names if n in cols]
    out = ["# written by mocapkit", ":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(N):
        out.append(str(f + 1))
        for n in order:
            out.append(n + " " + " ".join(_fmt(v) for v in cols[n][f]))
    atomic_write_text(path, "\n".join(out) + "\n")
    return report
