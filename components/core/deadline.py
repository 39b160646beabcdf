"""The time left for the current call: a deadline that whoever runs a component may set, read by the time budgets.

A component's ``time_budget`` is its own choice; whoever runs it may have a limit of its own. The server's solver
processes stop a solve at their time limit (``ghserver serve --solve-timeout``, 90 s by default) and then have no
answer to give. They set a deadline a little before that limit with :func:`deadline`; the solvers' budgets
(the planarizer's, and so every strategy's optimization) are cut to the time left (:func:`capped`), and the
pipelines skip optional further attempts once it has passed (:func:`expired`). The call then answers in time, with
its best state and a warning that names the limit. Components never learn who set the deadline: this module
imports nothing of the project. Without a deadline nothing changes.

The deadline belongs to the context (thread) that set it, like :mod:`components.core.progress`'s sink.

Example
-------
>>> time_left() == float("inf"), capped(30.0)
(True, (30.0, None))
>>> with deadline(5.0, "a 5 s limit"):
...     budget, why = capped(30.0)
...     with deadline(60.0, "a later one"):  # an inner deadline never extends an outer one
...         inner = capped(30.0)[1]
>>> budget <= 5.0, why, inner, expired()
(True, 'a 5 s limit', 'a 5 s limit', False)
>>> with deadline(0.0, "no time"):
...     expired()
True
"""
from __future__ import annotations

import contextvars
import math
import time
from contextlib import contextmanager
from typing import NamedTuple

__all__ = ["deadline", "time_left", "capped", "expired"]


class _Deadline(NamedTuple):
    at: float  # time.monotonic() of the deadline
    reason: str  # what sets it, for the warnings ("the server's time limit of 90 s ...")


_current: contextvars.ContextVar[_Deadline | None] = contextvars.ContextVar("components_deadline", default=None)


@contextmanager
def deadline(seconds: float, reason: str = "a time limit"):
    """Within the ``with`` block (this thread/context) the calls have at most ``seconds`` from now; a deadline
    already set that comes earlier stays."""
    at = time.monotonic() + max(float(seconds), 0.0)
    outer = _current.get()
    token = _current.set(outer if outer is not None and outer.at <= at else _Deadline(at, str(reason)))
    try:
        yield
    finally:
        _current.reset(token)


def time_left() -> float:
    """Seconds until the deadline (0 once it has passed; ``inf`` without one)."""
    d = _current.get()
    return math.inf if d is None else max(d.at - time.monotonic(), 0.0)


def capped(budget: float) -> tuple[float, str | None]:
    """``(budget, None)``, or ``(the time left, what set the deadline)`` when the deadline comes first."""
    d = _current.get()
    left = time_left()
    if d is None or left >= budget:
        return budget, None
    return left, d.reason


def expired() -> bool:
    """Whether a deadline is set and has passed."""
    return time_left() <= 0.0
