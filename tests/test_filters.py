"""Piecewise polynomial filtering: the iterative algorithm, the exact optimum, the CLI, real data."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from cli_run import completed
from mocapkit.errors import InvalidParameterError
from mocapkit.evaluation.filtering import evaluate_synthetic, knot_f1, synthetic_signal
from mocapkit.filters.additive import solve_additive
from mocapkit.filters.api import fit, split_at_gaps
from mocapkit.filters.chunks import build, chunk_ssr, fit_piece
from mocapkit.filters.exact import solve_exact, ssr_curve
from mocapkit.filters.ppa import fit_iterative


def brute_force(t, Y, order, K):
    """Every knot set (chunks of at least order+1 samples): the true optimum of sqrt(SSR) + K·N."""
    n = len(t)
    best = None
    for k in range(0, n // (order + 1)):
        for ks in itertools.combinations(range(order + 1, n - order), k):
            kn = [0, *ks, n]
            if any(b - a < order + 1 for a, b in zip(kn[:-1], kn[1:], strict=True)):
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
            if any(valid[a:b].sum() < order + 1 for a, b in zip(kn[:-1], kn[1:], strict=True)):
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
    _, hist = fit_iterative(t, y, int(rng.integers(0, 3)), float(rng.uniform(0.01, 0.5)),
                            init_chunk=int(rng.integers(3, 40)))
    assert len(hist) >= 4
    assert all(b <= a + 1e-12 for a, b in zip(hist[:-1], hist[1:], strict=True)), hist


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
        assert chunk_ssr(t, Y, 5, 33, order) == pytest.approx(
            sum(chunk_ssr(t, Y[:, [d]], 5, 33, order) for d in range(3)), rel=1e-12)
        res = sum(np.polynomial.Polynomial.fit(t[5:33], Y[5:33, d], order, full=True)[1][0].sum() for d in range(3))
        assert chunk_ssr(t, Y, 5, 33, order) == pytest.approx(float(res), rel=1e-9)


def test_ssr_curve_is_non_increasing_and_exact():
    rng = np.random.default_rng(3)
    t, Y = random_piecewise(rng, 12, 1)
    curve = ssr_curve(t, Y, 1, max_knots=4)
    assert all(b <= a + 1e-12 for a, b in zip(curve[:-1], curve[1:], strict=True))
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


def ar1(rng, n, rho, sd):
    """AR(1) noise of marginal standard deviation ``sd``."""
    e = rng.normal(0.0, sd * np.sqrt(1 - rho**2), n)
    x = np.empty(n)
    x[0] = rng.normal(0.0, sd)
    for i in range(1, n):
        x[i] = rho * x[i - 1] + e[i]
    return x


def juggle(cycles, rate=200.0, rho=0.8, sd=0.3, seed=0):
    """A juggled ball's height (mm): flights under g (0.6 s) and holds (0.3 s, +2v0/th), continuous in
    position (the knots are breaks of velocity and acceleration only), plus AR(1) noise."""
    tf, th = 0.6, 0.3
    v0 = 9810.0 * tf / 2
    ah = 2 * v0 / th
    nf, nh = int(round(tf * rate)), int(round(th * rate))
    ys, true = [], []
    for _ in range(cycles):
        tt = np.arange(nf) / rate
        ys.append(v0 * tt - 4905.0 * tt**2)
        true.append(sum(map(len, ys)))
        tt = np.arange(nh) / rate
        ys.append(-v0 * tt + ah / 2 * tt**2)
        true.append(sum(map(len, ys)))
    y = np.concatenate(ys)
    rng = np.random.default_rng(seed)
    e = np.empty(y.size)
    x = 0.0
    for i in range(y.size):
        x = rho * x + rng.normal(0, sd)
        e[i] = x
    return np.arange(y.size) / rate, y + e, np.array(true[:-1])


@pytest.mark.parametrize("seed", range(30))
def test_additive_solver_equals_brute_force(seed):
    rng = np.random.default_rng(900 + seed)
    n = int(rng.integers(5, 13))
    order = int(rng.integers(0, 3))
    D = int(rng.integers(1, 3))
    t, Y = random_piecewise(rng, n, D)
    if seed % 3 == 0:
        Y[rng.choice(n, 2, replace=False)] = np.nan
    lam = float(rng.uniform(0.01, 5.0))
    valid = ~np.isnan(Y).any(axis=1)
    # the shortest chunk allowed: order + 1 (default) or more valid samples (the automatic mode's order + 2)
    msize = order + 1 + seed % 3
    best = np.inf
    for k in range(n):
        for ks in itertools.combinations(range(1, n), k):
            kn = [0, *ks, n]
            if k and any(valid[a:b].sum() < msize for a, b in zip(kn[:-1], kn[1:], strict=True)):
                continue
            best = min(best, build(t, Y, kn, order, 0.0).ssr + lam * k)
    r = solve_additive(t, Y, order, lam, min_size=None if seed % 3 == 0 else msize)
    assert r.ssr + lam * r.n_knots == pytest.approx(best, rel=1e-9, abs=1e-12)
    assert all(valid[pc.i0:pc.i1].sum() >= min(msize, valid.sum()) for pc in r.pieces)


@pytest.mark.parametrize("seed", range(4))
def test_auto_recovers_known_knots_white_and_correlated_noise(seed):
    """Figure 2 signal with the report's uniform white noise and with AR(1) noise (ρ = 0.9): the
    automatic cost finds exactly the 3 true knots."""
    t, y, clean, true = synthetic_signal(n=600, noise=0.1, seed=seed)
    r = fit(t, y, 2)
    assert r.solver == "auto" and r.iterative_loss is None and r.knot_cost > 0
    assert r.n_knots == 3 and knot_f1(r.parts[0].knots[1:-1], true) == 1.0
    y2 = clean + ar1(np.random.default_rng(seed), 600, 0.9, 0.05)
    r2 = fit(t, y2, 2)
    assert r2.n_knots == 3 and knot_f1(r2.parts[0].knots[1:-1], true, margin=3) == 1.0
    # the old white-noise price of a knot (sigma-hat from 3rd differences) over-segments correlated noise
    from mocapkit.filters.penalty import noise_sigma

    K_white = noise_sigma(y2, 2) * (3 + 2 * np.log(600)) / np.sqrt(600)
    assert fit(t, y2, 2, K_white).n_knots > 10


@pytest.mark.parametrize("seed", range(3))
def test_auto_no_knot_on_noise_or_constant(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(2000) / 100.0
    assert fit(t, rng.normal(0, 1, 2000), 2).n_knots == 0
    assert fit(t, 5 + ar1(rng, 2000, 0.9, 1.0), 2).n_knots == 0
    assert fit(t[:300], np.full(300, 3.25), 2).n_knots == 0
    assert fit(t, np.c_[rng.normal(0, 1e-3, 2000), rng.normal(7, 1e-3, 2000)], 1).n_knots == 0


def test_auto_cost_does_not_grow_with_length():
    """The same juggling pattern over 6 and 12 cycles: the same knot cost λ, twice the knots, every
    true knot found; Eq. 2's equivalent K shrinks as 1/sqrt(n), which is why λ is used."""
    t1, y1, true1 = juggle(6)
    t2, y2, true2 = juggle(12)
    r1, r2 = fit(t1, y1, 2), fit(t2, y2, 2)
    assert r1.n_knots == len(true1) and r2.n_knots == len(true2)
    assert knot_f1(r1.parts[0].knots[1:-1], true1, margin=4) == 1.0
    assert knot_f1(r2.parts[0].knots[1:-1], true2, margin=4) == 1.0
    assert 0.8 < r2.knot_cost / r1.knot_cost < 1.25
    assert r2.penalty / r1.penalty == pytest.approx(np.sqrt(len(t1) / len(t2)), rel=0.1)
    acc = [2 * p.coeffs[2, 0] for p in r2.pieces[::2]]  # the flights
    assert np.median(acc) == pytest.approx(-9810.0, rel=0.01)
    # scale-free: the same signal in metres gets the same knots
    r3 = fit(t1, y1 * 1e-3, 2)
    assert np.array_equal(r3.parts[0].knots, r1.parts[0].knots)


