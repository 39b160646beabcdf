"""The real server on a loopback port: concurrency, Expect: 100-continue, compute_rhino3d, the Python client."""
from __future__ import annotations

import json
import logging
import signal
import socket
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import requests
import rhino3dm

from components.core.mesh import quad_grid
from ghserver import convert
from ghserver.client import Client, ClientError
from tests.ghserver.conftest import hops_body, hops_tree, shared_json


def test_eight_parallel_solves_are_all_correct(live_server):
    def solve(i):
        V, Q = quad_grid(20 + i, 10)
        V[:, 2] = np.sin(V[:, 0] * (i + 1)) * 0.1
        body = hops_body("foo", hops_tree("Mesh", [convert.encode_mesh(V, Q)]), hops_tree("Distance", [str(i)]))
        r = requests.post(f"{live_server.url}/solve", json=body, timeout=60)
        out = r.json()
        V2, _ = convert.decode_mesh(out["values"][0]["InnerTree"]["{0}"][0]["data"])
        return i, r.status_code, V, V2

    with ThreadPoolExecutor(8) as pool:
        results = list(pool.map(solve, range(8)))
    for i, status, V, V2 in results:
        assert status == 200
        d = np.linalg.norm(V2 - V, axis=1)
        assert np.allclose(d, i, atol=1e-9)  # each answer belongs to its own request


def test_expect_100_continue_is_answered(live_server):
    body = json.dumps(hops_body("echo/scale", hops_tree("x", ["2"]))).encode()
    with socket.create_connection(("127.0.0.1", live_server.port), timeout=5) as s:
        s.sendall(b"POST /solve HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                  b"Expect: 100-continue\r\nContent-Length: " + str(len(body)).encode() + b"\r\n\r\n")
        first = s.recv(4096)
        assert first.startswith(b"HTTP/1.1 100 Continue"), first
        s.sendall(body)
        rest = b""
        while b'"errors"' not in rest:
            chunk = s.recv(65536)
            if not chunk:
                break
            rest += chunk
    assert b"HTTP/1.1 200" in rest and b'"4.0"' in rest


def test_multi_megabyte_body(live_server):
    V, Q = quad_grid(300, 300)  # 90k quads, ~ 5 MB of JSON
    body = hops_body("foo", hops_tree("Mesh", [convert.encode_mesh(V, Q)]), hops_tree("Distance", ["1"]))
    data = json.dumps(body)
    assert len(data) > 2_000_000
    r = requests.post(f"{live_server.url}/solve", data=data, headers={"Content-Type": "application/json"}, timeout=60)
    assert r.status_code == 200
    V2, F2 = convert.decode_mesh(r.json()["values"][0]["InnerTree"]["{0}"][0]["data"])
    assert np.allclose(V2[:, 2], 1.0) and np.array_equal(F2, Q)


def test_compute_rhino3d_client_drives_the_server(live_server):
    pytest.importorskip("compute_rhino3d")
    from compute_rhino3d import Grasshopper as gh
    from compute_rhino3d import Util

    Util.url = live_server.url + "/"
    mesh = rhino3dm.Mesh()
    for p in [(0, 0, 0), (2, 0, 0), (2, 3, 0), (0, 3, 0)]:
        mesh.Vertices.Add(*p)
    mesh.Faces.AddFace(0, 1, 2, 3)
    tree_mesh = gh.DataTree("Mesh")
    tree_mesh.Append([0], [json.dumps(mesh.Encode())])
    tree_d = gh.DataTree("Distance")
    tree_d.Append([0], [2.5])
    out = gh.EvaluateDefinition(f"{live_server.url}/foo", [tree_mesh, tree_d])
    assert out["errors"] == []
    values = {t["ParamName"]: t["InnerTree"] for t in out["values"]}
    assert float(values["Area"]["{0}"][0]["data"]) == pytest.approx(6.0)
    moved = rhino3dm.CommonObject.Decode(json.loads(values["Result"]["{0}"][0]["data"]))
    assert moved.Vertices[0].Z == pytest.approx(2.5)
    # paths the way compute_rhino3d writes them: "0;1" without braces
    t = gh.DataTree("x")
    t.Append([0, 1], [3])
    out = gh.EvaluateDefinition(f"{live_server.url}/echo/scale", [t])
    assert out["values"][0]["InnerTree"] == {"{0;1}": [{"type": "System.Double", "data": "6.0"}]}
    # a bad input comes back as JSON errors through the same client
    t = gh.DataTree("x")
    t.Append([0], ["not a number"])
    out = gh.EvaluateDefinition(f"{live_server.url}/echo/scale", [t])
    assert out["values"] == [] and out["errors"][0].startswith("x: expected a number")


def test_python_client_with_numpy_trimesh_and_rhino3dm(live_server):
    c = Client(live_server.url)
    V, Q = quad_grid(4, 3, 4.0, 3.0)
    res = c.call("foo", Mesh=(V, Q), Distance=0.5)
    assert res.Area == pytest.approx(12.0)
    V2, F2 = res.Result
    assert np.allclose(V2[:, 2], 0.5) and np.array_equal(F2, Q)
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.Trimesh(vertices=V, faces=np.vstack([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]]), process=False)
    assert c.call("foo", Mesh=tm).Area == pytest.approx(12.0)
    rm = convert.arrays_to_mesh(V, Q)
    assert c.call("foo", Mesh=rm, Distance=0).Area == pytest.approx(12.0)
    lists = c.call("echo/lists", numbers=np.array([1.0, 2.0, 3.0]), points=np.eye(3), texts=["a", "é"])
    assert np.array_equal(lists.numbers, [1, 2, 3]) and lists.count == 3
    assert lists.points.shape == (3, 3) and lists.texts == ["a", "é"]
    s = c.call("echo/scale", x=2.0, _absolute_tolerance=0.5, _model_units="Meters")
    assert s.value == 4.0 and s.warnings == ["tolerance 0.5 Meters"]
    with pytest.raises(ClientError, match="factor: must not be negative") as err:
        c.call("echo/scale", x=1.0, factor=-1.0)
    assert err.value.status == 400
    with pytest.raises(ClientError, match="has no input"):
        c.call("echo/scale", y=1.0)
    with pytest.raises(ClientError, match="Unknown component"):
        c.call("nope/nothing", x=1)


