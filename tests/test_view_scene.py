"""The viewer's scene (docs/viewer.md): what every panel holds, checked against the files read another
way — the BVH text itself, the compress job's own error figures, the filter's CSV output — and the
refusals (a segmentation of another take, a .mkp of other sensors, a table)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.view.arrays import decode_array, encode_array
from mocapkit.view.scene import build_scene

DATA = Path(__file__).parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
CLIP = DATA / "clip" / "walk-meredith-60.mkc"
FREYA = DATA / "bvh" / "perception-neuron-freya-12.bvh"
XIO = DATA / "xio"
NGIMU = DATA / "imu" / "xio" / "ngimu_quaternion.csv"
TSV = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"


def mocapkit(*args, check=True) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "mocapkit", *map(str, args)], capture_output=True, text=True, timeout=300,
                       check=False)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def test_arrays_round_trip_bit_exact_with_nan():
    a = np.array([[1.5, np.nan], [-0.0, 1e-300]])
    assert np.array_equal(decode_array(encode_array(a, "float64")), a, equal_nan=True)
    b = decode_array(encode_array(a))
    assert b.dtype == np.float32 and np.array_equal(b, a.astype(np.float32), equal_nan=True)
    bad = encode_array(a)
    bad["shape"] = [3, 2]
    with pytest.raises(MocapFormatError, match="do not hold"):
        decode_array(bad)


def _bvh_root_positions(path: Path) -> np.ndarray:
    """The root's position channels straight from the BVH text (first three values of every frame)."""
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 1
    return np.array([[float(v) for v in ln.split()[:3]] for ln in lines[start:] if ln.strip()])


def test_a_skeleton_and_its_clip(tmp_path):
    scene = json.loads(json.dumps(build_scene([BVH, CLIP]), allow_nan=False))  # strict JSON throughout
    orig, dec = scene["panels"]
    assert scene["timeline"]["frames"] == 60 and orig["role"] == "original" and dec["decoded_from"] == orig["id"]
    pos = decode_array(orig["positions"])
    assert pos.shape == (60, len(orig["joints"]), 3)
    # the clip knows its unit (2.54 cm per inch): the BVH it decodes is drawn in the same unit
    root = orig["parents"].index(-1)
    np.testing.assert_allclose(pos[:, root], _bvh_root_positions(BVH) * 2.54, rtol=0, atol=1e-4)
    assert any("2.54 cm" in n for n in scene["notes"])
    err = decode_array(dec["error"]).astype(np.float64)
    expect = np.linalg.norm(decode_array(dec["positions"]).astype(np.float64) - pos, axis=-1)
    np.testing.assert_allclose(err, expect, atol=1e-4)
    assert 0 < dec["max_error"] <= dec["bound"] + 1e-6  # the clip's bound (cm) holds at every joint
    assert abs(dec["bound"] - 0.05) < 1e-9


def test_two_different_skeletons_are_two_originals():
    scene = build_scene([BVH, FREYA])
    assert [p["role"] for p in scene["panels"]] == ["original", "original"]
    assert all(p["error"] is None for p in scene["panels"])


def test_imu_and_its_packets_match_the_compress_job(tmp_path):
    mkp = tmp_path / "x.mkp"
    rec = json.loads(mocapkit("compress", XIO, "--max-angle", "2", "-o", mkp, "--json").stdout)
    by_name = {s["name"]: s for s in (rec if isinstance(rec, list) else rec["signals"])}
    scene = build_scene([XIO, mkp])
    (panel,) = scene["panels"]
    assert {s["name"] for s in panel["sensors"]} == set(by_name)
    for s in panel["sensors"]:
        err = decode_array(s["error_deg"])
        assert np.isfinite(err).all() and s["bound_deg"] == 2.0
        assert s["max_error_deg"] == pytest.approx(by_name[s["name"]]["max_deg"], abs=1e-4)
        assert len(decode_array(s["keyframes"])) == by_name[s["name"]]["n_points"]
        q, d = decode_array(s["original"]), decode_array(s["decoded"])
        assert q.shape == d.shape == (by_name[s["name"]]["n_samples"], 4)
    assert scene["timeline"]["frames"] == by_name[panel["sensors"][0]["name"]]["n_samples"]