def test_bad_parameters():
    t = np.arange(10) * 0.1
    with pytest.raises(InvalidParameterError):
        fit(t, np.ones(10), 2, -1.0)
    with pytest.raises(InvalidParameterError):
        fit(t, np.ones(10), 2, 1.0, solver="magic")
    with pytest.raises(InvalidParameterError):
        fit(t[::-1], np.ones(10), 2, 1.0)


def test_juggling_flights_fall_at_g(shared_data):
    """The report's K = 100 mm on the full take still works."""
    from mocapkit.evaluation.filtering import evaluate_juggling
    from mocapkit.io import load_markers

    m = load_markers(shared_data / "juggling" / "5-ball-juggling-qualisys-300hz.tsv")
    out = evaluate_juggling(m, ["unnamed_6", "unnamed_10"], penalty=100.0)
    assert out["n_flights"] >= 20
    assert abs(out["median_flight_acc"] + 9.81) < 0.05 * 9.81
    for rec in out["balls"].values():
        # the Butterworth-derived acceleration is not flat during the same flights
        assert np.median(rec["butterworth_flight_acc_std"]) > 0.5


def test_cli_filter_auto_on_juggling_take(shared_data):
    """``filter --auto`` on the full shared take (4,967 frames at 300 Hz): the five balls' flights fall
    within 5 % of g, the five base markers get no knot. ~1 min on one core."""
    from mocapkit.evaluation.filtering import flights, moving_markers
    from mocapkit.io import load_markers

    tsv = shared_data / "juggling" / "5-ball-juggling-qualisys-300hz.tsv"
    m = load_markers(tsv)
    moving, static = moving_markers(m)
    assert static == ["base_1", "base_2", "base_3", "base_4", "base_5"]
    assert set(moving) == {"unnamed_6", "unnamed_8", "unnamed_10", "unnamed_16", "unnamed_17"}
    sel = ",".join([f"{b}:z" for b in moving] + static)
    r = completed("filter", str(tsv), "--markers", sel, "--auto", "--json")
    assert r.returncode == 0, r.stderr
    recs = {rec["name"]: rec for rec in json.loads(r.stdout)}
    for b in static:
        assert recs[b]["n_knots"] == 0, recs[b]
    acc = []
    for b in moving:
        # flights as in evaluation.filtering.flights: concave pieces of at least 0.2 s
        acc += [2 * p["coeffs"][2] * 1e-3 for p in recs[f"{b}:z"]["pieces"]
                if p["coeffs"][2] < 0 and p["t1"] - p["t0"] >= 0.2]
        assert recs[f"{b}:z"]["knot_cost"] > 0
    res = fit(m.times, m.positions[:, m.labels.index("unnamed_6"), 2], 2)  # the library gives the same
    assert res.n_knots == recs["unnamed_6:z"]["n_knots"] and len(flights(res)) >= 10
    assert len(acc) >= 50
    assert abs(np.median(acc) + 9.81) < 0.05 * 9.81


