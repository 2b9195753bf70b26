"""glTF rotations as normalized SHORT: stored bytes against an independent decode, the Khronos validator,
the position bound on the decoded file (independent per-frame FK), malformed accessor types refused."""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mocapkit.errors import MocapFormatError
from mocapkit.io.formats.gltf import SHORT_KEY_ANGLE, quantize_rotations, read_gltf, write_gltf
from mocapkit.io.loaders import load_motion
from mocapkit.io.skeletal.bvh import read_bvh
from mocapkit.jobs import compress_job
from mocapkit.jobs.gltf_out import every_frame, readback_error, storage_error_bound
from mocapkit.pla.skeletal import compress_motion
from reference_kinematics import gltf_validator, naive_end_sites, naive_positions

ROOT = Path(__file__).resolve().parents[1]


# -- independent helpers (struct / numpy / scipy; nothing of mocapkit's reader) --------------------

def glb_parts(data: bytes) -> tuple[dict, bytes]:
    magic, version, total = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and total == len(data)
    jlen, jtype = struct.unpack_from("<II", data, 12)
    assert jtype == 0x4E4F534A
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<II", data, 20 + jlen)
    assert btype == 0x004E4942
    return doc, data[28 + jlen:28 + jlen + blen]


def glb_bytes(doc: dict, blob: bytes) -> bytes:
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    blob += b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(j) + 8 + len(blob)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(j), 0x4E4F534A) + j
            + struct.pack("<II", len(blob), 0x004E4942) + blob)


def raw_accessor(doc: dict, blob: bytes, i: int) -> np.ndarray:
    """The stored values of accessor ``i`` exactly as in the bytes (no normalisation)."""
    acc = doc["accessors"][i]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5126: "<f4"}[acc["componentType"]]
    n = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc["type"]]
    assert "byteStride" not in view
    off = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return np.frombuffer(blob, dtype=dtype, count=acc["count"] * n, offset=off).reshape(-1, n)


def continuous(q: np.ndarray) -> np.ndarray:
    """Hemisphere continuity, one key at a time."""
    out = np.array(q, dtype=float)
    for k in range(1, len(out)):
        if np.dot(out[k], out[k - 1]) < 0:
            out[k] = -out[k]
    return out


def validate(path: Path) -> dict:
    node, mods = gltf_validator()
    r = subprocess.run([node, str(ROOT / "tools" / "validate_gltf.mjs"), str(path)], capture_output=True, text=True,
                       env={**os.environ, "NODE_PATH": str(mods)}, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


# -- clips from tests/data ------------------------------------------------------------------------

def clips(tests_data):
    """(name, path, asf, unit_cm) of the skeletal excerpts."""
    return [("walk", tests_data / "bvh" / "walk-meredith-60.bvh", None, 2.54),
            ("freya", tests_data / "bvh" / "perception-neuron-freya-12.bvh", None, 1.0),
            ("86_01", tests_data / "cmu" / "86_01_first60.amc", tests_data / "cmu" / "86.asf", None)]


@pytest.fixture(scope="module")
def walk(tests_data):
    return read_bvh(tests_data / "bvh" / "walk-meredith-60.bvh")


# -- quantisation ---------------------------------------------------------------------------------

def test_quantisation_error_is_within_the_stated_worst_case():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(200_000, 4))
    c = quantize_rotations(q)
    u = q / np.linalg.norm(q, axis=1, keepdims=True)
    assert c.dtype == np.int16 and np.array_equal(c, np.rint(u * 32767).astype(np.int16))
    back = np.maximum(c / 32767.0, -1.0)
    ang = Rotation.from_quat(u).inv() * Rotation.from_quat(back)  # scipy normalises: the decoder does too
    worst = ang.magnitude().max()
    assert worst <= SHORT_KEY_ANGLE
    assert worst >= 0.3 * SHORT_KEY_ANGLE  # the stated bound is not vacuous
    assert SHORT_KEY_ANGLE == pytest.approx(2 * math.asin(1 / 32767)) and math.degrees(SHORT_KEY_ANGLE) < 0.0036


