"""The segmentation benchmark: every method on every labelled shared take and on TSSB.

Mocap takes (``../shared/data/cmu``): 86_01 with its HACA labels (86.asf), and the mocap6 takes
13_29, 13_30, 14_14 with per-frame labels (86.asf as an approximate skeleton: same bone names and
DOFs). Every method sees the 4 limb angles of Table 3 at 120 Hz, except PCA, which sees the pose
(root-relative joint positions) as in Barbič et al. 2004. The MLP is trained leave-one-take-out on
the other three takes' per-frame action labels. No method is told the number of cuts; the
``known_k`` rows (when asked for) are a separate mode that is given it.

TSSB (``../shared/data/tssb``): the 75 univariate series, methods applied to the raw series (PCA and
K-means on a delay embedding of the benchmark's window width), Covering per series next to the
published Covering of ClaSP, FLOSS, BinSeg, PELT (``published-covering-unknown-segments.csv``).
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.skeletal.labels import Reference, read_frame_labels, read_haca_labels
from mocapkit.segment.metrics import covering, f1_margin, frame_agreement, ri_paper

MOCAP_TAKES = ("86_01", "13_29", "13_30", "14_14")
#: ``every400`` is no method: it cuts every 400 frames (3.3 s at 120 Hz), to show what each metric makes of that.
MOCAP_METHODS = ("auto", "arma", "every400", "pca", "kmeans", "mlp", "kernelcpd", "pelt", "clasp")
TSSB_METHODS = ("arma", "pca", "kmeans", "kernelcpd", "pelt", "clasp")
KNOWN_K_METHODS = ("kernelcpd", "clasp")
#: Methods also run with ``n_cuts="auto"`` (the penalty read off their own cost curve, no labels).
CURVE_METHODS = ("kernelcpd", "pelt")
#: Row suffix of each mode.
MODE_SUFFIX = {"unknown_k": "", "known_k": " (known k)", "curve": " (curve penalty)"}
PUBLISHED = ("ClaSP", "FLOSS", "BinSeg", "PELT")
#: F1 margin in seconds (60 frames at 120 Hz); 86_01 cuts also count inside the annotators' a..c interval.
MARGIN_S = 0.5


@dataclass
class Take:
    name: str
    limbs: np.ndarray
    pose: np.ndarray
    ref: Reference
    actions: np.ndarray  # per-frame action label
    partition: np.ndarray | None = None  # the 8 limb-bone partition angles (Table 2)

    @property
    def n_frames(self) -> int:
        return int(self.limbs.shape[0])


def load_take(cmu_dir: Path, name: str) -> Take:
    """Features and reference of one shared CMU take (labels checked before the features)."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.segment.features import motion_features, pose_features

    motion = load_motion(cmu_dir / f"{name}.amc", asf=cmu_dir / "86.asf")
    n = motion.n_frames
    lab = cmu_dir / f"{name}.labels.txt"
    ref = read_haca_labels(lab, n_frames=n) if name.startswith("86_") else read_frame_labels(lab, n_frames=n)
    feats = motion_features(motion)
    actions = np.asarray(ref.labels, dtype=object)[ref.frame_labels()]
    return Take(name, feats.limbs, pose_features(motion), ref, actions, feats.partition)


def find_pairs(items, label_suffix: str = ".labels.txt") -> list[tuple[Path, Path]]:
    """``(motion, labels)`` pairs from ``TAKE=LABELS`` strings and folders (every motion file
    ``X.<ext>`` of a folder with a ``X.labels.txt`` beside it; ASF files are skeletons, not takes)."""
    out = []
    for it in items:
        it = str(it)
        if "=" in it:
            a, b = it.split("=", 1)
            out.append((Path(a.strip()), Path(b.strip())))
            continue
        folder = Path(it)
        if not folder.is_dir():
            raise InvalidParameterError(
                f"{it}: expected TAKE=LABELS or a folder of takes with TAKE.labels.txt beside them"
            )
        found = [
            (f, f.with_name(f.stem + label_suffix))
            for f in sorted(folder.iterdir())
            if f.is_file()
            and not f.name.endswith(label_suffix)
            and f.suffix.lower() not in (".asf", ".txt", ".md")
            and f.with_name(f.stem + label_suffix).is_file()
        ]
        if not found:
            raise InvalidParameterError(f"{folder}: no take with a {label_suffix} file beside it")
        out += found
    return out