def test_filter_eval_other_marker_names(tests_data, tmp_path, monkeypatch):
    """``filter-eval --juggling`` on a TSV whose markers have other names (the tests/data excerpt
    relabelled): moving markers detected by the rule, or named with --balls; clear errors."""
    import functools

    import mocapkit.evaluation.filtering as filtering

    # the runs share filter-eval's synthetic experiment (no input, the same result): computed once
    monkeypatch.setattr(filtering, "evaluate_synthetic", functools.cache(filtering.evaluate_synthetic))
    src = (tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv").read_text()
    lines = src.splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("MARKER_NAMES"))
    names = lines[i].split("\t")[1:]
    lines[i] = "\t".join(["MARKER_NAMES"] + [n.replace("base_", "Table") for n in names])
    hdr = next(k for k, ln in enumerate(lines) if ln.startswith("Frame\t"))
    lines[hdr] = lines[hdr].replace("base_", "Table")
    tsv = tmp_path / "other.tsv"
    tsv.write_text("\n".join(lines) + "\n")
    from mocapkit.io import load_markers

    labels = load_markers(tsv).labels
    assert "Table1" in labels and not any(lab.startswith("base") for lab in labels)
    run = ["filter-eval", "--juggling", str(tsv), "--sizes", ""]
    r = completed(*run, "--out", str(tmp_path / "a"))
    assert r.returncode == 0, r.stderr
    jug = json.loads((tmp_path / "a" / "juggling.json").read_text())
    assert set(jug["controls"]) == {f"Table{k}" for k in range(1, 6)}
    assert all(c["knots"] == 0 for c in jug["controls"].values())
    assert jug["balls"] and not any(b.startswith("Table") for b in jug["balls"])
    ball = next(iter(jug["balls"]))
    r = completed(*run, "--out", str(tmp_path / "b"), "--balls", ball, "--controls", "Table2")
    assert r.returncode == 0, r.stderr
    jug = json.loads((tmp_path / "b" / "juggling.json").read_text())
    assert list(jug["balls"]) == [ball] and list(jug["controls"]) == ["Table2"]
    r = completed(*run, "--out", str(tmp_path / "c"), "--balls", "unnamed_6,Ball9")
    assert r.returncode == 2 and "'Ball9'" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "c").exists()  # checked before any work


