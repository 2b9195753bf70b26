"""The experiments of Section 6 of the fastSW paper on any set of orientation signals.

Every method at 205 thresholds (0 and 204 values log-spaced over 1e-6..1e3), maximum segment
length 1000; per (method, threshold, signal): ICR, AAD, max and std of the angular deviation,
segment-point deviation, mean segment length, and time per sample — of the compiled batch kernel
(whole signal, best of 3) and of the streaming encoder (each ``push`` timed on its own, as the
paper timed each call; mean, 99th percentile and max).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

from mocapkit.motion import Signal
from mocapkit.pla import Encoder, compress, evaluate
from mocapkit.pla.base import prepared_values

SWEEP_METHODS = ("cplr", "swing", "sw", "fastsw")

FIELDS = [
    "method", "threshold", "signal", "n_samples", "n_points", "icr", "mean_segment_length",
    "aad_deg", "max_deg", "std_deg", "point_mean_deg", "point_max_deg",
    "batch_ns_per_sample", "stream_mean_ns", "stream_p99_ns", "stream_max_ns",
]


def paper_thresholds(n: int = 205) -> np.ndarray:
    """0 followed by ``n − 1`` thresholds log-spaced over nine decades, 1e-6..1e3 (Section 6)."""
    if n < 2:
        from mocapkit.errors import InvalidParameterError

        raise InvalidParameterError(f"--thresholds needs at least 2 (0 and one more), got {n}")
    return np.concatenate([[0.0], np.logspace(-6, 3, n - 1)])


def _time_batch(sig: Signal, X: np.ndarray, method: str, th: float, maxlen: int) -> float:
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter_ns()
        compress(sig, method, th, maxlen, _prepared=X)
        best = min(best, time.perf_counter_ns() - t0)
    return best / len(sig)


def _time_stream(sig: Signal, method: str, th: float, maxlen: int) -> np.ndarray:
    enc = Encoder(method, th, dim=sig.dim, kind=sig.kind, max_segment_length=maxlen)
    ns = np.empty(len(sig))
    clock = time.perf_counter_ns
    rows = sig.values.tolist()
    for i, (t, x) in enumerate(zip(sig.times.tolist(), rows, strict=True)):
        t0 = clock()
        enc.push(t, x)
        ns[i] = clock() - t0
    enc.flush()
    return ns


def run_sweep(
    signals: dict[str, Signal],
    n_thresholds: int = 205,
    max_segment_length: int = 1000,
    methods: tuple[str, ...] = SWEEP_METHODS,
    progress=None,
    timing: bool = True,
) -> list[dict]:
    rows = []
    ths = paper_thresholds(n_thresholds)
    for name, sig in signals.items():
        X = prepared_values(sig)
        for method in methods:
            compress(sig, method, 1.0, max_segment_length, _prepared=X)  # compile outside the timing
            _time_stream(Signal(sig.times[:50], sig.values[:50], sig.kind), method, 1.0, max_segment_length)
            for th in ths:
                comp = compress(sig, method, float(th), max_segment_length, _prepared=X)
                met = evaluate(sig, comp)
                row = {"method": method, "threshold": float(th), "signal": name}
                row.update({k: getattr(met, k) for k in FIELDS if hasattr(met, k)})
                if timing:
                    row["batch_ns_per_sample"] = _time_batch(sig, X, method, float(th), max_segment_length)
                    ns = _time_stream(sig, method, float(th), max_segment_length)
                    row["stream_mean_ns"] = float(ns.mean())
                    row["stream_p99_ns"] = float(np.percentile(ns, 99))
                    row["stream_max_ns"] = float(ns.max())
                rows.append(row)
            if progress is not None:
                progress.print(f"  {name}: {method} done")
    return rows


def aggregate(rows: list[dict]) -> list[dict]:
    """Dataset-level figures per (method, threshold), pooled over all signals as in the paper:
    ICR = all points / all samples, AAD = mean over all samples, max over all samples, std pooled."""
    groups: dict[tuple[str, float], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["threshold"]), []).append(r)
    out = []
    for (method, th), rs in groups.items():
        n = np.array([r["n_samples"] for r in rs], float)
        m = np.array([r["n_points"] for r in rs], float)
        aad = np.array([r["aad_deg"] for r in rs])
        std = np.array([r["std_deg"] for r in rs])
        mean = float((aad * n).sum() / n.sum())
        var = float(((std**2 + aad**2) * n).sum() / n.sum() - mean**2)
        pm = np.array([r["point_mean_deg"] for r in rs])
        agg = {
            "method": method,
            "threshold": th,
            "n_signals": len(rs),
            "icr": float(m.sum() / n.sum()),
            "mean_segment_length": float((n - 1).sum() / np.maximum(m - 1, 1).sum()),
            "aad_deg": mean,
            "std_deg": max(var, 0.0) ** 0.5,
            "max_deg": float(max(r["max_deg"] for r in rs)),
            "point_mean_deg": float((pm * m).sum() / m.sum()),
            "point_max_deg": float(max(r["point_max_deg"] for r in rs)),
        }
        if "batch_ns_per_sample" in rs[0]:
            agg["batch_ns_per_sample"] = float(sum(r["batch_ns_per_sample"] * r["n_samples"] for r in rs) / n.sum())
            agg["stream_mean_ns"] = float(sum(r["stream_mean_ns"] * r["n_samples"] for r in rs) / n.sum())
            agg["stream_max_ns"] = float(max(r["stream_max_ns"] for r in rs))
        out.append(agg)
    out.sort(key=lambda r: (r["method"], r["threshold"]))
    return out


def _write_csv(path: Path, rows: list[dict], fields: list[str]) -> None:
    import io

    from mocapkit.io.atomic import atomic_write_text

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    atomic_write_text(path, buf.getvalue())


def write_outputs(rows: list[dict], out: Path) -> list[Path]:
    from mocapkit.plot import plot_sweep_error, plot_sweep_time

    out.mkdir(parents=True, exist_ok=True)
    agg = aggregate(rows)
    paths = [out / "sweep.csv", out / "sweep_summary.csv"]
    _write_csv(paths[0], rows, FIELDS)
    _write_csv(paths[1], agg, list(agg[0].keys()))
    if "batch_ns_per_sample" in agg[0]:
        paths.append(plot_sweep_time(agg, out / "fig3_time_per_sample.png"))
    paths.append(plot_sweep_error(agg, out / "fig4_error_vs_icr.png"))
    return paths


def write_max_angle(signals: dict[str, Signal], out: Path, max_segment_length: int = 200) -> Path:
    """Points needed for a guaranteed maximum angle: optimum vs anglesw vs the tuned paper methods."""
    from mocapkit.evaluation.maxangle import compare

    rows = compare(signals, max_segment_length=max_segment_length)
    path = out / "max_angle.csv"
    _write_csv(path, rows, list(rows[0].keys()))
    return path


def at_icr(agg: list[dict], method: str, icr: float) -> dict:
    """The aggregated row of ``method`` whose ICR is closest to ``icr`` from below."""
    cands = [r for r in agg if r["method"] == method and r["icr"] <= icr]
    if not cands:
        cands = [r for r in agg if r["method"] == method]
    return min(cands, key=lambda r: abs(r["icr"] - icr))


def summarise(rows: list[dict]):
    from rich.table import Table

    agg = aggregate(rows)
    tab = Table(title="pooled over all signals, closest ICR <= target")
    for c in ("method", "target ICR", "ICR", "AAD °", "std °", "max °", "point max °"):
        tab.add_column(c, justify="right")
    for target in (0.25, 0.10, 0.05):
        for m in sorted({r["method"] for r in agg}):
            r = at_icr(agg, m, target)
            tab.add_row(m, f"{target:.2f}", f"{r['icr']:.4f}", f"{r['aad_deg']:.3f}", f"{r['std_deg']:.3f}",
                        f"{r['max_deg']:.3f}", f"{r['point_max_deg']:.3g}")
    return tab
