"""``mocapkit verify``: its SLERP, angle and forward kinematics against scipy, and on every shared file
its largest error equal to an independent scipy computation of the same decode (and within the bound);
a tampered output exits 1 naming where, a mismatched pair exits 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from mocapkit import cli
from mocapkit.io import load_signals, read_imu_csv
from mocapkit.io.loaders import load_motion
from mocapkit.jobs.verify import verify_job
from mocapkit.verify.kinematics import world_pose
from mocapkit.verify.quaternions import angle_deg, interpolate, slerp
from reference_kinematics import naive_positions

DATA = Path(__file__).resolve().parent / "data"


def _cli(args: list[str]) -> int:
    try:
        cli.main(args)
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def _rot(q: np.ndarray) -> Rotation:
    """scipy rotations of scalar-first quaternions."""
    return Rotation.from_quat(np.asarray(q)[..., [1, 2, 3, 0]])


# ---- SLERP and the angle against scipy ---------------------------------------------------------------

quat = st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 1e-3).map(np.array)


@settings(max_examples=300, deadline=None)
@given(a=quat, b=quat, f=st.floats(0, 1), sa=st.floats(0.1, 10), sb=st.sampled_from([1.0, -1.0, 3.0, -0.2]))
def test_slerp_and_angle_equal_scipy(a, b, f, sa, sb):
    """Any lengths and signs: the shortest-arc SLERP is scipy's Slerp, the angle scipy's magnitude."""
    ra, rb = _rot(a), _rot(b)
    if (ra.inv() * rb).magnitude() > math.pi - 1e-6:  # half a turn: no shortest arc to agree on
        return
    mine = slerp((sa * a)[None], (sb * b)[None], np.array([f]))
    ref = Slerp([0.0, 1.0], Rotation.concatenate([ra, rb]))([f])
    assert (_rot(mine).inv() * ref).magnitude()[0] < 1e-9
    assert abs(np.linalg.norm(mine) - 1) < 1e-12
    assert angle_deg((sa * a)[None], (sb * b)[None])[0] == pytest.approx(
        np.degrees((ra.inv() * rb).magnitude()), abs=1e-9)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(2, 30))
def test_interpolation_between_points_equals_scipy(seed, m):
    """Points at irregular times, evaluated anywhere in their span."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.001, 2.0, m))
    q = rng.normal(size=(m, 4))
    at = np.sort(rng.uniform(t[0], t[-1], 40))
    at[0], at[-1] = t[0], t[-1]
    ref = Slerp(t, _rot(q))(at)
    assert np.degrees((_rot(interpolate(at, t, q)).inv() * ref).magnitude()).max() < 1e-7


def test_small_angles_are_not_lost():
    """``acos`` of a dot product gives 0 below ~1e-6°; the chord form keeps the angle."""
    a = np.array([[1.0, 0, 0, 0]])
    b = _rot(Rotation.from_rotvec([1e-9, 0, 0]).as_quat()[[3, 0, 1, 2]]).as_quat()[[3, 0, 1, 2]][None]
    assert angle_deg(a, b)[0] == pytest.approx(np.degrees(1e-9), rel=1e-6)


# ---- forward kinematics against scipy ----------------------------------------------------------------

def scipy_pose(motion):
    """World positions, rotations (scipy stacks over frames) and End Sites by scipy, joint by joint."""
    sk = motion.skeleton
    world, pos = [], np.zeros((motion.n_frames, sk.n_joints, 3))
    for j, p in enumerate(sk.parents.tolist()):
        r = _rot(motion.rotations[:, j])
        if p < 0:
            world.append(r)
            pos[:, j] = motion.translations[:, j]
        else:
            world.append(world[p] * r)
            pos[:, j] = pos[:, p] + world[p].apply(motion.translations[:, j])
    ends = np.stack([pos[:, j] + world[j].apply(np.asarray(off)) for j, off in sk.end_sites], axis=1) \
        if sk.end_sites else np.zeros((motion.n_frames, 0, 3))
    return pos, world, ends


SKELETONS = [("bvh/walk-meredith-60.bvh", None), ("bvh/perception-neuron-freya-12.bvh", None),
             ("cmu/86_01_first60.amc", "cmu/86.asf")]


