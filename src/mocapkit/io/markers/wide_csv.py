"""The wide marker CSV: :func:`write_markers_csv` writes a :class:`~mocapkit.markers.Markers` as one row a
frame, :func:`read_markers_csv` reads it back bit-exactly.

Layout: ``time (s),<label>_x (<units>),<label>_y (<units>),<label>_z (<units>),...``; numbers as
``repr(float)``; a missing marker is ``nan`` in its three cells; header cells holding a comma or a quote
are quoted as per RFC 4180; line ends ``\\n``. :func:`mocapkit.io.loaders.load_markers` sends a ``.csv``
that is not a Vicon Nexus export here, and :func:`mocapkit.io.loaders.write_markers` a ``.csv`` output.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.atomic import atomic_write_text
from mocapkit.io.text.input import check_cells_budget, final_line_verdict, read_input, report_final_line
from mocapkit.io.text.numbers import parse_number
from mocapkit.markers import Markers

__all__ = ["marker_csv_header", "read_markers_csv", "write_markers_csv"]

_AXES = ("x", "y", "z")
_UNIT_RE = re.compile(r"^(.*_[xyzXYZ])\s*\(([^()]+)\)$")  # "<label>_x (mm)"
_MISSING = ("", "nan", "NaN")  # the wide CSV's missing coordinate (write_markers_csv writes "nan")


def marker_csv_header(markers: Markers) -> list[str]:
    """Column names of the wide CSV: ``time (s)`` then ``<label>_x (<units>)``, ``_y``, ``_z``..."""
    return ["time (s)"] + [f"{lab}_{ax} ({markers.units})" for lab in markers.labels for ax in _AXES]


def write_markers_csv(markers: Markers, path: str | Path) -> None:
    """Write a wide CSV atomically: ``time (s),<label>_x (mm),<label>_y (mm),...`` (one row a frame;
    the length unit is part of every coordinate's name, so it survives the round trip).

    Numbers are written as ``repr(float)`` (shortest text that reads back bit-exactly); a missing
    marker is written as ``nan`` in its three cells (``float("nan")``, numpy and pandas all read
    it back as NaN). Header cells holding a comma or a quote are quoted as per RFC 4180. Line ends
    are ``\\n``. :func:`read_markers_csv` reads the file back.
    """
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(marker_csv_header(markers))
    flat = markers.positions.reshape(markers.n_frames, -1)
    rows = [buf.getvalue()]
    for t, row in zip(markers.times.tolist(), flat.tolist(), strict=True):
        rows.append(",".join([repr(t)] + [repr(v) for v in row]))
        rows.append("\n")
    atomic_write_text(path, "".join(rows))


def read_markers_csv(path: str | Path, rate: float | None = None, units: str | None = None) -> Markers:
    """Read a wide marker CSV as written by :func:`write_markers_csv`.

    The header must be ``time`` (or ``time (s)``) followed by ``<label>_x, <label>_y, <label>_z``
    triples, each optionally with its unit, ``<label>_x (mm)``. ``nan`` (or an empty cell) is a missing
    coordinate. ``rate`` defaults to the mean rate ``(N - 1) / (t[-1] - t[0])`` (1 Hz for a single
    frame): pass it when you know it. The length unit is the header's; ``units`` gives it for a file
    that does not state it (default ``"mm"``, recorded as an assumption in ``meta["warnings"]``) and
    must agree with the header when both exist.

    Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers` (``nan``/``NaN``/empty are the
    only missing spellings; ``inf``, ``0_5`` and ``|value| > 1e12`` are errors naming line and column).
    A last line written without a newline whose last value has fewer decimals than that column on
    the rows before it is an error (the file was cut short); when that cannot be told (``repr``
    numbers vary in length) the row is read with a warning. Pipes are read in bounded chunks.
    """
    p = Path(path)
    src = str(p)
    data = read_input(p, "CSV file")
    ends_with_newline = data.endswith((b"\n", b"\r"))
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise MocapFormatError(src, line, "not UTF-8 text") from None
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in text.split("\n")]
    while lines and not lines[-1].strip():
        lines.pop()
        ends_with_newline = True
    if not lines:
        raise MocapFormatError(src, 1, "empty file (expected a header 'time,<label>_x,...')")
    try:
        header = next(csv.reader([lines[0]]))
    except csv.Error as exc:
        raise MocapFormatError(src, 1, f"cannot parse the header: {exc}") from None
    header = [h.strip() for h in header]
    if header and header[0].lower() in ("time (s)", "time(s)"):
        header[0] = "time"
    if not header or header[0].lower() != "time":
        raise MocapFormatError(src, 1, f"the first column must be 'time', got {header[0] if header else ''!r}")
    if (len(header) - 1) % 3:
        raise MocapFormatError(src, 1, f"{len(header) - 1} coordinate columns is not a multiple of 3")
    stated = []
    for j in range(1, len(header)):
        m = _UNIT_RE.match(header[j])
        if m:
            header[j] = m.group(1).rstrip()
            stated.append(m.group(2).strip())
    if stated and len(stated) != len(header) - 1:
        raise MocapFormatError(src, 1, "some coordinate columns state a unit, e.g. '(mm)', and others do not")
    if len(set(stated)) > 1:
        raise MocapFormatError(src, 1, f"the coordinate columns state different units: {sorted(set(stated))}")
    warnings = []
    if stated:
        if units is not None and units != stated[0]:
            raise MocapFormatError(src, 1, f"the header says the unit is {stated[0]!r}, but {units!r} was given")
        units = stated[0]
    elif units is None:
        units = "mm"
        warnings.append("the header states no length unit; mm assumed")
    labels = []
    for j in range(1, len(header), 3):
        trio = header[j:j + 3]
        stems = []
        for h, ax in zip(trio, _AXES, strict=False):
            if not h.lower().endswith("_" + ax):
                raise MocapFormatError(src, 1, f"column {j + _AXES.index(ax) + 1} ({h!r}) should end in '_{ax}'")
            stems.append(h[:-2])
        if len(set(stems)) != 1:
            raise MocapFormatError(src, 1, f"columns {j + 1}-{j + 3} ({', '.join(trio)}) are not one marker's x, y, z")
        labels.append(stems[0])
    ncol = len(header)
    check_cells_budget(src, 1, (len(lines) - 1) * ncol, len(data), f"{len(lines) - 1} rows of {ncol} columns")
    values = np.empty((len(lines) - 1, ncol), dtype=np.float64)
    fields = [f"column {j + 1} ({h})" for j, h in enumerate(header)]
    last = len(lines) - 2
    for i, ln in enumerate(lines[1:]):
        cells = ln.split(",")
        if len(cells) != ncol:
            cut = (" (the file ends in this line without a newline: it was cut short)"
                   if i == last and not ends_with_newline else "")
            raise MocapFormatError(src, i + 2, f"expected {ncol} comma-separated values, found {len(cells)}{cut}")
        if i == last and not ends_with_newline:
            verdict, col = final_line_verdict([r.split(",") for r in lines[max(1, i - 19):i + 1]], cells)
            report_final_line(src, i + 2, verdict, col, fields[col] if col is not None else "the last value",
                              cells[col] if col is not None else "", warnings)
        for j, c in enumerate(cells):
            values[i, j] = parse_number(c.strip(), src, i + 2, fields[j], missing=_MISSING)
    if values.shape[0] == 0:
        raise MocapFormatError(src, 1, "no data rows")
    times = values[:, 0]
    if np.isnan(times).any():
        raise MocapFormatError(src, int(np.flatnonzero(np.isnan(times))[0]) + 2, "missing time")
    if rate is None:
        span = float(times[-1] - times[0]) if len(times) > 1 else 0.0
        rate = (len(times) - 1) / span if span > 0 else 1.0
    try:
        return Markers(times, values[:, 1:].reshape(len(times), -1, 3), tuple(labels), rate,
                       units=units, source=src, meta={"format": "csv", "warnings": warnings})
    except InvalidSignalError as exc:
        raise MocapFormatError(src, None, str(exc)) from None
