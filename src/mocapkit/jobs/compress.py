"""The ``compress`` job: orientation streams (IMU files, sensor folders) into segment points, or whole
skeletons (BVH, AMC) into keyframes, by the piecewise linear approximations of :mod:`mocapkit.pla`."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import TextIO

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import (Progress, check_outputs, imu_columns, no_progress, output_entry, recording,
                                  sensor_outputs)

#: suffixes that name a file, not a folder (an IMU folder's output must be a folder)
FILE_SUFFIXES = (".csv", ".txt", ".tsv", ".json", ".bvh", ".amc", ".glb", ".gltf", ".c3d", ".trc", ".mot", ".sto",
                 ".png", ".parquet")


@contextlib.contextmanager
def naming_target_icr(target_icr):
    """An unreachable ``--target-icr`` is reported under the option's name."""
    from mocapkit.errors import UnreachableTargetError

    try:
        yield
    except UnreachableTargetError as e:
        raise InvalidParameterError(f"--target-icr {target_icr:g}: {e}") from None


def _signal_record(name: str, source: str, comp, metrics, mode: str, target) -> dict:
    return {
        "name": name, "source": source, "method": comp.method, "mode": mode, "target": target,
        "threshold": comp.threshold, "max_segment_length": comp.max_segment_length,
        "n_samples": metrics.n_samples, "n_points": metrics.n_points, "icr": metrics.icr,
        "mean_segment_length": metrics.mean_segment_length, "aad_deg": metrics.aad_deg,
        "max_deg": metrics.max_deg, "std_deg": metrics.std_deg, "point_mean_deg": metrics.point_mean_deg,
        "point_max_deg": metrics.point_max_deg,
    }


METHODS = ("fastsw", "sw", "cplr", "swing", "anglesw", "optimal")


def check_options(method: str = "fastsw", threshold=None, target_icr=None, max_angle=None,
                  max_position_error=None, skeletal_format=None, error_metric="joint+end",
                  per_file: bool = False) -> None:
    """The option checks that need no file: a known method and exactly one control; the batch's
    skeletal output format and what it can bound. ``per_file`` (a batch's own options, completed per
    file): ``max_angle`` and ``max_position_error`` may come together (each bounds its kind of input), or
    no control at all (the files' manifest or sidecars give them)."""
    from mocapkit.clip.metric import METRICS

    if skeletal_format not in (None, "glb", "mkc"):
        raise InvalidParameterError(f"--skeletal-format {skeletal_format!r}: mkc or glb")
    if error_metric not in METRICS:
        raise InvalidParameterError(f"--error-metric {error_metric!r}: one of {', '.join(METRICS)}")
    if error_metric == "shell" and skeletal_format == "glb":
        raise InvalidParameterError("--error-metric shell is bounded in .mkc clips: add --skeletal-format mkc")
    if method not in METHODS:
        raise InvalidParameterError(f"--method {method!r}: one of {', '.join(METHODS)}")
    given = sum(x is not None for x in (threshold, target_icr, max_angle, max_position_error))
    if per_file and (given == 0 or (given == 2 and max_angle is not None and max_position_error is not None)):
        return
    if given != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle (IMU data) or "
                                    "--max-position-error (skeletons)"
                                    + ("; --max-angle and --max-position-error may go together (each bounds its "
                                       "kind of input)" if per_file else ""))


