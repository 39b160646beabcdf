"""Independent steps on the machine's cores: a few threads for work that releases the GIL.

SuperLU's factorizations and solves and numpy's array operations on large arrays release the GIL, so two of them
run at once on two cores. :func:`concurrently` runs a few independent calls (two factorizations, two solves),
:func:`for_each` a function over independent items (blocks of faces), both returning what a plain sequential run
returns, bit for bit: each call computes exactly what it would alone, only the order in time changes. Nothing here
may be used for calls that share mutable state.

The thread count is :data:`ENV_THREADS` (``GHSERVER_THREADS``) when set (``1`` = everything in the calling
thread), else one in a process capped under :data:`MIN_CAP_MB` of address space, else the cores this process may
use, at most :data:`MAX_THREADS`. The pool is made on first use in each process (solver processes are started
fresh) and a call made from inside a pool thread runs sequentially, so nested uses never wait for each other. Where
no thread can be started (a process near its address-space cap) the calls run in the calling thread. A SuperLU
factor made in a helper and used after its call returns is wrapped in :class:`ThreadOwned`, so that its memory is
released in the helper that made it (SciPy frees it only there).

Example
-------
>>> concurrently(lambda: 1 + 1, lambda: 2 * 3)
[2, 6]
>>> out = [0] * 4
>>> for_each(lambda i: out.__setitem__(i, i * i), range(4))
>>> out
[0, 1, 4, 9]
"""
from __future__ import annotations

import logging
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable

__all__ = ["ENV_THREADS", "MAX_THREADS", "MIN_CAP_MB", "ThreadOwned", "thread_count", "concurrently", "for_each"]

log = logging.getLogger(__name__)

ENV_THREADS = "GHSERVER_THREADS"
MAX_THREADS = 4  # the steps' independent parts are few (pairs of systems, two boundary modes); measured on 2 cores
MIN_CAP_MB = 4096  # a process capped under this many MB of address space uses one thread (see thread_count)
_lock = threading.Lock()
_pool: list[ThreadPoolExecutor] = []
_pool_key: tuple | None = None  # (pid, size) the pool was made for
_local = threading.local()


def thread_count() -> int:
    """Threads the steps may use: ``GHSERVER_THREADS`` when set to a positive integer; else one in a process whose
    address space is capped under :data:`MIN_CAP_MB` (a server's solver process on a machine with little memory
    per worker: steps at the same time hold their memory at the same time, and 50k triangles at 1 GB ran out of
    memory with two threads and not with one); else this process's cores (at most :data:`MAX_THREADS`)."""
    env = os.environ.get(ENV_THREADS, "").strip()
    if env:
        try:
            n = int(env)
        except ValueError:
            n = 0
        if n >= 1:
            return n
    if _address_space_cap_mb() < MIN_CAP_MB:
        return 1
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # Windows, macOS
        cores = os.cpu_count() or 1
    return max(1, min(MAX_THREADS, cores))


def _address_space_cap_mb() -> float:
    """The process's address-space cap (``RLIMIT_AS``) in MB, infinite where there is none or it is unknown."""
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, AttributeError, OSError, ValueError):  # Windows
        return float("inf")
    return float("inf") if soft == resource.RLIM_INFINITY or soft < 0 else soft / 2**20


def _executors() -> list[ThreadPoolExecutor]:
    """The process's :func:`thread_count` − 1 helper threads (the caller's thread is the last one), each its own
    one-thread executor so that work can be sent to a given helper (:class:`ThreadOwned`); empty inside a helper
    thread or with one thread."""
    global _pool, _pool_key
    n = thread_count()
    if n <= 1 or getattr(_local, "home", None) is not None:
        return []
    key = (os.getpid(), n)
    with _lock:
        if _pool_key != key:  # first use, or a forked child, or another thread count
            _pool = [_helper(i) for i in range(n - 1)]
            _pool_key = key
        return _pool


def _helper(i: int) -> ThreadPoolExecutor:
    box: list = []
    ex = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"ghserver-step{i}", initializer=_mark_helper,
                            initargs=(box,))
    box.append(ex)  # before its thread starts (at the first submit)
    return ex


