"""Jobs for long solves (POST/GET/DELETE /jobs/...) on the local solver processes and in the server process.

The ``check_*`` functions take a live server and are reused by ``test_cluster.py`` against a Dask cluster.
``registry()`` (the echo components, the published ones and ``test/stages``, which reports progress) is the
factory the solver processes and the Dask workers load.
"""
from __future__ import annotations

import json
import os
import time
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
import pytest
import requests

from components.core import progress
from components.core.mesh import quad_grid
from ghserver.app import Config, create_app
from ghserver.client import Client, ClientError
from ghserver.endpoints import COMPONENTS
from ghserver.registry import Registry, declare
from tests.ghserver import echo
from tests.ghserver.conftest import LiveServer, hops_body, hops_tree

FACTORY = "tests.ghserver.test_jobs:registry"

pytestmark = pytest.mark.skipif(os.name == "nt", reason="POSIX solver processes")


class StagesResult(NamedTuple):
    steps: int
    pid: int


def stages(steps: int = 5, seconds: float = 0.2) -> StagesResult:
    """Report progress through ``steps`` stages of ``seconds`` each (a long solve with known progress).

    Parameters
    ----------
    steps : int
        Number of stages.
    seconds : float
        Seconds each stage takes.

    Returns
    -------
    steps : int
        The stages run.
    pid : int
        Process id of the solver.
    """
    for i in range(int(steps)):
        progress.report(i / steps, f"step {i}")
        time.sleep(seconds)
    return StagesResult(int(steps), os.getpid())


def registry():
    """The echo components, the published ones and ``test/stages``."""
    return Registry(list(echo.registry()) + list(COMPONENTS) + [declare(stages, "test/stages")])


def stages_body(steps=8, seconds=0.15):
    return hops_body("test/stages", hops_tree("steps", [str(steps)]), hops_tree("seconds", [str(seconds)]))


def nap_body(seconds):
    return hops_body("test/nap", hops_tree("seconds", [str(seconds)]))


def conjugate_inputs():
    V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    return dict(mesh=(V, F), target_length=2.0)


def wait_state(url, job, states, timeout=30.0, headers=None):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        st = requests.get(f"{url}/jobs/{job}", headers=headers, timeout=10).json()
        if st["state"] in states:
            return st
        time.sleep(0.05)
    raise AssertionError(f"job {job} not {states} after {timeout} s: {st}")


# ----------------------------------------------------------------------------------------------
# checks shared with test_cluster.py


def check_progress_rises_and_result_equals_solve(url):
    body = stages_body()
    r = requests.post(f"{url}/jobs/test/stages", json=body, timeout=10)
    assert r.status_code == 202 and r.headers["Location"] == f"/jobs/{r.json()['id']}"
    job = r.json()["id"]
    seen = []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        st = requests.get(f"{url}/jobs/{job}", timeout=10).json()
        seen.append((st["state"], st["progress"], st["stage"]))
        if st["state"] not in ("queued", "running"):
            break
        time.sleep(0.05)
    assert st["state"] == "done" and st["status"] == 200 and st["progress"] == 1.0, st
    fractions = [p for _, p, _ in seen]
    assert fractions == sorted(fractions), "progress never goes back"
    running = {(p, s) for state, p, s in seen if state == "running" and 0 < p < 1}
    assert len(running) >= 3, f"progress should rise through the stages, saw {seen}"
    assert all(s.startswith("step ") for _, s in running)
    solved = requests.post(f"{url}/test/stages", json=body, timeout=60)
    assert solved.status_code == 200
    got, want = st["result"], solved.json()
    assert got["errors"] == want["errors"] == [] and got["values"][0] == want["values"][0]  # steps; pids differ


def check_strategy_job_equals_call(url):
    c = Client(url)
    job = c.submit("fields/pq_from_conjugate_field", **conjugate_inputs())
    res = c.result(job, timeout=120, poll=0.05)
    st = c.status(job)
    assert st["state"] == "done" and st["progress"] == 1.0
    direct = c.call("fields/pq_from_conjugate_field", **conjugate_inputs())
    assert type(res).__name__ == type(direct).__name__
    for a, b, name in zip(res, direct, res._fields):
        if isinstance(a, tuple) and len(a) == 2 and isinstance(a[0], np.ndarray):
            assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]), name
        elif isinstance(a, np.ndarray):
            assert np.array_equal(a, b), name
        elif name.startswith("time_"):
            continue
        else:
            assert a == b, name
    assert res.planarized_max_planarity <= 1e-4


