"""Catmull-Clark subdivision of quad-dominant polygon meshes, with crease/corner boundaries.

One subdivision step is a sparse matrix ``S`` of shape ``(n + e + m, n)``: the new vertices are ``S @ V``, in
the order *vertex points* (the old vertices, same indices), *edge points* (one per undirected edge, in
:func:`components.core.mesh.edge_topology` order) and *face points* (one per face). Every face of ``k`` corners
becomes ``k`` quads, so after one level the mesh is all quads, and old vertex ``i`` keeps index ``i`` at every
level (corners, irregular vertices and user marks stay addressable).

Rules (Catmull & Clark 1978; boundary rules of Hoppe et al. 1994 / DeRose et al. 1998):

* face point: the centroid of the face corners;
* interior edge point: ``(a + b + f₁ + f₂) / 4`` with ``f₁, f₂`` the two new face points;
* interior vertex point of valence ``n``: ``((n − 2) P + Σ eⱼ / n + Σ fⱼ / n) / n`` with ``eⱼ`` the edge
  neighbours and ``fⱼ`` the new face points around it;
* boundary (``boundary="crease"``): boundary edges are creases: edge point = midpoint, boundary vertex
  ``3/4 P + 1/8 (a + b)`` with ``a, b`` its boundary neighbours, so every boundary polyline is refined as a
  uniform cubic B-spline control polygon and the subdivided net ends on the boundary curve of the coarse net;
* corners: boundary vertices of valence 2 (one face), boundary vertices where the boundary turns by more than
  ``corner_angle``, boundary vertices with more than two boundary edges, and user-given indices stay fixed; a
  boundary span between two corners is an open cubic B-spline that interpolates the corners;
* ``boundary="linear"``: every boundary vertex stays and boundary edges are split at their midpoints, so the
  boundary polygon is kept exactly (use it when the coarse boundary already lies on the surface boundary).

On a regular grid the scheme is the tensor product of the 1D cubic B-spline refinement (with fixed ends on the
boundary): bicubic B-spline knot insertion, exactly. :func:`subdivided_mesh` is the array-level function,
:func:`catmull_clark` the published component. :func:`limit_positions` gives the limit-surface position
of every vertex of an all-quad mesh (the limit stencil ``(n² P + 4 Σ eⱼ + Σ dⱼ) / (n (n + 5))``).

References
----------
E. Catmull, J. Clark, "Recursively generated B-spline surfaces on arbitrary topological meshes",
*Computer-Aided Design* 10(6):350-355, 1978.
H. Hoppe et al., "Piecewise smooth surface reconstruction", SIGGRAPH 1994 (crease and corner rules).
T. DeRose, M. Kass, T. Truong, "Subdivision surfaces in character animation", SIGGRAPH 1998.
J. Stam, "Exact evaluation of Catmull-Clark subdivision surfaces at arbitrary parameter values", SIGGRAPH 1998
(eigenstructure, limit stencils).
H. Pottmann, A. Schiftner, P. Bo, H. Schmiedhofer, W. Wang, N. Baldassini, J. Wallner, "Freeform surfaces from
single curved panels", and Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang, "Geometric modeling with conical
meshes and developable surfaces", SIGGRAPH 2006 (subdivide a coarse net, then planarize).
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from components.core.checks import check_choice, check_int, check_number, validate_mesh
from components.core.errors import InputError
from components.core.mesh import edge_topology, face_sizes, halfedges
from components.core.types import Integers, Mesh

log = logging.getLogger(__name__)

MAX_LEVELS = 64  # more levels are refused before any count or work (4^63 × the corners: no memory holds them)

__all__ = [
    "BOUNDARY_RULES",
    "DEFAULT_CORNER_ANGLE",
    "MAX_FACES",
    "MAX_LEVELS",
    "LevelInfo",
    "SubdivisionInfo",
    "SubdivisionStep",
    "CatmullClarkResult",
    "catmull_clark",
    "control_mesh",
    "face_count_after",
    "limit_positions",
    "subdivided_mesh",
    "subdivision_step",
]

BOUNDARY_RULES = ("crease", "linear")
DEFAULT_CORNER_ANGLE = float(np.pi / 3)  # a boundary turning by more than 60° is a corner
MAX_FACES = 2_000_000


class LevelInfo(NamedTuple):
    """Counts and irregular vertices of one subdivision level (level 0 is the input).

    ``vertex_count``, ``edge_count``, ``face_count`` ints; ``irregular_vertices (r,) int64`` the interior
    vertices whose valence is not 4; ``irregular_valences (r,) int64`` their valences.
    """

    level: int
    vertex_count: int
    edge_count: int
    face_count: int
    irregular_vertices: np.ndarray
    irregular_valences: np.ndarray


class SubdivisionInfo(NamedTuple):
    """What :func:`subdivided_mesh` reports: one :class:`LevelInfo` per level ``0..L`` and the corner vertices."""

    levels: list
    corners: np.ndarray  # (c,) int64 vertex indices kept fixed (valid at every level: old indices persist)


class SubdivisionStep(NamedTuple):
    """One Catmull-Clark step: ``V_new = S @ V``, the new quads and the corners carried to the new mesh."""

    S: sp.csr_matrix  # (n + e + m, n)
    Q: np.ndarray  # (h, 4) int64, h = sum of face sizes
    corners: np.ndarray  # (c,) int64


# ----------------------------------------------------------------------------------------------
# checks


def face_count_after(F: np.ndarray, levels: int) -> int:
    """Number of faces after ``levels`` Catmull-Clark steps (``m`` for 0, ``Σ sizes · 4^(levels−1)`` after).

    Parameters
    ----------
    F : (m, k) int64
        Padded polygon faces.
    levels : int
        Number of subdivision levels (≥ 0).

    Returns
    -------
    int
        Exact face count (a Python int, so huge ``levels`` do not overflow).

    Examples
    --------
    >>> face_count_after(np.array([[0, 1, 2, 3], [1, 4, 2, 2]]), 2)
    28
    """
    F = np.asarray(F)
    if levels == 0:
        return int(len(F))
    return int(face_sizes(F).sum()) * 4 ** (int(levels) - 1)


def _check_corners(corners, n: int, name: str = "corners") -> np.ndarray:
    if corners is None:
        return np.zeros(0, dtype=np.int64)
    try:
        C = np.asarray(corners).ravel()
        if C.size and not np.issubdtype(C.dtype, np.integer):
            if not np.all(np.isfinite(C.astype(float))) or np.any(C != np.round(C)):
                raise InputError(name, "vertex indices must be whole numbers")
        C = C.astype(np.int64)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(name, f"are not vertex indices ({exc})") from None
    bad = (C < 0) | (C >= n)
    if bad.any():
        raise InputError(name, f"index {int(C[np.argmax(bad)])} is out of range 0..{n - 1}")
    return np.unique(C)


def control_mesh(V, F, name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """Validate a user's coarse control mesh for subdivision and return it in canonical form.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Control vertices.
    F : (m, k) array_like of int
        Polygon faces (quads, triangles, n-gons), short faces padded by repeating their last vertex.
    name : str
        Name of the input in error messages.

    Returns
    -------
    V : (n, 3) float64
    F : (m, k) int64

    Raises
    ------
    MeshError
        Bad shape, NaN, index out of range, degenerate face, a non-manifold edge (more than two faces), or
        inconsistently oriented (flipped) faces; the message names the input and the offending face or edge.

    Examples
    --------
    >>> from components.core.mesh import quad_grid
    >>> V, F = control_mesh(*quad_grid(2, 2), name="coarse")
    >>> V.dtype, F.dtype, F.shape
    (dtype('float64'), dtype('int64'), (4, 4))
    """
    return validate_mesh(V, F, name=name, kind="any", allow_degenerate=False, manifold=True)


# ----------------------------------------------------------------------------------------------
# topology classification shared by the step and the limit stencils


class _Topology(NamedTuple):
    H: np.ndarray  # (h, 2) half-edges
    HF: np.ndarray  # (h,) face of each half-edge
    HE: np.ndarray  # (h,) edge of each half-edge
    E: np.ndarray  # (e, 2)
    EF: np.ndarray  # (e, 2)
    interior_edge: np.ndarray  # (e,) bool
    B: np.ndarray  # (b, 2) directed boundary half-edges
    valence: np.ndarray  # (n,) edges per vertex
    interior: np.ndarray  # (n,) bool: used, not on the boundary
    corner: np.ndarray  # (n,) bool: boundary vertex kept fixed
    smooth_boundary: np.ndarray  # (n,) bool: boundary vertex on a crease (B-spline rule)


def _topology(V, F, n, boundary, corners, corner_angle) -> _Topology:
    H, HF = halfedges(F)
    E, EF, count, HE = edge_topology(F)
    interior_edge = count == 2
    B = H[count[HE] == 1]
    valence = np.bincount(E.ravel(), minlength=n).astype(np.int64)
    bcount = np.bincount(B.ravel(), minlength=n)  # each boundary vertex: one in, one out → 2
    on_boundary = bcount > 0
    corner = np.zeros(n, dtype=bool)
    corner[corners] = True
    corner &= on_boundary
    corner |= on_boundary & ((bcount != 2) | (valence <= 2))
    if boundary == "linear":
        corner |= on_boundary
    elif V is not None and corner_angle < np.pi and len(B):
        # turning angle between the incoming and the outgoing boundary edge
        nxt = np.full(n, -1, dtype=np.int64)
        prv = np.full(n, -1, dtype=np.int64)
        nxt[B[:, 0]] = B[:, 1]
        prv[B[:, 1]] = B[:, 0]
        cand = np.nonzero(on_boundary & ~corner & (nxt >= 0) & (prv >= 0))[0]
        a = V[cand] - V[prv[cand]]
        b = V[nxt[cand]] - V[cand]
        cosang = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
        turn = np.arccos(np.clip(cosang, -1.0, 1.0))
        corner[cand[turn > corner_angle]] = True
    interior = (valence > 0) & ~on_boundary
    smooth_boundary = on_boundary & ~corner
    return _Topology(H, HF, HE, E, EF, interior_edge, B, valence, interior, corner, smooth_boundary)


def _csr(rows, cols, vals, shape):
    return sp.csr_matrix((np.asarray(vals, dtype=np.float64), (rows, cols)), shape=shape)


def _step(n: int, F: np.ndarray, t: _Topology) -> SubdivisionStep:
    H, HF, HE, E, EF = t.H, t.HF, t.HE, t.E, t.EF
    m, e, h = len(F), len(E), len(H)
    sizes = face_sizes(F)
    # face points (m × n)
    Fm = _csr(HF, H[:, 0], 1.0 / sizes[HF], (m, n))
    # edge points (e × n): midpoint for boundary edges, (a + b + f1 + f2) / 4 inside
    ie = t.interior_edge
    w = np.where(ie, 0.25, 0.5)
    eidx = np.arange(e)
    EV = _csr(np.concatenate([eidx, eidx]), E.T.ravel(), np.concatenate([w, w]), (e, n))
    iidx = eidx[ie]
    EFm = _csr(np.concatenate([iidx, iidx]), np.concatenate([EF[ie, 0], EF[ie, 1]]),
               np.full(2 * len(iidx), 0.25), (e, m))
    Erows = EV + EFm @ Fm
    # vertex points (n × n) + (n × m) @ Fm
    val = t.valence.astype(np.float64)
    inv2 = np.zeros(n)
    inv2[t.interior] = 1.0 / val[t.interior] ** 2
    diag = np.ones(n)
    diag[t.interior] = (val[t.interior] - 2.0) / val[t.interior]
    diag[t.smooth_boundary] = 0.75
    rows = [np.arange(n)]
    cols = [np.arange(n)]
    vals = [diag]
    for a, b in ((E[:, 0], E[:, 1]), (E[:, 1], E[:, 0])):  # interior: 1/n² per edge neighbour
        sel = t.interior[a]
        rows.append(a[sel])
        cols.append(b[sel])
        vals.append(inv2[a[sel]])
    B = t.B
    for a, b in ((B[:, 0], B[:, 1]), (B[:, 1], B[:, 0])):  # crease: 1/8 per boundary neighbour
        sel = t.smooth_boundary[a]
        rows.append(a[sel])
        cols.append(b[sel])
        vals.append(np.full(int(sel.sum()), 0.125))
    VV = _csr(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), (n, n))
    v = H[:, 0]
    sel = t.interior[v]
    VFm = _csr(v[sel], HF[sel], inv2[v[sel]], (n, m))
    Vrows = VV + VFm @ Fm
    S = sp.vstack([Vrows, Erows, Fm], format="csr")
    # new quads: one per corner (half-edge): (v, edge out, face, edge in)
    offsets = np.cumsum(sizes) - sizes
    j = np.arange(h) - offsets[HF]
    prev = offsets[HF] + (j - 1) % sizes[HF]
    Q = np.stack([v, n + HE, n + e + HF, n + HE[prev]], axis=1).astype(np.int64)
    return SubdivisionStep(S, Q, np.nonzero(t.corner)[0].astype(np.int64))


def _level_info(level: int, n: int, F: np.ndarray, t: _Topology) -> LevelInfo:
    irr = np.nonzero(t.interior & (t.valence != 4))[0].astype(np.int64)
    return LevelInfo(level, n, int(len(t.E)), int(len(F)), irr, t.valence[irr].copy())


# ----------------------------------------------------------------------------------------------
# public array functions


def subdivision_step(V, F, boundary: str = "crease", corners=None,
                     corner_angle: float = DEFAULT_CORNER_ANGLE) -> SubdivisionStep:
    """The sparse matrix of one Catmull-Clark step and the new quads.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions (the matrix depends on them only through the sharp-corner test).
    F : (m, k) int64
        Padded polygon faces (validated like :func:`control_mesh`: manifold, consistently oriented).
    boundary : {"crease", "linear"}
        Boundary rule (see the module notes).
    corners : (c,) int64, optional
        Boundary vertices to keep fixed, besides the automatic ones.
    corner_angle : float
        A boundary vertex where the boundary turns by more than this angle (radians) is a corner.

    Returns
    -------
    SubdivisionStep
        ``S (n + e + m, n)`` CSR with rows summing to 1, ``Q (Σ sizes, 4)`` int64 quads (child quads of face
        ``f`` are contiguous, in corner order), ``corners (c,)`` the fixed vertices.

    Raises
    ------
    MeshError, InputError
        As :func:`subdivided_mesh`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(2, 2)
    >>> step = subdivision_step(V, F)
    >>> V1, Q1 = step.S @ V, step.Q
    >>> V1.shape, Q1.shape, bool(np.allclose(step.S.sum(axis=1), 1.0))
    ((25, 3), (16, 4), True)
    """
    boundary = check_choice(boundary, "boundary", BOUNDARY_RULES, casefold=True)
    corner_angle = check_number(corner_angle, "corner_angle", 0.0, np.pi)
    V, F = control_mesh(V, F)
    n = len(V)
    t = _topology(V, F, n, boundary, _check_corners(corners, n), corner_angle)
    return _step(n, F, t)


def subdivided_mesh(V, F, levels: int = 1, boundary: str = "crease", corners=None,
                    corner_angle: float = DEFAULT_CORNER_ANGLE, max_faces: int = MAX_FACES,
                    name: str = "mesh") -> tuple[np.ndarray, np.ndarray, SubdivisionInfo]:
    """Catmull-Clark subdivision of a polygon mesh (quads, triangles, n-gons), any number of levels.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Control vertices.
    F : (m, k) array_like of int
        Padded polygon faces, consistently oriented, edge-manifold.
    levels : int
        Number of subdivision steps (0 returns the validated input).
    boundary : {"crease", "linear"}
        ``"crease"``: boundary polylines are refined as cubic B-spline curves with fixed corners;
        ``"linear"``: the boundary polygon is kept (boundary vertices fixed, boundary edges split in half).
    corners : (c,) array_like of int, optional
        Extra boundary vertices of the input to keep fixed (indices stay valid at every level).
    corner_angle : float
        Boundary vertices where the boundary turns by more than this angle (radians) are corners.
    max_faces : int
        Refuse to run when the result would have more faces than this.
    name : str
        Name of the mesh input in error messages.

    Returns
    -------
    V : (n_L, 3) float64
        Subdivided vertices: the old vertices first (same indices), then edge points, then face points, level
        after level. ``n_{l+1} = n_l + e_l + m_l``.
    Q : (m_L, 4) int64
        Quads (``m_L = Σ face sizes · 4^(L−1)``); for ``levels=0`` the validated input faces.
    info : SubdivisionInfo
        ``levels[l]`` (:class:`LevelInfo`: counts and the irregular interior vertices with their valences at level
        ``l``, ``l = 0..L``) and ``corners`` (the fixed boundary vertices).

    Raises
    ------
    MeshError
        The mesh is malformed, has a non-manifold edge or flipped (inconsistently oriented) faces.
    InputError
        ``levels`` is negative or not a whole number, the face count would exceed ``max_faces``, bad
        ``boundary``, ``corners`` or ``corner_angle``. All checks run before any subdivision work.

    Notes
    -----
    Catmull & Clark 1978 with the crease/corner boundary rules of Hoppe et al. 1994. This is the subdivision
    step of the third free-form strategy of Liu et al. 2006 (coarse net → subdivision → pull to the surface →
    planarization). Irregular vertices are carried unchanged: an interior vertex of valence ``n ≠ 4`` keeps
    its index and valence, and each non-quad face adds one irregular face point of valence = its size.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(2, 2)
    >>> V1, Q1, info = subdivided_mesh(V, F, levels=2)
    >>> len(Q1), info.levels[-1].irregular_vertices.tolist(), info.corners.tolist()
    (64, [], [0, 2, 6, 8])
    """
    levels = check_int(levels, "levels", 0)
    boundary = check_choice(boundary, "boundary", BOUNDARY_RULES, casefold=True)
    corner_angle = check_number(corner_angle, "corner_angle", 0.0, np.pi)
    max_faces = check_number(max_faces, "max_faces", 1, finite=False)
    V, F = control_mesh(V, F, name=name)
    corners = _check_corners(corners, len(V))
    # (4^63 times the corners passes any memory: no need to compute the exact count of a billion levels, a number
    # of 600 million digits)
    total = face_count_after(F, min(levels, MAX_LEVELS))
    if levels > MAX_LEVELS or total > max_faces:
        count = f"{total:,}" if levels <= MAX_LEVELS else f"more than {total:.3g}"
        limit = f"the limit of {int(max_faces):,} (max_faces)" if math.isfinite(max_faces) else "any computer holds"
        raise InputError("levels", f"{levels} levels would make {count} faces, more than {limit}; use fewer levels "
                                   "or a coarser mesh")
    t = _topology(V, F, len(V), boundary, corners, corner_angle)
    infos = [_level_info(0, len(V), F, t)]
    fixed = np.nonzero(t.corner)[0]
    for level in range(1, levels + 1):
        step = _step(len(V), F, t)
        V = step.S @ V
        F = step.Q
        # corners persist by index; sharp-angle detection only on the coarse net
        t = _topology(None, F, len(V), boundary, fixed, np.pi)
        infos.append(_level_info(level, len(V), F, t))
        log.debug("subdivided_mesh level %d: %d vertices, %d faces", level, len(V), len(F))
    return V, F, SubdivisionInfo(infos, fixed.astype(np.int64))


def limit_positions(V, Q, boundary: str = "crease", corners=None,
                    corner_angle: float = DEFAULT_CORNER_ANGLE) -> np.ndarray:
    """Positions on the Catmull-Clark limit surface of the vertices of an all-quad mesh.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices of a quad mesh (e.g. the output of :func:`subdivided_mesh` with ``levels ≥ 1``).
    Q : (m, 4) int64
        Quads.
    boundary : {"crease", "linear"}
        Boundary rule, as in :func:`subdivided_mesh`.
    corners : (c,) int64, optional
        Fixed boundary vertices (pass ``info.corners`` of :func:`subdivided_mesh` to match its corners).
    corner_angle : float
        Sharp-turn threshold for automatic corners, as in :func:`subdivided_mesh`.

    Returns
    -------
    (n, 3) float64
        Interior vertex of valence ``n``: ``(n² P + 4 Σ eⱼ + Σ dⱼ) / (n (n + 5))`` (``eⱼ`` edge neighbours,
        ``dⱼ`` the opposite corners of its quads); crease vertex ``(a + 4 P + b) / 6``; corners stay.

    Raises
    ------
    MeshError
        If the mesh is not a valid, manifold, consistently oriented quad mesh.

    Notes
    -----
    The stencil is the left eigenvector of the subdivision matrix for eigenvalue 1 (Halstead, Kass, DeRose 1993;
    Stam 1998); on a regular grid it is the bicubic B-spline evaluated at the knots.

    Examples
    --------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 2, height=lambda x, y: x * x)
    >>> float(limit_positions(V, Q)[4, 2])  # centre: (16·0.25 + 4·(0 + 1 + 0.25 + 0.25) + 2·(0 + 1)) / 36
    0.3333333333333333
    """
    V, Q = validate_mesh(V, Q, name="mesh", kind="quad")
    n = len(V)
    boundary = check_choice(boundary, "boundary", BOUNDARY_RULES, casefold=True)
    t = _topology(V, Q, n, boundary, _check_corners(corners, n), check_number(corner_angle, "corner_angle", 0.0, np.pi))
    val = t.valence.astype(np.float64)
    out = V.copy()
    W = np.zeros(n)
    W[t.interior] = 1.0 / (val[t.interior] * (val[t.interior] + 5.0))
    acc = np.zeros((n, 3))
    acc[t.interior] = (val[t.interior] ** 2)[:, None] * V[t.interior]
    for a, b in ((t.E[:, 0], t.E[:, 1]), (t.E[:, 1], t.E[:, 0])):
        sel = t.interior[a]
        np.add.at(acc, a[sel], 4.0 * V[b[sel]])
    # opposite corner of each quad corner
    opp = np.roll(Q, -2, axis=1)
    sel = t.interior[Q]
    np.add.at(acc, Q[sel], V[opp[sel]])
    out[t.interior] = acc[t.interior] * W[t.interior, None]
    sb = t.smooth_boundary
    nb = np.zeros((n, 3))
    B = t.B
    for a, b in ((B[:, 0], B[:, 1]), (B[:, 1], B[:, 0])):
        s = sb[a]
        np.add.at(nb, a[s], V[b[s]])
    out[sb] = (4.0 * V[sb] + nb[sb]) / 6.0
    return out


# ----------------------------------------------------------------------------------------------
# published component


class CatmullClarkResult(NamedTuple):
    mesh: Mesh
    irregular_vertices: Integers
    irregular_valences: Integers
    vertex_count: int
    face_count: int
    warnings: list[str]


def catmull_clark(mesh: Mesh, levels: int = 1, boundary: str = "crease", corners: Integers | None = None,
                  max_faces: int = 2000000) -> CatmullClarkResult:
    """Catmull-Clark subdivision of a quad-dominant mesh, boundary kept as a crease ending on its corners.

    Parameters
    ----------
    mesh : Mesh
        The coarse control mesh ``(V, F)``: quads with some triangles or n-gons, consistently oriented.
    levels : int
        Number of subdivision steps; every step turns each k-gon into k quads (faces ×4 for a quad mesh).
    boundary : str
        ``"crease"`` refines boundary polylines as cubic B-spline curves with fixed corners (valence-2 boundary
        vertices and turns sharper than 60°); ``"linear"`` keeps the boundary polygon exactly.
    corners : Integers
        Optional extra boundary vertex indices of the coarse mesh to keep fixed.
    max_faces : int
        Largest face count allowed; more levels than this permits are refused before any work.

    Returns
    -------
    mesh : Mesh
        The subdivided all-quad mesh; the coarse vertices keep their indices.
    irregular_vertices : Integers
        Interior vertices of the result whose valence is not 4 (the singularities carried from the coarse mesh).
    irregular_valences : Integers
        Valence of each irregular vertex (3 for a positive-index singularity, 5 or more for a negative one).
    vertex_count : int
        Number of vertices of the result.
    face_count : int
        Number of faces of the result.

    Raises
    ------
    MeshError
        The mesh is malformed, non-manifold or has flipped faces.
    InputError
        ``levels`` negative, not whole, or too large for ``max_faces``; unknown ``boundary``; bad ``corners``.

    Notes
    -----
    Catmull & Clark 1978, boundary rules of Hoppe et al. 1994. Step 3 of the subdivision strategy of Liu et al.,
    "Geometric modeling with conical meshes and developable surfaces", SIGGRAPH 2006: a coarse net whose
    irregular vertices sit where the curvature asks for them is refined, pulled to the surface and planarized.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = catmull_clark(quad_grid(3, 3), levels=2)
    >>> res.face_count, res.vertex_count
    (144, 169)
    """
    if not isinstance(mesh, (tuple, list)) or len(mesh) != 2:
        raise InputError("mesh", "must be a (V, F) pair")
    V, Q, info = subdivided_mesh(mesh[0], mesh[1], levels=levels, boundary=boundary, corners=corners,
                               max_faces=max_faces, name="mesh")
    last = info.levels[-1]
    warnings = []
    if levels == 0:
        warnings.append("levels is 0: the mesh is returned unchanged")
    return CatmullClarkResult((V, Q), last.irregular_vertices, last.irregular_valences, int(len(V)), int(len(Q)),
                           warnings)
