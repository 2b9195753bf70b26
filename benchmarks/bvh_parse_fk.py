"""Benchmark: BVH parse + forward kinematics, mocapkit vs ``bvhio`` (and ``bvh`` for parsing alone).

How to run (from the repository root; ``bvhio`` and ``bvh`` are benchmark-only, not project
dependencies)::

    .venv/bin/pip install bvhio bvh && .venv/bin/python benchmarks/bvh_parse_fk.py

Add ``--save docs/bvh_bench.txt`` to also write the printed report there.

Every library does the same work on each shared BVH file, timed as best of ``--repeats`` runs:

* mocapkit: ``read_bvh`` (read the file, parse hierarchy and motion, Euler angles -> quaternions)
  then ``forward_kinematics`` (world positions and rotations of every joint for every frame).
* bvhio: ``readAsHierarchy`` (its idiomatic loader: parse + build the transform hierarchy) then, for
  every frame, ``root.loadPose(frame)`` and each joint's ``PositionWorld`` over ``root.layout()``,
  collected into an ``(N, J, 3)`` array. This is the per-frame world-position API bvhio documents;
  it has no batched alternative.
* bvhio* (the fastest way we found to get the same numbers out of bvhio): as above, but instead of
  ``PositionWorld`` (which walks the parent chain for every joint) each frame composes the joints'
  local ``Space`` matrices parent-first once (``world = parent_world * joint.Space``) and takes
  ``parent_world * joint.Position``: the same PyGLM products, so the same float32 results.
* bvh (parsing only): read the file, ``Bvh(text)`` and convert its ``frames`` (all channel values
  of all frames, as strings) to an ``(N, C)`` float array. Its per-value accessors
  (``frame_joint_channels``) search the whole tree for every value, so converting the frames list is
  the fastest complete read it offers.

Correctness is checked in the same run: mocapkit's world positions against bvhio's (bvhio computes
in float32 via PyGLM, so differences of a few float32 ulps of the coordinate magnitude are
expected), and mocapkit's channel values against ``bvh``'s. bvhio, like mocapkit, lets a joint's
position channels *replace* its OFFSET, so every joint is compared.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import sys
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np

from mocapkit.io.skeletal.bvh import read_bvh
from mocapkit.skeleton import forward_kinematics

try:
    import bvhio
    import glm  # PyGLM, installed with bvhio
    from bvh import Bvh
except ImportError as e:  # pragma: no cover - benchmark-only dependencies
    sys.exit(f"{e}; install the benchmark dependencies: .venv/bin/pip install bvhio bvh")

# the shared data folder sits beside the repository (as for the Makefile's sweep target)
SHARED_BVH = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"
DEFAULT_FILES = [str(SHARED_BVH / "walk-meredith.bvh"), str(SHARED_BVH / "perception-neuron-freya.bvh")]


def best_of(fn, repeats: int):
    """Best wall time of ``repeats`` calls (after one untimed warm-up call) and the last result."""
    out = fn()
    best = float("inf")
    for _ in range(repeats):
        gc.collect()
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bvhio_world_positions(path: str) -> np.ndarray:
    root = bvhio.readAsHierarchy(path)
    joints = [j for j, _, _ in root.layout()]
    n = root.getKeyframeRange()[1] + 1
    out = np.empty((n, len(joints), 3))
    for k in range(n):
        root.loadPose(k, recursive=True)
        for i, j in enumerate(joints):
            out[k, i] = j.PositionWorld
    return out


def bvhio_world_positions_fast(path: str) -> np.ndarray:
    root = bvhio.readAsHierarchy(path)
    joints = [j for j, _, _ in root.layout()]
    index = {id(j): i for i, j in enumerate(joints)}
    parents = [index[id(j.Parent)] if j.Parent is not None else -1 for j in joints]
    identity = glm.mat4()
    n = root.getKeyframeRange()[1] + 1
    out = np.empty((n, len(joints), 3))
    for k in range(n):
        root.loadPose(k, recursive=True)
        world = [identity] * len(joints)
        for i, (j, p) in enumerate(zip(joints, parents, strict=True)):
            parent_world = world[p] if p >= 0 else identity
            world[i] = parent_world * j.Space
            out[k, i] = parent_world * j.Position
    return out


def bvh_channel_values(path: str) -> np.ndarray:
    mocap = Bvh(Path(path).read_text())
    return np.array(mocap.frames, dtype=np.float64)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", default=DEFAULT_FILES)
    ap.add_argument("--repeats", type=int, default=7, help="timed runs per measurement (best is kept)")
    ap.add_argument("--save", metavar="PATH", help="also write the report to PATH")
    args = ap.parse_args()

    lines: list[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    say("BVH parse + forward kinematics: mocapkit vs bvhio (parse+FK) and bvh (parse only)")
    say(
        f"python {platform.python_version()}, numpy {np.__version__}, bvhio {version('bvhio')}, "
        f"bvh {version('bvh')}, pyglm {version('pyglm')}; {os.cpu_count()} CPUs; "
        f"best of runs after 1 warm-up (mocapkit {max(args.repeats, 30)}, bvh {max(args.repeats, 10)}, "
        f"bvhio {args.repeats}), seconds"
    )
    say()
    rows = []
    checks = []
    for path in args.files:
        name = Path(path).name
        fast = max(args.repeats, 30)  # millisecond-scale runs: more repeats for a stable best
        t_parse, motion = best_of(lambda: read_bvh(path), fast)
        t_fk, (P, _R) = best_of(lambda: forward_kinematics(motion), fast)
        t_total, _ = best_of(lambda: forward_kinematics(read_bvh(path)), fast)
        t_bvhio, P_bvhio = best_of(lambda: bvhio_world_positions(path), args.repeats)
        t_bvhio_fast, P_bvhio_fast = best_of(lambda: bvhio_world_positions_fast(path), args.repeats)
        t_bvh, vals_bvh = best_of(lambda: bvh_channel_values(path), max(args.repeats, 10))
        rows.append(
            (name, motion.n_frames, motion.skeleton.n_joints, t_parse, t_fk, t_total, t_bvhio, t_bvhio_fast, t_bvh)
        )

        if P_bvhio.shape != P.shape:
            raise SystemExit(f"{name}: bvhio gives {P_bvhio.shape} positions, mocapkit {P.shape}")
        if not np.array_equal(P_bvhio_fast, P_bvhio):
            raise SystemExit(f"{name}: the two bvhio ways disagree by {np.abs(P_bvhio_fast - P_bvhio).max():.3g}")
        d = np.abs(P_bvhio - P)
        scale = float(np.abs(P).max())
        if vals_bvh.shape != motion.channel_values.shape:
            raise SystemExit(f"{name}: bvh gives {vals_bvh.shape} values, mocapkit {motion.channel_values.shape}")
        dv = float(np.abs(vals_bvh - motion.channel_values).max())
        checks.append((name, float(d.max()), float(d.mean()), scale, dv))

    hdr = (
        f"{'file':<28} {'frames':>6} {'joints':>6} {'mk parse':>9} {'mk FK':>7} {'mk total':>9} "
        f"{'bvhio':>7} {'bvhio*':>7} {'bvh parse':>9} {'bvhio/mk':>9} {'bvhio*/mk':>9} {'bvh/mk parse':>12}"
    )
    say(hdr)
    say("-" * len(hdr))
    for name, n, j, tp, tf, tt, tb, tbf, tv in rows:
        say(
            f"{name:<28} {n:>6} {j:>6} {tp:>9.4f} {tf:>7.4f} {tt:>9.4f} "
            f"{tb:>7.3f} {tbf:>7.3f} {tv:>9.4f} {tb / tt:>8.1f}x {tbf / tt:>8.1f}x {tv / tp:>11.1f}x"
        )
    say()
    say("mk parse = read_bvh (file -> Motion with quaternions); mk FK = forward_kinematics; mk total = both")
    say("timed together (each column is its own best of runs, so mk total can be below mk parse + mk FK).")
    say("bvhio = readAsHierarchy + loadPose + PositionWorld per joint and frame; bvhio* = the same with the")
    say("world matrices composed parent-first per frame (its fastest route we found); bvh parse = Bvh(text)")
    say("+ all frames to floats. Ratios: bvhio(*)/mk = their parse+FK / mocapkit parse+FK (mk total);")
    say("bvh/mk parse = bvh parse / mocapkit read_bvh.")
    say()
    say("Correctness (world positions of every joint and frame, file units):")
    for name, dmax, dmean, scale, dv in checks:
        say(
            f"  {name}: max |mocapkit - bvhio| = {dmax:.3g} (mean {dmean:.3g}); largest |coordinate| {scale:.4g}, "
            f"so max/largest = {dmax / scale:.2g} = {dmax / scale / np.finfo(np.float32).eps:.1f} float32 eps; "
            f"max |channel values mocapkit - bvh| = {dv:.3g}"
        )
    say("  bvhio computes in float32 (PyGLM), mocapkit in float64: the differences are float32 rounding")
    say("  (a few float32 eps of the coordinate size); bvhio and bvhio* give identical positions.")
    say("  Convention: bvhio, like mocapkit, lets a joint's position channels replace its OFFSET, so all")
    say("  joints (including Perception Neuron's animated non-root positions) are compared.")

    if args.save:
        Path(args.save).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