def test_python_client_needs_no_extra_package_and_reports_an_unreachable_server():
    # the client runs on the standard library (a plain `pip install .` has it working)
    import socket
    import subprocess
    import sys

    code = "import sys; sys.modules['requests'] = None; import ghserver.client"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True).returncode == 0
    with socket.socket() as sk:  # a port nobody listens on
        sk.bind(("127.0.0.1", 0))
        port = sk.getsockname()[1]
    with pytest.raises(ClientError, match="cannot reach"):
        Client(f"http://127.0.0.1:{port}", timeout=5).components()


def test_published_planarity_component_end_to_end(live_server):
    c = Client(live_server.url)
    V, Q = quad_grid(3, 3)
    V[5, 2] = 0.2  # lift one interior vertex: the four faces around it become non-planar
    res = c.call("metrics/planarity", mesh=(V, Q))
    assert res.planarity.shape == (9,)
    assert np.count_nonzero(res.planarity > 1e-6) == 4
    assert res.max_planarity == pytest.approx(res.planarity.max())
    assert res.mean_planarity == pytest.approx(res.planarity.mean())


def test_access_log_line_per_request(live_server, caplog):
    with caplog.at_level(logging.INFO, logger="ghserver.access"):
        requests.post(f"{live_server.url}/solve", json=hops_body("echo/scale", hops_tree("x", ["2"])), timeout=10)
    lines = [r.getMessage() for r in caplog.records if r.name == "ghserver.access"]
    assert any(line.startswith("solve echo/scale 200") and "x=1/" in line and "ms" in line for line in lines)


def test_access_log_names_the_reason_of_a_refusal_and_empty_inputs(live_server, caplog):
    with caplog.at_level(logging.INFO, logger="ghserver.access"):
        r = requests.post(f"{live_server.url}/solve", json=hops_body("echo/scale", hops_tree("x", [])), timeout=10)
    assert r.status_code >= 400
    reason = r.json()["errors"][0].splitlines()[0]
    lines = [r.getMessage() for r in caplog.records if r.name == "ghserver.access"]
    line = next(line for line in lines if line.startswith("solve echo/scale 4"))
    assert "x=empty" in line and f"error: {reason[:80]}" in line


