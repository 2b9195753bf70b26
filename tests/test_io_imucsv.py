"""Tests of mocapkit.io.imu.signals: IMU quaternion readers, sensor folders, writer."""

from __future__ import annotations

import csv
import math
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
    read_imu_file,
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
    text = ("// Sample rate: 25Hz\nAcc_X\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n"
            "7\t1\t0\t0\t0\n3\t0\t1\t0\t0\n9\t0\t0\t1\t0\n")
    sig = read_imu_csv(_write(tmp_path / "x.txt", text))
    assert sig.times.tolist() == [0.0, 1 / 25, 2 / 25]
    assert sig.values.tolist() == [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]
    assert sig.meta["time_column"] is None and sig.meta["time_unit"] is None
    # no rate line: the rate argument is used
    sig = read_imu_csv(_write(tmp_path / "y.txt", text.split("\n", 1)[1]), rate=10)
    assert sig.times.tolist() == [0.0, 0.1, 0.2]


def test_mt_manager_sample_time_fine_is_10khz_ticks(tmp_path: Path) -> None:
    # without a counter, MT Manager's SampleTimeFine (10 kHz ticks, uint32) is the clock
    text = ("// Update Rate: 100.0Hz\nSampleTimeFine\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n"
            "4294967196\t1\t0\t0\t0\n4294967296\t0\t1\t0\t0\n100\t0\t0\t1\t0\n")
    with pytest.raises(MocapFormatError, match=r"x\.txt:5: .*not a wrap-around"):  # beyond uint32
        read_imu_csv(_write(tmp_path / "x.txt", text))
    text = text.replace("4294967296", "4294967295")
    sig = read_imu_csv(_write(tmp_path / "y.txt", text))
    assert sig.meta["time_column"] == "SampleTimeFine" and sig.meta["time_unit"] == "tick10k"
    assert sig.times.tolist() == [4294967196 / 1e4, 4294967295 / 1e4, (2**32 + 100) / 1e4]


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
    p = _write(tmp_path / "u.csv", "Timestamp,Acc X,Acc Y,Acc Z\n1,1,0,0\n")
    msg = _assert_where(_error(p), p, 1)
    assert "no orientation columns in the header 'Timestamp,Acc X,Acc Y,Acc Z'" in msg
    for looked_for in ("W Element", "Quat_W", "qw", "q0..q3", "Element 1..4", "Mat[1][1]", "Roll",
                       "--quaternion-columns"):
        assert looked_for in msg
    # data before any header line
    p = _write(tmp_path / "x.csv", "1,1,0,0,0\ntime,w,x,y,z\n")
    assert "before any header" in _assert_where(_error(p), p, 1)
    # comment and metadata lines may come before any header now
    p = _write(tmp_path / "y.csv", "# exported by hand\nSample rate:,50\ntime,w,x,y,z\n0,1,0,0,0\n")
    sig = read_imu_csv(p)
    assert sig.meta["rate"] == 50.0 and sig.meta["header_line"] == 3


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

    monkeypatch.setattr("mocapkit.io.imu.signals.READERS", dict(READERS))
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
    values = rng.normal(size=(n, 4)) * 10.0 ** rng.integers(-100, 11, size=(n, 4))  # readers refuse |v| > 1e12
    values[0] = [-0.0, 1 / 3, 5e-324, 1e12]
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
    with pytest.raises(RuntimeError), atomic_writer(path) as fh:
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
        b"// Sample rate: 50.0Hz\nPacketCounter\tAcc_X\tQuat_w\tQuat_x\tQuat_y\tQuat_z\n"
        b"65533\t0.1\t1\t0\t0\t0\n65535\t0.2\t0.5\t0.5\t0.5\t0.5\n1\t0.3\t0\t1\t0\t0\n2\t0.4\t0\t0\t1\t0\n"
    ), None),
    "legacy": (b"Packet number,Element 1,Element 2,Element 3,Element 4\n"
               b"1,1,0,0,0\n2,0.5,0.5,0.5,0.5\n4,0,1,0,0\n", 100.0),
    "generic": (("\ufeff" + GENERIC.replace("\n", "\r\n")).encode(), None),
}
_IMU_DIR = Path(__file__).resolve().parent / "data" / "imu"
for _key, _rel, _n, _rate in (
    ("dot", "xsens-dot/LFemur_excerpt.csv", 16, None),
    ("matrix", "xsens-mtmanager/MT_012005D6_matrix_excerpt.txt", 10, None),
    ("euler", "xsens-mtmanager/euler_written.txt", 12, None),
    ("optitrack", "optitrack/take_lost_body.csv", 16, None),
    ("apdm", "apdm/imuData01_excerpt.csv", 8, None),
    ("shimmer", "shimmer/Session1_Shimmer_D0B5_Calibrated_PC.csv", 9, None),
    ("logger", "sensor-logger/Orientation.csv", 6, None),
    ("legacy3", "xio/legacy_QuaternionData.csv", 8, 128.0),
):
    _BASES[_key] = (b"\n".join((_IMU_DIR / _rel).read_bytes().split(b"\n")[:_n]) + b"\n", _rate)
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


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=_mutated())
def test_mutated_files_fail_only_with_format_error(fuzz_dir: Path, case: tuple[bytes, float | None]) -> None:
    data, rate = case
    path = fuzz_dir / "m.csv"
    path.write_bytes(data)
    from mocapkit.io.imu.stream import iter_samples

    for reader in (lambda: list(read_imu_file(path, rate=rate).values()),
                   lambda: [read_imu_text(data.decode("latin-1"), "<stdin>", rate=rate)],
                   lambda: list(iter_samples(data.decode("latin-1").splitlines(), "<stdin>", rate=rate))):
        try:
            out = reader()
        except MocapFormatError as exc:
            assert exc.line is None or exc.line >= 1
            assert str(exc).startswith(exc.path)
            continue
        for sig in out:
            if isinstance(sig, tuple):      # a streamed sample
                assert np.all(np.isfinite(sig[2])) and math.isfinite(sig[1])
                continue
            assert sig.values.shape == (len(sig), 4)
            assert np.all(np.diff(sig.times) > 0)
            assert np.all(np.isfinite(sig.values))


