"""Issue 10 for the marker and table readers: strict numbers, header claims checked against the file,
files cut short, non-UTF-8 bytes, pipes and devices (QTM TSV, C3D, TRC, MOT/STO, Vicon CSV, the wide
marker CSV, MVNX, label files).

Memory of the worst cases is measured (tracemalloc for the Python readers, the child's peak RSS for
ezc3d) and bounded generously; time is printed, never asserted.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import threading
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.errors import MocapFormatError, MocapWarning
from mocapkit.io.loaders import kind_of
from mocapkit.io.markers.c3d import check_c3d_structure, read_c3d, write_c3d
from mocapkit.io.markers.opensim import read_opensim_signals, read_table, read_trc
from mocapkit.io.markers.qtm import read_qtm_tsv
from mocapkit.io.markers.vicon_csv import read_vicon_csv
from mocapkit.io.markers.wide_csv import read_markers_csv, write_markers_csv
from mocapkit.io.skeletal.labels import read_frame_labels, read_haca_labels
from mocapkit.io.skeletal.mvnx import read_mvnx
from mocapkit.io.text import input as textinput
from mocapkit.markers import Markers

DATA = Path(__file__).resolve().parent / "data"
TSV = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"
VICON = DATA / "markers" / "vicon-nexus-walking2-excerpt.csv"
TRC = DATA / "opensim" / "walk_free_01-first20.trc"
TRC_NAN = DATA / "opensim" / "std_walking2_markers-frames36-51.trc"
MOT = DATA / "opensim" / "subject01_walk1_ik-first20.mot"
STO = DATA / "opensim" / "myComplexTasksTrial_orientations.sto"
MVNX = DATA / "mvnx" / "86_01_xsens_60hz.mvnx"
MB = 1024 * 1024
ALL_TEXT_EXCERPTS = [TSV, VICON, TRC, TRC_NAN, MOT, STO, MVNX]


def _peak(fn, *args, **kw):
    """``(result or exception, peak traced bytes, seconds)`` of a call (time is reported, not tested)."""
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        out = fn(*args, **kw)
    except Exception as exc:  # noqa: BLE001 - returned to the caller, which asserts its type
        out = exc
    dt = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"{getattr(fn, '__name__', fn)}: peak {peak / MB:.1f} MB, {dt * 1000:.0f} ms")
    return out, peak, dt


def _read_any(path: Path):
    s = path.suffix.lower()
    if s == ".tsv":
        return read_qtm_tsv(path)
    if s == ".trc":
        return read_trc(path)
    if s in (".mot", ".sto"):
        return read_opensim_signals(path)
    if s == ".mvnx":
        return read_mvnx(path)
    if s == ".csv":
        return read_vicon_csv(path) if path.read_bytes().startswith(b"Trajectories") or b"Devices" in \
            path.read_bytes()[:20] else read_markers_csv(path)
    raise AssertionError(path)


def _assert_sane(result) -> None:
    """No non-finite value except the documented gaps (NaN marker positions), nothing beyond 1e12."""
    if isinstance(result, Markers):
        assert np.isfinite(result.times).all()
        p = result.positions
        assert not np.isinf(p).any()
        assert np.all(np.abs(p[~np.isnan(p)]) <= 1e12)
        if result.analog is not None:
            assert np.isfinite(result.analog["values"]).all() or result.meta.get("format") == "vicon-csv"
    elif isinstance(result, dict):
        for sig in result.values():
            assert np.isfinite(sig.times).all() and np.isfinite(sig.values).all()
            assert np.all(np.abs(sig.values) <= 1e12)
    else:  # Motion
        assert np.isfinite(result.times).all()
        assert np.isfinite(result.rotations).all() and np.isfinite(result.translations).all()
        assert np.isfinite(result.skeleton.offsets).all()


def _error(fn, *args, **kw) -> MocapFormatError:
    with pytest.raises(MocapFormatError) as info:
        fn(*args, **kw)
    return info.value


def _lines(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").split("\n")


def _write(tmp_path: Path, name: str, lines_or_text, newline: bool = True) -> Path:
    f = tmp_path / name
    text = lines_or_text if isinstance(lines_or_text, str) else "\n".join(lines_or_text)
    f.write_bytes(text.encode("utf-8"))
    return f


def _tsv_lines(n_rows: int = 20) -> list[str]:
    lines = [ln for ln in _lines(TSV) if ln]
    out = [f"NO_OF_FRAMES\t{n_rows}" if ln.startswith("NO_OF_FRAMES") else ln for ln in lines[:12 + n_rows]]
    return out


def _replace_cell(line: str, k: int, value: str, sep: str = "\t") -> str:
    cells = line.split(sep)
    cells[k] = value
    return sep.join(cells)


# ==================================================================================================
# QTM TSV
# ==================================================================================================

BAD_NUMBERS = [("nan", "not a number"), ("inf", "not a number"), ("-Infinity", "not a number"),
               ("0_5", "not a number"), ("1e308", "out of range"), ("-2e12", "out of range"),
               ("1e999", "out of range"), ("0x10", "not a number"), ("١٢", "not a number")]


@pytest.mark.parametrize(("token", "problem"), BAD_NUMBERS)
def test_tsv_bad_number_names_line_and_marker_axis(tmp_path, token, problem):
    lines = _tsv_lines()
    lines[15] = _replace_cell(lines[15], 3, token)  # data row 4, base_1 Y
    e = _error(read_qtm_tsv, _write(tmp_path, "x.tsv", lines + [""]))
    assert e.path.endswith("x.tsv") and e.line == 16
    assert "base_1 Y" in e.problem and problem in e.problem, e


def test_tsv_missing_conventions(tmp_path):
    lines = _tsv_lines()
    lines[14] = _replace_cell(_replace_cell(_replace_cell(lines[14], 2, ""), 3, ""), 4, "")  # empty triple
    lines[16] = _replace_cell(_replace_cell(_replace_cell(lines[16], 5, "0.000"), 6, "0.000"), 7, "0.000")
    m = read_qtm_tsv(_write(tmp_path, "x.tsv", lines + [""]))
    assert m.missing[2, 0] and m.missing[4, 1]
    ref = read_qtm_tsv(_write(tmp_path, "ref.tsv", _tsv_lines() + [""]))
    keep = ~m.missing
    np.testing.assert_array_equal(m.positions[keep], ref.positions[keep])
    assert m.missing.sum() == ref.missing.sum() + 2
    # one empty coordinate is not a gap
    lines = _tsv_lines()
    lines[14] = _replace_cell(lines[14], 4, "")
    e = _error(read_qtm_tsv, _write(tmp_path, "y.tsv", lines + [""]))
    assert e.line == 15 and "base_1 Z" in e.problem and "empty" in e.problem


@pytest.mark.parametrize("key", ["NO_OF_MARKERS", "NO_OF_FRAMES", "NO_OF_CAMERAS", "NO_OF_ANALOG"])
def test_tsv_huge_header_counts_fail_or_read_with_small_memory(tmp_path, key):
    lines = [ln for ln in _lines(TSV) if ln]
    lines = [f"{key}\t1000000000" if ln.startswith(key + "\t") else ln for ln in lines]
    f = _write(tmp_path, "big.tsv", lines + [""])
    assert f.stat().st_size < 110_000
    out, peak, _ = _peak(read_qtm_tsv, f)
    assert peak < 200 * MB
    if key in ("NO_OF_MARKERS", "NO_OF_FRAMES"):
        assert isinstance(out, MocapFormatError) and key in out.problem, out
        assert out.line == [ln.split("\t")[0] for ln in lines].index(key) + 1
    else:
        assert isinstance(out, Markers) and out.meta["qtm"][key] == 1000000000
    out, peak, _ = _peak(read_qtm_tsv, f, strict=False)
    assert peak < 200 * MB
    if key == "NO_OF_FRAMES":
        assert out.meta["frame_count_mismatch"]["declared"] == 1000000000


def test_tsv_header_count_with_thousands_of_digits(tmp_path):
    lines = [ln for ln in _lines(TSV) if ln]
    lines[2] = "NO_OF_MARKERS\t" + "9" * 5000
    e = _error(read_qtm_tsv, _write(tmp_path, "x.tsv", lines + [""]))
    assert e.line == 3 and "NO_OF_MARKERS" in e.problem
    lines[2] = "NO_OF_MARKERS\t24"
    lines[3] = "FREQUENCY\t1e-320"
    e = _error(read_qtm_tsv, _write(tmp_path, "y.tsv", lines + [""]))
    assert e.line == 4 and "FREQUENCY" in e.problem


def test_tsv_cut_short_last_number_is_an_error(tmp_path):
    text = "\n".join(_tsv_lines()) + "\n"
    last = text.rstrip("\n")
    # cut inside the last value: '-655.899' style numbers with 3 decimals
    for cut in (1, 2, 3):
        body = last[:-cut]
        if body.endswith("\t") or body.endswith("."):
            continue
        e = _error(read_qtm_tsv, _write(tmp_path, "cut.tsv", body))
        assert e.line == 32 and "cut short" in e.problem and re.search(r"unnamed|marker|Z", e.problem), e
    # a whole number at the end without a newline is fine and equals the full read
    a = read_qtm_tsv(_write(tmp_path, "a.tsv", last))
    b = read_qtm_tsv(_write(tmp_path, "b.tsv", text))
    np.testing.assert_array_equal(a.positions, b.positions)
    # cut after a tab: too few fields on the final line
    body = last[: last.rindex("\t")]
    e = _error(read_qtm_tsv, _write(tmp_path, "c.tsv", body))
    assert e.line == 32 and "cut short" in e.problem


def test_tsv_latin1_and_nul(tmp_path):
    raw = TSV.read_bytes().replace(b"base_1", b"b\xe9se_1")
    f = tmp_path / "latin.tsv"
    f.write_bytes(raw)
    m = read_qtm_tsv(f)
    assert m.labels[0] == "b\u00e9se_1" and m.meta["encoding"] == "latin-1"
    f.write_bytes(TSV.read_bytes().replace(b"228.117", b"228\x00117", 1))
    e = _error(read_qtm_tsv, f)
    assert e.line == 13 and "NUL" in e.problem


def _fifo_feed(path: Path, payload: bytes, repeat: bool) -> threading.Thread:
    def run():
        try:
            with open(path, "wb") as fh:
                while True:
                    fh.write(payload)
                    if not repeat:
                        break
        except (BrokenPipeError, OSError):
            pass

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this platform")
def test_fifo_inputs_read_once_in_bounded_chunks(tmp_path, monkeypatch):
    fifo = tmp_path / "pipe.tsv"
    os.mkfifo(fifo)
    assert kind_of(fifo) == "markers"
    t = _fifo_feed(fifo, TSV.read_bytes(), repeat=False)
    m = read_qtm_tsv(fifo)
    t.join(5)
    ref = read_qtm_tsv(TSV)
    np.testing.assert_array_equal(np.nan_to_num(m.positions, nan=-1), np.nan_to_num(ref.positions, nan=-1))
    # endless zeros: a NUL byte in the first chunk
    t = _fifo_feed(fifo, bytes(1 << 16), repeat=True)
    out, peak, _ = _peak(read_qtm_tsv, fifo)
    assert isinstance(out, MocapFormatError) and "NUL" in out.problem and peak < 50 * MB
    t.join(5)
    # endless text: refused at the cap (lowered here to keep the test small)
    monkeypatch.setattr(textinput, "MAX_STREAM_BYTES", 4 * MB)
    t = _fifo_feed(fifo, b"1\t0.1\t2\t3\t4\n" * 4096, repeat=True)
    e = _error(read_qtm_tsv, fifo)
    assert "pipe or device" in e.problem
    t.join(5)
    # an OpenSim table from a pipe is read once and dispatched on its header
    sto = tmp_path / "pipe.sto"
    os.mkfifo(sto)
    assert kind_of(sto) == "table"
    t = _fifo_feed(sto, STO.read_bytes(), repeat=False)
    sigs = read_opensim_signals(sto)
    t.join(5)
    assert set(sigs) == set(read_opensim_signals(STO))


def test_dev_zero_fails_fast_for_every_reader():
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    for fn in (read_qtm_tsv, read_trc, read_table, read_vicon_csv, read_markers_csv, read_c3d, read_mvnx,
               lambda p: read_haca_labels(p)):
        out, peak, _ = _peak(fn, "/dev/zero")
        assert isinstance(out, MocapFormatError), (fn, out)
        assert out.path == "/dev/zero" and peak < 50 * MB


def test_cli_info_on_zero_fifo_is_one_line_error(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes")
    fifo = tmp_path / "z.tsv"
    os.mkfifo(fifo)
    feeder = subprocess.Popen(["sh", "-c", f"cat /dev/zero > '{fifo}'"], stderr=subprocess.DEVNULL)
    try:
        r = subprocess.run([sys.executable, "-m", "mocapkit", "info", str(fifo)], capture_output=True,
                           text=True, timeout=60)
    finally:
        feeder.kill()
        feeder.wait()
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("error: ") and "NUL" in r.stderr and r.stderr.count("\n") == 1, r.stderr


# ==================================================================================================
# TRC
# ==================================================================================================


@pytest.mark.parametrize(("token", "problem"), BAD_NUMBERS)
def test_trc_bad_number_names_line_and_marker_axis(tmp_path, token, problem):
    lines = _lines(TRC)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("188\t"))
    lines[k] = _replace_cell(lines[k], 3, token)  # R.ASIS Y
    if token == "nan":  # NaN is the TRC gap spelling (OpenSim writes it)
        m = read_trc(_write(tmp_path, "g.trc", lines))
        assert m.missing[k - 6, 0] and m.missing.sum() == 1  # line 6 is blank
        return
    e = _error(read_trc, _write(tmp_path, "x.trc", lines))
    assert e.line == k + 1 and "R.ASIS Y" in e.problem and problem in e.problem, e


def test_trc_gaps_are_empty_or_nan_cells(tmp_path):
    m = read_trc(TRC_NAN)
    lines = _lines(TRC_NAN)
    nan_cells = sum(ln.split("\t").count("NaN") for ln in lines[5:])
    assert nan_cells > 0 and np.isnan(m.positions).sum() >= nan_cells
    _assert_sane(m)


def test_trc_header_claims(tmp_path):
    lines = _lines(TRC)
    vals = lines[2].split("\t")
    vals[2] = "1000000000"   # NumFrames
    vals[3] = "1000000000"   # NumMarkers
    out, peak, _ = _peak(read_trc, _write(tmp_path, "x.trc", lines[:2] + ["\t".join(vals)] + lines[3:]))
    assert isinstance(out, Markers) and peak < 200 * MB
    assert any("NumFrames is 1000000000" in w for w in out.meta["warnings"])
    vals[2] = "9" * 5000
    e = _error(read_trc, _write(tmp_path, "y.trc", lines[:2] + ["\t".join(vals)] + lines[3:]))
    assert e.line == 3 and "NumFrames" in e.problem
    vals[2], vals[0] = "20", "1e-320"
    e = _error(read_trc, _write(tmp_path, "z.trc", lines[:2] + ["\t".join(vals)] + lines[3:]))
    assert e.line == 3 and "DataRate" in e.problem
    vals[0] = "6_0"
    e = _error(read_trc, _write(tmp_path, "w.trc", lines[:2] + ["\t".join(vals)] + lines[3:]))
    assert e.line == 3 and "DataRate" in e.problem and "not a number" in e.problem


def test_trc_short_rows_cannot_blow_up_memory(tmp_path):
    names = "\t".join(f"M{k}\t\t" for k in range(30_000))
    coords = "\t".join(f"X{k}\tY{k}\tZ{k}" for k in range(1, 30_001))
    rows = [f"{i}\t{i / 60:.5f}" for i in range(1, 60_001)]
    head = ["PathFileType\t4\t(X/Y/Z)\tx.trc", "DataRate\tNumFrames\tNumMarkers\tUnits",
            "60\t60000\t100000\tmm", "Frame#\tTime\t" + names, "\t\t" + coords, ""]
    f = _write(tmp_path, "short.trc", head + rows + [""])
    out, peak, _ = _peak(read_trc, f)
    assert isinstance(out, MocapFormatError) and "values" in out.problem and out.line == 4, out
    assert peak < 200 * MB
    # a header line beyond 1 MiB is refused as such
    f = _write(tmp_path, "long.trc", head[:4] + ["\t\t" + coords + "\tX" * 400_000] + rows[:3] + [""])
    e = _error(read_trc, f)
    assert e.line == 5 and "header line" in e.problem


def test_trc_cut_short(tmp_path):
    text = TRC.read_text()
    last = text.rstrip("\n")
    e = _error(read_trc, _write(tmp_path, "a.trc", last[:-3]))
    assert e.line == len(last.split("\n")) and "cut short" in e.problem, e
    body = last.rstrip("\t")  # the rows end with a tab
    e = _error(read_trc, _write(tmp_path, "b.trc", body[: body.rindex("\t")]))
    assert "cut short" in e.problem
    a, b = read_trc(_write(tmp_path, "c.trc", last)), read_trc(TRC)
    np.testing.assert_array_equal(np.nan_to_num(a.positions, nan=7), np.nan_to_num(b.positions, nan=7))


# ==================================================================================================
# MOT / STO
# ==================================================================================================


@pytest.mark.parametrize(("token", "problem"), BAD_NUMBERS)
def test_mot_bad_number_names_line_and_column(tmp_path, token, problem):
    lines = _lines(MOT)
    h = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
    col = lines[h + 1].split("\t")[3].strip()
    lines[h + 4] = _replace_cell(lines[h + 4], 3, token)
    e = _error(read_table, _write(tmp_path, "x.mot", lines))
    assert e.line == h + 5 and col in e.problem, e
    assert problem in e.problem or "empty or NaN" in e.problem


def test_mot_header_counts_and_rate(tmp_path):
    lines = _lines(MOT)
    lines = [("nRows=1000000000" if ln.startswith("nRows") else
              "nColumns=" + "9" * 5000 if ln.startswith("nColumns") else ln) for ln in lines]
    lines.insert(1, "DataRate=0_5")
    out, peak, _ = _peak(read_table, _write(tmp_path, "x.mot", lines))
    assert peak < 200 * MB and not isinstance(out, Exception), out
    assert out.meta["rate"] is None
    assert any("nRows is 1000000000" in w for w in out.meta["warnings"])
    assert any("nColumns" in w and "not a count" in w for w in out.meta["warnings"])


def test_sto_quaternion_component_out_of_range(tmp_path):
    lines = _lines(STO)
    h = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
    cells = lines[h + 3].split("\t")
    q = cells[1].split(",")
    q[2] = "1e308"
    cells[1] = ",".join(q)
    lines[h + 3] = "\t".join(cells)
    e = _error(read_opensim_signals, _write(tmp_path, "x.sto", lines))
    assert e.line == h + 4 and "column 2" in e.problem and " y:" in e.problem and "out of range" in e.problem


def test_mot_cut_short(tmp_path):
    last = MOT.read_text().rstrip("\n")
    e = _error(read_table, _write(tmp_path, "a.mot", last[:-2]))
    assert "cut short" in e.problem and e.line == len(last.split("\n")), e
    e = _error(read_table, _write(tmp_path, "b.mot", last[: last.rindex("\t")]))
    assert "cut short" in e.problem


# ==================================================================================================
# Vicon CSV and the wide CSV
# ==================================================================================================


@pytest.mark.parametrize(("token", "problem"), BAD_NUMBERS)
def test_vicon_bad_number_names_line_and_marker(tmp_path, token, problem):
    lines = _lines(VICON)
    k = len(lines) - 3
    lines[k] = _replace_cell(lines[k], 3, token, ",")
    e = _error(read_vicon_csv, _write(tmp_path, "x.csv", lines))
    assert e.line == k + 1 and "column 4" in e.problem and problem in e.problem, e


def test_vicon_cut_short(tmp_path):
    last = VICON.read_bytes().decode().rstrip("\r\n")  # CRLF file
    e = _error(read_vicon_csv, _write(tmp_path, "a.csv", last[: last.rindex(",") - 2]))
    assert "cut short" in e.problem and e.line == len(last.split("\n")), e
    # Nexus writes 6 significant digits: the decimals vary and a cut inside the last value cannot be
    # told; with a fixed-decimal last column it is
    lines = last.split("\r\n")
    fixed = [ln if not re.match(r"\d+,0,", ln) else
             ln.rsplit(",", 1)[0] + "," + f"{float(ln.rsplit(',', 1)[1]):.3f}" for ln in lines]
    e = _error(read_vicon_csv, _write(tmp_path, "f.csv", "\n".join(fixed)[:-2]))
    assert "cut short" in e.problem and "column 14" in e.problem, e
    with pytest.warns(MocapWarning, match="line 119, the last of the file, has no newline"):
        a = read_vicon_csv(_write(tmp_path, "b.csv", last))  # complete, but Nexus's %g cannot show it
    assert any("may be cut short" in w for w in a.meta["warnings"])
    b = read_vicon_csv(VICON)
    np.testing.assert_array_equal(np.nan_to_num(a.positions, nan=7), np.nan_to_num(b.positions, nan=7))


def test_wide_csv_strict_numbers_and_cut(tmp_path):
    m = read_trc(TRC)
    f = tmp_path / "w.csv"
    write_markers_csv(m, f)
    back = read_markers_csv(f, rate=m.rate)
    np.testing.assert_array_equal(np.nan_to_num(back.positions, nan=7), np.nan_to_num(m.positions, nan=7))
    lines = f.read_text().split("\n")
    for token, problem in BAD_NUMBERS:
        bad = list(lines)
        bad[3] = _replace_cell(bad[3], 2, token, ",")
        if token == "nan":  # the wide CSV's gap (write_markers_csv writes it)
            assert read_markers_csv(_write(tmp_path, "gap.csv", bad)).missing[2, 0]
            continue
        e = _error(read_markers_csv, _write(tmp_path, "bad.csv", bad))
        assert e.line == 4 and "column 3" in e.problem and problem in e.problem, (token, e)
    big = ["time,a_x,a_y,a_z"] + ["1"] * 50_000
    out, peak, _ = _peak(read_markers_csv, _write(tmp_path, "few.csv", "time," + ",".join(
        f"m{k}_{a}" for k in range(100_000) for a in "xyz") + "\n" + "\n".join(big[1:]) + "\n"))
    assert isinstance(out, MocapFormatError) and peak < 200 * MB


# ==================================================================================================
# C3D
# ==================================================================================================


def _c3d(tmp_path: Path, name: str = "m.c3d") -> tuple[Path, Markers]:
    t = np.arange(10) / 100.0
    p = np.arange(10 * 3 * 3, dtype=float).reshape(10, 3, 3) + 1.0
    p[4, 1] = np.nan
    m = Markers(t, p, ("A", "B", "C"), 100.0)
    f = tmp_path / name
    write_c3d(m, f)
    return f, m


def _patch_point(f: Path, frame: int, marker: int, axis: int, value: float) -> None:
    data = bytearray(f.read_bytes())
    lay = check_c3d_structure(bytes(data))
    assert lay.is_float and lay.n_analog == 0
    pos = 512 * (lay.data_start - 1) + frame * lay.n_points * 16 + marker * 16 + axis * 4
    data[pos:pos + 4] = np.float32(value).tobytes()
    f.write_bytes(bytes(data))


@pytest.mark.parametrize(("value", "problem"), [(np.inf, "not finite"), (-np.inf, "not finite"),
                                                (3e38, "out of range"), (-2e12, "out of range")])
def test_c3d_inf_and_huge_name_frame_marker_axis(tmp_path, value, problem):
    f, _ = _c3d(tmp_path)
    _patch_point(f, 6, 2, 1, value)
    e = _error(read_c3d, f)
    assert e.path == str(f) and "frame 7" in e.problem and "marker C Y" in e.problem and problem in e.problem, e


def test_c3d_unflagged_nan_is_a_documented_gap(tmp_path):
    f, m = _c3d(tmp_path)
    _patch_point(f, 2, 0, 0, np.nan)
    r = read_c3d(f)
    assert r.missing[2, 0] and r.missing[4, 1] and r.missing.sum() == 2
    assert any("without the C3D missing flag" in w for w in r.meta["warnings"])
    keep = ~r.missing
    np.testing.assert_allclose(r.positions[keep], m.positions[keep].astype(np.float32))


def _c3d_param_value_offset(data: bytes, group: str, name: str) -> int:
    lay = check_c3d_structure(data)
    prm = lay.groups[group][name]
    nlen = len(prm.name.encode("latin-1"))
    return prm.offset + 2 + nlen + 2 + 2 + len(prm.dims)


_RSS = """
import resource, sys
from mocapkit.errors import MocapFormatError
from mocapkit.io.markers.c3d import read_c3d
try:
    read_c3d(sys.argv[1]); print("read")
