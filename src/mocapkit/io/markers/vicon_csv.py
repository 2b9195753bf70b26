"""Vicon Nexus CSV export: the ``Trajectories`` block read into :class:`mocapkit.markers.Markers`.

Layout (Nexus "Export CSV"): one or more blocks separated by blank lines, each

====  ===========================================================================================
line  content
====  ===========================================================================================
1     block name: ``Devices``, ``Trajectories`` (also ``Model Outputs``, ``Joints``...)
2     rate in Hz
3     names: ``,,Subject:LASI,,,Subject:RASI,,,...`` (one name per group of columns, in its first
      column; device blocks name the device output, e.g. ``Force Plate 1 - Force``)
4     components: ``Frame,Sub Frame,X,Y,Z,X,Y,Z,...``
5     units: ``,,mm,mm,mm,...``
6...  data: frame number, sub-frame, values; an empty cell is a missing value
====  ===========================================================================================

The delimiter is sniffed from the components line (comma, or semicolon/tab as some locales write).
Marker labels keep the ``Subject:Marker`` names as written (made unique by
:func:`mocapkit.markers.make_unique_labels`). ``times = (frame - 1) / rate`` (Nexus numbers frames
from 1 in the trial; a cropped export keeps its frame numbers, hence its time origin). The units are
those of the first X column (``mm`` when the units line is empty, recorded as ``units_assumed``).
The ``Devices`` block, when present, becomes ``analog``: labels ``"<device> <component>"``,
``values`` ``(frames x sub-frames, K)`` with ``NaN`` for empty cells, ``rate`` from its own rate
line. Other blocks are listed in ``meta["blocks"]`` and not read.

Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers` (no ``0_5``, ``nan`` or ``inf``);
``|value| > MAX_ABS`` (1e12) is refused naming the line and column; the only missing value is an
empty cell (Nexus's gap). The rate must lie in [1e-6, 1e9] Hz. A file that ends without a newline and
whose last line has another number of cells than the line before, or whose last value is empty or
has fewer decimals than the same column on the rows before it (cut in the middle of a number), is
an error naming the line: the file was cut short. Nexus writes 6 significant digits, so the decimals
of a column vary and a cut inside the last value often cannot be told: then the row is read with a
warning (``meta["warnings"]`` and :class:`~mocapkit.errors.MocapWarning`). Rows that, padded with gaps, would need far
more values than the file holds are refused before allocation; pipes and devices are read in bounded chunks
(:mod:`mocapkit.io.text.input`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.text.input import check_cells_budget, final_line_verdict, read_text, report_final_line
from mocapkit.io.text.numbers import NUMBER_RE, parse_number
from mocapkit.markers import Markers, make_unique_labels

#: Range accepted for a block's rate (Hz).
RATE_RANGE = (1e-6, 1e9)

__all__ = ["read_vicon_csv", "is_vicon_csv", "BLOCK_NAMES"]

#: Block names that start a Nexus CSV export (a ``.csv`` whose first line is one of them is sniffed
#: as a Vicon export).
BLOCK_NAMES = ("Trajectories", "Devices", "Model Outputs", "Joints", "Segments")


def _first_line(head: str) -> str:
    for ln in head.splitlines():
        s = ln.strip().strip(",;\t").strip()
        if s:
            return s
    return ""


def is_vicon_csv(path: str | Path) -> bool:
    """True when the first non-empty line of the file is ``Trajectories`` or ``Devices``."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(256)
    except OSError:
        return False
    if head.startswith(b"\xef\xbb\xbf"):
        head = head[3:]
    return _first_line(head.decode("latin-1")) in ("Trajectories", "Devices")


class _Block:
    def __init__(self, name: str, start: int):
        self.name = name
        self.start = start          # 0-based index of the block-name line
        self.lines: list[tuple[int, list[str]]] = []


def _split_blocks(lines: list[str], src: str) -> tuple[list[_Block], str]:
    delim = ","
    for ln in lines[:12]:
        low = ln.lower()
        if low.startswith("frame"):
            delim = next((d for d in (",", ";", "\t") if f"frame{d}sub frame" in low), ",")
            break
    blocks: list[_Block] = []
    cur: _Block | None = None
    for i, ln in enumerate(lines):
        cells = [c.strip() for c in ln.split(delim)]
        if not any(cells):
            cur = None
            continue
        if cur is None:
            name = cells[0]
            if any(cells[1:]):
                raise MocapFormatError(src, i + 1, f"expected a block name line (e.g. 'Trajectories'), got "
                                       f"{ln[:60]!r}")
            cur = _Block(name, i)
            blocks.append(cur)
            continue
        cur.lines.append((i + 1, cells))
    return blocks, delim


