"""BVH reading/writing, forward kinematics, whole-skeleton compression and glTF export."""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit.errors import MocapFormatError
from mocapkit.io.formats.gltf import write_gltf
from mocapkit.io.skeletal.bvh import parse_bvh, read_bvh, write_bvh
from mocapkit.pla.skeletal import compress_motion, position_errors
from mocapkit.skeleton import forward_kinematics
from reference_kinematics import gltf_validator

ROOT = Path(__file__).resolve().parents[1]


def naive_fk(motion):
    """Independent per-frame FK straight from the BVH channel values (scipy matrices, Python loops)."""
    sk = motion.skeleton
    N, J = motion.channel_values.shape[0], sk.n_joints
    out = np.zeros((N, J, 3))
    for f in range(N):
        col = 0
        Rw = [None] * J
        for j in range(J):
            t = np.array(sk.offsets[j], dtype=float)
            order, ang = "", []
            for c in sk.channels[j]:
                v = motion.channel_values[f, col]
                col += 1
                if c.endswith("position"):
                    t["XYZ".index(c[0])] = v
                else:
                    order += c[0]
                    ang.append(v)
            r = Rotation.from_euler(order, ang, degrees=True).as_matrix() if order else np.eye(3)
            p = sk.parents[j]
            if p < 0:
                Rw[j], out[f, j] = r, t
            else:
                Rw[j] = Rw[p] @ r
                out[f, j] = out[f, p] + Rw[p] @ t
    return out


def bvh_files(tests_data):
    return sorted((tests_data / "bvh").glob("*.bvh"))


@pytest.fixture(scope="module")
def shared_bvh(shared_data):
    return sorted((shared_data / "bvh").glob("*.bvh"))


def test_fk_matches_naive_on_excerpts(tests_data):
    for f in bvh_files(tests_data):
        m = read_bvh(f)
        P, _ = forward_kinematics(m)
        assert np.abs(P - naive_fk(m)).max() < 1e-9, f.name


def test_fk_matches_naive_on_shared_files(shared_bvh):
    assert len(shared_bvh) >= 2
    for f in shared_bvh:
        m = read_bvh(f)
        sub = type(m)(m.skeleton, m.times[::25], m.rotations[::25], m.translations[::25], m.channel_values[::25])
        P, _ = forward_kinematics(sub)
        assert np.abs(P - naive_fk(sub)).max() < 1e-9, f.name


def test_shared_files_structure(shared_bvh):
    pn = read_bvh([f for f in shared_bvh if "perception" in f.name][0])
    assert pn.skeleton.n_joints == 59 and all(len(c) == 6 for c in pn.skeleton.channels)
    assert pn.n_frames == 733 and pn.rate == pytest.approx(125.0, rel=1e-3)


def test_round_trip_exact(tmp_path, shared_data):
    for f in sorted((shared_data / "bvh").glob("*.bvh")):
        m = read_bvh(f)
        write_bvh(tmp_path / "a.bvh", m, precision=6)
        m2 = read_bvh(tmp_path / "a.bvh")
        assert np.array_equal(m2.channel_values, m.channel_values), f.name  # files have <= 6 decimals
        assert np.array_equal(m2.skeleton.offsets, m.skeleton.offsets)
        assert m2.skeleton.names == m.skeleton.names and m2.skeleton.channels == m.skeleton.channels
        # from rotations (no channel values): same world positions
        write_bvh(tmp_path / "b.bvh", m, precision=9, use_channel_values=False)
        P3, _ = forward_kinematics(read_bvh(tmp_path / "b.bvh"))
        assert np.abs(P3 - forward_kinematics(m)[0]).max() < 1e-5


TRICKY = """HIERARCHY\r
ROOT mixamorig:Hips{\r
\tOFFSET 1 2 3\r
\tCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation\r
\tJOINT left.leg\r
\t{\r
\t\tOFFSET 0 -10 0\r
\t\tCHANNELS 3 Xrotation Zrotation Yrotation\r
\t\tEnd Site\r
\t\t{\r
\t\t\tOFFSET 0 -5 0\r
\t\t}\r
\t}\r
}\r
ROOT Prop\r
{\r
\tOFFSET 0 0 0\r
\tCHANNELS 3 Zrotation Xrotation Yrotation\r
}\r
MOTION\r
Frames: 2\r
Frame Time: 0.01\r
0.0-7.5 1 10 20 30 1 2 3 4 5 6\r
1 2 3 4 5 6 7 8 9 10 11 12"""


