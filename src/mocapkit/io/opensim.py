"""OpenSim text files: TRC marker trajectories and MOT/STO tables (joint angles, OpenSense orientations).

TRC (``PathFileType 4``)
------------------------
Line 1 ``PathFileType<TAB>4<TAB>(X/Y/Z)<TAB><name>``, line 2 the header keys (``DataRate``,
``CameraRate``, ``NumFrames``, ``NumMarkers``, ``Units``, ``OrigDataRate``, ``OrigDataStartFrame``,
``OrigNumFrames``), line 3 their values, line 4 ``Frame#<TAB>Time<TAB>M1<TAB><TAB><TAB>M2...``, line 5
``<TAB><TAB>X1<TAB>Y1<TAB>Z1<TAB>X2...``, then (after an optional blank line) one row per frame.
:func:`read_trc` follows the rows, not the header, where real files disagree with it:

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
and ``.mot`` in :data:`mocapkit.io.imucsv.READERS`). :func:`write_table` and
:func:`write_orientations` write them back (numbers as ``repr`` unless ``decimals`` is given).
``nRows``/``nColumns`` disagreeing with the rows are recorded in ``meta["warnings"]``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError
from mocapkit.io.atomic import atomic_write_text, read_text_lines
from mocapkit.motion import Signal

if TYPE_CHECKING:  # the model is imported lazily (mocapkit.markers imports mocapkit.io)
    from mocapkit.markers import Markers

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


def _lines(path: Path, what: str) -> tuple[list[str], str]:
    """Lines of a text file (BOM dropped, CR/LF handled), decoded as UTF-8 or else Latin-1."""
    return read_text_lines(path, what)


def _number(cell: str, src: str, line: int, what: str) -> float:
    c = cell.strip()
    if not c:
        return math.nan
    try:
        v = float(c)
    except ValueError:
        raise MocapFormatError(src, line, f"{what}: {c[:40]!r} is not a number") from None
    if math.isinf(v):
        raise MocapFormatError(src, line, f"{what}: {c!r} is infinite")
    return v


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


def read_trc(path: str | Path) -> Markers:
    """Read an OpenSim TRC marker file into :class:`mocapkit.markers.Markers` (see the module doc)."""
    from mocapkit.markers import Markers, make_unique_labels

    p = Path(path)
    src = str(p)
    lines, enc = _lines(p, "TRC file")
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines or not lines[0].split("\t")[0].strip().lower().startswith("pathfiletype"):
        raise MocapFormatError(src, 1, "not a TRC file (the first line must start with 'PathFileType')")
    if len(lines) < 5:
        raise MocapFormatError(src, len(lines) or 1, "the TRC header needs 5 lines (PathFileType, keys, "
                               "values, marker names, coordinate names)")
    keys = [k.strip() for k in lines[1].split("\t")]
    vals = [v.strip() for v in lines[2].split("\t")]
    header = {k: (vals[i] if i < len(vals) else "") for i, k in enumerate(keys) if k}
    low = {k.lower(): v for k, v in header.items()}
    warnings: list[str] = []

    def num(key: str, integer: bool = False):
        v = low.get(key.lower(), "")
        if v == "":
            return None
        try:
            x = float(v)
        except ValueError:
            raise MocapFormatError(src, 3, f"{key} {v!r} is not a number") from None
        if integer and x != int(x):
            raise MocapFormatError(src, 3, f"{key} {v!r} is not an integer")
        return int(x) if integer else x

    rate = num("DataRate")
    if rate is None:
        rate = num("CameraRate")
    if rate is None:
        raise MocapFormatError(src, 2, "no DataRate (or CameraRate) in the header")
    if not (math.isfinite(rate) and rate > 0):
        raise MocapFormatError(src, 3, f"DataRate must be > 0, got {rate!r}")
    units = low.get("units", "")
    meta: dict = {"format": "trc", "header": header, "encoding": enc}
    if not units:
        units = "mm"
        meta["units_assumed"] = True
        warnings.append("no Units in the header: millimetres assumed")
    n_frames_decl = num("NumFrames", integer=True)
    n_markers_decl = num("NumMarkers", integer=True)

    names = lines[3].split("\t")
    if len(names) < 2 or names[0].strip().lower() != "frame#" or names[1].strip().lower() != "time":
        raise MocapFormatError(src, 4, "line 4 must start with 'Frame#<TAB>Time' followed by the marker names")
    raw_labels = [c.strip() for c in names[2:] if c.strip()]
    m = len(raw_labels)
    if n_markers_decl is not None and n_markers_decl != m:
        warnings.append(f"NumMarkers is {n_markers_decl} but line 4 names {m} markers; {m} read")
    coords = [c.strip() for c in lines[4].split("\t") if c.strip()]
    if len(coords) != 3 * m:
        raise MocapFormatError(src, 5, f"expected {3 * m} coordinate names (X1 Y1 Z1 ... for {m} markers), "
                               f"found {len(coords)}")
    for j, c in enumerate(coords):
        if c[:1].upper() != "XYZ"[j % 3]:
            raise MocapFormatError(src, 5, f"coordinate name {j + 1} is {c!r}, expected {'XYZ'[j % 3]}{j // 3 + 1}")

    width = 2 + 3 * m
    rows: list[list[float]] = []
    row_lines: list[int] = []
    short = 0
    for i in range(5, len(lines)):
        ln = lines[i]
        if not ln.strip():
            continue
        cells = ln.split("\t")
        if len(cells) > width:
            extra = cells[width:]
            if any(c.strip() for c in extra):
                raise MocapFormatError(src, i + 1, f"expected {width} tab-separated cells (Frame#, Time and "
                                       f"{m} x 3 coordinates), found {len(cells)}")
            cells = cells[:width]
        elif len(cells) < width:
            if len(cells) < 2:
                raise MocapFormatError(src, i + 1, "a data row needs at least Frame# and Time")
            short += 1
            cells = cells + [""] * (width - len(cells))
        row = [_number(cells[0], src, i + 1, "Frame#"), _number(cells[1], src, i + 1, "Time")]
        for j in range(2, width):
            row.append(_number(cells[j], src, i + 1, f"column {j + 1} ({raw_labels[(j - 2) // 3]} "
                               f"{'XYZ'[(j - 2) % 3]})"))
        rows.append(row)
        row_lines.append(i + 1)
    if not rows:
        raise MocapFormatError(src, len(lines), "no data rows")
    data = np.asarray(rows, dtype=np.float64)
    times = data[:, 1]
    _check_times(times, src, row_lines)
    if short:
        warnings.append(f"{short} rows have fewer cells than {width}: the missing cells are read as gaps")
    if n_frames_decl is not None and n_frames_decl != len(rows):
        warnings.append(f"NumFrames is {n_frames_decl} but the file has {len(rows)} data rows "
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
        return Markers(times, data[:, 2:].reshape(len(rows), m, 3), labels, rate, units=units,
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
    for f, t, row in zip(frames, markers.times.tolist(), flat.tolist()):
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


def _parse_table(path: str | Path):
    p = Path(path)
    src = str(p)
    lines, _ = _lines(p, "MOT/STO file")
    while lines and not lines[-1].strip():
        lines.pop()
    pairs, name, text, h = _parse_header(lines, src)
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
            raise MocapFormatError(src, i + 1, f"expected {len(cols)} cells like the column header on line "
                                   f"{h + 1}, found {len(cells)}")
        body.append((i + 1, cells))
    if not body:
        raise MocapFormatError(src, h + 1, "no data rows")
    warnings: list[str] = []
    nrows = _get(pairs, "nRows") or _get(pairs, "datarows")
    if nrows is not None and nrows.strip().lstrip("-").isdigit() and int(nrows) != len(body):
        warnings.append(f"nRows is {nrows} but the file has {len(body)} data rows; the rows are read")
    ncols = _get(pairs, "nColumns") or _get(pairs, "datacolumns")
    if ncols is not None and ncols.strip().lstrip("-").isdigit() and int(ncols) != len(cols):
        warnings.append(f"nColumns is {ncols} but the column header has {len(cols)} columns")
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
    v = _get(pairs, "DataRate")
    try:
        r = float(v) if v is not None else None
    except ValueError:
        return None
    return r if r is not None and math.isfinite(r) and r > 0 else None


def _is_quaternion(pairs: dict) -> bool:
    return (_get(pairs, "DataType") or "").strip().lower() == "quaternion"


def read_table(path: str | Path) -> Signal:
    """Read a MOT/STO table of numbers (joint angles...) as one ``"vector"`` Signal (module doc)."""
    src, pairs, name, text, cols, body, warnings = _parse_table(path)
    if _is_quaternion(pairs):
        raise MocapFormatError(src, None, "DataType=Quaternion: read it with read_orientations")
    values = np.empty((len(body), len(cols)), dtype=np.float64)
    for r, (line, cells) in enumerate(body):
        for j, c in enumerate(cells):
            v = _number(c, src, line, f"column {j + 1} ({cols[j]})")
            if math.isnan(v):
                raise MocapFormatError(src, line, f"column {j + 1} ({cols[j]}) is empty or NaN (a table "
                                       "signal cannot hold gaps)")
            values[r, j] = v
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


def read_orientations(path: str | Path) -> dict[str, Signal]:
    """Read an OpenSense orientation STO (``DataType=Quaternion``): ``{IMU name: quaternion Signal}``."""
    src, pairs, name, text, cols, body, warnings = _parse_table(path)
    if not _is_quaternion(pairs):
        raise MocapFormatError(src, None, "not an orientation file (the header has no DataType=Quaternion)")
    n, k = len(body), len(cols) - 1
    times = np.empty(n)
    q = np.empty((n, k, 4))
    for r, (line, cells) in enumerate(body):
        times[r] = _number(cells[0], src, line, "time")
        for j in range(k):
            parts = cells[j + 1].split(",")
            if len(parts) != 4:
                raise MocapFormatError(src, line, f"column {j + 2} ({cols[j + 1]}): expected 'w,x,y,z', "
                                       f"got {cells[j + 1][:60]!r}")
            for a in range(4):
                v = _number(parts[a], src, line, f"column {j + 2} ({cols[j + 1]})")
                if math.isnan(v):
                    raise MocapFormatError(src, line, f"column {j + 2} ({cols[j + 1]}): empty or NaN component")
                q[r, j, a] = v
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
    lines, _ = _lines(p, "MOT/STO file")
    pairs, _, _, _ = _parse_header(lines, str(p))
    if _is_quaternion(pairs):
        return read_orientations(p)
    sig = read_table(p)
    return {Path(p).stem: sig}


def table_kind(path: str | Path) -> str:
    """``"orientations"`` for a ``DataType=Quaternion`` STO, else ``"table"`` (reads the header only)."""
    p = Path(path)
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            for _ in range(200):
                ln = fh.readline()
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
    for t, row in zip(signal.times.tolist(), signal.values.tolist()):
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
