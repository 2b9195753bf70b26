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

import mocapkit

DATA = Path(__file__).parent / "data"
BVH = DATA / "bvh" / "walk-meredith-60.bvh"
CLIP = DATA / "clip" / "walk-meredith-60.mkc"
IMU = DATA / "xio" / "pelvis"
MARKERS = DATA / "markers" / "juggling-qualisys-300hz-first120.tsv"
#: WebGL on the CPU (SwiftShader through ANGLE): no GPU is needed, and unlike --disable-gpu the canvas is not
#: read back with a driver performance warning on the console
LAUNCH_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 800}


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


class Page:
    """A fresh page on `served.url` with every console message, page error and request recorded;
    with `block_outside`, a route aborts (and records) every request not to 127.0.0.1."""

    def __init__(self, browser, served, block_outside=False):
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
        self.page.goto(served.url)
        self.page.wait_for_function("() => window.mocapkitView.ready || window.mocapkitView.errors.length > 0",
                                    timeout=60_000)

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

    def opener(served, block_outside=False):
        pages.append(Page(browser, served, block_outside))
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


@pytest.mark.parametrize("focus", ["body", "#scrub", "#play"])
def test_space_plays_and_pauses(open_page, skeleton_server, focus):
    page = open_page(skeleton_server)
    if focus == "body":
        page.page.locator("body").click(position={"x": 5, "y": 5})
    else:
        page.page.focus(focus)
    page.page.keyboard.press("Space")
    page.page.wait_for_function("() => window.mocapkitView.frame() > 0", timeout=10_000)
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
    moved = [np.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(first, pts) if a is not None and b is not None]
    assert max(moved) > 3
