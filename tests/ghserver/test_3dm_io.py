""".3dm and .stl in and out: ghserver.convert.read_3dm / read_model / write_meshes_3dm, the STL weld of
components.core.mesh.read_stl, and ``ghserver report`` / ``ghserver fabricate`` on such files."""
from __future__ import annotations

import struct

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")

from components.core.errors import InputError  # noqa: E402
from components.core.mesh import quad_grid, read_mesh, read_stl, triangulate, write_obj  # noqa: E402
from components.core.types import NurbsSurface  # noqa: E402
from components.surfaces.generators import surface_mesh  # noqa: E402
from ghserver import cli  # noqa: E402
from ghserver.convert import read_3dm, read_model, value_to_surface, write_meshes_3dm  # noqa: E402
from ghserver.report import QUICK, run_report  # noqa: E402


def _dome(offset=0.0, scale=1.0):
    V, Q = quad_grid(6, 5, 3.0, 2.5, height=lambda x, y: 0.3 * np.sin(x) * np.cos(y))
    return V * scale + offset, Q


def _write_stl(path, V, T, binary=True):
    P = V[T]
    if binary:
        out = bytearray(b"\0" * 80 + struct.pack("<I", len(T)))
        for tri in P:
            out += struct.pack("<3f", 0, 0, 0) + struct.pack("<9f", *tri.ravel()) + b"\0\0"
        path.write_bytes(bytes(out))
    else:
        lines = ["solid x"]
        for tri in P:
            lines += ["facet normal 0 0 0", "outer loop"] + [f"vertex {x:.9e} {y:.9e} {z:.9e}" for x, y, z in tri]
            lines += ["endloop", "endfacet"]
        path.write_text("\n".join(lines + ["endsolid x"]))


def _surface():
    # a bicubic-by-biquadratic NURBS patch with one weight off 1
    u, v = np.linspace(0, 4, 4), np.linspace(0, 3, 3)
    P = np.stack(list(np.meshgrid(u, v, indexing="ij")) + [np.zeros((4, 3))], axis=-1)
    P[1:3, 1, 2] = 1.5
    w = np.ones((4, 3))
    w[1, 1] = 2.0
    return NurbsSurface(3, 2, P, w, np.array([0, 0, 0, 1, 1, 1.0]), np.array([0, 0, 1, 1.0]))


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("offset, scale", [(0.0, 1.0), (5e6, 1000.0)])
def test_stl_is_welded_back_to_the_shared_vertices(tmp_path, binary, offset, scale):
    V, Q = _dome(offset, scale)
    T = triangulate(Q)[0]
    path = tmp_path / "dome.stl"
    _write_stl(path, V, T, binary)
    s = read_stl(path)
    assert len(s.V) == len(V) and len(s.F) == len(T) and s.corners == 3 * len(T) and s.dropped == 0
    diag = np.linalg.norm(V.max(0) - V.min(0))
    assert s.tolerance == pytest.approx(1e-6 * diag, rel=1e-3)  # the box of the stored (rounded) corners
    # every triangle lands on its corners as stored: float32 for binary STL (0.5 units at 5e6), 10 digits in ASCII
    stored = V.astype(np.float32).astype(np.float64) if binary else V
    assert np.abs(s.V[s.F] - stored[T]).max() <= 1e-9 * np.abs(V).max()
    V2, F2 = read_mesh(path)
    assert np.array_equal(F2, s.F)
    notes = read_model(path).notes
    assert "welded into 42 vertices" in notes[0]
    # far from the origin a binary STL has rounded the model (float32): the reader says so, with how much
    rounded = binary and offset > 0
    assert any("single-precision" in n for n in notes) == rounded, notes


def test_not_an_stl_is_a_typed_error(tmp_path):
    path = tmp_path / "x.stl"
    path.write_text("hello")
    with pytest.raises(ValueError, match="not an STL file"):
        read_stl(path)


def test_3dm_mesh_round_trip_exact(tmp_path):
    V, Q = _dome(5e6, 1.0)
    path = write_meshes_3dm(tmp_path / "m.3dm", [("design", "roof", V, Q)])
    V2, F2, notes, _ = read_model(path)
    assert np.array_equal(V2, V) and np.array_equal(F2, Q)
    assert "'roof'" in notes[0] and "'design'" in notes[0]


def test_3dm_nurbs_surface_and_brep_meshed_on_the_surface(tmp_path):
    srf = _surface()
    for geo in (value_to_surface(srf), rhino3dm.Brep.CreateFromSurface(value_to_surface(srf))):
        model = rhino3dm.File3dm()
        model.Objects.AddSurface(geo) if isinstance(geo, rhino3dm.Surface) else model.Objects.AddBrep(geo)
        path = tmp_path / "srf.3dm"
        assert model.Write(str(path), 7)
        V, T, notes, _ = read_3dm(path, segments=12)
        ref = surface_mesh(srf, 12, 12).mesh
        assert T.shape[1] == 3 and np.array_equal(T, ref[1])
        assert np.abs(V - ref[0]).max() <= 1e-12 * np.abs(ref[0]).max()
        assert "12 × 12" in notes[0]


def test_3dm_with_several_objects_needs_a_choice(tmp_path):
    V, Q = _dome()
    path = write_meshes_3dm(tmp_path / "two.3dm", [("a", "first", V, Q), ("b", "second", V + 1.0, Q)])
    with pytest.raises(InputError, match="2 meshes/surfaces.*'first'.*'second'"):
        read_model(path)
    assert np.array_equal(read_model(path, layer="b").V, V + 1.0)
    assert np.array_equal(read_model(path, name="first").V, V)
    with pytest.raises(InputError, match="no mesh.*--layer 'c'"):
        read_model(path, layer="c")
    obj = tmp_path / "x.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="only apply to .3dm"):
        read_model(obj, layer="a")