def test_cli_filter_json_and_csv(tests_data, tmp_path):
    tsv = tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"
    r = completed("filter", str(tsv), "--markers", "unnamed_6:z",
                  "--order", "2", "--penalty", "100", "--json", "-o", str(tmp_path / "f.csv"),
                  "--plot", str(tmp_path / "f.png"))
    assert r.returncode == 0, r.stderr
    (rec,) = json.loads(r.stdout)
    assert {"name", "loss", "n_knots", "pieces"} <= set(rec)
    assert rec["n_knots"] == len(rec["pieces"]) - 1
    p = rec["pieces"][0]
    # the polynomial is in (t - t0) seconds, lowest order first: evaluate it at t0 and compare with the CSV
    rows = np.loadtxt(tmp_path / "f.csv", delimiter=",", skiprows=1)
    assert rows[0, 1] == pytest.approx(p["coeffs"][0], rel=1e-9)
    assert (tmp_path / "f.png").stat().st_size > 10_000
    r = completed("filter", str(tsv), "--markers", "nope")
    assert r.returncode == 2 and "penalty" in r.stderr
    r = completed("filter", str(tsv), "--markers", "nope", "--auto")
    assert r.returncode == 2 and "nope" in r.stderr


def test_cli_filter_c3d_labels_with_colons(shared_data, tmp_path):
    c3d = shared_data / "c3d" / "Vicon.c3d"
    r = completed("filter", str(c3d), "--markers",
                  "Daphnee:ASISr,Daphnee:ASISr:z", "--auto", "--json")
    assert r.returncode == 0, r.stderr
    recs = json.loads(r.stdout)
    assert recs[0]["components"] == ["Daphnee:ASISr_x", "Daphnee:ASISr_y", "Daphnee:ASISr_z"]
    assert recs[1]["components"] == ["Daphnee:ASISr_z"]
    assert len(recs[0]["pieces"][0]["coeffs"]) == 3  # one polynomial per component, shared knots


