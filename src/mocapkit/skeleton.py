"""Skeletons and skeletal motion; forward kinematics vectorised over all frames.

Nothing here recurses over the hierarchy: helpers walk the joints in index order (parents come
first) or with an explicit stack, so a chain of any depth (10,000 joints and more) works.

A :class:`Skeleton` is a list of joints in topological order (every parent before its children;
``parents[j] = -1`` for a root; several roots are allowed). A :class:`Motion` holds, per frame and
joint, the *local* rotation (scalar-first unit quaternion) and the *local* translation relative to
the parent (the joint's ``OFFSET`` unless the file animates its position).

Forward kinematics (:func:`forward_kinematics`) loops over the joints only — every operation is a
NumPy batch over all frames — and returns world positions and world rotations of every joint (and,
optionally, of the end sites).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, overload

import numpy as np
from numpy.typing import NDArray

from mocapkit.errors import InvalidSignalError

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")

#: Joint-frames a reader builds at most when the file does not hold a value for each of them (a
#: joint-frame takes 56 bytes as rotation + translation: 20 million is 1.1 GB). Files with at least
#: one channel value per joint-frame are bounded by their own size instead.
MAX_JOINT_FRAMES = 20_000_000


@dataclass(frozen=True)
class Skeleton:
    """Joint hierarchy.

    Attributes
    ----------
    names
        Joint names (unique).
    parents
        ``(J,)`` parent index, ``-1`` for roots; ``parents[j] < j``.
    offsets
        ``(J, 3)`` rest translation of each joint relative to its parent (file units).
    channels
        Per joint, the animated channels in file order (BVH names: ``Xposition``.. ``Zrotation``);
        ``()`` for a joint without channels.
    end_sites
        ``(parent_joint, offset (3,))`` pairs for BVH ``End Site`` blocks (and ASF bone tips).
    """

    names: tuple[str, ...]
    parents: NDArray[np.int64]
    offsets: NDArray[np.float64]
    channels: tuple[tuple[str, ...], ...]
    end_sites: tuple[tuple[int, tuple[float, float, float]], ...] = ()
    meta: dict[str, Any] = field(default_factory=dict, compare=False)
    _index: dict[str, int] = field(init=False, repr=False, compare=False)  # name -> joint, set in __post_init__

    def __post_init__(self) -> None:
        p = np.asarray(self.parents, dtype=np.int64)
        o = np.asarray(self.offsets, dtype=np.float64).reshape(-1, 3)
        J = len(self.names)
        if p.shape != (J,) or o.shape != (J, 3) or len(self.channels) != J:
            raise InvalidSignalError(f"skeleton arrays disagree: {J} names, parents {p.shape}, offsets {o.shape}")
        index = {n: j for j, n in enumerate(self.names)}
        if len(index) != J:
            dup = sorted({n for j, n in enumerate(self.names) if index[n] != j})
            raise InvalidSignalError(f"duplicate joint names: {dup[:10]}")
        bad = np.flatnonzero((p < -1) | (p >= np.arange(J)))
        if bad.size:
            j = int(bad[0])
            raise InvalidSignalError(f"joint {self.names[j]!r}: parent index {p[j]} is not an earlier joint")
        if not np.all(np.isfinite(o)):
            j = int(np.flatnonzero(~np.isfinite(o).all(axis=1))[0])
            raise InvalidSignalError(f"joint {self.names[j]!r}: offset {o[j].tolist()} is not finite")
        p.setflags(write=False)
        o.setflags(write=False)
        object.__setattr__(self, "parents", p)
        object.__setattr__(self, "offsets", o)
        object.__setattr__(self, "_index", index)

    @property
    def n_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"no joint named {name!r}") from None

    def children(self, j: int) -> list[int]:
        """Joints whose parent is ``j``, in index order."""
        kids: list[int] = np.flatnonzero(self.parents == j).tolist()
        return kids

    def children_lists(self) -> list[list[int]]:
        """``children_lists()[j]`` = :meth:`children` of ``j`` for every joint, in one pass."""
        out: list[list[int]] = [[] for _ in range(self.n_joints)]
        for k, p in enumerate(self.parents.tolist()):
            if p >= 0:
                out[p].append(k)
        return out

    def depth_first(self) -> list[int]:
        """Joints in depth-first pre-order (roots in index order, children in index order); iterative,
        so any depth works. Every joint's subtree is then a contiguous run of this list."""
        kids = self.children_lists()
        stack = [j for j in range(self.n_joints - 1, -1, -1) if self.parents[j] < 0]
        out: list[int] = []
        while stack:
            j = stack.pop()
            out.append(j)
            stack.extend(reversed(kids[j]))
        return out

    def depths(self) -> NDArray[np.int64]:
        """``(J,)`` number of ancestors of every joint (0 for a root), in one pass."""
        d = np.zeros(self.n_joints, dtype=np.int64)
        for j, p in enumerate(self.parents.tolist()):
            if p >= 0:
                d[j] = d[p] + 1
        return d

    @property
    def n_channels(self) -> int:
        return sum(len(c) for c in self.channels)

    def rotation_order(self, j: int) -> str:
        """Intrinsic Euler order of joint ``j``'s rotation channels (e.g. ``"ZXY"``), ``""`` if none."""
        return "".join(c[0].upper() for c in self.channels[j] if c in ROTATION_CHANNELS)

    def has_position(self, j: int) -> bool:
        return any(c in POSITION_CHANNELS for c in self.channels[j])


