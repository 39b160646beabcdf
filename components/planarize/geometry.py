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

__all__ = ["FaceFrames", "corner_turns", "Stars", "vertex_stars", "LoopIndex", "crossing_pairs", "CrossingWatch"]


# ----------------------------------------------------------------------------------------------
# per-iteration face normals and corner turns


class FaceFrames:
    """Fast per-iteration face normals and corner turns of one mesh (index data built once per solver call).

    All-quad meshes take the Newell normal from the diagonals (``½ (c − a) × (d − b)``, the same vector); other
    meshes sum the corner cross products face by face.
    """

    def __init__(self, F: np.ndarray, corners: Corners):
        self.F = np.asarray(F, dtype=np.int64)
        self.C = corners
        self.m = len(self.F)
        self.all_quads = bool(self.F.shape[1] == 4 and np.all(face_sizes(self.F) == 4))

    def normals(self, X: np.ndarray, unit: bool = True) -> np.ndarray:
        """Newell normals ``(m, 3)`` (unit, zero for degenerate faces; area vectors when ``unit=False``)."""
        if self.all_quads:
            F = self.F
            N = 0.5 * cross(X[F[:, 2]] - X[F[:, 0]], X[F[:, 3]] - X[F[:, 1]])
        else:
            C = self.C
            cr = cross(X[C.v], X[C.next])
            N = np.empty((self.m, 3))
            for j in range(3):
                N[:, j] = 0.5 * np.bincount(C.face, cr[:, j], minlength=self.m)
        if unit:
            L = norm(N)
            N = N / np.where(L > 0, L, np.inf)[:, None]
        return N

    def turns(self, X: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`corner_turns` on this mesh."""
        return corner_turns(X, self.C, N)

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


def corner_turns(X: np.ndarray, C: Corners, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed turn and unsigned angle at every corner.

    The turn is ``((v − prev) × (next − v)) · n / (|v − prev| |next − v|)`` with ``n`` the unit normal of the
    corner's face (``N (m, 3)``): the sine of the interior angle, negative at a reflex corner. A planar face is
    convex with all angles in ``[θ, π − θ]`` exactly when every turn is at least ``sin θ``.

    Returns
    -------
    turn : (c,) float64
    angle : (c,) float64
        Unsigned angle in ``[0, π]`` between the two edges at the corner
        (:func:`components.core.measures.corner_angles`).
    """
    a = X[C.v] - X[C.prev]
    b = X[C.next] - X[C.v]
    cr = cross(a, b)
    den = np.maximum(np.sqrt(dot(a, a) * dot(b, b)), 1e-300)
    turn = dot(cr, N[C.face]) / den
    angle = np.arctan2(norm(cr), -dot(a, b))
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

    One :class:`components.core.proximity.PolylineIndex` per loop; a query keeps the nearest loop.
    """

    def __init__(self, X: np.ndarray, loops: list):
        kept = [k for k, lp in enumerate(loops) if len(lp) >= 2]
        self._numbers = np.array(kept, dtype=np.int64)  # the kept loops' positions in ``loops``
        self._loops = [PolylineIndex(X[loops[k]], closed=True, name="boundary") for k in kept]

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
        for number, idx in zip(self._numbers, self._loops):
            res = idx.query(P, name="boundary vertices")
            better = res.distances < best_d
            if better.any():
                best_d[better] = res.distances[better]
                Q[better] = res.points[better]
                L[better] = number
                t = idx.B[res.segments[better]] - idx.A[res.segments[better]]
                T[better] = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
        return Q, T, L


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

    def _spheres(self, X, faces=slice(None)):
        """Centres and radii of the bounding spheres of ``faces`` (all by default) at ``X``."""
        P, valid, sizes = X[self.F[faces]], self.valid[faces], self.sizes[faces]
        G = (P * valid[..., None]).sum(axis=1) / sizes[:, None]
        R = np.sqrt(np.where(valid, dot(P - G[:, None, :], P - G[:, None, :]), 0.0).max(axis=1))
        return G, R

    def _apart(self, pairs):
        if len(pairs) == 0:
            return pairs
        F = self.F
        return pairs[~(F[pairs[:, 0]][:, :, None] == F[pairs[:, 1]][:, None, :]).any(axis=(1, 2))]

    def _separated(self, X, pairs, gap) -> np.ndarray:
        """``(p,) bool``: face pairs whose corner sets lie more than ``gap`` apart along one of the axes tried (the
        two face normals, the line between the centroids, the in-plane normals of every edge of both faces): their
        convex hulls, hence their fan triangles, cannot touch (a separating axis; the exact test's tolerance is
        under ``gap``). Faces side by side on a surface are separated by an edge normal, so most sphere-overlapping
        pairs end here and the exact test sees only the few that come close."""
        F = self.F
        k = F.shape[1]
        first = np.repeat(F[:, :1], k, axis=1)
        Fp = np.where(self.valid, F, first)  # padding: the first corner again (min / max unchanged)
        nxt = np.where(np.roll(self.valid, -1, axis=1), np.roll(F, -1, axis=1), F[:, :1])
        nxt = np.where(self.valid, nxt, first)
        A, B = X[Fp[pairs[:, 0]]], X[Fp[pairs[:, 1]]]  # (p, k, 3)
        EA = X[nxt[pairs[:, 0]]] - A
        EB = X[nxt[pairs[:, 1]]] - B
        NA = cross(A[:, 2] - A[:, 0], A[:, -1] - A[:, 1]) + cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0])
        NB = cross(B[:, 2] - B[:, 0], B[:, -1] - B[:, 1]) + cross(B[:, 1] - B[:, 0], B[:, 2] - B[:, 0])
        axes = np.concatenate([NA[:, None], NB[:, None], (B.mean(axis=1) - A.mean(axis=1))[:, None],
                               cross(NA[:, None, :], EA), cross(NB[:, None, :], EB)], axis=1)  # (p, 3 + 2k, 3)
        L = np.sqrt(np.einsum("pai,pai->pa", axes, axes))
        axes = axes / np.where(L > 0, L, np.inf)[..., None]
        pa = np.einsum("pai,pki->pak", axes, A)
        pb = np.einsum("pai,pki->pak", axes, B)
        apart = (pa.max(axis=2) + gap < pb.min(axis=2)) | (pb.max(axis=2) + gap < pa.min(axis=2))
        return apart.any(axis=1)

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
        pairs = self.near
        if len(pairs) == 0:
            return empty
        faces, inv = np.unique(pairs, return_inverse=True)
        G, R = self._spheres(X, faces)
        i, j = inv.reshape(-1, 2).T
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


def _sphere_pairs(G, R) -> np.ndarray:
    """Index pairs ``(i, j)``, ``i < j``, of spheres (centres ``G``, radii ``R``) that overlap: one ``query_pairs``
    for the spheres up to 4 × the median radius, one ball query per larger sphere."""
    cap = 4.0 * float(np.median(R))
    small = R <= cap
    found = []
    si = np.nonzero(small)[0]
    if len(si) > 1:
        found.append(si[cKDTree(G[si]).query_pairs(2.0 * float(R[si].max()), output_type="ndarray")])
    bi = np.nonzero(~small)[0]
    if len(bi):
        lists = cKDTree(G).query_ball_point(G[bi], R[bi] + float(R.max()))
        a = np.repeat(bi, [len(x) for x in lists])
        b = np.fromiter((j for x in lists for j in x), dtype=np.int64, count=len(a))
        keep = (a != b) & (small[b] | (b > a))
        found.append(np.stack([a[keep], b[keep]], axis=1))
    if not found:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = np.sort(np.concatenate(found).astype(np.int64).reshape(-1, 2), axis=1)
    d = norm(G[pairs[:, 0]] - G[pairs[:, 1]])
    return pairs[d < R[pairs[:, 0]] + R[pairs[:, 1]]]
