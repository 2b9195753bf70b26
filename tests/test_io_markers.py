"""Marker files: the Markers model, C3D (ezc3d) and Qualisys TSV readers, the wide CSV."""

from __future__ import annotations

import os
import tempfile
import time
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from import_graph import import_graph as _import_graph
from import_graph import mocapkit_imports as _mocapkit_imports
from import_graph import reachable as _reachable
from mocapkit.errors import InvalidSignalError, MocapFormatError
from mocapkit.io.loaders import kind_of, load_markers, write_markers
from mocapkit.io.markers.c3d import check_c3d_structure, read_c3d, write_c3d
from mocapkit.io.markers.qtm import read_qtm_tsv, read_qtm_tsv_text
from mocapkit.io.markers.vicon_csv import read_vicon_csv
from mocapkit.io.markers.wide_csv import read_markers_csv, write_markers_csv
from mocapkit.markers import Markers, make_unique_labels

ezc3d = pytest.importorskip("ezc3d")

TESTS_DIR = Path(__file__).resolve().parent
EXCERPT = TESTS_DIR / "data" / "markers" / "juggling-qualisys-300hz-first120.tsv"
VICON_CSV = TESTS_DIR / "data" / "markers" / "vicon-nexus-walking2-excerpt.csv"
C3D_FILES = {"Vicon.c3d": 51, "BTS.c3d": 22, "FP_Type1.c3d": 22}
JUGGLING_NAMES = ("base_1", "base_2", "base_3", "base_4", "base_5")


def _markers(n=4, labels=("a", "b"), rate=100.0, **kw) -> Markers:
    t = np.arange(n) / rate
    p = np.arange(n * len(labels) * 3, dtype=float).reshape(n, len(labels), 3)
    return Markers(t, p, labels, rate, **kw)


# ==================================================================================================
# the Markers model
# ==================================================================================================


MODEL_MODULES = ("mocapkit.motion", "mocapkit.skeleton", "mocapkit.markers", "mocapkit.quat", "mocapkit.errors")


def _is_io(name: str) -> bool:
    return name == "mocapkit.io" or name.startswith("mocapkit.io.")


def test_import_walk_sees_lazy_and_relative_imports():
    """The checker below could pass vacuously if it missed imports: it must see one inside a function, in
    a ``TYPE_CHECKING`` block and a relative one, and find the real edges io -> model."""
    import ast

    known = {"mocapkit.io", "mocapkit.io.atomic", "mocapkit.io.loaders", "mocapkit.markers", "mocapkit.errors"}
    src = ("from mocapkit.errors import MocapError\n"
           "if TYPE_CHECKING:\n    from .io import loaders\n"
           "def f():\n    import mocapkit.io.atomic as a\n    return a\n")
    assert _mocapkit_imports(ast.parse(src), "mocapkit.markers", known) == {
        "mocapkit.errors", "mocapkit.io", "mocapkit.io.loaders", "mocapkit.io.atomic"}
    graph = _import_graph()
    assert "mocapkit.markers" in graph["mocapkit.io.markers.c3d"]  # module level
    assert "mocapkit.io.markers.wide_csv" in graph["mocapkit.io.loaders"]  # inside load_markers/write_markers
    assert "mocapkit.io.atomic" in graph["mocapkit.io.markers.wide_csv"]


def test_model_modules_import_no_io_at_all():
    """Imports point down: the data model (motion, skeleton, markers, quat, errors) imports no
    mocapkit.io module anywhere -- not at module level, not lazily inside a function -- neither itself
    nor through any mocapkit module it imports."""
    graph = _import_graph()
    for name in MODEL_MODULES:
        direct = sorted(m for m in graph[name] if _is_io(m))
        assert not direct, (name, direct)
        through = sorted(m for m in _reachable(graph, name) if _is_io(m))
        assert not through, (name, through)


def test_no_import_cycle_between_model_and_io():
    """No model module and io module reach each other through imports (lazy ones included), so the
    io readers may import the model at module level."""
    graph = _import_graph()
    io_modules = [m for m in graph if _is_io(m)]
    assert len(io_modules) > 10
    for io_mod in io_modules:
        back = sorted(m for m in _reachable(graph, io_mod) if m in MODEL_MODULES and io_mod in _reachable(graph, m))
        assert not back, (io_mod, back)


def test_markers_basic_properties():
    m = _markers(analog={"labels": ("f",), "rate": 1000.0, "values": np.zeros((40, 1))})
    assert (m.n_frames, m.n_markers, len(m)) == (4, 2, 4)
    assert m.positions.dtype == np.float64 and m.times.dtype == np.float64
    assert not m.positions.flags.writeable and not m.times.flags.writeable
    assert not m.analog["values"].flags.writeable
    np.testing.assert_array_equal(m.marker("b")[0], [3.0, 4.0, 5.0])
    assert m.index("b") == 1
    with pytest.raises(KeyError, match="no marker 'c'"):
        m.index("c")
    assert m.duration == pytest.approx(0.03)


def test_markers_partial_nan_triple_becomes_missing():
    p = np.zeros((2, 1, 3))
    p[1, 0, 1] = np.nan
    m = Markers([0.0, 1.0], p, ("a",), 1.0)
    assert np.isnan(m.positions[1, 0]).all()
    assert m.missing.tolist() == [[False], [True]]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"times": [0.0, 0.0]}, "strictly increasing"),
        ({"times": [0.0, np.nan]}, "not finite"),
        ({"positions": np.zeros((2, 2, 2))}, r"\(N, M, 3\)"),
        ({"positions": np.zeros((3, 2, 3))}, r"\(N, M, 3\)"),
        ({"positions": np.full((2, 2, 3), np.inf)}, "infinite"),
        ({"labels": ("a", "a")}, "repeated"),
        ({"labels": ("a", "")}, "empty"),
        ({"labels": ("a", " b")}, "white space"),
        ({"labels": ("a", "b\nc")}, "control character"),
        ({"labels": ("a",)}, "1 labels for 2 markers"),
        ({"labels": "ab"}, "not a string"),
        ({"rate": 0.0}, "rate"),
        ({"rate": float("nan")}, "rate"),
        ({"units": ""}, "units"),
        ({"analog": {"labels": ("x",), "rate": 10.0, "values": np.zeros((3, 2))}}, "analog values"),
        ({"analog": {"labels": ("x",), "values": np.zeros((3, 1))}}, "lacks rate"),
        ({"times": []}, "no frames"),
    ],
)
def test_markers_validation(kwargs, message):
    args = {"times": [0.0, 0.01], "positions": np.zeros((2, 2, 3)), "labels": ("a", "b"), "rate": 100.0}
    args.update(kwargs)
    if "times" in kwargs and len(kwargs["times"]) == 0:
        args["positions"] = np.zeros((0, 2, 3))
    with pytest.raises(InvalidSignalError, match=message):
        Markers(**args)


