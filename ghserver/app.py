"""The Flask application: routes, JSON errors, access log, result cache.

``create_app(config)`` builds everything; importing this module has no side effects.
"""
from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import logging
import socket
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlsplit

from flask import Blueprint, Flask, Response, current_app, request
from werkzeug.exceptions import HTTPException, RequestEntityTooLarge

from components.core.progress import Cancelled, reporting
from ghserver import catalogue, jobs, protocol
from ghserver.registry import Registry
from ghserver.workers import default_memory_limit_mb

log = logging.getLogger(__name__)
access_log = logging.getLogger("ghserver.access")

DEFAULT_MAX_BODY_MB = 512
LOOPBACK_NAMES = ("localhost",)


@dataclass
class Config:
    """Server settings (every field has a built-in default).

    ``workers`` > 0 runs solves in that many worker processes (isolation, time limit, memory cap); 0 solves in the
    request thread (the default of :func:`create_app`, handy for tests and embedding; ``ghserver serve`` uses
    one worker per core).
    """

    max_body_mb: float = DEFAULT_MAX_BODY_MB
    cache_size: int = 64  # solved results kept in memory (0 disables the cache)
    cache_mb: float = 256  # ... and their total size
    report_dir: str | None = None  # folder whose report.html is served at /report
    workers: int = 0
    solve_timeout: float = 90.0  # seconds; Hops gives up after 100 s by default
    memory_limit_mb: float | None = None  # per worker process (POSIX); None: derived from the machine, 0: none
    max_vertices: int = 5_000_000  # per mesh
    max_faces: int = 5_000_000
    max_request_vertices: int | None = None  # all meshes of a request together (None: max_vertices)
    max_request_faces: int | None = None
    max_json_mb: float = 512  # estimated size of the parsed request JSON
    max_response_mb: float = 256
    max_queued_mb: float | None = None  # request bodies held by the server process at once (None: 2 × max body)
    max_pending_solves: int = 0  # solves running or waiting at once; beyond → 503 (0: unlimited)
    api_key: str | None = None  # required on solves (RhinoComputeKey header or Bearer token) when set
    host: str = "127.0.0.1"  # the address the server is bound to (requests must name it, or a loopback name)
    allowed_hosts: tuple = field(default_factory=tuple)  # more Host / Origin names to accept ("*": any)
    registry_factory: str = "ghserver.endpoints:build_registry"
    cluster: str | None = None  # Dask scheduler address (tcp://HOST:PORT): solves run there, not in local processes
    job_timeout: float = 3600.0  # seconds a job's solve may run (jobs are for solves Hops cannot wait for)
    job_ttl: float = 600.0  # seconds a finished job is kept
    max_jobs: int = 64  # jobs kept at once (queued, running, finished); beyond → 429
    job_results_mb: float = 1024  # finished jobs' results kept together (the oldest are forgotten first)

    @property
    def limits(self) -> dict:
        return {"max_vertices": self.max_vertices, "max_faces": self.max_faces,
                "max_request_vertices": self.max_request_vertices or self.max_vertices,
                "max_request_faces": self.max_request_faces or self.max_faces,
                "max_json_mb": self.max_json_mb, "max_response_mb": self.max_response_mb}

    @property
    def worker_memory_mb(self) -> float | None:
        """The memory cap of each solver process: the configured one, else derived from the machine's memory."""
        if self.memory_limit_mb is None:
            return default_memory_limit_mb(self.workers) if self.workers > 0 and not self.cluster else None
        return self.memory_limit_mb or None

    @property
    def queued_bytes(self) -> int | None:
        mb = self.max_queued_mb if self.max_queued_mb is not None else 2 * (self.max_body_mb or DEFAULT_MAX_BODY_MB)
        return int(mb * 2**20) if mb else None


class ByteBudget:
    """Bytes of request bodies the server process holds at once; a request that does not fit is answered 503."""

    def __init__(self, limit: int | None):
        self.limit = limit
        self.used = 0
        self._lock = threading.Lock()

    def acquire(self, n: int) -> bool:
        with self._lock:
            if self.limit is not None and self.used + n > self.limit:
                return False
            self.used += n
            return True

    def release(self, n: int) -> None:
        with self._lock:
            self.used -= n


