"""Evaluation of the piecewise polynomial filter: the seed report's synthetic signal (Figure 2) and
step overshoot (Figure 1), the juggling case (Figure 3), the gap between the iterative algorithm and
the exact optimum, and the exact solver's time curve."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.filters.api import fit
from mocapkit.filters.butterworth import butterworth_filtfilt, smoothing_spline, step_overshoot, winter_residual_cutoff
from mocapkit.filters.exact import solve_exact
from mocapkit.filters.ppa import fit_iterative

G = 9.80665


def synthetic_signal(n: int = 600, noise: float = 0.1, seed: int = 0, rate: float = 100.0):
    """The seed's Figure 2 signal: a step, then a linear ramp, then a parabolic ramp, plus uniform
    noise in ``[-noise, noise]``. The report gives no levels; here each piece starts with a jump
    (0 → 1 step, ramp from 0.3 to 1.3, parabola from 1.8 down to 0.8), so that every true knot is a
    discontinuity. Returns ``(t, y, clean, true_knots)``."""
    rng = np.random.default_rng(seed)
    i = np.arange(n)
    t = i / rate
    k1, k2, k3 = n // 4, n // 2, 3 * n // 4
    clean = np.zeros(n)
    clean[k1:k2] = 1.0
    clean[k2:k3] = 0.3 + (i[k2:k3] - k2) / (k3 - k2)
    u = (i[k3:] - k3) / (n - k3)
    clean[k3:] = 1.8 - 1.0 * u * u
    y = clean + rng.uniform(-noise, noise, n)
    return t, y, clean, np.array([k1, k2, k3])


def knot_f1(found: np.ndarray, true: np.ndarray, margin: int = 2) -> float:
    """F1 of knot positions: a found knot is a hit if it lies within ``margin`` samples of an unmatched
    true knot (each true knot matched at most once)."""
    found_list = list(found)
    used = set()
    tp = 0
    for f in found_list:
        cands = [k for k in range(len(true)) if k not in used and abs(int(true[k]) - int(f)) <= margin]
        if cands:
            used.add(min(cands, key=lambda k: abs(int(true[k]) - int(f))))
            tp += 1
    if not found_list or not len(true):
        return 0.0
    p, r = tp / len(found_list), tp / len(true)
    return 0.0 if tp == 0 else 2 * p * r / (p + r)


def evaluate_synthetic(penalty: float | None = None, seeds=range(10), noise: float = 0.1) -> dict:
    """Knot F1, RMSE and step overshoot on the Figure 2 signal. ``penalty=None``: the automatic
    mode, with the iterative and exact solvers of Eq. 2 run at its equivalent ``K``."""
    rows = []
    for seed in seeds:
        t, y, clean, true = synthetic_signal(noise=noise, seed=seed)
        fs = 1.0 / (t[1] - t[0])
        auto = fit(t, y, 2, None) if penalty is None else None
        K = auto.penalty if auto is not None else penalty
        it = fit(t, y, 2, K, "iterative")
        ex = fit(t, y, 2, K, "exact")
        fc, _ = winter_residual_cutoff(y, fs)
        bw = np.asarray(butterworth_filtfilt(y, fs, float(fc))).reshape(-1)
        sp, lam = smoothing_spline(t, y)
        sp = np.asarray(sp).reshape(-1)
        seg = slice(0, int(true[1]))  # around the step: the overshoot of each filter relative to the clean step
        row = {"seed": seed, "K": ex.penalty, "knot_cost": None if auto is None else auto.knot_cost, "fc_hz": float(fc)}
        fits = [("iterative", it), ("exact", ex)] + ([("auto", auto)] if auto is not None else [])
        for name, est, knots in [(n, r.evaluate(t)[:, 0], r.parts[0].knots[1:-1]) for n, r in fits] + [
                ("butterworth", bw, None), ("spline", sp, None)]:
            row[f"{name}_rmse"] = float(np.sqrt(np.mean((est - clean) ** 2)))
            row[f"{name}_overshoot"] = float(step_overshoot(est[seg], clean[seg]))
            if knots is not None:
                row[f"{name}_f1"] = knot_f1(knots, true)
                row[f"{name}_knots"] = [int(k) for k in knots]
        row["iterative_loss"] = it.loss
        row["exact_loss"] = ex.loss
        rows.append(row)
    return {"rows": rows, "true_knots": [int(k) for k in true], "noise": noise}


def moving_markers(markers, min_valid: float = 0.5, ratio: float = 100.0) -> tuple[list[str], list[str]]:
    """``(moving, static)`` marker labels, among those with at least ``min_valid`` of their frames.

    Rule (unit-free): a marker moves when the spread of its positions (the largest over X, Y, Z of
    the 5–95 % inter-percentile range) is more than ``ratio`` times its own sample-to-sample noise
    σ̂ (:func:`mocapkit.filters.penalty.noise_sigma`, order 2). A static marker's spread is its noise
    and drift (a few σ̂); a thrown ball's is hundreds of millimetres against σ̂ of hundredths.
    """
    from mocapkit.filters.penalty import noise_sigma

    moving: list[str] = []
    static: list[str] = []
    for j, lab in enumerate(markers.labels):
        P = markers.positions[:, j, :]
        ok = np.isfinite(P).all(axis=1)
        if ok.mean() < min_valid or ok.sum() < 10:
            continue
        spread = float(np.max(np.percentile(P[ok], 95, axis=0) - np.percentile(P[ok], 5, axis=0)))
        sig = noise_sigma(P, 2)
        (moving if spread > ratio * max(sig, 1e-300) else static).append(lab)
    return moving, static


def flights(result, min_duration: float = 0.2):
    """Pieces that are free flights: concave (negative second derivative) and at least ``min_duration``
    long — identified without looking at the acceleration's size."""
    return [p for p in result.pieces if p.coeffs.shape[0] > 2 and p.coeffs[2, 0] < 0 and p.t1 - p.t0 >= min_duration]


