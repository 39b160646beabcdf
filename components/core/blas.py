"""One BLAS thread while sparse systems are factored and solved.

scipy's SuperLU hands its supernodes to the OpenBLAS bundled with scipy, and OpenBLAS starts a thread per core for
them. On a machine whose cores are busy with other work (a server's other solver processes, other jobs) those
threads wait for each other and a factorization takes many times longer: the same 20k-face complex factorization
(minimum-degree ordering, no pivoting, identical fill) took 0.34, 1.2 and 2.7 s of CPU time in three runs with
OpenBLAS' default threads and 0.10-0.15 s with one thread (2 cores shared with other jobs). This is the "sparse
factorization times swing 10-100x run to run" of the project notes. The factors, and so the results, are the same
either way.

:func:`single_blas_thread` is a context manager that sets the thread count of the OpenBLAS libraries bundled with
scipy and numpy (the pip wheels on Windows, macOS and Linux) to one and restores it on exit; nested and concurrent
uses are counted. Where no such library is found (another BLAS) it does nothing.
"""
from __future__ import annotations

import ctypes
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import scipy

__all__ = ["single_blas_thread", "blas_thread_controls"]

_NAMES = ("scipy_openblas", "openblas")  # symbol prefixes: scipy's wheels, then a plain OpenBLAS
_SUFFIXES = ("", "64_", "_64_")
_lock = threading.Lock()
_depth = 0
_saved: list = []
_controls: list | None = None


def _library_files() -> list[Path]:
    """OpenBLAS shared libraries shipped inside the scipy and numpy packages (Linux ``*.libs``, macOS ``.dylibs``,
    Windows ``*.libs`` DLLs)."""
    out = []
    for pkg in (scipy, np):
        base = Path(pkg.__file__).resolve().parent
        for folder in (base.parent / f"{base.name}.libs", base / ".dylibs"):
            if folder.is_dir():
                out += sorted(p for p in folder.iterdir() if "openblas" in p.name.lower())
    return out


def _find_controls() -> list:
    """``(get, set)`` thread-count functions of every bundled OpenBLAS library that has them."""
    found, seen = [], set()
    for path in _library_files():
        try:
            lib = ctypes.CDLL(str(path))
        except OSError:
            continue
        for prefix in _NAMES:
            for suffix in _SUFFIXES:
                get = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
                put = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
                if get is None or put is None:
                    continue
                key = ctypes.cast(put, ctypes.c_void_p).value
                if key in seen:
                    continue
                seen.add(key)
                get.restype, get.argtypes = ctypes.c_int, []
                put.restype, put.argtypes = None, [ctypes.c_int]
                found.append((get, put))
                break
            else:
                continue
            break
    return found


def blas_thread_controls() -> list:
    """The ``(get, set)`` thread-count functions :func:`single_blas_thread` uses (found once, then kept)."""
    global _controls
    if _controls is None:
        try:
            _controls = _find_controls()
        except (OSError, AttributeError, ValueError):  # an unusual install: leave the threads alone
            _controls = []
    return _controls


@contextmanager
def single_blas_thread():
    """Run the block with one OpenBLAS thread (see the module notes); the previous counts come back on exit.

    Example
    -------
    >>> import scipy.sparse as sp
    >>> from scipy.sparse.linalg import splu
    >>> A = sp.csc_matrix(sp.diags([4.0, 5.0, 6.0]))
    >>> with single_blas_thread():
    ...     x = splu(A).solve(np.array([4.0, 10.0, 18.0]))
    >>> x.tolist()
    [1.0, 2.0, 3.0]
    """
    global _depth, _saved
    with _lock:
        if _depth == 0:
            _saved = [(put, get()) for get, put in blas_thread_controls()]
            for put, _ in _saved:
                put(1)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                for put, n in _saved:
                    put(n)
                _saved = []
