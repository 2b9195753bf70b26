"""The .mkc clip: ACL's error metric, the track encoder, the block codec, the bound on the written bytes,
random access, lossless parts and corruption."""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocapkit.clip import Clip, encode_clip, position_errors
from mocapkit.clip.codec import entropy_decode, level_step, pack_block, steps_table, unpack_block, unpack_pose
from mocapkit.clip.container import mkc_bytes
from mocapkit.clip.keys import corridor_keys
from mocapkit.clip.metric import worst_errors
from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.loaders import load_motion, unit_cm
from mocapkit.jobs.readers import open_clip
from mocapkit.rotvec import exp_map, log_map
from mocapkit.skeleton import Motion, forward_kinematics

EXE = [sys.executable, "-m", "mocapkit.cli"]


# --------------------------------------------------------------------------------------------------
# independent references: per-frame forward kinematics with scipy, the shell points, a payload parser
# --------------------------------------------------------------------------------------------------

def naive_points(motion: Motion, d: float) -> tuple[np.ndarray, np.ndarray]:
    """World joint positions (N, J, 3) and shell points (N, J, 3 axes, 3) by scipy rotations, joint by
    joint (batched over frames), independent of mocapkit's forward kinematics."""
    sk = motion.skeleton
    N, J = motion.n_frames, sk.n_joints
    P = np.zeros((N, J, 3))
    S = np.zeros((N, J, 3, 3))
    world = [None] * J
    for j in range(J):
        q = motion.rotations[:, j]
        local = Rotation.from_quat(q[:, [1, 2, 3, 0]])  # scipy is scalar-last
        p = sk.parents[j]
        if p < 0:
            world[j] = local
            P[:, j] = motion.translations[:, j]
        else:
            world[j] = world[p] * local
            P[:, j] = P[:, p] + world[p].apply(motion.translations[:, j])
        for a in range(3):
            S[:, j, a] = P[:, j] + world[j].apply(d * np.eye(3)[a])
    return P, S


def naive_errors(original: Motion, decoded: Motion, d: float) -> tuple[np.ndarray, np.ndarray]:
    P0, S0 = naive_points(original, d)
    P1, S1 = naive_points(decoded, d)
    return np.linalg.norm(P1 - P0, axis=-1), np.linalg.norm(S1 - S0, axis=-1).max(axis=-1)


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    v, shift = 0, 0
    while True:
        b = buf[pos]
        v |= (b & 127) << shift
        pos += 1
        if b < 128:
            return v, pos
        shift += 7


def parse_payload(payload: bytes, n: int, T: int) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """The block layout of docs/mkc.md read in plain Python: (level, order, frames, grid integers)."""
    pos = 0
    head = []
    for _ in range(T):
        code, pos = _varint(payload, pos)
        K, pos = _varint(payload, pos)
        head.append((code >> 1, (code & 1) + 1, K))
    frames = []
    for _, _, K in head:
        f = [0]
        for _ in range(K - 2):
            g, pos = _varint(payload, pos)
            f.append(f[-1] + 1 + g)
        if K > 1:
            f.append(n - 1)
        frames.append(np.array(f))
    out = []
    for (level, order, K), f in zip(head, frames, strict=True):
        q = np.zeros((K, 3), dtype=np.int64)
        for c in range(3):
            for i in range(K):
                z, pos = _varint(payload, pos)
                r = z // 2 if z % 2 == 0 else -(z + 1) // 2
                if i == 0:
                    p = 0
                elif i == 1 or order == 1:
                    p = q[i - 1, c]
                else:
                    p = q[i - 1, c] + math.floor((q[i - 1, c] - q[i - 2, c])
                                                 * ((f[i] - f[i - 1]) / (f[i - 1] - f[i - 2])) + 0.5)
                q[i, c] = p + r
        out.append((level, order, f, q))
    assert pos == len(payload)
    return out


@pytest.fixture(scope="module")
def walk(tests_data) -> Motion:
    return load_motion(tests_data / "bvh" / "walk-meredith-60.bvh")


@pytest.fixture(scope="module")
def amc(tests_data) -> tuple[Motion, float]:
    m = load_motion(tests_data / "cmu" / "86_01_first60.amc", asf=tests_data / "cmu" / "86.asf")
    return m, unit_cm(m, None)[0]


# --------------------------------------------------------------------------------------------------
# the metric
# --------------------------------------------------------------------------------------------------

