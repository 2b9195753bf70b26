"""Issue 10 trial, readers at the API level: hypothesis mutates every format's seed (tokens, truncation,
lines, bytes, NUL/non-UTF-8, header counts) and loads it with the library in a child process.

Only ``MocapFormatError`` (or a documented warning) may come out — no other exception, signal, hang or
memory blow-up; a successful read holds finite values (NaN only for marker gaps); and a number the
strict grammar refuses, or a last line cut short, is never read as different data without a word.
"""

from __future__ import annotations

import os
import random
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from trial import checks, mutators, server
from trial.cases import CRC_FORMATS
from trial.seeds import build_seeds

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the trial forks")


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


@pytest.fixture(scope="module")
def seeds(tmp_path_factory, trial):
    work = tmp_path_factory.mktemp("seeds")
    made = build_seeds(work, run_cli=lambda argv, timeout=120: trial.run(argv, timeout=timeout))
    refs = {}
    for s in made:
        target = _target(s, s.path, s.companion)
        refs[s.name] = trial.digest(*target)
        assert refs[s.name]["status"] == "ok", (s.name, refs[s.name])
    return made, refs


def _target(seed, path: Path, companion: Path | None) -> tuple:
    if seed.fmt == "asf":
        return (companion, "amc", {"asf": str(path)})
    opts = {k: (str(companion) if v == "{asf}" else v) for k, v in seed.load_options.items()}
    return (path, seed.fmt, opts)


GROUPS = {
    "skeletal": {"bvh", "amc", "asf", "mvnx", "glb", "gltf"},
    "markers": {"qtm", "c3d", "trc", "vicon", "mot", "sto"},
    "imu": {"imu", "points"},
    "packets": {"mkp", "mkc", "mkpoints"},
}


def _check_one(trial, seeds, tmp_path, group, data):
    made, refs = seeds
    pool = [s for s in made if s.fmt in GROUPS[group] and not s.folder]
    seed = data.draw(st.sampled_from(pool), label="seed")
    table = mutators.BINARY_MUTATORS if seed.binary else mutators.TEXT_MUTATORS
    kind = data.draw(st.sampled_from(sorted(table)), label="mutation")
    rng = random.Random(data.draw(st.integers(0, 2**32 - 1), label="rng"))
    original = seed.path.read_bytes()
    mut = mutators.mutate(original, rng, seed.fmt, seed.binary, kind)
    if mut is None:
        return
    note(f"{seed.name}: {mut.kind} {({k: v for k, v in mut.detail.items() if k != 'complete'})} expect {mut.expect}; "
         f"last bytes {mut.data[-60:]!r}")
    case = Path(tempfile.mkdtemp(prefix="case-", dir=tmp_path))
    path = case / seed.path.name
    path.write_bytes(mut.data)
    companion = None
    if seed.companion is not None:
        companion = case / seed.companion.name
        shutil.copyfile(seed.companion, companion)
    complete = None
    if mut.expect == "truncated" and not seed.binary:
        cdir = case / "complete"
        cdir.mkdir()
        (cdir / seed.path.name).write_bytes(mut.detail["complete"])
        ccomp = None
        if seed.companion is not None:
            ccomp = cdir / seed.companion.name
            shutil.copyfile(seed.companion, ccomp)
        complete = trial.digest(*_target(seed, cdir / seed.path.name, ccomp))
    target = _target(seed, path, companion)
    if seed.fmt in CRC_FORMATS:  # every byte under a CRC: refused, reported as a lost packet, or no change
        checks.assert_not_silent(trial, target[0], target[1], refs[seed.name], target[2])
    elif mut.expect in ("refuse", "truncated") and not seed.binary:
        checks.assert_not_silent(trial, target[0], target[1], refs[seed.name], target[2], complete)
    else:
        rep = trial.digest(*target)
        assert rep.get("status") in ("ok", "error"), f"{seed.name} after {mut.kind} {mut.detail}: {rep}"
        if rep["status"] == "ok":
            assert not rep["nonfinite"], f"{seed.name} after {mut.kind}: non-finite {rep['nonfinite']}"


_SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                             HealthCheck.too_slow])


@_SETTINGS
@given(data=st.data())
def test_skeletal_readers_under_mutation(trial, seeds, tmp_path, data):
    _check_one(trial, seeds, tmp_path, "skeletal", data)


@_SETTINGS
@given(data=st.data())
def test_marker_readers_under_mutation(trial, seeds, tmp_path, data):
    _check_one(trial, seeds, tmp_path, "markers", data)


@_SETTINGS
@given(data=st.data())
def test_imu_readers_under_mutation(trial, seeds, tmp_path, data):
    _check_one(trial, seeds, tmp_path, "imu", data)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                 HealthCheck.too_slow])
@given(data=st.data())
def test_packet_and_clip_readers_under_mutation(trial, seeds, tmp_path, data):
    """.mkp, .mkc and the tick points CSV: a mutation is refused, reported (a damaged or lost packet) or
    reads the same data."""
    _check_one(trial, seeds, tmp_path, "packets", data)
