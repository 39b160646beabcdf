"""Panel health: is a panelling fabricable, and if not, why — one measure for every strategy and the planarizer.

"Planar and converged" is not enough: a result can be planar while its panels are collapsed (an edge 2.09 → 5e-10),
folded over each other, pinched to 0.08° corners, or cover only part of the design surface. :func:`face_health`
measures all of it on ``(V, F)`` arrays and says, line by line, what is wrong; :func:`panel_health` is the published
component (``metrics/panel_health``).

Checks (a face may fail several; each sets one bit of ``face_defects``)
------------------------------------------------------------------------
=====  ================  ==========================================================================================
bit    name              a face fails when
=====  ================  ==========================================================================================
1      ``nonplanar``     its scale-free planarity (:func:`components.core.measures.quad_planarity`) is above
                         ``tolerance`` (triangles are planar)
2      ``short_edge``    one of its edges is shorter than ``min_edge_ratio`` × the median edge
4      ``degenerate``    it has coincident corners (an edge ≤ 1e-9 × the median edge), zero area (≤ 1e-12 × median
                         edge²) or fewer than 3 distinct corners; the shape checks below skip degenerate faces
8      ``corner``        a corner is under ``min_angle`` or over 180° − ``min_angle`` (triangles included)
16     ``nonconvex``     a corner turns against the face normal (:func:`components.core.measures.nonconvex_faces`)
32     ``small``         its area is under ``min_area_ratio`` × the median face area
64     ``intersecting``  it crosses or overlaps a face it shares no vertex with
128    ``folded``        it and a face sharing one of its edges open by less than ``min_angle`` (folded onto each
                         other)
256    ``flipped``       (with a reference) its normal points against the design surface's normal at the closest
                         point, while most of the area points along it
512    ``far``           (with ``closeness_limit``) a corner is farther from the design surface than
                         ``closeness_limit`` × the median edge
1024   ``nonmanifold``   one of its edges has more than two faces or joins two faces of opposite orientation, or
                         a corner of it is pinched: a vertex with two boundary edges leaving it (two fans welded at
                         a point) or a boundary corner within 0.01 × the median edge of a boundary corner it shares
                         no edge with (two pieces touching there unwelded, which the planarizer refuses as input)
=====  ================  ==========================================================================================

With a reference (the design surface) the **coverage** is measured too: the reference is sampled (sub-triangle
centroids, several per median panel, weighted by area); a sample is covered when its distance to the panelling is
under ``coverage_distance`` × the median edge and its closest point on the panelling is not on the panelling's
boundary (beyond it), unless the sample is within ``boundary_margin`` × the median edge (the chord of a curved
boundary). ``coverage`` is the covered share of the reference's area (within 5 % of ``min_coverage`` it is measured
again with samples four times finer: coarse samples overstate it along the boundary); ``holes`` counts the connected
uncovered regions larger than one median panel.

Scale and placement
-------------------
Every bound is relative to the mesh's own size (median edge, median face area), never an absolute epsilon, and
positions are taken relative to a bounding-box centre before any product (the mesh's; the reference's own for the
reference, so that its closest-point index is built once and reused by every check against it): the verdict and
every ratio are the same for a model scaled by 0.001 or 1000 or moved by 5e6.

References
----------
T. Möller, "A fast triangle-triangle intersection test", Journal of Graphics Tools 2(2), 1997 (plane-side
rejection, then edges against the other triangle). libigl ``igl::quad_planarity``.
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from components.core.checks import check_mesh, check_number, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.measures import corner_angles, cross, dot, nonconvex_faces, norm, quad_planarity, unit
from components.core.mesh import edge_topology, face_normals, face_sizes, halfedges, triangulate
from components.core.proximity import TriangleIndex
from components.core.types import Integers, Mesh, Texts

log = logging.getLogger(__name__)

__all__ = ["DEFECTS", "DEFECT_BITS", "PanelHealth", "face_health", "shape_healthy", "PanelHealthResult", "panel_health"]

#: the defect names, in bit order (bit ``1 << i`` of ``face_defects`` is ``DEFECTS[i]``)
DEFECTS = ("nonplanar", "short_edge", "degenerate", "corner", "nonconvex", "small", "intersecting", "folded",
           "flipped", "far", "nonmanifold")
#: defect name → bit value
DEFECT_BITS = {name: 1 << i for i, name in enumerate(DEFECTS)}

_COINCIDENT = 1e-9  # an edge this short (× median edge) means coincident corners
_ZERO_AREA = 1e-12  # a face this small (× median edge²) has no area
_SLIVER = 1e-9  # triangles with |cross| ≤ this × longest edge² have no plane: left out of the intersection test
_MAX_SAMPLES = 150_000  # coverage samples at most
_MAX_LEVEL = 256  # largest subdivision of one reference triangle into samples
_REFINE_BAND = 0.05  # a coverage this close to min_coverage is measured again with samples _REFINE times finer:
_REFINE = 4  # a sub-triangle is covered or not as a whole, and where the panels' boundary chords cut off slivers
# narrower than the spacing the centroids overstate the coverage (the 52-panel wave sample: 85.2% at the default
# spacing, 84.1% at half of it, 83.7% at a quarter, 83.4% at an eighth; a healthy claim at 85.2% was false)
_WARPED = 1e-3  # quads warped more than this (scale-free planarity) are judged by both of their splits
_PAIR_CHUNK = 250_000  # triangle pairs tested together
TOUCH = 0.01  # boundary corners closer than this × the median edge that share no edge touch (a pinch)


class PanelHealth(NamedTuple):
    """The health of a panelling (see :func:`face_health`).

    Attributes
    ----------
    healthy : bool
        No violation.
    violations : list of str
        One line per failed check: the count and the worst value relative to its bound.
    face_defects : (m,) int64
        Bit mask per face, bits of :data:`DEFECT_BITS` (0 for a healthy face).
    counts : dict of str -> int
        Faces with each defect, by name (``"short_edge"`` counts faces; ``short_edges`` lists the edges).
    planarity : (m,) float64
        Scale-free planarity per face (0 for triangles and degenerate faces).
    min_corner, max_corner : (m,) float64
        Smallest and largest corner angle of every face, degrees.
    area_ratio : (m,) float64
        Face area / median face area.
    short_edges : (s, 2) int64
        The edges shorter than ``min_edge_ratio`` × median edge, as vertex pairs, shortest first.
    intersecting_pairs : (p, 2) int64
        Pairs of faces (sharing no vertex) that cross or overlap, ``a < b``, sorted.
    coverage : float
        Covered share of the reference's area, 0..1; NaN without a reference.
    holes : int
        Uncovered regions of the reference larger than one median panel (0 without a reference).
    worst_corner : float
        The corner angle farthest into its bounds (closest to 0° or 180°), degrees, over non-degenerate faces.
    shortest_edge_ratio : float
        Shortest edge / median edge.
    max_distance, mean_distance : float
        Largest and mean distance of the vertices to the reference / median edge; NaN without a reference.
    reversed : bool
        Most of the panelling's area faces against the reference's normals (its orientation is reversed; not a
        defect by itself).
    median_edge, median_area : float
        The scales every bound is relative to (model units, model units²).
    """

    healthy: bool
    violations: list
    face_defects: np.ndarray
    counts: dict
    planarity: np.ndarray
    min_corner: np.ndarray
    max_corner: np.ndarray
    area_ratio: np.ndarray
    short_edges: np.ndarray
    intersecting_pairs: np.ndarray
    coverage: float
    holes: int
    worst_corner: float
    shortest_edge_ratio: float
    max_distance: float
    mean_distance: float
    reversed: bool
    median_edge: float
    median_area: float


# ----------------------------------------------------------------------------------------------
# the array-level measure


def face_health(
    V,
    F,
    reference=None,
    *,
    tolerance: float = 1e-3,
    min_edge_ratio: float = 0.2,
    min_angle: float = 20.0,
    min_area_ratio: float = 0.1,
    min_coverage: float = 0.85,
    closeness_limit: float | None = None,
    coverage_distance: float = 0.25,
    boundary_margin: float = 0.05,
    intersection_tolerance: float = 1e-3,
    name: str = "mesh",
) -> PanelHealth:
    """Check every panel of a mesh for what makes it unfabricable, with all bounds relative to the mesh's size.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, k) array_like of int
        Padded polygon faces (quads, triangles ``(a, b, c, c)``, n-gons).
    reference : (Vr, Fr), TriangleIndex or None
        The design surface (triangles or polygons, fan-triangulated; or the
        :class:`~components.core.proximity.TriangleIndex` of its triangles): adds flipped faces, closeness and
        coverage. Its closest-point index is built once per surface (by content) and reused by later calls.
    tolerance : float
        Largest scale-free planarity of a healthy face (:func:`components.core.measures.quad_planarity`).
    min_edge_ratio : float
        Shortest healthy edge, × the median edge.
    min_angle : float
        Smallest healthy corner, degrees (corners over 180° − ``min_angle`` fail too; adjacent faces opening by
        less than it are folded). Below 90.
    min_area_ratio : float
        Smallest healthy face area, × the median face area.
    min_coverage : float
        Smallest healthy coverage of the reference, 0..1.
    closeness_limit : float or None
        Largest healthy vertex distance to the reference, × the median edge; ``None`` reports it only.
    coverage_distance : float
        A reference sample farther than this × the median edge from the panelling is not covered.
    boundary_margin : float
        A sample beyond the panelling's boundary still counts as covered within this × the median edge.
    intersection_tolerance : float
        Distances under this × the median edge count as touching, not crossing, in the intersection test.
    name : str
        Name of the mesh in error messages.

    Returns
    -------
    PanelHealth
        ``healthy``, ``violations`` (one line per failed check), per-face ``face_defects`` bits (see
        :data:`DEFECT_BITS`) and values, ``coverage``, ``holes``, ``worst_corner``, ``shortest_edge_ratio`` …

    Raises
    ------
    MeshError
        ``V``/``F`` or ``reference`` malformed (empty, NaN, indices out of range), or all vertices coincide.
    InputError
        A bound out of range.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4)
    >>> h = face_health(V, Q, (V, triangulate(Q)[0])); h.healthy, h.violations, round(h.coverage, 6)
    (True, [], 1.0)
    >>> V[7, 0] = V[6, 0] + 1e-12  # edge (6, 7) collapsed
    >>> for line in face_health(V, Q).violations: print(line)
    1 edge shorter than 0.2 × median edge (shortest 4e-12 × median: edge (6, 7))
    2 degenerate faces (coincident corners or zero area), e.g. face 1
    """
    V, F = validate_mesh(V, F, name=name, allow_degenerate=True, manifold=False)
    opts = _checked_options(tolerance, min_edge_ratio, min_angle, min_area_ratio, min_coverage, closeness_limit,
                            coverage_distance, boundary_margin, intersection_tolerance)
    center = 0.5 * (V.min(axis=0) + V.max(axis=0))
    X = V - center
    ref = None
    if reference is not None:
        Xr, Tr, ref_center = _reference_triangles(reference)
        ref = (Xr, Tr, center - ref_center)
    return _health(X, F, ref, opts, name)


class _Options(NamedTuple):
    tolerance: float
    min_edge_ratio: float
    min_angle: float
    min_area_ratio: float
    min_coverage: float
    closeness_limit: float | None
    coverage_distance: float
    boundary_margin: float
    intersection_tolerance: float


def _checked_options(tolerance, min_edge_ratio, min_angle, min_area_ratio, min_coverage, closeness_limit,
                     coverage_distance, boundary_margin, intersection_tolerance) -> _Options:
    min_angle = check_number(min_angle, "min_angle", 0.0)
    if min_angle >= 90.0:
        raise InputError("min_angle", f"must be a finite number between 0 and 90 (exclusive), got {min_angle!r}")
    min_coverage = check_number(min_coverage, "min_coverage", 0.0)
    if min_coverage > 1.0:
        raise InputError("min_coverage", f"must be a finite number between 0 and 1, got {min_coverage!r}")
    return _Options(
        check_number(tolerance, "tolerance", 0.0),
        check_number(min_edge_ratio, "min_edge_ratio", 0.0),
        min_angle,
        check_number(min_area_ratio, "min_area_ratio", 0.0),
        min_coverage,
        None if closeness_limit is None else check_number(closeness_limit, "closeness_limit", 0.0),
        check_number(coverage_distance, "coverage_distance", 0.0, above=True),
        check_number(boundary_margin, "boundary_margin", 0.0),
        check_number(intersection_tolerance, "intersection_tolerance", 0.0),
    )


def _reference_triangles(reference, name: str = "reference"):
    """The reference as vertices relative to its own bounding-box centre, triangles (those with a repeated corner
    dropped: no area) and that centre. Centred on itself, the same design surface gives the same arrays for every
    panelling checked against it, so its closest-point index is built once (:class:`TriangleIndex` reuses it)."""
    if isinstance(reference, TriangleIndex):
        Vr, Fr = reference.V, reference.T
    else:
        Vr, Fr = check_mesh(reference, name, allow_degenerate=True, manifold=False)
    Tr = Fr if Fr.shape[1] == 3 else triangulate(Fr)[0]
    Tr = Tr[(Tr[:, 0] != Tr[:, 1]) & (Tr[:, 1] != Tr[:, 2]) & (Tr[:, 0] != Tr[:, 2])]
    if len(Tr) == 0:
        raise MeshError(name, "has no triangle or polygon with 3 distinct corners")
    center = 0.5 * (Vr.min(axis=0) + Vr.max(axis=0))
    return Vr - center, Tr, center


class _Findings:
    """The per-face defect bits and the violation lines, filled check by check."""

    def __init__(self, m: int):
        self.bits = np.zeros(m, dtype=np.int64)
        self.lines: list[str] = []

    def flag(self, defect: str, faces: np.ndarray, line: str) -> None:
        """Set ``defect`` on the faces of the ``(m,) bool`` mask ``faces``; add ``line`` when there is one."""
        if faces.any():
            self.bits[faces] |= DEFECT_BITS[defect]
            self.lines.append(line)


class _Scales(NamedTuple):
    sizes: np.ndarray  # (m,) corners per face
    topo: object  # EdgeTopology
    H: np.ndarray  # (h, 2) half-edges
    HF: np.ndarray  # (h,) their faces
    lengths: np.ndarray  # (e,) edge lengths
    area_vec: np.ndarray  # (m, 3) Newell area vectors
    area: np.ndarray  # (m,) face areas
    degenerate: np.ndarray  # (m,) bool
    edge: float  # median edge
    face_area: float  # median area of the non-degenerate faces


def _scales(X, F, name: str) -> _Scales:
    """Topology, edge lengths, areas, degenerate faces and the two scales every bound is relative to."""
    sizes = face_sizes(F)
    topo = edge_topology(F)
    H, HF = halfedges(F)
    lengths = norm(X[topo.E[:, 1]] - X[topo.E[:, 0]])
    L = float(np.median(lengths)) if len(lengths) else 0.0
    if not L > 0.0:  # more than half the edges collapsed: the longest one still measures the mesh
        L = float(lengths.max()) if len(lengths) else 0.0
    if not L > 0.0:
        raise MeshError(name, "all vertices coincide: no edge has a length")
    area_vec = face_normals(X, F, unit=False)
    area = norm(area_vec)
    shortest = np.minimum.reduceat(lengths[topo.HE], np.cumsum(sizes) - sizes)
    degenerate = (sizes < 3) | (shortest <= _COINCIDENT * L) | (area <= _ZERO_AREA * L * L)
    A = float(np.median(area[~degenerate])) if (~degenerate).any() else L * L
    return _Scales(sizes, topo, H, HF, lengths, area_vec, area, degenerate, L, A)


def _health(X, F, ref, o: _Options, name: str) -> PanelHealth:
    sc = _scales(X, F, name)
    out = _Findings(len(F))
    shape = _shape_checks(X, F, sc, o, out)
    pairs = _crossing_checks(X, F, sc, o, out)
    reach = _reference_checks(X, F, sc, ref, o, out, name) if ref is not None else (np.nan, 0, np.nan, np.nan, False)
    coverage, holes, dmax, dmean, rev = reach
    counts = {d: int(np.count_nonzero(out.bits & DEFECT_BITS[d])) for d in DEFECTS}
    return PanelHealth(
        healthy=not out.lines, violations=out.lines, face_defects=out.bits, counts=counts, planarity=shape[0],
        min_corner=shape[1], max_corner=shape[2], area_ratio=sc.area / sc.face_area, short_edges=shape[3],
        intersecting_pairs=pairs, coverage=float(coverage), holes=int(holes), worst_corner=shape[4],
        shortest_edge_ratio=float(sc.lengths.min() / sc.edge), max_distance=float(dmax), mean_distance=float(dmean),
        reversed=bool(rev), median_edge=sc.edge, median_area=sc.face_area,
    )


def _shape_checks(X, F, sc: _Scales, o: _Options, out: _Findings):
    """Planarity, short edges, degenerate faces, corner angles, convexity and small faces.

    Returns planarity ``(m,)``, smallest and largest corner ``(m,)`` (degrees), the short edges ``(s, 2)`` shortest
    first, and the worst corner (degrees).
    """
    m = len(F)
    good = ~sc.degenerate
    P = np.nan_to_num(quad_planarity(X, F), nan=0.0, posinf=0.0)
    P[sc.degenerate] = 0.0
    w = float(P.max()) if m else 0.0
    out.flag("nonplanar", P > o.tolerance,
             f"{_n(np.sum(P > o.tolerance), 'face')} not planar: planarity above {o.tolerance:g} (worst {w:.3g} = "
             f"{w / o.tolerance if o.tolerance > 0 else np.inf:.3g} × the tolerance, face {int(np.argmax(P))})")

    ratio = sc.lengths / sc.edge
    short = np.nonzero(ratio < o.min_edge_ratio)[0]
    short = short[np.argsort(ratio[short], kind="stable")]
    if len(short):
        a, b = sc.topo.E[short[0]].tolist()
        on_short = np.zeros(m, dtype=bool)
        on_short[sc.HF[np.isin(sc.topo.HE, short)]] = True
        out.flag("short_edge", on_short,
                 f"{_n(len(short), 'edge')} shorter than {o.min_edge_ratio:g} × median edge "
                 f"(shortest {ratio[short[0]]:.3g} × median: edge ({a}, {b}))")
    out.flag("degenerate", sc.degenerate, f"{_n(sc.degenerate.sum(), 'degenerate face')} (coincident corners or "
                                          f"zero area), e.g. face {int(np.argmax(sc.degenerate))}")

    ang = np.degrees(corner_angles(X, F))
    starts = np.cumsum(sc.sizes) - sc.sizes
    lo = np.minimum.reduceat(ang, starts) if m else np.zeros(0)
    hi = np.maximum.reduceat(ang, starts) if m else np.zeros(0)
    worst, face = _worst_corner(lo, hi, good)
    bad = good & ((lo < o.min_angle) | (hi > 180.0 - o.min_angle))
    out.flag("corner", bad, f"{_n(bad.sum(), 'face')} with corners under {o.min_angle:g}° or over "
                            f"{180.0 - o.min_angle:g}° (worst {worst:.3g}° at face {face})")
    nonconvex = nonconvex_faces(X, F) & good
    out.flag("nonconvex", nonconvex,
             f"{_n(nonconvex.sum(), 'non-convex face')}, e.g. face {int(np.argmax(nonconvex))}")

    area_ratio = sc.area / sc.face_area
    small = good & (area_ratio < o.min_area_ratio)
    i = int(np.argmin(np.where(small, area_ratio, np.inf))) if m else 0
    out.flag("small", small, f"{_n(small.sum(), 'face')} smaller than {o.min_area_ratio:g} × median face area "
                             f"(smallest {area_ratio[i] if m else 0:.3g} × median: face {i})")
    return P, lo, hi, sc.topo.E[short], worst


def _crossing_checks(X, F, sc: _Scales, o: _Options, out: _Findings) -> np.ndarray:
    """Faces crossing faces they share no vertex with, faces folded onto an edge neighbour, non-manifold edges.

    Returns the crossing face pairs ``(p, 2)``.
    """
    m = len(F)
    pairs = _intersecting_pairs(X, F, ~sc.degenerate, o.intersection_tolerance * sc.edge)
    crossing = np.zeros(m, dtype=bool)
    crossing[pairs.ravel()] = True
    if len(pairs):
        a, b = pairs[0].tolist()
        out.flag("intersecting", crossing, f"{_n(crossing.sum(), 'face')} fold over non-adjacent faces "
                                           f"({_n(len(pairs), 'crossing pair')}, e.g. faces {a} and {b})")
    folded, worst, edge, nonmanifold = _folds(sc.topo, sc.H, sc.HF, unit(sc.area_vec), ~sc.degenerate, o.min_angle)
    if folded.any():
        a, b = sc.topo.E[edge].tolist()
        out.flag("folded", folded, f"{_n(folded.sum(), 'face')} folded onto an edge neighbour: opening under "
                                   f"{o.min_angle:g}° (worst {worst:.3g}° at edge ({a}, {b}))")
    out.flag("nonmanifold", nonmanifold, f"{_n(nonmanifold.sum(), 'face')} on non-manifold or inconsistently "
                                         f"oriented edges, e.g. face {int(np.argmax(nonmanifold))}")
    pinched, pair = pinches(X, sc.topo, sc.H, sc.HF, TOUCH * sc.edge)
    out.flag("nonmanifold", pinched, f"{_n(pinched.sum(), 'face')} at pinched corners (a vertex joining faces that "
                                     f"share no edge there, or boundary corners within {TOUCH:g} × the median edge "
                                     f"of each other without an edge between them), e.g. vertices {pair[0]} and "
                                     f"{pair[1]}")
    return pairs


def pinches(X, topo, H, HF, reach: float) -> tuple[np.ndarray, tuple]:
    """Faces at a pinched corner: a vertex with more than one boundary edge leaving it (fans welded at a point),
    or a boundary vertex within ``reach`` of another boundary vertex it shares no edge with (pieces touching
    unwelded, :func:`touching_pairs`). ``topo, H, HF``: :func:`edge_topology` and :func:`halfedges` of the faces.
    Returns ``(m,) bool`` and one such pair of vertices (a vertex twice for a welded pinch; ``(-1, -1)`` when there
    is none).

    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 1)
    >>> F = np.array([Q[0], Q[1] + len(V)])  # the two quads apart, touching along their shared side's corners
    >>> X = np.concatenate([V, V])
    >>> topo = edge_topology(F); H, HF = halfedges(F)
    >>> faces, pair = pinches(X, topo, H, HF, 1e-9); faces.tolist(), pair
    ([True, True], (1, 7))
    """
    m = int(HF.max()) + 1 if len(HF) else 0
    bh = H[topo.count[topo.HE] == 1]  # boundary half-edges
    bad = np.zeros(len(X), dtype=bool)
    pair = (-1, -1)
    leaving = np.bincount(bh[:, 0], minlength=len(X))
    if (leaving > 1).any():
        v = int(np.argmax(leaving > 1))
        bad[leaving > 1] = True
        pair = (v, v)
    touching = touching_pairs(X, topo, reach)
    if len(touching):
        bad[touching.ravel()] = True
        if pair[0] < 0:
            pair = tuple(touching[0].tolist())
    faces = np.zeros(m, dtype=bool)
    faces[HF[bad[H[:, 0]]]] = True
    return faces, pair


def touching_pairs(X, topo, reach: float) -> np.ndarray:
    """Pairs ``(p, 2)``, ``a < b``, of boundary vertices within ``reach`` of each other that share no edge (pieces
    touching unwelded); ``topo``: :func:`edge_topology` of the faces.

    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 1)
    >>> touching_pairs(np.concatenate([V, V]), edge_topology(np.array([Q[0], Q[1] + len(V)])), 1e-9).tolist()
    [[1, 7], [4, 10]]
    """
    B = np.unique(topo.E[topo.count == 1].ravel())
    if len(B) < 2 or not reach > 0:
        return np.zeros((0, 2), dtype=np.int64)
    P = X[B]
    close = cKDTree(P - P.mean(axis=0)).query_pairs(reach, output_type="ndarray")
    a, b = B[close[:, 0]], B[close[:, 1]]  # B ascends and query_pairs gives i < j: a < b
    n = np.int64(len(X))
    keys = np.minimum(topo.E[:, 0], topo.E[:, 1]) * n + np.maximum(topo.E[:, 0], topo.E[:, 1])
    apart = ~np.isin(a * n + b, keys)
    return np.stack([a[apart], b[apart]], axis=1).astype(np.int64)


def _reference_checks(X, F, sc: _Scales, ref, o: _Options, out: _Findings, name: str):
    """Closeness to the design surface, faces flipped against it, and its coverage.

    Returns ``coverage, holes, max_distance, mean_distance, reversed`` (distances × the median edge).
    """
    Xr, Tr, shift = ref  # the reference centred on itself; X + shift is the mesh in the reference's frame
    index = TriangleIndex(Xr, Tr, name="reference")
    k = F.shape[1]
    weights = (np.arange(k)[None, :] < sc.sizes[:, None]) / sc.sizes[:, None].astype(np.float64)
    centroids = np.einsum("mk,mkj->mj", weights, X[F])
    q = index.query(np.concatenate([X, centroids]) + shift, name=name)
    dist = q.distances[:len(X)] / sc.edge
    used = np.unique(F)
    dmax, dmean = float(dist[used].max()), float(dist[used].mean())
    if o.closeness_limit is not None:
        far = (dist > o.closeness_limit)[F].any(axis=1)
        out.flag("far", far, f"{_n(far.sum(), 'face')} with corners farther than {o.closeness_limit:g} × median "
                             f"edge from the reference (farthest {dmax:.3g} × median edge)")
    reversed_ = False
    if index.oriented:  # normals of an unoriented reference say nothing about a face's side
        good = ~sc.degenerate
        Tq = Tr[q.faces[len(X):]]  # the reference triangle nearest each face's centroid
        rn = unit(cross(Xr[Tq[:, 1]] - Xr[Tq[:, 0]], Xr[Tq[:, 2]] - Xr[Tq[:, 0]]))
        side = dot(unit(sc.area_vec), rn)
        majority = 1.0 if float(np.sum(sc.area[good] * np.sign(side[good]))) >= 0.0 else -1.0
        reversed_ = majority < 0
        flipped = good & (side * majority < 0.0)
        out.flag("flipped", flipped, f"{_n(flipped.sum(), 'face')} flipped against the reference surface, "
                                     f"e.g. face {int(np.argmax(flipped))}")
    coverage, holes, outside = _coverage(X, F, sc.topo, Xr - shift, Tr, sc.edge, sc.face_area, o)
    if coverage < o.min_coverage:
        out.lines.append(f"coverage {coverage:.0%} of the design surface < {o.min_coverage:.0%} "
                         f"({_n(holes, 'hole')} larger than one panel; of the uncovered area {outside:.0%} lies "
                         f"beyond the panelling's boundary, {1.0 - outside:.0%} is farther than "
                         f"{o.coverage_distance:g} × median edge from its panels)")
    return coverage, holes, dmax, dmean, reversed_


def _worst_corner(smallest, largest, good) -> tuple[float, int]:
    """The corner closest to 0° or 180° over the ``good`` faces (degrees) and its face; an acute corner wins a tie
    within 1e-6° (a sliver has both). ``(0.0, 0)`` when no face is good."""
    if not good.any():
        return 0.0, 0
    acute = np.where(good, smallest, np.inf)
    obtuse = np.where(good, largest, -np.inf)
    i, j = int(np.argmin(acute)), int(np.argmax(obtuse))
    if acute[i] <= 180.0 - obtuse[j] + 1e-6:
        return float(acute[i]), i
    return float(obtuse[j]), j


def _n(count, noun: str) -> str:
    count = int(count)
    return f"{count} {noun}" + ("" if count == 1 else "s")


def _folds(topo, H, HF, N, good, min_angle):
    """Faces folded onto an edge neighbour (opening angle under ``min_angle``) and faces on non-manifold edges.

    Returns ``folded (m,) bool``, the smallest opening (degrees), its edge, ``nonmanifold (m,) bool``.
    """
    m = len(N)
    sign = np.where(H[:, 0] < H[:, 1], 1.0, -1.0)
    net = np.bincount(topo.HE, weights=sign, minlength=len(topo.E))
    bad_e = (topo.count > 2) | ((topo.count == 2) & (net != 0))
    nonmanifold = np.zeros(m, dtype=bool)
    nonmanifold[HF[bad_e[topo.HE]]] = True
    inner = np.nonzero(topo.count == 2)[0]
    f1, f2 = topo.EF[inner, 0], topo.EF[inner, 1]
    n2 = N[f2] * np.where(net[inner] != 0, -1.0, 1.0)[:, None]  # opposite orientation: compare against -n2
    ok = good[f1] & good[f2]
    normal_angle = np.degrees(np.arctan2(norm(cross(N[f1], n2)), dot(N[f1], n2)))
    opening = 180.0 - normal_angle
    fold = ok & (opening < min_angle)
    folded = np.zeros(m, dtype=bool)
    if fold.any():
        folded[f1[fold]] = True
        folded[f2[fold]] = True
        j = int(np.argmin(np.where(fold, opening, np.inf)))
        return folded, float(opening[j]), int(inner[j]), nonmanifold
    return folded, np.inf, -1, nonmanifold


# ----------------------------------------------------------------------------------------------
# faces crossing faces they share no vertex with


def _intersecting_pairs(X, F, good, tol) -> np.ndarray:
    """Pairs ``(a, b)``, ``a < b``, of non-degenerate faces sharing no vertex whose triangles cross or overlap.

    Broad phase: bounding spheres of the faces (each holds its fan triangles) in k-d trees, pairs sharing a
    vertex dropped, then the bounding spheres of the two faces' triangles. Narrow phase (vectorized): plane-side
    rejection, then each triangle's edges against the other triangle both ways (Möller 1997); triangles lying
    within ``tol`` of each other's plane are tested for overlap in that plane instead.
    """
    empty = np.zeros((0, 2), dtype=np.int64)
    T, J = triangulate(F)
    keep = good[J]
    P = X[T]  # (t, 3, 3)
    e0, e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 1], P[:, 0] - P[:, 2]
    longest2 = np.maximum(np.maximum(dot(e0, e0), dot(e1, e1)), dot(e2, e2))
    keep &= norm(cross(e0, -e2)) > _SLIVER * longest2
    idx = np.nonzero(keep)[0]  # triangulate() lists a face's triangles together, faces in order
    if len(idx) < 2:
        return empty
    P, J = P[idx], J[idx]
    first = np.nonzero(np.r_[True, J[1:] != J[:-1]])[0]  # np.unique(J, return_index=True, return_counts=True):
    faces, count = J[first], np.diff(np.r_[first, len(J)])  # J ascends
    if len(faces) < 2:
        return empty
    C = X[F[faces]]  # (f, k, 3) corners (padding repeats a corner: it changes no bound)
    Gf = C.mean(axis=1)
    Rf = np.sqrt(np.max(dot(C - Gf[:, None, :], C - Gf[:, None, :]), axis=1))
    fp = _sphere_pairs(Gf, Rf, tol)
    fa, fb = faces[fp[:, 0]], faces[fp[:, 1]]
    apart = ~(F[fa][:, :, None] == F[fb][:, None, :]).any(axis=(1, 2))
    fp = fp[apart]
    if not len(fp):
        return empty
    # every triangle of one face against every triangle of the other
    na, nb = count[fp[:, 0]], count[fp[:, 1]]
    n = na * nb
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    ta = np.repeat(first[fp[:, 0]], n) + k // np.repeat(nb, n)
    tb = np.repeat(first[fp[:, 1]], n) + k % np.repeat(nb, n)
    G = P.mean(axis=1)
    R = np.sqrt(np.max(dot(P - G[:, None, :], P - G[:, None, :]), axis=1))
    D = G[ta] - G[tb]
    near = dot(D, D) <= (R[ta] + R[tb] + tol) ** 2
    ta, tb = ta[near], tb[near]
    hits = []
    for s in range(0, len(ta), _PAIR_CHUNK):
        a, b = ta[s:s + _PAIR_CHUNK], tb[s:s + _PAIR_CHUNK]
        hit = _triangles_cross(P[a], P[b], tol)
        hits.append(np.sort(np.stack([J[a[hit]], J[b[hit]]], axis=1), axis=1))
    if not hits:
        return empty
    out = np.concatenate(hits)
    return np.unique(out, axis=0) if len(out) else empty


def _sphere_pairs(G, R, tol) -> np.ndarray:
    """Index pairs ``(i, j)``, ``i < j``, of spheres (centres ``G``, radii ``R``) closer than ``R_i + R_j + tol``.

    The spheres are split into radius classes (up to 1.2 × the median radius, then growing by √2); each class
    pair searches one k-d tree with the sum of the two classes' largest radii, so the search radius follows the
    spheres' own sizes and one huge triangle does not widen every search.
    """
    r_med = float(np.median(R))
    unit_r = 1.2 * r_med if r_med > 0 else max(float(R.max()), 1.0)
    cls = np.maximum(np.ceil(np.log(np.maximum(R, 1e-300) / unit_r) / np.log(np.sqrt(2.0))).astype(np.int64) + 1, 0)
    groups = [np.flatnonzero(cls == c) for c in np.unique(cls)]
    trees = [cKDTree(G[g]) for g in groups]
    rmax = [float(R[g].max()) for g in groups]
    found = []
    for a, (ga, ta) in enumerate(zip(groups, trees)):
        if len(ga) > 1:
            pr = ta.query_pairs(2.0 * rmax[a] + tol, output_type="ndarray")
            found.append(ga[pr])
        for b in range(a + 1, len(groups)):
            sd = ta.sparse_distance_matrix(trees[b], rmax[a] + rmax[b] + tol, output_type="ndarray")
            found.append(np.stack([ga[sd["i"]], groups[b][sd["j"]]], axis=1))
    if not found:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = np.concatenate(found).astype(np.int64)
    i, j = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    D = G[i] - G[j]
    close = np.einsum("ij,ij->i", D, D) <= (R[i] + R[j] + tol) ** 2
    return np.stack([i[close], j[close]], axis=1)


def _triangles_cross(P, Q, tol) -> np.ndarray:
    """``(p,) bool``: triangle ``P[i]`` crosses or overlaps triangle ``Q[i]`` by more than ``tol`` (both (p, 3, 3))."""
    nP = unit(cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]))
    nQ = unit(cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0]))
    dQ = dot(Q - P[:, :1], nP[:, None])  # corners of Q above the plane of P
    dP = dot(P - Q[:, :1], nQ[:, None])
    apart = (dQ > tol).all(1) | (dQ < -tol).all(1) | (dP > tol).all(1) | (dP < -tol).all(1)
    in_p = ~apart & (np.abs(dQ) <= tol).all(1)  # Q lies in the plane of P
    in_q = ~apart & ~in_p & (np.abs(dP) <= tol).all(1)
    general = ~apart & ~in_p & ~in_q
    hit = np.zeros(len(P), dtype=bool)
    g = np.nonzero(general)[0]
    if len(g):
        hit[g] = _edges_through(P[g], dP[g], Q[g], nQ[g], tol) | _edges_through(Q[g], dQ[g], P[g], nP[g], tol)
    for sel, A, nA, B in ((in_p, P, nP, Q), (in_q, Q, nQ, P)):
        k = np.nonzero(sel)[0]
        if len(k):
            hit[k] = _overlap_in_plane(A[k], nA[k], B[k], tol)
    return hit


def _edges_through(S, dS, T, nT, tol) -> np.ndarray:
    """``(p,) bool``: an edge of triangle ``S`` crosses the plane of ``T`` (ends beyond ``tol`` on both sides) at a
    point inside ``T``; ``dS (p, 3)`` are the corners' signed distances to that plane, ``nT`` its unit normal."""
    hit = np.zeros(len(S), dtype=bool)
    for i in range(3):
        j = (i + 1) % 3
        a, b = dS[:, i], dS[:, j]
        k = np.nonzero(((a < -tol) & (b > tol)) | ((a > tol) & (b < -tol)))[0]
        if not len(k):
            continue
        t = a[k] / (a[k] - b[k])
        x = S[k, i] + t[:, None] * (S[k, j] - S[k, i])
        inside = np.ones(len(k), dtype=bool)
        for e in range(3):
            c0, c1 = T[k, e], T[k, (e + 1) % 3]
            inside &= dot(cross(c1 - c0, x - c0), nT[k]) >= 0.0
        hit[k[inside]] = True
    return hit


