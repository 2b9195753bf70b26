"""ACF/PACF, Ljung–Box and the differencing-order study of ``mocapkit.segment.diagnostics`` (ARMA seed paper,
Sec. 4.3, 4.5, 5.1) against statsmodels (test-only), brute-force formulas and closed-form properties; and the
``plot_arma_diagnostics`` figure."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.segment.arma import fit_arma
from mocapkit.segment.diagnostics import (
    acf,
    confidence_band,
    differencing_study,
    is_white,
    ljung_box,
    pacf,
    split_windows,
)


@pytest.fixture(scope="module")
def sm_stattools():
    """statsmodels (a test-only dependency) as the independent reference."""
    return pytest.importorskip("statsmodels.tsa.stattools")


@pytest.fixture(scope="module")
def sm_diag():
    return pytest.importorskip("statsmodels.stats.diagnostic")


def ar1(phi: float, n: int, seed: int, burn: int = 200) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(n + burn)
    x = np.zeros(n + burn)
    for t in range(1, n + burn):
        x[t] = phi * x[t - 1] + e[t]
    return x[burn:]


def arma(n: int, seed: int) -> np.ndarray:
    """An ARMA(2, 1) with a non-zero mean (so demeaning matters)."""
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(n + 300)
    x = np.zeros(n + 300)
    for t in range(2, n + 300):
        x[t] = 0.6 * x[t - 1] - 0.3 * x[t - 2] + e[t] + 0.4 * e[t - 1]
    return x[300:] + 5.0


def brute_acf(x, nlags, adjusted=False):
    """Eq. 14 term by term with explicit loops (1/n, or 1/(n−k) when adjusted)."""
    n = len(x)
    m = sum(x) / n
    g = []
    for k in range(nlags + 1):
        s = 0.0
        for t in range(k, n):
            s += (x[t] - m) * (x[t - k] - m)
        g.append(s / (n - k if adjusted else n))
    return np.array(g) / g[0]


def brute_pacf(x, nlags, adjusted=False):
    """φ_kk as the last coefficient of the k×k Yule–Walker system, solved directly for every k."""
    r = brute_acf(x, nlags, adjusted)
    out = [1.0]
    for k in range(1, nlags + 1):
        R = np.array([[r[abs(i - j)] for j in range(k)] for i in range(k)])
        out.append(np.linalg.solve(R, r[1:k + 1])[-1])
    return np.array(out)


# --- ACF / PACF ------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("adjusted", [False, True])
def test_acf_matches_statsmodels_and_brute_force(sm_stattools, seed, adjusted):
    x = arma(150, seed)
    ours = acf(x, 20, adjusted=adjusted)
    ref = sm_stattools.acf(x, nlags=20, adjusted=adjusted, fft=False)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours, brute_acf(list(x), 20, adjusted), rtol=0, atol=1e-12)


def test_acf_default_is_statsmodels_default(sm_stattools):
    """The reading of Eq. 14: 1/n at every lag, i.e. statsmodels' ``acf`` with its defaults."""
    x = arma(100, 7)
    np.testing.assert_allclose(acf(x, 15), sm_stattools.acf(x, nlags=15), atol=1e-10)
    # the literal 1/(n-1) for γ_0 would shrink every ρ_k by (n-1)/n: not what we compute
    assert not np.allclose(acf(x, 15)[1:], acf(x, 15)[1:] * 99 / 100, atol=1e-6)


@pytest.mark.parametrize("seed", [0, 3])
def test_pacf_matches_statsmodels_and_yule_walker(sm_stattools, seed):
    x = arma(200, seed)
    ours = pacf(x, 15)
    np.testing.assert_allclose(ours, sm_stattools.pacf(x, nlags=15, method="ldb"), atol=1e-10)
    np.testing.assert_allclose(ours, sm_stattools.pacf(x, nlags=15, method="ywm"), atol=1e-10)
    np.testing.assert_allclose(ours, brute_pacf(list(x), 15), atol=1e-10)
    adj = pacf(x, 15, adjusted=True)
    np.testing.assert_allclose(adj, sm_stattools.pacf(x, nlags=15), atol=1e-10)  # statsmodels' default method
    np.testing.assert_allclose(adj, brute_pacf(list(x), 15, adjusted=True), atol=1e-10)


