"""Actions named across takes (:func:`mocapkit.segment.naming.name_actions`): the calibration of the
threshold on synthetic segments, then the naming of the 4 shared labelled CMU takes.

    .venv/bin/python benchmarks/naming_bench.py [--calibrate] [../shared/data] [--out docs/segmentation]

``--calibrate`` only: draw synthetic segments from random stationary 4-channel processes and print the
distributions (in units of the within-segment spread) that set ``THRESHOLD_SCALE``; no labels involved.

Otherwise, on 86_01, 13_29, 13_30, 14_14 (limb angles, 120 Hz), with the cuts of
(a) the reference (upper bound of the naming step), (b) ``KernelCPDSegmenter(n_cuts=true k)``,
(c) the unsupervised default segmenters (``make_segmenter(method, take)``: kernelcpd, pelt, arma,
clasp), each take named alone and all takes named together (all segments clustered at once).
Frame accuracy (best one-to-one matching), purity and NMI at frame level; writes
``naming.md`` and ``naming.json`` in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from mocapkit.segment.cluster_metrics import frame_accuracy, nmi, purity
from mocapkit.segment.naming import THRESHOLD_SCALE, name_actions

UNSUPERVISED = ("kernelcpd", "pelt", "arma", "clasp")
#: (distance, rule) pairs run on the shared takes; the threshold was calibrated with the MMD distance only.
CONFIGS = (("mmd", "threshold"), ("mmd", "silhouette"), ("dtw", "threshold"))


# --------------------------------------------------------------------------------------------------
# synthetic calibration
# --------------------------------------------------------------------------------------------------


def random_process(rng: np.random.Generator, d: int = 4) -> dict:
    """A stationary process: per channel two harmonics of one period (0.5--2 s at 120 Hz), an
    offset, amplitudes, phases, and AR(1) noise."""
    return {
        "period": rng.uniform(60, 240),
        "offset": rng.normal(0.0, 1.0, d),
        "amp": rng.uniform(0.2, 1.5, d),
        "harm": rng.uniform(0.0, 0.5, d),
        "phase": rng.uniform(0, 2 * np.pi, d),
        "phase2": rng.uniform(0, 2 * np.pi, d),
        "noise": rng.uniform(0.05, 0.3, d),
    }


def draw_segment(rng: np.random.Generator, p: dict, n: int, jitter: float = 0.1) -> np.ndarray:
    """One segment of ``n`` frames of process ``p``: its own phase, period and amplitude jittered by
    ``jitter`` (relative), offset by ``jitter`` (absolute)."""
    d = p["offset"].size
    t = np.arange(n)[:, None]
    period = p["period"] * (1 + rng.uniform(-jitter, jitter))
    amp = p["amp"] * (1 + rng.uniform(-jitter, jitter, d))
    off = p["offset"] + rng.uniform(-jitter, jitter, d)
    ph = rng.uniform(0, 2 * np.pi)
    w = 2 * np.pi * t / period
    x = off + amp * (np.sin(w + p["phase"] + ph) + p["harm"] * np.sin(2 * w + p["phase2"] + 2 * ph))
    e = rng.normal(0.0, 1.0, (n, d)) * p["noise"] * np.sqrt(1 - 0.9**2)
    for i in range(1, n):
        e[i] += 0.9 * e[i - 1]
    return x + e


def synthetic_take(rng: np.random.Generator, n_proc: int, per_proc: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(features, cuts, class per segment)``: ``per_proc`` segments of 300--900 frames of each of
    ``n_proc`` random processes, in random order."""
    procs = [random_process(rng) for _ in range(n_proc)]
    cls = rng.permutation(np.repeat(np.arange(n_proc), per_proc))
    segs = [draw_segment(rng, procs[c], int(rng.integers(300, 901))) for c in cls]
    cuts = np.cumsum([s.shape[0] for s in segs])[:-1]
    return np.concatenate(segs), cuts, cls