def _levels(levels, n=300):
    """Noise-free thirds at the given levels (equal steps up, or a pulse): both knots gain exactly
    the same, so at the lower end λ0 of k = 0's range the 2-knot fit ties with no knot."""
    i = np.arange(n)
    return i / 100.0, np.asarray(levels, dtype=float)[np.minimum(3 * i // n, 2)]


@pytest.mark.filterwarnings("error")
def test_auto_noise_free_piecewise_parabola_gets_its_true_knots_without_warning():
    t = np.arange(300) / 100.0
    tau = t - np.floor(t)  # each piece in its own time origin
    coeffs = [(2.0, 3.0, -4.0), (-5.0, 0.5, 7.0), (1.0, -6.0, 2.5)]
    y = np.concatenate([c0 + c1 * tau[100 * j:100 * (j + 1)] + c2 * tau[100 * j:100 * (j + 1)] ** 2
                        for j, (c0, c1, c2) in enumerate(coeffs)])
    r = fit(t, y, 2)
    assert list(r.parts[0].knots) == [0, 100, 200, 300]
    np.testing.assert_allclose(r.evaluate(t)[:, 0], y, atol=1e-9)
    # pieces of exactly order + 1 samples are interpolated whatever the data: the automatic mode keeps
    # one residual degree of freedom per chunk, so it cannot tell them from noise and puts no knot;
    # an explicit K still can
    t6 = np.arange(6) / 100.0
    y6 = np.r_[np.polyval([3.0, -1.0, 2.0], t6[:3]), np.polyval([-2.0, 4.0, 1.0], t6[:3])]
    assert fit(t6, y6, 2).n_knots == 0
    assert list(fit(t6, y6, 2, 1e-3).parts[0].knots) == [0, 3, 6]
    # pieces of order + 2 samples (one residual degree of freedom each, exactly fitted): found
    t8 = np.arange(8) / 100.0
    y8 = np.r_[np.polyval([3.0, -1.0, 2.0], t8[:4]), np.polyval([-2.0, 4.0, 1.0], t8[:4])]
    assert list(fit(t8, y8, 2).parts[0].knots) == [0, 4, 8]


def _short_pieces(rng, length, pieces, D):
    """Noise-free piecewise parabola (mm-like scale), every piece in its own time origin."""
    tau = np.arange(length) / 100.0
    y = np.concatenate([np.stack([np.polyval(rng.normal(size=3) * [100.0, 10.0, 1.0], tau) for _ in range(D)], 1)
                        for _ in range(pieces)])
    return np.arange(length * pieces) / 100.0, y, list(range(0, length * pieces + 1, length))


@pytest.mark.parametrize("length,D,seed", [(5, 1, s) for s in range(4)] + [(5, 3, 0), (6, 1, 0), (12, 3, 0)])
def test_auto_noise_free_short_pieces_get_every_knot(length, D, seed):
    """Pieces of 5 samples: most 3rd differences straddle a knot, so σ̂ (and the search floor) is far
    above the true noise (0); the search goes on down to the residual of its finest fit and finds
    every knot."""
    t, y, true = _short_pieces(np.random.default_rng(50 + seed), length, 12, D)
    r = fit(t, y, 2)
    assert list(r.parts[0].knots) == true
    np.testing.assert_allclose(r.evaluate(t), y, atol=1e-6)


@pytest.mark.parametrize("seed", range(10))
def test_auto_six_noisy_samples_of_one_parabola_get_no_knot_in_1d_and_3d(seed):
    """Six samples (a marker seen for 20 ms): the only split is into two exactly interpolated
    parabolas of three samples (zero residual, so an unbounded significance), which the automatic
    mode must not take — in 1-D and 3-D alike. Also with 7 samples and with a NaN row."""
    rng = np.random.default_rng(seed)
    for n in (6, 7):
        t = np.arange(n) / 300.0
        clean = np.stack([np.polyval(rng.normal(0, [2000.0, 500.0, 100.0]), t) for _ in range(3)], 1)
        Y = clean + rng.normal(0, 0.5, (n, 3))
        for y in (Y, Y[:, 2], Y[:, :1]):
            r = fit(t, y, 2)
            assert r.n_knots == 0 and len(r.pieces) == 1 and r.loss > 0
    Y8 = np.vstack([Y, Y[-1:] + 1.0])
    Y8[3] = np.nan  # 7 valid samples: still no split into two chunks of 4
    assert fit(np.arange(8) / 300.0, Y8, 2).n_knots == 0


def test_auto_juggling_markers_seen_for_six_frames(shared_data):
    """unnamed_18 and unnamed_21 of the shared take have 6 valid samples each: no knot, 3-D and Z."""
    import mocapkit

    m = mocapkit.load(shared_data / "juggling" / "5-ball-juggling-qualisys-300hz.tsv")
    for name in ("unnamed_18", "unnamed_21"):
        P = m.positions[:, m.labels.index(name), :]
        assert int(np.isfinite(P).all(axis=1).sum()) == 6
        for y in (P, P[:, 2]):
            r = fit(m.times, y, 2)
            assert r.n_knots == 0 and r.loss > 0


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("levels,order", [((0, 1, 2), 2), ((0, 4, 0), 0)])
def test_auto_knot_count_at_lambda0_is_the_solutions_own(levels, order):
    """At λ0 the solver may return the 2-knot tie: its exact residual must not be taken for the
    residual of k = 0 (which then looked infinitely significant and won: no knot at all)."""
    from mocapkit.filters.penalty import choose_knot_cost

    t, y = _levels(levels)
    ch = choose_knot_cost([(t, y[:, None])], order)
    assert ch.n_knots == 2 and list(ch.solutions[0].knots) == [0, 100, 200, 300]
    lo, hi = ch.range
    assert lo < ch.knot_cost < hi and ch.significance > 1e12
    # the range is the 2-knot count's own: just inside either end the exact solver agrees
    assert solve_additive(t, y, order, hi * 0.999).n_knots == 2
    assert solve_additive(t, y, order, hi * 1.5).n_knots < 2
    assert fit(t, y, order).n_knots == 2
