"""Scores of a predicted segmentation against a reference one.

Every function takes segmentations as *cuts*: sorted 0-based frames ``c`` with ``0 < c < n``, each
starting a new segment, plus the number of frames ``n``. Cuts may be given in any order (they are
sorted) but must be distinct integers inside ``(0, n)``; an empty list means one segment.

* :func:`ri_paper` — the seed paper's accuracy RI of Eq. 33 as its authors compute it (per reference
  cut, the nearest found cut's error over the length of the reference segment it ends);
* :func:`frame_agreement` — frame-level agreement under the best one-to-one matching of segments (a
  score that neither over- nor under-segmentation can inflate; it is *not* the paper's RI);
* :func:`f1_margin` — precision, recall and F1 of the cuts, a prediction counting when it falls
  within a margin (or an annotator interval) of a reference cut, with one-to-one matching;
* :func:`covering` — the segmentation Covering of the TSSB benchmark (Ermshaus et al., DMKD 2023).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from mocapkit.errors import InvalidParameterError

__all__ = [
    "F1Result",
    "covering",
    "f1_margin",
    "frame_agreement",
    "ri_paper",
    "segments_from_cuts",
]


# --------------------------------------------------------------------------------------------------
# validation and segment overlaps
# --------------------------------------------------------------------------------------------------


def _check_n(n: object) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InvalidParameterError(f"the number of frames must be a positive integer, got {n!r}")
    return int(n)


def _as_int_array(values: object, name: str) -> np.ndarray:
    """``values`` as a 1-D int64 array; integral floats are accepted, anything else is an error."""
    try:
        a = np.asarray(values)
    except (TypeError, ValueError):  # ragged nesting
        raise InvalidParameterError(f"{name} must be a 1-D sequence of frames") from None
    if a.ndim != 1:
        raise InvalidParameterError(f"{name} must be a 1-D sequence of frames, got shape {a.shape}")
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.dtype.kind in "iu":
        return a.astype(np.int64)
    if a.dtype.kind == "f":
        if not np.all(np.isfinite(a)) or np.any(a != np.round(a)):
            bad = a[~np.isfinite(a) | (a != np.round(a))][0]
            raise InvalidParameterError(f"{name} must be integer frames, got {bad!r}")
        return a.astype(np.int64)
    raise InvalidParameterError(f"{name} must be integer frames, got dtype {a.dtype}")


def _check_cuts(cuts: object, n: int, name: str) -> np.ndarray:
    """Sorted int64 cuts, each in ``(0, n)``, without duplicates."""
    c = np.sort(_as_int_array(cuts, name))
    if c.size == 0:
        return c
    out = c[(c <= 0) | (c >= n)]
    if out.size:
        raise InvalidParameterError(
            f"{name} must lie strictly inside (0, {n}) (0-based starts of new segments), "
            f"got {int(out[0])}"
        )
    dup = c[1:][c[1:] == c[:-1]]
    if dup.size:
        raise InvalidParameterError(f"{name} contain the frame {int(dup[0])} more than once")
    return c


def _bounds(cuts: np.ndarray, n: int) -> np.ndarray:
    """Segment boundaries ``[0, *cuts, n]``: segment ``i`` is ``[b[i], b[i+1])``."""
    return np.concatenate(([0], cuts, [n])).astype(np.int64)


def _pieces(ref: np.ndarray, pred: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The common refinement of two segmentations.

    Every non-empty intersection of a reference segment and a predicted segment is one contiguous
    piece between consecutive boundaries of the union of both cut sets. Returns, per piece, the
    reference segment index, the predicted segment index and the piece length.
    """
    b = _bounds(np.union1d(ref, pred), n)
    starts = b[:-1]
    ri = np.searchsorted(ref, starts, side="right")
    pi = np.searchsorted(pred, starts, side="right")
    return ri, pi, np.diff(b)


