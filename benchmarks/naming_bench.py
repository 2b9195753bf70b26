"""Actions named across takes (:func:`mocapkit.segment.naming.name_actions`): the calibration of the
threshold on synthetic segments, then the naming of the 4 shared labelled CMU takes.

    .venv/bin/python benchmarks/naming_bench.py [--calibrate] [../shared/data] [--out docs/segmentation]

``--calibrate`` only: draw synthetic segments from random stationary 4-channel processes and print the
distributions (in units of the spread, measured on blocks or on segment halves) that set
``THRESHOLD_SCALE``, and the naming's frame accuracy on synthetic takes under perturbed cuts; no labels.

Otherwise, on 86_01, 13_29, 13_30, 14_14 (limb angles, 120 Hz), with the cuts of
(a) the reference (upper bound of the naming step), (b) ``KernelCPDSegmenter(n_cuts=true k)``,
(c) the unsupervised default segmenters (``make_segmenter(method, take)``: kernelcpd, pelt, arma,
clasp), (d) a control cutting every 400 frames; each take named alone and all takes named together
(all segments clustered at once).
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
#: Steps of the regular control cutter whose naming is reported per take (default naming).
REGULAR_STEPS = (200, 300, 400, 500, 600, 800)
#: (distance, rule, spread) run on the shared takes; the threshold was calibrated with the MMD distance only.
CONFIGS = (("mmd", "threshold", "blocks"), ("mmd", "threshold", "halves"), ("mmd", "silhouette", "blocks"),
           ("dtw", "threshold", "blocks"))


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


def synthetic_take(
    rng: np.random.Generator, n_proc: int, per_proc: int = 3
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(features, cuts, class per segment)``: ``per_proc`` segments of 300--900 frames of each of
    ``n_proc`` random processes, in random order."""
    procs = [random_process(rng) for _ in range(n_proc)]
    cls = rng.permutation(np.repeat(np.arange(n_proc), per_proc))
    segs = [draw_segment(rng, procs[c], int(rng.integers(300, 901))) for c in cls]
    cuts = np.cumsum([s.shape[0] for s in segs])[:-1]
    return np.concatenate(segs), cuts, cls


def perturbed_cuts(rng: np.random.Generator, cuts: np.ndarray, n: int, how: str) -> np.ndarray:
    """Cuts a real segmenter might give instead of the true ones: ``exact``, ``shifted`` (each by up
    to 100 frames), ``extra`` (len + 2 random cuts added, none closer than 120 frames to the previous),
    ``every400`` / ``every200`` (a regular cutter)."""
    if how == "exact":
        return cuts
    if how == "shifted":
        c = np.unique(cuts + rng.integers(-100, 101, cuts.size))
        return c[(c > 0) & (c < n)]
    if how.startswith("every"):
        step = int(how[5:])
        return np.arange(step, n, step)
    c = np.unique(np.concatenate([cuts, rng.integers(150, n - 150, cuts.size + 2)]))
    keep = [int(c[0])]
    for v in c[1:]:
        if v - keep[-1] >= 120:
            keep.append(int(v))
    return np.array(keep)


PERTURBATIONS = ("exact", "shifted", "extra", "every400", "every200")


def _cut_tree(d: np.ndarray, t: float) -> int:
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    if d.shape[0] == 1:
        return 1
    return int(fcluster(linkage(squareform(d, checks=False), method="average"), t, criterion="distance").max())


