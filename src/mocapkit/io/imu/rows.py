"""The data rows of an IMU export, parsed into times and orientation values, a block of lines at a time.

Every problem raises :class:`~mocapkit.errors.MocapFormatError` naming the file, the 1-based line
and the column: a wrong column count (trailing delimiters and empty extra cells are ignored), a
cell that is not a number by the strict grammar of :mod:`mocapkit.io.text.numbers` (``0_5``, ``1..2``,
text), NaN or infinity, a value beyond :data:`~mocapkit.io.text.numbers.MAX_ABS` in an orientation
column (quaternion component, matrix entry, angle), a zero quaternion, an empty line inside the
data, a duplicate or decreasing time, or a time step below :data:`MIN_STEP` (a rate above 1 GHz,
which would make the rate infinite or absurd). Time columns may hold raw epoch counters (ns since
1970, about 1.7e18): their limit before the unit scaling is ``MAX_ABS`` seconds in their unit
(:data:`TIME_LIMIT`), and a counter is an integer below 2**53 (:data:`COUNTER_LIMIT`).

Missing values: only OptiTrack Motive writes them, as empty cells when a rigid body is lost; that
frame is dropped for that body and counted in ``meta["warnings"]``. No other supported export has a
missing-value convention, so an empty, ``nan`` or ``inf`` cell is an error there.

A file whose last line has no line end may have been cut short: a different number of fields on
that line is an error (the message says so). Its last value is judged against the same column on
the (up to) 20 rows before it (:func:`mocapkit.io.text.input.cut_cell`; with one row before it,
rule (a) alone decides and (b) or (c) only give a warning: one row cannot tell a fixed-decimal column
from a varying one):

(a) it ends with ``.``, ``e``, ``E``, ``+`` or ``-`` (``0.`` for ``0.4``): an error;
(b) it has fewer decimals (or exponent digits) than that column on every one of those rows, all
    written alike (a fixed-decimal export cut in the middle of ``-0.124044`` leaves ``-0``): an error,
    only a warning in a column the reader does not use (the data read are complete);
(c) otherwise, in a column written with varying decimals (``repr``, ``%g``: the points CSV of
    ``mocapkit compress``), it has fewer significant characters than the longest value of that column
    in those rows (``-0.05344`` for ``-0.053447``): a warning in ``meta["warnings"]`` ("the file has no
    final newline and its last value ... is shorter than others of its column: it may be cut short").

A complete file that merely lacks a final line end is never refused; at most it gets warning (c).
The streaming reader (``online``) has no ``meta``: it issues its warnings with :func:`warnings.warn`
(:class:`~mocapkit.errors.MocapWarning`), which the command line prints.

Counters and device clocks that wrap (uint16 ``PacketCounter``, uint32 ``SampleTimeFine``) are
unwrapped when the next row continues from the wrapped value (serial-number arithmetic: a drop
followed by a step of at most half the range).

Counters become times with the sample rate ``r`` and the counter step ``s`` (the most frequent step
between rows; in a stream, the first step): ``t = (counter − first) / (r · s)``. A step of 1 is the
usual case; a legacy x-io file whose packet number counts every packet type steps by 3 for its
quaternion rows. Any step other than 1 is recorded in ``meta["warnings"]``.

A time column whose unit was guessed (a unit-less ``time``, read as seconds unless its magnitude makes
it an epoch) is checked for plausibility: a median sample interval giving a rate outside
:data:`PLAUSIBLE_RATE` is recorded in ``meta["warnings"]`` (the data are kept as read).

Speed and memory: a block of lines (:mod:`mocapkit.io.imu.lines`) whose used cells hold only digits,
signs, points and exponents, with the right number of delimiters on every line, is converted in one
``numpy.loadtxt`` call and checked with array operations; the values go straight into growing float64
arrays (one for the times, one ``(N, 4)`` per sensor), so the peak memory stays near the size of the
numbers. Any other block (text columns, quotes, lost OptiTrack bodies, an error) is parsed line by
line with the same rules, which also names the first bad line. Both paths give the same numbers
(``float`` of the text).
"""

from __future__ import annotations

import io
import math
from collections import Counter
from collections.abc import Sequence

import numpy as np

from mocapkit.errors import MocapFormatError, MocapWarning
from mocapkit.io.imu.columns import TIME_UNITS
from mocapkit.io.imu.layout import Layout
from mocapkit.io.imu.lines import check_line
from mocapkit.io.imu.orientation import euler_note, matrices_to_quaternions, matrix_note, quaternions_from_euler
from mocapkit.io.text.input import cut_cell, short_value_note
from mocapkit.io.text.numbers import CUT_ENDINGS, MAX_ABS, NUMBER_RE, parse_number

