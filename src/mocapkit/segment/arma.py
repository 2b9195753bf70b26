"""The ARMA segmenter of the seed paper (Mei, Hu, Yang, Liu, Sensors 2021, 21, 5577).

Every step of the paper, each as an explicit parameter with the paper's value as default. Where the
paper can be read two ways, the authors' published MATLAB code (the paper's reference [3],
``github.com/meifeng3/Mocap-data-collected-from-4-subjects``) decides the default and the other reading
stays an option (``differencing``, ``order``, ``cut``; steps 2, 4, 6 and 9):

1. **Downsampling** (Sec. 6.1) by an integer factor ``downsample`` (every k-th frame; the paper gives
   no factor: 4 takes 120 Hz mocap to 30 Hz).
2. **Differencing**, order ``diff_order`` = 2 (Sec. 5.1, Eq. 26: "motion sequence data after
   second-order difference are selected"). ``differencing="adf"`` (default, the authors'
   ``segmentnote_choose.m``): a window the stationarity test (step 4) passes is modelled raw, one that
   fails is differenced ``diff_order`` times, and one that still fails holds no cut — Sec. 5.2: "If
   the window sequence does not pass the stationarity test, it is differentiated".
   ``differencing="fixed"``: every limb sequence differenced ``diff_order`` times, windows that fail
   the test once more.
3. **Windows** of ``window`` = 100 samples (Sec. 5.2); a last partial window shorter than half a
   window joins the one before it.
4. **Stationarity test** per window (Sec. 4.2, Eq. 12): an augmented Dickey–Fuller test with a
   constant and ``adf_lags`` lagged differences at level ``adf_alpha`` (MacKinnon 2010 critical
   values); see step 2 for what a failing window becomes.
5. **AR(MA) least-squares fit** (Eq. 16–22): AR(p) by ordinary least squares on the lagged design
   of Eq. 20 with a constant ``c`` (Eq. 17); for q > 0 the MA part is fitted by the two-stage
   least-squares method of Hannan and Rissanen (a long AR gives residual estimates ε̂, then θ_t is
   regressed on p lags of θ and q lags of ε̂). All windows are solved at once by batched QR in NumPy.
   The residual variance is Eq. 22, σ̂² = s(β̂)/(n − p) with n − p the fitted samples.
6. **Order selection**. ``order="aic"`` (default, the authors' ``ARMA_output_change.m``: ``armax``
   over p, q = 0..5 and the least ``aic``): per window, the (p, q) of ``p_range`` × ``q_range`` (0..5
   each, p + q ≥ 1) with the least AIC = m·ln σ̂² + 2(p + q + 1), σ̂² over the samples every order
   predicts (so that all orders are compared on the same samples). ``order="best_f"``: Eq. 25, "the
   fitness F(p, q) of the ARMA model is used as the standard to decide whether the order of the model
   is appropriate" — the least F over the grid, F the mean squared one-step error of the model on the
   whole differenced sequence of a limb. ``order="parsimonious"``: the same F (below). The paper
   searches (p, q) by particle swarm optimisation (Eq. 23–24); an exhaustive search over the small
   grid finds the exact optimum PSO approximates, so it replaces it. Because in-sample F can only fall as the order
   grows, "parsimonious" takes the smallest p + q whose F is within ``order_rtol`` of the best (our earlier
   default, with p ≤ 4, q ≤ 2).
7. **R² per window** (Eq. 28–29) against ``r2_min`` = 0.6: a window whose R² is below the threshold
   holds a segmentation point. SSE and SST run over the samples the fit predicts (the first p, or
   long-AR + q, samples of a window have no prediction). Sec. 5.2 can be read two ways: each window
   fitted on its own (``r2_fit="window"``, default), or "fit each limb sequence, then divide the
   fitted sequence into windows" (``r2_fit="sequence"``: one model per limb, no per-window
   differencing; it needs ``order="best_f"`` or ``"parsimonious"``). With the fitness-SD reading of
   steps 2, 6, 9 the 4 labelled CMU takes gave mean frame agreement 0.673 with "window", 0.618 with
   "sequence". On real takes most windows fall below 0.6 with either reading, so the method tends to
   cut about once per window. (The authors' code tests R², as a squared correlation of measured and
   predicted, on sub-windows of 25 samples and keeps one cut per sub-window; we keep the paper's
   Eq. 28–29 on the window.)
8. **Per-sample fitness SD** (Eq. 30–31) in each such window: the model M currently in use — the fit
   of the preceding window, "is the current model suitable to continue to describe the subsequent
   sequence" (Sec. 5.3) — predicts every sample one step ahead; a sample inside the 95 % prediction
   interval θ̂ ± ``z``·σ̂ has SD = 1, one outside has
   SD = ((1 − 0.95) + 0.5·R_MO) / (R_O + R_AN·(1 − R_O·w/w_M)),
   with w = 2·z·σ̂ the width of the prediction interval and the paper's constants R_AN = 0.95,
   R_MO = 0.01, R_O = 0.025, w_M = 30 (the flattened Eq. 31 read term by term; clipped to [0, 1]).
   For one model every sample outside the interval gets the same SD (≈ 0.057 for w ≪ w_M). Three
   readings are ours: δ of Eq. 30 ("the standard deviation of the measurement data") is taken as the
   model's residual SD σ̂ of Eq. 22, the spread the one-step interval must cover; Eq. 31 prints
   1.90 where Eq. 30 has 1.96 — we use ``z`` = 1.96 (95 %); w_M = 30 is used as given, in the units
   of the differenced signal (the paper also calls it the window length and Max − Min of the data),
   and for w above w_M·(R_O + R_AN)/(R_AN·R_O) ≈ 1232 the denominator turns negative and SD is 0.
   With ``differencing="fixed"`` M is the preceding window's fit; with ``"adf"`` (windows modelled
   raw or differenced, not one contiguous series) and for the first window, and a window whose
   predecessor was differenced to another order, M is the window's own fit.
9. **The cut**. ``cut="max_error"`` (default, the authors' ``point_choose2.m``: ``[aa, bb] = max(W)``
   over ``W = |U − M3|``): the sample of largest |measured − predicted| one step ahead.
   ``cut="min_sd"``: Sec. 5.2, "the minimum fitness in this data segment is selected as the
   segmentation point" — the sample of minimum fitness SD. All samples outside the interval of one
   model have the same SD, so ties are broken (our choice; the paper does not say) by the sample that
   best splits the window into "M fits" before and "M fails" from it on (the count of SD = 1 samples
   before it plus SD < 1 samples from it), then by the larger standardised error.
10. **Median ensemble over limbs** (Eq. 32). The paper takes the median of each row of the matrix
    of per-limb cuts, which needs every limb to find the same number of cuts. We define: all cuts of
    all limbs are pooled and sorted; a cut within ``ensemble_tol`` samples of its group's first cut
    joins that group, otherwise it starts a new one; a group with cuts from at least ``min_limbs`` different limbs gives
    one cut at the median of its members (each limb first reduced to the median of its own members), other
    groups are dropped. When all limbs find the same cuts in the same order within the tolerance,
    this equals the paper's row-wise median. Groups are complete-linkage: a group spans at most
    ``ensemble_tol`` samples from its first cut, so chains of nearby cuts cannot merge far-apart ones.
    ``select="auto"`` instead keeps the subset of all groups (one limb enough) that the
    number-of-segments rule of :mod:`mocapkit.segment.autok` prefers (:meth:`ARMASegmenter.select_cuts`).

Cuts are returned as 0-based frames of the input (a downsampled sample ``t`` is input frame
``t·downsample``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts

# MacKinnon (2010), "Critical values for cointegration tests", Table: τ_c (one variable, constant),
# response-surface coefficients β∞, β1, β2, β3 for the 1 %, 5 % and 10 % levels.
_ADF_C_CRIT = {
    0.01: (-3.43035, -6.5393, -16.786, -79.433),
    0.05: (-2.86154, -2.8903, -4.234, -40.040),
    0.10: (-2.56677, -1.5384, -2.809, 0.0),
}


def adf_critical_value(nobs: int, alpha: float = 0.05) -> float:
    """MacKinnon (2010) critical value of the ADF t statistic (constant, no trend) for ``nobs``."""
    if alpha not in _ADF_C_CRIT:
        raise InvalidParameterError(f"adf_alpha must be one of {sorted(_ADF_C_CRIT)}, got {alpha}")
    b = _ADF_C_CRIT[alpha]
    x = 1.0 / nobs
    return b[0] + b[1] * x + b[2] * x * x + b[3] * x ** 3


def _batched_ols(D: np.ndarray, y: np.ndarray):
    """Least squares for a stack: ``D`` ``(K, m, k)``, ``y`` ``(K, m)`` → β ``(K, k)``, fitted ``(K, m)``.

    Solved by QR (``R β = Qᵀ y``), not by the normal equations, so that it agrees with statsmodels'
    pinv/QR-based OLS to rounding. Rank-deficient windows (e.g. a constant angle) fall back to
    ``lstsq`` one by one.
    """
    Q, R = np.linalg.qr(D)
    qty = np.einsum("kmi,km->ki", Q, y)
    diag = np.abs(np.diagonal(R, axis1=1, axis2=2))
    scale = np.maximum(diag.max(axis=1, initial=0.0), 1e-300)
    ok = (diag > 1e-10 * scale[:, None]).all(axis=1)
    beta = np.empty((D.shape[0], D.shape[2]))
    if ok.any():
        beta[ok] = np.linalg.solve(R[ok], qty[ok][..., None])[..., 0]
    for k in np.flatnonzero(~ok):
        beta[k] = np.linalg.lstsq(D[k], y[k], rcond=None)[0]
    fitted = np.einsum("kmi,ki->km", D, beta)
    return beta, fitted


def _r2(y: np.ndarray, resid: np.ndarray) -> float:
    """Eq. 28–29: R² = 1 − SSE/SST over the samples ``y`` with residuals ``resid`` (1 when SST = 0)."""
    sst = float(((y - y.mean()) ** 2).sum())
    return 1.0 - float((resid ** 2).sum()) / sst if sst > 0 else 1.0


def _lagged(z: np.ndarray, p: int, start: int) -> np.ndarray:
    """Design columns ``[z_{t-1}, ..., z_{t-p}]`` for ``t = start..m-1`` of each row of ``z`` ``(K, m)``."""
    m = z.shape[1]
    return (
        np.stack([z[:, start - i : m - i] for i in range(1, p + 1)], axis=2)
        if p
        else np.empty((z.shape[0], m - start, 0))
    )


@dataclass(frozen=True)
class ARMAFit:
    """Least-squares AR(MA) fits of a stack of equal-length series.

    ``coef`` ``(K, 1 + p + q)`` is ``[c, β_1..β_p, λ_1..λ_q]``; ``fitted`` and ``resid`` cover samples
    ``start..m-1`` of each series; ``sigma2`` is Eq. 22 (SSR / fitted samples).
    """

    p: int
    q: int
    start: int
    coef: np.ndarray
    fitted: np.ndarray
    resid: np.ndarray
    sigma2: np.ndarray
    long_coef: np.ndarray | None = None


def fit_arma(z, p: int, q: int = 0, long_ar: int | None = None) -> ARMAFit:
    """Least-squares ARMA(p, q) with a constant for each row of ``z`` (``(m,)`` or ``(K, m)``).

    q = 0: ordinary least squares of Eq. 20–21 on samples ``p..m-1`` (as statsmodels ``AutoReg`` with
    ``trend="c"``). q > 0: Hannan–Rissanen — residuals ε̂ of a long AR(``long_ar``, default
    ``max(2(p + q), p + q + 2)``), then OLS of θ_t on ``[1, θ_{t-1..t-p}, ε̂_{t-1..t-q}]`` on the
    samples where all lags exist.
    """
    z = np.atleast_2d(np.asarray(z, dtype=np.float64))
    if p < 0 or q < 0 or p + q == 0:
        raise InvalidParameterError(f"ARMA order needs p >= 0, q >= 0, p + q >= 1; got ({p}, {q})")
    m = z.shape[1]
    K = z.shape[0]
    if q == 0:
        start = p
        if m - start < p + 2:
            raise InvalidParameterError(f"{m} samples are too few for AR({p})")
        D = np.concatenate([np.ones((K, m - start, 1)), _lagged(z, p, start)], axis=2)
        y = z[:, start:]
    else:
        L = long_ar if long_ar is not None else max(2 * (p + q), p + q + 2)
        first = fit_arma(z, L, 0)
        eps = np.zeros_like(z)
        eps[:, L:] = first.resid
        start = L + q
        if m - start < p + q + 2:
            raise InvalidParameterError(f"{m} samples are too few for ARMA({p}, {q}) with a long AR({L})")
        D = np.concatenate(
            [np.ones((K, m - start, 1)), _lagged(z, max(p, 0), start), _lagged(eps, q, start)], axis=2
        )
        y = z[:, start:]
    coef, fitted = _batched_ols(D, y)
    resid = y - fitted
    sigma2 = (resid ** 2).sum(axis=1) / resid.shape[1]
    return ARMAFit(p=p, q=q, start=start, coef=coef, fitted=fitted, resid=resid, sigma2=sigma2,
                   long_coef=None if q == 0 else first.coef)


def predict_one_step(fit: ARMAFit, k: int, x: np.ndarray, history: np.ndarray) -> np.ndarray:
    """One-step predictions of the samples of ``x`` by row ``k`` of ``fit``.

    ``history`` holds the samples before ``x`` (at least the model's longest lag; the preceding
    window). For q > 0 the innovations ε_{t-j} are taken, as in the fit, from the long AR of the
    first Hannan–Rissanen stage, not from the recursion ε_t = θ_t − θ̂_t: after second-order
    differencing the MA part has roots on the unit circle and that recursion does not forget its
    start.
    """
    c = fit.coef[k, 0]
    beta = fit.coef[k, 1:1 + fit.p]
    lam = fit.coef[k, 1 + fit.p:]
    lags = fit.p
    long_coef = fit.long_coef
    if fit.q:
        assert long_coef is not None  # fit_arma keeps the long AR whenever q > 0
        L = long_coef.shape[1] - 1
        lags = max(fit.p, L + fit.q)
    if history.size < lags:
        raise InvalidParameterError(f"one-step prediction needs {lags} samples of history, got {history.size}")
    full = np.concatenate([history[history.size - lags:], x])
    n = x.size
    pred = np.full(n, c)
    for i in range(1, fit.p + 1):
        pred += beta[i - 1] * full[lags - i:lags - i + n]
    if fit.q:
        assert long_coef is not None
        lc = long_coef[k]
        m = n + fit.q  # innovations for samples -q..n-1 of x
        eps = full[lags - fit.q:].copy()
        eps -= lc[0]
        for i in range(1, L + 1):
            eps -= lc[i] * full[lags - fit.q - i:lags - fit.q - i + m]
        for j in range(1, fit.q + 1):
            pred += lam[j - 1] * eps[fit.q - j:fit.q - j + n]
    return pred


def adf_statistic(z, lags: int) -> np.ndarray:
    """Augmented Dickey–Fuller t statistic (constant, ``lags`` lagged differences) per row of ``z``.

    Regression Δy_t = a + γ·y_{t-1} + Σ δ_i Δy_{t-i} + e_t; returns γ̂ / se(γ̂) (as statsmodels
    ``adfuller(x, maxlag=lags, autolag=None, regression="c")``).
    """
    z = np.atleast_2d(np.asarray(z, dtype=np.float64))
    dz = np.diff(z, axis=1)
    m = dz.shape[1]
    start = lags
    K = z.shape[0]
    cols = [z[:, start:m][..., None]]  # y_{t-1} for Δy_t = dz[:, t] (dz[t] = z[t+1] - z[t])
    if lags:
        cols.append(_lagged(dz, lags, start))
    cols.append(np.ones((K, m - start, 1)))
    D = np.concatenate(cols, axis=2)
    y = dz[:, start:]
    beta, fitted = _batched_ols(D, y)
    resid = y - fitted
    dof = D.shape[1] - D.shape[2]
    s2 = (resid ** 2).sum(axis=1) / dof
    # (Dᵀ D)^-1 [0, 0] via the QR factor: var(γ̂) = s² · ||R^-T e_0||²
    _, R = np.linalg.qr(D)
    e0 = np.zeros((K, D.shape[2]))
    e0[:, 0] = 1.0
    with np.errstate(all="ignore"):
        u = np.linalg.solve(np.transpose(R, (0, 2, 1)), e0[..., None])[..., 0]
        se = np.sqrt(s2 * (u ** 2).sum(axis=1))
        return beta[:, 0] / se


class ARMASegmenter(Segmenter):
    """Unsupervised segmentation of limb angle sequences by AR(MA) fitness (the seed paper).

    Parameters
    ----------
    downsample
        Keep every ``downsample``-th frame (Sec. 6.1; no factor in the paper).
    diff_order
        Order of differencing before modelling (Sec. 5.1: 2).
    window
        Window length in (downsampled) samples (Sec. 5.2: 100).
    adf_lags, adf_alpha
        Lagged differences and level of the per-window ADF stationarity test (Sec. 4.2).
    p_range, q_range
        The (p, q) grid searched exhaustively (replaces the PSO): 0..5 each, as the authors' code.
    order_rtol
        ``order="parsimonious"``: the smallest p + q with F within this relative margin of the best F.
    r2_min
        R² threshold of Eq. 29 (0.6): windows below it hold a cut.
    z
        Half-width of the prediction interval in σ (Eq. 30: 1.96 for 95 %).
    r_an, r_mo, r_o, w_m
        The constants of Eq. 31 (0.95, 0.01, 0.025, 30).
    ensemble_tol
        Cuts of different limbs closer than this many samples are the same cut (Eq. 32 grouping).
    min_limbs
        A grouped cut is kept when found by at least this many limbs (capped at the number of
        channels that move).
    r2_fit
        ``"window"``: each window's own fit gives its R² (default); ``"sequence"``: one fit of the
        whole differenced sequence, split into windows (the module docstring, step 7).
    differencing
        ``"adf"`` (default, the authors' code) or ``"fixed"`` (module docstring, step 2).
    order
        ``"aic"`` (default, the authors' code), ``"best_f"`` (Eq. 25) or ``"parsimonious"`` (step 6).
    cut
        ``"max_error"`` (default, the authors' code) or ``"min_sd"`` (Sec. 5.2; step 9).
    select
        ``"ensemble"`` (default, Eq. 32) or ``"auto"`` (step 10).
    stats_width
        ``select="auto"``: width in samples of the moving statistics the selection compares (30: 1 s
        at 30 Hz).

    Attributes
    ----------
    channels_ : list of dict
        Per channel: ``cuts`` (downsampled samples), ``r2`` and ``bounds`` per window, ``orders``,
        ``sd`` per sample, and ``windows``: per modelled window a dict with ``start``/``stop`` (first
        and end sample of the modelled series), ``series``, ``resid``, ``order``, ``diff``, ``r2``.
    """

    def __init__(
        self,
        downsample: int = 4,
        diff_order: int = 2,
        window: int = 100,
        adf_lags: int = 4,
        adf_alpha: float = 0.05,
        p_range: tuple[int, ...] = (0, 1, 2, 3, 4, 5),
        q_range: tuple[int, ...] = (0, 1, 2, 3, 4, 5),
        order_rtol: float = 0.01,
        r2_min: float = 0.6,
        z: float = 1.96,
        r_an: float = 0.95,
        r_mo: float = 0.01,
        r_o: float = 0.025,
        w_m: float = 30.0,
        ensemble_tol: int = 50,
        min_limbs: int = 2,
        r2_fit: str = "window",
        differencing: str = "adf",
        order: str = "aic",
        cut: str = "max_error",
        select: str = "ensemble",
        stats_width: int = 30,
    ):
        if int(downsample) != downsample or downsample < 1:
            raise InvalidParameterError(f"downsample must be a positive integer, got {downsample}")
        if int(diff_order) != diff_order or not 0 <= diff_order <= 3:
            raise InvalidParameterError(f"diff_order must be 0..3, got {diff_order}")
        if int(window) != window or window < 20:
            raise InvalidParameterError(f"window must be an integer >= 20, got {window}")
        if not p_range or min(p_range) < 0 or not q_range or min(q_range) < 0:
            raise InvalidParameterError("p_range and q_range must be non-empty and non-negative")
        pm, qm = max(p_range), max(q_range)
        L = max(2 * (pm + qm), pm + qm + 2) if qm else 0
        need = max(2 * pm + 2, 2 * L + 2, L + pm + 2 * qm + 2)
        if need > window // 2 - 1:
            raise InvalidParameterError(
                f"orders p <= {pm}, q <= {qm} need windows of at least {2 * (need + 1)} samples, got {window}"
            )
        for name, value, allowed in (("differencing", differencing, ("adf", "fixed")),
                                     ("order", order, ("aic", "best_f", "parsimonious")),
                                     ("cut", cut, ("max_error", "min_sd")),
                                     ("select", select, ("ensemble", "auto"))):
            if value not in allowed:
                raise InvalidParameterError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
        if r2_fit == "sequence" and order == "aic":
            raise InvalidParameterError(
                "r2_fit='sequence' fits one model per limb: use order='best_f' or 'parsimonious'"
            )
        if r2_fit not in ("window", "sequence"):
            raise InvalidParameterError(f"r2_fit must be 'window' or 'sequence', got {r2_fit!r}")
        if not 0 < r2_min < 1:
            raise InvalidParameterError(f"r2_min must be in (0, 1), got {r2_min}")
        if z <= 0 or w_m <= 0 or not 0 <= r_o <= 1 or not 0 <= r_an <= 1 or not 0 <= r_mo <= 1:
            raise InvalidParameterError("z, w_m must be positive and r_an, r_mo, r_o probabilities")
        if ensemble_tol < 0 or min_limbs < 1:
            raise InvalidParameterError("ensemble_tol must be >= 0 and min_limbs >= 1")
        if adf_lags < 0:
            raise InvalidParameterError(f"adf_lags must be >= 0, got {adf_lags}")
        adf_critical_value(100, adf_alpha)  # validates adf_alpha
        self.downsample = int(downsample)
        self.diff_order = int(diff_order)
        self.window = int(window)
        self.adf_lags = int(adf_lags)
        self.adf_alpha = adf_alpha
        self.p_range = tuple(int(p) for p in p_range)
        self.q_range = tuple(int(q) for q in q_range)
        self.order_rtol = float(order_rtol)
        self.r2_min = float(r2_min)
        self.z = float(z)
        self.r_an, self.r_mo, self.r_o, self.w_m = float(r_an), float(r_mo), float(r_o), float(w_m)
        self.ensemble_tol = int(ensemble_tol)
        self.min_limbs = int(min_limbs)
        self.r2_fit = r2_fit
        self.differencing = differencing
        self.order = order
        self.cut = cut
        self.select = select
        if int(stats_width) != stats_width or stats_width < 2:
            raise InvalidParameterError(f"stats_width must be an integer >= 2, got {stats_width}")
        self.stats_width = int(stats_width)

    # -- steps -------------------------------------------------------------------------------
    def windows(self, m: int) -> list[tuple[int, int]]:
        """Window bounds (half-open) over ``m`` differenced samples (step 3)."""
        W = self.window
        bounds = [(s, min(s + W, m)) for s in range(0, m, W)]
        if len(bounds) > 1 and bounds[-1][1] - bounds[-1][0] < W // 2:
            last = bounds.pop()
            bounds[-1] = (bounds[-1][0], last[1])
        return bounds

    def select_order(self, z: np.ndarray) -> tuple[tuple[int, int], dict]:
        """Exhaustive (p, q) search by the fitness F of Eq. 25 on the whole series ``z`` (step 6)."""
        F = {}
        for p in self.p_range:
            for q in self.q_range:
                if p + q == 0:
                    continue
                f = fit_arma(z, p, q)
                F[(p, q)] = float(np.mean(f.resid[0] ** 2))
        best = min(F.values())
        rtol = self.order_rtol if self.order == "parsimonious" else 0.0
        ok = [o for o, v in F.items() if v <= best * (1 + rtol) + 1e-300]
        order = min(ok, key=lambda o: (o[0] + o[1], o[1], o[0]))
        return order, F

    def sd(self, err: np.ndarray, sigma: float) -> np.ndarray:
        """Fitness SD of Eq. 31 for prediction errors ``err`` of a model with residual SD ``sigma``."""
        width = 2 * self.z * sigma
        outside = ((1 - 0.95) + 0.5 * self.r_mo) / (self.r_o + self.r_an * (1 - self.r_o * width / self.w_m))
        outside = min(max(outside, 0.0), 1.0)
        return np.where(np.abs(err) <= self.z * sigma, 1.0, outside)

    @staticmethod
    def _cut_in(sd: np.ndarray, score_err: np.ndarray) -> int:
        """Index of the cut in one window: a sample of minimum SD (step 9).

        Ties — every sample outside the interval of one model has the same SD — go to the sample
        that best splits the window into "the model fits" before and "it does not" after (most
        samples with SD = 1 before it plus samples with SD < 1 from it on), then to the larger
        standardised error.
        """
        fits = sd >= 1.0
        before = np.concatenate([[0], np.cumsum(fits)[:-1]])
        after = np.cumsum((~fits)[::-1])[::-1]
        split = before + after
        return int(np.lexsort((-score_err, -split, sd))[0])

    def _stationary(self, w: np.ndarray) -> bool:
        """Step 4: the ADF test of one window rejects a unit root (a constant window, or one too short
        for the regression, counts as stationary: it is left as it is)."""
        nobs = w.size - 1 - self.adf_lags
        if np.ptp(w) == 0 or nobs - (self.adf_lags + 2) < 10:
            return True
        stat = adf_statistic(w, self.adf_lags)[0]
        return not np.isfinite(stat) or bool(stat < adf_critical_value(nobs, self.adf_alpha))

    def window_models(self, x: np.ndarray) -> tuple[list, list]:
        """Steps 2–4 on one channel: ``bounds`` (windows of raw samples) and, per window, ``(series,
        first sample, differencing order)`` of what is modelled, or None for a window the test still
        finds non-stationary after differencing (``differencing="adf"``: no cut there, as in the
        authors' code)."""
        d = self.diff_order
        if self.differencing == "adf":
            bounds = self.windows(x.size)
            out: list[tuple[np.ndarray, int, int] | None] = []
            for s, e in bounds:
                w = x[s:e]
                if self._stationary(w):
                    out.append((w, s, 0))
                    continue
                dw = np.diff(w, n=d) if d else w
                out.append((dw, s + d, d) if d and self._stationary(dw) else None)
            return bounds, out
        z = np.diff(x, n=d) if d else x.copy()  # z[i] belongs to sample i + d
        zb = self.windows(z.size)
        extra = np.array([not self._stationary(z[s:e]) for s, e in zb], dtype=bool)
        series = self.window_series(z, zb, extra)
        bounds = [(s + d, e + d) for s, e in zb]
        return bounds, [(v, off + d, d + int(extra[k])) for k, (v, off) in enumerate(series)]

    def _aic_orders(self, series: list) -> list:
        """Per window, the (p, q) of the grid with the least AIC = m·ln σ̂² + 2(p + q + 1) (the authors'
        ``armax`` + ``aic`` over p, q ≤ 5), σ̂² over the samples every order of the grid predicts."""
        grid = [(p, q) for p in self.p_range for q in self.q_range if p + q > 0]
        tail = max((max(2 * (p + q), p + q + 2) + q) if q else p for p, q in grid)
        best: list[tuple[int, int] | None] = [None] * len(series)
        by_len: dict[int, list[int]] = {}
        for k, item in enumerate(series):
            if item is not None:
                by_len.setdefault(item[0].size, []).append(k)
        for ks in by_len.values():
            stack = np.stack([series[k][0] for k in ks])
            scores = np.full((len(ks), len(grid)), np.inf)
            for j, (p, q) in enumerate(grid):
                try:
                    f = fit_arma(stack, p, q)
                except InvalidParameterError:
                    continue
                r = f.resid[:, tail - f.start:]
                s2 = np.maximum((r ** 2).mean(axis=1), 1e-300)
                scores[:, j] = r.shape[1] * np.log(s2) + 2 * (p + q + 1)
            for row, k in enumerate(ks):
                best[k] = grid[int(np.argmin(scores[row]))]
        return best

    def _channel(self, x: np.ndarray) -> dict:
        """Steps 2–9 on one downsampled channel; cut positions are downsampled sample indices."""
        d = self.diff_order
        if self.r2_fit == "sequence":
            z = np.diff(x, n=d) if d else x.copy()
            (p, q), F_seq = self.select_order(z)
            scale = max(float(np.abs(z).max()) if z.size else 0.0, np.finfo(float).tiny)
            return self._channel_sequence(z, self.windows(z.size), (p, q), F_seq, scale)
        bounds, series = self.window_models(x)
        F: dict | None = None
        if self.order == "aic":
            orders = self._aic_orders(series)
        else:  # one order per limb, by Eq. 25 on the whole differenced sequence
            (p, q), F = self.select_order(np.diff(x, n=d) if d else x)
            orders = [(p, q) if it is not None else None for it in series]
        scale = max(float(np.abs(np.diff(x, n=d) if d else x).max()), np.finfo(float).tiny)
        # step 5/7: per-window fits and R² (Eq. 28-29), batched per (length, order)
        fits: list = [None] * len(series)
        groups: dict[tuple, list[int]] = {}
        for k, item in enumerate(series):
            if item is not None:
                groups.setdefault((item[0].size, orders[k]), []).append(k)
        for (_, (p, q)), ks in groups.items():
            f = fit_arma(np.stack([series[k][0] for k in ks]), p, q)
            for row, k in enumerate(ks):
                fits[k] = (f, row)
        r2 = np.full(len(series), np.nan)
        for k, item in enumerate(series):
            if item is not None:
                f, row = fits[k]
                r2[k] = _r2(item[0][f.start:], f.resid[row])
        # steps 8-9: fitness SD and the cut in windows below the R² threshold
        sd_all = np.ones(x.size)
        cuts = []
        windows = []
        for k, item in enumerate(series):
            if item is None:
                continue
            seg, first, dk = item
            f, row = fits[k]
            windows.append({"start": int(first), "stop": int(first + seg.size), "series": seg,
                            "resid": f.resid[row], "order": orders[k], "diff": int(dk), "r2": float(r2[k])})
            if not r2[k] < self.r2_min:
                continue
            prev = series[k - 1] if k > 0 else None
            # "is the current model suitable to continue to describe the subsequent sequence" (Sec. 5.3):
            # the preceding window's model, where it models the same contiguous series
            use_prev = self.differencing == "fixed" and prev is not None and prev[2] == dk
            if use_prev and prev is not None:
                fp, rowp = fits[k - 1]
                err = seg - predict_one_step(fp, rowp, seg, prev[0])
                idx = np.arange(seg.size)
                sigma = max(float(np.sqrt(fp.sigma2[rowp])), 1e-12 * scale)
            else:
                err = f.resid[row]
                idx = np.arange(f.start, seg.size)
                sigma = max(float(np.sqrt(f.sigma2[row])), 1e-12 * scale)
            sd = self.sd(err, sigma)
            sd_all[first + idx] = sd
            if self.cut == "max_error":
                best = idx[int(np.argmax(np.abs(err)))]
            else:
                best = idx[self._cut_in(sd, np.abs(err) / sigma)]
            cuts.append(int(first + best))
        order = orders[0] if len({o for o in orders if o is not None}) == 1 else None
        return {"order": order, "orders": orders, "F": F, "r2": r2, "bounds": bounds, "sd": sd_all,
                "cuts": cuts, "windows": windows,
                "extra": np.array([it is not None and it[2] > d for it in series], dtype=bool)}

    def _channel_sequence(self, z, bounds, order, F, scale) -> dict:
        """``r2_fit="sequence"``: one fit of the whole differenced sequence, split into windows."""
        d = self.diff_order
        p, q = order
        f = fit_arma(z, p, q)
        resid = np.full(z.size, np.nan)
        resid[f.start:] = f.resid[0]
        sigma = max(float(np.sqrt(f.sigma2[0])), 1e-12 * scale)
        r2 = np.empty(len(bounds))
        sd_all = np.ones(z.size + d)
        cuts = []
        for k, (s, e) in enumerate(bounds):
            a = max(s, f.start)
            r2[k] = _r2(z[a:e], resid[a:e]) if e - a > 2 else 1.0
            if r2[k] < self.r2_min:
                err = resid[a:e]
                sd = self.sd(err, sigma)
                sd_all[a + d:e + d] = sd
                cuts.append(int(a + self._cut_in(sd, np.abs(err) / sigma) + d))
        return {"order": order, "F": F, "r2": r2, "bounds": bounds, "extra": np.zeros(len(bounds), bool),
                "sd": sd_all, "cuts": cuts}

    @staticmethod
    def window_series(z: np.ndarray, bounds, extra) -> list[tuple[np.ndarray, int]]:
        """Per window, ``(series, offset)``: ``z[s:e]``, or for a window that failed the stationarity
        test its first differences ``z[i] - z[i-1]`` for ``i = max(s, 1)..e-1`` (offset ``max(s, 1)``),
        so that neighbouring differenced windows join without a gap."""
        dz = np.diff(z)  # dz[i - 1] = z[i] - z[i - 1] belongs to index i
        out = []
        for k, (s, e) in enumerate(bounds):
            if extra[k]:
                a = max(s, 1)
                out.append((dz[a - 1:e - 1], a))
            else:
                out.append((z[s:e], s))
        return out

    def ensemble(self, limb_cuts: list[list[int]], n_channels: int | None = None) -> list[int]:
        """Median ensemble of per-limb cuts (Eq. 32, grouping rule in the module docstring)."""
        need = min(self.min_limbs, n_channels if n_channels is not None else len(limb_cuts))
        pooled = sorted((c, i) for i, cs in enumerate(limb_cuts) for c in cs)
        out = []
        group: list[tuple[int, int]] = []

        def close(g):
            limbs: dict[int, list[int]] = {}
            for c, i in g:
                limbs.setdefault(i, []).append(c)
            if len(limbs) >= need:
                out.append(int(round(float(np.median([np.median(v) for v in limbs.values()])))))

        for c, i in pooled:
            if group and c - group[0][0] > self.ensemble_tol:
                close(group)
                group = []
            group.append((c, i))
        if group:
            close(group)
        return out

    def select_cuts(self, x: np.ndarray, candidates: list[int]) -> list[int]:
        """``select="auto"``: the number of cuts chosen without labels among the ``candidates`` (every
        ensemble group, one limb enough). The limb angles' moving mean and standard deviation over
        ``stats_width`` samples are standardised; the penalty per cut is the slope heuristic of their
        unrestricted kernel cost curve (:func:`mocapkit.segment.autok.slope_penalty`), and the cuts
        are the subset of the candidates minimising kernel cost + penalty × cuts (exact, by
        :func:`mocapkit.segment.autok.cost_curve` with ``candidates``)."""
        from mocapkit.segment._common import standardise
        from mocapkit.segment.autok import cost_curve, slope_penalty, window_stats

        if not candidates or np.ptp(x, axis=0).max() == 0:
            return []
        stride = max(1, -(-x.shape[0] // 2000))  # the DP's tables are quadratic in the samples
        size = max(2, int(round(self.stats_width / stride)))
        f = standardise(window_stats(x[::stride], size))
        if f.shape[0] < 2 * size:
            return []
        full = cost_curve(f, size, 30, "rbf")
        pen = slope_penalty(full.costs)
        if pen is None:
            return []
        cand = sorted({int(round(c / stride)) for c in candidates} - {0, f.shape[0]})
        cand = [c for c in cand if 0 < c < f.shape[0]]
        if not cand:
            return []
        curve = cost_curve(f, size, 30, "rbf", candidates=cand)
        k = int(np.argmin(curve.costs + pen * np.arange(curve.costs.size)))
        return [int(c) * stride for c in curve.cuts(k)]

    # -- API -----------------------------------------------------------------------------------
    def fit(self, X) -> ARMASegmenter:
        X = as_signal(X)
        n = X.shape[0]
        x = X[:: self.downsample]
        need = self.window // 2 + self.diff_order + 1
        if x.shape[0] < need:
            raise InvalidParameterError(
                f"{n} frames give {x.shape[0]} samples after downsampling by {self.downsample}; the ARMA "
                f"segmenter needs at least {need}"
            )
        self.n_frames_ = n
        self.channels_ = [self._channel(x[:, j]) for j in range(x.shape[1])]
        limb = [ch["cuts"] for ch in self.channels_]
        moving = int(sum(np.ptp(x[:, j]) > 0 for j in range(x.shape[1])))
        if self.select == "auto":
            merged = self.select_cuts(x, self.ensemble(limb, 1))
        else:
            merged = self.ensemble(limb, max(moving, 1))
        self.limb_cuts_ = [clean_cuts(np.asarray(c) * self.downsample, n) for c in limb]
        self.cuts_ = clean_cuts(np.asarray(merged, dtype=np.int64) * self.downsample, n)
        return self
