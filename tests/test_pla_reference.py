"""Independent tests of the PLA methods against naive reference implementations.

The references in ``tests/reference_pla.py`` are written from the specification alone (Section 5 and
Algorithm 1 of the fastSW paper plus the package's documented semantics), not from the package's
code.  The tests check:

1. ``compress`` == reference for every method (indices exactly; values exactly for the methods that
   keep original samples, to 1e-12 relative for CPLR and the Swing Filter), on random smooth
   quaternion walks (with q / −q sign flips and slightly non-unit norms) and random vector signals
   with irregular timestamps and gaps, many thresholds, with and without a maximum segment length;
2. the streaming ``Encoder`` == batch ``compress`` bit for bit;
3. brute-force guarantees (Swing ε, CPLR/SW SSR, point preservation, the max-angle bound checked
   with scipy's SLERP);
4. the quaternion helpers against scipy / naive loops;
5. real recordings (skipped when ../shared/data is absent);
6. the documented floating-point tie between SW and fastSW.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

import reference_pla as ref
from mocapkit.motion import Signal
from mocapkit.pla.base import Compressed, Encoder, compress
from mocapkit.pla.decode import reconstruct_points
from mocapkit.pla.metrics import evaluate
from mocapkit.pla.tune import compress_to
from mocapkit.quat import angular_distance, hemisphere_continuous, slerp

METHODS = ref.ALL_METHODS
POS = ref.POS_METHODS

HSET = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


# --------------------------------------------------------------------------------------------
# random signals
# --------------------------------------------------------------------------------------------


def random_times(rng: np.random.Generator, n: int) -> np.ndarray:
    """Irregular, strictly increasing timestamps with occasional large gaps (dropped packets)."""
    base = 10.0 ** rng.uniform(-3, -0.5)
    dt = base * rng.uniform(0.3, 1.7, max(n - 1, 0))
    gaps = rng.random(dt.shape[0]) < 0.07
    dt[gaps] *= rng.uniform(2.0, 40.0, int(gaps.sum()))
    t0 = [0.0, float(rng.uniform(-10, 10)), 917.418209, 1.7e6][int(rng.integers(4))]
    t = t0 + np.concatenate([[0.0], np.cumsum(dt)])
    assert np.all(np.diff(t) > 0)
    return t


def _holds(rng: np.random.Generator, X: np.ndarray) -> np.ndarray:
    """Copy some samples onto their successors (stationary stretches: exactly repeated values)."""
    X = X.copy()
    if rng.random() < 0.5:
        for _ in range(int(rng.integers(1, 4))):
            i = int(rng.integers(0, X.shape[0]))
            k = int(rng.integers(1, 12))
            X[i : i + k] = X[i]
    return X


def random_quaternions(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """Smooth random walk of rotations, with sign flips (q and −q) and slightly non-unit norms."""
    n = t.shape[0]
    speed = 10.0 ** rng.uniform(-1.5, 1.0)  # rad/s
    w = rng.normal(size=3) * speed
    r = Rotation.random(random_state=int(rng.integers(2**31)))
    out = np.empty((n, 4))
    for i in range(n):
        if i:
            w = w + rng.normal(size=3) * speed * 0.3
            r = r * Rotation.from_rotvec(w * (t[i] - t[i - 1]))
        out[i] = ref.from_scipy(r)
    norm = int(rng.integers(3))
    if norm == 1:  # like the x-io sensor: |q| ≈ 1.00012
        out *= 1.00012
    elif norm == 2:
        out *= (1.0 + rng.normal(0.0, 1e-3, n))[:, None]
    # stationary stretches are bit-identical rows (copied after the norm perturbation: rows that
    # are merely parallel would be the same rotation only up to rounding, a float tie at TH = 0)
    out = _holds(rng, out)
    mode = int(rng.integers(4))
    if mode == 1:  # random single flips
        flip = rng.random(n) < 0.2
        out[flip] *= -1.0
    elif mode == 2:  # flipped blocks
        s = np.cumprod(np.where(rng.random(n) < 0.05, -1.0, 1.0))
        out *= s[:, None]
    elif mode == 3:  # both
        out[rng.random(n) < 0.1] *= -1.0
        out *= np.cumprod(np.where(rng.random(n) < 0.05, -1.0, 1.0))[:, None]
    return out


def random_vectors(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    n = t.shape[0]
    d = int(rng.integers(1, 7))
    scale = 10.0 ** rng.uniform(-2, 2)
    v = rng.normal(size=d) * scale
    x = rng.normal(size=d) * scale
    out = np.empty((n, d))
    for i in range(n):
        if i:
            dt = t[i] - t[i - 1]
            v = v + rng.normal(size=d) * scale * 0.5
            x = x + v * dt + rng.normal(size=d) * scale * 0.01 * math.sqrt(dt)
        out[i] = x
    return _holds(rng, out)


def random_signal(seed: int, n: int, kind: str) -> Signal:
    rng = np.random.default_rng(seed)
    t = random_times(rng, n)
    X = random_quaternions(rng, t) if kind == "quaternion" else random_vectors(rng, t)
    return Signal(t, X, kind)


def threshold_for(method: str, signal: Signal, log_factor: float, zero: bool) -> float:
    """A threshold on the method's own metric, scaled to the data (0 when ``zero``)."""
    if zero:
        return 0.0
    if method == "anglesw":
        return float(10.0 ** (0.6 * log_factor))  # ~0.004° .. 250°
    X = ref.prepare(signal.values, signal.kind)
    step = float(np.median(np.abs(np.diff(X, axis=0)))) if len(signal) > 1 else 1.0
    step = step if step > 0 else 1.0
    if method == "swing":
        return float(step * 10.0 ** (0.5 * log_factor))
    return float(step**2 * 10.0**log_factor)