def test_points_csv_and_a_lone_mkp(tmp_path):
    mkp, pts = tmp_path / "n.mkp", tmp_path / "n.csv"
    rec = json.loads(mocapkit("compress", NGIMU, "--max-angle", "2", "-o", mkp, "--json").stdout)
    mocapkit("decompress", mkp, "-o", pts)
    sig = (rec if isinstance(rec, list) else rec["signals"])[0]
    (s,) = build_scene([NGIMU, pts])["panels"][0]["sensors"]
    assert s["max_error_deg"] == pytest.approx(sig["max_deg"], abs=1e-4)
    (lone,) = build_scene([mkp])["panels"][0]["sensors"]
    assert lone["original"] is None and np.isfinite(decode_array(lone["decoded"])).all()
    assert len(decode_array(lone["times"])) == sig["n_samples"]  # every tick from the first to the last point


def test_packets_of_other_sensors_are_refused(tmp_path):
    mkp = tmp_path / "x.mkp"
    mocapkit("compress", XIO, "--max-angle", "2", "-o", mkp)
    with pytest.raises(InvalidParameterError, match="not those of"):
        build_scene([NGIMU, mkp])


def test_markers_with_the_filter_pieces_equal_the_filtered_csv(tmp_path):
    from mocapkit.io.loaders import load_markers

    mk = load_markers(TSV)
    chosen = mk.labels[:2]
    fit_json, fit_csv = tmp_path / "fit.json", tmp_path / "fit.csv"
    fit_json.write_text(mocapkit("filter", TSV, "--markers", ",".join(chosen), "--auto", "--json").stdout)
    mocapkit("filter", TSV, "--markers", ",".join(chosen), "--auto", "-o", fit_csv)
    table = np.loadtxt(fit_csv, delimiter=",", skiprows=1)
    scene = build_scene([TSV], filter_json=fit_json)
    (panel,) = scene["panels"]
    fitted = decode_array(panel["fitted"]).astype(np.float64)
    for k, label in enumerate(chosen):
        m = mk.labels.index(label)
        ok = ~np.isnan(table[:, 1 + 3 * k])
        np.testing.assert_allclose(fitted[ok, m], table[ok, 1 + 3 * k:4 + 3 * k], rtol=0, atol=1e-3)
    assert np.isnan(fitted[:, [mk.labels.index(x) for x in mk.labels[2:]]]).all()
    sigs = json.loads(fit_json.read_text())
    for kn in panel["knots"]:
        label = mk.labels[kn["marker"]]
        expect = sorted({p["t0"] for s in sigs if s["name"] == label for p in s["pieces"][1:]})
        assert kn["times"] == pytest.approx(expect)
    assert np.array_equal(decode_array(panel["positions"]), mk.positions.astype(np.float32), equal_nan=True)


def test_filter_json_of_another_file_is_refused(tmp_path):
    bad = tmp_path / "fit.json"
    bad.write_text(json.dumps([{"name": "NOPE", "components": ["NOPE_x"],
                                "pieces": [{"t0": 0, "t1": 1, "coeffs": [1]}]}]))
    with pytest.raises(MocapFormatError, match="NOPE_x"):
        build_scene([TSV], filter_json=bad)
    bad.write_text("[{\"name\": 1,\n oops")
    with pytest.raises(MocapFormatError, match=r"fit\.json:2"):
        build_scene([TSV], filter_json=bad)


def test_segments_on_the_timeline_and_refused_for_another_take(tmp_path):
    amc, asf = DATA / "cmu" / "86_01_15hz_first1600.amc", DATA / "cmu" / "86.asf"
    seg = tmp_path / "seg.json"
    seg.write_text(mocapkit("segment", amc, "--asf", asf, "--method", "auto", "--rate", "15", "--json").stdout)
    rec = json.loads(seg.read_text())
    assert rec["cuts"], "the excerpt has several actions"
    scene = build_scene([amc], segments=seg, asf=asf, rate=15)
    times = decode_array(scene["timeline"]["times"])
    assert [c["frame"] for c in scene["segments"]["cuts"]] == [c["frame"] for c in rec["cuts"]]
    assert [c["time_s"] for c in scene["segments"]["cuts"]] == [times[c["frame"]] for c in rec["cuts"]]
    assert [s["action"] for s in scene["segments"]["segments"]] == [s["action"] for s in rec["segments"]]
    with pytest.raises(InvalidParameterError, match=f"{rec['n_frames']} frames"):
        build_scene([BVH], segments=seg)
    seg.write_text(json.dumps({"job": "filter"}))
    with pytest.raises(MocapFormatError, match="segment --json"):
        build_scene([BVH], segments=seg)


