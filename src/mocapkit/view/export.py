"""``mocapkit view ... --export OUT.gif|OUT.mp4``: the viewer's scene (docs/viewer.md) drawn by matplotlib
into a video, with no window: the Agg canvas only, never pyplot.

One figure holds what the page shows: the skeleton panels (bones as lines, joints coloured by their
error in cm with a colour bar scaled to the clip's bound, else its largest error), the IMU panels (per
sensor a box turned by the original and by the decoded orientation, and the angle error over time with
the keyframes, the bound and a playhead), the marker panels (markers now, trajectories, the fitted
pieces and their knots) and, at the bottom, the timeline with the segments, the cuts and the playhead.
The figure is built once; each output frame only moves the artists (``set_segments``, ``set_offsets``
+ ``set_3d_properties``, ``set_xdata``) before the writer grabs it.

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
from mocapkit.view.arrays import decode_array

FORMATS = {".gif": "gif", ".mp4": "mp4"}
DPI = 64
"""Figure dots per inch: a power of two, so ``pixels / DPI * DPI`` is exact and the frame has the size asked."""
MAX_GIF_BYTES = 1 << 30
"""The GIF writer keeps every frame (one byte a pixel) until the end: larger exports are refused."""
MAX_TRACE_POINTS = 1500
"""Trajectories and fitted curves are drawn through at most this many samples per marker (static artists
are projected again on every frame)."""

_SIZE_RANGE = (64, 7680)
_FPS_RANGE = (0.1, 240.0)
_BG = "white"
_ORIGINAL = "#1f5fa8"
_DECODED = "#e0731a"


# --- checks done before any work ---------------------------------------------------------------------

def _fmt_of(out: Path) -> str:
    fmt = FORMATS.get(out.suffix.lower())
    if fmt is None:
        raise InvalidParameterError(f"--export {out}: unknown video format {out.suffix or '(no suffix)'!r}; "
                                    "give a .gif or .mp4 file name")
    return fmt


def _check_out(out: Path) -> tuple[str, os.stat_result | None]:
    """The final file to replace (symlinks followed) and its stat, or an error naming ``out``."""
    from mocapkit.io.atomic import check_output

    check_output(out, [], option="--export")
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


def output_times(timeline_times: np.ndarray, fps: float, frames: tuple[int, int] | None = None) -> np.ndarray:
    """The timeline time shown by each output frame: ``t[a] + k / fps`` up to ``t[b]`` (``frames=(a, b)``,
    inclusive; the whole timeline by default), clipped to ``t[b]``."""
    n = len(timeline_times)
    if n == 0:
        raise MocapFormatError("scene", None, "the timeline has no frame")
    if frames is None:
        a, b = 0, n - 1
    else:
        try:
            a, b = (int(frames[0]), int(frames[1]))
        except (TypeError, ValueError, IndexError):
            raise InvalidParameterError(f"export frames: expected (first, last), got {frames!r}") from None
        if a > b:
            raise InvalidParameterError(f"export frames {a}..{b}: empty range (the first is after the last)")
        if a < 0 or b > n - 1:
            raise InvalidParameterError(f"export frames {a}..{b}: outside the timeline's frames 0..{n - 1}")
    t0, t1 = float(timeline_times[a]), float(timeline_times[b])
    count = int(math.floor((t1 - t0) * fps + 1e-9)) + 1
    return np.minimum(t0 + np.arange(count) / fps, t1)


# --- reading the scene -----------------------------------------------------------------------------

def _field(d: dict, key: str, where: str):
    try:
        return d[key]
    except (KeyError, TypeError):
        raise MocapFormatError("scene", None, f"{where}: missing {key!r}") from None


def _array(d: dict, key: str, where: str, shape_tail: tuple = (), optional: bool = False):
    obj = _field(d, key, where)
    if obj is None:
        if optional:
            return None
        raise MocapFormatError("scene", None, f"{where}: {key!r} is null")
    a = decode_array(obj, f"scene {where}.{key}").astype(np.float64)
    if shape_tail and (a.ndim != 1 + len(shape_tail) or any(s is not None and a.shape[1 + i] != s
                                                            for i, s in enumerate(shape_tail))):
        raise MocapFormatError("scene", None, f"{where}.{key}: shape {a.shape} is not (n, {shape_tail})")
    return a


def _times(d: dict, where: str, n: int | None = None) -> np.ndarray:
    t = _array(d, "times", where)
    if t.ndim != 1 or (n is not None and len(t) != n) or len(t) == 0:
        raise MocapFormatError("scene", None, f"{where}.times: shape {t.shape} does not match its "
                                              f"{n if n is not None else 'samples'}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
        raise MocapFormatError("scene", None, f"{where}.times: not finite and non-decreasing")
    return t


def _index_at(times: np.ndarray, t: float) -> int:
    """The last sample at or before ``t`` (the first before the panel starts)."""
    return max(int(np.searchsorted(times, t, side="right")) - 1, 0)


def z_up(p: np.ndarray, up: str) -> np.ndarray:
    """Points ``(..., 3)`` of a file whose vertical axis is ``up`` in matplotlib's z-up frame: a y-up file's
    ``(x, y, z)`` is turned by +90 degrees about x to ``(x, -z, y)`` (a rotation: handedness kept)."""
    if up == "z":
        return p
    if up == "y":
        return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)
    raise MocapFormatError("scene", None, f"panel up {up!r}: expected 'y' or 'z'")


def _limits(points: np.ndarray, pad: float = 0.06) -> np.ndarray | None:
    """``(3, 2)`` axis limits around the finite points (a little margin; a flat axis gets some depth)."""
    p = points.reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) == 0:
        return None
    lo, hi = p.min(axis=0), p.max(axis=0)
    span = max(float((hi - lo).max()), 1e-9)
    half = np.maximum((hi - lo) / 2, span * 0.04) + span * pad
    mid = (lo + hi) / 2
    return np.stack([mid - half, mid + half], axis=1)


def quat_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(n, 3, 3)`` of scalar-first quaternions ``(n, 4)`` (normalised here; NaN stays NaN)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = (q[..., i] for i in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)], axis=-2)


# --- the figure ----------------------------------------------------------------------------------

def _style_3d(ax, lim: np.ndarray, fs: float, unit: str) -> None:
    from matplotlib.ticker import MaxNLocator

    ax.set_xlim(*lim[0])
    ax.set_ylim(*lim[1])
    ax.set_zlim(*lim[2])
    ax.set_box_aspect(tuple(lim[:, 1] - lim[:, 0]), zoom=1.05)
    ax.view_init(elev=14, azim=-62)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(3))
    ax.tick_params(labelsize=fs * 0.7, pad=0)
    ax.set_xlabel(unit, fontsize=fs * 0.7, labelpad=-6)


class SkeletonView:
    """One skeleton panel: a Line3DCollection of the bones and a scatter of the joints."""

    def __init__(self, fig, rect, panel: dict, lim: np.ndarray, fs: float, where: str):
        from matplotlib import colormaps
        from matplotlib.colors import Normalize
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        self.times = _times(panel, where)
        n = len(self.times)
        raw = _array(panel, "positions", where, (None, 3))
        if raw.shape[0] != n:
            raise MocapFormatError("scene", None, f"{where}.positions: {raw.shape[0]} frames for {n} times")
        self.pos = z_up(raw, _field(panel, "up", where))
        J = self.pos.shape[1]
        parents = [int(p) for p in _field(panel, "parents", where)]
        if len(parents) != J or any(not -1 <= p < J for p in parents):
            raise MocapFormatError("scene", None, f"{where}.parents: {len(parents)} parents for {J} joints")
        self.bones = np.array([(j, p) for j, p in enumerate(parents) if p >= 0], dtype=np.int64).reshape(-1, 2)
        self.error = _array(panel, "error", where, (J,), optional=True)
        if self.error is not None and self.error.shape[0] != n:
            raise MocapFormatError("scene", None, f"{where}.error: {self.error.shape[0]} frames for {n} times")
        bound, max_error = panel.get("bound"), panel.get("max_error")
        vmax = next((float(v) for v in (bound, max_error) if v is not None and float(v) > 0), 1.0)
        role = panel.get("role") or "skeleton"

        ax = fig.add_axes(rect, projection="3d", facecolor=_BG)
        _style_3d(ax, lim, fs, _field(panel, "unit", where))
        title = f"{panel.get('name', '')} — {role}"
        if max_error is not None:
            title += f"\nmax error {float(max_error):.3g} cm" + (f" (bound {float(bound):.3g})" if bound is not None else "")
        ax.set_title(title, fontsize=fs * 0.85, pad=0)
        bone_colour = _DECODED if role == "decoded" else _ORIGINAL
        self.lines = Line3DCollection(self._segments(0), colors=bone_colour, linewidths=max(fs / 6, 1.2))
        ax.add_collection3d(self.lines)
        p0 = self.pos[0]
        s = (fs * 0.55) ** 2
        if self.error is not None:
            cmap = colormaps["RdYlGn_r"].with_extremes(over="magenta", bad="0.6")
            self.norm = Normalize(0.0, vmax)
            self.joints = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], c=self.error[0], cmap=cmap, norm=self.norm,
                                     s=s, depthshade=False, edgecolors="none")
            cax = fig.add_axes([rect[0] + rect[2] * 0.9, rect[1] + rect[3] * 0.2, rect[2] * 0.025, rect[3] * 0.55])
            cb = fig.colorbar(self.joints, cax=cax, extend="max" if bound is not None else "neither")
            cb.set_label("error (cm)", fontsize=fs * 0.7)
            cb.ax.tick_params(labelsize=fs * 0.65)
        else:
            self.joints = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], color=bone_colour, s=s, depthshade=False,
                                     edgecolors="none")
        self.ax = ax

    def _segments(self, i: int) -> np.ndarray:
        p = self.pos[i]
        return np.stack([p[self.bones[:, 0]], p[self.bones[:, 1]]], axis=1)

    def artists(self) -> list:
        return [self.lines, self.joints]

    def show(self, t: float) -> None:
        i = _index_at(self.times, t)
        p = self.pos[i]
        self.lines.set_segments(self._segments(i))
        self.joints.set_offsets(p[:, :2])
        self.joints.set_3d_properties(p[:, 2], "z")
        if self.error is not None:
            self.joints.set_array(self.error[i])


_BOX = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * [1.0, 0.6, 0.25]
_BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
_TRIAD = np.array([[0, 0, 0], [1.5, 0, 0], [0, 0, 0], [0, 1.1, 0], [0, 0, 0], [0, 0, 0.8]], dtype=float)


class SensorView:
    """One IMU sensor: boxes turned by the original and decoded orientations, the angle error over time."""

    def __init__(self, fig, rect3d, rect2d, sensor: dict, up: str, window: tuple[float, float], fs: float,
                 where: str):
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        self.times = _times(sensor, where)
        n = len(self.times)
        self.up = up
        self.mats = {}
        for key in ("original", "decoded"):
            q = _array(sensor, key, where, (4,), optional=True)
            if q is not None:
                if q.shape[0] != n:
                    raise MocapFormatError("scene", None, f"{where}.{key}: {q.shape[0]} samples for {n} times")
                self.mats[key] = quat_matrices(q)
        ax = fig.add_axes(rect3d, projection="3d", facecolor=_BG)
        lim = np.array([[-1.6, 1.6]] * 3)
        ax.set_xlim(*lim[0]), ax.set_ylim(*lim[1]), ax.set_zlim(*lim[2])
        ax.set_box_aspect((1, 1, 1), zoom=1.15)
        ax.view_init(elev=14, azim=-62)
        ax.set_axis_off()
        ax.set_title(str(sensor.get("name", "")), fontsize=fs * 0.75, pad=0)
        self.boxes = {}
        styles = {"original": dict(colors=[_ORIGINAL] * 12 + ["#d62728", "#2ca02c", "#1f77b4"],
                                   linewidths=[max(fs / 8, 1.0)] * 12 + [max(fs / 5, 1.5)] * 3),
                  "decoded": dict(colors=_DECODED, linewidths=max(fs / 8, 1.0), linestyles="--")}
        for key in self.mats:
            col = Line3DCollection(self._segments(key, 0), **styles[key])
            ax.add_collection3d(col)
            self.boxes[key] = col
        self.ax3d = ax

        err = _array(sensor, "error_deg", where, optional=True)
        ax2 = fig.add_axes(rect2d, facecolor=_BG)
        ax2.tick_params(labelsize=fs * 0.65, pad=1)
        ax2.set_xlim(*window)
        ax2.set_ylabel("error (°)", fontsize=fs * 0.7, labelpad=1)
        top = 1.0
        if err is not None:
            if err.shape != (n,):
                raise MocapFormatError("scene", None, f"{where}.error_deg: shape {err.shape} for {n} times")
            ax2.plot(self.times, err, color=_DECODED, lw=max(fs / 10, 0.8))
            if np.any(np.isfinite(err)):
                top = max(top, float(np.nanmax(err)))
        bound = sensor.get("bound_deg")
        if bound is not None:
            ax2.axhline(float(bound), color="#c00000", ls="--", lw=max(fs / 10, 0.8))
            top = max(top, float(bound))
        ax2.set_ylim(0, top * 1.15)
        kf = _array(sensor, "keyframes", where, optional=True)
        if kf is not None and kf.size:
            from matplotlib.transforms import blended_transform_factory

            ax2.vlines(kf.ravel(), 0, 0.12, transform=blended_transform_factory(ax2.transData, ax2.transAxes),
                       color="k", lw=max(fs / 14, 0.6))
        self.err = err
        self.playhead = ax2.axvline(window[0], color="#d00000", lw=max(fs / 10, 1.0))
        self.ax2d = ax2

    def _segments(self, key: str, i: int) -> np.ndarray:
        R = self.mats[key][i]
        box = _BOX @ R.T
        segs = [(box[a], box[b]) for a, b in _BOX_EDGES]
        if key == "original":
            tri = _TRIAD @ R.T
            segs += [(tri[0], tri[1]), (tri[2], tri[3]), (tri[4], tri[5])]
        return z_up(np.array(segs), self.up)

    def artists(self) -> list:
        return [*self.boxes.values(), self.playhead]

    def show(self, t: float) -> None:
        i = _index_at(self.times, t)
        for key, col in self.boxes.items():
            col.set_segments(self._segments(key, i))
        self.playhead.set_xdata([t, t])


class MarkerView:
    """One marker panel: trajectories, fitted curves and knots (static), the markers now (moving)."""

    def __init__(self, fig, rect, panel: dict, fs: float, where: str):
        self.times = _times(panel, where)
        n = len(self.times)
        up = _field(panel, "up", where)
        raw = _array(panel, "positions", where, (None, 3))
        if raw.shape[0] != n:
            raise MocapFormatError("scene", None, f"{where}.positions: {raw.shape[0]} frames for {n} times")
        self.pos = z_up(raw, up)
        M = self.pos.shape[1]
        fitted = _array(panel, "fitted", where, (M, 3), optional=True)
        if fitted is not None and fitted.shape[0] != n:
            raise MocapFormatError("scene", None, f"{where}.fitted: {fitted.shape[0]} frames for {n} times")
        fitted = None if fitted is None else z_up(fitted, up)
        knots = []
        for k, kn in enumerate(panel.get("knots") or []):
            pts = np.asarray(_field(kn, "positions", f"{where}.knots[{k}]"), dtype=float).reshape(-1, 3)
            knots.append(z_up(pts, up))
        knots = np.concatenate(knots) if knots else np.zeros((0, 3))
        lim = _limits(np.concatenate([self.pos.reshape(-1, 3), knots]))
        if lim is None:
            lim = np.array([[-1.0, 1.0]] * 3)
        ax = fig.add_axes(rect, projection="3d", facecolor=_BG)
        _style_3d(ax, lim, fs, _field(panel, "unit", where))
        ax.set_title(f"{panel.get('name', '')} — {M} markers", fontsize=fs * 0.85, pad=0)
        step = max(1, math.ceil(n / MAX_TRACE_POINTS))
        for m in range(M):
            tr = self.pos[::step, m]
            ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], color="0.55", lw=max(fs / 16, 0.5))
            if fitted is not None and np.any(np.isfinite(fitted[:, m])):
                fc = fitted[::step, m]
                ax.plot(fc[:, 0], fc[:, 1], fc[:, 2], color=_DECODED, lw=max(fs / 12, 0.8), ls="--")
        if len(knots):
            ax.scatter(knots[:, 0], knots[:, 1], knots[:, 2], marker="x", color="k", s=(fs * 0.5) ** 2,
                       depthshade=False)
        p0 = self.pos[0]
        self.markers = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], color=_ORIGINAL, s=(fs * 0.55) ** 2,
                                  depthshade=False, edgecolors="none")
        self.ax = ax

    def artists(self) -> list:
        return [self.markers]

    def show(self, t: float) -> None:
        p = self.pos[_index_at(self.times, t)]
        self.markers.set_offsets(p[:, :2])
        self.markers.set_3d_properties(p[:, 2], "z")


class TimelineView:
    """The strip at the bottom: segments (labels, action letters), cuts, the playhead and the clock."""

    def __init__(self, fig, rect, scene: dict, timeline_times: np.ndarray, window: tuple[float, float], fs: float):
        ax = fig.add_axes(rect, facecolor="0.96")
        ax.set_xlim(*window)
        ax.set_ylim(0, 1)
        ax.set_yticks([])
        ax.tick_params(labelsize=fs * 0.7, pad=1)
        ax.set_xlabel("time (s)", fontsize=fs * 0.7, labelpad=1)
        seg = scene.get("segments")
        if seg:
            for k, s in enumerate(seg.get("segments") or []):
                w = f"segments[{k}]"
                t0, t1 = float(_field(s, "t0", w)), float(_field(s, "t1", w))
                ax.axvspan(t0, t1, color=("#cfe0f3", "#f6dcc4")[k % 2], lw=0)
                text = " ".join(str(v) for v in (s.get("action"), s.get("label")) if v)
                if text:
                    ax.text((t0 + t1) / 2, 0.5, text, ha="center", va="center", fontsize=fs * 0.75, clip_on=True)
            for c in seg.get("cuts") or []:
                ax.axvline(float(_field(c, "time_s", "cuts")), color="k", lw=max(fs / 8, 1.0))
        self.tl = timeline_times
        self.playhead = ax.axvline(window[0], color="#d00000", lw=max(fs / 6, 1.5))
        self.clock = ax.text(0.0, 1.08, "", transform=ax.transAxes, fontsize=fs * 0.8, va="bottom",
                             family="monospace")
        self.ax = ax

    def artists(self) -> list:
        return [self.playhead, self.clock]

    def show(self, t: float) -> None:
        self.playhead.set_xdata([t, t])
        i = _index_at(self.tl, t)
        self.clock.set_text(f"t = {t:8.3f} s   frame {i} / {len(self.tl) - 1}")


_WEIGHTS = {"skeleton": 1.0, "markers": 1.0, "imu": 1.5}


class SceneFigure:
    """The whole scene on one Agg figure of ``width_px x height_px`` pixels; ``show(t)`` moves every
    panel to timeline time ``t``. ``views`` lists the panel views in the scene's order."""

    def __init__(self, scene: dict, width_px: int, height_px: int, window: tuple[float, float] | None = None):
        from matplotlib.figure import Figure

        if not isinstance(scene, dict) or scene.get("mocapkit_view") != 1:
            raise MocapFormatError("scene", None, "not a mocapkit_view 1 scene")
        self.timeline_times = _times(_field(scene, "timeline", "scene"), "timeline")
        if window is None:
            window = (float(self.timeline_times[0]), float(self.timeline_times[-1]))
        if window[1] <= window[0]:
            window = (window[0] - 0.5, window[0] + 0.5)
        self.fig = Figure(figsize=(width_px / DPI, height_px / DPI), dpi=DPI, facecolor=_BG)
        _FrameCanvas(self.fig, self.frame)
        self._background = None
        fs = max(5.0, height_px / 48) * 72 / DPI  # points for ~1/48 of the height
        self.fs = fs
        title = str(scene.get("title", ""))
        self.fig.text(0.01, 0.985, title, fontsize=fs, va="top", ha="left", weight="bold")
        notes = [str(n) for n in scene.get("notes") or []]
        if notes:
            self.fig.text(0.99, 0.985, " · ".join(notes), fontsize=fs * 0.7, va="top", ha="right", color="0.3")
        panels = _field(scene, "panels", "scene")
        if not isinstance(panels, list):
            raise MocapFormatError("scene", None, "panels: expected a list")
        kinds = []
        for i, p in enumerate(panels):
            kind = _field(p, "kind", f"panels[{i}]")
            if kind not in _WEIGHTS:
                raise MocapFormatError("scene", None, f"panels[{i}]: unknown kind {kind!r}")
            kinds.append(kind)
        sk_lim = self._skeleton_limits(panels)
        y0, y1 = 0.20, 0.90
        total = sum(_WEIGHTS[k] for k in kinds) or 1.0
        x = 0.01
        self.views = []
        for i, (p, kind) in enumerate(zip(panels, kinds)):
            w = 0.98 * _WEIGHTS[kind] / total
            where = f"panel {p.get('id', i)}"
            if kind == "skeleton":
                self.views.append(SkeletonView(self.fig, [x, y0, w, y1 - y0], p, sk_lim, fs, where))
            elif kind == "markers":
                self.views.append(MarkerView(self.fig, [x, y0, w, y1 - y0], p, fs, where))
            else:
                self.views.extend(self._imu(p, x, w, y0, y1, window, fs, where))
            x += w
        self.timeline = TimelineView(self.fig, [0.05, 0.07, 0.9, 0.06], scene, self.timeline_times, window, fs)
        self.views.append(self.timeline)
        self.moving = [a for v in self.views for a in v.artists()]  # left out of the background

    @staticmethod
    def _skeleton_limits(panels: list) -> np.ndarray:
        """Shared limits of every skeleton panel (the same scale side by side)."""
        pts = []
        for i, p in enumerate(panels):
            if p.get("kind") == "skeleton":
                where = f"panel {p.get('id', i)}"
                pts.append(z_up(_array(p, "positions", where, (None, 3)), _field(p, "up", where)).reshape(-1, 3))
        lim = _limits(np.concatenate(pts)) if pts else None
        return lim if lim is not None else np.array([[-1.0, 1.0]] * 3)

    def _imu(self, p, x, w, y0, y1, window, fs, where) -> list:
        sensors = _field(p, "sensors", where)
        up = _field(p, "up", where)
        n = max(len(sensors), 1)
        h = (y1 - y0) / n
        views = []
        for k, s in enumerate(sensors):
            top = y1 - k * h
            r3 = [x, top - h, w * 0.34, h * 0.92]
            r2 = [x + w * 0.42, top - h + h * 0.18, w * 0.55, h * 0.62]
            views.append(SensorView(self.fig, r3, r2, s, up, window, fs, f"{where}.sensors[{k}]"))
        return views

    def show(self, t: float) -> None:
        for v in self.views:
            v.show(t)

    def frame(self) -> memoryview:
        """The figure now, as the canvas's RGBA buffer: the static background (drawn once: panes, grids,
        ticks, titles, colour bars, trajectories, segments) restored, then only the moving artists drawn."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        canvas = self.fig.canvas
        if self._background is None:
            for a in self.moving:
                a.set_visible(False)
            try:
                FigureCanvasAgg.draw(canvas)  # also sets each 3-D axes' projection, used below
            finally:
                for a in self.moving:
                    a.set_visible(True)
            self._background = canvas.copy_from_bbox(self.fig.bbox)
        else:
            canvas.restore_region(self._background)
        renderer = canvas.get_renderer()
        for a in self.moving:
            if hasattr(a, "do_3d_projection"):
                a.do_3d_projection()
            a.draw(renderer)
        return renderer.buffer_rgba()

    def render(self) -> np.ndarray:
        """The frame as written, ``(height, width, 4)`` uint8 RGBA (a copy)."""
        return np.asarray(self.frame()).copy()

    def render_full(self) -> np.ndarray:
        """The same picture drawn the plain way (every artist, no background reuse): the reference
        :meth:`frame` is checked against."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg.draw(self.fig.canvas)
        return np.asarray(self.fig.canvas.buffer_rgba()).copy()