def _overlap_in_plane(A, nA, B, tol) -> np.ndarray:
    """``(p,) bool``: triangle ``B``, lying in the plane of ``A``, overlaps ``A`` by more than ``tol`` there: an edge
    pair crosses properly, or a corner or the centroid of one lies inside the other (deeper than ``tol``)."""
    u = unit(A[:, 1] - A[:, 0])
    w = cross(nA, u)

    def flat(Y):
        D = Y - A[:, :1]
        return np.stack([dot(D, u[:, None]), dot(D, w[:, None])], axis=-1)  # (p, 3, 2)

    a, b = flat(A), flat(B)  # a turns counter-clockwise
    sb = np.sign(_cross2(b[:, 1] - b[:, 0], b[:, 2] - b[:, 0]))
    hit = np.zeros(len(A), dtype=bool)
    for pts, tri, orient in ((b, a, np.ones(len(A))), (a, b, sb)):
        for x in (pts[:, 0], pts[:, 1], pts[:, 2], pts.mean(axis=1)):
            hit |= _inside2(x, tri, orient, tol)
    for e in range(3):
        p0, p1 = a[:, e], a[:, (e + 1) % 3]
        lp = np.hypot(*(p1 - p0).T)
        for f in range(3):
            q0, q1 = b[:, f], b[:, (f + 1) % 3]
            lq = np.hypot(*(q1 - q0).T)
            d1 = _cross2(p1 - p0, q0 - p0) / lp
            d2 = _cross2(p1 - p0, q1 - p0) / lp
            d3 = _cross2(q1 - q0, p0 - q0) / lq
            d4 = _cross2(q1 - q0, p1 - q0) / lq
            hit |= (np.minimum(d1, d2) < -tol) & (np.maximum(d1, d2) > tol) & (np.minimum(d3, d4) < -tol) & (
                np.maximum(d3, d4) > tol)
    return hit


