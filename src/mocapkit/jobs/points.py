"""``mocapkit decompress POINTS.csv``: segment points back to a full-rate quaternion signal by SLERP.

A points CSV states its clock by its columns (docs/mkp.md, "Time"):

- ``time,w,x,y,z`` (``compress -o``, ``stream``): the points are on the original's own clock, so they
  are decoded at ``--times-from ORIGINAL``'s times, or on a ``--rate HZ`` grid of that clock;
- ``time,w,x,y,z,tick,gap_before`` (``decompress X.mkp -o``): the points' clock is ``tick``, the index of
  the original sample; ``time`` is only the stream's nominal ``t0 + tick / rate``. With ``--times-from``
  the points are decoded at the original's sample indices, as the ``.mkp`` itself is, and written at
  its times; an original of another sample count is refused. ``--rate HZ`` is a grid of the nominal
  clock, as for the ``.mkp``. A marked lost packet (``gap_before``) is refused: the decode would bridge it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, MocapError, MocapFormatError

#: the points CSV of a ``.mkp`` file: its clock is the tick column; a lost packet is marked in gap_before
TICK_COLUMN, GAP_COLUMN = "tick", "gap_before"


def decompress_points_job(points: Path, output: Path, *, times_from: Path | None = None, rate: float | None = None,
                          time_column: str | None = None, quaternion_columns: str | None = None,
                          scalar_last: bool = False, time_unit: str | None = None) -> dict:
    """Decode a points CSV at ``times_from``'s samples or on a ``rate`` Hz grid into ``output``
    (``time,w,x,y,z``); returns the record (``points``, ``samples``, ``clock``, the readers' ``warnings``)."""
    from mocapkit.io import read_imu_csv, write_signal_csv
    from mocapkit.jobs.common import imu_columns, output_entry

    points, output = Path(points), Path(output)
    if times_from is None and rate is None:
        raise InvalidParameterError("give --times-from ORIGINAL or --rate HZ")
    pts = read_imu_csv(points)
    warnings = [f"{pts.source}: {w}" for w in pts.meta.get("warnings", [])]
    header = [c.strip() for c in str(pts.meta.get("header", "")).split(",")]
    ticks = None
    if TICK_COLUMN in header or GAP_COLUMN in header:
        ticks = _mkp_columns(points, header, len(pts), need=times_from is not None)
    if times_from is not None:
        orig = _original(times_from, points, rate, imu_columns(time_column, quaternion_columns, scalar_last, time_unit))
        warnings += [f"{orig.source}: {w}" for w in orig.meta.get("warnings", [])]
        t = orig.times
        if ticks is not None:
            _check_same_samples(points, ticks, times_from, len(orig))
    else:
        assert rate is not None  # checked above: --times-from or --rate
        t = _grid(pts.times, rate)
    on_ticks = ticks is not None and times_from is not None
    vals = _decode(points, pts, (ticks, np.arange(len(t))) if on_ticks and ticks is not None else (pts.times, t))
    write_signal_csv(output, t, vals)
    return {"job": "decompress", "file": str(points), "kind": "imu", "mode": "samples",
            "clock": "ticks" if on_ticks else "time",
            "points": len(pts), "samples": len(t), "warnings": warnings, "outputs": [output_entry(output, "csv")]}


def _mkp_columns(points: Path, header: list[str], n: int, *, need: bool) -> np.ndarray | None:
    """The refusal of a point marked ``gap_before`` and the ``tick`` column (whole, increasing sample
    indices, one per point), or ``None`` without one or when a pipe cannot be read twice and the ticks are
    not needed."""
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.io.text.numbers import parse_number
    from mocapkit.pla.packet_layout import TICK_LIMIT

    col = header.index(TICK_COLUMN) if TICK_COLUMN in header else None
    gap = header.index(GAP_COLUMN) if GAP_COLUMN in header else None
    if is_device_or_pipe(points):  # read once already
        if need and col is not None:
            raise InvalidParameterError(f"{points}: a points CSV with a tick column is decoded at ORIGINAL's samples "
                                        "from a file, not a pipe: save it to a file first")
        return None
    src = str(points)
    ticks = np.empty(n, dtype=np.int64)
    k = 0
    with open(points, encoding="utf-8", errors="replace", newline="") as fh:
        for line, text in enumerate(fh, start=1):
            if line == 1 or not text.strip():
                continue
            cells = text.rstrip("\r\n").split(",")
            if k >= n or len(cells) <= max(col or 0, gap or 0):
                raise MocapFormatError(src, line, "the row does not hold a point's tick and gap_before")
            if gap is not None and cells[gap].strip() not in ("", "0"):
                raise InvalidParameterError(
                    f"{points}:{line}: this point follows a lost packet (gap_before = {cells[gap].strip()}); a "
                    "decode of the points would bridge the gap: decompress the .mkp file itself")
            if col is not None:
                v = parse_number(cells[col].strip(), src, line, TICK_COLUMN)
                if not (v == math.floor(v) and 0 <= v < TICK_LIMIT):
                    raise MocapFormatError(src, line, f"tick {cells[col].strip()!r} is not a sample index (a whole "
                                                      f"number in 0..{TICK_LIMIT - 1})")
                if k and not v > ticks[k - 1]:
                    raise MocapFormatError(src, line, f"tick {int(v)} is not after the previous point's tick "
                                                      f"{int(ticks[k - 1])}")
                ticks[k] = int(v)
            k += 1
    if k != n:
        raise MocapFormatError(src, None, f"{k} rows of ticks for {n} points")
    return ticks if col is not None else None


def _original(times_from: Path, points: Path, rate: float | None, columns: dict):
    """The one signal of ``times_from``; of several, the one named like the points file (``NAME.csv``)."""
    from mocapkit.io import load_signals

    originals = load_signals(times_from, rate=rate, **columns)
    if len(originals) == 1:
        return next(iter(originals.values()))
    if points.stem in originals:
        return originals[points.stem]
    raise InvalidParameterError(
        f"{times_from} holds {len(originals)} signals ({', '.join(list(originals)[:6])}): pick the one the "
        "points came from with --quaternion-columns (e.g. its W,X,Y,Z column names), or name the points file "
        "after it (NAME.csv)")


def _check_same_samples(points: Path, ticks: np.ndarray, times_from: Path, n: int) -> None:
    """The points of a ``.mkp`` stream are at ticks 0..n-1 of the recording they came from."""
    first, last = int(ticks[0]), int(ticks[-1])
    if first != 0 or last != n - 1:
        raise InvalidParameterError(
            f"{points}: its points are at ticks {first}..{last} (sample indices of the recording they came from), "
            f"but {times_from} has samples 0..{n - 1}: it is not that recording, read the same way, or the stream "
            "lost its start or end; decompress the .mkp file itself with --times-from")


def _grid(times: np.ndarray, rate: float) -> np.ndarray:
    span = float(times[-1] - times[0])
    n_float = math.floor(span * rate + 1e-9) + 1.0 if math.isfinite(span * rate) else math.inf
    if n_float > 50_000_000:
        raise InvalidParameterError(f"--rate {rate:g} over {span:g} s gives {n_float:g} samples; too many")
    t = np.minimum(times[0] + np.arange(int(n_float)) / rate, times[-1])  # not past the last point by rounding
    if t.shape[0] > 1 and not np.all(np.diff(t) > 0):
        raise InvalidParameterError(f"--rate {rate:g}: the grid's steps vanish in the rounding of times near "
                                    f"{float(times[0]):g} s; give a lower rate")
    return t


def _decode(points: Path, pts, clock: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """SLERP of the points at ``clock = (the points' clock values, where to decode on that clock)``: times,
    or ticks and the original's sample indices."""
    from mocapkit.pla.decode import reconstruct_points, unit_quaternions

    at, where = (np.asarray(c, dtype=np.float64) for c in clock)
    try:
        if len(pts) == 1:  # one point: that orientation at every time
            vals = np.repeat(unit_quaternions(pts.values), len(where), axis=0)
        else:
            vals = reconstruct_points(at, pts.values, where, "quaternion")
    except InvalidParameterError as e:
        raise InvalidParameterError(f"{points}: {e}") from None
    norms = np.sqrt(np.einsum("ij,ij->i", vals, vals)) if len(vals) else np.ones(0)
    if not (np.all(np.isfinite(vals)) and np.all(np.abs(norms - 1.0) < 1e-9)):  # never a zero-norm or NaN row
        raise MocapError(f"{points}: the decoded quaternions are not all finite unit quaternions "
                         "(a bug: please report)")
    return vals
