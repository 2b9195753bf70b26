"""``mocapkit view FILE...``: the files drawn in the browser from a server on 127.0.0.1 (mocapkit.view), or
rendered to a GIF/MP4 with ``--export``. Registered by :mod:`mocapkit.cli`; parses, calls, prints."""

from __future__ import annotations

import signal
import sys
from pathlib import Path
from typing import Annotated

import typer

from mocapkit.cli_options import (
    RATE_RANGE,
    AsfOpt,
    QuatColumnsOpt,
    ScalarLastOpt,
    StrictOpt,
    TimeColumnOpt,
    TimeUnitOpt,
    UnitCmOpt,
    _progress,
    _within,
    console,
    err,
)
from mocapkit.errors import InvalidParameterError

ViewRateOpt = Annotated[float | None, typer.Option(
    "--rate", help="Sample rate in Hz of an IMU file without timestamps (legacy x-io, Xsens), or the frame rate of "
                   "an AMC file (default 120 Hz), as compress reads them.", callback=_within(*RATE_RANGE))]


def _frame_range(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    a, sep, b = text.partition(":")
    try:
        lo, hi = int(a), int(b)
    except ValueError:
        lo = hi = -1
    if not sep or lo < 0 or hi <= lo:
        raise InvalidParameterError(f"--frames {text!r}: give A:B, whole frames with 0 <= A < B")
    return lo, hi


def _trail(text: str) -> float | None:
    if text.strip().lower() == "all":
        return None
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not (0 < v < 1e6):
        raise InvalidParameterError(f"--trail {text!r}: a positive number of seconds, or 'all'")
    return v


def view(
    files: Annotated[list[Path], typer.Argument(
        metavar="FILE...", help="Skeletons (BVH, AMC, MVNX, .mkc, glTF/.glb), IMU files or sensor folders with "
                                "their .mkp or points CSV, marker files (C3D, TSV, TRC). A skeleton with the "
                                "joints of an earlier one is drawn as its decode; a .mkp after an IMU file "
                                "as its compression.")],
    segments: Annotated[Path | None, typer.Option(
        "--segments", help="Cuts and labels from `mocapkit segment FILE --json` (of the first file).")] = None,
    filter_json: Annotated[Path | None, typer.Option(
        "--filter", help="Pieces and knots from `mocapkit filter MARKERS --json` (of the marker file).")] = None,
    port: Annotated[int, typer.Option(
        "--port", help="Port on 127.0.0.1 (default 0: a free one, printed).", callback=_within(0, 65535))] = 0,
    no_browser: Annotated[bool, typer.Option("--no-browser", help="Do not open a browser; just serve.")] = False,
    export: Annotated[Path | None, typer.Option(
        "--export", help="Render the view to OUT.gif or OUT.mp4 (ffmpeg) instead of serving it.")] = None,
    fps: Annotated[float, typer.Option(
        "--fps", help="--export: frames per second of the video.", callback=_within(1, 240))] = 30.0,
    frames: Annotated[str | None, typer.Option(
        "--frames", help="--export: frames A:B of the first file only (0-based, B excluded).")] = None,
    follow: Annotated[bool | None, typer.Option(
        "--follow/--no-follow", help="--export: keep the skeletons framed on their current pose (default: when a "
                                     "root travels more than 1.5 body heights).", show_default=False)] = None,
    trail: Annotated[str, typer.Option(
        "--trail", help="--export: marker trajectories, fits and knots within this many seconds of the current "
                        "time, or 'all'.")] = "1",
    asf: AsfOpt = None,
    rate: ViewRateOpt = None,
    time_column: TimeColumnOpt = None,
    quaternion_columns: QuatColumnsOpt = None,
    scalar_last: ScalarLastOpt = False,
    time_unit: TimeUnitOpt = None,
    unit_cm: UnitCmOpt = None,
    strict: StrictOpt = True,
) -> None:
    """Look at motion: original and compressed skeletons or IMU orientations side by side with their
    error, segment cuts on the timeline, marker trajectories with the filter's pieces and knots."""
    from mocapkit.jobs.common import imu_columns
    from mocapkit.view.scene import build_scene

    span = _frame_range(frames)
    trail_s = _trail(trail)
    if export is not None:
        from mocapkit.view.export import check_export

        inputs = [*files, *(p for p in (segments, filter_json, asf) if p is not None)]
        # the output (folder, not an input), suffix, ffmpeg, a GIF's fps: before reading anything
        check_export(export, fps, inputs=inputs)
    elif frames is not None or follow is not None or trail != "1":
        raise InvalidParameterError("--frames, --follow and --trail shape an --export; the page has its own controls")
    server = None
    if export is None:  # take the port first: a busy one is an error before the files are read
        from mocapkit.view.server import ViewServer

        server = ViewServer(None, files, port=port)
    try:
        with _progress("reading", None):
            scene = build_scene(files, segments=segments, filter_json=filter_json, asf=asf, unit_cm=unit_cm,
                                strict=strict, rate=rate,
                                columns=imu_columns(time_column, quaternion_columns, scalar_last, time_unit))
    except BaseException:
        if server is not None:
            server.server_close()
        raise
    for note in scene["notes"]:
        err.print(f"note: {note}", markup=False, highlight=False)
    if server is None:
        from mocapkit.view.export import export_scene

        out = export_scene(scene, export, fps=fps, frames=span, progress=_progress, follow=follow,
                           trail_s=trail_s)
        console.print(f"{export}: {out['frames_written']} frames at {out['fps']:g} fps, {out['bytes']:,} bytes",
                      markup=False, highlight=False)
        return
    server.publish(scene, files)
    _serve(server, no_browser)


def _serve(server, no_browser: bool) -> None:
    def _stop(signum, frame):  # SIGTERM stops as Ctrl-C does
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, _stop)
    # Ctrl-C stops the server even when the shell started it with SIGINT ignored (a background job)
    previous_int = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        print(f"serving on {server.url}", flush=True)
        err.print("press Ctrl-C to stop", highlight=False)
        if not no_browser:
            import webbrowser

            if not webbrowser.open(server.url):
                err.print(f"no browser found here: open {server.url} yourself", markup=False, highlight=False)
        server.serve_forever()
    except KeyboardInterrupt:
        err.print("stopped", highlight=False)
    finally:
        signal.signal(signal.SIGTERM, previous)
        signal.signal(signal.SIGINT, previous_int)
        server.server_close()
        sys.stdout.flush()
