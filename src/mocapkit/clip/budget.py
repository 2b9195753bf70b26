"""The error budget of every track, from the hierarchy, before any encoding.

A track's decoded values stay within ``τ`` per component of the original (the corridor of
:mod:`mocapkit.clip.keys`), so a rotation track turns its joint by at most ``√3·τ`` radians
(:mod:`mocapkit.rotvec`) and a translation track moves it by at most ``√3·τ``. A rotation error
``δ`` at joint ``i`` moves a point ``p`` hanging below it by at most ``2·sin(δ/2)·|p − p_i| ≤ δ·|p − p_i|``
and errors along a chain add up (rotations keep distances), so the error of a point ``k`` is at most
``Σ_i √3·τ_i·w_ik`` over the tracks ``i`` that move it, with ``w_ik = max_t |p_k − p_i|`` for a
rotation and 1 for a translation. Giving each of the ``n_k`` tracks that move point ``k`` an equal
share, ``τ_i = min_k E / (√3·n_k·w_ik)`` keeps every point within ``E`` (equal shares maximise
``Σ log τ_i`` — the bits a track costs fall with ``log τ`` — on one chain).

Points are the joints (``joint`` metric: a joint's own rotation does not move it), the joints and End
Sites (``joint+end``: an End Site hangs below its joint, so the joint's own rotation moves it too, with
``w = max_t |e − p_i|`` for that joint and its ancestors) or the joints' shell points at distance ``d``
along their local axes (``shell`` metric: a joint's own rotation moves its shell by ``d·δ``, and
``|s − p_i| ≤ |p_k − p_i| + d``).

This is the worst case (every error aligned, in the same frame); the encoder starts from a multiple of
it and tightens only where forward kinematics finds a point beyond the bound.
"""

from __future__ import annotations

import math

import numpy as np

from mocapkit.skeleton import Skeleton

EXACT_BUDGET = 20_000_000  # joint pairs × frames computed exactly at most (else a safe upper bound)


def track_tolerances(skeleton: Skeleton, P: np.ndarray, rot: list[int], trans: list[int], bound: float,
                     metric: str, shell_distance: float,
                     ends: np.ndarray | None = None) -> tuple[dict[int, float], dict[int, float]]:
    """Per-component tolerance of every rotation and translation track (``inf`` for a track that moves
    no point of the metric, such as a leaf's rotation under ``joint``).

    ``P`` ``(N, J, 3)`` are the original's world positions; ``bound``, ``shell_distance`` in file units;
    ``ends`` ``(N, E, 3)`` the world positions of ``skeleton.end_sites`` under ``joint+end``.
    """
    J = skeleton.n_joints
    parents = skeleton.parents.tolist()
    shell = metric == "shell"
    d = shell_distance if shell else 0.0
    is_rot = np.zeros(J, dtype=bool)
    is_rot[list(rot)] = True
    is_tr = np.zeros(J, dtype=bool)
    is_tr[list(trans)] = True
    # n_k: tracks moving point k = translations of k and its ancestors + rotations of its ancestors
    # (and of k itself for the shell)
    n_tr = np.zeros(J, dtype=np.int64)
    n_rot_above = np.zeros(J, dtype=np.int64)
    for j, p in enumerate(parents):
        n_tr[j] = is_tr[j] + (n_tr[p] if p >= 0 else 0)
        n_rot_above[j] = (n_rot_above[p] + is_rot[p]) if p >= 0 else 0
    n = n_tr + n_rot_above + (is_rot if shell else 0)
    with_ends = metric == "joint+end" and len(skeleton.end_sites) > 0
    end_joint = np.array([j for j, _ in skeleton.end_sites], dtype=np.int64) if with_ends else np.zeros(0, np.int64)
    n_end = (n_tr + n_rot_above + is_rot)[end_joint]  # an End Site: moved by its joint's own rotation too
    order = skeleton.depth_first()
    pos = np.empty(J, dtype=np.int64)
    pos[order] = np.arange(J)
    size = np.ones(J, dtype=np.int64)
    for j in reversed(order):
        if parents[j] >= 0:
            size[parents[j]] += size[j]
    order_arr = np.asarray(order, dtype=np.int64)
    exact = int(size.sum()) * P.shape[0] <= EXACT_BUDGET
    reach = None if exact else _reach_bound(skeleton, P, end_joint)
    root3 = math.sqrt(3.0)
    rt: dict[int, float] = {}
    tt: dict[int, float] = {}
    end_at = pos[end_joint]
    for i in set(rot) | set(trans):
        sub = order_arr[pos[i]:pos[i] + size[i]]  # i and its descendants
        below = np.flatnonzero((end_at >= pos[i]) & (end_at < pos[i] + size[i]))  # their End Sites
        if i in trans:
            tt[i] = bound / (root3 * float(max(n[sub].max(), n_end[below].max(initial=0))))
        if i in rot:
            pts = sub if shell else sub[1:]
            if pts.size == 0 and below.size == 0:
                rt[i] = math.inf
                continue
            if exact:
                w = np.linalg.norm(P[:, pts] - P[:, i:i + 1], axis=-1).max(axis=0) + d
                counts = n[pts]
                if below.size:
                    assert ends is not None  # End Sites are measured with their positions only
                    w = np.concatenate([w, np.linalg.norm(ends[:, below] - P[:, i:i + 1], axis=-1).max(axis=0)])
                    counts = np.concatenate([counts, n_end[below]])
                ok = w > 0  # a point on the joint itself (zero distance) is not moved by its rotation
                rt[i] = float((bound / (root3 * counts[ok] * w[ok])).min()) if ok.any() else math.inf
            else:
                assert reach is not None  # computed whenever the exact search is too large
                most = max(int(n[pts].max(initial=0)), int(n_end[below].max(initial=0)))
                rt[i] = bound / (root3 * most * (reach[i] + d)) if reach[i] + d > 0 else math.inf
    return rt, tt


def _reach_bound(skeleton: Skeleton, P: np.ndarray, end_joint: np.ndarray) -> np.ndarray:
    """Upper bound of ``max_t |p_k − p_i|`` over descendants ``k`` of every ``i`` and over the End Sites
    of the joints ``end_joint`` (rigid: their offsets' lengths) below it (leaves first, one pass)."""
    parents = skeleton.parents.tolist()
    reach = np.zeros(skeleton.n_joints)
    for e in range(len(end_joint)):
        j = int(end_joint[e])
        reach[j] = max(reach[j], float(np.linalg.norm(skeleton.end_sites[e][1])))
    for j in reversed(skeleton.depth_first()):
        p = parents[j]
        if p >= 0:
            reach[p] = max(reach[p], float(np.linalg.norm(P[:, j] - P[:, p], axis=-1).max()) + reach[j])
    return reach
