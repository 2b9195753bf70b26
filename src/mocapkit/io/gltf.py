"""glTF 2.0 export of compressed skeletal animation (via pygltflib).

One node per joint (its rest offset as the node translation, children as in the skeleton, plus a node
per end site), one animation with, per animated joint, a rotation channel with its own keyframe times
(``LINEAR``, which glTF defines as spherical linear interpolation for rotations) and, for joints whose
position is animated, a translation channel. Keyframe quaternions are normalised, reordered to glTF's
``(x, y, z, w)`` and made hemisphere-continuous, so a player that does not take the shortest arc gives
the same result. Lengths are converted to metres (glTF's unit) with ``unit_m`` metres per file unit.
``.glb`` (binary) or ``.gltf`` (JSON with the buffer embedded as a data URI) by the suffix.

The animation's ``extras["mocapkit"]`` keeps what glTF has no place for (frame times, the BVH channels of
every joint, the number of joint nodes, the length unit), so :func:`read_gltf` decodes a file written here
back to the full-rate motion exactly as :meth:`SkeletalCompressed.decode` does (up to float32). Other glTF
files are read too: every node is a joint, the frame rate is given by the caller.
"""

from __future__ import annotations

import base64
import math
from pathlib import Path

import numpy as np
import pygltflib as g

from mocapkit.errors import InvalidParameterError, MocapFormatError
from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text, read_file_bytes
from mocapkit.quat import hemisphere_continuous, normalize, slerp
from mocapkit.skeleton import Motion, Skeleton

EXTRAS_KEY = "mocapkit"
MAX_VALUES = 20_000_000  # joint-frames decoded at most (~1.1 GB as float64 rotations + translations)