seeds = st.integers(0, 2**32 - 1)
lengths = st.integers(1, 140)
log_factors = st.floats(-4.0, 4.0, allow_nan=False)
zeros = st.sampled_from([False] * 9 + [True])
max_lens = st.one_of(st.none(), st.integers(1, 40))
kinds = st.sampled_from(["quaternion", "vector"])


def kind_for(method: str, kind: str) -> str:
    return "quaternion" if method == "anglesw" else kind


def scale_of(signal: Signal) -> float:
    return max(1.0, float(np.max(np.abs(signal.values))))


def assert_same_as_reference(signal: Signal, method: str, th: float, L: int | None) -> Compressed:
    comp = compress(signal, method, th, L)
    idx, vals = ref.ref_compress(signal.times, signal.values, signal.kind, method, th, L)
    problems = ref.structure_problems(signal.times, len(signal), comp.indices, comp.times, L)
    assert not problems, problems
    np.testing.assert_array_equal(
        comp.indices, idx, err_msg=f"{method} th={th!r} L={L}: indices differ from the reference"
    )
    np.testing.assert_array_equal(comp.times, signal.times[idx])
    assert comp.values.shape == vals.shape
    if method in POS:
        np.testing.assert_array_equal(comp.values, vals)  # RAW rows, bit for bit
        np.testing.assert_array_equal(comp.values, signal.values[comp.indices])
    else:
        np.testing.assert_allclose(comp.values, vals, rtol=1e-12, atol=1e-12 * scale_of(signal))
    assert comp.n_points == idx.shape[0]
    assert comp.icr == idx.shape[0] / len(signal)
    return comp


# --------------------------------------------------------------------------------------------
# 1. compress == reference
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@HSET
@given(seed=seeds, n=lengths, kind=kinds, lf=log_factors, zero=zeros, L=max_lens)
def test_compress_matches_reference(method, seed, n, kind, lf, zero, L):
    sig = random_signal(seed, n, kind_for(method, kind))
    th = threshold_for(method, sig, lf, zero)
    assert_same_as_reference(sig, method, th, L)


@pytest.mark.parametrize("method", METHODS)
def test_compress_matches_reference_threshold_sweep(method):
    """Many thresholds on a few fixed signals (both kinds, with and without a length limit)."""
    for seed in range(4):
        for kind in ("quaternion", "vector"):
            kind = kind_for(method, kind)
            sig = random_signal(1000 + seed, 160, kind)
            for lf in np.linspace(-4, 4, 9):
                th = threshold_for(method, sig, float(lf), False)
                for L in (None, 1, 3, 17):
                    assert_same_as_reference(sig, method, th, L)


