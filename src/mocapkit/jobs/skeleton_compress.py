"""The ``compress`` job of a skeleton (BVH, AMC, MVNX, .mkc): keyframes as glTF, the decoded motion as
BVH, or a ``.mkc`` clip (:mod:`mocapkit.jobs.clip`), by the whole-skeleton compression of
:mod:`mocapkit.pla.skeletal`."""

from __future__ import annotations

from pathlib import Path

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import (
    Progress,
    check_outputs,
    no_progress,
    output_entry,
    recording,
)
from mocapkit.jobs.compress_kinds import SkeletonCompressOptions, naming_target_icr


def compress_skeleton(path: Path, options: SkeletonCompressOptions, *, output: Path | None = None,
                      discard_ok: bool = True, progress: Progress = no_progress) -> dict:
    """Compress the skeletal input ``path`` (one of ``threshold``, ``target_icr``, ``max_position_error``
    in cm) and return the record of ``mocapkit compress --json``.

    Keyframes go to ``.glb``/``.gltf`` (rotation keys ``gltf_rotations`` ``"short"`` or ``"float"``; with a
    bound, the written file is decoded and checked against it: :mod:`mocapkit.jobs.gltf_out`), the decoded
    motion to ``.bvh``; a ``.mkc`` output is the clip format, bounded by ``max_position_error`` in the
    ``error_metric`` (``"joint+end"``, ``"joint"`` or ``"shell"`` at ``shell_distance`` cm), ``block_frames``
    frames per block, ``entropy`` its lossless stage. ``skeletal_format`` is a batch's choice of the output's
    format (the path must carry it). ``discard_ok=False`` refuses, before any work, a run without ``output``.
    """
    o = options
    path = Path(path)
    output = None if output is None else Path(output)
    if o.skeletal_format is not None and output is not None and output.suffix.lower() != "." + o.skeletal_format:
        raise InvalidParameterError(f"{output}: the skeletal output format is {o.skeletal_format}")
    check_outputs(path, (output, "--output"), inputs=(o.asf,),
                  folder=path.is_dir() or (output is not None and output.is_dir()))
    if output is None and not discard_ok:
        raise InvalidParameterError(
            f"{path}: give -o OUT.glb|OUT.gltf|OUT.bvh to keep the compressed clip "
            "(or --json / --stats-only to print only the numbers)")
    if output is not None and output.suffix.lower() == ".mkc":
        from mocapkit.jobs.clip import compress_clip_job

        if o.threshold is not None or o.target_icr is not None:
            raise InvalidParameterError(f"{output}: a .mkc clip is bounded by --max-position-error CM only")
        return compress_clip_job(path, output, max_position_error=o.max_position_error, error_metric=o.error_metric,
                                 shell_distance=o.shell_distance, unit_cm=o.unit_cm, asf=o.asf, rate=o.rate,
                                 strict=o.strict, block_frames=o.block_frames, entropy=o.entropy, progress=progress)
    if o.error_metric == "shell" or o.block_frames is not None or o.entropy != "zstd":
        raise InvalidParameterError("--error-metric shell, --block-frames and --entropy apply to a .mkc clip "
                                    "(-o CLIP.mkc)")
    return _keyframes(path, output, o, progress)


def _keyframes(path: Path, output: Path | None, o: SkeletonCompressOptions, progress: Progress) -> dict:
    """glTF keyframes or the decoded BVH, the record with the joints' and the shell's errors."""
    from mocapkit.io.formats.gltf import ROTATION_FORMATS
    from mocapkit.io.loaders import load_motion
    from mocapkit.io.loaders import unit_cm as find_unit
    from mocapkit.io.skeletal.bvh import write_bvh
    from mocapkit.jobs.gltf_out import compress_to_gltf, write_checked
    from mocapkit.pla.skeletal import compress_motion, report, verify_position_bound

    end_sites = o.error_metric == "joint+end"
    if sum(x is not None for x in (o.threshold, o.target_icr, o.max_position_error)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-position-error")
    if output is not None and output.suffix.lower() not in (".glb", ".gltf", ".bvh"):
        raise InvalidParameterError(f"{output}: skeletal output is .mkc, .glb, .gltf or .bvh")
    if o.gltf_rotations not in ROTATION_FORMATS:
        raise InvalidParameterError(f"--gltf-rotations {o.gltf_rotations!r}: one of {', '.join(ROTATION_FORMATS)}")
    gltf_out = output is not None and output.suffix.lower() in (".glb", ".gltf")
    motion = load_motion(path, asf=o.asf, rate=o.rate, strict=o.strict)
    ucm, assumed = find_unit(motion, o.unit_cm)
    bound = None if o.max_position_error is None else o.max_position_error / ucm
    # repair rounds: the ticks carry the total
    steps = None if o.threshold is not None else 41 if o.target_icr is not None else 15
    stored = None
    with progress(f"compressing {path.name}", steps) as update, naming_target_icr(o.target_icr):
        # the bound is checked on the decoded file (written here)
        if gltf_out and output is not None and bound is not None:
            comp, stored = compress_to_gltf(motion, bound, output, rotations=o.gltf_rotations, unit_m=ucm / 100.0,
                                            name=path.stem, method=o.method, max_segment_length=o.max_segment_length,
                                            progress=update, end_sites=end_sites)
        else:
            comp = compress_motion(motion, o.method, threshold=o.threshold, target_icr=o.target_icr,
                                   max_position_error=bound, max_segment_length=o.max_segment_length,
                                   progress=update, end_sites=end_sites)
            if bound is not None:
                verify_position_bound(motion, comp, bound, end_sites)
    rec = {"job": "compress", "file": str(path), "kind": "skeletal", **report(comp, ucm), "unit_cm_assumed": assumed,
           "error_metric": "joint+end" if end_sites else "joint",
           "warnings": list(motion.meta.get("warnings", [])), "outputs": []}
    from mocapkit.clip.metric import position_errors as point_errors

    _, shell = point_errors(motion, comp.decode(), o.shell_distance / ucm)  # ACL's metric, beside the joints'
    rec["max_shell_error_cm"], rec["mean_shell_error_cm"] = float(shell.max()) * ucm, float(shell.mean()) * ucm
    rec["shell_distance_cm"] = o.shell_distance
    if output is not None:
        if output.suffix.lower() == ".bvh":
            write_bvh(output, comp.decode(), precision=6)
        elif stored is None:
            stored = write_checked(motion, comp, output, rotations=o.gltf_rotations, unit_m=ucm / 100.0,
                                   name=path.stem)
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
        rec["outputs"].append(output_entry(output, output.suffix.lower()[1:], o.max_position_error,
                                           None if o.max_position_error is None else "cm"))
    rec["recording"] = recording(motion, path)
    return rec
