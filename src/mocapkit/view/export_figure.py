"""The whole ``--export`` picture: the scene's panels (:mod:`mocapkit.view.export_panels`) laid out on one
Agg figure, drawn fast (the static background once, the moving artists per frame), and the single
palette a GIF is written with."""

from __future__ import annotations

import numpy as np

from mocapkit.errors import MocapFormatError
from mocapkit.view.export_panels import (
    BG,
    DECODED,
    ORIGINAL,
    MarkerView,
    SensorView,
    SkeletonView,
    TimelineView,
    _array,
    _field,
    _index_at,
    _limits,
    _times,
    body_measures,
    z_up,
)

DPI = 64
"""Figure dots per inch: a power of two, so ``pixels / DPI * DPI`` is exact and the frame has the size asked."""


_WEIGHTS = {"skeleton": 1.0, "markers": 1.0, "imu": 1.5}
FOLLOW_TRAVEL = 1.5
"""Follow by default when a skeleton's root travels more than this many body heights (static/viewer.js)."""
FOLLOW_HALF = 0.45
"""A followed skeleton's axes are a cube of this many body sizes (a frame's joint-box diagonal) each side
of its pose's centre."""


class SceneFigure:
    """The whole scene on one Agg figure of ``width_px x height_px`` pixels; ``show(t)`` moves every
    panel to timeline time ``t``. ``views`` lists the panel views in the scene's order.

    ``window`` is the timeline time span exported. ``follow``: each skeleton's axes follow its pose (a cube
    of about one body around the pose's centre, redrawn whole every frame) instead of the whole-take
    limits; None = as the page, when a skeleton's root travels more than ``FOLLOW_TRAVEL`` body heights
    over the window. ``trail_s``: marker trajectories, fitted curves and knots are drawn within this many
    seconds of the time shown; None = the whole take. ``following`` says whether the skeletons follow."""

    def __init__(self, scene: dict, width_px: int, height_px: int, window: tuple[float, float] | None = None,
                 follow: bool | None = None, trail_s: float | None = 1.0):
        from matplotlib.figure import Figure

        if not isinstance(scene, dict) or scene.get("mocapkit_view") != 1:
            raise MocapFormatError("scene", None, "not a mocapkit_view 1 scene")
        self.timeline_times = _times(_field(scene, "timeline", "scene"), "timeline")
        if window is None:
            window = (float(self.timeline_times[0]), float(self.timeline_times[-1]))
        if window[1] <= window[0]:
            window = (window[0] - 0.5, window[0] + 0.5)
        self.fig = Figure(figsize=(width_px / DPI, height_px / DPI), dpi=DPI, facecolor=BG)
        _frame_canvas(self.fig, self.frame)
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
        half = self._follow_half(panels, window, follow)
        self.following = half is not None
        y0, y1 = 0.20, 0.90
        total = sum(_WEIGHTS[k] for k in kinds) or 1.0
        x = 0.01
        self.views: list[SkeletonView | MarkerView | SensorView | TimelineView] = []
        for i, (p, kind) in enumerate(zip(panels, kinds, strict=False)):
            w = 0.98 * _WEIGHTS[kind] / total
            where = f"panel {p.get('id', i)}"
            if kind == "skeleton":
                self.views.append(SkeletonView(self.fig, [x, y0, w, y1 - y0], p, sk_lim, fs, where, half))
            elif kind == "markers":
                self.views.append(MarkerView(self.fig, [x, y0, w, y1 - y0], p, fs, where, trail_s))
            else:
                self.views.extend(self._imu(p, x, w, y0, y1, window, fs, where))
            x += w
        self.timeline = TimelineView(self.fig, [0.05, 0.07, 0.9, 0.06], scene, self.timeline_times, window, fs)
        self.views.append(self.timeline)
        self.moving = [a for v in self.views for a in v.artists()]  # left out of the background
        for k, a in enumerate(self.moving):  # above everything static, in this order (original, then decode)
            a.set_zorder(10 + k)
        # axes whose limits move (followed skeletons): left out of the background, drawn whole every frame
        self.redrawn = [v.ax for v in self.views if isinstance(v, SkeletonView) and v.follow_half is not None]
        self._drawn = [(ax, ax in self.redrawn, [a for a in self.moving if a.axes is ax]) for ax in self.fig.axes]
        assert sum(len(m) for _, _, m in self._drawn) == len(self.moving), "a moving artist outside the axes"
        for ax in self.fig.axes:
            if hasattr(ax, "computed_zorder"):
                ax.computed_zorder = False  # no depth sorting: the same order in a full redraw as in frame()

    @staticmethod
    def _follow_half(panels: list, window: tuple[float, float], follow: bool | None) -> float | None:
        """Half the side of a followed skeleton's axes cube, the same for all (None: no following)."""
        if follow is False:
            return None
        measures = []
        for i, p in enumerate(panels):
            if p.get("kind") == "skeleton":
                where = f"panel {p.get('id', i)}"
                times = _times(p, where)
                pos = z_up(_array(p, "positions", where, (None, 3)), _field(p, "up", where))
                parents = [int(j) for j in _field(p, "parents", where)]
                first, last = _index_at(times, window[0]), _index_at(times, window[1])
                measures.append(body_measures(pos, parents, first, last + 1))
        if not measures:
            return None
        if follow is None and not any(m["height"] > 0 and m["travel"] > FOLLOW_TRAVEL * m["height"]
                                      for m in measures):
            return None
        size = max(max(m["size"], m["height"]) for m in measures)
        return FOLLOW_HALF * size if size > 0 else 1.0

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
        """One row per sensor: the original's box, the decode's box (two squares as high as the row, at
        most 45% of the panel's width together), then the error plot; the columns headed once, above the
        first row's squares."""
        sensors = _field(p, "sensors", where)
        up = _field(p, "up", where)
        n = max(len(sensors), 1)
        W, H = self.fig.bbox.width, self.fig.bbox.height
        h = (y1 - y0) / n
        side = min(h * H, 0.225 * w * W)  # pixels
        sw = side / W  # a square's width as a fraction of the figure's
        bx = x + 0.005 * w
        # the error plots: after the boxes and room for their y label and numbers (clear of the squares)
        px = bx + 2 * sw + max(0.07 * w, 3.6 * fs * DPI / 72 / W)
        self.fig.text(x + 0.005, y1 + 0.028, f"{p.get('name', '')}: boxes turned by the original and the decode "
                      "(x y z arrows in red green blue)", fontsize=fs * 0.75, va="bottom")
        for k, (key, colour) in enumerate((("original", ORIGINAL), ("decoded", DECODED))):
            self.fig.text(bx + (k + 0.5) * sw, y1 - h / 2 + side / H / 2 + 0.004, key, fontsize=fs * 0.7,
                          color=colour, ha="center", va="bottom", weight="bold")
        views = []
        for k, s in enumerate(sensors):
            top = y1 - k * h
            r3 = {"original": [bx, top - h, sw, h], "decoded": [bx + sw, top - h, sw, h]}
            r2 = [px, top - h + h * 0.18, x + 0.97 * w - px, h * 0.62]
            views.append(SensorView(self.fig, r3, r2, s, up, window, fs, f"{where}.sensors[{k}]",
                                    time_labels=k == len(sensors) - 1))
        return views

    def show(self, t: float) -> None:
        for v in self.views:
            v.show(t)

    def frame(self) -> memoryview:
        """The figure now, as the canvas's RGBA buffer: the static background (drawn once: panes, grids,
        ticks, titles, colour bars, trajectories, segments) restored, then, axes by axes in the figure's
        order, the moving artists drawn, or the whole axes when its limits move (followed skeletons)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        canvas = self.fig.canvas
        assert isinstance(canvas, FigureCanvasAgg)  # _frame_canvas attached an Agg canvas
        if self._background is None:
            hidden = [*self.moving, *self.redrawn]
            for a in hidden:
                a.set_visible(False)
            try:
                FigureCanvasAgg.draw(canvas)  # also sets each 3-D axes' projection, used below
            finally:
                for a in hidden:
                    a.set_visible(True)
            self._background = canvas.copy_from_bbox(self.fig.bbox)
        else:
            canvas.restore_region(self._background)
        renderer = canvas.get_renderer()
        for ax, whole, moving in self._drawn:
            if whole:
                ax.draw(renderer)
                continue
            for a in moving:
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

        canvas = self.fig.canvas
        assert isinstance(canvas, FigureCanvasAgg)  # _frame_canvas attached an Agg canvas
        FigureCanvasAgg.draw(canvas)
        return np.asarray(canvas.buffer_rgba()).copy()


# --- writing -------------------------------------------------------------------------------------

def _frame_canvas(figure, frame):
    """Attach to ``figure`` an Agg canvas whose raw output is ``frame()`` (see :func:`_canvas_class`)."""
    return _canvas_class()(figure, frame)


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


def _codes(rgb: np.ndarray) -> np.ndarray:
    rgb = rgb.reshape(-1, 3)
    return (rgb[:, 0].astype(np.uint32) << 16) | (rgb[:, 1].astype(np.uint32) << 8) | rgb[:, 2]


class GifPalette:
    """One 256-colour palette for the whole GIF, from a few frames spread over ``times``: their ``exact``
    most frequent colours as they are (background, panes, text, the artists' flat colours) and a median
    cut of the other pixels (anti-aliased edges, the colour map). :meth:`quantize` maps a frame onto it:
    the exact colours exactly (Pillow's palette mapping goes through a coarse colour cache and would turn
    white into 252 grey), the others to Pillow's nearest entry."""

    def __init__(self, view: SceneFigure, times: np.ndarray, samples: int = 5, exact: int = 96):
        from PIL import Image

        picks = np.unique(np.linspace(0, len(times) - 1, min(samples, len(times))).round().astype(int))
        rows = []
        for k in picks:
            view.show(float(times[k]))
            rows.append(view.render()[..., :3].reshape(-1, 3))
        px = np.concatenate(rows)
        colours, inverse, counts = np.unique(_codes(px), return_inverse=True, return_counts=True)
        top = np.argsort(-counts, kind="stable")[:exact]
        palette: list[tuple[int, ...]] = [((c >> 16) & 255, (c >> 8) & 255, c & 255) for c in colours[top].tolist()]
        rest = px[~np.isin(inverse, top)]
        if len(rest):
            cut = Image.fromarray(rest[None, :, :].copy()).convert("P", palette=Image.Palette.ADAPTIVE,
                                                                   colors=256 - len(palette))
            values = cut.getpalette()
            assert values is not None  # a "P" image made with an adaptive palette has one
            palette += [tuple(values[3 * i:3 * i + 3]) for i in np.unique(np.asarray(cut)).tolist()]
        flat = [v for c in palette[:256] for v in c]
        self.image = Image.new("P", (1, 1))
        self.image.putpalette(flat + flat[:3] * (256 - len(flat) // 3))
        order = np.argsort(colours[top])
        self.exact_codes = colours[top][order]
        self.exact_index = np.arange(len(top), dtype=np.uint8)[order]

    def quantize(self, frame):
        """The RGB ``frame`` (a PIL image) as a ``P`` image on this palette."""
        from PIL import Image

        q = frame.quantize(palette=self.image, dither=Image.Dither.NONE)
        idx = np.array(q)
        code = _codes(np.asarray(frame)).reshape(idx.shape)
        pos = np.minimum(np.searchsorted(self.exact_codes, code), len(self.exact_codes) - 1)
        hit = self.exact_codes[pos] == code
        idx[hit] = self.exact_index[pos[hit]]
        out = Image.fromarray(idx, mode="P")
        out.putpalette(self.image.getpalette())
        return out
