"""Online piecewise linear approximation (PLA) of orientation and vector signals.

One module per algorithm (``sw``, ``fastsw``, ``cplr``, ``swing``, ``anglesw``), each with a compiled
``step`` (one sample), ``flush`` and ``batch`` kernel; :mod:`mocapkit.pla.base` wraps them.
"""

from mocapkit.pla.base import METHODS, POS_METHODS, Compressed, Encoder, Point, compress
from mocapkit.pla.decode import reconstruct, reconstruct_points
from mocapkit.pla.metrics import Metrics, deviations, evaluate
from mocapkit.pla.optimal import optimal_max_angle
from mocapkit.pla.skeletal import SkeletalCompressed, compress_motion, position_errors, verify_position_bound
from mocapkit.pla.tune import compress_to

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