# ------------------------------------------------------------------------------------------------
# header-driven layouts: real excerpts and excerpts written in the vendors' documented layouts
# (each file is parsed independently here with the csv module and compared exactly)
# ------------------------------------------------------------------------------------------------

IMU = Path(__file__).resolve().parent / "data" / "imu"


def _table(path: Path, header_line: int, delimiter: str = ",", skip: int = 0) -> tuple[list[str], list[list[str]]]:
    """Header names (1-based ``header_line``) and the data rows after ``skip`` more lines."""
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh, delimiter=delimiter))
    names = [n.strip() for n in rows[header_line - 1]]
    data = [r for r in rows[header_line + skip:] if any(c.strip() for c in r)]
    return names, data


def _cols(names: list[str], data: list[list[str]], wanted: list[str]) -> np.ndarray:
    idx = [names.index(w) for w in wanted]
    return np.array([[float(r[i]) for i in idx] for r in data])


def _matrix_of(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of unit scalar-first quaternions (the Xsens manual's formula for R_GS)."""
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def test_xsens_dot_excerpt() -> None:
    path = IMU / "xsens-dot" / "LFemur_excerpt.csv"
    names, data = _table(path, 12)
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "xsens-dot" and sig.meta["rate"] == 60.0
    assert sig.meta["time_column"] == "SampleTimeFine" and sig.meta["time_unit"] == "us"
    assert np.array_equal(sig.times, [int(r[1]) / 1e6 for r in data])          # device clock, µs
    assert np.array_equal(sig.values, _cols(names, data, ["Quat_W", "Quat_X", "Quat_Y", "Quat_Z"]))
    # the clock agrees with the packet counter at the stated 60 Hz (real-time streaming drops packets)
    counter = np.array([int(r[0]) for r in data])
    assert np.abs(np.diff(sig.times) * 60 - np.diff(counter)).max() < 1e-3
    assert np.diff(counter).max() > 1


@pytest.mark.parametrize("name", ["MT46_01-000_00B42D4D.txt", "MT46_trailing_tab.txt"])
def test_mt_manager_old_header(name: str) -> None:
    path = IMU / "xsens-mtmanager" / name
    names, data = _table(path, 5, "\t")
    if name == "MT46_trailing_tab.txt":   # every data row ends with a tab: one field more than the header
        assert all(len(r) == len(names) + 1 and r[-1] == "" for r in data)
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "xsens" and sig.meta["rate"] == 100.0
    assert sig.meta["time_column"] == "PacketCounter"        # SampleTimeFine is empty in this export
    assert np.array_equal(sig.times, [(int(r[0]) - 4097) / 100 for r in data])
    assert np.array_equal(sig.values, _cols(names, data, ["Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3"]))


def test_mt_manager_rotation_matrix() -> None:
    path = IMU / "xsens-mtmanager" / "MT_012005D6_matrix_excerpt.txt"
    names, data = _table(path, 6, "\t")
    sig = read_imu_csv(path)
    assert "from_matrix" in sig.meta["conversion"] and "R_GS" in sig.meta["conversion"]
    assert np.array_equal(sig.times, [(int(r[0]) - 472) / 100 for r in data])
    written = np.array([[[float(r[names.index(f"Mat[{i}][{j}]")]) for j in (1, 2, 3)] for i in (1, 2, 3)]
                        for r in data])
    np.testing.assert_allclose(np.linalg.norm(sig.values, axis=1), 1.0, atol=1e-12)
    # the quaternion rotates like the written matrix (entries have 6 decimals)
    np.testing.assert_allclose(_matrix_of(sig.values), written, atol=5e-6)
    # and the listing is column-major: Mat[2][1] (row 2, column 1) comes right after Mat[1][1]
    assert names[names.index("Mat[1][1]") + 1] == "Mat[2][1]"


def test_mt_manager_euler_degrees_and_counter_wrap() -> None:
    path = IMU / "xsens-mtmanager" / "euler_written.txt"
    names, data = _table(path, 5, "\t")
    sig = read_imu_csv(path)
    assert sig.times.tolist() == [i / 100 for i in range(20)]       # 65530..65535, 0, 1, ...: uint16 wrap
    assert "Rz(yaw)·Ry(pitch)·Rx(roll)" in sig.meta["conversion"] and "degrees" in sig.meta["conversion"]
    r, p, y = np.radians(_cols(names, data, ["Roll", "Pitch", "Yaw"])).T
    c, s = np.cos, np.sin
    one, zero = np.ones_like(r), np.zeros_like(r)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, c(r), -s(r)], -1),
                   np.stack([zero, s(r), c(r)], -1)], 1)
    ry = np.stack([np.stack([c(p), zero, s(p)], -1), np.stack([zero, one, zero], -1),
                   np.stack([-s(p), zero, c(p)], -1)], 1)
    rz = np.stack([np.stack([c(y), -s(y), zero], -1), np.stack([s(y), c(y), zero], -1),
                   np.stack([zero, zero, one], -1)], 1)
    np.testing.assert_allclose(_matrix_of(sig.values), rz @ ry @ rx, atol=1e-12)


