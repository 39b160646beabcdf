"""Attacks on a real server (issue #20): decompression bombs, many meshes near the limit, idle and slow
connections, cross-site posts, huge JSON, long integers, oversized and malformed HTTP, an error posted twice with
the cache on, a worker that died while idle.

Every answer must be JSON with the right status, the server and its metadata stay responsive, and a rejected
request never takes a solver process past 200 MB (peak resident memory, VmHWM from /proc, reset before each
attack). ``benchmarks/abuse.py`` prints the same attacks at full size.
"""
from __future__ import annotations

import json
import logging
import os
import signal
import socket
import threading
import time
from contextlib import contextmanager

import numpy as np
import pytest
import requests

from components.core.mesh import quad_grid
from ghserver import convert
from ghserver.app import Config, ResultCache, create_app, host_allowed
from ghserver.workers import peak_rss_mb, reset_peak_rss
from tests.ghserver import attacks
from tests.ghserver.conftest import LiveServer, hops_body, hops_tree

pytestmark = pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="peak memory is read from /proc")

FACTORY = "tests.ghserver.echo:registry"
PEAK_MB = 200  # the most a solver process may reach while a request is refused
LIMIT_V = 100_000


@pytest.fixture(scope="module")
def server():
    """One solver process, the cache on, small limits and a 1.5 s request deadline (to see slow clients dropped)."""
    cfg = Config(workers=1, solve_timeout=20, registry_factory=FACTORY, cache_size=16, max_vertices=LIMIT_V,
                 max_faces=LIMIT_V, max_body_mb=8, max_json_mb=16, max_pending_solves=4)
    app = create_app(cfg)
    with LiveServer(app, threads=8, max_body_mb=8, request_timeout=1.5) as srv:
        srv.pool = app.extensions["ghserver.pool"]
        srv.pool.solve(b'{"pointer": "echo/scale", "values": []}', None)  # the worker is up
        yield srv
    srv.pool.close()


@contextmanager
def worker_peak(srv):
    """``box["mb"]``: the peak resident memory any solver process reached inside the block."""
    pids = srv.pool.pids()
    assert all(reset_peak_rss(p) for p in pids)
    box = {}
    yield box
    box["mb"] = max(peak_rss_mb(p) for p in set(pids) | set(srv.pool.pids()))


def post(srv, data: bytes, headers=None, path="/solve", timeout=60):
    return requests.post(srv.url + path, data=data, timeout=timeout,
                         headers={"Content-Type": "application/json", **(headers or {})})


def assert_json_error(r, status, *words):
    assert r.status_code == status, (r.status_code, r.text[:300])
    assert r.headers["Content-Type"].startswith("application/json")
    msg = r.json()["errors"][0]
    for w in words:
        assert w in msg, msg
    return msg


