"""Online piecewise linear approximation (PLA) of orientation and vector signals.

One module per algorithm (``sw``, ``fastsw``, ``cplr``, ``swing``, ``anglesw``), each with a compiled
``step`` (one sample), ``flush`` and ``batch`` kernel; :mod:`mocapkit.pla.base` wraps them.
"""

from mocapkit.pla.base import METHODS, POS_METHODS, Compressed, Encoder, Point, compress
from mocapkit.pla.metrics import Metrics, evaluate
from mocapkit.pla.reconstruct import reconstruct
from mocapkit.pla.tune import compress_to

__all__ = [
    "METHODS",
    "POS_METHODS",
    "Compressed",
    "Encoder",
    "Point",
    "compress",
    "compress_to",
    "evaluate",
    "Metrics",
    "reconstruct",
]
