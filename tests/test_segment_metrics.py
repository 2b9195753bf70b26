"""Segmentation scores (mocapkit.segment.metrics) and ground-truth loaders (mocapkit.io.skeletal.labels):
hand-computed examples, brute-force references on small random cases, claspy's covering, tiny
good and bad label files, and the real CMU label files."""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest
from claspy.tests.evaluation import covering as claspy_covering

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError
from mocapkit.io.skeletal.labels import (
    MOCAP6_ACTIONS,
    Reference,
    labels_from_frames,
    read_frame_labels,
    read_haca_labels,
)
from mocapkit.segment.metrics import (
    F1Result,
    covering,
    f1_margin,
    frame_agreement,
    segments_from_cuts,
)

# --------------------------------------------------------------------------------------------------
# independent helpers (frame sets, exhaustive enumeration)
# --------------------------------------------------------------------------------------------------


def _frame_sets(cuts, n: int) -> list[set[int]]:
    """Segments as sets of frames, built frame by frame."""
    out: list[set[int]] = [set()]
    cut_set = set(int(c) for c in cuts)
    for f in range(n):
        if f in cut_set:
            out.append(set())
        out[-1].add(f)
    return out


def _brute_ri(pred, ref, n: int) -> float:
    """Best one-to-one matching by enumerating every injective map of the smaller side."""
    A, B = _frame_sets(ref, n), _frame_sets(pred, n)
    if len(A) > len(B):
        A, B = B, A
    best = 0
    for perm in itertools.permutations(range(len(B)), len(A)):
        best = max(best, sum(len(A[i] & B[j]) for i, j in enumerate(perm)))
    return best / n


def _brute_tp(pred, ref, margin, intervals=None) -> int:
    """Size of a maximum matching of hits, by trying every partial assignment of the references."""
    pred, ref = list(pred), list(ref)

    def hit(i: int, p: int) -> bool:
        if abs(p - ref[i]) <= margin:
            return True
        return intervals is not None and intervals[i][0] <= p <= intervals[i][1]

    best = 0
    choices = [None, *range(len(pred))]
    for assign in itertools.product(choices, repeat=len(ref)):
        used = [j for j in assign if j is not None]
        if len(used) != len(set(used)):
            continue
        best = max(best, sum(1 for i, j in enumerate(assign) if j is not None and hit(i, pred[j])))
    return best


def _random_cuts(rng: np.random.Generator, n: int, max_cuts: int) -> list[int]:
    k = int(rng.integers(0, min(max_cuts, n - 1) + 1))
    return sorted(rng.choice(np.arange(1, n), size=k, replace=False).tolist()) if k else []


# --------------------------------------------------------------------------------------------------
# segments_from_cuts and validation
# --------------------------------------------------------------------------------------------------


def test_segments_from_cuts() -> None:
    assert segments_from_cuts([3, 7], 10) == [(0, 3), (3, 7), (7, 10)]
    assert segments_from_cuts([], 4) == [(0, 4)]
    assert segments_from_cuts(np.array([7, 3]), 10) == [(0, 3), (3, 7), (7, 10)]  # any order
    assert segments_from_cuts([2.0], 5) == [(0, 2), (2, 5)]  # integral floats are frames


@pytest.mark.parametrize(
    "cuts,n,match",
    [
        ([0], 10, "inside"),
        ([10], 10, "inside"),
        ([-1], 10, "inside"),
        ([3, 3], 10, "more than once"),
        ([2.5], 10, "integer"),
        ([float("nan")], 10, "integer"),
        (["a"], 10, "integer"),
        ([[1, 2]], 10, "1-D"),
        ([1], 0, "positive integer"),
        ([1], 5.0, "positive integer"),
    ],
)
def test_invalid_cuts(cuts, n, match) -> None:
    for call in (
        lambda: segments_from_cuts(cuts, n),
        lambda: frame_agreement(cuts, [], n),
        lambda: frame_agreement([], cuts, n),
        lambda: f1_margin(cuts, [], n, 1),
        lambda: covering([], cuts, n),
    ):
        with pytest.raises(InvalidParameterError, match=match):
            call()


