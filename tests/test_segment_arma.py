"""Limb-angle features and the ARMA segmenter, each against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.segment.arma import ARMASegmenter, adf_critical_value, adf_statistic, fit_arma, predict_one_step
from mocapkit.segment.features import (
    LIMB_NAMES,
    bone_angles,
    limb_angles,
    motion_features,
    pose_features,
    resolve_joint_map,
)
from mocapkit.skeleton import Motion, Skeleton

#: The fitness-SD reading (the segmenter's default before the authors' code was followed): second
#: differences everywhere, the smallest order within 1 % of the best F, the cut at the minimum SD.
SD_READING = dict(differencing="fixed", order="parsimonious", cut="min_sd", p_range=(1, 2, 3, 4), q_range=(0, 1, 2))

# ---------------------------------------------------------------------------------------------
# features on a hand-built skeleton with known angles

NAMES = ("Hips", "Neck", "RightUpLeg", "RightLeg", "RightFoot", "LeftUpLeg", "LeftLeg", "LeftFoot",
         "RightArm", "RightForeArm", "RightHand", "LeftArm", "LeftForeArm", "LeftHand")
PARENTS = (-1, 0, 0, 2, 3, 0, 5, 6, 1, 8, 9, 1, 11, 12)
OFFSETS = ((0, 0, 0), (0, 50, 0), (-10, 0, 0), (0, -40, 0), (0, -40, 0), (10, 0, 0), (0, -42, 0), (0, -38, 0),
           (-15, 0, 0), (-30, 0, 0), (-25, 0, 0), (15, 0, 0), (30, 0, 0), (25, 0, 0))


def _hand_built(n=40, seed=0):
    """Legs bend in the body's x-y plane about z, arms too; the root turns and moves at random.

    Right thigh: rotated by φ about z → its angle to the spine (up) is 180° − φ; the knee adds ψ:
    shin at 180° − φ − ψ. Right upper arm (pointing −x) rotated by α about z → 90° + α; the elbow
    adds β → 90° + α + β. Left side mirrored: rotations by −φ' etc. give the same formulas.
    """
    rng = np.random.default_rng(seed)
    J = len(NAMES)
    sk = Skeleton(NAMES, np.array(PARENTS), np.array(OFFSETS, float), tuple(() for _ in NAMES))
    phi, psi = rng.uniform(0, 80, n), rng.uniform(0, 80, n)
    phl, psl = rng.uniform(0, 80, n), rng.uniform(0, 80, n)
    alpha, beta = rng.uniform(-60, 40, n), rng.uniform(0, 45, n)
    alpl, betl = rng.uniform(-60, 40, n), rng.uniform(0, 45, n)
    rot = np.zeros((n, J, 4))
    rot[..., 0] = 1
    rot[:, 0] = Rotation.random(n, random_state=seed).as_quat(scalar_first=True)

    def rz(deg):
        return Rotation.from_euler("z", deg, degrees=True).as_quat(scalar_first=True)

    rot[:, 2], rot[:, 3] = rz(phi), rz(psi)
    rot[:, 5], rot[:, 6] = rz(-phl), rz(-psl)
    rot[:, 8], rot[:, 9] = rz(alpha), rz(beta)
    rot[:, 11], rot[:, 12] = rz(-alpl), rz(-betl)
    tr = np.broadcast_to(np.array(OFFSETS, float), (n, J, 3)).copy()
    tr[:, 0] = rng.normal(0, 100, (n, 3))
    motion = Motion(sk, np.arange(n) / 100.0, rot, tr)
    expected = np.stack([180 - phi, 180 - phi - psi, 180 - phl, 180 - phl - psl,
                         90 + alpha, 90 + alpha + beta, 90 + alpl, 90 + alpl + betl], axis=1)
    return motion, expected


def test_partition_and_limb_angles_known_skeleton():
    motion, expected = _hand_built()
    F = motion_features(motion)
    np.testing.assert_allclose(F.partition, expected, atol=1e-9)
    np.testing.assert_allclose(F.limbs, (expected[:, 0::2] + expected[:, 1::2]) / 2, atol=1e-9)
    assert F.limbs.shape == (40, len(LIMB_NAMES))
    assert F.rate_hz == pytest.approx(100.0)
    assert F.joint_map["spine"] == "Neck" and F.joint_map["r_wrist"] == "RightHand"


def test_bone_angle_equals_arccos_form():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(500, 3)), rng.normal(size=(500, 3))
    ref = np.degrees(np.arccos(np.clip((a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1), -1, 1)))
    np.testing.assert_allclose(bone_angles(a, b), ref, atol=1e-7)
    assert bone_angles([1, 0, 0], [2, 0, 0]) == 0.0
    assert bone_angles([1, 0, 0], [-3, 0, 0]) == 180.0
    with pytest.raises(InvalidSignalError, match="zero length"):
        bone_angles([0, 0, 0], [1, 0, 0])


def test_limb_angles_is_table3_mean():
    P = np.arange(16.0).reshape(2, 8)
    np.testing.assert_allclose(limb_angles(P), [[0.5, 2.5, 4.5, 6.5], [8.5, 10.5, 12.5, 14.5]])


def test_joint_maps_cmu_pn_override_and_errors():
    cmu = ("root", "lhipjoint", "lfemur", "ltibia", "lfoot", "rhipjoint", "rfemur", "rtibia", "rfoot", "lowerback",
           "upperback", "thorax", "lowerneck", "upperneck", "head", "lclavicle", "lhumerus", "lradius", "lwrist",
           "rclavicle", "rhumerus", "rradius", "rwrist")
    m = resolve_joint_map(cmu)
    assert (m["root"], m["spine"], m["r_hip"], m["r_knee"], m["r_ankle"]) == (
        "root", "lowerneck", "rfemur", "rtibia", "rfoot")
    assert (m["l_shoulder"], m["l_elbow"], m["l_wrist"]) == ("lhumerus", "lradius", "lwrist")
    pn = ("Hips", "RightUpLeg", "RightLeg", "RightFoot", "LeftUpLeg", "LeftLeg", "LeftFoot", "Spine", "Spine3",
          "Neck", "Head", "RightShoulder", "RightArm", "RightForeArm", "RightHand", "LeftShoulder", "LeftArm",
          "LeftForeArm", "LeftHand")
    m = resolve_joint_map(pn)
    assert (m["spine"], m["r_shoulder"], m["r_elbow"], m["r_wrist"]) == (
        "Neck", "RightArm", "RightForeArm", "RightHand")
    assert resolve_joint_map(pn, {"spine": "Spine3"})["spine"] == "Spine3"
    with pytest.raises(InvalidParameterError, match="no joint 'Chest'"):
        resolve_joint_map(pn, {"spine": "Chest"})
    with pytest.raises(InvalidParameterError, match="unknown joint role"):
        resolve_joint_map(pn, {"torso": "Spine"})
    with pytest.raises(InvalidParameterError, match="l_elbow"):
        resolve_joint_map(tuple(n for n in pn if n != "LeftForeArm"))


def test_pose_features_are_root_relative():
    motion, _ = _hand_built(n=5)
    X = pose_features(motion)
    assert X.shape == (5, 3 * (len(NAMES) - 1))
    # a rigid translation of the root changes nothing
    tr = motion.translations.copy()
    tr[:, 0] += 1000
    moved = Motion(motion.skeleton, motion.times, motion.rotations, tr)
    np.testing.assert_allclose(pose_features(moved), X, atol=1e-9)


def test_features_on_shared_files(shared_data):
    from mocapkit.io.loaders import load_motion

    m = load_motion(shared_data / "cmu" / "86_01.amc", asf=shared_data / "cmu" / "86.asf")
    F = motion_features(m)
    assert F.limbs.shape == (4579, 4)
    # standing/walking: legs point away from the spine (> 120° on average), arms hang (> 90°)
    assert (F.limbs.mean(0)[:2] > 120).all() and (F.limbs.mean(0)[2:] > 90).all()
    F = motion_features(load_motion(shared_data / "bvh" / "perception-neuron-freya.bvh"))
    assert (F.joint_map["spine"], F.joint_map["r_shoulder"], F.joint_map["l_wrist"]) == ("Neck", "RightArm", "LeftHand")
    F = motion_features(load_motion(shared_data / "bvh" / "walk-meredith.bvh"))
    assert (F.joint_map["spine"], F.joint_map["r_hip"], F.joint_map["l_elbow"]) == ("Head", "RightUpLeg", "LeftForeArm")
    # walking: the legs stay far from the spine direction all through the take
    assert F.partition[:, :4].min() > 100 and F.limbs[:, :2].mean() > 140


# ---------------------------------------------------------------------------------------------
# AR(MA) least squares, ADF


def _ar_series(n, coefs, sigma=1.0, seed=0, c=0.3):
    rng = np.random.default_rng(seed)
    x = np.zeros(n + 200)
    e = rng.normal(0, sigma, n + 200)
    for t in range(len(coefs), n + 200):
        x[t] = c + sum(a * x[t - i - 1] for i, a in enumerate(coefs)) + e[t]
    return x[200:]


@pytest.mark.parametrize("p", [1, 2, 3, 4])
def test_ar_fit_equals_statsmodels_autoreg(p):
    from statsmodels.tsa.ar_model import AutoReg

    rng = np.random.default_rng(p)
    windows = np.stack([_ar_series(100, [0.5, -0.3, 0.1][: min(p, 3)], seed=s) + rng.normal() for s in range(6)])
    fit = fit_arma(windows, p, 0)
    for k in range(len(windows)):
        ref = AutoReg(windows[k], lags=p, trend="c").fit()
        np.testing.assert_allclose(fit.coef[k], ref.params, rtol=0, atol=1e-8)
        np.testing.assert_allclose(fit.fitted[k], ref.fittedvalues, rtol=0, atol=1e-8)
        np.testing.assert_allclose(fit.sigma2[k], ref.sigma2, rtol=1e-8)


def test_arma_hannan_rissanen_equals_naive_lstsq():
    x = _ar_series(100, [0.6, -0.2], seed=4) + np.convolve(np.random.default_rng(5).normal(size=100), [1, 0.5], "same")
    for p, q in [(1, 1), (2, 2), (3, 1)]:
        fit = fit_arma(x, p, q)
        L = max(2 * (p + q), p + q + 2)
        # stage 1, naive: long AR by lstsq
        rows = [[1.0] + [x[t - i] for i in range(1, L + 1)] for t in range(L, 100)]
        b1 = np.linalg.lstsq(np.array(rows), x[L:], rcond=None)[0]
        eps = np.zeros(100)
        eps[L:] = x[L:] - np.array(rows) @ b1
        rows2 = [[1.0] + [x[t - i] for i in range(1, p + 1)] + [eps[t - j] for j in range(1, q + 1)]
                 for t in range(L + q, 100)]
        b2 = np.linalg.lstsq(np.array(rows2), x[L + q:], rcond=None)[0]
        np.testing.assert_allclose(fit.coef[0], b2, atol=1e-9)
        np.testing.assert_allclose(fit.long_coef[0], b1, atol=1e-9)
        # one-step prediction of new data with the fitted model = the same regression written out
        y = _ar_series(60, [0.6, -0.2], seed=9)
        hist = x
        pred = predict_one_step(fit, 0, y, hist)
        full = np.concatenate([hist, y])
        n0 = hist.size
        e_new = np.array([full[t] - b1[0] - sum(b1[i] * full[t - i] for i in range(1, L + 1))
                          for t in range(n0 - q, n0 + 60)])
        ref = np.array([b2[0] + sum(b2[i] * full[t - i] for i in range(1, p + 1))
                        + sum(b2[p + j] * e_new[t - n0 + q - j] for j in range(1, q + 1)) for t in range(n0, n0 + 60)])
        np.testing.assert_allclose(pred, ref, atol=1e-9)


@pytest.mark.filterwarnings("ignore::FutureWarning")
def test_adf_statistic_and_critical_values_equal_statsmodels():
    from statsmodels.tsa.stattools import adfuller

    rng = np.random.default_rng(7)
    series = [rng.normal(size=100), np.cumsum(rng.normal(size=100)), _ar_series(100, [0.9], seed=2)]
    for x in series:
        for lags in (0, 2, 4):
            ref = adfuller(x, maxlag=lags, autolag=None, regression="c")
            assert adf_statistic(x, lags)[0] == pytest.approx(ref[0], abs=1e-8)
            nobs = x.size - 1 - lags
            for key, a in (("1%", 0.01), ("5%", 0.05), ("10%", 0.10)):
                assert adf_critical_value(nobs, a) == pytest.approx(ref[4][key], abs=1e-3)


# ---------------------------------------------------------------------------------------------
# the segmenter on a series with a known change in dynamics


def _changing(seed, n1=550, n=1100, noise=0.02):
    """A limb-angle-like oscillation that gets faster and wider at sample n1 (phase-continuous)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    f = np.where(t < n1, 1 / 40, 1 / 15)
    a = np.where(t < n1, 20.0, 35.0)
    return 120 + a * np.sin(np.cumsum(2 * np.pi * f)) + rng.normal(0, noise, n)


