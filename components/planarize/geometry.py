"""Geometry helpers of the planarization solver: per-iteration face frames and corner turns, vertex stars, closest
points on boundary loops, faces crossing faces they share no vertex with.

The measures (planarity, warping height, corner angles, convexity, row-wise vector algebra) are the shared ones of
:mod:`components.core.measures`; closest points come from :mod:`components.core.proximity`; the exact crossing
test is :func:`components.metrics.health.face_health`'s.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scipy.spatial import cKDTree

from components.core.measures import cross, dot, norm
from components.core.mesh import Corners, face_corners, face_sizes
from components.core.proximity import PolylineIndex
from components.metrics.health import face_health

__all__ = ["FaceFrames", "einsum_sum3", "corner_turns", "Stars", "vertex_stars", "LoopIndex", "crossing_pairs",
           "CrossingWatch"]

_AT_VERTEX = 1e-9  # a closest point this share of its segment's length from a loop vertex is at the vertex


# ----------------------------------------------------------------------------------------------
# per-iteration face normals and corner turns


class FaceFrames:
    """Fast per-iteration face normals and corner turns of one mesh (index data built once per solver call).

    All-quad meshes take the Newell normal from the diagonals (``½ (c − a) × (d − b)``, the same vector); other
    meshes sum the corner cross products face by face. The corner arrays are gathered component by component
    (1-D gathers are several times faster than gathers of ``(c, 3)`` rows; the arithmetic is the same).
    """

    def __init__(self, F: np.ndarray, corners: Corners):
        self.F = np.asarray(F, dtype=np.int64)
        self.C = corners
        self.m = len(self.F)
        self.all_quads = bool(self.F.shape[1] == 4 and np.all(face_sizes(self.F) == 4))
        self.succ = _next_corners(corners)

    def normals(self, X: np.ndarray, unit: bool = True) -> np.ndarray:
        """Newell normals ``(m, 3)`` (unit, zero for degenerate faces; area vectors when ``unit=False``)."""
        if self.all_quads:
            F = self.F
            N = 0.5 * cross(X[F[:, 2]] - X[F[:, 0]], X[F[:, 3]] - X[F[:, 1]])
        else:
            C = self.C
            x, y, z = (c[C.v] for c in np.ascontiguousarray(X.T))  # corner vertices, then the next ones
            xn, yn, zn = x[self.succ], y[self.succ], z[self.succ]
            N = np.empty((self.m, 3))
            for j, cr in enumerate((y * zn - z * yn, z * xn - x * zn, x * yn - y * xn)):  # cross(X[v], X[next])
                N[:, j] = 0.5 * np.bincount(C.face, cr, minlength=self.m)
        if unit:
            L = norm(N)
            N = N / np.where(L > 0, L, np.inf)[:, None]
        return N

    def turns(self, X: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`corner_turns` on this mesh."""
        return corner_turns(X, self.C, N, self.succ)

    def shape(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unsigned corner angles ``(c,)`` (:func:`components.core.measures.corner_angles`) and non-convex faces
        ``(m,) bool`` (:func:`components.core.measures.nonconvex_faces`) in one pass."""
        C = self.C
        a = X[C.v] - X[C.prev]
        b = X[C.next] - X[C.v]
        cr = cross(a, b)
        ang = np.arctan2(norm(cr), -dot(a, b))
        N = self.normals(X)
        ncv = np.zeros(self.m, dtype=bool)
        ncv[C.face[dot(cr, N[C.face]) <= 0.0]] = True
        ncv |= ~np.any(N != 0.0, axis=1)
        return ang, ncv


def _next_corners(C: Corners) -> np.ndarray:
    """``(c,) int64``: the index of the next corner of the same face (corners face by face, in slot order), so that
    ``C.v[_next_corners(C)] == C.next``.

    Example
    -------
    >>> from components.core.mesh import face_corners
    >>> _next_corners(face_corners(np.array([[0, 1, 2, 2], [2, 1, 3, 4]]))).tolist()
    [1, 2, 0, 4, 5, 6, 3]
    """
    k = np.arange(len(C.v), dtype=np.int64)
    size = np.bincount(C.face)[C.face] if len(k) else k
    return np.where(C.slot + 1 < size, k + 1, k - C.slot)


def corner_turns(X: np.ndarray, C: Corners, N: np.ndarray,
                 succ: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Signed turn and unsigned angle at every corner.

    The turn is ``((v − prev) × (next − v)) · n / (|v − prev| |next − v|)`` with ``n`` the unit normal of the
    corner's face (``N (m, 3)``): the sine of the interior angle, negative at a reflex corner. A planar face is
    convex with all angles in ``[θ, π − θ]`` exactly when every turn is at least ``sin θ``. ``succ``: the
    :func:`_next_corners` of ``C`` (computed when not given): the edge leaving a corner is the one entering the
    next corner. Computed component by component, in the operations of
    :func:`components.core.measures.cross` and :func:`~components.core.measures.dot`.

    Returns
    -------
    turn : (c,) float64
    angle : (c,) float64
        Unsigned angle in ``[0, π]`` between the two edges at the corner
        (:func:`components.core.measures.corner_angles`).
    """
    if succ is None:
        succ = _next_corners(C)
    Xc = np.ascontiguousarray(X.T)
    ax, ay, az = (c[C.v] - c[C.prev] for c in Xc)  # v − prev
    bx, by, bz = ax[succ], ay[succ], az[succ]  # next − v: the next corner's incoming edge
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    aa = ax * ax + ay * ay + az * az
    den = np.maximum(np.sqrt(aa * aa[succ]), 1e-300)
    nx, ny, nz = (np.ascontiguousarray(N[:, j])[C.face] for j in range(3))
    turn = (cx * nx + cy * ny + cz * nz) / den
    angle = np.arctan2(length3(cx, cy, cz), -(ax * bx + ay * by + az * bz))
    return turn, angle


# ----------------------------------------------------------------------------------------------
# vertex stars


class Stars(NamedTuple):
    """Regular vertex stars of a polygon mesh."""

    center: np.ndarray  # (s,) interior vertices of valence 4 whose four faces are all present
    corners: np.ndarray  # (s, 4) corner indices (face_corners order) around each, in cyclic order
    nbrs: np.ndarray  # (s, 4) neighbour vertices in the same cyclic order
    boundary_center: np.ndarray  # (b,) boundary vertices with at least two faces
    boundary_nbrs: np.ndarray  # (b, 2) previous and next vertex along the boundary


def vertex_stars(F: np.ndarray, n: int) -> Stars:
    """Cyclically ordered stars of the interior valence-4 vertices and the boundary neighbours of boundary vertices."""
    C = face_corners(F)
    c = len(C.v)
    # successor around the vertex: corner (f, v, prev u, next w) -> the corner at v whose prev is w
    key_prev = C.v * n + C.prev
    order = np.argsort(key_prev, kind="stable")
    sorted_keys = key_prev[order]
    want = C.v * n + C.next
    pos = np.searchsorted(sorted_keys, want)
    pos_c = np.minimum(pos, c - 1)
    found = sorted_keys[pos_c] == want
    succ = np.where(found, order[pos_c], -1)
    corners_per_v = np.bincount(C.v, minlength=n)
    # boundary: directed boundary edges are corner (v -> next) without a twin
    has_succ = succ >= 0
    # a vertex is interior iff all its corners have a successor
    open_corner = np.zeros(n, dtype=bool)
    open_corner[C.v[~has_succ]] = True
    first = np.full(n, -1, dtype=np.int64)
    first[C.v[::-1]] = np.arange(c)[::-1]
    cand = np.nonzero((corners_per_v == 4) & ~open_corner)[0]
    ring = np.empty((len(cand), 4), dtype=np.int64)
    cur = first[cand]
    ok = np.ones(len(cand), dtype=bool)
    for j in range(4):
        ring[:, j] = cur
        ok &= cur >= 0
        cur = np.where(cur >= 0, succ[np.maximum(cur, 0)], -1)
    ok &= cur == ring[:, 0]
    center = cand[ok]
    ring = ring[ok]
    nbrs = C.next[ring]
    # boundary neighbours: boundary half-edge v -> w (corner without successor) gives next; the corner whose
    # prev has no twin gives prev
    bnext = np.full(n, -1, dtype=np.int64)
    bnext[C.v[~has_succ]] = C.next[~has_succ]
    # predecessor relation: corner whose key (v, prev) is nobody's want
    key_next = np.sort(want)
    pos2 = np.minimum(np.searchsorted(key_next, key_prev), c - 1)
    no_pred = key_next[pos2] != key_prev
    bprev = np.full(n, -1, dtype=np.int64)
    bprev[C.v[no_pred]] = C.prev[no_pred]
    bmask = (bnext >= 0) & (bprev >= 0) & (corners_per_v >= 2)
    bc = np.nonzero(bmask)[0]
    return Stars(center, ring, nbrs, bc, np.stack([bprev[bc], bnext[bc]], axis=1))


# ----------------------------------------------------------------------------------------------
# closest points on boundary loops


class LoopIndex:
    """Closest points on a set of closed vertex loops (the boundary polylines to slide on), with unit tangents.

    One :class:`components.core.proximity.PolylineIndex` per loop; a query keeps the nearest loop. A point whose
    closest point is a loop's vertex (within :data:`_AT_VERTEX` of a segment's length from it) gets the vertex's
    tangent, the mean of its two segments' unit tangents, whichever segment the search returns: otherwise the
    round-off of the query picks one of the two (a candidate's boundary vertex snapped onto a vertex of the
    outline), and the same mesh in m and in mm is solved with another metric there and takes another path.
    """

    def __init__(self, X: np.ndarray, loops: list):
        kept = [k for k, lp in enumerate(loops) if len(lp) >= 2]
        self._numbers = np.array(kept, dtype=np.int64)  # the kept loops' positions in ``loops``
        self._loops = [PolylineIndex(X[loops[k]], closed=True, name="boundary") for k in kept]
        self._tangents = [_loop_tangents(idx) for idx in self._loops]

    def __bool__(self):
        return bool(self._loops)

    def query(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest points ``(p, 3)`` on the loops and the unit tangents ``(p, 3)`` of the segments holding them."""
        Q, T, _ = self._nearest(P)
        return Q, T

    def nearest_loop(self, P: np.ndarray) -> np.ndarray:
        """``(p,) int``: the position in ``loops`` of the loop nearest to each point (the first of equally near
        ones; -1 without loops)."""
        return self._nearest(P)[2]

    def _nearest(self, P):
        P = np.asarray(P, dtype=np.float64)
        best_d = np.full(len(P), np.inf)
        Q = np.zeros_like(P)
        T = np.zeros_like(P)
        L = np.full(len(P), -1, dtype=np.int64)
        if len(P) == 0:
            return Q, T, L
        for number, idx, (seg_t, vert_t) in zip(self._numbers, self._loops, self._tangents):
            res = idx.query(P, name="boundary vertices")
            better = res.distances < best_d
            if better.any():
                best_d[better] = res.distances[better]
                Q[better] = res.points[better]
                L[better] = number
                s, t = res.segments[better], res.t[better]
                tang = seg_t[s]
                at_a, at_b = t <= _AT_VERTEX, t >= 1.0 - _AT_VERTEX
                tang[at_a] = vert_t[s[at_a]]
                tang[at_b] = vert_t[(s[at_b] + 1) % len(vert_t)]
                T[better] = tang
        return Q, T, L


def _loop_tangents(idx) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents of a closed loop's segments and of its vertices (the mean of the two segments' there; the
    incoming segment's where they cancel)."""
    t = idx.B - idx.A
    seg_t = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    v = seg_t + np.roll(seg_t, 1, axis=0)  # vertex i: segments i (outgoing) and i - 1 (incoming)
    nv = np.linalg.norm(v, axis=1, keepdims=True)
    vert_t = np.where(nv > 1e-12, v / np.maximum(nv, 1e-300), np.roll(seg_t, 1, axis=0))
    return seg_t, vert_t


# ----------------------------------------------------------------------------------------------
# faces crossing faces they share no vertex with


def crossing_pairs(X: np.ndarray, F: np.ndarray, sizes: np.ndarray | None = None) -> np.ndarray:
    """Pairs ``(p, 2)`` (``a < b``, sorted) of faces sharing no vertex that cross or overlap.

    Broad phase here, on the faces' bounding spheres (centre: the mean corner, radius: the farthest corner): on a
    healthy mesh no two faces without a common vertex have overlapping spheres, so the usual cost is one KD-tree of
    the face centres. The exact test (triangle-triangle, Möller 1997) is
    :func:`components.metrics.health.face_health`'s, run on the few candidate faces only. For one mesh tested
    again and again as it moves, :class:`CrossingWatch` gives the same pairs without a KD-tree per test.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(4, 1)
    >>> crossing_pairs(V, F).tolist()
    []
    >>> V[[4, 9], 0] = -0.5  # the last quad folded back across the first two
    >>> crossing_pairs(V, F).tolist()
    [[0, 3], [1, 3]]
    """
    return CrossingWatch(F, sizes).pairs(X)


class CrossingWatch:
    """:func:`crossing_pairs` of one mesh whose vertices move from call to call, with the broad phase kept (a
    Verlet list): a KD-tree query at a reference state lists the pairs of faces sharing no vertex whose bounding
    spheres come within ``2 s`` of each other (``s``: a quarter of the median sphere radius); while no vertex has
    moved more than ``s`` from that state, every point of a face stays within its reference sphere grown by
    ``s``, so only the listed pairs can overlap, and only they are tested (their spheres at the new positions,
    then the exact test). A larger move takes a new reference state. The pairs are the same as
    :func:`crossing_pairs` computed from scratch.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(4, 1, 4.0, 1.0)  # unit squares: no two without a common corner come near
    >>> watch = CrossingWatch(F)
    >>> watch.pairs(V).tolist(), len(watch.near)
    ([], 0)
    >>> V[[4, 9], 0] = -2.0  # the last quad folded back across the first two
    >>> watch.pairs(V).tolist()
    [[0, 3], [1, 3]]
    """

    SKIN = 0.25  # × the median sphere radius at the reference state

    def __init__(self, F: np.ndarray, sizes: np.ndarray | None = None):
        self.F = np.asarray(F, dtype=np.int64)
        self.sizes = face_sizes(self.F) if sizes is None else np.asarray(sizes)
        self.valid = np.arange(self.F.shape[1])[None, :] < self.sizes[:, None]
        self.ref = None  # positions of the reference state
        self.skin = 0.0
        self.near = np.zeros((0, 2), dtype=np.int64)  # face pairs sharing no vertex, spheres within 2 skin
        self._near_faces = np.zeros(0, dtype=np.int64)  # the faces of ``near`` (sorted), and the positions of
        self._near_at = np.zeros((0, 2), dtype=np.int64)  # every pair's two faces among them (kept with ``near``)
        # corner columns (k, m) for 1-D gathers: the corners, the corners with the padding replaced by the first
        # corner (min / max unchanged), the next corners (the first one again at the padding)
        k = self.F.shape[1]
        first = np.repeat(self.F[:, :1], k, axis=1)
        nxt = np.where(np.roll(self.valid, -1, axis=1), np.roll(self.F, -1, axis=1), self.F[:, :1])
        self._cols = np.ascontiguousarray(self.F.T)
        self._Fp_cols = np.ascontiguousarray(np.where(self.valid, self.F, first).T)
        self._nxt_cols = np.ascontiguousarray(np.where(self.valid, nxt, first).T)

    def _spheres(self, X, faces=slice(None)):
        """Centres and radii of the bounding spheres of ``faces`` (all by default) at ``X``: the mean corner and the
        farthest corner's distance, corner column by corner column on 1-D gathers (the operations, in the order,
        of the sums and maxima over the ``(f, k, 3)`` corner array)."""
        Xc = np.ascontiguousarray(X.T)
        valid = self.valid[faces].T
        P = [[x[col[faces]] for x in Xc] for col in self._cols]  # (k, 3) lists of (f,) corner coordinates
        G = []
        for i in range(3):
            g = P[0][i] * valid[0]
            for j in range(1, len(P)):
                g = g + P[j][i] * valid[j]
            G.append(g / self.sizes[faces])
        R = None
        for j, (x, y, z) in enumerate(P):
            dx, dy, dz = x - G[0], y - G[1], z - G[2]
            d = np.where(valid[j], dx * dx + dy * dy + dz * dz, 0.0)
            R = d if R is None else np.maximum(R, d)
        return np.stack(G, axis=1), np.sqrt(R)

    def _apart(self, pairs):
        """The ``pairs`` of faces that share no vertex (every corner column of one against every one of the
        other, on 1-D gathers)."""
        if len(pairs) == 0:
            return pairs
        A = [col[pairs[:, 0]] for col in self._cols]
        B = [col[pairs[:, 1]] for col in self._cols]
        shared = np.zeros(len(pairs), dtype=bool)
        for a in A:
            for b in B:
                shared |= a == b
        return pairs[~shared]

    def _separated(self, X, pairs, gap) -> np.ndarray:
        """``(p,) bool``: face pairs whose corner sets lie more than ``gap`` apart along one of the axes tried (the
        two face normals, the line between the centroids, the in-plane normals of every edge of both faces): their
        convex hulls, hence their fan triangles, cannot touch (a separating axis; the exact test's tolerance is
        under ``gap``). Faces side by side on a surface are separated by an edge normal, so most sphere-overlapping
        pairs end here and the exact test sees only the few that come close."""
        Xc = np.ascontiguousarray(X.T)
        sides = [self._corner_coords(Xc, pairs[:, s]) for s in (0, 1)]
        axes = [_face_normal_sum(P) for P, _ in sides]  # the two (unnormalized) face normals
        cA, cB = (_corner_mean(P) for P, _ in sides)
        axes.append(tuple(b - a for a, b in zip(cA, cB)))  # the line between the centroids
        for n, (_, E) in zip(axes[:2], sides):  # the in-plane normals n × e of every edge of both faces
            axes += [_cross(n, e) for e in E]
        a0, a1, a2 = (np.stack([v[i] for v in axes], axis=1) for i in range(3))  # (p, 3 + 2k)
        L = np.sqrt(einsum_sum3(a0 * a0, a1 * a1, a2 * a2))
        L = np.where(L > 0, L, np.inf)
        ax0, ax1, ax2 = a0 / L, a1 / L, a2 / L
        # extent of each face's corners along every axis (the projections component by component)
        lo_a, hi_a = _extent(ax0, ax1, ax2, sides[0][0])
        lo_b, hi_b = _extent(ax0, ax1, ax2, sides[1][0])
        apart = (hi_a + gap < lo_b) | (hi_b + gap < lo_a)
        return apart.any(axis=1)

    def _corner_coords(self, Xc, faces):
        """The corners ``P`` (padding: the first corner again) and edge vectors ``E`` (to the next corner; zero
        at the padding) of ``faces``: ``k`` lists of ``(x, y, z)`` arrays ``(f,)`` from the coordinate rows
        ``Xc (3, n)``."""
        P = [tuple(x[col[faces]] for x in Xc) for col in self._Fp_cols]
        Pn = [tuple(x[col[faces]] for x in Xc) for col in self._nxt_cols]
        return P, [tuple(b - a for a, b in zip(p, q)) for p, q in zip(P, Pn)]

    def pairs(self, X: np.ndarray) -> np.ndarray:
        """Pairs ``(p, 2)`` (``a < b``, sorted) of faces sharing no vertex that cross or overlap at ``X``."""
        empty = np.zeros((0, 2), dtype=np.int64)
        if len(self.F) < 2:
            return empty
        moved = float(np.sqrt(np.max(dot(X - self.ref, X - self.ref)))) if (
            self.ref is not None and self.ref.shape == X.shape) else np.inf
        if not moved <= self.skin:
            G, R = self._spheres(X)
            self.skin = self.SKIN * float(np.median(R))
            self.near = self._apart(_sphere_pairs(G, R + self.skin))
            self.ref = np.array(X, dtype=np.float64, copy=True)
            self._near_faces, inv = np.unique(self.near, return_inverse=True)
            self._near_at = inv.reshape(-1, 2)
        pairs = self.near
        if len(pairs) == 0:
            return empty
        faces = self._near_faces
        G, R = self._spheres(X, faces)
        i, j = self._near_at.T
        pairs = pairs[norm(G[i] - G[j]) < R[i] + R[j]]
        if len(pairs):
            pairs = pairs[~self._separated(X, pairs, 2e-3 * float(R.max()))]
        if len(pairs) == 0:
            return empty
        faces = np.unique(pairs)
        sub = face_health(X, self.F[faces]).intersecting_pairs
        if len(sub) == 0:
            return empty
        out = np.sort(faces[sub], axis=1)
        return out[np.lexsort((out[:, 1], out[:, 0]))]


def length3(x, y, z):
    """Lengths of vectors given by their components (1-D arrays): the numbers of ``np.linalg.norm(v, axis=1)`` on the
    rows ``(x, y, z)``.

    Example
    -------
    >>> length3(np.array([3.0]), np.array([4.0]), np.array([0.0]))
    array([5.])
    """
    return np.sqrt(x * x + y * y + z * z)


def einsum_sum3(t0, t1, t2):
    """``t0 + t1 + t2`` summed in the order numpy's ``np.einsum`` sums a contiguous axis of three products
    (measured on numpy 2.4: ``0 + ((t0 + t2) + t1)``, two SIMD lanes, then the tail, into a zeroed output), so that
    kernels working component by component (1-D gathers, no ``(q, 3)`` rows) give the numbers, signed zeros
    included, that einsum's row-wise dot products (``np.einsum("ij,ij->i", a, b)`` and the like) gave before them.
    Another order would differ only by round-off; the order is kept because the solver's path turns round-off
    into a different result.

    Example
    -------
    >>> einsum_sum3(np.array([1.0, -0.0]), np.array([2.0, -0.0]), np.array([3.0, -0.0]))
    array([6., 0.])
    """
    return 0.0 + ((t0 + t2) + t1)


def _cross(a, b):
    """:func:`components.core.measures.cross` of two vectors given by their components ``(x, y, z)``."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


def _face_normal_sum(P):
    """``(c − a) × (last − b) + (b − a) × (c − a)`` of corners ``P`` (``k`` component tuples, ``a, b, c`` the
    first three): a normal of the face (twice the area vector of a quad)."""
    d = [tuple(q - p for p, q in zip(P[0], P[i])) for i in (1, 2)]  # b − a, c − a
    n1 = _cross(d[1], tuple(q - p for p, q in zip(P[1], P[-1])))
    n2 = _cross(d[0], d[1])
    return tuple(u + v for u, v in zip(n1, n2))


def _corner_mean(P):
    """The mean corner ``(x, y, z)`` of ``k`` corner component tuples (summed corner by corner, as ``mean``)."""
    total = P[0]
    for p in P[1:]:
        total = tuple(t + c for t, c in zip(total, p))
    return tuple(t / len(P) for t in total)


def _extent(ax0, ax1, ax2, P):
    """Smallest and largest projection ``(p, a)`` of the corners ``P`` (``k`` tuples of ``(p,)`` components) on
    the axes ``(ax0, ax1, ax2)`` (components, each ``(p, a)``), corner by corner (``ax · P_k`` summed as
    :func:`einsum_sum3`)."""
    lo = hi = None
    for x, y, z in P:
        proj = einsum_sum3(ax0 * x[:, None], ax1 * y[:, None], ax2 * z[:, None])
        if lo is None:
            lo, hi = proj, proj.copy()
        else:
            np.minimum(lo, proj, out=lo)
            np.maximum(hi, proj, out=hi)
    return lo, hi


def _sphere_pairs(G, R) -> np.ndarray:
    """Index pairs ``(i, j)``, ``i < j``, of spheres (centres ``G``, radii ``R``) that overlap
    (``|G_i − G_j| < R_i + R_j``).

    The spheres up to 1.35 × the median radius (on a mesh of even faces, nearly all) are paired by one
    ``query_pairs`` at twice the largest of their radii, the larger ones by one query of a tree of their own
    against all centres at their largest radius plus the largest radius: a superset of the overlapping pairs
    (widened by a relative ``1e-9`` against rounding in the trees' distances), then tested exactly. A single
    ``query_pairs`` at twice the largest radius listed six times the pairs on conjugate-field candidates."""
    empty = np.zeros((0, 2), dtype=np.int64)
    if len(R) < 2:
        return empty
    widen = 1.0 + 1e-9
    small = R <= 1.35 * float(np.median(R))
    si = np.nonzero(small)[0]
    bi = np.nonzero(~small)[0]
    found = []
    if len(si) > 1:  # query_pairs gives i < j, and si is ascending
        tree = cKDTree(G[si], balanced_tree=False, compact_nodes=False)
        found.append(si[tree.query_pairs(2.0 * float(R[si].max()) * widen, output_type="ndarray")])
    if len(bi):
        near = cKDTree(G[bi], balanced_tree=False, compact_nodes=False).sparse_distance_matrix(
            cKDTree(G, balanced_tree=False, compact_nodes=False), (float(R[bi].max()) + float(R.max())) * widen,
            output_type="ndarray")
        a, b = bi[near["i"]], near["j"].astype(np.int64)
        keep = (a != b) & (small[b] | (b > a))  # a pair of two large spheres once
        found.append(np.sort(np.stack([a[keep], b[keep]], axis=1), axis=1))
    if not found:
        return empty
    pairs = np.concatenate(found).astype(np.int64, copy=False).reshape(-1, 2)
    i, j = np.ascontiguousarray(pairs[:, 0]), np.ascontiguousarray(pairs[:, 1])
    Gx, Gy, Gz = np.ascontiguousarray(G.T)
    dx, dy, dz = Gx[i] - Gx[j], Gy[i] - Gy[j], Gz[i] - Gz[j]
    d = length3(dx, dy, dz)  # norm(G[i] − G[j]) from 1-D gathers
    keep = d < R[i] + R[j]
    return np.stack([i[keep], j[keep]], axis=1)
