"""The panels of the ``--export`` figure (:mod:`mocapkit.view.export_figure`), one class per panel kind of
the scene (docs/viewer.md) and the timeline: each builds its artists once on the figure and ``show(t)``
moves them to timeline time ``t`` (``set_segments``, ``set_offsets`` + ``set_3d_properties``...)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.view.arrays import decode_array

MAX_TRACE_POINTS = 1500
"""Trajectories and fitted curves are drawn through at most this many samples per marker (static artists
are projected again on every frame)."""
BG = "white"
ORIGINAL = "#1f5fa8"
DECODED = "#e0731a"


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
        raise MocapFormatError("scene", None, f"{where}.times: must be finite and non-decreasing")
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
    p: np.ndarray = points.reshape(-1, 3)
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


def fit_view(ax, points: np.ndarray, pad_px: float = 0.0, fill: bool = False) -> None:
    """Frame the 3-D axes ``ax`` on ``points`` (k, 3): its 2-D view (the projected plane's limits, square
    units: equal aspect kept) set to the points' projected extent plus ``pad_px`` pixels each side, centred.
    ``fill``: the axes keeps its whole rectangle instead of mplot3d's square inside it (the view widened
    to match), so a wide or tall panel is used whole. Call after the limits, box aspect, view angles and
    projection type are set."""
    from mpl_toolkits.mplot3d import proj3d

    fig = ax.get_figure()
    pos = ax.get_position(original=True)
    w_px, h_px = pos.width * fig.bbox.width, pos.height * fig.bbox.height
    if fill:
        ax.apply_aspect = lambda position=None: ax._set_position(
            position if position is not None else ax.get_position(original=True), "active")
    else:
        w_px = h_px = min(w_px, h_px)
    p = points[np.all(np.isfinite(points), axis=1)]
    if len(p) == 0 or w_px <= 2 * pad_px + 2 or h_px <= 2 * pad_px + 2:
        return
    x, y, _ = proj3d.proj_transform(p[:, 0], p[:, 1], p[:, 2], ax.get_proj())
    cx, cy = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
    # units per pixel: the larger of what the extent needs across and up the room left after the pads
    scale = max(float(np.ptp(x)) / (w_px - 2 * pad_px), float(np.ptp(y)) / (h_px - 2 * pad_px), 1e-12)
    ax.viewLim.intervalx = (cx - scale * w_px / 2, cx + scale * w_px / 2)
    ax.viewLim.intervaly = (cy - scale * h_px / 2, cy + scale * h_px / 2)


def _box_corners(lim: np.ndarray) -> np.ndarray:
    """The 8 corners ``(8, 3)`` of the box of axis limits ``lim`` (3, 2)."""
    return np.array([[lim[0, i], lim[1, j], lim[2, k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def _nice_step(x: float) -> float:
    """1, 2 or 5 times a power of ten, the nearest to ``x`` (> 0) in ratio."""
    p = 10.0 ** math.floor(math.log10(x))
    return min((m * p for m in (1, 2, 5, 10)), key=lambda v: abs(math.log(v / x)))


def _follow_style(ax, lim: np.ndarray, fs: float) -> float:
    """Style a followed skeleton's axes (a cube moving with the pose): panes and a grid of fixed world
    cells that scroll as the body travels, no tick numbers (they would change every frame and cost a text
    layout each). Returns the grid cell."""
    from matplotlib.ticker import MultipleLocator, NullFormatter

    _style_3d(ax, lim, fs, "")
    cell = _nice_step(float(lim[0, 1] - lim[0, 0]) / 3)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MultipleLocator(cell))
        axis.set_major_formatter(NullFormatter())
    return cell


class SkeletonView:
    """One skeleton panel: a Line3DCollection of the bones and a scatter of the joints."""

    def __init__(self, fig, rect, panel: dict, lim: np.ndarray, fs: float, where: str,
                 follow_half: float | None = None):
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
        self.parents = parents
        self.follow_half = follow_half
        self.centre: np.ndarray | None = None  # the followed pose's centre now (follow only)
        self.bones = np.array([(j, p) for j, p in enumerate(parents) if p >= 0], dtype=np.int64).reshape(-1, 2)
        self.error = _array(panel, "error", where, (J,), optional=True)
        if self.error is not None and self.error.shape[0] != n:
            raise MocapFormatError("scene", None, f"{where}.error: {self.error.shape[0]} frames for {n} times")
        bound, max_error = panel.get("bound"), panel.get("max_error")
        vmax = next((float(v) for v in (bound, max_error) if v is not None and float(v) > 0), 1.0)
        role = panel.get("role") or "skeleton"

        ax = fig.add_axes([rect[0], rect[1], rect[2] * 0.8, rect[3]],
                          projection="3d", facecolor=BG)
        unit = _field(panel, "unit", where)
        title = f"{panel.get('name', '')} — {role}"
        if max_error is not None:
            title += f"\nmax error {float(max_error):.3g} cm" + (
                f" (bound {float(bound):.3g})" if bound is not None else ""
            )
        if follow_half is None:
            _style_3d(ax, lim, fs, unit)
            ax.set_title(title, fontsize=fs * 0.85, pad=0)
        else:
            self.centre = _pose_centre(self.pos[0])
            if self.centre is None:
                self.centre = np.zeros(3)
            cell = _follow_style(ax, self.centre[:, None] + [-follow_half, follow_half], fs)
            # the title in the figure, not the axes, so that it stays in the background (drawn once)
            fig.text(rect[0] + rect[2] * 0.4, rect[1] + rect[3], f"{title}\nfollowed; grid {cell:g} {unit}",
                     fontsize=fs * 0.85, ha="center", va="bottom")
        bone_colour = DECODED if role == "decoded" else ORIGINAL
        self.lines = Line3DCollection(self._segments(0), colors=bone_colour, linewidths=max(fs / 6, 1.2))
        ax.add_collection3d(self.lines)
        p0 = self.pos[0]
        s = (fs * 0.55) ** 2
        if self.error is not None:
            cmap = colormaps["RdYlGn_r"].with_extremes(over="magenta", bad="0.6")
            self.norm = Normalize(0.0, vmax)
            self.joints = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], c=self.error[0], cmap=cmap, norm=self.norm,
                                     s=s, depthshade=False, edgecolors="none")
            cax = fig.add_axes([rect[0] + rect[2] * 0.89, rect[1] + rect[3] * 0.2, rect[2] * 0.025, rect[3] * 0.55])
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
        if self.follow_half is not None:
            centre = _pose_centre(p)
            if centre is not None:  # no joint drawn: the limits stay where they were
                self.centre = centre
            h = self.follow_half
            assert self.centre is not None  # set in __init__ whenever follow_half is
            self.ax.set_xlim(self.centre[0] - h, self.centre[0] + h)
            self.ax.set_ylim(self.centre[1] - h, self.centre[1] + h)
            self.ax.set_zlim(self.centre[2] - h, self.centre[2] + h)


def _pose_centre(p: np.ndarray) -> np.ndarray | None:
    """Centre of the box of the finite joints ``(J, 3)`` (None if none is finite)."""
    p = p[np.all(np.isfinite(p), axis=1)]
    return None if len(p) == 0 else (p.min(axis=0) + p.max(axis=0)) / 2


def body_measures(pos: np.ndarray, parents: list[int], first: int = 0, stop: int | None = None) -> dict:
    """The page's sizes of a skeleton (static/skeleton.js ``measure``) over samples ``first:stop`` of its
    z-up positions ``(n, J, 3)``: ``height``, the median over frames (every ``n // 500``-th) of the joints'
    vertical extent; ``size``, the median diagonal of a frame's box of joints; ``travel``, the diagonal
    of the horizontal box of the root joint's path (every frame). Medians are the upper middle value."""
    pos = pos[first:stop]
    n = len(pos)
    step = max(1, n // 500)
    heights, sizes = [], []
    for p in pos[::step]:
        p = p[np.all(np.isfinite(p), axis=1)]
        if len(p):
            lo, hi = p.min(axis=0), p.max(axis=0)
            heights.append(hi[2] - lo[2])
            sizes.append(float(np.linalg.norm(hi - lo)))

    def median(v):
        return float(sorted(v)[len(v) >> 1]) if v else 0.0

    root = parents.index(-1) if -1 in parents else 0
    path = pos[:, root, :2] if n else np.zeros((0, 2))
    path = path[np.all(np.isfinite(path), axis=1)]
    travel = float(np.hypot(*(path.max(axis=0) - path.min(axis=0)))) if len(path) else 0.0
    return {"height": median(heights), "size": median(sizes), "travel": travel}


_BOX = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * [1.0, 0.6, 0.25]
_BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if (a ^ b).bit_count() == 1]
_TRIAD = np.array([[0, 0, 0], [1.2, 0, 0], [0, 0, 0], [0, 0.85, 0], [0, 0, 0], [0, 0, 0.6]], dtype=float)
_REACH = 1.2
"""The farthest a box's or triad's point gets from its centre (a box corner, 1.19; the x arrow), whatever
the turn: the squares are framed on a sphere of this radius."""
KEYFRAME = "#8e24aa"
"""The keyframe ticks' colour (apart from the error curve's orange and the bound's and playhead's red)."""


def _sphere(r: float, k: int = 24) -> np.ndarray:
    """Points on a sphere of radius ``r`` (``k`` by ``k`` angles): what a turning body may reach."""
    u, v = np.meshgrid(np.linspace(0, np.pi, k), np.linspace(0, 2 * np.pi, 2 * k))
    return r * np.c_[(np.sin(u) * np.cos(v)).ravel(), (np.sin(u) * np.sin(v)).ravel(), np.cos(u).ravel()]


class SensorView:
    """One IMU sensor: a box turned by the original orientation (left) and one by the decoded (right), in
    two square axes of the same size and scale (parallel projection, as the page), and the angle error over
    time with the bound, the keyframes as ticks under the time axis and a playhead."""

    def __init__(self, fig, rects3d: dict, rect2d, sensor: dict, up: str, window: tuple[float, float], fs: float,
                 where: str, time_labels: bool = True):
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
        triad: dict[str, list[Any]]
        triad = {"colors": ["#d62728", "#2ca02c", "#1f77b4"], "linewidths": [max(fs / 5, 1.5)] * 3,
                 "linestyles": ["-"] * 3}
        styles: dict[str, dict[str, list[Any]]]
        styles = {"original": {"colors": [ORIGINAL] * 12, "linewidths": [max(fs / 7, 1.2)] * 12,
                               "linestyles": ["-"] * 12},
                  "decoded": {"colors": [DECODED] * 12, "linewidths": [max(fs / 7, 1.2)] * 12,
                              "linestyles": ["--"] * 12}}
        self.axes3d, self.boxes = {}, {}
        for key in ("original", "decoded"):
            ax = fig.add_axes(rects3d[key], projection="3d", facecolor=BG)
            ax.set_xlim(-_REACH, _REACH), ax.set_ylim(-_REACH, _REACH), ax.set_zlim(-_REACH, _REACH)
            ax.set_box_aspect((1, 1, 1))
            ax.view_init(elev=14, azim=-62)
            ax.set_proj_type("ortho")
            ax.set_axis_off()
            # the reach's sphere filling the square but for half the widest line and a pixel (never clipped)
            fit_view(ax, _sphere(_REACH), pad_px=max(fs / 5, 1.5) * fig.dpi / 72 / 2 + 1)
            self.axes3d[key] = ax
            if key in self.mats:
                style = {k: v + triad[k] for k, v in styles[key].items()}
                col = Line3DCollection(self._segments(key, 0), **style)
                ax.add_collection3d(col)
                self.boxes[key] = col
        self.ax3d = self.axes3d["original"]

        err = _array(sensor, "error_deg", where, optional=True)
        ax2 = fig.add_axes(rect2d, facecolor=BG)
        ax2.set_xlim(*window)
        ax2.set_ylabel("error (°)", fontsize=fs * 0.7, labelpad=1)
        top = 1.0
        if err is not None:
            if err.shape != (n,):
                raise MocapFormatError("scene", None, f"{where}.error_deg: shape {err.shape} for {n} times")
            ax2.plot(self.times, err, color=DECODED, lw=max(fs / 10, 0.8))
            if np.any(np.isfinite(err)):
                top = max(top, float(np.nanmax(err)))
        bound = sensor.get("bound_deg")
        if bound is not None:
            ax2.axhline(float(bound), color="#c00000", ls="--", lw=max(fs / 10, 0.8))
            top = max(top, float(bound))
        words = [f"bound {float(bound):.3g}°" if bound is not None else None,
                 f"max {float(sensor['max_error_deg']):.3g}°" if sensor.get("max_error_deg") is not None else None]
        said = [w for w in words if w]
        kf = _array(sensor, "keyframes", where, optional=True)
        kf = kf.ravel() if kf is not None else np.zeros(0)
        ax2.set_title(f"{sensor.get('name', '')}: angle error" + (f" ({', '.join(said)})" if said else "")
                      + (f", {len(kf)} keyframes (purple ticks)" if len(kf) else ""), fontsize=fs * 0.7, pad=2)
        ax2.set_ylim(0, top * 1.15)
        # keyframes: short ticks hanging under the time axis (a fixed length in points, whatever the row's
        # height); the axis's own ticks point inwards and its numbers sit below the keyframe ticks
        self.kf_len = max(fs * 0.5, 4.0)  # points
        ax2.tick_params(labelsize=fs * 0.65, pad=1)
        ax2.tick_params(axis="x", direction="in", pad=self.kf_len + 1, labelbottom=time_labels)
        self.keyframes = None
        shown = kf[(kf >= window[0]) & (kf <= window[1])]  # unclipped ticks: only those of the exported window
        if len(shown):
            self.keyframes, = ax2.plot(shown, np.zeros(len(shown)), ls="none", marker=3, markersize=self.kf_len,
                                       markeredgewidth=max(fs / 8, 1.2), color=KEYFRAME, clip_on=False)
        self.err = err
        self.playhead = ax2.axvline(window[0], color="#d00000", lw=max(fs / 10, 1.0))
        self.ax2d = ax2

    def _segments(self, key: str, i: int) -> np.ndarray:
        R = self.mats[key][i]
        box = _BOX @ R.T
        tri = _TRIAD @ R.T
        segs = [(box[a], box[b]) for a, b in _BOX_EDGES] + [(tri[0], tri[1]), (tri[2], tri[3]), (tri[4], tri[5])]
        return z_up(np.array(segs), self.up)

    def artists(self) -> list:
        return [*self.boxes.values(), self.playhead]

    def show(self, t: float) -> None:
        i = _index_at(self.times, t)
        for key, col in self.boxes.items():
            col.set_segments(self._segments(key, i))
        self.playhead.set_xdata([t, t])


class MarkerView:
    """One marker panel: the markers now, their trajectories, fitted curves and knots; those three within
    ``trail_s`` seconds of the time shown (moving artists, as the page's trail), or over the whole take
    when ``trail_s`` is None (static, drawn once)."""

    def __init__(self, fig, rect, panel: dict, fs: float, where: str, trail_s: float | None = None):
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
        knot_list: list[np.ndarray] = []
        time_list: list[np.ndarray] = []
        for k, kn in enumerate(panel.get("knots") or []):
            w = f"{where}.knots[{k}]"
            pts = np.asarray(_field(kn, "positions", w), dtype=float).reshape(-1, 3)
            kt = np.asarray(_field(kn, "times", w), dtype=float).reshape(-1)
            if len(kt) != len(pts):
                raise MocapFormatError("scene", None, f"{w}: {len(kt)} times for {len(pts)} positions")
            knot_list.append(z_up(pts, up))
            time_list.append(kt)
        knots = np.concatenate(knot_list) if knot_list else np.zeros((0, 3))
        knot_times = np.concatenate(time_list) if time_list else np.zeros(0)
        order = np.argsort(knot_times, kind="stable")
        self.knot_pos, self.knot_times = knots[order], knot_times[order]
        lim = _limits(np.concatenate([self.pos.reshape(-1, 3), knots]), pad=0.02)  # a small margin
        if lim is None:
            lim = np.array([[-1.0, 1.0]] * 3)
        ax = fig.add_axes(rect, projection="3d", facecolor=BG)
        _style_3d(ax, lim, fs, _field(panel, "unit", where))
        # framed on the markers' box (equal aspect) over the whole panel, room left for the tick numbers
        fit_view(ax, _box_corners(lim), pad_px=fs * 2.0, fill=True)
        ax.set_title(f"{panel.get('name', '')} — {M} markers", fontsize=fs * 0.85, pad=0)
        self.trail_s = trail_s
        self.fitted = fitted
        fit_marker = [fitted is not None and bool(np.any(np.isfinite(fitted[:, m]))) for m in range(M)]
        trace = {"color": "0.55", "lw": max(fs / 16, 0.5)}
        curve = {"color": DECODED, "lw": max(fs / 12, 0.8), "ls": "--"}
        knot_style = {"marker": "x", "color": "k", "s": (fs * 0.5) ** 2, "depthshade": False}
        self.traces, self.curves, self.knots = [], [], None
        if trail_s is None:  # the whole take, drawn once into the background
            step = max(1, math.ceil(n / MAX_TRACE_POINTS))
            for m in range(M):
                tr = self.pos[::step, m]
                ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], **trace)
                if fitted is not None and fit_marker[m]:
                    fc = fitted[::step, m]
                    ax.plot(fc[:, 0], fc[:, 1], fc[:, 2], **curve)
            if len(knots):
                ax.scatter(knots[:, 0], knots[:, 1], knots[:, 2], **knot_style)
        else:
            # a sample step fixed for the take (the most samples any window holds), on fixed sample indices
            most = int((np.searchsorted(self.times, self.times + 2 * trail_s, side="right") - np.arange(n)).max())
            self.step = max(1, math.ceil(most / MAX_TRACE_POINTS))
            self.traces = [ax.plot([], [], [], **trace)[0] for m in range(M)]
            self.curves = [(m, ax.plot([], [], [], **curve)[0]) for m in range(M) if fit_marker[m]]
            if len(knots):
                self.knots = ax.scatter(knots[:, 0], knots[:, 1], knots[:, 2], **knot_style)
        p0 = self.pos[0]
        self.markers = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], color=ORIGINAL, s=(fs * 0.55) ** 2,
                                  depthshade=False, edgecolors="none")
        self.ax = ax

    def artists(self) -> list:
        knots = [] if self.knots is None else [self.knots]
        return [*self.traces, *(c for _, c in self.curves), *knots, self.markers]

    def trail_range(self, t: float) -> tuple[int, int]:
        """Samples ``[a, b)`` of the trail at time ``t``: those within ``trail_s`` of it (all for None)."""
        if self.trail_s is None:
            return 0, len(self.times)
        return (int(np.searchsorted(self.times, t - self.trail_s, side="left")),
                int(np.searchsorted(self.times, t + self.trail_s, side="right")))

    def show(self, t: float) -> None:
        p = self.pos[_index_at(self.times, t)]
        self.markers.set_offsets(p[:, :2])
        self.markers.set_3d_properties(p[:, 2], "z")
        if self.trail_s is None:
            return
        a, b = self.trail_range(t)
        s = self.step
        idx = np.arange(-(-a // s) * s, b, s)  # multiples of the step in [a, b), with the window's ends
        if b > a:
            idx = np.unique(np.concatenate([[a], idx, [b - 1]]))
        for m, line in enumerate(self.traces):
            _set_polyline(line, self.pos[idx, m])
        if self.fitted is not None:  # the curves of the fitted markers
            for m, line in self.curves:
                _set_polyline(line, self.fitted[idx, m])
        if self.knots is not None:
            k0 = int(np.searchsorted(self.knot_times, t - self.trail_s, side="left"))
            k1 = int(np.searchsorted(self.knot_times, t + self.trail_s, side="right"))
            q = self.knot_pos[k0:k1]
            self.knots.set_offsets(q[:, :2])
            self.knots.set_3d_properties(q[:, 2], "z")


def _set_polyline(line, q: np.ndarray) -> None:
    """Give a 3-D line the points ``q`` (k, 3), NaN breaking it; leading and trailing missing points are
    left out (they draw nothing, and matplotlib looks for the first finite value one point at a time)."""
    ok = np.nonzero(np.all(np.isfinite(q), axis=1))[0]
    q = q[ok[0]:ok[-1] + 1] if len(ok) else q[:0]
    line.set_data_3d(q[:, 0], q[:, 1], q[:, 2])


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
        self.clock.set_text(f"t = {t:8.3f} s   frame {i} / {len(self.tl)}")