def _cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _inside2(x, tri, orient, tol):
    """Point ``x (p, 2)`` deeper than ``tol`` inside triangle ``tri (p, 3, 2)`` of orientation ``orient`` (±1)."""
    ok = np.ones(len(x), dtype=bool)
    for e in range(3):
        c0, c1 = tri[:, e], tri[:, (e + 1) % 3]
        ok &= orient * _cross2(c1 - c0, x - c0) / np.hypot(*(c1 - c0).T) > tol
    return ok


# ----------------------------------------------------------------------------------------------
# coverage of the design surface


def _coverage(X, F, topo, Xr, Tr, L, A, o: _Options) -> tuple[float, int, float]:
    """Covered share of the reference's area, the number of uncovered regions larger than ``A``, and the share of
    the uncovered area that lies beyond the mesh's boundary (the rest is too far from the mesh's faces; measured
    only when the coverage is under ``o.min_coverage``, where the report names it).

    Samples within ``boundary_margin`` of the faces are covered and those beyond ``coverage_distance`` are not
    (:meth:`TriangleIndex.within`, cheap); only the others need their closest point (on the boundary or not)."""
    splits = [(T, TriangleIndex(X, T, name="mesh")) for T in _splits(X, F)]
    S, W, spacing = _surface_samples(Xr, Tr, np.sqrt(A))  # sub-triangles with edges under √A: ≥ 4 per panel
    covered, beyond, far = _covered(S, splits, topo, len(X), L, o)
    coverage = _share(W, covered)
    if abs(coverage - o.min_coverage) < _REFINE_BAND:  # near the bound: finer samples decide
        S, W, spacing = _surface_samples(Xr, Tr, np.sqrt(A) / _REFINE)
        covered, beyond, far = _covered(S, splits, topo, len(X), L, o)
        coverage = _share(W, covered)
    missing = float(W[~covered].sum())
    if coverage < o.min_coverage:  # the report names the share beyond the boundary: the far samples' side too
        for index, T, rows in far:
            beyond[rows] |= _beyond_boundary(index.query(S[rows], name="reference"), T, topo, len(X))
    outside = float(W[~covered & beyond].sum()) / missing if missing > 0 else 0.0
    U = np.nonzero(~covered)[0]
    holes = 0
    if len(U):
        pr = cKDTree(S[U]).query_pairs(1.5 * spacing, output_type="ndarray")
        g = coo_matrix((np.ones(len(pr)), (pr[:, 0], pr[:, 1])), shape=(len(U), len(U)))
        _, label = connected_components(g, directed=False)
        holes = int(np.count_nonzero(np.bincount(label, weights=W[U]) > A))
    return min(coverage, 1.0), holes, outside


