"""Tests of mocapkit.io.imucsv: IMU quaternion readers, sensor folders, writer."""

from __future__ import annotations

import csv
import os
import stat
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io import (
    READERS,
    atomic_write_text,
    atomic_writer,
    detect_format,
    format_row,
    load_signals,
    read_imu_csv,
    read_imu_text,
    read_sensor_folder,
    register_reader,
    sample_data_path,
    write_signal_csv,
)
from mocapkit.motion import Signal

SENSORS = ["left-foot", "left-lower-leg", "left-upper-leg", "pelvis", "right-foot", "right-lower-leg",
           "right-upper-leg"]
SENSOR_ROWS = {"left-foot": 921, "left-lower-leg": 911, "left-upper-leg": 920, "pelvis": 900,
               "right-foot": 908, "right-lower-leg": 920, "right-upper-leg": 902}


def _write(path: Path, text: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, str):
        text = text.encode("utf-8")
    path.write_bytes(text)
    return path


def _error(path: Path, rate: float | None = None) -> MocapFormatError:
    with pytest.raises(MocapFormatError) as info:
        read_imu_csv(path, rate=rate)
    return info.value


def _assert_where(err: MocapFormatError, path: Path, line: int | None) -> str:
    msg = str(err)
    where = str(path) if line is None else f"{path}:{line}"
    assert msg.startswith(where + ": "), msg
    assert err.path == str(path) and err.line == line
    return msg