def _perturbed(m: Motion, seed: int, angle: float = 0.02, shift: float = 0.05) -> Motion:
    rng = np.random.default_rng(seed)
    N, J = m.n_frames, m.skeleton.n_joints
    dq = Rotation.from_rotvec(rng.normal(size=(N * J, 3)) * angle).as_quat()[:, [3, 0, 1, 2]].reshape(N, J, 4)
    w1, x1, y1, z1 = np.moveaxis(m.rotations, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(dq, -1, 0)
    rot = np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                    w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)
    tr = m.translations + rng.normal(size=m.translations.shape) * shift
    return Motion(m.skeleton, m.times, rot, tr)


@pytest.mark.parametrize("d", [1.0, 3.0 / 2.54, 7.5])
def test_both_metrics_match_a_naive_per_frame_implementation(walk, d):
    m = Motion(walk.skeleton, walk.times[:12], walk.rotations[:12], walk.translations[:12])
    dec = _perturbed(m, 1)
    je, se = position_errors(m, dec, d)
    nj, ns = naive_errors(m, dec, d)
    np.testing.assert_allclose(je, nj, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(se, ns, rtol=1e-9, atol=1e-9)
    # the compiled per-joint worst case used by the encoder's repair agrees too
    P0, R0 = forward_kinematics(m)
    for shell, ref in ((True, ns), (False, nj)):
        w = worst_errors(m.skeleton.parents.astype(np.int64), dec.rotations, dec.translations, P0, R0, d, shell)
        np.testing.assert_allclose(w, ref.max(axis=0), rtol=1e-9, atol=1e-9)
    # the shell sees a leaf's own rotation, the joint metric does not
    assert se.max() > 0 and np.all(se >= 0)


def test_shell_sees_a_leaf_rotation_that_moves_no_joint(walk):
    m = Motion(walk.skeleton, walk.times[:3], walk.rotations[:3], walk.translations[:3])
    leaf = next(j for j in range(m.skeleton.n_joints) if not m.skeleton.children(j))
    rot = m.rotations.copy()
    rot[:, leaf] = Rotation.from_rotvec([0, 0, 0.1]).as_quat()[[3, 0, 1, 2]]
    dec = Motion(m.skeleton, m.times, rot, m.translations)
    je, se = position_errors(m, dec, 2.0)
    assert je.max() == 0.0
    assert se[:, leaf].max() > 0.0


# --------------------------------------------------------------------------------------------------
# rotation vectors and the track encoder
# --------------------------------------------------------------------------------------------------

def test_exp_inverts_log_and_is_one_lipschitz():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(500, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    back = exp_map(log_map(q))
    assert np.all(np.abs(np.abs(np.einsum("ij,ij->i", back, q)) - 1) < 1e-12)
    u, v = rng.normal(size=(2, 2000, 3)) * 3.0
    dot = np.abs(np.einsum("ij,ij->i", exp_map(u), exp_map(v))).clip(0, 1)
    angle = 2 * np.arccos(dot)
    assert np.all(angle <= np.linalg.norm(u - v, axis=1) + 1e-12)


def test_exp_map_series_match_libm_sin_and_cos():
    """exp_into evaluates sin/cos of the half angle by series up to π: within 4e-16 of libm's."""
    h = np.concatenate([np.linspace(0, math.pi, 100_001), np.geomspace(1e-300, 1, 500),
                        [0.8, np.nextafter(0.8, 0), 4.0, 50.0]])
    v = np.zeros((h.size, 3))
    v[:, 1] = 2 * h
    q = exp_map(v)
    assert np.abs(q[:, 0] - np.cos(h)).max() <= 4e-16
    assert np.abs(q[:, 2] - np.sin(h)).max() <= 4e-16
    assert np.all(q[:, [1, 3]] == 0)


def _interp(f, q, step, n):
    return np.stack([np.interp(np.arange(n), f, q[:, c] * step) for c in range(q.shape[1])], axis=1)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1, 400), st.floats(1e-4, 1.0), st.floats(0.2, 2.0), st.integers(0, 2**31))
def test_corridor_keys_keep_every_sample_within_tolerance(n, tol, c, seed):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(size=(n, 3)) * rng.uniform(0.001, 0.5), axis=0)
    step = c * tol
    f, q = corridor_keys(x, tol, step)
    assert f[0] == 0 and f[-1] == n - 1 and np.all(np.diff(f) > 0)
    dec = _interp(f, q, step, n)
    assert np.abs(dec - x).max() <= tol * (1 + 1e-9)


