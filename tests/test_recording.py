"""jobs/recording.py: the catalog's description of a recording (BIDS-Motion channels, subject/take) and the
content hash, checked against the files' own text (parsed here independently), ezc3d and hashlib."""

from __future__ import annotations

import hashlib
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io.loaders import load
from mocapkit.jobs.recording import content_hash, describe

BIDS_TYPES = {"POS", "ORNT", "JNTANG", "VEL", "ACCEL", "ANGACCEL", "GYRO", "MAGN", "MISC", "LATENCY"}
BIDS_COMPONENTS = {"x", "y", "z", "quat_w", "quat_x", "quat_y", "quat_z", "n/a"}


def _check_shape(r: dict) -> None:
    assert set(r) == {"path", "format", "kind", "rate_hz", "frames", "duration_s", "subject", "take", "channels"}
    for c in r["channels"]:
        assert set(c) == {"name", "component", "type", "tracked_point", "units"}
        assert c["type"] in BIDS_TYPES and c["component"] in BIDS_COMPONENTS, c
    names = [c["name"] for c in r["channels"]]
    assert len(set(names)) == len(names), "channel names must be unique (they name motion.tsv columns)"


def test_bvh_channels_follow_the_file(tests_data):
    path = tests_data / "bvh" / "walk-meredith-60.bvh"
    r = describe(load(path), path)
    _check_shape(r)
    # the file's own CHANNELS lines, joint by joint, parsed here with a regex
    text = path.read_text()
    expected = []
    for joint, chans in re.findall(r"(?:ROOT|JOINT)\s+(\S+)\s*\{\s*OFFSET[^\n]*\n\s*CHANNELS\s+\d+\s+([^\n]+)", text):
        expected += [f"{joint}_{c}" for c in chans.split()]
    assert [c["name"] for c in r["channels"]] == expected
    frames = int(re.search(r"Frames:\s*(\d+)", text).group(1))
    ft = float(re.search(r"Frame Time:\s*(\S+)", text).group(1))
    assert (r["frames"] == frames and r["rate_hz"] == pytest.approx(1 / ft)
            and r["duration_s"] == pytest.approx(frames * ft))
    pos = [c for c in r["channels"] if c["name"].endswith("position")]
    rot = [c for c in r["channels"] if c["name"].endswith("rotation")]
    assert len(pos) + len(rot) == len(expected)
    assert {c["type"] for c in pos} == {"POS"} and {c["units"] for c in pos} == {"n/a"}  # BVH states no unit
    assert {c["type"] for c in rot} == {"ORNT"} and {c["units"] for c in rot} == {"deg"}
    assert all(c["component"] == c["name"].split("_")[-1][0].lower() for c in pos + rot)
    assert (r["kind"], r["format"], r["subject"], r["take"]) == ("skeletal", "bvh", None, None)


def test_amc_channels_are_the_asf_dofs_and_cmu_names_give_subject_and_take(tests_data, tmp_path):
    shutil.copy(tests_data / "cmu" / "86_01_first60.amc", tmp_path / "86_01.amc")
    shutil.copy(tests_data / "cmu" / "86.asf", tmp_path / "86.asf")
    path = tmp_path / "86_01.amc"
    r = describe(load(path), path)
    _check_shape(r)
    asf = (tests_data / "cmu" / "86.asf").read_text()
    n_dofs = sum(len(m.split()) for m in re.findall(r"^\s*dof\s+([^\n]+)$", asf, flags=re.MULTILINE))
    n_root = len(re.search(r"^\s*order\s+([^\n]+)$", asf, flags=re.MULTILINE).group(1).split())
    assert len(r["channels"]) == n_dofs + n_root == 62  # CMU's 62 channels
    assert r["channels"][0] == {"name": "root_tx", "component": "x", "type": "POS", "tracked_point": "root",
                                "units": "5.64444 cm"}  # ASF "length 0.45": 2.54 / 0.45 cm
    assert {c["units"] for c in r["channels"] if c["type"] == "ORNT"} == {"deg"}
    assert (r["subject"], r["take"]) == ("86", "01")
    assert (r["frames"], r["rate_hz"]) == (60, 120.0)
    # the subject/take rule is about CMU file names only
    other = describe(load(tests_data / "cmu" / "86_01_first60.amc", asf=tests_data / "cmu" / "86.asf"),
                     tests_data / "cmu" / "86_01_first60.amc")
    assert (other["subject"], other["take"]) == (None, None)


