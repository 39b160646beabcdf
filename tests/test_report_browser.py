"""End to end: the comparison report loads in headless Chromium without console errors, every picture decodes and
is shown large enough to read, and the interactive 3D views draw and orbit, from file:// and over HTTP.

The page is opened through the DevTools protocol (``tests/browser.py``) so that exceptions, console errors, failed
loads and HTTP errors are collected as events, and the page's own view of its images (loaded, natural size) is read
back. A 3D view is checked from a screenshot decoded with matplotlib: the canvas holds many colours (not the clear
colour), a synthetic mouse drag (``Input.dispatchMouseEvent``) changes the picture, and so do the stage and metric
controls. Skipped cleanly when no Chromium is installed (``.ci/run`` can install Debian's ``chromium``; set
``CHROMIUM`` to use another binary).
"""
from __future__ import annotations

import functools
import http.server
import json
import threading
import time
import urllib.request

import numpy as np
import pytest

from ghserver import report as rp
from tests.browser import CHROMIUM, SKIP_REASON, Browser, evaluate, event_problems, load, screenshot

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason=SKIP_REASON)

# ----------------------------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("browser_report")
    rp.run_report(out, quick=True, progress=False)
    return out


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless Chromium with a DevTools endpoint; yields its HTTP base URL; terminated afterwards."""
    with Browser(tmp_path_factory.mktemp("chromium_profile")) as b:
        yield b.base


@pytest.fixture
def http_report(report_dir):
    """The report folder served over HTTP on a free loopback port (as `ghserver serve --report-dir` would)."""
    handler = functools.partial(_QuietHandler, directory=str(report_dir))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/report.html"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _check(problems, state, report_dir):
    state = json.loads(state)
    assert not problems, "\n".join(problems)
    data = json.loads((report_dir / "report.json").read_text())
    assert state["title"].startswith("PQ strategies")
    assert state["charset"].lower() == "utf-8"
    assert state["mode"] == "CSS1Compat"  # standards mode: the doctype was recognised
    assert state["tables"] >= 1
    expected = {i["file"]: tuple(i["size"]) for r in data["results"] for i in r["images"]}
    expected.update({i["file"]: tuple(i["size"]) for i in data["comparisons"]})
    seen = {}
    for src, complete, w, h in state["images"]:
        assert complete and w > 0, f"{src} did not decode in the browser"
        seen[src] = (w, h)
    assert seen == expected


# ----------------------------------------------------------------------------------------------
# tests


def test_report_loads_from_file_without_console_errors(browser, report_dir, tmp_path):
    page, problems, state = load(browser, (report_dir / "report.html").resolve().as_uri())
    try:
        _check(problems, state, report_dir)
        _check_legible(page, report_dir)
        _check_3d_view(page, tmp_path, report_dir)
    finally:
        page.ws.close()


def test_report_loads_over_http_without_console_errors(browser, report_dir, http_report, tmp_path):
    page, problems, state = load(browser, http_report)
    try:
        _check(problems, state, report_dir)
        _check_3d_view(page, tmp_path, report_dir)
    finally:
        page.ws.close()


def test_3d_views_start_lazily_and_hold_few_webgl_contexts(browser, report_dir):
    """No view starts before it is scrolled to; scrolling past all of them (16 in the quick report) keeps at most
    ``MAX_LIVE`` WebGL contexts (Chromium drops the oldest beyond ~16), pausing the others with a still picture,
    and a paused view resumes when scrolled to again."""
    page, problems, _ = load(browser, (report_dir / "report.html").resolve().as_uri())
    try:
        assert not problems
        page.call("Emulation.setDeviceMetricsOverride", width=1280, height=900, deviceScaleFactor=1, mobile=False)
        data = json.loads((report_dir / "report.json").read_text())
        ids = [r["view"]["id"] for r in data["results"] if "id" in (r.get("view") or {})]
        assert len(ids) == sum(r["status"] != "failed" for r in data["results"]) > rp_max_live(page)
        assert evaluate(page, "document.querySelectorAll('canvas').length") == 0
        for vid in ids:
            _start(page, vid)
            assert evaluate(page, "document.querySelectorAll('canvas').length") <= rp_max_live(page)
        states = json.loads(evaluate(page, "JSON.stringify(Array.from(document.querySelectorAll('.viewer3d'))"
                                           ".map(v => v.dataset.state))"))
        assert states.count("ready") == rp_max_live(page) and states.count("paused") == len(ids) - rp_max_live(page)
        assert evaluate(page, "document.querySelectorAll('.v-start img').length") == len(ids) - rp_max_live(page)
        _start(page, ids[0])  # paused first: resumes
        assert evaluate(page, f"document.getElementById('view-{ids[0]}').dataset.state") == "ready"
        assert not _problems(page), _problems(page)
    finally:
        page.ws.close()


def rp_max_live(page) -> int:
    return evaluate(page, "PQViewer.MAX_LIVE")


def _problems(page) -> list[str]:
    """Errors among the page's events so far (as ``load`` collects them), and Chromium's WebGL-context warnings."""
    return event_problems(page.events, also_log="WebGL contexts")


def _start(page, vid: str, timeout: float = 60.0) -> None:
    """Scroll a view into sight and wait until it has drawn."""
    evaluate(page, f"document.getElementById('view-{vid}').scrollIntoView({{block: 'center'}}); 1")
    end = time.monotonic() + timeout
    state = None
    while time.monotonic() < end:
        state = evaluate(page, f"document.getElementById('view-{vid}').dataset.state")
        if state in ("ready", "error"):
            break
        page.drain(0.1)
    assert state == "ready", (vid, state, evaluate(page, f"document.getElementById('view-{vid}').dataset.message"))
    page.drain(0.2)


def _canvas_pixels(page, vid: str, path) -> np.ndarray:
    """The view's canvas as an (h, w, 3) array of 0..255, from a screenshot of the page."""
    import matplotlib.image as mpimg

    rect = json.loads(evaluate(page, f"JSON.stringify(document.querySelector('#view-{vid} canvas')"
                                     ".getBoundingClientRect())"))
    screenshot(page, path, 1280, 900)
    img = mpimg.imread(path)[..., :3]
    x0, y0 = int(round(rect["x"])), int(round(rect["y"]))
    crop = img[max(y0, 0):y0 + int(rect["height"]), max(x0, 0):x0 + int(rect["width"])]
    assert crop.shape[0] > 300 and crop.shape[1] > 600, f"the canvas is not in the viewport: {rect}"
    return np.round(crop * 255).astype(np.int32)