def test_a_table_and_nothing_are_refused():
    with pytest.raises(InvalidParameterError, match="nothing to draw"):
        build_scene([DATA / "opensim" / "subject01_walk1_ik-first20.mot"])
    with pytest.raises(InvalidParameterError):
        build_scene([])


def test_a_gltf_decode_is_paired_and_within_its_bound(tmp_path):
    glb = tmp_path / "w.glb"
    mocapkit("compress", BVH, "--max-position-error", "0.5", "-o", glb)
    orig, dec = build_scene([BVH, glb])["panels"]
    assert dec["role"] == "decoded" and dec["decoded_from"] == orig["id"]
    assert 0 < dec["max_error"] <= 0.5 + 1e-6


def _shifted(src: Path, dst: Path, rows: int | None = None, dt: float = 0.0) -> Path:
    """``src`` (a ``Time (s),W,X,Y,Z`` CSV) with its first ``rows`` samples, its clock moved by ``dt`` s."""
    lines = src.read_text().splitlines()
    body = lines[1:] if rows is None else lines[1:1 + rows]
    out = [lines[0]] + [",".join([f"{float(ln.split(',')[0]) + dt:.3f}", *ln.split(",")[1:]]) for ln in body]
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text("\n".join(out) + "\n")
    return dst


def test_compressions_of_another_recording_are_refused(tmp_path):
    """Same sensor name, but a shorter take or another clock: refused, not drawn with a decode that stops
    short (samples with no error) or keyframes at the wrong times."""
    short = _shifted(NGIMU, tmp_path / "short" / NGIMU.name, rows=12)
    later = _shifted(NGIMU, tmp_path / "later" / NGIMU.name, dt=100.0)
    for src in (short, later):
        mkp, pts = tmp_path / f"{src.parent.name}.mkp", tmp_path / f"{src.parent.name}.csv"
        mocapkit("compress", src, "--max-angle", "2", "-o", mkp)
        mocapkit("decompress", mkp, "-o", pts)
        with pytest.raises(InvalidParameterError, match="not a compression of this file"):
            build_scene([NGIMU, mkp])
        if src is later:  # a points CSV does not say its sample count; its times do
            with pytest.raises(InvalidParameterError, match="101.254 s"):
                build_scene([NGIMU, pts])
    (s,) = build_scene([later, tmp_path / "later.mkp"])["panels"][0]["sensors"]  # its own file: fine
    assert np.isfinite(decode_array(s["error_deg"])).all()


def test_a_second_compression_of_the_same_file_gets_its_own_panel(tmp_path):
    recs = {}
    for deg in ("2", "5"):
        rec = json.loads(mocapkit("compress", XIO, "--max-angle", deg, "-o", tmp_path / f"x{deg}.mkp", "--json").stdout)
        recs[float(deg)] = {s["name"]: s for s in (rec if isinstance(rec, list) else rec["signals"])}
    scene = build_scene([XIO, tmp_path / "x2.mkp", tmp_path / "x5.mkp"])
    assert [p["name"] for p in scene["panels"]] == ["xio + x2.mkp", "xio + x5.mkp"]
    for panel in scene["panels"]:
        for s in panel["sensors"]:
            assert s["max_error_deg"] == pytest.approx(recs[s["bound_deg"]][s["name"]]["max_deg"], abs=1e-4)
    assert {s["bound_deg"] for p in scene["panels"] for s in p["sensors"]} == {2.0, 5.0}


def test_a_points_csv_of_no_unit_quaternions_names_the_line(tmp_path):
    pts = tmp_path / "p.csv"
    pts.write_text("time,w,x,y,z,tick,gap_before\n0,1,0,0,0,0,0\n\n0.1,0,0,0,0,5,0\n")
    with pytest.raises(MocapFormatError, match=r"p\.csv:4: point 2: .* not a unit quaternion"):
        build_scene([pts])


