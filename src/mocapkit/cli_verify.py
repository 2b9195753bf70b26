"""``mocapkit verify ORIGINAL COMPRESSED``: any file mocapkit wrote checked against its original on every
sample (:func:`mocapkit.jobs.verify.verify_job`). Registered by :mod:`mocapkit.cli`; parses, calls, prints
(a table, or the record as strict JSON with ``--json``). Exit 1 when a given bound is exceeded."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from mocapkit.cli_options import (
    AsfOpt,
    MaxAngleOpt,
    MaxPositionErrorOpt,
    QuatColumnsOpt,
    RateOpt,
    ScalarLastOpt,
    ShellDistanceOpt,
    StrictOpt,
    TimeColumnOpt,
    TimeUnitOpt,
    UnitCmOpt,
    _json,
    _progress,
    console,
    print_warnings,
)

#: the exit code of a verify (single or batch) that found an error beyond the given bound
EXIT_EXCEEDED = 1


class VerifyMetric(str, Enum):
    joint_end = "joint+end"
    joint = "joint"
    shell = "shell"


def _where(w: dict | None) -> str:
    if not w:
        return ""
    name = w.get("sensor") or w.get("point")
    idx = f"sample {w['sample']}" if "sample" in w else f"frame {w['frame']}"
    return f"{name}, {idx}, {w['time_s']:.6g} s"


def _fmt(v, digits=4) -> str:
    return "" if v is None else f"{v:.{digits}g}"


def verdict(rec: dict) -> str:
    """One line: the largest error, where it is, the mean, the bound and whether it holds."""
    unit = "°" if rec["error_unit"] == "deg" else " cm"
    what = {"angle": "angle", "joint": "joint position", "joint+end": "joint and End Site position",
            "shell": "shell"}[rec["metric"]]
    line = (f"{Path(rec['compressed']).name}: max {what} error {_fmt(rec['max_error'], 6)}{unit} "
            f"({_where(rec['where'])}), mean {_fmt(rec['mean_error'], 6)}{unit}")
    if rec["bound"] is None:
        return line + "; no bound given"
    return line + f"; bound {rec['bound']:g}{unit}: " + ("within" if rec["within_bound"] else "EXCEEDED")


def _table(rec: dict) -> Table:
    if rec["kind"] == "imu":
        tab = Table(title=f"{Path(rec['file']).name} vs {Path(rec['compressed']).name} ({rec['format']}): "
                          "angle to the SLERP decode at every sample")
        for col in ("sensor", "samples", "compared", "max °", "at sample", "time s", "mean °"):
            tab.add_column(col, justify="left" if col == "sensor" else "right")
        for s in rec["sensors"]:
            at = s["max_at"] or {}
            tab.add_row(s["name"], str(s["samples"]), str(s["compared_samples"]), _fmt(s["max_deg"]),
                        str(at.get("sample", "")), _fmt(at.get("time_s"), 9), _fmt(s["mean_deg"]))
        return tab
    tab = Table(title=f"{Path(rec['file']).name} vs {Path(rec['compressed']).name}: {rec['frames']} frames, "
                      f"{rec['joints']} joints, {rec['end_sites']} End Sites, 1 unit = {rec['unit_cm']:g} cm"
                      + (" (assumed)" if rec["unit_cm_assumed"] else ""))
    for col in ("error", "max cm", "where", "frame", "time s", "mean cm"):
        tab.add_column(col, justify="left" if col in ("error", "where") else "right")
    for label, key in (("joints", "joint_positions"), ("End Sites", "end_site_positions"),
                       ("joints and End Sites", "positions"),
                       (f"shell ({rec['shell']['shell_distance_cm']:g} cm)", "shell")):
        s = rec[key]
        at = s["max_at"] or {}
        tab.add_row(label, _fmt(s["max_cm"]), at.get("point", ""), str(at.get("frame", "")), _fmt(at.get("time_s"), 9),
                    _fmt(s["mean_cm"]))
    return tab


def verify(
    original: Annotated[Path, typer.Argument(metavar="ORIGINAL", help="The recording that was compressed: an IMU file "
                                             "or sensor folder, or a BVH/AMC/MVNX take.")],
    compressed: Annotated[Path, typer.Argument(metavar="COMPRESSED", help="What mocapkit wrote from it: points CSV "
                                               "(or a folder of them), .mkp, .mkc, .glb/.gltf, or a decoded .bvh.")],
    max_angle: MaxAngleOpt = None,
    max_position_error: MaxPositionErrorOpt = None,
    error_metric: Annotated[VerifyMetric, typer.Option(
        "--error-metric", help="What --max-position-error is checked on: every joint and End Site (what compress "
                               "bounds by default), every joint, or ACL's shell points.")] = VerifyMetric.joint_end,
    shell_distance: ShellDistanceOpt = 3.0,
    unit_cm: UnitCmOpt = None,
    asf: AsfOpt = None,
    rate: RateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    strict: StrictOpt = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the record as JSON.")] = False,
) -> None:
    """Decode COMPRESSED and compare it with ORIGINAL on every sample or frame: IMU angle (SLERP decode),
    skeletal world positions of joints and End Sites and the shell metric, in cm. Prints the max and mean
    error and where the max is; exits 1 when a given bound is exceeded."""
    from mocapkit.jobs.verify import verify_job

    rec = verify_job(original, compressed=compressed, max_angle=max_angle, max_position_error=max_position_error,
                     error_metric=error_metric.value, shell_distance=shell_distance, unit_cm=unit_cm, asf=asf,
                     rate=rate, strict=strict, time_column=time_column, quaternion_columns=quaternion_columns,
                     scalar_last=scalar_last, time_unit=time_unit, progress=_progress)
    print_warnings(rec)
    if as_json:
        print(_json(rec, f"{original} {compressed}: verify --json"))
    else:
        console.print(_table(rec))
        console.print(verdict(rec), markup=False, highlight=False, soft_wrap=True)
    if rec["within_bound"] is False:
        raise typer.Exit(EXIT_EXCEEDED)


def exceeded_rows(rows: list[dict]) -> list[tuple[str, str]]:
    """``(input, verdict line)`` of the ``ok`` rows of a ``batch verify`` whose record exceeds its bound."""
    import json

    out = []
    for r in rows:
        if r.get("status") == "ok" and r.get("record_json"):
            rec = json.loads(r["record_json"])
            if rec.get("within_bound") is False:
                out.append((r["input"], verdict(rec)))
    return out


def summarise_exceeded(rows: list[dict]) -> int:
    """Print how many pairs of a ``batch verify`` exceed their bound, and which; returns that number."""
    bad = exceeded_rows(rows)
    say = lambda s: console.print(s, markup=False, highlight=False, soft_wrap=True)  # noqa: E731
    say(f"verify: {len(bad)} of {sum(r.get('status') == 'ok' for r in rows)} verified pairs exceed the bound")
    for path, line in bad:
        say(f"  {path}: {line}")
    return len(bad)


def check_batch_folders(inputs: list[str], compressed: Path, out: Path) -> None:
    """Refuse, before any work, a compressed folder that is missing or lies inside an input folder (its
    outputs would be read as inputs) and an ``--out`` that is the compressed folder (the journal and results
    of the compress batch would be replaced)."""
    import os

    from mocapkit.errors import InvalidParameterError

    comp = os.path.abspath(compressed)
    if not os.path.isdir(comp):
        raise InvalidParameterError(f"--compressed {compressed}: not a folder")
    if os.path.abspath(out) == comp:
        raise InvalidParameterError(f"--out {out}: give another folder than --compressed (its journal and results "
                                    "are the compress batch's)")
    for arg in inputs:
        a = os.path.abspath(arg)
        if os.path.isdir(a) and (comp + os.sep).startswith(a.rstrip(os.sep) + os.sep):
            raise InvalidParameterError(f"--compressed {compressed}: inside the input folder {arg}, whose files would "
                                        "be read as inputs")