def test_pacf_of_ar1_cuts_off_after_lag_1():
    """Sec. 4.3's identification rule: an AR(1)'s PACF is φ at lag 1, inside the band after it."""
    x = ar1(0.7, 4000, seed=5)
    p = pacf(x, 10)
    band = confidence_band(x.size)
    assert abs(p[1] - 0.7) < 0.05
    assert np.sum(np.abs(p[2:]) > band) <= 2  # ~5 % of 9 lags may stray
    a = acf(x, 10)
    np.testing.assert_allclose(a[1:6], 0.7 ** np.arange(1, 6), atol=0.06)  # ACF tails off geometrically


def test_confidence_band():
    assert confidence_band(100) == pytest.approx(1.959964 / 10, rel=1e-6)
    assert confidence_band(400, alpha=0.01) == pytest.approx(2.575829 / 20, rel=1e-6)
    with pytest.raises(InvalidParameterError):
        confidence_band(0)
    with pytest.raises(InvalidParameterError):
        confidence_band(10, alpha=1.0)


def test_constant_series_has_no_acf():
    a = acf(np.full(50, 3.0), 5)
    assert a[0] == 1.0 and np.all(np.isnan(a[1:]))
    assert np.all(np.isnan(pacf(np.full(50, 3.0), 5)[1:]))
    lb = ljung_box(np.full(50, 3.0), 5)
    assert np.isnan(lb.q) and np.isnan(lb.pvalue)
    assert is_white(np.full(50, 3.0)) is False


@pytest.mark.parametrize("bad", [[1.0], np.ones((5, 2)), [1.0, np.nan, 2.0, 3.0]])
def test_bad_series_refused(bad):
    with pytest.raises(InvalidParameterError):
        acf(bad, 1)


def test_bad_lags_refused():
    x = arma(30, 0)
    for nlags in (0, 30, 2.5, True):
        with pytest.raises(InvalidParameterError):
            acf(x, nlags)
    with pytest.raises(InvalidParameterError, match="more lags"):
        ljung_box(x, 3, model_df=3)
    with pytest.raises(InvalidParameterError):
        ljung_box(x, 5, model_df=-1)


# --- Ljung–Box -------------------------------------------------------------------------------------


def test_ljung_box_by_hand():
    """Q = n(n+2) Σ ρ_k²/(n−k) on a 6-sample series computed with fractions by hand."""
    x = [1.0, 3.0, 2.0, 5.0, 4.0, 3.0]  # mean 3; deviations -2, 0, -1, 2, 1, 0; Σd² = 10
    # lag 1: (0)(-2) + (-1)(0) + (2)(-1) + (1)(2) + (0)(1) = 0 -> ρ1 = 0
    # lag 2: (-1)(-2) + (2)(0) + (1)(-1) + (0)(2) = 1 -> ρ2 = 0.1
    lb = ljung_box(x, 2)
    q = 6 * 8 * (0.0 / 5 + 0.1 ** 2 / 4)
    assert lb.q == pytest.approx(q, abs=1e-12)
    from scipy.stats import chi2

    assert lb.df == 2 and lb.pvalue == pytest.approx(chi2.sf(q, 2), abs=1e-12)


@pytest.mark.parametrize("seed,lags,model_df", [(0, 10, 0), (1, 10, 3), (2, 5, 1), (3, 20, 6)])
def test_ljung_box_matches_statsmodels(sm_diag, seed, lags, model_df):
    x = arma(120, seed)
    ours = ljung_box(x, lags, model_df)
    ref = sm_diag.acorr_ljungbox(x, lags=[lags], model_df=model_df)
    assert ours.q == pytest.approx(float(ref["lb_stat"].iloc[0]), rel=1e-10)
    assert ours.pvalue == pytest.approx(float(ref["lb_pvalue"].iloc[0]), rel=1e-8, abs=1e-300)


