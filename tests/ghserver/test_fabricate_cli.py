"""``ghserver fabricate``: DXF, CSV and .3dm written and read back (ezdxf, csv, rhino3dm); bad input is a message and
exit code 2; the fabrication components solve through the Flask app as Hops calls them."""
from __future__ import annotations

import collections
import csv
import json

import ezdxf
import numpy as np
import pytest
import rhino3dm

from components.core.mesh import edge_topology, quad_grid, write_obj
from ghserver import cli, convert
from ghserver.app import Config, create_app
from ghserver.endpoints import build_registry
from tests.ghserver.conftest import hops_body, hops_tree


def roof():
    V, Q = quad_grid(6, 5, 6.0, 5.0)
    V[:, 2] = 0.05 * (V[:, 0] - 3.0) ** 2  # a barrel roof: planar quads, three panel types
    return V, Q


@pytest.fixture(scope="module")
def fabricated(tmp_path_factory):
    d = tmp_path_factory.mktemp("fab")
    V, Q = roof()
    write_obj(d / "roof.obj", V, Q)
    code = cli.main(["fabricate", str(d / "roof.obj"), "--out", str(d / "out"), "--tolerance", "0.001", "0.01", "1",
                     "--sheet", "3", "2", "--gap", "0.05"])
    return code, d / "out", V, Q


def test_fabricate_writes_the_three_files(fabricated, capsys):
    code, out, V, Q = fabricated
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == ["roof.3dm", "roof_cutting_list.csv", "roof_panels.dxf"]


def test_dxf_reads_back_with_a_closed_polyline_and_label_per_panel(fabricated):
    _, out, V, Q = fabricated
    msp = ezdxf.readfile(out / "roof_panels.dxf").modelspace()
    polys = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer.startswith("TYPE_")]
    assert len(polys) == len(Q) and all(p.closed and len(p) == 4 for p in polys)
    assert sorted(t.dxf.text for t in msp.query("TEXT")) == sorted(f"{r}{c:02d}" for r in "ABCDE" for c in range(1, 7))
    # the barrel's rows differ, its columns are mirror pairs: three types at 0.001
    assert len({p.dxf.layer for p in polys}) == 3
    # every flat outline has its 3D panel's edge lengths
    L2 = sorted(round(float(np.hypot(*np.subtract(p[(i + 1) % 4][:2], p[i][:2]))), 9)
                for p in polys for i in range(4))
    P = V[Q]
    L3 = sorted(round(float(x), 9) for x in np.linalg.norm(np.roll(P, -1, axis=1) - P, axis=2).ravel())
    assert L2 == L3


def test_csv_has_one_row_per_panel(fabricated):
    _, out, V, Q = fabricated
    rows = list(csv.DictReader((out / "roof_cutting_list.csv").open()))
    assert len(rows) == len(Q) and [int(r["id"]) for r in rows] == list(range(len(Q)))
    assert np.allclose(sorted(float(r["area"]) for r in rows), sorted(np.linalg.norm(
        np.cross(V[Q[:, 2]] - V[Q[:, 0]], V[Q[:, 3]] - V[Q[:, 1]]), axis=1) / 2), rtol=1e-9)
    assert {r["type"] for r in rows} == {"0", "1", "2"}


def test_3dm_reads_back_with_the_layers_and_counts(fabricated):
    _, out, V, Q = fabricated
    model = rhino3dm.File3dm.Read(str(out / "roof.3dm"))
    names = [model.Layers[i].Name for i in range(len(model.Layers))]
    assert names == list(convert.LAYERS_3DM)
    count = collections.Counter((names[o.Attributes.LayerIndex], type(o.Geometry).__name__) for o in model.Objects)
    n_edges = len(edge_topology(Q).E)
    sheets = count[("sheets", "PolylineCurve")]
    assert count == {("panels", "Mesh"): len(Q), ("labels", "TextDot"): len(Q), ("node_axes", "LineCurve"): len(V),
                     ("beams", "Mesh"): n_edges, ("flat_panels", "PolylineCurve"): len(Q),
                     ("sheets", "PolylineCurve"): sheets}
    assert sheets >= 15  # 1 × 1 panels, two per 3 × 2 sheet with a 0.05 gap
    dots = sorted(o.Geometry.Text for o in model.Objects if isinstance(o.Geometry, rhino3dm.TextDot))
    assert dots[:2] == ["A01", "A02"] and len(set(dots)) == len(Q)


def test_bad_input_is_a_message_and_exit_code_2(tmp_path, capsys):
    assert cli.main(["fabricate", str(tmp_path / "missing.obj"), "--out", str(tmp_path)]) == 2
    assert "ghserver fabricate:" in capsys.readouterr().err
    V, Q = roof()
    write_obj(tmp_path / "roof.obj", V, Q)
    assert cli.main(["fabricate", str(tmp_path / "roof.obj"), "--out", str(tmp_path / "o"), "--sheet", "0.5",
                     "0.5"]) == 2
    assert "sheet_width: panel A01" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