def test_make_unique_labels_is_deterministic_and_never_drops():
    labels, fixes = make_unique_labels(["a", "", "a", "a_2", " b ", "a"], 8)
    assert labels == ("a", "unnamed_2", "a_3", "a_2", "b", "a_4", "unnamed_7", "unnamed_8")
    reasons = {f["index"]: f["reason"] for f in fixes}
    assert reasons == {1: "empty", 2: "duplicate", 4: "cleaned", 5: "duplicate", 6: "missing", 7: "missing"}
    assert make_unique_labels(["a", "", "a", "a_2", " b ", "a"], 8) == (labels, fixes)

    labels, fixes = make_unique_labels(["x", "y", "z"], 2)
    assert labels == ("x", "y")
    assert fixes == [{"index": 2, "original": "z", "label": None, "reason": "extra"}]

    # a generated name never collides with a real label
    labels, _ = make_unique_labels(["unnamed_2", ""], 2)
    assert labels == ("unnamed_2", "unnamed_2_2")


# ==================================================================================================
# the wide CSV
# ==================================================================================================


def test_write_markers_csv_layout_and_round_trip(tmp_path):
    p = np.array([[[1.5, -2.0, 3.0], [np.nan] * 3], [[0.1, 0.2, 0.30000000000000004], [7.0, 8.0, 9.0]]])
    m = Markers([0.0, 1 / 3], p, ("RASI", "L,ASI"), 3.0, units="m")
    out = tmp_path / "m.csv"
    write_markers_csv(m, out)
    text = out.read_text()
    lines = text.split("\n")
    assert lines[0] == 'time (s),RASI_x (m),RASI_y (m),RASI_z (m),"L,ASI_x (m)","L,ASI_y (m)","L,ASI_z (m)"'
    assert lines[1] == "0.0,1.5,-2.0,3.0,nan,nan,nan"
    assert text.endswith("\n") and "\r" not in text
    assert [f for f in os.listdir(tmp_path) if f != "m.csv"] == []  # no temporary file left

    back = read_markers_csv(out, rate=3.0, units="m")
    assert back.labels == m.labels
    np.testing.assert_array_equal(back.times, m.times)  # bit-exact (repr)
    np.testing.assert_array_equal(back.positions, m.positions)  # NaN in the same places
    assert back.units == "m"
    assert read_markers_csv(out).units == "m" and read_markers_csv(out).meta["warnings"] == []  # unit kept
    with pytest.raises(MocapFormatError, match="unit is 'm'"):
        read_markers_csv(out, units="mm")
    legacy = tmp_path / "legacy.csv"  # a header without units: mm, and said so
    legacy.write_text("time,A_x,A_y,A_z\n0.0,1,2,3\n")
    old_style = read_markers_csv(legacy)
    assert old_style.units == "mm" and "mm assumed" in old_style.meta["warnings"][0]
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("time,A_x (m),A_y (mm),A_z (m)\n0.0,1,2,3\n")
    with pytest.raises(MocapFormatError, match="different units"):
        read_markers_csv(mixed)


def test_csv_round_trip_of_real_tsv_excerpt(tmp_path):
    m = read_qtm_tsv(EXCERPT)
    write_markers_csv(m, tmp_path / "j.csv")
    back = load_markers(tmp_path / "j.csv")
    assert back.labels == m.labels
    assert back.rate == pytest.approx(300.0, rel=1e-4)
    np.testing.assert_array_equal(back.times, m.times)
    np.testing.assert_array_equal(back.positions, m.positions)


