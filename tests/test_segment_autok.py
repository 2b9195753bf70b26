"""The number of segments chosen without labels (segment/autok.py) and the paper's RI (metrics.ri_paper)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.segment.autok import AutoSegmenter, choose_k, cost_curve, slope_penalty, window_stats
from mocapkit.segment.cpdpenalty import rbf_kernel
from mocapkit.segment.metrics import f1_margin, ri_paper
from mocapkit.segment.synthetic import motion_like


def _seg_cost(z, s, e, cost, gamma):
    x = z[s:e]
    if cost == "l2":
        return float(((x - x.mean(0)) ** 2).sum())
    K = rbf_kernel(x, None, gamma)
    return float(np.trace(K) - K.sum() / (e - s))


@pytest.mark.parametrize("cost", ["rbf", "l2"])
def test_cost_curve_equals_brute_force_over_every_segmentation(cost):
    rng = np.random.default_rng(1)
    z = np.concatenate([rng.normal(0, 1, (9, 2)), rng.normal(3, 1, (8, 2))])
    n, ms, gamma = z.shape[0], 3, 0.3
    curve = cost_curve(z, ms, 3, cost, gamma)
    for k in range(4):
        best = np.inf
        for cuts in itertools.combinations(range(ms, n - ms + 1), k):
            b = (0, *cuts, n)
            if min(np.diff(b)) < ms:
                continue
            c = sum(_seg_cost(z, s, e, cost, gamma) for s, e in zip(b[:-1], b[1:], strict=True))
            if c < best - 1e-12:
                best = c
        assert curve.costs[k] == pytest.approx(best, rel=1e-10, abs=1e-10)
        got = curve.cuts(k)
        b = (0, *got.tolist(), n)
        assert sum(_seg_cost(z, s, e, cost, gamma) for s, e in zip(b[:-1], b[1:], strict=True)) == pytest.approx(
            best, abs=1e-10)


def test_cost_curve_cuts_equal_ruptures_kernelcpd():
    rpt = pytest.importorskip("ruptures")
    rng = np.random.default_rng(0)
    z = rng.normal(size=(240, 3)) + np.repeat(rng.normal(size=(4, 3)) * 2, 60, axis=0)
    gamma = 0.2
    curve = cost_curve(z, 10, 6, "rbf", gamma)
    algo = rpt.KernelCPD(kernel="rbf", min_size=10, params={"gamma": gamma}).fit(z)
    for k in range(1, 7):
        assert curve.cuts(k).tolist() == algo.predict(n_bkps=k)[:-1]


@pytest.mark.parametrize("n_changes", range(1, 9))
def test_the_number_of_changes_is_recovered_on_synthetic_signals(n_changes):
    """On signals the constants were not calibrated on (other seeds), k is right in most cases and the
    cuts are where the changes are (measured: 39 of 40 right over 1-8 changes; the miss is at 8
    changes, where real changes start to fall inside the range the noise gain is read from)."""
    right, f1 = 0, []
    for seed in range(5):
        x, cuts = motion_like(n_changes, seed=90_000 + 100 * n_changes + seed)
        seg = AutoSegmenter(downsample=1).fit(x)
        right += len(seg.cuts_) == n_changes
        f1.append(f1_margin(seg.cuts_, cuts, x.shape[0], 15).f1)
    assert right >= (4 if n_changes < 8 else 3), right
    assert np.mean(f1) >= 0.9


def test_no_change_gives_no_cut():
    found = [len(AutoSegmenter(downsample=1).fit(motion_like(0, seed=s)[0]).cuts_) for s in range(5)]
    assert sum(found) <= 1
    assert AutoSegmenter().fit(np.full((3000, 8), 5.0)).cuts_.size == 0


def test_choose_k_minimises_the_penalised_cost():
    costs = np.array([100.0, 60, 30, 27, 25, 23.5, 22, 20.6, 19.3, 18, 16.8, 15.6, 14.5])
    pen = slope_penalty(costs, 3.5, (0.25, 0.5))
    gains = -np.diff(costs)
    a, b = int(0.25 * gains.size), int(0.5 * gains.size)
    assert pen == pytest.approx(3.5 * np.median(gains[a:b]))
    assert slope_penalty(costs) == pytest.approx(4.0 * np.median(gains[int(0.3 * gains.size):int(0.6 * gains.size)]))
    k = choose_k(costs, 3.5, (0.25, 0.5))
    assert k == int(np.argmin(costs + pen * np.arange(costs.size))) == 2
    assert choose_k([5.0, 1.0]) == 0 and choose_k([5.0, 5.0]) == 0  # too few cuts to estimate the noise: none
    for bad in ([], [np.nan, 1.0], [[1.0, 2.0]]):
        with pytest.raises(InvalidParameterError):
            choose_k(bad)
    with pytest.raises(InvalidParameterError):
        choose_k(costs, c=0)


def test_window_stats_are_moving_mean_and_std():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(50, 2))
    w = window_stats(x, 5)
    for i in range(2, 48):
        np.testing.assert_allclose(w[i, :2], x[i - 2:i + 3].mean(0), atol=1e-12)
        np.testing.assert_allclose(w[i, 2:], x[i - 2:i + 3].std(0), atol=1e-9)


def _ri_authors(fs_all, true):
    """The loop of the authors' main.m, literally (1-based MATLAB turned into Python)."""
    acc = []
    for q in range(len(true)):
        c1 = [abs(true[q] - m) for m in fs_all]
        fs = fs_all[c1.index(min(c1))]
        den = true[q] if q == 0 else true[q] - true[q - 1]
        acc.append(1 - abs(fs - true[q]) / den)
    return float(np.mean(acc))


