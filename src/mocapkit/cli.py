"""The ``mocapkit`` command line (typer + rich). Thin: parse, call the library, print or write."""

from __future__ import annotations

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
err = Console(stderr=True)


class Method(str, Enum):
    fastsw = "fastsw"
    sw = "sw"
    cplr = "cplr"
    swing = "swing"
    anglesw = "anglesw"
    optimal = "optimal"


RateOpt = Annotated[
    Optional[float],
    typer.Option("--rate", help="Sample rate in Hz, for files without timestamps (legacy x-io, Xsens)."),
]
MethodOpt = Annotated[Method, typer.Option("--method", "-m", help="PLA method.")]
ThresholdOpt = Annotated[
    Optional[float],
    typer.Option(
        "--threshold",
        "-t",
        help="The method's own bound: SSR per segment (fastsw, sw, cplr), ε per sample (swing), degrees (anglesw).",
    ),
]
MaxAngleOpt = Annotated[
    Optional[float],
    typer.Option("--max-angle", help="Guarantee: every sample within DEG degrees of the SLERP decode (verified)."),
]
MaxLenOpt = Annotated[
    Optional[int],
    typer.Option("--max-segment-length", help="At most N sample intervals between segment points."),
]


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
        Optional[float], typer.Option("--target-icr", help="Find the threshold giving this ICR (points/samples).")
    ] = None,
    max_angle: MaxAngleOpt = None,
    max_segment_length: MaxLenOpt = None,
    rate: RateOpt = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object per signal (a list).")] = False,
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    max_position_error: Annotated[
        Optional[float],
        typer.Option("--max-position-error", help="Skeletal input: every joint's world position within CM (verified)."),
    ] = None,
    unit_cm: Annotated[
        Optional[float], typer.Option("--unit-cm", help="Skeletal input: centimetres per file length unit.")
    ] = None,
    strict: Annotated[bool, typer.Option("--strict/--no-strict", help="BVH: Frames: mismatch is an error (default) or is recorded.")] = True,
) -> None:
    """Compress orientation streams (IMU files, sensor folders) or whole skeletons (BVH, AMC).

    IMU input: segment points as CSV time,w,x,y,z. Skeletal input: keyframes as glTF (.glb/.gltf) or
    the decoded full-rate motion as .bvh.
    """
    from mocapkit.io.loaders import kind_of

    if kind_of(input) == "skeletal":
        _compress_skeletal(input, output, method, threshold, target_icr, max_position_error, max_angle,
                           max_segment_length, rate, as_json, asf, unit_cm, strict)
        return
    if max_position_error is not None or asf is not None or unit_cm is not None:
        raise InvalidParameterError("--max-position-error, --asf and --unit-cm apply to BVH/AMC input")
    from mocapkit.io import load_signals, write_signal_csv
    from mocapkit.pla import compress_to, evaluate

    _one_control(threshold, target_icr, max_angle)
    signals = load_signals(input, rate=rate)
    folder_mode = input.is_dir()
    if folder_mode and output is not None and output.exists() and not output.is_dir():
        raise InvalidParameterError(f"{output}: INPUT is a folder, so --output must be a folder")
    mode, target = (
        ("threshold", threshold) if threshold is not None
        else ("target_icr", target_icr) if target_icr is not None
        else ("max_angle", max_angle)
    )
    records = []
    for name, sig in signals.items():
        comp = compress_to(
            sig, method.value, threshold=threshold, target_icr=target_icr, max_angle=max_angle,
            max_segment_length=max_segment_length,
        )
        met = evaluate(sig, comp)
        records.append(_record(name, sig.source, comp, met, mode, target))
        if output is not None:
            dest = output / f"{name}.csv" if folder_mode else output
            if folder_mode:
                output.mkdir(parents=True, exist_ok=True)
            write_signal_csv(dest, comp.times, comp.values)
        elif not folder_mode and not as_json:
            sys.stdout.write("time,w,x,y,z\n")
            for t, v in zip(comp.times.tolist(), comp.values.tolist()):
                sys.stdout.write(",".join(repr(x) for x in (t, *v)) + "\n")
    if as_json:
        print(json.dumps(records, indent=1))
    else:
        err.print(_summary_table(records, f"{method.value}: {mode} {target:g}"))
    if folder_mode and output is None:
        err.print("no --output folder given: the segment points were not written")
    skipped = sorted({f for s in signals.values() for f in s.meta.get("skipped_files", [])})
    if skipped:
        err.print(f"not orientation data, skipped: {', '.join(skipped)}")


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
    comp = compress_motion(
        motion, method.value, threshold=threshold, target_icr=target_icr, max_position_error=bound,
        max_segment_length=max_segment_length,
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
        print(json.dumps(rec, indent=1))
    else:
        tab = Table(title=f"{input.name}: {rec['method']} ({rec['mode']})")
        tab.add_column("quantity")
        tab.add_column("value", justify="right")
        for k in ("n_frames", "n_joints", "keyframes", "icr", "max_position_error_cm", "mean_position_error_cm",
                  "aad_deg", "max_deg", "bytes_raw", "bytes_out", "ratio"):
            v = rec[k]
            tab.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
        err.print(tab)
        if assumed:
            err.print("length unit assumed to be 1 cm; give --unit-cm for other units")


@app.command()
def info(
    input: Annotated[Path, typer.Argument(help="BVH, AMC, C3D, Qualisys TSV, IMU file or sensor folder.")],
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    rate: RateOpt = None,
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
        }
    else:
        from mocapkit.io import load_signals

        sigs = load_signals(input, rate=rate)
        rec = {
            "file": str(input), "kind": "imu", "signals": {
                n: {"samples": len(s), "duration_s": s.duration, "mean_rate_hz": s.mean_rate,
                    "format": s.meta.get("format"), "largest_gap_s": float(np.diff(s.times).max()) if len(s) > 1 else 0.0}
                for n, s in sigs.items()
            },
        }
    if as_json:
        print(json.dumps(rec, indent=1))
    else:
        tab = Table(title=str(input))
        tab.add_column("field")
        tab.add_column("value")
        for k, v in rec.items():
            if k in ("joint_names", "joint_channels", "labels"):
                v = f"{len(v)} entries (see --json)"
            tab.add_row(k, str(v))
        err.print(tab)


@app.command()
def convert(
    input: Annotated[Path, typer.Argument(help="AMC (+ --asf) or BVH; C3D or Qualisys TSV.")],
    output: Annotated[Path, typer.Argument(help="BVH or AMC for skeletal input; CSV for markers.")],
    asf: Annotated[Optional[Path], typer.Option("--asf", help="Skeleton for an AMC input.")] = None,
    precision: Annotated[int, typer.Option("--precision", help="Decimals written to BVH.")] = 6,
    strict: Annotated[bool, typer.Option("--strict/--no-strict", help="BVH: Frames: mismatch is an error (default) or is recorded.")] = True,
) -> None:
    """Convert AMC (with its ASF) to BVH and back (BVH + --asf to AMC), and markers (C3D, TSV) to CSV."""
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
        else:
            if asf is None or input.suffix.lower() != ".bvh":
                raise InvalidParameterError("BVH -> AMC needs --asf (the skeleton the BVH was made from)")
            from mocapkit.io.amc import read_asf, write_amc

            m = load_motion(input, strict=strict)
            try:
                write_amc(output, m, read_asf(asf))
            except InvalidSignalError as e:  # a rotation the ASF's dofs cannot express: name the files
                raise InvalidSignalError(f"{input} -> {output}: {e}") from None
        err.print(f"{input} -> {output}: {m.n_frames} frames, {m.skeleton.n_joints} joints")
    elif kind == "markers":
        if output.suffix.lower() != ".csv":
            raise InvalidParameterError(f"{output}: markers convert to .csv")
        from mocapkit.markers import load_markers

        mk = load_markers(input)
        mk.to_csv(output)
        err.print(f"{input} -> {output}: {mk.times.shape[0]} frames, {len(mk.labels)} markers")
    else:
        raise InvalidParameterError(f"{input}: convert reads BVH, AMC, C3D or TSV files")


class Solver(str, Enum):
    exact = "exact"
    iterative = "iterative"


def _filter_inputs(input: Path, markers: Optional[str], columns: Optional[str]):
    """``[(name, times, values (N, D), component names)]`` to filter."""
    from mocapkit.errors import MocapFormatError
    from mocapkit.io.loaders import kind_of

    out = []
    if markers is not None and columns is not None:
        raise InvalidParameterError("give --markers or --columns, not both")
    is_markers = kind_of(input) == "markers"
    if not is_markers and input.suffix.lower() == ".csv":
        head = input.open(encoding="utf-8", errors="replace").readline()
        is_markers = head.strip().lower().startswith("time,") and "_x" in head
        if columns is not None:
            is_markers = False
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
    # a plain CSV with a header: a time column (first) and named columns
    lines = input.read_text(encoding="utf-8").splitlines()
    if not lines:
        raise MocapFormatError(str(input), None, "empty file")
    header = [h.strip() for h in lines[0].split(",")]
    rows = []
    for i, ln in enumerate(lines[1:], start=2):
        if not ln.strip():
            continue
        f = ln.split(",")
        if len(f) != len(header):
            raise MocapFormatError(str(input), i, f"expected {len(header)} columns, got {len(f)}")
        try:
            rows.append([float(x) if x.strip() != "" else float("nan") for x in f])
        except ValueError:
            raise MocapFormatError(str(input), i, "a field is not a number") from None
    if not rows:
        raise MocapFormatError(str(input), None, "header only, no data rows")
    data = np.array(rows)
    bad = np.flatnonzero(~(np.diff(data[:, 0]) > 0))
    if bad.size or not np.all(np.isfinite(data[:, 0])):
        i = int(bad[0]) + 1 if bad.size else int(np.flatnonzero(~np.isfinite(data[:, 0]))[0])
        raise MocapFormatError(str(input), i + 2, f"time {data[i, 0]!r} is not after the previous row's; "
                               "times must be finite and strictly increasing")
    if np.isinf(data).any():
        i = int(np.flatnonzero(np.isinf(data).any(axis=1))[0])
        raise MocapFormatError(str(input), i + 2, "infinite value (leave a cell empty or write nan for a missing sample)")
    names = [c.strip() for c in columns.split(",")] if columns else header[1:]
    for c in names:
        if c not in header[1:]:
            raise InvalidParameterError(f"{input}: no column {c!r} (columns: {', '.join(header[1:])})")
        out.append((c, data[:, 0], data[:, [header.index(c)]], [c]))
    return out


@app.command("filter")
def filter_cmd(
    input: Annotated[Path, typer.Argument(help="C3D, Qualisys TSV, marker CSV or a CSV with a time column.")],
    order: Annotated[int, typer.Option("--order", help="Polynomial order of every chunk.")] = 2,
    penalty: Annotated[Optional[float], typer.Option("--penalty", help="K: the cost of a knot, in signal units.")] = None,
    auto: Annotated[bool, typer.Option("--auto", help="K from the noise level (see docs).")] = False,
    solver: Annotated[Solver, typer.Option("--solver", help="exact (global optimum) or iterative (the seed's).")] = Solver.exact,
    markers: Annotated[Optional[str], typer.Option("--markers", help="NAME[:xyz],... (knots shared by the components).")] = None,
    columns: Annotated[Optional[str], typer.Option("--columns", help="CSV columns to filter, each on its own.")] = None,
    output: Annotated[Optional[Path], typer.Option("--output", "-o", help="Filtered values at the input times (CSV).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Knots and polynomial pieces as JSON.")] = False,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG: position and two derivatives of the first signal.")] = None,
) -> None:
    """Filter by piecewise polynomials: keeps discontinuities (catches, throws, heel strikes)."""
    from mocapkit.filters.api import fit

    if (penalty is None) == (not auto):
        raise InvalidParameterError("give exactly one of --penalty K or --auto")
    if order < 0:
        raise InvalidParameterError("--order must be >= 0")
    signals = _filter_inputs(input, markers, columns)
    results = []
    for name, t, Y, comps in signals:
        r = fit(t, Y, order, penalty, solver.value)
        results.append((name, t, Y, comps, r))
        for a, b in r.unfitted:
            err.print(f"warning: {name}: samples at {a:g}..{b:g} s lie between long gaps and are too few to "
                      f"fit with order {order}: left out (NaN in the output)")
    if output is not None:
        from mocapkit.io.atomic import atomic_write_text

        t = results[0][1]
        cols = [r.evaluate(t) for (_, tt, _, _, r) in results]
        head = ["time"] + [c for (_, _, _, comps, _) in results for c in comps]
        body = np.column_stack([t] + cols)
        atomic_write_text(output, ",".join(head) + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in body) + "\n")
    if as_json:
        recs = []
        for name, t, Y, comps, r in results:
            D = Y.shape[1]
            recs.append({
                "name": name, "components": comps, "order": order, "penalty": r.penalty, "solver": r.solver,
                "loss": r.loss, "iterative_loss": r.iterative_loss, "n_knots": r.n_knots,
                "pieces": [{"t0": p.t0, "t1": p.t1,
                            "coeffs": p.coeffs[:, 0].tolist() if D == 1 else [p.coeffs[:, d].tolist() for d in range(D)]}
                           for p in r.pieces],
            })
        print(json.dumps(recs, indent=1))
    else:
        tab = Table(title=f"{input.name}: piecewise polynomials of order {order} ({solver.value})")
        for c in ("signal", "K", "knots", "pieces", "loss", "iterative loss"):
            tab.add_column(c, justify="right")
        for name, t, Y, comps, r in results:
            tab.add_row(name, f"{r.penalty:.4g}", str(r.n_knots), str(len(r.pieces)), f"{r.loss:.6g}", f"{r.iterative_loss:.6g}")
        err.print(tab)
    if plot is not None:
        from mocapkit.plot import plot_ppa

        name, t, Y, comps, r = results[0]
        plot_ppa(t, Y[:, -1], r, plot, title=f"{input.name}: {comps[-1]}")


