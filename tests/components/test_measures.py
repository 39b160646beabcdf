"""Analytic facts of the shared measures in :mod:`components.core.measures`."""
from __future__ import annotations

import numpy as np
import pytest

from components.core import measures as ms
from components.core.mesh import face_corners, pad_faces, quad_grid, triangulate
from components.metrics import quality

SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
#: an L-shaped hexagon, counter-clockwise seen from +z; its corner 3 at (1, 1) is reflex
L_HEXAGON = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]], dtype=float)


def twisted_quad(t):
    """Diagonal 0-2 in z = 0, diagonal 1-3 in z = t: the diagonal lines are exactly ``t`` apart."""
    return np.array([[0.0, 0.0, 0.0], [1.0, 0.0, t], [1.0, 1.0, 0.0], [0.0, 1.0, t]])


# ----------------------------------------------------------------------------------------------- vector algebra


def test_cross_dot_norm_on_known_vectors():
    ex, ey, ez = np.eye(3)
    np.testing.assert_array_equal(ms.cross([ex, ey, ez], [ey, ez, ex]), [ez, ex, ey])
    np.testing.assert_array_equal(ms.cross([ey], [ex]), [-ez])
    np.testing.assert_array_equal(ms.dot([[1.0, 2.0, 3.0]], [[4.0, -5.0, 6.0]]), [12.0])
    np.testing.assert_array_equal(ms.norm([[3.0, 4.0, 12.0]]), [13.0])
    np.testing.assert_array_equal(ms.unit([[0.0, 0.0, -2.0], [3.0, 4.0, 0.0]]), [[0.0, 0.0, -1.0], [0.6, 0.8, 0.0]])


def test_zero_rows_stay_zero():
    A = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0], [0.0, 0.0, 0.0]])
    with np.errstate(all="raise"):
        U = ms.unit(A)
    np.testing.assert_array_equal(U[[0, 2]], 0.0)
    np.testing.assert_allclose(U[1], [1 / 3, 2 / 3, 2 / 3])
    np.testing.assert_array_equal(ms.cross(A, A[::-1]), np.zeros((3, 3)))
    np.testing.assert_array_equal(ms.norm(A), [0.0, 3.0, 0.0])
    assert ms.unit(np.zeros((0, 3))).shape == (0, 3)


def test_vector_algebra_matches_numpy_and_broadcasts():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 500, 3))
    np.testing.assert_array_equal(ms.cross(a, b), np.cross(a, b))  # same formulas, same numbers
    np.testing.assert_allclose(ms.dot(a, b), np.einsum("ij,ij->i", a, b), rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(ms.norm(a), np.linalg.norm(a, axis=1))
    np.testing.assert_allclose(ms.norm(ms.unit(a)), 1.0, rtol=1e-15)
    P = rng.normal(size=(7, 5, 3))
    n = rng.normal(size=(7, 1, 3))
    assert ms.cross(P, n).shape == (7, 5, 3) and ms.dot(P, n).shape == (7, 5)
    np.testing.assert_allclose(ms.cross(P, n), np.cross(P, n), rtol=1e-15)
    assert ms.cross(np.array([[1, 0, 0]]), np.array([[0, 1, 0]])).tolist() == [[0, 0, 1]]  # integers stay exact


# ----------------------------------------------------------------------------------------------- corners


def test_square_corner_angles_are_right_angles():
    np.testing.assert_allclose(ms.corner_angles(SQUARE, [[0, 1, 2, 3]]), np.full(4, np.pi / 2), rtol=1e-15)
    V, Q = quad_grid(3, 2, 3.0, 7.0)  # rectangles
    ang = ms.corner_angles(V, Q)
    assert ang.shape == (4 * len(Q),)
    np.testing.assert_allclose(ang, np.pi / 2, rtol=1e-15)


def test_corner_angles_follow_face_corners_order_and_skip_padding():
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, np.sqrt(3) / 2, 0.0]])
    V = np.r_[SQUARE, tri + [3.0, 0.0, 0.0]]
    F = pad_faces([[0, 1, 2, 3], [4, 5, 6]])
    ang = ms.corner_angles(V, F)
    C = face_corners(F)
    assert len(ang) == len(C.v) == 7
    np.testing.assert_allclose(ang[C.face == 1], np.pi / 3, rtol=1e-14)
    # the L-hexagon's reflex corner reads its unsigned angle, π/2
    np.testing.assert_allclose(ms.corner_angles(L_HEXAGON, [[0, 1, 2, 3, 4, 5]]), np.pi / 2, rtol=1e-15)


