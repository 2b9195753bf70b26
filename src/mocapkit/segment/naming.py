"""Actions named across takes: the found segments of one or many takes clustered into action classes
without labels, one letter per segment ("A B A C A D C" as the HACA work prints for CMU 86_01).

Steps (:func:`name_actions`):

1. **Features.** Each take is an ``(n, d)`` array (the 4 limb angles of
   :func:`mocapkit.segment.features.motion_features`, or more columns); all takes must have the same
   ``d``. Every channel is standardised over the frames of all takes pooled (one mean and standard
   deviation per channel, so that a subject's posture differences stay visible).
2. **Distances between segments.** ``distance="mmd"`` (default): the maximum mean discrepancy with a
   Gaussian kernel ``exp(-gamma |x - y|^2)``, ``gamma`` = 1 / median squared distance between frames
   (median heuristic on at most 1,000 pooled frames); the square root of the biased estimate of MMD²
   (never negative, unlike the unbiased one, whose clipping at 0 made many spreads exactly 0). It
   compares the *distributions* of poses of two segments, ignoring frame order: cheap, and two stretches of a periodic
   action (walking) match whatever their phase and number of cycles. Each segment is represented by at most
   ``max_frames`` evenly spaced frames. ``distance="dtw"``: :func:`mocapkit.segment.similarity.dtw` on the same
   standardised, thinned segments (imported when asked for).
3. **Clustering.** Average-linkage hierarchical clustering (:func:`scipy.cluster.hierarchy.linkage`)
   of the distance matrix.
4. **Number of classes, without labels.** ``rule="threshold"`` (default): the dendrogram is cut at
   ``threshold_scale * spread``, where ``spread`` measures how much two stretches of *one* action
   differ, without labels: ``spread="blocks"`` (default), the median distance between neighbouring
   blocks of ``block`` frames (2 s at 120 Hz) of every take -- most neighbouring blocks lie inside one
   action, and the measure does not depend on the cuts; ``spread="halves"``, the median distance
   between the two halves of every segment of at least 16 frames (it grows when the cuts are bad: a
   segment straddling two actions has dissimilar halves, and short segments have noisy halves). The
   rule can give one class (all segments alike) and as many classes as segments (every action
   different, as in the mocap6 takes), which a silhouette rule cannot.
   ``THRESHOLD_SCALE`` was set on synthetic data only (``benchmarks/naming_bench.py --calibrate``):
   segments of 300--900 frames drawn from random 4-channel stationary processes (per channel two
   harmonics of a period of 0.5--2 s with the process's offset, amplitudes and phases, plus AR(1)
   noise), each segment with its own phase and a jitter of 10 % on period and amplitude and 0.1 on
   offset (a person never repeats an action exactly); 200 takes of k = 1..5 processes x 3 segments
   (40 per k). The scale is the multiple (0.5 to 4.0 by 0.1) that finds exactly k classes most often
   on them: 1.3 for blocks (96 % of the takes), 2.4 for halves (98 %). On fresh synthetic takes,
   exact k for k = 1..5: 94, 96, 98, 100, 94 % (blocks), 98, 98, 98, 100, 94 % (halves). In spreads,
   the largest distance between two segments of one process is 0.50 / 1.04 / 1.36 (median / 95 % /
   99 %, blocks) and the mean distance between two processes is above 1.44 in 99 % of pairs. Under
   bad cuts the block spread degrades less (frame accuracy on synthetic takes of 2--5 processes, true
   / shifted by up to 100 frames / 2 extra cuts / a cut every 400 / every 200 frames: 1.00, 0.94, 0.97,
   0.81, 0.88 with blocks; 1.00, 0.92, 0.95, 0.72, 0.52 with halves), hence the default (details in
   ``docs/segmentation/naming.md``). Real actions are closer to each other than random processes;
   that is where the rule errs. The threshold was calibrated for the MMD distance; with
   ``distance="dtw"`` the same multiple is used, uncalibrated.
   ``rule="silhouette"``: the ``k`` in ``2 .. min(max_classes, segments - 1)`` of best silhouette
   (scikit-learn, precomputed distances); with fewer than 3 segments it falls back to the threshold.
   ``n_classes=k`` forces ``k`` classes.
5. **Letters.** Classes are lettered in order of first appearance (takes in the given order, segments
   in time order): the first segment is ``A``, the next segment of a new class ``B``, ...; after ``Z``
   come ``AA``, ``AB``, ...

The caller decides the cuts (reference cuts, a segmenter's); a cut ``c`` starts a segment at frame
``c``, as everywhere in :mod:`mocapkit.segment`.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment._common import float_param, int_param, standardise

__all__ = ["DISTANCES", "RULES", "SPREADS", "THRESHOLD_SCALE", "Naming", "class_letter", "name_actions",
           "name_segments"]

#: Distances between segments.
DISTANCES = ("mmd", "dtw")
#: Rules choosing the number of classes.
RULES = ("threshold", "silhouette")
#: How the within-action spread is measured.
SPREADS = ("blocks", "halves")
#: Dendrogram cut as a multiple of the spread, per way of measuring it (set on synthetic data; module docstring).
THRESHOLD_SCALE = MappingProxyType({"blocks": 1.3, "halves": 2.4})
#: Shortest segment whose halves enter the spread (``spread="halves"``); blocks are at least half of it.
MIN_SPREAD_FRAMES = 16


@dataclass(frozen=True, eq=False)
class Naming:
    """Action classes of the segments of one or many takes.

    Attributes
    ----------
    letters
        Per take, one letter per segment (``("A", "B", "A", ...)``).
    classes
        Per take, the class index of each segment (``0`` is ``"A"``), an ``int64`` array.
    bounds
        Per take, the segment boundaries ``[0, cut_1, ..., n_frames]``.
    n_classes
        Number of classes found.
    distances
        ``(S, S)`` distances between all segments, takes in order then segments in time order.
    spread
        The spread of one action (median distance between neighbouring blocks, or between segment
        halves; ``spread`` option).
    threshold
        Height at which the dendrogram was cut (``None`` with ``rule="silhouette"`` or ``n_classes``).
    rule
        ``"threshold"``, ``"silhouette"`` or ``"fixed"`` (``n_classes`` given).
    """

    letters: tuple[tuple[str, ...], ...]
    classes: tuple[np.ndarray, ...]
    bounds: tuple[np.ndarray, ...]
    n_classes: int
    distances: np.ndarray
    spread: float
    threshold: float | None
    rule: str

    def frame_letters(self, take: int = 0) -> np.ndarray:
        """The letter of every frame of take ``take`` (object array)."""
        b = self.bounds[take]
        return np.repeat(np.asarray(self.letters[take], dtype=object), np.diff(b))

    def frame_classes(self, take: int = 0) -> np.ndarray:
        """The class index of every frame of take ``take``."""
        b = self.bounds[take]
        return np.repeat(self.classes[take], np.diff(b))


def class_letter(i: int) -> str:
    """``0 -> "A"``, ..., ``25 -> "Z"``, ``26 -> "AA"``, ``27 -> "AB"``, ... (spreadsheet columns)."""
    i = int(i)
    if i < 0:
        raise InvalidParameterError(f"class index must be >= 0, got {i}")
    s = ""
    i += 1
    while i:
        i, r = divmod(i - 1, 26)
        s = chr(65 + r) + s
    return s


# --------------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------------


def _check_take(x, k: int) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"take {k}: features must be a numeric (frames, features) array") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] == 0 or a.shape[1] == 0:
        raise InvalidParameterError(
            f"take {k}: features must be a non-empty (frames, features) array, got shape {a.shape}"
        )
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise InvalidParameterError(f"take {k}: non-finite feature at frame {i}, column {j}")
    return a


def _check_cuts(cuts, n: int, k: int) -> np.ndarray:
    values = np.asarray(cuts, dtype=object).reshape(-1).tolist()
    out = np.empty(len(values), dtype=np.int64)
    for i, v in enumerate(values):
        ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
        if not ok or not np.isfinite(float(v)) or not float(v).is_integer():
            raise InvalidParameterError(f"take {k}: cut {i} is not an integer frame: {v!r}")
        out[i] = int(v)
    if out.size and (out[0] <= 0 or out[-1] >= n or np.any(np.diff(out) <= 0)):
        raise InvalidParameterError(
            f"take {k}: cuts must be strictly increasing frames inside (0, {n}), got {out.tolist()}"
        )
    return out


def _as_takes(takes_features, takes_cuts) -> tuple[list[np.ndarray], list[np.ndarray]]:
    single = isinstance(takes_features, np.ndarray) and takes_features.ndim == 2
    feats = [takes_features] if single else list(takes_features)
    cuts = [takes_cuts] if single else list(takes_cuts)
    if not feats:
        raise InvalidParameterError("no take to name")
    if len(feats) != len(cuts):
        raise InvalidParameterError(f"{len(feats)} takes but {len(cuts)} lists of cuts")
    feats = [_check_take(x, k) for k, x in enumerate(feats)]
    d = feats[0].shape[1]
    for k, x in enumerate(feats):
        if x.shape[1] != d:
            raise InvalidParameterError(f"take {k} has {x.shape[1]} feature columns, take 0 has {d}")
    cuts = [_check_cuts(c, x.shape[0], k) for k, (x, c) in enumerate(zip(feats, cuts, strict=True))]
    return feats, cuts


# --------------------------------------------------------------------------------------------------
# distances
# --------------------------------------------------------------------------------------------------


def _thin(z: np.ndarray, max_frames: int) -> np.ndarray:
    if z.shape[0] <= max_frames:
        return z
    return z[np.round(np.linspace(0, z.shape[0] - 1, max_frames)).astype(np.int64)]


def _mmd_matrix(parts: list[np.ndarray], gamma: float) -> np.ndarray:
    """MMD between all pairs of ``parts``: the square root of the biased (V-statistic) MMD², which is
    never negative; its bias ``(1 - mean k)/m`` per part is a noise floor that grows with the part's
    own variability (parts are thinned to a common size, so the floors are comparable)."""
    from scipy.spatial.distance import cdist

    stacked = np.concatenate(parts)
    sizes = np.array([p.shape[0] for p in parts])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    sums: np.ndarray = np.empty((len(parts), len(parts)))
    for i, p in enumerate(parts):
        g = np.exp(-gamma * cdist(p, stacked, "sqeuclidean"))
        sums[i] = np.add.reduceat(g.sum(axis=0), starts)
    sums = 0.5 * (sums + sums.T)
    mean = sums / np.outer(sizes, sizes).astype(np.float64)
    self_mean = np.diag(mean)
    d = np.sqrt(np.maximum(self_mean[:, None] + self_mean[None, :] - 2.0 * mean, 0.0))
    np.fill_diagonal(d, 0.0)
    return d


def _pair_mmd(a: np.ndarray, b: np.ndarray, gamma: float) -> float:
    return float(_mmd_matrix([a, b], gamma)[0, 1])


def _dtw_function():
    try:
        from mocapkit.segment.similarity import dtw
    except ImportError:
        raise InvalidParameterError(
            "distance='dtw' needs mocapkit.segment.similarity.dtw, which this installation lacks; use distance='mmd'"
        ) from None
    return dtw


def _dtw_value(dtw, a: np.ndarray, b: np.ndarray) -> float:
    v = dtw(a, b)
    v = getattr(v, "distance", v)
    return float(v)


def _pair_function(distance: str, gamma: float, max_frames: int):
    """The distance between two (standardised) stretches, each thinned to ``max_frames``."""
    if distance == "mmd":
        return lambda a, b: _pair_mmd(_thin(a, max_frames), _thin(b, max_frames), gamma)
    dtw = _dtw_function()
    return lambda a, b: _dtw_value(dtw, _thin(a, max_frames), _thin(b, max_frames))


def _distances(segs: list[np.ndarray], distance: str, gamma: float, max_frames: int) -> np.ndarray:
    """Distance matrix between all segments."""
    thin = [_thin(s, max_frames) for s in segs]
    if distance == "mmd":
        return _mmd_matrix(thin, gamma)
    pair = _pair_function(distance, gamma, max_frames)
    n = len(thin)
    d = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            d[i, j] = d[j, i] = pair(thin[i], thin[j])
    return d


def _spread_values(zs: list[np.ndarray], segs: list[np.ndarray], spread: str, block: int, pair) -> np.ndarray:
    """Within-action distances the threshold is scaled by: neighbouring blocks of ``block`` frames
    of every take (``"blocks"``) or the two halves of every segment (``"halves"``)."""
    out = []
    if spread == "blocks":
        for z in zs:
            w = min(block, z.shape[0] // 2)
            if w < MIN_SPREAD_FRAMES // 2:
                continue
            nb = z.shape[0] // w
            out += [pair(z[j * w:(j + 1) * w], z[(j + 1) * w:(j + 2) * w]) for j in range(nb - 1)]
    else:
        out = [pair(s[: s.shape[0] // 2], s[s.shape[0] // 2:]) for s in segs if s.shape[0] >= MIN_SPREAD_FRAMES]
    if not out:
        raise InvalidParameterError(
            f"no take or segment is long enough ({MIN_SPREAD_FRAMES} frames) to measure the spread of an action"
        )
    return np.asarray(out)


# --------------------------------------------------------------------------------------------------
# clustering
# --------------------------------------------------------------------------------------------------


def _first_appearance(labels: np.ndarray) -> np.ndarray:
    order: dict[int, int] = {}
    return np.array([order.setdefault(int(v), len(order)) for v in labels], dtype=np.int64)


def _cluster(
    d: np.ndarray, rule: str, n_classes: int | None, threshold: float, max_classes: int
) -> tuple[np.ndarray, str, float | None]:
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    s = d.shape[0]
    if s == 1:
        return np.zeros(1, dtype=np.int64), "fixed" if n_classes else rule, None if n_classes else threshold
    tree = linkage(squareform(d, checks=False), method="average")
    if n_classes is not None:
        return fcluster(tree, min(n_classes, s), criterion="maxclust"), "fixed", None
    if rule == "silhouette" and s >= 3:
        from sklearn.metrics import silhouette_score

        best, best_lab = -np.inf, None
        for k in range(2, min(max_classes, s - 1) + 1):
            lab = fcluster(tree, k, criterion="maxclust")
            if len(np.unique(lab)) < 2:
                continue
            sc = silhouette_score(d, lab, metric="precomputed")
            if sc > best:
                best, best_lab = sc, lab
        if best_lab is not None:
            return best_lab, "silhouette", None
    return fcluster(tree, threshold, criterion="distance"), "threshold", threshold


def name_actions(
    takes_features,
    takes_cuts,
    *,
    distance: str = "mmd",
    rule: str = "threshold",
    n_classes: int | None = None,
    threshold_scale: float | None = None,
    max_classes: int = 8,
    max_frames: int = 300,
    gamma: float | None = None,
    spread: str = "blocks",
    block: int = 240,
) -> Naming:
    """Cluster the segments of one or many takes into action classes and letter them.

    Parameters
    ----------
    takes_features
        One ``(n, d)`` feature array, or a sequence of them (one per take, same ``d``).
    takes_cuts
        The cuts of that take, or a sequence of cut lists (one per take): strictly increasing
        integer frames inside ``(0, n)``; empty for a take of one segment.
    distance
        ``"mmd"`` (default) or ``"dtw"`` (module docstring).
    rule
        ``"threshold"`` (default) or ``"silhouette"``: how the number of classes is chosen.
    n_classes
        Force this number of classes (at most the number of segments); ``None`` (default) lets
        ``rule`` choose.
    threshold_scale
        Dendrogram cut in units of the spread (``rule="threshold"``); ``None`` (default):
        ``THRESHOLD_SCALE[spread]``.
    max_classes
        Largest ``k`` the silhouette rule tries (default 8).
    max_frames
        Frames kept (evenly spaced) per segment or half-segment for the distances (default 300).
    gamma
        Kernel bandwidth of the standardised features (``None``: median heuristic).
    spread
        ``"blocks"`` (default) or ``"halves"``: what the threshold is a multiple of (module docstring).
    block
        Block length in frames for ``spread="blocks"`` (default 240: 2 s at 120 Hz; scale it with the
        frame rate).

    Returns
    -------
    Naming

    Raises
    ------
    InvalidParameterError
        No take, a take without frames or with non-finite features, takes with different numbers
        of features, cuts that are not integers strictly increasing inside the take, no segment of
        16 frames or more, or an unknown option.
    """
    if distance not in DISTANCES:
        raise InvalidParameterError(f"distance must be one of {', '.join(DISTANCES)}, got {distance!r}")
    if rule not in RULES:
        raise InvalidParameterError(f"rule must be one of {', '.join(RULES)}, got {rule!r}")
    if n_classes is not None:
        n_classes = int_param(n_classes, "n_classes", 1)
    max_classes = int_param(max_classes, "max_classes", 2)
    max_frames = int_param(max_frames, "max_frames", 8)
    if spread not in SPREADS:
        raise InvalidParameterError(f"spread must be one of {', '.join(SPREADS)}, got {spread!r}")
    block = int_param(block, "block", MIN_SPREAD_FRAMES // 2)
    threshold_scale = (
        THRESHOLD_SCALE[spread] if threshold_scale is None else float_param(threshold_scale, "threshold_scale")
    )
    feats, cuts = _as_takes(takes_features, takes_cuts)

    z_all = standardise(np.concatenate(feats))
    if gamma is None:
        from mocapkit.segment.cpdpenalty import median_gamma

        gamma = median_gamma(z_all)
    else:
        gamma = float_param(gamma, "gamma")
    bounds, segs = [], []
    start = 0
    for x, c in zip(feats, cuts, strict=True):
        n = x.shape[0]
        z = z_all[start:start + n]
        start += n
        b = np.concatenate([[0], c, [n]]).astype(np.int64)
        bounds.append(b)
        segs += [z[b[i]:b[i + 1]] for i in range(len(b) - 1)]
    if n_classes is not None and n_classes > len(segs):
        raise InvalidParameterError(f"n_classes={n_classes} but there are only {len(segs)} segments")

    d = _distances(segs, distance, gamma, max_frames)
    zs = []
    start = 0
    for x in feats:
        zs.append(z_all[start:start + x.shape[0]])
        start += x.shape[0]
    spread_val = float(np.median(_spread_values(zs, segs, spread, block, _pair_function(distance, gamma, max_frames))))
    labels, used_rule, thr = _cluster(d, rule, n_classes, threshold_scale * spread_val, max_classes)
    cls = _first_appearance(np.asarray(labels))
    per_take, letters, i = [], [], 0
    for b in bounds:
        k = len(b) - 1
        c = cls[i:i + k]
        i += k
        c.setflags(write=False)
        per_take.append(c)
        letters.append(tuple(class_letter(v) for v in c))
    d.setflags(write=False)
    return Naming(
        letters=tuple(letters),
        classes=tuple(per_take),
        bounds=tuple(bounds),
        n_classes=int(cls.max()) + 1,
        distances=d,
        spread=spread_val,
        threshold=thr,
        rule=used_rule,
    )


def name_segments(limbs: np.ndarray, cuts, rate_hz: float) -> Naming | None:
    """The found segments named by action class ("A B A C …", :func:`mocapkit.segment.naming.name_actions`
    on the limb angles, blocks of 2 s); None when no segment is long enough to be named."""
    bounds = np.concatenate([[0], np.asarray(cuts, dtype=np.int64), [limbs.shape[0]]])
    if np.diff(bounds).max() < 16:  # no segment has the 16 frames a distance needs
        return None
    return name_actions(limbs, [int(c) for c in cuts], block=max(8, int(round(2.0 * rate_hz))))
