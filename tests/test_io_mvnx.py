"""Xsens MVNX reader (mocapkit.io.skeletal.mvnx): the excerpt's frames, labels and rate, forward kinematics
against the file's own segment positions (parsed independently with ElementTree), soft-body files,
times, malformed files and the command line (info, convert, compress, segment)."""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import make_mvnx
from mocapkit.errors import MocapFormatError
from mocapkit.io.loaders import kind_of, load_motion
from mocapkit.io.skeletal.bvh import read_bvh
from mocapkit.io.skeletal.mvnx import ROOT_CHANNELS, read_mvnx
from mocapkit.skeleton import forward_kinematics

DATA = Path(__file__).resolve().parent / "data"
EXCERPT = DATA / "mvnx" / "86_01_xsens_60hz.mvnx"
MVN_SEGMENTS = (
    "Pelvis", "L5", "L3", "T12", "T8", "Neck", "Head",
    "RightShoulder", "RightUpperArm", "RightForeArm", "RightHand",
    "LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand",
    "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToe",
    "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToe",
)


def _file_arrays(path: Path):
    """Reference read with ElementTree (whole tree in memory): segment labels, connectors, points,
    and the normal frames' orientations (N, S, 4) and positions (N, S, 3)."""
    root = ET.parse(path).getroot()
    ns = root.tag[: root.tag.index("}") + 1] if root.tag.startswith("{") else ""
    subj = root.find(f"{ns}subject")
    labels, points = [], {}
    for seg in subj.find(f"{ns}segments"):
        labels.append(seg.get("label"))
        points[seg.get("label")] = {p.get("label"): np.array(p.find(f"{ns}pos_b").text.split(), float)
                                    for p in seg.find(f"{ns}points")}
    joints = [(j.find(f"{ns}connector1").text.split("/"), j.find(f"{ns}connector2").text.split("/"))
              for j in subj.find(f"{ns}joints")]
    q, p, types = [], [], []
    for fr in subj.find(f"{ns}frames"):
        types.append(fr.get("type"))
        if fr.get("type") == "normal":
            q.append(np.array(fr.find(f"{ns}orientation").text.split(), float).reshape(-1, 4))
            p.append(np.array(fr.find(f"{ns}position").text.split(), float).reshape(-1, 3))
    return labels, points, joints, np.array(q), np.array(p), types, float(subj.get("frameRate"))


def _world_by_label(m):
    P, R = forward_kinematics(m)
    return {n: (P[:, j], R[:, j]) for j, n in enumerate(m.skeleton.names)}


def _max_position_difference(m, path: Path) -> float:
    labels, _, _, _, pos, _, _ = _file_arrays(path)
    world = _world_by_label(m)
    return max(float(np.abs(world[lab][0] - pos[:, s]).max()) for s, lab in enumerate(labels))


# --------------------------------------------------------------------------------------------------
# the excerpt
# --------------------------------------------------------------------------------------------------


def test_excerpt_frames_labels_rate_and_skipped_calibration() -> None:
    m = read_mvnx(EXCERPT)
    labels, points, joints, q, pos, types, rate = _file_arrays(EXCERPT)
    assert types[:3] == ["identity", "tpose", "tpose-isb"] and types.count("normal") == 30
    assert m.n_frames == 30 and m.rate == pytest.approx(60.0) and rate == 60.0
    np.testing.assert_allclose(m.times, np.arange(30) / 60.0, atol=1e-12)
    assert m.meta["skipped_frames"] == {"identity": 1, "tpose": 1, "tpose-isb": 1}
    assert m.meta["n_skipped_frames"] == 3
    sk = m.skeleton
    assert set(sk.names) == set(MVN_SEGMENTS) and sk.names[0] == "Pelvis"
    assert sk.meta["length_unit_cm"] == 100.0 and m.meta["up_axis"] == "Z"
    assert sk.channels[0] == ROOT_CHANNELS and all(not sk.has_position(j) for j in range(1, sk.n_joints))
    # every parent is the segment of connector1, every offset the connector points' difference
    for (ps, pp), (cs, cp) in joints:
        j = sk.index(cs)
        assert sk.names[sk.parents[j]] == ps
        np.testing.assert_array_equal(sk.offsets[j], points[ps][pp] - points[cs][cp])
    # leaf segments end at their farthest point
    ends = {sk.names[j]: off for j, off in sk.end_sites}
    assert set(ends) == {"Head", "RightHand", "LeftHand", "RightToe", "LeftToe"}
    np.testing.assert_array_equal(ends["Head"], points["Head"]["pTopOfHead"])


