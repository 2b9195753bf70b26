"""Line-by-line parsing of an IMU CSV stream (``mocapkit stream`` reads stdin with it).

Accepts the comma-separated headers of :mod:`mocapkit.io.imucsv` (x-io, NGIMU, legacy x-io with a
rate, generic ``time,w,x,y,z``) or, when the first line is numeric, headerless ``time,w,x,y,z``
rows. Every problem raises :class:`~mocapkit.errors.MocapFormatError` with the line number, after
the samples before it have been yielded (so a live consumer has already used them).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

from mocapkit.errors import MocapFormatError
from mocapkit.io.imucsv import ACCEPTED_HEADERS, _identify


def _is_numeric_row(fields: list[str]) -> bool:
    try:
        [float(f) for f in fields]
    except ValueError:
        return False
    return True


def iter_samples(
    lines: Iterable[str], source: str = "<stdin>", rate: float | None = None
) -> Iterator[tuple[int, float, tuple[float, float, float, float]]]:
    """Yield ``(line_number, time_s, (w, x, y, z))`` for each data row of a CSV stream."""
    time_kind = "s"
    tcol, qcols = 0, (1, 2, 3, 4)
    ncols = 5
    first_counter = None
    last_t = None
    last_line = None
    started = False
    for lineno, raw in enumerate(lines, start=1):
        line = raw.strip().lstrip("\ufeff")
        if not line:
            continue
        fields = [f.strip() for f in line.split(",")]
        if not started:
            started = True
            if not _is_numeric_row(fields):
                lay = _identify(line)
                if lay is None or lay.delim != ",":
                    raise MocapFormatError(
                        source, lineno,
                        f"unrecognised header {line[:80]!r}; expected one of: " + "; ".join(ACCEPTED_HEADERS[:3])
                        + "; " + ACCEPTED_HEADERS[4] + " (or headerless time,w,x,y,z rows)",
                    )
                time_kind, tcol, qcols, ncols = lay.time_kind, lay.time_col, lay.quat_cols, len(lay.names)
                if time_kind == "counter" and rate is None:
                    raise MocapFormatError(source, lineno, "this format has no timestamps: give --rate HZ")
                if time_kind != "counter" and rate is not None:
                    raise MocapFormatError(source, lineno, "this format has timestamps: do not give --rate")
                continue
        if len(fields) != ncols:
            raise MocapFormatError(source, lineno, f"expected {ncols} columns, got {len(fields)}")
        try:
            nums = [float(f) for f in fields]
        except ValueError:
            bad = next(f for f in fields if not _is_numeric_row([f]))
            raise MocapFormatError(source, lineno, f"{bad[:40]!r} is not a number") from None
        if not all(math.isfinite(v) for v in nums):
            raise MocapFormatError(source, lineno, "NaN or infinite value")
        if time_kind == "us":
            t = nums[tcol] / 1e6
        elif time_kind == "counter":
            if nums[tcol] < 0 or nums[tcol] != int(nums[tcol]):
                raise MocapFormatError(source, lineno, f"packet number {fields[tcol]!r} is not a non-negative integer")
            if first_counter is None:
                first_counter = nums[tcol]
            t = (nums[tcol] - first_counter) / rate
        else:
            t = nums[tcol]
        q = (nums[qcols[0]], nums[qcols[1]], nums[qcols[2]], nums[qcols[3]])
        if q == (0.0, 0.0, 0.0, 0.0):
            raise MocapFormatError(source, lineno, "zero-norm quaternion")
        if last_t is not None and t <= last_t:
            what = "duplicate timestamp" if t == last_t else "timestamp goes backwards"
            raise MocapFormatError(
                source, lineno, f"{what}: time {t!r} is not after {last_t!r} on line {last_line}"
            )
        last_t, last_line = t, lineno
        yield lineno, t, q