def _parse_block(b: _Block, src: str, cut_line: int | None = None, file_bytes: int = 0,
                 warnings: list[str] | None = None):
    """``(rate, names per column, components, units, frames, subframes, values (R, C), lines)``.

    ``cut_line``: the file's last line when it ends without a newline (checked for a cut-short row;
    a doubt goes to ``warnings``).
    """
    warnings = [] if warnings is None else warnings
    if len(b.lines) < 4:
        raise MocapFormatError(src, b.start + 1, f"the {b.name} block needs a rate, names, components and "
                               "units line before its data")
    (ln_r, rate_c), (ln_n, names), (ln_c, comps), (ln_u, units) = b.lines[:4]
    if not NUMBER_RE.fullmatch(rate_c[0]):
        raise MocapFormatError(src, ln_r, f"{b.name}: the rate {rate_c[0][:30]!r} is not a number")
    rate = float(rate_c[0])
    if not (math.isfinite(rate) and RATE_RANGE[0] <= rate <= RATE_RANGE[1]):
        raise MocapFormatError(src, ln_r, f"{b.name}: the rate must be > 0 (between {RATE_RANGE[0]:g} and "
                               f"{RATE_RANGE[1]:g} Hz), got {rate_c[0]!r}")
    while comps and not comps[-1]:
        comps.pop()
    if len(comps) < 3 or comps[0].lower() != "frame" or comps[1].lower() != "sub frame":
        raise MocapFormatError(src, ln_c, f"{b.name}: the components line must start with 'Frame,Sub Frame'")
    width = len(comps)
    for j in range(2, width):
        if not comps[j]:
            raise MocapFormatError(src, ln_c, f"{b.name}: column {j + 1} has no component name")
    # the name of a group of columns is written in its first column only
    col_names: list[str] = []
    current = ""
    for j in range(2, width):
        if j < len(names) and names[j]:
            current = names[j]
        col_names.append(current)
    extra = [c for c in names[width:] if c]
    if extra:
        raise MocapFormatError(src, ln_n, f"{b.name}: names past the last component column: {extra[:3]}")
    unit_cells = [(units[j] if j < len(units) else "") for j in range(2, width)]
    rows = b.lines[4:]
    if not rows:
        raise MocapFormatError(src, ln_u, f"{b.name}: no data rows")
    check_cells_budget(src, ln_c, len(rows) * width, file_bytes, f"{b.name}: {len(rows)} rows of {width} columns")
    vals = np.empty((len(rows), width), dtype=np.float64)
    field = [f"{b.name}: column {j + 1} ({(col_names[j - 2] + ' ') if j >= 2 and col_names[j - 2] else ''}"
             f"{comps[j]})" for j in range(width)]
    for r, (line, cells) in enumerate(rows):
        if len(cells) > width:
            if any(cells[width:]):
                raise MocapFormatError(src, line, f"{b.name}: expected {width} cells like the components line "
                                       f"{ln_c}, found {len(cells)}")
            cells = cells[:width]
        if line == cut_line:
            verdict, col = final_line_verdict([c for _, c in rows[max(0, r - 20):r]], cells)
            report_final_line(src, line, verdict, col,
                              field[col] if col is not None and col < width else "the last value",
                              cells[col] if col is not None else "", warnings)
        for j in range(width):
            c = cells[j] if j < len(cells) else ""
            if not c:
                if j < 2:
                    raise MocapFormatError(src, line, f"{b.name}: the {comps[j]} cell is empty")
                vals[r, j] = math.nan
                continue
            vals[r, j] = parse_number(c, src, line, field[j])
    return rate, col_names, comps[2:], unit_cells, vals, [ln for ln, _ in rows]


