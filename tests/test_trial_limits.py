"""Issue 10 trial, limits: no recursion on data (a 10,000-joint chain works in every command, a 2,000-bone
ASF too); bounded memory and time (header claims checked before allocating, ``/dev/zero`` and endless
pipes refused in bounded chunks, a 100k-joint BVH described quickly, streaming work per sample bounded).

Each command runs with a 2 GB address-space limit; a timeout counts as a hang.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from trial import checks, generators, server

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the trial forks")


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("deep")
    p = d / "chain10000.bvh"
    p.write_text(generators.bvh_chain(10_000, n_frames=4))
    return p


@pytest.fixture(scope="module")
def chain3000(tmp_path_factory) -> Path:
    """Three times Python's recursion limit: any recursive walk fails; compressing it stays affordable in
    the default suite (``make fuzz`` compresses 10,000-joint chains)."""
    d = tmp_path_factory.mktemp("deep3000")
    p = d / "chain3000.bvh"
    p.write_text(generators.bvh_chain(3000, n_frames=4))
    return p


@pytest.fixture(scope="module")
def asf_chain(tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("asf")
    asf, amc = d / "chain2000.asf", d / "chain2000.amc"
    asf.write_text(generators.asf_chain(2000))
    amc.write_text(generators.amc_for_chain(2000))
    return asf, amc


def _ok_and_readable(trial, run, out: Path | None, fmt: str | None = None):
    checks.assert_ok(run)
    if out is not None:
        rep = trial.digest(out, fmt or out.suffix[1:])
        assert rep["status"] == "ok" and not rep["nonfinite"], rep


def test_deep_bvh_chain_info(trial, chain):
    r = trial.run(["info", chain, "--json"], timeout=120)
    checks.assert_ok(r)
    assert checks.oracle.strict_json(r.out_text)["joints"] == 10_000


def test_deep_bvh_chain_convert(trial, chain, tmp_path):
    out = tmp_path / "o.bvh"
    _ok_and_readable(trial, trial.run(["convert", chain, out], timeout=120), out)


def test_deep_bvh_chain_compress_and_decompress(trial, chain3000, tmp_path):
    clip = tmp_path / "c.glb"
    _ok_and_readable(trial, trial.run(["compress", chain3000, "-o", clip, "-t", "0.01"], timeout=120), clip, "glb")
    out = tmp_path / "d.bvh"
    _ok_and_readable(trial, trial.run(["decompress", clip, "-o", out], timeout=120), out)


def test_deep_bvh_chain_position_bound(trial, chain3000):
    r = trial.run(["compress", chain3000, "--json", "--stats-only", "--max-position-error", "1", "--unit-cm", "1"],
                  timeout=120)
    checks.assert_no_failure(r, chain3000.name)


def test_deep_bvh_chain_segment(trial, chain):
    # the chain has no limbs to measure: a clean error naming what is missing is right, a traceback is not
    checks.assert_no_failure(trial.run(["segment", chain, "-m", "pca", "--json"], timeout=120), chain.name)


def test_deep_asf_chain(trial, asf_chain, tmp_path):
    asf, amc = asf_chain
    checks.assert_ok(trial.run(["info", amc, "--asf", asf, "--json"], timeout=120))
    out = tmp_path / "o.bvh"
    _ok_and_readable(trial, trial.run(["convert", amc, out, "--asf", asf], timeout=120), out)
    back = tmp_path / "back.amc"
    r = trial.run(["convert", out, back, "--asf", asf], timeout=120)
    checks.assert_ok(r)


def test_100k_joint_bvh_info_is_quick(trial, tmp_path):
    p = tmp_path / "wide.bvh"
    p.write_text(generators.bvh_chain(100_000, n_frames=2, wide=True))
    r = trial.run(["info", p, "--json"], timeout=30)
    checks.assert_no_failure(r, p.name)


@pytest.mark.parametrize("command", ["info", "convert", "filter"])
def test_marker_count_claim_is_checked_before_allocating(trial, tmp_path, command):
    p = tmp_path / "claim.tsv"
    p.write_text(generators.qtm_claim())
    argv = {"info": ["info", p, "--json"], "convert": ["convert", p, tmp_path / "o.csv"],
            "filter": ["filter", p, "--auto", "--json"]}[command]
    r = trial.run(argv, timeout=30)
    checks.assert_clean_error(r, p.name)
    assert r.seconds < 20


@pytest.mark.parametrize("claim", ["Frames: 1000000000", "Frames: 1e9"])
@pytest.mark.parametrize("strict", ["--strict", "--no-strict"])
def test_bvh_frame_claim(trial, tmp_path, claim, strict):
    p = tmp_path / "frames.bvh"
    p.write_text(generators.bvh_chain(5).replace("Frames: 4", claim))
    r = trial.run(["info", p, "--json", strict], timeout=30)
    kind = checks.assert_no_failure(r, p.name)
    if strict == "--strict":
        assert kind == "error"


@pytest.mark.parametrize("argv", [
    ["info", "/dev/zero"], ["info", "/dev/zero", "--json"], ["compress", "/dev/zero", "-t", "0.001"],
    ["filter", "/dev/zero", "--auto", "--json"], ["convert", "/dev/zero", "OUT/o.csv"],
    ["decompress", "/dev/zero", "-o", "OUT/d.csv", "--rate", "50"], ["stream", "-t", "0.001", "STDIN=/dev/zero"],
])
def test_dev_zero_is_refused_in_bounded_time(trial, tmp_path, argv):
    stdin = None
    args = []
    for a in argv:
        if a.startswith("STDIN="):
            stdin = a[6:]
        else:
            args.append(a.replace("OUT", str(tmp_path)))
    r = trial.run(args, stdin=stdin, timeout=30)
    checks.assert_clean_error(r, "zero", "stdin")


def test_endless_pipe_is_refused_in_bounded_time(trial, tmp_path):
    fifo = tmp_path / "endless.csv"
    os.mkfifo(fifo)
    code = ("import sys\nb=b'1.0,2.0,3.0,4.0,5.0\\n'*4096\n"
            "try:\n while True: sys.stdout.buffer.write(b)\nexcept OSError: pass\n")
    writer = subprocess.Popen(["/bin/sh", "-c", 'exec "$0" -c "$1" > "$2"', sys.executable, code, str(fifo)],
                              stderr=subprocess.DEVNULL)
    try:
        r = trial.run(["info", fifo, "--json"], timeout=30)
    finally:
        writer.kill()
        writer.wait()
    checks.assert_clean_error(r, fifo.name)


def test_stream_sliding_window_on_constant_input_is_bounded(trial, tmp_path):
    """SW on constant input never closes a segment by itself: a default maximum segment length keeps the
    work per sample bounded (200,000 samples in well under the timeout)."""
    p = tmp_path / "constant.csv"
    with open(p, "w") as fh:
        fh.write("time,w,x,y,z\n")
        for i in range(200_000):
            fh.write(f"{i / 100:.2f},1,0,0,0\n")
    r = trial.run(["stream", "-m", "sw", "-t", "0.001"], stdin=p, timeout=60)
    checks.assert_ok(r)