@app.command("filter-eval")
def filter_eval(
    out: Annotated[Path, typer.Option("--out", help="Folder for the JSON results and figures.")] = Path("filter-out"),
    juggling: Annotated[Optional[Path], typer.Option("--juggling", help="The Qualisys juggling TSV.")] = None,
    sizes: Annotated[str, typer.Option("--sizes", help="Signal lengths for the exact solver's time curve.")] = "1000,2000,5000,10000,20000,50000",
) -> None:
    """The filtering experiments: synthetic Figure 2 signal, step overshoot, juggling flights, timing."""
    from mocapkit.evaluation.filtering import evaluate_juggling, evaluate_synthetic, exact_time_curve, figures
    from mocapkit.io.atomic import atomic_write_text

    out.mkdir(parents=True, exist_ok=True)
    syn = evaluate_synthetic()
    atomic_write_text(out / "synthetic.json", json.dumps(syn, indent=1))
    mk = None
    if juggling is not None:
        from mocapkit.markers import load_markers

        mk = load_markers(juggling)
        balls = [b for b in mk.labels if not b.startswith("base") and
                 np.isfinite(mk.positions[:, mk.labels.index(b), 2]).mean() >= 0.5]
        jug = evaluate_juggling(mk, balls)
        atomic_write_text(out / "juggling.json", json.dumps(jug, indent=1))
        err.print(f"juggling: {jug['n_flights']} flights of {len(balls)} balls, median acceleration "
                  f"{jug['median_flight_acc']:.3f} m/s²")
    curve = exact_time_curve(tuple(int(x) for x in sizes.split(",")))
    atomic_write_text(out / "timing.json", json.dumps(curve, indent=1))
    for p in figures(out, mk):
        err.print(f"wrote {p}")
    rows = syn["rows"]
    for k in ("exact_f1", "iterative_f1", "exact_rmse", "butterworth_rmse", "spline_rmse",
              "exact_overshoot", "butterworth_overshoot", "spline_overshoot"):
        err.print(f"synthetic {k}: mean {np.mean([r[k] for r in rows]):.4f}")
    for c in curve:
        err.print(f"n = {c['n']}: iterative {c['iterative_s']:.2f} s, exact {c['exact_s']:.2f} s, "
                  f"loss gap {c['iterative_loss'] - c['exact_loss']:.4g}")


