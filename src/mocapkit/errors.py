"""The one error hierarchy of mocapkit.

Every error the library raises on purpose derives from :class:`MocapError`; the CLI turns it into a
one-line message and exit code 2.
"""

from __future__ import annotations

from pathlib import Path


class MocapError(Exception):
    """Base class of every error mocapkit raises on purpose."""


class MocapFormatError(MocapError):
    """A file (or stream) is malformed.

    Parameters
    ----------
    path
        The file, or a label such as ``"<stdin>"``.
    line
        1-based line number of the offending line, or ``None`` when the problem is the whole file.
    problem
        What is wrong and, where useful, what was expected.
    """

    def __init__(self, path: str | Path, line: int | None, problem: str):
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = self.path if line is None else f"{self.path}:{line}"
        super().__init__(f"{where}: {problem}")


class InvalidSignalError(MocapError):
    """Arrays handed to the library violate the signal model (shapes, NaN, time order...)."""

    #: set by the C streaming encoder (:mod:`mocapkit.pla.native`) only: the points made before the refused sample
    points: object


class InvalidParameterError(MocapError):
    """A parameter is out of its domain (negative threshold, unknown method, ...)."""


class UnreachableTargetError(InvalidParameterError):
    """A target (a compression ratio...) that no value of the tuned parameter reaches."""


class BoundViolationError(MocapError):
    """A guaranteed error bound was found violated on the output (a bug: please report it)."""


class MocapWarning(UserWarning):
    """A file was read but something in it looks wrong (e.g. a last value that seems cut short);
    issued with :func:`warnings.warn` and also recorded in the result's ``meta["warnings"]``."""


def error_line(e: BaseException) -> str:
    """The one line the command line prints after ``error:`` for this exception (``cli.main``'s rules)."""
    if isinstance(e, MocapError):
        text = str(e)
    elif isinstance(e, MemoryError):
        text = "out of memory (an input or option asks for more than this machine has)"
    elif isinstance(e, OSError):
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        text = f"{where}{e.strerror or e}"
    else:
        text = f"internal error: {type(e).__name__}: {e} (please report it)"
    return " ".join(part.strip() for part in text.splitlines() if part.strip())
