"""Every field of a ``.mkc`` header is checked for type, finiteness and range: a clip re-packed with one
field changed (and checksums recomputed, so only the checks can refuse it) is a MocapFormatError naming
the file and the field, never a motion that mocapkit's own writers and readers then refuse."""

from __future__ import annotations

import json

import pytest

from mocapkit.clip import Clip, encode_clip
from mocapkit.clip.container import mkc_bytes
from mocapkit.errors import MocapFormatError
from mocapkit.io.loaders import load_motion
from mocapkit.io.skeletal.bvh import read_bvh, write_bvh


@pytest.fixture(scope="module")
def clip_bytes(tests_data) -> bytes:
    m = load_motion(tests_data / "bvh" / "walk-meredith-60.bvh")
    return encode_clip(m, 0.1 / 2.54, metric="joint+end", unit_cm=2.54, block_frames=16).data


def _forge(clip_bytes: bytes, change) -> bytes:
    """The clip's header with ``change(header, blocks)`` applied, re-packed with correct checksums."""
    c = Clip("x", data=clip_bytes)
    head = json.loads(json.dumps(c.header))
    blocks = [(e.first, e.frames, e.raw, c.file.block(i)) for i, e in enumerate(c.file.blocks)]
    head.pop("blocks")
    change(head, blocks)
    return mkc_bytes(head, blocks)


def _set(key, value):
    return lambda h, b: h.__setitem__(key, value)


def _skel(key, change):
    return lambda h, b: change(h["skeleton"][key])


def _first_track(cls, key, value):
    """Set ``key`` of the first animated track; for a constant one, the first rotation track becomes constant."""
    def change(h, b):
        t = next(t for t in h["tracks"] if t["kind"] == "rotation")
        if cls == "constant":
            t.pop("base_step")
            t["class"] = "constant"
        t[key] = value
    return change


def _block_raw(delta):
    return lambda h, b: b.__setitem__(0, (b[0][0], b[0][1], b[0][2] + delta, b[0][3]))


