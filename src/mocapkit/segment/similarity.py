"""DTW similarity of motion sequences: Section 3.4 (Eq. 5–9) of the ARMA seed paper.

The paper checks that one action performed by different subjects gives similar limb-angle sequences
("the similarity of various types of movement between different heights are generally higher than
70 %", Figure 4). Two sequences are aligned by dynamic time warping and the aligned sequences are
correlated:

- Eq. 6: the point distance ``d(θ_e, θ_f) = sqrt(Σ (θ_e − θ_f)²)`` (Euclidean; the absolute difference
  for one limb angle, over the columns for ``(n, d)`` sequences).
- Eq. 8: the accumulated cost ``r(e, f) = d(e, f) + min(r(e−1, f−1), r(e−1, f), r(e, f−1))`` with
  ``r(0, 0) = d(0, 0)``; the optimal warping path W (Eq. 7) is read back from ``(m−1, n−1)`` to
  ``(0, 0)``, so ``max(m, n) <= K <= m + n − 1``.
- Eq. 5: ``DTW = Σ_k w_k / K``, the path's summed point distance divided by its length K. Eq. 5 is
  written as a minimum of that ratio; the recursion of Eq. 8 minimises the *sum*, and the ratio of the
  path it finds is what is reported (the usual reading: minimising the ratio itself is a different,
  costlier problem the paper does not describe).
- Eq. 9: ``r_θ`` is Pearson's correlation of the two sequences after alignment. The flattened formula
  ``Σ_{iE iF} (θ_iEiF − θ̄_iEiF)(θ_iEiF − θ̄_iEiF) / sqrt(Σ (…)² · Σ (…)²)`` is read as
  ``Σ_k (x_k − x̄)(y_k − ȳ) / sqrt(Σ_k (x_k − x̄)² Σ_k (y_k − ȳ)²)`` with ``x_k = θ_m[e_k]`` and
  ``y_k = θ_n[f_k]`` the two sequences repeated along the path ``w_k = (e_k, f_k)`` (θ_iE and θ_iF
  are "the corresponding regulated sequences", both of length K). ``r̄_θ = Σ_μ r_θμ / γ`` is the mean
  of r_θ over the γ pairs ("data groups") of one action type, per limb i.

Choices the paper leaves open, with this module's defaults:

- Alignment per limb (``align="limb"``, the paper's ``DTW(θ_im, θ_in)`` for each limb i: one path
  per limb angle) or one path for all limbs together (``align="joint"``, the (n, 4) sequences with the
  Euclidean distance of Eq. 6 over the 4 angles). A per-limb path can bend one angle onto any other
  with a similar range, so it flatters unrelated actions; the joint path keeps the limbs in step.
- Time normalisation: "the data of the same motion type are normalized over the time domain" before
  DTW. ``resample=N`` linearly resamples both sequences to N samples first (:func:`time_normalise`).
  The default is **no resampling**: DTW already absorbs a uniform change of speed, Eq. 7 speaks of the
  raw lengths m and n, and resampling would only change how many times each sample is counted in r_θ
  (so the default keeps every measured sample exactly once or more and adds none made up).
- Sakoe–Chiba band (``band=None``: none): the path may only visit cells with
  ``|e·(n−1) − f·(m−1)| <= band·(min(m, n) − 1)``, i.e. within ``band`` samples of the straight line
  from ``(0, 0)`` to ``(m−1, n−1)`` measured along the longer sequence. A band narrower than half the
  length ratio could leave rows without a cell and is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocapkit.errors import InvalidParameterError

#: the largest number of DTW cells (one byte of back-pointer each) computed in one call
MAX_CELLS = 400_000_000
#: the paper's threshold of Figure 4: "generally higher than 70 %"
PAPER_THRESHOLD = 0.7
ALIGNMENTS = ("limb", "joint")
#: the categories of :func:`similarity_table`, in print order
CATEGORIES = ("same action, different subjects", "same action, same subject",
              "different actions, different subjects", "different actions, same subject")


@dataclass(frozen=True)
class DTWResult:
    """An optimal DTW alignment.

    Attributes
    ----------
    distance
        Eq. 5: ``cost / K``, the mean point distance along the path.
    cost
        ``r(m−1, n−1)`` of Eq. 8: the summed point distance of the optimal path.
    path
        ``(K, 2)`` int64 pairs ``(e_k, f_k)``, 0-based, from ``(0, 0)`` to ``(m−1, n−1)``; each step
        advances e, f or both by one (Eq. 7: ``max(m, n) <= K <= m + n − 1``).
    """

    distance: float
    cost: float
    path: np.ndarray

    @property
    def K(self) -> int:
        """The path length K of Eq. 7."""
        return int(self.path.shape[0])


@dataclass(frozen=True)
class PairSimilarity:
    """Eq. 5 and Eq. 9 for two multi-column sequences (one column per limb angle).

    Attributes
    ----------
    r
        ``(d,)`` Eq. 9 correlation per column (NaN where a column is constant along the path).
    distance
        ``(d,)`` Eq. 5 DTW distance per column (``align="limb"``) or the joint path's distance repeated.
    path_length
        ``(d,)`` K of each column's path.
    align
        ``"limb"`` or ``"joint"``.
    lengths
        ``(m, n)``: the two sequences' lengths as compared (after any resampling).
    """

    r: np.ndarray
    distance: np.ndarray
    path_length: np.ndarray
    align: str
    lengths: tuple[int, int]
    paths: list = field(default_factory=list, repr=False)

    @property
    def r_mean(self) -> float:
        """The mean of r over the columns (NaN when any column's r is undefined)."""
        return float(np.mean(self.r))


def _as_sequence(x, name: str) -> np.ndarray:
    """``x`` as a C-contiguous ``(n, d)`` float64 array; 1-D input becomes one column."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise InvalidParameterError(f"{name}: a sequence is (n,) or (n, d), got shape {a.shape}")
    if a.shape[0] < 1 or a.shape[1] < 1:
        raise InvalidParameterError(f"{name}: an empty sequence (shape {a.shape})")
    if not np.all(np.isfinite(a)):
        raise InvalidParameterError(f"{name}: holds NaN or infinite values")
    return np.ascontiguousarray(a)


def min_band(m: int, n: int) -> int:
    """The narrowest Sakoe–Chiba band (in samples) that surely leaves a path through an ``m × n`` grid:
    half the length ratio ``(max − 1) / (min − 1)``, rounded up (every row then holds a cell and the
    rows overlap); 0 for equal lengths (the diagonal) or when a sequence has one sample."""
    lo, hi = min(m, n), max(m, n)
    if lo <= 1 or lo == hi:
        return 0
    return int(-(-(hi - 1) // (2 * (lo - 1))))


def dtw(a, b, band: int | None = None) -> DTWResult:
    """Dynamic time warping of two sequences (Eq. 5–8 of the ARMA seed paper).

    Parameters
    ----------
    a, b
        ``(m,)``/``(n,)`` or ``(m, d)``/``(n, d)`` finite sequences with the same number of columns.
    band
        Sakoe–Chiba band in samples (see the module docstring); None: no band.

    Returns
    -------
    DTWResult
        Eq. 5 distance, Eq. 8 cost and the optimal path W of Eq. 7.

    Raises
    ------
    InvalidParameterError
        Empty, non-finite or mismatched sequences, a band narrower than :func:`min_band`, or more
        than :data:`MAX_CELLS` cells.
    """
    A, B = _as_sequence(a, "a"), _as_sequence(b, "b")
    if A.shape[1] != B.shape[1]:
        raise InvalidParameterError(f"the sequences have {A.shape[1]} and {B.shape[1]} columns; DTW needs the same")
    m, n = A.shape[0], B.shape[0]
    if band is None:
        w = -1
    else:
        if isinstance(band, bool) or int(band) != band or band < 0:
            raise InvalidParameterError(f"band {band!r}: a number of samples >= 0")
        w = int(band)
        need = min_band(m, n)
        if w < need:
            raise InvalidParameterError(f"band {w}: sequences of {m} and {n} samples need a band of at least {need} "
                                        "samples (half their length ratio) for a path to exist")
    if m * n > MAX_CELLS:
        raise InvalidParameterError(f"DTW of {m} x {n} samples needs {m * n:,} cells (at most {MAX_CELLS:,}): "
                                    "compare shorter ranges or resample")
    from mocapkit.segment._dtw import backtrack, dtw_kernel  # numba: compiled on first use only

    cost, steps = dtw_kernel(A, B, w)
    path = backtrack(steps)
    return DTWResult(distance=float(cost) / path.shape[0], cost=float(cost), path=path)


def time_normalise(x, length: int) -> np.ndarray:
    """The paper's normalisation "over the time domain": ``x`` ((n,) or (n, d)) resampled to ``length``
    samples by linear interpolation between its first and last sample (same shape convention)."""
    if isinstance(length, bool) or int(length) != length or length < 2:
        raise InvalidParameterError(f"resample length {length!r}: an integer >= 2")
    X = _as_sequence(x, "x")
    n = X.shape[0]
    if n < 2:
        raise InvalidParameterError("a sequence of one sample cannot be resampled")
    u = np.linspace(0.0, n - 1.0, int(length))
    out = np.column_stack([np.interp(u, np.arange(n, dtype=np.float64), X[:, j]) for j in range(X.shape[1])])
    return out[:, 0] if np.ndim(x) == 1 else out


#: A series whose RMS deviation from its mean is at most this fraction of its size (its largest magnitude,
#: at least 1 unit: 1° for limb angles) is constant. What varies below is float rounding (forward
#: kinematics of identical frames gives limb angles with an RMS deviation near 1e-13°), never motion
#: (1e-9 of 180° is 2e-7°, far below any capture's resolution); a correlation of it would be noise.
REL_VARIATION = 1e-9


def is_constant(x) -> bool:
    """True when ``x`` (1-D) varies by no more than :data:`REL_VARIATION` of its size (see there)."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return True
    dx = x - x.mean()
    rms = math.sqrt(float(dx @ dx) / x.size)
    return rms <= REL_VARIATION * max(1.0, float(np.max(np.abs(x))))


def pearson(x, y) -> float:
    """Pearson's correlation of two equal-length 1-D arrays; NaN when either is constant
    (:func:`is_constant`: a variation of float rounding only)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if is_constant(x) or is_constant(y):
        return math.nan
    dx, dy = x - x.mean(), y - y.mean()
    sxx, syy = float(dx @ dx), float(dy @ dy)
    return float(np.clip((dx @ dy) / math.sqrt(sxx * syy), -1.0, 1.0))


def aligned_correlation(a, b, path) -> np.ndarray:
    """Eq. 9 r_θ per column: Pearson's correlation of ``a[e_k]`` and ``b[f_k]`` along ``path``
    (``(K, 2)``). Returns ``(d,)`` (NaN for a column constant along the path, :func:`is_constant`)."""
    A, B = _as_sequence(a, "a"), _as_sequence(b, "b")
    p = np.asarray(path, dtype=np.int64)
    x, y = A[p[:, 0]], B[p[:, 1]]
    return np.array([pearson(x[:, j], y[:, j]) for j in range(A.shape[1])])


def sequence_similarity(a, b, *, align: str = "limb", band: int | None = None,
                        resample: int | None = None) -> PairSimilarity:
    """Eq. 5 and Eq. 9 of two ``(m, d)`` / ``(n, d)`` sequences (columns: limb angles).

    ``align="limb"``: one DTW path per column (the paper's per-limb DTW); ``"joint"``: one path for all
    columns. ``resample``: both sequences time-normalised to that many samples first (None: not).
    """
    if align not in ALIGNMENTS:
        raise InvalidParameterError(f"align {align!r}: one of {', '.join(ALIGNMENTS)}")
    A, B = _as_sequence(a, "a"), _as_sequence(b, "b")
    if A.shape[1] != B.shape[1]:
        raise InvalidParameterError(f"the sequences have {A.shape[1]} and {B.shape[1]} columns; DTW needs the same")
    if resample is not None:
        A, B = time_normalise(A, resample), time_normalise(B, resample)
    d = A.shape[1]
    if align == "joint":
        res = dtw(A, B, band)
        r = aligned_correlation(A, B, res.path)
        dist = np.full(d, res.distance)
        K = np.full(d, res.K, dtype=np.int64)
        paths = [res.path]
    else:
        r, dist, K, paths = np.empty(d), np.empty(d), np.empty(d, dtype=np.int64), []
        for j in range(d):
            res = dtw(A[:, j], B[:, j], band)
            r[j] = aligned_correlation(A[:, j], B[:, j], res.path)[0]
            dist[j], K[j] = res.distance, res.K
            paths.append(res.path)
    return PairSimilarity(r=r, distance=dist, path_length=K, align=align, lengths=(A.shape[0], B.shape[0]),
                          paths=paths)


@dataclass(frozen=True)
class LabelledSegment:
    """One labelled piece of a take: ``values`` ``(n, d)`` (limb angles), its action ``label``, the
    ``subject`` who performed it, and where it comes from (``take``, frames ``[frame0, frame1)``)."""

    label: str
    subject: str
    values: np.ndarray
    take: str = ""
    frame0: int = 0
    frame1: int = 0


def category(s: LabelledSegment, t: LabelledSegment) -> str:
    """The :data:`CATEGORIES` entry of a pair: same/different action × same/different subject."""
    action = "same action" if s.label == t.label else "different actions"
    who = "same subject" if s.subject == t.subject else "different subjects"
    return f"{action}, {who}"


def _nanmean(v) -> float | None:
    v = np.asarray(v, dtype=np.float64)
    v = v[np.isfinite(v)]
    return float(v.mean()) if v.size else None


def similarity_table(segments, names=None, *, align: str = "limb", band: int | None = None,
                     resample: int | None = None) -> dict:
    """Eq. 9 over every pair of labelled segments, grouped by same/different action and subject.

    Parameters
    ----------
    segments
        :class:`LabelledSegment` list (every ``values`` with the same number of columns).
    names
        Column names (default ``col0``, ``col1``, …).
    align, band, resample
        As in :func:`sequence_similarity`.

    Returns
    -------
    dict
        ``pairs``: one row per pair (both segments, ``category``, ``r`` and ``distance`` per column,
        ``r_mean`` over columns); ``categories``: per category the number of pairs γ, r̄ per column
        (Eq. 9's mean over the γ pairs), its mean over columns and the share of pairs whose mean r is
        above 0.7; ``actions``: per action label and subject relation, r̄ per column. Undefined
        correlations (a constant column) are left out of the means and counted in ``undefined``.
    """
    segs = list(segments)
    if len(segs) < 2:
        raise InvalidParameterError("a similarity table needs at least two segments")
    d = _as_sequence(segs[0].values, "segment 0").shape[1]
    names = list(names) if names is not None else [f"col{j}" for j in range(d)]
    if len(names) != d:
        raise InvalidParameterError(f"{len(names)} names for {d} columns")
    pairs: list[dict[str, Any]] = []
    for i in range(len(segs)):
        for j in range(i + 1, len(segs)):
            s, t = segs[i], segs[j]
            ps = sequence_similarity(s.values, t.values, align=align, band=band, resample=resample)
            pairs.append({
                "a": {"take": s.take, "label": s.label, "subject": s.subject, "frames": [s.frame0, s.frame1]},
                "b": {"take": t.take, "label": t.label, "subject": t.subject, "frames": [t.frame0, t.frame1]},
                "category": category(s, t),
                "r": {nm: (None if not math.isfinite(v) else float(v)) for nm, v in zip(names, ps.r, strict=False)},
                "distance": {nm: float(v) for nm, v in zip(names, ps.distance, strict=False)},
                "r_mean": _nanmean(ps.r) if np.all(np.isfinite(ps.r)) else None,
            })

    def summary(rows) -> dict:
        r = np.array([[np.nan if p["r"][nm] is None else p["r"][nm] for nm in names] for p in rows])
        means = [p["r_mean"] for p in rows if p["r_mean"] is not None]
        return {"gamma": len(rows),
                "r_bar": {nm: _nanmean(r[:, k]) for k, nm in enumerate(names)},
                "r_bar_mean": _nanmean(means),
                "share_above_0.7": (float(np.mean(np.array(means) > PAPER_THRESHOLD)) if means else None),
                "distance": {nm: _nanmean([p["distance"][nm] for p in rows]) for nm in names},
                "undefined": int(np.sum(~np.isfinite(r)))}

    cats = {c: summary([p for p in pairs if p["category"] == c]) for c in CATEGORIES
            if any(p["category"] == c for p in pairs)}
    actions = {}
    for lab in sorted({s.label for s in segs}):
        for who in ("different subjects", "same subject"):
            rows = [p for p in pairs if p["category"] == f"same action, {who}" and p["a"]["label"] == lab]
            if rows:
                actions[f"{lab} ({who})"] = summary(rows)
    return {"names": names, "align": align, "band": band, "resample": resample, "pairs": pairs,
            "categories": cats, "actions": actions}
