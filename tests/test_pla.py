"""Model, tuning and metrics of the PLA layer (the algorithms themselves: test_pla_reference.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.io import read_imu_csv
from mocapkit.motion import Signal
from mocapkit.pla import Encoder, compress, compress_to, evaluate
from mocapkit.pla.tune import threshold_for_icr


@pytest.fixture(scope="module")
def pelvis(tests_data) -> Signal:
    return read_imu_csv(tests_data / "xio" / "pelvis" / "Quaternion.csv")


def test_signal_rejects_bad_arrays():
    t = np.array([0.0, 0.1, 0.2])
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    with pytest.raises(InvalidSignalError, match="strictly increasing"):
        Signal(np.array([0.0, 0.1, 0.1]), q)
    with pytest.raises(InvalidSignalError, match="NaN"):
        Signal(t, np.where(np.arange(12).reshape(3, 4) == 5, np.nan, q))
    with pytest.raises(InvalidSignalError, match="zero-norm"):
        Signal(t, np.vstack([q[:2], [0, 0, 0, 0]]))
    with pytest.raises(InvalidSignalError, match="4 columns"):
        Signal(t, q[:, :3])
    s = Signal(t, q)
    with pytest.raises(ValueError):
        s.values[0, 0] = 2.0  # read-only: raw values cannot be changed behind the model's back


def test_metrics_against_scipy(pelvis):
    comp = compress(pelvis, "cplr", 1e-3)
    m = evaluate(pelvis, comp)
    assert m.icr == comp.n_points / len(pelvis)
    key = Rotation.from_quat(np.roll(comp.values / np.linalg.norm(comp.values, axis=1, keepdims=True), -1, axis=1))
    rec = Slerp(comp.times, key)(pelvis.times)
    orig = Rotation.from_quat(np.roll(pelvis.values, -1, axis=1))
    dev = np.degrees((orig.inv() * rec).magnitude())
    assert m.aad_deg == pytest.approx(dev.mean(), abs=1e-9)
    assert m.max_deg == pytest.approx(dev.max(), abs=1e-9)
    assert m.std_deg == pytest.approx(dev.std(), abs=1e-9)
    # CPLR points are extrapolated: they deviate from the samples (Figure 4 right of the paper)
    assert m.point_max_deg > 0.01
    # SW/fastSW points are samples: zero deviation, exactly
    m2 = evaluate(pelvis, compress(pelvis, "fastsw", 1e-3))
    assert m2.point_max_deg == 0.0


def test_sign_flipped_input_gives_same_rotations(pelvis):
    """q and -q are the same rotation: flipping random samples must not change the decoded signal."""
    rng = np.random.default_rng(3)
    flip = np.where(rng.random(len(pelvis)) < 0.3, -1.0, 1.0)[:, None]
    flipped = Signal(pelvis.times, pelvis.values * flip)
    for method, th in (("fastsw", 1e-4), ("cplr", 1e-4), ("swing", 3e-3), ("anglesw", 1.0)):
        a = compress(pelvis, method, th)
        b = compress(flipped, method, th)
        assert np.array_equal(a.indices, b.indices), method
        assert evaluate(pelvis, a).max_deg == pytest.approx(evaluate(flipped, b).max_deg, abs=1e-9)


@pytest.mark.parametrize("method", ["fastsw", "sw", "cplr", "swing", "anglesw"])
def test_target_icr_is_met_and_tight(pelvis, method):
    target = 0.08
    comp = threshold_for_icr(pelvis, method, target)
    assert comp.icr <= target
    # the bisection stops at a boundary: a threshold 1 % smaller gives more points than allowed
    smaller = compress(pelvis, method, comp.threshold * 0.99)
    assert smaller.icr > target
    assert comp.icr > 0.8 * target  # not a trivially loose threshold


def test_target_icr_out_of_reach(pelvis):
    with pytest.raises(InvalidParameterError, match="out of reach"):
        compress_to(pelvis, "fastsw", target_icr=2.5 / len(pelvis), max_segment_length=10)


@pytest.mark.parametrize("L", [1, 3, 50])
def test_max_segment_length(pelvis, L):
    for method in ("fastsw", "sw", "cplr", "swing", "anglesw"):
        comp = compress(pelvis, method, 1e9 if method != "anglesw" else 180.0, L)
        gaps = np.diff(comp.indices)
        assert gaps.max() <= L
        if L == 1:
            assert comp.n_points == len(pelvis)


def test_max_angle_fewer_points_than_tuned_fastsw(pelvis):
    """anglesw uses the bound directly; fastSW's SSR threshold is a proxy and needs more points."""
    a = compress_to(pelvis, "anglesw", max_angle=2.0)
    f = compress_to(pelvis, "fastsw", max_angle=2.0)
    assert evaluate(pelvis, a).max_deg <= 2.0 + 1e-9
    assert evaluate(pelvis, f).max_deg <= 2.0 + 1e-9
    assert a.n_points < f.n_points


