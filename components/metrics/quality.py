"""Quality metrics of planar-quad (PQ) meshes: the numbers panel makers and engineers judge a mesh by.

Array-level functions (``quad_planarity(V, F) -> (m,)`` …) are for Python users and the other steps; the
published components (``planarity(mesh)`` …) validate their input once and return a ``NamedTuple`` of per-element
values plus summary statistics (min, max, mean, standard deviation, variance). The shared geometry (vector algebra,
:func:`quad_planarity`, :func:`warping_height` and the least-squares planes) is :mod:`components.core.measures`;
this module publishes those two measures under their old names.

Conventions
-----------
* Per-face values follow the rows of ``F``; per-vertex values the rows of ``V``; per-edge values the rows of the
  unique edge list (sorted ``(a, b)`` pairs with ``a < b``, in lexicographic order).
* A measure that is not defined on every element (e.g. diagonal ratio on a triangle, the conical criterion away
  from interior valence-4 vertices) is returned **only for the elements where it is defined, together with
  their indices** (``faces`` / ``vertices`` outputs). Outputs never contain NaN; statistics of an empty set are
  0 with a count of 0.
* Angles are radians, except the Verdict angle metrics, which keep Verdict's degrees so that its published
  ranges apply. Lengths, heights and distances are model units; ratios are scale-free.
* Triangles are planar: every planarity / warping measure is 0 on them.
* Mesh outputs are ``(V, F)`` tuples, or ``(V, F, C)`` with ``C (n, 3) uint8`` RGB vertex colours for the
  coloured display meshes of :func:`analysis`.

References
----------
libigl ``igl::quad_planarity`` (scale-free planarity). Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang,
"Geometric modeling with conical meshes and developable surfaces", ACM Trans. Graph. 25(3), 2006 (conical
criterion). C. J. Stimpson, C. D. Ernst, P. Knupp, P. P. Pébay, D. Melander, "The Verdict Geometric Quality
Library", Sandia report SAND2007-1751, 2007 (quadrilateral quality metrics).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from components.core import proximity
from components.core.checks import check_choice, check_mesh
from components.core.errors import InputError, MeshError
from components.core.measures import (  # noqa: F401  (quad_planarity, warping_height re-exported: metric outputs)
    FaceData,
    cross,
    dot,
    face_data,
    least_squares_planes,
    mean_edge_lengths,
    norm,
    quad_diagonals,
    quad_planarity,
    smallest_eigenvectors,
    warping_height,
)
from components.core.mesh import bounding_box_diagonal, face_sizes, halfedges, triangulate
from components.core.colors import UNDEFINED_COLOR, colormap, unweld
from components.core.types import Integers, Mesh, Numbers, Texts

log = logging.getLogger(__name__)

_TINY = 1e-12  # zero-length edges / diagonals: relative to the bounding-box diagonal


# ----------------------------------------------------------------------------------------------
# summary statistics


class Summary(NamedTuple):
    """Summary statistics of the defined values of a measure (population std/variance; all 0 when empty)."""

    count: int
    min: float
    max: float
    mean: float
    std: float
    variance: float


def summary(values) -> Summary:
    """Count, min, max, mean, standard deviation and variance of a set of values.

    Parameters
    ----------
    values : (q,) array_like of float
        The defined values only (callers drop undefined elements first). Must be finite.

    Returns
    -------
    Summary
        ``count, min, max, mean, std, variance``; population statistics (``ddof=0``). For an empty set every
        statistic is 0.0 and ``count`` is 0, never NaN.

    Example
    -------
    >>> summary([1.0, 2.0, 3.0]).mean
    2.0
    """
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size == 0:
        return Summary(0, 0.0, 0.0, 0.0, 0.0, 0.0)
    mean = float(x.mean())
    var = float(np.mean((x - mean) ** 2))
    return Summary(int(x.size), float(x.min()), float(x.max()), mean, float(np.sqrt(var)), var)


# ----------------------------------------------------------------------------------------------
# angles between vectors and lines (vector algebra, planarity pieces: components.core.measures)


def _line_angle(n1, n2):
    """Angle in [0, π/2] between the lines spanned by two vectors (0 when either vanishes)."""
    return np.arctan2(norm(cross(n1, n2)), np.abs(dot(n1, n2)))


def _vector_angle(a, b):
    """Angle in [0, π] between two vectors (robust atan2 form, 0 when either vanishes)."""
    return np.arctan2(norm(cross(a, b)), dot(a, b))


# ----------------------------------------------------------------------------------------------
# input handling


class _Topo(NamedTuple):
    """Per-call half-edge topology (computed once per call and passed around; never cached between calls)."""

    H: np.ndarray  # (h, 2) half-edges (from, to), face by face, corner by corner
    HF: np.ndarray  # (h,) face of every half-edge
    prev: np.ndarray  # (h,) previous half-edge in the same face
    E: np.ndarray  # (e, 2) unique undirected edges, a < b, lexicographic
    HE: np.ndarray  # (h,) edge of every half-edge
    count: np.ndarray  # (e,) faces per edge


def _topology(F: np.ndarray, n: int) -> _Topo:
    H, HF = halfedges(F)
    sizes = face_sizes(F)
    start = (np.cumsum(sizes) - sizes)[HF]
    local = np.arange(len(H)) - start
    prev = start + (local - 1) % sizes[HF]
    lo = np.minimum(H[:, 0], H[:, 1])
    hi = np.maximum(H[:, 0], H[:, 1])
    ukey, HE, count = np.unique(lo * np.int64(n) + hi, return_inverse=True, return_counts=True)
    E = np.stack([ukey // n, ukey % n], axis=1)
    return _Topo(H, HF, prev, E, HE.ravel(), count)


def _mesh_arg(mesh, name: str = "mesh", kind: str = "any") -> tuple[np.ndarray, np.ndarray]:
    """Unpack and validate a ``(V, F)`` (or ``(V, F, C)``) mesh input; reject geometry the metrics cannot measure.

    Raises
    ------
    MeshError
        Not a ``(V, F)`` pair, NaN coordinates, bad indices, degenerate or non-manifold faces, zero-length edges or
        diagonals — each message starts with ``name``.
    """
    V, F, _ = _validated(mesh, name, kind)
    return V, F


def _validated(mesh, name: str = "mesh", kind: str = "any") -> tuple[np.ndarray, np.ndarray, _Topo]:
    # the manifold test is done here on the half-edge topology the metrics need anyway: validate_mesh's own
    # (edge_topology + a sort of directed keys) adds ~0.14 s to the 0.5 s report of 100k quads (same wording)
    V, F = check_mesh(mesh, name, kind=kind, manifold=False)
    topo = _topology(F, len(V))
    _check_manifold(topo, name)
    _check_geometry(V, F, topo, name)
    return V, F, topo


def _check_manifold(topo: _Topo, name: str) -> None:
    """Every edge has at most two faces, and the two half-edges of an interior edge run in opposite directions.

    The failures are worded as :func:`components.core.checks.validate_mesh` words them.
    """
    H, E, HE, count = topo.H, topo.E, topo.HE, topo.count
    if np.any(count > 2):
        e = int(np.argmax(count > 2))
        a, b = E[e].tolist()
        raise MeshError(name, f"edge ({a}, {b}) is non-manifold: it has {int(count[e])} faces")
    s = np.where(H[:, 0] < H[:, 1], 1.0, -1.0)
    net = np.bincount(HE, weights=s, minlength=len(E))
    bad = (count == 2) & (net != 0)
    if bad.any():
        a, b = E[int(np.argmax(bad))].tolist()
        raise MeshError(
            name, f"faces are not consistently oriented: edge ({a}, {b}) is used twice in the same direction"
        )


def _check_geometry(V: np.ndarray, F: np.ndarray, topo: _Topo, name: str) -> None:
    """Zero-length edges and zero-length quad diagonals make every ratio meaningless: raise instead of NaN."""
    tol = _TINY * max(bounding_box_diagonal(V), np.finfo(float).tiny)
    E = topo.E
    L = norm(V[E[:, 1]] - V[E[:, 0]])
    bad = L <= tol
    if bad.any():
        e = int(np.argmax(bad))
        f = int(topo.HF[np.argmax(topo.HE == e)])
        a, b = E[e].tolist()
        raise MeshError(name, f"face {f} has a zero-length edge ({a}, {b})")
    sizes = face_sizes(F)
    q = np.nonzero(sizes == 4)[0]
    if len(q):
        Q = F[q]
        d1 = norm(V[Q[:, 2]] - V[Q[:, 0]])
        d2 = norm(V[Q[:, 3]] - V[Q[:, 1]])
        bad = (d1 <= tol) | (d2 <= tol)
        if bad.any():
            i = int(q[np.argmax(bad)])
            raise MeshError(name, f"face {i} has a zero-length diagonal: {F[i].tolist()}")


def _finite(values: np.ndarray, name: str, what: str, element: str = "face", index=None) -> np.ndarray:
    """Guarantee finite outputs: a non-finite value means the input was degenerate in a way not caught earlier."""
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.argmax(bad.reshape(len(values), -1).any(axis=1)))
        j = int(index[i]) if index is not None else i
        raise MeshError(name, f"{what} is undefined at {element} {j} (degenerate geometry)")
    return values


# ----------------------------------------------------------------------------------------------
# planarity, warping, diagonals, areas
# (quad_planarity and warping_height: components.core.measures, imported above)


def planarity_angle(V, F) -> np.ndarray:
    """Planarity of every face as an angle in radians: 0 for a planar face.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    (m,) float64
        Quads: the dihedral angle between the two triangles of the quad across a diagonal, for both diagonals,
        the larger one. The angle is measured between the triangles' *planes* (in ``[0, π/2]``), so a planar
        non-convex quad reads 0. Triangles: 0. n-gons: the largest angle between a corner's plane (the corner
        and its two neighbours) and the least-squares plane. Radians.

    Notes
    -----
    This is the "warp angle" of FE pre-processors (e.g. Pointwise, Oasys PRIMER: the angle between the normals
    of the two triangles of both diagonal splits, the larger).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    return _planarity_angle(V, F, face_data(V, F))


