"""The panels of the ``--export`` figure (:mod:`mocapkit.view.export_figure`), one class per panel kind of
the scene (docs/viewer.md) and the timeline: each builds its artists once on the figure and ``show(t)``
moves them to timeline time ``t`` (``set_segments``, ``set_offsets`` + ``set_3d_properties``...)."""

from __future__ import annotations

import math

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

        ax = fig.add_axes([rect[0], rect[1], rect[2] * 0.8, rect[3]],
                          projection="3d", facecolor=BG)
        _style_3d(ax, lim, fs, _field(panel, "unit", where))
        title = f"{panel.get('name', '')} — {role}"
        if max_error is not None:
            title += f"\nmax error {float(max_error):.3g} cm" + (f" (bound {float(bound):.3g})" if bound is not None else "")
        ax.set_title(title, fontsize=fs * 0.85, pad=0)
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


_BOX = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * [1.0, 0.6, 0.25]
_BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if (a ^ b).bit_count() == 1]
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
        ax = fig.add_axes(rect3d, projection="3d", facecolor=BG)
        lim = np.array([[-1.6, 1.6]] * 3)
        ax.set_xlim(*lim[0]), ax.set_ylim(*lim[1]), ax.set_zlim(*lim[2])
        ax.set_box_aspect((1, 1, 1), zoom=1.4)
        ax.view_init(elev=14, azim=-62)
        ax.set_axis_off()
        ax.set_title(str(sensor.get("name", "")), fontsize=fs * 0.75, pad=0)
        self.boxes = {}
        styles = {"original": {"colors": [ORIGINAL] * 12 + ["#d62728", "#2ca02c", "#1f77b4"],
                               "linewidths": [max(fs / 8, 1.0)] * 12 + [max(fs / 5, 1.5)] * 3},
                  "decoded": {"colors": DECODED, "linewidths": max(fs / 8, 1.0), "linestyles": "--"}}
        for key in self.mats:
            col = Line3DCollection(self._segments(key, 0), **styles[key])
            ax.add_collection3d(col)
            self.boxes[key] = col
        self.ax3d = ax

        err = _array(sensor, "error_deg", where, optional=True)
        ax2 = fig.add_axes(rect2d, facecolor=BG)
        ax2.tick_params(labelsize=fs * 0.65, pad=1)
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
        words = [w for w in words if w]
        ax2.set_title("angle error" + (f" ({', '.join(words)})" if words else "") + ", keyframes ticked",
                      fontsize=fs * 0.7, pad=2)
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
        ax = fig.add_axes(rect, projection="3d", facecolor=BG)
        _style_3d(ax, lim, fs, _field(panel, "unit", where))
        ax.set_title(f"{panel.get('name', '')} — {M} markers", fontsize=fs * 0.85, pad=0)
        step = max(1, math.ceil(n / MAX_TRACE_POINTS))
        for m in range(M):
            tr = self.pos[::step, m]
            ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], color="0.55", lw=max(fs / 16, 0.5))
            if fitted is not None and np.any(np.isfinite(fitted[:, m])):
                fc = fitted[::step, m]
                ax.plot(fc[:, 0], fc[:, 1], fc[:, 2], color=DECODED, lw=max(fs / 12, 0.8), ls="--")
        if len(knots):
            ax.scatter(knots[:, 0], knots[:, 1], knots[:, 2], marker="x", color="k", s=(fs * 0.5) ** 2,
                       depthshade=False)
        p0 = self.pos[0]
        self.markers = ax.scatter(p0[:, 0], p0[:, 1], p0[:, 2], color=ORIGINAL, s=(fs * 0.55) ** 2,
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
        self.clock.set_text(f"t = {t:8.3f} s   frame {i} / {len(self.tl)}")
