"""Geometry helpers of the planarization solver: planarity measures, panel shape, star topology, closest points.

The public functions here (:func:`face_planarity`, :func:`warping_height`, :func:`corner_angles`,
:func:`nonconvex_faces`) are array-level measures that the solver reports. The closest-point helpers are private
fallbacks used until ``components.proximity`` provides ``TriangleIndex`` / ``closest_points_on_polyline``; the solver
switches to those automatically when they exist.
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.mesh import face_sizes

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------------------------
# corners of padded polygon faces


class Corners(NamedTuple):
    """Every corner of every face: vertex, previous and next corner vertex, face."""

    v: np.ndarray  # (c,) vertex at the corner
    prev: np.ndarray  # (c,) previous vertex of the face
    next: np.ndarray  # (c,) next vertex of the face
    face: np.ndarray  # (c,) face index
    slot: np.ndarray  # (c,) position of the corner in its face


def face_corners(F: np.ndarray) -> Corners:
    """All corners of padded polygon faces, face by face, in face order."""
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    sizes = face_sizes(F)
    cols = np.arange(k)[None, :]
    valid = cols < sizes[:, None]
    s = sizes[:, None]
    nxt_idx = (cols + 1) % s
    prv_idx = (cols - 1) % s
    rows = np.broadcast_to(np.arange(m)[:, None], (m, k))
    v = F[valid]
    nxt = F[rows, nxt_idx][valid]
    prv = F[rows, prv_idx][valid]
    return Corners(v, prv, nxt, rows[valid].copy(), np.broadcast_to(cols, (m, k))[valid].copy())


def corner_angles(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Interior angle (radians, unsigned, in ``[0, π]``) at every corner, in :func:`face_corners` order."""
    C = face_corners(F)
    V = np.asarray(V, dtype=np.float64)
    a = V[C.prev] - V[C.v]
    b = V[C.next] - V[C.v]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def _newell(V, F):
    from components.mesh import face_normals

    return face_normals(V, F, unit=True)


