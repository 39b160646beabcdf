"""End-to-end curvature-network strategy on the built-in samples and libigl's inspired_mesh (the network traced by
components.fields.streamlines; the private test tracer of test_curvature_network stands in when it is absent)."""
from __future__ import annotations

import numpy as np
import pytest

from components.conical.cones import face_offset, face_planes
from components.network.pipeline import curvature_pipeline, pq_from_curvature_network
from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_vertex_mask, edge_topology, face_corners, quad_grid, read_mesh
from components.network.rebuild import quad_rebuild
from components.network.tracing import curvature_network
from components.surfaces.samples import sample_mesh
from tests.components.test_curvature_network import trace_evenly
from tests.components.test_network_health import assert_conical_claim
from tests.conftest import data_file


try:
    import components.fields.streamlines  # noqa: F401

    TRACER = None  # the project's tracer
except ImportError:  # pragma: no cover - until components.fields.streamlines lands
    TRACER = trace_evenly


def _surface(name):
    if name == "inspired":
        return read_mesh(data_file("inspired_mesh.obj"))
    V, T, _ = sample_mesh(name, 60)
    return V, T


CASES = [
    ("saddle", 2.0),
    ("dome", 2.0),
    ("inspired", 2.0),
    ("wave", 2.0),  # mixed curvature: flat-point umbilics, closed curvature lines around them
    ("canopy", 2.0),  # strongly free-form, mixed curvature, lobed boundary
]


def _dihedral_angles(V, F):
    """Angle between the planes of the two faces of every edge (edge_topology order; 0 on the boundary)."""
    topo = edge_topology(F)
    N, _ = face_planes(V, F)
    out = np.zeros(len(topo.E))
    two = topo.count == 2
    cos = np.einsum("ij,ij->i", N[topo.EF[two, 0]], N[topo.EF[two, 1]])
    out[two] = np.arccos(np.clip(cos, -1.0, 1.0))
    return out


def _regular(F, n):
    """Vertices where the conical criterion makes the face offset exact: four faces or fewer inside, three or fewer
    on the boundary."""
    faces_at = np.bincount(face_corners(F).v, minlength=n)
    return np.where(boundary_vertex_mask(F, n), faces_at <= 3, faces_at <= 4)


@pytest.mark.parametrize("name,h", CASES)
def test_end_to_end(name, h):
    V, T = _surface(name)
    d = 0.1 * h
    res = curvature_pipeline((V, T), h, offset=d, tracer=TRACER)
    Vc, Fc = res.candidate
    validate_mesh(Vc, Fc)  # manifold, oriented
    assert res.quad_fraction >= 0.75  # boundary cells and holes of the network are panelled too
    assert res.mean_angle_error < 10.0
    # conical optimization, healthy panels covering the surface
    assert res.max_planarity <= 1e-4
    assert res.max_criterion < 1e-4
    assert res.relative_closeness <= 0.02
    assert res.healthy and res.violations == []
    assert_conical_claim(res)
    assert res.coverage >= 0.85
    # face offset at d: the planes of every face with regular corners at d ± 1e-6 d, consecutive node axes there
    # coplanar; at the few vertices with five or more faces (four on the boundary) the criterion does not apply
    Vo, Fo = res.optimized
    off = face_offset(Vo, Fo, d)
    regular = _regular(Fo, len(Vo))
    C = face_corners(Fo)
    irregular_face = np.zeros(len(Fo), bool)
    irregular_face[C.face[~regular[C.v]]] = True
    assert off.face_error[~irregular_face].max() <= 1e-6 * d
    assert (~regular[np.unique(Fo)]).mean() < 0.15
    if res.max_offset_error > 1e-6 * d:
        assert any(w.startswith("face offset") for w in res.warnings)
    interior = ~boundary_vertex_mask(Fo, len(Vo))[off.E].any(axis=1) & regular[off.E].all(axis=1)
    # Where the two faces of an edge are almost coplanar (the wave's flat points: dihedral angles down to 2e-4 rad)
    # the offset vertices are fixed only to about planarity x edge / dihedral along the nearly parallel planes, so
    # the axes' triple product there is ~1e-9 / dihedral for the polished planarity 1e-10 (up to 3e-6 on the wave
    # with exact offsets). Elsewhere consecutive node axes are coplanar to 1e-6.
    cop = off.axis_coplanarity[interior]
    near_irregular = (~regular)[off.E[interior]].any(axis=1)
    assert np.all((cop <= 1e-6 + 1e-8 / np.maximum(_dihedral_angles(Vo, Fo)[interior], 1e-300)) | near_irregular)
    assert res.node_axes.shape == (len(Vo), 2, 3)


