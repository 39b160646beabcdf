"""Curvature regions of a design surface and suggested quad-mesh singularities (step 1 of the subdivision strategy).

A quad mesh bends with the surface's Gaussian curvature: around an interior vertex of valence ``v`` the cross field
of the mesh lines turns by ``(4 − v)·π/2``, so a region whose integrated Gaussian curvature is ``≈ ±k·π/2`` asks
for ``k`` singularities of index ``±1/4`` (valence 3 for a dome-like region, valence 5 for a saddle-like one).

What the analysis counts
------------------------
* Gaussian curvature per vertex: the angle defect at interior vertices (its integral is exact: Gauss-Bonnet), the
  quadric fit (:func:`components.core.curvature.gaussian_curvature`) times the barycentric area at boundary vertices
  (where the angle defect measures the boundary's turning, not the surface). Mean curvature: the quadric fit.
* Regions: connected sets of vertices whose curvature has the same sign (vertices with ``|K|`` below
  ``flat_tolerance`` times the largest ``|K|`` belong to no region), with their integrated curvature ``∫K``.
* Suggested singularities: a region with ``|∫K| ≥ threshold·π/2`` gets ``k = max(1, round(|∫K| / (π/2)))``
  singularities of index ``sign(∫K)/4``, placed at the region vertices nearest to the ``|K|``-weighted centroids
  of ``k`` clusters of the region (weighted k-means): on the surface and inside the region. They are suggestions for the user to accept or move.
* The boundary is *not* counted as curvature: on an open disk the singularity indices of a quad mesh whose
  boundary is a mesh polyline add up to ``1 − c/4`` with ``c`` the number of boundary corners of valence 2
  (Euler / Poincaré-Hopf: ``Σ_interior (4 − v) + Σ_boundary (3 − v) = 4χ``). ``boundary_corners`` reports the
  ``c`` that makes the suggested interior indices consistent; the boundary's geodesic turning (``2πχ − ∫K``,
  Gauss-Bonnet) is reported too. A smooth boundary with no corner at all forces a total index of ``+1`` (e.g. the
  four valence-3 vertices of an O-grid) whatever the sign of the curvature.

References
----------
M. Meyer, M. Desbrun, P. Schröder, A. Barr, "Discrete differential-geometry operators for triangulated
2-manifolds", 2003 (angle defect). N. Ray, B. Vallet, W. C. Li, B. Lévy, "N-symmetry direction field design",
ACM TOG 27(2), 2008 (singularity indices and curvature). Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang,
"Geometric modeling with conical meshes and developable surfaces", SIGGRAPH 2006 (irregular vertices of the coarse
net placed where the curvature asks for them).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from components.core.checks import check_int, check_mesh, check_number
from components.core.curvature import gaussian_curvature, mean_curvature
from components.core.measures import corner_angles
from components.core.mesh import boundary_loops, edge_topology, triangulate
from components.core.types import Integers, Mesh, Numbers, Points

log = logging.getLogger(__name__)

__all__ = [
    "CurvatureRegions",
    "SingularityResult",
    "SuggestedSingularities",
    "curvature_regions",
    "integrated_gaussian_curvature",
    "singularity_analysis",
    "suggested_singularities",
]


class CurvatureRegions(NamedTuple):
    """Same-sign curvature regions of a triangle mesh (see :func:`curvature_regions`)."""

    label: np.ndarray  # (n,) int64 region of every vertex, -1 for (nearly) flat vertices
    sign: np.ndarray  # (r,) int64 +1 / -1 per region
    curvature: np.ndarray  # (r,) float64 integrated Gaussian curvature ∫K of every region
    area: np.ndarray  # (r,) float64 area of every region


class SuggestedSingularities(NamedTuple):
    """Suggested singular points (see :func:`suggested_singularities`)."""

    points: np.ndarray  # (s, 3) float64 on the surface
    index: np.ndarray  # (s,) float64 ±1/4
    region: np.ndarray  # (s,) int64 the region each one comes from
    vertex: np.ndarray  # (s,) int64 the surface vertex nearest to each point


# ----------------------------------------------------------------------------------------------
# array-level functions


def integrated_gaussian_curvature(V, T, radius: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrated Gaussian curvature per vertex, its pointwise value and the vertex areas.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles (consistently oriented, manifold).
    radius : int
        Ring size of the quadric fit used at boundary vertices.

    Returns
    -------
    KA : (n,) float64
        ``∫K`` over the vertex's barycentric cell: the angle defect ``2π − Σθ`` inside, ``K_fit · area`` on the
        boundary (radians).
    K : (n,) float64
        Pointwise Gaussian curvature ``KA / area`` (1 / length²).
    area : (n,) float64
        Barycentric vertex areas.

    Notes
    -----
    The angle defects of the interior vertices and the geodesic turning of the boundary add up to ``2πχ``
    exactly (discrete Gauss-Bonnet), so the sums over regions are robust to the mesh resolution.

    Examples
    --------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 12)
    >>> KA, K, area = integrated_gaussian_curvature(V, T)
    >>> bool((K > 0).all()), bool(0 < KA.sum() < 2 * np.pi)
    (True, True)
    """
    n = len(V)
    ang = corner_angles(V, T)  # one angle per triangle corner, triangle by triangle
    total = np.bincount(T.ravel(), weights=ang.ravel(), minlength=n)
    tri_area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    area = np.bincount(T.ravel(), weights=np.repeat(tri_area / 3.0, 3), minlength=n)
    onb = np.zeros(n, dtype=bool)
    for lp in boundary_loops(T):
        onb[lp] = True
    KA = 2.0 * np.pi - total
    if onb.any():
        Kfit = gaussian_curvature(V, T, method="fit", radius=radius)
        KA[onb] = Kfit[onb] * area[onb]
    used = area > 0
    KA[~used] = 0.0
    K = np.where(used, KA / np.where(used, area, 1.0), 0.0)
    return KA, K, area