def _planarity_angle(V, F, fd):
    out = np.zeros(len(F))
    q = np.nonzero(fd.sizes == 4)[0]
    if len(q):
        Q = F[q]
        a, b, c, d = (V[Q[:, i]] for i in range(4))
        n_abc = cross(b - a, c - a)
        n_acd = cross(c - a, d - a)
        n_bcd = cross(c - b, d - b)
        n_bda = cross(d - b, a - b)
        out[q] = np.maximum(_line_angle(n_abc, n_acd), _line_angle(n_bcd, n_bda))
    g = np.nonzero(fd.sizes >= 5)[0]
    if len(g):
        _, n, _ = least_squares_planes(fd, g)
        P = fd.points[g]
        s = fd.sizes[g]
        r = np.arange(len(g))
        prv = np.roll(P, 1, axis=1)
        prv[:, 0] = P[r, s - 1]
        nxt = np.roll(P, -1, axis=1)
        nxt[r, s - 1] = P[:, 0]
        Nc = cross(nxt - P, prv - P)
        ang = _line_angle(Nc, n[:, None, :]) * fd.valid[g]
        out[g] = ang.max(axis=1)
    return out


def diagonal_lengths(V, F) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lengths of the two diagonals of every quad.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    faces : (q,) int64
        Indices of the quad faces (the only faces with exactly two diagonals).
    d1 : (q,) float64
        ``|v2 − v0|``, model units.
    d2 : (q,) float64
        ``|v3 − v1|``, model units.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    q = np.nonzero(face_sizes(F) == 4)[0]
    _, l1, l2 = quad_diagonals(V, F, q)
    return q, l1, l2


def polygon_areas(V, F) -> np.ndarray:
    """Area of every face in model units².

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    (m,) float64
        Planar faces: their area. **Non-planar quads and n-gons: the area of the polygon projected onto its
        least-squares plane** (the plane minimising the squared corner distances), computed as ``|A · n|`` with
        ``A = ½ Σ v_i × v_{i+1}`` the face's area vector and ``n`` the plane's unit normal.

    Notes
    -----
    For a non-planar panel this is the area of the flat panel that best fits it; the 3D surface of a warped
    quad is larger by second-order terms in the warping.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    return _areas(V, F, face_data(V, F))


def _areas(V, F, fd):
    out = norm(fd.area_vec)
    g = np.nonzero(fd.sizes >= 4)[0]
    if len(g):
        _, n, _ = least_squares_planes(fd, g)
        out[g] = np.abs(dot(fd.area_vec[g], n))
    return out


# ----------------------------------------------------------------------------------------------
# edges and corner angles


def mesh_edge_lengths(V, F) -> tuple[np.ndarray, np.ndarray]:
    """The unique edges of a mesh and their lengths.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    E : (e, 2) int64
        Unique undirected edges ``(a, b)``, ``a < b``, lexicographic order.
    L : (e,) float64
        Edge lengths, model units.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    E = _topology(F, len(V)).E
    return E, norm(V[E[:, 1]] - V[E[:, 0]])