def test_ri_paper_is_the_authors_formula():
    assert ri_paper([100, 260], [100, 250], 400) == pytest.approx(np.mean([1.0, 1 - 10 / 150]))
    assert ri_paper([95], [100, 300], 400) == pytest.approx(np.mean([1 - 5 / 100, 1 - 205 / 200]))  # may go below 0
    assert ri_paper([90, 110], [100], 400) == pytest.approx(0.9)  # a tie: the earlier cut, as MATLAB's min
    assert ri_paper([], [100], 400) == 0.0
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = 2000
        true = sorted(rng.choice(np.arange(1, n), rng.integers(1, 8), replace=False).tolist())
        pred = sorted(rng.choice(np.arange(1, n), rng.integers(1, 15), replace=False).tolist())
        assert ri_paper(pred, true, n) == pytest.approx(_ri_authors(pred, true), abs=1e-12)
    with pytest.raises(InvalidParameterError):
        ri_paper([5], [], 10)


def test_ri_paper_rewards_over_segmentation():
    """Extra cuts cost nothing in Eq. 33 as computed: cutting everywhere scores 1."""
    true = [300, 900, 1400]
    assert ri_paper(list(range(1, 2000)), true, 2000) == 1.0
    assert ri_paper([310, 880, 1420], true, 2000) < 1.0


def test_auto_on_the_shared_takes_needs_no_labels(shared_data):
    from mocapkit.evaluation.segmentation import MOCAP_TAKES, load_take, make_segmenter, score

    f1 = []
    for name in MOCAP_TAKES:
        take = load_take(shared_data / "cmu", name)
        seg = make_segmenter("auto", take)
        f1.append(score(seg.fit_predict(take.partition), take.ref)["f1"])
    assert np.mean(f1) >= 0.75, f1


def test_cost_curve_over_candidates_equals_brute_force_over_their_subsets():
    rng = np.random.default_rng(4)
    z = np.concatenate([rng.normal(0, 1, (30, 2)), rng.normal(2, 1, (30, 2)), rng.normal(-1, 1, (30, 2))])
    cand = [12, 29, 33, 47, 61, 70, 75]
    curve = cost_curve(z, 5, 7, "l2", candidates=cand)
    for k in range(curve.k_max + 1):
        best = min(
            (sum(_seg_cost(z, s, e, "l2", None) for s, e in zip((0, *c), (*c, 90), strict=True)), c)
            for c in itertools.combinations(cand, k) if min(np.diff((0, *c, 90))) >= 5
        )
        assert curve.costs[k] == pytest.approx(best[0], abs=1e-9)
        assert tuple(curve.cuts(k).tolist()) == best[1]
    assert curve.k_max == 6  # all 7 would leave 29..33, shorter than 5 samples


def test_arma_select_auto_keeps_a_subset_of_its_candidates():
    from mocapkit.segment.arma import ARMASegmenter

    x, _ = motion_like(3, d=4, seed=11)
    seg = ARMASegmenter(downsample=1, select="auto")
    cuts = seg.fit_predict(x)
    pooled = ARMASegmenter(downsample=1).fit(x)
    candidates = set(pooled.ensemble([ch["cuts"] for ch in pooled.channels_], 1))
    assert set(cuts.tolist()) <= candidates


def test_bad_inputs_are_refused_with_a_clear_error():
    z = np.random.default_rng(0).normal(size=(100, 2))
    for cand in ([10.5, 20], [-3, 50], [50, 100], ["a"], [True]):  # never silently dropped or rounded
        with pytest.raises(InvalidParameterError, match="candidates"):
            cost_curve(z, 5, 3, candidates=cand)
    assert cost_curve(z, 5, 3, candidates=np.array([20, 60])).cuts(2).tolist() == [20, 60]
    with pytest.raises(InvalidParameterError, match="gamma"):
        cost_curve(z, 5, 3, gamma=-1.0)
    for kw in ({"c": "x"}, {"noise_range": (0.5,)}, {"noise_range": 0.5}, {"c": float("inf")}):
        with pytest.raises(InvalidParameterError):
            AutoSegmenter(**kw)


def test_a_long_take_is_thinned_to_max_points_and_keeps_its_cuts():
    """Beyond max_points samples the DP sees fewer samples (bounded memory); the cuts stay where they were."""
    x, cuts = motion_like(4, seed=77)
    x4 = np.repeat(x, 4, axis=0)  # the same take at 4x the rate: 4x the samples
    seg = AutoSegmenter(downsample=1, max_points=x.shape[0])
    found = seg.fit_predict(x4)
    assert seg.step_ == 4
    assert f1_margin(found, cuts * 4, x4.shape[0], 60).f1 == 1.0


def test_a_short_take_gets_no_spurious_cut():
    for seed in range(5):
        x, _ = motion_like(0, min_len_s=3.0, max_len_s=4.5, seed=500 + seed)
        assert AutoSegmenter(downsample=1).fit(x).cuts_.size == 0