def _share(W, covered) -> float:
    total = float(W.sum())
    return float(W[covered].sum()) / total if total > 0 else 1.0


def _covered(S, splits, topo, n, L, o: _Options):
    """Which samples ``S`` the panelling covers (a warped quad is two surfaces, ``splits``: ``(triangles, index)``
    pairs; a sample is covered only when both cover it), which have their closest point beyond its boundary, and
    per split the samples too far from every face (their side is measured only when the report needs it)."""
    beyond = np.zeros(len(S), dtype=bool)
    covered = np.ones(len(S), dtype=bool)
    far = []
    for T, index in splits:
        rest = np.flatnonzero(~index.within(S, o.boundary_margin * L, name="reference"))  # the others: covered
        reach = index.within(S[rest], o.coverage_distance * L, name="reference")
        covered[rest[~reach]] = False  # too far from every face: not covered, beyond or not
        far.append((index, T, rest[~reach]))
        rest = rest[reach]
        q = index.query(S[rest], name="reference")
        d = q.distances / L
        out = _beyond_boundary(q, T, topo, n)
        covered[rest] &= (d <= o.coverage_distance) & (~out | (d <= o.boundary_margin))
        beyond[rest] |= out
    return covered, beyond, far


def _splits(X, F) -> list:
    """The triangulations whose union of doubts coverage judges: the fan from corner 0, and where a quad is warped
    (scale-free planarity over :data:`_WARPED`) also the split along its other diagonal (the panel's surface is
    ambiguous by the warp; the fan alone can claim area that the other split leaves uncovered)."""
    T, J = triangulate(F)
    is_quad = face_sizes(F) == 4
    quads = np.nonzero(is_quad)[0]
    if not len(quads) or float(quad_planarity(X, F[quads, :4]).max()) <= _WARPED:
        return [T]
    G = F[quads, :4]
    return [T, np.concatenate([T[~is_quad[J]], G[:, [1, 2, 3]], G[:, [1, 3, 0]]])]


