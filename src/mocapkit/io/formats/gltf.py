"""glTF 2.0 export of compressed skeletal animation (via pygltflib).

One node per joint (its rest offset as the node translation, children as in the skeleton, plus a node
per end site), one animation with, per animated joint, a rotation channel with its own keyframe times
(``LINEAR``, which glTF defines as spherical linear interpolation for rotations) and, for joints whose
position is animated, a translation channel. Keyframe quaternions are normalised, reordered to glTF's
``(x, y, z, w)`` and made hemisphere-continuous, so a player that does not take the shortest arc gives
the same result. Lengths are converted to metres (glTF's unit) with ``unit_m`` metres per file unit.
``.glb`` (binary) or ``.gltf`` (JSON with the buffer embedded as a data URI) by the suffix.

Rotation keys are stored as FLOAT (``rotations="float"``) or, 40 % smaller, as normalized SHORT
(``rotations="short"``: componentType 5122 with ``normalized: true``, which the glTF 2.0 core spec
allows for rotation sampler outputs; keyframe times stay FLOAT as the spec requires). Each component
of the normalised, hemisphere-continuous key ``q`` is rounded to the nearest ``c = round(32767·q)``;
a decoder reads ``max(c/32767, -1)`` and renormalises. Worst case this adds (derivation): every
component moves by at most ``0.5/32767``, so the 4-vector moves by at most ``√4·0.5/32767 = 1/32767``
and its direction by at most ``asin(1/32767)``; a rotation angle is twice the angle between its unit
quaternions, so a SHORT key is off by at most :data:`SHORT_KEY_ANGLE` ``= 2·asin(1/32767)`` = 6.10e-5 rad
(0.0035°), which moves a point 1 m from the joint by at most 0.061 mm. Between two keys ``θ`` apart,
the SLERP of the rounded keys stays within ``SHORT_KEY_ANGLE / cos(θ/4)`` of the exact one (to first
order; ``≤ √2·SHORT_KEY_ANGLE`` since hemisphere-continuous keys are at most 180° apart). FLOAT keys
add at most :data:`FLOAT_KEY_ANGLE` ``= 2·asin(2^-24)`` (float32 rounding of each component ``≤ 2^-25``).

The animation's ``extras["mocapkit"]`` keeps what glTF has no place for (frame times, the BVH channels of
every joint, the number of joint nodes, the length unit), so :func:`read_gltf` decodes a file written here
back to the full-rate motion exactly as :meth:`SkeletalCompressed.decode` does (up to float32). Other glTF
files are read too: every node is a joint, the frame rate is given by the caller. Reading parses the
GLB chunks and the JSON itself (standard ``json``, every field type- and range-checked) rather than
through pygltflib, whose object mapping costs about a millisecond per node, accessor or sampler; any
malformed or hostile content is a :class:`~mocapkit.errors.MocapFormatError` naming the file.
A file with ``extras["mocapkit"]`` must hold every field written here (none is defaulted) and agree
with itself: one channel list and offset per joint, rotation channels none or X, Y, Z once each, a
rotation/translation track exactly for joints with rotation/position channels (and no motion a BVH
channel list could not write), the scene's roots exactly the parentless nodes, every joint named;
accessor ``min``/``max`` (written for every accessor) must match the values read (the stored integers
for a normalized accessor, as the spec says). Accessor types are checked against what the core spec
allows where they are used: keyframe times and translations FLOAT, rotations FLOAT or normalized
BYTE/UNSIGNED_BYTE/SHORT/UNSIGNED_SHORT (decoded ``max(c/127, -1)``, ``c/255``, ``max(c/32767, -1)``,
``c/65535``); any other componentType, a ``normalized`` flag on the wrong type, an integer rotation
without it, or a sparse accessor is an error naming the file.
"""

from __future__ import annotations

import base64
import json
import math
import re
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pygltflib as g

from mocapkit.errors import InvalidParameterError, MocapError, MocapFormatError
from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text
from mocapkit.io.text.numbers import MAX_ABS
from mocapkit.quat import hemisphere_continuous, normalize, slerp
from mocapkit.skeleton import MAX_JOINT_FRAMES, POSITION_CHANNELS, ROTATION_CHANNELS, Motion, Skeleton

EXTRAS_KEY = "mocapkit"
MAX_VALUES = MAX_JOINT_FRAMES  # joint-frames decoded at most (~1.1 GB as float64 rotations + translations)
_VALID_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS


#: the ways rotation keys can be stored (``rotations=`` of :func:`build_gltf` / :func:`write_gltf`)
ROTATION_FORMATS = ("float", "short")
SHORT_SCALE = 32767
#: worst-case rotation angle (radians) one key stored as normalized SHORT adds (module notes)
SHORT_KEY_ANGLE = 2.0 * math.asin(1.0 / SHORT_SCALE)
#: worst-case rotation angle (radians) one key stored as float32 adds (each component rounded by <= 2^-25)
FLOAT_KEY_ANGLE = 2.0 * math.asin(2.0**-24)


def quantize_rotations(q: np.ndarray) -> np.ndarray:
    """``(M, 4)`` quaternions (any order of components, not yet normalised) as the int16 components
    ``round(32767·q/|q|)`` stored by a normalized SHORT accessor."""
    q = np.asarray(q, dtype=np.float64)
    u = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.clip(np.rint(u * SHORT_SCALE), -SHORT_SCALE, SHORT_SCALE).astype(np.int16)


