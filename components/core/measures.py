"""One set of geometric measures on ``(V, F)`` arrays: vector algebra, corner angles, convexity, planarity.

Every other module takes these from here instead of keeping a private copy:

* row-wise vector algebra on ``(..., 3)`` arrays: :func:`cross`, :func:`dot`, :func:`norm`, :func:`unit`
  (plain elementwise formulas, faster than ``np.cross`` / ``np.einsum`` / ``np.linalg.norm`` on ``(n, 3)``
  arrays; :func:`unit` leaves zero rows zero);
* panel shape: :func:`corner_angles` (unsigned, radians, in :func:`components.core.mesh.face_corners` order),
  :func:`triangle_angles` (the same as a ``(t, 3)`` table for triangle arrays) and :func:`nonconvex_faces`;
* planarity: :func:`quad_planarity` (scale-free) and :func:`warping_height` (model units), with the pieces they
  are built from (:func:`face_data`, :func:`quad_diagonals`, :func:`least_squares_planes`,
  :func:`mean_edge_lengths`, :func:`smallest_eigenvectors`) for callers that report several measures at once.

Faces are padded polygon faces ``F (m, k)`` (short faces repeat their last vertex, see
:func:`components.core.mesh.face_sizes`). Nothing here validates its input; the published components check their
meshes once with :mod:`components.core.checks`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.core.mesh import face_corners, face_normals, face_sizes

__all__ = [
    "cross",
    "dot",
    "norm",
    "unit",
    "corner_angles",
    "triangle_angles",
    "nonconvex_faces",
    "FaceData",
    "face_data",
    "smallest_eigenvectors",
    "least_squares_planes",
    "mean_edge_lengths",
    "QuadDiagonals",
    "quad_diagonals",
    "quad_planarity",
    "max_quad_planarity",
    "warping_height",
]


# ----------------------------------------------------------------------------------------------
# row-wise vector algebra


def cross(a, b) -> np.ndarray:
    """Row-wise cross product of ``(..., 3)`` arrays (broadcasting like numpy).

    Parameters
    ----------
    a, b : (..., 3) array_like

    Returns
    -------
    (..., 3) ndarray
        ``a × b`` row by row, computed component by component (cheaper than ``np.cross`` on large arrays, and
        the same numbers).

    Example
    -------
    >>> cross([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], [[0.0, 1.0, 0.0], [0.0, 0.0, 3.0]])
    array([[ 0.,  0.,  1.],
           [ 0., -6.,  0.]])
    """
    a = np.asarray(a)
    b = np.asarray(b)
    if a.shape == b.shape and a.dtype == b.dtype:
        out = np.empty_like(a)
    else:
        out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def dot(a, b) -> np.ndarray:
    """Row-wise dot product of ``(..., 3)`` arrays (broadcasting like numpy).

    Parameters
    ----------
    a, b : (..., 3) array_like

    Returns
    -------
    (...) ndarray
        ``a0 b0 + a1 b1 + a2 b2`` row by row, summed in that order.

    Example
    -------
    >>> dot([[1.0, 2.0, 3.0], [1.0, 0.0, 0.0]], [[4.0, 5.0, 6.0], [0.0, 1.0, 0.0]])
    array([32.,  0.])
    """
    a = np.asarray(a)
    b = np.asarray(b)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm(a) -> np.ndarray:
    """Row-wise Euclidean length of a ``(..., 3)`` array: ``sqrt(dot(a, a))``.

    Example
    -------
    >>> norm([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    array([5., 0.])
    """
    return np.sqrt(dot(a, a))


def unit(a) -> np.ndarray:
    """Row-wise unit vectors of a ``(..., 3)`` array; zero rows stay zero (never NaN).

    Returns
    -------
    (..., 3) float64
        ``a / |a|`` row by row, 0 where ``|a| = 0``.

    Example
    -------
    >>> unit([[3.0, 0.0, 4.0], [0.0, 0.0, 0.0]])
    array([[0.6, 0. , 0.8],
           [0. , 0. , 0. ]])
    """
    a = np.asarray(a, dtype=np.float64)
    L = norm(a)[..., None]
    return np.divide(a, L, out=np.zeros_like(a), where=L > 0)


# ----------------------------------------------------------------------------------------------
# corner angles and convexity


def corner_angles(V, F) -> np.ndarray:
    """Unsigned angle between the two edges at every face corner, in radians.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, k) array_like of int
        Padded polygon faces.

    Returns
    -------
    (c,) float64
        One angle in ``[0, π]`` per corner, in :func:`components.core.mesh.face_corners` order (face by face,
        corner by corner): ``atan2(|a × b|, −a · b)`` with ``a = v − prev`` and ``b = next − v``. A reflex corner
        reads its unsigned angle (below π); see :func:`nonconvex_faces` for the turning direction.

    Example
    -------
    >>> V = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> bool(np.allclose(corner_angles(V, [[0, 1, 2, 3]]), np.pi / 2))
    True
    """
    C = face_corners(F)
    V = np.asarray(V, dtype=np.float64)
    a = V[C.v] - V[C.prev]
    b = V[C.next] - V[C.v]
    c = cross(a, b)
    return np.arctan2(np.sqrt(dot(c, c)), -dot(a, b))


def triangle_angles(V, T) -> np.ndarray:
    """Unsigned angle at the three corners of every triangle, in radians.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    T : (t, 3) array_like of int
        Triangles (a row may repeat a vertex: its angles are then 0 or π, never NaN).

    Returns
    -------
    (t, 3) float64
        ``out[i, j]``: the angle at corner ``T[i, j]``, the same numbers as :func:`corner_angles` (which reads
        ``T`` as padded faces).

    Example
    -------
    >>> V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    >>> np.degrees(triangle_angles(V, [[0, 1, 2]])).round(6)
    array([[90., 45., 45.]])
    """
    V = np.asarray(V, dtype=np.float64)
    P = V[np.asarray(T, dtype=np.int64)]
    a = P - np.roll(P, 1, axis=1)
    b = np.roll(P, -1, axis=1) - P
    c = cross(a, b)
    return np.arctan2(np.sqrt(dot(c, c)), -dot(a, b))


def nonconvex_faces(V, F) -> np.ndarray:
    """Faces with a reflex (or folded) corner.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, k) array_like of int
        Padded polygon faces.

    Returns
    -------
    (m,) bool
        A corner is convex when its turn ``(v − prev) × (next − v)`` points along the face's Newell normal; a face
        is non-convex when any corner turns the other way, or when the face has no normal at all (zero area).

    Example
    -------
    >>> L = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]], dtype=float)
    >>> nonconvex_faces(L, [[0, 1, 2, 3, 4, 5], [0, 1, 2, 2, 2, 2]])
    array([ True, False])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    C = face_corners(F)
    N = face_normals(V, F, unit=True)
    turn = cross(V[C.v] - V[C.prev], V[C.next] - V[C.v])
    bad = dot(turn, N[C.face]) <= 0.0
    out = np.zeros(len(F), dtype=bool)
    out[C.face[bad]] = True
    out |= ~np.any(N != 0.0, axis=1)
    return out


