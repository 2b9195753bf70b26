"""Model identification and residual checks of the ARMA seed paper (Mei et al., Sensors 2021, 21, 5577).

* :func:`acf` (Sec. 4.3, Eq. 13–14), :func:`pacf` (Eq. 15, by the Durbin–Levinson recursion on the ACF,
  i.e. the last Yule–Walker coefficient of an AR(k)) and :func:`confidence_band` (±z/√n, 1.96/√n at 5 %):
  the paper identifies p and q where the PACF and the ACF "tail off" into this band.
* :func:`ljung_box` and :func:`is_white` (Sec. 4.5): "the model is tested ... on whether the residual
  sequences are white noise sequences or not". The paper names no test; Ljung–Box is the usual one
  (Q = n(n+2) Σ_{k=1..h} ρ̂_k²/(n−k), χ² with h − (p + q) degrees of freedom).
* :func:`differencing_study` (Sec. 5.1, Eq. 26–27, Figure 5): the limb sequences differenced 1, 2 and
  3 times, an AR(MA) fitted per window (``mocapkit.segment.arma.fit_arma``), and the average fitness
  γ̄ per limb and order, with the share of windows whose residuals are white and the share that pass
  the ADF stationarity test beside it.

Readings of the flattened equations (the paper's text lost its minus signs and fraction bars):

* **Eq. 14** prints γ_k = (1/n) Σ_{t=1}^{n−k} (θ_t − E θ)(θ_{t−k} − E θ) but γ_0 = (1/(n−1)) Σ (θ_t − E θ)².
  Taken literally ρ_0 = γ_0/γ_0 = 1 but ρ_k would carry a factor (n−1)/n against every other
  estimator; we read the 1/(n−1) as the sample-variance habit and use 1/n for every lag, with E θ the
  sample mean — statsmodels' default ``acf`` (``adjusted=False``, demeaned). ``adjusted=True`` divides
  lag k by n − k instead (statsmodels' ``adjusted=True``).
* **Eq. 15** is the partial autocorrelation: the correlation of θ_t and θ_{t−k} after removing
  θ_{t−1..t−k+1}. We compute it as φ_kk of the Yule–Walker equations solved by Durbin–Levinson on
  :func:`acf` (statsmodels ``pacf(method="ldb")``/``"ywm"``; with ``adjusted=True``, its default
  ``"ywadjusted"``).
* **Eq. 27** prints "γ̄ = 1 Σ_{j=1}^{g} (θ − θ̄)² Σ_{j=1}^{g} (θ̂ − θ̄)² n". Read literally as
  1 − SST/SSR it is ≤ 0 for every least-squares fit, so it cannot be a fitness in [0, 1]. We read it as
  the mean over the n windows of the R² of Eq. 28–29, γ̄ = (1/n) Σ_w [1 − Σ_j (θ_j − θ̂_j)² / Σ_j (θ_j −
  θ̄_w)²], on the differenced series θ(H) of Eq. 26 and its one-step fit θ̂ (j over the samples the fit
  predicts). The other consistent reading, Σ(θ̂ − θ̄)²/Σ(θ − θ̄)² (explained over total), is the same number
  here: ``fit_arma``'s last stage is least squares with a constant on exactly those samples, so
  SST = SSR + SSE (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mocapkit.errors import InvalidParameterError

__all__ = [
    "DifferencingStudy",
    "LjungBox",
    "acf",
    "confidence_band",
    "default_lags",
    "differencing_study",
    "is_white",
    "ljung_box",
    "pacf",
    "split_windows",
]


def _series(x, name: str = "x", minimum: int = 2) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1:
        raise InvalidParameterError(f"{name} must be one-dimensional, got shape {x.shape}")
    if x.size < minimum:
        raise InvalidParameterError(f"{name} needs at least {minimum} samples, got {x.size}")
    if not np.all(np.isfinite(x)):
        raise InvalidParameterError(f"{name} holds NaN or infinite values")
    return x


def _nlags(nlags, n: int) -> int:
    if isinstance(nlags, bool) or not isinstance(nlags, (int, np.integer)) or nlags < 1:
        raise InvalidParameterError(f"nlags must be a positive integer, got {nlags!r}")
    if nlags >= n:
        raise InvalidParameterError(f"nlags must be below the number of samples ({n}), got {nlags}")
    return int(nlags)


def acf(x, nlags: int, adjusted: bool = False) -> np.ndarray:
    """Sample autocorrelation ρ_0..ρ_nlags of Eq. 13–14 (``ρ_0 = 1``).

    γ_k = (1/n) Σ_{t=k+1}^{n} (x_t − x̄)(x_{t−k} − x̄) (``adjusted=True``: 1/(n − k)), ρ_k = γ_k/γ_0; see the
    module docstring for the reading of Eq. 14. A constant series has no autocorrelation: NaN for
    k ≥ 1.
    """
    x = _series(x)
    n = x.size
    nlags = _nlags(nlags, n)
    d = x - x.mean()
    # each lag a dot product: exact, O(n·nlags), and nlags is small (≤ n/4 in practice)
    g = np.array([d[k:] @ d[: n - k] for k in range(nlags + 1)])
    g = g / (n - np.arange(nlags + 1)) if adjusted else g / n
    out = np.full(nlags + 1, np.nan)
    out[0] = 1.0
    if g[0] > 0:
        out[1:] = g[1:] / g[0]
    return out


def _durbin_levinson(r: np.ndarray) -> np.ndarray:
    """φ_kk for k = 0..len(r)−1 from autocorrelations ``r`` (r[0] = 1)."""
    m = r.size - 1
    out = np.empty(m + 1)
    out[0] = 1.0
    if m == 0:
        return out
    phi = np.array([r[1]])
    out[1] = r[1]
    v = 1.0 - r[1] ** 2
    for k in range(2, m + 1):
        if v <= 0:  # a perfectly predictable series: nothing left to correlate
            out[k:] = np.nan
            break
        a = (r[k] - phi @ r[k - 1:0:-1]) / v
        phi = np.concatenate([phi - a * phi[::-1], [a]])
        out[k] = a
        v *= 1.0 - a * a
    return out


def pacf(x, nlags: int, adjusted: bool = False) -> np.ndarray:
    """Partial autocorrelation φ_00..φ_{nlags,nlags} of Eq. 15 (``φ_00 = 1``).

    φ_kk is the last coefficient of the Yule–Walker AR(k) fit on :func:`acf` (same ``adjusted``),
    computed by the Durbin–Levinson recursion. NaN where the ACF is undefined (a constant series).
    """
    x = _series(x)
    r = acf(x, _nlags(nlags, x.size), adjusted=adjusted)
    if not np.all(np.isfinite(r)):
        out = np.full(r.size, np.nan)
        out[0] = 1.0
        return out
    return _durbin_levinson(r)


def confidence_band(n: int, alpha: float = 0.05) -> float:
    """Half-width z_{1−α/2}/√n of the band an ACF/PACF of white noise stays in (1.96/√n at α = 0.05)."""
    from scipy.stats import norm

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InvalidParameterError(f"n must be a positive integer, got {n!r}")
    if not 0 < alpha < 1:
        raise InvalidParameterError(f"alpha must be in (0, 1), got {alpha!r}")
    return float(norm.ppf(1 - alpha / 2) / math.sqrt(n))


@dataclass(frozen=True)
class LjungBox:
    """Ljung–Box portmanteau test: statistic ``q`` over lags 1..``lags``, ``df`` = lags − model_df,
    ``pvalue`` = P(χ²_df > q)."""

    q: float
    df: int
    pvalue: float
    lags: int


def default_lags(n: int) -> int:
    """Lags of the Ljung–Box test when none are given: min(10, n // 5) (10 for a window of 100)."""
    return max(1, min(10, n // 5))


def ljung_box(resid, lags: int | None = None, model_df: int = 0) -> LjungBox:
    """Ljung–Box test of residuals (Sec. 4.5): Q = n(n+2) Σ_{k=1}^{h} ρ̂_k²/(n−k) with ρ̂ of :func:`acf`.

    Parameters
    ----------
    resid
        The residual series of one fit (``(n,)``).
    lags
        h; default :func:`default_lags`.
    model_df
        Degrees of freedom the fit used up: p + q for an ARMA(p, q) (the constant is not counted, as
        usual); the χ² has h − model_df degrees of freedom, so h must exceed it.

    A residual with zero variance has no ACF: ``q`` and ``pvalue`` are NaN.
    """
    from scipy.stats import chi2

    r = _series(resid, "resid", minimum=3)
    n = r.size
    h = default_lags(n) if lags is None else _nlags(lags, n)
    if isinstance(model_df, bool) or not isinstance(model_df, (int, np.integer)) or model_df < 0:
        raise InvalidParameterError(f"model_df must be a non-negative integer, got {model_df!r}")
    df = h - int(model_df)
    if df < 1:
        raise InvalidParameterError(f"Ljung-Box needs more lags ({h}) than model degrees of freedom ({model_df})")
    rho = acf(r, h)[1:]
    k = np.arange(1, h + 1)
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - k)))
    p = float(chi2.sf(q, df)) if math.isfinite(q) else math.nan
    return LjungBox(q=q, df=df, pvalue=p, lags=h)