def test_corridor_keys_need_no_interior_key_on_a_line():
    t = np.arange(200.0)
    x = np.stack([0.01 * t, -0.02 * t + 1, 0.5 + 0 * t], axis=1)
    f, _ = corridor_keys(x, 1e-3, 1e-3)
    assert f.tolist() == [0, 199]


def test_corridor_keys_refuse_a_step_beyond_twice_the_tolerance():
    with pytest.raises(InvalidParameterError):
        corridor_keys(np.zeros((3, 3)), 1e-3, 2.1e-3)


# --------------------------------------------------------------------------------------------------
# the block codec: an independent parser, exact keys, corrupt payloads
# --------------------------------------------------------------------------------------------------

def _random_tracks(rng, n, T):
    tracks = []
    for _ in range(T):
        K = int(rng.integers(2, n + 1)) if n > 1 else 1
        inner = np.sort(rng.choice(np.arange(1, n - 1), size=K - 2, replace=False)) if K > 2 else np.zeros(0, int)
        f = np.concatenate([[0], inner, [n - 1]]) if n > 1 else np.array([0])
        q = (rng.integers(-(2**40), 2**40, size=(len(f), 3)) if rng.random() < 0.2
             else rng.integers(-900, 900, size=(len(f), 3)))
        tracks.append((int(rng.integers(0, 20)), int(rng.integers(1, 3)), f.astype(np.int64), q.astype(np.int64)))
    return tracks


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 300), st.integers(0, 6), st.integers(0, 2**31))
def test_block_payload_round_trips_keys_exactly(n, T, seed):
    rng = np.random.default_rng(seed)
    tracks = _random_tracks(rng, n, T)
    payload = pack_block(n, tracks)
    parsed = parse_payload(payload, n, T)
    for (lv, order, f, q), (lv2, order2, f2, q2) in zip(tracks, parsed, strict=True):
        assert (lv, order) == (lv2, order2)
        assert np.array_equal(f, f2) and np.array_equal(q, q2)
    bases = rng.uniform(1e-6, 1e-2, size=T)
    table = steps_table(bases)
    vals = unpack_block(payload, n, np.full(T, 3), table, "x")
    for t, (lv, _, f, q) in enumerate(tracks):
        ref = _interp(f, q, level_step(bases[t], lv), n) if n > 1 else q * level_step(bases[t], lv)
        np.testing.assert_allclose(vals[:, 3 * t:3 * t + 3], ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max(initial=1))
    # the entropy stage is lossless and refuses a wrong length
    from mocapkit.clip.codec import entropy_encode

    coded = entropy_encode(payload)
    assert entropy_decode(coded, len(payload), "x") == payload
    with pytest.raises(MocapFormatError):
        entropy_decode(coded, len(payload) + 1, "x")


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=200), st.integers(1, 50), st.integers(0, 4))
def test_garbage_payloads_are_errors_not_crashes(blob, n, T):
    table = steps_table(np.full(T, 1e-3))
    try:
        vals = unpack_block(blob, n, np.full(T, 3), table, "fuzz")
    except MocapFormatError as e:
        assert "fuzz" in str(e)
        vals = None
    else:
        assert vals.shape == (n, 3 * T) and np.all(np.isfinite(vals))
    rot, tr = np.full((n, T + 1, 4), np.nan), np.full((n, T + 1, 3), np.nan)
    joints, is_rot = np.arange(T, dtype=np.int64), np.arange(T) % 2 == 0
    rest_r, rest_t = np.tile([1.0, 0, 0, 0], (T + 1, 1)), np.zeros((T + 1, 3))
    try:  # the pose decoder fails exactly where the values decoder does, and agrees with it otherwise
        unpack_pose(blob, n, table, joints, is_rot, rest_r, rest_t, rot, tr, "fuzz")
    except MocapFormatError as e:
        assert vals is None and "fuzz" in str(e)
    else:
        assert vals is not None and np.all(np.isfinite(rot)) and np.all(np.isfinite(tr))