def read_vicon_csv(path: str | Path) -> Markers:
    """Read the ``Trajectories`` (and ``Devices``) blocks of a Vicon Nexus CSV export (module doc)."""
    p = Path(path)
    src = str(p)
    lines, ends_with_newline, enc, size = read_text(p, "CSV file")
    while lines and not lines[-1].strip():
        lines.pop()
        ends_with_newline = True
    cut_line = None if ends_with_newline else len(lines)
    blocks, delim = _split_blocks(lines, src)
    if not blocks or blocks[0].name not in ("Trajectories", "Devices"):
        raise MocapFormatError(src, 1, "not a Vicon Nexus CSV export (the first line must be 'Trajectories' "
                               "or 'Devices')")
    by_name = {}
    for b in blocks:
        if b.name in by_name:
            raise MocapFormatError(src, b.start + 1, f"a second {b.name} block")
        by_name[b.name] = b
    traj = by_name.get("Trajectories")
    if traj is None:
        raise MocapFormatError(src, None, "no Trajectories block (only "
                               + ", ".join(b.name for b in blocks) + "): no marker positions to read")
    read_warnings: list[str] = []
    rate, col_names, comps, units, vals, row_lines = _parse_block(traj, src, cut_line, size, read_warnings)
    (ln_n, _), (ln_c, _) = traj.lines[1], traj.lines[2]
    if len(comps) % 3:
        raise MocapFormatError(src, ln_c, f"Trajectories: {len(comps)} value columns is not a multiple of 3 "
                               "(X, Y, Z per marker)")
    raw_labels = []
    for k in range(0, len(comps), 3):
        trio = [c.upper() for c in comps[k:k + 3]]
        if trio != ["X", "Y", "Z"]:
            raise MocapFormatError(src, ln_c, f"Trajectories: columns {k + 3}-{k + 5} are {comps[k:k + 3]}, "
                                   "expected X, Y, Z")
        if len({col_names[k], col_names[k + 1], col_names[k + 2]}) != 1:
            raise MocapFormatError(src, ln_n, f"Trajectories: column {k + 4} starts a new name inside one "
                                   "marker's X, Y, Z")
        raw_labels.append(col_names[k])
    frames = vals[:, 0]
    sub = vals[:, 1]
    if np.any(sub != 0):
        i = int(np.flatnonzero(sub != 0)[0])
        raise MocapFormatError(src, row_lines[i], "Trajectories: a sub-frame other than 0 (one row per frame "
                               "expected)")
    if np.any(frames != np.round(frames)):
        i = int(np.flatnonzero(frames != np.round(frames))[0])
        raise MocapFormatError(src, row_lines[i], f"Trajectories: frame {frames[i]!r} is not an integer")
    bad = np.flatnonzero(np.diff(frames) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MocapFormatError(src, row_lines[i], f"Trajectories: frame {int(frames[i])} does not follow "
                               f"frame {int(frames[i - 1])}")
    n, m = len(frames), len(raw_labels)
    labels, fixes = make_unique_labels(raw_labels, m)
    unit = units[0] if units and units[0] else ""
    meta: dict = {"format": "vicon-csv", "encoding": enc, "delimiter": delim, "label_fixes": fixes,
                  "first_frame": int(frames[0]), "blocks": [b.name for b in blocks], "warnings": read_warnings}
    if not unit:
        unit = "mm"
        meta["units_assumed"] = True
    if any(u and u != unit for u in units):
        meta["warnings"].append(f"Trajectories: mixed units {sorted(set(u for u in units if u))}; "
                                f"{unit!r} recorded")
    gaps = np.flatnonzero(np.diff(frames) > 1)
    if gaps.size:
        meta["warnings"].append(f"Trajectories: {gaps.size} jumps in the frame numbers (first after frame "
                                f"{int(frames[gaps[0]])})")
    skipped = [b.name for b in blocks if b.name not in ("Trajectories", "Devices")]
    if skipped:
        meta["warnings"].append(f"blocks not read: {', '.join(skipped)}")
    times = (frames - 1.0) / rate
    analog = None
    dev = by_name.get("Devices")
    if dev is not None:
        d_rate, d_names, d_comps, d_units, d_vals, d_lines = _parse_block(dev, src, cut_line, size, read_warnings)
        d_labels, d_fixes = make_unique_labels([f"{nm} {c}".strip() for nm, c in zip(d_names, d_comps, strict=False)],
                                               len(d_comps), prefix="analog")
        meta["analog_label_fixes"] = d_fixes
        analog = {"labels": d_labels, "rate": d_rate, "values": d_vals[:, 2:], "units": tuple(d_units),
                  "t0": float((d_vals[0, 0] - 1.0) / rate + d_vals[0, 1] / d_rate)}
    try:
        return Markers(times, vals[:, 2:].reshape(n, m, 3), labels, rate, units=unit, analog=analog,
                       source=src, meta=meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None