def nonconvex_faces(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``(m,) bool``: faces with a reflex (or folded) corner.

    A corner is convex when the turn ``(v - prev) × (next - v)`` points along the face's Newell normal; a face
    is non-convex when any corner turns the other way (or the face has no normal at all).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    C = face_corners(F)
    N = _newell(V, F)
    turn = np.cross(V[C.v] - V[C.prev], V[C.next] - V[C.v])
    bad = np.einsum("ij,ij->i", turn, N[C.face]) <= 0.0
    out = np.zeros(len(F), dtype=bool)
    np.logical_or.at(out, C.face, bad)
    out |= np.linalg.norm(N, axis=1) == 0.0
    return out


# ----------------------------------------------------------------------------------------------
# planarity


def _lsq_plane_distances(V, F, sizes, idx):
    """Max distance of the corners of faces ``idx`` to their least-squares planes, and their mean edge length."""
    dist = np.zeros(len(idx))
    mel = np.zeros(len(idx))
    for s in np.unique(sizes[idx]):
        sel = np.nonzero(sizes[idx] == s)[0]
        P = V[F[idx[sel], :s]]  # (q, s, 3)
        c = P.mean(axis=1, keepdims=True)
        X = P - c
        # smallest right singular vector of every corner set
        _, _, vt = np.linalg.svd(X)
        n = vt[:, -1, :]
        dist[sel] = np.abs(np.einsum("qsj,qj->qs", X, n)).max(axis=1)
        mel[sel] = np.linalg.norm(np.roll(P, -1, axis=1) - P, axis=2).mean(axis=1)
    return dist, mel


def warping_height(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Warping height of every face in model units.

    For quads the distance between the two diagonal lines; for n-gons (n ≥ 5) the largest distance of a corner
    to the face's least-squares plane; 0 for triangles.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, k) int64

    Returns
    -------
    (m,) float64
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    out = np.zeros(len(F))
    q = np.nonzero(sizes == 4)[0]
    if len(q):
        a, b, c, d = (V[F[q, i]] for i in range(4))
        d1, d2 = c - a, d - b
        cr = np.cross(d1, d2)
        nc = np.linalg.norm(cr, axis=1)
        vol = np.abs(np.einsum("ij,ij->i", b - a, cr))
        out[q] = np.divide(vol, nc, out=np.zeros_like(vol), where=nc > 0)
    g = np.nonzero(sizes > 4)[0]
    if len(g):
        out[g] = _lsq_plane_distances(V, F, sizes, g)[0]
    return out


def face_planarity(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Scale-free planarity of every face.

    Quads: distance between the two diagonal lines divided by the mean diagonal length (libigl's
    ``quad_planarity``, unsigned). N-gons: largest distance of a corner to the least-squares plane divided by
    the mean edge length. Triangles: 0.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, k) int64

    Returns
    -------
    (m,) float64
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    out = np.zeros(len(F))
    q = np.nonzero(sizes == 4)[0]
    if len(q):
        a, b, c, d = (V[F[q, i]] for i in range(4))
        d1, d2 = c - a, d - b
        cr = np.cross(d1, d2)
        nc = np.linalg.norm(cr, axis=1)
        vol = np.abs(np.einsum("ij,ij->i", b - a, cr))
        md = 0.5 * (np.linalg.norm(d1, axis=1) + np.linalg.norm(d2, axis=1))
        den = nc * md
        out[q] = np.divide(vol, den, out=np.zeros_like(vol), where=den > 0)
    g = np.nonzero(sizes > 4)[0]
    if len(g):
        dist, mel = _lsq_plane_distances(V, F, sizes, g)
        out[g] = np.divide(dist, mel, out=np.zeros_like(dist), where=mel > 0)
    return out


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
# closest points (private fallbacks for components.proximity)


def _closest_on_segments(P, A, B):
    d = B - A
    dd = np.einsum("ij,ij->i", d, d)
    t = np.divide(np.einsum("ij,ij->i", P - A, d), dd, out=np.zeros(len(P)), where=dd > 0)
    t = np.clip(t, 0.0, 1.0)
    return A + t[:, None] * d, t


def _closest_on_triangles(P, A, B, C):
    """Closest point of each ``P[i]`` on triangle ``(A[i], B[i], C[i])``; returns points and barycentrics."""
    ab, ac = B - A, C - A
    n = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", n, n)
    ap = P - A
    # barycentrics of the projection
    d00 = np.einsum("ij,ij->i", ab, ab)
    d01 = np.einsum("ij,ij->i", ab, ac)
    d11 = np.einsum("ij,ij->i", ac, ac)
    d20 = np.einsum("ij,ij->i", ap, ab)
    d21 = np.einsum("ij,ij->i", ap, ac)
    den = d00 * d11 - d01 * d01
    safe = np.where(den > 0, den, 1.0)
    v = (d11 * d20 - d01 * d21) / safe
    w = (d00 * d21 - d01 * d20) / safe
    u = 1.0 - v - w
    inside = (u >= 0) & (v >= 0) & (w >= 0) & (nn > 0)
    Q = A + v[:, None] * ab + w[:, None] * ac
    bary = np.stack([u, v, w], axis=1)
    out = ~inside
    if out.any():
        Po = P[out]
        best = None
        bb = None
        for (X, Y, ix, iy) in ((A, B, 0, 1), (B, C, 1, 2), (C, A, 2, 0)):
            q, t = _closest_on_segments(Po, X[out], Y[out])
            dist = np.einsum("ij,ij->i", Po - q, Po - q)
            b = np.zeros((len(Po), 3))
            b[np.arange(len(Po)), ix] = 1.0 - t
            b[np.arange(len(Po)), iy] += t
            if best is None:
                best, bq, bb = dist, q, b
            else:
                better = dist < best
                best = np.where(better, dist, best)
                bq = np.where(better[:, None], q, bq)
                bb = np.where(better[:, None], b, bb)
        Q[out] = bq
        bary[out] = bb
    return Q, bary


class _TriangleIndexFallback:
    """Exact closest points on a triangle mesh: k-d tree of centroids with a guaranteed search radius."""

    def __init__(self, V, T):
        self.V = np.asarray(V, dtype=np.float64)
        self.T = np.asarray(T, dtype=np.int64)
        P = self.V[self.T]
        self.cent = P.mean(axis=1)
        self.rad = float(np.linalg.norm(P - self.cent[:, None, :], axis=2).max()) if len(P) else 0.0
        self.tree = cKDTree(self.cent)

    def _eval(self, P, tri):
        A, B, C = (self.V[self.T[tri, i]] for i in range(3))
        Q, bary = _closest_on_triangles(P, A, B, C)
        return Q, bary, np.linalg.norm(P - Q, axis=1)

    def query(self, P):
        P = np.asarray(P, dtype=np.float64)
        k = min(8, len(self.T))
        dk, ik = self.tree.query(P, k=k)
        dk = dk.reshape(len(P), k)
        ik = ik.reshape(len(P), k)
        bestd = np.full(len(P), np.inf)
        bestq = np.zeros_like(P)
        bestb = np.zeros((len(P), 3))
        bestf = np.zeros(len(P), dtype=np.int64)
        for j in range(k):
            q, b, d = self._eval(P, ik[:, j])
            better = d < bestd
            bestd[better], bestq[better], bestb[better], bestf[better] = d[better], q[better], b[better], ik[better, j]
        # a closer triangle must have its centroid within bestd + rad; check the points where that is unsure
        unsure = np.nonzero(dk[:, -1] < bestd + self.rad)[0] if k < len(self.T) else np.zeros(0, np.int64)
        if len(unsure):
            lists = self.tree.query_ball_point(P[unsure], bestd[unsure] + self.rad)
            cnt = np.array([len(x) for x in lists])
            if cnt.sum():
                pi = np.repeat(unsure, cnt)
                ti = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists if len(x)])
                q, b, d = self._eval(P[pi], ti)
                order = np.lexsort((d, pi))
                pi, ti, q, b, d = pi[order], ti[order], q[order], b[order], d[order]
                firsts = np.ones(len(pi), dtype=bool)
                firsts[1:] = pi[1:] != pi[:-1]
                pi, ti, q, b, d = pi[firsts], ti[firsts], q[firsts], b[firsts], d[firsts]
                better = d < bestd[pi]
                sel = pi[better]
                bestd[sel], bestq[sel], bestb[sel], bestf[sel] = d[better], q[better], b[better], ti[better]
        return bestq, bestd, bestf, bestb