def compress_job(path: Path, *, method: str = "fastsw", threshold: float | None = None,
                 target_icr: float | None = None, max_angle: float | None = None,
                 max_segment_length: int | None = None, rate: float | None = None, time_column: str | None = None,
                 quaternion_columns: str | None = None, scalar_last: bool = False, time_unit: str | None = None,
                 asf: Path | None = None, max_position_error: float | None = None, unit_cm: float | None = None,
                 strict: bool = True, output: Path | None = None, points_stream: TextIO | None = None,
                 discard_ok: bool = True, progress: Progress = no_progress, gltf_rotations: str = "short",
                 error_metric: str = "joint+end", shell_distance: float = 3.0, block_frames: int | None = None,
                 skeletal_format: str | None = None, entropy: str = "zstd") -> dict:
    """Compress ``path`` and return the record of ``mocapkit compress --json``.

    IMU input (exactly one of ``threshold``, ``target_icr``, ``max_angle``): points CSV ``time,w,x,y,z`` to
    ``output`` (a folder of one CSV per sensor for a folder or a multi-sensor file), or to ``points_stream``
    for one signal without ``output``. Skeletal input (one of ``threshold``, ``target_icr``,
    ``max_position_error`` in cm): keyframes as ``.glb``/``.gltf`` or the decoded motion as ``.bvh``.
    glTF rotation keys are ``gltf_rotations`` ``"short"`` (normalized SHORT, smaller) or ``"float"``; with
    a bound, the written file is decoded and checked against it (:mod:`mocapkit.jobs.gltf_out`).
    ``discard_ok=False`` refuses, before any work, a run whose points would go nowhere. A ``.mkc`` output is
    the clip format (:mod:`mocapkit.jobs.clip`): bounded by ``max_position_error`` in the ``error_metric``
    (``"joint+end"``: every joint and End Site, ``"joint"``: the joints only, or ``"shell"`` at
    ``shell_distance`` cm; a glTF output takes the first two), ``block_frames`` frames per random-access block.
    ``entropy``: the clip's lossless stage (``"zstd"``, ``"lzma"``, ``"smallest"``).
    ``skeletal_format`` (``"mkc"``/``"glb"``) is the batch's choice of a skeletal output's format (its path
    carries it: :func:`mocapkit.jobs.batch_output`).
    """
    from mocapkit.io.loaders import kind_of

    check_options(method, threshold, target_icr, max_angle, max_position_error, skeletal_format, error_metric)
    path = Path(path)
    output = None if output is None else Path(output)
    if skeletal_format is not None and output is not None and kind_of(path) == "skeletal" \
            and output.suffix.lower() != "." + skeletal_format:
        raise InvalidParameterError(f"{output}: the skeletal output format is {skeletal_format}")
    check_outputs(path, (output, "--output"), inputs=(asf,),
                  folder=path.is_dir() or (output is not None and output.is_dir()))
    if kind_of(path) == "skeletal":
        if output is None and not discard_ok:
            raise InvalidParameterError(
                f"{path}: give -o OUT.glb|OUT.gltf|OUT.bvh to keep the compressed clip "
                "(or --json / --stats-only to print only the numbers)")
        if output is not None and output.suffix.lower() == ".mkc":
            from mocapkit.jobs.clip import compress_clip_job

            if threshold is not None or target_icr is not None or max_angle is not None:
                raise InvalidParameterError(f"{output}: a .mkc clip is bounded by --max-position-error CM only")
            return compress_clip_job(path, output, max_position_error=max_position_error, error_metric=error_metric,
                                     shell_distance=shell_distance, unit_cm=unit_cm, asf=asf, rate=rate,
                                     strict=strict, block_frames=block_frames, entropy=entropy, progress=progress)
        if error_metric == "shell" or block_frames is not None or entropy != "zstd":
            raise InvalidParameterError("--error-metric shell, --block-frames and --entropy apply to a .mkc clip "
                                        "(-o CLIP.mkc)")
        return _skeletal(path, output, method, threshold, target_icr, max_position_error, max_angle,
                         max_segment_length, rate, asf, unit_cm, strict, progress, gltf_rotations, shell_distance,
                         error_metric == "joint+end")
    if max_position_error is not None or asf is not None or unit_cm is not None:
        raise InvalidParameterError("--max-position-error, --asf and --unit-cm apply to BVH/AMC input")
    return _imu(path, output, method, threshold, target_icr, max_angle, max_segment_length, rate,
                imu_columns(time_column, quaternion_columns, scalar_last, time_unit), points_stream, discard_ok,
                progress)


