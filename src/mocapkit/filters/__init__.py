"""Filtering by piecewise polynomial approximation (PPA) and its baselines.

``ppa`` (the seed report's iterative knot algorithm), ``exact`` (the global optimum of its loss),
``butterworth`` (zero-phase Butterworth with Winter's residual cut-off, smoothing spline);
``chunks`` holds the shared pieces: exact chunk SSRs by QR updating, fits, the piecewise model.
"""

from mocapkit.filters.api import FilterResult, fit, split_at_gaps
from mocapkit.filters.butterworth import (
    butterworth_filtfilt,
    smoothing_spline,
    step_overshoot,
    winter_residual_cutoff,
)
from mocapkit.filters.chunks import Piece, PiecewisePolynomial
from mocapkit.filters.exact import solve_exact
from mocapkit.filters.ppa import fit_iterative

__all__ = [
    "FilterResult",
    "Piece",
    "PiecewisePolynomial",
    "butterworth_filtfilt",
    "fit",
    "fit_iterative",
    "smoothing_spline",
    "solve_exact",
    "split_at_gaps",
    "step_overshoot",
    "winter_residual_cutoff",
]
