"""Calibration of the number-of-segments rule (segment/autok.py) on synthetic signals only.

For 12 signals of each of 0..8 changes (``motion_like``, 8 channels at 30 Hz, seeds 1000·k + i), the
kernel cost curve of the 1-s moving statistics is computed once; then, for a grid of the constant ``c``
and of the ``noise_range`` the spurious-split gain is read from, the share of signals whose number of
changes is recovered exactly and the mean F1 (±0.5 s) are printed. The defaults of ``choose_k`` are the
best of this grid. No labelled take is read.

    .venv/bin/python benchmarks/autok_calibration.py [--out docs/segmentation/autok_calibration.json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mocapkit.segment._common import standardise
from mocapkit.segment.autok import C_DEFAULT, NOISE_RANGE, choose_k, cost_curve, window_stats
from mocapkit.segment.metrics import f1_margin
from mocapkit.segment.synthetic import motion_like

C_GRID = (2.0, 2.5, 3.0, 3.5, 4.0, 5.0)
RANGES = ((0.25, 0.5), (0.3, 0.6), (0.25, 0.75), (0.5, 1.0))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=None)
    ap.add_argument("--per-k", type=int, default=12)
    args = ap.parse_args()
    t0 = time.perf_counter()
    curves = []
    for k in range(9):
        for i in range(args.per_k):
            x, cuts = motion_like(k, seed=1000 * k + i)
            curve = cost_curve(standardise(window_stats(x, 30)), 30, 30, "rbf")
            curves.append((k, cuts, x.shape[0], curve))
    print(f"{len(curves)} synthetic signals, cost curves in {time.perf_counter() - t0:.1f} s")
    rows = []
    print("| c | noise range | exact k | mean F1 (±0.5 s) |")
    print("|---:|---|---:|---:|")
    for c in C_GRID:
        for lo, hi in RANGES:
            exact, f1 = 0, []
            for k, cuts, n, curve in curves:
                kk = choose_k(curve.costs, c, (lo, hi))
                exact += kk == k
                f1.append(f1_margin(curve.cuts(kk), cuts, n, 15).f1)
            row = {"c": c, "noise_range": [lo, hi], "exact_k": exact / len(curves), "f1": float(np.mean(f1))}
            rows.append(row)
            mark = " (default)" if (c, (lo, hi)) == (C_DEFAULT, NOISE_RANGE) else ""
            print(f"| {c:g} | {lo:g}–{hi:g}{mark} | {row['exact_k']:.3f} | {row['f1']:.3f} |")
    best = max(rows, key=lambda r: (r["exact_k"], r["f1"]))
    print(f"best: c = {best['c']:g}, noise range {best['noise_range']}: exact k {best['exact_k']:.3f}")
    if args.out:
        with open(args.out, "w") as fh:
            json.dump({"signals": len(curves), "rows": rows, "best": best}, fh, indent=1)


if __name__ == "__main__":
    main()
