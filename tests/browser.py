"""Headless Chromium for the tests, driven through the DevTools protocol with no extra dependency.

``Browser()`` starts ``chromium --headless`` with a DevTools endpoint; ``load(base, url)`` opens a page and collects
uncaught exceptions, console errors, failed loads and HTTP errors as events; ``screenshot(page, path)`` saves a PNG
of the viewport. Tests that use it skip cleanly when no Chromium is installed (``CHROMIUM`` names another binary).
"""
from __future__ import annotations

import base64
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
SKIP_REASON = "Chromium is not installed (apt-get install chromium)"

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
        data = self._pump(timeout, lambda d: d.get("id") == mid)
        if data is not None:
            if "error" in data:
                raise RuntimeError(f"{method}: {data['error']}")
            return data.get("result", {})
        raise TimeoutError(f"no answer to {method} in {timeout} s")

    def wait_for(self, method: str, timeout: float = 30.0) -> dict:
        for e in self.events:
            if e["method"] == method:
                return e
        found = self._pump(timeout, lambda data: data.get("method") == method)
        if found is None:
            raise TimeoutError(f"no {method} event in {timeout} s")
        return found

    def drain(self, seconds: float) -> None:
        self._pump(seconds, lambda data: False)

    def _pump(self, seconds: float, stop):
        """Read messages for up to ``seconds``, keeping events; the first message ``stop`` accepts is returned."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            msg = self.ws.recv(timeout=max(end - time.monotonic(), 0.01))
            if msg is None:
                return None
            data = json.loads(msg)
            if "method" in data:
                self.events.append(data)
            if stop(data):
                return data
        return None


class Browser:
    """A headless Chromium with a DevTools endpoint at ``self.base`` (its HTTP URL); ``close()`` terminates it."""

    def __init__(self, profile: str | Path, timeout: float = 60.0):
        self.proc = subprocess.Popen([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, errors="replace")
        self.lines: list[str] = []
        found = threading.Event()
        endpoint = {}

        def pump():  # read stderr to the end so the browser never blocks on a full pipe
            for line in self.proc.stderr:
                self.lines.append(line)
                if "DevTools listening on" in line and not found.is_set():
                    endpoint["ws"] = line.split("DevTools listening on", 1)[1].strip()
                    found.set()

        self._thread = threading.Thread(target=pump, daemon=True)
        self._thread.start()
        if not found.wait(timeout):
            self.close()
            raise RuntimeError(f"Chromium did not open its DevTools endpoint in {timeout} s:\n"
                               + "".join(self.lines[-20:]))
        u = urlparse(endpoint["ws"])
        self.base = f"http://{u.hostname}:{u.port}"

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
        self._thread.join(5)

    def __enter__(self) -> "Browser":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_page(base: str) -> Page:
    with urllib.request.urlopen(f"{base}/json/list", timeout=10) as r:
        targets = json.loads(r.read())
    page = next(t for t in targets if t.get("type") == "page")
    return Page(WebSocket(page["webSocketDebuggerUrl"]))


def load(base: str, url: str) -> tuple[Page, list[str], str]:
    """Open ``url``; return the page, the problems seen while loading, and ``STATE_JS`` (a JSON string)."""
    page = open_page(base)
    for domain in ("Runtime", "Log", "Page", "Network"):
        page.call(f"{domain}.enable")
    page.events.clear()
    page.call("Page.navigate", url=url)
    page.wait_for("Page.loadEventFired", timeout=60)
    page.drain(0.5)
    return page, event_problems(page.events), evaluate(page, STATE_JS)


def event_problems(events: list[dict], also_log: str | None = None) -> list[str]:
    """The errors among DevTools events: uncaught exceptions, console errors and asserts, error log entries (and log
    entries containing ``also_log``), failed loads and HTTP errors."""
    out = []
    for e in events:
        m, p = e["method"], e.get("params", {})
        if m == "Runtime.exceptionThrown":
            out.append(f"uncaught: {p['exceptionDetails'].get('text')} "
                       f"{p['exceptionDetails'].get('exception', {}).get('description', '')}")
        elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            out.append(f"console.{p['type']}: {[a.get('value') for a in p.get('args', [])]}")
        elif m == "Log.entryAdded" and (p["entry"].get("level") == "error"
                                        or (also_log is not None and also_log in p["entry"].get("text", ""))):
            out.append(f"log: {p['entry'].get('text')} {p['entry'].get('url', '')}")
        elif m == "Network.loadingFailed" and not p.get("canceled"):
            out.append(f"failed to load: {p.get('errorText')} (request {p.get('requestId')})")
        elif m == "Network.responseReceived" and p["response"].get("status", 200) >= 400:
            out.append(f"HTTP {p['response']['status']}: {p['response'].get('url')}")
    return out


def evaluate(page: Page, expression: str):
    """The value of a JavaScript expression in the page (JSON-serialisable values only)."""
    out = page.call("Runtime.evaluate", returnByValue=True, awaitPromise=True, expression=expression)
    if "exceptionDetails" in out:
        raise RuntimeError(f"page script failed: {out['exceptionDetails']}")
    return out["result"].get("value")


def screenshot(page: Page, path: str | Path, width: int = 1280, height: int = 900, full_page: bool = False) -> Path:
    """Save a PNG of the page (the viewport, or the whole page) at ``path``."""
    page.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False)
    params = {"format": "png", "captureBeyondViewport": full_page}
    if full_page:
        size = evaluate(page, "[document.documentElement.scrollWidth, document.documentElement.scrollHeight]")
        params["clip"] = {"x": 0, "y": 0, "width": size[0], "height": size[1], "scale": 1}
    data = page.call("Page.captureScreenshot", timeout=60, **params)["data"]
    path = Path(path)
    path.write_bytes(base64.b64decode(data))
    return path


STATE_JS = """JSON.stringify({
        title: document.title,
        charset: document.characterSet,
        mode: document.compatMode,
        tables: document.querySelectorAll('table').length,
        images: Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth,
                                                     i.naturalHeight])})"""


