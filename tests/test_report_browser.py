"""End to end: the comparison report loads in headless Chromium without console errors and every picture decodes.

The page is opened through the DevTools protocol (``tests/browser.py``) so that exceptions, console errors, failed
loads and HTTP errors are collected as events, and the page's own view of its images (loaded, natural size) is read
back. Skipped cleanly when no Chromium is installed (``.ci/run`` can install Debian's ``chromium``; set
``CHROMIUM`` to use another binary).
"""
from __future__ import annotations

import functools
import http.server
import json
import threading
import urllib.request

import pytest

from ghserver import report as rp
from tests.browser import CHROMIUM, SKIP_REASON, Browser, load

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


def test_report_loads_from_file_without_console_errors(browser, report_dir):
    page, problems, state = load(browser, (report_dir / "report.html").resolve().as_uri())
    try:
        _check(problems, state, report_dir)
    finally:
        page.ws.close()


def test_report_loads_over_http_without_console_errors(browser, report_dir, http_report):
    page, problems, state = load(browser, http_report)
    try:
        _check(problems, state, report_dir)
    finally:
        page.ws.close()


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


def test_report_served_by_ghserver(browser, report_dir):
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
        finally:
            page.ws.close()
