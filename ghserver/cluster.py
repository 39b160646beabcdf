"""Solves on a Dask cluster: ``ghserver serve --cluster tcp://HOST:PORT``.

:class:`ClusterPool` has the solve interface of :class:`ghserver.workers.WorkerPool` (``solve(raw, uri, wait)`` →
``(status, body, uri, info)``, plus the progress/cancel hooks of jobs), so the app only picks the backend.

Design
------
A Dask task runs in a thread of its worker and cannot be interrupted: a hung solve run directly in a task would
hold that Dask worker for ever. So each Dask worker owns a local :class:`~ghserver.workers.WorkerPool` of this
project's own solver processes (one per Dask worker thread, created by :class:`SolverPlugin` when the server
connects, or on the first solve): the task hands the request bytes to that pool, whose time limit kills and
replaces a child that runs too long (answered 504, the task returns at once). While it waits the task looks at its
own state in the worker every ``CANCEL_POLL`` s: when the server cancels the future (a cancelled job, the server's
own backstop, or the server going away: the scheduler releases the futures of a client that is gone) the task
kills its child and returns, so the Dask worker is free again within a fraction of a second.

Requests and answers cross the cluster as bytes (the JSON of the request and of the answer), never as pickled
request objects. Progress reports travel as worker events (``Worker.log_event``) on one topic the server
subscribes to; the task also logs when it starts, so a solve still queued on the cluster and one running are
told apart (a queued one past its wait is answered 503, a running one past its time limit 504).

Failures: a solver process that crashes is answered 500 by the worker's pool as locally; a Dask worker that dies
mid-solve loses the task, and the scheduler reruns it on another worker (solves are pure, so a rerun is safe; the
scheduler gives up after ``distributed.scheduler.allowed-failures`` lost workers, answered 500). ``retries=1``
reruns a task once more when it raised (e.g. its worker could not start a solver process).
"""
from __future__ import annotations

import json
import logging
import os
import socket
import threading
import time
import uuid

from distributed import Client, WorkerPlugin, get_worker
from distributed.utils import CancelledError  # an asyncio.CancelledError: a BaseException

from ghserver.protocol import error_body
from ghserver.workers import CANCEL_POLL, CANCELLED, WorkerPool, default_memory_limit_mb

log = logging.getLogger(__name__)

TOPIC = "ghserver-solve"  # worker events: {"key", "event": "start" | "progress", "fraction", "stage"}
CONNECT_TIMEOUT = 10.0  # seconds to reach the scheduler at start
BACKSTOP = 15.0  # seconds past a running solve's time limit before the server gives up on the cluster's answer

_pools: dict[tuple, WorkerPool] = {}
_pools_lock = threading.Lock()


class ClusterError(RuntimeError):
    """The Dask cluster cannot be used (unreachable scheduler, bad address, workers that cannot load the
    components)."""


def _pool_key(factory: str, memory_limit_mb: float | None, limits: dict) -> tuple:
    return factory, memory_limit_mb, json.dumps(limits, sort_keys=True)


def worker_pool(factory: str, memory_limit_mb: float | None, limits: dict, size: int | None = None) -> WorkerPool:
    """The solver processes of this Dask worker for one server configuration (created once per process).

    ``size``: one process per Dask worker thread by default. ``memory_limit_mb`` None: 60% of this machine's
    memory shared by the processes (as ``ghserver serve`` does locally), 0: no cap.
    """
    key = _pool_key(factory, memory_limit_mb, limits)
    with _pools_lock:
        pool = _pools.get(key)
        if pool is None:
            if size is None:
                try:
                    size = get_worker().state.nthreads
                except (ImportError, ValueError):
                    size = os.cpu_count() or 1
            cap = memory_limit_mb
            if cap is None:
                cap = default_memory_limit_mb(size)
            pool = WorkerPool(size, factory=factory, memory_limit_mb=cap or None, limits=limits)
            _pools[key] = pool
        return pool


def close_worker_pools() -> None:
    with _pools_lock:
        pools = list(_pools.values())
        _pools.clear()
    for pool in pools:
        pool.close()


