"""Shared pieces of the piecewise polynomial filters.

Chunks are half-open sample ranges ``[a, b)``; each is fitted by its own least-squares polynomial of
order ``O`` in real time (seconds; irregular sampling allowed), independent of its neighbours
(discontinuous at knots), all components of a vector signal sharing the knots. Samples with a NaN in
any component are left out of the fits.

SSRs of many chunks are computed by **updating a QR factorisation** one sample at a time (Givens
rotations; the polynomial basis in time centred on the scan's first sample and scaled by the scan's
span, so the design is well conditioned). Scanning forward from ``a`` yields ``SSR[a, k)`` for every
``k`` in one O(n·O²) pass, scanning backward from ``c`` yields ``SSR[k, c)``: numerically stable,
unlike differences of prefix moment sums.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from mocapkit.errors import InvalidParameterError


@numba.njit(cache=True, inline="always")
def _add_row(R, qy, x, y, rss, p, D) -> None:
    """Givens update of the QR of the design with row ``x`` (length p) and targets ``y`` (length D);
    the part of ``y`` orthogonal to the design so far is added to ``rss`` (length D)."""
    for i in range(p):
        xi = x[i]
        if xi == 0.0:
            continue
        rii = R[i, i]
        r = np.hypot(rii, xi)
        c = rii / r
        s = xi / r
        R[i, i] = r
        for j in range(i + 1, p):
            a = R[i, j]
            b = x[j]
            R[i, j] = c * a + s * b
            x[j] = -s * a + c * b
        for d in range(D):
            a = qy[i, d]
            b = y[d]
            qy[i, d] = c * a + s * b
            y[d] = -s * a + c * b
    for d in range(D):
        rss[d] += y[d] * y[d]


@numba.njit(cache=True, inline="always")
def _add_sample(t, Y, i, t0, span, R, qy, x, y, rss, p, D) -> bool:
    """Add sample ``i`` (basis ``((t_i − t0)/span)^j``) to the QR; ``False`` for a NaN row (skipped)."""
    for d in range(D):
        if Y[i, d] != Y[i, d]:
            return False
    tau = (t[i] - t0) / span
    v = 1.0
    for j in range(p):
        x[j] = v
        v *= tau
    for d in range(D):
        y[d] = Y[i, d]
    _add_row(R, qy, x, y, rss, p, D)
    return True


@numba.njit(cache=True)
def ssr_scan(t, Y, a, c, order, forward):
    """SSR of the chunks starting at ``a`` (``forward``) or ending at ``c`` (backward).

    Returns ``(ssr (c-a+1,), count (c-a+1,))``: forward, entry ``m`` is the chunk ``[a, a+m)``;
    backward, entry ``m`` is the chunk ``[c-m, c)``. ``count`` is the number of valid (non-NaN) rows;
    chunks with fewer than ``order + 1`` valid rows have SSR 0 (they are exactly fitted).
    """
    n = c - a
    D = Y.shape[1]
    p = order + 1
    ssr = np.zeros(n + 1)
    cnt = np.zeros(n + 1, dtype=np.int64)
    R = np.zeros((p, p))
    qy = np.zeros((p, D))
    rss = np.zeros(D)
    x = np.empty(p)
    y = np.empty(D)
    t0 = t[a] if forward else t[c - 1]
    span = abs(t[c - 1] - t[a])
    if span <= 0.0:
        span = 1.0
    k = 0
    for m in range(1, n + 1):
        i = a + m - 1 if forward else c - m
        if _add_sample(t, Y, i, t0, span, R, qy, x, y, rss, p, D):
            k += 1
        tot = 0.0
        for d in range(D):
            tot += rss[d]
        ssr[m] = tot
        cnt[m] = k
    return ssr, cnt


def chunk_ssr(t: np.ndarray, Y: np.ndarray, a: int, b: int, order: int) -> float:
    """SSR of one chunk ``[a, b)`` (summed over components)."""
    s, _ = ssr_scan(t, Y, a, b, order, True)
    return float(s[-1])


@dataclass(frozen=True)
class Piece:
    """One chunk: samples ``[i0, i1)``, times ``t0..t1`` (first and last sample), polynomial
    coefficients ``(O+1, D)`` in ``(t − t0)`` seconds, lowest order first."""

    i0: int
    i1: int
    t0: float
    t1: float
    coeffs: np.ndarray


def fit_piece(t: np.ndarray, Y: np.ndarray, a: int, b: int, order: int) -> Piece:
    """Least-squares polynomial of one chunk (NaN rows left out), in ``(t − t0)`` seconds."""
    tt = t[a:b]
    yy = Y[a:b]
    ok = ~np.isnan(yy).any(axis=1)
    D = Y.shape[1]
    t0 = float(tt[0])
    if ok.sum() == 0:
        return Piece(a, b, t0, float(tt[-1]), np.full((order + 1, D), np.nan))
    deg = min(order, int(ok.sum()) - 1)
    span = float(tt[-1] - t0) or 1.0
    tau = (tt[ok] - t0) / span
    c = np.polynomial.polynomial.polyfit(tau, yy[ok], deg)  # (deg+1, D), in tau
    c = np.vstack([c.reshape(deg + 1, D), np.zeros((order - deg, D))])
    c = c / (span ** np.arange(order + 1))[:, None]  # tau = (t - t0)/span
    return Piece(a, b, t0, float(tt[-1]), c)


@dataclass(frozen=True)
class PiecewisePolynomial:
    """The filter's output: knots (sample indices where chunks start, plus ``n``) and pieces."""

    knots: np.ndarray
    pieces: tuple[Piece, ...]
    order: int
    ssr: float
    penalty: float

    @property
    def n_knots(self) -> int:
        """Interior knots (chunk boundaries): the ``N_k`` of the loss (Eq. 2 of the seed report);
        the two fixed end knots would add the constant ``2K`` and are not counted."""
        return len(self.pieces) - 1

    @property
    def loss(self) -> float:
        """``sqrt(SSR) + K·N_k`` (Eq. 2 of the seed report)."""
        return float(np.sqrt(max(self.ssr, 0.0)) + self.penalty * self.n_knots)

    def evaluate(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Values (or the ``derivative``-th time derivative) at times ``t`` (each in its chunk)."""
        t = np.asarray(t, dtype=np.float64)
        starts = np.array([p.t0 for p in self.pieces])
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        D = self.pieces[0].coeffs.shape[1]
        out = np.empty((t.shape[0], D))
        for j, p in enumerate(self.pieces):
            sel = k == j
            if not sel.any():
                continue
            c = p.coeffs
            for _ in range(derivative):
                c = np.polynomial.polynomial.polyder(c, axis=0) if c.shape[0] > 1 else np.zeros((1, D))
            out[sel] = np.polynomial.polynomial.polyval(t[sel] - p.t0, c).T
        return out


def build(t: np.ndarray, Y: np.ndarray, knots, order: int, penalty: float) -> PiecewisePolynomial:
    knots = np.asarray(sorted(set(int(k) for k in knots) | {0, len(t)}), dtype=np.int64)
    pieces = tuple(fit_piece(t, Y, int(a), int(b), order) for a, b in zip(knots[:-1], knots[1:], strict=True))
    ssr = sum(chunk_ssr(t, Y, int(a), int(b), order) for a, b in zip(knots[:-1], knots[1:], strict=True))
    return PiecewisePolynomial(knots, pieces, order, float(ssr), float(penalty))


def as_2d(t, y) -> tuple[np.ndarray, np.ndarray]:
    t = np.ascontiguousarray(t, dtype=np.float64)
    Y = np.asarray(y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    Y = np.ascontiguousarray(Y)
    if t.ndim != 1 or Y.shape[0] != t.shape[0] or t.shape[0] == 0:
        raise InvalidParameterError(f"times (N,) and values (N,) or (N, D) needed; got {t.shape} and {Y.shape}")
    if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise InvalidParameterError("times must be finite and strictly increasing")
    if np.isinf(Y).any():
        raise InvalidParameterError("values must not be infinite (NaN marks a missing sample)")
    return t, Y
