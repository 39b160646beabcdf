"""Isotropic remeshing: topology, orientation, edge lengths, closeness to the input, boundaries, corners, features."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, edge_topology, read_mesh, triangulate
from components.core.proximity import TriangleIndex, closest_points_on_polyline
from components.fields.remesh import decimate, feature_edges, isotropic_remesh, remesh
from tests.conftest import data_file


def _grid_tris(nu, nv):
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)


def _disk(f, n_r=12, n_t=48, radius=1.0):
    """A polar-grid disk lifted by z = f(x, y), counter-clockwise (normals up), one boundary loop."""
    V = [[0.0, 0.0]]
    for i in range(1, n_r + 1):
        t = np.linspace(0, 2 * np.pi, n_t, endpoint=False) + 0.5 * i
        r = radius * i / n_r
        V += list(zip(r * np.cos(t), r * np.sin(t)))
    V = np.asarray(V)
    from scipy.spatial import Delaunay

    T = Delaunay(V).simplices.astype(np.int64)
    P = np.column_stack([V, f(V[:, 0], V[:, 1])])
    N = np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]])
    T[N[:, 2] < 0] = T[N[:, 2] < 0][:, ::-1]
    return P, T


def _edges(T):
    return edge_topology(T).E


def _mean_edge(V, T):
    E = _edges(T)
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


def _chi(V, T):
    return len(np.unique(T)) - len(_edges(T)) + len(T)


def _check_remesh(V, T, V2, T2, L, within=0.9):
    """Every property the issue asks for; returns the measured numbers."""
    bbox = float(np.linalg.norm(np.ptp(V, axis=0)))
    V2, T2 = validate_mesh(V2, T2, name="result", kind="tri")  # manifold, oriented, no degenerate faces
    assert len(np.unique(T2)) == len(V2)  # no unused vertices
    loops_in, loops_out = boundary_loops(T), boundary_loops(T2)  # raises on non-manifold vertices
    assert len(loops_out) == len(loops_in)
    assert _chi(V2, T2) == _chi(V, T)
    E = _edges(T2)
    lengths = np.linalg.norm(V2[E[:, 1]] - V2[E[:, 0]], axis=1)
    frac = np.mean(np.abs(lengths / L - 1) <= 0.3)
    assert frac >= within
    # no sliver: smallest triangle area relative to L²
    A2 = 0.5 * np.linalg.norm(np.cross(V2[T2[:, 1]] - V2[T2[:, 0]], V2[T2[:, 2]] - V2[T2[:, 0]]), axis=1)
    assert A2.min() > 1e-3 * L * L
    # every vertex on the input surface
    index = TriangleIndex(V, T)
    q = index.query(V2)
    assert q.distances.max() <= 1e-9 * bbox
    # orientation: each output face agrees with the input face under its centroid
    G = V2[T2].mean(axis=1)
    qf = index.query(G)
    N_in = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])[qf.faces]
    N_out = np.cross(V2[T2[:, 1]] - V2[T2[:, 0]], V2[T2[:, 2]] - V2[T2[:, 0]])
    assert np.mean(np.einsum("ij,ij->i", N_in, N_out) > 0) == 1.0
    # boundary vertices on the input boundary polyline
    if loops_in:
        bv = np.unique(np.concatenate(loops_out))
        d = np.min([closest_points_on_polyline(V2[bv], V[lp], closed=True).distances for lp in loops_in], axis=0)
        assert d.max() <= 1e-9 * bbox
    return frac


def test_dome_disk():
    V, T = _disk(lambda x, y: 0.5 * (1 - x * x - y * y))
    L = 0.08
    V2, T2 = isotropic_remesh(V, T, L)
    _check_remesh(V, T, V2, T2, L)
    # the remesher refines this coarse input: many more triangles, boundary resampled to ≈ L
    loop = boundary_loops(T2)[0]
    seg = np.linalg.norm(V2[np.roll(loop, -1)] - V2[loop], axis=1)
    assert np.all(np.abs(seg / L - 1) < 0.5)


def test_saddle_coarsens_and_keeps_square_corners():
    V0 = np.stack(np.meshgrid(np.linspace(-1, 1, 41), np.linspace(-1, 1, 41)), -1).reshape(-1, 2)
    V = np.column_stack([V0, 0.4 * V0[:, 0] * V0[:, 1]])
    T = _grid_tris(40, 40)
    L = 0.15
    V2, T2 = isotropic_remesh(V, T, L)
    _check_remesh(V, T, V2, T2, L)
    assert len(T2) < len(T) / 3
    # the four corners turn by 90°: they are kept exactly
    corners = V[[0, 40, 41 * 40, 41 * 41 - 1]]
    for c in corners:
        assert np.min(np.linalg.norm(V2 - c, axis=1)) == 0.0


def test_unprotected_corners_still_stay_on_the_boundary():
    V0 = np.stack(np.meshgrid(np.linspace(-1, 1, 21), np.linspace(-1, 1, 21)), -1).reshape(-1, 2)
    V = np.column_stack([V0, 0.4 * V0[:, 0] * V0[:, 1]])
    T = _grid_tris(20, 20)
    V2, T2 = isotropic_remesh(V, T, 0.2, preserve_boundary=False)
    _check_remesh(V, T, V2, T2, 0.2, within=0.85)


def test_boundary_vertices_slide_instead_of_staying_fixed():
    # gpytoolbox keeps the input boundary vertices; here the boundary is resampled to the target
    V0 = np.stack(np.meshgrid(np.linspace(0, 1, 51), np.linspace(0, 0.2, 3)), -1).reshape(-1, 2)
    V = np.column_stack([V0, np.zeros(len(V0))])
    T = _grid_tris(50, 2)
    V2, T2 = isotropic_remesh(V, T, 0.1)
    _check_remesh(V, T, V2, T2, 0.1, within=0.8)
    bottom = np.abs(V2[:, 1]) < 1e-12
    assert 9 <= bottom.sum() <= 13  # was 51


def test_hole_and_features_folded_plate():
    # two planes meeting at a right angle along x = 0 (a sharp feature), with a square hole in one of them
    u = np.linspace(-1, 1, 21)
    X, Y = np.meshgrid(u, u)
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], 1)
    fold = V[:, 0] > 0
    V[fold, 2] = V[fold, 0]
    V[fold, 0] = 0.0
    T = _grid_tris(20, 20)
    cen = V[T].mean(axis=1)
    hole = (np.abs(cen[:, 0] + 0.5) < 0.2) & (np.abs(cen[:, 1]) < 0.2)
    T = T[~hole]
    used = np.unique(T)
    remap = np.full(len(V), -1)
    remap[used] = np.arange(len(used))
    V, T = V[used], remap[T]
    assert len(feature_edges(V, T, 45.0)) == 20
    L = 0.12
    V2, T2 = isotropic_remesh(V, T, L)
    _check_remesh(V, T, V2, T2, L, within=0.85)
    assert len(boundary_loops(T2)) == 2
    # the fold survives: the sharp edges of the result run along x = 0, z = 0 over the whole width
    sharp = feature_edges(V2, T2, 45.0)
    P = V2[sharp.ravel()]
    assert np.abs(P[:, 0]).max() < 1e-12 and np.abs(P[:, 2]).max() < 1e-12
    assert np.linalg.norm(V2[sharp[:, 1]] - V2[sharp[:, 0]], axis=1).sum() == pytest.approx(2.0)


@pytest.mark.parametrize("name, factor", [
    ("inspired_mesh.obj", 1.0),
    ("inspired_mesh.obj", 2.0),
    ("lilium.obj", 1.5),
    ("geometrylab_test_tri_dome.obj", 0.5),
    ("geometrylab_test_tri_mesh.obj", 1.0),  # annulus: two boundary loops
])
def test_real_meshes(name, factor):
    V, F = read_mesh(data_file(name))
    T, _ = triangulate(F)
    L = factor * _mean_edge(V, T)
    V2, T2 = isotropic_remesh(V, T, L, iterations=10)
    frac = _check_remesh(V, T, V2, T2, L)
    assert frac >= 0.95  # measured 0.98–0.99


def test_published_component(hypar_grid):
    V, F = hypar_grid  # quads: fan-triangulated first
    res = remesh((V, F), target_length=0.1)
    V2, T2 = res.mesh
    assert T2.shape[1] == 3
    assert 0.8 * 0.1 < res.mean_edge < 1.2 * 0.1
    assert res.min_edge <= res.mean_edge <= res.max_edge <= 4 / 3 * 0.1 * 1.3
    assert res.max_deviation < 1e-9
    assert res.warnings == []
    res = remesh((V, F), target_length=1.0, iterations=2)
    assert res.warnings and "large" in res.warnings[0]


def test_bad_inputs(nonmanifold_fan, hypar_grid):
    V, F = hypar_grid
    T, _ = triangulate(F)
    with pytest.raises(MeshError, match="^mesh: .*non-manifold"):
        isotropic_remesh(*nonmanifold_fan, 0.5)
    with pytest.raises(MeshError, match="^mesh: .*non-manifold"):
        remesh(nonmanifold_fan, 0.5)
    for bad in (0.0, -1.0, float("nan"), float("inf"), "x", None):
        with pytest.raises(InputError, match="^target_length: "):
            isotropic_remesh(V, T, bad)
        with pytest.raises(InputError, match="^target_length: "):
            remesh((V, F), bad)
    with pytest.raises(InputError, match="^target_length: .*triangles"):
        remesh((V, F), 1e-5)
    for bad in (0, -2, 1.5, True):
        with pytest.raises(InputError, match="^iterations: "):
            isotropic_remesh(V, T, 0.1, iterations=bad)
    with pytest.raises(InputError, match="^feature_angle: "):
        isotropic_remesh(V, T, 0.1, feature_angle=-5)
    with pytest.raises(MeshError, match="^mesh: .*triangle"):
        isotropic_remesh(V, F, 0.1)  # quads need the published component (or triangulate)
    Vd = V.copy()
    Vd[T[0, 1]] = Vd[T[0, 0]]
    with pytest.raises(MeshError, match="^mesh: .*degenerate"):
        isotropic_remesh(Vd, T, 0.1)
    # a bow-tie vertex (two boundary fans meeting at one vertex)
    Vb = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=float)
    Tb = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(MeshError, match="^mesh: .*non-manifold"):
        isotropic_remesh(Vb, Tb, 0.3)


def test_topology_sorts_match_stable_argsort():
    """The remesher's linear-time sorts (issue #21) give exactly ``np.argsort(kind="stable")``: on both paths (packed
    keys and the counting sort used when the keys do not fit in 62 bits), with ties, and for half-edge keys."""
    from components.fields.remesh import _BIG, _group_order, _pair_order

    rng = np.random.default_rng(3)
    for n in (1, 7, 1000):
        x = rng.integers(0, n, 5000)
        assert np.array_equal(_group_order(x, n), np.argsort(x, kind="stable"))
        lo, hi = np.sort(rng.integers(0, n, (2, 5000)), axis=0)
        assert np.array_equal(_pair_order(lo, hi, n), np.argsort(lo * _BIG + hi, kind="stable"))
    big = 1 << 50  # too wide to pack with the positions: the counting-sort path
    x = rng.integers(0, 300, 4000) * (1 << 40)
    assert np.array_equal(_group_order(x % 300, big), np.argsort(x % 300, kind="stable"))
    lo, hi = np.sort(rng.integers(0, 300, (2, 4000)), axis=0)
    assert np.array_equal(_pair_order(lo, hi, 1 << 30), np.argsort(lo * _BIG + hi, kind="stable"))
    assert len(_group_order(np.zeros(0, np.int64), 5)) == 0


def test_remesh_same_at_every_scale(hypar_grid):
    """Remeshing a scaled or far-placed copy gives the same mesh, scaled or moved (no absolute epsilon)."""
    V, F = hypar_grid
    T, _ = triangulate(F)
    V2, T2 = isotropic_remesh(V, T, 0.08, iterations=4)
    for s, off in ((1e-3, 0.0), (1e3, 0.0), (1.0, 5e6)):
        W2, S2 = isotropic_remesh(V * s + off, T, 0.08 * s, iterations=4)
        assert np.array_equal(S2, T2)
        assert np.abs((W2 - off) / s - V2).max() < 1e-6 * np.ptp(V, axis=0).max()


def test_remesh_reports_the_exact_deviation():
    """``max_deviation`` is the exact distance of the result from the input (not the remesher's local bound, which
    said 0.0138 on DOS heart at 0.8 of its mean edge where every vertex lies on the input to 4.5e-15)."""
    V, F = read_mesh(data_file("obj_pq__heart.obj"))
    T, _ = triangulate(F)
    E = edge_topology(T).E
    h = float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())
    res = remesh((V, T), 0.8 * h)
    V2 = res.mesh[0]
    exact = float(np.linalg.norm(TriangleIndex(V, T).query(V2).points - V2, axis=1).max())
    assert res.max_deviation == exact and exact < 1e-12 * h


def _decimation_checks(V, T, V2, T2, L):
    """The coarse copy keeps the surface's topology and orientation, its boundary and its corners, and lies within
    a fraction of an edge of the input."""
    V2, T2 = validate_mesh(V2, T2, name="coarse", kind="tri")  # manifold, oriented, no degenerate faces
    assert len(boundary_loops(T2)) == len(boundary_loops(T))
    assert _chi(V2, T2) == _chi(V, T)
    index = TriangleIndex(V, T)
    assert index.query(V2).distances.max() <= 0.5 * L  # a midpoint collapse leaves the surface by a fraction
    qf = index.query(V2[T2].mean(axis=1))
    N_in = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])[qf.faces]
    N_out = np.cross(V2[T2[:, 1]] - V2[T2[:, 0]], V2[T2[:, 2]] - V2[T2[:, 0]])
    assert np.all(np.einsum("ij,ij->i", N_in, N_out) > 0)
    return _mean_edge(V2, T2)


@pytest.mark.parametrize("factor", [1.6, 2.5])
def test_decimate_coarsens_keeping_topology_boundary_and_corners(factor):
    V0 = np.stack(np.meshgrid(np.linspace(-1, 1, 61), np.linspace(-1, 1, 61)), -1).reshape(-1, 2)
    V = np.column_stack([V0, 0.4 * V0[:, 0] * V0[:, 1] + 0.2 * np.sin(2 * V0[:, 0])])
    T = _grid_tris(60, 60)
    cen = V[T].mean(axis=1)
    T = T[np.hypot(cen[:, 0] - 0.3, cen[:, 1] + 0.2) > 0.25]  # a hole: two boundary loops
    V, T = validate_mesh(*(lambda u: (V[u], np.searchsorted(u, T)))(np.unique(T)), name="mesh", kind="tri")
    L = factor * _mean_edge(V, T)
    V2, T2 = decimate(V, T, L)
    mean = _decimation_checks(V, T, V2, T2, L)
    assert 0.8 * L <= mean <= 1.1 * L
    assert len(T2) < len(T) / (0.6 * factor * factor)
    for c in ([-1, -1], [1, -1], [1, 1], [-1, 1]):  # the square's corners turn by 90°: kept exactly
        i = np.flatnonzero(np.all(V[:, :2] == c, axis=1))[0]
        assert np.min(np.linalg.norm(V2 - V[i], axis=1)) == 0.0


def test_decimate_real_mesh_and_same_at_every_scale():
    V, F = read_mesh(data_file("lilium.obj"))
    V, T = validate_mesh(V, triangulate(F)[0], name="mesh", kind="tri")
    L = 2.0 * _mean_edge(V, T)
    V2, T2 = decimate(V, T, L)
    _decimation_checks(V, T, V2, T2, L)
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    for scale, shift in ((1000.0, 0.0), (0.001, 0.0), (1.0, 5e6)):
        V3, T3 = decimate(V * scale + shift, T, L * scale)
        assert np.array_equal(T3, T2)
        assert np.abs((V3 - shift) / scale - V2).max() <= 1e-9 * size
