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
        pts = 0
        sum_dev = 0.0
        mx = 0.0
        pmx = 0.0
        for name, sig in signals.items():
            comp = compress_to(sig, method, target_icr=TARGET_ICR, max_segment_length=1000)
            m = evaluate(sig, comp)
            pts += m.n_points
            sum_dev += m.aad_deg * m.n_samples
            mx = max(mx, m.max_deg)
            pmx = max(pmx, m.point_max_deg)
            d = out / f"icr{round(TARGET_ICR * 100)}-{method}"
            _mk(d)
            write_signal_csv(d / f"{name}.csv", comp.times, comp.values)
        results[method] = {"points": pts, "icr": pts / n_samples, "aad_deg": sum_dev / n_samples, "max_deg": mx}
        tab.add_row(method, str(pts), f"{pts / n_samples:.4f}", f"{sum_dev / n_samples:.3f}", f"{mx:.3f}", f"{pmx:.3g}")
    console.print(tab)

    tab2 = Table(title=f"guarantee: every sample within {MAX_ANGLE}° of the SLERP decode (verified)")
    for c in ("method", "points", "ICR", "AAD °", "max °"):
        tab2.add_column(c, justify="right")
    for method in ("anglesw", "fastsw"):
        pts = 0
        sum_dev = 0.0
        mx = 0.0
        for name, sig in signals.items():
            comp = compress_to(sig, method, max_angle=MAX_ANGLE, max_segment_length=1000)
            m = evaluate(sig, comp)
            pts += m.n_points
            sum_dev += m.aad_deg * m.n_samples
            mx = max(mx, m.max_deg)
            d = out / f"max{MAX_ANGLE:g}deg-{method}"
            _mk(d)
            write_signal_csv(d / f"{name}.csv", comp.times, comp.values)
        label = "anglesw (online)" if method == "anglesw" else "fastsw (threshold tuned)"
        results[f"max_angle_{method}"] = {"points": pts, "max_deg": mx}
        tab2.add_row(label, str(pts), f"{pts / n_samples:.4f}", f"{sum_dev / n_samples:.3f}", f"{mx:.3f}")
    console.print(tab2)
    console.print(f"segment points written under {out}/ (CSV time,w,x,y,z; decode with `mocapkit decompress`)")
    return results


def _mk(d: Path) -> bool:
    d.mkdir(parents=True, exist_ok=True)
    return True