def test_mvnx_subject_from_the_file_and_quaternion_channels(tests_data):
    path = tests_data / "mvnx" / "86_01_xsens_60hz.mvnx"
    m = load(path)
    r = describe(m, path)
    _check_shape(r)
    label = re.search(r'<subject label="([^"]*)"', path.read_text()).group(1)
    assert r["subject"] == label and r["take"] is None
    quat = [c for c in r["channels"] if c["type"] == "ORNT"]
    assert len(quat) == 4 * m.skeleton.n_joints
    assert [c["component"] for c in quat[:4]] == ["quat_w", "quat_x", "quat_y", "quat_z"]
    assert {c["units"] for c in r["channels"] if c["type"] == "POS"} == {"m"}  # MVNX positions are metres
    assert r["format"] == "mvnx" and r["rate_hz"] == 60.0


def test_markers_channels_units_and_qtm_carries_no_subject(tests_data):
    path = tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"
    mk = load(path)
    r = describe(mk, path)
    _check_shape(r)
    header = dict(line.split("\t", 1) for line in path.read_text().splitlines()[:9])
    assert r["frames"] == int(header["NO_OF_FRAMES"]) and r["rate_hz"] == float(header["FREQUENCY"])
    assert len(r["channels"]) == 3 * int(header["NO_OF_MARKERS"])
    assert r["channels"][:3] == [{"name": f"base_1_{a}", "component": a, "type": "POS", "tracked_point": "base_1",
                                  "units": "mm"} for a in "xyz"]
    assert r["subject"] is None and r["format"] == "qtm-tsv" and r["kind"] == "markers"


def test_c3d_subjects_parameter(tmp_path):
    ezc3d = pytest.importorskip("ezc3d")
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100]
    c["parameters"]["POINT"]["LABELS"]["value"] = ["LASI", "RASI"]
    c["parameters"]["POINT"]["UNITS"]["value"] = ["m"]
    pts = np.ones((4, 2, 5))
    pts[:3] = np.arange(30).reshape(3, 2, 5)
    c["data"]["points"] = pts
    c.add_parameter("SUBJECTS", "NAMES", ["S07", "Ball"])
    c.write(str(tmp_path / "trial.c3d"))
    r = describe(load(tmp_path / "trial.c3d"), tmp_path / "trial.c3d")
    _check_shape(r)
    assert r["subject"] == "S07, Ball"
    assert r["channels"][0] == {"name": "LASI_x", "component": "x", "type": "POS", "tracked_point": "LASI",
                                "units": "m"}
    assert (r["frames"], r["rate_hz"], r["format"]) == (5, 100.0, "c3d")
    # without the group: no subject
    c2 = ezc3d.c3d()
    c2["parameters"]["POINT"]["RATE"]["value"] = [100]
    c2["parameters"]["POINT"]["LABELS"]["value"] = ["LASI", "RASI"]
    c2["data"]["points"] = pts
    c2.write(str(tmp_path / "plain.c3d"))
    assert describe(load(tmp_path / "plain.c3d"), tmp_path / "plain.c3d")["subject"] is None


def test_c3d_subjects_of_real_files(shared_data):
    ezc3d = pytest.importorskip("ezc3d")
    for name in ("Vicon.c3d", "vicon-nexus-walking2.c3d", "motion-analysis-walk1.c3d", "BTS.c3d"):
        path = shared_data / "c3d" / name
        params = ezc3d.c3d(str(path))["parameters"]
        names = params["SUBJECTS"]["NAMES"]["value"] if "SUBJECTS" in params else []
        r = describe(load(path), path)
        assert r["subject"] == (", ".join(n.strip() for n in names) if names else None), name


def test_imu_signals_and_sensor_folder(tests_data):
    folder = tests_data / "xio"
    sigs = load(folder)
    r = describe(sigs, folder)
    _check_shape(r)
    assert r["kind"] == "imu" and r["format"] == "x-io"
    assert [c["tracked_point"] for c in r["channels"]] == [s for s in sigs for _ in range(4)]
    assert {c["units"] for c in r["channels"]} == {"n/a"}
    # counts and times from the CSV files themselves
    lens, t0, t1 = [], [], []
    for sensor in sorted(sigs):
        rows = np.loadtxt(folder / sensor / "Quaternion.csv", delimiter=",", skiprows=1)
        lens.append(len(rows))
        t0.append(rows[0, 0] / 1e6)
        t1.append(rows[-1, 0] / 1e6)
    assert r["frames"] == max(lens)
    assert r["duration_s"] == pytest.approx(max(t1) - min(t0))
    longest = max(sigs.values(), key=len)
    assert r["rate_hz"] == pytest.approx((len(longest) - 1) / longest.duration)  # no stated rate: mean rate
    apdm = describe(load(tests_data / "imu" / "apdm" / "imuData01_excerpt.csv"), "x.csv")
    assert apdm["rate_hz"] == 128.0  # "Sample Rate:,128,Hz" stated by every sensor
    assert len(apdm["channels"]) == 4 * 4


