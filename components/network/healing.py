"""Healing of a rebuilt cell complex: no short edges, no flat or sharp corners, no oversized cells, full coverage.

The quad rebuild (:mod:`components.network.rebuild`) turns a two-family line network into cells of a planar graph.
Where the network is irregular the cells are not fabricable panels as they come:

* **short edges** — two line ends stopping on one line close together (T-junctions), a line ending on the boundary
  next to a crossing, two lines ending on the boundary side by side;
* **flat corners** — a line stopping on another one leaves a corner of about 180° in the cell across it (a
  T-junction), a boundary node that lost its line leaves one on the boundary;
* **oversized cells** — holes of the network (skipped umbilic regions, lines stopped short of the boundary) are
  cells with many corners, often non-convex;
* **sharp or tiny cells** — where the boundary cuts the corner of a network cell.

:func:`healed_cells` repairs them in rounds, in the plane of the rebuild (the cells are simple counter-clockwise
polygons there, so every operation is checked for orientation and self-crossing) with lengths, areas and corner
angles measured in 3D (the plane map need not be conformal):

1. edges shorter than ``min_edge_ratio`` × the median edge are **collapsed** (a corner of the boundary stays put, a
   boundary node keeps its place against a crossing, two crossings meet half-way, two boundary nodes half-way on
   the boundary);
2. **flat nodes** that only one cell uses (a boundary node whose line was removed) or that two cells pass straight
   through are **dropped** from their cells;
3. cells with a flat or reflex corner, or with more than ``max_face_size`` corners, are **split**: along a diagonal
   between their own corners, greedily (each diagonal removes as many bad corners as it can and keeps the new
   corners as wide as it can, preferring quads), or — where no diagonal removes the bad corner, or every one
   would leave a node far from conical or with too many faces — by running the line that stops at the corner on
   across the cell, to a corner near where it lands or to a new node on the far edge (the cell across that edge
   takes the node and is healed in turn, the line runs on until it ends well: a T-junction's pentagon becomes two
   quads, a hole becomes quads, triangles and pentagons);
4. triangles with a sharp corner and cells under ``min_area_ratio`` × the median area are **collapsed** along
   their shortest edge; a larger cell with a sharp corner is merged with a neighbour and split again;
5. interior nodes with four cells whose conical angle criterion ``|ω1 − ω2 + ω3 − ω4|`` is far from 0 (the
   conical optimization would have to bend the mesh away from the surface to meet it) are **moved** in the plane
   until it is met, or given three cells (an edge removed) or five (a cell split at them);
6. with ``max_bulge``: cells under which the surface bulges more than that × the median edge from the plane of
   their corners are **split in two** across their longer extent (between the midpoints of two edges, or from a
   corner to an edge's midpoint; the cells across take the new nodes), and the rounds above run again (a flat panel
   over a bulging cell leaves its middle far from the design surface).

A corner is judged by its 3D angle, and is reflex where the plane corner is reflex or where it turns against the
cell's Newell normal in 3D (a strongly curved cell can be convex in the plane and not in space).

The cells keep their nodes and the lines their directions, except where two nodes meet half-way, a line is run on
across a cell, or a node is moved for its criterion. Nodes with five or more cells (four on the boundary) are
avoided where a choice exists: the conical criterion does not hold there, so a face offset is exact only to
about the planarity of their star. Array-level: :func:`healed_cells`, :func:`manifold_cells`.
"""
from __future__ import annotations

import logging
import math
from collections import defaultdict
from typing import Callable, NamedTuple

import numpy as np

from components.core.compiled import kernel
from components.core.mesh import edge_topology, pad_faces

log = logging.getLogger(__name__)

__all__ = ["HealedCells", "NODE_BOUNDARY", "NODE_CORNER", "NODE_CROSSING", "healed_cells", "manifold_cells"]

NODE_CROSSING, NODE_BOUNDARY, NODE_CORNER = 0, 1, 2
_ROUNDS = 8  # healing rounds at most (each one collapses, drops and splits what it finds)
_REFINE_PASSES = 4  # passes splitting bulging cells at most (each one followed by healing rounds)
# a plane corner within this angle (radians; its sine, relative to its two edges) of straight is straight, not reflex:
# its 3D angle decides, as where the plane corner is exactly straight. A node put on an edge (a line's end, a split)
# is collinear with its neighbours up to rounding, and the sign of that rounding decided whether its 3D angle (about
# 155° where the lifted node bulges off the chord) counted as reflex (the torus patch of the tests: 153 panels at the
# origin, 168 at +5e6)
_STRAIGHT = 1e-9
_STRAIGHT_DEG = math.degrees(_STRAIGHT)


class HealedCells(NamedTuple):
    """Result of :func:`healed_cells`: the cells and their nodes (new nodes appended) and what was done."""

    faces: list  # counter-clockwise node lists (in the plane)
    uv: np.ndarray  # (nn', 2) node plane positions
    X: np.ndarray  # (nn', 3) node surface positions
    kind: np.ndarray  # (nn',) NODE_CROSSING, NODE_BOUNDARY or NODE_CORNER
    collapsed: int  # short edges (and sharp or tiny cells) collapsed
    restarred: int  # nodes with four cells far from conical given three or five
    dropped_nodes: int  # flat nodes dropped from their cells
    split: int  # cells split along a diagonal (each split counts once)
    left_open: int  # cells still larger than max_face_size, left out
    refined: int = 0  # bulging cells split in two


def _cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


_ROLL: dict = {}


def _roll(k: int):
    """Index arrays ``(next, previous)`` of a ``k``-gon's corners."""
    out = _ROLL.get(k)
    if out is None:
        out = _ROLL[k] = (np.r_[1:k, 0], np.r_[k - 1, 0:k - 1])
    return out


def _c2(ax, ay, bx, by) -> float:
    return ax * by - ay * bx


def _simple_ccw(P) -> bool:
    """The polygon ``P (k, 2)`` turns counter-clockwise and no two of its non-adjacent edges meet (plain floats)."""
    L = P.tolist() if isinstance(P, np.ndarray) else P
    k = len(L)
    if sum(_c2(L[i][0], L[i][1], L[(i + 1) % k][0], L[(i + 1) % k][1]) for i in range(k)) <= 0.0:
        return False
    if k <= 3:
        return True
    for i in range(k):
        (ax, ay), (bx, by) = L[i], L[(i + 1) % k]
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue
            (cx, cy), (dx, dy) = L[j], L[(j + 1) % k]
            d1, d2 = _c2(bx - ax, by - ay, cx - ax, cy - ay), _c2(bx - ax, by - ay, dx - ax, dy - ay)
            d3, d4 = _c2(dx - cx, dy - cy, ax - cx, ay - cy), _c2(dx - cx, dy - cy, bx - cx, by - cy)
            if d1 * d2 <= 0.0 and d3 * d4 <= 0.0:
                return False
    return True


def _interior_angles(P) -> np.ndarray:
    """Interior angles (degrees, 0..360) of a counter-clockwise polygon ``P (k, 2)``; above 180 is reflex."""
    nx, pv = _roll(len(P))
    nxt = P[nx] - P
    prv = P[pv] - P
    return np.degrees(np.mod(np.arctan2(_cross2(nxt, prv), np.einsum("ij,ij->i", nxt, prv)), 2.0 * math.pi))


def _cross3(a, b):
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _angle(a, b) -> float:
    """Angle between two 3-vectors, radians (plain floats: cheaper than numpy for one pair)."""
    ax, ay, az = a.tolist() if isinstance(a, np.ndarray) else a
    bx, by, bz = b.tolist() if isinstance(b, np.ndarray) else b
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz)


