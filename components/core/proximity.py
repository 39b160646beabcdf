"""Closest points on a triangle mesh and on a polyline: exact, vectorized, with a real spatial index.

Used by the quality metrics (closeness to a reference surface), the planarization solver (closeness goal: build
the index once, query it every iteration) and the subdivision step (pull points back onto the surface).

How it works
------------
Every primitive (triangle or segment) is covered by *sample points*: its centroid, or, for primitives much
larger than the typical one, the centroids of a regular subdivision into ``n²`` similar sub-triangles (``n``
sub-segments). Each sample ``s`` carries a radius ``ρ_s`` such that every point of the part of the primitive it
stands for lies within ``ρ_s`` of ``s`` (the circumradius about the centroid of a sub-triangle, half a
sub-segment). A :class:`scipy.spatial.cKDTree` holds the samples.

A query point ``p`` takes its ``k`` nearest samples, computes the exact distance to their primitives (Ericson's
Voronoi-region method for triangles, a clamped projection for segments) and keeps the smallest, ``d``. Any
primitive closer than ``d`` has some sample within ``d + ρ_max`` of ``p`` (triangle inequality), so when the
``k``-th nearest sample is farther than ``d + ρ_max`` no unseen primitive can win and the answer is exact;
otherwise ``k`` grows (×4) for that point only. The answer is therefore the exact minimum over all primitives,
not an approximation, whatever the triangle sizes.

References
----------
C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, §5.1.5 (closest point on a triangle).
J. A. Bærentzen, H. Aanæs, "Signed distance computation using the angle weighted pseudonormal", IEEE TVCG 11(3),
2005 (sign from face / edge / vertex pseudo-normals).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.core.checks import check_points, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.measures import cross, triangle_angles, unit
from components.core.mesh import edge_topology, halfedges

log = logging.getLogger(__name__)

__all__ = [
    "ClosestPoints",
    "PolylineClosestPoints",
    "TriangleIndex",
    "PolylineIndex",
    "closest_points",
    "closest_points_on_polyline",
    "closest_points_on_triangles",
]

_CHUNK = 65536  # query points processed together
_PAIRS = 1 << 20  # point-primitive pairs evaluated together (bounds the temporary arrays)
_MAX_LEVEL = 64  # largest subdivision of a single primitive into sample cells


class ClosestPoints(NamedTuple):
    """Result of a closest-point query on a triangle mesh.

    ``points (p, 3)`` closest points, ``distances (p,)`` Euclidean distances (signed when asked: positive on the
    side the normals point to), ``faces (p,)`` index of the triangle holding each closest point,
    ``barycentric (p, 3)`` its barycentric coordinates in that triangle (corners in ``T`` order).
    """

    points: np.ndarray
    distances: np.ndarray
    faces: np.ndarray
    barycentric: np.ndarray


class PolylineClosestPoints(NamedTuple):
    """Result of a closest-point query on a polyline.

    ``points (p, 3)``, ``distances (p,)``, ``segments (p,)`` index ``i`` of the segment from vertex ``i`` to
    vertex ``i + 1`` (the closing segment of a closed polyline is ``n - 1``), ``t (p,)`` the parameter in
    ``[0, 1]`` along that segment.
    """

    points: np.ndarray
    distances: np.ndarray
    segments: np.ndarray
    t: np.ndarray


# ----------------------------------------------------------------------------------------------
# exact kernels


def closest_points_on_triangles(P, A, B, C) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest point of each point ``P[i]`` on the triangle ``(A[i], B[i], C[i])`` (row-wise pairs).

    Parameters
    ----------
    P, A, B, C : (q, 3) float64
        Query points and triangle corners, paired row by row.

    Returns
    -------
    sqdist : (q,) float64
        Squared distances.
    bary : (q, 3) float64
        Barycentric coordinates of the closest points (they sum to 1).
    region : (q,) int8
        Voronoi region of the closest point: 0 interior, 1/2/3 corner A/B/C, 4/5/6 edge AB/BC/CA.

    Notes
    -----
    Ericson's region method (Real-Time Collision Detection, §5.1.5), vectorized; zero-area triangles (collinear
    or repeated corners) are handled as the union of their three edges.
    """
    P = np.asarray(P, dtype=np.float64)
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    C = np.asarray(C, dtype=np.float64)
    ab = B - A
    ac = C - A
    ap = P - A
    bp = P - B
    cp = P - C
    d1 = np.einsum("ij,ij->i", ab, ap)
    d2 = np.einsum("ij,ij->i", ac, ap)
    d3 = np.einsum("ij,ij->i", ab, bp)
    d4 = np.einsum("ij,ij->i", ac, bp)
    d5 = np.einsum("ij,ij->i", ab, cp)
    d6 = np.einsum("ij,ij->i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2

    in_a = (d1 <= 0) & (d2 <= 0)
    in_b = (d3 >= 0) & (d4 <= d3)
    in_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    in_c = (d6 >= 0) & (d5 <= d6)
    in_ca = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    in_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)

    q = len(P)
    region = np.zeros(q, dtype=np.int8)
    # assign in reverse priority so the first matching test of Ericson's order wins
    region[in_bc] = 6
    region[in_ca] = 5  # temporarily: AC edge
    region[in_c] = 3
    region[in_ab] = 4
    region[in_b] = 2
    region[in_a] = 1

    bary = np.empty((q, 3), dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        # interior
        denom = va + vb + vc
        v = vb / denom
        w = vc / denom
        bary[:, 0] = 1.0 - v - w
        bary[:, 1] = v
        bary[:, 2] = w
        r = region == 1
        bary[r] = (1.0, 0.0, 0.0)
        r = region == 2
        bary[r] = (0.0, 1.0, 0.0)
        r = region == 3
        bary[r] = (0.0, 0.0, 1.0)
        r = region == 4
        t = d1[r] / (d1[r] - d3[r])
        bary[r, 0] = 1.0 - t
        bary[r, 1] = t
        bary[r, 2] = 0.0
        r = region == 5  # edge AC
        t = d2[r] / (d2[r] - d6[r])
        bary[r, 0] = 1.0 - t
        bary[r, 1] = 0.0
        bary[r, 2] = t
        r = region == 6
        t = (d4[r] - d3[r]) / ((d4[r] - d3[r]) + (d5[r] - d6[r]))
        bary[r, 0] = 0.0
        bary[r, 1] = 1.0 - t
        bary[r, 2] = t
    # region codes: report edges as AB=4, BC=5, CA=6
    code = region.copy()
    code[region == 5] = 6
    code[region == 6] = 5

    # zero-area triangles (or any numerically broken case): fall back to the three edges
    bad = ~np.isfinite(bary).all(axis=1)
    cross = np.cross(ab, ac)
    area2 = np.einsum("ij,ij->i", cross, cross)
    scale = np.maximum(np.einsum("ij,ij->i", ab, ab), np.einsum("ij,ij->i", ac, ac))
    bad |= area2 <= 1e-24 * scale * scale
    if bad.any():
        bary[bad], code[bad] = _closest_on_triangle_edges(P[bad], A[bad], B[bad], C[bad])
    X = bary[:, 0:1] * A + bary[:, 1:2] * B + bary[:, 2:3] * C
    D = P - X
    sqdist = np.einsum("ij,ij->i", D, D)
    return sqdist, bary, code


def _segment_parameter(P, A, B):
    """Parameter ``t ∈ [0, 1]`` of the closest point of ``P`` on segment ``AB`` (0 for zero-length segments)."""
    AB = B - A
    L2 = np.einsum("ij,ij->i", AB, AB)
    num = np.einsum("ij,ij->i", P - A, AB)
    t = np.divide(num, L2, out=np.zeros_like(num), where=L2 > 0)
    return np.clip(t, 0.0, 1.0)


def _closest_on_triangle_edges(P, A, B, C):
    """Barycentric coordinates and region code of the closest point on the three edges of each triangle."""
    q = len(P)
    best = np.full(q, np.inf)
    bary = np.zeros((q, 3))
    code = np.zeros(q, dtype=np.int8)
    for (X, Y, i, j, ecode) in ((A, B, 0, 1, 4), (B, C, 1, 2, 5), (C, A, 2, 0, 6)):
        t = _segment_parameter(P, X, Y)
        Q = X + t[:, None] * (Y - X)
        d = np.einsum("ij,ij->i", P - Q, P - Q)
        better = d < best
        best[better] = d[better]
        b = np.zeros((better.sum(), 3))
        b[:, i] = 1.0 - t[better]
        b[:, j] = t[better]
        bary[better] = b
        c = np.full(better.sum(), ecode, dtype=np.int8)
        c[t[better] == 0.0] = i + 1
        c[t[better] == 1.0] = j + 1
        code[better] = c
    return bary, code


# ----------------------------------------------------------------------------------------------
# sample-point index with a certified candidate radius


class _SampleIndex:
    """k-d tree over sample points standing for primitives, each sample within ``radius`` of its primitive part."""

    def __init__(self, samples: np.ndarray, owner: np.ndarray, sample_radius: np.ndarray):
        self.tree = cKDTree(samples, balanced_tree=False, compact_nodes=False)
        self.owner = owner
        self.sample_radius = np.asarray(sample_radius, dtype=np.float64)
        self.radius = float(self.sample_radius.max()) if len(self.sample_radius) else 0.0
        self.size = len(samples)

    def nearest(self, P: np.ndarray, exact, n_primitives: int, k0: int = 8):
        """Exact nearest primitive of every point of ``P``.

        ``exact(pi, prim)`` returns ``(sqdist, extra)`` for the row-wise pairs of point indices ``pi`` into ``P``
        and primitive indices ``prim``; ``extra`` is a tuple of arrays indexed like the pairs.
        Returns ``(best_prim (p,), sqdist (p,), extras)`` with ``extras`` the selected pairs' extra arrays.

        The candidate count ``k`` grows ×4 for the points whose certificate fails; points that would need more
        than half of all samples (e.g. the centre of a finely meshed sphere, equidistant from everything) are
        compared with every primitive instead. Work is done in batches of at most ``_PAIRS`` pairs.
        """
        p = len(P)
        best = np.full(p, -1, dtype=np.int64)
        best_d2 = np.full(p, np.inf)
        extras = None

        def update(rows, prims, d2, extra):
            nonlocal extras
            # rows (q,), prims (q, c), d2 (q, c)
            q, c = prims.shape
            j = np.argmin(d2, axis=1)
            r = np.arange(q)
            d2min = d2[r, j]
            if extras is None:
                extras = tuple(np.empty((p,) + e.shape[1:], dtype=e.dtype) for e in extra)
            improve = d2min < best_d2[rows]
            tgt = rows[improve]
            best[tgt] = prims[r, j][improve]
            best_d2[tgt] = d2min[improve]
            sel = (r * c + j)[improve]
            for E, e in zip(extras, extra):
                E[tgt] = e[sel]

        todo = np.arange(p)
        k_done = 0
        k = min(k0, self.size)
        while len(todo) and 2 * k <= self.size:
            failed = []
            step = max(1, _PAIRS // k)
            for s in range(0, len(todo), step):
                rows = todo[s:s + step]
                dist, idx = self.tree.query(P[rows], k=k)
                if k == 1:
                    dist, idx = dist[:, None], idx[:, None]
                if k_done == 0:  # an upper bound from the nearest sample's primitive
                    prim0 = self.owner[idx[:, :1]]
                    d2, extra = exact(rows, prim0[:, 0])
                    update(rows, prim0, d2[:, None], extra)
                    start = 1
                else:
                    start = k_done
                # exact distances only where the sample's lower bound |p - s| - r_s beats the best so far
                lb = dist[:, start:] - self.sample_radius[idx[:, start:]]
                ub = np.sqrt(best_d2[rows])
                cand = lb < ub[:, None] * (1.0 + 1e-12)
                r_i, c_i = np.nonzero(cand)
                if len(r_i):
                    prim = self.owner[idx[:, start:]]
                    d2, extra = exact(rows[r_i], prim[r_i, c_i])
                    D2 = np.full(cand.shape, np.inf)
                    D2[r_i, c_i] = d2
                    # map the evaluated pairs' extras to a dense (row, column) layout for update()
                    pos = np.full(cand.shape, 0, dtype=np.int64)
                    pos[r_i, c_i] = np.arange(len(r_i))
                    j = np.argmin(D2, axis=1)
                    rr = np.arange(len(rows))
                    has = np.isfinite(D2[rr, j])
                    sel = pos[rr, j][has]
                    update(rows[has], prim[rr, j][has][:, None], D2[rr, j][has][:, None],
                           tuple(e[sel] for e in extra))
                bound = (np.sqrt(best_d2[rows]) + self.radius) * (1.0 + 1e-12)
                failed.append(rows[~(dist[:, -1] > bound)])
            todo = np.concatenate(failed)
            k_done = k
            k = min(4 * k, self.size)
        if len(todo):
            log.debug("%d query points compared with all %d primitives", len(todo), n_primitives)
            step = max(1, _PAIRS // n_primitives)
            allp = np.arange(n_primitives)
            for s in range(0, len(todo), step):
                rows = todo[s:s + step]
                prim = np.broadcast_to(allp, (len(rows), n_primitives))
                d2, extra = exact(np.repeat(rows, n_primitives), prim.ravel())
                update(rows, prim, d2.reshape(prim.shape), extra)
        return best, best_d2, extras


def _triangle_samples(A, B, C, target: float):
    """Sample points (sub-triangle centroids) covering each triangle, their owners and covering radii."""
    G = (A + B + C) / 3.0
    r = np.sqrt(np.max(np.stack([np.einsum("ij,ij->i", X - G, X - G) for X in (A, B, C)], axis=1), axis=1))
    if target <= 0 or not np.isfinite(target):
        level = np.ones(len(A), dtype=np.int64)
    else:
        level = np.clip(np.ceil(r / target), 1, _MAX_LEVEL).astype(np.int64)
    samples = [G[level == 1]]
    owner = [np.nonzero(level == 1)[0]]
    radius = [r[level == 1]]
    for n in np.unique(level[level > 1]):
        tri = np.nonzero(level == n)[0]
        # barycentric (i, j) offsets of the n² sub-triangle centroids, in units of 1/n
        I, J = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        up = (I + J) <= n - 1
        dn = (I + J) <= n - 2
        u = np.concatenate([I[up] + 1 / 3, I[dn] + 2 / 3]) / n
        v = np.concatenate([J[up] + 1 / 3, J[dn] + 2 / 3]) / n
        a, ab, ac = A[tri], B[tri] - A[tri], C[tri] - A[tri]
        S = a[:, None, :] + u[None, :, None] * ab[:, None, :] + v[None, :, None] * ac[:, None, :]
        samples.append(S.reshape(-1, 3))
        owner.append(np.repeat(tri, len(u)))
        radius.append(np.repeat(r[tri] / n, len(u)))
    return np.concatenate(samples), np.concatenate(owner), np.concatenate(radius)


# ----------------------------------------------------------------------------------------------
# triangle mesh


class TriangleIndex:
    """A spatial index over a triangle mesh answering exact closest-point queries; build once, query many.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles. Zero-area triangles are allowed (treated as their edges); polygon meshes must be
        triangulated first (:func:`components.core.mesh.triangulate` gives the face map ``J``).
    name : str
        Name of the input in error messages.

    Attributes
    ----------
    oriented : bool
        True when the mesh is an edge-manifold, consistently oriented surface: signed distances are then
        available (sign from the angle-weighted pseudo-normals of Bærentzen & Aanæs 2005).

    Raises
    ------
    MeshError
        Bad shapes, NaN coordinates, indices out of range, empty mesh.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4)  # the unit square in the z = 0 plane, normals +z
    >>> index = TriangleIndex(V, triangulate(Q)[0])
    >>> P = np.array([[0.3, 0.6, 2.0], [0.5, 0.5, -1.0]])
    >>> res = index.query(P)             # res.points, res.distances, res.faces, res.barycentric
    >>> res.points.round(12).tolist(), res.distances.tolist()
    ([[0.3, 0.6, 0.0], [0.5, 0.5, 0.0]], [2.0, 1.0])
    >>> index.query(P, signed=True).distances.tolist()
    [2.0, -1.0]
    """

    def __init__(self, V, T, name: str = "mesh"):
        V, T = validate_mesh(V, T, name=name, allow_degenerate=True, manifold=False)
        if T.shape[1] != 3:
            raise MeshError(name, f"a triangle array (t, 3) is required, got {T.shape}; triangulate polygons first")
        self.V = V
        self.T = T
        self.A = np.ascontiguousarray(V[T[:, 0]])
        self.B = np.ascontiguousarray(V[T[:, 1]])
        self.C = np.ascontiguousarray(V[T[:, 2]])
        r = self._circumradii()
        target = float(np.median(r)) if len(r) else 0.0
        samples, owner, radius = _triangle_samples(self.A, self.B, self.C, 2.0 * target)
        self._index = _SampleIndex(samples, owner, radius)
        self.oriented = self._is_oriented()
        self._pseudo = self._pseudonormals() if self.oriented else None

    def _circumradii(self):
        G = (self.A + self.B + self.C) / 3.0
        return np.sqrt(np.max(np.stack([np.einsum("ij,ij->i", X - G, X - G) for X in (self.A, self.B, self.C)]),
                              axis=0))

    def _is_oriented(self) -> bool:
        T = self.T
        if np.any(T[:, 0] == T[:, 1]) or np.any(T[:, 1] == T[:, 2]) or np.any(T[:, 0] == T[:, 2]):
            return False
        topo = edge_topology(T)
        if np.any(topo.count > 2):
            return False
        H, _ = halfedges(T)
        key = H[:, 0] * len(self.V) + H[:, 1]
        return len(np.unique(key)) == len(key)

    def _pseudonormals(self):
        """Face normals, edge pseudo-normals per triangle edge (AB, BC, CA) and angle-weighted vertex normals."""
        N = unit(cross(self.B - self.A, self.C - self.A))
        topo = edge_topology(self.T)
        EN = np.zeros((len(topo.E), 3))
        np.add.at(EN, topo.HE, np.repeat(N, 3, axis=0))
        edge_normals = EN[topo.HE].reshape(-1, 3, 3)  # halfedge order per face: AB, BC, CA
        VN = np.zeros((len(self.V), 3))
        ang = triangle_angles(self.V, self.T)
        for i in range(3):
            np.add.at(VN, self.T[:, i], ang[:, i, None] * N)
        return N, edge_normals, VN

    def query(self, P, signed: bool = False, name: str = "points") -> ClosestPoints:
        """Closest points on the mesh of every query point.

        Parameters
        ----------
        P : (p, 3) array_like of float
            Query points.
        signed : bool
            Return signed distances (positive where ``P - closest`` agrees with the pseudo-normal, i.e. on the
            side the triangle normals point to). Requires :attr:`oriented`.
        name : str
            Name of the query input in error messages.

        Returns
        -------
        ClosestPoints
            ``points (p, 3)``, ``distances (p,)``, ``faces (p,)``, ``barycentric (p, 3)``.

        Raises
        ------
        InputError
            ``P`` is not ``(p, 3)`` finite numbers, or ``signed`` on a mesh that is not oriented.
        """
        P = check_points(P, name)
        if signed and not self.oriented:
            raise InputError(name, "signed distances need an oriented, edge-manifold reference mesh")
        p = len(P)
        faces = np.empty(p, dtype=np.int64)
        d2 = np.empty(p)
        bary = np.empty((p, 3))
        code = np.empty(p, dtype=np.int8)
        for s in range(0, p, _CHUNK):
            Pc = P[s:s + _CHUNK]

            def exact(pi, tri, Pc=Pc):
                sq, b, c = closest_points_on_triangles(Pc[pi], self.A[tri], self.B[tri], self.C[tri])
                return sq, (b, c)

            f, dd, (b, c) = self._index.nearest(Pc, exact, len(self.T))
            faces[s:s + _CHUNK] = f
            d2[s:s + _CHUNK] = dd
            bary[s:s + _CHUNK] = b
            code[s:s + _CHUNK] = c
        X = bary[:, 0:1] * self.A[faces] + bary[:, 1:2] * self.B[faces] + bary[:, 2:3] * self.C[faces]
        dist = np.linalg.norm(P - X, axis=1)
        if signed:
            dist = dist * self._sign(P, X, faces, code)
        return ClosestPoints(X, dist, faces, bary)

    def _sign(self, P, X, faces, code):
        N, EN, VN = self._pseudo
        n = N[faces].copy()
        for c, corner in ((1, 0), (2, 1), (3, 2)):
            s = code == c
            n[s] = VN[self.T[faces[s], corner]]
        for c, e in ((4, 0), (5, 1), (6, 2)):
            s = code == c
            n[s] = EN[faces[s], e]
        side = np.einsum("ij,ij->i", P - X, n)
        return np.where(side < 0, -1.0, 1.0)


def closest_points(P, V, T, signed: bool = False) -> ClosestPoints:
    """Closest points on a triangle mesh (builds a :class:`TriangleIndex` and queries it once).

    Parameters
    ----------
    P : (p, 3) float64
        Query points.
    V : (n, 3) float64
        Mesh vertices.
    T : (t, 3) int64
        Triangles.
    signed : bool
        Signed distances (the mesh must be oriented).

    Returns
    -------
    ClosestPoints
        ``points``, ``distances``, ``faces``, ``barycentric``.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(2, 2)
    >>> res = closest_points(np.array([[0.2, 0.3, 1.0]]), V, triangulate(Q)[0])
    >>> res.distances
    array([1.])
    """
    return TriangleIndex(V, T).query(P, signed=signed)


# ----------------------------------------------------------------------------------------------
# polyline


class PolylineIndex:
    """A spatial index over a polyline answering exact closest-point queries (build once, query many).

    Parameters
    ----------
    polyline_points : (n, 3) float64
        Polyline vertices in order (n ≥ 2; a closed polyline does not repeat its first vertex, a repeated last
        vertex is dropped).
    closed : bool
        Add the segment from the last vertex back to the first.
    name : str
        Name of the input in error messages.
    """

    def __init__(self, polyline_points, closed: bool = False, name: str = "polyline"):
        X = check_points(polyline_points, name)
        if closed and len(X) > 2 and np.array_equal(X[0], X[-1]):
            X = X[:-1]
        if len(X) < 2:
            raise InputError(name, f"a polyline needs at least 2 points, got {len(X)}")
        self.X = X
        self.closed = bool(closed)
        self.A = X if closed else X[:-1]
        self.B = np.roll(X, -1, axis=0) if closed else X[1:]
        L = np.linalg.norm(self.B - self.A, axis=1)
        if not np.any(L > 0):
            raise InputError(name, "all polyline points coincide")
        target = float(np.median(L[L > 0]))
        level = np.clip(np.ceil(L / target), 1, 4 * _MAX_LEVEL).astype(np.int64)
        owner = np.repeat(np.arange(len(L)), level)
        start = np.cumsum(level) - level
        local = (np.arange(len(owner)) - start[owner] + 0.5) / level[owner]
        S = self.A[owner] + local[:, None] * (self.B - self.A)[owner]
        self._index = _SampleIndex(S, owner, (0.5 * L / level)[owner])

    def query(self, P, name: str = "points") -> PolylineClosestPoints:
        """Closest points on the polyline of every query point (see :class:`PolylineClosestPoints`)."""
        P = check_points(P, name)
        p = len(P)
        seg = np.empty(p, dtype=np.int64)
        t = np.empty(p)
        for s in range(0, p, _CHUNK):
            Pc = P[s:s + _CHUNK]

            def exact(pi, sg, Pc=Pc):
                tt = _segment_parameter(Pc[pi], self.A[sg], self.B[sg])
                Q = self.A[sg] + tt[:, None] * (self.B[sg] - self.A[sg])
                D = Pc[pi] - Q
                return np.einsum("ij,ij->i", D, D), (tt,)

            sg, _, (tt,) = self._index.nearest(Pc, exact, len(self.A))
            seg[s:s + _CHUNK] = sg
            t[s:s + _CHUNK] = tt
        Q = self.A[seg] + t[:, None] * (self.B[seg] - self.A[seg])
        return PolylineClosestPoints(Q, np.linalg.norm(P - Q, axis=1), seg, t)


def closest_points_on_polyline(P, polyline_points, closed: bool = False) -> PolylineClosestPoints:
    """Closest points on a polyline (open or closed) of every query point.

    Parameters
    ----------
    P : (p, 3) float64
        Query points.
    polyline_points : (n, 3) float64
        Polyline vertices in order.
    closed : bool
        Whether the last vertex connects back to the first.

    Returns
    -------
    PolylineClosestPoints
        ``points (p, 3)``, ``distances (p,)``, ``segments (p,)``, ``t (p,)``.

    Example
    -------
    >>> square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> res = closest_points_on_polyline([[0.5, -0.2, 0.0], [0.1, 0.5, 0.0]], square, closed=True)
    >>> res.points.round(12).tolist(), res.segments.tolist()  # slide points back onto the boundary curve
    ([[0.5, 0.0, 0.0], [0.0, 0.5, 0.0]], [0, 3])
    """
    return PolylineIndex(polyline_points, closed=closed).query(P)

