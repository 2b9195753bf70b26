"""DTW similarity (Eq. 5–9 of the ARMA seed paper): the compiled DTW against a naive O(n·m) Python DTW
and against brute force over every warping path, the path constraints of Eq. 7, the Eq. 9 correlation
against numpy, the band, the similarity table, the ``similarity`` command and the shared CMU takes."""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError
from mocapkit.segment import similarity as sim

# ---------------------------------------------------------------------------------------------- references

def naive_dtw(a, b, allowed=None):
    """Eq. 8 over the full matrix in plain Python, then the path read back from r itself (ties: diagonal,
    then (e−1, f), then (e, f−1)); ``allowed(e, f)`` restricts the cells (a band)."""
    a = np.asarray(a, float).reshape(len(a), -1)
    b = np.asarray(b, float).reshape(len(b), -1)
    m, n = len(a), len(b)
    inf = float("inf")
    r = [[inf] * n for _ in range(m)]
    for e in range(m):
        for f in range(n):
            if allowed is not None and not allowed(e, f):
                continue
            d = math.sqrt(sum((float(x) - float(y)) ** 2 for x, y in zip(a[e], b[f], strict=True)))
            if e == 0 and f == 0:
                r[e][f] = d
                continue
            prev = min(r[e - 1][f - 1] if e and f else inf, r[e - 1][f] if e else inf, r[e][f - 1] if f else inf)
            r[e][f] = d + prev
    path = [(m - 1, n - 1)]
    e, f = m - 1, n - 1
    while (e, f) != (0, 0):
        cands = [(e - 1, f - 1), (e - 1, f), (e, f - 1)]
        cands = [(x, y) for x, y in cands if x >= 0 and y >= 0]
        best = min(r[x][y] for x, y in cands)
        e, f = next((x, y) for x, y in cands if r[x][y] == best)
        path.append((e, f))
    path.reverse()
    return r[m - 1][n - 1], np.array(path)


def all_paths(m, n):
    """Every warping path from (0, 0) to (m−1, n−1) with unit steps (brute force; small m, n only)."""
    def walk(e, f):
        if (e, f) == (m - 1, n - 1):
            yield [(e, f)]
            return
        for de, df in ((1, 1), (1, 0), (0, 1)):
            if e + de < m and f + df < n:
                for rest in walk(e + de, f + df):
                    yield [(e, f), *rest]
    return list(walk(0, 0))


def point_cost(a, b, path):
    a = np.asarray(a, float).reshape(len(a), -1)
    b = np.asarray(b, float).reshape(len(b), -1)
    return sum(float(np.sqrt(np.sum((a[e] - b[f]) ** 2))) for e, f in path)


def in_band(m, n, w):
    return lambda e, f: abs(e * (n - 1) - f * (m - 1)) <= w * (min(m, n) - 1)


CASES = [(1, 1, 1), (1, 6, 1), (6, 1, 2), (7, 7, 1), (9, 5, 1), (5, 12, 3), (20, 31, 4), (40, 17, 2), (33, 33, 3)]


# ---------------------------------------------------------------------------------------------- DTW

@pytest.mark.parametrize("m,n,d", CASES)
def test_dtw_equals_naive(m, n, d):
    rng = np.random.default_rng(m * 100 + n * 10 + d)
    for trial in range(5):
        a = rng.normal(size=(m, d)) if d > 1 or trial % 2 else rng.normal(size=m)
        b = rng.normal(size=(n, d)) if d > 1 or trial % 2 else rng.normal(size=n)
        res = sim.dtw(a, b)
        cost, path = naive_dtw(a, b)
        assert res.cost == pytest.approx(cost, rel=1e-12, abs=1e-12)
        np.testing.assert_array_equal(res.path, path)
        assert res.distance == pytest.approx(cost / len(path), rel=1e-12)


