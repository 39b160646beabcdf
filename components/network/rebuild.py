"""Quad rebuild: a two-family line network on a disk-like surface → the plane → crossings → a quad-dominant mesh.

A curvature-line network (two families of polylines traced on a triangle mesh, see
:mod:`components.network.tracing`) is turned into a mesh in five steps:

1. **Plane.** The triangle mesh is mapped to the plane by a conformal map (LSCM, orientation kept; a fixed-boundary
   disk map when LSCM folds), so the network's right angles stay right angles in the plane.
2. **Network in the plane.** Every polyline point is located on the mesh (closest point, barycentric coordinates)
   and carried to the plane with the same barycentric coordinates; polylines are resampled finely.
3. **Naked ends.** A line that stops short of the boundary (the tracer stopped it near another line, an umbilic
   region or the boundary) is extended straight to the boundary when the gap is at most ``gap`` panel sizes;
   otherwise its dangling piece beyond the last crossing is dropped (a T-junction remains).
4. **Arrangement.** Crossings of the two families are found (segment–segment tests on a spatial index); crossings,
   boundary ends and boundary corners become nodes, consecutive nodes along a line or along the boundary become
   edges, nodes closer than ``merge`` panel sizes to a boundary node are merged into it, and the faces of the planar
   graph are traced (the edge to the right of the reverse half-edge). Faces with 3 to ``max_face_size`` corners are
   kept; the outer face and larger cells (holes, e.g. skipped umbilic regions) are dropped. A hexagon whose two
   opposite corners are flat (a line interrupted inside one cell: two facing T-junctions) is split into two quads
   along the diagonal joining them, which restores the missing piece of line.
5. **Back to 3D.** Every node is located in the planar triangulation and mapped back with its barycentric
   coordinates: the candidate lies on the input surface.
6. **Healing** (``boundary_cells="extend"``, the strategy's default): the boundary cells and the larger cells are kept and the
   cell complex is healed in the plane (:mod:`components.network.healing`), so the panels reach the design boundary
   with no short edge, flat, sharp or reflex corner, tiny cell or hole; cells under which the surface bulges more
   than ``max_bulge`` × the median edge from their corners' plane are split in two (a flat panel over them would
   leave their middle far from the design surface).

Boundary corners are taken at the scale of a panel (the turn over a quarter and three quarters of a panel on both
sides): the teeth of a boundary cut along a mesh's triangles make no corner nodes.

Array-level functions: :func:`plane_map`, :func:`network_to_plane`, :func:`network_crossings`,
:func:`rebuild_from_network`. The published component :func:`quad_rebuild` lives here too (it traces the network
with :func:`components.network.tracing.principal_network` first).

References
----------
Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*, SIGGRAPH
2006 (curvature-line networks as the origin of conical meshes); Alliez, Cohen-Steiner, Devillers, Lévy, Desbrun,
*Anisotropic polygonal remeshing*, SIGGRAPH 2003 (lines of curvature traced, intersected in a conformal
parametrization and turned into a quad-dominant mesh).
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.core.blas import single_blas_thread
from components.core.checks import check_choice, check_number
from components.core.memo import ContentCache, digest
from components.core.conformal import cached_boundary_loops, check_disk, disk_map, lscm
from components.core.errors import MeshError
from components.core.mesh import edge_topology, face_sizes, pad_faces
from components.core.types import Curves, Mesh, Numbers
from components.network.healing import NODE_BOUNDARY, NODE_CORNER, NODE_CROSSING, healed_cells, manifold_cells
from components.network.tracing import network_for_mesh, principal_angle_error, surface_index

log = logging.getLogger(__name__)

__all__ = [
    "Rebuild",
    "QuadRebuildResult",
    "network_crossings",
    "network_to_plane",
    "plane_map",
    "quad_rebuild",
    "rebuild_from_network",
    "uv_to_surface",
]

PLANE_MAPS = ("lscm", "disk")
#: what to do with a surface the rebuild cannot take (its lines are intersected in one plane map of a disk)
NOT_A_DISK = ("the curvature-network rebuild needs a surface with exactly one boundary loop and no handle; fill its "
              "holes or split it into disk-like patches, or, for holes, use fields/pq_from_conjugate_field (the "
              "conjugate strategy), which takes them (not handles)")
BOUNDARY_CELLS = ("extend", "trim", "keep")
MAX_BULGE = 0.12  # × median edge: healed cells under which the surface bulges more are split (coverage: 0.25)


# ----------------------------------------------------------------------------------------------
# the plane


def _signed_areas(UV, T):
    a, b, c = UV[T[:, 0]], UV[T[:, 1]], UV[T[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def plane_map(V: np.ndarray, T: np.ndarray, method: str = "lscm") -> tuple[np.ndarray, list[str]]:
    """Map a disk-like triangle mesh to the plane, keeping its orientation (counter-clockwise triangles).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles of a topological disk, consistently oriented.
    method : {"lscm", "disk"}
        ``"lscm"``: least-squares conformal map (free boundary, falls back to the disk map if it folds);
        ``"disk"``: fixed-boundary harmonic map onto the unit disk, scaled to the surface's area.

    Returns
    -------
    UV : (n, 2) float64
        Parameter coordinates; every triangle has positive signed area when the map is an embedding.
    warnings : list of str
        What was done instead (fallbacks).

    Raises
    ------
    MeshError
        No boundary, several boundary loops or handles (not a disk), several components (named ``mesh``).
    """
    check_choice(method, "method", PLANE_MAPS)
    # the strategy's retries rebuild on the same surface
    UV, warnings = _PLANE.get(digest(method, np.asarray(V, np.float64), np.asarray(T, np.int64)),
                              lambda: _plane_map(V, T, method))
    return UV.copy(), list(warnings)


_PLANE = ContentCache("plane maps")  # the last plane map computed (plane_map)


def _plane_map(V, T, method):
    warnings: list[str] = []
    check_disk(V, T, cached_boundary_loops(T), NOT_A_DISK)
    UV = None
    if method == "lscm":
        UV = lscm(V, T)
        S = _signed_areas(UV, T)
        if np.sum(S < 0) > np.sum(S > 0):
            UV[:, 0] = -UV[:, 0]
            S = -S
        nflip = int(np.sum(S <= 0))
        if nflip:
            warnings.append(f"the conformal map (LSCM) folds {nflip} triangles; used the fixed-boundary disk map")
            UV = None
    if UV is None:
        UV, info = disk_map(V, T, shape="disk")
        warnings.extend(info["warnings"])
        S = _signed_areas(UV, T)
        if np.sum(S < 0) > np.sum(S > 0):
            UV[:, 0] = -UV[:, 0]
        a3 = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum()
        UV *= math.sqrt(a3 / max(abs(_signed_areas(UV, T).sum()), 1e-300))
    return UV, warnings


class _Locator:
    """Point location in a planar triangulation (nearest centroids, then barycentric tests)."""

    def __init__(self, UV, T):
        self.UV, self.T = UV, T
        self.tree = cKDTree(UV[T].mean(axis=1))

    def bary(self, P, faces):
        a, b, c = self.UV[self.T[faces, 0]], self.UV[self.T[faces, 1]], self.UV[self.T[faces, 2]]
        v0, v1, v2 = b - a, c - a, P[..., :] - a
        d00 = np.einsum("...i,...i->...", v0, v0)
        d01 = np.einsum("...i,...i->...", v0, v1)
        d11 = np.einsum("...i,...i->...", v1, v1)
        d20 = np.einsum("...i,...i->...", v2, v0)
        d21 = np.einsum("...i,...i->...", v2, v1)
        den = d00 * d11 - d01 * d01
        den = np.where(np.abs(den) > 1e-300, den, 1e-300)
        w1 = (d11 * d20 - d01 * d21) / den
        w2 = (d00 * d21 - d01 * d20) / den
        return np.stack([1.0 - w1 - w2, w1, w2], axis=-1)

    def locate(self, P):
        """Triangle and clamped barycentric coordinates of every point ``P`` (p, 2)."""
        P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
        face = np.zeros(len(P), dtype=np.int64)
        B = np.zeros((len(P), 3))
        todo = np.arange(len(P))
        for k in (8, 32, 128):
            if len(todo) == 0:
                break
            k = min(k, len(self.T))
            _, cand = self.tree.query(P[todo], k=k)
            cand = cand.reshape(len(todo), k)
            W = self.bary(P[todo][:, None, :], cand)  # (q, k, 3)
            score = W.min(axis=2)
            best = np.argmax(score, axis=1)
            rows = np.arange(len(todo))
            face[todo] = cand[rows, best]
            B[todo] = W[rows, best]
            done = score[rows, best] >= -1e-9
            todo = todo[~done]
        # points outside (numerically on the boundary): clamp to the best triangle
        B = np.clip(B, 0.0, None)
        B /= B.sum(axis=1, keepdims=True)
        return face, B


def uv_to_surface(V: np.ndarray, T: np.ndarray, UV: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map plane points back to the surface by barycentric coordinates in the planar triangulation.

    Parameters
    ----------
    V : (n, 3) float64
        Surface vertices.
    T : (t, 3) int64
        Triangles.
    UV : (n, 2) float64
        The plane map of the vertices.
    P : (p, 2) float64
        Points in the plane (inside the image of the mesh; points just outside are clamped to it).

    Returns
    -------
    X : (p, 3) float64
        Surface points.
    faces : (p,) int64
        Triangle of every point.
    """
    loc = _Locator(np.asarray(UV, float), np.asarray(T, np.int64))
    f, B = loc.locate(P)
    return np.einsum("pk,pkj->pj", B, V[T[f]]), f


