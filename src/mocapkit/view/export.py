"""``mocapkit view ... --export OUT.gif|OUT.mp4``: the viewer's scene (docs/viewer.md) drawn by matplotlib
into a video, with no window: the Agg canvas only, never pyplot.

One figure holds what the page shows: the skeleton panels (bones as lines, joints coloured by their
error in cm with a colour bar scaled to the clip's bound, else its largest error), the IMU panels (per
sensor a row: a box turned by the original orientation and, right of it at the same scale, one turned by
the decoded, both in a parallel projection filling the row's height; then the angle error over time with
the bound, the keyframes as ticks under the time axis and a playhead), the marker panels (markers now,
trajectories, the fitted pieces and their knots; framed on the markers' box at equal aspect over the
panel's whole rectangle) and, at the bottom, the timeline with the segments, the cuts and the playhead.
The figure is built once; each output frame only moves the artists (``set_segments``, ``set_offsets``
+ ``set_3d_properties``, ``set_xdata``) before the writer grabs it. As on the page, the skeletons' axes
follow their poses (a cube of about one body, redrawn whole every frame) when a root travels more than
1.5 body heights over the exported frames (``follow``), and the markers' trajectories, fitted curves and
knots are drawn within 1 s of the time shown (``trail_s``).

Output frame ``k`` shows timeline time ``t0 + k / fps`` (clipped to the last frame); a panel shows its
last sample at or before that time. GIFs are written by matplotlib's ``PillowWriter``, MP4s by its
``FFMpegWriter`` (H.264, ``yuv420p``; ffmpeg must be installed). The writer writes a hidden temporary
file in the output's folder, renamed onto the output once complete and removed on any failure
(``KeyboardInterrupt`` included): the output is the old file or the complete new one, never a part.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import stat
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from mocapkit.errors import InvalidParameterError, MocapError, MocapFormatError
from mocapkit.view.export_figure import DPI, GifPalette, SceneFigure
from mocapkit.view.export_panels import BG, _field, _times

FORMATS = {".gif": "gif", ".mp4": "mp4"}
MAX_GIF_BYTES = 1 << 30
"""The GIF writer keeps every frame (one byte a pixel) until the end: larger exports are refused."""

_SIZE_RANGE = (64, 7680)
_FPS_RANGE = (0.1, 240.0)


# --- checks done before any work ---------------------------------------------------------------------

def _fmt_of(out: Path) -> str:
    fmt = FORMATS.get(out.suffix.lower())
    if fmt is None:
        raise InvalidParameterError(f"--export {out}: unknown video format {out.suffix or '(no suffix)'!r}; "
                                    "give a .gif or .mp4 file name")
    return fmt


def _check_out(out: Path, inputs) -> tuple[str, os.stat_result | None]:
    """The final file to replace (symlinks followed) and its stat, or an error naming ``out`` (its folder
    missing or not writable, a folder, an input file, inside an input folder...)."""
    from mocapkit.io.atomic import check_output
    from mocapkit.io.loaders import inputs_with_companions

    check_output(out, inputs_with_companions(inputs), option="--export")
    try:
        st = os.stat(out)
    except FileNotFoundError:
        st = None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise InvalidParameterError(f"--export {out}: is not a regular file; a video is written to a file")
    return os.path.realpath(out), st


def _check_ffmpeg() -> str:
    from matplotlib import animation

    path = animation.FFMpegWriter.bin_path()
    found = shutil.which(path)
    if found is None:
        raise MocapError(f"--export .mp4 needs the ffmpeg program, not found (looked for {path!r}): install "
                         "ffmpeg (Debian/Ubuntu: apt install ffmpeg; macOS: brew install ffmpeg; conda: "
                         "conda install ffmpeg) or export a .gif instead")
    return found


def _check_numbers(fps: float, width_px: int, height_px: int, fmt: str) -> tuple[float, int, int]:
    try:
        fps = float(fps)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"--fps: expected a number, got {fps!r}") from None
    if not (math.isfinite(fps) and _FPS_RANGE[0] <= fps <= _FPS_RANGE[1]):
        raise InvalidParameterError(f"--fps: {fps:g} is outside [{_FPS_RANGE[0]:g}, {_FPS_RANGE[1]:g}]")
    sizes = []
    for name, v in (("width", width_px), ("height", height_px)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not _SIZE_RANGE[0] <= v <= _SIZE_RANGE[1]:
            raise InvalidParameterError(f"export {name}: expected a whole number of pixels in "
                                        f"[{_SIZE_RANGE[0]}, {_SIZE_RANGE[1]}], got {v!r}")
        if fmt == "mp4" and v % 2:
            raise InvalidParameterError(f"export {name}: {v} px is odd; H.264 (yuv420p) needs even sizes")
        sizes.append(int(v))
    return fps, sizes[0], sizes[1]


def check_export(out, fps: float = 30.0, width_px: int = 960, height_px: int = 540, inputs=()) -> None:
    """The checks :func:`export_scene` starts with (suffix, numbers, the output file, ffmpeg for an MP4, at
    most 50 fps for a GIF), for a caller to make before it reads its inputs."""
    out = Path(out)
    fmt = _fmt_of(out)
    fps, _, _ = _check_numbers(fps, width_px, height_px, fmt)
    _check_out(out, inputs)
    if fmt == "mp4":
        _check_ffmpeg()
    else:
        gif_fps(fps)


def output_times(timeline_times: np.ndarray, fps: float, frames: tuple[int, int] | None = None) -> np.ndarray:
    """The timeline time shown by each output frame: ``t[a] + k / fps`` up to ``t[b - 1]`` (``frames=(a, b)``:
    timeline frames ``a`` to ``b`` excluded, as ``--frames A:B``; the whole timeline by default)."""
    n = len(timeline_times)
    if n == 0:
        raise MocapFormatError("scene", None, "the timeline has no frame")
    if frames is None:
        a, b = 0, n
    else:
        try:
            a, b = (int(frames[0]), int(frames[1]))
        except (TypeError, ValueError, IndexError):
            raise InvalidParameterError(f"--frames: expected (first, stop), got {frames!r}") from None
        if b <= a:
            raise InvalidParameterError(f"--frames {a}:{b}: empty range (B excluded, so A < B)")
        if a < 0 or b > n:
            raise InvalidParameterError(f"--frames {a}:{b}: outside the timeline's frames 0..{n - 1} "
                                        f"(at most {n} as B)")
    t0, t1 = float(timeline_times[a]), float(timeline_times[b - 1])
    count = math.floor((t1 - t0) * fps + 1e-9) + 1
    return np.minimum(t0 + np.arange(count) / fps, t1)


def _gif_writer(fps: float, palette: GifPalette):
    from matplotlib.animation import PillowWriter

    delay_ms = round(1000 / fps)  # a whole number of hundredths (gif_fps)

    class GifWriter(PillowWriter):
        """PillowWriter keeping each frame as indices into one palette (one byte a pixel, instead of RGB
        until the end; mapping to a fixed palette is ~20x faster than a median cut per frame) and
        writing the exact frame delay (``PillowWriter`` truncates ``1000 / fps``)."""

        def grab_frame(self, **savefig_kwargs):
            super().grab_frame(**savefig_kwargs)
            frames = getattr(self, "_frames", None)
            if frames and frames[-1].mode == "RGB":
                frames[-1] = palette.quantize(frames[-1])

        def finish(self):
            self._frames[0].save(self.outfile, save_all=True, append_images=self._frames[1:],
                                 duration=delay_ms, loop=0)

    return GifWriter(fps=fps)  # type: ignore[arg-type]  # matplotlib's stubs say int; a GIF's rate is 100/k


def gif_fps(fps: float) -> float:
    """The frame rate a GIF can hold nearest ``fps``: its frame delays are whole hundredths of a second
    (30 -> 100/3 = 33.3 fps); players slow down delays under 2 hundredths, so at most 50 fps."""
    if fps > 50:
        raise InvalidParameterError(f"--fps {fps:g}: a GIF holds at most 50 frames a second (its frame delays are "
                                    "hundredths of a second and players slow down shorter ones); export an .mp4")
    return 100.0 / max(2, round(100.0 / fps))


def _mp4_writer(fps: float):
    from matplotlib.animation import FFMpegWriter

    return FFMpegWriter(fps=fps, codec="h264", bitrate=-1,  # type: ignore[arg-type]  # stubs: int; ffmpeg takes any
                        extra_args=["-pix_fmt", "yuv420p", "-crf", "20", "-preset", "medium"])


def _abort(writer) -> None:
    """Stop a writer after a failure without finishing its file (ffmpeg is killed, not waited for)."""
    proc = getattr(writer, "_proc", None)
    if proc is not None:
        with contextlib.suppress(Exception):
            proc.kill()
        with contextlib.suppress(Exception):
            proc.communicate(timeout=10)


def _finish(writer, out: Path) -> None:
    try:
        writer.finish()
    except subprocess.CalledProcessError as e:
        err = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else str(e.stderr or "")
        last = err.strip().splitlines()[-1] if err.strip() else f"exit status {e.returncode}"
        raise MocapError(f"--export {out}: ffmpeg failed: {last}") from None


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _check_view(follow, trail_s) -> float | None:
    if follow not in (None, True, False):
        raise InvalidParameterError(f"export follow: expected True, False or None (automatic), got {follow!r}")
    if trail_s is None:
        return None
    try:
        trail_s = float(trail_s)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"export trail: expected seconds or None (all), got {trail_s!r}") from None
    if not (math.isfinite(trail_s) and trail_s > 0):
        raise InvalidParameterError(f"export trail: {trail_s:g} s; expected a positive number of seconds "
                                    "(or None for the whole take)")
    return trail_s


def export_scene(scene: dict, out, *, fps: float = 30.0, width_px: int = 960, height_px: int = 540,
                 frames: tuple[int, int] | None = None, progress=None, inputs=(), follow: bool | None = None,
                 trail_s: float | None = 1.0) -> dict:
    """Draw ``scene`` (docs/viewer.md) into the video ``out`` (``.gif`` or ``.mp4``).

    Parameters
    ----------
    scene
        The dict of :func:`mocapkit.view.scene.build_scene` (its arrays as ``encode_array`` objects).
    out
        The video to write (replaced atomically; its folder must exist).
    fps
        Output frames per second; output frame ``k`` shows timeline time ``t0 + k / fps``. A GIF uses the
        nearest rate it can hold (:func:`gif_fps`: 30 -> 33.3; at most 50); the result gives the rate used.
    width_px, height_px
        The frame size in pixels (even for MP4).
    frames
        ``(first, stop)``: export timeline frames ``first`` to ``stop`` excluded; the whole timeline by default.
    progress
        ``progress(what, total)`` context-manager factory (:mod:`mocapkit.jobs.common`), updated per frame.
    inputs
        The files the scene was read from: an output that is one of them (or inside an input folder) is
        refused before any work.
    follow
        Each skeleton's axes follow its current pose (a cube of about one body around it) instead of
        holding the whole take; None (default) = as the page, when a skeleton's root travels more than 1.5
        body heights over the exported frames.
    trail_s
        Marker trajectories, fitted curves and knots are drawn within this many seconds of the time shown
        (default 1, as the page); None = over the whole take.

    Returns
    -------
    dict
        ``{"path", "frames_written", "fps", "bytes", "format"}``.

    Raises
    ------
    InvalidParameterError
        An unknown suffix, a missing output folder, an empty or out-of-range frame range, a bad size, fps,
        follow or trail.
    MocapError
        ffmpeg missing (MP4; checked before any work) or failing; a malformed scene (MocapFormatError).
    """
    from mocapkit.jobs.common import no_progress

    out = Path(out)
    fmt = _fmt_of(out)
    fps, width_px, height_px = _check_numbers(fps, width_px, height_px, fmt)
    trail_s = _check_view(follow, trail_s)
    target, old = _check_out(out, inputs)
    if fmt == "mp4":
        _check_ffmpeg()
    else:
        fps = gif_fps(fps)
    tl_times = _times(_field(scene, "timeline", "scene") if isinstance(scene, dict) else None, "timeline")
    times = output_times(tl_times, fps, frames)
    if fmt == "gif" and len(times) * width_px * height_px > MAX_GIF_BYTES:
        raise InvalidParameterError(
            f"--export {out}: {len(times)} frames of {width_px}x{height_px} would need "
            f"{len(times) * width_px * height_px / 2**30:.1f} GiB for a GIF (at most {MAX_GIF_BYTES / 2**30:g}); "
            "export an .mp4, fewer frames (frames=) or a lower fps or size")
    progress = progress or no_progress

    import matplotlib as mpl

    view = SceneFigure(scene, width_px, height_px, window=(float(times[0]), float(times[-1])), follow=follow,
                       trail_s=trail_s)
    writer = _gif_writer(fps, GifPalette(view, times)) if fmt == "gif" else _mp4_writer(fps)
    folder, base = os.path.split(target)
    tmp: str | None
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=f".tmp{out.suffix.lower()}", dir=folder or ".")
    os.close(fd)
    try:
        with mpl.rc_context({"savefig.bbox": None, "savefig.facecolor": BG, "savefig.edgecolor": BG,
                             "savefig.transparent": False, "savefig.pad_inches": 0}):
            try:
                writer.setup(view.fig, tmp, dpi=DPI)
                with progress(f"exporting {out.name}", len(times)) as update:
                    for k, t in enumerate(times):
                        view.show(float(t))
                        writer.grab_frame()
                        update(k + 1)
                _finish(writer, out)
            except BaseException:
                _abort(writer)
                raise
        os.chmod(tmp, (old.st_mode & 0o7777) if old is not None else (0o666 & ~_umask()))
        os.replace(tmp, target)
        tmp = None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    return {"path": str(out), "frames_written": len(times), "fps": fps,
            "bytes": os.stat(target).st_size, "format": fmt}
