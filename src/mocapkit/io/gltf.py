"""glTF 2.0 export of compressed skeletal animation (via pygltflib).

One node per joint (its rest offset as the node translation, children as in the skeleton, plus a node
per end site), one animation with, per animated joint, a rotation channel with its own keyframe times
(``LINEAR``, which glTF defines as spherical linear interpolation for rotations) and, for joints whose
position is animated, a translation channel. Keyframe quaternions are normalised, reordered to glTF's
``(x, y, z, w)`` and made hemisphere-continuous, so a player that does not take the shortest arc gives
the same result. Lengths are converted to metres (glTF's unit) with ``unit_m`` metres per file unit.
``.glb`` (binary) or ``.gltf`` (JSON with the buffer embedded as a data URI) by the suffix.
"""

from __future__ import annotations

import base64
import os
import tempfile
from pathlib import Path

import numpy as np
import pygltflib as g

from mocapkit.errors import InvalidParameterError
from mocapkit.quat import hemisphere_continuous


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
    gl = g.GLTF2(
        asset=g.Asset(version="2.0", generator="mocapkit"),
        scene=0,
        scenes=[g.Scene(name=name, nodes=roots)],
        nodes=nodes,
        animations=[g.Animation(name=name, samplers=samplers, channels=channels)] if channels else [],
        accessors=blob.accessors,
        bufferViews=blob.views,
        buffers=[g.Buffer(byteLength=len(blob.data))],
    )
    gl._blob = bytes(blob.data)  # kept for writing
    return gl


def write_gltf(path: str | Path, comp, unit_m: float = 0.01, name: str = "mocapkit") -> Path:
    """Write ``.glb`` or ``.gltf`` (chosen by the suffix) atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".glb", ".gltf"):
        raise InvalidParameterError(f"{path}: a glTF file ends in .glb or .gltf")
    gl = build_gltf(comp, unit_m=unit_m, name=name)
    data = gl._blob
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=folder)
    os.close(fd)
    try:
        if suffix == ".glb":
            gl.set_binary_blob(data)
            gl.save_binary(tmp)
        else:
            gl.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
            gl.save_json(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
