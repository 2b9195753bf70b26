"""Jobs: one plain function per job, from an input path plus options to a record.

``info``, ``compress``, ``filter`` and ``segment`` are what the single-file commands print with ``--json``
and what ``mocapkit batch`` runs on every file of a database (in worker processes or on a Dask cluster) and
stores in Parquet and in the catalog. A job never prints; progress goes to an optional callback.
"""

from __future__ import annotations

from pathlib import Path

from mocapkit.errors import InvalidParameterError
from mocapkit.jobs.compress import compress_job
from mocapkit.jobs.filter import filter_job
from mocapkit.jobs.info import info_job
from mocapkit.jobs.segment import segment_job

JOBS = {"info": info_job, "compress": compress_job, "filter": filter_job, "segment": segment_job}

__all__ = ["JOBS", "batch_output", "compress_job", "filter_job", "info_job", "not_read_by", "run_job", "segment_job"]

#: the kinds of input (``mocapkit.io.loaders.kind_of``) each job reads
READS = {"info": ("imu", "skeletal", "markers", "table"), "compress": ("imu", "skeletal"),
         "filter": ("markers",), "segment": ("skeletal",)}
_KIND_WORDS = {"imu": "IMU data", "skeletal": "skeletons", "markers": "marker files", "table": "OpenSim tables"}


def run_job(job: str, path: str | Path, options: dict, output: str | Path | None = None) -> dict:
    """Run job ``job`` on ``path`` with ``options`` (the single-file command's options in snake case,
    JSON-able values) writing its outputs to ``output`` (None: nothing written). Returns the record."""
    if job not in JOBS:
        raise InvalidParameterError(f"unknown job {job!r}: one of {', '.join(JOBS)}")
    return JOBS[job](Path(path), output=None if output is None else Path(output), **options)


def not_read_by(job: str, path: str | Path) -> str | None:
    """Why ``job`` does not read ``path`` (e.g. ``segment`` and a C3D file), judged by the file's kind
    alone; None when it does. A batch lists such inputs as skipped instead of running them into errors.
    ``filter`` reads marker files and CSV text with a time column (IMU data included, as plain columns)."""
    from mocapkit.io.loaders import kind_of

    path = Path(path)
    kind = kind_of(path)
    if job == "filter" and kind in ("imu", "table"):
        if path.is_file() and path.suffix.lower() in (".csv", ".txt"):
            return None
        return f"filter reads marker files and CSV tables with a time column; this is {_KIND_WORDS[kind]}" + (
            "" if path.is_file() else " (a folder)")
    if kind in READS.get(job, ()):
        return None
    if job == "filter":
        return f"filter reads marker files and CSV tables with a time column; this is {_KIND_WORDS[kind]}"
    return f"{job} reads {' and '.join(_KIND_WORDS[k] for k in READS[job])}; this is {_KIND_WORDS[kind]}"


def batch_output(job: str, path: str | Path, options: dict, base: str | Path) -> Path | None:
    """Where ``mocapkit batch`` writes the output of ``job`` for ``path``, with the folders it needs made:
    ``base`` is ``OUT/<relative folder>/<input stem>``. Compressed IMU points go to the folder
    ``<base>.points`` (one CSV per sensor, whatever the number of sensors), a compressed skeleton to
    ``<base>.glb``, filtered values to ``<base>.filtered.csv`` (``.filtered.c3d`` for a C3D input);
    ``info`` and ``segment`` write nothing (their record is the result)."""
    from mocapkit.io.loaders import kind_of

    path, base = Path(path), Path(base)
    if job == "compress":
        if kind_of(path) == "skeletal":
            out = base.with_name(base.name + ".glb")
        else:
            out = base.with_name(base.name + ".points")
            out.mkdir(parents=True, exist_ok=True)
    elif job == "filter":
        keep_c3d = path.suffix.lower() == ".c3d" and not options.get("columns")
        out = base.with_name(base.name + (".filtered.c3d" if keep_c3d else ".filtered.csv"))
    else:
        return None
    out.parent.mkdir(parents=True, exist_ok=True)
    return out