def test_short_bytes_against_an_independent_decode(walk, tmp_path):
    comp = compress_motion(walk, "fastsw", threshold=1e-4)
    p = write_gltf(tmp_path / "w.glb", comp, unit_m=0.0254, rotations="short")
    doc, blob = glb_parts(p.read_bytes())
    anim = doc["animations"][0]
    keys = {}
    for ch in anim["channels"]:
        smp = anim["samplers"][ch["sampler"]]
        acc_in, acc_out = doc["accessors"][smp["input"]], doc["accessors"][smp["output"]]
        assert acc_in["componentType"] == 5126 and not acc_in.get("normalized", False)  # times stay FLOAT
        t = raw_accessor(doc, blob, smp["input"])[:, 0]
        v = raw_accessor(doc, blob, smp["output"])
        assert acc_in["min"] == [float(t.min())] and acc_in["max"] == [float(t.max())]
        j = ch["target"]["node"]
        if ch["target"]["path"] == "translation":
            assert acc_out["componentType"] == 5126
            continue
        assert acc_out["componentType"] == 5122 and acc_out["normalized"] is True and acc_out["type"] == "VEC4"
        assert acc_out["min"] == v.min(axis=0).tolist() and acc_out["max"] == v.max(axis=0).tolist()
        # the stored integers are the nearest SHORTs of the normalised, hemisphere-continuous keys
        src = comp.rotations[j].values
        u = continuous(src / np.linalg.norm(src, axis=1, keepdims=True))[:, [1, 2, 3, 0]]
        assert np.array_equal(v, np.rint(u * 32767))
        dec = np.maximum(v / 32767.0, -1.0)
        assert np.abs(dec - u).max() <= 0.5 / 32767 + 1e-15
        assert np.array_equal(t, comp.rotations[j].times.astype(np.float32))
        keys[j] = (t.astype(float), dec)
    assert set(keys) == set(comp.rotations)
    # our reader's full-rate motion = SLERP of the independently decoded keys at the frame times
    back = read_gltf(p)
    for j, (t, dec) in keys.items():
        tt = np.clip(walk.times, t[0], t[-1])
        want = Slerp(t, Rotation.from_quat(dec))(tt) if len(t) > 1 else Rotation.from_quat(np.repeat(dec, len(tt), 0))
        got = Rotation.from_quat(back.rotations[:, j][:, [1, 2, 3, 0]])
        assert (want.inv() * got).magnitude().max() < 1e-9, walk.skeleton.names[j]


def test_short_file_is_smaller_and_decodes_within_the_key_angle(walk, tmp_path):
    comp = compress_motion(walk, "fastsw", threshold=1e-4)
    f = write_gltf(tmp_path / "f.glb", comp, rotations="float")
    s = write_gltf(tmp_path / "s.glb", comp, rotations="short")
    n_rot_keys = sum(c.n_points for c in comp.rotations.values())
    assert f.stat().st_size - s.stat().st_size >= 8 * n_rot_keys - 4 * len(comp.rotations)  # 8 bytes a key saved
    mf, ms = read_gltf(f), read_gltf(s)
    ang = (Rotation.from_quat(mf.rotations.reshape(-1, 4)[:, [1, 2, 3, 0]]).inv()
           * Rotation.from_quat(ms.rotations.reshape(-1, 4)[:, [1, 2, 3, 0]])).magnitude()
    assert ang.max() <= math.sqrt(2) * SHORT_KEY_ANGLE + 1e-6


# -- the Khronos validator ------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_validator_passes_short_rotations(tests_data, tmp_path, suffix):
    gltf_validator()
    for name, path, asf, ucm in clips(tests_data):
        out = tmp_path / f"{name}{suffix}"
        rec = compress_job(path, asf=asf, unit_cm=ucm, max_position_error=0.5, output=out)
        assert rec["gltf_rotations"] == "short"
        doc = json.loads(out.read_text()) if suffix == ".gltf" else glb_parts(out.read_bytes())[0]
        assert any(a["componentType"] == 5122 and a.get("normalized") for a in doc["accessors"])
        rep = validate(out)
        assert rep["numErrors"] == 0, (name, rep["messages"])
        assert rep["numWarnings"] == 0, (name, rep)


# -- the bound on the decoded file ----------------------------------------------------------------

