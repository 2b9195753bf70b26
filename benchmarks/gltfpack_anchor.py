"""Second anchor for glTF output: mocapkit's bounded SHORT glb against gltfpack (meshoptimizer) at the same
bound, on CMU 86_01 (ASF/AMC, unit from the ASF) and walk-meredith.bvh (2.54 cm per unit).

How to run (from the repository root; ``make test`` installs gltfpack under ``.venv/node``)::

    .venv/bin/python benchmarks/gltfpack_anchor.py            # prints the table, writes docs/gltfpack_anchor.json

For each clip and bound (0.01, 0.1, 1 cm):

* ours: ``compress_job(..., max_position_error=CM, output=clip.glb)`` (the CLI's ``mocapkit compress``;
  SHORT rotations by default, FLOAT where SHORT would take half the bound); bytes of the file and its
  read-back error (``read_gltf`` + forward kinematics of every joint and frame against the original).
* gltfpack: the ORIGINAL motion at full rate (every frame a key, FLOAT, written by mocapkit's glTF writer)
  run through ``gltfpack -kn -ar BITS -af HZ`` (``-kn`` keeps the named joint nodes; constant tracks are
  dropped as by default, which changes nothing; no ``-c``/``-cc`` meshopt compression, which mocapkit's
  reader cannot decode). Its output (normalized SHORT rotations, FLOAT translations and times) is read
  with ``read_gltf(rate=)`` — the generic path, joints matched by node name — and its error measured by
  forward kinematics against the original (frames after its last key hold that key, as a player does).
  ``-af`` in 0 (keep every frame), 60, 30 Hz is tried; the table shows, per bound, the smallest gltfpack
  file within the bound (or, if none is, the closest). Without ``-c`` gltfpack stores every rotation as a
  16-bit normalized SHORT whatever ``-ar`` says (measured: bytes and error are the same for ``-ar`` 8 to
  16; the bit count only drives its meshopt filters), so the core runs use ``-ar 16``. The JSON also
  lists, for every ``-ar`` from 8 to 16, the bytes with ``-cc`` added (EXT_meshopt_compression: not
  core glTF, not decodable by mocapkit, so its error is not measured); the table shows ``-cc -ar 16``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mocapkit.io.formats.gltf import read_gltf, write_gltf  # noqa: E402 (after the path insert)
from mocapkit.io.loaders import load_motion, unit_cm  # noqa: E402
from mocapkit.jobs import compress_job  # noqa: E402
from mocapkit.jobs.gltf_out import every_frame  # noqa: E402
from mocapkit.skeleton import forward_kinematics  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
CLIPS = {
    "86_01": (DATA / "cmu" / "86_01.amc", DATA / "cmu" / "86.asf", None),
    "walk-meredith": (DATA / "bvh" / "walk-meredith.bvh", None, 2.54),
}
BOUNDS = (0.01, 0.1, 1.0)
AR_BITS = tuple(range(8, 17))
AF_RATES = (0, 60, 30)
GLTFPACK = ROOT / ".venv" / "node" / "node_modules" / "gltfpack" / "cli.js"


def error_cm(original, ucm: float, back, back_ucm: float) -> float:
    """Largest world distance (cm) between ``original``'s joints and ``back``'s joints of the same names,
    over every frame of the original (``back`` held at its last frame beyond its end)."""
    P0 = forward_kinematics(original)[0] * ucm
    P1 = forward_kinematics(back)[0] * back_ucm
    idx = [back.skeleton.index(n) for n in original.skeleton.names]
    P1 = P1[:, idx]
    n0, n1 = P0.shape[0], P1.shape[0]
    if n1 < n0:
        P1 = np.concatenate([P1, np.repeat(P1[-1:], n0 - n1, axis=0)])
    return float(np.linalg.norm(P1[:n0] - P0, axis=-1).max())


def run_gltfpack(node: str, src: Path, dst: Path, opts: list[str]) -> None:
    r = subprocess.run([node, str(GLTFPACK), "-i", str(src), "-o", str(dst), *opts], capture_output=True, text=True,
                       timeout=600)
    if r.returncode != 0 or not dst.is_file():
        raise RuntimeError(f"gltfpack {' '.join(opts)} failed: {r.stderr.strip()[-500:]}")


def gltfpack_sweep(node: str, motion, ucm: float, work: Path) -> list[dict]:
    """Every gltfpack setting on the full-rate FLOAT glb of ``motion``: bytes and measured error."""
    full = work / "full.glb"
    write_gltf(full, every_frame(motion), unit_m=ucm / 100.0, rotations="float")
    rows = []
    for af in AF_RATES:
        opts = ["-kn", "-ar", "16", "-af", str(af)]
        out = work / f"gp-af{af}.glb"
        run_gltfpack(node, full, out, opts)
        back = read_gltf(out, rate=motion.rate)  # not our extras: every node a joint, metres
        cc = {}
        for ar in AR_BITS:
            f = work / f"gp-ar{ar}-af{af}-cc.glb"
            run_gltfpack(node, full, f, ["-kn", "-ar", str(ar), "-af", str(af), "-cc"])
            cc[str(ar)] = f.stat().st_size
        rows.append({"options": " ".join(opts), "af": af, "bytes": out.stat().st_size,
                     "error_cm": error_cm(motion, ucm, back, 100.0), "bytes_cc_by_ar": cc})
    return rows, full.stat().st_size


def pick(rows: list[dict], bound: float) -> dict:
    within = [r for r in rows if r["error_cm"] <= bound]
    if within:
        return {**min(within, key=lambda r: (r["bytes"], r["error_cm"])), "within_bound": True}
    return {**min(rows, key=lambda r: (r["error_cm"], r["bytes"])), "within_bound": False}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, default=ROOT / "docs" / "gltfpack_anchor.json")
    args = ap.parse_args(argv)
    node = shutil.which("node")
    if node is None or not GLTFPACK.is_file():
        print(f"needs node and gltfpack in {GLTFPACK.parent} (make test installs it)", file=sys.stderr)
        return 2
    version = subprocess.run([node, str(GLTFPACK), "-v"], capture_output=True, text=True).stdout.strip()
    results = {"gltfpack": version, "ar_bits": list(AR_BITS), "af_rates": list(AF_RATES), "clips": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name, (path, asf, given_unit) in CLIPS.items():
            motion = load_motion(path, asf=asf)
            ucm, _ = unit_cm(motion, given_unit)
            sweep, full_bytes = gltfpack_sweep(node, motion, ucm, work)
            clip = {"frames": motion.n_frames, "joints": motion.skeleton.n_joints, "unit_cm": ucm,
                    "full_rate_float_glb_bytes": full_bytes, "gltfpack_sweep": sweep, "bounds": []}
            for cm in BOUNDS:
                out = work / f"ours-{name}-{cm}.glb"
                t = time.perf_counter()
                rec = compress_job(path, asf=asf, unit_cm=given_unit, max_position_error=cm, output=out)
                clip["bounds"].append({
                    "bound_cm": cm,
                    "ours": {"bytes": rec["file_bytes"], "error_cm": rec["readback_max_position_error_cm"],
                             "rotations": rec["gltf_rotations"], "keyframes": rec["keyframes"],
                             "seconds": time.perf_counter() - t},
                    "gltfpack": pick(sweep, cm)})
            results["clips"][name] = clip
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=1, allow_nan=False) + "\n")
    print("| clip | bound cm | ours bytes | ours err cm | rotations | gltfpack bytes | gltfpack err cm | options "
          "| gltfpack/ours | gltfpack -cc -ar 16 bytes (error not measured) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, clip in results["clips"].items():
        for b in clip["bounds"]:
            o, g = b["ours"], b["gltfpack"]
            mark = "" if g["within_bound"] else " (closest; none within)"
            print(f"| {name} | {b['bound_cm']:g} | {o['bytes']:,} | {o['error_cm']:.4f} | {o['rotations']} | "
                  f"{g['bytes']:,} | {g['error_cm']:.4f}{mark} | `{g['options']}` | {g['bytes'] / o['bytes']:.2f} | "
                  f"{g['bytes_cc_by_ar']['16']:,} |")
    print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
