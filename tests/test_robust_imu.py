"""Issue 10 for the IMU / signal CSV readers: strict finite numbers, time steps, bounded memory and
reading, files cut short, non-UTF-8 text, and the stream parser. Values are compared with an
independent parse by the ``csv`` module."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.imu.lines import CHUNK_BYTES, MAX_LINE_BYTES
from mocapkit.io.imu.rows import MIN_STEP
from mocapkit.io.imu.signals import read_imu_csv, read_imu_file, read_imu_text
from mocapkit.io.imu.stream import iter_samples
from mocapkit.io.text.numbers import MAX_ABS

IMU = Path(__file__).resolve().parent / "data" / "imu"
H = "Timestamp (us),W,X,Y,Z\n"


def _write(path: Path, data: str | bytes) -> Path:
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def _err(path: Path, **kw) -> MocapFormatError:
    with pytest.raises(MocapFormatError) as info:
        read_imu_file(path, **kw)
    return info.value


def _where(err: MocapFormatError, path: Path | str, line: int | None, *words: str) -> str:
    msg = str(err)
    assert err.path == str(path) and err.line == line, msg
    assert msg.startswith(f"{path}:{line}: " if line is not None else f"{path}: "), msg
    for w in words:
        assert w in msg, msg
    return msg


def _all_readers_fail(tmp_path: Path, text: str, line: int, *words: str, rate: float | None = None) -> None:
    """The file reader, the text reader and the stream all refuse ``text`` naming ``line`` and ``words``."""
    p = _write(tmp_path / "bad.csv", text)
    _where(_err(p, rate=rate), p, line, *words)
    with pytest.raises(MocapFormatError) as info:
        read_imu_text(text, "<t>", rate=rate)
    _where(info.value, "<t>", line, *words)
    with pytest.raises(MocapFormatError) as info:
        list(iter_samples(io.StringIO(text), "<s>", rate))
    _where(info.value, "<s>", line, *words)


def _csv_parse(path: Path, skip: int, tcol: int, qcols: list[int], delimiter: str = ","):
    """Independent reference: the csv module and ``float`` of each cell."""
    with open(path, newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(fh, delimiter=delimiter)][skip:]
    rows = [r for r in rows if any(c.strip() for c in r)]
    return [r[tcol] for r in rows], np.array([[float(r[c]) for c in qcols] for r in rows])


def _big_rows(n: int, rng: np.random.Generator, fmt: str = "{:.9f}", start: int = 0) -> list[str]:
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    t = 1_000_000 + 10_000 * np.arange(start, start + n)
    return [f"{a}," + ",".join(fmt.format(v) for v in row) for a, row in zip(t.tolist(), q.tolist(), strict=True)]


# ------------------------------------------------------------------------------------------------
# strict numbers
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("cell", "words"), [
    ("0_5", ["column X", "'0_5'", "not a number"]),
    ("nan", ["column X is NaN"]),
    ("-inf", ["column X is infinite"]),
    ("1e999", ["column X is infinite"]),
    ("1e308", ["column X", "'1e308'", "out of range"]),
    ("-2e12", ["column X", "out of range"]),
    ("0x10", ["column X", "not a number"]),
    ("1.5.2", ["column X", "not a number"]),
    ("", ["column X", "not a number"]),
])
def test_orientation_cell_is_a_strict_finite_number(tmp_path: Path, cell: str, words: list[str]) -> None:
    text = H + "100,1,0,0,0\n200,1,0,0,0\n" + f"300,0.5,{cell},0.5,0.5\n" + "400,1,0,0,0\n"
    _all_readers_fail(tmp_path, text, 4, *words)


def test_limit_is_inclusive_and_values_are_exact(tmp_path: Path) -> None:
    text = H + "100,1e12,0,0,-1e12\n200,0.5,1e-300,0,0\n"
    p = _write(tmp_path / "ok.csv", text)
    sig = read_imu_csv(p)
    assert sig.values.tolist() == [[1e12, 0.0, 0.0, -1e12], [0.5, 1e-300, 0.0, 0.0]]


def test_matrix_entry_and_euler_angle_beyond_the_limit(tmp_path: Path) -> None:
    names = "\t".join(f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3))
    ident = "\t".join(["1", "0", "0", "0", "1", "0", "0", "0", "1"])
    text = f"// Update Rate: 100.0Hz\nPacketCounter\t{names}\n1\t{ident}\n2\t{ident.replace('1', '1e308', 1)}\n"
    p = _write(tmp_path / "m.txt", text)
    _where(_err(p), p, 4, "column Mat[1][1]", "out of range")
    text = "time,Roll (deg),Pitch (deg),Yaw (deg)\n0,0,0,0\n0.01,0,1e300,0\n"
    _all_readers_fail(tmp_path, text, 3, "column Pitch (deg)", "out of range")


def test_zero_quaternion_names_its_line(tmp_path: Path) -> None:
    text = H + "".join(f"{100 * (i + 1)},1,0,0,0\n" for i in range(5000)) + "500100,0,-0.0,0e3,0\n"
    p = _write(tmp_path / "z.csv", text)
    _where(_err(p), p, 5002, "zero-norm quaternion")


def test_epoch_in_ns_uses_a_larger_limit_before_scaling(tmp_path: Path) -> None:
    t = [1_700_000_000_123_456_789 + 10_000_000 * i for i in range(4)]
    text = "time (ns),qw,qx,qy,qz\n" + "".join(f"{v},1,0,0,0\n" for v in t)
    p = _write(tmp_path / "ns.csv", text)
    sig = read_imu_csv(p)
    assert sig.times.tolist() == [v / 1e9 for v in t]
    p = _write(tmp_path / "ns2.csv", text + "1e22,1,0,0,0\n")
    _where(_err(p), p, 6, "column time (ns)", "out of range")
    # seconds keep MAX_ABS
    p = _write(tmp_path / "s.csv", f"time (s),qw,qx,qy,qz\n0,1,0,0,0\n{2 * MAX_ABS:g},1,0,0,0\n")
    _where(_err(p), p, 3, "column time (s)", "out of range")


def test_counter_must_be_a_plain_integer(tmp_path: Path) -> None:
    base = "// Update Rate: 100.0Hz\nPacketCounter\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n1\t1\t0\t0\t0\n"
    for cell, words in (("2.5", ["not an integer"]), ("2_0", ["not a number"]), ("1e20", ["out of range"]),
                        ("nan", ["is NaN"])):
        p = _write(tmp_path / "c.txt", base + f"{cell}\t1\t0\t0\t0\n")
        _where(_err(p), p, 4, "column PacketCounter", *words)


# ------------------------------------------------------------------------------------------------
# times and rates
# ------------------------------------------------------------------------------------------------


def test_a_time_step_giving_an_absurd_rate_is_an_error(tmp_path: Path) -> None:
    _all_readers_fail(tmp_path, "time,w,x,y,z\n0,1,0,0,0\n1e-320,1,0,0,0\n", 3, "below", "not a sample interval")
    _all_readers_fail(tmp_path, "time,w,x,y,z\n1,1,0,0,0\n1.0000000000001,1,0,0,0\n", 3, "below")
    ok = read_imu_text(f"time,w,x,y,z\n0,1,0,0,0\n{MIN_STEP!r},1,0,0,0\n", "<t>")
    assert ok.times.tolist() == [0.0, MIN_STEP]


def test_absurd_rates_are_refused(tmp_path: Path) -> None:
    counter = "PacketCounter,Quat_W,Quat_X,Quat_Y,Quat_Z\n1,1,0,0,0\n2,1,0,0,0\n"
    for rate in ("1e300", "1e-300", "1_00", "nan"):
        p = _write(tmp_path / "r.csv", f"Sample rate:,{rate}\n" + counter)
        _where(_err(p), p, 1, "sample rate")
    p = _write(tmp_path / "c.csv", counter)
    for bad in (1e300, 2e9, math.inf, 0.0):
        with pytest.raises(InvalidParameterError, match="rate"):
            read_imu_file(p, rate=bad)


def test_duplicate_and_decreasing_times_deep_in_a_large_file(tmp_path: Path) -> None:
    rows = _big_rows(60_000, np.random.default_rng(1))
    k = 45_000
    dup = rows[:k] + [rows[k - 1].split(",", 1)[0] + "," + rows[k].split(",", 1)[1]] + rows[k + 1:]
    p = _write(tmp_path / "d.csv", H + "\n".join(dup) + "\n")
    _where(_err(p), p, k + 2, "duplicate timestamp", f"line {k + 1}")
    dec = rows[:k] + ["5," + rows[k].split(",", 1)[1]] + rows[k + 1:]
    p = _write(tmp_path / "e.csv", H + "\n".join(dec) + "\n")
    _where(_err(p), p, k + 2, "timestamps must increase")


def _unwrap(raw: list[int], mod: int) -> list[int]:
    """Reference unwrapping of a counter with wrap-arounds (no error cases)."""
    out, off = [raw[0]], 0
    for a, b in zip(raw[:-1], raw[1:], strict=True):
        if b < a:
            off += mod
        out.append(b + off)
    return out


def test_counter_wraps_in_a_large_file_match_a_reference(tmp_path: Path) -> None:
    n = 200_000
    raw = [(65_000 + i) % 65_536 for i in range(n)]
    q = "\t1\t0\t0\t0"
    p = _write(tmp_path / "w.txt", "// Update Rate: 100.0Hz\nPacketCounter\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n"
               + "".join(f"{c:05d}{q}\n" for c in raw))
    sig = read_imu_csv(p)
    ref = np.array(_unwrap(raw, 65_536), dtype=np.float64)
    assert np.array_equal(sig.times, (ref - ref[0]) / 100.0)
    # a drop that is no wrap-around, deep in the file, names its line
    bad = raw[:150_000] + [raw[150_000] - 70] + raw[150_001:]
    p = _write(tmp_path / "w2.txt", "// Update Rate: 100.0Hz\nPacketCounter\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3\n"
               + "".join(f"{c:05d}{q}\n" for c in bad))
    _where(_err(p), p, 150_003, "PacketCounter must increase")


# ------------------------------------------------------------------------------------------------
# bulk and line-by-line paths give the numbers of the csv module
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("variant", ["plain", "crlf", "padded", "quoted-block", "exponents", "trailing-delim"])
def test_large_files_match_the_csv_module(tmp_path: Path, variant: str) -> None:
    rng = np.random.default_rng(3)
    rows = _big_rows(40_000, rng, "{!r}" if variant != "exponents" else "{:.6e}")
    if variant == "padded":
        rows = [r.replace(",", ", ") for r in rows]
    if variant == "quoted-block":       # quotes in one block send it through the line-by-line path
        rows = rows[:20_000] + [",".join(f'"{c}"' for c in r.split(",")) for r in rows[20_000:21_000]] + rows[21_000:]
    if variant == "trailing-delim":
        rows = [r + "," for r in rows]
    text = H + "\n".join(rows) + "\n"
    if variant == "crlf":
        text = text.replace("\n", "\r\n")
    p = _write(tmp_path / "big.csv", text)
    sig = read_imu_csv(p)
    ts, ref = _csv_parse(p, 1, 0, [1, 2, 3, 4])
    assert np.array_equal(sig.values, ref)
    assert np.array_equal(sig.times, np.array([int(t.strip().strip('"')) / 1e6 for t in ts]))
    assert np.array_equal(read_imu_text(text, "<t>").values, ref)


def test_mt_manager_text_with_empty_columns_and_trailing_tabs(tmp_path: Path) -> None:
    head = (IMU / "xsens-mtmanager" / "MT46_trailing_tab.txt").read_text().split("\n")[:5]
    rng = np.random.default_rng(5)
    rows = []
    for i in range(30_000):
        q = rng.normal(size=4)
        rows.append(f"{i % 65536:05d}\t\t\t\t\t\t" + "\t".join(f"{v:.6f}" for v in rng.normal(size=6)) + "\t"
                    + "\t".join(f"{v:.6f}" for v in q) + "\t")
    p = _write(tmp_path / "mt.txt", "\n".join(head) + "\n" + "\n".join(rows) + "\n")
    sig = read_imu_csv(p)
    _, ref = _csv_parse(p, 5, 0, [12, 13, 14, 15], delimiter="\t")
    assert np.array_equal(sig.values, ref)
    assert np.array_equal(sig.times, np.arange(30_000) / 100.0)


# ------------------------------------------------------------------------------------------------
# the last line without a line end
# ------------------------------------------------------------------------------------------------


def _fixed(n: int) -> list[str]:
    return [f"{100 * (i + 1)},{0.5 + i * 1e-6:.6f},-0.124044,0.250000,0.750000" for i in range(n)]


def test_number_cut_short_at_end_of_file_is_an_error(tmp_path: Path) -> None:
    for n in (5, 30_000):          # within the header's block, and in a later block
        rows = _fixed(n)
        text = H + "\n".join(rows[:-1]) + "\n" + rows[-1].rsplit(",", 1)[0] + ",0"
        p = _write(tmp_path / "cut.csv", text)
        _where(_err(p), p, n + 1, "column Z", "'0'", "cut short")
        with pytest.raises(MocapFormatError, match="cut short"):
            list(iter_samples(io.StringIO(text), "<s>"))
    # the exponent cut off: 1.5e-05 -> 1.5e-0
    text = "time,w,x,y,z\n0,1,0,0,1.5e-05\n1,1,0,0,2.5e-05\n2,1,0,0,3.5e-0"
    with pytest.raises(MocapFormatError, match="cut short"):
        read_imu_text(text, "<t>")


def test_last_line_with_fewer_fields_and_no_line_end(tmp_path: Path) -> None:
    text = H + "\n".join(_fixed(4)) + "\n500,0.500004,-0.12"
    p = _write(tmp_path / "f.csv", text)
    _where(_err(p), p, 6, "expected 5", "got 3", "cut short")


def test_complete_last_line_without_line_end_is_read(tmp_path: Path) -> None:
    rows = _fixed(6)
    p = _write(tmp_path / "ok.csv", H + "\n".join(rows))
    assert len(read_imu_csv(p)) == 6
    # repr-written numbers have varying decimals: a last value shorter than the longest of its column
    # is read as written, with a warning (rule (c)): never an error
    p = _write(tmp_path / "r.csv", "time,w,x,y,z\n0.0,1,0,0,0.123456789\n0.5,1,0,0,0.25\n1.0,1,0,0,0.5")
    sig = read_imu_csv(p)
    assert sig.values[-1].tolist() == [1, 0, 0, 0.5]
    assert any("line 4" in w and "'0.5'" in w and "may be cut short" in w for w in sig.meta["warnings"])
    # as long as the longest value of its column: no warning
    p = _write(tmp_path / "r2.csv", "time,w,x,y,z\n0.0,1,0,0,0.25\n0.5,1,0,0,0.5\n1.0,1,0,0,0.75")
    assert not read_imu_csv(p).meta["warnings"]


def test_cut_in_an_unused_column_is_a_warning(tmp_path: Path) -> None:
    rows = [f"{100 * (i + 1)},1,0,0,0,{9.81 + i * 1e-6:.6f}" for i in range(5)]
    p = _write(tmp_path / "u.csv", "Timestamp (us),W,X,Y,Z,Acc\n" + "\n".join(rows[:-1]) + "\n500,1,0,0,0,9.8")
    sig = read_imu_csv(p)
    assert len(sig) == 5 and any("cut short" in w and "Acc" in w for w in sig.meta["warnings"])


FORMATS = Path(__file__).resolve().parent / "data" / "formats"
XIO_PELVIS = Path(__file__).resolve().parent / "data" / "xio" / "pelvis" / "Quaternion.csv"
EXE = [sys.executable, "-m", "mocapkit.cli"]


def _stream_warnings(text: str) -> list[str]:
    import warnings

    from mocapkit.errors import MocapWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        list(iter_samples(io.StringIO(text), "<s>"))
    return [str(w.message) for w in caught if issubclass(w.category, MocapWarning)]


def test_generic_csv_cut_after_the_point_is_an_error(tmp_path: Path) -> None:
    """``tests/data/formats/generic.csv`` ending ``1.0,0.1,0.2,0.3,0.`` (was ``0.4``): the column holds
    ``0`` and ``1e-300``, so decimals cannot tell; a number ending with its point is cut (rule (a))."""
    text = (FORMATS / "generic.csv").read_text().rstrip("\n")
    assert text.endswith(",0.4")
    cut = text[:-1]
    p = _write(tmp_path / "generic.csv", cut)
    _where(_err(p), p, 4, "column z", "'0.'", "cut short")
    with pytest.raises(MocapFormatError, match="cut short") as info:
        list(iter_samples(io.StringIO(cut), "<s>"))
    assert info.value.line == 4
    # the same line with its line end is a complete row holding 0.0 (a legitimate spelling)
    p = _write(tmp_path / "whole.csv", cut + "\n")
    assert read_imu_csv(p).values[-1].tolist() == [0.1, 0.2, 0.3, 0.0]
    # cut before the point (``0``): shorter than ``1e-300`` in a column of varying shapes: a warning
    p = _write(tmp_path / "generic0.csv", text[:-2])
    sig = read_imu_csv(p)
    assert any(w.startswith("line 4: column z:") and "'0'" in w and "may be cut short" in w
               for w in sig.meta["warnings"]), sig.meta["warnings"]
    assert any(w.startswith("<s>: line 4: column z:") for w in _stream_warnings(text[:-2]))
    # the intact file without its final newline is read whole; ``0.4`` is shorter than ``1e-300``, so
    # rule (c) may warn, but it is never refused
    p = _write(tmp_path / "intact.csv", text)
    assert read_imu_csv(p).values[-1].tolist() == [0.1, 0.2, 0.3, 0.4]
    assert len(_stream_warnings(text)) <= 1 and len(list(iter_samples(io.StringIO(text + "\n"), "<s>"))) == 3


@pytest.mark.parametrize("end", ["e", "E", "e-", "+", "-"])
def test_last_value_ending_like_a_cut_number_is_an_error(tmp_path: Path, end: str) -> None:
    rows = ["time,w,x,y,z,note", "0,1,0,0,0,1.5e-05", "1,1,0,0,0,2.5e+05", "2,1,0,0,0,3.5" + end]
    p = _write(tmp_path / "e.csv", "\n".join(rows))
    _where(_err(p), p, 4, "column note", "cut short")   # even in a column the reader does not use


def test_trailing_point_written_by_the_exporter_is_not_a_cut(tmp_path: Path) -> None:
    rows = ["time,w,x,y,z", "0,1,0,0,1.", "1,1,0,0,2.", "2,1,0,0,3."]
    p = _write(tmp_path / "p.csv", "\n".join(rows))
    assert read_imu_csv(p).values[-1].tolist() == [1, 0, 0, 3.0]


@pytest.fixture(scope="module")
def compress_points(tmp_path_factory) -> Path:
    """A points CSV written by ``mocapkit compress`` (``repr`` floats: varying decimals)."""
    out = tmp_path_factory.mktemp("points") / "points.csv"
    r = subprocess.run(EXE + ["compress", str(XIO_PELVIS), "-t", "0.001", "-o", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return out


def test_compress_points_cut_inside_their_last_value_are_reported(tmp_path: Path, compress_points: Path) -> None:
    data = compress_points.read_bytes().rstrip(b"\n")
    lines = data.split(b"\n")
    n = len(lines)
    shapes = {len(x.split(b",")[-1].partition(b".")[2]) for x in lines[1:]}
    assert len(shapes) > 1, "the last column should be written with varying decimals"
    start = data.rindex(b",") + 1   # the last value: from the last comma to the end
    assert len(data) - start >= 4
    # the intact file without its final newline: read, at most a warning
    p = _write(tmp_path / "points.csv", data)
    ref = read_imu_csv(compress_points).values
    assert np.array_equal(read_imu_csv(p).values, ref)
    for cut in range(start + 1, len(data)):
        text = data[:cut]
        p = _write(tmp_path / "points.csv", text)
        try:
            sig = read_imu_csv(p)
        except MocapFormatError as e:
            _where(e, p, n, "column z", "cut short")
            continue
        assert any(w.startswith(f"line {n}: column z:") and "may be cut short" in w
                   for w in sig.meta["warnings"]), (text[-30:], sig.meta["warnings"])
    # the case of the trial (``-0.053447`` cut to ``-0.05344``) through the command line: the warning
    # names the file and the line, for decompress (which reads points) and compress
    body = data[:start] + b"-0.05344"
    p = _write(tmp_path / "cut_points.csv", body)
    for argv in (["decompress", str(p), "-o", str(tmp_path / "d.csv"), "--rate", "50"],
                 ["compress", str(p), "--max-angle", "2", "--json"]):
        r = subprocess.run(EXE + argv, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        assert f"warning: {p}: line {n}: column z: the file has no final newline and its last value " \
               "'-0.05344' is shorter than others of its column" in r.stderr, r.stderr


# ------------------------------------------------------------------------------------------------
# non-regular inputs, NUL bytes, long lines, encodings
# ------------------------------------------------------------------------------------------------


def test_dev_zero_fails_fast() -> None:
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    t0 = time.perf_counter()
    err = _err(Path("/dev/zero"))
    assert "NUL" in str(err) and err.line == 1
    assert time.perf_counter() - t0 < 30  # generous; the point is that it ends


def test_nul_byte_and_long_line_in_a_file(tmp_path: Path) -> None:
    p = _write(tmp_path / "n.csv", H + "100,1,0,0,0\n200,1,0\x00,0,0\n")
    _where(_err(p), p, 3, "NUL")
    p = _write(tmp_path / "l.csv", H + "100,1,0,0,0\n" + "7" * (MAX_LINE_BYTES + 10) + "\n")
    _where(_err(p), p, 3, "longer than")
    p = _write(tmp_path / "l2.csv", "x" * (3 * CHUNK_BYTES))
    _where(_err(p), p, 1, "longer than")
    p = _write(tmp_path / "e.csv", H + "100,1,0,0,0\n" + "\n" * 200_000 + "300,1,0,0,0\n")
    _where(_err(p), p, 3, "empty line")


def test_fifo_is_read_in_chunks(tmp_path: Path) -> None:
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    rows = _big_rows(20_000, np.random.default_rng(2))
    payload = (H + "\n".join(rows) + "\n").encode()

    def writer(data: bytes) -> None:
        with open(fifo, "wb") as fh:
            for i in range(0, len(data), 65_536):
                fh.write(data[i: i + 65_536])

    th = threading.Thread(target=writer, args=(payload,))
    th.start()
    sig = read_imu_file(fifo)
    th.join()
    assert len(sig["pipe"]) == 20_000
    assert sig["pipe"].values[-1].tolist() == [float(x) for x in rows[-1].split(",")[1:]]

    def nuls() -> None:
        try:
            with open(fifo, "wb") as fh:
                fh.write(b"\0" * (4 * CHUNK_BYTES))
        except BrokenPipeError:
            pass

    th = threading.Thread(target=nuls)
    th.start()
    err = _err(fifo)
    th.join()
    assert "NUL" in str(err)


def test_not_utf8_is_a_format_error(tmp_path: Path) -> None:
    data = (H + "100,1,0,0,0\n200,0.5,0.5,0.5,0.5\n").encode() + b"300,\xff,0,0,0\n"
    p = _write(tmp_path / "b.csv", data)
    _where(_err(p), p, 4, "not UTF-8")
    with pytest.raises(MocapFormatError, match="not UTF-8"):
        list(iter_samples(io.TextIOWrapper(io.BytesIO(data), encoding="utf-8"), "<stdin>"))
    # stdin in a POSIX locale decodes with surrogateescape: still a clear error
    text = data.decode("utf-8", "surrogateescape")
    with pytest.raises(MocapFormatError, match="not UTF-8"):
        list(iter_samples(io.StringIO(text), "<stdin>"))


class _Source:
    """A text stream that records the largest read asked for (the stream must bound its lines)."""

    def __init__(self, text: str):
        self.fh = io.StringIO(text)
        self.largest = 0

    def readline(self, size: int = -1) -> str:
        self.largest = max(self.largest, size if size >= 0 else 1 << 62)
        return self.fh.readline(size)


def test_stream_reads_bounded_lines() -> None:
    src = _Source(H + "100,1,0,0,0\n" + "9" * (5 * MAX_LINE_BYTES))
    with pytest.raises(MocapFormatError, match="longer than"):
        list(iter_samples(src, "<stdin>"))
    assert src.largest <= MAX_LINE_BYTES + 1
    with pytest.raises(MocapFormatError, match="NUL"):
        list(iter_samples(io.StringIO("\0" * 5000), "<stdin>"))


@pytest.mark.parametrize("row", ["300,inf,0,0,0", "300,1,nan,0,0", "300,1e308,0,0,0", "nan,1,0,0,0",
                                 "300,0_5,0,0,0"])
def test_stream_never_yields_non_finite_rows(row: str) -> None:
    text = H + "100,1,0,0,0\n200,1,0,0,0\n" + row + "\n400,1,0,0,0\n"
    got = []
    with pytest.raises(MocapFormatError) as info:
        for s in iter_samples(io.StringIO(text), "<stdin>"):
            got.append(s)
    assert info.value.line == 4
    assert [g[0] for g in got] == [2, 3]


def test_stream_counter_time_must_stay_sane() -> None:
    text = "PacketCounter,Quat_W,Quat_X,Quat_Y,Quat_Z\n1,1,0,0,0\n2,1,0,0,0\n"
    with pytest.raises(MocapFormatError, match="out of range"):
        list(iter_samples(io.StringIO(text), "<s>", rate=1e-300))


# ------------------------------------------------------------------------------------------------
# mutated real excerpts
# ------------------------------------------------------------------------------------------------

_EXCERPTS = {
    "ximu3": ("xio/ximu3_Quaternion.csv", None),
    "dot": ("xsens-dot/LFemur_excerpt.csv", None),
    "mt46": ("xsens-mtmanager/MT46_trailing_tab.txt", None),
    "matrix": ("xsens-mtmanager/MT_012005D6_matrix_excerpt.txt", None),
    "optitrack": ("optitrack/take_lost_body.csv", None),
    "ngimu": ("xio/ngimu_quaternion.csv", None),
    "legacy": ("xio/legacy_QuaternionData.csv", 128.0),
    "logger": ("sensor-logger/Orientation.csv", None),
}
_TOKENS = [b"nan", b"NaN", b"inf", b"-inf", b"1e308", b"-1e308", b"1e999", b"0_5", b"1_000", b"1e-320", b""]


@st.composite
def _mutation(draw):
    key = draw(st.sampled_from(sorted(_EXCERPTS)))
    rel, rate = _EXCERPTS[key]
    data = (IMU / rel).read_bytes()
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["token", "truncate", "double_delim", "token"]))
        if op == "truncate":
            data = data[: draw(st.integers(0, len(data)))]
            continue
        lines = data.split(b"\n")
        i = draw(st.integers(0, max(len(lines) - 1, 0)))
        line = lines[i]
        delim = b"\t" if b"\t" in line else b","
        cells = line.split(delim)
        j = draw(st.integers(0, max(len(cells) - 1, 0)))
        if op == "token":
            cells[j] = draw(st.sampled_from(_TOKENS))
        else:
            cells[j] = cells[j] + delim
        lines[i] = delim.join(cells)
        data = b"\n".join(lines)
    return key, data, rate


def _check_signal(sig) -> None:
    assert np.all(np.isfinite(sig.times)) and np.all(np.isfinite(sig.values))
    assert np.all(np.abs(sig.values) <= MAX_ABS)
    assert np.all(np.diff(sig.times) >= MIN_STEP)
    assert np.all(np.einsum("ij,ij->i", sig.values, sig.values) > 0)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(case=_mutation())
def test_mutated_excerpts_give_finite_values_or_a_format_error(tmp_path: Path, case) -> None:
    key, data, rate = case
    p = tmp_path / f"m_{key}.csv"
    p.write_bytes(data)
    try:
        sigs = read_imu_file(p, rate=rate)
    except MocapFormatError as exc:
        assert str(exc).startswith(str(p)) and (exc.line is None or exc.line >= 1)
        sigs = None
    if sigs is not None:
        for s in sigs.values():
            _check_signal(s)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return
    try:
        streamed = list(iter_samples(io.StringIO(text), "<s>", rate))
    except MocapFormatError:
        return
    for _, t, q in streamed:
        assert math.isfinite(t) and all(math.isfinite(v) and abs(v) <= MAX_ABS for v in q)
    if sigs is not None and len(sigs) == 1:
        sig = next(iter(sigs.values()))
        assert np.array_equal(np.array([q for _, _, q in streamed]).reshape(-1, 4), sig.values)
        assert np.array_equal(np.array([t for _, t, _ in streamed]), sig.times)


# ------------------------------------------------------------------------------------------------
# memory
# ------------------------------------------------------------------------------------------------

_MEASURE = r"""
import json, sys
def status(key):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
from mocapkit.io import read_imu_file
import scipy.spatial.transform
base = status("VmRSS")
sig = read_imu_file(sys.argv[1])["big"]
print(json.dumps({"base": base, "peak": status("VmHWM"), "rows": len(sig)}))
"""


def test_peak_memory_stays_within_three_times_the_numbers(tmp_path: Path) -> None:
    """A ~50 MB file: the reader's peak resident memory above the interpreter's (measured in a
    fresh process) stays below 3x the float64 data plus 40 MB of fixed slack (chunks, loadtxt's
    buffers, malloc arenas). Before issue 10 it was about 15x."""
    if not Path("/proc/self/status").exists():
        pytest.skip("needs /proc (Linux)")
    rng = np.random.default_rng(11)
    n = 750_000
    p = tmp_path / "big.csv"
    with open(p, "w") as fh:
        fh.write(H)
        for s in range(0, n, 150_000):
            fh.write("\n".join(_big_rows(150_000, rng, start=s)) + "\n")
    assert p.stat().st_size > 40e6
    out = subprocess.run([sys.executable, "-c", _MEASURE, str(p)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["rows"] == n
    numeric = n * 5 * 8
    growth = res["peak"] - res["base"]
    assert growth <= 3 * numeric + 40 * 2**20, (growth / numeric, res)


def test_number_cut_after_its_point_with_one_row_before_is_an_error(tmp_path: Path) -> None:
    """Found by the trial: ``xsens.txt`` cut to ``...\\t0.`` on its second data row. One row before it
    says little about a column's decimals (rules (b)/(c) need two), but rule (a) needs none."""
    text = (FORMATS / "xsens.txt").read_text()
    lines = text.split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("11\t"))
    cut = "\n".join(lines[:k] + [lines[k][:lines[k].rindex(".") + 1]])
    assert cut.endswith("\t0.")
    p = _write(tmp_path / "xsens.txt", cut)
    _where(_err(p), p, k + 1, "column Quat_z", "'0.'", "cut short")
    with pytest.raises(MocapFormatError, match="cut short"):
        list(iter_samples(io.StringIO(cut), "<s>"))
    # the same row complete but without a line end is read as written, without a word
    whole = "\n".join(lines[:k + 1])
    sig = read_imu_file(_write(tmp_path / "whole.txt", whole))
    assert len(next(iter(sig.values())).times) == 2
