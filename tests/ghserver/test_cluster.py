"""``ghserver serve --cluster``: solves and jobs on a real Dask cluster (one scheduler, two worker processes on
loopback, started once for this module by :class:`tests.daskcluster.LoopbackCluster`).

Checked: the published components' property cases of ``test_published.py`` give the same answers on the cluster
as a local solve (all but the seven intermediate steps listed in ``REPEATED``, whose work the three strategy cases
repeat; solved two at a time); a hanging solve is answered 504 and the next solve answers;
a Dask worker killed mid-solve gives a JSON answer while the server stays up; jobs (progress, result, cancel,
unknown id) as on the local processes (the checks of ``test_jobs.py``); an unreachable cluster at start is a
one-line error with exit code 2.
"""
from __future__ import annotations

import json
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import requests

from ghserver import protocol
from ghserver.app import Config, create_app
from ghserver.client import Client
from tests.daskcluster import LoopbackCluster
from tests.ghserver import test_jobs as J
from tests.ghserver.conftest import LiveServer, hops_body, hops_tree
from tests.ghserver.test_published import CASES

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(os.name == "nt", reason="POSIX solver processes")


@pytest.fixture(scope="module")
def cluster():
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([old] if old else []))  # the workers import tests.*
    try:
        with LoopbackCluster(workers=2) as c:
            yield c
    finally:
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old


def _server(cluster, timeout):
    app = create_app(Config(cluster=cluster.address, solve_timeout=timeout, registry_factory=J.FACTORY,
                            cache_size=0, max_pending_solves=12, job_ttl=60))
    srv = LiveServer(app, threads=16)
    srv.app = app
    srv.pool = app.extensions["ghserver.pool"]
    return srv


@pytest.fixture(scope="module")
def served(cluster):
    """A server on the cluster with a time limit for real solves on a busy machine."""
    with _server(cluster, 120.0) as srv:
        yield srv
    srv.pool.close()


@pytest.fixture(scope="module")
def strict(cluster):
    """A second server on the same cluster with a 3 s time limit."""
    with _server(cluster, 3.0) as srv:
        yield srv
    srv.pool.close()


def _without_timings(answer: bytes) -> dict:
    body = json.loads(answer)
    body["values"] = [t for t in body["values"] if "time" not in t["ParamName"]]
    return body


def test_published_components_answer_the_same_on_the_cluster(served):
    """Every case of test_published.py: the property holds and the answer equals a local solve's (every output but
    the timings)."""
    client = Client(served.url)
    registry = J.registry()

    def one(uri):
        make_inputs, check = CASES[uri]
        inputs = make_inputs()
        body = client.request_body(uri, dict(inputs))
        raw = json.dumps(body).encode()
        r = requests.post(f"{served.url}/{uri}", data=raw, headers={"Content-Type": "application/json"},
                          timeout=120)
        local_status, local_text, _, _ = protocol.solve_bytes(registry, raw, uri, limits=served.app.extensions[
            "ghserver.config"].limits)
        result = client._result(uri, r.status_code, r.json())
        outcome = check(result)
        return (uri, r.status_code, local_status, outcome is None or bool(outcome),
                _without_timings(r.content) == _without_timings(local_text))

    with ThreadPoolExecutor(2) as ex:
        rows = list(ex.map(one, sorted(CASES)))
    bad = [row for row in rows if not (row[1] == row[2] == 200 and row[3] and row[4])]
    assert not bad, f"(uri, cluster status, local status, property holds, same answer): {bad}"


def _ancestors(pid: int) -> list[int]:
    out = []
    while pid > 1 and len(out) < 5:
        status = Path(f"/proc/{pid}/status").read_text()
        pid = int(next(ln.split()[1] for ln in status.splitlines() if ln.startswith("PPid:")))
        out.append(pid)
    return out


def test_solves_run_in_solver_processes_of_the_dask_workers(served, cluster):
    r = requests.post(f"{served.url}/test/nap", json=J.nap_body(0), timeout=30)
    assert r.status_code == 200
    pid = int(r.json()["values"][1]["InnerTree"]["{0}"][0]["data"])
    assert pid != os.getpid() and {p.pid for p in cluster.workers} & set(_ancestors(pid))


