"""``mocapkit similarity A B``: two takes compared on their limb angles by DTW (Eq. 5–9 of the ARMA
seed paper). Registered by :mod:`mocapkit.cli`; parses, calls :func:`mocapkit.jobs.similarity.similarity_job`
and prints its record (a table, or strict JSON with ``--json``)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from mocapkit.cli_options import (
    AsfOpt,
    JointOpt,
    SegRateOpt,
    StrictOpt,
    _json,
    _progress,
    _within,
    console,
    print_warnings,
)


class Limb(str, Enum):
    right_leg = "right_leg"
    left_leg = "left_leg"
    right_arm = "right_arm"
    left_arm = "left_arm"


class Align(str, Enum):
    limb = "limb"
    joint = "joint"


def _range(rec_side: dict) -> str:
    a0, a1 = rec_side["frames"]
    return f"{Path(rec_side['file']).name}[{a0}:{a1}]"


def similarity(
    a: Annotated[
        Path, typer.Argument(metavar="A", help="First take: BVH, or AMC (with --asf or a CMU-named ASF beside it).")
    ],
    b: Annotated[Path, typer.Argument(metavar="B", help="Second take (may be the same file with another --frames-b).")],
    limb: Annotated[list[Limb] | None, typer.Option(
        "--limb", help="Limb angle to compare (repeat; default all four).")] = None,
    asf: AsfOpt = None,
    frames: Annotated[str | None, typer.Option(
        "--frames", help="Frames A0:A1 of the first take (0-based, A1 excluded; default all).")] = None,
    frames_b: Annotated[str | None, typer.Option(
        "--frames-b", help="Frames B0:B1 of the second take (default all).")] = None,
    align: Annotated[Align, typer.Option(
        "--align", help="One DTW path per limb (the paper's) or one joint path for all compared limbs.")] = Align.limb,
    band: Annotated[int | None, typer.Option(
        "--band", help="Sakoe-Chiba band in samples around the diagonal (default: none).",
        callback=_within(0, 1_000_000_000))] = None,
    resample: Annotated[int | None, typer.Option(
        "--resample", help="Time-normalise both ranges to N samples before DTW (default: no).",
        callback=_within(2, 10_000_000))] = None,
    rate: SegRateOpt = None,
    joint: JointOpt = None,
    strict: StrictOpt = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the record as JSON.")] = False,
) -> None:
    """Similarity of two takes' limb angles: DTW (Eq. 5-8) then the correlation of the aligned
    sequences (Eq. 9) per limb, as the ARMA paper's Section 3.4."""
    from mocapkit.jobs.similarity import similarity_job

    rec = similarity_job(a, b, asf=asf, limbs=[x.value for x in limb] if limb else None, frames=frames,
                         frames_b=frames_b, rate=rate, joint=joint, align=align.value, band=band, resample=resample,
                         strict=strict, progress=_progress)
    print_warnings(rec)
    if as_json:
        print(_json(rec, f"{a} {b}: similarity --json"))
        return
    per = "limb" if rec["align"] == "limb" else "joint path"
    tab = Table(title=f"{_range(rec['a'])} vs {_range(rec['b'])}: DTW per {per}"
                      + (f", band {rec['band']}" if rec["band"] is not None else "")
                      + (f", resampled to {rec['resample']}" if rec["resample"] is not None else ""))
    for col in ("limb", "r (Eq. 9)", "similarity %", "DTW distance ° (Eq. 5)", "K"):
        tab.add_column(col, justify="left" if col == "limb" else "right")
    for row in rec["limbs"]:
        r = row["r"]
        tab.add_row(row["limb"], "n/a" if r is None else f"{r:.3f}",
                    "" if r is None else f"{row['similarity_pct']:.1f}", f"{row['distance_deg']:.3f}",
                    str(row["path_length"]))
    console.print(tab)
    if rec["r_mean"] is not None:
        above = "above" if rec["above_paper_threshold"] else "not above"
        console.print(f"mean r over {len(rec['limbs'])} limb{'s' * (len(rec['limbs']) > 1)}: {rec['r_mean']:.3f} "
                      f"({above} the paper's 0.7 for one action across subjects)")
