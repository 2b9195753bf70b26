"""Actions named across takes (segment/naming.py) and the frame-level cluster scores
(segment/cluster_metrics.py): metrics against brute force, scikit-learn and hand cases; the clustering
against synthetic takes whose classes are known; input checks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.signal import lfilter
from sklearn.metrics import normalized_mutual_info_score

from mocapkit.errors import InvalidParameterError
from mocapkit.segment.cluster_metrics import (
    best_matching,
    contingency,
    frame_accuracy,
    nmi,
    purity,
)
from mocapkit.segment.naming import _mmd_matrix, class_letter, name_actions

# --------------------------------------------------------------------------------------------------
# metrics
# --------------------------------------------------------------------------------------------------


def brute_accuracy(found, ref) -> float:
    """Best one-to-one matching by enumerating every injective assignment of found classes to labels."""
    fv, rv = sorted(set(found)), sorted(set(ref))
    best = 0
    slots = rv + [None] * len(fv)  # None: the class is left unmatched
    for perm in itertools.permutations(slots, len(fv)):
        if len({p for p in perm if p is not None}) != sum(p is not None for p in perm):
            continue
        m = dict(zip(fv, perm, strict=True))
        best = max(best, sum(m[f] == r for f, r in zip(found, ref, strict=True)))
    return best / len(found)


@pytest.mark.parametrize("seed", range(30))
def test_frame_accuracy_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 25))
    found = rng.integers(0, int(rng.integers(1, 5)), n).tolist()
    ref = [f"L{v}" for v in rng.integers(0, int(rng.integers(1, 5)), n)]
    assert frame_accuracy(found, ref) == pytest.approx(brute_accuracy(found, ref), abs=1e-12)
    m = best_matching(found, ref)
    assert len(set(m.values())) == len(m)  # one-to-one
    assert sum(m.get(f) == r for f, r in zip(found, ref, strict=True)) / n == pytest.approx(brute_accuracy(found, ref))


def test_frame_accuracy_hand_cases():
    # a class split in two: the best matching keeps its larger half
    assert frame_accuracy(["A", "A", "B", "B", "C", "C"], [1, 1, 1, 1, 2, 2]) == pytest.approx(4 / 6)
    # more labels than classes
    assert frame_accuracy([0, 0, 0, 0], ["x", "y", "y", "z"]) == pytest.approx(2 / 4)
    # renaming does not matter
    assert frame_accuracy(["B", "A", "A"], ["walk", "run", "run"]) == 1.0


def test_purity_hand_cases():
    assert purity([0, 0, 0, 1, 1, 1], ["a", "a", "b", "b", "b", "b"]) == pytest.approx(5 / 6)
    assert purity([0, 1, 2, 3], ["a", "a", "b", "b"]) == 1.0  # over-splitting is pure...
    assert frame_accuracy([0, 1, 2, 3], ["a", "a", "b", "b"]) == pytest.approx(0.5)  # ...but not accurate
    assert purity([0, 0, 0, 0], ["a", "a", "b", "c"]) == pytest.approx(0.5)


def test_nmi_hand_cases():
    assert nmi([0, 0, 1, 1], ["a", "a", "b", "b"]) == pytest.approx(1.0)
    assert nmi([0, 0, 1, 1], ["a", "b", "a", "b"]) == pytest.approx(0.0, abs=1e-12)  # independent
    assert nmi([5, 5, 5], ["x", "x", "x"]) == 1.0
    assert nmi([0, 0, 0, 0], ["a", "a", "b", "b"]) == 0.0
    # found = {0,0,1,1,1,1}, ref = {a,a,a,a,b,b}: I = H(F) + H(R) - H(F, R), by hand
    p = np.array([2, 2, 2]) / 6  # joint cells (0,a), (1,a), (1,b)
    h_joint = -(p * np.log(p)).sum()
    h = -(1 / 3 * np.log(1 / 3) + 2 / 3 * np.log(2 / 3))
    expected = (2 * h - h_joint) / h
    assert nmi([0, 0, 1, 1, 1, 1], ["a", "a", "a", "a", "b", "b"]) == pytest.approx(expected)


@pytest.mark.parametrize("seed", range(30))
def test_nmi_equals_sklearn(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(1, 60))
    found = rng.integers(0, int(rng.integers(1, 7)), n)
    ref = rng.integers(0, int(rng.integers(1, 7)), n)
    assert nmi(found, ref) == pytest.approx(normalized_mutual_info_score(ref, found), abs=1e-10)


def test_contingency_counts():
    c, fv, rv = contingency(["B", "A", "B", "B"], [1, 1, 2, 2])
    assert fv == ["B", "A"] and rv == [1, 2]
    assert c.tolist() == [[1, 2], [1, 0]]


@pytest.mark.parametrize("found, ref", [([0, 1], [0]), ([], []), ([[0, 1]], [[0, 1]]), ([0, [1]], [0, 1])])
def test_metrics_refuse_bad_input(found, ref):
    for f in (purity, nmi, frame_accuracy):
        with pytest.raises(InvalidParameterError):
            f(found, ref)


# --------------------------------------------------------------------------------------------------
# MMD against a naive double loop
# --------------------------------------------------------------------------------------------------


def naive_mmd(a, b, gamma):
    """Square root of the biased (V-statistic) MMD², every kernel term summed in Python."""
    def k(x, y):
        return np.exp(-gamma * ((x - y) ** 2).sum())

    m, n = len(a), len(b)
    kaa = sum(k(a[i], a[j]) for i in range(m) for j in range(m)) / m**2
    kbb = sum(k(b[i], b[j]) for i in range(n) for j in range(n)) / n**2
    kab = sum(k(a[i], b[j]) for i in range(m) for j in range(n)) / (m * n)
    return np.sqrt(max(kaa + kbb - 2 * kab, 0.0))


def test_mmd_matrix_equals_naive():
    rng = np.random.default_rng(7)
    parts = [rng.normal(i * 0.7, 1.0, (int(rng.integers(2, 12)), 3)) for i in range(4)]
    d = _mmd_matrix(parts, 0.3)
    for i in range(4):
        assert d[i, i] == 0.0
        for j in range(4):
            if i != j:
                assert d[i, j] == pytest.approx(naive_mmd(parts[i], parts[j], 0.3), abs=1e-9)


# --------------------------------------------------------------------------------------------------
# clustering on synthetic takes
# --------------------------------------------------------------------------------------------------


def process(rng, d=4):
    """A stationary process: per-channel offset, amplitude and phase of one period, AR(1) noise."""
    return (rng.normal(0, 1, d), rng.uniform(0.3, 1.5, d), rng.uniform(0, 2 * np.pi, d), rng.uniform(60, 240))


def segment(rng, p, n):
    off, amp, ph, period = p
    t = np.arange(n)[:, None]
    x = off + amp * np.sin(2 * np.pi * t / period + ph + rng.uniform(0, 2 * np.pi))
    e = lfilter([1.0], [1.0, -0.8], rng.normal(0, 0.1, (n, off.size)), axis=0)  # AR(1) noise
    return x + e


def take_from(rng, procs, order):
    segs = [segment(rng, procs[c], int(rng.integers(300, 800))) for c in order]
    return np.concatenate(segs), np.cumsum([len(s) for s in segs])[:-1]


def expected_letters(order):
    seen: dict = {}
    return tuple(class_letter(seen.setdefault(c, len(seen))) for c in order)


@pytest.mark.parametrize("spread", ["blocks", "halves"])
@pytest.mark.parametrize("seed", range(5))
def test_three_distinct_processes_recovered(seed, spread):
    """Three clearly different processes (offsets 3 apart), segments in a random order: the classes
    and the letters are exactly the processes in order of appearance."""
    rng = np.random.default_rng(seed)
    procs = [process(rng) for _ in range(3)]
    procs = [(p[0] + 3.0 * i, *p[1:]) for i, p in enumerate(procs)]
    order = [0, 1, 0, 2] + rng.integers(0, 3, 5).tolist()
    x, cuts = take_from(rng, procs, order)
    r = name_actions(x, cuts, spread=spread)
    assert r.letters[0] == expected_letters(order)
    assert r.letters[0][:4] == ("A", "B", "A", "C")
    assert r.n_classes == 3 and r.rule == "threshold"
    # frame level: the per-frame letters score 1 against the per-frame process
    ref = np.repeat(order, np.diff(r.bounds[0]))
    assert frame_accuracy(r.frame_letters(0), ref) == 1.0
    assert r.frame_classes(0).shape == (x.shape[0],)


@pytest.mark.parametrize("spread", ["blocks", "halves"])
@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_number_of_classes_found_on_synthetic(k, spread):
    """Random processes (not made distinct on purpose), 3 segments each in random order: the
    threshold rule finds exactly k classes in at least 80 % of 20 draws, with either spread, and the
    frame accuracy averages 0.9 or more."""
    rng = np.random.default_rng(1000 + k)
    hits = 0
    accs = []
    for _ in range(20):
        procs = [process(rng) for _ in range(k)]
        order = rng.permutation(np.repeat(np.arange(k), 3))
        x, cuts = take_from(rng, procs, order)
        r = name_actions(x, cuts, spread=spread)
        hits += r.n_classes == k
        accs.append(frame_accuracy(r.frame_classes(0), np.repeat(order, np.diff(r.bounds[0]))))
    assert hits >= 16, f"k={k}: right number of classes in {hits}/20 draws"
    assert np.mean(accs) >= 0.9


def test_block_spread_ignores_the_cuts_and_survives_short_segments():
    """The block spread is a property of the takes, not of the cuts; cutting three distinct processes
    every 150 frames (segments shorter than most of the true ones) still names >= 90 % of the frames
    right, while the half spread grows as the segments shrink."""
    rng = np.random.default_rng(21)
    procs = [(p[0] + 3.0 * i, *p[1:]) for i, p in enumerate(process(rng) for _ in range(3))]
    order = [0, 1, 2, 0, 2, 1]
    x, cuts = take_from(rng, procs, order)
    truth = np.repeat(order, np.diff(np.concatenate([[0], cuts, [x.shape[0]]])))
    regular = np.arange(150, x.shape[0], 150)
    a, b = name_actions(x, cuts), name_actions(x, regular)
    assert a.spread == pytest.approx(b.spread, rel=1e-12)
    assert frame_accuracy(b.frame_classes(0), truth) >= 0.9
    assert name_actions(x, regular, spread="halves").spread > name_actions(x, cuts, spread="halves").spread


def test_same_letters_across_takes():
    rng = np.random.default_rng(3)
    procs = [(p[0] + 3.0 * i, *p[1:]) for i, p in enumerate(process(rng) for _ in range(3))]
    x1, c1 = take_from(rng, procs, [2, 0, 2])
    x2, c2 = take_from(rng, procs, [1, 0, 1, 2])
    r = name_actions([x1, x2], [c1, c2])
    assert r.letters == (("A", "B", "A"), ("C", "B", "C", "A"))
    assert r.distances.shape == (7, 7)
    np.testing.assert_allclose(r.distances, r.distances.T)


def test_fixed_number_of_classes_and_silhouette():
    rng = np.random.default_rng(5)
    procs = [(p[0] + 3.0 * i, *p[1:]) for i, p in enumerate(process(rng) for _ in range(3))]
    order = [0, 1, 2, 0, 1, 2]
    x, cuts = take_from(rng, procs, order)
    assert name_actions(x, cuts, n_classes=2).n_classes == 2
    assert name_actions(x, cuts, n_classes=1).letters[0] == ("A",) * 6
    s = name_actions(x, cuts, rule="silhouette")
    assert s.rule == "silhouette" and s.letters[0] == expected_letters(order)
    one = name_actions(x[: cuts[0]], [])
    assert one.letters == (("A",),) and one.n_classes == 1


def test_class_letters():
    assert [class_letter(i) for i in (0, 1, 25, 26, 27, 51, 52, 701, 702)] == [
        "A", "B", "Z", "AA", "AB", "AZ", "BA", "ZZ", "AAA"]
    with pytest.raises(InvalidParameterError):
        class_letter(-1)


def test_dtw_option():
    """With the DTW of segment/similarity.py the distinct processes are recovered."""
    rng = np.random.default_rng(11)
    procs = [(p[0] + 3.0 * i, *p[1:]) for i, p in enumerate(process(rng) for _ in range(3))]
    order = [0, 1, 0, 2, 1]
    x, cuts = take_from(rng, procs, order)
    r = name_actions(x, cuts, distance="dtw", max_frames=100)
    assert r.letters[0] == expected_letters(order)


def test_dtw_missing_is_a_clear_error(monkeypatch):
    """An installation without segment/similarity.py refuses distance="dtw" with a message naming it."""
    import sys

    monkeypatch.setitem(sys.modules, "mocapkit.segment.similarity", None)  # import now raises ImportError
    with pytest.raises(InvalidParameterError, match="dtw"):
        name_actions(X100, [50], distance="dtw")


# --------------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------------


X100 = np.random.default_rng(0).normal(size=(100, 4))


@pytest.mark.parametrize(
    "feats, cuts",
    [
        (X100, [0, 50]),  # cut at frame 0
        (X100, [50, 100]),  # cut at the end
        (X100, [150]),  # outside
        (X100, [-5]),
        (X100, [60, 40]),  # not increasing
        (X100, [40, 40]),
        (X100, [40.5]),
        (X100, [True]),
        (X100, ["40"]),
        ([], []),  # no take
        ([X100], []),  # takes and cut lists differ in number
        ([X100, X100], [[50]]),
        (np.zeros((0, 4)), []),  # empty take
        ([X100, X100[:, :3]], [[50], [50]]),  # different feature counts
        (np.where(np.arange(400).reshape(100, 4) == 7, np.nan, X100), [50]),
        (X100[:15], [5, 10]),  # a take shorter than 16 frames: no spread measurable
    ],
)
def test_bad_input_refused(feats, cuts):
    with pytest.raises(InvalidParameterError):
        name_actions(feats, cuts)


def test_short_segments():
    """Segments of 5 frames: named with the block spread (the take is long enough), refused with the
    half spread (no segment of 16 frames)."""
    r = name_actions(X100[:20], [5, 10, 15])
    assert len(r.letters[0]) == 4
    with pytest.raises(InvalidParameterError, match="16 frames"):
        name_actions(X100[:20], [5, 10, 15], spread="halves")


@pytest.mark.parametrize("opts", [{"distance": "euclid"}, {"rule": "gap"}, {"n_classes": 0}, {"n_classes": 5},
                                  {"threshold_scale": -1.0}, {"max_classes": 1}, {"gamma": float("nan")},
                                  {"spread": "quartiles"}, {"block": 0}, {"block": 2.5}])
def test_bad_options_refused(opts):
    with pytest.raises(InvalidParameterError):
        name_actions(X100, [30, 60], **opts)


# --------------------------------------------------------------------------------------------------
# real data
# --------------------------------------------------------------------------------------------------


def test_86_01_reference_cuts_named_as_haca(shared_data):
    """86_01 with its reference cuts: walk jump walk punch walk leg_kick punch -> A B A C A D C."""
    from mocapkit.evaluation.segmentation import load_take

    take = load_take(shared_data / "cmu", "86_01")
    r = name_actions(take.limbs, take.ref.cuts)
    assert " ".join(r.letters[0]) == "A B A C A D C"
    assert frame_accuracy(r.frame_letters(0), take.actions) == 1.0
