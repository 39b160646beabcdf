"""Conical meshes: the angle criterion, node (cone) axes, and face / vertex offsets.

A conical mesh (Liu, Pottmann, Wallner, Yang, Wang 2006) is a planar-quad mesh whose faces around every vertex are
tangent to a common right circular cone; equivalently, at an interior valence-4 vertex the face angles satisfy
``ω1 + ω3 = ω2 + ω4``, and the unit face normals lie on a circle of the Gauss sphere. The cone axis is the
*node axis*. Moving every face plane by the same distance ``d`` along its normal gives again a conical mesh with
the same node axes (the *face offset*), which is what glass roofs with straight node axes and beams of constant
height need. Offsetting the vertices along vertex normals (the *vertex offset*) does not keep face planes at a
constant distance; :func:`vertex_offset` is here for comparison.

Array-level functions: :func:`conical_criterion`, :func:`conical_check`, :func:`node_axes`, :func:`face_planes`,
:func:`face_offset`, :func:`vertex_offset`. Published components: :func:`analysis` (``conical/analysis``),
:func:`offset` (``conical/offset``).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from components.core.checks import check_choice, check_length, check_mesh, check_number
from components.core.errors import InputError
from components.core.measures import corner_angles, quad_planarity
from components.core.mesh import Corners, bounding_box_diagonal, edge_topology, face_corners, face_sizes
from components.core.types import Integers, Lines, Mesh, Numbers

log = logging.getLogger(__name__)

__all__ = [
    "AnalysisResult",
    "ConicalCheck",
    "ConeFit",
    "Offset",
    "OffsetResult",
    "analysis",
    "conical_check",
    "conical_criterion",
    "cone_fit",
    "face_offset",
    "face_planes",
    "node_axes",
    "offset",
    "vertex_offset",
]


# ----------------------------------------------------------------------------------------------
# private topology helpers (ordered vertex stars; the corner table is components.core.mesh.face_corners)


def _regular_stars(C: Corners, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Interior valence-4 vertices and their four corners in cyclic order (each the successor of the last).

    The successor of corner ``(v, prev, next)`` is the corner at ``v`` in the face across the edge ``v → next``
    (in a consistently oriented mesh its ``prev`` is our ``next``).
    """
    c = len(C.v)
    key = C.v * n + C.prev
    order = np.argsort(key, kind="stable")
    skey = key[order]
    want = C.v * n + C.next
    pos = np.minimum(np.searchsorted(skey, want), c - 1)
    succ = np.where(skey[pos] == want, order[pos], -1)
    count = np.bincount(C.v, minlength=n)
    open_v = np.zeros(n, dtype=bool)
    open_v[C.v[succ < 0]] = True
    first = np.full(n, -1, dtype=np.int64)
    first[C.v[::-1]] = np.arange(c)[::-1]
    cand = np.nonzero((count == 4) & ~open_v)[0]
    ring = np.empty((len(cand), 4), dtype=np.int64)
    cur = first[cand]
    for j in range(4):
        ring[:, j] = cur
        cur = succ[cur]
    ok = cur == ring[:, 0]
    return cand[ok], ring[ok]


# ----------------------------------------------------------------------------------------------
# angle criterion