@dataclass(frozen=True)
class Motion:
    """Skeletal motion sampled at ``times``.

    Attributes
    ----------
    skeleton
        The hierarchy.
    times
        ``(N,)`` seconds, strictly increasing (frame ``k`` at ``k · frame_time`` for files with a rate).
    rotations
        ``(N, J, 4)`` local rotations, scalar-first unit quaternions.
    translations
        ``(N, J, 3)`` local translations (the offset for joints whose position is not animated).
    channel_values
        ``(N, C)`` the file's channel values as read, when the motion came from a channel-based file
        (BVH/AMC): writers use them to reproduce the channels exactly. ``None`` otherwise.
    """

    skeleton: Skeleton
    times: NDArray[np.float64]
    rotations: NDArray[np.float64]
    translations: NDArray[np.float64]
    channel_values: NDArray[np.float64] | None = None
    source: str = ""
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=np.float64)
        r = np.asarray(self.rotations, dtype=np.float64)
        x = np.asarray(self.translations, dtype=np.float64)
        J = self.skeleton.n_joints
        N = t.shape[0]
        if r.shape != (N, J, 4) or x.shape != (N, J, 3):
            raise InvalidSignalError(
                f"motion arrays: times {t.shape}, rotations {r.shape}, translations {x.shape}; J={J}"
            )
        if not np.all(np.isfinite(t)):
            raise InvalidSignalError("motion times must be finite")
        if N > 1 and np.any(np.diff(t) <= 0):
            raise InvalidSignalError("motion times must be strictly increasing")
        for what, a in (("rotations", r), ("translations", x)):
            if not np.all(np.isfinite(a)):
                n, j = (int(v[0]) for v in np.nonzero(~np.isfinite(a).all(axis=-1)))
                raise InvalidSignalError(f"motion {what}: joint {self.skeleton.names[j]!r} frame {n} is not finite")
        if N and J and not np.all(np.abs(r).max(axis=-1) > 0):
            n, j = (int(v[0]) for v in np.nonzero(~(np.abs(r).max(axis=-1) > 0)))
            raise InvalidSignalError(
                f"motion rotations: joint {self.skeleton.names[j]!r} frame {n} is a zero quaternion"
            )
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "rotations", r)
        object.__setattr__(self, "translations", x)

    @property
    def n_frames(self) -> int:
        return int(self.times.shape[0])

    @property
    def frame_time(self) -> float:
        return float(self.meta.get("frame_time", (self.times[-1] - self.times[0]) / max(self.n_frames - 1, 1)))

    @property
    def rate(self) -> float:
        return 1.0 / self.frame_time


def quat_to_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 4)`` scalar-first quaternions (normalised here) to ``(..., 3, 3)`` rotation matrices."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (yy + zz)
    m[..., 0, 1] = 2 * (xy - wz)
    m[..., 0, 2] = 2 * (xz + wy)
    m[..., 1, 0] = 2 * (xy + wz)
    m[..., 1, 1] = 1 - 2 * (xx + zz)
    m[..., 1, 2] = 2 * (yz - wx)
    m[..., 2, 0] = 2 * (xz - wy)
    m[..., 2, 1] = 2 * (yz + wx)
    m[..., 2, 2] = 1 - 2 * (xx + yy)
    return m


_Array = NDArray[np.float64]


