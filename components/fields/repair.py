"""Panel health of the candidate: what makes a candidate quad mesh unfabricable, repaired before planarization.

The extraction (:mod:`components.fields.extract`) leaves a few panels that no planarization can make fabricable:
an interior vertex of valence 2 (two faces folded onto each other, or a quad with a 170° corner), a quad pinched
to a triangle near a singularity (a corner over 160°), a bow-tie where the parametrization folded, a corner under
20° where snapped boundary vertices met, an edge a fraction of the median. :func:`repaired_candidate` measures the
candidate with :func:`components.metrics.health.face_health` (shape checks at the health bounds: corners in
``[20°, 160°]``, edges over 0.2 × the median, faces over 0.1 × the median area, convex, not flipped against the
surface, not folded or crossing) and repairs, pass by pass, until it is healthy or nothing changes:

0. *weld* every pinch of the outline (a vertex with two boundary edges leaving it, or two boundary corners touching
   without an edge between them: the snapping sends two grid vertices onto the tip of a spike of the outline)
   whose pocket is short, and close the pocket with a face (the planarizer cannot take a pinched mesh);
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
5. *drop* a triangle or quad that is still unhealthy and has all its corners on the boundary (a sliver along the
   outline, a quad pinched or folded in a bend of it), where the mesh stays manifold without it;
6. when a pass changes nothing, or the last one leaves defects, *collapse* the chord of every quad or triangle
   still beyond the corner bounds or too small: the shorter diagonal of a quad whose two obtuse corners face each
   other, the shortest edge of a triangle (a sliver between two as thin: opening it by a smoothing move closes a
   neighbour), and smooth around the merged vertices in up to two more passes (on the 200k-triangle benchmark
   patch the best-ranked candidate kept a 19.5° sliver beside a 20.3° one without this step); the last pass also
   drops the unhealthy pentagons with four or five corners on the boundary.

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

from components.core.measures import cross
from components.core.mesh import edge_topology, face_sizes, halfedges
from components.core.proximity import TriangleIndex
from components.fields.extract import (
    boundary_curve,
    closest_on_boundary,
    collapse_short_edges,
    drop_keeping_manifold,
    relabel,
)
from components.metrics.health import DEFECT_BITS, TOUCH, PanelHealth, face_health, touching_pairs

log = logging.getLogger(__name__)

__all__ = ["Repaired", "candidate_health", "close_pinches", "repaired_candidate"]

_STEPS = (1.0, 0.5, 0.25, 0.1)  # fractions of the way to each smoothing target
_RING = 8  # directions of the small tangent moves tried besides the targets
_RADII = (0.05, 0.15, 0.3)  # their lengths, × the vertex's shortest edge
_SWEEPS = 20  # smoothing sweeps per pass (each moves a vertex at most once; most stop after a few)
_BATCH = 512  # vertices whose trials are scored together (bounds the temporary arrays)
_PASSES = 4  # repair passes (each: dissolve, collapse, smooth, drop)
_SLIVER_PASSES = 2  # passes added after the last one to smooth around collapsed slivers
_SHARP_TURN = np.radians(30.0)  # a boundary vertex where the candidate's outline turns more than this stays put
_MARGIN = 5.0  # degrees: the smoothing keeps improving a vertex's worst corner up to the bound plus this
_QUANTUM = 0.01  # degrees: corner margins are compared at this resolution (see _quantized)
_SLACK = 1.25  # a smoothing move may not take an edge (a face) under this × its bound, unless it already was
_QUAD_CHORD = 0.75  # a sliver quad's short diagonal collapsed up to this share of its longest edge (_chord_limit)
_TRIANGLE_CHORD = 0.6  # ... a triangle's shortest edge (any length when the triangle is under the area bound)
_POCKET = 3  # boundary vertices at most between two touching boundary corners whose pocket is closed by a face
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
        Repair passes at most (and up to two more after a sliver collapse, see the module notes).

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
    FN = cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    FN /= np.maximum(np.linalg.norm(FN, axis=1, keepdims=True), 1e-300)
    bounds = (min_edge_ratio, min_angle, min_area_ratio)
    actions = dict(welded=0, dissolved=0, collapsed=0, smoothed=0, rotated=0, split=0, dropped=0)
    state = (Vc, Fc, tri, bary, grid)

    def check(st):
        return candidate_health(st[0], st[1], min_edge_ratio=min_edge_ratio, min_angle=min_angle,
                                min_area_ratio=min_area_ratio)

    hl = check(state)
    budget, done = max(int(passes), 0), 0
    while done < budget:
        done += 1
        if not ((hl.face_defects & _SHAPE_BITS).any() or _near_bounds(hl, min_angle).any()) or len(state[1]) < 2:
            break
        before = (len(state[0]), len(state[1]), hl.face_defects.copy(), hl.worst_corner)
        state, k = _closed_pockets(state, hl)
        actions["welded"] += k
        if k:
            hl = check(state)
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
        state, k = _drop_bad_boundary_faces(state, hl)
        actions["dropped"] += k
        if k:
            hl = check(state)
        stuck = ((len(state[0]), len(state[1])) == before[:2] and np.array_equal(hl.face_defects, before[2])
                 and hl.worst_corner == before[3])
        last = done == budget and bool((hl.face_defects & _SHAPE_BITS).any())
        if stuck or last:
            # stuck, or the last pass still left defects: the slivers no step above opened (a thin face between two
            # as thin, or one the last pass made) lose a chord, the next pass smooths around them
            state, k = _collapsed_slivers(state, hl, index, min_angle)
            if k:
                actions["collapsed"] += k
                hl = check(state)
            if last:  # and the pentagons still unhealthy in a bend of the outline go, like its triangles and quads
                state, dropped = _drop_bad_boundary_faces(state, hl, pentagons=True)
                if dropped:
                    actions["dropped"] += dropped
                    hl = check(state)
                k += dropped
            if not k:
                break
            if done == budget and budget < max(int(passes), 0) + _SLIVER_PASSES:
                budget += 1  # a pass to smooth around the merged vertices
    log.debug("repaired_candidate: %s; %s", actions, "; ".join(hl.violations) or "healthy")
    return Repaired(*state, health=hl, actions=actions)


# ----------------------------------------------------------------------------------------------
# topology: dissolve valence-2 vertices, drop boundary triangles


def _face_lists(F: np.ndarray) -> list:
    return [row[:k] for row, k in zip(F.tolist(), face_sizes(F).tolist())]


def _face_rows(F: np.ndarray, rows, sizes: np.ndarray) -> dict:
    """``{row: corners}`` of the given rows of the padded faces ``F`` (``sizes`` their :func:`face_sizes`), in the
    order of ``rows``."""
    rows = np.asarray(rows, dtype=np.int64)
    return {r: c[:k] for r, c, k in zip(rows.tolist(), F[rows].tolist(), sizes[rows].tolist())}


def _replaced(F: np.ndarray, repl: dict, sizes: np.ndarray) -> np.ndarray:
    """The padded faces ``F`` with every row ``r`` of ``repl`` replaced by the faces ``repl[r]`` (a list of corner
    lists, empty to drop the row), in its place: what :func:`components.core.mesh.pad_faces` makes of the face
    list with those replacements, without touching the other rows one by one."""
    m = len(F)
    cnt = np.ones(m, dtype=np.int64)
    for r, fs in repl.items():
        cnt[r] = len(fs)
    rest = np.ones(m, dtype=bool)
    rest[list(repl)] = False
    K = max([3] + [len(c) for fs in repl.values() for c in fs] + ([int(sizes[rest].max())] if rest.any() else []))
    src = np.repeat(np.arange(m), cnt)
    out = np.empty((len(src), K), dtype=np.int64)
    w = min(K, F.shape[1])
    out[:, :w] = F[src, :w]
    if K > w:
        out[:, w:] = F[src, w - 1:w]  # the padding repeats the last corner
    start = np.cumsum(cnt) - cnt
    for r, fs in repl.items():
        for i, c in enumerate(fs):
            out[start[r] + i, :len(c)] = c
            out[start[r] + i, len(c):] = c[-1]
    return out


def _closed_pockets(state, hl: PanelHealth):
    """Weld every pinch of the outline whose pocket is short, and close the pocket with a face.

    A pinch is a vertex with two boundary edges leaving it, or two boundary corners touching (within
    :data:`components.metrics.health.TOUCH` × the median edge) without an edge between them: the boundary snapping
    sends two grid vertices to the same point where the outline has a sharp spike (a staircase hole cut along a
    triangulation's edges), and the planarizer cannot take such a mesh (welded, the vertex joins two fans). Where
    the outline runs from one corner to the other through at most :data:`_POCKET` vertices, the corners are welded
    and the pocket between them becomes a face (one vertex between them: its two edges are zipped into one).
    Returns the new state and the number of pinches welded (others are left; the health check names them)."""
    Vc, Fc, tri, bary, grid = state
    if not hl.counts["nonmanifold"] or len(Fc) < 2:
        return state, 0
    topo = edge_topology(Fc)
    H, _ = halfedges(Fc)
    nxt: dict = {}
    for a, b in H[topo.count[topo.HE] == 1].tolist():
        nxt.setdefault(a, []).append(b)
    # the pairs: welded pinches (a vertex twice) and touching corners
    pairs = [(v, v) for v, out in nxt.items() if len(out) > 1]
    pairs += [tuple(p) for p in touching_pairs(Vc, topo, TOUCH * hl.median_edge).tolist()]
    nv = len(Vc)
    lab = np.arange(nv)
    used: set = set()
    pockets = []
    done = 0
    for a, b in sorted(pairs):
        if a in used or b in used:
            continue
        path = _pocket(nxt, a, b) or (_pocket(nxt, b, a) if a != b else None)
        if path is None:
            continue
        if path[0] != a:
            a, b = b, a
        mid = path[1:]
        used.update([a, b, *mid])
        lab[b] = a
        done += 1
        if len(mid) >= 2:
            pockets.append([a] + mid[::-1])  # the twins of the pocket's boundary edges: oriented as its neighbours
    if not done:
        return state, 0
    K = max([Fc.shape[1]] + [len(c) for c in pockets])
    rows = [np.pad(Fc, ((0, 0), (0, K - Fc.shape[1])), mode="edge")] if K > Fc.shape[1] else [Fc]
    rows += [np.array([c + [c[-1]] * (K - len(c))], dtype=np.int64) for c in pockets]
    log.debug("repair: %d pinched corners welded, %d pockets closed", done, len(pockets))
    return relabel(Vc, np.concatenate(rows), tri, bary, grid, lab), done


def close_pinches(Vc, Fc):
    """A quad net ``(Vc, Fc)`` with its short pinches welded and their pockets closed (see :func:`_closed_pockets`):
    ``(V, F, welded)``, the unused vertices dropped.

    >>> from components.core.mesh import pad_faces, quad_grid
    >>> V, Q = quad_grid(3, 2, 3.0, 2.0)
    >>> V[10] = V[9] = [1.5, 2.0, 0.0]  # a notch's two top corners moved together: two quads touch there
    >>> F = pad_faces([r for r in Q.tolist() if set(r) != {5, 6, 10, 9}])
    >>> X, G, k = close_pinches(V, F)
    >>> k, len(G), len(X), candidate_health(X, G).healthy
    (1, 6, 11, True)
    """
    n = len(Vc)
    state = (Vc, Fc, np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.ones(n, dtype=bool))
    (V, F, *_), k = _closed_pockets(state, candidate_health(Vc, Fc))
    return V, F, k


def _pocket(nxt: dict, a: int, b: int):
    """The outline from ``a`` to ``b`` (along the boundary edges, ``nxt``: their successors) through at most
    :data:`_POCKET` vertices with one successor each: ``[a, ..., b)`` without ``b``, or None."""
    for s in nxt.get(a, []):
        path, cur = [a], s
        for _ in range(_POCKET + 1):
            if cur == b:
                return path
            if cur == a or len(nxt.get(cur, [])) != 1:
                break
            path.append(cur)
            cur = nxt[cur][0]
    return None


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
    sizes = face_sizes(Fc)
    faces = _face_rows(Fc, np.nonzero(np.isin(Fc, lonely).any(axis=1))[0], sizes)  # the faces around them
    vf: dict = {}
    for fi, c in faces.items():
        for v in c:
            vf.setdefault(v, []).append(fi)
    dead = np.zeros(len(Fc), dtype=bool)
    repl: dict = {}
    done = 0
    for v in lonely.tolist():
        fs = vf.get(v, [])
        if len(fs) != 2 or dead[fs].any():
            continue
        merged = _merged_without(faces[fs[0]], faces[fs[1]], v)
        if merged is None:
            continue
        faces[fs[0]] = merged
        repl[fs[0]] = [merged]
        dead[fs[1]] = True
        done += 1
    if not done:
        return (Vc, Fc, tri, bary, grid), 0
    for f in np.nonzero(dead)[0].tolist():
        repl[f] = []
    return relabel(Vc, _replaced(Fc, repl, sizes), tri, bary, grid, np.arange(nv)), done


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
    bad = (hl.face_defects & _SHAPE_BITS) != 0
    sizes = face_sizes(Fc)
    rows = np.nonzero((sizes >= 4) & (bad | (sizes > 4)) & lone[Fc].any(axis=1))[0]
    straight = 180.0 - min_angle - _MARGIN
    repl: dict = {}
    for fi, c in _face_rows(Fc, rows, sizes).items():
        theta = _signed_corners(Vc[c])
        for i, v in enumerate(c):
            if lone[v] and straight <= theta[i] <= 180.0 + _MARGIN:  # further reflex: the chord leaves the surface
                repl[fi] = [c[:i] + c[i + 1:]]
                break
    if not repl:
        return state, 0
    return relabel(Vc, _replaced(Fc, repl, sizes), tri, bary, grid, np.arange(nv)), len(repl)


def _signed_corners(P: np.ndarray, N: np.ndarray | None = None) -> np.ndarray:
    """Corner angles (degrees) of the polygon ``P (k, 3)``, ``360° − θ`` where a corner turns against the normal
    ``N`` (default: the polygon's Newell normal), as :func:`components.core.measures.nonconvex_faces` has it."""
    O = P[0]
    Q = P - O
    Pn, Pp = np.roll(Q, -1, axis=0), np.roll(Q, 1, axis=0)
    if N is None:
        N = cross(Q, Pn).sum(axis=0)
    a, b = Pp - Q, Pn - Q
    ang = np.degrees(np.arctan2(np.linalg.norm(cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))
    return np.where(cross(Q - Pp, Pn - Q) @ N > 0, ang, 360.0 - ang)


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
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    val = np.bincount(topo.E.ravel(), minlength=nv)
    # only the unhealthy quads and the faces across their edges take part: their half-edges, edges and corners
    H, HF = halfedges(Fc)  # face by face, corner by corner
    bq = (bad & (sizes == 4))[HF]
    key = H[:, 0] * nv + H[:, 1]
    across = np.isin(key, H[bq, 1] * nv + H[bq, 0])
    owner = dict(zip(map(tuple, H[across].tolist()), HF[across].tolist()))
    faces = _face_rows(Fc, np.unique(np.concatenate([HF[bq], HF[across]])), sizes)
    near = np.zeros(nv, dtype=bool)
    near[[v for c in faces.values() for v in c]] = True
    edges = set(map(tuple, topo.E[near[topo.E[:, 0]] & near[topo.E[:, 1]]].tolist()))
    used = np.zeros(len(Fc), dtype=bool)
    repl: dict = {}
    done = 0
    worst = np.minimum(hl.min_corner, 180.0 - hl.max_corner)
    order = np.argsort(worst, kind="stable")
    for f in order[bad[order] & (sizes[order] == 4)].tolist():
        if used[f]:
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
            N = cross(Vc[H] - Vc[H[0]], np.roll(Vc[H], -1, axis=0) - Vc[H[0]]).sum(axis=0)
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
        repl[f], repl[g] = [A], [B]
        used[[f, g]] = True
        edges.discard((min(a, b), max(a, b)))
        edges.add((min(u, w), max(u, w)))
        val[[a, b]] -= 1
        val[[u, w]] += 1
        done += 1
    if not done:
        return state, 0
    return (Vc, _replaced(Fc, repl, sizes), tri, bary, grid), done


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
    sizes = face_sizes(Fc)
    repl: dict = {}
    for fi, c in _face_rows(Fc, bad[sizes[bad] >= 4], sizes).items():
        k = len(c)
        N = cross(Vc[c] - Vc[c[0]], np.roll(Vc[c], -1, axis=0) - Vc[c[0]]).sum(axis=0)
        theta = _signed_corners(Vc[c], N)
        i = int(np.argmax(theta))
        if theta[i] <= 180.0 - min_angle:
            continue
        best, pieces = min(np.minimum(theta, 180.0 - theta)), None
        for step in range(2, k - 1):
            j = (i + step) % k
            A = [c[(i + r) % k] for r in range(step + 1)]
            B = [c[(j + r) % k] for r in range(k - step + 1)]
            m = min(min(np.minimum(t, 180.0 - t)) for t in (_signed_corners(Vc[A], N), _signed_corners(Vc[B], N)))
            if m > best + _MARGIN:
                best, pieces = m, (A, B)
        if pieces is not None:
            repl[fi] = list(pieces)
    if not repl:
        return state, 0
    return (Vc, _replaced(Fc, repl, sizes), tri, bary, grid), len(repl)


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


def _collapsed_slivers(state, hl: PanelHealth, index, min_angle: float):
    """Collapse the chord of every quad or triangle still unhealthy with a corner beyond the bounds or too small
    an area (a sliver no smoothing opened: moving a corner to open it closes a neighbour as thin): the shorter
    diagonal of a quad whose two obtuse corners face each other (the quad vanishes, its neighbours keep their
    corners), the shortest edge of a triangle (a quad across it becomes a triangle). Its two ends merge where the
    mesh stays manifold (their common neighbours are the quad's other two corners, or the third corners of the
    triangles on the edge; not both on the boundary unless the chord is a boundary edge), at an outline corner or
    boundary vertex among them, else at the surface point closest to their midpoint. The chord is at most
    :func:`_chord_limit` of the face's longest edge. One sliver per neighbourhood per call. Returns the new state
    and the number of vertices merged away."""
    Vc, Fc, tri, bary, grid = state
    sizes = face_sizes(Fc)
    sliver = ((hl.min_corner < min_angle) | (hl.max_corner > 180.0 - min_angle)
              | ((hl.face_defects & DEFECT_BITS["small"]) != 0))
    bad = np.nonzero(((hl.face_defects & _SHAPE_BITS) != 0) & sliver & (sizes <= 4))[0]
    if not len(bad):
        return state, 0
    topo = edge_topology(Fc)
    nv = len(Vc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    bnd_edges = set(map(tuple, topo.E[topo.count == 1].tolist()))
    fixed = _outline_corners(Vc, topo, onb)
    st = _stars(Fc, topo, nv)

    def nbrs(v):
        return set(st.nb_v[st.nb_ptr[v]:st.nb_ptr[v + 1]].tolist())

    worst = np.minimum(hl.min_corner, 180.0 - hl.max_corner)
    lab = np.arange(nv)
    touched = np.zeros(nv, dtype=bool)
    goals, who = [], []
    for f in bad[np.argsort(worst[bad], kind="stable")].tolist():
        c = Fc[f, :sizes[f]].tolist()
        if touched[c].any():
            continue
        P = Vc[c]
        side = np.linalg.norm(P - np.roll(P, -1, axis=0), axis=1)
        if len(c) == 3:
            i = int(np.argmin(side))
            a, b = c[i], c[(i + 1) % 3]
            chord = side[i]
            apex = set()  # the third corners of the triangles on the edge (a quad on it becomes a triangle)
            for g in st.vf_face[st.vf_ptr[a]:st.vf_ptr[a + 1]].tolist():
                cg = Fc[g, :sizes[g]].tolist()
                if len(cg) == 3 and b in cg:
                    apex.add(next(x for x in cg if x != a and x != b))
            if nbrs(a) & nbrs(b) != apex:
                continue
            if onb[a] and onb[b] and (min(a, b), max(a, b)) not in bnd_edges:
                continue
        else:
            d0, d1 = np.linalg.norm(P[0] - P[2]), np.linalg.norm(P[1] - P[3])
            i = 0 if d0 <= d1 else 1
            a, b = c[i], c[i + 2]
            chord = min(d0, d1)
            t = _signed_corners(P)
            if not (t[i] > 90.0 and t[i + 2] > 90.0) or b in nbrs(a) or (onb[a] and onb[b]):
                continue
            if nbrs(a) & nbrs(b) != {c[(i + 1) % 4], c[(i + 3) % 4]}:
                continue
        if chord > _chord_limit(len(c), bool(hl.face_defects[f] & DEFECT_BITS["small"])) * side.max():
            continue
        keep, gone = (a, b) if (fixed[a], onb[a]) >= (fixed[b], onb[b]) else (b, a)
        lab[gone] = keep
        touched[list(nbrs(a) | nbrs(b) | {a, b})] = True
        if not onb[keep] and not onb[gone]:
            who.append(keep)
            goals.append(0.5 * (Vc[a] + Vc[b]))
    if (lab == np.arange(nv)).all():
        return state, 0
    if who:
        Vc, tri, bary = Vc.copy(), tri.copy(), bary.copy()
        q = index.query(np.asarray(goals))
        Vc[who], tri[who], bary[who] = q.points, q.faces, q.barycentric
    return relabel(Vc, Fc, tri, bary, grid, lab), int(np.count_nonzero(lab != np.arange(nv)))


def _chord_limit(corners: int, small: bool) -> float:
    """The longest chord :func:`_collapsed_slivers` collapses (its faces are slivers by their corners or their area),
    as a share of the face's longest edge. It was half for both; a sliver is one whatever its sides: a quad's short
    diagonal up to :data:`_QUAD_CHORD` (a flat parallelogram along the outline, corners 20° / 160° and sides
    1 : 0.3, has a short diagonal 0.72 of its long side), a triangle's shortest edge up to :data:`_TRIANGLE_CHORD`
    (a cap with two corners under 20° beside an obtuse one has short sides of sin 20° / sin 140° = 0.53 of the long
    one), any edge of a triangle under the area bound (each of its edges is short).

    >>> _chord_limit(4, False), _chord_limit(3, False), _chord_limit(3, True)
    (0.75, 0.6, 1.0)
    """
    if corners == 3:
        return 1.0 if small else _TRIANGLE_CHORD
    return _QUAD_CHORD


def _drop_bad_boundary_faces(state, hl: PanelHealth, pentagons: bool = False):
    """Remove the unhealthy triangles and quads whose corners all lie on the boundary where the mesh stays manifold
    (no vertex where two boundary loops would touch): the candidate's boundary stays on the surface's boundary. (A
    quad wedged in a bend of the outline, pinched non-convex or folded onto its neighbour, was left by the other
    steps on a sixth of the 200k patch's seeds.) With ``pentagons`` (the last pass) also the unhealthy pentagons with
    four or five corners on the boundary (non-convex in a bend of the outline, a corner of 10° or 174°: what kept
    the best-ranked candidates of an 80k-triangle canopy unhealthy). Returns the new state and the number removed."""
    Vc, Fc, tri, bary, grid = state
    sizes = face_sizes(Fc)
    topo = edge_topology(Fc)
    onb = np.zeros(len(Vc), dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    drop = (sizes <= 4) & onb[Fc].all(axis=1)  # padding repeats a corner: the padded row has the same corners
    if pentagons and Fc.shape[1] >= 5:
        drop |= (sizes == 5) & (onb[Fc[:, :5]].sum(axis=1) >= 4)
    cand = np.nonzero(drop & ((hl.face_defects & _SHAPE_BITS) != 0))[0]
    if not len(cand) or len(Fc) - len(cand) < 1:
        return state, 0
    keep = drop_keeping_manifold(Fc, topo, cand, len(Vc))
    if keep.all():
        return state, 0
    return relabel(Vc, Fc[keep], tri, bary, grid, np.arange(len(Vc))), int((~keep).sum())


# ----------------------------------------------------------------------------------------------
# smoothing on the surface


class _Stars(NamedTuple):
    """The faces around every vertex of a candidate (fixed topology), for batched smoothing trials."""

    F: np.ndarray  # (m, k) padded faces
    size: np.ndarray  # (m,) corners per face
    vf_ptr: np.ndarray  # (n + 1,) CSR: the faces around vertex v are vf_face[vf_ptr[v]:vf_ptr[v + 1]] (ascending)
    vf_face: np.ndarray
    vf_slot: np.ndarray  # the corner of v in each of them
    nb_ptr: np.ndarray  # (n + 1,) CSR: the neighbours of v, in the order of their edges in edge_topology
    nb_v: np.ndarray


def _stars(Fc: np.ndarray, topo, nv: int) -> _Stars:
    k = face_sizes(Fc)
    K = Fc.shape[1]
    slot = np.tile(np.arange(K), len(Fc))
    face = np.repeat(np.arange(len(Fc)), K)
    ok = slot < np.repeat(k, K)
    w, face, slot = Fc.ravel()[ok], face[ok], slot[ok]
    order = np.lexsort((face, w))
    vf_ptr = np.searchsorted(w[order], np.arange(nv + 1))
    E = topo.E
    a = np.concatenate([E[:, 0], E[:, 1]])
    b = np.concatenate([E[:, 1], E[:, 0]])
    e = np.concatenate([np.arange(len(E)), np.arange(len(E))])
    o2 = np.lexsort((e, a))
    nb_ptr = np.searchsorted(a[o2], np.arange(nv + 1))
    return _Stars(Fc, k, vf_ptr, face[order], slot[order], nb_ptr, b[o2])


def _segments(ptr: np.ndarray, vs: np.ndarray):
    """Flattened CSR rows of the vertices ``vs``: ``(owner (r,), position in the CSR arrays (r,), starts (n,))``."""
    cnt = ptr[vs + 1] - ptr[vs]
    owner = np.repeat(np.arange(len(vs)), cnt)
    starts = np.cumsum(cnt) - cnt
    pos = ptr[vs][owner] + np.arange(len(owner)) - starts[owner]
    return owner, pos, starts


class _Corners(NamedTuple):
    """Every corner of every face around each vertex of ``vs`` (rows grouped by vertex, then by face)."""

    pair_owner: np.ndarray  # (p,) vertex (index into vs) of each (vertex, face) pair
    pair_face: np.ndarray  # (p,) its face
    pair_start: np.ndarray  # (n,) first pair of each vertex
    row_pair: np.ndarray  # (r,) pair of each corner row
    row_start: np.ndarray  # (p,) first row of each pair
    row_owner: np.ndarray  # (r,) vertex of each row
    vert_row_start: np.ndarray  # (n,) first row of each vertex
    c: np.ndarray  # (r,) the corner's vertex
    prev: np.ndarray  # (r,) the one before it in its face
    nxt: np.ndarray  # (r,) the one after it
    own_rows: np.ndarray  # rows whose corner is the moving vertex itself (its two edges)


def _corners(st: _Stars, vs: np.ndarray) -> _Corners:
    pair_owner, pos, pair_start = _segments(st.vf_ptr, vs)
    pair_face = st.vf_face[pos]
    k = st.size[pair_face]
    row_pair = np.repeat(np.arange(len(pair_face)), k)
    row_start = np.cumsum(k) - k
    i = np.arange(len(row_pair)) - row_start[row_pair]
    kk = k[row_pair]
    f = pair_face[row_pair]
    c = st.F[f, i]
    prev = st.F[f, (i - 1) % kk]
    nxt = st.F[f, (i + 1) % kk]
    row_owner = pair_owner[row_pair]
    vert_row_start = row_start[pair_start] if len(pair_start) else np.zeros(0, dtype=np.int64)
    own_rows = np.nonzero(c == vs[row_owner])[0]
    return _Corners(pair_owner, pair_face, pair_start, row_pair, row_start, row_owner, vert_row_start, c, prev,
                    nxt, own_rows)


def _batch_scores(vs: np.ndarray, Y: np.ndarray, X: np.ndarray, cn: _Corners, normal: np.ndarray):
    """Scores of positions ``Y (n, s, 3)`` of the vertices ``vs`` (one at a time, the others where ``X`` has them):
    the worst corner margin ``(n, s)`` over the faces around the vertex (degrees; ``min(θ, 180° − θ)`` with ``θ``
    the corner angle, taken as ``360° − θ`` where the corner turns against its face's Newell normal, as
    :func:`components.core.measures.nonconvex_faces` has it, so reflex corners are negative; −180° for a face
    flipped against the surface), the lengths ``(o, s)`` of the vertex's edges (rows ``cn.own_rows``: to the
    corners before and after it in each face) and the areas ``(p, s)`` of its faces (negative when flipped)."""
    O = Y[cn.row_owner]  # (r, s, 3): products about the moving vertex (no cancellation far from the origin)

    def at(w):
        own = (w == vs[cn.row_owner])[:, None, None]
        return np.where(own, O, X[w][:, None, :]) - O

    pc, pp, pn = at(cn.c), at(cn.prev), at(cn.nxt)
    N = np.add.reduceat(cross(pc, pn), cn.row_start, axis=0)
    a, b = pp - pc, pn - pc
    ang = np.degrees(np.arctan2(np.linalg.norm(cross(a, b), axis=2), np.einsum("rsj,rsj->rs", a, b)))
    convex = np.einsum("rsj,rsj->rs", cross(pc - pp, pn - pc), N[cn.row_pair]) > 0
    theta = np.where(convex, ang, 360.0 - ang)
    margin = np.minimum(theta, 180.0 - theta)
    side = np.einsum("psj,pj->ps", N, normal[cn.pair_face])
    margin = np.minimum.reduceat(np.where(side[cn.row_pair] > 0, margin, -180.0), cn.vert_row_start, axis=0)
    o = cn.own_rows
    L = np.concatenate([np.linalg.norm(pp[o], axis=2), np.linalg.norm(pn[o], axis=2)])
    area = 0.5 * np.linalg.norm(N, axis=2) * np.where(side > 0, 1.0, -1.0)
    return margin, L, area


def _trial_positions(vs: np.ndarray, X: np.ndarray, st: _Stars, cn: _Corners):
    """Positions to try for the vertices ``vs`` (before they are put back on the surface): ``(n, t, 3)`` and which
    are real ``(n, t)`` (a vertex without quads has no parallelogram target). Towards the mean of the neighbours,
    the mean of the quads' parallelogram completions and the mean of the faces' centroids (without the vertex) by
    :data:`_STEPS`, then :data:`_RING` directions × :data:`_RADII` in the tangent plane."""
    n = len(vs)
    x = X[vs]
    nb_owner, nb_pos, nb_start = _segments(st.nb_ptr, vs)
    nb = st.nb_v[nb_pos]
    cnt = np.diff(np.r_[nb_start, len(nb)])
    g_nb = np.add.reduceat(X[nb], nb_start, axis=0) / cnt[:, None]
    # per face around v: its centroid without v, and the parallelogram completion of a quad
    f = cn.pair_face
    k = st.size[f]
    s = st.vf_slot[_segments(st.vf_ptr, vs)[1]]
    K = st.F.shape[1]
    jj = np.arange(K)
    others = (jj[None, :] < k[:, None]) & (jj[None, :] != s[:, None])
    P = X[st.F[f]]  # (p, K, 3)
    cent = np.zeros((len(f), 3))
    for j in range(K):  # corners in face order, as a mean over the others would add them
        cent = np.where(others[:, j:j + 1], cent + P[:, j], cent)
    cent /= (k - 1)[:, None]
    quad = k == 4
    para = (X[st.F[f, (s + 1) % 4]] + X[st.F[f, (s + 3) % 4]]) - X[st.F[f, (s + 2) % 4]]
    nq = np.bincount(cn.pair_owner, weights=quad, minlength=n)
    g_para = np.zeros((n, 3))
    g_cent = np.zeros((n, 3))
    npair = np.diff(np.r_[cn.pair_start, len(f)])
    for j in range(int(npair.max()) if n else 0):  # faces in ascending order per vertex, summed in that order
        has = npair > j
        p = np.where(has, cn.pair_start + j, 0)
        g_cent = np.where(has[:, None], g_cent + cent[p], g_cent)
        q = has & quad[p]
        g_para = np.where(q[:, None], g_para + para[p], g_para)
    g_cent /= npair[:, None]
    g_para /= np.maximum(nq, 1)[:, None]
    targets = np.stack([g_nb, g_para, g_cent], axis=1)  # (n, 3, 3)
    steps = np.asarray(_STEPS)
    Yt = x[:, None, None, :] + steps[None, None, :, None] * (targets[:, :, None, :] - x[:, None, None, :])
    real_t = np.repeat(np.stack([np.ones(n, bool), nq > 0, np.ones(n, bool)], axis=1), len(steps), axis=1)
    # the tangent plane: Newell-like sum over the neighbours (in edge order), the longest spoke, the shortest one
    d = X[nb] - x[nb_owner]
    nxt = np.arange(len(nb)) + 1
    last = nb_start + cnt - 1
    nxt[last] = nb_start
    nrm = np.add.reduceat(cross(d, d[nxt]), nb_start, axis=0)
    ln = np.linalg.norm(d, axis=1)
    longest = np.maximum.reduceat(ln, nb_start)
    first = np.full(n, len(nb))
    hit = np.nonzero(ln == longest[nb_owner])[0]
    np.minimum.at(first, nb_owner[hit], hit)
    e1 = d[first]
    e1 = e1 - nrm * np.einsum("ij,ij->i", e1, nrm)[:, None] / np.maximum(np.einsum("ij,ij->i", nrm, nrm), 1e-300)[:, None]
    e1 /= np.maximum(np.linalg.norm(e1, axis=1), 1e-300)[:, None]
    e2 = cross(nrm, e1)
    e2 /= np.maximum(np.linalg.norm(e2, axis=1), 1e-300)[:, None]
    r = np.minimum.reduceat(ln, nb_start)
    ang = np.arange(_RING) * (2.0 * np.pi / _RING)
    dirs = np.cos(ang)[None, :, None] * e1[:, None, :] + np.sin(ang)[None, :, None] * e2[:, None, :]  # (n, ring, 3)
    rad = np.asarray(_RADII)
    Yr = x[:, None, None, :] + (rad[None, None, :] * r[:, None, None])[..., None] * dirs[:, :, None, :]
    Y = np.concatenate([Yt.reshape(n, -1, 3), Yr.reshape(n, -1, 3)], axis=1)
    real = np.concatenate([real_t, np.ones((n, _RING * len(rad)), dtype=bool)], axis=1)
    return Y, real


def _put_on_surface(Y: np.ndarray, real: np.ndarray, on_boundary: np.ndarray, index, bc):
    """The trial positions ``Y (n, t, 3)`` put back on the surface (on the boundary for the vertices
    ``on_boundary``): points, triangles, barycentric coordinates. One query for all interior vertices' trials and
    one for the boundary ones (a point's closest point does not depend on the others)."""
    n, t = real.shape
    pts = Y.copy()
    tri = np.zeros((n, t), dtype=np.int64)
    bary = np.zeros((n, t, 3))
    for onb in (True, False):
        sel = real & (on_boundary[:, None] == onb)
        if not sel.any():
            continue
        if onb:
            p, tr, ba = closest_on_boundary(Y[sel], bc)
        else:
            q = index.query(Y[sel])
            p, tr, ba = q.points, q.faces, q.barycentric
        pts[sel], tri[sel], bary[sel] = p, tr, ba
    return pts, tri, bary


def _smoothed(state, hl: PanelHealth, FN: np.ndarray, index, bc, bounds):
    """Smart smoothing of the vertices of the unhealthy faces (see the module notes): the new state and the number
    of moves kept.

    Batched: every sweep scores all candidate vertices' trials at once (one closest-point query); a vertex is tried
    only while no vertex of its faces has moved in the sweep (a move takes the whole star), so its trials are
    those of the sweep's start, and a vertex whose star did not change since it was last tried (no better trial
    then) is not tried again: its trials would be the same."""
    Vc, Fc, tri, bary, grid = state
    min_edge_ratio, min_angle, min_area_ratio = bounds
    bad = ((hl.face_defects & _SHAPE_BITS) != 0) | _near_bounds(hl, min_angle)
    if not bad.any():
        return state, 0
    L_min = _SLACK * min_edge_ratio * hl.median_edge  # with room for the planarization (and the median's drift)
    A_min = _SLACK * min_area_ratio * hl.median_area
    nv = len(Vc)
    topo = edge_topology(Fc)
    onb = np.zeros(nv, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    fixed = _outline_corners(Vc, topo, onb)
    st = _stars(Fc, topo, nv)
    X, tri, bary = Vc.copy(), tri.copy(), bary.copy()
    active = np.zeros(nv, dtype=bool)
    sizes = face_sizes(Fc)
    rows = np.nonzero(bad)[0]
    active[Fc[rows][np.arange(Fc.shape[1])[None, :] < sizes[rows, None]]] = True
    active &= ~fixed
    cand = np.nonzero(active)[0]
    if not len(cand):
        return state, 0
    goal = min_angle + _MARGIN
    m0 = np.zeros(nv)
    better = np.zeros(nv, dtype=bool)
    new_x, new_t, new_b = np.zeros((nv, 3)), np.zeros(nv, dtype=np.int64), np.zeros((nv, 3))
    dirty = active.copy()  # vertices whose star changed since they were last scored
    moved = 0
    for _ in range(_SWEEPS):
        normal = _face_normals(Fc, FN, tri, np.unique(st.vf_face[_segments(st.vf_ptr, cand[dirty[cand]])[1]]))
        redo = cand[dirty[cand]]
        for ch in range(0, len(redo), _BATCH):
            vs = redo[ch:ch + _BATCH]
            cn = _corners(st, vs)
            m_now, L0, A0 = _batch_scores(vs, X[vs][:, None, :], X, cn, normal)
            m0[vs] = m_now[:, 0]
            below = _quantized(m_now[:, 0]) < goal
            better[vs] = False
            if not below.any():
                continue
            ts = vs[below]
            cn = _corners(st, ts)
            Y, real = _trial_positions(ts, X, st, cn)
            Y, t_, b_ = _put_on_surface(Y, real, onb[ts], index, bc)
            m, L, A = _batch_scores(ts, Y, X, cn, normal)
            _, Lk, Ak = _batch_scores(ts, X[ts][:, None, :], X, cn, normal)
            Lk, Ak = Lk[:, 0], Ak[:, 0]
            own = np.concatenate([cn.row_owner[cn.own_rows], cn.row_owner[cn.own_rows]])
            short = np.zeros((len(ts), Y.shape[1]), dtype=bool)
            np.logical_or.at(short, own, L < np.minimum(L_min, Lk)[:, None])
            np.logical_or.at(short, cn.pair_owner, A < np.minimum(A_min, Ak)[:, None])
            ok = real & ~short
            # the best worst corner, counted up to the bound plus 5°; of equals the shortest move (the net stays
            # as conjugate as it can: a long move spoils the planarity the planarization has to restore)
            mq = np.where(ok, np.minimum(_quantized(m), goal), -np.inf)
            top = mq.max(axis=1)
            dist = np.where(mq == top[:, None], np.linalg.norm(Y - X[ts][:, None, :], axis=2), np.inf)
            j = np.argmin(dist, axis=1)
            r = np.arange(len(ts))
            better[ts] = top > _quantized(m0[ts])
            new_x[ts], new_t[ts], new_b[ts] = Y[r, j], t_[r, j], b_[r, j]
        dirty[:] = False
        order = cand[np.lexsort((cand, _quantized(m0[cand])))]
        order = order[better[order]]
        taken = np.zeros(nv, dtype=bool)
        went = []
        for v in order.tolist():
            if taken[v]:
                continue
            X[v], tri[v], bary[v] = new_x[v], new_t[v], new_b[v]
            star = st.F[st.vf_face[st.vf_ptr[v]:st.vf_ptr[v + 1]]].ravel()
            taken[star] = True
            went.append(v)
        if not went:
            break
        moved += len(went)
        went = np.asarray(went)
        cw = _corners(st, went)
        dirty[cw.c] = True
    return (X, Fc, tri, bary, grid), moved


def _quantized(margin):
    """Corner margins rounded to :data:`_QUANTUM` degrees: the smoothing compares and orders these, so the last
    bits of the input (its units, its placement) do not change which move wins."""
    return np.round(np.asarray(margin) / _QUANTUM) * _QUANTUM


def _near_bounds(hl: PanelHealth, min_angle: float) -> np.ndarray:
    """``(m,) bool``: faces with a corner within 5° of the corner bounds (or beyond them)."""
    return (hl.min_corner < min_angle + _MARGIN) | (hl.max_corner > 180.0 - min_angle - _MARGIN)


def _face_normals(Fc: np.ndarray, FN: np.ndarray, tri: np.ndarray, faces=None) -> np.ndarray:
    """Unit surface normal of every face (padded ``Fc``): the mean of the input normals under its corners (summed
    corner by corner, in the faces' order); with ``faces``, only theirs (the other rows are zero)."""
    if faces is not None:
        out = np.zeros((len(Fc), 3))
        out[faces] = _face_normals(Fc[faces], FN, tri)
        return out
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
