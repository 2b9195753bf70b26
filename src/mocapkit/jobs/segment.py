"""The ``segment`` job: a take cut into actions from its limb-bone angles (the ARMA method of
:mod:`mocapkit.segment.arma` or one of the baselines), scored against reference labels when given."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.common import Progress, check_outputs, no_progress, output_entry, recording

if TYPE_CHECKING:
    from mocapkit.segment.arma import ARMASegmenter
    from mocapkit.segment.base import Segmenter


def pairs(items, what: str) -> list[tuple[str, str]]:
    """``A=B`` strings as pairs (``--joint ROLE=JOINT``, ``--train MOTION=LABELS``)."""
    out = []
    for it in items or []:
        if "=" not in it:
            raise InvalidParameterError(f"{what}: expected A=B, got {it!r}")
        a, b = it.split("=", 1)
        out.append((a.strip(), b.strip()))
    return out


def segments_of(cuts, n_frames: int, rate_hz: float, ref=None) -> list[dict]:
    """The segments between consecutive cuts; ``label`` is the reference label covering most of the
    segment's frames when a reference is given, else None."""
    bounds = [0, *[int(c) for c in cuts], int(n_frames)]
    frame_labels = None if ref is None else np.asarray(ref.labels, dtype=object)[ref.frame_labels()]
    out = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        label = None
        if frame_labels is not None and b > a:
            label = str(Counter(frame_labels[a:b].tolist()).most_common(1)[0][0])
        out.append({"t0": a / rate_hz, "t1": b / rate_hz, "frame0": a, "frame1": b, "label": label})
    return out


def check_options(method: str = "arma", train: list[str] | None = None, joint: list[str] | None = None,
                  downsample: int | None = None) -> None:
    """The option checks that need no file: a known method, ``--train`` exactly for ``mlp``,
    ``--downsample`` only for ``arma``, ``A=B`` pairs."""
    from mocapkit.segment import BASELINES

    if method not in ("auto", "arma") and method not in BASELINES:
        raise InvalidParameterError(f"--method {method!r}: one of auto, arma, {', '.join(BASELINES)}")
    if method == "mlp" and not train:
        raise InvalidParameterError("--method mlp is supervised: give labelled takes with --train MOTION=LABELS")
    if train and method != "mlp":
        raise InvalidParameterError("--train is only for --method mlp")
    if downsample is not None and method not in ("arma", "auto"):
        raise InvalidParameterError("--downsample is an option of --method arma and auto")
    pairs(joint, "--joint")
    pairs(train, "--train")