def _colours(px: np.ndarray) -> int:
    return len(np.unique((px[..., 0] << 16 | px[..., 1] << 8 | px[..., 2]).ravel()))


def _changed(a: np.ndarray, b: np.ndarray) -> float:
    """Share of pixels that changed visibly."""
    return float(np.mean(np.any(np.abs(a - b) > 8, axis=-1)))


def _drag(page, x: float, y: float, dx: float, dy: float, steps: int = 10) -> None:
    page.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y)
    page.call("Input.dispatchMouseEvent", type="mousePressed", x=x, y=y, button="left", buttons=1, clickCount=1)
    for k in range(1, steps + 1):
        page.call("Input.dispatchMouseEvent", type="mouseMoved", x=x + dx * k / steps, y=y + dy * k / steps,
                  button="left", buttons=1)
    page.call("Input.dispatchMouseEvent", type="mouseReleased", x=x + dx, y=y + dy, button="left", buttons=0,
              clickCount=1)
    page.drain(0.3)


def _check_3d_view(page, tmp_path, report_dir) -> None:
    """A view with a candidate and an optimized mesh: drawn, orbits under a mouse drag, switches stage and
    metric; no console error on the way."""
    page.call("Emulation.setDeviceMetricsOverride", width=1280, height=900, deviceScaleFactor=1, mobile=False)
    data = json.loads((report_dir / "report.json").read_text())
    row = next(r for r in data["results"] if r["strategy"] == "subdivision" and len(r["meshes"]) == 2)
    vid = row["view"]["id"]
    _start(page, vid)
    first = _canvas_pixels(page, vid, tmp_path / "view1.png")
    background = np.array([0xF4, 0xF4, 0xF4])
    assert _colours(first) > 50, f"the canvas is nearly blank ({_colours(first)} colours)"
    assert 0.03 < float(np.mean(np.any(first != background, axis=-1))) < 0.97  # a mesh on the clear colour
    legend = evaluate(page, f"document.querySelector('#view-{vid} .v-legend').textContent")
    assert "planarity" in legend and "optimized" in legend
    rect = json.loads(evaluate(page, f"JSON.stringify(document.querySelector('#view-{vid} canvas')"
                                     ".getBoundingClientRect())"))
    _drag(page, rect["x"] + rect["width"] / 2, rect["y"] + rect["height"] / 2, 220, 70)
    orbited = _canvas_pixels(page, vid, tmp_path / "view2.png")
    assert _changed(first, orbited) > 0.02, "a mouse drag did not orbit the view"
    evaluate(page, f"(() => {{ const i = document.querySelector('#view-{vid} input[value=candidate]'); i.click(); "
                   "return i.checked; })()")
    page.drain(0.2)
    assert evaluate(page, f"document.getElementById('view-{vid}').dataset.stage") == "candidate"
    candidate = _canvas_pixels(page, vid, tmp_path / "view3.png")
    assert _changed(orbited, candidate) > 0.005, "the stage toggle did not change the picture"
    assert "candidate" in evaluate(page, f"document.querySelector('#view-{vid} .v-legend').textContent")
    evaluate(page, f"(() => {{ const s = document.querySelector('#view-{vid} .v-metric'); s.value = 'area'; "
                   "s.dispatchEvent(new Event('change')); return 1; })()")
    page.drain(0.2)
    area = _canvas_pixels(page, vid, tmp_path / "view4.png")
    assert _changed(candidate, area) > 0.01, "colouring by another metric did not change the picture"
    assert "panel area" in evaluate(page, f"document.querySelector('#view-{vid} .v-legend').textContent")
    assert not _problems(page), _problems(page)


