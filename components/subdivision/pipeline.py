"""End-to-end subdivision strategy: coarse net → Catmull-Clark → pull onto the surface → planarization.

:func:`pq_from_subdivision` (published) and :func:`subdivision_pq` (array level) run the steps of the third
free-form strategy of Liu et al. 2006 on a design surface:

1. the coarse quad-dominant net: the user's (validated: manifold, consistently oriented, no degenerate face) or an
   automatic one (:func:`components.subdivision.coarse.coarse_net`: along the conjugate direction field, or an O-grid in the
   unit-disk map, whichever ranks better; see :mod:`components.subdivision.coarse`);
2. ``levels`` Catmull-Clark steps with crease boundaries (:func:`components.subdivision.subdivide.catmull_clark`);
3. boundary vertices onto the surface boundary, spread by arc length between the coarse boundary vertices, the
   interior following harmonically, then every interior vertex to its closest point on the surface
   (:func:`components.subdivision.pull.pulled_subdivision`);
4. planarization with hard planarity, closeness to the surface, fairness and boundary vertices sliding on the
   surface boundary (:func:`components.planarize.planarizer.planarize_mesh`).

All input checks, including the face count after ``levels`` against ``max_faces``, run before any of the heavy
steps.
"""
from __future__ import annotations

import logging
import math
import time
from typing import NamedTuple

import numpy as np

from components.core.checks import check_int, validate_mesh
from components.core.errors import InputError
from components.core.mesh import edge_topology, triangulate
from components.core.types import Mesh

log = logging.getLogger(__name__)

__all__ = ["SubdivisionPQ", "SubdivisionPQResult", "pq_from_subdivision", "subdivision_pq"]


class SubdivisionPQ(NamedTuple):
    """Result of :func:`subdivision_pq` (arrays and the planarizer's full result)."""

    coarse: tuple  # (V, F) the coarse net used
    candidate: tuple  # (V, Q) subdivided and pulled
    candidate_planarity: np.ndarray  # (q,)
    candidate_distance: np.ndarray  # (n,) distance of every candidate vertex to the surface
    planarized: object  # components.planarize.planarizer.PlanarizeResult or None
    mean_edge: float  # mean edge length of the candidate
    timings: dict
    warnings: list
    layout: str  # layout of the coarse net ("aligned", "ogrid", "patches", or "given")


def _mean_edge(V, F):
    E = edge_topology(F).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


