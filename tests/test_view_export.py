"""``mocapkit view --export``: the scene drawn into GIF/MP4 files (``mocapkit.view.export``).

Scenes are built by hand following docs/viewer.md (and, at the end, by ``build_scene`` from the sample
files). The pictures are checked against things computed here: the joints projected with the 3-D axes'
own projection matrix, the GIF's frame count and delays read back by Pillow, the MP4 probed by ffprobe.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from PIL import Image

from mocapkit.errors import InvalidParameterError, MocapError, MocapFormatError
from mocapkit.view.arrays import encode_array
from mocapkit.view.export import export_scene
from mocapkit.view.export_figure import SceneFigure

DATA = Path(__file__).resolve().parent / "data"
W, H = 320, 200


# --- hand-built scenes (docs/viewer.md) ---------------------------------------------------------------

PARENTS = [-1, 0, 1, 1, 1, 0]  # hips, spine, head, left hand, right hand, foot


def skeleton_positions(times: np.ndarray) -> np.ndarray:
    """A z-up stick figure walking along x with its left hand waving: (n, 6, 3) cm, joints far apart."""
    n = len(times)
    p = np.zeros((n, 6, 3))
    x0 = 40.0 * times
    wave = 25.0 * np.sin(2 * np.pi * times)
    p[:, 0] = np.stack([x0, 0 * x0, 0 * x0 + 100], axis=1)
    p[:, 1] = p[:, 0] + [0, 0, 35]
    p[:, 2] = p[:, 0] + [0, 0, 70]
    p[:, 3] = p[:, 1] + np.stack([0 * x0 - 45, 0 * x0, wave], axis=1)
    p[:, 4] = p[:, 1] + [45, 0, -20]
    p[:, 5] = p[:, 0] + [10, 0, -90]
    return p


def decode_offsets(times: np.ndarray) -> np.ndarray:
    """(n, 6) how far each decoded joint is off (cm): joint j by 0.1 j, growing from half to all of it."""
    return 0.1 * np.arange(6)[None, :] * (0.5 + 0.5 * times[:, None] / max(times[-1], 1e-9))


def skeleton_scene(n: int = 41, rate: float = 20.0, up: str = "z", positions=None, segments: bool = True) -> dict:
    times = np.arange(n) / rate
    pos = skeleton_positions(times) if positions is None else positions
    offset = np.zeros_like(pos)
    offset[:, :, 1] = decode_offsets(times)  # errors growing over time
    if up == "y":
        offset = np.stack([offset[..., 0], offset[..., 2], -offset[..., 1]], axis=-1)
    dec = pos + offset
    err = np.linalg.norm(dec - pos, axis=-1)

    def panel(pid, role, p, error):
        return {"id": pid, "kind": "skeleton", "file": f"{pid}.bvh", "name": f"{pid}.bvh", "up": up,
                "times": encode_array(times, "float64"),
                "joints": ["hips", "spine", "head", "lhand", "rhand", "foot"], "parents": PARENTS, "unit": "cm",
                "positions": encode_array(p), "role": role, "decoded_from": None if role == "original" else "p0",
                "error": None if error is None else encode_array(error),
                "max_error": None if error is None else float(error.max()),
                "bound": None if error is None else 0.5}

    seg = None
    if segments:
        cut = n // 2
        seg = {"file": "p0.bvh", "method": "arma", "cuts": [{"frame": cut, "time_s": float(times[cut])}],
               "segments": [{"t0": 0.0, "t1": float(times[cut - 1]), "frame0": 0, "frame1": cut, "label": "walk",
                             "action": "A"},
                            {"t0": float(times[cut]), "t1": float(times[-1]), "frame0": cut, "frame1": n,
                             "label": None, "action": "B"}]}
    return {"mocapkit_view": 1, "title": "p0.bvh · p1.mkc",
            "timeline": {"times": encode_array(times, "float64"), "frames": n, "rate_hz": rate, "source": "p0"},
            "segments": seg, "notes": [], "panels": [panel("p0", "original", pos, None),
                                                     panel("p1", "decoded", dec, err)]}


def quat_z(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle / 2), 0 * angle, 0 * angle, np.sin(angle / 2)], axis=1)


def mixed_scene(n: int = 41, rate: float = 20.0) -> dict:
    """An IMU panel (one sensor turning about z, its decode a little behind) and a marker panel."""
    times = np.arange(n) / rate
    ang = np.pi * times
    orig, dec = quat_z(ang), quat_z(ang - np.radians(1.5) * np.sin(5 * times))
    err = np.degrees(np.abs(np.radians(1.5) * np.sin(5 * times)))
    sensor = {"name": "wrist", "times": encode_array(times, "float64"), "original": encode_array(orig),
              "decoded": encode_array(dec), "error_deg": encode_array(err),
              "keyframes": encode_array(times[::8], "float64"), "bound_deg": 2.0, "max_error_deg": float(err.max())}
    m_pos = np.zeros((n, 3, 3))
    m_pos[:, 0] = np.stack([100 * times, 0 * times, 500 + 300 * times - 490 * times ** 2], axis=1)
    m_pos[:, 1] = [0, 200, 0]
    m_pos[:, 2] = [300, 200, 0]
    m_pos[5:9, 2] = np.nan  # a gap
    fitted = np.full_like(m_pos, np.nan)
    fitted[:, 0] = m_pos[:, 0]
    markers = {"id": "p1", "kind": "markers", "file": "m.tsv", "name": "m.tsv", "up": "z",
               "times": encode_array(times, "float64"), "labels": ["ball", "b1", "b2"], "unit": "mm",
               "positions": encode_array(m_pos), "fitted": encode_array(fitted),
               "knots": [{"marker": 0, "times": [float(times[n // 2])], "positions": [m_pos[n // 2, 0].tolist()]}]}
    imu = {"id": "p0", "kind": "imu", "file": "w.csv", "name": "w.csv + w.mkp", "up": "z",
           "times": encode_array(times, "float64"), "sensors": [sensor]}
    return {"mocapkit_view": 1, "title": "mixed",
            "timeline": {"times": encode_array(times, "float64"), "frames": n, "rate_hz": rate, "source": "p0"},
            "segments": None, "notes": ["a note"], "panels": [imu, markers]}


# --- helpers ----------------------------------------------------------------------------------------

def gif_frames(path: Path) -> tuple[list[np.ndarray], list[int], tuple[int, int]]:
    frames, delays = [], []
    with Image.open(path) as im:
        size = im.size
        for k in range(im.n_frames):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB")).astype(int))
            delays.append(im.info.get("duration"))
    return frames, delays, size


def projected(ax, pts: np.ndarray) -> np.ndarray:
    """Pixel (column, row) of 3-D points through the axes' projection matrix ``ax.M`` and ``transData``,
    computed here (homogeneous coordinates), rows counted from the top."""
    h = np.c_[pts, np.ones(len(pts))] @ np.asarray(ax.M).T
    xy = ax.transData.transform(h[:, :2] / h[:, 3:4])
    return np.c_[xy[:, 0], ax.figure.bbox.height - xy[:, 1]]


def rows_cols(ax) -> tuple[slice, slice]:
    x0, y0, x1, y1 = ax.bbox.extents
    Hf = ax.figure.bbox.height
    return slice(int(Hf - y1), int(Hf - y0)), slice(int(x0), int(x1))


def running_children(name: str) -> list[int]:
    """This process's children called ``name`` that are still running (not zombies), from /proc."""
    found = []
    for d in Path("/proc").glob("[0-9]*"):
        with contextlib.suppress(OSError, IndexError, ValueError):
            stat = (d / "stat").read_text()
            comm, rest = stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
            if comm == name and int(rest[1]) == os.getpid() and rest[0] not in ("Z", "X"):
                found.append(int(d.name))
    return found


