"""The ``mocapkit`` command line (typer + rich). Thin: parse, call the library, print or write."""

from __future__ import annotations

import contextlib
import json
import math
import sys
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Compress, filter and segment human-motion recordings.",
)


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


def _version(value: bool) -> None:
    if value:
        from mocapkit import __version__

        print(f"mocapkit {__version__}")
        raise typer.Exit()


@app.callback()
def _main_options(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Compress, filter and segment human-motion recordings."""


@contextlib.contextmanager
def _progress(what: str, total: int | None = None):
    """A progress display on stderr (a bar with ETA when ``total`` is known, else a spinner with the
    elapsed time); yields ``update(done, total)``. Nothing is drawn when stderr is not a terminal."""
    from rich.progress import (
        BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn,
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
    Optional[float],
    typer.Option("--rate", help="Sample rate in Hz, for files without timestamps (legacy x-io, Xsens).",
                 callback=_within(*RATE_RANGE)),
]
TimeColumnOpt = Annotated[
    Optional[str], typer.Option("--time-column", help="IMU files: the name of the time column, when the guess is wrong.")
]
QuatColumnsOpt = Annotated[
    Optional[str],
    typer.Option("--quaternion-columns", help="IMU files: the four quaternion column names in w,x,y,z order, e.g. 'W,X,Y,Z'."),
]
ScalarLastOpt = Annotated[
    bool, typer.Option("--scalar-last", help="IMU files: numbered quaternion columns (q0..q3, Element 1..4) hold x,y,z,w.")
]
TimeUnitOpt = Annotated[
    Optional[str], typer.Option("--time-unit", help="IMU files: unit of the time column: s, ms, us, ns, or counter (with --rate).")
]


def _columns(time_column, quaternion_columns, scalar_last, time_unit) -> dict:
    """The IMU header overrides as keyword arguments of load_signals / iter_samples."""
    return {"time_column": time_column, "quaternion_columns": quaternion_columns, "scalar_last": scalar_last,
            "time_unit": time_unit}


def _warn_signals(signals) -> None:
    """Print each loaded signal's ``meta["warnings"]`` to stderr, once per file and text."""
    seen = set()
    for sig in signals.values():
        for w in sig.meta.get("warnings", []):
            if (sig.source, w) not in seen:
                seen.add((sig.source, w))
                err.print(f"warning: {sig.source}: {w}", markup=False, highlight=False)
MethodOpt = Annotated[Method, typer.Option("--method", "-m", help="PLA method.")]
ThresholdOpt = Annotated[
    Optional[float],
    typer.Option(
        "--threshold",
        "-t",
        help="The method's own bound: SSR per segment (fastsw, sw, cplr), ε per sample (swing), degrees (anglesw).",
        callback=_within(0.0),
    ),
]
MaxAngleOpt = Annotated[
    Optional[float],
    typer.Option("--max-angle", help="Guarantee: every sample within DEG degrees of the SLERP decode (verified).",
                 callback=_within(0.0, 180.0, lo_open=True, hi_open=True)),
]
MaxLenOpt = Annotated[
    Optional[int],
    typer.Option("--max-segment-length", callback=_within(1, MAX_SEGMENT_LENGTH),
                 help="At most N sample intervals between segment points (default: 1000 for sw and anglesw, whose "
                      "work per sample grows with the segment; unbounded for the O(1) methods)."),
]


FILE_SUFFIXES = (".csv", ".txt", ".tsv", ".json", ".bvh", ".amc", ".glb", ".gltf", ".c3d", ".trc", ".mot", ".sto",
                 ".png", ".parquet")


def _check_output(path: Optional[Path], folder: bool = False, source: Optional[Path] = None, *,
                  inputs=(), option: str = "--output") -> None:
    """Refuse, before any work, an output (``option``) that cannot be written, is the same file as an
    input (``source`` and ``inputs``; hard links and symlinks too) or lies in an input folder
    (:func:`mocapkit.io.atomic.check_output`)."""
    from mocapkit.io.atomic import check_output

    check_output(path, [source, *inputs], folder=folder, option=option)


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


def _one_control(threshold, target_icr, max_angle) -> None:
    if sum(x is not None for x in (threshold, target_icr, max_angle)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle")


def _record(name: str, source: str, comp, metrics, mode: str, target) -> dict:
    return {
        "name": name,
        "source": source,
        "method": comp.method,
        "mode": mode,
        "target": target,
        "threshold": comp.threshold,
        "max_segment_length": comp.max_segment_length,
        "n_samples": metrics.n_samples,
        "n_points": metrics.n_points,
        "icr": metrics.icr,
        "mean_segment_length": metrics.mean_segment_length,
        "aad_deg": metrics.aad_deg,
        "max_deg": metrics.max_deg,
        "std_deg": metrics.std_deg,
        "point_mean_deg": metrics.point_mean_deg,
        "point_max_deg": metrics.point_max_deg,
    }


def _summary_table(records: list[dict], title: str) -> Table:
    tab = Table(title=title)
    for col in ("signal", "method", "threshold", "samples", "points", "ICR", "AAD °", "max °", "std °"):
        tab.add_column(col, justify="right" if col not in ("signal", "method") else "left")
    for r in records:
        tab.add_row(
            r["name"], r["method"], f"{r['threshold']:.4g}", str(r["n_samples"]), str(r["n_points"]),
            f"{r['icr']:.4f}", f"{r['aad_deg']:.3f}", f"{r['max_deg']:.3f}", f"{r['std_deg']:.3f}",
        )
    return tab


@app.command()
def compress(
    input: Annotated[Path, typer.Argument(help="An IMU file or a folder of sensors.")],
    output: Annotated[
        Optional[Path], typer.Option("--output", "-o", help="Points CSV (a folder when INPUT is a folder).")
    ] = None,
    method: MethodOpt = Method.fastsw,
    threshold: ThresholdOpt = None,
    target_icr: Annotated[
        Optional[float], typer.Option("--target-icr", help="Find the threshold giving this ICR (points/samples).",
                                      callback=_within(0.0, 1.0, lo_open=True))
    ] = None,
    max_angle: MaxAngleOpt = None,
    max_segment_length: MaxLenOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object per signal (a list).")] = False,
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    max_position_error: Annotated[
        Optional[float],
        typer.Option("--max-position-error", help="Skeletal input: every joint's world position within CM (verified).",
                     callback=_within(1e-6, 1e9)),
    ] = None,
    unit_cm: Annotated[
        Optional[float], typer.Option("--unit-cm", help="Skeletal input: centimetres per file length unit.",
                                      callback=_within(*UNIT_RANGE))
    ] = None,
    strict: Annotated[bool, typer.Option("--strict/--no-strict", help="BVH: Frames: mismatch is an error (default) or is recorded.")] = True,
    stats_only: Annotated[
        bool, typer.Option("--stats-only", help="Only measure (print the table); write no points or clip.")
    ] = False,
) -> None:
    """Compress orientation streams (IMU files, sensor folders) or whole skeletons (BVH, AMC).

    IMU input: segment points as CSV time,w,x,y,z (to -o, or to stdout for one file). Skeletal input:
    keyframes as glTF (.glb/.gltf) or the decoded full-rate motion as .bvh (-o). Without -o, a result
    that cannot go to stdout is refused before any work unless --json or --stats-only asks for the numbers.
    """
    from mocapkit.io.loaders import kind_of

    if stats_only and output is not None:
        raise InvalidParameterError("--stats-only writes nothing: drop it or drop --output")
    _check_output(output, folder=input.is_dir() or (output is not None and output.is_dir()), source=input,
                  inputs=(asf,))
    if kind_of(input) == "skeletal":
        if output is None and not (as_json or stats_only):
            raise InvalidParameterError(
                f"{input}: give -o OUT.glb|OUT.gltf|OUT.bvh to keep the compressed clip "
                "(or --json / --stats-only to print only the numbers)")
        _compress_skeletal(input, output, method, threshold, target_icr, max_position_error, max_angle,
                           max_segment_length, rate, as_json, asf, unit_cm, strict)
        return
    if max_position_error is not None or asf is not None or unit_cm is not None:
        raise InvalidParameterError("--max-position-error, --asf and --unit-cm apply to BVH/AMC input")
    from mocapkit.io import load_signals, write_signal_csv
    from mocapkit.io.atomic import is_device_or_pipe
    from mocapkit.pla import compress_to, evaluate

    _one_control(threshold, target_icr, max_angle)
    signals = load_signals(input, rate=rate, **_columns(time_column, quaternion_columns, scalar_last, time_unit))
    _warn_signals(signals)
    folder_mode = input.is_dir() or len(signals) > 1  # one CSV per sensor
    what = "a folder" if input.is_dir() else f"a file of {len(signals)} sensors"
    if folder_mode and output is not None and output.exists() and not output.is_dir():
        raise InvalidParameterError(f"{output}: INPUT is {what}, so --output must be a folder")
    if folder_mode and output is None and not (as_json or stats_only):
        raise InvalidParameterError(
            f"{input} is {what}: give -o FOLDER to keep the segment points (one CSV per sensor), "
            "or --json / --stats-only to print only the numbers")
    if output is not None and folder_mode and output.suffix.lower() in FILE_SUFFIXES:
        raise InvalidParameterError(f"{output}: INPUT is {what}, so --output is a folder (one CSV per sensor), "
                                    f"not a {output.suffix} file")
    if output is not None and not folder_mode and output.suffix.lower() != ".csv" and not is_device_or_pipe(output):
        raise InvalidParameterError(f"{output}: segment points are written as .csv")
    points_to_stdout = output is None and not folder_mode and not as_json and not stats_only
    mode, target = (
        ("threshold", threshold) if threshold is not None
        else ("target_icr", target_icr) if target_icr is not None
        else ("max_angle", max_angle)
    )
    records = []
    with _progress(f"compressing {input.name}", total=len(signals)) as update:
        comps = {}
        for i, (name, sig) in enumerate(signals.items()):
            with _naming_target_icr(target_icr):
                comps[name] = compress_to(
                    sig, method.value, threshold=threshold, target_icr=target_icr, max_angle=max_angle,
                    max_segment_length=max_segment_length,
                )
            update(i + 1)
    for name, sig in signals.items():
        comp = comps[name]
        met = evaluate(sig, comp)
        records.append(_record(name, sig.source, comp, met, mode, target))
        if output is not None:
            dest = output / f"{name}.csv" if folder_mode else output
            if folder_mode:
                output.mkdir(exist_ok=True)  # one new level; its parent was checked before any work
            write_signal_csv(dest, comp.times, comp.values)
        elif points_to_stdout:
            sys.stdout.write("time,w,x,y,z\n")
            for t, v in zip(comp.times.tolist(), comp.values.tolist()):
                sys.stdout.write(",".join(repr(x) for x in (t, *v)) + "\n")
    if as_json:
        print(_json(records, "compress --json"))
    else:  # the table is the result unless the points went to stdout
        (err if points_to_stdout else console).print(_summary_table(records, f"{method.value}: {mode} {target:g}"))
    skipped = sorted({f for s in signals.values() for f in s.meta.get("skipped_files", [])})
    if skipped:
        err.print(f"not orientation data, skipped: {', '.join(skipped)}")


@contextlib.contextmanager
def _naming_target_icr(target_icr):
    """An unreachable ``--target-icr`` is reported under the option's name."""
    from mocapkit.errors import UnreachableTargetError

    try:
        yield
    except UnreachableTargetError as e:
        raise InvalidParameterError(f"--target-icr {target_icr:g}: {e}") from None


def _compress_skeletal(input, output, method, threshold, target_icr, max_position_error, max_angle,
                       max_segment_length, rate, as_json, asf, unit_cm, strict=True) -> None:
    from mocapkit.io.bvh import write_bvh
    from mocapkit.io.gltf import write_gltf
    from mocapkit.io.loaders import load_motion, unit_cm as find_unit
    from mocapkit.pla.skeletal import compress_motion, report, verify_position_bound

    if max_angle is not None:
        raise InvalidParameterError("for skeletal input use --max-position-error CM (or --threshold / --target-icr)")
    if sum(x is not None for x in (threshold, target_icr, max_position_error)) != 1:
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-position-error")
    if output is not None and output.suffix.lower() not in (".glb", ".gltf", ".bvh"):
        raise InvalidParameterError(f"{output}: skeletal output is .glb, .gltf or .bvh")
    motion = load_motion(input, asf=asf, rate=rate, strict=strict)
    ucm, assumed = find_unit(motion, unit_cm)
    bound = None if max_position_error is None else max_position_error / ucm
    steps = None if threshold is not None else 41 if target_icr is not None else 15
    with _progress(f"compressing {input.name}", total=steps) as update, _naming_target_icr(target_icr):
        comp = compress_motion(
            motion, method.value, threshold=threshold, target_icr=target_icr, max_position_error=bound,
            max_segment_length=max_segment_length, progress=update,
        )
        if bound is not None:
            verify_position_bound(motion, comp, bound)
    rec = {"file": str(input), **report(comp, ucm), "unit_cm_assumed": assumed}
    if output is not None:
        if output.suffix.lower() == ".bvh":
            write_bvh(output, comp.decode(), precision=6)
        else:
            write_gltf(output, comp, unit_m=ucm / 100.0, name=input.stem)
        rec["output"] = str(output)
        rec["file_bytes"] = output.stat().st_size
    if as_json:
        print(_json(rec, f"{input}: compress --json"))
    else:
        tab = Table(title=f"{input.name}: {rec['method']} ({rec['mode']})")
        tab.add_column("quantity")
        tab.add_column("value", justify="right")
        for k in ("n_frames", "n_joints", "keyframes", "icr", "max_position_error_cm", "mean_position_error_cm",
                  "aad_deg", "max_deg", "bytes_raw", "bytes_out", "ratio"):
            v = rec[k]
            tab.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
        console.print(tab)
        if assumed:
            err.print("length unit assumed to be 1 cm; give --unit-cm for other units")


@app.command()
def info(
    input: Annotated[Path, typer.Argument(help="BVH, AMC, C3D, Qualisys TSV, IMU file or sensor folder.")],
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    strict: Annotated[bool, typer.Option("--strict/--no-strict", help="BVH: a Frames: count that disagrees with the data is an error (default) or is recorded.")] = True,
) -> None:
    """Describe a motion file: joints, frames, rate, duration, channels, markers."""
    from mocapkit.io.loaders import kind_of, load_motion

    kind = kind_of(input)
    if kind == "skeletal":
        m = load_motion(input, asf=asf, rate=rate, strict=strict)
        sk = m.skeleton
        rec = {
            "file": str(input), "kind": "skeletal", "frames": m.n_frames, "rate_hz": m.rate,
            "duration_s": m.n_frames * m.frame_time, "joints": sk.n_joints, "channels": sk.n_channels,
            "end_sites": len(sk.end_sites), "roots": [sk.names[j] for j in range(sk.n_joints) if sk.parents[j] < 0],
            "joint_names": list(sk.names),
            "joint_channels": {sk.names[j]: list(sk.channels[j]) for j in range(sk.n_joints)},
            "warnings": m.meta.get("warnings", []),
        }
    elif kind == "markers":
        from mocapkit.markers import load_markers

        mk = load_markers(input)
        rec = {
            "file": str(input), "kind": "markers", "frames": int(mk.times.shape[0]), "rate_hz": mk.rate,
            "duration_s": float(mk.times.shape[0] / mk.rate), "markers": len(mk.labels), "labels": list(mk.labels),
            "units": mk.units, "missing_fraction": float(np.isnan(mk.positions[..., 0]).mean()),
            "analog_channels": 0 if not mk.analog else len(mk.analog.get("labels", [])),
            "format": mk.meta.get("format"), "warnings": list(mk.meta.get("warnings", [])),
        }
    elif kind == "table":
        from mocapkit.io.opensim import read_table

        sig = read_table(input)
        rec = {
            "file": str(input), "kind": "table", "name": sig.meta.get("name"), "frames": len(sig),
            "rate_hz": sig.meta.get("rate") or sig.mean_rate, "duration_s": sig.duration,
            "columns": sig.values.shape[1], "labels": list(sig.meta["labels"]),
            "in_degrees": sig.meta.get("in_degrees"), "format": sig.meta.get("format"),
            "warnings": list(sig.meta.get("warnings", [])),
        }
    else:
        from mocapkit.io import load_signals

        sigs = load_signals(input, rate=rate, **_columns(time_column, quaternion_columns, scalar_last, time_unit))
        rec = {
            "file": str(input), "kind": "imu", "signals": {
                n: {"samples": len(s), "duration_s": s.duration, "mean_rate_hz": s.mean_rate,
                    "format": s.meta.get("format"), "largest_gap_s": float(np.diff(s.times).max()) if len(s) > 1 else 0.0,
                    "time_column": s.meta.get("time_column"), "time_unit": s.meta.get("time_unit"),
                    "stated_rate_hz": s.meta.get("rate"),
                    "orientation_columns": s.meta.get("orientation_columns"), "conversion": s.meta.get("conversion")}
                for n, s in sigs.items()
            },
            "warnings": [f"{n}: {w}" for n, s in sigs.items() for w in s.meta.get("warnings", [])],
        }
    if as_json:
        print(_json(rec, f"{input}: info --json"))
    else:
        _print_info(rec)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return ", ".join(_fmt(x) for x in v) if v else "-"
    return "-" if v is None else str(v)


def _print_info(rec: dict) -> None:
    """``info``'s record as tables on stdout: the file's fields, then one row per signal."""
    title = str(rec.get("file"))
    tab = Table(title=title, min_width=len(title) + 4)  # the path is never wrapped
    tab.add_column("field")
    tab.add_column("value")
    nested = {}
    for k, v in rec.items():
        if k == "file":
            continue
        if isinstance(v, dict) and v and all(isinstance(x, dict) for x in v.values()):
            nested[k] = v  # e.g. IMU signals: a table of their own
            continue
        if k in ("joint_names", "joint_channels", "labels"):
            v = f"{len(v)} entries (see --json)"
        elif k == "warnings":
            v = "\n".join(map(str, v)) if v else "-"
        tab.add_row(k, _fmt(v))
    console.print(tab)
    for k, rows in nested.items():
        cols = list(dict.fromkeys(c for r in rows.values() for c in r))
        sub = Table(title=k)
        sub.add_column("name")
        for c in cols:
            sub.add_column(c, justify="right")
        for name, r in rows.items():
            sub.add_row(name, *(_fmt(r.get(c)) for c in cols))
        console.print(sub)


@app.command()
def convert(
    input: Annotated[Path, typer.Argument(help="AMC (+ --asf), BVH or Xsens MVNX; markers (C3D, TSV, TRC, CSV); MOT/STO.")],
    output: Annotated[Path, typer.Argument(help="BVH or AMC for skeletal input; .csv/.c3d/.trc for markers; .mot/.sto/.csv for tables.")],
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    precision: Annotated[int, typer.Option("--precision", help="Decimals written to BVH.", callback=_within(0, 20))] = 6,
    strict: Annotated[bool, typer.Option("--strict/--no-strict", help="BVH: Frames: mismatch is an error (default) or is recorded.")] = True,
    max_residual: Annotated[float, typer.Option("--max-residual", help="BVH -> AMC: largest rotation (deg) the ASF's dofs may fail to express.",
                                                          callback=_within(0.0, 180.0))] = 0.1,
) -> None:
    """Convert AMC (with its ASF) to BVH and back (BVH + --asf to AMC); markers (C3D, TSV, TRC, Vicon CSV)
    to CSV, C3D or TRC; OpenSim MOT/STO to MOT, STO or CSV."""
    _check_output(output, source=input, inputs=(asf,), option="OUTPUT")
    from mocapkit.io.loaders import kind_of, load_motion

    kind = kind_of(input)
    if kind == "skeletal":
        suffix = output.suffix.lower()
        if suffix not in (".bvh", ".amc"):
            raise InvalidParameterError(f"{output}: skeletal motion converts to .bvh or .amc")
        if suffix == ".bvh":
            from mocapkit.io.bvh import write_bvh

            m = load_motion(input, asf=asf, strict=strict)
            write_bvh(output, m, precision=precision)
            ucm = m.skeleton.meta.get("length_unit_cm")
            note = "" if ucm is None else f"; lengths in the input's unit (1 unit = {ucm:g} cm)"
        else:
            if asf is None or input.suffix.lower() != ".bvh":
                raise InvalidParameterError("BVH -> AMC needs --asf (the skeleton the BVH was made from)")
            from mocapkit.io.amc import read_asf, write_amc

            m = load_motion(input, strict=strict)
            try:
                rep = write_amc(output, m, read_asf(asf), max_residual_deg=max_residual)
            except InvalidSignalError as e:  # a rotation the ASF's dofs cannot express: name the files
                raise InvalidSignalError(f"{input} -> {output}: {e}; --max-residual DEG sets the limit") from None
            note = (f"; largest rotation residual {rep['max_residual_deg']:.3g} deg ({rep['joint']}, frame "
                    f"{rep['frame']}; limit {max_residual:g} deg)")
        err.print(f"{input} -> {output}: {m.n_frames} frames, {m.skeleton.n_joints} joints{note}")
        for w in m.meta.get("warnings", []):
            err.print(f"warning: {input}: {w}")
    elif kind == "markers":
        from mocapkit.io.loaders import MARKER_WRITE_SUFFIXES, load_markers, write_markers

        if output.suffix.lower() not in MARKER_WRITE_SUFFIXES:
            raise InvalidParameterError(f"{output}: markers convert to {', '.join(MARKER_WRITE_SUFFIXES)}")
        mk = load_markers(input)
        write_markers(mk, output)
        err.print(f"{input} -> {output}: {mk.times.shape[0]} frames, {len(mk.labels)} markers")
        for w in mk.meta.get("warnings", []):
            err.print(f"warning: {input}: {w}")
    elif input.suffix.lower() in (".mot", ".sto"):
        from mocapkit.io.opensim import read_opensim_signals, write_orientations, write_table, write_table_csv

        suffix = output.suffix.lower()
        if suffix not in (".mot", ".sto", ".csv"):
            raise InvalidParameterError(f"{output}: an OpenSim table converts to .mot, .sto or .csv")
        sigs = read_opensim_signals(input)
        first = next(iter(sigs.values()))
        if suffix == ".csv":
            write_table_csv(sigs, output)
        elif kind == "table":
            write_table(first, output)
        else:
            write_orientations(sigs, output, rate=first.meta.get("rate"))
        err.print(f"{input} -> {output}: {len(first)} frames, "
                  + (f"{first.values.shape[1]} columns" if kind == "table" else f"{len(sigs)} IMUs"))
    else:
        raise InvalidParameterError(f"{input}: convert reads BVH, AMC, markers (C3D, TSV, TRC, CSV) or MOT/STO files")


class Solver(str, Enum):
    exact = "exact"
    iterative = "iterative"


def _filter_inputs(input: Path, markers: Optional[str], columns: Optional[str]):
    """``[(name, times, values (N, D), component names)]`` to filter."""
    from mocapkit.io.loaders import kind_of

    out = []
    if markers is not None and columns is not None:
        raise InvalidParameterError("give --markers or --columns, not both")
    is_markers = kind_of(input) == "markers"
    if is_markers and columns is not None and input.suffix.lower() == ".csv":
        from mocapkit.io.vicon_csv import is_vicon_csv

        is_markers = is_vicon_csv(input)  # --columns reads a wide marker CSV as plain columns
    if is_markers and columns is not None:
        raise InvalidParameterError(f"{input} is a marker file: choose markers with --markers NAME[:xyz],... "
                                    "(--columns is for plain CSV files)")
    if is_markers:
        from mocapkit.markers import load_markers

        mk = load_markers(input)
        wanted = [w.strip() for w in markers.split(",")] if markers else list(mk.labels)
        for w in wanted:
            # labels may contain ':' themselves (Vicon's "Subject:Marker"): a suffix is a component
            # selection only when the whole string is not a label
            name, comp = (w, "") if w in mk.labels else (w.rpartition(":")[0] or w, w.rpartition(":")[2] if ":" in w else "")
            if name not in mk.labels:
                raise InvalidParameterError(f"{input}: no marker {name!r} (markers: {', '.join(mk.labels[:12])}...)")
            comps = comp.lower() or "xyz"
            if any(c not in "xyz" for c in comps):
                raise InvalidParameterError(f"{w!r}: components are x, y, z (e.g. {name}:z)")
            cols = ["xyz".index(c) for c in comps]
            out.append((w, mk.times, mk.positions[:, mk.labels.index(name)][:, cols], [f"{name}_{c}" for c in comps]))
        return out
    if markers is not None:
        raise InvalidParameterError(f"{input}: --markers needs a C3D, Qualisys TSV or marker CSV file")
    if kind_of(input) not in ("imu", "table") or input.suffix.lower() not in (".csv", ".txt"):
        raise InvalidParameterError(f"{input}: filter reads marker files (C3D, TSV, TRC, marker CSV) or a CSV "
                                    "with a time column; for skeletal motion, convert it or segment it")
    # a plain CSV with a header: a time column (first) and named columns (strict, bounded: io/timetable.py)
    from mocapkit.io.timetable import read_time_table

    tab = read_time_table(input)
    names = [c.strip() for c in columns.split(",")] if columns else tab.columns
    for c in names:
        if c not in tab.columns:
            raise InvalidParameterError(f"{input}: no column {c!r} (columns: {', '.join(tab.columns)})")
        out.append((c, tab.times, tab.values[:, [tab.columns.index(c)]], [c]))
    return out


@app.command("filter")
def filter_cmd(
    input: Annotated[Path, typer.Argument(help="C3D, Qualisys TSV, marker CSV or a CSV with a time column.")],
    order: Annotated[int, typer.Option("--order", help="Polynomial order of every chunk (0..10).",
                                       callback=_within(0, MAX_FILTER_ORDER))] = 2,
    penalty: Annotated[Optional[float], typer.Option("--penalty", help="K: the cost of a knot, in signal units.",
                                                     callback=_within(0.0))] = None,
    auto: Annotated[bool, typer.Option("--auto", help="Choose the knot cost from the data (length-independent; see docs).")] = False,
    solver: Annotated[Solver, typer.Option("--solver", help="exact (global optimum) or iterative (the seed's).")] = Solver.exact,
    markers: Annotated[Optional[str], typer.Option("--markers", help="NAME[:xyz],... (knots shared by the components).")] = None,
    columns: Annotated[Optional[str], typer.Option("--columns", help="CSV columns to filter, each on its own.")] = None,
    output: Annotated[Optional[Path], typer.Option("--output", "-o", help="Filtered values at the input times: CSV, or .c3d/.trc for markers.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Knots and polynomial pieces as JSON.")] = False,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: position and two derivatives of the first signal.")] = None,
) -> None:
    """Filter by piecewise polynomials: keeps discontinuities (catches, throws, heel strikes)."""
    from mocapkit.filters.api import fit

    if (penalty is None) == (not auto):
        raise InvalidParameterError("give exactly one of --penalty K or --auto")
    if order < 0:
        raise InvalidParameterError("--order must be >= 0")
    _check_output(output, source=input)
    _check_output(plot, source=input, option="--plot")
    from mocapkit.io.atomic import is_device_or_pipe

    suffix = None if output is None else output.suffix.lower()
    if suffix == "" and is_device_or_pipe(output):  # /dev/null, /dev/stdout, a FIFO: written into, as CSV
        suffix = ".csv"
    if suffix not in (None, ".csv", ".c3d", ".trc"):
        raise InvalidParameterError(f"{output}: filter writes .csv, or .c3d/.trc for a marker file")
    marker_out = suffix in (".c3d", ".trc")
    if marker_out:
        from mocapkit.io.loaders import kind_of

        if kind_of(input) != "markers" or columns is not None:
            raise InvalidParameterError(f"{output}: a .c3d/.trc output needs a marker file as input")
    signals = _filter_inputs(input, markers, columns)
    if marker_out and any(comps != [f"{c[:-2]}_x", f"{c[:-2]}_y", f"{c[:-2]}_z"] for (_, _, _, comps) in signals
                          for c in comps[:1]):
        raise InvalidParameterError(f"{output}: a .c3d/.trc output needs whole markers (x, y, z), not components")
    results = []
    with _progress(f"filtering {input.name}", total=len(signals)) as update:
        for i, (name, t, Y, comps) in enumerate(signals):
            try:
                r = fit(t, Y, order, penalty, solver.value)
            except InvalidParameterError as e:  # e.g. a marker that is (almost) never seen: report, go on
                err.print(f"warning: {name}: not filtered ({e}); written as missing")
                r = None
            results.append((name, t, Y, comps, r))
            update(i + 1)
    if all(r is None for *_, r in results):
        raise InvalidParameterError(f"{input}: no signal could be filtered (see the warnings above)")
    for name, t, Y, comps, r in results:
        for a, b in (r.unfitted if r is not None else []):
            err.print(f"warning: {name}: samples at {a:g}..{b:g} s lie between long gaps and are too few to "
                      f"fit with order {order}: left out (NaN in the output)")

    def filtered(t, Y, r) -> np.ndarray:
        return np.full(Y.shape, np.nan) if r is None else np.asarray(r.evaluate(t)).reshape(Y.shape)

    if marker_out:
        # the input's markers with the filtered ones replaced; labels, rate, units, gaps and analog kept
        from mocapkit.io.loaders import load_markers, write_markers
        from mocapkit.markers import Markers

        mk = load_markers(input)
        pos = np.array(mk.positions)
        done = []
        for name, t, Y, comps, r in results:
            j = mk.labels.index(comps[0][:-2])
            pos[:, j] = np.where(np.isnan(Y), np.nan, filtered(t, Y, r))
            done.append(j)
        write_markers(Markers(mk.times, pos, mk.labels, mk.rate, units=mk.units, analog=mk.analog,
                              source=str(output), meta={"filtered_from": str(input)}), output)
        kept = len(mk.labels) - len(set(done))
        if kept:
            err.print(f"{output}: {len(set(done))} markers filtered, {kept} copied unfiltered")
    elif output is not None:
        from mocapkit.io.atomic import atomic_write_text

        t = results[0][1]
        cols = [filtered(tt, Y, r) for (_, tt, Y, _, r) in results]
        head = ["time"] + [c for (_, _, _, comps, _) in results for c in comps]
        from mocapkit.io.loaders import kind_of, load_markers

        if kind_of(input) == "markers" and columns is None:  # keep the length unit in the column names
            units = load_markers(input).units
            head = ["time (s)"] + [f"{c} ({units})" for c in head[1:]]
        body = np.column_stack([t] + cols)
        atomic_write_text(output, ",".join(head) + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in body) + "\n")
    if as_json:
        recs = []
        for name, t, Y, comps, r in results:
            D = Y.shape[1]
            if r is None:
                recs.append({"name": name, "components": comps, "order": order, "error": "not filtered"})
                continue
            recs.append({
                "name": name, "components": comps, "order": order, "penalty": r.penalty, "solver": r.solver,
                "loss": r.loss, "iterative_loss": r.iterative_loss, "knot_cost": r.knot_cost, "n_knots": r.n_knots,
                "pieces": [{"t0": p.t0, "t1": p.t1,
                            "coeffs": p.coeffs[:, 0].tolist() if D == 1 else [p.coeffs[:, d].tolist() for d in range(D)]}
                           for p in r.pieces],
            })
        print(_json(recs, f"{input}: filter --json"))
    else:
        tab = Table(title=f"{input.name}: piecewise polynomials of order {order} "
                          f"({'automatic knot cost' if auto else solver.value})")
        for c in ("signal", "K", "knots", "pieces", "loss", "iterative loss"):
            tab.add_column(c, justify="right")
        for name, t, Y, comps, r in results:
            if r is None:
                tab.add_row(name, "–", "not filtered", "", "", "")
                continue
            tab.add_row(name, f"{r.penalty:.4g}", str(r.n_knots), str(len(r.pieces)), f"{r.loss:.6g}",
                        "–" if r.iterative_loss is None else f"{r.iterative_loss:.6g}")
        console.print(tab)
    if plot is not None:
        from mocapkit.plot import plot_ppa

        name, t, Y, comps, r = next(x for x in results if x[4] is not None)
        plot_ppa(t, Y[:, -1], r, plot, title=f"{input.name}: {comps[-1]}")


@app.command("filter-eval")
def filter_eval(
    out: Annotated[Path, typer.Option("--out", help="Folder for the JSON results and figures.")] = Path("filter-out"),
    juggling: Annotated[Optional[Path], typer.Option("--juggling", help="A marker file (Qualisys TSV, C3D, TRC, marker CSV) with thrown balls, Z up.")] = None,
    balls: Annotated[Optional[str], typer.Option("--balls", help="Ball markers A,B,C (default: every marker that moves, see docs).")] = None,
    controls: Annotated[Optional[str], typer.Option("--controls", help="Static control markers (default: every marker that does not move).")] = None,
    penalty: Annotated[Optional[float], typer.Option("--penalty", help="K of Eq. 2 for the balls (default: --auto).",
                                                     callback=_within(0.0))] = None,
    unit_m: Annotated[float, typer.Option("--unit-m", help="Metres per unit of the marker file (mm: 0.001).",
                                          callback=_within(*UNIT_RANGE))] = 1e-3,
    sizes: Annotated[str, typer.Option("--sizes", help="Signal lengths for the exact solver's time curve ('' to skip).")] = "1000,2000,5000,10000,20000,50000",
) -> None:
    """The filtering experiments: synthetic Figure 2 signal, step overshoot, juggling flights, timing."""
    from mocapkit.evaluation.filtering import evaluate_juggling, evaluate_synthetic, exact_time_curve, figures, moving_markers
    from mocapkit.io.atomic import atomic_write_text

    _check_output(out, folder=True, inputs=(juggling,), option="--out")
    mk = ball_list = None
    ctrl: list[str] = []
    if juggling is not None:  # read and check everything before any long computation
        from mocapkit.markers import load_markers

        mk = load_markers(juggling)
        moving, static = moving_markers(mk)

        def names(opt: str, what: str) -> list[str]:
            got = [b.strip() for b in opt.split(",") if b.strip()]
            bad = [b for b in got if b not in mk.labels]
            if bad or not got:
                raise InvalidParameterError(f"{juggling}: no marker {', '.join(map(repr, bad)) or '(empty list)'} for "
                                            f"{what} (markers: {', '.join(mk.labels)})")
            return got

        ball_list = names(balls, "--balls") if balls is not None else moving
        ctrl = names(controls, "--controls") if controls is not None else static
        if not ball_list:
            raise InvalidParameterError(f"{juggling}: no moving marker with at least half of its frames found; "
                                        "name the balls with --balls A,B,C")
    if penalty is not None and not penalty >= 0:
        raise InvalidParameterError("--penalty must be >= 0")
    n_sizes = tuple(int(x) if x.strip().isdigit() and 10 <= int(x) <= 10_000_000 else -1
                    for x in sizes.split(",") if x.strip())
    if any(n < 0 for n in n_sizes):
        raise InvalidParameterError(f"--sizes must be comma-separated integers in 10..10000000 (or ''), got {sizes!r}")
    out.mkdir(parents=True, exist_ok=True)
    syn = evaluate_synthetic()
    atomic_write_text(out / "synthetic.json", _json(syn, "filter-eval synthetic.json"))
    if mk is not None:
        jug = evaluate_juggling(mk, ball_list, penalty=penalty, unit_m=unit_m, controls=ctrl)
        atomic_write_text(out / "juggling.json", _json(jug, "filter-eval juggling.json"))
        med = jug["median_flight_acc"]
        err.print(f"juggling: {jug['n_flights']} flights of {len(ball_list)} balls ({', '.join(ball_list)}), median "
                  f"acceleration {'–' if med is None else f'{med:.3f}'} m/s²"
                  + (f"; knots on the static controls: {sum(c['knots'] for c in jug['controls'].values())} "
                     f"({len(ctrl)} markers)" if ctrl else ""))
    curve = exact_time_curve(n_sizes)
    atomic_write_text(out / "timing.json", _json(curve, "filter-eval timing.json"))
    best = None
    if mk is not None:
        best = max(ball_list, key=lambda b: int(np.isfinite(mk.positions[:, mk.labels.index(b), 2]).sum()))
    for p in figures(out, mk, best, penalty):
        err.print(f"wrote {p}")
    rows = syn["rows"]
    for k in ("auto_f1", "exact_f1", "iterative_f1", "auto_rmse", "exact_rmse", "butterworth_rmse", "spline_rmse",
              "exact_overshoot", "butterworth_overshoot", "spline_overshoot"):
        err.print(f"synthetic {k}: mean {np.mean([r[k] for r in rows]):.4f}")
    for c in curve:
        err.print(f"n = {c['n']}: iterative {c['iterative_s']:.2f} s, exact {c['exact_s']:.2f} s, "
                  f"loss gap {c['iterative_loss'] - c['exact_loss']:.4g}")


@app.command()
def decompress(
    points: Annotated[Path, typer.Argument(help="Segment points CSV (time,w,x,y,z), or a compressed clip (.glb/.gltf).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Reconstructed CSV (.bvh for a clip).")],
    times_from: Annotated[
        Optional[Path], typer.Option("--times-from", help="Decode at the timestamps of this original file.")
    ] = None,
    rate: Annotated[
        Optional[float],
        typer.Option(
            "--rate",
            help="Decode on a uniform grid at HZ; with --times-from, the rate of an ORIGINAL without timestamps.",
            callback=_within(*RATE_RANGE),
        ),
    ] = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
) -> None:
    """Reconstruct a full-rate quaternion signal from segment points by SLERP, or the full-rate motion
    of a compressed skeletal clip (.glb/.gltf -> .bvh)."""
    import numpy as np

    _check_output(output, source=points, inputs=(times_from,))
    if points.suffix.lower() in (".glb", ".gltf"):
        _decompress_clip(points, output, times_from, rate)
        return
    from mocapkit.io.loaders import kind_of

    if kind_of(points) != "imu":
        raise InvalidParameterError(f"{points}: decompress reads segment points (CSV time,w,x,y,z) or a "
                                    "compressed clip (.glb/.gltf), not a full recording")

    from mocapkit.io import load_signals, read_imu_csv, write_signal_csv
    from mocapkit.pla.decode import reconstruct_points, unit_quaternions

    if times_from is None and rate is None:
        raise InvalidParameterError("give --times-from ORIGINAL or --rate HZ")
    pts = read_imu_csv(points)
    _warn_signals({"points": pts})
    if times_from is not None:
        originals = load_signals(times_from, rate=rate,
                                 **_columns(time_column, quaternion_columns, scalar_last, time_unit))
        if len(originals) != 1:
            raise InvalidParameterError(
                f"{times_from} holds {len(originals)} signals ({', '.join(list(originals)[:6])}): pick the one the "
                "points came from with --quaternion-columns (e.g. its W,X,Y,Z column names)")
        _warn_signals(originals)
        t = next(iter(originals.values())).times
    else:
        span = float(pts.times[-1] - pts.times[0])
        n_float = math.floor(span * rate + 1e-9) + 1.0 if math.isfinite(span * rate) else math.inf
        if n_float > 50_000_000:
            raise InvalidParameterError(f"--rate {rate:g} over {span:g} s gives {n_float:g} samples; too many")
        t = pts.times[0] + np.arange(int(n_float)) / rate
        if t.shape[0] > 1 and not np.all(np.diff(t) > 0):
            raise InvalidParameterError(f"--rate {rate:g}: the grid's steps vanish in the rounding of times near "
                                        f"{float(pts.times[0]):g} s; give a lower rate")
    try:
        if len(pts) == 1:  # one point: that orientation at every time
            vals = np.repeat(unit_quaternions(pts.values), len(t), axis=0)
        else:
            vals = reconstruct_points(pts.times, pts.values, t, "quaternion")
    except InvalidParameterError as e:
        raise InvalidParameterError(f"{points}: {e}") from None
    norms = np.sqrt(np.einsum("ij,ij->i", vals, vals)) if len(vals) else np.ones(0)
    if not (np.all(np.isfinite(vals)) and np.all(np.abs(norms - 1.0) < 1e-9)):  # never a zero-norm or NaN row
        raise MocapError(f"{points}: the decoded quaternions are not all finite unit quaternions (a bug: please report)")
    write_signal_csv(output, t, vals)
    err.print(f"{points}: {len(pts)} points -> {len(t)} samples in {output}")


def _decompress_clip(clip: Path, output: Path, times_from: Optional[Path], rate: Optional[float]) -> None:
    from mocapkit.io.bvh import write_bvh
    from mocapkit.io.gltf import read_gltf

    if output.suffix.lower() != ".bvh":
        raise InvalidParameterError(f"{output}: a skeletal clip decodes to .bvh")
    if times_from is not None:
        raise InvalidParameterError("--times-from is for IMU points; a clip keeps its frame times (or give --rate)")
    motion = read_gltf(clip, rate=rate)
    write_bvh(output, motion, precision=6)
    err.print(f"{clip}: {motion.n_frames} frames, {motion.skeleton.n_joints} joints -> {output}")


@app.command()
def stream(
    method: Annotated[
        Optional[Method], typer.Option("--method", "-m", help="PLA method (default: fastsw, or anglesw with --max-angle).")
    ] = None,
    threshold: ThresholdOpt = None,
    max_angle: MaxAngleOpt = None,
    max_segment_length: MaxLenOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
) -> None:
    """Read IMU CSV rows from stdin; write each segment point to stdout the moment it is decided."""
    from mocapkit.io.streamcsv import iter_samples
    from mocapkit.pla import Encoder

    if (threshold is None) == (max_angle is None):
        raise InvalidParameterError("give exactly one of --threshold or --max-angle (a target ICR needs the whole signal)")
    m = method.value if method is not None else ("anglesw" if max_angle is not None else "fastsw")
    if m == "optimal":
        raise InvalidParameterError("method 'optimal' is offline (it needs the whole signal); stream with anglesw")
    if max_angle is not None:
        if m != "anglesw":
            raise InvalidParameterError("--max-angle in a stream needs --method anglesw (online, guaranteed)")
        threshold = max_angle
    enc = Encoder(m, threshold, max_segment_length=max_segment_length)
    out = sys.stdout

    def emit(points) -> None:
        for p in points:
            row = (p.time, *p.values)
            if not all(math.isfinite(v) for v in row):  # an extrapolated point (cplr, swing) out of range
                raise MocapError(f"<stdin>: the segment point at time {p.time!r} is not finite {row!r}; "
                                 "the input's values or time steps are out of floating-point range for this method")
            out.write(",".join(repr(float(v)) for v in row) + "\n")
        if points:
            out.flush()

    out.write("time,w,x,y,z\n")
    out.flush()
    try:
        for _lineno, t, q in iter_samples(sys.stdin, "<stdin>", rate,
                                            **_columns(time_column, quaternion_columns, scalar_last, time_unit)):
            emit(enc.push(t, q))
    finally:
        emit(enc.flush())


@app.command()
def sweep(
    inputs: Annotated[list[Path], typer.Argument(help="IMU files or sensor folders.")],
    out: Annotated[Path, typer.Option("--out", help="Folder for sweep.csv and the figures.")] = Path("sweep-out"),
    n_thresholds: Annotated[int, typer.Option("--thresholds", help="Thresholds: 0 plus N-1 log-spaced in 1e-6..1e3.",
                                              callback=_within(2, 100_000))] = 205,
    max_segment_length: Annotated[int, typer.Option("--max-segment-length",
                                                    callback=_within(1, MAX_SEGMENT_LENGTH))] = 1000,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for AMC inputs.")] = None,
    unit_cm: Annotated[Optional[list[str]], typer.Option("--unit-cm", help="NAME=CM per file (BVH has no unit).")] = None,
) -> None:
    """The fastSW paper's experiments: 4 methods x 205 thresholds on every sensor; CSV + figures.

    Skeletal inputs (BVH, AMC with --asf or CMU naming): ICR vs world-position error per method,
    the guaranteed-error mode, and a Figure-5-like PNG of stick figures (skeletal.csv, fig5_*.png).
    """
    from mocapkit.evaluation.sweep import run_sweep, summarise, write_outputs
    from mocapkit.io import load_signals
    from mocapkit.io.loaders import kind_of

    _check_output(out, folder=True, inputs=(*inputs, asf), option="--out")
    if all(kind_of(p) == "skeletal" for p in inputs):
        _sweep_skeletal(inputs, out, asf, unit_cm)
        return

    signals = {}
    for p in inputs:
        for name, sig in load_signals(
            p, rate=rate, **_columns(time_column, quaternion_columns, scalar_last, time_unit)
        ).items():
            key = name if name not in signals else f"{p.stem}/{name}"
            signals[key] = sig
    _warn_signals(signals)
    rows = run_sweep(signals, n_thresholds=n_thresholds, max_segment_length=max_segment_length, progress=err)
    paths = write_outputs(rows, out)
    if all(s.kind == "quaternion" for s in signals.values()):
        from mocapkit.evaluation.sweep import write_max_angle

        paths.append(write_max_angle(signals, out))
    console.print(summarise(rows))
    for p in paths:
        err.print(f"wrote {p}")


def _sweep_skeletal(inputs, out: Path, asf, unit_cm) -> None:
    from mocapkit.evaluation.skeletal import (
        evaluate_motion, plot_curves, stick_figure_png, summary_table, write_rows,
    )
    from mocapkit.io.loaders import load_motion, unit_cm as find_unit

    units = {}
    for item in unit_cm or []:
        name, _, v = item.partition("=")
        try:
            units[name] = float(v)
        except ValueError:
            raise InvalidParameterError(f"--unit-cm expects NAME=CM, got {item!r}") from None
        if not UNIT_RANGE[0] <= units[name] <= UNIT_RANGE[1]:  # also refuses nan
            raise InvalidParameterError(f"--unit-cm {name}: CM must be in [{UNIT_RANGE[0]:g}, {UNIT_RANGE[1]:g}], "
                                        f"got {v!r}")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for p in inputs:
        m = load_motion(p, asf=asf)
        u, assumed = find_unit(m, units.get(p.stem))
        err.print(f"  {p.name}: {m.n_frames} frames, {m.skeleton.n_joints} joints, {u:g} cm/unit"
                  + (" (assumed)" if assumed else ""))
        rows += evaluate_motion(p.stem, m, u)
        stick_figure_png(m, out / f"fig5_{p.stem}.png")
    write_rows(rows, out / "skeletal.csv")
    plot_curves(rows, out / "icr_vs_position_error.png")
    console.print(summary_table(rows))
    err.print(f"wrote {out / 'skeletal.csv'}, icr_vs_position_error.png and fig5_*.png")


@app.command()
def bench(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON records.")] = False,
    channels: Annotated[int, typer.Option("--channels", help="Channels in the many-channel batch run.",
                                          callback=_within(1, 10_000))] = 31,
    frames: Annotated[int, typer.Option("--frames", help="Frames per channel in the many-channel run.",
                                        callback=_within(100, 100_000_000))] = 100_000,
    quick: Annotated[bool, typer.Option("--quick", help="Smaller sizes (for a smoke test).")] = False,
) -> None:
    """ns/sample of batch kernels and streaming encoders vs mean segment length; fastSW/SW ratio."""
    from mocapkit.evaluation.bench import run_bench

    if channels * frames > 50_000_000:  # (channels, frames, 4) float64 arrays: 1.6 GB each at the limit
        raise InvalidParameterError(f"--channels {channels} x --frames {frames} is more than 50000000 samples")
    records, summary = run_bench(channels=channels, frames=frames, quick=quick, progress=err)
    if as_json:  # the JSON is the result; the table goes to stderr, so `--json > file` keeps both
        err.print(summary)
        print(_json(records, "bench --json"))
    else:
        console.print(summary)


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", help="Where to write the segment points.")] = Path("demo-out"),
) -> None:
    """Compress the bundled x-io lower-body walk (7 IMUs) with every method; print the trade-offs."""
    from mocapkit.evaluation.demo import run_demo
    from mocapkit.io import sample_data_path

    _check_output(out, folder=True, inputs=(sample_data_path(),), option="--out")
    run_demo(out, err)