def test_cli_list_prints_the_catalogue():
    out = subprocess.run([sys.executable, "-m", "ghserver", "list"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0
    assert "/metrics/planarity" in out.stdout


def test_real_request_against_real_server(live_server):
    body = shared_json("post_solve_request.json")
    r = requests.post(f"{live_server.url}/solve", data=json.dumps(body),
                      headers={"Content-Type": "application/json; charset=utf-8"}, timeout=30)
    assert r.status_code == 200 and r.headers["Content-Type"].startswith("application/json")
    assert [t["ParamName"] for t in r.json()["values"]] == ["Result", "Area"]


def test_grafted_multi_item_request_end_to_end(live_server):
    """Three meshes grafted in Grasshopper ({0;0}, {0;1}, {0;2}: one item per branch, as Hops sends a grafted
    tree) and the same three as items of one branch: every answer lands on its own path with its own values."""
    from components.core.measures import quad_planarity

    meshes = []
    for k in range(3):
        V, Q = quad_grid(3 + k, 2)
        V[:, 2] = 0.05 * (k + 1) * np.sin(3 * V[:, 0] + V[:, 1])
        meshes.append((V, Q))
    items = [{"type": "Rhino.Geometry.Mesh", "data": convert.encode_mesh(V, Q)} for V, Q in meshes]
    grafted = {"ParamName": "mesh", "InnerTree": {f"{{0;{k}}}": [it] for k, it in enumerate(items)}}
    for tree, paths in ((grafted, ["{0;0}", "{0;1}", "{0;2}"]),
                        ({"ParamName": "mesh", "InnerTree": {"{0}": items}}, None)):
        r = requests.post(f"{live_server.url}/solve", json=hops_body("metrics/planarity", tree), timeout=60)
        assert r.status_code == 200, r.text
        out = {t["ParamName"]: t["InnerTree"] for t in r.json()["values"]}
        if paths is not None:  # one branch per mesh, the item output one value per branch
            assert sorted(out["planarity"]) == paths and sorted(out["max_planarity"]) == paths
            per_mesh = [out["planarity"][p] for p in paths]
            maxima = [float(out["max_planarity"][p][0]["data"]) for p in paths]
        else:  # items of one branch: the list output gets a sub-branch per item, the item output a list
            assert sorted(out["planarity"]) == ["{0;0}", "{0;1}", "{0;2}"] and list(out["max_planarity"]) == ["{0}"]
            per_mesh = [out["planarity"][f"{{0;{k}}}"] for k in range(3)]
            maxima = [float(it["data"]) for it in out["max_planarity"]["{0}"]]
        for (V, Q), got, mx in zip(meshes, per_mesh, maxima):
            expected = quad_planarity(V, Q)
            assert np.allclose([float(it["data"]) for it in got], expected, rtol=1e-12, atol=1e-15)
            assert mx == pytest.approx(expected.max(), rel=1e-12)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM is POSIX")
def test_serve_logs_its_shutdown_on_sigterm():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "ghserver", "serve", "--port", str(port), "--workers", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if requests.get(f"http://127.0.0.1:{port}/", timeout=2).status_code == 200:
                    break
            except requests.ConnectionError:
                time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    lines = out.splitlines()
    assert any("stopping (SIGTERM)" in line for line in lines), out
    assert lines[-1].endswith("stopped"), out


def test_a_strategy_over_hops_gives_the_same_panels_in_mm_and_m(live_server):
    """Through the wire in mm and m (double-precision vertices, as Rhino 7 and later send meshes): the same panels up
    to the scale, as on arrays (components.core.frame snaps the few ulps of other units away)."""
    from components.surfaces.samples import sample_mesh

    V, T, _ = sample_mesh("wave", 16)
    c = Client(live_server.url)
    out = [c.call("subdivision/pq_from_subdivision", surface=(V * s, T), faces=24, levels=1) for s in (1.0, 1000.0)]
    (Xa, Fa), (Xb, Fb) = out[0].planarized, out[1].planarized
    assert np.array_equal(Fa, Fb) and len(Fa) > 0
    assert np.abs(Xb / 1000.0 - Xa).max() <= 1e-12 * np.ptp(V, axis=0).max()
    assert (out[0].converged, out[0].healthy) == (out[1].converged, out[1].healthy) == (True, True)
