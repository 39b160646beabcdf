"""Panel health of the candidate: what makes a candidate quad mesh unfabricable, repaired before planarization.

The extraction (:mod:`components.fields.extract`) leaves a few panels that no planarization can make fabricable:
an interior vertex of valence 2 (two faces folded onto each other, or a quad with a 170° corner), a quad pinched
to a triangle near a singularity (a corner over 160°), a bow-tie where the parametrization folded, a corner under
20° where snapped boundary vertices met, an edge a fraction of the median. :func:`repaired_candidate` measures the
candidate with :func:`components.metrics.health.face_health` (shape checks at the health bounds: corners in
``[20°, 160°]``, edges over 0.2 × the median, faces over 0.1 × the median area, convex, not flipped against the
surface, not folded or crossing) and repairs, pass by pass, until it is healthy or nothing changes:

1. *dissolve* every interior vertex of valence 2 (its two faces merge into one polygon without it) and every
   outline vertex of valence 2 whose corner is within 25° of straight in an unhealthy face or a pentagon;
2. *collapse* edges shorter than the bound (:func:`components.fields.extract.collapse_short_edges`, then the
   ones it keeps, e.g. between two corners of a jagged outline);
3. *smooth* the vertices of the unhealthy faces, and of those within 5° of the corner bounds, on the surface:
   each tries a few positions (towards the mean of its neighbours, the mean of its quads' parallelogram
   completions, the mean of its faces' centroids, by full, half, quarter and tenth steps; small moves in eight
   tangent directions), put back on the surface (boundary vertices on the boundary; sharp corners of the
   outline stay), and keeps the one that opens its worst corner most (signed about the face's normal, so a
   reflex corner or a face flipped against the surface counts negative; counted up to 5° past the bound, the
   shortest such move wins: the net stays as conjugate as it can) without taking an edge or a face under 1.25 ×
   its bound; vertices sharing a face do not move in the same sweep;
4. *rotate* the edge between an unhealthy quad and a neighbouring quad, or *split* an unhealthy polygon at its
   worst corner, where that opens the worst corner by 5° or more;
5. *drop* a triangle that is still unhealthy and has all its corners on the boundary (a sliver along the
   outline), where the mesh stays manifold without it.

Every bound is relative to the candidate's median edge and median face area, every product is taken about a
nearby vertex, and the smoothing compares corner margins rounded to 0.01°: the repair does the same for a model
in millimetres or kilometres, or far from the origin (the last bits of the input do not decide a move).

References
----------
D. A. Field, "Laplacian smoothing and Delaunay triangulations", Comm. Applied Numerical Methods 4(6), 1988 (smart
Laplacian smoothing: a move is kept only when it improves the elements around the vertex).
L. A. Freitag, "On combining Laplacian and optimization-based mesh smoothing techniques", AMD Trends in
Unstructured Mesh Generation 220, 1997 (maximizing the worst angle of the incident elements).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from components.core.mesh import edge_topology, face_sizes, pad_faces
from components.core.proximity import TriangleIndex
from components.fields.extract import (
    boundary_curve,
    closest_on_boundary,
    collapse_short_edges,
    relabel,
)
from components.metrics.health import DEFECT_BITS, PanelHealth, face_health

log = logging.getLogger(__name__)

__all__ = ["Repaired", "candidate_health", "repaired_candidate"]

_STEPS = (1.0, 0.5, 0.25, 0.1)  # fractions of the way to each smoothing target
_RING = 8  # directions of the small tangent moves tried besides the targets
_RADII = (0.05, 0.15, 0.3)  # their lengths, × the vertex's shortest edge
_SWEEPS = 20  # smoothing sweeps per pass (each moves a vertex at most once; most stop after a few)
_PASSES = 4  # repair passes (each: dissolve, collapse, smooth, drop)
_SHARP_TURN = np.radians(30.0)  # a boundary vertex where the candidate's outline turns more than this stays put
_MARGIN = 5.0  # degrees: the smoothing keeps improving a vertex's worst corner up to the bound plus this
_QUANTUM = 0.01  # degrees: corner margins are compared at this resolution (see _quantized)
_SLACK = 1.25  # a smoothing move may not take an edge (a face) under this × its bound, unless it already was
# defects the repair acts on (planarity is the planarization's, coverage needs the surface)
_SHAPE = ("short_edge", "degenerate", "corner", "nonconvex", "small", "intersecting", "folded", "flipped",
          "nonmanifold")
_SHAPE_BITS = sum(DEFECT_BITS[d] for d in _SHAPE)


class Repaired(NamedTuple):
    """Result of :func:`repaired_candidate`: the candidate ``V, F, tri, bary, grid`` (conventions of
    :mod:`components.fields.extract`), its ``health`` (shape checks, no reference) and ``actions``, the counts of
    what was done (``dissolved``, ``collapsed``, ``smoothed``, ``dropped``)."""

    V: np.ndarray
    F: np.ndarray
    tri: np.ndarray
    bary: np.ndarray
    grid: np.ndarray
    health: PanelHealth
    actions: dict


def candidate_health(Vc, Fc, reference=None, *, min_edge_ratio: float = 0.2, min_angle: float = 20.0,
                     min_area_ratio: float = 0.1, min_coverage: float = 0.85) -> PanelHealth:
    """:func:`~components.metrics.health.face_health` of a candidate before planarization: the shape checks (and,
    with ``reference``, coverage and faces flipped against it), planarity left out (it is the planarization's).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> h = candidate_health(*quad_grid(3, 3))
    >>> h.healthy, h.worst_corner
    (True, 90.0)
    """
    return face_health(Vc, Fc, reference, tolerance=1e300, min_edge_ratio=min_edge_ratio, min_angle=min_angle,
                       min_area_ratio=min_area_ratio, min_coverage=min_coverage, name="candidate")


def repaired_candidate(V, T, Vc, Fc, tri, bary, grid, target_length: float, *, index=None,
                       min_edge_ratio: float = 0.2, min_angle: float = 20.0, min_area_ratio: float = 0.1,
                       passes: int = _PASSES) -> Repaired:
    """Repair the unhealthy panels of a candidate on the surface ``(V, T)`` (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64
        Input surface vertices.
    T : (t, 3) int64
        Input triangles.
    Vc, Fc, tri, bary, grid
        The candidate: vertices on the surface, padded faces, the input triangle and barycentric coordinates of
        every vertex, grid-vertex flags.
    target_length : float
        Panel size (model units); collapses are measured against the candidate's median edge, not this.
    index : TriangleIndex, optional
        Closest-point index of ``(V, T)`` (built when omitted).
    min_edge_ratio, min_angle, min_area_ratio : float
        The health bounds (× median edge, degrees, × median face area).
    passes : int
        Repair passes at most.

    Returns
    -------
    Repaired

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4, 4.0, 4.0)
    >>> T = triangulate(Q)[0]
    >>> Vc = V.copy(); Vc[6] = [1.8, 1.8, 0.0]  # vertex 6 pushed past the middle of its quad: a 14° corner
    >>> q = TriangleIndex(V, T).query(Vc)
    >>> r = repaired_candidate(V, T, q.points, Q, q.faces, q.barycentric, np.ones(len(V), bool), 1.0)
    >>> r.health.healthy, r.actions["smoothed"], r.health.worst_corner
    (True, 1, 90.0)
    """
    h = float(target_length)
    index = TriangleIndex(V, T) if index is None else index
    bc = boundary_curve(V, T)
    FN = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    FN /= np.maximum(np.linalg.norm(FN, axis=1, keepdims=True), 1e-300)
    bounds = (min_edge_ratio, min_angle, min_area_ratio)
    actions = dict(dissolved=0, collapsed=0, smoothed=0, rotated=0, split=0, dropped=0)
    state = (Vc, Fc, tri, bary, grid)

    def check(st):
        return candidate_health(st[0], st[1], min_edge_ratio=min_edge_ratio, min_angle=min_angle,
                                min_area_ratio=min_area_ratio)

    hl = check(state)
    for _ in range(max(int(passes), 0)):
        if not ((hl.face_defects & _SHAPE_BITS).any() or _near_bounds(hl, min_angle).any()) or len(state[1]) < 2:
            break
        before = (len(state[0]), len(state[1]), hl.face_defects.copy(), hl.worst_corner)
        state, k = _dissolve_valence_two(*state)
        actions["dissolved"] += k
        if k:
            hl = check(state)
        state, k = _dissolve_boundary_corners(state, hl, min_angle)
        actions["dissolved"] += k
        if k:
            hl = check(state)
        if hl.counts["short_edge"]:
            n0 = len(state[0])
            ratio = 1.02 * min_edge_ratio * hl.median_edge / h
            state = collapse_short_edges(*state, h, ratio=ratio)
            hl = check(state)
            if hl.counts["short_edge"]:
                state = _collapse_remaining(state, hl)
                hl = check(state)
            actions["collapsed"] += n0 - len(state[0])
        state, k = _smoothed(state, hl, FN, index, bc, bounds)
        actions["smoothed"] += k
        if k:
            hl = check(state)
        state, k = _rotated_edges(state, hl)
        actions["rotated"] += k
        if k:
            hl = check(state)
            state, k2 = _smoothed(state, hl, FN, index, bc, bounds)
            actions["smoothed"] += k2
            if k2:
                hl = check(state)
        state, k = _split_bad_faces(state, hl, min_angle)
        actions["split"] += k
        if k:
            hl = check(state)
        state, k = _drop_bad_boundary_triangles(state, hl)
        actions["dropped"] += k
        if k:
            hl = check(state)
        if ((len(state[0]), len(state[1])) == before[:2] and np.array_equal(hl.face_defects, before[2])
                and hl.worst_corner == before[3]):
            break
    log.debug("repaired_candidate: %s; %s", actions, "; ".join(hl.violations) or "healthy")
    return Repaired(*state, health=hl, actions=actions)


# ----------------------------------------------------------------------------------------------
# topology: dissolve valence-2 vertices, drop boundary triangles


def _face_lists(F: np.ndarray) -> list:
    sizes = face_sizes(F)
    return [row[:k].tolist() for row, k in zip(F, sizes)]


def _dissolve_valence_two(Vc, Fc, tri, bary, grid):
    """Merge the two faces around every interior vertex of valence 2 into one polygon without it (one vertex per
    face per call). Returns the new state and the number of vertices dissolved."""
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    val = np.bincount(topo.E.ravel(), minlength=nv)
    lonely = np.nonzero((val == 2) & ~onb)[0]
    if not len(lonely):
        return (Vc, Fc, tri, bary, grid), 0
    faces = _face_lists(Fc)
    vf: dict = {}
    for fi, c in enumerate(faces):
        for v in c:
            vf.setdefault(v, []).append(fi)
    dead = np.zeros(len(faces), dtype=bool)
    done = 0
    for v in lonely.tolist():
        fs = vf.get(v, [])
        if len(fs) != 2 or dead[fs].any():
            continue
        merged = _merged_without(faces[fs[0]], faces[fs[1]], v)
        if merged is None:
            continue
        faces[fs[0]] = merged
        dead[fs[1]] = True
        done += 1
    if not done:
        return (Vc, Fc, tri, bary, grid), 0
    F = pad_faces([c for fi, c in enumerate(faces) if not dead[fi]])
    return relabel(Vc, F, tri, bary, grid, np.arange(nv)), done


def _merged_without(a: list, b: list, v: int):
    """The outline of faces ``a`` and ``b`` (sharing the two edges at ``v``) without ``v``, or None."""
    he = {}
    for c in (a, b):
        for i in range(len(c)):
            he[(c[i], c[(i + 1) % len(c)])] = True
    nxt = {}
    for (p, q) in he:
        if (q, p) not in he:
            if p in nxt:
                return None
            nxt[p] = q
    if not nxt or v in nxt:
        return None
    start = next(iter(nxt))
    cyc, w = [start], nxt[start]
    while w != start:
        if w not in nxt or len(cyc) > len(nxt):
            return None
        cyc.append(w)
        w = nxt[w]
    return cyc if len(cyc) == len(nxt) and len(cyc) >= 3 else None


def _dissolve_boundary_corners(state, hl: PanelHealth, min_angle: float):
    """Remove from its face every boundary vertex of valence 2 (a face corner on the outline) whose corner is
    within ``min_angle + 5°`` of straight (at most 5° reflex), when the face is unhealthy or has more than four
    corners (a quad with a straight corner is a triangle, a pentagon with one is a quad). Returns the new state
    and the number removed."""
    Vc, Fc, tri, bary, grid = state
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    val = np.bincount(topo.E.ravel(), minlength=nv)
    lone = onb & (val == 2)
    if not lone.any():
        return state, 0
    faces = _face_lists(Fc)
    bad = (hl.face_defects & _SHAPE_BITS) != 0
    straight = 180.0 - min_angle - _MARGIN
    done = 0
    for fi, c in enumerate(faces):
        k = len(c)
        if k < 4 or not (bad[fi] or k > 4):
            continue
        theta = _signed_corners(Vc[c])
        for i, v in enumerate(c):
            if lone[v] and straight <= theta[i] <= 180.0 + _MARGIN:  # further reflex: the chord leaves the surface
                faces[fi] = c[:i] + c[i + 1:]
                done += 1
                break
    if not done:
        return state, 0
    return relabel(Vc, pad_faces(faces), tri, bary, grid, np.arange(nv)), done


def _signed_corners(P: np.ndarray, N: np.ndarray | None = None) -> np.ndarray:
    """Corner angles (degrees) of the polygon ``P (k, 3)``, ``360° − θ`` where a corner turns against the normal
    ``N`` (default: the polygon's Newell normal), as :func:`components.core.measures.nonconvex_faces` has it."""
    O = P[0]
    Q = P - O
    Pn, Pp = np.roll(Q, -1, axis=0), np.roll(Q, 1, axis=0)
    if N is None:
        N = np.cross(Q, Pn).sum(axis=0)
    a, b = Pp - Q, Pn - Q
    ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))
    return np.where(np.cross(Q - Pp, Pn - Q) @ N > 0, ang, 360.0 - ang)


