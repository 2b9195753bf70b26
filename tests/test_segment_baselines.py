"""Baseline segmenters: PCA (Barbič et al. 2004), K-means, MLP, ruptures and claspy adapters."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from scipy.signal import lfilter

from mocapkit.errors import InvalidParameterError, InvalidSignalError
from mocapkit.segment import (
    BASELINES,
    ClaSPSegmenter,
    KernelCPDSegmenter,
    KMeansSegmenter,
    MLPSegmenter,
    PCASegmenter,
    PELTSegmenter,
)
from mocapkit.segment.base import Segmenter
from mocapkit.segment.labelruns import merge_short_runs, mode_filter
from mocapkit.segment.pelt import _prefix_cost

# --------------------------------------------------------------------------------------------------
# a piecewise-stationary synthetic signal
# --------------------------------------------------------------------------------------------------

N_TYPES = 5
FREQS = (0.010, 0.016, 0.023, 0.031, 0.040)  # cycles per sample of each regime's oscillation
PHIS = (0.9, 0.6, 0.8, 0.7, 0.85)  # AR(1) coefficient of each regime's second source


def _helmert(n: int) -> np.ndarray:
    """The ``(n - 1, n)`` Helmert rows: an orthonormal basis of the zero-sum vectors in closed form.

    (The singular vectors of the centring matrix, used before, are any basis of that space, as its
    singular value 1 is repeated: LAPACK builds chose different ones, and the test signal with them.)"""
    h = np.zeros((n - 1, n))
    for k in range(1, n):
        h[k - 1, :k] = 1.0
        h[k - 1, k] = -float(k)
        h[k - 1] /= np.sqrt(k * (k + 1.0))
    return h


def _orthonormal(a: np.ndarray) -> np.ndarray:
    """Q of the QR factorisation of ``a`` with R's diagonal positive (unique; LAPACK leaves the signs open)."""
    q, r = np.linalg.qr(a)
    return q * np.where(np.diag(r) < 0, -1.0, 1.0)


def _regime_types(d: int, seed: int = 7, spread: float = 4.0) -> list[tuple]:
    """Five regimes: means at the vertices of a regular simplex (pairwise distance ``spread *
    sqrt(5/4)``), each regime living in its own random 2-D subspace of the ``d`` channels."""
    rng = np.random.default_rng(seed)
    centred = np.eye(N_TYPES) - 1.0 / N_TYPES
    simplex = centred @ _helmert(N_TYPES).T
    types = []
    for t in range(N_TYPES):
        basis = _orthonormal(rng.normal(size=(d, d)))[:, :2]
        mean = np.zeros(d)
        mean[: N_TYPES - 1] = spread * simplex[t] / np.linalg.norm(simplex[t])
        types.append((mean, basis, FREQS[t], PHIS[t]))
    return types


def _draw(seed: int, d: int = 4, types: list[int] | None = None, noise: float = 0.1):
    """Regimes of 300--800 samples: ``mean + [oscillation, AR(1)] @ basis.T + noise``.

    Returns the signal, the true cuts and the per-sample regime label. Without ``types``, four
    regimes are drawn (no regime follows itself).
    """
    bank = _regime_types(d)
    rng = np.random.default_rng(seed)
    if types is None:
        types = [int(rng.integers(N_TYPES))]
        while len(types) < 4:
            t = int(rng.integers(N_TYPES))
            if t != types[-1]:
                types.append(t)
    lengths = rng.integers(300, 801, size=len(types))
    parts, labels = [], []
    for t, n in zip(types, lengths, strict=True):
        mean, basis, freq, phi = bank[t]
        phase = rng.uniform(0.0, 2.0 * np.pi)
        osc = 1.5 * np.sqrt(2.0) * np.sin(2.0 * np.pi * freq * np.arange(n) + phase)
        ar = lfilter([np.sqrt(1.0 - phi**2)], [1.0, -phi], rng.normal(size=n))
        parts.append(mean + np.column_stack([osc, ar]) @ basis.T + noise * rng.normal(size=(n, d)))
        labels += [t] * n
    return np.vstack(parts), np.cumsum(lengths)[:-1], np.asarray(labels)


