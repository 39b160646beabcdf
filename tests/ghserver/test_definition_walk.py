"""Every shipped ``gh_definitions/*.ghx`` runs out of the box.

The test reads each definition as Grasshopper would, follows its wires and solves every Hops component through the
server (Flask test client, the real registry) with what its inputs are wired to: the sliders' and panels' values,
the outputs of the upstream Hops components (passed on as the server returned them), and for the floating
Mesh/Curve parameters a user sets from Rhino a small sample in metres (a 36 m × 24 m wave, two curves of about 10 m).
No Hops component may answer an error (HTTP status or the Hops ``errors`` list), neither at the sliders' defaults nor
(for the components that answer within a second) with one slider moved to either end of its range; every slider sits
inside the range the server declares for the input it feeds (Hops refuses to send values outside it).
"""
from __future__ import annotations

import json
import time
from graphlib import TopologicalSorter

import numpy as np
import pytest

from components.core.types import NurbsCurve
from components.surfaces.samples import sample_mesh
from ghserver import convert, definitions, ghx
from ghserver import params as P
from ghserver.app import Config, create_app
from tests.conftest import ROOT

SHIPPED = sorted((ROOT / "gh_definitions").glob("*.ghx"))
HEADERS = {"Content-Type": "application/json"}
QUICK_SOLVE = 1.0  # seconds: components answering faster are also solved at their sliders' ends
# ... except these: 0.25 m panels on the 36 m wave take 13 s (0.4 s on a tenth of its size); the conical pipeline
# with them 97 s (its default, 1.5 m, answers in 0.8 s since the planarizer's reduced solves)
SLOW_ENDS = {("network/curvature_network", "panel_size", "Min"),
             ("network/pq_from_curvature_network", "panel_size", "Min")}


def _wave():
    V, T, _ = sample_mesh("wave", 12)
    return V, T


def _arc():
    w = np.array([1.0, np.sqrt(0.5), 1.0])
    return NurbsCurve(2, np.array([[0.0, 0, 0], [0, 5, 3], [0, 10, 0]]), w, np.array([0, 0, 1, 1.0]))


# what a user sets from Rhino into the floating parameters, by (kind, parameter name)
SAMPLES = {
    ("Mesh", "mesh"): lambda: {"type": "Rhino.Geometry.Mesh", "data": convert.encode_mesh(*_wave())},
    ("Mesh", "surface"): lambda: {"type": "Rhino.Geometry.Mesh", "data": convert.encode_mesh(*_wave())},
    ("Mesh", "reference"): lambda: {"type": "Rhino.Geometry.Mesh", "data": convert.encode_mesh(*_wave())},
    ("Curve", "generatrix"): lambda: P.encode_item(
        "Curve", NurbsCurve(1, np.array([[0.0, 0, 0], [4, 0, 1], [8, 0, 0.5], [12, 0, 0.0]]), np.ones(4),
                            np.array([0, 1, 2, 3.0]))),
    ("Curve", "directrix"): lambda: P.encode_item("Curve", _arc()),
}


class Walk:
    """The objects of one definition and the wires between them."""

    def __init__(self, path):
        root = ghx.load_ghx(path)
        self.name = path.name
        self.objects = {o.find("Container").get("InstanceGuid"): o for o in ghx.definition_objects(root)}
        self.hops = ghx.hops_components(root)
        self.output_of = {o.instance_guid: (h, o) for h in self.hops for o in h.outputs}

    def order(self):
        """The Hops components, every one after the components it is wired to."""
        by_guid = {h.instance_guid: h for h in self.hops}
        deps = {h.instance_guid: {self.output_of[s][0].instance_guid for i in h.inputs for s in i.sources
                                  if s in self.output_of} for h in self.hops}
        return [by_guid[g] for g in TopologicalSorter(deps).static_order()]

    def sliders(self):
        """``(hops component, input, slider chunk)`` for every slider wired into a Hops input."""
        for h in self.hops:
            for inp in h.inputs:
                for s in inp.sources:
                    obj = self.objects.get(s)
                    if obj is not None and obj.get("GUID") == ghx.SLIDER_GUID:
                        yield h, inp, obj.find("Container").find("Slider")

    def items(self, inp, source: str, results: dict) -> list[dict]:
        """The Hops items ``{"type", "data"}`` a wire from ``source`` carries into ``inp``."""
        if source in self.output_of:
            h, out = self.output_of[source]
            tree = results[h.instance_guid][out.name]
            return [it for branch in tree.values() for it in branch]
        obj = self.objects[source]
        kind, c = obj.get("GUID"), obj.find("Container")
        if kind == ghx.SLIDER_GUID:
            s = c.find("Slider")
            value = s.get("Value")
            return [P.encode_item(inp.kind, int(round(value)) if s.get("Interval") == 1 else value)]
        if kind == ghx.PANEL_GUID:
            text = c.get("UserText")
            if inp.kind == "Boolean":
                assert text in ("true", "false"), f"{self.name}: panel {text!r} feeds the Boolean {inp.name}"
                return [P.encode_item("Boolean", text == "true")]
            return [P.encode_item(inp.kind, text)]
        param_kind = ghx.PARAM_KIND_BY_GUID.get(kind)
        sample = SAMPLES.get((param_kind, c.get("NickName")))
        assert sample is not None, f"{self.name}: no sample for the floating {param_kind} {c.get('NickName')!r}"
        return [sample()]