@pytest.mark.parametrize("cm", [0.02, 0.1, 0.5, 2.0])
def test_bound_holds_on_the_read_back_file(tests_data, tmp_path, cm):
    for name, path, asf, ucm in clips(tests_data):
        out = tmp_path / f"{name}.glb"
        rec = compress_job(path, asf=asf, unit_cm=ucm, max_position_error=cm, output=out)
        orig = load_motion(path, asf=asf)
        unit = rec["unit_cm"]
        back = read_gltf(out)  # what any reader of the file gets
        assert back.n_frames == orig.n_frames and back.skeleton.names == orig.skeleton.names
        err = np.linalg.norm(naive_positions(back) - naive_positions(orig), axis=-1).max() * unit
        err = max(err, np.linalg.norm(naive_end_sites(back) - naive_end_sites(orig), axis=-1).max() * unit)
        assert err <= cm, (name, cm, err, rec["gltf_rotations"])  # joints and End Sites (the default metric)
        assert err == pytest.approx(rec["readback_max_position_error_cm"], rel=1e-6, abs=1e-9)
        assert rec["file_bytes"] == out.stat().st_size
        assert rec["gltf_compress_bound_cm"] < cm  # compressed within a bound that leaves room for storage
        if rec["gltf_rotations"] == "float":  # only where SHORT would take half the bound
            assert rec["warnings"] and "FLOAT" in rec["warnings"][-1]
            assert rec["gltf_storage_error_measured_cm"] > 0 and cm <= 0.1


def test_short_at_loose_bounds_and_float_fallback_at_tight_ones(tests_data, tmp_path):
    path = tests_data / "bvh" / "walk-meredith-60.bvh"
    loose = compress_job(path, unit_cm=2.54, max_position_error=1.0, output=tmp_path / "a.glb")
    assert loose["gltf_rotations"] == "short" and not loose["warnings"]
    tight = compress_job(path, unit_cm=2.54, max_position_error=0.004, output=tmp_path / "b.glb")
    assert tight["gltf_rotations"] == "float" and "SHORT rotations would take" in tight["warnings"][0]
    doc, _ = glb_parts((tmp_path / "b.glb").read_bytes())
    assert all(a["componentType"] == 5126 for a in doc["accessors"])
    forced = compress_job(path, unit_cm=2.54, max_position_error=1.0, output=tmp_path / "c.glb", gltf_rotations="float")
    assert forced["gltf_rotations"] == "float"
    assert loose["file_bytes"] < forced["file_bytes"]


def test_storage_error_bound_covers_the_measured_storage_error(tests_data, tmp_path):
    for name, path, asf, _ucm in clips(tests_data):
        m = load_motion(path, asf=asf)
        full = every_frame(m)
        for fmt in ("short", "float"):
            p = write_gltf(tmp_path / f"{name}-{fmt}.glb", full, unit_m=0.01, rotations=fmt)
            measured = readback_error(m, p)
            bound = storage_error_bound(m, fmt)
            assert 0 < measured <= bound, (name, fmt, measured, bound)


# -- accessor types: decoded as the spec says, malformed ones refused ------------------------------

