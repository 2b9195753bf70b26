"""``mocapkit bench``: time per sample of every method, batch and streaming, vs mean segment length.

Data: smooth synthetic orientation streams at 100 Hz (a random walk of the rotation vector, low-pass
filtered: joint-like motion with no static stretches), so that the sizes asked for (31 channels ×
100k frames) exist without a skeleton reader. Thresholds are found per method to hit mean segment
lengths 2..500 (maximum segment length 1000, as in the paper). All ratios are taken within one run (the machine is
shared and noisy); each timing is the best of several repeats.
"""

from __future__ import annotations

import time
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from mocapkit.motion import Signal
from mocapkit.pla import Encoder, compress
from mocapkit.pla import fastsw as fastsw_mod
from mocapkit.pla.base import prepared_values
from mocapkit.pla.tune import threshold_for_icr
from mocapkit.quat import from_scipy

if TYPE_CHECKING:
    from rich.console import RenderableType

METHODS = ("fastsw", "sw", "cplr", "swing", "anglesw")
TARGET_LENGTHS = (2, 5, 10, 20, 50, 100, 200, 500)
MAX_SEGMENT_LENGTH = 1000  # as in the paper's experiments


def synthetic_orientations(channels: int, frames: int, rate: float = 100.0, seed: int = 0):
    """``(times (N,), quats (C, N, 4))``: smooth random rotations, scalar-first."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / rate
    q = np.empty((channels, frames, 4))
    for c in range(channels):
        steps = gaussian_filter1d(rng.normal(0.0, 0.02, size=(frames, 3)), sigma=rate / 10, axis=0)
        rv = np.cumsum(steps, axis=0) * 10.0
        q[c] = from_scipy(Rotation.from_rotvec(rv))
    return t, q


def _best_ns(fn, n_samples: int, repeats: int = 3) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        best = min(best, time.perf_counter_ns() - t0)
    return best / n_samples


#: streaming modes: one push() per sample on the compiled numba kernels (the encoder before the C
#: library), one push() per sample on C, push_many() of STREAM_BATCH samples per call on C
STREAM_MODES = ("stream-numba", "stream", "stream-batch")
STREAM_BATCH = 1000


def _stream_ns(sig: Signal, method: str, th: float, n: int, mode: str = "stream") -> float:
    enc = Encoder(method, th, max_segment_length=MAX_SEGMENT_LENGTH,
                  engine="numba" if mode == "stream-numba" else "c")
    if mode == "stream-batch":
        ts, xs = sig.times[:n], sig.values[:n]
        t0 = time.perf_counter_ns()
        for a in range(0, n, STREAM_BATCH):
            enc.push_many(ts[a:a + STREAM_BATCH], xs[a:a + STREAM_BATCH])
        enc.flush()
        return (time.perf_counter_ns() - t0) / n
    ts = sig.times[:n].tolist()
    xs = sig.values[:n].tolist()
    t0 = time.perf_counter_ns()
    for t, x in zip(ts, xs, strict=True):
        enc.push(t, x)
    enc.flush()
    return (time.perf_counter_ns() - t0) / n


def run_bench(channels: int = 31, frames: int = 100_000, quick: bool = False, progress=None):
    from rich.table import Table

    if quick:
        channels, frames = min(channels, 4), min(frames, 5000)
    n1 = 20_000 if not quick else 3000
    t, q = synthetic_orientations(1, n1, seed=1)
    sig = Signal(t, q[0], name="synthetic")
    X = prepared_values(sig)
    records = []
    pairs: dict[tuple[str, int, str], dict] = {}
    for method in METHODS:
        # anglesw does O(segment) work per sample: a shorter signal keeps its bisection affordable
        s_m = sig if method != "anglesw" else Signal(sig.times[: n1 // 4], sig.values[: n1 // 4])
        X_m = X[: len(s_m)]
        compress(s_m, method, 1e-3, MAX_SEGMENT_LENGTH)  # compile
        for L in TARGET_LENGTHS:
            if L > len(s_m) // 4:  # too few segments to measure (only in --quick)
                continue
            comp = threshold_for_icr(s_m, method, 1.0 / L, MAX_SEGMENT_LENGTH)
            th = comp.threshold
            msl = comp.mean_segment_length
            ns_b = _best_ns(partial(compress, s_m, method, th, MAX_SEGMENT_LENGTH, _prepared=X_m), len(s_m))
            n_stream = min(len(s_m), 5000 if not quick else 1000)
            timed = [("batch", ns_b)] + [(mode, min(_stream_ns(s_m, method, th, n_stream, mode) for _ in range(2)))
                                         for mode in STREAM_MODES]
            for mode, ns in timed:
                rec = {"method": method, "mode": mode, "target_segment_length": L,
                       "mean_segment_length": msl, "threshold": th, "ns_per_sample": ns}
                records.append(rec)
                pairs[(method, L, mode)] = rec
        if progress is not None:
            progress.print(f"  {method}: timed at {len(TARGET_LENGTHS)} segment lengths")

    # many channels in one call (fastSW, numba prange over channels)
    tm, qm = synthetic_orientations(channels, frames, seed=2)
    Xm = np.stack([prepared_values(Signal(tm, qm[c])) for c in range(channels)])
    th_many = pairs[("fastsw", 10, "batch")]["threshold"]
    fastsw_mod.batch_many(tm[:10], np.ascontiguousarray(Xm[:, :10]), th_many, 0)  # compile
    total = channels * frames
    ns_many = _best_ns(lambda: fastsw_mod.batch_many(tm, Xm, th_many, 0), total)
    ns_many_serial = _best_ns(lambda: [fastsw_mod.batch(tm, Xm[c], th_many, 0) for c in range(channels)], total)
    counts, _ = fastsw_mod.batch_many(tm, Xm, th_many, 0)
    many_len = float((frames - 1) * channels / max((counts - 1).sum(), 1))
    records.append({"method": "fastsw", "mode": "batch", "channels": channels, "frames": frames,
                    "parallel": True, "mean_segment_length": many_len, "threshold": th_many, "ns_per_sample": ns_many})
    records.append({"method": "fastsw", "mode": "batch", "channels": channels, "frames": frames,
                    "parallel": False, "mean_segment_length": many_len, "threshold": th_many,
                    "ns_per_sample": ns_many_serial})

    tab = Table(title=f"ns per sample (best of repeats; one channel of {n1} samples, 4-D; anglesw {n1 // 4})")
    tab.add_column("method")
    tab.add_column("mode")
    for L in TARGET_LENGTHS:
        tab.add_column(f"L≈{L}", justify="right")
    for method in METHODS:
        for mode in ("batch", *STREAM_MODES):
            tab.add_row(method, mode, *[f"{pairs[(method, L, mode)]['ns_per_sample']:.0f}"
                                        if (method, L, mode) in pairs else "–" for L in TARGET_LENGTHS])
        gain = {
            L: pairs[(method, L, "stream-numba")]["ns_per_sample"] / pairs[(method, L, "stream-batch")]["ns_per_sample"]
            for L in TARGET_LENGTHS
            if (method, L, "stream-batch") in pairs
        }
        tab.add_row(
            method, "numba push / C push_many", *[f"{gain[L]:.0f}×" if L in gain else "–" for L in TARGET_LENGTHS]
        )
        records.append({"method": method, "mode": "stream-numba/stream-batch", "ratio_by_target_segment_length": gain})
    ratio = {L: pairs[("sw", L, "batch")]["ns_per_sample"] / pairs[("fastsw", L, "batch")]["ns_per_sample"]
             for L in TARGET_LENGTHS if ("sw", L, "batch") in pairs}
    tab.add_row("SW/fastSW", "batch", *[f"{ratio[L]:.1f}×" if L in ratio else "–" for L in TARGET_LENGTHS])
    records.append({"method": "sw/fastsw", "mode": "batch", "ratio_by_target_segment_length": ratio})
    lines: list[RenderableType] = [tab,
             f"fastSW batch, {channels} channels × {frames} frames in one call: {ns_many:.2f} ns/sample "
             f"(parallel), {ns_many_serial:.2f} ns/sample (one channel after another); "
             f"mean segment length {many_len:.1f}"]
    from rich.console import Group

    return records, Group(*lines)