def test_white_noise_passes_and_ar1_fails():
    """Seeded, 40 series of 200 samples: white noise is rejected at about the test's size (≤ 5 of 40
    at α = 5 %), an AR(1) with φ = 0.8 is rejected every time, and the residuals of an AR(1) fit to it
    pass about as often as white noise."""
    white_ok = ar_ok = resid_ok = 0
    for seed in range(40):
        rng = np.random.default_rng(1000 + seed)
        white_ok += is_white(rng.standard_normal(200))
        x = ar1(0.8, 200, seed)
        ar_ok += is_white(x)
        f = fit_arma(x, 1, 0)
        resid_ok += is_white(f.resid[0], model_df=1)
    assert white_ok >= 35
    assert ar_ok == 0
    assert resid_ok >= 35


# --- the differencing study ------------------------------------------------------------------------


def integrated_twice(phi: float, n: int, seed: int) -> np.ndarray:
    return np.cumsum(np.cumsum(ar1(phi, n, seed)))


def test_split_windows_rule():
    assert split_windows(250, 100) == [(0, 100), (100, 200), (200, 250)]
    assert split_windows(249, 100) == [(0, 100), (100, 249)]
    assert split_windows(60, 100) == [(0, 60)]


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_study_on_ar_integrated_twice(seed):
    """On an AR(1) (φ = 0.5) integrated twice, the right order is 2. Properties that could fail:

    * the ADF-based identification picks 2 (1 leaves the windows integrated, 3 is not the smallest);
    * γ̄ at d = 2 is the R² of an AR(1), φ² = 0.25 (theory), within sampling error;
    * over-differencing (d = 3) fits worse than d = 2 on average;
    * and γ̄ itself cannot pick 2: the still-integrated d = 1 windows have R² near 1 (their variance
      is mostly wander) — the reason Eq. 27 does not choose the order (see docs/segmentation/differencing.md).
    """
    y = integrated_twice(0.5, 4000, seed)
    st = differencing_study([y], orders=(1, 2, 3), window=100)
    assert st.identified == {"channel 0": 2}
    g1, g2, g3 = (st.gamma("channel 0", d) for d in (1, 2, 3))
    assert abs(g2 - 0.25) < 0.06
    assert g3 < g2
    assert g1 > 0.9
    rows = {r["diff"]: r for r in st.rows}
    assert rows[1]["stationary_share"] < 0.2 and rows[2]["stationary_share"] > 0.8
    assert rows[2]["white_share"] >= 0.85  # AR(1) residuals of an AR(1): white
    assert rows[2]["windows"] == len(split_windows(4000 - 2, 100))


def test_study_windows_are_what_was_fitted():
    """Each window dict holds the differenced samples it claims, and its R² is recomputed from an
    independent fit of that window alone (fixed order, so no selection is involved)."""
    x = np.stack([integrated_twice(0.5, 900, 11), np.cumsum(ar1(0.3, 900, 12))], axis=1)
    st = differencing_study([x[:500], x[500:]], orders=(2,), window=100, order=(2, 1), names=["a", "b"])
    for j in range(2):
        ws = st.windows[(j, 2)]
        assert len(ws) == 2 * 5 - 1  # 498 -> 5 windows, 398 -> 4 windows
        for w in ws:
            take = x[:500, j] if w["take"] == 0 else x[500:, j]
            z = np.diff(take, n=2)
            seg = z[w["start"] - 2:w["stop"] - 2]
            np.testing.assert_array_equal(w["series"], seg)
            f = fit_arma(seg, 2, 1)
            y = seg[f.start:]
            r2 = 1 - np.sum(f.resid[0] ** 2) / np.sum((y - y.mean()) ** 2)
            assert w["r2"] == pytest.approx(r2, abs=1e-12)
            # the other reading of Eq. 27 (explained / total) is the same number: SST = SSR + SSE
            ssr = np.sum((f.fitted[0] - y.mean()) ** 2)
            assert ssr / np.sum((y - y.mean()) ** 2) == pytest.approx(r2, abs=1e-9)
            assert w["lb_pvalue"] == pytest.approx(ljung_box(f.resid[0], 10, 3).pvalue, abs=1e-12)
    assert st.gamma("a", 2) == pytest.approx(np.mean([w["r2"] for w in st.windows[(0, 2)]]))