@pytest.fixture(scope="module")
def server():
    app = create_app(Config(cache_size=64))
    return app.test_client()


def _solve(server, h, trees: list[dict]):
    body = {"absolutetolerance": 0.001, "angletolerance": 1.0, "modelunits": "Meters", "dataversion": 7,
            "algo": None, "pointer": h.url, "cachesolve": False, "values": trees, "warnings": [], "errors": []}
    r = server.post("/solve", data=json.dumps(body), headers=HEADERS)
    return r.status_code, r.get_json()


def test_definitions_are_shipped():
    assert len(SHIPPED) >= 7, [p.name for p in SHIPPED]


def test_every_slider_without_a_server_default_has_a_chosen_one():
    from ghserver.endpoints import build_registry

    registry = build_registry()
    for path in SHIPPED:
        for h, inp, _ in Walk(path).sliders():
            uri = ghx.uri_of(h.url)
            (schema,) = [i for i in registry.get(uri).metadata()["Inputs"] if i["Name"] == inp.name]
            if schema.get("Default") is None:
                assert definitions.slider_of(uri, schema) is not None, \
                    f"{path.name}: {uri} {inp.name} has no default: add it to ghserver.definitions.SLIDERS"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_sliders_sit_inside_the_declared_ranges(path):
    from ghserver.endpoints import build_registry

    registry = build_registry()
    walk = Walk(path)
    count = 0
    for h, inp, s in walk.sliders():
        lo, hi, value = s.get("Min"), s.get("Max"), s.get("Value")
        where = f"{path.name}: {ghx.uri_of(h.url)} {inp.name}"
        assert lo <= value <= hi and lo < hi, f"{where}: slider {value} in [{lo}, {hi}]"
        (schema,) = [i for i in registry.get(ghx.uri_of(h.url)).metadata()["Inputs"] if i["Name"] == inp.name]
        if schema.get("Minimum") is not None:
            assert lo >= schema["Minimum"], f"{where}: slider minimum {lo} below the declared {schema['Minimum']}"
        if schema.get("Maximum") is not None:
            assert hi <= schema["Maximum"], f"{where}: slider maximum {hi} above the declared {schema['Maximum']}"
        count += 1
    if path.name not in ("metrics_analysis.ghx",):
        assert count, f"{path.name}: no slider"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_every_hops_component_solves_without_errors(path, server):
    """Solve every Hops component with what it is wired to; a component that answers quickly (under
    :data:`QUICK_SOLVE` seconds) is solved again with each of its sliders at the slider's minimum and maximum."""
    walk = Walk(path)
    assert walk.hops, path.name
    results: dict[str, dict] = {}
    ends = 0
    for h in walk.order():
        trees = {}
        for inp in h.inputs:
            if not inp.sources:
                continue  # Hops sends the server's default (or nothing for an optional input)
            items = [it for s in inp.sources for it in walk.items(inp, s, results)]
            trees[inp.name] = {"ParamName": inp.name, "InnerTree": {"{0}": items}}
        where = f"{path.name}: {ghx.uri_of(h.url)}"
        t0 = time.perf_counter()
        status, answer = _solve(server, h, list(trees.values()))
        quick = time.perf_counter() - t0 < QUICK_SOLVE
        assert status == 200, f"{where}: HTTP {status}: {answer}"
        assert answer["errors"] == [], f"{where}: {answer['errors']}"
        results[h.instance_guid] = {v["ParamName"]: v["InnerTree"] for v in answer["values"]}
        for out in h.outputs:
            assert out.name in results[h.instance_guid], f"{where}: no output {out.name}"
        if not quick:
            continue
        for hs, inp, s in walk.sliders():
            if hs is not h:
                continue
            for end in ("Min", "Max"):
                if (ghx.uri_of(h.url), inp.name, end) in SLOW_ENDS:
                    continue
                value = int(round(s.get(end))) if s.get("Interval") == 1 else s.get(end)
                moved = dict(trees, **{inp.name: {"ParamName": inp.name,
                                                  "InnerTree": {"{0}": [P.encode_item(inp.kind, value)]}}})
                status, answer = _solve(server, h, list(moved.values()))
                assert status == 200 and answer["errors"] == [], \
                    f"{where}: slider {inp.name} at its {end.lower()}imum {value}: HTTP {status} {answer['errors']}"
                ends += 1
    if path.name != "metrics_analysis.ghx":
        assert ends, f"{path.name}: no slider end tried"
