"""Exact closest points on triangle meshes and polylines, checked against brute force and trimesh."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import quad_grid, triangulate
from components.core.proximity import (
    PolylineIndex,
    TriangleIndex,
    closest_points,
    closest_points_on_polyline,
    closest_points_on_triangles,
)

trimesh = pytest.importorskip("trimesh")


def brute_force(P, V, T):
    """Distance to every triangle (row-wise kernel over all pairs), then the minimum."""
    p, t = len(P), len(T)
    pi = np.repeat(np.arange(p), t)
    ti = np.tile(np.arange(t), p)
    d2, _, _ = closest_points_on_triangles(P[pi], V[T[ti, 0]], V[T[ti, 1]], V[T[ti, 2]])
    return np.sqrt(d2.reshape(p, t).min(axis=1))


def random_soup(rng, t=300, big=True):
    """Random triangles of very different sizes (one huge one forces the index to subdivide it)."""
    C = rng.uniform(-1, 1, size=(t, 1, 3))
    S = rng.uniform(0.01, 0.2, size=(t, 1, 1))
    X = C + S * rng.normal(size=(t, 3, 3))
    if big:
        X[0] = [[-3, -3, 0.1], [3, -3, 0.0], [0, 3, -0.1]]
    return X.reshape(-1, 3), np.arange(3 * t).reshape(t, 3)


def test_kernel_matches_trimesh_on_random_triangles():
    rng = np.random.default_rng(1)
    q = 20000
    A, B, C = rng.normal(size=(3, q, 3))
    P = 2.0 * rng.normal(size=(q, 3))
    d2, bary, region = closest_points_on_triangles(P, A, B, C)
    X = trimesh.triangles.closest_point(np.stack([A, B, C], axis=1), P)
    np.testing.assert_allclose(np.sqrt(d2), np.linalg.norm(P - X, axis=1), atol=1e-12)
    assert np.allclose(bary.sum(axis=1), 1.0) and bary.min() >= -1e-12
    # region codes agree with the zero pattern of the barycentric coordinates
    assert np.all(bary[region == 0] > 0)
    assert np.all(bary[region == 1, 0] == 1) and np.all(bary[region == 5, 0] == 0)


def test_kernel_handles_zero_area_triangles():
    rng = np.random.default_rng(2)
    P = rng.normal(size=(50, 3))
    A = np.zeros((50, 3))
    B = np.tile([1.0, 0, 0], (50, 1))
    C = np.tile([2.0, 0, 0], (50, 1))  # collinear
    d2, bary, _ = closest_points_on_triangles(P, A, B, C)
    x = np.clip(P[:, 0], 0, 2)
    expected = np.linalg.norm(P - np.stack([x, 0 * x, 0 * x], axis=1), axis=1)
    np.testing.assert_allclose(np.sqrt(d2), expected, atol=1e-12)
    d2, bary, _ = closest_points_on_triangles(P, A, A, C)  # repeated corner
    assert np.all(np.isfinite(bary))
    np.testing.assert_allclose(np.sqrt(d2), expected, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_index_is_exact_against_brute_force(seed):
    rng = np.random.default_rng(seed)
    V, T = random_soup(rng)
    P = np.concatenate([rng.uniform(-1.5, 1.5, size=(300, 3)), 10 * rng.normal(size=(30, 3)),
                        V[rng.integers(0, len(V), 50)] + 1e-3 * rng.normal(size=(50, 3))])
    res = TriangleIndex(V, T).query(P)
    np.testing.assert_allclose(res.distances, brute_force(P, V, T), atol=1e-12, rtol=0)
    # the returned point lies on the returned face at the returned barycentric coordinates
    X = np.einsum("pi,pij->pj", res.barycentric, V[T[res.faces]])
    np.testing.assert_allclose(X, res.points, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(P - res.points, axis=1), res.distances, atol=1e-12)


def test_far_and_equidistant_points_are_exact():
    m = trimesh.creation.icosphere(subdivisions=3)
    V, T = np.asarray(m.vertices), np.asarray(m.faces)
    P = np.array([[0.0, 0, 0], [0.01, 0, 0], [0, 0, 50.0], [-20, 5, 3]])
    res = closest_points(P, V, T)
    np.testing.assert_allclose(res.distances, brute_force(P, V, T), atol=1e-12)


def test_at_least_as_close_as_trimesh_rtree():
    pytest.importorskip("rtree")
    m = trimesh.creation.icosphere(subdivisions=3)
    rng = np.random.default_rng(3)
    P = np.asarray(m.vertices)[rng.integers(0, len(m.vertices), 2000)] * (1 + 0.05 * rng.normal(size=(2000, 1)))
    res = TriangleIndex(m.vertices, m.faces).query(P)
    _, dist, _ = trimesh.proximity.closest_point(m, P)
    assert np.all(res.distances <= dist + 1e-12)
    np.testing.assert_allclose(res.distances, dist, atol=1e-6)


def test_signed_distance_on_closed_meshes():
    m = trimesh.creation.icosphere(subdivisions=3)
    rng = np.random.default_rng(4)
    D = rng.normal(size=(500, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    r = rng.uniform(0.3, 1.7, size=(500, 1))
    P = D * r
    index = TriangleIndex(m.vertices, m.faces)
    assert index.oriented
    res = index.query(P, signed=True)
    keep = np.abs(r[:, 0] - 1) > 0.05  # away from the polyhedral approximation error
    assert np.all(np.sign(res.distances[keep]) == np.sign(r[keep, 0] - 1))
    # a box: points nearest to edges and corners take the sign of the edge / vertex pseudo-normals
    box = trimesh.creation.box()
    Pb = np.array([[0.6, 0.6, 0.0], [0.6, 0.6, 0.6], [0.45, 0.45, 0.45], [0.4, 0.4, 0.0], [0.0, 0.0, 0.7]])
    sd = TriangleIndex(box.vertices, box.faces).query(Pb, signed=True).distances
    assert np.all(sd[[0, 1, 4]] > 0) and np.all(sd[[2, 3]] < 0)
    np.testing.assert_allclose(np.abs(sd), [np.hypot(0.1, 0.1), np.sqrt(3) * 0.1, 0.05, 0.1, 0.2], atol=1e-12)


def test_signed_plane_and_polygon_reference():
    V, Q = quad_grid(4, 4, 2.0, 2.0)
    T, _ = triangulate(Q)
    P = np.array([[1.0, 1.0, 0.3], [0.5, 1.5, -0.2], [3.0, 1.0, 0.0]])
    res = closest_points(P, V, T, signed=True)
    np.testing.assert_allclose(res.distances, [0.3, -0.2, 1.0], atol=1e-12)
    np.testing.assert_allclose(res.points[2], [2.0, 1.0, 0.0], atol=1e-12)


def test_bad_inputs_raise_typed_errors(nonmanifold_fan):
    V, T = nonmanifold_fan
    index = TriangleIndex(V, T)
    assert not index.oriented
    with pytest.raises(InputError, match="^points"):
        index.query(np.zeros((2, 3)), signed=True)
    with pytest.raises(InputError, match="^points: point 0 has a NaN or infinite coordinate$"):
        index.query(np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(InputError, match="^points: must be points with shape \\(n, 3\\), got shape \\(2, 2\\)$"):
        index.query(np.zeros((2, 2)))
    with pytest.raises(InputError, match="^points: must be points with shape \\(n, 3\\)"):
        index.query("abc")
    assert index.query(np.zeros((0, 3))).distances.shape == (0,)  # no points: empty answers
    assert index.query(None).points.shape == (0, 3)
    with pytest.raises(MeshError, match="^mesh"):
        TriangleIndex(np.array([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="^mesh"):
        TriangleIndex(*quad_grid(2, 2))  # quads must be triangulated first
    with pytest.raises(MeshError, match="^mesh"):
        TriangleIndex(np.zeros((3, 3)), np.array([[0, 1, 5]]))


def polyline_brute_force(P, X, closed):
    A = X if closed else X[:-1]
    B = np.roll(X, -1, axis=0) if closed else X[1:]
    AB = B - A
    t = np.clip(np.einsum("psj,sj->ps", P[:, None, :] - A[None], AB) / np.einsum("sj,sj->s", AB, AB), 0, 1)
    Q = A[None] + t[..., None] * AB[None]
    return np.linalg.norm(P[:, None, :] - Q, axis=2).min(axis=1)


@pytest.mark.parametrize("closed", [False, True])
def test_polyline_exact(closed):
    rng = np.random.default_rng(5)
    s = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    X = np.stack([np.cos(s), np.sin(s), 0.1 * np.sin(3 * s)], axis=1)
    X[10] *= 3.0  # two long segments
    P = rng.uniform(-2, 2, size=(400, 3))
    res = closest_points_on_polyline(P, X, closed=closed)
    np.testing.assert_allclose(res.distances, polyline_brute_force(P, X, closed), atol=1e-12)
    assert res.t.min() >= 0 and res.t.max() <= 1
    A = X if closed else X[:-1]
    B = np.roll(X, -1, axis=0) if closed else X[1:]
    np.testing.assert_allclose(A[res.segments] + res.t[:, None] * (B - A)[res.segments], res.points, atol=1e-12)
    if closed:
        r = PolylineIndex(X, closed=True).query(np.array([0.5 * (X[-1] + X[0])]))
        assert r.segments[0] == len(X) - 1 and r.distances[0] < 1e-12


def test_polyline_bad_inputs():
    with pytest.raises(InputError, match="^polyline"):
        PolylineIndex(np.zeros((1, 3)))
    with pytest.raises(InputError, match="^polyline"):
        PolylineIndex(np.zeros((4, 3)))
    with pytest.raises(InputError, match="^points: point 0 has a NaN or infinite coordinate$"):
        PolylineIndex(np.eye(3)).query(np.array([[np.inf, 0, 0]]))
    with pytest.raises(InputError, match="^polyline: a polyline needs at least 2 points, got 0$"):
        PolylineIndex(None)
    assert PolylineIndex(np.eye(3)).query([]).t.shape == (0,)


@pytest.mark.parametrize("scale, shift", [(1.0, 0.0), (1e3, 0.0), (1e-3, 5e6)])
def test_exact_at_every_distance_scale_and_placement(scale, shift):
    """Points on, near and far from a soup of very unequal triangles (the grid's own cell, its ball, the coarser
    grids and the coarsest one all answer): the exact minimum over all triangles, relative to the model's size."""
    rng = np.random.default_rng(11)
    V, T = random_soup(rng, t=400)
    V[T[5]] = V[T[5]] * [40.0, 0.2, 1.0]  # a long sliver across the soup
    on = np.einsum("pi,pij->pj", rng.dirichlet(np.ones(3), 200), V[T[rng.integers(0, len(T), 200)]])
    P = np.concatenate([on, on + 1e-4 * rng.normal(size=on.shape), rng.uniform(-2, 2, size=(300, 3)),
                        10.0 ** rng.uniform(0, 3, size=(100, 1)) * rng.normal(size=(100, 3))])
    res = TriangleIndex(V * scale + shift, T).query(P * scale + shift)
    expected = brute_force(P, V, T)
    tol = 1e-12 if shift == 0.0 else 2e-9 / scale  # +5e6: the coordinates' own round-off
    np.testing.assert_allclose(res.distances / scale, expected, atol=tol * (1 + expected.max()), rtol=0)