def _rotated_edges(state, hl: PanelHealth):
    """Rotate the edge between an unhealthy quad and a neighbouring quad: of the three ways to cut their hexagon
    into two quads, take the one with the best worst corner when it opens the worst corner by 5° or more (no
    interior vertex left with fewer than three edges, no edge doubled). Returns the new state and the number of
    edges rotated."""
    Vc, Fc, tri, bary, grid = state
    bad = (hl.face_defects & _SHAPE_BITS) != 0
    sizes = face_sizes(Fc)
    if not (bad & (sizes == 4)).any():
        return state, 0
    faces = _face_lists(Fc)
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    val = np.bincount(topo.E.ravel(), minlength=nv)
    edges = {(int(a), int(b)) for a, b in topo.E}
    owner = {}
    for fi, c in enumerate(faces):
        for i in range(len(c)):
            owner[(c[i], c[(i + 1) % len(c)])] = fi
    used = np.zeros(len(faces), dtype=bool)
    done = 0
    worst = np.minimum(hl.min_corner, 180.0 - hl.max_corner)
    for f in np.argsort(worst, kind="stable").tolist():
        if not bad[f] or sizes[f] != 4 or used[f]:
            continue
        best = None
        for i in range(4):
            a, b = faces[f][i], faces[f][(i + 1) % 4]
            g = owner.get((b, a))
            if g is None or used[g] or sizes[g] != 4:
                continue
            cf, cg = faces[f], faces[g]
            p, q = cf[(i + 2) % 4], cf[(i + 3) % 4]
            j = cg.index(b)
            r, s_ = cg[(j + 2) % 4], cg[(j + 3) % 4]
            H = [b, p, q, a, r, s_]
            if len(set(H)) != 6:
                continue
            N = np.cross(Vc[H] - Vc[H[0]], np.roll(Vc[H], -1, axis=0) - Vc[H[0]]).sum(axis=0)
            now = min(_margin(Vc[cf], N), _margin(Vc[cg], N))
            for u, w, A, B in ((p, r, [p, q, a, r], [r, s_, b, p]), (q, s_, [q, a, r, s_], [s_, b, p, q])):
                if (min(u, w), max(u, w)) in edges:
                    continue
                if any(not onb[x] and val[x] - 1 < 3 for x in (a, b)):
                    continue
                m = min(_margin(Vc[A], N), _margin(Vc[B], N))
                if m > now + _MARGIN and (best is None or m > best[0]):
                    best = (m, g, A, B, (a, b), (u, w))
        if best is None:
            continue
        _, g, A, B, (a, b), (u, w) = best
        faces[f], faces[g] = A, B
        used[[f, g]] = True
        edges.discard((min(a, b), max(a, b)))
        edges.add((min(u, w), max(u, w)))
        val[[a, b]] -= 1
        val[[u, w]] += 1
        done += 1
    if not done:
        return state, 0
    return (Vc, pad_faces(faces), tri, bary, grid), done