def curvature_regions(T, K, KA, area, flat_tolerance: float = 0.02) -> CurvatureRegions:
    """Connected regions of vertices whose Gaussian curvature has one sign.

    Parameters
    ----------
    T : (t, 3) int64
        Triangles.
    K : (n,) float64
        Pointwise Gaussian curvature per vertex.
    KA : (n,) float64
        Integrated curvature per vertex cell.
    area : (n,) float64
        Vertex areas.
    flat_tolerance : float
        Vertices with ``|K| ≤ flat_tolerance · max |K|`` are flat: they join no region.

    Returns
    -------
    CurvatureRegions
        ``label (n,)``, and per region ``sign``, ``curvature`` (``∫K``), ``area``.
    """
    n = len(K)
    kmax = float(np.abs(K).max()) if n else 0.0
    s = np.where(np.abs(K) > flat_tolerance * kmax, np.sign(K), 0).astype(np.int64)
    E = edge_topology(T).E
    same = (s[E[:, 0]] == s[E[:, 1]]) & (s[E[:, 0]] != 0)
    A = sp.coo_matrix((np.ones(int(same.sum())), (E[same, 0], E[same, 1])), shape=(n, n))
    _, comp = connected_components(A, directed=False)
    label = np.full(n, -1, dtype=np.int64)
    signed = np.nonzero(s != 0)[0]
    uniq, lab = np.unique(comp[signed], return_inverse=True)
    label[signed] = lab
    r = len(uniq)
    curv = np.bincount(lab, weights=KA[signed], minlength=r)
    ar = np.bincount(lab, weights=area[signed], minlength=r)
    sign = np.zeros(r, dtype=np.int64)
    if r:
        first = np.zeros(r, dtype=np.int64)
        first[lab[::-1]] = signed[::-1]
        sign = s[first]
    return CurvatureRegions(label, sign, curv, ar)