# ------------------------------------------------------------------------------------------------ Hops round trip


@pytest.fixture(scope="module")
def client():
    return create_app(Config(cache_size=0, workers=0), registry=build_registry()).test_client()


def _values(resp) -> dict:
    body = resp.get_json()
    return {v["ParamName"]: [item for branch in v["InnerTree"].values() for item in branch] for v in body["values"]}


def test_kinks_solve_through_the_app_as_hops_sends_it(client):
    nt = 8
    z = np.linspace(0.0, 2.0, 3)
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    Z, Th = np.meshgrid(z, th, indexing="ij")
    V = np.stack([np.cos(Th), np.sin(Th), Z], -1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(3, nt)
    F = np.array([[idx[i, j], idx[i, (j + 1) % nt], idx[i + 1, (j + 1) % nt], idx[i + 1, j]]
                  for i in range(2) for j in range(nt)])
    body = hops_body("fabrication/kinks", hops_tree("mesh", [convert.encode_mesh(V, F)]),
                     hops_tree("limit", ["30.0"], type_="System.Double"))
    resp = client.post("/solve", data=json.dumps(body), content_type="application/json")
    assert resp.status_code == 200, resp.get_data(as_text=True)
    out = _values(resp)
    kinks = np.array([float(json.loads(i["data"])) for i in out["kinks"]])
    assert len(kinks) == len(edge_topology(F).E) - 2 * nt  # interior edges: the two rims are the boundary
    assert np.allclose(np.sort(kinks)[-2 * nt:], 360.0 / nt, atol=1e-9)
    assert float(json.loads(out["max_kink"][0]["data"])) == pytest.approx(45.0)
    assert int(json.loads(out["over_count"][0]["data"])) == 2 * nt
    assert any("kink more than 30" in w for w in resp.get_json()["warnings"])


def test_panels_metadata_and_bad_input_through_the_app(client):
    meta = client.get("/fabrication/panels").get_json()
    assert meta["InputNames"][:4] == ["mesh", "sheet_width", "sheet_height", "gap"]
    assert "outlines" in meta["OutputNames"] and "sheet_frames" in meta["OutputNames"]
    V, Q = quad_grid(2, 2)
    body = hops_body("fabrication/panels", hops_tree("mesh", [convert.encode_mesh(V, Q)]),
                     hops_tree("gap", ["-1.0"], type_="System.Double"))
    resp = client.post("/solve", data=json.dumps(body), content_type="application/json")
    assert resp.status_code == 400 and resp.get_json()["errors"][0].startswith("gap:")


def test_readme_fabrication_example_runs_and_prints_what_it_says(tmp_path, monkeypatch):
    import re
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Fabrication\n", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, re.S)
    monkeypatch.chdir(tmp_path)
    printed = []
    exec(compile(block, "README.md", "exec"), {"print": lambda *a: printed.append(a)})
    labels, sheets, err = printed[0]
    assert labels == ["A01", "A02", "A03"] and sheets == 5 and err < 1e-15
    assert printed[1][0] == 1 and printed[1][1].tolist() == [1, 1, 1, 1]  # a barrel vault: one panel type
    assert round(printed[2][0], 1) == 14.3 and printed[3][0] < 1e-12  # 1/4 rad between the rows; conical
    assert (tmp_path / "roof.obj").exists()
    assert (tmp_path / "roof_panels.dxf").exists() and (tmp_path / "roof_cutting_list.csv").exists()
    assert "ghserver fabricate roof.obj --units m --out fabrication" in section


@pytest.mark.parametrize("uri", ["metrics/valence", "metrics/edge_lengths", "subdivision/catmull_clark",
                                 "metrics/conical_criterion"])
def test_an_unwelded_mesh_is_said_in_every_answer_that_follows_its_edges(client, uri):
    # an audit: valence, edge counts, the conical criterion, Catmull-Clark on a mesh whose faces have their own
    # corners came back wrong and silent; the server says so for every mesh input, naming it and saying "weld"
    V, Q = quad_grid(4, 4, 4.0, 4.0)
    V[:, 2] = 0.1 * V[:, 0] * V[:, 1]
    soup_V, soup_F = V[Q].reshape(-1, 3), np.arange(4 * len(Q)).reshape(-1, 4)
    said = []
    for VV, FF in ((V, Q), (soup_V, soup_F)):
        resp = client.post("/solve", data=json.dumps(hops_body(uri, hops_tree("mesh", [convert.encode_mesh(VV, FF)]))),
                           content_type="application/json")
        assert resp.status_code == 200, resp.get_data(as_text=True)
        said.append([w for w in resp.get_json()["warnings"] if "not welded" in w])
    assert said[0] == []
    assert len(said[1]) == 1 and said[1][0].startswith(f"mesh: {len(soup_V) - len(V)} vertices lie exactly on other")
    assert "weld it (Rhino: _Weld)" in said[1][0]