@overload
def forward_kinematics(motion: Motion, end_sites: Literal[False] = ...) -> tuple[_Array, _Array]: ...
@overload
def forward_kinematics(motion: Motion, end_sites: Literal[True]) -> tuple[_Array, _Array, _Array]: ...
@overload
def forward_kinematics(motion: Motion, end_sites: bool) -> tuple[_Array, _Array] | tuple[_Array, _Array, _Array]: ...
def forward_kinematics(motion: Motion, end_sites: bool = False
                       ) -> tuple[_Array, _Array] | tuple[_Array, _Array, _Array]:
    """World positions ``(N, J, 3)`` and world rotation matrices ``(N, J, 3, 3)`` of every joint.

    ``p_j = p_parent + R_parent · t_j`` and ``R_j = R_parent · r_j`` with ``t_j``, ``r_j`` the local
    translation and rotation; roots use the identity as parent. One NumPy batch per joint over all
    frames. With ``end_sites=True`` also returns the ``(N, E, 3)`` end-site positions.
    """
    sk = motion.skeleton
    N, J = motion.n_frames, sk.n_joints
    # Joint-major, element-major layout: L (J, 3, 3, N) and t (J, 3, N), so that one matrix element
    # of one joint is a contiguous run over all frames and each per-joint product is a few long ufunc
    # loops into preallocated buffers (not N tiny 3×3 matmuls). L and t start as the local rotations
    # and translations and are overwritten, parents first, with the world ones; few large temporaries.
    c = np.asarray(motion.rotations, dtype=np.float64).transpose(2, 1, 0).copy()  # (4, J, N), own copy
    # normalise and convert exactly as quat_to_matrix does (same operations in the same order)
    norm = c[0] * c[0]
    tmp = c[1] * c[1]
    norm += tmp
    np.multiply(c[2], c[2], out=tmp)
    norm += tmp
    np.multiply(c[3], c[3], out=tmp)
    norm += tmp
    np.sqrt(norm, out=norm)
    c /= norm
    w, x, y, z = c
    L = np.empty((J, 3, 3, N))
    for a, b, k in ((y, z, 0), (x, z, 1), (x, y, 2)):  # 1 - 2 (yy + zz) etc.
        o = L[:, k, k]
        np.multiply(a, a, out=o)
        np.multiply(b, b, out=tmp)
        o += tmp
        o *= 2
        np.subtract(1, o, out=o)
    for a1, b1, a2, b2, (i, k) in ((x, y, w, z, (0, 1)), (x, z, w, y, (2, 0)), (y, z, w, x, (1, 2))):
        minus, plus = L[:, i, k], L[:, k, i]  # 2 (xy - wz) at (0, 1), 2 (xy + wz) at (1, 0), ...
        np.multiply(a1, b1, out=minus)
        np.multiply(a2, b2, out=tmp)
        np.add(minus, tmp, out=plus)
        minus -= tmp
        minus *= 2
        plus *= 2
    del c, norm, tmp, w, x, y, z
    t = np.asarray(motion.translations, dtype=np.float64).transpose(1, 2, 0).copy()  # (J, 3, N), own copy
    macc, mbuf = np.empty((3, 3, N)), np.empty((3, 3, N))
    vacc, vbuf = np.empty((3, N)), np.empty((3, N))
    for j, p in enumerate(sk.parents.tolist()):
        if p < 0:
            continue  # a root's world rotation and position are its local ones
        Rp, Lj, tj = L[p], L[j], t[j]
        # R_j[a, c] = Σ_b R_p[a, b] · r_j[b, c]
        np.multiply(Rp[:, 0, None], Lj[0], out=macc)
        np.multiply(Rp[:, 1, None], Lj[1], out=mbuf)
        macc += mbuf
        np.multiply(Rp[:, 2, None], Lj[2], out=mbuf)
        macc += mbuf
        # p_j = p_p + R_p · t_j
        np.multiply(Rp[:, 0], tj[0], out=vacc)
        np.multiply(Rp[:, 1], tj[1], out=vbuf)
        vacc += vbuf
        np.multiply(Rp[:, 2], tj[2], out=vbuf)
        vacc += vbuf
        np.add(t[p], vacc, out=tj)
        Lj[...] = macc
    P = np.ascontiguousarray(t.transpose(2, 0, 1))
    R = np.ascontiguousarray(L.transpose(3, 0, 1, 2))
    if not end_sites:
        return P, R
    E = np.empty((N, len(sk.end_sites), 3))
    for e, (j, off) in enumerate(sk.end_sites):
        E[:, e] = P[:, j] + np.einsum("nab,b->na", R[:, j], np.asarray(off, dtype=np.float64))
    return P, R, E