# ----------------------------------------------------------------------------------------------
# face data and least-squares planes


class FaceData(NamedTuple):
    """Per-call face data of a mesh (computed once per call and passed around; never cached between calls)."""

    sizes: np.ndarray  # (m,) corner count
    points: np.ndarray  # (m, k, 3) corner positions (padding repeats the last corner)
    valid: np.ndarray  # (m, k) bool, real corners
    area_vec: np.ndarray  # (m, 3) Newell area vectors


def face_data(V, F) -> FaceData:
    """Corner counts, corner positions, real-corner mask and Newell area vectors of every face.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    FaceData
        ``sizes (m,)``, ``points (m, k, 3)``, ``valid (m, k) bool``, ``area_vec (m, 3)``.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> fd = face_data(*quad_grid(2, 1, 2.0, 1.0)); fd.sizes.tolist(), fd.area_vec[:, 2].tolist()
    ([4, 4], [1.0, 1.0])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    k = F.shape[1]
    valid = np.arange(k)[None, :] < sizes[:, None]
    return FaceData(sizes, V[F], valid, face_normals(V, F, unit=False))


def smallest_eigenvectors(M, fallback) -> np.ndarray:
    """Unit eigenvector of the smallest eigenvalue of symmetric 3×3 matrices.

    Closed form (trigonometric solution of the characteristic cubic, then the largest cross product of two rows
    of ``M − λ I``), ~10× faster than batched ``eigh``.

    Parameters
    ----------
    M : (q, 3, 3) float64
        Symmetric matrices.
    fallback : (q, 3) float64
        Used where the eigenvector is not determined (isotropic or zero matrices).

    Returns
    -------
    (q, 3) float64
        Unit eigenvectors (sign arbitrary), or the ``fallback`` rows.

    Example
    -------
    >>> M = np.array([[[2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 1.0]]])
    >>> np.abs(smallest_eigenvectors(M, np.zeros((1, 3))))
    array([[0., 0., 1.]])
    """
    q = len(M)
    out = np.array(fallback, dtype=np.float64, copy=True)
    if q == 0:
        return out
    a, b, c = M[:, 0, 0], M[:, 1, 1], M[:, 2, 2]
    d, e, f = M[:, 0, 1], M[:, 0, 2], M[:, 1, 2]
    p1 = d * d + e * e + f * f
    tr = (a + b + c) / 3.0
    p2 = (a - tr) ** 2 + (b - tr) ** 2 + (c - tr) ** 2 + 2.0 * p1
    p = np.sqrt(p2 / 6.0)
    ok = p > 1e-300
    ps = np.where(ok, p, 1.0)
    Ba, Bb, Bc = (a - tr) / ps, (b - tr) / ps, (c - tr) / ps
    Bd, Be, Bf = d / ps, e / ps, f / ps
    detB = Ba * (Bb * Bc - Bf * Bf) - Bd * (Bd * Bc - Bf * Be) + Be * (Bd * Bf - Bb * Be)
    phi = np.arccos(np.clip(detB / 2.0, -1.0, 1.0)) / 3.0
    lam = tr + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    R = M - lam[:, None, None] * np.eye(3)[None]
    c01 = cross(R[:, 0], R[:, 1])
    c02 = cross(R[:, 0], R[:, 2])
    c12 = cross(R[:, 1], R[:, 2])
    C = np.stack([c01, c02, c12], axis=1)
    L = dot(C, C)
    j = np.argmax(L, axis=1)
    v = C[np.arange(q), j]
    nv = np.sqrt(L[np.arange(q), j])
    good = ok & (nv > 1e-300 * np.maximum(tr, 1e-300))
    out[good] = v[good] / nv[good, None]
    return out


def least_squares_planes(faces: FaceData, idx) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares planes of some faces (the planes minimising the squared corner distances).

    Parameters
    ----------
    faces : FaceData
        From :func:`face_data`.
    idx : (q,) int64
        The faces to fit.

    Returns
    -------
    centroid : (q, 3) float64
        Mean of the real corners.
    normal : (q, 3) float64
        Unit plane normal, oriented like the face's Newell normal.
    distances : (q, k) float64
        Signed corner distances to the plane (0 on padding), model units.

    Example
    -------
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    >>> c, n, d = least_squares_planes(face_data(V, [[0, 1, 2, 3]]), [0]); n.tolist(), d.tolist()
    ([[0.0, 0.0, 1.0]], [[0.0, 0.0, 0.0, 0.0]])
    """
    P = faces.points[idx]
    w = faces.valid[idx].astype(np.float64)
    s = faces.sizes[idx].astype(np.float64)
    c = np.einsum("qk,qkj->qj", w, P) / s[:, None]
    X = (P - c[:, None, :]) * w[..., None]
    M = np.einsum("qki,qkj->qij", X, X)
    A = faces.area_vec[idx]
    nA = norm(A)
    fallback = np.divide(A, nA[:, None], out=np.zeros_like(A), where=nA[:, None] > 0)
    n = smallest_eigenvectors(M, fallback)
    flip = dot(n, A) < 0
    n[flip] *= -1.0
    d = np.einsum("qkj,qj->qk", X, n) * w
    return c, n, d