class _Blob:
    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[g.BufferView] = []
        self.accessors: list[g.Accessor] = []

    def add(self, arr: np.ndarray, type_: str, minmax: bool = False) -> int:
        """Append ``arr`` as an accessor: int16 arrays as normalized SHORT, anything else as FLOAT;
        ``min``/``max`` are the stored values (the integers for SHORT, as the spec requires)."""
        short = np.asarray(arr).dtype == np.int16
        a = np.ascontiguousarray(arr, dtype="<i2" if short else "<f4")
        while len(self.data) % 4:
            self.data.append(0)
        off = len(self.data)
        self.data.extend(a.tobytes())
        self.views.append(g.BufferView(buffer=0, byteOffset=off, byteLength=a.nbytes))
        acc = g.Accessor(
            bufferView=len(self.views) - 1,
            componentType=g.SHORT if short else g.FLOAT,
            normalized=True if short else None,
            count=int(a.shape[0]),
            type=type_,
        )
        if minmax:
            flat = a.reshape(a.shape[0], -1)
            cast = int if short else float
            acc.min = [cast(v) for v in flat.min(axis=0)]
            acc.max = [cast(v) for v in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def build_gltf(comp, unit_m: float = 0.01, name: str = "mocapkit", rotations: str = "float") -> g.GLTF2:
    """A :class:`pygltflib.GLTF2` for a :class:`~mocapkit.pla.skeletal.SkeletalCompressed`; rotation keys
    as ``"float"`` or normalized ``"short"`` (module notes: worst-case error of each)."""
    if rotations not in ROTATION_FORMATS:
        raise InvalidParameterError(f"rotations must be one of {', '.join(ROTATION_FORMATS)}, got {rotations!r}")
    motion = comp.motion
    sk = motion.skeleton
    nodes: list[g.Node] = []
    for j in range(sk.n_joints):
        q = motion.rotations[0, j] / np.linalg.norm(motion.rotations[0, j])
        nodes.append(
            g.Node(
                name=sk.names[j],
                translation=[float(v) * unit_m for v in motion.translations[0, j]],
                rotation=[float(q[1]), float(q[2]), float(q[3]), float(q[0])],
                children=[],
            )
        )
    for e, (j, off) in enumerate(sk.end_sites):
        nodes.append(g.Node(name=f"{sk.names[j]}_end{e}", translation=[float(v) * unit_m for v in off]))
        nodes[j].children.append(len(nodes) - 1)
    for j in range(sk.n_joints):
        if sk.parents[j] >= 0:
            nodes[sk.parents[j]].children.append(j)
    for n in nodes:
        if not n.children:
            n.children = None
    blob = _Blob()
    samplers: list[g.AnimationSampler] = []
    channels: list[g.AnimationChannel] = []
    time_acc: dict[bytes, int] = {}

    def times_accessor(t: np.ndarray) -> int:
        key = np.asarray(t, dtype=np.float32).tobytes()
        if key not in time_acc:  # tracks with the same keyframe times share one input accessor
            time_acc[key] = blob.add(t, g.SCALAR, minmax=True)
        return time_acc[key]

    for j, c in sorted(comp.rotations.items()):
        q = c.values / np.linalg.norm(c.values, axis=1, keepdims=True)
        q = hemisphere_continuous(q)
        xyzw = np.concatenate([q[:, 1:], q[:, :1]], axis=1)
        out = blob.add(quantize_rotations(xyzw) if rotations == "short" else xyzw, g.VEC4, minmax=True)
        samplers.append(g.AnimationSampler(input=times_accessor(c.times), output=out, interpolation="LINEAR"))
        channels.append(
            g.AnimationChannel(sampler=len(samplers) - 1, target=g.AnimationChannelTarget(node=j, path="rotation"))
        )
    for j, c in sorted(comp.translations.items()):
        out = blob.add(c.values * unit_m, g.VEC3, minmax=True)
        samplers.append(g.AnimationSampler(input=times_accessor(c.times), output=out, interpolation="LINEAR"))
        channels.append(
            g.AnimationChannel(sampler=len(samplers) - 1, target=g.AnimationChannelTarget(node=j, path="translation"))
        )
    roots = [j for j in range(sk.n_joints) if sk.parents[j] < 0]
    extras = {EXTRAS_KEY: {
        "n_joints": sk.n_joints,
        "channels": [list(c) for c in sk.channels],
        "offsets": sk.offsets.tolist(),
        "t0": float(motion.times[0]),
        "frame_time": float(motion.frame_time),
        "n_frames": int(motion.n_frames),
        "unit_m": float(unit_m),
    }}
    gl = g.GLTF2(
        asset=g.Asset(version="2.0", generator="mocapkit"),
        scene=0,
        scenes=[g.Scene(name=name, nodes=roots)],
        nodes=nodes,
        animations=[g.Animation(name=name, samplers=samplers, channels=channels, extras=extras)] if channels else [],
        accessors=blob.accessors,
        bufferViews=blob.views,
        buffers=[g.Buffer(byteLength=len(blob.data))],
    )
    gl._blob = bytes(blob.data)  # kept for writing
    return gl


def gltf_bytes(comp, suffix: str = ".glb", unit_m: float = 0.01, name: str = "mocapkit",
               rotations: str = "float") -> bytes:
    """The bytes :func:`write_gltf` writes for ``suffix`` ``.glb`` or ``.gltf``."""
    suffix = suffix.lower()
    if suffix not in (".glb", ".gltf"):
        raise InvalidParameterError(f"a glTF file ends in .glb or .gltf, got {suffix!r}")
    gl = build_gltf(comp, unit_m=unit_m, name=name, rotations=rotations)
    data = gl._blob
    if suffix == ".glb":
        gl.set_binary_blob(data)
        return b"".join(gl.save_to_bytes())
    gl.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
    return gl.gltf_to_json().encode("utf-8")


def write_gltf(path: str | Path, comp, unit_m: float = 0.01, name: str = "mocapkit", rotations: str = "float",
               data: bytes | None = None) -> Path:
    """Write ``.glb`` or ``.gltf`` (chosen by the suffix) atomically, with the normal file mode.

    ``rotations``: ``"float"`` or ``"short"`` (normalized SHORT keys, module notes). ``data``: the bytes
    of :func:`gltf_bytes` for this suffix when the caller already built (and checked) them."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".glb", ".gltf"):
        raise InvalidParameterError(f"{path}: a glTF file ends in .glb or .gltf")
    if data is None:
        data = gltf_bytes(comp, suffix, unit_m=unit_m, name=name, rotations=rotations)
    if suffix == ".glb":
        atomic_write_bytes(path, data)
    else:
        atomic_write_text(path, data.decode("utf-8"))
    return path


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------
#
# The file is parsed here with the standard json module into plain dicts (not pygltflib's
# dataclasses: ~1 ms an object, minutes for a 10,000-joint clip) and every field is checked for its
# type and range before use: indices inside their arrays, buffer views and accessors inside the
# buffer, strides within the spec's 4..252, numbers finite and at most MAX_ABS, counts bounded by the
# buffer (so a hostile file cannot make the reader allocate or loop more than its own size).

_N_COMP: dict[Any, int] = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}  # looked up with any JSON value
_FLOAT = 5126
_GLB_JSON, _GLB_BIN = 0x4E4F534A, 0x004E4942
MAX_FILE_BYTES = 1 << 31  # a glTF file larger than 2 GiB is not a clip this reader decodes
MIN_UNIT_M, MAX_UNIT_M = 1e-9, 1e9
MIN_FRAME_TIME, MAX_FRAME_TIME = 1e-6, 1e6


class _Bad(Exception):
    """A structural problem; becomes MocapFormatError(src, None, message) at the top."""


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _finite_float(tok: str) -> float:
    v = float(tok)
    if not math.isfinite(v):
        raise ValueError(f"{tok} overflows a double")
    return v


def _json(raw: bytes | bytearray) -> dict:
    try:
        text = raw.decode("utf-8-sig")
        doc = json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float)
    except UnicodeDecodeError as exc:
        raise _Bad(f"the JSON is not UTF-8 (byte {exc.start})") from None
    except RecursionError:
        raise _Bad("the JSON is nested too deeply") from None
    except ValueError as exc:
        raise _Bad(f"not valid glTF JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise _Bad("the glTF JSON is not an object")
    return doc


def _glb(data: bytes | bytearray) -> tuple[dict, bytes | bytearray]:
    if len(data) < 20:
        raise _Bad("a GLB file needs a 12-byte header and a JSON chunk")
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise _Bad(f"GLB version {version} (only 2 is read)")
    if length > len(data):
        raise _Bad(f"the GLB header says {length} bytes but the file has {len(data)} (cut short?)")
    chunks: list[tuple[int, bytes | bytearray]] = []
    off = 12
    while off + 8 <= length:
        clen, ctype = struct.unpack_from("<II", data, off)
        if off + 8 + clen > length:
            raise _Bad(f"GLB chunk {len(chunks)} of {clen} bytes reaches past the end of the file")
        chunks.append((ctype, data[off + 8: off + 8 + clen]))
        off += 8 + clen
        if len(chunks) == 2:
            break
    if not chunks or chunks[0][0] != _GLB_JSON:
        raise _Bad("the first GLB chunk is not JSON")
    blob = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == _GLB_BIN else b""
    return _json(chunks[0][1]), blob


def _load(path: Path, data: bytes | bytearray | None = None) -> tuple[dict, bytes | bytearray]:
    """The JSON document and buffer 0 of ``path`` (or of its bytes ``data``, already read)."""
    from mocapkit.io.text.input import read_input

    src = str(path)
    if data is None:
        data = read_input(path, "glTF file", max_stream_bytes=MAX_FILE_BYTES, text=False)
    try:
        if data[:4] == b"glTF":
            return _glb(data)
        doc = _json(data)
        buffers = _list(doc, "buffers")
        uri = buffers[0].get("uri") if buffers and isinstance(buffers[0], dict) else None
        if uri is None:
            return doc, b""
        if not isinstance(uri, str):
            raise _Bad("buffer 0: uri is not a string")
        size = _int(buffers[0].get("byteLength"), "buffer 0: byteLength", 1, MAX_FILE_BYTES)
        if uri.startswith("data:"):
            return doc, _data_uri(uri, size)
        return doc, _buffer_file(path, uri, size)
    except _Bad as exc:
        raise MocapFormatError(src, None, str(exc)) from None


def _data_uri(uri: str, size: int) -> bytes:
    """The ``size`` bytes of a base64 data URI, refused unread when it is longer than ``size`` bytes
    (with up to 3 bytes of padding, as in a GLB chunk) need, or shorter once decoded."""
    head, sep, body = uri.partition(",")
    if not sep or not head.endswith(";base64"):
        raise _Bad("buffer 0: the data URI is not base64")
    if len(body) > 4 * ((size + 3 + 2) // 3):
        raise _Bad(f"buffer 0: the data URI holds {len(body):,} base64 characters, more than byteLength {size:,} needs")
    try:
        raw = base64.b64decode(body, validate=True)
    except ValueError:
        raise _Bad("buffer 0: the data URI is not base64") from None
    if len(raw) < size:
        raise _Bad(f"buffer 0: the data URI holds {len(raw):,} bytes, fewer than byteLength {size:,}")
    return raw[:size]


def buffer_file_path(gltf: str | Path, uri: object) -> Path | None:
    """The file a ``.gltf``'s buffer ``uri`` names, resolved as :func:`read_gltf` resolves it, or ``None``
    for a data URI or a URI the reader refuses (so never reads): what an output must not overwrite."""
    if not isinstance(uri, str) or uri.startswith("data:"):
        return None
    try:
        return _buffer_target(Path(gltf), uri)
    except _Bad:
        return None


def gltf_buffer_files(path: str | Path) -> list[Path]:
    """The existing files a ``.gltf`` names as buffers (:func:`buffer_file_path`): inputs read with it,
    which an output must not overwrite. ``[]`` for any other file, or one that does not parse (the
    reader reports it)."""
    p = Path(path)
    try:
        if p.suffix.lower() != ".gltf" or not p.is_file() or p.stat().st_size > MAX_FILE_BYTES:
            return []
        buffers = _json(p.read_bytes()).get("buffers")
    except (OSError, _Bad):
        return []
    found = (
        (buffer_file_path(p, b.get("uri")) for b in buffers if isinstance(b, dict)) if isinstance(buffers, list) else ()
    )
    return [f for f in found if f is not None and f.is_file()]


def _buffer_target(gltf: Path, uri: str) -> Path:
    from urllib.parse import unquote

    name = unquote(uri)
    shown = uri[:80]
    if not name or "\0" in name or re.match(r"[A-Za-z][A-Za-z0-9+.-]*:", name) or name.startswith(("/", "\\")):
        raise _Bad(f"buffer 0: uri {shown!r} is not a relative path to a file beside the glTF file")
    folder = gltf.parent.resolve()
    target = (folder / name).resolve()
    if not target.is_relative_to(folder):
        raise _Bad(f"buffer 0: uri {shown!r} leads out of the glTF file's folder ({target})")
    return target


def _buffer_file(gltf: Path, uri: str, size: int) -> bytes:
    """The first ``size`` bytes of the buffer file ``uri`` names: a relative path (percent-decoded) to a
    regular file inside the ``.gltf``'s folder (symlinks resolved), at least ``size`` bytes long. Nothing
    else is opened: no absolute path, no ``..`` or link out of the folder, no device, pipe or folder."""
    import os
    import stat

    shown = uri[:80]
    target = _buffer_target(gltf, uri)
    try:
        fd = os.open(target, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0))
    except OSError as exc:
        raise _Bad(f"buffer 0: cannot read {shown!r}: {exc.strerror or exc}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise _Bad(f"buffer 0: {shown!r} is not a regular file")
    with os.fdopen(fd, "rb") as fh:
        if st.st_size < size:
            raise _Bad(f"buffer 0: {shown!r} has {st.st_size:,} bytes, fewer than byteLength {size:,}")
        data = fh.read(size)
    if len(data) < size:
        raise _Bad(f"buffer 0: {shown!r} ends after {len(data):,} of byteLength {size:,} bytes")
    return data


def _list(d: dict, key: str) -> list:
    v = d.get(key, [])
    if not isinstance(v, list):
        raise _Bad(f"{key!r} is not an array")
    return v


def _obj(v, what: str) -> dict:
    if not isinstance(v, dict):
        raise _Bad(f"{what} is not an object")
    return v


def _int(v, what: str, lo: int = 0, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in {lo}..{hi}"
        raise _Bad(f"{what} must be an integer {rng}, got {str(v)[:40]}")
    return v


def _num(v, what: str, lo: float = -MAX_ABS, hi: float = MAX_ABS) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
        raise _Bad(f"{what} must be a number from {lo:g} to {hi:g}, got {str(v)[:40]}")
    return float(v)


def _vec(v, n: int, what: str, default) -> np.ndarray:
    if v is None:
        return np.asarray(default, dtype=np.float64)
    if not isinstance(v, list) or len(v) != n:
        raise _Bad(f"{what} must be {n} numbers")
    return np.array([_num(x, what) for x in v], dtype=np.float64)


# componentType -> (little-endian dtype, name, divisor of a normalized value, signed)
_COMPONENTS: dict[Any, tuple[str, str, float | None, bool]] = {
    5120: ("<i1", "BYTE", 127.0, True),
    5121: ("<u1", "UNSIGNED_BYTE", 255.0, False),
    5122: ("<i2", "SHORT", 32767.0, True),
    5123: ("<u2", "UNSIGNED_SHORT", 65535.0, False),
    5125: ("<u4", "UNSIGNED_INT", None, False),
    5126: ("<f4", "FLOAT", None, True),
}
#: (componentType, normalized) pairs the core spec allows for each use in an animation
_FLOAT_ONLY = frozenset({(_FLOAT, False)})
_ROTATION_OUTPUT = frozenset({(_FLOAT, False), (5120, True), (5121, True), (5122, True), (5123, True)})


def _accessor(doc: dict, blob: bytes | bytearray, i, what: str, allowed=_FLOAT_ONLY) -> tuple[np.ndarray, float | None]:
    """Accessor ``i`` (SCALAR/VEC3/VEC4) as ``(count, n)`` float64 and the divisor of its normalized
    integers (``None`` for FLOAT). Its componentType and ``normalized`` flag must be one of ``allowed``
    (pairs); normalized integers are decoded as the spec says (``max(c/127, -1)``, ``c/255``,
    ``max(c/32767, -1)``, ``c/65535``); float values must be finite and at most MAX_ABS. Alignment and
    bounds are checked against the view and the buffer before anything is read."""
    accessors, views = _list(doc, "accessors"), _list(doc, "bufferViews")
    i = _int(i, f"{what}: accessor index", 0, len(accessors) - 1)
    acc = _obj(accessors[i], f"accessor {i}")
    n = _N_COMP.get(acc.get("type"))
    ctype, norm = acc.get("componentType"), acc.get("normalized", False)
    if not isinstance(norm, bool):
        raise _Bad(f"accessor {i}: normalized must be true or false, got {str(norm)[:20]}")
    comp = _COMPONENTS.get(ctype) if isinstance(ctype, int) and not isinstance(ctype, bool) else None
    if n is None or comp is None or (ctype, norm) not in allowed:
        kinds = " or ".join(f"normalized {_COMPONENTS[c][1]}" if nm else _COMPONENTS[c][1] for c, nm in sorted(allowed))
        got = f"{_COMPONENTS[ctype][1]} ({ctype})" if comp is not None else str(ctype)[:20]
        raise _Bad(f"accessor {i} ({what}) is type {str(acc.get('type'))[:20]}, componentType {got}"
                   f"{', normalized' if norm else ''}; glTF allows here SCALAR/VEC3/VEC4 of {kinds}")
    if "sparse" in acc:
        raise _Bad(f"accessor {i}: sparse accessors are not read")
    dtype, _, scale, signed = comp
    size = np.dtype(dtype).itemsize
    vi = _int(acc.get("bufferView"), f"accessor {i}: bufferView", 0, len(views) - 1)
    view = _obj(views[vi], f"bufferView {vi}")
    _int(view.get("buffer", 0), f"bufferView {vi}: buffer", 0, 0)
    v_off = _int(view.get("byteOffset", 0), f"bufferView {vi}: byteOffset")
    v_len = _int(view.get("byteLength"), f"bufferView {vi}: byteLength")
    if v_off + v_len > len(blob):
        raise _Bad(f"bufferView {vi} ({v_len} bytes at {v_off}) reaches past the end of the {len(blob)}-byte buffer")
    elem = size * n
    stride = view.get("byteStride")
    stride = elem if stride is None else _int(stride, f"bufferView {vi}: byteStride", 4, 252)
    if stride % size or stride < elem:
        raise _Bad(f"bufferView {vi}: byteStride {stride} does not hold {n} {comp[1]} values "
                   f"(multiple of {size}, >= {elem})")
    a_off = _int(acc.get("byteOffset", 0), f"accessor {i}: byteOffset")
    count = _int(acc.get("count"), f"accessor {i}: count", 1)
    if a_off % size or (v_off + a_off) % size:
        raise _Bad(f"accessor {i}: byteOffset {a_off} is not a multiple of {size} (the {comp[1]} size)")
    if a_off + stride * (count - 1) + elem > v_len:
        raise _Bad(f"accessor {i}: {count} elements reach past the end of bufferView {vi} ({v_len} bytes)")
    start = v_off + a_off
    raw = np.frombuffer(blob, dtype=dtype, count=(stride * (count - 1) + elem) // size, offset=start)
    stored = raw.reshape(-1, n) if stride == elem else np.lib.stride_tricks.as_strided(
        raw, shape=(count, n), strides=(stride, size), writeable=False)
    stored = stored.astype(np.float64)
    if scale is None:
        bad = ~(np.abs(stored) <= MAX_ABS)
        if bad.any():
            k = int(np.flatnonzero(bad.any(axis=1))[0])
            raise _Bad(f"accessor {i} element {k}: {stored[k].tolist()} is not finite or larger than {MAX_ABS:g}")
    _check_min_max(acc, i, stored)  # min/max are the stored values, normalized or not (spec 3.6.2.5)
    if not norm:
        return stored, None
    out = stored / scale
    return (np.maximum(out, -1.0) if signed else out), scale


def _sample(key_t: np.ndarray, key_v: np.ndarray, t: np.ndarray, rotation: bool) -> np.ndarray:
    """glTF ``LINEAR`` sampling: SLERP for rotations, linear otherwise; held before/after the keys."""
    tc = np.clip(t, key_t[0], key_t[-1])
    if len(key_t) == 1:
        return np.repeat(normalize(key_v[:1]) if rotation else key_v[:1], len(t), axis=0)
    k = np.clip(np.searchsorted(key_t, tc, side="right") - 1, 0, len(key_t) - 2)
    f = (tc - key_t[k]) / (key_t[k + 1] - key_t[k])
    if rotation:
        return slerp(key_v[k], key_v[k + 1], f)
    return key_v[k] + f[:, None] * (key_v[k + 1] - key_v[k])


def read_gltf(path: str | Path, rate: float | None = None, data: bytes | bytearray | None = None) -> Motion:
    """Decode the first animation of a glTF file to a full-rate skeletal :class:`Motion`.

    A file written by :func:`write_gltf` is decoded at its original frame times, in its original length
    unit, with its joints' BVH channels. For other files, every node is a joint (rotation channels ZXY,
    plus position channels where a translation is animated), lengths stay in metres and ``rate`` (Hz)
    sets the frame grid from the first to the last keyframe.

    Every problem is a :class:`~mocapkit.errors.MocapFormatError` naming ``path``: malformed JSON or
    GLB chunks, indices out of range, accessors reaching past their buffer, NaN or huge values, node
    cycles or shared children; the work is linear in the file size (deep node chains included).
    ``data``: the file's bytes, decoded exactly as the file would be (a writer checking what it is
    about to write); ``path`` then only names it in messages (and locates an external buffer).
    """
    p = Path(path)
    src = str(p)
    if rate is not None:
        try:
            r = float(rate)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"rate must be a number of Hz, got {rate!r}") from None
        if not 1.0 / MAX_FRAME_TIME <= r <= 1.0 / MIN_FRAME_TIME:
            raise InvalidParameterError(
                f"rate must be between {1 / MAX_FRAME_TIME:g} and {1 / MIN_FRAME_TIME:g} Hz, got {rate!r}"
            )
        rate = r
    doc, blob = _load(p, data)
    try:
        return _decode(doc, blob, src, rate)
    except _Bad as exc:
        raise MocapFormatError(src, None, str(exc)) from None
    except (ValueError, IndexError, KeyError, TypeError, OverflowError) as exc:  # a check missed above
        raise MocapFormatError(src, None, f"malformed glTF content ({type(exc).__name__}: {exc})") from None


def _unit_like(q: np.ndarray, scale: float | None = None) -> bool:
    """Quaternions whose norm is 1 up to float32 storage and writer rounding (glTF requires unit ones);
    normalized integers with divisor ``scale`` may be off by their rounding too (``≤ 2·0.5/scale``)."""
    n = np.linalg.norm(q, axis=-1)
    return bool(np.all(np.abs(n - 1.0) < 1e-3 + (0.0 if scale is None else 1.0 / scale)))


def _check_size(n_frames: int, n_joints: int) -> None:
    if n_frames < 1 or n_frames * n_joints > MAX_VALUES:
        raise _Bad(f"{n_frames} frames × {n_joints} joints is not a clip this reader decodes "
                   f"(at least 1 frame, at most {MAX_VALUES:,} joint-frames)")


def _channels(v, j: int) -> tuple[str, ...]:
    """Joint ``j``'s BVH channels from the extras: distinct names, no rotation or exactly three
    rotation axes (X, Y and Z once each: an Euler order), each position axis at most once."""
    if not isinstance(v, list) or len(v) > 6 or not all(isinstance(c, str) and c in _VALID_CHANNELS for c in v) \
            or len(set(v)) != len(v):
        raise _Bad(f"extras channels of joint {j} must be distinct BVH channel names, got {str(v)[:60]}")
    n_rot = sum(c in ROTATION_CHANNELS for c in v)
    if n_rot not in (0, 3):
        raise _Bad(f"extras channels of joint {j} must hold no rotation or all three (Xrotation, Yrotation, "
                   f"Zrotation in some order), got {n_rot}: {str(v)[:80]}")
    return tuple(v)


_EXTRAS_FIELDS = ("n_joints", "channels", "offsets", "t0", "frame_time", "n_frames", "unit_m")


def _mocapkit_extras(anim: dict | None) -> dict | None:
    """The ``extras["mocapkit"]`` object of a file written by :func:`write_gltf` with every field it
    writes (a missing one means the file was damaged: no default could be right), or ``None``."""
    if anim is None:
        return None
    extras = _obj(anim.get("extras", {}), "animation extras")
    if EXTRAS_KEY not in extras:
        return None
    mk = _obj(extras[EXTRAS_KEY], f"extras {EXTRAS_KEY!r}")
    for key in _EXTRAS_FIELDS:
        if key not in mk:
            raise _Bad(f"extras {EXTRAS_KEY!r} has no {key!r} field (a file written by mocapkit has all of "
                       f"{', '.join(_EXTRAS_FIELDS)})")
    return mk


def _scene_roots(doc: dict, parents: np.ndarray) -> None:
    """A file written here lists exactly its parentless nodes as the scene's roots: a node cut from its
    parent's ``children`` (a joint or an end site dropped out of the hierarchy) is an error."""
    scenes = _list(doc, "scenes")
    si = _int(doc.get("scene", 0), "scene", 0, max(len(scenes) - 1, 0))
    if not scenes:
        raise _Bad("no scenes: a file written by mocapkit has one")
    listed = _list(_obj(scenes[si], f"scene {si}"), "nodes")
    roots = [int(i) for i in np.flatnonzero(parents < 0)]
    if sorted(_int(n, f"scene {si}: node", 0, len(parents) - 1) for n in listed) != roots:
        raise _Bad(f"scene {si} lists root nodes {str(listed)[:60]} but the nodes without a parent are "
                   f"{str(roots)[:60]}: the hierarchy is damaged")