def _match(pred: np.ndarray, true: np.ndarray, tol: int) -> tuple[int, int]:
    """(true cuts without a predicted cut within ``tol``, predicted cuts without a true one)."""
    missed = sum(1 for c in true if pred.size == 0 or np.min(np.abs(pred - c)) > tol)
    spurious = sum(1 for p in pred if np.min(np.abs(true - p)) > tol)
    return missed, spurious


def _check_contract(cuts: np.ndarray, n: int) -> None:
    assert isinstance(cuts, np.ndarray)
    assert cuts.dtype == np.int64
    assert cuts.ndim == 1
    assert np.all(np.diff(cuts) > 0)
    assert np.all((cuts > 0) & (cuts < n))


TOL = 30  # samples; the shortest regime of the test signal has 308 samples (5% would be 15)


@pytest.fixture(scope="module")
def signal():
    x, cuts, labels = _draw(0)
    assert cuts.tolist() == [454, 774, 1111]  # the generator itself has not changed
    return x, cuts, labels


@pytest.fixture(scope="module")
def training_takes():
    """Two other draws of the generator, every regime type present in each."""
    a = _draw(101, types=[0, 1, 2, 3, 4])
    b = _draw(102, types=[4, 2, 0, 3, 1])
    return [(a[0], a[2]), (b[0], b[2])]


def _factories(train):
    return {
        "pca": lambda: PCASegmenter(),
        "kmeans": lambda: KMeansSegmenter(),
        "mlp": lambda: MLPSegmenter(train=train),
        "kernelcpd": lambda: KernelCPDSegmenter(),
        "pelt": lambda: PELTSegmenter(),
        "clasp": lambda: ClaSPSegmenter(),
    }


# --------------------------------------------------------------------------------------------------
# every baseline finds the cuts of the synthetic signal
# --------------------------------------------------------------------------------------------------

# measured on the test signal: every method finds the three cuts within 11 samples, no spurious cut
MAX_SPURIOUS = 1


@pytest.mark.parametrize("name", ["pca", "kmeans", "mlp", "kernelcpd", "pelt", "clasp"])
def test_finds_true_cuts(name, signal, training_takes):
    x, true, _ = signal
    cuts = _factories(training_takes)[name]().fit_predict(x)
    _check_contract(cuts, len(x))
    missed, spurious = _match(cuts, true, TOL)
    assert missed == 0, f"{name}: {cuts} vs {true}"
    assert spurious <= MAX_SPURIOUS, f"{name}: {cuts} vs {true}"


def test_pca_finds_subspace_changes_in_8_channels():
    """Barbič's setting: each regime lives in its own 2-D subspace of 8 channels."""
    x, true, _ = _draw(1, d=8)
    seg = PCASegmenter()
    cuts = seg.fit_predict(x)
    assert _match(cuts, true, TOL) == (0, 0), f"{cuts} vs {true}"
    assert [scan["r"] for scan in seg.scans_] == [2, 2, 2, 2]  # 2 latent sources per regime
    # a cut is declared after the change, within one step plus the noise of the derivative
    assert np.all(cuts - true >= 0) and np.all(cuts - true <= 10)


def test_pca_sees_a_pure_change_of_subspace():
    """Same mean, same sources, same variance: only the 2-D subspace changes at sample 600."""
    rng = np.random.default_rng(3)
    d, n = 6, 1200
    q1 = _orthonormal(rng.normal(size=(d, d)))[:, :2]
    q2 = _orthonormal(rng.normal(size=(d, d)))[:, :2]
    src = lfilter([0.3], [1.0, -0.95], rng.normal(size=(n, 2)), axis=0) * 3.0
    x = np.vstack([src[:600] @ q1.T, src[600:] @ q2.T]) + 0.05 * rng.normal(size=(n, d))
    cuts = PCASegmenter().fit_predict(x)
    assert _match(cuts, np.array([600]), TOL) == (0, 0), cuts


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_ruptures_adapters_over_several_draws(seed):
    """KernelCPD and PELT with their a-priori penalties on other draws (measured: exact on 20 of 20
    draws, within 5 samples)."""
    x, true, _ = _draw(seed)
    for seg in (KernelCPDSegmenter(), PELTSegmenter(), PELTSegmenter(model="rbf")):
        cuts = seg.fit_predict(x)
        assert _match(cuts, true, TOL) == (0, 0), f"{type(seg).__name__}: {cuts} vs {true}"


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_mlp_over_several_draws(seed, training_takes):
    x, true, labels = _draw(seed)
    seg = MLPSegmenter(train=training_takes)
    cuts = seg.fit_predict(x)
    assert _match(cuts, true, TOL) == (0, 0), f"{cuts} vs {true}"
    assert np.mean(seg.labels_ == labels) > 0.97