def _weighted_kmeans(P, w, k, iterations: int = 20):
    """Weighted Lloyd clustering of points ``P`` into ``k`` groups (farthest-point start); centroids."""
    k = min(k, len(P))
    centres = [P[int(np.argmax(w))]]
    for _ in range(1, k):
        d = np.min(np.linalg.norm(P[:, None, :] - np.asarray(centres)[None], axis=2), axis=1)
        centres.append(P[int(np.argmax(d * w))])
    C = np.asarray(centres)
    for _ in range(iterations):
        a = np.argmin(np.linalg.norm(P[:, None, :] - C[None], axis=2), axis=1)
        newC = C.copy()
        for j in range(k):
            sel = a == j
            if sel.any() and w[sel].sum() > 0:
                newC[j] = (w[sel, None] * P[sel]).sum(axis=0) / w[sel].sum()
        if np.allclose(newC, C):
            break
        C = newC
    return C


def suggested_singularities(V, T, regions: CurvatureRegions, KA, threshold: float = 0.25) -> SuggestedSingularities:
    """Singular points suggested by the integrated curvature of every region.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles.
    regions : CurvatureRegions
        From :func:`curvature_regions`.
    KA : (n,) float64
        Integrated curvature per vertex.
    threshold : float
        A region proposes singularities when ``|∫K| ≥ threshold · π/2``; it proposes
        ``max(1, round(|∫K| / (π/2)))`` of them.

    Returns
    -------
    SuggestedSingularities
        ``points``: the region vertices nearest to the clusters' ``|K|``-weighted centroids (on the surface and
        inside the region, so the local curvature has the region's sign), ``index``
        (``+1/4`` for a region with ``∫K > 0``, ``−1/4`` for ``∫K < 0``), ``region``, ``vertex``.
    """
    quarter = 0.5 * np.pi
    pts, idx, reg = [], [], []
    for r in np.argsort(-np.abs(regions.curvature)):
        total = float(regions.curvature[r])
        if abs(total) < threshold * quarter:
            continue
        k = max(1, int(round(abs(total) / quarter)))
        members = np.nonzero(regions.label == r)[0]
        w = np.abs(KA[members])
        if w.sum() <= 0:
            continue
        C = _weighted_kmeans(V[members], w, k)
        # the region member nearest to each centroid: a centroid of a curved or ring-shaped region may fall
        # outside it, where the curvature has the other sign
        near = members[np.argmin(np.linalg.norm(V[members][:, None, :] - C[None], axis=2), axis=0)]
        pts.append(V[np.unique(near)])
        idx.append(np.full(len(pts[-1]), 0.25 * float(np.sign(total))))
        reg.append(np.full(len(pts[-1]), r, dtype=np.int64))
    if not pts:
        return SuggestedSingularities(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64))
    P = np.vstack(pts)
    vert = cKDTree(V).query(P)[1].astype(np.int64)
    return SuggestedSingularities(P, np.concatenate(idx), np.concatenate(reg), vert)


# ----------------------------------------------------------------------------------------------
# published component


class SingularityResult(NamedTuple):
    gaussian: Numbers
    mean: Numbers
    region: Integers
    region_curvature: Numbers
    positive_region: Integers
    negative_region: Integers
    singularities: Points
    singularity_index: Numbers
    positive_count: int
    negative_count: int
    total_index: float
    boundary_turning: float
    boundary_corners: int
    warnings: list[str]