__all__ = ["COUNTER_LIMIT", "MAX_BLANK_LINES", "MIN_STEP", "PLAUSIBLE_RATE", "TIME_LIMIT", "RowReader"]

#: Sample rates (Hz) of orientation data from body-worn IMUs and optical systems. Their outputs run
#: at about 10 Hz to 2 kHz (high-speed optical cameras up to ~10 kHz); human movement needs a few
#: Hz at the very least. Milliseconds read as seconds divide the rate by 1000 (100 Hz -> 0.1 Hz,
#: 1 kHz -> 1 Hz), microseconds by 1e6: all below 2 Hz. Used only when the unit was not stated.
PLAUSIBLE_RATE = (2.0, 10_000.0)

#: Smallest time step accepted between rows (s): 1 ns, a rate of 1 GHz. A smaller step (e.g.
#: ``1e-320`` s) would give an infinite or absurd rate; no motion sensor samples that fast.
MIN_STEP = 1e-9

#: Largest raw value of a clock column in its own unit (``MAX_ABS`` seconds: an epoch in ns is
#: about 1.7e18, far below 1e21).
TIME_LIMIT = {u: MAX_ABS * d for u, d in TIME_UNITS.items()}

#: Largest counter value (integers stay exact in float64 below 2**53).
COUNTER_LIMIT = float(2**53)

#: Empty lines accepted in a row at the end of a file (an endless input of line ends is refused).
MAX_BLANK_LINES = 100_000

#: Blocks shorter than this are parsed line by line (cheaper than setting up a bulk conversion).
BULK_MIN_LINES = 32

#: Rows before the last line of a file without a final line end that it is compared with.
CUT_CONTEXT = 20

_SEP_NAMES = {"\t": "tab", ",": "comma", ";": "semicolon", None: "whitespace"}
_NAN_WORDS = {"nan", "+nan", "-nan"}
_INF_WORDS = {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}

#: Characters of a block that the bulk path converts (numbers, padding, line ends; plus the
#: delimiter); anything else (letters, quotes, ``_``) sends the block to the line-by-line path.
_NUMERIC_BYTES = b"0123456789.+-eE \t\n"


_fullmatch = NUMBER_RE.fullmatch


def _short(text: str, limit: int = 80) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


class _Grow:
    """A float64 array of ``(n, *shape)`` rows grown in place (``ndarray.resize``: large blocks are
    remapped, not copied), trimmed to ``n`` rows at the end."""

    def __init__(self, width: int | None, capacity: int = 4096):
        self.width = width
        self.n = 0
        self.a = np.empty((capacity,) if width is None else (capacity, width), dtype=np.float64)

    def extend(self, rows: np.ndarray) -> None:
        k = len(rows)
        need = self.n + k
        if need > len(self.a):
            cap = max(need, int(len(self.a) * 1.5) + 1024)
            try:
                self.a.resize((cap,) + self.a.shape[1:], refcheck=False)
            except ValueError:  # pragma: no cover - the array owns its data; kept as a safety net
                b = np.empty((cap,) + self.a.shape[1:], dtype=np.float64)
                b[: self.n] = self.a[: self.n]
                self.a = b
        self.a[self.n: need] = rows
        self.n = need

    def array(self) -> np.ndarray:
        try:
            self.a.resize((self.n,) + self.a.shape[1:], refcheck=False)
            out = self.a
        except ValueError:  # pragma: no cover
            out = self.a[: self.n].copy()
        self.a = np.empty((0,) + self.a.shape[1:])
        return out


