"""End Sites under the position bound: the ``joint+end`` metric (the default of ``compress``) keeps every
joint and every End Site of the decoded bytes within the bound, in ``.mkc`` clips and glTF files; the
End Site positions are computed by an independent forward kinematics (scipy rotations)."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit import cli
from mocapkit.clip import Clip, encode_clip
from mocapkit.clip.budget import track_tolerances
from mocapkit.io.loaders import load_motion, unit_cm
from mocapkit.jobs.readers import open_clip
from mocapkit.skeleton import Motion, Skeleton, forward_kinematics
from reference_kinematics import naive_end_sites, naive_positions

TESTS_FILES = [("bvh/walk-meredith-60.bvh", None, 2.54), ("bvh/perception-neuron-freya-12.bvh", None, None),
               ("cmu/86_01_first60.amc", "cmu/86.asf", None), ("cmu/13_29_first20.amc", "cmu/86.asf", None)]
SHARED = [("cmu/86_01.amc", "cmu/86.asf", None), ("cmu/13_29.amc", "cmu/86.asf", None),
          ("cmu/13_30.amc", "cmu/86.asf", None), ("cmu/14_14.amc", "cmu/86.asf", None),
          ("bvh/walk-meredith.bvh", None, 2.54), ("bvh/mixamo-rig.bvh", None, None),
          ("bvh/cmu-131_01-3dsmax.bvh", None, None), ("bvh/perception-neuron-freya.bvh", None, None),
          ("bvh/mocapbank.bvh", None, None)]


def end_error(original: Motion, decoded: Motion) -> float:
    assert [j for j, _ in decoded.skeleton.end_sites] == [j for j, _ in original.skeleton.end_sites]
    return float(np.linalg.norm(naive_end_sites(decoded) - naive_end_sites(original), axis=-1).max())


def joint_error(original: Motion, decoded: Motion) -> float:
    return float(np.linalg.norm(naive_positions(decoded) - naive_positions(original), axis=-1).max())


def _cli_json(*args) -> dict:
    out, errs = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(errs), pytest.raises(SystemExit) as e:
        cli.main([str(a) for a in args])
    assert e.value.code == 0, errs.getvalue()
    return json.loads(out.getvalue())


def _load(root, name, asf, u):
    m = load_motion(root / name, asf=None if asf is None else root / asf)
    return m, u or unit_cm(m, None)[0]


@pytest.mark.parametrize("name,asf,u", TESTS_FILES)
def test_joint_end_metric_bounds_end_sites_on_the_written_bytes(tests_data, name, asf, u):
    m, u = _load(tests_data, name, asf, u)
    assert m.skeleton.end_sites
    for bound_cm in (0.1, 1.0):
        enc = encode_clip(m, bound_cm / u, metric="joint+end", unit_cm=u, block_frames=16)
        dec = Clip(name, data=enc.data).decode()
        e, j = end_error(m, dec), joint_error(m, dec)
        assert e <= bound_cm / u * (1 + 1e-9), (name, bound_cm, e * u)
        assert j <= bound_cm / u * (1 + 1e-9)
        assert enc.report["max_end_site_error"] == pytest.approx(e, rel=1e-7)
    # the joint-only metric stays selectable: it bounds the joints and reports the End Sites it leaves free
    enc = encode_clip(m, 0.1 / u, metric="joint", unit_cm=u, block_frames=16)
    dec = Clip(name, data=enc.data).decode()
    assert joint_error(m, dec) <= 0.1 / u * (1 + 1e-9)
    assert enc.report["max_end_site_error"] == pytest.approx(end_error(m, dec), rel=1e-7)


def test_the_budget_covers_end_sites_so_the_worst_case_alone_holds(tests_data):
    """Every track at its worst-case tolerance, errors aligned on purpose: End Sites stay within the bound
    (a leaf joint's rotation gets a finite tolerance from the End Site it moves)."""
    m, u = _load(tests_data, "bvh/walk-meredith-60.bvh", None, 2.54)
    sk = m.skeleton
    P, _, E = forward_kinematics(m, end_sites=True)
    J = sk.n_joints
    bound = 0.1 / u
    rot = [j for j in range(J) if np.ptp(m.rotations[:, j], axis=0).max() > 0]
    tr = [j for j in range(J) if np.ptp(m.translations[:, j], axis=0).max() > 0]
    rt, tt = track_tolerances(sk, P, rot, tr, bound, "joint+end", 1.0, ends=E)
    leaves = {j for j, _ in sk.end_sites}
    assert all(np.isfinite(rt[j]) for j in rot if j in leaves)
    rt0, _ = track_tolerances(sk, P, rot, tr, bound, "joint", 1.0)
    assert any(not np.isfinite(rt0[j]) for j in rot if j in leaves)  # joints alone leave leaf rotations free
    # turn every rotation by √3·τ about one axis and shift every translation by τ per component
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(3):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rots = m.rotations.copy()
        trans = m.translations.copy()
        for j in rot:
            d = Rotation.from_rotvec(axis * np.sqrt(3) * rt[j]).as_quat()[[3, 0, 1, 2]]
            q = Rotation.from_quat(rots[:, j][:, [1, 2, 3, 0]]) * Rotation.from_quat(d[[1, 2, 3, 0]])
            rots[:, j] = q.as_quat()[:, [3, 0, 1, 2]]
        for j in tr:
            trans[:, j] += tt[j] * np.sign(axis)
        moved = Motion(sk, m.times, rots, trans, channel_values=None, source="moved", meta={})
        worst = max(worst, end_error(m, moved))
    assert 0 < worst <= bound * (1 + 1e-9)


def _chain_motion(lengths, tips, n, seed) -> Motion:
    """A random chain (plus a branch at its root) with End Sites on both leaves and smooth random rotations."""
    rng = np.random.default_rng(seed)
    J = len(lengths) + 1
    parents = np.array([-1] + list(range(J - 2)) + [0], dtype=np.int64)
    offsets = np.zeros((J, 3))
    for j in range(1, J):
        v = rng.normal(size=3)
        offsets[j] = v / np.linalg.norm(v) * lengths[j - 1]
    chans = (("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),) + \
        (("Zrotation", "Xrotation", "Yrotation"),) * (J - 1)
    ends = ((J - 2, (0.0, tips[0], 0.0)), (J - 1, (tips[1], 0.0, 0.0)))
    sk = Skeleton(tuple(f"j{j}" for j in range(J)), parents, offsets, chans, ends)
    t = np.arange(n) / 60.0
    freq = rng.uniform(0.2, 3.0, size=(J, 3))
    amp = rng.uniform(0.1, 1.5, size=(J, 3))
    rv = amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None, None] + rng.uniform(0, 6, size=(J, 3)))
    rots = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat()[:, [3, 0, 1, 2]].reshape(n, J, 4)
    trans = np.broadcast_to(offsets, (n, J, 3)).copy()
    trans[:, 0] = np.stack([np.sin(t), 0.1 * t, np.cos(t)], axis=-1) * 30.0
    return Motion(sk, t, rots, trans, channel_values=None, source="chain", meta={})


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lengths=st.lists(st.floats(0.5, 40.0), min_size=1, max_size=5),
       tips=st.tuples(st.floats(0.0, 60.0), st.floats(0.1, 60.0)),
       n=st.integers(2, 90), seed=st.integers(0, 2**31 - 1), bound=st.floats(0.005, 2.0),
       block=st.integers(2, 40))
