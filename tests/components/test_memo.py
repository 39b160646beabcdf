"""components.core.memo: content-keyed caches shared by the stages, bounded, thread-safe, forgotten on request."""
import threading

import numpy as np

from components.core import memo, proximity
from components.core.memo import ContentCache, digest


def test_digest_is_by_content_dtype_and_shape():
    a = np.arange(12.0)
    assert digest(a) == digest(a.copy()) == digest(a.reshape(3, 4)[:, :].ravel())
    assert digest(a) != digest(a.reshape(3, 4))  # shape
    assert digest(a) != digest(a.astype(np.float32))  # dtype
    b = a.copy()
    b[5] += 1e-12
    assert digest(a) != digest(b)
    assert digest(a[::2]) == digest(np.ascontiguousarray(a[::2]))  # views hash their elements
    assert digest("lscm", a) != digest("spectral", a) and digest(1.0) != digest(1)


def test_entries_and_weight_bound_what_is_kept():
    c = ContentCache("test entries", entries=2)
    built = []
    for k in (1, 2, 3, 1):
        c.get(k, lambda k=k: built.append(k) or k)
    assert built == [1, 2, 3, 1] and len(c) == 2  # 1 was evicted by 3, so built again
    c.get(3, lambda: built.append("again"))
    assert built[-1] == 1  # 3 kept
    w = ContentCache("test weight", entries=10, limit=10, weight=len)
    w.get("a", lambda: "x" * 6)
    w.get("b", lambda: "x" * 6)  # 12 > 10: "a" goes
    assert len(w) == 1 and w.get("b", lambda: None) == "x" * 6
    w.get("c", lambda: "x" * 50)  # the newest is kept even over the limit
    assert len(w) == 1 and w.get("c", lambda: None) == "x" * 50


def test_threads_share_one_cache_without_errors():
    c = ContentCache("test threads", entries=3)
    errors, results = [], []

    def work(i):
        try:
            for j in range(200):
                results.append(c.get(j % 5, lambda j=j: (j % 5) * 10))
        except Exception as exc:  # pragma: no cover - the failure this test is about
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    assert not errors and len(c) <= 3
    assert set(results) == {0, 10, 20, 30, 40}


def test_clear_all_forgets_the_stage_caches():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]], float)
    T = np.array([[0, 1, 2], [1, 3, 2]])
    proximity.TriangleIndex(V, T).query(np.array([[0.2, 0.2, 1.0]]))
    assert len(proximity._CACHE) >= 1
    memo.clear_all()
    assert len(proximity._CACHE) == 0
    d = proximity.TriangleIndex(V, T).query(np.array([[0.2, 0.2, 1.0]])).distances
    assert np.allclose(d, 1.0)