def _check_legible(page, report_dir) -> None:
    """At a 1280-pixel-wide window every picture is shown at a scale where its smallest text is >= 11 px."""
    page.call("Emulation.setDeviceMetricsOverride", width=1280, height=900, deviceScaleFactor=1, mobile=False)
    page.drain(0.2)
    data = json.loads((report_dir / "report.json").read_text())
    font = {i["file"]: i["min_font_px"] for r in data["results"] for i in r["images"]}
    font.update({i["file"]: i["min_font_px"] for i in data["comparisons"]})
    shown = json.loads(evaluate(page, "JSON.stringify(Array.from(document.images).map(i => [i.getAttribute('src'), "
                                      "i.getBoundingClientRect().width, i.naturalWidth]))"))
    assert {src for src, _, _ in shown} == set(font)
    assert evaluate(page, "document.documentElement.scrollWidth") <= 1280  # no sideways scrolling
    for src, width, natural in shown:
        assert font[src] * width / natural >= 11.0, f"{src}: text {font[src] * width / natural:.1f} px"


def test_a_missing_picture_is_caught(browser, report_dir, tmp_path):
    """The harness itself: a page with a broken image and a script error is reported, not passed."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>x</title></head><body>'
                   '<img src="img/nope.png" alt="missing"><script>undefinedFunction();</script></body></html>')
    page, problems, state = load(browser, bad.resolve().as_uri())
    try:
        text = "\n".join(problems)
        assert "uncaught" in text
        assert "failed to load" in text or "nope.png" in text
    finally:
        page.ws.close()


def test_report_served_by_ghserver(browser, report_dir, tmp_path):
    """`ghserver serve --report-dir DIR`: the catalogue links the report and `/report` loads with its pictures.

    The pictures are linked relatively (``img/...``, so the file opens from disk too); under the server they
    resolve only when the page's URL ends in a slash, i.e. ``/report`` redirects to ``/report/``.
    """
    from ghserver.app import Config, create_app
    from tests.ghserver.conftest import LiveServer

    app = create_app(Config(report_dir=str(report_dir), workers=0, cache_size=0))
    with LiveServer(app) as srv:
        req = urllib.request.Request(srv.url + "/", headers={"Accept": "text/html"})
        with urllib.request.urlopen(req, timeout=30) as r:
            assert 'href="/report' in r.read().decode()
        with urllib.request.urlopen(srv.url + "/report", timeout=30) as r:  # follows the redirect to /report/
            assert r.status == 200 and r.geturl().endswith("/report/")
        page, problems, state = load(browser, srv.url + "/report")
        try:
            _check(problems, state, report_dir)
            _check_3d_view(page, tmp_path, report_dir)
        finally:
            page.ws.close()