def segment_job(path: Path, *, asf: Path | None = None, method: str = "arma", labels: Path | None = None,
                joint: list[str] | None = None, train: list[str] | None = None, rate: float | None = None,
                downsample: int | None = None, labels_beside: bool = False, strict: bool = True,
                output: Path | None = None,
                plot: Path | None = None, progress: Progress = no_progress) -> dict:
    """Segment the BVH/AMC take ``path`` with ``method`` and return the record of ``mocapkit segment
    --json`` (cuts in frames and seconds, the segments between them; ``reference_cuts`` and ``scores``
    against ``labels``; ``labels_beside``: the take's ``<stem>.labels.txt`` when there is one, as a database
    such as CMU's keeps them). ``output`` is unused (the cuts are the record); ``plot``: a PNG of the limb angles
    with the cuts."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.io.skeletal.labels import read_reference
    from mocapkit.segment.features import LIMB_NAMES, motion_features, pose_features

    check_options(method, train, joint, downsample)
    path = Path(path)
    plot = None if plot is None else Path(plot)
    if labels is None and labels_beside and path.with_name(path.stem + ".labels.txt").is_file():
        labels = path.with_name(path.stem + ".labels.txt")
    train_files = [Path(x.strip()) for it in train or [] for x in it.split("=", 1)]
    arma_plot = None if plot is None or method != "arma" else plot.with_name(plot.stem + "_arma.png")
    check_outputs(path, (plot, "--plot"), (arma_plot, "--plot (ARMA windows)"), inputs=(asf, labels, *train_files))
    motion = load_motion(path, asf=asf, rate=rate, strict=strict)
    rate_hz = float(motion.rate)
    warnings = list(motion.meta.get("warnings", []))
    ref = None
    if labels is not None:  # read and checked against the take before any segmenting
        ref = read_reference(Path(labels), motion.n_frames, rate_hz)
        warnings += list(ref.warnings)
    jmap = dict(pairs(joint, "--joint"))
    feats = motion_features(motion, jmap)
    seg: Segmenter
    arma: ARMASegmenter | None = None
    if method == "arma":
        from mocapkit.segment.arma import ARMASegmenter

        ds = downsample if downsample is not None else max(1, int(round(rate_hz / 30.0)))
        seg = arma = ARMASegmenter(downsample=ds)
    elif method == "auto":
        from mocapkit.evaluation.segmentation import auto_settings
        from mocapkit.segment.autok import AutoSegmenter

        seg = AutoSegmenter(**auto_settings(rate_hz, downsample))
    else:
        from mocapkit.segment import BASELINES

        kw = {}
        if method == "mlp":  # check_options made sure --train is given
            data = []
            for mot, lab in pairs(train, "--train"):
                tm = load_motion(mot, asf=asf, rate=rate)
                tref = read_reference(Path(lab), tm.n_frames, tm.rate)
                warnings += list(tref.warnings)
                data.append((motion_features(tm, jmap).limbs,
                             np.asarray(tref.labels, dtype=object)[tref.frame_labels()]))
            kw["train"] = data
        from mocapkit.evaluation.segmentation import rate_scaled

        kw.update(rate_scaled(method, rate_hz))  # the baselines' 120 Hz frame counts at this rate
        seg = BASELINES[method](**kw)
    X = pose_features(motion) if method == "pca" else feats.partition if method == "auto" else feats.limbs
    with progress(f"segmenting {path.name} ({method})", None):
        cuts = seg.fit_predict(X)
    rec: dict[str, Any] = {
        "job": "segment", "file": str(path), "kind": "skeletal", "method": method, "n_frames": motion.n_frames,
        "rate_hz": rate_hz, "cuts": [{"frame": int(c), "time_s": float(c) / rate_hz} for c in cuts],
        "segments": segments_of(cuts, motion.n_frames, rate_hz, ref), "warnings": warnings, "outputs": []}
    from mocapkit.segment.naming import name_segments

    naming = name_segments(feats.limbs, cuts, rate_hz)
    rec["actions"] = None if naming is None else " ".join(naming.letters[0])
    for seg_rec, letter in zip(rec["segments"], naming.letters[0] if naming is not None else [], strict=False):
        seg_rec["action"] = letter
    if ref is not None:
        from mocapkit.evaluation.segmentation import score

        rec["reference_cuts"] = [int(c) for c in ref.cuts]
        rec["scores"] = score(cuts, ref, naming=naming)
    if plot is not None:
        from mocapkit.plot import plot_segmentation

        plot_segmentation(feats.limbs, rate_hz, cuts, plot, ref_cuts=None if ref is None else ref.cuts,
                          names=list(LIMB_NAMES), title=f"{path.name}: {method}")
        rec["outputs"].append(output_entry(plot, "png"))
    if arma_plot is not None and arma is not None:  # arma_plot is set for --method arma only
        # per limb: ACF, PACF and Ljung-Box of the windows' residuals (Sec. 4.3, 4.5)
        from mocapkit.plot import plot_arma_diagnostics

        plot_arma_diagnostics([ch["windows"] for ch in arma.channels_], list(LIMB_NAMES), arma_plot,
                              title=f"{path.name}: ARMA windows")
        rec["outputs"].append(output_entry(arma_plot, "png"))
    rec["recording"] = recording(motion, path)
    return rec