def subdivision_pq(V, T, coarse=None, levels: int = 2, planarize: bool = True, faces: int = 36,
                   closeness_weight: float = 15.0, fairness_weight: float = 0.01, tolerance: float = 1e-4,
                   max_iterations: int = 100, time_budget: float = 30.0,
                   max_faces: int = 2_000_000, layout: str = "auto",
                   spread_boundary: bool = True) -> SubdivisionPQ:
    """Subdivision strategy on arrays: coarse net → Catmull-Clark → pull → planarize.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Design surface vertices.
    T : (t, k) array_like of int
        Design surface faces (triangles or polygons, triangulated internally); a disk for the automatic net.
    coarse : tuple (Vc, Fc), optional
        The coarse quad-dominant control net; automatic (see ``layout``) when None.
    levels : int
        Catmull-Clark levels (≥ 0).
    planarize : bool
        Run the planarization.
    faces : int
        Target coarse face count of the automatic net.
    closeness_weight, fairness_weight, tolerance, max_iterations, time_budget
        Passed to :func:`components.planarize.planarizer.planarize_mesh` (boundary ``"slide"`` on the surface boundary).
    max_faces : int
        Refuse, before any work, when the subdivided net would have more faces.
    layout : {"auto", "aligned", "ogrid"}
        Layout of the automatic coarse net (:func:`components.subdivision.coarse.coarse_net`).
    spread_boundary : bool
        Pull with :func:`components.subdivision.pull.pulled_subdivision` (boundary by arc length between the coarse boundary
        vertices); False: plain closest points (:func:`components.subdivision.pull.pulled_vertices`).

    Returns
    -------
    SubdivisionPQ

    Raises
    ------
    MeshError
        Malformed surface, or a coarse net with flipped faces, non-manifold edges or degenerate faces.
    InputError
        ``levels`` negative / not whole / too large for ``max_faces``, bad ``faces`` or ``max_faces``.
    """
    from components.subdivision.coarse import _ogrid_size
    from components.subdivision.subdivide import coarse_mesh, face_count_after

    # ---- every check first (cheap)
    levels = check_int(levels, "levels", 0)
    max_faces = check_int(max_faces, "max_faces", 1)
    faces = check_int(faces, "faces", 4)
    if not isinstance(layout, str) or layout not in ("auto", "aligned", "ogrid"):
        raise InputError("layout", f"must be one of auto, aligned, ogrid; got {layout!r}")
    V, F = validate_mesh(V, T, name="surface", manifold=True)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    if coarse is not None:
        if not isinstance(coarse, (tuple, list)) or len(coarse) < 2:
            raise InputError("coarse", "must be a (V, F) pair")
        Vc, Fc = coarse_mesh(coarse[0], coarse[1], name="coarse")
        total = face_count_after(Fc, levels)
    else:
        from components.subdivision.coarse import _check_surface_disk

        _check_surface_disk((V, T))
        n, k = _ogrid_size(faces)
        # the aligned net's face count is known only after the field pipeline: bound it by 1.5 × the target
        total = max(n * n + 4 * n * k, math.ceil(1.5 * faces)) * 4 ** levels
    if total > max_faces:
        raise InputError("levels", f"{levels} levels would make {total:,} faces, more than the limit of "
                         f"{max_faces:,} (max_faces); use fewer levels or a coarser net")
    # ---- heavy work
    from components.subdivision.coarse import coarse_net
    from components.planarize.planarizer import face_planarity, planarize_mesh
    from components.subdivision.pull import pulled_subdivision, pulled_vertices
    from components.subdivision.subdivide import catmull_clark

    timings: dict = {}
    warnings: list[str] = []
    used_layout = "given"
    t = time.perf_counter()
    if coarse is None:
        net = coarse_net(V, T, faces=faces, layout=layout, levels=levels)
        Vc, Fc = net.V, net.Q
        used_layout = net.layout
        warnings += net.warnings
    timings["coarse"] = time.perf_counter() - t
    t = time.perf_counter()
    Vs, Qs, _ = catmull_clark(Vc, Fc, levels=levels, boundary="crease", max_faces=max_faces, name="coarse")
    timings["subdivide"] = time.perf_counter() - t
    t = time.perf_counter()
    if spread_boundary:
        pulled = pulled_subdivision(Vs, Qs, Vc, V, T, name="candidate", reference_name="surface")
    else:
        pulled = pulled_vertices(Vs, Qs, V, T, boundary="boundary", name="candidate", reference_name="surface")
    warnings += pulled.warnings
    Xc = pulled.V
    cand_dist = pulled.distances_after
    timings["pull"] = time.perf_counter() - t
    cand_pl = face_planarity(Xc, Qs)
    mean_edge = _mean_edge(Xc, Qs)
    res = None
    if planarize:
        t = time.perf_counter()
        res = planarize_mesh(Xc, Qs, reference=(V, T), closeness_weight=closeness_weight,
                             fairness_weight=fairness_weight, boundary="slide", tolerance=tolerance,
                             max_iterations=max_iterations, time_budget=time_budget, mesh_name="candidate")
        timings["planarize"] = time.perf_counter() - t
        warnings += list(res.warnings)
    return SubdivisionPQ((Vc, Fc), (Xc, Qs), cand_pl, cand_dist, res, mean_edge, timings, warnings, used_layout)


# ----------------------------------------------------------------------------------------------
# published component


class SubdivisionPQResult(NamedTuple):
    candidate: Mesh
    candidate_max_planarity: float
    candidate_mean_planarity: float
    candidate_max_distance: float
    planarized: Mesh
    max_planarity: float
    mean_planarity: float
    mean_closeness: float
    max_closeness: float
    mean_edge: float
    worst_corner_angle: float
    nonconvex_faces: int
    iterations: int
    converged: bool
    coarse: Mesh
    warnings: list[str]