@pytest.mark.parametrize("seed", range(6))
def test_cut_lands_on_the_change_in_dynamics(seed):
    seg = ARMASegmenter(**SD_READING, downsample=1)
    cuts = seg.fit_predict(_changing(seed))
    assert len(cuts) == 1 and abs(int(cuts[0]) - 550) <= 10


def test_r2_and_sd_follow_the_equations():
    x = _changing(3)
    seg = ARMASegmenter(**SD_READING, downsample=1).fit(x)
    ch = seg.channels_[0]
    p, q = ch["order"]
    z = np.diff(x, n=2)  # z[i] is sample i + 2
    # Eq. 28-29 per window, recomputed with an independent naive ARMA least squares
    def naive_fit(w):
        L = max(2 * (p + q), p + q + 2) if q else 0
        eps = np.zeros(w.size)
        if q:
            A = np.array([[1.0] + [w[t - i] for i in range(1, L + 1)] for t in range(L, w.size)])
            eps[L:] = w[L:] - A @ np.linalg.lstsq(A, w[L:], rcond=None)[0]
        s = L + q if q else p
        A = np.array([[1.0] + [w[t - i] for i in range(1, p + 1)] + [eps[t - j] for j in range(1, q + 1)]
                      for t in range(s, w.size)])
        r = w[s:] - A @ np.linalg.lstsq(A, w[s:], rcond=None)[0]
        return w[s:], r
    r2 = []
    for s, e in seg.windows(z.size):
        y, r = naive_fit(z[s:e])
        r2.append(1 - (r ** 2).sum() / ((y - y.mean()) ** 2).sum())
    np.testing.assert_allclose(ch["r2"], r2, atol=1e-9)
    flagged = np.flatnonzero(np.array(r2) < 0.6)
    assert flagged.tolist() == [5]  # only the window holding sample 550 (z index 548)
    # Eq. 30-31 in the flagged window, with the previous window's model and its Eq. 22 sigma
    s5, e5 = seg.windows(z.size)[5]
    s4, e4 = seg.windows(z.size)[4]
    f4 = fit_arma(z[s4:e4], p, q)
    sigma = np.sqrt(f4.sigma2[0])
    pred = predict_one_step(f4, 0, z[s5:e5], z[s4:e4])
    err = z[s5:e5] - pred
    outside = ((1 - 0.95) + 0.5 * 0.01) / (0.025 + 0.95 * (1 - 0.025 * (2 * 1.96 * sigma) / 30))
    expected_sd = np.where(np.abs(err) <= 1.96 * sigma, 1.0, outside)
    np.testing.assert_allclose(ch["sd"][s5 + 2:e5 + 2], expected_sd, atol=1e-12)
    # the cut is a minimum-SD sample
    cut = int(seg.predict()[0])
    assert ch["sd"][cut] == ch["sd"].min() < 1