def is_white(resid, alpha: float = 0.05, lags: int | None = None, model_df: int = 0) -> bool:
    """True when the Ljung–Box test does not reject whiteness at level ``alpha`` (p-value > alpha)."""
    if not 0 < alpha < 1:
        raise InvalidParameterError(f"alpha must be in (0, 1), got {alpha!r}")
    p = ljung_box(resid, lags, model_df).pvalue
    return bool(p > alpha)  # NaN (zero-variance residual) is not called white


# --- the differencing-order study (Sec. 5.1, Eq. 26-27, Figure 5) ---------------------------------------


def split_windows(m: int, window: int) -> list[tuple[int, int]]:
    """Half-open windows of ``window`` samples over ``m`` samples; a last partial window shorter than half
    a window joins the one before it (the rule of ``ARMASegmenter.windows``)."""
    bounds = [(s, min(s + window, m)) for s in range(0, m, window)]
    if len(bounds) > 1 and bounds[-1][1] - bounds[-1][0] < window // 2:
        last = bounds.pop()
        bounds[-1] = (bounds[-1][0], last[1])
    return bounds


def _r2(y: np.ndarray, resid: np.ndarray) -> np.ndarray:
    """Eq. 28–29 per row: 1 − SSE/SST over the fitted samples (1 where SST = 0)."""
    sst = ((y - y.mean(axis=1, keepdims=True)) ** 2).sum(axis=1)
    sse = (resid ** 2).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sst > 0, 1.0 - sse / np.where(sst > 0, sst, 1.0), 1.0)


