"""Optional compiled kernels: numba where it is installed, the numpy code where it is not.

A few inner loops run tens of times over every face of a large mesh (the conjugate field's local step evaluates
16 samples of a cost per face in every one of its ~50 iterations). numpy evaluates such a loop as tens of passes
over temporaries, one ufunc at a time and holding the GIL between them; compiled, the same arithmetic runs in one
pass per sample without temporaries and without the GIL, so the step's threads run side by side.

numba is an optional dependency (``pip install ".[fast]"``; wheels on Windows, macOS and Linux). Without it, or
with ``GHSERVER_COMPILED=0``, or where it fails to import or to compile, every caller keeps its numpy code, which
stays the reference. A kernel performs the same IEEE operations as the numpy code it replaces, in the same order
and without fast-math (no reassociation, no fused multiply-add), and leaves transcendental functions to numpy, so
the results are the same bit for bit with and without it (the tests compare both).

Kernels are compiled when their module is imported (explicit signatures) and cached on disk by numba (next to
the module, or in the user's cache directory where that is read-only): the first import after an install compiles
for a few seconds, later ones load in a fraction of a second. Where no cache directory is writable they are
compiled anew in every process.

Example
-------
>>> from components.core.compiled import kernel
>>> @kernel("float64(float64[::1])")
... def total(x):
...     s = 0.0
...     for v in x:
...         s += v
...     return s
>>> import numpy as np
>>> total is None or total(np.arange(4.0)) == 6.0
True
"""
from __future__ import annotations

import logging
import os
from typing import Callable

log = logging.getLogger(__name__)

__all__ = ["ENV_COMPILED", "available", "kernel", "status"]

ENV_COMPILED = "GHSERVER_COMPILED"  # "0" (or "false", "no", "off"): numpy everywhere

_numba = None
_checked = False


def _disabled() -> bool:
    """Whether ``GHSERVER_COMPILED`` turns the kernels off."""
    return os.environ.get(ENV_COMPILED, "").strip().lower() in ("0", "false", "no", "off")


def _load():
    """numba, or None (absent, disabled, or failing to import)."""
    global _numba, _checked
    if not _checked:
        _checked = True
        if _disabled():
            return None
        try:
            import numba
        except Exception as exc:  # absent (ImportError) or broken (a numpy it does not support, ...)
            if not isinstance(exc, ImportError):
                log.warning("numba does not import (%s): the numpy code runs", exc)
            return None
        _numba = numba
    return _numba


def available() -> bool:
    """Whether kernels are compiled in this process (numba imports and ``GHSERVER_COMPILED`` does not disable it)."""
    return _load() is not None


def status() -> str:
    """One line for the server's log: whether kernels are compiled, and why not."""
    if available():
        return f"compiled kernels on (numba {_numba.__version__})"
    if _disabled():
        return f"compiled kernels off ({ENV_COMPILED}={os.environ[ENV_COMPILED]}): numpy code, the same results"
    return 'compiled kernels off (numba not installed: pip install ".[fast]"): numpy code, the same results'


def kernel(signature: str) -> Callable[[Callable], Callable | None]:
    """Decorator: the function compiled by numba for ``signature`` (at once, cached on disk, releasing the GIL), or
    None when numba is unavailable or the compilation fails (the caller then runs its numpy code)."""
    def wrap(fn: Callable) -> Callable | None:
        nb = _load()
        if nb is None:
            return None
        for cache in (True, False):  # no writable cache directory at all: compiled anew in every process
            try:
                return nb.njit(signature, cache=cache, nogil=True, error_model="numpy", fastmath=False)(fn)
            except Exception as exc:  # a numba that cannot compile it: the numpy code runs
                error = exc
        log.warning("numba could not compile %s (%s): the numpy code runs", fn.__name__, error)
        return None
    return wrap
