"""mocapkit: compress, filter and segment human-motion recordings."""

from mocapkit.errors import InvalidSignalError, MocapError, MocapFormatError
from mocapkit.motion import Signal

__version__ = "0.1.0"
__all__ = ["MocapError", "MocapFormatError", "InvalidSignalError", "Signal", "__version__"]
