"""Issue 10 trial, numbers: NaN, inf and overflowing values are refused where the format has no missing
value; a number the strict grammar refuses (``0_5``) or one cut at the end of the file is never read as
a different value without a word; no traceback on ordinary mistakes (non-UTF-8, ±1e308, a time-only CSV).

"Not silent" is checked differentially (``trial.checks.assert_not_silent``): the library's read of the
mutated file is an error, or carries a warning, or equals the read of the original.
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

from trial import checks, server
from trial.mutators import NUMBER

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the trial forks")


@pytest.fixture(scope="module")
def trial():
    return server.shared_client()


def _copy(src: Path, dst_dir: Path, name: str | None = None) -> Path:
    dst_dir.mkdir(parents=True, exist_ok=True)
    dst = dst_dir / (name or src.name)
    shutil.copyfile(src, dst)
    return dst


def _sub(path: Path, pattern: str, repl: str) -> Path:
    text = path.read_text()
    new, n = re.subn(pattern, repl, text, count=1, flags=re.M)
    assert n == 1, f"{pattern!r} not found in {path.name}"
    path.write_text(new)
    return path


# --------------------------------------------------------------------------------------------------
# explicit cases of the issue
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e308", "NaN"])
@pytest.mark.parametrize("command", ["info", "convert", "compress"])
def test_bvh_offset_not_finite_or_huge_is_a_clean_error(trial, tests_data, tmp_path, value, command):
    bvh = _sub(_copy(tests_data / "bvh" / "walk-meredith-60.bvh", tmp_path / "in"), r"OFFSET 11\.2666",
               f"OFFSET {value}")
    argv = {"info": ["info", bvh, "--json"], "convert": ["convert", bvh, tmp_path / "o.bvh"],
            "compress": ["compress", bvh, "--json", "--stats-only", "--max-position-error", "1", "--unit-cm", "1"]}
    checks.assert_clean_error(trial.run(argv[command]), bvh.name)
    assert not (tmp_path / "o.bvh").exists()


@pytest.mark.parametrize("value", ["1e308", "nan", "inf"])
def test_amc_root_value_huge_is_a_clean_error(trial, tests_data, tmp_path, value):
    asf = _copy(tests_data / "cmu" / "86.asf", tmp_path / "in")
    amc = _sub(_copy(tests_data / "cmu" / "86_01_first60.amc", tmp_path / "in"), r"^root (\S+)", f"root {value}")
    for argv in (["info", amc, "--asf", asf, "--json"], ["convert", amc, tmp_path / "o.bvh", "--asf", asf],
                 ["compress", amc, "--asf", asf, "--json", "--stats-only", "--max-position-error", "1"]):
        checks.assert_clean_error(trial.run(argv), amc.name)


@pytest.mark.parametrize("value", ["1e308", "-1e308", "nan", "inf", "1e13"])
def test_quaternion_component_huge_is_a_clean_error(trial, tests_data, tmp_path, value):
    imu = _copy(tests_data / "xio" / "pelvis" / "Quaternion.csv", tmp_path / "in")
    _sub(imu, r"^(917438268),0\.850149", rf"\g<1>,{value}")
    for argv, stdin in ((["compress", imu, "-m", "anglesw", "--max-angle", "1", "--json"], None),
                        (["stream", "-m", "anglesw", "--max-angle", "1"], imu),
                        (["compress", imu, "-t", "0.001", "-o", tmp_path / "p.csv"], None),
                        (["info", imu, "--json"], None)):
        checks.assert_clean_error(trial.run(argv, stdin=stdin), imu.name, "<stdin>")


@pytest.mark.parametrize("row", ["0,0,0,0", "nan,0,0,0", "1e308,0,0,0", "inf,1,0,0"])
def test_decompress_validates_its_points(trial, tests_data, tmp_path, row):
    pts = tmp_path / "in" / "points.csv"
    pts.parent.mkdir()
    checks.assert_ok(trial.run(["compress", tests_data / "xio" / "pelvis" / "Quaternion.csv", "-t", "0.001",
                                "-o", pts]))
    lines = pts.read_text().splitlines()
    t = lines[3].split(",")[0]
    lines[3] = f"{t},{row}"
    pts.write_text("\n".join(lines) + "\n")
    checks.assert_clean_error(trial.run(["decompress", pts, "-o", tmp_path / "d.csv", "--rate", "50"]), pts.name)
    assert not (tmp_path / "d.csv").exists()


@pytest.mark.parametrize("frame_time", ["1e-320", "0", "-0.01", "nan", "1e308"])
def test_bvh_frame_time_out_of_range_is_a_clean_error(trial, tests_data, tmp_path, frame_time):
    bvh = _sub(_copy(tests_data / "bvh" / "walk-meredith-60.bvh", tmp_path / "in"), r"Frame Time:.*$",
               f"Frame Time: {frame_time}")
    checks.assert_clean_error(trial.run(["info", bvh, "--json"]), bvh.name)


TEXT_FILES = {
    "bvh": ("bvh/walk-meredith-60.bvh", "bvh", {}), "amc": ("cmu/86_01_first60.amc", "amc", {"asf": "86.asf"}),
    "trc": ("opensim/walk_free_01-first20.trc", "trc", {}),
    "mot": ("opensim/subject01_walk1_ik-first20.mot", "mot", {}),
    "sto": ("opensim/myComplexTasksTrial_orientations.sto", "sto", {}),
    "tsv": ("markers/juggling-qualisys-300hz-first120.tsv", "qtm", {}),
    "vicon": ("markers/vicon-nexus-walking2-excerpt.csv", "vicon", {}),
    "imu": ("xio/pelvis/Quaternion.csv", "imu", {}), "xsens": ("imu/xsens-dot/LFemur_excerpt.csv", "imu", {}),
    "mtm": ("imu/xsens-mtmanager/MT46_01-000_00B42D4D.txt", "imu", {}),
    "optitrack": ("imu/optitrack/take_excerpt.csv", "imu", {}), "apdm": ("imu/apdm/imuData01_excerpt.csv", "imu", {}),
}


def _setup_text(tests_data, tmp_path, key) -> tuple[Path, str, dict, Path]:
    rel, fmt, opts = TEXT_FILES[key]
    d = tmp_path / "in"
    f = _copy(tests_data / rel, d)
    ref_dir = tmp_path / "ref"
    ref = _copy(tests_data / rel, ref_dir)
    if "asf" in opts:
        _copy(tests_data / "cmu" / "86.asf", d)
        _copy(tests_data / "cmu" / "86.asf", ref_dir)
    return f, fmt, opts, ref


def _opts(opts: dict, folder: Path) -> dict:
    return {k: str(folder / v) for k, v in opts.items()}


_REFERENCES: dict[str, dict] = {}


def _reference(trial, key: str, ref: Path, fmt: str, opts: dict) -> dict:
    """The digest of the unmutated file (once per file)."""
    if key not in _REFERENCES:
        _REFERENCES[key] = trial.digest(ref, fmt, _opts(opts, ref.parent))
    assert _REFERENCES[key]["status"] == "ok", _REFERENCES[key]
    return _REFERENCES[key]


def _last_data_number(data: bytes) -> re.Match:
    """The last number of the file that is followed only by separators and numbers on its line (data)."""
    nums = [m for m in NUMBER.finditer(data)]
    return nums[-1]


@pytest.mark.parametrize("token", ["0_5", "nan", "1e308", "0x1", "9" * 400])
@pytest.mark.parametrize("key", sorted(TEXT_FILES))
def test_last_number_spelled_badly_is_never_read_silently(trial, tests_data, tmp_path, key, token):
    f, fmt, opts, ref = _setup_text(tests_data, tmp_path, key)
    if token == "nan" and fmt in ("qtm",):
        pytest.skip("NaN may be a gap in this format")
    data = f.read_bytes()
    m = _last_data_number(data)
    f.write_bytes(data[:m.start()] + token.encode() + data[m.end():])
    reference = _reference(trial, key, ref, fmt, opts)
    checks.assert_not_silent(trial, f, fmt, reference, _opts(opts, f.parent))


@pytest.mark.parametrize("key", sorted(TEXT_FILES))
def test_number_cut_at_end_of_file_is_reported(trial, tests_data, tmp_path, key):
    """``-0.124044`` cut to ``-0.12`` (or to ``-``) at the end of the file: a warning or an error."""
    f, fmt, opts, ref = _setup_text(tests_data, tmp_path, key)
    data = f.read_bytes().rstrip(b"\r\n\t ")
    m = [x for x in NUMBER.finditer(data) if len(x.group()) >= 3][-1]
    for cut in sorted({m.start() + 1, (m.start() + m.end()) // 2, m.end() - 1}):
        f.write_bytes(data[:cut])
        reference = _reference(trial, key, ref, fmt, opts)
        rep = checks.assert_not_silent(trial, f, fmt, reference, _opts(opts, f.parent))
        assert rep["status"] == "error" or rep["warnings"], f"{f.name} cut at byte {cut} read without a word"


def test_filter_on_non_utf8_text_is_a_clean_error_or_a_result(trial, tests_data, tmp_path):
    tsv = _copy(tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv", tmp_path / "in")
    data = bytearray(tsv.read_bytes())
    i = data.index(b"\n", len(data) // 2) + 3
    data[i] = 0xFF
    tsv.write_bytes(bytes(data))
    csv = tmp_path / "in" / "plain.csv"
    csv.write_bytes(b"time,x\n0,1\n0.1,\xff2\n0.2,3\n0.3,4\n")
    for argv in (["filter", tsv, "--auto", "--json"], ["filter", csv, "--auto", "--json"],
                 ["filter", csv, "--penalty", "1", "-o", tmp_path / "f.csv"]):
        checks.assert_no_failure(trial.run(argv), tsv.name, csv.name)


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1e200"])
def test_filter_on_huge_values_is_a_clean_error_or_finite(trial, tmp_path, value):
    csv = tmp_path / "big.csv"
    rows = ["time,x"] + [f"{i * 0.01:.2f},{value if i % 7 == 3 else i * 0.1}" for i in range(40)]
    csv.write_text("\n".join(rows) + "\n")
    for argv in (["filter", csv, "--auto", "--json"], ["filter", csv, "--penalty", "1", "--json"],
                 ["filter", csv, "--auto", "-o", tmp_path / "f.csv"]):
        checks.assert_no_failure(trial.run(argv), csv.name)


def test_filter_time_only_csv_is_a_clean_error(trial, tmp_path):
    csv = tmp_path / "times.csv"
    csv.write_text("time\n" + "\n".join(f"{i * 0.01:.2f}" for i in range(30)) + "\n")
    for argv in (["filter", csv, "--auto", "-o", tmp_path / "f.csv"], ["filter", csv, "--auto", "--json"]):
        checks.assert_clean_error(trial.run(argv), csv.name)


@pytest.mark.parametrize("frame_time", ["1e-320", "1e-300"])
def test_rate_is_never_infinity_in_json(trial, tests_data, tmp_path, frame_time):
    bvh = _sub(_copy(tests_data / "bvh" / "walk-meredith-60.bvh", tmp_path / "in"), r"Frame Time:.*$",
               f"Frame Time: {frame_time}")
    r = trial.run(["info", bvh, "--json"])
    checks.assert_no_failure(r, bvh.name)