def _margin(P: np.ndarray, N: np.ndarray) -> float:
    """Worst corner margin (degrees) of the polygon ``P``: ``min(θ, 180° − θ)`` over its signed corners."""
    t = _signed_corners(P, N)
    return float(np.minimum(t, 180.0 - t).min())


def _split_bad_faces(state, hl: PanelHealth, min_angle: float):
    """Split every unhealthy polygon of four or more corners whose worst corner is reflex or over
    ``180° − min_angle`` by the diagonal from that corner that leaves the best worst corner in the two pieces,
    when that opens the worst corner by 5° or more (a quad and a triangle from a pentagon, two triangles from a
    quad; the smoothing of the next pass evens out the pieces). Returns the new state and the number of faces
    split."""
    Vc, Fc, tri, bary, grid = state
    bad = np.nonzero((hl.face_defects & _SHAPE_BITS) != 0)[0]
    if not len(bad):
        return state, 0
    faces = _face_lists(Fc)
    out, done = [], 0
    for fi, c in enumerate(faces):
        k = len(c)
        if k < 4 or fi not in set(bad.tolist()):
            out.append(c)
            continue
        N = np.cross(Vc[c] - Vc[c[0]], np.roll(Vc[c], -1, axis=0) - Vc[c[0]]).sum(axis=0)
        theta = _signed_corners(Vc[c], N)
        i = int(np.argmax(theta))
        if theta[i] <= 180.0 - min_angle:
            out.append(c)
            continue
        best, pieces = min(np.minimum(theta, 180.0 - theta)), None
        for step in range(2, k - 1):
            j = (i + step) % k
            A = [c[(i + r) % k] for r in range(step + 1)]
            B = [c[(j + r) % k] for r in range(k - step + 1)]
            m = min(min(np.minimum(t, 180.0 - t)) for t in (_signed_corners(Vc[A], N), _signed_corners(Vc[B], N)))
            if m > best + _MARGIN:
                best, pieces = m, (A, B)
        if pieces is None:
            out.append(c)
            continue
        out.extend(pieces)
        done += 1
    if not done:
        return state, 0
    return (Vc, pad_faces(out), tri, bary, grid), done