def _fit_stack(stack: np.ndarray, orders: list[tuple[int, int]]):
    """Fit every order to every row; per row the order of least AIC on the samples all orders predict.

    Returns ``(chosen order index per row, {order: ARMAFit})``. AIC = m_c·log(SSE_c/m_c) + 2(p + q + 1)
    with SSE_c over the common samples (Hannan–Rissanen fits start later than AR fits, so their own
    sample sets differ).
    """
    from mocapkit.segment.arma import fit_arma

    fits = {o: fit_arma(stack, *o) for o in orders}
    if len(orders) == 1:
        return np.zeros(stack.shape[0], dtype=int), fits
    common = max(f.start for f in fits.values())
    mc = stack.shape[1] - common
    tiny = np.finfo(float).tiny
    aic = np.stack([
        mc * np.log(np.maximum((fits[o].resid[:, common - fits[o].start:] ** 2).sum(axis=1) / mc, tiny))
        + 2 * (o[0] + o[1] + 1)
        for o in orders
    ])
    return np.argmin(aic, axis=0), fits


@dataclass
class DifferencingStudy:
    """Result of :func:`differencing_study`.

    ``rows``: one dict per limb and difference order — ``limb``, ``diff``, ``windows`` (count),
    ``gamma_bar`` (γ̄ of Eq. 27: mean window R²), ``gamma_sd``, ``white_share`` (windows whose residuals
    pass Ljung–Box at ``alpha``), ``stationary_share`` (windows passing the ADF test), ``orders``
    (``"p,q"`` → count of windows). ``identified``: per limb, the smallest order whose windows mostly
    (≥ half) pass the ADF test — "difference until stationary" (Sec. 4.2, 5.2) — or ``None``.
    ``windows[(limb, diff)]``: the per-window dicts of ``plot_arma_diagnostics`` (``start``/``stop``:
    the samples of the series the window's differences belong to, ``series``, ``resid``, ``order``,
    ``diff``, ``r2``, ``lb_pvalue``, ``take``).
    """

    names: list[str]
    orders: tuple[int, ...]
    rows: list[dict]
    identified: dict[str, int | None]
    windows: dict = field(default_factory=dict, repr=False)

    def gamma(self, limb: str, diff: int) -> float:
        """γ̄ of one limb at one difference order."""
        for r in self.rows:
            if r["limb"] == limb and r["diff"] == diff:
                return r["gamma_bar"]
        raise KeyError((limb, diff))


