"""Where things are in an IMU export: preamble, header line, rows under the header, first data row,
the delimiter, the stated sample rate, and which columns hold time and orientation.

The header is the first line in which orientation columns are found (see
:mod:`mocapkit.io.imu.columns`). Lines before it are the preamble: blank lines, an Excel ``sep=X``
line, comments (``//``, ``#``), ``Key:,value`` metadata (read for a sample rate). Rows right
under the header with no number in their time and orientation cells (at most
:data:`MAX_DESCRIPTOR_ROWS`: units, ``CAL``/``RAW``) are read for the time unit and listed in the
warnings; a row with a date or text in another column (``Date``, ``loggingTime(txt)``) is data.
OptiTrack's and APDM ``Format=7``'s multi-row headers are handled by :mod:`mocapkit.io.imu.vendors`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from mocapkit.errors import MocapFormatError
from mocapkit.io.imu.columns import (
    ColumnOptions,
    Orientation,
    TimeColumn,
    choose_time,
    classify_time,
    find_column,
    find_orientations,
    is_descriptor_row,
    is_metadata_line,
    is_numeric_row,
    norm,
    parse_rate,
    parse_sep_line,
    rate_in_line,
    sniff_delimiter,
    split_fields,
)
from mocapkit.io.imu.vendors import apdm7_columns, is_apdm7, is_optitrack, optitrack_columns, vendor_label

__all__ = ["EXPECTED", "Layout", "MAX_DESCRIPTOR_ROWS", "find_layout"]

#: Rows between the header and the data that are read as units / channel-type rows.
MAX_DESCRIPTOR_ROWS = 3

#: What the reader looks for, for error messages.
EXPECTED = (
    "quaternion columns named w,x,y,z in any order (W X Y Z, W Element, Quat_W, qw, quaternion.w, "
    "<Sensor>/Orientation/Scalar X Y Z, ...) or numbered (q0..q3, Quat_q0..3, Element 1..4), a rotation "
    "matrix Mat[1][1]..Mat[3][3], or Roll/Pitch/Yaw (Xsens: also Euler_X/Y/Z); name them with "
    "--quaternion-columns W,X,Y,Z"
)


@dataclass
class Layout:
    """Everything the row parser needs (line indices are 0-based)."""

    fmt: str
    delim: str | None
    names: list[str]
    header_index: int
    data_index: int
    time: TimeColumn
    sensors: list[Orientation]
    rate: float | None
    file_rate: float | None = None
    rate_line: int | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def header_line(self) -> int:
        return self.header_index + 1


def _short(text: str, limit: int = 80) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


def _file_rate(lines: Sequence[str], preamble: Sequence[int], src: str) -> tuple[float | None, int | None]:
    rate = None
    rate_line = None
    for i in preamble:
        found = rate_in_line(lines[i])
        if found is None:
            continue
        key, value = found
        r = parse_rate(value)
        if r is None:
            raise MocapFormatError(src, i + 1, f"cannot read the sample rate {value!r} ({key}): "
                                   "expected a number of Hz from 1e-06 to 1e+09")
        if rate is not None and r != rate:
            raise MocapFormatError(src, i + 1, f"sample rate {r:g} Hz contradicts {rate:g} Hz on line {rate_line}")
        rate, rate_line = r, i + 1
    return rate, rate_line


def _is_xsens(names: Sequence[str], lines: Sequence[str], preamble: Sequence[int]) -> bool:
    low = [norm(n) for n in names]
    return ("packetcounter" in low or "sampletimefine" in low or any(n.startswith(("acc_", "quat_")) for n in low)
            or any(lines[i].lstrip().startswith("//") for i in preamble))


def _key_columns(names: Sequence[str], sensors: Sequence[Orientation], opts: ColumnOptions) -> list[int]:
    """The orientation columns and the possible time columns (by name, or the one given)."""
    cols = [c for o in sensors for c in o.cols]
    if opts.time_column is not None:
        t = find_column(names, opts.time_column)
        return cols + ([t] if t is not None else [])
    return cols + [i for i, n in enumerate(names) if classify_time(n) is not None]


def find_layout(lines: Sequence[str], end: int, src: str, rate: float | None,
                opts: ColumnOptions, probe: bool = False) -> Layout:
    """Read the layout of ``lines[:end]`` (``end`` excludes trailing blank lines).

    ``probe=True`` only recognises the header (no data row or sample rate required).
    """
    i = 0
    sep: str | None = None
    seen = False
    preamble: list[int] = []
    last_text: int | None = None
    header: int | None = None
    sensors: list[Orientation] = []
    names: list[str] = []
    delim: str | None = None
    optitrack = False
    warnings: list[str] = []
    file_rate = None
    while i < end:
        raw = lines[i]
        if not raw.strip():
            i += 1
            continue
        if not seen:
            seen = True
            d = parse_sep_line(raw)
            if d is not None:
                sep = d
                preamble.append(i)
                i += 1
                continue
            if is_optitrack(raw):
                axis, names, sensors, file_rate, warnings = optitrack_columns(lines, i, end, src, opts)
                preamble.append(i)
                header, delim, optitrack = axis, ",", True
                break
            if is_apdm7(raw):
                header, names, sensors, warnings = apdm7_columns(lines, i, end, src, opts)
                preamble.append(i)
                delim = ","
                break
        d = sep if sep is not None else sniff_delimiter(raw)
        fields = split_fields(raw, d)
        if is_metadata_line(fields, raw):
            preamble.append(i)
            i += 1
            continue
        if is_numeric_row(fields):
            if last_text is not None:
                raise MocapFormatError(
                    src, last_text + 1, f"no orientation columns in the header {_short(lines[last_text].strip())}; "
                    f"looked for {EXPECTED}",
                )
            raise MocapFormatError(src, i + 1, f"data before any header line {_short(raw.strip())}; expected a "
                                   f"header with {EXPECTED}")
        names = [f.strip() for f in fields]
        sensors = find_orientations(names, opts, src, i + 1, xsens=_is_xsens(names, lines, preamble))
        if sensors:
            header, delim = i, d
            break
        preamble.append(i)
        last_text = i
        i += 1
    if header is None:
        if end == 0:
            raise MocapFormatError(src, 1, "empty file (expected a header line such as 'Timestamp (us),W,X,Y,Z')")
        if last_text is not None:
            if opts.quaternion_columns is not None:
                raise MocapFormatError(src, last_text + 1, f"no header line with the columns "
                                       f"{', '.join(opts.quaternion_columns)} (--quaternion-columns)")
            raise MocapFormatError(src, last_text + 1, f"no orientation columns in the header "
                                   f"{_short(lines[last_text].strip())}; looked for {EXPECTED}")
        raise MocapFormatError(src, end, "only comment or metadata lines: no header line and no data")

    # rows under the header: units / channel-type rows have no number in the time and orientation
    # cells (a first column holding a date or text does not make a data row a units row)
    key_cols = _key_columns(names, sensors, opts)
    descriptors: list[list[str]] = []
    j = header + 1
    while j < end and lines[j].strip() and len(descriptors) < MAX_DESCRIPTOR_ROWS:
        f = split_fields(lines[j], delim)
        if not is_descriptor_row(f, key_cols):
            break
        descriptors.append([x.strip() for x in f])
        warnings.append(f"line {j + 1} read as a units row, not data (no number in the time and orientation "
                        f"columns): {_short(lines[j].strip())}")
        j += 1
    if j >= end and not probe:
        raise MocapFormatError(src, header + 1, "header only: no data rows after the header")
    first_row = split_fields(lines[j], delim) if j < end else []

    mt_manager = any(lines[k].lstrip().startswith("//") for k in preamble)
    time = choose_time(names, first_row, descriptors, opts, src, header + 1, mt_manager)
    if optitrack and time.col is not None and time.unit is None:
        time.unit = "s"
    if not optitrack:
        file_rate, rate_line = _file_rate(lines, preamble, src)
    else:
        rate_line = preamble[0] + 1
    if time.note:
        warnings.append(f"column {time.name!r}: {time.note}; override with --time-unit")

    if probe:
        eff = file_rate if file_rate is not None else rate
    elif time.unit in ("counter", None):
        if file_rate is not None and rate is not None and file_rate != rate:
            raise MocapFormatError(
                src, rate_line, f"the file's sample rate is {file_rate:g} Hz but a rate of {rate:g} Hz was given; "
                "drop --rate or correct the file",
            )
        eff = file_rate if file_rate is not None else rate
        if eff is None:
            what = (f"the counter column {time.name!r} counts samples" if time.col is not None
                    else f"no time column found (columns: {', '.join(repr(n) for n in names[:20])})")
            raise MocapFormatError(
                src, header + 1, f"{what} and the file states no sample rate: pass the sample rate with "
                "--rate HZ (or name a time column with --time-column NAME)",
            )
    else:
        if rate is not None:
            raise MocapFormatError(
                src, header + 1, f"this file has its own timestamps (column {time.name!r}); a sample rate "
                f"({rate:g} Hz) must not be given",
            )
        eff = file_rate
    fmt = vendor_label(names, [lines[k] for k in preamble], sensors, optitrack)
    return Layout(fmt, delim, names, header, j, time, sensors, eff, file_rate, rate_line, warnings)