def interior_angles(V, F) -> tuple[np.ndarray, np.ndarray]:
    """Interior angle at every face corner, in radians.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    angles : (h,) float64
        One angle per corner, face by face, corner by corner (the order of
        :func:`components.core.mesh.halfedges`; the corner of half-edge ``i`` is its start vertex). The angle between
        the two edges at the corner, in ``[0, π]``, replaced by ``2π −`` that angle at reflex corners (where the
        corner turns against the face's Newell normal), so non-convex faces show an angle above π.
    HF : (h,) int64
        Face of every corner.

    Notes
    -----
    The unsigned angles are those of :func:`components.core.measures.corner_angles` (same corner order).

    Example
    -------
    >>> V = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]], dtype=float)
    >>> ang, HF = interior_angles(V, [[0, 1, 2, 3, 4, 5]]); np.degrees(ang).round(6)  # an L: one reflex corner
    array([ 90.,  90.,  90., 270.,  90.,  90.])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    topo = _topology(F, len(V))
    return _interior_angles(V, face_data(V, F), topo), topo.HF


def _interior_angles(V, fd: FaceData, topo: _Topo) -> np.ndarray:
    H, HF, prev = topo.H, topo.HF, topo.prev
    p = V[H[:, 0]]
    e_next = V[H[:, 1]] - p
    e_prev = V[H[prev, 0]] - p
    X = cross(e_next, e_prev)
    ang = np.arctan2(norm(X), dot(e_next, e_prev))
    reflex = dot(X, fd.area_vec[HF]) < 0
    ang[reflex] = 2.0 * np.pi - ang[reflex]
    return ang


def _per_face_min_max(values, sizes):
    start = np.cumsum(sizes) - sizes
    return np.minimum.reduceat(values, start), np.maximum.reduceat(values, start)


# ----------------------------------------------------------------------------------------------
# Verdict quadrilateral quality

VERDICT_METRICS = ("aspect_ratio", "skew", "taper", "warpage", "stretch", "minimum_angle", "maximum_angle",
                   "scaled_jacobian")

#: Verdict's acceptable ranges for quadrilaterals (as tabulated by VTK/PyVista from the Verdict manual).
VERDICT_ACCEPTABLE = {
    "aspect_ratio": (1.0, 1.3),
    "skew": (0.0, 0.7),
    "taper": (0.0, 0.7),
    "warpage": (0.5, 1.0),
    "stretch": (0.25, 1.0),
    "minimum_angle": (45.0, 90.0),
    "maximum_angle": (90.0, 135.0),
    "scaled_jacobian": (0.3, 1.0),
}


def verdict_quad_quality(V, F) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The CUBIT/Verdict quality metrics of every quad.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces (only the quads are measured).

    Returns
    -------
    faces : (q,) int64
        Indices of the quads.
    metrics : dict of str -> (q,) float64
        With ``P0..P3`` the corners, edges ``L0 = P1 − P0, L1 = P2 − P1, L2 = P3 − P2, L3 = P0 − P3``, principal
        axes ``X1 = L0 − L2``, ``X2 = L1 − L3``, cross derivative ``X12 = P0 − P1 + P2 − P3``, corner normals
        ``N_k = L_{k−1} × L_k`` (unit: ``n_k``), centre normal ``n_c = X1 × X2 / |X1 × X2|`` and signed corner areas
        ``α_k = n_c · N_k`` (Verdict's definitions):

        ``aspect_ratio``  ``max|L_k| · Σ|L_k| / (2 (|L0 × L1| + |L2 × L3|))``; 1 for a square; acceptable [1, 1.3].
        ``skew``          ``|X1 · X2| / (|X1| |X2|)``; 0 for a rectangle; acceptable [0, 0.7].
        ``taper``         ``|X12| / min(|X1|, |X2|)``; 0 for a parallelogram; acceptable [0, 0.7].
        ``warpage``       ``min(n0 · n2, n1 · n3)³``; 1 for a planar quad; acceptable [0.5, 1].
        ``stretch``       ``√2 · min|L_k| / max(|P2 − P0|, |P3 − P1|)``; 1 for a square; acceptable [0.25, 1].
        ``minimum_angle`` smallest corner angle, **degrees**; acceptable [45, 90].
        ``maximum_angle`` largest corner angle, **degrees** (``360 −`` it when a corner area ``α_k < 0``);
                          acceptable [90, 135].
        ``scaled_jacobian`` ``min_k α_k / (|L_{k−1}| |L_k|)``; 1 for a rectangle, ≤ 0 for a non-convex quad;
                          acceptable [0.3, 1].

    Notes
    -----
    Definitions follow the Verdict library (Stimpson et al., SAND2007-1751) as implemented in VTK's
    ``V_QuadMetric``. Verdict's *code* returns warpage as the cube itself (1 = planar); the 2007 manual writes
    ``1 −`` the cube and its tables mix the two (VTK issue 19644); the acceptable ranges above are those VTK and
    PyVista tabulate for the code's values.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    q = np.nonzero(face_sizes(F) == 4)[0]
    return q, _verdict(V, F[q])


def _verdict(V, Q) -> dict[str, np.ndarray]:
    P0, P1, P2, P3 = (V[Q[:, i]] for i in range(4))
    L = [P1 - P0, P2 - P1, P3 - P2, P0 - P3]
    ln = [norm(x) for x in L]
    X1 = L[0] - L[2]
    X2 = L[1] - L[3]
    X12 = P0 - P1 + P2 - P3
    nX1, nX2 = norm(X1), norm(X2)
    N = [cross(L[(k - 1) % 4], L[k]) for k in range(4)]
    nc = cross(X1, X2)
    nc = nc / norm(nc)[:, None]
    alpha = [dot(nc, N[k]) for k in range(4)]
    out = {}
    lmax = np.maximum.reduce(ln)
    lmin = np.minimum.reduce(ln)
    out["aspect_ratio"] = 0.5 * lmax * (ln[0] + ln[1] + ln[2] + ln[3]) / (norm(N[1]) + norm(N[3]))
    out["skew"] = np.abs(dot(X1, X2)) / (nX1 * nX2)
    out["taper"] = norm(X12) / np.minimum(nX1, nX2)
    n = [N[k] / norm(N[k])[:, None] for k in range(4)]
    out["warpage"] = np.minimum(dot(n[0], n[2]), dot(n[1], n[3])) ** 3
    dmax = np.maximum(norm(P2 - P0), norm(P3 - P1))
    out["stretch"] = np.sqrt(2.0) * lmin / dmax
    ang = np.stack([np.degrees(_vector_angle(-L[(k - 1) % 4], L[k])) for k in range(4)], axis=1)
    out["minimum_angle"] = ang.min(axis=1)
    amax = ang.max(axis=1)
    neg = np.minimum.reduce(alpha) < 0
    out["maximum_angle"] = np.where(neg, 360.0 - amax, amax)
    out["scaled_jacobian"] = np.minimum.reduce([alpha[k] / (ln[(k - 1) % 4] * ln[k]) for k in range(4)])
    return out


# ----------------------------------------------------------------------------------------------
# conical criterion and valence


def _twins(topo: _Topo) -> np.ndarray:
    """Opposite half-edge of every half-edge, -1 on the boundary."""
    h = len(topo.H)
    order = np.argsort(topo.HE, kind="stable")
    starts = np.cumsum(topo.count) - topo.count
    first = order[starts]
    second = order[np.minimum(starts + 1, h - 1)]
    he = topo.HE
    two = topo.count[he] == 2
    twin = np.where(first[he] == np.arange(h), second[he], first[he])
    return np.where(two, twin, -1)


def conical_criterion_values(V, F) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Conical-mesh angle criterion and normal-cone deviation at every interior valence-4 vertex.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded faces of an edge-manifold, consistently oriented mesh.

    Returns
    -------
    vertices : (c,) int64
        Interior vertices with exactly four edges and four faces (where the criterion is defined).
    criterion : (c,) float64
        ``|ω1 + ω3 − ω2 − ω4|`` in radians, with ``ω1..ω4`` the face angles at the vertex in cyclic order
        (Liu et al. 2006: a quad mesh is conical iff ``ω1 + ω3 = ω2 + ω4`` at every such vertex). Reported as an
        absolute value because its sign depends on which face is counted first.
    cone_deviation : (c,) float64
        The spread (max − min, radians) of the angles between the four face normals and their best-fit cone axis
        (the normal of the plane through the normals' tips fitted by least squares). 0 when the four face
        planes are tangent to a common right circular cone, the geometric meaning of a conical vertex.

    Notes
    -----
    Face angles are the 3D angles between the edges at the vertex; face normals are Newell normals, so the
    measure is meaningful on slightly non-planar meshes too. Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang,
    W. Wang, "Geometric modeling with conical meshes and developable surfaces", ACM TOG 25(3), 2006.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fd = face_data(V, F)
    topo = _topology(F, len(V))
    return _conical(V, fd, topo, _interior_angles(V, fd, topo))


def _conical(V, fd: FaceData, topo: _Topo, ang: np.ndarray):
    n = len(V)
    H, HF, E, count = topo.H, topo.HF, topo.E, topo.count
    valence = np.bincount(E.ravel(), minlength=n)
    boundary = np.zeros(n, dtype=bool)
    boundary[E[count == 1].ravel()] = True
    corners_at = np.bincount(H[:, 0], minlength=n)
    cand = (~boundary) & (valence == 4) & (corners_at == 4)
    verts = np.nonzero(cand)[0]
    if len(verts) == 0:
        return verts, np.zeros(0), np.zeros(0)
    first = np.full(n, -1, dtype=np.int64)
    uv, ui = np.unique(H[:, 0], return_index=True)
    first[uv] = ui  # first corner of every vertex
    # next corner around the vertex: the corner of the half-edge opposite the one entering this corner
    rot = _twins(topo)[topo.prev]
    c0 = first[verts]
    c1 = rot[c0]
    ok = c1 >= 0
    c2 = np.where(ok, rot[np.maximum(c1, 0)], -1)
    ok &= c2 >= 0
    c3 = np.where(ok, rot[np.maximum(c2, 0)], -1)
    ok &= c3 >= 0
    ok &= np.where(ok, rot[np.maximum(c3, 0)] == c0, False)
    verts, c0, c1, c2, c3 = verts[ok], c0[ok], c1[ok], c2[ok], c3[ok]
    crit = np.abs(ang[c0] + ang[c2] - ang[c1] - ang[c3])
    Nf = fd.area_vec / norm(fd.area_vec)[:, None]
    Ns = np.stack([Nf[HF[c]] for c in (c0, c1, c2, c3)], axis=1)  # (c, 4, 3)
    mean = Ns.mean(axis=1)
    X = Ns - mean[:, None, :]
    M = np.einsum("cki,ckj->cij", X, X)
    mlen = norm(mean)
    fallback = np.divide(mean, mlen[:, None], out=np.zeros_like(mean), where=mlen[:, None] > 0)
    axis = smallest_eigenvectors(M, fallback)
    axis[dot(axis, mean) < 0] *= -1.0
    cosang = np.clip(np.einsum("ckj,cj->ck", Ns, axis), -1.0, 1.0)
    phi = np.arccos(cosang)
    dev = phi.max(axis=1) - phi.min(axis=1)
    return verts, crit, dev


def vertex_valences(V, F) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Valence of every vertex and the interior singularities.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions (only their count is used).
    F : (m, k) int64
        Padded faces.

    Returns
    -------
    valence : (n,) int64
        Number of edges at every vertex (0 for unreferenced vertices).
    boundary : (n,) bool
        Vertices on a boundary edge.
    singular : (s,) int64
        Interior (non-boundary, referenced) vertices whose valence is not 4: the singularities of a quad
        layout, e.g. valence 3 and 5.
    """
    F = np.asarray(F, dtype=np.int64)
    topo = _topology(F, len(V))
    return _valence(len(V), topo.E, topo.count)


