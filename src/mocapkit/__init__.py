"""mocapkit: compress, filter and segment human-motion recordings.

>>> import mocapkit
>>> take = mocapkit.load("walk.bvh")          # doctest: +SKIP

The packages: :mod:`mocapkit.pla` (compression), :mod:`mocapkit.filters`, :mod:`mocapkit.segment`,
:mod:`mocapkit.io` (readers and writers).
"""

from importlib import metadata as _metadata

from mocapkit.errors import (
    BoundViolationError,
    InvalidParameterError,
    InvalidSignalError,
    MocapError,
    MocapFormatError,
)
from mocapkit.io.loaders import load
from mocapkit.markers import Markers
from mocapkit.motion import Signal
from mocapkit.skeleton import Motion, Skeleton, forward_kinematics

try:
    __version__ = _metadata.version("mocapkit")
except _metadata.PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
__all__ = [
    "BoundViolationError",
    "InvalidParameterError",
    "InvalidSignalError",
    "Markers",
    "MocapError",
    "MocapFormatError",
    "Motion",
    "Signal",
    "Skeleton",
    "__version__",
    "forward_kinematics",
    "load",
]
