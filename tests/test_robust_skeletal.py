"""Issue 10 for the skeletal readers and the skeleton model: strict finite numbers (BVH, ASF, AMC,
glTF), files cut short at the end, no recursion on any hierarchy (10,000-joint chains through every
command), header claims checked before allocation, hostile glTF files."""

from __future__ import annotations

import base64
import json
import math
import re
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit.errors import MocapFormatError, MocapWarning
from mocapkit.io.formats.gltf import read_gltf, write_gltf
from mocapkit.io.skeletal import bvh as bvh_mod
from mocapkit.io.skeletal.amc import read_amc, read_amc_text, read_asf, read_asf_text, write_amc
from mocapkit.io.skeletal.bvh import parse_bvh, read_bvh, write_bvh
from mocapkit.io.text.numbers import MAX_ABS, parse_number
from mocapkit.pla import skeletal as pla_skeletal
from mocapkit.pla.decode import reconstruct
from mocapkit.pla.skeletal import compress_motion
from mocapkit.skeleton import Skeleton, forward_kinematics
from reference_kinematics import naive_positions

DATA = Path(__file__).resolve().parent / "data"
WALK = DATA / "bvh" / "walk-meredith-60.bvh"
ASF86 = DATA / "cmu" / "86.asf"
AMC86 = DATA / "cmu" / "86_01_first60.amc"
EXE = [sys.executable, "-m", "mocapkit.cli"]
BAD_TOKENS = ["nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e999", "0_5", "1_000", "0x10", "--1", "1e"]

# --------------------------------------------------------------------------------------------------
# generators
# --------------------------------------------------------------------------------------------------

CMU_ROLES = ["root", "lowerneck", "rfemur", "rtibia", "rfoot", "lfemur", "ltibia", "lfoot",
             "rhumerus", "rradius", "rwrist", "lhumerus", "lradius", "lwrist"]


