"""Matplotlib figures (written as PNG; the Agg backend, no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402

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


def plot_ppa(t, y, result, path, title: str = "", butter=None) -> Path:
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
    if axes[0, 0].get_legend_handles_labels()[0]:  # no cut at all: no legend (and no matplotlib warning)
        axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    return _save(fig, path)


_ARMA_WINDOW_KEYS = ("start", "stop", "series", "resid", "order", "diff", "r2")


def _arma_window(w, j: int, k: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Check one window dict of ``plot_arma_diagnostics``; returns (series, resid, p, q)."""
    from mocapkit.errors import InvalidParameterError

    where = f"limb {j}, window {k}"
    if not isinstance(w, dict) or any(key not in w for key in _ARMA_WINDOW_KEYS):
        raise InvalidParameterError(f"{where}: a window must be a dict with keys {', '.join(_ARMA_WINDOW_KEYS)}")
    series = np.asarray(w["series"], dtype=float)
    resid = np.asarray(w["resid"], dtype=float)
    if series.ndim != 1 or resid.ndim != 1 or series.size < 4 or resid.size < 4:
        raise InvalidParameterError(f"{where}: series and resid must be 1-D with at least 4 samples")
    if not (np.all(np.isfinite(series)) and np.all(np.isfinite(resid))):
        raise InvalidParameterError(f"{where}: series or resid holds NaN or infinite values")
    try:
        p, q = (int(v) for v in w["order"])
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{where}: order must be a pair (p, q), got {w['order']!r}") from None
    return series, resid, p, q


def plot_arma_diagnostics(windows, names, out_png, title: str = "", per_limb: int | None = 3, nlags: int = 20,
                          alpha: float = 0.05, lags: int | None = None) -> Path:
    """Model identification and residual checks of the ARMA windows (Sec. 4.3 and 4.5 of the seed paper).

    Top: the Ljung–Box p-value of every window's residuals (model_df = p + q), per limb, against the
    level ``alpha``. Below, for ``per_limb`` windows of each limb (evenly spread; ``None``: all): the ACF
    and PACF of the modelled series and the ACF of the residuals, each with the ±z/√n band.

    ``windows[j]`` is the list of limb j's window dicts: ``start``, ``stop`` (samples, shown as labels),
    ``series`` (the modelled series: raw or differenced), ``resid``, ``order`` (p, q), ``diff``, ``r2``.
    """
    from mocapkit.errors import InvalidParameterError
    from mocapkit.segment.diagnostics import acf, confidence_band, default_lags, ljung_box, pacf

    names = [str(n) for n in names]
    if len(windows) != len(names):
        raise InvalidParameterError(f"{len(windows)} limbs of windows for {len(names)} names")
    if per_limb is not None and (isinstance(per_limb, bool) or int(per_limb) != per_limb or per_limb < 1):
        raise InvalidParameterError(f"per_limb must be a positive integer or None, got {per_limb!r}")
    checked = [[_arma_window(w, j, k) for k, w in enumerate(ws)] for j, ws in enumerate(windows)]
    pvals = []
    for ws in checked:
        row = []
        for _series, resid, p, q in ws:
            h = default_lags(resid.size) if lags is None else lags
            row.append(ljung_box(resid, h, p + q).pvalue if 1 <= h < resid.size and h > p + q else np.nan)
        pvals.append(np.array(row))
    shown = []
    for j, ws in enumerate(checked):
        n = len(ws)
        ks = (
            range(n)
            if per_limb is None or n <= per_limb
            else np.unique(np.linspace(0, n - 1, per_limb).round().astype(int))
        )
        shown += [(j, int(k)) for k in ks]
    rows = len(shown)
    # fixed margins in inches (tight_layout over dozens of axes takes seconds)
    head, row_h = 3.2, 1.05
    height = head + row_h * rows + 0.4
    fig = plt.figure(figsize=(11, height))
    top = fig.add_gridspec(1, 1, left=0.07, right=0.99, top=1 - 0.6 / height,
                           bottom=1 - (head - 0.95) / height).subplots()
    assert isinstance(top, Axes)  # one row, one column: a single Axes
    gs = fig.add_gridspec(rows, 3, left=0.07, right=0.99, top=1 - (head + 0.2) / height, bottom=0.4 / height,
                          hspace=0.55, wspace=0.08)
    for j, name in enumerate(names):
        if len(pvals[j]):
            starts = [int(w["start"]) for w in windows[j]]
            white = np.mean(pvals[j] > alpha)
            top.plot(starts, np.maximum(pvals[j], 1e-12), "o-", ms=3, lw=0.6, label=f"{name} ({white:.0%} white)")
    top.axhline(alpha, color="k", ls="--", lw=0.8)
    top.set_yscale("log")
    top.set_ylabel("Ljung–Box p")
    top.set_xlabel("window start (sample)")
    top.legend(fontsize=7, ncol=min(4, max(1, len(names))), loc="best")
    top.grid(True, alpha=0.3)
    top.set_title(
        (title + "\n" if title else "") + f"residual whiteness per window (dashed: α = {alpha:g})", fontsize=9
    )

    def bars(ax, values, band):
        k = np.arange(1, values.size)
        ax.axhspan(-band, band, color="tab:blue", alpha=0.12, lw=0)
        ax.vlines(k, 0, values[1:], color="k", lw=1.2)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylim(-1.05, 1.05)
        ax.set_xlim(0.3, values.size - 0.5)
        ax.set_yticks([-1, 0, 1])  # few fixed ticks: drawing ticks is most of the time of a tall figure
        ax.set_xticks([t for t in (1, 5, 10, 15, 20, 30, 40, 50) if t < values.size])
        ax.tick_params(labelsize=7)

    for r, (j, k) in enumerate(shown):
        series, resid, p, q = checked[j][k]
        w = windows[j][k]
        m = min(nlags, series.size - 1)
        axes = [fig.add_subplot(gs[r, c]) for c in range(3)]
        bars(axes[0], acf(series, m), confidence_band(series.size, alpha))
        bars(axes[1], pacf(series, m), confidence_band(series.size, alpha))
        bars(axes[2], acf(resid, min(nlags, resid.size - 1)), confidence_band(resid.size, alpha))
        axes[0].set_title(f"{names[j]}, samples {int(w['start'])}–{int(w['stop'])}: d={int(w['diff'])}, "
                          f"ARMA({p},{q}), R²={float(w['r2']):.2f}", fontsize=7, loc="left")
        pv = pvals[j][k]
        axes[2].set_title(f"Ljung–Box p = {pv:.3g}" if np.isfinite(pv) else "Ljung–Box: too few lags", fontsize=7,
                          loc="right")
        if r == 0:
            for ax, what in zip(axes, ("ACF of the series", "PACF of the series", "ACF of the residuals"), strict=True):
                ax.text(0.5, 1.4, what, transform=ax.transAxes, ha="center", fontsize=9, weight="bold")
        for ax in axes[1:]:
            ax.tick_params(labelleft=False)
        if r == rows - 1:
            for ax in axes:
                ax.set_xlabel("lag", fontsize=7)
        else:
            for ax in axes:
                ax.tick_params(labelbottom=False)
    return _save(fig, out_png)