def test_triangle_angles_table_matches_corner_angles():
    V, Q = quad_grid(4, 3, height=lambda x, y: 0.3 * np.sin(3 * x) * y)
    T, _ = triangulate(Q)
    A = ms.triangle_angles(V, T)
    assert A.shape == (len(T), 3)
    np.testing.assert_array_equal(A.ravel(), ms.corner_angles(V, T))
    np.testing.assert_allclose(A.sum(axis=1), np.pi, rtol=1e-14)
    deg = ms.triangle_angles(V, [[0, 1, 1]])  # a repeated corner gives 0 / π, never NaN
    assert np.all(np.isfinite(deg))


def test_l_hexagon_is_nonconvex_and_square_is_convex():
    hexagon = [[0, 1, 2, 3, 4, 5]]
    assert ms.nonconvex_faces(L_HEXAGON, hexagon).tolist() == [True]
    assert ms.nonconvex_faces(L_HEXAGON[:, [1, 0, 2]], hexagon).tolist() == [True]  # mirrored: still non-convex
    assert ms.nonconvex_faces(SQUARE, [[0, 1, 2, 3], [3, 2, 1, 0]]).tolist() == [False, False]
    V, Q = quad_grid(3, 3, height=lambda x, y: 0.2 * x * y)
    assert not ms.nonconvex_faces(V, Q).any()
    flat = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])  # no normal at all
    assert ms.nonconvex_faces(flat, [[0, 1, 2]]).tolist() == [True]


# ----------------------------------------------------------------------------------------------- planarity


def test_planar_quads_have_zero_planarity_and_warping():
    V, Q = quad_grid(4, 3, 2.0, 5.0)
    R = np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]])  # a rotation: planar faces stay planar
    for W in (V, V @ R.T + [3.0, -1.0, 2.0]):
        np.testing.assert_allclose(ms.quad_planarity(W, Q), 0.0, atol=1e-15)
        np.testing.assert_allclose(ms.warping_height(W, Q), 0.0, atol=1e-15)


@pytest.mark.parametrize("t", [1e-3, 0.2, 1.0])
def test_twisted_quad_known_values(t):
    V = twisted_quad(t)
    Q = np.array([[0, 1, 2, 3]])
    assert ms.warping_height(V, Q)[0] == pytest.approx(t, rel=1e-14)
    assert ms.quad_planarity(V, Q)[0] == pytest.approx(t / np.sqrt(2.0), rel=1e-14)  # both diagonals are √2 long
    d = ms.quad_diagonals(V, Q, [0])
    assert d.gap[0] == pytest.approx(t, rel=1e-14)
    assert (d.length_1[0], d.length_2[0]) == pytest.approx((np.sqrt(2.0), np.sqrt(2.0)), rel=1e-15)


def test_one_lifted_corner_known_values():
    h = 0.5
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, h], [0.0, 1.0, 0.0]])
    Q = np.array([[0, 1, 2, 3]])
    gap = h / np.sqrt(2.0 * h * h + 4.0)  # |(d1 × d2)·(v1 − v0)| / |d1 × d2| with d1 × d2 = (−h, −h, 2)
    assert ms.warping_height(V, Q)[0] == pytest.approx(gap, rel=1e-14)
    assert ms.quad_planarity(V, Q)[0] == pytest.approx(gap / (0.5 * (np.sqrt(2.0 + h * h) + np.sqrt(2.0))), rel=1e-14)


