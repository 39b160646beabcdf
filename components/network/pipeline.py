"""End-to-end curvature-network strategy: surface + panel size → PQ candidate → conical mesh → face offset.

Steps (project issue 7): the principal curvature network (:mod:`components.network.tracing`), the quad rebuild in
a conformal plane (:mod:`components.network.rebuild`), conical analysis of the candidate, the conical optimization
through the planarization solver (:mod:`components.conical.optimize`) and the face offset with its node axes
(:func:`components.conical.cones.face_offset`).

Array-level: :func:`curvature_pipeline`. Published: :func:`pq_from_curvature_network`.
"""
from __future__ import annotations

import logging
import math
import time
from typing import Callable, NamedTuple

import numpy as np

from components.conical.cones import cone_fit, conical_criterion, face_offset
from components.conical.optimize import optimize_conical
from components.network.tracing import network_for_mesh, principal_angle_error
from components.core.errors import InputError
from components.core.mesh import edge_topology
from components.network.rebuild import rebuild_from_network
from components.core.types import Curves, Lines, Mesh

log = logging.getLogger(__name__)

__all__ = ["CurvaturePipelineResult", "curvature_pipeline", "pq_from_curvature_network"]


class CurvaturePipelineResult(NamedTuple):
    candidate: Mesh
    quad_fraction: float
    mean_angle_error: float
    candidate_max_planarity: float
    candidate_max_criterion: float
    optimized: Mesh
    max_planarity: float
    max_criterion: float
    max_cone_deviation: float
    mean_closeness: float
    relative_closeness: float
    is_conical: bool
    offset_mesh: Mesh
    max_offset_error: float
    max_axis_coplanarity: float
    node_axes: Lines
    lines_1: Curves
    lines_2: Curves
    warnings: list[str]


def _max_planarity(V, F):
    from components.planarize.planarizer import face_planarity

    p = face_planarity(V, F)
    return float(p.max()) if len(p) else 0.0


def _max_criterion(V, F):
    _, c = conical_criterion(V, F)
    return float(np.abs(c).max()) if len(c) else 0.0


def curvature_pipeline(mesh, panel_size: float, optimize: bool = True, offset: float = 0.0,
                       umbilic_threshold: float = 0.05, boundary_cells: str = "trim", closeness_weight: float = 1.0,
                       time_budget: float = 60.0, tracer: Callable | None = None,
                       timings: dict | None = None) -> CurvaturePipelineResult:
    """Array-level form of :func:`pq_from_curvature_network` (same inputs plus the tracer and a timings dict).

    Parameters
    ----------
    mesh : tuple (V, F)
        The design surface, a disk-like triangle or polygon mesh.
    panel_size : float
        Panel size in model units.
    optimize : bool
        Run the conical optimization.
    offset : float
        Face offset distance (0: none).
    umbilic_threshold : float
        Anisotropy threshold of umbilic regions.
    boundary_cells : {"trim", "keep"}
        Boundary cells of the rebuild.
    closeness_weight : float
        Weight of the pull to the design surface in the optimization.
    time_budget : float
        Seconds for the optimization.
    tracer : callable, optional
        Streamline tracer ``tracer(V, T, U, W, family, separation)`` (default: the project's).
    timings : dict, optional
        Filled with the seconds spent in each step.

    Returns
    -------
    CurvaturePipelineResult
    """
    t = {} if timings is None else timings
    t0 = time.perf_counter()
    try:
        d = float(offset)
    except (TypeError, ValueError):
        raise InputError("offset", f"must be a number, got {offset!r}") from None
    if not math.isfinite(d):
        raise InputError("offset", f"must be finite, got {offset!r}")
    if boundary_cells not in ("trim", "keep"):
        raise InputError("boundary_cells", f"must be 'trim' or 'keep', got {boundary_cells!r}")
    V, T, net = network_for_mesh(mesh, panel_size, umbilic_threshold, tracer=tracer)
    t["network"] = time.perf_counter() - t0
    warnings = list(net.warnings)
    t1 = time.perf_counter()
    rb = rebuild_from_network(V, T, net.lines_1, net.lines_2, panel_size, boundary_cells=boundary_cells)
    t["rebuild"] = time.perf_counter() - t1
    warnings += rb.warnings
    err = principal_angle_error(rb.V, rb.F, V, T, net)
    cand_pl = _max_planarity(rb.V, rb.F)
    cand_crit = _max_criterion(rb.V, rb.F)
    E = edge_topology(rb.F).E
    L = float(np.linalg.norm(rb.V[E[:, 1]] - rb.V[E[:, 0]], axis=1).mean())
    if optimize:
        t2 = time.perf_counter()
        opt = optimize_conical(rb.V, rb.F, (V, T), closeness_weight=closeness_weight, time_budget=time_budget,
                               mesh_name="candidate")
        t["optimize"] = time.perf_counter() - t2
        warnings += opt.warnings
        X, F = opt.V, opt.F
        max_pl, max_crit, max_dev = opt.max_planarity, opt.max_criterion, opt.max_cone_deviation
        close, L = opt.mean_closeness, opt.mean_edge_length
        is_conical = opt.converged
    else:
        from components.core.proximity import TriangleIndex

        X, F = rb.V, rb.F
        max_pl, max_crit = cand_pl, cand_crit
        fit = cone_fit(X, F)
        max_dev = float(fit.deviation.max()) if len(fit.deviation) else 0.0
        close = float(TriangleIndex(V, T).query(X).distances.mean())
        is_conical = max_pl <= 1e-4 and max_crit <= 1e-4
    t3 = time.perf_counter()
    if d != 0:
        off = face_offset(X, F, d)
        offset_mesh = (off.V, F)
        max_off = float(off.face_error.max())
        cop = float(off.axis_coplanarity.max()) if len(off.axis_coplanarity) else 0.0
        axes = off.axes
        if max_off > 1e-6 * abs(d):
            warnings.append(f"face offset: face planes are up to {max_off:.2e} from the distance {d:g} "
                            f"(the mesh is not exactly conical{'; run with optimize=True' if not optimize else ''})")
    else:
        offset_mesh = (X, F)
        max_off, cop = 0.0, 0.0
        axes = np.stack([X, X + L * cone_fit(X, F).axis], axis=1)
    t["offset"] = time.perf_counter() - t3
    t["total"] = time.perf_counter() - t0
    return CurvaturePipelineResult(
        candidate=(rb.V, rb.F),
        quad_fraction=rb.quad_fraction,
        mean_angle_error=err.mean_away_from_umbilics,
        candidate_max_planarity=cand_pl,
        candidate_max_criterion=cand_crit,
        optimized=(X, F),
        max_planarity=max_pl,
        max_criterion=max_crit,
        max_cone_deviation=max_dev,
        mean_closeness=close,
        relative_closeness=close / max(L, 1e-300),
        is_conical=bool(is_conical),
        offset_mesh=offset_mesh,
        max_offset_error=max_off,
        max_axis_coplanarity=cop,
        node_axes=axes,
        lines_1=net.lines_1,
        lines_2=net.lines_2,
        warnings=warnings,
    )


