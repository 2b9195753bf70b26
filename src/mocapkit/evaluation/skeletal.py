"""Whole-skeleton compression experiments: ICR vs world-position error per PLA method, the
guaranteed-error mode, and a Figure-5-like picture of stick figures at several sizes."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from mocapkit.io.atomic import atomic_write_text
from mocapkit.pla.skeletal import compress_motion, position_errors
from mocapkit.skeleton import Motion, forward_kinematics

METHODS = ("fastsw", "cplr", "swing")  # SW gives fastSW's points (tested), so it is not repeated
TARGET_ICRS = (0.5, 0.25, 0.10, 0.05, 0.02)
BOUNDS_CM = (0.0495, 0.1, 0.5, 1.0, 2.0)


def evaluate_motion(name: str, motion: Motion, unit_cm: float, methods=METHODS, icrs=TARGET_ICRS,
                    bounds_cm=BOUNDS_CM) -> list[dict]:
    rows = []
    for m in methods:
        for icr in icrs:
            c = compress_motion(motion, m, target_icr=icr)
            e = position_errors(motion, c.decode()) * unit_cm
            rows.append({"file": name, "mode": "target_icr", "method": m, "target": icr, "icr": c.icr,
                         "keyframes": c.n_keyframes, "max_cm": float(e.max()), "mean_cm": float(e.mean()),
                         "ratio": c.bytes_raw() / c.bytes_out()})
    for b in bounds_cm:
        c = compress_motion(motion, "anglesw", max_position_error=b / unit_cm)
        e = position_errors(motion, c.decode()) * unit_cm
        rows.append({"file": name, "mode": "max_position_error", "method": "anglesw", "target": b, "icr": c.icr,
                     "keyframes": c.n_keyframes, "max_cm": float(e.max()), "mean_cm": float(e.mean()),
                     "ratio": c.bytes_raw() / c.bytes_out()})
    return rows


def write_rows(rows: list[dict], path: Path) -> Path:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0].keys()), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())
    return path


def stick_figure_png(motion: Motion, path: Path, sizes=(0.5, 0.25, 0.10, 0.05), methods=("cplr", "swing", "fastsw"),
                     n_shots: int = 6, step_s: float = 0.1, start_s: float | None = None) -> Path:
    """Figure 5 of the fastSW paper, for a skeleton: frames every ``step_s`` seconds, one panel per
    method (columns) and shot; the original in light blue under reconstructions whose keyframes take
    50/25/10/5 % of the original size."""
    from mocapkit.plot import _save, plt

    P0, _ = forward_kinematics(motion)
    sk = motion.skeleton
    n = motion.n_frames
    t0 = start_s if start_s is not None else 0.4 * motion.times[-1]
    frames = [int(np.clip(np.searchsorted(motion.times, t0 + k * step_s), 0, n - 1)) for k in range(n_shots)]
    colors = {0.5: "tab:green", 0.25: "gold", 0.10: "tab:orange", 0.05: "orangered", 0.02: "darkred"}
    recon = {(m, s): forward_kinematics(compress_motion(motion, m, target_icr=s).decode())[0]
             for m in methods for s in sizes}
    up = int(np.argmax(np.median(np.ptp(P0, axis=1), axis=0)))  # vertical: the body's largest extent in a frame
    side = [a for a in range(3) if a != up]
    horiz = side[int(np.argmax([np.ptp(P0[..., a]) for a in side]))]
    fig, axes = plt.subplots(len(methods), n_shots, figsize=(2.0 * n_shots, 2.6 * len(methods)), squeeze=False)
    for r, m in enumerate(methods):
        for c, f in enumerate(frames):
            ax = axes[r][c]
            for P, col, lw in [(P0, "lightblue", 4.0)] + [(recon[(m, s)], colors.get(s, "k"), 1.2) for s in sizes]:
                for j in range(sk.n_joints):
                    p = sk.parents[j]
                    if p >= 0:
                        ax.plot([P[f, p, horiz], P[f, j, horiz]], [P[f, p, up], P[f, j, up]], color=col, lw=lw)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"t = {motion.times[f]:.2f} s", fontsize=8)
            if c == 0:
                ax.set_ylabel({"cplr": "CPLR", "swing": "SF", "fastsw": "SW/fastSW"}.get(m, m))
    handles = [plt.Line2D([], [], color="lightblue", lw=4, label="original")] + [
        plt.Line2D([], [], color=colors.get(s, "k"), lw=1.5, label=f"{round(s * 100)} % size") for s in sizes]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return _save(fig, path)


def plot_curves(rows: list[dict], path: Path) -> Path:
    """ICR vs max (dashed) and mean (solid) world-position error, one panel per file, one colour per
    method; the guaranteed mode as black dots."""
    from mocapkit.plot import COLORS, LABELS, _save, plt

    files = list(dict.fromkeys(r["file"] for r in rows))
    ncol = min(3, len(files))
    nrow = -(-len(files) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
    for ax in axes.flat[len(files):]:
        ax.set_visible(False)
    for ax, f in zip(axes.flat, files, strict=False):
        for m in METHODS:
            rs = sorted((r for r in rows if r["file"] == f and r["method"] == m and r["mode"] == "target_icr"),
                        key=lambda r: float(r["icr"]))
            if not rs:
                continue
            x = [float(r["icr"]) for r in rs]
            ax.plot(x, [float(r["mean_cm"]) for r in rs], "-o", ms=3, color=COLORS.get(m), label=LABELS.get(m, m))
            ax.plot(x, [float(r["max_cm"]) for r in rs], "--", color=COLORS.get(m), lw=0.8)
        g = [r for r in rows if r["file"] == f and r["mode"] == "max_position_error"]
        ax.plot([float(r["icr"]) for r in g], [float(r["max_cm"]) for r in g], "k.", label="guaranteed max")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ticks = [0.02, 0.05, 0.1, 0.25, 0.5, 1.0]
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
        ax.minorticks_off()
        ax.set_title(f, fontsize=9)
        ax.set_xlabel("ICR")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylabel("position error [cm]")
    fig.suptitle("world-position error vs ICR: mean (solid), max (dashed); guaranteed mode (dots)", fontsize=9)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def summary_table(rows: list[dict]):
    from rich.table import Table

    tab = Table(title="whole-skeleton compression (world-position error in cm)")
    for c in ("file", "mode", "method", "target", "ICR", "max cm", "mean cm", "ratio"):
        tab.add_column(c, justify="right")
    for r in rows:
        tab.add_row(r["file"], r["mode"], r["method"], f"{r['target']:g}", f"{r['icr']:.4f}", f"{r['max_cm']:.3f}",
                    f"{r['mean_cm']:.3f}", f"{r['ratio']:.2f}")
    return tab