def test_planarity_is_scale_free_and_warping_scales():
    V = twisted_quad(0.3)
    Q = np.array([[0, 1, 2, 3]])
    np.testing.assert_allclose(ms.quad_planarity(7.0 * V, Q), ms.quad_planarity(V, Q), rtol=1e-14)
    np.testing.assert_allclose(ms.warping_height(7.0 * V, Q), 7.0 * ms.warping_height(V, Q), rtol=1e-14)


def test_triangles_are_planar_and_parallel_diagonals_give_zero():
    V = twisted_quad(0.5)
    F = pad_faces([[0, 1, 2], [0, 1, 2, 3]])
    assert ms.quad_planarity(V, F)[0] == 0.0 and ms.warping_height(V, F)[0] == 0.0
    # a quad folded flat onto a line pair: the diagonals are parallel, the gap is 0 (not NaN)
    P = np.array([[0.0, 0, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]])
    assert ms.quad_diagonals(P, np.array([[0, 1, 2, 3]]), [0]).gap.tolist() == [0.0]


def test_ngon_planarity_uses_the_least_squares_plane():
    rng = np.random.default_rng(1)
    s = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    P = np.stack([np.cos(s), np.sin(s), 0.05 * rng.normal(size=6)], axis=1)
    F = np.array([[0, 1, 2, 3, 4, 5]])
    c = P.mean(axis=0)
    n = np.linalg.svd(P - c)[2][-1]
    dmax = np.abs((P - c) @ n).max()
    mean_edge = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1).mean()
    assert ms.warping_height(P, F)[0] == pytest.approx(dmax, rel=1e-10)
    assert ms.quad_planarity(P, F)[0] == pytest.approx(dmax / mean_edge, rel=1e-10)
    fd = ms.face_data(P, F)
    assert ms.mean_edge_lengths(fd, [0])[0] == pytest.approx(mean_edge, rel=1e-14)
    centroid, normal, dist = ms.least_squares_planes(fd, [0])
    np.testing.assert_allclose(centroid[0], c, atol=1e-15)
    assert normal[0] @ fd.area_vec[0] > 0  # oriented like the face
    np.testing.assert_allclose(np.abs(dist[0]), np.abs((P - c) @ n), atol=1e-12)
    assert ms.least_squares_planes(ms.face_data(P, F[:, ::-1]), [0])[1][0] @ normal[0] == pytest.approx(-1.0)


def test_smallest_eigenvector_closed_form():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(500, 4, 3)) * [1.0, 0.7, 0.01]
    Mx = np.einsum("qki,qkj->qij", X, X)
    v = ms.smallest_eigenvectors(Mx, np.zeros((500, 3)))
    w, U = np.linalg.eigh(Mx)
    np.testing.assert_allclose(np.abs(np.einsum("qi,qi->q", v, U[:, :, 0])), 1.0, atol=1e-9)
    fallback = np.tile([0.0, 0.0, 1.0], (2, 1))
    np.testing.assert_array_equal(ms.smallest_eigenvectors(np.zeros((2, 3, 3)), fallback), fallback)
    assert ms.smallest_eigenvectors(np.zeros((0, 3, 3)), np.zeros((0, 3))).shape == (0, 3)


def test_metrics_publish_the_shared_planarity():
    assert quality.quad_planarity is ms.quad_planarity
    assert quality.warping_height is ms.warping_height
    V, Q = quad_grid(5, 5, height=lambda x, y: 0.3 * x * y)
    np.testing.assert_array_equal(quality.planarity((V, Q)).planarity, ms.quad_planarity(V, Q))
    np.testing.assert_array_equal(quality.warping((V, Q)).warping, ms.warping_height(V, Q))


def test_metric_interior_angles_are_the_shared_corner_angles_made_reflex():
    V, Q = quad_grid(4, 4, height=lambda x, y: 0.4 * np.sin(4 * x) * y)
    ang, _ = quality.interior_angles(V, Q)
    np.testing.assert_array_equal(ang, ms.corner_angles(V, Q))  # all convex: identical numbers
    ang, _ = quality.interior_angles(L_HEXAGON, [[0, 1, 2, 3, 4, 5]])
    np.testing.assert_allclose(ang, [np.pi / 2] * 3 + [1.5 * np.pi] + [np.pi / 2] * 2, rtol=1e-15)