def test_sign_flips_do_not_change_the_points():
    """q and −q are the same rotation: flipping arbitrary samples changes only the raw point
    values (POS methods report the rows as given), never the indices."""
    sig = random_signal(7, 120, "quaternion")
    rng = np.random.default_rng(3)
    flips = np.where(rng.random(len(sig)) < 0.3, -1.0, 1.0)
    flipped = Signal(sig.times, sig.values * flips[:, None], "quaternion")
    for method in METHODS:
        th = threshold_for(method, sig, 0.5, False)
        a = compress(sig, method, th)
        b = compress(flipped, method, th)
        np.testing.assert_array_equal(a.indices, b.indices, err_msg=method)
        if method in POS:
            np.testing.assert_array_equal(b.values, flipped.values[b.indices])
        else:  # extrapolated points follow the sign of the first sample
            s = flips[0]
            np.testing.assert_allclose(b.values, s * a.values, rtol=1e-12, atol=1e-12)


def _vec(times, xs) -> Signal:
    return Signal(np.asarray(times, dtype=np.float64), np.asarray(xs, dtype=np.float64)[:, None], "vector")


def test_threshold_is_inclusive():
    """The thresholds are inclusive (SSR <= TH, intervals intersect when they touch), checked on data
    whose SSR / slope bounds are exact in floating point whatever the evaluation order."""
    below = lambda x: float(np.nextafter(x, -np.inf))  # noqa: E731
    # SW / fastSW: anchor (0, 0), candidate (2, 0): β = 0, the inner sample (1, 1) gives SSR = 1
    sig = _vec([0, 1, 2], [0, 1, 0])
    for m in ("sw", "fastsw"):
        assert compress(sig, m, 1.0).indices.tolist() == [0, 2]
        assert compress(sig, m, below(1.0)).indices.tolist() == [0, 1, 2]
    # CPLR: anchor (0, 0), samples (1, 2), (2, -1): Σty = 0 so β = 0 and SSR = 4 + 1 = 5
    sig = _vec([0, 1, 2], [0, 2, -1])
    c = compress(sig, "cplr", 5.0)
    assert c.indices.tolist() == [0, 2] and c.values.ravel().tolist() == [0.0, 0.0]
    c = compress(sig, "cplr", below(5.0))
    assert c.indices.tolist() == [0, 1, 2] and c.values.ravel().tolist() == [0.0, 2.0, -1.0]
    # Swing, ε = 1: sample (1, 0) admits slopes [-1, 1]; (2, 3) admits [1, 2], touching at 1
    c = compress(_vec([0, 1, 2], [0, 0, 3]), "swing", 1.0)
    assert c.indices.tolist() == [0, 2]
    assert c.values.ravel().tolist() == [0.0, 2.0]  # LS slope 6/5 clamped into [1, 1]
    c = compress(_vec([0, 1, 2], [0, 0, float(np.nextafter(3.0, np.inf))]), "swing", 1.0)
    assert c.indices.tolist() == [0, 1, 2]
    for sig_, m, th in ((_vec([0, 1, 2], [0, 1, 0]), "sw", 1.0), (_vec([0, 1, 2], [0, 2, -1]), "cplr", 5.0),
                        (_vec([0, 1, 2], [0, 0, 3]), "swing", 1.0)):
        assert_same_as_reference(sig_, m, th, None)


@pytest.mark.parametrize("method", METHODS)
def test_max_segment_length_boundary(method):
    """A constant signal fits any line: only the length limit cuts, every L samples exactly."""
    n = 10
    t = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.5, 2.0, n - 1)])
    if method == "anglesw":
        sig = Signal(t, np.tile([0.5, 0.5, -0.5, 0.5], (n, 1)), "quaternion")
    else:
        sig = Signal(t, np.tile([1.5, -2.0], (n, 1)), "vector")
    for L, expected in ((None, [0, 9]), (1, list(range(10))), (2, [0, 2, 4, 6, 8, 9]), (3, [0, 3, 6, 9]),
                        (9, [0, 9]), (100, [0, 9])):
        c = compress(sig, method, 0.0, L)
        assert c.indices.tolist() == expected, (L, c.indices.tolist())
        np.testing.assert_array_equal(c.values, sig.values[expected])
        assert_same_as_reference(sig, method, 0.0, L)