# --------------------------------------------------------------------------------------------------
# known number of cuts
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("cls", [KernelCPDSegmenter, PELTSegmenter, ClaSPSegmenter])
def test_n_cuts_true_count_finds_the_cuts(cls, signal):
    x, true, _ = signal
    cuts = cls(n_cuts=3).fit_predict(x)
    _check_contract(cuts, len(x))
    assert cuts.size == 3
    assert _match(cuts, true, TOL) == (0, 0), cuts


@pytest.mark.parametrize("cls", [KernelCPDSegmenter, PELTSegmenter, ClaSPSegmenter])
@pytest.mark.parametrize("k", [0, 1, 5])
def test_n_cuts_exact_count(cls, k, signal):
    x, true, _ = signal
    cuts = cls(n_cuts=k).fit_predict(x)
    _check_contract(cuts, len(x))
    assert cuts.size == k
    if k == 1:  # the strongest change is one of the true ones
        assert np.min(np.abs(true - cuts[0])) <= TOL


def test_pelt_n_cuts_off_the_hull_is_still_exact():
    """Counts that no penalty reaches are obtained by removing the cheapest cuts."""
    x, _, _ = _draw(2)
    for k in range(0, 9):
        assert PELTSegmenter(n_cuts=k).fit_predict(x).size == k


def test_n_cuts_capped_by_min_size():
    x, _, _ = _draw(0)  # 1,419 samples
    cuts = KernelCPDSegmenter(n_cuts=50, min_size=120).fit_predict(x)
    assert cuts.size == len(x) // 120 - 1
    assert np.all(np.diff(np.concatenate(([0], cuts, [len(x)]))) >= 120)


# --------------------------------------------------------------------------------------------------
# downsampling
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        lambda: KernelCPDSegmenter(downsample=3),
        lambda: PELTSegmenter(downsample=3),
        # on every third sample claspy's own window (27) makes its shortest segment (5 windows)
        # too long for more than one cut; a window of 10 analysed samples leaves room for three
        lambda: ClaSPSegmenter(downsample=3, n_cuts=3, window_size=10),
    ],
    ids=["kernelcpd", "pelt", "clasp"],
)
def test_downsample_maps_cuts_back(make, signal):
    x, true, _ = signal
    cuts = make().fit_predict(x)
    _check_contract(cuts, len(x))
    assert np.all(cuts % 3 == 0)
    assert _match(cuts, true, TOL) == (0, 0), cuts


def test_downsample_is_the_same_run_on_every_kth_frame(signal):
    """downsample=3 equals running on x[::3] (with min_size in analysed frames) and multiplying by 3."""
    x, _, _ = signal
    for big, small in (
        (KernelCPDSegmenter(downsample=3, min_size=120), KernelCPDSegmenter(min_size=40)),
        (PELTSegmenter(downsample=3, min_size=120), PELTSegmenter(min_size=40)),
    ):
        assert big.fit_predict(x).tolist() == (3 * small.fit_predict(x[::3])).tolist()


def test_min_size_is_in_input_frames():
    x, _, _ = _draw(0)
    for seg in (
        KernelCPDSegmenter(pen=1e-3, min_size=200, downsample=4),
        PELTSegmenter(pen=1e-3, min_size=200, downsample=4),
    ):
        cuts = seg.fit_predict(x)
        assert cuts.size > 2  # a tiny penalty: as many cuts as allowed
        assert np.all(np.diff(np.concatenate(([0], cuts, [len(x)]))) >= 200 - 4)


# --------------------------------------------------------------------------------------------------
# output contract, constant and bad input, bad parameters
# --------------------------------------------------------------------------------------------------


def _all(train):
    return [make() for make in _factories(train).values()]