def test_downsampling_maps_cuts_to_input_frames():
    x = _changing(1)
    fine = np.repeat(x, 4)  # the same take at 4x the rate: every 4th frame is x again
    cuts = ARMASegmenter(**SD_READING, downsample=4).fit_predict(fine)
    assert cuts.tolist() == (4 * ARMASegmenter(**SD_READING, downsample=1).fit_predict(x)).tolist()
    assert len(cuts) == 1 and abs(int(cuts[0]) - 4 * 550) <= 40


def test_order_selection_picks_the_true_ar_order():
    z = _ar_series(3000, [1.2, -0.6], sigma=1.0, seed=11)
    from statsmodels.tsa.ar_model import AutoReg

    order, F = ARMASegmenter(**SD_READING).select_order(z)
    assert order == (2, 0)
    for (p, q), v in F.items():  # F is Eq. 25: the mean squared one-step error of that model
        if q == 0:
            assert v == pytest.approx(AutoReg(z, lags=p, trend="c").fit().sigma2, rel=1e-9)
    # the parsimony rule: larger orders are not 1 % better, yet they are not worse either
    assert min(F.values()) <= F[(2, 0)] <= min(F.values()) * 1.01


def test_ensemble_rules():
    s = ARMASegmenter(**SD_READING, ensemble_tol=50, min_limbs=2)
    assert s.ensemble([[100], [104], [300], []]) == [102]  # 300 found by one limb only: dropped
    assert s.ensemble([[100, 400], [110, 405], [90, 395], [130, 700]]) == [105, 400]
    # complete linkage: a chain 100-140-180-220 is two cuts, not one
    assert s.ensemble([[100], [140], [180], [220]]) == [120, 200]
    # equal counts, matching order: the paper's row-wise median
    rng = np.random.default_rng(0)
    truth = np.array([300, 800, 1500, 2100])
    S = truth[:, None] + rng.integers(-20, 21, size=(4, 4))
    got = s.ensemble([list(S[:, j]) for j in range(4)])
    assert got == [int(round(float(v))) for v in np.median(S, axis=1)]
    # one channel: min_limbs is capped at the channel count
    assert ARMASegmenter(**SD_READING).ensemble([[10, 200]], 1) == [10, 200]