def test_fk_reproduces_the_files_segment_positions_and_orientations() -> None:
    """FK of the read motion vs every segment's <position> and <orientation> in every normal frame."""
    m = read_mvnx(EXCERPT)
    labels, _, _, q, pos, _, _ = _file_arrays(EXCERPT)
    world = _world_by_label(m)
    dpos = max(float(np.abs(world[lab][0] - pos[:, s]).max()) for s, lab in enumerate(labels))
    # six decimals in the file: positions and quaternions rounded to 5e-7 -> a few micrometres
    assert dpos < 1e-5, f"largest FK vs file difference {dpos * 1e6:.3g} um"
    dang = 0.0
    for s, lab in enumerate(labels):
        fk = Rotation.from_matrix(world[lab][1])
        ref = Rotation.from_quat(np.roll(q[:, s], -1, axis=1))
        dang = max(dang, float(np.degrees((fk.inv() * ref).magnitude()).max()))
    assert dang < 1e-4
    # the gap between connector offsets and the file's own translations is text rounding only
    assert 0 < m.meta["max_joint_gap_m"] < 5e-6 and m.meta["animated_offsets"] == []


def test_local_rotations_are_parent_inverse_times_child() -> None:
    m = read_mvnx(EXCERPT)
    labels, _, _, q, _, _, _ = _file_arrays(EXCERPT)
    G = {lab: Rotation.from_quat(np.roll(q[:, s], -1, axis=1)) for s, lab in enumerate(labels)}
    sk = m.skeleton
    for j, name in enumerate(sk.names):
        ref = G[name] if sk.parents[j] < 0 else G[sk.names[sk.parents[j]]].inv() * G[name]
        got = Rotation.from_quat(np.roll(m.rotations[:, j], -1, axis=1))
        assert np.degrees((got.inv() * ref).magnitude()).max() < 1e-9, name


def test_load_motion_and_kind_of() -> None:
    assert kind_of(EXCERPT) == "skeletal"
    assert load_motion(EXCERPT).n_frames == 30
    with pytest.raises(MocapFormatError, match="frameRate"):
        load_motion(EXCERPT, rate=100)


# --------------------------------------------------------------------------------------------------
# soft body, times, layout variants (files made by the generator or by editing the excerpt)
# --------------------------------------------------------------------------------------------------


def _generated(tmp_path: Path, name: str, **kw) -> Path:
    cmu = DATA / "cmu"
    data = make_mvnx.build(cmu / "86.asf", cmu / "86_01_first60.amc", stride=2, **kw)
    out = tmp_path / name
    make_mvnx.write(out, data, rate=60.0, note="test")
    return out


def test_soft_body_gets_position_channels_and_still_reproduces_positions(tmp_path: Path) -> None:
    soft = _generated(tmp_path, "soft.mvnx", soft_m=0.003, seed=1)
    m = read_mvnx(soft)
    assert len(m.meta["animated_offsets"]) == 22 and m.meta["max_joint_gap_m"] > 1e-3
    assert any("segment lengths vary" in w for w in m.meta["warnings"])
    assert all(m.skeleton.has_position(j) for j in range(m.skeleton.n_joints))
    assert _max_position_difference(m, soft) < 1e-5
    # a rigid reading of the same file (tolerance 1 m) cannot reproduce it: the channels are needed
    rigid = read_mvnx(soft, gap_tolerance_m=1.0)
    assert rigid.meta["animated_offsets"] == []
    assert _max_position_difference(rigid, soft) > 2e-3


def test_times_from_the_time_attribute(tmp_path: Path) -> None:
    text = EXCERPT.read_text()
    no_rate = tmp_path / "norate.mvnx"
    no_rate.write_text(re.sub(r' frameRate="60"', "", text, count=1))
    m = read_mvnx(no_rate)
    assert m.meta["times_from"].startswith("time attribute")
    np.testing.assert_allclose(m.times, np.round(np.arange(30) * 1000 / 60) / 1000)
    assert m.rate == pytest.approx(60.0, rel=0.05)
    jitter = tmp_path / "jitter.mvnx"
    jitter.write_text(text.replace('time="83" index="5"', 'time="90" index="5"'))
    m = read_mvnx(jitter)
    assert m.meta["times_from"] == "time attribute" and m.times[5] == pytest.approx(0.090)
    assert any("differ from frameRate" in w for w in m.meta["warnings"])