def calibrate(spread: str, n_per_k: int = 40, seed: int = 0) -> dict:
    """The threshold scale for ``spread`` (``"blocks"`` or ``"halves"``) on synthetic takes only.

    ``n_per_k`` synthetic takes of k = 1..5 random processes x 3 segments; the scale is the one of
    the grid 0.5, 0.6, ..., 4.0 that finds exactly k classes most often (the smallest of ties).
    Reported beside it: the largest distance between two segments of one process and the mean
    distance between two processes, in spreads; on fresh takes (other seed), the exact-k rate per k
    and the frame accuracy of the naming under perturbed cuts (40 takes of 2..5 processes each)."""
    rng = np.random.default_rng(seed)
    within, between, cases = [], [], []
    for k in range(1, 6):
        for _ in range(n_per_k):
            x, cuts, cls = synthetic_take(rng, k)
            r = name_actions(x, cuts, n_classes=1, spread=spread)
            d = r.distances / r.spread
            cases.append((d, k))
            for c in range(k):
                idx = np.flatnonzero(cls == c)
                within.append(d[np.ix_(idx, idx)].max())
                for c2 in range(c + 1, k):
                    between.append(d[np.ix_(idx, np.flatnonzero(cls == c2))].mean())
    within, between = np.array(within), np.array(between)
    q = {"spread": spread, "library_scale": THRESHOLD_SCALE[spread],
         "within_q50": float(np.quantile(within, 0.5)), "within_q95": float(np.quantile(within, 0.95)),
         "within_q99": float(np.quantile(within, 0.99)), "between_q01": float(np.quantile(between, 0.01)),
         "between_q05": float(np.quantile(between, 0.05)), "between_q50": float(np.quantile(between, 0.5))}
    grid = np.round(np.arange(0.5, 4.01, 0.1), 2)
    rate = {float(t): float(np.mean([_cut_tree(d, t) == k for d, k in cases])) for t in grid}
    q["exact_k_rate_by_scale"] = rate
    scale = float(max(rate, key=lambda t: (rate[t], -t)))
    q["chosen_scale"] = scale
    rng = np.random.default_rng(seed + 1)
    exact = {}
    for k in range(1, 6):
        hits = 0
        for _ in range(50):
            x, cuts, cls = synthetic_take(rng, k)
            hits += name_actions(x, cuts, spread=spread, threshold_scale=scale).n_classes == k
        exact[k] = hits / 50
    q["exact_k_rate"] = exact
    robust = {}
    for how in PERTURBATIONS:
        rng = np.random.default_rng(seed + 2)
        accs = []
        for _ in range(40):
            x, cuts, cls = synthetic_take(rng, int(rng.integers(2, 6)))
            truth = np.repeat(cls, np.diff(np.concatenate([[0], cuts, [x.shape[0]]])))
            nm = name_actions(x, perturbed_cuts(rng, cuts, x.shape[0], how), spread=spread, threshold_scale=scale)
            accs.append(frame_accuracy(nm.frame_classes(0), truth))
        robust[how] = float(np.mean(accs))
    q["frame_accuracy_perturbed"] = robust
    return q


# --------------------------------------------------------------------------------------------------
# the shared takes
# --------------------------------------------------------------------------------------------------


def scores(naming, takes) -> dict:
    """Frame-level scores of ``naming`` (of ``takes``, in order) against the takes' action labels."""
    found = np.concatenate([naming.frame_letters(i) for i in range(len(takes))])
    ref = np.concatenate([t.actions for t in takes])
    return {"frame_accuracy": frame_accuracy(found, ref), "purity": purity(found, ref), "nmi": nmi(found, ref),
            "n_classes": naming.n_classes, "n_ref_classes": len(set(ref.tolist()))}


