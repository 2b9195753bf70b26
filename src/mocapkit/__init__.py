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
from mocapkit.io.loaders import load, register_motion_reader
from mocapkit.markers import Markers
from mocapkit.motion import Signal
from mocapkit.skeleton import Motion, Skeleton, forward_kinematics


def _read_mkc(path):
    """A ``.mkc`` clip for :func:`load`: its bytes read by io, decoded by :mod:`mocapkit.clip`."""
    from mocapkit.jobs.readers import read_mkc

    return read_mkc(path)


register_motion_reader(".mkc", _read_mkc)  # io imports no algorithm: the root joins them

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