# --------------------------------------------------------------------------------------------------
# the encoder: the bound on the decoded bytes, checked by the naive FK
# --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("metric", ["joint", "shell"])
@pytest.mark.parametrize("bound_cm", [0.01, 0.1, 1.0, 5.0])
def test_bound_holds_on_the_written_bytes(walk, amc, metric, bound_cm):
    for m, u in ((walk, 2.54), amc):
        enc = encode_clip(m, bound_cm / u, metric=metric, shell_distance=3.0 / u, unit_cm=u, block_frames=16)
        dec = Clip("clip.mkc", data=enc.data).decode()
        je, se = naive_errors(m, dec, 3.0 / u)
        err = se if metric == "shell" else je
        assert err.max() <= bound_cm / u * (1 + 1e-9)
        # the report is what the bytes give
        assert enc.report["max_joint_error"] == pytest.approx(je.max(), rel=1e-9, abs=1e-12)
        assert enc.report["max_shell_error"] == pytest.approx(se.max(), rel=1e-9, abs=1e-12)
        assert enc.report["bytes"] == len(enc.data)


def test_looser_bounds_give_smaller_clips(amc):
    m, u = amc
    sizes = [len(encode_clip(m, b / u, metric="shell", shell_distance=3 / u).data) for b in (0.01, 0.1, 1.0)]
    assert sizes[0] > sizes[1] > sizes[2]


def test_lossless_parts_round_trip_exactly(amc):
    m, u = amc
    enc = encode_clip(m, 0.5 / u, metric="joint", shell_distance=3 / u, unit_cm=u, block_frames=8, source="86_01")
    clip = Clip("c.mkc", data=enc.data)
    dec = clip.decode()
    sk0, sk1 = m.skeleton, dec.skeleton
    assert sk1.names == sk0.names and np.array_equal(sk1.parents, sk0.parents)
    assert np.array_equal(sk1.offsets, sk0.offsets) and sk1.channels == sk0.channels
    assert [(j, tuple(o)) for j, o in sk1.end_sites] == [(j, tuple(o)) for j, o in sk0.end_sites]
    assert sk1.meta["length_unit_cm"] == u
    np.testing.assert_allclose(dec.times, m.times, rtol=0, atol=1e-9 * m.frame_time)
    # constant tracks: exactly the original value (every frame equal in the source)
    for j in range(sk0.n_joints):
        if np.all(m.rotations[:, j] == m.rotations[0, j]):
            assert np.array_equal(dec.rotations[:, j], m.rotations[:, j])
        if np.all(m.translations[:, j] == m.translations[0, j]):
            assert np.array_equal(dec.translations[:, j], m.translations[:, j])
    # key positions: the file's blocks parsed independently decode to the reader's values
    T = len(clip.animated)
    for i, e in enumerate(clip.file.blocks):
        raw = entropy_decode(clip.file.block(i), e.raw, "x")
        parsed = parse_payload(raw, e.frames, T)
        vals = clip.block_values(i)
        for t, (lv, _, f, q) in enumerate(parsed):
            ref = _interp(f, q, clip.steps[t, lv], e.frames)
            np.testing.assert_allclose(vals[:, 3 * t:3 * t + 3], ref, rtol=1e-12, atol=1e-15)
    assert sum(len(p[2]) for i, e in enumerate(clip.file.blocks)
               for p in parse_payload(entropy_decode(clip.file.block(i), e.raw, "x"), e.frames, T)
               ) == enc.report["keyframes"]


def test_pose_at_decodes_one_block_and_matches_the_full_decode(amc, monkeypatch):
    m, u = amc
    enc = encode_clip(m, 0.2 / u, shell_distance=3 / u, block_frames=10)
    full = Clip("c.mkc", data=enc.data).decode()
    clip = Clip("c.mkc", data=enc.data)
    import mocapkit.clip.decoder as reader

    calls = []
    real = reader.entropy_decode
    monkeypatch.setattr(reader, "entropy_decode", lambda *a: calls.append(a[2]) or real(*a))
    rot, tr = clip.pose_at(m.times[23])  # frame 23: block 2 only
    assert calls == ["c.mkc (block 2)"]
    assert np.allclose(np.abs(np.einsum("jc,jc->j", rot, full.rotations[23])), 1, atol=1e-12)
    np.testing.assert_allclose(tr, full.translations[23], atol=1e-12)
    # between two frames (across a block boundary): the rotation lies between the two frames' rotations
    t = 0.5 * (m.times[29] + m.times[30])
    rot, tr = clip.pose_at(t)
    np.testing.assert_allclose(tr, 0.5 * (full.translations[29] + full.translations[30]), atol=1e-12)
    a = 2 * np.arccos(np.abs(np.einsum("jc,jc->j", full.rotations[29], full.rotations[30])).clip(0, 1))
    b = 2 * np.arccos(np.abs(np.einsum("jc,jc->j", rot, full.rotations[29])).clip(0, 1))
    assert np.all(b <= a + 1e-9)
    # clamped outside the clip
    r0, _ = clip.pose_at(-5.0)
    assert np.allclose(np.abs(np.einsum("jc,jc->j", r0, full.rotations[0])), 1, atol=1e-12)