def mean_edge_lengths(faces: FaceData, idx) -> np.ndarray:
    """Mean edge length ``(q,)`` of some faces, model units.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> mean_edge_lengths(face_data(*quad_grid(1, 1, 2.0, 4.0)), [0])
    array([3.])
    """
    idx = np.asarray(idx, dtype=np.int64)
    P = faces.points[idx]
    nxt = np.roll(P, -1, axis=1)
    s = faces.sizes[idx]
    nxt[np.arange(len(idx)), s - 1] = P[:, 0]
    L = norm(nxt - P) * faces.valid[idx]
    return L.sum(axis=1) / s


# ----------------------------------------------------------------------------------------------
# planarity


class QuadDiagonals(NamedTuple):
    """The two diagonals of some quads (see :func:`quad_diagonals`)."""

    gap: np.ndarray  # (q,) distance between the two diagonal lines, model units
    length_1: np.ndarray  # (q,) |v2 - v0|
    length_2: np.ndarray  # (q,) |v3 - v1|


def quad_diagonals(V, F, q) -> QuadDiagonals:
    """Distance between the two diagonal lines and the diagonal lengths of some quads.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.
    q : (q,) int64
        Indices of quad faces (the first four corners are used).

    Returns
    -------
    QuadDiagonals
        ``gap = |(d1 × d2)·(v1 − v0)| / |d1 × d2|`` (0 for parallel diagonals, which lie in one plane),
        ``length_1 = |d1|``, ``length_2 = |d2|`` with ``d1 = v2 − v0``, ``d2 = v3 − v1``; model units.

    Example
    -------
    >>> V = np.array([[0, 0, 0], [1, 0, 0.5], [1, 1, 0], [0, 1, 0.5]])
    >>> float(quad_diagonals(V, np.array([[0, 1, 2, 3]]), [0]).gap[0])
    0.5
    """
    Q = np.asarray(F, dtype=np.int64)[q]
    V = np.asarray(V, dtype=np.float64)
    v0, v1, v2, v3 = (V[Q[:, i]] for i in range(4))
    D1 = v2 - v0
    D2 = v3 - v1
    X = cross(D1, D2)
    nX = norm(X)
    h = np.abs(dot(X, v1 - v0))
    h = np.divide(h, nX, out=np.zeros_like(h), where=nX > 0)  # parallel diagonals lie in one plane
    return QuadDiagonals(h, norm(D1), norm(D2))


