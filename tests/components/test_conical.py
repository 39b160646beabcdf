"""Conical meshes: angle criterion, node axes, face and vertex offsets, the published components."""
from __future__ import annotations

import numpy as np
import pytest

from components.conical.cones import (
    analysis,
    conical_check,
    conical_criterion,
    cone_fit,
    face_offset,
    face_planes,
    node_axes,
    offset,
    vertex_offset,
)
from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_vertex_mask, quad_grid, read_mesh
from tests.conftest import data_file


def revolution_net(nz=8, nt=10, closed=False, sweep=0.8 * np.pi):
    """Meridians × parallels of the surface of revolution r(z) = 1 + 0.1 z + 0.3 z²: an exactly planar conical net."""
    z = np.linspace(-1, 1, nz + 1)
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False) if closed else np.linspace(0, sweep, nt + 1)
    Z, Th = np.meshgrid(z, th, indexing="ij")
    R = 1 + 0.1 * Z + 0.3 * Z**2
    V = np.stack([R * np.cos(Th), R * np.sin(Th), Z], -1).reshape(-1, 3)
    m = len(th)
    idx = np.arange(len(V)).reshape(nz + 1, m)
    F = [[idx[i, j], idx[i, (j + 1) % m], idx[i + 1, (j + 1) % m], idx[i + 1, j]]
         for i in range(nz) for j in range(m if closed else m - 1)]
    return validate_mesh(V, np.asarray(F))


