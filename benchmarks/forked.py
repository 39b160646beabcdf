"""What the benchmark scripts share: a measurement in a fresh process, and that process's peak memory.

Each measured case runs in a child process forked after the imports (:func:`run_forked`), so the peak resident
size it reports (:func:`peak_mb`, read in the child) is that case's own high-water mark, and a case that crashes
costs one row, not the table.
"""
from __future__ import annotations

import multiprocessing as mp
import time
from typing import Any, Callable


def peak_mb() -> float:
    """Peak resident memory of this process in MB (nan where the platform has no figure, e.g. Windows)."""
    try:
        import resource
    except ImportError:
        return float("nan")
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


def best_of(fn: Callable, repeat: int = 3, clock: Callable = time.perf_counter) -> tuple:
    """``(best time, last result)`` of ``repeat`` calls of ``fn()``, timed by ``clock`` (wall by default;
    ``time.process_time`` for CPU seconds)."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = clock()
        out = fn()
        best = min(best, clock() - t)
    return best, out


def counted_factorizations() -> list:
    """Count the planarizer's sparse factorizations in this (child) process from now on: a one-item list whose
    item grows with every call of ``components.planarize.step.factor_spd`` (the solver calls the module's
    function, so wrapping it counts without changing what it does)."""
    from components.planarize import step

    count = [0]
    factor = step.factor_spd

    def counted(S):
        count[0] += 1
        return factor(S)

    step.factor_spd = counted
    return count


def _child(conn, fn, args):
    conn.send(fn(*args))
    conn.close()


def run_forked(fn: Callable, *args, failed: Any = None) -> Any:
    """``fn(*args)`` in a fresh (forked where the platform can) process; its return value, or ``failed`` when the
    process dies before answering. ``fn`` must be a module-level function where processes are spawned."""
    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
    a, b = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_child, args=(b, fn, args))
    p.start()
    b.close()
    try:
        out = a.recv()
    except EOFError:
        out = failed
    p.join()
    return out
