"""components.core.parallel: independent steps on two threads give exactly the sequential results; the field and
the candidate are bit for bit the same with one thread and with two."""
import hashlib
import os
import threading

import numpy as np
import pytest

from components.core import parallel
from components.core.mesh import quad_grid, triangulate
from components.core.parallel import ThreadOwned, concurrently, for_each, thread_count
from components.fields.candidate import candidate_mesh
from components.fields.parametrize import direction_field


@pytest.fixture
def two_threads(monkeypatch):
    monkeypatch.setenv(parallel.ENV_THREADS, "2")


def test_thread_count_follows_the_environment(monkeypatch):
    monkeypatch.setenv(parallel.ENV_THREADS, "3")
    assert thread_count() == 3
    monkeypatch.setenv(parallel.ENV_THREADS, "1")
    assert thread_count() == 1
    for bad in ("0", "-2", "two", ""):
        monkeypatch.setenv(parallel.ENV_THREADS, bad)
        assert 1 <= thread_count() <= parallel.MAX_THREADS  # ignored: the cores


def test_calls_run_at_the_same_time_and_results_keep_their_order(two_threads):
    both = threading.Barrier(2, timeout=10)  # broken (an error) unless the two calls run at the same time

    def meet(x):
        both.wait()
        return x

    assert concurrently(lambda: meet("a"), lambda: meet("b")) == ["a", "b"]


def test_one_thread_runs_everything_in_the_calling_thread(monkeypatch):
    monkeypatch.setenv(parallel.ENV_THREADS, "1")
    me = threading.get_ident()
    assert concurrently(threading.get_ident, threading.get_ident) == [me, me]
    seen = []
    for_each(lambda i: seen.append((i, threading.get_ident())), range(5))
    assert seen == [(i, me) for i in range(5)]


def test_the_first_error_is_raised_after_every_call_has_ended(two_threads):
    ended = threading.Event()

    def slow_ok():
        ended.wait(0.2)
        ended.set()
        return 1

    def fail(msg):
        raise ValueError(msg)

    with pytest.raises(ValueError, match="first"):
        concurrently(lambda: fail("first"), slow_ok, lambda: fail("third"))
    assert ended.is_set()
    with pytest.raises(ValueError, match="second"):
        concurrently(lambda: 0, lambda: fail("second"))


def test_nested_use_does_not_wait_for_itself(two_threads):
    inner = concurrently(lambda: concurrently(lambda: 1, lambda: 2), lambda: concurrently(lambda: 3, lambda: 4))
    assert inner == [[1, 2], [3, 4]]


def test_for_each_visits_every_item_once(two_threads):
    out = np.zeros(1000, dtype=np.int64)

    def fill(i):
        out[i * 10:(i + 1) * 10] += i

    for_each(fill, range(100))
    assert np.array_equal(out, np.repeat(np.arange(100), 10))


def _wavy(n):
    V, Q = quad_grid(n, n, 6.0, 6.0, height=lambda x, y: 0.4 * np.sin(0.8 * x) * np.cos(0.6 * y) + 0.05 * x * y)
    return V, triangulate(Q)[0]


def _sha(*arrays):
    h = hashlib.sha1()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def test_the_field_is_bit_identical_on_one_and_two_threads(monkeypatch):
    V, T = _wavy(40)  # 3,200 triangles: the local step runs on one block; the solves and factorizations in pairs
    out = {}
    for n in ("1", "2"):
        monkeypatch.setenv(parallel.ENV_THREADS, n)
        out[n] = _sha(*direction_field(V, T, field="conjugate"))
    assert out["1"] == out["2"]


def test_the_local_step_blocks_are_bit_identical_on_one_and_two_threads(monkeypatch):
    from components.fields import field as F

    V, T = _wavy(30)
    monkeypatch.setattr(F, "_CHUNK", 97)  # many blocks of odd size, shared out among the threads
    out = {}
    for n in ("1", "2"):
        monkeypatch.setenv(parallel.ENV_THREADS, n)
        s = F.smooth_frame_field(V, T, diagnostics=False)
        c = F.conjugate_frame_field(V, T, s.U, s.W, iterations=5, diagnostics=False)
        out[n] = _sha(c.U, c.W)
    assert out["1"] == out["2"]


