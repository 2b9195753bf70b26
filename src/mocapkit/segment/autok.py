"""The number of segments chosen without labels.

A change-point method with a cost (kernel or squared error) gives, for every number of cuts ``k``,
the least total cost ``C(k)`` of a segmentation with ``k`` cuts (:func:`cost_curve`, an exact dynamic
programme). ``C`` always falls as ``k`` grows; a real change makes it fall by much more than a split
inside one action. :func:`choose_k` takes the *gain* of each extra cut, ``g(k) = C(k-1) - C(k)``,
estimates the gain of a spurious split as the median gain over the upper part of the curve (cuts
``k`` from ``noise_range[0]·k_max`` to ``noise_range[1]·k_max``, where almost all cuts split an
action), and returns the ``k`` minimising ``C(k) + c · noise · k``. It is the slope heuristic of
model selection (Baudry, Maugis and Michel, "Slope heuristics: overview and implementation",
Stat. Comput. 22, 2012) with the slope of the spurious part estimated robustly by a median.

The constants ``c = 4`` and ``noise_range = (0.3, 0.6)`` are the best of a grid (c from 2 to 5, four
ranges) on synthetic signals only (:func:`mocapkit.segment.synthetic.motion_like`, 12 signals for each
of 0–8 changes, 8 channels at 30 Hz): they recover the exact number of changes in 97.2 % of them (mean
F1 at ±0.5 s: 0.980); ``benchmarks/autok_calibration.py`` prints the grid. No label of any take was
used.

:class:`AutoSegmenter` is the method of ``mocapkit segment --method auto``: per-frame features are
replaced by their 1-second moving mean and standard deviation (a rhythmic action becomes
stationary), standardised, and cut by the kernel cost with ``k`` chosen as above. The 1-s width and
shortest segment were set beforehand and not varied. Which features it is given was chosen by
looking at the 4 labelled CMU takes: the 8 partition angles of Table 2 (mean F1 0.839) over the
4 limb angles (0.58) and over the limb bones' unit vectors in the pelvis frame (0.74) — the one
choice of this method made with labels, so its F1 there is optimistic.
"""

from __future__ import annotations

import numpy as np

from mocapkit.errors import InvalidParameterError
from mocapkit.segment._common import float_param, int_param, standardise, take_every
from mocapkit.segment.base import Segmenter, as_signal, clean_cuts

__all__ = ["AutoSegmenter", "CostCurve", "choose_k", "cost_curve", "curve_penalty", "slope_penalty", "window_stats"]

#: The calibrated constants of :func:`choose_k` (module docstring).
C_DEFAULT = 4.0
NOISE_RANGE = (0.3, 0.6)


def window_stats(x: np.ndarray, width: int) -> np.ndarray:
    """Centred moving mean and standard deviation of every channel over ``width`` samples (edges
    repeat the end samples), ``(n, 2d)``."""
    from scipy.ndimage import uniform_filter1d

    x = np.asarray(x, dtype=np.float64)
    m = uniform_filter1d(x, int(width), axis=0, mode="nearest")
    v = uniform_filter1d(x * x, int(width), axis=0, mode="nearest") - m * m
    return np.hstack([m, np.sqrt(np.maximum(v, 0.0))])


def _segment_costs(z: np.ndarray, cost: str, gamma: float | None) -> np.ndarray:
    """``(n + 1, n + 1)`` table ``T[s, e]`` = cost of the segment ``z[s:e]`` (upper triangle used).

    ``"rbf"``: Σ k(x_i, x_i) − (1 / len) Σ_{i,j} k(x_i, x_j) with the Gaussian kernel of
    :func:`mocapkit.segment.cpdpenalty.rbf_kernel`; ``"l2"``: Σ ||x_i − mean||².
    """
    from mocapkit.segment.cpdpenalty import rbf_kernel

    n = z.shape[0]
    lens = np.arange(n + 1)[None, :] - np.arange(n + 1)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        if cost == "rbf":
            assert gamma is not None  # cost_curve sets it for "rbf"
            K = rbf_kernel(z, None, gamma)
            S = np.zeros((n + 1, n + 1))
            S[1:, 1:] = K.cumsum(0).cumsum(1)
            d = np.concatenate([[0.0], np.cumsum(np.diag(K))])
            corner = np.diag(S)  # S[e, e]; S is symmetric, so the block sum is S[e,e] + S[s,s] - 2 S[s,e]
            block = corner[None, :] + corner[:, None] - 2.0 * S
            T = (d[None, :] - d[:, None]) - block / lens
        elif cost == "l2":
            c1 = np.vstack([np.zeros(z.shape[1]), np.cumsum(z, 0)])
            c2 = np.concatenate([[0.0], np.cumsum((z * z).sum(1))])
            diff = c1[None, :, :] - c1[:, None, :]
            T = (c2[None, :] - c2[:, None]) - (diff * diff).sum(2) / lens
        else:
            raise InvalidParameterError(f"cost must be 'rbf' or 'l2', got {cost!r}")
    T[lens <= 0] = np.inf
    return T