class ResultCache:
    """A thread-safe LRU of successful solve responses, keyed on the request's content, bounded in entries and
    in bytes. Only 200 answers are ever stored (Hops keeps 200 answers: a cached error would come back as a
    success); an answer larger than a quarter of the byte budget is not stored."""

    def __init__(self, size: int, max_bytes: int | None = 256 * 2**20):
        self.size = size
        self.max_bytes = max_bytes
        self.bytes = 0
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

    def put(self, key: str, value: bytes, status: int = 200) -> None:
        if self.size <= 0 or status != 200:
            return
        if self.max_bytes is not None and len(value) > self.max_bytes // 4:
            return
        with self._lock:
            old = self._data.pop(key, None)
            if old is not None:
                self.bytes -= len(old)
            self._data[key] = value
            self.bytes += len(value)
            while len(self._data) > self.size or (self.max_bytes is not None and self.bytes > self.max_bytes):
                _, dropped = self._data.popitem(last=False)
                self.bytes -= len(dropped)


def json_response(obj, status: int = 200) -> Response:
    body = json.dumps(obj, ensure_ascii=False, allow_nan=False)
    return Response(body, status=status, mimetype="application/json")


def not_found_body(path: str) -> dict:
    msg = f"Unknown component /{path.strip('/')}"
    return {"message": msg, "Errors": [msg], "Warnings": [], "Inputs": [], "Outputs": [], "InputNames": [],
            "OutputNames": [], "Description": msg}


def refusal_body(msg: str) -> dict:
    """An error both Hops' solve reader (``errors``) and its metadata reader (``Errors``, ``Inputs``, …) show."""
    return {"values": [], "warnings": [], "errors": [msg], "message": msg, "Errors": [msg], "Warnings": [],
            "Inputs": [], "Outputs": [], "InputNames": [], "OutputNames": [], "Description": msg}


bp = Blueprint("hops", __name__)


def _registry() -> Registry:
    return current_app.extensions["ghserver.registry"]


# GET / (the catalogue) and GET /doc/<component> are in ghserver.catalogue


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
    missing = json_response({"errors": [f"no report file {name[:80]!r} in the report folder; run `ghserver demo` "
                                        "or `ghserver report` first"]}, 404)
    if len(name) > 1024 or "\0" in name or any(len(part) > 255 for part in name.split("/")):
        return missing
    try:
        target = (root / name).resolve()
        if root not in target.parents or not target.is_file():
            return missing
        data = target.read_bytes()
    except (OSError, ValueError):  # a name the file system refuses
        return missing
    mime = {".html": "text/html", ".js": "text/javascript", ".png": "image/png", ".csv": "text/csv",
            ".json": "application/json", ".svg": "image/svg+xml", ".obj": "text/plain"}.get(target.suffix.lower(), "application/octet-stream")
    return Response(data, mimetype=mime)


@bp.get("/<path:uri>")
def metadata(uri: str):
    comp = _registry().get(protocol.pointer_uri(uri))
    if comp is None:
        return json_response(not_found_body(uri), 404)
    if catalogue.wants_html():  # a browser: the component's page (Hops sends no Accept and gets the JSON)
        return catalogue.component_page(comp)
    return json_response(comp.metadata())


def authorized() -> bool:
    """The API key, when one is set, in the ``RhinoComputeKey`` header or as an ``Authorization: Bearer`` token.

    Either matching is enough (compute_rhino3d sends its own ``authToken`` as the Bearer token beside the key);
    an empty credential never matches.
    """
    key = current_app.extensions["ghserver.config"].api_key
    if not key:
        return True
    given = [request.headers.get("RhinoComputeKey", "")]
    auth = request.headers.get("Authorization", "")
    if auth[:7].lower() == "bearer ":
        given.append(auth[7:].strip())
    expected = key.encode("utf-8")
    ok = False
    for g in given:  # compare every candidate (constant time each), no early exit
        ok |= bool(g) and hmac.compare_digest(g.encode("utf-8", "surrogateescape"), expected)
    return ok


def _split_host(value: str) -> str:
    """The host name of a ``Host`` header value or an ``Origin``'s authority: no port, no brackets, lower case."""
    value = value.strip().lower()
    if value.startswith("["):
        return value[1:value.find("]")] if "]" in value else value[1:]
    if value.count(":") == 1:
        value = value.split(":", 1)[0]
    return value.rstrip(".")


def _machine_names() -> set[str]:
    names = set()
    try:
        names.update({socket.gethostname().lower(), socket.getfqdn().lower()})
    except OSError:  # pragma: no cover
        pass
    return {n for n in names if n}