def _valence(n, E, count):
    valence = np.bincount(E.ravel(), minlength=n).astype(np.int64)
    boundary = np.zeros(n, dtype=bool)
    boundary[E[count == 1].ravel()] = True
    singular = np.nonzero((~boundary) & (valence > 0) & (valence != 4))[0]
    return valence, boundary, singular


# ----------------------------------------------------------------------------------------------
# closeness to a reference surface


def _reference_index(reference, name: str = "reference") -> proximity.TriangleIndex:
    RV, RF = check_mesh(reference, name, allow_degenerate=True, manifold=False)
    RT, _ = triangulate(RF)
    if len(RT) == 0:
        raise MeshError(name, "the reference mesh has no triangle or polygon with 3 distinct corners")
    return proximity.TriangleIndex(RV, RT, name=name)


def vertex_distances(V, reference_V, reference_F, signed: bool | None = None) -> tuple[np.ndarray, bool]:
    """Distance of every vertex to a reference surface mesh.

    Parameters
    ----------
    V : (n, 3) float64
        Points (the vertices of the measured mesh).
    reference_V : (r, 3) float64
        Reference mesh vertices.
    reference_F : (t, k) int64
        Reference faces (triangles or padded polygons; polygons are fan-triangulated).
    signed : bool or None
        ``True`` signed (raises if the reference is not oriented), ``False`` unsigned, ``None`` signed when the
        reference is an oriented edge-manifold mesh.

    Returns
    -------
    distances : (n,) float64
        Exact Euclidean distance to the closest point of the reference, model units; positive on the side the
        reference normals point to when signed.
    signed : bool
        Whether the distances are signed.
    """
    index = _reference_index((reference_V, reference_F))
    use_sign = index.oriented if signed is None else bool(signed)
    return index.query(V, signed=use_sign, name="mesh").distances, use_sign


# ----------------------------------------------------------------------------------------------
# published components

_PLANARITY_MEASURES = ("diagonal", "angle", "warping")