def _one_track(ctype: int, normalized, stored: np.ndarray, extra: dict | None = None) -> bytes:
    """Two nodes, one rotation track with two keys whose output accessor is ``stored`` as ``ctype``."""
    times = np.array([0.0, 1.0], dtype="<f4").tobytes()
    dt = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}[ctype]
    vals = np.ascontiguousarray(stored, dtype=dt).tobytes()
    vals += b"\0" * (-len(vals) % 4)
    blob = times + vals
    acc = {"bufferView": 1, "componentType": ctype, "count": 2, "type": "VEC4",
           "min": stored.min(axis=0).tolist(), "max": stored.max(axis=0).tolist()}
    if normalized is not None:
        acc["normalized"] = normalized
    acc.update(extra or {})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"name": "a", "children": [1]}, {"name": "b", "translation": [0, 1, 0]}],
           "buffers": [{"byteLength": len(blob)}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 8},
                           {"buffer": 0, "byteOffset": 8, "byteLength": len(vals)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR",
                          "min": [0.0], "max": [1.0]}, acc],
           "animations": [{"samplers": [{"input": 0, "output": 1}],
                           "channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}]}]}
    return glb_bytes(doc, blob)


Q_KEYS = np.array([[0.1, 0.2, 0.3, math.sqrt(1 - 0.14)], [0.5, 0.1, 0.2, math.sqrt(1 - 0.30)]])  # x y z w, all >= 0


@pytest.mark.parametrize("ctype,scale,signed", [(5120, 127, True), (5121, 255, False), (5122, 32767, True),
                                                (5123, 65535, False)])
def test_normalized_integer_rotations_decode_as_the_spec_says(tmp_path, ctype, scale, signed):
    stored = np.rint(Q_KEYS * scale)
    if signed:
        stored[1] = [-scale - 1, 0, 0, 0]  # the most negative integer: decoded as -1 (max(c/scale, -1))
    p = tmp_path / "t.glb"
    p.write_bytes(_one_track(ctype, True, stored))
    m = read_gltf(p, rate=2)  # frames at 0, 0.5, 1 s
    dec = np.maximum(stored / scale, -1.0) if signed else stored / scale
    want = Slerp([0.0, 1.0], Rotation.from_quat(dec))([0.0, 0.5, 1.0])
    got = Rotation.from_quat(m.rotations[:, 0][:, [1, 2, 3, 0]])
    assert (want.inv() * got).magnitude().max() < 1e-9


def _short_clip(tmp_path, walk) -> Path:
    return write_gltf(tmp_path / "clip.glb", compress_motion(walk, "fastsw", max_position_error=0.5),
                      rotations="short")


def _rot_output(doc):
    anim = doc["animations"][0]
    ch = next(c for c in anim["channels"] if c["target"]["path"] == "rotation")
    return doc["accessors"][anim["samplers"][ch["sampler"]]["output"]]


def _tr_output(doc):
    anim = doc["animations"][0]
    ch = next(c for c in anim["channels"] if c["target"]["path"] == "translation")
    return doc["accessors"][anim["samplers"][ch["sampler"]]["output"]]


def _times(doc):
    return doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]


MALFORMED = {
    "integer rotation without normalized": (lambda d: _rot_output(d).pop("normalized"), "componentType SHORT"),
    "normalized false": (lambda d: _rot_output(d).update(normalized=False), "componentType SHORT"),
    "normalized not a bool": (lambda d: _rot_output(d).update(normalized="yes"), "normalized must be true or false"),
    "normalized FLOAT": (lambda d: _times(d).update(normalized=True), "normalized"),
    "SHORT times": (lambda d: _times(d).update(componentType=5122, normalized=True), "sampler 0 input"),
    "SHORT translation": (lambda d: _tr_output(d).update(componentType=5122, normalized=True), "translation output"),
    "UNSIGNED_INT rotation": (lambda d: _rot_output(d).update(componentType=5125), "UNSIGNED_INT"),
    "unknown componentType": (lambda d: _rot_output(d).update(componentType=5130), "componentType 5130"),
    "boolean componentType": (lambda d: _rot_output(d).update(componentType=True), "componentType True"),
    "min as decoded floats": (lambda d: _rot_output(d).update(min=[v / 32767 for v in _rot_output(d)["min"]]),
                              "differs from its values"),
    "odd byteOffset": (lambda d: _rot_output(d).update(byteOffset=1), "not a multiple of 2"),
    "sparse": (lambda d: _rot_output(d).update(sparse={"count": 1}), "sparse"),
    "VEC3 rotation": (lambda d: [_rot_output(d).update(type="VEC3"), _rot_output(d).pop("min"),
                                 _rot_output(d).pop("max")],
                      "rotation keys must be VEC4"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_accessor_types_are_refused(tmp_path, walk, case):
    mutate, fragment = MALFORMED[case]
    doc, blob = glb_parts(_short_clip(tmp_path, walk).read_bytes())
    mutate(doc)
    p = tmp_path / "user clip.glb"
    p.write_bytes(glb_bytes(doc, blob))
    with pytest.raises(MocapFormatError) as ei:
        read_gltf(p)
    assert ei.value.path == str(p) and str(ei.value).startswith(str(p))
    assert fragment in ei.value.problem, ei.value


def test_unit_check_allows_byte_rounding_only_for_bytes(tmp_path):
    q = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]])
    p = tmp_path / "t.glb"
    stored = np.rint(q * 127)
    stored[:, 0] = 1  # norm 1.00003: a BYTE key may be off by this much
    p.write_bytes(_one_track(5120, True, stored))
    assert read_gltf(p, rate=1).n_frames == 2
    p.write_bytes(_one_track(5126, None, stored / 127))  # the same values as FLOAT are accepted too (< 1e-3)
    read_gltf(p, rate=1)
    p.write_bytes(_one_track(5126, None, np.array([[0.0, 0.0, 0.0, 1.01]] * 2)))
    with pytest.raises(MocapFormatError, match="not a unit quaternion"):
        read_gltf(p, rate=1)
