"""`similarity` on motionless takes: a correlation of float noise is not reported. A BVH whose frames are all
equal (its limb angles vary only by forward-kinematics rounding, ~1e-13°) and one with 1e-12° noise on
every channel give r = null (n/a in the table) and a warning saying the takes are motionless; a small but
real motion is still correlated exactly as numpy does."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.segment import similarity as sim
from test_robust_cli import cli_run

WALK = Path(__file__).resolve().parent / "data" / "bvh" / "walk-meredith-60.bvh"


def _still_bvh(path: Path, noise: float, seed: int, n: int = 40) -> Path:
    head, motion = WALK.read_text().split("MOTION", 1)
    lines = motion.strip().split("\n")
    first = np.array([float(v) for v in lines[2].split()])
    rng = np.random.default_rng(seed)
    rows = [" ".join(repr(float(v)) for v in first + rng.normal(0.0, noise, first.size)) for _ in range(n)]
    path.write_text(f"{head}MOTION\nFrames: {n}\n{lines[1]}\n" + "\n".join(rows) + "\n")
    return path


@pytest.fixture
def still(tmp_path) -> Path:
    return _still_bvh(tmp_path / "still.bvh", 0.0, 0)


@pytest.fixture
def noisy(tmp_path) -> Path:
    return _still_bvh(tmp_path / "noisy.bvh", 1e-12, 1)


def _record(a: Path, b: Path) -> dict:
    r = cli_run("similarity", a, b, "--json")
    assert r.code == 0, r.err
    return json.loads(r.out)


@pytest.mark.parametrize("which", ["still", "noisy"])
def test_a_motionless_take_has_no_correlation(request, which):
    take = request.getfixturevalue(which)
    rec = _record(take, WALK)
    assert [row["r"] for row in rec["limbs"]] == [None] * 4
    assert all(row["similarity_pct"] is None for row in rec["limbs"])
    assert rec["r_mean"] is None and rec["above_paper_threshold"] is None
    assert any("motionless" in w and str(take) in w for w in rec["warnings"])
    assert all(math.isfinite(row["distance_deg"]) for row in rec["limbs"])   # the DTW distance stays defined


def test_two_motionless_takes(still, noisy, tmp_path):
    other = _still_bvh(tmp_path / "noisy2.bvh", 1e-12, 2)
    for a, b in ((still, noisy), (noisy, other)):
        rec = _record(a, b)
        assert [row["r"] for row in rec["limbs"]] == [None] * 4
        assert any(w.startswith("both takes are motionless") for w in rec["warnings"])
    r = cli_run("similarity", noisy, other)
    assert r.code == 0 and r.out.count("n/a") == 4, r.out
    assert "motionless" in r.err


def test_moving_takes_are_unchanged():
    rec = _record(WALK, WALK)
    assert all(row["r"] == pytest.approx(1.0, abs=1e-12) for row in rec["limbs"])
    assert not any("motionless" in w for w in rec["warnings"])


@settings(max_examples=60, deadline=None)
@given(level=st.floats(-180, 180), amp=st.floats(1e-6, 50), seed=st.integers(0, 2 ** 31))
def test_pearson_keeps_real_motion(level, amp, seed):
    """Any variation of more than 1e-6 of a 1..180 degree angle is motion: r equals numpy's."""
    rng = np.random.default_rng(seed)
    x = level + amp * rng.standard_normal(50)
    y = level - amp * rng.standard_normal(50) + 0.5 * (x - level)
    r = sim.pearson(x, y)
    assert r == pytest.approx(np.corrcoef(x, y)[0, 1], abs=1e-9)


@given(level=st.floats(-180, 180), rel=st.floats(0, 1e-10), seed=st.integers(0, 2 ** 31))
def test_pearson_of_float_noise_is_undefined(level, rel, seed):
    rng = np.random.default_rng(seed)
    x = level + rel * max(1.0, abs(level)) * rng.standard_normal(50)
    assert math.isnan(sim.pearson(x, np.arange(50.0)))
    assert math.isnan(sim.pearson(np.arange(50.0), x))
