"""Process isolation for solves: a pool of worker processes with a time limit and a memory cap per solve.

A solve that crashes its process, leaks, or runs past its time limit is killed and answered with a JSON error
while the server and the other solves carry on. So that a long solve answers rather than being killed, a worker runs
each solve under a deadline a little before its limit (:func:`solve_deadline`): the components' time budgets end
there (:mod:`components.core.deadline`). A solve may also be cancelled (its process is killed and replaced)
and may report progress: the components' :func:`components.core.progress.report` calls in the worker process
travel up its pipe as small JSON messages. Requests and answers cross the process boundary as JSON bytes
(never pickled request data). Each worker builds its own registry from an importable factory
(``"module:function"``), so any component set — the published one or a test one — can run isolated.
"""
from __future__ import annotations

import contextlib
import importlib
import json
import logging
import multiprocessing as mp
import os
import queue
import re
import sys
import threading
import time
from pathlib import Path

from components.core import deadline, memo, progress

log = logging.getLogger(__name__)

DEFAULT_FACTORY = "ghserver.endpoints:build_registry"
STARTUP_TIMEOUT = 120.0  # seconds a new worker may take to import numpy/scipy and build its registry
CANCELLED = 499  # the status of a cancelled solve (never sent to a client: a job says "cancelled")
PROGRESS_INTERVAL = 0.1  # seconds between two progress messages of a worker (at most)
CANCEL_POLL = 0.05  # seconds between two looks at a solve's cancel flag
_SEND_TRIES = 3  # workers a request is offered to when each dies before it takes the request


def load_factory(spec: str):
    """The callable named by ``"package.module:function"``."""
    module, _, name = spec.partition(":")
    if not module or not name:
        raise ValueError(f"registry factory must look like 'package.module:function', got {spec!r}")
    return getattr(importlib.import_module(module), name)


def _rss_mb() -> float:
    """Resident memory of this process in MB (Linux /proc; 0 where unavailable)."""
    try:
        with open("/proc/self/statm") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, AttributeError):
        return 0.0


def peak_rss_mb(pid: int | str = "self") -> float:
    """Peak resident memory (VmHWM) of a process in MB, from Linux /proc; 0 where unavailable."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except (OSError, ValueError):
        pass
    return 0.0


def reset_peak_rss(pid: int | str = "self") -> bool:
    """Reset a process's peak resident memory to its current one (Linux >= 4.0, own processes); False if not."""
    try:
        with open(f"/proc/{pid}/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def machine_memory_mb() -> float:
    """Physical memory of the machine in MB (or of the container's cgroup when that is smaller); 0 if unknown."""
    total = 0.0
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**20
    except (ValueError, OSError, AttributeError):  # Windows
        try:
            import ctypes

            class _Status(ctypes.Structure):
                _fields_ = [("dwLength", ctypes.c_ulong), ("dwMemoryLoad", ctypes.c_ulong),
                            ("ullTotalPhys", ctypes.c_ulonglong), ("rest", ctypes.c_ulonglong * 6)]

            st = _Status()
            st.dwLength = ctypes.sizeof(st)
            if ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(st)):
                total = st.ullTotalPhys / 2**20
        except (AttributeError, OSError, ImportError):
            total = 0.0
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) / 2**20 < (total or float("inf")):
            total = int(text) / 2**20
    return total


def default_memory_limit_mb(workers: int) -> float:
    """The default memory cap of one solver process: 60% of the machine's memory shared by the workers, at least
    1 GB (the server process, its queue and cache, and the operating system keep the rest)."""
    total = machine_memory_mb()
    if not total:
        return 4096.0
    return float(max(1024, int(0.6 * total / max(1, workers))))