def test_segments_outside_the_frames_are_refused(tmp_path):
    seg = tmp_path / "seg.json"
    good = {"job": "segment", "file": str(BVH), "n_frames": 60, "method": "auto",
            "cuts": [{"frame": 30, "time_s": 1.0}],
            "segments": [{"t0": 0, "t1": 1, "frame0": 0, "frame1": 30}, {"t0": 1, "t1": 2, "frame0": 30, "frame1": 60}]}
    seg.write_text(json.dumps(good))
    assert build_scene([BVH], segments=seg)["segments"]["cuts"][0]["frame"] == 30
    for cut, seg1 in ((-3, 30), (60, 30), (30, 61), (30, 0)):  # -3 would be frame 57 by Python's indexing
        bad = json.loads(json.dumps(good))
        bad["cuts"][0]["frame"] = cut
        bad["segments"][0]["frame1"] = seg1
        seg.write_text(json.dumps(bad))
        with pytest.raises(MocapFormatError, match=r"seg\.json: (cut at frame|segment of frames)"):
            build_scene([BVH], segments=seg)


def test_an_mvnx_and_its_clip_stand_z_up(tmp_path):
    mvnx = DATA / "mvnx" / "86_01_xsens_60hz.mvnx"
    clip = tmp_path / "m.mkc"
    mocapkit("compress", mvnx, "--max-position-error", "1", "-o", clip)
    panels = build_scene([mvnx, clip])["panels"]
    assert [p["role"] for p in panels] == ["original", "decoded"]
    for p in panels:
        pos = decode_array(p["positions"]).astype(np.float64)
        height = pos[..., 2].max(axis=1) - pos[..., 2].min(axis=1)  # head to toe, per frame
        assert p["up"] == "z" and height.min() > 100  # a standing person, in cm


def test_knots_are_the_piece_starts_at_the_filtered_values(tmp_path):
    """Pieces with knots (the marker's x and z only): the knots and their positions against the filter's
    own CSV at the knot's sample; the axis not filtered stays NaN."""
    from mocapkit.io.loaders import load_markers

    mk = load_markers(TSV)
    fit_json, fit_csv = tmp_path / "fit.json", tmp_path / "fit.csv"
    args = (TSV, "--markers", "unnamed_6:xz", "--penalty", "5")
    fit_json.write_text(mocapkit("filter", *args, "--json").stdout)
    mocapkit("filter", *args, "-o", fit_csv)
    table = np.loadtxt(fit_csv, delimiter=",", skiprows=1)
    (sig,) = json.loads(fit_json.read_text())
    expect = [p["t0"] for p in sig["pieces"][1:]]
    assert len(expect) >= 2, "the test needs knots"
    (panel,) = build_scene([TSV], filter_json=fit_json)["panels"]
    (kn,) = panel["knots"]
    m = mk.labels.index("unnamed_6")
    assert kn["marker"] == m and kn["times"] == pytest.approx(expect)
    for t, (x, y, z) in zip(kn["times"], kn["positions"], strict=True):
        row = table[np.argmin(np.abs(table[:, 0] - t))]
        assert abs(row[0] - t) < 1e-9 and y is None
        assert (x, z) == pytest.approx((row[1], row[2]), abs=1e-6)
    fitted = decode_array(panel["fitted"]).astype(np.float64)
    np.testing.assert_allclose(fitted[:, m, [0, 2]], table[:, 1:3], rtol=0, atol=1e-3)
    assert np.isnan(fitted[:, m, 1]).all()


def test_a_declared_unit_is_kept_and_the_clip_is_drawn_in_it(tmp_path):
    """An AMC knows its unit (ASF); a clip made with another --unit-cm is drawn in the AMC's unit, its bound
    converted, so the per-joint errors compare like with like and stay within the bound."""
    amc, asf = DATA / "cmu" / "86_01_first60.amc", DATA / "cmu" / "86.asf"
    clip = tmp_path / "c.mkc"
    mocapkit("compress", amc, "--asf", asf, "--unit-cm", "1", "--max-position-error", "0.2", "-o", clip)
    from mocapkit.io.loaders import load_motion

    declared = load_motion(amc, asf=asf).skeleton.meta["length_unit_cm"]
    assert abs(declared - 1) > 0.1
    scene = build_scene([amc, clip], asf=asf)
    orig, dec = scene["panels"]
    assert any("differs" in n for n in scene["notes"]) and not any("no length unit" in n for n in scene["notes"])
    assert dec["bound"] == pytest.approx(0.2 * declared)
    assert 0 < dec["max_error"] <= dec["bound"] * (1 + 1e-6)
    alone = build_scene([amc], asf=asf)["panels"][0]
    assert np.array_equal(decode_array(alone["positions"]), decode_array(orig["positions"]))


