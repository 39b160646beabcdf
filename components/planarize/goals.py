"""Goals of the planarization solver as linearized residual blocks.

Every goal is a vector of residuals ``r(x)`` of the vertex positions ``x`` (flattened ``3 v + c``) with its sparse
Jacobian, evaluated at the current state. The solver stacks the blocks with their weights and solves one sparse
least-squares problem per iteration (Gauss-Newton). All quantities are in the solver's normalized units (mean edge
length 1), so the weights are scale-free.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.core.mesh import Corners, face_corners
from components.planarize.geometry import Stars, einsum_sum3, length3


class Block(NamedTuple):
    """Residuals ``r`` (q,) and the Jacobian as triplets ``(rows, cols, vals)`` (rows in ``0..q-1``)."""

    r: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    weight: float


def _triplets(rows_per, verts, grads):
    """Jacobian triplets from per-residual vertex lists ``verts (q, p)`` and gradients ``grads (q, p, 3)``."""
    q, p = verts.shape
    rows = np.repeat(np.arange(q), 3 * p)
    cols = (3 * verts[:, :, None] + np.arange(3)[None, None, :]).ravel()
    return rows, cols, grads.reshape(-1)


def planarity_residual(X: np.ndarray, Q4: np.ndarray) -> np.ndarray:
    """Signed scale-free diagonal distance of every (pseudo-)quad: the residual of :func:`planarity_block`."""
    Xc = np.ascontiguousarray(X.T)  # component by component (1-D gathers), the same operations as row-wise
    a, b, c, d = ([x[Q4[:, i]] for x in Xc] for i in range(4))
    d1 = [ci - ai for ci, ai in zip(c, a)]
    d2 = [di - bi for di, bi in zip(d, b)]
    cr = (d1[1] * d2[2] - d1[2] * d2[1], d1[2] * d2[0] - d1[0] * d2[2], d1[0] * d2[1] - d1[1] * d2[0])  # np.cross
    md = 0.5 * (length3(*d1) + length3(*d2))
    den = length3(*cr) * md
    vol = einsum_sum3(*((bi - ai) * ci for ai, bi, ci in zip(a, b, cr)))  # np.einsum("ij,ij->i", b - a, cr)
    return vol / np.where(den > 1e-300, den, 1e-300)


def planarity_block(X: np.ndarray, Q4: np.ndarray, weight: float) -> Block:
    """Scale-free diagonal-distance residual of quads (and of consecutive corner quadruples of n-gons).

    ``r = (b − a)·((c − a) × (d − b)) / (|(c − a) × (d − b)| · mean diagonal)``: the signed distance between the
    diagonals over the mean diagonal length, differentiated exactly (numerator and denominator). Being scale-free,
    it cannot be lowered by shrinking a quad, which is what keeps the Gauss-Newton steps from collapsing panels.
    """
    a, b, c, d = (X[Q4[:, i]] for i in range(4))
    e, d1, d2 = b - a, c - a, d - b
    cr = np.cross(d1, d2)
    vol = np.einsum("ij,ij->i", e, cr)
    l1 = np.linalg.norm(d1, axis=1)
    l2 = np.linalg.norm(d2, axis=1)
    md = 0.5 * (l1 + l2)
    ncr = np.linalg.norm(cr, axis=1)
    ncr = np.where(ncr > 1e-300, ncr, 1e-300)
    den = ncr * md
    r = vol / den
    ch = cr / ncr[:, None]
    gden1 = md[:, None] * np.cross(d2, ch) + 0.5 * ncr[:, None] * d1 / np.maximum(l1, 1e-300)[:, None]
    gden2 = md[:, None] * np.cross(ch, d1) + 0.5 * ncr[:, None] * d2 / np.maximum(l2, 1e-300)[:, None]
    inv = (1.0 / den)[:, None]
    ge = cr * inv
    g1 = np.cross(d2, e) * inv - r[:, None] * gden1 * inv
    g2 = np.cross(e, d1) * inv - r[:, None] * gden2 * inv
    grads = np.stack([-ge - g1, ge - g2, g1, g2], axis=1)
    rows, cols, vals = _triplets(4, Q4, grads)
    return Block(r, rows, cols, vals, weight)


def closeness_block(X: np.ndarray, idx: np.ndarray, C: np.ndarray, N: np.ndarray, weight: float) -> Block:
    """Point-to-plane distance of vertices ``idx`` to their closest points ``C`` with normals ``N``."""
    r = np.einsum("ij,ij->i", X[idx] - C, N)
    rows, cols, vals = _triplets(1, idx[:, None], N[:, None, :])
    return Block(r, rows, cols, vals, weight)


def start_block(X: np.ndarray, X0: np.ndarray, idx: np.ndarray, weight: float) -> Block:
    """Displacement of vertices ``idx`` from their start positions (three residuals per vertex)."""
    r = (X[idx] - X0[idx]).ravel()
    q = len(idx)
    rows = np.arange(3 * q)
    cols = (3 * idx[:, None] + np.arange(3)[None, :]).ravel()
    return Block(r, rows, cols, np.ones(3 * q), weight)


def _linear_vec_block(X, verts, coef, weight):
    """Residual ``Σ_j coef[j] · X[verts[:, j]]`` per coordinate (three residuals per row of ``verts``)."""
    q, p = verts.shape
    r = np.einsum("j,qjc->qc", coef, X[verts]).ravel()
    # residual row 3i + c depends on X[verts[i, j], c] with coefficient coef[j]
    rows = (3 * np.arange(q)[:, None, None] + np.arange(3)[None, None, :]).repeat(p, axis=1)  # (q, p, 3)
    cols = 3 * verts[:, :, None] + np.arange(3)[None, None, :]
    vals = np.broadcast_to(coef[None, :, None], (q, p, 3))
    return Block(r, rows.ravel(), cols.ravel(), np.ascontiguousarray(vals).ravel(), weight)


def fairness_block(X: np.ndarray, stars: Stars, mode: str, weight: float, nbr_lists=None) -> Block:
    """Discrete fairness: second differences along the mesh polylines, or the umbrella Laplacian.

    ``"polylines"``: ``a − 2 v + b`` for both pairs of opposite neighbours of interior valence-4 vertices and for the
    boundary neighbours of boundary vertices. ``"laplacian"``: ``v − mean(neighbours)`` at every vertex with
    neighbours (``nbr_lists`` = (vertex, neighbour, 1/valence) triplets).
    """
    if mode == "laplacian":
        vv, nb, wt = nbr_lists
        n_rows = len(np.unique(vv))
        uniq, row_of = np.unique(vv, return_inverse=True)
        r = X[uniq] - np.zeros((n_rows, 3))
        np.subtract.at(r, row_of, wt[:, None] * X[nb])
        rows = np.concatenate([3 * np.arange(n_rows)[:, None] + np.arange(3)[None, :],
                               3 * row_of[:, None] + np.arange(3)[None, :]]).ravel()
        cols = np.concatenate([3 * uniq[:, None] + np.arange(3)[None, :],
                               3 * nb[:, None] + np.arange(3)[None, :]]).ravel()
        vals = np.concatenate([np.ones((n_rows, 3)), np.repeat(-wt[:, None], 3, axis=1)]).ravel()
        return Block(r.ravel(), rows, cols, vals, weight)
    trip = [np.stack([stars.nbrs[:, 0], stars.center, stars.nbrs[:, 2]], axis=1),
            np.stack([stars.nbrs[:, 1], stars.center, stars.nbrs[:, 3]], axis=1),
            np.stack([stars.boundary_nbrs[:, 0], stars.boundary_center, stars.boundary_nbrs[:, 1]], axis=1)]
    verts = np.concatenate(trip).astype(np.int64)
    return _linear_vec_block(X, verts, np.array([1.0, -2.0, 1.0]), weight)


def edge_length_block(X: np.ndarray, E: np.ndarray, target: float, weight: float) -> Block:
    """Edge length minus the target length (the current mean length when ``target <= 0``)."""
    d = X[E[:, 1]] - X[E[:, 0]]
    L = np.linalg.norm(d, axis=1)
    t = L.mean() if target <= 0 else target
    u = d / np.where(L > 0, L, 1.0)[:, None]
    grads = np.stack([-u, u], axis=1)
    rows, cols, vals = _triplets(2, E, grads)
    return Block(L - t, rows, cols, vals, weight)


def area_block(X: np.ndarray, F: np.ndarray, corners: Corners, target: float, weight: float) -> Block:
    """Face area (norm of the Newell vector) minus the target (the current mean when ``target <= 0``)."""
    m = len(F)
    P, Pn = X[corners.v], X[corners.next]
    Avec = np.zeros((m, 3))
    np.add.at(Avec, corners.face, 0.5 * np.cross(P, Pn))
    area = np.linalg.norm(Avec, axis=1)
    nrm = Avec / np.where(area > 0, area, 1.0)[:, None]
    t = area.mean() if target <= 0 else target
    # d|A|/dv_i = 0.5 (v_next − v_prev) × n
    g = 0.5 * np.cross(X[corners.next] - X[corners.prev], nrm[corners.face])
    rows = np.repeat(corners.face, 3)
    cols = (3 * corners.v[:, None] + np.arange(3)[None, :]).ravel()
    return Block(area - t, rows, cols, g.ravel(), weight)


def _angle_and_grads(X, v, u, w):
    """Angle at ``v`` between ``u − v`` and ``w − v`` and its gradient w.r.t. ``v``, ``u``, ``w``."""
    a = X[u] - X[v]
    b = X[w] - X[v]
    la = np.linalg.norm(a, axis=1)
    lb = np.linalg.norm(b, axis=1)
    la = np.where(la > 0, la, 1e-300)
    lb = np.where(lb > 0, lb, 1e-300)
    ah, bh = a / la[:, None], b / lb[:, None]
    cos = np.einsum("ij,ij->i", ah, bh)
    sin = np.linalg.norm(np.cross(ah, bh), axis=1)
    theta = np.arctan2(sin, cos)
    s = np.maximum(sin, 1e-8)[:, None]
    ga = -(bh - cos[:, None] * ah) / (la[:, None] * s)
    gb = -(ah - cos[:, None] * bh) / (lb[:, None] * s)
    return theta, -(ga + gb), ga, gb


def conical_block(X: np.ndarray, corners: Corners, stars: Stars, weight: float) -> Block:
    """Angle criterion of conical meshes ``ω1 − ω2 + ω3 − ω4`` at interior valence-4 vertices (Liu et al. 2006)."""
    ring = stars.corners
    s = len(ring)
    r = np.zeros(s)
    verts = np.empty((s, 4, 3), dtype=np.int64)
    grads = np.empty((s, 4, 3, 3))
    for j in range(4):
        cj = ring[:, j]
        th, gv, gu, gw = _angle_and_grads(X, corners.v[cj], corners.prev[cj], corners.next[cj])
        sign = 1.0 if j % 2 == 0 else -1.0
        r += sign * th
        verts[:, j] = np.stack([corners.v[cj], corners.prev[cj], corners.next[cj]], axis=1)
        grads[:, j] = sign * np.stack([gv, gu, gw], axis=1)
    rows, cols, vals = _triplets(12, verts.reshape(s, 12), grads.reshape(s, 12, 3))
    return Block(r, rows, cols, vals, weight)


def turn_block(X: np.ndarray, corners: Corners, sel: np.ndarray, N: np.ndarray, target) -> Block:
    """Corner-turn guard rows ``turn − target`` for the corners ``sel`` (see
    :func:`components.planarize.geometry.corner_turns`), the face normals ``N`` held fixed.

    ``target`` is a number or one value per selected corner. Met as equalities they hold a corner that would
    otherwise fall below the bound at it: no quad collapses (angle → 0 or π) and none turns non-convex (a negative
    turn).
    """
    v, p, w = corners.v[sel], corners.prev[sel], corners.next[sel]
    a = X[v] - X[p]
    b = X[w] - X[v]
    n = N[corners.face[sel]]
    la2 = np.maximum(np.einsum("ij,ij->i", a, a), 1e-300)
    lb2 = np.maximum(np.einsum("ij,ij->i", b, b), 1e-300)
    den = np.sqrt(la2 * lb2)
    s = np.einsum("ij,ij->i", np.cross(a, b), n) / den
    ga = np.cross(b, n) / den[:, None] - (s / la2)[:, None] * a
    gb = np.cross(n, a) / den[:, None] - (s / lb2)[:, None] * b
    verts = np.stack([p, v, w], axis=1)
    rows, cols, vals = _triplets(3, verts, np.stack([-ga, ga - gb, gb], axis=1))
    return Block(s - target, rows, cols, vals, 1.0)


def sharpness_guard_block(X: np.ndarray, corners: Corners, sel: np.ndarray, target) -> Block:
    """Corner guard rows ``s − target`` for the corners ``sel``, ``s = min(θ, π − θ)`` the distance of the corner
    angle ``θ`` (between its two edges, in 3D) to 0° or 180°, differentiated exactly: no corner is pinched to a
    sliver nor flattened to a straight angle, whether its face is planar yet or not."""
    v, p, w = corners.v[sel], corners.prev[sel], corners.next[sel]
    theta, gv, gp, gw = _angle_and_grads(X, v, p, w)
    sign = np.where(theta <= 0.5 * np.pi, 1.0, -1.0)[:, None]
    s = np.minimum(theta, np.pi - theta)
    rows, cols, vals = _triplets(3, np.stack([p, v, w], axis=1), sign[:, None, :] * np.stack([gp, gv, gw], axis=1))
    return Block(s - target, rows, cols, vals, 1.0)


def edge_guard_block(X: np.ndarray, E: np.ndarray, sel: np.ndarray, target) -> Block:
    """Edge-length guard rows ``|x_b − x_a| − target`` for the edges ``E[sel]`` (``target``: a number or one per
    selected edge). Met as equalities they hold an edge that would otherwise fall below its bound: no edge
    collapses."""
    e = E[sel]
    d = X[e[:, 1]] - X[e[:, 0]]
    L = np.linalg.norm(d, axis=1)
    u = d / np.maximum(L, 1e-300)[:, None]
    rows, cols, vals = _triplets(2, e, np.stack([-u, u], axis=1))
    return Block(L - target, rows, cols, vals, 1.0)


def _area_vectors(X: np.ndarray, F: np.ndarray, faces: np.ndarray):
    """Corners, Newell area vectors and areas of the faces ``F[faces]``, the vectors summed about each face's first
    corner (no cancellation far from the origin)."""
    C = face_corners(F[faces])
    O = X[F[faces, 0]][C.face]
    Avec = np.zeros((len(faces), 3))
    np.add.at(Avec, C.face, 0.5 * np.cross(X[C.v] - O, X[C.next] - O))
    return C, Avec, np.linalg.norm(Avec, axis=1)


def _unit_normals(X: np.ndarray, F: np.ndarray, faces: np.ndarray):
    """Corners, unit Newell normals and areas (at least 1e-300) of the faces ``F[faces]`` (:func:`_area_vectors`)."""
    C, Avec, area = _area_vectors(X, F, faces)
    area = np.maximum(area, 1e-300)
    return C, Avec / area[:, None], area


def area_guard_block(X: np.ndarray, F: np.ndarray, sel: np.ndarray, target) -> Block:
    """Face-area guard rows ``|A| − target`` (``A``: the Newell area vector) for the faces ``F[sel]``: no panel
    shrinks to nothing. The rows come face by face, each corner's three columns together."""
    C, Avec, area = _area_vectors(X, F, sel)
    nrm = Avec / np.maximum(area, 1e-300)[:, None]
    g = 0.5 * np.cross(X[C.next] - X[C.prev], nrm[C.face])  # d|A|/dv = ½ (v_next − v_prev) × n
    rows = np.repeat(C.face, 3)
    cols = (3 * C.v[:, None] + np.arange(3)[None, :]).ravel()
    return Block(area - target, rows, cols, g.ravel(), 1.0)


