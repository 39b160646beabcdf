"""Content-keyed memory of what a solve computes several times: one surface's closest-point index, its boundary,
a field's cut graph, a tracer, a plane map.

One strategy asks for the same thing again and again (every extraction and repair queries the same design surface;
the two streamline families share one tracer; the two boundary modes of the candidate share one cut graph). A
:class:`ContentCache` keeps the last few values keyed by a :func:`digest` of their inputs' *contents* (dtype, shape
and bytes), so a copy of the same arrays hits and a changed array misses; it is thread-safe (a value is built once
even when two threads ask for it at the same time), bounded in entries and, optionally, in a weight (e.g. triangles
held). A value pushed out by newer ones but still held elsewhere (a design surface's index kept by the object that
queries it while other meshes are indexed) is found again through a weak reference instead of being rebuilt: it
costs no memory the cache would hold. Every cache registers itself: :func:`clear_all` forgets them all, and the
server's solver processes call it after each solve, so what a solve leaves behind never outlives it.

Example
-------
>>> import numpy as np
>>> cache = ContentCache("example", entries=2)
>>> a = np.arange(6.0)
>>> cache.get(digest(a), lambda: float(a.sum())), cache.get(digest(a.copy()), lambda: -1.0)
(15.0, 15.0)
>>> len(cache), clear_all() or len(cache)
(1, 0)
"""
from __future__ import annotations

import hashlib
import threading
import weakref
from collections import OrderedDict
from typing import Any, Callable, Hashable

import numpy as np

__all__ = ["ContentCache", "clear_all", "digest"]

_ALL: "weakref.WeakSet[ContentCache]" = weakref.WeakSet()


def digest(*parts: Any) -> bytes:
    """A 20-byte digest of ``parts``: arrays by dtype, shape and bytes, anything else by its ``repr``."""
    h = hashlib.blake2b(digest_size=20)
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"a{a.dtype.str}{a.shape}".encode())
            h.update(a.view(np.uint8).reshape(-1))
        else:
            h.update(f"v{p!r}".encode())
        h.update(b"|")
    return h.digest()


class ContentCache:
    """The last ``entries`` values (most recently used kept), at most ``limit`` of their summed ``weight(value)``
    (the newest is always kept). Values are shared: treat them as read-only.

    A value evicted while something else still references it is kept by a weak reference (values that allow one:
    objects, arrays; not tuples or numbers) and returned again for its key, so what is alive anyway is not built
    twice; it then counts as recently used again."""

    def __init__(self, name: str, entries: int = 1, limit: float | None = None,
                 weight: Callable[[Any], float] | None = None):
        self.name = name
        self.entries = int(entries)
        self.limit = limit
        self.weight = weight
        self._items: OrderedDict = OrderedDict()
        self._evicted: weakref.WeakValueDictionary = weakref.WeakValueDictionary()  # evicted, alive elsewhere
        self._lock = threading.Lock()
        self._building: dict = {}  # key -> Event set when the thread building its value is done
        _ALL.add(self)

    def get(self, key: Hashable, build: Callable[[], Any]) -> Any:
        """The value kept under ``key`` (or evicted but still alive elsewhere), else ``build()`` (outside the lock),
        kept and returned. While one thread builds a key's value, another asking for the same key waits for it
        instead of building it too (if the build fails, the waiting thread builds it itself)."""
        while True:
            with self._lock:
                if key in self._items:
                    self._items.move_to_end(key)
                    return self._items[key]
                value = self._evicted.pop(key, None)
                if value is not None:
                    self._keep(key, value)
                    return value
                pending = self._building.get(key)
                if pending is None:
                    done = self._building[key] = threading.Event()
                    break
            pending.wait()
        try:
            value = build()
            with self._lock:
                self._keep(key, value)
        finally:
            with self._lock:
                del self._building[key]
            done.set()
        return value

    def _keep(self, key: Hashable, value: Any) -> None:
        """Store ``value`` as the newest entry and evict the oldest beyond the bounds (lock held)."""
        self._items[key] = value
        self._items.move_to_end(key)
        while len(self._items) > 1 and (len(self._items) > self.entries or self._over_limit()):
            old_key, old = self._items.popitem(last=False)
            try:
                self._evicted[old_key] = old
            except TypeError:  # no weak reference to it (a tuple, a number): simply forgotten
                pass

    def _over_limit(self) -> bool:
        if self.limit is None or self.weight is None:
            return False
        return sum(self.weight(v) for v in self._items.values()) > self.limit

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self._evicted.clear()

    def __len__(self) -> int:
        return len(self._items)


def clear_all() -> None:
    """Forget every :class:`ContentCache`'s values."""
    for cache in list(_ALL):
        cache.clear()