def test_invalid_margin_and_intervals() -> None:
    with pytest.raises(InvalidParameterError, match="margin"):
        f1_margin([3], [4], 10, -1)
    with pytest.raises(InvalidParameterError, match="margin"):
        f1_margin([3], [4], 10, float("inf"))
    with pytest.raises(InvalidParameterError, match="shape"):
        f1_margin([3], [4], 10, 0, intervals=[[3, 5], [6, 7]])
    with pytest.raises(InvalidParameterError, match="does not contain"):
        f1_margin([3], [4], 10, 0, intervals=[[5, 6]])


# --------------------------------------------------------------------------------------------------
# accuracy RI
# --------------------------------------------------------------------------------------------------


def test_ri_hand_examples() -> None:
    # n=10, ref [0,5)|[5,10), pred [0,4)|[4,10): overlaps [[4,1],[0,5]]; best 4 + 5 -> 9/10
    assert frame_agreement([4], [5], 10) == pytest.approx(0.9)
    # over-segmented: pred [0,2)|[2,5)|[5,8)|[8,10); best [0,5)-[2,5) = 3, [5,10)-[5,8) = 3 -> 6/10
    assert frame_agreement([2, 5, 8], [5], 10) == pytest.approx(0.6)
    # under-segmented: one predicted segment, ref [0,3)|[3,6)|[6,10): only the largest, 4 -> 4/10
    assert frame_agreement([], [3, 6], 10) == pytest.approx(0.4)
    # one segment on both sides
    assert frame_agreement([], [], 7) == 1.0


def test_ri_identity_and_extremes() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        n = int(rng.integers(1, 80))
        ref = _random_cuts(rng, n, 8)
        assert frame_agreement(ref, ref, n) == 1.0
        # every frame its own segment: each reference segment gets one frame -> (k+1)/n
        assert frame_agreement(list(range(1, n)), ref, n) == pytest.approx((len(ref) + 1) / n)
        # a single predicted segment: the longest reference segment
        longest = max(e - s for s, e in segments_from_cuts(ref, n))
        assert frame_agreement([], ref, n) == pytest.approx(longest / n)


def test_ri_matches_brute_force() -> None:
    rng = np.random.default_rng(2)
    for _ in range(300):
        n = int(rng.integers(2, 25))
        ref = _random_cuts(rng, n, 4)
        pred = _random_cuts(rng, n, 5)
        ri = frame_agreement(pred, ref, n)
        assert ri == pytest.approx(_brute_ri(pred, ref, n))
        assert ri == pytest.approx(frame_agreement(ref, pred, n))  # the matching is symmetric
        assert 0 < ri <= 1
        assert (ri == 1.0) == (pred == ref)


# --------------------------------------------------------------------------------------------------
# F1 with margin
# --------------------------------------------------------------------------------------------------


def test_f1_hand_examples() -> None:
    # n=10, ref [5], pred [4]: |4 - 5| = 1
    r0 = f1_margin([4], [5], 10, margin=0)
    assert (r0.tp, r0.precision, r0.recall, r0.f1) == (0, 0.0, 0.0, 0.0)
    r1 = f1_margin([4], [5], 10, margin=1)
    assert (r1.tp, r1.precision, r1.recall, r1.f1) == (1, 1.0, 1.0, 1.0)
    assert isinstance(r1, F1Result) and (r1.n_pred, r1.n_ref) == (1, 1)

    # ref [20, 50, 80], pred [18, 22, 49, 90], margin 2: 20 <- 18 or 22 (only one counts),
    # 50 <- 49, 80 <- none (90 is 10 away): tp 2, P = 2/4, R = 2/3, F1 = 2PR/(P+R) = (2/3)/(7/6) = 4/7
    r = f1_margin([18, 22, 49, 90], [20, 50, 80], 100, margin=2)
    assert r.tp == 2
    assert (r.precision, r.recall, r.f1) == pytest.approx((0.5, 2 / 3, 4 / 7))
    # with annotator intervals (given in the order of the unsorted cuts) and margin 0: 20 <- 18 in
    # [15, 25], 50 <- 49 in [45, 55], 80 <- 90 in [75, 92]: tp 3, P = 3/4, R = 1, F1 = 1.5/1.75 = 6/7
    r = f1_margin([18, 22, 49, 90], [80, 20, 50], 100, 0, intervals=[[75, 92], [15, 25], [45, 55]])
    assert r.tp == 3
    assert (r.precision, r.recall, r.f1) == pytest.approx((0.75, 1.0, 6 / 7))