@app.command()
def decompress(
    points: Annotated[Path, typer.Argument(help="Segment points CSV (time,w,x,y,z).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Reconstructed CSV.")],
    times_from: Annotated[
        Optional[Path], typer.Option("--times-from", help="Decode at the timestamps of this original file.")
    ] = None,
    rate: Annotated[
        Optional[float],
        typer.Option(
            "--rate",
            help="Decode on a uniform grid at HZ; with --times-from, the rate of an ORIGINAL without timestamps.",
        ),
    ] = None,
) -> None:
    """Reconstruct a full-rate quaternion signal from segment points by SLERP."""
    import numpy as np

    from mocapkit.io import load_signals, read_imu_csv, write_signal_csv
    from mocapkit.pla.decode import reconstruct_points
    from mocapkit.quat import normalize

    if times_from is None and rate is None:
        raise InvalidParameterError("give --times-from ORIGINAL or --rate HZ")
    pts = read_imu_csv(points)
    if times_from is not None:
        originals = load_signals(times_from, rate=rate)
        if len(originals) != 1:
            raise InvalidParameterError(f"{times_from}: expected one signal, found {len(originals)}")
        t = next(iter(originals.values())).times
    else:
        if not (math.isfinite(rate) and rate > 0):
            raise InvalidParameterError(f"--rate must be a positive number, got {rate!r}")
        n = int(math.floor((pts.times[-1] - pts.times[0]) * rate + 1e-9)) + 1
        if n > 50_000_000:
            raise InvalidParameterError(f"--rate {rate:g} over {pts.times[-1] - pts.times[0]:g} s gives {n} samples; too many")
        t = pts.times[0] + np.arange(n) / rate
    if len(pts) == 1:
        vals = np.repeat(normalize(pts.values), len(t), axis=0)
    else:
        try:
            vals = reconstruct_points(pts.times, pts.values, t, "quaternion")
        except InvalidParameterError as e:
            raise InvalidParameterError(f"{points}: {e}") from None
    write_signal_csv(output, t, vals)
    err.print(f"{points}: {len(pts)} points -> {len(t)} samples in {output}")