def conical_criterion(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle criterion ``ω1 − ω2 + ω3 − ω4`` at every interior valence-4 vertex.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces (consistently oriented; padded polygons allowed, only vertices with four faces around are checked).

    Returns
    -------
    vertices : (s,) int64
        The interior vertices with exactly four faces in a closed cycle.
    criterion : (s,) float64
        Signed ``ω1 − ω2 + ω3 − ω4`` in radians, ``ωj`` the face angles at the vertex in cyclic order.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006, Theorem 1: a PQ mesh is conical iff this vanishes at every interior valence-4 vertex.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> verts, crit = conical_criterion(*quad_grid(2, 2))
    >>> verts.tolist(), abs(float(crit[0])) < 1e-15
    ([4], True)
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    C = face_corners(F)
    verts, ring = _regular_stars(C, len(V))
    ang = corner_angles(V, F)
    A = ang[ring]
    return verts, A[:, 0] - A[:, 1] + A[:, 2] - A[:, 3]


class ConeFit(NamedTuple):
    """Per-vertex cone through the face normals (see :func:`cone_fit`)."""

    axis: np.ndarray  # (n, 3) unit node axis, pointing to the side of the face normals
    half_angle: np.ndarray  # (n,) mean angle between the axis and the unit face normals, radians
    deviation: np.ndarray  # (n,) half the spread (max − min) of those angles, radians; 0 on an exact cone


def _vertex_face_groups(C: Corners, n: int):
    """Yield ``(k, vertices (g,), faces (g, k))``: vertices grouped by their number of incident faces."""
    order = np.argsort(C.v, kind="stable")
    count = np.bincount(C.v, minlength=n)
    start = np.r_[0, np.cumsum(count)[:-1]]
    for k in np.unique(count[count > 0]):
        verts = np.nonzero(count == k)[0]
        idx = start[verts][:, None] + np.arange(k)[None, :]
        yield int(k), verts, C.face[order[idx]]


def cone_fit(V: np.ndarray, F: np.ndarray) -> ConeFit:
    """Best-fit cone of the unit face normals at every vertex: its axis (the node axis) and the misfit.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces.

    Returns
    -------
    ConeFit
        ``axis`` (n, 3) unit node axes, ``half_angle`` (n,) cone half-angle, ``deviation`` (n,) cone-normal
        deviation (half the spread of the angles between axis and face normals, radians; 0 when the normals lie
        on a circle of the Gauss sphere, i.e. the faces touch a common right circular cone). Vertices used by no
        face get a zero axis.

    Notes
    -----
    The normals ``n_f`` of the faces at a vertex are points of the unit sphere; the plane fitted to them
    (least squares, exact for three) cuts the sphere in the circle whose centre direction is the cone axis
    (Liu et al. 2006, §3). With two distinct normals (a boundary vertex with two faces, or a developable strip)
    the circle is not determined: the axis is then the bisector, which lies in the family; with one normal it
    is that normal.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    n = len(V)
    N = _face_normals_lsq(V, F)[0]
    C = face_corners(F)
    axis = np.zeros((n, 3))
    half = np.zeros(n)
    dev = np.zeros(n)
    for k, verts, faces in _vertex_face_groups(C, n):
        P = N[faces]  # (g, k, 3)
        a = _circle_axis(P)
        cosang = np.clip(np.einsum("gkj,gj->gk", P, a), -1.0, 1.0)
        th = np.arccos(cosang)
        axis[verts] = a
        half[verts] = th.mean(axis=1)
        dev[verts] = 0.5 * (th.max(axis=1) - th.min(axis=1))
    return ConeFit(axis, half, dev)


def _circle_axis(P: np.ndarray, eps: float = 1e-9) -> np.ndarray:
    """Axis of the circle fitted to points ``P`` (g, k, 3) on the unit sphere, oriented like their mean."""
    mean = P.mean(axis=1)
    mean_n = mean / np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-300)
    Q = P - mean[:, None, :]
    _, s, Wt = np.linalg.svd(Q, full_matrices=True)  # s (g, min(k,3)), Wt (g, 3, 3)
    s3 = np.zeros((len(P), 3))
    s3[:, : s.shape[1]] = s
    a = Wt[:, 2, :].copy()
    # degenerate spreads: collinear normals (two distinct ones) -> the mean direction with the spread removed;
    # coincident normals -> the mean itself
    line = (s3[:, 1] <= eps) & (s3[:, 0] > eps)
    if line.any():
        d = Wt[line, 0, :]
        m = mean_n[line] - np.einsum("ij,ij->i", mean_n[line], d)[:, None] * d
        a[line] = m / np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
    point = s3[:, 0] <= eps
    a[point] = mean_n[point]
    sign = np.where(np.einsum("ij,ij->i", a, mean) < 0, -1.0, 1.0)
    return a * sign[:, None]


def node_axes(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit node (cone) axis at every vertex: the normal of the circle through its unit face normals.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces.

    Returns
    -------
    (n, 3) float64
        Unit axes oriented to the side of the face normals (0 for vertices used by no face).

    Notes
    -----
    Liu et al. 2006: for a conical mesh the face normals at a vertex lie on a circle of the Gauss sphere, and its
    axis is the node axis; consecutive node axes are coplanar. For a non-conical mesh this is the least-squares
    circle's axis (see :func:`cone_fit` for the misfit).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> node_axes(*quad_grid(1, 1))[0].tolist()
    [0.0, 0.0, 1.0]
    """
    return cone_fit(V, F).axis


class ConicalCheck(NamedTuple):
    """Result of :func:`conical_check`."""

    criterion: np.ndarray  # (n,) |ω1 − ω2 + ω3 − ω4| in radians, NaN where not applicable
    checked: np.ndarray  # (n,) bool, interior vertices with at least four faces
    passed: np.ndarray  # (n,) bool, cone deviation within the planarity-scaled tolerance (True where not checked)
    deviation: np.ndarray  # (n,) cone-normal deviation, radians
    max_criterion: float


PLANARITY_FACTOR = 4.0  # deviation slack per unit of local planarity (dos conical1.obj needs 2.2)


def conical_check(V: np.ndarray, F: np.ndarray, tol: float = 1e-4,
                  planarity_factor: float = PLANARITY_FACTOR) -> ConicalCheck:
    """Conical verdict at every interior vertex: do its face normals lie on a cone of revolution?

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces, consistently oriented.
    tol : float
        Accepted cone-normal deviation (radians) for exactly planar faces.
    planarity_factor : float
        At a vertex whose faces have planarity up to ``p`` (scale-free), the accepted deviation is
        ``tol + planarity_factor · p``: the normal of a face that is not quite planar is uncertain by about that
        much.

    Returns
    -------
    ConicalCheck
        ``criterion`` (n,) ``|ω1 − ω2 + ω3 − ω4|`` at interior valence-4 vertices (NaN elsewhere; reported beside the
        verdict), ``checked`` (n,) interior vertices with at least four faces, ``passed`` (n,) deviation within the
        scaled tolerance (True where not checked), ``deviation`` (n,) cone-normal deviation (radians) from
        :func:`cone_fit`, ``max_criterion`` (0 when there is no valence-4 vertex).

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006, §3: a vertex is conical when its face normals lie on a circle of the Gauss sphere; for exactly
    planar faces this is equivalent to the angle criterion ``ω1 + ω3 = ω2 + ω4`` at valence 4. The angle criterion
    is perturbed by faces that are planar only to a tolerance, the cone fit is not: the published conical mesh
    ``dos/obj_pq__conical1.obj`` (planarity 4e-5) has cone deviations up to 3.8e-5 rad but angle criteria up to
    7.5e-4 rad, and passes this check as it is.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> bool(conical_check(*quad_grid(3, 3)).passed.all())
    True
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    n = len(V)
    verts, crit = conical_criterion(V, F)
    out = np.full(n, np.nan)
    out[verts] = np.abs(crit)
    C = face_corners(F)
    count = np.bincount(C.v, minlength=n)
    topo = edge_topology(F)
    boundary = np.zeros(n, bool)
    boundary[topo.E[topo.count == 1].ravel()] = True
    checked = ~boundary & (count >= 4)
    pv = np.zeros(n)
    np.maximum.at(pv, C.v, quad_planarity(V, F)[C.face])
    dev = cone_fit(V, F).deviation
    passed = ~checked | (dev <= tol + planarity_factor * pv)
    return ConicalCheck(out, checked, passed, dev, float(np.abs(crit).max()) if len(crit) else 0.0)


# ----------------------------------------------------------------------------------------------
# offsets


def _face_normals_lsq(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares plane of every face: unit normal (oriented like the face) and offset ``c = n·x``."""
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    N = np.zeros((len(F), 3))
    c = np.zeros(len(F))
    for s in np.unique(sizes):
        idx = np.nonzero(sizes == s)[0]
        P = V[F[idx, :s]]  # (g, s, 3)
        cen = P.mean(axis=1)
        Q = P - cen[:, None, :]
        # Newell vector for the orientation
        newell = 0.5 * np.cross(Q, np.roll(Q, -1, axis=1)).sum(axis=1)  # centred: no cancellation far out
        if s == 3:
            nrm = newell
        else:
            _, _, Wt = np.linalg.svd(Q, full_matrices=True)
            nrm = Wt[:, 2, :]
            nrm = nrm * np.where(np.einsum("ij,ij->i", nrm, newell) < 0, -1.0, 1.0)[:, None]
        nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        N[idx] = nrm
        c[idx] = np.einsum("ij,ij->i", nrm, cen)
    return N, c


def face_planes(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane ``n·x = c`` of every face (least squares for a non-planar face, exact for a planar one).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces.

    Returns
    -------
    N : (m, 3) float64
        Unit normals, oriented like the face (its Newell vector).
    c : (m,) float64
        Plane offsets: the plane is ``{x : N[f]·x = c[f]}`` through the face centroid.
    """
    return _face_normals_lsq(np.asarray(V, dtype=np.float64), F)


class Offset(NamedTuple):
    """An offset mesh with its error report (see :func:`face_offset`, :func:`vertex_offset`)."""

    V: np.ndarray  # (n, 3) offset vertices
    F: np.ndarray  # (m, k) faces (unchanged)
    axes: np.ndarray  # (n, 2, 3) node axis segments, vertex -> offset vertex
    face_error: np.ndarray  # (m,) max over the face's offset corners of |distance to the original face plane − d|
    vertex_residual: np.ndarray  # (n,) max over the vertex's faces of |distance to the moved plane|
    E: np.ndarray  # (e, 2) edges
    axis_coplanarity: np.ndarray  # (e,) |det(e, a_i, a_j)| / (|e||a_i||a_j|) of the axes at the two ends


def _offset_report(V, F, X, d, N, c, C):
    n = len(V)
    D = X - V
    axes = np.stack([V, X], axis=1)
    dist = np.einsum("ij,ij->i", N[C.face], X[C.v]) - c[C.face]  # signed distance of offset corners
    err = np.abs(dist - d)
    face_error = np.zeros(len(F))
    np.maximum.at(face_error, C.face, err)
    vertex_residual = np.zeros(n)
    np.maximum.at(vertex_residual, C.v, err)
    E = edge_topology(F).E
    A = D.copy()
    short = np.linalg.norm(A, axis=1) <= 1e-300
    if short.any():
        A[short] = cone_fit(V, F).axis[short]
    e = V[E[:, 1]] - V[E[:, 0]]
    ai, aj = A[E[:, 0]], A[E[:, 1]]
    vol = np.abs(np.einsum("ij,ij->i", e, np.cross(ai, aj)))
    scale = np.linalg.norm(e, axis=1) * np.linalg.norm(ai, axis=1) * np.linalg.norm(aj, axis=1)
    cop = vol / np.maximum(scale, 1e-300)
    return Offset(X, F, axes, face_error, vertex_residual, E, cop)


def face_offset(V: np.ndarray, F: np.ndarray, d: float, rcond: float = 1e-6) -> Offset:
    """Face offset: every face plane moved by ``d`` along its unit normal, vertices at the planes' intersection.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions of a (near-)conical PQ mesh.
    F : (m, k) int64
        Faces, consistently oriented; the offset side is the side of the face normals (``d < 0`` the other).
    d : float
        Offset distance in model units.
    rcond : float
        Relative cut-off for the least-squares plane intersection: directions in which the face normals at a
        vertex differ by less than about ``rcond`` radians (flat spots) are not solved for, the vertex stays on
        its node axis there.

    Returns
    -------
    Offset
        ``V`` offset vertices; ``F``; ``axes`` (n, 2, 3) node-axis segments vertex → offset vertex; ``face_error``
        (m,) max over the face's offset corners of ``|distance to the original face plane − d|`` (0 for an exact
        conical mesh); ``vertex_residual`` (n,) the same per vertex (the misfit of the plane intersection);
        ``E``, ``axis_coplanarity`` (e,) scale-free triple product of the two node axes of every edge (0 when
        coplanar).

    Notes
    -----
    Liu et al. 2006, §3: a PQ mesh has a face offset at constant distance iff it is conical. Each vertex solves
    ``n_f·x = c_f + d`` for its faces in the least-squares sense, starting from the point ``v + d/cos θ · a`` on
    its node axis ``a`` (cone half-angle ``θ``), which is the exact solution at a conical vertex and keeps the
    system well posed at boundary vertices with two faces (their offset point is on the bisecting node axis). A
    corner vertex with a single face takes the point of its moved plane that keeps both offset boundary edges
    parallel to the original ones, so its axis is coplanar with its neighbours' as well.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> off = face_offset(*quad_grid(2, 2), 0.5)
    >>> bool(np.allclose(off.V[:, 2], 0.5)), float(off.face_error.max()) < 1e-12
    (True, True)
    """
    V0 = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    d = check_number(d, "distance")
    n = len(V0)
    centre = 0.5 * (V0.min(axis=0) + V0.max(axis=0)) if n else np.zeros(3)
    V = V0 - centre  # plane offsets c = n·x of a far-placed model lose digits: solve about the centre
    N, c = _face_normals_lsq(V, F)
    C = face_corners(F)
    X = V.copy()
    for k, verts, faces in _vertex_face_groups(C, n):
        P = N[faces]  # (g, k, 3)
        a = _circle_axis(P)
        cosang = np.einsum("gkj,gj->gk", P, a).mean(axis=1)
        cosang = np.where(np.abs(cosang) < 1e-3, np.where(cosang < 0, -1e-3, 1e-3), cosang)  # axis ⟂ faces
        X0 = V[verts] + (d / cosang)[:, None] * a
        r = c[faces] + d - np.einsum("gkj,gj->gk", P, X0)
        if k >= 2:
            pinv = np.linalg.pinv(P, rcond=rcond)  # (g, 3, k)
            X0 = X0 + np.einsum("gjk,gk->gj", pinv, r)
        X[verts] = X0
    _fit_boundary(V, F, X, N, C, count=np.bincount(C.v, minlength=n))
    off = _offset_report(V, F, X, d, N, c, C)
    return off._replace(V=off.V + centre, axes=off.axes + centre)


def _fit_boundary(V, F, X, N, C, count, reg: float = 1e-7):
    """Slide the offset points of vertices with one or two faces so that offset boundary edges stay parallel.

    Such a vertex may move in the null space of its face normals (along the line where its two moved planes
    meet, or within its single moved plane) without leaving its planes. Over all of them at once, minimize the
    component of every offset boundary edge orthogonal to the original edge (within its face plane), plus a tiny
    pull ``reg`` towards the start point. For a conical mesh the minimum is 0: the offset boundary polygons are
    parallel and the node axes at the two ends of every boundary edge are coplanar. Modifies ``X`` in place.
    """
    few = np.nonzero((count >= 1) & (count <= 2))[0]
    if len(few) == 0:
        return
    topo = edge_topology(F)
    bnd = np.nonzero(topo.count == 1)[0]
    if len(bnd) == 0:
        return
    # null-space basis (up to 2 vectors) of each few-face vertex's normals
    cols = []  # (vertex, direction)
    order = np.argsort(C.v, kind="stable")
    start = np.r_[0, np.cumsum(count)[:-1]]
    for k in (1, 2):
        verts = few[count[few] == k]
        if len(verts) == 0:
            continue
        faces = C.face[order[start[verts][:, None] + np.arange(k)[None, :]]]
        P = N[faces]
        _, sv, Wt = np.linalg.svd(P, full_matrices=True)
        s3 = np.zeros((len(verts), 3))
        s3[:, : sv.shape[1]] = sv
        for j in range(3):
            null = s3[:, j] <= 1e-9 * np.maximum(s3[:, 0], 1e-300)
            for v, g in zip(verts[null], Wt[null, j, :]):
                cols.append((v, g))
    if not cols:
        return
    col_v = np.array([cv for cv, _ in cols], dtype=np.int64)
    G = np.array([g for _, g in cols])
    ncol = len(cols)
    # map vertex -> its unknown columns
    by_v = {}
    for j, v in enumerate(col_v.tolist()):
        by_v.setdefault(v, []).append(j)
    E = topo.E[bnd]
    f = topo.EF[bnd, 0]
    u = V[E[:, 1]] - V[E[:, 0]]
    m = np.cross(N[f], u)
    m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
    rows, cc, vals = [], [], []
    for i, (a, b) in enumerate(E.tolist()):
        for v, sgn in ((b, 1.0), (a, -1.0)):
            for j in by_v.get(v, ()):
                rows.append(i)
                cc.append(j)
                vals.append(sgn * float(m[i] @ G[j]))
    A = sp.csr_matrix((vals, (rows, cc)), shape=(len(E), ncol))
    r0 = np.einsum("ij,ij->i", m, X[E[:, 1]] - X[E[:, 0]])
    M = (A.T @ A + reg * reg * sp.identity(ncol)).tocsc()
    y = spla.spsolve(M, -(A.T @ r0))
    np.add.at(X, col_v, y[:, None] * G)


def vertex_offset(V: np.ndarray, F: np.ndarray, d: float) -> Offset:
    """Vertex offset: every vertex moved by ``d`` along its unit vertex normal (for comparison with faces).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Faces, consistently oriented.
    d : float
        Offset distance in model units.

    Returns
    -------
    Offset
        Same report as :func:`face_offset`; here ``face_error`` is generally not 0: the offset faces are neither
        at distance ``d`` from the original planes nor, in general, planar.

    Notes
    -----
    The vertex normal is the normalized sum of the unit normals of the faces at the vertex. Only spherical meshes
    (all vertices on a sphere, offset radially) keep their offsets parallel (Pottmann et al. 2007).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> bool(np.allclose(vertex_offset(*quad_grid(2, 2), 0.5).V[:, 2], 0.5))
    True
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    d = check_number(d, "distance")
    N, c = _face_normals_lsq(V, F)
    C = face_corners(F)
    S = np.zeros_like(V)
    np.add.at(S, C.v, N[C.face])
    L = np.linalg.norm(S, axis=1, keepdims=True)
    S = np.divide(S, L, out=np.zeros_like(S), where=L > 0)
    return _offset_report(V, F, V + d * S, d, N, c, C)


# ----------------------------------------------------------------------------------------------
# published components


def _axis_length(V, F):
    E = edge_topology(F).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean()) if len(E) else 1.0


