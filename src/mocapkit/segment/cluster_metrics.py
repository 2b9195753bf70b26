"""Scores of named actions (a class per frame) against reference action labels, at frame level.

Both arguments are per-frame label arrays of the same length: ``found`` (the classes a clustering
gave, e.g. the letters of :func:`mocapkit.segment.naming.name_actions`) and ``ref`` (the annotated
actions). Labels may be any hashable values (ints, strings); their names never matter, only which
frames share a label.

* :func:`purity` -- each found class counts the frames of its most frequent reference label;
* :func:`nmi` -- normalised mutual information, arithmetic-mean normalisation (scikit-learn's
  ``normalized_mutual_info_score`` default), implemented here from the contingency table;
* :func:`frame_accuracy` -- the fraction of frames right after the best one-to-one matching of found
  classes to reference labels (Hungarian algorithm, :func:`scipy.optimize.linear_sum_assignment`);
  found classes left unmatched (more classes than labels) count as wrong.

Purity rewards over-splitting (one class per frame has purity 1); frame accuracy does not, so report
both.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from mocapkit.errors import InvalidParameterError

__all__ = ["best_matching", "contingency", "frame_accuracy", "nmi", "purity"]


def _codes(labels: object, name: str) -> tuple[np.ndarray, list]:
    arr = np.asarray(labels, dtype=object)
    if arr.ndim != 1:
        raise InvalidParameterError(f"{name} must be a 1-D per-frame label array, got shape {arr.shape}")
    index: dict = {}
    codes = np.empty(arr.size, dtype=np.int64)
    for i, v in enumerate(arr.tolist()):
        try:
            codes[i] = index.setdefault(v, len(index))
        except TypeError:
            raise InvalidParameterError(f"{name}[{i}] is not a usable label: {v!r}") from None
    return codes, list(index)


def contingency(found, ref) -> tuple[np.ndarray, list, list]:
    """Frame counts ``C[i, j]`` of found class ``i`` and reference label ``j``, with the class and
    label values in order of first appearance.

    Raises
    ------
    InvalidParameterError
        If the arrays are not 1-D, are empty or differ in length.
    """
    f, fv = _codes(found, "found")
    r, rv = _codes(ref, "ref")
    if f.size != r.size:
        raise InvalidParameterError(f"found has {f.size} frames and ref {r.size}: they must be the same frames")
    if f.size == 0:
        raise InvalidParameterError("no frames to score")
    c = np.zeros((len(fv), len(rv)), dtype=np.int64)
    np.add.at(c, (f, r), 1)
    return c, fv, rv


def purity(found, ref) -> float:
    """Cluster purity: ``sum_i max_j C[i, j] / n``."""
    c, _, _ = contingency(found, ref)
    return float(c.max(axis=1).sum() / c.sum())


def _entropy(counts: np.ndarray) -> float:
    p = counts[counts > 0] / counts.sum()
    return float(-(p * np.log(p)).sum())


def nmi(found, ref) -> float:
    """Normalised mutual information ``I(F; R) / ((H(F) + H(R)) / 2)`` (natural logarithms).

    Conventions (those of scikit-learn): 1 when both sides have a single class (the partitions are
    then identical); 0 when the mutual information is 0 otherwise.
    """
    c, _, _ = contingency(found, ref)
    n = c.sum()
    if c.shape[0] == 1 and c.shape[1] == 1:
        return 1.0
    rows = c.sum(axis=1)
    cols = c.sum(axis=0)
    i, j = np.nonzero(c)
    nij = c[i, j].astype(np.float64)
    mi = float((nij / n * (np.log(nij * n) - np.log(rows[i] * cols[j].astype(np.float64)))).sum())
    if mi <= 0.0:
        return 0.0
    return float(min(1.0, mi / (0.5 * (_entropy(rows) + _entropy(cols)))))


def best_matching(found, ref) -> dict:
    """The one-to-one matching of found classes to reference labels with the most frames in common
    (``{found class: reference label}``; classes left over are absent)."""
    c, fv, rv = contingency(found, ref)
    rows, cols = linear_sum_assignment(c, maximize=True)
    return {fv[i]: rv[j] for i, j in zip(rows, cols, strict=True)}


def frame_accuracy(found, ref) -> float:
    """Fraction of frames whose found class is matched to their reference label under the best
    one-to-one matching (Hungarian algorithm on the contingency table)."""
    c, _, _ = contingency(found, ref)
    rows, cols = linear_sum_assignment(c, maximize=True)
    return float(c[rows, cols].sum() / c.sum())