def _beyond_boundary(q, T, topo, n) -> np.ndarray:
    """``(p,) bool``: the closest point on the mesh lies on one of its boundary edges or boundary vertices."""
    bnd = topo.E[topo.count == 1]
    beyond = np.zeros(len(q.faces), dtype=bool)
    if not len(bnd):
        return beyond
    bkeys = np.sort(bnd[:, 0] * np.int64(n) + bnd[:, 1])
    bvert = np.zeros(n, dtype=bool)
    bvert[bnd.ravel()] = True
    zero = q.barycentric <= 1e-12  # the closest-point kernel gives exact zeros on edges and corners
    nz = zero.sum(axis=1)
    Tq = T[q.faces]
    on_edge = np.nonzero(nz == 1)[0]
    if len(on_edge):
        k = np.argmax(zero[on_edge], axis=1)
        a = Tq[on_edge, (k + 1) % 3]
        b = Tq[on_edge, (k + 2) % 3]
        key = np.minimum(a, b) * np.int64(n) + np.maximum(a, b)
        pos = np.clip(np.searchsorted(bkeys, key), 0, len(bkeys) - 1)
        beyond[on_edge] = bkeys[pos] == key
    at_vertex = np.nonzero(nz >= 2)[0]
    if len(at_vertex):
        beyond[at_vertex] = bvert[Tq[at_vertex, np.argmax(q.barycentric[at_vertex], axis=1)]]
    return beyond


