"""The data rows of an IMU export, parsed one line at a time into times and orientation values.

Every problem raises :class:`~mocapkit.errors.MocapFormatError` with the 1-based line: wrong column
count (trailing delimiters and empty extra cells are ignored), text, NaN or infinity in a used
column, a zero quaternion, a duplicate or decreasing time. Counters and device clocks that wrap
(uint16 ``PacketCounter``, uint32 ``SampleTimeFine``) are unwrapped when the next row continues from
the wrapped value (serial-number arithmetic: a drop followed by a step of at most half the range).

Counters become times with the sample rate ``r`` and the counter step ``s`` (the most frequent step
between rows; in a stream, the first step): ``t = (counter − first) / (r · s)``. A step of 1 is the
usual case; a legacy x-io file whose packet number counts every packet type steps by 3 for its
quaternion rows. Any step other than 1 is recorded in ``meta["warnings"]``.

A time column whose unit was guessed (a unit-less ``time``, read as seconds unless its magnitude makes
it an epoch) is checked for plausibility: a median sample interval giving a rate outside
:data:`PLAUSIBLE_RATE` is recorded in ``meta["warnings"]`` (the data are kept as read).
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.io.imu_columns import TIME_UNITS
from mocapkit.io.imu_layout import Layout
from mocapkit.io.imu_orientation import quaternions_from_euler, quaternions_from_matrices

__all__ = ["PLAUSIBLE_RATE", "RowReader"]

#: Sample rates (Hz) of orientation data from body-worn IMUs and optical systems. Their outputs run
#: at about 10 Hz to 2 kHz (high-speed optical cameras up to ~10 kHz); human movement needs a few
#: Hz at the very least. Milliseconds read as seconds divide the rate by 1000 (100 Hz -> 0.1 Hz,
#: 1 kHz -> 1 Hz), microseconds by 1e6: all below 2 Hz. Used only when the unit was not stated.
PLAUSIBLE_RATE = (2.0, 10_000.0)

_SEP_NAMES = {"\t": "tab", ",": "comma", ";": "semicolon", None: "whitespace"}


def _short(text: str, limit: int = 80) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


class RowReader:
    """Feed data lines with :meth:`feed`; :meth:`finish` returns times and per-sensor values.

    With ``online=True`` (a stream) :meth:`feed` returns the row's time in seconds and its
    quaternions at once, and keeps only the first and the previous row's time: memory stays
    constant however long the stream.
    """

    def __init__(self, layout: Layout, src: str, online: bool = False):
        self.lay = layout
        self.src = src
        self.online = online
        self.ncols = len(layout.names)
        self.tcol = layout.time.col
        self.unit = layout.time.unit
        self.tname = layout.time.name
        self.wrap = layout.time.wrap
        self.times: list[float] = []          # seconds (clock units); not kept online
        self.counts: list[int] = []           # unwrapped integers (counters, wrapping clocks); not kept online
        self.line_nos: list[int] = []         # not kept online
        self._n = 0                           # rows fed
        self._prev_ln = 0                     # line of the previous row
        self._prev_t: float | None = None     # time of the previous row (s)
        self._prev_u: int | None = None       # unwrapped count of the previous row
        self._first_u = 0                     # unwrapped count of the first row
        self.rows: list[list[int]] = [[] for _ in layout.sensors]
        self.values: list[list[tuple[float, ...]]] = [[] for _ in layout.sensors]
        self.dropped = [0] * len(layout.sensors)
        self._prev_text = ""
        self._prev_raw = 0
        self._offset = 0
        self._pending: tuple[int, int, int] | None = None
        self._step: int | None = None

    # -- fields -----------------------------------------------------------------------------------
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
            raise MocapFormatError(
                self.src, ln, f"expected {self.ncols} {_SEP_NAMES.get(d, repr(d))}-separated columns like the "
                + (f"header on line {self.lay.header_line}" if self.lay.header_index >= 0 else "first row")
                + f", got {shown}",
            )
        return fields

    # -- time -------------------------------------------------------------------------------------
    def _int(self, text: str, ln: int) -> int:
        try:
            return int(text)
        except ValueError:
            raise MocapFormatError(self.src, ln, f"column {self.tname}: {_short(text)} is not an integer") from None

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

    def _clock(self, text: str, ln: int) -> float:
        unit = self.unit
        try:
            if unit == "s":
                t = float(text)
            else:
                try:
                    raw: float | int = int(text)
                except ValueError:
                    raw = float(text)
                t = raw / TIME_UNITS[unit]  # type: ignore[index]
        except ValueError:
            raise MocapFormatError(self.src, ln, f"column {self.tname}: {_short(text)} is not a number") from None
        except OverflowError:
            raise MocapFormatError(self.src, ln, f"column {self.tname}: {_short(text)} is out of range") from None
        if math.isnan(t):
            raise MocapFormatError(self.src, ln, f"column {self.tname} is NaN")
        if math.isinf(t):
            raise MocapFormatError(self.src, ln, f"column {self.tname} is infinite ({_short(text)})")
        if self._prev_t is not None:
            prev = self._prev_t
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
        self._prev_text = text
        return t

    def _time(self, fields: list[str], ln: int) -> None:
        if self.tcol is None:
            return
        text = fields[self.tcol].strip().strip('"')
        t: float | None = None
        if self.unit == "counter" or self.wrap is not None:
            c = self._count(self._int(text, ln), ln)
            if self._prev_u is None:
                self._first_u = c
            self._prev_u = c
            if not self.online:
                self.counts.append(c)
            self._prev_raw = int(text)
            if self.unit != "counter":
                t = c / TIME_UNITS[self.unit]  # type: ignore[index]
        else:
            t = self._clock(text, ln)
        if t is not None:
            self._prev_t = t
            if not self.online:
                self.times.append(t)

    # -- values -----------------------------------------------------------------------------------
    def _values(self, fields: list[str], ln: int, k: int) -> tuple[float, ...] | None:
        o = self.lay.sensors[k]
        texts = [fields[c].strip().strip('"') for c in o.cols]
        if o.missing_rows == "drop" and any(not t for t in texts):
            return None
        out = []
        for text, name in zip(texts, o.names):
            try:
                v = float(text)
            except ValueError:
                raise MocapFormatError(self.src, ln, f"column {name}: {_short(text)} is not a number") from None
            if v != v:
                raise MocapFormatError(self.src, ln, f"column {name} is NaN")
            if v in (math.inf, -math.inf):
                raise MocapFormatError(self.src, ln, f"column {name} is infinite ({_short(text)})")
            out.append(v)
        if o.kind == "quaternion" and all(v * v == 0.0 for v in out):
            raise MocapFormatError(
                self.src, ln, f"zero-norm quaternion ({', '.join(o.names)} = {', '.join(repr(v) for v in out)})"
            )
        return tuple(out)

    def feed(self, line: str, ln: int) -> tuple[float, list[tuple[float, ...] | None]] | None:
        """Parse one data line (``ln`` 1-based). Online: return ``(time_s, per-sensor w,x,y,z or None)``."""
        if not line.strip():
            raise MocapFormatError(self.src, ln, "empty line inside the data (only trailing empty lines are allowed)")
        fields = self._fields(line, ln)
        vals = [self._values(fields, ln, k) for k in range(len(self.lay.sensors))]
        self._time(fields, ln)
        idx = self._n
        self._n += 1
        self._prev_ln = ln
        if not self.online:
            self.line_nos.append(ln)
        for k, v in enumerate(vals):
            if v is None:
                self.dropped[k] += 1
            elif not self.online:
                self.rows[k].append(idx)
                self.values[k].append(v)
        if not self.online:
            return None
        return self._online_time(idx, ln), [
            None if v is None else v if self.lay.sensors[k].kind == "quaternion" else self._convert(k, [v], [ln])[0][0]
            for k, v in enumerate(vals)
        ]

    def _online_time(self, idx: int, ln: int) -> float:
        if self.unit not in ("counter", None):
            return self._prev_t  # type: ignore[return-value]
        rate = self.lay.rate
        if self.unit is None:
            return idx / rate  # type: ignore[operator]
        if self._step is None and idx >= 1:
            self._step = self._prev_u - self._first_u  # type: ignore[operator]
        t = (self._prev_u - self._first_u) / (rate * (self._step or 1))  # type: ignore[operator]
        if idx and not (t > self._last_online):
            raise MocapFormatError(self.src, ln, f"time {t!r} s from {self.tname} is not after the previous row")
        self._last_online = t
        return t

    _last_online = -math.inf

    # -- results ----------------------------------------------------------------------------------
    def _convert(self, k: int, values, line_nos) -> tuple[np.ndarray, str | None]:
        o = self.lay.sensors[k]
        arr = np.array(values, dtype=np.float64).reshape(len(values), len(o.cols))
        if o.kind == "matrix":
            return quaternions_from_matrices(arr, self.src, line_nos, o.names)
        if o.kind == "euler":
            return quaternions_from_euler(arr, o.degrees, o.names)
        return arr, None

    def _implausible_rate(self, times: list[float]) -> str | None:
        """A warning when a guessed time unit gives a rate outside :data:`PLAUSIBLE_RATE`."""
        if self.lay.time.stated or len(times) < 2:
            return None
        dt = float(np.median(np.diff(np.asarray(times, dtype=np.float64))))
        lo, hi = PLAUSIBLE_RATE
        rate = 1.0 / dt
        if lo <= rate <= hi:
            return None
        hint = " (milliseconds read as seconds give 1/1000 of the rate)" if self.unit == "s" and rate < lo else ""
        return (f"column {self.tname!r} has no unit and was read in {self.unit}: its median sample interval "
                f"{dt:.6g} s gives {rate:.6g} Hz, outside the {lo:g}-{hi:g} Hz of orientation sensors{hint}; "
                "if that is not its unit, give --time-unit s|ms|us|ns")

    def finish(self) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray, str | None]], list[str]]:
        """``(times of all rows, [(row indices, (M, 4) w,x,y,z, conversion) per sensor], warnings)``."""
        if not self.line_nos:
            raise MocapFormatError(self.src, self.lay.header_line, "header only: no data rows after the header")
        warnings: list[str] = []
        n = len(self.line_nos)
        rate = self.lay.rate
        if self.unit in ("counter", None):
            if self.unit is None:
                times = [i / rate for i in range(n)]  # type: ignore[operator]
            else:
                step = 1
                if n > 1:
                    tally = Counter(b - a for a, b in zip(self.counts, self.counts[1:]))
                    step = min(tally, key=lambda s: (-tally[s], s))
                if step != 1:
                    warnings.append(
                        f"{self.tname} steps by {step} between rows: read as one sample every {step} counts at "
                        f"{rate:g} Hz (t = (counter - first) / ({rate:g} * {step}))"
                    )
                first = self.counts[0]
                try:
                    times = [(u - first) / (rate * step) for u in self.counts]  # type: ignore[operator]
                except OverflowError:
                    raise MocapFormatError(self.src, None, f"{self.tname} values are too large") from None
            for i in range(1, n):
                if not (times[i] > times[i - 1]) or not math.isfinite(times[i]):
                    raise MocapFormatError(
                        self.src, self.line_nos[i], f"time {times[i]!r} s (from the sample rate {rate:g} Hz) is "
                        f"not after {times[i - 1]!r} s on line {self.line_nos[i - 1]}",
                    )
        else:
            times = self.times
            note = self._implausible_rate(times)
            if note:
                warnings.append(note)
        out = []
        for k, o in enumerate(self.lay.sensors):
            if not self.rows[k]:
                raise MocapFormatError(self.src, None, f"{o.sensor or 'the orientation'} has no complete row "
                                       f"(columns {', '.join(o.names)})")
            q, how = self._convert(k, self.values[k], [self.line_nos[i] for i in self.rows[k]])
            out.append((np.array(self.rows[k], dtype=np.intp), q, how))
        return np.array(times, dtype=np.float64), out, warnings