def chain_bvh(n_joints: int, n_frames: int, animated: int | None = None, named: bool = False) -> str:
    """A BVH chain: every joint the only child of the previous one; ``animated`` joints have channels."""
    animated = n_joints if animated is None else animated
    names = [f"j{k}" for k in range(n_joints)]
    if named:
        names[:len(CMU_ROLES)] = CMU_ROLES
    out = ["HIERARCHY", f"ROOT {names[0]}", "{", "\tOFFSET 0 0 0",
           "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for j in range(1, n_joints):
        out += [f"JOINT {names[j]}", "{", "OFFSET 0 1 0.5",
                "CHANNELS 3 Zrotation Xrotation Yrotation" if j < animated else "CHANNELS 0"]
    out += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * n_joints
    C = 6 + 3 * (min(animated, n_joints) - 1)
    out += ["MOTION", f"Frames: {n_frames}", "Frame Time: 0.0333333"]
    for f in range(n_frames):
        half = f < n_frames // 2
        out.append(" ".join(f"{(20 * math.sin(0.05 * f * (1 + c % 5) + c) if half else 30 * math.cos(0.2 * f + c)):.4f}"
                            for c in range(C)))
    return "\n".join(out) + "\n"


def chain_asf(n_bones: int) -> str:
    out = [":version 1.10", ":name chain", ":units", "  mass 1.0", "  length 0.45", "  angle deg",
           ":root", "   order TX TY TZ RX RY RZ", "   axis XYZ", "   position 0 0 0", "   orientation 0 0 0",
           ":bonedata"]
    for b in range(1, n_bones + 1):
        out += ["  begin", f"     id {b}", f"     name b{b}", "     direction 0 1 0", "     length 0.5",
                "     axis 0 0 10 XYZ"]
        if b % 2:
            out += ["     dof rx rz", "     limits (-180 180)", "            (-inf inf)"]
        out += ["  end"]
    out += [":hierarchy", "  begin", "    root b1"] + [f"    b{b} b{b + 1}" for b in range(1, n_bones)] + ["  end"]
    return "\n".join(out) + "\n"


def chain_amc(n_bones: int, n_frames: int) -> str:
    out = [":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(1, n_frames + 1):
        out.append(str(f))
        out.append(f"root {f * 0.5} 1.25 -3.5 {f} 2.5 -7.25")
        out += [f"b{b} {(b + f) % 17 - 8.5} {f * 0.25}" for b in range(1, n_bones + 1, 2)]
    return "\n".join(out) + "\n"


def _line_of(text: str, needle: str, nth: int = 1) -> int:
    hits = [i for i, ln in enumerate(text.split("\n"), 1) if needle in ln]
    return hits[nth - 1]


def _bvh_err(tmp_path: Path, text: str, strict: bool = True) -> MocapFormatError:
    p = tmp_path / "bad.bvh"
    p.write_text(text)
    with pytest.raises(MocapFormatError) as ei:
        read_bvh(p, strict=strict)
    assert ei.value.path == str(p) and str(ei.value).startswith(str(p))
    return ei.value


WALK_TEXT = WALK.read_text()
WALK_LINES = WALK_TEXT.split("\n")
FIRST_DATA = _line_of(WALK_TEXT, "Frame Time") + 1  # 1-based file line of frame 1


# --------------------------------------------------------------------------------------------------
# BVH: strict numbers, with the line and the field named
# --------------------------------------------------------------------------------------------------


def test_bvh_values_equal_an_independent_strict_parse():
    m = read_bvh(WALK)
    rows = [[parse_number(t, "x", 0, "v") for t in ln.split()] for ln in WALK_LINES[FIRST_DATA - 1:] if ln.strip()]
    assert np.array_equal(m.channel_values, np.array(rows))
    assert m.frame_time == 0.008333 and np.all(np.isfinite(m.times))


@pytest.mark.parametrize("bad", BAD_TOKENS)
def test_bvh_offset_rejected_with_joint_and_axis(tmp_path, bad):
    text = WALK_TEXT.replace("OFFSET 7.3084 0.0000 0.0000", f"OFFSET 7.3084 {bad} 0.0000")
    err = _bvh_err(tmp_path, text)
    assert err.line == _line_of(text, f"OFFSET 7.3084 {bad}")
    assert "OFFSET y of joint LeftArm" in err.problem and repr(bad) in err.problem, err


@pytest.mark.parametrize("bad", ["nan", "1e308", "0_5"])
def test_bvh_end_site_offset_rejected(tmp_path, bad):
    text = WALK_TEXT.replace("OFFSET 0.0000 4.5275 0.0000", f"OFFSET 0.0000 4.5275 {bad}")
    err = _bvh_err(tmp_path, text)
    assert err.line == _line_of(text, f"4.5275 {bad}")
    assert "End Site OFFSET z of joint Head" in err.problem, err


@pytest.mark.parametrize("bad", BAD_TOKENS)
def test_bvh_frame_value_rejected_with_frame_channel_and_joint(tmp_path, bad):
    lines = list(WALK_LINES)
    k = FIRST_DATA - 1 + 4  # frame 5
    toks = lines[k].split()
    toks[7] = bad  # column 8: the second channel of Spine (after the root's 6)
    lines[k] = " ".join(toks)
    err = _bvh_err(tmp_path, "\n".join(lines))
    assert err.line == k + 1, err
    assert "frame 5" in err.problem and "Yrotation of joint Spine" in err.problem, err


@pytest.mark.parametrize("ft,fragment", [
    ("1e-320", "a rate of inf Hz"), ("0", "not a positive time"), ("-0.01", "not a positive time"),
    ("1e-7", "a rate of 1e+07 Hz"), ("2e6", "not between"), ("nan", "is not a number"),
    ("inf", "is not a number"), ("0_5", "is not a number"), ("1e999", "out of range"),
])
def test_bvh_frame_time_absurd_is_an_error_naming_its_line(tmp_path, ft, fragment):
    text = WALK_TEXT.replace("Frame Time: 0.008333", f"Frame Time: {ft}")
    err = _bvh_err(tmp_path, text)
    assert err.line == _line_of(text, "Frame Time") and fragment in err.problem, err
    assert "Infinity" not in str(err)


def test_bvh_frames_claim_checked_quickly(tmp_path):
    text = WALK_TEXT.replace("Frames: 60", "Frames: 1000000000")
    err = _bvh_err(tmp_path, text)
    assert err.line == _line_of(text, "Frames:")
    assert "Frames: 1000000000 but 60 data lines" in err.problem
    for bad in ("0_5", "1e9", "-3", "99999999999999999999999"):
        err = _bvh_err(tmp_path, WALK_TEXT.replace("Frames: 60", f"Frames: {bad}"))
        assert err.line == _line_of(WALK_TEXT, "Frames:") and "Frames:" in err.problem


def test_bvh_channels_count_strict(tmp_path):
    text = WALK_TEXT.replace("CHANNELS 3 Xrotation Yrotation Zrotation",
                             "CHANNELS 0_3 Xrotation Yrotation Zrotation", 1)
    err = _bvh_err(tmp_path, text)
    assert "CHANNELS count '0_3' of joint 'Spine'" in err.problem and err.line == 9


def test_bvh_joint_frames_bounded_before_allocation(tmp_path, monkeypatch):
    # 50 joints, only the root animated: 60 frame lines build 60 × 50 joint-frames from 60 × 6 values
    text = chain_bvh(50, 60, animated=1)
    monkeypatch.setattr(bvh_mod, "MAX_JOINT_FRAMES", 1000)
    err = _bvh_err(tmp_path, text)
    assert "60 frame lines × 50 joints" in err.problem and err.line == _line_of(text, "Frame Time") + 1
    monkeypatch.setattr(bvh_mod, "MAX_JOINT_FRAMES", 3000)
    assert read_bvh(tmp_path / "bad.bvh").n_frames == 60


def test_dev_zero_and_pipe_like_inputs_are_refused_quickly(tmp_path):
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    link = tmp_path / "zero.bvh"
    link.symlink_to("/dev/zero")
    with pytest.raises(MocapFormatError, match="NUL byte"):
        read_bvh(link)
    amc = tmp_path / "zero.amc"
    amc.symlink_to("/dev/zero")
    with pytest.raises(MocapFormatError, match="NUL byte"):
        read_amc(amc, read_asf(ASF86))


# --------------------------------------------------------------------------------------------------
# BVH: a file cut short at the end
# --------------------------------------------------------------------------------------------------


def _cut_walk(last_line: str) -> str:
    body = WALK_TEXT.rstrip("\n").split("\n")
    body[-1] = last_line
    return "\n".join(body)  # no final newline


def test_bvh_incomplete_last_frame_is_an_error_or_dropped(tmp_path):
    full = read_bvh(WALK)
    last = WALK_TEXT.rstrip("\n").split("\n")[-1]
    toks = last.split()
    cut = " ".join(toks[:40]) + " " + toks[40][:3]  # cut in the middle of value 41
    text = _cut_walk(cut)
    err = _bvh_err(tmp_path, text)
    assert err.line == len(text.split("\n")) and "incomplete" in err.problem and "no final newline" in err.problem
    p = tmp_path / "bad.bvh"
    with pytest.warns(MocapWarning, match="incomplete"):
        m = read_bvh(p, strict=False)
    assert m.n_frames == 59 and np.array_equal(m.channel_values, full.channel_values[:59])
    assert any("incomplete" in w for w in m.meta["warnings"])
    # the same short line followed by a newline is a malformed line, not a cut
    err = _bvh_err(tmp_path, text + "\n")
    assert "expected" in err.problem and "channel values" in err.problem


def test_bvh_last_value_cut_to_a_prefix_warns(tmp_path):
    last = WALK_TEXT.rstrip("\n").split("\n")[-1]
    toks = last.split()
    toks[-1] = "-0"  # the column reads like -9.8803 / 0.0000
    p = tmp_path / "cut.bvh"
    p.write_text(_cut_walk(" ".join(toks)))
    with pytest.warns(MocapWarning, match="may be cut short") as rec:
        m = read_bvh(p)
    assert f"line {len(WALK_TEXT.rstrip().split(chr(10)))}, Zrotation of joint RightToeBase" in str(rec[0].message)
    assert m.n_frames == 60 and m.channel_values[-1, -1] == 0.0
    assert any("cut short" in w for w in m.meta["warnings"])
    # the same line with its final newline, or the original last line without one: no warning
    for text in (_cut_walk(" ".join(toks)) + "\n", WALK_TEXT.rstrip("\n")):
        p.write_text(text)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            read_bvh(p)


# --------------------------------------------------------------------------------------------------
# BVH: hypothesis, mutated tokens of the real excerpt
# --------------------------------------------------------------------------------------------------

_TOKEN_POS = [(i, k) for i, ln in enumerate(WALK_LINES) for k, t in enumerate(ln.split())
              if bvh_mod.NUMBER_RE.fullmatch(t)]
_MUTANTS = ["nan", "inf", "-inf", "1e308", "-1e308", "1e999", "0_5", "1e-320", "-0", "", "1.5.5", "+", "٣"]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(_TOKEN_POS), st.sampled_from(_MUTANTS) | st.text(max_size=4)),
                min_size=1, max_size=3),
       st.one_of(st.none(), st.integers(min_value=0, max_value=len(WALK_TEXT))), st.booleans())
