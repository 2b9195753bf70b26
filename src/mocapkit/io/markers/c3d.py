"""Read C3D marker files (via ezc3d) into :class:`mocapkit.markers.Markers`.

ezc3d is a C++ library: on a damaged file it can crash the interpreter (segmentation fault), loop
forever or try to allocate terabytes, instead of raising. So the file is first walked by a small,
strict, pure-Python parser of the C3D structure (512-byte header, parameter section, size of the data
section) that checks everything ezc3d relies on; only a file that passes goes to ezc3d. Every
problem, found by the pre-check or raised by ezc3d, becomes a
:class:`mocapkit.errors.MocapFormatError` ``(path, None, problem)``.

What is read
------------
* ``positions``: ezc3d's points (``POINT:SCALE`` applied), ``(N, M, 3)``. Gaps: a point whose
  residual is negative (the C3D "invalid" flag; ezc3d already returns NaN for it) is ``NaN``; so is a
  point of a float C3D holding a NaN coordinate without that flag (some exporters write NaN for a
  missing marker), counted in ``meta["warnings"]``. An infinite coordinate, or one (or an analog
  value) beyond ``MAX_ABS`` (1e12) — what a damaged scale or float word gives — is an error naming
  the 1-based frame, the marker (or analog channel) and the axis. A point at exactly ``(0, 0, 0)``
  with a valid residual is kept as is.
* ``labels``: ``POINT:LABELS`` then ``LABELS2``, ``LABELS3``..., made unique by
  :func:`mocapkit.markers.make_unique_labels` (fixes recorded in ``meta["label_fixes"]``).
* ``rate``: ``POINT:RATE`` (the header rate when ``POINT:RATE`` is 0, as ezc3d does).
* ``units``: ``POINT:UNITS`` (``"mm"`` when absent or empty, recorded as
  ``meta["units_assumed"] = True``).
* ``times``: ``(first_frame - 1 + arange(N)) / rate`` where ``first_frame`` is the 1-based number of the
  first stored frame: ``TRIAL:ACTUAL_START_FIELD`` when present (``low + 65536 * high``), else the
  header's first frame (a header value 0 is read as 1). A trimmed recording thus keeps its original
  time base; a file that starts at frame 1 starts at t = 0.
* ``analog``: ``None`` without analog channels, else ``{"labels", "rate", "values" (A, K) with
  ezc3d's scaling ``(raw - OFFSET) * SCALE * GEN_SCALE`` applied, "units", "t0"}``
  (``t0 = times[0]``: analog sample ``a`` is at ``t0 + a / rate``).
* ``meta``: ``format``, ``processor``, ``first_frame``, ``header`` (sizes, rates, frames as stored),
  ``point_scale``, ``groups``, ``label_fixes``, ``analog_label_fixes``, ``manufacturer`` (when present).

Refused (``MocapFormatError``): not a C3D file, truncated file or section, a damaged parameter section
(bad record links, impossible types or sizes, negative lengths), header and parameters disagreeing on
sizes (points, analog channels, samples per frame, frames, data start, storage format), MIPS
(big-endian) files (ezc3d does not read them), no frames, a zero or non-finite rate.

Sizes: every count of the header and parameters is checked against the file's size by the
pre-check before ezc3d allocates anything (a data section shorter than declared is read as the
complete frames it holds). A pipe or device is read in bounded chunks (its first 512 bytes must
look like a C3D header, so ``/dev/zero`` fails at once) and handed to ezc3d as a temporary file.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.text.input import is_regular, read_input
from mocapkit.io.text.numbers import MAX_ABS
from mocapkit.markers import Markers, make_unique_labels

__all__ = ["read_c3d", "write_c3d", "check_c3d_structure", "C3DLayout"]

_BLOCK = 512
_PROCESSORS = {84: "intel", 85: "dec", 86: "mips"}
#: Largest number of frames accepted (guards against absurd header values).
MAX_FRAMES = 50_000_000


# --------------------------------------------------------------------------------------------------
# structural pre-check
# --------------------------------------------------------------------------------------------------


class _Bad(Exception):
    """Internal: a structural problem (turned into MocapFormatError by the caller)."""


@dataclass
class _Param:
    name: str
    type: int            # -1 char, 1 byte, 2 int16, 4 float32
    dims: tuple[int, ...]
    raw: bytes
    offset: int          # byte offset of the record in the file

    @property
    def count(self) -> int:
        n = 1
        for d in self.dims:
            n *= d
        return n


@dataclass
class _Group:
    gid: int
    name: str | None = None         # None: never defined by a group record
    params: dict[str, _Param] = field(default_factory=dict)


@dataclass
class C3DLayout:
    """What the structural pre-check found (all sizes as ezc3d will use them)."""

    processor: str
    param_block: int
    param_blocks: int
    data_start: int                 # 1-based block
    n_points: int
    n_analog: int                   # analog channels
    analog_per_frame: int           # analog samples per channel per frame
    n_frames: int
    first_frame: int                # 1-based (header)
    is_float: bool
    point_rate: float
    analog_rate: float
    header: dict
    groups: dict[str, dict[str, _Param]]
    data_bytes: int
    warnings: list[str] = field(default_factory=list)

    def values(self, group: str, name: str) -> list | None:
        """Decoded values of a parameter (numbers or strings), ``None`` when absent."""
        p = self.groups.get(group, {}).get(name)
        return None if p is None else _decode(p, self.processor)


def _i8(b: bytes | bytearray, i: int) -> int:
    v = b[i]
    return v - 256 if v > 127 else v


def _u16(b: bytes | bytearray, i: int) -> int:
    return b[i] | (b[i + 1] << 8)


def _dec_float(b4: bytes | bytearray) -> float:
    """A DEC (VAX F) float stored in 4 bytes, as ezc3d converts it."""
    hi = b4[1]
    tp = bytes([b4[2], b4[3], b4[0], hi - 1 if hi != 0 else hi])
    return struct.unpack("<f", tp)[0]


def _float(b: bytes | bytearray, i: int, processor: str) -> float:
    chunk = b[i:i + 4]
    if processor == "dec":
        return _dec_float(chunk)
    return struct.unpack("<f", chunk)[0]


def _decode(p: _Param, processor: str) -> list:
    """Values of a parameter: numbers, or for text the strings (first dimension = string length)."""
    if p.type == -1:
        width = p.dims[0]
        n_str = 1
        for d in p.dims[1:]:
            n_str *= d
        if len(p.dims) == 1 and width == 0:
            return []
        return [p.raw[k * width:(k + 1) * width].decode("latin-1").rstrip(" ") for k in range(n_str)]
    n = p.count
    if p.type == 1:
        return [_i8(p.raw, k) for k in range(n)]
    if p.type == 2:
        return list(struct.unpack(f"<{n}h", p.raw))
    return [_float(p.raw, 4 * k, processor) for k in range(n)]


def _check_name(raw: bytes | bytearray) -> str:
    """The name ezc3d will see: the bytes up to the first NUL (any other byte is accepted, as ezc3d
    does: QTM writes names with spaces such as ``Uncropped Measurement Length``)."""
    return raw.split(b"\0", 1)[0].decode("latin-1")


def _walk_parameters(data: bytes | bytearray, start: int, end: int, processor: str) -> dict[int, _Group]:
    groups: dict[int, _Group] = {}
    pos = start + 4
    while True:
        if pos + 2 > end:
            raise _Bad(f"the parameter section (bytes {start}-{end}) ends at byte {pos} without a "
                       "terminating record")
        nlen = _i8(data, pos)
        if nlen == 0:
            break
        gid = _i8(data, pos + 1)
        if gid == 0:
            raise _Bad(f"parameter record at byte {pos} has group id 0")
        q = pos + 2
        name_end = q + abs(nlen)
        if name_end + 2 > end:
            raise _Bad(f"parameter record at byte {pos} runs past the parameter section")
        kind = "group" if gid < 0 else "parameter"
        name = _check_name(data[q:name_end])
        off_pos = name_end
        offset = _u16(data, off_pos)
        q = off_pos + 2
        if gid < 0:
            if q + 1 > end:
                raise _Bad(f"group {name!r} at byte {pos} runs past the parameter section")
            dlen = _i8(data, q)
            q += 1
            if dlen < 0:
                raise _Bad(f"group {name!r} at byte {pos} has a negative description length")
            q += dlen
            if q > end:
                raise _Bad(f"group {name!r} at byte {pos} runs past the parameter section")
            g = groups.setdefault(-gid, _Group(-gid))
            if g.name is not None:
                raise _Bad(f"group id {-gid} is defined twice ({g.name!r} and {name!r})")
            g.name = name
        else:
            if q + 2 > end:
                raise _Bad(f"parameter {name!r} at byte {pos} runs past the parameter section")
            ptype = _i8(data, q)
            nd = _i8(data, q + 1)
            q += 2
            if ptype not in (-1, 1, 2, 4):
                raise _Bad(f"parameter {name!r} at byte {pos} has an unknown type {ptype} "
                           "(expected -1, 1, 2 or 4)")
            if not 0 <= nd <= 7:
                raise _Bad(f"parameter {name!r} at byte {pos} has {nd} dimensions (expected 0..7)")
            if ptype == -1 and nd == 0:
                raise _Bad(f"character parameter {name!r} at byte {pos} has no dimensions")
            if q + nd > end:
                raise _Bad(f"parameter {name!r} at byte {pos} runs past the parameter section")
            dims = tuple(data[q:q + nd])
            q += nd
            count = 1
            for d in dims:
                count *= d
            size = count * abs(ptype)
            if q + size + 1 > end:
                raise _Bad(f"parameter {name!r} at byte {pos} ({size} bytes of values) runs past "
                           "the parameter section")
            raw = bytes(data[q:q + size])
            q += size
            dlen = _i8(data, q)
            q += 1
            if dlen < 0:
                raise _Bad(f"parameter {name!r} at byte {pos} has a negative description length")
            q += dlen
            if q > end:
                raise _Bad(f"parameter {name!r} at byte {pos} runs past the parameter section")
            g = groups.setdefault(gid, _Group(gid))
            if name in g.params:
                raise _Bad(f"parameter {name!r} is defined twice in group id {gid}")
            g.params[name] = _Param(name, ptype, dims, raw, pos)
        if offset == 0:
            break
        nxt = off_pos + offset
        if nxt != q:
            raise _Bad(f"{kind} {name!r} at byte {pos}: its link to the next record ({nxt}) does not "
                       f"point right after it ({q})")
        pos = nxt
    return groups


def _first(groups: dict[str, dict[str, _Param]], group: str, name: str, processor: str,
           kinds: tuple[int, ...], required: bool = True):
    """Decoded values of a parameter that must have one of ``kinds`` and at least one value."""
    p = groups.get(group, {}).get(name)
    if p is None:
        if required:
            raise _Bad(f"parameter {group}:{name} is missing")
        return None
    if p.type not in kinds:
        want = {-1: "text", 1: "byte", 2: "integer", 4: "float"}
        raise _Bad(f"parameter {group}:{name} has type {want.get(p.type, p.type)}, expected "
                   + " or ".join(want[k] for k in kinds))
    if p.count == 0:
        raise _Bad(f"parameter {group}:{name} is empty")
    return _decode(p, processor)


def _series_len(groups: dict[str, dict[str, _Param]], group: str, name: str, processor: str,
                kinds: tuple[int, ...]) -> int:
    """Total number of values of NAME, NAME2, NAME3... (as ezc3d concatenates them)."""
    total = 0
    k = 1
    while True:
        key = name if k == 1 else f"{name}{k}"
        p = groups.get(group, {}).get(key)
        if p is None:
            return total
        if p.type not in kinds:
            raise _Bad(f"parameter {group}:{key} has an unexpected type")
        total += p.count if p.type != -1 else (p.count // p.dims[0] if p.dims and p.dims[0] else 0)
        k += 1


def check_c3d_structure(data: bytes | bytearray) -> C3DLayout:
    """Check the structure of a C3D file held in ``data``; raise ``ValueError`` naming the problem.

    This is the pre-check :func:`read_c3d` runs before handing a file to ezc3d.
    """
    try:
        return _check(data)
    except _Bad as exc:
        raise ValueError(str(exc)) from None


def _check(data: bytes | bytearray) -> C3DLayout:
    size = len(data)
    if size < _BLOCK:
        raise _Bad(f"too short for a C3D file ({size} bytes; the header alone is 512)")
    pblock = data[0]
    if pblock == 0 or data[1] != 0x50:
        raise _Bad("not a C3D file (the first two bytes must be the parameter block number and 0x50)")
    if pblock < 2:
        raise _Bad(f"the parameter section cannot start in block {pblock} (the header is block 1)")
    pstart = _BLOCK * (pblock - 1)
    if pstart + 4 > size:
        raise _Bad(f"the parameter section (block {pblock}) lies beyond the end of the file")
    nblocks = data[pstart + 2]
    proc_id = data[pstart + 3]
    processor = _PROCESSORS.get(proc_id)
    if processor is None:
        raise _Bad(f"unknown processor type {proc_id} (expected 84 Intel, 85 DEC or 86 MIPS)")
    if processor == "mips":
        raise _Bad("MIPS (big-endian) C3D files are not supported by ezc3d")
    if nblocks == 0:
        raise _Bad("the parameter section has 0 blocks")
    pend = pstart + _BLOCK * nblocks
    if pend > size:
        raise _Bad(f"the parameter section ({nblocks} blocks from block {pblock}) runs past the end "
                   f"of the file ({size} bytes)")

    hdr: dict[str, Any] = {
        "points": _u16(data, 2),
        "analog_measurements": _u16(data, 4),
        "first_frame": _u16(data, 6),
        "last_frame": _u16(data, 8),
        "scale": _float(data, 12, processor),
        "data_start": _u16(data, 16),
        "analog_per_frame": _u16(data, 18),
        "rate": _float(data, 20, processor),
    }

    by_id = _walk_parameters(data, pstart, pend, processor)
    groups: dict[str, dict[str, _Param]] = {}
    for gid in sorted(by_id):
        g = by_id[gid]
        name = g.name if g.name is not None else ""
        if name in groups:
            if name == "":
                groups[name].update(g.params)
                continue
            raise _Bad(f"group {name!r} is defined twice")
        groups[name] = dict(g.params)
    if "POINT" not in groups:
        raise _Bad("no POINT group")
    has_rot = "ROTATION" in groups

    # --- what ezc3d will use (parameters win over the header) ---------------------------------
    used = _first(groups, "POINT", "USED", processor, (2,))[0]
    if used < 0:
        raise _Bad(f"POINT:USED is negative ({used})")
    warnings: list[str] = []
    if used != hdr["points"]:  # ezc3d follows POINT:USED
        warnings.append(f"the header says {hdr['points']} points but POINT:USED is {used}; "
                        f"{used} points read")
    prate = _first(groups, "POINT", "RATE", processor, (4,))[0]
    if not math.isfinite(prate) or prate < 0:
        raise _Bad(f"POINT:RATE is {prate!r}")
    hrate = hdr["rate"]
    rate = prate
    if prate == 0.0 and used != 0:
        rate = hrate
    if not (math.isfinite(rate) and rate > 0):
        raise _Bad(f"no valid frame rate (POINT:RATE {prate!r}, header {hrate!r})")

    if used:
        nscale = _series_len(groups, "POINT", "SCALE", processor, (4,))
        if nscale == 0:
            raise _Bad("POINT:SCALE is missing or empty")
        scales = _first(groups, "POINT", "SCALE", processor, (4,))
        k = 2
        while f"SCALE{k}" in groups["POINT"]:
            scales += _decode(groups["POINT"][f"SCALE{k}"], processor)
            k += 1
        pscales = [scales[i] if i < len(scales) else scales[0] for i in range(used)]
        if any(not math.isfinite(s) for s in pscales):
            raise _Bad("POINT:SCALE is not finite")
        signs = {s < 0 for s in pscales}
        if len(signs) > 1:
            raise _Bad("POINT:SCALE mixes float (negative) and integer (positive) storage")
        is_float = signs.pop()
        if not math.isfinite(hdr["scale"]) or (hdr["scale"] < 0) != is_float:
            raise _Bad(f"the header scale factor ({hdr['scale']!r}) and POINT:SCALE ({pscales[0]!r}) "
                       "disagree on the storage format (float or integer)")
    else:
        if not math.isfinite(hdr["scale"]):
            raise _Bad("the header scale factor is not finite")
        is_float = hdr["scale"] < 0

    # analog: ezc3d recomputes samples per frame from ANALOG:RATE / POINT:RATE
    analog_group = groups.get("ANALOG", {})
    a_used = 0
    arate_param = 0.0
    if "USED" in analog_group:
        a_used = _first(groups, "ANALOG", "USED", processor, (2,))[0]
        if a_used < 0:
            raise _Bad(f"ANALOG:USED is negative ({a_used})")
    if "RATE" in analog_group:
        arate_param = _first(groups, "ANALOG", "RATE", processor, (4,))[0]
        if not math.isfinite(arate_param) or arate_param < 0:
            raise _Bad(f"ANALOG:RATE is {arate_param!r}")
    if "GEN_SCALE" in analog_group:
        gs = _first(groups, "ANALOG", "GEN_SCALE", processor, (4,))[0]
        if not math.isfinite(gs):
            raise _Bad("ANALOG:GEN_SCALE is not finite")
    ratio = hdr["analog_per_frame"]
    if int(prate) != 0:
        r = arate_param / prate
        if not math.isfinite(r) or r > 65535:
            raise _Bad(f"ANALOG:RATE / POINT:RATE = {r!r} is not a valid number of samples per frame")
        r = int(r)
        if r != ratio and not (ratio == 1 and "SHADOW" in groups):
            raise _Bad(f"the header says {ratio} analog samples per frame but ANALOG:RATE / "
                       f"POINT:RATE = {arate_param:g} / {prate:g} gives {r}")
    h_analog = hdr["analog_measurements"] // ratio if ratio else 0
    if ratio and hdr["analog_measurements"] % ratio:
        raise _Bad(f"the header's {hdr['analog_measurements']} analog measurements per frame are not "
                   f"a multiple of its {ratio} samples per frame")
    n_analog = a_used if ratio else 0
    if ratio and a_used != h_analog:
        raise _Bad(f"the header says {h_analog} analog channels but ANALOG:USED is {a_used}")
    if n_analog:
        for key, kinds in (("SCALE", (4,)), ("OFFSET", (2, 1))):
            n = _series_len(groups, "ANALOG", key, processor, kinds)
            if n < n_analog:
                raise _Bad(f"ANALOG:{key} has {n} values for {n_analog} channels")
            vals = _decode(groups["ANALOG"][key], processor)
            if key == "SCALE" and any(not math.isfinite(v) for v in vals):
                raise _Bad("ANALOG:SCALE is not finite")
    analog_rate = arate_param if arate_param > 0 else ratio * rate

    # frames, as ezc3d: POINT:FRAMES wins over the header when non-zero
    first = hdr["first_frame"]
    last = hdr["last_frame"]
    first0 = first - 1 if first else 0
    last0 = last - 1 if (last and first) else last
    frames_p = groups["POINT"].get("FRAMES")
    pframes = 0
    if frames_p is not None:
        fv = _first(groups, "POINT", "FRAMES", processor, (2,))
        pframes = fv[0] & 0xFFFF if (len(fv) > 1 or fv[0] < 0) else fv[0]
    if last0 + 1 < first0 and pframes == 0:
        raise _Bad(f"the header's last frame ({last}) is before its first frame ({first})")
    h_frames = last0 - first0 + 1
    if pframes:
        if pframes != h_frames and last != 0xFFFF:  # ezc3d follows POINT:FRAMES
            warnings.append(f"the header says {max(h_frames, 0)} frames but POINT:FRAMES is {pframes}")
        n_frames = pframes
    else:
        n_frames = h_frames
    if used == 0 and n_analog == 0 and not has_rot:
        n_frames = 0
    if n_frames > MAX_FRAMES:
        raise _Bad(f"{n_frames} frames is more than this reader accepts ({MAX_FRAMES})")

    # data section
    dstart = hdr["data_start"]
    ds_param = groups["POINT"].get("DATA_START")
    if ds_param is not None:
        dsv = _first(groups, "POINT", "DATA_START", processor, (2,))[0] & 0xFFFF
        if dsv != dstart:
            raise _Bad(f"the header says the data start in block {dstart} but POINT:DATA_START is {dsv}")
    if dstart < pblock + nblocks:
        raise _Bad(f"the data (block {dstart}) would start inside the header or the parameter section "
                   f"(blocks 1-{pblock + nblocks - 1})")
    word = 4 if is_float else 2
    frame_bytes = used * 4 * word + ratio * n_analog * word
    data_bytes = n_frames * frame_bytes
    dpos = _BLOCK * (dstart - 1)
    if dpos > size:
        raise _Bad(f"the data section (block {dstart}) starts beyond the end of the file ({size} bytes)")
    truncated = False
    if frame_bytes:
        # ezc3d reads the complete frames that are there (and stops at the end of the file)
        held = (size - dpos) // frame_bytes
        if held < n_frames:
            truncated = True
            warnings.append(f"the data section is truncated: the parameters say {n_frames} frames of "
                            f"{frame_bytes} bytes from byte {dpos}, the file ({size} bytes) holds {held} "
                            f"complete frames; {held} frames read")
            n_frames = held
            data_bytes = n_frames * frame_bytes
    rbytes = 0
    if has_rot:
        rg = groups["ROTATION"]
        rs = _first(groups, "ROTATION", "DATA_START", processor, (2,))[0]
        ru = _first(groups, "ROTATION", "USED", processor, (2,))[0]
        if "RATIO" in rg:
            rr = _first(groups, "ROTATION", "RATIO", processor, (2,))[0]
        elif "RATE" in rg:
            rv = _first(groups, "ROTATION", "RATE", processor, (4,))[0]
            rr = rv / hrate if (math.isfinite(rv) and hrate and math.isfinite(hrate)) else -1
            rr = int(rr) if math.isfinite(rr) else -1
        else:
            raise _Bad("ROTATION has neither RATIO nor RATE")
        if rs < 1 or ru < 0 or rr < 0:
            raise _Bad("ROTATION:DATA_START, USED or RATIO is invalid")
        rbytes = n_frames * rr * ru * 17 * 4  # 4 x 4 matrix + reliability, float32
        if rbytes and _BLOCK * (rs - 1) + rbytes > size:
            raise _Bad(f"the ROTATION data section is truncated ({ru} rotations x {rr} per frame "
                       f"from block {rs} do not fit in the file)")
    # bytes after the declared frames (a truncated file's leftover partial frame is not one of them;
    # less than a frame or a padded last block is the usual end of a data section; ezc3d pads a data
    # section that ends on a block boundary with one more whole block, so up to 512 bytes are padding)
    extra = (size - dpos - data_bytes) // frame_bytes if frame_bytes else 0
    if not truncated and not rbytes and extra >= 1 and size - dpos - data_bytes > _BLOCK:
        warnings.append(f"the file has {size - dpos - data_bytes} bytes after the {n_frames} frames the "
                        f"parameters declare (room for {extra} more frames); as ezc3d, only the declared "
                        "frames are read")

    return C3DLayout(
        processor=processor, param_block=pblock, param_blocks=nblocks, data_start=dstart,
        n_points=used, n_analog=n_analog, analog_per_frame=ratio, n_frames=n_frames,
        first_frame=first if first else 1, is_float=is_float, point_rate=rate,
        analog_rate=float(analog_rate), header=hdr, groups=groups, data_bytes=data_bytes,
        warnings=warnings,
    )


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------


def _text_list(value) -> list[str]:
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    return [str(v) for v in value]


def _param_value(params, group: str, name: str):
    try:
        return params[group][name]["value"]
    except (KeyError, TypeError, IndexError):
        return None


def _labels_series(params, group: str) -> list[str]:
    out = _text_list(_param_value(params, group, "LABELS"))
    k = 2
    while True:
        v = _param_value(params, group, f"LABELS{k}")
        if v is None:
            return out
        out += _text_list(v)
        k += 1


def _clean_text(s: str) -> str:
    # ezc3d hands undecodable bytes over as surrogate escapes: show them as latin-1 characters
    try:
        s.encode("utf-8")
        return s
    except UnicodeEncodeError:
        return s.encode("utf-8", "surrogateescape").decode("latin-1")


def _check_values(positions: np.ndarray, src: str, first_frame: int, names: list[str], axes: str) -> None:
    """Refuse ``inf`` and ``|value| > MAX_ABS`` in ``(N, M, 3)`` positions naming frame, marker and axis
    (NaN is a gap, decided by the caller)."""
    bad = ~(np.abs(positions) <= MAX_ABS) & ~np.isnan(positions)
    if bad.any():
        f, mk, a = (int(v) for v in np.argwhere(bad)[0])
        v = float(positions[f, mk, a])
        what = "not finite" if not math.isfinite(v) else f"out of range (|value| > {MAX_ABS:g})"
        raise MocapFormatError(src, None, f"frame {first_frame + f}, {names[mk]} {axes[a]}: {v!r} is {what}")


def _first_frame(layout: C3DLayout) -> tuple[int, str]:
    start = layout.values("TRIAL", "ACTUAL_START_FIELD")
    p = layout.groups.get("TRIAL", {}).get("ACTUAL_START_FIELD")
    if start and p is not None and p.type in (1, 2) and len(start) >= 2:
        lo, hi = start[0] & 0xFFFF, start[1] & 0xFFFF
        value = lo + 65536 * hi
        if value >= 1:
            return value, "TRIAL:ACTUAL_START_FIELD"
    return layout.first_frame, "header"


def read_c3d(path: str | Path) -> Markers:
    """Read the markers (and analog channels) of a C3D file; see the module docstring."""
    p = Path(path)
    src = str(p)

    def head(first: bytes) -> None:
        if len(first) >= 2 and (first[0] == 0 or first[1] != 0x50):
            raise MocapFormatError(src, None, "not a C3D file (the first two bytes must be the parameter "
                                   "block number and 0x50)")

    data = read_input(p, "C3D file", text=False, check_head=head)
    try:
        layout = _check(data)
    except _Bad as exc:
        raise MocapFormatError(src, None, str(exc)) from None
    if layout.n_frames == 0:
        raise MocapFormatError(src, None, "; ".join(["no frames"] + layout.warnings))

    try:
        import ezc3d
    except ImportError:  # pragma: no cover - ezc3d is a dependency of the C3D reader
        raise MocapFormatError(src, None, "reading C3D files needs the 'ezc3d' package") from None
    if is_regular(p):
        return _read_checked(ezc3d, src, src, layout)
    import tempfile  # a pipe or device was read once: ezc3d gets the same bytes from a file

    with tempfile.TemporaryDirectory(prefix="mocapkit-c3d-") as tmp:
        name = str(Path(tmp) / "in.c3d")
        Path(name).write_bytes(data)
        del data
        return _read_checked(ezc3d, name, src, layout)


def _read_checked(ezc3d, name: str, src: str, layout: C3DLayout) -> Markers:
    """Read with ezc3d the file ``name`` (``src`` in messages) whose structure passed the pre-check."""
    try:
        c = ezc3d.c3d(name)
        params = c["parameters"]
        pts = np.asarray(c["data"]["points"], dtype=np.float64)
        res = np.asarray(c["data"]["meta_points"]["residuals"], dtype=np.float64)
        ana = np.asarray(c["data"]["analogs"], dtype=np.float64)
        point_labels = [_clean_text(s) for s in _labels_series(params, "POINT")]
        analog_labels = [_clean_text(s) for s in _labels_series(params, "ANALOG")]
        units_v = [_clean_text(s) for s in _text_list(_param_value(params, "POINT", "UNITS"))]
        analog_units = [_clean_text(s) for s in _text_list(_param_value(params, "ANALOG", "UNITS"))]
    except MemoryError:
        raise MocapFormatError(src, None, "ezc3d ran out of memory reading the file") from None
    except Exception as exc:  # noqa: BLE001 - ezc3d raises RuntimeError, OSError, ValueError...
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise MocapFormatError(src, None, f"ezc3d cannot read the file: {msg}") from None

    n, m = layout.n_frames, layout.n_points
    if pts.ndim != 3 or pts.shape[0] < 3 or pts.shape[1:] != (m, n):
        raise MocapFormatError(src, None, f"ezc3d returned points of shape {pts.shape}, expected "
                               f"(4, {m}, {n}) from the header")
    positions = np.ascontiguousarray(np.transpose(pts[:3], (2, 1, 0)))
    del pts
    invalid = (res[0] < 0).T if res.shape == (1, m, n) else np.zeros((n, m), dtype=bool)
    positions[invalid] = np.nan
    labels, fixes = make_unique_labels(point_labels, m)
    first_frame, first_from = _first_frame(layout)
    _check_values(positions, src, first_frame, [f"marker {lab}" for lab in labels], "XYZ")
    unflagged_nan = int(np.count_nonzero(np.isnan(positions).any(axis=2) & ~invalid))
    if unflagged_nan:
        layout.warnings.append(f"{unflagged_nan} samples hold NaN coordinates without the C3D missing flag "
                               "(residual -1); they are read as gaps")
    positions[np.isnan(positions).any(axis=2)] = np.nan

    rate = float(layout.point_rate)
    times = (first_frame - 1 + np.arange(n, dtype=np.float64)) / rate

    units = units_v[0].strip() if units_v and units_v[0].strip() else ""
    meta: dict = {
        "format": "c3d",
        "processor": layout.processor,
        "first_frame": first_frame,
        "first_frame_from": first_from,
        "header": dict(layout.header),
        "point_scale": layout.header["scale"],
        "storage": "float" if layout.is_float else "integer",
        "groups": sorted(layout.groups),
        "label_fixes": fixes,
        "warnings": list(layout.warnings),
    }
    if not units:
        units = "mm"
        meta["units_assumed"] = True
    manu = {}
    for key in ("COMPANY", "SOFTWARE", "VERSION_LABEL"):
        v = _text_list(_param_value(params, "MANUFACTURER", key))
        if v:
            manu[key.lower()] = _clean_text(" ".join(s.strip() for s in v if s.strip()))
    if manu:
        meta["manufacturer"] = manu
    up = _text_list(_param_value(params, "POINT", "Y_SCREEN"))  # the axis drawn upward on screen: "+Z", "+Y"...
    if up and up[0].strip().upper() in ("+X", "-X", "+Y", "-Y", "+Z", "-Z"):
        meta["up_axis"] = up[0].strip().upper()
    subjects = _text_list(_param_value(params, "SUBJECTS", "NAMES"))
    if subjects:
        meta["subjects"] = [_clean_text(s.strip()) for s in subjects if s.strip()]

    analog = None
    k = layout.n_analog
    if k:
        expected = (1, k, n * layout.analog_per_frame)
        if ana.shape != expected:
            raise MocapFormatError(src, None, f"ezc3d returned analogs of shape {ana.shape}, "
                                   f"expected {expected} from the header")
        a_labels, a_fixes = make_unique_labels(analog_labels, k, prefix="analog")
        meta["analog_label_fixes"] = a_fixes
        ratio = max(layout.analog_per_frame, 1)
        a_vals = ana[0].T  # (samples, channels)
        bad = ~(np.abs(a_vals) <= MAX_ABS)
        if bad.any():
            smp, ch = (int(v) for v in np.argwhere(bad)[0])
            raise MocapFormatError(src, None, f"frame {first_frame + smp // ratio} (analog sample {smp + 1}), "
                                   f"analog channel {a_labels[ch]}: {float(a_vals[smp, ch])!r} is "
                                   + ("not finite" if not np.isfinite(a_vals[smp, ch]) else
                                      f"out of range (|value| > {MAX_ABS:g})")
                                   + " (analog data has no missing-value convention)")
        a_units = tuple((analog_units[i].strip() if i < len(analog_units) else "") for i in range(k))
        analog = {
            "labels": a_labels,
            "rate": float(layout.analog_rate),
            "values": np.ascontiguousarray(ana[0].T),
            "units": a_units,
            "t0": float(times[0]),
        }
    try:
        return Markers(times, positions, labels, rate, units=units, analog=analog, source=src,
                       meta=meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


# --------------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------------

#: Largest deviation of a frame time from the regular grid ``(first - 1 + k) / rate`` accepted by
#: :func:`write_c3d`, in frames (text formats round their times: a TRC at 60 Hz with 3 decimals is
#: off by up to 0.03 frame).
TIME_GRID_TOLERANCE = 0.1
#: Largest first frame number :func:`write_c3d` stores (TRIAL:ACTUAL_START_FIELD holds 32 bits).
MAX_START_FRAME = 2**32 - 1


def _frame_grid(markers: Markers) -> int:
    """The 1-based number of the first frame; raise when the times are not on a regular grid."""
    from mocapkit.errors import InvalidParameterError

    k = markers.times * markers.rate
    first = int(round(float(k[0])))
    dev = np.abs(k - (first + np.arange(markers.n_frames)))
    if dev.max() > TIME_GRID_TOLERANCE:
        i = int(np.argmax(dev))
        raise InvalidParameterError(
            f"C3D stores frames at a constant rate: frame {i} (t={float(markers.times[i])!r} s) is "
            f"{float(dev[i]):.3g} frames off the {markers.rate:g} Hz grid (gaps in time cannot be "
            "stored; write TRC or CSV instead)")
    if not 0 <= first < MAX_START_FRAME:
        raise InvalidParameterError(f"the first frame number ({first + 1}) cannot be stored in C3D "
                                    f"(frame numbers run from 1 to {MAX_START_FRAME})")
    return first + 1


def _words(value: int) -> np.ndarray:
    """``value`` as the two 16-bit words ``[low, high]`` of the TRIAL:*_FIELD parameters."""
    return np.array([value & 0xFFFF, (value >> 16) & 0xFFFF], dtype=np.int64)


def write_c3d(markers: Markers, path: str | Path, *, analog: bool = True) -> None:
    """Write markers as a C3D file (float storage, Intel byte order) with ezc3d, atomically.

    Stored: ``POINT:LABELS`` (``LABELS2``... beyond 255 markers), ``POINT:RATE``, ``POINT:UNITS``,
    the first frame number (``round(times[0] * rate) + 1``, so the time origin is kept) in the
    header, or beyond 65535 (a take cropped late in a long recording) in ``TRIAL:ACTUAL_START_FIELD``
    and ``ACTUAL_END_FIELD`` (low and high 16-bit words, the header then counting from 1), the
    positions as float32 and a missing sample as the C3D invalid point (coordinates 0, residual -1;
    read back as NaN). Times must lie on the frame grid (within ``TIME_GRID_TOLERANCE`` frames).
    With ``analog=True`` the analog channels (when present) are written too; they need a rate that
    is an integer multiple of the frame rate and ``rate_ratio * N`` samples, else
    ``InvalidParameterError`` naming ``path`` (pass ``analog=False`` to leave them out).
    """
    from mocapkit.errors import InvalidParameterError

    try:
        _build_and_write(markers, path, analog)
    except InvalidParameterError as exc:  # name the output the user asked for
        raise InvalidParameterError(f"{path}: cannot be written as C3D: {exc}") from None


def _build_and_write(markers: Markers, path: str | Path, analog: bool) -> None:
    """The body of :func:`write_c3d`."""
    import errno
    import tempfile

    import ezc3d

    from mocapkit.errors import InvalidParameterError
    from mocapkit.io.atomic import atomic_write_bytes

    first = _frame_grid(markers)
    n, m = markers.n_frames, markers.n_markers
    for lab in markers.labels:
        if len(lab.encode("utf-8")) > 255:
            raise InvalidParameterError(f"marker label {lab[:40]!r}... is longer than C3D's 255 bytes")
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [markers.rate]
    c["parameters"]["POINT"]["UNITS"]["value"] = [markers.units]
    labels = list(markers.labels)
    c["parameters"]["POINT"]["LABELS"]["value"] = labels[:255]
    for k in range(1, (m + 254) // 255):
        c.add_parameter("POINT", f"LABELS{k + 1}", labels[255 * k:255 * (k + 1)])
    missing = markers.missing
    pts = np.ones((4, m, n))
    pts[:3] = np.transpose(np.where(missing[:, :, None], 0.0, markers.positions), (2, 1, 0))
    res = np.where(missing.T, -1.0, 0.0)[None]
    c["data"]["points"] = pts
    c["data"]["meta_points"] = {"residuals": res, "camera_masks": np.zeros((7, m, n), dtype=bool)}
    a = markers.analog
    if analog and a is not None and len(a["labels"]):
        ratio = a["rate"] / markers.rate
        vals = a["values"]
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1 or vals.shape[0] != round(ratio) * n:
            raise InvalidParameterError(
                f"analog channels at {a['rate']:g} Hz ({vals.shape[0]} samples) cannot be stored with "
                f"{n} frames at {markers.rate:g} Hz (C3D needs an integer number of samples per frame)")
        if not np.isfinite(vals).all():
            raise InvalidParameterError("analog values must be finite to be written to C3D")
        c["parameters"]["ANALOG"]["RATE"]["value"] = [float(a["rate"])]
        c["parameters"]["ANALOG"]["LABELS"]["value"] = list(a["labels"])
        units = a.get("units")
        if units is not None and len(units) == len(a["labels"]):
            c["parameters"]["ANALOG"]["UNITS"]["value"] = [u or " " for u in units]
        c["data"]["analogs"] = np.ascontiguousarray(vals.T)[None]
    if first <= 0xFFFF:
        c["header"]["points"]["first_frame"] = first - 1
        c["header"]["points"]["last_frame"] = first - 2 + n
    else:
        # the header's 16-bit words cannot hold the frame numbers: the header counts from 1 and
        # TRIAL:ACTUAL_START_FIELD / ACTUAL_END_FIELD hold the 32-bit first and last frame numbers
        # as [low, high] 16-bit words (integer parameters; read_c3d and ezc3d see low + 65536 * high)
        c["header"]["points"]["first_frame"] = 0
        c["header"]["points"]["last_frame"] = n - 1
        for name, value in (("ACTUAL_START_FIELD", first), ("ACTUAL_END_FIELD", first + n - 1)):
            c.add_parameter("TRIAL", name, [0, 0])
            c["parameters"]["TRIAL"][name]["type"] = 2  # integer (a Python list is stored as float)
            c["parameters"]["TRIAL"][name]["value"] = _words(value)
    # ezc3d writes only to a path: a private folder of the system's temporary space (removed on any
    # failure), never the target's folder; the bytes then go through the safe writer
    with tempfile.TemporaryDirectory(prefix="mocapkit-c3d-") as tmp:
        name = str(Path(tmp) / "out.c3d")
        try:
            c.write(name)
            data = Path(name).read_bytes()
        except Exception as exc:  # noqa: BLE001 - ezc3d raises RuntimeError, OSError...
            raise OSError(errno.EIO, f"the C3D data could not be built ({exc})", str(path)) from None
    atomic_write_bytes(path, data)