def test_a_segmentation_of_another_file_name_gets_a_note(tmp_path):
    amc, asf = DATA / "cmu" / "86_01_15hz_first1600.amc", DATA / "cmu" / "86.asf"
    seg = tmp_path / "seg.json"
    seg.write_text(mocapkit("segment", amc, "--asf", asf, "--method", "auto", "--rate", "15", "--json").stdout)
    other = tmp_path / "other.amc"
    other.write_bytes(amc.read_bytes())
    notes = build_scene([other], segments=seg, asf=asf, rate=15)["notes"]
    assert any("a segmentation of 86_01_15hz_first1600.amc" in n for n in notes)
    assert not any("a segmentation of" in n for n in build_scene([amc], segments=seg, asf=asf, rate=15)["notes"])


def test_compressed_files_pair_whatever_the_order(tmp_path):
    scene = build_scene([CLIP, BVH])
    assert [(p["name"], p["role"]) for p in scene["panels"]] == [("walk-meredith-60.bvh", "original"),
                                                                 ("walk-meredith-60.mkc", "decoded")]
    assert scene["timeline"]["frames"] == 60 and scene["timeline"]["source"] == scene["panels"][0]["id"]
    mkp = tmp_path / "n.mkp"
    mocapkit("compress", NGIMU, "--max-angle", "2", "-o", mkp)
    (panel,) = build_scene([mkp, NGIMU])["panels"]
    assert panel["sensors"][0]["decoded"] is not None and panel["sensors"][0]["original"] is not None


def test_a_clip_of_another_take_gets_a_note():
    scene = build_scene([FREYA, CLIP])
    assert [p["role"] for p in scene["panels"]] == ["original", "original"]
    assert any("walk-meredith-60.mkc: a compressed clip whose joints are those of no other file" in n
               for n in scene["notes"])
    assert not any("compressed clip" in n for n in build_scene([CLIP])["notes"])


def test_a_c3d_says_which_axis_is_up(tmp_path):
    """POINT:Y_SCREEN (the axis drawn upward) sets the panel's vertical axis; z when the file does not say."""
    ezc3d = pytest.importorskip("ezc3d")
    from mocapkit.io.loaders import load_markers

    for screen, up in (("+Y", "y"), ("+Z", "z"), (None, "z")):
        c = ezc3d.c3d()
        c["parameters"]["POINT"]["RATE"]["value"] = [100.0]
        c["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B"]
        if screen is not None:
            c.add_parameter("POINT", "Y_SCREEN", [screen])
        pts = np.ones((4, 2, 5))
        pts[:3] = np.arange(30, dtype=float).reshape(3, 2, 5)
        c["data"]["points"] = pts
        f = tmp_path / f"up{up}{screen is None}.c3d"
        c.write(str(f))
        assert load_markers(f).meta.get("up_axis") == screen
        assert build_scene([f])["panels"][0]["up"] == up


def test_the_shared_bts_c3d_stands_y_up(shared_data):
    assert build_scene([shared_data / "c3d" / "BTS.c3d"])["panels"][0]["up"] == "y"
    assert build_scene([shared_data / "c3d" / "Vicon.c3d"])["panels"][0]["up"] == "z"


def test_an_unlikely_height_in_assumed_centimetres_gets_a_hint(tmp_path):
    bvh = tmp_path / "tiny.bvh"
    bvh.write_text("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Xposition Yposition Zposition\n"
                   "\tJOINT Head\n\t{\n\t\tOFFSET 0 1.7 0\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n"
                   "\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 0.2 0\n\t\t}\n\t}\n}\n"
                   "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0 0 0 0\n0 0 0 0 0 0\n")
    notes = build_scene([bvh])["notes"]
    assert any("it would be 1.7 cm tall: give --unit-cm" in n for n in notes), notes
    assert not any("tall" in n for n in build_scene([bvh], unit_cm=100)["notes"])
    assert not any("tall" in n for n in build_scene([BVH])["notes"])