def differencing_study(
    series_list,
    orders=(1, 2, 3),
    window: int = 100,
    names=None,
    order="aic",
    p_range=(1, 2, 3, 4),
    q_range=(0, 1, 2),
    alpha: float = 0.05,
    lags: int | None = None,
    adf_lags: int = 4,
) -> DifferencingStudy:
    """Average ARMA fitness per limb and difference order (Sec. 5.1, Eq. 26–27, Figure 5).

    Each series (a take) is differenced x times (Eq. 26, ``np.diff(·, n=x)``), cut into windows of
    ``window`` samples (:func:`split_windows`; windows never span two takes), and each window is fitted
    by ``fit_arma``. γ̄ is the mean of the windows' R² over all takes (Eq. 27, reading in the module
    docstring).

    Parameters
    ----------
    series_list
        Takes, each ``(n,)`` or ``(n, L)`` (L limbs, the same for all takes; e.g. the 4 limb angles of
        Table 3 after downsampling).
    orders
        Difference orders x (Eq. 26: 1, 2, 3).
    names
        L limb names (default ``channel 0..``).
    order
        ``"aic"``: per window the (p, q) of ``p_range`` × ``q_range`` with the least AIC (as the authors'
        published code chooses; Eq. 25's in-sample F would always pick the largest order);
        ``(p, q)``: one fixed order.
    alpha, lags
        Level and lags of the Ljung–Box whiteness test of each window's residuals (model_df = p + q).
    adf_lags
        Lagged differences of the per-window ADF test (5 % MacKinnon critical value, as the segmenter).
    """
    from mocapkit.segment.arma import adf_critical_value, adf_statistic

    takes = [np.asarray(s, dtype=np.float64) for s in series_list]
    if not takes:
        raise InvalidParameterError("differencing_study needs at least one series")
    takes = [t[:, None] if t.ndim == 1 else t for t in takes]
    if any(t.ndim != 2 for t in takes) or len({t.shape[1] for t in takes}) != 1:
        raise InvalidParameterError("every series must be (n,) or (n, L) with the same L")
    if any(not np.all(np.isfinite(t)) for t in takes):
        raise InvalidParameterError("a series holds NaN or infinite values")
    L = takes[0].shape[1]
    names = [f"channel {j}" for j in range(L)] if names is None else [str(n) for n in names]
    if len(names) != L:
        raise InvalidParameterError(f"{len(names)} names for {L} channels")
    orders = tuple(int(x) for x in orders)
    if not orders or min(orders) < 0:
        raise InvalidParameterError(f"difference orders must be non-negative, got {orders}")
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 20:
        raise InvalidParameterError(f"window must be an integer >= 20, got {window!r}")
    if isinstance(order, str):
        if order != "aic":
            raise InvalidParameterError(f"order must be 'aic' or (p, q), got {order!r}")
        grid = [(p, q) for p in p_range for q in q_range if p + q > 0]
    else:
        grid = [(int(order[0]), int(order[1]))]
    if not grid:
        raise InvalidParameterError("no (p, q) with p + q >= 1 in p_range x q_range")
    need_df = max(p + q for p, q in grid)
    rows, identified, out_windows = [], {}, {}
    for j, name in enumerate(names):
        for x in orders:
            wins = []
            for ti, t in enumerate(takes):
                z = np.diff(t[:, j], n=x) if x else t[:, j].copy()
                for s, e in split_windows(z.size, int(window)):
                    wins.append((ti, s + x, e + x, z[s:e]))
            if not wins:
                raise InvalidParameterError(f"no series is longer than {x} samples")
            r2 = np.empty(len(wins))
            chosen: list = [None] * len(wins)
            by_len: dict[int, list[int]] = {}
            for k, w in enumerate(wins):
                by_len.setdefault(w[3].size, []).append(k)
            for ks in by_len.values():
                stack = np.stack([wins[k][3] for k in ks])
                pick, fits = _fit_stack(stack, grid)
                for row, k in enumerate(ks):
                    f = fits[grid[pick[row]]]
                    chosen[k] = (grid[pick[row]], f.resid[row], stack[row, f.start:])
            white = np.zeros(len(wins), dtype=bool)
            stationary = np.zeros(len(wins), dtype=bool)
            lb_p = np.full(len(wins), np.nan)
            dicts = []
            for k, (ti, s, e, seg) in enumerate(wins):
                (p, q), resid, fitted_y = chosen[k]
                r2[k] = _r2(fitted_y[None], resid[None])[0]
                h = default_lags(resid.size) if lags is None else lags
                if h > need_df:
                    lb = ljung_box(resid, h, p + q)
                    lb_p[k] = lb.pvalue
                    white[k] = lb.pvalue > alpha
                nobs = seg.size - 1 - adf_lags
                if np.ptp(seg) > 0 and nobs - (adf_lags + 2) >= 10:
                    stat = adf_statistic(seg, adf_lags)[0]
                    stationary[k] = bool(np.isfinite(stat) and stat < adf_critical_value(nobs, 0.05))
                dicts.append({"start": int(s), "stop": int(e), "series": seg, "resid": resid, "order": (p, q),
                              "diff": x, "r2": float(r2[k]), "lb_pvalue": float(lb_p[k]), "take": ti})
            counts: dict[str, int] = {}
            for d in dicts:
                key = f"{d['order'][0]},{d['order'][1]}"
                counts[key] = counts.get(key, 0) + 1
            rows.append({
                "limb": name, "diff": x, "windows": len(wins),
                "gamma_bar": float(r2.mean()), "gamma_sd": float(r2.std()),
                "white_share": float(white.mean()), "stationary_share": float(stationary.mean()),
                "orders": dict(sorted(counts.items())),
            })
            out_windows[(j, x)] = dicts
        ok = [r["diff"] for r in rows if r["limb"] == name and r["stationary_share"] >= 0.5]
        identified[name] = min(ok) if ok else None
    return DifferencingStudy(names=names, orders=orders, rows=rows, identified=identified, windows=out_windows)
