"""mocapkit: compress, filter and segment human-motion recordings.

>>> import mocapkit
>>> take = mocapkit.load("walk.bvh")          # doctest: +SKIP

The packages: :mod:`mocapkit.pla` (compression), :mod:`mocapkit.filters`, :mod:`mocapkit.segment`,
:mod:`mocapkit.io` (readers and writers).

``import mocapkit`` loads only the errors and the file-type dispatcher; the model classes, the version and
every sub-package's names load on first use (PEP 562 ``__getattr__``), so the command line starts fast.
"""

import importlib as _importlib

from mocapkit.errors import (
    BoundViolationError,
    InvalidParameterError,
    InvalidSignalError,
    MocapError,
    MocapFormatError,
)
from mocapkit.io.loaders import load, register_motion_reader

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.markers import Markers
    from mocapkit.motion import Signal
    from mocapkit.skeleton import Motion, Skeleton, forward_kinematics

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.markers": ("Markers",),
    "mocapkit.motion": ("Signal",),
    "mocapkit.skeleton": ("Motion", "Skeleton", "forward_kinematics"),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def _read_mkc(path):
    """A ``.mkc`` clip for :func:`load`: its bytes read by io, decoded by :mod:`mocapkit.clip`."""
    from mocapkit.jobs.readers import read_mkc

    return read_mkc(path)


register_motion_reader(".mkc", _read_mkc)  # io imports no algorithm: the root joins them


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("mocapkit")
    except metadata.PackageNotFoundError:  # running from a source tree that was never installed
        return "0+unknown"


def __getattr__(name: str):
    """A lazy name of ``__all__`` (or ``__version__``), imported on first use and then kept."""
    if name == "__version__":
        value = _version()
    elif name in _WHERE:
        value = getattr(_importlib.import_module(_WHERE[name]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