def test_f1_maximum_matching_beats_nearest_first() -> None:
    # ref [9, 11], pred [10, 13], margin 2. Nearest-first from 11 takes 10 (distance 1) and leaves 9
    # with nothing (13 is 4 away): tp 1. The maximum matching is 9 <- 10, 11 <- 13: tp 2.
    assert f1_margin([10, 13], [9, 11], 100, 2).tp == 2
    assert _brute_tp([10, 13], [9, 11], 2) == 2


def test_f1_empty_conventions() -> None:
    assert f1_margin([], [], 10, 1) == F1Result(1.0, 1.0, 1.0, 0, 0, 0)
    r = f1_margin([], [5], 10, 1)
    assert (r.precision, r.recall, r.f1, r.tp) == (0.0, 0.0, 0.0, 0)
    r = f1_margin([5], [], 10, 1)
    assert (r.precision, r.recall, r.f1, r.tp) == (0.0, 0.0, 0.0, 0)
    r = f1_margin([], [], 10, 1, intervals=np.zeros((0, 2), dtype=int))
    assert r.f1 == 1.0


def test_f1_matches_brute_force() -> None:
    rng = np.random.default_rng(3)
    for _ in range(300):
        n = int(rng.integers(2, 40))
        ref = _random_cuts(rng, n, 4)
        pred = _random_cuts(rng, n, 5)
        margin = int(rng.integers(0, 5))
        intervals = None
        if rng.random() < 0.5:
            intervals = [
                [r - int(rng.integers(0, 6)), r + int(rng.integers(0, 6))] for r in ref
            ]
        r = f1_margin(pred, ref, n, margin, intervals=intervals)
        assert r.tp == _brute_tp(pred, ref, margin, intervals)
        if pred and ref:
            assert r.precision == pytest.approx(r.tp / len(pred))
            assert r.recall == pytest.approx(r.tp / len(ref))


# --------------------------------------------------------------------------------------------------
# covering
# --------------------------------------------------------------------------------------------------


def test_covering_hand_example() -> None:
    # n=10, ref A1=[0,5), A2=[5,10); pred B1=[0,4), B2=[4,10).
    # A1: |A1∩B1|/|A1∪B1| = 4/5, |A1∩B2|/|A1∪B2| = 1/10 -> 4/5
    # A2: B1 disjoint, |A2∩B2|/|A2∪B2| = 5/6            -> 5/6
    # (5·4/5 + 5·5/6) / 10 = (4 + 25/6) / 10 = 49/60
    assert covering([4], [5], 10) == pytest.approx(49 / 60)
    # over-segmented: ref [0,10), pred [0,5)|[5,10): 10 · 5/10 / 10 = 1/2
    assert covering([5], [], 10) == pytest.approx(0.5)
    # under-segmented: ref [0,2)|[2,10), pred [0,10): (2·2/10 + 8·8/10) / 10 = 0.68
    assert covering([], [2], 10) == pytest.approx(0.68)
    assert covering([3, 6], [3, 6], 10) == 1.0


def test_covering_equals_claspy() -> None:
    # claspy.tests.evaluation.covering(annotations, predictions, n_obs) takes a dict of annotators'
    # change points and adds the boundaries 0 and n itself (a cut at 0 would be ignored); it sums
    # over the annotated segments and maximises over the predicted ones, as we do.
    rng = np.random.default_rng(4)
    for _ in range(300):
        n = int(rng.integers(1, 120))
        ref = _random_cuts(rng, n, 10)
        pred = _random_cuts(rng, n, 10)
        assert covering(pred, ref, n) == pytest.approx(claspy_covering({0: ref}, pred, n), abs=1e-12)


