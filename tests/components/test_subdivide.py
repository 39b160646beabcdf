"""Catmull-Clark subdivision: exactness on grids, counts on mixed meshes, boundary curves, limit stencils."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

import components.subdivision.subdivide as subdiv
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, edge_topology, face_normals, face_sizes, pad_faces, quad_grid, read_mesh
from components.subdivision.subdivide import (
    catmull_clark,
    control_mesh,
    face_count_after,
    limit_positions,
    subdivided_mesh,
    subdivision_step,
)
from tests.conftest import data_file


def _cube():
    V = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    F = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    return V, F


def _tetrahedron():
    V = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    T = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    return V, T


def _lifted_grid(nu=4, nv=3, seed=0):
    """Integer-spaced grid with random heights: x, y stay dyadic under subdivision (exact in floating point)."""
    V, Q = quad_grid(nu, nv, float(nu), float(nv))
    V[:, 2] = 0.1 * np.random.default_rng(seed).normal(size=len(V))  # gentle: no sharp boundary turns
    return V, Q


def _refine_1d(n: int) -> np.ndarray:
    """Cubic B-spline refinement of an open control polygon of ``n + 1`` points with fixed (interpolated) ends."""
    R = np.zeros((2 * n + 1, n + 1))
    R[0, 0] = R[2 * n, n] = 1.0
    for i in range(1, n):
        R[2 * i, i - 1:i + 2] = (0.125, 0.75, 0.125)
    for i in range(n):
        R[2 * i + 1, i:i + 2] = 0.5
    return R


def _grid_values(V, nu, nv, L):
    """z of the subdivided grid arranged as (rows, cols) by the dyadic x, y of each vertex."""
    s = 2 ** L
    ix = np.rint(V[:, 0] * s).astype(int)
    iy = np.rint(V[:, 1] * s).astype(int)
    assert np.allclose(V[:, 0] * s, ix, atol=1e-9) and np.allclose(V[:, 1] * s, iy, atol=1e-9)
    Z = np.full((nv * s + 1, nu * s + 1), np.nan)
    Z[iy, ix] = V[:, 2]
    return Z


def _max_dihedral(V, Q):
    N = face_normals(V, Q)
    topo = edge_topology(Q)
    inner = topo.count == 2
    c = np.einsum("ij,ij->i", N[topo.EF[inner, 0]], N[topo.EF[inner, 1]])
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))).max())


# ----------------------------------------------------------------------------------------------
# regular grids


@pytest.mark.parametrize("levels", [1, 2, 3])
def test_planar_grid_stays_planar_and_regular(planar_grid, levels):
    V, Q = planar_grid  # 6 × 4 quads on [0, 3] × [0, 2]
    V1, Q1, info = subdivided_mesh(V, Q, levels=levels)
    s = 2 ** levels
    Vr, Qr = quad_grid(6 * s, 4 * s, 3.0, 2.0)
    assert np.all(V1[:, 2] == 0.0)
    # the same point set as the finer regular grid
    key = lambda X: X[np.lexsort((X[:, 0], X[:, 1]))]  # noqa: E731
    assert len(V1) == len(Vr) and len(Q1) == len(Qr)
    assert np.allclose(key(V1), key(Vr), atol=1e-13)
    # every quad is a square of the refined size, no irregular vertices at any level
    h = 0.5 / s
    E = edge_topology(Q1).E
    assert np.allclose(np.linalg.norm(V1[E[:, 0]] - V1[E[:, 1]], axis=1), h, atol=1e-13)
    assert all(len(lv.irregular_vertices) == 0 for lv in info.levels)
    assert np.allclose(face_normals(V1, Q1), [0, 0, 1])


@pytest.mark.parametrize("levels", [1, 2])
def test_regular_grid_is_bicubic_bspline_refinement(levels):
    nu, nv = 5, 4
    V, Q = _lifted_grid(nu, nv)
    V1, _, _ = subdivided_mesh(V, Q, levels=levels)
    Z = V[:, 2].reshape(nv + 1, nu + 1)
    for level in range(levels):
        n_u, n_v = nu * 2 ** level, nv * 2 ** level
        Z = _refine_1d(n_v) @ Z @ _refine_1d(n_u).T
    Z1 = _grid_values(V1, nu, nv, levels)
    assert not np.isnan(Z1).any()
    np.testing.assert_allclose(Z1, Z, atol=1e-13)


def _extended(P):
    """Control polygon with the phantom end points 2 P0 − P1 and 2 Pn − Pn−1 (interpolating ends)."""
    return np.concatenate([2 * P[:1] - P[1:2], P, 2 * P[-1:] - P[-2:-1]])


def _scipy_curve(P):
    C = _extended(P)
    t = np.arange(len(C) + 4, dtype=float) - 3.0
    return BSpline(t, C, 3, extrapolate=False)  # base domain [0, len(P) - 1]


def _chain(loop, a, b, corners):
    """The part of a boundary loop from vertex a to vertex b that passes no other corner."""
    loop = list(loop)
    i = loop.index(a)
    loop = loop[i:] + loop[:i]
    for seq in (loop, [loop[0]] + loop[1:][::-1]):
        j = seq.index(b)
        if not set(seq[1:j]) & set(corners):
            return np.array(seq[:j + 1])
    raise AssertionError("no corner-free chain")


@pytest.mark.parametrize("levels", [1, 2, 3])
def test_boundary_is_cubic_bspline_subdivision_of_coarse_boundary(levels):
    nu, nv = 4, 3
    V, Q = _lifted_grid(nu, nv, seed=1)
    V[:, :2] += 0.1 * np.random.default_rng(2).normal(size=(len(V), 2))  # not a tensor grid any more
    V1, Q1, info = subdivided_mesh(V, Q, levels=levels)
    corners = [0, nu, (nu + 1) * nv, (nu + 1) * (nv + 1) - 1]
    assert sorted(info.corners.tolist()) == corners
    loop = boundary_loops(Q1)[0]
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    sides = [(idx[0, :], 0, nu), (idx[:, -1], nu, corners[3]), (idx[:, 0], 0, corners[2])]
    s = 2 ** levels
    for coarse, a, b in sides:
        chain = V1[_chain(loop, a, b, corners)]
        assert len(chain) == (len(coarse) - 1) * s + 1
        # limit points of the refined polygon at its knots = the coarse spline (scipy) at the refined knots
        D = _extended(chain)
        limit = (D[:-2] + 4 * D[1:-1] + D[2:]) / 6
        u = np.arange(len(chain)) / s
        np.testing.assert_allclose(limit, _scipy_curve(V[coarse])(u), atol=1e-12)
        # and the corners are interpolated
        np.testing.assert_allclose(chain[[0, -1]], V[[a, b]], atol=0)


def test_limit_positions_on_grid_equal_bicubic_spline():
    nu, nv = 5, 4
    V, Q = _lifted_grid(nu, nv, seed=3)
    V1, Q1, info = subdivided_mesh(V, Q, levels=1)
    P = limit_positions(V1, Q1, corners=info.corners)
    Z = V[:, 2].reshape(nv + 1, nu + 1)
    # extend rows then columns with phantom points, evaluate the tensor-product spline with scipy
    Zx = np.stack([_extended(r) for r in Z])  # (nv+1, nu+3)
    Zxy = np.stack([_extended(c) for c in Zx.T]).T  # (nv+3, nu+3)
    tu = np.arange(nu + 3 + 4, dtype=float) - 3
    tv = np.arange(nv + 3 + 4, dtype=float) - 3
    su = BSpline(tu, Zxy.T, 3)  # along u, coefficients (nu+3, nv+3)
    u = np.arange(2 * nu + 1) / 2
    v = np.arange(2 * nv + 1) / 2
    Au = su(u)  # (len u, nv+3)
    ref = BSpline(tv, Au.T, 3)(v)  # (len v, len u)
    got = _grid_values(np.column_stack([V1[:, :2], P[:, 2]]), nu, nv, 1)
    np.testing.assert_allclose(got, ref, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# counts and irregular vertices on mixed meshes


def _mixed_closed():
    """A closed mixed mesh: a square pyramid (four triangles and a quad base)."""
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
    F = pad_faces([[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], k=4)
    return V, F


@pytest.mark.parametrize("which", ["strip", "pyramid", "tetra", "cube"])
def test_counts_per_level_follow_formulas(mixed_strip, which):
    V, F = {"strip": mixed_strip, "pyramid": _mixed_closed(), "tetra": _tetrahedron(), "cube": _cube()}[which]
    levels = 3
    V1, Q1, info = subdivided_mesh(V, F, levels=levels)
    nv, ne, nf = len(V), len(edge_topology(F).E), len(F)
    h = int(face_sizes(F).sum())
    for lv in info.levels:
        assert (lv.vertex_count, lv.edge_count, lv.face_count) == (nv, ne, nf)
        assert lv.face_count == face_count_after(F, lv.level)
        nv, ne, nf, h = nv + ne + nf, 2 * ne + h, h, 4 * h
    assert Q1.shape == (info.levels[-1].face_count, 4) and len(V1) == info.levels[-1].vertex_count
    # Euler characteristic is kept
    chi = [lv.vertex_count - lv.edge_count + lv.face_count for lv in info.levels]
    assert len(set(chi)) == 1


def test_irregular_vertices_are_carried():
    V, T = _tetrahedron()
    _, _, info = subdivided_mesh(V, T, levels=2)
    lv0, lv1, lv2 = info.levels
    assert lv0.irregular_vertices.tolist() == [0, 1, 2, 3] and lv0.irregular_valences.tolist() == [3] * 4
    # level 1: the old four plus one face point per triangle (valence 3), indices n + e + f
    face_pts = [4 + 6 + f for f in range(4)]
    assert lv1.irregular_vertices.tolist() == [0, 1, 2, 3] + face_pts
    assert lv1.irregular_valences.tolist() == [3] * 8
    np.testing.assert_array_equal(lv2.irregular_vertices, lv1.irregular_vertices)
    np.testing.assert_array_equal(lv2.irregular_valences, lv1.irregular_valences)


def test_pentagon_and_valence_five_vertex():
    # a disk: an interior vertex of valence 5 (five quads around it) and a pentagon elsewhere
    ring = [[np.cos(a), np.sin(a), 0] for a in np.linspace(0, 2 * np.pi, 11)[:-1]]
    V = np.array([[0, 0, 0.3]] + ring, dtype=float)
    faces = [[0, 1 + (2 * i) % 10, 1 + (2 * i + 1) % 10, 1 + (2 * i + 2) % 10] for i in range(5)]
    F = pad_faces(faces, k=5)
    V1, Q1, info = subdivided_mesh(V, F, levels=2)
    assert info.levels[0].irregular_vertices.tolist() == [0]
    assert info.levels[0].irregular_valences.tolist() == [5]
    assert info.levels[2].irregular_vertices.tolist() == [0]
    # a pentagon face adds an irregular face point of valence 5
    Vp = np.vstack([V, [[0.0, 0.0, -1.0]]])
    Fp = pad_faces([[1, 3, 5, 7, 9], [1, 2, 3], [3, 4, 5], [5, 6, 7], [7, 8, 9], [9, 10, 1]], k=5)
    _, _, info2 = subdivided_mesh(Vp, Fp, levels=1)
    e = len(edge_topology(Fp).E)
    assert len(Vp) + e + 0 in info2.levels[1].irregular_vertices.tolist()
    i = info2.levels[1].irregular_vertices.tolist().index(len(Vp) + e)
    assert info2.levels[1].irregular_valences[i] == 5


# ----------------------------------------------------------------------------------------------
# smoothness and limit stencils


def test_cube_converges_toward_smooth_surface():
    V, F = _cube()
    angles = []
    for levels in range(1, 6):
        V1, Q1, _ = subdivided_mesh(V, F, levels=levels)
        angles.append(_max_dihedral(V1, Q1))
    assert all(b < 0.65 * a for a, b in zip(angles, angles[1:])), angles  # about halves
    assert angles[-1] < 4.0
    # no extreme flattening: the limit surface stays a closed convex blob around the centre
    r = np.linalg.norm(V1 - 0.5, axis=1)
    assert r.min() > 0.4 and r.max() < 0.45


def test_subdivision_matrix_rows_are_convex_combinations(mixed_strip):
    for V, F in (mixed_strip, _cube(), _mixed_closed()):
        S = subdivision_step(V, F).S
        np.testing.assert_allclose(np.asarray(S.sum(axis=1)).ravel(), 1.0, atol=1e-14)
        assert S.data.min() >= 0.0


def test_limit_positions_are_invariant_under_subdivision(hypar_grid):
    # the limit stencil is the left eigenvector of S for eigenvalue 1: limit(S V) == limit(V) on old vertices
    cases = [subdivided_mesh(*_cube(), levels=1), subdivided_mesh(*_mixed_closed(), levels=1),
             subdivided_mesh(*hypar_grid, levels=1), subdivided_mesh(*_tetrahedron(), levels=1)]
    for V1, Q1, info in cases:
        step = subdivision_step(V1, Q1, corners=info.corners)
        V2 = step.S @ V1
        L1 = limit_positions(V1, Q1, corners=info.corners)
        L2 = limit_positions(V2, step.Q, corners=info.corners)
        np.testing.assert_allclose(L2[:len(V1)], L1, atol=1e-13)


def test_vertices_converge_to_limit_positions():
    V1, Q1, _ = subdivided_mesh(*_cube(), levels=1)
    L = limit_positions(V1, Q1)
    errors = []
    V, Q = V1, Q1
    for _ in range(5):
        errors.append(np.abs(V[:len(V1)] - L).max())
        V, Q, _ = subdivided_mesh(V, Q, levels=1)
    assert all(b < 0.5 * a for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 1e-3


# ----------------------------------------------------------------------------------------------
# boundary options and corners


def test_sharp_turn_and_user_corners_stay_fixed():
    # L-shaped grid: the reflex corner (boundary turning 90°, 3 faces) is a corner
    V, Q = quad_grid(4, 4, 4.0, 4.0)
    keep = ~((V[Q].mean(axis=1)[:, 0] > 2) & (V[Q].mean(axis=1)[:, 1] > 2))
    Q = Q[keep]
    V[:, 2] = np.sin(V[:, 0]) * np.cos(V[:, 1])
    reflex = int(np.nonzero(np.all(V[:, :2] == [2.0, 2.0], axis=1))[0][0])
    side = int(np.nonzero(np.all(V[:, :2] == [1.0, 0.0], axis=1))[0][0])
    V1, _, info = subdivided_mesh(V, Q, levels=2)
    assert reflex in info.corners
    np.testing.assert_array_equal(V1[reflex], V[reflex])
    assert not np.array_equal(V1[side], V[side])
    V2, _, info2 = subdivided_mesh(V, Q, levels=2, corners=[side])
    assert side in info2.corners
    np.testing.assert_array_equal(V2[side], V[side])
    # with a 100° threshold the reflex corner is smoothed
    V3, _, info3 = subdivided_mesh(V, Q, levels=1, corner_angle=np.radians(100))
    assert reflex not in info3.corners


def test_linear_boundary_keeps_the_boundary_polygon():
    V, Q = _lifted_grid(4, 3, seed=5)
    V1, Q1, _ = subdivided_mesh(V, Q, levels=2, boundary="linear")
    loop0 = boundary_loops(Q)[0]
    A, B = V[loop0], V[np.roll(loop0, -1)]
    for p in V1[boundary_loops(Q1)[0]]:
        t = np.clip(np.einsum("ij,ij->i", p - A, B - A) / np.einsum("ij,ij->i", B - A, B - A), 0, 1)
        assert np.min(np.linalg.norm(A + t[:, None] * (B - A) - p, axis=1)) < 1e-12


def test_levels_zero_returns_input(mixed_strip):
    V, F = mixed_strip
    V1, F1, info = subdivided_mesh(V, F, levels=0)
    np.testing.assert_array_equal(V1, V)
    np.testing.assert_array_equal(F1, F)
    assert len(info.levels) == 1


def test_real_quad_mesh_subdivides(request):
    V, F = read_mesh(data_file("obj_gnet__chebyshev_sphere.obj"))
    V1, Q1, info = subdivided_mesh(V, F, levels=2)
    assert len(Q1) == 16 * len(F)
    assert len(info.levels[-1].irregular_vertices) == len(info.levels[0].irregular_vertices)
    # smoother: the largest dihedral angle drops
    assert _max_dihedral(V1, Q1) < _max_dihedral(V, F)


# ----------------------------------------------------------------------------------------------
# bad input: typed errors before any heavy work


def test_flipped_face_is_rejected(planar_grid):
    V, Q = planar_grid
    Q = Q.copy()
    Q[7] = Q[7, ::-1]
    with pytest.raises(MeshError, match=r"^mesh: .*oriented"):
        subdivided_mesh(V, Q)
    with pytest.raises(MeshError, match=r"^mesh: "):
        catmull_clark((V, Q))


def test_nonmanifold_edge_is_rejected(nonmanifold_fan):
    with pytest.raises(MeshError, match=r"^mesh: .*non-manifold"):
        subdivided_mesh(*nonmanifold_fan)
    with pytest.raises(MeshError, match=r"^coarse: "):
        control_mesh(*nonmanifold_fan, name="coarse")


@pytest.mark.parametrize("levels", [-1, 1.5, "2", True, None])
def test_bad_levels(planar_grid, levels):
    with pytest.raises(InputError, match=r"^levels: "):
        subdivided_mesh(*planar_grid, levels=levels)


def test_too_many_faces_refused_before_work(planar_grid, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("subdivision started")

    monkeypatch.setattr(subdiv, "_step", boom)
    with pytest.raises(InputError, match=r"^levels: .*limit"):
        subdivided_mesh(*planar_grid, levels=40)  # 24 · 4^39 faces
    with pytest.raises(InputError, match=r"^levels: "):
        subdivided_mesh(*planar_grid, levels=3, max_faces=1535)  # 96 · 4² = 1536 faces
    with pytest.raises(InputError, match=r"^levels: "):
        catmull_clark(planar_grid, levels=12)
    with pytest.raises(AssertionError):
        subdivided_mesh(*planar_grid, levels=3, max_faces=1536)  # at the limit: runs


def test_bad_options(planar_grid):
    with pytest.raises(InputError, match=r"^boundary: "):
        subdivided_mesh(*planar_grid, boundary="smooth")
    with pytest.raises(InputError, match=r"^corners: "):
        subdivided_mesh(*planar_grid, corners=[1000])
    with pytest.raises(InputError, match=r"^corners: "):
        subdivided_mesh(*planar_grid, corners=[0.5])
    with pytest.raises(InputError, match=r"^corner_angle: "):
        subdivided_mesh(*planar_grid, corner_angle=-1)
    with pytest.raises(InputError, match=r"^max_faces: "):
        subdivided_mesh(*planar_grid, max_faces=0)
    with pytest.raises(InputError, match=r"^mesh: "):
        catmull_clark(planar_grid[0])
    with pytest.raises(MeshError, match=r"^mesh: .*NaN"):
        V = planar_grid[0].copy()
        V[3, 1] = np.nan
        catmull_clark((V, planar_grid[1]))


# ----------------------------------------------------------------------------------------------
# published component


def test_published_component(mixed_strip):
    from ghserver.registry import declare

    comp = declare(catmull_clark, "subdivision/catmull_clark")
    assert [p.name for p in comp.inputs] == ["mesh", "levels", "boundary", "corners", "max_faces"]
    assert [p.name for p in comp.outputs] == ["mesh", "irregular_vertices", "irregular_valences", "vertex_count",
                                              "face_count"]
    res = catmull_clark(_mixed_closed(), levels=2)
    V, Q = res.mesh
    assert Q.shape == (res.face_count, 4) and len(V) == res.vertex_count
    assert res.irregular_vertices.dtype == np.int64
    # pyramid: apex of valence 4 is regular; 4 base corners and 4 triangle face points have valence 3
    assert res.irregular_valences.tolist() == [3] * 8
    assert res.warnings == []
    assert catmull_clark(mixed_strip, levels=0).warnings