def test_rotation_matrix_that_is_not_a_rotation(tmp_path: Path) -> None:
    head = "// Update Rate: 100.0Hz\nPacketCounter\t" + "\t".join(
        f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3)) + "\n"
    p = _write(tmp_path / "m.txt", head + "1\t1\t0\t0\t0\t1\t0\t0\t0\t1\n2\t2\t0\t0\t0\t1\t0\t0\t0\t1\n")
    assert "not a rotation matrix" in _assert_where(_error(p), p, 4)


def test_apdm_excerpt(tmp_path: Path) -> None:
    path = IMU / "apdm" / "imuData01_excerpt.csv"
    names, data = _table(path, 3, skip=1)       # a units row under the header
    sigs = load_signals(path)
    assert list(sigs) == ["Static", "Upper", "Middle", "Lower"]
    for sensor, sig in sigs.items():
        assert sig.name == sensor and sig.meta["sensor"] == sensor and sig.meta["format"] == "apdm"
        assert sig.meta["rate"] == 128.0 and sig.meta["time_unit"] == "s"
        assert np.array_equal(sig.times, [float(r[0]) for r in data])
        want = [f"{sensor}/Orientation/{c}" for c in ("Scalar", "X", "Y", "Z")]
        assert np.array_equal(sig.values, _cols(names, data, want))
    # the short component name /S is read the same
    text = path.read_text().replace("/Orientation/Scalar", "/Orientation/S")
    short = load_signals(_write(tmp_path / "apdm_s.csv", text))
    assert all(np.array_equal(short[k].values, sigs[k].values) for k in sigs)
    with pytest.raises(MocapFormatError, match="holds 4 sensors"):
        read_imu_csv(path)


def test_optitrack_excerpt() -> None:
    path = IMU / "optitrack" / "take_excerpt.csv"
    _, data = _table(path, 7)
    sigs = load_signals(path)
    assert list(sigs) == ["Rigid Body 1"]
    sig = sigs["Rigid Body 1"]
    assert sig.meta["format"] == "optitrack" and sig.meta["rate"] == 120.0 and sig.meta["warnings"] == []
    assert np.array_equal(sig.times, [float(r[1]) for r in data])
    xyzw = np.array([[float(v) for v in r[2:6]] for r in data])       # Rotation X,Y,Z,W: scalar-last
    assert np.array_equal(sig.values, xyzw[:, [3, 0, 1, 2]])


def test_optitrack_lost_body_rows_dropped_and_counted() -> None:
    path = IMU / "optitrack" / "take_lost_body.csv"
    _, data = _table(path, 7)
    kept = [r for r in data if r[2] != ""]
    assert len(data) - len(kept) == 3
    sig = load_signals(path)["Rigid Body 1"]
    assert np.array_equal(sig.times, [float(r[1]) for r in kept])
    assert np.array_equal(sig.values, np.array([[float(v) for v in r[2:6]] for r in kept])[:, [3, 0, 1, 2]])
    assert len(sig.meta["warnings"]) == 1 and "3 of 40 rows dropped" in sig.meta["warnings"][0]


def test_ximu3_excerpt() -> None:
    path = IMU / "xio" / "ximu3_Quaternion.csv"
    names, data = _table(path, 1)
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "x-imu3" and sig.meta["time_unit"] == "us"
    assert np.array_equal(sig.times, [int(r[0]) / 1e6 for r in data])
    assert np.array_equal(sig.values, _cols(names, data, ["W Element", "X Element", "Y Element", "Z Element"]))


def test_ngimu_excerpt() -> None:
    path = IMU / "xio" / "ngimu_quaternion.csv"
    names, data = _table(path, 1)
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "ngimu" and sig.meta["time_unit"] == "s"
    assert np.array_equal(sig.times, [float(r[0]) for r in data])
    assert np.array_equal(sig.values, _cols(names, data, ["W", "X", "Y", "Z"]))


def test_legacy_xio_counter_steps_by_three() -> None:
    path = IMU / "xio" / "legacy_QuaternionData.csv"
    names, data = _table(path, 1)
    sig = read_imu_csv(path, rate=128)
    packets = [int(r[0]) for r in data]
    assert np.array_equal(sig.times, [(p - packets[0]) / (128 * 3) for p in packets])
    assert np.median(np.diff(sig.times)) == pytest.approx(1 / 128)     # not a third of the rate
    assert any("steps by 3" in w for w in sig.meta["warnings"])
    assert np.array_equal(sig.values, _cols(names, data, ["Element 1", "Element 2", "Element 3", "Element 4"]))


