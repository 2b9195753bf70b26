"""The ``compress`` job of IMU data: orientation streams (IMU files, sensor folders) into segment points by
the piecewise linear approximations of :mod:`mocapkit.pla`."""

from __future__ import annotations

from pathlib import Path
from typing import TextIO

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import (
    Progress,
    check_outputs,
    imu_columns,
    no_progress,
    output_entry,
    recording,
    sensor_outputs,
)
from mocapkit.jobs.compress_kinds import ImuCompressOptions, naming_target_icr

#: suffixes that name a file, not a folder (an IMU folder's output must be a folder)
FILE_SUFFIXES = (".csv", ".txt", ".tsv", ".json", ".bvh", ".amc", ".glb", ".gltf", ".c3d", ".trc", ".mot", ".sto",
                 ".png", ".parquet")


def _signal_record(name: str, source: str, comp, metrics, mode: str, target) -> dict:
    return {
        "name": name, "source": source, "method": comp.method, "mode": mode, "target": target,
        "threshold": comp.threshold, "max_segment_length": comp.max_segment_length,
        "n_samples": metrics.n_samples, "n_points": metrics.n_points, "icr": metrics.icr,
        "mean_segment_length": metrics.mean_segment_length, "aad_deg": metrics.aad_deg,
        "max_deg": metrics.max_deg, "std_deg": metrics.std_deg, "point_mean_deg": metrics.point_mean_deg,
        "point_max_deg": metrics.point_max_deg,
    }


def compress_imu(path: Path, options: ImuCompressOptions, *, output: Path | None = None,
                 points_stream: TextIO | None = None, discard_ok: bool = True,
                 progress: Progress = no_progress) -> dict:
    """Compress the IMU input ``path`` (exactly one of ``threshold``, ``target_icr``, ``max_angle``) and
    return the record of ``mocapkit compress --json``: points CSV ``time,w,x,y,z`` to ``output`` (a folder
    of one CSV per sensor for a folder or a multi-sensor file), or to ``points_stream`` for one signal
    without ``output``. ``discard_ok=False`` refuses, before any work, a run whose points would go nowhere."""
    from mocapkit.io import load_signals, write_signal_csv
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.pla import compress_to, evaluate

    o = options
    path = Path(path)
    output = None if output is None else Path(output)
    check_outputs(path, (output, "--output"), folder=path.is_dir() or (output is not None and output.is_dir()))
    if sum(x is not None for x in (o.threshold, o.target_icr, o.max_angle)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle")
    signals = load_signals(path, rate=o.rate, **imu_columns(o.time_column, o.quaternion_columns, o.scalar_last,
                                                            o.time_unit))
    # one CSV per sensor: a folder, a file of several sensors, or an existing folder as the output
    folder_mode = path.is_dir() or len(signals) > 1 or (output is not None and output.is_dir())
    what = "a folder" if path.is_dir() else f"a file of {len(signals)} sensor{'s' * (len(signals) > 1)}"
    if folder_mode and output is not None and output.exists() and not output.is_dir():
        raise InvalidParameterError(f"{output}: INPUT is {what}, so --output must be a folder")
    if folder_mode and output is None and not discard_ok:
        raise InvalidParameterError(
            f"{path} is {what}: give -o FOLDER to keep the segment points (one CSV per sensor), "
            "or --json / --stats-only to print only the numbers")
    if output is not None and folder_mode and output.suffix.lower() in FILE_SUFFIXES:
        raise InvalidParameterError(f"{output}: INPUT is {what}, so --output is a folder (one CSV per sensor), "
                                    f"not a {output.suffix} file")
    if output is not None and not folder_mode and output.suffix.lower() != ".csv" and not is_device_or_pipe(output):
        raise InvalidParameterError(f"{output}: segment points are written as .csv")
    mode, target = (("threshold", o.threshold) if o.threshold is not None
                    else ("target_icr", o.target_icr) if o.target_icr is not None else ("max_angle", o.max_angle))
    warnings: list[str] = []
    dests: dict[str, Path] = {} if output is None else {name: output for name in signals}
    if output is not None and folder_mode:
        dests, warnings = sensor_outputs(output, list(signals), path)
    comps = {}
    with progress(f"compressing {path.name}", len(signals)) as update:
        for i, (name, sig) in enumerate(signals.items()):
            with naming_target_icr(o.target_icr):
                comps[name] = compress_to(sig, o.method, threshold=o.threshold, target_icr=o.target_icr,
                                          max_angle=o.max_angle, max_segment_length=o.max_segment_length)
            update(i + 1)
    records, outputs = [], []
    bound, unit = {"max_angle": (o.max_angle, "deg")}.get(mode, (None, None))
    for name, sig in signals.items():
        comp = comps[name]
        records.append(_signal_record(name, sig.source, comp, evaluate(sig, comp), mode, target))
        if output is not None:
            dest = dests[name]
            if folder_mode:
                output.mkdir(exist_ok=True)  # one new level; its parent was checked before any work
            write_signal_csv(dest, comp.times, comp.values)
            outputs.append(output_entry(dest, "csv", bound, unit))
        elif points_stream is not None and not folder_mode:
            points_stream.write("time,w,x,y,z\n")
            for t, v in zip(comp.times.tolist(), comp.values.tolist(), strict=True):
                points_stream.write(",".join(repr(x) for x in (t, *v)) + "\n")
    for sig in signals.values():
        for w in sig.meta.get("warnings", []):
            if f"{sig.source}: {w}" not in warnings:
                warnings.append(f"{sig.source}: {w}")
    skipped = sorted({f for s in signals.values() for f in s.meta.get("skipped_files", [])})
    return {"job": "compress", "file": str(path), "kind": "imu", "method": o.method, "mode": mode, "target": target,
            "signals": records, "warnings": warnings, "skipped_files": skipped, "outputs": outputs,
            "recording": recording(signals, path)}
