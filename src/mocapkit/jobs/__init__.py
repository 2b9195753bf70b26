"""Jobs: one plain function per job, from an input path plus options to a record.

``info``, ``compress``, ``filter`` and ``segment`` are what the single-file commands print with ``--json``
and what ``mocapkit batch`` runs on every file of a database (in worker processes or on a Dask cluster) and
stores in Parquet and in the catalog. A job never prints; progress goes to an optional callback.
"""

from __future__ import annotations

import importlib as _importlib
from pathlib import Path

from mocapkit.errors import InvalidParameterError, MocapError

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.jobs.compress import compress_job
    from mocapkit.jobs.compress_kinds import (
        ImuCompressOptions,
        PacketCompressOptions,
        SkeletonCompressOptions,
        compress_options,
    )
    from mocapkit.jobs.filter import filter_job
    from mocapkit.jobs.imu_compress import compress_imu
    from mocapkit.jobs.info import info_job
    from mocapkit.jobs.packet_compress import compress_packets
    from mocapkit.jobs.segment import segment_job
    from mocapkit.jobs.skeleton_compress import compress_skeleton
    from mocapkit.jobs.verify import verify_job

    JOBS: dict = {}

#: job -> its module, holding ``<job>_job`` and its ``check_options`` (``info`` has none); imported on first use
_MODULES = {"info": "mocapkit.jobs.info", "compress": "mocapkit.jobs.compress", "filter": "mocapkit.jobs.filter",
            "segment": "mocapkit.jobs.segment", "verify": "mocapkit.jobs.verify"}

#: the compress job by kind and its options (jobs/compress_kinds.py): name -> module, imported on first use
_COMPRESS_NAMES = {"ImuCompressOptions": "mocapkit.jobs.compress_kinds",
                   "SkeletonCompressOptions": "mocapkit.jobs.compress_kinds",
                   "PacketCompressOptions": "mocapkit.jobs.compress_kinds",
                   "compress_options": "mocapkit.jobs.compress_kinds", "compress_imu": "mocapkit.jobs.imu_compress",
                   "compress_skeleton": "mocapkit.jobs.skeleton_compress",
                   "compress_packets": "mocapkit.jobs.packet_compress"}


def _module(job: str):
    if job not in _MODULES:
        raise InvalidParameterError(f"unknown job {job!r}: one of {', '.join(_MODULES)}")
    return _importlib.import_module(_MODULES[job])