def test_without_namespace_and_with_prefix(tmp_path: Path) -> None:
    text = EXCERPT.read_text()
    plain = tmp_path / "plain.mvnx"
    plain.write_text(text.replace(' xmlns="http://www.xsens.com/mvn/mvnx"', ""))
    prefixed = tmp_path / "prefixed.mvnx"
    prefixed.write_text(re.sub(r"<(/?)(?!\?)", r"<\1x:", text).replace(
        ' xmlns="http://www.xsens.com/mvn/mvnx"', ' xmlns:x="http://www.xsens.com/mvn/mvnx"'))
    ref = read_mvnx(EXCERPT)
    for f in (plain, prefixed):
        m = read_mvnx(f)
        np.testing.assert_array_equal(m.rotations, ref.rotations)
        np.testing.assert_array_equal(m.translations, ref.translations)


# --------------------------------------------------------------------------------------------------
# malformed files: MocapFormatError with the path and the line
# --------------------------------------------------------------------------------------------------


def _line_of(text: str, needle: str) -> int:
    return text[: text.index(needle)].count("\n") + 1


def _cases():
    text = EXCERPT.read_text()
    f3 = 'time="50" index="3"'
    cut = text.index(f3) + 300

    def orientation_of(t, marker):  # the <orientation> line of the frame with `marker`
        i = t.index(marker)
        return t[: t.index("<orientation>", i)].count("\n") + 1

    yield "truncated", text[:cut], text[:cut].count("\n") + 1, "malformed XML"
    yield "not xml", "hello\n", 1, "malformed XML"
    yield "empty", "", 1, "malformed XML"
    yield "wrong root", '<?xml version="1.0"?>\n<motion version="1"/>\n', 2, "root element is <motion>"
    bad = text.replace('<frame time="50" index="3"', '<frame time="50" index="3" bad="x" bad="y"', 1)
    yield "duplicate attribute", bad, _line_of(bad, f3), "malformed XML"
    # a normal frame without <position>
    i = text.index(f3)
    j = text.index("<position>", i)
    k = text.index("</position>", j) + len("</position>")
    yield "no position", text[:j] + text[k:], _line_of(text, f3), "no <position>"
    # an orientation with a number missing
    j = text.index("<orientation>", i) + len("<orientation>")
    t = text[:j] + text[text.index(" ", j) + 1:]
    yield "short orientation", t, orientation_of(t, f3), "holds 91 numbers, expected 4 per segment"
    t = text[:j] + "0.9x " + text[text.index(" ", j) + 1:]
    yield "not a number", t, orientation_of(t, f3), "'0.9x' is not a number"
    t = text[:j] + "nan 0 0 0 " + text[j:].split(" ", 4)[4]
    yield "nan", t, orientation_of(t, f3), "NaN or infinite"
    z = text[:j] + "0 0 0 0 " + text[j:].split(" ", 4)[4]
    yield "zero quaternion", z, _line_of(z, f3), "zero orientation quaternion"
    t = text.replace("<connector1>RightUpperArm/jRightElbow</connector1>",
                     "<connector1>RightArm/jRightElbow</connector1>")
    yield "unknown segment", t, _line_of(t, "RightArm/jRightElbow"), "no segment 'RightArm'"
    t = text.replace("<connector2>RightForeArm/jRightElbow</connector2>",
                     "<connector2>RightForeArm/jElbow</connector2>")
    yield "unknown point", t, _line_of(t, "RightForeArm/jElbow"), "has no point 'jElbow'"
    t = text.replace("<connector1>L5/jL4L3</connector1>", "<connector1>L5 jL4L3</connector1>")
    yield "connector syntax", t, _line_of(t, "L5 jL4L3"), "is not 'Segment/point'"
    t = text.replace("<connector2>L5/jL5S1</connector2>", "<connector2>L3/jL4L3</connector2>")
    second = t.index("<connector2>L3/jL4L3</connector2>", t.index("<connector2>L3/jL4L3</connector2>") + 1)
    yield "two parents", t, t[:second].count("\n") + 1, "already has the parent"
    t = text.replace('type="normal"', 'type="tpose"')
    yield "no normal frames", t, None, "no normal frames"
    t = text.replace('<segment label="L3" id="3">', '<segment label="L5" id="3">')
    yield "duplicate segment", t, _line_of(t, '<segment label="L5" id="3">'), "defined twice"
    t = text.replace(f3, 'time="33" index="3"')
    yield "time goes back", t, _line_of(t, 'time="33" index="3"'), "is not after the previous"
    t = text.replace('frameRate="60"', 'frameRate="sixty"')
    yield "bad rate", t, _line_of(t, 'frameRate="sixty"'), "is not a number"
    t = text.replace("<pos_b>0.000000 0.000000 0.000000</pos_b>", "<pos_b>0 0</pos_b>", 1)
    yield "short pos_b", t, _line_of(t, "<pos_b>0 0</pos_b>"), "expected 3 numbers"
    # a <segment> holding <points> outside <segments>: before any segment (was an IndexError) and
    # after them (its points were filed under the last segment)
    stray = ('<segment label="Stray">\n<points>\n<point label="pStray">\n<pos_b>0 0 0</pos_b>\n</point>\n'
             '</points>\n</segment>\n')
    for where, anchor in (("before", "<segments>"), ("after", "</segments>")):
        i = text.index(anchor) + (len(anchor) + 1 if where == "after" else 0)
        t = text[:i] + stray + text[i:]
        yield (f"segment outside segments {where}", t, _line_of(t, '<point label="pStray">'),
               "outside mvnx/subject/segments")
    i = text.index("<orientation>", text.index(f3))
    t = text[:i] + '<frames><frame type="normal"/></frames>' + text[i:]
    yield "frames inside a frame", t, _line_of(t, '<frame type="normal"/>'), "outside mvnx/subject/frames"
    t = text[:i + 13] + "<x/>" + text[i + 13:]
    yield "element inside orientation", t, _line_of(t, "<x/>"), "holds text only"