class SegMethod(str, Enum):
    arma = "arma"
    pca = "pca"
    kmeans = "kmeans"
    mlp = "mlp"
    kernelcpd = "kernelcpd"
    pelt = "pelt"
    clasp = "clasp"


def _read_reference(path: Path, n_frames: int, rate_hz: float):
    """A labels file (CMU-86 HACA or mocap6 per-frame), checked against the take; its warnings
    (one label block more or less than the take needs) are printed on stderr."""
    from mocapkit.io.labels import read_reference

    ref = read_reference(path, n_frames, rate_hz)
    for w in ref.warnings:
        err.print(f"warning: {w}")
    return ref


def _pairs(items: Optional[list[str]], what: str) -> list[tuple[str, str]]:
    out = []
    for it in items or []:
        if "=" not in it:
            raise InvalidParameterError(f"{what}: expected A=B, got {it!r}")
        a, b = it.split("=", 1)
        out.append((a.strip(), b.strip()))
    return out


@app.command()
def segment(
    input: Annotated[Path, typer.Argument(help="BVH file, or AMC (with --asf or a CMU-named ASF beside it).")],
    asf: Annotated[Optional[Path], typer.Option("--asf", help="ASF skeleton for an AMC file.")] = None,
    method: Annotated[SegMethod, typer.Option("--method", "-m", help="Segmentation method.")] = SegMethod.arma,
    as_json: Annotated[bool, typer.Option("--json", help="Print the cuts as JSON.")] = False,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: the 4 limb angles with the cuts.")] = None,
    labels: Annotated[Optional[Path], typer.Option("--labels", help="Reference labels (CMU-86 HACA or mocap6 per-frame): scored and plotted.")] = None,
    joint: Annotated[Optional[list[str]], typer.Option("--joint", help="ROLE=JOINT overrides of the joint map (e.g. spine=Spine3).")] = None,
    train: Annotated[Optional[list[str]], typer.Option("--train", help="MOTION=LABELS takes to train --method mlp on (repeat).")] = None,
    rate: Annotated[Optional[float], typer.Option("--rate", help="Frame rate of an AMC file (default 120 Hz).",
                                                  callback=_within(*RATE_RANGE))] = None,
    downsample: Annotated[Optional[int], typer.Option("--downsample", help="ARMA: keep every N-th frame (default: the factor nearest to 30 Hz).",
                                                      callback=_within(1, 1_000_000))] = None,
) -> None:
    """Cut a take into actions from its limb-bone angles (the ARMA method or a baseline)."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.segment.features import LIMB_NAMES, motion_features, pose_features

    _check_output(plot, source=input, option="--plot",
                  inputs=(asf, labels, *[Path(x.strip()) for it in train or [] for x in it.split("=", 1)]))
    motion = load_motion(input, asf=asf, rate=rate)
    rate_hz = float(motion.rate)
    # the labels are read and checked against the take before any segmenting
    ref = _read_reference(labels, motion.n_frames, rate_hz) if labels is not None else None
    jmap = dict(_pairs(joint, "--joint"))
    feats = motion_features(motion, jmap)
    m = method.value
    if m == "arma":
        from mocapkit.segment.arma import ARMASegmenter

        ds = downsample if downsample is not None else max(1, int(round(float(motion.rate) / 30.0)))
        seg = ARMASegmenter(downsample=ds)
    else:
        if downsample is not None:
            raise InvalidParameterError("--downsample is an option of --method arma")
        from mocapkit.segment.baselines import BASELINES

        kw = {}
        if m == "mlp":
            if not train:
                raise InvalidParameterError("--method mlp is supervised: give labelled takes with --train MOTION=LABELS")
            data = []
            for mot, lab in _pairs(train, "--train"):
                tm = load_motion(mot, asf=asf, rate=rate)
                tref = _read_reference(Path(lab), tm.n_frames, tm.rate)
                data.append((motion_features(tm, jmap).limbs, np.asarray(tref.labels, dtype=object)[tref.frame_labels()]))
            kw["train"] = data
        elif train:
            raise InvalidParameterError("--train is only for --method mlp")
        from mocapkit.evaluation.segmentation import rate_scaled

        kw.update(rate_scaled(m, float(motion.rate)))  # the baselines' 120 Hz frame counts at this rate
        seg = BASELINES[m](**kw)
    X = pose_features(motion) if m == "pca" else feats.limbs
    with _progress(f"segmenting {input.name} ({m})"):
        cuts = seg.fit_predict(X)
    if as_json:
        rec = {"method": m, "n_frames": motion.n_frames, "rate_hz": rate_hz,
               "cuts": [{"frame": int(c), "time_s": float(c) / rate_hz} for c in cuts]}
        if ref is not None:
            from mocapkit.evaluation.segmentation import score

            rec["reference_cuts"] = [int(c) for c in ref.cuts]
            rec["scores"] = score(cuts, ref)
        print(_json(rec, f"{input}: segment --json"))
    else:
        console.print(f"{input.name}: {len(cuts)} cuts ({m}, {motion.n_frames} frames at {rate_hz:g} Hz)")
        tab = Table()
        tab.add_column("cut", justify="right")
        tab.add_column("frame", justify="right")
        tab.add_column("time (s)", justify="right")
        for i, c in enumerate(cuts, 1):
            tab.add_row(str(i), str(int(c)), f"{c / rate_hz:.3f}")
        console.print(tab)
        if ref is not None:
            from mocapkit.evaluation.segmentation import score

            sc = score(cuts, ref)
            console.print(f"against {labels.name}: RI {sc['ri']:.3f}, F1 {sc['f1']:.3f} "
                            f"(P {sc['precision']:.3f}, R {sc['recall']:.3f}), Covering {sc['covering']:.3f}")
    if plot is not None:
        from mocapkit.plot import plot_segmentation

        plot_segmentation(feats.limbs, rate_hz, cuts, plot, ref_cuts=None if ref is None else ref.cuts,
                          names=list(LIMB_NAMES), title=f"{input.name}: {m}")
        err.print(f"wrote {plot}")


@app.command("segment-bench")
def segment_bench(
    takes: Annotated[Optional[list[str]], typer.Argument(help="Labelled takes: TAKE=LABELS pairs or folders of takes with TAKE.labels.txt beside them (default: the shared CMU set).")] = None,
    asf: Annotated[Optional[Path], typer.Option("--asf", help="ASF skeleton for AMC takes.")] = None,
    rate: Annotated[Optional[float], typer.Option("--rate", help="Frame rate of AMC takes (default 120 Hz).",
                                                  callback=_within(*RATE_RANGE))] = None,
    data: Annotated[Path, typer.Option("--data", help="The shared data folder (cmu/ and tssb/).")] = Path("../shared/data"),
    out: Annotated[Optional[Path], typer.Option("--out", help="Folder for segment_bench.json and .md.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print all rows as JSON.")] = False,
    methods: Annotated[str, typer.Option("--methods", help="Comma-separated methods.")] = "arma,pca,kmeans,mlp,kernelcpd,pelt,clasp",
    tssb: Annotated[Optional[bool], typer.Option("--tssb/--no-tssb", help="Also run the 75 TSSB series (default: only without TAKES).")] = None,
    tssb_limit: Annotated[Optional[int], typer.Option("--tssb-limit", help="Only the first N TSSB series.",
                                                      callback=_within(1, 1_000_000))] = None,
    known_k: Annotated[bool, typer.Option("--known-k", help="Add rows given the true number of cuts (separate mode).")] = False,
) -> None:
    """Every segmentation method on labelled takes (yours, or the shared CMU set) and on TSSB: RI, F1,
    Covering, seconds. Every label file is checked against its take before any segmenting."""
    from mocapkit.evaluation.segmentation import (MOCAP_METHODS, TSSB_METHODS, find_pairs, load_user_takes, markdown,
                                                  run_mocap, run_tssb, summarise)

    ms = [m.strip() for m in methods.split(",") if m.strip()]
    bad = [m for m in ms if m not in MOCAP_METHODS]
    if bad:
        raise InvalidParameterError(f"--methods: unknown method(s) {bad}; choose from {', '.join(MOCAP_METHODS)}")
    _check_output(out, folder=True, option="--out",
                  inputs=(data, asf, *[Path(x.strip()) for it in takes or [] for x in str(it).split("=", 1)]))
    cmu_dir, tssb_dir = data / "cmu", data / "tssb"
    log = (lambda s: err.print(s)) if not as_json else None
    if takes:
        source = load_user_takes(find_pairs(takes), asf=asf, rate=rate, log=lambda s: err.print(s))
        tssb = bool(tssb)
    else:
        if not cmu_dir.is_dir():
            raise InvalidParameterError(f"{cmu_dir} not found: give the shared data folder with --data, or TAKE=LABELS")
        source = cmu_dir
        tssb = True if tssb is None else tssb
    if tssb and not tssb_dir.is_dir():
        raise InvalidParameterError(f"{tssb_dir} not found (or use --no-tssb)")
    rows = run_mocap(source, ms, known_k=known_k, log=log)
    trows = []
    if tssb:
        if not tssb_dir.is_dir():
            raise InvalidParameterError(f"{tssb_dir} not found (or use --no-tssb)")
        trows = run_tssb(tssb_dir, [m for m in ms if m in TSSB_METHODS], limit=tssb_limit, log=log)
    md = markdown(rows, trows)
    text = _json({"cmu": rows, "tssb": trows, "summary": summarise(rows, trows)}, "segment-bench results")
    if out is not None:
        from mocapkit.io.atomic import atomic_write_text

        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "segment_bench.json", text)
        atomic_write_text(out / "segment_bench.md", md)
    if as_json:
        print(text)
    else:
        print(md)


#: typer's click exceptions (usage errors: missing argument, unknown option, a value that is not a
#: number...), reached through the public ``typer.BadParameter`` whether typer vendors click or not
_ClickException = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")
_UsageError = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 2, 3, 130


def _one_line(text) -> str:
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def _fail(message: str, code: int) -> None:
    import os
    import traceback

    if os.environ.get("MOCAPKIT_DEBUG", "") not in ("", "0"):
        traceback.print_exc()
    sys.stderr.write(f"error: {_one_line(message)}\n")
    sys.exit(code)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Python warnings (a reader's ``MocapWarning``...) as one line ``warning: ...`` each, once per text."""
    text = _one_line(message)
    if text not in _SHOWN_WARNINGS:
        _SHOWN_WARNINGS.add(text)
        sys.stderr.write(f"warning: {text}\n")