@app.command()
def stream(
    method: MethodOpt = Method.fastsw,
    threshold: ThresholdOpt = None,
    max_angle: MaxAngleOpt = None,
    max_segment_length: MaxLenOpt = None,
    rate: RateOpt = None,
) -> None:
    """Read IMU CSV rows from stdin; write each segment point to stdout the moment it is decided."""
    from mocapkit.io.streamcsv import iter_samples
    from mocapkit.pla import Encoder

    if (threshold is None) == (max_angle is None):
        raise InvalidParameterError("give exactly one of --threshold or --max-angle (a target ICR needs the whole signal)")
    m = method.value
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
            out.write(",".join(repr(float(v)) for v in (p.time, *p.values)) + "\n")
        if points:
            out.flush()

    out.write("time,w,x,y,z\n")
    out.flush()
    try:
        for _lineno, t, q in iter_samples(sys.stdin, "<stdin>", rate):
            emit(enc.push(t, q))
    finally:
        emit(enc.flush())


@app.command()
def sweep(
    inputs: Annotated[list[Path], typer.Argument(help="IMU files or sensor folders.")],
    out: Annotated[Path, typer.Option("--out", help="Folder for sweep.csv and the figures.")] = Path("sweep-out"),
    n_thresholds: Annotated[int, typer.Option("--thresholds", help="Thresholds: 0 plus N-1 log-spaced in 1e-6..1e3.")] = 205,
    max_segment_length: Annotated[int, typer.Option("--max-segment-length")] = 1000,
    rate: RateOpt = None,
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

    if all(kind_of(p) == "skeletal" for p in inputs):
        _sweep_skeletal(inputs, out, asf, unit_cm)
        return

    signals = {}
    for p in inputs:
        for name, sig in load_signals(p, rate=rate).items():
            key = name if name not in signals else f"{p.stem}/{name}"
            signals[key] = sig
    rows = run_sweep(signals, n_thresholds=n_thresholds, max_segment_length=max_segment_length, progress=err)
    paths = write_outputs(rows, out)
    if all(s.kind == "quaternion" for s in signals.values()):
        from mocapkit.evaluation.sweep import write_max_angle

        paths.append(write_max_angle(signals, out))
    err.print(summarise(rows))
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
    err.print(summary_table(rows))
    err.print(f"wrote {out / 'skeletal.csv'}, icr_vs_position_error.png and fig5_*.png")


@app.command()
def bench(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON records.")] = False,
    channels: Annotated[int, typer.Option("--channels", help="Channels in the many-channel batch run.")] = 31,
    frames: Annotated[int, typer.Option("--frames", help="Frames per channel in the many-channel run.")] = 100_000,
    quick: Annotated[bool, typer.Option("--quick", help="Smaller sizes (for a smoke test).")] = False,
) -> None:
    """ns/sample of batch kernels and streaming encoders vs mean segment length; fastSW/SW ratio."""
    from mocapkit.evaluation.bench import run_bench

    if channels < 1 or frames < 100:
        raise InvalidParameterError("--channels must be >= 1 and --frames >= 100")
    records, summary = run_bench(channels=channels, frames=frames, quick=quick, progress=err)
    err.print(summary)  # the table goes to stderr, so `--json > file` keeps both
    if as_json:
        print(json.dumps(records, indent=1))


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", help="Where to write the segment points.")] = Path("demo-out"),
) -> None:
    """Compress the bundled x-io lower-body walk (7 IMUs) with every method; print the trade-offs."""
    from mocapkit.evaluation.demo import run_demo

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
    """A labels file: CMU-86 HACA (``label a b c`` lines after a header) or mocap6 per-frame labels."""
    from mocapkit.io.labels import read_frame_labels, read_haca_labels

    lines = [ln.split() for ln in Path(path).read_text(errors="replace").splitlines() if ln.strip()]
    # HACA: a header line, then "label a b c" lines with a (non-integer) label name; mocap6: integers only
    haca = any(not tok.lstrip("-").isdigit() for ln in lines[1:] for tok in ln)
    if haca:
        return read_haca_labels(path, n_frames=n_frames, rate_hz=rate_hz)
    # mocap6 labels are at 10 Hz: 12 frames of a 120 Hz take per label
    return read_frame_labels(path, n_frames=n_frames, frames_per_label=max(1, int(round(rate_hz / 10.0))),
                             rate_hz=rate_hz)