def run(cmu_dir: Path, log=print) -> list[dict]:
    from mocapkit.evaluation.segmentation import MOCAP_TAKES, load_take, make_segmenter
    from mocapkit.segment.kernelcpd import KernelCPDSegmenter

    takes = [load_take(cmu_dir, t) for t in MOCAP_TAKES]
    cut_sets: dict[str, list[np.ndarray]] = {"reference": [t.ref.cuts for t in takes]}
    cut_sets["kernelcpd (known k)"] = [KernelCPDSegmenter(n_cuts=len(t.ref.cuts)).fit_predict(t.limbs) for t in takes]
    for m in UNSUPERVISED:
        cut_sets[m] = [make_segmenter(m, t).fit_predict(t.limbs) for t in takes]
    cut_sets["every 400 frames (control)"] = [np.arange(400, t.n_frames, 400) for t in takes]
    rows = []
    for cuts_name, cuts in cut_sets.items():
        for dist, rule, spread in CONFIGS:
            for i, t in enumerate(takes):
                t0 = time.perf_counter()
                nm = name_actions(t.limbs, cuts[i], rule=rule, distance=dist, spread=spread)
                dt = time.perf_counter() - t0
                row = {
                    "cuts": cuts_name,
                    "distance": dist,
                    "rule": rule if rule == "silhouette" else f"threshold/{spread}",
                    "take": t.name,
                    "n_segments": len(cuts[i]) + 1,
                    "letters": " ".join(nm.letters[0]),
                    "seconds": dt,
                }
                row.update(scores(nm, [t]))
                rows.append(row)
            t0 = time.perf_counter()
            nm = name_actions([t.limbs for t in takes], cuts, rule=rule, distance=dist, spread=spread)
            dt = time.perf_counter() - t0
            row = {
                "cuts": cuts_name,
                "distance": dist,
                "rule": rule if rule == "silhouette" else f"threshold/{spread}",
                "take": "all 4 together",
                "n_segments": sum(len(c) + 1 for c in cuts),
                "letters": " | ".join(" ".join(run) for run in nm.letters),
                "seconds": dt,
            }
            row.update(scores(nm, takes))
            rows.append(row)
            if log:
                for r in rows[-5:]:
                    log(
                        f"{r['cuts']:20s} {r['distance']:4s} {r['rule']:17s} {r['take']:15s} "
                        f"acc {r['frame_accuracy']:.3f} "
                        f"pur {r['purity']:.3f} nmi {r['nmi']:.3f} k {r['n_classes']}/{r['n_ref_classes']} "
                        f"{r['letters']}"
                    )
    for step in REGULAR_STEPS:
        for t in takes:
            nm = name_actions(t.limbs, np.arange(step, t.n_frames, step))
            row = {"cuts": f"every {step} frames", "distance": "mmd", "rule": "threshold/blocks", "take": t.name,
                   "n_segments": len(nm.letters[0]), "letters": " ".join(nm.letters[0]), "seconds": 0.0,
                   "regular_step": step}
            row.update(scores(nm, [t]))
            rows.append(row)
    return rows


