"""Seamless global parametrization from a direction field: cut graph, transition functions, integer rounding.

Given per-triangle field directions ``U, W`` (unit tangent vectors standing for the 4-fold set ``±U, ±W``, not
necessarily orthogonal) and a target edge length ``h``, this module computes per-corner parameters ``UV (m, 3, 2)``
whose gradients follow the *dual* frame of the field, ``∇u ≈ U*/h`` and ``∇v ≈ W*/h`` (``U*·U = 1, U*·W = 0``…),
so that the iso-``v`` lines run along ``U``, the iso-``u`` lines along ``W`` and the integer iso-lines are ``h``
apart. The result is *seamless*: across every cut the two sides differ by a rotation by a multiple of 90° and an
integer translation, singular vertices sit at integer points and (with ``boundary="aligned"``) every boundary
stretch follows an integer iso-line, so the integer iso-lines close up into a quad mesh (see
:mod:`components.fields.extract`).

Steps (mixed-integer quadrangulation after Bommes, Zimmer & Kobbelt 2009, simplified for open surfaces):

1. *Matching*: across each interior edge, the rotation ``k ∈ {0, 1, 2, 3}`` (``U → W → −U → −W``) that best maps
   one face's frame onto its neighbour's (after unfolding the two triangles). Interior vertices around which the
   matchings do not add up to 0 mod 4 are singular.
2. *Cut graph*: from every singular vertex a shortest path to the boundary (paths vertex-disjoint), plus one path
   from every further boundary loop to the first, so the cut surface is a topological disk whose field has no
   holonomy. The field is *combed* (each face's frame rotated) so the matching is the identity off the cuts.
3. *Vertex copies*: corners are merged across uncut edges; a vertex on a cut has one copy per side. The copy on
   the right of a cut is eliminated: ``x_R = A·x_L + t`` with ``A`` the rotation of the cut and
   ``t = (I − A)·x_s`` (``x_s`` the singular vertex at the start of the cut) or a free translation for cuts
   between boundary loops.
4. *Least squares*: ``Σ_f area_f (|∇u − U*/h|² + |∇v − W*/h|²)`` plus, for an aligned boundary, a stiff penalty
   keeping each boundary stretch on one iso-line ``u = c`` or ``v = c`` (the family whose direction is closer
   to the boundary tangent, short runs merged). One sparse factorization.
5. *Greedy rounding*: singular positions, boundary constants and loop translations are rounded to integers,
   closest to an integer first, a batch at a time, re-solving the rest after each batch. The re-solves reuse the
   one factorization: with ``Z = M⁻¹E`` for the integer columns ``E`` (solved once for all densities), fixing a
   set ``S`` is a small dense Schur-complement solve on ``Z[S, S]``.

References
----------
D. Bommes, H. Zimmer, L. Kobbelt, "Mixed-integer quadrangulation", ACM Trans. Graph. (SIGGRAPH) 28(3), 2009.
F. Kälberer, M. Nieser, K. Polthier, "QuadCover — surface parameterization using branched coverings",
Computer Graphics Forum (Eurographics) 26(3), 2007.
Y. Liu, W. Xu, J. Wang, L. Zhu, B. Guo, F. Chen, G. Wang, "General planar quadrilateral mesh design using conjugate
direction field", ACM Trans. Graph. (SIGGRAPH Asia) 30(6), 2011 (non-orthogonal frames, the dual basis).
"""
from __future__ import annotations

import logging
import math
import time
from functools import partial
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, dijkstra
from scipy.sparse.linalg import splu

from components.core.blas import single_blas_thread
from components.core.checks import check_choice, check_mesh, check_number, pieces_error
from components.core.memo import ContentCache, digest
from components.core.curvature import face_principal_curvature, vertex_principal_curvature
from components.core.errors import InputError, MeshError
from components.core.measures import cross, unit
from components.core.mesh import boundary_loops, edge_topology, piece_count, triangulate
from components.core.parallel import concurrently
from components.core.types import Curves, Mesh, Points
from components.fields.extract import iso_segments
from components.fields.field import (closest_conjugate_pairs, conjugate_frame_field, field_curvature,
                                     smooth_frame_field, transferred_field)
from components.fields.remesh import decimate

log = logging.getLogger(__name__)

__all__ = [
    "Parametrization",
    "ParametrizeResult",
    "check_target_fits",
    "direction_field",
    "field_angle_error",
    "parametrize",
    "seamless_parametrization",
    "seamless_parametrizations",
    "iso_lines",
]

FIELDS = ("conjugate", "smooth", "principal")
BOUNDARY_MODES = ("aligned", "free")

# rotation by k quarter turns of the frame pair: (U, W) -> (W, -U) for k = 1; the parameters follow the same 2×2
# integer matrix: (u, v)_g = A_k (u, v)_f + t
_A = np.array(
    [[[1, 0], [0, 1]], [[0, 1], [-1, 0]], [[-1, 0], [0, -1]], [[0, -1], [1, 0]]], dtype=np.int64
)


