"""Pull to surface: every vertex on the reference, boundary on its boundary, idempotent, typed errors."""
from __future__ import annotations

import igl
import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, bounding_box_diagonal, quad_grid, read_mesh, triangulate
from components.subdivision.pull import pull_to_surface, pulled_vertices, reference_boundary
from components.subdivision.subdivide import subdivided_mesh
from tests.conftest import data_file


def _hypar_reference(n=40):
    """Fine triangulated hyperbolic paraboloid z = x y / 2 over [-1, 1]²."""
    V, Q = quad_grid(n, n, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = 0.5 * V[:, 0] * V[:, 1]
    return V, triangulate(Q)[0]


def _coarse_over_hypar(levels=2):
    """A coarse 3 × 3 net over the hypar, lifted off it, subdivided."""
    V, Q = quad_grid(3, 3, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = 0.5 * V[:, 0] * V[:, 1] + 0.05
    V1, Q1, _ = subdivided_mesh(V, Q, levels=levels)
    return V1, Q1


def _distance_to_segments(P, A, B):
    """Brute-force distance of every point to a set of segments (independent of components.core.proximity)."""
    AB = B - A
    t = np.einsum("pij,ij->pi", P[:, None, :] - A[None], AB) / np.einsum("ij,ij->i", AB, AB)
    t = np.clip(t, 0, 1)
    X = A[None] + t[..., None] * AB[None]
    return np.linalg.norm(P[:, None, :] - X, axis=2).min(axis=1)


def _boundary_distance(P, V_ref, T_ref):
    A, B = [], []
    for loop in boundary_loops(T_ref):
        A.append(V_ref[loop])
        B.append(V_ref[np.roll(loop, -1)])
    return _distance_to_segments(P, np.concatenate(A), np.concatenate(B))


def test_every_vertex_lands_on_surface_and_boundary_on_boundary():
    Vr, Tr = _hypar_reference()
    V, Q = _coarse_over_hypar()
    res = pulled_vertices(V, Q, Vr, Tr)
    diag = bounding_box_diagonal(Vr)
    # independent check with libigl's AABB distance
    sq, _, _ = igl.point_mesh_squared_distance(res.V, Vr, Tr)
    assert np.sqrt(sq).max() <= 1e-9 * diag
    assert res.distances_after.max() <= 1e-9 * diag
    # the boundary vertices of the pulled mesh are the mesh's boundary loop, and they sit on the reference boundary
    assert sorted(res.boundary_vertices.tolist()) == sorted(boundary_loops(Q)[0].tolist())
    assert _boundary_distance(res.V[res.boundary_vertices], Vr, Tr).max() <= 1e-9 * diag
    # interior: the move is the distance to the surface (the closest point, checked against libigl)
    inner = np.setdiff1d(np.arange(len(V)), res.boundary_vertices)
    sq0, _, _ = igl.point_mesh_squared_distance(V[inner], Vr, Tr)
    np.testing.assert_allclose(res.distances_before[inner], np.sqrt(sq0), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(res.V - V, axis=1), res.distances_before, atol=1e-12)
    assert len(res.flipped_faces) == 0 and res.warnings == []


def test_pull_is_idempotent():
    Vr, Tr = _hypar_reference()
    V, Q = _coarse_over_hypar()
    once = pulled_vertices(V, Q, Vr, Tr)
    twice = pulled_vertices(once.V, Q, Vr, Tr)
    diag = bounding_box_diagonal(Vr)
    assert np.abs(twice.V - once.V).max() <= 1e-12 * diag
    assert twice.distances_before.max() <= 1e-12 * diag


def test_surface_and_fixed_modes():
    Vr, Tr = _hypar_reference()
    V, Q = _coarse_over_hypar()
    surf = pulled_vertices(V, Q, Vr, Tr, boundary="surface")
    assert len(surf.boundary_vertices) == 0
    assert surf.distances_after.max() <= 1e-9 * bounding_box_diagonal(Vr)
    fixed = pulled_vertices(V, Q, Vr, Tr, boundary="fixed")
    b = fixed.boundary_vertices
    np.testing.assert_array_equal(fixed.V[b], V[b])
    assert np.all(fixed.distances_before[b] == 0)
    assert np.all(fixed.distances_after[b] > 0.01)  # they were lifted 0.05 off the surface


def test_polygon_reference_and_closed_reference_warning():
    # a closed reference (subdivided cube, quads): boundary vertices of an open mesh go to the surface, with a warning
    Vc = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    Fc = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    Vs, Qs, _ = subdivided_mesh(Vc, Fc, levels=3)
    assert reference_boundary(Vs, Qs) == []
    V, Q = quad_grid(4, 4, 0.6, 0.6)
    V += [0.2, 0.2, 1.2]  # above the top of the blob
    res = pulled_vertices(V, Q, Vs, Qs)
    assert res.warnings and "closed" in res.warnings[0]
    T = triangulate(Qs)[0]
    sq, _, _ = igl.point_mesh_squared_distance(res.V, Vs, T)
    assert np.sqrt(sq).max() <= 1e-9 * bounding_box_diagonal(Vs)


def test_flipped_faces_are_reported():
    # outside the corner of a square, the closest-point map folds a triangle over (orientation reverses)
    Vr, Qr = quad_grid(8, 8, 2.0, 2.0)
    Tr = triangulate(Qr)[0]
    V = np.array([[1.9, 3.0, 0.0], [3.0, 1.9, 0.0], [2.2, 2.2, 0.0]])
    T = np.array([[0, 1, 2]])
    res = pulled_vertices(V, T, Vr, Tr, boundary="surface")
    np.testing.assert_allclose(res.V, [[1.9, 2, 0], [2, 1.9, 0], [2, 2, 0]], atol=1e-15)
    assert res.flipped_faces.tolist() == [0]
    assert "turned over" in res.warnings[0]


def test_real_mesh_quad_remesh_onto_inspired_mesh():
    Vr, Tr = read_mesh(data_file("inspired_mesh.obj"))
    Vq, Fq = read_mesh(data_file("inspired_mesh_quads_Conjugate.off"))
    V1, Q1, _ = subdivided_mesh(Vq, Fq, levels=1)
    res = pulled_vertices(V1, Q1, Vr, Tr)
    diag = bounding_box_diagonal(Vr)
    sq, _, _ = igl.point_mesh_squared_distance(res.V, Vr, Tr)
    assert np.sqrt(sq).max() <= 1e-9 * diag
    assert _boundary_distance(res.V[res.boundary_vertices], Vr, Tr).max() <= 1e-9 * diag
    again = pulled_vertices(res.V, Q1, Vr, Tr)
    assert np.abs(again.V - res.V).max() <= 1e-12 * diag


def _coarse_layout(surface, n=6):
    """A coarse n × n quad net over a sample's plan domain (square rings mapped to the boundary), lifted to it."""
    V, Q = quad_grid(n, n, 2.0, 2.0)
    u, v = V[:, 0] - 1, V[:, 1] - 1
    theta = np.arctan2(v, u)
    r = np.maximum(np.abs(u), np.abs(v)) * surface.boundary_radius(theta)
    return surface.point(r * np.cos(theta), r * np.sin(theta)), Q


@pytest.mark.parametrize("name", ["dome", "saddle", "wave", "canopy"])
def test_subdivided_net_pulled_onto_sample_surfaces(name):
    samples = pytest.importorskip("components.surfaces.samples")
    s = samples.sample_surface_function(name)
    Vr, Tr, _ = samples.sample_mesh(name, 24)
    V, Q, _ = subdivided_mesh(*_coarse_layout(s), levels=2)
    res = pulled_vertices(V, Q, Vr, Tr)
    diag = bounding_box_diagonal(Vr)
    assert res.distances_after.max() <= 1e-9 * diag
    sq, _, _ = igl.point_mesh_squared_distance(res.V, Vr, Tr)
    assert np.sqrt(sq).max() <= 1e-9 * diag
    assert _boundary_distance(res.V[res.boundary_vertices], Vr, Tr).max() <= 1e-9 * diag
    # the exact surface is close too (the reference mesh is a fine approximation of it)
    assert s.distance(res.V).max() < 0.01 * diag
    if name in ("dome", "saddle"):
        assert len(res.flipped_faces) == 0


# ----------------------------------------------------------------------------------------------
# published component and errors


def test_published_component():
    from ghserver.registry import declare

    comp = declare(pull_to_surface, "subdivide/pull_to_surface")
    assert [p.name for p in comp.inputs] == ["mesh", "surface", "boundary"]
    assert [p.name for p in comp.outputs] == ["mesh", "distances_before", "distances_after", "max_before",
                                              "mean_before", "max_after", "mean_after"]
    Vr, Tr = _hypar_reference()
    V, Q = _coarse_over_hypar(levels=1)
    res = pull_to_surface((V, Q), (Vr, Tr))
    Vp, Qp = res.mesh
    np.testing.assert_array_equal(Qp, Q)
    assert res.max_after <= 1e-9 * bounding_box_diagonal(Vr) and res.max_before > 0.01
    assert res.mean_before == pytest.approx(res.distances_before.mean())
    assert res.warnings == []


def test_bad_inputs(nonmanifold_fan):
    Vr, Tr = _hypar_reference(8)
    V, Q = _coarse_over_hypar(levels=1)
    with pytest.raises(InputError, match=r"^boundary: "):
        pulled_vertices(V, Q, Vr, Tr, boundary="edge")
    bad = Vr.copy()
    bad[0, 0] = np.inf
    with pytest.raises(MeshError, match=r"^surface: .*NaN or infinite"):
        pull_to_surface((V, Q), (bad, Tr))
    with pytest.raises(MeshError, match=r"^mesh: .*out of range"):
        pull_to_surface((V, Q + len(V)), (Vr, Tr))
    with pytest.raises(InputError, match=r"^surface: "):
        pull_to_surface((V, Q), Vr)
    with pytest.raises(InputError, match=r"^mesh: "):
        pull_to_surface(V, (Vr, Tr))
    # a bow-tie boundary (two loops through one vertex) is not a simple boundary
    Vb = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=float)
    Tb = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(MeshError, match=r"^surface: "):
        pulled_vertices(V, Q, Vb, Tb)


def test_pulled_subdivision_spreads_the_boundary_and_keeps_panels_open():
    # lobed canopy boundary: closest points collapse the boundary panels (0.8° corner measured), the arc-length
    # spread with the smooth interior follow-up keeps them open
    from components.subdivision.coarse import coarse_net
    from components.core.measures import corner_angles
    from components.core.proximity import PolylineIndex, TriangleIndex
    from components.subdivision.pull import pulled_subdivision
    from components.surfaces.samples import sample_mesh

    V, T, _ = sample_mesh("canopy", 20)
    net = coarse_net(V, T, faces=36, layout="ogrid")
    Vs, Qs, _ = subdivided_mesh(net.V, net.Q, levels=2)
    res = pulled_subdivision(Vs, Qs, net.V, V, T)
    diag = bounding_box_diagonal(V)
    assert TriangleIndex(V, T).query(res.V).distances.max() <= 1e-9 * diag
    bv = boundary_loops(Qs)[0]
    assert np.array_equal(np.sort(bv), res.boundary_vertices)
    assert PolylineIndex(V[boundary_loops(T)[0]], closed=True).query(res.V[bv]).distances.max() <= 1e-9 * diag
    # coarse boundary vertices stay where they were
    cb = bv[bv < len(net.V)]
    assert np.abs(res.V[cb] - net.V[cb]).max() <= 1e-9 * diag
    worst = np.degrees(corner_angles(res.V, Qs)).min()
    plain = pulled_vertices(Vs, Qs, V, T)
    assert worst > 20 and worst > np.degrees(corner_angles(plain.V, Qs)).min()
    assert len(res.flipped_faces) == 0


def test_pulled_subdivision_falls_back_without_a_boundary_order():
    V, T = _hypar_reference(10)
    Vq, Q = quad_grid(2, 2, 2.0, 2.0)
    Vq[:, :2] -= 1.0
    Vs, Qs, _ = subdivided_mesh(Vq, Q, levels=1)
    from components.subdivision.pull import pulled_subdivision

    # coarse vertices given in an unrelated place: no ordered anchors -> plain closest points
    res = pulled_subdivision(Vs, Qs, Vq[::-1] * 0.0, V, T)
    ref = pulled_vertices(Vs, Qs, V, T)
    assert np.allclose(res.V, ref.V)


def test_pulled_subdivision_does_not_squeeze_the_first_row():
    # canopy, resolution 32, 17 coarse faces: a coarse boundary vertex at the bottom of a concave dent moves back
    # onto the boundary by more than an edge; with a harmonic follow-up its inward edge shrank to 0.078 × median
    from components.subdivision.coarse import coarse_net
    from components.subdivision.pull import pulled_subdivision
    from components.surfaces.samples import sample_mesh

    V, T, _ = sample_mesh("canopy", 32)
    net = coarse_net(V, T, faces=17, layout="ogrid")
    Vs, Qs, _ = subdivided_mesh(net.V, net.Q, levels=2)
    X = pulled_subdivision(Vs, Qs, net.V, V, T).V
    E = np.unique(np.sort(np.concatenate([Qs[:, [0, 1]], Qs[:, [1, 2]], Qs[:, [2, 3]], Qs[:, [3, 0]]]), axis=1), axis=0)
    L = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    assert L.min() >= 0.2 * np.median(L)