except MocapFormatError as e:
    print("error", e)
# the peak of this process image (VmHWM); ru_maxrss would also count the pytest process this child
# was forked from (Linux keeps the larger peak across exec)
try:
    print(next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")))
except OSError:
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


@pytest.mark.parametrize(("param", "value"), [("USED", 32767), ("FRAMES", 65535)])
def test_c3d_huge_counts_small_memory(tmp_path, param, value):
    f, _ = _c3d(tmp_path)
    data = bytearray(f.read_bytes())
    k = _c3d_param_value_offset(bytes(data), "POINT", param)
    data[k:k + 2] = int(value).to_bytes(2, "little")
    if param == "USED":
        data[2:4] = int(value).to_bytes(2, "little")  # the header agrees
    f.write_bytes(bytes(data))
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", _RSS, str(f)], capture_output=True, text=True, timeout=120)
    print(f"{param}={value}: {time.perf_counter() - t0:.2f} s, {r.stdout.strip()}")
    assert r.returncode == 0, r.stderr
    out = r.stdout.strip().split("\n")
    assert out[0].startswith(("read", "error"))
    assert int(out[-1]) < 600 * 1024  # KiB: interpreter + numpy + ezc3d + the data, far below a real blow-up


# ==================================================================================================
# MVNX
# ==================================================================================================


def _mvnx_text() -> str:
    return MVNX.read_text(encoding="utf-8")


@pytest.mark.parametrize(("token", "problem"), [("1e308", "out of range"), ("0_5", "not a number"),
                                                ("inf", "NaN or infinite"), ("-1e999", "NaN or infinite")])
def test_mvnx_bad_number_names_segment_component(tmp_path, token, problem):
    text = _mvnx_text()
    i = text.index("<orientation>", text.index('type="normal"')) + len("<orientation>")
    rest = text[i:].split(" ", 1)
    bad = text[:i] + token + " " + rest[1]
    line = text[:i].count("\n") + 1
    e = _error(read_mvnx, _write(tmp_path, "x.mvnx", bad))
    if token == "-1e999":  # the grammar accepts it; the size does not
        assert "out of range" in e.problem or "infinite" in e.problem
    else:
        assert problem in e.problem
    assert e.line == line and "segment 'Pelvis' q0" in e.problem, e


def test_mvnx_attributes(tmp_path):
    text = _mvnx_text()
    for old, new, what in ((' frameRate="60"', ' frameRate="1e-320"', "frameRate"),
                           (' frameRate="60"', ' frameRate="6_0"', "frameRate"),
                           ('index="0"', 'index="1_0"', "index")):
        assert old in text
        e = _error(read_mvnx, _write(tmp_path, "x.mvnx", text.replace(old, new, 1)))
        assert what in e.problem and e.line is not None, e
    out, peak, _ = _peak(read_mvnx, _write(tmp_path, "y.mvnx", text.replace('segmentCount="23"',
                                                                            'segmentCount="1000000000"')))
    assert peak < 200 * MB and not isinstance(out, Exception)


def test_mvnx_endless_pipe_is_refused(tmp_path, monkeypatch):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes")
    fifo = tmp_path / "p.mvnx"
    os.mkfifo(fifo)
    monkeypatch.setattr(textinput, "MAX_STREAM_BYTES", 2 * MB)
    text = _mvnx_text()
    head = text[: text.index("</frames>")].encode()
    frame = text[text.index('<frame time="'): text.index("</frame>", text.index('<frame time="')) + 8].encode()

    def run():
        try:
            with open(fifo, "wb") as fh:
                fh.write(head)
                while True:
                    fh.write(frame)
        except OSError:
            pass

    t = threading.Thread(target=run, daemon=True)
    t.start()
    e = _error(read_mvnx, fifo)
    assert "pipe or device" in e.problem
    t.join(5)


# ==================================================================================================
# label files
# ==================================================================================================


def test_label_integers_are_strict(tmp_path):
    f = _write(tmp_path, "l.txt", "86 01\nwalk 1 1_0 20\nrun 30 40 50\n")
    e = _error(read_haca_labels, f)
    assert e.line == 2 and "1_0" in e.problem
    f = _write(tmp_path, "m.txt", "1 1 2 " + "9" * 25 + "\n")
    e = _error(read_frame_labels, f, n_frames=48)
    assert e.line == 1 and "integer" in e.problem
    f.write_bytes(b"1 1 2 \xff 2\n")
    e = _error(read_frame_labels, f, n_frames=60)
    assert e.line == 1


# ==================================================================================================
# hypothesis: mutated excerpts
# ==================================================================================================

_TOKENS = ["nan", "NaN", "inf", "-inf", "1e308", "-1e308", "0_5", "1e999", "", "1000000000", "9" * 30, "\x00",
           "\xe9", "0", "-0", "1e-320"]


def _mutate(text: str, ops) -> str:
    for kind, where, tok in ops:
        if kind == "number":  # replace the number around a position by a token
            i = int(where * len(text))
            m = next(re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?", text[max(0, i - 40): i + 40]), None)
            if m is not None:
                a, b = max(0, i - 40) + m.start(), max(0, i - 40) + m.end()
                text = text[:a] + tok + text[b:]
        elif kind == "header":  # a huge count in a header field
            text = re.sub(r"(NO_OF_\w+\t|NumFrames\t[^\n]*\n[^\n]*|nRows=|nColumns=|segmentCount=\")\d+",
                          lambda mm: mm.group(1) + tok if tok.isdigit() else mm.group(0), text, count=1)
        elif kind == "insert":
            i = int(where * len(text))
            text = text[:i] + tok + text[i:]
        else:  # truncate at a byte
            text = text[: int(where * len(text))]
    return text


_mop = st.tuples(st.sampled_from(["number", "number", "header", "insert", "truncate"]),
                 st.floats(0, 1, exclude_max=True), st.sampled_from(_TOKENS))


def _only_format_errors(path: Path) -> object:
    try:
        out = _read_any(path)
    except MocapFormatError as exc:
        assert exc.problem and str(exc.path) == str(path)
        return None
    _assert_sane(out)
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(which=st.sampled_from(ALL_TEXT_EXCERPTS), ops=st.lists(_mop, min_size=1, max_size=4))
def test_fuzz_mutated_excerpts_raise_only_format_errors(tmp_path, which, ops):
    text = which.read_text(encoding="utf-8")
    bad = _mutate(text, ops)
    f = tmp_path / ("fuzz" + which.suffix)
    f.write_bytes(bad.encode("utf-8", "surrogatepass"))
    tracemalloc.start()
    try:
        _only_format_errors(f)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 200 * MB


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(which=st.sampled_from([TSV, VICON, TRC, TRC_NAN, MOT]), where=st.floats(0.3, 1, exclude_max=True))
def test_fuzz_truncated_file_is_an_error_or_a_true_prefix(tmp_path, which, where):
    """Cut at a random byte: either an error, or every row read equals the full file's row."""
    raw = which.read_bytes()
    f = tmp_path / ("cut" + which.suffix)
    f.write_bytes(raw[: int(where * len(raw))])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if which.suffix == ".tsv":
            try:
                got = read_qtm_tsv(f, strict=False)
            except MocapFormatError:
                return
            full = read_qtm_tsv(which)
        else:
            got = _only_format_errors(f)
            if got is None:
                return
            full = _read_any(which)
    if any(issubclass(w.category, MocapWarning) and "cut short" in str(w.message) for w in caught):
        return  # reported: the last value may be cut (a %g or repr column cannot show it)
    if isinstance(got, dict):
        (g,), (w,) = got.values(), full.values()
        n = len(g.times)
        np.testing.assert_array_equal(g.values, w.values[:n])
        np.testing.assert_array_equal(g.times, w.times[:n])
    else:
        n = got.n_frames
        np.testing.assert_array_equal(np.nan_to_num(got.positions, nan=7.5),
                                      np.nan_to_num(full.positions[:n], nan=7.5))
        np.testing.assert_array_equal(got.times, full.times[:n])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_c3d_float_words(tmp_path, data):
    """Any float32 word in the point data: a gap, a value read as written, or an error naming the frame."""
    f, _ = _c3d(tmp_path, "fz.c3d")
    bits = data.draw(st.integers(0, 2**32 - 1))
    frame, marker, axis = data.draw(st.integers(0, 9)), data.draw(st.integers(0, 2)), data.draw(st.integers(0, 2))
    value = np.frombuffer(np.uint32(bits).tobytes(), dtype=np.float32)[0]
    _patch_point(f, frame, marker, axis, value)
    try:
        r = read_c3d(f)
    except MocapFormatError as e:
        assert not (np.isfinite(value) and abs(float(value)) <= 1e12) and f"frame {frame + 1}," in e.problem
        return
    _assert_sane(r)
    if np.isfinite(value) and not (frame == 4 and marker == 1):
        assert r.positions[frame, marker, axis] == float(value)
    elif np.isnan(value):
        assert r.missing[frame, marker]


def test_everything_measured_is_finite_on_the_excerpts():
    for p in ALL_TEXT_EXCERPTS:
        _assert_sane(_read_any(p))
    assert math.isfinite(read_qtm_tsv(TSV).rate)
