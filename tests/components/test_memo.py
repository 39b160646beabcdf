"""components.core.memo: content-keyed caches shared by the stages, bounded, thread-safe, forgotten on request; the
checks and loops kept through them (validate_mesh, cached_boundary_loops)."""
import gc
import threading

import numpy as np
import pytest

from components.core import memo, proximity
from components.core.checks import validate_mesh
from components.core.conformal import cached_boundary_loops
from components.core.errors import MeshError
from components.core.memo import ContentCache, digest
from components.core.mesh import boundary_loops, quad_grid, triangulate


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


def test_a_value_asked_for_by_two_threads_at_once_is_built_once():
    c = ContentCache("test once", entries=4)
    started, release, built = threading.Event(), threading.Event(), []

    def slow():
        built.append(1)
        started.set()
        release.wait(10)
        return "value"

    out = []
    first = threading.Thread(target=lambda: out.append(c.get("k", slow)))
    first.start()
    assert started.wait(10)
    second = threading.Thread(target=lambda: out.append(c.get("k", slow)))
    second.start()
    second.join(0.2)
    assert second.is_alive()  # waits for the first thread's build instead of building
    release.set()
    first.join(10)
    second.join(10)
    assert out == ["value", "value"] and built == [1]


def test_a_failed_build_lets_a_waiting_thread_build_the_value():
    c = ContentCache("test failed build", entries=4)
    started, release = threading.Event(), threading.Event()

    def failing():
        started.set()
        release.wait(10)
        raise RuntimeError("no")

    errors, out = [], []

    def first():
        try:
            c.get("k", failing)
        except RuntimeError as exc:
            errors.append(str(exc))

    t1 = threading.Thread(target=first)
    t1.start()
    assert started.wait(10)
    t2 = threading.Thread(target=lambda: out.append(c.get("k", lambda: "built by the second")))
    t2.start()
    release.set()
    t1.join(10)
    t2.join(10)
    assert errors == ["no"] and out == ["built by the second"] and c.get("k", lambda: None) == "built by the second"


def test_clear_all_forgets_the_stage_caches():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]], float)
    T = np.array([[0, 1, 2], [1, 3, 2]])
    proximity.TriangleIndex(V, T).query(np.array([[0.2, 0.2, 1.0]]))
    assert len(proximity._CACHE) >= 1
    memo.clear_all()
    assert len(proximity._CACHE) == 0
    d = proximity.TriangleIndex(V, T).query(np.array([[0.2, 0.2, 1.0]])).distances
    assert np.allclose(d, 1.0)


class _Value:
    """A weak-referenceable value."""

    def __init__(self, k):
        self.k = k


def test_an_evicted_value_still_held_elsewhere_is_found_again_not_rebuilt():
    c = ContentCache("test revival", entries=1)
    built = []

    def build(k):
        built.append(k)
        return _Value(k)

    held = c.get("a", lambda: build("a"))
    c.get("b", lambda: build("b"))  # evicts "a", which `held` keeps alive
    assert len(c) == 1 and c.get("a", lambda: build("a")) is held and built == ["a", "b"]
    # "b" was evicted by the revived "a" and nothing holds it any more: built again
    gc.collect()
    assert c.get("b", lambda: build("b")).k == "b" and built == ["a", "b", "b"]
    c.clear()  # forgets the weakly kept ones too
    assert c.get("a", lambda: build("a")) is not held and built[-1] == "a" and len(c) == 1


def test_validate_mesh_keeps_passes_only_and_words_each_failure_for_its_caller():
    V, Q = quad_grid(6, 6)
    T = triangulate(Q)[0]
    V1, T1 = validate_mesh(V, T)
    V2, T2 = validate_mesh(V.copy(), T.copy())  # the passes are found again: same result, fresh arrays
    assert np.array_equal(V1, V2) and np.array_equal(T1, T2) and V2 is not V1 and T2 is not T1
    W = V.copy()
    W[T[0, 1]] = W[T[0, 0]] + 0.5 * (W[T[0, 2]] - W[T[0, 0]])  # same faces, face 0 collapsed to a segment
    for name in ("surface", "reference"):  # a failure is never kept: raised again, for the name given
        with pytest.raises(MeshError, match=rf"^{name}: face 0 is degenerate \(zero area\)"):
            validate_mesh(W, T, name=name)
    validate_mesh(W, T, allow_degenerate=True)
    bad = T.copy()
    bad[1] = bad[1, ::-1]  # face 1 turned over: an edge used twice in the same direction
    for name in ("a", "b"):
        with pytest.raises(MeshError, match=rf"^{name}: faces are not consistently oriented"):
            validate_mesh(V, bad, name=name)
    assert validate_mesh(V, bad, manifold=False)[1] is not None


def test_cached_boundary_loops_are_fresh_copies_of_the_loops():
    T = triangulate(quad_grid(5, 4)[1])[0]
    first = cached_boundary_loops(T)
    assert [a.tolist() for a in first] == [a.tolist() for a in boundary_loops(T)]
    first[0][:] = -1  # a caller may change what it got
    again = cached_boundary_loops(T.copy())
    assert [a.tolist() for a in again] == [a.tolist() for a in boundary_loops(T)]