def to_markdown(rows: list[dict], calibs: list[dict]) -> str:
    out = ["# Actions named across takes", "",
           ("Generated by `benchmarks/naming_bench.py` (one run). Frame-level scores against the take labels: "
           "frame accuracy after the best one-to-one matching of found classes to labels (Hungarian), "
           "cluster purity, NMI (arithmetic normalisation). `k`: classes found / labelled. Naming by "
           "`name_actions`: MMD (or the Eq. 5 DTW distance of `segment/similarity.py`) between segments, "
           "average linkage, number of classes by the threshold rule (dendrogram cut at "
           f"{THRESHOLD_SCALE['blocks']} x the spread measured on 2-s blocks, the default, or "
           f"{THRESHOLD_SCALE['halves']} x the spread of segment halves) or by the silhouette. The threshold "
           "was calibrated on synthetic data with MMD; with DTW the same multiple is used uncalibrated. "
           "No label is used by any step; the labels only score. `every 400 frames` is a control cutter "
           "that knows nothing of the take."), ""]
    out += ["## Summary (frame accuracy)", "",
            "| cuts | distance | rule | 86_01 | mean of the 4 takes named alone | 4 takes named together |",
            "|---|---|---|---:|---:|---:|"]
    main_rows = [r for r in rows if "regular_step" not in r]
    keys = list(dict.fromkeys((r["cuts"], r["distance"], r["rule"]) for r in main_rows))
    for key in keys:
        rs = [r for r in main_rows if (r["cuts"], r["distance"], r["rule"]) == key]
        alone = [r["frame_accuracy"] for r in rs if r["take"] != "all 4 together"]
        together = [r["frame_accuracy"] for r in rs if r["take"] == "all 4 together"]
        first = [r["frame_accuracy"] for r in rs if r["take"] == "86_01"]
        out.append(f"| {key[0]} | {key[1]} | {key[2]} | {first[0]:.3f} | {np.mean(alone):.3f} | {together[0]:.3f} |")
    names = list(dict.fromkeys(r["take"] for r in rows if "regular_step" in r))
    out += ["", "## A regular cutter, then naming (default naming; frame accuracy per take)", "",
            ("Cut every N frames whatever the take (no label, no segmenter), name the pieces; adjacent pieces "
            "with one letter are one action."), "",
            "| N | " + " | ".join(names) + " |", "|---:|" + "---:|" * len(names)]
    for step in REGULAR_STEPS:
        accs = {r["take"]: r["frame_accuracy"] for r in rows if r.get("regular_step") == step}
        out.append(f"| {step} | " + " | ".join(f"{accs[n]:.3f}" for n in names) + " |")
    out += ["", "## Calibration of the threshold (synthetic only)", "",
            ("200 synthetic takes of k = 1..5 random stationary processes x 3 segments (40 per k; 300--900 frames, "
            "per-segment phase, 10 % jitter; `random_process`/`draw_segment` in the benchmark). Distances in "
            "units of the spread. The scale is the multiple (0.5..4.0 by 0.1) finding exactly k classes most "
            "often on these takes. With it, on fresh takes: how often exactly k classes are found (50 per k), "
            "and the frame accuracy when the cuts are not the true ones (40 takes of 2--5 processes each: "
            "true, shifted by up to 100 frames, 2 extra cuts, a cut every 400 or 200 frames)."), "",
            ("| spread | same process (largest): median / 95 % / 99 % | two processes (mean): 1 % / 5 % / median "
             "| scale (library) | exact k for k = 1, 2, 3, 4, 5 | frame acc.: ") + ", ".join(PERTURBATIONS) + " |",
            "|---|---|---|---|---|---|"]
    for c in calibs:
        out.append(f"| {c['spread']} | {c['within_q50']:.2f} / {c['within_q95']:.2f} / {c['within_q99']:.2f} | "
                   f"{c['between_q01']:.2f} / {c['between_q05']:.2f} / {c['between_q50']:.2f} | "
                   f"{c['chosen_scale']:.1f} ({c['library_scale']}) | "
                   + ", ".join(f"{v:.2f}" for v in c["exact_k_rate"].values()) + " | "
                   + ", ".join(f"{c['frame_accuracy_perturbed'][h]:.3f}" for h in PERTURBATIONS) + " |")
    out += ["", "## Every row", "",
            "| cuts | distance | rule | take | segments | frame acc. | purity | NMI | k | letters |",
            "|---|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in main_rows:
        out.append(f"| {r['cuts']} | {r['distance']} | {r['rule']} | {r['take']} | {r['n_segments']} | "
                   f"{r['frame_accuracy']:.3f} | {r['purity']:.3f} | {r['nmi']:.3f} | "
                   f"{r['n_classes']} / {r['n_ref_classes']} | {r['letters']} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("data", nargs="?", default="../shared/data")
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    calibs = []
    for spread in ("blocks", "halves"):
        c = calibrate(spread)
        calibs.append(c)
        print(json.dumps({k: v for k, v in c.items() if k != "exact_k_rate_by_scale"}, indent=1))
        print("scale: exact-k rate on the calibration takes")
        print(" ".join(f"{t:.1f}:{v:.2f}" for t, v in c["exact_k_rate_by_scale"].items()))
    if a.calibrate:
        return
    rows = run(Path(a.data) / "cmu")
    md = to_markdown(rows, calibs)
    print(md)
    if a.out:
        out = Path(a.out)
        (out / "naming.md").write_text(md)
        (out / "naming.json").write_text(json.dumps({"rows": rows, "calibration": calibs,
                                                     "threshold_scale": dict(THRESHOLD_SCALE)}, indent=1) + "\n")


if __name__ == "__main__":
    main()