def evaluate_juggling(markers, balls, penalty: float | None = None, unit_m: float = 1e-3, controls=(),
                      axis: int = 2) -> dict:
    """Vertical ball trajectories (``axis``, default Z up; ``unit_m`` metres per unit, mm by default)
    with O = 2: per-flight acceleration of the fit (2·c2) and of the Butterworth-filtered signal
    (second derivative by central differences). ``penalty=None``: the automatic mode. ``controls``:
    static markers, filtered the same way in 3-D (their knot count should be 0)."""
    out: dict[str, Any] = {"balls": {}, "controls": {}, "penalty": penalty,
                           "mode": "auto" if penalty is None else "fixed K"}
    all_acc = []
    for b in balls:
        z = markers.positions[:, markers.labels.index(b), axis]
        t = markers.times
        r = fit(t, z, 2, penalty, "exact")
        fl = flights(r)
        acc = [float(2 * p.coeffs[2, 0] * unit_m) for p in fl]
        all_acc += acc
        rec = {"knots": r.n_knots, "pieces": len(r.pieces), "flights": len(fl), "flight_acc_m_s2": acc,
               "median_acc": float(np.median(acc)) if acc else None, "K": r.penalty, "knot_cost": r.knot_cost,
               "loss": r.loss, "iterative_loss": r.iterative_loss}
        ok = ~np.isnan(z)
        # Butterworth on the longest NaN-free run
        runs = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
        a, e = max(zip(runs[::2], runs[1::2], strict=True), key=lambda r_: r_[1] - r_[0])
        fs = markers.rate
        stds, means = [], []
        fc: float | np.ndarray = float("nan")
        if e - a >= 30:
            fc, _ = winter_residual_cutoff(z[a:e], fs)
            zb = np.asarray(butterworth_filtfilt(z[a:e], fs, float(fc))).reshape(-1)
            ab = np.gradient(np.gradient(zb, t[a:e]), t[a:e]) * unit_m
            for p in fl:
                sel = (t[a:e] >= p.t0 + 0.05) & (t[a:e] <= p.t1 - 0.05)
                if sel.sum() > 10:
                    stds.append(float(ab[sel].std()))
                    means.append(float(ab[sel].mean()))
        rec.update({"butterworth_fc_hz": float(fc) if e - a >= 30 else None,  # None: no run long enough
                    "butterworth_flight_acc_std": stds,
                    "butterworth_flight_acc_mean": means})
        cycles = max(len(fl), 1)
        rec["parameters_per_cycle"] = float((len(r.pieces) * 3 + r.n_knots) / cycles)
        out["balls"][b] = rec
    for c in controls:
        r = fit(markers.times, markers.positions[:, markers.labels.index(c), :], 2, penalty, "exact")
        out["controls"][c] = {"knots": r.n_knots, "K": r.penalty, "knot_cost": r.knot_cost}
    out["median_flight_acc"] = float(np.median(all_acc)) if all_acc else None
    out["n_flights"] = len(all_acc)
    return out


def exact_time_curve(sizes=(1000, 2000, 5000, 10000, 20000, 50000), penalty: float = 1.0) -> list[dict]:
    rows = []
    for n in sizes:
        rng = np.random.default_rng(n)
        t = np.arange(n) / 300.0
        # a piecewise signal with a break every ~1000 samples and uniform noise
        y = np.zeros(n)
        for k in range(0, n, 1000):
            seg = slice(k, min(n, k + 1000))
            tt = t[seg] - t[k]
            y[seg] = rng.normal() + rng.normal() * tt + rng.normal() * tt * tt
        y += rng.uniform(-0.05, 0.05, n)
        t0 = time.perf_counter()
        it, _ = fit_iterative(t, y, 2, penalty)
        t1 = time.perf_counter()
        ex = solve_exact(t, y, 2, penalty, incumbent=it)
        t2 = time.perf_counter()
        rows.append({"n": n, "iterative_s": t1 - t0, "exact_s": t2 - t1, "knots": ex.n_knots,
                     "iterative_loss": it.loss, "exact_loss": ex.loss})
    return rows


