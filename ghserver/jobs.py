"""Jobs for long solves: submit, poll progress, fetch the result, cancel.

* ``POST /jobs/<component>`` (the body of ``POST /<component>``; ``/jobs/solve`` takes the component from the
  body's ``pointer``) → ``202 {"id": ..., "state": "queued", ...}`` with a ``Location: /jobs/<id>`` header;
* ``GET /jobs/<id>`` → ``{"id", "component", "state", "progress", "stage", "elapsed", "status", "result"}``: state is
  ``queued``, ``running``, ``done`` (``result`` is the ``/solve`` answer), ``failed`` (``result`` is the ``/solve``
  error answer, ``status`` its HTTP status) or ``cancelled``; progress 0..1 where the component reports it (the
  strategies report their stages, the planarizer its iterations);
* ``DELETE /jobs/<id>`` cancels a queued or running job (its solver process is killed, the worker is free again
  at once) or forgets a finished one.

The API key, the cross-site rules and the size limits apply as to ``/solve``. A job's solve has its own time limit
(``job_timeout``, default an hour: jobs are for what Hops' 100 s cannot wait for). Finished jobs are kept
``job_ttl`` seconds; at most ``max_jobs`` are kept at once (beyond: 429) and their results take at most
``job_results_mb`` together (the oldest finished ones are forgotten first). Jobs run on the server's backend: the
local solver processes, the Dask cluster, or (``workers=0``) a thread of the server, where cancelling stops the
solve at its next progress report.
"""
from __future__ import annotations

import json
import logging
import secrets
import threading
import time
from concurrent.futures import ThreadPoolExecutor

from flask import Blueprint, Response, current_app, request

from ghserver import protocol
from ghserver.workers import CANCELLED

log = logging.getLogger(__name__)

__all__ = ["CANCELLED", "Job", "JobStore", "register"]

TERMINAL = ("done", "failed", "cancelled")

bp = Blueprint("jobs", __name__)


def _json(obj, status: int = 200, headers: dict | None = None) -> Response:
    return Response(json.dumps(obj, ensure_ascii=False, allow_nan=False), status=status, mimetype="application/json",
                    headers=headers)


def _error(msg: str, status: int) -> Response:
    return _json(protocol.error_body([msg]), status)


class Job:
    """One submitted solve and what is known of it (thread-safe through its lock)."""

    def __init__(self, uri: str | None, raw: bytes):
        self.id = secrets.token_urlsafe(16)
        self.uri = uri
        self.raw: bytes | None = raw
        self.state = "queued"
        self.progress = 0.0
        self.stage = ""
        self.created = time.time()
        self.started: float | None = None
        self.finished: float | None = None
        self.status: int | None = None
        self.result: bytes | None = None
        self.cancel = threading.Event()
        self.lock = threading.Lock()

    def report(self, fraction: float, stage: str) -> None:
        with self.lock:
            if self.state in ("queued", "running"):
                self.progress = max(self.progress, min(max(float(fraction), 0.0), 1.0))
                self.stage = stage

    def mark_started(self) -> None:
        with self.lock:
            if self.state == "queued":
                self.state, self.started = "running", time.time()

    def finish(self, state: str, status: int | None = None, result: bytes | None = None) -> bool:
        """Move to a final state unless already in one; False if it was."""
        with self.lock:
            if self.state in TERMINAL:
                return False
            self.state, self.status, self.result, self.finished = state, status, result, time.time()
            if state == "done":
                self.progress, self.stage = 1.0, ""
            self.raw = None
            return True

    def body(self) -> bytes:
        """The ``GET /jobs/<id>`` answer (the result spliced in as it was answered, not parsed again)."""
        with self.lock:
            end = self.finished or time.time()
            head = {"id": self.id, "component": self.uri or "", "state": self.state,
                    "progress": round(self.progress, 4), "stage": self.stage, "created": round(self.created, 3),
                    "elapsed": round(end - (self.started or self.created), 3), "status": self.status}
            result = self.result
        text = json.dumps(head, ensure_ascii=False)
        if result is None:
            return text.encode("utf-8")
        return text[:-1].encode("utf-8") + b', "result": ' + result + b"}"


class JobStore:
    """The jobs of one app: at most ``max_jobs`` kept, finished ones for ``ttl`` seconds, results within
    ``max_bytes``."""

    def __init__(self, max_jobs: int, ttl: float, max_bytes: int | None, threads: int):
        self.max_jobs = max(1, int(max_jobs))
        self.ttl = float(ttl)
        self.max_bytes = max_bytes
        self._jobs: dict[str, Job] = {}
        self._lock = threading.Lock()
        self.executor = ThreadPoolExecutor(max_workers=max(1, threads), thread_name_prefix="ghserver-job")

    def purge(self) -> None:
        now = time.time()
        with self._lock:
            for key, job in list(self._jobs.items()):
                if job.finished is not None and now - job.finished > self.ttl:
                    del self._jobs[key]
            if self.max_bytes is not None:
                done = sorted((j for j in self._jobs.values() if j.result is not None), key=lambda j: j.finished)
                total = sum(len(j.result) for j in done)
                while done and total > self.max_bytes:
                    j = done.pop(0)
                    total -= len(j.result)
                    del self._jobs[j.id]

    def add(self, job: Job) -> bool:
        self.purge()
        with self._lock:
            if len(self._jobs) >= self.max_jobs:
                return False
            self._jobs[job.id] = job
            return True

    def get(self, job_id: str) -> Job | None:
        self.purge()
        with self._lock:
            return self._jobs.get(job_id)

    def remove(self, job_id: str) -> None:
        with self._lock:
            self._jobs.pop(job_id, None)

    def __len__(self) -> int:
        with self._lock:
            return len(self._jobs)


