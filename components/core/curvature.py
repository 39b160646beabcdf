"""Principal, Gaussian and mean curvature of a triangle mesh, per vertex and per face.

The per-vertex estimator fits a height-field quadric ``z = a x² + b xy + c y² + d x + e y`` to the ``radius``-ring
of every vertex, in a local frame whose ``z`` axis is the angle-weighted vertex normal, and reads the shape
operator of the fitted graph at the vertex (first and second fundamental forms, so the slope terms ``d, e`` also
correct a tilted normal). Everything is vectorized: the rings come from powers of the sparse vertex adjacency, the
5×5 normal equations of all vertices are accumulated with segment sums and solved as one batch.

Sign convention (the same as libigl's ``principal_curvature``): a curvature is **positive where the surface bends
away from its normal**, so a sphere whose normals point outwards has ``k1 = k2 = +1/r`` and mean curvature
``+1/r``; flipping the orientation of the faces flips the signs of ``k1, k2`` and of the mean curvature (the
Gaussian curvature does not change). ``k1 ≥ k2`` always (signed), ``pd1`` is the direction of ``k1``.

Boundary vertices see a one-sided neighbourhood. The fit stays well posed there as long as the points are spread in
both tangent directions; vertices whose ring has too few points or whose normal equations are ill conditioned are
refitted on a wider ring (up to ``radius + 2``), and a small Tikhonov term keeps the remaining near-degenerate
systems solvable.

References
----------
D. Panozzo, E. Puppo, L. Rocca, "Efficient multi-scale curvature and crease estimation", GraVisMa 2010 (the
quadric fitting of libigl's ``principal_curvature``).
M. Meyer, M. Desbrun, P. Schröder, A. H. Barr, "Discrete differential-geometry operators for triangulated
2-manifolds", VisMath 2002 (angle defect, cotangent mean-curvature normal, mixed Voronoi areas).
G. Thürmer, C. A. Wüthrich, "Computing vertex normals from polygonal facets", JGT 3(1), 1998 (angle weights).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from components.core.checks import check_choice, check_int, check_mesh
from components.core.measures import cross, norm, triangle_angles, unit
from components.core.mesh import boundary_vertex_mask, triangulate
from components.core.types import Lines, Mesh, Numbers, Vectors

log = logging.getLogger(__name__)

__all__ = [
    "CurvatureResult",
    "face_principal_curvature",
    "gaussian_curvature",
    "mean_curvature",
    "principal_curvature",
    "vertex_normals",
    "vertex_principal_curvature",
]

_MIN_POINTS = 7  # neighbours needed for a 5-parameter fit with some redundancy


# ----------------------------------------------------------------------------------------------
# small vectorized helpers


def _tangent_frames(N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangent vectors ``(U, W)`` with ``U × W = N`` for unit normals ``N`` (zero rows get any frame)."""
    N = np.where(norm(N)[:, None] > 0, N, np.array([0.0, 0.0, 1.0]))
    axis = np.zeros_like(N)
    axis[np.arange(len(N)), np.argmin(np.abs(N), axis=1)] = 1.0
    U = unit(cross(N, axis))
    W = cross(N, U)
    return U, W