class _TriangleQuery:
    """``query(P) -> (points, distances, faces)`` over a triangle mesh, built once per solve."""

    def __init__(self, V, T):
        try:
            from components.proximity import TriangleIndex
        except ImportError:  # pragma: no cover - the sibling module is present in this tree
            TriangleIndex = None
        self._shared = TriangleIndex(V, T, name="reference") if TriangleIndex is not None else None
        self._fallback = None if self._shared is not None else _TriangleIndexFallback(V, T)

    def query(self, P):
        if self._shared is not None:
            res = self._shared.query(P)
            return np.asarray(res.points), np.asarray(res.distances), np.asarray(res.faces)
        q, d, f, _ = self._fallback.query(P)
        return q, d, f


def triangle_query(V, T) -> _TriangleQuery:
    """An index answering closest points on a triangle mesh: ``components.proximity.TriangleIndex`` when it exists,
    else a private k-d tree fallback."""
    return _TriangleQuery(V, T)


class _PolylineIndex:
    """Closest points on a set of polylines (segments ``A[i] → B[i]``)."""

    def __init__(self, A, B):
        self.A = np.asarray(A, dtype=np.float64)
        self.B = np.asarray(B, dtype=np.float64)
        mid = 0.5 * (self.A + self.B)
        self.rad = float(0.5 * np.linalg.norm(self.B - self.A, axis=1).max()) if len(self.A) else 0.0
        self.tree = cKDTree(mid)

    def query(self, P):
        P = np.asarray(P, dtype=np.float64)
        if len(P) == 0:
            return P.copy(), np.zeros(0, dtype=np.int64)
        k = min(4, len(self.A))
        dk, ik = self.tree.query(P, k=k)
        dk = dk.reshape(len(P), k)
        ik = ik.reshape(len(P), k)
        bestd = np.full(len(P), np.inf)
        bestq = np.zeros_like(P)
        bests = np.zeros(len(P), dtype=np.int64)
        for j in range(k):
            q, _ = _closest_on_segments(P, self.A[ik[:, j]], self.B[ik[:, j]])
            d = np.linalg.norm(P - q, axis=1)
            better = d < bestd
            bestd[better], bestq[better], bests[better] = d[better], q[better], ik[better, j]
        if k < len(self.A):
            for i in np.nonzero(dk[:, -1] < bestd + self.rad)[0]:
                segs = np.asarray(self.tree.query_ball_point(P[i], bestd[i] + self.rad), dtype=np.int64)
                if len(segs) == 0:
                    continue
                q, _ = _closest_on_segments(np.repeat(P[i:i + 1], len(segs), 0), self.A[segs], self.B[segs])
                d = np.linalg.norm(q - P[i], axis=1)
                j = int(np.argmin(d))
                if d[j] < bestd[i]:
                    bestd[i], bestq[i], bests[i] = d[j], q[j], segs[j]
        return bestq, bests


def loop_segments(V: np.ndarray, loops: list) -> tuple[np.ndarray, np.ndarray]:
    """Segments ``(A, B)`` of closed vertex loops."""
    if not loops:
        return np.zeros((0, 3)), np.zeros((0, 3))
    A = np.concatenate([V[lp] for lp in loops])
    B = np.concatenate([V[np.roll(lp, -1)] for lp in loops])
    return A, B
