"""Issue 10 on the command line: every bad option and usage error is one line ``error: ...`` with exit
code 2 naming the option; every JSON output is strict; ``decompress`` validates its points; streaming
encoders have a bounded segment length; an unexpected exception is one line with exit code 3.

Most cases run :func:`mocapkit.cli.main` in-process (stdout/stderr captured, ``SystemExit`` caught)
so that the hypothesis tests stay fast; a few run the installed entry point in a subprocess.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mocapkit import cli
from mocapkit.errors import InvalidParameterError, MocapError, MocapFormatError
from mocapkit.motion import Signal
from mocapkit.pla import Encoder, compress
from mocapkit.pla.decode import reconstruct_points, unit_quaternions

DATA = Path(__file__).resolve().parent / "data"
PELVIS = DATA / "xio" / "pelvis" / "Quaternion.csv"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
ASF = DATA / "cmu" / "86.asf"
AMC = DATA / "cmu" / "86_01_15hz_first1600.amc"
LABELS = DATA / "cmu" / "86_01_15hz_first1600.labels.txt"
TSV = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"


@dataclass
class Result:
    code: int
    out: str
    err: str


def cli_run(*args, stdin: str = "", env: dict | None = None) -> Result:
    """``mocapkit ARGS`` in-process: the exit code, stdout and stderr."""
    out, errs = io.StringIO(), io.StringIO()
    old_stdin, old_env = sys.stdin, dict(os.environ)
    sys.stdin = io.StringIO(stdin)
    os.environ.update(env or {})
    code = None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs):
            cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    finally:
        sys.stdin = old_stdin
        os.environ.clear()
        os.environ.update(old_env)
    assert code is not None, "main() must always end with SystemExit"
    return Result(code, out.getvalue(), errs.getvalue())


def assert_one_line_error(r: Result, *names: str, code: int = 2) -> str:
    lines = r.err.strip("\n").split("\n")
    assert r.code == code, (r.code, r.err)
    assert len(lines) == 1, f"expected one stderr line, got:\n{r.err}"
    assert lines[0].startswith("error: "), lines[0]
    assert "Traceback" not in r.err + r.out
    for n in names:
        assert n in lines[0], f"{n!r} not named in {lines[0]!r}"
    return lines[0]


def _no_constant(name):
    raise AssertionError(f"JSON holds {name}, which RFC 8259 does not allow")


def strict_json(text: str):
    """``json.loads`` that refuses NaN, Infinity and -Infinity."""
    return json.loads(text, parse_constant=_no_constant)


@pytest.fixture(scope="module")
def ok_csv(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("csv") / "ok.csv"
    t = np.arange(60) * 0.01
    y = np.where(t < 0.3, t, 0.6 - t) + 0.001 * np.sin(37 * t)
    p.write_text("time,a,b\n" + "".join(f"{a!r},{b!r},{c!r}\n"
                                        for a, b, c in zip(t.tolist(), y.tolist(), (2 * y).tolist(), strict=True)))
    return p


# --------------------------------------------------------------------------------------------
# every numeric option of every command: out of its domain -> one line naming it, exit 2
# --------------------------------------------------------------------------------------------

NAN, INF, HUGE_INT = "nan", "inf", "99999999999999999999"
BAD_OPTIONS = [
    # compress (IMU and skeletal)
    *[(["compress", PELVIS, "--threshold", v], "--threshold") for v in ("-1", NAN, INF, "-inf")],
    *[(["compress", PELVIS, "-t", v], "--threshold") for v in ("-0.5",)],
    *[(["compress", PELVIS, "--target-icr", v], "--target-icr") for v in ("0", "-0.1", "1.5", NAN, INF)],
    *[(["compress", PELVIS, "--max-angle", v], "--max-angle") for v in ("0", "-1", "180", "360", NAN, INF)],
    *[(["compress", PELVIS, "-t", "1", "--max-segment-length", v], "--max-segment-length")
      for v in ("0", "-1", "1000000001", HUGE_INT)],
    *[(["compress", PELVIS, "-t", "1", "--rate", v], "--rate") for v in ("0", "-100", NAN, INF, "1e7", "1e-9")],
    *[(["compress", BVH, "--max-position-error", "1", "--unit-cm", v, "--json"], "--unit-cm")
      for v in ("0", "-1", NAN, INF, "1e-320", "1e300")],
    *[(["compress", BVH, "--max-position-error", v, "--json"], "--max-position-error")
      for v in ("0", "-1", NAN, INF, "1e300")],
    # info
    *[(["info", PELVIS, "--rate", v], "--rate") for v in ("0", NAN)],
    # convert
    *[(["convert", BVH, "{tmp}/o.bvh", "--precision", v], "--precision") for v in ("-3", "21", HUGE_INT)],
    *[(["convert", BVH, "{tmp}/o.amc", "--asf", ASF, "--max-residual", v], "--max-residual")
      for v in ("-1", NAN, INF, "181")],
    # filter
    *[(["filter", "{ok}", "--auto", "--order", v], "--order") for v in ("-1", "11", HUGE_INT)],
    *[(["filter", "{ok}", "--penalty", v], "--penalty") for v in ("-1", NAN, INF)],
    # filter-eval
    (["filter-eval", "--out", "{tmp}/fe", "--penalty", "-1"], "--penalty"),
    *[(["filter-eval", "--out", "{tmp}/fe", "--unit-m", v], "--unit-m") for v in ("0", "-1", NAN)],
    *[(["filter-eval", "--out", "{tmp}/fe", "--sizes", v], "--sizes") for v in ("abc", "5", "1,x", "-100")],
    # decompress
    *[(["decompress", "{pts}", "-o", "{tmp}/d.csv", "--rate", v], "--rate") for v in ("0", "-1", NAN, INF)],
    # stream
    *[(["stream", "--threshold", v], "--threshold") for v in ("-1", NAN, INF)],
    *[(["stream", "--max-angle", v], "--max-angle") for v in ("0", "180", NAN)],
    *[(["stream", "-t", "1", "--max-segment-length", v], "--max-segment-length") for v in ("0", HUGE_INT)],
    (["stream", "-t", "1", "--rate", "0"], "--rate"),
    # sweep
    *[(["sweep", PELVIS, "--out", "{tmp}/sw", "--thresholds", v], "--thresholds") for v in ("1", "0", "-5", HUGE_INT)],
    *[(["sweep", PELVIS, "--out", "{tmp}/sw", "--max-segment-length", v], "--max-segment-length")
      for v in ("0", HUGE_INT)],
    (["sweep", PELVIS, "--out", "{tmp}/sw", "--rate", NAN], "--rate"),
    *[(["sweep", BVH, "--out", "{tmp}/sw", "--unit-cm", f"walk-meredith-60={v}"], "--unit-cm")
      for v in ("0", "-1", NAN, INF, "abc")],
    # bench
    *[(["bench", "--channels", v], "--channels") for v in ("0", "-1", HUGE_INT)],
    *[(["bench", "--frames", v], "--frames") for v in ("99", "0", HUGE_INT)],
    (["bench", "--frames", "100000000", "--channels", "10"], "--channels 10 x --frames 100000000"),
    # segment
    *[(["segment", BVH, "--rate", v], "--rate") for v in ("0", NAN)],
    *[(["segment", BVH, "--downsample", v], "--downsample") for v in ("0", "-2", HUGE_INT)],
    # segment-bench
    (["segment-bench", "--rate", "0"], "--rate"),
    (["segment-bench", "--tssb-limit", "0"], "--tssb-limit"),
    (["segment-bench", "--methods", "bogus", "--data", "{tmp}"], "--methods"),
]


@pytest.fixture(scope="module")
def points_csv(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("pts") / "pts.csv"
    r = cli_run("compress", PELVIS, "-t", "1e-3", "-o", p)
    assert r.code == 0, r.err
    return p


@pytest.mark.parametrize("args,option", BAD_OPTIONS, ids=[" ".join(map(str, a[:1] + a[-2:])) for a, _ in BAD_OPTIONS])
def test_bad_option_is_one_line_naming_it(args, option, tmp_path, ok_csv, points_csv):
    args = [str(a).format(tmp=tmp_path, ok=ok_csv, pts=points_csv) for a in args]
    r = cli_run(*args)
    assert_one_line_error(r, option)
    assert r.out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # refused before any output


def test_unit_cm_minus_one_is_not_reported_as_the_position_error():
    line = assert_one_line_error(cli_run("compress", BVH, "--max-position-error", "1", "--unit-cm", "-1", "--json"))
    assert "--unit-cm" in line and "position" not in line


def test_option_limits_match_the_library():
    from mocapkit.filters.api import MAX_ORDER
    from mocapkit.pla.base import MAX_SEGMENT_LENGTH_LIMIT

    assert cli.MAX_SEGMENT_LENGTH == MAX_SEGMENT_LENGTH_LIMIT
    assert cli.MAX_FILTER_ORDER == MAX_ORDER


def test_library_refuses_what_the_options_refuse():
    sig = Signal(np.arange(5.0), np.tile([1.0, 0, 0, 0], (5, 1)), "quaternion")
    for L in (0, -1, 10**9 + 1, 10**20, 2.5, True):
        with pytest.raises(InvalidParameterError, match="max segment length"):
            compress(sig, "fastsw", 0.1, L)
        with pytest.raises(InvalidParameterError, match="max segment length"):
            Encoder("sw", 0.1, max_segment_length=L)
    from mocapkit.filters.api import fit

    t = np.arange(20.0)
    for order in (-1, 11, 2.0, 10**20):
        with pytest.raises(InvalidParameterError, match="order"):
            fit(t, t, order=order, penalty=1.0)
    for gap in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(InvalidParameterError, match="gap"):
            fit(t, t, order=1, penalty=1.0, max_gap=gap)


# --------------------------------------------------------------------------------------------
# usage errors: one line, exit 2; and the real entry point in a subprocess
# --------------------------------------------------------------------------------------------

USAGE = [
    (["compress"], "input"),
    (["compress", PELVIS, "--bogus"], "--bogus"),
    (["compress", PELVIS, "-t", "1", "--max-segment-length", "x"], "--max-segment-length"),
    (["compress", PELVIS, "-t", "1", "--max-segment-length", "1.5"], "--max-segment-length"),
    (["compress", PELVIS, "--threshold", "abc"], "--threshold"),
    (["compress", PELVIS, "--threshold"], "--threshold"),
    (["compress", PELVIS, "-m", "foo", "-t", "1"], "--method"),
    (["nosuchcommand"], "nosuchcommand"),
    (["--bogus"], "--bogus"),
    (["convert", BVH], "output"),
    (["decompress", PELVIS], "--output"),
    (["filter", PELVIS, "--solver", "best"], "--solver"),
    (["segment", BVH, "-m", "magic"], "--method"),
    (["info", "/nonexistent/file.bvh"], "/nonexistent/file.bvh"),
    (["compress", "/nonexistent/q.csv", "-t", "1"], "/nonexistent/q.csv"),
]


@pytest.mark.parametrize("args,name", USAGE, ids=[" ".join(map(str, a))[-40:] for a, _ in USAGE])
def test_usage_errors_are_one_line(args, name):
    assert_one_line_error(cli_run(*args), name)


def test_entry_point_usage_and_option_errors_in_a_subprocess(tmp_path):
    exe = Path(sys.executable).parent / "mocapkit"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "mocapkit.cli"]
    for args, name in ((["compress", str(PELVIS), "--bogus"], "--bogus"),
                       (["compress", str(BVH), "--max-position-error", "1", "--unit-cm", "0", "--json"], "--unit-cm"),
                       (["compress", str(PELVIS), "-t", "1", "--max-segment-length", HUGE_INT], "--max-segment-length"),
                       (["compress"], "input")):
        p = subprocess.run(cmd + args, capture_output=True, text=True, timeout=300, cwd=tmp_path,
                           env={**os.environ, "COLUMNS": "80"})
        assert_one_line_error(Result(p.returncode, p.stdout, p.stderr), name)
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)  # bare: the help, not an error box
    assert p.returncode == 2 and "Usage" in p.stdout + p.stderr and "Traceback" not in p.stderr
    p = subprocess.run(cmd + ["--version"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and p.stdout.startswith("mocapkit ")


# --------------------------------------------------------------------------------------------
# catch-all: MocapError -> one line, exit 2; a bug -> one line, exit 3, traceback on request
# --------------------------------------------------------------------------------------------


def test_internal_error_is_one_line_with_exit_3(monkeypatch):
    import mocapkit.io.loaders as loaders

    def boom(path):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(loaders, "kind_of", boom)
    r = cli_run("compress", PELVIS, "-t", "1")
    line = assert_one_line_error(r, "internal error", "RuntimeError", "boom second line", "please report", code=3)
    assert "MOCAPKIT_DEBUG" in line
    r = cli_run("compress", PELVIS, "-t", "1", env={"MOCAPKIT_DEBUG": "1"})
    assert r.code == 3 and "Traceback" in r.err and r.err.rstrip().split("\n")[-1].startswith("error: internal error")


def test_mocap_error_with_newlines_is_one_line(monkeypatch):
    import mocapkit.io.loaders as loaders

    def bad(path):
        raise MocapFormatError(path, 7, "first\nsecond")

    monkeypatch.setattr(loaders, "kind_of", bad)
    assert_one_line_error(cli_run("compress", PELVIS, "-t", "1"), f"{PELVIS}:7: first second")


# --------------------------------------------------------------------------------------------
# strict JSON on every --json path and JSON file
# --------------------------------------------------------------------------------------------


def test_json_helper_refuses_non_finite_naming_the_field():
    assert strict_json(cli._json({"a": [1.0, {"b": None}]}, "x")) == {"a": [1.0, {"b": None}]}
    for bad, field in (({"a": [1.0, {"b": math.nan}]}, "a[1].b"), ([{"icr": math.inf}], "[0].icr"),
                       ({"r": np.float64(-math.inf)}, "r")):
        with pytest.raises(MocapError, match=field.replace("[", r"\[").replace("]", r"\]")):
            cli._json(bad, "what")


IMU_FILES = sorted(p for p in (DATA / "imu").rglob("*") if p.is_file()) + sorted((DATA / "formats").iterdir())
INFO_FILES = [[p] for p in IMU_FILES] + [
    [BVH], [DATA / "bvh" / "perception-neuron-freya-12.bvh"], [AMC, "--asf", ASF],
    [DATA / "cmu" / "86_01_first60.amc", "--asf", ASF],
    [DATA / "mvnx" / "86_01_xsens_60hz.mvnx"], [TSV], [DATA / "markers" / "vicon-nexus-walking2-excerpt.csv"],
    *[[p] for p in sorted((DATA / "opensim").iterdir())], [DATA / "xio" / "pelvis"],
]


@pytest.mark.parametrize("args", INFO_FILES, ids=[a[0].name for a in INFO_FILES])
def test_info_json_is_strict(args):
    r = cli_run("info", *args, "--json")
    if r.code == 2:  # a reader's documented refusal (e.g. a format needing --rate): one line, no JSON
        assert_one_line_error(r)
        return
    assert r.code == 0, r.err
    rec = strict_json(r.out)
    assert rec["file"] == str(args[0])


@pytest.mark.parametrize("control", [["-t", "1e-3"], ["--target-icr", "0.1"], ["--max-angle", "1"], ["-t", "0"],
                                     ["-t", "1e300"], ["--max-angle", "179.9"], ["--target-icr", "1"]])
@pytest.mark.parametrize("method", ["fastsw", "sw", "cplr", "swing", "anglesw"])
def test_compress_json_is_strict(method, control):
    r = cli_run("compress", PELVIS, "-m", method, *control, "--json")
    assert r.code in (0, 2), r.err
    if r.code == 2:
        assert_one_line_error(r)
        return
    (rec,) = strict_json(r.out)
    assert rec["method"] == method and rec["n_points"] >= 2
    if method in ("sw", "anglesw"):
        assert rec["max_segment_length"] == 1000  # the default that bounds their work per sample


def test_compress_folder_and_skeletal_json_are_strict(tmp_path):
    r = cli_run("compress", DATA / "xio", "--max-angle", "2", "--json")
    assert r.code == 0, r.err
    assert len(strict_json(r.out)) >= 2
    for control in (["-t", "1e-4"], ["--max-position-error", "1"], ["--target-icr", "0.2"]):
        r = cli_run("compress", BVH, *control, "--json")
        assert r.code == 0, r.err
        assert strict_json(r.out)["n_frames"] > 0
    r = cli_run("compress", AMC, "--asf", ASF, "--max-position-error", "0.5", "--unit-cm", "2.54", "--json",
                "-o", tmp_path / "c.glb")
    assert r.code == 0, r.err
    assert strict_json(r.out)["max_position_error_cm"] <= 0.5 + 1e-9


def test_filter_json_is_strict(ok_csv):
    for args in ([ok_csv, "--auto"], [ok_csv, "--penalty", "0.01", "--solver", "iterative"], [TSV, "--auto"]):
        r = cli_run("filter", *args, "--json")
        assert r.code == 0, r.err
        recs = strict_json(r.out)
        assert recs and all("name" in x for x in recs)


def test_segment_and_segment_bench_json_are_strict(tmp_path):
    r = cli_run("segment", AMC, "--asf", ASF, "-m", "kmeans", "--labels", LABELS, "--json")
    assert r.code == 0, r.err
    rec = strict_json(r.out)
    assert isinstance(rec["cuts"], list) and "scores" in rec and rec["n_frames"] > 0
    r = cli_run("segment-bench", f"{AMC}={LABELS}", "--asf", ASF, "--methods", "kmeans", "--json",
                "--out", tmp_path / "sb")
    assert r.code == 0, r.err
    assert strict_json(r.out)["cmu"]
    assert strict_json((tmp_path / "sb" / "segment_bench.json").read_text())["cmu"]


def test_bench_json_is_strict():
    r = cli_run("bench", "--quick", "--json")
    assert r.code == 0, r.err
    recs = strict_json(r.out)
    assert sum("ns_per_sample" in x for x in recs) >= 10


def test_filter_eval_json_files_are_strict(tmp_path):
    r = cli_run("filter-eval", "--out", tmp_path / "fe", "--sizes", "", "--juggling", TSV)
    assert r.code == 0, r.err
    for name in ("synthetic.json", "juggling.json", "timing.json"):
        strict_json((tmp_path / "fe" / name).read_text())


# --------------------------------------------------------------------------------------------
# filter: the cases that gave tracebacks
# --------------------------------------------------------------------------------------------

FILTER_BAD = [
    ("time\n0\n1\n2\n3\n", "one column"),
    ("time,a\n0,1\n1,1e308\n2,-1e308\n3,1\n", "1e308"),
    (b"time,a\n0,1\n1,\xff\n2,3\n", "not a number"),
    ("time,a\n0,1\n1,0_5\n2,3\n", "0_5"),
    ("time,a\n0,1\n1,inf\n2,3\n", "inf"),
    ("time,a\n0,1\n0,2\n2,3\n", "time"),
    ("time,a\n", "no data rows"),
    ("", "empty"),
]


@pytest.mark.parametrize("text,words", FILTER_BAD)
@pytest.mark.parametrize("extra", [[], ["-o", "out.csv"], ["--json"]])
def test_filter_bad_csv_is_one_line(tmp_path, text, words, extra):
    p = tmp_path / "in.csv"
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    extra = [str(tmp_path / e) if e.endswith(".csv") else e for e in extra]
    assert_one_line_error(cli_run("filter", p, "--auto", *extra), str(p), words)
    assert not (tmp_path / "out.csv").exists()


def test_filter_latin1_header_is_read(tmp_path):
    p = tmp_path / "in.csv"
    p.write_bytes("time,h\xf6he\n".encode("latin-1")
                  + "".join(f"{i * 0.01!r},{(i % 7) * 0.1!r}\n" for i in range(40)).encode())
    r = cli_run("filter", p, "--auto", "--json")
    assert r.code == 0, r.err
    assert strict_json(r.out)[0]["name"] == "h\u00f6he"


# --------------------------------------------------------------------------------------------
# decompress: points validated like a reader; never a zero-norm or NaN row written
# --------------------------------------------------------------------------------------------

CORRUPT = [
    (lambda f: [f[0], "nan", *f[2:]], ":4:"),
    (lambda f: [f[0], "inf", *f[2:]], ":4:"),
    (lambda f: [f[0], "", *f[2:]], ":4:"),
    (lambda f: [f[0], "0", "0", "0", "0"], ":4:"),
    (lambda f: [f[0], "0.0", "-0.0", "0e5", "0"], ":4:"),
    (lambda f: [f[0], "0_5", *f[2:]], ":4:"),
    (lambda f: ["-5", *f[1:]], ":4:"),
    (lambda f: f[:3], ":4:"),
]


@pytest.mark.parametrize("mutate,where", CORRUPT)
@pytest.mark.parametrize("decode", [["--rate", "100"], ["--times-from", PELVIS]])
def test_decompress_refuses_corrupted_points(points_csv, tmp_path, mutate, where, decode):
    lines = points_csv.read_text().splitlines()
    lines[3] = ",".join(mutate(lines[3].split(",")))
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    r = cli_run("decompress", bad, "-o", tmp_path / "out.csv", *decode)
    assert_one_line_error(r, f"{bad}{where}")
    assert not (tmp_path / "out.csv").exists()


def test_decompress_duplicate_time_is_refused(points_csv, tmp_path):
    lines = points_csv.read_text().splitlines()
    lines[3] = ",".join([lines[2].split(",")[0], *lines[3].split(",")[1:]])
    bad = tmp_path / "dup.csv"
    bad.write_text("\n".join(lines) + "\n")
    assert_one_line_error(cli_run("decompress", bad, "-o", tmp_path / "o.csv", "--rate", "50"), f"{bad}:4:")


@pytest.mark.parametrize("value", ["1e300", "1e-200", "1e12", "1e-12"])
def test_decompress_extreme_components_never_write_bad_rows(points_csv, tmp_path, value):
    """A component far from 1 is refused by the reader (out of range / zero norm) or, where the reader
    lets it through, the written quaternions are still finite unit quaternions."""
    lines = points_csv.read_text().splitlines()
    f = lines[3].split(",")
    lines[3] = ",".join([f[0], value, "0", "0", value])
    bad = tmp_path / "x.csv"
    bad.write_text("\n".join(lines) + "\n")
    out = tmp_path / "o.csv"
    r = cli_run("decompress", bad, "-o", out, "--rate", "100")
    if r.code == 2:
        assert_one_line_error(r, str(bad))
        return
    assert r.code == 0, r.err
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:]
    assert np.all(np.isfinite(q))
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)


def test_decompress_rate_too_fine_for_the_times(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("time (s),w,x,y,z\n100000000000,1,0,0,0\n100000000001,0,1,0,0\n")  # ulp ~1.5e-5 s
    assert_one_line_error(cli_run("decompress", p, "-o", tmp_path / "o.csv", "--rate", "1e6"), "--rate")
    assert not (tmp_path / "o.csv").exists()


def test_unit_quaternions_without_overflow_or_underflow():
    q = np.array([[1e300, 0, 0, 1e300], [1e-200, 0, 0, 1e-200], [2.0, 0, 0, 2.0], [0, -3e-310, 0, 0]])
    u = unit_quaternions(q)
    h = math.sqrt(0.5)
    np.testing.assert_array_equal(u[0], u[2])  # scaled first: 1e300 and 1e-200 normalise exactly like 2
    np.testing.assert_array_equal(u[1], u[2])
    np.testing.assert_allclose(u[2], [h, 0, 0, h], rtol=0, atol=2e-16)
    np.testing.assert_array_equal(u[3], [0, -1.0, 0, 0])
    for bad in ([0, 0, 0, 0], [math.nan, 1, 0, 0], [math.inf, 0, 0, 0]):
        with pytest.raises(InvalidParameterError, match="segment point 1"):
            unit_quaternions(np.array([[1.0, 0, 0, 0], bad]))


def test_reconstruct_points_refuses_bad_points():
    t = np.array([0.0, 1.0, 2.0])
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    np.testing.assert_array_equal(reconstruct_points(t, q * 1e-200, t), q)  # tiny but not zero: fine
    for tt, qq, msg in ((t, np.vstack([q[:2], [0, 0, 0, 0]]), "zero-norm"),
                        (np.array([0.0, 1.0, 1.0]), q, "increasing"),
                        (np.array([0.0, math.nan, 2.0]), q, "finite")):
        with pytest.raises(InvalidParameterError, match=msg):
            reconstruct_points(tt, qq, np.array([0.0, 0.5]))
    with pytest.raises(InvalidParameterError, match="not finite"):  # vector difference overflows
        reconstruct_points(np.array([0.0, 1.0]), np.array([[-1.7e308], [1.7e308]]), np.array([0.5]), "vector")


# --------------------------------------------------------------------------------------------
# streaming: a default maximum segment length bounds the work per sample; batch == stream
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["sw", "anglesw"])
def test_streaming_segment_length_is_bounded_by_default(method):
    n = 3500
    times = np.arange(n) * 0.01
    q = np.tile([0.5, 0.5, 0.5, 0.5], (n, 1))  # a still sensor: one endless segment without a cap
    enc = Encoder(method, 1e9 if method == "sw" else 90.0)
    idx = []
    for k in range(n):
        idx += [p.index for p in enc.push(times[k], q[k])]
        # the buffer the per-sample check walks never holds more than the default length
        assert int(enc._state[0][2]) <= 1000
        assert enc._state[-2].shape[0] <= 2048
    idx += [p.index for p in enc.flush()]
    assert idx == [0, 1000, 2000, 3000, n - 1]
    comp = compress(Signal(times, q, "quaternion"), method, 1e9 if method == "sw" else 90.0)
    assert comp.indices.tolist() == idx  # batch applies the same default
    assert comp.max_segment_length == 1000
    # an explicit length still wins, in both
    enc = Encoder(method, 1e9 if method == "sw" else 90.0, max_segment_length=7)
    got = [p.index for k in range(50) for p in enc.push(times[k], q[k])] + [p.index for p in enc.flush()]
    assert got == compress(Signal(times[:50], q[:50], "quaternion"), method, 1e9 if method == "sw" else 90.0,
                           7).indices.tolist()
    assert np.diff(got).max() == 7


@pytest.mark.parametrize("method", ["fastsw", "cplr", "swing"])
def test_o1_methods_stay_unbounded_by_default(method):
    n = 2500
    times = np.arange(n) * 0.01
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    assert compress(Signal(times, q, "quaternion"), method, 1.0).indices.tolist() == [0, n - 1]


def test_stream_command_on_constant_input_emits_a_point_every_1000_samples():
    rows = "".join(f"{k * 0.01!r},0.5,0.5,0.5,0.5\n" for k in range(2500))
    r = cli_run("stream", "-m", "sw", "-t", "1e9", stdin="time,w,x,y,z\n" + rows)
    assert r.code == 0, r.err
    t = np.array([float(line.split(",")[0]) for line in r.out.splitlines()[1:]])
    np.testing.assert_allclose(t, [0.0, 10.0, 20.0, 24.99])


def test_stream_never_writes_a_non_finite_point(monkeypatch):
    from mocapkit.pla import base

    real_flush = base.Encoder.flush
    monkeypatch.setattr(base.Encoder, "flush",
                        lambda self: real_flush(self) + [base.Point(99, 9.0, (math.nan, 0.0, 0.0, 1.0))])
    r = cli_run("stream", "-t", "0.1", stdin="time,w,x,y,z\n0,1,0,0,0\n1,1,0,0,0\n")
    assert_one_line_error(r, "<stdin>", "not finite")
    assert "nan" not in r.out


@settings(max_examples=150, deadline=None)
@given(steps=st.lists(st.sampled_from([1e-100, 3e-77, 1e-9, 0.01, 1.0, 1e6]), min_size=1, max_size=25),
       vals=st.lists(st.sampled_from([0.0, 1.0, -1.0, 1e-300, 1e12, -1e12, 0.5]), min_size=104, max_size=104),
       method=st.sampled_from(["fastsw", "sw", "cplr", "swing", "anglesw"]),
       th=st.sampled_from([0.0, 1e-300, 1e-3, 1.0, 1e300]), kind=st.sampled_from(["quaternion", "vector"]),
       L=st.sampled_from([None, 1, 3]))
def test_kernels_on_extreme_finite_input_are_finite_and_agree(steps, vals, method, th, kind, L):
    """Time steps down to the 1e-100 s limit and values of +-1e12: batch and stream give the same
    finite points, or both refuse with a MocapError (never a ZeroDivisionError or a NaN point)."""
    if method == "anglesw":
        kind = "quaternion"
    n = len(steps) + 1
    t = np.concatenate([[0.0], np.cumsum(steps)])
    assume(np.all(np.diff(t) > 0))  # a tiny step after a large time is absorbed by rounding
    X = np.array(vals[: n * 4]).reshape(n, 4)
    X[np.all(X == 0, axis=1), 0] = 1.0  # the model refuses zero quaternions
    if kind == "vector":
        X = X[:, :3]
    try:
        sig = Signal(t, X, kind)
    except MocapError:  # the model's own refusal (e.g. a 1e-300 quaternion's norm underflows to zero)
        assume(False)
    try:
        comp = compress(sig, method, th, L)
    except MocapError:
        with pytest.raises(MocapError):
            enc = Encoder(method, th, dim=sig.dim, kind=kind, max_segment_length=L)
            for k in range(n):
                enc.push(t[k], X[k])
        return
    assert np.all(np.isfinite(comp.values)) and comp.indices[0] == 0 and comp.indices[-1] == n - 1
    enc = Encoder(method, th, dim=sig.dim, kind=kind, max_segment_length=L)
    pts = [p for k in range(n) for p in enc.push(t[k], X[k])] + enc.flush()
    assert [p.index for p in pts] == comp.indices.tolist()
    np.testing.assert_array_equal(np.array([p.values for p in pts]), comp.values)


def test_time_steps_below_the_limit_are_refused():
    from mocapkit.errors import InvalidSignalError

    sig = Signal(np.array([0.0, 1e-300, 1.0]), np.array([[1.0, 0, 0, 0], [1, 1e12, 0, 0], [1, 0, 0, 0]]), "quaternion")
    for m in ("fastsw", "sw", "cplr", "swing", "anglesw"):
        with pytest.raises(InvalidSignalError, match="time step"):
            compress(sig, m, 0.0)
        enc = Encoder(m, 0.0)
        enc.push(0.0, (1.0, 0, 0, 0))
        with pytest.raises(InvalidSignalError, match="time step"):
            enc.push(1e-300, (1.0, 1e12, 0, 0))


# --------------------------------------------------------------------------------------------
# hypothesis: any option value gives exit 0 or 2, never a traceback; JSON valid on success
# --------------------------------------------------------------------------------------------

odd_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["0", "-0", "1e308", "-1e308", "1e-320", "5e-324", "nan", "-inf", "1e999", "0x10", "1_0",
                     "", " ", "--", "1e", ".", "１", "1,5", "2**3", "NaN", "Infinity"]),
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.floats(min_value=-1e3, max_value=1e3).map(lambda x: f"{x:.6g}"),
    st.text(max_size=6),
)
HSET = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def check_outcome(r: Result, as_json: bool) -> None:
    assert r.code in (0, 2), (r.code, r.err)
    assert "Traceback" not in r.out + r.err
    if r.code == 2:
        assert r.err.rstrip("\n").split("\n")[-1].startswith("error: ")
    elif as_json:
        strict_json(r.out)


@HSET
@given(opt=st.sampled_from(["--threshold", "--target-icr", "--max-angle", "--max-segment-length", "--rate"]),
       value=odd_numbers, method=st.sampled_from(["fastsw", "sw", "cplr", "swing", "anglesw", "optimal"]))
def test_hypothesis_compress_options(opt, value, method):
    control = [] if opt in ("--threshold", "--target-icr", "--max-angle") else ["--max-angle", "2"]
    check_outcome(cli_run("compress", PELVIS, "-m", method, *control, opt, value, "--json"), True)


@HSET
@given(opt=st.sampled_from(["--unit-cm", "--max-position-error", "--threshold", "--max-segment-length"]),
       value=odd_numbers)
def test_hypothesis_compress_skeletal_options(opt, value):
    control = ["--max-position-error", "2"] if opt in ("--unit-cm", "--max-segment-length") else []
    check_outcome(cli_run("compress", BVH, *control, opt, value, "--json"), True)


@HSET
@given(opt=st.sampled_from(["--order", "--penalty"]), value=odd_numbers, solver=st.sampled_from(["exact", "iterative"]))
def test_hypothesis_filter_options(ok_csv, opt, value, solver):
    rest = ["--auto"] if opt == "--order" else []
    check_outcome(cli_run("filter", ok_csv, "--solver", solver, *rest, opt, value, "--json"), True)


@HSET
@given(opt=st.sampled_from(["--threshold", "--max-angle", "--max-segment-length", "--rate"]), value=odd_numbers,
       method=st.sampled_from(["fastsw", "sw", "cplr", "swing", "anglesw"]))
def test_hypothesis_stream_options(opt, value, method):
    src = "".join(PELVIS.read_text().splitlines(keepends=True)[:60])
    control = [] if opt in ("--threshold", "--max-angle") else ["-t", "0.5"]
    r = cli_run("stream", "-m", method, *control, opt, value, stdin=src)
    check_outcome(r, False)
    if r.code == 0:
        vals = np.array([[float(x) for x in line.split(",")] for line in r.out.splitlines()[1:]])
        assert vals.shape[0] >= 2 and np.all(np.isfinite(vals))


@HSET
@given(opt=st.sampled_from(["--precision", "--max-residual"]), value=odd_numbers)
def test_hypothesis_convert_options(tmp_path, opt, value):
    out = tmp_path / "o.bvh"
    check_outcome(cli_run("convert", BVH, out, opt, value), False)


# --- errors found by the adversarial trial that did not name the option or the file -------------------

def test_unreachable_target_icr_names_the_option():
    for src in (PELVIS, BVH):
        r = cli_run("compress", str(src), "--target-icr", "4.9e-324", "--stats-only")
        msg = assert_one_line_error(r, "--target-icr")
        assert "out of reach" in msg


def test_position_bound_below_float_resolution_is_refused_by_option_and_library():
    r = cli_run("compress", str(BVH), "--max-position-error", "1e-320", "--stats-only")
    assert_one_line_error(r, "--max-position-error")
    from mocapkit.io.skeletal.bvh import read_bvh
    from mocapkit.pla.skeletal import compress_motion

    with pytest.raises(InvalidParameterError, match="below what float64 forward kinematics resolves"):
        compress_motion(read_bvh(BVH), "fastsw", max_position_error=1e-300)


def test_c3d_writer_errors_name_the_output(tmp_path):
    from mocapkit import Markers
    from mocapkit.io.markers.c3d import write_c3d

    out = tmp_path / "gappy.c3d"
    mk = Markers(np.array([0.0, 0.01, 0.025]), np.zeros((3, 1, 3)), ["a"], 100.0)
    with pytest.raises(InvalidParameterError, match=r"gappy\.c3d: cannot be written as C3D: .*constant rate"):
        write_c3d(mk, out)
    assert not out.exists()


@pytest.mark.parametrize("argv", [["info", ""], ["compress", "", "--max-angle", "1"], ["info", "--json", ""],
                                  ["decompress", "x.mkp", "-o", "out.csv", ""]])
def test_an_empty_argument_is_a_usage_error_not_the_current_folder(argv, capsys):
    """``Path("")`` is ``.``: ``mocapkit info ''`` must not read the current folder (an option's value may be
    empty: ``filter-eval --sizes ''``)."""
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    assert "an empty argument" in capsys.readouterr().err
