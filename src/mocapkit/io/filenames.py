"""File names for names read from a file's contents (a sensor, a device): never a path.

A sensor called ``../victim`` in an OpenSense ``.sto`` column or a ``.mkp`` header, or ``/etc/x``,
must not write outside the output folder. `file_names` maps each name to one plain file name:
every character that is not a letter, digit, ``_``, ``-``, ``.`` or a space becomes ``_``; leading dots
and spaces and trailing dots and spaces are dropped (no hidden file, no ``..``, nothing Windows would
strip); a name Windows reserves (``CON``, ``NUL``, ``COM1``...) gets a leading ``_``; names that end up
equal — also when compared case-insensitively, as macOS and Windows do — get ``-2``, ``-3``... A name
that leaves nothing (``..``, ``///``) or a file name of more than `MAX_NAME_BYTES` bytes is refused.
Every name changed is reported, so nothing is renamed silently.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from mocapkit.errors import MocapFormatError

MAX_NAME_BYTES = 200
_UNSAFE = re.compile(r"[^\w.\- ]")
_RESERVED = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(1, 10)), *(f"lpt{i}" for i in range(1, 10))}


def safe_stem(name: str, source: str) -> str:
    """One name as a file stem that is never a path; `MocapFormatError` (naming `source`) if none is left."""
    s = _UNSAFE.sub("_", str(name)).lstrip(". ").rstrip(". ")
    if not s:
        raise MocapFormatError(source, None, f"the name {name!r} cannot be made a file name "
                                             "(nothing is left once path characters are removed)")
    if s.split(".", 1)[0].casefold() in _RESERVED:
        s = "_" + s
    return s


def file_names(names: Iterable[str], suffix: str, source: str) -> tuple[dict[str, str], list[str]]:
    """``({name: file name}, warnings)`` for names read from `source`, each file name ending in `suffix`.

    The file names are distinct (also case-insensitively) and hold no path separator, so each lies
    directly in the output folder. A warning names every name that was changed.
    """
    out: dict[str, str] = {}
    taken: set[str] = set()
    warnings: list[str] = []
    for name in names:
        stem = safe_stem(name, source)
        fname, k = stem + suffix, 1
        while fname.casefold() in taken:
            k += 1
            fname = f"{stem}-{k}{suffix}"
        if len(fname.encode("utf-8")) > MAX_NAME_BYTES:
            raise MocapFormatError(source, None, f"the name {name!r} is too long for a file name "
                                                 f"(over {MAX_NAME_BYTES} bytes)")
        taken.add(fname.casefold())
        out[name] = fname
        if fname != f"{name}{suffix}":
            warnings.append(f"{source}: the name {name!r} is written as {fname} (a name read from the file "
                            "never becomes a path)")
    return out, warnings