def _surface_samples(Xr, Tr, delta) -> tuple[np.ndarray, np.ndarray, float]:
    """Area-weighted samples of the reference: the centroids of a regular subdivision of every triangle into ``s²``
    similar sub-triangles with edges under ``delta`` (widened, or triangles drawn at random with their weight
    scaled, so that there are at most ``_MAX_SAMPLES``); returns points, weights (areas) and the sample spacing."""
    a, b, c = Xr[Tr[:, 0]], Xr[Tr[:, 1]], Xr[Tr[:, 2]]
    longest = np.sqrt(np.maximum(np.maximum(dot(b - a, b - a), dot(c - b, c - b)), dot(a - c, a - c)))
    area = 0.5 * norm(cross(b - a, c - a))
    while True:
        s = np.clip(np.ceil(longest / delta), 1, _MAX_LEVEL).astype(np.int64)
        total = int(np.sum(s * s))
        if total <= _MAX_SAMPLES or s.max() == 1:
            break
        delta *= 1.05 * np.sqrt(total / _MAX_SAMPLES)
    t_all = np.arange(len(Tr))
    scale = 1.0
    if total > _MAX_SAMPLES:  # more reference triangles than samples wanted: a fixed random share of them
        t_all = np.sort(np.random.default_rng(0).choice(len(Tr), _MAX_SAMPLES, replace=False))
        scale = len(Tr) / _MAX_SAMPLES
    pts, wts = [], []
    for level in np.unique(s[t_all]):
        t = t_all[s[t_all] == level]
        uv = _subdivision_centroids(int(level))  # (level², 2)
        P = a[t, None, :] + uv[None, :, :1] * (b - a)[t, None, :] + uv[None, :, 1:] * (c - a)[t, None, :]
        pts.append(P.reshape(-1, 3))
        wts.append(np.repeat(scale * area[t] / float(level * level), len(uv)))
    S, W = np.concatenate(pts), np.concatenate(wts)
    spacing = max(float(delta) if s.max() > 1 else float(np.median(longest)), np.sqrt(2.0 * W.sum() / len(S)))
    return S, W, spacing