def pq_from_curvature_network(mesh: Mesh, panel_size: float, optimize: bool = True, offset: float = 0.0,
                              umbilic_threshold: float = 0.05, boundary_cells: str = "trim",
                              closeness_weight: float = 1.0, time_budget: float = 60.0) -> CurvaturePipelineResult:
    """Planar-quad (conical) mesh from the principal curvature network of a surface, with its face offset.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``: a triangle (or polygon) mesh of a topological disk.
    panel_size : float
        Panel size in model units (spacing of the curvature lines).
    optimize : bool
        Run the conical optimization (planarity + conical angle criterion + closeness).
    offset : float
        Distance of the face offset in model units (0: no offset; the node axes are then one edge long).
    umbilic_threshold : float
        Curvature anisotropy below which a region is umbilic and skipped by the network.
    boundary_cells : str
        ``"trim"``: boundary triangles/pentagons dropped (nearly all quads); ``"keep"``: kept.
    closeness_weight : float
        Weight of the pull to the design surface during the optimization.
    time_budget : float
        Seconds allowed for the optimization.

    Returns
    -------
    candidate : Mesh
        The quad-dominant mesh rebuilt from the curvature network (on the surface).
    quad_fraction : float
        Fraction of the candidate's faces that are quads.
    mean_angle_error : float
        Mean angle (degrees) between the candidate's edges and the principal directions, away from umbilics.
    candidate_max_planarity : float
        Largest face planarity of the candidate (scale-free).
    candidate_max_criterion : float
        Largest conical angle criterion of the candidate (radians).
    optimized : Mesh
        The conical mesh (the candidate when ``optimize`` is off).
    max_planarity : float
        Largest face planarity of the optimized mesh.
    max_criterion : float
        Largest angle criterion ``|ω1 − ω2 + ω3 − ω4|`` at interior valence-4 vertices (radians).
    max_cone_deviation : float
        Largest cone-normal deviation at interior vertices (radians).
    mean_closeness : float
        Mean distance of the optimized vertices to the surface (model units).
    relative_closeness : float
        Mean closeness divided by the mean edge length.
    is_conical : bool
        Planarity and angle criterion within 1e-4.
    offset_mesh : Mesh
        The face offset at ``offset`` (the optimized mesh itself when ``offset`` is 0).
    max_offset_error : float
        Largest ``|distance of an offset face plane − offset|`` (model units).
    max_axis_coplanarity : float
        Largest scale-free triple product of the node axes at the ends of an edge (0: consecutive axes coplanar).
    node_axes : Lines
        Node axis of every vertex (vertex → offset vertex, or one edge long).
    lines_1 : Curves
        Lines of maximal curvature.
    lines_2 : Curves
        Lines of minimal curvature.

    Raises
    ------
    MeshError
        Malformed mesh, no boundary or not a topological disk (named ``mesh``).
    InputError
        Non-positive panel size, bad options, a surface umbilic almost everywhere.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006; Pottmann, Liu, Wallner, Bobenko, Wang, *Geometry of multi-layer freeform structures for
    architecture*, SIGGRAPH 2007; Alliez et al., *Anisotropic polygonal remeshing*, SIGGRAPH 2003.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("saddle", 40)
    >>> res = pq_from_curvature_network((V, T), panel_size=2.0, offset=0.2)
    >>> res.is_conical
    True
    """
    return curvature_pipeline(mesh, panel_size, optimize=bool(optimize), offset=offset,
                              umbilic_threshold=umbilic_threshold, boundary_cells=boundary_cells,
                              closeness_weight=closeness_weight, time_budget=time_budget)