def _collapse_remaining(state, hl: PanelHealth):
    """Collapse the short edges :func:`components.fields.extract.collapse_short_edges` kept (two outline corners
    joined by a short boundary edge, e.g. along a jagged boundary), shortest first, one per neighbourhood, where
    the mesh stays manifold; the end that stays is an outline corner, else a boundary vertex, else the first."""
    Vc, Fc, tri, bary, grid = state
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    fixed = _outline_corners(Vc, topo, onb)
    count = {(int(a), int(b)): int(c) for (a, b), c in zip(topo.E, topo.count)}
    nbrs: list = [set() for _ in range(nv)]
    for a, b in topo.E.tolist():
        nbrs[a].add(b)
        nbrs[b].add(a)
    apex: dict = {}
    for c in _face_lists(Fc):
        if len(c) == 3:
            for i in range(3):
                a, b = c[i], c[(i + 1) % 3]
                apex.setdefault((min(a, b), max(a, b)), set()).add(c[(i + 2) % 3])
    rank = fixed.astype(int) * 2 + onb.astype(int)
    lab = np.arange(nv)
    touched = np.zeros(nv, dtype=bool)
    for a, b in hl.short_edges.tolist():
        key = (min(a, b), max(a, b))
        if touched[a] or touched[b] or key not in count:
            continue
        if onb[a] and onb[b] and count[key] != 1:
            continue
        if nbrs[a] & nbrs[b] != apex.get(key, set()):
            continue
        keep, gone = (a, b) if rank[a] >= rank[b] else (b, a)
        lab[gone] = keep
        touched[list(nbrs[a] | nbrs[b] | {a, b})] = True
    if (lab == np.arange(nv)).all():
        return state
    return relabel(Vc, Fc, tri, bary, grid, lab)