class Recorder:
    """A ``progress(what, total)`` factory recording its calls (optionally raising at one update)."""

    def __init__(self, raise_at: int | None = None, exc=KeyboardInterrupt):
        self.opened, self.updates, self.raise_at, self.exc = [], [], raise_at, exc

    def __call__(self, what, total):
        self.opened.append((what, total))

        @contextlib.contextmanager
        def cm():
            def update(done, n=None):
                self.updates.append(done)
                if self.raise_at is not None and done == self.raise_at:
                    raise self.exc()
            yield update
        return cm()


# --- frame counts, sizes, delays ------------------------------------------------------------------------

def test_gif_frame_count_delay_and_size(tmp_path):
    scene = skeleton_scene(n=41, rate=20.0)  # 2 s
    out = tmp_path / "a.gif"
    rec = Recorder()
    r = export_scene(scene, out, fps=10, width_px=W, height_px=H, progress=rec)
    frames, delays, size = gif_frames(out)
    assert size == (W, H)
    assert len(frames) == 21 == r["frames_written"]  # 0, 0.1, ..., 2.0 s
    assert delays == [100] * 21
    assert r == {"path": str(out), "frames_written": 21, "fps": 10.0, "bytes": out.stat().st_size, "format": "gif"}
    assert rec.opened == [("exporting a.gif", 21)] and rec.updates == list(range(1, 22))
    # 30 fps: a GIF's delays are hundredths, so 3 cs = 33.3 fps; 2 s -> floor(2 / 0.03) + 1 frames
    r = export_scene(scene, out, fps=30, width_px=W, height_px=H)
    frames, delays, _ = gif_frames(out)
    assert r["fps"] == pytest.approx(100 / 3) and len(frames) == r["frames_written"] == math.floor(2 / 0.03) + 1
    assert set(delays) == {30}
    assert sorted(os.listdir(tmp_path)) == ["a.gif"]


def test_frame_range_limits_the_export(tmp_path):
    scene = skeleton_scene(n=41, rate=20.0)
    r = export_scene(scene, tmp_path / "r.gif", fps=20, width_px=W, height_px=H, frames=(10, 20))  # 10..19
    frames, _, _ = gif_frames(tmp_path / "r.gif")
    assert len(frames) == r["frames_written"] == 10
    r = export_scene(scene, tmp_path / "one.gif", fps=20, width_px=W, height_px=H, frames=(7, 8))
    assert r["frames_written"] == 1 and len(gif_frames(tmp_path / "one.gif")[0]) == 1


def test_consecutive_frames_of_a_moving_skeleton_differ(tmp_path):
    scene = skeleton_scene(n=41, rate=20.0)
    export_scene(scene, tmp_path / "m.gif", fps=10, width_px=W, height_px=H)
    frames, _, _ = gif_frames(tmp_path / "m.gif")
    view = SceneFigure(scene, W, H)
    view.render()  # places the axes
    for v in view.views[:2]:
        rr, cc = rows_cols(v.ax)
        for a, b in itertools.pairwise(frames):
            assert np.abs(a[rr, cc] - b[rr, cc]).sum(axis=2).max() > 100, "the skeleton did not move"
    # a still skeleton: its panels do not change from frame to frame (only the clock and playhead do)
    still = skeleton_scene(n=41, rate=20.0, positions=np.repeat(skeleton_positions(np.zeros(1)), 41, axis=0))
    export_scene(still, tmp_path / "s.gif", fps=10, width_px=W, height_px=H)
    frames, _, _ = gif_frames(tmp_path / "s.gif")
    rr, cc = rows_cols(view.views[0].ax)
    assert all(np.array_equal(a[rr, cc], frames[0][rr, cc]) for a in frames[1:])


# --- the picture --------------------------------------------------------------------------------------

