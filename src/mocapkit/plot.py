"""Matplotlib figures (written as PNG; the Agg backend, no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLORS = {"cplr": "tab:blue", "swing": "tab:orange", "sw": "tab:green", "fastsw": "tab:red", "anglesw": "tab:purple"}
LABELS = {"cplr": "CPLR", "swing": "SF", "sw": "SW", "fastsw": "fastSW", "anglesw": "angle-SW"}


def _save(fig, path: Path) -> Path:
    from mocapkit.io.atomic import atomic_writer

    path = Path(path)
    try:
        with atomic_writer(path, binary=True) as fh:  # a device or pipe is written into, a file replaced
            fig.savefig(fh, format="png", dpi=120)
    finally:
        plt.close(fig)  # also when writing fails
    return path


def _by_method(agg: list[dict]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in agg:
        out.setdefault(r["method"], []).append(r)
    return out


def plot_sweep_time(agg: list[dict], path: Path) -> Path:
    """Like Figure 3 of the fastSW paper: time per sample vs mean segment length (log y)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharex=True)
    for m, rs in _by_method(agg).items():
        rs = sorted(rs, key=lambda r: r["mean_segment_length"])
        x = [r["mean_segment_length"] for r in rs]
        axes[0].plot(x, [r["batch_ns_per_sample"] for r in rs], ".-", ms=3, color=COLORS.get(m), label=LABELS.get(m, m))
        axes[1].plot(x, [r["stream_mean_ns"] for r in rs], ".-", ms=3, color=COLORS.get(m), label=LABELS.get(m, m))
    axes[0].set_title("compiled batch kernel")
    axes[1].set_title("streaming encoder (one push() per sample)")
    for ax in axes:
        ax.set_yscale("log")
        ax.set_xlabel("mean segment length [samples]")
        ax.set_ylabel("mean time per sample [ns]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    return _save(fig, path)


def plot_sweep_error(agg: list[dict], path: Path) -> Path:
    """Like Figure 4 of the fastSW paper: angular deviation vs ICR, of the SLERP decode (left) and of
    the segment points themselves (right); mean (solid), ±std (shaded), max (dashed)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for m, rs in _by_method(agg).items():
        rs = sorted(rs, key=lambda r: r["icr"])
        icr = np.array([r["icr"] for r in rs])
        c = COLORS.get(m)
        mean = np.array([r["aad_deg"] for r in rs])
        std = np.array([r["std_deg"] for r in rs])
        axes[0].plot(icr, mean, "-", color=c, label=LABELS.get(m, m))
        axes[0].fill_between(icr, np.maximum(mean - std, 1e-6), mean + std, color=c, alpha=0.12)
        axes[0].plot(icr, [r["max_deg"] for r in rs], "--", color=c, lw=0.8)
        pm = np.maximum([r["point_mean_deg"] for r in rs], 1e-9)
        axes[1].plot(icr, pm, "-", color=c, label=LABELS.get(m, m))
        axes[1].plot(icr, np.maximum([r["point_max_deg"] for r in rs], 1e-9), "--", color=c, lw=0.8)
    axes[0].set_title("decoded signal (SLERP) vs original")
    axes[1].set_title("segment points vs original samples")
    axes[1].annotate("SW/fastSW: exactly 0 (drawn at 1e-9)", (0.02, 0.08), xycoords="axes fraction", fontsize=8)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("ICR (points / samples)")
        ax.set_ylabel("angular deviation [°]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    return _save(fig, path)


def plot_ppa(t, y, result, path, title: str = "", butter=None) -> "Path":
    """Like Figure 3 of the seed report: a signal with its piecewise polynomial fit and knots, and the
    fit's first and second time derivatives (optionally a Butterworth-filtered comparison)."""
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64).reshape(len(t), -1)[:, -1]
    fig, axes = plt.subplots(3, 1, figsize=(10, 7.5), sharex=True)
    tt = np.linspace(t[0], t[-1], max(2000, 4 * len(t)))
    comp = -1
    axes[0].plot(t, y, ".", ms=2, color="0.6", label="data")
    for d, ax in enumerate(axes):
        v = result.evaluate(tt, derivative=d)[:, comp]
        ax.plot(tt, v, color="tab:red", lw=1.2, label="piecewise polynomial")
        if butter is not None:
            ax.plot(t, butter[d], color="tab:blue", lw=0.8, alpha=0.8, label="Butterworth (filtfilt)")
        for p in result.pieces[1:]:
            ax.axvline(p.t0, color="tab:green", lw=0.5, alpha=0.6)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("position")
    axes[1].set_ylabel("velocity /s")
    axes[2].set_ylabel("acceleration /s²")
    axes[2].set_xlabel("time [s]")
    axes[0].legend(fontsize=8, loc="upper right")
    axes[0].set_title(title + "  (knots: green lines)")
    fig.tight_layout()
    return _save(fig, path)


def plot_segmentation(limbs, rate_hz: float, cuts, path, ref_cuts=None, names=None, title: str = "") -> Path:
    """The 4 limb angle sequences (Table 3) with the found cuts (solid) and reference cuts (dashed)."""
    limbs = np.asarray(limbs, dtype=float)
    names = names or [f"channel {i}" for i in range(limbs.shape[1])]
    t = np.arange(limbs.shape[0]) / rate_hz
    fig, axes = plt.subplots(limbs.shape[1], 1, figsize=(11, 1.8 * limbs.shape[1] + 0.6), sharex=True, squeeze=False)
    for i, ax in enumerate(axes[:, 0]):
        ax.plot(t, limbs[:, i], lw=0.8, color="tab:blue")
        ax.set_ylabel(f"{names[i]}\n(deg)", fontsize=8)
        for k, c in enumerate(cuts):
            ax.axvline(c / rate_hz, color="tab:red", lw=1.2, label="found cut" if (i == 0 and k == 0) else None)
        for k, c in enumerate(ref_cuts if ref_cuts is not None else []):
            ax.axvline(c / rate_hz, color="k", ls="--", lw=1.0, label="reference cut" if (i == 0 and k == 0) else None)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    return _save(fig, path)