class SolverPlugin(WorkerPlugin):
    """A Dask worker plugin that starts the worker's solver processes when the server connects (and on every
    worker that joins later) and stops them when the worker closes."""

    def __init__(self, factory: str, memory_limit_mb: float | None, limits: dict):
        self.factory = factory
        self.memory_limit_mb = memory_limit_mb
        self.limits = dict(limits)
        self.name = "ghserver-solvers-" + uuid.uuid5(uuid.NAMESPACE_URL, repr(_pool_key(
            factory, memory_limit_mb, self.limits))).hex[:12]

    def setup(self, worker) -> None:
        worker_pool(self.factory, self.memory_limit_mb, self.limits, size=worker.state.nthreads)

    def teardown(self, worker) -> None:
        close_worker_pools()


def remote_solve(raw: bytes, uri: str | None, factory: str, memory_limit_mb: float | None, limits: dict,
                 timeout: float, option: str, report: bool) -> tuple[int, bytes, str, dict]:
    """The Dask task: solve ``raw`` in this worker's solver pool; killed child and early return on cancel."""
    worker = get_worker()
    key = worker.get_current_task()
    pool = worker_pool(factory, memory_limit_mb, limits)

    def event(**msg):
        try:
            worker.log_event(TOPIC, {"key": str(key), **msg})
        except Exception:  # progress is best effort
            pass

    def cancelled() -> bool:
        ts = worker.state.tasks.get(key)
        return ts is None or ts.state not in ("executing", "long-running")

    def progress(fraction: float, stage: str) -> None:
        event(event="progress", fraction=float(fraction), stage=stage)

    status, text, comp_uri, info = pool.solve(raw, uri, wait=3600.0, timeout=timeout, option=option,
                                              cancel=cancelled, progress=progress if report else None,
                                              started=lambda: event(event="start"))
    return status, text, comp_uri, {**info, "worker": str(worker.address)}


class _Watch:
    """What the server heard of one submitted solve: how often it started (a rerun after a lost worker starts
    again) and where its progress goes."""

    __slots__ = ("starts", "progress")

    def __init__(self, progress):
        self.starts = 0
        self.progress = progress


