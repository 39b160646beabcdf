"""Quad extraction: the candidate quad-dominant mesh from the integer iso-lines of a seamless parametrization.

In every triangle the parametrization is linear, so the integer iso-lines ``u = i`` and ``v = j`` are straight
segments there. They are cut where they cross each other (grid vertices) and where they leave the triangle; the
mesh boundary is cut where iso-lines hit it. All these pieces form one planar graph on the surface: pieces from
neighbouring triangles meet at the same 3D point on their shared edge (also across cuts, where the transition
functions are exact rotations and integer shifts), so nodes are merged by position. Nodes of degree 2 that are not
grid vertices (an iso-line passing a mesh edge, a mesh vertex along the boundary) are contracted, leaving the
candidate's vertices: grid vertices and boundary hits. Faces are the cells of the graph, found by a half-edge walk
that turns at every vertex to the next edge clockwise from the one it arrived by (edges ordered by angle in the
tangent plane); the one cell per boundary loop that runs around the outside is dropped.

Every vertex is a barycentric point of an input triangle, so it lies exactly on the input surface; the faces are
oriented like the input (counter-clockwise about its normals). A clean-up then merges vertices closer than a small
fraction of the target length (slivers along the boundary) and removes faces that became degenerate.

The chain surface → field → parametrization → this extraction is :func:`components.fields.candidate.candidate_mesh`
(published as ``fields/extract_quads``).

References
----------
D. Bommes, H. Zimmer, L. Kobbelt, "Mixed-integer quadrangulation", SIGGRAPH 2009 (iso-line extraction).
H.-C. Ebke, D. Bommes, M. Campen, L. Kobbelt, "QEx: robust quad mesh extraction", ACM Trans. Graph. (SIGGRAPH
Asia) 32(6), 2013 (tracing in the triangles' charts, robustness of the graph).
"""
from __future__ import annotations

import heapq
import logging
import math
import time
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import factorized
from scipy.spatial import cKDTree

from components.core.blas import single_blas_thread
from components.core.measures import corner_angles, cross, dot, nonconvex_faces
from components.core.memo import ContentCache, digest
from components.core.mesh import edge_topology, face_corners, face_normals, face_sizes, halfedges
from components.core.proximity import TriangleIndex

log = logging.getLogger(__name__)

__all__ = ["BoundaryCurve", "Extraction", "boundary_curve", "boundary_turns", "closest_on_boundary",
           "collapse_short_edges", "drop_keeping_manifold", "iso_segments", "put_back",
           "quad_mesh_from_parametrization", "relabel", "relax_edge_lengths", "snap_boundary", "split_large_faces"]

_TOL = 1e-9  # parameter tolerance (in grid units) for "on an iso-line"


# ----------------------------------------------------------------------------------------------
# iso-line pieces per triangle