def figures(out: Path, markers=None, ball: str | None = None, penalty: float | None = None) -> list[Path]:
    """Figure 1 (filtfilt overshoot at a clean step), Figure 2 (the synthetic signal with every
    method) and Figure 3 (a juggled ball, its fit and two derivatives, with Butterworth)."""
    from mocapkit.plot import _save, plot_ppa, plt

    paths = []
    # Figure 1: a clean step through forward-backward Butterworth filters of order 2 and 4
    n, fs = 300, 100.0
    t = np.arange(n) / fs
    step = (np.arange(n) >= n // 2).astype(float)
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot(t, step, "k", lw=2, label="step")
    for order in (2, 4):
        yb = np.asarray(butterworth_filtfilt(step, fs, 5.0, order=order)).reshape(-1)
        ax.plot(t, yb, label=f"filtfilt order {order}, 5 Hz: overshoot {100 * step_overshoot(yb, step):.1f} %")
    pp = fit(t, step, 2, 0.01)
    ax.plot(t, pp.evaluate(t)[:, 0], "--", color="tab:red", label="piecewise polynomial: overshoot "
            f"{100 * step_overshoot(pp.evaluate(t)[:, 0], step):.1f} %")
    ax.set_xlim(1.0, 2.0)
    ax.legend(fontsize=7)
    ax.set_title("Figure 1 effect: zero-phase Butterworth overshoots a step")
    fig.tight_layout()
    paths.append(_save(fig, out / "fig1_step_overshoot.png"))
    # Figure 2
    t, y, clean, true = synthetic_signal(seed=0)
    fs = 1.0 / (t[1] - t[0])
    fc, _ = winter_residual_cutoff(y, fs)
    auto = fit(t, y, 2, None)
    ex = fit(t, y, 2, auto.penalty, "exact")
    it = fit(t, y, 2, auto.penalty, "iterative")
    fig, ax = plt.subplots(figsize=(9, 3.8))
    ax.plot(t, y, ".", ms=2, color="0.6", label="noisy signal")
    ax.plot(t, clean, "k", lw=1, label="clean")
    ax.plot(t, np.asarray(butterworth_filtfilt(y, fs, float(fc))).reshape(-1), color="tab:blue", lw=1,
            label=f"Butterworth filtfilt, Winter fc = {float(fc):.1f} Hz")
    ax.plot(
        t, np.asarray(smoothing_spline(t, y)[0]).reshape(-1), color="tab:purple", lw=1, label="smoothing spline (GCV)"
    )
    ax.plot(t, ex.evaluate(t)[:, 0], color="tab:red", lw=1.5, label=f"exact PPA, K = {ex.penalty:.3f}")
    ax.plot(t, it.evaluate(t)[:, 0], "--", color="tab:orange", lw=1, label="iterative PPA")
    for k in ex.parts[0].knots[1:-1]:
        ax.axvline(t[k], color="tab:red", lw=0.6, alpha=0.5)
    for k in true:
        ax.plot(t[k], -0.35, "^", color="k", ms=5)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title("Figure 2 signal: knots (red lines) vs true breakpoints (triangles)")
    fig.tight_layout()
    paths.append(_save(fig, out / "fig2_synthetic.png"))
    # Figure 3
    if markers is not None and ball is not None:
        z = markers.positions[:, markers.labels.index(ball), 2]
        tt = markers.times
        sel = tt <= tt[0] + 5.0
    if markers is not None and ball is not None and np.isfinite(z[sel]).all() and sel.sum() >= 30:
        r = fit(tt[sel], z[sel], 2, penalty, "exact")
        fc, _ = winter_residual_cutoff(z[sel], markers.rate)
        zb = np.asarray(butterworth_filtfilt(z[sel], markers.rate, float(fc))).reshape(-1)
        vb = np.gradient(zb, tt[sel])
        ab = np.gradient(vb, tt[sel])
        paths.append(
            plot_ppa(
                tt[sel],
                z[sel],
                r,
                out / "fig3_juggling.png",
                title=f"juggled ball {ball}, Z, O = 2, "
                f"{'automatic' if penalty is None else f'K = {penalty:g}'}; Butterworth fc = {float(fc):.1f} Hz",
                butter=(zb, vb, ab),
            )
        )
    return paths