def _overlap_matrix(ref: np.ndarray, pred: np.ndarray, n: int) -> np.ndarray:
    """``(k_ref + 1, k_pred + 1)`` matrix of frames shared by reference and predicted segments."""
    ri, pi, size = _pieces(ref, pred, n)
    m = np.zeros((ref.size + 1, pred.size + 1), dtype=np.int64)
    m[ri, pi] = size
    return m


# --------------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------------


def segments_from_cuts(cuts, n: int) -> list[tuple[int, int]]:
    """Segments of a segmentation, as half-open frame ranges.

    Parameters
    ----------
    cuts
        0-based cut frames, distinct integers in ``(0, n)``.
    n
        Number of frames.

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` of every segment, in order: frames ``start .. stop - 1``. They tile
        ``0 .. n - 1``; there are ``len(cuts) + 1`` of them.

    Raises
    ------
    InvalidParameterError
        If ``n`` is not a positive integer or the cuts are invalid.
    """
    n = _check_n(n)
    b = _bounds(_check_cuts(cuts, n, "cuts"), n)
    return [(int(s), int(e)) for s, e in zip(b[:-1], b[1:], strict=True)]


def ri_paper(pred_cuts, ref_cuts, n: int) -> float:
    """The seed paper's accuracy RI (Eq. 33) as its authors compute it.

    Eq. 33 reads ``RI = 1 − ER = 1 − |s − N| / N`` ("N is the actual number of frames" of the action); the
    authors' published ``main.m`` computes, for each reference cut ``True(q)`` (in order, with
    ``True(0) = 0``), the found cut ``FS(q)`` nearest to it and

        ``acc(q) = 1 − |FS(q) − True(q)| / (True(q) − True(q−1))``,

    and the paper reports their mean. Ties between two equally near found cuts go to the earlier one
    (MATLAB's ``min`` returns the first). ``acc(q)`` is not clipped: a found cut farther away than
    the reference segment is long gives a negative term, as in ``main.m``.

    Only the distance from each reference cut to the *nearest* found cut counts, so extra cuts cost
    nothing: the metric rewards over-segmentation (cutting every 400 frames scores about 0.83 on the
    shared CMU takes, more than any method that finds the actions; ``segment-bench`` reports it).
    Use :func:`f1_margin` or :func:`frame_agreement` to compare methods.

    Parameters
    ----------
    pred_cuts, ref_cuts
        Predicted and reference 0-based cuts, distinct integers in ``(0, n)``; at least one
        reference cut.
    n
        Number of frames.

    Returns
    -------
    float
        The mean of ``acc(q)``, at most 1; 0 when nothing was found (no term can be computed, and
        finding nothing earns nothing).

    Raises
    ------
    InvalidParameterError
        If ``n`` or the cuts are invalid, or there is no reference cut (the formula has no term).
    """
    n = _check_n(n)
    pred = _check_cuts(pred_cuts, n, "pred_cuts")
    ref = _check_cuts(ref_cuts, n, "ref_cuts")
    if ref.size == 0:
        raise InvalidParameterError("ri_paper needs at least one reference cut (Eq. 33 has one term per cut)")
    if pred.size == 0:
        return 0.0
    dist = np.abs(pred[None, :] - ref[:, None])
    fs = pred[np.argmin(dist, axis=1)]  # argmin: the first (earliest) of equally near cuts
    length = np.diff(np.concatenate(([0], ref)))
    return float(np.mean(1.0 - np.abs(fs - ref) / length))