def __getattr__(name: str):
    """``JOBS`` (job -> function) and the ``<job>_job`` functions, their modules imported on first use
    (PEP 562: ``import mocapkit.jobs`` loads no job), then kept."""
    if name == "JOBS":
        value = {job: getattr(_module(job), f"{job}_job") for job in _MODULES}
    elif name.endswith("_job") and name[:-4] in _MODULES:
        value = getattr(_module(name[:-4]), name)
    elif name in _COMPRESS_NAMES:
        value = getattr(_importlib.import_module(_COMPRESS_NAMES[name]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = ["JOBS", "ImuCompressOptions", "PacketCompressOptions", "SkeletonCompressOptions", "batch_output",
           "check_options", "compress_imu", "compress_job", "compress_options", "compress_packets",
           "compress_skeleton", "filter_job", "info_job", "not_read_by", "run_job", "segment_job", "verify_job"]

#: the kinds of input (``mocapkit.io.loaders.kind_of``) each job reads
READS = {"info": ("imu", "skeletal", "markers", "table"), "compress": ("imu", "skeletal"),
         "filter": ("markers",), "segment": ("skeletal",), "verify": ("imu", "skeletal")}
_KIND_WORDS = {"imu": "IMU data", "skeletal": "skeletons", "markers": "marker files", "table": "OpenSim tables"}
_KIND_WORD = {"imu": "IMU data", "skeletal": "a skeleton", "markers": "a marker file", "table": "an OpenSim table"}


def run_job(job: str, path: str | Path, options: dict, output: str | Path | None = None) -> dict:
    """Run job ``job`` on ``path`` with ``options`` (the single-file command's options in snake case,
    JSON-able values) writing its outputs to ``output`` (None: nothing written). Returns the record."""
    run = getattr(_module(job), f"{job}_job")
    return run(Path(path), output=None if output is None else Path(output), **options)


def _named_columns_only(path: Path) -> list[str] | None:
    """The header cells of a text table whose first line names its columns, or None (binary, empty,
    undecodable, no header): a table mocapkit could read but holding no orientation columns is skipped,
    anything else is left to the job, which reports the error."""
    import re

    try:
        with open(path, "rb") as fh:
            head = fh.read(65536)
        line = next((ln for ln in head.decode("utf-8").splitlines() if ln.strip()), "")
    except (OSError, UnicodeDecodeError):
        return None
    cells = [c.strip().strip('"') for c in re.split(r"[,;\t]", line)]
    if len(cells) < 2 or not all(re.search(r"[A-Za-z]", c) for c in cells if c):
        return None
    return cells


def not_read_by(job: str, path: str | Path, options: dict | None = None) -> str | None:
    """Why ``job`` does not read ``path`` (``segment`` and a C3D file...), judged by the file's kind and
    the options; None when it does. A batch lists such inputs as skipped (with this reason) instead of
    running them into errors. ``filter`` reads marker files and CSV text with a time column;
    ``compress --max-angle`` is for IMU data, ``--max-position-error`` for skeletons; an IMU-looking table
    whose named columns hold no orientation (x-io ``Inertial.csv``: gyroscope, accelerometer) is not read
    by ``info`` or ``compress``."""
    from mocapkit.io.loaders import kind_of

    options = options or {}
    path = Path(path)
    kind = kind_of(path)
    if job == "filter":
        if kind == "markers" or (kind in ("imu", "table") and path.is_file()
                                 and path.suffix.lower() in (".csv", ".txt")):
            return None
        return (f"filter reads marker files and CSV tables with a time column; this is "
                f"{_KIND_WORD[kind]}{'' if path.is_file() else ' (a folder)'}")
    if kind not in READS.get(job, ()):
        return f"{job} reads {' and '.join(_KIND_WORDS[k] for k in READS[job])}; this is {_KIND_WORD[kind]}"
    if job == "compress" and kind == "skeletal" and options.get("max_angle") is not None \
            and options.get("max_position_error") is None:
        return "--max-angle is a bound for IMU data; skeletons take --max-position-error CM"
    if job == "compress" and kind == "imu" and options.get("max_position_error") is not None \
            and options.get("max_angle") is None:
        return "--max-position-error is a bound for skeletons; IMU data takes --max-angle DEG"
    if kind == "imu" and path.is_file() and path.suffix.lower() in (".csv", ".txt", ".tsv"):
        from mocapkit.io.imu.columns import ColumnOptions
        from mocapkit.io.imu.signals import detect_format

        cols = {k: options.get(k) for k in ("time_column", "quaternion_columns", "scalar_last", "time_unit")}
        try:
            found = detect_format(path, ColumnOptions(**{k: v for k, v in cols.items() if v}))
        except MocapError:
            return None  # a bad column option: the job says so
        header = None if found is not None else _named_columns_only(path)
        if header is not None:
            shown = ", ".join(header[:6]) + (", ..." if len(header) > 6 else "")
            return f"no orientation columns (columns: {shown}); mocapkit reads orientations (quaternions, " \
                   "rotation matrices, Euler angles)"
    return None


def check_options(job: str, options: dict, per_file: bool = False) -> None:
    """Refuse, before any input is read, options that no input could make right (e.g. ``segment --method
    mlp`` without ``--train``): the checks each job makes first, without a file. ``per_file``: a batch's
    options, which each file's manifest entry or sidecar may complete (``compress``: no control, or one
    bound per kind of input)."""
    check = getattr(_module(job), "check_options", None)
    if check is not None:
        extra = {"per_file": True} if per_file and job == "compress" else {}
        check(**{k: v for k, v in options.items() if k in check.__code__.co_varnames}, **extra)


def batch_output(job: str, path: str | Path, options: dict, base: str | Path, make: bool = True) -> Path | None:
    """Where ``mocapkit batch`` writes the output of ``job`` for ``path``, with the folders it needs made
    (``make=False``: only the path):
    ``base`` is ``OUT/<relative folder>/<input stem>``. Compressed IMU points go to the folder
    ``<base>.points`` (one CSV per sensor, whatever the number of sensors), a compressed skeleton to
    ``<base>.glb`` (``<base>.mkc`` with the option ``skeletal_format="mkc"``), filtered values to
    ``<base>.filtered.csv`` (``.filtered.c3d`` for a C3D input);
    ``info`` and ``segment`` write nothing (their record is the result); ``verify`` writes nothing and reads
    what a ``compress`` batch wrote for ``path`` under ``options["compressed_dir"]``
    (:func:`mocapkit.jobs.verify.compressed_output`), which it gets as its ``output``."""
    from mocapkit.io.loaders import kind_of

    path, base = Path(path), Path(base)
    if job == "verify":
        from mocapkit.jobs.verify import compressed_output

        return compressed_output(path, options, base)
    if job == "compress":
        if kind_of(path) == "skeletal":
            out = base.with_name(base.name + "." + (options.get("skeletal_format") or "glb"))
        else:
            out = base.with_name(base.name + ".points")
            if make:
                out.mkdir(parents=True, exist_ok=True)
    elif job == "filter":
        keep_c3d = path.suffix.lower() == ".c3d" and not options.get("columns")
        out = base.with_name(base.name + (".filtered.c3d" if keep_c3d else ".filtered.csv"))
    else:
        return None
    if make:
        out.parent.mkdir(parents=True, exist_ok=True)
    return out