def fold_guard_block(X: np.ndarray, F: np.ndarray, pairs: np.ndarray, target) -> Block:
    """Fold guard rows ``n1 · n2 − target`` for the face pairs ``pairs (q, 2)`` sharing an edge (``n``: unit Newell
    normals): two faces whose normals turn by nearly 180° have folded onto each other; held above the target,
    they cannot. ``d(n1·n2)/dv = ½ (v_next − v_prev) × u`` over the corners of each face, with
    ``u1 = (n2 − (n1·n2) n1) / |A1|`` (and the same for the second face); the shared vertices get both terms."""
    parts = []
    normals = [_unit_normals(X, F, pairs[:, side]) for side in (0, 1)]
    n1, n2 = normals[0][1], normals[1][1]
    dots = np.einsum("ij,ij->i", n1, n2)
    for (C, n, area), other in zip(normals, (n2, n1)):
        u = (other - dots[:, None] * n) / area[:, None]
        g = 0.5 * np.cross(X[C.next] - X[C.prev], u[C.face])
        parts.append((C.face, C.v, g))
    face = np.concatenate([p[0] for p in parts])
    order = np.argsort(face, kind="stable")
    verts = np.concatenate([p[1] for p in parts])[order]
    g = np.concatenate([p[2] for p in parts])[order]
    rows = np.repeat(face[order], 3)
    cols = (3 * verts[:, None] + np.arange(3)[None, :]).ravel()
    return Block(dots - target, rows, cols, g.ravel(), 1.0)


