"""The Flask application: routes, JSON errors, access log, result cache.

``create_app(config)`` builds everything; importing this module has no side effects.
"""
from __future__ import annotations

import hashlib
import hmac
import html
import json
import logging
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

from flask import Blueprint, Flask, Response, current_app, request
from werkzeug.exceptions import HTTPException, RequestEntityTooLarge

from ghserver import protocol
from ghserver.registry import Registry

log = logging.getLogger(__name__)
access_log = logging.getLogger("ghserver.access")

DEFAULT_MAX_BODY_MB = 512


@dataclass
class Config:
    """Server settings (every field has a built-in default).

    ``workers`` > 0 runs solves in that many worker processes (isolation, time limit, memory cap); 0 solves in the
    request thread (the default of :func:`create_app`, handy for tests and embedding; ``ghserver serve`` uses
    one worker per core).
    """

    max_body_mb: float = DEFAULT_MAX_BODY_MB
    cache_size: int = 64  # solved results kept in memory (0 disables the cache)
    report_dir: str | None = None  # folder whose report.html is served at /report
    workers: int = 0
    solve_timeout: float = 90.0  # seconds; Hops gives up after 100 s by default
    memory_limit_mb: float | None = None  # per worker process (POSIX)
    max_vertices: int = 5_000_000
    max_faces: int = 5_000_000
    max_pending_solves: int = 0  # solves running or waiting at once; beyond → 503 (0: unlimited)
    api_key: str | None = None  # required on solves (RhinoComputeKey header or Bearer token) when set
    registry_factory: str = "ghserver.endpoints:build_registry"

    @property
    def limits(self) -> dict:
        return {"max_vertices": self.max_vertices, "max_faces": self.max_faces}


class ResultCache:
    """A small thread-safe LRU of successful solve responses, keyed on the request's content."""

    def __init__(self, size: int):
        self.size = size
        self._data: OrderedDict[str, bytes] = OrderedDict()
        self._lock = threading.Lock()

    @staticmethod
    def key(uri: str | None, raw: bytes) -> str:
        """Key of a request: the target and the exact body (Hops sends identical JSON for identical inputs,
        tolerances and units; compute.geometry keys its cache the same way)."""
        h = hashlib.sha256((uri or "").encode("utf-8", "surrogatepass") + b"\0")
        h.update(raw)
        return h.hexdigest()

    def get(self, key: str) -> bytes | None:
        with self._lock:
            v = self._data.get(key)
            if v is not None:
                self._data.move_to_end(key)
            return v

    def put(self, key: str, value: bytes) -> None:
        if self.size <= 0:
            return
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)


def json_response(obj, status: int = 200) -> Response:
    body = json.dumps(obj, ensure_ascii=False, allow_nan=False)
    return Response(body, status=status, mimetype="application/json")


def not_found_body(path: str) -> dict:
    msg = f"Unknown component /{path.strip('/')}"
    return {"message": msg, "Errors": [msg], "Warnings": [], "Inputs": [], "Outputs": [], "InputNames": [],
            "OutputNames": [], "Description": msg}


bp = Blueprint("hops", __name__)


def _registry() -> Registry:
    return current_app.extensions["ghserver.registry"]


def _wants_html() -> bool:
    best = request.accept_mimetypes.best_match(["application/json", "text/html"])
    return best == "text/html" and request.accept_mimetypes["text/html"] > request.accept_mimetypes["application/json"]


@bp.get("/")
def catalogue():
    reg = _registry()
    if _wants_html():
        return Response(catalogue_html(reg, has_report=_report_path() is not None), mimetype="text/html")
    return json_response(reg.catalogue())


def _report_path() -> Path | None:
    folder = current_app.extensions["ghserver.config"].report_dir
    if not folder:
        return None
    path = Path(folder) / "report.html"
    return path if path.is_file() else None


@bp.get("/report")
def report_redirect():
    # the report's pictures are relative links (img/...): they resolve only below a URL ending in "/"
    return Response(status=308, headers={"Location": "/report/"})


