"""The Hops compatibility checklist (hops-protocol.md §7), item by item, through the Flask app."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import rhino3dm

from components.core.mesh import quad_grid
from ghserver import convert
from ghserver.app import Config, create_app
from ghserver.protocol import parse_path, pointer_uri
from ghserver.registry import Registry, declare
from tests.ghserver import echo
from tests.ghserver.conftest import hops_body, hops_tree, shared_json

GH_KINDS = {"Number", "Integer", "Boolean", "Text", "Point", "Vector", "Plane", "Line", "Curve", "Surface", "Mesh"}


def mesh_data(V, F):
    return convert.encode_mesh(V, F)


def values(resp):
    return {t["ParamName"]: t["InnerTree"] for t in resp.json["values"]}


# 1. metadata ------------------------------------------------------------------------------------


def test_1_metadata_get(client):
    r = client.get("/foo")
    assert r.status_code == 200 and "json" in r.content_type
    meta = r.json
    assert isinstance(meta, dict)
    assert meta["InputNames"] == [p["Name"] for p in meta["Inputs"]] == ["Mesh", "Distance"]
    assert meta["OutputNames"] == [p["Name"] for p in meta["Outputs"]] == ["Result", "Area"]
    assert meta["Description"] == "Offset a mesh and report its area."
    for p in meta["Inputs"] + meta["Outputs"]:
        assert p["Name"] and p["ParamType"] in GH_KINDS
    # the real metadata of a "foo" component, as in tests/data/hops/get_foo_response.json
    real = shared_json("get_foo_response.json")
    assert meta["InputNames"] == real["InputNames"] and meta["OutputNames"] == real["OutputNames"]
    for ours, theirs in zip(meta["Inputs"], real["Inputs"]):
        for key in ("Name", "Nickname", "ParamType", "AtLeast", "AtMost"):
            assert ours[key] == theirs[key], key
    d = {p["Name"]: p for p in meta["Inputs"]}["Distance"]
    assert (d["Default"], d["Minimum"], d["Maximum"]) == (1.0, 0.0, 100.0)
    # query strings are ignored, a trailing slash too
    assert client.get("/foo?x=1").json == meta
    assert client.get("/foo/").json == meta


# 2. access and defaults ---------------------------------------------------------------------------


def test_2_access_optional_and_falsy_defaults(client):
    lists = {p["Name"]: p for p in client.get("/echo/lists").json["Inputs"]}
    assert (lists["numbers"]["AtLeast"], lists["numbers"]["AtMost"]) == (1, 2147483647)
    assert (lists["integers"]["AtLeast"], lists["integers"]["AtMost"]) == (0, 2147483647)  # optional list
    tree = client.get("/echo/tree").json["Inputs"][0]
    assert tree["TreeAccess"] is True
    scal = {p["Name"]: p for p in client.get("/echo/scalars").json["Inputs"]}
    assert scal["number"]["Default"] == 0.0 and scal["integer"]["Default"] == 0
    assert scal["boolean"]["Default"] is False and scal["text"]["Default"] == ""
    assert all((p["AtLeast"], p["AtMost"]) == (1, 1) for p in scal.values())


# 3. catalogue and unknown paths -----------------------------------------------------------------


def test_3_catalogue_json_and_html(client):
    r = client.get("/")
    assert r.status_code == 200 and "json" in r.content_type
    uris = [c["Uri"] for c in r.json]
    assert "/foo" in uris and "/echo/scalars" in uris
    page = client.get("/", headers={"Accept": "text/html,application/xhtml+xml,*/*;q=0.8"})
    assert page.status_code == 200 and page.mimetype == "text/html"
    text = page.get_data(as_text=True)
    assert "/echo/lists" in text and "Offset a mesh and report its area." in text and "Distance" in text


def test_3_unknown_get_is_404_metadata_shaped_json(client):
    r = client.get("/no/such/thing")
    assert r.status_code == 404 and "json" in r.content_type
    body = r.json
    assert body["Inputs"] == [] and body["Outputs"] == [] and body["InputNames"] == [] and body["OutputNames"] == []
    assert body["Errors"] == ["Unknown component /no/such/thing"]


# 4. POST /solve by pointer ------------------------------------------------------------------------


@pytest.mark.parametrize("pointer", ["echo/scale", "/echo/scale", "echo/scale/", "echo%2Fscale",
                                     "http://127.0.0.1:5000/echo/scale?cache=1"])
def test_4_pointer_forms(client, pointer):
    r = client.post("/solve", json=hops_body(pointer, hops_tree("x", ["2.0"], type_="System.Double")))
    assert r.status_code == 200, r.json
    assert [t["ParamName"] for t in r.json["values"]] == ["value", "doubled"]  # metadata order
    assert values(r)["value"] == {"{0}": [{"type": "System.Double", "data": "4.0"}]}


def test_4_direct_post_and_grasshopper_route(client):
    body = hops_body("ignored", hops_tree("x", ["3"]))
    r = client.post("/echo/scale", json=body)
    assert r.status_code == 200 and values(r)["value"]["{0}"][0]["data"] == "6.0"
    body = {"algo": None, "pointer": "http://127.0.0.1:5000/echo/scale", "values": [hops_tree("x", [1.5], key="0")]}
    r = client.post("/grasshopper", json=body)
    assert r.status_code == 200 and values(r)["value"]["{0}"][0]["data"] == "3.0"


# 5. tree keys and empty trees --------------------------------------------------------------------


@pytest.mark.parametrize("key, path", [("{0}", (0,)), ("0", (0,)), ("{1}", (1,)), ("{0;0}", (0, 0)),
                                       ("0;1", (0, 1)), ("{ 0; 1; }", (0, 1)), ("{2;0;5}", (2, 0, 5))])
def test_5_tree_keys(client, key, path):
    assert parse_path(key) == path
    r = client.post("/solve", json=hops_body("echo/scale", hops_tree("x", ["2.0"], key=key)))
    assert r.status_code == 200
    out_key = "{" + ";".join(map(str, path)) + "}"
    assert values(r)["value"] == {out_key: [{"type": "System.Double", "data": "4.0"}]}


def test_5_empty_optional_inputs_and_unknown_top_level_keys(client):
    body = hops_body("echo/scale", hops_tree("x", ["1"]), {"ParamName": "factor", "InnerTree": {}},
                     dataformat=0, filename="x.gh", recursionlevel=1, **{"values-grasshopper": {}})
    r = client.post("/solve", json=body)
    assert r.status_code == 200 and values(r)["value"]["{0}"][0]["data"] == "2.0"  # default factor 2
    body = hops_body("echo/lists", hops_tree("numbers", ["1", "2", "3"]),
                     *[{"ParamName": n, "InnerTree": {}} for n in ("integers", "texts", "points")])
    r = client.post("/solve", json=body)
    assert r.status_code == 200
    assert values(r)["count"] == {"{0}": [{"type": "System.Int32", "data": "3"}]}
    assert values(r)["integers"] == {}  # a None output is an empty tree, still present


# 6. several branches, longest-list matching, tree access -----------------------------------------


def test_6_branch_by_branch_with_longest_list(client):
    body = hops_body("echo/scale",
                     {"ParamName": "x", "InnerTree": {"{0;0}": [{"data": "1"}], "{0;1}": [{"data": "2"}],
                                                      "{0;2}": [{"data": "3"}]}},
                     {"ParamName": "factor", "InnerTree": {"{0}": [{"data": "10"}], "{1}": [{"data": "100"}]}})
    r = client.post("/solve", json=body)
    assert r.status_code == 200
    v = values(r)["value"]
    # x has the most branches: its paths are kept; factor's last branch repeats (longest list)
    assert {k: [i["data"] for i in items] for k, items in v.items()} == {
        "{0;0}": ["10.0"], "{0;1}": ["200.0"], "{0;2}": ["300.0"]}


def test_6_several_items_in_a_branch_iterate_and_list_outputs_graft(client):
    body = hops_body("echo/scale", hops_tree("x", ["1", "2"]))
    v = values(client.post("/solve", json=body))
    assert [i["data"] for i in v["value"]["{0}"]] == ["2.0", "4.0"]
    assert set(v["doubled"]) == {"{0;0}", "{0;1}"}


def test_6_tree_access_keeps_paths(client):
    body = hops_body("echo/tree", {"ParamName": "tree", "InnerTree": {
        "{0;1}": [{"data": "1"}, {"data": "2"}], "0;0": [{"data": "5"}], "{3}": [{"data": "0.5"}]}})
    r = client.post("/solve", json=body)
    assert r.status_code == 200
    v = values(r)
    assert [i["data"] for i in v["sums"]["{0}"]] == ["5.0", "3.0", "0.5"]
    assert [json.loads(i["data"]) for i in v["paths"]["{0}"]] == ["0;0", "0;1", "3"]


# 7. geometry: the real Hops request ----------------------------------------------------------------


def test_7_real_hops_request_solves(client):
    body = shared_json("post_solve_request.json")
    r = client.post("/solve", json=body)
    assert r.status_code == 200, r.json
    v = values(r)
    assert list(v) == ["Result", "Area"]
    item = v["Result"]["{0}"][0]
    assert item["type"] == "Rhino.Geometry.Mesh" and isinstance(item["data"], str)
    out = rhino3dm.CommonObject.Decode(json.loads(item["data"]))
    src = rhino3dm.CommonObject.Decode(json.loads(body["values"][0]["InnerTree"]["{0}"][0]["data"]))
    assert isinstance(out, rhino3dm.Mesh) and len(out.Vertices) == len(src.Vertices)
    area = float(v["Area"]["{0}"][0]["data"])
    assert area > 0
    # response shape as in tests/data/hops/post_solve_response.json
    real = shared_json("post_solve_response.json")
    assert [t["ParamName"] for t in real["values"]] == list(v)
    assert real["values"][0]["InnerTree"]["{0}"][0]["type"] == item["type"]


def test_7_geometry_round_trip_every_kind(client):
    V, Q = quad_grid(3, 2)
    curve = convert.encode_curve(np.array([[0, 0, 0], [1, 1, 0], [2, 0, 1.0]]))
    body = hops_body(
        "echo/geometry",
        hops_tree("point", ['{"X":1.0,"Y":2.0,"Z":3.0}'], type_="Rhino.Geometry.Point3d"),
        hops_tree("vector", ['{"X":0.0,"Y":0.0,"Z":1.0}'], type_="Rhino.Geometry.Vector3d"),
        hops_tree("plane", [json.dumps({"Origin": {"X": 0, "Y": 0, "Z": 1}, "XAxis": {"X": 1, "Y": 0, "Z": 0},
                                        "YAxis": {"X": 0, "Y": 1, "Z": 0}, "ZAxis": {"X": 0, "Y": 0, "Z": 1}})],
                  type_="Rhino.Geometry.Plane"),
        hops_tree("line", ['{"From":{"X":0,"Y":0,"Z":0},"To":{"X":1,"Y":0,"Z":0}}'], type_="Rhino.Geometry.Line"),
        hops_tree("curve", [curve], type_="Rhino.Geometry.PolylineCurve"),
        hops_tree("mesh", [mesh_data(V, Q)], type_="Rhino.Geometry.Mesh"),
    )
    r = client.post("/solve", json=body)
    assert r.status_code == 200, r.json
    v = {k: t["{0}"][0] for k, t in values(r).items()}
    assert json.loads(v["point"]["data"]) == {"X": 1.0, "Y": 2.0, "Z": 3.0}
    assert v["point"]["type"] == "Rhino.Geometry.Point3d" and v["vector"]["type"] == "Rhino.Geometry.Vector3d"
    assert json.loads(v["plane"]["data"])["Origin"] == {"X": 0.0, "Y": 0.0, "Z": 1.0}
    assert json.loads(v["line"]["data"])["To"] == {"X": 1.0, "Y": 0.0, "Z": 0.0}
    assert np.array_equal(convert.decode_curve(v["curve"]["data"]), [[0, 0, 0], [1, 1, 0], [2, 0, 1]])
    V2, F2 = convert.decode_mesh(v["mesh"]["data"])
    assert np.array_equal(V2, V) and np.array_equal(F2, Q)


def test_7_surface_input(client):
    from components.core.types import NurbsSurface

    P = np.zeros((3, 3, 3))
    P[..., 0], P[..., 1] = np.meshgrid(np.arange(3.0), np.arange(3.0), indexing="ij")
    s = NurbsSurface(2, 2, P, np.ones((3, 3)), np.array([0, 0, 1, 1.0]), np.array([0, 0, 1, 1.0]))
    body = hops_body("echo/surface", hops_tree("surface", [convert.encode_surface(s)],
                                               type_="Rhino.Geometry.NurbsSurface"))
    v = values(client.post("/solve", json=body))
    assert v["degree_u"]["{0}"][0]["data"] == "2" and json.loads(v["corner"]["{0}"][0]["data"])["X"] == 0.0


def test_7_list_inputs_and_outputs_every_kind(client):
    V, Q = quad_grid(1, 1)
    body = hops_body(
        "echo/lists", hops_tree("numbers", ["1.5", "2.5"]), hops_tree("integers", ["1", "2", "3"]),
        hops_tree("texts", ['"a"', '"\u00e9"']), hops_tree("points", ['{"X":1,"Y":2,"Z":3}', '{"X":4,"Y":5,"Z":6}']),
        hops_tree("vectors", ['{"X":0,"Y":0,"Z":1}']),
        hops_tree("lines", ['{"From":{"X":0,"Y":0,"Z":0},"To":{"X":1,"Y":1,"Z":1}}']),
        hops_tree("curves", [convert.encode_curve(np.eye(3)), convert.encode_curve(2 * np.eye(3))]),
        hops_tree("meshes", [mesh_data(V, Q), mesh_data(V + 1, Q)]),
    )
    r = client.post("/solve", json=body)
    assert r.status_code == 200, r.json
    v = {k: t["{0}"] for k, t in values(r).items()}
    assert [i["data"] for i in v["numbers"]] == ["1.5", "2.5"]
    assert [i["data"] for i in v["integers"]] == ["1", "2", "3"]
    assert [i["data"] for i in v["texts"]] == ['"a"', '"\u00e9"']
    assert [json.loads(i["data"])["Z"] for i in v["points"]] == [3.0, 6.0]
    assert len(v["vectors"]) == 1 and len(v["lines"]) == 1 and len(v["curves"]) == 2
    assert [convert.decode_mesh(i["data"])[0][0, 0] for i in v["meshes"]] == [0.0, 1.0]
    assert v["count"][0]["data"] == "2"


# 8. scalar encodings -------------------------------------------------------------------------------


def test_8_scalar_output_encodings(client):
    body = hops_body("echo/scalars", hops_tree("number", ["100"]), hops_tree("integer", ["3"]),
                     hops_tree("boolean", ["true"]), hops_tree("text", [json.dumps('hé "x"\n')]))
    v = {k: t["{0}"][0] for k, t in values(client.post("/solve", json=body)).items()}
    assert v["number"] == {"type": "System.Double", "data": "100.0"}
    assert v["integer"] == {"type": "System.Int32", "data": "3"}
    assert v["boolean"] == {"type": "System.Boolean", "data": "true"}
    assert v["text"] == {"type": "System.String", "data": '"hé \\"x\\"\\n"'}
    raw = client.post("/solve", json=body).get_data()
    assert "hé".encode() in raw  # no ASCII escaping on the wire


# 9. errors and warnings -----------------------------------------------------------------------------


def test_9_warnings_are_200(client):
    r = client.post("/solve", json=hops_body("echo/scale", hops_tree("x", ["1"])))
    assert r.status_code == 200 and r.json["warnings"] == ["tolerance 0.001 Millimeters"]
    assert r.json["errors"] == []


def test_9_handler_failure_is_500_one_line(client, caplog):
    r = client.post("/solve", json=hops_body("echo/scale", hops_tree("x", ["13"])))
    assert r.status_code == 500 and "json" in r.content_type
    assert r.json["values"] == [] and len(r.json["errors"]) == 1
    msg = r.json["errors"][0]
    assert "unlucky" in msg and "\n" not in msg and "Traceback" not in msg
    assert "Traceback" in caplog.text  # the traceback goes to the log only


def test_9_nan_output_is_500(client):
    r = client.post("/solve", json=hops_body("echo/scale", hops_tree("x", ["424242.5"])))
    assert r.status_code == 500 and "NaN" in r.json["errors"][0] and "value" in r.json["errors"][0]


# bad input classes: 400 naming the input ------------------------------------------------------------


def _bad_meshes():
    m = rhino3dm.Mesh()
    m.Vertices.UseDoublePrecisionVertices = True
    for p in [(0, 0, 0), (1, 0, 0), (0, 1, 0)]:
        m.Vertices.AddPoint3d(*p)
    m.Faces.AddFace(0, 1, 5, 5)  # rhino3dm keeps the face although the index is out of range
    out_of_range = json.dumps(m.Encode())
    m2 = rhino3dm.Mesh()
    m2.Vertices.UseDoublePrecisionVertices = True
    for p in [(0, 0, 0), (1, 0, 0), (float("nan"), 1, 0)]:
        m2.Vertices.AddPoint3d(*p)
    m2.Faces.AddFace(0, 1, 2, 2)
    return out_of_range, json.dumps(m2.Encode())


@pytest.mark.parametrize("case", ["malformed_json", "not_object", "unknown_component", "missing_input",
                                  "mistyped_number", "undecodable_geometry", "not_geometry", "nan_coordinates",
                                  "face_index_out_of_range", "nan_number", "bad_tree_key", "bad_values",
                                  "component_input_error", "wrong_geometry_type"])
def test_bad_input_is_400_naming_the_input(client, case):
    out_of_range, nan_mesh = _bad_meshes()
    V, Q = quad_grid(1, 1)
    curve = convert.encode_curve(np.eye(3))
    cases = {
        "malformed_json": (b'{"pointer": "foo", "values": [', "not valid JSON"),
        "not_object": (b"[1, 2, 3]", "JSON object"),
        "unknown_component": (hops_body("nope", hops_tree("x", ["1"])), "unknown component 'nope'"),
        "missing_input": (hops_body("foo", hops_tree("Distance", ["1"])), "Mesh: missing required input"),
        "mistyped_number": (hops_body("echo/scale", hops_tree("x", ["abc"])), "x: expected a number"),
        "undecodable_geometry": (hops_body("foo", hops_tree("Mesh", ['{"version":10000,"archive3dm":60,'
                                                                     '"opennurbs":1,"data":"AAAA"}'])),
                                 "Mesh: geometry data could not be decoded"),
        "not_geometry": (hops_body("foo", hops_tree("Mesh", ["hello"])), "Mesh: geometry data is not JSON"),
        "nan_coordinates": (hops_body("foo", hops_tree("Mesh", [nan_mesh])), "Mesh: mesh vertex 2 has a NaN"),
        "face_index_out_of_range": (hops_body("foo", hops_tree("Mesh", [out_of_range])),
                                    "Mesh: mesh face 0 has a vertex index out of range"),
        "nan_number": (hops_body("echo/scale", hops_tree("x", ["NaN"])), "x: value nan is not a finite number"),
        "bad_tree_key": (hops_body("echo/scale", hops_tree("x", ["1"], key="{a;b}")), "x: tree key"),
        "bad_values": (hops_body("echo/scale") | {"values": {"x": 1}}, "'values' must be a list"),
        "component_input_error": (hops_body("echo/scale", hops_tree("x", ["1"]), hops_tree("factor", ["-2"])),
                                  "factor: must not be negative"),
        "wrong_geometry_type": (hops_body("foo", hops_tree("Mesh", [curve])), "Mesh: expected a Mesh"),
    }
    body, message = cases[case]
    r = client.post("/solve", data=body if isinstance(body, bytes) else json.dumps(body),
                    content_type="application/json")
    assert r.status_code == 400, r.get_data(as_text=True)
    assert "json" in r.content_type and r.json["values"] == []
    assert message in r.json["errors"][0], r.json["errors"]


# 10. stale client: Bad inputs -------------------------------------------------------------------------


def test_10_stale_inputs_answer_bad_inputs(client):
    r = client.post("/solve", json=hops_body("echo/scale", hops_tree("x", ["1"]), hops_tree("old_name", ["2"])))
    assert r.status_code == 500 and r.json["errors"][0] == "Bad inputs"
    assert "old_name" in r.json["errors"][1]


# 13. cache ------------------------------------------------------------------------------------------------


def test_13_cachesolve(echo_registry):
    calls = []

    def counting(x: float, factor: float = 2.0) -> echo.Scaled:
        calls.append(x)
        return echo.Scaled(x * factor, np.array([x]), [])

    counting.__doc__ = echo.scale.__doc__
    reg = Registry([declare(counting, "count")])
    client = create_app(Config(cache_size=8), registry=reg).test_client()
    body = hops_body("count", hops_tree("x", ["1"]), cachesolve=True)
    a = client.post("/solve", json=body)
    b = client.post("/solve", json=body)
    assert a.get_data() == b.get_data() and len(calls) == 1
    client.post("/solve", json=dict(body, cachesolve=False))
    assert len(calls) == 2
    other_tol = dict(body, absolutetolerance=0.01)
    client.post("/solve", json=other_tol)
    assert len(calls) == 3
    # errors are never cached
    bad = hops_body("count", hops_tree("x", ["abc"]), cachesolve=True)
    assert client.post("/solve", json=bad).status_code == 400


# 14. no stdout dumps -------------------------------------------------------------------------------------


def test_14_nothing_printed(client, capsys):
    client.post("/solve", json=shared_json("post_solve_request.json"))
    client.get("/foo")
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


def test_body_size_limit_is_json_413(echo_registry):
    client = create_app(Config(max_body_mb=0.001), registry=echo_registry).test_client()
    body = hops_body("echo/lists", hops_tree("numbers", ["1.0"] * 1000))
    r = client.post("/solve", json=body)
    assert r.status_code == 413 and "json" in r.content_type
    assert "limit" in r.json["errors"][0] and "MB" in r.json["errors"][0]


def test_method_not_allowed_is_json(client):
    r = client.put("/foo")
    assert r.status_code == 405 and "json" in r.content_type and r.json["errors"]


def test_pointer_uri_forms():
    assert pointer_uri("a/b") == pointer_uri("/a/b/") == pointer_uri("a%2Fb") == "a/b"
    assert pointer_uri("https://h:1/x/y?q=1") == "x/y"


def test_request_is_not_mutated(client):
    body = hops_body("echo/scale", hops_tree("x", ["1"]))
    before = copy.deepcopy(body)
    client.post("/solve", json=body)
    assert body == before


def test_a_repeated_branch_is_decoded_once(client, monkeypatch):
    from ghserver import params

    calls = []
    real = params.decode_item

    def counting(kind, item, limits=None):
        calls.append(kind)
        return real(kind, item, limits)

    monkeypatch.setattr(params, "decode_item", counting)
    V, Q = quad_grid(3, 3)
    body = hops_body("foo", hops_tree("Mesh", [mesh_data(V, Q)]),
                     {"ParamName": "Distance", "InnerTree": {f"{{{i}}}": [{"data": str(i)}] for i in range(4)}})
    r = client.post("/solve", json=body)
    assert r.status_code == 200 and len(values(r)["Area"]) == 4  # one answer per branch of Distance
    assert calls.count("Mesh") == 1 and calls.count("Number") == 4