def test_contract_on_noise(training_takes):
    rng = np.random.default_rng(5)
    x = rng.normal(size=(900, 4))
    for seg in _all(training_takes):
        cuts = seg.fit_predict(x)
        _check_contract(cuts, len(x))
        assert seg.n_frames_ == len(x)
        np.testing.assert_array_equal(seg.predict(), cuts)


def test_constant_signal_gives_no_cut(training_takes):
    x = np.full((1000, 4), 12.5)
    for seg in _all(training_takes):
        assert seg.fit_predict(x).size == 0, type(seg).__name__


def test_univariate_input_is_accepted():
    """A change of level and of rhythm at sample 600 (claspy z-normalises its windows, so it sees
    the rhythm, the others see the level)."""
    rng = np.random.default_rng(8)
    t = np.arange(600)
    y = np.concatenate([np.sin(2 * np.pi * 0.02 * t), 4.0 + np.sin(2 * np.pi * 0.07 * t)])
    y += 0.3 * rng.normal(size=y.size)
    for seg in (
        PCASegmenter(),
        KMeansSegmenter(),
        KernelCPDSegmenter(),
        PELTSegmenter(),
        ClaSPSegmenter(),
    ):
        cuts = seg.fit_predict(y)
        _check_contract(cuts, len(y))
        assert _match(cuts, np.array([600]), TOL)[0] == 0, (type(seg).__name__, cuts)
        assert _match(cuts, np.array([600]), TOL)[1] <= 1, (type(seg).__name__, cuts)


def test_short_series_gives_no_cut_rather_than_an_error(training_takes):
    x = np.random.default_rng(0).normal(size=(12, 4))
    for seg in _all(training_takes):
        cuts = seg.fit_predict(x)
        _check_contract(cuts, len(x))
        assert cuts.size == 0, (type(seg).__name__, cuts)  # 12 frames are shorter than any minimum segment


@pytest.mark.parametrize(
    "bad",
    [
        np.array([[0.0, 1.0], [np.nan, 1.0], [2.0, 2.0]]),
        np.zeros((10, 2, 2)),
        np.zeros((1, 4)),
        np.zeros((0,)),
        np.array([[np.inf, 0.0]] * 5),
    ],
    ids=["nan", "3d", "one-frame", "empty", "inf"],
)
def test_bad_signal_raises(bad, training_takes):
    for seg in _all(training_takes):
        with pytest.raises(InvalidSignalError):
            seg.fit(bad)


def test_mlp_refuses_other_channel_count(training_takes):
    with pytest.raises(InvalidSignalError):
        MLPSegmenter(train=training_takes).fit(np.zeros((100, 3)))


def test_predict_before_fit_raises(training_takes):
    for seg in _all(training_takes):
        with pytest.raises(InvalidParameterError):
            seg.predict()


@pytest.mark.parametrize(
    "make",
    [
        lambda: PCASegmenter(tau=0.0),
        lambda: PCASegmenter(tau=1.5),
        lambda: PCASegmenter(k_init=1),
        lambda: PCASegmenter(step=0),
        lambda: PCASegmenter(step=7, lag=60),
        lambda: PCASegmenter(R=-1.0),
        lambda: PCASegmenter(min_segment=2.5),
        lambda: KMeansSegmenter(n_clusters=0),
        lambda: KMeansSegmenter(max_clusters=1),
        lambda: KMeansSegmenter(smooth=-1),
        lambda: KMeansSegmenter(min_segment=0),
        lambda: KernelCPDSegmenter(pen=-1.0),
        lambda: KernelCPDSegmenter(pen_scale=0.0),
        lambda: KernelCPDSegmenter(min_size=0),
        lambda: KernelCPDSegmenter(n_cuts=-1),
        lambda: KernelCPDSegmenter(downsample=0),
        lambda: KernelCPDSegmenter(gamma=float("nan")),
        lambda: PELTSegmenter(model="l1"),
        lambda: PELTSegmenter(jump=0),
        lambda: PELTSegmenter(n_cuts=1.5),
        lambda: PELTSegmenter(pen="big"),
        lambda: ClaSPSegmenter(window_size="magic"),
        lambda: ClaSPSegmenter(window_size=1),
        lambda: ClaSPSegmenter(validation="vote"),
        lambda: ClaSPSegmenter(threshold=-0.1),
        lambda: ClaSPSegmenter(excl_radius=2, k_neighbours=3),
        lambda: ClaSPSegmenter(n_cuts=True),
        lambda: ClaSPSegmenter(distance="manhattan"),
        lambda: ClaSPSegmenter(n_jobs=0),
    ],
)
def test_bad_parameters_raise(make):
    with pytest.raises(InvalidParameterError):
        make()


