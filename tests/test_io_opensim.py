"""OpenSim TRC and MOT/STO files: read the real layouts and quirks, write -> read round trips, CLI."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.loaders import kind_of, load_markers
from mocapkit.io.markers.opensim import (
    read_opensim_signals,
    read_orientations,
    read_table,
    read_trc,
    write_orientations,
    write_table,
    write_table_csv,
    write_trc,
)
from mocapkit.io.markers.wide_csv import write_markers_csv
from mocapkit.markers import Markers
from mocapkit.motion import Signal

DATA = Path(__file__).resolve().parent / "data" / "opensim"
WALK_FREE = DATA / "walk_free_01-first20.trc"
STD_WALK = DATA / "std_walking2_markers-frames36-51.trc"
IK = DATA / "subject01_walk1_ik-first20.mot"
ORIENT = DATA / "myComplexTasksTrial_orientations.sto"
EXE = [sys.executable, "-m", "mocapkit"]


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([*EXE, *map(str, args)], capture_output=True, text=True, timeout=300)


def _trc_reference(path: Path, n_markers: int) -> np.ndarray:
    """Independent parse: numpy.genfromtxt on the data rows (empty cells and NaN -> nan)."""
    rows = np.genfromtxt(path, delimiter="\t", skip_header=6)
    return rows[:, : 2 + 3 * n_markers]


# ==================================================================================================
# TRC
# ==================================================================================================


def test_trc_excerpt_numframes_quirk_is_a_warning():
    m = read_trc(WALK_FREE)
    ref = _trc_reference(WALK_FREE, 41)
    assert m.n_frames == 20 and m.n_markers == 41 and m.rate == 60.0 and m.units == "mm"
    assert m.labels[:3] == ("R.ASIS", "L.ASIS", "V.Sacral")
    np.testing.assert_array_equal(m.times, ref[:, 1])
    np.testing.assert_array_equal(m.positions.reshape(20, -1), ref[:, 2:])
    assert m.meta["warnings"] == ["NumFrames is 900 but the file has 20 data rows (lines 7-26); the rows are read"]
    assert m.meta["first_frame"] == 185 and load_markers(WALK_FREE).n_frames == 20


def test_trc_excerpt_with_odd_label_spacing_nan_and_rate_quirk():
    m = read_trc(STD_WALK)
    ref = _trc_reference(STD_WALK, 44)
    assert m.n_markers == 44 and m.labels[:2] == ("RTH1", "RFHD") and m.labels[-1] == "RKJC"
    np.testing.assert_array_equal(m.positions.reshape(16, -1), ref[:, 2:])
    assert m.missing.sum() == int(np.isnan(ref[:, 2::3]).sum()) == 154
    # DataRate says 250 Hz, the Time column steps by 0.04 s: the data's own times win, with a warning
    assert m.rate == 25.0 and m.meta["declared_rate"] == 250.0
    assert any("DataRate is 250 Hz" in w for w in m.meta["warnings"])


def _small_trc(rows: list[str], numframes: int = 3) -> str:
    head = ["PathFileType\t4\t(X/Y/Z)\tx.trc",
            "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
            f"100\t100\t{numframes}\t2\tm\t100\t1\t{numframes}",
            "Frame#\tTime\tA\t\t\tB\t\t",
            "\t\tX1\tY1\tZ1\tX2\tY2\tZ2",
            ""]
    return "\n".join(head + rows) + "\n"


def test_trc_gaps_short_rows_and_trailing_tabs(tmp_path):
    f = tmp_path / "g.trc"
    f.write_text(_small_trc(["1\t0\t1\t2\t3\t4\t5\t6\t", "2\t0.01\t\t\t\t4\t5\t6", "3\t0.02\t1\t2\t3"]))
    m = read_trc(f)
    assert m.units == "m" and m.labels == ("A", "B")
    assert m.missing.tolist() == [[False, False], [True, False], [False, True]]
    assert m.positions[0].tolist() == [[1, 2, 3], [4, 5, 6]]
    assert "1 rows have fewer cells than 8" in m.meta["warnings"][0]


@pytest.mark.parametrize(
    ("rows", "line", "message"),
    [
        (["1\t0\t1\t2\tx\t4\t5\t6"], 7, "column 5 (A Z): 'x' is not a number"),
        (["1\t0\t1\t2\t3\t4\t5\t6\t7"], 7, "expected 8 tab-separated cells"),
        (["1\t0.01\t1\t2\t3\t4\t5\t6", "2\t0.01\t1\t2\t3\t4\t5\t6"], 8, "not after the previous row"),
        (["1\t\t1\t2\t3\t4\t5\t6"], 7, "the time cell is empty"),
        (["1"], 7, "at least Frame# and Time"),
        ([], 5, "no data rows"),
    ],
)
def test_trc_rejections_name_the_line(tmp_path, rows, line, message):
    f = tmp_path / "bad.trc"
    f.write_text(_small_trc(rows))
    with pytest.raises(MocapFormatError) as info:
        read_trc(f)
    assert info.value.line == line and message in info.value.problem, info.value


def test_trc_header_rejections(tmp_path):
    f = tmp_path / "bad.trc"
    f.write_text("hello\n")
    with pytest.raises(MocapFormatError, match="not a TRC file"):
        read_trc(f)
    f.write_text(_small_trc(["1\t0\t1\t2\t3\t4\t5\t6"]).replace("\t\tX1\tY1\tZ1\tX2\tY2\tZ2", "\t\tX1\tY1"))
    with pytest.raises(MocapFormatError, match=r"bad.trc:5: expected 6 coordinate names"):
        read_trc(f)
    f.write_text(_small_trc(["1\t0\t1\t2\t3\t4\t5\t6"]).replace("100\t100\t3", "0\t100\t3"))
    with pytest.raises(MocapFormatError, match="DataRate must be > 0"):
        read_trc(f)


def test_trc_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    p = rng.normal(scale=800.0, size=(50, 5, 3))
    p[rng.random((50, 5)) < 0.2] = np.nan
    mk = Markers((7 + np.arange(50)) / 59.94, p, ("LASI", "R.ASI", "a b", "Sub:M", "x"), 59.94, units="cm")
    f = tmp_path / "w.trc"
    write_trc(mk, f, decimals=5)
    lines = f.read_text().split("\n")
    assert lines[0] == "PathFileType\t4\t(X/Y/Z)\tw.trc"
    assert lines[2].split("\t")[:6] == ["59.94", "59.94", "50", "5", "cm", "59.94"]
    assert lines[3].startswith("Frame#\tTime\tLASI\t\t\tR.ASI\t\t\ta b")
    assert lines[4] == "\t\t" + "\t".join(f"{a}{k}" for k in range(1, 6) for a in "XYZ")
    assert lines[6].split("\t")[0] == "8"
    back = read_trc(f)
    assert back.labels == mk.labels and back.units == "cm" and back.rate == 59.94
    assert back.meta["warnings"] == []
    np.testing.assert_array_equal(back.times, mk.times)  # times are written as repr
    np.testing.assert_array_equal(back.missing, mk.missing)
    np.testing.assert_allclose(back.positions, mk.positions, rtol=0, atol=0.5e-5 + 1e-12)
    np.testing.assert_array_equal(back.positions, np.round(mk.positions, 5))  # exactly the decimals


@pytest.mark.shared
@pytest.mark.parametrize(("name", "frames", "markers", "rate"),
                         [("walk_free_01.trc", 73, 41, 60.0), ("std_walking2_markers.trc", 126, 44, 25.0)])
def test_shared_trc_files(shared_data, name, frames, markers, rate):
    path = shared_data / "opensim" / name
    m = read_trc(path)
    ref = _trc_reference(path, markers)
    assert (m.n_frames, m.n_markers, m.rate) == (frames, markers, rate)
    np.testing.assert_array_equal(m.times, ref[:, 1])
    np.testing.assert_array_equal(m.positions.reshape(frames, -1), ref[:, 2:])


# ==================================================================================================
# MOT / STO
# ==================================================================================================


def test_mot_joint_angles_excerpt():
    s = read_table(IK)
    ref = np.genfromtxt(IK, delimiter="\t", skip_header=9)
    assert s.kind == "vector" and s.values.shape == (20, 23) and s.name == "Coordinates"
    assert s.meta["labels"][:3] == ("pelvis_tilt", "pelvis_list", "pelvis_rotation")
    assert s.meta["in_degrees"] is True and s.meta["units"] == "deg"  # from "Angles are in degrees."
    np.testing.assert_array_equal(s.times, ref[:, 0])
    np.testing.assert_array_equal(s.values, ref[:, 1:])
    assert s.meta["warnings"] == ["nRows is 211 but the file has 20 data rows; the rows are read"]
    assert kind_of(IK) == "table"


def test_sto_orientations_excerpt():
    sig = read_orientations(ORIENT)
    assert list(sig)[:2] == ["pelvis_imu", "tibia_r_imu"] and len(sig) == 7
    lines = ORIENT.read_text().split("\n")
    first = lines[6].split("\t")
    np.testing.assert_array_equal(sig["pelvis_imu"].values[0], [float(v) for v in first[1].split(",")])
    np.testing.assert_array_equal(sig["calcn_r_imu"].values[0], [float(v) for v in first[7].split(",")])
    s = sig["femur_r_imu"]
    assert s.kind == "quaternion" and len(s) == 6 and s.meta["rate"] == 100.0
    np.testing.assert_allclose(np.diff(s.times), 0.01, atol=1e-12)
    assert kind_of(ORIENT) == "imu"
    from mocapkit.io import load_signals  # registered for .sto through mocapkit.io.loaders

    assert list(load_signals(ORIENT)) == list(sig)
    with pytest.raises(MocapFormatError, match="DataType=Quaternion"):
        read_table(ORIENT)
    with pytest.raises(MocapFormatError, match="not an orientation file"):
        read_orientations(IK)


def test_table_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(5)
    s = Signal(np.arange(40) / 120.0, rng.normal(scale=30, size=(40, 3)), kind="vector", name="IK",
               meta={"labels": ("hip_flexion_r", "knee_angle_r", "pelvis_tx"), "in_degrees": False})
    for suffix in (".mot", ".sto"):
        f = tmp_path / f"t{suffix}"
        write_table(s, f)
        text = f.read_text().split("\n")
        assert text[:6] == ["IK", "version=1", "nRows=40", "nColumns=4", "inDegrees=no", "endheader"]
        back = read_table(f)
        np.testing.assert_array_equal(back.times, s.times)
        np.testing.assert_array_equal(back.values, s.values)  # repr: exact
        assert back.meta["labels"] == s.meta["labels"] and back.meta["in_degrees"] is False
        assert back.meta["warnings"] == [] and back.meta["format"] == suffix[1:]
    write_table(s, tmp_path / "r.mot", decimals=4, in_degrees=True)
    back = read_table(tmp_path / "r.mot")
    np.testing.assert_array_equal(back.values, np.round(s.values, 4))
    assert back.meta["in_degrees"] is True


def test_orientations_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(6)
    t = np.arange(25) / 100.0
    sigs = {n: Signal(t, rng.normal(size=(25, 4)), name=n) for n in ("pelvis_imu", "femur_r_imu")}
    f = tmp_path / "o.sto"
    write_orientations(sigs, f, rate=100.0)
    assert f.read_text().split("\n")[:4] == ["DataRate=100.000000", "DataType=Quaternion", "version=3", "endheader"]
    back = read_orientations(f)
    assert list(back) == list(sigs)
    for n in sigs:
        np.testing.assert_array_equal(back[n].values, sigs[n].values)
        np.testing.assert_array_equal(back[n].times, t)
    other = Signal(t + 1, rng.normal(size=(25, 4)))
    with pytest.raises(InvalidParameterError, match="share the first one's times"):
        write_orientations({"a": sigs["pelvis_imu"], "b": other}, tmp_path / "x.sto")


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("name\nversion=1\ntime\ta\n0\t1\n", 1, "no 'endheader'"),
        ("endheader\nt\ta\n0\t1\n", 2, "the first column must be 'time'"),
        ("endheader\ntime\ta\n0\t1\n1\t2\t3\n", 4, "expected 2 cells"),
        ("endheader\ntime\ta\n0\t1\n1\t\n", 4, "column 2 (a) is empty or NaN"),
        ("endheader\ntime\ta\n0\t1\n0\t2\n", 4, "not after the previous row"),
        ("DataType=Quaternion\nendheader\ntime\timu\n0\t1,0,0\n", 4, "expected 'w,x,y,z'"),
        ("endheader\ntime\ta\n", 2, "no data rows"),
    ],
)
def test_table_rejections_name_the_line(tmp_path, text, line, message):
    f = tmp_path / "bad.sto"
    f.write_text(text)
    with pytest.raises(MocapFormatError) as info:
        read_opensim_signals(f)
    assert info.value.line == line and message in info.value.problem, info.value


_op = st.tuples(st.sampled_from(["insert", "delete", "replace"]), st.floats(0, 1, exclude_max=True),
                st.sampled_from(list("\t\n,.-0123456789eEXYZ=") + ["", "NaN", "endheader"]))


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ops=st.lists(_op, min_size=1, max_size=5), which=st.sampled_from(["trc", "sto", "mot"]))
def test_fuzz_opensim_text_only_raises_mocap_format_error(ops, which):
    src = {"trc": WALK_FREE, "sto": ORIENT, "mot": IK}[which]
    text = "\n".join(src.read_text().split("\n")[:12]) + "\n"
    for kind, where, ch in ops:
        i = int(where * (len(text) + 1))
        text = {"insert": text[:i] + ch + text[i:], "delete": text[:i] + text[i + 1:],
                "replace": text[:i] + ch + text[i + 1:]}[kind]
    fd, name = tempfile.mkstemp(suffix="." + which)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        try:
            read_trc(name) if which == "trc" else read_opensim_signals(name)
        except MocapFormatError as exc:
            assert exc.path == name and exc.problem
    finally:
        os.unlink(name)


@pytest.mark.shared
def test_shared_mot_and_sto(shared_data):
    mot = shared_data / "opensim" / "subject01_walk1_ik.mot"
    s = read_table(mot)
    ref = np.genfromtxt(mot, delimiter="\t", skip_header=9)
    assert s.values.shape == (211, 23) and s.meta["warnings"] == []
    np.testing.assert_array_equal(s.values, ref[:, 1:])
    assert s.mean_rate == pytest.approx(60.0)
    sto = read_orientations(shared_data / "opensim" / "myComplexTasksTrial_orientations.sto")
    assert len(sto) == 7 and all(len(v) == 6 for v in sto.values())
    norms = np.linalg.norm(sto["pelvis_imu"].values, axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-6)


# ==================================================================================================
# CLI
# ==================================================================================================


def test_cli_convert_trc_c3d_trc_round_trip(tmp_path):
    c3d, trc = tmp_path / "w.c3d", tmp_path / "w.trc"
    r = run("convert", WALK_FREE, c3d)
    assert r.returncode == 0, r.stderr
    assert "NumFrames is 900" in r.stderr  # the reader's warning is shown
    r = run("convert", c3d, trc)
    assert r.returncode == 0, r.stderr
    src, back = read_trc(WALK_FREE), read_trc(trc)
    assert back.labels == src.labels and back.rate == 60.0 and back.units == "mm"
    np.testing.assert_array_equal(back.positions, src.positions.astype(np.float32).astype(np.float64).round(6))
    np.testing.assert_allclose(back.times, (184 + np.arange(20)) / 60.0, rtol=0, atol=1e-12)  # frame grid
    r = run("info", "--json", trc)
    assert r.returncode == 0 and '"format": "trc"' in r.stdout


def test_cli_convert_tables(tmp_path):
    r = run("convert", IK, tmp_path / "ik.sto")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(read_table(tmp_path / "ik.sto").values, read_table(IK).values)
    r = run("convert", ORIENT, tmp_path / "o.csv")
    assert r.returncode == 0, r.stderr
    csv = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)
    np.testing.assert_array_equal(csv["pelvis_imu_w"], read_orientations(ORIENT)["pelvis_imu"].values[:, 0])
    r = run("info", "--json", IK)
    assert r.returncode == 0 and '"kind": "table"' in r.stdout and '"in_degrees": true' in r.stdout
    r = run("convert", IK, tmp_path / "x.bvh")
    assert r.returncode == 2 and "converts to .mot, .sto or .csv" in r.stderr


def test_write_table_csv_tables_and_orientations(tmp_path):
    ik = read_opensim_signals(IK)
    f = tmp_path / "ik.csv"
    write_table_csv(ik, f)
    sig = read_table(IK)
    lines = f.read_text().splitlines()
    assert lines[0].split(",") == ["time", *sig.meta["labels"]] and len(lines) == len(sig) + 1
    back = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])  # exact: repr
    np.testing.assert_array_equal(back[:, 0], sig.times)
    np.testing.assert_array_equal(back[:, 1:], sig.values)
    imus = read_orientations(ORIENT)
    write_table_csv(imus, tmp_path / "o.csv")
    csv = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)
    for name, q in imus.items():
        for k, c in enumerate("wxyz"):
            np.testing.assert_array_equal(csv[f"{name}_{c}"], q.values[:, k])
    # refused: signals on different times, a header that CSV cannot hold, mixed kinds
    first, second = list(imus.items())[:2]
    shifted = Signal(second[1].times + 1.0, second[1].values, kind="quaternion", name=second[0])
    with pytest.raises(InvalidParameterError, match="share the first one's times"):
        write_table_csv({first[0]: first[1], second[0]: shifted}, tmp_path / "x.csv")
    bad = Signal(sig.times, sig.values, kind="vector", meta={"labels": ["a,b", *sig.meta["labels"][1:]]})
    with pytest.raises(InvalidParameterError, match="CSV header"):
        write_table_csv({"t": bad}, tmp_path / "x.csv")
    with pytest.raises(InvalidParameterError, match="one vector signal or quaternion"):
        write_table_csv({"t": sig, first[0]: first[1]}, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("suffix", [".c3d", ".trc"])
def test_cli_filter_output_markers_keeps_labels_rate_units_gaps(tmp_path, suffix):
    src = tmp_path / "in.trc"
    rng = np.random.default_rng(9)
    t = np.arange(120) / 100.0
    base = np.stack([np.stack([100 * np.sin(t + k), 50 * t + k, 10 * t**2], axis=1) for k in range(2)], axis=1)
    p = base + rng.normal(scale=0.5, size=base.shape)
    p[40:45, 1] = np.nan  # a gap
    write_markers_csv(Markers(t, p, ("Sub:LASI", "RASI"), 100.0, units="mm"), src.with_suffix(".csv"))
    write_trc(Markers(t, p, ("Sub:LASI", "RASI"), 100.0, units="mm"), src)
    out = tmp_path / f"out{suffix}"
    r = run("filter", src, "--penalty", "50", "-o", out)
    assert r.returncode == 0, r.stderr
    back = load_markers(out)
    assert back.labels == ("Sub:LASI", "RASI") and back.rate == 100.0 and back.units == "mm"
    np.testing.assert_array_equal(back.missing, np.isnan(p[:, :, 0]))
    np.testing.assert_allclose(back.times, t, rtol=0, atol=1e-12)
    ok = ~back.missing
    assert np.abs(back.positions[ok] - base[ok]).max() < 3.0  # filtered, close to the clean signal
    assert np.abs(back.positions[ok] - p[ok]).max() > 0.01  # and not a copy of the input
    # the CSV output names each component with the marker file's unit
    r = run("filter", src, "--penalty", "50", "-o", tmp_path / "out.csv")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out.csv").read_text().startswith("time (s),Sub:LASI_x (mm),")