@pytest.mark.parametrize("m,n", [(1, 4), (3, 3), (4, 5), (5, 3), (5, 5)])
def test_dtw_is_the_minimum_over_every_path(m, n):
    """Brute force: the cost of Eq. 8 is the smallest summed point distance of all warping paths."""
    rng = np.random.default_rng(m * 7 + n)
    paths = all_paths(m, n)
    for _ in range(4):
        a, b = rng.normal(size=(m, 2)), rng.normal(size=(n, 2))
        best = min(point_cost(a, b, p) for p in paths)
        res = sim.dtw(a, b)
        assert res.cost == pytest.approx(best, rel=1e-12)
        assert point_cost(a, b, res.path) == pytest.approx(res.cost, rel=1e-12)


def test_path_constraints_of_eq7():
    rng = np.random.default_rng(3)
    for _ in range(60):
        m, n = rng.integers(1, 80, size=2)
        a, b = rng.normal(size=(m, 2)).cumsum(0), rng.normal(size=(n, 2)).cumsum(0)
        res = sim.dtw(a, b)
        p = res.path
        assert tuple(p[0]) == (0, 0) and tuple(p[-1]) == (m - 1, n - 1)
        steps = {tuple(s) for s in np.diff(p, axis=0).tolist()}
        assert steps <= {(1, 0), (0, 1), (1, 1)}
        assert max(m, n) <= res.K <= m + n - 1
        assert res.distance == pytest.approx(point_cost(a, b, p) / res.K, rel=1e-12)  # Eq. 5


def test_identical_and_time_warped_copies():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(200, 4)).cumsum(0)
    res = sim.dtw(a, a)
    assert res.distance == 0.0 and res.K == 200
    np.testing.assert_array_equal(res.path, np.column_stack([np.arange(200)] * 2))
    ps = sim.sequence_similarity(a, a)
    np.testing.assert_allclose(ps.r, 1.0, rtol=0, atol=1e-12)
    for align in ("limb", "joint"):
        # a time-warped copy: every sample repeated 1..4 times (a slowed, uneven replay)
        idx = np.repeat(np.arange(200), rng.integers(1, 5, size=200))
        w = a[idx]
        assert sim.dtw(a, w).distance == 0.0
        ps = sim.sequence_similarity(a, w, align=align)
        np.testing.assert_array_equal(ps.distance, 0.0)
        np.testing.assert_allclose(ps.r, 1.0, rtol=0, atol=1e-12)
    # but a copy with noise is not at distance 0 (the test above can fail)
    assert sim.dtw(a, a + rng.normal(scale=0.1, size=a.shape)).distance > 0.01


@pytest.mark.parametrize("m,n,w", [(9, 9, 0), (9, 9, 2), (20, 31, 1), (31, 20, 1), (12, 40, 2), (40, 12, 5),
                                   (6, 50, 5)])
def test_band_equals_naive_band(m, n, w):
    rng = np.random.default_rng(m + n + w)
    a, b = rng.normal(size=m), rng.normal(size=n)
    if w < sim.min_band(m, n):
        with pytest.raises(InvalidParameterError, match="band"):
            sim.dtw(a, b, band=w)
        return
    res = sim.dtw(a, b, band=w)
    cost, path = naive_dtw(a, b, allowed=in_band(m, n, w))
    assert math.isfinite(cost)
    assert res.cost == pytest.approx(cost, rel=1e-12)
    np.testing.assert_array_equal(res.path, path)
    assert all(in_band(m, n, w)(e, f) for e, f in res.path)
    assert res.cost >= sim.dtw(a, b).cost - 1e-12
    # a band as wide as the grid is no band
    big = sim.dtw(a, b, band=max(m, n))
    assert big.cost == pytest.approx(sim.dtw(a, b).cost, rel=1e-12)


def test_min_band_always_leaves_a_path():
    """The refused/accepted border: at min_band every grid has a finite path; the naive DP agrees."""
    rng = np.random.default_rng(11)
    for _ in range(40):
        m, n = (int(x) for x in rng.integers(2, 60, size=2))
        w = sim.min_band(m, n)
        cost, _ = naive_dtw(np.zeros(m), np.zeros(n), allowed=in_band(m, n, w))
        assert cost == 0.0
        assert sim.dtw(np.zeros(m), np.zeros(n), band=w).cost == 0.0