# --------------------------------------------------------------------------------------------------
# Reference and labels_from_frames
# --------------------------------------------------------------------------------------------------


def test_labels_from_frames_and_frame_labels() -> None:
    per_frame = ["a", "a", "b", "b", "b", "a"]
    ref = labels_from_frames(per_frame, rate_hz=60.0)
    assert ref.n_frames == 6
    assert ref.cuts.tolist() == [2, 5]
    assert ref.intervals.tolist() == [[2, 2], [5, 5]]
    assert ref.labels == ("a", "b", "a")
    assert ref.rate_hz == 60.0
    assert ref.cuts.dtype == np.int64 and ref.intervals.dtype == np.int64
    assert ref.frame_labels().tolist() == [0, 0, 1, 1, 1, 2]
    assert ref.n_segments == 3
    assert labels_from_frames(np.array([3, 3, 7])).labels == ("3", "7")
    assert labels_from_frames([1]).cuts.size == 0
    with pytest.raises(InvalidSignalError):
        labels_from_frames([])
    with pytest.raises(InvalidSignalError):
        labels_from_frames(np.zeros((2, 2)))


def test_reference_is_validated_and_read_only() -> None:
    ref = Reference(10, [4], [[3, 5]], ("x", "y"))
    with pytest.raises(ValueError):
        ref.cuts[0] = 1
    with pytest.raises(InvalidParameterError, match="inside"):
        Reference(10, [10], [[10, 10]], ("x", "y"))
    with pytest.raises(InvalidParameterError, match="labels"):
        Reference(10, [4], [[4, 4]], ("x",))
    with pytest.raises(InvalidParameterError, match="outside its interval"):
        Reference(10, [4], [[5, 6]], ("x", "y"))
    with pytest.raises(InvalidParameterError, match="shape"):
        Reference(10, [4], [[4, 4], [5, 5]], ("x", "y"))


# --------------------------------------------------------------------------------------------------
# read_haca_labels on tiny files
# --------------------------------------------------------------------------------------------------


def _write(tmp_path: Path, text: str, name: str = "t.labels.txt") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode())
    return path


def test_haca_good_file(tmp_path: Path) -> None:
    path = _write(tmp_path, "86 99\r\n\r\nwalk 8 10 12\r\n  jump 20 20 21\r\nrest 30 30 30\r\n\r\n")
    ref = read_haca_labels(path, rate_hz=100.0)
    assert ref.n_frames == 30
    assert ref.cuts.tolist() == [10, 20]  # 1-based end frame b -> 0-based start b of the next
    assert ref.intervals.tolist() == [[8, 12], [20, 21]]
    assert ref.labels == ("walk", "jump", "rest")
    assert ref.rate_hz == 100.0 and ref.source == str(path)
    assert read_haca_labels(path, n_frames=30).cuts.tolist() == [10, 20]
    one = read_haca_labels(_write(tmp_path, "h\nall 5 5 5\n", "one.txt"))
    assert one.n_frames == 5 and one.cuts.size == 0 and one.labels == ("all",)


