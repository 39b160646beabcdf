"""Fuzzing the protocol layer: malformed and adversarial Hops payloads always get JSON with the right status.

Bad input must be a 400 (or 413 for size limits, 404 never on POST); 500 is allowed only as Hops' "Bad inputs"
refresh signal. Solves run in worker processes, and none may die from any of these payloads.
"""
from __future__ import annotations

import base64
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from components.core.mesh import quad_grid
from ghserver import convert
from ghserver.app import Config, create_app
from ghserver.endpoints import COMPONENTS
from ghserver.registry import Registry
from tests.ghserver import echo

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                           HealthCheck.too_slow])

URIS = ["echo/scalars", "echo/geometry", "echo/lists", "echo/surface", "echo/tree", "echo/scale", "foo",
        "metrics/planarity", "metrics/valence", "nope", "", "/", "a/../b"]
PARAM_NAMES = ["number", "integer", "boolean", "text", "point", "vector", "plane", "line", "curve", "mesh", "numbers",
               "tree", "x", "factor", "Mesh", "Distance", "surface", "RH_IN:x", "", "zzz"]

_V, _Q = quad_grid(2, 2)
GOOD_MESH = convert.encode_mesh(_V, _Q)
_blob = json.loads(GOOD_MESH)
_raw = base64.b64decode(_blob["data"])


def _mutated_mesh(data):
    kind = data.draw(st.sampled_from(["truncate", "flip", "badb64", "keys", "types", "huge"]))
    blob = dict(_blob)
    if kind == "truncate":
        n = data.draw(st.integers(0, len(_raw)))
        blob["data"] = base64.b64encode(_raw[:n]).decode()
    elif kind == "flip":
        b = bytearray(_raw)
        i = data.draw(st.integers(0, len(b) - 1))
        b[i] ^= data.draw(st.integers(1, 255))
        blob["data"] = base64.b64encode(bytes(b)).decode()
    elif kind == "badb64":
        blob["data"] = data.draw(st.text(max_size=40))
    elif kind == "keys":
        blob.pop(data.draw(st.sampled_from(["archive3dm", "opennurbs", "data", "version"])))
    elif kind == "types":
        blob[data.draw(st.sampled_from(["archive3dm", "opennurbs"]))] = data.draw(
            st.one_of(st.text(max_size=5), st.floats(), st.none(), st.lists(st.integers(), max_size=2)))
    else:
        blob["archive3dm"] = data.draw(st.sampled_from([2**63, -(2**63), 10**30, 0]))
    text = json.dumps(blob)
    return text[: data.draw(st.integers(0, len(text)))] if data.draw(st.booleans()) else text


json_scalars = st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70),
                         st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=30))
json_values = st.recursive(json_scalars, lambda c: st.one_of(st.lists(c, max_size=4),
                                                              st.dictionaries(st.text(max_size=8), c, max_size=4)),
                           max_leaves=12)


@st.composite
def item_data(draw):
    return draw(st.one_of(
        json_values,
        st.sampled_from(["NaN", "Infinity", "-inf", "1e400", "-1e400", "1e308", "1" * 400, "\"\\u0000\"", "true",
                         '{"X":1,"Y":2}', '{"X":"a","Y":2,"Z":3}', '{"X":1e999,"Y":0,"Z":0}', '{"From":{}}',
                         '{"Origin":{"X":0,"Y":0,"Z":0},"XAxis":{"X":0,"Y":0,"Z":0},"YAxis":{"X":0,"Y":0,"Z":0}}',
                         GOOD_MESH, "[" * 5000 + "]" * 5000]),
        st.builds(lambda d: _mutated_mesh(d), st.data()),
    ))


@st.composite
def tree_key(draw):
    return draw(st.one_of(
        st.sampled_from(["{0}", "0", "{1}", "{0;0}", "0;1", "{ 0; 1; }", "{}", "", "{a}", "{-1}", "{0;;1}",
                         "{99999999999}", "{" + ";".join(["0"] * 100) + "}", "{1.5}", "🙂"]),
        st.text(max_size=12),
    ))


@st.composite
def hops_bodies(draw):
    body = {"pointer": draw(st.one_of(st.sampled_from(URIS), st.text(max_size=20), json_values))}
    trees = []
    for _ in range(draw(st.integers(0, 4))):
        inner = draw(st.one_of(
            st.dictionaries(tree_key(), st.lists(st.one_of(
                st.builds(lambda t, d: {"type": t, "data": d}, st.text(max_size=20), item_data()),
                st.builds(lambda d: {"data": d}, item_data()),
                json_values), max_size=3), max_size=3),
            json_values))
        trees.append(draw(st.one_of(
            st.builds(lambda n, i: {"ParamName": n, "InnerTree": i}, st.sampled_from(PARAM_NAMES), st.just(inner)),
            json_values)))
    body["values"] = draw(st.one_of(st.just(trees), json_values))
    for key in draw(st.lists(st.sampled_from(["absolutetolerance", "angletolerance", "modelunits", "cachesolve",
                                               "dataversion", "algo", "recursionlevel"]), max_size=3)):
        body[key] = draw(json_values)
    return body