def _bone_distance(px: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distance of every pixel centre ``px`` (P, 2) to the nearest 2-D segment of ``segs`` (S, 2, 2)."""
    a, b = segs[:, 0][None], segs[:, 1][None]
    d = b - a
    u = np.clip(((px[:, None] - a) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-12), 0, 1)
    return np.linalg.norm(px[:, None] - (a + u[..., None] * d), axis=-1).min(axis=1)


def test_skeleton_drawn_where_the_joints_project(tmp_path):
    from matplotlib import colormaps

    scene = skeleton_scene(n=41, rate=20.0)
    export_scene(scene, tmp_path / "f.gif", fps=10, width_px=W, height_px=H, frames=(26, 27))
    gif = gif_frames(tmp_path / "f.gif")[0][0]
    view = SceneFigure(scene, W, H)
    view.show(1.3)
    img = view.render()[..., :3].astype(int)
    assert np.abs(gif - img).mean() < 3, "the GIF holds another picture"
    for v in view.views[:2]:
        v.lines.set_visible(False), v.joints.set_visible(False)
    empty = view.render_full()[..., :3].astype(int)
    for v in view.views[:2]:
        v.lines.set_visible(True), v.joints.set_visible(True)
    pos = skeleton_positions(np.arange(41) / 20.0)[26]
    err = decode_offsets(np.arange(41) / 20.0)[26]
    for i, v in enumerate(view.views[:2]):
        p = pos + (np.c_[0 * err, err, 0 * err] if i else 0)
        px = projected(v.ax, p)
        cols, rows = px[:, 0].astype(int), px[:, 1].astype(int)
        # every joint is drawn, in the GIF too
        assert (np.abs(img[rows, cols] - empty[rows, cols]).sum(axis=1) > 60).all()
        assert (np.abs(gif[rows, cols] - empty[rows, cols]).sum(axis=1) > 60).all()
        # joints coloured: the original's in one colour, the decode's by its error over the 0.5 cm bound
        want = (np.array([[0x1f, 0x5f, 0xa8]] * 6) if i == 0 else
                np.round(colormaps["RdYlGn_r"](err / 0.5)[:, :3] * 255))
        assert np.abs(img[rows, cols] - want).max() <= 3
        # nothing else moved: far from every joint and bone, the panel equals the empty one
        rr, cc = rows_cols(v.ax)
        yy, xx = np.mgrid[rr, cc]
        pix = np.c_[xx.ravel() + 0.5, yy.ravel() + 0.5]
        segs = np.stack([px[[j for j, q in enumerate(PARENTS) if q >= 0]],
                         px[[q for q in PARENTS if q >= 0]]], axis=1)
        far = np.minimum(_bone_distance(pix, segs), np.linalg.norm(pix[:, None] - px[None], axis=-1).min(1)) > 6
        diff = np.abs(img[yy.ravel(), xx.ravel()] - empty[yy.ravel(), xx.ravel()]).sum(axis=1)
        assert far.sum() > 1000 and (diff[far] == 0).all()
        assert (diff[~far] > 0).sum() > 20


def test_y_up_scene_is_drawn_upright(tmp_path):
    """A y-up file shows the same picture as the same motion turned by hand to z-up (x, -z, y): a rotation,
    so the head stays above the feet and nothing is mirrored."""
    times = np.arange(41) / 20.0
    zup = skeleton_positions(times)
    yup = np.stack([zup[..., 0], zup[..., 2], -zup[..., 1]], axis=-1)  # the inverse turn
    a = SceneFigure(skeleton_scene(up="y", positions=yup), W, H)
    b = SceneFigure(skeleton_scene(up="z", positions=zup), W, H)
    for t in (0.0, 0.7, 1.9):
        a.show(t), b.show(t)
        assert np.array_equal(a.render(), b.render())
    px = projected(b.views[0].ax, zup[10])
    assert px[2, 1] < px[1, 1] < px[0, 1] < px[5, 1]  # head above spine above hips above foot (rows from top)


def test_background_reuse_draws_what_a_full_redraw_draws():
    for scene in (skeleton_scene(), mixed_scene()):
        view = SceneFigure(scene, W, H)
        for t in (0.0, 0.55, 1.35, 2.0):
            view.show(t)
            fast = view.render()
            full = view.render_full()
            assert np.array_equal(fast, full)


# --- follow (travelling skeletons) and the markers' trail -------------------------------------------------

def travelling_positions(times: np.ndarray, speed: float = 200.0) -> np.ndarray:
    """The stick figure carried along x at ``speed`` cm/s on top of its walk."""
    return skeleton_positions(times) + np.stack([speed * times, 0 * times, 0 * times], axis=1)[:, None, :]


def test_body_measures_are_the_pages():
    """Height (vertical extent), size (box diagonal) and the root's horizontal travel, as skeleton.js."""
    from mocapkit.view.export_panels import body_measures

    times = np.arange(41) / 20.0
    pos = skeleton_positions(times)
    m = body_measures(pos, PARENTS)
    assert m["travel"] == pytest.approx(80.0)  # 40 cm/s for 2 s, along x only
    assert m["height"] == pytest.approx(160.0)  # foot at z = 10, head at 170
    boxes = [np.linalg.norm(p.max(0) - p.min(0)) for p in pos]
    assert m["size"] == pytest.approx(sorted(boxes)[len(boxes) // 2])
    assert body_measures(pos, PARENTS, 10, 21)["travel"] == pytest.approx(40.0 * 0.5)  # frames 10..20 only
    # 80 cm < 1.5 x 160: not followed by default; carried 400 cm further it is, and follow= overrides either way
    assert not SceneFigure(skeleton_scene(), W, H).following
    assert SceneFigure(skeleton_scene(), W, H, follow=True).following
    moving = skeleton_scene(positions=travelling_positions(times))
    assert SceneFigure(moving, W, H).following
    assert not SceneFigure(moving, W, H, follow=False).following
    # the rule looks at the frames exported: the first 0.25 s travel 60 cm
    assert not SceneFigure(moving, W, H, window=(0.0, 0.25)).following


def test_a_followed_skeleton_stays_in_the_middle_of_its_axes_and_large(tmp_path):
    times = np.arange(41) / 20.0
    pos = travelling_positions(times)
    scene = skeleton_scene(positions=pos)

    def placement(follow):
        """Per time: the pose centre's projected distance (px) to its axes' centre, and the pose's height (px)."""
        view = SceneFigure(scene, W, H, follow=follow)
        out = []
        for k in (0, 10, 20, 30, 40):
            view.show(times[k])
            fast = view.render()
            assert np.array_equal(fast, view.render_full())  # moving limits: still what a full redraw draws
            for i, v in enumerate(view.views[:2]):
                p = pos[k] + (np.c_[0 * pos[k, :, 0], decode_offsets(times)[k], 0 * pos[k, :, 0]] if i else 0)
                x0, y0, x1, y1 = v.ax.bbox.extents
                centre = projected(v.ax, ((p.min(0) + p.max(0)) / 2)[None])[0]
                px = projected(v.ax, p)
                out.append((np.hypot(*(centre - [(x0 + x1) / 2, H - (y0 + y1) / 2])) / (x1 - x0),
                            np.ptp(px[:, 1]) / (y1 - y0)))
                if i == 0:  # and it is drawn there: the head's pixel is the bone colour
                    col, row = px[2].astype(int)
                    assert np.abs(fast[row, col, :3].astype(int) - [0x1f, 0x5f, 0xa8]).max() <= 3
        return np.array(out)

    followed, still = placement(None), placement(False)
    assert followed[:, 0].max() < 0.03  # within 3% of the axes' width of its centre, every frame
    assert still[:, 0].max() > 0.25  # the whole-take limits: it walks across
    assert followed[:, 1].min() > 0.5 and still[:, 1].max() < 0.3  # drawn large when followed
    # the export writes the same pictures
    export_scene(scene, tmp_path / "f.gif", fps=10, width_px=W, height_px=H)
    view = SceneFigure(scene, W, H)
    view.show(1.5)
    assert np.abs(gif_frames(tmp_path / "f.gif")[0][15] - view.render()[..., :3].astype(int)).mean() < 3


def trail_scene(n: int = 81, rate: float = 20.0) -> dict:
    """One marker moving along x (100 mm/s, 4 s) and one still, its fit 80 mm above it, knots at 0.5 and 3.5 s."""
    times = np.arange(n) / rate
    pos = np.zeros((n, 2, 3))
    pos[:, 0, 0] = 100 * times
    pos[:, 1] = [0, 300, 300]
    fitted = np.full_like(pos, np.nan)
    fitted[:, 0] = pos[:, 0] + [0, 0, 80]
    kt = [0.5, 3.5]
    panel = {"id": "p0", "kind": "markers", "file": "m.tsv", "name": "m.tsv", "up": "z",
             "times": encode_array(times, "float64"), "labels": ["a", "b"], "unit": "mm",
             "positions": encode_array(pos), "fitted": encode_array(fitted),
             "knots": [{"marker": 0, "times": kt, "positions": [(fitted[int(t * rate), 0]).tolist() for t in kt]}]}
    return {"mocapkit_view": 1, "title": "trail",
            "timeline": {"times": encode_array(times, "float64"), "frames": n, "rate_hz": rate, "source": "p0"},
            "segments": None, "notes": [], "panels": [panel]}


def bare(ax) -> np.ndarray:
    """The figure of ``ax`` drawn without its lines and collections (restored after)."""
    hidden = [*ax.lines, *ax.collections]
    for a in hidden:
        a.set_visible(False)
    try:
        FigureCanvasAgg.draw(ax.figure.canvas)
        return np.asarray(ax.figure.canvas.buffer_rgba()).copy()
    finally:
        for a in hidden:
            a.set_visible(True)


def test_the_trail_holds_one_second_around_the_time_shown():
    scene = trail_scene()
    view = SceneFigure(scene, W, H)  # trail_s=1.0 by default, as the page
    mv = view.views[0]
    view.show(3.5)
    x, _, _ = mv.traces[0].get_data_3d()
    assert x.min() == pytest.approx(250) and x.max() == pytest.approx(400)  # samples at 2.5..4.0 s
    (_, curve), = mv.curves
    assert curve.get_data_3d()[0].min() == pytest.approx(250)
    assert mv.knots.get_offsets().tolist() == [[350.0, 0.0]]  # the 3.5 s knot only
    img = view.render()
    assert np.array_equal(img, view.render_full())
    empty = bare(mv.ax)

    def drawn(x_mm, dz=0.0):
        """Whether anything is drawn along the path from ``x_mm - 10`` to ``x_mm + 10`` (the fit is dashed)."""
        pts = np.c_[np.linspace(x_mm - 10, x_mm + 10, 9), np.zeros(9), np.full(9, dz)]
        cols, rows = projected(mv.ax, pts).astype(int).T
        return (np.abs(img[rows, cols, :3].astype(int) - empty[rows, cols, :3].astype(int)).sum(axis=1) > 60).any()

    assert drawn(300) and drawn(300, 80)  # the trajectory and the fit 0.5 s ago are drawn,
    assert not drawn(50) and not drawn(50, 80)  # 3 s ago not
    # the whole take (trail_s=None): drawn once into the background, there at every time
    view = SceneFigure(scene, W, H, trail_s=None)
    view.show(3.5)
    img = view.render()
    mv = view.views[0]
    empty = bare(mv.ax)
    assert drawn(50) and drawn(50, 80) and not np.array_equal(img, empty)
    # the knot at 0.5 s is drawn then (an x), not in the window at 3.5 s
    view = SceneFigure(scene, W, H)
    view.show(0.5)
    img = view.render()
    mv = view.views[0]
    col, row = projected(mv.ax, np.array([[50, 0, 80]]))[0].astype(int)
    knot_px = img[row - 1:row + 2, col - 1:col + 2, :3].astype(int)
    assert (np.abs(knot_px).sum(axis=2) < 60).any()  # black
    view.show(3.5)
    img = view.render()
    assert not (np.abs(img[row - 1:row + 2, col - 1:col + 2, :3].astype(int)).sum(axis=2) < 60).any()


def test_playhead_and_clock_follow_the_output_time():
    scene = skeleton_scene(n=41, rate=20.0)
    view = SceneFigure(scene, W, H)
    ax = view.timeline.ax
    rr, cc = rows_cols(ax)
    for t in (0.25, 1.0, 1.75):
        view.show(t)
        img = view.render()[..., :3].astype(int)
        red = (np.abs(img[rr, cc] - [0xd0, 0, 0]).sum(axis=2) < 40).sum(axis=0)
        x_px = ax.transData.transform((t, 0))[0]
        cols = np.nonzero(red > 0.5 * red.max())[0] + cc.start
        assert red.max() > 5 and abs(cols.mean() + 0.5 - x_px) < 1.5
        assert view.timeline.clock.get_text().split() == ["t", "=", f"{t:.3f}", "s", "frame", str(round(t * 20)),
                                                         "/", "41"]


def test_a_panel_holds_its_last_sample_at_or_before_the_time():
    """A decoded panel sampled at 5 Hz from 0.5 s on a 20 Hz timeline: before 0.5 s it shows its first
    sample, between samples the earlier one (docs/viewer.md)."""
    scene = skeleton_scene(n=41, rate=20.0)
    tp = 0.5 + 0.2 * np.arange(8)
    pos = skeleton_positions(tp)
    panel = scene["panels"][1]
    panel["times"] = encode_array(tp, "float64")
    panel["positions"] = encode_array(pos)
    panel["error"] = encode_array(np.full((8, 6), 0.2))
    view = SceneFigure(scene, W, H)
    rr, cc = rows_cols(view.views[1].ax)

    def at(t):
        view.show(t)
        return view.render()[rr, cc]

    first = at(0.5)
    assert np.array_equal(at(0.0), first) and np.array_equal(at(0.45), first) and np.array_equal(at(0.69), first)
    assert not np.array_equal(at(0.7), first)
    assert np.array_equal(at(0.7), at(0.89)) and np.array_equal(at(2.0), at(tp[-1] + 1e-9))


def test_imu_and_marker_panels_move(tmp_path):
    scene = mixed_scene()
    r = export_scene(scene, tmp_path / "x.gif", fps=10, width_px=W, height_px=H)
    frames, _, _ = gif_frames(tmp_path / "x.gif")
    assert len(frames) == r["frames_written"] == 21
    view = SceneFigure(scene, W, H)
    view.render()
    sensor, markers = view.views[0], view.views[1]
    for ax in (sensor.ax3d, sensor.ax2d, markers.ax):  # the box turns, the playhead and the ball move
        rr, cc = rows_cols(ax)
        assert all(np.abs(a[rr, cc] - b[rr, cc]).sum() > 0 for a, b in itertools.pairwise(frames))
    # the decoded box and the marker are drawn where they project (moving artists hidden -> empty)
    view.show(1.0)
    img = view.render()[..., :3].astype(int)
    for art in sensor.boxes.values():
        art.set_visible(False)
    markers.markers.set_visible(False)
    empty = view.render_full()[..., :3].astype(int)
    ball = np.array([[100 * 1.0, 0, 500 + 300 - 490.0]])
    col, row = projected(markers.ax, ball)[0].astype(int)
    assert np.abs(img[row, col] - empty[row, col]).sum() > 60
    rr, cc = rows_cols(sensor.ax3d)
    assert (np.abs(img[rr, cc] - empty[rr, cc]).sum(axis=2) > 60).sum() > 30


def imu_scene(sensors: int = 7, n: int = 41, rate: float = 20.0) -> dict:
    """An IMU panel of ``sensors`` sensors turning about z at different speeds, the decodes lagging."""
    scene = mixed_scene(n, rate)
    times = np.arange(n) / rate
    sens = []
    for k in range(sensors):
        ang = (1 + 0.3 * k) * np.pi * times
        lag = np.radians(1.5) * np.sin(5 * times)
        sens.append({"name": f"s{k}", "times": encode_array(times, "float64"), "original": encode_array(quat_z(ang)),
                     "decoded": encode_array(quat_z(ang - lag)), "error_deg": encode_array(np.degrees(np.abs(lag))),
                     "keyframes": encode_array(times[3::7], "float64"), "bound_deg": 2.0,
                     "max_error_deg": float(np.degrees(np.abs(lag)).max())})
    scene["panels"] = [scene["panels"][0] | {"sensors": sens}]
    return scene


def test_imu_original_and_decode_side_by_side_at_one_scale_and_large():
    """Each sensor's two boxes in its row: the original left, the decode right, their centres apart by more
    than a box's drawn size, the same box drawn the same size in both, together filling the row's height;
    each box's colour only on its side; the columns labelled."""
    from mocapkit.view.export_panels import (
        _BOX,
        _REACH,
        DECODED,
        ORIGINAL,
        _sphere,
        z_up,
    )

    for sensors, (w, h) in ((7, (960, 540)), (1, (W, H))):
        view = SceneFigure(imu_scene(sensors), w, h)
        view.show(0.6)
        img = view.render()[..., :3].astype(int)
        texts = [t.get_text() for t in view.fig.texts]
        assert "original" in texts and "decoded" in texts
        row_px = 0.7 * h / sensors
        for k, sv in enumerate(view.views[:sensors]):
            ao, ad = sv.axes3d["original"], sv.axes3d["decoded"]
            co, cd = projected(ao, np.zeros((1, 3)))[0], projected(ad, np.zeros((1, 3)))[0]
            R = sv.mats["original"][12]
            box_o = projected(ao, z_up(_BOX @ R.T, "z"))
            box_d = projected(ad, z_up(_BOX @ R.T, "z"))
            size = np.ptp(box_o, axis=0)
            assert np.allclose(np.ptp(box_d, axis=0), size, rtol=1e-6)  # one scale
            assert cd[0] - co[0] > size.max() and abs(cd[1] - co[1]) < 1  # decode right of the original, same row
            # large: what a turning box may reach spans (nearly) the whole row height (or its capped width)
            reach = np.ptp(projected(ao, _sphere(_REACH)), axis=0)
            assert reach.min() > 0.9 * min(row_px, 0.225 * 0.98 * w) and size.max() > 0.35 * reach.min()
            for ax, mine, other in ((ao, ORIGINAL, DECODED), (ad, DECODED, ORIGINAL)):
                rr, cc = rows_cols(ax)
                count = [(np.abs(img[rr, cc] - [int(c[i:i + 2], 16) for i in (1, 3, 5)]).sum(-1) < 30).sum()
                         for c in (mine, other)]
                assert count[0] > 20 and count[1] == 0
            # rows do not overlap: this sensor's boxes are above the next one's
            if k + 1 < sensors:
                assert ao.bbox.y0 >= view.views[k + 1].axes3d["original"].bbox.y1 - 1


def test_keyframes_are_ticks_under_the_time_axis_with_the_bound_and_playhead():
    from mocapkit.view.export_panels import KEYFRAME

    scene = imu_scene(3)
    times = np.arange(41) / 20.0
    kf = times[3::7]
    view = SceneFigure(scene, 960, 540)
    view.show(1.0)
    img = view.render()[..., :3].astype(int)
    purple = np.abs(img - [int(KEYFRAME[i:i + 2], 16) for i in (1, 3, 5)]).sum(-1) < 40
    for sv in view.views[:3]:
        ax = sv.ax2d
        assert np.array_equal(sv.keyframes.get_xdata(), kf)
        bottom = round(540 - ax.bbox.y0)  # the axis' row, counted from the top
        below = purple[bottom:bottom + 20]
        for t in kf:
            col = int(ax.transData.transform((t, 0))[0])
            run = below[:, col - 1:col + 2].any(axis=1)
            assert run.sum() >= 4, f"keyframe {t} s: {run.sum()} px"  # a visible tick under the axis
            assert not purple[int(540 - ax.bbox.y1) + 2:bottom - 2, col - 1:col + 2].any()  # not across the plot
        for t in (kf[:-1] + kf[1:]) / 2:  # nothing between keyframes
            col = int(ax.transData.transform((t, 0))[0])
            assert not below[:, col - 1:col + 2].any()
        # the bound (dashed) and the playhead are still drawn
        rr, cc = rows_cols(ax)
        x_px = int(ax.transData.transform((1.0, 0))[0])
        red = np.abs(img[rr, x_px - 1:x_px + 2] - [0xd0, 0, 0]).sum(-1) < 40
        assert red.any(axis=1).mean() > 0.8
        y_px = int(540 - ax.transData.transform((0, 2.0))[1])
        bound = np.abs(img[y_px - 1:y_px + 2, cc] - [0xc0, 0, 0]).sum(-1) < 60
        assert 0.3 < bound.any(axis=0).mean() < 0.95  # dashed: about half the width


def marker_coverage(view) -> tuple[float, float]:
    """The projected box of all the markers' finite positions over the take, as a fraction of the panel's
    rectangle across and up (the larger is the one the equal aspect lets fill)."""
    mv = view.views[0]
    p = mv.pos.reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    px = projected(mv.ax, p)
    x0, y0, x1, y1 = mv.ax.get_position(original=True).transformed(view.fig.transFigure).extents
    Hf = view.fig.bbox.height
    assert px[:, 0].min() >= x0 and px[:, 0].max() <= x1 and px[:, 1].min() >= Hf - y1 and px[:, 1].max() <= Hf - y0
    return np.ptp(px[:, 0]) / (x1 - x0), np.ptp(px[:, 1]) / (y1 - y0)


def test_markers_are_framed_on_their_extent():
    """A 6 m walk (a long, flat extent): the markers' box fills the panel in one direction, at equal aspect."""
    times = np.arange(101) / 20.0
    pos = np.zeros((101, 4, 3))
    for m, (dy, z) in enumerate(((0, 100), (300, 100), (0, 1700), (300, 1700))):
        pos[:, m] = np.c_[-3000 + 1200 * times, 0 * times + dy, 0 * times + z]
    scene = trail_scene()
    scene["panels"][0] |= {"times": encode_array(times, "float64"), "positions": encode_array(pos), "fitted": None,
                           "knots": [], "labels": list("abcd")}
    scene["timeline"]["times"] = encode_array(times, "float64")
    view = SceneFigure(scene, 960, 540)
    view.show(2.0)
    assert np.array_equal(view.render(), view.render_full())
    assert max(marker_coverage(view)) > 0.7  # 0.35 in mplot3d's square with a 6% margin
    ax = view.views[0].ax  # square units on screen: equal aspect
    assert ax.viewLim.width / ax.bbox.width == pytest.approx(ax.viewLim.height / ax.bbox.height, rel=1e-6)
    # a body at one time is drawn large: its 1.6 m height over a quarter of the panel's height
    body = projected(ax, pos[40])
    assert np.ptp(body[:, 1]) > 0.25 * ax.bbox.height


@pytest.mark.parametrize("name", ["c3d/vicon-nexus-walking2.c3d", "juggling/5-ball-juggling-qualisys-300hz.tsv"])
def test_real_markers_are_framed_on_their_extent(shared_data, name):
    from mocapkit.view.scene import build_scene

    view = SceneFigure(build_scene([shared_data / name]), 960, 540)
    view.show(1.0)
    view.render()
    assert max(marker_coverage(view)) > 0.7


# --- MP4 -------------------------------------------------------------------------------------------

needs_ffmpeg = pytest.mark.skipif(shutil.which("ffmpeg") is None or shutil.which("ffprobe") is None,
                                  reason="ffmpeg/ffprobe not installed (Debian: apt install ffmpeg)")


@needs_ffmpeg
def test_mp4_is_a_real_video(tmp_path):
    out = tmp_path / "v.mp4"
    r = export_scene(skeleton_scene(n=41, rate=20.0), out, fps=10, width_px=W, height_px=H)
    probe = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                            "stream=codec_name,width,height,nb_read_frames,pix_fmt,r_frame_rate", "-of", "json",
                            str(out)], capture_output=True, text=True, check=True)
    st = json.loads(probe.stdout)["streams"][0]
    assert st["codec_name"] == "h264" and st["pix_fmt"] == "yuv420p"
    assert (st["width"], st["height"]) == (W, H)
    assert int(st["nb_read_frames"]) == r["frames_written"] == 21
    assert st["r_frame_rate"] == "10/1"
    assert r["format"] == "mp4" and r["bytes"] == out.stat().st_size > 1000
    assert os.listdir(tmp_path) == ["v.mp4"]


# --- refusals and failures --------------------------------------------------------------------------------

@pytest.mark.parametrize("name, kwargs, words", [
    ("a.avi", {}, ["'.avi'", ".gif or .mp4"]),
    ("a", {}, ["no suffix"]),
    ("missing/a.gif", {}, ["does not exist"]),
    ("a.gif", {"frames": (5, 3)}, ["empty"]),
    ("a.gif", {"frames": (5, 5)}, ["empty"]),
    ("a.gif", {"frames": (0, 42)}, ["outside", "0..40"]),
    ("a.gif", {"frames": (-1, 4)}, ["outside"]),
    ("a.gif", {"fps": 60}, ["at most 50"]),
    ("a.gif", {"fps": 0}, ["--fps"]),
    ("a.mp4", {"width_px": 321}, ["odd"]),
    ("a.gif", {"height_px": 10}, ["height"]),
    ("a.gif", {"trail_s": 0}, ["trail", "positive"]),
    ("a.gif", {"trail_s": float("nan")}, ["trail"]),
    ("a.gif", {"follow": "yes"}, ["follow"]),
])
def test_bad_requests_are_refused_before_any_work(tmp_path, name, kwargs, words):
    rec = Recorder()
    with pytest.raises(InvalidParameterError) as e:
        export_scene(skeleton_scene(), tmp_path / name, progress=rec, **kwargs)
    assert all(w in str(e.value) for w in words), str(e.value)
    assert rec.opened == [] and os.listdir(tmp_path) == []


def test_output_that_is_an_input_is_refused(tmp_path):
    src = tmp_path / "walk.gif"
    src.write_bytes(b"an input")
    with pytest.raises(InvalidParameterError, match="input file"):
        export_scene(skeleton_scene(), src, inputs=[src])
    assert src.read_bytes() == b"an input"


def test_no_window_and_no_pyplot(tmp_path):
    """Even with a GUI backend asked for (MPLBACKEND=TkAgg) and no display, the export draws on Agg
    only: neither pyplot nor a GUI toolkit is imported."""
    import sys

    code = ("import sys; from pathlib import Path; sys.path.insert(0, sys.argv[2]); "
            "from test_view_export import skeleton_scene; from mocapkit.view.export import export_scene; "
            "export_scene(skeleton_scene(), Path(sys.argv[1]), fps=5, width_px=160, height_px=100); "
            "print([m for m in sys.modules if m.split('.')[0] in ('tkinter', 'PyQt5', 'PyQt6', 'PySide6', 'gi', "
            "'wx') or m in ('matplotlib.pyplot', 'matplotlib.backends.backend_tkagg')])")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MPLBACKEND"] = "TkAgg"
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "w.gif"), str(Path(__file__).parent)],
                       check=False, capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]" and (tmp_path / "w.gif").stat().st_size > 0