def test_mlp_bad_training_data_raises():
    x = np.zeros((50, 2))
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[])
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[(x, np.zeros(49))])  # label count
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[(x, np.zeros(50))])  # one class only
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[(x, np.arange(50) % 2), (np.zeros((50, 3)), np.arange(50) % 2)])
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[x])
    with pytest.raises(InvalidParameterError):
        MLPSegmenter(train=[(x, np.arange(50) % 2)], hidden_layer_sizes=(0,))
    with pytest.raises(InvalidSignalError):
        MLPSegmenter(train=[(np.full((50, 2), np.nan), np.arange(50) % 2)])


@pytest.mark.parametrize("module", ["ruptures", "claspy.segmentation"])
def test_missing_optional_package_is_explained(module, monkeypatch):
    monkeypatch.setitem(sys.modules, module, None)  # makes ``import module`` fail
    x = np.random.default_rng(0).normal(size=(300, 2))
    segs = [ClaSPSegmenter()] if module.startswith("claspy") else [KernelCPDSegmenter(), PELTSegmenter()]
    for seg in segs:
        with pytest.raises(InvalidParameterError, match=r"pip install 'mocapkit\[segment\]'"):
            seg.fit(x)


def test_registry():
    assert set(BASELINES) == {"pca", "kmeans", "mlp", "kernelcpd", "pelt", "clasp"}
    assert BASELINES["pca"] is PCASegmenter and BASELINES["clasp"] is ClaSPSegmenter
    assert all(issubclass(cls, Segmenter) for cls in BASELINES.values())


# --------------------------------------------------------------------------------------------------
# PCA: the incremental projection error against a from-scratch SVD
# --------------------------------------------------------------------------------------------------


def _naive_error(window: np.ndarray, r: int) -> float:
    centred = window - window.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    return float(np.sum(s[r:] ** 2))


@pytest.mark.parametrize("d", [4, 8, 93])
def test_pca_incremental_error_matches_svd(d):
    x, _, _ = _draw(0, d=d)
    x = x * 30.0 + 90.0  # degrees-like offsets: the moments are accumulated about a reference
    seg = PCASegmenter().fit(x)
    for scan in seg.scans_:
        start, r = scan["start"], scan["r"]
        for j in (0, 11, 47, len(scan["lengths"]) - 1):
            length = int(scan["lengths"][j])
            expected = _naive_error(x[start : start + length], r)
            assert scan["errors"][j] == pytest.approx(expected, rel=1e-8, abs=1e-9)


def test_pca_rank_is_the_tau_fraction():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(2000, 5)) * np.array([10.0, 5.0, 3.0, 0.1, 0.1])
    # variance shares 100 : 25 : 9 : 0.01 : 0.01 -> 2 components explain 93%, 1 explains 74%
    assert PCASegmenter(tau=0.9).fit(x).scans_[0]["r"] == 2
    assert PCASegmenter(tau=0.7).fit(x).scans_[0]["r"] == 1
    assert PCASegmenter(tau=0.99).fit(x).scans_[0]["r"] == 3
    assert PCASegmenter(tau=1.0).fit(x).scans_[0]["r"] == 4  # capped at D - 1


def test_pca_cut_waits_for_warm_up_and_min_segment():
    x, _, _ = _draw(0)
    cuts = PCASegmenter(k_init=240, lag=60, min_segment=120).fit_predict(x)
    bounds = np.concatenate(([0], cuts, [len(x)]))
    assert np.all(np.diff(bounds)[:-1] >= 300)
    assert np.diff(bounds)[-1] >= 120


# --------------------------------------------------------------------------------------------------
# label smoothing, merging, and the prefix-sum cost given to ruptures' PELT
# --------------------------------------------------------------------------------------------------


