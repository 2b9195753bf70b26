"""Piecewise polynomial filtering: the iterative algorithm, the exact optimum, the CLI, real data."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.filters.api import auto_penalty, fit, split_at_gaps
from mocapkit.filters.chunks import build, chunk_ssr, fit_piece
from mocapkit.filters.exact import solve_exact, ssr_curve
from mocapkit.filters.ppa import fit_iterative
from mocapkit.evaluation.filtering import evaluate_synthetic, flights, knot_f1, synthetic_signal


def brute_force(t, Y, order, K):
    """Every knot set (chunks of at least order+1 samples): the true optimum of sqrt(SSR) + K·N."""
    n = len(t)
    best = None
    for k in range(0, n // (order + 1)):
        for ks in itertools.combinations(range(order + 1, n - order), k):
            kn = [0, *ks, n]
            if any(b - a < order + 1 for a, b in zip(kn[:-1], kn[1:])):
                continue
            pp = build(t, Y, kn, order, K)
            if best is None or pp.loss < best.loss - 1e-12:
                best = pp
    return best


def random_piecewise(rng, n, D=1):
    t = np.cumsum(rng.uniform(0.5, 1.5, n)) * 0.01
    cut = int(rng.integers(2, n - 2))
    y = np.where(np.arange(n)[:, None] < cut, 0.0, rng.normal(0, 2, D)) + rng.normal(0, 0.3, (n, D))
    return t, y + 5 * t[:, None] ** 2


@pytest.mark.parametrize("seed", range(25))
def test_exact_equals_brute_force_and_beats_iterative(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 15))
    order = int(rng.integers(0, 3))
    D = int(rng.integers(1, 3))
    t, Y = random_piecewise(rng, n, D)
    K = float(rng.uniform(0.02, 1.5))
    bf = brute_force(t, Y, order, K)
    ex = solve_exact(t, Y, order, K)
    assert ex.loss == pytest.approx(bf.loss, abs=1e-9)
    it, _ = fit_iterative(t, Y, order, K, init_chunk=order + 1)
    assert ex.loss <= it.loss + 1e-9
    ex2 = solve_exact(t, Y, order, K, incumbent=it)  # seeding with the iterative result changes nothing
    assert ex2.loss == pytest.approx(bf.loss, abs=1e-9)
    ex3 = solve_exact(t, Y, order, K, incumbent=bf)  # the tightest incumbent: pruning at equality
    assert ex3.loss == pytest.approx(bf.loss, abs=1e-9)


@pytest.mark.parametrize("seed", range(12))
def test_exact_with_nan_rows_equals_brute_force(seed):
    rng = np.random.default_rng(500 + seed)
    n = int(rng.integers(7, 14))
    t, Y = random_piecewise(rng, n, 1)
    Y[rng.choice(n, 2, replace=False)] = np.nan
    K = float(rng.uniform(0.05, 1.0))
    order = int(rng.integers(0, 2))
    # brute force over knot sets whose chunks hold >= order+1 valid samples
    valid = ~np.isnan(Y[:, 0])
    best = None
    for k in range(0, n):
        for ks in itertools.combinations(range(1, n), k):
            kn = [0, *ks, n]
            if any(valid[a:b].sum() < order + 1 for a, b in zip(kn[:-1], kn[1:])):
                continue
            pp = build(t, Y, kn, order, K)
            if best is None or pp.loss < best.loss - 1e-12:
                best = pp
    ex = solve_exact(t, Y, order, K)
    assert ex.loss == pytest.approx(best.loss, abs=1e-9)


@pytest.mark.parametrize("seed", range(10))
def test_iterative_loss_never_increases(seed):
    rng = np.random.default_rng(100 + seed)
    t, y, _, _ = synthetic_signal(n=240, noise=0.1, seed=seed)
    y = y + rng.normal(0, 0.05, y.shape)
    _, hist = fit_iterative(t, y, int(rng.integers(0, 3)), float(rng.uniform(0.01, 0.5)), init_chunk=int(rng.integers(3, 40)))
    assert len(hist) >= 4
    assert all(b <= a + 1e-12 for a, b in zip(hist[:-1], hist[1:])), hist


def test_chunk_fit_equals_numpy_polynomial():
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(3.0, 4.0, 40))
    Y = np.c_[np.sin(5 * t), t**3, rng.normal(size=40)]
    for order in (0, 1, 2, 3):
        p = fit_piece(t, Y, 5, 33, order)
        for d in range(3):
            ref = np.polynomial.Polynomial.fit(t[5:33] - t[5], Y[5:33, d], order).convert().coef
            assert np.allclose(p.coeffs[: len(ref), d], ref, rtol=1e-8, atol=1e-10)
        # shared-knot vector cost = sum of the per-component costs
        assert chunk_ssr(t, Y, 5, 33, order) == pytest.approx(sum(chunk_ssr(t, Y[:, [d]], 5, 33, order) for d in range(3)), rel=1e-12)
        res = sum(np.polynomial.Polynomial.fit(t[5:33], Y[5:33, d], order, full=True)[1][0].sum() for d in range(3))
        assert chunk_ssr(t, Y, 5, 33, order) == pytest.approx(float(res), rel=1e-9)


def test_ssr_curve_is_non_increasing_and_exact():
    rng = np.random.default_rng(3)
    t, Y = random_piecewise(rng, 12, 1)
    curve = ssr_curve(t, Y, 1, max_knots=4)
    assert all(b <= a + 1e-12 for a, b in zip(curve[:-1], curve[1:]))
    best2 = min(build(t, Y, [0, a, b, 12], 1, 0).ssr for a, b in itertools.combinations(range(2, 11), 2) if b - a >= 2)
    assert curve[2] == pytest.approx(best2, rel=1e-9)


def test_real_timestamps_recover_a_parabola_in_seconds():
    rng = np.random.default_rng(0)
    t = 100.0 + np.cumsum(rng.uniform(0.001, 0.01, 200))  # irregular, far from 0
    y = 3.0 - 2.0 * (t - t[0]) - 4.905 * (t - t[0]) ** 2
    r = fit(t, y, 2, 1e-6, "exact")
    assert r.n_knots == 0
    assert np.allclose(r.pieces[0].coeffs[:, 0], [3.0, -2.0, -4.905], rtol=1e-7, atol=1e-7)
    assert np.allclose(r.evaluate(t, derivative=2)[:, 0], -9.81)


def test_nan_samples_and_long_gaps():
    t, y, clean, _ = synthetic_signal(n=400, noise=0.05, seed=1)
    y = y.copy()
    y[37] = np.nan  # a short gap: left out of the fit, not bridged
    r = fit(t, y, 2, 0.05)
    keep = np.isfinite(y)
    r2 = fit(t[keep], y[keep], 2, 0.05)
    assert r.loss == pytest.approx(r2.loss, rel=1e-9)
    y[200:260] = np.nan  # a long gap: two independent parts, nothing drawn across it
    parts = split_at_gaps(t, y[:, None], max_gap=0.1)
    assert len(parts) == 2 and parts[0][1] == 200 and parts[1][0] == 260
    r3 = fit(t, y, 2, 0.05, max_gap=0.1)
    assert len(r3.parts) == 2
    assert np.isnan(r3.evaluate(t[[230]])).all()
    # a part too short to fit is reported, never dropped silently
    y[262:300] = np.nan
    r4 = fit(t, y, 2, 0.05, max_gap=0.1)
    assert r4.unfitted == ((float(t[260]), float(t[261])),)


def test_synthetic_breakpoints_exact_within_two_samples():
    """The seed's Figure 2 signal at its noise level: the exact solver finds the true knots."""
    out = evaluate_synthetic(penalty=None, seeds=range(6), noise=0.1)
    for row in out["rows"]:
        assert row["exact_f1"] == 1.0, row["exact_knots"]
        # and the piecewise fit beats both smoothers on RMSE and on overshoot at the step
        assert row["exact_rmse"] < 0.5 * min(row["butterworth_rmse"], row["spline_rmse"])
        assert row["exact_overshoot"] < row["butterworth_overshoot"]