def flip_guard_block(X: np.ndarray, F: np.ndarray, faces: np.ndarray, R: np.ndarray, target) -> Block:
    """Flip guard rows ``n · r − target`` for the faces ``F[faces]`` (``n``: unit Newell normal, ``r (q, 3)``: the
    design surface's unit normal under each face, fixed): a face whose normal turns against the surface's has
    flipped; held above the target, it cannot. ``d(n·r)/dv = ½ (v_next − v_prev) × u`` over the corners of the
    face, ``u = (r − (n·r) n) / |A|``; the rows come face by face."""
    C, n, area = _unit_normals(X, F, faces)
    dots = np.einsum("ij,ij->i", n, R)
    u = (R - dots[:, None] * n) / area[:, None]
    g = 0.5 * np.cross(X[C.next] - X[C.prev], u[C.face])
    rows = np.repeat(C.face, 3)
    cols = (3 * C.v[:, None] + np.arange(3)[None, :]).ravel()
    return Block(dots - target, rows, cols, g.ravel(), 1.0)


def conical_residual(X: np.ndarray, corners: Corners, stars: Stars) -> np.ndarray:
    """``ω1 − ω2 + ω3 − ω4`` (radians) at every interior valence-4 vertex of ``stars``."""
    if len(stars.center) == 0:
        return np.zeros(0)
    return conical_block(X, corners, stars, 1.0).r