class PlanarityResult(NamedTuple):
    planarity: Numbers
    max_planarity: float
    mean_planarity: float
    min_planarity: float
    std_planarity: float
    variance_planarity: float


def planarity(mesh: Mesh, measure: str = "diagonal") -> PlanarityResult:
    """Planarity of every face of a quad or polygon mesh (0 = planar).

    Parameters
    ----------
    mesh : Mesh
        The quad, triangle or polygon mesh ``(V, F)`` to measure.
    measure : str
        Which planarity: ``"diagonal"`` scale-free (distance between the diagonals / mean diagonal length, as
        libigl's ``quad_planarity``), ``"angle"`` (dihedral angle across the diagonals, radians) or
        ``"warping"`` (distance between the diagonals, model units).

    Returns
    -------
    planarity : Numbers
        Per-face planarity in the chosen measure; triangles are 0; n-gons use the least-squares plane.
    max_planarity : float
        Largest face value.
    mean_planarity : float
        Mean over the faces.
    min_planarity : float
        Smallest face value.
    std_planarity : float
        Standard deviation over the faces.
    variance_planarity : float
        Variance over the faces.

    Raises
    ------
    InputError
        Unknown ``measure``; a malformed, degenerate, non-manifold or NaN ``mesh`` (:class:`MeshError`).

    Notes
    -----
    Formulas in :func:`quad_planarity`, :func:`planarity_angle`, :func:`warping_height`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> planarity(quad_grid(4, 4)).max_planarity
    0.0
    """
    check_choice(measure, "measure", _PLANARITY_MEASURES)
    V, F = _mesh_arg(mesh)
    fn = {"diagonal": quad_planarity, "angle": planarity_angle, "warping": warping_height}[measure]
    values = _finite(fn(V, F), "mesh", "planarity")
    s = summary(values)
    return PlanarityResult(values, s.max, s.mean, s.min, s.std, s.variance)


class WarpingResult(NamedTuple):
    warping: Numbers
    max_warping: float
    mean_warping: float
    min_warping: float
    std_warping: float
    variance_warping: float


def warping(mesh: Mesh) -> WarpingResult:
    """Warping height of every face in model units: the distance between the two diagonals of a quad.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)``.

    Returns
    -------
    warping : Numbers
        Per-face warping height, model units (triangles 0; n-gons: largest corner distance to the least-squares
        plane).
    max_warping : float
        Largest warping height.
    mean_warping : float
        Mean warping height.
    min_warping : float
        Smallest warping height.
    std_warping : float
        Standard deviation.
    variance_warping : float
        Variance, model units².

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh``.
    """
    V, F = _mesh_arg(mesh)
    values = _finite(warping_height(V, F), "mesh", "warping")
    s = summary(values)
    return WarpingResult(values, s.max, s.mean, s.min, s.std, s.variance)


class DiagonalRatioResult(NamedTuple):
    diagonal_ratio: Numbers
    diagonal_1: Numbers
    diagonal_2: Numbers
    faces: Integers
    max_ratio: float
    mean_ratio: float
    min_ratio: float
    std_ratio: float
    variance_ratio: float


def diagonal_ratio(mesh: Mesh) -> DiagonalRatioResult:
    """Diagonal aspect ratio (longer / shorter diagonal) and diagonal lengths of every quad.

    Parameters
    ----------
    mesh : Mesh
        The quad or quad-dominant mesh ``(V, F)``.

    Returns
    -------
    diagonal_ratio : Numbers
        Per quad, ``max(|d1|, |d2|) / min(|d1|, |d2|)`` (1 for rectangles and isosceles trapezoids), unitless.
    diagonal_1 : Numbers
        Per quad, length of the diagonal from corner 0 to corner 2, model units.
    diagonal_2 : Numbers
        Per quad, length of the diagonal from corner 1 to corner 3, model units.
    faces : Integers
        Index of every measured quad (non-quad faces have no two diagonals and are left out).
    max_ratio : float
        Largest ratio.
    mean_ratio : float
        Mean ratio.
    min_ratio : float
        Smallest ratio.
    std_ratio : float
        Standard deviation of the ratio.
    variance_ratio : float
        Variance of the ratio.

    Raises
    ------
    MeshError
        Malformed, degenerate (including a zero-length diagonal), non-manifold or NaN ``mesh``.
    """
    V, F = _mesh_arg(mesh)
    q, l1, l2 = diagonal_lengths(V, F)
    ratio = _finite(np.maximum(l1, l2) / np.minimum(l1, l2), "mesh", "diagonal ratio", index=q)
    s = summary(ratio)
    return DiagonalRatioResult(ratio, l1, l2, q, s.max, s.mean, s.min, s.std, s.variance)


class FaceAreasResult(NamedTuple):
    areas: Numbers
    total_area: float
    max_area: float
    mean_area: float
    min_area: float
    std_area: float
    variance_area: float


def face_areas(mesh: Mesh) -> FaceAreasResult:
    """Area of every face; non-planar quads are measured by their least-squares projected polygon.

    Parameters
    ----------
    mesh : Mesh
        The polygon mesh ``(V, F)``.

    Returns
    -------
    areas : Numbers
        Per-face area, model units². For a non-planar face: the area of the face projected onto its
        least-squares plane (see :func:`polygon_areas`).
    total_area : float
        Sum of the face areas.
    max_area : float
        Largest face area.
    mean_area : float
        Mean face area.
    min_area : float
        Smallest face area.
    std_area : float
        Standard deviation of the areas.
    variance_area : float
        Variance of the areas, model units⁴.

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh``.
    """
    V, F = _mesh_arg(mesh)
    values = _finite(_areas(V, F, face_data(V, F)), "mesh", "area")
    s = summary(values)
    return FaceAreasResult(values, float(values.sum()), s.max, s.mean, s.min, s.std, s.variance)


class EdgeLengthsResult(NamedTuple):
    lengths: Numbers
    max_length: float
    mean_length: float
    min_length: float
    std_length: float
    variance_length: float
    length_ratio: float


def edge_lengths(mesh: Mesh) -> EdgeLengthsResult:
    """Length of every edge of a mesh and their spread.

    Parameters
    ----------
    mesh : Mesh
        The polygon mesh ``(V, F)``.

    Returns
    -------
    lengths : Numbers
        Per unique edge (sorted vertex pairs in lexicographic order), model units.
    max_length : float
        Longest edge.
    mean_length : float
        Mean edge length.
    min_length : float
        Shortest edge.
    std_length : float
        Standard deviation of the lengths.
    variance_length : float
        Variance of the lengths.
    length_ratio : float
        Longest / shortest edge, unitless (1 for a uniform mesh).

    Raises
    ------
    MeshError
        Malformed, degenerate (including zero-length edges), non-manifold or NaN ``mesh``.
    """
    V, F = _mesh_arg(mesh)
    _, L = mesh_edge_lengths(V, F)
    s = summary(L)
    return EdgeLengthsResult(L, s.max, s.mean, s.min, s.std, s.variance, s.max / s.min)