def host_allowed(name: str, cfg: Config) -> bool:
    """Whether a request naming host ``name`` may be answered (DNS-rebinding defence).

    Allowed: loopback names and addresses, the address the server is bound to, any IP address when it is bound
    to all interfaces (a DNS name pointing elsewhere is what a rebinding attack needs, an address literal cannot
    be rebound), this machine's own names when it is bound beyond loopback, and ``cfg.allowed_hosts``
    (``"*"`` allows every name).
    """
    allowed = {h.lower().rstrip(".") for h in cfg.allowed_hosts}
    if "*" in allowed:
        return True
    bound = _split_host(cfg.host or "")
    if name in LOOPBACK_NAMES or name in allowed or (name and name == bound):
        return True
    try:
        bound_ip = ipaddress.ip_address(bound)
    except ValueError:
        bound_ip = None
    try:
        ip = ipaddress.ip_address(name)
    except ValueError:
        ip = None
    if ip is not None:
        return ip.is_loopback or (bound_ip is not None and (ip == bound_ip or bound_ip.is_unspecified))
    if bound_ip is None or not bound_ip.is_loopback:
        return name in _machine_names()
    return False


def cross_site_refusal(cfg: Config) -> tuple[int, str] | None:
    """``(status, message)`` when the current request must be refused as cross-site, else ``None``.

    * every request: its ``Host`` must be allowed (:func:`host_allowed`): a page whose DNS name is rebound to this
      server cannot read its answers;
    * a request with an ``Origin`` (every browser sends one on a POST) must come from an allowed host;
    * a POST must be ``Content-Type: application/json`` (what Hops sends) or carry no Content-Type at all (what
      McNeel's compute_rhino3d sends): a web page can post ``text/plain`` or a form to any address without asking,
      but JSON only after a CORS preflight, which this server never grants.
    """
    host = request.environ.get("HTTP_HOST")
    if host is not None and not host_allowed(_split_host(host), cfg):
        return 403, (f"requests naming host {host[:100]!r} are refused (cross-site protection); allow a proxy's or "
                     "this machine's name with ghserver serve --allowed-hosts NAME")
    origin = request.headers.get("Origin")
    if origin is not None:
        parts = urlsplit(origin.strip()) if origin.strip().lower() != "null" else None
        if parts is None or parts.scheme not in ("http", "https") or not host_allowed(_split_host(parts.netloc), cfg):
            return 403, (f"cross-site request from origin {origin[:100]!r} refused; allow that host with "
                         "ghserver serve --allowed-hosts NAME")
    if request.method not in ("GET", "HEAD", "OPTIONS"):
        ctype = request.headers.get("Content-Type")
        if ctype is not None and request.mimetype != "application/json":
            return 415, (f"solves need Content-Type: application/json, got {ctype[:100]!r} (cross-site protection: "
                         "a web page can send other types to any server without asking)")
    return None


@bp.before_app_request
def _guard():
    cfg: Config = current_app.extensions["ghserver.config"]
    refused = cross_site_refusal(cfg)
    if refused is not None:
        return json_response(refusal_body(refused[1]), refused[0])
    if request.method == "OPTIONS":  # no CORS preflight is ever granted; answer in JSON like everything else
        return Response(json.dumps({"methods": ["GET", "POST"]}), status=200, mimetype="application/json",
                        headers={"Allow": "GET, HEAD, POST"})
    return None


def _solve(uri: str | None):
    started = time.perf_counter()
    if not authorized():
        return json_response(protocol.error_body(["missing or wrong API key (send the RhinoComputeKey header)"]), 401)
    slots: threading.BoundedSemaphore | None = current_app.extensions["ghserver.slots"]
    if slots is not None and not slots.acquire(blocking=False):
        return json_response(protocol.error_body(["the server is busy with other solves; try again"]), 503)
    budget: ByteBudget = current_app.extensions["ghserver.queue"]
    size = request.content_length or 0
    limit = current_app.config.get("MAX_CONTENT_LENGTH")
    if limit and size > limit:
        if slots is not None:
            slots.release()
        return _body_too_large()
    if not budget.acquire(size):
        if slots is not None:
            slots.release()
        return json_response(protocol.error_body([
            f"the server holds {budget.used / 2**20:.0f} MB of other requests; try again (ghserver serve "
            "--max-queued-mb)"]), 503)
    try:
        return _solve_now(uri, started)
    finally:
        budget.release(size)
        if slots is not None:
            slots.release()


def _body_too_large():
    limit = current_app.config.get("MAX_CONTENT_LENGTH") or 0
    msg = f"request body is larger than the server's limit of {limit / 2**20:g} MB (ghserver serve --max-body-mb)"
    return json_response(protocol.error_body([msg]), 413)


