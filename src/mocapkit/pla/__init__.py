"""Online piecewise linear approximation (PLA) of orientation and vector signals.

One module per algorithm (``sw``, ``fastsw``, ``cplr``, ``swing``, ``anglesw``), each with a compiled
``step`` (one sample), ``flush`` and ``batch`` kernel; :mod:`mocapkit.pla.base` wraps them.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.pla.base import (
        METHODS,
        POS_METHODS,
        Compressed,
        Encoder,
        Point,
        compress,
    )
    from mocapkit.pla.decode import reconstruct, reconstruct_points
    from mocapkit.pla.metrics import Metrics, deviations, evaluate
    from mocapkit.pla.optimal import optimal_max_angle
    from mocapkit.pla.skeletal import (
        SkeletalCompressed,
        compress_motion,
        position_errors,
        verify_position_bound,
    )
    from mocapkit.pla.tune import compress_to

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.pla.base": ("METHODS", "POS_METHODS", "Compressed", "Encoder", "Point", "compress"),
    "mocapkit.pla.decode": ("reconstruct", "reconstruct_points"),
    "mocapkit.pla.metrics": ("Metrics", "deviations", "evaluate"),
    "mocapkit.pla.optimal": ("optimal_max_angle",),
    "mocapkit.pla.skeletal": ("SkeletalCompressed", "compress_motion", "position_errors", "verify_position_bound"),
    "mocapkit.pla.tune": ("compress_to",),
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
    "METHODS",
    "POS_METHODS",
    "Compressed",
    "Encoder",
    "Metrics",
    "Point",
    "SkeletalCompressed",
    "compress",
    "compress_motion",
    "compress_to",
    "deviations",
    "evaluate",
    "optimal_max_angle",
    "position_errors",
    "reconstruct",
    "reconstruct_points",
    "verify_position_bound",
]