@bp.get("/report/")
@bp.get("/report/<path:name>")
def report(name: str = "report.html"):
    cfg = current_app.extensions["ghserver.config"]
    if not cfg.report_dir:
        return json_response({"errors": ["no report folder is configured (ghserver serve --report-dir)"]}, 404)
    root = Path(cfg.report_dir).resolve()
    target = (root / name).resolve()
    if root not in target.parents or not target.is_file():
        return json_response({"errors": [f"no report file {name!r} in the report folder; run `ghserver demo` or "
                                          "`ghserver report` first"]}, 404)
    mime = {".html": "text/html", ".png": "image/png", ".csv": "text/csv", ".json": "application/json",
            ".svg": "image/svg+xml", ".obj": "text/plain"}.get(target.suffix.lower(), "application/octet-stream")
    return Response(target.read_bytes(), mimetype=mime)


@bp.get("/<path:uri>")
def metadata(uri: str):
    comp = _registry().get(protocol.pointer_uri(uri))
    if comp is None:
        return json_response(not_found_body(uri), 404)
    return json_response(comp.metadata())


def _authorized() -> bool:
    key = current_app.extensions["ghserver.config"].api_key
    if not key:
        return True
    given = request.headers.get("RhinoComputeKey", "")
    auth = request.headers.get("Authorization", "")
    if auth.lower().startswith("bearer "):
        given = given or auth[7:].strip()
    return hmac.compare_digest(given.encode(), key.encode())


def _solve(uri: str | None):
    started = time.perf_counter()
    if not _authorized():
        return json_response(protocol.error_body(["missing or wrong API key (send the RhinoComputeKey header)"]), 401)
    slots: threading.BoundedSemaphore | None = current_app.extensions["ghserver.slots"]
    if slots is not None and not slots.acquire(blocking=False):
        return json_response(protocol.error_body(["the server is busy with other solves; try again"]), 503)
    try:
        return _solve_now(uri, started)
    finally:
        if slots is not None:
            slots.release()


def _solve_now(uri: str | None, started: float):
    cfg: Config = current_app.extensions["ghserver.config"]
    raw = request.get_data(cache=False)
    cache: ResultCache = current_app.extensions["ghserver.cache"]
    key = cache.key(uri, raw) if cache.size > 0 else None
    if key is not None:
        hit = cache.get(key)
        if hit is not None:
            _log_access(uri or "", 200, started, len(raw), "", cached=True)
            return Response(hit, status=200, mimetype="application/json")
    pool = current_app.extensions.get("ghserver.pool")
    if pool is not None:
        status, text, comp_uri, info = pool.solve(raw, uri)
    else:
        status, text, comp_uri, info = protocol.solve_bytes(_registry(), raw, uri, limits=cfg.limits)
    if status == 200 and key is not None and info.get("cachesolve"):
        cache.put(key, text)
    _log_access(comp_uri, status, started, len(raw), info.get("inputs", ""))
    return Response(text, status=status, mimetype="application/json")


def _log_access(uri, status, started, nbytes, inputs, cached=False):
    access_log.info("solve %s %d %.1fms in=%dB %s%s", uri or "?", status, 1000 * (time.perf_counter() - started),
                    nbytes, inputs, " (cached)" if cached else "")


@bp.post("/solve")
@bp.post("/grasshopper")
def solve_by_pointer():
    return _solve(None)


@bp.post("/<path:uri>")
def solve_direct(uri: str):
    return _solve(uri)


def _handle_http_error(exc: HTTPException):
    if isinstance(exc, RequestEntityTooLarge):
        limit = current_app.config.get("MAX_CONTENT_LENGTH") or 0
        msg = f"request body is larger than the server's limit of {limit / 2**20:g} MB"
        return json_response(protocol.error_body([msg]), 413)
    if exc.code == 404:
        return json_response(not_found_body(request.path), 404)
    msg = f"{exc.code} {exc.name}: {exc.description}"
    body = protocol.error_body([msg])
    body["message"] = msg
    return json_response(body, exc.code or 500)


def _handle_unexpected(exc: Exception):
    log.exception("unhandled error on %s %s", request.method, request.path)
    return json_response(protocol.error_body([f"internal server error: {type(exc).__name__}"]), 500)