def _subdivision_centroids(s: int) -> np.ndarray:
    """``(s², 2)`` parameters ``(u, v)`` of the centroids of the regular ``s²``-subdivision of a triangle."""
    i, j = np.meshgrid(np.arange(s), np.arange(s), indexing="ij")
    up = (i + j) <= s - 1
    down = (i + j) <= s - 2
    U = np.concatenate([(i[up] + 1.0 / 3.0), (i[down] + 2.0 / 3.0)]) / s
    V = np.concatenate([(j[up] + 1.0 / 3.0), (j[down] + 2.0 / 3.0)]) / s
    return np.stack([U, V], axis=1)


# ----------------------------------------------------------------------------------------------
# published component


def shape_healthy(h: PanelHealth, min_coverage: float = 0.85) -> bool:
    """Healthy but for planarity (which is the tolerance's): no other defect, and ``min_coverage`` of the reference
    covered (when measured).

    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(3, 3)
    >>> V[4, 2] = 0.3  # a bump: four faces not planar, nothing else wrong
    >>> h = face_health(V, Q, tolerance=1e-4)
    >>> h.healthy, shape_healthy(h)
    (False, True)
    """
    covered = bool(np.isnan(h.coverage) or h.coverage >= min_coverage)
    return bool(not np.any(h.face_defects & ~DEFECT_BITS["nonplanar"])) and covered