def test_tricky_file():
    m = parse_bvh(TRICKY, "tricky.bvh")
    sk = m.skeleton
    assert sk.names == ("mixamorig:Hips", "left.leg", "Prop")
    assert list(sk.parents) == [-1, 0, -1]
    assert sk.rotation_order(0) == "YXZ" and sk.rotation_order(1) == "XZY"
    assert m.channel_values[0, :2].tolist() == [0.0, -7.5]  # glued numbers split
    assert np.allclose(m.translations[0, 0], [0.0, -7.5, 1.0])  # positions replace the offset
    assert np.abs(forward_kinematics(m)[0] - naive_fk(m)).max() < 1e-12


@pytest.mark.parametrize(
    "mutate,needle",
    [
        (lambda s: s.replace("Frames: 2", "Frames: 3"), "Frames: 3 but 2"),
        (lambda s: s.replace("12", "12 13"), "expected 12 channel values"),
        (lambda s: s.replace("Zrotation Xrotation Yrotation", "Zrotation Xrotation Wrotation"), "unknown channel"),
        (lambda s: s.replace("OFFSET 0 -10 0", "OFFSET 0 x 0"), "not a number"),
        (lambda s: s.replace("Frame Time: 0.01", "Frame Time: 0"), "Frame Time"),
        (lambda s: s.replace("1 2 3 4 5 6 7 8 9 10 11 12", "1 2 3 4 5 6 7 8 9 10 11 abc"), "'abc'"),
        (lambda s: s.split("MOTION")[0], "no MOTION"),
        (lambda s: "", "empty"),
        (lambda s: s.replace("left.leg", "Prop"), "used twice"),
    ],
)
def test_rejections(mutate, needle):
    with pytest.raises(MocapFormatError) as e:
        parse_bvh(mutate(TRICKY), "bad.bvh")
    assert "bad.bvh" in str(e.value) and needle in str(e.value)


def test_frame_count_mismatch_non_strict():
    m = parse_bvh(TRICKY.replace("Frames: 2", "Frames: 5"), "x.bvh", strict=False)
    assert m.n_frames == 2 and "Frames: 5 but 2" in m.meta["warnings"][0]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_bvh_only_format_errors(tests_data, data):
    text = (tests_data / "bvh" / "walk-meredith-60.bvh").read_text()
    lines = text.split("\n")
    op = data.draw(st.sampled_from(["del", "dup", "tok", "trunc", "byte"]))
    i = data.draw(st.integers(0, len(lines) - 1))
    if op == "del":
        del lines[i]
    elif op == "dup":
        lines.insert(i, lines[i])
    elif op == "tok":
        toks = lines[i].split() or [""]
        k = data.draw(st.integers(0, len(toks) - 1))
        toks[k] = data.draw(st.sampled_from(["{", "}", "nan", "-", "1e999", "JOINT", "End", "", "0.0.0", "CHANNELS"]))
        lines[i] = " ".join(toks)
    elif op == "trunc":
        lines = lines[:i]
    else:
        s = lines[i]
        k = data.draw(st.integers(0, max(len(s) - 1, 0)))
        lines[i] = s[:k] + data.draw(st.characters(blacklist_categories=("Cs",))) + s[k + 1:]
    with contextlib.suppress(MocapFormatError):
        parse_bvh("\n".join(lines), "fuzz.bvh")


@pytest.mark.parametrize("cm", [0.5, 2.0])
def test_max_position_error_bound_by_independent_fk(tests_data, tmp_path, cm):
    for f in bvh_files(tests_data):
        m = read_bvh(f)
        comp = compress_motion(m, "fastsw", max_position_error=cm)
        dec = comp.decode()
        write_bvh(tmp_path / "dec.bvh", dec, precision=10, use_channel_values=False)
        back = read_bvh(tmp_path / "dec.bvh")
        err = np.linalg.norm(naive_fk(back) - naive_fk(m), axis=-1)
        assert err.max() <= cm * (1 + 1e-6), (f.name, err.max())
        assert comp.n_keyframes < 0.5 * comp.n_samples  # and it does compress