def check_cancel_frees_the_workers(url, n_workers=2, before_quick=None):
    """Occupy every worker with a 30 s job, cancel them: a quick solve answers within 2 s of the cancels."""
    jobs = [requests.post(f"{url}/jobs/test/nap", json=nap_body(30), timeout=10).json()["id"]
            for _ in range(n_workers)]
    for job in jobs:
        wait_state(url, job, ("running",))
    time.sleep(0.3)
    meta_t = time.monotonic()
    assert requests.get(f"{url}/test/nap", timeout=5).status_code == 200  # metadata while every worker is busy
    assert time.monotonic() - meta_t < 5.0  # answered here, never queued behind the solves
    t0 = time.monotonic()
    for job in jobs:
        r = requests.delete(f"{url}/jobs/{job}", timeout=5)
        assert r.status_code == 200 and r.json()["state"] == "cancelled"
    with ThreadPoolExecutor(n_workers) as ex:
        quick = list(ex.map(lambda _: requests.post(f"{url}/test/nap", json=nap_body(0), timeout=30),
                            range(n_workers)))
    elapsed = time.monotonic() - t0
    assert all(q.status_code == 200 for q in quick), [q.text for q in quick]
    # the cancelled naps would hold the workers for 30 s; a quiet machine frees them in 0.6-1.0 s (the issue's
    # target is 2 s); the bound leaves room for a CI machine loaded by the other test processes
    assert elapsed < 10.0, f"the workers were busy {elapsed:.2f} s after the cancel"
    for job in jobs:
        st = requests.get(f"{url}/jobs/{job}", timeout=5).json()
        assert st["state"] == "cancelled" and "result" not in st


def check_unknown_job_is_json_404(url):
    for method in ("get", "delete"):
        r = getattr(requests, method)(f"{url}/jobs/no-such-job", timeout=5)
        assert r.status_code == 404 and r.headers["Content-Type"].startswith("application/json")
        assert "no job 'no-such-job'" in r.json()["errors"][0]


def check_failed_job_keeps_the_solve_error(url):
    r = requests.post(f"{url}/jobs/test/crash", json=hops_body("test/crash", hops_tree("how", [json.dumps("exit")])),
                      timeout=10)
    st = wait_state(url, r.json()["id"], ("done", "failed", "cancelled"))
    assert st["state"] == "failed" and st["status"] == 500 and "crashed" in st["result"]["errors"][0]


# ----------------------------------------------------------------------------------------------
# the local solver processes


@pytest.fixture(scope="module")
def pooled():
    cfg = Config(workers=2, solve_timeout=5.0, registry_factory=FACTORY, cache_size=0, job_ttl=60)
    app = create_app(cfg)
    with LiveServer(app, threads=12) as srv:
        srv.app = app
        yield srv
    app.extensions["ghserver.pool"].close()


def test_progress_rises_and_result_equals_solve(pooled):
    check_progress_rises_and_result_equals_solve(pooled.url)


def test_strategy_job_equals_call(pooled):
    check_strategy_job_equals_call(pooled.url)


def test_cancel_kills_the_solve_and_frees_the_worker(pooled):
    before = set(pooled.app.extensions["ghserver.pool"].pids())
    check_cancel_frees_the_workers(pooled.url)
    assert not before & set(pooled.app.extensions["ghserver.pool"].pids()), "the cancelled solvers were killed"


def test_unknown_job_is_json_404(pooled):
    check_unknown_job_is_json_404(pooled.url)


def test_failed_job_keeps_the_solve_error(pooled):
    check_failed_job_keeps_the_solve_error(pooled.url)


def test_job_has_its_own_time_limit():
    app = create_app(Config(workers=1, solve_timeout=5.0, job_timeout=1.0, registry_factory=FACTORY, cache_size=0))
    try:
        with LiveServer(app) as srv:
            job = requests.post(f"{srv.url}/jobs/test/nap", json=nap_body(30), timeout=10).json()["id"]
            st = wait_state(srv.url, job, ("done", "failed"), timeout=20)
    finally:
        app.extensions["ghserver.pool"].close()
    assert st["status"] == 504 and "time limit of 1 s" in st["result"]["errors"][0]
    assert "--job-timeout" in st["result"]["errors"][0]


# ----------------------------------------------------------------------------------------------
# in the server process (workers=0), and the rules a job shares with /solve (Flask test client)


@pytest.fixture
def inline():
    from tests.ghserver.test_jobs import registry as reg

    return create_app(Config(cache_size=0, max_jobs=3, job_ttl=0.5, api_key="k3y", max_body_mb=1), registry=reg())


KEY = {"RhinoComputeKey": "k3y"}


