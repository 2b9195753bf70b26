"""Read Qualisys Track Manager (QTM) 3-D TSV exports into :class:`mocapkit.markers.Markers`.

Layout of the file (tab-separated, one field a cell)::

    NO_OF_FRAMES	4967
    NO_OF_CAMERAS	4
    NO_OF_MARKERS	24
    FREQUENCY	300
    NO_OF_ANALOG	0
    ANALOG_FREQUENCY	0
    DESCRIPTION	--
    TIME_STAMP	2024-12-12, 16:25:26.188	56373.87175403
    DATA_INCLUDED	3D
    MARKER_NAMES	base_1	base_2	...	(empty names: unnamed trajectories)
    TRAJECTORY_TYPES	Measured	Mixed	...
    Frame	Time	base_1 X	base_1 Y	base_1 Z	...	 X	 Y	 Z
    1	0.00000	228.117	-404.129	-672.697	...

* Header lines are ``KEY<TAB>value...`` with an upper-case ``KEY``; all of them are kept, as lists of
  strings, in ``meta["header"]`` (``EVENT`` lines, which may repeat, in ``meta["events"]``) and their
  line numbers in ``meta["header_lines"]``. Required: ``NO_OF_FRAMES``, ``NO_OF_MARKERS``,
  ``FREQUENCY`` (a number: an external time base, ``EXT``, is refused) and ``MARKER_NAMES``;
  ``DATA_INCLUDED``, when present, must be ``3D``. Known numeric fields are also given typed in
  ``meta["qtm"]``.
* The column header line (``Frame``, ``Time``, then ``<name> X/Y/Z`` per marker) is optional; without
  it, data rows have either ``3 * NO_OF_MARKERS`` values (no frame/time columns: times are
  ``arange(N) / FREQUENCY``) or two more (frame and time).
* Marker names: ``MARKER_NAMES`` (trailing empty names beyond ``NO_OF_MARKERS`` are ignored, too few
  are padded with empty names, recorded as ``meta["marker_names_padded"]``); the column header must
  agree with them. Empty and repeated names are made unique by
  :func:`mocapkit.markers.make_unique_labels` (``unnamed_6``, ``RASI_2``...), recorded in
  ``meta["label_fixes"]``.
* Missing markers: QTM writes a marker it did not see as ``0.000 0.000 0.000``; a marker whose three
  coordinates are all exactly 0 is therefore missing (``NaN``), and so is a marker whose three cells
  are empty (nothing else can be meant). One or two empty coordinates, an empty frame or time cell,
  and any other spelling (``nan``, ``inf``...) are errors.
* Numbers follow the strict grammar of :mod:`mocapkit.io.text.numbers` (no ``0_5``); ``|value| >
  MAX_ABS`` (1e12) is refused. Errors name the line and the field (``Frame``, ``Time`` or
  ``<marker> X/Y/Z``).
* ``times`` come from the ``Time`` column as written (QTM rounds it, e.g. to 1e-5 s); each is checked
  against its frame number: ``t - t_first`` must equal ``(frame - frame_first) / FREQUENCY`` within
  the rounding of the column (at most half a frame period). Frame numbers must be strictly increasing
  integers; gaps are allowed and counted in ``meta["frame_gaps"]``. The frame numbers are kept in
  ``meta["frame_numbers"]``.
* ``units`` are ``"mm"`` (QTM always exports millimetres); ``analog`` is ``None`` (QTM writes analog
  data to a separate ``_a.tsv`` file; ``NO_OF_ANALOG`` is kept in the header).

Errors: every malformed input raises :class:`mocapkit.errors.MocapFormatError` with the path, the
1-based line and the problem (wrong number of columns, not a number, header field missing or invalid,
column header disagreeing with ``MARKER_NAMES``, times disagreeing with frame numbers...).
``NO_OF_FRAMES`` must equal the number of data rows with ``strict=True`` (the default); with
``strict=False`` a disagreement is accepted and recorded as ``meta["frame_count_mismatch"] =
{"declared": ..., "rows": ...}``, and so is a time/frame disagreement
(``meta["time_mismatch"]``). Text may be UTF-8 (with or without BOM) or, failing that, Latin-1;
line ends may be LF or CRLF, the final newline may be missing and trailing tabs are ignored.

Damaged and hostile files (all errors, before any large allocation):

* header counts are checked against the file: ``NO_OF_MARKERS`` larger than the file's size (a row
  needs 3 values a marker) is refused before anything is allocated; ``NO_OF_FRAMES``,
  ``NO_OF_CAMERAS`` and ``NO_OF_ANALOG`` only size nothing (more than 18 digits is refused);
  ``FREQUENCY`` must lie in [1e-6, 1e9] Hz; a header line longer than 1 MiB is refused;
* a file that ends without a newline and whose last line has another number of values than the
  line before, or whose last value has fewer decimals than the same column on the rows before it (a
  file cut in the middle of ``-0.124044`` leaves ``-0``), is an error naming the line and field: the
  file was cut short and its last row cannot be trusted (delete that line to read the rest). When
  the column's decimals vary so that a cut cannot be told, the row is read with a warning
  (``meta["warnings"]`` and :class:`~mocapkit.errors.MocapWarning`);
* a pipe or device is read in bounded chunks and a NUL byte is refused
  (:mod:`mocapkit.io.text.input`).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.text.input import MAX_HEADER_LINE, decode_text, final_line_verdict, read_input, report_final_line
from mocapkit.io.text.numbers import MAX_ABS, parse_number
from mocapkit.markers import Markers, make_unique_labels

__all__ = ["read_qtm_tsv", "read_qtm_tsv_text", "REQUIRED_FIELDS"]

#: Header fields a 3-D TSV export must have.
REQUIRED_FIELDS = ("NO_OF_FRAMES", "NO_OF_MARKERS", "FREQUENCY", "MARKER_NAMES")

_KEY_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")
_INT_FIELDS = ("NO_OF_FRAMES", "NO_OF_CAMERAS", "NO_OF_MARKERS", "NO_OF_ANALOG")
_FLOAT_FIELDS = ("FREQUENCY", "ANALOG_FREQUENCY")
_SINGLE_FIELDS = _INT_FIELDS + _FLOAT_FIELDS + ("DATA_INCLUDED",)
_INT_RE = re.compile(r"^[+]?\d{1,18}$", re.ASCII)
_NUM_RE = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$", re.ASCII)
_NOT_NUMERIC = re.compile(r"[^0-9eE.+\-\t ]")  # a data line holding anything else has a bad value
_AXES = ("X", "Y", "Z")
#: Range accepted for FREQUENCY (Hz).
RATE_RANGE = (1e-6, 1e9)


def _short(text: str, limit: int = 40) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


def read_qtm_tsv(path: str | Path, *, strict: bool = True) -> Markers:
    """Read a QTM 3-D TSV export (see the module docstring for the rules)."""
    p = Path(path)
    src = str(p)
    data = read_input(p, "TSV file")
    text, encoding = decode_text(data)
    return _Parser(text, src, strict, encoding).parse()


def read_qtm_tsv_text(text: str, source: str = "<text>", *, strict: bool = True) -> Markers:
    """Parse the text of a QTM 3-D TSV export; ``source`` labels it in messages."""
    return _Parser(text, str(source), strict, "text").parse()


class _Parser:
    def __init__(self, text: str, src: str, strict: bool, encoding: str):
        if text.startswith("\ufeff"):
            text = text[1:]
        self.size = len(text)
        self.ends_with_newline = text.endswith(("\n", "\r")) or not text.strip()
        lines = text.split("\n")
        self.lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
        while self.lines and not self.lines[-1].strip():
            self.ends_with_newline = True  # blank lines after the last row: it is complete
            self.lines.pop()
        self.src = src
        self.strict = strict
        self.encoding = encoding

    def err(self, idx: int | None, problem: str) -> MocapFormatError:
        """Error at 0-based line ``idx``."""
        return MocapFormatError(self.src, None if idx is None else idx + 1, problem)

    # ---------------------------------------------------------------------------------------------

    def parse(self) -> Markers:
        lines = self.lines
        if not lines:
            raise self.err(0, "empty file (expected QTM header lines such as 'NO_OF_FRAMES<TAB>...')")

        header: dict[str, list[str]] = {}
        header_lines: dict[str, int] = {}
        events: list[dict] = []
        i = 0
        while i < len(lines):
            line = lines[i]
            fields = line.split("\t", 1) if len(line) > MAX_HEADER_LINE else line.split("\t")
            key = fields[0].strip()
            if not line.strip():
                raise self.err(i, "empty line in the header")
            if not _KEY_RE.match(key):
                break
            if len(line) > MAX_HEADER_LINE:
                raise self.err(i, f"header line {key} is {len(line):,} characters long (more than "
                                  f"{MAX_HEADER_LINE:,}): not a QTM export")
            cells = [f.strip() for f in fields[1:]]
            if key == "EVENT":
                vals = [v for v in cells if v] if len(cells) > 3 else cells
                if len(vals) < 3:
                    raise self.err(i, f"EVENT needs a name, a frame and a time, got {len(vals)} values")
                if not _INT_RE.match(vals[1]):
                    raise self.err(i, f"EVENT frame {_short(vals[1])} is not a frame number")
                ev_frame = int(vals[1])
                ev_time = parse_number(vals[2], self.src, i + 1, "EVENT time")
                events.append({"name": vals[0], "frame": ev_frame, "time": ev_time, "line": i + 1})
            else:
                if key in header:
                    raise self.err(i, f"header field {key} is repeated (first on line {header_lines[key] + 1})")
                header[key] = cells
                header_lines[key] = i
            i += 1
        end_header = i
        if not header and not events:
            raise self.err(0, f"not a QTM TSV export: the first line starts with {_short(lines[0].split(chr(9))[0])}, "
                              "expected a header field such as NO_OF_FRAMES")
        for key in REQUIRED_FIELDS:
            if key not in header:
                raise self.err(min(end_header, len(lines) - 1),
                               f"header field {key} is missing (the header ends before line {end_header + 1})")

        qtm: dict = {}
        for key in _SINGLE_FIELDS:
            if key not in header:
                continue
            vals = header[key]
            while vals and not vals[-1]:
                vals = vals[:-1]
            if len(vals) != 1:
                raise self.err(header_lines[key], f"header field {key} needs exactly one value, got {len(vals)}")
            v = vals[0]
            if key in _INT_FIELDS:
                if not _INT_RE.match(v):
                    raise self.err(header_lines[key], f"{key} must be a non-negative integer, got {_short(v)}")
                qtm[key] = int(v)
            elif key in _FLOAT_FIELDS:
                if not _NUM_RE.match(v) or not math.isfinite(float(v)) or float(v) < 0 or float(v) > RATE_RANGE[1]:
                    extra = " (an external time base, EXT, is not supported)" if v.upper() == "EXT" else ""
                    raise self.err(header_lines[key], f"{key} must be a non-negative number (at most "
                                                      f"{RATE_RANGE[1]:g}), got {_short(v)}{extra}")
                qtm[key] = float(v)
            else:
                qtm[key] = v
        rate = qtm["FREQUENCY"]
        if not rate >= RATE_RANGE[0]:
            raise self.err(header_lines["FREQUENCY"], f"FREQUENCY must be > 0 (at least {RATE_RANGE[0]:g} "
                                                      f"Hz), got {header['FREQUENCY'][0]!r}")
        if "DATA_INCLUDED" in qtm and qtm["DATA_INCLUDED"].upper() != "3D":
            raise self.err(header_lines["DATA_INCLUDED"],
                           f"DATA_INCLUDED is {_short(qtm['DATA_INCLUDED'])}; only 3D exports are supported")
        for key in ("DESCRIPTION", "TIME_STAMP", "FILE_VERSION"):
            if key in header:
                vals = list(header[key])
                while vals and not vals[-1]:
                    vals.pop()
                qtm[key] = vals[0] if len(vals) == 1 else tuple(vals)
        n_markers = qtm["NO_OF_MARKERS"]
        n_declared = qtm["NO_OF_FRAMES"]
        if 3 * n_markers > self.size:  # checked before anything is sized by it
            raise self.err(header_lines["NO_OF_MARKERS"],
                           f"NO_OF_MARKERS is {n_markers} but the whole file ({self.size:,} characters) "
                           f"cannot hold one row of 3 x {n_markers} values")

        meta: dict = {
            "format": "qtm-tsv",
            "encoding": self.encoding,
            "header": {k: list(v) for k, v in header.items()},
            "header_lines": {k: v + 1 for k, v in header_lines.items()},
            "events": events,
            "qtm": qtm,
            "missing_value": "0.000 0.000 0.000 triplet",
        }

        names = list(header["MARKER_NAMES"])
        if len(names) > n_markers:
            surplus = [v for v in names[n_markers:] if v]
            if surplus:
                raise self.err(header_lines["MARKER_NAMES"],
                               f"MARKER_NAMES has {len([v for v in names if v])} names but NO_OF_MARKERS is "
                               f"{n_markers} (first extra name: {_short(surplus[0])})")
            names = names[:n_markers]
        elif len(names) < n_markers:
            meta["marker_names_padded"] = n_markers - len(names)
            names += [""] * (n_markers - len(names))
        if "TRAJECTORY_TYPES" in header:
            types = list(header["TRAJECTORY_TYPES"])
            while len(types) > n_markers and not types[-1]:
                types.pop()
            if len(types) == n_markers:
                meta["trajectory_types"] = tuple(types)

        # ---- column header -----------------------------------------------------------------------
        if end_header >= len(lines):
            raise self.err(len(lines) - 1, "no data rows after the header")
        has_frame = has_time = False
        first_data = end_header
        col_fields = lines[end_header].split("\t")
        while len(col_fields) > 1 and not col_fields[-1].strip():
            col_fields.pop()
        head0 = col_fields[0].strip()
        looks_numeric = bool(_NUM_RE.match(head0))
        if not looks_numeric:
            first_data = end_header + 1
            k = 0
            if k < len(col_fields) and col_fields[k].strip().lower() == "frame":
                has_frame = True
                k += 1
            if k < len(col_fields) and col_fields[k].strip().lower() == "time":
                has_time = True
                k += 1
            triples = col_fields[k:]
            if len(triples) != 3 * n_markers:
                raise self.err(end_header,
                               f"the column header has {len(triples)} coordinate columns, expected "
                               f"3 x NO_OF_MARKERS = {3 * n_markers}"
                               + ("" if has_frame or has_time else
                                  f" (or it is not a column header: {_short(head0)} is neither 'Frame' nor a number)"))
            for m in range(n_markers):
                for a, ax in enumerate(_AXES):
                    col = k + 3 * m + a
                    cell = col_fields[col].strip()
                    if not (cell == ax or cell.endswith(" " + ax)):
                        raise self.err(end_header, f"column {col + 1} is {_short(cell)}, expected "
                                                   f"'{(names[m] + ' ') if names[m] else ''}{ax}'")
                    name = cell[:-1].strip()
                    if name != names[m]:
                        raise self.err(end_header, f"column {col + 1} ({_short(cell)}) does not match marker "
                                                   f"{m + 1} of MARKER_NAMES ({_short(names[m])})")
            ncol = k + 3 * n_markers
        else:
            nf = len(col_fields)
            if nf == 3 * n_markers + 2:
                has_frame = has_time = True
            elif nf != 3 * n_markers:
                raise self.err(end_header, f"expected {3 * n_markers} or {3 * n_markers + 2} values "
                                           f"(3 x NO_OF_MARKERS, optionally after frame and time), found {nf}")
            ncol = nf
        if ncol == 0:
            raise self.err(end_header, "no columns to read (NO_OF_MARKERS is 0 and no Frame/Time columns)")

        # ---- data rows ----------------------------------------------------------------------------
        data_lines = lines[first_data:]
        n_rows = len(data_lines)
        if n_rows == 0:
            raise self.err(len(lines) - 1, "no data rows after the column header")
        k0 = int(has_frame) + int(has_time)
        field_names = [f"column {k + 1} ({_short(nm)})" for k, nm in enumerate(
            (["Frame"] if has_frame else []) + (["Time"] if has_time else [])
            + [f"{names[m] or f'marker {m + 1}'} {ax}" for m in range(n_markers) for ax in _AXES])]
        last = n_rows - 1
        flat: list[str] = []
        extend = flat.extend
        empties: list[int] = []  # rows holding an empty cell
        for j, ln in enumerate(data_lines):
            fields = ln.split("\t")
            if len(fields) != ncol:
                while len(fields) > ncol and not fields[-1].strip():
                    fields.pop()
                if len(fields) != ncol:
                    if not ln.strip():
                        raise self.err(first_data + j, "empty line inside the data")
                    cut = (" (the file ends without a newline in this line: it was cut short)"
                           if j == last and not self.ends_with_newline else "")
                    raise self.err(first_data + j, f"expected {ncol} tab-separated values, found "
                                                   f"{len(fields)}{cut}")
            if _NOT_NUMERIC.search(ln):
                self._locate_bad_value(ln, first_data + j, ncol, field_names)
            if "" in fields or any(not f.strip() for f in fields):
                empties.append(j)
                fields = [f if f.strip() else "nan" for f in fields]
            extend(fields)
        if not self.ends_with_newline:
            prev = [ln.split("\t") for ln in data_lines[max(0, last - 20):last]]
            cells = data_lines[last].split("\t")
            verdict, c = final_line_verdict(prev, cells)
            report_final_line(self.src, first_data + last + 1, verdict, c,
                              field_names[c] if c is not None and c < ncol else "the last value",
                              cells[c] if c is not None else "", meta.setdefault("warnings", []))
        try:
            values = np.array(flat, dtype=np.float64)
        except ValueError:
            for j, ln in enumerate(data_lines):
                self._locate_bad_value(ln, first_data + j, ncol, field_names)
            raise self.err(None, "a value is not a number") from None  # pragma: no cover
        del flat
        values = values.reshape(n_rows, ncol)
        for j in empties:
            row = values[j]
            gap = np.isnan(row)
            if gap[:k0].any():
                raise self.err(
                    first_data + j, f"{field_names[int(np.flatnonzero(gap[:k0])[0])]}: empty value is not a number"
                )
            trip = gap[k0:].reshape(n_markers, 3)
            partial = np.flatnonzero(trip.any(axis=1) & ~trip.all(axis=1))
            if partial.size:
                m = int(partial[0])
                a = int(np.flatnonzero(trip[m])[0])
                raise self.err(first_data + j, f"{field_names[k0 + 3 * m + a]}: empty value is not a number "
                                               "(a missing marker has all three cells empty)")
        big = ~(np.abs(values) <= MAX_ABS)
        big &= ~np.isnan(values)  # the empty triples checked above
        if big.any():
            r, c = (int(v) for v in np.argwhere(big)[0])
            raise self.err(first_data + r, f"{field_names[c]}: {_short(data_lines[r].split(chr(9))[c].strip())} "
                                           f"is out of range (|value| > {MAX_ABS:g})")

        if n_rows != n_declared:
            problem = (f"NO_OF_FRAMES is {n_declared} but the file has {n_rows} data rows "
                       f"(lines {first_data + 1}-{first_data + n_rows})")
            if self.strict:
                raise self.err(header_lines["NO_OF_FRAMES"], problem + "; use strict=False to accept the rows")
            meta["frame_count_mismatch"] = {"declared": n_declared, "rows": n_rows}

        c = 0
        frames = None
        if has_frame:
            frames = values[:, 0]
            c = 1
            nonint = np.flatnonzero(frames != np.floor(frames))
            if nonint.size:
                r = int(nonint[0])
                raise self.err(first_data + r, f"frame number {float(frames[r])!r} is not an integer")
            dec = np.flatnonzero(np.diff(frames) <= 0)
            if dec.size:
                r = int(dec[0]) + 1
                raise self.err(first_data + r, f"frame number {int(frames[r])} does not follow "
                                               f"{int(frames[r - 1])} (frame numbers must increase)")
            meta["frame_gaps"] = int(np.count_nonzero(np.diff(frames) != 1))
            meta["frame_numbers"] = frames.astype(np.int64)
            meta["frame_numbers"].setflags(write=False)
        if has_time:
            times = values[:, c].copy()
            c += 1
            dec = np.flatnonzero(np.diff(times) <= 0)
            if dec.size:
                r = int(dec[0]) + 1
                raise self.err(first_data + r, f"time {float(times[r])!r} is not after the previous row's "
                                               f"{float(times[r - 1])!r} (times must increase)")
            if frames is not None:
                self._check_times(times, frames, rate, data_lines, first_data, meta)
        else:
            base = (frames - frames[0]) if frames is not None else np.arange(n_rows, dtype=np.float64)
            times = base / rate

        pos = values[:, c:].reshape(n_rows, n_markers, 3).copy()
        missing = np.all(pos == 0.0, axis=2)
        pos[missing] = np.nan
        labels, fixes = make_unique_labels(names, n_markers)
        meta["label_fixes"] = fixes
        try:
            return Markers(times, pos, labels, rate, units="mm", analog=None, source=self.src, meta=meta)
        except InvalidSignalError as exc:  # pragma: no cover - the checks above catch these
            raise self.err(None, str(exc)) from None

    # ---------------------------------------------------------------------------------------------

    def _check_times(self, times: np.ndarray, frames: np.ndarray, rate: float, data_lines: list[str],
                     first_data: int, meta: dict) -> None:
        t0_text = data_lines[0].split("\t")[1].strip()
        decimals = len(t0_text.split(".", 1)[1]) if "." in t0_text and "e" not in t0_text.lower() else 0
        tol = min(10.0 ** -decimals, 0.5 / rate) + 1e-9 * max(1.0, float(np.abs(times).max()))
        expected = times[0] + (frames - frames[0]) / rate
        dev = np.abs(times - expected)
        worst = float(dev.max())
        if worst <= tol:
            return
        r = int(np.flatnonzero(dev > tol)[0])
        problem = (f"time {float(times[r])!r} of frame {int(frames[r])} disagrees with FREQUENCY {rate:g} Hz: "
                   f"expected {expected[r]:.6f} s (frame {int(frames[0])} at {float(times[0])!r} s), off by "
                   f"{dev[r]:.3g} s")
        if self.strict:
            raise self.err(first_data + r, problem + "; use strict=False to accept the Time column")
        meta["time_mismatch"] = {"line": first_data + r + 1, "max_deviation_s": worst, "first": problem}

    def _locate_bad_value(self, line: str, idx: int, ncol: int, field_names: list[str]) -> None:
        """Raise naming the first cell of ``line`` (0-based line ``idx``) that is not a number."""
        for k, cell in enumerate(line.split("\t")[:ncol]):
            s = cell.strip()
            if s and not _NUM_RE.match(s):
                raise self.err(idx, f"{field_names[k]}: {_short(s)} is not a number")
