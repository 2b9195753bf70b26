"""The ``info`` job: what a motion file holds (joints, frames, rate, duration, channels, markers)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapkit.jobs.common import Progress, imu_columns, no_progress, recording


def info_job(path: Path, *, asf: Path | None = None, rate: float | None = None, time_column: str | None = None,
             quaternion_columns: str | None = None, scalar_last: bool = False, time_unit: str | None = None,
             strict: bool = True, output: Path | None = None, progress: Progress = no_progress) -> dict:
    """Describe ``path``: a BVH/AMC skeleton, a marker file, an OpenSim table or IMU data (a file or a
    sensor folder). ``output`` is unused (the record is the result); the record's fields are those of
    ``mocapkit info --json``."""
    from mocapkit.io.loaders import kind_of, load_motion
    from mocapkit.jobs.clip import clip_fields

    path = Path(path)
    if path.suffix.lower() == ".mkp":
        return {"job": "info", **packet_fields(path), "recording": None, "outputs": []}
    kind = kind_of(path)
    obj: object  # what the catalog describes: a Motion, Markers, a Signal or {name: Signal}
    with progress(f"reading {path.name}", None):
        if kind == "skeletal":
            m = load_motion(path, asf=asf, rate=rate, strict=strict)
            sk = m.skeleton
            rec = {
                "file": str(path), "kind": "skeletal", "frames": m.n_frames, "rate_hz": m.rate,
                "duration_s": m.n_frames * m.frame_time, "joints": sk.n_joints, "channels": sk.n_channels,
                "end_sites": len(sk.end_sites),
                "roots": [sk.names[j] for j in range(sk.n_joints) if sk.parents[j] < 0],
                "joint_names": list(sk.names),
                "joint_channels": {sk.names[j]: list(sk.channels[j]) for j in range(sk.n_joints)},
                "warnings": list(m.meta.get("warnings", [])),
            }
            if path.suffix.lower() == ".mkc":
                rec.update(clip_fields(path))
            obj = m
        elif kind == "markers":
            from mocapkit.io.loaders import load_markers

            mk = load_markers(path)
            rec = {
                "file": str(path), "kind": "markers", "frames": int(mk.times.shape[0]), "rate_hz": mk.rate,
                "duration_s": float(mk.times.shape[0] / mk.rate), "markers": len(mk.labels),
                "labels": list(mk.labels), "units": mk.units,
                "missing_fraction": float(np.isnan(mk.positions[..., 0]).mean()),
                "analog_channels": 0 if not mk.analog else len(mk.analog.get("labels", [])),
                "format": mk.meta.get("format"), "warnings": list(mk.meta.get("warnings", [])),
            }
            obj = mk
        elif kind == "table":
            from mocapkit.io.markers.opensim import read_table

            sig = read_table(path)
            rec = {
                "file": str(path), "kind": "table", "name": sig.meta.get("name"), "frames": len(sig),
                "rate_hz": sig.meta.get("rate") or sig.mean_rate, "duration_s": sig.duration,
                "columns": sig.values.shape[1], "labels": list(sig.meta["labels"]),
                "in_degrees": sig.meta.get("in_degrees"), "format": sig.meta.get("format"),
                "warnings": list(sig.meta.get("warnings", [])),
            }
            obj = sig
        else:
            from mocapkit.io import load_signals

            sigs = load_signals(path, rate=rate, **imu_columns(time_column, quaternion_columns, scalar_last,
                                                               time_unit))
            rec = {
                "file": str(path), "kind": "imu", "signals": {
                    n: {"samples": len(s), "duration_s": s.duration, "mean_rate_hz": s.mean_rate,
                        "format": s.meta.get("format"),
                        "largest_gap_s": float(np.diff(s.times).max()) if len(s) > 1 else 0.0,
                        "time_column": s.meta.get("time_column"), "time_unit": s.meta.get("time_unit"),
                        "stated_rate_hz": s.meta.get("rate"),
                        "orientation_columns": s.meta.get("orientation_columns"),
                        "conversion": s.meta.get("conversion")}
                    for n, s in sigs.items()
                },
                "warnings": [f"{n}: {w}" for n, s in sigs.items() for w in s.meta.get("warnings", [])],
            }
            obj = sigs
    rec["recording"] = recording(obj, path)
    return {"job": "info", **rec, "outputs": []}


def packet_fields(path: Path) -> dict:
    """``info`` of a radio packet stream (.mkp): its settings, and per sensor what arrived and what was lost."""
    from mocapkit.jobs.readers import read_mkp

    pf = read_mkp(path)
    h = pf.header
    return {
        "file": str(path), "kind": "packets", "format": "mkp", "bytes": path.stat().st_size,
        "max_angle_deg": h.max_angle_deg, "bits": h.bits, "packet_bytes": h.packet_bytes,
        "max_segment_length": h.max_segment_length,
        "sensors": {
            name: {"rate_hz": s.sensor.rate, "t0_s": s.sensor.t0, "packets": s.packets, "points": len(s.ticks),
                   "samples": s.samples, "lost_sequence_numbers": len(s.lost), "ended": s.ended}
            for name, s in pf.streams.items()
        },
        "damaged_packets": len(pf.damaged), "lost_packets": pf.lost_packets,
        "warnings": pf.losses(),
    }