def test_pose_decoder_gives_exactly_the_values_decoder_then_exp(amc):
    m, u = amc
    clip = Clip("c.mkc", data=encode_clip(m, 0.05 / u, shell_distance=3 / u, block_frames=16).data)
    rot, tr = clip.decode_arrays()
    for i, e in enumerate(clip.file.blocks):
        v = clip.block_values(i)
        for k, (j, kind) in enumerate(clip.animated):
            got = (rot if kind == "rotation" else tr)[e.first:e.first + e.frames, j]
            want = exp_map(v[:, 3 * k:3 * k + 3]) if kind == "rotation" else v[:, 3 * k:3 * k + 3]
            assert np.array_equal(got, want)
    fixed = [j for j in range(m.skeleton.n_joints) if (j, "rotation") not in clip.animated]
    assert np.array_equal(rot[:, fixed], np.broadcast_to(clip.rest_rotations[fixed], rot[:, fixed].shape))


def test_the_committed_version_1_clip_still_decodes_within_its_bound(tests_data, walk):
    clip = open_clip(tests_data / "clip" / "walk-meredith-60.mkc")
    assert clip.header["bound"]["metric"] == "shell" and clip.unit_cm == 2.54
    b = clip.header["bound"]
    je, se = naive_errors(walk, clip.decode(), b["shell_distance"])
    assert se.max() <= b["value"] * (1 + 1e-9) and se.max() > 0.5 * b["value"]
    assert b["value"] * 2.54 == pytest.approx(0.05)


def test_bad_parameters_are_refused(walk):
    with pytest.raises(InvalidParameterError):
        encode_clip(walk, 0.0)
    with pytest.raises(InvalidParameterError):
        encode_clip(walk, 0.1, metric="vertex")
    with pytest.raises(InvalidParameterError):
        encode_clip(walk, 0.1, shell_distance=-1)
    with pytest.raises(InvalidParameterError):
        encode_clip(walk, 1e-14)


# --------------------------------------------------------------------------------------------------
# corruption: truncation, flipped bytes, forged headers
# --------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def clip_bytes(walk) -> bytes:
    return encode_clip(walk, 0.05 / 2.54, metric="shell", shell_distance=3 / 2.54, unit_cm=2.54, block_frames=16).data


def test_every_truncation_is_an_error(clip_bytes):
    for cut in list(range(0, 40)) + list(range(40, len(clip_bytes), 97)) + [len(clip_bytes) - 1]:
        with pytest.raises(MocapFormatError) as e:
            Clip("cut.mkc", data=clip_bytes[:cut]).decode()
        assert "cut.mkc" in str(e.value)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.integers(0, 10**9), st.integers(1, 255)), min_size=1, max_size=4))
def test_flipped_bytes_are_errors_never_a_wrong_motion(clip_bytes, flips):
    data = bytearray(clip_bytes)
    for pos, x in flips:
        data[pos % len(data)] ^= x
    assume(bytes(data) != clip_bytes)  # two flips of one byte may cancel
    with pytest.raises(MocapFormatError):
        Clip("flip.mkc", data=bytes(data)).decode()


def _forge(clip_bytes: bytes, change) -> bytes:
    """A file whose checksums are right but whose header says something else."""
    c = Clip("x", data=clip_bytes)
    head = json.loads(json.dumps(c.header))
    blocks = [(e.first, e.frames, e.raw, c.file.block(i)) for i, e in enumerate(c.file.blocks)]
    head.pop("blocks")
    change(head, blocks)
    return mkc_bytes(head, blocks)