def _wait_inline(client, job, states, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        st = client.get(f"/jobs/{job}", headers=KEY).get_json()
        if st["state"] in states:
            return st
        time.sleep(0.02)
    raise AssertionError(st)


def test_inline_job_progress_and_cooperative_cancel(inline):
    c = inline.test_client()
    r = c.post("/jobs/test/stages", json=stages_body(steps=4, seconds=0.05), headers=KEY)
    assert r.status_code == 202
    st = _wait_inline(c, r.get_json()["id"], ("done",))
    assert st["progress"] == 1.0 and st["result"]["values"][0]["InnerTree"]["{0}"][0]["data"] == "4"
    r = c.post("/jobs/test/stages", json=stages_body(steps=100, seconds=0.05), headers=KEY)
    job = r.get_json()["id"]
    _wait_inline(c, job, ("running",))
    time.sleep(0.2)
    assert c.delete(f"/jobs/{job}", headers=KEY).get_json()["state"] == "cancelled"
    worker = inline.extensions["ghserver.jobs"].executor
    t0 = time.monotonic()
    assert worker.submit(lambda: 1).result(timeout=2) == 1  # the job thread stopped at the next stage (0.05 s)
    assert time.monotonic() - t0 < 1.0


def test_jobs_need_the_api_key(inline):
    c = inline.test_client()
    assert c.post("/jobs/test/nap", json=nap_body(0)).status_code == 401
    job = c.post("/jobs/test/nap", json=nap_body(0), headers={"Authorization": "Bearer k3y"}).get_json()["id"]
    for method in (c.get, c.delete):
        r = method(f"/jobs/{job}")
        assert r.status_code == 401 and "API key" in r.get_json()["errors"][0]
    assert c.get(f"/jobs/{job}", headers=KEY).status_code == 200


def test_jobs_follow_the_cross_site_and_size_rules(inline):
    c = inline.test_client()
    r = c.post("/jobs/test/nap", json=nap_body(0), headers={**KEY, "Origin": "http://evil.example"})
    assert r.status_code == 403 and "cross-site" in r.get_json()["errors"][0]
    r = c.post("/jobs/test/nap", data=json.dumps(nap_body(0)), headers={**KEY, "Content-Type": "text/plain"})
    assert r.status_code == 415
    r = c.post("/jobs/test/nap", data=b"[" + b"0," * 600_000 + b"0]", headers={**KEY, "Content-Type":
                                                                             "application/json"})
    assert r.status_code == 413 and r.headers["Content-Type"].startswith("application/json")
    r = c.post("/jobs/no/such", json=nap_body(0), headers=KEY)
    assert r.status_code == 404 and "Unknown component /no/such" in r.get_json()["errors"][0]
    r = c.post("/jobs/test/nap", data=b"{not json", headers={**KEY, "Content-Type": "application/json"})
    st = _wait_inline(c, r.get_json()["id"], ("failed",))
    assert st["status"] == 400 and "not valid JSON" in st["result"]["errors"][0]


def test_jobs_are_bounded_and_expire(inline):
    c = inline.test_client()
    ids = [c.post("/jobs/test/nap", json=nap_body(0), headers=KEY).get_json()["id"] for _ in range(3)]
    r = c.post("/jobs/test/nap", json=nap_body(0), headers=KEY)
    assert r.status_code == 429 and "--max-jobs" in r.get_json()["errors"][0]
    for job in ids:
        _wait_inline(c, job, ("done",))
    time.sleep(0.6)  # job_ttl=0.5: the finished jobs are forgotten
    assert c.get(f"/jobs/{ids[0]}", headers=KEY).status_code == 404
    assert c.post("/jobs/test/nap", json=nap_body(0), headers=KEY).status_code == 202


def test_delete_forgets_a_finished_job(inline):
    c = inline.test_client()
    job = c.post("/jobs/test/nap", json=nap_body(0), headers=KEY).get_json()["id"]
    _wait_inline(c, job, ("done",))
    assert c.delete(f"/jobs/{job}", headers=KEY).get_json() == {"id": job, "state": "deleted"}
    assert c.get(f"/jobs/{job}", headers=KEY).status_code == 404


def test_client_result_raises_for_a_cancelled_job(pooled):
    c = Client(pooled.url)
    job = c.submit("test/nap", seconds=30)
    wait_state(pooled.url, job, ("running",))
    assert c.cancel(job)["state"] == "cancelled"
    with pytest.raises(ClientError, match="cancelled"):
        c.result(job, timeout=5)
    with pytest.raises(ClientError) as err:
        c.status("nope")
    assert err.value.status == 404