def test_multilimb_synthetic_ensemble():
    # four limbs change at the same time (±3 samples); a fifth changes alone at 850: that cut of a
    # single limb is dropped by the ensemble
    X = np.stack([_changing(s, n1=550 + d) for s, d in zip(range(4), (0, 2, -3, 1), strict=True)]
                 + [_changing(9, n1=850)], axis=1)
    seg = ARMASegmenter(**SD_READING, downsample=1)
    cuts = seg.fit_predict(X)
    assert any(abs(int(c) - 850) <= 10 for c in seg.limb_cuts_[4])
    assert len(cuts) == 1 and abs(int(cuts[0]) - 550) <= 10


def test_min_limbs_counts_moving_channels_only():
    X = np.stack([_changing(2), np.full(1100, 45.0)], axis=1)
    assert (ARMASegmenter(**SD_READING, downsample=1).fit_predict(X).tolist()
            == ARMASegmenter(**SD_READING, downsample=1).fit_predict(X[:, 0]).tolist())


def test_differenced_windows_join_without_gap():
    z = np.cumsum(np.random.default_rng(0).normal(size=250))
    series = ARMASegmenter.window_series(z, [(0, 100), (100, 200), (200, 250)], [True, True, False])
    assert [off for _, off in series] == [1, 100, 200]
    np.testing.assert_array_equal(np.concatenate([series[0][0], series[1][0]]), np.diff(z)[:199])
    np.testing.assert_array_equal(series[2][0], z[200:250])


