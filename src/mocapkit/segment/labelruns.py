"""Per-frame label sequences to cuts, shared by the K-means and MLP segmenters: a majority-vote filter,
the merging of runs shorter than a minimum length into a neighbour, and the cuts where the label changes."""

from __future__ import annotations

import heapq

import numpy as np

__all__ = ["cuts_at_label_changes", "merge_short_runs", "mode_filter"]


def mode_filter(codes: np.ndarray, n_classes: int, width: int) -> np.ndarray:
    """Majority vote over the ``2 * (width // 2) + 1`` frames centred on each frame (clipped at the
    ends); a frame keeps its own label when that label is among the most frequent ones, otherwise it
    takes the most frequent label with the lowest code."""
    n = codes.size
    half = width // 2
    if half == 0 or n == 0:
        return codes.copy()
    counts = np.zeros((n + 1, n_classes), dtype=np.int64)
    np.cumsum(np.eye(n_classes, dtype=np.int64)[codes], axis=0, out=counts[1:])
    idx = np.arange(n)
    window = counts[np.minimum(idx + half + 1, n)] - counts[np.maximum(idx - half, 0)]
    best = window.argmax(axis=1)
    keep = window[idx, codes] >= window[idx, best]
    return np.where(keep, codes, best)


def merge_short_runs(codes: np.ndarray, min_len: int) -> np.ndarray:
    """Relabel runs shorter than ``min_len`` frames.

    The shortest run (the earliest among equals) is repeatedly given the label of its longer
    neighbour (the preceding one on a tie, the only one at either end), and neighbouring runs with
    the same label are joined, until every run has ``min_len`` frames or only one run is left.
    """
    n = codes.size
    if n == 0 or min_len <= 1:
        return codes.copy()
    change = np.flatnonzero(np.diff(codes)) + 1
    starts = np.concatenate(([0], change)).tolist()
    lengths = np.diff(np.concatenate((starts, [n]))).tolist()
    values = codes[starts].tolist()
    k = len(starts)
    prev = list(range(-1, k - 1))
    nxt = list(range(1, k + 1))
    nxt[-1] = -1
    alive = [True] * k
    n_alive = k
    heap = [(lengths[i], starts[i], i) for i in range(k)]
    heapq.heapify(heap)
    while heap and n_alive > 1:
        length, _, i = heapq.heappop(heap)
        if not alive[i] or length != lengths[i]:
            continue  # stale entry
        if length >= min_len:
            break
        p, q = prev[i], nxt[i]
        if p < 0:
            j = q
        elif q < 0:
            j = p
        else:
            j = p if lengths[p] >= lengths[q] else q
        # run i is absorbed by run j
        lengths[j] += lengths[i]
        starts[j] = min(starts[j], starts[i])
        alive[i] = False
        n_alive -= 1
        if j == p:
            nxt[p] = q
            if q >= 0:
                prev[q] = p
            other = q
        else:
            prev[q] = p
            if p >= 0:
                nxt[p] = q
            other = p
        if other >= 0 and values[other] == values[j]:  # the run beyond i has j's label: join it
            lengths[j] += lengths[other]
            starts[j] = min(starts[j], starts[other])
            alive[other] = False
            n_alive -= 1
            if other == nxt[j]:
                nxt[j] = nxt[other]
                if nxt[other] >= 0:
                    prev[nxt[other]] = j
            else:
                prev[j] = prev[other]
                if prev[other] >= 0:
                    nxt[prev[other]] = j
        heapq.heappush(heap, (lengths[j], starts[j], j))
    out = np.empty_like(codes)
    for i in range(k):
        if alive[i]:
            out[starts[i] : starts[i] + lengths[i]] = values[i]
    return out


def cuts_at_label_changes(codes: np.ndarray) -> np.ndarray:
    return (np.flatnonzero(np.diff(codes)) + 1).astype(np.int64)
