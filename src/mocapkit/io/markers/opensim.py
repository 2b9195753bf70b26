"""OpenSim text files: TRC marker trajectories and MOT/STO tables (joint angles, OpenSense orientations).

TRC (``PathFileType 4``)
------------------------
Line 1 ``PathFileType<TAB>4<TAB>(X/Y/Z)<TAB><name>``, line 2 the header keys (``DataRate``,
``CameraRate``, ``NumFrames``, ``NumMarkers``, ``Units``, ``OrigDataRate``, ``OrigDataStartFrame``,
``OrigNumFrames``), line 3 their values, line 4 ``Frame#<TAB>Time<TAB>M1<TAB><TAB><TAB>M2...``, line 5
``<TAB><TAB>X1<TAB>Y1<TAB>Z1<TAB>X2...``, then (after an optional blank line) one row per frame.
:func:`read_trc` follows the rows, not the header, where real files disagree with it:

* a TRC saved by a spreadsheet is read the same: when the first line has no tab but a comma, every line
  is split as CSV (``"..."`` quoting; the empty cells that pad short rows are ignored as trailing tabs
  are; ``meta["delimiter"]`` says which);
* labels are the non-empty cells of line 4 after ``Time`` (files space them by one, two or three
  tabs); line 5 must hold ``3 x`` that many coordinate names;
* an empty cell (or ``NaN``) is a missing coordinate; a row with fewer cells than ``2 + 3M`` is
  padded with missing values, empty cells past the last marker (trailing tabs) are ignored;
* ``NumFrames`` (or ``NumMarkers``) disagreeing with the file: the rows are read and the
  difference is recorded in ``meta["warnings"]``;
* times are the ``Time`` column; ``rate`` is ``DataRate`` (``CameraRate`` when ``DataRate`` is
  absent), unless both the median and the mean step of the times disagree with it by more than
  1 %: then the rate of the median step is used, with a warning (``meta["declared_rate"]`` keeps the header's).

:func:`write_trc` writes that layout (tab-separated, ``\\n`` line ends, positions with ``decimals``
decimals, times as ``repr``, missing samples as empty cells).

MOT / STO
---------
Header lines until ``endheader``: ``key=value`` pairs (``version``, ``nRows``, ``nColumns``,
``inDegrees=yes|no``, ``DataRate``, ``DataType``...), an optional first line naming the table and
free text (``Angles are in degrees.`` in old files). Then a tab-separated column header starting with
``time`` and the rows. Two kinds of content:

* **a table of numbers** (joint angles from inverse kinematics, any MOT/STO):
  :func:`read_table` returns one ``Signal`` of kind ``"vector"`` whose ``meta`` holds ``labels``
  (column names without ``time``), ``in_degrees`` (``True``/``False``/``None`` when the file does
  not say), ``units`` (``"deg"``/``"rad"``/``None``: the unit of the rotational columns; OpenSim
  keeps translations in metres), ``name`` and ``header``. A ``Signal`` cannot hold gaps: an empty
  or ``NaN`` cell is an error naming the line and column.
* **OpenSense orientations** (``DataType=Quaternion``, one ``w,x,y,z`` cell per IMU):
  :func:`read_orientations` returns ``{imu name: Signal}`` of kind ``"quaternion"``.

:func:`read_opensim_signals` reads either as ``{name: Signal}`` (the reader registered for ``.sto``
and ``.mot`` in :data:`mocapkit.io.imu.signals.READERS`). :func:`write_table` and
:func:`write_orientations` write them back (numbers as ``repr`` unless ``decimals`` is given).
``nRows``/``nColumns`` disagreeing with the rows are recorded in ``meta["warnings"]``.

Damaged and hostile files
-------------------------
* Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers` (no ``0_5``, no ``inf``);
  ``|value| > MAX_ABS`` (1e12) is refused with the line and the column (``<marker> X`` in a TRC,
  the column name in a MOT/STO). The only missing-value spellings are those of the formats: an
  empty cell or ``NaN`` in a TRC (a gap); none in a MOT/STO (an error).
* Header counts (``NumFrames``, ``NumMarkers``, ``nRows``, ``nColumns``) size nothing: they are only
  compared with the rows (a warning); more than 18 digits is refused. A TRC whose rows, padded to
  the markers of line 4, would need far more values than the file holds is refused before the
  array is allocated. ``DataRate`` must lie in [1e-6, 1e9] Hz. A header line longer than 1 MiB is
  refused.
* A file that ends without a newline and whose last line has another number of cells than the line
  before it (a TRC pads short rows with gaps, but not this one), an empty last cell where every
  earlier row has a value, or a last value with fewer decimals than the same column on the rows
  before it (cut in the middle of ``-0.124044``) is an error naming the line and column: the file
  was cut short (delete that line to read the rest). When the column's decimals vary (``repr``
  writers) so that a cut cannot be told, the row is read with a warning (``meta["warnings"]`` and
  :class:`~mocapkit.errors.MocapWarning`).
* Pipes and devices are read in bounded chunks; a NUL byte is refused (:mod:`mocapkit.io.text.input`).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.text.input import (
    MAX_HEADER_LINE,
    check_cells_budget,
    final_line_verdict,
    is_regular,
    read_text,
    report_final_line,
)
from mocapkit.io.text.numbers import parse_number
from mocapkit.markers import Markers, make_unique_labels
from mocapkit.motion import Signal

__all__ = [
    "read_trc",
    "write_trc",
    "read_table",
    "read_orientations",
    "read_opensim_signals",
    "write_table",
    "write_orientations",
    "write_table_csv",
]


# --------------------------------------------------------------------------------------------------
# shared text helpers
# --------------------------------------------------------------------------------------------------


#: Range accepted for a header rate (Hz).
RATE_RANGE = (1e-6, 1e9)
_TRC_MISSING = ("", "NaN", "nan")


class _Text:
    """The lines of a text input, whether it ended with a newline and its size in bytes."""

    def __init__(self, path: Path, what: str, header_lines: int):
        self.src = str(path)
        self.lines, self.ends_with_newline, self.encoding, self.size = read_text(path, what)
        while self.lines and not self.lines[-1].strip():
            self.lines.pop()
            self.ends_with_newline = True
        for i, ln in enumerate(self.lines[:header_lines]):
            if len(ln) > MAX_HEADER_LINE:
                raise MocapFormatError(self.src, i + 1, f"header line of {len(ln):,} characters (more than "
                                       f"{MAX_HEADER_LINE:,})")


def _number(cell: str, src: str, line: int, what: str) -> float:
    """A cell by the strict grammar; an empty cell (or ``NaN``) is ``nan`` (the caller decides)."""
    return parse_number(cell.strip(), src, line, what, missing=_TRC_MISSING)


def _count(v: str) -> int | None:
    """A header count (``NumFrames``...): a plain integer of at most 18 digits, else ``None``."""
    t = v.strip()
    if t.isascii() and t.isdigit() and len(t) <= 18:
        return int(t)
    return None


def _check_cut(rows: list[list[str]], last: list[str], src: str, line: int, names: list[str],
               warnings: list[str]) -> None:
    """Judge a last line written without a newline (:func:`mocapkit.io.text.input.final_line_verdict`):
    an error when it is evidently cut short, a warning when that cannot be told."""
    verdict, j = final_line_verdict(rows, last)
    name = (names[j] if j < len(names) else f"column {j + 1}") if j is not None else "the last value"
    report_final_line(src, line, verdict, j, name, last[j] if j is not None else "", warnings)


def _check_times(times: np.ndarray, src: str, lines_of: list[int]) -> None:
    if np.isnan(times).any():
        i = int(np.flatnonzero(np.isnan(times))[0])
        raise MocapFormatError(src, lines_of[i], "the time cell is empty")
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MocapFormatError(src, lines_of[i], f"time {times[i]!r} is not after the previous row's "
                               f"({times[i - 1]!r}); times must be strictly increasing")


def _fmt(v: float, decimals: int | None) -> str:
    if math.isnan(v):
        return ""
    return repr(float(v)) if decimals is None else f"{v:.{decimals}f}"


# --------------------------------------------------------------------------------------------------
# TRC
# --------------------------------------------------------------------------------------------------

_TRC_KEYS = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
             "OrigDataStartFrame", "OrigNumFrames")


def _trc_splitter(first_line: str):
    """How the cells of a TRC are split: on tabs (OpenSim), or as CSV when the first line has no tab and
    a comma (a TRC saved by a spreadsheet: ``"..."`` quoting, trailing commas padding every row)."""
    if "\t" in first_line or "," not in first_line:
        return "\t", lambda ln: ln.split("\t")

    def split_csv(ln: str) -> list[str]:
        if '"' not in ln:
            return ln.split(",")
        return next(csv.reader([ln]))
    return ",", split_csv


def read_trc(path: str | Path) -> Markers:
    """Read an OpenSim TRC marker file into :class:`mocapkit.markers.Markers` (see the module doc)."""
    p = Path(path)
    src = str(p)
    txt = _Text(p, "TRC file", 5)
    lines, enc = txt.lines, txt.encoding
    delim, split = _trc_splitter(lines[0] if lines else "")
    if not lines or not split(lines[0])[0].strip().lower().startswith("pathfiletype"):
        raise MocapFormatError(src, 1, "not a TRC file (the first line must start with 'PathFileType')")
    if len(lines) < 5:
        raise MocapFormatError(src, len(lines) or 1, "the TRC header needs 5 lines (PathFileType, keys, "
                               "values, marker names, coordinate names)")
    keys = [k.strip() for k in split(lines[1])]
    vals = [v.strip() for v in split(lines[2])]
    header = {k: (vals[i] if i < len(vals) else "") for i, k in enumerate(keys) if k}
    low = {k.lower(): v for k, v in header.items()}
    warnings: list[str] = []

    def num(key: str, integer: bool = False):
        v = low.get(key.lower(), "")
        if v == "":
            return None
        if integer:
            n = _count(v)
            if n is None:
                raise MocapFormatError(src, 3, f"{key} {v[:40]!r} is not a count (a non-negative integer of at "
                                       "most 18 digits)")
            return n
        return parse_number(v, src, 3, key)

    rate = num("DataRate")
    if rate is None:
        rate = num("CameraRate")
    if rate is None:
        raise MocapFormatError(src, 2, "no DataRate (or CameraRate) in the header")
    if not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
        raise MocapFormatError(src, 3, f"DataRate must be > 0 (between {RATE_RANGE[0]:g} and {RATE_RANGE[1]:g} "
                               f"Hz), got {rate!r}")
    units = low.get("units", "")
    meta: dict = {"format": "trc", "header": header, "encoding": enc, "delimiter": delim}
    sep = "<TAB>" if delim == "\t" else ","
    if not units:
        units = "mm"
        meta["units_assumed"] = True
        warnings.append("no Units in the header: millimetres assumed")
    n_frames_decl = num("NumFrames", integer=True)
    n_markers_decl = num("NumMarkers", integer=True)

    names = split(lines[3])
    if len(names) < 2 or names[0].strip().lower() != "frame#" or names[1].strip().lower() != "time":
        raise MocapFormatError(src, 4, f"line 4 must start with 'Frame#{sep}Time' followed by the marker names")
    raw_labels = [c.strip() for c in names[2:] if c.strip()]
    m = len(raw_labels)
    if n_markers_decl is not None and n_markers_decl != m:
        warnings.append(f"NumMarkers is {n_markers_decl} but line 4 names {m} markers; {m} read")
    coords = [c.strip() for c in split(lines[4]) if c.strip()]
    if len(coords) != 3 * m:
        raise MocapFormatError(src, 5, f"expected {3 * m} coordinate names (X1 Y1 Z1 ... for {m} markers), "
                               f"found {len(coords)}")
    for j, c in enumerate(coords):
        if c[:1].upper() != "XYZ"[j % 3]:
            raise MocapFormatError(src, 5, f"coordinate name {j + 1} is {c!r}, expected {'XYZ'[j % 3]}{j // 3 + 1}")

    width = 2 + 3 * m
    field = ["Frame#", "Time"] + [f"column {j + 1} ({raw_labels[(j - 2) // 3]} {'XYZ'[(j - 2) % 3]})"
                                  for j in range(2, width)]
    body = [i for i in range(5, len(lines)) if lines[i].strip()]
    if not body:
        raise MocapFormatError(src, len(lines), "no data rows")
    check_cells_budget(src, 4, len(body) * width, txt.size, f"{len(body)} rows of {m} markers")
    data = np.empty((len(body), width), dtype=np.float64)
    row_lines = [i + 1 for i in body]
    last = len(body) - 1
    cut = not txt.ends_with_newline
    short = 0
    for r, i in enumerate(body):
        ln = lines[i]
        cells = split(ln)
        if len(cells) > width:
            extra = cells[width:]
            if any(c.strip() for c in extra):
                raise MocapFormatError(
                    src,
                    i + 1,
                    f"expected {width} {'tab' if delim == chr(9) else 'comma'}-separated cells (Frame#, Time and "
                    f"{m} x 3 coordinates), found {len(cells)}",
                )
            cells = cells[:width]
        elif len(cells) < width:
            if len(cells) < 2:
                raise MocapFormatError(src, i + 1, "a data row needs at least Frame# and Time")
            short += 1
            cells = cells + [""] * (width - len(cells))
        row = data[r]
        for j in range(width):
            row[j] = _number(cells[j], src, i + 1, field[j])
        if cut and r == last:
            _check_cut([split(lines[k]) for k in body[max(0, r - 20):r]], split(ln), src, i + 1,
                       field, warnings)
    times = data[:, 1]
    _check_times(times, src, row_lines)
    if short:
        warnings.append(f"{short} rows have fewer cells than {width}: the missing cells are read as gaps")
    if n_frames_decl is not None and n_frames_decl != len(body):
        warnings.append(f"NumFrames is {n_frames_decl} but the file has {len(body)} data rows "
                        f"(lines {row_lines[0]}-{row_lines[-1]}); the rows are read")
    if len(times) > 2:
        step = float(np.median(np.diff(times)))
        mean_step = float(times[-1] - times[0]) / (len(times) - 1)  # robust to rounded times
        if abs(step * rate - 1.0) > 0.01 and abs(mean_step * rate - 1.0) > 0.01:
            meta["declared_rate"] = rate
            warnings.append(f"DataRate is {rate:g} Hz but the Time column steps by {step:.6g} s "
                            f"({1.0 / step:.6g} Hz): the rate of the Time column is used")
            rate = float(f"{1.0 / step:.6g}")
    labels, fixes = make_unique_labels(raw_labels, m)
    frames = data[:, 0]
    meta.update({"label_fixes": fixes, "warnings": warnings,
                 "first_frame": None if math.isnan(frames[0]) else frames[0]})
    try:
        return Markers(times, data[:, 2:].reshape(len(body), m, 3), labels, rate, units=units,
                       source=src, meta=meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


def _frame_numbers(markers: Markers) -> list[int]:
    k = np.round(markers.times * markers.rate).astype(np.int64) + 1
    if len(k) > 1 and not np.all(np.diff(k) > 0):
        return list(range(1, markers.n_frames + 1))
    return k.tolist()


def write_trc(markers: Markers, path: str | Path, *, decimals: int = 6) -> None:
    """Write markers as an OpenSim TRC file (``PathFileType 4``), atomically.

    Frame numbers are ``round(t * rate) + 1`` (``1..N`` when that does not increase), times are
    written as ``repr`` (exact), coordinates with ``decimals`` decimals, a missing sample as three
    empty cells.
    """
    if decimals < 0:
        raise InvalidParameterError("decimals must be >= 0")
    n, m = markers.n_frames, markers.n_markers
    frames = _frame_numbers(markers)
    r = f"{markers.rate:g}" if float(f"{markers.rate:g}") == markers.rate else repr(markers.rate)
    out = [
        f"PathFileType\t4\t(X/Y/Z)\t{Path(path).name}",
        "\t".join(_TRC_KEYS),
        "\t".join([r, r, str(n), str(m), markers.units, r, str(frames[0]), str(n)]),
        "\t".join(["Frame#", "Time"] + [f"{lab}\t\t" for lab in markers.labels]).rstrip("\t"),
        "\t".join(["", ""] + [f"{a}{k + 1}" for k in range(m) for a in "XYZ"]),
        "",
    ]
    flat = markers.positions.reshape(n, 3 * m)
    for f, t, row in zip(frames, markers.times.tolist(), flat.tolist(), strict=True):
        out.append("\t".join([str(f), repr(t)] + [_fmt(v, decimals) for v in row]))
    atomic_write_text(path, "\n".join(out) + "\n")


# --------------------------------------------------------------------------------------------------
# MOT / STO
# --------------------------------------------------------------------------------------------------


def _parse_header(lines: list[str], src: str) -> tuple[dict, str, list[str], int]:
    """``(key=value pairs, table name, free text lines, index of the column-header line)``."""
    pairs: dict[str, str] = {}
    name = ""
    text: list[str] = []
    for i, ln in enumerate(lines):
        s = ln.strip()
        if s.lower() == "endheader":
            j = i + 1
            while j < len(lines) and not lines[j].strip():
                j += 1
            if j >= len(lines):
                raise MocapFormatError(src, i + 1, "no column header after 'endheader'")
            return pairs, name, text, j
        if "=" in s and not s.startswith("#"):
            k, _, v = s.partition("=")
            pairs[k.strip()] = v.strip()
        elif s:
            if i == 0 and not name:
                name = s
            else:
                text.append(s)
    raise MocapFormatError(src, 1, "not an OpenSim MOT/STO file: no 'endheader' line")


def _get(pairs: dict, key: str) -> str | None:
    for k, v in pairs.items():
        if k.lower() == key.lower():
            return v
    return None


def _parse_table(path: str | Path, txt: _Text | None = None):
    p = Path(path)
    src = str(p)
    if txt is None:
        txt = _Text(p, "MOT/STO file", 0)
    lines = txt.lines
    pairs, name, text, h = _parse_header(lines, src)
    for i in range(h + 1):
        if len(lines[i]) > MAX_HEADER_LINE:
            raise MocapFormatError(src, i + 1, f"header line of {len(lines[i]):,} characters (more than "
                                   f"{MAX_HEADER_LINE:,})")
    head = lines[h]
    tabbed = "\t" in head
    cols = [c.strip() for c in (head.split("\t") if tabbed else head.split())]
    while cols and not cols[-1]:
        cols.pop()
    if not cols or cols[0].lower() != "time":
        raise MocapFormatError(src, h + 1, f"the first column must be 'time', got {cols[0] if cols else ''!r}")
    if len(cols) < 2:
        raise MocapFormatError(src, h + 1, "no data column besides 'time'")
    for j, c in enumerate(cols):
        if not c:
            raise MocapFormatError(src, h + 1, f"column {j + 1} has no name")
    body = []
    for i in range(h + 1, len(lines)):
        ln = lines[i]
        if not ln.strip():
            continue
        cells = [c.strip() for c in (ln.split("\t") if tabbed else ln.split())]
        while len(cells) > len(cols) and not cells[-1]:
            cells.pop()
        if len(cells) != len(cols):
            cut = (", and the file ends in this line without a newline: it was cut short"
                   if i == len(lines) - 1 and not txt.ends_with_newline else "")
            raise MocapFormatError(src, i + 1, f"expected {len(cols)} cells like the column header on line "
                                   f"{h + 1}, found {len(cells)}{cut}")
        body.append((i + 1, cells))
    if not body:
        raise MocapFormatError(src, h + 1, "no data rows")
    warnings: list[str] = []
    if not txt.ends_with_newline:
        last = body[-1][1]
        prev = [c for _, c in body[-21:-1]]
        names = [f"column {j + 1} ({c})" for j, c in enumerate(cols)]
        if "," in "".join(last):  # orientation cells w,x,y,z: judge the components
            last = [x for c in last for x in c.split(",")]
            prev = [[x for c in r for x in c.split(",")] for r in prev]
            names = [f"column {j + 1} ({c}) {a}" for j, c in enumerate(cols) for a in ("wxyz" if j else "t")]
        _check_cut(prev, last, src, body[-1][0], names, warnings)
    for key, alt, found, what in (("nRows", "datarows", len(body), "data rows"),
                                  ("nColumns", "datacolumns", len(cols), "columns in the column header")):
        v = _get(pairs, key) or _get(pairs, alt)
        if v is None:
            continue
        n = _count(v)
        if n is None:
            warnings.append(f"{key} is {v[:40]!r}, not a count; ignored")
        elif n != found:
            warnings.append(f"{key} is {n} but the file has {found} {what}; the rows are read")
    return src, pairs, name, text, cols, body, warnings


def _in_degrees(pairs: dict, text: list[str]) -> bool | None:
    v = _get(pairs, "inDegrees")
    if v is not None:
        if v.lower() in ("yes", "true", "1"):
            return True
        if v.lower() in ("no", "false", "0"):
            return False
    joined = " ".join(text).lower()
    if "in degrees" in joined:
        return True
    if "in radians" in joined:
        return False
    return None


def _rate(pairs: dict) -> float | None:
    """``DataRate`` when it is a plain number in :data:`RATE_RANGE`, else ``None`` (the time column rules)."""
    v = (_get(pairs, "DataRate") or "").strip()
    try:
        r = parse_number(v, "", None, "DataRate")
    except MocapFormatError:
        return None
    return r if RATE_RANGE[0] <= r <= RATE_RANGE[1] else None


def _is_quaternion(pairs: dict) -> bool:
    return (_get(pairs, "DataType") or "").strip().lower() == "quaternion"


def read_table(path: str | Path, _txt: _Text | None = None) -> Signal:
    """Read a MOT/STO table of numbers (joint angles...) as one ``"vector"`` Signal (module doc)."""
    src, pairs, name, text, cols, body, warnings = _parse_table(path, _txt)
    if _is_quaternion(pairs):
        raise MocapFormatError(src, None, "DataType=Quaternion: read it with read_orientations")
    values = np.empty((len(body), len(cols)), dtype=np.float64)
    for r, (line, cells) in enumerate(body):
        for j, c in enumerate(cells):
            if c in _TRC_MISSING:
                raise MocapFormatError(src, line, f"column {j + 1} ({cols[j]}) is empty or NaN (a table "
                                       "signal cannot hold gaps)")
            values[r, j] = parse_number(c, src, line, f"column {j + 1} ({cols[j]})")
    times = values[:, 0]
    _check_times(times, src, [b[0] for b in body])
    deg = _in_degrees(pairs, text)
    meta = {
        "format": Path(src).suffix.lower().lstrip(".") or "sto",
        "labels": tuple(cols[1:]), "in_degrees": deg,
        "units": None if deg is None else ("deg" if deg else "rad"),
        "name": name, "header": dict(pairs), "header_text": text, "rate": _rate(pairs),
        "warnings": warnings,
    }
    try:
        return Signal(times, values[:, 1:], kind="vector", name=name or Path(src).stem, source=src, meta=meta)
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None


def read_orientations(path: str | Path, _txt: _Text | None = None) -> dict[str, Signal]:
    """Read an OpenSense orientation STO (``DataType=Quaternion``): ``{IMU name: quaternion Signal}``."""
    src, pairs, name, text, cols, body, warnings = _parse_table(path, _txt)
    if not _is_quaternion(pairs):
        raise MocapFormatError(src, None, "not an orientation file (the header has no DataType=Quaternion)")
    n, k = len(body), len(cols) - 1
    times = np.empty(n)
    q = np.empty((n, k, 4))
    for r, (line, cells) in enumerate(body):
        times[r] = _number(cells[0], src, line, "column 1 (time)")
        for j in range(k):
            parts = cells[j + 1].split(",")
            if len(parts) != 4:
                raise MocapFormatError(src, line, f"column {j + 2} ({cols[j + 1]}): expected 'w,x,y,z', "
                                       f"got {cells[j + 1][:60]!r}")
            for a in range(4):
                c = parts[a].strip()
                if c in _TRC_MISSING:
                    raise MocapFormatError(src, line, f"column {j + 2} ({cols[j + 1]}): empty or NaN component")
                q[r, j, a] = parse_number(c, src, line, f"column {j + 2} ({cols[j + 1]}) {'wxyz'[a]}")
    _check_times(times, src, [b[0] for b in body])
    if len(set(cols[1:])) != k:
        raise MocapFormatError(src, body[0][0] - 1, "IMU names in the column header are repeated")
    meta_base = {"format": "opensense-sto", "header": dict(pairs), "rate": _rate(pairs), "warnings": warnings}
    out: dict[str, Signal] = {}
    for j, imu in enumerate(cols[1:]):
        try:
            out[imu] = Signal(times, q[:, j], kind="quaternion", name=imu, source=src, meta=dict(meta_base))
        except InvalidSignalError as exc:
            raise MocapFormatError(src, None, f"{imu}: {exc}") from None
    return out


def read_opensim_signals(path: str | Path, *, rate: float | None = None) -> dict[str, Signal]:
    """``{name: Signal}`` of a MOT/STO file: the IMUs of an orientation file, else one table signal.

    ``rate`` is accepted for the reader-table signature and ignored (the file has a time column).
    """
    p = Path(path)
    txt = _Text(p, "MOT/STO file", 0)  # read once: a pipe cannot be read twice
    pairs, _, _, _ = _parse_header(txt.lines, str(p))
    if _is_quaternion(pairs):
        return read_orientations(p, txt)
    sig = read_table(p, txt)
    return {Path(p).stem: sig}


def table_kind(path: str | Path) -> str:
    """``"orientations"`` for a ``DataType=Quaternion`` STO, else ``"table"`` (reads the header only)."""
    p = Path(path)
    if not is_regular(p):  # a pipe would be consumed: read_opensim_signals tells them apart
        return "table"
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            for _ in range(200):
                ln = fh.readline(MAX_HEADER_LINE)
                if not ln or ln.strip().lower() == "endheader":
                    break
                k, _, v = ln.partition("=")
                if k.strip().lower() == "datatype" and v.strip().lower() == "quaternion":
                    return "orientations"
    except OSError:
        pass
    return "table"


def write_table(signal: Signal, path: str | Path, *, decimals: int | None = None,
                in_degrees: bool | None = None, name: str | None = None) -> None:
    """Write a ``"vector"`` Signal as an OpenSim MOT/STO table (version 1 header), atomically.

    Columns are ``meta["labels"]`` (else ``c1..cD``); ``inDegrees`` is ``in_degrees``, else
    ``meta["in_degrees"]``, and is left out when unknown. Numbers are ``repr`` (exact) or, with
    ``decimals``, fixed-point; times are always ``repr``.
    """
    if signal.kind != "vector":
        raise InvalidParameterError("write_table writes vector signals; quaternions go to write_orientations")
    d = signal.values.shape[1]
    labels = list(signal.meta.get("labels") or [f"c{k + 1}" for k in range(d)])
    if len(labels) != d:
        raise InvalidParameterError(f"{len(labels)} labels for {d} columns")
    for lab in labels:
        if not lab or any(ch in lab for ch in "\t\n\r"):
            raise InvalidParameterError(f"column name {lab!r} cannot be written to a tab-separated table")
    deg = signal.meta.get("in_degrees") if in_degrees is None else in_degrees
    title = name or signal.meta.get("name") or signal.name or Path(path).stem
    out = [title.replace("\n", " "), "version=1", f"nRows={len(signal)}", f"nColumns={d + 1}"]
    if deg is not None:
        out.append(f"inDegrees={'yes' if deg else 'no'}")
    out += ["endheader", "\t".join(["time"] + labels)]
    for t, row in zip(signal.times.tolist(), signal.values.tolist(), strict=True):
        out.append("\t".join([repr(t)] + [_fmt(v, decimals) for v in row]))
    atomic_write_text(path, "\n".join(out) + "\n")


def write_orientations(signals: dict[str, Signal], path: str | Path, *, rate: float | None = None,
                       decimals: int | None = None) -> None:
    """Write quaternion signals sharing one time base as an OpenSense orientation STO, atomically.

    Header ``DataRate`` (``rate``, else the mean rate), ``DataType=Quaternion``, ``version=3``,
    ``endheader``; then ``time<TAB><imu>...`` and one ``w,x,y,z`` cell per IMU.
    """
    if not signals:
        raise InvalidParameterError("no signals to write")
    items = list(signals.items())
    t = items[0][1].times
    for name, s in items:
        if s.kind != "quaternion":
            raise InvalidParameterError(f"{name}: only quaternion signals are written to an orientation file")
        if s.times.shape != t.shape or not np.array_equal(s.times, t):
            raise InvalidParameterError(f"{name}: every IMU must share the first one's times")
        if not name or any(ch in name for ch in "\t\n\r"):
            raise InvalidParameterError(f"IMU name {name!r} cannot be written to a tab-separated table")
    if rate is None:
        rate = (len(t) - 1) / float(t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else 1.0
    out = [f"DataRate={rate:.6f}", "DataType=Quaternion", "version=3", "endheader",
           "\t".join(["time"] + [n for n, _ in items])]
    vals = [s.values.tolist() for _, s in items]
    for i, ti in enumerate(t.tolist()):
        out.append("\t".join([repr(ti)] + [",".join(_fmt(v, decimals) for v in q[i]) for q in vals]))
    atomic_write_text(path, "\n".join(out) + "\n")


def write_table_csv(signals: dict[str, Signal], path: str | Path) -> None:
    """Write what :func:`read_opensim_signals` returns as a comma-separated table, atomically.

    One ``"vector"`` signal (a MOT/STO table) gives ``time`` and its ``meta["labels"]`` (else
    ``c1..cD``); quaternion signals (an orientation file) give ``time`` and ``<imu>_w, _x, _y, _z``
    per IMU. Numbers are written with ``repr`` (exact; a gap is ``nan``). Every signal must share the
    first one's times.
    """
    if not signals:
        raise InvalidParameterError("no signals to write")
    items = list(signals.items())
    first = items[0][1]
    if len(items) == 1 and first.kind == "vector":
        d = first.values.shape[1]
        head = list(first.meta.get("labels") or [f"c{k + 1}" for k in range(d)])
        if len(head) != d:
            raise InvalidParameterError(f"{len(head)} labels for {d} columns")
    elif all(s.kind == "quaternion" for _, s in items):
        head = [f"{n}_{c}" for n, _ in items for c in "wxyz"]
    else:
        raise InvalidParameterError("write_table_csv writes one vector signal or quaternion signals")
    for name, s in items:
        if s.times.shape != first.times.shape or not np.array_equal(s.times, first.times):
            raise InvalidParameterError(f"{name}: every signal must share the first one's times")
    for col in head:
        if not col or any(ch in col for ch in ',"\n\r'):
            raise InvalidParameterError(f"column name {col!r} cannot be written to a CSV header")
    body = np.column_stack([first.times] + [s.values for _, s in items])
    atomic_write_text(path, ",".join(["time", *head]) + "\n" + "".join(
        ",".join(repr(float(v)) for v in row) + "\n" for row in body))