def test_shimmer_excerpt() -> None:
    path = IMU / "shimmer" / "Session1_Shimmer_D0B5_Calibrated_PC.csv"
    names, data = _table(path, 2, "\t", skip=2)     # "sep=\t" line; CAL/RAW and units rows under the header
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "shimmer" and sig.meta["time_unit"] == "ms"   # from the units row
    assert np.array_equal(sig.times, [float(r[0]) / 1e3 for r in data])
    want = [f"Shimmer_D0B5_Quat_Madge_9DOF_{c}_CAL" for c in "WXYZ"]
    assert np.array_equal(sig.values, _cols(names, data, want))


def test_metawear_excerpt() -> None:
    path = IMU / "metawear" / "MetaWear_Quaternion.csv"
    names, data = _table(path, 1)
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "metawear" and sig.meta["time_column"] == "epoc (ms)"
    assert np.array_equal(sig.times, [int(r[0]) / 1e3 for r in data])
    assert np.array_equal(sig.values, _cols(names, data, ["w (number)", "x (number)", "y (number)", "z (number)"]))


def test_sensor_logger_orientation_any_column_order() -> None:
    path = IMU / "sensor-logger" / "Orientation.csv"
    names, data = _table(path, 1)
    assert names[2:6] == ["qz", "qy", "qx", "qw"]
    sig = read_imu_csv(path)
    assert sig.meta["format"] == "sensor-logger" and sig.meta["time_unit"] == "ns"
    assert any("inferred from the magnitude" in w for w in sig.meta["warnings"])
    assert np.array_equal(sig.times, [int(r[0]) / 1e9 for r in data])
    assert np.array_equal(sig.values, _cols(names, data, ["qw", "qx", "qy", "qz"]))   # scalar-first out
    assert sig.meta["conversion"] is None      # roll/pitch/yaw are ignored when a quaternion is present


# ------------------------------------------------------------------------------------------------
# delimiters, overrides, ambiguity
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("text", [
    "Time (s);W;X;Y;Z\n0.5;1;0;0;0\n0.75;0;1;0;0\n",
    "time qw qx qy qz\n0.5  1 0 0 0\n0.75 0 1 0 0\n",
    "sep=;\nTime (s);W;X;Y;Z\n0.5;1;0;0;0\n0.75;0;1;0;0\n",
    "Time (s)\tW\tX\tY\tZ\t\n0.5\t1\t0\t0\t0\t\n0.75\t0\t1\t0\t0\t\t\n",
    "# a comment\nTime (s),quaternion.w,quaternion.x,quaternion.y,quaternion.z,\n0.5,1,0,0,0,,\n0.75,0,1,0,0,\n",
    "Time (s),quaternionW,quaternionX,quaternionY,quaternionZ\n0.5,1,0,0,0\n0.75,0,1,0,0\n",
    "Time (s),Quat_W,Quat_X,Quat_Y,Quat_Z\n0.5,1,0,0,0\n0.75,0,1,0,0\n",
    "Time (s),q0,q1,q2,q3\n0.5,1,0,0,0\n0.75,0,1,0,0\n",
    "Time (s),X,W,Z,Y\n0.5,0,1,0,0\n0.75,1,0,0,0\n",
], ids=["semicolon", "whitespace", "sep-line", "tab-trailing", "quaternion.w", "quaternionW", "Quat_W", "q0",
        "shuffled"])
def test_delimiters_and_names(tmp_path: Path, text: str) -> None:
    sig = read_imu_csv(_write(tmp_path / "d.csv", text))
    assert sig.times.tolist() == [0.5, 0.75]
    assert sig.values.tolist() == [[1, 0, 0, 0], [0, 1, 0, 0]]


def test_override_time_column_and_unit(tmp_path: Path) -> None:
    path = IMU / "sensor-logger" / "Orientation.csv"
    names, data = _table(path, 1)
    sig = read_imu_csv(path, time_column="seconds_elapsed")
    assert sig.meta["time_column"] == "seconds_elapsed"
    assert np.array_equal(sig.times, [float(r[1]) for r in data])
    p = _write(tmp_path / "ms.csv", "t,qw,qx,qy,qz\n1500,1,0,0,0\n1520,0,1,0,0\n")
    assert read_imu_csv(p).times.tolist() == [1500.0, 1520.0]               # a bare 't' is seconds
    assert read_imu_csv(p, time_unit="ms").times.tolist() == [1.5, 1.52]
    counted = read_imu_csv(p, time_unit="counter", rate=50)     # the rate is the rows' rate
    assert counted.times.tolist() == [0.0, 1 / 50] and "steps by 20" in counted.meta["warnings"][0]
    with pytest.raises(InvalidParameterError):
        read_imu_csv(p, time_unit="fortnights")
    msg = _assert_where(_error_kw(p, time_column="Zeit"), p, 1)
    assert "'Zeit'" in msg and "'t'" in msg and "'qw'" in msg


def _error_kw(path: Path, **kw) -> MocapFormatError:
    with pytest.raises(MocapFormatError) as info:
        read_imu_csv(path, **kw)
    return info.value