def read_response(sock) -> tuple[bytes, bytes]:
    """``(status line and headers, body)`` of one HTTP answer read from ``sock`` (by its Content-Length)."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(65536)
        if not chunk:
            break
        data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    length = next((int(line.split(b":")[1]) for line in head.split(b"\r\n")
                   if line.lower().startswith(b"content-length:")), 0)
    while len(body) < length:
        chunk = sock.recv(65536)
        if not chunk:
            break
        body += chunk
    return head, body


def assert_responsive(srv):
    t0 = time.monotonic()
    assert requests.get(srv.url + "/", timeout=5).status_code == 200
    assert requests.get(srv.url + "/foo", timeout=5).json()["Inputs"][0]["Name"] == "Mesh"
    r = post(srv, json.dumps(hops_body("echo/scale", hops_tree("x", ["2"]))).encode(), timeout=10)
    assert r.status_code == 200 and r.json()["values"][0]["InnerTree"]["{0}"][0]["data"] == "4.0"
    return time.monotonic() - t0


# ----------------------------------------------------------------------------------------------
# limits before work


@pytest.mark.parametrize("vcount", [2**20, 2**23, 2**26])  # inflating to 36 MB, 288 MB, 2.3 GB
def test_mesh_bombs_are_refused_before_inflating(server, vcount):
    body = attacks.bomb_body("foo", "Mesh", vcount)
    assert len(body) < 4 * 2**20
    with worker_peak(server) as peak:
        t0 = time.monotonic()
        r = post(server, body)
        elapsed = time.monotonic() - t0
    assert_json_error(r, 413, f"Mesh: {vcount} vertices is more than the server's limit of {LIMIT_V}",
                      "--max-vertices")
    assert peak["mb"] < PEAK_MB and elapsed < 5
    assert assert_responsive(server) < 2


def test_many_meshes_near_the_limit_in_one_branch(server):
    body = attacks.bomb_body("foo", "Mesh", LIMIT_V - 10_000, copies=20)
    with worker_peak(server) as peak:
        r = post(server, body)
    assert_json_error(r, 413, f"{20 * (LIMIT_V - 10_000)} vertices together", "--max-request-vertices")
    assert peak["mb"] < PEAK_MB


def test_the_rhino3dm_fallback_never_decodes_what_the_fast_reader_refused(monkeypatch):
    import rhino3dm

    calls = []
    real = rhino3dm.CommonObject.Decode
    monkeypatch.setattr(rhino3dm.CommonObject, "Decode", lambda blob: calls.append(1) or real(blob))
    limits = {"max_vertices": LIMIT_V, "max_faces": LIMIT_V, "max_inflated_mb": 100}
    bomb = attacks.mesh_bomb(2**22)
    with pytest.raises(convert.TooLargeError, match="--max-vertices"):
        convert.decode_mesh(bomb, limits)
    raw = bytearray(__import__("base64").b64decode(bomb["data"]))
    raw[24] ^= 0xFF  # another class id: the fast reader refuses it and cannot read its counts
    odd = dict(bomb, data=__import__("base64").b64encode(bytes(raw)).decode())
    assert convert.mesh_counts(odd) is None
    with pytest.raises(convert.TooLargeError, match="inflate to 144 MB"):
        convert.decode_mesh(odd, limits)
    assert calls == []  # rhino3dm never saw either
    V, F = convert.decode_mesh(attacks.mesh_bomb(1000), limits)  # a small one decodes
    assert V.shape == (1000, 3) and F.shape == (0, 4)


def test_the_answer_size_is_bounded(echo_registry):
    client = create_app(Config(max_response_mb=0.5), registry=echo_registry).test_client()
    V, Q = quad_grid(150, 150)  # 22,801 vertices: about 1 MB of answer
    r = client.post("/solve", json=hops_body("foo", hops_tree("Mesh", [convert.encode_mesh(V, Q)])))
    assert r.status_code == 413 and "answer of foo would be more than the server's limit of 0.5 MB" in \
        r.json["errors"][0] and "--max-response-mb" in r.json["errors"][0]
    V, Q = quad_grid(20, 20)
    r = client.post("/solve", json=hops_body("foo", hops_tree("Mesh", [convert.encode_mesh(V, Q)])))
    assert r.status_code == 200


# ----------------------------------------------------------------------------------------------
# connections


def test_idle_and_slow_connections_do_not_lock_clients_out(server):
    idle = [socket.create_connection(("127.0.0.1", server.port), timeout=10) for _ in range(200)]
    slow = [socket.create_connection(("127.0.0.1", server.port), timeout=10) for _ in range(10)]
    stop = threading.Event()

    def trickle():  # one byte every 0.3 s: headers that never end
        line = b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + b"a" * 100
        for i in range(len(line)):
            for s in slow:
                try:
                    s.send(line[i:i + 1])
                except OSError:
                    pass
            if stop.wait(0.3):
                return

    t = threading.Thread(target=trickle, daemon=True)
    t.start()
    try:
        for _ in range(3):
            assert assert_responsive(server) < 2  # catalogue, metadata and a solve, with 210 clients hanging on
        time.sleep(3.0)  # past the 1.5 s request deadline and a cleanup round
        for s in slow:
            s.settimeout(5)
            head, body = read_response(s)
            assert head.startswith(b"HTTP/1.1 408") and b"application/json" in head, head
            assert "too slowly" in json.loads(body)["errors"][0]
        assert assert_responsive(server) < 2
    finally:
        stop.set()
        t.join(5)
        for s in idle + slow:
            s.close()


def test_metadata_is_answered_while_solves_fill_the_server(server):
    from concurrent.futures import ThreadPoolExecutor

    body = json.dumps(hops_body("test/nap", hops_tree("seconds", ["0.5"]))).encode()
    with ThreadPoolExecutor(6) as ex:
        futs = [ex.submit(post, server, body) for _ in range(6)]
        time.sleep(0.2)
        t0 = time.monotonic()
        assert requests.get(server.url + "/foo", timeout=5).status_code == 200
        assert time.monotonic() - t0 < 0.5
        statuses = sorted(f.result().status_code for f in futs)
    assert set(statuses) <= {200, 503} and 200 in statuses  # beyond the solve slots: a JSON 503, never a hang


# ----------------------------------------------------------------------------------------------
# cross-site requests


def test_cross_site_requests_are_refused_in_json(server):
    good = json.dumps(hops_body("echo/scale", hops_tree("x", ["2"]))).encode()
    url = server.url + "/solve"
    evil = {"Origin": "http://evil.example"}
    r = requests.post(url, data=good, headers={"Content-Type": "text/plain", **evil}, timeout=10)
    assert_json_error(r, 403, "origin 'http://evil.example'", "--allowed-hosts")
    r = requests.post(url, data=good, headers={"Content-Type": "text/plain"}, timeout=10)
    assert_json_error(r, 415, "application/json")
    r = requests.post(url, data={"pointer": "echo/scale"}, timeout=10)  # an HTML form
    assert_json_error(r, 415, "application/x-www-form-urlencoded")
    r = requests.post(url, data=good, headers={"Content-Type": "application/json", **evil}, timeout=10)
    assert_json_error(r, 403, "evil.example")
    r = requests.post(url, data=good, headers={"Content-Type": "application/json", "Origin": "null"}, timeout=10)
    assert_json_error(r, 403, "'null'")
    # DNS rebinding: a foreign name resolved to this machine; neither solves nor metadata are answered
    rebound = {"Host": f"evil.example:{server.port}"}
    r = requests.post(url, data=good, headers={"Content-Type": "application/json", **rebound}, timeout=10)
    assert_json_error(r, 403, "evil.example", "--allowed-hosts")
    r = requests.get(server.url + "/foo", headers=rebound, timeout=10)
    assert r.status_code == 403 and r.json()["Inputs"] == [] and "evil.example" in r.json()["Errors"][0]
    # what real clients send is answered: Hops (JSON, charset), compute_rhino3d (no Content-Type), localhost
    for headers in ({"Content-Type": "application/json; charset=utf-8"}, {},
                    {"Content-Type": "application/json", "Host": f"localhost:{server.port}"},
                    {"Content-Type": "application/json", "Origin": server.url}):
        r = requests.post(url, data=good, headers=headers, timeout=10)
        assert r.status_code == 200, (headers, r.text)


def test_allowed_hosts_for_a_proxy(echo_registry):
    body = hops_body("echo/scale", hops_tree("x", ["2"]))
    client = create_app(Config(allowed_hosts=("ghserver.internal",)), registry=echo_registry).test_client()
    assert client.post("/solve", json=body, headers={"Host": "ghserver.internal"}).status_code == 200
    assert client.post("/solve", json=body, headers={"Host": "other.internal"}).status_code == 403
    anyhost = create_app(Config(allowed_hosts=("*",)), registry=echo_registry).test_client()
    assert anyhost.post("/solve", json=body, headers={"Host": "other.internal"}).status_code == 200
    r = anyhost.post("/solve", data=json.dumps(body), content_type="text/plain")
    assert r.status_code == 415  # the Content-Type rule stays on


def test_host_rule():
    loop, everywhere = Config(host="127.0.0.1"), Config(host="0.0.0.0")
    for name in ("localhost", "127.0.0.1", "127.0.0.2", "::1"):
        assert host_allowed(name, loop) and host_allowed(name, everywhere)
    assert not host_allowed("192.168.1.5", loop) and host_allowed("192.168.1.5", everywhere)
    assert not host_allowed("evil.example", loop) and not host_allowed("evil.example", everywhere)
    assert host_allowed("192.168.1.5", Config(host="192.168.1.5"))
    assert not host_allowed("192.168.1.6", Config(host="192.168.1.5"))


# ----------------------------------------------------------------------------------------------
# memory and sizes


def test_huge_json_is_refused_before_parsing(server):
    body = attacks.empty_objects_body(6)  # 6 MB: 160 MB once parsed
    with worker_peak(server) as peak:
        r = post(server, body)
    assert_json_error(r, 413, "once parsed", "limit of 16 MB", "--max-json-mb")
    assert peak["mb"] < PEAK_MB


@pytest.mark.parametrize("mb", [9, 64])
def test_a_body_over_the_limit_is_a_json_413_not_a_reset(server, mb):
    r = post(server, b" " * (mb * 2**20))
    assert_json_error(r, 413, "larger than the server's limit of 8 MB", "--max-body-mb")
    # a client that sends the whole body before reading (no Expect: 100-continue) is neither reset nor cut off:
    # the server answers at the headers and reads and drops the rest
    with socket.create_connection(("127.0.0.1", server.port), timeout=20) as s:
        s.sendall(b"POST /solve HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                  b"Content-Length: " + str(mb * 2**20).encode() + b"\r\n\r\n")
        chunk = b" " * 2**20
        for _ in range(mb):
            s.sendall(chunk)  # raises ConnectionResetError / BrokenPipeError if the server closed on us
        head, body = read_response(s)
    assert head.startswith(b"HTTP/1.1 413") and b"application/json" in head, head
    assert "--max-body-mb" in json.loads(body)["errors"][0]
    assert assert_responsive(server) < 2


def test_an_oversized_body_is_answered_at_its_headers(server):
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as s:
        s.sendall(b"POST /solve HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                  b"Expect: 100-continue\r\nContent-Length: 900000000\r\n\r\n")
        head, body = read_response(s)
    assert head.startswith(b"HTTP/1.1 413") and b"application/json" in head, head  # no 100 Continue first
    assert "--max-body-mb" in json.loads(body)["errors"][0]
    r = requests.post(server.url + "/solve", data=iter([b" " * 2**20] * 10), timeout=10,  # chunked
                      headers={"Content-Type": "application/json"})
    assert_json_error(r, 413, "--max-body-mb")


@pytest.mark.parametrize("raw, status", [
    (b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: abc\r\n\r\n", 400),
    (b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + b"a" * 300_000 + b"\r\n\r\n", 431),
    (b"POST /solve HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n", 400),
])
def test_malformed_http_is_answered_in_json(server, raw, status):
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as s:
        s.sendall(raw)
        head, body = read_response(s)
    assert head.split(b" ")[1] == str(status).encode() and b"application/json" in head, head
    assert json.loads(body)["errors"][0]


def test_long_integers_are_400(server):
    pid = server.pool.pids()[0]
    r = post(server, attacks.long_integer_body(5000))
    assert_json_error(r, 400, "not valid JSON")
    body = hops_body("echo/scalars", hops_tree("number", ["7" * 5000]))
    assert_json_error(post(server, json.dumps(body).encode()), 400, "number: expected a number")
    body = hops_body("echo/scalars", hops_tree("integer", ["7" * 5000]))
    assert_json_error(post(server, json.dumps(body).encode()), 400, "integer: expected an integer")
    body = hops_body("echo/scalars", hops_tree("text", ["7" * 5000]))
    r = post(server, json.dumps(body).encode())
    assert r.status_code == 200
    raw = json.dumps(hops_body("echo/scale", hops_tree("x", ["X"]))).replace('"X"', "7" * 5000).encode()
    assert_json_error(post(server, raw), 400, "not valid JSON")
    assert server.pool.pids() == [pid]  # the worker never crashed


def test_an_error_posted_twice_is_never_answered_from_the_cache(server, caplog):
    bad = json.dumps(hops_body("echo/scale", hops_tree("x", ["abc"]), cachesolve=True)).encode()
    good = json.dumps(hops_body("echo/scale", hops_tree("x", ["21"]), cachesolve=True)).encode()
    with caplog.at_level(logging.INFO, logger="ghserver.access"):
        first, second = post(server, bad), post(server, bad)
        ok1, ok2 = post(server, good), post(server, good)
    for r in (first, second):
        assert_json_error(r, 400, "x: expected a number")
    assert second.content == first.content
    assert ok1.status_code == ok2.status_code == 200 and ok2.content == ok1.content
    lines = [rec.getMessage() for rec in caplog.records if rec.name == "ghserver.access"]
    assert sum("(cached)" in line for line in lines) == 1  # only the second good one


def test_result_cache_is_bounded_in_bytes_and_keeps_only_successes():
    cache = ResultCache(size=100, max_bytes=1000)
    cache.put("err", b"x" * 10, status=400)
    assert cache.get("err") is None
    for i in range(10):
        cache.put(str(i), b"y" * 200)
    assert cache.bytes <= 1000 and len(cache._data) == 5 and cache.get("9") is not None and cache.get("0") is None
    cache.put("huge", b"z" * 300)  # more than a quarter of the budget: not kept
    assert cache.get("huge") is None and cache.bytes <= 1000


def _kill_and_wait(pid: int, timeout: float = 5.0) -> None:
    """SIGKILL `pid` and wait until it is a zombie or gone (reaped by anyone: the pool, multiprocessing's cleanup)."""
    os.kill(pid, signal.SIGKILL)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with open(f"/proc/{pid}/stat") as f:
                state = f.read().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return
        if state in "ZX":
            return
        time.sleep(0.02)


def test_a_worker_that_died_while_idle_is_replaced_before_dispatch(server):
    (pid,) = server.pool.pids()
    _kill_and_wait(pid)
    body = json.dumps(hops_body("test/nap", hops_tree("seconds", ["0"]))).encode()
    r = post(server, body)
    assert r.status_code == 200, r.text
    assert int(r.json()["values"][1]["InnerTree"]["{0}"][0]["data"]) != pid


def test_a_worker_that_dies_after_the_liveness_check_passes_the_request_on(server, monkeypatch):
    # the race the check above cannot close: the worker is killed between the check and the send (the OOM killer,
    # an operator); the request never reached it, so a new worker solves it
    (pid,) = server.pool.pids()
    _kill_and_wait(pid)
    (w,) = [w for w in server.pool._all if w.process.pid == pid]
    monkeypatch.setattr(w.process, "is_alive", lambda: True)  # it looked alive when it was taken
    body = json.dumps(hops_body("test/nap", hops_tree("seconds", ["0"]))).encode()
    r = post(server, body)
    assert r.status_code == 200, r.text
    assert int(r.json()["values"][1]["InnerTree"]["{0}"][0]["data"]) != pid


# ----------------------------------------------------------------------------------------------
# every answer JSON


def test_report_route_oddities_are_json_without_traceback(tmp_path, echo_registry, caplog):
    (tmp_path / "report.html").write_text("<html></html>")
    client = create_app(Config(report_dir=str(tmp_path)), registry=echo_registry).test_client()
    with caplog.at_level(logging.WARNING):
        for path in ("/report/%00", "/report/a%00b.html", "/report/" + "a" * 5000, "/report/" + "b/" * 900 + "c",
                     "/report/..%2f..%2fetc/passwd"):
            r = client.get(path)
            assert r.status_code == 404 and r.content_type.startswith("application/json"), path
            assert "no report file" in r.json["errors"][0]
    assert not [rec for rec in caplog.records if rec.levelno >= logging.ERROR]


def test_other_methods_and_routes_answer_json(client):
    for r in (client.options("/solve"), client.put("/solve", data=b"{}"), client.delete("/foo"),
              client.get("/no/such/component"), client.post("/", data=b"{}", content_type="application/json")):
        assert r.content_type.startswith("application/json"), (r.status_code, r.data[:100])
        json.loads(r.data)


def test_numpy_answer_stays_exact_after_all_the_guards(server):
    V, Q = quad_grid(30, 20)
    V[:, 2] = np.sin(V[:, 0])
    body = json.dumps(hops_body("foo", hops_tree("Mesh", [convert.encode_mesh(V, Q)]),
                                hops_tree("Distance", ["0"]))).encode()
    r = post(server, body)
    V2, F2 = convert.decode_mesh(r.json()["values"][0]["InnerTree"]["{0}"][0]["data"])
    assert np.array_equal(V2, V) and np.array_equal(F2, Q)
