"""The ``similarity`` job: two takes (or frame ranges of them) compared on their 4 limb-bone angles by
DTW and the correlation of the aligned sequences (Eq. 5–9 of the ARMA seed paper,
:mod:`mocapkit.segment.similarity`). It reads two inputs, so it is a command of its own and not one of
the batch jobs of :data:`mocapkit.jobs.JOBS`."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import Progress, no_progress, recording

if TYPE_CHECKING:
    import numpy as np

_RANGE_RE = re.compile(r"\s*([0-9]*)\s*:\s*([0-9]*)\s*")


def parse_frames(text: str | None, option: str) -> tuple[int | None, int | None] | None:
    """``"A0:A1"`` (0-based, end excluded, either side may be left out) as ``(a0, a1)``; None for None."""
    if text is None:
        return None
    m = _RANGE_RE.fullmatch(str(text))
    if m is None:
        raise InvalidParameterError(f"{option} {text!r}: expected START:END frame numbers (0-based, END excluded), "
                                    "e.g. 0:550")
    a0, a1 = (int(g) if g else None for g in m.groups())
    if a0 is not None and a1 is not None and a1 - a0 < 2:
        raise InvalidParameterError(f"{option} {text!r}: END must be at least START + 2 (two frames to correlate)")
    return a0, a1


def frame_range(rng: tuple[int | None, int | None] | None, n_frames: int, path: Path, option: str) -> tuple[int, int]:
    """The range ``rng`` checked against a take of ``n_frames`` frames (never clipped)."""
    a0, a1 = rng if rng is not None else (None, None)
    a0 = 0 if a0 is None else a0
    a1 = n_frames if a1 is None else a1
    if a1 > n_frames:
        raise InvalidParameterError(f"{option} {a0}:{a1}: {path} has {n_frames} frames (0..{n_frames - 1})")
    if a1 - a0 < 2:
        raise InvalidParameterError(f"{option} {a0}:{a1}: fewer than two frames of {path} ({n_frames} frames)")
    return a0, a1


def check_options(limbs=None, frames=None, frames_b=None, align: str = "limb", band=None, resample=None) -> None:
    """The checks that need no file: known limbs, well-formed ranges, alignment, band and resampling."""
    from mocapkit.segment.features import LIMB_NAMES
    from mocapkit.segment.similarity import ALIGNMENTS

    bad = [x for x in limbs or [] if x not in LIMB_NAMES]
    if bad:
        raise InvalidParameterError(f"--limb {bad[0]!r}: one of {', '.join(LIMB_NAMES)}")
    if limbs is not None and len(set(limbs)) != len(limbs):
        raise InvalidParameterError(f"--limb: {min(x for x in set(limbs) if limbs.count(x) > 1)} given twice")
    parse_frames(frames, "--frames")
    parse_frames(frames_b, "--frames-b")
    if align not in ALIGNMENTS:
        raise InvalidParameterError(f"--align {align!r}: one of {', '.join(ALIGNMENTS)}")
    if band is not None and (isinstance(band, bool) or int(band) != band or band < 0):
        raise InvalidParameterError(f"--band {band!r}: a number of samples >= 0")
    if resample is not None and (isinstance(resample, bool) or int(resample) != resample or resample < 2):
        raise InvalidParameterError(f"--resample {resample!r}: a number of samples >= 2")


def _motionless_warnings(still: list[list[bool]], names: list[str], paths: list[Path]) -> list[str]:
    """A warning for takes whose compared limb angles all stand still (no correlation is defined)."""
    if all(still[0]) and all(still[1]):
        return [f"both takes are motionless ({', '.join(names)} do not change in {paths[0]} nor in {paths[1]}): "
                "no correlation is defined (r is null)"]
    return [f"{p}: the take is motionless ({', '.join(names)} do not change): no correlation with it is defined "
            "(r is null)" for p, st in zip(paths, still, strict=True) if all(st)]


def similarity_job(path: Path, path_b: Path, *, asf: Path | None = None, limbs: list[str] | None = None,
                   frames: str | None = None, frames_b: str | None = None, rate: float | None = None,
                   joint: list[str] | None = None, align: str = "limb", band: int | None = None,
                   resample: int | None = None, strict: bool = True, output: Path | None = None,
                   progress: Progress = no_progress) -> dict:
    """Compare the BVH/AMC takes ``path`` and ``path_b`` (frame ranges ``frames``/``frames_b``,
    ``"A0:A1"``) on the limb angles ``limbs`` (default all four of ``LIMB_NAMES``): per limb the Eq. 9
    correlation r after DTW alignment, the Eq. 5 DTW distance in degrees and the path length K.
    ``output`` is unused (the numbers are the record)."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.jobs.segment import pairs
    from mocapkit.segment.features import LIMB_NAMES, motion_features
    from mocapkit.segment.similarity import PAPER_THRESHOLD, is_constant, min_band, sequence_similarity

    check_options(limbs, frames, frames_b, align, band, resample)
    path, path_b = Path(path), Path(path_b)
    names = list(limbs) if limbs else list(LIMB_NAMES)
    cols = [LIMB_NAMES.index(x) for x in names]
    jmap = dict(pairs(joint, "--joint"))
    sides: list[tuple[np.ndarray, dict[str, Any]]] = []
    warnings: list[str] = []
    motions, loaded = [], {}
    for p, rng, option in ((path, frames, "--frames"), (path_b, frames_b, "--frames-b")):
        if p.resolve() not in loaded:  # the same take twice (two ranges of it) is read once
            motion = load_motion(p, asf=asf, rate=rate, strict=strict)
            warnings += [f"{p}: {w}" for w in motion.meta.get("warnings", [])]
            loaded[p.resolve()] = (motion, motion_features(motion, jmap).limbs)
        motion, all_limbs = loaded[p.resolve()]
        a0, a1 = frame_range(parse_frames(rng, option), motion.n_frames, p, option)
        limb = all_limbs[a0:a1][:, cols]
        sides.append((limb, {"file": str(p), "frames": [a0, a1], "n_frames": int(motion.n_frames),
                             "rate_hz": float(motion.rate)}))
        motions.append(motion)
    (A, sa), (B, sb) = sides
    if abs(sa["rate_hz"] - sb["rate_hz"]) > 1e-3 * max(sa["rate_hz"], sb["rate_hz"]):  # not a rounded frame time
        warnings.append(f"the takes have different frame rates ({sa['rate_hz']:g} and {sb['rate_hz']:g} Hz): DTW "
                        "aligns them, but a band and the path length count samples of each")
    if band is not None and resample is None and band < min_band(len(A), len(B)):
        raise InvalidParameterError(f"--band {band}: ranges of {len(A)} and {len(B)} frames need a band of at least "
                                    f"{min_band(len(A), len(B))} samples (half their length ratio)")
    with progress(f"DTW of {len(A)} x {len(B)} frames ({align})", None):
        ps = sequence_similarity(A, B, align=align, band=band, resample=resample)
    still = [[is_constant(X[:, k]) for k in range(len(names))] for X in (A, B)]
    warnings += _motionless_warnings(still, names, [path, path_b])
    rows: list[dict[str, Any]] = []
    for k, nm in enumerate(names):
        r = float(ps.r[k])
        if not math.isfinite(r) and not (all(still[0]) or all(still[1])):
            which = " and ".join(str(p) for p, st in zip((path, path_b), still, strict=True) if st[k]) or "one take"
            warnings.append(f"{nm}: the angle does not change in {which}; its correlation is undefined")
        rows.append({"limb": nm, "r": r if math.isfinite(r) else None,
                     "similarity_pct": 100.0 * r if math.isfinite(r) else None,
                     "distance_deg": float(ps.distance[k]), "path_length": int(ps.path_length[k])})
    defined = [x["r"] for x in rows if x["r"] is not None]
    r_mean = sum(defined) / len(defined) if len(defined) == len(rows) else None
    return {"job": "similarity", "file": str(path), "file_b": str(path_b), "kind": "skeletal", "align": align,
            "band": band, "resample": resample, "lengths": list(ps.lengths), "a": sa, "b": sb, "limbs": rows,
            "r_mean": r_mean, "above_paper_threshold": None if r_mean is None else bool(r_mean > PAPER_THRESHOLD),
            "warnings": warnings, "outputs": [], "recording": recording(motions[0], path),
            "recording_b": recording(motions[1], path_b)}