@pytest.mark.parametrize("change,fragment", [
    (lambda h, b: h.update(frames=h["frames"] + 1), "cover"),
    (lambda h, b: h["skeleton"]["parents"].__setitem__(1, 5), "parent"),
    (lambda h, b: h["skeleton"]["offsets"][0].__setitem__(0, "1"), "offsets"),
    (lambda h, b: h["skeleton"]["channels"][0].append("Wrotation"), "channel"),
    (lambda h, b: h["tracks"][0].update(kind="scale"), "track 0"),
    (lambda h, b: h["tracks"].pop(), "block"),
    (lambda h, b: h.update(frame_time=-1.0), "frame_time"),
    (lambda h, b: h.update(skeleton=None), "skeleton"),
    (lambda h, b: b.__setitem__(0, (b[0][0], b[0][1] + 1, b[0][2], b[0][3])), "frames"),
    (lambda h, b: b.__setitem__(0, (b[0][0], b[0][1], b[0][2] + 3, b[0][3])), "bytes"),
])
def test_forged_headers_with_valid_checksums_are_errors(clip_bytes, change, fragment):
    data = _forge(clip_bytes, change)
    with pytest.raises(MocapFormatError) as e:
        Clip("forged.mkc", data=data).decode()
    assert fragment in str(e.value) and "forged.mkc" in str(e.value)


def test_not_a_clip_and_other_versions_are_named(clip_bytes, tmp_path):
    with pytest.raises(MocapFormatError, match="not a mocapkit clip"):
        Clip("a.mkc", data=b"BVH\n" + clip_bytes[4:])
    v2 = bytearray(clip_bytes)
    v2[4:6] = struct.pack("<H", 2)
    with pytest.raises(MocapFormatError, match="version 2"):
        Clip("b.mkc", data=bytes(v2))
    with pytest.raises(MocapFormatError, match="no such file"):
        load_motion(tmp_path / "missing.mkc")


# --------------------------------------------------------------------------------------------------
# the command line
# --------------------------------------------------------------------------------------------------

def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([*EXE, *map(str, args)], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "COLUMNS": "200"})


