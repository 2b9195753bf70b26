"""``mocapkit batch JOB INPUT... [job options] --out DIR``: one job over a database of recordings.

Thin like ``cli.py``: parse the job's options (the same options as the single-file command, from
:mod:`mocapkit.cli_options`), call :func:`mocapkit.batch.run_batch`, show progress on stderr and print
the summary on stdout. Exit 0 when every input is ok, 1 when some rows are errors (the batch still
finishes and writes every row), 2 for a usage error (before any work).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Annotated, overload

import typer

from mocapkit.cli_options import (
    AsfOpt,
    AutoOpt,
    ColumnsOpt,
    DownsampleOpt,
    ErrorMetric,
    ErrorMetricOpt,
    GltfRotations,
    GltfRotationsOpt,
    JointOpt,
    MarkersOpt,
    MaxAngleOpt,
    MaxLenOpt,
    MaxPositionErrorOpt,
    Method,
    MethodOpt,
    OrderOpt,
    PenaltyOpt,
    QuatColumnsOpt,
    RateOpt,
    ScalarLastOpt,
    SegMethod,
    SegMethodOpt,
    SegRateOpt,
    ShellDistanceOpt,
    Solver,
    SolverOpt,
    StrictOpt,
    TargetIcrOpt,
    ThresholdOpt,
    TimeColumnOpt,
    TimeUnitOpt,
    TrainOpt,
    UnitCmOpt,
    _within,
    console,
    err,
)
from mocapkit.errors import InvalidParameterError

batch_app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Run one job (info, compress, filter, segment) over files, folders (recursively) and globs: a "
         "process pool or a Dask cluster, a journal and OUT/results.parquet, --resume after a stop.",
)

InputsArg = Annotated[list[str], typer.Argument(
    help="Files, folders (walked recursively) and quoted globs ('data/**/*.bvh') of any format mocapkit reads.")]
OutOpt = Annotated[Path, typer.Option("--out", help="Folder for the outputs (mirroring the inputs' tree), "
                                                    "journal.jsonl and results.parquet.")]
JobsOpt = Annotated[int | None, typer.Option("--jobs", "-j", help="Worker processes (default: the CPU count).",
                                                callback=_within(1, 4096))]
EngineOpt = Annotated[str, typer.Option("--engine", help="local (a process pool) or dask.")]
SchedulerOpt = Annotated[str | None, typer.Option(
    "--scheduler", help="tcp://HOST:PORT of a running Dask scheduler (--engine dask; default: a local cluster).")]
ResumeOpt = Annotated[bool, typer.Option(
    "--resume", help="Keep the ok rows of an earlier batch in OUT with the same job, options and file content; "
                     "run the rest.")]
DbOpt = Annotated[str | None, typer.Option(
    "--db", help="Also add the rows to a motion catalog: motion.duckdb or postgresql://...")]
ManifestOpt = Annotated[Path | None, typer.Option(
    "--manifest", help="Options per file: a TOML file of [[files]] tables (glob = \"cmu/*.amc\", rate = 120, "
                       "asf = \"cmu/86.asf\"...). A TAKE.mocapkit.toml beside an input wins over it; the command's "
                       "options only fill in what a file lacks (a file's own clock or skeleton always wins).")]


@overload
def _abs(p: Path | str) -> str: ...
@overload
def _abs(p: None) -> None: ...
@overload
def _abs(p: Path | str | None) -> str | None: ...
def _abs(p: Path | str | None) -> str | None:
    """A path option as an absolute string: the options are JSON (hashed, stored) and workers on a
    cluster do not share the command's working folder."""
    return None if p is None else os.path.abspath(os.fspath(p))