class CornerAnglesResult(NamedTuple):
    min_angle: Numbers
    max_angle: Numbers
    smallest_angle: float
    largest_angle: float
    mean_angle: float
    std_angle: float
    variance_angle: float


def corner_angles(mesh: Mesh) -> CornerAnglesResult:
    """Smallest and largest corner angle of every face, in radians.

    Parameters
    ----------
    mesh : Mesh
        The polygon mesh ``(V, F)``.

    Returns
    -------
    min_angle : Numbers
        Per face, the smallest interior angle, radians.
    max_angle : Numbers
        Per face, the largest interior angle, radians (above π at a reflex corner of a non-convex face).
    smallest_angle : float
        Smallest corner angle of the mesh, radians.
    largest_angle : float
        Largest corner angle of the mesh, radians.
    mean_angle : float
        Mean corner angle over all corners, radians.
    std_angle : float
        Standard deviation of the corner angles over all corners, radians.
    variance_angle : float
        Variance of the corner angles over all corners, radians².

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh``.

    Notes
    -----
    Corner angles are 3D angles between the two edges at the corner, made reflex (``2π − θ``) where the corner
    turns against the face normal; see :func:`interior_angles`. Panels with a corner angle near 0 are collapsed.
    """
    V, F, topo = _validated(mesh)
    fd = face_data(V, F)
    ang = _finite(_interior_angles(V, fd, topo), "mesh", "corner angle", element="corner")
    amin, amax = _per_face_min_max(ang, fd.sizes)
    s = summary(ang)
    return CornerAnglesResult(amin, amax, s.min, s.max, s.mean, s.std, s.variance)


class VerdictResult(NamedTuple):
    values: Numbers
    faces: Integers
    max_value: float
    mean_value: float
    min_value: float
    std_value: float
    variance_value: float
    acceptable_min: float
    acceptable_max: float
    count_outside: int


def verdict_quality(mesh: Mesh, metric: str = "scaled_jacobian") -> VerdictResult:
    """One CUBIT/Verdict quadrilateral quality metric of every quad, with Verdict's acceptable range.

    Parameters
    ----------
    mesh : Mesh
        The quad or quad-dominant mesh ``(V, F)``.
    metric : str
        One of ``"aspect_ratio"``, ``"skew"``, ``"taper"``, ``"warpage"``, ``"stretch"``, ``"minimum_angle"``,
        ``"maximum_angle"`` (degrees, as Verdict) or ``"scaled_jacobian"``.

    Returns
    -------
    values : Numbers
        Per quad, the metric (definitions in :func:`verdict_quad_quality`).
    faces : Integers
        Index of every measured quad (other faces are left out).
    max_value : float
        Largest value.
    mean_value : float
        Mean value.
    min_value : float
        Smallest value.
    std_value : float
        Standard deviation.
    variance_value : float
        Variance.
    acceptable_min : float
        Lower end of Verdict's acceptable range for this metric.
    acceptable_max : float
        Upper end of Verdict's acceptable range.
    count_outside : int
        Number of quads outside the acceptable range.

    Raises
    ------
    InputError
        Unknown ``metric``; malformed, degenerate, non-manifold or NaN ``mesh``.

    Notes
    -----
    C. J. Stimpson, C. D. Ernst, P. Knupp, P. P. Pébay, D. Melander, "The Verdict Geometric Quality Library",
    SAND2007-1751, 2007.
    """
    check_choice(metric, "metric", VERDICT_METRICS)
    V, F = _mesh_arg(mesh)
    q, metrics = verdict_quad_quality(V, F)
    values = _finite(metrics[metric], "mesh", metric, index=q)
    lo, hi = VERDICT_ACCEPTABLE[metric]
    s = summary(values)
    outside = int(np.count_nonzero((values < lo) | (values > hi)))
    return VerdictResult(values, q, s.max, s.mean, s.min, s.std, s.variance, lo, hi, outside)


class ConicalResult(NamedTuple):
    criterion: Numbers
    cone_deviation: Numbers
    vertices: Integers
    max_criterion: float
    mean_criterion: float
    std_criterion: float
    max_deviation: float
    mean_deviation: float


def conical_criterion(mesh: Mesh) -> ConicalResult:
    """Conical-mesh angle criterion |ω1 + ω3 − ω2 − ω4| and normal-cone deviation at interior valence-4 vertices.

    Parameters
    ----------
    mesh : Mesh
        The quad mesh ``(V, F)``.

    Returns
    -------
    criterion : Numbers
        Per measured vertex, ``|ω1 + ω3 − ω2 − ω4|`` of the four face angles in cyclic order, radians
        (0 at a conical vertex).
    cone_deviation : Numbers
        Per measured vertex, the spread (max − min) of the angles between the four face normals and their
        best-fit cone axis, radians (0 at a conical vertex).
    vertices : Integers
        The measured vertices: interior vertices with four edges and four faces.
    max_criterion : float
        Largest criterion.
    mean_criterion : float
        Mean criterion.
    std_criterion : float
        Standard deviation of the criterion.
    max_deviation : float
        Largest cone deviation.
    mean_deviation : float
        Mean cone deviation.

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh``.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, "Geometric modeling with conical meshes and developable surfaces",
    ACM TOG 25(3), 2006; see :func:`conical_criterion_values`.
    """
    V, F = _mesh_arg(mesh)
    verts, crit, dev = conical_criterion_values(V, F)
    _finite(crit, "mesh", "conical criterion", element="vertex", index=verts)
    _finite(dev, "mesh", "cone deviation", element="vertex", index=verts)
    sc, sd = summary(crit), summary(dev)
    return ConicalResult(crit, dev, verts, sc.max, sc.mean, sc.std, sd.max, sd.mean)


class ValenceResult(NamedTuple):
    valence: Integers
    singularities: Integers
    singularity_valence: Integers
    count_singularities: int
    count_valence_3: int
    count_valence_5: int
    count_other: int


def valence(mesh: Mesh) -> ValenceResult:
    """Valence of every vertex and the interior irregular vertices (singularities) of a quad mesh.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)``.

    Returns
    -------
    valence : Integers
        Per vertex, the number of edges (0 for unreferenced vertices).
    singularities : Integers
        Indices of the interior vertices whose valence is not 4.
    singularity_valence : Integers
        Valence of each singularity.
    count_singularities : int
        Number of interior irregular vertices.
    count_valence_3 : int
        Number of interior vertices of valence 3.
    count_valence_5 : int
        Number of interior vertices of valence 5.
    count_other : int
        Number of interior irregular vertices of another valence (2, 6, …).

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh``.
    """
    V, F = _mesh_arg(mesh)
    val, _, sing = vertex_valences(V, F)
    sv = val[sing]
    c3 = int(np.count_nonzero(sv == 3))
    c5 = int(np.count_nonzero(sv == 5))
    return ValenceResult(val, sing, sv, int(len(sing)), c3, c5, int(len(sing)) - c3 - c5)


