"""The ``mocapkit`` command line (typer + rich). Thin: parse, call the library, print or write."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from mocapkit.cli_options import (  # noqa: F401 - _console, _json and the limits are part of the module's face
    MAX_FILTER_ORDER,
    MAX_SEGMENT_LENGTH,
    RATE_RANGE,
    UNIT_RANGE,
    AsfOpt,
    AutoOpt,
    BlockFramesOpt,
    ColumnsOpt,
    DownsampleOpt,
    EntropyOpt,
    ErrorMetric,
    ErrorMetricOpt,
    GltfRotations,
    GltfRotationsOpt,
    JointOpt,
    LabelsOpt,
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
    _check_output,
    _console,
    _json,
    _progress,
    _within,
    console,
    err,
    print_warnings,
)
from mocapkit.errors import InvalidParameterError, InvalidSignalError, MocapError
from mocapkit.jobs.common import imu_columns as _columns

if TYPE_CHECKING:
    from mocapkit.evaluation.segmentation import Take

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Compress, filter and segment human-motion recordings.",
)


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


def _warn_signals(signals) -> None:
    """Print each loaded signal's ``meta["warnings"]`` to stderr, once per file and text."""
    seen = set()
    for sig in signals.values():
        for w in sig.meta.get("warnings", []):
            if (sig.source, w) not in seen:
                seen.add((sig.source, w))
                err.print(f"warning: {sig.source}: {w}", markup=False, highlight=False)


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
    input: Annotated[
        Path, typer.Argument(help="An IMU file or a folder of sensors; or a skeleton (BVH, AMC, MVNX, .mkc).")
    ],
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Points CSV (a folder when INPUT is a folder).")
    ] = None,
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
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object per signal (a list).")] = False,
    asf: AsfOpt = None,
    max_position_error: MaxPositionErrorOpt = None,
    unit_cm: UnitCmOpt = None,
    gltf_rotations: GltfRotationsOpt = GltfRotations.short,
    error_metric: ErrorMetricOpt = ErrorMetric.joint_end,
    shell_distance: ShellDistanceOpt = 3.0,
    block_frames: BlockFramesOpt = None,
    entropy: EntropyOpt = "zstd",
    packet_bits: Annotated[int | None, typer.Option(
        "--packet-bits", help=".mkp packets: bits per quaternion component, 6..16 (default: the fewest whose "
                              "quantisation stays within 15% of --max-angle).", callback=_within(6, 16))] = None,
    packet_bytes: Annotated[int | None, typer.Option(
        "--packet-bytes", help=".mkp packets: the radio payload, 16..255 bytes (default 20: BLE 4 ATT).",
        callback=_within(16, 255))] = None,
    strict: StrictOpt = True,
    stats_only: Annotated[
        bool, typer.Option("--stats-only", help="Only measure (print the table); write no points or clip.")
    ] = False,
) -> None:
    """Compress orientation streams (IMU files, sensor folders) or whole skeletons (BVH, AMC).

    IMU input: segment points as CSV time,w,x,y,z (to -o, or to stdout for one file), or radio packets of
    every sensor with -o OUT.mkp (--max-angle bounds the decode end to end, quantisation included). Skeletal input:
    a .mkc clip (the smallest; bounded by --max-position-error in the --error-metric, checked on the
    written bytes), keyframes as glTF (.glb/.gltf) or the decoded full-rate motion as .bvh (-o). Without -o, a result
    that cannot go to stdout is refused before any work unless --json or --stats-only asks for the numbers.
    """
    from mocapkit.jobs import compress_job

    if stats_only and output is not None:
        raise InvalidParameterError("--stats-only writes nothing: drop it or drop --output")
    numbers_only = as_json or stats_only
    common = {"method": method.value, "threshold": threshold, "target_icr": target_icr, "max_angle": max_angle,
               "max_segment_length": max_segment_length, "rate": rate, "time_column": time_column,
               "quaternion_columns": quaternion_columns, "scalar_last": scalar_last, "time_unit": time_unit}
    if output is not None and output.suffix.lower() == ".mkp":  # radio packets (docs/mkp.md)
        from mocapkit.cli_packets import print_compress
        from mocapkit.jobs import compress_options, compress_packets

        options = compress_options("packets", output, **common, packet_bits=packet_bits, packet_bytes=packet_bytes)
        rec = compress_packets(input, options, output=output, progress=_progress)
        print_warnings(rec)
        print_compress(rec, input, as_json)
        return
    if packet_bits is not None or packet_bytes is not None:
        raise InvalidParameterError("--packet-bits and --packet-bytes apply to a packet stream (-o OUT.mkp)")
    rec = compress_job(
        input, **common, asf=asf, max_position_error=max_position_error, unit_cm=unit_cm, strict=strict,
        output=output, points_stream=None if numbers_only else sys.stdout, discard_ok=numbers_only,
        progress=_progress, gltf_rotations=gltf_rotations.value, error_metric=error_metric.value,
        shell_distance=shell_distance, block_frames=block_frames, entropy=entropy)
    print_warnings(rec)
    if rec["kind"] == "skeletal":
        if as_json:
            print(_json(rec, f"{input}: compress --json"))
            return
        if rec["method"] == "mkc":
            _clip_table(rec, input)
            return
        tab = Table(title=f"{input.name}: {rec['method']} ({rec['mode']})")
        tab.add_column("quantity")
        tab.add_column("value", justify="right")
        for k in ("n_frames", "n_joints", "keyframes", "icr", "max_position_error_cm", "mean_position_error_cm",
                  "aad_deg", "max_deg", "bytes_raw", "bytes_out", "ratio"):
            v = rec[k]
            tab.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
        console.print(tab)
        if rec["unit_cm_assumed"]:
            err.print("length unit assumed to be 1 cm; give --unit-cm for other units")
        return
    points_to_stdout = output is None and not numbers_only and not input.is_dir() and len(rec["signals"]) == 1
    if as_json:
        print(_json(rec["signals"], "compress --json"))
    else:  # the table is the result unless the points went to stdout
        (err if points_to_stdout else console).print(
            _summary_table(rec["signals"], f"{rec['method']}: {rec['mode']} {rec['target']:g}"))
    if rec["skipped_files"]:
        err.print(f"not orientation data, skipped: {', '.join(rec['skipped_files'])}")


