"""Quad extraction from a seamless parametrization: exact grids, on-surface vertices, orientation, topology."""
from __future__ import annotations

import numpy as np
import pytest

from components.fields.candidate import extract_quads
from components.fields.extract import iso_segments, quad_mesh_from_parametrization, snap_boundary
from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import edge_topology, face_normals, face_sizes
from components.fields.parametrize import direction_field, seamless_parametrization
from components.surfaces.samples import sample_mesh
from tests.components.test_parametrize import annulus, constant_field, plane


def euler(V, F):
    return len(np.unique(F)) - len(edge_topology(F).E) + len(F)


def on_input_triangles(ex, V, T):
    """Every candidate vertex is its barycentric point of an input triangle."""
    P = np.einsum("pk,pkd->pd", ex.bary, V[T[ex.tri]])
    return np.abs(P - ex.V).max(), ex.bary.min()


def oriented_like(Vc, F, V, T, ex_tri):
    """Candidate face normals agree with the input normals under their corners."""
    N = face_normals(Vc, F)
    NT = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    NT /= np.linalg.norm(NT, axis=1, keepdims=True)
    ref = NT[ex_tri[F[:, 0]]]
    return np.einsum("ij,ij->i", N, ref)


def test_plane_constant_field_gives_the_exact_grid():
    V, T = plane(n=10, size=6.0, jitter=0.3)
    U, W = constant_field(T, [1, 0, 0], [0, 1, 0])
    h = 0.5
    par = seamless_parametrization(V, T, U, W, target_length=h)
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=h)
    s = face_sizes(ex.F)
    assert len(ex.F) == 144 and np.all(s == 4)
    # vertices on the h-lattice
    assert np.allclose(ex.V[:, :2] / h, np.round(ex.V[:, :2] / h), atol=1e-6)
    assert len(ex.V) == 13 * 13
    validate_mesh(ex.V, ex.F)
    assert euler(ex.V, ex.F) == 1
    assert oriented_like(ex.V, ex.F, V, T, ex.tri).min() > 0.999


def test_rotated_field_with_free_boundary_clips_cells_at_the_boundary():
    V, T = plane(n=10, size=6.0)
    a = np.radians(25)
    U, W = constant_field(T, [np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0])
    h = 0.6
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=h, merge=0.0)
    validate_mesh(ex.V, ex.F)
    # the cells tile the square exactly
    area = np.linalg.norm(face_normals(ex.V, ex.F, unit=False), axis=1).sum()
    assert area == pytest.approx(36.0, rel=1e-9)
    # interior cells are rotated squares of side h
    s = face_sizes(ex.F)
    full = np.isclose(np.linalg.norm(face_normals(ex.V, ex.F, unit=False), axis=1), h * h)
    assert full.sum() > 60 and np.all(s[full] == 4)
    assert euler(ex.V, ex.F) == 1
    err, bmin = on_input_triangles(ex, V, T)
    assert err < 1e-12 and bmin > -1e-9


@pytest.mark.parametrize("angle", [8, 25, 40])
def test_snapped_free_boundary_gives_whole_quads(angle):
    V, T = plane(n=12, size=6.0)
    a = np.radians(angle)
    U, W = constant_field(T, [np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0])
    h = 0.6
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=h)
    Vs, Fs, tri, bary, grid = snap_boundary(V, T, ex.V, ex.F, ex.tri, ex.bary, ex.grid, h)
    validate_mesh(Vs, Fs)
    assert euler(Vs, Fs) == 1
    assert oriented_like(Vs, Fs, V, T, tri).min() > 0
    # still a tiling of the square (vertices on the boundary stay on it), with more quads than the clipped mesh
    area = np.linalg.norm(face_normals(Vs, Fs, unit=False), axis=1).sum()
    assert area == pytest.approx(36.0, rel=1e-2)
    assert np.mean(face_sizes(Fs) == 4) > np.mean(face_sizes(ex.F) == 4)
    assert np.mean(face_sizes(Fs) == 4) >= 0.7  # a small square: 45°-ish staircases keep corner triangles
    # no short edges left: boundary hits closer than h/2 to a grid vertex were absorbed
    E = edge_topology(Fs).E
    L = np.linalg.norm(Vs[E[:, 1]] - Vs[E[:, 0]], axis=1)
    assert np.mean(np.abs(L / h - 1) <= 0.3) >= 0.85 and L.min() > 0.2 * h
    P = np.einsum("pk,pkd->pd", bary, V[T[tri]])
    assert np.abs(P - Vs).max() < 1e-9 and np.all(np.abs(Vs[:, 2]) < 1e-12)