def pq_from_subdivision(surface: Mesh, coarse: Mesh | None = None, levels: int = 2, planarize: bool = True,
                        faces: int = 36, closeness_weight: float = 15.0, fairness_weight: float = 0.01,
                        tolerance: float = 1e-4, max_iterations: int = 100, time_budget: float = 30.0,
                        max_faces: int = 2000000, layout: str = "auto") -> SubdivisionPQResult:
    """Planar-quad mesh by subdivision: coarse net, Catmull-Clark, pull onto the surface, planarize.

    Parameters
    ----------
    surface : Mesh
        The design surface as a triangle (or polygon) mesh; a topological disk when the coarse net is automatic.
    coarse : Mesh | None
        The coarse quad-dominant control net (consistently oriented, manifold); automatic when absent (see
        layout).
    levels : int
        Catmull-Clark levels; each multiplies the face count by 4.
    planarize : bool
        Planarize the candidate (planarity, closeness to the surface, fairness, boundary sliding on the surface
        boundary); when false the planarized output is the candidate.
    faces : int
        Target face count of the automatic coarse net.
    closeness_weight : float
        Weight of closeness to the surface in the planarization (15 keeps the mean closeness within 2% of the
        mean edge on the sample surfaces and inspired_mesh).
    fairness_weight : float
        Weight of fairness (second differences along mesh polylines) in the planarization.
    tolerance : float
        Scale-free planarity to reach (max over faces).
    max_iterations : int
        Iteration cap of the planarization.
    time_budget : float
        Seconds the planarization may take.
    max_faces : int
        Largest face count allowed after subdivision; larger requests are refused before any work.
    layout : str
        Automatic coarse net: "aligned" (along the conjugate direction field), "ogrid" (block and rings in the disk
        map) or "auto" (the better ranked of the two; the O-grid with a warning if the field pipeline fails).

    Returns
    -------
    candidate : Mesh
        The subdivided net pulled onto the surface (boundary on the surface boundary).
    candidate_max_planarity : float
        Largest scale-free planarity of the candidate.
    candidate_mean_planarity : float
        Mean scale-free planarity of the candidate.
    candidate_max_distance : float
        Largest distance of a candidate vertex to the surface (model units; zero up to round-off).
    planarized : Mesh
        The planarized mesh (same faces as the candidate).
    max_planarity : float
        Largest scale-free planarity of the planarized mesh.
    mean_planarity : float
        Mean scale-free planarity of the planarized mesh.
    mean_closeness : float
        Mean distance of the planarized vertices to the surface (model units).
    max_closeness : float
        Largest distance of a planarized vertex to the surface (model units).
    mean_edge : float
        Mean edge length of the candidate (model units), to judge the closeness by.
    worst_corner_angle : float
        Smallest corner angle of the planarized mesh, in degrees.
    nonconvex_faces : int
        Number of non-convex faces of the planarized mesh.
    iterations : int
        Planarization iterations run.
    converged : bool
        Whether the planarity tolerance was reached.
    coarse : Mesh
        The coarse net used (the given one, validated, or the automatic one).

    Raises
    ------
    MeshError
        The surface is malformed; the coarse net has flipped faces, non-manifold edges or degenerate faces.
    InputError
        levels negative, not whole or too large for max_faces; the surface is not a disk (automatic net); bad
        faces or max_faces. Every check runs before the heavy steps.

    Notes
    -----
    The subdivision strategy of Liu, Pottmann, Wallner, Yang & Wang, "Geometric modeling with conical meshes and
    developable surfaces", SIGGRAPH 2006: Catmull & Clark 1978 with crease boundaries, exact closest points, then
    guided-projection planarization (Tang et al. 2014). The planarization can only stay close to the surface when
    the net's two families of lines are close to conjugate directions of the surface, hence the automatic net
    along the conjugate field where it ranks better; elsewhere the closeness weight holds the planarized mesh to
    the surface (measured, faces 36, 2 levels: max planarity < 1e-4 with mean closeness 0.2–1.7% of the mean
    edge on dome, saddle, wave, canopy and inspired_mesh).

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 24)
    >>> res = pq_from_subdivision((V, T), levels=2)
    >>> res.converged
    True
    """
    if not isinstance(surface, (tuple, list)) or len(surface) < 2:
        raise InputError("surface", "must be a (V, F) pair")
    out = subdivision_pq(surface[0], surface[1], coarse=coarse, levels=levels, planarize=bool(planarize),
                         faces=faces, closeness_weight=closeness_weight, fairness_weight=fairness_weight,
                         tolerance=tolerance, max_iterations=max_iterations, time_budget=time_budget,
                         max_faces=max_faces, layout=layout)
    Xc, Q = out.candidate
    cp = out.candidate_planarity
    cd = out.candidate_distance
    res = out.planarized
    if res is None:
        from components.planarize.planarizer import corner_angles, nonconvex_faces

        ang = corner_angles(Xc, Q)
        return SubdivisionPQResult(
            (Xc, Q), float(cp.max()), float(cp.mean()), float(cd.max()), (Xc, Q), float(cp.max()), float(cp.mean()),
            float(cd.mean()), float(cd.max()), out.mean_edge, float(np.degrees(ang.min())),
            int(nonconvex_faces(Xc, Q).sum()), 0, bool(cp.max() <= tolerance), out.coarse, out.warnings)
    return SubdivisionPQResult(
        (Xc, Q), float(cp.max()), float(cp.mean()), float(cd.max()), res.mesh, res.max_planarity,
        res.mean_planarity, res.mean_closeness, res.max_closeness, out.mean_edge, res.worst_corner_angle,
        res.nonconvex_faces, res.iterations, res.converged, out.coarse, out.warnings)