def test_bvh_mutations_give_an_error_or_finite_checked_values(mutations, cut_at, strict):
    raw = list(WALK_LINES)
    for (i, k), tok in mutations:
        toks = raw[i].split()
        if k < len(toks):
            toks[k] = tok
            lead = raw[i][: len(raw[i]) - len(raw[i].lstrip())]
            raw[i] = lead + " ".join(toks)
    text = "\n".join(raw)
    if cut_at is not None:
        text = text[:cut_at]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            m = parse_bvh(text, "fuzz.bvh", strict=strict)
        except MocapFormatError as e:
            assert e.path == "fuzz.bvh"
            return
    assert all(issubclass(w.category, MocapWarning) for w in caught), [str(w.message) for w in caught]
    for a in (m.channel_values, m.rotations, m.translations, m.times, m.skeleton.offsets):
        assert np.all(np.isfinite(a)) and np.all(np.abs(a) <= MAX_ABS * 1.0000001)
    assert 1e-6 <= m.frame_time <= 1e6
    # the values are those of the text, token by token, by the strict grammar
    data = text.split("\n")[FIRST_DATA - 1:]
    tokens = [[x for t in ln.split() for x in bvh_mod.NUMBER_RE.findall(t)]
              for ln in data if ln.strip()]  # glued numbers ("0.0-7.5") are split as the reader does
    # a short (cut) last line is dropped by the reader, so only full rows are parsed here
    rows = [[parse_number(x, "x", 0, "v") for x in r] for r in tokens
            if len(r) == m.channel_values.shape[1]][: m.n_frames]
    assert np.array_equal(m.channel_values, np.array(rows).reshape(m.channel_values.shape))


# --------------------------------------------------------------------------------------------------
# ASF / AMC: strict numbers, cut files
# --------------------------------------------------------------------------------------------------

ASF_TEXT = ASF86.read_text()
AMC_TEXT = AMC86.read_text()


@pytest.mark.parametrize("old,new,fragment", [
    ("length 2.46425", "length 1e308", "length: '1e308' is out of range"),
    ("length 2.46425", "length 0_5", "length: '0_5' is not a number"),
    ("direction 0.561145 -0.797705", "direction 0x1 -0.797705", "direction: '0x1' is not a number"),
    ("axis 0 0 20", "axis 0 nan 20", "axis is NaN"),
    ("axis 0 0 20", "axis 0 1e999 20", "axis: '1e999' is out of range"),
    ("length 0.45", "length 1e-300", "units length 1e-300 is not between"),
    ("mass 1.0", "mass 1e13", "units mass: '1e13' is out of range"),
    ("position 0 0 0", "position 0 1e308 0", ":root position: '1e308' is out of range"),
    ("limits (-160.0 20.0)", "limits (-160.0 2e12)", "limits: '2e12' is out of range"),
])
def test_asf_strict_numbers(tmp_path, old, new, fragment):
    assert old in ASF_TEXT
    text = ASF_TEXT.replace(old, new, 1)
    p = tmp_path / "bad.asf"
    p.write_text(text)
    with pytest.raises(MocapFormatError) as ei:
        read_asf(p)
    assert ei.value.path == str(p) and ei.value.line == _line_of(text, new) and fragment in ei.value.problem, ei.value