class AnalysisResult(NamedTuple):
    criterion: Numbers
    checked: Integers
    failed: Integers
    max_criterion: float
    mean_criterion: float
    cone_deviation: Numbers
    max_cone_deviation: float
    node_axes: Lines
    max_planarity: float
    is_conical: bool
    warnings: list[str]


def analysis(mesh: Mesh, tolerance: float = 1e-4) -> AnalysisResult:
    """Check whether a planar-quad mesh is conical: angle criterion, cone-normal deviation and node axes.

    Parameters
    ----------
    mesh : Mesh
        The quad or quad-dominant mesh ``(V, F)``, consistently oriented.
    tolerance : float
        Largest accepted angle criterion ``|ω1 − ω2 + ω3 − ω4|`` (radians) and quad planarity (scale-free).

    Returns
    -------
    criterion : Numbers
        Per vertex ``|ω1 − ω2 + ω3 − ω4|`` in radians at interior valence-4 vertices, 0 at the others.
    checked : Integers
        Indices of the checked vertices (interior, at least four faces).
    failed : Integers
        Indices of the checked vertices whose face normals leave their best-fit cone by more than the tolerance
        (scaled by the planarity of the faces around the vertex, see :func:`conical_check`).
    max_criterion : float
        Largest criterion (radians).
    mean_criterion : float
        Mean criterion over the checked vertices (radians).
    cone_deviation : Numbers
        Per vertex half the spread of the angles between the node axis and the unit face normals (radians;
        0 when the faces touch a common right circular cone).
    max_cone_deviation : float
        Largest cone deviation over vertices with at least three faces.
    node_axes : Lines
        Node axis of every vertex as a line from the vertex, one mean edge length long.
    max_planarity : float
        Largest quad planarity (distance between the diagonals / mean diagonal): a conical mesh is a PQ mesh.
    is_conical : bool
        True when no checked vertex failed and the largest planarity is within the tolerance.

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        Negative or non-finite tolerance.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006: a PQ mesh is conical when the face normals at every vertex lie on a circle of the Gauss sphere
    (whose axis is the node axis); for exactly planar quads this is ``ω1 + ω3 = ω2 + ω4`` at every interior
    valence-4 vertex. The verdict uses the cone fit, which faces planar only to a tolerance do not perturb; the
    angle criterion is reported beside it.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> analysis(quad_grid(3, 3)).is_conical
    True
    """
    V, F = check_mesh(mesh, "mesh")
    tolerance = check_number(tolerance, "tolerance", 0)
    warnings: list[str] = []
    chk = conical_check(V, F, tol=tolerance)
    crit = np.nan_to_num(chk.criterion, nan=0.0)
    checked = np.nonzero(chk.checked)[0]
    if len(checked) == 0:
        warnings.append("no interior vertex with four or more faces: nothing to check")
    failed = np.nonzero(~chk.passed)[0]
    fit = cone_fit(V, F)
    nfaces = np.bincount(face_corners(F).v, minlength=len(V))
    dev_ok = nfaces >= 3
    planarity = np.where(face_sizes(F) == 4, quad_planarity(V, F), 0.0)  # quads only, as documented
    max_pl = float(planarity.max()) if len(planarity) else 0.0
    if max_pl > tolerance:
        warnings.append(
            f"faces are not planar (max planarity {max_pl:.2e} > {tolerance:g}): the angle criterion characterizes "
            "conical meshes only among planar-quad meshes"
        )
    nonquad = int(np.sum(face_sizes(F) != 4))
    if nonquad:
        warnings.append(f"{nonquad} faces are not quads; vertices next to them are not checked by the criterion")
    L = _axis_length(V, F)
    lines = np.stack([V, V + L * fit.axis], axis=1)
    max_crit = chk.max_criterion
    return AnalysisResult(
        criterion=crit,
        checked=checked.astype(np.int64),
        failed=failed.astype(np.int64),
        max_criterion=max_crit,
        mean_criterion=float(np.nanmean(chk.criterion)) if np.isfinite(chk.criterion).any() else 0.0,
        cone_deviation=fit.deviation,
        max_cone_deviation=float(fit.deviation[dev_ok].max()) if dev_ok.any() else 0.0,
        node_axes=lines,
        max_planarity=max_pl,
        is_conical=bool(len(failed) == 0 and max_pl <= tolerance),
        warnings=warnings,
    )