def _check_min_max(acc: dict, i: int, out: np.ndarray) -> None:
    """``min``/``max`` of an accessor, when given, must be the values' (glTF requires them exact; a
    mismatch means the accessor reads the wrong bytes)."""
    for key, got in (("min", out.min(axis=0)), ("max", out.max(axis=0))):
        if key not in acc:
            continue
        v = acc[key]
        if not isinstance(v, list) or len(v) != out.shape[1]:
            raise _Bad(f"accessor {i}: {key} must be {out.shape[1]} numbers")
        want = np.array([_num(x, f"accessor {i}: {key}") for x in v])
        if not np.all(np.abs(want - got) <= 1e-6 * np.maximum(1.0, np.abs(got))):
            raise _Bad(f"accessor {i}: {key} {want.tolist()[:4]} differs from its values' {got.tolist()[:4]} "
                       "(the accessor or its bufferView is damaged)")


def _check_channels_hold_motion(chans, offsets: np.ndarray, rot: np.ndarray, trans: np.ndarray,
                                names, tracks: dict) -> None:
    """The extras' channels agree with the animation, as :func:`write_gltf` writes them: a joint has a
    rotation track exactly when it has rotation channels and a translation track exactly when it has
    position channels. What BVH cannot write must not move: a joint without rotation channels keeps the
    identity rotation and an axis without a position channel keeps its offset (else writing the BVH
    channels would drop motion silently)."""
    for j, ch in enumerate(chans):
        for kind, listed in (("rotation", any(c in ROTATION_CHANNELS for c in ch)),
                             ("translation", any(c in POSITION_CHANNELS for c in ch))):
            if listed != ((j, kind) in tracks):
                raise _Bad(f"joint {names[j]!r}: the extras list {'' if listed else 'no '}{kind} channels "
                           f"({', '.join(ch) or 'none'}) but the animation has {'no ' if listed else 'a '}"
                           f"{kind} track for it")
        if not any(c in ROTATION_CHANNELS for c in ch) and not np.all(np.abs(rot[:, j, 0]) >= 1.0 - 1e-6):
            raise _Bad(f"joint {names[j]!r} has no rotation channels in the extras but its rotation is animated")
        for a, axis in enumerate("XYZ"):
            if f"{axis}position" not in ch:
                dev = np.abs(trans[:, j, a] - offsets[j, a])
                if not np.all(dev <= 1e-5 * max(1.0, abs(offsets[j, a]))):
                    raise _Bad(f"joint {names[j]!r} has no {axis}position channel in the extras but its {axis} "
                               f"translation differs from its offset by up to {dev.max():g}")