def test_mode_filter():
    codes = np.array([0, 0, 0, 1, 0, 0, 2, 2, 2, 2, 0, 2, 2])
    out = mode_filter(codes, 3, 3)
    np.testing.assert_array_equal(out, [0, 0, 0, 0, 0, 0, 2, 2, 2, 2, 2, 2, 2])
    np.testing.assert_array_equal(mode_filter(codes, 3, 1), codes)


def test_merge_short_runs_rule():
    # runs: 0 x5, 1 x2, 0 x1, 2 x6
    codes = np.array([0] * 5 + [1] * 2 + [0] * 1 + [2] * 6)
    # the 1-run of 0 (shortest) joins its longer neighbour, the 2s (now 7 long); then the 2-run of
    # 1s joins its longer neighbour, again the 2s
    out = merge_short_runs(codes, 3)
    np.testing.assert_array_equal(out, [0] * 5 + [2] * 9)
    # a short run between two runs of one label makes them one run
    codes = np.array([3] * 4 + [1] * 2 + [3] * 5)
    np.testing.assert_array_equal(merge_short_runs(codes, 3), [3] * 11)
    # on a tie the preceding neighbour wins
    codes = np.array([0] * 4 + [1] * 1 + [2] * 4)
    np.testing.assert_array_equal(merge_short_runs(codes, 2), [0] * 5 + [2] * 4)
    # everything short: one run is left
    assert np.unique(merge_short_runs(np.arange(10) % 3, 50)).size == 1


def test_kmeans_segments_respect_min_segment(signal):
    x, _, _ = signal
    seg = KMeansSegmenter(min_segment=200, smooth=0)
    cuts = seg.fit_predict(x)
    assert np.all(np.diff(np.concatenate(([0], cuts, [len(x)]))) >= 200)
    assert 2 <= seg.n_clusters_ <= 10
    assert seg.silhouettes_ and max(seg.silhouettes_, key=seg.silhouettes_.get) == seg.n_clusters_


def test_mlp_string_labels_and_single_training(training_takes):
    names = np.array(["walk", "jump", "punch", "kick", "run"])
    train = [(x, names[lab]) for x, lab in training_takes]
    seg = MLPSegmenter(train=train, context=5)
    x, true, labels = _draw(0)
    cuts = seg.fit_predict(x)
    assert _match(cuts, true, TOL) == (0, 0)
    assert seg.labels_.dtype.kind == "U"
    assert np.mean(seg.labels_ == names[labels]) > 0.97
    model = seg.model_
    seg.fit(x[:700])
    assert seg.model_ is model  # trained once


@pytest.mark.parametrize("model", ["l2", "rbf"])
def test_prefix_cost_equals_ruptures_cost(model):
    rpt = pytest.importorskip("ruptures")
    z = np.random.default_rng(4).normal(size=(400, 3))
    gamma = None if model == "l2" else 0.37
    fast = _prefix_cost(rpt.base.BaseCost, model, gamma).fit(z)
    ref = rpt.costs.CostL2().fit(z) if gamma is None else rpt.costs.CostRbf(gamma=gamma).fit(z)
    for a, b in [(0, 1), (0, 400), (17, 18), (17, 230), (399, 400), (120, 300)]:
        assert fast.error(a, b) == pytest.approx(ref.error(a, b), rel=1e-9, abs=1e-9)


def test_auto_penalty_is_scale_free(signal):
    x, _, _ = signal
    a = KernelCPDSegmenter().fit(x)
    b = KernelCPDSegmenter().fit(x * 1000.0 - 7.0)
    np.testing.assert_array_equal(a.predict(), b.predict())
    assert a.pen_ == pytest.approx(b.pen_, rel=1e-9)


def test_stationary_series_get_few_cuts():
    """The a-priori penalties on stationary AR(1) series (the regime where a fixed penalty on the
    short-term variance would over-segment)."""
    rng = np.random.default_rng(11)
    x = lfilter([1.0], [1.0, -0.95], rng.normal(size=(3000, 4)), axis=0)
    assert KernelCPDSegmenter().fit_predict(x).size <= 1
    assert PELTSegmenter().fit_predict(x).size <= 1