class ClosenessResult(NamedTuple):
    distances: Numbers
    max_distance: float
    mean_distance: float
    std_distance: float
    rms_distance: float
    signed: bool
    warnings: list[str]


def closeness(mesh: Mesh, reference: Mesh) -> ClosenessResult:
    """Distance of every vertex of a mesh to a reference surface mesh, in model units.

    Parameters
    ----------
    mesh : Mesh
        The mesh ``(V, F)`` whose vertices are measured.
    reference : Mesh
        The reference surface as a triangle or polygon mesh ``(V, F)`` (e.g. the design surface meshed finely).

    Returns
    -------
    distances : Numbers
        Per vertex, the exact distance to the reference surface, model units; signed (positive on the side the
        reference normals point to) when the reference is an oriented edge-manifold mesh.
    max_distance : float
        Largest absolute distance.
    mean_distance : float
        Mean absolute distance.
    std_distance : float
        Standard deviation of the absolute distances.
    rms_distance : float
        Root mean square distance.
    signed : bool
        Whether the distances carry a sign.

    Raises
    ------
    MeshError
        Malformed ``mesh`` or ``reference`` (NaN, bad indices, empty).

    Notes
    -----
    Exact point-to-triangle distances through a k-d tree with a certified candidate radius
    (:class:`components.core.proximity.TriangleIndex`); the sign uses the angle-weighted pseudo-normals of
    Bærentzen & Aanæs (2005).
    """
    V, F = _mesh_arg(mesh)
    index = _reference_index(reference)
    warnings = []
    if not index.oriented:
        warnings.append("reference is not an oriented manifold mesh: distances are unsigned")
    d = index.query(V, signed=index.oriented, name="mesh").distances
    a = np.abs(d)
    s = summary(a)
    return ClosenessResult(d, s.max, s.mean, s.std, float(np.sqrt(np.mean(a * a))), bool(index.oriented), warnings)


# ----------------------------------------------------------------------------------------------
# analysis (coloured display mesh) and report

#: measure name -> (element, description)
MEASURES = {
    "planarity": ("face", "scale-free planarity (diagonal distance / mean diagonal)"),
    "planarity_angle": ("face", "planarity as the larger dihedral angle across a diagonal, radians"),
    "warping": ("face", "warping height (distance between the diagonals), model units"),
    "diagonal_ratio": ("face", "longer / shorter diagonal of quads"),
    "area": ("face", "face area (least-squares projected for non-planar faces), model units²"),
    "min_angle": ("face", "smallest corner angle of the face, radians"),
    "max_angle": ("face", "largest corner angle of the face, radians"),
    **{f"verdict_{k}": ("face", f"Verdict quad {k.replace('_', ' ')}") for k in VERDICT_METRICS},
    "conical": ("vertex", "conical criterion |ω1 + ω3 − ω2 − ω4| at interior valence-4 vertices, radians"),
    "cone_deviation": ("vertex", "spread of the face-normal angles to the best-fit cone axis, radians"),
    "valence": ("vertex", "vertex valence"),
    "closeness": ("vertex", "distance to the reference surface, model units"),
}


def measure_values(V, F, measure: str, reference=None) -> tuple[str, np.ndarray, np.ndarray]:
    """Values of one named measure on the elements where it is defined.

    Parameters
    ----------
    V : (n, 3) float64
        Validated vertex positions.
    F : (m, k) int64
        Validated faces.
    measure : str
        A key of :data:`MEASURES`.
    reference : (V, F) tuple or None
        Reference surface mesh, needed by ``"closeness"``.

    Returns
    -------
    element : str
        ``"face"`` or ``"vertex"``.
    indices : (q,) int64
        Elements where the measure is defined.
    values : (q,) float64
    """
    check_choice(measure, "measure", MEASURES)
    element = MEASURES[measure][0]
    m, n = len(F), len(V)
    allf = np.arange(m)
    if measure == "planarity":
        return element, allf, quad_planarity(V, F)
    if measure == "planarity_angle":
        return element, allf, planarity_angle(V, F)
    if measure == "warping":
        return element, allf, warping_height(V, F)
    if measure == "diagonal_ratio":
        q, l1, l2 = diagonal_lengths(V, F)
        return element, q, np.maximum(l1, l2) / np.minimum(l1, l2)
    if measure == "area":
        return element, allf, polygon_areas(V, F)
    if measure in ("min_angle", "max_angle"):
        fd = face_data(V, F)
        amin, amax = _per_face_min_max(_interior_angles(V, fd, _topology(F, n)), fd.sizes)
        return element, allf, amin if measure == "min_angle" else amax
    if measure.startswith("verdict_"):
        q, metrics = verdict_quad_quality(V, F)
        return element, q, metrics[measure[len("verdict_"):]]
    if measure in ("conical", "cone_deviation"):
        verts, crit, dev = conical_criterion_values(V, F)
        return element, verts, crit if measure == "conical" else dev
    if measure == "valence":
        val = vertex_valences(V, F)[0]
        used = np.nonzero(val > 0)[0]
        return element, used, val[used].astype(np.float64)
    # closeness
    if reference is None:
        raise InputError("reference", "the closeness measure needs a reference mesh")
    index = _reference_index(reference)
    d = index.query(V, signed=index.oriented, name="mesh").distances
    return element, np.arange(n), d


class AnalysisResult(NamedTuple):
    display: Mesh
    values: Numbers
    indices: Integers
    element: str
    legend_min: float
    legend_max: float