@pytest.mark.parametrize(
    "text,line,match",
    [
        ("h\nwalk 8 10\nrest 30 30 30\n", 2, "4 tokens"),
        ("h\nwalk 8 10 12 13\nrest 30 30 30\n", 2, "4 tokens"),
        ("h\nwalk 8 ten 12\nrest 30 30 30\n", 2, "integer"),
        ("h\nwalk 8 10 12\n\nrest 30 30.5 30\n", 4, "integer"),
        ("h\nwalk 11 10 12\nrest 30 30 30\n", 2, "a <= b <= c"),
        ("h\nwalk 8 10 9\nrest 30 30 30\n", 2, "a <= b <= c"),
        ("h\nwalk 0 10 12\nrest 30 30 30\n", 2, "1-based"),
        ("h\nwalk 8 10 12\njump 9 10 11\nrest 30 30 30\n", 3, "increase"),
        ("h\nwalk 8 10 12\njump 7 9 11\nrest 30 30 30\n", 3, "increase"),
        ("h\nwalk 8 10 30\nrest 30 30 30\n", 2, "end of the take"),
        ("h\n\n", None, "no segment"),
        ("", None, "no segment"),
    ],
)
def test_haca_bad_files(tmp_path: Path, text: str, line: int | None, match: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(MocapFormatError, match=match) as info:
        read_haca_labels(path)
    assert info.value.line == line
    assert info.value.path == str(path)
    prefix = str(path) if line is None else f"{path}:{line}:"
    assert str(info.value).startswith(prefix)


def test_haca_frame_count_mismatch(tmp_path: Path) -> None:
    path = _write(tmp_path, "h\nwalk 8 10 12\n\nrest 30 30 30\n")
    with pytest.raises(MocapFormatError, match="31 frames") as info:
        read_haca_labels(path, n_frames=31)
    assert info.value.line == 4
    assert str(info.value).startswith(f"{path}:4:")


def test_labels_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MocapFormatError, match="no such file") as info:
        read_haca_labels(tmp_path / "absent.txt")
    assert info.value.line is None
    with pytest.raises(MocapFormatError, match="no such file"):
        read_frame_labels(tmp_path / "absent.txt", 10)


def test_loader_parameters(tmp_path: Path) -> None:
    path = _write(tmp_path, "1 1\n")
    with pytest.raises(InvalidParameterError):
        read_frame_labels(path, 0)
    with pytest.raises(InvalidParameterError):
        read_frame_labels(path, 24, frames_per_label=0)
    with pytest.raises(InvalidParameterError):
        read_frame_labels(path, 24, rate_hz=-1.0)
    with pytest.raises(InvalidParameterError):
        read_haca_labels(path, n_frames=-3)


# --------------------------------------------------------------------------------------------------
# read_frame_labels on tiny files
# --------------------------------------------------------------------------------------------------


def test_frame_labels_good_file(tmp_path: Path) -> None:
    # 30 frames, 12 per label -> ceil(30/12) = 3 labels covering 0..11, 12..23, 24..29
    path = _write(tmp_path, "1 1\n2\n")
    ref = read_frame_labels(path, 30)
    assert ref.n_frames == 30
    assert ref.cuts.tolist() == [24]
    assert ref.intervals.tolist() == [[24, 24]]
    assert ref.labels == ("JumpJack", "Jog")
    assert read_frame_labels(path, 30, action_names=None).labels == ("1", "2")
    assert read_frame_labels(path, 30, action_names={2: "two"}).labels == ("1", "two")
    assert ref.frame_labels().tolist() == [0] * 24 + [1] * 6
    # a different block size: 3 labels of 5 frames over 13 frames
    ref = read_frame_labels(_write(tmp_path, "4 6 6", "b.txt"), 13, frames_per_label=5)
    assert ref.cuts.tolist() == [5]
    assert ref.labels == (MOCAP6_ACTIONS[4], MOCAP6_ACTIONS[6])