class PanelHealthResult(NamedTuple):
    healthy: bool
    violations: Texts
    coverage: float
    holes: int
    worst_corner: float
    shortest_edge_ratio: float
    intersecting_faces: Integers
    unhealthy_faces: Integers
    face_defects: Integers


def panel_health(
    mesh: Mesh,
    reference: Mesh | None = None,
    tolerance: float = 1e-3,
    min_edge_ratio: float = 0.2,
    min_angle: float = 20.0,
    min_area_ratio: float = 0.1,
    min_coverage: float = 0.85,
) -> PanelHealthResult:
    """Is the panelling fabricable? Planarity, collapsed edges, sharp corners, folds, crossings, coverage — or why not.

    Parameters
    ----------
    mesh : Mesh
        The panelling ``(V, F)``: quads, triangles or polygons.
    reference : Mesh, optional
        The design surface; adds faces flipped against it and the coverage of it.
    tolerance : float
        Largest scale-free planarity of a healthy panel (diagonal distance / mean diagonal).
    min_edge_ratio : float
        Shortest healthy edge, as a fraction of the median edge.
    min_angle : float
        Smallest healthy corner angle, degrees (corners over 180° minus it fail too). Below 90.
    min_area_ratio : float
        Smallest healthy panel area, as a fraction of the median panel area.
    min_coverage : float
        Smallest healthy share of the design surface's area covered by the panelling, 0..1.

    Returns
    -------
    healthy : bool
        True when no check fails.
    violations : Texts
        One line per failed check, with the count and the worst value relative to its bound.
    coverage : float
        Share of the reference's area covered by the panelling, 0..1; -1 when no reference is given.
    holes : int
        Uncovered regions of the reference larger than one median panel.
    worst_corner : float
        The corner angle closest to 0° or 180°, degrees.
    shortest_edge_ratio : float
        Shortest edge divided by the median edge.
    intersecting_faces : Integers
        Faces that cross or overlap a face they share no vertex with.
    unhealthy_faces : Integers
        Faces with any defect.
    face_defects : Integers
        Bit mask per face: 1 not planar, 2 short edge, 4 degenerate, 8 corner angle, 16 non-convex, 32 small,
        64 intersecting, 128 folded onto a neighbour, 256 flipped against the reference, 512 far from the
        reference, 1024 non-manifold edge; 0 for a healthy face.

    Raises
    ------
    MeshError
        Malformed ``mesh`` or ``reference`` (empty, NaN, index out of range).
    InputError
        A bound out of range.

    Notes
    -----
    Every bound is relative to the mesh's own median edge and median panel area: the verdict does not depend on
    units or placement. Details in :func:`face_health`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> r = panel_health(quad_grid(4, 4)); r.healthy, r.coverage, r.worst_corner
    (True, -1.0, 90.0)
    """
    V, F = check_mesh(mesh, "mesh", allow_degenerate=True, manifold=False)
    h = face_health(V, F, reference, tolerance=tolerance, min_edge_ratio=min_edge_ratio, min_angle=min_angle,
                    min_area_ratio=min_area_ratio, min_coverage=min_coverage)
    crossing = np.unique(h.intersecting_pairs.ravel()).astype(np.int64)
    return PanelHealthResult(
        healthy=h.healthy,
        violations=list(h.violations),
        coverage=-1.0 if np.isnan(h.coverage) else h.coverage,
        holes=h.holes,
        worst_corner=h.worst_corner,
        shortest_edge_ratio=h.shortest_edge_ratio,
        intersecting_faces=crossing,
        unhealthy_faces=np.nonzero(h.face_defects)[0].astype(np.int64),
        face_defects=h.face_defects,
    )