@pytest.mark.parametrize("scale", [1.0, 1.00012, 0.7])
def test_anglesw_zero_threshold_identical_samples(scale):
    """anglesw at 0°: samples bit-identical to both ends of a segment lie exactly on its SLERP
    (angle 0 <= 0), so a stationary stretch of identical rows must stay ONE segment.  The x-io
    sensor's quaternions have |q| ≈ 1.00012, hence the non-unit scales."""
    q = np.array([-0.17105523944309478, -0.8020629430757665, 0.32541550640666705, 0.47093513671608495])
    q = q / np.linalg.norm(q) * scale
    for t in (np.arange(10) * 0.02, np.arange(10) * 1.0):
        sig = Signal(t, np.tile(q, (10, 1)), "quaternion")
        assert ref.ref_anglesw(sig.times, sig.values, "quaternion", 0.0)[0].tolist() == [0, 9]
        got = compress(sig, "anglesw", 0.0).indices.tolist()
        assert got == [0, 9], f"|q| = {scale}, dt = {t[1]}: anglesw at 0° cut a constant signal at {got}"


@HSET
@given(seed=seeds, n=lengths, kind=kinds, lf=log_factors, zero=zeros, L=max_lens)
def test_sw_equals_fastsw(seed, n, kind, lf, zero, L):
    sig = random_signal(seed, n, kind)
    th = threshold_for("sw", sig, lf, zero)
    a = compress(sig, "sw", th, L)
    b = compress(sig, "fastsw", th, L)
    np.testing.assert_array_equal(a.indices, b.indices)
    np.testing.assert_array_equal(a.values, b.values)


# --------------------------------------------------------------------------------------------
# 2. streaming Encoder == batch compress
# --------------------------------------------------------------------------------------------


def run_encoder(signal: Signal, method: str, th: float, L: int | None):
    enc = Encoder(method, th, dim=signal.dim, kind=signal.kind, max_segment_length=L)
    pts = []
    for t, x in zip(signal.times, signal.values, strict=True):
        got = enc.push(float(t), x)
        assert len(got) <= 1
        pts.extend(got)
    pts.extend(enc.flush())
    assert enc.flush() == []
    return pts


@pytest.mark.parametrize("method", METHODS)
@HSET
@given(seed=seeds, n=lengths, kind=kinds, lf=log_factors, zero=zeros, L=max_lens)
def test_encoder_matches_compress(method, seed, n, kind, lf, zero, L):
    sig = random_signal(seed, n, kind_for(method, kind))
    th = threshold_for(method, sig, lf, zero)
    comp = compress(sig, method, th, L)
    pts = run_encoder(sig, method, th, L)
    idx = np.array([p.index for p in pts], dtype=np.int64)
    times = np.array([p.time for p in pts])
    vals = np.array([p.values for p in pts]).reshape(len(pts), sig.dim)
    np.testing.assert_array_equal(idx, comp.indices)
    np.testing.assert_array_equal(times, comp.times)
    np.testing.assert_array_equal(vals, comp.values)


# --------------------------------------------------------------------------------------------
# 3. brute-force guarantees
# --------------------------------------------------------------------------------------------


def check_guarantees(signal: Signal, comp: Compressed, method: str, th: float, L: int | None) -> None:
    problems = ref.structure_problems(signal.times, len(signal), comp.indices, comp.times, L)
    assert not problems, problems
    X = ref.prepare(signal.values, signal.kind)
    if method in POS:
        np.testing.assert_array_equal(comp.values, signal.values[comp.indices])
    if method == "swing":
        dec = ref.linear_decode(comp.times, comp.values, signal.times)
        err = np.abs(X - dec)
        assert err.max() <= th + 1e-9, f"swing: max |error| {err.max()!r} > ε {th!r}"
    elif method in ("cplr", "sw", "fastsw"):
        pv = X[comp.indices] if method in POS else comp.values
        for k, (ssr, scale) in enumerate(ref.segment_ssrs(signal.times, X, comp.indices, pv)):
            slack = 1e-9 * th + 1e-12 * scale
            assert ssr <= th + slack, (
                f"{method}: segment {k} ({comp.indices[k]}..{comp.indices[k + 1]}) SSR {ssr!r} > {th!r}"
            )
    elif method == "anglesw":
        dev = ref.scipy_deviation_deg(signal.times, signal.values, comp.times, comp.values)
        assert dev.max() <= th + 1e-7, f"anglesw: max deviation {dev.max()!r}° > {th!r}°"


