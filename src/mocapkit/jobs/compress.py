"""The ``compress`` job: the options built by :func:`~mocapkit.jobs.compress_kinds.compress_options` and
the input sent, by its kind, to :func:`~mocapkit.jobs.imu_compress.compress_imu` (orientation streams) or
:func:`~mocapkit.jobs.skeleton_compress.compress_skeleton` (BVH, AMC, MVNX, .mkc)."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import cast

from mocapkit.jobs.common import no_progress
from mocapkit.jobs.compress_kinds import (
    ImuCompressOptions,
    SkeletonCompressOptions,
    check_options,
    compress_options,
)
from mocapkit.jobs.imu_compress import compress_imu
from mocapkit.jobs.skeleton_compress import compress_skeleton

__all__ = ["check_options", "compress_job", "options_for"]

#: what a run needs besides the options (where the result goes, how progress is shown)
RUN_NAMES = ("output", "points_stream", "discard_ok", "progress")
#: the options :func:`compress_job` takes (those of IMU data and of skeletons)
JOB_OPTIONS = (ImuCompressOptions, SkeletonCompressOptions)
JobOptions = ImuCompressOptions | SkeletonCompressOptions
_CHECKED = ("method", "threshold", "target_icr", "max_angle", "max_position_error", "skeletal_format", "error_metric")


def options_for(path: Path, output: Path | None = None, **given) -> JobOptions:
    """The options of compressing ``path`` (IMU data or a skeleton, by the file's kind) to ``output``."""
    from mocapkit.io.loaders import kind_of

    check_options(**{k: given[k] for k in _CHECKED if k in given})  # before the file is looked at, as always
    kind = "skeletal" if kind_of(Path(path)) == "skeletal" else "imu"
    return cast(JobOptions, compress_options(kind, output, **given))


def compress_job(path: Path, **given) -> dict:
    """Compress ``path`` and return the record of ``mocapkit compress --json``: the options given by
    name (the command's, in snake case), the run's ``output``, ``points_stream``, ``discard_ok`` and
    ``progress`` (see :func:`~mocapkit.jobs.imu_compress.compress_imu` and
    :func:`~mocapkit.jobs.skeleton_compress.compress_skeleton`)."""
    unknown = [k for k in given if k not in _NAMES]
    if unknown:
        raise TypeError(f"compress_job() got an unexpected keyword argument {unknown[0]!r}")
    run = {k: given.pop(k) for k in RUN_NAMES if k in given}
    options = options_for(path, run.get("output"), **given)
    if isinstance(options, SkeletonCompressOptions):
        run.pop("points_stream", None)
        return compress_skeleton(Path(path), options, **run)
    return compress_imu(Path(path), options, **run)


def _signature() -> inspect.Signature:
    """``compress_job``'s keywords as ``inspect`` shows them (the batch reads which options the job takes)."""
    from dataclasses import MISSING, fields

    params = [inspect.Parameter("path", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Path)]
    seen = set()
    for cls in JOB_OPTIONS:
        for f in fields(cls):
            if f.name not in seen:
                seen.add(f.name)
                params.append(inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY,
                                                default=None if f.default is MISSING else f.default,
                                                annotation=f.type))
    defaults = {"output": None, "points_stream": None, "discard_ok": True, "progress": no_progress}
    params += [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=defaults[k]) for k in RUN_NAMES]
    return inspect.Signature(params, return_annotation=dict)


compress_job.__signature__ = _signature()  # type: ignore[attr-defined]
_NAMES = frozenset(compress_job.__signature__.parameters) - {"path"}  # type: ignore[attr-defined]