class RowReader:
    """Parse the data rows of one layout: :meth:`feed_block` (files) or :meth:`feed` (one line, a
    stream); :meth:`finish` returns times and per-sensor values.

    With ``online=True`` (a stream) :meth:`feed` returns the row's time in seconds and its
    quaternions at once and nothing is stored: memory stays constant however long the stream.
    """

    def __init__(self, layout: Layout, src: str, online: bool = False, size_hint: int | None = None):
        self.lay = layout
        self.src = src
        self.online = online
        self.ncols = len(layout.names)
        self.tcol = layout.time.col
        self.unit = layout.time.unit
        self.tname = layout.time.name
        self.wrap = layout.time.wrap
        self.counting = self.tcol is not None and (self.unit == "counter" or self.wrap is not None)
        self.raw_limit = COUNTER_LIMIT if self.counting else TIME_LIMIT.get(self.unit or "s", MAX_ABS)
        self._n = 0                           # rows fed
        self._first_ln: int | None = None     # line of row 0 (every later line is a row: rows = lines)
        self._prev_ln = 0                     # line of the previous row
        self._prev_t: float | None = None     # time of the previous row (s)
        self._prev_text = ""                  # time text of the previous row (for messages)
        self._prev_u: int | None = None       # unwrapped count of the previous row
        self._first_u = 0                     # unwrapped count of the first row
        self._prev_raw = 0
        self._offset = 0
        self._pending: tuple[int, int, int] | None = None
        self._step: int | None = None
        self._last_online = -math.inf
        self._blank: int | None = None        # first empty line of the current run
        self._blank_run = 0
        self._final_ln: int | None = None     # the last line when the input ends without a line end
        self._tail: list[str] = []            # the last rows' text (for the cut-short check)
        self.dropped = [0] * len(layout.sensors)
        self.warnings: list[str] = []
        # used columns, in the order of the bulk array: time (if any), then each sensor's columns
        self._used: list[int] = ([self.tcol] if self.tcol is not None else []) + [c for o in layout.sensors
                                                                                    for c in o.cols]
        d = layout.delim
        self._fast = d is None or (len(d) == 1 and d not in '0123456789.+-eE\n\r"')
        self._alphabet = _NUMERIC_BYTES + (d.encode() if self._fast and d is not None else b"")
        if not online:
            cap = 4096 if size_hint is None else max(4096, min(size_hint // 16 + 1024, 1 << 26))
            self._times = _Grow(None, cap) if self.tcol is not None else None
            self._vals = [_Grow(4, cap) for _ in layout.sensors]
            self._drops: list[list[np.ndarray]] = [[] for _ in layout.sensors]
            self._dev = [0.0 for _ in layout.sensors]          # largest |R Rᵀ − I| of matrix sensors

    # ---------------------------------------------------------------------------------------------
    # one cell
    # ---------------------------------------------------------------------------------------------
    def _number(self, text: str, ln: int, name: str, limit: float) -> float:
        """A cell by the strict grammar (:mod:`mocapkit.io.text.numbers`), finite and within ``limit``."""
        if _fullmatch(text):
            v = float(text)
            if abs(v) <= limit:
                return v
            if math.isinf(v):
                raise MocapFormatError(self.src, ln, f"column {name} is infinite ({_short(text)})")
            return parse_number(text, self.src, ln, f"column {name}", limit=limit)  # raises: out of range
        low = text.lower()
        if low in _NAN_WORDS:
            raise MocapFormatError(self.src, ln, f"column {name} is NaN")
        if low in _INF_WORDS:
            raise MocapFormatError(self.src, ln, f"column {name} is infinite ({_short(text)})")
        if ln == self._final_ln and text.strip().endswith(CUT_ENDINGS):  # '-', '1e-': rule (a)
            raise MocapFormatError(self.src, ln, f"column {name}: {_short(text.strip())} is not a number; the file "
                                   "ends in this line without a line end: it was cut short (delete this line to "
                                   "read the rest)")
        return parse_number(text, self.src, ln, f"column {name}", limit=limit)  # raises: not a number

    # ---------------------------------------------------------------------------------------------
    # one line
    # ---------------------------------------------------------------------------------------------
    def _fields(self, line: str, ln: int) -> list[str]:
        d = self.lay.delim
        if d is None:
            fields = line.split()
            ok = len(fields) == self.ncols
        else:
            fields = line.split(d)
            ok = len(fields) >= self.ncols and not any(f.strip() for f in fields[self.ncols:])
        if not ok:
            shown = len(fields)
            if d is not None:
                while shown > self.ncols and not fields[shown - 1].strip():
                    shown -= 1
            cut = (" (the last line, which has no line end: the file looks cut short)"
                   if ln == self._final_ln else "")
            raise MocapFormatError(
                self.src, ln, f"expected {self.ncols} {_SEP_NAMES.get(d, repr(d))}-separated columns like the "
                + (f"header on line {self.lay.header_line}" if self.lay.header_index >= 0 else "first row")
                + f", got {shown}{cut}",
            )
        return fields

    def _count(self, c: int, ln: int) -> int:
        if c < 0:
            raise MocapFormatError(self.src, ln, f"column {self.tname}: {c} is negative")
        if self._prev_u is None:
            return c
        mod = self.wrap
        u = c + self._offset
        prev_u = self._prev_u
        prev_raw = self._prev_raw
        if self._pending is not None:
            before_ln, before_raw, wrap_raw = self._pending
            if not (prev_u < u <= prev_u + (mod or 0) // 2):
                raise MocapFormatError(
                    self.src, ln, f"{self.tname} drops from {before_raw} (line {before_ln}) to {wrap_raw} "
                    f"(line {self._prev_ln}) but line {ln} ({c}) does not continue from {wrap_raw}: "
                    "not a wrap-around",
                )
            self._pending = None
        if u == prev_u:
            raise MocapFormatError(self.src, ln, f"duplicate {self.tname} {c} on lines {self._prev_ln} and {ln}")
        if u < prev_u:
            step = c + (mod or 0) - prev_raw
            if mod and c < mod and prev_raw < mod and 1 <= step <= mod // 2:
                self._offset = prev_u - prev_raw + mod
                u = c + self._offset
                self._pending = (self._prev_ln, prev_raw, c)
            else:
                raise MocapFormatError(
                    self.src, ln, f"{self.tname} must increase: line {ln} has {c}, less than {prev_raw} on line "
                    f"{self._prev_ln}" + (f" (not a wrap-around of a {mod}-value counter)" if mod else ""),
                )
        return u

    def _check_step(self, t: float, ln: int, text: str) -> None:
        prev = self._prev_t
        if prev is None:
            return
        if t == prev:
            raise MocapFormatError(
                self.src, ln, f"duplicate timestamp: line {ln} has {self.tname} {_short(text)} ({t!r} s), "
                f"the same time as line {self._prev_ln} ({_short(self._prev_text)})",
            )
        if t < prev:
            raise MocapFormatError(
                self.src, ln, f"timestamps must increase: line {ln} has {self.tname} {_short(text)} ({t!r} s), "
                f"earlier than line {self._prev_ln} with {_short(self._prev_text)} ({prev!r} s)",
            )
        if t - prev < MIN_STEP:
            raise MocapFormatError(
                self.src, ln, f"column {self.tname}: the step from line {self._prev_ln} ({_short(self._prev_text)}) "
                f"to {_short(text)} is {t - prev!r} s, below {MIN_STEP:g} s (a rate above {1 / MIN_STEP:g} Hz): "
                "not a sample interval",
            )

    def _time(self, fields: list[str], ln: int) -> float | None:
        """The row's time in seconds (clocks) or unwrapped count (counters); updates the state."""
        if self.tcol is None:
            return None
        text = fields[self.tcol].strip().strip('"')
        if self.counting:
            v = self._number(text, ln, self.tname, COUNTER_LIMIT)
            if not v.is_integer():
                raise MocapFormatError(self.src, ln, f"column {self.tname}: {_short(text)} is not an integer")
            raw = int(v)
            c = self._count(raw, ln)
            if self._prev_u is None:
                self._first_u = c
            self._prev_u = c
            self._prev_raw = raw
            self._prev_text = text
            if self.unit == "counter":
                return float(c)
            t = c / TIME_UNITS[self.unit]  # type: ignore[index]
            self._prev_t = t
            return t
        raw_v = self._number(text, ln, self.tname, self.raw_limit)
        t = raw_v / TIME_UNITS[self.unit] if self.unit != "s" else raw_v  # type: ignore[index]
        self._check_step(t, ln, text)
        self._prev_t = t
        self._prev_text = text
        return t

    def _values(self, fields: list[str], ln: int, k: int) -> tuple[float, ...] | None:
        o = self.lay.sensors[k]
        texts = [fields[c].strip().strip('"') for c in o.cols]
        if o.missing_rows == "drop" and any(not t for t in texts):
            return None
        out = [self._number(text, ln, name, MAX_ABS) for text, name in zip(texts, o.names, strict=False)]
        if o.kind == "quaternion" and all(v * v == 0.0 for v in out):
            raise MocapFormatError(
                self.src, ln, f"zero-norm quaternion ({', '.join(o.names)} = {', '.join(repr(v) for v in out)})"
            )
        return tuple(out)

    def _row(self, line: str, ln: int) -> tuple[float | None, list[tuple[float, ...] | None]]:
        if self._blank is not None:
            raise MocapFormatError(self.src, self._blank,
                                   "empty line inside the data (only trailing empty lines are allowed)")
        fields = self._fields(line, ln)
        vals = [self._values(fields, ln, k) for k in range(len(self.lay.sensors))]
        t = self._time(fields, ln)
        if self._first_ln is None:
            self._first_ln = ln
        self._n += 1
        self._prev_ln = ln
        return t, vals

    def feed(self, line: str, ln: int) -> tuple[float, list[tuple[float, ...] | None]] | None:
        """Parse one data line (``ln`` 1-based). Online: return ``(time_s, per-sensor w,x,y,z or None)``
        (blank lines are the caller's business); else the row is stored."""
        if not self.online:
            self._lines([line], ln)
            return None
        check_line(line, self.src, ln)
        if not line.strip():
            raise MocapFormatError(self.src, ln, "empty line inside the data (only trailing empty lines are allowed)")
        idx = self._n
        t, vals = self._row(line, ln)
        for k, v in enumerate(vals):
            if v is None:
                self.dropped[k] += 1
        return self._online_time(idx, ln, t), [
            None if v is None else v if self.lay.sensors[k].kind == "quaternion" else self._convert(k, [v], [ln])[0][0]
            for k, v in enumerate(vals)
        ]

    def _online_time(self, idx: int, ln: int, t: float | None) -> float:
        if not (self.unit == "counter" or self.tcol is None):
            return t  # type: ignore[return-value]
        rate = self.lay.rate
        if self.tcol is None:
            t = idx / rate  # type: ignore[operator]
        else:
            if self._step is None and idx >= 1:
                self._step = self._prev_u - self._first_u  # type: ignore[operator]
            t = (self._prev_u - self._first_u) / (rate * (self._step or 1))  # type: ignore[operator]
        if not (abs(t) <= MAX_ABS):
            raise MocapFormatError(self.src, ln, f"time {t!r} s from {self.tname or 'the row index'} and the rate "
                                   f"{rate:g} Hz is out of range (|t| > {MAX_ABS:g} s)")
        if idx and not (t - self._last_online >= MIN_STEP):
            raise MocapFormatError(self.src, ln, f"time {t!r} s from {self.tname or 'the row index'} and the rate "
                                   f"{rate:g} Hz is not at least {MIN_STEP:g} s after the previous row")
        self._last_online = t
        return t

    # ---------------------------------------------------------------------------------------------
    # blocks (files)
    # ---------------------------------------------------------------------------------------------
    def feed_block(self, text: str, first_ln: int, n_lines: int, final: bool, terminated: bool) -> None:
        """Parse ``n_lines`` lines (``\\n``-ended, the last one maybe not when ``final``) starting at
        line ``first_ln``. Empty lines are allowed only at the end of the input."""
        if n_lines == 0:
            return
        body = text[:-1] if terminated else text
        n = n_lines
        if final:
            if not terminated and body[body.rfind("\n") + 1:].strip():
                self._final_ln = first_ln + n_lines - 1
            core = body.rstrip()
            if len(core) < len(body):       # the lines after `core` are empty: allowed at the end
                n = core.count("\n") + 1 if core else 0
                body = core
        if n and not self._bulk(body, first_ln, n):
            self._lines(body.split("\n"), first_ln)
        if self._final_ln is not None and self._blank is None:
            self._check_cut(body)
        self._keep_tail(body)

    def _lines(self, lines: Sequence[str], first_ln: int) -> None:
        ts: list[float | None] = []
        vals: list[list[tuple[float, ...] | None]] = []
        lns: list[int] = []
        idx0 = self._n
        for i, line in enumerate(lines):
            ln = first_ln + i
            if not line.strip():
                if self._blank is None:
                    self._blank = ln
                    self._blank_run = 0
                self._blank_run += 1
                if self._blank_run > MAX_BLANK_LINES:
                    raise MocapFormatError(self.src, self._blank, f"more than {MAX_BLANK_LINES} empty lines from "
                                           "here on: not an IMU export")
                continue
            t, v = self._row(line, ln)
            ts.append(t)
            vals.append(v)
            lns.append(ln)
        if ts:
            self._store_rows(ts, vals, idx0, lns)

    def _store_rows(self, ts, vals, idx0: int, lns: list[int]) -> None:
        if self._times is not None:
            self._times.extend(np.array(ts, dtype=np.float64))
        for k in range(len(self.lay.sensors)):
            keep = [i for i, v in enumerate(vals) if v[k] is not None]
            if len(keep) < len(vals):
                gone = np.array([i for i, v in enumerate(vals) if v[k] is None], dtype=np.intp) + idx0
                self._drops[k].append(gone)
                self.dropped[k] += len(gone)
            if keep:
                q, _ = self._convert(k, [vals[i][k] for i in keep], [lns[i] for i in keep])
                self._vals[k].extend(q)

    def _bulk(self, body: str, first_ln: int, n: int) -> bool:
        """Convert a clean block in one go; ``False`` (nothing stored, state unchanged) when the block
        needs the line-by-line path (text or quotes, an empty cell, any error)."""
        if n < BULK_MIN_LINES or not self._fast or self._blank is not None or not body.isascii():
            return False
        raw = body.encode("ascii")
        if raw.translate(None, self._alphabet):
            return False
        d = self.lay.delim
        if d is not None and not self._delimiters_ok(raw, n, ord(d)):
            return False
        try:
            if d is None:
                arr = np.loadtxt(io.StringIO(body), dtype=np.float64, comments=None, ndmin=2)
                if arr.shape != (n, self.ncols):
                    return False
                arr = arr[:, self._used]
            else:
                arr = np.loadtxt(io.StringIO(body), delimiter=d, usecols=self._used, dtype=np.float64,
                                 comments=None, ndmin=2)
        except ValueError:
            return False
        if arr.shape != (n, len(self._used)):
            return False
        j = 0
        t = None
        if self.tcol is not None:
            t = self._bulk_time(arr[:, 0], first_ln, n)
            if t is None:
                return False
            j = 1
        parts = []
        for o in self.lay.sensors:
            v = arr[:, j: j + len(o.cols)]
            j += len(o.cols)
            if not (np.abs(v) <= MAX_ABS).all():
                return False
            if o.kind == "quaternion" and ((v * v) == 0.0).all(axis=1).any():
                return False
            parts.append(v)
        # everything checked: commit
        converted = [self._convert(k, v, np.arange(first_ln, first_ln + n))[0] for k, v in enumerate(parts)]
        if self._first_ln is None:
            self._first_ln = first_ln
        if t is not None:
            t_vals, state = t
            self._times.extend(t_vals)  # type: ignore[union-attr]
            self._commit_time(state, body)
        for k, q in enumerate(converted):
            self._vals[k].extend(q)
        self._n += n
        self._prev_ln = first_ln + n - 1
        return True

    def _delimiters_ok(self, raw: bytes, n: int, dcode: int) -> bool:
        a = np.frombuffer(raw, dtype=np.uint8)
        ends = np.flatnonzero(a == 10)
        if len(ends) != n - 1:
            return False
        ends = np.append(ends, len(a))
        per = np.diff(np.searchsorted(np.flatnonzero(a == dcode), ends), prepend=0)
        want = self.ncols - 1
        if (per == want).all():
            return True
        extra = per == want + 1  # one trailing delimiter (Xsens MT Manager ends its lines with a tab)
        if not ((per == want) | extra).all():
            return False
        return bool((a[ends[extra] - 1] == dcode).all())

    def _bulk_time(self, raw: np.ndarray, first_ln: int, n: int):
        """``(times or counts to store, state)`` for a block's time cells, or ``None`` (line path)."""
        if self.counting:
            if not ((raw >= 0) & (raw < COUNTER_LIMIT) & (raw == np.floor(raw))).all():
                return None
            r = raw.astype(np.int64)
            mod = self.wrap
            if self._prev_u is None:
                d = np.diff(r)
                d = np.concatenate(([1], d))
            else:
                d = np.diff(r, prepend=self._prev_raw)
            neg = d < 0
            if (d == 0).any():
                return None
            if neg.any():
                if not mod:
                    return None
                prev = r - d
                w = d[neg] + mod
                if not ((r[neg] < mod) & (prev[neg] < mod) & (w >= 1) & (w <= mod // 2)).all():
                    return None
                nxt = np.flatnonzero(neg) + 1
                nxt = nxt[nxt < n]
                if ((d[nxt] <= 0) | (d[nxt] > mod // 2)).any():
                    return None
            if self._pending is not None and not (1 <= d[0] <= (mod or 0) // 2):
                return None
            offs = self._offset + (mod or 0) * np.cumsum(neg)
            u = r + offs
            pending = None
            if neg[-1]:
                pending = (first_ln + n - 2 if n >= 2 else self._prev_ln, int(r[-2]) if n >= 2 else self._prev_raw,
                           int(r[-1]))
            state = ("count", int(r[-1]), int(u[-1]), int(offs[-1]), pending, int(u[0]))
            if self.unit == "counter":
                return u.astype(np.float64), state
            t = u / TIME_UNITS[self.unit]  # type: ignore[index]
            if self._prev_t is not None and not (t[0] - self._prev_t >= MIN_STEP):
                return None
            if n > 1 and not (np.diff(t) >= MIN_STEP).all():
                return None
            return t, state + (float(t[-1]),)
        if not (np.abs(raw) <= self.raw_limit).all():
            return None
        t = raw / TIME_UNITS[self.unit] if self.unit != "s" else raw  # type: ignore[index]
        if self._prev_t is not None and not (t[0] - self._prev_t >= MIN_STEP):
            return None
        if n > 1 and not (np.diff(t) >= MIN_STEP).all():
            return None
        return t, ("clock", float(t[-1]))

    def _commit_time(self, state: tuple, body: str) -> None:
        last = body[body.rfind("\n") + 1:]
        fields = last.split(self.lay.delim) if self.lay.delim is not None else last.split()
        self._prev_text = fields[self.tcol].strip()  # type: ignore[index]
        if state[0] == "clock":
            self._prev_t = state[1]
            return
        _, self._prev_raw, self._prev_u, self._offset, self._pending, first_u = state[:6]
        if self._n == 0:
            self._first_u = first_u
        if len(state) > 6:
            self._prev_t = state[6]

    # ---------------------------------------------------------------------------------------------
    # the last line of a file without a line end
    # ---------------------------------------------------------------------------------------------
    def split(self, line: str) -> list[str]:
        """The fields of a line (the layout's delimiter)."""
        return line.split(self.lay.delim) if self.lay.delim is not None else line.split()

    def _keep_tail(self, body: str) -> None:
        lines = body.rsplit("\n", CUT_CONTEXT)
        self._tail = (self._tail + lines)[-CUT_CONTEXT:]

    def _check_cut(self, body: str) -> None:
        lines = (self._tail + body.rsplit("\n", CUT_CONTEXT + 1))[-(CUT_CONTEXT + 1):]
        lines = [ln for ln in lines if ln.strip()]
        if not lines:
            return
        self.check_cut_line([self.split(x) for x in lines[:-1]], lines[-1], self._final_ln)  # type: ignore[arg-type]

    def check_cut_line(self, prev_rows: list[list[str]], last: str, ln: int) -> None:
        """Report a last line (without a line end) whose last number looks cut short (rules (a)-(c) of
        the module docstring): an error, or a warning in an unused column or when it is only shorter
        than others of a column written with varying decimals."""
        self._final_ln = ln
        fields = self.split(last)
        found = cut_cell(prev_rows, fields)
        if found is None:
            return
        j, verdict = found
        name = self.lay.names[j] if j < len(self.lay.names) else f"column {j + 1}"
        cell = fields[j].strip()
        if len(prev_rows) < 2 and not (verdict == "cut" and cell.endswith(CUT_ENDINGS)):
            # one row before it cannot tell a fixed-decimal column from a varying one: a doubt, said
            self._warn(f"line {ln}: column {name}: {_short(cell)} is shorter than on the one row before it and "
                       "the file ends there without a line end: it may be cut short")
            return
        if verdict == "short":
            self._warn(f"line {ln}: column {name}: {short_value_note(cell)}")
            return
        ends_cut = cell.endswith((".", "e", "E", "+", "-"))
        how = "ends like a number cut short" if ends_cut else "has fewer decimals than the rows before it"
        what = f"column {name}: {_short(cell)} {how} and the file ends there without a line end"
        if j in self._used or ends_cut:
            raise MocapFormatError(self.src, ln, f"{what}: the file was cut short (delete this line to read the rest)")
        self._warn(f"line {ln}: {what} (an unused column; the file may have been cut short)")

    def _warn(self, text: str) -> None:
        """A warning for ``meta["warnings"]``; a stream (no meta) issues it with :func:`warnings.warn`."""
        self.warnings.append(text)
        if self.online:
            import warnings

            warnings.warn(f"{self.src}: {text}", MocapWarning, stacklevel=4)

    # ---------------------------------------------------------------------------------------------
    # results
    # ---------------------------------------------------------------------------------------------
    def _convert(self, k: int, values, line_nos) -> tuple[np.ndarray, str | None]:
        o = self.lay.sensors[k]
        arr = np.asarray(values, dtype=np.float64).reshape(len(values), len(o.cols))
        if o.kind == "matrix":
            q, dev = matrices_to_quaternions(arr, self.src, line_nos, o.names)
            if not self.online:
                self._dev[k] = max(self._dev[k], dev)
            return q, matrix_note(o.names, dev)
        if o.kind == "euler":
            return quaternions_from_euler(arr, o.degrees, o.names)
        return np.ascontiguousarray(arr), None

    def _implausible_rate(self, times: np.ndarray) -> str | None:
        """A warning when a guessed time unit gives a rate outside :data:`PLAUSIBLE_RATE`."""
        if self.lay.time.stated or len(times) < 2:
            return None
        dt = float(np.median(np.diff(times)))
        lo, hi = PLAUSIBLE_RATE
        rate = 1.0 / dt
        if lo <= rate <= hi:
            return None
        hint = " (milliseconds read as seconds give 1/1000 of the rate)" if self.unit == "s" and rate < lo else ""
        return (f"column {self.tname!r} has no unit and was read in {self.unit}: its median sample interval "
                f"{dt:.6g} s gives {rate:.6g} Hz, outside the {lo:g}-{hi:g} Hz of orientation sensors{hint}; "
                "if that is not its unit, give --time-unit s|ms|us|ns")

    def _counter_step(self, c: np.ndarray) -> int:
        if len(c) <= 4096:
            tally: Counter[int] = Counter(np.diff(c).astype(np.int64).tolist())
            return min(tally, key=lambda s: (-tally[s], s))
        tally = Counter()
        chunk = 1 << 20
        for i in range(0, len(c) - 1, chunk):
            vals, counts = np.unique(np.diff(c[i: i + chunk + 1]), return_counts=True)
            for v, k in zip(vals.tolist(), counts.tolist(), strict=True):
                tally[int(v)] += int(k)
        return min(tally, key=lambda s: (-tally[s], s)) if tally else 1

    def _check_times(self, t: np.ndarray, what: str) -> None:
        first = self._first_ln or 0
        bad = ~(np.abs(t) <= MAX_ABS)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise MocapFormatError(self.src, first + i, f"time {float(t[i])!r} s ({what}) is out of range "
                                   f"(|t| > {MAX_ABS:g} s)")
        if len(t) > 1:
            small = np.flatnonzero(~(np.diff(t) >= MIN_STEP))
            if small.size:
                i = int(small[0]) + 1
                raise MocapFormatError(
                    self.src, first + i, f"time {float(t[i])!r} s ({what}) is not at least {MIN_STEP:g} s after "
                    f"{float(t[i - 1])!r} s on line {first + i - 1}",
                )

    def finish(self) -> tuple[np.ndarray, list[tuple[np.ndarray | None, np.ndarray, str | None]], list[str]]:
        """``(times of all rows, [(kept row indices or None for all, (M, 4) w,x,y,z, conversion) per
        sensor], warnings)``."""
        n = self._n
        if n == 0:
            raise MocapFormatError(self.src, self.lay.header_line, "header only: no data rows after the header")
        warnings: list[str] = list(self.warnings)
        rate = self.lay.rate
        if self.tcol is None:
            times = np.arange(n, dtype=np.float64) / rate  # type: ignore[operator]
            self._check_times(times, f"row index / {rate:g} Hz")
        elif self.unit == "counter":
            times = self._times.array()  # type: ignore[union-attr]
            step = self._counter_step(times) if n > 1 else 1
            if step != 1:
                warnings.append(
                    f"{self.tname} steps by {step} between rows: read as one sample every {step} counts at "
                    f"{rate:g} Hz (t = (counter - first) / ({rate:g} * {step}))"
                )
            np.subtract(times, times[0], out=times)
            np.divide(times, rate * step, out=times)  # type: ignore[operator]
            self._check_times(times, f"from {self.tname} and the sample rate {rate:g} Hz")
        else:
            times = self._times.array()  # type: ignore[union-attr]
            note = self._implausible_rate(times)
            if note:
                warnings.append(note)
        out = []
        for k, o in enumerate(self.lay.sensors):
            q = self._vals[k].array()
            if len(q) == 0:
                raise MocapFormatError(self.src, None, f"{o.sensor or 'the orientation'} has no complete row "
                                       f"(columns {', '.join(o.names)})")
            rows = None
            if self._drops[k]:
                mask = np.ones(n, dtype=bool)
                for g in self._drops[k]:
                    mask[g] = False
                rows = np.flatnonzero(mask)
            how = (matrix_note(o.names, self._dev[k]) if o.kind == "matrix"
                   else euler_note(o.names, o.degrees) if o.kind == "euler" else None)
            out.append((rows, q, how))
        return times, out, warnings