def test_read_markers_csv_rejections(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("t,a_x,a_y,a_z\n0,1,2,3\n")
    with pytest.raises(MocapFormatError, match=r"bad.csv:1: the first column must be 'time'"):
        read_markers_csv(f)
    f.write_text("time,a_x,a_y\n0,1,2\n")
    with pytest.raises(MocapFormatError, match="not a multiple of 3"):
        read_markers_csv(f)
    f.write_text("time,a_x,a_y,a_z\n0,1,2,3\n1,1,x,3\n")
    with pytest.raises(MocapFormatError, match=r"bad.csv:3: column 3 \(a_y\): 'x' is not a number"):
        read_markers_csv(f)
    f.write_text("time,a_x,a_y,a_z\n0,1,2\n")
    with pytest.raises(MocapFormatError, match=r"bad.csv:2: expected 4"):
        read_markers_csv(f)


# ==================================================================================================
# C3D
# ==================================================================================================


def _write_c3d(path: Path, *, labels=("LASI", "RASI", "C7"), first_frame: int | None = None) -> dict:
    """A small C3D written by ezc3d with known values (all exactly representable in float32)."""
    n, m, ratio = 6, len(labels), 4
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [50.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = tuple(labels)
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    xyz = (np.arange(3 * m * n, dtype=float).reshape(3, m, n) * 0.25) - 7.0
    pts = np.ones((4, m, n))
    pts[:3] = xyz
    c["data"]["points"] = pts
    res = np.zeros((1, m, n))
    res[0, 1, 2] = -1.0  # RASI missing in frame 2
    res[0, 2, 5] = -1.0  # C7 missing in the last frame
    c["data"]["meta_points"] = {"residuals": res, "camera_masks": np.zeros((7, m, n), dtype=bool)}
    c["parameters"]["ANALOG"]["RATE"]["value"] = [50.0 * ratio]
    c["parameters"]["ANALOG"]["LABELS"]["value"] = ("Fz", "EMG")
    analogs = np.arange(2 * n * ratio, dtype=float).reshape(1, 2, n * ratio) / 8.0
    c["data"]["analogs"] = analogs
    c.write(str(path))
    if first_frame is not None:  # patch the header's first/last frame (1-based)
        data = bytearray(path.read_bytes())
        data[6:8] = first_frame.to_bytes(2, "little")
        data[8:10] = (first_frame + n - 1).to_bytes(2, "little")
        path.write_bytes(bytes(data))
    expected = np.transpose(xyz, (2, 1, 0)).copy()
    expected[2, 1] = np.nan
    expected[5, 2] = np.nan
    return {"positions": expected, "analog": analogs[0].T, "n": n}


def test_small_c3d_written_by_ezc3d_reads_back_exactly(tmp_path):
    f = tmp_path / "small.c3d"
    exp = _write_c3d(f)
    m = read_c3d(f)
    assert m.labels == ("LASI", "RASI", "C7")
    assert m.rate == 50.0 and m.units == "mm"
    np.testing.assert_array_equal(m.times, np.arange(exp["n"]) / 50.0)
    np.testing.assert_array_equal(m.positions, exp["positions"])
    assert m.missing.sum() == 2
    assert m.analog["labels"] == ("Fz", "EMG")
    assert m.analog["rate"] == 200.0
    np.testing.assert_array_equal(m.analog["values"], exp["analog"])
    assert m.meta["format"] == "c3d" and m.meta["first_frame"] == 1 and m.meta["label_fixes"] == []
    assert load_markers(f).labels == m.labels


def test_c3d_first_frame_sets_time_origin(tmp_path):
    f = tmp_path / "trimmed.c3d"
    _write_c3d(f, first_frame=11)
    m = read_c3d(f)
    assert m.meta["first_frame"] == 11
    np.testing.assert_allclose(m.times, (10 + np.arange(6)) / 50.0, rtol=0, atol=1e-15)


def test_c3d_repeated_and_empty_labels_are_made_unique(tmp_path):
    f = tmp_path / "labels.c3d"
    _write_c3d(f, labels=("A", "A", ""))
    m = read_c3d(f)
    assert m.labels == ("A", "A_2", "unnamed_3")
    assert [(x["index"], x["reason"]) for x in m.meta["label_fixes"]] == [(1, "duplicate"), (2, "empty")]
    assert m.n_markers == 3  # nothing dropped


def test_c3d_labels2_continue_labels(tmp_path):
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [10.0]
    labels = [f"M{i:03d}" for i in range(300)]
    c["parameters"]["POINT"]["LABELS"]["value"] = labels[:255]
    c.add_parameter("POINT", "LABELS2", labels[255:])
    c["data"]["points"] = np.ones((4, 300, 2))
    f = tmp_path / "many.c3d"
    c.write(str(f))
    assert "LABELS2" in ezc3d.c3d(str(f))["parameters"]["POINT"]
    m = read_c3d(f)
    assert m.labels == tuple(labels) and m.meta["label_fixes"] == []
    assert m.analog is None


def test_c3d_rejections(tmp_path):
    good = tmp_path / "good.c3d"
    _write_c3d(good)
    data = good.read_bytes()

    def bad(name: str, content: bytes) -> str:
        p = tmp_path / name
        p.write_bytes(content)
        with pytest.raises(MocapFormatError) as info:
            read_c3d(p)
        assert info.value.path == str(p) and info.value.line is None
        return info.value.problem

    assert "too short" in bad("empty.c3d", b"")
    assert "not a C3D file" in bad("text.c3d", b"NO_OF_FRAMES\t3\n" * 100)
    assert "parameter section" in bad("cutparam.c3d", data[:700] + bytes(10))
    assert "no frames" in bad("nodata.c3d", data[:512 * (data[16] - 1)])
    proc = bytearray(data)
    proc[512 + 3] = 99
    assert "processor type" in bad("proc.c3d", bytes(proc))
    with pytest.raises(MocapFormatError, match="no such file"):
        read_c3d(tmp_path / "absent.c3d")
    with pytest.raises(MocapFormatError, match="folder"):
        read_c3d(tmp_path)
    with pytest.raises(ValueError, match="too short"):
        check_c3d_structure(b"\x02\x50")


@lru_cache(maxsize=1)
def _small_c3d_bytes() -> bytes:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "fuzz.c3d"
        _write_c3d(p)
        return p.read_bytes()


_c3d_edit = st.tuples(
    st.sampled_from(["header", "parameters", "anywhere"]),
    st.floats(0, 1, exclude_max=True),
    st.integers(0, 255),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(edits=st.lists(_c3d_edit, min_size=1, max_size=8), cut=st.none() | st.floats(0, 1))
def test_fuzz_c3d_byte_corruption_only_raises_mocap_format_error(edits, cut):
    base = _small_c3d_bytes()
    data = bytearray(base)
    regions = {"header": (0, 512), "parameters": (512, 512 * (base[0] - 1) + 512 * base[514]),
               "anywhere": (0, len(base))}
    for region, where, value in edits:
        lo, hi = regions[region]
        data[lo + int(where * (hi - lo))] = value
    if cut is not None:
        data = data[: int(cut * len(data))]
    fd, name = tempfile.mkstemp(suffix=".c3d")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(bytes(data))
        try:
            m = read_c3d(name)
        except MocapFormatError as exc:
            assert exc.path == name and exc.problem
        else:
            assert m.n_frames >= 1 and m.positions.shape == (m.n_frames, m.n_markers, 3)
    finally:
        os.unlink(name)


@pytest.mark.shared
@pytest.mark.parametrize("name", sorted(C3D_FILES))
def test_shared_c3d_files_against_ezc3d(shared_data, name):
    path = shared_data / "c3d" / name
    m = read_c3d(path)
    ref = ezc3d.c3d(str(path))  # independent read
    ref_labels = list(ref["parameters"]["POINT"]["LABELS"]["value"])
    assert len(ref_labels) == C3D_FILES[name] == m.n_markers == len(m.labels)
    assert list(m.labels) == [s.strip() for s in ref_labels]  # these files have clean, unique labels
    assert m.rate == 100.0 == float(ref["parameters"]["POINT"]["RATE"]["value"][0])
    n = ref["data"]["points"].shape[2]
    assert m.n_frames == n
    np.testing.assert_allclose(m.times, np.arange(n) / 100.0, rtol=0, atol=1e-12)
    assert m.units == ref["parameters"]["POINT"]["UNITS"]["value"][0]

    residuals = ref["data"]["meta_points"]["residuals"][0].T  # (N, M)
    np.testing.assert_array_equal(m.missing, residuals < 0)
    np.testing.assert_array_equal(m.positions, np.transpose(ref["data"]["points"][:3], (2, 1, 0)))

    ana = ref["data"]["analogs"][0].T
    assert m.analog is not None and ana.shape[1] > 0
    assert m.analog["values"].shape == ana.shape
    np.testing.assert_array_equal(m.analog["values"], ana)
    assert len(m.analog["labels"]) == len(ref["parameters"]["ANALOG"]["LABELS"]["value"])
    assert m.analog["rate"] == float(ref["parameters"]["ANALOG"]["RATE"]["value"][0])
    assert load_markers(path).n_markers == m.n_markers


@pytest.mark.shared
def test_shared_c3d_details(shared_data):
    vicon = read_c3d(shared_data / "c3d" / "Vicon.c3d")
    assert vicon.missing.sum() == 305 and vicon.units == "mm"
    assert vicon.meta["manufacturer"]["company"] == "Vicon"
    assert vicon.meta["first_frame_from"] == "TRIAL:ACTUAL_START_FIELD"
    assert (vicon.analog["rate"], len(vicon.analog["labels"])) == (2000.0, 38)
    bts = read_c3d(shared_data / "c3d" / "BTS.c3d")
    assert bts.missing.sum() == 7661 and bts.n_frames == 675
    fp = read_c3d(shared_data / "c3d" / "FP_Type1.c3d")
    assert fp.units == "m" and fp.missing.sum() == 0  # this file stores metres, no gaps


# ==================================================================================================
# Qualisys TSV
# ==================================================================================================


def _reference_zero_triplets(path: Path, skip: int = 12) -> np.ndarray:
    a = np.loadtxt(path, skiprows=skip, delimiter="\t")
    p = a[:, 2:].reshape(len(a), -1, 3)
    return np.all(p == 0.0, axis=2)


def test_tsv_excerpt():
    m = read_qtm_tsv(EXCERPT)
    assert m.n_frames == 120 and m.n_markers == 24 and m.rate == 300.0 and m.units == "mm"
    assert m.labels[:5] == JUGGLING_NAMES
    assert m.labels[5:] == tuple(f"unnamed_{k}" for k in range(6, 25))
    assert len(m.meta["label_fixes"]) == 19
    assert m.times[0] == 0.0 and m.times[1] == 0.00333 and m.times[-1] == 0.39667
    np.testing.assert_array_equal(m.missing, _reference_zero_triplets(EXCERPT))
    assert m.missing[:, 10:].all() and not m.missing[:, :6].any()
    assert m.positions[0, 0].tolist() == [228.117, -404.129, -672.697]
    assert m.meta["qtm"]["NO_OF_CAMERAS"] == 4 and m.meta["qtm"]["DATA_INCLUDED"] == "3D"
    assert m.meta["qtm"]["TIME_STAMP"] == ("2024-12-12, 16:25:26.188", "56373.87175403")
    assert m.meta["header"]["DESCRIPTION"] == ["--"]
    assert m.meta["header_lines"]["MARKER_NAMES"] == 10
    assert m.meta["trajectory_types"][12] == "Mixed"
    assert m.meta["frame_numbers"][-1] == 120 and m.meta["frame_gaps"] == 0
    assert m.analog is None
    assert load_markers(EXCERPT).n_frames == 120


@pytest.mark.parametrize("variant", ["crlf", "no-final-newline", "bom", "trailing-tabs", "latin1"])
def test_tsv_text_variants_read_the_same(tmp_path, variant):
    base = read_qtm_tsv(EXCERPT)
    text = EXCERPT.read_text()
    data: bytes
    if variant == "crlf":
        data = text.replace("\n", "\r\n").encode()
    elif variant == "no-final-newline":
        data = text.rstrip("\n").encode()
    elif variant == "bom":
        data = b"\xef\xbb\xbf" + text.encode()
    elif variant == "trailing-tabs":
        data = "\n".join(ln + "\t\t" if ln else ln for ln in text.split("\n")).encode()
    else:
        data = text.replace("base_1", "bas\u00e9_1").encode("latin-1")
    f = tmp_path / "v.tsv"
    f.write_bytes(data)
    m = read_qtm_tsv(f)
    np.testing.assert_array_equal(m.times, base.times)
    np.testing.assert_array_equal(m.positions, base.positions)
    if variant == "latin1":
        assert m.labels[0] == "bas\u00e9_1" and m.meta["encoding"] == "latin-1"
    else:
        assert m.labels == base.labels


def _excerpt_lines(rows: int = 120) -> list[str]:
    lines = EXCERPT.read_text().split("\n")[: 12 + rows]
    lines[0] = f"NO_OF_FRAMES\t{rows}"
    return lines


def _parse(lines: list[str], strict: bool = True) -> Markers:
    return read_qtm_tsv_text("\n".join(lines) + "\n", "x.tsv", strict=strict)


def _error(lines: list[str], strict: bool = True) -> MocapFormatError:
    with pytest.raises(MocapFormatError) as info:
        _parse(lines, strict=strict)
    return info.value


def test_tsv_frame_count_strict_and_lenient():
    lines = _excerpt_lines(20)
    lines[0] = "NO_OF_FRAMES\t25"
    e = _error(lines)
    assert (e.path, e.line) == ("x.tsv", 1)
    assert "NO_OF_FRAMES is 25 but the file has 20 data rows (lines 13-32)" in e.problem
    m = _parse(lines, strict=False)
    assert m.n_frames == 20
    assert m.meta["frame_count_mismatch"] == {"declared": 25, "rows": 20}


def test_tsv_time_must_match_frames():
    lines = _excerpt_lines(20)
    f = lines[20].split("\t")
    f[1] = "0.02800"  # frame 9 should be at 0.02667
    lines[20] = "\t".join(f)
    e = _error(lines)
    assert e.line == 21 and "disagrees with FREQUENCY 300 Hz" in e.problem
    m = _parse(lines, strict=False)
    assert m.meta["time_mismatch"]["line"] == 21
    assert m.times[8] == 0.028  # the Time column is used as written


def _set_header(lines: list[str], key: str, value: str | None) -> list[str]:
    out = []
    for ln in lines:
        if ln.split("\t")[0] == key:
            if value is None:
                continue
            ln = f"{key}\t{value}"
        out.append(ln)
    return out


@pytest.mark.parametrize(
    ("edit", "line", "message"),
    [
        (lambda L: _set_header(L, "FREQUENCY", None), 11, "header field FREQUENCY is missing"),
        (lambda L: _set_header(L, "FREQUENCY", "EXT"), 4, "external time base"),
        (lambda L: _set_header(L, "FREQUENCY", "-3"), 4, "FREQUENCY must be a non-negative number"),
        (lambda L: _set_header(L, "FREQUENCY", "0"), 4, "FREQUENCY must be > 0"),
        (lambda L: _set_header(L, "NO_OF_MARKERS", "2x"), 3, "NO_OF_MARKERS must be a non-negative integer"),
        (lambda L: _set_header(L, "NO_OF_MARKERS", "23"), 12, "expected 3 x NO_OF_MARKERS = 69"),
        (lambda L: _set_header(L, "NO_OF_MARKERS", "3"), 10, "MARKER_NAMES has 5 names but NO_OF_MARKERS is 3"),
        (lambda L: _set_header(L, "DATA_INCLUDED", "6D"), 9, "only 3D exports"),
        (lambda L: _set_header(L, "NO_OF_CAMERAS", "4\t5"), 2, "exactly one value"),
        (lambda L: L[:3] + ["NO_OF_MARKERS\t24"] + L[3:], 4, "NO_OF_MARKERS is repeated"),
        (lambda L: [L[0].replace("NO_OF_FRAMES", "Hello")] + L[1:], 1, "not a QTM TSV export"),
        (lambda L: L[:11] + [L[11].replace("base_2 Y", "base_9 Y")] + L[12:], 12, "column 7"),
        (lambda L: L[:15] + [L[15] + "\t1.0"] + L[16:], 16, "expected 74 tab-separated values, found 75"),
        (lambda L: L[:15] + [L[15].rsplit("\t", 1)[0]] + L[16:], 16, "found 73"),
        (lambda L: L[:15] + [L[15].replace("228.", "2x8.", 1)] + L[16:], 16, "column 3 ('base_1 X'): '2x8."),
        (lambda L: L[:15] + ["\t".join(L[15].split("\t")[:2] + [""] + L[15].split("\t")[3:])] + L[16:], 16,
         "column 3 ('base_1 X'): empty value is not a number"),
        (lambda L: L[:15] + [L[15].replace("228.", "1_0", 1)] + L[16:], 16, "'1_0"),
        (lambda L: L[:15] + [L[15].replace("228.", "nan", 1)] + L[16:], 16, "'nan"),
        (lambda L: L[:15] + [""] + L[16:], 16, "empty line inside the data"),
        (lambda L: L[:15] + [L[14]] + L[16:], 16, "frame number 3 does not follow 3"),
        (lambda L: L[:15] + ["3.5" + L[15][1:]] + L[16:], 16, "frame number 3.5 is not an integer"),
        (lambda L: L[:12], 12, "no data rows"),
        (lambda L: L[:3] + [""] + L[3:], 4, "empty line in the header"),
        (lambda L: L[:3] + ["EVENT\tx\t1"] + L[3:], 4, "EVENT needs"),
    ],
)
def test_tsv_rejections_name_the_line(edit, line, message):
    e = _error(edit(_excerpt_lines(20)))
    assert e.path == "x.tsv"
    assert e.line == line, e
    assert message in e.problem, e
    assert str(e).startswith(f"x.tsv:{line}: ")


def test_tsv_without_column_header_and_with_events():
    lines = _excerpt_lines(20)
    m0 = _parse(lines)
    no_head = lines[:11] + ["EVENT\tthrow\t5\t0.01333"] + lines[12:]
    m = _parse(no_head)
    np.testing.assert_array_equal(m.positions, m0.positions)
    np.testing.assert_array_equal(m.times, m0.times)
    assert m.meta["events"] == [{"name": "throw", "frame": 5, "time": 0.01333, "line": 12}]
    # no frame/time columns at all: times from the rate
    bare = lines[:11] + ["\t".join(r.split("\t")[2:]) for r in lines[12:]]
    m2 = _parse(bare)
    np.testing.assert_allclose(m2.times, np.arange(20) / 300.0)
    np.testing.assert_array_equal(m2.positions, m0.positions)


def test_tsv_repeated_and_padded_marker_names():
    lines = _excerpt_lines(5)
    lines = [ln.replace("base_2", "base_1") for ln in lines]
    m = _parse(lines)
    assert m.labels[:3] == ("base_1", "base_1_2", "base_3")
    # MARKER_NAMES with its trailing (empty) names stripped by an editor: padded, recorded
    lines2 = [("MARKER_NAMES\t" + "\t".join(JUGGLING_NAMES)) if ln.startswith("MARKER_NAMES") else ln
              for ln in _excerpt_lines(5)]
    m2 = _parse(lines2)
    assert m2.meta["marker_names_padded"] == 19 and m2.n_markers == 24


def test_tsv_file_errors(tmp_path):
    with pytest.raises(MocapFormatError, match="no such file"):
        read_qtm_tsv(tmp_path / "absent.tsv")
    f = tmp_path / "empty.tsv"
    f.write_bytes(b"")
    with pytest.raises(MocapFormatError, match=r"empty.tsv:1: empty file"):
        read_qtm_tsv(f)
    with pytest.raises(MocapFormatError, match="unknown marker file suffix"):
        load_markers(TESTS_DIR / "data" / "README.md")


_FUZZ_BASE = None


def _fuzz_base() -> str:
    global _FUZZ_BASE
    if _FUZZ_BASE is None:
        _FUZZ_BASE = "\n".join(_excerpt_lines(12)) + "\n"
    return _FUZZ_BASE


_op = st.tuples(
    st.sampled_from(["insert", "delete", "replace", "dup_line", "drop_line", "swap_lines"]),
    st.floats(0, 1, exclude_max=True),
    st.sampled_from(list("\t\n\r0123456789.-+eE XYZ_a,")) | st.characters(),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ops=st.lists(_op, min_size=1, max_size=6), strict=st.booleans())
def test_fuzz_tsv_mutations_only_raise_mocap_format_error(ops, strict):
    text = _fuzz_base()
    for kind, where, ch in ops:
        if kind in ("insert", "delete", "replace"):
            i = int(where * (len(text) + 1))
            if kind == "insert":
                text = text[:i] + ch + text[i:]
            elif kind == "delete":
                text = text[:i] + text[i + 1:]
            else:
                text = text[:i] + ch + text[i + 1:]
        else:
            lines = text.split("\n")
            i = int(where * len(lines))
            if kind == "dup_line":
                lines.insert(i, lines[i])
            elif kind == "drop_line":
                del lines[i]
            elif i + 1 < len(lines):
                lines[i], lines[i + 1] = lines[i + 1], lines[i]
            text = "\n".join(lines)
    try:
        m = read_qtm_tsv_text(text, "fuzz.tsv", strict=strict)
    except MocapFormatError as exc:
        assert exc.path == "fuzz.tsv" and exc.problem
        assert exc.line is None or exc.line >= 1
    else:
        assert isinstance(m, Markers) and m.positions.shape == (m.n_frames, m.n_markers, 3)


@pytest.mark.shared
def test_shared_juggling_tsv(shared_data):
    path = shared_data / "juggling" / "5-ball-juggling-qualisys-300hz.tsv"
    t0 = time.perf_counter()
    m = read_qtm_tsv(path)
    elapsed = time.perf_counter() - t0
    assert elapsed < 1.0, f"reading took {elapsed:.2f} s"
    assert m.n_frames == 4967 == m.meta["qtm"]["NO_OF_FRAMES"]
    assert m.rate == 300.0 and m.n_markers == 24
    assert m.labels[:5] == JUGGLING_NAMES and m.labels[5] == "unnamed_6"
    ref = np.loadtxt(path, skiprows=12, delimiter="\t")
    np.testing.assert_array_equal(m.times, ref[:, 1])
    zero = _reference_zero_triplets(path)
    np.testing.assert_array_equal(m.missing, zero)
    assert zero.sum() == 69_872
    present = ~zero
    np.testing.assert_array_equal(m.positions[present], ref[:, 2:].reshape(4967, 24, 3)[present])
    np.testing.assert_allclose(np.diff(m.times), 1 / 300, atol=1e-5)


# ==================================================================================================
# C3D: what ezc3d reads is read (no false rejections), with warnings
# ==================================================================================================


def _ezc3d_positions(path: Path) -> np.ndarray:
    ref = ezc3d.c3d(str(path))
    return np.transpose(ref["data"]["points"][:3], (2, 1, 0))


def test_c3d_parameter_name_with_spaces_reads_like_ezc3d(tmp_path):
    # QTM writes parameter names with spaces ("Uncropped Measurement Length"): ezc3d reads them
    f = tmp_path / "qtm.c3d"
    _write_c3d(f)
    c = ezc3d.c3d(str(f))
    c.add_parameter("TRIAL", "UNCROPPED_MEASUREMENT_LENGTH", [1234.0])
    c.write(str(f))
    data = bytearray(f.read_bytes())
    i = data.find(b"UNCROPPED_MEASUREMENT_LENGTH")
    assert i > 0
    data[i:i + 28] = b"Uncropped Measurement Length"
    f.write_bytes(bytes(data))
    ref = ezc3d.c3d(str(f))
    assert "Uncropped Measurement Length" in ref["parameters"]["TRIAL"]
    m = read_c3d(f)
    assert "TRIAL" in m.meta["groups"] and m.meta["warnings"] == []
    np.testing.assert_array_equal(m.positions, _ezc3d_positions(f))
    np.testing.assert_array_equal(m.analog["values"], ref["data"]["analogs"][0].T)


@pytest.mark.parametrize("cut", [0, 5, 48, 49, 60, 63])
def test_c3d_truncated_data_reads_the_complete_frames_like_ezc3d(tmp_path, cut):
    # an Optotrak file whose data section is shorter than POINT:FRAMES says: ezc3d reads the
    # complete frames; so does read_c3d, with a warning. Frame = 3 points x 16 + 2 x 4 x 4 bytes = 80.
    f = tmp_path / "cut.c3d"
    exp = _write_c3d(f)
    data = f.read_bytes()
    dpos = 512 * (data[16] - 1)
    f.write_bytes(data[:dpos + 4 * 80 + cut])
    m = read_c3d(f)
    ref = ezc3d.c3d(str(f))
    assert m.n_frames == ref["data"]["points"].shape[2] == 4
    np.testing.assert_array_equal(m.positions, exp["positions"][:4])
    np.testing.assert_array_equal(m.analog["values"], ref["data"]["analogs"][0].T)
    np.testing.assert_array_equal(m.analog["values"], exp["analog"][:16])
    assert len(m.meta["warnings"]) == 1
    assert ("the data section is truncated" in m.meta["warnings"][0]
            and "holds 4 complete frames" in m.meta["warnings"][0])


@pytest.mark.parametrize("frames", [4, 9])
def test_c3d_header_frame_count_disagreeing_with_point_frames(tmp_path, frames):
    f = tmp_path / "hdr.c3d"
    exp = _write_c3d(f)
    data = bytearray(f.read_bytes())
    data[8:10] = frames.to_bytes(2, "little")  # header last frame; POINT:FRAMES still says 6
    f.write_bytes(bytes(data))
    m = read_c3d(f)
    assert m.n_frames == ezc3d.c3d(str(f))["data"]["points"].shape[2] == 6
    np.testing.assert_array_equal(m.positions, exp["positions"])
    assert m.meta["warnings"] == [f"the header says {frames} frames but POINT:FRAMES is 6"]


def test_c3d_header_point_count_disagreeing_with_point_used(tmp_path):
    f = tmp_path / "pts.c3d"
    exp = _write_c3d(f)
    data = bytearray(f.read_bytes())
    data[2:4] = (7).to_bytes(2, "little")  # header: 7 points, POINT:USED says 3 (ezc3d follows USED)
    f.write_bytes(bytes(data))
    m = read_c3d(f)
    np.testing.assert_array_equal(m.positions, exp["positions"])
    np.testing.assert_array_equal(m.positions, _ezc3d_positions(f))
    assert "the header says 7 points but POINT:USED is 3" in m.meta["warnings"][0]


def test_c3d_data_longer_than_declared_is_reported(tmp_path):
    f = tmp_path / "long.c3d"
    exp = _write_c3d(f)
    f.write_bytes(f.read_bytes() + bytes(80 * 10))  # 10 more frames' worth of bytes after the data
    m = read_c3d(f)
    assert m.n_frames == ezc3d.c3d(str(f))["data"]["points"].shape[2] == 6
    np.testing.assert_array_equal(m.positions, exp["positions"])
    assert len(m.meta["warnings"]) == 1 and "only the declared frames are read" in m.meta["warnings"][0]


@pytest.mark.parametrize("partial", [0, 100, 600, 639])
def test_c3d_truncated_file_has_only_the_truncation_warning(tmp_path, partial):
    # 40 markers: a frame is 640 bytes, so a leftover partial frame can exceed a 512-byte block; it
    # must not also be reported as "bytes after the declared frames (room for 0 more frames)"
    f = tmp_path / "cut.c3d"
    write_c3d(_random_markers(n=10, m=40, seed=3), f)
    data = f.read_bytes()
    dpos = 512 * (data[16] - 1)
    f.write_bytes(data[:dpos + 7 * 640 + partial])
    m = read_c3d(f)
    assert m.n_frames == ezc3d.c3d(str(f))["data"]["points"].shape[2] == 7
    assert len(m.meta["warnings"]) == 1, m.meta["warnings"]
    assert "the data section is truncated" in m.meta["warnings"][0]
    assert "holds 7 complete frames" in m.meta["warnings"][0]


def test_c3d_bytes_after_the_data_less_than_a_frame_are_not_reported(tmp_path):
    f = tmp_path / "pad.c3d"
    write_c3d(_random_markers(n=10, m=40, seed=3), f)
    data = f.read_bytes()
    dpos = 512 * (data[16] - 1)
    f.write_bytes(data[:dpos + 10 * 640] + bytes(600))  # 600 bytes: a block, not a frame (640)
    assert read_c3d(f).meta["warnings"] == []
    f.write_bytes(data[:dpos + 10 * 640] + bytes(2 * 640))
    w = read_c3d(f).meta["warnings"]
    assert len(w) == 1 and "room for 2 more frames" in w[0]


@pytest.mark.shared
def test_shared_c3d_cut_short_has_one_warning(shared_data, tmp_path):
    f = tmp_path / "bts_cut.c3d"
    data = (shared_data / "c3d" / "BTS.c3d").read_bytes()
    f.write_bytes(data[:-100])
    m = read_c3d(f)
    assert m.n_frames == ezc3d.c3d(str(f))["data"]["points"].shape[2] == 674
    assert len(m.meta["warnings"]) == 1 and "holds 674 complete frames" in m.meta["warnings"][0]


# ==================================================================================================
# C3D writer
# ==================================================================================================


def _random_markers(n=30, m=4, rate=120.0, first=0, units="mm", seed=0, analog=None) -> Markers:
    rng = np.random.default_rng(seed)
    p = rng.normal(scale=500.0, size=(n, m, 3))
    p[rng.random((n, m)) < 0.15] = np.nan
    labels = [f"M{k:03d}" for k in range(m)]
    return Markers((first + np.arange(n)) / rate, p, labels, rate, units=units, analog=analog)


def test_write_c3d_round_trip_against_ezc3d(tmp_path):
    rng = np.random.default_rng(1)
    an = {"labels": ("Fz", "EMG 1"), "rate": 1200.0, "values": rng.normal(size=(300, 2)), "units": ("N", "V")}
    mk = _random_markers(n=30, m=300, rate=120.0, first=10, units="m", analog=an)
    f = tmp_path / "w.c3d"
    write_markers(mk, f)
    assert oct(f.stat().st_mode & 0o777) == oct(0o666 & ~_umask())
    back = read_c3d(f)
    assert back.labels == mk.labels and back.rate == 120.0 and back.units == "m"
    np.testing.assert_array_equal(back.missing, mk.missing)
    np.testing.assert_array_equal(back.positions, mk.positions.astype(np.float32).astype(np.float64))
    np.testing.assert_allclose(back.times, mk.times, rtol=0, atol=1e-12)
    assert back.meta["first_frame"] == 11 and back.meta["warnings"] == []
    assert back.analog["labels"] == ("Fz", "EMG 1") and back.analog["rate"] == 1200.0
    assert back.analog["units"] == ("N", "V")
    np.testing.assert_array_equal(back.analog["values"], an["values"].astype(np.float32).astype(np.float64))
    # independently with ezc3d: labels over LABELS/LABELS2, units, rate, the invalid flag
    ref = ezc3d.c3d(str(f))
    pp = ref["parameters"]["POINT"]
    assert list(pp["LABELS"]["value"]) + list(pp["LABELS2"]["value"]) == list(mk.labels)
    assert pp["UNITS"]["value"][0] == "m" and pp["RATE"]["value"][0] == 120.0
    res = ref["data"]["meta_points"]["residuals"][0].T
    np.testing.assert_array_equal(res < 0, mk.missing)
    assert ref["header"]["points"]["first_frame"] == 10


@pytest.mark.parametrize("first", [65533, 65534, 65535, 3 * 65536 + 40000])
def test_write_c3d_late_first_frame_round_trip(tmp_path, first):
    # a take cropped late in a long recording: frame numbers beyond the header's 16 bits go to
    # TRIAL:ACTUAL_START_FIELD / ACTUAL_END_FIELD as [low, high] 16-bit words
    mk = _random_markers(n=20, m=3, rate=120.0, first=first, seed=5)
    f = tmp_path / "late.c3d"
    write_c3d(mk, f)
    back = read_c3d(f)
    assert back.meta["first_frame"] == first + 1 and back.meta["warnings"] == []
    np.testing.assert_allclose(back.times, mk.times, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(back.positions, mk.positions.astype(np.float32).astype(np.float64))
    ref = ezc3d.c3d(str(f))  # independently: what a C3D tool sees
    assert ref["data"]["points"].shape[2] == 20
    if first + 1 <= 0xFFFF:
        assert ref["header"]["points"]["first_frame"] == first  # ezc3d: 0-based
        assert "TRIAL" not in ref["parameters"] and back.meta["first_frame_from"] == "header"
        return
    assert back.meta["first_frame_from"] == "TRIAL:ACTUAL_START_FIELD"
    assert ref["header"]["points"]["first_frame"] == 0
    trial = ref["parameters"]["TRIAL"]
    for name, want in (("ACTUAL_START_FIELD", first + 1), ("ACTUAL_END_FIELD", first + 20)):
        assert trial[name]["type"] == 2  # integer words, as the C3D documentation defines them
        lo, hi = (int(v) & 0xFFFF for v in trial[name]["value"])
        assert lo + 65536 * hi == want


def test_write_c3d_refuses_negative_frames(tmp_path):
    from mocapkit.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="first frame number"):
        write_c3d(_random_markers(n=5, m=2, first=-3), tmp_path / "neg.c3d")
    assert not (tmp_path / "neg.c3d").exists()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_write_c3d_without_analog_and_its_rejections(tmp_path):
    from mocapkit.errors import InvalidParameterError
    from mocapkit.io.markers.c3d import write_c3d

    bad_an = {"labels": ("a",), "rate": 250.0, "values": np.zeros((75, 1))}  # 250/120 is no integer
    mk = _random_markers(n=30, m=3, analog=bad_an)
    with pytest.raises(InvalidParameterError, match="integer number of samples per frame"):
        write_c3d(mk, tmp_path / "a.c3d")
    write_c3d(mk, tmp_path / "a.c3d", analog=False)
    assert read_c3d(tmp_path / "a.c3d").analog is None
    t = np.arange(10) / 100.0
    t[5:] += 0.5  # a gap in time: C3D has no time column
    gap = Markers(t, np.zeros((10, 1, 3)), ("a",), 100.0)
    with pytest.raises(InvalidParameterError, match="frame 5 .* off the 100 Hz grid"):
        write_c3d(gap, tmp_path / "gap.c3d")
    assert not (tmp_path / "gap.c3d").exists()
    with pytest.raises(InvalidParameterError, match="markers are written to"):
        write_markers(gap, tmp_path / "x.bvh")


def test_write_markers_dispatch_round_trips(tmp_path):
    mk = _random_markers(n=12, m=3, rate=50.0, first=3)
    for suffix in (".csv", ".trc", ".c3d"):
        f = tmp_path / f"m{suffix}"
        write_markers(mk, f)
        back = load_markers(f)
        assert back.labels == mk.labels and kind_of(f) == "markers"
        np.testing.assert_array_equal(back.missing, mk.missing)
        tol = {".csv": 0, ".trc": 5e-7, ".c3d": 1e-3}[suffix]
        np.testing.assert_allclose(back.positions, mk.positions, rtol=0, atol=tol)
        np.testing.assert_allclose(back.times, mk.times, rtol=0, atol=1e-12)


# ==================================================================================================
# Vicon Nexus CSV export
# ==================================================================================================


def _vicon_reference(path: Path):
    """An independent parse of the excerpt with numpy.genfromtxt (block lines located by hand)."""
    lines = path.read_text().splitlines()
    t0 = lines.index("Trajectories")
    blank = lines.index("")
    dev = np.genfromtxt(path, delimiter=",", skip_header=5, max_rows=blank - 5)
    traj = np.genfromtxt(path, delimiter=",", skip_header=t0 + 5)
    return dev, traj


def test_vicon_csv_excerpt_reads_the_trajectories_and_devices():
    m = load_markers(VICON_CSV)
    dev, traj = _vicon_reference(VICON_CSV)
    assert m.meta["format"] == "vicon-csv" and m.meta["blocks"] == ["Devices", "Trajectories"]
    assert m.labels == ("walker:LPSI", "walker:LTB2", "walker:RTH1", "walker:LTH3")
    assert m.rate == 250.0 and m.units == "mm" and m.n_frames == 12
    np.testing.assert_allclose(m.times, (traj[:, 0] - 1) / 250.0, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m.positions.reshape(12, -1), traj[:, 2:])  # NaN where empty
    assert m.missing.sum(axis=0).tolist() == [6, 5, 0, 0]
    assert m.analog["rate"] == 2000.0 and m.analog["values"].shape == (96, 3)
    assert m.analog["labels"][2] == "Imported AMTI OR6 Series Force Plate #1 - Force Fz"
    np.testing.assert_array_equal(m.analog["values"], dev[:, 2:])
    assert m.analog["t0"] == m.times[0]


def test_vicon_csv_dispatch_keeps_the_other_csv_readers(tmp_path, tests_data):
    from mocapkit.io import load_signals

    assert kind_of(VICON_CSV) == "markers"
    generic = tests_data / "formats" / "generic.csv"
    assert kind_of(generic) == "imu" and len(load_signals(generic)) == 1
    wide = tmp_path / "wide.csv"
    write_markers_csv(_random_markers(n=5, m=2), wide)
    assert kind_of(wide) == "markers" and load_markers(wide).meta["format"] == "csv"


@pytest.mark.parametrize("variant", ["lf", "semicolon", "bom", "trajectories-only", "leading-blank"])
def test_vicon_csv_variants(tmp_path, variant):
    base = read_vicon_csv(VICON_CSV)
    text = VICON_CSV.read_text()
    if variant == "lf":
        text = text.replace("\r\n", "\n")
    elif variant == "semicolon":
        text = text.replace(",", ";")
    elif variant == "bom":
        text = "\ufeff" + text
    elif variant == "trajectories-only":
        text = text[text.index("Trajectories"):]
    else:
        text = "\n" + text
    f = tmp_path / "v.csv"
    f.write_text(text, encoding="utf-8", newline="")
    assert kind_of(f) == "markers"
    m = load_markers(f)
    assert m.labels == base.labels
    np.testing.assert_array_equal(m.positions, base.positions)
    assert (m.analog is None) == (variant == "trajectories-only")


def _vicon_lines() -> list[str]:
    return VICON_CSV.read_text().replace("\r\n", "\n").rstrip("\n").split("\n")


@pytest.mark.parametrize(
    ("edit", "line", "message"),
    [
        (lambda L: L[:103] + ["x250"] + L[104:], 104, "the rate 'x250' is not a number"),
        (lambda L: L[:105] + [L[105].replace("X,Y,Z,X", "X,Z,Y,X", 1)] + L[106:], 106, "expected X, Y, Z"),
        (lambda L: L[:107] + [L[107].replace("-2255.74", "1x", 1)] + L[108:], 108, "'1x' is not a number"),
        (lambda L: L[:108] + [L[107]] + L[109:], 109, "frame 262 does not follow frame 262"),
        (lambda L: L[:108] + [L[108] + ",1.0"] + L[109:], 109, "expected 14 cells"),
        (lambda L: L[:100], None, "no Trajectories block"),
        (lambda L: L[102:107], 5, "no data rows"),
    ],
)
def test_vicon_csv_rejections_name_the_line(tmp_path, edit, line, message):
    f = tmp_path / "bad.csv"
    f.write_text("\n".join(edit(_vicon_lines())) + "\n")
    with pytest.raises(MocapFormatError) as info:
        read_vicon_csv(f)
    assert info.value.line == line, info.value
    assert message in info.value.problem, info.value


_vop = st.tuples(st.sampled_from(["insert", "delete", "replace", "drop_line", "dup_line"]),
                 st.floats(0, 1, exclude_max=True), st.sampled_from(list(",;\n\r0123456789.-eE XYZ:") + ["", "nan"]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ops=st.lists(_vop, min_size=1, max_size=6))
def test_fuzz_vicon_csv_only_raises_mocap_format_error(ops):
    text = "\n".join(_vicon_lines()[102:]) + "\n"
    for kind, where, ch in ops:
        if kind in ("insert", "delete", "replace"):
            i = int(where * (len(text) + 1))
            text = {"insert": text[:i] + ch + text[i:], "delete": text[:i] + text[i + 1:],
                    "replace": text[:i] + ch + text[i + 1:]}[kind]
        else:
            lines = text.split("\n")
            i = int(where * len(lines))
            if kind == "dup_line":
                lines.insert(i, lines[i])
            else:
                del lines[i]
            text = "\n".join(lines)
    fd, name = tempfile.mkstemp(suffix=".csv")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        try:
            m = read_vicon_csv(name)
        except MocapFormatError as exc:
            assert exc.path == name and exc.problem
        else:
            assert m.positions.shape == (m.n_frames, m.n_markers, 3)
    finally:
        os.unlink(name)


# ==================================================================================================
# real files
# ==================================================================================================


@pytest.mark.shared
def test_every_shared_c3d_file_reads_like_ezc3d(shared_data):
    files = sorted((shared_data / "c3d").glob("*.c3d"))
    assert len(files) >= 5
    for path in files:
        m = read_c3d(path)
        ref = ezc3d.c3d(str(path))
        assert m.n_frames == ref["data"]["points"].shape[2] >= 100, path.name
        assert m.rate == float(ref["parameters"]["POINT"]["RATE"]["value"][0]) > 0
        np.testing.assert_array_equal(m.positions, np.transpose(ref["data"]["points"][:3], (2, 1, 0)))
        assert m.meta["warnings"] == [], (path.name, m.meta["warnings"])


@pytest.mark.shared
def test_vicon_csv_excerpt_equals_its_c3d_source(shared_data):
    src = read_c3d(shared_data / "c3d" / "vicon-nexus-walking2.c3d")
    m = read_vicon_csv(VICON_CSV)
    rows = slice(261, 273)  # frames 262-273
    cols = [src.index(lab.split(":")[1]) for lab in m.labels]
    np.testing.assert_array_equal(m.missing, src.missing[rows][:, cols])
    np.testing.assert_allclose(m.positions, src.positions[rows][:, cols], rtol=5e-6)  # 6 significant digits
    np.testing.assert_allclose(m.times, src.times[rows], rtol=0, atol=1e-12)
    ai = [src.analog["labels"].index(c) for c in ("Fx1", "Fy1", "Fz1")]
    np.testing.assert_allclose(m.analog["values"], src.analog["values"][261 * 8:273 * 8][:, ai], rtol=5e-6, atol=1e-9)


@pytest.mark.parametrize("n,m", [(120, 24), (32, 1), (33, 1), (10, 40)])
def test_own_c3d_reads_back_without_warnings(tmp_path, n, m):
    # ezc3d pads a data section ending on a 512-byte boundary with one more whole block: that padding
    # is not "bytes after the declared frames"
    f = tmp_path / "own.c3d"
    write_c3d(_random_markers(n=n, m=m, seed=1), f)
    data = f.read_bytes()
    assert 0 < len(data) - 512 * (data[16] - 1) - n * m * 16 <= 512
    assert read_c3d(f).meta["warnings"] == []
