"""Benchmark: peak memory and speed of the IMU CSV reader on a large generated file.

How to run (from the repository root)::

    .venv/bin/python benchmarks/imu_memory.py                 # 13.5 M rows, about 800 MiB
    .venv/bin/python benchmarks/imu_memory.py --rows 750000   # about 50 MB, a quick check

The script writes an x-io style export (``Timestamp (us),W,X,Y,Z``: an integer clock in µs and
four unit-quaternion components with 9 decimals, about 66 bytes a row) to a temporary folder
(``--dir``, default the system's), reads it with :func:`mocapkit.io.read_imu_file` in a fresh
Python process, and deletes it. The child process reports its resident memory after the imports
(``baseline``, ``VmRSS``) and its peak (``VmHWM``, Linux) after the read, and the read's wall time; the parent
prints, from that one run:

* the numeric data: rows × 5 columns × 8 bytes (the float64 arrays the reader returns),
* the peak resident memory and its ratio to the numeric data (issue 10's target: ≤ 3),
* the growth over the baseline and its ratio to the numeric data,
* the parse time, rows per second and MB per second,

and checks the result (row count, first and last time, a few values against the text). Add
``--save docs/imu_memory.txt`` to also write the report there.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HEADER = "Timestamp (us),W,X,Y,Z\n"
COLUMNS = 5

_CHILD = r"""
import json, sys, time
def status_mb(key):
    # VmRSS: resident now; VmHWM: peak resident of this process image (reset at exec, unlike
    # ru_maxrss, which a child started by vfork inherits from its parent)
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024
    raise SystemExit("no /proc/self/status: Linux only")
from mocapkit.io import read_imu_file
import mocapkit.io.imu.signals, scipy.spatial.transform  # everything the read needs is imported
base = status_mb("VmRSS")
t0 = time.perf_counter()
sigs = read_imu_file(sys.argv[1])
dt = time.perf_counter() - t0
peak = status_mb("VmHWM")
sig = next(iter(sigs.values()))
print(json.dumps({"baseline_mb": base, "peak_mb": peak, "seconds": dt,
                  "rows": len(sig), "t0": sig.times[0], "t1": sig.times[-1],
                  "first": sig.values[0].tolist(), "last": sig.values[-1].tolist()}))
"""


def generate(path: Path, rows: int, seed: int = 1) -> tuple[int, list[str]]:
    """Write ``rows`` rows; return the file size and the first and last data lines."""
    rng = np.random.default_rng(seed)
    first = last = ""
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(HEADER)
        step = 250_000
        for s in range(0, rows, step):
            m = min(step, rows - s)
            q = rng.normal(size=(m, 4))
            q /= np.linalg.norm(q, axis=1)[:, None]
            t = np.arange(s, s + m, dtype=np.int64) * 10_000 + 1_000_000
            lines = [
                f"{a},{b:.9f},{c:.9f},{d:.9f},{e:.9f}" for a, b, c, d, e in zip(t.tolist(), *q.T.tolist(), strict=True)
            ]
            if s == 0:
                first = lines[0]
            last = lines[-1]
            fh.write("\n".join(lines))
            fh.write("\n")
    return path.stat().st_size, [first, last]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=13_500_000, help="data rows to generate (default 13.5 M, ~800 MiB)")
    ap.add_argument("--dir", type=Path, default=None, help="folder for the temporary file")
    ap.add_argument("--save", type=Path, default=None, help="also write the report to this file")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory(dir=args.dir, prefix="imu-memory-") as tmp:
        path = Path(tmp) / "big_imu.csv"
        t0 = time.perf_counter()
        size, (first, last) = generate(path, args.rows)
        gen_s = time.perf_counter() - t0
        env = dict(os.environ)
        proc = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True, env=env)
        if proc.returncode != 0:
            sys.stderr.write(proc.stderr)
            return 1
        res = json.loads(proc.stdout.strip().splitlines()[-1])
        path.unlink()

    numeric = args.rows * COLUMNS * 8
    mb = 1024 * 1024
    ok = (res["rows"] == args.rows and res["t0"] == int(first.split(",")[0]) / 1e6
          and res["t1"] == int(last.split(",")[0]) / 1e6
          and res["first"] == [float(x) for x in first.split(",")[1:]]
          and res["last"] == [float(x) for x in last.split(",")[1:]])
    report = "\n".join([
        f"IMU CSV reader memory benchmark ({platform.python_implementation()} {platform.python_version()}, "
        f"numpy {np.__version__}, {platform.machine()})",
        f"file            {size / mb:10.1f} MB  ({args.rows:,} rows x {COLUMNS} columns, generated in {gen_s:.1f} s)",
        f"numeric data    {numeric / mb:10.1f} MB  (rows x columns x 8 bytes)",
        f"peak RSS        {res['peak_mb']:10.1f} MB  ratio to numeric data {res['peak_mb'] * mb / numeric:.2f} "
        "(target <= 3)",
        f"baseline RSS    {res['baseline_mb']:10.1f} MB  (Python, numpy, scipy, mocapkit imported)",
        f"growth          {res['peak_mb'] - res['baseline_mb']:10.1f} MB  ratio to numeric data "
        f"{(res['peak_mb'] - res['baseline_mb']) * mb / numeric:.2f}",
        f"parse time      {res['seconds']:10.2f} s   ({args.rows / res['seconds'] / 1e6:.2f} M rows/s, "
        f"{size / mb / res['seconds']:.1f} MB/s)",
        f"values checked  {'ok' if ok else 'MISMATCH'}",
    ])
    print(report)
    if args.save is not None:
        args.save.write_text(report + "\n")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
