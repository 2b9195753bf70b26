"""Readers of layouts that were refused before: APDM CSV ``Format=7``, a TRC saved by a spreadsheet
(comma-separated), a legacy x-io folder whose ``*_Registers.csv`` states the quaternion rate, and an
NGIMU session whose ``Session.xml`` lists devices that are missing. Values are checked against an
independent parse of each file's text (csv module / numpy)."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io import load_markers, load_signals, read_sensor_folder
from mocapkit.io.markers.opensim import read_trc
from test_robust_cli import assert_one_line_error, cli_run

DATA = Path(__file__).resolve().parent / "data"
APDM7 = DATA / "formats" / "apdm_format7.csv"
TRC_CSV = DATA / "opensim" / "walk_free_01-spreadsheet.trc"
TRC_TAB = DATA / "opensim" / "walk_free_01-first20.trc"
XIO_LEGACY = DATA / "formats" / "xio-legacy-session"
NGIMU = DATA / "formats" / "ngimu-session"


def _rows(path: Path) -> list[list[str]]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


# --------------------------------------------------------------------------------------------------
# APDM Format=7
# --------------------------------------------------------------------------------------------------


def test_apdm_format7_values_match_the_text():
    sigs = load_signals(APDM7)
    assert list(sigs) == ["SI-000774", "SI-000795"]
    rows = _rows(APDM7)
    data = np.array([[float(c) for c in r] for r in rows[3:]])
    # independent: each sensor's group starts at its "I<n>" label; Orientation S,X,Y,Z are the group's
    # columns 11..14 (after Accelerometer, Gyroscope, Magnetometer x3 and Barometer)
    for label, name in (("I1", "SI-000774"), ("I2", "SI-000795")):
        j0 = rows[0].index(label)
        assert rows[0][j0 + 3] == name
        cols = list(range(j0 + 10, j0 + 14))
        assert [rows[2][c] for c in cols] == ["S", "X", "Y", "Z"]
        assert rows[1][j0 + 10] == "Orientation"
        sig = sigs[name]
        np.testing.assert_array_equal(sig.values, data[:, cols])
        np.testing.assert_array_equal(sig.times, data[:, 0] / 1e6)   # an epoch in µs, by its magnitude
        assert sig.meta["format"] == "apdm" and sig.meta["time_unit"] == "us"
        assert sig.meta["orientation_columns"] == [f"{name}/Orientation/{c}" for c in "SXYZ"]


def _apdm_variant(tmp_path: Path, edit) -> Path:
    lines = APDM7.read_text().splitlines()
    lines = edit(lines)
    p = tmp_path / "apdm.csv"
    p.write_text("\n".join(lines) + "\n")
    return p


@pytest.mark.parametrize("edit, line, words", [
    (lambda ls: [ls[0].replace("Format=7", "Format=8")] + ls[1:], 1, "Format=8"),
    (lambda ls: ls[:1], 1, "two header rows"),
    (lambda ls: [ls[0], ls[1], ls[2].replace(",S,X,Y,Z", ",S,X,Y,Q", 1)] + ls[3:], 3, "SI-000774"),
    (lambda ls: [ls[0].replace(",,,SI-000774", ",,SI-000999,SI-000774", 1)] + ls[1:], 1, "names 2 sensors"),
    (lambda ls: ls[:5] + [ls[5].rsplit(",", 3)[0] + ",x,0,0"] + ls[6:], 6, "SI-000795/Orientation/X"),
])
def test_apdm_format7_malformed_is_a_clear_error(tmp_path, edit, line, words):
    p = _apdm_variant(tmp_path, edit)
    with pytest.raises(MocapFormatError) as ei:
        load_signals(p)
    assert ei.value.line == line, str(ei.value)
    assert words in str(ei.value)
    r = cli_run("info", p)
    assert_one_line_error(r, str(p))


# --------------------------------------------------------------------------------------------------
# TRC saved by a spreadsheet
# --------------------------------------------------------------------------------------------------


def test_trc_with_commas_reads_like_the_tab_original():
    mk = load_markers(TRC_CSV)
    assert mk.meta["delimiter"] == "," and mk.rate == 60.0 and mk.units == "mm"
    rows = _rows(TRC_CSV)
    assert rows[0][3] == "walk, free 01.trc"             # a quoted cell holding a comma
    labels = [c for c in rows[3][2:] if c]
    assert list(mk.labels) == labels
    width = 2 + 3 * len(labels)
    data = np.array([[float(c) for c in r[:width]] for r in rows[5:]])
    np.testing.assert_array_equal(mk.times, data[:, 1])
    np.testing.assert_array_equal(mk.positions.reshape(len(data), -1), data[:, 2:])
    # the same numbers as the tab-separated file it was saved from
    tab = read_trc(TRC_TAB)
    np.testing.assert_array_equal(mk.positions, tab.positions[:len(data), :len(labels)])
    assert tab.meta["delimiter"] == "\t"


def test_trc_with_commas_malformed(tmp_path):
    lines = TRC_CSV.read_text().splitlines()
    bad = lines[:6] + [lines[6] + ",12.5"] + lines[7:]        # a value past the last marker
    p = tmp_path / "bad.trc"
    p.write_text("\n".join(bad) + "\n")
    with pytest.raises(MocapFormatError, match="comma-separated cells") as ei:
        read_trc(p)
    assert ei.value.line == 7
    no_rate = [lines[0], lines[1].replace('"DataRate","CameraRate"', '"Rate","Camera"')] + lines[2:]
    p2 = tmp_path / "norate.trc"
    p2.write_text("\n".join(no_rate) + "\n")
    assert_one_line_error(cli_run("info", p2), str(p2), "no DataRate")


# --------------------------------------------------------------------------------------------------
# legacy x-io folder with *_Registers.csv
# --------------------------------------------------------------------------------------------------


def test_legacy_xio_rate_from_the_registers():
    sigs = read_sensor_folder(XIO_LEGACY)
    assert list(sigs) == ["00000_Quaternion"]          # the Euler file is the same orientation: skipped
    sig = sigs["00000_Quaternion"]
    regs = {int(r[1]): int(r[2]) for r in _rows(XIO_LEGACY / "00000_Registers.csv")[1:]}
    rate = float(2 ** (regs[55] - 1))                   # x-io's decoding of QuatOutputRate
    assert sig.meta["rate"] == rate == 128.0
    assert "register 55" in sig.meta["rate_from"]
    assert "00000_EulerAngles.csv" in sig.meta["skipped_files"]
    rows = _rows(XIO_LEGACY / "00000_Quaternion.csv")[1:]
    pn = np.array([int(r[0]) for r in rows])
    q = np.array([[float(c) for c in r[1:5]] for r in rows])
    step = np.bincount(np.diff(pn)).argmax()
    np.testing.assert_allclose(sig.times, (pn - pn[0]) / (rate * step), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(sig.values, q)
    # the same rate given is accepted; another is refused
    assert read_sensor_folder(XIO_LEGACY, rate=128)["00000_Quaternion"].meta["rate"] == 128.0
    with pytest.raises(MocapFormatError, match="128 Hz but --rate 100"):
        read_sensor_folder(XIO_LEGACY, rate=100)


def test_legacy_xio_folder_compresses_without_rate(tmp_path):
    r = cli_run("compress", XIO_LEGACY, "--threshold", "1e-3", "--json")
    assert r.code == 0, r.err
    assert "--rate" not in r.err


@pytest.mark.parametrize("reg_rows, words", [
    (["1,55,8,8,QuatOutputRate", "2,55,7,7,QuatOutputRate"], "conflicting values"),
    (["1,55,0,0,QuatOutputRate"], "output was off"),
    (["1,55,40,40,QuatOutputRate"], "rate code"),
    (["1,54,9,9,InertialMagOutputRate"], "no register 55"),
    (["1,55,eight,8,QuatOutputRate"], "whole numbers"),
])
def test_legacy_xio_bad_registers(tmp_path, reg_rows, words):
    d = tmp_path / "session"
    shutil.copytree(XIO_LEGACY, d)
    (d / "00000_Registers.csv").write_text("Packet Number,Address,Value,Float Value,Name\n"
                                           + "\n".join(reg_rows) + "\n")
    with pytest.raises(MocapFormatError, match=words) as ei:
        read_sensor_folder(d)
    assert "00000_Registers.csv" in str(ei.value)
    assert_one_line_error(cli_run("info", d), "00000_Registers.csv")


# --------------------------------------------------------------------------------------------------
# NGIMU session with Session.xml
# --------------------------------------------------------------------------------------------------


def test_ngimu_session_warns_of_missing_devices():
    sigs = read_sensor_folder(NGIMU)
    assert list(sigs) == ["NGIMU - 0035EEA0", "NGIMU - 0035EEB1"]
    for name, sig in sigs.items():
        rows = _rows(NGIMU / name / "quaternion.csv")[1:]
        data = np.array([[float(c) for c in r] for r in rows])
        np.testing.assert_array_equal(sig.times, data[:, 0])
        np.testing.assert_array_equal(sig.values, data[:, 1:])
        assert sig.meta["skipped_files"] == ["euler.csv"]
        assert any("'NGIMU - 0040A1C2'" in w and "3 devices" in w for w in sig.meta["warnings"])
    r = cli_run("compress", NGIMU, "--threshold", "1e-3", "--json")
    assert r.code == 0, r.err
    assert "warning:" in r.err and "NGIMU - 0040A1C2" in r.err


def test_ngimu_session_all_present_no_warning(tmp_path):
    d = tmp_path / "s"
    shutil.copytree(NGIMU, d)
    xml = (d / "Session.xml").read_text()
    (d / "Session.xml").write_text("\n".join(ln for ln in xml.splitlines() if "0040A1C2" not in ln))
    for sig in read_sensor_folder(d).values():
        assert not any("Session.xml" in w for w in sig.meta["warnings"])


@pytest.mark.parametrize("xml, words", [
    ("<Session><Devices><Device DirectoryName='a'></Devices></Session>", "not XML"),
    ("<Other/>", "expected <Session>"),
    ('<?xml version="1.0"?><!DOCTYPE s [<!ENTITY a "aaaa">]><Session/>', "DOCTYPE"),
    ("<Session><Devices><Device SerialNumber='1'/></Devices></Session>", "without DirectoryName"),
])
def test_ngimu_bad_session_xml(tmp_path, xml, words):
    d = tmp_path / "s"
    shutil.copytree(NGIMU, d)
    (d / "Session.xml").write_text(xml)
    with pytest.raises(MocapFormatError, match=words):
        read_sensor_folder(d)
    assert_one_line_error(cli_run("info", d), "Session.xml")


def test_ngimu_session_names_are_never_paths(tmp_path):
    d = tmp_path / "s"
    shutil.copytree(NGIMU, d)
    (tmp_path / "outside").mkdir()
    xml = (d / "Session.xml").read_text().replace("NGIMU - 0040A1C2", "../outside")
    (d / "Session.xml").write_text(xml)
    sigs = read_sensor_folder(d)
    assert list(sigs) == ["NGIMU - 0035EEA0", "NGIMU - 0035EEB1"]
    assert any("'../outside'" in w for w in sigs["NGIMU - 0035EEA0"].meta["warnings"])


def test_batch_inputs_take_an_ngimu_session_as_one_recording():
    from mocapkit.jobs.inputs import expand_inputs, is_sensor_folder

    assert is_sensor_folder(NGIMU)                     # Session.xml at the top, euler.csv beside quaternion.csv
    got = expand_inputs([NGIMU])
    assert got.files == [NGIMU.resolve()]
    legacy = expand_inputs([XIO_LEGACY])
    assert (str((XIO_LEGACY / "00000_Registers.csv").resolve()), "x-io register file (read with the quaternion "
            "file beside it)") in legacy.skipped


def test_apdm_one_row_sensor_groups(tmp_path):
    """Per-sensor groups named in one header row (``SI-000774/Orientation S`` ...): one signal per sensor."""
    p = tmp_path / "apdm_one_row.csv"
    head = ["Time"] + [f"{s}/Orientation {c}" for s in ("SI-000774", "SI-000775") for c in "SXYZ"]
    rows = [[0.0, 1, 0, 0, 0, 0.5, 0.5, 0.5, 0.5], [0.0078125, 0.99, 0.141067, 0, 0, 0.5, 0.5, -0.5, 0.5]]
    p.write_text(",".join(head) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    sigs = load_signals(p)
    assert list(sigs) == ["SI-000774", "SI-000775"]
    data = np.genfromtxt(p, delimiter=",", skip_header=1)
    np.testing.assert_array_equal(sigs["SI-000774"].values, data[:, 1:5])
    np.testing.assert_array_equal(sigs["SI-000775"].values, data[:, 5:9])
    assert sigs["SI-000775"].meta["format"] == "apdm"


# --------------------------------------------------------------------------------------------------
# properties: any TRC re-saved as CSV, any Format=7 layout
# --------------------------------------------------------------------------------------------------

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(2, 12), m=st.integers(1, 4), seed=st.integers(0, 2 ** 31),
       quoting=st.sampled_from([csv.QUOTE_MINIMAL, csv.QUOTE_NONNUMERIC, csv.QUOTE_ALL]),
       pad=st.integers(0, 5), gap=st.booleans())
def test_property_trc_resaved_as_csv_reads_the_same(tmp_path, n, m, seed, quoting, pad, gap):
    """A TRC written by mocapkit (tabs) and saved again as CSV by any quoting rule, rows padded with
    commas, reads to the same markers (gaps included)."""
    from mocapkit.io.markers.opensim import write_trc
    from mocapkit.markers import Markers

    rng = np.random.default_rng(seed)
    pos = np.round(rng.normal(0, 500, (n, m, 3)), 6)
    if gap:
        pos[rng.integers(n), rng.integers(m)] = np.nan
    mk = Markers(np.arange(n) / 100.0, pos, [f"M,{k}" if k == 0 else f"M{k}" for k in range(m)], 100.0, units="mm")
    tab = tmp_path / f"t{seed}.trc"
    write_trc(mk, tab)
    rows = [ln.split("\t") for ln in tab.read_text().split("\n") if ln != ""]
    width = max(len(r) for r in rows) + pad
    out = tmp_path / f"c{seed}.trc"

    def cell(c: str) -> str:  # minimal: only what needs it; text: every non-number; all: every cell
        if quoting == csv.QUOTE_ALL or "," in c or '"' in c or (quoting == csv.QUOTE_NONNUMERIC and c and not _num(c)):
            return '"' + c.replace('"', '""') + '"'
        return c
    out.write_text("\r\n".join(",".join(cell(c) for c in r + [""] * (width - len(r))) for r in rows) + "\r\n")
    a, b = read_trc(tab), read_trc(out)
    assert b.meta["delimiter"] == "," and list(b.labels) == list(a.labels)
    np.testing.assert_array_equal(b.times, a.times)
    np.testing.assert_array_equal(np.isnan(b.positions), np.isnan(a.positions))
    np.testing.assert_array_equal(np.nan_to_num(b.positions), np.nan_to_num(a.positions))


def _num(c: str) -> bool:
    try:
        float(c)
    except ValueError:
        return False
    return c.strip() != "" and c.strip().lower() not in ("nan", "inf", "-inf")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(k=st.integers(1, 4), n=st.integers(2, 10), seed=st.integers(0, 2 ** 31), extra=st.booleans())
def test_property_apdm_format7_any_sensor_count(tmp_path, k, n, seed, extra):
    """k sensors in Format=7 groups of 14 columns (or 15 with an extra quantity before Orientation):
    each sensor's S,X,Y,Z equal the text's numbers, in the file's sensor order."""
    rng = np.random.default_rng(seed)
    names = [f"SI-{rng.integers(0, 999999):06d}" for _ in range(k)]
    if len(set(names)) < k:
        return
    quantities = ["Accelerometer", "", "", "Gyroscope", "", "", "Magnetometer", "", "", "Barometer"]
    comps = ["X", "Y", "Z", "X", "Y", "Z", "X", "Y", "Z", ""]
    if extra:
        quantities, comps = quantities + ["Temperature"], comps + [""]
    g = len(quantities) + 4
    r1, r2, r3 = ["Format=7"], ["Time"], [""]
    for j, s in enumerate(names):
        r1 += [f"I{j + 1}", "", "", s] + [""] * (g - 4)
        r2 += quantities + ["Orientation", "", "", ""]
        r3 += comps + ["S", "X", "Y", "Z"]
    data = np.round(rng.normal(0, 1, (n, 1 + g * k)), 8)
    data[:, 0] = np.arange(n) / 128.0
    p = tmp_path / f"a{seed}.csv"
    p.write_text("\n".join(",".join(r) for r in (r1, r2, r3)) + "\n"
                 + "\n".join(",".join(repr(float(v)) for v in row) for row in data) + "\n")
    sigs = load_signals(p)
    assert list(sigs) == names
    for j, s in enumerate(names):
        c0 = 1 + j * g + len(quantities)
        np.testing.assert_array_equal(sigs[s].values, data[:, c0:c0 + 4])
        np.testing.assert_array_equal(sigs[s].times, data[:, 0])