def test_end_sites_within_the_bound_on_random_chains(lengths, tips, n, seed, bound, block):
    m = _chain_motion(lengths, tips, n, seed)
    enc = encode_clip(m, bound, metric="joint+end", block_frames=block)
    dec = Clip("chain.mkc", data=enc.data).decode()
    assert end_error(m, dec) <= bound * (1 + 1e-9)
    assert joint_error(m, dec) <= bound * (1 + 1e-9)


def test_compress_bounds_end_sites_by_default_in_clips_and_gltf(tests_data, tmp_path):
    """``compress --max-position-error 0.1`` with no --error-metric: End Sites of the written .mkc and
    .glb decoded from disk are within 0.1 cm; --error-metric joint is still the joints-only bound."""
    from mocapkit.io.formats.gltf import read_gltf

    src = tests_data / "bvh" / "walk-meredith-60.bvh"
    m = load_motion(src)
    for suffix in (".mkc", ".glb"):
        out = tmp_path / f"w{suffix}"
        rec = _cli_json("compress", src, "-o", out, "--max-position-error", "0.1", "--unit-cm", "2.54", "--json")
        back = load_motion(out) if suffix == ".mkc" else read_gltf(out)
        err = end_error(m, back)
        assert err <= 0.1 / 2.54 * (1 + 1e-9), (suffix, err * 2.54)
        assert rec["error_metric"] == "joint+end"
        if suffix == ".mkc":  # measured on the written bytes
            assert rec["max_end_site_error_cm"] == pytest.approx(err * 2.54, rel=1e-7)
        else:  # the file read back: joints and End Sites
            assert err * 2.54 * (1 - 1e-6) <= rec["readback_max_position_error_cm"] <= 0.1
    out = tmp_path / "j.mkc"
    rec = _cli_json("compress", src, "-o", out, "--max-position-error", "0.1", "--unit-cm", "2.54",
                    "--error-metric", "joint", "--json")
    assert rec["error_metric"] == "joint" and open_clip(out).header["bound"]["metric"] == "joint"
    assert joint_error(m, load_motion(out)) <= 0.1 / 2.54 * (1 + 1e-9)


@pytest.mark.shared
@pytest.mark.parametrize("name,asf,u", SHARED)
def test_end_sites_within_the_bound_on_every_shared_skeletal_file(shared_data, name, asf, u):
    m, u = _load(shared_data, name, asf, u)
    ref = naive_end_sites(m)
    enc = encode_clip(m, 0.1 / u, metric="joint+end", unit_cm=u)
    dec = Clip(name, data=enc.data).decode()
    err = float(np.linalg.norm(naive_end_sites(dec) - ref, axis=-1).max())
    assert err <= 0.1 / u * (1 + 1e-9), (name, err * u)


@pytest.mark.parametrize("name,asf,u", TESTS_FILES)
def test_gltf_output_bounds_end_sites_by_default(tests_data, tmp_path, name, asf, u):
    """``compress -o X.glb --max-position-error 0.1``: End Sites of the file read back within 0.1 cm (with
    the joints only, the ASF skeleton's End Sites moved 0.196 cm)."""
    from mocapkit.io.formats.gltf import read_gltf
    from mocapkit.jobs import compress_job

    out = tmp_path / "x.glb"
    rec = compress_job(tests_data / name, asf=None if asf is None else tests_data / asf, unit_cm=u,
                       max_position_error=0.1, output=out)
    m, _ = _load(tests_data, name, asf, u)
    back = read_gltf(out)
    unit = rec["unit_cm"]
    err = end_error(m, back) * unit
    assert err <= 0.1, (name, err)
    assert max(err, joint_error(m, back) * unit) == pytest.approx(rec["readback_max_position_error_cm"],
                                                                  rel=1e-6, abs=1e-9)
