"""The command line's face of ``.mkp`` packet streams (called from :mod:`mocapkit.cli`): the compress
table and the decompress command's work, so that ``cli.py`` only dispatches on the suffix."""

from __future__ import annotations

from pathlib import Path

from rich.table import Table

from mocapkit.cli_options import console, err, print_warnings


def packets_table(rec: dict, input: Path) -> Table:
    """The radio summary of ``compress -o OUT.mkp``: per sensor, points, packets, bytes per second."""
    tab = Table(title=f"{input.name} -> {rec['outputs'][0]['path']}: max angle {rec['target']:g} deg, "
                      f"{rec['packet_bits']} bits (quantisation <= {rec['quantisation_bound_deg']:.4g} deg), "
                      f"packets <= {rec['packet_bytes']} bytes")
    for col in ("signal", "samples", "points", "packets", "bytes", "Hz", "bytes/s", "raw f32 bytes/s", "ratio",
                "max °"):
        tab.add_column(col, justify="left" if col == "signal" else "right")
    for r in rec["signals"]:
        tab.add_row(r["name"], str(r["n_samples"]), str(r["n_points"]), str(r["packets"]), str(r["bytes"]),
                    f"{r['rate_hz']:.4g}", f"{r['bytes_per_s']:.1f}", f"{r['raw_float32_bytes_per_s']:.0f}",
                    f"{r['ratio']:.4f}", f"{r['max_deg']:.3f}")
    return tab


def print_compress(rec: dict, input: Path, as_json: bool) -> None:
    from mocapkit.cli_options import _json

    if as_json:
        print(_json(rec["signals"], "compress --json"))
    else:
        console.print(packets_table(rec, input))


def decompress(points: Path, output: Path, times_from: Path | None, rate: float | None, columns: dict) -> None:
    """``mocapkit decompress STREAM.mkp``: losses on stderr (one line each), then a summary line."""
    from mocapkit.jobs.packets import decompress_packets_job

    rec = decompress_packets_job(points, output, times_from=times_from, rate=rate, **columns)
    for line in rec["losses"]:
        err.print(f"warning: {line}", markup=False, highlight=False)
    print_warnings(rec)
    what = "points" if rec["mode"] == "points" else "samples"
    n = sum(s["points"] if what == "points" else s["samples"] for s in rec["sensors"])
    left = sum(s["samples_left_out"] for s in rec["sensors"])
    gaps = f", {left} samples across lost packets left out" if left else ""
    err.print(f"{points}: {len(rec['sensors'])} sensor{'s' * (len(rec['sensors']) > 1)}, {n} {what} -> {output}; "
              f"{rec['lost_packets']} packets lost, {rec['damaged_packets']} damaged{gaps}",
              markup=False, highlight=False)
