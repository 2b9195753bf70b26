"""IMU panels of the scene: per sensor the original orientations, their SLERP decode from the compressed
points (a ``.mkp`` packet file or the points CSV ``decompress`` writes), the angle between the two
(Eq. 2 of the fastSW paper) and the points' times (the keyframes)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.view.arrays import encode_array

#: the header ``mocapkit decompress X.mkp -o POINTS.csv`` writes
POINTS_HEADER = ("time", "w", "x", "y", "z", "tick", "gap_before")


def is_points_csv(path: Path) -> bool:
    """A points CSV of ``decompress`` (its first line is :data:`POINTS_HEADER`)."""
    if path.suffix.lower() != ".csv" or not path.is_file():
        return False
    with open(path, "rb") as fh:
        head = fh.readline(256).decode("utf-8", "replace").strip()
    return tuple(c.strip() for c in head.split(",")) == POINTS_HEADER


#: The header of the points CSV that ``compress -o`` writes (the kept samples at their own times).
COMPRESS_POINTS_HEADER = ("time", "w", "x", "y", "z")


def is_compress_points(path: Path) -> bool:
    """A CSV with exactly the header of ``compress -o`` (``time,w,x,y,z``): maybe the points of an original."""
    if path.suffix.lower() != ".csv" or not path.is_file():
        return False
    with open(path, "rb") as fh:
        head = fh.readline(256).decode("utf-8", "replace").strip().lstrip("\ufeff")
    return tuple(c.strip().lower() for c in head.split(",")) == COMPRESS_POINTS_HEADER


def points_of(signal, original_times: np.ndarray) -> Points | None:
    """``signal`` as the segment points of a recording sampled at ``original_times``, when it is one:
    fewer samples, the same first and last time, every time one of the original's (``compress -o`` writes
    the kept samples' times as they were read); else ``None``."""
    t = np.asarray(signal.times, dtype=np.float64)
    ot = np.asarray(original_times, dtype=np.float64)
    if not (2 <= len(t) < len(ot)) or t[0] != ot[0] or t[-1] != ot[-1]:
        return None
    ticks = np.searchsorted(ot, t)
    if np.any(ticks >= len(ot)) or not np.array_equal(ot[np.minimum(ticks, len(ot) - 1)], t):
        return None
    return Points(signal.name, ticks, signal.values, np.zeros(len(t), dtype=bool), None, None, times=t, in_time=True)


class Points:
    """One sensor's compressed points: ticks (sample indices), unit quaternions, lost-packet marks and
    the times of the ticks when the file has them (``times_of(ticks)`` otherwise from rate and t0);
    ``samples``: the stream's sample count when the file says (a ``.mkp`` stream whose end arrived)."""

    def __init__(self, name: str, ticks, values, gap_before, t0: float | None, rate: float | None,
                 times=None, bound_deg: float | None = None, samples: int | None = None, in_time: bool = False):
        self.name, self.t0, self.rate, self.bound_deg, self.samples = name, t0, rate, bound_deg, samples
        self.in_time = in_time  # decoded by SLERP in time (the kept samples of ``compress -o``), not in ticks
        self.ticks = np.asarray(ticks, dtype=np.float64)
        self.values = np.asarray(values, dtype=np.float64)
        self.gap_before = np.asarray(gap_before, dtype=bool)
        self.times = None if times is None else np.asarray(times, dtype=np.float64)

    def own_times(self, ticks: np.ndarray) -> np.ndarray:
        if self.times is not None and len(self.ticks) > 1 and np.array_equal(ticks, self.ticks):
            return self.times
        if self.rate is None:  # a points CSV: times of the points, linear between them
            assert self.times is not None  # points without a rate are built with their times
            return np.interp(ticks, self.ticks, self.times)
        assert self.t0 is not None  # a packet stream's points have its rate and start time
        return self.t0 + ticks / self.rate


def read_packets(path: Path) -> tuple[dict[str, Points], list[str]]:
    """The points of every stream of a ``.mkp`` file and the reader's losses (damaged packets are dropped by the reader
    and the points after a lost packet are marked, so the decode never bridges a gap)."""
    from mocapkit.jobs.readers import read_mkp

    pf = read_mkp(path)
    return {name: Points(name, s.ticks, s.values, s.gap_before, s.sensor.t0, s.sensor.rate,
                         bound_deg=pf.header.max_angle_deg, samples=s.samples)
            for name, s in pf.streams.items()}, pf.losses()