def _run(app, job: Job, size: int) -> None:
    """The job's thread: the solve on the app's backend, its progress into the job, the answer kept."""
    store: JobStore = app.extensions["ghserver.jobs"]
    budget = app.extensions["ghserver.queue"]
    try:
        if job.cancel.is_set():
            return
        raw = job.raw
        cfg = app.extensions["ghserver.config"]
        status, text, comp_uri, info = app.extensions["ghserver.solve"](
            app, raw, job.uri, timeout=cfg.job_timeout, wait=cfg.job_timeout, progress=job.report,
            cancel=job.cancel.is_set, started=job.mark_started, option="--job-timeout")
        if status == CANCELLED or job.cancel.is_set():
            job.finish("cancelled")
            return
        if comp_uri and not job.uri:
            job.uri = comp_uri
        job.finish("done" if status == 200 else "failed", status, text)  # a solve's errors are never a 200
        store.purge()
        log.info("job %s %s: %s (%d) in %.1fs", job.id[:8], job.uri or "?", job.state, status,
                 (job.finished or 0) - (job.started or job.created))
    except Exception as exc:  # the backends never raise; anything else still ends the job in JSON
        log.exception("job %s failed", job.id[:8])
        job.finish("failed", 500, json.dumps(protocol.error_body([f"internal error: {type(exc).__name__}"])).encode())
    finally:
        budget.release(size)


def _store() -> JobStore:
    return current_app.extensions["ghserver.jobs"]


def _authorized() -> bool:
    return current_app.extensions["ghserver.authorized"]()


@bp.post("/jobs/<path:uri>")
def submit(uri: str):
    if not _authorized():
        return _error("missing or wrong API key (send the RhinoComputeKey header)", 401)
    pointer = None if uri in ("solve", "grasshopper") else uri
    if pointer is not None and current_app.extensions["ghserver.registry"].get(protocol.pointer_uri(pointer)) is None:
        return _error(f"Unknown component /{pointer.strip('/')}", 404)
    size = request.content_length or 0
    limit = current_app.config.get("MAX_CONTENT_LENGTH")
    if limit and size > limit:
        return _error(f"request body is larger than the server's limit of {limit / 2**20:g} MB "
                      "(ghserver serve --max-body-mb)", 413)
    store = _store()
    budget = current_app.extensions["ghserver.queue"]
    if not budget.acquire(size):
        return _error(f"the server holds {budget.used / 2**20:.0f} MB of other requests; try again "
                      "(ghserver serve --max-queued-mb)", 503)
    try:
        raw = request.get_data(cache=False)
        protocol.check_json_size(raw, current_app.extensions["ghserver.config"].limits)
    except protocol.RequestError as exc:
        budget.release(size)
        return _json(protocol.error_body(exc.errors), exc.status)
    except Exception:
        budget.release(size)
        raise
    job = Job(pointer, raw)
    if not store.add(job):
        budget.release(size)
        return _error(f"the server keeps {store.max_jobs} jobs already; fetch or delete finished ones "
                      f"(DELETE /jobs/<id>) or wait until they expire ({store.ttl:g} s after finishing; ghserver "
                      "serve --max-jobs, --job-ttl)", 429)
    store.executor.submit(_run, current_app._get_current_object(), job, size)
    return _json({"id": job.id, "component": job.uri or "", "state": "queued", "url": f"/jobs/{job.id}"}, 202,
                 headers={"Location": f"/jobs/{job.id}"})


def _unknown(job_id: str) -> Response:
    return _error(f"no job {job_id[:64]!r} (unknown, or finished more than "
                  f"{_store().ttl:g} s ago and forgotten)", 404)


@bp.get("/jobs/<job_id>")
def status(job_id: str):
    if not _authorized():
        return _error("missing or wrong API key (send the RhinoComputeKey header)", 401)
    job = _store().get(job_id)
    if job is None:
        return _unknown(job_id)
    return Response(job.body(), status=200, mimetype="application/json")


@bp.delete("/jobs/<job_id>")
def cancel(job_id: str):
    if not _authorized():
        return _error("missing or wrong API key (send the RhinoComputeKey header)", 401)
    store = _store()
    job = store.get(job_id)
    if job is None:
        return _unknown(job_id)
    job.cancel.set()
    if not job.finish("cancelled"):  # finished already: forget it
        store.remove(job_id)
        return _json({"id": job.id, "state": "deleted"})
    log.info("job %s %s cancelled", job.id[:8], job.uri or "?")
    return Response(job.body(), status=200, mimetype="application/json")


def register(app, solve, authorized) -> None:
    """Add the job routes to ``app``; ``solve(app, raw, uri, **hooks)`` runs a solve on the app's backend (see
    :func:`ghserver.app.run_solve`), ``authorized()`` checks the current request's API key."""
    cfg = app.extensions["ghserver.config"]
    pool = app.extensions.get("ghserver.pool")
    threads = getattr(pool, "size", None) or (cfg.max_jobs if pool is not None else 2)
    app.extensions["ghserver.solve"] = solve
    app.extensions["ghserver.authorized"] = authorized
    app.extensions["ghserver.jobs"] = JobStore(cfg.max_jobs, cfg.job_ttl,
                                               int(cfg.job_results_mb * 2**20) if cfg.job_results_mb else None,
                                               threads)
    app.register_blueprint(bp)