def calibrate(n_draws: int = 200, seed: int = 0) -> dict:
    """Within-process and between-process distances in units of the within-segment spread, over
    ``n_draws`` synthetic takes of 4 processes x 3 segments; then the exact-k rate of the threshold
    rule for 2..5 processes (the choice rule: ``THRESHOLD_SCALE`` is the smallest grid value whose
    same-process split rate is at most 5 %)."""
    rng = np.random.default_rng(seed)
    within, between = [], []
    for _ in range(n_draws):
        x, cuts, cls = synthetic_take(rng, 4)
        r = name_actions(x, cuts, n_classes=1)
        d = r.distances / r.spread
        for c in range(4):
            idx = np.flatnonzero(cls == c)
            within.append(d[np.ix_(idx, idx)].max())
            for c2 in range(c + 1, 4):
                between.append(d[np.ix_(idx, np.flatnonzero(cls == c2))].mean())
    within, between = np.array(within), np.array(between)
    q = {"within_q50": float(np.quantile(within, 0.5)), "within_q95": float(np.quantile(within, 0.95)),
         "within_q99": float(np.quantile(within, 0.99)), "between_q01": float(np.quantile(between, 0.01)),
         "between_q05": float(np.quantile(between, 0.05)), "between_q50": float(np.quantile(between, 0.5))}
    grid = np.round(np.arange(1.0, 4.01, 0.1), 2)
    q["split_rate"] = {float(c): float((within > c).mean()) for c in grid}
    q["merge_rate"] = {float(c): float((between <= c).mean()) for c in grid}
    q["chosen_scale"] = float(min(c for c in grid if q["split_rate"][float(c)] <= 0.05))
    rng = np.random.default_rng(seed + 1)
    exact = {}
    for k in range(2, 6):
        hits = 0
        for _ in range(50):
            x, cuts, cls = synthetic_take(rng, k)
            hits += name_actions(x, cuts).n_classes == k
        exact[k] = hits / 50
    q["exact_k_rate"] = exact
    return q


# --------------------------------------------------------------------------------------------------
# the shared takes
# --------------------------------------------------------------------------------------------------


def scores(naming, takes, idx=None) -> dict:
    idx = range(len(takes)) if idx is None else idx
    found = np.concatenate([naming.frame_letters(i) for i in range(len(takes))])
    ref = np.concatenate([takes[i].actions for i in idx])
    return {"frame_accuracy": frame_accuracy(found, ref), "purity": purity(found, ref), "nmi": nmi(found, ref),
            "n_classes": naming.n_classes, "n_ref_classes": int(len(set(ref.tolist())))}


def run(cmu_dir: Path, log=print) -> list[dict]:
    from mocapkit.evaluation.segmentation import MOCAP_TAKES, load_take, make_segmenter
    from mocapkit.segment.kernelcpd import KernelCPDSegmenter

    takes = [load_take(cmu_dir, t) for t in MOCAP_TAKES]
    cut_sets: dict[str, list[np.ndarray]] = {"reference": [t.ref.cuts for t in takes]}
    cut_sets["kernelcpd (known k)"] = [KernelCPDSegmenter(n_cuts=len(t.ref.cuts)).fit_predict(t.limbs) for t in takes]
    for m in UNSUPERVISED:
        cut_sets[m] = [make_segmenter(m, t).fit_predict(t.limbs) for t in takes]
    rows = []
    for cuts_name, cuts in cut_sets.items():
        for dist, rule in CONFIGS:
            for i, t in enumerate(takes):
                t0 = time.perf_counter()
                nm = name_actions(t.limbs, cuts[i], rule=rule, distance=dist)
                dt = time.perf_counter() - t0
                row = {"cuts": cuts_name, "distance": dist, "rule": rule, "take": t.name, "n_segments": len(cuts[i]) + 1,
                       "letters": " ".join(nm.letters[0]), "seconds": dt}
                row.update(scores(nm, [t]))
                rows.append(row)
            t0 = time.perf_counter()
            nm = name_actions([t.limbs for t in takes], cuts, rule=rule, distance=dist)
            dt = time.perf_counter() - t0
            row = {"cuts": cuts_name, "distance": dist, "rule": rule, "take": "all 4 together",
                   "n_segments": sum(len(c) + 1 for c in cuts),
                   "letters": " | ".join(" ".join(l) for l in nm.letters), "seconds": dt}
            row.update(scores(nm, takes))
            rows.append(row)
            if log:
                for r in rows[-5:]:
                    log(f"{r['cuts']:20s} {r['distance']:4s} {r['rule']:10s} {r['take']:15s} acc {r['frame_accuracy']:.3f} "
                        f"pur {r['purity']:.3f} nmi {r['nmi']:.3f} k {r['n_classes']}/{r['n_ref_classes']} "
                        f"{r['letters']}")
    return rows