def _progress():
    """``(report, close)``: a rich bar on a terminal (done/total, errors, ETA), else a plain line on
    stderr at every tenth of the inputs. The display starts with the first finished row."""
    t0 = time.monotonic()
    state: dict = {}

    def report(row, done, errors, n):
        if err.is_terminal:
            if "prog" not in state:
                from rich.progress import (
                    BarColumn,
                    MofNCompleteColumn,
                    Progress,
                    TextColumn,
                    TimeElapsedColumn,
                    TimeRemainingColumn,
                )

                prog = Progress(TextColumn("batch"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("{task.fields[errors]} errors"), TimeElapsedColumn(), TextColumn("ETA"),
                                TimeRemainingColumn(), console=err, transient=True)
                state["prog"], state["task"] = prog, prog.add_task("batch", total=n, errors=0)
                prog.start()
            state["prog"].update(state["task"], completed=done, total=n, errors=errors)
        elif done % max(1, n // 10) == 0 or done == n:
            spent = time.monotonic() - t0
            eta = spent / done * (n - done) if done else 0.0
            err.print(f"batch: {done}/{n} done, {errors} errors, {spent:.0f} s, ETA {eta:.0f} s",
                      markup=False, highlight=False)

    def close():
        prog = state.pop("prog", None)
        if prog is not None:
            prog.stop()

    return report, close


def _run(job: str, inputs: list[str], options: dict, out: Path, jobs: int | None, engine: str,
         scheduler: str | None, resume: bool, db: str | None, manifest: Path | None) -> None:
    from mocapkit.batch import run_batch
    from mocapkit.batch.engine import BatchInterrupted, hold_interrupts

    n = jobs if jobs is not None else (os.cpu_count() or 1)
    report, close = _progress()
    try:
        res = run_batch(job, inputs, options, out, jobs=n, engine=engine, scheduler=scheduler, resume=resume,
                        db=db, report=report, manifest=manifest)
    except BatchInterrupted as e:
        hold_interrupts()  # exiting: a further Ctrl-C must not kill the process before it says how to resume
        close()
        err.print(str(e), markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(130) from None
    finally:
        close()
    _summary(job, res)
    if job == "verify":
        from mocapkit.cli_verify import summarise_exceeded

        if summarise_exceeded(res.rows):
            raise typer.Exit(1)
    if res.errors:
        raise typer.Exit(1)


MAX_WARNINGS_SHOWN = 20


def _n(k: int, word: str) -> str:
    return f"{k} {word}{'' if k == 1 else 's'}"


def _summary(job: str, res) -> None:
    say = lambda s: console.print(s, markup=False, highlight=False, soft_wrap=True)  # noqa: E731
    import json

    kept = f", {res.kept} kept from an earlier run" if res.kept else ""
    warned = [(r["input"], w) for r in res.rows if r["status"] == "ok" and r.get("record_json")
              for w in json.loads(r["record_json"]).get("warnings", [])]
    n_warned = len({p for p, _ in warned})
    say(f"batch {job}: {res.ok} ok{f' ({n_warned} with warnings)' if n_warned else ''}, "
        f"{_n(len(res.errors), 'error')}, "
        f"{len(res.skipped)} skipped{kept} in {res.seconds:.1f} s")
    say(f"results: {res.results_path}")
    if res.catalog is not None:
        say(f"catalog: {res.catalog.get('runs', 0)} runs, {res.catalog.get('recordings', 0)} recordings written")
    if res.errors:
        say("errors:")
        for r in res.errors:  # most errors name the file first already
            e = r["error"] or ""
            say(f"  {e}" if e.startswith(r["input"]) else f"  {r['input']}: {e}")
    if warned:
        say("warnings (read, but check them):")
        for p, w in warned[:MAX_WARNINGS_SHOWN]:
            say(f"  {p}: {w}")
        if len(warned) > MAX_WARNINGS_SHOWN:
            say(f"  ... {len(warned) - MAX_WARNINGS_SHOWN} more (record_json in the results, runs.warnings in "
                "the catalog)")
    if res.skipped:
        say("skipped:")
        for p, why in res.skipped:
            say(f"  {p}: {why}")


@batch_app.command("info")
def batch_info(
    inputs: InputsArg,
    out: OutOpt,
    asf: AsfOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    strict: StrictOpt = True,
    jobs: JobsOpt = None,
    engine: EngineOpt = "local",
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    db: DbOpt = None,
    manifest: ManifestOpt = None,
) -> None:
    """Describe every recording (the record of ``mocapkit info --json``)."""
    options = {"asf": _abs(asf), "rate": rate, "time_column": time_column, "quaternion_columns": quaternion_columns,
               "scalar_last": scalar_last, "time_unit": time_unit, "strict": strict}
    _run("info", inputs, options, out, jobs, engine, scheduler, resume, db, manifest)


@batch_app.command("compress")
def batch_compress(
    inputs: InputsArg,
    out: OutOpt,
    method: MethodOpt = Method.fastsw,
    threshold: ThresholdOpt = None,
    target_icr: TargetIcrOpt = None,
    max_angle: MaxAngleOpt = None,
    max_segment_length: MaxLenOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    asf: AsfOpt = None,
    max_position_error: MaxPositionErrorOpt = None,
    unit_cm: UnitCmOpt = None,
    skeletal_format: Annotated[str, typer.Option("--skeletal-format", help="Skeletons as .glb (keyframes, "
                               "standard glTF) or .mkc (the compact clip; needs --max-position-error).")] = "glb",
    error_metric: ErrorMetricOpt = ErrorMetric.joint_end,
    shell_distance: ShellDistanceOpt = 3.0,
    gltf_rotations: GltfRotationsOpt = GltfRotations.short,
    strict: StrictOpt = True,
    jobs: JobsOpt = None,
    engine: EngineOpt = "local",
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    db: DbOpt = None,
    manifest: ManifestOpt = None,
) -> None:
    """Compress every recording: IMU points to OUT/.../<stem>.points/, skeletons to OUT/.../<stem>.glb
    (or <stem>.mkc with --skeletal-format mkc). --max-angle bounds the IMU data and --max-position-error the
    skeletons of the same batch."""
    given = [x is not None for x in (threshold, target_icr, max_angle, max_position_error)]
    both_bounds = given == [False, False, True, True]
    if sum(given) != 1 and not both_bounds and not (manifest is not None and not any(given)):
        raise InvalidParameterError("give exactly one of --threshold, --target-icr, --max-angle (IMU input) or "
                                    "--max-position-error (skeletal input); --max-angle and --max-position-error "
                                    "may go together (each bounds its kind), and a --manifest may give the bounds")
    options = {"method": method.value, "threshold": threshold, "target_icr": target_icr, "max_angle": max_angle,
               "max_segment_length": max_segment_length, "rate": rate, "time_column": time_column,
               "quaternion_columns": quaternion_columns, "scalar_last": scalar_last, "time_unit": time_unit,
               "asf": _abs(asf), "max_position_error": max_position_error, "unit_cm": unit_cm, "strict": strict,
               "skeletal_format": skeletal_format, "error_metric": error_metric.value, "shell_distance": shell_distance,
               "gltf_rotations": gltf_rotations.value}
    _run("compress", inputs, options, out, jobs, engine, scheduler, resume, db, manifest)


@batch_app.command("filter")
def batch_filter(
    inputs: InputsArg,
    out: OutOpt,
    order: OrderOpt = 2,
    penalty: PenaltyOpt = None,
    auto: AutoOpt = False,
    solver: SolverOpt = Solver.exact,
    markers: MarkersOpt = None,
    columns: ColumnsOpt = None,
    jobs: JobsOpt = None,
    engine: EngineOpt = "local",
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    db: DbOpt = None,
    manifest: ManifestOpt = None,
) -> None:
    """Filter every marker file or time table: values to OUT/.../<stem>.filtered.csv (.filtered.c3d)."""
    if (penalty is None) == (not auto):
        raise InvalidParameterError("give exactly one of --penalty K or --auto")
    options = {"order": order, "penalty": penalty, "auto": auto, "solver": solver.value, "markers": markers,
               "columns": columns}
    _run("filter", inputs, options, out, jobs, engine, scheduler, resume, db, manifest)


@batch_app.command("segment")
def batch_segment(
    inputs: InputsArg,
    out: OutOpt,
    asf: AsfOpt = None,
    method: SegMethodOpt = SegMethod.arma,
    joint: JointOpt = None,
    train: TrainOpt = None,
    rate: SegRateOpt = None,
    downsample: DownsampleOpt = None,
    labels_beside: Annotated[bool, typer.Option(
        "--labels-beside", help="Score each take against its TAKE.labels.txt (CMU-86 HACA or mocap6 per-frame) "
                                "when one lies beside it; segments get the reference labels.")] = False,
    jobs: JobsOpt = None,
    engine: EngineOpt = "local",
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    db: DbOpt = None,
    manifest: ManifestOpt = None,
) -> None:
    """Cut every BVH/AMC take into actions (the record of ``mocapkit segment --json``)."""
    train_abs = None if not train else [
        "=".join(_abs(x.strip()) for x in item.split("=", 1)) for item in train]
    options = {"asf": _abs(asf), "method": method.value, "joint": joint or None, "train": train_abs, "rate": rate,
               "downsample": downsample, "labels_beside": labels_beside}
    _run("segment", inputs, options, out, jobs, engine, scheduler, resume, db, manifest)


@batch_app.command("verify")
def batch_verify(
    inputs: InputsArg,
    compressed: Annotated[Path, typer.Option("--compressed", help="The --out folder of the `batch compress` whose "
                                                                  "outputs are checked (same INPUTs).")],
    out: OutOpt,
    max_angle: MaxAngleOpt = None,
    max_position_error: MaxPositionErrorOpt = None,
    error_metric: Annotated[str, typer.Option("--error-metric", help="joint+end, joint or shell (see mocapkit verify "
                                                                     "--help).")] = "joint+end",
    shell_distance: ShellDistanceOpt = 3.0,
    skeletal_format: Annotated[str | None, typer.Option("--skeletal-format", help="glb or mkc, when both are "
                                                           "there.")] = None,
    unit_cm: UnitCmOpt = None,
    asf: AsfOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    strict: StrictOpt = True,
    jobs: JobsOpt = None,
    engine: EngineOpt = "local",
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    db: DbOpt = None,
    manifest: ManifestOpt = None,
) -> None:
    """Check every output of an earlier `batch compress ... --out COMPRESSED` against its input (the record of
    ``mocapkit verify --json``); the summary counts the pairs beyond the bound (exit 1 when any is)."""
    from mocapkit.cli_verify import check_batch_folders

    check_batch_folders(inputs, compressed, out)
    options = {"compressed_dir": _abs(compressed), "out": _abs(out), "max_angle": max_angle,
               "max_position_error": max_position_error, "error_metric": error_metric,
               "shell_distance": shell_distance, "skeletal_format": skeletal_format, "unit_cm": unit_cm,
               "asf": _abs(asf), "rate": rate, "time_column": time_column, "quaternion_columns": quaternion_columns,
               "scalar_last": scalar_last, "time_unit": time_unit, "strict": strict}
    _run("verify", inputs, options, out, jobs, engine, scheduler, resume, db, manifest)
