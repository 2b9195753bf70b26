"""How the command line behaves: results on stdout, diagnostics on stderr, no truncation when piped,
--version, nothing computed and thrown away, normal file modes, paths named as given, clips decoded."""

from __future__ import annotations

import importlib
import json
import os
import pkgutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.formats.gltf import read_gltf, write_gltf
from mocapkit.io.skeletal.bvh import read_bvh
from mocapkit.pla.skeletal import compress_motion
from mocapkit.skeleton import forward_kinematics

EXE = [sys.executable, "-m", "mocapkit.cli"]


def run(*args, cwd: Path | None = None, umask: int | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}  # piped, no width hint
    pre = (lambda: os.umask(umask)) if umask is not None else None
    return subprocess.run([*EXE, *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300,
                          env=env, preexec_fn=pre)


@pytest.fixture(scope="module")
def bvh(tests_data) -> Path:
    return tests_data / "bvh" / "walk-meredith-60.bvh"


def test_version_matches_the_package():
    r = run("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"mocapkit {mocapkit.__version__}"
    assert mocapkit.__version__ == importlib.metadata.version("mocapkit")


def test_info_goes_to_stdout_and_is_not_cut_when_piped(tests_data, tmp_path):
    long_name = "sensor-" + "x" * 150  # wider than the 80 columns rich assumes without a terminal
    (tmp_path / long_name).mkdir()
    src = tests_data / "xio" / "pelvis" / "Quaternion.csv"
    (tmp_path / long_name / "Quaternion.csv").write_bytes(src.read_bytes())
    r = run("info", tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    assert long_name in r.stdout  # the whole name on one line
    assert "300" in r.stdout  # samples, in a table row rather than a Python dict
    assert "{" not in r.stdout


def test_skeletal_compress_without_output_is_refused_before_any_work(bvh, tmp_path):
    t0 = time.perf_counter()
    r = run("compress", bvh, "--max-position-error", "0.5")
    assert r.returncode == 2 and "-o" in r.stderr and str(bvh) in r.stderr
    assert time.perf_counter() - t0 < 60  # a refusal, not a compression (generous: the machine is shared)
    r = run("compress", bvh, "--max-position-error", "0.5", "--stats-only")
    assert r.returncode == 0, r.stderr
    assert "keyframes" in r.stdout  # the numbers are the result: on stdout
    r = run("compress", bvh, "--threshold", "0.01", "--stats-only", "-o", tmp_path / "x.glb")
    assert r.returncode == 2 and not (tmp_path / "x.glb").exists()


def test_imu_folder_without_output_is_refused(tests_data):
    r = run("compress", tests_data / "xio", "--threshold", "1e-3")
    assert r.returncode == 2 and "-o FOLDER" in r.stderr
    r = run("compress", tests_data / "xio", "--threshold", "1e-3", "--stats-only")
    assert r.returncode == 0 and "pelvis" in r.stdout


def test_points_on_stdout_and_table_on_stderr(tests_data):
    r = run("compress", tests_data / "xio" / "pelvis" / "Quaternion.csv", "--threshold", "1e-3")
    assert r.returncode == 0
    assert r.stdout.startswith("time,w,x,y,z\n")
    assert "ICR" in r.stderr and "ICR" not in r.stdout


def test_written_files_have_the_normal_mode(bvh, tests_data, tmp_path):
    outs = [tmp_path / "a.glb", tmp_path / "a.gltf", tmp_path / "a.bvh"]
    for o in outs:
        assert run("compress", bvh, "--threshold", "0.01", "-o", o, umask=0o022).returncode == 0
    pts = tmp_path / "p.csv"
    assert run("compress", tests_data / "xio" / "pelvis" / "Quaternion.csv", "-t", "1e-3", "-o", pts,
               umask=0o022).returncode == 0
    for o in outs + [pts]:
        assert oct(o.stat().st_mode & 0o777) == oct(0o644), o
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert leftovers == []


def test_errors_name_the_path_the_user_gave(bvh, tmp_path):
    target = tmp_path / "no-such-folder" / "clip.glb"
    r = run("compress", bvh, "--threshold", "0.01", "-o", target)
    assert r.returncode == 2
    assert str(target) in r.stderr and ".tmp" not in r.stderr
    assert r.stderr.count("\n") == 1  # one line, no traceback


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_decompress_clip_to_bvh_equals_the_decoded_motion(bvh, tmp_path, suffix):
    clip = tmp_path / f"clip{suffix}"
    r = run("compress", bvh, "--max-position-error", "0.5", "--unit-cm", "2.54", "-o", clip, "--gltf-rotations",
            "float", "--json")
    assert r.returncode == 0, r.stderr
    inner = json.loads(r.stdout)["bound"]  # compressed within a bound that leaves room for float32 storage
    assert inner < 0.5 / 2.54
    out = tmp_path / "back.bvh"
    r = run("decompress", clip, "-o", out)
    assert r.returncode == 0, r.stderr
    back = read_bvh(out)
    orig = read_bvh(bvh)
    assert back.n_frames == orig.n_frames and back.skeleton.names == orig.skeleton.names
    assert back.skeleton.channels == orig.skeleton.channels
    # the same compression in memory, decoded: equal up to float32 storage and 6 BVH decimals
    comp = compress_motion(orig, "fastsw", max_position_error=inner)
    P0, _ = forward_kinematics(comp.decode())
    P1, _ = forward_kinematics(back)
    assert np.abs(P1 - P0).max() < 1e-3
    # and within the guaranteed bound of the original (0.5 cm = 0.197 in)
    Pr, _ = forward_kinematics(orig)
    assert np.linalg.norm(P1 - Pr, axis=-1).max() <= 0.5 / 2.54 + 1e-3


def test_read_gltf_of_other_files_needs_a_rate(bvh, tmp_path):
    comp = compress_motion(read_bvh(bvh), "fastsw", threshold=1e-4)
    p = write_gltf(tmp_path / "c.gltf", comp)
    doc = json.loads(p.read_text())
    del doc["animations"][0]["extras"]  # as if another tool wrote it
    p.write_text(json.dumps(doc))
    with pytest.raises(mocapkit.InvalidParameterError, match="rate"):
        read_gltf(p)
    m = read_gltf(p, rate=120)
    assert m.skeleton.meta["length_unit_cm"] == 100.0
    assert np.allclose(np.diff(m.times), 1 / 120)


def test_malformed_clip_is_a_format_error(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(MocapFormatError, match="bad.glb"):
        read_gltf(bad)
    r = run("decompress", bad, "-o", tmp_path / "x.bvh")
    assert r.returncode == 2 and r.stderr.startswith("error: ") and r.stderr.count("\n") == 1


def test_skeletal_progress_reports_every_step(bvh):
    calls = []
    compress_motion(read_bvh(bvh), "fastsw", max_position_error=0.2, progress=lambda d, n: calls.append((d, n)))
    assert [d for d, _ in calls] == list(range(1, len(calls) + 1)) and calls[-1][0] == calls[-1][1]


# ------------------------------------------------------------------------------------------------
# the Python API
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("package", ["mocapkit", "mocapkit.pla", "mocapkit.filters", "mocapkit.segment", "mocapkit.io",
                                     "mocapkit.verify"])
def test_public_names_exist_and_no_function_hides_a_submodule(package):
    pkg = importlib.import_module(package)
    assert pkg.__all__, f"{package} exports nothing"
    for name in pkg.__all__:
        assert hasattr(pkg, name), f"{package}.{name} is in __all__ but missing"
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_"):  # __main__ runs the command line
            continue
        mod = importlib.import_module(f"{package}.{info.name}")
        if hasattr(pkg, info.name):
            assert getattr(pkg, info.name) is mod, f"{package}.{info.name} is not the submodule"


def test_load_returns_the_model_object_of_each_kind(tests_data, bvh):
    assert isinstance(mocapkit.load(bvh), mocapkit.Motion)
    amc = mocapkit.load(tests_data / "cmu" / "86_01_first60.amc", asf=tests_data / "cmu" / "86.asf")
    assert isinstance(amc, mocapkit.Motion) and amc.n_frames == 60
    mk = mocapkit.load(tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv")
    assert isinstance(mk, mocapkit.Markers) and mk.positions.shape[0] == 120
    sig = mocapkit.load(tests_data / "xio")
    assert set(sig) == {"pelvis", "left-foot"} and all(isinstance(s, mocapkit.Signal) for s in sig.values())
    with pytest.raises(TypeError):
        mocapkit.load(bvh, asf_typo=1)


def test_read_gltf_fuzz_raises_only_format_errors(bvh, tmp_path):
    """Random edits of a valid clip's JSON (wrong types, lengths, indices, huge numbers) either decode
    or raise MocapFormatError / InvalidParameterError; nothing else escapes (no traceback in the CLI)."""
    import random

    comp = compress_motion(read_bvh(bvh), "fastsw", threshold=1e-3)
    base = json.loads(write_gltf(tmp_path / "c.gltf", comp).read_text())
    rng = random.Random(7)
    junk = [None, -1, 0, 1, 2.5, 1e300, -1e9, "x", [], [1], [1, 2], [0, 0, 0, 0, 0], {}, {"a": 1}, True]

    def paths(node, prefix=()):
        yield prefix
        if isinstance(node, dict):
            for k, v in node.items():
                if k != "uri":  # keep the buffer itself; its content is tested by the accessor checks
                    yield from paths(v, prefix + (k,))
        elif isinstance(node, list):
            for i, v in enumerate(node[:6]):
                yield from paths(v, prefix + (i,))

    all_paths = [p for p in paths(base) if p]
    outcomes = {"decoded": 0, "refused": 0}
    for trial in range(300):
        doc = json.loads(json.dumps(base))
        for _ in range(rng.randint(1, 3)):
            path = rng.choice(all_paths)
            parent = doc
            try:
                for k in path[:-1]:
                    parent = parent[k]
                parent[path[-1]] = rng.choice(junk)
            except (KeyError, IndexError, TypeError):
                continue
        f = tmp_path / f"m{trial}.gltf"
        f.write_text(json.dumps(doc))
        try:
            m = read_gltf(f)
            assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.times)), f"non-finite decode {trial}"
            outcomes["decoded"] += 1
        except (MocapFormatError, mocapkit.InvalidParameterError):
            outcomes["refused"] += 1
    assert outcomes["refused"] > 50 and outcomes["decoded"] > 0, outcomes


# ------------------------------------------------------------------------------------------------
# findings of a newcomer's trial on the shared files
# ------------------------------------------------------------------------------------------------

def _markers_with_a_lost_one(tmp_path) -> Path:
    """A C3D with 3 markers (one never seen) and 2 analog channels."""
    from mocapkit.io.loaders import write_markers

    rng = np.random.default_rng(3)
    n = 200
    t = np.arange(n) / 100.0
    pos = np.stack([np.column_stack([t * 100, np.zeros(n), 500 - 490 * t ** 2]) + rng.normal(0, 0.2, (n, 3)),
                    np.full((n, 3), np.nan),
                    np.column_stack([np.full(n, 10.0), np.full(n, 20.0), np.full(n, 30.0)])], axis=1)
    analog = {"labels": ("F1", "F2"), "rate": 1000.0, "values": rng.normal(size=(n * 10, 2))}
    path = tmp_path / "lost.c3d"
    write_markers(mocapkit.Markers(t, pos, ("ball", "lost", "base"), 100.0, units="mm", analog=analog), path)
    return path


def test_filter_keeps_every_marker_and_analog_and_reports_a_lost_marker(tmp_path):
    src = _markers_with_a_lost_one(tmp_path)
    out = tmp_path / "f.c3d"
    r = run("filter", src, "--penalty", "5", "--markers", "ball,lost", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "lost: not filtered" in r.stderr and "1 copied unfiltered" in r.stderr
    a, b = mocapkit.load(src), mocapkit.load(out)
    assert b.labels == a.labels
    assert np.allclose(b.positions[:, 2], a.positions[:, 2], atol=1e-4)  # 'base' copied as it was
    assert np.isnan(b.positions[:, 1]).all()
    assert not np.allclose(b.positions[:, 0], a.positions[:, 0], atol=1e-3)  # 'ball' was filtered...
    assert np.abs(b.positions[:, 0] - a.positions[:, 0]).max() < 2.0  # ...and stays near the data
    assert b.analog is not None and b.analog["labels"] == ("F1", "F2")
    assert np.allclose(b.analog["values"], a.analog["values"], atol=1e-5)


def test_filter_refuses_before_work(tmp_path, tests_data):
    tsv = tests_data / "markers" / "juggling-qualisys-300hz-first120.tsv"
    r = run("filter", tsv, "--penalty", "100", "-o", tmp_path / "x.bvh")
    assert r.returncode == 2 and ".csv, or .c3d/.trc" in r.stderr
    r = run("filter", tsv, "--penalty", "100", "--columns", "base_1_x")
    assert r.returncode == 2 and "--markers" in r.stderr
    r = run("filter", tests_data / "bvh" / "walk-meredith-60.bvh", "--auto")
    assert r.returncode == 2 and "filter reads marker files" in r.stderr


def test_compress_output_must_match_what_is_written(tests_data, tmp_path):
    pelvis = tests_data / "xio" / "pelvis" / "Quaternion.csv"
    r = run("compress", pelvis, "-t", "1e-3", "-o", tmp_path / "p.glb")
    assert r.returncode == 2 and not (tmp_path / "p.glb").exists()
    r = run("compress", tests_data / "xio", "-t", "1e-3", "-o", tmp_path / "all.csv")
    assert r.returncode == 2 and not (tmp_path / "all.csv").exists()
    r = run("compress", tests_data / "xio", "-t", "1e-3", "-o", tmp_path / "missing" / "deeper" / "out")
    assert r.returncode == 2 and not (tmp_path / "missing").exists()


def test_stream_max_angle_defaults_to_the_guaranteed_method(tests_data):
    src = (tests_data / "xio" / "pelvis" / "Quaternion.csv").read_text()
    r = subprocess.run([*EXE, "stream", "--max-angle", "1"], input=src, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    r2 = subprocess.run([*EXE, "stream", "--max-angle", "1", "-m", "anglesw"], input=src, capture_output=True,
                        text=True, timeout=300)
    assert r.stdout == r2.stdout and r.stdout.count("\n") > 2


def test_decompress_refuses_a_recording(tests_data, tmp_path):
    r = run("decompress", tests_data / "bvh" / "walk-meredith-60.bvh", "-o", tmp_path / "x.bvh")
    assert r.returncode == 2 and "compressed clip" in r.stderr


def test_joint_roles_ignore_a_rig_namespace():
    from mocapkit.segment.features import ROLES, resolve_joint_map

    names = ["mixamorig:Hips", "mixamorig:Spine", "mixamorig:Neck", "mixamorig:Head",
             *[f"mixamorig:{s}{p}" for s in ("Left", "Right")
               for p in ("UpLeg", "Leg", "Foot", "Arm", "ForeArm", "Hand")]]
    jm = resolve_joint_map(names)
    assert set(jm) == set(ROLES) and all(v.startswith("mixamorig:") for v in jm.values())
    assert jm["root"] == "mixamorig:Hips"


def test_output_equal_to_the_input_is_refused(tests_data, tmp_path):
    src = tmp_path / "q.csv"
    src.write_bytes((tests_data / "xio" / "pelvis" / "Quaternion.csv").read_bytes())
    before = src.read_bytes()
    for args in (("compress", src, "-t", "1e-3", "-o", src), ("decompress", src, "--rate", "50", "-o", src)):
        r = run(*args)
        assert r.returncode == 2 and "is the input file" in r.stderr
        assert src.read_bytes() == before