def test_annulus_keeps_its_topology_and_quads():
    V, T, U, W = annulus()
    par = seamless_parametrization(V, T, U, W, target_length=0.5)
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=0.5)
    validate_mesh(ex.V, ex.F)
    assert euler(ex.V, ex.F) == 0
    assert np.all(face_sizes(ex.F) == 4)
    assert oriented_like(ex.V, ex.F, V, T, ex.tri).min() > 0.9
    err, _ = on_input_triangles(ex, V, T)
    assert err < 1e-12


@pytest.mark.parametrize("name", ["dome", "canopy"])
def test_sample_surfaces_with_singularities(name):
    V, T, _ = sample_mesh(name, 24)
    U, W = direction_field(V, T, field="smooth", alignment=0.1)
    h = 2.0
    par = seamless_parametrization(V, T, U, W, target_length=h)
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=h)
    validate_mesh(ex.V, ex.F)  # manifold, consistently oriented, no degenerate faces
    assert euler(ex.V, ex.F) == 1
    s = face_sizes(ex.F)
    assert np.mean(s == 4) >= 0.95
    assert oriented_like(ex.V, ex.F, V, T, ex.tri).min() > 0  # no flipped face
    err, _ = on_input_triangles(ex, V, T)
    assert err < 1e-9


def test_iso_segments_lie_on_integer_lines():
    V, T = plane(n=6, size=3.0)
    U, W = constant_field(T, [1, 0, 0], [0, 1, 0])
    par = seamless_parametrization(V, T, U, W, target_length=0.5)
    S = iso_segments(V, T, par.UV)
    assert S.shape[1:] == (2, 3) and len(S) > 0
    # each segment is on x = i h or y = j h
    on_x = np.all(np.isclose(S[:, :, 0] / 0.5, np.round(S[:, :, 0] / 0.5)), axis=1)
    on_y = np.all(np.isclose(S[:, :, 1] / 0.5, np.round(S[:, :, 1] / 0.5)), axis=1)
    assert np.all(on_x | on_y)


def test_extract_quads_component():
    V, T, _ = sample_mesh("wave", 24)
    res = extract_quads((V, T), target_length=2.0, field="smooth")
    Vc, Fc = res.mesh
    assert res.quads + res.other_faces == len(Fc)
    assert res.quad_ratio >= 0.95
    assert res.singularities >= 0 and res.mean_angle_error < 10


def test_extract_quads_errors(nonmanifold_fan):
    V, T, _ = sample_mesh("dome", 8)
    with pytest.raises(InputError, match="target_length"):
        extract_quads((V, T), target_length=0.0)
    with pytest.raises(MeshError, match="mesh"):
        extract_quads(nonmanifold_fan, target_length=0.1)


@pytest.mark.parametrize("angle", [25, 40, 45])
def test_snap_merges_boundary_triangles(angle):
    V, T = plane(n=12, size=6.0)
    a = np.radians(angle)
    U, W = constant_field(T, [np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0])
    h = 0.6
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    ex = quad_mesh_from_parametrization(V, T, par.UV, target_length=h)
    Vk, Fk, *_ = snap_boundary(V, T, ex.V, ex.F, ex.tri, ex.bary, ex.grid, h, merge_triangles=False)
    Vs, Fs, tri, bary, grid = snap_boundary(V, T, ex.V, ex.F, ex.tri, ex.bary, ex.grid, h)
    validate_mesh(Vs, Fs)
    assert euler(Vs, Fs) == 1
    assert oriented_like(Vs, Fs, V, T, tri).min() > 0
    # fewer triangles, no fewer quads, same tiling of the square, every vertex still on the plane
    assert np.sum(face_sizes(Fs) == 3) < np.sum(face_sizes(Fk) == 3)
    assert np.mean(face_sizes(Fs) == 4) >= np.mean(face_sizes(Fk) == 4)
    area = np.linalg.norm(face_normals(Vs, Fs, unit=False), axis=1).sum()
    assert area == pytest.approx(36.0, rel=1e-2)
    P = np.einsum("pk,pkd->pd", bary, V[T[tri]])
    assert np.abs(P - Vs).max() < 1e-9