def test_output_that_is_a_folder_is_refused(tmp_path):
    (tmp_path / "d.gif").mkdir()
    with pytest.raises(MocapError, match="folder"):
        export_scene(skeleton_scene(), tmp_path / "d.gif")


def test_missing_ffmpeg_is_named_before_any_work(tmp_path, monkeypatch):
    import matplotlib as mpl

    monkeypatch.setitem(mpl.rcParams, "animation.ffmpeg_path", str(tmp_path / "no-such-ffmpeg"))
    rec = Recorder()
    with pytest.raises(MocapError) as e:
        export_scene(skeleton_scene(), tmp_path / "v.mp4", width_px=W, height_px=H, progress=rec)
    assert "ffmpeg" in str(e.value) and "apt install ffmpeg" in str(e.value) and ".gif" in str(e.value)
    assert rec.opened == [] and os.listdir(tmp_path) == []


def test_malformed_scene_is_a_format_error(tmp_path):
    scene = skeleton_scene()
    del scene["panels"][1]["positions"]
    with pytest.raises(MocapFormatError, match="positions"):
        export_scene(scene, tmp_path / "a.gif", width_px=W, height_px=H)
    scene = skeleton_scene()
    scene["panels"][0]["positions"]["shape"] = [41, 5, 3]
    with pytest.raises(MocapFormatError, match="bytes"):
        export_scene(scene, tmp_path / "a.gif", width_px=W, height_px=H)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("suffix", [".gif", pytest.param(".mp4", marks=needs_ffmpeg)])