def _mark_helper(box: list):
    _local.home = box[0]  # the helper thread's own executor


class ThreadOwned:
    """``obj`` (a SuperLU factor) released in the thread that made it, whichever thread drops the last reference to
    this wrapper; its attributes are ``obj``'s (``owned.solve(b)``).

    SciPy's SuperLU tracks the memory of a factorization per thread and frees it only from the thread that
    allocated it (scipy issue #15921): a factor made in a helper thread of :func:`concurrently` and dropped in the
    caller's is never freed, and a solver process's address space grew by the factors of every request (the
    canopy's pipeline three times in one process: 0.50 → 1.46 → 2.13 → 2.79 GB) until a large request met its cap.
    Made in a helper thread, the wrapper hands ``obj`` back to that helper to be dropped there; made in any other
    thread (the caller's), it does nothing, and ``obj`` must be dropped in that thread (as a local variable is).
    Nothing made in a helper that holds such memory may leave the helper's call except in a wrapper."""

    __slots__ = ("_box", "_home", "_pid")

    def __init__(self, obj):
        self._box = [obj]
        self._home = getattr(_local, "home", None)
        self._pid = os.getpid()

    def __getattr__(self, name: str):
        if name in ThreadOwned.__slots__:  # not set: __init__ did not run to its end
            raise AttributeError(name)
        return getattr(self._box[0], name)

    def __del__(self):
        home = getattr(self, "_home", None)
        if home is None or getattr(_local, "home", None) is home or os.getpid() != self._pid:
            return  # made in the caller's thread, or dropped where it was made: released here, as usual
        try:
            home.submit(self._box.clear)  # the helper drops the last reference: its memory is freed there
        except RuntimeError:  # the helper is shut down (the interpreter exits): the memory goes with the process
            pass


def concurrently(*calls: Callable[[], object]) -> list:
    """The results of the zero-argument ``calls``, in order; the first runs in the calling thread, the others on the
    pool at the same time. When a call runs out of memory (together they may need more than a capped process has),
    the results are dropped and the calls run again one after the other; otherwise the first exception (in call
    order) is raised after all calls have ended."""
    helpers = _executors() if len(calls) > 1 else []
    if not helpers:
        return [c() for c in calls]
    futures = []
    for i, c in enumerate(calls[1:]):  # call i + 1 on helper i (round robin), each helper one call at a time
        try:
            futures.append(helpers[i % len(helpers)].submit(c))
        except RuntimeError:  # no thread could be started (e.g. a solver process's address-space cap): the rest
            break  # run here, after the first
    out, errors = [None] * len(calls), [None] * len(calls)
    try:
        for i in [0] + list(range(1 + len(futures), len(calls))):
            try:
                out[i] = calls[i]()
            except MemoryError as exc:
                errors[i] = exc
    finally:
        for i, f in enumerate(futures, start=1):  # wait for every call before anything is raised
            errors[i] = f.exception()
            if errors[i] is None:
                out[i] = f.result()
    if any(isinstance(exc, MemoryError) for exc in errors):
        # too much at once for a capped solver process: every call again, one after the other, as with one thread
        # (the results so far are dropped first, so that their memory is free)
        out = errors = None
        log.info("%d steps ran out of memory beside each other: again one after the other", len(calls))
        return [c() for c in calls]
    for exc in errors:
        if exc is not None:
            raise exc
    return out


def for_each(fn: Callable[[object], None], items: Iterable) -> None:
    """``fn(item)`` for every item, the items shared out among the threads (each takes the next free one); an item
    that runs out of memory is run again alone at the end. ``fn`` must only write what belongs to its item."""
    items = list(items)
    n = min(thread_count(), len(items))
    if n <= 1 or not _executors():
        for it in items:
            fn(it)
        return
    lock = threading.Lock()
    queue = iter(items)
    again = []  # items that ran out of memory beside the others: run alone at the end

    def worker():
        while True:
            with lock:
                it = next(queue, _DONE)
            if it is _DONE:
                return
            try:
                fn(it)
            except MemoryError:
                with lock:
                    again.append(it)

    concurrently(*([worker] * n))
    for it in again:
        fn(it)


_DONE = object()
