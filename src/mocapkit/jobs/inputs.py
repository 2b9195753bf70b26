"""The inputs of a batch or a catalog import: files, folders (recursively) and globs expanded into a sorted
list of recordings.

A recording is a file whose suffix one of the readers knows (:data:`input_suffixes`). Companion files are
not inputs: an ASF skeleton belongs to the AMC takes beside it (the AMC job finds ``<stem>.asf`` or
``<subject>.asf``, CMU naming, or is given ``--asf``) and ``TAKE.labels.txt`` holds a take's reference
labels and ``TAKE.mocapkit.toml`` its reading options in a batch (:mod:`mocapkit.batch.file_options`).
Hidden files and folders (a name starting with ``.``) and the batch's own output folder are never entered.
Every skipped file that is not hidden is reported with its reason.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mocapkit.errors import InvalidParameterError

#: files that accompany recordings: (name ending, reason reported)
COMPANIONS = ((".asf", "ASF skeleton (read with the AMC takes beside it)"),
              (".labels.txt", "reference labels of a take"),
              (".mocapkit.toml", "reading options of the take beside it (a batch's sidecar)"),
              ("_registers.csv", "x-io register file (read with the quaternion file beside it)"))
_GLOB_MAGIC = ("*", "?", "[")


def input_suffixes() -> tuple[str, ...]:
    """Every suffix a reader knows (lower case): skeletal, marker and OpenSim table files, and the
    suffixes of the IMU readers' table :data:`mocapkit.io.imu.signals.READERS`."""
    from mocapkit.io import loaders  # the suffixes of its skeletal, marker and table readers
    from mocapkit.io.imu.signals import READERS

    return tuple(sorted({*loaders.SKELETAL_SUFFIXES, *loaders.MARKER_SUFFIXES, *loaders.TABLE_SUFFIXES,
                         *READERS}))


@dataclass
class Inputs:
    """The expanded inputs: ``files`` (absolute, sorted, unique) and ``skipped`` ``(path, reason)``."""

    files: list[Path] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)


def _within(path: str, folder: str | None) -> bool:
    return folder is not None and (path == folder or path.startswith(folder.rstrip(os.sep) + os.sep))


def _companion(name: str) -> str | None:
    low = name.lower()
    return next((why for end, why in COMPANIONS if low.endswith(end)), None)


def is_sensor_folder(folder: str | os.PathLike[str]) -> bool:
    """A folder of sensors in the layout of x-io's exports: only sub-folders (hidden names aside), each
    holding CSV/TXT files only, exactly one of them with orientation columns (``Quaternion.csv``; the others,
    e.g. ``Inertial.csv``, are ignored by :func:`mocapkit.io.imu.signals.read_sensor_folder`; so are an x-io
    ``euler.csv``/``matrix.csv`` beside ``quaternion.csv``), and an NGIMU ``Session.xml`` at the top. Such a
    folder is one recording whose sensors are named after the sub-folders."""
    from mocapkit.io.imu.sessions import SESSION_XML, drop_derived
    from mocapkit.io.imu.signals import detect_format

    try:
        entries = [e for e in os.scandir(folder) if not e.name.startswith(".")]
        entries = [e for e in entries if not (e.name.lower() == SESSION_XML.lower() and e.is_file())]
        if not entries or not all(e.is_dir(follow_symlinks=False) for e in entries):
            return False
        for sub in entries:
            files = [e for e in os.scandir(sub.path) if not e.name.startswith(".")]
            if not files or not all(e.is_file() and os.path.splitext(e.name)[1].lower() in (".csv", ".txt")
                                    for e in files):
                return False
            kept, _ = drop_derived([Path(e.path) for e in files if detect_format(e.path) is not None])
            if len(kept) != 1:
                return False
    except OSError:
        return False
    return True


def expand_inputs(args: Sequence[str | os.PathLike[str]], out: str | os.PathLike[str] | None = None) -> Inputs:
    """Expand the command line's INPUT arguments.

    A file is taken as given (a recording, or skipped with its reason), a sensor folder
    (:func:`is_sensor_folder`) is one input, any other folder is walked recursively
    (symlinked folders inside it are not followed; symlinked files are inputs, a dangling one becomes an
    error row; a folder that cannot be listed is reported as skipped),
    an argument that does not exist but holds ``* ? [`` is expanded by :func:`glob.glob` with
    ``recursive=True`` (``**`` spans folders). Paths are made absolute (not resolved: a symlink keeps its
    name). An argument that names nothing, or a glob that matches nothing, is an
    :class:`~mocapkit.errors.InvalidParameterError` naming it, before any work.
    """
    suffixes = input_suffixes()
    out_abs = None if out is None else os.path.abspath(out)
    found: dict[str, None] = {}
    skipped: dict[str, str] = {}

    def consider(p: str, explicit: bool) -> None:
        name = os.path.basename(p)
        if _within(p, out_abs):
            if explicit:
                skipped[p] = "inside the output folder"
            return
        if name.startswith(".") and not explicit:
            return
        why = _companion(name)
        if why is not None:
            skipped[p] = why
        elif os.path.splitext(name)[1].lower() in suffixes:
            found[p] = None
        else:
            skipped[p] = "unknown suffix"

    def walk(folder: str) -> None:
        if _within(folder, out_abs):
            return
        def unreadable(e: OSError) -> None:
            skipped[os.fspath(e.filename)] = f"folder not readable ({e.strerror})"

        for d, dirs, files in os.walk(folder, onerror=unreadable):
            dirs[:] = sorted(x for x in dirs if not x.startswith(".") and not _within(os.path.join(d, x), out_abs))
            if is_sensor_folder(d):  # one recording of several sensors, as `mocapkit info FOLDER` reads it
                found[d] = None
                dirs[:] = []
                continue
            for f in files:
                consider(os.path.join(d, f), explicit=False)

    for arg in args:
        s = os.fspath(arg)
        if os.path.lexists(s):
            items = [s]
        elif any(c in s for c in _GLOB_MAGIC):
            items = glob.glob(s, recursive=True)
            if not items:
                raise InvalidParameterError(f"{s}: no file matches this pattern")
        else:
            raise InvalidParameterError(f"{s}: no such file or folder")
        for item in items:
            p = os.path.abspath(item)
            if os.path.isdir(p):
                walk(p)
            else:
                consider(p, explicit=item == s)
    files = sorted(found)
    return Inputs([Path(f) for f in files], sorted((p, why) for p, why in skipped.items() if p not in found))


def output_bases(files: list[Path], out: Path) -> dict[Path, Path]:
    """Each input's output base ``OUT/<relative dir>/<stem>`` (no suffix), mirroring the input tree under
    ``out`` from the inputs' deepest common folder. Two inputs of one folder with the same stem
    (``walk.bvh``, ``walk.amc``) get ``<stem>-<suffix>`` so that their outputs cannot collide."""
    if not files:
        return {}
    root = os.path.commonpath([os.path.dirname(os.fspath(f)) for f in files])
    seen: dict[tuple[str, str], int] = {}
    for f in files:
        key = (os.path.dirname(os.fspath(f)), f.stem)
        seen[key] = seen.get(key, 0) + 1
    bases = {}
    for f in files:
        rel = os.path.relpath(os.path.dirname(os.fspath(f)), root)
        clash = seen[(os.path.dirname(os.fspath(f)), f.stem)] > 1
        name = f"{f.stem}-{f.suffix[1:]}" if clash else f.stem
        bases[f] = Path(out) / rel / name if rel != "." else Path(out) / name
    return bases