@pytest.mark.parametrize("name,asf", SKELETONS)
def test_forward_kinematics_equals_scipy(name, asf):
    m = load_motion(DATA / name, asf=None if asf is None else DATA / asf)
    assert m.skeleton.end_sites  # End Sites are part of what is checked
    pose = world_pose(m.skeleton, m.rotations, m.translations)
    pos, world, ends = scipy_pose(m)
    scale = max(1.0, float(np.abs(pos).max()))
    assert np.abs(pose.positions - naive_positions(m)).max() < 1e-9 * scale
    assert np.abs(pose.positions - pos).max() < 1e-9 * scale
    assert np.abs(pose.end_sites - ends).max() < 1e-9 * scale
    for j in range(m.skeleton.n_joints):
        assert np.abs(pose.rotations[:, j] - world[j].as_matrix()).max() < 1e-12 * m.skeleton.n_joints


# ---- independent references of a whole comparison --------------------------------------------------

def scipy_skeletal(original, decoded, unit_cm: float, shell_cm: float) -> dict:
    """Max joint, End Site and shell errors (cm) by scipy forward kinematics."""
    p0, w0, e0 = scipy_pose(original)
    p1, w1, e1 = scipy_pose(decoded)
    joint = np.linalg.norm(p1 - p0, axis=-1) * unit_cm
    end = np.linalg.norm(e1 - e0, axis=-1) * unit_cm
    d = shell_cm / unit_cm
    shell = np.zeros_like(joint)
    for j in range(len(w0)):
        for axis in np.eye(3):
            v = (p1[:, j] + w1[j].apply(d * axis)) - (p0[:, j] + w0[j].apply(d * axis))
            shell[:, j] = np.maximum(shell[:, j], np.linalg.norm(v, axis=-1) * unit_cm)
    return {"joint": joint.max(), "end": end.max() if end.size else 0.0, "shell": shell.max(),
            "joint_mean": joint.mean()}


def scipy_imu(original: Path, compressed: Path) -> tuple[float, float]:
    """Max and mean angle (deg) of the original's samples to scipy's SLERP of the compressed points: by time
    for a points CSV, by sample index within each run of points with no lost packet for a .mkp."""
    signals = load_signals(original)
    errs = []
    if compressed.suffix == ".mkp":
        from mocapkit.jobs.readers import read_mkp

        streams = read_mkp(compressed).streams
        for name, sig in signals.items():
            s = streams[name]
            runs = np.split(np.arange(len(s.ticks)), np.flatnonzero(s.gap_before[1:]) + 1)
            for r in runs:
                k = s.ticks[r].astype(float)
                u = np.arange(k[0], k[-1] + 1)
                dec = Slerp(k, _rot(s.values[r]))(u) if len(r) > 1 else _rot(np.repeat(s.values[r], len(u), 0))
                errs.append(np.degrees((_rot(sig.values[u.astype(int)]).inv() * dec).magnitude()))
    else:
        files = {f.stem: f for f in compressed.glob("*.csv")} if compressed.is_dir() else \
            {next(iter(signals)): compressed}
        for name, sig in signals.items():
            pts = read_imu_csv(files[name])
            dec = Slerp(pts.times, _rot(pts.values))(sig.times)
            errs.append(np.degrees((_rot(sig.values).inv() * dec).magnitude()))
    e = np.concatenate(errs)
    return float(e.max()), float(e.mean())


# ---- every shared file -------------------------------------------------------------------------------

IMU_FILES = ["imu/xio-lower-body", "imu/apdm/imuData01.csv", "imu/optitrack/sample_optitrack_take.csv",
             "imu/xsens-dot/LFemur_20210820_202113_831.csv", "imu/xsens-mtmanager/MT46_01-000_00B42D4D.txt",
             "imu/xsens-mtmanager/MT_012005D6_009-001_00B421E6.txt",
             "opensim/myComplexTasksTrial_orientations.sto"]


@pytest.fixture(scope="module")
def imu_outputs(shared_data, tmp_path_factory):
    """Each shared IMU recording compressed with --max-angle 2 to points CSV and to .mkp."""
    out = tmp_path_factory.mktemp("imu")
    made = []
    for k, rel in enumerate(IMU_FILES):
        src = shared_data / rel
        if not src.exists():
            continue
        several = len(load_signals(src)) > 1
        pts = out / (f"p{k}" if several else f"p{k}.csv")
        assert _cli(["compress", str(src), "--max-angle", "2", "-o", str(pts)]) == 0
        assert _cli(["compress", str(src), "--max-angle", "2", "-o", str(out / f"p{k}.mkp")]) == 0
        made += [(src, pts), (src, out / f"p{k}.mkp")]
    return made