class OffsetResult(NamedTuple):
    offset: Mesh
    node_axes: Lines
    face_error: Numbers
    max_face_error: float
    vertex_residual: Numbers
    max_axis_coplanarity: float
    warnings: list[str]


def offset(mesh: Mesh, distance: float = 0.1, method: str = "face") -> OffsetResult:
    """Offset a (conical) mesh at a constant distance, with node axes and the offset error.

    Parameters
    ----------
    mesh : Mesh
        The planar-quad mesh ``(V, F)``, consistently oriented; offsets go to the side of the face normals.
    distance : float
        Offset distance in model units (negative: the other side).
    method : str
        ``"face"``: every face plane moved by the distance, vertices at the intersection of the moved planes
        (exact for a conical mesh); ``"vertex"``: every vertex moved along its unit vertex normal (comparison).

    Returns
    -------
    offset : Mesh
        The offset mesh (same faces).
    node_axes : Lines
        The node axis of every vertex as the line from the vertex to its offset.
    face_error : Numbers
        Per face, the largest ``|distance of an offset corner to the original face plane − distance|``
        (model units; 0 for the face offset of a conical mesh).
    max_face_error : float
        Largest face error (model units).
    vertex_residual : Numbers
        Per vertex, the largest distance of the offset vertex to the moved planes of its faces (model units).
    max_axis_coplanarity : float
        Largest scale-free triple product of the node axes at the two ends of an edge (0 when every pair of
        consecutive node axes is coplanar, as on a conical mesh).

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        Non-finite or zero ``distance``; unknown ``method``.

    Notes
    -----
    Liu et al. 2006; Pottmann, Liu, Wallner, Bobenko, Wang, *Geometry of multi-layer freeform structures for
    architecture*, SIGGRAPH 2007: conical meshes have face offsets at constant distance, and their node axes form
    a torsion-free support structure.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = offset(quad_grid(2, 2), distance=0.25)
    >>> bool(res.max_face_error < 1e-12)
    True
    """
    V, F = check_mesh(mesh, "mesh")
    d = check_length(distance, "distance", bounding_box_diagonal(V))
    if d == 0:
        raise InputError("distance", "must be non-zero")
    check_choice(method, "method", ("face", "vertex"))
    warnings: list[str] = []
    off = face_offset(V, F, d) if method == "face" else vertex_offset(V, F, d)
    max_err = float(off.face_error.max())
    N0 = face_planes(V, F)[0]
    N1 = face_planes(off.V, F)[0]
    flipped = int(np.sum(np.einsum("ij,ij->i", N0, N1) <= 0))
    if flipped:
        warnings.append(
            f"{flipped} offset faces are flipped: the distance {d:g} exceeds the local radius of curvature there"
        )
    if method == "face" and max_err > 1e-6 * abs(d):
        chk = conical_check(V, F)
        worst = float(chk.deviation[chk.checked].max()) if chk.checked.any() else 0.0
        why = (f"face normals up to {worst:.2e} rad off their cones; "
               "the moved face planes do not meet in one point at every vertex")
        warnings.append(
            f"the mesh is not conical ({why}): the offset faces are up to {max_err:.3g} from the distance {d:g}"
        )
    return OffsetResult(
        offset=(off.V, F),
        node_axes=off.axes,
        face_error=off.face_error,
        max_face_error=max_err,
        vertex_residual=off.vertex_residual,
        max_axis_coplanarity=float(off.axis_coplanarity.max()) if len(off.axis_coplanarity) else 0.0,
        warnings=warnings,
    )