FORGERIES = [
    # top-level fields: presence, type
    ("missing field", lambda h, b: h.pop("keyframes"), "missing"),
    ("unknown field", _set("colour", "red"), "unknown header fields"),
    ("generator not text", _set("generator", 3), "generator"),
    ("source too long", _set("source", "x" * 5000), "source"),
    # frames and times
    ("frames a float", _set("frames", 60.0), "frames"),
    ("too many joint-frames", lambda h, b: h.update(frames=10**9), "frames"),
    ("frame time 1e-300", _set("frame_time", 1e-300), "frame_time"),
    ("frame time zero", _set("frame_time", 0.0), "frame_time"),
    ("frame time 1e7 s", _set("frame_time", 1e7), "frame_time"),
    ("frame time a string", _set("frame_time", "0.01"), "frame_time"),
    ("frame time a bool", _set("frame_time", True), "frame_time"),
    ("start time huge", _set("start_time", 1e13), "start_time"),
    ("start time swallowing the steps", lambda h, b: h.update(start_time=1e11, frame_time=1e-6), "start_time"),
    ("times too few", _set("times", [0.0, 1.0]), "times"),
    ("times backwards", lambda h, b: h.update(times=[float(60 - k) for k in range(60)]), "times"),
    ("times at 1 ns", lambda h, b: h.update(times=[k * 1e-9 for k in range(60)]), "times"),
    # unit
    ("unit zero", _set("unit_cm", 0.0), "unit_cm"),
    ("unit negative", _set("unit_cm", -2.54), "unit_cm"),
    ("unit 1e-300", _set("unit_cm", 1e-300), "unit_cm"),
    ("unit 1e9", _set("unit_cm", 1e9), "unit_cm"),
    ("unit text", _set("unit_cm", "2.54"), "unit_cm"),
    # skeleton
    ("skeleton field missing", lambda h, b: h["skeleton"].pop("end_sites"), "skeleton"),
    ("skeleton field unknown", lambda h, b: h["skeleton"].update(scale=1), "skeleton"),
    ("joint name with a blank", _skel("names", lambda v: v.__setitem__(1, "left hip")), "names"),
    ("joint name with a brace", _skel("names", lambda v: v.__setitem__(1, "a}")), "names"),
    ("joint name empty", _skel("names", lambda v: v.__setitem__(1, "")), "names"),
    ("joint name repeated", _skel("names", lambda v: v.__setitem__(1, v[0])), "duplicate"),
    ("joint name a number", _skel("names", lambda v: v.__setitem__(1, 7)), "names"),
    ("parent after its child", _skel("parents", lambda v: v.__setitem__(1, 5)), "parent"),
    ("offset infinite-ish", _skel("offsets", lambda v: v[0].__setitem__(0, 1e300)), "offsets"),
    ("offset of 2 numbers", _skel("offsets", lambda v: v[0].pop()), "offsets"),
    ("unknown channel", _skel("channels", lambda v: v[0].append("Wrotation")), "channel"),
    ("end site of no joint", _skel("end_sites", lambda v: v[0].__setitem__(0, 99)), "end site joint"),
    ("end site offset huge", _skel("end_sites", lambda v: v[0][1].__setitem__(0, -1e13)), "end site offset"),
    ("two end sites on one joint", _skel("end_sites", lambda v: v.append([v[0][0], [1.0, 0.0, 0.0]])), "End Sites"),
    ("end sites not a list", lambda h, b: h["skeleton"].update(end_sites={"a": 1}), "end site"),
    # tracks
    ("track field unknown", lambda h, b: h["tracks"][0].update(scale=2), "tracks[0]"),
    ("base step zero", _first_track("animated", "base_step", 0.0), "base_step"),
    ("base step 1e-300", _first_track("animated", "base_step", 1e-300), "base_step"),
    ("base step negative", _first_track("animated", "base_step", -0.1), "base_step"),
    ("constant rotation not unit", _first_track("constant", "value", [2.0, 0.0, 0.0, 0.0]), "unit quaternion"),
    ("constant rotation 1e-300", _first_track("constant", "value", [1e-300, 0.0, 0.0, 0.0]), "unit quaternion"),
    ("track joint out of range", lambda h, b: h["tracks"][0].update(joint=-1), "joint"),
    # informative fields are still typed
    ("keyframes negative", _set("keyframes", -1), "keyframes"),
    ("keyframes beyond frames x tracks", _set("keyframes", 10**12), "keyframes"),
    ("bound not an object", _set("bound", 0.1), "bound"),
    ("bound of an unknown metric", lambda h, b: h["bound"].update(metric="hands"), "bound.metric"),
    ("bound value zero", lambda h, b: h["bound"].update(value=0.0), "bound.value"),
    ("bound shell distance negative", lambda h, b: h["bound"].update(shell_distance=-3.0), "bound.shell_distance"),
    ("bound field missing", lambda h, b: h["bound"].pop("shell_distance"), "bound"),
    # counts against sizes: a block declaring more payload than its frames and tracks can hold
    ("block raw length beyond its frames", _block_raw(10**9), "raw length"),
]


@pytest.mark.parametrize("change,fragment", [f[1:] for f in FORGERIES], ids=[f[0] for f in FORGERIES])
def test_every_header_field_is_checked(clip_bytes, change, fragment):
    data = _forge(clip_bytes, change)
    with pytest.raises(MocapFormatError) as e:
        Clip("forged.mkc", data=data).decode()
    msg = str(e.value)
    assert fragment in msg and "forged.mkc" in msg, msg


def test_an_unchanged_repack_still_decodes(clip_bytes, tmp_path):
    """The forging itself changes nothing: the re-packed clip decodes, and its BVH reads back."""
    data = _forge(clip_bytes, lambda h, b: None)
    m = Clip("same.mkc", data=data).decode()
    write_bvh(tmp_path / "same.bvh", m, precision=6)
    assert read_bvh(tmp_path / "same.bvh").n_frames == m.n_frames


@pytest.mark.parametrize("change", [_set("frame_time", 1e-300), _set("unit_cm", -1.0),
                                    _skel("names", lambda v: v.__setitem__(1, "left hip"))],
                         ids=["frame time", "unit", "name"])
def test_clips_bvh_cannot_hold_are_refused_on_load(clip_bytes, change, tmp_path):
    """A clip whose motion BVH cannot hold (frame time, unit, joint name) is refused when loaded from disk,
    one error naming the file (these used to decode)."""
    data = _forge(clip_bytes, change)
    (tmp_path / "f.mkc").write_bytes(data)
    with pytest.raises(MocapFormatError, match="f.mkc"):
        load_motion(tmp_path / "f.mkc")