def test_imu_shared_files_agree_with_scipy(imu_outputs):
    assert len(imu_outputs) == 2 * len(IMU_FILES)
    for src, comp in imu_outputs:
        rec = verify_job(src, compressed=comp, max_angle=2.0)
        ref_max, ref_mean = scipy_imu(src, comp)
        assert rec["max_error"] == pytest.approx(ref_max, rel=1e-9, abs=1e-9), (src, comp)
        assert rec["mean_error"] == pytest.approx(ref_mean, rel=1e-9, abs=1e-9), (src, comp)
        assert rec["within_bound"] is True and rec["max_error"] <= 2.0
        assert rec["samples_not_decoded"] == 0


#: (file, asf, frames kept): the first frames of the longer takes (compressing the whole of 86_01's 4579
#: frames twice takes a minute; the comparison itself is the same code for any length)
SKELETAL_FILES = [("bvh/walk-meredith.bvh", None, 240), ("bvh/perception-neuron-freya.bvh", None, 120),
                  ("cmu/86_01.amc", "cmu/86.asf", 240), ("bvh/mocapbank.bvh", None, 120),
                  ("bvh/cmu-131_01-3dsmax.bvh", None, 120), ("bvh/mixamo-rig.bvh", None, 120),
                  ("cmu/13_29.amc", "cmu/86.asf", 120), ("cmu/13_30.amc", "cmu/86.asf", 120),
                  ("cmu/14_14.amc", "cmu/86.asf", 120)]


def _first_frames(src: Path, n: int, dest: Path) -> Path:
    """The file cut after its first ``n`` frames (BVH: the Frames: line changed; AMC: up to frame n)."""
    lines = src.read_text(encoding="utf-8", errors="replace").splitlines()
    if src.suffix == ".bvh":
        at = next(i for i, ln in enumerate(lines) if ln.strip().startswith("Frames:"))
        n = min(n, len(lines) - at - 2)
        lines = lines[:at] + [f"Frames: {n}"] + lines[at + 1:at + 2 + n]
    else:
        end = next((i for i, ln in enumerate(lines) if ln.strip() == str(n + 1)), len(lines))
        lines = lines[:end]
    dest.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return dest


@pytest.fixture(scope="module")
def skeletal_outputs(shared_data, tmp_path_factory):
    """The first frames of each shared take compressed with --max-position-error 0.5 to .mkc and .glb."""
    out = tmp_path_factory.mktemp("skel")
    made = []
    for rel, asf, n in SKELETAL_FILES:
        src = shared_data / rel
        if not src.exists():
            continue
        cut = _first_frames(src, n, out / Path(rel).name)
        extra = [] if asf is None else ["--asf", str(shared_data / asf)]
        for suffix in (".mkc", ".glb"):
            comp = out / (cut.stem + suffix)
            assert _cli(["compress", str(cut), "--max-position-error", "0.5", "-o", str(comp), *extra]) == 0
            made.append((cut, comp, None if asf is None else shared_data / asf))
    return made


def test_skeletal_shared_files_agree_with_scipy(skeletal_outputs):
    from mocapkit.io.formats.gltf import read_gltf
    from mocapkit.jobs.readers import read_mkc

    assert len(skeletal_outputs) == 2 * len(SKELETAL_FILES)
    for src, comp, asf in skeletal_outputs:
        rec = verify_job(src, compressed=comp, max_position_error=0.5, asf=asf)
        original = load_motion(src, asf=asf)
        decoded = read_mkc(comp) if comp.suffix == ".mkc" else read_gltf(comp)
        ref = scipy_skeletal(original, decoded, rec["unit_cm"], 3.0)
        for key, mine in (("joint", rec["joint_positions"]["max_cm"]), ("end", rec["end_site_positions"]["max_cm"]),
                          ("shell", rec["shell"]["max_cm"]), ("joint_mean", rec["joint_positions"]["mean_cm"])):
            assert mine == pytest.approx(ref[key], rel=1e-9, abs=1e-12), (src, comp, key)
        assert rec["max_error"] == rec["positions"]["max_cm"]  # the default metric: every joint and End Site
        assert rec["within_bound"] is True and rec["max_error"] <= 0.5 * (1 + 1e-9), (src, comp)
        assert rec["positions"]["max_cm"] == pytest.approx(max(ref["joint"], ref["end"]), rel=1e-9)


