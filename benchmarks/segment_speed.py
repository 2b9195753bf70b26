"""Segmentation speed: the ARMA segmenter (the authors' reading, default, and the fitness-SD reading) and
``--method auto`` on CMU 86_01 (4,579 frames) and on a 5,000-frame take, and the per-window AR fit batched
in NumPy vs one statsmodels AutoReg per window (ratio in one run).

    .venv/bin/python benchmarks/segment_speed.py [../shared/data]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from mocapkit.segment.arma import ARMASegmenter, fit_arma


def best_of(f, repeat=7):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return min(ts), float(np.median(ts))


def main() -> None:
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("../shared/data")
    from mocapkit.io.loaders import load_motion
    from mocapkit.segment.features import motion_features

    motion = load_motion(data / "cmu" / "86_01.amc", asf=data / "cmu" / "86.asf")
    t0 = time.perf_counter()
    feats = motion_features(motion)
    limbs, part = feats.limbs, feats.partition
    t_feat = time.perf_counter() - t0
    print(f"86_01 ({limbs.shape[0]} frames): features (FK + angles) {t_feat:.3f} s")
    from mocapkit.segment.autok import AutoSegmenter

    sd_reading = dict(differencing="fixed", order="parsimonious", cut="min_sd", p_range=(1, 2, 3, 4), q_range=(0, 1, 2))
    for name, seg, X in (("ARMA (authors' reading)", ARMASegmenter(), limbs),
                         ("ARMA (fitness-SD reading)", ARMASegmenter(**sd_reading), limbs),
                         ("auto", AutoSegmenter(), part)):
        X5 = np.concatenate([X, X[: 5000 - X.shape[0]]])
        a, _ = best_of(lambda: seg.fit_predict(X))
        bmin, bmed = best_of(lambda: seg.fit_predict(X5))
        print(f"{name}: 86_01 best {a:.3f} s; 5,000-frame take best {bmin:.3f} s, median {bmed:.3f} s "
              f"(target < 1 s; paper Table 6: 728.5 s)")

    # the fit step alone: all windows of all limbs (second differences, 100 samples) with AR(4)
    z = np.diff(limbs[::4], n=2, axis=0)
    K = z.shape[0] // 100
    W = np.concatenate([z[: K * 100, j].reshape(K, 100) for j in range(4)])
    from statsmodels.tsa.ar_model import AutoReg

    ours, _ = best_of(lambda: fit_arma(W, 4, 0))
    sm, _ = best_of(lambda: [AutoReg(w, lags=4, trend="c").fit() for w in W], repeat=3)
    print(f"AR(4) least squares on {W.shape[0]} windows: batched {ours * 1e3:.2f} ms, statsmodels AutoReg per "
          f"window {sm * 1e3:.1f} ms: {sm / ours:.0f}x")


if __name__ == "__main__":
    main()