def load_user_takes(pairs, asf: Path | None = None, rate: float | None = None, log=None) -> list[Take]:
    """Every take and its labels. All label files are read and checked against their take's frame
    count first (a bad file fails before any feature is computed); then the features."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.io.skeletal.labels import read_reference
    from mocapkit.segment.features import motion_features, pose_features

    motions = []
    for mot, lab in pairs:
        motion = load_motion(mot, asf=asf, rate=rate)
        ref = read_reference(lab, motion.n_frames, float(motion.rate))
        for w in ref.warnings:
            if log:
                log(f"warning: {w}")
        motions.append((Path(mot).stem, motion, ref))
    takes = []
    for name, motion, ref in motions:
        feats = motion_features(motion)
        actions = np.asarray(ref.labels, dtype=object)[ref.frame_labels()]
        takes.append(Take(name, feats.limbs, pose_features(motion), ref, actions, feats.partition))
    return takes


def auto_settings(rate_hz: float, downsample: int | None = None) -> dict:
    """``AutoSegmenter`` settings at ``rate_hz``: keep the factor nearest 30 Hz (or ``downsample``); moving
    statistics and the shortest segment span 1 s of kept samples."""
    ds = downsample if downsample is not None else max(1, int(round(rate_hz / 30.0)))
    one_s = max(2, int(round(rate_hz / ds)))
    return {"downsample": ds, "width": one_s, "min_size": one_s}


def rate_scaled(method: str, rate_hz: float) -> dict:
    """Settings of a take at ``rate_hz``: the library defaults are set for 120 Hz (1 s shortest segment,
    0.5 s smoothing, Barbič's 2 s warm-up; ARMA keeps every 4th frame, ~30 Hz); at another rate the
    frame counts are scaled and ARMA keeps the factor nearest 30 Hz (as the ``segment`` command does).
    At 120 Hz: no change (``{}``)."""
    if abs(rate_hz - 120.0) < 1e-9:
        return {}
    f = rate_hz / 120.0

    def fr(n: int) -> int:
        return max(1, int(round(n * f)))

    if method == "arma":
        return {"downsample": max(1, int(round(rate_hz / 30.0)))}
    if method == "auto":
        return auto_settings(rate_hz)
    if method == "pca":
        step = fr(5)
        return {"k_init": fr(240), "step": step, "lag": step * max(1, round(fr(60) / step)), "min_segment": fr(120)}
    if method in ("kmeans", "mlp"):
        return {"smooth": fr(61) | 1, "min_segment": fr(120)}
    if method in ("kernelcpd", "pelt"):
        return {"min_size": max(2, fr(120))}
    return {}


class RegularCutter:
    """Cuts every ``step`` frames, whatever the take: the reference line of the metrics table."""

    def __init__(self, step: int = 400):
        self.step = int(step)

    def fit_predict(self, X) -> np.ndarray:
        return np.arange(self.step, len(X), self.step, dtype=np.int64)


def features_for(method: str, take: Take) -> np.ndarray:
    """What ``method`` sees: the pose for PCA (Barbič et al.), the 8 partition angles for ``auto``,
    the 4 limb angles otherwise."""
    if method == "pca":
        return take.pose
    if method == "auto":
        if take.partition is None:
            raise InvalidParameterError(f"{take.name}: method 'auto' needs the take's 8 partition angles "
                                        "(Take.partition)")
        return take.partition
    return take.limbs


def make_segmenter(method: str, take: Take | None = None, others: list[Take] | None = None,
                   n_cuts: int | str | None = None):
    """A segmenter with the benchmark's settings (the library defaults, scaled to the take's rate by
    :func:`rate_scaled`; MLP trained on ``others``)."""
    from mocapkit.segment import BASELINES
    from mocapkit.segment.arma import ARMASegmenter

    kw = rate_scaled(method, take.ref.rate_hz) if take is not None else {}
    if method == "arma":
        return ARMASegmenter(**kw)
    if method == "auto":
        from mocapkit.segment.autok import AutoSegmenter

        return AutoSegmenter(**kw)
    if method == "every400":
        return RegularCutter(max(1, int(round(400 * (take.ref.rate_hz if take is not None else 120.0) / 120.0))))
    cls = BASELINES[method]
    if method == "mlp":
        kw["train"] = [(t.limbs, t.actions) for t in (others or [])]
    if n_cuts is not None:
        kw["n_cuts"] = n_cuts
    return cls(**kw)


def score(pred, ref: Reference, margin_s: float = MARGIN_S, naming=None) -> dict:
    """F1 (margin ``margin_s`` seconds at the reference's rate, or the annotators' interval), frame agreement,
    the paper's RI (Eq. 33 as its authors compute it; None without reference cuts) and Covering."""
    n = ref.n_frames
    margin = int(round(margin_s * ref.rate_hz))
    f = f1_margin(pred, ref.cuts, n, margin, intervals=ref.intervals)
    return {
        "frame_agreement": frame_agreement(pred, ref.cuts, n),
        "ri_paper": ri_paper(pred, ref.cuts, n) if len(ref.cuts) else None,
        "f1": f.f1,
        "precision": f.precision,
        "recall": f.recall,
        "covering": covering(pred, ref.cuts, n),
        **(naming_scores(naming, ref) if naming is not None else {}),
    }


