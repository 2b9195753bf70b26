"""The ``.mkc`` clip against ACL, and its speed, measured in one run on this machine.

1. **Size at a bound**: every shared skeletal file (../shared/data) at shell bounds 0.01, 0.1 and 1 cm and,
   for the two clips ACL was run on, at ACL's own measured shell error (86_01: 0.0175 cm; walk-meredith:
   0.0149 cm): clip bytes, the joint and shell errors measured on the decoded bytes, and ACL's bytes from
   issue 12's side-by-side run (ACL built from source, one independent error script for both decoders).
2. **Encoding speed**: the clip encoder against the glTF path (``pla.skeletal.compress_motion``: per-joint
   angle-bounded SW; a bisection over forward kinematics until issue 12, now the same repair as the
   clip's) on 86_01 at the same joint bound, in this run (the ratio is what counts; the machine is shared).
3. **Decoding speed**: joint-samples (frames × joints) per second of a whole-clip decode to local poses,
   on one thread and on all cores (blocks are independent), and of ``Clip.decode`` (the checked model
   object); ``Clip.pose_at`` for random instants, cold (block not cached) and in playback order.

    python benchmarks/clip_bench.py [--json docs/clip_bench.json] [--entropy zstd|lzma]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"

#: (file, ASF, cm per length unit or None = the file's / assumed 1)
FILES = [("cmu/86_01.amc", "cmu/86.asf", None), ("cmu/13_29.amc", "cmu/86.asf", None),
         ("cmu/13_30.amc", "cmu/86.asf", None), ("cmu/14_14.amc", "cmu/86.asf", None),
         ("bvh/walk-meredith.bvh", None, 2.54), ("bvh/cmu-131_01-3dsmax.bvh", None, None),
         ("bvh/perception-neuron-freya.bvh", None, None), ("bvh/mixamo-rig.bvh", None, None),
         ("bvh/mocapbank.bvh", None, None)]
BOUNDS_CM = (0.01, 0.1, 1.0)
#: ACL's clips from issue 12's side-by-side run: shell error (cm) -> bytes, by ACL's precision setting
ACL = {"cmu/86_01.amc": {"default": (0.0175, 398_429), "0.1 cm": (0.163, 251_025), "1 cm": (1.58, 85_100)},
       "bvh/walk-meredith.bvh": {"default": (0.0149, 85_335)}}


def best_of(fn, n: int) -> float:
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--entropy", default="zstd", choices=("zstd", "lzma", "smallest"))
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        sys.exit(f"needs the shared recordings at {DATA}")
    import mocapkit.clip.decoder as reader
    from mocapkit.clip import Clip, encode_clip
    from mocapkit.io.loaders import load_motion, unit_cm
    from mocapkit.pla.skeletal import compress_motion

    def load(name, asf, u):
        m = load_motion(DATA / name, asf=None if asf is None else DATA / asf)
        return m, (u or unit_cm(m, None)[0])

    # warm the compiled kernels so no row pays for compilation
    m, u = load(*FILES[4])
    encode_clip(m, 0.1 / u, shell_distance=3 / u, entropy=args.entropy)

    rows = []
    for name, asf, uu in FILES:
        m, u = load(name, asf, uu)
        bounds = list(BOUNDS_CM) + ([ACL[name]["default"][0]] if name in ACL else [])
        for b in bounds:
            t0 = time.perf_counter()
            enc = encode_clip(m, b / u, metric="shell", shell_distance=3.0 / u, unit_cm=u, entropy=args.entropy)
            wall = time.perf_counter() - t0
            r = enc.report
            row = {"file": name, "frames": m.n_frames, "joints": m.skeleton.n_joints, "unit_cm": u,
                   "bound_shell_cm": b, "bytes": r["bytes"], "max_joint_cm": r["max_joint_error_cm"],
                   "max_shell_cm": r["max_shell_error_cm"], "keyframes": r["keyframes"], "encode_s": wall,
                   "acl_bytes": None, "acl_shell_cm": None}
            acl = ACL.get(name, {})
            if name in ACL and b == acl["default"][0]:
                row["acl_shell_cm"], row["acl_bytes"] = acl["default"]
            elif b == 0.1 and "0.1 cm" in acl:
                row["acl_shell_cm"], row["acl_bytes"] = acl["0.1 cm"]
            elif b == 1.0 and "1 cm" in acl:
                row["acl_shell_cm"], row["acl_bytes"] = acl["1 cm"]
            rows.append(row)
            versus = (
                f"  ACL {row['acl_bytes']:,} B at shell {row['acl_shell_cm']} cm ({row['acl_bytes'] / r['bytes']:.2f}x)"
                if row["acl_bytes"]
                else ""
            )
            print(f"{name:34s} shell<={b:<7g} {r['bytes']:>9,} B  joint {r['max_joint_error_cm']:.4f}  "
                  f"shell {r['max_shell_error_cm']:.4f} cm  {wall:5.2f} s{versus}", flush=True)

    # encoding speed against the previous path, same joint bound, one run
    m, u = load(*FILES[0])
    speed = {}
    for b in (0.1, 1.0):
        t_old = best_of(lambda: compress_motion(m, "anglesw", max_position_error=b / u), 1)
        t_new = best_of(lambda: encode_clip(m, b / u, metric="joint", shell_distance=3 / u, entropy=args.entropy), 3)
        speed[f"{b:g} cm"] = {"previous_s": t_old, "clip_s": t_new, "ratio": t_old / t_new}
        print(f"86_01 joint<={b:g} cm: glTF path {t_old:.2f} s, clip encoder {t_new:.3f} s ({t_old / t_new:.0f}x)")

    # decoding speed
    js = m.n_frames * m.skeleton.n_joints
    decode = {}
    for b in (0.0175, 1.0):
        data = encode_clip(m, b / u, metric="shell", shell_distance=3 / u, entropy=args.entropy).data
        res = {"bytes": len(data)}
        for threads in (1, reader.THREADS):
            saved, reader.THREADS = reader.THREADS, threads
            try:
                t = best_of(lambda: Clip("c.mkc", data=data).decode_arrays(), 7)
            finally:
                reader.THREADS = saved
            res[f"poses_per_s_{threads}_threads"] = js / t
        res["motion_per_s"] = js / best_of(lambda: Clip("c.mkc", data=data).decode(), 7)
        clip = Clip("c.mkc", data=data)
        ts = np.random.default_rng(0).uniform(0, float(m.times[-1]), 2000)

        def cold():
            for t in ts:
                clip._cache.clear()
                clip.pose_at(t)

        res["pose_at_cold_us"] = best_of(cold, 1) / len(ts) * 1e6
        res["pose_at_playback_us"] = best_of(lambda: [clip.pose_at(t) for t in np.sort(ts)], 3) / len(ts) * 1e6
        decode[f"shell {b:g} cm"] = res
        print(
            f"decode 86_01 at shell {b:g} cm ({len(data):,} B): "
            + ", ".join(
                f"{k} {v / 1e6:.1f} M" if "per_s" in k else f"{k} {v:.0f}" for k, v in res.items() if k != "bytes"
            )
        )
    out = {"entropy": args.entropy, "rows": rows, "encode_speed": speed, "decode": decode}
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