@pytest.mark.parametrize("method", METHODS)
@HSET
@given(seed=seeds, n=lengths, kind=kinds, lf=log_factors, zero=zeros, L=max_lens)
def test_guarantees(method, seed, n, kind, lf, zero, L):
    sig = random_signal(seed, n, kind_for(method, kind))
    th = threshold_for(method, sig, lf, zero)
    check_guarantees(sig, compress(sig, method, th, L), method, th, L)


def test_guarantee_checkers_can_fail():
    """The brute-force checkers are not vacuous: a deliberately bad approximation fails them."""
    sig = random_signal(11, 80, "quaternion")
    bad = Compressed("swing", 1e-4, None, "quaternion", len(sig), np.array([0, len(sig) - 1]),
                     sig.times[[0, -1]], 1.5 * ref.prepare(sig.values, "quaternion")[[0, -1]])
    for method, th in (("swing", 1e-4), ("cplr", 1e-8), ("anglesw", 0.01)):
        with pytest.raises(AssertionError):
            check_guarantees(sig, bad, method, th, None)
    with pytest.raises(AssertionError):  # not original samples
        check_guarantees(sig, bad, "sw", 1e9, None)


DEGS = (0.5, 2.0, 5.0)


@pytest.mark.parametrize("method", METHODS)
@settings(HSET, max_examples=25)
@given(seed=seeds, n=st.integers(2, 120), deg=st.sampled_from(DEGS + (0.1, 20.0)), L=max_lens)
def test_compress_to_max_angle_random(method, seed, n, deg, L):
    sig = random_signal(seed, n, "quaternion")
    comp = compress_to(sig, method, max_angle=deg, max_segment_length=L)
    assert not ref.structure_problems(sig.times, len(sig), comp.indices, comp.times, L)
    dev = ref.scipy_deviation_deg(sig.times, sig.values, comp.times, comp.values)
    assert dev.max() <= deg + 1e-7, f"{method}: max deviation {dev.max()!r}° > {deg}°"


# --------------------------------------------------------------------------------------------
# decode / metrics against own implementations
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@settings(HSET, max_examples=30)
@given(seed=seeds, n=lengths, kind=kinds, lf=log_factors)
def test_reconstruct_and_evaluate(method, seed, n, kind, lf):
    sig = random_signal(seed, n, kind_for(method, kind))
    th = threshold_for(method, sig, lf, False)
    comp = compress(sig, method, th)
    rec = reconstruct_points(comp.times, comp.values, sig.times, sig.kind)
    m = evaluate(sig, comp)
    assert m.n_points == comp.n_points and m.n_samples == len(sig)
    assert m.icr == comp.n_points / len(sig)
    if sig.kind == "quaternion":
        own = ref.from_scipy(ref.scipy_slerp_decode(comp.times, comp.values, sig.times))
        sgn = np.where(np.sum(own * rec, axis=1) < 0, -1.0, 1.0)
        np.testing.assert_allclose(rec, own * sgn[:, None], rtol=0, atol=1e-12)
        dev = ref.scipy_deviation_deg(sig.times, sig.values, comp.times, comp.values)
        pdev = np.degrees((ref.to_scipy(sig.values[comp.indices]).inv() * ref.to_scipy(comp.values)).magnitude())
    else:
        own = ref.linear_decode(comp.times, comp.values, sig.times)
        np.testing.assert_allclose(rec, own, rtol=1e-12, atol=1e-12 * scale_of(sig))
        dev = np.linalg.norm(sig.values - own, axis=1)
        pdev = np.linalg.norm(sig.values[comp.indices] - comp.values, axis=1)
    tol = 1e-9 * (1.0 if sig.kind == "quaternion" else scale_of(sig))
    assert abs(m.max_deg - dev.max()) <= tol
    assert abs(m.aad_deg - dev.mean()) <= tol
    assert abs(m.point_max_deg - pdev.max()) <= tol
    assert abs(m.point_mean_deg - pdev.mean()) <= tol


# --------------------------------------------------------------------------------------------
# 4. quaternion helpers
# --------------------------------------------------------------------------------------------


def _random_quats(rng, k, unit=False):
    q = rng.normal(size=(k, 4))
    if unit:
        q /= np.linalg.norm(q, axis=1, keepdims=True)
    else:
        q *= rng.uniform(0.5, 2.0, (k, 1))
    return q


