"""Geometry helpers of the planarization solver: planarity measures, panel shape, star topology, closest points.

The public functions here (:func:`face_planarity`, :func:`warping_height`, :func:`corner_angles`,
:func:`nonconvex_faces`, :func:`corner_turns`) are array-level measures that the solver reports and guards; the
planarity measures are the shared ones of :mod:`components.metrics.quality`, closest points come from
:mod:`components.core.proximity`.
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from components.metrics import quality as metrics
from components.core.mesh import Corners, face_corners, face_normals, face_sizes  # noqa: F401  (Corners, face_corners re-exported)
from components.core.proximity import PolylineIndex

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------------------------
# corners of padded polygon faces


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _cross(a, b):
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def corner_angles(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Interior angle (radians, unsigned, in ``[0, π]``) at every corner, in :func:`face_corners` order."""
    C = face_corners(F)
    V = np.asarray(V, dtype=np.float64)
    a = V[C.v] - V[C.prev]
    b = V[C.next] - V[C.v]
    c = _cross(a, b)
    return np.arctan2(np.sqrt(_dot(c, c)), -_dot(a, b))


def nonconvex_faces(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``(m,) bool``: faces with a reflex (or folded) corner.

    A corner is convex when the turn ``(v - prev) × (next - v)`` points along the face's Newell normal; a face
    is non-convex when any corner turns the other way (or the face has no normal at all).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    C = face_corners(F)
    N = face_normals(V, F, unit=True)
    turn = _cross(V[C.v] - V[C.prev], V[C.next] - V[C.v])
    bad = _dot(turn, N[C.face]) <= 0.0
    out = np.zeros(len(F), dtype=bool)
    out[C.face[bad]] = True
    out |= ~np.any(N != 0.0, axis=1)
    return out


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
            N = 0.5 * _cross(X[F[:, 2]] - X[F[:, 0]], X[F[:, 3]] - X[F[:, 1]])
        else:
            C = self.C
            cr = _cross(X[C.v], X[C.next])
            N = np.empty((self.m, 3))
            for j in range(3):
                N[:, j] = 0.5 * np.bincount(C.face, cr[:, j], minlength=self.m)
        if unit:
            L = np.sqrt(_dot(N, N))
            N = N / np.where(L > 0, L, np.inf)[:, None]
        return N

    def turns(self, X: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`corner_turns` on this mesh."""
        return corner_turns(X, self.C, N)

    def shape(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unsigned corner angles ``(c,)`` (:func:`corner_angles`) and non-convex faces ``(m,) bool``
        (:func:`nonconvex_faces`) in one pass."""
        C = self.C
        a = X[C.v] - X[C.prev]
        b = X[C.next] - X[C.v]
        cr = _cross(a, b)
        ang = np.arctan2(np.sqrt(_dot(cr, cr)), -_dot(a, b))
        N = self.normals(X)
        ncv = np.zeros(self.m, dtype=bool)
        ncv[C.face[_dot(cr, N[C.face]) <= 0.0]] = True
        ncv |= ~np.any(N != 0.0, axis=1)
        return ang, ncv


# ----------------------------------------------------------------------------------------------
# planarity


def warping_height(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Warping height of every face in model units (:func:`components.metrics.quality.warping_height`).

    Quads: the distance between the two diagonal lines; n-gons (n ≥ 5): the largest distance of a corner to the
    face's least-squares plane; triangles: 0. Returns ``(m,) float64``.
    """
    return metrics.warping_height(V, F)


def face_planarity(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Scale-free planarity of every face (:func:`components.metrics.quality.quad_planarity`).

    Quads: distance between the two diagonal lines divided by the mean diagonal length (libigl's
    ``quad_planarity``, unsigned); n-gons: largest distance of a corner to the least-squares plane divided by the
    mean edge length; triangles: 0. Returns ``(m,) float64``.
    """
    return metrics.quad_planarity(V, F)


def corner_turns(X: np.ndarray, C: Corners, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed turn and unsigned angle at every corner.

    The turn is ``((v − prev) × (next − v)) · n / (|v − prev| |next − v|)`` with ``n`` the unit normal of the
    corner's face (``N (m, 3)``): the sine of the interior angle, negative at a reflex corner. A planar face is
    convex with all angles in ``[θ, π − θ]`` exactly when every turn is at least ``sin θ``.

    Returns
    -------
    turn : (c,) float64
    angle : (c,) float64
        Unsigned angle in ``[0, π]`` between the two edges at the corner (:func:`corner_angles`).
    """
    a = X[C.v] - X[C.prev]
    b = X[C.next] - X[C.v]
    cr = _cross(a, b)
    den = np.maximum(np.sqrt(_dot(a, a) * _dot(b, b)), 1e-300)
    turn = _dot(cr, N[C.face]) / den
    angle = np.arctan2(np.sqrt(_dot(cr, cr)), -_dot(a, b))
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
        self._loops = [PolylineIndex(X[lp], closed=True, name="boundary") for lp in loops if len(lp) >= 2]

    def __bool__(self):
        return bool(self._loops)

    def query(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest points ``(p, 3)`` on the loops and the unit tangents ``(p, 3)`` of the segments holding them."""
        P = np.asarray(P, dtype=np.float64)
        best_d = np.full(len(P), np.inf)
        Q = np.zeros_like(P)
        T = np.zeros_like(P)
        if len(P) == 0:
            return Q, T
        for idx in self._loops:
            res = idx.query(P, name="boundary vertices")
            better = res.distances < best_d
            if better.any():
                best_d[better] = res.distances[better]
                Q[better] = res.points[better]
                t = idx.B[res.segments[better]] - idx.A[res.segments[better]]
                T[better] = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
        return Q, T