def frame_agreement(pred_cuts, ref_cuts, n: int) -> float:
    """Frame-level agreement of two segmentations (not the paper's RI: see :func:`ri_paper`).

    Reference and predicted segments are matched one-to-one so that the total number of frames
    shared by matched pairs is maximal (an assignment problem, solved exactly with
    :func:`scipy.optimize.linear_sum_assignment` on the overlap matrix). The score is that total
    divided by ``n``: the fraction of frames whose reference segment is matched to the predicted
    segment containing them; one minus it is the fraction of mis-segmented frames.

    Unmatched segments count entirely as errors, so neither over-segmentation (extra predicted
    segments are left unmatched; predicting every frame as its own segment gives
    ``(len(ref_cuts) + 1) / n``) nor under-segmentation (one predicted segment can only be
    credited to one reference segment) can inflate the score. It is 1 exactly when the two
    segmentations are equal. (Earlier versions of mocapkit called this score ``accuracy_ri``.)

    Parameters
    ----------
    pred_cuts, ref_cuts
        Predicted and reference 0-based cuts, distinct integers in ``(0, n)``.
    n
        Number of frames.

    Returns
    -------
    float
        Agreement in ``[0, 1]`` (in fact ``> 0``: some pair always overlaps).

    Raises
    ------
    InvalidParameterError
        If ``n`` or the cuts are invalid.

    Notes
    -----
    Time and memory are ``O((len(ref_cuts) + 1) * (len(pred_cuts) + 1))`` for the dense overlap
    matrix, plus the cubic-at-worst assignment; fine for action segmentations, heavy when both
    sides have thousands of segments.
    """
    n = _check_n(n)
    pred = _check_cuts(pred_cuts, n, "pred_cuts")
    ref = _check_cuts(ref_cuts, n, "ref_cuts")
    overlap = _overlap_matrix(ref, pred, n)
    rows, cols = linear_sum_assignment(overlap, maximize=True)
    return float(overlap[rows, cols].sum()) / n


@dataclass(frozen=True)
class F1Result:
    """Precision, recall and F1 of predicted cuts (see :func:`f1_margin`).

    Attributes
    ----------
    precision, recall, f1
        Scores in ``[0, 1]``.
    tp
        Number of matched (predicted, reference) pairs: the true positives.
    n_pred, n_ref
        Number of predicted and reference cuts.
    """

    precision: float
    recall: float
    f1: float
    tp: int
    n_pred: int
    n_ref: int


def f1_margin(pred_cuts, ref_cuts, n: int, margin: float, intervals=None) -> F1Result:
    """Precision, recall and F1 of predicted cuts, with a tolerance.

    A predicted cut ``p`` *hits* a reference cut ``r`` when ``|p - r| <= margin`` or, when
    ``intervals`` are given, when ``lo <= p <= hi`` for ``r``'s interval ``[lo, hi]``. Each
    reference cut may be credited to at most one prediction and each prediction to at most one
    reference cut; ``tp`` is the size of a maximum such matching (computed exactly with
    :func:`scipy.sparse.csgraph.maximum_bipartite_matching`, so that e.g. two nearby reference
    cuts are both credited when two predictions can cover them, whatever nearest-first greedy
    would pick). Then ``precision = tp / n_pred``, ``recall = tp / n_ref`` and
    ``f1 = 2 P R / (P + R)``.

    Only the interior cuts are scored; unlike the TCPDBench convention, the start of the series is
    not counted as an always-found change point.

    Conventions for empty sets: no predicted and no reference cuts gives ``P = R = F1 = 1`` (the
    single segment was found). Otherwise an empty side makes its ratio undefined, and it is set
    to 0: no predictions gives ``P = 0`` (and ``R = 0``), no references gives ``R = 0`` (and
    ``P = 0``); in both cases ``F1 = 0``. ``F1 = 0`` also whenever ``P + R = 0``.

    Parameters
    ----------
    pred_cuts, ref_cuts
        Predicted and reference 0-based cuts, distinct integers in ``(0, n)``.
    n
        Number of frames.
    margin
        Tolerance in frames, ``>= 0``.
    intervals
        Optional ``(len(ref_cuts), 2)`` inclusive 0-based tolerance intervals ``[lo, hi]``, one per
        reference cut in the order given (e.g. :attr:`mocapkit.io.skeletal.labels.Reference.intervals`);
        each must contain its cut.

    Returns
    -------
    F1Result

    Raises
    ------
    InvalidParameterError
        If ``n``, the cuts, ``margin`` or ``intervals`` are invalid.
    """
    n = _check_n(n)
    pred = _check_cuts(pred_cuts, n, "pred_cuts")
    ref_raw = _as_int_array(ref_cuts, "ref_cuts")
    ref = _check_cuts(ref_raw, n, "ref_cuts")
    try:
        m = float(margin)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"margin must be a number of frames, got {margin!r}") from None
    if not math.isfinite(m) or m < 0:
        raise InvalidParameterError(f"margin must be finite and >= 0, got {margin!r}")

    # the hit window of reference cut r: [r - margin, r + margin], widened by its interval
    lo = ref - m
    hi = ref + m
    if intervals is not None:
        iv = np.asarray(intervals)
        if iv.size == 0:
            iv = iv.reshape(0, 2)
        if iv.shape != (ref.size, 2):
            raise InvalidParameterError(
                f"intervals must have shape ({ref.size}, 2), one per reference cut, got {iv.shape}"
            )
        iv = _as_int_array(iv.reshape(-1), "intervals").reshape(-1, 2)
        iv = iv[np.argsort(ref_raw, kind="stable")]  # follow the cuts into sorted order
        bad = (iv[:, 0] > ref) | (iv[:, 1] < ref)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InvalidParameterError(
                f"the interval {iv[i].tolist()} does not contain its reference cut {int(ref[i])}"
            )
        # both ranges contain r, so their union is one range
        lo = np.minimum(lo, iv[:, 0])
        hi = np.maximum(hi, iv[:, 1])

    n_pred, n_ref = int(pred.size), int(ref.size)
    if n_pred and n_ref:
        first = np.searchsorted(pred, lo, side="left")
        last = np.searchsorted(pred, hi, side="right")
        counts = last - first
        rows = np.repeat(np.arange(n_ref), counts)
        cols = np.concatenate([np.arange(a, b) for a, b in zip(first, last, strict=True)]).astype(np.int64)
        hits = csr_matrix(
            (np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n_ref, n_pred)
        )
        tp = int(np.count_nonzero(maximum_bipartite_matching(hits, perm_type="column") >= 0))
    else:
        tp = 0

    if n_pred == 0 and n_ref == 0:
        return F1Result(1.0, 1.0, 1.0, 0, 0, 0)
    precision = tp / n_pred if n_pred else 0.0
    recall = tp / n_ref if n_ref else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return F1Result(float(precision), float(recall), float(f1), tp, n_pred, n_ref)


