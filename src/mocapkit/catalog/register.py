"""Register recordings in the catalog without running a job (``mocapkit catalog import``).

Each input is read once by the ``info`` job (:mod:`mocapkit.jobs.info`) in this process; its
``"recording"`` dict, content hash and size go to ``recordings`` and ``channels``. No ``runs`` row is
written. A file that cannot be read is reported with its one-line error and the others go on.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mocapkit.catalog.engine import Catalog

#: recordings written per transaction (a crash loses at most this many)
BATCH = 200


@dataclass
class ImportResult:
    """``registered``: paths written; ``errors``: ``(path, one-line error)``; ``skipped``: ``(path, reason)``
    for files that are no recordings (ASF skeletons, labels, unknown suffixes); ``warnings``: ``(path,
    warning)`` of files registered although the reader found something odd (a truncated file...)."""

    registered: list[str] = field(default_factory=list)
    warnings: list[tuple[str, str]] = field(default_factory=list)
    errors: list[tuple[str, str]] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)


def describe_input(path: str | os.PathLike, asf: Path | None = None,
                   warnings: list | None = None) -> tuple[dict, str, int | None, tuple[str, str]]:
    """``(R, content_hash, bytes, reading)`` of one input (raises what the reader raises; ``reading`` as
    :func:`mocapkit.catalog.ingest.reading_key`); the reader's warnings are appended to ``warnings`` when
    given."""
    from mocapkit.catalog.ingest import input_bytes, reading_key
    from mocapkit.jobs import run_job
    from mocapkit.jobs.recording import content_hash

    h = content_hash(path)
    options = {"asf": os.path.abspath(asf) if asf is not None and Path(path).suffix.lower() == ".amc" else None}
    record = run_job("info", Path(path), options)
    if warnings is not None:
        warnings += record.get("warnings", [])
    return {**record["recording"], "path": os.fspath(path)}, h, input_bytes(os.fspath(path)), reading_key(options)


def import_folder(catalog: Catalog, inputs: Sequence[str | os.PathLike[str]], asf: Path | None = None,
                  on_file: Callable[[str, str | None], None] | None = None) -> ImportResult:
    """Register every recording found in ``inputs`` (files, folders walked recursively, globs: the rules of
    :func:`mocapkit.jobs.inputs.expand_inputs`). ``on_file(path, error_or_None)`` is called after each
    file (progress, messages). An argument naming nothing raises before any work."""
    from mocapkit.catalog.ingest import put_recordings
    from mocapkit.errors import error_line
    from mocapkit.jobs.inputs import expand_inputs

    found = expand_inputs(list(inputs))
    result = ImportResult(skipped=list(found.skipped))
    pending: list[tuple] = []

    def flush() -> None:
        if pending:
            with catalog.transaction():
                put_recordings(catalog, pending)
            result.registered += [item[0]["path"] for item in pending]
            pending.clear()

    for f in found.files:
        try:
            found_warnings: list[str] = []
            pending.append(describe_input(f, asf, found_warnings))
            result.warnings += [(os.fspath(f), w) for w in found_warnings]
            error = None
        except (Exception, SystemExit) as e:  # noqa: BLE001 - every failure is this file's error line
            error = error_line(e)
            result.errors.append((os.fspath(f), error))
        if on_file is not None:
            on_file(os.fspath(f), error)
        if len(pending) >= BATCH:
            flush()
    flush()
    return result
