"""The viewer's page in headless Chromium, served by the real command (`mocapkit view ... --no-browser
--port 0`): it loads with no console error and no request leaving 127.0.0.1, shows the file's frame count,
scrubbing (the range input, a click on the strip, the space key) changes the frame and the pose, and
screenshots have the skeleton, the IMU bodies and error plot, and the markers drawn where they project.

Frame counts and times come from `mocapkit.load` (not from the page); the screen positions of the points
come from the page's test hook `window.mocapkitView.jointScreenPositions` and are checked against the
screenshot's pixels and against the data's vertical axis (higher in the file = higher on the screen)."""

from __future__ import annotations

import io
import json
import re
import select
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest

try:
    from playwright.sync_api import sync_playwright
except ImportError:  # pragma: no cover - depends on the machine
    pytest.skip("Python playwright is not installed (pip install playwright; the browser is Debian's chromium)",
                allow_module_level=True)

CHROMIUM = Path("/usr/bin/chromium")
if not CHROMIUM.is_file():  # pragma: no cover - depends on the machine
    pytest.skip(f"{CHROMIUM} is missing (apt-get install chromium)", allow_module_level=True)

import mocapkit  # noqa: E402 - after the module-level skips

DATA = Path(__file__).parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
CLIP = DATA / "clip" / "walk-meredith-60.mkc"
IMU = DATA / "xio" / "pelvis"
MARKERS = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"
AMC = DATA / "cmu" / "86_01_15hz_first1600.amc"  # the subject walks about 1.9 body heights
ASF = DATA / "cmu" / "86.asf"
#: WebGL on the CPU (SwiftShader through ANGLE): no GPU is needed, and unlike --disable-gpu the canvas is not
#: read back with a driver performance warning on the console
LAUNCH_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-quic",
               "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 800}
#: a sensor name too long for its error plot's title
LONG_SENSOR = "s3-right-upper-arm-lateral-segment-sensor"


def _run_cli(*args: str) -> str:
    out = subprocess.run([sys.executable, "-m", "mocapkit", *args], capture_output=True, text=True, timeout=300,
                         check=False)
    assert out.returncode == 0, out.stderr
    return out.stdout