def _angles3(P, Q) -> np.ndarray:
    """Interior angles (degrees, 0..360) of a cell with counter-clockwise plane corners ``P (k, 2)`` and surface
    corners ``Q (k, 3)``: the 3D angle, reflex (360° minus it) where the plane corner is reflex (not within
    :data:`_STRAIGHT` of straight) or where the corner turns against the cell's Newell normal in 3D (the plane map
    need not be conformal, the panels' angles are the 3D ones). Plain floats: the cells are small and this runs for
    every cell many times."""
    k = len(Q)
    P, Q = P.tolist(), Q.tolist()
    cx = sum(q[0] for q in Q) / k
    cy = sum(q[1] for q in Q) / k
    cz = sum(q[2] for q in Q) / k
    Y = [(q[0] - cx, q[1] - cy, q[2] - cz) for q in Q]
    nx = ny = nz = 0.0
    for i in range(k):
        a, b = Y[i], Y[(i + 1) % k]
        nx += a[1] * b[2] - a[2] * b[1]
        ny += a[2] * b[0] - a[0] * b[2]
        nz += a[0] * b[1] - a[1] * b[0]
    out = np.empty(k)
    for i in range(k):
        q, qn, qp = Q[i], Q[(i + 1) % k], Q[i - 1]
        ax, ay, az = qn[0] - q[0], qn[1] - q[1], qn[2] - q[2]
        bx, by, bz = qp[0] - q[0], qp[1] - q[1], qp[2] - q[2]
        wx, wy, wz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        a3 = math.degrees(math.atan2(math.sqrt(wx * wx + wy * wy + wz * wz), ax * bx + ay * by + az * bz))
        p, pn, pp = P[i], P[(i + 1) % k], P[i - 1]
        ux, uy, vx, vy = pn[0] - p[0], pn[1] - p[1], pp[0] - p[0], pp[1] - p[1]
        plane_reflex = ux * vy - uy * vx < -_STRAIGHT * math.sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy))
        # a corner turning against the face's Newell normal is reflex in 3D even where the plane corner is convex
        against = k > 3 and wx * nx + wy * ny + wz * nz < 0.0
        out[i] = 360.0 - a3 if plane_reflex or against else a3
    return out


# math.atan2 element by element: numpy's SIMD arctan2 differs from the C library's in the last bit on some CPUs
# (7 % of values on an AVX-512 machine), and the per-cell path (:func:`_angles3`) uses the C library's
_ATAN2 = np.frompyfunc(math.atan2, 2, 1)


def _angles3_many(P, Q) -> np.ndarray:
    """:func:`_angles3` of ``n`` cells with ``k`` corners each at once: ``P (n, k, 2)``, ``Q (n, k, 3)`` → ``(n, k)``,
    the same numbers (the same operations in the same order, vectorized over the cells)."""
    k = Q.shape[1]
    X, Y, Z = Q[..., 0], Q[..., 1], Q[..., 2]
    nx, ny, nz = _newell_many(Q)
    nxt, prv = _roll(k)
    ax, ay, az = X[:, nxt] - X, Y[:, nxt] - Y, Z[:, nxt] - Z
    bx, by, bz = X[:, prv] - X, Y[:, prv] - Y, Z[:, prv] - Z
    wx, wy, wz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    a3 = np.degrees(_ATAN2(np.sqrt(wx * wx + wy * wy + wz * wz), ax * bx + ay * by + az * bz).astype(np.float64))
    U, V = P[..., 0], P[..., 1]
    ux, uy, vx, vy = U[:, nxt] - U, V[:, nxt] - V, U[:, prv] - U, V[:, prv] - V
    reflex = ux * vy - uy * vx < -_STRAIGHT * np.sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy))
    if k > 3:
        reflex |= wx * nx[:, None] + wy * ny[:, None] + wz * nz[:, None] < 0.0
    return np.where(reflex, 360.0 - a3, a3)


def _split_angles3(P, Q, i, tp, tq) -> np.ndarray:
    """The two new corners (degrees, as in :func:`_angles3`) at corner ``i`` of a cell split by a segment to the
    target (plane ``tp``, surface ``tq``): the one after the next edge first."""
    k = len(P)
    uv = _corner_split_angles(P, i, tp)
    out = []
    for (a, b), u in zip(((Q[(i + 1) % k] - Q[i], tq - Q[i]), (tq - Q[i], Q[(i - 1) % k] - Q[i])), uv):
        a3 = math.degrees(_angle(a, b))
        out.append(a3 if u <= 180.0 + _STRAIGHT_DEG else 360.0 - a3)
    return np.array(out)


def _split_pair(P: list, Q: list, i: int, j: int) -> tuple:
    """:func:`_split_angles3` of corner ``i`` split towards corner ``j`` (plane ``P`` and surface ``Q`` corners as
    lists of plain floats; the same numbers)."""
    k = len(P)
    (px, py), (nx_, ny_), (qx, qy), (tx, ty) = P[i], P[(i + 1) % k], P[i - 1], P[j]
    vnx, vny, vpx, vpy, dx, dy = nx_ - px, ny_ - py, qx - px, qy - py, tx - px, ty - py
    two_pi = 2 * math.pi
    u1 = math.degrees(math.atan2(vnx * dy - vny * dx, vnx * dx + vny * dy) % two_pi)
    u2 = math.degrees(math.atan2(dx * vpy - dy * vpx, dx * vpx + dy * vpy) % two_pi)
    q, qn, qp, t = Q[i], Q[(i + 1) % k], Q[i - 1], Q[j]
    d = (t[0] - q[0], t[1] - q[1], t[2] - q[2])
    a1 = math.degrees(_angle((qn[0] - q[0], qn[1] - q[1], qn[2] - q[2]), d))
    a2 = math.degrees(_angle(d, (qp[0] - q[0], qp[1] - q[1], qp[2] - q[2])))
    return (a1 if u1 <= 180.0 + _STRAIGHT_DEG else 360.0 - a1, a2 if u2 <= 180.0 + _STRAIGHT_DEG else 360.0 - a2)


def _area3(X) -> float:
    """Area of a (non-planar) polygon ``X (k, 3)`` by Newell's vector (relative to its centroid; plain floats)."""
    Q = X.tolist() if isinstance(X, np.ndarray) else X
    k = len(Q)
    cx = sum(q[0] for q in Q) / k
    cy = sum(q[1] for q in Q) / k
    cz = sum(q[2] for q in Q) / k
    nx = ny = nz = 0.0
    for i in range(k):
        a, b = Q[i], Q[(i + 1) % k]
        a0, a1, a2 = a[0] - cx, a[1] - cy, a[2] - cz
        b0, b1, b2 = b[0] - cx, b[1] - cy, b[2] - cz
        nx += a1 * b2 - a2 * b1
        ny += a2 * b0 - a0 * b2
        nz += a0 * b1 - a1 * b0
    return 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)


def _areas3_many(Q) -> np.ndarray:
    """:func:`_area3` of ``n`` cells with ``k`` corners each at once: ``Q (n, k, 3)`` → ``(n,)``, the same numbers
    (the same operations in the same order, vectorized over the cells)."""
    nx, ny, nz = _newell_many(Q)
    return 0.5 * np.sqrt(nx * nx + ny * ny + nz * nz)


def _newell_many(Q):
    """The Newell normals (twice the vector area) of ``n`` cells with ``k`` corners each, about their centroids:
    ``Q (n, k, 3)`` → ``nx, ny, nz (n,)``, with the operations of :func:`_area3` in the same order."""
    n, k = Q.shape[:2]
    X, Y, Z = Q[..., 0], Q[..., 1], Q[..., 2]
    cx, cy, cz = X[:, 0].copy(), Y[:, 0].copy(), Z[:, 0].copy()
    for i in range(1, k):
        cx += X[:, i]
        cy += Y[:, i]
        cz += Z[:, i]
    A, B, C = X - (cx / k)[:, None], Y - (cy / k)[:, None], Z - (cz / k)[:, None]
    nx, ny, nz = np.zeros(n), np.zeros(n), np.zeros(n)
    for i in range(k):
        j = (i + 1) % k
        nx += B[:, i] * C[:, j] - C[:, i] * B[:, j]
        ny += C[:, i] * A[:, j] - A[:, i] * C[:, j]
        nz += A[:, i] * B[:, j] - B[:, i] * A[:, j]
    return nx, ny, nz


