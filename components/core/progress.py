"""Progress of a long computation: ``report(fraction, stage)`` at stage boundaries, a no-op unless someone listens.

Components call :func:`report` at the stage boundaries of their pipelines; whoever runs them (the server's solver
process, a job, a script) may install a sink with :func:`reporting` to receive ``(fraction, stage)`` pairs.
Components never learn who listens: this module imports nothing of the project.

Nesting without bookkeeping in the components: the first function that reports under a sink owns the overall
fraction (0..1). A stage it announces with ``until=`` spans ``[fraction, until]``, and the reports of the functions
it calls (e.g. the planarizer's iterations inside a strategy) are mapped into that span; without ``until`` they
only name the sub-stage. The fraction a sink receives never decreases.

Example
-------
>>> seen = []
>>> def inner():
...     for i in range(3):
...         report(i / 2, f"iteration {i}")
>>> def pipeline():
...     report(0.0, "field")
...     report(0.5, "planarize", until=0.9)
...     inner()
...     report(0.9, "health")
>>> with reporting(lambda f, s: seen.append((round(f, 2), s))):
...     pipeline()
>>> seen
[(0.0, 'field'), (0.5, 'planarize'), (0.5, 'planarize: iteration 0'), (0.7, 'planarize: iteration 1'), \
(0.9, 'planarize: iteration 2'), (0.9, 'health')]
>>> report(0.3, "nobody listens")  # a no-op
"""
from __future__ import annotations

import contextvars
import sys
from contextlib import contextmanager
from typing import Callable

__all__ = ["Cancelled", "report", "reporting"]


class Cancelled(BaseException):
    """Raised out of :func:`report` by a sink whose computation was cancelled (a ``BaseException``, so the
    ``except Exception`` of a component does not swallow it)."""


class _State:
    __slots__ = ("sink", "owner", "fraction", "until", "stage", "sent")

    def __init__(self, sink):
        self.sink = sink
        self.owner = None  # the frame of the first function that reported
        self.fraction = 0.0  # the owner's last fraction
        self.until = None  # ... and the end of its current stage
        self.stage = ""
        self.sent = 0.0  # the largest fraction sent to the sink


_current: contextvars.ContextVar[_State | None] = contextvars.ContextVar("components_progress", default=None)


def report(fraction: float, stage: str = "", until: float | None = None) -> None:
    """Tell the listener (if any) that ``fraction`` (0..1) of the work is done and ``stage`` starts.

    ``until`` announces where this stage ends, so the reports of the functions it calls are mapped into
    ``[fraction, until]``. Never raises, except :class:`Cancelled` when the listener cancels the computation.
    """
    state = _current.get()
    if state is None:
        return
    try:
        f = min(max(float(fraction), 0.0), 1.0)
    except (TypeError, ValueError):
        return
    frame = sys._getframe(1)
    if state.owner is None:
        state.owner = frame
    if frame is state.owner:
        state.stage = str(stage)
        state.fraction = f
        state.until = None if until is None else min(max(float(until), f), 1.0)
        value, name = f, state.stage
    else:  # a step called by the owner: within the owner's current span
        value = state.fraction if state.until is None else state.fraction + f * (state.until - state.fraction)
        name = f"{state.stage}: {stage}" if state.stage and stage else str(stage or state.stage)
    state.sent = value = max(value, state.sent)
    try:
        state.sink(value, name)
    except Cancelled:
        raise
    except Exception:  # a listener's failure never breaks the computation
        pass


@contextmanager
def reporting(sink: Callable[[float, str], None]):
    """Send the :func:`report` calls made inside the ``with`` block (in this thread/context) to ``sink``."""
    token = _current.set(_State(sink))
    try:
        yield
    finally:
        _current.reset(token)