def test_asf_limits_inf_is_the_acclaim_convention():
    sk = read_asf_text(ASF_TEXT.replace("limits (-160.0 20.0)", "limits (-inf inf)", 1), "x.asf")
    lims = [b["limits"] for b in sk.meta["asf"]["bones"].values() if b["limits"]]
    assert (-math.inf, math.inf) in [lim for bone in lims for lim in bone]


@pytest.mark.parametrize("bad", ["1e308", "-2e12", "nan", "inf", "0_5", "1e999"])
def test_amc_values_strict(tmp_path, bad):
    lines = AMC_TEXT.split("\n")
    k = _line_of(AMC_TEXT, "root ", 3) - 1
    toks = lines[k].split()
    toks[2] = bad
    lines[k] = " ".join(toks)
    text = "\n".join(lines)
    p = tmp_path / "bad.amc"
    p.write_text(text)
    with pytest.raises(MocapFormatError) as ei:
        read_amc(p, read_asf(ASF86))
    assert ei.value.path == str(p) and ei.value.line == k + 1 and "bone root" in ei.value.problem, ei.value


def test_amc_cut_files(tmp_path):
    sk = read_asf(ASF86)
    body = AMC_TEXT.rstrip("\n").split("\n")
    last = body[-1].split()
    # a last value cut to a prefix, no final newline: read, with a warning
    cut = body[:-1] + [" ".join(last[:-1] + ["-0"])]
    col = [ln.split()[-1] for ln in body if ln.split() and ln.split()[0] == last[0]]
    assert min(len(t.partition(".")[2]) for t in col) > 0  # every earlier value of the column has decimals
    with pytest.warns(MocapWarning, match="may be cut short"):
        m = read_amc_text("\n".join(cut), sk, "cut.amc")
    assert m.meta["warnings"] and m.meta["amc_values"][last[0]][-1, -1] == 0.0
    with warnings.catch_warnings():  # the intact file without its final newline: no warning
        warnings.simplefilter("error")
        read_amc_text("\n".join(body), sk, "cut.amc")
    # a last line with a value missing: an error that says so
    short = body[:-1] + [" ".join(last[:-1])]
    with pytest.raises(MocapFormatError, match="cut short") as ei:
        read_amc_text("\n".join(short), sk, "cut.amc")
    assert ei.value.line == len(short)
    # a last frame missing its last bones
    k = max(i for i, ln in enumerate(body) if ln.strip().isdigit())
    with pytest.raises(MocapFormatError, match="cut short"):
        read_amc_text("\n".join(body[: k + 3]), sk, "cut.amc")


def test_amc_crlf_cut_inside_its_last_number_is_reported(tmp_path):
    """The CMU excerpt (CRLF line ends, ``%g`` values: ``-6.563`` beside ``-4.49705``) cut inside its last
    number, no final newline: ``ltoes -4.2989`` for ``-4.29898`` has as many decimals as some earlier
    ``ltoes`` values, so only its length against the longest tells (a warning naming file and line);
    ``-4.`` and ``-`` end like a cut number (an error naming the line)."""
    raw = AMC86.read_bytes()
    assert raw.endswith(b"ltoes -4.29898\r\n")
    body = raw[:-2]
    n = body.count(b"\n") + 1                       # the last line's number
    asf = tmp_path / "86.asf"
    asf.write_bytes(ASF86.read_bytes())
    sk = read_asf(asf)
    col = [ln.split()[-1] for ln in body.split(b"\r\n") if ln.startswith(b"ltoes ")][:-1]
    assert any(len(t.partition(b".")[2]) <= 4 for t in col)   # the decimals vary: rule (b) cannot tell
    for eol in (b"\r\n", b"\n"):                     # the line ends make no difference
        text = body.replace(b"\r\n", eol)
        amc = tmp_path / "cut.amc"
        for cut in (b"-4.2989", b"-4.298", b"-4.29", b"-4"):
            amc.write_bytes(text[:-len(b"-4.29898")] + cut)
            with pytest.warns(MocapWarning) as rec:
                m = read_amc(amc, sk)
            msgs = [str(w.message) for w in rec if issubclass(w.category, MocapWarning)]
            assert any(x.startswith(f"{amc}: line {n}, bone ltoes:") and "may be cut short" in x for x in msgs), msgs
            assert any(f"line {n}" in w for w in m.meta["warnings"])
            assert m.meta["amc_values"]["ltoes"][-1, -1] == float(cut)
        for cut in (b"-4.", b"-"):
            amc.write_bytes(text[:-len(b"-4.29898")] + cut)
            with pytest.raises(MocapFormatError) as ei:
                read_amc(amc, sk)
            assert ei.value.path == str(amc) and ei.value.line == n and "cut short" in ei.value.problem, str(ei.value)
        # the intact file without its final newline is read whole (no error)
        amc.write_bytes(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MocapWarning)
            m = read_amc(amc, sk)
        assert m.meta["amc_values"]["ltoes"][-1, -1] == -4.29898


_AMC_HEAD = "\n".join(AMC_TEXT.split("\n")[: _line_of(AMC_TEXT, "root ", 4) - 2])  # 3 frames
_AMC_POS = [(i, k) for i, ln in enumerate(_AMC_HEAD.split("\n")) for k, t in enumerate(ln.split())
            if k > 0 and bvh_mod.NUMBER_RE.fullmatch(t)]