def test_the_candidate_is_bit_identical_on_one_and_two_threads(monkeypatch):
    V, T = _wavy(30)
    out = {}
    for n in ("1", "2"):
        monkeypatch.setenv(parallel.ENV_THREADS, n)
        c = candidate_mesh((V, T), 0.6, boundary="auto", repair=True)
        out[n] = (_sha(c.V, c.F), c.quads, round(c.timings["parametrize"] + c.timings["extract"], 6) > 0)
    assert out["1"] == out["2"]


def test_candidates_repaired_two_at_a_time_are_those_of_one_at_a_time(monkeypatch):
    """With the first candidates judged unhealthy the search repairs the ranking two at a time after the first:
    the same repairs, judged in the same order, and the same candidate as on one thread."""
    from components.fields import candidate as C

    V, T = _wavy(30)
    real, real_ranked, real_repair = C.candidate_health, C._best_first, C.repaired_candidate
    out = {}
    for n in ("1", "2"):
        monkeypatch.setenv(parallel.ENV_THREADS, n)
        judged = []

        def health(Vc, Fc, ref, judged=judged):  # the first three judged unhealthy, every panel
            judged.append(_sha(Vc, Fc))
            h = real(Vc, Fc, ref)
            bad = np.ones_like(h.face_defects)
            return h._replace(healthy=False, face_defects=bad) if len(judged) <= 3 else h

        ranking, repaired = [], {}

        def ranked(*a, ranking=ranking):
            for ex, par in real_ranked(*a):
                ranking.append(_sha(ex.V, ex.F))
                yield ex, par

        def repair(V, T, Vc, Fc, *a, repaired=repaired, **k):
            r = real_repair(V, T, Vc, Fc, *a, **k)
            repaired[_sha(Vc, Fc)] = _sha(r.V, r.F)
            return r

        monkeypatch.setattr(C, "candidate_health", health)
        monkeypatch.setattr(C, "_best_first", ranked)
        monkeypatch.setattr(C, "repaired_candidate", repair)
        c = candidate_mesh((V, T), 0.6, boundary="auto", repair=True)
        out[n] = (judged, _sha(c.V, c.F))
        # judged in the ranking's order, as one at a time would
        assert judged == [repaired[h] for h in ranking if h in repaired][:len(judged)]
    assert len(out["1"][0]) >= 4
    assert out["1"] == out["2"]


def test_the_coarse_copys_field_is_bit_identical_on_one_and_two_threads(monkeypatch):
    from components.fields import parametrize

    monkeypatch.setattr(parametrize, "TWO_LEVEL_FACES", 2000)  # the coarse copy and the curvature side by side
    monkeypatch.setattr(parametrize, "COARSE_FACES", 1000)
    V, T = _wavy(40)
    out = {}
    for n in ("1", "2"):
        monkeypatch.setenv(parallel.ENV_THREADS, n)
        out[n] = _sha(*direction_field(V, T, field="conjugate", resolution=0.6))
    assert out["1"] == out["2"]


def test_calls_run_here_when_no_thread_can_be_started(two_threads, monkeypatch):
    def refuse(*args, **kwargs):
        raise RuntimeError("can't start new thread")

    for helper in parallel._executors():
        monkeypatch.setattr(helper, "submit", refuse)
    me = threading.get_ident()
    assert concurrently(lambda: 1, threading.get_ident, lambda: 3) == [1, me, 3]