@settings(HSET, max_examples=40)
@given(seed=seeds)
def test_slerp_matches_scipy(seed):
    rng = np.random.default_rng(seed)
    k = 40
    q0 = _random_quats(rng, k)
    q1 = _random_quats(rng, k)
    # near-identical, near-antipodal and exactly antipodal pairs
    q1[:5] = q0[:5] * 1.3 + rng.normal(size=(5, 4)) * 1e-7
    q1[5:10] = -q0[5:10] * 0.7 + rng.normal(size=(5, 4)) * 1e-3
    q1[10] = -q0[10]
    f = rng.uniform(0.0, 1.0, k)
    f[11], f[12] = 0.0, 1.0
    got = slerp(q0, q1, f)
    assert got.shape == (k, 4)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, rtol=0, atol=1e-12)
    for i in range(k):
        exp = ref.from_scipy(Slerp([0.0, 1.0], ref.to_scipy(np.stack([q0[i], q1[i]])))([f[i]]))[0]
        own = ref._unit(ref.slerp_ref(q0[i], q1[i], [f[i]])[0])
        for other in (exp, own):
            s = -1.0 if np.dot(got[i], other) < 0 else 1.0
            np.testing.assert_allclose(got[i], s * other, rtol=0, atol=1e-12, err_msg=f"pair {i}, f={f[i]}")
    # the ends are the (normalised) inputs, as rotations
    assert ref.quat_angle(got[11], q0[11]) < 1e-7
    assert ref.quat_angle(got[12], q1[12]) < 1e-7


@settings(HSET, max_examples=40)
@given(seed=seeds)
def test_angular_distance(seed):
    rng = np.random.default_rng(seed)
    k = 60
    q0 = _random_quats(rng, k)
    q1 = _random_quats(rng, k)
    u0 = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
    u1 = q1 / np.linalg.norm(q1, axis=1, keepdims=True)
    naive = 2.0 * np.arccos(np.clip(np.abs(np.sum(u0 * u1, axis=1)), 0.0, 1.0))
    got = angular_distance(q0, q1)
    far = naive > math.radians(1.0)
    np.testing.assert_allclose(got[far], naive[far], rtol=0, atol=1e-10)
    np.testing.assert_allclose(angular_distance(q0, q1, degrees=True)[far], np.degrees(naive[far]),
                               rtol=0, atol=1e-8)
    # close pairs against scipy (stable everywhere) and the sign symmetry
    close = q0 * 1.1 + rng.normal(size=q0.shape) * 1e-6
    sp = (ref.to_scipy(q0).inv() * ref.to_scipy(close)).magnitude()
    np.testing.assert_allclose(angular_distance(q0, close), sp, rtol=1e-6, atol=1e-14)
    np.testing.assert_allclose(angular_distance(q0, -close), sp, rtol=1e-6, atol=1e-14)
    np.testing.assert_array_equal(angular_distance(q0, q0), 0.0)


@settings(HSET, max_examples=40)
@given(seed=seeds, n=st.integers(1, 200))
def test_hemisphere_continuous(seed, n):
    rng = np.random.default_rng(seed)
    q = _random_quats(rng, n)
    if n > 6:  # exact negations and repeated rows
        q[3] = -q[2]
        q[4] = q[3]
        q[6] = -q[5] * 2.0
    got = hemisphere_continuous(q)
    np.testing.assert_array_equal(got, ref.hemisphere_continuous_ref(q))
    np.testing.assert_array_equal(np.abs(got), np.abs(q))


ZERO_DOT = np.array(
    [
        [-0.6, 0.2, 0.7, 0.3],  # <e0, q0> < 0: sample 1 is negated
        [1.0, 0.0, 0.0, 0.0],  # e0
        [0.0, 1.0, 0.0, 0.0],  # e1: dot with the continuous sample 1 (-e0) is exactly 0 (-0.0)
        [0.1, 0.9, 0.1, 0.0],
        [0.2, 0.8, 0.1, 0.1],
    ]
)