_ASF86_SK = read_asf(ASF86)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(_AMC_POS), st.sampled_from(_MUTANTS) | st.text(max_size=4)),
                min_size=1, max_size=3),
       st.one_of(st.none(), st.integers(min_value=0, max_value=len(_AMC_HEAD))))
def test_amc_mutations_give_an_error_or_finite_checked_values(mutations, cut_at):
    raw = _AMC_HEAD.split("\n")
    for (i, k), tok in mutations:
        toks = raw[i].split()
        if k < len(toks):
            toks[k] = tok
            raw[i] = " ".join(toks)
    text = "\n".join(raw)[:cut_at]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            m = read_amc_text(text, _ASF86_SK, "fuzz.amc")
        except MocapFormatError as e:
            assert e.path == "fuzz.amc"
            return
    assert all(issubclass(w.category, MocapWarning) for w in caught), [str(w.message) for w in caught]
    assert np.all(np.isfinite(m.rotations)) and np.all(np.abs(m.translations) <= 2 * MAX_ABS)
    for name, vals in m.meta["amc_values"].items():  # the values of the text, by the strict grammar
        lines = [ln.split("#", 1)[0].split() for ln in re.split(r"\r\n|\r|\n", text)]
        ref = [[parse_number(t, "x", 0, "v") for t in ln[1:]] for ln in lines if ln and ln[0] == name]
        assert np.array_equal(vals, np.array(ref)), name


@pytest.mark.parametrize("rate", [1e-320, 1e7, 1e300])
def test_amc_rate_bounds(rate):
    with pytest.raises(Exception, match="rate must be between"):
        read_amc(AMC86, read_asf(ASF86), rate=rate)


# --------------------------------------------------------------------------------------------------
# no recursion: 10,000-joint chains in the library
# --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def chain_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("chains")
    (d / "chain.bvh").write_text(chain_bvh(10_000, 3))
    (d / "named.bvh").write_text(chain_bvh(10_000, 240, animated=20, named=True))
    (d / "chain.asf").write_text(chain_asf(2_500))
    (d / "chain_01.amc").write_text(chain_amc(2_500, 4))
    return d


def test_bvh_chain_reads_writes_and_fk_matches_naive(chain_files, tmp_path):
    m = read_bvh(chain_files / "chain.bvh")
    sk = m.skeleton
    assert sk.n_joints == 10_000 and np.array_equal(sk.parents, np.arange(-1, 9_999))
    assert sk.depth_first() == list(range(10_000)) and sk.depths()[-1] == 9_999
    write_bvh(tmp_path / "w.bvh", m)
    back = read_bvh(tmp_path / "w.bvh")
    assert back.skeleton.names == sk.names and np.array_equal(back.skeleton.parents, sk.parents)
    assert np.array_equal(back.channel_values, m.channel_values) and back.skeleton.end_sites == sk.end_sites
    assert (tmp_path / "w.bvh").stat().st_size < 3 * (chain_files / "chain.bvh").stat().st_size  # linear
    P = forward_kinematics(m)[0]
    sub = 300  # the naive FK of the first 300 joints (its own chain) checks the batched one
    from mocapkit.skeleton import Motion
    msub = Motion(Skeleton(sk.names[:sub], sk.parents[:sub], sk.offsets[:sub], sk.channels[:sub]),
                  m.times, m.rotations[:, :sub], m.translations[:, :sub])
    assert np.allclose(P[:, :sub], naive_positions(msub), atol=1e-9, rtol=1e-12)


def test_skeleton_helpers_match_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(20):
        J = int(rng.integers(1, 40))
        parents = np.array([-1] + [int(rng.integers(-1, j)) for j in range(1, J)])
        sk = Skeleton(tuple(f"n{j}" for j in range(J)), parents, np.zeros((J, 3)), ((),) * J)
        kids = [[k for k in range(J) if parents[k] == j] for j in range(J)]
        assert sk.children_lists() == kids and all(sk.children(j) == kids[j] for j in range(J))

        def pre(j):  # small trees: recursion is fine in the reference
            return [j] + [x for k in kids[j] for x in pre(k)]

        assert sk.depth_first() == [x for r in range(J) if parents[r] < 0 for x in pre(r)]
        depth = [0 if parents[j] < 0 else None for j in range(J)]
        for j in range(J):
            d, p = 0, parents[j]
            while p >= 0:
                d, p = d + 1, parents[p]
            depth[j] = d
        assert sk.depths().tolist() == depth
        assert all(sk.index(f"n{j}") == j for j in range(J))


def test_reach_and_chain_depth_match_brute_force(monkeypatch):
    m = read_bvh(WALK)
    sk = m.skeleton
    P, _, E = forward_kinematics(m, end_sites=True)
    brute = np.zeros(sk.n_joints)
    for j in range(sk.n_joints):
        for k in range(sk.n_joints):
            a = sk.parents[k]
            while a >= 0 and a != j:
                a = sk.parents[a]
            if a == j:
                brute[j] = max(brute[j], np.linalg.norm(P[:, k] - P[:, j], axis=-1).max())
        for e, (k, _) in enumerate(sk.end_sites):
            a = k
            while a >= 0 and a != j:
                a = sk.parents[a]
            if a == j:
                brute[j] = max(brute[j], np.linalg.norm(E[:, e] - P[:, j], axis=-1).max())
    assert np.array_equal(pla_skeletal._reach(m), brute)
    monkeypatch.setattr(pla_skeletal, "REACH_EXACT_BUDGET", 0)  # the triangle bound: never below
    bound = pla_skeletal._reach(m)
    assert np.all(bound >= brute - 1e-9) and np.all(bound[brute == 0] == 0)
    rot, tr = pla_skeletal.animated_tracks(m)
    naive = 1
    for k in range(sk.n_joints):
        c, i = 0, k
        while i >= 0:
            c += (i in rot) + (i in tr)
            i = sk.parents[i]
        naive = max(naive, c)
    assert pla_skeletal._chain_depth(m, rot, tr) == naive