def test_calls_run_again_one_by_one_when_one_runs_out_of_memory(two_threads):
    both = threading.Barrier(2, timeout=10)
    running = []

    def once_out_of_memory():
        running.append("big")
        if running.count("big") == 1:
            both.wait()  # the other call is running at the same time
            raise MemoryError
        return "big done"

    def other():
        running.append("other")
        if running.count("other") == 1:
            both.wait()
        return "other done"

    assert concurrently(other, once_out_of_memory) == ["other done", "big done"]
    assert running.count("big") == 2 and running.count("other") == 2  # beside each other, then one by one
    assert running[-2:] == ["other", "big"]

    def always():
        raise MemoryError

    with pytest.raises(MemoryError):
        concurrently(lambda: 1, always)


def test_for_each_runs_an_item_out_of_memory_again_at_the_end(two_threads):
    out, tries = np.zeros(50), []

    def fill(i):
        tries.append(i)
        if i == 7 and tries.count(7) == 1:
            raise MemoryError
        out[i] = i

    for_each(fill, range(50))
    assert np.array_equal(out, np.arange(50.0)) and tries.count(7) == 2


def test_one_thread_in_a_process_capped_under_4_gb(monkeypatch):
    monkeypatch.delenv(parallel.ENV_THREADS, raising=False)
    monkeypatch.setattr(parallel, "_address_space_cap_mb", lambda: 1024.0)
    assert thread_count() == 1
    monkeypatch.setenv(parallel.ENV_THREADS, "2")  # asked for explicitly: given
    assert thread_count() == 2
    monkeypatch.delenv(parallel.ENV_THREADS)
    monkeypatch.setattr(parallel, "_address_space_cap_mb", lambda: 8192.0)
    assert thread_count() == min(parallel.MAX_THREADS, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count())


class _Probe:
    """Records the thread it is released in."""

    def __init__(self, log: list):
        self.log = log

    def value(self):
        return 42

    def __del__(self):
        self.log.append(threading.get_ident())


def _flush_helpers():
    """Waits until every helper has run what was sent to it before (each runs its work in order)."""
    n = len(parallel._executors())
    concurrently(*([lambda: None] * (n + 1)))


def test_an_object_made_on_a_helper_is_released_on_that_helper(two_threads):
    released = []
    _, (owned, helper) = concurrently(lambda: None, lambda: (ThreadOwned(_Probe(released)), threading.get_ident()))
    assert helper != threading.get_ident()
    assert owned.value() == 42  # its attributes are the object's
    del owned
    _flush_helpers()
    assert released == [helper]  # dropped here, released there
    # made in the calling thread: released where it is dropped, at once
    here = ThreadOwned(_Probe(released))
    del here
    assert released == [helper, threading.get_ident()]
    # made and dropped on the helper: released there
    concurrently(lambda: None, lambda: ThreadOwned(_Probe(released)) and None)
    _flush_helpers()
    assert released[-1] == helper


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads the address space from /proc (Linux)")
def test_a_factor_made_on_a_helper_leaves_no_memory_behind(two_threads):
    """SciPy frees a SuperLU factor's memory only in the thread that made it (scipy #15921): the direction field's
    factor made on a helper and dropped here grew the process by its size every time (115 MB for these 20k rows)."""
    import gc

    import scipy.sparse as sp

    from components.fields.field import _factor

    n, k = 20000, 141
    A = (sp.diags([np.full(n - 1, -1.0), np.full(n, 4.5), np.full(n - 1, -1.0), np.full(n - k, -1.0),
                   np.full(n - k, -1.0)], [-1, 0, 1, -k, k]) * (1 + 0.1j)).tocsc()

    def address_space_mb():
        with open("/proc/self/status") as fh:
            return int(fh.read().split("VmSize:")[1].split()[0]) / 1e3

    sizes = []
    for _ in range(5):
        _, lu = concurrently(lambda: None, lambda: _factor(A))
        assert np.allclose(A @ lu.solve(np.ones(n)), 1.0)
        del lu
        gc.collect()
        _flush_helpers()
        sizes.append(address_space_mb())
    assert sizes[-1] - sizes[0] < 50, sizes  # four factors of ~115 MB each, released