@pytest.mark.parametrize("exc", [KeyboardInterrupt, RuntimeError])
def test_a_failure_leaves_no_temporary_and_the_old_file(tmp_path, suffix, exc):
    out = tmp_path / f"v{suffix}"
    with pytest.raises(exc):
        export_scene(skeleton_scene(), out, fps=10, width_px=W, height_px=H, progress=Recorder(raise_at=3, exc=exc))
    assert os.listdir(tmp_path) == []
    assert running_children("ffmpeg") == [], "ffmpeg left running"
    out.write_bytes(b"old")
    with pytest.raises(exc):
        export_scene(skeleton_scene(), out, fps=10, width_px=W, height_px=H, progress=Recorder(raise_at=3, exc=exc))
    assert os.listdir(tmp_path) == [out.name] and out.read_bytes() == b"old"
    export_scene(skeleton_scene(), out, fps=10, width_px=W, height_px=H)  # and a clean run replaces it
    assert os.listdir(tmp_path) == [out.name] and out.read_bytes()[:3] != b"old"


def test_ffmpeg_failing_is_a_mocap_error(tmp_path, monkeypatch):
    import matplotlib as mpl

    fake = tmp_path / "bin" / "ffmpeg"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\ncat > /dev/null\necho 'Unknown encoder h264' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setitem(mpl.rcParams, "animation.ffmpeg_path", str(fake))
    out = tmp_path / "out" / "v.mp4"
    out.parent.mkdir()
    with pytest.raises(MocapError, match="ffmpeg failed: Unknown encoder h264"):
        export_scene(skeleton_scene(), out, fps=10, width_px=W, height_px=H)
    assert os.listdir(out.parent) == []