def quad_planarity(V, F) -> np.ndarray:
    """Scale-free planarity of every face: 0 for a planar face.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    (m,) float64
        Quads: distance between the two diagonal lines divided by the mean diagonal length,
        ``|(d1 × d2)·(v1 − v0)| / |d1 × d2| / ((|d1| + |d2|) / 2)`` with ``d1 = v2 − v0``, ``d2 = v3 − v1``
        (libigl's ``quad_planarity``, unsigned). Triangles: 0. n-gons (k ≥ 5): largest distance of a corner to
        the face's least-squares plane divided by the face's mean edge length. Unitless.

    Notes
    -----
    For quads this is exactly ``igl.quad_planarity`` (absolute value); the libigl binding returns it signed.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 2); quad_planarity(V, Q)
    array([0., 0., 0., 0.])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fd = face_data(V, F)
    out = np.zeros(len(F))
    q = np.nonzero(fd.sizes == 4)[0]
    if len(q):
        h, l1, l2 = quad_diagonals(V, F, q)
        out[q] = h / (0.5 * (l1 + l2))
    g = np.nonzero(fd.sizes >= 5)[0]
    if len(g):
        _, _, d = least_squares_planes(fd, g)
        out[g] = np.abs(d).max(axis=1) / mean_edge_lengths(fd, g)
    return out


def max_quad_planarity(V, F) -> float:
    """The largest :func:`quad_planarity` of the faces, 0.0 without faces.

    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 2); max_quad_planarity(V, Q), max_quad_planarity(V, Q[:0])
    (0.0, 0.0)
    """
    pl = quad_planarity(V, F)
    return float(pl.max()) if len(pl) else 0.0


def warping_height(V, F) -> np.ndarray:
    """Warping height of every face in model units: 0 for a planar face.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    (m,) float64
        Quads: the distance between the two diagonal lines (the height a flat panel must bend by),
        ``|(d1 × d2)·(v1 − v0)| / |d1 × d2|``. Triangles: 0. n-gons: the largest distance of a corner to the
        least-squares plane. Model units.

    Notes
    -----
    Kangaroo's planarity goal reports this absolute gap; :func:`quad_planarity` is it divided by the mean
    diagonal length.

    Example
    -------
    >>> V = np.array([[0, 0, 0], [1, 0, 0.2], [1, 1, 0], [0, 1, 0.2]])
    >>> warping_height(V, [[0, 1, 2, 3], [0, 1, 2, 2]]).round(12)
    array([0.2, 0. ])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fd = face_data(V, F)
    out = np.zeros(len(F))
    q = np.nonzero(fd.sizes == 4)[0]
    if len(q):
        out[q] = quad_diagonals(V, F, q).gap
    g = np.nonzero(fd.sizes >= 5)[0]
    if len(g):
        out[g] = np.abs(least_squares_planes(fd, g)[2]).max(axis=1)
    return out
