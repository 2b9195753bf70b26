"""Generate a test database for ``mocapkit batch``: the shared recordings plus perturbed copies, and a few
corrupt files.

Every original file of ``../shared/data`` that a job reads (IMU exports, BVH, AMC with its ASF, C3D, the
Qualisys TSV) is copied once as it is; the rest of the ``n`` recordings are copies of them cut to a random
window (2-12 s) with small noise added to every value (BVH and AMC rewritten as text with their own header,
C3D and IMU data through mocapkit's writers). Every file is named ``SS_TT.<ext>`` in the CMU style, so that
the catalog's subject (``SS``, from the source recording) and take (``TT``) fields come from the file name.
``n_corrupt`` files are broken the ways real files break (cut short, wrong numbers, empty, random bytes).

    python benchmarks/batch_db.py OUT [--n 1000] [--corrupt 10] [--seed 0]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def _sources(shared: Path) -> list[tuple[str, Path]]:
    """``(kind, path)`` of the originals used as seeds (kind: bvh, amc, c3d, tsv, imu)."""
    out = [("bvh", p) for p in sorted((shared / "bvh").glob("*.bvh"))]
    out += [("amc", p) for p in sorted((shared / "cmu").glob("*.amc"))]
    out += [("c3d", p) for p in sorted((shared / "c3d").glob("*.c3d"))]
    out += [("tsv", p) for p in sorted((shared / "juggling").glob("*.tsv"))]
    out += [("imu", p) for p in sorted((shared / "imu" / "xio-lower-body").glob("*/Quaternion.csv"))]
    out += [("imu", p) for p in sorted((shared / "imu" / "xsens-dot").glob("*.csv"))]
    out += [("imu", p) for p in sorted((shared / "imu" / "xsens-mtmanager").glob("MT46_*.txt"))]
    return out


def _noisy_numbers(tokens: list[str], rng, scale: float) -> str:
    return " ".join(f"{float(t) + rng.normal(0.0, scale):.6f}" for t in tokens)


def _bvh_copy(src: Path, dest: Path, rng) -> None:
    lines = src.read_text().splitlines()
    m = next(i for i, ln in enumerate(lines) if ln.strip().upper() == "MOTION")
    ft = next(i for i in range(m + 1, len(lines)) if lines[i].strip().lower().startswith("frame time"))
    frame_time = float(lines[ft].split(":", 1)[1])
    frames = [ln for ln in lines[ft + 1:] if ln.strip()]
    n = min(len(frames), max(2, int(rng.uniform(2.0, 12.0) / frame_time)))
    a = int(rng.integers(0, len(frames) - n + 1))
    body = [_noisy_numbers(f.split(), rng, 0.05) for f in frames[a:a + n]]
    dest.write_text("\n".join(lines[:m + 1] + [f"Frames: {n}", lines[ft].strip()] + body) + "\n")


def _amc_copy(src: Path, dest: Path, rng, rate: float = 120.0) -> None:
    lines = src.read_text().replace("\r\n", "\n").splitlines()
    head_end = next(i for i, ln in enumerate(lines) if ln.strip().isdigit())
    blocks, cur = [], None
    for ln in lines[head_end:]:
        if ln.strip().isdigit():
            cur = []
            blocks.append(cur)
        elif ln.strip():
            cur.append(ln.split())
    n = min(len(blocks), max(2, int(rng.uniform(2.0, 12.0) * rate)))
    a = int(rng.integers(0, len(blocks) - n + 1))
    out = lines[:head_end]
    for k, block in enumerate(blocks[a:a + n], 1):
        out.append(str(k))
        out += [f"{toks[0]} {_noisy_numbers(toks[1:], rng, 0.05)}" for toks in block]
    dest.write_text("\n".join(out) + "\n")


def _markers_copy(src: Path, dest: Path, rng) -> None:
    from mocapkit.io.loaders import load_markers, write_markers
    from mocapkit.markers import Markers

    mk = load_markers(src)
    n_all = mk.times.shape[0]
    n = min(n_all, max(2, int(rng.uniform(2.0, 12.0) * mk.rate)))
    a = int(rng.integers(0, n_all - n + 1))
    pos = np.array(mk.positions[a:a + n]) + rng.normal(0.0, 0.2, size=(n, *mk.positions.shape[1:]))
    write_markers(Markers(mk.times[a:a + n] - mk.times[a], pos, mk.labels, mk.rate, units=mk.units), dest)


def _imu_copy(src: Path, dest: Path, rng) -> None:
    from mocapkit.io import load_signals, write_signal_csv

    sig = next(iter(load_signals(src).values()))
    n_all = len(sig)
    rate = sig.mean_rate
    n = min(n_all, max(2, int(rng.uniform(2.0, 12.0) * rate)))
    a = int(rng.integers(0, n_all - n + 1))
    q = np.array(sig.values[a:a + n]) + rng.normal(0.0, 1e-3, size=(n, 4))
    write_signal_csv(dest, sig.times[a:a + n], q / np.linalg.norm(q, axis=1, keepdims=True))


def _corrupt(dest: Path, i: int, good: list[Path], rng) -> Path:
    """The ``i``-th corrupt file, named like a recording."""
    kind = i % 10
    bvh = next(p for p in good if p.suffix == ".bvh")
    if kind == 0:  # cut short inside the hierarchy
        p = dest / f"90_{i:02d}.bvh"
        p.write_text(bvh.read_text()[:300])
    elif kind == 1:  # a word where a number belongs
        p = dest / f"90_{i:02d}.bvh"
        p.write_text(bvh.read_text().replace("\n0", "\nzero", 1) + "1.0 oops\n")
    elif kind == 2:
        p = dest / f"90_{i:02d}.c3d"
        p.write_bytes(b"")
    elif kind == 3:
        p = dest / f"90_{i:02d}.c3d"
        p.write_bytes(rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    elif kind == 4:  # an IMU CSV with a header only
        p = dest / f"90_{i:02d}.csv"
        p.write_text("time,w,x,y,z\n")
    elif kind == 5:  # non-finite values
        p = dest / f"90_{i:02d}.csv"
        p.write_text("time,w,x,y,z\n0.0,1,0,0,0\n0.01,nan,0,0,0\n0.02,1,0,0,0\n")
    elif kind == 6:  # binary bytes in a text format
        p = dest / f"90_{i:02d}.bvh"
        p.write_bytes(b"HIERARCHY\n\x00\x01\x02" + bytes(range(256)))
    elif kind == 7:  # an AMC whose skeleton is missing
        p = dest / f"91_{i:02d}.amc"
        p.write_text(":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\n")
    elif kind == 8:  # times going backwards
        p = dest / f"90_{i:02d}.csv"
        p.write_text("time,w,x,y,z\n0.0,1,0,0,0\n0.02,1,0,0,0\n0.01,1,0,0,0\n")
    else:  # a C3D cut inside its parameter section
        c3d = next(p for p in good if p.suffix == ".c3d")
        p = dest / f"90_{i:02d}.c3d"
        p.write_bytes(c3d.read_bytes()[:1500])
    return p


def generate(dest: Path, n: int = 1000, n_corrupt: int = 10, seed: int = 0, shared: Path = SHARED) -> dict:
    """Write the database into ``dest`` (made empty first); returns counts per kind."""
    rng = np.random.default_rng(seed)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    sources = _sources(shared)
    asf = shared / "cmu" / "86.asf"
    counts: dict[str, int] = {}
    written: list[Path] = []
    suffix = {"bvh": ".bvh", "amc": ".amc", "c3d": ".c3d", "tsv": ".c3d", "imu": ".csv"}
    for k in range(n):
        s = k % len(sources)
        kind, src = sources[s]
        subject, take = 10 + s, k // len(sources) + 1
        sub = dest / kind
        sub.mkdir(exist_ok=True)
        if take == 1:  # the original itself, in its own format
            p = sub / f"{subject:02d}_{take:02d}{src.suffix.lower()}"
            shutil.copyfile(src, p)
        else:
            p = sub / f"{subject:02d}_{take:02d}{suffix[kind]}"
            {"bvh": _bvh_copy, "amc": _amc_copy, "c3d": _markers_copy, "tsv": _markers_copy,
             "imu": _imu_copy}[kind](src, p, rng)
        if kind == "amc":  # its skeleton beside it, named as CMU names them
            sk = sub / f"{subject:02d}.asf"
            if not sk.exists():
                shutil.copyfile(asf, sk)
        counts[kind] = counts.get(kind, 0) + 1
        written.append(p)
    bad = dest / "corrupt"
    bad.mkdir()
    for i in range(n_corrupt):
        _corrupt(bad, i, written, rng)
    counts["corrupt"] = n_corrupt
    return counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--corrupt", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    print(generate(a.out, a.n, a.corrupt, a.seed))


if __name__ == "__main__":
    main()