def test_dtw_rejects_bad_input(monkeypatch):
    with pytest.raises(InvalidParameterError, match="NaN"):
        sim.dtw([0.0, np.nan], [1.0])
    with pytest.raises(InvalidParameterError, match="empty"):
        sim.dtw([], [1.0])
    with pytest.raises(InvalidParameterError, match="columns"):
        sim.dtw(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(InvalidParameterError, match="shape"):
        sim.dtw(np.zeros((3, 2, 2)), np.zeros((3, 2, 2)))
    for bad in (-1, 1.5, True):
        with pytest.raises(InvalidParameterError, match="band"):
            sim.dtw([1.0, 2.0], [1.0, 2.0], band=bad)
    monkeypatch.setattr(sim, "MAX_CELLS", 99)
    with pytest.raises(InvalidParameterError, match="cells"):
        sim.dtw(np.zeros(10), np.zeros(10))


# ---------------------------------------------------------------------------------------------- Eq. 9

def test_aligned_correlation_equals_numpy_corrcoef():
    rng = np.random.default_rng(8)
    for _ in range(20):
        m, n = (int(x) for x in rng.integers(5, 90, size=2))
        a, b = rng.normal(size=(m, 3)).cumsum(0), rng.normal(size=(n, 3)).cumsum(0)
        res = sim.dtw(a, b)
        r = sim.aligned_correlation(a, b, res.path)
        x, y = a[res.path[:, 0]], b[res.path[:, 1]]
        want = [np.corrcoef(x[:, j], y[:, j])[0, 1] for j in range(3)]
        np.testing.assert_allclose(r, want, rtol=1e-12, atol=1e-12)
        ps = sim.sequence_similarity(a, b, align="joint")
        np.testing.assert_allclose(ps.r, want, rtol=1e-12, atol=1e-12)
        # per limb: each column's own path
        ps = sim.sequence_similarity(a, b, align="limb")
        for j in range(3):
            rj = sim.dtw(a[:, j], b[:, j])
            assert ps.distance[j] == pytest.approx(rj.distance, rel=1e-12) and ps.path_length[j] == rj.K
            xj, yj = a[rj.path[:, 0], j], b[rj.path[:, 1], j]
            assert ps.r[j] == pytest.approx(np.corrcoef(xj, yj)[0, 1], rel=1e-12, abs=1e-12)


def test_correlation_sign_and_undefined():
    t = np.linspace(0, 1, 300)
    a = np.column_stack([t, np.full(300, 2.0)])
    b = np.column_stack([-t[::2] ** 2, np.cos(t[::2])])
    for align in ("limb", "joint"):
        ps = sim.sequence_similarity(a, b, align=align)
        # no warping reverses time: a rising and a falling angle stay anti-correlated along any path
        assert ps.r[0] < -0.5
        assert math.isnan(ps.r[1])  # constant column: Eq. 9's denominator is 0
    assert math.isnan(sim.pearson(np.ones(4), np.arange(4.0)))


def test_time_normalise_equals_scipy_interp1d():
    from scipy.interpolate import interp1d

    rng = np.random.default_rng(2)
    x = rng.normal(size=(37, 2))
    got = sim.time_normalise(x, 100)
    want = interp1d(np.arange(37), x, axis=0)(np.linspace(0, 36, 100))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert sim.time_normalise(x[:, 0], 5).shape == (5,)
    np.testing.assert_allclose(sim.time_normalise(x, 37), x, atol=1e-12)
    for bad in (1, 2.5):
        with pytest.raises(InvalidParameterError):
            sim.time_normalise(x, bad)
    ps = sim.sequence_similarity(x, x[:20], resample=50)
    assert ps.lengths == (50, 50)


def test_similarity_table_groups_and_means():
    """γ per category and r̄ = the mean of the pairs' Eq. 9 values, computed here independently."""
    rng = np.random.default_rng(4)
    t = np.linspace(0, 6 * np.pi, 240)

    def seg(kind, subject, n, k):
        u = t[:n]
        v = np.sin(u) if kind == "sine" else np.sign(np.sin(u)) * 0.5 + 0.1 * u
        return sim.LabelledSegment(kind, subject, np.column_stack([v, np.cos(u * (1 + k))])
                                   + rng.normal(scale=0.05, size=(n, 2)), take=f"{subject}_{k}")

    segs = [seg("sine", "s1", 200, 0), seg("sine", "s2", 240, 1), seg("sine", "s1", 220, 2),
            seg("square", "s2", 230, 3), seg("square", "s3", 210, 4)]
    tab = sim.similarity_table(segs, names=["x", "y"], align="joint")
    assert len(tab["pairs"]) == 10
    want_gamma = {"same action, different subjects": 3, "same action, same subject": 1,
                  "different actions, different subjects": 5, "different actions, same subject": 1}
    assert {c: v["gamma"] for c, v in tab["categories"].items()} == want_gamma
    for c, v in tab["categories"].items():
        rs = []
        for i, j in itertools.combinations(range(5), 2):
            if sim.category(segs[i], segs[j]) == c:
                rs.append(sim.sequence_similarity(segs[i].values, segs[j].values, align="joint").r)
        rs = np.array(rs)
        assert v["r_bar"]["x"] == pytest.approx(rs[:, 0].mean(), rel=1e-12)
        assert v["r_bar_mean"] == pytest.approx(rs.mean(axis=1).mean(), rel=1e-12)
        assert v["share_above_0.7"] == pytest.approx(np.mean(rs.mean(axis=1) > 0.7))
    assert tab["actions"]["sine (different subjects)"]["gamma"] == 2
    assert tab["actions"]["square (different subjects)"]["gamma"] == 1
    with pytest.raises(InvalidParameterError):
        sim.similarity_table(segs[:1])
    with pytest.raises(InvalidParameterError):
        sim.similarity_table(segs, names=["x"])


# ---------------------------------------------------------------------------------------------- command

EXE = [sys.executable, "-m", "mocapkit"]


@pytest.fixture(scope="module")
def excerpt(tests_data):
    d = tests_data / "cmu"
    return d / "86_01_15hz_first1600.amc", d / "86.asf"


def cli(capsys, *args):
    """``mocapkit ARGS`` in-process: (exit code, stdout, stderr)."""
    from mocapkit.cli import main

    with pytest.raises(SystemExit) as ex:
        main([str(a) for a in args])
    out = capsys.readouterr()
    return ex.value.code, out.out, out.err


def test_similarity_command_json_equals_library(excerpt):
    """The command (a real process) reports what the library computes on the same limb angles."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.segment.features import LIMB_NAMES, motion_features

    amc, asf = excerpt
    r = subprocess.run([*EXE, "similarity", str(amc), str(amc), "--asf", str(asf), "--rate", "15",
                        "--frames", "0:69", "--frames-b", "144:200", "--json"],
                       capture_output=True, text=True, timeout=600, env={**os.environ, "COLUMNS": "200"}, check=False)
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    limbs = motion_features(load_motion(amc, asf=asf, rate=15)).limbs
    ps = sim.sequence_similarity(limbs[0:69], limbs[144:200])
    assert rec["job"] == "similarity" and rec["a"]["frames"] == [0, 69] and rec["b"]["frames"] == [144, 200]
    assert [x["limb"] for x in rec["limbs"]] == list(LIMB_NAMES)
    for k, row in enumerate(rec["limbs"]):
        assert row["r"] == pytest.approx(ps.r[k], rel=1e-12)
        assert row["distance_deg"] == pytest.approx(ps.distance[k], rel=1e-12)
        assert row["path_length"] == ps.path_length[k]
        assert row["similarity_pct"] == pytest.approx(100 * ps.r[k])
    assert rec["r_mean"] == pytest.approx(ps.r.mean(), rel=1e-12)
    assert rec["above_paper_threshold"] == bool(ps.r.mean() > 0.7)


def test_similarity_command_options(excerpt, capsys):
    amc, asf = excerpt
    code, out, _ = cli(capsys, "similarity", amc, amc, "--asf", asf, "--rate", 15, "--json")
    assert code in (0, None)
    rec = json.loads(out)  # the whole take with itself: similarity 1, distance 0
    assert all(x["r"] == pytest.approx(1.0, abs=1e-12) and x["distance_deg"] == 0.0 for x in rec["limbs"])
    code, out, _ = cli(capsys, "similarity", amc, amc, "--asf", asf, "--rate", 15, "--frames", ":69", "--frames-b",
                       "69:", "--limb", "left_arm", "--limb", "right_leg", "--align", "joint", "--band", 10,
                       "--resample", 60, "--json")
    rec = json.loads(out)
    assert [x["limb"] for x in rec["limbs"]] == ["left_arm", "right_leg"]
    assert rec["lengths"] == [60, 60] and rec["b"]["frames"] == [69, 200] and rec["band"] == 10
    assert len({x["path_length"] for x in rec["limbs"]}) == 1  # one joint path
    code, out, _ = cli(capsys, "similarity", amc, amc, "--asf", asf, "--rate", 15, "--frames", "0:69",
                       "--frames-b", "144:200")
    assert "r (Eq. 9)" in out and "right_leg" in out and "mean r over 4 limbs" in out


@pytest.mark.parametrize("args,msg", [
    (("--frames", "0:999"), "has 200 frames"),
    (("--frames", "5:x"), "START:END"),
    (("--frames-b", "10:11"), "at least START"),
    (("--limb", "tail"), "tail"),
    (("--band", "-1"), "--band"),
    (("--resample", "1"), "--resample"),
    (("--frames", "0:20", "--frames-b", "0:200", "--band", "1"), "band of at least"),
    (("--align", "diagonal"), "diagonal"),
    (("--joint", "spine"), "A=B"),
])
def test_similarity_command_errors(excerpt, capsys, args, msg):
    amc, asf = excerpt
    code, _, errtext = cli(capsys, "similarity", amc, amc, "--asf", asf, "--rate", 15, *args)
    assert code == 2
    assert errtext.startswith("error: ") and msg in errtext and errtext.count("\n") == 1


def test_similarity_command_file_errors(excerpt, capsys, tmp_path):
    amc, asf = excerpt
    code, _, errtext = cli(capsys, "similarity", amc, tmp_path / "missing.amc", "--asf", asf)
    assert code == 2 and "missing.amc" in errtext and "no such file" in errtext
    bad = tmp_path / "bad.amc"
    bad.write_text(":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 zero\n")
    code, _, errtext = cli(capsys, "similarity", amc, bad, "--asf", asf)
    assert code == 2 and "bad.amc" in errtext and errtext.count("\n") == 1


# ---------------------------------------------------------------------------------------------- real takes

def test_shared_86_walks_are_more_alike_than_walk_and_other_actions(shared_data):
    """On 86_01 (one subject) the three HACA walks are closer to each other than to any other action,
    with the joint DTW path (a property the data could break)."""
    from mocapkit.evaluation.segmentation import load_take

    take = load_take(shared_data / "cmu", "86_01")
    b = [0, *take.ref.cuts.tolist(), take.n_frames]
    segs = [(lab, take.limbs[b[i]:b[i + 1]]) for i, lab in enumerate(take.ref.labels)]
    walks = [x for lab, x in segs if lab == "walk"]
    others = [x for lab, x in segs if lab != "walk"]
    same = [sim.sequence_similarity(p, q, align="joint").r_mean for p, q in itertools.combinations(walks, 2)]
    diff = [sim.sequence_similarity(p, q, align="joint").r_mean for p in walks for q in others]
    assert len(same) == 3 and len(diff) == 12
    assert min(same) > max(diff)
