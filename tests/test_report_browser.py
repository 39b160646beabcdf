"""End to end: the comparison report loads in headless Chromium without console errors and every picture decodes.

The page is opened through the DevTools protocol (a tiny WebSocket client below, no extra dependency) so that
exceptions, console errors, failed loads and HTTP errors are collected as events, and the page's own view of its
images (loaded, natural size) is read back. Skipped cleanly when no Chromium is installed (``.ci/run`` can install
Debian's ``chromium``; set ``CHROMIUM`` to use another binary).
"""
from __future__ import annotations

import base64
import functools
import http.server
import json
import os
import shutil
import socket
import struct
import subprocess
import threading
import time
import urllib.request
from pathlib import Path
from urllib.parse import urlparse

import pytest

from ghserver import report as rp


def _chromium() -> str | None:
    env = os.environ.get("CHROMIUM")
    if env:
        return env if Path(env).is_file() else shutil.which(env)
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


CHROMIUM = _chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-default-apps", "--mute-audio", "--remote-debugging-address=127.0.0.1",
         "--remote-debugging-port=0"]


# ----------------------------------------------------------------------------------------------
# a minimal WebSocket client (RFC 6455: client frames masked, text frames, ping/pong, fragmentation)


class WebSocket:
    def __init__(self, url: str, timeout: float = 30.0):
        u = urlparse(url)
        self.sock = socket.create_connection((u.hostname, u.port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        path = u.path + (f"?{u.query}" if u.query else "")
        req = (f"GET {path} HTTP/1.1\r\nHost: {u.hostname}:{u.port}\r\nUpgrade: websocket\r\n"
               f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n")
        self.sock.sendall(req.encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(1)
            if not chunk:
                raise ConnectionError("WebSocket handshake: connection closed")
            head += chunk
        status = head.split(b"\r\n", 1)[0]
        if b" 101 " not in status + b" ":
            raise ConnectionError(f"WebSocket handshake refused: {status!r}")

    def _read(self, n: int) -> bytes:
        buf = b""
        while len(buf) < n:
            chunk = self.sock.recv(n - len(buf))
            if not chunk:
                raise ConnectionError("WebSocket closed")
            buf += chunk
        return buf

    def _send_frame(self, opcode: int, payload: bytes) -> None:
        header = bytes([0x80 | opcode])
        n = len(payload)
        if n < 126:
            header += bytes([0x80 | n])
        elif n < 1 << 16:
            header += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            header += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(header + mask + masked)

    def send(self, text: str) -> None:
        self._send_frame(0x1, text.encode())

    def recv(self, timeout: float | None = None) -> str | None:
        """Next text message, or None on timeout."""
        self.sock.settimeout(timeout)
        parts = []
        try:
            while True:
                b0, b1 = self._read(2)
                opcode, fin = b0 & 0x0F, b0 & 0x80
                n = b1 & 0x7F
                if n == 126:
                    n = struct.unpack(">H", self._read(2))[0]
                elif n == 127:
                    n = struct.unpack(">Q", self._read(8))[0]
                mask = self._read(4) if b1 & 0x80 else None
                data = self._read(n)
                if mask:
                    data = bytes(b ^ mask[i % 4] for i, b in enumerate(data))
                if opcode == 0x9:  # ping
                    self._send_frame(0xA, data)
                    continue
                if opcode == 0x8:
                    raise ConnectionError("WebSocket closed by the browser")
                if opcode in (0x0, 0x1, 0x2):
                    parts.append(data)
                    if fin:
                        return b"".join(parts).decode("utf-8", "replace")
        except socket.timeout:
            if parts:
                raise
            return None

    def close(self) -> None:
        try:
            self._send_frame(0x8, b"")
        except OSError:
            pass
        self.sock.close()


class Page:
    """A DevTools session on one page target: commands with ids, events collected."""

    def __init__(self, ws: WebSocket):
        self.ws = ws
        self.next_id = 0
        self.events: list[dict] = []

    def call(self, method: str, timeout: float = 30.0, **params):
        self.next_id += 1
        mid = self.next_id
        self.ws.send(json.dumps({"id": mid, "method": method, "params": params}))
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            msg = self.ws.recv(timeout=max(end - time.monotonic(), 0.01))
            if msg is None:
                break
            data = json.loads(msg)
            if data.get("id") == mid:
                if "error" in data:
                    raise RuntimeError(f"{method}: {data['error']}")
                return data.get("result", {})
            if "method" in data:
                self.events.append(data)
        raise TimeoutError(f"no answer to {method} in {timeout} s")

    def wait_for(self, method: str, timeout: float = 30.0) -> dict:
        for e in self.events:
            if e["method"] == method:
                return e
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            msg = self.ws.recv(timeout=max(end - time.monotonic(), 0.01))
            if msg is None:
                break
            data = json.loads(msg)
            if "method" in data:
                self.events.append(data)
                if data["method"] == method:
                    return data
        raise TimeoutError(f"no {method} event in {timeout} s")

    def drain(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            msg = self.ws.recv(timeout=max(end - time.monotonic(), 0.01))
            if msg is None:
                return
            data = json.loads(msg)
            if "method" in data:
                self.events.append(data)


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
    profile = tmp_path_factory.mktemp("chromium_profile")
    proc = subprocess.Popen([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, errors="replace")
    lines: list[str] = []
    found = threading.Event()
    endpoint = {}

    def pump():  # read stderr to the end so the browser never blocks on a full pipe
        for line in proc.stderr:
            lines.append(line)
            if "DevTools listening on" in line and not found.is_set():
                endpoint["ws"] = line.split("DevTools listening on", 1)[1].strip()
                found.set()

    t = threading.Thread(target=pump, daemon=True)
    t.start()
    try:
        if not found.wait(60):
            pytest.fail("Chromium did not open its DevTools endpoint in 60 s:\n" + "".join(lines[-20:]))
        u = urlparse(endpoint["ws"])
        yield f"http://{u.hostname}:{u.port}"
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)
        t.join(5)


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


def _open_page(base: str) -> Page:
    with urllib.request.urlopen(f"{base}/json/list", timeout=10) as r:
        targets = json.loads(r.read())
    page = next(t for t in targets if t.get("type") == "page")
    return Page(WebSocket(page["webSocketDebuggerUrl"]))


def _load(base: str, url: str) -> tuple[Page, list[str], dict]:
    page = _open_page(base)
    for domain in ("Runtime", "Log", "Page", "Network"):
        page.call(f"{domain}.enable")
    page.events.clear()
    page.call("Page.navigate", url=url)
    page.wait_for("Page.loadEventFired", timeout=60)
    page.drain(0.5)
    problems = []
    for e in page.events:
        m, p = e["method"], e.get("params", {})
        if m == "Runtime.exceptionThrown":
            problems.append(f"uncaught: {p['exceptionDetails'].get('text')} "
                            f"{p['exceptionDetails'].get('exception', {}).get('description', '')}")
        elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            problems.append(f"console.{p['type']}: {[a.get('value') for a in p.get('args', [])]}")
        elif m == "Log.entryAdded" and p["entry"].get("level") == "error":
            problems.append(f"log: {p['entry'].get('text')} {p['entry'].get('url', '')}")
        elif m == "Network.loadingFailed" and not p.get("canceled"):
            problems.append(f"failed to load: {p.get('errorText')} (request {p.get('requestId')})")
        elif m == "Network.responseReceived" and p["response"].get("status", 200) >= 400:
            problems.append(f"HTTP {p['response']['status']}: {p['response'].get('url')}")
    state = page.call("Runtime.evaluate", returnByValue=True, expression="""JSON.stringify({
        title: document.title,
        charset: document.characterSet,
        mode: document.compatMode,
        tables: document.querySelectorAll('table').length,
        images: Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth,
                                                     i.naturalHeight])})""")
    return page, problems, json.loads(state["result"]["value"])


def _check(problems, state, report_dir):
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
    page, problems, state = _load(browser, (report_dir / "report.html").resolve().as_uri())
    try:
        _check(problems, state, report_dir)
    finally:
        page.ws.close()


def test_report_loads_over_http_without_console_errors(browser, report_dir, http_report):
    page, problems, state = _load(browser, http_report)
    try:
        _check(problems, state, report_dir)
    finally:
        page.ws.close()


def test_a_missing_picture_is_caught(browser, report_dir, tmp_path):
    """The harness itself: a page with a broken image and a script error is reported, not passed."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>x</title></head><body>'
                   '<img src="img/nope.png" alt="missing"><script>undefinedFunction();</script></body></html>')
    page, problems, state = _load(browser, bad.resolve().as_uri())
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
        page, problems, state = _load(browser, srv.url + "/report")
        try:
            _check(problems, state, report_dir)
        finally:
            page.ws.close()