def _drop_bad_boundary_triangles(state, hl: PanelHealth):
    """Remove the unhealthy triangles whose corners all lie on the boundary where the mesh stays manifold (no
    vertex where two boundary loops would touch): the candidate's boundary stays on the surface's boundary.
    Returns the new state and the number removed."""
    Vc, Fc, tri, bary, grid = state
    sizes = face_sizes(Fc)
    topo = edge_topology(Fc)
    onb = np.zeros(len(Vc), dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    allb = onb[Fc].all(axis=1)  # padding repeats a corner: the padded row has the same corners
    cand = np.nonzero((sizes == 3) & allb & ((hl.face_defects & _SHAPE_BITS) != 0))[0]
    if not len(cand) or len(Fc) - len(cand) < 1:
        return state, 0
    keep = np.ones(len(Fc), dtype=bool)
    for f in cand.tolist():
        keep[f] = False
        t = edge_topology(Fc[keep])
        nb = np.bincount(t.E[t.count == 1].ravel(), minlength=len(Vc))
        if np.any(nb > 2):
            keep[f] = True
    if keep.all():
        return state, 0
    return relabel(Vc, Fc[keep], tri, bary, grid, np.arange(len(Vc))), int((~keep).sum())


# ----------------------------------------------------------------------------------------------
# smoothing on the surface


class _Local(NamedTuple):
    """The faces around one vertex, indexed into its local vertex list."""

    verts: np.ndarray  # (l,) global vertices; verts[0] is the moving one
    corner: np.ndarray  # (c,) local vertex of each corner
    prev: np.ndarray  # (c,) local vertex before it in its face
    nxt: np.ndarray  # (c,) local vertex after it
    cface: np.ndarray  # (c,) local face of each corner
    normal: np.ndarray  # (f, 3) surface normal of each face
    edges: np.ndarray  # (e, 2) local edges of the faces


def _local(v: int, fs: list, faces: list, normal: np.ndarray) -> _Local:
    verts = [v] + sorted({w for f in fs for w in faces[f]} - {v})
    pos = {w: i for i, w in enumerate(verts)}
    corner, prev, nxt, cface, edges = [], [], [], [], set()
    for j, f in enumerate(fs):
        c = [pos[w] for w in faces[f]]
        k = len(c)
        for i in range(k):
            corner.append(c[i])
            prev.append(c[i - 1])
            nxt.append(c[(i + 1) % k])
            cface.append(j)
            edges.add((min(c[i], c[(i + 1) % k]), max(c[i], c[(i + 1) % k])))
    arr = lambda x: np.asarray(x, dtype=np.int64)  # noqa: E731
    return _Local(arr(verts), arr(corner), arr(prev), arr(nxt), arr(cface), normal[fs],
                  arr(sorted(edges)).reshape(-1, 2))


def _scores(P: np.ndarray, loc: _Local):
    """For candidate local positions ``P (s, l, 3)``: the worst corner margin (degrees; ``min(θ, 180° − θ)`` with
    ``θ`` the corner angle, taken as ``360° − θ`` where the corner turns against its face's Newell normal, as
    :func:`components.core.measures.nonconvex_faces` has it, so reflex corners are negative; −180° for a face
    flipped against the surface), edge lengths ``(s, e)`` and face areas ``(s, f)`` (negative when flipped)."""
    nf = len(loc.normal)
    O = P[:, :1]  # about the moving vertex: no cancellation far from the origin
    pc, pp, pn = P[:, loc.corner] - O, P[:, loc.prev] - O, P[:, loc.nxt] - O
    N = np.zeros((len(P), nf, 3))
    np.add.at(N, (slice(None), loc.cface), np.cross(pc, pn))
    a, b = pp - pc, pn - pc
    ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=2), np.einsum("scj,scj->sc", a, b)))
    convex = np.einsum("scj,scj->sc", np.cross(pc - pp, pn - pc), N[:, loc.cface]) > 0
    theta = np.where(convex, ang, 360.0 - ang)
    margin = np.minimum(theta, 180.0 - theta)
    side = np.einsum("sfj,fj->sf", N, loc.normal)
    margin = np.where(side[:, loc.cface] > 0, margin, -180.0).min(axis=1)
    L = np.linalg.norm(P[:, loc.edges[:, 1]] - P[:, loc.edges[:, 0]], axis=2)
    area = 0.5 * np.linalg.norm(N, axis=2) * np.where(side > 0, 1.0, -1.0)
    return margin, L, area


