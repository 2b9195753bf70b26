"""``mocapkit demo``: the main job on the bundled x-io lower-body walk (7 body-worn IMUs, 50 Hz)."""

from __future__ import annotations

from pathlib import Path

from rich.table import Table

from mocapkit.io import load_signals, sample_data_path, write_signal_csv
from mocapkit.pla import compress_to, evaluate

TARGET_ICR = 0.10
MAX_ANGLE = 2.0


def run_demo(out: Path, console) -> dict:
    """Compress every sensor with every method at ICR 10 % and with a 2° guarantee; write points."""
    src = sample_data_path()
    signals = load_signals(src)
    n_samples = sum(len(s) for s in signals.values())
    console.print(f"[bold]{len(signals)} sensors[/bold] from {src} ({n_samples} quaternion samples)")

    tab = Table(title=f"every method at target ICR {TARGET_ICR:.2f} (pooled over the sensors)")
    for c in ("method", "points", "ICR", "AAD °", "max °", "segment-point max °"):
        tab.add_column(c, justify="right")
    results: dict = {}
    for method in ("fastsw", "sw", "cplr", "swing"):
        r = _compress_all(signals, out / f"icr{round(TARGET_ICR * 100)}-{method}", method, target_icr=TARGET_ICR)
        results[method] = {"points": r["points"], "icr": r["points"] / n_samples, "aad_deg": r["aad_deg"],
                           "max_deg": r["max_deg"]}
        tab.add_row(method, str(r["points"]), f"{r['points'] / n_samples:.4f}", f"{r['aad_deg']:.3f}",
                    f"{r['max_deg']:.3f}", f"{r['point_max_deg']:.3g}")
    console.print(tab)

    tab2 = Table(title=f"guarantee: every sample within {MAX_ANGLE}° of the SLERP decode (verified)")
    for c in ("method", "points", "ICR", "AAD °", "max °"):
        tab2.add_column(c, justify="right")
    for method in ("anglesw", "fastsw"):
        r = _compress_all(signals, out / f"max{MAX_ANGLE:g}deg-{method}", method, max_angle=MAX_ANGLE)
        label = "anglesw (online)" if method == "anglesw" else "fastsw (threshold tuned)"
        results[f"max_angle_{method}"] = {"points": r["points"], "max_deg": r["max_deg"]}
        tab2.add_row(label, str(r["points"]), f"{r['points'] / n_samples:.4f}", f"{r['aad_deg']:.3f}",
                     f"{r['max_deg']:.3f}")
    console.print(tab2)
    console.print(f"segment points written under {out}/ (CSV time,w,x,y,z; decode with `mocapkit decompress`)")
    return results


def _compress_all(signals: dict, folder: Path, method: str, **control) -> dict:
    """Compress every sensor, write its points to ``folder``; pooled points, AAD, max and point max."""
    folder.mkdir(parents=True, exist_ok=True)
    pts, sum_dev, n, mx, pmx = 0, 0.0, 0, 0.0, 0.0
    for name, sig in signals.items():
        comp = compress_to(sig, method, max_segment_length=1000, **control)
        m = evaluate(sig, comp)
        pts += m.n_points
        sum_dev += m.aad_deg * m.n_samples
        n += m.n_samples
        mx = max(mx, m.max_deg)
        pmx = max(pmx, m.point_max_deg)
        write_signal_csv(folder / f"{name}.csv", comp.times, comp.values)
    return {"points": pts, "aad_deg": sum_dev / n, "max_deg": mx, "point_max_deg": pmx}