class CostCurve:
    """``costs[k]``: least total cost with ``k`` cuts, ``k = 0..k_max``; :meth:`cuts` gives the cuts."""

    def __init__(self, costs: np.ndarray, back: np.ndarray, n: int, index: np.ndarray | None = None):
        self.costs, self._back, self.n = costs, back, n
        self._index = index  # the DP ran over these boundaries only (``candidates``)

    @property
    def k_max(self) -> int:
        return int(self.costs.size - 1)

    def cuts(self, k: int) -> np.ndarray:
        """The cuts (sample indices) of the best segmentation with ``k`` cuts."""
        if not 0 <= k <= self.k_max:
            raise InvalidParameterError(f"k must be in 0..{self.k_max}, got {k}")
        out = []
        e = self._back.shape[1] - 1
        for j in range(k, 0, -1):
            e = int(self._back[j, e])
            out.append(e)
        cuts = np.asarray(out[::-1], dtype=np.int64)
        return cuts if self._index is None else self._index[cuts]


def cost_curve(z, min_size: int, k_max: int, cost: str = "rbf", gamma: float | None = None,
               candidates=None) -> CostCurve:
    """Exact least costs for ``0..k_max`` cuts (segments of at least ``min_size`` samples).

    Segment neighbourhood dynamic programme (Auger and Lawrence 1989): ``F_k(e) = min_s F_{k-1}(s) +
    T[s, e]``, vectorised over ``e``; ``O(k_max · n²)`` time and ``O(n²)`` memory. ``k_max`` is
    lowered to what ``min_size`` allows. ``candidates``: cuts may only be placed at these samples
    (e.g. the cuts another method proposes); the curve then ranks subsets of them.
    """
    z = as_signal(z)
    n = z.shape[0]
    min_size = int_param(min_size, "min_size", 1)
    k_max = min(int_param(k_max, "k_max", 0), n // min_size - 1)
    if k_max < 0:
        k_max = 0
    if cost == "rbf" and gamma is None:
        from mocapkit.segment.cpdpenalty import median_gamma

        gamma = median_gamma(z)
    elif gamma is not None:
        gamma = float_param(gamma, "gamma")
    T = _segment_costs(z, cost, gamma)
    lens = np.arange(n + 1)[None, :] - np.arange(n + 1)[:, None]
    T = np.where(lens >= min_size, T, np.inf)
    keep = None
    if candidates is not None:
        c = np.unique(np.asarray(candidates, dtype=object).reshape(-1).tolist())
        if c.size and (not np.issubdtype(c.dtype, np.integer) or c[0] <= 0 or c[-1] >= n):
            raise InvalidParameterError(f"candidates must be integer samples inside (0, {n}), got {c.tolist()}")
        c = c.astype(np.int64)
        keep = np.concatenate([[0], c, [n]])
        T = T[np.ix_(keep, keep)]
        k_max = min(k_max, c.size)
        n_full, n = n, keep.size - 1
    F = T[0].copy()  # F_0(e): one segment [0, e)
    costs = [float(F[n])]
    back = np.zeros((k_max + 1, n + 1), dtype=np.int64)
    for k in range(1, k_max + 1):
        tot = F[:, None] + T  # [s, e]
        back[k] = np.argmin(tot, axis=0)
        F = tot[back[k], np.arange(n + 1)]
        if not np.isfinite(F[n]):  # no segmentation with k cuts meets min_size (candidates too close)
            back = back[:k]
            break
        costs.append(float(F[n]))
    if keep is not None:
        return CostCurve(np.asarray(costs), back, n_full, keep)
    return CostCurve(np.asarray(costs), back, n)


def _check_curve(costs, c: float, noise_range) -> np.ndarray:
    try:
        C = np.asarray(costs, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError("costs must be a non-empty 1-D array of finite numbers") from None
    if C.ndim != 1 or C.size == 0 or not np.all(np.isfinite(C)):
        raise InvalidParameterError("costs must be a non-empty 1-D array of finite numbers")
    try:
        lo, hi = (float(v) for v in noise_range)
        c = float(c)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"c must be a number and noise_range a pair of numbers, got {c!r}, {noise_range!r}"
        ) from None
    if not 0 <= lo < hi <= 1 or not 0 < c < np.inf:
        raise InvalidParameterError("need 0 <= noise_range[0] < noise_range[1] <= 1 and a finite c > 0")
    return C


def slope_penalty(costs, c: float = C_DEFAULT, noise_range: tuple[float, float] = NOISE_RANGE) -> float | None:
    """The penalty per cut ``c · noise`` of :func:`choose_k`; None with fewer than 4 possible cuts.

    ``noise`` is the median gain ``C(k-1) - C(k)`` of the cuts ``k = a+1 .. b`` with
    ``a = max(1, floor(noise_range[0] · k_max))`` and ``b = max(a + 1, floor(noise_range[1] · k_max))``.
    """
    C = _check_curve(costs, c, noise_range)
    g = -np.diff(C)
    if g.size < 4:
        return None
    a = max(1, int(noise_range[0] * g.size))
    b = max(a + 1, int(noise_range[1] * g.size))
    return c * float(np.median(g[a:b]))


def choose_k(costs, c: float = C_DEFAULT, noise_range: tuple[float, float] = NOISE_RANGE) -> int:
    """The number of cuts minimising ``C(k) + pen · k`` with ``pen`` of :func:`slope_penalty`
    (module docstring). With fewer than 4 possible cuts there is no upper part to estimate the
    noise from, and no cut is proposed (a take shorter than 5 shortest segments is one action).
    """
    C = _check_curve(costs, c, noise_range)
    pen = slope_penalty(C, c, noise_range)
    if pen is None:  # no spurious-split gain to compare with: no evidence for any cut
        return 0
    return int(np.argmin(C + pen * np.arange(C.size)))


def curve_penalty(z: np.ndarray, min_size: int, cost: str, gamma: float | None, k_max: int = 30,
                  max_points: int = 1500) -> float | None:
    """:func:`slope_penalty` of ``z`` for a penalised search (PELT): the cost curve is computed on at
    most ``max_points`` evenly spaced samples (its table is quadratic in them) and the penalty scaled
    back by the stride, as a segment's cost grows with its number of samples."""
    stride = max(1, -(-z.shape[0] // max_points))
    sub = z[::stride]
    curve = cost_curve(sub, max(1, min_size // stride), k_max, cost, gamma)
    pen = slope_penalty(curve.costs)
    return None if pen is None else pen * stride


class AutoSegmenter(Segmenter):
    """Segmentation with the number of segments chosen without labels (``segment --method auto``).

    Every ``downsample``-th frame is kept; each channel is replaced by its moving mean and standard
    deviation over ``width`` samples; the result is standardised and cut by the Gaussian-kernel cost
    (exact dynamic programme, :func:`cost_curve`) with the number of cuts of :func:`choose_k`.

    Parameters
    ----------
    downsample
        Keep every ``downsample``-th frame (default 4: 120 Hz to 30 Hz).
    width
        Moving-statistics width in kept samples (default 30: 1 s at 30 Hz).
    min_size
        Shortest segment in kept samples (default 30: 1 s).
    k_max
        Largest number of cuts considered (default 30).
    c, noise_range
        The calibrated constants of :func:`choose_k`.
    max_points
        At most this many samples enter the dynamic programme (default 2,000: 67 s at 30 Hz); a longer
        take keeps every ``k``-th of the downsampled samples more, with ``width`` and ``min_size``
        divided by ``k`` (its tables are quadratic in the samples: 2,000 take about 0.2 GB).
    """

    def __init__(self, downsample: int = 4, width: int = 30, min_size: int = 30, k_max: int = 30,
                 c: float = C_DEFAULT, noise_range: tuple[float, float] = NOISE_RANGE, max_points: int = 2000):
        self.max_points = int_param(max_points, "max_points", 100)
        self.downsample = int_param(downsample, "downsample", 1)
        self.width = int_param(width, "width", 1)
        self.min_size = int_param(min_size, "min_size", 2)
        self.k_max = int_param(k_max, "k_max", 4)
        choose_k(np.zeros(6), c, noise_range)  # validates the constants
        self.c = float(c)
        self.noise_range = (float(noise_range[0]), float(noise_range[1]))

    def fit(self, X) -> AutoSegmenter:
        x = as_signal(X)
        n = x.shape[0]
        self.n_frames_ = n
        # the DP's tables are quadratic in the samples: beyond max_points, keep fewer (and scale the
        # widths with them), so a long take costs time linear in its length and bounded memory
        kept = -(-n // self.downsample)  # ceil: samples after downsampling
        extra = max(1, -(-kept // self.max_points))
        step = self.downsample * extra
        width = max(2, int(round(self.width / extra)))
        size = max(2, int(round(self.min_size / extra)))
        z = take_every(x, step)
        self.step_ = step
        if np.ptp(z, axis=0).max() == 0 or z.shape[0] < 2 * size:
            self.curve_ = None
            self.k_ = 0
            self.cuts_ = np.zeros(0, dtype=np.int64)
            return self
        f = standardise(window_stats(z, width))
        self.curve_ = cost_curve(f, size, self.k_max, "rbf")
        self.k_ = choose_k(self.curve_.costs, self.c, self.noise_range)
        self.cuts_ = clean_cuts(self.curve_.cuts(self.k_) * step, n)
        return self