def _parse_by_hand(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    t = np.array([int(r[0]) / 1e6 for r in rows])
    v = np.array([[float(x) for x in r[1:5]] for r in rows])
    return t, v


# ------------------------------------------------------------------------------------------------
# each format
# ------------------------------------------------------------------------------------------------


def test_xio_excerpt_exact(tests_data: Path) -> None:
    path = tests_data / "xio" / "pelvis" / "Quaternion.csv"
    sig = read_imu_csv(path)
    assert isinstance(sig, Signal)
    assert sig.kind == "quaternion" and sig.name == "Quaternion" and sig.source == str(path)
    assert sig.meta["format"] == "x-io"
    assert len(sig) == 300
    assert sig.times.dtype == np.float64 and sig.values.dtype == np.float64
    assert sig.times[0] == 917418209 / 1e6
    assert sig.values[0].tolist() == [0.850093, -0.040743, -0.524145, -0.034592]
    t, v = _parse_by_hand(path)
    assert np.array_equal(sig.times, t)
    assert np.array_equal(sig.values, v)  # not normalised, not sign-flipped
    # irregular sampling with a dropped packet between lines 61 and 62
    dt = np.diff(sig.times)
    assert dt[59] == 918641891 / 1e6 - 918601770 / 1e6
    assert 0.039 < dt[59] < 0.041
    assert np.median(dt) == pytest.approx(0.02, abs=1e-4)
    assert not np.allclose(dt, dt[0])


def test_xio_name_argument(tests_data: Path) -> None:
    sig = read_imu_csv(tests_data / "xio" / "left-foot" / "Quaternion.csv", name="left-foot")
    assert sig.name == "left-foot" and len(sig) == 300


def test_ngimu(tests_data: Path) -> None:
    sig = read_imu_csv(tests_data / "formats" / "ngimu.csv")
    assert sig.meta["format"] == "ngimu"
    assert sig.times.tolist() == [0.0, 0.01, 0.02, 0.035]
    assert sig.values.tolist() == [
        [1.0, 0.0, 0.0, 0.0],
        [0.99995, 0.01, 0.0, 0.0],
        [0.9998, 0.019999, -0.0, 0.0],
        [0.99955, 0.029996, -0.0001, 0.0002],
    ]
    assert np.signbit(sig.values[2, 2])  # "-0.000000" kept as -0.0


def test_legacy_xio(tests_data: Path) -> None:
    path = tests_data / "formats" / "legacy_xio.csv"
    sig = read_imu_csv(path, rate=100)
    assert sig.meta["format"] == "x-io-legacy" and sig.meta["rate"] == 100.0
    # packet 103 is missing: a gap
    assert sig.times.tolist() == [0 / 100, 1 / 100, 2 / 100, 4 / 100, 5 / 100]
    assert sig.values[0].tolist() == [0.707107, 0.0, 0.707107, 0.0]
    assert sig.values[4].tolist() == [0.7066, 0.005, 0.7076, -0.0025]


def test_legacy_xio_needs_rate(tests_data: Path) -> None:
    path = tests_data / "formats" / "legacy_xio.csv"
    msg = _assert_where(_error(path), path, 1)
    assert "--rate HZ" in msg


def test_legacy_xio_bad_packet_numbers(tmp_path: Path) -> None:
    head = "Packet number,Element 1,Element 2,Element 3,Element 4\n"
    p = _write(tmp_path / "dup.csv", head + "5,1,0,0,0\n6,1,0,0,0\n6,1,0,0,0\n")
    msg = _assert_where(_error(p, rate=50), p, 4)
    assert "duplicate" in msg and "lines 3 and 4" in msg
    p = _write(tmp_path / "dec.csv", head + "5,1,0,0,0\n6,1,0,0,0\n2,1,0,0,0\n")
    msg = _assert_where(_error(p, rate=50), p, 4)
    assert "line 4" in msg and "line 3" in msg and "2" in msg and "6" in msg
    p = _write(tmp_path / "frac.csv", head + "5.5,1,0,0,0\n")
    msg = _assert_where(_error(p, rate=50), p, 2)
    assert "Packet number" in msg and "not an integer" in msg


def test_xsens_with_rate_line_and_counter(tests_data: Path) -> None:
    path = tests_data / "formats" / "xsens.txt"
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "xsens" and sig.meta["rate"] == 50.0
    # counters 10, 11, 12, 14 at 50 Hz: the dropped 13 shows as a gap
    assert sig.times.tolist() == [0 / 50, 1 / 50, 2 / 50, 4 / 50]
    assert sig.values.tolist() == [
        [0.999825, 0.012001, -0.0045, 0.0132],
        [0.99982, 0.0121, -0.0046, 0.0133],
        [0.999815, 0.0122, -0.0047, 0.0134],
        [0.999805, 0.0124, -0.0049, 0.0136],
    ]
    # the same rate given explicitly is fine
    assert np.array_equal(read_imu_csv(path, rate=50.0).times, sig.times)


def test_xsens_rate_conflict(tests_data: Path) -> None:
    path = tests_data / "formats" / "xsens.txt"
    msg = _assert_where(_error(path, rate=100), path, 8)  # the "// Sample rate" line
    assert "50 Hz" in msg and "100 Hz" in msg


def test_xsens_wraparound(tests_data: Path) -> None:
    path = tests_data / "formats" / "xsens_wrap.txt"
    sig = read_imu_csv(path, rate=100)
    # 65533, 65534, 0 (=65536), 1, 3
    assert sig.times.tolist() == [0 / 100, 1 / 100, 3 / 100, 4 / 100, 6 / 100]
    assert sig.values[:, 0].tolist() == [0.5, 0.5, 0.5, 0.5, -0.5]
    assert sig.values[1].tolist() == [0.5, 0.5, 0.5, -0.5]
    msg = _assert_where(_error(path), path, 1)  # neither a rate line nor a rate
    assert "--rate HZ" in msg


def test_xsens_without_counter_uses_row_index(tmp_path: Path) -> None:
    text = ("// Sample rate: 25Hz\nSampleTimeFine\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n"
            "7\t1\t0\t0\t0\n3\t0\t1\t0\t0\n9\t0\t0\t1\t0\n")
    sig = read_imu_csv(_write(tmp_path / "x.txt", text))
    assert sig.times.tolist() == [0.0, 1 / 25, 2 / 25]
    assert sig.values.tolist() == [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]
    # no rate line: the rate argument is used
    sig = read_imu_csv(_write(tmp_path / "y.txt", text.split("\n", 1)[1]), rate=10)
    assert sig.times.tolist() == [0.0, 0.1, 0.2]


def test_xsens_counter_errors(tmp_path: Path) -> None:
    head = "// Sample rate: 100Hz\nPacketCounter\tQuat_w\tQuat_x\tQuat_y\tQuat_z\n"

    def rows(*counters: int) -> str:
        return head + "".join(f"{c}\t1\t0\t0\t0\n" for c in counters)

    p = _write(tmp_path / "dup.txt", rows(4, 5, 5, 6))
    msg = _assert_where(_error(p), p, 5)
    assert "duplicate" in msg and "lines 4 and 5" in msg
    # a small decrease is not a wrap-around
    p = _write(tmp_path / "dec.txt", rows(100, 101, 50, 51))
    msg = _assert_where(_error(p), p, 5)
    assert "line 5" in msg and "line 4" in msg and "50" in msg and "101" in msg
    # a wrap-around must be followed by a continuation
    p = _write(tmp_path / "glitch.txt", rows(65534, 65535, 0, 65535))
    msg = _assert_where(_error(p), p, 6)
    assert "line 4" in msg and "line 5" in msg and "wrap-around" in msg
    # counters beyond uint16 do not wrap
    p = _write(tmp_path / "big.txt", rows(70000, 70001, 3))
    _assert_where(_error(p), p, 5)
    # a real wrap with a continuation, and a second wrap later
    p = _write(tmp_path / "ok.txt", rows(65535, 0, 1, 65535, 0, 2))
    assert read_imu_csv(p).times.tolist() == [0 / 100, 1 / 100, 2 / 100, 65536 / 100, 65537 / 100,
                                              65539 / 100]


def test_xsens_column_count_and_rate_line_errors(tmp_path: Path) -> None:
    head = "// Sample rate: 100Hz\nCounter\tAcc_X\tQuat_w\tQuat_x\tQuat_y\tQuat_z\n"
    p = _write(tmp_path / "cols.txt", head + "1\t0.1\t1\t0\t0\t0\n2\t1\t0\t0\t0\n")
    msg = _assert_where(_error(p), p, 4)
    assert "expected 6" in msg and "got 5" in msg
    p = _write(tmp_path / "rate.txt", "// Sample rate: fast\n" + head.split("\n", 1)[1] + "1\t0\t1\t0\t0\t0\n")
    msg = _assert_where(_error(p), p, 1)
    assert "sample rate" in msg and "'fast'" in msg
    p = _write(tmp_path / "zero.txt", "// Sample rate: 0Hz\n" + head.split("\n", 1)[1] + "1\t0\t1\t0\t0\t0\n")
    _assert_where(_error(p), p, 1)


def test_generic(tests_data: Path) -> None:
    sig = read_imu_csv(tests_data / "formats" / "generic.csv")
    assert sig.meta["format"] == "generic"
    assert sig.times.tolist() == [0.5, 0.75, 1.0]
    assert sig.values.tolist() == [[1.0, 0.0, 0.0, 0.0], [-1.5e-3, 25.0, -0.0, 1e-300], [0.1, 0.2, 0.3, 0.4]]
    assert np.signbit(sig.values[1, 2])


def test_rate_refused_for_timestamped_formats(tests_data: Path) -> None:
    for rel in ("xio/pelvis/Quaternion.csv", "formats/ngimu.csv", "formats/generic.csv"):
        path = tests_data / rel
        msg = _assert_where(_error(path, rate=50), path, 1)
        assert "timestamps" in msg


def test_bad_rate_argument(tests_data: Path) -> None:
    for bad in (0, -5, float("nan"), float("inf"), "x"):
        with pytest.raises(InvalidParameterError):
            read_imu_csv(tests_data / "formats" / "legacy_xio.csv", rate=bad)  # type: ignore[arg-type]


def test_read_imu_text_stdin() -> None:
    sig = read_imu_text("time,w,x,y,z\n0,1,0,0,0\n0.1,0,1,0,0\n", "<stdin>")
    assert sig.name == "stdin" and sig.source == "<stdin>"
    assert sig.times.tolist() == [0.0, 0.1]
    with pytest.raises(MocapFormatError, match=r"^<stdin>:3: duplicate"):
        read_imu_text("time,w,x,y,z\n0,1,0,0,0\n0,0,1,0,0\n", "<stdin>")


# ------------------------------------------------------------------------------------------------
# line ends, BOM
# ------------------------------------------------------------------------------------------------

GENERIC = "time,w,x,y,z\n0.0,1,0,0,0\n0.02,0.5,0.5,0.5,0.5\n0.04,0.0,0.0,0.0,-1.0\n"


@pytest.mark.parametrize(
    "variant",
    [
        GENERIC,
        GENERIC.replace("\n", "\r\n"),
        "\ufeff" + GENERIC,
        "\ufeff" + GENERIC.replace("\n", "\r\n").rstrip("\r\n"),
        GENERIC.rstrip("\n"),
        GENERIC + "\n\n  \n",
        GENERIC.replace("\n", "\r\n") + "\r\n\r\n",
    ],
    ids=["lf", "crlf", "bom", "bom-crlf-no-final-eol", "no-final-eol", "trailing-blank", "crlf-trailing-blank"],
)
def test_line_end_variants(tmp_path: Path, variant: str) -> None:
    sig = read_imu_csv(_write(tmp_path / "v.csv", variant))
    assert sig.times.tolist() == [0.0, 0.02, 0.04]
    assert sig.values.tolist() == [[1, 0, 0, 0], [0.5, 0.5, 0.5, 0.5], [0, 0, 0, -1]]
    assert read_imu_text(variant, "t").values.tolist() == sig.values.tolist()


def test_real_file_line_end_variants(shared_data: Path, tmp_path: Path) -> None:
    data = (shared_data / "imu" / "xio-lower-body" / "pelvis" / "Quaternion.csv").read_bytes()
    a = read_imu_csv(shared_data / "imu" / "xio-lower-body" / "pelvis" / "Quaternion.csv")
    assert len(a) == 900
    variants = {
        "no-eol.csv": data.rstrip(b"\n"),
        "crlf-bom.csv": b"\xef\xbb\xbf" + data.replace(b"\n", b"\r\n") + b"\r\n",
        "crlf-no-eol.csv": data.rstrip(b"\n").replace(b"\n", b"\r\n"),
    }
    for name, variant in variants.items():
        b = read_imu_csv(_write(tmp_path / name, variant))
        assert np.array_equal(a.times, b.times) and np.array_equal(a.values, b.values), name


# ------------------------------------------------------------------------------------------------
# rejections
# ------------------------------------------------------------------------------------------------


def test_empty_file(tmp_path: Path) -> None:
    for name, text in (("empty.csv", ""), ("blank.csv", "\n \r\n\n"), ("bom.csv", "\ufeff")):
        p = _write(tmp_path / name, text)
        msg = _assert_where(_error(p), p, 1)
        assert "empty file" in msg


def test_header_only(tmp_path: Path) -> None:
    p = _write(tmp_path / "h.csv", "Timestamp (us),W,X,Y,Z\n\n")
    msg = _assert_where(_error(p), p, 1)
    assert "header only" in msg and "no data rows" in msg


def test_only_comment_lines(tmp_path: Path) -> None:
    p = _write(tmp_path / "c.txt", "// Sample rate: 50Hz\n// nothing else\n")
    msg = _assert_where(_error(p), p, 2)
    assert "no header" in msg


def test_unrecognised_header(tmp_path: Path) -> None:
    p = _write(tmp_path / "u.csv", "Timestamp,W,X,Y,Z\n1,1,0,0,0\n")
    msg = _assert_where(_error(p), p, 1)
    assert "unrecognised header 'Timestamp,W,X,Y,Z'" in msg
    for accepted in ("Timestamp (us),W,X,Y,Z", "Time (s),W,X,Y,Z", "Packet number,Element 1", "Quat_w",
                     "Quat_q0", "time,w,x,y,z"):
        assert accepted in msg
    # the header is looked for right at the top (after blank lines only)
    p = _write(tmp_path / "x.csv", "1,1,0,0,0\ntime,w,x,y,z\n")
    _assert_where(_error(p), p, 1)
    # '//' lines belong to Xsens exports only
    p = _write(tmp_path / "y.csv", "// Sample rate: 50Hz\ntime,w,x,y,z\n0,1,0,0,0\n")
    msg = _assert_where(_error(p), p, 1)
    assert "Xsens" in msg


def test_wrong_column_count(tmp_path: Path) -> None:
    p = _write(tmp_path / "c.csv", "Timestamp (us),W,X,Y,Z\n100,1,0,0,0\n200,1,0,0,0,7\n")
    msg = _assert_where(_error(p), p, 3)
    assert "expected 5" in msg and "got 6" in msg
    p = _write(tmp_path / "d.csv", "Time (s),W,X,Y,Z\n0.1,1,0,0\n")
    msg = _assert_where(_error(p), p, 2)
    assert "expected 5" in msg and "got 4" in msg


@pytest.mark.parametrize(
    ("row", "words"),
    [
        ("300,1,abc,0,0", ["column X", "'abc'", "not a number"]),
        ("300,1,,0,0", ["column X", "''", "not a number"]),
        ("300,1,0,0,1..2", ["column Z", "not a number"]),
        ("3x0,1,0,0,0", ["column Timestamp (us)", "'3x0'", "not a number"]),
        ("300,1,0,nan,0", ["column Y is NaN"]),
        ("300,NaN,0,0,0", ["column W is NaN"]),
        ("300,1,0,0,inf", ["column Z is infinite"]),
        ("300,-Infinity,0,0,1", ["column W is infinite"]),
        ("300,1e400,0,0,0", ["column W is infinite", "1e400"]),
        ("nan,1,0,0,0", ["column Timestamp (us) is NaN"]),
        ("inf,1,0,0,0", ["column Timestamp (us) is infinite"]),
        ("300,0,0,0,0", ["zero-norm quaternion"]),
        ("300,0.0,-0.0,0e5,0", ["zero-norm quaternion"]),
        ("300,1e-200,0,0,0", ["zero-norm quaternion"]),  # its squared norm underflows to 0
        ("", ["empty line"]),
    ],
)
def test_bad_field(tmp_path: Path, row: str, words: list[str]) -> None:
    p = _write(tmp_path / "bad.csv", f"Timestamp (us),W,X,Y,Z\n100,1,0,0,0\n200,1,0,0,0\n{row}\n400,1,0,0,0\n")
    msg = _assert_where(_error(p), p, 4)
    for w in words:
        assert w in msg, msg


def test_time_not_increasing(tmp_path: Path) -> None:
    p = _write(tmp_path / "t.csv", "Time (s),W,X,Y,Z\n0.0,1,0,0,0\n0.5,1,0,0,0\n0.25,1,0,0,0\n")
    msg = _assert_where(_error(p), p, 4)
    assert "line 4" in msg and "line 3" in msg and "0.25" in msg and "0.5" in msg
    assert "duplicate" not in msg


def test_time_duplicate(tmp_path: Path) -> None:
    p = _write(tmp_path / "t.csv", "Timestamp (us),W,X,Y,Z\n1000,1,0,0,0\n2000,1,0,0,0\n2000,0,1,0,0\n")
    msg = _assert_where(_error(p), p, 4)
    assert "duplicate" in msg and "line 4" in msg and "line 3" in msg and "2000" in msg


def test_not_utf8(tmp_path: Path) -> None:
    p = _write(tmp_path / "b.csv", b"time,w,x,y,z\n0,1,0,0,0\n1,\xff,0,0,0\n")
    msg = _assert_where(_error(p), p, 3)
    assert "UTF-8" in msg


def test_missing_file(tmp_path: Path) -> None:
    p = tmp_path / "nope.csv"
    _assert_where(_error(p), p, None)
    with pytest.raises(MocapFormatError) as info:
        load_signals(p)
    assert _assert_where(info.value, p, None).endswith("no such file or folder")


# ------------------------------------------------------------------------------------------------
# folders and dispatch
# ------------------------------------------------------------------------------------------------


def test_sensor_folder_excerpt(tests_data: Path) -> None:
    folder = tests_data / "xio"
    assert detect_format(folder / "pelvis" / "Quaternion.csv") == "x-io"
    assert detect_format(folder / "pelvis" / "Inertial.csv") is None
    sigs = read_sensor_folder(folder)
    assert list(sigs) == ["left-foot", "pelvis"]
    for name, sig in sigs.items():
        assert sig.name == name and len(sig) == 300
        assert sig.source == str(folder / name / "Quaternion.csv")
    assert sigs["pelvis"].values[0].tolist() == [0.850093, -0.040743, -0.524145, -0.034592]
    assert list(load_signals(folder)) == ["left-foot", "pelvis"]


def test_sensor_folder_full_shared(shared_data: Path) -> None:
    folder = shared_data / "imu" / "xio-lower-body"
    sigs = load_signals(folder)
    assert list(sigs) == SENSORS
    assert {k: len(s) for k, s in sigs.items()} == SENSOR_ROWS
    pelvis = sigs["pelvis"]
    # known dropped packet: lines 61 -> 62 of pelvis/Quaternion.csv jump 40121 us
    assert pelvis.times[59] == 918601770 / 1e6 and pelvis.times[60] == 918641891 / 1e6
    for sig in sigs.values():
        dt = np.diff(sig.times)
        assert dt.min() > 0.019 and 0.039 < dt.max() < 0.061  # 50 Hz with 40-60 ms gaps
        assert np.abs(np.linalg.norm(sig.values, axis=1) - 1).max() < 1e-3


def test_bundled_sample_data_matches_shared(shared_data: Path) -> None:
    bundled = sample_data_path()
    assert sorted(p.name for p in bundled.iterdir() if p.is_dir()) == SENSORS
    for name in SENSORS:
        src = shared_data / "imu" / "xio-lower-body" / name / "Quaternion.csv"
        assert (bundled / name / "Quaternion.csv").read_bytes() == src.read_bytes()


def test_bundled_sample_data_loads() -> None:
    bundled = sample_data_path()
    assert (bundled / "README.md").is_file()
    sigs = load_signals(bundled)
    assert {k: len(s) for k, s in sigs.items()} == SENSOR_ROWS


def test_folder_of_files(tests_data: Path, tmp_path: Path) -> None:
    src = tests_data / "formats"
    _write(tmp_path / "b.csv", (src / "ngimu.csv").read_text())
    _write(tmp_path / "a.txt", (src / "generic.csv").read_text())
    _write(tmp_path / "notes.md", "not data")
    _write(tmp_path / ".hidden.csv", "junk")
    sigs = read_sensor_folder(tmp_path)
    assert list(sigs) == ["a", "b"]
    assert sigs["a"].name == "a" and sigs["b"].meta["format"] == "ngimu"
    # a file that is not a quaternion format (like x-io's Inertial.csv) is not a sensor: it is
    # skipped and named in meta, never dropped silently
    _write(tmp_path / "c.csv", "foo,bar\n1,2\n")
    sigs = read_sensor_folder(tmp_path)
    assert list(sigs) == ["a", "b"] and sigs["a"].meta["skipped_files"] == ["c.csv"]
    # a quaternion file with bad data is still an error
    _write(tmp_path / "d.csv", "time,w,x,y,z\n0,1,0,0,0\n0,1,0,0,0\n")
    with pytest.raises(MocapFormatError, match=r"d\.csv:3"):
        read_sensor_folder(tmp_path)


def test_folder_errors(tests_data: Path, tmp_path: Path) -> None:
    quat = (tests_data / "xio" / "pelvis" / "Quaternion.csv").read_text()
    inertial = (tests_data / "xio" / "pelvis" / "Inertial.csv").read_text()

    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(MocapFormatError) as info:
        read_sensor_folder(empty)
    assert "no sensors" in _assert_where(info.value, empty, None)

    none = tmp_path / "none"
    _write(none / "a" / "Quaternion.csv", quat)
    _write(none / "b" / "Inertial.csv", inertial)
    with pytest.raises(MocapFormatError) as info:
        read_sensor_folder(none)
    msg = _assert_where(info.value, none / "b", None)
    assert "without a quaternion file" in msg and "Inertial.csv" in msg

    two = tmp_path / "two"
    _write(two / "a" / "Quaternion.csv", quat)
    _write(two / "a" / "Copy.csv", quat)
    with pytest.raises(MocapFormatError) as info:
        read_sensor_folder(two)
    msg = _assert_where(info.value, two / "a", None)
    assert "several quaternion files" in msg and "Copy.csv" in msg and "Quaternion.csv" in msg

    mixed = tmp_path / "mixed"
    _write(mixed / "a" / "Quaternion.csv", quat)
    _write(mixed / "b.csv", quat)
    with pytest.raises(MocapFormatError) as info:
        read_sensor_folder(mixed)
    assert "b.csv" in _assert_where(info.value, mixed, None)

    # a broken quaternion file inside a sensor folder reports its own line
    broken = tmp_path / "broken"
    _write(broken / "a" / "Quaternion.csv", quat.replace("917458328,", "917458328,x", 1))
    with pytest.raises(MocapFormatError) as info:
        read_sensor_folder(broken)
    assert "not a number" in _assert_where(info.value, broken / "a" / "Quaternion.csv", 4)


def test_load_signals_file_and_registry(tests_data: Path, tmp_path: Path, monkeypatch) -> None:
    sigs = load_signals(tests_data / "formats" / "legacy_xio.csv", rate=100)
    assert list(sigs) == ["legacy_xio"] and sigs["legacy_xio"].name == "legacy_xio"
    # unknown suffixes fall back to the IMU CSV reader
    p = _write(tmp_path / "rec.dat", GENERIC)
    assert len(load_signals(p)["rec"]) == 3

    calls = []

    def fake(path: Path, *, rate: float | None = None) -> dict[str, Signal]:
        calls.append((path, rate))
        return {"root": Signal([0.0], [[1.0, 0, 0, 0]], name="root")}

    monkeypatch.setattr("mocapkit.io.imucsv.READERS", dict(READERS))
    register_reader("BVH", fake)
    bvh = _write(tmp_path / "walk.bvh", "HIERARCHY\n")
    assert list(load_signals(bvh, rate=None)) == ["root"]
    assert calls == [(bvh, None)]


# ------------------------------------------------------------------------------------------------
# writing
# ------------------------------------------------------------------------------------------------


def test_format_row() -> None:
    assert format_row(0.1, [1, -0.0, 1e-300, 1 / 3]) == "0.1,1.0,-0.0,1e-300,0.3333333333333333"
    assert format_row(np.float64(2.5), np.array([0.5, 0.5, 0.5, 0.5])) == "2.5,0.5,0.5,0.5,0.5"


def test_write_read_round_trip_bit_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    n = 500
    times = np.cumsum(rng.uniform(1e-6, 0.05, n)) + 1234.5
    values = rng.normal(size=(n, 4)) * 10.0 ** rng.integers(-100, 100, size=(n, 4))
    values[0] = [-0.0, 1 / 3, 5e-324, 1.7976931348623157e308]
    values[1] = [np.nextafter(1.0, 2.0), -np.nextafter(0.0, 1.0), 0.1, -2.0]
    path = tmp_path / "out.csv"
    write_signal_csv(path, times, values)
    text = path.read_text()
    assert text.startswith("time,w,x,y,z\n") and text.endswith("\n")
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "generic"
    assert np.array_equal(sig.times.view(np.uint64), times.view(np.uint64))
    assert np.array_equal(sig.values.view(np.uint64), values.view(np.uint64))
    # overwrite keeps no temporary files around
    write_signal_csv(path, times[:3], values[:3])
    assert len(read_imu_csv(path)) == 3
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_write_rejects_bad_arrays(tmp_path: Path) -> None:
    from mocapkit.errors import InvalidSignalError

    with pytest.raises(InvalidSignalError):
        write_signal_csv(tmp_path / "a.csv", [0.0, 1.0], [[1, 0, 0, 0]])
    with pytest.raises(InvalidSignalError):
        write_signal_csv(tmp_path / "a.csv", [0.0], [[np.nan, 0, 0, 0]])
    with pytest.raises(InvalidSignalError):
        write_signal_csv(tmp_path / "a.csv", [0.0], [[1, 0, 0]])
    assert not (tmp_path / "a.csv").exists()


def test_atomic_write_failure_keeps_old_file(tmp_path: Path) -> None:
    path = tmp_path / "keep.txt"
    atomic_write_text(path, "old\n")
    os.chmod(path, 0o640)
    with pytest.raises(RuntimeError):
        with atomic_writer(path) as fh:
            fh.write("new, half written")
            raise RuntimeError("boom")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
    atomic_write_text(path, "a\nb\n")
    assert path.read_bytes() == b"a\nb\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o640  # permissions of the replaced file kept


# ------------------------------------------------------------------------------------------------
# speed and robustness
# ------------------------------------------------------------------------------------------------


def test_parse_large_file() -> None:
    n = 100_000
    rows = "".join(f"{1_000_000 + 20_000 * i},0.5,0.5,0.5,{0.5 + i * 1e-7:.7f}\n" for i in range(n))
    text = "Timestamp (us),W,X,Y,Z\n" + rows
    sig = read_imu_text(text, "big.csv")  # speed is measured in benchmarks, never asserted in tests
    assert len(sig) == n and sig.times[-1] == (1_000_000 + 20_000 * (n - 1)) / 1e6


_BASES = {
    "xio": (("Timestamp (us),W,X,Y,Z\n" + "".join(
        f"{917418209 + 20060 * i},0.85{i:02d},-0.04{i:02d},-0.52{i:02d},-0.03{i:02d}\n" for i in range(12)
    )).encode(), None),
    "xsens": ((
        "// Sample rate: 50.0Hz\nPacketCounter\tAcc_X\tQuat_w\tQuat_x\tQuat_y\tQuat_z\n"
        "65533\t0.1\t1\t0\t0\t0\n65535\t0.2\t0.5\t0.5\t0.5\t0.5\n1\t0.3\t0\t1\t0\t0\n2\t0.4\t0\t0\t1\t0\n"
    ).encode(), None),
    "legacy": (b"Packet number,Element 1,Element 2,Element 3,Element 4\n"
               b"1,1,0,0,0\n2,0.5,0.5,0.5,0.5\n4,0,1,0,0\n", 100.0),
    "generic": (("\ufeff" + GENERIC.replace("\n", "\r\n")).encode(), None),
}
_INTERESTING = b"0123456789.,-+eE\t\r\n /naifINF\xff\xef\xbb\xbf\x00"


@st.composite
def _mutated(draw):
    key = draw(st.sampled_from(sorted(_BASES)))
    data, rate = _BASES[key]
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["replace", "insert", "delete", "truncate", "dup_line", "del_line", "swap"]))
        if op in ("replace", "insert", "delete"):
            pos = draw(st.integers(0, max(len(data) - 1, 0)))
            byte = draw(st.one_of(st.sampled_from(list(_INTERESTING)), st.integers(0, 255)))
            if op == "replace" and data:
                data[pos] = byte
            elif op == "insert":
                data.insert(pos, byte)
            elif data:
                del data[pos]
        elif op == "truncate":
            data = data[: draw(st.integers(0, len(data)))]
        else:
            lines = bytes(data).split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            if op == "dup_line":
                lines.insert(i, lines[i])
            elif op == "del_line":
                del lines[i]
            else:
                j = draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            data = bytearray(b"\n".join(lines))
    return bytes(data), rate


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=_mutated())
def test_mutated_files_fail_only_with_format_error(fuzz_dir: Path, case: tuple[bytes, float | None]) -> None:
    data, rate = case
    path = fuzz_dir / "m.csv"
    path.write_bytes(data)
    for reader in (lambda: read_imu_csv(path, rate=rate),
                   lambda: read_imu_text(data.decode("latin-1"), "<stdin>", rate=rate)):
        try:
            sig = reader()
        except MocapFormatError as exc:
            assert exc.line is None or exc.line >= 1
            assert str(exc).startswith(exc.path)
            continue
        assert sig.values.shape == (len(sig), 4)
        assert np.all(np.diff(sig.times) > 0)
        assert np.all(np.isfinite(sig.values))
