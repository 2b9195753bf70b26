"""Acclaim ASF/AMC reader (mocapkit.io.skeletal.amc): hand-computed poses, an independent CMU-style forward
kinematics on real CMU data, line-end variants, rejections and a mutation fuzz test."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapFormatError
from mocapkit.io.skeletal.amc import (
    JOINT_CHANNELS,
    ROOT_CHANNELS,
    load_amc_for_cli,
    project_onto_dofs,
    read_amc,
    read_amc_text,
    read_asf,
    read_asf_amc,
    read_asf_text,
    write_amc,
)
from mocapkit.skeleton import Skeleton, forward_kinematics, quat_to_matrix

CMU = Path(__file__).resolve().parent / "data" / "cmu"
ASF86 = CMU / "86.asf"
AMC86 = CMU / "86_01_first60.amc"
AMC13 = CMU / "13_29_first20.amc"

# --------------------------------------------------------------------------------------------------
# a tiny hand-made skeleton: root -> a -> b (leaf), root -> c (leaf)
# --------------------------------------------------------------------------------------------------

TINY_ASF = """\
# tiny test skeleton
:version 1.10
:name tiny
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
  hand-made: a has an axis (0 0 90), c has two dofs
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name a
     direction 0 1 0
     length 2
     axis 0 0 90 XYZ
    dof rx
    limits (-180.0 180.0)
  end
  begin
     id 2
     name b
     direction 1 0 0
     length 1
     axis 0 0 0 XYZ
  end
  begin
     id 3
     name c
     direction 0 0 1
     length 1
     axis 0 0 0 XYZ
    dof rx rz
    limits (-180 180)
           (-180 180)
  end
:hierarchy
  begin
    root a c
    a b
  end