def _pairs(items: Optional[list[str]], what: str) -> list[tuple[str, str]]:
    out = []
    for it in items or []:
        if "=" not in it:
            raise InvalidParameterError(f"{what}: expected A=B, got {it!r}")
        a, b = it.split("=", 1)
        out.append((a.strip(), b.strip()))
    return out


def _rate_scaled(method: str, rate_hz: float) -> dict:
    """The baselines' frame-count defaults (set for 120 Hz: 1 s shortest segment, 0.5 s smoothing,
    Barbič's 2 s warm-up) scaled to the take's rate."""
    f = rate_hz / 120.0

    def fr(n: int) -> int:
        return max(1, int(round(n * f)))

    if method == "pca":
        step = fr(5)
        return {"k_init": fr(240), "step": step, "lag": step * max(1, round(fr(60) / step)), "min_segment": fr(120)}
    if method in ("kmeans", "mlp"):
        return {"smooth": fr(61) | 1, "min_segment": fr(120)}
    if method in ("kernelcpd", "pelt"):
        return {"min_size": max(2, fr(120))}
    return {}


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
    rate: Annotated[Optional[float], typer.Option("--rate", help="Frame rate of an AMC file (default 120 Hz).")] = None,
    downsample: Annotated[Optional[int], typer.Option("--downsample", help="ARMA: keep every N-th frame (default: the factor nearest to 30 Hz).")] = None,
) -> None:
    """Cut a take into actions from its limb-bone angles (the ARMA method or a baseline)."""
    from mocapkit.io.loaders import load_motion
    from mocapkit.segment.features import LIMB_NAMES, motion_features, pose_features

    motion = load_motion(input, asf=asf, rate=rate)
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
                ref = _read_reference(Path(lab), tm.n_frames, tm.rate)
                data.append((motion_features(tm, jmap).limbs, np.asarray(ref.labels, dtype=object)[ref.frame_labels()]))
            kw["train"] = data
        elif train:
            raise InvalidParameterError("--train is only for --method mlp")
        kw.update(_rate_scaled(m, float(motion.rate)))
        seg = BASELINES[m](**kw)
    X = pose_features(motion) if m == "pca" else feats.limbs
    cuts = seg.fit_predict(X)
    rate_hz = float(motion.rate)
    ref = _read_reference(labels, motion.n_frames, rate_hz) if labels is not None else None
    if as_json:
        rec = {"method": m, "n_frames": motion.n_frames, "rate_hz": rate_hz,
               "cuts": [{"frame": int(c), "time_s": float(c) / rate_hz} for c in cuts]}
        if ref is not None:
            from mocapkit.evaluation.segmentation import score

            rec["reference_cuts"] = [int(c) for c in ref.cuts]
            rec["scores"] = score(cuts, ref)
        print(json.dumps(rec, indent=1))
    else:
        Console().print(f"{input.name}: {len(cuts)} cuts ({m}, {motion.n_frames} frames at {rate_hz:g} Hz)")
        tab = Table()
        tab.add_column("cut", justify="right")
        tab.add_column("frame", justify="right")
        tab.add_column("time (s)", justify="right")
        for i, c in enumerate(cuts, 1):
            tab.add_row(str(i), str(int(c)), f"{c / rate_hz:.3f}")
        Console().print(tab)
        if ref is not None:
            from mocapkit.evaluation.segmentation import score

            sc = score(cuts, ref)
            Console().print(f"against {labels.name}: RI {sc['ri']:.3f}, F1 {sc['f1']:.3f} "
                            f"(P {sc['precision']:.3f}, R {sc['recall']:.3f}), Covering {sc['covering']:.3f}")
    if plot is not None:
        from mocapkit.plot import plot_segmentation

        plot_segmentation(feats.limbs, rate_hz, cuts, plot, ref_cuts=None if ref is None else ref.cuts,
                          names=list(LIMB_NAMES), title=f"{input.name}: {m}")
        err.print(f"wrote {plot}")