def test_knot_f1():
    assert knot_f1(np.array([10, 50]), np.array([11, 49])) == 1.0
    assert knot_f1(np.array([10, 50]), np.array([13, 49])) == pytest.approx(0.5)
    assert knot_f1(np.array([10, 11]), np.array([10])) == pytest.approx(2 / 3)


def test_auto_penalty_scales_with_noise():
    t, y, _, _ = synthetic_signal(n=600, noise=0.1, seed=0)
    t2, y2, _, _ = synthetic_signal(n=600, noise=0.2, seed=0)
    k1, k2 = auto_penalty(y, 2), auto_penalty(y2, 2)
    assert 1.6 < k2 / k1 < 2.4


def test_bad_parameters():
    t = np.arange(10) * 0.1
    with pytest.raises(InvalidParameterError):
        fit(t, np.ones(10), 2, -1.0)
    with pytest.raises(InvalidParameterError):
        fit(t, np.ones(10), 2, 1.0, solver="magic")
    with pytest.raises(InvalidParameterError):
        fit(t[::-1], np.ones(10), 2, 1.0)


def test_juggling_flights_fall_at_g(shared_data):
    from mocapkit.evaluation.filtering import evaluate_juggling
    from mocapkit.markers import load_markers

    m = load_markers(shared_data / "juggling" / "5-ball-juggling-qualisys-300hz.tsv")
    out = evaluate_juggling(m, ["unnamed_6", "unnamed_10"], penalty=100.0)
    assert out["n_flights"] >= 20
    assert abs(out["median_flight_acc"] + 9.81) < 0.05 * 9.81
    for rec in out["balls"].values():
        # the Butterworth-derived acceleration is not flat during the same flights
        assert np.median(rec["butterworth_flight_acc_std"]) > 0.5