def analysis(mesh: Mesh, measure: str = "planarity", reference: Mesh | None = None, legend_min: float = 0.0,
             legend_max: float = 0.0) -> AnalysisResult:
    """Colour a mesh by a quality measure: an unwelded display mesh with per-vertex colours, values and legend.

    Parameters
    ----------
    mesh : Mesh
        The mesh ``(V, F)`` to analyse.
    measure : str
        The measure: ``"planarity"``, ``"planarity_angle"``, ``"warping"``, ``"diagonal_ratio"``, ``"area"``,
        ``"min_angle"``, ``"max_angle"``, ``"verdict_<metric>"`` (e.g. ``"verdict_scaled_jacobian"``),
        ``"conical"``, ``"cone_deviation"``, ``"valence"`` or ``"closeness"``.
    reference : Mesh, optional
        Reference surface mesh, required by ``"closeness"``.
    legend_min : float
        Value drawn with the first colour of the map; used with ``legend_max`` when ``legend_max > legend_min``,
        otherwise the legend spans the values.
    legend_max : float
        Value drawn with the last colour of the map.

    Returns
    -------
    display : Mesh
        ``(V, F, C)``: the mesh unwelded (every face has its own corner vertices) with ``C (n, 3) uint8`` RGB
        vertex colours (viridis; grey where the measure is undefined). Face measures give each face one flat
        colour; vertex measures colour each face corner by its vertex.
    values : Numbers
        The measure on the elements where it is defined.
    indices : Integers
        The faces or vertices those values belong to.
    element : str
        ``"face"`` or ``"vertex"``.
    legend_min : float
        Value of the first legend colour.
    legend_max : float
        Value of the last legend colour.

    Raises
    ------
    InputError
        Unknown ``measure``, ``"closeness"`` without ``reference``, malformed ``mesh`` or ``reference``.
    """
    check_choice(measure, "measure", MEASURES)
    V, F = _mesh_arg(mesh)
    element, idx, values = measure_values(V, F, measure, reference)
    values = _finite(np.asarray(values, dtype=np.float64), "mesh", measure, element=element, index=idx)
    if legend_max > legend_min:
        lo, hi = float(legend_min), float(legend_max)
    elif len(values):
        lo, hi = float(values.min()), float(values.max())
    else:
        lo = hi = 0.0
    VD, FD, corner_face, corner_vertex = unweld(V, F)
    C = np.empty((len(VD), 3), dtype=np.uint8)
    C[:] = UNDEFINED_COLOR
    owner = corner_face if element == "face" else corner_vertex
    size = len(F) if element == "face" else len(V)
    defined = np.zeros(size, dtype=bool)
    defined[idx] = True
    colour = np.empty((size, 3), dtype=np.uint8)
    colour[idx] = colormap(values, lo, hi)
    mask = defined[owner]
    C[mask] = colour[owner[mask]]
    return AnalysisResult((VD, FD, C), values, idx.astype(np.int64), element, lo, hi)


def metrics_report(V, F, reference=None, name: str = "mesh") -> dict[str, float]:
    """All summary numbers of a mesh as one flat table.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, k) array_like of int
        Padded faces.
    reference : (V, F) tuple, optional
        Reference surface mesh; adds the ``closeness_*`` entries.
    name : str
        Name of the mesh input in error messages.

    Returns
    -------
    dict of str -> float
        Counts (``vertices``, ``faces``, ``quads``, ``triangles``, ``ngons``, ``edges``, ``boundary_edges``,
        ``singularities``, ``valence_3``, ``valence_5``, ``conical_vertices``), ``total_area``, and for every
        measure ``<measure>_min``, ``_max``, ``_mean``, ``_std``, ``_variance`` over its defined elements:
        ``planarity``, ``planarity_angle``, ``warping``, ``diagonal_ratio``, ``area``, ``edge_length``,
        ``corner_angle``, ``verdict_<metric>`` for the eight Verdict metrics, ``conical``, ``cone_deviation``
        and, with a reference, ``closeness`` (absolute distances). Insertion order is stable.

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN mesh.
    """
    V, F, topo = _validated((V, F), name=name)
    return _report_table(V, F, topo, reference, name)


def _report_table(V, F, topo: _Topo, reference, name: str) -> dict[str, float]:
    """:func:`metrics_report` of a validated mesh and its topology."""
    n, m = len(V), len(F)
    fd = face_data(V, F)
    out: dict[str, float] = {}
    E, count = topo.E, topo.count
    val, boundary, sing = _valence(n, E, count)
    ang = _interior_angles(V, fd, topo)
    verts, crit, dev = _conical(V, fd, topo, ang)
    out["vertices"] = float(n)
    out["faces"] = float(m)
    out["quads"] = float(np.count_nonzero(fd.sizes == 4))
    out["triangles"] = float(np.count_nonzero(fd.sizes == 3))
    out["ngons"] = float(np.count_nonzero(fd.sizes >= 5))
    out["edges"] = float(len(E))
    out["boundary_edges"] = float(np.count_nonzero(count == 1))
    out["singularities"] = float(len(sing))
    out["valence_3"] = float(np.count_nonzero(val[sing] == 3))
    out["valence_5"] = float(np.count_nonzero(val[sing] == 5))
    out["conical_vertices"] = float(len(verts))
    areas = _areas(V, F, fd)
    out["total_area"] = float(areas.sum())

    def add(key, values):
        s = summary(_finite(np.asarray(values, dtype=np.float64), name, key))
        out[f"{key}_min"], out[f"{key}_max"], out[f"{key}_mean"] = s.min, s.max, s.mean
        out[f"{key}_std"], out[f"{key}_variance"] = s.std, s.variance

    q = np.nonzero(fd.sizes == 4)[0]
    h, l1, l2 = quad_diagonals(V, F, q)
    plan = np.zeros(m)
    warp = np.zeros(m)
    plan[q] = h / (0.5 * (l1 + l2))
    warp[q] = h
    g = np.nonzero(fd.sizes >= 5)[0]
    if len(g):
        _, _, d = least_squares_planes(fd, g)
        dmax = np.abs(d).max(axis=1)
        plan[g] = dmax / mean_edge_lengths(fd, g)
        warp[g] = dmax
    add("planarity", plan)
    add("planarity_angle", _planarity_angle(V, F, fd))
    add("warping", warp)
    add("diagonal_ratio", np.maximum(l1, l2) / np.minimum(l1, l2))
    add("area", areas)
    add("edge_length", norm(V[E[:, 1]] - V[E[:, 0]]))
    add("corner_angle", ang)
    ver = _verdict(V, F[q])
    for k in VERDICT_METRICS:
        add(f"verdict_{k}", ver[k])
    add("conical", crit)
    add("cone_deviation", dev)
    if reference is not None:
        index = _reference_index(reference)
        add("closeness", np.abs(index.query(V, name=name).distances))
    return out


class ReportResult(NamedTuple):
    names: Texts
    values: Numbers


def report(mesh: Mesh, reference: Mesh | None = None) -> ReportResult:
    """All summary numbers of a mesh (counts, planarity, shape, conical, closeness) as one name/value table.

    Parameters
    ----------
    mesh : Mesh
        The mesh ``(V, F)`` to report on.
    reference : Mesh, optional
        Reference surface mesh; adds the closeness statistics.

    Returns
    -------
    names : Texts
        Row names, e.g. ``"planarity_max"`` (see :func:`metrics_report`).
    values : Numbers
        Row values, in the same order.

    Raises
    ------
    MeshError
        Malformed, degenerate, non-manifold or NaN ``mesh`` or ``reference``.
    """
    V, F, topo = _validated(mesh)
    table = _report_table(V, F, topo, reference, "mesh")
    return ReportResult(list(table), np.array(list(table.values()), dtype=np.float64))