def test_grouped_decode_equals_per_track_reconstruct(chain_files):
    m = read_bvh(chain_files / "named.bvh")
    comp = compress_motion(m, "fastsw", threshold=1e-4)
    dec = comp.decode()
    for j, c in comp.rotations.items():
        assert np.array_equal(dec.rotations[:, j], reconstruct(c, m.times))
    for j, c in comp.translations.items():
        assert np.array_equal(dec.translations[:, j], reconstruct(c, m.times))


def test_asf_amc_chain_reads_and_converts(chain_files, tmp_path):
    sk = read_asf(chain_files / "chain.asf")
    assert sk.n_joints == 2_501 and np.array_equal(sk.parents, np.arange(-1, 2_500))
    m = read_amc(chain_files / "chain_01.amc", sk)
    write_bvh(tmp_path / "c.bvh", m)
    back = read_bvh(tmp_path / "c.bvh")
    assert np.allclose(forward_kinematics(back)[0], forward_kinematics(m)[0], atol=1e-4)
    rep = write_amc(tmp_path / "c.amc", back, sk)
    assert rep["max_residual_deg"] < 1e-3
    again = read_amc(tmp_path / "c.amc", sk)
    for n, v in m.meta["amc_values"].items():
        assert np.allclose(again.meta["amc_values"][n], v, atol=1e-3), n


def test_asf_hierarchy_cycle_still_found_linearly():
    text = chain_asf(50).replace("    root b1\n", "    root b1\n    b50 b1\n")
    with pytest.raises(MocapFormatError, match="two parents"):
        read_asf_text(text, "x.asf")
    text = chain_asf(50).replace("    root b1\n", "    b50 b1\n")
    with pytest.raises(MocapFormatError, match="cycle in :hierarchy: b1 -> b2 -> b3"):
        read_asf_text(text, "x.asf")


# --------------------------------------------------------------------------------------------------
# glTF: hostile files
# --------------------------------------------------------------------------------------------------


def _glb_parts(path: Path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    jlen = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + jlen])
    blen = struct.unpack_from("<I", data, 20 + jlen)[0]
    return doc, data[28 + jlen: 28 + jlen + blen]


def _glb_bytes(doc, blob: bytes) -> bytes:
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    blob += b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(j) + 8 + len(blob)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(j), 0x4E4F534A) + j
            + struct.pack("<II", len(blob), 0x004E4942) + blob)


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("clip")
    comp = compress_motion(read_bvh(WALK), "fastsw", max_position_error=0.5)
    return write_gltf(d / "walk.glb", comp)


def _hostile(tmp_path, clip, mutate) -> MocapFormatError:
    doc, blob = _glb_parts(clip)
    out = mutate(doc, bytearray(blob))
    data = out if isinstance(out, bytes) else _glb_bytes(doc, bytes(blob if out is None else out))
    p = tmp_path / "user clip.glb"
    p.write_bytes(data)
    with pytest.raises(MocapFormatError) as ei:
        read_gltf(p)
    assert ei.value.path == str(p) and str(ei.value).startswith(str(p)), ei.value
    assert ".tmp" not in str(ei.value)
    return ei.value


def _set(path, value):
    def f(doc, blob):
        obj = doc
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value
    return f


def _nan_in_output(doc, blob):
    acc = doc["accessors"][doc["animations"][0]["samplers"][0]["output"]]
    off = doc["bufferViews"][acc["bufferView"]].get("byteOffset", 0) + acc.get("byteOffset", 0)
    blob[off:off + 4] = struct.pack("<f", float("nan"))
    return blob


def _deep_json(doc, blob):
    return b"glTF" + struct.pack("<II", 2, 12 + 8 + 200_004) + struct.pack("<II", 200_004, 0x4E4F534A) + \
        b"[" * 100_002 + b"]" * 100_002


@pytest.mark.parametrize("mutate,fragment", [
    (_set(["accessors", 0, "count"], 10**15), "reach past the end"),
    (_set(["accessors", 0, "count"], -1), "count must be an integer"),
    (_set(["accessors", 0, "count"], "many"), "count must be an integer"),
    (_set(["bufferViews", 0, "byteStride"], -8), "byteStride must be an integer"),
    (_set(["bufferViews", 0, "byteOffset"], 2**40), "reaches past the end"),
    (_nan_in_output, "not finite"),
    (_set(["nodes", 2, "children"], [0]), "cycle"),
    (_set(["nodes", 2, "children"], [1]), "shared child"),
    (_set(["nodes", 0, "children"], [0]), "invalid or shared child"),
    (_set(["nodes", 0, "translation"], [0, 1e300, 0]), "translation"),
    (_set(["animations", 0, "extras", "mocapkit", "frame_time"], 1e-320), "extras frame_time"),
    (_set(["animations", 0, "extras", "mocapkit", "n_frames"], 10**12), "joint-frames"),
    (_set(["animations", 0, "extras", "mocapkit", "unit_m"], 0), "extras unit_m"),
    (_set(["animations", 0, "extras", "mocapkit", "channels"], [["Wrotation"]] * 23), "BVH channel names"),
    (_set(["animations", 0, "samplers", 0, "input"], 10**6), "accessor index"),
    (_deep_json, "nested too deeply"),
    (lambda doc, blob: _glb_bytes(doc, bytes(blob))[:-100], "cut short"),
])
def test_hostile_gltf_gives_format_errors_naming_the_users_file(tmp_path, clip, mutate, fragment):
    err = _hostile(tmp_path, clip, mutate)
    assert fragment in err.problem, err