def test_hemisphere_continuous_exact_zero_dot():
    """Spec: a sample is negated only when its dot product with the (already continuous) previous
    sample is NEGATIVE.  Sample 2 (e1) has dot product exactly 0 with the continuous sample 1
    (which is -e0), so it must stay as it is; so must everything after it."""
    expected = ZERO_DOT.copy()
    expected[1] = -expected[1]
    np.testing.assert_array_equal(ref.hemisphere_continuous_ref(ZERO_DOT), expected)
    np.testing.assert_array_equal(hemisphere_continuous(ZERO_DOT), expected)


@pytest.mark.parametrize("method", ["cplr", "swing"])
def test_zero_dot_hemisphere_in_compress(method):
    """The same exact-zero case through ``compress`` (CPLR/Swing points live in the
    hemisphere-continuous domain, so the sign choice is visible in their values)."""
    sig = Signal(np.arange(5, dtype=np.float64) * 0.02, ZERO_DOT, "quaternion")
    for th in (0.0, 1e-3, 10.0):
        assert_same_as_reference(sig, method, th, None)


def test_reference_slerp_matches_scipy():
    """The reference's own SLERP (used by the anglesw reference) is itself right."""
    rng = np.random.default_rng(5)
    for _ in range(50):
        q0, q1 = _random_quats(rng, 2)
        f = rng.uniform(0, 1, 7)
        own = ref.slerp_ref(q0, q1, f)
        sp = Slerp([0.0, 1.0], ref.to_scipy(np.stack([q0, q1])))(f)
        assert np.all((sp.inv() * ref.to_scipy(own)).magnitude() < 1e-12)


# --------------------------------------------------------------------------------------------
# 5. real data
# --------------------------------------------------------------------------------------------

XIO = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "imu" / "xio-lower-body"
REAL_THRESHOLDS = np.concatenate([[0.0], np.logspace(-6, 3, 204)])
SENSORS = ("left-foot", "left-lower-leg", "left-upper-leg", "pelvis", "right-foot", "right-lower-leg",
           "right-upper-leg")


def load_xio_quaternions(path: Path) -> Signal:
    with open(path) as fh:
        header = fh.readline().strip()
    assert header == "Timestamp (us),W,X,Y,Z", header
    data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64)
    return Signal(data[:, 0] / 1e6, data[:, 1:5], "quaternion", name=path.parent.name)


@pytest.fixture(scope="module")
def real_signals() -> dict[str, Signal]:
    if not XIO.is_dir():
        pytest.skip(f"real data folder absent: {XIO}")
    files = sorted(XIO.glob("*/Quaternion.csv"))
    if not files:
        pytest.skip(f"no */Quaternion.csv under {XIO}")
    return {f.parent.name: load_xio_quaternions(f) for f in files}


def _real(real_signals, sensor) -> Signal:
    if sensor not in real_signals:
        pytest.skip(f"{sensor}/Quaternion.csv absent")
    return real_signals[sensor]


@pytest.mark.shared
@pytest.mark.parametrize("sensor", SENSORS)
def test_real_sw_equals_fastsw_all_thresholds(real_signals, sensor):
    sig = _real(real_signals, sensor)
    assert len(sig) > 800
    for th in REAL_THRESHOLDS:
        a = compress(sig, "sw", float(th), 1000)
        b = compress(sig, "fastsw", float(th), 1000)
        np.testing.assert_array_equal(a.indices, b.indices, err_msg=f"{sensor} th={th!r}")
        np.testing.assert_array_equal(a.values, b.values)


@pytest.mark.shared
@pytest.mark.parametrize("sensor", SENSORS)
def test_real_reference_sw(real_signals, sensor):
    sig = _real(real_signals, sensor)
    n_points = []
    for th in REAL_THRESHOLDS[::10]:
        comp = assert_same_as_reference(sig, "sw", float(th), 1000)
        check_guarantees(sig, comp, "sw", float(th), 1000)
        n_points.append(comp.n_points)
    assert n_points[0] == len(sig) or n_points[0] > n_points[-1]  # the sweep really compresses
    assert n_points[-1] < len(sig) // 10


@pytest.mark.shared
@pytest.mark.parametrize("sensor", SENSORS)
def test_real_reference_other_methods(real_signals, sensor):
    sig = _real(real_signals, sensor)
    for method, ths in (
        ("cplr", REAL_THRESHOLDS[1::40]),
        ("swing", np.logspace(-5, -0.5, 6)),
        ("anglesw", (0.05, 0.5, 2.0, 10.0)),
    ):
        for th in ths:
            for L in (None, 50):
                comp = assert_same_as_reference(sig, method, float(th), L)
                check_guarantees(sig, comp, method, float(th), L)