def test_split_large_faces_cuts_quads_and_keeps_orientation():
    from components.fields.extract import split_large_faces
    from components.core.mesh import pad_faces

    t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    oct_ = np.stack([np.cos(t), np.sin(t), np.zeros(8)], axis=1)
    pent = np.stack([np.cos(t[:5] * 8 / 5) + 5, np.sin(t[:5] * 8 / 5), np.zeros(5)], axis=1)
    V = np.concatenate([oct_, pent])
    F = pad_faces([list(range(8)), list(range(8, 13))])
    G = split_large_faces(V, F)
    s = face_sizes(G)
    assert sorted(s.tolist()) == [4, 4, 4, 5]
    assert np.all(face_normals(V, G)[:, 2] > 0)  # counter-clockwise like the input
    # the octagon's outline is kept: its 8 edges are boundary edges of the pieces, the cuts are interior
    topo = edge_topology(G)
    bnd = {tuple(sorted(e)) for e in topo.E[topo.count == 1].tolist()}
    assert {tuple(sorted((i, (i + 1) % 8))) for i in range(8)} <= bnd
    assert np.count_nonzero(topo.count == 2) == 2
    # a mesh without large faces comes back unchanged
    assert np.array_equal(split_large_faces(V, F[1:]), F[1:])


def _grid_quads(k):
    x, y = np.meshgrid(np.arange(k + 1.0), np.arange(k + 1.0))
    V = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    F = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], axis=1)
    return V, F


def _collapse(V, F, h=1.0):
    from components.fields.extract import collapse_short_edges

    n = len(V)
    return collapse_short_edges(V, F, np.arange(n), np.zeros((n, 3)), np.ones(n, dtype=bool), h)


def test_collapse_short_edges_interior_edge():
    V, F = _grid_quads(4)
    V[12] = V[13] + [-0.1, 0.0, 0.0]  # centre vertex 0.1 from its right neighbour
    V2, F2, tri, bary, grid = _collapse(V, F)
    validate_mesh(V2, F2)
    assert len(V2) == len(V) - 1 and len(tri) == len(bary) == len(grid) == len(V2)
    s = face_sizes(F2)
    assert np.count_nonzero(s == 3) == 2 and np.count_nonzero(s == 4) == 14  # the two quads on the edge
    E = edge_topology(F2).E
    assert np.linalg.norm(V2[E[:, 1]] - V2[E[:, 0]], axis=1).min() > 0.25
    assert np.all(face_normals(V2, F2)[:, 2] > 0)
    # nothing short: unchanged
    V3, F3, *_ = _collapse(*_grid_quads(3))
    assert len(V3) == 16 and np.array_equal(F3, _grid_quads(3)[1])


def test_collapse_short_edges_boundary_corner_of_a_face():
    # a pentagon whose extra corner sits 0.05 beside a boundary vertex on the straight top boundary (the
    # inspired_mesh case that blocked the planarization): the corner goes, the pentagon becomes a quad
    from components.core.mesh import pad_faces

    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [1.05, 1, 0], [2, 1, 0]], dtype=float)
    F = pad_faces([[0, 1, 4, 3], [1, 2, 6, 5, 4]])
    V2, F2, *_ = _collapse(V, F)
    validate_mesh(V2, F2)
    assert len(V2) == 6 and sorted(face_sizes(F2).tolist()) == [4, 4]
    # a short edge across the inside between two boundary vertices would pinch the mesh: kept
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 0.1, 0], [2, 1, 0]], dtype=float)
    F = np.array([[0, 1, 4, 3], [1, 2, 5, 4]])
    V2, F2, *_ = _collapse(V, F)
    assert len(V2) == 6 and np.array_equal(F2, F)