def test_max_position_error_on_shared_files(shared_bvh):
    for f in shared_bvh:
        m = read_bvh(f)
        comp = compress_motion(m, "fastsw", max_position_error=1.0)
        assert position_errors(m, comp.decode()).max() <= 1.0 * (1 + 1e-9)


@pytest.mark.node
@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_gltf_valid_and_keyframes(tests_data, tmp_path, suffix):
    node, mods = gltf_validator()
    m = read_bvh(tests_data / "bvh" / "perception-neuron-freya-12.bvh")
    comp = compress_motion(m, "cplr", target_icr=0.2)
    out = write_gltf(tmp_path / f"pn{suffix}", comp)
    r = subprocess.run([node, str(ROOT / "tools" / "validate_gltf.mjs"), str(out)], capture_output=True, text=True,
                       env={**os.environ, "NODE_PATH": str(mods)}, timeout=120)
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout.strip().splitlines()[-1])
    assert rep["numErrors"] == 0, rep["messages"]
    assert rep["numWarnings"] == 0
    g = pygltflib.GLTF2().load(str(out))
    anim = g.animations[0]
    counts = {}
    for ch in anim.channels:
        counts[(ch.target.node, ch.target.path)] = g.accessors[anim.samplers[ch.sampler].input].count
    for j, c in comp.rotations.items():
        assert counts[(j, "rotation")] == c.n_points
    for j, c in comp.translations.items():
        assert counts[(j, "translation")] == c.n_points
    assert len(counts) == len(comp.rotations) + len(comp.translations)


def test_cli_skeletal_compress_json(tests_data, tmp_path):
    f = tests_data / "bvh" / "walk-meredith-60.bvh"
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "compress", str(f), "-o", str(tmp_path / "w.glb"),
                        "--max-position-error", "1", "--unit-cm", "2.54", "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    for k in ("n_frames", "n_joints", "icr", "keyframes", "max_position_error_cm", "mean_position_error_cm",
              "aad_deg", "max_deg", "bytes_raw", "bytes_out", "ratio"):
        assert k in rec
    assert rec["max_position_error_cm"] <= 1.0 * (1 + 1e-9) and rec["n_frames"] == 60
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "compress", str(f), "-o", str(tmp_path / "w.bvh"),
                        "--target-icr", "0.2"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert read_bvh(tmp_path / "w.bvh").n_frames == 60


def test_amc_to_bvh_round_trip_positions(tests_data, tmp_path):
    """ASF/AMC -> BVH -> read back: world positions equal within 1e-6 of the length unit."""
    from mocapkit.io.skeletal.amc import read_amc, read_asf

    cmu = tests_data / "cmu"
    asf = read_asf(cmu / "86.asf")
    for amc in sorted(cmu.glob("*.amc")):
        m = read_amc(amc, asf)
        write_bvh(tmp_path / "x.bvh", m, precision=9)
        back = read_bvh(tmp_path / "x.bvh")
        P0, _ = forward_kinematics(m)
        P1, _ = forward_kinematics(back)
        assert np.abs(P1 - P0).max() < 1e-6, amc.name
        assert back.n_frames == m.n_frames