def _clip_table(rec: dict, input: Path) -> None:
    tab = Table(title=f"{input.name} -> {rec['output']}: {rec['error_metric']} error "
                      f"<= {rec['max_position_error_cm']:g} cm")
    tab.add_column("quantity")
    tab.add_column("value", justify="right")
    for k in ("frames", "joints", "keyframes", "blocks", "max_joint_error_cm", "max_shell_error_cm",
              "mean_joint_error_cm", "mean_shell_error_cm", "bytes", "bytes_raw_float32", "ratio", "encode_s"):
        v = rec[k]
        tab.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
    console.print(tab)
    if rec["unit_cm_assumed"]:
        err.print("length unit assumed to be 1 cm; give --unit-cm for other units")


@app.command()
def info(
    input: Annotated[Path, typer.Argument(help="BVH, AMC, C3D, Qualisys TSV, IMU file or sensor folder.")],
    asf: AsfOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    strict: StrictOpt = True,
) -> None:
    """Describe a motion file: joints, frames, rate, duration, channels, markers."""
    from mocapkit.jobs import info_job

    rec = info_job(input, asf=asf, rate=rate, time_column=time_column, quaternion_columns=quaternion_columns,
                   scalar_last=scalar_last, time_unit=time_unit, strict=strict)
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
        if k in ("file", "job", "outputs", "recording"):
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
    input: Annotated[
        Path, typer.Argument(help="AMC (+ --asf), BVH or Xsens MVNX; markers (C3D, TSV, TRC, CSV); MOT/STO.")
    ],
    output: Annotated[
        Path,
        typer.Argument(help="BVH or AMC for skeletal input; .csv/.c3d/.trc for markers; .mot/.sto/.csv for tables."),
    ],
    asf: Annotated[Path | None, typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    precision: Annotated[
        int, typer.Option("--precision", help="Decimals written to BVH.", callback=_within(0, 20))
    ] = 6,
    strict: Annotated[
        bool, typer.Option("--strict/--no-strict", help="BVH: Frames: mismatch is an error (default) or is recorded.")
    ] = True,
    max_residual: Annotated[
        float,
        typer.Option("--max-residual", help="BVH -> AMC: largest rotation (deg) the ASF's dofs may fail to express.",
                     callback=_within(0.0, 180.0)),
    ] = 0.1,
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
            from mocapkit.io.skeletal.bvh import write_bvh

            m = load_motion(input, asf=asf, strict=strict)
            write_bvh(output, m, precision=precision)
            ucm = m.skeleton.meta.get("length_unit_cm")
            note = "" if ucm is None else f"; lengths in the input's unit (1 unit = {ucm:g} cm)"
        else:
            if asf is None or input.suffix.lower() != ".bvh":
                raise InvalidParameterError("BVH -> AMC needs --asf (the skeleton the BVH was made from)")
            from mocapkit.io.skeletal.amc import read_asf, write_amc

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
        from mocapkit.io.markers.opensim import read_opensim_signals, write_orientations, write_table, write_table_csv

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


@app.command("filter")
def filter_cmd(
    input: Annotated[Path, typer.Argument(help="C3D, Qualisys TSV, marker CSV or a CSV with a time column.")],
    order: OrderOpt = 2,
    penalty: PenaltyOpt = None,
    auto: AutoOpt = False,
    solver: SolverOpt = Solver.exact,
    markers: MarkersOpt = None,
    columns: ColumnsOpt = None,
    output: Annotated[
        Path | None,
        typer.Option("--output", "-o", help="Filtered values at the input times: CSV, or .c3d/.trc for markers."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Knots and polynomial pieces as JSON.")] = False,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="PNG: position and two derivatives of the first signal.")
    ] = None,
) -> None:
    """Filter by piecewise polynomials: keeps discontinuities (catches, throws, heel strikes)."""
    from mocapkit.jobs import filter_job

    rec = filter_job(input, order=order, penalty=penalty, auto=auto, solver=solver.value, markers=markers,
                     columns=columns, output=output, plot=plot, progress=_progress)
    print_warnings(rec)
    if as_json:
        print(_json(rec["signals"], f"{input}: filter --json"))
        return
    tab = Table(title=f"{input.name}: piecewise polynomials of order {order} "
                      f"({'automatic knot cost' if auto else solver.value})")
    for c in ("signal", "K", "knots", "pieces", "loss", "iterative loss"):
        tab.add_column(c, justify="right")
    for r in rec["signals"]:
        if "error" in r:
            tab.add_row(r["name"], "–", "not filtered", "", "", "")
            continue
        tab.add_row(r["name"], f"{r['penalty']:.4g}", str(r["n_knots"]), str(len(r["pieces"])), f"{r['loss']:.6g}",
                    "–" if r["iterative_loss"] is None else f"{r['iterative_loss']:.6g}")
    console.print(tab)


@app.command("filter-eval")
def filter_eval(
    out: Annotated[Path, typer.Option("--out", help="Folder for the JSON results and figures.")] = Path("filter-out"),
    juggling: Annotated[
        Path | None,
        typer.Option("--juggling", help="A marker file (Qualisys TSV, C3D, TRC, marker CSV) with thrown balls, Z up."),
    ] = None,
    balls: Annotated[
        str | None, typer.Option("--balls", help="Ball markers A,B,C (default: every marker that moves, see docs).")
    ] = None,
    controls: Annotated[
        str | None,
        typer.Option("--controls", help="Static control markers (default: every marker that does not move)."),
    ] = None,
    penalty: Annotated[float | None, typer.Option("--penalty", help="K of Eq. 2 for the balls (default: --auto).",
                                                     callback=_within(0.0))] = None,
    unit_m: Annotated[float, typer.Option("--unit-m", help="Metres per unit of the marker file (mm: 0.001).",
                                          callback=_within(*UNIT_RANGE))] = 1e-3,
    sizes: Annotated[
        str, typer.Option("--sizes", help="Signal lengths for the exact solver's time curve ('' to skip).")
    ] = "1000,2000,5000,10000,20000,50000",
) -> None:
    """The filtering experiments: synthetic Figure 2 signal, step overshoot, juggling flights, timing."""
    import numpy as np

    from mocapkit.evaluation.filtering import (
        evaluate_juggling,
        evaluate_synthetic,
        exact_time_curve,
        figures,
        moving_markers,
    )
    from mocapkit.io.atomic import atomic_write_text

    _check_output(out, folder=True, inputs=(juggling,), option="--out")
    mk = None
    ball_list: list[str] = []
    ctrl: list[str] = []
    if juggling is not None:  # read and check everything before any long computation
        from mocapkit.io.loaders import load_markers

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
    points: Annotated[
        Path,
        typer.Argument(help="Segment points CSV (time,w,x,y,z), radio packets (.mkp), or a compressed clip "
                            "(.mkc, .glb/.gltf)."),
    ],
    output: Annotated[Path, typer.Option("--output", "-o", help="Reconstructed CSV (.bvh for a clip).")],
    times_from: Annotated[
        Path | None, typer.Option("--times-from", help="Decode at the timestamps of this original file.")
    ] = None,
    rate: Annotated[
        float | None,
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
    of a compressed skeletal clip (.mkc -> .bvh/.glb; .glb/.gltf -> .bvh)."""
    # several sensors of a .mkp decode into a folder (one CSV each): an existing folder is a valid output
    _check_output(output, folder=points.suffix.lower() == ".mkp" and output.is_dir(), source=points,
                  inputs=(times_from,))  # a .gltf's buffer files are its companions (io.loaders.companions)
    if points.suffix.lower() in (".glb", ".gltf"):
        _decompress_clip(points, output, times_from, rate)
        return
    if points.suffix.lower() == ".mkp":  # radio packets (docs/mkp.md)
        from mocapkit.cli_packets import decompress as decompress_packets

        decompress_packets(points, output, times_from, rate, _columns(time_column, quaternion_columns, scalar_last,
                                                                     time_unit))
        return
    if points.suffix.lower() == ".mkc":
        from mocapkit.jobs.clip import decompress_clip_job

        if times_from is not None or rate is not None:
            raise InvalidParameterError("a .mkc clip keeps its own frame times: drop --times-from / --rate")
        rec = decompress_clip_job(points, output)
        err.print(f"{points}: {rec['frames']} frames, {rec['joints']} joints -> {output}")
        return
    from mocapkit.io.loaders import kind_of

    if kind_of(points) != "imu":
        raise InvalidParameterError(f"{points}: decompress reads segment points (CSV time,w,x,y,z) or a "
                                    "compressed clip (.glb/.gltf), not a full recording")

    from mocapkit.jobs.points import decompress_points_job

    rec = decompress_points_job(points, output, times_from=times_from, rate=rate,
                                **_columns(time_column, quaternion_columns, scalar_last, time_unit))
    print_warnings(rec)
    err.print(f"{points}: {rec['points']} points -> {rec['samples']} samples in {output}")


def _decompress_clip(clip: Path, output: Path, times_from: Path | None, rate: float | None) -> None:
    from mocapkit.io.formats.gltf import read_gltf
    from mocapkit.io.skeletal.bvh import write_bvh

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
        Method | None, typer.Option("--method", "-m", help="PLA method (default: fastsw, or anglesw with --max-angle).")
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
    from mocapkit.jobs.stream import run_stream
    from mocapkit.pla import Encoder

    if (threshold is None) == (max_angle is None):
        raise InvalidParameterError("give exactly one of --threshold or --max-angle "
                                    "(a target ICR needs the whole signal)")
    m = method.value if method is not None else ("anglesw" if max_angle is not None else "fastsw")
    if m == "optimal":
        raise InvalidParameterError("method 'optimal' is offline (it needs the whole signal); stream with anglesw")
    if max_angle is not None:
        if m != "anglesw":
            raise InvalidParameterError("--max-angle in a stream needs --method anglesw (online, guaranteed)")
        threshold = max_angle
    assert threshold is not None  # exactly one of --threshold and --max-angle, checked above
    enc = Encoder(m, threshold, max_segment_length=max_segment_length)
    out = sys.stdout

    def emit(points) -> None:
        for t, vals in zip(points.times.tolist(), points.values.tolist(), strict=True):
            row = (t, *vals)
            if not all(math.isfinite(v) for v in row):  # an extrapolated point (cplr, swing) out of range
                raise MocapError(f"<stdin>: the segment point at time {t!r} is not finite {tuple(row)!r}; "
                                 "the input's values or time steps are out of floating-point range for this method")
            out.write(",".join(repr(float(v)) for v in row) + "\n")
        if len(points.times):
            out.flush()

    out.write("time,w,x,y,z\n")
    out.flush()
    run_stream(sys.stdin, enc, emit, "<stdin>", rate,
               **_columns(time_column, quaternion_columns, scalar_last, time_unit))


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
    asf: Annotated[Path | None, typer.Option("--asf", help="Skeleton for AMC inputs.")] = None,
    unit_cm: Annotated[list[str] | None, typer.Option("--unit-cm", help="NAME=CM per file (BVH has no unit).")] = None,
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
        evaluate_motion,
        plot_curves,
        stick_figure_png,
        summary_table,
        write_rows,
    )
    from mocapkit.io.loaders import load_motion
    from mocapkit.io.loaders import unit_cm as find_unit

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


@app.command()
def segment(
    input: Annotated[Path, typer.Argument(help="BVH file, or AMC (with --asf or a CMU-named ASF beside it).")],
    asf: AsfOpt = None,
    method: SegMethodOpt = SegMethod.arma,
    as_json: Annotated[bool, typer.Option("--json", help="Print the cuts as JSON.")] = False,
    plot: Annotated[Path | None, typer.Option("--plot", help="PNG: the 4 limb angles with the cuts.")] = None,
    labels: LabelsOpt = None,
    joint: JointOpt = None,
    train: TrainOpt = None,
    rate: SegRateOpt = None,
    downsample: DownsampleOpt = None,
    strict: StrictOpt = True,
) -> None:
    # one line: the command list of `mocapkit --help` keeps a docstring's line breaks
    """Cut a take into actions from its limb-bone angles (auto: the number of actions found without being told; the ARMA method; or a baseline)."""  # noqa: E501
    from mocapkit.jobs import segment_job

    rec = segment_job(input, asf=asf, method=method.value, labels=labels, joint=joint, train=train, rate=rate,
                      downsample=downsample, strict=strict, plot=plot, progress=_progress)
    print_warnings(rec)
    if as_json:
        print(_json(rec, f"{input}: segment --json"))
    else:
        n_cuts = len(rec["cuts"])
        console.print(f"{input.name}: {n_cuts} cut{'' if n_cuts == 1 else 's'} ({rec['method']}, {rec['n_frames']} "
                      f"frames at {rec['rate_hz']:g} Hz)")
        tab = Table()
        tab.add_column("cut", justify="right")
        tab.add_column("frame", justify="right")
        tab.add_column("time (s)", justify="right")
        for i, c in enumerate(rec["cuts"], 1):
            tab.add_row(str(i), str(c["frame"]), f"{c['time_s']:.3f}")
        if rec["cuts"]:
            console.print(tab)
        if rec.get("actions"):
            console.print(f"actions: {rec['actions']}")
        if "scores" in rec:
            assert labels is not None  # scores come with --labels only
            sc = rec["scores"]
            ri = "–" if sc["ri_paper"] is None else f"{sc['ri_paper']:.3f}"
            console.print(f"against {labels.name}: F1 {sc['f1']:.3f} (P {sc['precision']:.3f}, R {sc['recall']:.3f}), "
                          f"frame agreement {sc['frame_agreement']:.3f}, RI as the paper's authors compute it {ri}, "
                          f"Covering {sc['covering']:.3f}")
            if "naming_accuracy" in sc:
                console.print(f"actions named: frame accuracy {sc['naming_accuracy']:.3f} (best matching of letters to "
                              f"labels), purity {sc['naming_purity']:.3f}, NMI {sc['naming_nmi']:.3f}")
    for out in rec["outputs"]:  # the plot, and with --method arma its per-window diagnostics
        err.print(f"wrote {out['path']}")


@app.command("segment-bench")
def segment_bench(
    takes: Annotated[
        list[str] | None,
        typer.Argument(help="Labelled takes: TAKE=LABELS pairs or folders of takes with TAKE.labels.txt beside them "
                            "(default: the shared CMU set)."),
    ] = None,
    asf: Annotated[Path | None, typer.Option("--asf", help="ASF skeleton for AMC takes.")] = None,
    rate: Annotated[float | None, typer.Option("--rate", help="Frame rate of AMC takes (default 120 Hz).",
                                                  callback=_within(*RATE_RANGE))] = None,
    data: Annotated[
        Path, typer.Option("--data", help="The shared data folder (cmu/ and tssb/).")
    ] = Path("../shared/data"),
    out: Annotated[Path | None, typer.Option("--out", help="Folder for segment_bench.json and .md.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print all rows as JSON.")] = False,
    methods: Annotated[
        str, typer.Option("--methods", help="Comma-separated methods.")
    ] = "auto,arma,every400,pca,kmeans,mlp,kernelcpd,pelt,clasp",
    tssb: Annotated[
        bool | None, typer.Option("--tssb/--no-tssb", help="Also run the 75 TSSB series (default: only without TAKES).")
    ] = None,
    tssb_limit: Annotated[int | None, typer.Option("--tssb-limit", help="Only the first N TSSB series.",
                                                      callback=_within(1, 1_000_000))] = None,
    known_k: Annotated[
        bool, typer.Option("--known-k", help="Add rows given the true number of cuts (separate mode).")
    ] = False,
) -> None:
    """Every segmentation method on labelled takes (yours, or the shared CMU set) and on TSSB: RI, F1,
    Covering, seconds. Every label file is checked against its take before any segmenting."""
    from mocapkit.evaluation.segmentation import (
        MOCAP_METHODS,
        TSSB_METHODS,
        find_pairs,
        load_user_takes,
        markdown,
        run_mocap,
        run_tssb,
        summarise,
    )

    ms = [m.strip() for m in methods.split(",") if m.strip()]
    bad = [m for m in ms if m not in MOCAP_METHODS]
    if bad:
        raise InvalidParameterError(f"--methods: unknown method(s) {bad}; choose from {', '.join(MOCAP_METHODS)}")
    _check_output(out, folder=True, option="--out",
                  inputs=(data, asf, *[Path(x.strip()) for it in takes or [] for x in str(it).split("=", 1)]))
    cmu_dir, tssb_dir = data / "cmu", data / "tssb"
    log = (lambda s: err.print(s)) if not as_json else None
    source: list[Take] | Path
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


from mocapkit.cli_similarity import similarity as _similarity  # noqa: E402 - imports the shared options only

app.command("similarity")(_similarity)
from mocapkit.cli_view import view as _view  # noqa: E402 - imports the shared options only

app.command("view")(_view)
from mocapkit.cli_verify import verify as _verify  # noqa: E402 - imports the shared options only

app.command("verify")(_verify)

from mocapkit.cli_batch import batch_app  # noqa: E402 - the sub-app imports the shared options only

app.add_typer(batch_app, name="batch")

from mocapkit.cli_catalog import catalog_app  # noqa: E402 - the sub-app imports the shared options only

app.add_typer(catalog_app, name="catalog")


#: typer's click exceptions (usage errors: missing argument, unknown option, a value that is not a
#: number...), reached through the public ``typer.BadParameter`` whether typer vendors click or not (so typed
#: as any class: their ``show``/``format_message`` are click's)
_ClickException: type[Any] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")
_UsageError: type[Any] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
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
    from mocapkit.cli_options import SHOWN_WARNINGS

    if text not in SHOWN_WARNINGS:
        SHOWN_WARNINGS.add(text)
        sys.stderr.write(f"warning: {text}\n")




def _empty_positional(args: list[str]) -> list[str] | None:
    """The command words when a positional argument is empty (``Path("")`` would be the current folder),
    else ``None``. An option's value may be empty (``filter-eval --sizes ''`` means none): the command's
    options that take a value are looked up, so ``info --json ''`` is caught and ``--sizes ''`` is not."""
    if "" not in args:
        return None
    cmd, words, i = typer.main.get_command(app), [], 0
    while i < len(args):
        commands = getattr(cmd, "commands", {})  # a group's sub-commands by name
        if args[i] not in commands:
            break
        cmd = commands[args[i]]
        words.append(args[i])
        i += 1
    takes_value = {o for p in cmd.params if getattr(p, "opts", None) and not getattr(p, "is_flag", False)
                   and not getattr(p, "count", False) and p.param_type_name == "option"
                   for o in (*p.opts, *p.secondary_opts)}
    while i < len(args):
        if args[i] == "--":
            return words if "" in args[i + 1:] else None
        if args[i] == "":
            return words
        i += 2 if args[i] in takes_value else 1
    return None


def main(argv: list[str] | None = None) -> None:
    """The ``mocapkit`` entry point: every failure is one line ``error: ...`` on stderr.

    Exit codes: 0 success; 2 bad input, option or usage (a ``MocapError``, an ``OSError`` or a
    usage error of the command line); 3 an internal error (an exception mocapkit did not raise on
    purpose: a bug, please report it); 130 interrupted. ``MOCAPKIT_DEBUG=1`` adds the traceback.
    """
    import warnings

    warnings.showwarning = _show_warning
    args = sys.argv[1:] if argv is None else [str(a) for a in argv]
    words = _empty_positional(args)
    if words is not None:
        _fail(f"an empty argument: a file name or a value was expected (see mocapkit {' '.join([*words, '--help'])})",
              EXIT_INPUT)
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