def test_sequence_reading_of_r2():
    seg = ARMASegmenter(**SD_READING, downsample=1, r2_fit="sequence").fit(_changing(0))
    ch = seg.channels_[0]
    z = np.diff(_changing(0), n=2)
    f = fit_arma(z, *ch["order"])
    s, e = seg.windows(z.size)[3]
    r = f.resid[0][s - f.start:e - f.start]
    assert ch["r2"][3] == pytest.approx(1 - (r ** 2).sum() / ((z[s:e] - z[s:e].mean()) ** 2).sum())


def test_contract_and_errors():
    with pytest.raises(InvalidParameterError):
        ARMASegmenter(window=10)
    with pytest.raises(InvalidParameterError):
        ARMASegmenter(r2_min=1.5)
    with pytest.raises(InvalidParameterError):
        ARMASegmenter(adf_alpha=0.2)
    with pytest.raises(InvalidParameterError, match="windows of at least"):
        ARMASegmenter(window=22, p_range=(2,), q_range=(1,))
    with pytest.raises(InvalidParameterError):
        ARMASegmenter(r2_fit="global")
    with pytest.raises(InvalidParameterError, match="at least"):
        ARMASegmenter().fit(np.zeros(100))
    with pytest.raises(InvalidSignalError):
        ARMASegmenter().fit(np.full(1000, np.nan))
    cuts = ARMASegmenter(**SD_READING).fit_predict(np.random.default_rng(0).normal(size=(3000, 4)))
    assert cuts.dtype == np.int64 and (np.diff(cuts) > 0).all() and ((cuts > 0) & (cuts < 3000)).all()
    # a constant signal: every window is degenerate, no cut
    assert ARMASegmenter(**SD_READING).fit_predict(np.full((2000, 4), 90.0)).size == 0