def test_trim_keeps_the_quads_and_exact_offsets():
    # boundary_cells="trim": nearly all quads, every vertex regular, the offset exact; the health verdict says what
    # the trimmed boundary costs
    V, T = _surface("saddle")
    d = 0.2
    res = curvature_pipeline((V, T), 2.0, offset=d, tracer=TRACER, boundary_cells="trim")
    assert res.quad_fraction >= 0.9
    assert res.max_planarity <= 1e-4 and res.max_criterion < 1e-4
    assert res.max_offset_error <= 1e-6 * d
    assert_conical_claim(res)
    if not res.healthy:
        assert res.violations and any(w.startswith("panels not healthy") for w in res.warnings)


def test_no_optimization_and_zero_offset():
    V, T = _surface("saddle")
    res = curvature_pipeline((V, T), 2.5, optimize=False, tracer=TRACER)
    assert res.optimized[0] is res.candidate[0]
    assert res.offset_mesh[0] is res.optimized[0] and res.max_offset_error == 0.0
    assert res.candidate_max_planarity == res.max_planarity


def test_bad_inputs():
    V, T = _surface("saddle")
    with pytest.raises(InputError, match="panel_size"):
        pq_from_curvature_network((V, T), panel_size=-2.0)
    with pytest.raises(InputError, match="offset"):
        pq_from_curvature_network((V, T), panel_size=2.0, offset=float("nan"))
    with pytest.raises(InputError, match="boundary_cells"):
        pq_from_curvature_network((V, T), panel_size=2.0, boundary_cells="round")
    Vo = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    To = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    with pytest.raises(MeshError, match="no boundary"):
        pq_from_curvature_network((Vo, To), panel_size=0.5)


def test_a_non_disk_gets_the_fields_candidate_or_is_refused_when_trimmed():
    # an annulus of a cone (anisotropic everywhere): the rebuild's plane map needs a disk
    ang, rad = np.meshgrid(np.linspace(0, 2 * np.pi, 33)[:-1], np.linspace(1, 2, 6), indexing="ij")
    V = np.stack([rad * np.cos(ang), rad * np.sin(ang), 0.5 * rad], -1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(32, 6)
    Q = np.array([[idx[i, j], idx[(i + 1) % 32, j], idx[(i + 1) % 32, j + 1], idx[i, j + 1]]
                  for i in range(32) for j in range(5)])
    res = curvature_pipeline((V, Q), 0.3, tracer=trace_evenly)
    assert any(w.startswith("not a topological disk (2 boundary loops") and "fell back" in w for w in res.warnings)
    assert res.healthy == (res.violations == [])
    with pytest.raises(MeshError, match="disk"):
        curvature_pipeline((V, Q), 0.3, tracer=trace_evenly, boundary_cells="trim")


@pytest.mark.parametrize("scale", [1.0, 1000.0])
def test_a_panel_size_that_does_not_fit_is_refused_by_name_in_the_units_given(scale):
    V, Q = quad_grid(6, 6, 3.0, 3.0, height=lambda x, y: 0.2 * x * y)
    mesh = (V * scale, Q)
    across = np.linalg.norm(V.max(axis=0) - V.min(axis=0)) * scale
    with pytest.raises(InputError, match=rf"^panel_size: {50 * scale:g} is larger than the surface \({across:g} across"):
        curvature_pipeline(mesh, 50.0 * scale)
    with pytest.raises(InputError, match=rf"^panel_size: {1e-4 * scale:g} would give about 1e\+09 quads \(limit 2e6\); use at least "
                                        rf"{0.00224 * scale:.3g}$"):
        curvature_pipeline(mesh, 1e-4 * scale)
    with pytest.raises(InputError, match=r"^panel_size: .* would give about"):
        curvature_network(mesh, 1e-4 * scale)
    with pytest.raises(InputError, match=r"^panel_size: .* is larger than the surface"):
        quad_rebuild(mesh, 50.0 * scale)