def _smoothed(state, hl: PanelHealth, FN: np.ndarray, index, bc, bounds):
    """Smart smoothing of the vertices of the unhealthy faces (see the module notes): the new state and the number
    of moves kept."""
    Vc, Fc, tri, bary, grid = state
    min_edge_ratio, min_angle, min_area_ratio = bounds
    bad = ((hl.face_defects & _SHAPE_BITS) != 0) | _near_bounds(hl, min_angle)
    if not bad.any():
        return state, 0
    L_min = _SLACK * min_edge_ratio * hl.median_edge  # with room for the planarization (and the median's drift)
    A_min = _SLACK * min_area_ratio * hl.median_area
    faces = _face_lists(Fc)
    nv = len(Vc)
    vf: list = [[] for _ in range(nv)]
    for fi, c in enumerate(faces):
        for v in c:
            vf[v].append(fi)
    topo = edge_topology(Fc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    fixed = _outline_corners(Vc, topo, onb)
    nbrs: list = [[] for _ in range(nv)]
    for a, b in topo.E.tolist():
        nbrs[a].append(b)
        nbrs[b].append(a)
    X, tri, bary = Vc.copy(), tri.copy(), bary.copy()
    active = np.zeros(nv, dtype=bool)
    for f in np.nonzero(bad)[0]:
        active[faces[f]] = True
    active &= ~fixed
    moved = 0
    goal = min_angle + _MARGIN
    for _ in range(_SWEEPS):
        cand = np.nonzero(active)[0]
        if not len(cand):
            break
        normal = _face_normals(Fc, FN, tri)
        locs = {v: _local(v, vf[v], faces, normal) for v in cand.tolist()}
        cur = {v: _scores(X[locs[v].verts][None], locs[v]) for v in locs}
        order = sorted(locs, key=lambda v: (_quantized(cur[v][0][0]), v))
        taken = np.zeros(nv, dtype=bool)
        any_move = False
        # every vertex's trials at once (one closest-point query): a vertex is tried only while no vertex of its
        # faces has moved in this sweep (a move takes the whole star), so its trials are those of the sweep's start
        trials = _trial_batch([v for v in order if _quantized(cur[v][0][0]) < goal], X, faces, vf, nbrs, onb,
                              index, bc)
        for v in order:
            if taken[v] or _quantized(cur[v][0][0]) >= min_angle + _MARGIN:
                continue
            Y, t_, b_ = trials[v]
            loc = locs[v]
            P = np.repeat(X[loc.verts][None], len(Y), axis=0)
            P[:, 0] = Y
            m0, L0, A0 = cur[v]
            m, L, A = _scores(P, loc)
            ok = (L >= np.minimum(L_min, L0)).all(axis=1) & (A >= np.minimum(A_min, A0)).all(axis=1)
            # the best worst corner, counted up to the bound plus 5°; of equals the shortest move (the net stays
            # as conjugate as it can: a long move spoils the planarity the planarization has to restore)
            m = np.where(ok, np.minimum(_quantized(m), goal), -np.inf)
            j = int(np.lexsort((np.linalg.norm(Y - X[v], axis=1), -m))[0])
            if m[j] > _quantized(m0[0]):
                X[v], tri[v], bary[v] = Y[j], t_[j], b_[j]
                taken[loc.verts] = True
                moved += 1
                any_move = True
        if not any_move:
            break
    return (X, Fc, tri, bary, grid), moved


def _quantized(margin):
    """Corner margins rounded to :data:`_QUANTUM` degrees: the smoothing compares and orders these, so the last
    bits of the input (its units, its placement) do not change which move wins."""
    return np.round(np.asarray(margin) / _QUANTUM) * _QUANTUM


def _near_bounds(hl: PanelHealth, min_angle: float) -> np.ndarray:
    """``(m,) bool``: faces with a corner within 5° of the corner bounds (or beyond them)."""
    return (hl.min_corner < min_angle + _MARGIN) | (hl.max_corner > 180.0 - min_angle - _MARGIN)


def _face_normals(Fc: np.ndarray, FN: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Unit surface normal of every face (padded ``Fc``): the mean of the input normals under its corners (summed
    corner by corner, in the faces' order)."""
    k = face_sizes(Fc)
    out = FN[tri[Fc[:, 0]]]
    for j in range(1, Fc.shape[1]):
        has = k > j
        out = np.where(has[:, None], out + FN[tri[np.where(has, Fc[:, j], Fc[:, 0])]], out)
    return out / np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-300)


def _outline_corners(Vc, topo, onb) -> np.ndarray:
    """Boundary vertices where the candidate's outline turns by more than 30° (or that are not on one simple
    loop): they stay put."""
    nv = len(Vc)
    be = topo.E[topo.count == 1]
    deg = np.bincount(be.ravel(), minlength=nv)
    fixed = onb & (deg != 2)
    nb: list = [[] for _ in range(nv)]
    for a, b in be.tolist():
        nb[a].append(b)
        nb[b].append(a)
    for v in np.nonzero(onb & (deg == 2))[0].tolist():
        d1 = Vc[v] - Vc[nb[v][0]]
        d2 = Vc[nb[v][1]] - Vc[v]
        c = d1 @ d2 / max(float(np.linalg.norm(d1) * np.linalg.norm(d2)), 1e-300)
        fixed[v] = c < np.cos(_SHARP_TURN)
    return fixed


def _trial_points(v: int, X, faces: list, vf: list, nbrs: list) -> np.ndarray:
    """Positions to try for vertex ``v`` (before they are put back on the surface)."""
    targets = [X[nbrs[v]].mean(axis=0)]
    para, cents = [], []
    for f in vf[v]:
        c = faces[f]
        k = len(c)
        i = c.index(v)
        others = [w for w in c if w != v]
        cents.append(X[others].mean(axis=0))
        if k == 4:
            para.append(X[c[(i + 1) % 4]] + X[c[(i + 3) % 4]] - X[c[(i + 2) % 4]])
    if para:
        targets.append(np.mean(para, axis=0))
    targets.append(np.mean(cents, axis=0))
    x = X[v]
    Y = [x + t * (g - x) for g in targets for t in _STEPS]
    # and a ring of small moves in the tangent plane (the normal of the faces around)
    n = np.cross(X[nbrs[v]] - x, np.roll(X[nbrs[v]], -1, axis=0) - x).sum(axis=0)
    d = X[nbrs[v]] - x
    e1 = d[np.argmax(np.linalg.norm(d, axis=1))]
    e1 = e1 - n * (e1 @ n) / max(float(n @ n), 1e-300)
    e1 /= max(float(np.linalg.norm(e1)), 1e-300)
    e2 = np.cross(n, e1)
    e2 /= max(float(np.linalg.norm(e2)), 1e-300)
    r = float(np.linalg.norm(d, axis=1).min())
    for a in np.arange(_RING) * (2.0 * np.pi / _RING):
        for t in _RADII:
            Y.append(x + t * r * (np.cos(a) * e1 + np.sin(a) * e2))
    return np.asarray(Y)


def _trial_batch(vs: list, X, faces: list, vf: list, nbrs: list, onb, index, bc) -> dict:
    """Positions to try for every vertex of ``vs``, put back on the surface (on the boundary for boundary
    vertices): ``{v: (points, triangles, barycentric coordinates)}``. One closest-point query for all interior
    vertices and one for the boundary ones (a point's closest point does not depend on the others)."""
    Ys = [_trial_points(v, X, faces, vf, nbrs) for v in vs]
    out = {}
    for on_boundary in (True, False):
        idx = [i for i, v in enumerate(vs) if bool(onb[v]) == on_boundary]
        if not idx:
            continue
        P = np.concatenate([Ys[i] for i in idx])
        if on_boundary:
            pts, tri, bary = closest_on_boundary(P, bc)
        else:
            q = index.query(P)
            pts, tri, bary = q.points, q.faces, q.barycentric
        ends = np.cumsum([len(Ys[i]) for i in idx])
        for i, b, e in zip(idx, ends - [len(Ys[i]) for i in idx], ends):
            out[vs[i]] = (pts[b:e], tri[b:e], bary[b:e])
    return out