@pytest.mark.shared
@pytest.mark.parametrize("sensor", SENSORS)
@pytest.mark.parametrize("method", METHODS)
def test_real_max_angle(real_signals, sensor, method):
    sig = _real(real_signals, sensor)
    for deg in DEGS:
        comp = compress_to(sig, method, max_angle=deg)
        assert not ref.structure_problems(sig.times, len(sig), comp.indices, comp.times)
        dev = ref.scipy_deviation_deg(sig.times, sig.values, comp.times, comp.values)
        assert dev.max() <= deg + 1e-7, f"{sensor} {method}: max deviation {dev.max()!r}° > {deg}°"
        assert comp.n_points < len(sig)  # and it does compress


# --------------------------------------------------------------------------------------------
# 6. the floating-point tie between SW and fastSW
# --------------------------------------------------------------------------------------------


def _smallest_accepting_threshold(sig3: Signal, method: str) -> float:
    """The computed SSR of the segment 0 -> 2 of a 3-sample signal, read off the public API:
    the smallest float threshold at which sample 2 joins (points [0, 2] instead of [0, 1, 2])."""

    def joins(th: float) -> bool:
        return compress(sig3, method, th).n_points == 2

    assert not joins(0.0)
    hi = 1.0
    while not joins(hi):
        hi *= 4.0
    lo_bits = 0
    hi_bits = int(np.float64(hi).view(np.int64))
    while hi_bits - lo_bits > 1:  # non-negative doubles are ordered like their bit patterns
        mid = (lo_bits + hi_bits) // 2
        if joins(float(np.int64(mid).view(np.float64))):
            hi_bits = mid
        else:
            lo_bits = mid
    return float(np.int64(hi_bits).view(np.float64))


def test_sw_fastsw_float_tie():
    """SW (Eq. 5, residuals squared) and fastSW (Eq. 13, updated means) are mathematically equal
    but round differently.  Find a segment whose two computed SSRs differ by a few ulps, put the
    threshold between them, and check the outputs then differ only by that one cut moving by one
    sample (and agree again once the threshold covers both values)."""
    rng = np.random.default_rng(20240611)
    for _attempt in range(400):
        t = np.sort(rng.uniform(0.0, 1.0, 4))
        t[1:] += np.arange(1, 4) * 0.05
        x = rng.normal(size=(4, 3))
        # sample 3 continues the line 1 -> 2 almost exactly, so the segment 1 -> 3 is nearly free
        x[3] = x[2] + (x[2] - x[1]) * (t[3] - t[2]) / (t[2] - t[1]) + rng.normal(size=3) * 1e-9
        sig3 = Signal(t[:3], x[:3], "vector")
        s_sw = _smallest_accepting_threshold(sig3, "sw")
        s_fast = _smallest_accepting_threshold(sig3, "fastsw")
        exact = ref._sw_ssr(t, x, 0, 2)
        # both are the same quantity up to rounding
        assert abs(s_sw - exact) <= 1e-12 * exact and abs(s_fast - exact) <= 1e-12 * exact
        if s_sw == s_fast:
            continue
        sig = Signal(t, x, "vector")
        th = min(s_sw, s_fast)
        a = compress(sig, "sw", th).indices
        b = compress(sig, "fastsw", th).indices
        if not (a.shape == b.shape and np.count_nonzero(a != b) == 1):
            continue  # this draw does not show the "moved cut" pattern; try another
        k = int(np.flatnonzero(a != b)[0])
        assert abs(int(a[k]) - int(b[k])) == 1
        # the method with the smaller computed SSR accepted sample 2 (cut at 2), the other cut at 1
        small, large = (a, b) if s_sw < s_fast else (b, a)
        assert small.tolist() == [0, 2, 3] and large.tolist() == [0, 1, 3]
        # once the threshold covers both computed values they agree again
        th2 = max(s_sw, s_fast)
        np.testing.assert_array_equal(compress(sig, "sw", th2).indices, compress(sig, "fastsw", th2).indices)
        return
    pytest.fail("no SW/fastSW float tie found in 400 random draws")