def _ar_window_signal(seed: int) -> np.ndarray:
    """Stationary AR(2) noise for 600 samples, then a burst of AR(1) 0.95 noise of another scale."""
    rng = np.random.default_rng(seed)
    a = _ar_series(600, [0.5, -0.3], sigma=1.0, seed=seed)
    b = np.zeros(400)
    e = rng.normal(0, 6.0, 400)
    for i in range(1, 400):
        b[i] = 0.3 * b[i - 1] + e[i]
    return np.concatenate([a, b])


def test_authors_reading_keeps_stationary_windows_raw_and_cuts_at_the_largest_error():
    """segmentnote_choose: a window the ADF test finds stationary is modelled raw; point_choose2: the cut
    is the sample of largest |measured - predicted| of that window's own one-step fit."""
    x = _ar_window_signal(4)
    seg = ARMASegmenter(downsample=1, window=100).fit(x)
    ch = seg.channels_[0]
    assert all(w["diff"] == 0 for w in ch["windows"])  # stationary: nothing differenced
    for w in ch["windows"]:
        s, e = w["start"], w["stop"]
        np.testing.assert_array_equal(w["series"], x[s:e])
        p, q = w["order"]
        f = fit_arma(x[s:e], p, q)
        np.testing.assert_allclose(w["resid"], f.resid[0], atol=1e-9)
        r2 = 1 - (f.resid[0] ** 2).sum() / ((x[s + f.start:e] - x[s + f.start:e].mean()) ** 2).sum()
        assert w["r2"] == pytest.approx(r2, abs=1e-9)
        if r2 < 0.6:
            assert s + f.start + int(np.argmax(np.abs(f.resid[0]))) in ch["cuts"]
        else:
            assert not [c for c in ch["cuts"] if s <= c < e]


def test_authors_reading_differences_only_where_the_adf_test_fails():
    rng = np.random.default_rng(2)
    walk = np.cumsum(np.cumsum(rng.normal(size=300)))  # integrated twice: not stationary
    noise = rng.normal(size=300)
    seg = ARMASegmenter(downsample=1, window=100).fit(np.concatenate([noise, walk[:300] + 50]))
    diffs = [w["diff"] for w in seg.channels_[0]["windows"]]
    assert diffs[:2] == [0, 0] and 2 in diffs[3:]
    for w in seg.channels_[0]["windows"]:
        if w["diff"] == 2:
            x = np.concatenate([noise, walk[:300] + 50])
            np.testing.assert_allclose(w["series"], np.diff(x[w["start"] - 2:w["stop"]], n=2))


def test_aic_order_is_the_least_aic_of_the_grid():
    """order='aic': each window's (p, q) has the least AIC over p, q <= 5, recomputed here by brute
    force from independent fits on the common tail of samples every order predicts."""
    x = _ar_window_signal(7)[:600]
    seg = ARMASegmenter(downsample=1, window=100).fit(x)
    grid = [(p, q) for p in range(6) for q in range(6) if p + q]
    tail = max((max(2 * (p + q), p + q + 2) + q) if q else p for p, q in grid)
    for w in seg.channels_[0]["windows"]:
        aic = {}
        for p, q in grid:
            f = fit_arma(w["series"], p, q)
            r = f.resid[0][tail - f.start:]
            aic[(p, q)] = r.size * np.log((r ** 2).mean()) + 2 * (p + q + 1)
        assert w["order"] == min(aic, key=aic.get)


def test_best_f_order_is_the_least_f():
    z = _ar_series(3000, [1.2, -0.6], sigma=1.0, seed=11)
    order, F = ARMASegmenter(order="best_f", p_range=(1, 2, 3, 4), q_range=(0, 1, 2)).select_order(z)
    assert F[order] == min(F.values())


def test_reading_options_are_checked():
    for kw in ({"cut": "min"}, {"order": "bic"}, {"differencing": "always"}, {"r2_fit": "sequence"}):
        with pytest.raises(InvalidParameterError):
            ARMASegmenter(**kw)