def _solve_now(uri: str | None, started: float):
    cfg: Config = current_app.extensions["ghserver.config"]
    raw = request.get_data(cache=False)
    try:
        protocol.check_json_size(raw, cfg.limits)  # here, so an oversized body never reaches a solver process
    except protocol.RequestError as exc:
        _log_access(uri or "", exc.status, started, len(raw), "", error=exc.errors[0] if exc.errors else "")
        return json_response(protocol.error_body(exc.errors), exc.status)
    cache: ResultCache = current_app.extensions["ghserver.cache"]
    key = cache.key(uri, raw) if cache.size > 0 else None
    if key is not None:
        hit = cache.get(key)
        if hit is not None:
            _log_access(uri or "", 200, started, len(raw), "", cached=True)
            return Response(hit, status=200, mimetype="application/json")
    status, text, comp_uri, info = run_solve(current_app, raw, uri, key=key)
    _log_access(comp_uri, status, started, len(raw), info.get("inputs", ""),
                error=protocol.first_error(text) if status != 200 else "")
    return Response(text, status=status, mimetype="application/json")


def run_solve(app, raw: bytes, uri: str | None, key: str | None = None, **hooks) -> tuple[int, bytes, str, dict]:
    """One solve on the app's backend (the Dask cluster, the local solver processes, or this thread), its 200
    answer cached; never raises. ``hooks`` (``timeout``, ``wait``, ``progress``, ``cancel``, ``started``,
    ``option``) are those of :meth:`ghserver.workers.WorkerPool.solve`; jobs use them.
    """
    cache: ResultCache = app.extensions["ghserver.cache"]
    if key is None and cache.size > 0:
        key = cache.key(uri, raw)
        hit = cache.get(key)
        if hit is not None:
            return 200, hit, uri or "", {"cached": True}
    pool = app.extensions.get("ghserver.pool")
    if pool is not None:
        status, text, comp_uri, info = pool.solve(raw, uri, **hooks)
    else:
        status, text, comp_uri, info = _solve_here(app, raw, uri, **hooks)
    if status == 200 and key is not None and info.get("cachesolve"):
        cache.put(key, text, status)
    return status, text, comp_uri, info


def _solve_here(app, raw: bytes, uri: str | None, progress=None, cancel=None, started=None,
                **_limits) -> tuple[int, bytes, str, dict]:
    """A solve in this thread (``workers=0``); a cancelled one stops at the component's next progress report."""
    limits = app.extensions["ghserver.config"].limits
    registry = app.extensions["ghserver.registry"]
    if progress is None and cancel is None:
        return protocol.solve_bytes(registry, raw, uri, limits=limits)

    def sink(fraction: float, stage: str) -> None:
        if cancel is not None and cancel():
            raise Cancelled()
        if progress is not None:
            progress(fraction, stage)

    if started is not None:
        started()
    try:
        with reporting(sink):
            return protocol.solve_bytes(registry, raw, uri, limits=limits)
    except Cancelled:
        return jobs.CANCELLED, json.dumps(protocol.error_body(["the solve was cancelled"])).encode(), uri or "", {}


def _log_access(uri, status, started, nbytes, inputs, cached=False, error=""):
    access_log.info("solve %s %d %.1fms in=%dB %s%s%s", uri or "?", status, 1000 * (time.perf_counter() - started),
                    nbytes, inputs, " (cached)" if cached else "", f" error: {error}" if error else "")


@bp.post("/solve")
@bp.post("/grasshopper")
def solve_by_pointer():
    return _solve(None)


@bp.post("/<path:uri>")
def solve_direct(uri: str):
    return _solve(uri)


def _handle_http_error(exc: HTTPException):
    if isinstance(exc, RequestEntityTooLarge):
        return _body_too_large()
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
    app.extensions["ghserver.cache"] = ResultCache(config.cache_size,
                                                   int(config.cache_mb * 2**20) if config.cache_mb else None)
    app.extensions["ghserver.slots"] = (threading.BoundedSemaphore(config.max_pending_solves)
                                        if config.max_pending_solves > 0 else None)
    app.extensions["ghserver.queue"] = ByteBudget(config.queued_bytes)
    if config.cluster:
        from ghserver.cluster import ClusterPool  # deferred import: distributed loads in ~1 s, only --cluster needs it

        app.extensions["ghserver.pool"] = ClusterPool(
            config.cluster, factory=config.registry_factory, timeout=config.solve_timeout,
            memory_limit_mb=config.memory_limit_mb, limits=config.limits)
    elif config.workers > 0:
        from ghserver.workers import WorkerPool

        app.extensions["ghserver.pool"] = WorkerPool(
            config.workers, factory=config.registry_factory, timeout=config.solve_timeout,
            memory_limit_mb=config.worker_memory_mb, limits=config.limits,
        )
    jobs.register(app, run_solve, authorized)
    app.register_blueprint(bp)
    app.register_blueprint(catalogue.bp)
    app.register_error_handler(HTTPException, _handle_http_error)
    app.register_error_handler(Exception, _handle_unexpected)
    return app
