"""One input of a batch in a worker process: hash it, run the job, and always return a batch row.

:func:`run_one` is the same function on the local process pool and on Dask workers. It never raises for a
bad input: a corrupt, empty or unreadable file becomes a row with ``status="error"`` and the one-line
error the single-file command prints (after ``error:``). The row's fields are described in
``docs/records.md`` ("Batch rows").
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

from mocapkit.errors import error_line  # noqa: F401 - the rows' one-line errors

#: the columns of a batch row, in table order
ROW_FIELDS = ("job", "input", "status", "error", "content_hash", "options_json", "options_hash",
              "mocapkit_version", "started_at", "seconds", "record_json")
#: columns that differ between two runs of the same batch (when and how long)
TIMING_FIELDS = ("started_at", "seconds")


def options_json(options: dict) -> str:
    """The canonical JSON of a job's options: sorted keys, no spaces, paths as strings, strict numbers."""
    return json.dumps(options, sort_keys=True, separators=(",", ":"), allow_nan=False, default=_plain)


def options_hash(options: dict) -> str:
    """sha256 (hex) of :func:`options_json`."""
    return hashlib.sha256(options_json(options).encode()).hexdigest()


def _plain(v):
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    if hasattr(v, "value"):  # an Enum option
        return v.value
    raise TypeError(f"option value {v!r} is not JSON-able")


def numba_cache_dir() -> str | None:
    """The folder every worker's numba cache (``cache=True`` kernels) lives in.

    ``NUMBA_CACHE_DIR`` when set; else ``None`` (numba's own cache in ``__pycache__`` beside the sources,
    which all processes share) when mocapkit's package folder is writable; else a per-user folder
    ``$XDG_CACHE_HOME/mocapkit/numba`` (``~/.cache/mocapkit/numba``).
    """
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        return given
    import mocapkit

    if os.access(Path(mocapkit.__file__).parent, os.W_OK):
        return None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "mocapkit", "numba")


def configure_numba_cache() -> str | None:
    """Point this process (and the processes it starts) at :func:`numba_cache_dir`; returns it.

    Called by the main process before any worker starts and again by each worker before it compiles,
    so a worker of an existing Dask cluster follows the same rule on its own machine."""
    d = numba_cache_dir()
    if d is not None and os.environ.get("NUMBA_CACHE_DIR") != d:
        os.environ["NUMBA_CACHE_DIR"] = d
        if "numba" in sys.modules:  # numba reads its configuration at import: read it again
            from numba.core import config

            config.reload_config()
    return d


def ignore_interrupts() -> None:
    """A pool worker's initializer: Ctrl-C (SIGINT, sent by a terminal to the whole process group) is the
    main process's to handle; it stops the workers itself."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _version() -> str:
    from mocapkit import __version__

    return __version__


def new_row(job: str, path: str | os.PathLike[str], options: dict) -> dict:
    """A row for ``path`` that has not run yet (status ``"error"`` until the job succeeds)."""
    return {"job": job, "input": os.fspath(path), "status": "error", "error": None, "content_hash": None,
            "options_json": options_json(options), "options_hash": options_hash(options),
            "mocapkit_version": _version(),
            "started_at": datetime.now(UTC).isoformat(timespec="microseconds"),
            "seconds": 0.0, "record_json": None}


def failed_row(job: str, path: str | os.PathLike[str], options: dict, error: str) -> dict:
    """A row for an input whose worker never returned (the worker process died, the cluster lost it)."""
    row = new_row(job, path, options)
    row["error"] = error
    return row


def _drop_empty_folder(output) -> None:
    """A failed input leaves no empty output folder behind (``batch_output`` makes the folder of a
    compressed IMU file's points before the job runs); files are never removed."""
    if output is not None and Path(output).is_dir() and not Path(output).is_symlink():
        # not empty: the job wrote something before failing; kept as it is
        with contextlib.suppress(OSError):
            Path(output).rmdir()


def run_one(job: str, path: str | os.PathLike[str], options: dict, out_base: str | os.PathLike[str] | None,
            notes: list[str] | tuple[str, ...] = ()) -> dict:
    """Run ``job`` on one input and return its batch row; never raises for a bad input.

    The output (if the job writes one) goes to ``mocapkit.jobs.batch_output(job, path, options, out_base)``;
    its folder is created. ``notes`` (options the file made needless: :mod:`mocapkit.batch.file_options`)
    open the record's ``warnings``. Every exception becomes ``status="error"`` with :func:`error_line`.
    """
    configure_numba_cache()
    t0 = time.perf_counter()
    row = new_row(job, path, options)
    output = None
    try:
        from mocapkit.jobs import batch_output, run_job
        from mocapkit.jobs.recording import content_hash

        row["content_hash"] = content_hash(path)

        output = None if out_base is None else batch_output(job, Path(path), options, Path(out_base))
        if output is not None:
            Path(output).parent.mkdir(parents=True, exist_ok=True)
        record = run_job(job, Path(path), options, output=output)
        if notes:
            record["warnings"] = [*notes, *record.get("warnings", [])]
        row["record_json"] = json.dumps(record, allow_nan=False, separators=(",", ":"))
        row["status"] = "ok"
    except (Exception, SystemExit) as e:  # noqa: BLE001 - every failure is this input's row
        row["error"] = error_line(e)
        _drop_empty_folder(output)
    row["seconds"] = time.perf_counter() - t0
    return row
