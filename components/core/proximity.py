"""Closest points on a triangle mesh and on a polyline: exact, vectorized, with a real spatial index.

Used by the quality metrics (closeness to a reference surface), the panel-health check (closeness, coverage), the
planarization solver (closeness goal: build the index once, query it every iteration), the field and network
pipelines and the subdivision step (pull points back onto the surface).

How it works
------------
**Triangle meshes** (:class:`TriangleIndex`): a uniform grid of cubic cells (edge: half the median longest triangle
edge, widened for meshes of very unequal triangles) lists, for every cell, the triangles that touch it: those whose
bounding box overlaps the cell and whose plane passes through it (triangles spanning many cells are registered
block by block, an octree descent that keeps a block while its centre is within its half-diagonal of the
triangle). A query point takes the triangles of its own cell (of the 26 around it when its cell is empty) and
keeps the nearest, at distance ``d``; every triangle closer than ``d`` touches a cell that the point's ball of
radius ``d`` overlaps, so searching those cells too makes the answer the exact minimum over all triangles, not an
approximation. A ball spanning more than :data:`_BALL_CELLS` cells (a point far from the surface) is searched in a
grid of twice the cell size, and so on (built on first use); the coarsest grid has at most 4 cells a side. Point /
triangle distances are computed for many pairs at once, components first and without branches (the projection
onto the plane when it falls inside, else the nearest edge), then the winner's closest point, barycentric
coordinates and Voronoi region once per point. Orientation and pseudo-normals are computed only for a signed query.
Indexing the same arrays again reuses the built index (a small cache keyed on their content).

**Polylines** (:class:`PolylineIndex`): every segment is covered by *sample points* (its midpoint, or the
midpoints of ``n`` equal sub-segments for long ones), each with the radius ``ρ_s`` of the part it stands for, in a
:class:`scipy.spatial.cKDTree`. A query point takes its ``k`` nearest samples, the exact distance to their segments,
and keeps the smallest, ``d``; any segment closer than ``d`` has a sample within ``d + ρ_max`` (triangle
inequality), so when the ``k``-th sample is farther no unseen segment can win; otherwise ``k`` grows (×4).

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
from components.core.compiled import kernel
from components.core.errors import InputError, MeshError
from components.core.memo import ContentCache, digest
from components.core.measures import cross, triangle_angles, unit
from components.core.mesh import edge_topology

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
_CELL_FACTOR = 0.5  # grid cell edge, × the median longest triangle edge
_BALL_CELLS = 27  # a query ball spanning more cells is searched in the next coarser grid
_GRID_PAIRS = 1 << 15  # point-triangle pairs evaluated together by the grid
_AROUND = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], dtype=np.int64)
_CACHE_ENTRIES = 4  # built triangle indexes kept for reuse
_CACHE_TRIANGLES = 600_000  # ... holding at most this many triangles together (~400 B each)


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


# ----------------------------------------------------------------------------------------------
# uniform grid of cells listing the triangles that touch them


def _plane_coords(P, D):
    """What both pair kernels start from: the offsets ``w0, w1, w2`` of the points ``P`` (components first) from
    the triangles' first corners, their dot products ``d20, d21`` with the edges AB and AC, the unnormalized
    barycentric ``s, t`` of their projections (over ``den``) and whether the projection is inside the triangle."""
    ax, ay, az, ux, uy, uz, vx, vy, vz, nx, ny, nz, d00, d01, d11, den, i00, i11, iff = D
    w0, w1, w2 = P[0] - ax, P[1] - ay, P[2] - az
    d20 = w0 * ux + w1 * uy + w2 * uz
    d21 = w0 * vx + w1 * vy + w2 * vz
    s = d11 * d20 - d01 * d21
    t = d00 * d21 - d01 * d20
    inside = (s >= 0.0) & (t >= 0.0) & (s + t <= den)
    return w0, w1, w2, d20, d21, s, t, inside


def _pair_sqdist(P, D):
    """Squared distances of the row-wise pairs point / triangle, components first: ``P`` is ``(x, y, z)`` of the
    points, ``D`` the triangles' columns of :attr:`_TriangleGrid.data` gathered for the pairs.

    The projection onto the plane is the answer when it falls inside the triangle; otherwise the nearest of the
    three edges is (a triangle without area is its three edges). Within round-off of
    :func:`closest_points_on_triangles`, and free of branches (masks blend, no subsets), which makes it about ten
    times faster.
    """
    ax, ay, az, ux, uy, uz, vx, vy, vz, nx, ny, nz, d00, d01, d11, den, i00, i11, iff = D
    w0, w1, w2, d20, d21, _, _, inside = _plane_coords(P, D)
    h = w0 * nx + w1 * ny + w2 * nz
    t = np.clip(d20 * i00, 0.0, 1.0)  # edge AB
    r0, r1, r2 = w0 - t * ux, w1 - t * uy, w2 - t * uz
    best = r0 * r0 + r1 * r1 + r2 * r2
    t = np.clip(d21 * i11, 0.0, 1.0)  # edge AC
    r0, r1, r2 = w0 - t * vx, w1 - t * vy, w2 - t * vz
    np.minimum(best, r0 * r0 + r1 * r1 + r2 * r2, out=best)
    w0 -= ux  # edge BC, from B
    w1 -= uy
    w2 -= uz
    f0, f1, f2 = vx - ux, vy - uy, vz - uz
    t = np.clip((w0 * f0 + w1 * f1 + w2 * f2) * iff, 0.0, 1.0)
    r0, r1, r2 = w0 - t * f0, w1 - t * f1, w2 - t * f2
    np.minimum(best, r0 * r0 + r1 * r1 + r2 * r2, out=best)
    return best + inside * (h * h - best)  # inside: the plane distance (never above the edges')


@kernel("float64(float64, float64, float64, float64[::1])")
def _sqdist_one(x, y, z, D):  # pragma: no cover (compiled)
    """:func:`_pair_sqdist` of one point and one triangle (``D``: the triangle's row of :attr:`_TriangleGrid.rows`),
    with the same operations in the same order."""
    ax, ay, az, ux, uy, uz, vx, vy, vz = D[0], D[1], D[2], D[3], D[4], D[5], D[6], D[7], D[8]
    nx, ny, nz, d00, d01, d11, den, i00, i11, iff = D[9], D[10], D[11], D[12], D[13], D[14], D[15], D[16], D[17], D[18]
    w0, w1, w2 = x - ax, y - ay, z - az
    d20 = w0 * ux + w1 * uy + w2 * uz
    d21 = w0 * vx + w1 * vy + w2 * vz
    s = d11 * d20 - d01 * d21
    t = d00 * d21 - d01 * d20
    inside = 1.0 if ((s >= 0.0) and (t >= 0.0) and (s + t <= den)) else 0.0
    h = w0 * nx + w1 * ny + w2 * nz
    t = min(max(d20 * i00, 0.0), 1.0)  # edge AB
    r0, r1, r2 = w0 - t * ux, w1 - t * uy, w2 - t * uz
    best = r0 * r0 + r1 * r1 + r2 * r2
    t = min(max(d21 * i11, 0.0), 1.0)  # edge AC
    r0, r1, r2 = w0 - t * vx, w1 - t * vy, w2 - t * vz
    best = min(best, r0 * r0 + r1 * r1 + r2 * r2)
    w0, w1, w2 = w0 - ux, w1 - uy, w2 - uz  # edge BC, from B
    f0, f1, f2 = vx - ux, vy - uy, vz - uz
    t = min(max((w0 * f0 + w1 * f1 + w2 * f2) * iff, 0.0), 1.0)
    r0, r1, r2 = w0 - t * f0, w1 - t * f1, w2 - t * f2
    best = min(best, r0 * r0 + r1 * r1 + r2 * r2)
    return best + inside * (h * h - best)


@kernel("void(float64[:, ::1], int64[::1], int64[::1], int64[::1], int64[::1], float64[:, ::1], int64[::1], "
        "float64[::1])")
def _scan_compiled(P3, rows, start, ln, tri, data, best, best_d2):  # pragma: no cover (compiled)
    """:meth:`TriangleIndex._scan` compiled: every triangle ``tri[start[j]:start[j] + ln[j]]`` of the cell of entry
    ``j`` against the point ``rows[j]`` (``P3`` (3, q)); the first nearest of each run of entries of one point
    replaces the point's best when strictly nearer (the numpy code's rule, so the same triangle wins)."""
    r = len(rows)
    i = 0
    while i < r:
        p = rows[i]
        x, y, z = P3[0, p], P3[1, p], P3[2, p]
        low, arg = np.inf, -1
        j = i
        while j < r and rows[j] == p:
            for k in range(start[j], start[j] + ln[j]):
                t = tri[k]
                d2 = _sqdist_one(x, y, z, data[t])
                if d2 < low:
                    low, arg = d2, t
            j += 1
        if low < best_d2[p]:
            best_d2[p], best[p] = low, arg
        i = j


class _TriangleGrid:
    """Cubic cells of edge ``h``; each cell lists every triangle that touches it (a superset: the triangle's
    bounding box overlaps the cell, and for triangles spanning many cells the cell's centre is within its
    half-diagonal of the triangle). A point's nearest triangle is certified by the cells its search ball overlaps.
    """

    def __init__(self, A, B, C, finer: "_TriangleGrid | None" = None):
        self._coarser = None
        if finer is not None:  # a coarser level: the same triangles, cells twice as large
            self.data, self.lo, self.hi, self.lo_all, self.hi_all = (finer.data, finer.lo, finer.hi, finer.lo_all,
                                                                     finer.hi_all)
            self._rows, self._finer = None, finer  # the table is the finest grid's (see rows)
            self.level = finer.level + 1
            self._register(2.0 * finer.h)
            return
        At, Bt, Ct = np.ascontiguousarray(A.T), np.ascontiguousarray(B.T), np.ascontiguousarray(C.T)
        U, W = Bt - At, Ct - At
        F = W - U
        d00, d11, dff = (X[0] * X[0] + X[1] * X[1] + X[2] * X[2] for X in (U, W, F))
        d01 = U[0] * W[0] + U[1] * W[1] + U[2] * W[2]
        Nv = np.stack([U[1] * W[2] - U[2] * W[1], U[2] * W[0] - U[0] * W[2], U[0] * W[1] - U[1] * W[0]])
        den = Nv[0] * Nv[0] + Nv[1] * Nv[1] + Nv[2] * Nv[2]
        longest = np.sqrt(np.maximum(np.maximum(d00, d11), dff))
        flat = den <= 1e-24 * longest ** 4
        nn = np.sqrt(np.where(flat, 1.0, den))
        Nn = np.where(flat, 0.0, Nv / nn)
        den = np.where(flat, -1.0, den)  # never "inside": a triangle without area is its three edges
        inv = [np.divide(1.0, x, out=np.zeros_like(x), where=x > 0) for x in (d00, d11, dff)]
        #: per-triangle columns of the distance kernel: A, B - A, C - A, unit normal, U·U, U·W, W·W, |U×W|² and the
        #: inverse squared lengths of AB, AC, BC
        self.data = [*At, *U, *W, *Nn, d00, d01, d11, den, *inv]
        self._rows, self._finer = None, None
        self.lo = lo = np.minimum(np.minimum(At, Bt), Ct)
        self.hi = hi = np.maximum(np.maximum(At, Bt), Ct)
        self.lo_all, self.hi_all = lo.min(axis=1), hi.max(axis=1)
        self.level = 0
        self._register(_cell_size(longest, 0.5 * np.sqrt(np.maximum(den, 0.0)), self.hi_all - self.lo_all))

    @property
    def rows(self) -> np.ndarray | None:
        """:attr:`data` per triangle ``(t, 19)`` for the compiled scan, made on first use and shared by the coarser
        levels; None without the compiled scan."""
        if _scan_compiled is None:
            return None
        if self._rows is None:
            self._rows = self._finer.rows if self._finer is not None else np.ascontiguousarray(
                np.stack(self.data, axis=1))
        return self._rows

    def coarser(self) -> "_TriangleGrid":
        """The grid of the same triangles with cells twice as large (built on first use)."""
        if self._coarser is None:
            self._coarser = _TriangleGrid(None, None, None, finer=self)
        return self._coarser

    def _register(self, h: float):
        """List every triangle in the cells of edge ``h`` it touches."""
        lo, hi, lo_all, hi_all = self.lo, self.hi, self.lo_all, self.hi_all
        At, Nn = np.stack(self.data[0:3]), np.stack(self.data[9:12])
        t = len(At[0])
        self.h = h
        self.origin = lo_all - 0.5 * h
        self.dims = (np.floor((hi_all - self.origin) / h)).astype(np.int64) + 2
        # cells touched by each triangle: those of its box that its plane passes through (cube-plane test)
        pad = 1e-9 * h + 16.0 * np.finfo(float).eps * float(max(np.abs(lo_all).max(), np.abs(hi_all).max()))
        self.pad = pad
        i0 = np.clip(np.floor((lo - pad - self.origin[:, None]) / h).astype(np.int64), 0, (self.dims - 1)[:, None])
        i1 = np.clip(np.floor((hi + pad - self.origin[:, None]) / h).astype(np.int64), 0, (self.dims - 1)[:, None])
        n = i1 - i0 + 1
        small = (n[0] <= 3) & (n[1] <= 3) & (n[2] <= 3)
        reach = 0.5 * h * (np.abs(Nn[0]) + np.abs(Nn[1]) + np.abs(Nn[2])) * (1.0 + 1e-9) + pad
        base = sum(Nn[k] * (self.origin[k] + 0.5 * h - At[k]) for k in range(3))  # plane offset of cell (0, 0, 0)
        k0 = self._key(i0[0], i0[1], i0[2])
        step = np.array([self.dims[1] * self.dims[2], self.dims[2], 1], dtype=np.int64)
        shape = np.where(small, (n[0] - 1) * 9 + (n[1] - 1) * 3 + (n[2] - 1), -1)  # the box's cell pattern
        order = np.argsort(shape, kind="stable")
        bounds = np.searchsorted(shape[order], np.arange(28))
        keys, tris = [], []
        for code in range(27):
            idx = order[bounds[code]:bounds[code + 1]]
            if not len(idx):
                continue
            nx, ny, nz = code // 9 + 1, code // 3 % 3 + 1, code % 3 + 1
            o = np.array([(dx, dy, dz) for dx in range(nx) for dy in range(ny) for dz in range(nz)], dtype=np.int64)
            K = k0[idx][:, None] + (o @ step)[None, :]
            I = np.broadcast_to(idx[:, None], K.shape)
            if len(o) >= 8:  # boxes spanning 2 cells in every direction: keep the cells the plane passes through
                off = base[idx][:, None] + h * (Nn[0, idx][:, None] * (i0[0, idx][:, None] + o[:, 0]) +
                                                Nn[1, idx][:, None] * (i0[1, idx][:, None] + o[:, 1]) +
                                                Nn[2, idx][:, None] * (i0[2, idx][:, None] + o[:, 2]))
                keep = np.abs(off) <= reach[idx][:, None]
                keys.append(K[keep])
                tris.append(I[keep])
            else:
                keys.append(K.ravel())
                tris.append(I.ravel())
        big = np.flatnonzero(~small)
        if len(big):
            bt, bk = self._descend(big, i0[:, big].T, i1[:, big].T)
            keys.append(bk)
            tris.append(bt)
        keys = np.concatenate(keys) if keys else np.zeros(0, np.int64)
        tris = np.concatenate(tris) if tris else np.zeros(0, np.int64)
        if float(np.prod(self.dims.astype(float))) * t < 2.0 ** 62:  # one SIMD sort of key·t + triangle
            comp = np.sort(keys * np.int64(t) + tris)
            keys = comp // t
            self.tri = comp - keys * t
        else:
            order = np.argsort(keys)
            keys, self.tri = keys[order], tris[order]
        first = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]) if len(keys) else np.zeros(0, np.int64)
        self.cell_keys = keys[first]
        self.cell_start = first
        self.cell_len = np.diff(np.r_[first, len(keys)])

    def _key(self, ix, iy, iz):
        return (ix * self.dims[1] + iy) * self.dims[2] + iz

    def _descend(self, tri, i0, i1):
        """Cells touched by the triangles ``tri`` whose boxes span many cells: blocks of ``2^L`` cells, halved
        level by level, kept while their centre is within their half-diagonal of the triangle."""
        span = (i1 - i0 + 1).max(axis=1)
        L = np.maximum(np.ceil(np.log2(span)).astype(np.int64) - 1, 0)
        size = np.int64(1) << L
        b0 = i0 // size[:, None]  # block coordinates in units of the block size
        b1 = i1 // size[:, None]
        nb = b1 - b0 + 1
        cnt = nb.prod(axis=1)
        item = np.repeat(np.arange(len(tri)), cnt)
        local = np.arange(len(item)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        nbi = nb[item]
        bx = b0[item, 0] + local % nbi[:, 0]
        rest = local // nbi[:, 0]
        by = b0[item, 1] + rest % nbi[:, 1]
        bz = b0[item, 2] + rest // nbi[:, 1]
        cells = np.stack([bx, by, bz], axis=1) * size[item][:, None]  # lowest cell of each block
        sz = size[item]
        tri_all, key_all = [], []
        while len(item):
            centre = self.origin + (cells + 0.5 * sz[:, None]) * self.h
            r = 0.5 * np.sqrt(3.0) * sz * self.h * (1.0 + 1e-9) + self.pad
            d2 = self.sqdist(np.ascontiguousarray(centre.T), tri[item])
            keep = d2 <= r * r
            item, cells, sz = item[keep], cells[keep], sz[keep]
            done = sz == 1
            inside = done & np.all((cells >= i0[item]) & (cells <= i1[item]), axis=1)
            tri_all.append(tri[item[inside]])
            key_all.append(self._key(*cells[inside].T))
            item, cells, sz = item[~done], cells[~done], sz[~done] // 2
            if len(item):  # split into the 8 children inside the triangle's cell range
                off = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=np.int64)
                cells = (cells[:, None, :] + off[None] * sz[:, None, None]).reshape(-1, 3)
                item, sz = np.repeat(item, 8), np.repeat(sz, 8)
                hi_c = cells + sz[:, None] - 1
                ok = np.all((hi_c >= i0[item]) & (cells <= i1[item]), axis=1)
                item, cells, sz = item[ok], cells[ok], sz[ok]
        return np.concatenate(tri_all), np.concatenate(key_all)

    def sqdist(self, P3, tri):
        """Squared distances of the points ``P3 (3, q)`` to the triangles ``tri (q,)`` (row-wise pairs)."""
        return _pair_sqdist(P3, [x[tri] for x in self.data])

    def closest(self, P3, tri):
        """Closest points ``(3, q)``, barycentric coordinates ``(q, 3)`` and region codes (as
        :func:`closest_points_on_triangles`: 0 inside, 1/2/3 corner, 4/5/6 edge AB/BC/CA; exact zeros off the
        region) of the row-wise pairs point ``P3 (3, q)`` / triangle ``tri (q,)``."""
        D = [x[tri] for x in self.data]
        ax, ay, az, ux, uy, uz, vx, vy, vz, nx, ny, nz, d00, d01, d11, den, i00, i11, iff = D
        w0, w1, w2, d20, d21, s, t, inside = _plane_coords(P3, D)
        tab = np.clip(d20 * i00, 0.0, 1.0)
        tca = np.clip(d21 * i11, 0.0, 1.0)
        f0, f1, f2 = vx - ux, vy - uy, vz - uz
        tbc = np.clip(((w0 - ux) * f0 + (w1 - uy) * f1 + (w2 - uz) * f2) * iff, 0.0, 1.0)
        e = np.empty((3, len(tri)))
        for k, (tt, x0, x1, x2, y0, y1, y2) in enumerate(((tab, 0.0, 0.0, 0.0, ux, uy, uz),
                                                         (tbc, ux, uy, uz, f0, f1, f2),
                                                         (tca, 0.0, 0.0, 0.0, vx, vy, vz))):
            r0, r1, r2 = w0 - x0 - tt * y0, w1 - x1 - tt * y1, w2 - x2 - tt * y2
            e[k] = r0 * r0 + r1 * r1 + r2 * r2
        k = np.argmin(e, axis=0)
        bary = np.zeros((len(tri), 3))
        code = np.empty(len(tri), dtype=np.int8)
        for edge, tt, i, j in ((0, tab, 0, 1), (1, tbc, 1, 2), (2, tca, 0, 2)):
            m = np.flatnonzero(k == edge)
            bary[m, i] = 1.0 - tt[m]
            bary[m, j] = tt[m]
            c = np.full(len(m), 4 + edge, dtype=np.int8)
            c[tt[m] == 0.0] = i + 1
            c[tt[m] == 1.0] = j + 1
            code[m] = c
        m = np.flatnonzero(inside)
        v, w = s[m] / den[m], t[m] / den[m]
        bary[m, 0] = 1.0 - v - w
        bary[m, 1] = v
        bary[m, 2] = w
        code[m] = 0
        b1, b2 = bary[:, 1], bary[:, 2]
        X = np.stack([ax + b1 * ux + b2 * vx, ay + b1 * uy + b2 * vy, az + b1 * uz + b2 * vz])
        return X, bary, code


# ----------------------------------------------------------------------------------------------
# triangle mesh


class _Surface:
    """What an index of one triangle mesh needs, built once per content (shared through :data:`_CACHE`): corner
    arrays, the cell grid, and lazily the sample index (far points), the orientation and the pseudo-normals."""

    def __init__(self, V, T):
        self.V, self.T = V, T
        self.A = np.ascontiguousarray(V[T[:, 0]])
        self.B = np.ascontiguousarray(V[T[:, 1]])
        self.C = np.ascontiguousarray(V[T[:, 2]])
        self.grid = _TriangleGrid(self.A, self.B, self.C)
        self._oriented = None
        self._pseudo = None

    def oriented(self) -> bool:
        """Edge-manifold and consistently oriented: no repeated corner and no directed edge twice (an edge of
        three or more faces repeats a direction)."""
        if self._oriented is None:
            T = self.T
            if np.any(T[:, 0] == T[:, 1]) or np.any(T[:, 1] == T[:, 2]) or np.any(T[:, 0] == T[:, 2]):
                self._oriented = False
            else:
                n = np.int64(len(self.V))
                key = np.sort(np.concatenate([T[:, 0] * n + T[:, 1], T[:, 1] * n + T[:, 2], T[:, 2] * n + T[:, 0]]))
                self._oriented = bool(not np.any(key[1:] == key[:-1]))
        return self._oriented

    def pseudonormals(self):
        """Face normals, edge pseudo-normals per triangle edge (AB, BC, CA) and angle-weighted vertex normals."""
        if self._pseudo is None:
            N = unit(cross(self.B - self.A, self.C - self.A))
            topo = edge_topology(self.T)
            EN = np.zeros((len(topo.E), 3))
            np.add.at(EN, topo.HE, np.repeat(N, 3, axis=0))
            edge_normals = EN[topo.HE].reshape(-1, 3, 3)  # halfedge order per face: AB, BC, CA
            VN = np.zeros((len(self.V), 3))
            ang = triangle_angles(self.V, self.T)
            for i in range(3):
                np.add.at(VN, self.T[:, i], ang[:, i, None] * N)
            self._pseudo = N, edge_normals, VN
        return self._pseudo


def _cell_size(longest, area, ext) -> float:
    """Cell edge of the grid: :data:`_CELL_FACTOR` × the median longest triangle edge, widened so that a few huge or
    long triangles do not fill millions of cells (mean area / 4, mean longest edge / 8) and the cell count stays
    an int64; ``longest``, ``area`` per triangle, ``ext`` the extent of the mesh per axis."""
    h = max(_CELL_FACTOR * float(np.median(longest)), float(np.sqrt(area.mean() / 4.0)), float(longest.mean() / 8.0))
    h = max(h, float(np.prod(ext + h)) ** (1.0 / 3.0) / 2.0 ** 19)  # at most ~2^57 cells
    if not h > 0.0:  # every triangle collapsed onto one point
        h = 1.0
    return h


_CACHE = ContentCache("triangle indexes", entries=_CACHE_ENTRIES, limit=_CACHE_TRIANGLES, weight=lambda s: len(s.T))


def _surface(V, T) -> _Surface:
    """The :class:`_Surface` of ``(V, T)``, from :data:`_CACHE` when the same arrays (by content) were indexed
    recently."""
    return _CACHE.get(digest(V, T), lambda: _Surface(V.copy(), T.copy()))


def _box_cells(rows: np.ndarray, lo: np.ndarray, n: np.ndarray, cnt: np.ndarray):
    """Every cell of each row's box of cells (lowest cell ``lo (q, 3)``, ``n (q, 3)`` cells along each axis,
    ``cnt = n.prod(axis=1)``): ``(row, ix, iy, iz)``, one entry per cell, x fastest."""
    r = np.repeat(rows, cnt)
    local = np.arange(len(r)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    nm, lm = np.repeat(n, cnt, axis=0), np.repeat(lo, cnt, axis=0)
    q = local // nm[:, 0]
    return r, lm[:, 0] + local % nm[:, 0], lm[:, 1] + q % nm[:, 1], lm[:, 2] + q // nm[:, 1]


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
        available (sign from the angle-weighted pseudo-normals of Bærentzen & Aanæs 2005). Computed on first use.

    Raises
    ------
    MeshError
        Bad shapes, NaN coordinates, indices out of range, empty mesh.

    Notes
    -----
    Indexing the same arrays again (equal content, e.g. the design surface of every health check of a pipeline)
    reuses the built index: a few recently built ones are kept, keyed by a digest of ``V`` and ``T``.

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
        self._s = _surface(V, T)
        self.V = V
        self.T = T
        self.A, self.B, self.C = self._s.A, self._s.B, self._s.C

    @property
    def oriented(self) -> bool:
        return self._s.oriented()

    def pseudonormals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit face normals ``(t, 3)``, the pseudo-normals of every triangle's edges ``(t, 3, 3)`` (AB, BC, CA: the
        sum of the unit normals of the faces on the edge) and the angle-weighted vertex normals ``(n, 3)`` (not
        unit), computed on first use and shared with the signed queries."""
        return self._s.pseudonormals()

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
        bary = np.empty((p, 3))
        code = np.empty(p, dtype=np.int8)
        X = np.empty((p, 3))
        for s in range(0, p, _CHUNK):
            Pc = P[s:s + _CHUNK]
            P3 = np.ascontiguousarray(Pc.T)
            f, _ = self._nearest(Pc, P3)
            x, b, c = self._s.grid.closest(P3, f)
            faces[s:s + _CHUNK] = f
            bary[s:s + _CHUNK] = b
            code[s:s + _CHUNK] = c
            X[s:s + _CHUNK] = x.T
        dist = np.linalg.norm(P - X, axis=1)
        if signed:
            dist = dist * self._sign(P, X, faces, code)
        return ClosestPoints(X, dist, faces, bary)

    def within(self, P, distance: float, name: str = "points") -> np.ndarray:
        """Whether each point lies within ``distance`` of the mesh (exactly as ``query(P).distances <= distance``,
        up to round-off), cheaper than :meth:`query` where a triangle listed in the point's grid cell settles it.

        Parameters
        ----------
        P : (p, 3) array_like of float
            Query points.
        distance : float
            The bound, in model units.
        name : str
            Name of the query input in error messages.

        Returns
        -------
        (p,) bool

        Example
        -------
        >>> from components.core.mesh import quad_grid, triangulate
        >>> V, Q = quad_grid(4, 4)
        >>> TriangleIndex(V, triangulate(Q)[0]).within([[0.5, 0.5, 0.1], [0.5, 0.5, 0.3], [1.2, 0.5, 0.0]], 0.2)
        array([ True, False,  True])
        """
        P = check_points(P, name)
        r2 = float(distance) ** 2
        g = self._s.grid
        inside = np.zeros(len(P), dtype=bool)
        for s in range(0, len(P), _CHUNK):
            Pc = P[s:s + _CHUNK]
            P3 = np.ascontiguousarray(Pc.T)
            yes = np.zeros(len(Pc), dtype=bool)
            c = np.floor((Pc - g.origin) / g.h).astype(np.int64)
            rows = np.flatnonzero(np.all((c >= 0) & (c < g.dims), axis=1))
            keys = g._key(*c[rows].T)
            if len(rows) and len(g.cell_keys):
                # the triangles of the point's own cell one at a time: a point stops at the first within reach
                pos = np.minimum(np.searchsorted(g.cell_keys, keys), len(g.cell_keys) - 1)
                hit = g.cell_keys[pos] == keys
                rows, start, ln = rows[hit], g.cell_start[pos[hit]], g.cell_len[pos[hit]]
                k = 0
                while len(rows):
                    d2 = g.sqdist([x[rows] for x in P3], g.tri[start + k])
                    near = d2 <= r2
                    yes[rows[near]] = True
                    k += 1
                    more = ~near & (ln > k)
                    rows, start, ln = rows[more], start[more], ln[more]
            # the other cells the ball of radius ``distance`` overlaps: a triangle within reach touches one of them
            rest = np.flatnonzero(~yes)
            lo = np.clip(np.floor((Pc[rest] - float(distance) - g.origin) / g.h).astype(np.int64), 0, g.dims - 1)
            hi = np.clip(np.floor((Pc[rest] + float(distance) - g.origin) / g.h).astype(np.int64), 0, g.dims - 1)
            n = np.maximum(hi - lo + 1, 0)
            cnt = n[:, 0] * n[:, 1] * n[:, 2]
            few = cnt <= _BALL_CELLS
            m = np.flatnonzero(few & (cnt > 0))
            if len(m):
                r, ix, iy, iz = _box_cells(rest[m], lo[m], n[m], cnt[m])
                new = (ix != c[r, 0]) | (iy != c[r, 1]) | (iz != c[r, 2])  # the own cell is done
                best = np.full(len(Pc), -1, dtype=np.int64)
                best_d2 = np.full(len(Pc), np.inf)
                self._scan(g, P3, r[new], g._key(ix[new], iy[new], iz[new]), best, best_d2)
                yes[rest[m]] = best_d2[rest[m]] <= r2
            big = rest[~few]  # a ball of many cells: the exact distance
            if len(big):
                _, d2 = self._nearest(Pc[big], np.ascontiguousarray(P3[:, big]))
                yes[big] = d2 <= r2
            inside[s:s + _CHUNK] = yes
        return inside

    @staticmethod
    def _scan(g, P3, rows, keys, best, best_d2):
        """Update ``best``/``best_d2`` of the points ``rows`` (repeats next to each other) with every triangle
        listed in the cells ``keys`` of the grid ``g`` (one key per row entry)."""
        if not len(rows) or not len(g.cell_keys):
            return
        pos = np.minimum(np.searchsorted(g.cell_keys, keys), len(g.cell_keys) - 1)
        hit = g.cell_keys[pos] == keys
        rows, pos = rows[hit], pos[hit]
        start, ln = g.cell_start[pos], g.cell_len[pos]
        if g.rows is not None:  # compiled: the same pairs, distances and winners
            _scan_compiled(P3, rows.astype(np.int64, copy=False), start.astype(np.int64, copy=False),
                           ln.astype(np.int64, copy=False), g.tri.astype(np.int64, copy=False), g.rows, best, best_d2)
            return
        ends = np.cumsum(ln)
        s = 0
        while s < len(rows):  # batches of about _GRID_PAIRS pairs
            base = ends[s - 1] if s else 0
            e = max(int(np.searchsorted(ends, base + _GRID_PAIRS, side="right")), s + 1)
            r, st, n = rows[s:e], start[s:e], ln[s:e]
            pr = np.repeat(r, n)
            off = np.arange(len(pr)) - np.repeat(np.cumsum(n) - n, n)
            tri = g.tri[np.repeat(st, n) + off]
            d2 = g.sqdist([x[pr] for x in P3], tri)
            first = np.flatnonzero(np.r_[True, pr[1:] != pr[:-1]])
            mins = np.minimum.reduceat(d2, first)
            run = np.diff(np.r_[first, len(pr)])
            at = np.flatnonzero(d2 == np.repeat(mins, run))
            grp = np.searchsorted(first, at, side="right") - 1
            at = at[np.r_[True, grp[1:] != grp[:-1]]]  # first minimum of every run
            rr = pr[first]
            better = mins < best_d2[rr]
            best_d2[rr[better]] = mins[better]
            best[rr[better]] = tri[at[better]]
            s = e

    def _nearest(self, P, P3):
        """Nearest triangle of every point of ``P`` (``P3`` its transpose) and its squared distance.

        The point's own cell gives a first candidate (an empty cell: the 26 around it); then every cell its ball
        (radius: that candidate's distance) overlaps is searched, which makes the answer exact. Where the ball
        spans more than :data:`_BALL_CELLS` cells the search moves to a grid of twice the cell size, and so on;
        the coarsest grid has at most 4 cells a side, where any ball fits.
        """
        p = len(P)
        best = np.full(p, -1, dtype=np.int64)
        best_d2 = np.full(p, np.inf)
        g = self._s.grid
        todo = np.arange(p)
        while len(todo):
            coarsest = bool(g.dims.max() <= 4)
            Pt = P[todo]
            c = np.clip(np.floor((Pt - g.origin) / g.h).astype(np.int64), -1, g.dims)  # -1 / dims: outside
            own = np.all((c >= 0) & (c < g.dims), axis=1)
            if g.level == 0:
                r = np.flatnonzero(own)
                self._scan(g, P3, todo[r], g._key(*c[r].T), best, best_d2)
            unbound = np.flatnonzero(~np.isfinite(best_d2[todo]))
            block = np.zeros(len(todo), dtype=bool)  # the 27 cells around were searched
            block[unbound] = True
            if len(unbound):  # an empty cell (or outside the grid): the cells around it for a first bound
                cn = (c[unbound][:, None, :] + _AROUND[None]).reshape(-1, 3)
                r = np.repeat(todo[unbound], len(_AROUND))
                ok = np.all((cn >= 0) & (cn < g.dims), axis=1)
                self._scan(g, P3, r[ok], g._key(*cn[ok].T), best, best_d2)
            d = np.sqrt(best_d2[todo]) * (1.0 + 1e-12)
            dd = np.where(np.isfinite(d), d, 0.0)[:, None]
            lo = np.clip(np.floor((Pt - dd - g.origin) / g.h).astype(np.int64), 0, g.dims - 1)
            hi = np.clip(np.floor((Pt + dd - g.origin) / g.h).astype(np.int64), 0, g.dims - 1)
            if coarsest:  # no bound yet (cannot happen with triangles in the grid): every cell
                lo[~np.isfinite(d)], hi[~np.isfinite(d)] = 0, g.dims - 1
            n = hi - lo + 1
            cnt = n[:, 0] * n[:, 1] * n[:, 2]
            fits = np.isfinite(d) & (cnt <= _BALL_CELLS) | coarsest
            search = fits & ((cnt > 1) | (g.level > 0) | ~own)  # a ball inside its own cell is settled
            m = np.flatnonzero(search)
            if len(m):
                r, ix, iy, iz = _box_cells(todo[m], lo[m], n[m], cnt[m])
                cm = np.repeat(c[m], cnt[m], axis=0)
                bm = np.repeat(block[m], cnt[m])
                near = np.abs(np.stack([ix, iy, iz], axis=1) - cm).max(axis=1)
                new = np.where(bm, near > 1, (near > 0) | (g.level > 0))  # cells not searched yet
                # ... and reached by the ball (the corners of its box often are not)
                cell = np.stack([ix, iy, iz], axis=1) * g.h + g.origin
                gap = np.maximum(np.maximum(cell - P[r], P[r] - cell - g.h), 0.0)
                new &= np.einsum("ij,ij->i", gap, gap) <= best_d2[r] * (1.0 + 1e-9)
                r, ix, iy, iz = r[new], ix[new], iy[new], iz[new]
                self._scan(g, P3, r, g._key(ix, iy, iz), best, best_d2)
            todo = todo[~fits]
            if len(todo):
                g = g.coarser()
        return best, best_d2

    def _sign(self, P, X, faces, code):
        N, EN, VN = self._s.pseudonormals()
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