def test_cli_filter_json_and_csv(tests_data, tmp_path):
    tsv = tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "filter", str(tsv), "--markers", "unnamed_6:z",
                        "--order", "2", "--penalty", "100", "--json", "-o", str(tmp_path / "f.csv"),
                        "--plot", str(tmp_path / "f.png")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    (rec,) = json.loads(r.stdout)
    assert {"name", "loss", "n_knots", "pieces"} <= set(rec)
    assert rec["n_knots"] == len(rec["pieces"]) - 1
    p = rec["pieces"][0]
    # the polynomial is in (t - t0) seconds, lowest order first: evaluate it at t0 and compare with the CSV
    rows = np.loadtxt(tmp_path / "f.csv", delimiter=",", skiprows=1)
    assert rows[0, 1] == pytest.approx(p["coeffs"][0], rel=1e-9)
    assert (tmp_path / "f.png").stat().st_size > 10_000
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "filter", str(tsv), "--markers", "nope"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "penalty" in r.stderr
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "filter", str(tsv), "--markers", "nope", "--auto"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "nope" in r.stderr


def test_cli_filter_c3d_labels_with_colons(shared_data, tmp_path):
    c3d = shared_data / "c3d" / "Vicon.c3d"
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "filter", str(c3d), "--markers",
                        "Daphnee:ASISr,Daphnee:ASISr:z", "--auto", "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    recs = json.loads(r.stdout)
    assert recs[0]["components"] == ["Daphnee:ASISr_x", "Daphnee:ASISr_y", "Daphnee:ASISr_z"]
    assert recs[1]["components"] == ["Daphnee:ASISr_z"]
    assert len(recs[0]["pieces"][0]["coeffs"]) == 3  # one polynomial per component, shared knots
