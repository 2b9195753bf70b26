"""The ``compress`` job of ``.mkp`` radio packets (``mocapkit compress IMU --max-angle DEG -o OUT.mkp``): every
sensor through the C packetiser into one file, the written file decoded and its bound checked on every sample."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mocapkit.errors import BoundViolationError, InvalidParameterError
from mocapkit.jobs.common import (
    Progress,
    check_outputs,
    imu_columns,
    no_progress,
    output_entry,
    recording,
)
from mocapkit.jobs.compress_kinds import PacketCompressOptions, compress_options
from mocapkit.jobs.packets import (
    RAW_REFERENCE_HZ,
    RAW_SAMPLE_BYTES,
    decode_at,
    nominal_rate,
)


def compress_packets_job(path: Path, output: Path, *, progress: Progress = no_progress, **given) -> dict:
    """:func:`compress_packets` with the options given by name (``max_angle``, ``packet_bits``...), built by
    :func:`mocapkit.jobs.compress_kinds.compress_options`."""
    options = compress_options("packets", output, **given)
    return compress_packets(path, options, output=output, progress=progress)


def compress_packets(path: Path, options: PacketCompressOptions, *, output: Path,
                     progress: Progress = no_progress) -> dict:
    """Every sensor of the IMU input ``path`` through the C packetiser into the ``.mkp`` file ``output``.

    The packets of all sensors are stored in the order a receiver would get them (by the time of the
    sample whose push sent them). The written file is read back and decoded at every sample: a
    sample further than ``max_angle`` from its original is a :class:`BoundViolationError` (a bug).
    """
    from mocapkit.io import load_signals
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.io.formats.mkp import write_mkp
    from mocapkit.jobs.readers import read_mkp
    from mocapkit.pla.packet_layout import Header, Sensor, delta_bound, mkp_bytes
    from mocapkit.pla.packets import DEFAULT_MAXLEN, default_bits, packetise
    from mocapkit.quat import angular_distance

    o = options
    max_angle, packet_bytes, precision = o.max_angle, o.packet_bytes, o.precision
    path, output = Path(path), Path(output)
    bits = default_bits(max_angle) if o.packet_bits is None else o.packet_bits
    maxlen = DEFAULT_MAXLEN if o.max_segment_length is None else o.max_segment_length
    from mocapkit.io.loaders import kind_of

    if kind_of(path) != "imu":
        raise InvalidParameterError(f"{output}: a .mkp packet stream holds IMU orientation streams; {path} is not one")
    check_outputs(path, (output, "--output"))
    if output.is_dir():
        raise InvalidParameterError(f"{output}: a packet stream is one file (.mkp), not a folder")
    signals = load_signals(path, rate=o.rate, **imu_columns(o.time_column, o.quaternion_columns, o.scalar_last,
                                                            o.time_unit))
    if len(signals) > 255:
        raise InvalidParameterError(f"{path}: {len(signals)} sensors; a packet file holds at most 255")
    sensors, per = [], []
    sent: list[tuple[float, int, int, bytes]] = []
    with progress(f"packetising {path.name}", len(signals)) as update:
        for sid, (name, sig) in enumerate(signals.items()):
            if sig.kind != "quaternion":
                raise InvalidParameterError(f"{sig.source}: {name} is not a quaternion signal")
            r = nominal_rate(sig)
            sensors.append(Sensor(name, r, float(sig.times[0])))
            pk = packetise(sig.values, max_angle, bits=bits, packet_bytes=packet_bytes, max_segment_length=maxlen,
                           sensor=sid, precision=precision)
            at = sig.times[np.minimum(pk.sent_at, len(sig) - 1)]
            sent.extend((float(t), sid, k, p) for k, (t, p) in enumerate(zip(at, pk.packets, strict=True)))
            per.append(pk)
            update(sid + 1)
    sent.sort(key=lambda x: (x[0], x[1], x[2]))
    header = Header(bits, packet_bytes, float(max_angle), maxlen, tuple(sensors))
    data = mkp_bytes(header, [p for *_, p in sent])
    write_mkp(output, data)
    back = read_mkp(output) if not is_device_or_pipe(output) else read_mkp(output, data=data)
    records: list[dict] = []
    for (name, sig), pk in zip(signals.items(), per, strict=True):
        s = back.streams[name]
        if not (np.array_equal(s.ticks, pk.ticks) and np.array_equal(s.codes, pk.codes)) or back.lost_packets:
            raise BoundViolationError(f"{output}: {name}: the file does not give back the points the packetiser sent")
        keep, dec = decode_at(s.ticks, s.values, s.gap_before, np.arange(len(sig), dtype=np.float64))
        err = np.degrees(angular_distance(dec, sig.values[keep]))
        if not keep.all() or (len(err) and err.max() > max_angle):
            raise BoundViolationError(f"{output}: {name}: a decoded sample is {float(err.max()):.6g} degrees from the "
                                      f"original, more than --max-angle {max_angle:g} (a bug: please report it)")
        nbytes = sum(len(p) for p in pk.packets)
        n = len(sig)
        bps = nbytes * sensors[len(records)].rate / n
        raw = RAW_SAMPLE_BYTES * sensors[len(records)].rate
        records.append({
            "name": name, "source": sig.source, "method": "anglesw", "mode": "max_angle", "target": max_angle,
            "threshold": math.degrees(math.radians(max_angle) - delta_bound(bits) - 1e-6),
            "max_segment_length": maxlen, "n_samples": n, "n_points": len(pk.ticks),
            "icr": len(pk.ticks) / n, "mean_segment_length": (n - 1) / max(len(pk.ticks) - 1, 1),
            "aad_deg": float(err.mean()), "max_deg": float(err.max()), "std_deg": float(err.std()),
            "packets": len(pk.packets), "bytes": nbytes, "rate_hz": sensors[len(records)].rate,
            "bytes_per_s": bps, "raw_float32_bytes_per_s": raw, "ratio": nbytes / (RAW_SAMPLE_BYTES * n),
            "ratio_100hz": bps / (RAW_SAMPLE_BYTES * RAW_REFERENCE_HZ),
        })
    warnings = []
    for sig in signals.values():
        for w in sig.meta.get("warnings", []):
            if f"{sig.source}: {w}" not in warnings:
                warnings.append(f"{sig.source}: {w}")
    skipped = sorted({f for s in signals.values() for f in s.meta.get("skipped_files", [])})
    return {"job": "compress", "file": str(path), "kind": "imu", "method": "mkp", "mode": "max_angle",
            "target": max_angle, "packet_bits": bits, "packet_bytes": packet_bytes,
            "quantisation_bound_deg": math.degrees(delta_bound(bits)), "precision": precision,
            "bytes": len(data), "signals": records, "warnings": warnings, "skipped_files": skipped,
            "outputs": [output_entry(output, "mkp", max_angle, "deg")], "recording": recording(signals, path)}