def naming_scores(naming, ref: Reference) -> dict:
    """Frame accuracy after the best one-to-one matching of found action classes to labels, purity and
    NMI of a one-take :class:`~mocapkit.segment.naming.Naming` against the reference's frame labels."""
    from mocapkit.segment.cluster_metrics import frame_accuracy, nmi, purity

    found = naming.frame_letters(0)
    labels = np.asarray(ref.labels, dtype=object)[ref.frame_labels()]
    return {"naming_accuracy": frame_accuracy(found, labels), "naming_purity": purity(found, labels),
            "naming_nmi": nmi(found, labels)}


def run_mocap(cmu_dir, methods=MOCAP_METHODS, known_k: bool = False, log=None) -> list[dict]:
    """Every method on every labelled take: one row per (take, method). ``cmu_dir``: the shared CMU
    folder (its 4 takes), or a list of :class:`Take` (:func:`load_user_takes`). The MLP is trained
    on the other takes, so it needs at least two (skipped otherwise, with a message)."""
    takes = [load_take(Path(cmu_dir), t) for t in MOCAP_TAKES] if isinstance(cmu_dir, (str, Path)) else list(cmu_dir)
    if "mlp" in methods and len(takes) < 2:
        methods = [m for m in methods if m != "mlp"]
        if log:
            log("mlp skipped: it is trained on the other takes and needs at least two")
    rows = []
    jobs = ([(m, None) for m in methods] + [(m, "curve") for m in CURVE_METHODS if m in methods]
            + ([(m, "known_k") for m in KNOWN_K_METHODS if m in methods] if known_k else []))
    for take in takes:
        others = [t for t in takes if t is not take]
        for method, mode in jobs:
            k = len(take.ref.cuts) if mode == "known_k" else "auto" if mode == "curve" else None
            seg = make_segmenter(method, take, others, n_cuts=k)
            X = features_for(method, take)
            t0 = time.perf_counter()
            pred = seg.fit_predict(X)
            dt = time.perf_counter() - t0
            row = {"dataset": "cmu", "take": take.name, "method": method, "mode": mode or "unknown_k",
                   "n_frames": take.n_frames, "n_ref_cuts": int(len(take.ref.cuts)), "n_cuts": int(len(pred)),
                   "cuts": [int(c) for c in pred], "ref_cuts": [int(c) for c in take.ref.cuts], "seconds": dt}
            from mocapkit.segment.naming import name_segments

            row.update(score(pred, take.ref, naming=name_segments(take.limbs, pred, take.ref.rate_hz)))
            rows.append(row)
            if log:
                log(
                    f"{take.name} {method}{MODE_SUFFIX[mode or 'unknown_k']}: frame agreement "
                    f"{row['frame_agreement']:.3f} RI (paper) {_f(row['ri_paper'])} F1 {row['f1']:.3f} "
                    f"Cov {row['covering']:.3f} cuts {len(pred)}/{len(take.ref.cuts)} {dt:.2f} s"
                )
    return rows