def network_to_plane(V, T, UV, lines, max_segment: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Carry 3D polylines lying on a triangle mesh to the plane and resample them.

    Parameters
    ----------
    V : (n, 3) float64
        Surface vertices.
    T : (t, 3) int64
        Triangles.
    UV : (n, 2) float64
        The plane map.
    lines : list of (k, 3) float64
        Polylines on (or very near) the surface.
    max_segment : float
        Longest segment after resampling, in plane units.

    Returns
    -------
    uv_lines : list of (k', 2) float64
        Polylines in the plane (duplicate points removed, at least two points each; shorter ones are dropped).
    index : list of int
        Index of the input polyline each output came from.
    """
    lines = [np.asarray(L, dtype=np.float64).reshape(-1, 3) for L in lines]
    if not lines:
        return [], []
    P = np.concatenate(lines)
    cp = surface_index(V, T).query(P)
    Q = np.einsum("pk,pkj->pj", cp.barycentric, UV[T[cp.faces]])
    out, idx = [], []
    start = 0
    for i, L in enumerate(lines):
        q = Q[start:start + len(L)]
        start += len(L)
        if len(q) >= 2:
            step = np.linalg.norm(np.diff(q, axis=0), axis=1)
            keep = np.r_[True, step > 1e-12 * max(max_segment, 1e-300)]
            q = q[keep]
        if len(q) < 2:
            continue
        out.append(_resample(q, max_segment))
        idx.append(i)
    return out, idx


def _resample(q, max_segment):
    seg = np.linalg.norm(np.diff(q, axis=0), axis=1)
    nsub = np.maximum(1, np.ceil(seg / max_segment).astype(np.int64))
    if np.all(nsub == 1):
        return q
    parts = []
    for j in range(len(seg)):
        t = np.arange(nsub[j])[:, None] / nsub[j]
        parts.append(q[j] + t * (q[j + 1] - q[j]))
    parts.append(q[-1:])
    return np.concatenate(parts)


# ----------------------------------------------------------------------------------------------
# crossings


def _segments(lines):
    A = np.concatenate([L[:-1] for L in lines]) if lines else np.zeros((0, 2))
    B = np.concatenate([L[1:] for L in lines]) if lines else np.zeros((0, 2))
    lid = np.concatenate([np.full(len(L) - 1, i) for i, L in enumerate(lines)]) if lines else np.zeros(0, int)
    sid = np.concatenate([np.arange(len(L) - 1) for L in lines]) if lines else np.zeros(0, int)
    last = np.concatenate([np.arange(len(L) - 1) == len(L) - 2 for L in lines]) if lines else np.zeros(0, bool)
    return A, B, lid.astype(np.int64), sid.astype(np.int64), last


def _cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def network_crossings(lines_a: list, lines_b: list):
    """Crossings between two families of planar polylines.

    Parameters
    ----------
    lines_a, lines_b : list of (k, 2) float64
        The two families.

    Returns
    -------
    ia : (c,) int64
        Line of family a of every crossing.
    sa : (c,) float64
        Its parameter along that line (segment index + fraction).
    ib : (c,) int64
        Line of family b.
    sb : (c,) float64
        Parameter along it.
    P : (c, 2) float64
        Crossing points.

    Notes
    -----
    Segments are paired through a k-d tree on their midpoints (radius: the longest segment), then tested exactly;
    segment parameters are half-open ``[0, 1)`` except at a polyline's last segment, so a crossing at a shared
    polyline vertex is found once.
    """
    A1, B1, l1, s1, last1 = _segments(lines_a)
    A2, B2, l2, s2, last2 = _segments(lines_b)
    empty = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2)))
    if len(A1) == 0 or len(A2) == 0:
        return empty
    len1 = np.linalg.norm(B1 - A1, axis=1)
    len2 = np.linalg.norm(B2 - A2, axis=1)
    r = 0.5 * (len1.max() + len2.max()) * 1.0001
    t1 = cKDTree(0.5 * (A1 + B1))
    t2 = cKDTree(0.5 * (A2 + B2))
    M = t1.sparse_distance_matrix(t2, r, output_type="coo_matrix")
    i, j = M.row.astype(np.int64), M.col.astype(np.int64)
    # sparse_distance_matrix drops exact zero distances: add coincident midpoints back
    d0, j0 = t2.query(0.5 * (A1 + B1))
    z = np.nonzero(d0 == 0)[0]
    if len(z):
        i = np.r_[i, z]
        j = np.r_[j, j0[z]]
    p, rr = A1[i], B1[i] - A1[i]
    q, ss = A2[j], B2[j] - A2[j]
    den = _cross2(rr, ss)
    ok = np.abs(den) > 1e-14 * (len1[i] * len2[j] + 1e-300)
    den = np.where(ok, den, 1.0)
    qp = q - p
    t = _cross2(qp, ss) / den
    u = _cross2(qp, rr) / den
    hi1 = np.where(last1[i], 1.0 + 1e-12, 1.0)
    hi2 = np.where(last2[j], 1.0 + 1e-12, 1.0)
    hit = ok & (t >= 0) & (t < hi1) & (u >= 0) & (u < hi2)
    i, j, t, u = i[hit], j[hit], np.minimum(t[hit], 1.0), np.minimum(u[hit], 1.0)
    P = A1[i] + t[:, None] * (B1[i] - A1[i])
    return l1[i], s1[i] + t, l2[j], s2[j] + u, P


# ----------------------------------------------------------------------------------------------
# boundary


class _Boundary:
    """The boundary polygon in the plane with an arc-length parameter."""

    def __init__(self, P):
        self.P = P
        self.Q = np.roll(P, -1, axis=0)
        self.len = np.linalg.norm(self.Q - P, axis=1)
        self.cum = np.r_[0.0, np.cumsum(self.len)]
        self.total = float(self.cum[-1])

    def project(self, X):
        """Closest boundary point, its distance and arc-length parameter of every point X (p, 2)."""
        X = np.asarray(X, float).reshape(-1, 2)
        d = self.Q - self.P
        ll = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
        out_p = np.zeros_like(X)
        out_d = np.zeros(len(X))
        out_s = np.zeros(len(X))
        for a in range(0, len(X), 256):
            x = X[a:a + 256]
            t = np.clip(np.einsum("pij,ij->pi", x[:, None, :] - self.P[None], d) / ll, 0.0, 1.0)
            C = self.P[None] + t[..., None] * d[None]
            dist = np.linalg.norm(C - x[:, None, :], axis=2)
            k = np.argmin(dist, axis=1)
            rows = np.arange(len(x))
            out_p[a:a + 256] = C[rows, k]
            out_d[a:a + 256] = dist[rows, k]
            out_s[a:a + 256] = self.cum[k] + t[rows, k] * self.len[k]
        return out_p, out_d, out_s

    def ray(self, o, r):
        """Smallest positive distance along the unit ray ``o + t r`` to the boundary (inf when none)."""
        d = self.Q - self.P
        den = _cross2(r[None, :], d)
        ok = np.abs(den) > 1e-14 * self.len  # not parallel (relative to the edge length)
        den = np.where(ok, den, 1.0)
        w = self.P - o[None, :]
        t = _cross2(w, d) / den
        u = _cross2(w, r[None, :]) / den
        hit = ok & (t > 1e-12 * self.total) & (u >= 0) & (u <= 1)
        return float(t[hit].min()) if hit.any() else math.inf

    def point(self, s):
        s = np.mod(s, self.total)
        k = np.clip(np.searchsorted(self.cum, s, side="right") - 1, 0, len(self.P) - 1)
        t = (s - self.cum[k]) / np.maximum(self.len[k], 1e-300)
        return self.P[k] + t[..., None] * (self.Q[k] - self.P[k])

    def arc(self, s0, s1):
        """Boundary polyline from parameter s0 forward to s1 (wrapping around)."""
        if s1 <= s0:
            s1 = s1 + self.total
        inner = self.cum[:-1]
        ks = np.concatenate([inner, inner + self.total])
        mid = ks[(ks > s0) & (ks < s1)]
        return self.point(np.r_[s0, mid, s1])


# ----------------------------------------------------------------------------------------------
# arrangement → faces


class Rebuild(NamedTuple):
    """Result of :func:`rebuild_from_network`."""

    V: np.ndarray  # (q, 3) candidate vertices on the surface
    F: np.ndarray  # (m, k) faces (quad-dominant, padded), counter-clockwise in the plane
    UV: np.ndarray  # (q, 2) plane positions of the vertices
    kind: np.ndarray  # (q,) 0 crossing, 1 boundary end, 2 boundary corner
    quad_fraction: float
    extended: int  # naked ends closed to the boundary
    trimmed: int  # naked ends trimmed back to their last crossing
    dropped: int  # cells dropped (larger than max_face_size, or degenerate)
    warnings: list


def _find(parent, x):
    """Root of ``x`` in a union-find forest (path halving)."""
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


def _union_find(n, pairs):
    """Cluster representative (the smallest index of its cluster) of each of ``n`` items joined by ``pairs``."""
    parent = np.arange(n)
    for a, b in pairs:
        ra, rb = _find(parent, a), _find(parent, b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([_find(parent, x) for x in range(n)], dtype=np.int64)


def _arc_point(pts, frac=0.3):
    """The point at ``frac`` of the arc length of a polyline (direction proxy for angular sorting)."""
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    s = frac * cum[-1]
    k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1))
    t = (s - cum[k]) / max(seg[k], 1e-300)
    return pts[k] + t * (pts[k + 1] - pts[k])


def _arc_points(polys, frac=0.3):
    """:func:`_arc_point` of every polyline (at least two points each), vectorized with the same arithmetic: (p, 2)."""
    n = np.array([len(p) for p in polys], np.int64)
    P = np.concatenate(polys)
    first = np.r_[0, np.cumsum(n)[:-1]]
    seg_all = np.linalg.norm(np.diff(P, axis=0), axis=1)
    m = n - 1  # segments per polyline
    lane = np.arange(int(m.max()))
    valid = lane[None, :] < m[:, None]
    idx = np.where(valid, first[:, None] + lane[None, :], 0)
    seg = np.where(valid, seg_all[idx], 0.0)
    cum = np.concatenate([np.zeros((len(n), 1)), np.cumsum(seg, axis=1)], axis=1)  # row-wise: as per polyline
    total = cum[np.arange(len(n)), m]
    s = frac * total
    k = np.count_nonzero((cum[:, :-1] <= s[:, None]) & valid, axis=1) - 1  # searchsorted(cum, s, "right") - 1
    k = np.clip(k, 0, m - 1)
    rows = np.arange(len(n))
    t = (s - cum[rows, k]) / np.maximum(seg[rows, k], 1e-300)
    a, b = P[first + k], P[first + k + 1]
    return a + t[:, None] * (b - a)


def _trace_faces(nuv, edges, dirs_out, dirs_in):
    """Faces of a planar graph: cycles of half-edges, each followed by the next one clockwise at its head."""
    ne = len(edges)
    src = np.r_[edges[:, 0], edges[:, 1]]
    dvec = np.r_[dirs_out, dirs_in]  # direction leaving src
    ang = np.arctan2(dvec[:, 1], dvec[:, 0])
    order = np.lexsort((ang, src))
    pos = np.empty(2 * ne, dtype=np.int64)
    pos[order] = np.arange(2 * ne)
    ssrc = src[order]
    first = np.searchsorted(ssrc, ssrc, side="left")
    cnt = np.bincount(src, minlength=len(nuv))[ssrc]
    prev_sorted = first + (np.arange(2 * ne) - first - 1) % cnt  # clockwise neighbour in sorted order
    cw = np.empty(2 * ne, dtype=np.int64)
    cw[order] = order[prev_sorted]
    twin = np.r_[np.arange(ne) + ne, np.arange(ne)]
    nxt = cw[twin]
    seen = np.zeros(2 * ne, dtype=bool)
    faces = []
    for h0 in range(2 * ne):
        if seen[h0]:
            continue
        cyc = []
        h = h0
        while not seen[h]:
            seen[h] = True
            cyc.append(src[h])
            h = nxt[h]
        faces.append(cyc)
    return faces


# ---- step 1-2: the plane scale and the naked ends


def _plane_scale(V, T, UV):
    """3D length per plane length: the square root of the ratio of the surface's area to its image's."""
    a3 = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    a2 = np.abs(_signed_areas(UV, T))
    return math.sqrt(a3.sum() / max(a2.sum(), 1e-300))


def _end_extension(pts, bnd, h_uv, gap, eps_b):
    """Points extending the polyline ``pts`` straight from its last point to the boundary (``None`` when the end
    is on the boundary already, has no direction, or is more than ``gap`` panels from the boundary)."""
    _, dist, _ = bnd.project(pts[-1:])
    if dist[0] <= eps_b:
        return None
    # end direction over the last quarter panel
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.cumsum(seg[::-1])
    k = int(min(np.searchsorted(cum, 0.25 * h_uv) + 1, len(seg)))
    r = pts[-1] - pts[-1 - k]
    nr = np.linalg.norm(r)
    if nr <= 0:
        return None
    r = r / nr
    t = bnd.ray(pts[-1], r)
    if not t <= gap * h_uv:
        return None
    return _resample(np.vstack([pts[-1], pts[-1] + t * r]), 0.25 * h_uv)[1:]


def _extend_naked_ends(L, bnd, h_uv, gap, eps_b):
    """Extend the naked ends of one family's plane polylines ``L`` to the boundary where the gap is small.

    An extension may not run along another line of the family (closer than a quarter panel). Returns the new
    polylines and the number of extended ends; the other naked ends are trimmed later.
    """
    own_id = np.concatenate([np.full(len(q), i) for i, q in enumerate(L)]) if L else np.zeros(0, np.int64)
    tree = cKDTree(np.concatenate(L)) if L else None
    out, extended = [], 0
    for i, q in enumerate(L):
        for end in (0, 1):
            pts = q if end == 1 else q[::-1]
            ext = _end_extension(pts, bnd, h_uv, gap, eps_b)
            if ext is None:
                continue
            hits = tree.query_ball_point(ext, 0.25 * h_uv)
            if any(own_id[j] != i for hs in hits for j in hs):
                continue
            pts = np.vstack([pts, ext])
            extended += 1
            q = pts if end == 1 else pts[::-1]
        out.append(q)
    return out, extended


# ---- step 4: the arrangement (nodes, edges, merges, cells)


class _Nodes(NamedTuple):
    """Nodes of the arrangement: crossings first, then boundary ends, then boundary corners."""

    uv: np.ndarray  # (nn, 2) plane positions
    kind: np.ndarray  # (nn,) NODE_CROSSING, NODE_BOUNDARY or NODE_CORNER
    per_line: list  # per family, per polyline: [(parameter along it, node)]
    boundary: list  # [(boundary arc-length parameter, node)]
    trimmed: int  # naked ends (off the boundary) after a crossing: their piece beyond it is left out


def _boundary_corners(bnd, corner_angle, window) -> np.ndarray:
    """Boundary vertices that are corners at the scale of ``window`` (plane units, about a panel): the boundary
    turns by more than ``corner_angle`` degrees there over a quarter and over three quarters of the window on both
    sides, and by most within three quarters of the window. A boundary with small teeth (a mesh cut along its
    triangles) has no corner at the teeth; a smooth turn spread over a panel is no corner either."""
    P0 = bnd.P
    s = bnd.cum[:-1]
    turn = np.full(len(P0), np.inf)
    for w in (0.25 * window, 0.75 * window):
        a1 = P0 - bnd.point(s - w)
        a2 = bnd.point(s + w) - P0
        turn = np.minimum(turn, np.abs(np.arctan2(_cross2(a1, a2), np.einsum("ij,ij->i", a1, a2))))
    out = []
    for k in np.nonzero(turn > math.radians(corner_angle))[0]:
        d = np.abs(s - s[k])
        near = np.nonzero(np.minimum(d, bnd.total - d) < 0.75 * window)[0]
        best = near[turn[near] == turn[near].max()]
        if k == best.min():
            out.append(k)
    return np.array(out, np.int64)


def _network_nodes(fam, bnd, crossings, eps_b, corner_angle, window) -> _Nodes:
    """Crossings, line ends on the boundary and boundary corners (turns sharper than ``corner_angle`` degrees at
    the scale ``window``, :func:`_boundary_corners`)."""
    ia, sa, ib, sb, P = crossings
    node_uv = [P]
    node_kind = [np.zeros(len(P), np.int64)]
    per_line = [[[] for _ in fam[0]], [[] for _ in fam[1]]]  # (param, node)
    for c in range(len(P)):
        per_line[0][ia[c]].append((sa[c], c))
        per_line[1][ib[c]].append((sb[c], c))
    nn = len(P)
    bnodes = []  # (boundary param, node)
    trimmed = 0
    for f, L in enumerate(fam):
        for i, q in enumerate(L):
            ends = bnd.project(q[[0, -1]])
            for e, par in ((0, 0.0), (1, float(len(q) - 1))):
                if ends[1][e] <= eps_b * 10:
                    node_uv.append(ends[0][e:e + 1])
                    node_kind.append(np.array([NODE_BOUNDARY]))
                    per_line[f][i].append((par, nn))
                    bnodes.append((ends[2][e], nn))
                    nn += 1
                elif per_line[f][i]:
                    trimmed += 1
    P0 = bnd.P
    for k in _boundary_corners(bnd, corner_angle, window):
        node_uv.append(P0[k:k + 1])
        node_kind.append(np.array([NODE_CORNER]))
        bnodes.append((bnd.cum[k], nn))
        nn += 1
    return _Nodes(np.concatenate(node_uv), np.concatenate(node_kind), per_line, bnodes, trimmed)


def _network_edges(fam, nodes: _Nodes, bnd):
    """Edges between consecutive nodes along every line and along the boundary.

    Returns ``edges`` (e, 2) int64, their plane polylines (list of (k, 2)) and ``family`` (e,) int64 (0, 1 the
    line families, 2 the boundary).
    """
    nuv = nodes.uv
    edges, polys, efam = [], [], []
    for f, L in enumerate(fam):
        for i, q in enumerate(L):
            lst = sorted(nodes.per_line[f][i])
            for (s0, n0), (s1, n1) in zip(lst[:-1], lst[1:]):
                if n0 == n1:
                    continue
                k0, k1 = int(math.floor(s0)), int(math.floor(s1))
                inner = q[k0 + 1:k1 + 1] if k1 >= k0 + 1 else np.zeros((0, 2))
                edges.append((n0, n1))
                polys.append(np.vstack([nuv[n0], inner, nuv[n1]]))
                efam.append(f)
    bnodes = sorted(nodes.boundary)
    for (s0, n0), (s1, n1) in zip(bnodes, bnodes[1:] + bnodes[:1]):
        if n0 == n1 or len(bnodes) < 2:
            continue
        pts = bnd.arc(s0, s1)
        pts[0], pts[-1] = nuv[n0], nuv[n1]
        edges.append((n0, n1))
        polys.append(pts)
        efam.append(2)
    return np.asarray(edges, np.int64).reshape(-1, 2), polys, np.asarray(efam, np.int64)


def _merge_boundary_ends(X, edges, kind, tol):
    """Merge every boundary end into the crossing it is joined to by an edge shorter than ``tol`` (3D).

    Returns ``head`` (nn,) the node every node is merged into (the cluster's corner, else its crossing, else its
    smallest index; line edges keep their directions) and the new ``kind`` (a crossing that took a boundary end
    in is on the boundary now).
    """
    nn = len(kind)
    elen = np.linalg.norm(X[edges[:, 0]] - X[edges[:, 1]], axis=1)
    isx = kind == NODE_CROSSING
    isend = kind == NODE_BOUNDARY
    short = (elen < tol) & ((isx[edges[:, 0]] & isend[edges[:, 1]]) | (isend[edges[:, 0]] & isx[edges[:, 1]]))
    rep = _union_find(nn, [tuple(e) for e in edges[short][np.argsort(elen[short])]])
    rank = np.where(kind == NODE_CORNER, 0, np.where(kind == NODE_CROSSING, 1, 2))
    order = np.lexsort((np.arange(nn), rank, rep))
    first = np.r_[True, rep[order][1:] != rep[order][:-1]]
    head_of_rep = dict(zip(rep[order][first].tolist(), order[first].tolist()))
    head = np.array([head_of_rep[r] for r in rep.tolist()], dtype=np.int64)
    kind = kind.copy()
    merged_b = head[(kind == NODE_BOUNDARY) & (head != np.arange(nn))]
    kind[merged_b[kind[merged_b] == NODE_CROSSING]] = NODE_BOUNDARY
    return head, kind


def _kept_edges(E, efam, nn):
    """Indices (sorted) of the edges to keep: no loops, one edge per node pair (the boundary edge, else the
    first), none hanging at a node of degree 1 (pruned repeatedly)."""
    key = np.minimum(E[:, 0], E[:, 1]) * nn + np.maximum(E[:, 0], E[:, 1])
    pref = np.where(efam == 2, 0, 1)
    idx = np.nonzero(E[:, 0] != E[:, 1])[0]
    idx = idx[np.lexsort((pref[idx], key[idx]))]
    uniq = np.r_[True, key[idx][1:] != key[idx][:-1]]
    sel = np.sort(idx[uniq])
    alive = np.ones(len(sel), bool)
    Es = E[sel]
    while True:
        deg = np.bincount(Es[alive].ravel(), minlength=nn)
        dang = alive & ((deg[Es[:, 0]] == 1) | (deg[Es[:, 1]] == 1))
        if not dang.any():
            break
        alive &= ~dang
    return sel[alive]


def _cells(nuv, E, polys, max_face_size):
    """Bounded cells of the planar graph with 3 to ``max_face_size`` distinct corners (counter-clockwise).

    Returns the cells, the number of dropped cells (too large or repeating a node) and the cells too large
    (counter-clockwise node lists with distinct nodes).
    """
    # directions: from each end towards a point 30% along its polyline (after merging, from the merged node)
    dout = _arc_points(polys, 0.3) - nuv[E[:, 0]]
    din = _arc_points([p[::-1] for p in polys], 0.3) - nuv[E[:, 1]]
    faces, dropped, big = [], 0, []
    for cyc in _trace_faces(nuv, E, dout, din):
        if len(cyc) < 3 or len(set(cyc)) != len(cyc):
            dropped += len(cyc) >= 3
            continue
        pu = nuv[cyc]
        area = 0.5 * np.sum(_cross2(pu, np.roll(pu, -1, axis=0)))
        if area <= 0:
            continue  # the outer face (or an inverted sliver)
        if len(cyc) > max_face_size:
            big.append(cyc)
            dropped += 1
            continue
        faces.append(cyc)
    return faces, dropped, big


def _arrangement_faces(nodes: _Nodes, edges, polys, efam, X, merge_tol, max_face_size, warnings, fill=False):
    """Merge short boundary ends, clean the edges and trace the cells: ``(faces, big, kind, dropped)``.

    ``big`` are the cells with more than ``max_face_size`` corners: left open (and reported) unless ``fill``, when
    they are returned to be split. Appends what was done to ``warnings``; raises :class:`MeshError` when no cell
    remains.
    """
    nn = len(nodes.kind)
    head, kind = _merge_boundary_ends(X, edges, nodes.kind, merge_tol)
    E = head[edges]
    sel = _kept_edges(E, efam, nn)
    if len(sel) == 0:
        raise MeshError("mesh", "the line network forms no closed cell (panel size too large for the surface?)")
    faces, dropped, big = _cells(nodes.uv, E[sel], [polys[i] for i in sel.tolist()], max_face_size)
    faces, nsplit = _split_hexagons(faces, nodes.uv)
    if nsplit:
        warnings.append(f"{nsplit} hexagon(s) between two facing line ends (T-junctions) were split into two quads "
                        "(the missing piece of line restored straight in the plane)")
    if big and not fill:
        warnings.append(f"{len(big)} cell(s) with more than {max_face_size} corners (holes in the network, e.g. "
                        "skipped umbilic regions or stopped lines) were left open")
    if not faces and not (fill and big):
        raise MeshError("mesh", "the line network forms no cell with at most "
                                f"{max_face_size} corners (panel size too large for the surface?)")
    return faces, big if fill else [], kind, dropped


def _healed(faces, nuv, X, kind, V, T, loc: _Locator, bnd, warnings, max_bulge):
    """Heal the cells (:func:`components.network.healing.healed_cells`): ``(faces, uv, X, kind)``; appends what
    was done to ``warnings``. ``loc`` locates plane points in the plane map of ``(V, T)``."""

    def lift(P):
        f, B = loc.locate(P)
        return np.einsum("pk,pkj->pj", B, V[T[f]])

    h = healed_cells(faces, nuv, X, kind, lift, lambda P: bnd.project(P)[0], max_bulge=max_bulge)
    done = []
    if h.collapsed:
        done.append(f"{h.collapsed} short edge(s) or sharp/tiny cell(s) collapsed")
    if h.dropped_nodes:
        done.append(f"{h.dropped_nodes} flat node(s) dropped")
    if h.split:
        done.append(f"{h.split} cell(s) with flat corners or too many corners (T-junctions, holes of the network) "
                    "split along diagonals")
    if h.refined:
        done.append(f"{h.refined} cell(s) under which the surface bulges more than {max_bulge:g} × the median edge "
                    "split in two")
    if done:
        warnings.append("boundary and irregular cells extended to the design boundary and healed: " + "; ".join(done))
    if h.left_open:
        warnings.append(f"{h.left_open} cell(s) could not be split into panels with at most 5 corners and were left "
                        "open (holes)")
    return h.faces, h.uv, h.X, h.kind


def _boundary_edges(faces):
    """The boundary edges ``{(a, b) : a < b}`` of a list of faces."""
    topo = edge_topology(pad_faces(faces))
    return set(map(tuple, np.sort(topo.E[topo.count == 1], axis=1).tolist()))


# ---- the rebuild


@single_blas_thread()  # sparse factorizations: see components.core.blas
def rebuild_from_network(V, T, lines_1, lines_2, panel_size: float, UV=None, gap: float = 1.0,
                         merge: float = 0.1, max_face_size: int = 6, corner_angle: float = 35.0,
                         plane: str = "lscm", boundary_cells: str = "trim",
                         max_bulge: float | None = MAX_BULGE) -> Rebuild:
    """Rebuild a quad-dominant mesh from a two-family line network on a disk-like triangle mesh.

    Parameters
    ----------
    V : (n, 3) float64
        Surface vertices.
    T : (t, 3) int64
        Triangles of a topological disk, consistently oriented.
    lines_1, lines_2 : list of (k, 3) float64
        The two families of polylines, lying on the surface (e.g. curvature lines).
    panel_size : float
        The network's spacing in model units (sets the resampling, gap and merge distances).
    UV : (n, 2) float64, optional
        A plane map of the mesh (counter-clockwise triangles); computed with :func:`plane_map` when absent.
    gap : float
        Naked ends closer than ``gap`` panel sizes to the boundary (along the line's end direction) are extended to
        it; the others are trimmed back to their last crossing.
    merge : float
        A line's boundary end closer than ``merge`` panel sizes (in 3D) to its last crossing is merged into that
        crossing (line directions are kept): no slivers along the boundary.
    max_face_size : int
        Cells with more corners are dropped (holes, reported).
    corner_angle : float
        Boundary turns sharper than this (degrees, in the plane, measured over a quarter and three quarters of a
        panel on both sides: teeth of a boundary cut along the mesh's triangles are no corners) become nodes
        (corners of the candidate).
    plane : {"lscm", "disk"}
        Plane map used when ``UV`` is absent.
    boundary_cells : {"extend", "trim", "keep"}
        ``"extend"``: every cell is kept and healed (:func:`components.network.healing.healed_cells`): short edges
        collapsed, flat nodes dropped, cells with flat or reflex corners and holes of the network split along
        diagonals, sharp or tiny cells collapsed, four-face nodes far from conical given three or five faces — the
        candidate covers the surface up to its boundary with healthy panels (quads, triangles, pentagons);
        ``"trim"``: boundary triangles and pentagons (two boundary nodes and one or three crossings, where the
        boundary cuts a cell's corner) are dropped, so the candidate is nearly all quads, every line edge keeps its
        direction and no boundary vertex has four faces; ``"keep"``: they are kept as traced (the candidate covers
        the surface up to its boundary, with triangles and pentagons there).
    max_bulge : float, optional
        With ``"extend"``: healed cells under which the surface bulges more than this × the median edge from the
        plane of their corners are split in two (a cell larger than the surface's curvature allows leaves its
        middle far from a flat panel); ``None``: off.

    Returns
    -------
    Rebuild
        ``V, F`` the candidate (on the surface), ``UV``, node ``kind``, ``quad_fraction``, counts of ``extended``
        and ``trimmed`` naked ends and of ``dropped`` cells, ``warnings``.

    Raises
    ------
    MeshError
        The surface is not a topological disk (named ``mesh``); the network has no crossing.
    InputError
        Non-positive panel size.
    """
    V = np.asarray(V, np.float64)
    T = np.asarray(T, np.int64)
    h = check_number(panel_size, "panel_size", 0, above=True)
    check_choice(boundary_cells, "boundary_cells", BOUNDARY_CELLS)
    warnings: list[str] = []
    if UV is None:
        UV, w = plane_map(V, T, plane)
        warnings += w
    bnd = _Boundary(UV[cached_boundary_loops(T)[0]])
    h_uv = h / _plane_scale(V, T, UV)
    eps_b = 1e-6 * h_uv
    fam, extended = [], 0
    for lines in (lines_1, lines_2):
        L, n_ext = _extend_naked_ends(network_to_plane(V, T, UV, lines, 0.25 * h_uv)[0], bnd, h_uv, gap, eps_b)
        fam.append(L)
        extended += n_ext
    crossings = network_crossings(*fam)
    if len(crossings[4]) == 0:
        raise MeshError("mesh", "the two line families do not cross: no quad can be formed (panel size too large?)")
    nodes = _network_nodes(fam, bnd, crossings, eps_b, corner_angle, h_uv)
    edges, polys, efam = _network_edges(fam, nodes, bnd)
    loc = _Locator(np.asarray(UV, float), T)  # one point location for the nodes and the healing (uv_to_surface's)
    f, B = loc.locate(nodes.uv)
    X = np.einsum("pk,pkj->pj", B, V[T[f]])
    extend = boundary_cells == "extend"
    faces, big, kind, dropped = _arrangement_faces(nodes, edges, polys, efam, X, merge * h, max_face_size, warnings,
                                                   fill=extend)
    nuv = nodes.uv
    if extend:
        if max_bulge is not None:
            max_bulge = check_number(max_bulge, "max_bulge", 0, above=True)
        faces, nuv, X, kind = _healed(faces + big, nuv, X, kind, V, T, loc, bnd, warnings, max_bulge)
    elif boundary_cells == "trim":
        faces, ntri, npen = _trim_boundary_cells(faces, kind, _boundary_edges(faces))
        if ntri or npen:
            warnings.append(f"boundary cells: {ntri} corner triangle(s) and {npen} pentagon(s) where the boundary cuts "
                            "the network were dropped (the candidate's boundary runs up to one panel inside the "
                            "surface's boundary there; use boundary_cells='extend' or 'keep' to keep them)")
    faces = _manifold_faces(faces, len(kind), warnings)
    F = pad_faces(faces)
    used = np.unique(F)
    remap = np.full(len(kind), -1, np.int64)
    remap[used] = np.arange(len(used))
    F = remap[F]
    if nodes.trimmed:
        warnings.append(f"{nodes.trimmed} line end(s) stopped inside the surface more than {gap:g} panel size(s) from "
                        "the boundary; they were trimmed back to their last crossing (T-junctions)")
    qf = float(np.mean(face_sizes(F) == 4))
    return Rebuild(X[used], F, nuv[used], kind[used], qf, extended, nodes.trimmed, dropped, warnings)


def _split_hexagons(faces, nuv, flat: float = 150.0):
    """Split every hexagon whose two opposite corners are flat (interior angle above ``flat`` degrees in the
    plane: the nodes where a line stopped on each side of the cell) into two quads along the diagonal joining them.

    Such a hexagon is a line interrupted inside one cell (two facing T-junctions); the diagonal restores the line.
    Returns the new faces and the number of split hexagons.
    """
    out, n = [], 0
    cos_flat = math.cos(math.radians(180.0 - flat))
    for f in faces:
        if len(f) != 6:
            out.append(f)
            continue
        P = nuv[f]
        a = P - np.roll(P, 1, axis=0)
        b = np.roll(P, -1, axis=0) - P
        na = np.linalg.norm(a, axis=1)
        nb = np.linalg.norm(b, axis=1)
        c = np.einsum("ij,ij->i", a, b) / np.maximum(na * nb, 1e-300)
        left = _cross2(a, b) >= 0  # counter-clockwise faces: a left turn is a convex corner
        flatness = np.where(left, c, 2.0 - c)  # > cos_flat: nearly straight (or reflex)
        best = None
        for i in range(3):
            if flatness[i] > cos_flat and flatness[i + 3] > cos_flat:
                score = min(flatness[i], flatness[i + 3])
                if best is None or score > best[0]:
                    best = (score, i)
        if best is None:
            out.append(f)
            continue
        i = best[1]
        out.append([f[i], f[i + 1], f[i + 2], f[i + 3]])
        out.append([f[i + 3], f[(i + 4) % 6], f[(i + 5) % 6], f[i]])
        n += 1
    return out, n


def _trim_boundary_cells(faces, kind, bedge):
    """Drop the boundary triangles and pentagons: cells with two consecutive boundary nodes (sharing a boundary
    edge) and one or three crossings, where the boundary cuts a cell's corner.

    Dropping them (rather than cutting or collapsing) keeps every line edge's direction and leaves no boundary
    vertex with four faces, so a conical optimization of the rest has an exact face offset. Returns the new faces
    and the numbers of dropped triangles and pentagons.
    """
    out, ntri, npen = [], 0, 0
    for f in faces:
        k = len(f)
        if k in (3, 5):
            isb = [kind[v] != NODE_CROSSING for v in f]
            if sum(isb) == 2:
                j = [i for i in range(k) if isb[i] and isb[(i + 1) % k]]
                if j and (min(f[j[0]], f[(j[0] + 1) % k]), max(f[j[0]], f[(j[0] + 1) % k])) in bedge:
                    ntri += k == 3
                    npen += k == 5
                    continue
        out.append(f)
    return out, ntri, npen


def _manifold_faces(faces, n, warnings):
    """Drop faces until every vertex has a single fan (:func:`components.network.healing.manifold_cells`)."""
    faces, dropped, nbad = manifold_cells(faces, n)
    if dropped:
        warnings.append(f"{dropped} cell(s) were dropped to keep the mesh manifold at {nbad} vertex(es)")
    return faces


# ----------------------------------------------------------------------------------------------
# published component


class QuadRebuildResult(NamedTuple):
    candidate: Mesh
    lines_1: Curves
    lines_2: Curves
    quad_fraction: float
    face_sizes: Numbers
    mean_angle_error: float
    warnings: list[str]


def quad_rebuild(mesh: Mesh, panel_size: float, umbilic_threshold: float = 0.05, gap: float = 1.0,
                 merge: float = 0.1, plane: str = "lscm", boundary_cells: str = "trim") -> QuadRebuildResult:
    """Quad-dominant mesh from the principal curvature network of a disk-like surface.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``, a triangle (or polygon) mesh of a topological disk.
    panel_size : float
        Spacing of the curvature lines in model units (the panel size of the candidate).
    umbilic_threshold : float
        Curvature anisotropy ``|k1 − k2| / (|k1| + |k2|)`` below which a region counts as umbilic (no lines are
        seeded there, lines entering it stop).
    gap : float
        Naked line ends closer than this many panel sizes to the boundary are extended to it.
    merge : float
        Nodes closer than this many panel sizes to a boundary node are merged into it.
    plane : str
        Plane map: ``"lscm"`` (conformal, free boundary) or ``"disk"`` (fixed boundary on a disk).
    boundary_cells : str
        ``"extend"``: the cells reach the boundary and are healed (short edges collapsed, flat corners and holes
        split; healthy panels covering the surface); ``"trim"``: boundary triangles and pentagons (where the boundary
        cuts a cell's corner) are dropped; ``"keep"``: they are kept as traced.

    Returns
    -------
    candidate : Mesh
        The quad-dominant mesh, on the surface, its edges along the curvature lines.
    lines_1 : Curves
        Lines of maximal curvature used.
    lines_2 : Curves
        Lines of minimal curvature used.
    quad_fraction : float
        Fraction of faces that are quads.
    face_sizes : Numbers
        Number of corners of every face.
    mean_angle_error : float
        Mean angle (degrees) between the candidate's edges and the nearest principal direction, away from
        umbilic regions.

    Raises
    ------
    MeshError
        Malformed mesh, no boundary or not a topological disk (named ``mesh``).
    InputError
        Non-positive panel size or bad options.

    Notes
    -----
    Alliez et al., *Anisotropic polygonal remeshing*, SIGGRAPH 2003; Liu et al., *Geometric modeling with conical
    meshes and developable surfaces*, SIGGRAPH 2006.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("saddle", 24)
    >>> res = quad_rebuild((V, T), panel_size=3.0)
    >>> res.quad_fraction > 0.8
    True
    """
    V, T, net = network_for_mesh(mesh, panel_size, umbilic_threshold=umbilic_threshold)
    gap = check_number(gap, "gap", 0)
    merge = check_number(merge, "merge", 0)
    check_choice(plane, "plane", PLANE_MAPS)
    check_choice(boundary_cells, "boundary_cells", BOUNDARY_CELLS)
    rb = rebuild_from_network(V, T, net.lines_1, net.lines_2, panel_size, gap=gap, merge=merge, plane=plane,
                              boundary_cells=boundary_cells)
    err = principal_angle_error(rb.V, rb.F, V, T, net)
    return QuadRebuildResult(
        candidate=(rb.V, rb.F),
        lines_1=net.lines_1,
        lines_2=net.lines_2,
        quad_fraction=rb.quad_fraction,
        face_sizes=face_sizes(rb.F).astype(np.float64),
        mean_angle_error=err.mean_away_from_umbilics,
        warnings=list(net.warnings) + list(rb.warnings),
    )