# ---- tampering and mismatched pairs ------------------------------------------------------------------

def test_a_moved_point_exits_1_naming_where(tmp_path, capsys):
    src = DATA / "imu" / "xsens-dot"
    src = next(p for p in sorted(src.rglob("*.csv")))
    pts = tmp_path / "pts.csv"
    assert _cli(["compress", str(src), "--max-angle", "2", "-o", str(pts)]) == 0
    assert _cli(["verify", str(src), str(pts), "--max-angle", "2"]) == 0
    rows = pts.read_text().splitlines()
    k = len(rows) // 2  # a point inside: rotate it by 10 degrees
    t, *q = rows[k].split(",")
    moved = (_rot(np.array(q, dtype=float)) * Rotation.from_rotvec([0.0, math.radians(10), 0.0])).as_quat()
    rows[k] = ",".join([t, *(repr(float(v)) for v in moved[[3, 0, 1, 2]])])
    pts.write_text("\n".join(rows) + "\n")
    capsys.readouterr()
    assert _cli(["verify", str(src), str(pts), "--max-angle", "2", "--json"]) == 1
    rec = json.loads(capsys.readouterr().out)
    sample = int(np.flatnonzero(load_signals(src)[rec["where"]["sensor"]].times == float(t))[0])
    assert rec["where"]["sample"] == sample and rec["where"]["time_s"] == float(t)
    assert rec["max_error"] == pytest.approx(10.0, abs=2.0) and rec["within_bound"] is False
    assert _cli(["verify", str(src), str(pts), "--max-angle", "2"]) == 1
    assert f"sample {sample}" in capsys.readouterr().out


def test_a_changed_frame_of_a_decoded_bvh_exits_1_naming_the_joint(tmp_path, capsys):
    src, clip = DATA / "bvh" / "walk-meredith-60.bvh", DATA / "clip" / "walk-meredith-60.mkc"
    dec = tmp_path / "dec.bvh"
    assert _cli(["decompress", str(clip), "-o", str(dec)]) == 0
    assert _cli(["verify", str(src), str(dec), "--max-position-error", "1", "--unit-cm", "2.54"]) == 0
    lines = dec.read_text().splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 1 + 17  # frame 17
    vals = lines[at].split()
    vals[0] = repr(float(vals[0]) + 2.0)  # the root's Xposition moved 2 units (5.08 cm)
    lines[at] = " ".join(vals)
    dec.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert _cli(["verify", str(src), str(dec), "--max-position-error", "1", "--unit-cm", "2.54", "--json"]) == 1
    rec = json.loads(capsys.readouterr().out)
    assert rec["where"]["frame"] == 17 and rec["within_bound"] is False
    assert rec["max_error"] == pytest.approx(5.08, abs=0.2)


def test_mismatched_pairs_exit_2(tmp_path, capsys):
    walk, freya = DATA / "bvh" / "walk-meredith-60.bvh", DATA / "bvh" / "perception-neuron-freya-12.bvh"
    clip = DATA / "clip" / "walk-meredith-60.mkc"
    assert _cli(["verify", str(freya), str(clip)]) == 2  # another skeleton
    assert "not a decode" in capsys.readouterr().err
    short = _first_frames(walk, 30, tmp_path / "short.bvh")
    assert _cli(["verify", str(short), str(clip)]) == 2  # another frame count
    assert "frames" in capsys.readouterr().err
    imu = sorted((DATA / "imu" / "xsens-dot").rglob("*.csv"))[0]
    assert _cli(["verify", str(walk), str(tmp_path / "missing.glb")]) == 2
    assert _cli(["verify", str(imu), str(clip)]) == 2  # IMU against a clip
    pts = tmp_path / "pts.csv"
    assert _cli(["compress", str(imu), "--max-angle", "2", "-o", str(pts)]) == 0
    rows = pts.read_text().splitlines()
    pts.write_text("\n".join(rows[:-1]) + "\n")  # the last point gone: the points end before the samples
    capsys.readouterr()
    assert _cli(["verify", str(imu), str(pts)]) == 2
    assert "not a compression of this file" in capsys.readouterr().err
    assert _cli(["verify", str(walk), str(clip), "--max-angle", "2"]) == 2  # an IMU bound for a skeleton