def test_hanging_solve_is_504_and_the_next_solve_answers(strict):
    t0 = time.monotonic()
    r = requests.post(f"{strict.url}/test/nap", json=J.nap_body(30), timeout=60)
    took = time.monotonic() - t0
    assert r.status_code == 504 and r.headers["Content-Type"].startswith("application/json")
    assert "time limit of 3 s" in r.json()["errors"][0] and took < 8
    t0 = time.monotonic()
    ok = [requests.post(f"{strict.url}/test/nap", json=J.nap_body(0), timeout=30) for _ in range(2)]
    assert all(o.status_code == 200 for o in ok) and time.monotonic() - t0 < 3


def test_a_solve_on_the_cluster_gets_its_deadline_before_the_limit(strict):
    """The Dask workers' solver processes set the deadline too (components.core.deadline): a solve whose budgets run
    to the deadline answers before the 3 s limit instead of a 504."""
    from ghserver.workers import deadline_margin

    r = requests.post(f"{strict.url}/test/until_deadline",
                      json=hops_body("test/until_deadline", hops_tree("seconds", ["30"])), timeout=60)
    assert r.status_code == 200, r.text
    waited = float(r.json()["values"][0]["InnerTree"]["{0}"][0]["data"])
    assert 3.0 - deadline_margin(3.0) - 0.3 < waited <= 3.0 - deadline_margin(3.0) + 0.05


def test_crashing_solve_is_500_and_the_dask_worker_lives(served, cluster):
    r = requests.post(f"{served.url}/test/crash", json=hops_body("test/crash", hops_tree("how", ['"segfault"'])),
                      timeout=30)
    assert r.status_code == 500 and "crashed" in r.json()["errors"][0]
    assert all(p.poll() is None for p in cluster.workers)
    assert requests.post(f"{served.url}/test/nap", json=J.nap_body(0), timeout=30).status_code == 200


def test_jobs_progress_rises_and_result_equals_solve(served):
    J.check_progress_rises_and_result_equals_solve(served.url)


def test_strategy_job_equals_call(served):
    J.check_strategy_job_equals_call(served.url)


def test_job_cancel_frees_the_dask_workers(served):
    J.check_cancel_frees_the_workers(served.url)


def test_unknown_job_is_json_404(served):
    J.check_unknown_job_is_json_404(served.url)


def test_failed_job_keeps_the_solve_error(served):
    J.check_failed_job_keeps_the_solve_error(served.url)


def test_unreachable_cluster_is_a_clear_error(capsys):
    from ghserver.cli import main

    assert main(["serve", "--cluster", "tcp://127.0.0.1:9", "--port", "0", "--workers", "0"]) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("ghserver serve: cannot reach the Dask scheduler at tcp://127.0.0.1:9 ("), err
    assert main(["serve", "--cluster", "127.0.0.1:9", "--port", "0"]) == 2
    assert "needs a scheduler address like tcp://HOST:8786" in capsys.readouterr().err


def test_killed_worker_mid_solve_gives_json_and_the_server_stays_up(served, cluster):
    """SIGKILL one Dask worker while both run a solve: the lost solve is rerun on the other worker (or answered
    500); every answer is JSON, and the server then answers metadata and solves."""
    with ThreadPoolExecutor(2) as ex:
        futs = [ex.submit(requests.post, f"{served.url}/test/nap", json=J.nap_body(1.5 + 0.01 * i), timeout=60)
                for i in range(2)]
        time.sleep(0.7)
        cluster.kill_worker(0)
        answers = [f.result() for f in futs]
    for a in answers:
        assert a.headers["Content-Type"].startswith("application/json")
        assert a.status_code in (200, 500), a.text
        if a.status_code == 500:
            assert "cluster" in a.json()["errors"][0]
    assert sum(a.status_code == 200 for a in answers) >= 1
    assert requests.get(f"{served.url}/test/nap", timeout=5).status_code == 200
    assert requests.post(f"{served.url}/test/nap", json=J.nap_body(0), timeout=30).status_code == 200
    # (the last test of the module: the cluster keeps one worker)