def _imu(path, output, method, threshold, target_icr, max_angle, max_segment_length, rate, columns,
         points_stream, discard_ok, progress) -> dict:
    from mocapkit.io import load_signals, write_signal_csv
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.pla import compress_to, evaluate

    if sum(x is not None for x in (threshold, target_icr, max_angle)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle")
    signals = load_signals(path, rate=rate, **columns)
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
    mode, target = (("threshold", threshold) if threshold is not None
                    else ("target_icr", target_icr) if target_icr is not None else ("max_angle", max_angle))
    warnings: list[str] = []
    dests = {name: output for name in signals}
    if output is not None and folder_mode:
        dests, warnings = sensor_outputs(output, list(signals), path)
    comps = {}
    with progress(f"compressing {path.name}", len(signals)) as update:
        for i, (name, sig) in enumerate(signals.items()):
            with naming_target_icr(target_icr):
                comps[name] = compress_to(sig, method, threshold=threshold, target_icr=target_icr,
                                          max_angle=max_angle, max_segment_length=max_segment_length)
            update(i + 1)
    records, outputs = [], []
    bound, unit = {"max_angle": (max_angle, "deg")}.get(mode, (None, None))
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
            for t, v in zip(comp.times.tolist(), comp.values.tolist()):
                points_stream.write(",".join(repr(x) for x in (t, *v)) + "\n")
    for sig in signals.values():
        for w in sig.meta.get("warnings", []):
            if f"{sig.source}: {w}" not in warnings:
                warnings.append(f"{sig.source}: {w}")
    skipped = sorted({f for s in signals.values() for f in s.meta.get("skipped_files", [])})
    return {"job": "compress", "file": str(path), "kind": "imu", "method": method, "mode": mode, "target": target,
            "signals": records, "warnings": warnings, "skipped_files": skipped, "outputs": outputs,
            "recording": recording(signals, path)}


def _skeletal(path, output, method, threshold, target_icr, max_position_error, max_angle, max_segment_length,
              rate, asf, unit_cm, strict, progress, gltf_rotations="short", shell_distance=3.0,
              end_sites=True) -> dict:
    from mocapkit.io.skeletal.bvh import write_bvh
    from mocapkit.io.formats.gltf import ROTATION_FORMATS
    from mocapkit.io.loaders import load_motion, unit_cm as find_unit
    from mocapkit.jobs.gltf_out import compress_to_gltf, write_checked
    from mocapkit.pla.skeletal import compress_motion, report, verify_position_bound

    if max_angle is not None:
        raise InvalidParameterError("for skeletal input use --max-position-error CM (or --threshold / --target-icr)")
    if sum(x is not None for x in (threshold, target_icr, max_position_error)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-position-error")
    if output is not None and output.suffix.lower() not in (".glb", ".gltf", ".bvh"):
        raise InvalidParameterError(f"{output}: skeletal output is .mkc, .glb, .gltf or .bvh")
    if gltf_rotations not in ROTATION_FORMATS:
        raise InvalidParameterError(f"--gltf-rotations {gltf_rotations!r}: one of {', '.join(ROTATION_FORMATS)}")
    gltf_out = output is not None and output.suffix.lower() in (".glb", ".gltf")
    motion = load_motion(path, asf=asf, rate=rate, strict=strict)
    ucm, assumed = find_unit(motion, unit_cm)
    bound = None if max_position_error is None else max_position_error / ucm
    steps = None if threshold is not None else 41 if target_icr is not None else 15  # repair rounds: the ticks carry the total
    stored = None
    with progress(f"compressing {path.name}", steps) as update, naming_target_icr(target_icr):
        if gltf_out and bound is not None:  # the bound is checked on the decoded file (written here)
            comp, stored = compress_to_gltf(motion, bound, output, rotations=gltf_rotations, unit_m=ucm / 100.0,
                                            name=path.stem, method=method, max_segment_length=max_segment_length,
                                            progress=update, end_sites=end_sites)
        else:
            comp = compress_motion(motion, method, threshold=threshold, target_icr=target_icr,
                                   max_position_error=bound, max_segment_length=max_segment_length, progress=update,
                                   end_sites=end_sites)
            if bound is not None:
                verify_position_bound(motion, comp, bound, end_sites)
    rec = {"job": "compress", "file": str(path), "kind": "skeletal", **report(comp, ucm), "unit_cm_assumed": assumed,
           "error_metric": "joint+end" if end_sites else "joint",
           "warnings": list(motion.meta.get("warnings", [])), "outputs": []}
    from mocapkit.clip.metric import position_errors as point_errors

    _, shell = point_errors(motion, comp.decode(), shell_distance / ucm)  # ACL's metric, beside the joints'
    rec["max_shell_error_cm"], rec["mean_shell_error_cm"] = float(shell.max()) * ucm, float(shell.mean()) * ucm
    rec["shell_distance_cm"] = shell_distance
    if output is not None:
        if output.suffix.lower() == ".bvh":
            write_bvh(output, comp.decode(), precision=6)
        elif stored is None:
            stored = write_checked(motion, comp, output, rotations=gltf_rotations, unit_m=ucm / 100.0, name=path.stem)
        if stored is not None:
            rec["gltf_rotations"] = stored["rotations"]
            rec["readback_max_position_error_cm"] = stored["readback_error"] * ucm
            for key in ("compress_bound", "storage_error_bound", "storage_error_measured"):
                if key in stored:
                    rec[f"gltf_{key}_cm"] = stored[key] * ucm
            if "attempts" in stored:
                rec["gltf_attempts"] = len(stored["attempts"])
            rec["warnings"] += stored["warnings"]
        rec["output"] = str(output)
        rec["file_bytes"] = output.stat().st_size
        rec["outputs"].append(output_entry(output, output.suffix.lower()[1:], max_position_error,
                                           None if max_position_error is None else "cm"))
    rec["recording"] = recording(motion, path)
    return rec