"""

TINY_AMC = """\
#!OML:ASF tiny.asf
:FULLY-SPECIFIED
:DEGREES
1
root 1 2 3 0 90 0
a 90
c 0 90
2
root 0 0 0 0 0 0
a 0
c 90 90
"""

S2 = math.sqrt(0.5)


def _line_of(text: str, needle: str, nth: int = 1) -> int:
    hits = [i for i, ln in enumerate(text.split("\n"), 1) if needle in ln]
    return hits[nth - 1]


def _write(tmp_path: Path, name: str, text: str | bytes) -> Path:
    p = tmp_path / name
    if isinstance(text, str):
        p.write_text(text, encoding="utf-8", newline="")
    else:
        p.write_bytes(text)
    return p


def _tiny(tmp_path: Path, asf: str = TINY_ASF, amc: str = TINY_AMC):
    return read_asf_amc(_write(tmp_path, "tiny.asf", asf), _write(tmp_path, "tiny.amc", amc), rate=60.0)


def test_tiny_skeleton_model(tmp_path: Path) -> None:
    sk = read_asf(_write(tmp_path, "tiny.asf", TINY_ASF))
    assert sk.names == ("root", "a", "b", "c")
    assert sk.parents.tolist() == [-1, 0, 1, 0]
    # joint offset = the parent bone's direction x length; children of the root: 0
    np.testing.assert_array_equal(sk.offsets, [[0, 0, 0], [0, 0, 0], [0, 2, 0], [0, 0, 0]])
    assert sk.channels == (ROOT_CHANNELS, JOINT_CHANNELS, JOINT_CHANNELS, JOINT_CHANNELS)
    assert ROOT_CHANNELS == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
    assert sk.end_sites == ((2, (1.0, 0.0, 0.0)), (3, (0.0, 0.0, 1.0)))
    assert sk.meta["length_unit_cm"] == pytest.approx(2.54 / 0.45)
    assert sk.rotation_order(1) == "ZYX"
    assert read_asf(tmp_path / "tiny.asf", length_unit_cm=1.0).meta["length_unit_cm"] == 1.0


def test_tiny_hand_computed_positions(tmp_path: Path) -> None:
    m = _tiny(tmp_path)
    assert m.n_frames == 2
    np.testing.assert_array_equal(m.times, [0.0, 1 / 60])
    assert m.meta["frame_time"] == 1 / 60
    assert m.channel_values is None
    assert m.meta["first_frame"] == 1
    P, R, E = forward_kinematics(m, end_sites=True)
    # frame 1: root at (1,2,3) rotated Ry(90). Bone a: C = Rz(90), M = Rx(90) -> L = Ry(90), so the
    # world rotation of a is Ry(180): b starts at (1,2,3) + Ry180 (0,2,0) = (1,4,3) and ends at
    # (1,4,3) + Ry180 (1,0,0) = (0,4,3). Bone c: M = Rz(90) Rx(0); its end is
    # (1,2,3) + Ry90 Rz90 (0,0,1) = (2,2,3).
    np.testing.assert_allclose(P[0], [[1, 2, 3], [1, 2, 3], [1, 4, 3], [1, 2, 3]], atol=1e-12)
    np.testing.assert_allclose(E[0], [[0, 4, 3], [2, 2, 3]], atol=1e-12)
    ry90 = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    np.testing.assert_allclose(R[0, 0], ry90, atol=1e-12)
    np.testing.assert_allclose(R[0, 1], np.diag([-1, 1, -1]), atol=1e-12)
    # frame 2: c has rx = 90, rz = 90 -> M = Rz(90) Rx(90) (x first, about fixed axes):
    # Rz90 Rx90 (0,0,1) = Rz90 (0,-1,0) = (1,0,0). (The other order would give (0,-1,0).)
    np.testing.assert_allclose(P[1], [[0, 0, 0], [0, 0, 0], [0, 2, 0], [0, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(E[1], [[1, 2, 0], [1, 0, 0]], atol=1e-12)
    # local rotations of joints without dofs are the identity
    np.testing.assert_allclose(m.rotations[:, 2], [[1, 0, 0, 0]] * 2)


@pytest.mark.parametrize("amc_header", [":RADIANS\n", ""])
def test_tiny_radians(tmp_path: Path, amc_header: str) -> None:
    h = repr(math.pi / 2)
    asf = TINY_ASF.replace("angle deg", "angle rad").replace("axis 0 0 90 XYZ", f"axis 0 0 {h} XYZ")
    asf = asf.replace("(-180.0 180.0)", "(-3.2 3.2)").replace("(-180 180)", "(-3.2 3.2)")
    amc = TINY_AMC.replace(":DEGREES\n", amc_header).replace(" 90", " " + h)
    m_rad = _tiny(tmp_path, asf, amc)
    (tmp_path / "deg").mkdir()
    m_deg = _tiny(tmp_path / "deg", TINY_ASF, TINY_AMC)
    assert m_rad.meta["angle_unit"] == "rad"
    np.testing.assert_allclose(forward_kinematics(m_rad)[0], forward_kinematics(m_deg)[0], atol=1e-12)


def test_root_position_and_orientation(tmp_path: Path) -> None:
    asf = TINY_ASF.replace("position 0 0 0", "position 0.5 0 0").replace("orientation 0 0 0", "orientation 0 0 90")
    amc = ":FULLY-SPECIFIED\n:DEGREES\n1\nroot 1 2 3 90 0 0\na 0\nc 0 0\n"
    m = _tiny(tmp_path, asf, amc)
    assert m.skeleton.offsets[0].tolist() == [0.5, 0, 0]
    P, R, E = forward_kinematics(m, end_sites=True)
    # root translation = position + T; root rotation = C Rx(90) C^-1 with C = Rz(90) -> Ry(90)
    np.testing.assert_allclose(P[0, 0], [1.5, 2, 3], atol=1e-12)
    np.testing.assert_allclose(R[0, 0], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(P[0, 2], [1.5, 4, 3], atol=1e-12)
    np.testing.assert_allclose(E[0], [[1.5, 4, 2], [2.5, 2, 3]], atol=1e-12)


def test_root_order_is_honoured(tmp_path: Path) -> None:
    asf = TINY_ASF.replace("order TX TY TZ RX RY RZ", "order RZ RY RX TX TY TZ")
    amc = "1\nroot 90 0 90 0 0 0\na 0\nc 0 0\n"  # no header: angles in the ASF's unit (deg)
    m = _tiny(tmp_path, asf, amc)
    P, R, E = forward_kinematics(m, end_sites=True)
    # M = Rx(90) Ry(0) Rz(90): rotations about fixed axes in the listed order z, y, x
    np.testing.assert_allclose(P[0, 0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(P[0, 2], [-2, 0, 0], atol=1e-12)
    np.testing.assert_allclose(E[0], [[-2, 0, 1], [0, -1, 0]], atol=1e-12)
    assert m.meta["angle_unit"] == "deg"
    assert not m.meta["fully_specified"]


def test_bone_without_dofs_may_be_listed(tmp_path: Path) -> None:
    amc = TINY_AMC.replace("a 90\n", "a 90\nb\n")
    m = _tiny(tmp_path, TINY_ASF, amc)
    np.testing.assert_allclose(forward_kinematics(m)[0], forward_kinematics(_tiny(tmp_path))[0])


# --------------------------------------------------------------------------------------------------
# independent naive CMU forward kinematics
# --------------------------------------------------------------------------------------------------


def _naive_asf(path: Path) -> dict:
    """A deliberately simple parser of CMU ASF files (fixed CMU layout)."""
    lines = [ln.split("#")[0].split() for ln in path.read_text().splitlines()]
    bones, hier, section, cur, order = {}, {}, None, None, None
    for toks in lines:
        if not toks:
            continue
        if toks[0].startswith(":"):
            section = toks[0]
            continue
        if section == ":root" and toks[0] == "order":
            order = toks[1:]
        elif section == ":bonedata":
            if toks[0] == "begin":
                cur = {"dof": []}
            elif toks[0] == "end":
                bones[cur["name"]] = cur
            elif toks[0] == "name":
                cur["name"] = toks[1]
            elif toks[0] == "direction":
                cur["dir"] = np.array([float(v) for v in toks[1:]])
            elif toks[0] == "length":
                cur["len"] = float(toks[1])
            elif toks[0] == "axis":
                cur["axis"] = [float(v) for v in toks[1:4]]
            elif toks[0] == "dof":
                cur["dof"] = toks[1:]
        elif section == ":hierarchy" and toks[0] not in ("begin", "end"):
            for kid in toks[1:]:
                hier[kid] = toks[0]
    return {"bones": bones, "parent": hier, "order": order}


def _naive_amc(path: Path, n_frames: int) -> list[dict]:
    frames: list[dict] = []
    for ln in path.read_text().splitlines():
        toks = ln.split()
        if not toks or toks[0].startswith(("#", ":")):
            continue
        if len(toks) == 1 and toks[0].isdigit():
            if len(frames) == n_frames:
                break
            frames.append({})
        else:
            frames[-1][toks[0]] = [float(v) for v in toks[1:]]
    return frames


def _naive_fk(asf: dict, frame: dict) -> tuple[dict, dict]:
    """Per-bone world rotation W and bone end, CMU formula, 3x3 matrices straight from the numbers."""
    rt = frame["root"]
    vals = dict(zip(asf["order"], rt, strict=True))
    W = {"root": Rotation.from_euler("xyz", [vals["RX"], vals["RY"], vals["RZ"]], degrees=True).as_matrix()}
    end = {"root": np.array([vals["TX"], vals["TY"], vals["TZ"]])}
    pending = list(asf["bones"])
    while pending:
        for name in list(pending):
            par = asf["parent"][name]
            if par not in W:
                continue
            b = asf["bones"][name]
            C = Rotation.from_euler("xyz", b["axis"], degrees=True).as_matrix()
            ang = dict(zip(b["dof"], frame.get(name, []), strict=True))
            M = Rotation.from_euler("xyz", [ang.get("rx", 0.0), ang.get("ry", 0.0), ang.get("rz", 0.0)],
                                    degrees=True).as_matrix()
            W[name] = W[par] @ C @ M @ np.linalg.inv(C)
            end[name] = end[par] + W[name] @ (b["dir"] * b["len"])
            pending.remove(name)
    return W, end


def _compare_with_naive(asf_path: Path, amc_path: Path, n_frames: int) -> int:
    asf = _naive_asf(asf_path)
    frames = _naive_amc(amc_path, n_frames)
    m = read_amc(amc_path, read_asf(asf_path))
    assert m.n_frames >= len(frames)
    sub = type(m)(m.skeleton, m.times[: len(frames)], m.rotations[: len(frames)], m.translations[: len(frames)])
    P, R, E = forward_kinematics(sub, end_sites=True)
    sk = m.skeleton
    leaf_of = {sk.names[j]: e for e, (j, _) in enumerate(sk.end_sites)}
    worst = 0.0
    for f, frame in enumerate(frames):
        W, end = _naive_fk(asf, frame)
        for j, name in enumerate(sk.names):
            # joint = bone start = parent's bone end (root: its translation)
            start = end["root"] if name == "root" else end[asf["parent"][name]]
            worst = max(worst, np.abs(P[f, j] - start).max(), np.abs(R[f, j] - W[name]).max())
            if name in leaf_of:
                worst = max(worst, np.abs(E[f, leaf_of[name]] - end[name]).max())
    assert worst < 1e-9, worst
    return len(frames)


def test_naive_fk_matches_on_excerpt() -> None:
    assert _compare_with_naive(ASF86, AMC86, 60) == 60


def test_naive_fk_matches_on_13_29_excerpt() -> None:
    assert _compare_with_naive(ASF86, AMC13, 20) == 20


@pytest.mark.shared
def test_naive_fk_matches_on_shared_86_01(shared_data: Path) -> None:
    cmu = shared_data / "cmu"
    assert _compare_with_naive(cmu / "86.asf", cmu / "86_01.amc", 200) == 200


@pytest.mark.shared
def test_shared_86_01_full(shared_data: Path) -> None:
    m = read_asf_amc(shared_data / "cmu" / "86.asf", shared_data / "cmu" / "86_01.amc")
    assert m.n_frames == 4579
    assert m.rate == pytest.approx(120.0)
    P, _ = forward_kinematics(m)
    # feet reach the floor, the head is ~1.7 m up (5.644 cm per unit)
    cm = m.skeleton.meta["length_unit_cm"]
    assert -5 < P[:, :, 1].min() * cm < 5
    assert 150 < P[:, m.skeleton.index("head"), 1].max() * cm < 200
    excerpt = read_amc(AMC86, read_asf(ASF86))
    np.testing.assert_array_equal(m.rotations[:60], excerpt.rotations)
    np.testing.assert_array_equal(m.translations[:60], excerpt.translations)


@pytest.mark.shared
@pytest.mark.parametrize("trial,frames", [("13_29", 4592), ("13_30", None), ("14_14", None)])
def test_shared_mocap6_crlf(shared_data: Path, trial: str, frames: int | None) -> None:
    path = shared_data / "cmu" / f"{trial}.amc"
    data = path.read_bytes()
    assert b"\r\n" in data
    n = len(re.findall(rb"(?m)^\d+\r?$", data))
    if frames is not None:
        assert n == frames
    m = read_amc(path, shared_data / "cmu" / "86.asf")  # no ASF for subjects 13/14: same bones and dofs
    assert m.n_frames == n
    assert m.times[-1] == pytest.approx((n - 1) / 120.0)


def test_real_excerpts_basic() -> None:
    sk = read_asf(ASF86)
    assert sk.n_joints == 31 and sk.names[0] == "root"
    assert sk.meta["length_unit_cm"] == pytest.approx(5.644444444444445)
    assert sorted(sk.names[j] for j, _ in sk.end_sites) == sorted(
        ["ltoes", "rtoes", "head", "lfingers", "lthumb", "rfingers", "rthumb"]
    )
    # lfemur starts at the end of lhipjoint
    lh = sk.meta["asf"]["bones"]["lhipjoint"]
    np.testing.assert_allclose(sk.offsets[sk.index("lfemur")], np.array(lh["direction"]) * lh["length"])
    m13 = read_amc(AMC13, sk)
    assert m13.n_frames == 20
    m86 = read_amc(AMC86, sk)
    assert m86.n_frames == 60
    assert m86.meta["amc_values"]["lclavicle"].shape == (60, 2)
    np.testing.assert_allclose(np.linalg.norm(m86.rotations, axis=-1), 1.0, atol=1e-12)


def test_line_end_variants(tmp_path: Path) -> None:
    ref = read_asf_amc(ASF86, AMC86)
    asf = ASF86.read_bytes()
    amc = AMC86.read_bytes()
    variants = {
        "lf": (asf.replace(b"\r\n", b"\n"), amc.replace(b"\r\n", b"\n")),
        "cr": (asf.replace(b"\r\n", b"\r"), amc.replace(b"\r\n", b"\r")),
        "no_final_newline": (asf.rstrip(), amc.rstrip()),
        "trailing_blank_lines": (asf + b"\r\n\r\n  \r\n", amc + b"\r\n\r\n\r\n"),
        "bom": (b"\xef\xbb\xbf" + asf, b"\xef\xbb\xbf" + amc),
        "latin1_comment": (asf.replace(b"VICON BodyLanguage", b"VICON Body\xe9Language"),
                           amc.replace(b"Patient1", b"Patient\xe91")),
    }
    for name, (a, b) in variants.items():
        m = read_asf_amc(_write(tmp_path, f"{name}.asf", a), _write(tmp_path, f"{name}.amc", b))
        assert m.n_frames == 60, name
        np.testing.assert_array_equal(m.rotations, ref.rotations, err_msg=name)
        np.testing.assert_array_equal(m.translations, ref.translations, err_msg=name)


# --------------------------------------------------------------------------------------------------
# rejections
# --------------------------------------------------------------------------------------------------


def _asf_err(tmp_path: Path, text: str | bytes) -> MocapFormatError:
    p = _write(tmp_path, "bad.asf", text)
    with pytest.raises(MocapFormatError) as ei:
        read_asf(p)
    assert ei.value.path == str(p)
    assert str(ei.value).startswith(str(p))
    return ei.value


def _amc_err(tmp_path: Path, text: str | bytes, asf: str = TINY_ASF) -> MocapFormatError:
    sk = read_asf(_write(tmp_path, "ok.asf", asf))
    p = _write(tmp_path, "bad.amc", text)
    with pytest.raises(MocapFormatError) as ei:
        read_amc(p, sk)
    assert ei.value.path == str(p)
    return ei.value


def _cut_section(text: str, start: str, stop: str | None) -> str:
    i = text.index(start)
    j = len(text) if stop is None else text.index(stop)
    return text[:i] + text[j:]


def _at(text: str, needle: str, nth: int = 1, exact: bool = False) -> int:
    """1-based number of the ``nth`` line containing (or, with ``exact``, equal to) ``needle``."""
    lines = text.split("\n")
    hits = [i for i, ln in enumerate(lines, 1) if (ln == needle if exact else needle in ln)]
    return hits[nth - 1]


def _case(name: str, text: str, where, fragment: str):
    """``where``: None (whole file), a needle, or ``(needle, nth[, exact])``."""
    if where is None:
        line = None
    elif isinstance(where, str):
        line = _at(text, where)
    else:
        line = _at(text, *where)
    return pytest.param(text, line, fragment, id=name)


_T = TINY_ASF
ASF_CASES = [
    _case("no_bonedata", _cut_section(_T, ":bonedata", None), None, "no :bonedata section"),
    _case("no_root", _cut_section(_T, ":root", ":bonedata"), None, "no :root section"),
    _case("no_hierarchy", _cut_section(_T, ":hierarchy", None), None, "no :hierarchy section"),
    _case("unknown_child", _T.replace("    a b\n", "    a b ghost\n"), "a b ghost",
          "hierarchy names an unknown bone 'ghost'"),
    _case("unknown_parent", _T.replace("    a b\n", "    ghost b\n"), "ghost b", "unknown bone 'ghost'"),
    _case("cycle", _T.replace("    root a c\n    a b\n", "    root c\n    a b\n    b a\n"), "    b a",
          "cycle in :hierarchy: a -> b -> a"),
    _case("self_child", _T.replace("    a b\n", "    a a b\n"), "a a b", "its own child"),
    _case("two_parents", _T.replace("    a b\n", "    a b\n    c b\n"), "    c b", "bone 'b' has two parents"),
    _case("not_attached", _T.replace("    a b\n", ""), "name b", "bone 'b' is not attached"),
    _case("root_as_child", _T.replace("    a b\n", "    a b root\n"), "a b root", "root cannot be the child"),
    _case("direction_token", _T.replace("direction 0 1 0", "direction 0 x 0"), "direction 0 x 0",
          "direction: 'x' is not a number"),
    _case("direction_count", _T.replace("direction 0 1 0", "direction 0 1"), "direction 0 1",
          "direction: expected 3 numbers, got 2"),
    _case("length_nan", _T.replace("length 2\n", "length nan\n"), "length nan", "length is NaN"),
    _case("length_negative", _T.replace("length 2\n", "length -2\n"), "length -2", "must not be negative"),
    _case("axis_order", _T.replace("axis 0 0 90 XYZ", "axis 0 0 90 XYQ"), "XYQ", "permutation of XYZ"),
    _case("axis_count", _T.replace("axis 0 0 90 XYZ", "axis 0 90 XYZ"), "axis 0 90 XYZ", "axis: expected three"),
    _case("dof_unknown", _T.replace("dof rx rz", "dof rx rw"), "dof rx rw", "unknown dof 'rw'"),
    _case("dof_translation", _T.replace("dof rx rz", "dof rx tx"), "dof rx tx", "dof 'tx' is not supported"),
    _case("dof_twice", _T.replace("dof rx rz", "dof rx rx"), "dof rx rx", "listed twice"),
    _case("limits_too_few", _T.replace("           (-180 180)\n", ""), ("  end", 3, True),
          "1 limit pair(s) for 2 dof(s)"),
    _case("limits_too_many", _T.replace("limits (-180.0 180.0)", "limits (-180.0 180.0) (0 1)"), "(0 1)",
          "more pairs than the 1 dof(s)"),
    _case("limits_odd", _T.replace("limits (-180.0 180.0)", "limits (-180.0)"), "limits (-180.0)",
          "expected '(lo hi)' pairs"),
    _case("limits_reversed", _T.replace("limits (-180.0 180.0)", "limits (180.0 -180.0)"), "limits (180.0",
          "exceeds upper bound"),
    _case("unclosed_bone", _T.replace("     axis 0 0 0 XYZ\n  end\n", "     axis 0 0 0 XYZ\n", 1),
          ("  begin", 3, True), "'begin' inside the bone block"),
    _case("unclosed_last_bone", _T.replace("           (-180 180)\n  end\n", "           (-180 180)\n"),
          ":hierarchy", "missing 'end'"),
    _case("outside_block", _T.replace("  begin\n     id 2\n", "     id 2\n"), "id 2", "outside a bone block"),
    _case("no_name", _T.replace("     name b\n", ""), ("  end", 2, True), "has no 'name'"),
    _case("no_length", _T.replace("     length 1\n", "", 1), ("  end", 2, True), "has no 'length'"),
    _case("duplicate_name", _T.replace("name c", "name a"), ("name a", 2), "defined twice"),
    _case("bone_named_root", _T.replace("name c", "name root"), "name root", "cannot be named 'root'"),
    _case("unknown_field", _T.replace("     id 2\n", "     id 2\n     colour red\n"), "colour",
          "unknown bone field 'colour'"),
    _case("field_twice", _T.replace("     id 2\n", "     id 2\n     id 7\n"), "id 7", "given twice"),
    _case("bad_id", _T.replace("id 2", "id two"), "id two", "bone id must be an integer"),
    _case("angle_unit", _T.replace("angle deg", "angle grad"), "angle grad", "'deg' or 'rad'"),
    _case("length_unit_zero", _T.replace("length 0.45", "length 0"), "length 0", "must be positive"),
    _case("unknown_unit", _T.replace("mass 1.0", "weight 1.0"), "weight", "unknown unit"),
    _case("root_order", _T.replace("order TX TY TZ RX RY RZ", "order TX TY TZ RX RY RW"), "order",
          "unknown token 'RW'"),
    _case("root_order_twice", _T.replace("order TX TY TZ RX RY RZ", "order TX TX TZ RX RY RZ"), "order",
          "names a channel twice"),
    _case("no_root_order", _T.replace("   order TX TY TZ RX RY RZ\n", ""), ":root", "has no 'order' line"),
    _case("root_position", _T.replace("position 0 0 0", "position 0 0"), "position", "expected 3 numbers"),
    _case("root_unknown", _T.replace("   axis XYZ\n", "   axis XYZ\n   scale 2\n"), "scale",
          "unknown :root field"),
    _case("section_twice", _T + ":root\n", (":root", 2), "section :root appears twice"),
    _case("text_before_sections", "hello\n" + _T, "hello", "before the first ':' section keyword"),
    _case("hierarchy_after_end", _T + "    b c\n", "    b c", "after 'end' of :hierarchy"),
    _case("hierarchy_unclosed", _T.replace("    a b\n  end\n", "    a b\n"), ("  begin", 4, True),
          "not closed by 'end'"),
    _case("hierarchy_no_children", _T.replace("    a b\n", "    a\n"), ("    a", 1, True), "no children"),
    _case("infinite_direction", _T.replace("direction 0 1 0", "direction 0 inf 0"), "0 inf 0", "is infinite"),
    _case("bad_utf8_surrogate_text", _T.replace("name c", "name c\udcff"), "name c", "not UTF-8"),
]


@pytest.mark.parametrize("text,line,fragment", ASF_CASES)
def test_asf_rejections(tmp_path: Path, text: str, line: int | None, fragment: str) -> None:
    err = _asf_err(tmp_path, text.encode("utf-8", "surrogateescape"))
    assert fragment in err.problem, err
    assert err.line == line, err
    if line is not None:
        assert str(err) == f"{err.path}:{line}: {err.problem}"
    else:
        assert str(err) == f"{err.path}: {err.problem}"


def test_asf_rejects_invalid_utf8(tmp_path: Path) -> None:
    data = TINY_ASF.encode().replace(b"name c", b"name c\xff")
    err = _asf_err(tmp_path, data)
    assert err.line == _line_of(TINY_ASF, "name c")
    assert "not UTF-8" in err.problem and "0xff" in err.problem


def test_asf_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MocapFormatError) as ei:
        read_asf(tmp_path / "nope.asf")
    assert ei.value.line is None and "no such file" in ei.value.problem


_M = TINY_AMC
AMC_CASES = [
    _case("unknown_bone", _M.replace("a 90\n", "a 90\nghost 1 2 3\n"), "ghost", "unknown bone 'ghost'"),
    _case("too_many_values", _M.replace("a 90\n", "a 90 1\n"), "a 90 1",
          "bone 'a' has 1 dof(s) but the line holds 2 value(s)"),
    _case("too_few_values", _M.replace("root 1 2 3 0 90 0", "root 1 2 3 0 90"), "root 1 2 3",
          "bone 'root' has 6 dof(s) but the line holds 5 value(s)"),
    _case("not_a_number", _M.replace("c 0 90", "c 0 ninety"), "ninety", "bone c: 'ninety' is not a number"),
    _case("underscore_number", _M.replace("c 0 90", "c 0 9_0"), "9_0", "'9_0' is not a number"),
    _case("unicode_digits", _M.replace("c 0 90", "c 0 \u0669\u0660"), "c 0 ", "is not a number"),
    _case("nan", _M.replace("c 0 90", "c 0 nan"), "c 0 nan", "bone c is NaN"),
    _case("infinite", _M.replace("c 0 90", "c 0 -inf"), "-inf", "bone c is infinite"),
    _case("frames_not_consecutive", _M.replace("\n2\n", "\n3\n"), ("3", 1, True),
          "frame number 3 does not follow frame 1 (line 4)"),
    _case("frames_backwards", _M.replace("\n2\n", "\n1\n"), ("1", 2, True),
          "frame number 1 does not follow frame 1"),
    _case("missing_bone", _M.replace("a 90\n", ""), ("1", 1, True), "frame 1 has no line for bone(s) a"),
    _case("missing_bone_last_frame", _M.replace("a 0\n", ""), ("2", 1, True), "frame 2 has no line for bone(s) a"),
    _case("bone_twice", _M.replace("a 90\n", "a 90\na 80\n"), "a 80", "bone 'a' appears twice in frame 1"),
    _case("bone_before_frame", _M.replace("1\nroot", "root 0 0 0 0 0 0\n1\nroot"), "root 0 0 0 0 0 0",
          "before the first frame number"),
    _case("no_frames", ":FULLY-SPECIFIED\n:DEGREES\n", None, "no frames"),
    _case("empty", "", None, "no frames"),
    _case("unknown_keyword", _M.replace(":DEGREES", ":FURLONGS"), ":FURLONGS", "unknown keyword ':FURLONGS'"),
    _case("keyword_after_frames", _M + ":DEGREES\n", (":DEGREES", 2), "after the first frame"),
    _case("keyword_twice", _M.replace(":DEGREES\n", ":DEGREES\n:DEGREES\n"), (":DEGREES", 2), "given twice"),
    _case("deg_and_rad", _M.replace(":DEGREES\n", ":DEGREES\n:RADIANS\n"), ":RADIANS", "contradicts"),
    _case("word_instead_of_frame", _M.replace("\n2\n", "\ntwo\n"), ("two", 1, True),
          "neither a frame number nor a bone"),
    _case("nul_byte", _M.replace("a 0\n", "a 0\x00\n"), "a 0", "NUL byte"),
    _case("bad_utf8", _M.replace("c 0 90", "c 0 9\udcc30"), "c 0 9", "not UTF-8 text: byte 0xc3"),
]


@pytest.mark.parametrize("text,line,fragment", AMC_CASES)
def test_amc_rejections(tmp_path: Path, text: str, line: int | None, fragment: str) -> None:
    err = _amc_err(tmp_path, text.encode("utf-8", "surrogateescape"))
    assert fragment in err.problem, err
    assert err.line == line, err
    assert str(err) == (f"{err.path}:{line}: {err.problem}" if line is not None else f"{err.path}: {err.problem}")


def test_amc_rejects_invalid_utf8_in_data(tmp_path: Path) -> None:
    data = TINY_AMC.encode().replace(b"c 0 90", b"c 0 9\xc30")
    err = _amc_err(tmp_path, data)
    assert err.line == _line_of(TINY_AMC, "c 0 90")
    assert "not UTF-8" in err.problem


def test_amc_unicode_digits_are_not_numbers(tmp_path: Path) -> None:
    err = _amc_err(tmp_path, TINY_AMC.replace("c 0 90", "c 0 \u0669\u0660"))
    assert err.line == _line_of(TINY_AMC, "c 0 90") and "is not a number" in err.problem


def test_amc_against_wrong_skeleton(tmp_path: Path) -> None:
    # the CMU motion against the tiny skeleton: the first unknown bone is reported
    sk = read_asf(_write(tmp_path, "tiny.asf", TINY_ASF))
    with pytest.raises(MocapFormatError) as ei:
        read_amc(AMC86, sk)
    assert ei.value.line == 6
    assert "unknown bone 'lowerback'" in ei.value.problem


def test_bad_parameters(tmp_path: Path) -> None:
    sk = read_asf(ASF86)
    for rate in (0, -1, float("nan"), float("inf"), "fast"):
        with pytest.raises(InvalidParameterError):
            read_amc(AMC86, sk, rate=rate)
    plain = Skeleton(("r",), np.array([-1]), np.zeros((1, 3)), (("Xrotation",),))
    with pytest.raises(InvalidParameterError):
        read_amc(AMC86, plain)
    with pytest.raises(InvalidParameterError):
        read_amc(AMC86, 42)
    with pytest.raises(InvalidParameterError):
        read_asf(ASF86, length_unit_cm=-1)
    with pytest.raises(MocapFormatError):
        read_amc(tmp_path / "missing.amc", sk)
    with pytest.raises(MocapFormatError):
        read_amc(AMC86, tmp_path / "missing.asf")


# --------------------------------------------------------------------------------------------------
# CLI hook, writer
# --------------------------------------------------------------------------------------------------


def test_load_amc_for_cli(tmp_path: Path) -> None:
    shutil.copy(ASF86, tmp_path / "86.asf")
    shutil.copy(AMC86, tmp_path / "86_01.amc")
    m = load_amc_for_cli(tmp_path / "86_01.amc")
    assert m.n_frames == 60 and m.rate == pytest.approx(120.0)
    m2 = load_amc_for_cli(tmp_path / "86_01.amc", asf=ASF86, rate=60)
    assert m2.rate == pytest.approx(60.0)
    shutil.copy(AMC13, tmp_path / "13_29.amc")
    with pytest.raises(InvalidParameterError, match="13.asf"):
        load_amc_for_cli(tmp_path / "13_29.amc")
    assert load_amc_for_cli(tmp_path / "13_29.amc", asf=tmp_path / "86.asf").n_frames == 20


def test_write_amc_round_trip(tmp_path: Path) -> None:
    sk = read_asf(ASF86)
    m = read_amc(AMC86, sk)
    out = tmp_path / "out.amc"
    write_amc(out, m, sk)
    back = read_amc(out, sk)
    assert back.n_frames == m.n_frames
    P0, R0 = forward_kinematics(m)
    P1, R1 = forward_kinematics(back)
    np.testing.assert_allclose(P1, P0, atol=1e-9)
    np.testing.assert_allclose(R1, R0, atol=1e-9)
    # the values come back (CMU angles are inside the principal Euler ranges here)
    for name, v in m.meta["amc_values"].items():
        np.testing.assert_allclose(back.meta["amc_values"][name], v, atol=1e-9, err_msg=name)


def test_write_amc_refuses_unrepresentable_rotation(tmp_path: Path) -> None:
    sk = read_asf(ASF86)
    m = read_amc(AMC86, sk)
    rot = m.rotations.copy()
    rot[3, sk.index("ltibia")] = [S2, 0, S2, 0]  # 90 deg about y: ltibia only has rx
    bad = type(m)(sk, m.times, rot, m.translations)
    with pytest.raises(InvalidSignalError) as ei:
        write_amc(tmp_path / "bad.amc", bad, sk)
    msg = str(ei.value)
    # joint, 1-based frame, how far (deg) and the dofs; ltibia's axis is not along y, so the
    # closest rx rotation is less than 90 deg away — recomputed here by brute force
    assert "joint 'ltibia' frame 4:" in msg and "(rx)" in msg and "ltibia (1 frame)" in msg
    deg = float(re.search(r"is ([0-9.]+) deg away", msg).group(1))
    c = Rotation.from_quat(np.roll(sk.meta["asf"]["axis_quat"]["ltibia"], -1))
    M = c.inv() * Rotation.from_quat([0, S2, 0, S2]) * c
    grid = Rotation.from_euler("x", np.linspace(-180, 180, 72001), degrees=True)
    brute = np.degrees((grid.inv() * M).magnitude()).min()
    assert deg == pytest.approx(brute, rel=1e-3) and deg > 10
    assert not (tmp_path / "bad.amc").exists()
    # a generous limit writes it and reports the same residual
    rep = write_amc(tmp_path / "ok.amc", bad, sk, max_residual_deg=100)
    assert rep["joint"] == "ltibia" and rep["frame"] == 4 and rep["max_residual_deg"] == pytest.approx(brute, rel=1e-3)
    with pytest.raises(InvalidParameterError):
        write_amc(tmp_path / "x.amc", m, sk, max_residual_deg=-1)


def test_write_amc_reports_the_residual(tmp_path: Path) -> None:
    sk = read_asf(ASF86)
    m = read_amc(AMC86, sk)
    rep = write_amc(tmp_path / "out.amc", m, sk)
    assert rep["max_residual_deg"] < 1e-9 and rep["limit_deg"] == 0.1
    assert set(rep["per_joint"]) == {"root", *sk.meta["asf"]["bones"]}


def _angle_to(q: np.ndarray, seq: str, ang: np.ndarray) -> np.ndarray:
    r = Rotation.from_euler(seq, ang, degrees=True) if seq else Rotation.identity(len(q))
    return np.degrees((r.inv() * Rotation.from_quat(np.roll(q, -1, axis=-1))).magnitude())


@pytest.mark.parametrize("seq", ["", "x", "y", "z", "xz", "zx", "yz", "zy", "xy", "yx", "xyz", "zyx"])
def test_projection_is_the_closest_expressible_rotation(seq: str) -> None:
    """The closed form against a numerical optimum (multi-start Nelder–Mead over the dof angles)."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(len(seq) * 7 + sum(map(ord, seq)))
    q = Rotation.random(12, random_state=rng).as_quat()
    q = np.roll(q, 1, axis=1)  # scalar first
    ang, res = project_onto_dofs(q, seq)
    assert ang.shape == (12, len(seq)) and np.all(np.abs(ang) <= 180 + 1e-9)
    np.testing.assert_allclose(_angle_to(q, seq, ang), res, atol=1e-7)  # the residual is what it says
    if not seq:
        return
    for n in range(12):
        best = np.inf
        for start in rng.uniform(-180, 180, size=(6, len(seq))):
            r = minimize(lambda a: _angle_to(q[n:n + 1], seq, a[None])[0], start, method="Nelder-Mead",
                         options={"xatol": 1e-8, "fatol": 1e-10, "maxiter": 4000})
            best = min(best, r.fun)
        assert res[n] <= best + 1e-6, (seq, n, res[n], best)
        assert res[n] >= best - 1e-4, (seq, n, res[n], best)