def _check(r):
    assert r.content_type.startswith("application/json"), r.data[:200]
    body = json.loads(r.data)
    assert isinstance(body, dict)
    if r.status_code == 200:
        assert body["errors"] == [] and isinstance(body["values"], list)
    elif r.status_code == 500:
        assert body["errors"][0] == "Bad inputs", body["errors"]
    else:
        assert r.status_code in (400, 413), (r.status_code, body)
        assert body["errors"] and all(isinstance(e, str) and e for e in body["errors"])


@pytest.fixture(scope="module")
def fuzz_app():
    """Echo + published components, solved in two worker processes."""
    cfg = Config(workers=2, solve_timeout=20.0, registry_factory="tests.ghserver.test_fuzz:fuzz_registry",
                 cache_size=0)
    app = create_app(cfg)
    yield app
    app.extensions["ghserver.pool"].close()


def fuzz_registry():
    return Registry(list(echo.registry()) + [c for c in COMPONENTS if c.uri in ("metrics/planarity",
                                                                                 "metrics/valence")])


@FUZZ
@given(body=hops_bodies())
def test_adversarial_hops_payloads(fuzz_app, body):
    pool = fuzz_app.extensions["ghserver.pool"]
    pids = pool.pids()
    client = fuzz_app.test_client()
    r = client.post("/solve", data=json.dumps(body, allow_nan=False), content_type="application/json")
    _check(r)
    assert pool.pids() == pids, "a worker died"


@FUZZ
@given(raw=st.one_of(st.binary(max_size=300), st.builds(
    lambda b, n: json.dumps(b)[:n].encode(), hops_bodies(), st.integers(0, 400))))
def test_truncated_and_binary_bodies(fuzz_app, raw):
    client = fuzz_app.test_client()
    r = client.post("/solve", data=raw, content_type="application/json")
    _check(r)


@FUZZ
@given(uri=st.text(max_size=30), body=hops_bodies())
def test_direct_posts_to_any_path(fuzz_app, uri, body):
    client = fuzz_app.test_client()
    r = client.post("/" + uri.lstrip("/"), data=json.dumps(body), content_type="application/json")
    if r.status_code == 405:  # a path Flask refuses before routing (e.g. "/report") still answers JSON
        assert r.content_type.startswith("application/json")
        return
    _check(r)


@pytest.mark.parametrize("payload", [
    b"[" * 100_000 + b"]" * 100_000,  # deep nesting: RecursionError in the JSON parser
    json.dumps({"pointer": "echo/scale", "values": [{"ParamName": "x", "InnerTree": {"{0}": [{"data": "1e999"}]}}]}
               ).encode(),
    json.dumps({"pointer": "echo/lists", "values": [{"ParamName": "numbers", "InnerTree": {
        "{0}": [{"data": str(i)} for i in range(20000)]}}]}).encode(),
    json.dumps({"pointer": "echo/tree", "values": [{"ParamName": "tree", "InnerTree": {
        "{" + ";".join(["1"] * 33) + "}": [{"data": "1"}]}}]}).encode(),
])
def test_extreme_payloads(fuzz_app, payload):
    client = fuzz_app.test_client()
    _check(client.post("/solve", data=payload, content_type="application/json"))


def test_huge_numbers_are_finite_or_rejected(fuzz_app):
    client = fuzz_app.test_client()
    for value in ("1e308", "-1e308", str(2**1000), "1e-320"):
        body = {"pointer": "echo/scale", "values": [{"ParamName": "x", "InnerTree": {"{0}": [{"data": value}]}}]}
        r = client.post("/solve", json=body)
        _check(r)
        if r.status_code == 200:
            out = json.loads(r.data)["values"][0]["InnerTree"]["{0}"][0]["data"]
            assert math.isfinite(float(out))


def test_random_meshes_through_published_metrics(fuzz_app):
    """Random (often degenerate) meshes: metrics answer 200 or a named 400, never a 500."""
    client = fuzz_app.test_client()
    rng = np.random.default_rng(0)
    for _ in range(40):
        n = int(rng.integers(3, 12))
        V = rng.normal(size=(n, 3)).round(int(rng.integers(0, 3)))
        F = rng.integers(0, n, size=(int(rng.integers(1, 8)), 4))
        body = {"pointer": "metrics/planarity",
                "values": [{"ParamName": "mesh", "InnerTree": {"{0}": [{"data": convert.encode_mesh(V, F)}]}}]}
        r = client.post("/solve", json=body)
        _check(r)
        if r.status_code == 400:
            assert json.loads(r.data)["errors"][0].startswith("mesh")