class Served:
    """`mocapkit view ARGS --no-browser --port 0` in a subprocess; `url` from its `serving on` line."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen([sys.executable, "-m", "mocapkit", "view", *args, "--no-browser", "--port", "0"],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], 120)
        line = self.proc.stdout.readline() if ready else ""
        m = re.fullmatch(r"serving on (http://127\.0\.0\.1:(\d+)/)\n", line)
        if m is None:
            self.stop()
            pytest.fail(f"no 'serving on' line from mocapkit view: {line!r}; stderr: {self.stderr}")
        self.url, self.port = m.group(1), int(m.group(2))

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            _, self.stderr = self.proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, self.stderr = self.proc.communicate()
            pytest.fail("mocapkit view did not stop on SIGTERM")
        return self.proc.returncode


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=LAUNCH_ARGS, headless=True)
        yield b
        b.close()


def _serve(request, *args):
    served = Served(*args)

    def finish():
        rc = served.stop()
        assert rc == 0, f"mocapkit view exited with {rc} on SIGTERM: {served.stderr}"

    request.addfinalizer(finish)
    return served


@pytest.fixture(scope="module")
def skeleton_server(request, tmp_path_factory):
    seg = tmp_path_factory.mktemp("view-skeleton") / "seg.json"
    seg.write_text(_run_cli("segment", str(BVH), "--method", "auto", "--json"))
    served = _serve(request, str(BVH), str(CLIP), "--segments", str(seg))
    served.segments = json.loads(seg.read_text())
    return served


@pytest.fixture(scope="module")
def imu_server(request, tmp_path_factory):
    mkp = tmp_path_factory.mktemp("view-imu") / "pelvis.mkp"
    _run_cli("compress", str(IMU), "--max-angle", "2", "-o", str(mkp))
    return _serve(request, str(IMU), str(mkp))


@pytest.fixture(scope="module")
def marker_server(request, tmp_path_factory):
    fit = tmp_path_factory.mktemp("view-markers") / "fit.json"
    fit.write_text(_run_cli("filter", str(MARKERS), "--markers", "unnamed_6,unnamed_7,unnamed_8", "--auto", "--json"))
    return _serve(request, str(MARKERS), "--filter", str(fit))


@pytest.fixture(scope="module")
def walking_server(request, tmp_path_factory):
    """The travelling AMC excerpt and its compressed clip."""
    clip = tmp_path_factory.mktemp("view-walk") / "86.mkc"
    _run_cli("compress", str(AMC), "--asf", str(ASF), "--rate", "15", "--max-position-error", "1", "-o", str(clip))
    return _serve(request, str(AMC), str(clip), "--asf", str(ASF), "--rate", "15")


def _write_qtm_tsv(path: Path, rate: float, names: list[str], positions: np.ndarray) -> None:
    """A QTM 3-D TSV of `positions` (n, M, 3) in mm."""
    n = positions.shape[0]
    lines = [f"NO_OF_FRAMES\t{n}", f"NO_OF_MARKERS\t{len(names)}", f"FREQUENCY\t{rate:g}", "DATA_INCLUDED\t3D",
             "MARKER_NAMES\t" + "\t".join(names), "Frame\tTime\t" + "\t".join(f"{m} {a}" for m in names for a in "XYZ")]
    for k in range(n):
        lines.append(f"{k + 1}\t{k / rate:.5f}\t" + "\t".join(f"{v:.3f}" for v in positions[k].ravel()))
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def long_marker_server(request, tmp_path_factory):
    """8 s at 100 Hz: a ball circling and bouncing every 0.8 s, a hand, a fixed base; ball and hand fitted."""
    folder = tmp_path_factory.mktemp("view-long-markers")
    t = np.arange(800) / 100.0
    ball = np.stack([400 * np.cos(2 * np.pi * t / 2.5), 300 * np.sin(2 * np.pi * t / 2.5),
                     1000 + 500 * np.abs(np.sin(np.pi * t / 0.8))], 1)
    hand = np.stack([300 * np.cos(2 * np.pi * t / 4) + 100, -200 + 50 * np.sin(2 * np.pi * t),
                     900 + 30 * np.sin(4 * np.pi * t)], 1)
    base = np.tile([-300.0, 250.0, 50.0], (len(t), 1))
    tsv = folder / "long.tsv"
    _write_qtm_tsv(tsv, 100.0, ["ball", "hand", "base"], np.stack([ball, hand, base], 1))
    fit = folder / "fit.json"
    fit.write_text(_run_cli("filter", str(tsv), "--markers", "ball,hand", "--auto", "--json"))
    served = _serve(request, str(tsv), "--filter", str(fit))
    served.tsv, served.fit = tsv, json.loads(fit.read_text())
    return served


@pytest.fixture(scope="module")
def imu_grid_server(request, tmp_path_factory):
    """Seven sensors (copies of the two xio excerpts) and their compressed points."""
    import shutil

    folder = tmp_path_factory.mktemp("view-imu-grid")
    sensors = folder / "body"
    for i in range(7):
        shutil.copytree(DATA / "xio" / ("pelvis" if i % 2 else "left-foot"),
                        sensors / (LONG_SENSOR if i == 3 else f"s{i}"))
    mkp = folder / "body.mkp"
    _run_cli("compress", str(sensors), "--max-angle", "2", "-o", str(mkp))
    return _serve(request, str(sensors), str(mkp))


def _wait(page, expr: str, timeout: float) -> int:
    """Evaluate the JS expression `expr` until it is truthy (at most `timeout` s); the number of evaluations.

    Not `page.wait_for_function`: its polling evaluates a string in the page, which the page's CSP (no
    'unsafe-eval') refuses; `page.evaluate` goes through the DevTools protocol, which the CSP does not govern."""
    deadline = time.monotonic() + timeout
    polls = 0
    while True:
        polls += 1
        if page.evaluate(expr):
            return polls
        if time.monotonic() > deadline:
            pytest.fail(f"not true within {timeout} s: {expr}")
        page.wait_for_timeout(50)


class Page:
    """A fresh page on `served.url` with every console message, page error and request recorded;
    with `block_outside`, a route aborts (and records) every request not to 127.0.0.1; `setup(page)` runs
    before the page is opened. `polls`: how many times readiness was checked."""

    def __init__(self, browser, served, block_outside=False, setup=None):
        self.context = browser.new_context(viewport=VIEWPORT, device_scale_factor=1)
        self.page = self.context.new_page()
        self.console, self.page_errors, self.requests, self.blocked = [], [], [], []

        def on_console(msg):
            if msg.type in ("error", "warning"):
                self.console.append(f"{msg.type}: {msg.text}")

        self.page.on("console", on_console)
        self.page.on("pageerror", lambda e: self.page_errors.append(str(e)))
        self.page.on("request", lambda r: self.requests.append(r.url))
        if block_outside:
            def route(r):
                if urlsplit(r.request.url).hostname != "127.0.0.1":
                    self.blocked.append(r.request.url)
                    r.abort()
                else:
                    r.continue_()

            self.page.route("**/*", route)
        if setup is not None:
            setup(self.page)
        self.page.goto(served.url)
        self.polls = _wait(self.page, "window.mocapkitView.ready || window.mocapkitView.errors.length > 0", 60)

    def js(self, expr, arg=None):
        return self.page.evaluate(expr, arg)

    def problems(self):
        return self.console + self.page_errors + self.js("window.mocapkitView.errors")

    def frame_text(self) -> int:
        return int(self.page.text_content("#frame"))

    def positions(self, panel: str) -> list:
        return self.js("(id) => window.mocapkitView.jointScreenPositions(id)", panel)

    def scrub(self, frame: int) -> None:
        self.page.eval_on_selector(
            "#scrub", "(el, v) => { el.value = String(v); el.dispatchEvent(new Event('input', {bubbles: true})); }",
            frame)

    def screenshot(self) -> np.ndarray:
        return _png(self.page.screenshot())

    def close(self):
        self.context.close()


@pytest.fixture()
def open_page(browser):
    pages = []

    def opener(served, block_outside=False, setup=None):
        pages.append(Page(browser, served, block_outside, setup))
        return pages[-1]

    yield opener
    for p in pages:
        p.close()


def _png(data: bytes) -> np.ndarray:
    import matplotlib.image

    img = matplotlib.image.imread(io.BytesIO(data), format="png")
    return np.round(img[..., :3] * 255).astype(int)


def _rgb(hex_colour: str) -> np.ndarray:
    return np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)])


def _is_background(img, x, y, bg, tol=6) -> bool:
    return bool(np.abs(img[round(y), round(x)] - bg).max() <= tol)


def _drawn_fraction(img, points, bg) -> float:
    """Fraction of `points` ([x, y] or None) whose pixel differs from the background (None = skipped)."""
    pts = [p for p in points if p is not None]
    h, w = img.shape[:2]
    inside = [p for p in pts if 0 <= p[0] < w and 0 <= p[1] < h]
    assert len(inside) == len(pts), f"points off the screenshot: {set(map(tuple, pts)) - set(map(tuple, inside))}"
    return sum(not _is_background(img, x, y, bg) for x, y in inside) / len(inside)


def _canvas_rect(page: Page, selector: str) -> dict:
    return page.page.eval_on_selector(selector, "el => { const r = el.getBoundingClientRect(); "
                                                "return {x: r.left, y: r.top, w: r.width, h: r.height}; }")


def _assert_loads_clean(page: Page, served: Served):
    assert page.js("window.mocapkitView.ready") is True
    assert page.problems() == []
    hosts = {(urlsplit(u).hostname, urlsplit(u).port) for u in page.requests}
    assert hosts == {("127.0.0.1", served.port)}, page.requests
    paths = {urlsplit(u).path for u in page.requests}
    # the page, the scene and three.js (both files of the module and OrbitControls) were fetched
    assert {"/", "/scene.json", "/static/vendor/three/three.module.min.js", "/static/vendor/three/three.core.min.js",
            "/static/vendor/three/OrbitControls.js"} <= paths
    assert page.blocked == []


def _vertical_order(page: Page, panel: str, heights: np.ndarray) -> float:
    """Spearman correlation between the data's heights and the points' heights on the screen (-y)."""
    from scipy.stats import spearmanr

    pos = page.positions(panel)
    keep = [i for i, p in enumerate(pos) if p is not None]
    assert len(keep) >= 3
    return float(spearmanr(heights[keep], [-pos[i][1] for i in keep]).statistic)


# -------------------------------------------------------------------------------------------------- skeleton


def test_skeleton_page_loads_with_no_error_and_nothing_leaves_127(open_page, skeleton_server):
    page = open_page(skeleton_server)
    _assert_loads_clean(page, skeleton_server)
    # and again with every request to another host aborted: none was even attempted
    blocked = open_page(skeleton_server, block_outside=True)
    _assert_loads_clean(blocked, skeleton_server)
    assert blocked.js("window.mocapkitView.panels()") == [{"id": "p0", "kind": "skeleton"},
                                                          {"id": "p1", "kind": "skeleton"}]
    header = blocked.page.text_content("header")
    assert BVH.name in header and CLIP.name in header


def test_waiting_for_a_late_scene_under_the_pages_csp(open_page, skeleton_server):
    """/scene.json held back 1.5 s: the page is not ready at once, and the wait (polling through
    page.evaluate) sees it become ready with no CSP or other error."""
    held = []

    def setup(page):
        def late(route):
            held.append(time.monotonic())
            page.wait_for_timeout(1500)
            route.continue_()

        page.route("**/scene.json", late)

    start = time.monotonic()
    page = open_page(skeleton_server, setup=setup)
    assert len(held) == 1
    assert time.monotonic() - held[0] >= 1.5
    assert page.polls > 1  # not ready at the first look: the wait did wait
    assert page.js("window.mocapkitView.ready") is True and page.problems() == []
    assert page.js("window.mocapkitView.frames") == len(mocapkit.load(BVH).times)
    assert time.monotonic() - start < 60


def test_the_strip_draws_the_segments(open_page, skeleton_server):
    times = np.asarray(mocapkit.load(BVH).times)
    segments = skeleton_server.segments["segments"]
    assert segments
    page = open_page(skeleton_server)
    strip = _png(page.page.locator("#strip").screenshot())
    bg = _rgb(page.js("window.mocapkitView.background"))
    band = strip[: int(strip.shape[0] * 0.5)]  # the segments' band (the upper 55 % of the strip)
    coloured = np.abs(band - bg).max(axis=2) > 20
    w = strip.shape[1]
    for seg in segments:  # each segment's span of the strip is filled with its colour
        x0 = int((seg["t0"] - times[0]) / (times[-1] - times[0]) * w) + 3
        x1 = int((seg["t1"] - times[0]) / (times[-1] - times[0]) * w) - 3
        assert x1 > x0 and coloured[:, x0:x1].mean() > 0.9


def test_skeleton_frame_count_is_the_files(open_page, skeleton_server):
    n = len(mocapkit.load(BVH).times)
    page = open_page(skeleton_server)
    assert page.page.text_content("#frame-count") == str(n)
    assert page.js("window.mocapkitView.frames") == n
    assert page.page.get_attribute("#scrub", "max") == str(n - 1)
    assert page.frame_text() == 0


def test_scrubbing_changes_the_frame_and_the_pose(open_page, skeleton_server):
    times = np.asarray(mocapkit.load(BVH).times)
    n = len(times)
    page = open_page(skeleton_server)
    before = np.array(page.positions("p0"))
    k = (2 * n) // 3
    page.scrub(k)
    assert page.frame_text() == k and page.js("window.mocapkitView.frame()") == k
    assert float(page.page.text_content("#time")) == pytest.approx(times[k], abs=6e-4)
    after = np.array(page.positions("p0"))
    assert np.abs(after - before).max() > 3  # CSS pixels: the pose moved on the screen
    # a click on the strip at a quarter of its width: the frame nearest that time
    r = _canvas_rect(page, "#strip")
    page.page.mouse.click(r["x"] + 0.25 * r["w"], r["y"] + r["h"] / 2)
    t = times[0] + 0.25 * (times[-1] - times[0])
    expected = int(np.argmin(np.abs(times - t)))
    assert abs(page.frame_text() - expected) <= 1
    assert page.page.eval_on_selector("#scrub", "el => Number(el.value)") == page.frame_text()
    clicked = np.array(page.positions("p0"))
    assert np.abs(clicked - after).max() > 3
    # dragging along the strip to its end scrubs to the last frame
    page.page.mouse.move(r["x"] + 0.5 * r["w"], r["y"] + r["h"] / 2)
    page.page.mouse.down()
    page.page.mouse.move(r["x"] + r["w"] - 1, r["y"] + r["h"] / 2, steps=5)
    page.page.mouse.up()
    assert page.frame_text() >= n - 2


def test_the_range_keeps_its_place_as_the_readouts_change(open_page, skeleton_server):
    n = len(mocapkit.load(BVH).times)
    page = open_page(skeleton_server)

    def box():
        return page.page.locator("#scrub").bounding_box()

    first = box()
    assert first["width"] > 100
    for frame in (9, 10, n // 2, n - 1, 0):
        page.scrub(frame)
        assert page.frame_text() == frame
        assert box() == first, frame


@pytest.mark.parametrize("focus", ["body", "#scrub", "#play"])
def test_space_plays_and_pauses(open_page, skeleton_server, focus):
    page = open_page(skeleton_server)
    if focus == "body":
        page.page.locator("body").click(position={"x": 5, "y": 5})
    else:
        page.page.focus(focus)
    page.page.keyboard.press("Space")
    _wait(page.page, "window.mocapkitView.frame() > 0", 10)
    assert page.page.text_content("#play") == "pause"
    page.page.keyboard.press("Space")
    assert page.page.text_content("#play") == "play"
    f = page.frame_text()
    page.page.wait_for_timeout(300)
    assert page.frame_text() == f
    assert page.problems() == []


def test_screenshot_has_the_skeletons_drawn(open_page, skeleton_server):
    motion = mocapkit.load(BVH)
    fk = np.asarray(mocapkit.forward_kinematics(motion)[0])
    page = open_page(skeleton_server)
    bg = _rgb(page.js("window.mocapkitView.background"))
    for frame in (0, len(motion.times) // 2):
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        img = page.screenshot()
        for panel in ("p0", "p1"):
            pts = page.positions(panel)
            assert len(pts) == fk.shape[1]
            assert _drawn_fraction(img, pts, bg) >= 0.8, (panel, frame)
        # the file is y-up: the higher a joint in the file, the higher on the screen
        assert _vertical_order(page, "p0", fk[frame, :, 1]) > 0.9
        r = _canvas_rect(page, "#view3d canvas")
        corners = [(r["x"] + 4, r["y"] + 4), (r["x"] + r["w"] - 5, r["y"] + 4),
                   (r["x"] + 4, r["y"] + r["h"] - 5), (r["x"] + r["w"] - 5, r["y"] + r["h"] - 5)]
        assert all(_is_background(img, x, y, bg) for x, y in corners)


def test_side_by_side_skeletons_are_drawn_at_the_same_scale(open_page, skeleton_server):
    """The original and its decode (equal to well under a millimetre) side by side: the same height on the
    screen, so neither looks bigger for being nearer the camera."""
    page = open_page(skeleton_server)
    page.js("(i) => window.mocapkitView.setFrame(i)", 0)
    heights = []
    for panel in ("p0", "p1"):
        pts = np.array(page.positions(panel))
        heights.append(pts[:, 1].max() - pts[:, 1].min())
    assert min(heights) > 50
    assert max(heights) / min(heights) < 1.10, heights


def test_the_floor_grid_is_drawn_without_follow(open_page, skeleton_server):
    page = open_page(skeleton_server)
    assert not page.page.is_checked("#follow")
    r = _canvas_rect(page, "#view3d canvas")
    img = page.screenshot()[int(r["y"]):int(r["y"] + r["h"]), int(r["x"]):int(r["x"] + r["w"])]
    grid = np.zeros(img.shape[:2], bool)
    for colour in ("#2c313b", "#3a414e"):  # the floor's lines (viewer.js FLOOR, FLOOR_AXES)
        grid |= np.abs(img - _rgb(colour)).max(axis=2) <= 3
    assert grid.sum() > 1000, grid.sum()
    # under the feet: the floor is in the lower part of the view
    lowest = max(p[1] for pid in ("p0", "p1") for p in page.positions(pid)) - r["y"]
    assert grid[int(lowest) - 40:].sum() > 0.5 * grid.sum()


def test_overlay_puts_the_decode_on_the_original(open_page, skeleton_server):
    page = open_page(skeleton_server)
    side = (np.array(page.positions("p0")), np.array(page.positions("p1")))
    assert np.median(np.abs(side[0][:, 0] - side[1][:, 0])) > 50  # side by side: apart on the screen
    page.page.select_option("#layout", "overlay")
    over = (np.array(page.positions("p0")), np.array(page.positions("p1")))
    # the decode is within its bound (well under a millimetre here): on the same pixels as the original
    assert np.abs(over[0] - over[1]).max() < 2
    img = page.screenshot()
    assert _drawn_fraction(img, over[1], _rgb(page.js("window.mocapkitView.background"))) >= 0.8


# ------------------------------------------------------------------------------------------------------ IMU


def test_imu_page_loads_with_its_frame_count_and_error_plot(open_page, imu_server):
    n = len(mocapkit.load(IMU)["Quaternion"].times)
    page = open_page(imu_server, block_outside=True)
    _assert_loads_clean(page, imu_server)
    assert page.page.text_content("#frame-count") == str(n)
    plots = page.page.locator("canvas.error-plot")
    assert plots.count() == 1
    bg = _rgb(page.js("window.mocapkitView.background"))
    shot0 = _png(plots.first.screenshot())
    drawn = np.abs(shot0 - bg).max(axis=2) > 20
    assert drawn.mean() > 0.02  # the curve, the bound, the ticks, the text
    # the playhead moves with the frame: the plot changes, and so do the bodies
    bodies0 = page.positions("p0")
    page.scrub(n // 2)
    assert page.frame_text() == n // 2
    shot1 = _png(plots.first.screenshot())
    assert (np.abs(shot1 - shot0).max(axis=2) > 20).sum() > 20
    # the original's and the decode's bodies are drawn where their centres project
    img = page.screenshot()
    pts = page.positions("p0")
    assert len(pts) == 2 and pts == bodies0  # the bodies turn in place
    assert _drawn_fraction(img, pts, bg) == 1.0


def _face_colours(img: np.ndarray) -> np.ndarray:
    """Pixel counts of the bodies' reddish, greenish and bluish faces (not the orange outline, not text)."""
    r, g, b = (img[..., c].astype(float) for c in range(3))
    red = (r > 1.6 * g) & (np.abs(g - b) < 25) & (r > 50)
    green = (g > 1.4 * r) & (g > 1.4 * b) & (g > 50)
    blue = (b > 1.4 * r) & (b > 1.15 * g) & (b > 50)
    return np.array([red.sum(), green.sum(), blue.sum()])