def test_encoder_rejects_bad_samples():
    enc = Encoder("fastsw", 1e-3)
    enc.push(0.0, (1, 0, 0, 0))
    with pytest.raises(InvalidSignalError, match="duplicate"):
        enc.push(0.0, (1, 0, 0, 0))
    with pytest.raises(InvalidSignalError, match="zero-norm"):
        enc.push(0.1, (0, 0, 0, 0))
    with pytest.raises(InvalidSignalError, match="NaN"):
        enc.push(0.1, (float("nan"), 0, 0, 0))
    with pytest.raises(InvalidSignalError, match="expected 4"):
        enc.push(0.1, (1, 0, 0))
    with pytest.raises(InvalidParameterError, match="threshold"):
        Encoder("fastsw", -1.0)
    with pytest.raises(InvalidParameterError, match="unknown method"):
        Encoder("bogus", 1.0)


def test_vector_signals_linear_decode():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.005, 0.02, 400))
    x = np.cumsum(rng.normal(size=(400, 3)), axis=0)
    sig = Signal(t, x, kind="vector")
    comp = compress(sig, "swing", 0.5)
    m = evaluate(sig, comp)
    # swing guarantees 0.5 per dimension, so at most 0.5*sqrt(3) in Euclidean distance
    assert m.max_deg <= 0.5 * np.sqrt(3) + 1e-9
    with pytest.raises(InvalidParameterError, match="quaternion"):
        compress(sig, "anglesw", 1.0)


def test_max_angle_bound_on_every_shared_sensor(shared_data):
    from mocapkit.io import read_sensor_folder

    sensors = read_sensor_folder(shared_data / "imu" / "xio-lower-body")
    assert len(sensors) == 7
    for sig in sensors.values():
        for deg in (0.5, 1.0, 3.0):
            for method in ("anglesw", "fastsw", "swing"):
                comp = compress_to(sig, method, max_angle=deg, max_segment_length=1000)
                assert evaluate(sig, comp).max_deg <= deg + 1e-9


def _brute_min_points(t, q, deg):
    """Fewest sample points (first and last included) keeping every sample within deg: brute force."""
    from itertools import combinations

    n = len(t)
    R = Rotation.from_quat(np.roll(q, -1, axis=1))
    for k in range(0, n - 1):
        for inner in combinations(range(1, n - 1), k):
            idx = [0, *inner, n - 1]
            rec = Slerp(t[idx], R[idx])(t)
            if np.degrees((R.inv() * rec).magnitude()).max() <= deg + 1e-12:
                return k + 2
    return n


def test_optimal_max_angle_equals_brute_force_and_bounds_anglesw():
    from mocapkit.evaluation.maxangle import optimal_max_angle

    rng = np.random.default_rng(11)
    for trial in range(12):
        n = 11
        t = np.cumsum(rng.uniform(0.01, 0.03, n))
        rv = np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)
        q = np.roll(Rotation.from_rotvec(rv).as_quat(), 1, axis=1)
        sig = Signal(t, q)
        deg = float(rng.uniform(0.5, 4.0))
        opt = optimal_max_angle(sig, deg, max_segment_length=n)
        assert opt.n_points == _brute_min_points(t, q, deg), trial
        assert evaluate(sig, opt).max_deg <= deg + 1e-9
        assert opt.n_points <= compress(sig, "anglesw", deg).n_points