def test_opensim_table_joint_angles(tests_data):
    from mocapkit.io.markers.opensim import read_table

    path = tests_data / "opensim" / "subject01_walk1_ik-first20.mot"
    r = describe(read_table(path), path)
    _check_shape(r)
    lines = path.read_text().splitlines()
    cols = lines[next(i for i, s in enumerate(lines) if s.strip() == "endheader") + 1].split("\t")[1:]
    assert [c["name"] for c in r["channels"]] == [c.strip() for c in cols]
    by = {c["name"]: c for c in r["channels"]}
    assert by["knee_angle_r"] == {"name": "knee_angle_r", "component": "n/a", "type": "JNTANG",
                                  "tracked_point": "knee_angle_r", "units": "deg"}
    assert by["pelvis_ty"] == {"name": "pelvis_ty", "component": "y", "type": "POS", "tracked_point": "pelvis",
                               "units": "m"}
    assert r["kind"] == "table" and r["frames"] == 20


def test_describe_refuses_other_objects():
    with pytest.raises(TypeError, match="describe"):
        describe({}, "x")
    with pytest.raises(TypeError):
        describe([1, 2], "x")


def test_content_hash_of_a_file_is_sha256_of_its_bytes(tests_data):
    path = tests_data / "bvh" / "walk-meredith-60.bvh"
    assert content_hash(path) == hashlib.sha256(path.read_bytes()).hexdigest()


def test_content_hash_of_a_large_file_spans_chunks(tmp_path):
    data = os.urandom((1 << 20) * 2 + 12345)
    (tmp_path / "big.bin").write_bytes(data)
    assert content_hash(tmp_path / "big.bin") == hashlib.sha256(data).hexdigest()


def _folder_digest(folder: Path) -> str:
    """Independent re-statement of the folder rule: sorted relative names, NUL, 8-byte size, bytes."""
    h = hashlib.sha256()
    files = sorted((p.relative_to(folder).as_posix(), p) for p in folder.rglob("*") if p.is_file())
    for rel, p in files:
        b = p.read_bytes()
        h.update(rel.encode() + b"\0" + len(b).to_bytes(8, "little") + b)
    return h.hexdigest()


def test_content_hash_of_a_folder(tests_data, tmp_path):
    src = tests_data / "xio"
    assert content_hash(src) == _folder_digest(src)
    copy = tmp_path / "elsewhere" / "xio"
    shutil.copytree(src, copy)
    assert content_hash(copy) == content_hash(src)  # relative names: the place does not matter
    (copy / "pelvis" / "Inertial.csv").rename(copy / "pelvis" / "Inertial2.csv")
    renamed = content_hash(copy)
    assert renamed != content_hash(src)
    data = bytearray((copy / "left-foot" / "Quaternion.csv").read_bytes())
    data[-3] ^= 1
    (copy / "left-foot" / "Quaternion.csv").write_bytes(bytes(data))
    assert content_hash(copy) not in (renamed, content_hash(src))
    # moving bytes from one file's end to the next file's start changes the hash (sizes are hashed)
    a, b = tmp_path / "ab" / "a", tmp_path / "ab" / "b"
    a.parent.mkdir()
    a.write_bytes(b"12")
    b.write_bytes(b"3")
    h1 = content_hash(a.parent)
    a.write_bytes(b"1")
    b.write_bytes(b"23")
    assert content_hash(a.parent) != h1


def test_content_hash_refuses_a_fifo(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(MocapFormatError, match="pipe.csv"):
        content_hash(fifo)


def test_jobs_records_carry_the_recording(tests_data):
    from mocapkit.jobs import run_job

    path = tests_data / "bvh" / "walk-meredith-60.bvh"
    rec = run_job("info", path, {})
    assert rec["recording"] == describe(load(path), path)
    assert rec["recording"]["frames"] == rec["frames"] and rec["recording"]["rate_hz"] == rec["rate_hz"]


def test_cmu_style_names_give_subject_and_take_in_any_format(tests_data, tmp_path):
    import shutil

    from mocapkit.jobs import run_job

    for src, name in ((tests_data / "imu" / "xio" / "ngimu_quaternion.csv", "07_02.csv"),
                      (tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv", "12_003.tsv"),
                      (tests_data / "imu" / "xio" / "ngimu_quaternion.csv", "07_02b.csv")):
        p = tmp_path / name
        shutil.copy(src, p)
        r = run_job("info", p, {})["recording"]
        want = (None, None) if name == "07_02b.csv" else tuple(p.stem.split("_"))
        assert (r["subject"], r["take"]) == want, name