def test_imu_original_and_decode_show_the_same_faces(open_page, imu_server):
    """The decode is within 2 degrees of the original: both bodies show the same faces, in the same
    proportions (a perspective view would show them from different sides)."""
    n = len(mocapkit.load(IMU)["Quaternion"].times)
    page = open_page(imu_server)
    for frame in (0, n // 3, (2 * n) // 3):
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        img = page.screenshot()
        (x0, y0), (x1, y1) = page.positions("p0")
        half = int(0.3 * np.hypot(x1 - x0, y1 - y0))
        crops = [img[int(y) - half:int(y) + half, int(x) - half:int(x) + half] for x, y in ((x0, y0), (x1, y1))]
        counts = [_face_colours(c) for c in crops]
        assert counts[0].sum() > 200, counts
        share = [c / c.sum() for c in counts]
        assert np.abs(share[0] - share[1]).max() < 0.08, (frame, counts)


def test_imu_error_plot_titles_and_keyframe_ticks(open_page, imu_grid_server):
    page = open_page(imu_grid_server)
    plots = page.page.locator("canvas.error-plot")
    assert plots.count() == 7
    long_plot = page.page.locator(f"canvas.error-plot[data-sensor='{LONG_SENSOR}']")
    drawn = long_plot.get_attribute("data-drawn-title")
    whole = long_plot.get_attribute("title")
    # the long name shortened, the summary (max error, keyframe count) kept whole
    assert whole.startswith(LONG_SENSOR + ": error") and re.search(r", \d+ keyframes$", whole)
    assert "…" in drawn and drawn.endswith(whole[len(LONG_SENSOR):]) and len(drawn) < len(whole)
    # keyframes: ticks under the axis, nothing yellow over the plot
    for i in range(plots.count()):
        img = _png(plots.nth(i).screenshot()).astype(float)
        h = img.shape[0]
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        yellow = (r > 60) & (g > 0.8 * r) & (b < 0.75 * g)
        assert yellow[16:h - 20].sum() == 0
        assert yellow[h - 20:h - 13].sum() > 5


# -------------------------------------------------------------------------------------------------- markers


def test_marker_page_draws_the_markers_where_they_project(open_page, marker_server):
    markers = mocapkit.load(MARKERS)
    n = len(markers.times)
    page = open_page(marker_server, block_outside=True)
    _assert_loads_clean(page, marker_server)
    assert page.page.text_content("#frame-count") == str(n)
    bg = _rgb(page.js("window.mocapkitView.background"))
    first = None
    for frame in (0, n // 2, n - 1):
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        pts = page.positions("p0")
        present = np.isfinite(markers.positions[frame]).all(axis=1)
        assert [p is not None for p in pts] == present.tolist()
        img = page.screenshot()
        assert _drawn_fraction(img, pts, bg) >= 0.8
        # the file is z-up: higher markers higher on the screen
        assert _vertical_order(page, "p0", markers.positions[frame, :, 2]) > 0.8
        if first is None:
            first = pts
    moved = [np.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(first, pts, strict=True)
             if a is not None and b is not None]
    assert max(moved) > 3


def test_markers_have_a_key_and_no_layout_or_follow(open_page, marker_server):
    page = open_page(marker_server)
    assert not page.page.is_visible("#layout") and not page.page.is_visible("#follow")
    assert page.page.is_visible("#trail") and page.page.input_value("#trail") == "1"
    key = page.page.locator(".legend .key li").all_text_contents()
    assert [k.split(" ")[0] for k in key] == ["markers", "trajectories", "fitted", "knots"]


def _trail_expected(times, positions, fit, labels, t, w):
    """Vertices of the trajectory and fitted lines and knots within [t - w, t + w], from the files."""
    inside = (times >= t - w) & (times <= t + w)
    finite = np.isfinite(positions).all(axis=2)
    both = inside[1:, None] & inside[:-1, None]
    trajectory = 2 * int((both & finite[1:] & finite[:-1]).sum())
    fitted = knots = 0
    for entry in fit:
        m = labels.index(entry["name"])
        span = (times >= entry["pieces"][0]["t0"] - 1e-9) & (times <= entry["pieces"][-1]["t1"] + 1e-9)
        ok = span & finite[:, m]
        fitted += 2 * int((both[:, 0] & ok[1:] & ok[:-1]).sum())
        kt = np.array([p["t0"] for p in entry["pieces"][1:]])
        knots += int(((kt >= t - w) & (kt <= t + w)).sum())
    return {"trajectory": trajectory, "fitted": fitted, "knots": knots}


def test_the_trail_draws_only_the_window_around_the_current_time(open_page, long_marker_server):
    markers = mocapkit.load(long_marker_server.tsv)
    times = np.asarray(markers.times)
    labels = list(markers.labels)
    fit = long_marker_server.fit
    n = len(times)
    page = open_page(long_marker_server)
    assert page.problems() == []
    bg = _rgb(page.js("window.mocapkitView.background"))
    r = _canvas_rect(page, "#view3d canvas")
    drawn = {}
    for choice, w in (("0.5", 0.5), ("1", 1.0), ("3", 3.0), ("all", np.inf)):
        page.page.select_option("#trail", choice)
        for frame in (0, 333, n - 1):
            page.js("(i) => window.mocapkitView.setFrame(i)", frame)
            got = page.js("window.mocapkitView.drawnTrail('p0')")
            assert got == _trail_expected(times, markers.positions, fit, labels, times[frame], w), (choice, frame)
        img = page.screenshot()[int(r["y"]):int(r["y"] + r["h"]), int(r["x"]):int(r["x"] + r["w"])]
        drawn[choice] = int((np.abs(img - bg).max(axis=2) > 12).sum())
    assert got["knots"] == sum(len(e["pieces"]) - 1 for e in fit) > 5  # all of them with "all"
    # fewer pixels of lines and knots the narrower the window (frame n - 1: half a window before it)
    assert drawn["0.5"] * 1.3 < drawn["1"] and drawn["1"] * 1.3 < drawn["3"] and drawn["3"] < drawn["all"]
    assert page.problems() == []


def _centre_and_height(page: Page, panels=("p0", "p1")):
    """The centre of the joints' screen box (fractions of the canvas from its centre) and the height of
    p0's joints (fraction of the canvas height)."""
    r = _canvas_rect(page, "#view3d canvas")
    pts = np.array([q for pid in panels for q in page.positions(pid) if q is not None])
    p0 = np.array([q for q in page.positions(panels[0]) if q is not None])
    cx = ((pts[:, 0].min() + pts[:, 0].max()) / 2 - r["x"] - r["w"] / 2) / r["w"]
    cy = ((pts[:, 1].min() + pts[:, 1].max()) / 2 - r["y"] - r["h"] / 2) / r["h"]
    return (cx, cy), (p0[:, 1].max() - p0[:, 1].min()) / r["h"]


def test_follow_keeps_a_travelling_skeleton_in_the_middle(open_page, walking_server):
    n = len(mocapkit.load(AMC, asf=ASF, rate=15).times)
    page = open_page(walking_server)
    assert page.problems() == []
    assert page.page.is_checked("#follow")  # on by default: the root travels far for the body's size
    frames = [0, n // 4, n // 2, (3 * n) // 4, n - 1]
    follow = []
    for frame in frames:
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        follow.append(_centre_and_height(page))
        img = page.screenshot()
        for panel in ("p0", "p1"):
            assert _drawn_fraction(img, page.positions(panel), _rgb(page.js("window.mocapkitView.background"))) >= 0.8
    off = np.hypot(*np.array([c for c, _ in follow]).T)
    height = np.array([h for _, h in follow])
    assert off.max() < 0.05, off  # the pair's centre stays in the middle of the view
    assert np.median(height) > 0.3, height  # framed on about one body
    # the whole take instead: the skeletons wander about the view and are drawn smaller
    page.page.click("#follow")
    whole = []
    for frame in frames:
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        whole.append(_centre_and_height(page))
    w_off = np.hypot(*np.array([c for c, _ in whole]).T)
    w_height = np.array([h for _, h in whole])
    assert w_off.max() > 0.12 and np.median(w_height) < 0.7 * np.median(height), whole
    # back to following, then orbit with the mouse: the view turns, and still follows
    page.page.click("#follow")
    page.js("(i) => window.mocapkitView.setFrame(i)", n // 2)
    before = np.array(page.positions("p0"))
    r = _canvas_rect(page, "#view3d canvas")
    page.page.mouse.move(r["x"] + r["w"] / 2, r["y"] + r["h"] / 2)
    page.page.mouse.down()
    page.page.mouse.move(r["x"] + r["w"] / 2 + 200, r["y"] + r["h"] / 2 + 40, steps=8)
    page.page.mouse.up()
    page.js("(i) => window.mocapkitView.setFrame(i)", 0)
    page.js("(i) => window.mocapkitView.setFrame(i)", n // 2)
    turned = np.array(page.positions("p0"))
    assert np.abs(turned - before).max() > 20  # the orbit was kept
    turned = []
    for frame in frames:
        page.js("(i) => window.mocapkitView.setFrame(i)", frame)
        turned.append(_centre_and_height(page)[0])
    # seen from elsewhere the pair's screen box is a little off the centre, but not wandering as without follow
    assert np.hypot(*np.array(turned).T).max() < 0.1, turned
    assert page.problems() == []


def test_follow_is_off_for_a_skeleton_that_stays_put(open_page, skeleton_server):
    page = open_page(skeleton_server)
    assert page.page.is_visible("#follow") and not page.page.is_checked("#follow")
    assert page.page.is_visible("#layout") and not page.page.is_visible("#trail")


def test_imu_sensors_in_a_grid_that_fits_the_view(open_page, imu_grid_server):
    page = open_page(imu_grid_server)
    assert page.problems() == []
    r = _canvas_rect(page, "#view3d canvas")
    pts = np.array(page.positions("p0"))  # original, decoded per sensor
    assert pts.shape == (14, 2)
    spacing = np.hypot(*(pts[1::2] - pts[0::2]).T)  # a sensor's original to its decode, on the screen
    margin = spacing.min() / 2
    assert (pts[:, 0] > r["x"] + margin).all() and (pts[:, 0] < r["x"] + r["w"] - margin).all()
    assert (pts[:, 1] > r["y"] + margin).all() and (pts[:, 1] < r["y"] + r["h"] - margin).all()
    columns = np.unique(np.round((pts[0::2, 0] - pts[0::2, 0].min()) / spacing.min()))
    assert len(columns) >= 2  # a grid, not one column
    assert spacing.min() > 0.09 * r["w"], spacing / r["w"]  # the bodies use the view
    img = page.screenshot()
    assert _drawn_fraction(img, pts.tolist(), _rgb(page.js("window.mocapkitView.background"))) == 1.0