# --- real scenes from the sample files --------------------------------------------------------------------

def _run_cli(*args) -> str:
    """``mocapkit ARGS`` in-process; its stdout (a failure fails the test with its stderr)."""
    from mocapkit import cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            cli.main([str(a) for a in args])
        except SystemExit as e:
            assert not e.code, err.getvalue()
    return out.getvalue()


def _bvh_frames(path: Path) -> tuple[int, float]:
    text = path.read_text()
    n = int(text.split("Frames:")[1].split()[0])
    dt = float(text.split("Frame Time:")[1].split()[0])
    return n, dt


def test_real_walk_and_its_clip(tmp_path):
    from mocapkit.view.scene import build_scene

    bvh = DATA / "bvh" / "walk-meredith-60.bvh"
    scene = build_scene([bvh, DATA / "clip" / "walk-meredith-60.mkc"])
    n, dt = _bvh_frames(bvh)
    r = export_scene(scene, tmp_path / "w.gif", fps=25, width_px=W, height_px=H)
    frames, delays, size = gif_frames(tmp_path / "w.gif")
    assert size == (W, H) and set(delays) == {40}
    assert len(frames) == r["frames_written"] == math.floor((n - 1) * dt * 25 + 1e-6) + 1
    view = SceneFigure(scene, W, H)
    view.render()
    rr, cc = rows_cols(view.views[1].ax)
    assert all(np.abs(a[rr, cc] - b[rr, cc]).sum() > 0 for a, b in itertools.pairwise(frames))


