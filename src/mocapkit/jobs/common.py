"""What every job shares: no-op progress, the IMU column overrides, output entries, the recording.

A job is a plain function ``job(path, *, output=None, progress=None, **options) -> record``: it reads one
input, runs an algorithm, writes the optional outputs (atomically, through :mod:`mocapkit.io.atomic`) and
returns a record of JSON-able values. It never prints, so it runs the same in the command line, in a
worker process of ``mocapkit batch`` or on a Dask worker.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from contextlib import AbstractContextManager
from pathlib import Path

#: ``progress(what, total)`` -> a context manager yielding ``update(done, total=None)``
Progress = Callable[[str, int | None], AbstractContextManager[Callable[..., None]]]


@contextlib.contextmanager
def no_progress(what: str, total: int | None = None):
    """The default progress: nothing is shown."""
    yield lambda done, n=None: None


def imu_columns(time_column=None, quaternion_columns=None, scalar_last=False, time_unit=None) -> dict:
    """The IMU header overrides as keyword arguments of ``load_signals``."""
    return {"time_column": time_column, "quaternion_columns": quaternion_columns, "scalar_last": scalar_last,
            "time_unit": time_unit}


#: the options that change how a file is read, with their defaults (the catalog keys a recording by them)
READING_DEFAULTS = {"rate": None, "asf": None, "time_column": None, "quaternion_columns": None,
                    "scalar_last": False, "time_unit": None, "strict": True}


def reading_options(options: dict) -> dict:
    """The reading options in ``options`` that differ from their default: how a file was read."""
    return {k: options[k] for k, d in READING_DEFAULTS.items() if k in options and options[k] != d}


def output_entry(path: Path, fmt: str, bound: float | None = None, bound_unit: str | None = None) -> dict:
    """One written output as the record lists it (``bytes`` is None for a device or pipe)."""
    p = Path(path)
    try:
        st = os.stat(p)
        size = st.st_size if p.is_file() else None
    except OSError:
        size = None
    return {"path": str(p), "bytes": size, "format": fmt, "bound": bound, "bound_unit": bound_unit}


def check_outputs(path: Path, *outputs: tuple[Path | None, str], inputs=(), folder: bool = False) -> None:
    """Refuse, before any work, outputs that cannot be written or would overwrite an input
    (:func:`mocapkit.io.atomic.check_output`); ``outputs`` are ``(path, option name)`` pairs. The files
    read implicitly with the inputs (:func:`mocapkit.io.loaders.companions`) are inputs too."""
    from mocapkit.io.atomic import check_output
    from mocapkit.io.loaders import inputs_with_companions

    if all(out is None for out, _ in outputs):
        return
    every = inputs_with_companions([path, *inputs])
    for out, option in outputs:
        check_output(out, every, folder=folder, option=option)


def sensor_outputs(folder: Path, names: list[str], path: Path, inputs=()) -> tuple[dict[str, Path], list[str]]:
    """``({sensor: file under folder}, warnings)``: one CSV per sensor, named safely from a name read from
    the data (:func:`mocapkit.io.filenames.file_names`), each file checked like an output (never an input,
    nor a link to one) before anything is written."""
    from mocapkit.io.atomic import check_output
    from mocapkit.io.filenames import file_names

    fnames, warnings = file_names(names, ".csv", str(path))
    dests = {name: folder / f for name, f in fnames.items()}
    for dest in dests.values():
        if dest.exists() or dest.is_symlink():
            check_output(dest, [path, *inputs], option="--output")
    return dests, warnings


def recording(obj, path: Path, fmt: str | None = None) -> dict:
    """The catalog's description of the input (:func:`mocapkit.jobs.recording.describe`)."""
    from mocapkit.jobs.recording import describe

    return describe(obj, path, fmt)
