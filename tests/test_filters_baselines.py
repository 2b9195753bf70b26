"""Baselines of issue 5 (item 4): zero-phase Butterworth, Winter's cut-off, smoothing spline."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal
from scipy.interpolate import _bsplines, make_smoothing_spline

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.filters.butterworth import (
    butterworth_filtfilt,
    corrected_cutoff,
    smoothing_spline,
    step_overshoot,
    winter_residual_cutoff,
)

FS = 300.0


def _amplitude(x: np.ndarray) -> float:
    """Half the peak-to-peak of the central half of ``x`` (away from the filter's end effects)."""
    n = len(x)
    mid = x[n // 4 : 3 * n // 4]
    return 0.5 * float(mid.max() - mid.min())


# --------------------------------------------------------------------------------------------------
# the two-pass cut-off correction
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("order", [1, 2, 3, 4])
@pytest.mark.parametrize("fc, fs", [(6.0, 300.0), (10.0, 100.0), (30.0, 100.0), (0.5, 1000.0)])
def test_corrected_cutoff_puts_cascade_at_minus_3db(order, fc, fs):
    fd = corrected_cutoff(fc, fs, order=order, passes=2)
    assert fc < fd < fs / 2
    sos = signal.butter(order, fd, fs=fs, output="sos")
    _, h = signal.sosfreqz(sos, worN=[fc], fs=fs)
    forward_backward = abs(h[0]) ** 2  # |H|^2: a forward and a backward pass
    assert forward_backward == pytest.approx(1 / np.sqrt(2), abs=1e-6)


def test_correction_acts_on_warped_frequency_not_on_fc():
    """At fc/fs = 0.3 the low-frequency approximation fc/0.802 is visibly wrong; ours is exact."""
    fc, fs, order = 30.0, 100.0, 2
    naive = fc / (np.sqrt(2) - 1) ** 0.25  # Winter's C = 0.802 applied to fc directly
    sos = signal.butter(order, naive, fs=fs, output="sos")
    _, h = signal.sosfreqz(sos, worN=[fc], fs=fs)
    assert abs(abs(h[0]) ** 2 - 1 / np.sqrt(2)) > 0.02
    fd = corrected_cutoff(fc, fs, order)
    expected = fs / np.pi * np.arctan(np.tan(np.pi * fc / fs) / (np.sqrt(2) - 1) ** 0.25)
    assert fd == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("passes", [1, 3, 4])
def test_corrected_cutoff_other_pass_counts(passes):
    fc, fs, order = 8.0, 200.0, 3
    fd = corrected_cutoff(fc, fs, order=order, passes=passes)
    if passes == 1:
        assert fd == pytest.approx(fc, rel=1e-14)
    _, h = signal.sosfreqz(signal.butter(order, fd, fs=fs, output="sos"), worN=[fc], fs=fs)
    assert abs(h[0]) ** passes == pytest.approx(1 / np.sqrt(2), abs=1e-6)


def test_filtfilt_sine_at_cutoff_is_at_minus_3db():
    """End to end through sosfiltfilt: a sine at fc comes out at 1/sqrt(2) of its amplitude."""
    t = np.arange(6000) / FS
    fc = 7.0
    y = np.sin(2 * np.pi * fc * t)
    for order in (1, 2, 4):
        amp = _amplitude(butterworth_filtfilt(y, FS, fc, order=order))
        assert amp == pytest.approx(1 / np.sqrt(2), abs=2e-3)
    # uncorrected: each pass at fc, so the cascade is at -6 dB there
    uncorrected = butterworth_filtfilt(y, FS, fc, correct=False)
    assert _amplitude(uncorrected) == pytest.approx(0.5, abs=2e-3)


# --------------------------------------------------------------------------------------------------
# butterworth_filtfilt
# --------------------------------------------------------------------------------------------------


def test_filtfilt_passes_low_and_stops_high_frequencies():
    t = np.arange(3000) / FS
    low = np.sin(2 * np.pi * 2.0 * t)
    high = np.sin(2 * np.pi * 60.0 * t)
    assert _amplitude(butterworth_filtfilt(low, FS, 10.0)) == pytest.approx(1.0, rel=0.01)
    assert _amplitude(butterworth_filtfilt(high, FS, 10.0)) < 0.01


def test_filtfilt_is_zero_phase():
    t = np.arange(3000) / FS
    y = np.sin(2 * np.pi * 3.0 * t + 0.4)
    window = slice(1400, 1500)  # one 100-sample period in the middle
    peak = int(np.argmax(y[window]))
    yf = butterworth_filtfilt(y, FS, 10.0, order=4)
    assert int(np.argmax(yf[window])) == peak
    # a single causal pass of the same filter does lag (the check can fail)
    causal = signal.sosfilt(signal.butter(4, 10.0, fs=FS, output="sos"), y)
    assert int(np.argmax(causal[window])) != peak


def test_filtfilt_vector_signal_filters_columns_independently():
    rng = np.random.default_rng(3)
    y = rng.standard_normal((500, 3)).cumsum(axis=0)
    out = butterworth_filtfilt(y, FS, 6.0)
    assert out.shape == y.shape
    for j in range(3):
        np.testing.assert_array_equal(out[:, j], butterworth_filtfilt(y[:, j], FS, 6.0))


# --------------------------------------------------------------------------------------------------
# Winter's residual analysis
# --------------------------------------------------------------------------------------------------


def _synthetic(seed: int, sigma: float, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) / FS
    clean = (
        0.5 * np.sin(2 * np.pi * 1.0 * t)
        + 0.3 * np.sin(2 * np.pi * 2.7 * t + 1.0)
        + 0.15 * np.sin(2 * np.pi * 5.5 * t + 0.3)
    )
    noise = sigma * np.random.default_rng(seed).standard_normal(n)
    return clean, noise


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_winter_cutoff_and_noise_level(seed):
    clean, noise = _synthetic(seed, sigma=0.02)
    fc, info = winter_residual_cutoff(clean + noise, FS)
    assert 5.0 <= fc <= 12.0
    assert info["bracketed"]
    noise_rms = float(np.sqrt(np.mean(noise**2)))
    assert info["intercept"] == pytest.approx(noise_rms, rel=0.30)
    assert info["slope"] < 0
    # default grid and fit-range rule (upper third of 0.5..30 Hz)
    grid = info["fc_grid"]
    assert grid[0] == 0.5 and grid[-1] == pytest.approx(30.0) and np.allclose(np.diff(grid), 0.25)
    lo, hi = info["fit_range"]
    assert lo >= 0.5 + 2 / 3 * 29.5 - 1e-9 and hi == pytest.approx(30.0)
    # fc is where the residual curve meets the intercept
    r_at_fc = np.interp(fc, grid, info["residuals"])
    assert r_at_fc == pytest.approx(info["intercept"], rel=1e-6)


def test_winter_more_noise_lowers_cutoff():
    clean, noise = _synthetic(7, sigma=1.0)
    fc_small, _ = winter_residual_cutoff(clean + 0.005 * noise, FS)
    fc_large, _ = winter_residual_cutoff(clean + 0.05 * noise, FS)
    assert fc_large < fc_small


def test_winter_vector_is_per_component():
    clean, noise = _synthetic(4, sigma=1.0)
    y = np.column_stack([clean + 0.01 * noise, clean + 0.04 * noise[::-1]])
    fc, info = winter_residual_cutoff(y, FS)
    assert fc.shape == (2,) and info["intercept"].shape == (2,)
    assert info["residuals"].shape == (info["fc_grid"].size, 2)
    for j in range(2):
        fj, ij = winter_residual_cutoff(y[:, j], FS)
        assert fc[j] == pytest.approx(fj, rel=1e-12)
        assert info["intercept"][j] == pytest.approx(ij["intercept"], rel=1e-12)


def test_winter_explicit_fit_range():
    clean, noise = _synthetic(5, sigma=0.02)
    _, info = winter_residual_cutoff(clean + noise, FS, fit_range=(15.0, 25.0))
    assert info["fit_range"] == (15.0, 25.0)
    with pytest.raises(InvalidParameterError, match="at least 3"):
        winter_residual_cutoff(clean + noise, FS, fit_range=(15.0, 15.3))


# --------------------------------------------------------------------------------------------------
# overshoot at a step (seed report, Fig. 1)
# --------------------------------------------------------------------------------------------------


def _step(n: int = 900) -> np.ndarray:
    y = np.zeros(n)
    y[n // 2 :] = 1.0
    return y


def test_filtfilt_overshoots_at_step_fig1():
    step = _step()
    ov = {order: step_overshoot(butterworth_filtfilt(step, FS, 5.0, order=order), step)
          for order in (1, 2, 4)}
    # order 1 forward-backward has a positive impulse response: monotone step response
    assert ov[1] < 1e-9
    assert ov[2] > 0.01
    # Fig. 1: fourth-order Butterworth, forward and reverse, overshoots; measured: 0.0682
    assert ov[4] > ov[2]
    assert ov[4] == pytest.approx(0.0682, abs=0.002)


def test_smoothing_spline_overshoots_at_step():
    step = _step()
    t = np.arange(step.size) / FS
    for lam in (1e-7, 1e-5):
        ys, used = smoothing_spline(t, step, lam=lam)
        assert used == lam
        ov = step_overshoot(ys, step)
        assert ov > 0.01  # Gibbs-like ringing; measured ~0.034 (like order-2 filtfilt)


def test_step_overshoot_definition():
    step = _step(10)
    assert step_overshoot(step, step) == 0.0
    y = step.copy()
    y[7] = 1.25
    y[2] = -0.1
    assert step_overshoot(y, step) == pytest.approx(0.25)
    assert step_overshoot(-y, -step) == pytest.approx(0.25)  # falling step
    assert step_overshoot(2 * y, 2 * step) == pytest.approx(0.25)  # relative to the step height


# --------------------------------------------------------------------------------------------------
# smoothing spline
# --------------------------------------------------------------------------------------------------


def test_smoothing_spline_gcv_equals_scipy():
    rng = np.random.default_rng(11)
    t = np.sort(rng.uniform(0, 3, 200))  # irregular timestamps
    t = np.unique(t)
    y = np.sin(2 * np.pi * 0.8 * t) + 0.05 * rng.standard_normal(t.size)
    original = _bsplines._compute_optimal_gcv_parameter
    ys, lam = smoothing_spline(t, y)
    assert _bsplines._compute_optimal_gcv_parameter is original  # the wrapper is removed
    np.testing.assert_array_equal(ys, make_smoothing_spline(t, y)(t))
    assert np.isfinite(lam) and lam > 0
    # lam_used is the GCV parameter SciPy used: refitting with it reproduces the spline
    np.testing.assert_allclose(make_smoothing_spline(t, y, lam=lam)(t), ys, rtol=0, atol=1e-12)


def test_smoothing_spline_vector_per_column():
    rng = np.random.default_rng(12)
    t = np.arange(150) / 50.0
    y = np.column_stack([np.cos(t), t**2]) + 0.02 * rng.standard_normal((150, 2))
    ys, lams = smoothing_spline(t, y)
    assert ys.shape == y.shape and lams.shape == (2,)
    for j in range(2):
        yj, lj = smoothing_spline(t, y[:, j])
        np.testing.assert_array_equal(ys[:, j], yj)
        assert lams[j] == lj


# --------------------------------------------------------------------------------------------------
# bad inputs
# --------------------------------------------------------------------------------------------------


def test_cutoff_at_or_above_nyquist_is_refused():
    with pytest.raises(InvalidParameterError, match="Nyquist"):
        corrected_cutoff(150.0, 300.0)
    with pytest.raises(InvalidParameterError, match="Nyquist"):
        butterworth_filtfilt(np.zeros(100), 300.0, 200.0)
    with pytest.raises(InvalidParameterError, match="Nyquist"):
        butterworth_filtfilt(np.zeros(100), 300.0, 150.0, correct=False)
    with pytest.raises(InvalidParameterError, match="fc must be finite and > 0"):
        corrected_cutoff(0.0, 300.0)
    with pytest.raises(InvalidParameterError, match="order"):
        corrected_cutoff(5.0, 300.0, order=0)
    with pytest.raises(InvalidParameterError, match="fc_grid"):
        winter_residual_cutoff(np.zeros(500), 300.0, fc_grid=np.linspace(1, 150, 20))


def test_nan_is_refused_naming_first_index():
    y = np.sin(np.arange(200) / 10.0)
    y[17] = np.nan
    y[40] = np.nan
    msg = r"NaN at sample 17 \(first one\).*split the signal"
    with pytest.raises(InvalidSignalError, match=msg):
        butterworth_filtfilt(y, FS, 10.0)
    with pytest.raises(InvalidSignalError, match="NaN at sample 17"):
        winter_residual_cutoff(y, FS)
    with pytest.raises(InvalidSignalError, match="NaN at sample 17"):
        smoothing_spline(np.arange(200) / FS, y)
    y2 = np.zeros((50, 3))
    y2[9, 2] = np.nan
    with pytest.raises(InvalidSignalError, match="sample 9, column 2"):
        butterworth_filtfilt(y2, FS, 10.0)


def test_other_bad_signals():
    with pytest.raises(InvalidSignalError, match="needs more than"):
        butterworth_filtfilt(np.zeros(8), FS, 10.0)
    with pytest.raises(InvalidSignalError, match="shape"):
        butterworth_filtfilt(np.zeros((4, 4, 4)), FS, 10.0)
    with pytest.raises(InvalidSignalError, match="strictly increasing"):
        smoothing_spline([0.0, 1.0, 1.0, 2.0, 3.0], np.zeros(5))
    with pytest.raises(InvalidParameterError, match="lam"):
        smoothing_spline(np.arange(10.0), np.zeros(10), lam=-1.0)
    with pytest.raises(InvalidSignalError, match="constant"):
        step_overshoot(np.zeros(5), np.ones(5))