class _Blob:
    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[g.BufferView] = []
        self.accessors: list[g.Accessor] = []

    def add(self, arr: np.ndarray, type_: str, minmax: bool = False) -> int:
        a = np.ascontiguousarray(arr, dtype=np.float32)
        while len(self.data) % 4:
            self.data.append(0)
        off = len(self.data)
        self.data.extend(a.tobytes())
        self.views.append(g.BufferView(buffer=0, byteOffset=off, byteLength=a.nbytes))
        acc = g.Accessor(
            bufferView=len(self.views) - 1,
            componentType=g.FLOAT,
            count=int(a.shape[0]),
            type=type_,
        )
        if minmax:
            flat = a.reshape(a.shape[0], -1)
            acc.min = [float(v) for v in flat.min(axis=0)]
            acc.max = [float(v) for v in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def build_gltf(comp, unit_m: float = 0.01, name: str = "mocapkit") -> g.GLTF2:
    """A :class:`pygltflib.GLTF2` for a :class:`~mocapkit.pla.skeletal.SkeletalCompressed`."""
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
        out = blob.add(np.concatenate([q[:, 1:], q[:, :1]], axis=1), g.VEC4)
        samplers.append(g.AnimationSampler(input=times_accessor(c.times), output=out, interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1, target=g.AnimationChannelTarget(node=j, path="rotation")))
    for j, c in sorted(comp.translations.items()):
        out = blob.add(c.values * unit_m, g.VEC3)
        samplers.append(g.AnimationSampler(input=times_accessor(c.times), output=out, interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1, target=g.AnimationChannelTarget(node=j, path="translation")))
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


def write_gltf(path: str | Path, comp, unit_m: float = 0.01, name: str = "mocapkit") -> Path:
    """Write ``.glb`` or ``.gltf`` (chosen by the suffix) atomically, with the normal file mode."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".glb", ".gltf"):
        raise InvalidParameterError(f"{path}: a glTF file ends in .glb or .gltf")
    gl = build_gltf(comp, unit_m=unit_m, name=name)
    data = gl._blob
    if suffix == ".glb":
        gl.set_binary_blob(data)
        atomic_write_bytes(path, b"".join(gl.save_to_bytes()))
    else:
        gl.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
        atomic_write_text(path, gl.gltf_to_json())
    return path


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------

_N_COMP = {g.SCALAR: 1, g.VEC3: 3, g.VEC4: 4}


def _load(path: Path) -> tuple[g.GLTF2, bytes]:
    src = str(path)
    data = read_file_bytes(path, "glTF file")
    try:
        if data[:4] == b"glTF":
            gl = g.GLTF2.load_from_bytes(data)
            blob = gl.binary_blob() or b""
        else:
            gl = g.GLTF2.gltf_from_json(data.decode("utf-8"))
            uri = gl.buffers[0].uri if gl.buffers else None
            if uri is None:
                blob = b""
            elif uri.startswith("data:"):
                blob = base64.b64decode(uri.split(",", 1)[1])
            else:
                blob = read_file_bytes(path.parent / uri, "glTF buffer")
    except MocapFormatError:
        raise
    except Exception as exc:  # pygltflib raises many kinds on malformed input
        raise MocapFormatError(src, None, f"not a readable glTF file ({type(exc).__name__}: {exc})") from None
    return gl, blob


def _acc_view(acc: g.Accessor) -> int:
    return -1 if acc.bufferView is None else int(acc.bufferView)


def _accessor(gl: g.GLTF2, blob: bytes, i: int, src: str) -> np.ndarray:
    try:
        if not (0 <= i < len(gl.accessors)) or not (0 <= _acc_view(gl.accessors[i]) < len(gl.bufferViews)):
            raise IndexError(i)
        acc = gl.accessors[i]
        view = gl.bufferViews[acc.bufferView]
        n = _N_COMP[acc.type]
    except (IndexError, KeyError, TypeError):
        raise MocapFormatError(src, None, f"accessor {i} is missing or not a float SCALAR/VEC3/VEC4") from None
    if acc.componentType != g.FLOAT:
        raise MocapFormatError(src, None, f"accessor {i}: only FLOAT components are read (got {acc.componentType})")
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    stride = view.byteStride or 4 * n
    end = start + stride * (acc.count - 1) + 4 * n
    if acc.count < 1 or end > len(blob):
        raise MocapFormatError(src, None, f"accessor {i} reaches past the end of the buffer")
    raw = np.frombuffer(blob, dtype="<f4", count=(end - start) // 4, offset=start)
    if stride == 4 * n:
        out = raw.reshape(acc.count, n)
    else:
        out = np.lib.stride_tricks.as_strided(raw, shape=(acc.count, n), strides=(stride, 4))
    out = out.astype(np.float64)
    if not np.all(np.isfinite(out)):
        raise MocapFormatError(src, None, f"accessor {i} holds NaN or infinite values")
    return out


def _sample(key_t: np.ndarray, key_v: np.ndarray, t: np.ndarray, rotation: bool) -> np.ndarray:
    """glTF ``LINEAR`` sampling: SLERP for rotations, linear otherwise; held before/after the keys."""
    tc = np.clip(t, key_t[0], key_t[-1])
    if len(key_t) == 1:
        return np.repeat(key_v[:1], len(t), axis=0)
    k = np.clip(np.searchsorted(key_t, tc, side="right") - 1, 0, len(key_t) - 2)
    f = (tc - key_t[k]) / (key_t[k + 1] - key_t[k])
    if rotation:
        return slerp(key_v[k], key_v[k + 1], f)
    return key_v[k] + f[:, None] * (key_v[k + 1] - key_v[k])


def read_gltf(path: str | Path, rate: float | None = None) -> Motion:
    """Decode the first animation of a glTF file to a full-rate skeletal :class:`Motion`.

    A file written by :func:`write_gltf` is decoded at its original frame times, in its original length
    unit, with its joints' BVH channels. For other files, every node is a joint (rotation channels ZXY,
    plus position channels where a translation is animated), lengths stay in metres and ``rate`` (Hz)
    sets the frame grid from the first to the last keyframe.
    """
    p = Path(path)
    src = str(p)
    gl, blob = _load(p)
    try:
        return _decode(gl, blob, src, rate)
    except (MocapFormatError, InvalidParameterError):
        raise
    except (ValueError, IndexError, KeyError, TypeError, AttributeError, OverflowError) as exc:
        # a structure pygltflib accepted but that is not a consistent animation (wrong lengths, types)
        raise MocapFormatError(src, None, f"malformed glTF content ({type(exc).__name__}: {exc})") from None


def _unit_like(q: np.ndarray) -> bool:
    """Quaternions whose norm is 1 up to float32 storage and writer rounding (glTF requires unit ones)."""
    with np.errstate(over="ignore", invalid="ignore"):
        n = np.linalg.norm(q, axis=-1)
    return bool(np.all(np.abs(n - 1.0) < 1e-3))


def _check_size(n_frames: int, n_joints: int, src: str) -> None:
    if n_frames < 1 or n_frames * n_joints > MAX_VALUES:
        raise MocapFormatError(src, None, f"{n_frames} frames × {n_joints} joints is not a clip this reader decodes "
                               f"(at least 1 frame, at most {MAX_VALUES:,} joint-frames)")


def _decode(gl: g.GLTF2, blob: bytes, src: str, rate: float | None) -> Motion:
    if not gl.nodes:
        raise MocapFormatError(src, None, "no nodes: not a skeletal glTF file")
    anim = gl.animations[0] if gl.animations else None
    extras = ((anim.extras or {}) if anim is not None else {}).get(EXTRAS_KEY) or {}
    n_nodes = int(extras.get("n_joints", len(gl.nodes)))
    if not (1 <= n_nodes <= len(gl.nodes)):
        raise MocapFormatError(src, None, f"extras say {n_nodes} joints but the file has {len(gl.nodes)} nodes")
    parents = np.full(len(gl.nodes), -1, dtype=np.int64)
    for i, node in enumerate(gl.nodes):
        for c in node.children or []:
            if not (0 <= c < len(gl.nodes)) or parents[c] != -1 or c == i:
                raise MocapFormatError(src, None, f"node {i} has an invalid or shared child {c}")
            parents[c] = i
    # joints in topological order (parents first), end sites (extra nodes) kept as BVH end sites
    order: list[int] = []
    roots = [i for i in range(n_nodes) if parents[i] < 0]
    stack = list(reversed(roots))
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed([c for c in (gl.nodes[i].children or []) if c < n_nodes]))
    if len(order) != n_nodes:
        raise MocapFormatError(src, None, "the node hierarchy has a cycle")
    new = {old: k for k, old in enumerate(order)}
    unit_m = float(extras.get("unit_m", 1.0))
    if not (math.isfinite(unit_m) and unit_m > 0):
        raise MocapFormatError(src, None, f"extras unit_m {unit_m!r} is not a positive number")

    def vec(v, default):
        a = np.asarray(v if v is not None else default, dtype=np.float64)
        if a.shape != (len(default),):
            raise MocapFormatError(src, None, f"a node vector has {a.size} numbers, expected {len(default)}")
        if not np.all(np.isfinite(a)):
            raise MocapFormatError(src, None, "a node holds NaN or infinite values")
        return a

    rest_t = np.array([vec(gl.nodes[o].translation, [0, 0, 0]) / unit_m for o in order])
    rest_q = np.array([vec(gl.nodes[o].rotation, [0, 0, 0, 1])[[3, 0, 1, 2]] for o in order])
    if not _unit_like(rest_q):
        raise MocapFormatError(src, None, "a node rotation is not a unit quaternion (glTF requires one)")
    tracks: dict[tuple[int, str], tuple[np.ndarray, np.ndarray]] = {}
    for ch in (anim.channels if anim is not None else []):
        node, kind = ch.target.node, ch.target.path
        if kind not in ("rotation", "translation") or node is None or node not in new:
            continue
        if not (isinstance(ch.sampler, int) and 0 <= ch.sampler < len(anim.samplers)):
            raise MocapFormatError(src, None, f"a channel names sampler {ch.sampler!r}, which does not exist")
        smp = anim.samplers[ch.sampler]
        if (smp.interpolation or "LINEAR") != "LINEAR":
            raise MocapFormatError(src, None, f"sampler {ch.sampler}: only LINEAR interpolation is read, got {smp.interpolation}")
        kt = _accessor(gl, blob, smp.input, src)[:, 0]
        kv = _accessor(gl, blob, smp.output, src)
        if len(kt) != len(kv) or np.any(np.diff(kt) <= 0):
            raise MocapFormatError(src, None, f"sampler {ch.sampler}: key times must increase and match the values")
        if kind == "rotation":
            kv = kv[:, [3, 0, 1, 2]]
            if not _unit_like(kv):
                raise MocapFormatError(src, None, f"sampler {ch.sampler}: a key is not a unit quaternion")
        else:
            kv = kv / unit_m
        tracks[(new[node], kind)] = (kt, kv)
    if "frame_time" in extras and "n_frames" in extras:
        if rate is not None:
            raise InvalidParameterError(f"{src} records its own frame times; do not give a rate")
        ft, n = float(extras["frame_time"]), int(extras["n_frames"])
        _check_size(n, n_nodes, src)
        if not (math.isfinite(ft) and ft > 0):
            raise MocapFormatError(src, None, f"extras frame_time {ft!r} is not a positive number")
        times = float(extras.get("t0", 0.0)) + ft * np.arange(n)
    else:
        if rate is None:
            raise InvalidParameterError(f"{src} has no mocapkit frame times: give the frame rate (--rate HZ)")
        if not tracks:
            raise MocapFormatError(src, None, "no rotation or translation animation to decode")
        t0 = min(float(kt[0]) for kt, _ in tracks.values())
        t1 = max(float(kt[-1]) for kt, _ in tracks.values())
        ft = 1.0 / float(rate)
        n = int(math.floor((t1 - t0) / ft + 1e-9)) + 1
        _check_size(n, n_nodes, src)
        times = t0 + ft * np.arange(n)
    J, N = n_nodes, len(times)
    rot = np.broadcast_to(normalize(rest_q)[None], (N, J, 4)).copy()
    trans = np.broadcast_to(rest_t[None], (N, J, 3)).copy()
    for (j, kind), (kt, kv) in tracks.items():
        if kind == "rotation":
            rot[:, j] = _sample(kt, kv, times, True)
        else:
            trans[:, j] = _sample(kt, kv, times, False)
    names = [gl.nodes[o].name or f"joint{o}" for o in order]
    if "channels" in extras:
        chans = [tuple(extras["channels"][o]) for o in order]
    else:
        chans = [(("Xposition", "Yposition", "Zposition") if (j, "translation") in tracks else ())
                 + ("Zrotation", "Xrotation", "Yrotation") for j in range(J)]
    end_sites = []
    for o in order:
        for c in gl.nodes[o].children or []:
            if c >= n_nodes:
                end_sites.append((new[o], tuple(float(v) for v in vec(gl.nodes[c].translation, [0, 0, 0]) / unit_m)))
    offsets = rest_t
    if "offsets" in extras:
        offsets = np.array([vec(extras["offsets"][o], [0, 0, 0]) for o in order])
    try:
        sk = Skeleton(tuple(names), np.array([new[parents[o]] if parents[o] >= 0 else -1 for o in order]),
                      offsets, tuple(chans), tuple(end_sites),
                      meta={"length_unit_cm": 100.0 * unit_m})
        return Motion(sk, times, rot, trans, channel_values=None, source=src, meta={"frame_time": ft})
    except Exception as exc:
        raise MocapFormatError(src, None, f"inconsistent skeleton: {exc}") from None