def test_cli_compress_info_decompress(tests_data, tmp_path):
    src = tests_data / "bvh" / "walk-meredith-60.bvh"
    out = tmp_path / "walk.mkc"
    r = run("compress", src, "-o", out, "--max-position-error", "0.05", "--error-metric", "shell",
            "--unit-cm", "2.54", "--json")
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout)
    assert rec["error_metric"] == "shell" and rec["bytes"] == out.stat().st_size
    assert rec["max_shell_error_cm"] <= 0.05 and rec["max_joint_error_cm"] > 0
    assert rec["outputs"][0] == {"path": str(out), "bytes": out.stat().st_size, "format": "mkc", "bound": 0.05,
                                 "bound_unit": "cm"}
    # both metrics reported whichever is bounded, checked against the naive FK of the decoded file
    m = load_motion(src)
    je, se = naive_errors(m, load_motion(out), 3 / 2.54)
    assert rec["max_shell_error_cm"] == pytest.approx(se.max() * 2.54, rel=1e-9)
    assert rec["max_joint_error_cm"] == pytest.approx(je.max() * 2.54, rel=1e-9)
    r = run("info", out, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["frames"] == m.n_frames and info["clip_bytes"] == out.stat().st_size
    assert info["clip_error_metric"] == "shell" and info["clip_bound_cm"] == pytest.approx(0.05)
    for suffix in (".bvh", ".glb"):
        dest = tmp_path / f"back{suffix}"
        r = run("decompress", out, "-o", dest)
        assert r.returncode == 0, r.stderr
    back = load_motion(tmp_path / "back.bvh")
    je2, _ = naive_errors(m, back, 1.0)
    assert je2.max() <= 0.05 / 2.54 + 1e-5  # 6 decimals of BVH
    from mocapkit.io.formats.gltf import read_gltf

    g = read_gltf(tmp_path / "back.glb")
    assert g.n_frames == m.n_frames


def test_cli_entropy_stage_is_chosen_and_named_in_the_file(tests_data, tmp_path):
    src = tests_data / "cmu" / "86_01_first60.amc"
    sizes = {}
    for entropy, codec in (("zstd", 1), ("lzma", 2)):
        out = tmp_path / f"{entropy}.mkc"
        r = run("compress", src, "--asf", tests_data / "cmu" / "86.asf", "-o", out, "--max-position-error", "0.01",
                "--entropy", entropy, "--block-frames", "30")
        assert r.returncode == 0, r.stderr
        clip = open_clip(out)
        assert {clip.file.block(i)[0] for i in range(len(clip.file.blocks))} <= {0, codec}
        sizes[entropy] = out.stat().st_size
        clip.decode()
    r = run("compress", src, "--asf", tests_data / "cmu" / "86.asf", "-o", tmp_path / "x.mkc",
            "--max-position-error", "0.01", "--entropy", "brotli")
    assert r.returncode == 2 and "--entropy" in r.stderr and not (tmp_path / "x.mkc").exists()


def test_cli_refuses_clip_options_that_do_not_apply(tests_data, tmp_path):
    src = tests_data / "bvh" / "walk-meredith-60.bvh"
    r = run("compress", src, "-o", tmp_path / "w.mkc", "--target-icr", "0.1")
    assert r.returncode == 2 and "--max-position-error" in r.stderr
    r = run("compress", src, "-o", tmp_path / "w.glb", "--max-position-error", "0.1", "--error-metric", "shell")
    assert r.returncode == 2 and ".mkc" in r.stderr
    r = run("decompress", tmp_path / "none.mkc", "-o", tmp_path / "x.csv")
    assert r.returncode == 2
    bad = tmp_path / "bad.mkc"
    bad.write_bytes(b"MKC\x00" + b"\x00" * 30)
    r = run("info", bad)
    assert r.returncode == 2 and "bad.mkc" in r.stderr and len(r.stderr.strip().splitlines()) == 1


# --------------------------------------------------------------------------------------------------
# every shared skeletal file, several bounds, both metrics
# --------------------------------------------------------------------------------------------------

SHARED = [("cmu/86_01.amc", "cmu/86.asf", None), ("cmu/13_29.amc", "cmu/86.asf", None),
          ("cmu/13_30.amc", "cmu/86.asf", None), ("cmu/14_14.amc", "cmu/86.asf", None),
          ("bvh/walk-meredith.bvh", None, 2.54), ("bvh/mixamo-rig.bvh", None, None),
          ("bvh/cmu-131_01-3dsmax.bvh", None, None), ("bvh/perception-neuron-freya.bvh", None, None),
          ("bvh/mocapbank.bvh", None, None)]


@pytest.mark.shared
@pytest.mark.parametrize("name,asf,u", SHARED)
def test_bound_holds_on_every_shared_skeletal_file(shared_data, name, asf, u):
    m = load_motion(shared_data / name, asf=None if asf is None else shared_data / asf)
    u = u or unit_cm(m, None)[0]
    d = 3 / u
    P0, S0 = naive_points(m, d)  # scipy, not mocapkit's forward kinematics
    for metric, bound_cm in (("shell", 0.01), ("joint", 0.1), ("shell", 1.0)):
        enc = encode_clip(m, bound_cm / u, metric=metric, shell_distance=d, unit_cm=u)
        P1, S1 = naive_points(Clip(name, data=enc.data).decode(), d)
        joint = np.linalg.norm(P1 - P0, axis=-1)
        shell = np.linalg.norm(S1 - S0, axis=-1).max(axis=-1)
        err = shell if metric == "shell" else joint
        assert err.max() <= bound_cm / u * (1 + 1e-9), (name, metric, bound_cm, err.max() * u)
        assert enc.report["max_shell_error"] == pytest.approx(shell.max(), rel=1e-7)
        assert enc.report["max_joint_error"] == pytest.approx(joint.max(), rel=1e-7)


def test_batch_writes_clips_within_their_bound(tests_data, tmp_path):
    pytest.importorskip("pyarrow")
    src = tmp_path / "in"
    src.mkdir()
    for name in ("walk-meredith-60.bvh", "perception-neuron-freya-12.bvh"):
        (src / name).write_bytes((tests_data / "bvh" / name).read_bytes())
    out = tmp_path / "out"
    r = run("batch", "compress", src, "--out", out, "--max-position-error", "0.2", "--skeletal-format", "mkc",
            "--error-metric", "shell", "--jobs", "1")
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for line in (out / "journal.jsonl").read_text().splitlines() if line.strip()]
    assert len(rows) == 2
    for name in ("walk-meredith-60", "perception-neuron-freya-12"):
        clip = out / f"{name}.mkc"
        m = load_motion(src / f"{name}.bvh")
        _, se = naive_errors(m, load_motion(clip), 3.0)
        assert se.max() <= 0.2 * (1 + 1e-9)
    r = run("batch", "compress", src, "--out", tmp_path / "o2", "--max-position-error", "0.2",
            "--error-metric", "shell")
    assert r.returncode == 2 and "--skeletal-format mkc" in r.stderr and not (tmp_path / "o2").exists()