def covering(pred_cuts, ref_cuts, n: int) -> float:
    """Segmentation Covering of the reference by the prediction (TSSB benchmark).

    With ``G`` the reference segments and ``S`` the predicted segments (both tiling
    ``0 .. n - 1``; the boundaries 0 and ``n`` are implied by the cuts)::

        Covering(G, S) = (1 / n) * sum over A in G of |A| * max over A' in S of |A ∩ A'| / |A ∪ A'|

    i.e. every reference segment is scored by the Jaccard index of its best-overlapping predicted
    segment, weighted by its length. This is the single-annotator case of the covering used by
    Ermshaus et al. (Data Min. Knowl. Discov. 2023) and by claspy's evaluation helpers.

    Parameters
    ----------
    pred_cuts, ref_cuts
        Predicted and reference 0-based cuts, distinct integers in ``(0, n)``.
    n
        Number of frames.

    Returns
    -------
    float
        Covering in ``(0, 1]``; 1 exactly when the segmentations are equal.

    Raises
    ------
    InvalidParameterError
        If ``n`` or the cuts are invalid.

    Notes
    -----
    Only overlapping pairs are visited (at most ``len(ref_cuts) + len(pred_cuts) + 1`` of them),
    so the cost is ``O(k log k)`` in the number of cuts.
    """
    n = _check_n(n)
    pred = _check_cuts(pred_cuts, n, "pred_cuts")
    ref = _check_cuts(ref_cuts, n, "ref_cuts")
    ri, pi, inter = _pieces(ref, pred, n)
    ref_len = np.diff(_bounds(ref, n))
    pred_len = np.diff(_bounds(pred, n))
    jaccard = inter / (ref_len[ri] + pred_len[pi] - inter)
    best = np.zeros(ref.size + 1)
    np.maximum.at(best, ri, jaccard)
    return float(np.dot(ref_len, best)) / n