def test_override_quaternion_columns_and_scalar_last(tmp_path: Path) -> None:
    p = _write(tmp_path / "two.csv", "Time (s),Quat_W,Quat_X,Quat_Y,Quat_Z,qw,qx,qy,qz\n"
                                     "0,1,0,0,0,0,1,0,0\n1,0,0,1,0,0,0,0,1\n")
    msg = _assert_where(_error(p), p, 1)
    assert "(Quat_W, Quat_X, Quat_Y, Quat_Z)" in msg and "(qw, qx, qy, qz)" in msg
    assert "--quaternion-columns" in msg
    sig = read_imu_csv(p, quaternion_columns="qw,qx,qy,qz")
    assert sig.values.tolist() == [[0, 1, 0, 0], [0, 0, 0, 1]]
    sig = read_imu_csv(p, quaternion_columns=["Quat_W", "Quat_X", "Quat_Y", "Quat_Z"])
    assert sig.values.tolist() == [[1, 0, 0, 0], [0, 0, 1, 0]]
    # numbered columns that hold x, y, z, w
    p = _write(tmp_path / "sl.csv", "Time (s),Element 1,Element 2,Element 3,Element 4\n0,0.1,0.2,0.3,0.9\n")
    assert read_imu_csv(p).values.tolist() == [[0.1, 0.2, 0.3, 0.9]]
    assert read_imu_csv(p, scalar_last=True).values.tolist() == [[0.9, 0.1, 0.2, 0.3]]
    # named components have a known order: --scalar-last is refused for them
    q = _write(tmp_path / "named.csv", "Time (s),qx,qy,qz,qw\n0,0.1,0.2,0.3,0.9\n")
    assert "--scalar-last" in str(_error_kw(q, scalar_last=True))
    assert read_imu_csv(q).values.tolist() == [[0.9, 0.1, 0.2, 0.3]]


@pytest.mark.parametrize(("text", "words"), [
    ("time,timestamp,w,x,y,z\n0,0,1,0,0,0\n", ["'time', 'timestamp'", "--time-column"]),
    ("Frame,PacketCounter,w,x,y,z\n0,0,1,0,0,0\n", ["'Frame', 'PacketCounter'", "--time-column"]),
    ("w,x,y,z\n1,0,0,0\n", ["no time column", "'w', 'x', 'y', 'z'", "--rate", "--time-column"]),
    ("Frame,w,x,y,z\n0,1,0,0,0\n", ["'Frame'", "--rate"]),
    ("time,roll,pitch,yaw\n0,1,2,3\n", ["roll, pitch, yaw", "without a unit"]),
])
def test_ambiguous_files_name_columns_and_flag(tmp_path: Path, text: str, words: list[str]) -> None:
    p = _write(tmp_path / "amb.csv", text)
    msg = _assert_where(_error(p), p, 1)
    for w in words:
        assert w in msg, msg


def test_euler_with_units_in_names(tmp_path: Path) -> None:
    p = _write(tmp_path / "e.csv", "time,roll (rad),pitch (rad),yaw (rad)\n0,0,0,1.5707963267948966\n")
    sig = read_imu_csv(p)
    np.testing.assert_allclose(sig.values, [[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]], atol=1e-15)
    assert "radians" in sig.meta["conversion"]


def test_cli_override_flags(tmp_path: Path) -> None:
    import subprocess
    import sys

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "mocapkit.cli", *args], capture_output=True, text=True,
                              timeout=300)

    p = _write(tmp_path / "two.csv", "Time (s),Quat_W,Quat_X,Quat_Y,Quat_Z,qw,qx,qy,qz\n"
                                     "0,1,0,0,0,0,1,0,0\n1,0,0,1,0,0,0,0,1\n")
    r = run("info", str(p), "--json")
    assert r.returncode == 2 and "--quaternion-columns" in r.stderr
    r = run("info", str(p), "--json", "--quaternion-columns", "qw,qx,qy,qz", "--time-column", "Time (s)",
            "--time-unit", "ms")
    assert r.returncode == 0, r.stderr
    assert '"samples": 2' in r.stdout and '"duration_s": 0.001' in r.stdout


def test_stream_uses_the_same_header_detection() -> None:
    from mocapkit.io.imu.stream import iter_samples

    for path, kw in ((IMU / "xio" / "ximu3_Quaternion.csv", {}),
                     (IMU / "xsens-mtmanager" / "MT46_trailing_tab.txt", {}),
                     (IMU / "sensor-logger" / "Orientation.csv", {}),
                     (IMU / "xsens-mtmanager" / "euler_written.txt", {}),
                     (IMU / "xio" / "ngimu_quaternion.csv", {})):
        sig = read_imu_csv(path, **kw)
        with open(path, newline="") as fh:
            got = list(iter_samples(fh, str(path), **kw))
        assert np.array_equal([t for _, t, _ in got], sig.times), path
        assert np.array_equal([q for _, _, q in got], sig.values), path
    with open(IMU / "sensor-logger" / "Orientation.csv") as fh:
        got = list(iter_samples(fh, "<stdin>", time_column="seconds_elapsed"))
    assert got[0][1] == 0.216759663
    with open(IMU / "apdm" / "imuData01_excerpt.csv") as fh, pytest.raises(MocapFormatError, match="one sensor"):
        list(iter_samples(fh, "<stdin>"))


def test_shared_imu_files_read_with_plausible_rates(shared_data: Path) -> None:
    folder = shared_data / "imu"
    expected = {"xsens-dot": 60, "xsens-mtmanager": 100, "apdm": 128, "optitrack": 120, "xio-lower-body": 50}
    seen = set()
    for sub, rate in expected.items():
        paths = [folder / sub] if sub == "xio-lower-body" else sorted(p for p in (folder / sub).iterdir())
        for path in paths:
            sigs = load_signals(path)
            assert sigs, path
            for name, sig in sigs.items():
                seen.add(sub)
                step = float(np.min(np.diff(sig.times)))     # real logs drop samples: the shortest step
                assert 1 / step == pytest.approx(rate, rel=0.1), (path, name)
                assert len(sig) >= 5
                assert np.abs(np.linalg.norm(sig.values, axis=1) - 1).max() < 1e-3, (path, name)
    assert seen == set(expected)
    assert set(p.name for p in folder.iterdir()) == set(expected)   # every shared IMU export is covered