def _line_segments(UV: np.ndarray, k: int):
    """Clip the lines ``coord_k = integer`` to every triangle.

    Returns ``tri (s,)``, ``val (s,)`` the integer, ``B0, B1 (s, 3)`` barycentric endpoints ordered by the other
    coordinate, ``o0, o1 (s,)`` the other coordinate at the endpoints.
    """
    c = UV[:, :, k]
    o = UV[:, :, 1 - k]
    lo = np.ceil(np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2]) - _TOL).astype(np.int64)  # c.min(axis=1)
    hi = np.floor(np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2]) + _TOL).astype(np.int64)
    cnt = np.maximum(hi - lo + 1, 0)
    tri = np.repeat(np.arange(len(UV)), cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    val = (np.repeat(lo, cnt) + np.arange(len(tri)) - start).astype(float)
    if len(tri) == 0:
        z = np.zeros(0)
        return tri, z, np.zeros((0, 3)), np.zeros((0, 3)), z, z
    cs = c[tri]
    os_ = o[tri]
    # candidate endpoints 2e (where the line crosses edge e, or its first end when the edge lies on the line) and
    # 2e + 1 (the second end of an edge on the line): their other coordinate, and the edge parameters
    cand_o = np.empty((len(tri), 6))
    ok = np.empty((len(tri), 6), dtype=bool)
    S = np.empty((len(tri), 3))
    ON = np.empty((len(tri), 3), dtype=bool)
    for e in range(3):
        a, b = e, (e + 1) % 3
        ca, cb = cs[:, a], cs[:, b]
        den = cb - ca
        flat = np.abs(den) <= _TOL
        on = flat & (np.abs(ca - val) <= _TOL)
        s = np.where(flat, 0.0, (val - ca) / np.where(flat, 1.0, den))
        hit = ~flat & (s >= -_TOL) & (s <= 1 + _TOL)
        s = np.clip(s, 0.0, 1.0)
        cand_o[:, 2 * e] = np.where(on, os_[:, a], (1 - s) * os_[:, a] + s * os_[:, b])
        ok[:, 2 * e] = hit | on
        # a collinear edge contributes its second endpoint too
        cand_o[:, 2 * e + 1] = os_[:, b]
        ok[:, 2 * e + 1] = on
        S[:, e] = s
        ON[:, e] = on
    i0 = np.argmin(np.where(ok, cand_o, np.inf), axis=1)
    i1 = np.argmax(np.where(ok, cand_o, -np.inf), axis=1)
    r = np.arange(len(tri))
    o0, o1 = cand_o[r, i0], cand_o[r, i1]
    good = np.nonzero(ok.any(axis=1) & (o1 - o0 > _TOL))[0]
    return (tri[good], val[good], _candidate_bary(i0[good], S[good], ON[good]),
            _candidate_bary(i1[good], S[good], ON[good]), o0[good], o1[good])


def _candidate_bary(i: np.ndarray, S: np.ndarray, ON: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of the candidate endpoints ``i`` of :func:`_line_segments`: ``2e`` the point
    ``(1 − s) c_e + s c_{e+1}`` of edge ``e`` (corner ``e`` itself where the edge lies on the line), ``2e + 1``
    corner ``e + 1``; ``S, ON (s, 3)`` the edge parameters and on-the-line flags."""
    r = np.arange(len(i))
    e = i // 2
    a, b = e, (e + 1) % 3
    s = S[r, e]
    cross_ = (i % 2 == 0) & ~ON[r, e]
    B = np.zeros((len(i), 3))
    B[r, np.where(i % 2 == 0, a, b)] = np.where(cross_, 1 - s, 1.0)
    B[r[cross_], b[cross_]] = 0.0 + s[cross_]  # (1 − s) · 0 + s · 1 as e_a (1 − s) + e_b s has it: −0 → +0
    return B


def iso_segments(V: np.ndarray, T: np.ndarray, UV: np.ndarray) -> np.ndarray:
    """All integer iso-line segments inside the triangles, ``(s, 2, 3)`` (for display).

    Parameters
    ----------
    V : (n, 3) float64
    T : (m, 3) int64
    UV : (m, 3, 2) float64
        Per-corner parameters.

    Returns
    -------
    (s, 2, 3) float64
    """
    out = []
    for k in range(2):
        tri, _, B0, B1, _, _ = _line_segments(UV, k)
        P = V[T[tri]]
        out.append(np.stack([np.einsum("sk,skd->sd", B0, P), np.einsum("sk,skd->sd", B1, P)], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


class _Points(NamedTuple):
    tri: np.ndarray  # (p,) triangle
    bary: np.ndarray  # (p, 3)
    grid: np.ndarray  # (p,) bool: both coordinates integer
    bnd: np.ndarray  # (p,) bool: on the mesh boundary
    corner: np.ndarray  # (p,) bool: a sharp corner of the mesh boundary (kept as a vertex)


class _Surface(NamedTuple):
    """What every extraction on one input surface shares (:func:`_surface`)."""

    P: np.ndarray  # (m, 3, 3) corner positions of the triangles
    FN: np.ndarray  # (m, 3) unit normals
    bh: np.ndarray  # (b,) boundary half-edges (face by face, corner by corner)
    sharp_end: np.ndarray  # (b,) the outline turns by more than 35° at the end of the boundary half-edge
    diag: float  # bounding-box diagonal


_SHARP_CORNER = 35.0  # degrees: boundary corners turning more than this stay vertices of the candidate
_SURFACES = ContentCache("extraction surfaces", entries=2)


def _surface(V: np.ndarray, T: np.ndarray) -> _Surface:
    """:class:`_Surface` of ``(V, T)``; the last ones are kept (keyed by the arrays' contents): the candidate
    extracts six parametrizations of the same surface."""
    return _SURFACES.get(digest(V, T), lambda: _surface_of(V, T))


def _surface_of(V: np.ndarray, T: np.ndarray) -> _Surface:
    P = V[T]
    topo = edge_topology(T)
    bh = np.nonzero(topo.count[topo.HE] != 2)[0]  # half-edge order = face by face, corner by corner
    FN = cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    FN /= np.linalg.norm(FN, axis=1, keepdims=True)
    # sharp boundary corners: the turn between the boundary edge arriving at a vertex and the one leaving it
    n = int(T.max()) + 1
    H = np.stack([T.ravel(), np.roll(T, -1, axis=1).ravel()], axis=1)
    dvec = V[H[bh, 1]] - V[H[bh, 0]]
    dvec /= np.linalg.norm(dvec, axis=1, keepdims=True)
    out_of = np.full(n, -1, dtype=np.int64)
    out_of[H[bh, 0]] = np.arange(len(bh))
    nxt_e = out_of[H[bh, 1]]
    sharp_end = np.einsum("ij,ij->i", dvec, dvec[nxt_e]) < np.cos(np.radians(_SHARP_CORNER))
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    return _Surface(P, FN, bh, sharp_end, diag)


def _pieces(T, UV, surf: _Surface):
    """Points and pieces (index pairs into the points) of the iso-line graph and of the split boundary."""
    tris, barys, grids, bnds = [], [], [], []
    pa, pb = [], []
    base = 0
    for k in range(2):
        tri, val, B0, B1, o0, o1 = _line_segments(UV, k)
        if len(tri) == 0:
            continue
        # split at integers of the other coordinate strictly inside (o0, o1)
        jlo = np.floor(o0 + _TOL).astype(np.int64) + 1
        jhi = np.ceil(o1 - _TOL).astype(np.int64) - 1
        cnt = np.maximum(jhi - jlo + 1, 0)
        npts = cnt + 2
        seg = np.repeat(np.arange(len(tri)), npts)
        first = np.cumsum(npts) - npts
        pos = np.arange(len(seg)) - np.repeat(first, npts)  # 0 .. cnt+1
        o0s, o1s, last = o0[seg], o1[seg], np.repeat(npts - 1, npts)
        ov = np.where(pos == 0, o0s, np.where(pos == last, o1s, (np.repeat(jlo - 1, npts) + pos).astype(float)))
        t = (ov - o0s) / (o1s - o0s)
        bary = (1 - t)[:, None] * B0[seg] + t[:, None] * B1[seg]
        isint = np.abs(ov - np.round(ov)) <= 1e-7
        tris.append(tri[seg])
        barys.append(bary)
        grids.append(isint)
        bnds.append(np.zeros(len(seg), dtype=bool))
        idx = base + np.arange(len(seg))
        nxt = pos < last
        pa.append(idx[nxt])
        pb.append(idx[nxt] + 1)
        base += len(seg)
    # boundary edges split at the iso-line hits
    bh = surf.bh
    f = bh // 3
    i0 = bh % 3
    i1 = (i0 + 1) % 3
    ua = UV[f, i0]
    ub = UV[f, i1]
    ss = [np.zeros(len(bh)), np.ones(len(bh))]
    owner = [np.arange(len(bh)), np.arange(len(bh))]
    for k in range(2):
        a, b = ua[:, k], ub[:, k]
        lo = np.floor(np.minimum(a, b) + _TOL).astype(np.int64) + 1
        hi = np.ceil(np.maximum(a, b) - _TOL).astype(np.int64) - 1
        cnt = np.maximum(hi - lo + 1, 0)
        e = np.repeat(np.arange(len(bh)), cnt)
        st = np.repeat(np.cumsum(cnt) - cnt, cnt)
        v = (np.repeat(lo, cnt) + np.arange(len(e)) - st).astype(float)
        den = b[e] - a[e]
        ss.append((v - a[e]) / den)
        owner.append(e)
    ss = np.concatenate(ss)
    owner = np.concatenate(owner)
    order = np.lexsort((ss, owner))
    ss, owner = ss[order], owner[order]
    eye = np.eye(3)
    bary = (1 - ss)[:, None] * eye[i0[owner]] + ss[:, None] * eye[i1[owner]]
    uvp = (1 - ss)[:, None] * ua[owner] + ss[:, None] * ub[owner]
    tris.append(f[owner])
    barys.append(bary)
    grids.append(np.all(np.abs(uvp - np.round(uvp)) <= 1e-7, axis=1))
    bnds.append(np.ones(len(ss), dtype=bool))
    idx = base + np.arange(len(ss))
    same = owner[1:] == owner[:-1]
    pa.append(idx[:-1][same])
    pb.append(idx[1:][same])
    sharp_pt = (ss >= 1.0) & surf.sharp_end[owner]
    corners = [np.zeros(len(t), dtype=bool) for t in tris[:-1]] + [sharp_pt]
    pts = _Points(np.concatenate(tris), np.concatenate(barys), np.concatenate(grids), np.concatenate(bnds),
                  np.concatenate(corners))
    return pts, np.concatenate(pa), np.concatenate(pb)


# ----------------------------------------------------------------------------------------------
# graph → faces


def _merge_close(X: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Union of points closer than ``r``: ``label (p,)`` and the representative (first) point of each label."""
    pairs = _close_pairs(X, r)
    n = len(X)
    if len(pairs) == 0:
        return np.arange(n, dtype=np.int64), np.arange(n, dtype=np.int64)
    G = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(G, directed=False)
    lab = lab.astype(np.int64)  # int32 from scipy: pair keys lab * n overflow on large meshes
    rep = np.full(lab.max() + 1, n, dtype=np.int64)
    np.minimum.at(rep, lab, np.arange(n))
    return lab, rep


def _close_pairs(X: np.ndarray, r: float) -> np.ndarray:
    """Pairs ``(i, j)``, ``i < j``, of points ``X (p, 3)`` at most ``r`` apart (the pairs of
    ``cKDTree.query_pairs``, in another order).

    The points are sorted along a generic direction ``w`` (unit length): points within ``r`` of each other are
    within ``r`` along it, so each point is compared only with the next ones up to ``r`` (and a rounding margin)
    farther along ``w``. Fast for a radius well below the points' spacing (the merges here: coincident points,
    slivers): the windows then hold the close points alone, where the k-d tree's build and traversal cost
    several times more."""
    n = len(X)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    w = np.array([0.6, 0.48, 0.64])  # unit; no axis, so rows of points on an axis-parallel line do not share a slot
    s = X @ w
    order = np.argsort(s)  # the pairs do not depend on the order of equal keys
    ss = s[order]
    slack = 1e-12 * float(np.abs(ss).max()) + 1e-9 * r
    end = np.searchsorted(ss, ss + (r + slack), side="right")
    cnt = end - np.arange(n) - 1
    i = np.repeat(np.arange(n), cnt)
    j = i + 1 + (np.arange(len(i)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    Xs = X[order]  # neighbours in the order: the candidates' coordinates are read almost in sequence
    D = Xs[i] - Xs[j]
    near = np.einsum("ij,ij->i", D, D) <= r * r
    a, b = order[i[near]], order[j[near]]
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


def _tangent_angles(D: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Angle of vectors ``D`` in the tangent plane of unit normals ``N`` (any consistent in-plane basis)."""
    a = np.where(np.abs(N[:, 0:1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = a - N * np.einsum("ij,ij->i", a, N)[:, None]
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = cross(N, e1)
    return np.arctan2(np.einsum("ij,ij->i", D, e2), np.einsum("ij,ij->i", D, e1))


def _faces_from_graph(X, N, a, b, da, db):
    """Cells of an embedded graph: half-edge walk turning to the next edge clockwise at every vertex.

    ``X (p, 3)`` node positions, ``N (p, 3)`` node normals, edges ``(a, b)`` with initial directions ``da`` at ``a``
    and ``db`` at ``b``. Returns the cycles as flat arrays, one after the other: their nodes ``(h,)`` and
    half-edges ``(h,)``, the cycles' starts and lengths ``(c,)``, and their signed areas about the normals ``(c,)``.
    """
    ne = len(a)
    if ne == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z, z, z, np.zeros(0)
    tail = np.concatenate([a, b])  # half-edge h (< ne): a -> b; h + ne: b -> a
    dirs = np.concatenate([da, db])
    ang = _tangent_angles(dirs, N[tail])
    order = np.lexsort((ang, tail))
    # position of each half-edge in its tail's ccw list
    st = tail[order]
    start = np.searchsorted(st, st, side="left")
    end = np.searchsorted(st, st, side="right")
    rank = np.empty(2 * ne, dtype=np.int64)
    rank[order] = np.arange(2 * ne)
    twin = np.concatenate([np.arange(ne, 2 * ne), np.arange(ne)])
    # next(h) = the out-half-edge preceding twin(h) in ccw order around head(h)
    t = twin
    r = rank[t]
    s = start[r]
    e = end[r]
    prev = np.where(r - 1 >= s, r - 1, e - 1)
    nxt = order[prev]
    # cycles of the permutation nxt, each from its smallest half-edge (the order a walk over the half-edges in
    # index order finds them in), as flat arrays: list ranking by pointer doubling, no per-half-edge loop
    n = 2 * ne
    _, comp = connected_components(sp.csr_matrix((np.ones(n), (np.arange(n), nxt)), shape=(n, n)),
                                   directed=True, connection="weak")
    first = np.full(int(comp.max()) + 1, n, dtype=np.int64)
    np.minimum.at(first, comp, np.arange(n))
    succ = np.where(nxt == first[comp], np.arange(n), nxt)  # the last half-edge of each cycle ends the list
    dist = (succ != np.arange(n)).astype(np.int64)  # half-edges to the end of the cycle
    while True:
        s2 = succ[succ]
        if np.array_equal(s2, succ):
            break
        dist = dist + dist[succ]
        succ = s2
    lens_c = np.bincount(comp)
    rank = lens_c[comp] - 1 - dist
    order = np.lexsort((rank, first[comp]))
    hes = order  # half-edges, cycle by cycle, each in walking order
    cyc_order = np.argsort(first, kind="stable")
    lens = lens_c[cyc_order]
    flat = tail[hes]
    # signed areas, all cycles at once
    starts = np.cumsum(lens) - lens
    cid = np.repeat(np.arange(len(lens)), lens)
    P = X[flat]
    P = P - P[starts][cid]  # about a corner: far from the origin the products would cancel
    nxt_pos = np.arange(len(flat)) + 1
    nxt_pos[starts + lens - 1] = starts
    S = np.add.reduceat(cross(P, P[nxt_pos]), starts, axis=0)
    nrm = np.add.reduceat(N[flat], starts, axis=0) / lens[:, None]
    area = 0.5 * np.einsum("ij,ij->i", S, nrm)
    return flat, hes, starts, lens, area


class Extraction(NamedTuple):
    """Result of :func:`quad_mesh_from_parametrization`.

    ``V (p, 3)``, ``F (f, k)`` the candidate, ``tri (p,)`` and ``bary (p, 3)`` the input triangle and barycentric
    coordinates of every vertex, ``grid (p,)`` True for iso-line crossings (False: boundary hits),
    ``dropped`` cells that were discarded (degenerate or inverted), ``timings``.
    """

    V: np.ndarray
    F: np.ndarray
    tri: np.ndarray
    bary: np.ndarray
    grid: np.ndarray
    dropped: int
    timings: dict


def quad_mesh_from_parametrization(V: np.ndarray, T: np.ndarray, UV: np.ndarray, merge: float = 0.05,
                                   target_length: float | None = None) -> Extraction:
    """Extract the quad-dominant mesh of the integer iso-lines of a per-corner parametrization.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices of the input surface.
    T : (m, 3) int64
        Its triangles (consistently oriented).
    UV : (m, 3, 2) float64
        Per-corner parameters in grid units (seamless: across cuts the corners differ by a rotation by a multiple
        of 90° and an integer translation).
    merge : float
        Vertices closer than ``merge · target_length`` are merged (slivers at the boundary, near-coincident
        crossings).
    target_length : float, optional
        Grid spacing in model units (estimated from the parametrization when omitted).

    Returns
    -------
    Extraction

    Notes
    -----
    Iso-line extraction as in Bommes et al. 2009 / Ebke et al. 2013, built as a planar graph from per-triangle
    pieces (see the module notes).
    """
    timings = {}
    t0 = time.perf_counter()
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    UV = np.asarray(UV, dtype=np.float64)
    surf = _surface(V, T)
    P = surf.P
    if target_length is None:
        e3 = np.linalg.norm(P[:, 1] - P[:, 0], axis=1)
        eu = np.linalg.norm(UV[:, 1] - UV[:, 0], axis=1)
        ok = eu > 1e-12
        target_length = float(np.median(e3[ok] / eu[ok])) if ok.any() else 1.0
    h = float(target_length)
    pts, pa, pb = _pieces(T, UV, surf)
    X = np.einsum("pk,pkd->pd", pts.bary, P[pts.tri])
    timings["pieces"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    # exact coincidences first (the same point computed in two triangles)
    lab, rep = _merge_close(X, 1e-9 * max(surf.diag, 1e-300) + 1e-7 * h)
    nn = len(rep)
    grid = np.zeros(nn, dtype=bool)
    grid[lab[pts.grid]] = True
    bnd = np.zeros(nn, dtype=bool)
    bnd[lab[pts.bnd]] = True
    # prefer a grid point as the representative position
    a, b = lab[pa], lab[pb]
    keep = a != b
    a, b = a[keep], b[keep]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = np.sort(lo * nn + hi)
    key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key  # np.unique, sorting once
    a, b = key // nn, key % nn
    Xn = X[rep]
    deg = np.bincount(np.concatenate([a, b]), minlength=nn)
    corner = np.zeros(nn, dtype=bool)
    corner[lab[pts.corner]] = True
    kept = grid | corner | (deg != 2)
    kept &= deg > 0
    timings["merge"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    ca, cb, da, db, first_o = _contract_chains(a, b, kept, Xn)
    kn = np.nonzero(kept)[0]
    remap = np.full(nn, -1, dtype=np.int64)
    remap[kn] = np.arange(len(kn))
    Vc = Xn[kn]
    # exact rep for tri/bary (the representative point)
    node_tri = pts.tri[rep]
    node_bary = pts.bary[rep]
    Nn = surf.FN[node_tri[kn]]
    # half-edges that run along the mesh boundary against its orientation face the outside (also around holes)
    bdir = lab[pa[pts.bnd[pa] & pts.bnd[pb]]] * nn + lab[pb[pts.bnd[pa] & pts.bnd[pb]]]
    fwd = np.isin(ca * nn + first_o, bdir)
    bwd = np.isin(first_o * nn + ca, bdir)
    # overlapping chains leaving a node the same way (an iso-line along the boundary): one stays
    keep = _distinct_chains(ca, cb, da, db, fwd | bwd, Xn)
    ca, cb, da, db, fwd, bwd = ca[keep], cb[keep], da[keep], db[keep], fwd[keep], bwd[keep]
    A_, B_ = remap[ca], remap[cb]
    outside = np.concatenate([bwd & ~fwd, fwd & ~bwd])
    flat, hes, starts, lens, area = _faces_from_graph(Vc, Nn, A_, B_, da, db)
    timings["cells"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    out_c = np.logical_or.reduceat(outside[hes], starts) if len(starts) else np.zeros(0, dtype=bool)
    good = (area > 0) & ~out_c & (lens >= 3)
    dropped = int(np.count_nonzero(~out_c & ((area <= 0) | (lens < 3))))
    # the kept cells as padded rows (the last corner repeated)
    fs, fl = starts[good], lens[good]
    width = max(3, int(fl.max()) if len(fl) else 3)
    j = np.minimum(np.arange(width)[None, :], fl[:, None] - 1)
    faces = flat[fs[:, None] + j] if len(fs) else np.zeros((0, width), dtype=np.int64)
    Vout, Fout, tri_out, bary_out, grid_out = _cleanup(Vc, faces, node_tri[kn], node_bary[kn], grid[kn], Nn,
                                                       merge * h)
    timings["cleanup"] = time.perf_counter() - t3
    timings["total"] = time.perf_counter() - t0
    return Extraction(Vout, Fout, tri_out, bary_out, grid_out, dropped, timings)


def _distinct_chains(ca, cb, da, db, on_boundary, X, cos_same: float = 1.0 - 1e-9) -> np.ndarray:
    """``(c,) bool``: the chains to keep when two leave a node in the same direction (within ~4e-5 rad).

    Such overlaps appear where an integer iso-line runs along the boundary: twins joining the same two nodes (one
    stays, a boundary chain first), or a chain ``n → m`` running past a node ``k`` that a shorter chain ``n → k``
    and a chain ``k → m`` in the same direction join (the long one goes). Left in, the order of their equal angles
    at ``n`` (the last bits of the input) decided which cells the half-edge walk found: another candidate for the
    same surface in other units. ``X`` are the node positions.
    """
    keep = np.ones(len(ca), dtype=bool)
    if len(ca) < 2:
        return keep
    tail = np.concatenate([ca, cb])
    head = np.concatenate([cb, ca])
    d = np.concatenate([da, db])
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    chain = np.concatenate([np.arange(len(ca)), np.arange(len(ca))])
    bnd = np.concatenate([on_boundary, on_boundary])
    reach = np.linalg.norm(X[head] - X[tail], axis=1)
    order = np.lexsort((~bnd, reach, tail))
    ts = tail[order]
    # nodes where two half-edges leave the same way (vectorized: offsets within each node's run)
    same_way = np.zeros(len(order), dtype=bool)
    for k in range(1, int(np.bincount(ts).max())):
        i = np.nonzero(ts[k:] == ts[:-k])[0]
        hit = i[np.einsum("ij,ij->i", d[order[i]], d[order[i + k]]) > cos_same]
        same_way[hit] = True
    if not same_way.any():
        return keep
    starts = np.nonzero(np.r_[True, ts[1:] != ts[:-1]])[0]
    busy = set(ts[same_way].tolist())
    out_of: dict = {}
    for run in np.split(order, starts[1:]):
        if len(run) > 1:
            out_of[int(tail[run[0]])] = run.tolist()
    for n, hs in out_of.items():
        if n not in busy:
            continue
        for i, h in enumerate(hs):
            if not keep[chain[h]]:
                continue
            for g in hs[:i]:  # shorter (or equal) ones first
                if not keep[chain[g]] or d[g] @ d[h] <= cos_same:
                    continue
                if head[g] == head[h]:
                    keep[chain[h]] = False  # a twin
                elif any(head[f] == head[h] and d[f] @ d[h] > cos_same for f in out_of.get(int(head[g]), [])):
                    keep[chain[h]] = False  # runs past head[g], which continues the same way to head[h]
                if not keep[chain[h]]:
                    break
    return keep


def _contract_chains(a: np.ndarray, b: np.ndarray, kept: np.ndarray, Xn: np.ndarray):
    """Contract the chains of degree-2 pass nodes of the graph with edges ``(a, b)`` between kept nodes.

    Each edge endpoint at a kept node becomes a private virtual node, so every chain is one connected component
    with two virtual ends. Returns the chains' end nodes ``ca, cb``, their initial directions ``da`` at ``ca`` and
    ``db`` at ``cb`` (towards the first node along the chain, positions ``Xn``) and that first node from ``ca``.
    """
    nn = len(kept)
    ne = len(a)
    va = np.where(kept[a], nn + 2 * np.arange(ne), a)
    vb = np.where(kept[b], nn + 2 * np.arange(ne) + 1, b)
    nv = nn + 2 * ne
    G = sp.csr_matrix((np.ones(ne), (va, vb)), shape=(nv, nv))
    _, comp = connected_components(G, directed=False)
    virt = np.concatenate([va[kept[a]], vb[kept[b]]])
    vnode = np.concatenate([a[kept[a]], b[kept[b]]])  # the kept node of each virtual endpoint
    vother = np.concatenate([b[kept[a]], a[kept[b]]])  # the first node along the chain
    vc = comp[virt]
    order = np.argsort(vc, kind="stable")
    vc_s = vc[order]
    starts = np.nonzero(np.r_[True, vc_s[1:] != vc_s[:-1]])[0]
    counts = np.diff(np.r_[starts, len(vc_s)])
    two = counts == 2
    i0 = order[starts[two]]
    i1 = order[starts[two] + 1]
    ca, cb = vnode[i0], vnode[i1]
    da = Xn[vother[i0]] - Xn[ca]
    db = Xn[vother[i1]] - Xn[cb]
    # chain is on the boundary if its first piece is (both nodes of the piece on the boundary)
    good = ca != cb
    return ca[good], cb[good], da[good], db[good], vother[i0][good]


def _cleanup(Vc, faces, tri, bary, grid, Nn, r):
    """Merge vertices closer than ``r`` (grid vertices win), drop repeated corners and degenerate faces (``faces``
    padded; pinched polygons are split into their loops, see :func:`relabel`)."""
    if r > 0 and len(Vc):
        lab, rep = _merge_close(Vc, r)
        # prefer grid vertices as representatives
        nl = len(rep)
        score = np.where(grid, 0, 1)
        best = np.full(nl, -1, dtype=np.int64)
        order = np.lexsort((np.arange(len(Vc)), score, lab))
        first = np.r_[True, lab[order][1:] != lab[order][:-1]]
        best[lab[order][first]] = order[first]
        rep = best
    else:
        lab = np.arange(len(Vc))
        rep = np.arange(len(Vc))
    # the merged vertices numbered by their label, standing at their representative
    return relabel(Vc[rep], lab[faces] if len(faces) else faces, tri[rep], bary[rep], grid[rep],
                   np.arange(len(rep)))


def _split_pinched(c: list) -> list:
    out = []
    stack = list(c)
    seen = {}
    cur = []
    for v in stack:
        if v in seen:
            i = seen[v]
            loop = cur[i:]
            if len(loop) >= 3:
                out.append(loop)
            for w in loop[1:]:
                seen.pop(w, None)
            cur = cur[: i + 1]
        else:
            seen[v] = len(cur)
            cur.append(v)
    if len(cur) >= 3:
        out.append(cur)
    return out


# ----------------------------------------------------------------------------------------------
# boundary snapping (free boundary → whole quads along the boundary)


class BoundaryCurve(NamedTuple):
    """The input surface's boundary edges, for closest points on the boundary (:func:`closest_on_boundary`)."""

    A: np.ndarray  # (b, 3) start of each input boundary edge
    B: np.ndarray  # (b, 3) end
    tri: np.ndarray  # (b,) its triangle
    ca: np.ndarray  # (b,) corner (0..2) of the start in that triangle
    cb: np.ndarray  # (b,) corner of the end


def boundary_curve(V: np.ndarray, T: np.ndarray) -> BoundaryCurve:
    """The boundary edges of the triangle mesh ``(V, T)``, each with its triangle and the corners of its ends.

    The last few are kept (keyed by the arrays' contents): the extraction, its relaxations and the repair ask for
    the same surface's boundary many times. Treat the returned arrays as read-only."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    T = np.ascontiguousarray(T, dtype=np.int64)
    return _CURVES.get(digest(V, T), lambda: _boundary_curve(V, T))


_CACHED = 4  # boundary curves (and their segment indexes) kept
_CURVES = ContentCache("boundary curves", entries=_CACHED)
_TREES = ContentCache("boundary segment indexes", entries=_CACHED)


def _boundary_curve(V: np.ndarray, T: np.ndarray) -> BoundaryCurve:
    topo = edge_topology(T)
    he = np.nonzero(topo.count[topo.HE] == 1)[0]
    f, c = he // 3, he % 3
    return BoundaryCurve(V[T[f, c]], V[T[f, (c + 1) % 3]], f, c, (c + 1) % 3)


def _nearest_segments_brute(P, A, D, dd, chunk):
    """Per point the first segment of least distance and the parameter of its closest point (every segment)."""
    best = np.empty(len(P), dtype=np.int64)
    tbest = np.empty(len(P))
    for s in range(0, len(P), chunk):
        Q = P[s:s + chunk]
        t = np.clip(np.einsum("qbd,bd->qb", Q[:, None, :] - A[None], D) / dd[None], 0.0, 1.0)
        X = A[None] + t[..., None] * D[None]
        d2 = np.einsum("qbd,qbd->qb", X - Q[:, None, :], X - Q[:, None, :])
        j = np.argmin(d2, axis=1)
        best[s:s + chunk] = j
        tbest[s:s + chunk] = t[np.arange(len(Q)), j]
    return best, tbest


_NEAR_K = 8  # segments per point first compared exactly when the boundary is indexed
_BRUTE_PAIRS = 1 << 13  # below this many point-segment pairs every segment is compared


def _segment_index(A: np.ndarray, D: np.ndarray):
    """k-d tree of the segment midpoints and the longest half segment, kept for the last few boundary curves."""
    return _TREES.get(digest(A, D), lambda: (cKDTree(A + 0.5 * D),
                                             float(0.5 * np.sqrt(np.einsum("ij,ij->i", D, D)).max())))


def _nearest_segments_indexed(P, A, D, dd, chunk):
    """As :func:`_nearest_segments_brute`, comparing only the segments with the nearest midpoints.

    The nearest midpoint is a point of its segment, at distance ``r``, so the closest segment (and every segment
    as close) has its midpoint within ``r`` plus the longest half segment: when the ``k``-th nearest midpoint is
    farther than that (with a rounding margin), every candidate is among the ``k``; else ``k`` grows ×4, and a point
    that still fails is compared with every segment. Candidates are compared in segment order and with the same
    arithmetic, so the result is the brute force's, bit for bit (the first of equal distances wins).
    """
    M = A + 0.5 * D
    tree, half = _segment_index(A, D)
    scale = float(np.abs(P).max(initial=0.0) + np.abs(M).max(initial=0.0))
    best = np.empty(len(P), dtype=np.int64)
    tbest = np.empty(len(P))
    todo = np.arange(len(P))
    k = _NEAR_K
    while len(todo) and k < len(A):
        dist, idx = tree.query(P[todo], k=k)
        reach = (dist[:, 0] + half) * (1.0 + 1e-9) + 1e-12 * scale
        sure = dist[:, -1] > reach
        rows = todo[sure]
        if len(rows):
            cand = np.sort(idx[sure], axis=1)  # segment order: the first of equal distances wins, as in the brute force
            Q = P[rows]
            Ac, Dc = A[cand], D[cand]
            t = np.clip(np.einsum("qbd,qbd->qb", Q[:, None, :] - Ac, Dc) / dd[cand], 0.0, 1.0)
            X = Ac + t[..., None] * Dc
            d2 = np.einsum("qbd,qbd->qb", X - Q[:, None, :], X - Q[:, None, :])
            j = np.argmin(d2, axis=1)
            r = np.arange(len(rows))
            best[rows] = cand[r, j]
            tbest[rows] = t[r, j]
        todo = todo[~sure]
        k *= 4
    if len(todo):
        best[todo], tbest[todo] = _nearest_segments_brute(P[todo], A, D, dd, chunk)
    return best, tbest


def closest_on_boundary(P: np.ndarray, bc: BoundaryCurve, chunk: int = 2048):
    """Closest points of ``P`` on the input boundary: points, triangles, barycentric coordinates.

    Exact: the first closest boundary edge of every point (many points: only the edges with the nearest
    midpoints are compared, certified, see :func:`_nearest_segments_indexed`)."""
    P = np.asarray(P, dtype=np.float64)
    D = bc.B - bc.A
    dd = np.maximum(np.einsum("ij,ij->i", D, D), 1e-300)
    if len(P) * len(D) <= _BRUTE_PAIRS or len(D) <= _NEAR_K:  # the index would cost more than it saves
        best, tbest = _nearest_segments_brute(P, bc.A, D, dd, chunk)
    else:
        best, tbest = _nearest_segments_indexed(P, bc.A, D, dd, chunk)
    X = bc.A[best] + tbest[:, None] * D[best]
    bary = np.zeros((len(P), 3))
    bary[np.arange(len(P)), bc.ca[best]] = 1.0 - tbest
    bary[np.arange(len(P)), bc.cb[best]] += tbest
    return X, bc.tri[best], bary


def snap_boundary(V: np.ndarray, T: np.ndarray, Vc: np.ndarray, Fc: np.ndarray, tri: np.ndarray, bary: np.ndarray,
                  grid: np.ndarray, target_length: float, snap: float = 0.6, relax: int = 8,
                  merge_triangles: bool = True, index=None):
    """Turn the clipped cells along a free boundary into whole quads: snap grid vertices onto the boundary.

    A grid vertex joined to boundary hits by short edges (shorter than ``snap · target_length``) absorbs them and
    moves to its closest point on the input boundary: corner-cut triangles vanish, the pentagons beside them
    become quads, thin strips along the boundary collapse. The band of vertices along the boundary (the boundary
    and its first interior ring) is then relaxed (boundary vertices slide along the boundary, the ring moves in the
    surface) so the rows next to the boundary share the length left over by the grid.

    Parameters
    ----------
    V : (n, 3) float64
        Input surface vertices.
    T : (m, 3) int64
        Input triangles.
    Vc : (p, 3) float64
        Candidate vertices.
    Fc : (f, k) int64
        Candidate faces (padded).
    tri : (p,) int64
        Input triangle of every candidate vertex.
    bary : (p, 3) float64
        Its barycentric coordinates.
    grid : (p,) bool
        True for grid vertices (iso-line crossings), False for boundary hits and corners.
    target_length : float
        Grid spacing in model units.
    snap : float
        Boundary hits closer than ``snap · target_length`` to a grid vertex are absorbed by it.
    relax : int
        Relaxation sweeps of the boundary band (0: none).
    merge_triangles : bool
        Remove the triangles left along the boundary where the grid meets it obliquely: two triangles sharing an
        edge become one quad when their union is convex; a triangle, a quad and a triangle around one boundary
        vertex become two quads; a triangle with one boundary edge loses that edge (its two
        boundary vertices merge, the quads on either side stay quads) unless that stretches the cells around it
        past ``2 · target_length``.
    index : TriangleIndex, optional
        Closest-point index of ``(V, T)`` for the relaxation (built when omitted).

    Returns
    -------
    V, F, tri, bary, grid
        The new candidate (same conventions).

    Notes
    -----
    The boundary snapping of quad extraction for free boundaries (as in the boundary handling of QEx, Ebke et
    al. 2013, where grid vertices close to the boundary are moved onto it).
    """
    h = float(target_length)
    if len(Fc) == 0:
        return Vc, Fc, tri, bary, grid
    bc = boundary_curve(V, T)
    topo = edge_topology(Fc)
    E = topo.E
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[E[topo.count == 1].ravel()] = True
    L = np.linalg.norm(Vc[E[:, 1]] - Vc[E[:, 0]], axis=1)
    # spokes: interior edges from an interior grid vertex to a boundary hit
    spoke = []
    for a, b in ((0, 1), (1, 0)):
        g, p = E[:, a], E[:, b]
        ok = (topo.count == 2) & grid[g] & ~onb[g] & onb[p] & ~grid[p] & (L < snap * h)
        spoke.append(np.stack([g[ok], p[ok], np.nonzero(ok)[0]], axis=1))
    S = np.concatenate(spoke)
    lab = np.arange(nv)
    if len(S):
        # each boundary hit goes to its closest grid vertex
        order = np.argsort(L[S[:, 2]], kind="stable")
        S = S[order]
        _, first = np.unique(S[:, 1], return_index=True)
        S = S[first]
        lab[S[:, 1]] = S[:, 0]
        movers = np.unique(S[:, 0])
        X, ftri, fbary = closest_on_boundary(Vc[movers], bc)
        Vc = Vc.copy()
        tri = tri.copy()
        bary = bary.copy()
        Vc[movers], tri[movers], bary[movers] = X, ftri, fbary
        # a face that collapses around a boundary corner (a corner of the outline between absorbed hits): the grid
        # vertex goes to the corner instead, so sharp corners of the outline survive
        sizes = face_sizes(Fc)
        # only a face with a relabelled corner can collapse (faces have 3+ distinct corners): those, in order, and
        # the later faces around a corner relabelled on the way
        small = sizes <= 5
        todo = np.nonzero(small & (lab[Fc] != Fc).any(axis=1))[0].tolist()
        heapq.heapify(todo)
        queued = set(todo)
        while todo:
            fi = heapq.heappop(todo)
            row = _face_list(Fc[fi])
            c = {int(lab[v]) for v in row}
            corners = [v for v in row if lab[v] == v and not grid[v] and onb[v]]
            gs = [v for v in c if grid[v]]
            if len(c) < 3 and len(corners) == 1 and len(gs) == 1:
                g, v = gs[0], corners[0]
                lab[v] = g
                Vc[g], tri[g], bary[g] = Vc[v], tri[v], bary[v]
                for f in np.nonzero(small & (Fc == v).any(axis=1))[0].tolist():
                    if f > fi and f not in queued:
                        queued.add(f)
                        heapq.heappush(todo, f)
        # grid vertices that snapped onto the same boundary point (a convex turn of the outline) become one
        dl, drep = _merge_close(Vc, 1e-3 * h)
        if len(drep) < nv:
            lab = drep[dl[lab]]
        Vc, Fc, tri, bary, grid = relabel(Vc, Fc, tri, bary, grid, lab)
    if len(Fc):
        Vc, Fc, tri, bary, grid = _close_boundary_corners(Vc, Fc, tri, bary, grid, bc)
    if merge_triangles and len(Fc):
        Vc, Fc, tri, bary, grid = _merge_boundary_triangles(Vc, Fc, tri, bary, grid, bc, h)
    if relax > 0 and len(Fc):
        Vc, tri, bary = _relax_band(Vc, Fc, tri, bary, bc, relax, TriangleIndex(V, T) if index is None else index)
    return Vc, Fc, tri, bary, grid


def relabel(Vc, Fc, tri, bary, grid, lab):
    """Apply a vertex relabelling ``lab (p,)`` to the candidate's faces, drop collapsed faces and unused vertices
    (pinched polygons are split into their loops): ``V, F, tri, bary, grid``."""
    lab = np.asarray(lab, dtype=np.int64)
    if len(Fc) == 0:
        idx = np.zeros(0, dtype=np.int64)
        return Vc[idx], np.zeros((0, 4), dtype=np.int64), tri[idx], bary[idx], grid[idx]
    # vectorized: relabel, drop repeated consecutive corners (cyclic), keep the faces with 3+ distinct corners; the
    # few pinched polygons (a corner repeated further on) are split into their loops one by one
    m, K = Fc.shape
    k = face_sizes(Fc)
    C = lab[Fc]
    j = np.arange(K)
    valid = j[None, :] < k[:, None]
    prev = np.where(j[None, :] > 0, j[None, :] - 1, k[:, None] - 1)
    keep = valid & ((C != np.take_along_axis(C, prev, axis=1)) | (k[:, None] == 1))
    n = keep.sum(axis=1)
    order = np.argsort(~keep, axis=1, kind="stable")
    Cc = np.take_along_axis(C, order, axis=1)
    inside = j[None, :] < n[:, None]
    S = np.sort(np.where(inside, Cc, -1 - j[None, :]), axis=1)
    dup = (S[:, 1:] == S[:, :-1]).any(axis=1) if K > 1 else np.zeros(m, dtype=bool)
    good = (n >= 3) & ~dup
    pinched = np.nonzero((n >= 3) & dup)[0]
    rows = np.nonzero(good)[0]
    pieces = [(int(r), [int(v) for v in Cc[r, :n[r]]]) for r in pinched]
    split = [(r, i, c) for r, c in pieces for i, c in enumerate(_split_pinched(c))]
    width = max([3] + ([int(n[rows].max())] if len(rows) else []) + [len(c) for _, _, c in split])
    if not len(rows) and not split:
        idx = np.zeros(0, dtype=np.int64)
        return Vc[idx], np.zeros((0, 4), dtype=np.int64), tri[idx], bary[idx], grid[idx]
    W = np.arange(width)
    if width <= K:
        G = Cc[rows, :width]
    else:
        G = np.concatenate([Cc[rows], np.repeat(Cc[rows, :1], width - K, axis=1)], axis=1)
    G = np.where(W[None, :] < n[rows, None], G, G[np.arange(len(rows)), n[rows] - 1][:, None])
    if split:
        extra = np.asarray([c + [c[-1]] * (width - len(c)) for _, _, c in split], dtype=np.int64)
        at = np.concatenate([rows, np.asarray([r for r, _, _ in split], dtype=np.int64)])
        sub = np.concatenate([np.zeros(len(rows), dtype=np.int64), np.asarray([i for _, i, _ in split])])
        G = np.concatenate([G, extra])[np.lexsort((sub, at))]
    used = np.zeros(len(Vc), dtype=bool)
    used[G.ravel()] = True
    used = np.nonzero(used)[0]  # np.unique(G), without sorting
    new = np.full(len(Vc), -1, dtype=np.int64)
    new[used] = np.arange(len(used))
    return Vc[used], new[G], tri[used], bary[used], grid[used]


def _close_boundary_corners(Vc, Fc, tri, bary, grid, bc):
    """Merge the two boundary hits of a pentagon (or triangle) whose grid corner lies just outside the boundary.

    A pentagon ``(g1, g2, g3, p1, p2)`` with one boundary edge ``p1 p2`` between two boundary hits is a quad whose
    fourth corner the boundary clipped: ``p1, p2`` merge into one vertex at the boundary point closest to the
    missing corner ``g1 + g3 − g2``; a triangle ``(g, p1, p2)`` merges its hits at the boundary point closest to
    their midpoint (the triangle vanishes).
    """
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    sizes = face_sizes(Fc)
    lab = np.arange(nv)
    taken = np.zeros(nv, dtype=bool)
    targets, who = [], []
    for fi in np.nonzero((sizes == 5) | (sizes == 3))[0]:
        c = _face_list(Fc[fi])
        k = len(c)
        hits = [i for i in range(k) if not grid[c[i]] and onb[c[i]]]
        if len(hits) != 2:
            continue
        i, j = hits
        if (j - i) % k == k - 1:
            i, j = j, i
        if (j - i) % k != 1:
            continue
        p1, p2 = c[i], c[j]
        if taken[p1] or taken[p2]:
            continue
        others = [c[(j + r) % k] for r in range(1, k - 1)]
        if not all(grid[o] for o in others):
            continue
        if k == 5:
            g1, g2, g3 = others
            goal = Vc[g1] + Vc[g3] - Vc[g2]
        else:
            goal = 0.5 * (Vc[p1] + Vc[p2])
        taken[[p1, p2]] = True
        lab[p2] = p1
        targets.append(goal)
        who.append(p1)
    if not who:
        return Vc, Fc, tri, bary, grid
    X, t_, b_ = closest_on_boundary(np.asarray(targets), bc)
    Vc, tri, bary = Vc.copy(), tri.copy(), bary.copy()
    who = np.asarray(who)
    Vc[who], tri[who], bary[who] = X, t_, b_
    return relabel(Vc, Fc, tri, bary, grid, lab)


def _face_list(row: np.ndarray) -> list:
    r = row.tolist()
    while len(r) > 1 and r[-1] == r[-2]:
        r.pop()
    return r


def _relax_band(Vc, Fc, tri, bary, bc, sweeps, index):
    """Uniform Laplacian sweeps over the boundary band; boundary vertices slide on the boundary."""
    topo = edge_topology(Fc)
    E = topo.E
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[E[topo.count == 1].ravel()] = True
    # boundary corners of the candidate (valence 2) stay put
    val = np.bincount(E.ravel(), minlength=nv)
    ring = np.zeros(nv, dtype=bool)
    ring[E[onb[E[:, 0]] | onb[E[:, 1]]].ravel()] = True
    ring &= ~onb
    # boundary vertices where the outline turns sharply (> 30°) stay put too
    be = E[topo.count == 1]
    vv = np.concatenate([be[:, 0], be[:, 1]])
    ww = np.concatenate([be[:, 1], be[:, 0]])
    o = np.argsort(vv, kind="stable")
    vv, ww = vv[o], ww[o]
    first = np.r_[True, vv[1:] != vv[:-1]]
    nb1 = np.full(nv, -1, dtype=np.int64)
    nb2 = np.full(nv, -1, dtype=np.int64)
    nb1[vv[first]] = ww[first]
    second = np.nonzero(~first)[0]
    nb2[vv[second]] = ww[second]
    ok = onb & (nb1 >= 0) & (nb2 >= 0)
    i = np.nonzero(ok)[0]
    d1 = Vc[nb1[i]] - Vc[i]
    d2 = Vc[i] - Vc[nb2[i]]
    cosang = np.einsum("ij,ij->i", d1, d2) / np.maximum(np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1),
                                                        1e-300)
    straight = np.zeros(nv, dtype=bool)
    straight[i] = cosang > np.cos(np.radians(30.0))
    mov_b = onb & (val >= 3) & straight
    mov = mov_b | ring
    if not mov.any():
        return Vc, tri, bary
    # neighbours: boundary vertices average their boundary neighbours only (sliding), ring vertices all neighbours
    bedge = topo.count == 1
    Vc = Vc.copy()
    tri = tri.copy()
    bary = bary.copy()
    rows = np.concatenate([E[:, 0], E[:, 1]])
    cols = np.concatenate([E[:, 1], E[:, 0]])
    isb = np.concatenate([bedge, bedge])
    keep = np.where(onb[rows], isb, True)
    A = sp.csr_matrix((np.ones(int(keep.sum())), (rows[keep], cols[keep])), shape=(nv, nv))
    deg = np.asarray(A.sum(axis=1)).ravel()
    deg[deg == 0] = 1
    ib = np.nonzero(mov_b)[0]
    ir = np.nonzero(ring)[0]
    for _ in range(sweeps):
        avg = (A @ Vc) / deg[:, None]
        put_back(Vc + 0.5 * (avg - Vc), ib, ir, bc, index, Vc, tri, bary)
    return Vc, tri, bary


def put_back(Y, ib, ii, bc, index, X, tri, bary):
    """Write the moved points ``Y`` back onto the surface into ``X, tri, bary`` (in place): boundary vertices
    ``ib`` at their closest boundary points, interior vertices ``ii`` at their closest surface points."""
    if len(ib):
        X[ib], tri[ib], bary[ib] = closest_on_boundary(Y[ib], bc)
    if len(ii):
        cp = index.query(Y[ii])
        X[ii], tri[ii], bary[ii] = cp.points, cp.faces, cp.barycentric


def boundary_turns(Vc: np.ndarray, Fc: np.ndarray):
    """Boundary vertices and whether the outline turns sharply (> 30°) or ends a face corner (valence 2) there."""
    topo = edge_topology(Fc)
    E = topo.E
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    be = E[topo.count == 1]
    onb[be.ravel()] = True
    val = np.bincount(E.ravel(), minlength=nv)
    fixed = onb & (val <= 2)
    # each boundary vertex's two boundary neighbours, in the order of their edges (vectorized)
    own = be.ravel()  # (a0, b0, a1, b1, ...): a's neighbour b, then b's neighbour a, edge by edge
    other = be[:, ::-1].ravel()
    o = np.argsort(own, kind="stable")
    own, other = own[o], other[o]
    deg = np.bincount(own, minlength=nv)
    fixed |= onb & (deg != 2)
    two = np.nonzero(onb & (deg == 2))[0]
    first = np.searchsorted(own, two)
    d1 = Vc[two] - Vc[other[first]]
    d2 = Vc[other[first + 1]] - Vc[two]
    c = np.einsum("ij,ij->i", d1, d2) / np.maximum(np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1), 1e-300)
    fixed[two] |= c < np.cos(np.radians(30.0))
    return topo, onb, fixed


def _convex_quad(P: np.ndarray, max_angle: float = 160.0) -> bool:
    """Whether the 3D quad ``P (4, 3)`` is convex in its mean plane with every corner below ``max_angle``.

    ``max_angle`` above 180° admits slightly reflex corners (a straight corner that the boundary relaxation then
    bends): every corner's turn is measured signed about the quad's mean normal.
    """
    p = P.tolist()  # plain floats: numpy's overhead on 3-vectors is most of the time
    a = [p[2][j] - p[0][j] for j in range(3)]
    b = [p[3][j] - p[1][j] for j in range(3)]
    n = _cross3(a, b)
    nn = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    if nn <= 1e-300:
        return False
    n = [x / nn for x in n]
    for i in range(4):
        a = [p[i - 1][j] - p[i][j] for j in range(3)]
        b = [p[(i + 1) % 4][j] - p[i][j] for j in range(3)]
        c = _cross3(b, a)
        ang = math.degrees(math.atan2(c[0] * n[0] + c[1] * n[1] + c[2] * n[2],
                                      a[0] * b[0] + a[1] * b[1] + a[2] * b[2])) % 360.0  # interior, counter-clockwise
        if not 1.0 < ang < max_angle:
            return False
    return True


def _cross3(a: list, b: list) -> list:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def split_large_faces(Vc: np.ndarray, Fc: np.ndarray, max_size: int = 5) -> np.ndarray:
    """Cut quads off the polygons with more than ``max_size`` corners until none is left (no new vertices).

    Large polygons appear where the parametrization folds near singularities; as panels they are useless and
    they stall the planarization. Each step cuts off the convex quad ``(i, i+1, i+2, i+3)`` (by the diagonal
    ``i — i+3``) whose largest corner angle is smallest (a non-convex one only when no cut gives a convex quad).

    Parameters
    ----------
    Vc : (p, 3) float64
        Vertices.
    Fc : (f, k) int64
        Faces (padded).
    max_size : int
        Polygons with at most this many corners are kept.

    Returns
    -------
    (f', k') int64
        The faces, oriented as before.
    """
    sizes = face_sizes(Fc)
    if len(Fc) == 0 or sizes.max() <= max_size:
        return Fc
    big = np.nonzero(sizes > max_size)[0]
    pieces = []  # (row, piece number, polygon): the large polygons' pieces take their place, in order
    for r in big.tolist():
        out = []
        c = Fc[r, :sizes[r]].tolist()
        while len(c) > max_size:
            n = len(c)
            quads = np.asarray([[c[(i + j) % n] for j in range(4)] for i in range(n)], dtype=np.int64)
            worst = corner_angles(Vc, quads).reshape(n, 4).max(axis=1)
            best = min(range(n), key=lambda i: (not _convex_quad(Vc[quads[i]]), worst[i]))
            out.append(quads[best].tolist())
            drop = {c[(best + 1) % n], c[(best + 2) % n]}
            c = [v for v in c if v not in drop]
        out.append(c)
        pieces.extend((r, i, q) for i, q in enumerate(out))
    small = np.nonzero(sizes <= max_size)[0]
    width = max([3, int(sizes[small].max()) if len(small) else 3] + [len(q) for _, _, q in pieces])
    rows = np.concatenate([Fc[small, :width],
                           np.asarray([q + [q[-1]] * (width - len(q)) for _, _, q in pieces], dtype=np.int64)])
    at = np.concatenate([small, np.asarray([r for r, _, _ in pieces], dtype=np.int64)])
    sub = np.concatenate([np.zeros(len(small), dtype=np.int64),
                          np.asarray([i for _, i, _ in pieces], dtype=np.int64)])
    return rows[np.lexsort((sub, at))]


_DEGENERATE = np.radians(5.0)  # corners sharper than this, or straighter than 180° minus this, are degenerate


def collapse_short_edges(Vc: np.ndarray, Fc: np.ndarray, tri: np.ndarray, bary: np.ndarray, grid: np.ndarray,
                         target_length: float, ratio: float = 0.25):
    """Collapse the candidate's edges shorter than ``ratio · target_length`` (shortest first, one per vertex per pass).

    Short edges are left where the boundary snapping and relaxation bring two boundary vertices together, or where
    iso-lines cross almost at one point; as panels they are slivers (a quad with a short edge is a triangle with a
    T-vertex), and a quad whose short boundary edge is straightened by the planarization's boundary sliding
    degenerates and blocks the solver. At a degenerate corner (sharper than 5° or straighter than 175°: spikes
    and T-vertices where snapped boundary vertices met) its two edges are collapsed as well, the shorter first
    (one per pass), and a straight face corner of valence 2 on the boundary does not count as an outline corner.
    The kept end is the more constrained one (a sharp corner of the outline, then a boundary vertex, then a grid
    vertex); an edge is skipped where collapsing it would pinch the mesh (both ends on the boundary across the
    inside, or common neighbours other than the apexes of triangles on the edge) or merge two outline corners (a
    face corner of valence 2 joined to a boundary vertex of higher valence by a short boundary edge is not a
    second corner: it goes). Quads on the edge become triangles. Faces whose corners all lie on the boundary and
    that are degenerate, non-convex or small are then removed where the mesh stays manifold (slivers and folds
    where the outline turns tightly, e.g. around a small hole).

    Parameters
    ----------
    Vc, Fc, tri, bary, grid
        The candidate (as returned by :func:`quad_mesh_from_parametrization` / :func:`snap_boundary`).
    target_length : float
        Grid spacing in model units.
    ratio : float
        Edges shorter than ``ratio · target_length`` are collapsed.

    Returns
    -------
    V, F, tri, bary, grid
        The new candidate (same conventions).
    """
    h = float(target_length)
    for _ in range(3):
        if len(Fc) == 0:
            break
        topo, onb, fixed = boundary_turns(Vc, Fc)
        E = topo.E
        L = np.linalg.norm(Vc[E[:, 1]] - Vc[E[:, 0]], axis=1)
        nv = len(Vc)
        short = np.nonzero(L < ratio * h)[0]
        # degenerate corners (spikes and straight corners): the shorter of their two edges goes too
        C = face_corners(Fc)
        ang = corner_angles(Vc, Fc)
        deg = np.nonzero(_degenerate(ang))[0]
        if len(deg):
            # corners and half-edges share their order: corner i starts half-edge i, its face's previous corner
            # starts the half-edge that ends at it
            k = face_sizes(Fc)[C.face[deg]]
            prev = np.where(C.slot[deg] > 0, deg - 1, deg + k - 1)
            short = np.union1d(short, topo.HE[np.concatenate([deg, prev])])  # the shorter goes first, if it may
            # a face corner (valence 2) standing straight on the boundary is no corner of the outline
            straight = np.zeros(nv, dtype=bool)
            straight[C.v[deg][ang[deg] > np.pi - _DEGENERATE]] = True
            fixed = fixed & ~(straight & (np.bincount(E.ravel(), minlength=nv) == 2))
        if not len(short):
            break
        nbrs = _neighbour_sets(E, nv, np.unique(E[short]))  # of the short edges' ends only
        apex = _apexes(Fc, E[short])
        rank = fixed.astype(int) * 4 + onb.astype(int) * 2 + grid.astype(int)
        lab = np.arange(nv)
        touched = np.zeros(nv, dtype=bool)
        Vn = Vc.copy()
        done = 0
        for e in short[np.argsort(L[short], kind="stable")]:
            a, b = (int(x) for x in E[e])
            if touched[a] or touched[b]:
                continue
            if onb[a] and onb[b] and topo.count[e] != 1:
                continue
            if (nbrs[a] & nbrs[b]) != apex.get((min(a, b), max(a, b)), set()):
                continue
            if fixed[a] and fixed[b]:
                # two "corners" joined by a short boundary edge: the turn measured across a short edge is
                # unreliable, and the corner of a face (valence 2) is the end that goes; real corner pairs stay
                if topo.count[e] != 1 or (len(nbrs[a]) > 2) == (len(nbrs[b]) > 2):
                    continue
                keep, gone = (a, b) if len(nbrs[a]) > 2 else (b, a)
            else:
                keep, gone = (a, b) if rank[a] >= rank[b] else (b, a)
            lab[gone] = keep
            touched[[a, b]] = True
            touched[list(nbrs[a] | nbrs[b])] = True  # one collapse per neighbourhood per pass
            done += 1
        if not done:
            break
        Vc, Fc, tri, bary, grid = relabel(Vn, Fc, tri, bary, grid, lab)
    for _ in range(3):  # a dropped sliver can leave its neighbour on the boundary
        nf = len(Fc)
        Vc, Fc, tri, bary, grid = _drop_boundary_slivers(Vc, Fc, tri, bary, grid, h)
        if len(Fc) == nf:
            break
    return Vc, Fc, tri, bary, grid


def drop_keeping_manifold(Fc: np.ndarray, topo, drop, nv: int) -> np.ndarray:
    """``keep (m,) bool``: the faces ``drop`` removed one by one, in order, each only where afterwards no vertex has
    more than two boundary edges (two boundary loops touching there); ``topo`` is :func:`edge_topology` of ``Fc``.

    Incremental (the face counts of the removed face's edges, the boundary-edge counts of their ends): the same
    verdicts as recounting the boundary of the remaining faces after every removal."""
    keep = np.ones(len(Fc), dtype=bool)
    count = topo.count.copy()
    nb = np.bincount(topo.E[count == 1].ravel(), minlength=nv)
    over = int(np.count_nonzero(nb > 2))
    H, HF = halfedges(Fc)
    first = np.searchsorted(HF, np.arange(len(Fc) + 1))
    for f in np.asarray(drop, dtype=np.int64).tolist():
        es = topo.HE[first[f]:first[f + 1]].tolist()
        changed = []
        for e in es:
            a, b = topo.E[e].tolist()
            count[e] -= 1
            step = 1 if count[e] == 1 else (-1 if count[e] == 0 else 0)  # became / stopped being a boundary edge
            if step:
                for v in (a, b):
                    over -= nb[v] > 2
                    nb[v] += step
                    over += nb[v] > 2
                changed.append((a, b, step))
        if over > 0:  # undo
            for e in es:
                count[e] += 1
            for a, b, step in changed:
                for v in (a, b):
                    over -= nb[v] > 2
                    nb[v] -= step
                    over += nb[v] > 2
        else:
            keep[f] = False
    return keep


def _neighbour_sets(E: np.ndarray, nv: int, verts: np.ndarray) -> dict:
    """``{v: set of neighbours}`` of the vertices ``verts`` in the graph of the edges ``E``."""
    a = np.concatenate([E[:, 0], E[:, 1]])
    b = np.concatenate([E[:, 1], E[:, 0]])
    o = np.argsort(a, kind="stable")
    ptr = np.searchsorted(a[o], np.arange(nv + 1))
    b = b[o]
    return {v: set(b[ptr[v]:ptr[v + 1]].tolist()) for v in np.asarray(verts).tolist()}


def _apexes(Fc: np.ndarray, edges: np.ndarray) -> dict:
    """``{(a, b): set of apexes}`` (``a < b``) of the triangles of ``Fc`` on the given edges (rows ``(a, b)``)."""
    T3 = Fc[face_sizes(Fc) == 3][:, :3]
    if not len(T3) or not len(edges):
        return {}
    n = int(max(Fc.max(), edges.max())) + 1
    want = np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1])
    out: dict = {}
    for i in range(3):
        a, b, c = T3[:, i], T3[:, (i + 1) % 3], T3[:, (i + 2) % 3]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        on = np.isin(lo * n + hi, want)
        for x, y, z in zip(lo[on].tolist(), hi[on].tolist(), c[on].tolist()):
            out.setdefault((x, y), set()).add(z)
    return out


def _degenerate(ang: np.ndarray) -> np.ndarray:
    """Which corner angles (radians, :func:`corner_angles`) are sharper than 5° or straighter than 175°."""
    return (ang < _DEGENERATE) | (ang > np.pi - _DEGENERATE)


def _drop_boundary_slivers(Vc, Fc, tri, bary, grid, h: float = 0.0, small: float = 0.3):
    """Remove the faces whose corners all lie on the boundary and that have a degenerate corner, are non-convex
    (folded by the snapping where the outline turns tightly) or have an area below ``small · h²`` (slivers spanning
    a turn of the outline, e.g. along a jagged hole: they cover next to no surface, no sliding on the boundary can
    make them planar and no collapse can fix them), when the mesh stays manifold without them. Only faces wholly on
    the boundary go, so the candidate's boundary stays on the input boundary."""
    if len(Fc) < 2:
        return Vc, Fc, tri, bary, grid
    topo = edge_topology(Fc)
    onb = np.zeros(len(Vc), dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    # only the faces wholly on the boundary are measured (every measure is per face): the padding repeats a corner
    allb = np.nonzero(onb[Fc].all(axis=1))[0]
    if not len(allb):
        return Vc, Fc, tri, bary, grid
    Fb = Fc[allb]
    bad = np.zeros(len(Fb), dtype=bool)
    bad[face_corners(Fb).face[_degenerate(corner_angles(Vc, Fb))]] = True
    Xc = Vc - Vc.mean(axis=0)  # Newell products about the centre: far from the origin they would cancel
    bad |= np.linalg.norm(face_normals(Xc, Fb, unit=False), axis=1) < small * h * h
    drop = allb[bad | nonconvex_faces(Xc, Fb)]
    if not len(drop):
        return Vc, Fc, tri, bary, grid
    keep = drop_keeping_manifold(Fc, topo, drop, len(Vc))  # a vertex where two boundary loops would touch: kept
    if keep.all():
        return Vc, Fc, tri, bary, grid
    return relabel(Vc, Fc[keep], tri, bary, grid, np.arange(len(Vc)))


@single_blas_thread()  # sparse factorizations: see components.core.blas
def relax_edge_lengths(V: np.ndarray, T: np.ndarray, Vc: np.ndarray, Fc: np.ndarray, tri: np.ndarray,
                       bary: np.ndarray, target_length: float, band: float = 0.25, iterations: int = 10,
                       anchor: float = 0.05, index=None):
    """Even out the candidate's edge lengths on the surface: edges outside ``±band`` of the target are pulled
    into the band, the others keep their current vectors.

    A local-global iteration: every edge's goal is its current vector with the length clamped to
    ``[(1 − band) h, (1 + band) h]``; one sparse least-squares solve (edge goals plus a weak pull ``anchor`` to the
    current positions, one factorization) moves the vertices, which are then put back on the surface (interior
    vertices) or slid along the surface boundary (boundary vertices; sharp corners of the outline stay). Where the
    parametrization compresses or stretches the grid (a field that is not integrable, a boundary band after
    snapping) the cells even out while the rows keep their course; measured on the test surfaces the share of
    edges within ±30% rises by 2–6 points at a 5–15% higher mean planarity before optimization. An iteration
    that would make a face non-convex, turn it against the surface or give it a degenerate corner (sharper than
    5°, straighter than 175°) holds that face's corners where they were for the rest of the relaxation.

    Parameters
    ----------
    V : (n, 3) float64
        Input surface vertices.
    T : (m, 3) int64
        Input triangles.
    Vc : (p, 3) float64
        Candidate vertices (on the surface).
    Fc : (f, k) int64
        Candidate faces (padded).
    tri : (p,) int64
        Input triangle of every candidate vertex.
    bary : (p, 3) float64
        Its barycentric coordinates.
    target_length : float
        Target edge length.
    band : float
        Relative half-width of the accepted length band.
    iterations : int
        Local-global iterations (0: none).
    anchor : float
        Weight of the pull to the current positions.
    index : TriangleIndex, optional
        Closest-point index of ``(V, T)`` (built when omitted).

    Returns
    -------
    V, tri, bary
        The moved candidate vertices and their surface locations (faces unchanged).
    """
    h = float(target_length)
    if len(Fc) == 0 or iterations <= 0:
        return Vc, tri, bary
    index = TriangleIndex(V, T) if index is None else index
    bc = boundary_curve(V, T)
    topo, onb, fixed = boundary_turns(Vc, Fc)
    E = topo.E
    ne, nv = len(E), len(Vc)
    rows = np.r_[np.arange(ne), np.arange(ne)]
    D = sp.csr_matrix((np.r_[-np.ones(ne), np.ones(ne)], (rows, np.r_[E[:, 0], E[:, 1]])), shape=(ne, nv))
    w = np.where(fixed, 1e6, anchor)
    solve = factorized((D.T @ D + sp.diags(w)).tocsc())
    FN = cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    first = Fc[:, 0]
    C = face_corners(Fc)

    def bad_faces(X, tri_):
        """Faces turned against the surface, non-convex or with a degenerate corner (:func:`nonconvex_faces` and
        :func:`corner_angles` with the normals and corners computed once)."""
        Xc = X - X.mean(axis=0)  # Newell products about the centre: far from the origin they would cancel
        N = face_normals(Xc, Fc)
        bad = np.einsum("ij,ij->i", N, FN[tri_[first]]) <= 0
        bad[C.face[dot(cross(Xc[C.v] - Xc[C.prev], Xc[C.next] - Xc[C.v]), N[C.face]) <= 0.0]] = True
        bad |= ~np.any(N != 0.0, axis=1)
        a, b = X[C.v] - X[C.prev], X[C.next] - X[C.v]
        c = cross(a, b)
        bad[C.face[_degenerate(np.arctan2(np.sqrt(dot(c, c)), -dot(a, b)))]] = True
        return bad

    ib = np.nonzero(onb & ~fixed)[0]
    ii = np.nonzero(~onb)[0]
    X, tri, bary = Vc.copy(), tri.copy(), bary.copy()
    bad0 = bad_faces(X, tri)
    held = np.zeros(nv, dtype=bool)  # vertices whose move spoiled a face: they stay where they were
    for _ in range(int(iterations)):
        d = X[E[:, 1]] - X[E[:, 0]]
        L = np.linalg.norm(d, axis=1)
        if np.all(np.abs(L / h - 1.0) <= band):
            break
        goal = d / np.maximum(L, 1e-300)[:, None] * np.clip(L, (1.0 - band) * h, (1.0 + band) * h)[:, None]
        rhs = D.T @ goal + w[:, None] * X
        Y = np.column_stack([solve(rhs[:, k]) for k in range(3)])
        tri2, bary2 = tri.copy(), bary.copy()
        put_back(Y, ib, ii, bc, index, Y, tri2, bary2)
        for _ in range(3):
            stay = fixed | held
            Y[stay], tri2[stay], bary2[stay] = X[stay], tri[stay], bary[stay]
            spoiled = bad_faces(Y, tri2) & ~bad0
            if not spoiled.any():
                break
            held[Fc[spoiled][Fc[spoiled] >= 0]] = True
        else:
            break
        X, tri, bary = Y, tri2, bary2
    return X, tri, bary


def _union_cycle(polys: list):
    """Outline of the union of adjacent polygons (one cycle of vertices) or None if it is not one simple cycle."""
    he = {}
    for c in polys:
        for i in range(len(c)):
            he[(c[i], c[(i + 1) % len(c)])] = True
    out = {}
    for a, b in he:
        if (b, a) not in he:
            if a in out:
                return None
            out[a] = b
    if not out:
        return None
    start = next(iter(out))
    cyc, v = [start], out[start]
    while v != start:
        if v not in out or len(cyc) > len(out):
            return None
        cyc.append(v)
        v = out[v]
    return cyc if len(cyc) == len(out) else None


def _merge_boundary_triangles(Vc, Fc, tri, bary, grid, bc, h, stretch=2.0):
    """Remove the triangles along the boundary (grid oblique to the boundary).

    First, two triangles sharing an interior edge, one of them on the boundary, become one quad when their union
    is convex (the shared edge is dropped). Along a boundary at ~45° to the grid the boundary row alternates
    half-cell triangles and cells standing on a corner: a boundary vertex with exactly a triangle, a quad and a
    triangle around it is the corner of a hexagon, which the diagonal from it to the opposite corner splits into
    two quads (corners up to 185° are admitted: the relaxation bends the straight ones). Then a triangle ``(g, p1, p2)`` with one boundary edge ``p1 p2`` loses
    that edge: ``p1`` and ``p2`` merge (when ``g`` is their only common neighbour, so the mesh stays manifold), at
    the sharp corner of the outline if one of them is one, else at the boundary point closest to their midpoint.
    The quads on either side of the triangle keep four corners; the boundary relaxation that follows evens out
    the spacing along the boundary. A collapse that would leave a neighbour of the merged vertex farther than
    ``stretch · h`` from it is skipped: at ~45° the boundary triangles are half cells, and removing all of them
    stretches the boundary row past the ±30% edge-length band (measured without the cap: inspired_mesh 90.1% →
    89.3% of edges in the band; ``stretch = 2`` keeps the edge share wherever it was ≥ 90%).
    """
    topo, onb, fixed = boundary_turns(Vc, Fc)
    # every step works on the faces with a corner on the boundary (the band): a boundary triangle's neighbours
    # across its edges, the faces around a boundary vertex all have one; the other faces stay as they are
    sizes = face_sizes(Fc)
    band = np.nonzero(onb[Fc].any(axis=1))[0]  # padding repeats a corner: the padded row has the same corners
    faces = {f: r[:k] for f, r, k in zip(band.tolist(), Fc[band].tolist(), sizes[band].tolist())}
    near = np.zeros(len(Vc), dtype=bool)
    near[Fc[band].ravel()] = True
    edge_faces = _edge_faces(Fc, topo, near)
    dead = np.zeros(len(Fc), dtype=bool)
    _pair_boundary_triangles(Vc, faces, edge_faces, dead)
    if _split_boundary_hexagons(Vc, faces, edge_faces, dead, onb & ~fixed, h, stretch):
        topo = edge_topology(_with_faces(Fc, faces, dead))
    lab, keep, goal = _collapse_boundary_triangles(Vc, faces, edge_faces, dead, topo, onb, fixed, bc, h, stretch)
    nv = len(Vc)
    if not dead.any() and not (lab != np.arange(nv)).any():
        return Vc, Fc, tri, bary, grid
    Vc, tri, bary, grid = Vc.copy(), tri.copy(), bary.copy(), grid.copy()
    if keep:
        X, t_, b_ = closest_on_boundary(np.asarray(goal), bc)
        keep = np.asarray(keep)
        Vc[keep], tri[keep], bary[keep] = X, t_, b_
    moved = np.nonzero(lab != np.arange(nv))[0]
    grid[lab[moved]] |= grid[moved]
    return relabel(Vc, _with_faces(Fc, faces, dead), tri, bary, grid, lab)


def _with_faces(Fc: np.ndarray, faces: dict, dead: np.ndarray) -> np.ndarray:
    """``Fc`` with the rows of ``faces`` (``{row: corners}``) replaced and the ``dead`` rows removed: the padded
    array of the faces as :func:`components.core.mesh.pad_faces` makes it from the list of the living faces."""
    K = max([3] + [len(c) for f, c in faces.items() if not dead[f]])
    live = ~dead
    rest = live.copy()
    rest[list(faces)] = False
    K = max(K, int(face_sizes(Fc[rest]).max()) if rest.any() else 3)
    F = np.empty((len(Fc), K), dtype=np.int64)
    w = min(K, Fc.shape[1])
    F[:, :w] = Fc[:, :w]
    if K > w:
        F[:, w:] = Fc[:, w - 1:w]
    for f, c in faces.items():
        F[f, :len(c)] = c
        F[f, len(c):] = c[-1]
    return F[live]


def _edge_faces(Fc: np.ndarray, topo, near: np.ndarray | None = None) -> dict:
    """``{(a, b): [faces]}`` (``a < b``) of every edge of ``Fc`` (with ``near``, of the edges with an end where
    ``near`` is set), faces in ascending order (``topo`` its :func:`edge_topology`)."""
    sel = np.ones(len(topo.E), dtype=bool) if near is None else near[topo.E[:, 0]] | near[topo.E[:, 1]]
    idx = np.nonzero(sel)[0]
    keys = list(map(tuple, topo.E[idx].tolist()))
    out = {k: ([f0] if c == 1 else [f0, f1])
           for k, c, (f0, f1) in zip(keys, topo.count[idx].tolist(), topo.EF[idx].tolist())}
    many = np.nonzero(sel & (topo.count > 2))[0]
    if len(many):
        _, HF = halfedges(Fc)
        for e in many.tolist():
            out[tuple(topo.E[e].tolist())] = HF[topo.HE == e].tolist()
    return out


def _boundary_slots(c: list, edge_faces: dict) -> list:
    """Positions ``i`` of the boundary edges ``c[i] → c[i+1]`` of a face (edges with one face in ``edge_faces``)."""
    return [i for i in range(len(c)) if len(edge_faces[(min(c[i], c[(i + 1) % len(c)]),
                                                       max(c[i], c[(i + 1) % len(c)]))]) == 1]


def _pair_boundary_triangles(Vc, faces: dict, edge_faces: dict, dead: np.ndarray) -> None:
    """Two triangles sharing an interior edge, one of them on the boundary, become one quad when their union is
    convex (in place: the quad replaces the boundary triangle, the other is marked dead; ``faces`` ``{row:
    corners}`` of the faces with a corner on the boundary, in ascending order)."""
    for fi in list(faces):
        c = faces[fi]
        if len(c) != 3 or dead[fi] or not _boundary_slots(c, edge_faces):
            continue
        best = None
        for i in range(3):
            a, b = c[i], c[(i + 1) % 3]
            fs = edge_faces[(min(a, b), max(a, b))]
            if len(fs) != 2:
                continue
            fj = fs[0] if fs[1] == fi else fs[1]
            d = faces[fj]
            if len(d) != 3 or dead[fj]:
                continue
            # d runs b → a; its third vertex goes between a and b
            x = [v for v in d if v != a and v != b][0]
            q = [c[(i + 2) % 3], a, x, b]
            if len(set(q)) == 4 and _convex_quad(Vc[q]):
                best = (fj, q)
                break
        if best is not None:
            fj, q = best
            faces[fi] = q
            dead[fj] = True


def _split_boundary_hexagons(Vc, faces: dict, edge_faces: dict, dead: np.ndarray, movable: np.ndarray, h: float,
                             stretch: float) -> bool:
    """A triangle, a quad and a triangle around a movable boundary vertex (the row along a ~45° boundary) become
    two quads split by the diagonal from that vertex (in place). Returns whether any was split."""
    vf: dict = {}
    for fi, c in faces.items():
        for v in c:
            vf.setdefault(v, []).append(fi)
    split = False
    for p in np.nonzero(movable)[0].tolist():
        fs = vf.get(p, [])
        if len(fs) != 3 or sorted(len(faces[f]) for f in fs) != [3, 3, 4]:
            continue
        if any(len(faces[f]) == 3 and not _boundary_slots(faces[f], edge_faces) for f in fs):
            continue
        hexa = _union_cycle([faces[f] for f in fs])
        if hexa is None or len(hexa) != 6 or p not in hexa:
            continue
        r = hexa.index(p)
        hexa = hexa[r:] + hexa[:r]
        q1, q2 = hexa[0:4], hexa[3:6] + [hexa[0]]
        if np.linalg.norm(Vc[hexa[3]] - Vc[p]) > stretch * h:
            continue
        if not (_convex_quad(Vc[q1], 185.0) and _convex_quad(Vc[q2], 185.0)):
            continue
        f0, f1, f2 = fs
        faces[f0], faces[f1] = q1, q2
        dead[f2] = True
        split = True
        for v in hexa:
            vf[v] = [f for f in vf[v] if f not in fs] + [f for f in (f0, f1) if v in faces[f]]
    return split


def _collapse_boundary_triangles(Vc, faces: dict, edge_faces: dict, dead: np.ndarray, topo, onb: np.ndarray,
                                 fixed: np.ndarray, bc: BoundaryCurve, h: float, stretch: float):
    """The boundary edge ``p1 p2`` of each remaining boundary triangle ``(g, p1, p2)`` collapses (see
    :func:`_merge_boundary_triangles`): ``lab`` the vertex relabelling, ``keep`` the merged vertices that move and
    ``goal`` the points whose closest boundary points they move to."""
    nv = len(Vc)
    lab = np.arange(nv)
    touched = np.zeros(nv, dtype=bool)
    keep, goal = [], []
    todo = []
    for fi, c in faces.items():
        if len(c) != 3 or dead[fi]:
            continue
        be = _boundary_slots(c, edge_faces)
        if len(be) == 1:
            todo.append((c, be[0]))
    ends = np.asarray([c[(i + r) % 3] for c, i in todo for r in (0, 1)], dtype=np.int64)
    nbrs = _neighbour_sets(topo.E, nv, np.unique(ends))  # of the boundary edges' ends only
    # the boundary points closest to the boundary edges' midpoints, all at once (each is the point's own)
    mids = np.asarray([0.5 * (Vc[c[i]] + Vc[c[(i + 1) % 3]]) for c, i in todo]).reshape(-1, 3)
    near = closest_on_boundary(mids, bc)[0] if len(todo) else mids
    for (c, i), X_mid in zip(todo, near):
        p1, p2, g = c[i], c[(i + 1) % 3], c[(i + 2) % 3]
        if touched[p1] or touched[p2] or onb[g] or (fixed[p1] and fixed[p2]):
            continue
        if nbrs[p1] & nbrs[p2] != {g}:
            continue
        if fixed[p2]:
            p1, p2 = p2, p1
        X = Vc[p1] if fixed[p1] else X_mid
        around = [v for v in (nbrs[p1] | nbrs[p2]) if v != p1 and v != p2]
        if np.linalg.norm(Vc[around] - X, axis=1).max() > stretch * h:
            continue
        lab[p2] = p1
        touched[list(nbrs[p1] | nbrs[p2] | {p1, p2})] = True
        if not fixed[p1]:
            keep.append(p1)
            goal.append(0.5 * (Vc[p1] + Vc[p2]))
    return lab, keep, goal