class ClusterPool:
    """Solves on a Dask cluster with the interface of :class:`ghserver.workers.WorkerPool`.

    Parameters
    ----------
    address : str
        The scheduler, e.g. ``"tcp://10.0.0.5:8786"``.
    factory, timeout, memory_limit_mb, limits, queue_timeout
        As for :class:`~ghserver.workers.WorkerPool`; ``memory_limit_mb`` None lets each worker derive its cap.
    connect_timeout : float
        Seconds to reach the scheduler; past it :class:`ClusterError`.

    Raises
    ------
    ClusterError
        Unreachable scheduler, malformed address, or workers that cannot start the solver processes.
    """

    def __init__(self, address: str, factory: str = "ghserver.endpoints:build_registry", timeout: float = 90.0,
                 memory_limit_mb: float | None = None, limits: dict | None = None, queue_timeout: float = 60.0,
                 connect_timeout: float = CONNECT_TIMEOUT):
        self.address = address
        self.factory = factory
        self.timeout = float(timeout)
        self.memory_limit_mb = memory_limit_mb
        self.limits = dict(limits or {})
        self.queue_timeout = float(queue_timeout)
        self._watch: dict[str, _Watch] = {}
        self._lock = threading.Lock()
        self._closed = False
        if "://" not in address or not address.split("://", 1)[1]:
            raise ClusterError(f"--cluster needs a scheduler address like tcp://HOST:8786, got {address!r}")
        scheme, _, rest = address.partition("://")
        host, _, port = rest.rpartition(":")
        if scheme == "tcp" and port.isdigit():  # a refused connection is known at once: say so without waiting
            try:
                socket.create_connection((host.strip("[]"), int(port)), timeout=connect_timeout).close()
            except OSError as exc:
                raise ClusterError(f"cannot reach the Dask scheduler at {address} ({exc.strerror or exc}); start "
                                   "it with `dask scheduler` and check the address and firewall") from None
        try:
            self.client = Client(address, timeout=connect_timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterError(f"cannot reach the Dask scheduler at {address} within {connect_timeout:g} s "
                               f"({type(exc).__name__}: {str(exc).splitlines()[0][:200] if str(exc) else ''}); "
                               "start it with `dask scheduler` and check the address and firewall") from None
        try:
            self.client.subscribe_topic(TOPIC, self._on_event)
            plugin = SolverPlugin(factory, memory_limit_mb, self.limits)
            self.client.register_plugin(plugin, name=plugin.name)
        except Exception as exc:
            self.client.close()
            raise ClusterError(f"the Dask workers at {address} cannot start the solver processes "
                               f"({type(exc).__name__}: {str(exc)[:300]}); install this project on every worker "
                               "machine") from None

    # ------------------------------------------------------------------------------------------
    def _on_event(self, event) -> None:
        """Worker events (in the client's event loop thread: quick dictionary work only)."""
        try:
            msg = event[1]
            watch = self._watch.get(msg.get("key"))
        except (TypeError, IndexError, AttributeError):
            return
        if watch is None:
            return
        if msg.get("event") == "start":
            watch.starts += 1
        elif msg.get("event") == "progress" and watch.progress is not None:
            watch.starts = max(watch.starts, 1)
            try:
                watch.progress(float(msg.get("fraction", 0.0)), str(msg.get("stage", "")))
            except Exception:
                log.exception("progress listener failed")

    def workers(self) -> int:
        """Dask workers the scheduler knows now."""
        try:
            return len(self.client.scheduler_info(n_workers=-1).get("workers", {}))
        except TypeError:  # older distributed: no n_workers argument
            return len(self.client.scheduler_info().get("workers", {}))

    def solve(self, raw: bytes, uri: str | None, wait: float | None = None, *, timeout: float | None = None,
              progress=None, cancel=None, started=None,
              option: str = "--solve-timeout") -> tuple[int, bytes, str, dict]:
        """Solve one request body on the cluster. Never raises; the answers of :meth:`WorkerPool.solve`."""
        def err(status, msg):
            return status, json.dumps(error_body([msg]), ensure_ascii=False).encode("utf-8"), uri or "", {}

        if self._closed:
            return err(503, "server is shutting down")
        limit = self.timeout if timeout is None else float(timeout)
        queue_wait = self.queue_timeout if wait is None else float(wait)
        key = f"ghserver-solve-{uuid.uuid4().hex}"
        watch = _Watch(progress)
        with self._lock:
            self._watch[key] = watch
        fut = None
        try:
            fut = self.client.submit(remote_solve, raw, uri, self.factory, self.memory_limit_mb, self.limits, limit,
                                     option, progress is not None, key=key, pure=False, retries=1)
            # wait on our own event, not fut.result(timeout=...): a short result timeout racing the answer can
            # surface as UnboundLocalError from distributed's sync() (an asyncio CancelledError it does not catch)
            done = threading.Event()
            fut.add_done_callback(lambda _: done.set())
            submitted = time.monotonic()
            run_started, starts = None, 0
            while True:
                if cancel is not None and cancel():
                    fut.cancel()
                    return err(CANCELLED, "the solve was cancelled")
                if done.wait(CANCEL_POLL if cancel else 0.25):
                    status, text, comp_uri, info = fut.result()
                    break
                now = time.monotonic()
                if watch.starts > starts:  # (re)started on a worker: the time limit counts from here
                    if starts == 0 and started is not None:
                        started()
                    run_started, starts = now, watch.starts
                if run_started is None and now - submitted > queue_wait + BACKSTOP:
                    fut.cancel()
                    return err(503, f"the cluster's workers are all busy (or none is connected to {self.address}); "
                                    "try again")
                if run_started is not None and now - run_started > limit + BACKSTOP:
                    fut.cancel()
                    log.warning("solve %s of %s: no answer from the cluster %g s past its time limit", key, uri,
                                BACKSTOP)
                    return err(504, f"solve of {uri or 'the request'} passed the server's time limit of {limit:g} s "
                                    f"and was stopped (raise {option}, or send a smaller input)")
        except CancelledError:
            return err(500, f"the cluster dropped the solve of {uri or 'the request'} (scheduler restarted or "
                            "unreachable); the server is fine, try again")
        except Exception as exc:  # KilledWorker: the workers running it died; the task raised even after a retry
            name = type(exc).__name__
            log.error("cluster solve %s of %s failed: %s: %s", key, uri, name, str(exc)[:300], exc_info=True)
            if name == "KilledWorker":
                return err(500, f"the cluster lost the worker(s) solving {uri or 'the request'} (they died or were "
                                "stopped, the solve was rerun and lost again); the server is fine, try again")
            return err(500, f"the cluster failed to solve {uri or 'the request'} ({name}); the server is fine")
        finally:
            with self._lock:
                self._watch.pop(key, None)
            if fut is not None:
                fut.release()
        return int(status), text, comp_uri, info

    def close(self) -> None:
        self._closed = True
        try:
            self.client.close(timeout=5)
        except Exception:  # closing a client whose scheduler is gone
            pass