def test_sensor_logger_euler_only(tmp_path: Path) -> None:
    """Without quaternion columns, the logger's roll/pitch/yaw (radians) give the same rotations."""
    path = IMU / "sensor-logger" / "Orientation.csv"
    names, data = _table(path, 1)
    keep = [names.index(n) for n in ("time", "seconds_elapsed", "roll", "pitch", "yaw")]
    text = "\n".join(",".join(row[i] for i in keep) for row in [names] + data) + "\n"
    euler = read_imu_csv(_write(tmp_path / "Orientation.csv", text))
    quat = read_imu_csv(path)
    assert "radians" in euler.meta["conversion"]
    assert np.array_equal(euler.times, quat.times)
    np.testing.assert_allclose(_matrix_of(euler.values), _matrix_of(quat.values), atol=1e-12)


# ------------------------------------------------------------------------------------------------
# rows under the header, Xsens DOT Euler export, unit-less clocks, stream memory
# ------------------------------------------------------------------------------------------------


def test_ios_sensorlog_rows_starting_with_a_date_are_data() -> None:
    """iOS SensorLog: the first column is ``loggingTime(txt)`` (a date); no data row may be taken
    for a units row."""
    path = IMU / "sensorlog-ios" / "SensorLog_motion.csv"
    names, data = _table(path, 1)
    assert len(data) == 12 and all(r[0].startswith("2024-05-02 ") for r in data)   # rows start with a date
    want = _cols(names, data, [f"motionQuaternion{c}(R)" for c in "WXYZ"])     # scalar-last in the file
    by_rate = read_imu_csv(path, rate=100)             # no clock it recognises: rows at the given rate
    assert np.array_equal(by_rate.values, want) and np.array_equal(by_rate.times, np.arange(12) / 100)
    column = "motionTimestamp_sinceReboot(s)"
    sig = read_imu_csv(path, time_column=column)       # unit (s) from the name
    assert sig.meta["format"] == "sensorlog" and sig.meta["time_unit"] == "s" and sig.meta["warnings"] == []
    assert np.array_equal(sig.times, [float(r[names.index(column)]) for r in data])
    assert np.array_equal(sig.values, want)
    msg = str(_error(path))
    assert "--rate" in msg and "--time-column" in msg
    from mocapkit.io.imu.stream import iter_samples

    with open(path, newline="") as fh:
        got = list(iter_samples(fh, str(path), time_column=column))
    assert [ln for ln, _, _ in got] == list(range(2, 14))
    assert np.array_equal([t for _, t, _ in got], sig.times) and np.array_equal([q for _, _, q in got], want)


@pytest.mark.parametrize("n", [2, 5])
def test_date_first_column_keeps_every_row(tmp_path: Path, n: int) -> None:
    rows = [f"2024-05-02,{0.5 + i / 4},{i % 2},{(i + 1) % 2},0,0" for i in range(n)]
    p = _write(tmp_path / "date.csv", "Date,Time (s),W,X,Y,Z\n" + "\n".join(rows) + "\n")
    sig = read_imu_csv(p)
    assert sig.times.tolist() == [0.5 + i / 4 for i in range(n)]
    assert sig.values.tolist() == [[i % 2, (i + 1) % 2, 0, 0] for i in range(n)]
    assert sig.meta["warnings"] == []
    from mocapkit.io.imu.stream import iter_samples

    got = list(iter_samples(p.read_text().splitlines(), str(p)))
    assert [t for _, t, _ in got] == sig.times.tolist()


def test_units_row_under_a_date_column_is_skipped_and_reported(tmp_path: Path) -> None:
    p = _write(tmp_path / "u.csv", "Date,Time,W,X,Y,Z\n,ms,,,,\n2024-05-02,500,1,0,0,0\n2024-05-02,750,0,1,0,0\n")
    sig = read_imu_csv(p)
    assert sig.times.tolist() == [0.5, 0.75] and sig.meta["time_unit"] == "ms"
    assert len(sig.meta["warnings"]) == 1 and "line 2" in sig.meta["warnings"][0]
    apdm = load_signals(IMU / "apdm" / "imuData01_excerpt.csv")["Static"]
    assert any("line 4" in w and "units row" in w for w in apdm.meta["warnings"])