CASES = list(_cases())


@pytest.mark.parametrize("name,text,line,fragment", CASES, ids=[c[0] for c in CASES])
def test_malformed_files_name_the_line(tmp_path: Path, name: str, text: str, line: int | None, fragment: str) -> None:
    f = tmp_path / "bad.mvnx"
    f.write_text(text)
    with pytest.raises(MocapFormatError) as ei:
        read_mvnx(f)
    e = ei.value
    assert e.path == str(f) and e.line == line and fragment in e.problem, str(e)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MocapFormatError, match="No such file"):
        read_mvnx(tmp_path / "missing.mvnx")


# --------------------------------------------------------------------------------------------------
# the command line
# --------------------------------------------------------------------------------------------------


def _run(*args):
    return subprocess.run([sys.executable, "-m", "mocapkit.cli", *map(str, args)], capture_output=True, text=True)


def test_cli_info_convert_compress(tmp_path: Path) -> None:
    r = _run("info", EXCERPT, "--json")
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    assert rec["kind"] == "skeletal" and rec["frames"] == 30 and rec["joints"] == 23
    assert rec["rate_hz"] == pytest.approx(60.0) and rec["roots"] == ["Pelvis"]
    assert rec["joint_names"][:7] == list(MVN_SEGMENTS[:7])

    out = tmp_path / "x.bvh"
    r = _run("convert", EXCERPT, out)
    assert r.returncode == 0, r.stderr
    assert "1 unit = 100 cm" in r.stderr
    back = read_bvh(out)
    assert back.skeleton.names == read_mvnx(EXCERPT).skeleton.names
    # the BVH (metres, 6 decimals) still reproduces the file's segment positions
    assert _max_position_difference(back, EXCERPT) < 2e-5

    glb = tmp_path / "x.glb"
    r = _run("compress", EXCERPT, "--max-position-error", "1", "-o", glb, "--json")
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    assert rec["unit_cm"] == pytest.approx(100.0) and not rec["unit_cm_assumed"]
    assert rec["max_position_error_cm"] <= 1.0 * (1 + 1e-9) and rec["n_frames"] == 30
    assert glb.stat().st_size > 0


def test_cli_segment_equals_the_amc_it_was_made_from(tmp_path: Path) -> None:
    """The MVNX made from the 15 Hz 86_01 excerpt places hips, knees, ankles, shoulders, elbows,
    wrists, pelvis and neck where the AMC's joints are: the limb angles, hence the cuts, agree."""
    cmu = DATA / "cmu"
    amc = cmu / "86_01_15hz_first1600.amc"
    data = make_mvnx.build(cmu / "86.asf", amc)
    mvnx = tmp_path / "take.mvnx"
    make_mvnx.write(mvnx, data, rate=15.0, note="test")
    for method in ("arma", "kmeans"):
        r1 = _run("segment", mvnx, "--json", "-m", method)
        r2 = _run("segment", amc, "--asf", cmu / "86.asf", "--rate", 15, "--json", "-m", method)
        assert r1.returncode == 0 and r2.returncode == 0, r1.stderr + r2.stderr
        c1 = [c["frame"] for c in json.loads(r1.stdout)["cuts"]]
        c2 = [c["frame"] for c in json.loads(r2.stdout)["cuts"]]
        assert c1 == c2 and len(c1) > 0, (method, c1, c2)