def read_tssb(tssb_dir: Path) -> list[tuple[str, np.ndarray, int, np.ndarray]]:
    """``(name, series, window, change points)`` of every series listed in ``desc.txt``."""
    desc = tssb_dir / "desc.txt"
    out = []
    for ln, line in enumerate(desc.read_text().splitlines(), 1):
        if not line.strip():
            continue
        parts = line.strip().split(",")
        try:
            name, w, cps = parts[0], int(parts[1]), np.array([int(v) for v in parts[2:]], dtype=np.int64)
        except (ValueError, IndexError):
            raise MocapFormatError(desc, ln, "expected name,window,changepoint,...") from None
        x = np.loadtxt(tssb_dir / f"{name}.txt", dtype=np.float64)
        out.append((name, x, w, cps))
    return out


def read_published(tssb_dir: Path) -> dict[str, dict[str, float]]:
    with open(tssb_dir / "published-covering-unknown-segments.csv", newline="") as fh:
        return {r["dataset"]: {k: float(v) for k, v in r.items() if k != "dataset"} for r in csv.DictReader(fh)}


def _embed(x: np.ndarray, w: int) -> tuple[np.ndarray, int]:
    """Delay embedding of width ``w`` (rows ``x[i:i+w]``) and the offset mapping a row to its centre."""
    w = max(2, min(w, x.size // 4))
    return np.lib.stride_tricks.sliding_window_view(x, w).copy(), w // 2


def tssb_segmenter(method: str, n: int, w: int):
    """The TSSB settings: ARMA without downsampling; the baselines' shortest segment 5 windows
    (``5·w``, ClaSP's own exclusion zone) instead of the 1 s of mocap; PELT runs on every
    ``ceil(n / 8000)``-th sample of long series (its cost grows with n² without pruning)."""
    from mocapkit.segment import BASELINES
    from mocapkit.segment.arma import ARMASegmenter

    if method == "arma":
        return ARMASegmenter(downsample=1)
    seg_min = max(5 * w, 10)
    if method in ("pca", "kmeans"):
        return BASELINES[method](min_segment=seg_min)
    if method == "kernelcpd":
        return BASELINES[method](min_size=seg_min)
    if method == "pelt":
        ds = max(1, -(-n // 8000))
        return BASELINES[method](min_size=seg_min, downsample=ds)  # min_size is in input samples
    return BASELINES[method]()


def run_tssb(tssb_dir: Path, methods=TSSB_METHODS, limit: int | None = None, log=None) -> list[dict]:
    """Covering of every method on every TSSB series (raw series; PCA/K-means on a delay embedding)."""
    series = read_tssb(tssb_dir)[:limit]
    published = read_published(tssb_dir)
    rows = []
    for name, x, w, cps in series:
        n = x.size
        cps = cps[(cps > 0) & (cps < n)]
        for method in methods:
            seg = tssb_segmenter(method, n, w)
            t0 = time.perf_counter()
            if method in ("pca", "kmeans"):
                E, off = _embed(x, w)
                pred = np.unique(np.clip(seg.fit_predict(E) + off, 1, n - 1))
            else:
                pred = seg.fit_predict(x)
            dt = time.perf_counter() - t0
            row = {"dataset": "tssb", "take": name, "method": method, "n_frames": int(n), "n_ref_cuts": int(cps.size),
                   "n_cuts": int(len(pred)), "covering": covering(pred, cps, n), "seconds": dt,
                   "published": published.get(name, {})}
            rows.append(row)
            if log:
                log(f"tssb {name} {method}: Cov {row['covering']:.3f} ({len(pred)} cuts / {cps.size}) {dt:.2f} s")
    return rows


def _mean(values) -> float | None:
    """Mean of the values that are not None (``ri_paper`` of a take without cuts); None if none is."""
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _f(x) -> str:
    return "–" if x is None else f"{x:.3f}"


def summarise(mocap_rows: list[dict], tssb_rows: list[dict]) -> dict:
    """Per method: mean F1 / frame agreement / the paper's RI / Covering / seconds over the mocap takes;
    mean TSSB Covering."""
    out: dict = {"cmu": {}, "tssb": {}}
    for r in mocap_rows:
        key = r["method"] + MODE_SUFFIX[r["mode"]]
        out["cmu"].setdefault(key, []).append(r)
    out["cmu"] = {k: {m: _mean([r.get(m) for r in v])
                      for m in ("frame_agreement", "ri_paper", "f1", "covering", "naming_accuracy", "seconds")}
                  for k, v in out["cmu"].items()}
    by: dict[str, list[dict]] = {}
    for r in tssb_rows:
        by.setdefault(r["method"], []).append(r)
    out["tssb"] = {m: {"covering": float(np.mean([r["covering"] for r in v])), "n_series": len(v),
                       "seconds": float(np.mean([r["seconds"] for r in v]))}
                  for m, v in by.items()}
    if tssb_rows:
        names = sorted({r["take"] for r in tssb_rows})
        pub = {r["take"]: r["published"] for r in tssb_rows}
        out["tssb_published"] = {p: float(np.mean([pub[n][p] for n in names if p in pub[n]])) for p in PUBLISHED}
    return out


def markdown(mocap_rows: list[dict], tssb_rows: list[dict]) -> str:
    """The README tables: per take and method F1 / frame agreement / the paper's RI / Covering / frame
    accuracy of the named actions / seconds; TSSB means."""
    lines = []
    if mocap_rows:
        lines.append("| take | method | F1 | agreement | RI (paper) | Covering | named acc. | cuts / true | s |")
        lines.append("|---|---|---:|---:|---:|---:|---:|---:|---:|")
        for r in mocap_rows:
            m = r["method"] + MODE_SUFFIX[r["mode"]]
            lines.append(f"| {r['take']} | {m} | {r['f1']:.3f} | {r['frame_agreement']:.3f} | {_f(r['ri_paper'])} | "
                         f"{r['covering']:.3f} | {_f(r.get('naming_accuracy'))} | {r['n_cuts']} / {r['n_ref_cuts']} | "
                         f"{r['seconds']:.2f} |")
        s = summarise(mocap_rows, [])["cmu"]
        lines.append("")
        lines.append(f"| method (mean of {len({r['take'] for r in mocap_rows})} takes) | F1 | agreement | RI (paper) | "
                     "Covering | named acc. | s per take |")
        lines.append("|---|---:|---:|---:|---:|---:|---:|")
        for m, v in s.items():
            lines.append(f"| {m} | {v['f1']:.3f} | {v['frame_agreement']:.3f} | {_f(v['ri_paper'])} | "
                         f"{v['covering']:.3f} | {_f(v['naming_accuracy'])} | {v['seconds']:.2f} |")
    if tssb_rows:
        s = summarise([], tssb_rows)
        lines.append("")
        lines.append(f"| TSSB ({s['tssb'][next(iter(s['tssb']))]['n_series']} series) | mean Covering | s per series |")
        lines.append("|---|---:|---:|")
        for m, v in s["tssb"].items():
            lines.append(f"| {m} (ours) | {v['covering']:.3f} | {v['seconds']:.2f} |")
        for p, v in s["tssb_published"].items():
            lines.append(f"| {p} (published) | {v:.3f} | |")
    return "\n".join(lines) + "\n"
