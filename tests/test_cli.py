"""The command line: outputs, JSON shape, exit code 2 with a one-line message on bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cli_run import completed as run_here
from mocapkit.io import read_imu_csv
from mocapkit.pla import compress_to
from mocapkit.pla.decode import reconstruct_points
from mocapkit.quat import angular_distance

EXE = [sys.executable, "-m", "mocapkit.cli"]


def run(*args, stdin: str | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*EXE, *map(str, args)], input=stdin, capture_output=True, text=True, cwd=cwd, timeout=300,
        env={**os.environ, "COLUMNS": "200"},
    )


@pytest.fixture(scope="module")
def pelvis(tests_data) -> Path:
    return tests_data / "xio" / "pelvis" / "Quaternion.csv"


def test_help_lists_every_command():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("compress", "decompress", "stream", "sweep", "bench", "demo", "info", "convert", "filter",
                "filter-eval"):
        assert cmd in r.stdout


def test_compress_json_and_points_are_input_rows(pelvis, tmp_path):
    out = tmp_path / "pts.csv"
    r = run_here("compress", pelvis, "-o", out, "--method", "fastsw", "--threshold", "1e-3", "--json")
    assert r.returncode == 0, r.stderr
    (rec,) = json.loads(r.stdout)
    for key in ("method", "threshold", "n_samples", "n_points", "icr", "aad_deg", "max_deg", "std_deg"):
        assert key in rec
    sig = read_imu_csv(pelvis)
    pts = read_imu_csv(out)
    assert rec["n_samples"] == len(sig) and rec["n_points"] == len(pts)
    # every point is exactly an input row (time and values)
    pos = np.searchsorted(sig.times, pts.times)
    assert np.array_equal(sig.times[pos], pts.times)
    assert np.array_equal(sig.values[pos], pts.values)
    # the JSON metrics are those of an independent decode of the written file
    rec_q = reconstruct_points(pts.times, pts.values, sig.times)
    dev = angular_distance(sig.values, rec_q, degrees=True)
    assert rec["max_deg"] == pytest.approx(dev.max(), rel=1e-9)
    assert rec["aad_deg"] == pytest.approx(dev.mean(), rel=1e-9)


@pytest.mark.parametrize("method", ["fastsw", "sw", "cplr", "swing", "anglesw"])
def test_compress_max_angle_bound_holds_on_written_file(pelvis, tmp_path, method):
    out = tmp_path / f"{method}.csv"
    r = run_here("compress", pelvis, "-o", out, "--method", method, "--max-angle", "1.5", "--json")
    assert r.returncode == 0, r.stderr
    (rec,) = json.loads(r.stdout)
    sig = read_imu_csv(pelvis)
    pts = read_imu_csv(out)
    dev = angular_distance(sig.values, reconstruct_points(pts.times, pts.values, sig.times), degrees=True)
    assert dev.max() <= 1.5 + 1e-9
    assert rec["max_deg"] <= 1.5 + 1e-9


def test_compress_target_icr(pelvis):
    r = run_here("compress", pelvis, "--method", "cplr", "--target-icr", "0.1", "--json")
    assert r.returncode == 0, r.stderr
    (rec,) = json.loads(r.stdout)
    assert rec["icr"] <= 0.1
    assert rec["icr"] > 0.08  # bisection lands close to the target, not at a trivial extreme


def test_compress_folder_to_folder(tests_data, tmp_path):
    out = tmp_path / "out"
    r = run_here("compress", tests_data / "xio", "-o", out, "--threshold", "1e-3", "--json")
    assert r.returncode == 0, r.stderr
    recs = json.loads(r.stdout)
    assert sorted(x["name"] for x in recs) == ["left-foot", "pelvis"]
    assert sorted(p.name for p in out.iterdir()) == ["left-foot.csv", "pelvis.csv"]


def test_decompress_times_from_and_rate(pelvis, tmp_path):
    pts = tmp_path / "pts.csv"
    assert run_here("compress", pelvis, "-o", pts, "--method", "swing", "--threshold", "0.01").returncode == 0
    full = tmp_path / "full.csv"
    r = run_here("decompress", pts, "--times-from", pelvis, "-o", full)
    assert r.returncode == 0, r.stderr
    sig = read_imu_csv(pelvis)
    rec = read_imu_csv(full)
    assert np.array_equal(rec.times, sig.times)
    assert np.allclose(np.linalg.norm(rec.values, axis=1), 1.0)
    # equals decoding the in-memory compression
    comp = compress_to(sig, "swing", threshold=0.01)
    assert np.allclose(rec.values, reconstruct_points(comp.times, comp.values, sig.times), atol=1e-12)
    grid = tmp_path / "grid.csv"
    r = run_here("decompress", pts, "--rate", "100", "-o", grid)
    assert r.returncode == 0, r.stderr
    g = read_imu_csv(grid)
    assert np.allclose(np.diff(g.times), 0.01)


def test_stream_emits_points_equal_to_batch(pelvis):
    text = pelvis.read_text()
    r = run("stream", "--method", "fastsw", "--threshold", "1e-3", stdin=text)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert lines[0] == "time,w,x,y,z"
    got = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    sig = read_imu_csv(pelvis)
    comp = compress_to(sig, "fastsw", threshold=1e-3)
    assert np.array_equal(got[:, 0], comp.times)
    assert np.array_equal(got[:, 1:], comp.values)


def test_stream_is_incremental(pelvis):
    """A point appears on stdout before stdin is closed (the encoder sits behind a live logger)."""
    rows = pelvis.read_text().splitlines()
    p = subprocess.Popen([*EXE, "stream", "--threshold", "1e-4"], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1)
    try:
        p.stdin.write("\n".join(rows[:200]) + "\n")
        p.stdin.flush()
        assert p.stdout.readline().strip() == "time,w,x,y,z"
        first = p.stdout.readline()  # the first sample is a point at once
        second = p.stdout.readline()  # and a later one, decided within the 199 rows sent
        assert first.count(",") == 4 and second.count(",") == 4
        assert float(second.split(",")[0]) > float(first.split(",")[0])
    finally:
        p.stdin.close()
        p.wait(timeout=60)
    assert p.returncode == 0


def test_stream_bad_row_exits_2_after_emitting(pelvis):
    rows = pelvis.read_text().splitlines()
    rows.insert(50, "917999999,nan,0,0,0")
    r = run("stream", "--threshold", "1e-4", stdin="\n".join(rows) + "\n")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0
    assert "<stdin>:51" in r.stderr and "NaN" in r.stderr
    assert len(r.stdout.splitlines()) > 2  # the points before the bad row were written


@pytest.mark.parametrize(
    "content,needle",
    [
        ("", "empty"),
        ("Timestamp (us),W,X,Y,Z\n", "no data"),
        ("Timestamp (us),W,X,Y,Z\n1,1,0,0,0\n2,1,0,0\n", ":3:"),
        ("Timestamp (us),W,X,Y,Z\n1,1,0,0,0\n1,1,0,0,0\n", "duplicate"),
        ("Timestamp (us),W,X,Y,Z\n1,1,0,0,0\n2,0,0,0,0\n", "zero"),
        ("Timestamp (us),W,X,Y,Z\n1,1,0,0,0\n2,inf,0,0,0\n", ":3:"),
        ("hello,world\n1,2\n", "header"),
    ],
)
def test_bad_input_exit_code_2_one_line(tmp_path, content, needle):
    f = tmp_path / "bad.csv"
    f.write_text(content)
    r = run("compress", f, "--threshold", "1e-3")
    assert r.returncode == 2
    msg = r.stderr.strip()
    assert "\n" not in msg and "Traceback" not in msg
    assert "bad.csv" in msg and needle.lower() in msg.lower()


def test_usage_errors_exit_2(pelvis, tmp_path):
    r = run("compress", pelvis)  # no error control given
    assert r.returncode == 2 and "exactly one" in r.stderr
    r = run("compress", pelvis, "--threshold", "-1")
    assert r.returncode == 2 and "threshold" in r.stderr
    r = run("compress", tmp_path / "missing.csv", "--threshold", "1")
    assert r.returncode == 2 and "missing.csv" in r.stderr
    r = run("compress", pelvis, "--threshold", "1", "--rate", "50")
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_demo_runs_on_bundled_data(tmp_path):
    r = run_here("demo", "--out", tmp_path / "demo")
    assert r.returncode == 0, r.stderr
    assert "anglesw" in r.stderr
    assert len(list((tmp_path / "demo").glob("*/*.csv"))) == 6 * 7


def test_sweep_small(tests_data, tmp_path):
    r = run_here("sweep", tests_data / "xio", "--out", tmp_path / "sw", "--thresholds", "6")
    assert r.returncode == 0, r.stderr
    import csv

    rows = list(csv.DictReader((tmp_path / "sw" / "sweep.csv").open()))
    assert len(rows) == 2 * 4 * 6
    assert (tmp_path / "sw" / "fig3_time_per_sample.png").stat().st_size > 10_000
    assert (tmp_path / "sw" / "fig4_error_vs_icr.png").stat().st_size > 10_000
    # SW and fastSW rows agree on every point count
    by = {(r["method"], r["threshold"], r["signal"]): r for r in rows}
    for (m, th, s), r in by.items():
        if m == "sw":
            assert by[("fastsw", th, s)]["n_points"] == r["n_points"]


def test_bench_quick_json():
    r = run_here("bench", "--quick", "--json")
    assert r.returncode == 0, r.stderr
    recs = json.loads(r.stdout)
    methods = {(x["method"], x["mode"]) for x in recs if "ns_per_sample" in x}
    for m in ("fastsw", "sw", "cplr", "swing"):
        assert (m, "batch") in methods and (m, "stream") in methods
    assert all(x["ns_per_sample"] > 0 for x in recs if "ns_per_sample" in x)


def test_rate_for_files_without_timestamps(tests_data, tmp_path):
    legacy = tests_data / "formats" / "legacy_xio.csv"
    r = run_here("compress", legacy, "--threshold", "0")
    assert r.returncode == 2 and "--rate" in r.stderr
    pts = tmp_path / "pts.csv"
    r = run_here("compress", legacy, "--rate", "100", "--threshold", "1e-4", "-o", pts)
    assert r.returncode == 0, r.stderr
    full = tmp_path / "full.csv"
    r = run_here("decompress", pts, "--times-from", legacy, "--rate", "100", "-o", full)
    assert r.returncode == 0, r.stderr
    orig = read_imu_csv(legacy, rate=100)
    assert np.array_equal(read_imu_csv(full).times, orig.times)


def test_optimal_method_cli(pelvis):
    r = run_here("compress", pelvis, "--method", "optimal", "--max-angle", "2", "--json")
    assert r.returncode == 0, r.stderr
    (opt,) = json.loads(r.stdout)
    r = run_here("compress", pelvis, "--method", "anglesw", "--max-angle", "2", "--json")
    (ang,) = json.loads(r.stdout)
    assert opt["max_deg"] <= 2 + 1e-9 and opt["n_points"] <= ang["n_points"]
    r = run("stream", "--method", "optimal", "--max-angle", "2", stdin=pelvis.read_text())
    assert r.returncode == 2 and "offline" in r.stderr