# ---- batch verify -----------------------------------------------------------------------------------

def test_batch_verify_over_a_compress_batch(tmp_path, capsys):
    import shutil

    from mocapkit.batch.journal import read_journal

    inp = tmp_path / "in"
    (inp / "walk").mkdir(parents=True)
    shutil.copy(DATA / "bvh" / "walk-meredith-60.bvh", inp / "walk")
    shutil.copy(DATA / "cmu" / "86_01_first60.amc", inp)
    shutil.copy(DATA / "cmu" / "86.asf", inp)
    comp, out = tmp_path / "comp", tmp_path / "check"
    assert _cli(["batch", "compress", str(inp), "--out", str(comp), "--max-position-error", "1", "--jobs", "1"]) == 0
    assert (comp / "walk" / "walk-meredith-60.glb").is_file() and (comp / "86_01_first60.glb").is_file()
    capsys.readouterr()
    assert _cli(["batch", "verify", str(inp), "--compressed", str(comp), "--out", str(out),
                 "--max-position-error", "1", "--jobs", "1"]) == 0
    assert "0 of 2 verified pairs exceed the bound" in capsys.readouterr().out
    rows = read_journal(out / "journal.jsonl")
    assert [r["status"] for r in rows] == ["ok", "ok"]
    for r in rows:  # each row is the single-file command's record
        rec = json.loads(r["record_json"])
        single = verify_job(Path(r["input"]), compressed=Path(rec["compressed"]), max_position_error=1.0)
        assert rec["max_error"] == single["max_error"] and rec["within_bound"] is True
    # a tighter bound: both pairs exceed it; a missing output is an error row, the other pair still runs
    (comp / "walk" / "walk-meredith-60.glb").unlink()
    assert _cli(["batch", "verify", str(inp), "--compressed", str(comp), "--out", str(tmp_path / "c2"),
                 "--max-position-error", "0.001", "--jobs", "1"]) == 1
    text = capsys.readouterr().out
    assert "1 of 1 verified pairs exceed the bound" in text and "86_01_first60.amc" in text
    assert "no compressed output" in text
    # the compressed folder inside an input folder, or as --out, is refused before any work
    assert _cli(["batch", "verify", str(tmp_path), "--compressed", str(comp), "--out", str(tmp_path / "c3")]) == 2
    assert _cli(["batch", "verify", str(inp), "--compressed", str(comp), "--out", str(comp)]) == 2


def test_the_checks_are_a_second_implementation():
    """``mocapkit.verify`` imports no mocapkit module but its own: not the encoders' or the model's kernels."""
    import ast

    root = Path(__file__).resolve().parents[1] / "src" / "mocapkit" / "verify"
    for f in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            for n in names:
                assert not n.startswith("mocapkit") or n.startswith("mocapkit.verify"), (f.name, n)


def test_both_bounds_each_apply_to_their_kind(tmp_path, capsys):
    """As in a mixed batch: --max-angle and --max-position-error together, each bounding its kind."""
    src = next(p for p in sorted((DATA / "imu" / "xsens-dot").rglob("*.csv")))
    pts = tmp_path / "pts.csv"
    assert _cli(["compress", str(src), "--max-angle", "2", "-o", str(pts)]) == 0
    capsys.readouterr()
    assert _cli(["verify", str(src), str(pts), "--max-angle", "2", "--max-position-error", "0.001", "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["bound"] == 2 and rec["bound_unit"] == "deg"
    assert _cli(["verify", str(src), str(pts), "--max-angle", "0.01", "--max-position-error", "100", "--json"]) == 1
    walk, clip = DATA / "bvh" / "walk-meredith-60.bvh", DATA / "clip" / "walk-meredith-60.mkc"
    capsys.readouterr()
    assert _cli(["verify", str(walk), str(clip), "--max-angle", "0.001", "--max-position-error", "1",
                 "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["bound"] == 1 and rec["bound_unit"] == "cm"