def test_frame_labels_wrong_count(tmp_path: Path) -> None:
    path = _write(tmp_path, "1 1\n2\n")
    for n in (12, 49):  # ceil(12/12) = 1 and ceil(49/12) = 5 labels expected, 3 found: an error
        with pytest.raises(MocapFormatError) as info:
            read_frame_labels(path, n)
        assert info.value.line is None
        expected = -(-n // 12)
        assert f"expected {expected} labels" in str(info.value)
        assert "found 3" in str(info.value)
        assert str(info.value).startswith(str(path))


def test_frame_labels_one_block_more_or_less_is_a_warning(tmp_path: Path) -> None:
    path = _write(tmp_path, "1 1\n2\n")
    ref = read_frame_labels(path, 24)  # 2 labels expected, 3 found: the last is ignored
    assert len(ref.warnings) == 1 and "the last label is ignored" in ref.warnings[0] and str(path) in ref.warnings[0]
    assert ref.cuts.size == 0 and ref.n_frames == 24
    ref = read_frame_labels(path, 37)  # 4 expected, 3 found: the last label covers frames 36..36
    assert len(ref.warnings) == 1 and "last 1 frames" in ref.warnings[0]
    assert ref.cuts.tolist() == [24] and ref.n_frames == 37 and ref.frame_labels()[-1] == 1
    assert read_frame_labels(path, 36).warnings == ()  # exact: no warning


def test_frame_labels_bad_token(tmp_path: Path) -> None:
    path = _write(tmp_path, "1 1\r\n2 x\r\n")
    with pytest.raises(MocapFormatError, match="integer") as info:
        read_frame_labels(path, 48)
    assert info.value.line == 2
    assert str(info.value).startswith(f"{path}:2:")


# --------------------------------------------------------------------------------------------------
# real CMU label files
# --------------------------------------------------------------------------------------------------


def _amc_frames(path: Path) -> int:
    """Frames of an AMC file: lines holding a bare integer after the ``:DEGREES`` header."""
    text = path.read_text(errors="replace")
    body = text[text.index(":DEGREES") :]
    return len(re.findall(r"(?m)^\s*\d+\s*$", body))


@pytest.mark.shared
def test_real_86_01(shared_data: Path) -> None:
    cmu = shared_data / "cmu"
    n = _amc_frames(cmu / "86_01.amc")
    assert n == 4579
    ref = read_haca_labels(cmu / "86_01.labels.txt", n_frames=n)
    # lines "walk 500 550 600" ... "leg_kick 4015 4065 4115", then "punch 4579 4579 4579" (the end)
    assert ref.n_frames == 4579
    assert ref.cuts.tolist() == [550, 1150, 1980, 2500, 3200, 4065]
    assert ref.intervals.tolist() == [
        [500, 600], [1100, 1200], [1930, 2030], [2450, 2550], [3150, 3250], [4015, 4115],
    ]
    assert ref.labels == ("walk", "jump", "walk", "punch", "walk", "leg_kick", "punch")
    assert ref.frame_labels()[[0, 549, 550, 4578]].tolist() == [0, 0, 1, 6]
    with pytest.raises(MocapFormatError) as info:
        read_haca_labels(cmu / "86_01.labels.txt", n_frames=4580)
    assert info.value.line == 8


@pytest.mark.shared
@pytest.mark.parametrize(
    "trial,frames,cuts,actions",
    [
        ("13_29", 4592, [468, 1212, 1920, 2700, 3804], [1, 6, 5, 10, 4, 3]),
        ("13_30", 2465, [216, 804, 1416, 1932], [1, 6, 4, 3, 2]),
        ("14_14", 4653, [456, 1044, 1608, 2280, 3576], [1, 2, 3, 4, 5, 6]),
    ],
)
def test_real_mocap6(shared_data: Path, trial: str, frames: int, cuts: list[int], actions: list[int]) -> None:
    cmu = shared_data / "cmu"
    n = _amc_frames(cmu / f"{trial}.amc")
    assert n == frames
    path = cmu / f"{trial}.labels.txt"
    n_labels = len(path.read_text().split())
    assert n_labels == math.ceil(n / 12)  # the files hold exactly ceil(n/12) labels
    ref = read_frame_labels(path, n)
    assert ref.n_frames == n
    assert ref.cuts.tolist() == cuts
    assert all(c % 12 == 0 for c in cuts)
    assert ref.labels == tuple(MOCAP6_ACTIONS[a] for a in actions)
    # every segment lasts more than a second at 120 Hz (shortest: 216 frames, 13_30 JumpJack)
    lengths = np.diff(np.r_[0, ref.cuts, n])
    assert lengths.min() > 120
    # the reference scores perfectly against itself
    assert frame_agreement(ref.cuts, ref.cuts, n) == 1.0
    assert covering(ref.cuts, ref.cuts, n) == 1.0
    assert f1_margin(ref.cuts, ref.cuts, n, 0, ref.intervals).f1 == 1.0
