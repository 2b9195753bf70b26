"""ARMA segmenter speed: the whole pipeline on CMU 86_01 (4,579 frames) and on a 5,000-frame take,
and the per-window AR fit batched in NumPy vs one statsmodels AutoReg per window (ratio in one run).

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
    limbs = motion_features(motion).limbs
    t_feat = time.perf_counter() - t0
    seg = ARMASegmenter()
    bmin, bmed = best_of(lambda: seg.fit_predict(limbs))
    print(f"86_01 ({limbs.shape[0]} frames, 4 limbs): features (FK + angles) {t_feat:.3f} s; "
          f"ARMA segmentation best {bmin:.3f} s, median {bmed:.3f} s")
    X5 = np.concatenate([limbs, limbs[: 5000 - limbs.shape[0]]])
    bmin, bmed = best_of(lambda: seg.fit_predict(X5))
    print(f"5,000-frame take: ARMA segmentation best {bmin:.3f} s, median {bmed:.3f} s (target < 0.5 s; paper Table 6: 728.5 s)")

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