@app.command("segment-bench")
def segment_bench(
    data: Annotated[Path, typer.Option("--data", help="The shared data folder (cmu/ and tssb/).")] = Path("../shared/data"),
    out: Annotated[Optional[Path], typer.Option("--out", help="Folder for segment_bench.json and .md.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print all rows as JSON.")] = False,
    methods: Annotated[str, typer.Option("--methods", help="Comma-separated methods.")] = "arma,pca,kmeans,mlp,kernelcpd,pelt,clasp",
    tssb: Annotated[bool, typer.Option("--tssb/--no-tssb", help="Also run the 75 TSSB series.")] = True,
    tssb_limit: Annotated[Optional[int], typer.Option("--tssb-limit", help="Only the first N TSSB series.")] = None,
    known_k: Annotated[bool, typer.Option("--known-k", help="Add rows given the true number of cuts (separate mode).")] = False,
) -> None:
    """Every segmentation method on the labelled CMU takes and on TSSB: RI, F1, Covering, seconds."""
    from mocapkit.evaluation.segmentation import MOCAP_METHODS, TSSB_METHODS, markdown, run_mocap, run_tssb, summarise

    ms = [m.strip() for m in methods.split(",") if m.strip()]
    bad = [m for m in ms if m not in MOCAP_METHODS]
    if bad:
        raise InvalidParameterError(f"unknown method(s) {bad}; choose from {', '.join(MOCAP_METHODS)}")
    cmu_dir, tssb_dir = data / "cmu", data / "tssb"
    if not cmu_dir.is_dir():
        raise InvalidParameterError(f"{cmu_dir} not found: give the shared data folder with --data")
    log = (lambda s: err.print(s)) if not as_json else None
    rows = run_mocap(cmu_dir, ms, known_k=known_k, log=log)
    trows = []
    if tssb:
        if not tssb_dir.is_dir():
            raise InvalidParameterError(f"{tssb_dir} not found (or use --no-tssb)")
        trows = run_tssb(tssb_dir, [m for m in ms if m in TSSB_METHODS], limit=tssb_limit, log=log)
    md = markdown(rows, trows)
    if out is not None:
        from mocapkit.io.atomic import atomic_write_text

        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "segment_bench.json", json.dumps({"cmu": rows, "tssb": trows,
                                                                  "summary": summarise(rows, trows)}, indent=1))
        atomic_write_text(out / "segment_bench.md", md)
    if as_json:
        print(json.dumps({"cmu": rows, "tssb": trows, "summary": summarise(rows, trows)}, indent=1))
    else:
        print(md)


def main() -> None:
    try:
        app()
    except MocapError as e:
        sys.stderr.write(f"error: {e}\n")
        sys.exit(2)
    except OSError as e:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        sys.stderr.write(f"error: {where}{e.strerror or e}\n")
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)


if __name__ == "__main__":
    main()