def to_markdown(rows: list[dict], calib: dict | None) -> str:
    out = ["# Actions named across takes", "",
           "Generated by `benchmarks/naming_bench.py` (one run). Frame-level scores against the take labels: "
           "frame accuracy after the best one-to-one matching of found classes to labels (Hungarian), "
           "cluster purity, NMI (arithmetic normalisation). `k`: classes found / labelled. Default naming "
           f"(`name_actions`: MMD distance, average linkage, threshold {THRESHOLD_SCALE} x within-segment spread) "
           "unless the row says otherwise (silhouette rule; DTW distance of `segment/similarity.py`, Eq. 5 distance, with the threshold calibrated for MMD). No label is used by any step; the labels only score.", ""]
    out += ["## Summary (frame accuracy)", "",
            "| cuts | distance | rule | 86_01 | mean of the 4 takes named alone | 4 takes named together |",
            "|---|---|---|---:|---:|---:|"]
    keys = list(dict.fromkeys((r["cuts"], r["distance"], r["rule"]) for r in rows))
    for key in keys:
        rs = [r for r in rows if (r["cuts"], r["distance"], r["rule"]) == key]
        alone = [r["frame_accuracy"] for r in rs if r["take"] != "all 4 together"]
        together = [r["frame_accuracy"] for r in rs if r["take"] == "all 4 together"]
        first = [r["frame_accuracy"] for r in rs if r["take"] == "86_01"]
        out.append(f"| {key[0]} | {key[1]} | {key[2]} | {first[0]:.3f} | {np.mean(alone):.3f} | {together[0]:.3f} |")
    out += ["", "## Every row", ""]
    out += ["| cuts | distance | rule | take | segments | frame acc. | purity | NMI | k | letters |",
            "|---|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        out.append(f"| {r['cuts']} | {r['distance']} | {r['rule']} | {r['take']} | {r['n_segments']} | {r['frame_accuracy']:.3f} | "
                   f"{r['purity']:.3f} | {r['nmi']:.3f} | {r['n_classes']} / {r['n_ref_classes']} | {r['letters']} |")
    if calib:
        out += ["", "## Calibration of the threshold (synthetic only)", "",
                "200 synthetic takes of 4 random stationary processes x 3 segments (300--900 frames, "
                "per-segment phase, 10 % jitter; `random_process`/`draw_segment` in the benchmark). "
                "Distances in units of the within-segment spread:", "",
                f"- largest distance between segments of one process: median {calib['within_q50']:.2f}, "
                f"95 % {calib['within_q95']:.2f}, 99 % {calib['within_q99']:.2f}",
                f"- mean distance between two processes: 1 % {calib['between_q01']:.2f}, "
                f"5 % {calib['between_q05']:.2f}, median {calib['between_q50']:.2f}",
                f"- smallest multiple (0.1 grid) splitting at most 5 % of processes: {calib['chosen_scale']:.1f} "
                f"(the library's `THRESHOLD_SCALE` = {THRESHOLD_SCALE})",
                "- exact number of classes found by the threshold rule (50 synthetic takes each): "
                + ", ".join(f"{k} processes {v:.2f}" for k, v in calib["exact_k_rate"].items())]
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("data", nargs="?", default="../shared/data")
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    calib = calibrate()
    print(json.dumps({k: v for k, v in calib.items() if k not in ("split_rate", "merge_rate")}, indent=1))
    print("c: P(same process split) P(two processes merged)")
    for c in calib["split_rate"]:
        print(f"{c:.1f}: {calib['split_rate'][c]:.3f} {calib['merge_rate'][c]:.3f}")
    if a.calibrate:
        return
    rows = run(Path(a.data) / "cmu")
    md = to_markdown(rows, calib)
    print(md)
    if a.out:
        out = Path(a.out)
        (out / "naming.md").write_text(md)
        (out / "naming.json").write_text(json.dumps({"rows": rows, "calibration": calib,
                                                     "threshold_scale": THRESHOLD_SCALE}, indent=1) + "\n")


if __name__ == "__main__":
    main()
