"""The ``.mkc`` clip job: ``mocapkit compress MOTION -o CLIP.mkc --max-position-error CM`` (and the
decoding side used by ``decompress`` and ``info``)."""

from __future__ import annotations

from pathlib import Path

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import Progress, no_progress, output_entry, recording


def compress_clip_job(path: Path, output: Path, *, max_position_error: float | None, error_metric: str = "joint+end",
                      shell_distance: float = 3.0, unit_cm: float | None = None, asf: Path | None = None,
                      rate: float | None = None, strict: bool = True, block_frames: int | None = None,
                      entropy: str = "zstd", progress: Progress = no_progress) -> dict:
    """Encode a skeletal file as a clip bounded by ``max_position_error`` cm (``error_metric``
    joint+end, joint or shell, shell points ``shell_distance`` cm from each joint); the record holds
    every metric as measured by decoding the written bytes."""
    from mocapkit.clip import DEFAULT_BLOCK_FRAMES, encode_clip
    from mocapkit.clip.metric import check_metric
    from mocapkit.io.formats.mkc import write_mkc
    from mocapkit.io.loaders import load_motion
    from mocapkit.io.loaders import unit_cm as find_unit

    check_metric(error_metric)
    from mocapkit.clip.codec import ENTROPY

    if entropy not in ENTROPY:
        raise InvalidParameterError(f"--entropy {entropy!r}: one of {', '.join(ENTROPY)}")
    if max_position_error is None:
        raise InvalidParameterError(f"{output}: a .mkc clip needs --max-position-error CM (its guarantee)")
    if not (shell_distance > 0):
        raise InvalidParameterError(f"--shell-distance must be positive, got {shell_distance!r}")
    motion = load_motion(path, asf=asf, rate=rate, strict=strict)
    ucm, assumed = find_unit(motion, unit_cm)
    blocks = DEFAULT_BLOCK_FRAMES if block_frames is None else block_frames
    with progress(f"encoding {Path(path).name}", None) as update:
        enc = encode_clip(motion, max_position_error / ucm, metric=error_metric, shell_distance=shell_distance / ucm,
                          unit_cm=ucm, block_frames=blocks, source=Path(path).name, entropy=entropy,
                          progress=lambda done, total: update(done, total))
    write_mkc(output, enc.data)
    r = enc.report
    rec = {"job": "compress", "file": str(path), "kind": "skeletal", "method": "mkc", "mode": "max_position_error",
           "error_metric": error_metric, "entropy": entropy, "max_position_error_cm": max_position_error,
           "shell_distance_cm": shell_distance,
           "unit_cm": ucm, "unit_cm_assumed": assumed,
           **{k: r[k] for k in ("bytes", "frames", "joints", "blocks", "keyframes", "tracks", "default_tracks",
                                "repair_rounds", "repaired_track_blocks", "encode_s", "bytes_raw_float32", "ratio")},
           "max_joint_error_cm": r["max_joint_error"] * ucm, "mean_joint_error_cm": r["mean_joint_error"] * ucm,
           "max_shell_error_cm": r["max_shell_error"] * ucm, "mean_shell_error_cm": r["mean_shell_error"] * ucm,
           "max_end_site_error_cm": r["max_end_site_error"] * ucm,
           "warnings": list(motion.meta.get("warnings", [])), "output": str(output)}
    rec["outputs"] = [output_entry(output, "mkc", max_position_error, "cm")]
    rec["recording"] = recording(motion, path)
    return rec


def clip_fields(path: Path) -> dict:
    """What ``info`` adds for a ``.mkc`` clip (from its header; ``clip_`` fields)."""
    from mocapkit.jobs.readers import open_clip

    i = open_clip(path).info()
    b = i.get("bound") or {}
    u = i.get("unit_cm")

    def cm(v: float | None) -> float | None:
        return None if v is None or u is None else v * u

    return {"clip_bytes": i["bytes"], "clip_blocks": i["blocks"], "clip_keyframes": i["keyframes"],
            "clip_error_metric": b.get("metric"), "clip_bound_cm": cm(b.get("value")),
            "clip_shell_distance_cm": cm(b.get("shell_distance")), "unit_cm": u,
            "clip_tracks": "; ".join(f"{kind}: " + ", ".join(f"{n} {cls}" for cls, n in d.items())
                                     for kind, d in i["tracks"].items()),
            "clip_source": i.get("source")}


def decompress_clip_job(path: Path, output: Path) -> dict:
    """Decode a ``.mkc`` clip to ``.bvh`` (6 decimals) or ``.glb``/``.gltf`` (every frame a key, float rotations)."""
    from mocapkit.jobs.readers import read_mkc

    suffix = Path(output).suffix.lower()
    if suffix not in (".bvh", ".glb", ".gltf"):
        raise InvalidParameterError(f"{output}: a .mkc clip decodes to .bvh, .glb or .gltf")
    motion = read_mkc(path)
    if suffix == ".bvh":
        from mocapkit.io.skeletal.bvh import write_bvh

        write_bvh(output, motion, precision=6)
    else:
        from mocapkit.io.formats.gltf import write_gltf
        from mocapkit.jobs.gltf_out import every_frame

        u = motion.skeleton.meta.get("length_unit_cm") or 1.0
        write_gltf(output, every_frame(motion), unit_m=u / 100.0, name=Path(path).stem, rotations="float")
    return {"job": "decompress", "file": str(path), "kind": "skeletal", "frames": motion.n_frames,
            "joints": motion.skeleton.n_joints, "outputs": [output_entry(output, suffix[1:])], "warnings": []}