class _Complex:
    """Faces as node lists with a half-edge map, node positions and kinds; edits are checked and atomic."""

    def __init__(self, faces, uv, X, kind):
        self.faces: dict[int, list[int]] = {}
        self.he: dict[tuple[int, int], int] = {}
        self.vf: dict[int, set] = defaultdict(set)
        self.uv = [np.asarray(p, np.float64) for p in uv]
        self.X = [np.asarray(p, np.float64) for p in X]
        self.kind = [int(k) for k in kind]
        self.next_id = 0
        self.inserted = 0  # cells inserted so far (see made_since)
        self._angle_cache: dict = {}
        for f in faces:
            self._insert(self._new_id(), list(f))

    def _new_id(self) -> int:
        self.next_id += 1
        return self.next_id - 1

    def _insert(self, fid, f):
        self.faces[fid] = f
        self.inserted += 1
        for a, b in zip(f, f[1:] + f[:1]):
            self.he[(a, b)] = fid
        for v in f:
            self.vf[v].add(fid)

    def _remove(self, fid):
        f = self.faces.pop(fid)
        for a, b in zip(f, f[1:] + f[:1]):
            if self.he.get((a, b)) == fid:
                del self.he[(a, b)]
        for v in f:
            self.vf[v].discard(fid)
        return f

    def mark(self) -> tuple:
        """The state :meth:`made_since` compares with."""
        return self.next_id, self.inserted

    def made_since(self, mark: tuple) -> list:
        """The ids of the cells made since ``mark`` (:meth:`mark`) that still exist, in the order of ``faces``
        (a scan of the cells inserted since, from the end: a cell restored by a refused edit keeps its old id)."""
        first, inserted = mark
        out = [g for _, g in zip(range(self.inserted - inserted), reversed(self.faces)) if g >= first]
        out.reverse()
        return out

    def add_node(self, uv, X, kind) -> int:
        self.uv.append(np.asarray(uv, np.float64))
        self.X.append(np.asarray(X, np.float64))
        self.kind.append(int(kind))
        return len(self.uv) - 1

    def polygon(self, f) -> np.ndarray:
        return np.array([self.uv[v] for v in f])

    def forget_angles(self) -> None:
        """Drop the cached angles (after a node moved)."""
        self._angle_cache.clear()

    def points(self, f) -> np.ndarray:
        return np.array([self.X[v] for v in f])

    def prime_angles(self) -> None:
        """Compute the angles of every cell not cached yet at once (:func:`_angles3_many`: the numbers
        :meth:`angles` gives, a cell at a time)."""
        todo: dict[int, list] = defaultdict(list)
        cache = self._angle_cache
        for f in self.faces.values():
            key = tuple(f)
            if key not in cache:
                todo[len(key)].append(key)
        if not todo:
            return
        UV, X = np.array(self.uv).reshape(-1, 2), np.array(self.X).reshape(-1, 3)
        for keys in todo.values():
            idx = np.array(keys, np.int64)
            for key, row in zip(keys, _angles3_many(UV[idx], X[idx])):
                cache[key] = row

    def areas(self) -> dict:
        """``{face id: area}`` of every cell (3D, :func:`_area3`, computed at once by :func:`_areas3_many`)."""
        groups: dict[int, list] = defaultdict(list)
        for fid, f in self.faces.items():
            groups[len(f)].append(fid)
        X = np.array(self.X).reshape(-1, 3)
        out = {}
        for fids in groups.values():
            idx = np.array([self.faces[g] for g in fids], np.int64)
            out.update(zip(fids, _areas3_many(X[idx]).tolist()))
        return {fid: out[fid] for fid in self.faces}

    def angles(self, f) -> np.ndarray:
        """Interior angles of cell ``f`` (degrees, :func:`_angles3`; cached until a node moves)."""
        key = tuple(f)
        out = self._angle_cache.get(key)
        if out is None:
            out = self._angle_cache[key] = _angles3(self.polygon(f), self.points(f))
        return out

    def edit(self, remove: list, add: list, moved: dict | None = None) -> bool:
        """Replace the faces ``remove`` (ids) by the node lists ``add``, with nodes ``moved`` {node: uv} at new
        plane positions: done only when every new face is a simple counter-clockwise polygon with distinct nodes, no
        half-edge is used twice and every face around a moved node stays simple and counter-clockwise."""
        add = [f for f in add if f is not None]
        for f in add:
            if len(f) < 3 or len(set(f)) != len(f):
                return False
        old_uv = {}
        if moved:
            self._angle_cache.clear()
        for v, p in (moved or {}).items():
            old_uv[v] = self.uv[v]
            self.uv[v] = np.asarray(p, np.float64)
        saved = [(fid, self._remove(fid)) for fid in remove]
        ok = True
        new_he = set()
        for f in add:
            for a, b in zip(f, f[1:] + f[:1]):
                if (a, b) in self.he or (a, b) in new_he:
                    ok = False
                new_he.add((a, b))
            if ok and not _simple_ccw(self.polygon(f)):
                ok = False
        if ok and moved:
            around = set().union(*(self.vf[v] for v in moved))
            ok = all(_simple_ccw(self.polygon(self.faces[g])) for g in around)
        if not ok:
            for fid, f in saved:
                self._insert(fid, f)
            for v, p in old_uv.items():
                self.uv[v] = p
            return False
        for f in add:
            self._insert(self._new_id(), f)
        return True

    def edges(self) -> np.ndarray:
        """Undirected edges ``(e, 2)`` (each once)."""
        if not self.he:
            return np.zeros((0, 2), np.int64)
        H = np.sort(np.array(list(self.he), np.int64), axis=1)
        n = int(H.max()) + 1
        key = np.unique(H[:, 0] * n + H[:, 1])  # sorted as the pairs (a, b)
        return np.stack([key // n, key % n], axis=1)

    def corner_angles(self):
        """``[(face id, node, interior angle in degrees)]`` of every corner, in the plane."""
        out = []
        self.prime_angles()
        for fid, f in self.faces.items():
            for v, a in zip(f, self.angles(f).tolist()):
                out.append((fid, v, float(a)))
        return out


# ----------------------------------------------------------------------------------------------
# operations


def _collapse(cx: _Complex, a: int, b: int, lift: Callable, project: Callable) -> bool:
    """Merge node ``b`` into ``a`` (the survivor is the higher kind; two crossings meet half-way, two boundary
    nodes half-way on the boundary). Refused when both are corners, when a face holds both without an edge between
    them, or when a face would turn over."""
    ka, kb = cx.kind[a], cx.kind[b]
    if ka == NODE_CORNER and kb == NODE_CORNER:
        return False
    if kb > ka:
        a, b, ka, kb = b, a, kb, ka
    if ka == kb:
        mid = 0.5 * (cx.uv[a] + cx.uv[b])
        pos = project(mid[None])[0] if ka == NODE_BOUNDARY else mid
    else:
        pos = cx.uv[a]
    remove, add = [], []
    for fid in cx.vf[a] | cx.vf[b]:
        f = cx.faces[fid]
        if a in f and b in f:
            i, j = f.index(a), f.index(b)
            if (i - j) % len(f) not in (1, len(f) - 1):
                return False
        g = [a if v == b else v for v in f]
        g = [v for k, v in enumerate(g) if v != g[k - 1]]
        remove.append(fid)
        add.append(g if len(g) >= 3 else None)
    if not cx.edit(remove, add, moved={a: pos}):
        return False
    if ka == kb:
        cx.X[a] = lift(np.asarray(pos)[None])[0]
        cx.forget_angles()
    cx.kind[a] = ka
    return True


def _split_choice(P, Q, min_angle: float, max_face_size: int, diag_scale: float, star_cost=None,
                  strict: int = 0, irregular=None):
    """The best diagonal ``(i, j)`` of the cell with counter-clockwise plane corners ``P (k, 2)`` and surface corners
    ``Q (k, 3)`` (angles: :func:`_angles3`), or ``None``.

    A diagonal must run inside the polygon. It is chosen for, in order: fewest bad corners left (flat, reflex or
    sharp: outside ``[min_angle, 180 − min_angle]``) over both pieces, then the widest new corners, quads, and a
    length under 1.5 × ``diag_scale``. ``None`` when no diagonal removes a bad corner and the polygon is small.
    ``star_cost(i, a1, a2)``, when given, counts the nodes a split of corner ``i`` into ``a1``, ``a2`` (degrees)
    would leave with four faces far from conical (ranked right after the bad corners). ``irregular(i)``, when
    given, is 1 when one more edge at corner ``i`` makes its node irregular (five faces inside, four on the
    boundary: no exact face offset there), ranked next. With ``strict`` 1 a diagonal leaving a star far from conical
    is not taken, with 2 neither one leaving an irregular node (unless the polygon has more than ``max_face_size``
    corners).
    """
    k = len(P)
    ang = _angles3(P, Q)
    hi = 180.0 - min_angle
    bad = ((ang < min_angle) | (ang > hi)).tolist()
    nbad = sum(bad)
    if nbad == 0 and k <= max_face_size:
        return None
    Pl, Ql = P.tolist(), Q.tolist()  # plain floats: the loop below runs for every pair of corners
    inside = _diagonals_inside(Pl)
    best, best_key = None, None
    for i in range(k):
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue
            if not inside(i, j):
                continue
            new = _split_pair(Pl, Ql, i, j) + _split_pair(Pl, Ql, j, i)
            left = nbad - bad[i] - bad[j] + sum(a < min_angle or a > hi for a in new)
            sizes = (j - i + 1, k - (j - i) + 1)
            big = sum(s > max_face_size for s in sizes)
            if best_key is not None and (-left, -big) < best_key[:2]:
                continue  # ranked below the best whatever its stars (the costly part) say
            quality = min(min(a, 180.0 - a) for a in new)
            quads = sum(s == 4 for s in sizes)
            tris = sum(s == 3 for s in sizes)
            length = float(np.hypot(Pl[j][0] - Pl[i][0], Pl[j][1] - Pl[i][1])) / diag_scale
            stars = 0 if star_cost is None else star_cost(i, new[0], new[1]) + star_cost(j, new[2], new[3])
            irr = 0 if irregular is None else irregular(i) + irregular(j)
            if k <= max_face_size and ((strict >= 1 and stars) or (strict >= 2 and irr)):
                continue
            key = (-left, -big, -stars, -irr, quality + 12.0 * quads + 4.0 * tris - 30.0 * max(0.0, length - 1.5))
            if best_key is None or key > best_key:
                best, best_key = (i, j), key
    if best is None:
        return None
    if -best_key[0] >= nbad and k <= max_face_size:
        return None  # no bad corner removed
    return best


def _diagonal_inside(P, i, j) -> bool:
    """The segment ``P[i] P[j]`` runs inside the counter-clockwise polygon ``P`` (inside the corner cones at both
    ends, crossing no edge; plain floats)."""
    L = P.tolist() if isinstance(P, np.ndarray) else P
    k = len(L)
    two_pi = 2 * math.pi
    for s, t in ((i, j), (j, i)):
        (px, py), (nx_, ny_), (qx, qy), (tx, ty) = L[s], L[(s + 1) % k], L[(s - 1) % k], L[t]
        vnx, vny, vpx, vpy, dx, dy = nx_ - px, ny_ - py, qx - px, qy - py, tx - px, ty - py
        interior = math.atan2(_c2(vnx, vny, vpx, vpy), vnx * vpx + vny * vpy) % two_pi
        a = math.atan2(_c2(vnx, vny, dx, dy), vnx * dx + vny * dy) % two_pi
        if not 1e-9 < a < interior - 1e-9:
            return False
    (ax, ay), (bx, by) = L[i], L[j]
    for e in range(k):
        f = (e + 1) % k
        if e in (i, j) or f in (i, j):
            continue
        (cx, cy), (dx, dy) = L[e], L[f]
        d1, d2 = _c2(bx - ax, by - ay, cx - ax, cy - ay), _c2(bx - ax, by - ay, dx - ax, dy - ay)
        d3, d4 = _c2(dx - cx, dy - cy, ax - cx, ay - cy), _c2(dx - cx, dy - cy, bx - cx, by - cy)
        if (d1 > 0) != (d2 > 0) and (d3 > 0) != (d4 > 0):
            return False
        if d1 == 0 or d2 == 0:  # an edge end on the diagonal
            return False
    return True


@kernel("boolean(float64[:, ::1], int64, int64)")
def _inside_compiled(P, i, j):  # pragma: no cover (compiled)
    """:func:`_diagonal_inside` compiled (the same operations; ``math.atan2`` is the C library's in both)."""
    k = P.shape[0]
    two_pi = 2 * math.pi
    for s, t in ((i, j), (j, i)):
        px, py = P[s, 0], P[s, 1]
        vnx, vny = P[(s + 1) % k, 0] - px, P[(s + 1) % k, 1] - py
        vpx, vpy = P[(s - 1) % k, 0] - px, P[(s - 1) % k, 1] - py
        dx, dy = P[t, 0] - px, P[t, 1] - py
        interior = math.atan2(vnx * vpy - vny * vpx, vnx * vpx + vny * vpy) % two_pi
        a = math.atan2(vnx * dy - vny * dx, vnx * dx + vny * dy) % two_pi
        if not 1e-9 < a < interior - 1e-9:
            return False
    ax, ay, bx, by = P[i, 0], P[i, 1], P[j, 0], P[j, 1]
    for e in range(k):
        f = (e + 1) % k
        if e == i or e == j or f == i or f == j:
            continue
        cx, cy, dx, dy = P[e, 0], P[e, 1], P[f, 0], P[f, 1]
        d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        d2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
        d3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
        d4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
        if (d1 > 0) != (d2 > 0) and (d3 > 0) != (d4 > 0):
            return False
        if d1 == 0 or d2 == 0:
            return False
    return True


@kernel("boolean[:, ::1](float64[:, ::1])")
def _diagonals_compiled(P):  # pragma: no cover (compiled)
    """``inside[i, j]`` (``i < j``, not the edge ``(0, k − 1)``): :func:`_diagonal_inside` of every diagonal."""
    k = P.shape[0]
    out = np.zeros((k, k), dtype=np.bool_)
    for i in range(k):
        for j in range(i + 2, k):
            if not (i == 0 and j == k - 1):
                out[i, j] = _inside_compiled(P, i, j)
    return out


def _diagonals_inside(P: list):
    """``inside(i, j)`` for the diagonals of the counter-clockwise polygon ``P`` (plain floats): all at once where
    compiled (the polygons of a fine network have up to a few hundred corners, and :func:`_split_choice` tests
    every pair), else :func:`_diagonal_inside` pair by pair."""
    if _diagonals_compiled is None:
        return lambda i, j: _diagonal_inside(P, i, j)
    table = _diagonals_compiled(np.array(P, dtype=np.float64).reshape(-1, 2)).tolist()
    return lambda i, j: table[i][j]


def _split_face(cx: _Complex, fid: int, min_angle: float, max_face_size: int, diag_scale: float,
                max_criterion: float, strict: int = 0) -> int:
    """Split a face recursively along its best diagonals; returns the number of splits done."""
    todo, done = [fid], 0
    while todo:
        g = todo.pop()
        f = cx.faces.get(g)
        if f is None:
            continue
        choice = _split_choice(cx.polygon(f), cx.points(f), min_angle, max_face_size, diag_scale,
                               lambda i, a1, a2, g=g: _star_cost(cx, g, i, a1, a2, max_criterion), strict,
                               lambda i, g=g: _irregular_after(cx, cx.faces[g][i]))
        if choice is None:
            continue
        i, j = choice
        since = cx.mark()
        if not cx.edit([g], [f[i:j + 1], f[j:] + f[:i + 1]]):
            continue
        done += 1
        todo += cx.made_since(since)
    return done


# ----------------------------------------------------------------------------------------------
# the healing rounds


def healed_cells(faces, uv, X, kind, lift: Callable, project: Callable, *, min_edge_ratio: float = 0.25,
                 min_angle: float = 22.0, min_area_ratio: float = 0.15, max_face_size: int = 5,
                 max_criterion: float = 1.0, max_bulge: float | None = None, rounds: int = _ROUNDS) -> HealedCells:
    """Collapse short edges, drop flat nodes, split bad cells and collapse sharp or tiny ones, in rounds; then give
    the four-cell nodes far from conical a better star (see the module's steps 1–5).

    The margins (22°, 0.25 × the median edge, 0.15 × the median area) stay above the panel-health bounds (20°, 0.2,
    0.1) so that the optimization that follows has room.

    Parameters
    ----------
    faces : list of list of int
        Cells (node lists, counter-clockwise in the plane), a manifold complex.
    uv : (nn, 2) float64
        Node plane positions.
    X : (nn, 3) float64
        Node surface positions.
    kind : (nn,) int64
        ``NODE_CROSSING``, ``NODE_BOUNDARY`` or ``NODE_CORNER`` per node.
    lift : callable
        ``lift(P (p, 2)) -> (p, 3)``: plane points to the surface.
    project : callable
        ``project(P (p, 2)) -> (p, 2)``: plane points to the closest boundary point.
    min_edge_ratio : float
        Edges shorter than this × the median edge (3D) are collapsed.
    min_angle : float
        Corners outside ``[min_angle, 180 − min_angle]`` degrees (3D angles, reflex where the plane corner is) are
        bad.
    min_area_ratio : float
        Cells smaller than this × the median cell area (3D) are collapsed.
    max_face_size : int
        Cells with more corners are split; those left larger after splitting are dropped (``left_open``).
    max_criterion : float
        An interior node with four cells whose conical angle criterion ``|ω1 − ω2 + ω3 − ω4|`` (3D corner angles,
        radians) is above this is moved, or gets three or five cells (an edge removed or a cell split at it), so
        the conical optimization is not asked to bend the mesh away from the surface there.
    max_bulge : float, optional
        Cells under which the surface bulges more than this × the median edge from the plane of their corners (at
        the cell's centre and its edges' midpoints, lifted from the plane) are split in two across their longer
        extent (:func:`_refine_bulging`), then healed again; ``None``: off.
    rounds : int
        Largest number of healing rounds.

    Returns
    -------
    HealedCells

    Example
    -------
    >>> import numpy as np
    >>> uv = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1], [1.05, 0.02]], float)
    >>> X = np.c_[uv, np.zeros(7)]
    >>> kind = np.array([1, 1, 1, 1, 1, 1, 0])
    >>> h = healed_cells([[0, 6, 4, 5], [6, 1, 2, 3, 4]], uv, X, kind, lambda P: np.c_[P, np.zeros(len(P))],
    ...                  lambda P: P)
    >>> sorted(len(f) for f in h.faces), h.collapsed, h.split
    ([4, 4], 1, 0)
    """
    cx = _Complex(faces, uv, X, kind)
    counts = {"collapsed": 0, "dropped": 0, "split": 0, "restarred": 0, "refined": 0}

    def heal():
        for _ in range(rounds):
            changed = _collapse_short(cx, lift, project, min_edge_ratio, counts)
            changed |= _drop_flat_nodes(cx, min_angle, counts)
            changed |= _split_bad(cx, min_angle, max_face_size, max_criterion, lift, project, counts)
            changed |= _collapse_sharp_and_small(cx, lift, project, min_angle, min_area_ratio, max_face_size,
                                                 max_criterion, counts)
            if not changed:
                break

    heal()
    for _ in range(_REFINE_PASSES if max_bulge is not None else 0):
        if not _refine_bulging(cx, lift, project, max_bulge, min_angle, min_edge_ratio, counts):
            break
        heal()
    _conical_stars(cx, _Bounds(min_angle, min_edge_ratio, min_area_ratio, max_face_size, max_criterion), lift, counts)
    out = [f for f in cx.faces.values() if len(f) <= max_face_size]
    left_open = len(cx.faces) - len(out)
    return HealedCells(out, np.array(cx.uv).reshape(-1, 2), np.array(cx.X).reshape(-1, 3),
                       np.array(cx.kind, np.int64), counts["collapsed"], counts["restarred"], counts["dropped"],
                       counts["split"], left_open, counts["refined"])


# ----------------------------------------------------------------------------------------------
# bulging cells


def _bulges(cx: _Complex, lift: Callable) -> dict:
    """``{face id: bulge}``: the largest distance from the plane of a cell's corners (least squares) of the surface
    points under the cell's centre and its edges' midpoints (taken in the plane and lifted)."""
    fids = list(cx.faces)
    if not fids:
        return {}
    UV, X = np.array(cx.uv).reshape(-1, 2), np.array(cx.X).reshape(-1, 3)
    faces = [cx.faces[g] for g in fids]
    P = [UV[f] for f in faces]
    samples = [np.vstack([p.mean(axis=0)[None], 0.5 * (p + p[_roll(len(p))[0]])]) for p in P]
    S = lift(np.concatenate(samples))
    # the corners' planes, the cells of one size at once (one stacked SVD: the same numbers as one cell at a time)
    normal, centre = [None] * len(fids), [None] * len(fids)
    by_size: dict[int, list] = defaultdict(list)
    for i, f in enumerate(faces):
        by_size[len(f)].append(i)
    for k, rows in by_size.items():
        Q = X[np.array([faces[i] for i in rows])]  # (r, k, 3)
        C = Q.mean(axis=1)
        N = np.linalg.svd(Q - C[:, None])[2][:, -1]
        for i, c, n in zip(rows, C, N):
            centre[i], normal[i] = c, n
    out, start = {}, 0
    for g, smp, c, n in zip(fids, samples, centre, normal):
        out[g] = float(np.abs((S[start:start + len(smp)] - c) @ n).max())
        start += len(smp)
    return out


def _halves(P, Q, cut):
    """The two pieces of the cell with plane corners ``P (k, 2)`` and surface corners ``Q (k, 3)`` split along
    ``cut = ((where, plane point, surface point), (where, ...))``, ``where`` a corner index ``("c", i)`` or an edge
    index ``("e", e)`` (a new point on edge ``e``): ``(pieces as index lists into the extended corner list, plane
    points, surface points)``; the extended corner list has the new points after the corners."""
    k = len(P)
    seq, extra_p, extra_q = [], [], []
    on_edge = {c[0][1]: c for c in cut if c[0][0] == "e"}
    ends = []
    for i in range(k):
        seq.append(i)
        if i in [c[0][1] for c in cut if c[0][0] == "c"]:
            ends.append(len(seq) - 1)
        if i in on_edge:
            extra_p.append(on_edge[i][1])
            extra_q.append(on_edge[i][2])
            seq.append(k + len(extra_p) - 1)
            ends.append(len(seq) - 1)
    a, b = sorted(ends)
    pieces = [seq[a:b + 1], seq[b:] + seq[:a + 1]]
    Pe = np.vstack([P] + [np.asarray(x)[None] for x in extra_p])
    Qe = np.vstack([Q] + [np.asarray(x)[None] for x in extra_q])
    return pieces, Pe, Qe


def _bisection(cx: _Complex, fid: int, lift: Callable, project: Callable, min_angle: float, min_edge: float):
    """The best cut of cell ``fid`` in two: between the midpoints of two edges, or from a corner to the midpoint of
    an edge not at it; every corner of both pieces within ``[min_angle, 180 − min_angle]``, every new edge over
    ``min_edge`` (3D), the pieces simple. Chosen for the smallest larger piece's diameter (3D), then quads. Returns
    ``(cut, key)`` or ``None``."""
    f = cx.faces[fid]
    k = len(f)
    P, Q = cx.polygon(f), cx.points(f)
    nx = _roll(k)[0]
    M = 0.5 * (P + P[nx])
    bnd = [cx.he.get((f[(e + 1) % k], f[e])) is None for e in range(k)]
    for e in range(k):
        if bnd[e]:
            M[e] = project(M[e][None])[0]
    MQ = lift(M)
    elen = np.linalg.norm(Q[nx] - Q, axis=1)
    ends = [(("e", e), M[e], MQ[e]) for e in range(k) if 0.5 * elen[e] >= min_edge]
    ends += [(("c", i), P[i], Q[i]) for i in range(k)]
    best = None
    for x in range(len(ends)):
        for y in range(x + 1, len(ends)):
            a, b = ends[x], ends[y]
            if a[0][0] == "c" and b[0][0] == "c":
                continue
            if a[0][0] == "c" or b[0][0] == "c":
                c, e = (a, b) if a[0][0] == "c" else (b, a)
                if c[0][1] in (e[0][1], (e[0][1] + 1) % k):
                    continue
            elif (a[0][1] - b[0][1]) % k in (0,):
                continue
            if np.linalg.norm(a[2] - b[2]) < min_edge:
                continue
            pieces, Pe, Qe = _halves(P, Q, (a, b))
            if min(len(q) for q in pieces) < 3:
                continue
            ok, diam = True, 0.0
            for q in pieces:
                pp, qq = Pe[q], Qe[q]
                if not _simple_ccw(pp):
                    ok = False
                    break
                ang = _angles3(pp, qq)
                if ang.min() < min_angle or ang.max() > 180.0 - min_angle:
                    ok = False
                    break
                diam = max(diam, float(np.max(np.linalg.norm(qq[:, None] - qq[None], axis=2))))
            if not ok:
                continue
            key = (-diam * (1.0 - 0.05 * sum(len(q) == 4 for q in pieces)),)
            if best is None or key > best[1]:
                best = ((a, b), key)
    return best


def _apply_bisection(cx: _Complex, fid: int, cut, project: Callable, lift: Callable) -> bool:
    """Split cell ``fid`` along ``cut`` (see :func:`_bisection`): new nodes on the cut edges, also in the cells
    across them (or on the design boundary)."""
    f = cx.faces[fid]
    k = len(f)
    remove, add, newnode = [fid], [], {}
    for where, p, q in cut:
        if where[0] != "e":
            continue
        e = where[1]
        a, b = f[e], f[(e + 1) % k]
        other = cx.he.get((b, a))
        newnode[e] = cx.add_node(p, q, NODE_BOUNDARY if other is None else NODE_CROSSING)
        if other is not None:
            h = cx.faces[other] if other not in remove else next(x for x in add if b in x and a in x)
            j = h.index(b)
            h2 = h[:j + 1] + [newnode[e]] + h[j + 1:]
            if other in remove:
                add[add.index(h)] = h2
            else:
                remove.append(other)
                add.append(h2)
    g, ends = [], []
    corners = {w[1] for w, _, _ in cut if w[0] == "c"}
    for i in range(k):
        g.append(f[i])
        if i in corners:
            ends.append(len(g) - 1)
        if i in newnode:
            g.append(newnode[i])
            ends.append(len(g) - 1)
    a, b = sorted(ends)
    return cx.edit(remove, [g[a:b + 1], g[b:] + g[:a + 1]] + add)


def _refine_bulging(cx: _Complex, lift: Callable, project: Callable, max_bulge: float, min_angle: float,
                    min_edge_ratio: float, counts) -> bool:
    """Split every cell whose surface bulges more than ``max_bulge`` × the median edge from its corners' plane in
    two (:func:`_bisection`), largest bulge first, one cell per neighbourhood per pass; returns whether any was."""
    E = cx.edges()
    if not len(E):
        return False
    med = float(np.median(_edge_lengths(cx, E)))
    bul = _bulges(cx, lift)
    todo = sorted((b, g) for g, b in bul.items() if b > max_bulge * med)[::-1]
    touched, changed = set(), False
    for _, g in todo:
        f = cx.faces.get(g)
        if f is None or touched.intersection(f):
            continue
        choice = _bisection(cx, g, lift, project, min_angle + 4.0, max(2.0 * min_edge_ratio, 0.4) * med)
        if choice is None:
            continue
        near = {v for w in f for h in cx.vf[w] for v in cx.faces[h]}
        if _apply_bisection(cx, g, choice[0], project, lift):
            counts["refined"] += 1
            touched |= near
            changed = True
    return changed


def manifold_cells(faces: list, n: int) -> tuple[list, int, int]:
    """Drop cells until every node has a single fan (no bow-tie nodes), the non-quads at a bow-tie first, else all
    but one fan of it.

    Parameters
    ----------
    faces : list of list of int
        Cells (node lists), consistently oriented.
    n : int
        Number of nodes.

    Returns
    -------
    faces : list of list of int
        The kept cells.
    dropped : int
        Cells dropped.
    bow_ties : int
        Bow-tie nodes found (over all passes).

    Example
    -------
    >>> manifold_cells([[0, 1, 2, 3], [0, 4, 5, 6]], 7)  # two quads touching at node 0 only
    ([[0, 1, 2, 3]], 1, 1)
    """
    dropped_total, bad_total = 0, 0
    for _ in range(10):
        if not faces:
            break
        topo = edge_topology(pad_faces(faces))
        B = topo.E[topo.count == 1]
        deg = np.bincount(B.ravel(), minlength=n)
        bad = np.nonzero(deg > 2)[0]
        if len(bad) == 0:
            break
        badset = set(bad.tolist())
        drop = {i for i, f in enumerate(faces) if badset.intersection(f) and len(f) != 4}
        if not drop:
            for v in bad.tolist():
                inc = [i for i, f in enumerate(faces) if v in f]
                drop.update(inc[1:2])
        dropped_total += len(drop)
        bad_total += len(bad)
        faces = [f for i, f in enumerate(faces) if i not in drop]
    return faces, dropped_total, bad_total


def _edge_lengths(cx: _Complex, E) -> np.ndarray:
    X = np.array(cx.X)
    return np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1)


def _collapse_short(cx, lift, project, ratio, counts) -> bool:
    E = cx.edges()
    if not len(E):
        return False
    L = _edge_lengths(cx, E)
    med = float(np.median(L))
    touched, changed = set(), False
    for e in np.argsort(L):
        if L[e] >= ratio * med:
            break
        a, b = int(E[e, 0]), int(E[e, 1])
        if a in touched or b in touched:
            continue
        if _collapse(cx, a, b, lift, project):
            counts["collapsed"] += 1
            touched.update((a, b))
            changed = True
    return changed


def _drop_flat_nodes(cx, min_angle, counts) -> bool:
    """Drop nodes (not corners) used by one cell at a nearly straight corner, or passed straight through by two."""
    flat_at = defaultdict(list)
    for fid, v, a in cx.corner_angles():
        flat_at[v].append((fid, abs(a - 180.0) < min_angle))
    changed = False
    for v, lst in flat_at.items():
        if cx.kind[v] == NODE_CORNER or not all(flat for _, flat in lst) or len(lst) > 2:
            continue
        fids = [fid for fid, _ in lst]
        if set(fids) != cx.vf[v] or any(len(cx.faces[g]) <= 3 for g in fids):
            continue
        if len(lst) == 1 and cx.kind[v] == NODE_CROSSING:
            continue  # an interior node of one cell is not on its boundary: leave it
        if cx.edit(fids, [[u for u in cx.faces[g] if u != v] for g in fids]):
            counts["dropped"] += 1
            changed = True
    return changed


def _split_bad(cx, min_angle, max_face_size, max_criterion, lift, project, counts) -> bool:
    """Split the cells with a flat or reflex corner or too many corners: along diagonals where one removes a bad
    corner, else by running the line that stops at the bad corner on across the cell (:func:`_extend_through`)."""
    E = cx.edges()
    scale = float(np.median(np.linalg.norm(np.array(cx.uv)[E[:, 0]] - np.array(cx.uv)[E[:, 1]], axis=1))) \
        if len(E) else 1.0
    changed = False
    todo = list(cx.faces)
    budget = 4 * len(todo) + 100
    cx.prime_angles()
    while todo and budget > 0:
        budget -= 1
        fid = todo.pop()
        f = cx.faces.get(fid)
        if f is None:
            continue
        if not (len(f) > max_face_size or max(cx.angles(f).tolist()) > 180.0 - min_angle):
            continue
        since = cx.mark()
        for strict in (2, 1, 0):  # first without irregular nodes or stars far from conical, then without the latter
            n = _split_face(cx, fid, min_angle, max_face_size, scale, max_criterion, strict)
            new = cx.made_since(since)
            if not n and fid in cx.faces:
                new = _extend_through(cx, fid, min_angle, max_criterion, lift, project, strict)
                n = int(bool(new))
            if n:
                counts["split"] += n
                changed = True
                todo += new
                break
    return changed


def _extend_through(cx: _Complex, fid: int, min_angle: float, max_criterion: float, lift: Callable,
                    project: Callable, strict: int = 0) -> list:
    """Run a line that stops at a flat or reflex corner of cell ``fid`` on, straight across the cell, to its far
    side: to a corner there when it lands near one, else to a new node on that edge (the cell across it, if any,
    takes the node too and is healed in turn). Returns the ids of the new cells (empty when nothing was done)."""
    f = cx.faces[fid]
    k = len(f)
    P, Q = cx.polygon(f), cx.points(f)
    ang = _angles3(P, Q)
    best = None
    for i in np.argsort(-np.abs(ang - 180.0)):
        if ang[i] <= 180.0 - min_angle:
            continue
        t = f[i]
        dirs = [cx.uv[t] - cx.uv[s] for s in _neighbours(cx, t)]
        v_next = P[(i + 1) % k] - P[i]
        half = math.radians(0.5 * ang[i])
        c, sn = math.cos(half), math.sin(half)
        dirs.append(np.array([c * v_next[0] - sn * v_next[1], sn * v_next[0] + c * v_next[1]]))  # the bisector
        for d in dirs:
            nd = float(np.hypot(*d))
            if nd <= 0.0:
                continue
            hit = _ray_exit(P, i, d / nd)
            if hit is None:
                continue
            e, u, q = hit
            for cand in _landings(P, Q, i, e, u, q):
                new = _split_angles3(P, Q, i, cand[1], cand[3])
                quality = float(np.minimum(new, 180.0 - new).min())
                if quality < min_angle:
                    continue
                stars = _star_cost(cx, fid, int(i), new[0], new[1], max_criterion)
                if cand[0] == "corner":
                    stars += _star_cost(cx, fid, cand[2], *_split_angles3(P, Q, cand[2], P[i], Q[i]), max_criterion)
                irr = _irregular_after(cx, f[i]) + (_irregular_after(cx, f[cand[2]]) if cand[0] == "corner" else 0)
                if (strict >= 1 and stars) or (strict >= 2 and irr):
                    continue
                key = (-stars, -irr, quality + (10.0 if cand[0] == "corner" else 0.0))
                if best is None or key > best[0]:
                    best = (key, i, e, cand)
        if best is not None:
            break
    if best is None:
        return []
    _, i, e, cand = best
    since = cx.mark()
    if cand[0] == "corner":
        j = cand[2]
        a, b = (i, j) if i < j else (j, i)
        ok = cx.edit([fid], [f[a:b + 1], f[b:] + f[:a + 1]])
    else:
        ok = _insert_and_split(cx, fid, i, e, cand[1], lift, project)
    return cx.made_since(since) if ok else []


def _neighbours(cx: _Complex, v: int) -> set:
    return {b for fid in cx.vf[v] for a, b in zip(cx.faces[fid], cx.faces[fid][1:] + cx.faces[fid][:1])
            if a == v} | {a for fid in cx.vf[v] for a, b in zip(cx.faces[fid], cx.faces[fid][1:] + cx.faces[fid][:1])
                          if b == v}


def _ray_exit(P, i, d):
    """Where the ray from corner ``i`` of polygon ``P`` along unit ``d`` first meets an edge not at ``i``:
    ``(edge index e, parameter u along P[e] → P[e+1], point)`` or ``None``."""
    k = len(P)
    L = P.tolist()  # plain floats (the same arithmetic as on the arrays)
    ox, oy = L[i]
    dx, dy = float(d[0]), float(d[1])
    best = None
    for e in range(k):
        f = (e + 1) % k
        if e == i or f == i:
            continue
        (cx, cy), (ex, ey) = L[e], L[f]
        wx, wy = ex - cx, ey - cy
        den = dx * wy - dy * wx
        if abs(den) <= 1e-12 * float(np.hypot(wx, wy)):
            continue
        rx, ry = cx - ox, cy - oy
        t = (rx * wy - ry * wx) / den
        u = (rx * dy - ry * dx) / den
        if t > 0.0 and -1e-9 <= u <= 1.0 + 1e-9 and (best is None or t < best[0]):
            best = (t, e, min(max(u, 0.0), 1.0))
    if best is None:
        return None
    t, e, u = best
    return e, u, P[i] + t * d


def _landings(P, Q, i, e, u, q):
    """Where a line from corner ``i`` exiting through edge ``e`` at ``u`` may end: the near corner (when ``u`` is
    within 0.3 of an end) and the exit point itself (when it is inside 0.15..0.85), as ``(kind, plane point, corner
    or edge index, surface point)``."""
    k = len(P)
    out = []
    for j, uu in ((e, u), ((e + 1) % k, 1.0 - u)):
        if uu < 0.3 and (j - i) % k not in (1, k - 1):
            out.append(("corner", P[j], j, Q[j]))
    if 0.15 < u < 0.85:
        out.append(("point", q, e, Q[e] + u * (Q[(e + 1) % k] - Q[e])))
    return out


def _corner_split_angles(P, i, target) -> np.ndarray:
    """The two new angles at corner ``i`` of ``P`` when a segment to ``target`` splits it (degrees)."""
    k = len(P)
    v_next, v_prev = P[(i + 1) % k] - P[i], P[(i - 1) % k] - P[i]
    dd = target - P[i]
    a1 = math.degrees(math.atan2(_cross2(v_next, dd), float(v_next @ dd)) % (2 * math.pi))
    a2 = math.degrees(math.atan2(_cross2(dd, v_prev), float(dd @ v_prev)) % (2 * math.pi))
    return np.array([a1, a2])


def _insert_and_split(cx: _Complex, fid: int, i: int, e: int, q, lift, project) -> bool:
    """Insert a node at ``q`` on edge ``e`` of cell ``fid`` (and of the cell across it, or on the boundary) and
    split ``fid`` between corner ``i`` and the new node."""
    f = cx.faces[fid]
    k = len(f)
    a, b = f[e], f[(e + 1) % k]
    other = cx.he.get((b, a))
    kind = NODE_CROSSING
    if other is None:  # a boundary edge: the new node goes onto the design boundary
        q = project(np.asarray(q)[None])[0]
        kind = NODE_BOUNDARY
    p = cx.add_node(q, lift(np.asarray(q)[None])[0], kind)
    g = f[:e + 1] + [p] + f[e + 1:]  # p after position e
    ip, ii = e + 1, (i if i <= e else i + 1)
    lo, hi = min(ip, ii), max(ip, ii)
    pieces = [g[lo:hi + 1], g[hi:] + g[:lo + 1]]
    remove, add = [fid], pieces
    if other is not None:
        h = cx.faces[other]
        j = h.index(b)
        remove.append(other)
        add = pieces + [h[:j + 1] + [p] + h[j + 1:]]
    return cx.edit(remove, add)


def _collapse_sharp_and_small(cx, lift, project, min_angle, min_area_ratio, max_face_size, max_criterion,
                              counts) -> bool:
    """Collapse the edge opposite a sharp corner of a triangle and the shortest edge of a tiny cell; merge a larger
    cell with a sharp corner with its neighbour across one of that corner's edges and split the union again."""
    areas = cx.areas()
    if not areas:
        return False
    med = float(np.median(list(areas.values())))
    todo, merges = [], []
    cx.prime_angles()
    for fid, f in cx.faces.items():
        ang = cx.angles(f)
        if len(f) == 3 and ang.min() < min_angle:
            k = int(np.argmin(ang))
            todo.append((f[(k + 1) % 3], f[(k + 2) % 3]))
        elif areas[fid] < min_area_ratio * med:
            L = [np.linalg.norm(cx.X[a] - cx.X[b]) for a, b in zip(f, f[1:] + f[:1])]
            k = int(np.argmin(L))
            todo.append((f[k], f[(k + 1) % len(f)]))
        elif ang.min() < min_angle:
            merges.append(fid)
    touched, changed = set(), False
    for a, b in todo:
        if a in touched or b in touched or not cx.vf[a] or not cx.vf[b]:
            continue
        if _collapse(cx, a, b, lift, project):
            counts["collapsed"] += 1
            touched.update((a, b))
            changed = True
    for fid in merges:
        f = cx.faces.get(fid)
        if f is None or touched.intersection(f):
            continue
        k = int(np.argmin(cx.angles(f)))
        for e in ((k - 1) % len(f), k):
            fid = cx.he[(f[0], f[1])]  # a reverted try gives the cell a new id
            if _remerged(cx, fid, e, min_angle, max_face_size, max_criterion):
                counts["collapsed"] += 1
                touched.update(f)
                changed = True
                break
    return changed


def _remerged(cx: _Complex, fid: int, e: int, min_angle: float, max_face_size: int, max_criterion: float) -> bool:
    """Merge cell ``fid`` with its neighbour across its edge ``e`` and split the union again along its best
    diagonals; kept only when every piece has at most ``max_face_size`` corners within ``[min_angle,
    180 − min_angle]``."""
    f = cx.faces[fid]
    v, w = f[e], f[(e + 1) % len(f)]
    g = cx.he.get((w, v))
    if g is None:
        return False
    h = cx.faces[g]
    if len(set(f) & set(h)) != 2:
        return False
    i, j = f.index(w), h.index(v)
    merged = f[i:] + f[:i] + (h[j:] + h[:j])[1:-1]
    since = cx.mark()
    if not cx.edit([fid, g], [merged]):
        return False
    E = cx.edges()
    scale = float(np.median(np.linalg.norm(np.array(cx.uv)[E[:, 0]] - np.array(cx.uv)[E[:, 1]], axis=1)))
    _split_face(cx, cx.next_id - 1, min_angle, max_face_size, scale, max_criterion)
    pieces = cx.made_since(since)
    ok = all(len(cx.faces[q]) <= max_face_size and min_angle <= cx.angles(cx.faces[q]).min() and
             cx.angles(cx.faces[q]).max() <= 180.0 - min_angle for q in pieces)
    if not ok:
        cx.edit(pieces, [f, h])
    return ok


def _merged_across(cx: _Complex, fid: int, e: int, min_angle: float, max_face_size: int):
    """Cell ``fid`` merged with its neighbour across its edge ``e`` (``f[e] → f[e+1]``): ``(quality, neighbour id,
    merged node list)`` when the merged cell has at most ``max_face_size`` corners within ``[min_angle,
    180 − min_angle]``, else ``None``."""
    f = cx.faces[fid]
    v, w = f[e], f[(e + 1) % len(f)]
    g = cx.he.get((w, v))
    if g is None:
        return None
    h = cx.faces[g]
    if len(f) + len(h) - 2 > max_face_size or len(set(f) & set(h)) != 2:
        return None
    i = f.index(w)
    fw = f[i:] + f[:i]  # starts at w, ends at v
    j = h.index(v)
    hv = h[j:] + h[:j]  # starts at v, ends at w
    merged = fw + hv[1:-1]
    ang = cx.angles(merged)
    if ang.max() > 180.0 - min_angle or ang.min() < min_angle:
        return None
    return float(np.minimum(ang, 180.0 - ang).min()), g, merged


# ----------------------------------------------------------------------------------------------
# vertex stars the conical optimization can satisfy


def _ring_faces(cx: _Complex, v: int):
    """Faces around an interior node ``v`` in cyclic order as ``(face id, previous node, next node)`` (``None`` for
    a boundary node)."""
    fids = cx.vf[v]
    if not fids:
        return None
    start = next(iter(fids))
    ring, fid = [], start
    for _ in range(len(fids) + 1):
        f = cx.faces[fid]
        i = f.index(v)
        p, n = f[i - 1], f[(i + 1) % len(f)]
        ring.append((fid, p, n))
        fid = cx.he.get((v, p))
        if fid is None:
            return None
        if fid == start:
            return ring if len(ring) == len(fids) else None
    return None


def _ring(cx: _Complex, v: int):
    """Faces around an interior node ``v`` in cyclic order with the 3D corner angle at ``v`` in each (``None`` for
    a boundary node)."""
    ring = _ring_faces(cx, v)
    if ring is None:
        return None
    X = cx.X
    x0, x1, x2 = X[v].tolist()  # plain floats (the same differences as of the arrays)
    out = []
    for fid, p, n in ring:
        a, b = X[p].tolist(), X[n].tolist()
        out.append((fid, _angle((a[0] - x0, a[1] - x1, a[2] - x2), (b[0] - x0, b[1] - x1, b[2] - x2))))
    return out


def _irregular_after(cx: _Complex, v: int) -> int:
    """1 when one more edge at node ``v`` gives it five faces inside or four on the boundary, else 0."""
    n = len(cx.vf[v]) + 1
    return int(n >= 5 or (n >= 4 and _ring_faces(cx, v) is None))


def _star_cost(cx: _Complex, fid: int, i: int, a1: float, a2: float, max_criterion: float) -> int:
    """1 when splitting corner ``i`` of face ``fid`` into ``a1`` then ``a2`` (degrees, counter-clockwise) leaves its
    node interior with four faces and a conical criterion above ``max_criterion``, else 0."""
    v = cx.faces[fid][i]
    if len(cx.vf[v]) != 3:
        return 0
    ring = _ring(cx, v)
    if ring is None:
        return 0
    w = []
    for g, a in ring:
        w += [math.radians(a1), math.radians(a2)] if g == fid else [a]
    return int(abs(w[0] - w[1] + w[2] - w[3]) > max_criterion)


def _criterion(cx: _Complex, v: int) -> float:
    """``|ω1 − ω2 + ω3 − ω4|`` at an interior node with four faces, else 0."""
    ring = _ring(cx, v)
    if ring is None or len(ring) != 4:
        return 0.0
    w = [a for _, a in ring]
    return abs(w[0] - w[1] + w[2] - w[3])


class _Bounds(NamedTuple):
    min_angle: float  # degrees, in the plane
    min_edge_ratio: float  # × median edge (3D)
    min_area_ratio: float  # × median face area (3D)
    max_face_size: int
    max_criterion: float  # radians


def _sizes_ok(cx: _Complex, faces, b: _Bounds, med_edge: float, med_area: float, X=None) -> bool:
    """Every face of ``faces`` (node lists) has edges and an area above the bounds (3D, ``X`` overriding node
    positions: {node: point})."""
    X = X or {}
    for f in faces:
        P = np.array([X.get(v, cx.X[v]) for v in f])
        if np.linalg.norm(P - np.roll(P, -1, axis=0), axis=1).min() < b.min_edge_ratio * med_edge:
            return False
        if _area3(P) < b.min_area_ratio * med_area:
            return False
    return True


def _conical_stars(cx: _Complex, b: _Bounds, lift, counts) -> None:
    """Give every interior node with four faces far from the conical criterion a better star: moved in the plane
    until the criterion is met, or three faces (an edge removed), or five (a face split at it); the corners stay
    within ``[min_angle, 180 − min_angle]``, edges and areas above their bounds."""
    E = cx.edges()
    if not len(E):
        return
    med_edge = float(np.median(_edge_lengths(cx, E)))
    med_area = float(np.median(list(cx.areas().values())))
    for _ in range(4):
        bad = sorted(((_criterion(cx, v), v) for v in list(cx.vf) if len(cx.vf[v]) == 4), reverse=True)
        bad = [v for c, v in bad if c > b.max_criterion]
        if not bad:
            return
        done = False
        for v in bad:
            if len(cx.vf[v]) == 4 and _criterion(cx, v) > b.max_criterion:
                if _relocate(cx, v, b, lift, med_edge, med_area) or _remove_edge_at(cx, v, b) or \
                        _split_at(cx, v, b, med_edge, med_area):
                    counts["restarred"] += 1
                    done = True
        if not done:
            return


def _remove_edge_at(cx, v, b: _Bounds) -> bool:
    """Merge two faces across an edge at ``v`` when the merged face is small and convex enough and the other end
    of the edge does not become a four-face node far from conical."""
    best = None
    for fid in list(cx.vf[v]):
        f = cx.faces[fid]
        e = f.index(v)
        o = _merged_across(cx, fid, e, b.min_angle, b.max_face_size)
        if o is not None and (best is None or o[0] > best[0]):
            best = (o[0], fid, o[1], o[2], f[(e + 1) % len(f)])
    if best is None:
        return False
    _, fid, g, merged, w = best
    f, h = cx.faces[fid], cx.faces[g]
    if not cx.edit([fid, g], [merged]):
        return False
    if len(cx.vf[w]) == 4 and _criterion(cx, w) > b.max_criterion:
        cx.edit([cx.next_id - 1], [f, h])  # the other end would be far from conical: undone
        return False
    return True


def _split_at(cx, v, b: _Bounds, med_edge, med_area) -> bool:
    """Split a face at ``v`` along a diagonal from ``v`` that keeps the corners healthy (preferring one whose other
    end does not get four faces)."""
    best = None
    for fid in list(cx.vf[v]):
        f = cx.faces[fid]
        k = len(f)
        if k < 4:
            continue
        i = f.index(v)
        P, Q = cx.polygon(f), cx.points(f)
        for j in range(k):
            if (j - i) % k in (0, 1, k - 1) or not _diagonal_inside(P, i, j):
                continue
            new = np.r_[_split_angles3(P, Q, i, P[j], Q[j]), _split_angles3(P, Q, j, P[i], Q[i])]
            if new.min() < b.min_angle or new.max() > 180.0 - b.min_angle:
                continue
            lo, hi = min(i, j), max(i, j)
            pieces = [f[lo:hi + 1], f[hi:] + f[:lo + 1]]
            if max(len(q) for q in pieces) > b.max_face_size or not _sizes_ok(cx, pieces, b, med_edge, med_area):
                continue
            quality = float(np.minimum(new, 180.0 - new).min()) - 15.0 * sum(len(q) == 3 for q in pieces)
            u = f[j]
            if len(cx.vf[u]) == 3 and _ring(cx, u) is not None:
                quality -= 30.0  # the other end gets four faces: maybe far from conical, handled in the next pass
            if best is None or quality > best[0]:
                best = (quality, fid, pieces, f[j])
    if best is None:
        return False
    return cx.edit([best[1]], best[2])


def _relocate(cx: _Complex, v: int, b: _Bounds, lift: Callable, med_edge: float, med_area: float) -> bool:
    """Move an interior crossing with four faces in the plane (Gauss-Newton on its criterion measured with plane
    angles, steps under a fifth of its shortest edge) until the criterion is under half ``max_criterion``; kept when
    the 3D criterion is under ``max_criterion``, the corners of its faces within ``[min_angle, 180 − min_angle]``
    and its edges and areas above their bounds."""
    if cx.kind[v] != NODE_CROSSING:
        return False
    ring = _ring(cx, v)
    if ring is None or len(ring) != 4:
        return False
    fids = [g for g, _ in ring]
    faces = [cx.faces[g] for g in fids]
    p0 = cx.uv[v].copy()

    def criterion(p):  # in the plane
        cx.uv[v] = p
        w = np.radians([_interior_angles(cx.polygon(f))[f.index(v)] for f in faces])
        cx.uv[v] = p0
        return w[0] - w[1] + w[2] - w[3]

    reach = min(float(np.hypot(*(cx.uv[u] - p0))) for u in _neighbours(cx, v))
    p = p0.copy()
    c = criterion(p)
    for _ in range(12):
        eps = 1e-4 * reach
        g = np.array([(criterion(p + eps * e) - c) / eps for e in np.eye(2)])
        gg = float(g @ g)
        if gg <= 0.0:
            return False
        step = -c * g / gg
        n = float(np.hypot(*step))
        if n > 0.2 * reach:
            step *= 0.2 * reach / n
        p = p + step
        if float(np.hypot(*(p - p0))) > 0.6 * reach:
            return False
        c = criterion(p)
        if abs(c) < 0.5 * b.max_criterion:
            Xp, X0 = lift(p[None])[0], cx.X[v]
            cx.X[v], cx.uv[v] = Xp, p
            cx.forget_angles()
            ang3 = np.concatenate([cx.angles(f) for f in faces])
            ok = _criterion(cx, v) < b.max_criterion and b.min_angle <= ang3.min() and \
                ang3.max() <= 180.0 - b.min_angle
            cx.X[v], cx.uv[v] = X0, p0
            cx.forget_angles()
            if not ok or not _sizes_ok(cx, faces, b, med_edge, med_area, {v: Xp}) or \
                    not cx.edit(fids, faces, moved={v: p}):
                return False
            cx.X[v] = Xp
            cx.forget_angles()
            return True
    return False
