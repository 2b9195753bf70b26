"""What the command-line faces share: the consoles, the option checks and types, progress and strict JSON.

``cli.py`` (single-file commands), ``cli_batch.py`` and ``cli_catalog.py`` import from here, so one option is
spelled, checked and documented once.
"""

from __future__ import annotations

import contextlib
import json
import math
from enum import Enum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from mocapkit.errors import InvalidParameterError, MocapError


def _console(stderr: bool = False) -> Console:
    """A rich console; when it is not a terminal (piped, redirected) lines are never cut at 80 columns."""
    c = Console(stderr=stderr)
    return c if c.is_terminal else Console(stderr=stderr, width=100_000)


err = _console(stderr=True)  # diagnostics and progress
console = _console()  # results (stdout)


def _opt_name(param) -> str:
    longs = [o for o in getattr(param, "opts", ()) if o.startswith("--")]
    return longs[0] if longs else f"--{param.name.replace('_', '-')}"


def _show(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _within(lo=None, hi=None, *, lo_open: bool = False, hi_open: bool = False):
    """A typer callback checking an option's number (or each of a list): finite and within ``lo``..``hi``
    (``lo_open``/``hi_open``: strict bounds). Anything else is an InvalidParameterError naming the
    option, which :func:`main` prints on one line with exit code 2 before any work is done."""
    if lo is not None and hi is not None:
        want = f"in {'(' if lo_open else '['}{_show(lo)}, {_show(hi)}{')' if hi_open else ']'}"
    elif lo is not None:
        want = f"{'>' if lo_open else '>='} {_show(lo)}"
    else:
        want = f"{'<' if hi_open else '<='} {_show(hi)}" if hi is not None else "a finite number"

    def ok(v) -> bool:
        if not isinstance(v, int) and not math.isfinite(v):
            return False
        return ((lo is None or (v > lo if lo_open else v >= lo))
                and (hi is None or (v < hi if hi_open else v <= hi)))

    def check(ctx: typer.Context, param: typer.CallbackParam, value):
        if value is None or ctx.resilient_parsing:
            return value
        for v in value if isinstance(value, (list, tuple)) else (value,):
            if not ok(v):
                raise InvalidParameterError(f"{_opt_name(param)} must be {want}, got {_show(v)}")
        return value

    return check


#: limits of the options (documented in the README's "Errors and exit codes"): rates and units within
#: 12 decades keep every time and length far from float64 overflow
RATE_RANGE = (1e-6, 1e6)
UNIT_RANGE = (1e-6, 1e6)
MAX_SEGMENT_LENGTH = 10**9  # = mocapkit.pla.base.MAX_SEGMENT_LENGTH_LIMIT (not imported: numba at start-up)
MAX_FILTER_ORDER = 10  # = mocapkit.filters.api.MAX_ORDER


@contextlib.contextmanager
def _progress(what: str, total: int | None = None):
    """A progress display on stderr (a bar with ETA when ``total`` is known, else a spinner with the
    elapsed time); yields ``update(done, total)``. Nothing is drawn when stderr is not a terminal."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    if not err.is_terminal:  # a log file gets no spinner frames
        yield lambda done, n=None: None
        return
    cols = [SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
            TimeElapsedColumn(), TimeRemainingColumn()] if total else [
            SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn()]
    with Progress(*cols, console=err, transient=True) as prog:
        task = prog.add_task(what, total=total)

        def update(done: int, n: int | None = None) -> None:
            prog.update(task, completed=done, total=n if n is not None else total)

        yield update


class Method(str, Enum):
    fastsw = "fastsw"
    sw = "sw"
    cplr = "cplr"
    swing = "swing"
    anglesw = "anglesw"
    optimal = "optimal"


RateOpt = Annotated[
    float | None,
    typer.Option("--rate", help="Sample rate in Hz, for files without timestamps (legacy x-io, Xsens).",
                 callback=_within(*RATE_RANGE)),
]
TimeColumnOpt = Annotated[
    str | None, typer.Option("--time-column", help="IMU files: the name of the time column, when the guess is wrong.")
]
QuatColumnsOpt = Annotated[
    str | None,
    typer.Option("--quaternion-columns",
                 help="IMU files: the four quaternion column names in w,x,y,z order, e.g. 'W,X,Y,Z'."),
]
ScalarLastOpt = Annotated[
    bool,
    typer.Option("--scalar-last", help="IMU files: numbered quaternion columns (q0..q3, Element 1..4) hold x,y,z,w."),
]
TimeUnitOpt = Annotated[
    str | None,
    typer.Option("--time-unit", help="IMU files: unit of the time column: s, ms, us, ns, or counter (with --rate)."),
]


MethodOpt = Annotated[Method, typer.Option("--method", "-m", help="PLA method.")]
ThresholdOpt = Annotated[
    float | None,
    typer.Option(
        "--threshold",
        "-t",
        help="The method's own bound: SSR per segment (fastsw, sw, cplr), ε per sample (swing), degrees (anglesw).",
        callback=_within(0.0),
    ),
]
MaxAngleOpt = Annotated[
    float | None,
    typer.Option("--max-angle", help="Guarantee: every sample within DEG degrees of the SLERP decode (verified).",
                 callback=_within(0.0, 180.0, lo_open=True, hi_open=True)),
]
MaxLenOpt = Annotated[
    int | None,
    typer.Option("--max-segment-length", callback=_within(1, MAX_SEGMENT_LENGTH),
                 help="At most N sample intervals between segment points (default: 1000 for sw and anglesw, whose "
                      "work per sample grows with the segment; unbounded for the O(1) methods)."),
]



def _check_output(path: Path | None, folder: bool = False, source: Path | None = None, *,
                  inputs=(), option: str = "--output") -> None:
    """Refuse, before any work, an output (``option``) that cannot be written, is the same file as an
    input (``source`` and ``inputs``; hard links and symlinks too) or lies in an input folder
    (:func:`mocapkit.io.atomic.check_output`). The files read implicitly with them (an AMC's ASF, a
    folder's ``Session.xml``...: :func:`mocapkit.io.loaders.companions`) are inputs too."""
    from mocapkit.io.atomic import check_output
    from mocapkit.io.loaders import inputs_with_companions

    if path is None:
        return
    check_output(path, inputs_with_companions([source, *inputs]), folder=folder, option=option)


def _non_finite(obj, where: str = ""):
    """``(field, value)`` of the first NaN or infinity in a JSON-able record, else ``None``."""
    if isinstance(obj, float):
        return None if math.isfinite(obj) else (where or "the value", obj)
    if isinstance(obj, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in obj.items())
    elif isinstance(obj, (list, tuple)):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(obj))
    else:
        return None
    for w, v in items:
        found = _non_finite(v, w)
        if found:
            return found
    return None


def _json(obj, what: str) -> str:
    """``obj`` as strict JSON (RFC 8259: no NaN or Infinity). A non-finite number is an error naming its
    field: a result that cannot be reported exactly is not reported."""
    bad = _non_finite(obj)
    if bad is not None:
        raise MocapError(f"{what}: {bad[0]} is {float(bad[1])!r}, not a finite number; no JSON was written")
    return json.dumps(obj, indent=1, allow_nan=False)


class Solver(str, Enum):
    exact = "exact"
    iterative = "iterative"


class SegMethod(str, Enum):
    auto = "auto"
    arma = "arma"
    pca = "pca"
    kmeans = "kmeans"
    mlp = "mlp"
    kernelcpd = "kernelcpd"
    pelt = "pelt"
    clasp = "clasp"




# the options of the jobs (info, compress, filter, segment), shared by the single-file commands and batch
AsfOpt = Annotated[Path | None, typer.Option("--asf", help="Skeleton for an AMC input.")]
StrictOpt = Annotated[bool, typer.Option("--strict/--no-strict",
                                         help="BVH: a Frames: count that disagrees with the data is an error "
                                              "(default) or is recorded.")]
TargetIcrOpt = Annotated[
    float | None, typer.Option("--target-icr", help="Find the threshold giving this ICR (points/samples).",
                                  callback=_within(0.0, 1.0, lo_open=True))
]
MaxPositionErrorOpt = Annotated[
    float | None,
    typer.Option("--max-position-error",
                 help="Skeletal input: every joint's and End Site's world position within CM (verified).",
                 callback=_within(1e-6, 1e9)),
]
UnitCmOpt = Annotated[
    float | None, typer.Option("--unit-cm", help="Skeletal input: centimetres per file length unit.",
                                  callback=_within(*UNIT_RANGE))
]


class GltfRotations(str, Enum):
    short = "short"
    float = "float"


GltfRotationsOpt = Annotated[
    GltfRotations, typer.Option("--gltf-rotations", help="glTF output: rotation keys as normalized SHORT "
                                "(smaller; the bound is still checked on the file) or FLOAT.")
]
class ErrorMetric(str, Enum):
    joint_end = "joint+end"
    joint = "joint"
    shell = "shell"


ErrorMetricOpt = Annotated[
    ErrorMetric, typer.Option("--error-metric", help="What --max-position-error bounds: every joint and End Site "
                              "(default), the joints only, or (ACL's metric, .mkc only) every shell point at "
                              "--shell-distance along each joint's axes.")
]
ShellDistanceOpt = Annotated[float, typer.Option("--shell-distance", help="Shell metric: the points' distance "
                                                 "from each joint, in cm (ACL's default 3).",
                                                 callback=_within(1e-6, 1e6))]
EntropyOpt = Annotated[str, typer.Option("--entropy", help=".mkc clip: the lossless stage, zstd (fast to decode) or "
                                         "lzma (~8 % smaller, ~2x slower to decode) or smallest (per block).")]
BlockFramesOpt = Annotated[int | None, typer.Option("--block-frames", help=".mkc clip: frames per random-access "
                                                       "block (default 512).", callback=_within(2, 1_000_000))]
OrderOpt = Annotated[int, typer.Option("--order", help="Polynomial order of every chunk (0..10).",
                                       callback=_within(0, MAX_FILTER_ORDER))]
PenaltyOpt = Annotated[float | None, typer.Option("--penalty", help="K: the cost of a knot, in signal units.",
                                                     callback=_within(0.0))]
AutoOpt = Annotated[
    bool, typer.Option("--auto", help="Choose the knot cost from the data (length-independent; see docs).")
]
SolverOpt = Annotated[Solver, typer.Option("--solver", help="exact (global optimum) or iterative (the seed's).")]
MarkersOpt = Annotated[str | None, typer.Option("--markers", help="NAME[:xyz],... (knots shared by the components).")]
ColumnsOpt = Annotated[str | None, typer.Option("--columns", help="CSV columns to filter, each on its own.")]
SegMethodOpt = Annotated[SegMethod, typer.Option("--method", "-m", help="Segmentation method.")]
LabelsOpt = Annotated[Path | None, typer.Option(
    "--labels", help="Reference labels (CMU-86 HACA or mocap6 per-frame): scored and plotted.")]
JointOpt = Annotated[list[str] | None, typer.Option(
    "--joint", help="ROLE=JOINT overrides of the joint map (e.g. spine=Spine3).")]
TrainOpt = Annotated[list[str] | None, typer.Option(
    "--train", help="MOTION=LABELS takes to train --method mlp on (repeat).")]
SegRateOpt = Annotated[float | None, typer.Option("--rate", help="Frame rate of an AMC file (default 120 Hz).",
                                                     callback=_within(*RATE_RANGE))]
DownsampleOpt = Annotated[int | None, typer.Option(
    "--downsample", help="arma and auto: keep every N-th frame (default: the factor nearest to 30 Hz).",
    callback=_within(1, 1_000_000))]


#: Warnings already printed by the ``warnings`` hook of :func:`mocapkit.cli.main` (a reader's
#: ``MocapWarning``, prefixed with the file), so that a record does not print them a second time.
SHOWN_WARNINGS: set[str] = set()


def print_warnings(rec: dict) -> None:
    """A job record's warnings (``warning: ...``) and notes on stderr, one line each; a warning the
    reader already issued for the same file is not repeated."""
    for w in rec.get("warnings", []):
        if any(shown == w or shown.endswith(f": {w}") for shown in SHOWN_WARNINGS):
            continue
        err.print(f"warning: {w}", markup=False, highlight=False)
    for n in rec.get("notes", []):
        err.print(n, markup=False, highlight=False)