def test_real_imu_with_its_packets_and_markers_with_their_fit(tmp_path):
    from mocapkit.view.scene import build_scene

    mkp = tmp_path / "xio.mkp"
    _run_cli("compress", DATA / "xio", "--max-angle", "2", "-o", mkp)
    tsv = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"
    fit = tmp_path / "fit.json"
    fit.write_text(_run_cli("filter", tsv, "--markers", "unnamed_6,unnamed_7", "--auto", "--json"))
    scene = build_scene([DATA / "xio", mkp])
    r = export_scene(scene, tmp_path / "imu.gif", fps=10, width_px=W, height_px=H, frames=(0, 61))
    first = scene["panels"][0]["sensors"][0]["name"]  # the timeline's sensor; its file's times in microseconds
    times = np.genfromtxt(DATA / "xio" / first / "Quaternion.csv", delimiter=",", skip_header=1)[:, 0] / 1e6
    assert r["frames_written"] == math.floor((times[60] - times[0]) * 10 + 1e-6) + 1
    assert len(gif_frames(tmp_path / "imu.gif")[0]) == r["frames_written"]
    scene = build_scene([tsv], filter_json=fit)
    r = export_scene(scene, tmp_path / "m.gif", fps=50, width_px=W, height_px=H)
    assert r["frames_written"] == math.floor(119 / 300 * 50 + 1e-6) + 1
    assert len(gif_frames(tmp_path / "m.gif")[0]) == r["frames_written"]
    assert sorted(os.listdir(tmp_path)) == ["fit.json", "imu.gif", "m.gif", "xio.mkp"]