def _rot_frame(U: np.ndarray, W: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotate frame pairs by ``k`` quarter turns: ``k = 1`` maps ``(U, W)`` to ``(W, −U)``."""
    k = np.mod(k, 4)
    # (U, W) -> (W, -U) -> (-U, -W) -> (-W, U): the first is P[k], the second P[k + 1] of P = (U, W, -U, -W)
    sign = np.where(k >= 2, -1.0, 1.0)[:, None]
    odd = (k % 2 == 1)[:, None]
    U2 = sign * np.where(odd, W, U)
    W2 = sign * np.where(odd, -U, W)
    return U2, W2


# ----------------------------------------------------------------------------------------------
# input checks


def check_target_fits(V: np.ndarray, T: np.ndarray, target: float, name: str = "target_length") -> None:
    """Raise :class:`~components.core.errors.InputError` when a panel size does not fit the surface ``(V, T)``.

    The size (already checked positive) must not exceed the surface's bounding-box diagonal, and the surface must
    not hold more than about two million panels of that size.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(2, 2)
    >>> check_target_fits(V, triangulate(Q)[0], 0.5)
    >>> check_target_fits(V, triangulate(Q)[0], 5.0)
    Traceback (most recent call last):
    ...
    components.core.errors.InputError: target_length: 5 is larger than the surface (1.41421 across): no quad fits
    """
    P = V[T].reshape(-1, 3)
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    if target > diag:
        raise InputError(name, f"{target:g} is larger than the surface ({diag:g} across): no quad fits")
    area = 0.5 * float(np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum())
    if area / target**2 > 2e6:
        raise InputError(name, f"{target:g} would give about {area / target**2:.3g} quads (limit 2e6); use at least "
                               f"{math.sqrt(area / 2e6):.3g}")


# ----------------------------------------------------------------------------------------------
# direction fields


def _smoothed_principal_field(V: np.ndarray, T: np.ndarray, alignment: float, constraints=None):
    """Principal directions smoothed as a 4-RoSy field (orthogonal; conjugate where it follows them).

    The ``"principal"`` field of :func:`direction_field`. Per face the cross is ``z = e^{4iθ}`` in the face frame;
    energy ``Σ_edges |z_g − r_e z_f|² + alignment · Σ_f a_f |z_f − z0_f|²`` with the connection ``r_e`` across
    each edge and ``a_f`` the curvature anisotropy.
    """
    m = len(T)
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    n = unit(np.cross(B - A, C - A))
    e1 = unit(B - A)
    e2 = np.cross(n, e1)
    PD1, PD2, k1, k2 = vertex_principal_curvature(V, T, radius=2)
    FD1, FD2, FK1, FK2 = face_principal_curvature(V, T, PD1, PD2, k1, k2)
    size = np.abs(FK1) + np.abs(FK2)
    aniso = np.abs(FK1 - FK2) / (size + 1e-12 * max(float(size.mean()), 1e-300))  # relative: units do not matter
    theta0 = np.arctan2(np.einsum("ij,ij->i", FD1, e2), np.einsum("ij,ij->i", FD1, e1))
    z0 = np.exp(4j * theta0)
    topo = edge_topology(T)
    inner = topo.count == 2
    E, EF = topo.E[inner], topo.EF[inner]
    d = unit(V[E[:, 1]] - V[E[:, 0]])
    f, g = EF[:, 0], EF[:, 1]
    af = np.arctan2(np.einsum("ij,ij->i", d, e2[f]), np.einsum("ij,ij->i", d, e1[f]))
    ag = np.arctan2(np.einsum("ij,ij->i", d, e2[g]), np.einsum("ij,ij->i", d, e1[g]))
    r = np.exp(4j * (ag - af))
    ne = len(E)
    rows = np.repeat(np.arange(ne), 2)
    cols = np.stack([f, g], axis=1).ravel()
    vals = np.stack([-r, np.ones(ne)], axis=1).ravel()
    D = sp.csr_matrix((vals, (rows, cols)), shape=(ne, m))
    area = 0.5 * np.linalg.norm(np.cross(B - A, C - A), axis=1)
    share = area / area.sum() * m
    w = alignment * aniso * share + 1e-6
    # a faint global pull to the x axis keeps flat regions defined
    x = np.array([1.0, 0.0, 0.0])
    xt = x - n * (n @ x)[:, None]
    bad = np.linalg.norm(xt, axis=1) < 1e-3
    xt[bad] = e1[bad]
    zx = np.exp(4j * np.arctan2(np.einsum("ij,ij->i", xt, e2), np.einsum("ij,ij->i", xt, e1)))
    target = (alignment * aniso * share * z0 + 1e-6 * zx) / w
    if constraints is not None:
        cf, cd = constraints
        tc = np.arctan2(np.einsum("ij,ij->i", cd, e2[cf]), np.einsum("ij,ij->i", cd, e1[cf]))
        target[cf] = (w[cf] * target[cf] + 100.0 * np.exp(4j * tc)) / (w[cf] + 100.0)
        w[cf] += 100.0
    M = (D.conj().T @ D + sp.diags(w)).tocsc()
    z = splu(M, permc_spec="MMD_AT_PLUS_A").solve(w * target)
    th = np.angle(z) / 4.0
    U = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    W = np.cross(n, U)
    return U, W


@single_blas_thread()  # sparse factorizations: see components.core.blas
def direction_field(V: np.ndarray, T: np.ndarray, field: str = "conjugate", alignment: float = 0.1,
                    constraints=None, release_separation: float | None = None,
                    resolution: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per-face field directions ``U, W`` for the parametrization (:mod:`components.fields.field`, or principal).

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles.
    field : {"conjugate", "smooth", "principal"}
        ``"conjugate"``: the smooth field made conjugate (:func:`~components.fields.field.conjugate_frame_field`);
        ``"smooth"``: the smooth field softly aligned to the principal directions
        (:func:`~components.fields.field.smooth_frame_field`); ``"principal"``: principal directions smoothed by
        this module's own 4-RoSy solve.
    alignment : float
        Weight of the pull towards the principal directions (smaller = smoother, fewer singularities).
    constraints : tuple (faces (c,), directions (c, 3)), optional
        Prescribed directions on some faces.
    release_separation : float, optional
        Passed to :func:`~components.fields.field.conjugate_frame_field` (its default when omitted).
    resolution : float, optional
        The smallest length (model units) the field must resolve, e.g. the panel size. Given, a mesh of more than
        :data:`TWO_LEVEL_FACES` triangles without constraints gets the ``"conjugate"`` or ``"smooth"`` field of a
        coarser copy (:func:`~components.fields.remesh.decimate` to about :data:`COARSE_FACES` triangles, its
        edges at most ``resolution / 1.25``), carried to its faces
        (:func:`~components.fields.field.transferred_field`) and, for ``"conjugate"``, made conjugate face by face
        (:func:`~components.fields.field.closest_conjugate_pairs`): the field varies on the surface's scale, not
        the mesh's, and its solves grow faster than the mesh (the 500k-triangle benchmark patch: 41 s and 3.4 GB →
        18 s).

    Returns
    -------
    U, W : (m, 3) float64
        Unit tangent directions, ``W`` counter-clockwise from ``U``.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(6, 6, height=lambda x, y: 0.3 * x * y)
    >>> T = triangulate(Q)[0]
    >>> U, W = direction_field(V, T, field="smooth")
    >>> U.shape == (len(T), 3), bool(np.allclose(np.linalg.norm(W, axis=1), 1.0))
    (True, True)
    """
    if field == "principal":
        return _smoothed_principal_field(V, T, alignment, constraints)
    extra = {} if release_separation is None else {"release_separation": release_separation}
    edge = _coarse_edge(V, T, resolution) if constraints is None else None
    if edge is not None:
        # the coarse copy and the mesh's own curvature (for its conjugate pairs) at the same time, on two cores
        (Vc, Tc), cv = concurrently(partial(decimate, V, T, edge),
                                    partial(field_curvature, V, T) if field == "conjugate" else lambda: None)
        log.debug("direction_field: the field of a %d-triangle copy (edge %.3g)", len(Tc), edge)
        Uc, Wc = direction_field(Vc, Tc, field=field, alignment=alignment, release_separation=release_separation)
        U, W = transferred_field(V, T, Vc, Tc, Uc, Wc)
        if field == "conjugate":  # conjugate face by face on the mesh itself, as the field's own last step
            U, W = closest_conjugate_pairs(V, T, U, W, curvature=cv, **extra)
        return U, W
    cv = field_curvature(V, T)  # once for both fields
    # the directions only: the fields' singularities and errors are not needed here
    fld = smooth_frame_field(V, T, alignment=alignment, constraints=constraints, curvature=cv, diagnostics=False)
    if field == "conjugate":
        fld = conjugate_frame_field(V, T, fld.U, fld.W, constraints=constraints, curvature=cv, diagnostics=False,
                                    **extra)
    return np.asarray(fld.U, dtype=np.float64), np.asarray(fld.W, dtype=np.float64)


# direction_field: meshes above this many triangles get a coarse copy's field. Measured 2026-12 on the benchmark
# patch (benchmarks/fields.py): at 500k triangles the mesh's own field takes 41 s and 3.4 GB, the coarse copy's 18 s
# (pq_from_conjugate_field 87 s, 2.9 GB); at 200k 13-14 s against 6-7 s, and over 23 seeds of the 200k patch the
# pipeline took 34.9 s on average against 42.0 s, but its best-ranked candidates were healthy after repair less
# often (11 of 23 kept the nominal density, against 16 of 22) and 3 results fell short (2 unhealthy, 1 not
# converged) against 1: below this size the mesh's own field is affordable and the better one.
TWO_LEVEL_FACES = 300_000
COARSE_FACES = 50_000  # ... decimated to about this many triangles
_COARSE_MIN = 1.25  # ... only when that makes its edges at least this × the mesh's mean edge


def _coarse_edge(V: np.ndarray, T: np.ndarray, resolution: float | None) -> float | None:
    """The edge length of the coarse copy of a large mesh for :func:`direction_field`'s field, or None (small
    mesh, no resolution given, or no real coarsening within it)."""
    m = len(T)
    if resolution is None or m <= TWO_LEVEL_FACES:
        return None
    mean_edge = float(np.mean(np.linalg.norm(V[T] - V[np.roll(T, -1, axis=1)], axis=2)))
    edge = min(mean_edge * np.sqrt(m / COARSE_FACES), float(resolution) / 1.25)
    return edge if edge >= _COARSE_MIN * mean_edge else None


# ----------------------------------------------------------------------------------------------
# cut graph, combing, copies


class _Topology(NamedTuple):
    H: np.ndarray  # (3m, 2) half-edges, index 3f + i goes from corner i to corner i+1
    twin: np.ndarray  # (3m,) opposite half-edge or -1 on the boundary
    n: np.ndarray  # (m, 3) unit normals
    area: np.ndarray  # (m,)
    E: np.ndarray  # (e, 2) undirected edges (edge_topology)


def _topology(V: np.ndarray, T: np.ndarray) -> _Topology:
    m = len(T)
    H = np.stack([T.ravel(), np.roll(T, -1, axis=1).ravel()], axis=1)
    topo = edge_topology(T)
    he = topo.HE
    order = np.argsort(he, kind="stable")
    twin = np.full(3 * m, -1, dtype=np.int64)
    hs = he[order]
    pair = np.nonzero(hs[1:] == hs[:-1])[0]
    a, b = order[pair], order[pair + 1]
    twin[a] = b
    twin[b] = a
    N = cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    area = 0.5 * np.linalg.norm(N, axis=1)
    return _Topology(H, twin, unit(N), area, topo.E)


def _matchings(V, T, tp: _Topology, U, W) -> np.ndarray:
    """Per half-edge ``h`` (face f) with a twin (face g): ``k`` with ``frame_g ≈ R_k(frame_f)``."""
    m = len(T)
    h = np.nonzero(tp.twin >= 0)[0]
    f = h // 3
    g = tp.twin[h] // 3
    d = unit(V[tp.H[h, 1]] - V[tp.H[h, 0]])
    # unfold g's vectors into f's plane: components along the edge and along n × d
    bf = cross(tp.n[f], d)  # np.cross's numbers, cheaper
    bg = cross(tp.n[g], d)

    def carry(X):
        a = np.einsum("ij,ij->i", X, d)
        b = np.einsum("ij,ij->i", X, bg)
        return a[:, None] * d + b[:, None] * bf

    Ug, Wg = carry(U[g]), carry(W[g])
    Uf, Wf = U[f], W[f]
    uu = np.einsum("ij,ij->i", Uf, Ug) + np.einsum("ij,ij->i", Wf, Wg)
    wu = np.einsum("ij,ij->i", Wf, Ug) - np.einsum("ij,ij->i", Uf, Wg)
    # score of R_r(frame_f) against frame_g: r = 0: uu, 1: wu, 2: -uu, 3: -wu (the first best wins ties)
    k = np.argmax(np.stack([uu, wu, -uu, -wu], axis=1), axis=1).astype(np.int64)
    out = np.full(3 * m, -1, dtype=np.int64)
    out[h] = k
    return out


def _singular_vertices(T, tp: _Topology, match: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Interior vertices whose matchings around do not sum to 0 mod 4, and that sum."""
    bnd = np.zeros(n, dtype=bool)
    bnd[tp.H[tp.twin < 0].ravel()] = True
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    total = np.zeros(n, dtype=np.int64)
    ok = tp.twin >= 0
    np.add.at(total, tp.H[ok, 0], match[ok])
    total = np.mod(total, 4)
    sing = np.nonzero(used & ~bnd & (total != 0))[0]
    return sing, total[sing]


def _cut_paths(V, T, tp: _Topology, sing: np.ndarray, loops: list[np.ndarray]) -> tuple[list, list, list[str]]:
    """Vertex-disjoint shortest paths: singular vertex → boundary, and boundary loop k → loop 0.

    Returns ``paths`` (lists of vertices, singular or loop start first), ``kinds`` ("sing" / "loop") and warnings.
    """
    n = len(V)
    E = tp.E
    L = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)
    bnd = np.zeros(n, dtype=bool)
    for lp in loops:
        bnd[lp] = True
    blocked = np.zeros(n, dtype=bool)
    blocked[sing] = True
    paths, kinds, warnings = [], [], []

    def shortest(src, targets_mask, through_mask):
        """Path from src (list of sources) to the nearest vertex of targets_mask through vertices of through_mask."""
        a, b = E[:, 0], E[:, 1]
        ok_ab = through_mask[a] & ~blocked[b] & (through_mask[b] | targets_mask[b])
        ok_ba = through_mask[b] & ~blocked[a] & (through_mask[a] | targets_mask[a])
        rows = np.concatenate([a[ok_ab], b[ok_ba]])
        cols = np.concatenate([b[ok_ab], a[ok_ba]])
        w = np.concatenate([L[ok_ab], L[ok_ba]])
        G = sp.csr_matrix((w, (rows, cols)), shape=(n, n))
        dist, pred, _ = dijkstra(G, directed=True, indices=src, return_predecessors=True, min_only=True)
        cand = np.nonzero(targets_mask & np.isfinite(dist))[0]
        if len(cand) == 0:
            return None
        t = int(cand[np.argmin(dist[cand])])
        path = [t]
        while pred[path[-1]] >= 0:
            path.append(int(pred[path[-1]]))
        return path[::-1]

    # extra boundary loops first (they make the surface a disk), then singularities nearest the boundary first
    for lp in loops[1:]:
        src_mask = np.zeros(n, dtype=bool)
        src_mask[lp] = True
        tgt = np.zeros(n, dtype=bool)
        tgt[loops[0]] = True
        tgt &= ~blocked
        through = ~bnd & ~blocked
        through_src = through | src_mask
        p = shortest(np.asarray(lp), tgt, through_src)
        if p is None:
            warnings.append("a boundary loop could not be connected to the outer boundary by a cut")
            continue
        # the path may run along its own loop at first: start at the last loop vertex on it
        start = max(i for i, v in enumerate(p) if src_mask[v])
        p = p[start:]
        blocked[p] = True
        paths.append(p)
        kinds.append("loop")
    if len(sing):
        tgt_all = bnd.copy()
        Gd = None
        order = sing
        if len(sing) > 1:
            a, b = E[:, 0], E[:, 1]
            Gd = sp.csr_matrix((np.concatenate([L, L]), (np.concatenate([a, b]), np.concatenate([b, a]))),
                               shape=(n, n))
            dist = dijkstra(Gd, directed=False, indices=np.nonzero(bnd)[0], min_only=True)
            order = sing[np.argsort(dist[sing], kind="stable")]
        for s in order.tolist():
            blocked[s] = False
            through = ~bnd & ~blocked
            p = shortest(s, tgt_all & ~blocked, through)
            if p is None:
                blocked[s] = True
                warnings.append(f"singular vertex {s} could not be cut to the boundary (enclosed by other cuts)")
                continue
            blocked[p] = True
            paths.append(p)
            kinds.append("sing")
    return paths, kinds, warnings


class _Cuts(NamedTuple):
    cut_he: np.ndarray  # (3m,) bool: half-edge lies on a cut (both sides marked)
    comb: np.ndarray  # (m,) quarter turns applied to each face's frame
    copy: np.ndarray  # (3m,) copy index of every corner
    ncopies: int
    left: np.ndarray  # (r,) left copy of each eliminated (right) copy relation
    right: np.ndarray  # (r,) right copy
    rot: np.ndarray  # (r,) rotation k of the relation x_R = A_k x_L + t
    cut_of: np.ndarray  # (r,) index of the cut
    cut_kind: list  # per cut: "sing" or "loop"
    cut_source: np.ndarray  # per cut: copy of the singular vertex (or -1)
    paths: list
    inconsistent: int


def _build_cuts(V, T, tp: _Topology, match: np.ndarray, paths: list, kinds: list) -> _Cuts:
    m = len(T)
    # half-edge lookup by directed vertex pair
    n = len(V)
    key = tp.H[:, 0] * n + tp.H[:, 1]
    order = np.argsort(key)
    skey = key[order]

    def find(a, b):
        k = a * n + b
        i = np.searchsorted(skey, k)
        ok = (i < len(skey)) & (skey[np.minimum(i, len(skey) - 1)] == k)
        return np.where(ok, order[np.minimum(i, len(skey) - 1)], -1)

    cut_he = np.zeros(3 * m, dtype=bool)
    path_left = []
    for p in paths:
        p = np.asarray(p, dtype=np.int64)
        hl = find(p[:-1], p[1:])  # face on the left of the travel direction
        hr = find(p[1:], p[:-1])
        if np.any(hl < 0) or np.any(hr < 0):
            raise MeshError("mesh", "a cut runs along a boundary edge (internal error)")
        cut_he[hl] = True
        cut_he[hr] = True
        path_left.append((hl, hr))
    # combing: BFS over the dual graph without the cuts
    inner = (tp.twin >= 0) & ~cut_he
    h = np.nonzero(inner)[0]
    G = sp.csr_matrix((np.ones(len(h)), (h // 3, tp.twin[h] // 3)), shape=(m, m))
    ncomp, lab = connected_components(G, directed=False)
    # the BFS trees (one per piece): each face's parent and the matching from the parent to it
    up = np.arange(m)  # roots are their own parents
    k_up = np.zeros(m, dtype=np.int64)
    for root in np.unique(lab, return_index=True)[1]:
        nodes, pred = breadth_first_order(G, int(root), directed=False, return_predecessors=True)
        # matching from parent to child: look up half-edge of parent whose twin is in child
        child = nodes[1:]
        par = pred[child]
        # find half-edges of par with twin face == child (uncut)
        cand = 3 * par[:, None] + np.arange(3)[None, :]
        tw = tp.twin[cand]
        hit = (tw >= 0) & (tw // 3 == child[:, None]) & inner[cand]
        j = np.argmax(hit, axis=1)
        up[child] = par
        k_up[child] = match[cand[np.arange(len(child)), j]]
    # c_child = c_parent - k: c = −(the sum of k from the root) mod 4, the sums by pointer doubling
    while True:
        k_up = k_up + k_up[up]  # the sum from up (exclusive) to the face; a root's sum is 0
        up2 = up[up]
        if np.array_equal(up2, up):
            break
        up = up2
    comb = np.mod(-k_up, 4)
    # matchings after combing: k' = k + c_g - c_f
    hh = np.nonzero(tp.twin >= 0)[0]
    kc = np.full(3 * m, -1, dtype=np.int64)
    kc[hh] = np.mod(match[hh] + comb[tp.twin[hh] // 3] - comb[hh // 3], 4)
    inconsistent = int(np.count_nonzero(kc[inner] != 0) // 2)
    # vertex copies: merge corners across uncut interior edges; corner of half-edge h is its 'from' vertex
    hi = np.nonzero(inner)[0]
    t = tp.twin[hi]
    nxt = lambda x: 3 * (x // 3) + (x + 1) % 3  # noqa: E731
    a1, a2 = hi, nxt(t)  # from-vertex of h == to-vertex of twin
    b1, b2 = nxt(hi), t
    rows = np.concatenate([a1, b1])
    cols = np.concatenate([a2, b2])
    C = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * m, 3 * m))
    ncopies, copy = connected_components(C, directed=False)
    # relations across the cuts: x_R = A x_L + t
    left, right, rot, cut_of, src = [], [], [], [], []
    for ci, (hl, hr) in enumerate(path_left):
        k = kc[hl]  # rotation from the left face to the right face
        # vertices: from of hl == to of hr, to of hl == from of hr
        ls = np.concatenate([copy[hl], copy[nxt(hl)]])
        rs = np.concatenate([copy[nxt(hr)], copy[hr]])
        ks = np.concatenate([k, k])
        keep = ls != rs
        pairs = np.unique(np.stack([ls[keep], rs[keep], ks[keep]], axis=1), axis=0)
        left.append(pairs[:, 0])
        right.append(pairs[:, 1])
        rot.append(pairs[:, 2])
        cut_of.append(np.full(len(pairs), ci))
        src.append(int(copy[hl[0]]) if kinds[ci] == "sing" else -1)
    cat = lambda xs: np.concatenate(xs).astype(np.int64) if xs else np.zeros(0, np.int64)  # noqa: E731
    return _Cuts(cut_he, comb, copy.astype(np.int64), int(ncopies), cat(left), cat(right), cat(rot), cat(cut_of),
                 list(kinds), np.asarray(src, dtype=np.int64), paths, inconsistent)


# ----------------------------------------------------------------------------------------------
# the least-squares system


def _dual_targets(U: np.ndarray, W: np.ndarray, n: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Dual basis ``U*, W*`` of the (projected) frame in each face plane, times ``scale``."""
    U = unit(U - n * np.einsum("ij,ij->i", U, n)[:, None])
    W = unit(W - n * np.einsum("ij,ij->i", W, n)[:, None])
    g11 = np.einsum("ij,ij->i", U, U)
    g12 = np.einsum("ij,ij->i", U, W)
    g22 = np.einsum("ij,ij->i", W, W)
    det = g11 * g22 - g12 * g12
    det = np.where(np.abs(det) < 1e-6, 1e-6, det)
    Us = (g22[:, None] * U - g12[:, None] * W) / det[:, None]
    Ws = (-g12[:, None] * U + g11[:, None] * W) / det[:, None]
    return scale * Us, scale * Ws


def _gradient_operator(V: np.ndarray, T: np.ndarray, tp: _Topology, cols: np.ndarray, ncols: int) -> sp.csr_matrix:
    """``(3m, ncols)``: gradient of a piecewise-linear function given per corner column ``cols (m, 3)``."""
    m = len(T)
    P = V[T]
    G = np.empty((m, 3, 3))
    for i in range(3):
        e = P[:, (i + 2) % 3] - P[:, (i + 1) % 3]
        G[:, i] = cross(tp.n, e) / (2.0 * tp.area[:, None])
    rows = (3 * np.arange(m)[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)  # (m, corner, xyz)
    cc = np.broadcast_to(cols[:, :, None], (m, 3, 3))
    return sp.csr_matrix((G.ravel(), (rows.ravel(), cc.ravel())), shape=(3 * m, ncols))


class _Boundary(NamedTuple):
    seg_copy: np.ndarray  # (b,) copies constrained
    seg_coord: np.ndarray  # (b,) which coordinate (0 = u, 1 = v) is constant
    seg_id: np.ndarray  # (b,) segment of the constraint
    nseg: int


def _boundary_segments(V, T, tp: _Topology, cuts: _Cuts, U, W, loops, target: float, min_run: float,
                       free_angle: float | None = None) -> _Boundary:
    """Label each boundary edge with the field family closest to it and group runs into segments.

    With ``free_angle`` (radians), runs of edges farther than that from both families (after merging runs
    shorter than ``min_run``) are left unconstrained.
    """
    n = len(V)
    bh = np.nonzero(tp.twin < 0)[0]
    key = tp.H[bh, 0]
    hof = np.full(n, -1, dtype=np.int64)
    hof[key] = bh  # boundary half-edge leaving each boundary vertex (manifold boundary: unique)
    Uc, Wc = _rot_frame(U, W, cuts.comb)
    copies, coords, segs = [], [], []
    nseg = 0
    nxt = lambda x: 3 * (x // 3) + (x + 1) % 3  # noqa: E731
    for lp in loops:
        hs = hof[lp]
        f = hs // 3
        d = unit(V[tp.H[hs, 1]] - V[tp.H[hs, 0]])
        cu = np.abs(np.einsum("ij,ij->i", d, unit(Uc[f])))
        cw = np.abs(np.einsum("ij,ij->i", d, unit(Wc[f])))
        # along U: v is constant (coordinate 1); along W: u is constant (coordinate 0)
        lab = np.where(cu >= cw, 1, 0)
        ln = np.linalg.norm(V[tp.H[hs, 1]] - V[tp.H[hs, 0]], axis=1)
        ca = cuts.copy[hs]
        cb = cuts.copy[nxt(hs)]
        # geometric label: in the combed frame of each face. Across a cut the frame rotates, so compare labels
        # only within continuous copy chains; a break in copies starts a new segment.
        brk = np.roll(cb, 1) != ca  # edge i starts a new chain
        lab = _merge_short_runs(lab, ln, brk, min_run)
        start = brk | (np.roll(lab, 1) != lab)
        keep = np.ones(len(hs), dtype=bool)
        if free_angle is not None:
            off = np.arccos(np.clip(np.maximum(cu, cw), 0.0, 1.0)) > free_angle
            keep = ~_merge_short_runs(off.astype(np.int64), ln, brk, min_run).astype(bool)
            start = start | (np.roll(keep, 1) != keep)
        if not start.any():
            start[0] = True
        first = int(np.argmax(start))
        sid = np.cumsum(np.roll(start, -first)) - 1
        sid = np.roll(sid, first) + nseg
        nseg += int(sid.max() - nseg + 1)
        copies += [ca[keep], cb[keep]]
        coords += [lab[keep], lab[keep]]
        segs += [sid[keep], sid[keep]]
    if not copies:
        z = np.zeros(0, dtype=np.int64)
        return _Boundary(z, z, z, 0)
    seg_copy = np.concatenate(copies)
    seg_coord = np.concatenate(coords)
    seg_id = np.concatenate(segs)
    u = np.unique(np.stack([seg_copy, seg_coord, seg_id], axis=1), axis=0)
    return _Boundary(u[:, 0], u[:, 1], u[:, 2], nseg)


def _merge_short_runs(lab: np.ndarray, ln: np.ndarray, brk: np.ndarray, min_run: float) -> np.ndarray:
    """Flip runs of one label shorter than ``min_run`` (between label changes) to the neighbours' label."""
    lab = lab.copy()
    nb = len(lab)
    for _ in range(nb):
        change = np.roll(lab, 1) != lab
        if not change.any():
            break
        first = int(np.argmax(change))
        idx = np.roll(np.arange(nb), -first)
        runs = np.cumsum(change[idx]) - 1
        rlen = np.bincount(runs, weights=ln[idx])
        nrun = len(rlen)
        if nrun <= 2:
            # two runs only: a loop needs at least 4 turns; leave it
            break
        r = int(np.argmin(rlen))
        if rlen[r] >= min_run:
            break
        lab[idx[runs == r]] = 1 - lab[idx[runs == r]]
    return lab


class Parametrization(NamedTuple):
    """Result of :func:`seamless_parametrization`.

    ``UV (m, 3, 2)`` per-corner parameters in units of the target length, ``U, W (m, 3)`` the combed field,
    ``singularities (k,)`` singular vertices, ``singularity_turns (k,)`` their matching sum mod 4 (1 or 3: a
    quarter turn, 2: half), ``cut_edges (c, 2)`` the cut graph, ``angle_error (m,)`` per face in radians,
    ``flipped`` count of triangles whose parameter image is inverted, ``seam_gap`` largest mismatch of the
    transition functions (0 up to rounding: exact by construction), ``boundary_gap`` largest distance (grid units)
    of a boundary vertex from its integer iso-line (the stiff penalty's residual, removed by snapping except at cut
    ends),
    ``copy (m, 3)`` vertex copy of every corner, ``warnings``, ``timings``, ``scale`` the global factor applied
    (size centering × density: the iso-lines are ``target_length / scale`` apart where the field is followed
    exactly).
    """

    UV: np.ndarray
    U: np.ndarray
    W: np.ndarray
    singularities: np.ndarray
    singularity_turns: np.ndarray
    cut_edges: np.ndarray
    angle_error: np.ndarray
    flipped: int
    seam_gap: float
    boundary_gap: float
    copy: np.ndarray
    warnings: list
    timings: dict
    scale: float = 1.0


def _triangle_edges(V: np.ndarray, T: np.ndarray):
    """``e1 = x1 − x0`` and ``e2 = x2 − x0`` of every triangle (the surface side of :func:`_parameter_tangents`)."""
    return V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]


def _parameter_tangents(edges, UV: np.ndarray, eps: float = 0.0):
    """Per face ``∂x/∂u, ∂x/∂v`` (the columns of ``[e1 e2] · [d1 d2]⁻¹``, ``edges = (e1, e2)`` from
    :func:`_triangle_edges`), the parameter triangle's doubled signed area ``det`` and its scale ``|d1|₁ |d2|₁``;
    faces with ``|det| ≤ eps`` get tangents as if ``det`` were 1 (callers mask them)."""
    e1, e2 = edges
    d1 = UV[:, 1] - UV[:, 0]
    d2 = UV[:, 2] - UV[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    safe = np.where(np.abs(det) > eps, det, 1.0)[:, None]
    # x_u = (e1 d2v - e2 d1v) / det, x_v = (-e1 d2u + e2 d1u) / det
    xu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / safe
    xv = (-e1 * d2[:, 0:1] + e2 * d1[:, 0:1]) / safe
    return xu, xv, det, np.abs(d1).sum(1) * np.abs(d2).sum(1)


def field_angle_error(V: np.ndarray, T: np.ndarray, UV: np.ndarray, U: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Per-face angle (radians) between the parametrization's iso-lines and the field directions.

    The iso-``v`` line through a face runs along ``∂x/∂u`` and the iso-``u`` line along ``∂x/∂v`` (the columns of
    the inverse Jacobian); the error is the larger of their line angles to ``U`` and ``W``.

    Parameters
    ----------
    V : (n, 3) float64
    T : (m, 3) int64
    UV : (m, 3, 2) float64
        Per-corner parameters.
    U, W : (m, 3) float64
        The (combed) field the parametrization was built from.

    Returns
    -------
    (m,) float64
        Angle in radians (π/2 for a degenerate parameter triangle).
    """
    return _angle_error(_triangle_edges(V, T), UV, unit(U), unit(W))


def _angle_error(edges, UV: np.ndarray, Uu: np.ndarray, Wu: np.ndarray) -> np.ndarray:
    """:func:`field_angle_error` from the triangles' edge vectors (:func:`_triangle_edges`) and the unit field
    directions: what the densities of one parametrization share is computed once."""
    xu, xv, det, _ = _parameter_tangents(edges, UV, eps=1e-14)
    ok = np.abs(det) > 1e-14

    def line_angle(a, ub):
        c = np.abs(np.einsum("ij,ij->i", unit(a), ub))
        return np.arccos(np.clip(c, 0.0, 1.0))

    err = np.maximum(line_angle(xu, Uu), line_angle(xv, Wu))
    return np.where(ok, err, np.pi / 2)


def seamless_parametrization(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray, target_length: float,
                             boundary: str = "aligned", boundary_weight: float = 1e4, min_run: float = 1.5,
                             round_batch: float = 0.1, center_sizes: bool = True, density: float = 1.0,
                             free_angle: float | None = None) -> Parametrization:
    """Seamless integer-grid parametrization of a triangle mesh following a 4-fold direction field.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles, consistently oriented, edge-manifold, with at least one boundary loop and genus 0 (a disk or a
        disk with holes).
    U, W : (m, 3) float64
        Per-face field directions (any of the four in each face; need not be orthogonal or combed).
    target_length : float
        Spacing of the integer iso-lines in model units (> 0).
    boundary : {"aligned", "free"}
        ``"aligned"``: each boundary stretch follows an integer iso-line of the family closest to it (boundary
        cells are whole quads); ``"free"``: the boundary is left free (iso-lines end on it).
    boundary_weight : float
        Stiffness of the boundary alignment relative to the field-fitting energy.
    min_run : float
        Boundary stretches shorter than ``min_run · target_length`` take the family of their neighbours.
    round_batch : float
        Fraction of the remaining integer variables rounded per greedy step (0 rounds one at a time).
    center_sizes : bool
        Choose the global scale (within a factor 1.25 of ``1 / target_length``) that puts the most surface area
        under iso-line spacings within ±25% of the target, instead of the scale whose mean spacing is the target:
        a field that cannot be followed with a constant spacing (curvature, non-integrability) stretches some
        regions and compresses others, and the centering keeps the spread around the target.
    density : float
        Extra factor on the global scale (1.1 = 10% more iso-lines in each direction), applied after centering.
    free_angle : float, optional
        With ``boundary="aligned"``: boundary stretches farther than this angle (radians) from both field
        families are left free instead of being forced onto an iso-line (a mixed boundary).

    Returns
    -------
    Parametrization

    Raises
    ------
    MeshError
        A closed surface or one with handles (genus > 0).
    InputError
        Bad target length or mode.

    Notes
    -----
    Mixed-integer quadrangulation (Bommes, Zimmer & Kobbelt 2009) with cuts from the singularities to the
    boundary; the non-orthogonal frame is followed through its dual basis (Liu et al. 2011). See the module notes.
    """
    return seamless_parametrizations(V, T, U, W, target_length, (density,), boundary=boundary,
                                     boundary_weight=boundary_weight, min_run=min_run, round_batch=round_batch,
                                     center_sizes=center_sizes, free_angle=free_angle)[0]


@single_blas_thread()  # sparse factorizations: see components.core.blas
def seamless_parametrizations(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray, target_length: float,
                              densities=(1.0,), boundary: str = "aligned", boundary_weight: float = 1e4,
                              min_run: float = 1.5, round_batch: float = 0.1, center_sizes: bool = True,
                              free_angle: float | None = None) -> list[Parametrization]:
    """:func:`seamless_parametrization` at several densities, sharing everything the density does not change.

    The matching, cuts, assembly, factorization and relaxed solution depend on the density only through a final
    scale, so they are computed once; each density then has its own rounding. Every result is the one
    :func:`seamless_parametrization` gives for that density; the shared seconds are in the first one's timings.
    The cut graph and the field-fitting energy depend only on the mesh and the field, not on the boundary mode:
    those of the last field are remembered (keyed by the arrays' contents), so a second call on the same field
    (the candidate's other boundary mode) skips them.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(6, 6, 3.0, 3.0)
    >>> T = triangulate(Q)[0]
    >>> U, W = np.tile([1.0, 0.0, 0.0], (len(T), 1)), np.tile([0.0, 1.0, 0.0], (len(T), 1))
    >>> pars = seamless_parametrizations(V, T, U, W, 1.0, densities=(1.0, 2.0), boundary="free")
    >>> [round(float(np.ptp(p.UV[..., 0])), 6) for p in pars]  # twice the density: twice the iso-lines
    [3.0, 6.0]
    """
    timings = {}
    t0 = time.perf_counter()
    V, T, U, W, target, bw, _, free_angle = _checked_inputs(V, T, U, W, target_length, boundary, boundary_weight,
                                                            1.0, free_angle)
    densities = [check_number(d, "density", 0, above=True) for d in densities]
    m = len(T)
    fc = _field_cuts(V, T, U, W)
    tp, loops, W, sing, turns, kinds, cuts, Uc, Wc = (fc.tp, fc.loops, fc.W, fc.sing, fc.turns, fc.kinds, fc.cuts,
                                                      fc.Uc, fc.Wc)
    warnings0 = list(fc.warnings)
    timings["matching"], timings["cut_graph"] = fc.seconds if fc.fresh else (0.0, 0.0)
    t2 = time.perf_counter()
    bd = _aligned_boundary(V, T, tp, cuts, U, W, loops, target, min_run * target, free_angle,
                           active=boundary == "aligned" and bw > 0)
    lay = _layout(cuts, kinds, bd.nseg)
    P = _copy_map(cuts, kinds, lay)
    corner_copy = cuts.copy.reshape(m, 3)
    M, b = _normal_equations(fc.energy, target, P, bd, bw, lay)
    timings["assemble"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    lu = splu(M, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    y_relaxed = lu.solve(b)
    center = 1.0
    if center_sizes:  # every constraint is homogeneous: the relaxed solution for h / s is s times this one
        center = _centering_scale(V, T, (P @ y_relaxed).reshape(2, lay.nc).T[corner_copy], target, tp.area)
    ints = _integer_columns(cuts, kinds, lay)
    Z = _rounding_basis(lu, lay.ny, ints)
    timings["factor_solve"] = time.perf_counter() - t3
    cut_edges = fc.cut_edges
    shared = time.perf_counter() - t0
    edges, Uu, Wu = _triangle_edges(V, T), unit(Uc), unit(Wc)  # for the angle errors
    out = []
    for density in densities:
        t4 = time.perf_counter()
        scale = center * density
        y0 = y_relaxed * scale
        y = _greedy_round(Z, y0, ints, round_batch)
        tm = dict(timings) if not out else {k: 0.0 for k in timings}
        tm["rounding"] = time.perf_counter() - t4
        warnings = list(warnings0)
        X, boundary_gap, seam_gap = _copy_parameters(P, y, cuts, kinds, lay, bd)
        UV = X[corner_copy]
        d1 = UV[:, 1] - UV[:, 0]
        d2 = UV[:, 2] - UV[:, 0]
        flipped = int(np.count_nonzero(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] <= 0))
        if flipped:
            warnings.append(f"{flipped} triangles are inverted in the parametrization (the field is hard to follow "
                            "there)")
        err = _angle_error(edges, UV, Uu, Wu)  # field_angle_error(V, T, UV, Uc, Wc)
        tm["total"] = time.perf_counter() - t4 + (shared if not out else 0.0)
        log.debug("seamless_parametrization: %d faces, %d singularities, %d integer variables, %.3fs", m, len(sing),
                  len(ints), tm["total"])
        out.append(Parametrization(UV, Uc.copy(), Wc.copy(), sing.copy(), turns.copy(), cut_edges.copy(), err, flipped,
                                   seam_gap, boundary_gap, corner_copy.copy(), warnings, tm, scale))
    return out


class _FieldCuts(NamedTuple):
    """What :func:`seamless_parametrizations` derives from the mesh and the field alone (not from the boundary
    mode, target or densities): topology, boundary loops, the right-handed ``W``, singularities, cut graph and the
    combed frames ``Uc, Wc``; ``seconds`` (matching, cut graph) and ``fresh`` (computed by this call, not
    remembered)."""

    tp: _Topology
    loops: list
    W: np.ndarray
    sing: np.ndarray
    turns: np.ndarray
    paths: list
    kinds: list
    warnings: list
    cuts: _Cuts
    Uc: np.ndarray
    Wc: np.ndarray
    cut_edges: np.ndarray
    energy: tuple
    seconds: tuple
    fresh: bool = True


_CUTS = ContentCache("field cut graphs")  # the last field's cut graph


def _field_cuts(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray) -> _FieldCuts:
    """:class:`_FieldCuts` of a mesh and field. The last one is remembered (keyed by the arrays' contents): the
    candidate parametrizes one field in two boundary modes, and the cut graph is the same for both."""
    built = []
    out = _CUTS.get(digest(V, T, U, W), lambda: built.append(True) or _built_cuts(V, T, U, W))
    return out if built else out._replace(fresh=False)


def _built_cuts(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray) -> _FieldCuts:
    t0 = time.perf_counter()
    tp = _topology(V, T)
    loops = _disk_boundary_loops(V, T, tp.E)
    # right-handed frames: W on the counter-clockwise side of U (the cross (±U, ±W) is unchanged)
    W = np.where((np.einsum("ij,ij->i", np.cross(U, W), tp.n) < 0)[:, None], -W, W)
    match = _matchings(V, T, tp, U, W)
    sing, turns = _singular_vertices(T, tp, match, len(V))
    t1 = time.perf_counter()
    paths, kinds, warnings = _cut_paths(V, T, tp, sing, loops)
    cuts = _build_cuts(V, T, tp, match, paths, kinds)
    if cuts.inconsistent:
        warnings.append(f"{cuts.inconsistent} edges keep a field mismatch off the cuts (uncut singularities)")
    Uc, Wc = _rot_frame(U, W, cuts.comb)
    pieces = [np.stack([np.asarray(p[:-1]), np.asarray(p[1:])], axis=1) for p in paths if len(p) > 1]
    cut_edges = np.concatenate(pieces).astype(np.int64) if pieces else np.zeros((0, 2), dtype=np.int64)
    energy = _copy_energy(V, T, tp, cuts.copy.reshape(len(T), 3), cuts.ncopies, Uc, Wc)
    out = _FieldCuts(tp, loops, W, sing, turns, paths, kinds, warnings, cuts, Uc, Wc, cut_edges, energy,
                     (t1 - t0, time.perf_counter() - t1))
    return out


def _checked_inputs(V, T, U, W, target_length, boundary, boundary_weight, density, free_angle):
    """The inputs of :func:`seamless_parametrization` as arrays and checked numbers."""
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    U = np.asarray(U, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    target = check_number(target_length, "target_length", 0, above=True)
    check_choice(boundary, "boundary", BOUNDARY_MODES)
    bw = check_number(boundary_weight, "boundary_weight", 0)
    density = check_number(density, "density", 0, above=True)
    if free_angle is not None:
        free_angle = check_number(free_angle, "free_angle", 0)
    m = len(T)
    if U.shape != (m, 3) or W.shape != (m, 3):
        raise InputError("field", f"U and W must have shape ({m}, 3), got {U.shape} and {W.shape}")
    return V, T, U, W, target, bw, density, free_angle


def _disk_boundary_loops(V: np.ndarray, T: np.ndarray, E: np.ndarray | None = None) -> list:
    """Boundary loops of a connected disk with holes; :class:`MeshError` for a closed surface, several pieces or
    handles (genus > 0). ``E``: the mesh's edges when known."""
    n, m = len(V), len(T)
    loops = boundary_loops(T)
    if not loops:
        raise MeshError("mesh", "the surface is closed: the parametrization needs an open surface (a boundary)")
    ne = len(edge_topology(T).E if E is None else E)
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    nused = int(np.count_nonzero(used))  # vertices of the triangles
    chi = nused - ne + m
    ncomp = piece_count(T, n)
    if ncomp != 1:
        raise pieces_error(V, T, ncomp, "parametrize them one at a time")
    genus2 = 2 - len(loops) - chi
    if genus2 != 0:
        raise MeshError("mesh", f"the surface has handles (genus {genus2 / 2:g}); only disks with holes are supported")
    return loops


def _aligned_boundary(V, T, tp: _Topology, cuts: _Cuts, U, W, loops, target: float, min_run: float,
                      free_angle: float | None, active: bool) -> _Boundary:
    """The boundary segments that follow an iso-line (:func:`_boundary_segments`), numbered from 0; none unless
    ``active``."""
    if not active:
        z = np.zeros(0, dtype=np.int64)
        return _Boundary(z, z, z, 0)
    bd = _boundary_segments(V, T, tp, cuts, U, W, loops, target, min_run, free_angle)
    if bd.nseg:  # renumber the segments that kept constraints
        uq, inv = np.unique(bd.seg_id, return_inverse=True)
        bd = bd._replace(seg_id=inv.astype(np.int64), nseg=len(uq))
    return bd


class _Layout(NamedTuple):
    """Columns of the unknowns ``y``: free copies (2 each), loop translations (2 each), boundary constants (1 each)."""

    nc: int  # vertex copies
    elim: np.ndarray  # (nc,) bool: the copy is eliminated (the right side of a cut)
    col_of: np.ndarray  # (nc,) index of each free copy among the free copies (-1 when eliminated)
    nfree: int  # free copies
    tcol: dict  # loop cut → first column of its translation
    ccol0: int  # first column of the boundary constants
    ny: int  # unknowns


def _layout(cuts: _Cuts, kinds: list, nseg: int) -> _Layout:
    nc = cuts.ncopies
    elim = np.zeros(nc, dtype=bool)
    elim[cuts.right] = True
    free = np.nonzero(~elim)[0]
    col_of = np.full(nc, -1, dtype=np.int64)
    col_of[free] = np.arange(len(free))
    nfree = len(free)
    loop_cuts = [i for i, k in enumerate(kinds) if k == "loop"]
    tcol = {ci: 2 * nfree + 2 * j for j, ci in enumerate(loop_cuts)}
    ccol0 = 2 * nfree + 2 * len(loop_cuts)
    return _Layout(nc, elim, col_of, nfree, tcol, ccol0, ccol0 + nseg)


def _copy_map(cuts: _Cuts, kinds: list, lay: _Layout) -> sp.csr_matrix:
    """``P (2 nc, ny)``: row ``q`` gives ``u`` of copy ``q``, row ``nc + q`` its ``v``, from the unknowns; an
    eliminated copy is ``x_R = A x_L + t`` with ``t = (I − A) x_s`` (singular cut) or a free translation (loop)."""
    nc, col_of = lay.nc, lay.col_of
    free = np.nonzero(~lay.elim)[0]
    rows = [free, nc + free]
    cols = [2 * col_of[free], 2 * col_of[free] + 1]
    vals = [np.ones(lay.nfree), np.ones(lay.nfree)]
    if len(cuts.right):
        A = _A[cuts.rot]  # (r, 2, 2)
        R, Lc = cuts.right, cuts.left
        for a in range(2):
            for b in range(2):
                # x_R[a] += A[a, b] x_L[b]
                rows.append(a * nc + R)
                cols.append(2 * col_of[Lc] + b)
                vals.append(A[:, a, b].astype(float))
        for ci in range(len(kinds)):
            sel = cuts.cut_of == ci
            if not sel.any():
                continue
            Rs = R[sel]
            As = A[sel]
            if kinds[ci] == "sing":
                s = cuts.cut_source[ci]
                IA = np.eye(2)[None] - As
                for a in range(2):
                    for b in range(2):
                        rows.append(a * nc + Rs)
                        cols.append(np.full(len(Rs), 2 * col_of[s] + b))
                        vals.append(IA[:, a, b])
            else:
                for a in range(2):
                    rows.append(a * nc + Rs)
                    cols.append(np.full(len(Rs), lay.tcol[ci] + a))
                    vals.append(np.ones(len(Rs)))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * nc, lay.ny))


def _copy_energy(V, T, tp: _Topology, corner_copy: np.ndarray, ncopies: int, Uc, Wc):
    """The field-fitting energy per coordinate in the vertex copies, for ``target = 1``: ``K = Gᵀ A G`` (the
    area-weighted gradient Gram matrix, ``(nc, nc)``) and ``Gᵀ A U*``, ``Gᵀ A W*`` (``A`` the face areas, ``G`` the
    per-face gradient, ``U*, W*`` the dual frame), so that ``Σ_f area_f |∇u − U*/h|²`` is
    ``uᵀ K u − 2 uᵀ Gᵀ A U* / h + const``."""
    G = _gradient_operator(V, T, tp, corner_copy, ncopies)
    Us, Ws = _dual_targets(Uc, Wc, tp.n, 1.0)
    a3 = np.repeat(tp.area, 3)
    GtA = (G.T @ sp.diags(a3)).tocsr()
    return (GtA @ G).tocsr(), GtA @ Us.ravel(), GtA @ Ws.ravel()


def _normal_equations(energy, target: float, P: sp.csr_matrix, bd: _Boundary, bw: float,
                      lay: _Layout) -> tuple[sp.csc_matrix, np.ndarray]:
    """``M y = b`` of the least-squares energy (area-weighted gradient fit to the dual frame over ``target``:
    :func:`_copy_energy`, the stiff boundary penalty with weight ``bw``) in the unknowns, one free copy pinned."""
    K, gU, gW = energy
    nc = lay.nc
    Pu, Pv = P[:nc], P[nc:]
    M = (Pu.T @ (K @ Pu) + Pv.T @ (K @ Pv)).tocsr()
    b = (Pu.T @ gU + Pv.T @ gW) / target
    if bd.nseg:
        nb = len(bd.seg_copy)
        # rows: w (x[copy][coord] - c_seg)
        Prow = P[bd.seg_coord * lay.nc + bd.seg_copy]
        S = sp.csr_matrix((np.ones(nb), (np.arange(nb), lay.ccol0 + bd.seg_id)), shape=(nb, lay.ny))
        D = (Prow - S).tocsr()
        M = M + bw * (D.T @ D)
    # the energy is invariant under a global translation of the parameters: pin one free copy (no bias)
    diag_scale = float(M.diagonal().mean()) if lay.ny else 1.0
    pin = np.zeros(lay.ny)
    if lay.nfree:
        pin[[0, 1]] = diag_scale
    return (M + sp.diags(pin)).tocsc(), b


def _integer_columns(cuts: _Cuts, kinds: list, lay: _Layout) -> np.ndarray:
    """Unknowns rounded to integers: singular positions, loop translations, boundary constants."""
    ints = []
    for ci, k in enumerate(kinds):
        if k == "sing":
            s = cuts.cut_source[ci]
            ints += [2 * lay.col_of[s], 2 * lay.col_of[s] + 1]
        else:
            ints += [lay.tcol[ci], lay.tcol[ci] + 1]
    ints += list(range(lay.ccol0, lay.ny))
    return np.asarray(ints, dtype=np.int64)


def _copy_parameters(P: sp.csr_matrix, y: np.ndarray, cuts: _Cuts, kinds: list, lay: _Layout, bd: _Boundary):
    """Parameters ``X (nc, 2)`` of every copy from the rounded unknowns ``y``: boundary constants and singular
    vertices snapped to their integers, eliminated copies re-derived from their (snapped) left copies so the seams
    stay exact. Also the boundary gap (largest distance of a boundary copy from its integer line before snapping,
    and of an eliminated boundary copy after) and the seam residual."""
    nc = lay.nc
    x = P @ y
    X = np.stack([x[:nc], x[nc:]], axis=1)
    if bd.nseg:
        cval = np.round(y[lay.ccol0:])
        X[bd.seg_copy, bd.seg_coord] = cval[bd.seg_id]
        gap = 0.0 if not len(bd.seg_copy) else float(np.max(np.abs(
            np.stack([x[:nc], x[nc:]], axis=1)[bd.seg_copy, bd.seg_coord] - cval[bd.seg_id])))
    else:
        gap = 0.0
    for ci, k in enumerate(kinds):
        if k == "sing":
            s = cuts.cut_source[ci]
            X[s] = np.round(X[s])
    seam_gap = resid = 0.0
    if len(cuts.right):
        A = _A[cuts.rot].astype(float)
        tr = np.zeros((len(cuts.right), 2))
        for ci, k in enumerate(kinds):
            sel = cuts.cut_of == ci
            if k == "sing":
                s = cuts.cut_source[ci]
                tr[sel] = X[s] - np.einsum("rij,j->ri", A[sel], X[s])
            else:
                tr[sel] = np.round(y[[lay.tcol[ci], lay.tcol[ci] + 1]])
        X[cuts.right] = np.einsum("rij,rj->ri", A, X[cuts.left]) + tr
        # the eliminated copies on an aligned boundary follow their left copies exactly (seams stay exact); how far
        # they are from their own segment's integer line is reported
        if bd.nseg:
            onb = lay.elim[bd.seg_copy]
            seam_gap = float(np.max(np.abs(X[bd.seg_copy[onb], bd.seg_coord[onb]]
                                           - np.round(y[lay.ccol0:])[bd.seg_id[onb]]), initial=0.0))
        resid = float(np.max(np.abs(X[cuts.right] - np.einsum("rij,rj->ri", A, X[cuts.left]) - tr)))
    return X, max(gap, seam_gap), resid


def _centering_scale(V, T, UV, target: float, area: np.ndarray, spread: float = 0.25,
                     limit: float = 1.25) -> float:
    """Global factor ``s`` on the relaxed parameters maximizing the area whose iso-line spacings lie within
    ``±spread`` of the target (ties: the factor closest to 1).

    Per face the spacings are ``|∂x/∂u|`` and ``|∂x/∂v|`` (model units per unit parameter) of the affine map from
    the parameter triangle to the surface triangle; scaling the parameters by ``s`` divides them by ``s``.
    """
    xu, xv, det, size = _parameter_tangents(_triangle_edges(V, T), UV, eps=1e-300)
    ok = det > 1e-12 * (size + 1e-300)
    if np.count_nonzero(ok) < 3:
        return 1.0
    lens = np.concatenate([np.linalg.norm(xu[ok], axis=1), np.linalg.norm(xv[ok], axis=1)]) / target
    w = np.concatenate([area[ok], area[ok]])
    cand = np.exp(np.linspace(-np.log(limit), np.log(limit), 81))
    # area with c (1 − spread) ≤ lens ≤ c (1 + spread), for every candidate c at once (prefix sums)
    order = np.argsort(lens)
    ls = lens[order]
    cw = np.concatenate([[0.0], np.cumsum(w[order])])
    score = cw[np.searchsorted(ls, cand * (1.0 + spread), side="right")] - cw[np.searchsorted(ls, cand * (1.0 - spread))]
    best = np.nonzero(score >= score.max() * (1 - 1e-9))[0]
    return float(cand[best[np.argmin(np.abs(np.log(cand[best])))]])


def _rounding_basis(lu, ny: int, ints: np.ndarray) -> np.ndarray:
    """``Z = M⁻¹ E`` ``(ny, k)`` for the unit columns ``E`` of the integer variables (one solve for all densities)."""
    k = len(ints)
    E = np.zeros((ny, k))
    E[ints, np.arange(k)] = 1.0
    return lu.solve(E) if k else E


def _greedy_round(Z: np.ndarray, y0: np.ndarray, ints: np.ndarray, batch: float) -> np.ndarray:
    """Round the integer variables greedily (closest to an integer first), re-solving the others each time.

    With ``Z = M⁻¹ E`` (:func:`_rounding_basis`), fixing a set ``S`` to values ``d`` gives ``y = y0 − Z[:, S] λ``
    with ``Z[S, S] λ = y0[S] − d`` (Lagrange multipliers of the constraints ``y_S = d``).
    """
    k = len(ints)
    if k == 0:
        return y0
    Zi = Z[ints]  # (k, k)
    y0i = y0[ints]
    fixed = np.zeros(k, dtype=bool)
    d = np.zeros(k)
    lam = np.zeros(0)
    cur = y0i.copy()
    while not fixed.all():
        free = np.nonzero(~fixed)[0]
        dist = np.abs(cur[free] - np.round(cur[free]))
        take = max(1, int(np.ceil(batch * len(free)))) if batch > 0 else 1
        pick = free[np.argsort(dist, kind="stable")[:take]]
        d[pick] = np.round(cur[pick])
        fixed[pick] = True
        S = np.nonzero(fixed)[0]
        lam = np.linalg.lstsq(Zi[np.ix_(S, S)], y0i[S] - d[S], rcond=None)[0]
        cur = y0i - Zi[:, S] @ lam
    S = np.nonzero(fixed)[0]
    y = y0 - Z[:, S] @ lam
    y[ints] = d
    return y


# ----------------------------------------------------------------------------------------------
# display


def iso_lines(V: np.ndarray, T: np.ndarray, UV: np.ndarray) -> list[np.ndarray]:
    """Integer iso-line pieces of a per-corner parametrization, one 2-point polyline per triangle crossing.

    Parameters
    ----------
    V : (n, 3) float64
    T : (m, 3) int64
    UV : (m, 3, 2) float64

    Returns
    -------
    list of (2, 3) float64 arrays
        Segments of the lines ``u = i`` and ``v = j`` inside each triangle.
    """
    S = iso_segments(V, T, UV)
    return [s for s in S]


# ----------------------------------------------------------------------------------------------
# published component


class ParametrizeResult(NamedTuple):
    iso_lines: Curves
    uv_mesh: Mesh
    singularities: Points
    mean_angle_error: float
    max_angle_error: float
    flipped_triangles: int
    warnings: list[str]


def parametrize(mesh: Mesh, target_length: float, field: str = "conjugate", alignment: float = 0.1,
                boundary: str = "aligned") -> ParametrizeResult:
    """Seamless quad parametrization of a surface mesh following a conjugate (or smooth) direction field.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``: an open, oriented, manifold mesh (triangles or polygons), a disk or a disk
        with holes.
    target_length : float
        Panel size: spacing of the integer iso-lines in model units.
    field : str
        Direction field to follow: ``"conjugate"`` (planar quads), ``"smooth"`` (smooth field softly aligned
        to the principal directions) or ``"principal"`` (this module's own smoothed principal directions).
    alignment : float
        Weight of the field's pull towards the principal curvature directions (smaller = smoother field, fewer
        singularities).
    boundary : str
        ``"aligned"`` (boundary stretches follow integer iso-lines) or ``"free"``.

    Returns
    -------
    iso_lines : Curves
        The integer iso-lines as short polylines (one per triangle crossing), for display.
    uv_mesh : Mesh
        The cut parameter domain as a flat mesh (``z = 0``, ``u, v`` times the target length), one vertex per
        triangle corner.
    singularities : Points
        Positions of the field's singular vertices.
    mean_angle_error : float
        Area-weighted mean angle (degrees) between the iso-lines and the field directions.
    max_angle_error : float
        Largest per-face angle error (degrees).
    flipped_triangles : int
        Triangles whose parameter image is inverted (0 for a valid parametrization).

    Raises
    ------
    MeshError
        Malformed, non-manifold, degenerate or closed mesh, or one with handles.
    InputError
        Non-positive target length, unknown field or boundary mode, negative alignment.

    Notes
    -----
    Mixed-integer quadrangulation after Bommes, Zimmer & Kobbelt 2009 (cuts from the singularities to the
    boundary, greedy rounding), following the dual frame of a possibly non-orthogonal field (Liu et al. 2011).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    >>> res = parametrize((V, F), target_length=2.0)
    >>> res.mean_angle_error < 10, res.flipped_triangles
    (True, 0)
    """
    target = check_number(target_length, "target_length", 0, above=True)
    check_choice(field, "field", FIELDS)
    alignment = check_number(alignment, "alignment", 0)
    check_choice(boundary, "boundary", BOUNDARY_MODES)
    V, F = check_mesh(mesh)
    T, _ = triangulate(F)
    check_target_fits(V, T, target)
    U, W = direction_field(V, T, field=field, alignment=alignment)
    par = seamless_parametrization(V, T, U, W, target, boundary=boundary)
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    mean_err = float(np.degrees(np.sum(par.angle_error * area) / area.sum()))
    max_err = float(np.degrees(par.angle_error.max()))
    m = len(T)
    uvV = np.concatenate([par.UV.reshape(-1, 2) * (target / par.scale), np.zeros((3 * m, 1))], axis=1)
    uvF = np.arange(3 * m, dtype=np.int64).reshape(m, 3)
    return ParametrizeResult(iso_lines(V, T, par.UV), (uvV, uvF), V[par.singularities], mean_err, max_err,
                             par.flipped, list(par.warnings))