def test_amc_cli_compress_and_convert(tests_data, tmp_path):
    cmu = tests_data / "cmu"
    amc = sorted(cmu.glob("86_*.amc"))[0]
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "compress", str(amc), "-o", str(tmp_path / "a.glb"),
                        "--max-position-error", "0.5", "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    assert rec["unit_cm"] == pytest.approx(2.54 / 0.45) and not rec["unit_cm_assumed"]
    assert rec["max_position_error_cm"] <= 0.5 * (1 + 1e-9)
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "convert", str(amc), str(tmp_path / "a.bvh")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    other = sorted(cmu.glob("13_*.amc"))[0]
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "info", str(other)], capture_output=True, text=True)
    assert r.returncode == 2 and "asf" in r.stderr.lower()
    r = subprocess.run([sys.executable, "-m", "mocapkit.cli", "info", str(other), "--asf", str(cmu / "86.asf"),
                        "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["joints"] == 31


def test_amc_to_bvh_round_trip_on_shared_files(shared_data, tmp_path):
    from mocapkit.io.skeletal.amc import read_amc, read_asf

    asf = read_asf(shared_data / "cmu" / "86.asf")
    for name in ("86_01", "13_29", "13_30", "14_14"):
        m = read_amc(shared_data / "cmu" / f"{name}.amc", asf)
        write_bvh(tmp_path / "x.bvh", m, precision=9)
        back = read_bvh(tmp_path / "x.bvh")
        assert np.abs(forward_kinematics(back)[0] - forward_kinematics(m)[0]).max() < 1e-6, name


def test_position_bound_on_shared_cmu(shared_data):
    from mocapkit.io.skeletal.amc import read_amc, read_asf

    m = read_amc(shared_data / "cmu" / "86_01.amc", read_asf(shared_data / "cmu" / "86.asf"))
    bound = 0.5 / m.skeleton.meta["length_unit_cm"]  # 0.5 cm in file units
    comp = compress_motion(m, "fastsw", max_position_error=bound)
    assert position_errors(m, comp.decode()).max() <= bound * (1 + 1e-9)
    assert comp.icr < 0.25


def test_convert_bvh_to_amc_and_back(tests_data, tmp_path):
    cmu = tests_data / "cmu"
    amc = sorted(cmu.glob("86_*.amc"))[0]
    exe = [sys.executable, "-m", "mocapkit.cli", "convert"]
    r = subprocess.run([*exe, str(amc), str(tmp_path / "a.bvh"), "--precision", "9"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*exe, str(tmp_path / "a.bvh"), str(tmp_path / "b.amc"), "--asf", str(cmu / "86.asf")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    from mocapkit.io.skeletal.amc import read_amc, read_asf

    asf = read_asf(cmu / "86.asf")
    P0 = forward_kinematics(read_amc(amc, asf))[0]
    P1 = forward_kinematics(read_amc(tmp_path / "b.amc", asf))[0]
    assert np.abs(P1 - P0).max() < 1e-4  # AMC is written with 6 decimals


_PARTIAL = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Knee
  {
    OFFSET 0 -40 0
    CHANNELS %s
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.01
"""


@pytest.mark.parametrize("chans,rows", [
    ("1 Zrotation", ["1 2 3 0 0 0 10", "1 2 3 5 0 0 -20", "1 2 3 0 7 0 35.5"]),
    ("2 Xrotation Zrotation", ["0 0 0 0 0 0 10 -5", "0 0 0 0 0 0 -20 30", "0 0 0 0 0 0 0 90"]),
])
def test_joint_with_fewer_rotation_channels_writes_back_exactly(tmp_path, chans, rows):
    src = tmp_path / "partial.bvh"
    src.write_text(_PARTIAL % chans + "\n".join(rows) + "\n")
    m = read_bvh(src)
    out = tmp_path / "out.bvh"
    write_bvh(out, m, precision=6, use_channel_values=False)  # from the rotations, not the file's values
    back = read_bvh(out)
    assert back.skeleton.channels == m.skeleton.channels
    expect = np.array([[float(x) for x in r.split()] for r in rows])
    got = np.array([[float(x) for x in r.split()] for r in out.read_text().split("Frame Time:")[1].split("\n")[1:4]])
    np.testing.assert_allclose(got, expect, atol=1e-6)
    np.testing.assert_allclose(forward_kinematics(back)[0], forward_kinematics(m)[0], atol=1e-9)


def test_joint_with_fewer_rotation_channels_refuses_a_rotation_about_a_missing_axis(tmp_path):
    from mocapkit.errors import InvalidSignalError

    src = tmp_path / "partial.bvh"
    src.write_text(_PARTIAL % "1 Zrotation" + "0 0 0 0 0 0 10\n0 0 0 0 0 0 20\n0 0 0 0 0 0 30\n")
    m = read_bvh(src)
    m.rotations[1, 1] = Rotation.from_euler("ZX", [20, 3], degrees=True).as_quat(scalar_first=True)
    with pytest.raises(InvalidSignalError,
                       match=r"'Knee' has the rotation channels Z only, but at frame 1 it turns 3 degrees about X"):
        write_bvh(tmp_path / "out.bvh", m, use_channel_values=False)
    assert not (tmp_path / "out.bvh").exists()