def _limit_memory(mb: float | None) -> None:
    if not mb or sys.platform == "win32":
        return
    try:
        import resource

        limit = int(mb * 2**20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    except (ImportError, ValueError, OSError) as exc:  # pragma: no cover - platform dependent
        log.warning("cannot cap worker memory: %s", exc)


def _worker_main(conn, factory: str, memory_limit_mb: float | None, limits: dict) -> None:
    """Loop of a worker process: receive (header, body) bytes, solve, send (header, response) bytes."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl+C
    from ghserver import protocol

    _limit_memory(memory_limit_mb)
    registry = load_factory(factory)()
    conn.send_bytes(b'{"ready": true}')
    while True:
        try:
            header = json.loads(conn.recv_bytes())
            raw = conn.recv_bytes()
        except (EOFError, OSError):
            return
        reset_peak_rss()
        try:
            sink = _progress_sender(conn) if header.get("progress") else None
            with progress.reporting(sink) if sink else contextlib.nullcontext(), \
                    solve_deadline(header.get("limit"), header.get("option") or "--solve-timeout"):
                status, text, uri, info = protocol.solve_bytes(registry, raw, header.get("uri"), limits=limits)
        except Exception as exc:  # solve_bytes never raises; a worker must outlive anything that still does
            log.exception("solve failed in a worker")
            status, uri, info = 500, header.get("uri") or "", {}
            text = json.dumps(protocol.error_body([f"internal error: {type(exc).__name__}"])).encode()
        del raw
        memo.clear_all()  # what the solve kept for reuse (surface indexes, tracers, ...) must not outlive it
        conn.send_bytes(json.dumps({"status": status, "uri": uri, "rss_mb": _rss_mb(), "peak_mb": peak_rss_mb(),
                                    **info}).encode())
        conn.send_bytes(text)


def solve_deadline(limit: float | None, option: str = "--solve-timeout"):
    """The deadline of a solve with a time limit of ``limit`` seconds (:mod:`components.core.deadline`): the
    solvers' time budgets end :func:`deadline_margin` before the limit, so that the answer (the best state so far,
    with a warning naming the limit) is built and sent before the solve would be stopped without one."""
    if not limit or limit <= 0:
        return contextlib.nullcontext()
    return deadline.deadline(float(limit) - deadline_margin(float(limit)),
                             f"the server's time limit of {float(limit):g} s per solve (raise {option} for more)")


def deadline_margin(limit: float) -> float:
    """Seconds of a solve's time limit kept for what follows the solvers' budgets: the last iteration, the panel
    health verdict, the offsets, encoding and sending the answer (15 %, at most 30 s)."""
    return min(0.15 * limit, 30.0)


def _progress_sender(conn):
    """A progress sink that sends ``{"progress": fraction, "stage": name}`` up the pipe, at most every
    ``PROGRESS_INTERVAL`` seconds (and always when the stage name's first part changes)."""
    last = {"t": 0.0, "stage": None}

    def send(fraction: float, stage: str) -> None:
        now = time.monotonic()
        head = stage.split(":", 1)[0]
        if now - last["t"] < PROGRESS_INTERVAL and head == last["stage"]:
            return
        last["t"], last["stage"] = now, head
        conn.send_bytes(json.dumps({"progress": round(float(fraction), 4), "stage": stage[:200]}).encode())

    return send


class _Worker:
    def __init__(self, ctx, factory, memory_limit_mb, limits):
        parent, child = ctx.Pipe()
        self.conn = parent
        self.process = ctx.Process(target=_worker_main, args=(child, factory, memory_limit_mb, limits), daemon=True)
        self.process.start()
        child.close()
        self.solves = 0
        self.ready = False
        self._kill_lock = threading.Lock()
        self._killed = False

    def wait_ready(self, timeout: float) -> bool:
        if self.ready:
            return True
        if self.conn.poll(timeout):
            try:
                self.ready = json.loads(self.conn.recv_bytes()).get("ready", False)
            except (EOFError, OSError, ValueError):
                return False
        return self.ready

    def kill(self) -> None:
        """Kill the process and close its pipe, once: a cancelled solve retiring its worker and the pool closing
        may both get here at the same moment (a second close of the pipe would fail with a bad descriptor)."""
        with self._kill_lock:
            if self._killed:
                return
            self._killed = True
            try:
                self.process.kill()
            except Exception:  # pragma: no cover
                pass
            self.process.join(timeout=5)
            self.conn.close()


_POINTER = re.compile(rb'"pointer"\s*:\s*"([^"\\]{1,200})"')


def _pointer(raw) -> str | None:
    """The component a ``/solve`` body points to, read from its first 4 KB (Hops writes the pointer before the
    inputs), for the log and a timeout's answer; None when it is not there."""
    if not isinstance(raw, (bytes, bytearray)):
        return None
    m = _POINTER.search(bytes(raw[:4096]))
    return m.group(1).decode("utf-8", "replace") if m else None


class WorkerPool:
    """``size`` worker processes; :meth:`solve` runs one request in an idle one.

    Parameters
    ----------
    size : int
        Number of worker processes (default: the number of cores).
    factory : str
        ``"module:function"`` returning the registry each worker serves.
    timeout : float
        Seconds a solve may run before its worker is killed (answered 504).
    memory_limit_mb : float, optional
        Address-space cap of each worker (POSIX); a solve that passes it fails with a JSON error.
    recycle_mb : float, optional
        A worker whose resident memory is above this after a solve is replaced, so memory returns to baseline.
    limits : dict
        Input size limits passed to :func:`ghserver.protocol.solve`.
    queue_timeout : float
        Seconds a request may wait for an idle worker before it is answered 503 (Hops gives up after 100 s).
    """

    def __init__(self, size: int | None = None, factory: str = DEFAULT_FACTORY, timeout: float = 90.0,
                 memory_limit_mb: float | None = None, recycle_mb: float | None = 1024.0,
                 limits: dict | None = None, start_method: str | None = None, queue_timeout: float = 60.0):
        self.size = max(1, int(size or os.cpu_count() or 1))
        self.factory = factory
        self.timeout = float(timeout)
        self.memory_limit_mb = memory_limit_mb
        self.recycle_mb = recycle_mb
        self.limits = dict(limits or {})
        self.queue_timeout = float(queue_timeout)
        if start_method is None:
            start_method = "forkserver" if sys.platform.startswith("linux") else "spawn"
        self.ctx = mp.get_context(start_method)
        if start_method == "forkserver":
            # workers fork from a server that has already imported the heavy modules: a crashed or recycled
            # worker is replaced in milliseconds instead of re-importing numpy/scipy/rhino3dm
            # A parent started as `python -m package.module` (e.g. `dask worker`) has each new process run that
            # module again (multiprocessing's main-module fix-up): preloaded, its imports cost nothing there
            # (measured in a dask worker: 1.8 s → 0.05 s per replaced worker).
            spec = getattr(sys.modules.get("__main__"), "__spec__", None)
            main = [spec.name] if spec is not None and spec.name and not spec.name.endswith("__main__") else []
            self.ctx.set_forkserver_preload(["numpy", "scipy.sparse", "rhino3dm", "ghserver.protocol",
                                             "ghserver.workers", factory.partition(":")[0], *main])
        self._idle: queue.Queue[_Worker] = queue.Queue()
        self._lock = threading.Lock()
        self._all: list[_Worker] = []
        self._closed = False
        load_factory(factory)  # fail early on a bad factory
        for _ in range(self.size):
            self._idle.put(self._spawn())

    def _spawn(self) -> _Worker:
        w = _Worker(self.ctx, self.factory, self.memory_limit_mb, self.limits)
        with self._lock:
            self._all.append(w)
        return w

    def _retire(self, w: _Worker) -> None:
        w.kill()
        with self._lock:
            if w in self._all:
                self._all.remove(w)

    def _replace(self, w: _Worker) -> None:
        self._retire(w)
        if not self._closed:
            self._idle.put(self._spawn())

    def _idle_worker(self, wait: float) -> _Worker:
        """An idle worker that is alive: one that died while idle (killed, out of memory) is replaced first."""
        deadline = time.monotonic() + wait
        while True:
            w = self._idle.get(timeout=max(0.0, deadline - time.monotonic()))
            if w.process.is_alive():
                return w
            log.warning("worker %d died while idle (exit code %s): replaced", w.process.pid, w.process.exitcode)
            self._replace(w)

    def pids(self) -> list[int]:
        with self._lock:
            return [w.process.pid for w in self._all]

    def solve(self, raw: bytes, uri: str | None, wait: float | None = None, *, timeout: float | None = None,
              progress=None, cancel=None, started=None,
              option: str = "--solve-timeout") -> tuple[int, bytes, str, dict]:
        """Solve one request body in a worker. Never raises.

        Returns ``(status, response JSON bytes, component uri, info)`` where ``info`` holds ``cachesolve`` and the
        ``inputs`` summary for the access log (see :func:`ghserver.protocol.solve_bytes`).

        ``timeout`` overrides the pool's time limit for this solve (jobs have their own); ``progress(fraction,
        stage)`` receives the component's progress reports; when ``cancel()`` turns true (polled every
        ``CANCEL_POLL`` s) the worker is killed and replaced and the answer is :data:`CANCELLED`; ``started()`` is
        called once a worker has taken the solve; ``option`` is the setting a 504's message says to raise.
        """
        from ghserver.protocol import error_body

        def err(status, msg):
            return status, json.dumps(error_body([msg]), ensure_ascii=False).encode("utf-8"), uri or "", {}

        limit = self.timeout if timeout is None else float(timeout)
        if self._closed:
            return err(503, "server is shutting down")
        for tries in range(_SEND_TRIES):
            try:
                w = self._idle_worker(wait if wait is not None else self.queue_timeout)
            except queue.Empty:
                return err(503, "all solver processes are busy; try again")
            try:
                if not w.wait_ready(STARTUP_TIMEOUT):
                    self._replace(w)
                    return err(500, "a solver process failed to start (see the server log)")
                if cancel is not None and cancel():
                    self._idle.put(w)
                    return err(CANCELLED, "the solve was cancelled")
                w.conn.send_bytes(json.dumps({"uri": uri, "progress": progress is not None, "limit": limit,
                                              "option": option}).encode())
                w.conn.send_bytes(raw)
                break
            except (EOFError, OSError) as exc:
                # it died after the liveness check and before it took the request (killed, out of memory while
                # idle): nothing of the request reached it, so another worker gets it
                w.process.join(timeout=1.0)
                log.warning("worker %d died before it took a request (exit code %s, %s): replaced",
                            w.process.pid, w.process.exitcode, type(exc).__name__)
                self._replace(w)
                if tries == _SEND_TRIES - 1:
                    return err(500, "the solver processes died before they could take the request (see the "
                                    "server log); the server is fine, try again")
        try:
            started_at = time.monotonic()
            if started is not None:
                started()
            while True:
                remaining = limit - (time.monotonic() - started_at)
                if cancel is not None and cancel():
                    log.info("solve of %s cancelled: worker %d killed", uri or _pointer(raw), w.process.pid)
                    self._replace(w)
                    return err(CANCELLED, "the solve was cancelled")
                if remaining > 0 and not w.conn.poll(min(remaining, CANCEL_POLL) if cancel else remaining):
                    continue
                if remaining <= 0:
                    shown = uri or _pointer(raw) or "the request"
                    log.warning("solve of %s passed the %g s time limit: worker %d killed", shown, limit,
                                w.process.pid)
                    self._replace(w)
                    return err(504, f"solve of {shown} passed the server's time limit of {limit:g} s "
                                    f"and was stopped (raise {option}, or send a smaller input)")
                header = json.loads(w.conn.recv_bytes())
                if "progress" in header and "status" not in header:
                    if progress is not None:
                        try:
                            progress(float(header["progress"]), str(header.get("stage", "")))
                        except Exception:  # a listener's failure never fails the solve
                            log.exception("progress listener failed")
                    continue
                break
            text = w.conn.recv_bytes()
        except (EOFError, OSError, ValueError) as exc:
            w.process.join(timeout=1.0)  # reap it, so its exit code is known
            code = w.process.exitcode
            log.error("worker %d died during a solve of %s (exit code %s, %s)", w.process.pid, uri or "a request",
                      code, type(exc).__name__)
            self._replace(w)
            return err(500, f"the solver process crashed while solving {uri or 'the request'} "
                            f"(exit code {code}); the server is fine, other solves are unaffected")
        w.solves += 1
        if self.recycle_mb and header.get("rss_mb", 0) > self.recycle_mb:
            log.info("recycling worker %d (%.0f MB resident)", w.process.pid, header["rss_mb"])
            self._replace(w)
        else:
            self._idle.put(w)
        info = {k: header[k] for k in ("cachesolve", "inputs", "peak_mb") if k in header}
        return int(header["status"]), text, header.get("uri", uri or ""), info

    def close(self) -> None:
        self._closed = True
        with self._lock:
            workers = list(self._all)
        for w in workers:
            w.kill()
        with self._lock:
            self._all.clear()