def test_xsens_dot_euler_export_matches_the_quaternion_export() -> None:
    """``LFemur_euler_excerpt.csv`` holds the quaternion excerpt's rotations as Euler_X/Y/Z = roll,
    pitch, yaw (degrees, 6 decimals; R = Rz(yaw)·Ry(pitch)·Rx(roll)); both files give the same rotations."""
    quat = read_imu_csv(IMU / "xsens-dot" / "LFemur_excerpt.csv")
    euler = read_imu_csv(IMU / "xsens-dot" / "LFemur_euler_excerpt.csv")
    assert euler.meta["format"] == "xsens-dot" and euler.meta["rate"] == 60.0
    assert euler.meta["orientation_columns"] == ["Euler_X", "Euler_Y", "Euler_Z"]
    assert "degrees" in euler.meta["conversion"]
    assert np.array_equal(euler.times, quat.times)
    q = quat.values / np.linalg.norm(quat.values, axis=1, keepdims=True)
    sign = np.sign(np.sum(q * euler.values, axis=1, keepdims=True))
    np.testing.assert_allclose(euler.values * sign, q, atol=1e-7)
    # the same names outside an Xsens file are not taken for roll, pitch, yaw (e.g. BNO055: x = heading)
    with pytest.raises(MocapFormatError, match="no orientation columns"):
        read_imu_text("time,Euler_X,Euler_Y,Euler_Z\n0,1,2,3\n", "<t>")


@pytest.mark.parametrize(("first", "unit"), [("1698501144401", "ms"), ("1698501144401759", "us"),
                                             ("1698501144401759663", "ns"), ("1698501144.4", "s"),
                                             ("12.5", "s")])
def test_unitless_epoch_by_magnitude(first: str, unit: str) -> None:
    sig = read_imu_text(f"timestamp,qw,qx,qy,qz\n{first},1,0,0,0\n", "<t>")
    assert sig.meta["time_unit"] == unit
    assert sig.times[0] == pytest.approx(float(first) / {"s": 1, "ms": 1e3, "us": 1e6, "ns": 1e9}[unit])


@pytest.mark.parametrize("first", ["12345678901234", "98765432101", "5000000000", "98765432101234567"])
def test_unitless_clock_that_is_no_epoch_is_refused(tmp_path: Path, first: str) -> None:
    """An Android uptime clock in ns (~1e13) is no epoch in any unit: no guess, an error naming the
    column and --time-unit; with --time-unit it reads."""
    p = _write(tmp_path / "up.csv", f"timestamp,qw,qx,qy,qz\n{first},1,0,0,0\n{int(first) + 10_000_000},0,1,0,0\n")
    msg = _assert_where(_error(p), p, 1)
    assert "'timestamp'" in msg and "--time-unit" in msg
    sig = read_imu_csv(p, time_unit="ns")
    assert sig.times.tolist() == [int(first) / 1e9, (int(first) + 10_000_000) / 1e9]


@pytest.mark.parametrize(("header", "row"), [
    ("time,qw,qx,qy,qz", "{t},1,0,0,0"),                    # a clock in seconds
    ("Frame,qw,qx,qy,qz", "{i},1,0,0,0"),                   # a counter with a rate
])
def test_stream_memory_is_constant(header: str, row: str) -> None:
    """``mocapkit stream`` keeps no per-row lists: the peak memory of 60 000 rows stays far below
    what one list entry per row would take (line numbers and times or counters: >= 60 B a row, 3.6 MB)."""
    import tracemalloc

    from mocapkit.io.imu.stream import iter_samples

    n = 60_000
    rate = 100.0 if header.startswith("Frame") else None

    def lines():
        yield header + "\n"
        for i in range(n):
            yield row.format(t=repr(0.5 + i / 100), i=i) + "\n"

    tracemalloc.start()
    try:
        count = 0
        last = None
        for last in iter_samples(lines(), "<gen>", rate):  # noqa: B007 - the last sample is checked below
            count += 1
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert count == n and last is not None and last[1] == pytest.approx((n - 1) / 100 + (0.5 if rate is None else 0))
    assert peak < 250_000, peak


def test_stream_without_header_stops_buffering() -> None:
    """Text lines without any orientation header: the stream reports the missing header after at
    most MAX_HEAD_LINES lines instead of buffering the whole input."""
    from mocapkit.io.imu.stream import MAX_HEAD_LINES, iter_samples

    read = []

    def lines():
        yield "Date,note,value\n"
        for i in range(10 * MAX_HEAD_LINES):
            read.append(i)
            yield f"2024-05-02,text {i},x\n"

    with pytest.raises(MocapFormatError, match="no orientation columns"):
        list(iter_samples(lines(), "<gen>"))
    assert len(read) <= MAX_HEAD_LINES + 1


# --------------------------------------------------------------------------------------------------
# plausibility of a guessed time unit; the order of numbered quaternion columns
# --------------------------------------------------------------------------------------------------

def _ms_rows(step: float, n: int = 6) -> str:
    rows = [f"{k * step:g},{math.cos(0.05 * k)!r},{math.sin(0.05 * k)!r},0,0" for k in range(n)]
    return "time,w,x,y,z\n" + "\n".join(rows) + "\n"


def _rate_warnings(sig: Signal) -> list[str]:
    return [w for w in sig.meta["warnings"] if "has no unit" in w]


def test_unitless_time_in_ms_warns_and_keeps_the_data(tmp_path: Path) -> None:
    p = _write(tmp_path / "ms.csv", _ms_rows(10))          # 100 Hz in milliseconds, header says "time"
    sig = read_imu_csv(p)
    (w,) = _rate_warnings(sig)
    assert "'time'" in w and "0.1 Hz" in w and "--time-unit" in w
    assert sig.times.tolist() == [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]   # read as given, never rescaled
    fixed = read_imu_csv(p, time_unit="ms")
    assert _rate_warnings(fixed) == [] and fixed.times == pytest.approx([0, 0.01, 0.02, 0.03, 0.04, 0.05])
    assert np.array_equal(fixed.values, sig.values)