# --- writing -------------------------------------------------------------------------------------

def _canvas_class():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    class FrameCanvas(FigureCanvasAgg):
        """An Agg canvas whose raw/RGBA output (what the movie writers' ``grab_frame`` asks ``savefig``
        for) is :meth:`SceneFigure.frame`: the background reused, only the moving artists drawn."""

        def __init__(self, figure, frame):
            super().__init__(figure)
            self._frame = frame

        def print_raw(self, filename_or_obj, *, metadata=None, **_ignored):  # facecolor...: the figure's own
            data = self._frame()
            if hasattr(filename_or_obj, "write"):
                filename_or_obj.write(data)
            else:
                with open(filename_or_obj, "wb") as fh:
                    fh.write(data)

        print_rgba = print_raw

    return FrameCanvas


def _FrameCanvas(figure, frame):
    return _canvas_class()(figure, frame)


def _gif_writer(fps: float):
    from matplotlib.animation import PillowWriter
    from PIL import Image

    class GifWriter(PillowWriter):
        """PillowWriter keeping each frame as 256 colours (one byte a pixel) instead of RGB: the palette
        conversion Pillow's GIF encoder does anyway, done as frames arrive."""

        def grab_frame(self, **savefig_kwargs):
            super().grab_frame(**savefig_kwargs)
            frames = getattr(self, "_frames", None)
            if frames and frames[-1].mode == "RGB":
                frames[-1] = frames[-1].convert("P", palette=Image.Palette.ADAPTIVE, colors=256)

    return GifWriter(fps=fps)