def test_study_aic_choice_is_the_least_aic():
    """The per-window order is the least AIC over the grid, recomputed on the common samples."""
    y = np.diff(integrated_twice(0.5, 600, 21), n=2)
    st = differencing_study([np.cumsum(np.cumsum(y))], orders=(2,), window=100, p_range=(1, 2), q_range=(0, 1))
    for w in st.windows[(0, 2)]:
        seg = w["series"]
        fits = {o: fit_arma(seg, *o) for o in [(1, 0), (1, 1), (2, 0), (2, 1)]}
        common = max(f.start for f in fits.values())
        m = seg.size - common
        aic = {o: m * np.log(np.sum(f.resid[0][common - f.start:] ** 2) / m) + 2 * (sum(o) + 1)
               for o, f in fits.items()}
        assert w["order"] == min(aic, key=aic.get)


def test_study_refuses_bad_input():
    y = np.cumsum(np.random.default_rng(0).standard_normal(300))
    with pytest.raises(InvalidParameterError):
        differencing_study([])
    with pytest.raises(InvalidParameterError):
        differencing_study([np.ones((100, 2)), np.ones((100, 3))])
    with pytest.raises(InvalidParameterError):
        differencing_study([y], names=["a", "b"])
    with pytest.raises(InvalidParameterError):
        differencing_study([y], window=10)
    with pytest.raises(InvalidParameterError):
        differencing_study([y], order="bic")
    with pytest.raises(InvalidParameterError):
        differencing_study([np.r_[y, np.nan]])


# --- the figure ------------------------------------------------------------------------------------


def window_dicts(x: np.ndarray, diff: int, order=(2, 0), window: int = 100) -> list[dict]:
    """Build the segmenter's window contract from ``fit_arma`` directly."""
    z = np.diff(x, n=diff)
    out = []
    for s, e in split_windows(z.size, window):
        seg = z[s:e]
        f = fit_arma(seg, *order)
        y = seg[f.start:]
        out.append({"start": s + diff, "stop": e + diff, "series": seg, "resid": f.resid[0], "order": order,
                    "diff": diff, "r2": float(1 - np.sum(f.resid[0] ** 2) / np.sum((y - y.mean()) ** 2))})
    return out


def test_plot_arma_diagnostics_writes_png(tmp_path):
    from mocapkit.plot import plot_arma_diagnostics

    limbs = [window_dicts(integrated_twice(0.5, 520, 1), 2), window_dicts(np.cumsum(ar1(0.8, 420, 2)), 1, (1, 1))]
    out = plot_arma_diagnostics(limbs, ["leg", "arm"], tmp_path / "d.png", title="test", per_limb=2)
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    all_png = plot_arma_diagnostics(limbs, ["leg", "arm"], tmp_path / "all.png", per_limb=None)
    # every window drawn: the figure grows with the number of detail rows (9 vs 4)
    from PIL import Image

    h2 = Image.open(out).size[1]
    h_all = Image.open(all_png).size[1]
    assert h_all > h2 + 4 * 100


def test_plot_arma_diagnostics_refuses_bad_input(tmp_path):
    from mocapkit.plot import plot_arma_diagnostics

    limbs = [window_dicts(integrated_twice(0.5, 320, 3), 2)]
    with pytest.raises(OSError):
        plot_arma_diagnostics(limbs, ["leg"], tmp_path / "missing" / "d.png")
    with pytest.raises(OSError):
        plot_arma_diagnostics(limbs, ["leg"], tmp_path)  # a folder
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InvalidParameterError, match="names"):
        plot_arma_diagnostics(limbs, ["leg", "arm"], tmp_path / "d.png")
    bad = [dict(limbs[0][0])]
    del bad[0]["resid"]
    with pytest.raises(InvalidParameterError, match="limb 0, window 0"):
        plot_arma_diagnostics([bad], ["leg"], tmp_path / "d.png")
    bad = [dict(limbs[0][0], series=np.r_[limbs[0][0]["series"], np.nan])]
    with pytest.raises(InvalidParameterError, match="NaN"):
        plot_arma_diagnostics([bad], ["leg"], tmp_path / "d.png")
    with pytest.raises(InvalidParameterError, match="per_limb"):
        plot_arma_diagnostics(limbs, ["leg"], tmp_path / "d.png", per_limb=0)
    assert not (tmp_path / "d.png").exists()
