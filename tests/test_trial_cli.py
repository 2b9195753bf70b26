"""Issue 10 trial, options and usage: every option value gives a valid result or one ``error:`` line
naming the option (or the file), exit 2; usage mistakes are one line too; no traceback, no NaN in JSON.
Explicit cases from the issue, then a hypothesis search over commands × options × values.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from trial import checks, server
from trial.cases import BAD_VALUES

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the trial forks")


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory, tests_data) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("cli-inputs")
    src = {"imu": tests_data / "xio" / "pelvis" / "Quaternion.csv", "bvh": tests_data / "bvh" / "walk-meredith-60.bvh",
           "tsv": tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv",
           "amc": tests_data / "cmu" / "86_01_first60.amc", "asf": tests_data / "cmu" / "86.asf"}
    out = {}
    for k, p in src.items():
        out[k] = d / p.name
        shutil.copyfile(p, out[k])
    return out


def _mentions(line: str, option: str) -> bool:
    bare = option.lstrip("-")
    return any(s in line for s in (option, bare, bare.replace("-", "_")))


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "-inf", "1e308", "1e-320"])
def test_unit_cm_is_validated_and_named(trial, inputs, tmp_path, value):
    r = trial.run(["compress", inputs["bvh"], "--json", "--stats-only", "--max-position-error", "1",
                   "--unit-cm", value])
    line = checks.assert_clean_error(r, "--unit-cm")
    assert _mentions(line, "--unit-cm"), f"the message names another option: {line}"


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "-3"])
def test_max_position_error_is_validated_and_named(trial, inputs, value):
    r = trial.run(["compress", inputs["bvh"], "--json", "--stats-only", "--max-position-error", value])
    line = checks.assert_clean_error(r, "--max-position-error")
    assert _mentions(line, "--max-position-error"), line


@pytest.mark.parametrize("value", ["-3", "-1", "100000", "99999999999999999999"])
def test_precision_out_of_range(trial, inputs, tmp_path, value):
    r = trial.run(["convert", inputs["bvh"], tmp_path / "o.bvh", "--precision", value])
    if checks.assert_no_failure(r, "--precision") == "error":
        assert _mentions(r.first_error_line(), "--precision")


@pytest.mark.parametrize("value", ["99999999999999999999", "-1", "0", "2147483648", "9223372036854775808"])
@pytest.mark.parametrize("where", ["compress", "stream", "skeletal"])
def test_max_segment_length_out_of_range(trial, inputs, tmp_path, value, where):
    argv = {"compress": ["compress", inputs["imu"], "-t", "0.001", "--json"],
            "stream": ["stream", "-t", "0.001"],
            "skeletal": ["compress", inputs["bvh"], "-t", "0.01", "--json", "--stats-only"]}[where]
    r = trial.run(argv + ["--max-segment-length", value], stdin=inputs["imu"] if where == "stream" else None)
    if checks.assert_no_failure(r, "--max-segment-length") == "error":
        assert _mentions(r.first_error_line(), "--max-segment-length")


@pytest.mark.parametrize("argv", [
    ["info", "IMU", "--no-such-option"], ["compress", "IMU", "-t"], ["compress", "IMU", "-t", "abc"],
    ["compress", "IMU", "--method", "nope", "-t", "1"], ["filter", "TSV", "--solver", "nope", "--auto"],
    ["decompress", "IMU"], ["convert", "IMU"], ["info", "IMU", "extra-argument"], ["segment", "BVH", "-m", "nope"],
    ["info", "IMU", "--rate", "fast"], ["stream", "--max-segment-length", "1.5"], ["info"], ["nosuchcommand"],
])
def test_usage_errors_are_one_line(trial, inputs, argv):
    argv = [str(inputs["imu"]) if a == "IMU" else str(inputs["tsv"]) if a == "TSV" else
            str(inputs["bvh"]) if a == "BVH" else a for a in argv]
    r = trial.run(argv, stdin=inputs["imu"] if argv[0] == "stream" else None)
    checks.assert_clean_error(r, *[a for a in argv if a.startswith("-")], "nosuchcommand", "extra-argument",
                              "argument", "INPUT", "OUTPUT", "POINTS", "missing", "Missing")


@pytest.mark.parametrize("path", ["missing.csv", "folder", ""])
def test_unreadable_input_paths_are_one_line(trial, tmp_path, path):
    (tmp_path / "folder").mkdir()
    target = str(tmp_path / path) if path else ""
    r = trial.run(["info", target])
    checks.assert_clean_error(r, path or "''", "INPUT", "input", "folder")


def test_glb_errors_name_the_given_file(trial, inputs, tmp_path):
    clip = tmp_path / "clip.glb"
    checks.assert_ok(trial.run(["compress", inputs["bvh"], "-o", clip, "-t", "0.01"]))
    data = bytearray(clip.read_bytes())
    data[20:40] = b"\x00" * 20  # the JSON chunk's opening
    clip.write_bytes(bytes(data))
    r = trial.run(["decompress", clip, "-o", tmp_path / "d.bvh"])
    line = checks.assert_clean_error(r, clip.name)
    assert "/tmp/tmp" not in line.replace(str(tmp_path), ""), f"the message names a temporary file: {line}"


OPTION_CASES = [
    (["compress", "IMU", "-o", "OUT/p.csv"], ["--threshold", "--max-angle", "--target-icr", "--rate"]),
    (["compress", "IMU", "--json", "-t", "0.001"], ["--max-segment-length", "--rate"]),
    (["stream"], ["--threshold", "--max-angle", "--max-segment-length", "--rate"]),
    (["compress", "BVH", "-o", "OUT/c.glb"], ["--threshold", "--max-position-error", "--target-icr", "--max-angle"]),
    (["compress", "BVH", "--json", "--stats-only", "--max-position-error", "1"], ["--unit-cm", "--max-segment-length"]),
    (["convert", "BVH", "OUT/o.bvh"], ["--precision"]),
    (["convert", "AMC", "OUT/o.bvh", "--asf", "ASF"], ["--precision"]),
    (["segment", "BVH", "--json", "-m", "pca"], ["--downsample"]),
    (["filter", "TSV", "--json"], ["--penalty"]),
    (["filter", "TSV", "--auto", "--json"], ["--order"]),
    (["info", "IMU", "--json"], ["--rate", "--time-unit", "--time-column", "--quaternion-columns"]),
]

values = st.one_of(st.sampled_from(BAD_VALUES), st.floats().map(repr), st.integers(-10**25, 10**25).map(str),
                   st.sampled_from(["1e-9", "1e9", "0.5", "3", "s", "ms", "counter", "W,X,Y,Z", "a,b,c,d"]))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=st.sampled_from(OPTION_CASES), data=st.data())
def test_any_option_value_gives_a_result_or_a_named_error(trial, inputs, tmp_path, case, data):
    base, options = case
    opt = data.draw(st.sampled_from(options))
    value = data.draw(values)
    argv = [str(inputs["imu"]) if a == "IMU" else str(inputs["bvh"]) if a == "BVH" else str(inputs["tsv"])
            if a == "TSV" else str(inputs["amc"]) if a == "AMC" else str(inputs["asf"]) if a == "ASF"
            else a.replace("OUT", str(tmp_path)) for a in base]
    argv += [opt, value]
    if argv[0] in ("compress", "stream") and not any(o in argv for o in ("--threshold", "-t", "--max-angle",
                                                                         "--target-icr", "--max-position-error")):
        argv += ["-t", "0.001"]
    r = trial.run(argv, stdin=inputs["imu"] if argv[0] == "stream" else None, timeout=60)
    checks.assert_no_failure(r, opt, Path(argv[1]).name if len(argv) > 1 else "")