_SHOWN_WARNINGS: set[str] = set()


def main(argv: list[str] | None = None) -> None:
    """The ``mocapkit`` entry point: every failure is one line ``error: ...`` on stderr.

    Exit codes: 0 success; 2 bad input, option or usage (a ``MocapError``, an ``OSError`` or a
    usage error of the command line); 3 an internal error (an exception mocapkit did not raise on
    purpose: a bug, please report it); 130 interrupted. ``MOCAPKIT_DEBUG=1`` adds the traceback.
    """
    import warnings

    warnings.showwarning = _show_warning
    try:
        code = app(args=argv, prog_name="mocapkit", standalone_mode=False)
    except _ClickException as e:
        if type(e).__name__ == "NoArgsIsHelpError":  # bare `mocapkit` / `mocapkit sweep`: the help
            e.show()
            sys.exit(EXIT_INPUT)
        ctx = getattr(e, "ctx", None)
        hint = f" (see {ctx.command_path} --help)" if ctx is not None and isinstance(e, _UsageError) else ""
        _fail(f"{e.format_message()}{hint}", EXIT_INPUT)
    except MocapError as e:
        _fail(str(e), EXIT_INPUT)
    except KeyboardInterrupt:
        sys.exit(EXIT_INTERRUPTED)
    except typer.Abort:
        _fail("aborted", EXIT_INTERRUPTED)
    except MemoryError:
        _fail("out of memory (an input or option asks for more than this machine has)", EXIT_INTERNAL)
    except OSError as e:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        _fail(f"{where}{e.strerror or e}", EXIT_INPUT)
    except Exception as e:  # a bug: one line, never a silent success; the traceback on request
        _fail(f"internal error: {type(e).__name__}: {e} (please report it; MOCAPKIT_DEBUG=1 shows the traceback)",
              EXIT_INTERNAL)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