def test_cli_malformed_names_path_and_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mvnx"
    bad.write_text(EXCERPT.read_text()[:5000])
    r = _run("info", bad)
    assert r.returncode == 2 and f"{bad}:" in r.stderr and "malformed XML" in r.stderr


# --------------------------------------------------------------------------------------------------
# mutation fuzzing: a damaged file is read or refused with MocapFormatError, nothing else
# --------------------------------------------------------------------------------------------------

_BYTES = EXCERPT.read_bytes()


def _small_tree() -> ET.Element:
    """The excerpt with its 3 calibration and first 3 normal frames (fast to read many times)."""
    root = ET.fromstring(_BYTES)
    ns = root.tag[: root.tag.index("}") + 1]
    frames = root.find(f"{ns}subject/{ns}frames")
    for fr in list(frames)[6:]:
        frames.remove(fr)
    return root


_SMALL = ET.tostring(_small_tree())
_TAGS = sorted({e.tag for e in _small_tree().iter()})


def _nest(root: ET.Element, op: int, a: int, b: int, c: int) -> None:
    """One change of element nesting: move, copy, wrap (in an element of the file's vocabulary) or
    unwrap (children take its place) element ``a``; ``b`` and ``c`` pick the target and position."""
    els = list(root.iter())
    parent = {ch: p for p in els for ch in p}
    x = els[1 + a % (len(els) - 1)]
    p = parent[x]
    i = list(p).index(x)
    if op in (0, 1):
        inside = set(x.iter())
        targets = [e for e in els if e not in inside]
        y = targets[b % len(targets)]
        if op == 0:
            p.remove(x)
        else:
            x = copy.deepcopy(x)
        y.insert(c % (len(y) + 1), x)
    elif op == 2:
        w = ET.Element(_TAGS[b % len(_TAGS)], x.attrib if c % 2 else {})
        p.remove(x)
        w.append(x)
        p.insert(i, w)
    else:
        p.remove(x)
        for k, ch in enumerate(list(x)):
            p.insert(i + k, ch)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 10**6), st.integers(0, 10**6), st.integers(0, 10**6)),
                min_size=1, max_size=3))
def test_fuzz_element_nesting_only_format_errors_escape(tmp_path: Path, ops) -> None:
    """Elements moved, copied, wrapped or unwrapped anywhere (a <segment> with <points> outside
    <segments>, a <frame> inside a <frame>, an element inside <orientation>...)."""
    root = ET.fromstring(_SMALL)
    for op in ops:
        _nest(root, *op)
    f = tmp_path / "nest.mvnx"
    f.write_bytes(ET.tostring(root))
    try:
        m = read_mvnx(f)
    except MocapFormatError as e:
        assert e.path == str(f)
    else:
        assert m.n_frames >= 1 and np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.translations))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.integers(0, len(_BYTES) - 1), st.integers(0, 255), st.integers(0, 2)),
                min_size=1, max_size=4))
def test_fuzz_only_format_errors_escape(tmp_path: Path, edits) -> None:
    data = bytearray(_BYTES)
    for pos, byte, op in edits:
        pos = min(pos, len(data) - 1)
        if op == 0:
            data[pos] = byte
        elif op == 1:
            del data[pos:pos + 1 + byte]
        else:
            data[pos:pos] = bytes([byte])
    f = tmp_path / "fuzz.mvnx"
    f.write_bytes(bytes(data))
    try:
        m = read_mvnx(f)
    except MocapFormatError as e:
        assert e.path == str(f)
    else:
        assert m.n_frames >= 1 and np.all(np.isfinite(m.rotations))


def test_unknown_xml_encoding_is_a_format_error(tmp_path):
    f = tmp_path / "enc.mvnx"
    f.write_text('<?xml version="1.0" encoding="TF-8"?>\n<mvnx version="4"><subject/></mvnx>\n')
    with pytest.raises(MocapFormatError, match="cannot decode the XML"):
        read_mvnx(f)