def singularity_analysis(surface: Mesh, threshold: float = 0.25, flat_tolerance: float = 0.02,
                         radius: int = 2) -> SingularityResult:
    """Gaussian and mean curvature, same-sign curvature regions and suggested quad-mesh singularities with their index.

    Parameters
    ----------
    surface : Mesh
        The design surface as a triangle (or polygon) mesh, consistently oriented.
    threshold : float
        A region proposes singularities when its integrated curvature reaches ``threshold · π/2`` (0.25: a
        quarter of what one valence-3 / valence-5 vertex absorbs).
    flat_tolerance : float
        Vertices whose ``|K|`` is below this fraction of the largest ``|K|`` count as flat and join no region.
    radius : int
        Ring size of the quadric curvature fit (mean curvature, Gaussian curvature at boundary vertices).

    Returns
    -------
    gaussian : Numbers
        Gaussian curvature per vertex (1 / length²): angle defect / area inside, quadric fit on the boundary.
    mean : Numbers
        Signed mean curvature per vertex (quadric fit; positive where the surface bends away from its normal).
    region : Integers
        Region label of every vertex (-1 for flat vertices).
    region_curvature : Numbers
        Integrated Gaussian curvature ∫K of every region, in radians.
    positive_region : Integers
        Vertices with positive Gaussian curvature (dome-like, synclastic).
    negative_region : Integers
        Vertices with negative Gaussian curvature (saddle-like, anticlastic).
    singularities : Points
        Suggested singular vertices on the surface, for the user to accept or move.
    singularity_index : Numbers
        Index of each suggestion: +0.25 (a valence-3 vertex) or -0.25 (a valence-5 vertex).
    positive_count : int
        Number of suggested +1/4 singularities.
    negative_count : int
        Number of suggested -1/4 singularities.
    total_index : float
        Sum of the suggested indices.
    boundary_turning : float
        Geodesic turning of the surface boundary in radians (2πχ − ∫K over the surface, Gauss-Bonnet).
    boundary_corners : int
        Boundary corners (valence-2 boundary vertices) a quad mesh with these interior singularities needs:
        4·(χ − total_index); 0 or less means the boundary alone cannot absorb the index.

    Raises
    ------
    MeshError
        The surface is malformed, non-manifold or inconsistently oriented.
    InputError
        ``threshold``, ``flat_tolerance`` or ``radius`` out of range.

    Notes
    -----
    The boundary is not counted as curvature: on an open disk the indices of a boundary-aligned quad mesh add up
    to ``1 − c/4`` with ``c`` the number of its valence-2 boundary corners, so a smooth boundary with no corner
    forces ``+1`` (four valence-3 vertices) whatever the curvature. Angle defects after Meyer et al. 2003;
    indices and curvature after Ray et al., "N-symmetry direction field design", 2008; the coarse net with
    irregular vertices where the curvature asks for them is the subdivision strategy of Liu et al. 2006.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 16)
    >>> res = singularity_analysis((V, T))
    >>> bool((res.singularity_index > 0).all())
    True
    """
    thr = check_number(threshold, "threshold", 0.0, 100.0)
    flat = check_number(flat_tolerance, "flat_tolerance", 0.0, 1.0)
    radius = check_int(radius, "radius", 1, 5)
    V, F = check_mesh(surface, "surface", manifold=True)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    warnings: list[str] = []
    loops = boundary_loops(T, name="surface")
    used = np.zeros(len(V), dtype=bool)
    used[T.ravel()] = True
    chi = int(used.sum()) - len(edge_topology(T).E) + len(T)
    KA, K, area = integrated_gaussian_curvature(V, T, radius=int(radius))
    H = mean_curvature(V, T, method="fit", radius=int(radius))
    regions = curvature_regions(T, K, KA, area, flat_tolerance=flat)
    sug = suggested_singularities(V, T, regions, KA, threshold=thr)
    turning = float(2 * np.pi * chi - KA.sum())
    if not loops:
        warnings.append("surface is closed: the suggested indices should add up to the Euler characteristic "
                        f"{chi}; boundary_corners is not meaningful")
    total = float(sug.index.sum())
    corners = int(round(4 * (chi - total)))
    if loops and corners < 0:
        warnings.append(f"the suggested indices add up to {total:g} > χ = {chi}: a boundary-aligned quad mesh would "
                        "need concave (valence-4) boundary corners")
    return SingularityResult(
        gaussian=K,
        mean=H,
        region=regions.label,
        region_curvature=regions.curvature,
        positive_region=np.nonzero(K > 0)[0].astype(np.int64),
        negative_region=np.nonzero(K < 0)[0].astype(np.int64),
        singularities=sug.points,
        singularity_index=sug.index,
        positive_count=int(np.sum(sug.index > 0)),
        negative_count=int(np.sum(sug.index < 0)),
        total_index=total,
        boundary_turning=turning,
        boundary_corners=corners,
        warnings=warnings,
    )