def _decode(doc: dict, blob: bytes | bytearray, src: str, rate: float | None) -> Motion:
    nodes = _list(doc, "nodes")
    if not nodes:
        raise _Bad("no nodes: not a skeletal glTF file")
    nodes = [_obj(n, f"node {i}") for i, n in enumerate(nodes)]
    anims = _list(doc, "animations")
    anim = _obj(anims[0], "animation 0") if anims else None
    mk = _mocapkit_extras(anim)  # a file written by write_gltf: every field checked, none defaulted
    extras = mk if mk is not None else {}
    n_nodes = _int(extras.get("n_joints", len(nodes)), "extras n_joints", 1)
    if n_nodes > len(nodes):
        raise _Bad(f"extras say {n_nodes} joints but the file has {len(nodes)} nodes")
    parents = np.full(len(nodes), -1, dtype=np.int64)
    children: list[list[int]] = []
    for i, node in enumerate(nodes):
        kids = _list(node, "children")
        for c in kids:
            c = _int(c, f"node {i}: child", 0, len(nodes) - 1)
            if parents[c] != -1 or c == i:
                raise _Bad(f"node {i} has an invalid or shared child {c}")
            parents[c] = i
        children.append(kids)
    # joints in topological order (parents first), end sites (extra nodes) kept as BVH end sites
    order: list[int] = []
    stack = [i for i in range(n_nodes - 1, -1, -1) if parents[i] < 0]
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(c for c in reversed(children[i]) if c < n_nodes)
    if len(order) != n_nodes:
        raise _Bad("the node hierarchy has a cycle (or a joint hangs below a non-joint node)")
    if mk is not None:
        _scene_roots(doc, parents)
    new = {old: k for k, old in enumerate(order)}
    unit_m = _num(extras.get("unit_m", 1.0), "extras unit_m", MIN_UNIT_M, MAX_UNIT_M)

    def scaled(v, what):
        a = v / unit_m
        if not np.all(np.abs(a) <= MAX_ABS):
            raise _Bad(f"{what}: {v.tolist()} m is larger than {MAX_ABS:g} file units")
        return a

    rest_t = np.array([scaled(_vec(nodes[o].get("translation"), 3, f"node {o}: translation", [0, 0, 0]),
                              f"node {o}: translation") for o in order]).reshape(-1, 3)
    rest_q = np.array([_vec(nodes[o].get("rotation"), 4, f"node {o}: rotation", [0, 0, 0, 1])[[3, 0, 1, 2]]
                       for o in order]).reshape(-1, 4)
    if not _unit_like(rest_q):
        raise _Bad("a node rotation is not a unit quaternion (glTF requires one)")
    tracks: dict[tuple[int, str], tuple[np.ndarray, np.ndarray]] = {}
    if anim is not None:
        samplers = _list(anim, "samplers")
        for ci, ch in enumerate(_list(anim, "channels")):
            ch = _obj(ch, f"animation channel {ci}")
            target = _obj(ch.get("target"), f"animation channel {ci}: target")
            node, kind = target.get("node"), target.get("path")
            if mk is not None and (kind not in ("rotation", "translation") or not isinstance(node, int)
                                   or isinstance(node, bool) or not 0 <= node < n_nodes):
                raise _Bad(f"animation channel {ci}: a mocapkit file animates the rotation or translation of a "
                           f"joint node (0..{n_nodes - 1}), got path {str(kind)[:20]}, node {str(node)[:20]}")
            if kind not in ("rotation", "translation") or node is None:
                continue
            node = _int(node, f"animation channel {ci}: target node", 0, len(nodes) - 1)
            if node not in new:
                continue
            if (new[node], kind) in tracks:
                raise _Bad(f"animation channel {ci}: node {node} {kind} is animated twice (glTF allows a target once)")
            si = _int(ch.get("sampler"), f"animation channel {ci}: sampler", 0, len(samplers) - 1)
            smp = _obj(samplers[si], f"sampler {si}")
            if smp.get("interpolation", "LINEAR") != "LINEAR":
                raise _Bad(f"sampler {si}: only LINEAR interpolation is read, got {str(smp.get('interpolation'))[:20]}")
            kt = _accessor(doc, blob, smp.get("input"), f"sampler {si} input")[0]
            if kt.shape[1] != 1:
                raise _Bad(f"sampler {si}: key times must be SCALAR")
            kt = kt[:, 0]
            kv, scale = _accessor(doc, blob, smp.get("output"), f"sampler {si} {kind} output",
                                  _ROTATION_OUTPUT if kind == "rotation" else _FLOAT_ONLY)
            if len(kt) != len(kv) or np.any(np.diff(kt) <= 0):
                raise _Bad(f"sampler {si}: key times must increase and match the values")
            if kind == "rotation":
                if kv.shape[1] != 4:
                    raise _Bad(f"sampler {si}: rotation keys must be VEC4")
                kv = kv[:, [3, 0, 1, 2]]
                if not _unit_like(kv, scale):
                    raise _Bad(f"sampler {si}: a key is not a unit quaternion")
            else:
                if kv.shape[1] != 3:
                    raise _Bad(f"sampler {si}: translation keys must be VEC3")
                kv = scaled(kv, f"sampler {si} output")
            tracks[(new[node], kind)] = (kt, kv)
    if "frame_time" in extras and "n_frames" in extras:
        if rate is not None:
            raise InvalidParameterError(f"{src} records its own frame times; do not give a rate")
        ft = _num(extras["frame_time"], "extras frame_time", MIN_FRAME_TIME, MAX_FRAME_TIME)
        n = _int(extras["n_frames"], "extras n_frames", 1)
        _check_size(n, n_nodes)
        t0 = _num(extras.get("t0", 0.0), "extras t0")
        times = t0 + ft * np.arange(n, dtype=np.float64)
    else:
        if rate is None:
            raise InvalidParameterError(f"{src} has no mocapkit frame times: give the frame rate (--rate HZ)")
        if not tracks:
            raise _Bad("no rotation or translation animation to decode")
        t0 = min(float(kt[0]) for kt, _ in tracks.values())
        t1 = max(float(kt[-1]) for kt, _ in tracks.values())
        ft = 1.0 / rate
        span = (t1 - t0) / ft
        if not span < MAX_VALUES:
            raise _Bad(f"keyframes over {t1 - t0:g} s at {rate:g} Hz are more frames than this reader decodes")
        n = int(math.floor(span + 1e-3)) + 1  # float32 key times end a hair before the last frame
        _check_size(n, n_nodes)
        times = t0 + ft * np.arange(n, dtype=np.float64)
    J, N = n_nodes, len(times)
    rot = np.broadcast_to(normalize(rest_q)[None], (N, J, 4)).copy()
    trans = np.broadcast_to(rest_t[None], (N, J, 3)).copy()
    for (j, kind), (kt, kv) in tracks.items():
        if kind == "rotation":
            rot[:, j] = _sample(kt, kv, times, True)
        else:
            trans[:, j] = _sample(kt, kv, times, False)
    names = []
    for o in order:
        if mk is not None and "name" not in nodes[o]:
            raise _Bad(f"node {o}: no name (a file written by mocapkit names every joint)")
        nm = nodes[o].get("name", f"joint{o}")
        if not isinstance(nm, str):
            raise _Bad(f"node {o}: name is not a string")
        if mk is not None and (not nm or any(ch.isspace() or ch in "{}" or not ch.isprintable() for ch in nm)):
            raise _Bad(f"node {o}: name {nm[:40]!r} is not a joint name (empty, or holds blanks or braces)")
        names.append(nm or f"joint{o}")
    if "channels" in extras:
        ch_list = extras["channels"]
        if not isinstance(ch_list, list) or len(ch_list) != n_nodes:
            raise _Bad(f"extras channels must list the channels of the {n_nodes} joints, "
                       f"got {len(ch_list) if isinstance(ch_list, list) else type(ch_list).__name__}")
        chans = [_channels(ch_list[o], o) for o in order]
    else:
        chans = [(("Xposition", "Yposition", "Zposition") if (j, "translation") in tracks else ())
                 + ("Zrotation", "Xrotation", "Yrotation") for j in range(J)]
    end_sites = []
    for o in order:
        for c in children[o]:
            if c >= n_nodes:
                off = scaled(_vec(nodes[c].get("translation"), 3, f"node {c}: translation", [0, 0, 0]),
                             f"node {c}: translation")
                x, y, z = (float(v) for v in off)
                end_sites.append((new[o], (x, y, z)))
    offsets = rest_t
    if "offsets" in extras:
        off_list = extras["offsets"]
        if not isinstance(off_list, list) or len(off_list) != n_nodes:
            raise _Bad(f"extras offsets must list the offsets of the {n_nodes} joints, "
                       f"got {len(off_list) if isinstance(off_list, list) else type(off_list).__name__}")
        offsets = np.array([_vec([] if off_list[o] is None else off_list[o], 3, f"extras offsets of joint {o}",
                                 None) for o in order]).reshape(-1, 3)
    if mk is not None:
        _check_channels_hold_motion(chans, offsets, rot, trans, names, tracks)
    try:
        sk = Skeleton(tuple(names), np.array([new[parents[o]] if parents[o] >= 0 else -1 for o in order]),
                      offsets, tuple(chans), tuple(end_sites),
                      meta={"length_unit_cm": 100.0 * unit_m})
        return Motion(sk, times, rot, trans, channel_values=None, source=src, meta={"frame_time": ft})
    except MocapError as exc:
        raise _Bad(f"inconsistent skeleton: {exc}") from None
