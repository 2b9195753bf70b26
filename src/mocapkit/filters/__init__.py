"""Filtering by piecewise polynomial approximation (PPA) and its baselines.

``ppa`` (the seed report's iterative knot algorithm), ``exact`` (the global optimum of its loss),
``butterworth`` (zero-phase Butterworth with Winter's residual cut-off, smoothing spline);
``chunks`` holds the shared pieces: exact chunk SSRs by QR updating, fits, the piecewise model.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
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

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.filters.api": ("FilterResult", "fit", "split_at_gaps"),
    "mocapkit.filters.butterworth": ("butterworth_filtfilt", "smoothing_spline", "step_overshoot",
                                     "winter_residual_cutoff"),
    "mocapkit.filters.chunks": ("Piece", "PiecewisePolynomial"),
    "mocapkit.filters.exact": ("solve_exact",),
    "mocapkit.filters.ppa": ("fit_iterative",),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str):
    """A name of ``__all__``, imported from its module on first use (PEP 562) and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