def test_not_a_3dm_is_a_typed_error(tmp_path):
    path = tmp_path / "bad.3dm"
    path.write_bytes(b"not rhino")
    with pytest.raises(InputError, match="not a readable Rhino .3dm"):
        read_model(path)


def test_report_reads_3dm_and_stl_and_writes_results_3dm(tmp_path):
    V, Q = _dome()
    model = tmp_path / "model.3dm"
    write_meshes_3dm(model, [("design", "roof", V, Q)])
    stl = tmp_path / "roof.stl"
    _write_stl(stl, V, triangulate(Q)[0])
    summary = run_report(tmp_path / "out", surfaces=(), mesh_files=[model, stl], progress=False,
                         strategies=["translation", "subdivision"], settings=QUICK)
    assert summary.rows == 4
    back = rhino3dm.File3dm.Read(str(summary.out_dir / "results.3dm"))
    layers = [back.Layers[i].Name for i in range(len(back.Layers))]
    assert layers == ["translation", "subdivision"][:len(layers)] and len(layers) >= 1
    names = {o.Attributes.Name for o in back.Objects}
    with_mesh = [s for s in summary.statuses if s[2] != "failed"]
    assert {n.split()[0] for n in names} <= {"model", "roof"} and len(names) >= len(with_mesh)
    for o in back.Objects:
        assert isinstance(o.Geometry, rhino3dm.Mesh) and len(o.Geometry.Faces) > 0


def test_fabricate_accepts_3dm(tmp_path, capsys):
    V, Q = quad_grid(3, 2, 2.0, 1.0)
    model = write_meshes_3dm(tmp_path / "panels.3dm", [("p", "flat", V, Q)])
    assert cli.main(["fabricate", str(model), "--out", str(tmp_path / "fab")]) == 0
    assert (tmp_path / "fab" / "panels.3dm").exists()
    assert "6 panels" in capsys.readouterr().out


@pytest.mark.parametrize("units, dxf_code", [("Meters", 6), ("Millimeters", 4), ("Feet", 2), (None, 0)])
def test_fabricate_writes_the_model_units_into_the_dxf_and_the_3dm(tmp_path, capsys, units, dxf_code):
    # a model in metres must not come back labelled millimetres (rhino3dm's default) or a mm model as metres (ezdxf's):
    # a reader that honours the units would scale every panel by 1000
    import ezdxf

    V, Q = quad_grid(3, 2, 2.0, 1.0)
    model = write_meshes_3dm(tmp_path / "panels.3dm", [("p", "flat", V, Q)], units=units)
    assert read_model(model).units == units
    assert cli.main(["fabricate", str(model), "--out", str(tmp_path / "fab")]) == 0
    out = capsys.readouterr().out
    assert ezdxf.readfile(tmp_path / "fab" / "panels_panels.dxf").units == dxf_code
    back = rhino3dm.File3dm.Read(str(tmp_path / "fab" / "panels.3dm")).Settings.ModelUnitSystem.name
    assert back == (units or "None")
    assert ("does not say its units" in out) == (units is None)


def test_fabricate_units_option_for_files_without_units(tmp_path, capsys):
    import ezdxf

    V, Q = quad_grid(3, 2, 2000.0, 1000.0)
    obj = tmp_path / "roof.obj"
    write_obj(obj, V, Q)
    assert read_model(obj).units is None
    assert cli.main(["fabricate", str(obj), "--units", "mm", "--out", str(tmp_path / "fab")]) == 0
    assert "does not say its units" not in capsys.readouterr().out
    assert ezdxf.readfile(tmp_path / "fab" / "roof_panels.dxf").units == 4
    assert rhino3dm.File3dm.Read(str(tmp_path / "fab" / "roof.3dm")).Settings.ModelUnitSystem.name == "Millimeters"
    with pytest.raises(SystemExit):  # argparse refuses a unit it does not list
        cli.main(["fabricate", str(obj), "--units", "furlong"])


def test_report_results_3dm_keeps_the_meshes_units(tmp_path):
    V, Q = quad_grid(4, 4, 4000.0, 4000.0)
    V[:, 2] = 1e-4 * (V[:, 0] - 2000.0) * (V[:, 1] - 2000.0)
    model = write_meshes_3dm(tmp_path / "roof.3dm", [("roof", "roof", V, triangulate(Q)[0])], units="Millimeters")
    summary = run_report(tmp_path / "out", surfaces=(), mesh_files=[model], progress=False,
                         strategies=["translation"], settings=QUICK)
    back = rhino3dm.File3dm.Read(str(summary.out_dir / "results.3dm"))
    assert back.Settings.ModelUnitSystem.name == "Millimeters"


def test_a_single_precision_3dm_mesh_far_from_the_origin_gets_a_note(tmp_path):
    V, Q = quad_grid(3, 3, 3000.0, 3000.0)
    for shift, noted in ((0.0, False), (5e6, True)):
        W = (V + shift).astype(np.float32).astype(np.float64)  # what a single-precision export keeps
        mesh = rhino3dm.Mesh()
        for x, y, z in W.tolist():
            mesh.Vertices.Add(x, y, z)
        for f in Q.tolist():
            mesh.Faces.AddFace(*f)
        m = rhino3dm.File3dm()
        m.Objects.AddMesh(mesh)
        path = tmp_path / f"single_{int(shift)}.3dm"
        assert m.Write(str(path), 7)
        notes = " ".join(read_model(path).notes)
        assert ("single-precision" in notes and "rounded by up to 0.25" in notes) == noted
