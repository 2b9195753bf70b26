"""``.mkp`` radio packets read back: ``mocapkit decompress OUT.mkp`` (the points, or the full-rate SLERP decode,
never across a lost packet) and the decode both it and the compress job
(:mod:`mocapkit.jobs.packet_compress`) use."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import imu_columns, output_entry, sensor_outputs

#: bytes per sample of the raw stream a packet stream is compared with: four float32
RAW_SAMPLE_BYTES = 16
#: the rate of the second raw reference stream (the issue's 100 Hz)
RAW_REFERENCE_HZ = 100.0
#: points CSV columns (decompress without --times-from / --rate)
POINT_COLUMNS = ("time", "w", "x", "y", "z", "tick", "gap_before")


def nominal_rate(sig) -> float:
    """The sensor's sample rate: the file's stated rate, else one over the median sample step (a log's
    dropped samples do not lower it)."""
    r = sig.meta.get("rate")
    if r is not None and math.isfinite(float(r)) and float(r) > 0:
        return float(r)
    if len(sig) > 1:
        return float(1.0 / np.median(np.diff(sig.times)))
    return 1.0


def decode_at(ticks: np.ndarray, values: np.ndarray, gap_before: np.ndarray, u: np.ndarray):
    """SLERP decode of one sensor's points at (fractional) ticks ``u`` (increasing), never across a gap.

    Returns ``(keep, quaternions)``: ``keep`` marks the ``u`` that lie on a point or between two
    consecutive points with no lost packet between them; the quaternions are those samples' decode.
    """
    from mocapkit.pla.decode import reconstruct_points

    u = np.asarray(u, dtype=np.float64)
    keep = np.zeros(u.shape[0], dtype=bool)
    out = []
    if len(ticks) == 0:
        return keep, np.empty((0, 4))
    starts = np.flatnonzero(gap_before).tolist()
    bounds = sorted(set([0] + starts + [len(ticks)]))
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        lo, hi = float(ticks[a]), float(ticks[b - 1])
        i0, i1 = np.searchsorted(u, lo, "left"), np.searchsorted(u, hi, "right")
        if i1 > i0:
            keep[i0:i1] = True
            out.append(reconstruct_points(ticks[a:b].astype(np.float64), values[a:b], u[i0:i1], "quaternion"))
    return keep, (np.concatenate(out) if out else np.empty((0, 4)))


def _originals(times_from: Path, names: list[str], rate, columns) -> dict:
    from mocapkit.io import load_signals

    orig = load_signals(times_from, rate=rate, **columns)
    if len(names) == 1 and len(orig) == 1:
        return {names[0]: next(iter(orig.values()))}
    missing = [n for n in names if n not in orig]
    if missing:
        raise InvalidParameterError(f"{times_from} has no sensor {', '.join(missing[:6])} (it holds "
                                    f"{', '.join(list(orig)[:6])})")
    return {n: orig[n] for n in names}


def _presented(q: np.ndarray) -> np.ndarray:
    """The points as written: smallest-three makes the dropped component positive, so a decoded point may
    be the negation of the sensor's; the same rotations are shown with w >= 0 at the first point and no
    sign jump after it (negation is exact; the SLERP decode takes the shortest arc either way)."""
    from mocapkit.quat import hemisphere_continuous

    q = hemisphere_continuous(q)
    return -q if len(q) and q[0, 0] < 0 else q


def _check_against_original(decoded: np.ndarray, original: np.ndarray, bound_deg: float, times_from: Path,
                            name: str) -> None:
    """Refuse an ORIGINAL the stream was not made from: its decode must lie within the stream's own
    ``max_angle`` of every sample (a recording of the same length but other motion would pass the tick
    checks unnoticed)."""
    from mocapkit.quat import angular_distance

    if not len(decoded):
        return
    err = angular_distance(decoded, original / np.linalg.norm(original, axis=1, keepdims=True), degrees=True)
    worst = int(np.argmax(err))
    if err[worst] > bound_deg * (1 + 1e-9) + 1e-9:
        raise InvalidParameterError(
            f"{times_from}: {name}: the stream decodes {float(err[worst]):.3g} deg away from this recording's "
            f"sample {worst}, beyond the stream's own bound of {bound_deg:g} deg: it was not made from this "
            "recording")


def decompress_packets_job(path: Path, output: Path, *, times_from: Path | None = None, rate: float | None = None,
                           time_column: str | None = None, quaternion_columns: str | None = None,
                           scalar_last: bool = False, time_unit: str | None = None) -> dict:
    """Read a ``.mkp`` file back: the points as CSV ``time,w,x,y,z,tick,gap_before`` (no ``times_from``
    nor ``rate``), or the full-rate SLERP decode ``time,w,x,y,z`` at the ticks of ``times_from``'s samples
    or on a ``rate`` Hz grid. Samples between points separated by a lost packet are left out (counted
    in ``samples_left_out``), never bridged. Several sensors go to a folder (``output``/NAME.csv)."""
    from mocapkit.io import write_signal_csv
    from mocapkit.io.atomic import atomic_write_text, is_device_or_pipe
    from mocapkit.io.imu.signals import format_row
    from mocapkit.jobs.readers import read_mkp
    from mocapkit.pla.packet_layout import MIN_STEP

    path, output = Path(path), Path(output)
    pf = read_mkp(path)
    names = list(pf.streams)
    folder = len(names) > 1 or output.is_dir()
    if folder and output.exists() and not output.is_dir():
        raise InvalidParameterError(f"{output}: {path} holds {len(names)} sensors, so --output must be a folder")
    if folder and output.suffix.lower() == ".csv":
        raise InvalidParameterError(f"{output}: {path} holds {len(names)} sensors, so --output is a folder "
                                    "(one CSV per sensor), not a .csv file")
    if not folder and output.suffix.lower() != ".csv" and not is_device_or_pipe(output):
        raise InvalidParameterError(f"{output}: decoded points and samples are written as .csv")
    dests: dict[str, Path] = {name: output for name in names}
    warnings: list[str] = []
    if folder:
        dests, warnings = sensor_outputs(output, names, path, inputs=[times_from])
    originals = None
    if times_from is not None:
        originals = _originals(times_from, names, rate, imu_columns(time_column, quaternion_columns, scalar_last,
                                                                    time_unit))
    records: list[dict] = []
    outputs: list[dict] = []
    written: dict[str, str | tuple[np.ndarray, np.ndarray]] = {}  # a points CSV's text, or (times, samples)
    for name, s in pf.streams.items():
        rec = {"name": name, "points": len(s.ticks), "packets": s.packets, "lost_sequence_numbers": s.lost,
               "ended": s.ended, "gaps": int(s.gap_before.sum()), "samples_left_out": 0}
        r = s.sensor.rate
        if len(s.ticks) == 0:
            raise InvalidParameterError(f"{path}: no point of sensor {name} arrived")
        values = _presented(s.values)
        if originals is None and rate is None:  # the clock is the tick column; time = t0 + tick / rate
            rows = [format_row(t, v) + f",{int(k)},{int(g)}" for t, k, v, g in
                    zip(s.sensor.nominal_times(s.ticks).tolist(), s.ticks.tolist(), values.tolist(),
                        s.gap_before.tolist(), strict=True)]
            written[name] = ",".join(POINT_COLUMNS) + "\n" + "".join(x + "\n" for x in rows)
            records.append(rec)
            continue
        if originals is not None:
            orig = originals[name]
            n = len(orig)
            if s.samples is not None and s.samples != n:
                raise InvalidParameterError(f"{times_from}: {name} has {n} samples, the packet stream {s.samples}")
            if s.ticks[-1] >= n:
                raise InvalidParameterError(f"{times_from}: {name} has {n} samples, the packet stream reaches "
                                            f"tick {int(s.ticks[-1])}")
            u = np.arange(n, dtype=np.float64)
            times = orig.times
        else:  # a grid on the stream's nominal clock, made in ticks: at --rate = the stream's rate, on every tick
            assert rate is not None  # no ORIGINAL and no --rate left on the tick clock above
            step = r / rate
            m = math.floor((float(s.ticks[-1]) - float(s.ticks[0])) / step + 1e-9) + 1
            if m > 50_000_000:
                raise InvalidParameterError(f"--rate {rate:g} over {(s.ticks[-1] - s.ticks[0]) / r:g} s gives {m} "
                                            "samples; too many")
            u = np.minimum(float(s.ticks[0]) + np.arange(m) * step, float(s.ticks[-1]))  # not past it by rounding
            times = s.sensor.nominal_times(u)
            if m > 1 and not np.diff(times).min() >= MIN_STEP:
                raise InvalidParameterError(f"--rate {rate:g}: the grid's steps vanish in the rounding of times near "
                                            f"{float(times[0]):g} s; give a lower rate")
        keep, vals = decode_at(s.ticks, values, s.gap_before, u)
        if originals is not None and times_from is not None:
            _check_against_original(vals, originals[name].values[keep], pf.header.max_angle_deg, times_from, name)
        rec["samples"] = int(keep.sum())
        rec["samples_left_out"] = int((~keep).sum())
        written[name] = (times[keep], vals)
        records.append(rec)
    if folder:
        output.mkdir(exist_ok=True)
    for name, what in written.items():
        dest = dests[name]
        if isinstance(what, str):
            atomic_write_text(dest, what)
        else:
            write_signal_csv(dest, *what)
        outputs.append(output_entry(dest, "csv"))
    return {"job": "decompress", "file": str(path), "kind": "imu",
            "mode": "points" if originals is None and rate is None else "samples",
            "bits": pf.header.bits, "max_angle": pf.header.max_angle_deg,
            "lost_packets": pf.lost_packets, "damaged_packets": len(pf.damaged), "losses": pf.losses(),
            "sensors": records, "outputs": outputs, "warnings": warnings}