def translation_net(n=8):
    """A translation surface z = 0.4 x² − 0.3 y³ + 0.2 x on a grid: planar quads, but not conical."""
    V, Q = quad_grid(n, n, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = 0.4 * V[:, 0] ** 2 - 0.3 * V[:, 1] ** 3 + 0.2 * V[:, 0]
    return V, Q


def _warping(V, F):
    N, c = face_planes(V, F)
    return np.abs(np.einsum("fkj,fj->fk", V[F], N) - c[:, None]).max(axis=1)


# ---------------------------------------------------------------------------------------------- criterion


def test_criterion_vanishes_on_principal_nets(sphere_cap):
    for V, F in (revolution_net(), revolution_net(closed=True), sphere_cap):
        verts, crit = conical_criterion(V, F)
        assert len(verts) > 0 and np.abs(crit).max() <= 1e-12
        chk = conical_check(V, F)
        assert chk.passed.all() and chk.max_criterion <= 1e-12
        assert np.nanmax(chk.deviation) <= 1e-12  # the face normals lie on a circle of the Gauss sphere


def test_criterion_detects_non_conical_pq_mesh():
    V, F = translation_net()
    assert _warping(V, F).max() <= 1e-12  # a PQ mesh ...
    chk = conical_check(V, F, tol=1e-4)
    assert chk.max_criterion > 1e-2 and not chk.passed.all()  # ... that is not conical
    assert np.isnan(chk.criterion[~chk.checked]).all() and chk.checked.sum() == 7 * 7


def test_node_axes_of_a_surface_of_revolution_meet_the_rotation_axis():
    V, F = revolution_net(closed=True)
    A = node_axes(V, F)
    assert np.allclose(np.linalg.norm(A, axis=1), 1.0)
    # each axis lies in the meridian plane of its vertex: (V × A) · z-axis component... the axis line meets z
    radial = V * [1, 1, 0]
    tangential = np.cross([0, 0, 1.0], radial)
    assert np.abs(np.einsum("ij,ij->i", A, tangential)).max() <= 1e-12
    # oriented like the face normals (outward here, the faces are counter-clockwise seen from outside)
    assert (np.einsum("ij,ij->i", A, radial) > 0).all()


def test_conical1_passes_as_is():
    V, F = read_mesh(data_file("obj_pq__conical1.obj"))
    chk = conical_check(V, F, tol=1e-3)
    # measured: max |ω1 − ω2 + ω3 − ω4| = 7.5e-4 rad (0.043°, next to the boundary), median 2.1e-5 rad, over
    # 1,015 interior valence-4 vertices; the mesh is planar only to 4e-5, which bounds what the criterion can show
    assert chk.checked.sum() == 1015
    assert chk.passed.all() and chk.max_criterion < 1e-3
    assert np.nanmedian(chk.criterion) < 5e-5
    assert chk.deviation.max() < 1e-4  # face normals on a circle to 3.8e-5 rad
    res = analysis((V, F), tolerance=1e-3)
    assert res.is_conical and len(res.failed) == 0 and res.max_planarity < 1e-4
    # a planarized but non-conical PQ mesh of the same collection fails by orders of magnitude
    V2, F2 = read_mesh(data_file("obj_pq__planarizednormalized_six_quad.obj"))
    assert conical_check(V2, F2).max_criterion > 0.1


# ---------------------------------------------------------------------------------------------- offsets


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("d", [0.05, -0.2])
def test_face_offset_of_an_exact_conical_mesh(closed, d):
    V, F = revolution_net(closed=closed)
    off = face_offset(V, F, d)
    # every offset face plane at distance d from the original: all corners, to 1e-6·d (measured ~1e-15)
    assert off.face_error.max() <= 1e-6 * abs(d)
    assert off.face_error.max() <= 1e-13
    assert off.vertex_residual.max() <= 1e-13
    # the offset is a PQ mesh, conical again, with parallel faces
    assert _warping(off.V, F).max() <= 1e-13
    assert conical_check(off.V, F).max_criterion <= 1e-12
    N0, N1 = face_planes(V, F)[0], face_planes(off.V, F)[0]
    assert np.abs(N0 - N1).max() <= 1e-12
    # consecutive node axes are coplanar, including boundary and corner vertices
    assert off.axis_coplanarity.max() <= 1e-9
    a0, a1 = off.axes[off.E[:, 0]], off.axes[off.E[:, 1]]
    vol = np.abs(np.einsum("ij,ij->i", a1[:, 0] - a0[:, 0], np.cross(a0[:, 1] - a0[:, 0], a1[:, 1] - a1[:, 0])))
    assert vol.max() <= 1e-9 * abs(d)  # the triple product itself, in model units³
    # the offset vertex lies on the node axis at v + d / cos θ
    fit = cone_fit(V, F)
    inner = ~boundary_vertex_mask(F, len(V))
    expect = V + (d / np.cos(fit.half_angle))[:, None] * fit.axis
    assert np.abs(off.V[inner] - expect[inner]).max() <= 1e-12


def test_face_offset_of_a_flat_grid_is_a_translation(planar_grid):
    V, F = planar_grid
    off = face_offset(V, F, 0.3)
    assert np.abs(off.V - (V + [0, 0, 0.3])).max() <= 1e-14


def test_face_offset_of_a_non_conical_mesh_has_residuals():
    V, F = translation_net()
    off = face_offset(V, F, 0.1)
    assert off.vertex_residual.max() > 1e-4
    assert offset((V, F), distance=0.1).warnings  # says the mesh is not conical


def test_vertex_offset_does_not_keep_face_distances():
    V, F = revolution_net()
    d = 0.1
    vo = vertex_offset(V, F, d)
    assert np.allclose(np.linalg.norm(vo.V - V, axis=1), d)  # vertices moved by exactly d ...
    assert vo.face_error.max() > 1e-3 * d  # ... but the face planes are not at distance d
    assert face_offset(V, F, d).face_error.max() <= 1e-6 * d


def test_conical1_face_offset_bound():
    V, F = read_mesh(data_file("obj_pq__conical1.obj"))
    warp = _warping(V, F).max()  # 2.1e-5 model units (edges ≈ 0.95): the input is planar only to 4e-5
    for d in (0.1, 1.0):
        off = face_offset(V, F, d)
        # what holds: |distance − d| ≤ the input's own warping (measured 1.7e-5 for d = 0.1 and 1), not 1e-6·d
        assert off.face_error.max() <= warp
        # the offset faces' least-squares planes are parallel to the originals within 1e-4 rad
        N0, N1 = face_planes(V, F)[0], face_planes(off.V, F)[0]
        assert np.arccos(np.clip(np.einsum("ij,ij->i", N0, N1), -1, 1)).max() < 1e-4
    # node axes nearly coplanar (median 5e-6, worst 6e-3 at d = 1, scale-free)
    assert np.median(off.axis_coplanarity) < 1e-4


def test_offset_bad_inputs(planar_grid):
    V, F = planar_grid
    with pytest.raises(InputError, match="distance"):
        face_offset(V, F, float("nan"))
    with pytest.raises(InputError, match="distance"):
        offset(planar_grid, distance=0.0)
    with pytest.raises(InputError, match="method"):
        offset(planar_grid, method="normal")
    with pytest.raises(MeshError, match="mesh"):
        offset((V, F[:, ::-1][:3].tolist() + F[3:].tolist()))  # inconsistent orientation
    with pytest.raises(InputError, match="tolerance"):
        analysis(planar_grid, tolerance=-1.0)


# ---------------------------------------------------------------------------------------------- components


def test_analysis_component():
    V, F = revolution_net()
    res = analysis((V, F))
    assert res._fields == ("criterion", "checked", "failed", "max_criterion", "mean_criterion", "cone_deviation",
                           "max_cone_deviation", "node_axes", "max_planarity", "is_conical", "warnings")
    assert res.is_conical and not res.warnings and len(res.failed) == 0
    assert res.criterion.shape == (len(V),) and res.node_axes.shape == (len(V), 2, 3)
    assert len(res.checked) == 7 * 9
    bad = analysis(translation_net())
    assert not bad.is_conical and len(bad.failed) > 0


def test_analysis_warns_on_non_planar(hypar_grid):
    res = analysis(hypar_grid)
    assert not res.is_conical and any("not planar" in w for w in res.warnings)


def test_offset_mesh_component():
    V, F = revolution_net()
    res = offset((V, F), distance=0.2)
    assert res._fields == ("offset", "node_axes", "face_error", "max_face_error", "vertex_residual",
                           "max_axis_coplanarity", "warnings")
    assert res.max_face_error <= 1e-13 and res.max_axis_coplanarity <= 1e-9 and not res.warnings
    W, G = res.offset
    assert W.shape == V.shape and np.array_equal(G, F)
    vres = offset((V, F), distance=0.2, method="vertex")
    assert vres.max_face_error > 1e-4
    # beyond the radius of curvature faces flip: said in a warning
    far = offset((V, F), distance=-3.0)
    assert any("flipped" in w for w in far.warnings)


def test_triangle_mesh_is_not_reported_conical():
    V, F = read_mesh(data_file("geometrylab_test_tri_dome.obj"))
    res = analysis((V, F))
    # valence-6 stars of triangles: their six normals do not lie on a common cone
    assert not res.is_conical and len(res.checked) > 0 and len(res.failed) > 0
    off = offset((V, F), distance=0.05)
    assert any("do not meet in one point" in w for w in off.warnings)


def test_face_offset_far_from_the_origin():
    # the same exact conical net placed at 5e6 and in millimetres: the offset is as exact (solved about the centre)
    V, F = revolution_net()
    d = 0.2
    for scale, shift in ((1.0, 5e6), (1000.0, 0.0)):
        off = face_offset(V * scale + shift, F, d * scale)
        assert off.face_error.max() <= 1e-6 * d * scale
        assert off.vertex_residual.max() <= 1e-6 * d * scale
