"""Load on loopback: 200 mixed requests from 8 concurrent clients, with crashing and timing-out solves.

Every good request gets the right answer, every bad one a JSON error, the server stays up and its memory returns
to its baseline.
"""
from __future__ import annotations

import json
import os
import random
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import requests

from components.core.mesh import quad_grid
from components.metrics.quality import quad_planarity
from ghserver import convert
from ghserver.app import Config, create_app
from ghserver.workers import _rss_mb
from tests.ghserver.conftest import LiveServer, hops_body, hops_tree

pytestmark = pytest.mark.skipif(os.name == "nt", reason="POSIX process isolation")


def _rss_of(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return 0.0


def _requests(n=200, seed=0):
    rng = random.Random(seed)
    reqs = []
    for i in range(n):
        r = rng.random()
        if r < 0.40:
            x = i + 0.25
            reqs.append(("good_scale", "echo/scale", [hops_tree("x", [repr(x)])], 2 * x))
        elif r < 0.65:
            V, Q = quad_grid(6, 5)
            V[:, 2] = np.random.default_rng(i).normal(scale=0.05, size=len(V))
            reqs.append(("good_planarity", "metrics/planarity", [hops_tree("mesh", [convert.encode_mesh(V, Q)])],
                         quad_planarity(V, Q)))
        elif r < 0.80:
            bad = rng.choice([("echo/scale", [hops_tree("x", ["abc"])]), ("no/such", []),
                              ("metrics/planarity", [hops_tree("mesh", ["garbage"])]),
                              ("echo/scale", [hops_tree("x", ["1"], key="{x}")])])
            reqs.append(("bad", bad[0], bad[1], None))
        elif r < 0.90:
            reqs.append(("crash", "test/crash", [hops_tree("how", [json.dumps(rng.choice(["exit", "segfault"]))])],
                         None))
        else:
            reqs.append(("timeout", "test/nap", [hops_tree("seconds", ["30"])], None))
    return reqs


def test_two_hundred_mixed_requests_eight_clients():
    cfg = Config(workers=2, solve_timeout=1.5, registry_factory="tests.ghserver.test_fuzz:fuzz_registry",
                 cache_size=0, max_pending_solves=64)
    app = create_app(cfg)
    pool = app.extensions["ghserver.pool"]
    try:
        with LiveServer(app, threads=16) as srv:
            session = requests.Session()

            def send(req):
                kind, uri, trees, expected = req
                r = requests.post(f"{srv.url}/solve", json=hops_body(uri, *trees), timeout=60)
                return kind, r.status_code, r.headers.get("Content-Type", ""), r.json(), expected

            # warm up and take the baseline
            for req in _requests(20, seed=1):
                if req[0].startswith("good"):
                    send(req)
            base_main = _rss_mb()
            base_workers = max(_rss_of(p) for p in pool.pids())

            with ThreadPoolExecutor(8) as ex:
                results = list(ex.map(send, _requests(200)))

            counts = {}
            for kind, status, ctype, body, expected in results:
                counts[kind] = counts.get(kind, 0) + 1
                assert ctype.startswith("application/json")
                if kind == "good_scale":
                    assert status == 200, body
                    assert float(body["values"][0]["InnerTree"]["{0}"][0]["data"]) == expected
                elif kind == "good_planarity":
                    assert status == 200, body
                    got = [float(it["data"]) for it in body["values"][0]["InnerTree"]["{0}"]]
                    assert np.allclose(got, expected, rtol=0, atol=1e-12)
                elif kind == "bad":
                    assert status == 400 and body["errors"], body
                elif kind == "crash":
                    assert status == 500 and "crashed" in body["errors"][0]
                elif kind == "timeout":
                    assert status == 504 and "time limit" in body["errors"][0]
            assert all(counts.get(k, 0) >= 5 for k in ("good_scale", "good_planarity", "bad", "crash", "timeout"))

            # the server is still up and answers normally
            assert session.get(f"{srv.url}/metrics/planarity", timeout=5).status_code == 200
            ok = send(("good_scale", "echo/scale", [hops_tree("x", ["0.5"])], 1.0))
            assert ok[1] == 200
            assert len(pool.pids()) == 2
            # memory back to its baseline: the server process did not grow, the workers stay near theirs
            assert _rss_mb() - base_main < 80
            assert max(_rss_of(p) for p in pool.pids()) < base_workers + 80
    finally:
        pool.close()