def test_gltf_json_nan_literal_and_deep_node_chain(tmp_path, clip):
    doc, blob = _glb_parts(clip)
    p = tmp_path / "c.gltf"
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    text = json.dumps(doc)
    assert '"t0": 0.0' in text
    p.write_text(text)
    assert read_gltf(p).n_frames == 60  # the embedded-buffer form reads
    p.write_text(text.replace('"t0": 0.0', '"t0": NaN'))
    with pytest.raises(MocapFormatError, match="NaN is not a JSON number"):
        read_gltf(p)
    # a chain of 10,000 plain nodes with one rotation track: read at a given rate, no recursion
    n = 10_000
    times = np.array([0.0, 1.0], dtype="<f4")
    quats = np.array([[0, 0, 0, 1], [0, 0, 0.7071068, 0.7071068]], dtype="<f4")
    blob2 = times.tobytes() + quats.tobytes()
    doc3 = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}],
            "nodes": [{"name": f"n{i}", "translation": [0, 0.1, 0], **({"children": [i + 1]} if i + 1 < n else {})}
                      for i in range(n)],
            "buffers": [{"byteLength": len(blob2)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 8},
                            {"buffer": 0, "byteOffset": 8, "byteLength": 32}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR"},
                          {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"}],
            "animations": [{"samplers": [{"input": 0, "output": 1}],
                            "channels": [{"sampler": 0, "target": {"node": 5, "path": "rotation"}}]}]}
    p = tmp_path / "deep.glb"
    p.write_bytes(_glb_bytes(doc3, blob2))
    m = read_gltf(p, rate=4)
    assert m.skeleton.n_joints == n and m.n_frames == 5 and np.array_equal(m.skeleton.parents, np.arange(-1, n - 1))
    expect = Rotation.from_quat(quats.astype(float)[1]).as_quat()
    assert np.allclose(m.rotations[-1, 5][[1, 2, 3, 0]], expect, atol=1e-6)
    with pytest.raises(Exception, match="rate must be between"):
        read_gltf(p, rate=1e-320)


# --------------------------------------------------------------------------------------------------
# CLI on the chains: every command, one-line errors, strict JSON
# --------------------------------------------------------------------------------------------------


def run(*args, timeout=900) -> subprocess.CompletedProcess:
    r = subprocess.run([*EXE, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    assert "Traceback" not in r.stderr and "RecursionError" not in r.stderr, r.stderr[-2000:]
    return r


def _strict_json(s: str):
    def no(c):
        raise AssertionError(f"non-finite {c} in JSON")
    return json.loads(s, parse_constant=no)


def test_cli_every_command_on_a_10000_joint_chain(chain_files, tmp_path):
    bvh = chain_files / "chain.bvh"
    r = run("info", bvh, "--json")
    assert r.returncode == 0, r.stderr
    rec = _strict_json(r.stdout)
    assert rec["joints"] == 10_000 and rec["frames"] == 3 and rec["rate_hz"] == pytest.approx(1 / 0.0333333)
    r = run("convert", bvh, tmp_path / "c.bvh")
    assert r.returncode == 0, r.stderr
    assert np.array_equal(read_bvh(tmp_path / "c.bvh").channel_values, read_bvh(bvh).channel_values)
    r = run("compress", bvh, "--max-position-error", "1", "--unit-cm", "1", "-o", tmp_path / "c.glb", "--json")
    assert r.returncode == 0, r.stderr
    rec = _strict_json(r.stdout)
    assert rec["n_joints"] == 10_000 and rec["max_position_error_cm"] <= 1.0
    r = run("decompress", tmp_path / "c.glb", "-o", tmp_path / "d.bvh")
    assert r.returncode == 0, r.stderr
    orig, dec = read_bvh(bvh), read_bvh(tmp_path / "d.bvh")
    assert dec.skeleton.names == orig.skeleton.names
    err = np.linalg.norm(forward_kinematics(dec)[0] - forward_kinematics(orig)[0], axis=-1).max()
    assert err <= 1.0 + 1e-3  # the bound, up to float32 storage and 6 written decimals
    r = run("compress", bvh, "--max-position-error", "1", "--unit-cm", "1", "-o", tmp_path / "c2.bvh")
    assert r.returncode == 0, r.stderr
    err = np.linalg.norm(forward_kinematics(read_bvh(tmp_path / "c2.bvh"))[0] - forward_kinematics(orig)[0], axis=-1)
    assert err.max() <= 1.0 + 1e-4
    r = run("segment", bvh)  # no joint names to find the limbs by: a clean one-line error
    assert r.returncode == 2 and r.stderr.startswith("error: ") and r.stderr.count("\n") == 1
    assert "and 9960 more joints" in r.stderr


def test_cli_segment_and_amc_chain(chain_files, tmp_path):
    r = run("segment", chain_files / "named.bvh", "--json")
    assert r.returncode == 0, r.stderr
    _strict_json(r.stdout)
    amc = chain_files / "chain_01.amc"
    r = run("info", amc, "--json")
    assert r.returncode == 0, r.stderr
    assert _strict_json(r.stdout)["joints"] == 2_501
    r = run("convert", amc, tmp_path / "a.bvh", "--asf", chain_files / "chain.asf")
    assert r.returncode == 0, r.stderr
    m = read_amc(amc, read_asf(chain_files / "chain.asf"))
    assert np.allclose(forward_kinematics(read_bvh(tmp_path / "a.bvh"))[0], forward_kinematics(m)[0], atol=1e-4)


def test_cli_bad_bvh_numbers_are_one_line_errors(tmp_path):
    for old, new in (("Frame Time: 0.008333", "Frame Time: 1e-320"), ("OFFSET 7.3084 0.0000", "OFFSET nan 0.0000")):
        p = tmp_path / "b.bvh"
        p.write_text(WALK_TEXT.replace(old, new))
        for cmd in (("info", p, "--json"), ("convert", p, tmp_path / "o.bvh"),
                    ("compress", p, "--max-position-error", "1", "-o", tmp_path / "o.glb")):
            r = run(*cmd)
            assert r.returncode == 2 and r.stderr.startswith(f"error: {p}:") and r.stderr.count("\n") == 1, r.stderr
            assert "Infinity" not in r.stdout and not (tmp_path / "o.bvh").exists()


# --------------------------------------------------------------------------------------------------
# glTF JSON with lines duplicated or deleted (the trial's mutation of a `.gltf` clip)
# --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def gltf_text(tmp_path_factory):
    """The JSON text (one field or array item a line) of a `.gltf` clip of the walk, and its decode."""
    d = tmp_path_factory.mktemp("gltf_text")
    comp = compress_motion(read_bvh(WALK), "fastsw", max_position_error=1.0)
    p = write_gltf(d / "walk.gltf", comp)
    text = p.read_text()
    assert text.count("\n") > 500  # indented: the mutations below act on single fields
    return text, read_gltf(p)


def _same_motion(a, b) -> bool:
    sa, sb = a.skeleton, b.skeleton
    return (sa.names == sb.names and np.array_equal(sa.parents, sb.parents) and sa.channels == sb.channels
            and np.array_equal(sa.offsets, sb.offsets) and sa.end_sites == sb.end_sites
            and np.array_equal(a.times, b.times) and np.array_equal(a.rotations, b.rotations)
            and np.array_equal(a.translations, b.translations))


def _mutate_lines(text: str, edits) -> str:
    lines = text.split("\n")
    for op, k in edits:
        i = k % len(lines)
        if op == "dup":
            lines.insert(i, lines[i])
        else:
            del lines[i]
    return "\n".join(lines)


@given(edits=st.lists(st.tuples(st.sampled_from(["dup", "del"]), st.integers(0, 10**6)), min_size=1, max_size=3))
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_gltf_json_lines_duplicated_or_deleted_read_the_same_or_fail_cleanly(gltf_text, tmp_path, edits):
    text, original = gltf_text
    p = tmp_path / "mutated clip.gltf"
    p.write_text(_mutate_lines(text, edits))
    try:
        m = read_gltf(p)
    except MocapFormatError as exc:
        assert exc.path == str(p) and str(exc).startswith(str(p)) and exc.problem, exc
        return
    # a clean read is the unchanged clip (a duplicated key keeps its value, a deleted optional field
    # had its default): anything else would be a silently different motion
    assert _same_motion(m, original), edits
    write_bvh(tmp_path / "d.bvh", m)  # and it can be written (the trial's crash was in this step)


def _drop_channel(doc):
    doc["animations"][0]["extras"]["mocapkit"]["channels"][1].remove("Yrotation")  # the trial's 'XZ'


def _drop_root_x(doc):
    doc["animations"][0]["extras"]["mocapkit"]["channels"][0].remove("Xposition")


def _drop(*keys):
    def f(doc):
        obj = doc
        for k in keys[:-1]:
            obj = obj[k]
        del obj[keys[-1]]
    return f


def _cut_first_child(doc):
    del doc["nodes"][0]["children"][0]


@pytest.mark.parametrize("mutate,fragment", [
    (_drop_channel, "extras channels of joint 1 must hold no rotation or all three"),
    (_drop_root_x, "no Xposition channel in the extras but its X translation differs"),
    (_drop("animations", 0, "extras", "mocapkit", "t0"), "has no 't0' field"),
    (_drop("animations", 0, "extras", "mocapkit", "unit_m"), "has no 'unit_m' field"),
    (_drop("nodes", 3, "name"), "node 3: no name"),
    (_drop("animations", 0, "channels", 0, "target", "path"), "animation channel 0: a mocapkit file animates"),
    (_cut_first_child, "scene 0 lists root nodes"),  # a joint cut loose from its parent
])
def test_gltf_damaged_extras_and_hierarchy_name_the_field(gltf_text, tmp_path, mutate, fragment):
    doc = json.loads(gltf_text[0])
    mutate(doc)
    p = tmp_path / "walk.gltf"
    p.write_text(json.dumps(doc, indent=2))
    with pytest.raises(MocapFormatError) as ei:
        read_gltf(p)
    assert ei.value.path == str(p) and fragment in ei.value.problem, ei.value