def test_within_agrees_with_the_distances():
    m = trimesh.creation.icosphere(subdivisions=3)
    V, T = np.asarray(m.vertices), np.asarray(m.faces)
    rng = np.random.default_rng(12)
    P = rng.normal(size=(3000, 3)) * rng.uniform(0.0, 2.0, size=(3000, 1))
    index = TriangleIndex(V, T)
    d = index.query(P).distances
    for r in (0.0, 0.01, 0.2, 5.0):
        inside = index.within(P, r)
        clear = np.abs(d - r) > 1e-12  # away from round-off at the bound
        assert np.array_equal(inside[clear], (d <= r)[clear])


def test_an_index_of_changed_arrays_is_a_new_index():
    """Indexes are reused by content: changing the arrays in place and indexing them again sees the change, and the
    first index keeps answering for the arrays it was built on."""
    V, Q = quad_grid(4, 4)
    T = triangulate(Q)[0]
    first = TriangleIndex(V, T)
    again = TriangleIndex(V.copy(), T.copy())
    P = np.array([[0.5, 0.5, 1.0]])
    assert again.query(P).distances[0] == first.query(P).distances[0] == 1.0
    V[:, 2] += 0.25
    moved = TriangleIndex(V, T)
    assert moved.query(P).distances[0] == pytest.approx(0.75, abs=1e-12)
    assert first.query(P).distances[0] == 1.0