@pytest.mark.parametrize("seq", ["x", "yz", "xz", "xyz"])
def test_projection_is_exact_for_expressible_rotations(seq: str) -> None:
    rng = np.random.default_rng(3)
    ang = rng.uniform(-179, 179, size=(50, len(seq)))
    if len(seq) == 3:
        ang[:, 1] = rng.uniform(-89, 89, 50)
    q = np.roll(Rotation.from_euler(seq, ang, degrees=True).as_quat(), 1, axis=1)
    back, res = project_onto_dofs(q, seq)
    assert res.max() < 1e-9
    np.testing.assert_allclose(back, ang, atol=1e-9)


def test_bvh_to_amc_round_trip_of_shared_86_01(shared_data: Path, tmp_path: Path) -> None:
    """86_01 AMC -> BVH (default 6 decimals) -> AMC through the CLI: every value of the AMC comes back
    within the BVH's written precision (root heading beyond ±180° included), the residual is reported."""
    import subprocess
    import sys

    cmu = shared_data / "cmu"
    exe = [sys.executable, "-m", "mocapkit.cli", "convert"]
    r = subprocess.run([*exe, str(cmu / "86_01.amc"), str(tmp_path / "a.bvh")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*exe, str(tmp_path / "a.bvh"), str(tmp_path / "b.amc"), "--asf", str(cmu / "86.asf")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    got = re.search(r"largest rotation residual ([0-9.e+-]+) deg \((\w+), frame (\d+); limit 0.1 deg\)", r.stderr)
    assert got is not None, r.stderr
    assert 0 < float(got.group(1)) < 1e-5
    sk = read_asf(cmu / "86.asf")
    a = read_amc(cmu / "86_01.amc", sk).meta["amc_values"]
    b = read_amc(tmp_path / "b.amc", sk).meta["amc_values"]
    assert np.abs(a["root"]).max() > 360  # the original counts the heading past ±180°
    worst = max(float(np.abs(b[n] - v).max()) for n, v in a.items())
    assert worst < 5e-6  # 6 decimals in the BVH: rounding of 5e-7 deg per channel


def test_cli_bvh_to_amc_refuses_a_real_loss(tmp_path: Path) -> None:
    import subprocess
    import sys

    from mocapkit.io.skeletal.bvh import write_bvh

    sk = read_asf(ASF86)
    m = read_amc(AMC86, sk)
    rot = m.rotations.copy()
    rot[9, sk.index("rtibia")] = Rotation.from_euler("xyz", [30, 0, 2], degrees=True).as_quat()[[3, 0, 1, 2]]
    write_bvh(tmp_path / "bad.bvh", type(m)(sk, m.times, rot, m.translations, None, "", dict(m.meta)))
    exe = [sys.executable, "-m", "mocapkit.cli", "convert", str(tmp_path / "bad.bvh"), str(tmp_path / "bad.amc"),
           "--asf", str(ASF86)]
    r = subprocess.run(exe, capture_output=True, text=True)
    assert r.returncode == 2
    assert "joint 'rtibia' frame 10:" in r.stderr and "deg away" in r.stderr and "--max-residual" in r.stderr
    assert not (tmp_path / "bad.amc").exists()
    deg = float(re.search(r"is ([0-9.]+) deg away", r.stderr).group(1))
    assert 0.5 < deg < 30
    r = subprocess.run([*exe, "--max-residual", str(deg * 1.01)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "(rtibia, frame 10;" in r.stderr


def test_quaternions_match_matrix_formula() -> None:
    """L = C·M·C⁻¹ for a 3-dof bone, checked against matrices from the file's numbers."""
    sk = read_asf(ASF86)
    m = read_amc(AMC86, sk)
    b = sk.meta["asf"]["bones"]["lfoot"]  # axis -90 7.6e-16 20, dof rx rz
    C = Rotation.from_euler("xyz", b["axis"], degrees=True).as_matrix()
    v = m.meta["amc_values"]["lfoot"][7]
    M = Rotation.from_euler("xyz", [v[0], 0, v[1]], degrees=True).as_matrix()
    np.testing.assert_allclose(quat_to_matrix(m.rotations[7, sk.index("lfoot")]), C @ M @ C.T, atol=1e-12)


# --------------------------------------------------------------------------------------------------
# fuzz: mutated real files raise MocapFormatError or read
# --------------------------------------------------------------------------------------------------

_ASF_BYTES = ASF86.read_bytes()
_AMC_BYTES = b"\r\n".join(AMC86.read_bytes().split(b"\r\n")[:3 + 30 * 4]) + b"\r\n"  # header + 4 frames
_TOKENS = ["", "0", "-1", "1e400", "nan", "inf", "x", "root", "lfemur", "begin", "end", ":root", ":bonedata",
           ":hierarchy", ":DEGREES", "(", ")", "rx", "XYZ", "XYQ", "dof", "limits", "#", "1_0", "\u0663",
           "99999", "2", "-0", "ltibia", "axis", "\x00", "\xff"]


@st.composite
def _mutated(draw) -> tuple[str, bytes]:
    which = draw(st.sampled_from(["asf", "amc"]))
    data = _ASF_BYTES if which == "asf" else _AMC_BYTES
    lines = data.split(b"\n")
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["delete", "duplicate", "swap", "token", "truncate", "bytes", "join"]))
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "join" and i + 1 < len(lines):
            lines[i : i + 2] = [lines[i].rstrip(b"\r") + b" " + lines[i + 1]]
        elif kind == "token":
            toks = lines[i].split(b" ")
            k = draw(st.integers(0, len(toks) - 1))
            toks[k] = draw(st.sampled_from(_TOKENS)).encode("utf-8")
            lines[i] = b" ".join(toks)
        elif kind == "truncate":
            blob = b"\n".join(lines)
            cut = draw(st.integers(0, len(blob)))
            lines = blob[:cut].split(b"\n")
        elif kind == "bytes":
            pos = draw(st.integers(0, len(lines[i])))
            junk = draw(st.binary(min_size=1, max_size=6))
            lines[i] = lines[i][:pos] + junk + lines[i][pos:]
    return which, b"\n".join(lines)


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("amc_fuzz")
    (d / "good.asf").write_bytes(_ASF_BYTES)
    (d / "good.amc").write_bytes(_AMC_BYTES)
    return d


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=_mutated())
def test_fuzz_only_format_errors_escape(fuzz_dir: Path, case: tuple[str, bytes]) -> None:
    which, data = case
    if which == "asf":
        asf, amc = fuzz_dir / "mut.asf", fuzz_dir / "good.amc"
    else:
        asf, amc = fuzz_dir / "good.asf", fuzz_dir / "mut.amc"
    (fuzz_dir / f"mut.{which}").write_bytes(data)
    n_lines = data.count(b"\n") + data.count(b"\r") + 1
    try:
        m = read_asf_amc(asf, amc)
    except MocapFormatError as exc:
        assert exc.path in (str(asf), str(amc))
        assert exc.line is None or 1 <= exc.line <= n_lines, exc
        assert exc.problem
        return
    assert m.n_frames >= 1
    assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.translations))
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-9)


def test_read_text_functions() -> None:
    sk = read_asf_text(TINY_ASF, "<tiny>")
    m = read_amc_text(TINY_AMC, sk, "<tiny-amc>", rate=30)
    assert m.source == "<tiny-amc>" and m.rate == pytest.approx(30.0)
    with pytest.raises(MocapFormatError) as ei:
        read_amc_text(TINY_AMC.replace("a 90", "a x"), sk, "<tiny-amc>")
    assert ei.value.path == "<tiny-amc>" and ei.value.line == _line_of(TINY_AMC, "a 90")