def create_app(config: Config | dict | None = None, registry: Registry | None = None) -> Flask:
    """Build the Flask app.

    Parameters
    ----------
    config : Config or dict, optional
        Settings; a dict is turned into :class:`Config`.
    registry : Registry, optional
        Components to serve; default: every component of :mod:`ghserver.endpoints`.
    """
    if config is None:
        config = Config()
    elif isinstance(config, dict):
        config = Config(**config)
    if registry is None:
        from ghserver.workers import load_factory

        registry = load_factory(config.registry_factory)()
    app = Flask("ghserver")
    app.config["MAX_CONTENT_LENGTH"] = int(config.max_body_mb * 2**20) if config.max_body_mb else None
    app.json.ensure_ascii = False
    app.extensions["ghserver.registry"] = registry
    app.extensions["ghserver.config"] = config
    app.extensions["ghserver.cache"] = ResultCache(config.cache_size)
    app.extensions["ghserver.slots"] = (threading.BoundedSemaphore(config.max_pending_solves)
                                        if config.max_pending_solves > 0 else None)
    if config.workers > 0:
        from ghserver.workers import WorkerPool

        app.extensions["ghserver.pool"] = WorkerPool(
            config.workers, factory=config.registry_factory, timeout=config.solve_timeout,
            memory_limit_mb=config.memory_limit_mb, limits=config.limits,
        )
    app.register_blueprint(bp)
    app.register_error_handler(HTTPException, _handle_http_error)
    app.register_error_handler(Exception, _handle_unexpected)
    return app


# ----------------------------------------------------------------------------------------------
# the catalogue page


def catalogue_html(registry: Registry, has_report: bool = False) -> str:
    e = html.escape
    rows = []
    for c in registry:
        ins = "".join(_param_li(p, True) for p in c.inputs)
        outs = "".join(_param_li(p, False) for p in c.outputs)
        rows.append(
            f'<section id="{e(c.uri)}"><h2><code>/{e(c.uri)}</code></h2><p>{e(c.description)}</p>'
            f'<div class="io"><div><h3>Inputs</h3><ul>{ins}</ul></div>'
            f'<div><h3>Outputs</h3><ul>{outs}</ul></div></div></section>'
        )
    report = ('<p><a href="/report/">Comparison report</a> of all strategies on the built-in surfaces.</p>'
              if has_report else
              '<p>No comparison report yet: run <code>ghserver demo</code> (or <code>ghserver report</code>) in '
              'the folder the server was started from, and it appears at <a href="/report/">/report/</a>.</p>')
    toc = "".join(f'<li><a href="#{e(c.uri)}">{e(c.uri)}</a></li>' for c in registry)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>PQ mesh components</title>
<style>
body{{font-family:system-ui,sans-serif;max-width:60rem;margin:2rem auto;padding:0 1rem;color:#222}}
section{{border-top:1px solid #ddd;padding:.5rem 0}} .io{{display:flex;gap:2rem}} .io>div{{flex:1}}
code{{background:#f4f4f4;padding:0 .2em}} li{{margin:.2rem 0}} .kind{{color:#666}}
</style></head><body>
<h1>Planar-quad meshing components</h1>
<p>{len(registry)} components. In Grasshopper, place a <b>Hops</b> component and set its path to
<code>http://127.0.0.1:5000/&lt;component&gt;</code>, e.g. <code>http://127.0.0.1:5000/metrics/planarity</code>.
<code>GET /&lt;component&gt;</code> returns its metadata as JSON.</p>
{report}
<ul>{toc}</ul>
{''.join(rows)}
</body></html>"""


def _param_li(p, is_input: bool) -> str:
    e = html.escape
    extra = ""
    if is_input:
        if p.optional and not p.has_default:
            extra = " (optional)"
        elif p.has_default and p.default is not None:
            extra = f" = {e(json.dumps(p.default) if not isinstance(p.default, str) else repr(p.default))}"
        elif p.optional:
            extra = " (optional)"
    return (f'<li><b>{e(p.name)}</b> <span class="kind">{e(p.kind)} {e(p.access)}</span>{extra}: '
            f'{e(p.description)}</li>')