def test_relax_edge_lengths_evens_a_compressed_column_on_the_surface():
    from components.fields.extract import relax_edge_lengths
    from components.core.mesh import boundary_loops

    V, T = plane(24, 4.0)  # the input surface: a triangulated square [0, 4]², z = 0
    Vc, Fc = _grid_quads(4)
    Vc[:, 0] = np.array([0.0, 0.45, 2.0, 3.0, 4.0])[np.round(Vc[:, 0]).astype(int)]  # columns 0.45 and 1.55 wide
    from components.core.proximity import TriangleIndex

    cp = TriangleIndex(V, T).query(Vc)
    tri, bary = cp.faces, cp.barycentric
    X, tri2, bary2 = relax_edge_lengths(V, T, Vc, Fc, tri, bary, 1.0)
    E = edge_topology(Fc).E
    L = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    L0 = np.linalg.norm(Vc[E[:, 1]] - Vc[E[:, 0]], axis=1)
    assert np.mean(np.abs(L0 - 1) <= 0.3) < 0.8 and np.all(np.abs(L - 1) <= 0.3)
    assert np.allclose(X[:, 2], 0.0)  # on the surface
    # boundary vertices stay on the square's outline, its corners do not move
    lp = boundary_loops(Fc)[0]
    on_edge = np.isclose(X[lp, 0], 0) | np.isclose(X[lp, 0], 4) | np.isclose(X[lp, 1], 0) | np.isclose(X[lp, 1], 4)
    assert on_edge.all()
    for c in ([0, 0], [4, 0], [0, 4], [4, 4]):
        assert np.any(np.all(np.isclose(X[:, :2], c), axis=1))
    assert np.all(face_normals(X, Fc)[:, 2] > 0)
    # the reported surface locations reproduce the points
    np.testing.assert_allclose(np.einsum("pk,pkd->pd", bary2, V[T[tri2]]), X, atol=1e-9)
    # already even: unchanged
    Xe, *_ = relax_edge_lengths(V, T, *_grid_quads(4), tri, bary, 1.0)
    np.testing.assert_array_equal(Xe, _grid_quads(4)[0])


def test_collapse_short_edges_degenerate_corners():
    from components.core.mesh import pad_faces

    # a straight corner (180°) of valence 2 on the boundary: a T-vertex in a pentagon; its shorter edge (0.3,
    # above the short-edge ratio) goes and the pentagon becomes a quad
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [0.7, 1, 0], [1, 1, 0], [2, 1, 0]], dtype=float)
    F = pad_faces([[0, 1, 5, 4, 3], [1, 2, 6, 5]])
    V2, F2, *_ = _collapse(V, F)
    validate_mesh(V2, F2)
    assert len(V2) == 6 and sorted(face_sizes(F2).tolist()) == [4, 4]
    # a sliver with every corner on the boundary (a 2.3° corner) disappears, the quad beside it stays
    V = np.array([[0, 0, 0], [1, 0, 0], [1.02, 0.5, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    F = pad_faces([[0, 1, 4, 3], [1, 2, 4]])
    V2, F2, *_ = _collapse(V, F)
    validate_mesh(V2, F2)
    assert face_sizes(F2).tolist() == [4] and np.allclose(np.sort(V2[:, 0]), [0, 0, 1, 1])
    # the same sliver removed directly (where no collapse applies, e.g. all its corners are outline corners)
    from components.fields.extract import _drop_boundary_slivers

    n = len(V)
    _, F3, *_ = _drop_boundary_slivers(V, F, np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.ones(n, dtype=bool))
    assert face_sizes(F3).tolist() == [4]
    # a bow-tie folded by the snapping on the boundary goes as well
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 1, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0]], dtype=float)
    F = np.array([[0, 1, 4, 3], [1, 2, 5, 4]])
    n = len(V)
    _, F4, *_ = _drop_boundary_slivers(V, F, np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.ones(n, dtype=bool))
    assert face_sizes(F4).tolist() == [4]
    # a small face wholly on the boundary (area below 0.3 h², no degenerate corner) is a sliver too
    V = np.array([[0, 0, 0], [1, 0, 0], [1.2, 0.5, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    F = pad_faces([[0, 1, 4, 3], [1, 2, 4]])  # the triangle: area 0.1
    n = len(V)
    args = (np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.ones(n, dtype=bool))
    assert face_sizes(_drop_boundary_slivers(V, F, *args)[1]).tolist() == [4, 3]  # no h: only degenerate ones
    assert face_sizes(_drop_boundary_slivers(V, F, *args, h=1.0)[1]).tolist() == [4]