def _mp4_writer(fps: float):
    from matplotlib.animation import FFMpegWriter

    return FFMpegWriter(fps=fps, codec="h264", bitrate=-1,
                        extra_args=["-pix_fmt", "yuv420p", "-crf", "20", "-preset", "medium"])


def _abort(writer) -> None:
    """Stop a writer after a failure without finishing its file (ffmpeg is killed, not waited for)."""
    proc = getattr(writer, "_proc", None)
    if proc is not None:
        with contextlib.suppress(Exception):
            proc.kill()
        with contextlib.suppress(Exception):
            proc.communicate(timeout=10)


def _finish(writer, fmt: str, out: Path) -> None:
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


def export_scene(scene: dict, out, *, fps: float = 30.0, width_px: int = 960, height_px: int = 540,
                 frames: tuple[int, int] | None = None, progress=None) -> dict:
    """Draw ``scene`` (docs/viewer.md) into the video ``out`` (``.gif`` or ``.mp4``).

    Parameters
    ----------
    scene
        The dict of :func:`mocapkit.view.scene.build_scene` (its arrays as ``encode_array`` objects).
    out
        The video to write (replaced atomically; its folder must exist).
    fps
        Output frames per second; output frame ``k`` shows timeline time ``t0 + k / fps``.
    width_px, height_px
        The frame size in pixels (even for MP4).
    frames
        ``(first, last)`` timeline frames to export (inclusive); the whole timeline by default.
    progress
        ``progress(what, total)`` context-manager factory (:mod:`mocapkit.jobs.common`), updated per frame.

    Returns
    -------
    dict
        ``{"path", "frames_written", "fps", "bytes", "format"}``.

    Raises
    ------
    InvalidParameterError
        An unknown suffix, a missing output folder, an empty or out-of-range frame range, a bad size or fps.
    MocapError
        ffmpeg missing (MP4; checked before any work) or failing; a malformed scene (MocapFormatError).
    """
    from mocapkit.jobs.common import no_progress

    out = Path(out)
    fmt = _fmt_of(out)
    fps, width_px, height_px = _check_numbers(fps, width_px, height_px, fmt)
    target, old = _check_out(out)
    if fmt == "mp4":
        _check_ffmpeg()
    tl_times = _times(_field(scene, "timeline", "scene") if isinstance(scene, dict) else None, "timeline")
    times = output_times(tl_times, fps, frames)
    if fmt == "gif" and len(times) * width_px * height_px > MAX_GIF_BYTES:
        raise InvalidParameterError(
            f"--export {out}: {len(times)} frames of {width_px}x{height_px} would need "
            f"{len(times) * width_px * height_px / 2**30:.1f} GiB for a GIF (at most {MAX_GIF_BYTES / 2**30:g}); "
            "export an .mp4, fewer frames (frames=) or a lower fps or size")
    progress = progress or no_progress

    import matplotlib as mpl

    view = SceneFigure(scene, width_px, height_px, window=(float(times[0]), float(times[-1])))
    writer = _gif_writer(fps) if fmt == "gif" else _mp4_writer(fps)
    folder, base = os.path.split(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=f".tmp{out.suffix.lower()}", dir=folder or ".")
    os.close(fd)
    try:
        with mpl.rc_context({"savefig.bbox": None, "savefig.facecolor": _BG, "savefig.edgecolor": _BG,
                             "savefig.transparent": False, "savefig.pad_inches": 0}):
            writer.setup(view.fig, tmp, dpi=DPI)
            try:
                with progress(f"exporting {out.name}", len(times)) as update:
                    for k, t in enumerate(times):
                        view.show(float(t))
                        writer.grab_frame()
                        update(k + 1)
            except BaseException:
                _abort(writer)
                raise
            _finish(writer, fmt, out)
        os.chmod(tmp, (old.st_mode & 0o7777) if old is not None else (0o666 & ~_umask()))
        os.replace(tmp, target)
        tmp = None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    return {"path": str(out), "frames_written": int(len(times)), "fps": fps,
            "bytes": os.stat(target).st_size, "format": fmt}