@pytest.mark.parametrize("step, warns", [
    (0.01, False),      # 100 Hz in seconds
    (1 / 2000, False),  # 2 kHz in seconds
    (0.25, False),      # 4 Hz: slow but possible
    (1.0, True),        # a 1 kHz recording in ms read as seconds: 1 Hz
    (1e-5, True),       # 100 kHz: no orientation sensor
])
def test_unitless_time_rate_bounds(tmp_path: Path, step: float, warns: bool) -> None:
    sig = read_imu_csv(_write(tmp_path / "t.csv", _ms_rows(step)))
    assert bool(_rate_warnings(sig)) is warns


def test_stated_time_unit_is_not_second_guessed(tmp_path: Path) -> None:
    """'Time (s)' at 0.1 Hz, or a units row saying s, is what the file says: no plausibility warning."""
    p = _write(tmp_path / "slow.csv", _ms_rows(10).replace("time,", "Time (s),", 1))
    assert read_imu_csv(p).meta["warnings"] == []
    p = _write(tmp_path / "units.csv", _ms_rows(10).replace("\n", "\ns,,,,\n", 1))
    assert _rate_warnings(read_imu_csv(p)) == []


def _imu_files(shared_data: Path, tests_data: Path) -> list[Path]:
    files = [f for root in (shared_data / "imu", tests_data / "imu") for f in sorted(root.rglob("*"))
             if f.suffix in (".csv", ".txt") and f.name != "Inertial.csv"]
    assert len(files) >= 25
    return files


def _load_any(f: Path) -> dict[str, Signal]:
    try:
        return load_signals(f)
    except MocapFormatError as exc:     # counters or no time column: the file states no rate
        assert "--rate" in str(exc)
        return load_signals(f, rate=100.0)


def test_real_files_give_no_rate_warning(shared_data: Path, tests_data: Path) -> None:
    for f in _imu_files(shared_data, tests_data):
        for sig in _load_any(f).values():
            assert _rate_warnings(sig) == [], f


def test_numbered_columns_state_their_order(tests_data: Path, tmp_path: Path) -> None:
    """q0..q3 / Element 1..4 do not say which one is w: meta["conversion"] says how they were read."""
    mt = read_imu_csv(tests_data / "imu" / "xsens-mtmanager" / "MT46_01-000_00B42D4D.txt")
    assert mt.meta["conversion"] == ("numbered columns Quat_q0, Quat_q1, Quat_q2, Quat_q3 read as w,x,y,z "
                                     "(scalar first); use --scalar-last if they hold x,y,z,w")
    legacy = read_imu_csv(tests_data / "imu" / "xio" / "legacy_QuaternionData.csv", rate=100.0)
    assert "Element 1, Element 2, Element 3, Element 4 read as w,x,y,z" in legacy.meta["conversion"]
    named = read_imu_csv(tests_data / "imu" / "xio" / "ximu3_Quaternion.csv")
    assert named.meta["conversion"] is None
    # a scalar-last rewrite, read with --scalar-last, gives the same quaternions and says so
    q = mt.values
    text = "Sample rate: 100\nq0,q1,q2,q3\n" + "".join(f"{x!r},{y!r},{z!r},{w!r}\n" for w, x, y, z in q.tolist())
    back = read_imu_csv(_write(tmp_path / "last.csv", text), scalar_last=True)
    assert np.array_equal(back.values, q)
    assert back.meta["conversion"] == "numbered columns q0, q1, q2, q3 read as x,y,z,w (--scalar-last)"
    assert back.meta["orientation_columns"] == ["q3", "q0", "q1", "q2"]


def test_why_the_values_cannot_tell_the_scalar(shared_data: Path) -> None:
    """The reason no order check is made (imucsv docstring): on a real scalar-first file the scalar
    crosses zero while a vector part keeps its sign, which a sign rule ("the scalar keeps its sign")
    would read as scalar-last."""
    sig = read_imu_csv(shared_data / "imu" / "xio-lower-body" / "right-lower-leg" / "Quaternion.csv")
    w, z = sig.values[:, 0], sig.values[:, 3]
    assert w.min() < -0.1 and w.max() > 0.1                 # W takes both signs (the walker turns)
    assert np.all(z < 0) and np.abs(z).min() > 0.2         # Z keeps one sign, far from zero


@pytest.mark.parametrize("command", [
    ["compress", "{f}", "-t", "1e-3", "--stats-only"],
    ["decompress", "{pts}", "-o", "{out}", "--times-from", "{f}"],
    ["sweep", "{f}", "--thresholds", "3", "--out", "{out_dir}"],
])
def test_cli_prints_reader_warnings(tmp_path: Path, command: list[str]) -> None:
    import subprocess
    import sys

    f = _write(tmp_path / "ms.csv", _ms_rows(10, n=40))
    pts = _write(tmp_path / "pts.csv", "time,w,x,y,z\n0,1,0,0,0\n390,1,0,0,0\n")
    args = [a.format(f=f, pts=pts, out=tmp_path / "out.csv", out_dir=tmp_path / "sw") for a in command]
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", *args], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith(f"warning: {f}: column 'time' has no unit")]
    assert len(lines) == 1 and "0.1 Hz" in lines[0] and "--time-unit" in lines[0], r.stderr
    assert "warning" not in r.stdout