def read_points_csv(path: Path) -> tuple[dict[str, Points], list[str]]:
    """The points CSV of ``decompress`` (one sensor, named after the file)."""
    from mocapkit.io.text.timetable import read_time_table

    tab = read_time_table(path, "points CSV")
    col = {c: tab.values[:, k] for k, c in enumerate(tab.columns)}
    if np.isnan(tab.values).any():
        raise MocapFormatError(str(path), None, "a points CSV has no missing values")
    ticks = col["tick"]
    if np.any(ticks != np.round(ticks)) or np.any(np.diff(ticks) <= 0):
        raise MocapFormatError(str(path), None, "the tick column must hold increasing whole sample indices")
    q = np.column_stack([col["w"], col["x"], col["y"], col["z"]])
    bad = np.flatnonzero(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-3)
    if len(bad):
        k = int(bad[0])
        raise MocapFormatError(str(path), _line_of_row(path, k), f"point {k + 1}: {q[k].tolist()} is not a unit "
                               "quaternion (norm 1 within 1e-3)")
    return {path.stem: Points(path.stem, ticks, q, col["gap_before"] != 0, None, None, times=tab.times)}, []


def _line_of_row(path: Path, k: int) -> int | None:
    """The line of the ``k``-th data row (0-based) of a points CSV: the ``k + 1``-th non-blank line after the header."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        rows = (i for i, line in enumerate(fh, start=1) if i > 1 and line.strip())
        return next((i for j, i in enumerate(rows) if j == k), None)


def decode(points: Points, n: int | None, at_times: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(ticks, decoded (m, 4) with NaN rows where a gap is not bridged, keyframe ticks)`` at every
    sample ``0..n-1`` of the original (or from the first to the last point without one). ``at_times``:
    the original's sample times, used for points read ``in_time`` (``compress -o``): SLERP in time, as
    ``decompress --times-from`` decodes them (irregular clocks included)."""
    from mocapkit.jobs.packets import decode_at

    if len(points.ticks) == 0:
        m = 0 if n is None else n
        return np.arange(m, dtype=np.float64), np.full((m, 4), np.nan), points.ticks
    u = (np.arange(n, dtype=np.float64) if n is not None
         else np.arange(points.ticks[0], points.ticks[-1] + 1, dtype=np.float64))
    if at_times is not None and points.in_time:
        assert points.times is not None  # points read in time are built with their times
        keep, vals = decode_at(points.times, points.values, points.gap_before, np.asarray(at_times, np.float64))
    else:
        keep, vals = decode_at(points.ticks, points.values, points.gap_before, u)
    out = np.full((len(u), 4), np.nan)
    out[keep] = vals
    return u, out, points.ticks


def sensor_entry(name: str, times, original, decoded, keyframes, bound_deg) -> dict:
    """One sensor of an IMU panel (docs/viewer.md)."""
    from mocapkit.quat import angular_distance

    err = None
    if original is not None and decoded is not None:
        err = np.full(len(original), np.nan)
        ok = ~np.isnan(decoded).any(axis=1)
        if ok.any():
            err[ok] = angular_distance(np.asarray(original)[ok], decoded[ok], degrees=True)
    finite = None if err is None or not np.isfinite(err).any() else float(np.nanmax(err))
    return {"name": name, "times": encode_array(times, "float64"),
            "original": None if original is None else encode_array(original),
            "decoded": None if decoded is None else encode_array(decoded),
            "error_deg": None if err is None else encode_array(err),
            "keyframes": encode_array(np.asarray(keyframes, dtype=np.float64), "float64"),
            "bound_deg": bound_deg, "max_error_deg": finite}


def imu_panel(pid: str, path: Path, sensors: list[dict], times) -> dict:
    return {"id": pid, "kind": "imu", "file": str(path), "name": path.name, "up": "z",
            "times": encode_array(times, "float64"), "sensors": sensors}