def test_the_command_checks_the_export_before_reading_the_files(tmp_path):
    """A wrong suffix or a GIF's fps is named before the inputs are read (a garbage input is not reached)."""
    from mocapkit import cli

    bad = tmp_path / "garbage.bvh"
    bad.write_bytes(b"not a BVH\n")
    for args, words in ((["--export", tmp_path / "v.avi"], "unknown video format"),
                        (["--export", tmp_path / "v.gif", "--fps", "60"], "at most 50")):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()), \
                pytest.raises(SystemExit) as e:
            cli.main([str(a) for a in ["view", bad, *args]])
        assert e.value.code == 2 and words in err.getvalue() and "garbage.bvh" not in err.getvalue(), err.getvalue()
    assert sorted(os.listdir(tmp_path)) == ["garbage.bvh"]


def test_the_command_passes_follow_and_trail_and_refuses_them_without_export(tmp_path):
    bvh = Path(__file__).parent / "data" / "bvh" / "walk-meredith-60.bvh"
    tsv = Path(__file__).parent / "data" / "markers" / "juggling-qualisys-300hz-first120.tsv"

    def run(*args):
        return subprocess.run([sys.executable, "-m", "mocapkit", "view", *map(str, args)], capture_output=True,
                              text=True, timeout=300, check=False)

    r = run(bvh, "--export", tmp_path / "f.gif", "--follow", "--fps", "10")
    assert r.returncode == 0, r.stderr
    r = run(tsv, "--export", tmp_path / "t.gif", "--trail", "all", "--fps", "10")
    assert r.returncode == 0, r.stderr
    from PIL import Image

    with Image.open(tmp_path / "f.gif") as a, Image.open(tmp_path / "t.gif") as b:
        assert a.n_frames >= 5 and b.n_frames >= 3
    for bad in (["--trail", "0"], ["--trail", "soon"]):
        r = run(tsv, "--export", tmp_path / "x.gif", *bad)
        assert r.returncode == 2 and "--trail" in r.stderr
    r = run(bvh, "--follow", "--no-browser")
    assert r.returncode == 2 and "--export" in r.stderr
    assert not (tmp_path / "x.gif").exists()


def test_keyframe_ticks_outside_the_exported_window_are_not_drawn():
    """The ticks hang outside the axes (unclipped): only the keyframes within the window may be drawn."""
    scene = imu_scene(2)
    kf = (np.arange(41) / 20.0)[3::7]
    view = SceneFigure(scene, 960, 540, window=(0.5, 1.2))
    for sv in view.views[:2]:
        assert np.array_equal(sv.keyframes.get_xdata(), kf[(kf >= 0.5) & (kf <= 1.2)])
