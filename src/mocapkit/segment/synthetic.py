"""Synthetic motion-like signals with known action changes, for calibrating and testing the choice of
the number of segments (:mod:`mocapkit.segment.autok`) without touching any labelled take.

Each action is a rhythmic, piecewise-stationary multichannel pattern, as limb-bone directions are
during walking, jumping jacks or squats: per channel an offset, a periodic part with a period shared
by the channels of the action (0.6–2.5 s) and two harmonics, slow amplitude drift and AR(1) noise.
Consecutive actions are drawn independently; they blend linearly over a short transition.
"""

from __future__ import annotations

import numpy as np

from mocapkit.errors import InvalidParameterError

__all__ = ["motion_like"]


def _action(rng: np.random.Generator, n: int, d: int, rate: float) -> np.ndarray:
    t = np.arange(n) / rate
    period = rng.uniform(0.6, 2.5)
    offset = rng.normal(0.0, 1.0, d)
    amp = rng.uniform(0.0, 1.2, d) * (rng.random(d) < 0.7)
    phase = rng.uniform(0, 2 * np.pi, d)
    h2 = rng.uniform(0.0, 0.5, d)
    drift = 1.0 + 0.2 * np.sin(2 * np.pi * t[:, None] / rng.uniform(5, 20) + rng.uniform(0, 6.3, d))
    w = 2 * np.pi * t[:, None] / period
    x = offset + drift * amp * (np.sin(w + phase) + h2 * np.sin(2 * w + 2 * phase))
    noise = np.empty((n, d))
    e = rng.normal(0.0, 0.15, (n, d))
    noise[0] = e[0]
    for i in range(1, n):
        noise[i] = 0.9 * noise[i - 1] + e[i]
    return x + noise


def motion_like(n_changes: int, *, rate: float = 30.0, d: int = 8, min_len_s: float = 4.0,
                max_len_s: float = 15.0, transition_s: float = 0.5, seed=None) -> tuple[np.ndarray, np.ndarray]:
    """A ``(n, d)`` signal at ``rate`` Hz with ``n_changes`` action changes and their frames.

    Segment lengths are uniform in ``[min_len_s, max_len_s]`` seconds; each change is the middle of a
    linear blend of ``transition_s`` seconds between two independently drawn actions.
    """
    if int(n_changes) != n_changes or n_changes < 0:
        raise InvalidParameterError(f"n_changes must be a non-negative integer, got {n_changes}")
    if not 0 < min_len_s <= max_len_s or rate <= 0 or d < 1 or transition_s < 0:
        raise InvalidParameterError("need 0 < min_len_s <= max_len_s, rate > 0, d >= 1, transition_s >= 0")
    rng = np.random.default_rng(seed)
    lens = np.round(rng.uniform(min_len_s, max_len_s, n_changes + 1) * rate).astype(int)
    cuts = np.cumsum(lens)[:-1]
    half = int(round(transition_s * rate / 2))
    starts = np.concatenate([[0], cuts])
    acts = [_action(rng, int(m) + 2 * half, d, rate) for m in lens]  # `half` extra samples each side
    x = np.concatenate([a[half:half + m] for a, m in zip(acts, lens, strict=True)])
    if half:
        wgt = np.linspace(0.0, 1.0, 2 * half)[:, None]
        for i, c in enumerate(cuts):  # blend across each change: frames c - half .. c + half - 1
            g = np.arange(c - half, c + half)
            prev = acts[i][g - starts[i] + half]
            nxt = acts[i + 1][g - c + half]
            x[g] = (1 - wgt) * prev + wgt * nxt
    return x, cuts.astype(np.int64)