def _sym2_eig(a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Eigen-decomposition of symmetric 2×2 matrices ``[[a, b], [b, c]]``, largest eigenvalue first.

    Returns ``(l1, l2, x, y)``: eigenvalues ``l1 ≥ l2`` and the unit eigenvector ``(x, y)`` of ``l1`` (the one of
    ``l2`` is ``(-y, x)``).
    """
    half = 0.5 * (a - c)
    r = np.hypot(half, b)
    mid = 0.5 * (a + c)
    l1, l2 = mid + r, mid - r
    # eigenvector of l1: angle θ with tan 2θ = 2b / (a - c)
    theta = 0.5 * np.arctan2(b, half)
    return l1, l2, np.cos(theta), np.sin(theta)


def _triangles(mesh, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    V, F = check_mesh(mesh, name)
    T, J = triangulate(F)
    return V, F, T, J


# ----------------------------------------------------------------------------------------------
# normals and areas


def vertex_normals(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Angle-weighted unit vertex normals of a triangle mesh.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented.

    Returns
    -------
    (n, 3) float64
        Unit normals, each the sum of the incident face normals weighted by the corner angle (zero for unused
        vertices).

    Notes
    -----
    Thürmer & Wüthrich 1998. Independent of the tessellation of the one-ring, which matters for remeshed input.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> T, _ = triangulate(Q)  # a paraboloid of curvature 1 at its apex, vertex 60 = (1, 1, 0)
    >>> N = vertex_normals(V, T); (N[60].round(6) + 0.0).tolist()
    [0.0, 0.0, 1.0]
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    FN = unit(cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]))
    ang = triangle_angles(V, T)
    N = np.zeros_like(V)
    for i in range(3):
        for d in range(3):
            N[:, d] += np.bincount(T[:, i], weights=ang[:, i] * FN[:, d], minlength=len(V))
    return unit(N)


def _mixed_areas(V: np.ndarray, T: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """Mixed Voronoi area of every vertex (Meyer et al. 2002)."""
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    area = 0.5 * norm(cross(B - A, C - A))
    sq = np.stack([np.einsum("ij,ij->i", C - B, C - B),  # opposite corner 0
                   np.einsum("ij,ij->i", A - C, A - C),  # opposite corner 1
                   np.einsum("ij,ij->i", B - A, B - A)], axis=1)  # opposite corner 2
    with np.errstate(divide="ignore", invalid="ignore"):
        cot = np.cos(ang) / np.sin(ang)
    cot = np.nan_to_num(cot)
    obtuse = ang > 0.5 * np.pi
    any_obtuse = obtuse.any(axis=1)
    out = np.zeros(len(V))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        # Voronoi part of corner i: edges i-j (opposite k) and i-k (opposite j)
        vor = (sq[:, k] * cot[:, k] + sq[:, j] * cot[:, j]) / 8.0
        a = np.where(any_obtuse, np.where(obtuse[:, i], area / 2.0, area / 4.0), vor)
        out += np.bincount(T[:, i], weights=a, minlength=len(V))
    return out


# ----------------------------------------------------------------------------------------------
# neighbourhoods


def _edges(T: np.ndarray, n: int) -> np.ndarray:
    """Unique undirected edges ``(e, 2)`` of a triangle mesh, by their keys sorted (1-D keys, faster than a
    row-unique; a sort and a neighbour test, faster than ``np.unique``'s hash table on these keys)."""
    a = T.ravel()
    b = np.roll(T, -1, axis=1).ravel()
    key = np.sort(np.minimum(a, b) * n + np.maximum(a, b))
    if len(key):
        first = np.empty(len(key), dtype=bool)
        first[0] = True
        np.not_equal(key[1:], key[:-1], out=first[1:])
        key = key[first]
    return np.stack([key // n, key % n], axis=1)


def _adjacency(T: np.ndarray, n: int) -> sp.csr_matrix:
    E = _edges(T, n)
    data = np.ones(2 * len(E) + n, dtype=np.float32)
    rows = np.concatenate([E[:, 0], E[:, 1], np.arange(n)])
    cols = np.concatenate([E[:, 1], E[:, 0], np.arange(n)])
    A = sp.csr_matrix((data, (rows, cols)), shape=(n, n))
    A.data[:] = 1.0
    return A


def _ring_pairs(A1: sp.csr_matrix, R: sp.csr_matrix, radius: int) -> sp.csr_matrix:
    """Grow the ring matrix ``R`` (rows: vertices, columns: vertices within some ring) to ``radius`` rings."""
    for _ in range(radius):
        R = R @ A1
        R.data[:] = 1.0
    return R


# ----------------------------------------------------------------------------------------------
# quadric fit


def _fit_shape_operators(V, N, U, W, R: sp.csr_matrix, rows: np.ndarray):
    """Fit the quadric for the vertices ``rows`` over their neighbours in ``R`` (restricted to those rows).

    Returns per row the symmetric shape operator ``(s11, s12, s22)`` in the orthonormal tangent basis ``(t1, t2)``
    of the fitted graph (3D vectors), and a conditioning flag (False = ill posed).
    """
    Rs = R[rows]
    Rs.sort_indices()
    indptr, nb = Rs.indptr, Rs.indices
    counts = np.diff(indptr)
    owner = np.repeat(np.arange(len(rows)), counts)
    vi = rows[owner]
    D = V[nb] - V[vi]
    x = np.einsum("ij,ij->i", D, U[vi])
    y = np.einsum("ij,ij->i", D, W[vi])
    z = np.einsum("ij,ij->i", D, N[vi])
    # scale every neighbourhood to unit size for conditioning
    r2 = x * x + y * y
    starts = indptr[:-1]
    nonempty = counts > 0
    scale = np.ones(len(rows))
    if len(r2):
        s2 = np.maximum.reduceat(r2, starts[nonempty])
        scale[nonempty] = np.sqrt(np.maximum(s2, 1e-300))
    sx = scale[owner]
    x, y, z = x / sx, y / sx, z / sx
    cols = (x * x, x * y, y * y, x, y)
    M = np.zeros((len(rows), 5, 5))
    b = np.zeros((len(rows), 5))

    def seg(vals):
        out = np.zeros(len(rows))
        if len(vals):
            out[nonempty] = np.add.reduceat(vals, starts[nonempty])
        return out

    for i in range(5):
        b[:, i] = seg(cols[i] * z)
        for j in range(i, 5):
            M[:, i, j] = M[:, j, i] = seg(cols[i] * cols[j])
    tr = np.trace(M, axis1=1, axis2=2)
    ok = counts >= 5
    # conditioning: the neighbours must spread in both tangent directions (second moments of x, y)
    _, small, _, _ = _sym2_eig(M[:, 3, 3], M[:, 3, 4], M[:, 4, 4])
    ok &= small > 0.02 * np.maximum(M[:, 3, 3] + M[:, 4, 4], 1e-300)
    reg = 1e-9 * np.maximum(tr, 1e-12)
    M = M + reg[:, None, None] * np.eye(5)[None]
    coef = np.linalg.solve(M, b[..., None])[..., 0]
    a2, bb, c2, d, e = coef.T
    # undo the scaling: z/s = a (x/s)² ... → second-order coefficients divide by s, slopes unchanged
    a2, bb, c2 = a2 / scale, bb / scale, c2 / scale
    # graph r(x, y) = (x, y, f): first form I, second form II (w.r.t. the normal along +z of the fit)
    Wn = np.sqrt(1.0 + d * d + e * e)
    E_, F_, G_ = 1.0 + d * d, d * e, 1.0 + e * e
    L_, M_, N_ = 2.0 * a2 / Wn, bb / Wn, 2.0 * c2 / Wn
    # Cholesky of I = Rᵀ R with R upper triangular [[r11, r12], [0, r22]]
    r11 = np.sqrt(E_)
    r12 = F_ / r11
    r22 = np.sqrt(np.maximum(G_ - r12 * r12, 1e-300))
    # S_sym = R^{-T} II R^{-1}; R^{-1} = [[1/r11, -r12/(r11 r22)], [0, 1/r22]]
    i11, i12, i22 = 1.0 / r11, -r12 / (r11 * r22), 1.0 / r22
    # II R^{-1}
    p11 = L_ * i11
    p12 = L_ * i12 + M_ * i22
    p22 = M_ * i12 + N_ * i22
    s11 = i11 * p11
    s12 = i11 * p12
    s22 = i12 * p12 + i22 * p22
    # tangent basis J R^{-1} in 3D: r_x = U + d N, r_y = W + e N
    ux = U[rows] + d[:, None] * N[rows]
    uy = W[rows] + e[:, None] * N[rows]
    t1 = i11[:, None] * ux
    t2 = i12[:, None] * ux + i22[:, None] * uy
    # the curvature sign convention: positive where the surface bends away from the normal → negate II
    return -s11, -s12, -s22, t1, t2, ok


def vertex_principal_curvature(V: np.ndarray, T: np.ndarray, radius: int = 2):
    """Principal curvature directions and values at every vertex, by quadric fitting on a ``radius``-ring.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented, edge-manifold (open boundaries and holes are fine).
    radius : int
        Number of edge rings in the fitting neighbourhood (≥ 1; 2 is a good default, larger smooths more).

    Returns
    -------
    PD1 : (n, 3) float64
        Unit direction of maximal (signed) curvature, tangent to the fitted surface.
    PD2 : (n, 3) float64
        Unit direction of minimal curvature; ``PD1 × PD2`` is the fitted normal.
    PV1 : (n,) float64
        Maximal curvature ``k1``.
    PV2 : (n,) float64
        Minimal curvature ``k2 ≤ k1``.

    Raises
    ------
    InputError
        If ``radius`` is not a positive integer.

    Notes
    -----
    Quadric fitting as in Panozzo, Puppo & Rocca 2010 (libigl's ``principal_curvature``), with the slope terms of the
    fit used in the fundamental forms. Vertices with fewer than 7 ring neighbours or neighbours not spread in both
    tangent directions (corners of an open boundary, slivers) are refitted on up to two more rings; so ``radius=1``
    behaves like 2 on a regular mesh, as in libigl. The quadric misses the quartic terms of the surface: on a sphere
    the error grows with the ring (≈1% at radius 2, 2.5% at radius 3 for 7.5° edges) and is about 2.5× larger on a
    one-sided boundary ring, like libigl's. Positive curvature bends away from the
    normal (a sphere with outward normals has ``k1 = k2 = 1/r``). Unused vertices get zero curvature.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> T, _ = triangulate(Q)  # a paraboloid of curvature 1 at its apex, vertex 60 = (1, 1, 0)
    >>> PD1, PD2, PV1, PV2 = vertex_principal_curvature(V, T, radius=2)
    >>> round(float(PV1[60]), 6), round(float(PV2[60]), 6)  # bends towards its +z normals: negative
    (-1.0, -1.0)
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    radius = check_int(radius, "radius", lo=1)
    n = len(V)
    N = vertex_normals(V, T)
    U, W = _tangent_frames(N)
    A1 = _adjacency(T, n)
    R = _ring_pairs(A1, A1, radius - 1)
    rows = np.arange(n)
    counts = np.diff(R.indptr) - 1  # minus the vertex itself
    s11 = np.zeros(n)
    s12 = np.zeros(n)
    s22 = np.zeros(n)
    T1 = np.zeros((n, 3))
    T2 = np.zeros((n, 3))
    todo = rows[counts >= 1]
    wider = 0
    while True:
        f11, f12, f22, t1, t2, ok = _fit_shape_operators(V, N, U, W, R, todo)
        good = ok & (counts[todo] >= _MIN_POINTS)
        last = wider == 2
        keep = np.ones_like(good) if last else good
        idx = todo[keep]
        s11[idx], s12[idx], s22[idx] = f11[keep], f12[keep], f22[keep]
        T1[idx], T2[idx] = t1[keep], t2[keep]
        todo = todo[~keep]
        if len(todo) == 0 or last:
            break
        wider += 1
        R = _ring_pairs(A1, R, 1)
        counts = np.diff(R.indptr) - 1
    l1, l2, cx, cy = _sym2_eig(s11, s12, s22)
    PD1 = unit(cx[:, None] * T1 + cy[:, None] * T2)
    PD2 = unit(-cy[:, None] * T1 + cx[:, None] * T2)
    unused = np.ones(n, dtype=bool)
    unused[T.ravel()] = False
    if unused.any():
        l1[unused] = l2[unused] = 0.0
        PD1[unused], PD2[unused] = U[unused], W[unused]
    return PD1, PD2, l1, l2


def face_principal_curvature(V: np.ndarray, T: np.ndarray, PD1, PD2, PV1, PV2):
    """Per-face principal curvatures: the corner shape tensors averaged and projected into the face plane.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles.
    PD1, PD2 : (n, 3) float64
        Per-vertex principal directions (from :func:`vertex_principal_curvature`).
    PV1, PV2 : (n,) float64
        Per-vertex principal curvatures.

    Returns
    -------
    FD1 : (t, 3) float64
        Unit direction of maximal curvature in the face plane.
    FD2 : (t, 3) float64
        Unit direction of minimal curvature, ``face normal × FD1``.
    FV1 : (t,) float64
        Maximal curvature.
    FV2 : (t,) float64
        Minimal curvature.

    Notes
    -----
    Each vertex tensor ``k1 d1 d1ᵀ + k2 d2 d2ᵀ`` is expressed in the face's orthonormal frame (the projection is a
    rotation-free restriction, adequate when corner normals are close to the face normal), the three are averaged and
    diagonalized.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> T, _ = triangulate(Q)  # a paraboloid of curvature 1 at its apex, vertex 60 = (1, 1, 0)
    >>> FD1, FD2, FV1, FV2 = face_principal_curvature(V, T, *vertex_principal_curvature(V, T))
    >>> FD1.shape, bool(np.all(FV1 >= FV2))
    ((200, 3), True)
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    FN = unit(cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]))
    U, W = _tangent_frames(FN)
    a = np.zeros(len(T))
    b = np.zeros(len(T))
    c = np.zeros(len(T))
    for i in range(3):
        v = T[:, i]
        for D, K in ((PD1[v], PV1[v]), (PD2[v], PV2[v])):
            # project the direction into the face plane and renormalize so the tensor keeps its trace
            du = np.einsum("ij,ij->i", D, U)
            dw = np.einsum("ij,ij->i", D, W)
            nrm = np.hypot(du, dw)
            nrm = np.where(nrm > 0, nrm, 1.0)
            du, dw = du / nrm, dw / nrm
            a += K * du * du
            b += K * du * dw
            c += K * dw * dw
    a, b, c = a / 3.0, b / 3.0, c / 3.0
    l1, l2, cx, cy = _sym2_eig(a, b, c)
    FD1 = unit(cx[:, None] * U + cy[:, None] * W)
    FD2 = cross(FN, FD1)
    return FD1, FD2, l1, l2


def gaussian_curvature(V: np.ndarray, T: np.ndarray, method: str = "fit", radius: int = 2) -> np.ndarray:
    """Gaussian curvature per vertex.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles.
    method : {"fit", "discrete"}
        ``"fit"``: ``k1·k2`` of the quadric fit (:func:`vertex_principal_curvature`). ``"discrete"``: angle defect
        ``(2π − Σθ) / A_mixed`` (Meyer et al. 2002); at boundary vertices the angle defect measures the boundary's
        geodesic turning, not the surface, so the fitted value is used there.
    radius : int
        Ring size of the fit.

    Returns
    -------
    (n,) float64
        Gaussian curvature (orientation-independent), in 1/length².

    Raises
    ------
    InputError
        Unknown ``method`` or bad ``radius``.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> T, _ = triangulate(Q)  # a paraboloid of curvature 1 at its apex, vertex 60 = (1, 1, 0)
    >>> K = gaussian_curvature(V, T, method="discrete"); round(float(K[60]), 2)
    0.99
    """
    check_choice(method, "method", ("fit", "discrete"))
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    _, _, k1, k2 = vertex_principal_curvature(V, T, radius=radius)
    K = k1 * k2
    if method == "discrete":
        ang = triangle_angles(V, T)
        total = np.zeros(len(V))
        for i in range(3):
            total += np.bincount(T[:, i], weights=ang[:, i], minlength=len(V))
        area = _mixed_areas(V, T, ang)
        inner = ~boundary_vertex_mask(T, len(V)) & (area > 0)
        K = K.copy()
        K[inner] = (2.0 * np.pi - total[inner]) / area[inner]
    return K


def mean_curvature(V: np.ndarray, T: np.ndarray, method: str = "fit", radius: int = 2) -> np.ndarray:
    """Signed mean curvature per vertex.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented.
    method : {"fit", "discrete"}
        ``"fit"``: ``(k1 + k2) / 2`` of the quadric fit. ``"discrete"``: half the cotangent Laplacian of the
        positions over the mixed area, signed against the angle-weighted normal (Meyer et al. 2002); the fitted value
        is used at boundary vertices, where the discrete operator is not a curvature.
    radius : int
        Ring size of the fit.

    Returns
    -------
    (n,) float64
        Mean curvature, positive where the surface bends away from its normal (sphere, outward normals: ``1/r``).

    Raises
    ------
    InputError
        Unknown ``method`` or bad ``radius``.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> T, _ = triangulate(Q)  # a paraboloid of curvature 1 at its apex, vertex 60 = (1, 1, 0)
    >>> H = mean_curvature(V, T); round(float(H[60]), 6)
    -1.0
    """
    check_choice(method, "method", ("fit", "discrete"))
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    _, _, k1, k2 = vertex_principal_curvature(V, T, radius=radius)
    H = 0.5 * (k1 + k2)
    if method == "discrete":
        ang = triangle_angles(V, T)
        with np.errstate(divide="ignore", invalid="ignore"):
            cot = np.nan_to_num(np.cos(ang) / np.sin(ang))
        LV = np.zeros_like(V)
        for i in range(3):
            j, k = (i + 1) % 3, (i + 2) % 3
            # edge j-k is opposite corner i: contributes cot_i (x_k - x_j) to j and the reverse to k
            d = V[T[:, k]] - V[T[:, j]]
            w = 0.5 * cot[:, i][:, None] * d
            for dim in range(3):
                LV[:, dim] += np.bincount(T[:, j], weights=w[:, dim], minlength=len(V))
                LV[:, dim] -= np.bincount(T[:, k], weights=w[:, dim], minlength=len(V))
        area = _mixed_areas(V, T, ang)
        N = vertex_normals(V, T)
        inner = ~boundary_vertex_mask(T, len(V)) & (area > 0)
        Hn = LV[inner] / area[inner, None]  # = -2 H n for our convention
        H = H.copy()
        H[inner] = -0.5 * np.einsum("ij,ij->i", Hn, N[inner])
    return H


# ----------------------------------------------------------------------------------------------
# published component


class CurvatureResult(NamedTuple):
    pd1: Vectors
    pd2: Vectors
    k1: Numbers
    k2: Numbers
    gaussian: Numbers
    mean: Numbers
    lines1: Lines
    lines2: Lines


def principal_curvature(mesh: Mesh, radius: int = 2) -> CurvatureResult:
    """Principal curvature directions and values, Gaussian and mean curvature at every vertex of a mesh.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``: triangles or polygons (fan-triangulated), open boundaries and holes allowed.
    radius : int
        Size of the fitting neighbourhood in edge rings (1–6; 2 is the default, larger smooths noise).

    Returns
    -------
    pd1 : Vectors
        Unit direction of maximal curvature at every vertex.
    pd2 : Vectors
        Unit direction of minimal curvature at every vertex.
    k1 : Numbers
        Maximal principal curvature (1/model units); positive where the surface bends away from the mesh normal.
    k2 : Numbers
        Minimal principal curvature (``k2 ≤ k1``).
    gaussian : Numbers
        Gaussian curvature ``k1·k2``.
    mean : Numbers
        Mean curvature ``(k1 + k2) / 2``.
    lines1 : Lines
        Short segments along ``pd1`` centred at the vertices (length: mean edge length), for display.
    lines2 : Lines
        Short segments along ``pd2`` centred at the vertices.

    Raises
    ------
    MeshError
        The mesh is malformed, degenerate or non-manifold.
    InputError
        ``radius`` is out of range.

    Notes
    -----
    Quadric fitting on the ``radius``-ring (Panozzo, Puppo & Rocca 2010, as libigl's ``principal_curvature``), with a
    wider ring where an open boundary leaves too few neighbours. See :mod:`components.core.curvature`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(10, 10, 2.0, 2.0, height=lambda x, y: 0.5 * ((x - 1) ** 2 + (y - 1) ** 2))
    >>> res = principal_curvature((V, F), radius=2)
    >>> res.k1.shape == (len(V),), round(float(res.gaussian[60]), 6)
    (True, 1.0)
    """
    V, F, T, _ = _triangles(mesh, "mesh")
    radius = check_int(radius, "radius", 1, 6)
    PD1, PD2, k1, k2 = vertex_principal_curvature(V, T, radius=radius)
    E = _edges(T, len(V))
    h = 0.5 * float(np.mean(norm(V[E[:, 1]] - V[E[:, 0]])))
    lines1 = np.stack([V - h * PD1, V + h * PD1], axis=1)
    lines2 = np.stack([V - h * PD2, V + h * PD2], axis=1)
    return CurvatureResult(PD1, PD2, k1, k2, k1 * k2, 0.5 * (k1 + k2), lines1, lines2)
