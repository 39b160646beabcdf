"""End-to-end curvature-network strategy: surface + panel size → PQ candidate → conical mesh → face offset.

Steps (project issue 7): the principal curvature network (:mod:`components.network.tracing`), the quad rebuild in
a conformal plane (:mod:`components.network.rebuild`, boundary and irregular cells healed by
:mod:`components.network.healing`), conical analysis of the candidate, the conical optimization through the
planarization solver (:func:`components.conical.optimize.conical_mesh`) and the face offset with its node axes
(:func:`components.conical.cones.face_offset`).

Fabricable or it says why (project issue 16): the candidate and the result are measured with
:func:`components.metrics.health.face_health` against the design surface (corners of 20° to 160°, edges over 0.2 ×
the median, faces over 0.1 × the median area, no folds or crossings, 85% of the surface covered). A folded
candidate (faces crossing or folded onto each other, flipped against the surface: the curvature lines of a surface
with umbilics or flat points can fold in the plane map) is never returned: a few folded cells are dropped, else the
network is traced again at a coarser panel size, else a typed :class:`~components.core.errors.InputError` says why.
``is_conical`` is claimed only when the tolerance is reached **and** the panels are healthy; anything else comes
with a warning naming the counts.

Units and placement do not matter: the surface is centred on its bounding box and scaled to unit size before anything
is computed (and every output is mapped back), so a model in millimetres, metres or placed at 5e6 gives the same
panels.

Array-level: :func:`curvature_pipeline`. Published: :func:`pq_from_curvature_network`.
"""
from __future__ import annotations

import logging
import math
import time
from typing import Callable, NamedTuple

import numpy as np

from components.conical.cones import cone_fit, conical_criterion, face_offset
from components.conical.optimize import conical_mesh
from components.core.checks import check_choice, check_mesh, check_number
from components.core.errors import InputError
from components.core.measures import quad_planarity
from components.core.mesh import boundary_vertex_mask, edge_topology, face_corners, face_lists, face_sizes, pad_faces
from components.core.proximity import TriangleIndex
from components.core.types import Curves, Lines, Mesh, Texts
from components.metrics.health import DEFECT_BITS, face_health
from components.network.healing import manifold_cells
from components.network.rebuild import BOUNDARY_CELLS, rebuild_from_network
from components.network.tracing import network_for_mesh, principal_angle_error

log = logging.getLogger(__name__)

__all__ = ["CurvaturePipelineResult", "curvature_pipeline", "pq_from_curvature_network"]

#: the panel-health bounds every result is judged by (components.metrics.health.face_health)
HEALTH = {"min_edge_ratio": 0.2, "min_angle": 20.0, "min_area_ratio": 0.1, "min_coverage": 0.85}
TOLERANCE = 1e-4  # planarity (scale-free) and angle criterion (radians) of a conical result
SHAPE_TOLERANCE = 10.0  # planarity bound when judging a candidate's shape (a candidate is not planar yet)
FOLDS = ("intersecting", "folded", "flipped", "nonmanifold")  # defects of a folded mesh
COARSER = (1.5, 2.0)  # panel-size factors tried when the network's mesh folds
MAX_REPAIR = 0.05  # largest share of a candidate's cells dropped to repair its folds
SNAP = 2.0 ** -20  # grid of the centred, unit-size coordinates the computation runs on


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
    healthy: bool
    coverage: float
    violations: Texts
    warnings: list[str]


def _max_planarity(V, F):
    p = quad_planarity(V, F)
    return float(p.max()) if len(p) else 0.0


def _max_criterion(V, F):
    _, c = conical_criterion(V, F)
    return float(np.abs(c).max()) if len(c) else 0.0


class _Frame(NamedTuple):
    """Centre and scale the computation runs in: ``x → (x − centre) / scale``."""

    centre: np.ndarray
    scale: float

    def to(self, X):
        """``(X − centre) / scale`` snapped to a grid of ``SNAP`` (a millionth of the size, far below any modelling
        tolerance), so that the rounding of other units or of a far placement cannot change the traced network."""
        return np.round((np.asarray(X, np.float64) - self.centre) / self.scale / SNAP) * SNAP

    def back(self, X):
        return np.asarray(X, np.float64) * self.scale + self.centre


def _frame(V) -> _Frame:
    """The bounding box's centre and largest extent: every model maps to the same unit-size, centred mesh."""
    lo, hi = V.min(axis=0), V.max(axis=0)
    ext = float((hi - lo).max())
    return _Frame(0.5 * (lo + hi), ext if ext > 0 and math.isfinite(ext) else 1.0)


def _fold_mask(h) -> np.ndarray:
    """Faces with a fold defect (crossing, folded onto a neighbour, flipped, non-manifold edge)."""
    bits = sum(DEFECT_BITS[d] for d in FOLDS)
    return (h.face_defects & bits) != 0


def _fold_counts(h) -> str:
    return ", ".join(f"{h.counts[d]} {d}" for d in FOLDS if h.counts.get(d, 0))


def _without(rb, drop):
    """The rebuild ``rb`` without the faces ``drop`` (a bool mask), kept manifold and compact; ``None`` when
    nothing is left."""
    faces = [f for f, d in zip(face_lists(rb.F), drop) if not d]
    faces, _, _ = manifold_cells(faces, len(rb.V))
    if not faces:
        return None
    F = pad_faces(faces)
    used = np.unique(F)
    remap = np.full(len(rb.V), -1, np.int64)
    remap[used] = np.arange(len(used))
    F = remap[F]
    return rb._replace(V=rb.V[used], F=F, UV=rb.UV[used], kind=rb.kind[used],
                       quad_fraction=float(np.mean(face_sizes(F) == 4)))


def _candidate(Vn, Fn, hn, h, umbilic_threshold, boundary_cells, tracer, warnings, t):
    """Trace the network and rebuild the candidate (normalized units ``hn``; ``h`` the panel size as asked), never a
    folded one: a few folded cells are dropped, else a coarser panel size is tried, else :class:`InputError`.

    Returns ``(V, T, net, rebuild, candidate health)``; puts the seconds spent in ``t["network"]`` and
    ``t["rebuild"]`` (all tries).
    """
    tried = []
    t["network"] = t["rebuild"] = 0.0
    for factor in (1.0,) + COARSER:
        t0 = time.perf_counter()
        V, T, net = network_for_mesh((Vn, Fn), hn * factor, umbilic_threshold, tracer=tracer)
        t1 = time.perf_counter()
        rb = rebuild_from_network(V, T, net.lines_1, net.lines_2, hn * factor, boundary_cells=boundary_cells)
        health = face_health(rb.V, rb.F, (V, T), tolerance=SHAPE_TOLERANCE, **HEALTH)
        t["network"] += t1 - t0
        t["rebuild"] += time.perf_counter() - t1
        bad = _fold_mask(health)
        if not bad.any():
            if factor != 1.0:
                warnings.append(f"the curvature network folds at panel size {h:g} ({'; '.join(tried)}); the "
                                f"candidate was rebuilt at panel size {h * factor:g} instead")
            return V, T, net, rb, health
        counts = _fold_counts(health)
        if bad.sum() <= MAX_REPAIR * len(bad):
            fixed = _without(rb, bad)
            if fixed is not None:
                h2 = face_health(fixed.V, fixed.F, (V, T), tolerance=SHAPE_TOLERANCE, **HEALTH)
                if not _fold_mask(h2).any():
                    warnings.append(f"the rebuilt candidate folds ({counts} faces): {int(bad.sum())} folded cell(s) "
                                    "were dropped")
                    if factor != 1.0:
                        warnings.append(f"the curvature network folds at panel size {h:g} ({'; '.join(tried)}); "
                                        f"the candidate was rebuilt at panel size {h * factor:g} instead")
                    return V, T, net, fixed, h2
        tried.append(f"panel size {h * factor:g}: {counts} faces")
    own = face_health(Vn, Fn, min_edge_ratio=0.0, min_angle=0.0, min_area_ratio=0.0).intersecting_pairs
    if len(own):
        raise InputError("mesh", f"the design surface crosses itself ({len(own)} pairs of crossing faces, e.g. faces "
                                 f"{own[0, 0]} and {own[0, 1]}), so every panelling of it folds ("
                                 + "; ".join(tried) + "); repair the surface first")
    raise InputError("mesh", "the curvature lines of this surface fold in every rebuild tried (" + "; ".join(tried)
                     + "): umbilics or flat points make the network cross itself; use fields/pq_from_conjugate_field")


def curvature_pipeline(mesh, panel_size: float, optimize: bool = True, offset: float = 0.0,
                       umbilic_threshold: float = 0.05, boundary_cells: str = "extend", closeness_weight: float = 1.0,
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
    boundary_cells : {"extend", "trim", "keep"}
        Boundary cells of the rebuild (see :func:`components.network.rebuild.rebuild_from_network`).
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

    Raises
    ------
    MeshError
        Malformed mesh, no boundary or not a topological disk.
    InputError
        Bad numbers or options; a surface umbilic almost everywhere; a network that folds at every panel size tried.
    """
    t = {} if timings is None else timings
    t0 = time.perf_counter()
    d = check_number(offset, "offset")
    check_choice(boundary_cells, "boundary_cells", BOUNDARY_CELLS)
    V0, F0 = check_mesh(mesh, "mesh")
    h = check_number(panel_size, "panel_size", 0, above=True)
    fr = _frame(V0)
    warnings: list[str] = []
    hn = max(round(h / fr.scale / SNAP), 1) * SNAP  # on the same grid: the same panel size in every unit
    V, T, net, rb, cand_health = _candidate(fr.to(V0), F0, hn, h, umbilic_threshold, boundary_cells, tracer,
                                            warnings, t)
    warnings[:0] = list(net.warnings) + list(rb.warnings)
    cand_shape = [line for line in cand_health.violations if "not planar" not in line]
    if cand_shape:
        warnings.append("candidate panels not healthy: " + "; ".join(cand_shape))
    err = principal_angle_error(rb.V, rb.F, V, T, net)
    cand_pl = _max_planarity(rb.V, rb.F)
    cand_crit = _max_criterion(rb.V, rb.F)
    if optimize:
        t2 = time.perf_counter()
        opt = conical_mesh(rb.V, rb.F, (V, T), closeness_weight=closeness_weight, time_budget=time_budget,
                           tolerance=TOLERANCE, mesh_name="candidate", **HEALTH)
        t["optimize"] = time.perf_counter() - t2
        warnings += opt.warnings
        X, F = opt.V, opt.F
        max_pl, max_crit, max_dev = opt.max_planarity, opt.max_criterion, opt.max_cone_deviation
        close, L = opt.mean_closeness, opt.mean_edge_length
        healthy, coverage, violations = opt.healthy, opt.coverage, list(opt.violations)
        is_conical = opt.converged
        if not healthy:
            res_health = face_health(X, F, (V, T), tolerance=TOLERANCE, **HEALTH)
            if _fold_mask(res_health).any():  # never a folded mesh: back to the (unfolded) candidate
                warnings.append(f"the conical optimization folded the mesh ({_fold_counts(res_health)} faces); the "
                                "candidate is returned unoptimized")
                X = rb.V
                max_pl, max_crit = cand_pl, cand_crit
                max_dev = float(cone_fit(X, F).deviation.max()) if len(X) else 0.0
                close = float(TriangleIndex(V, T).query(X).distances.mean())
                res_health = face_health(X, F, (V, T), tolerance=TOLERANCE, **HEALTH)
                healthy, coverage, violations = res_health.healthy, res_health.coverage, list(res_health.violations)
                is_conical = False
    else:
        X, F = rb.V, rb.F
        max_pl, max_crit = cand_pl, cand_crit
        fit = cone_fit(X, F)
        max_dev = float(fit.deviation.max()) if len(fit.deviation) else 0.0
        close = float(TriangleIndex(V, T).query(X).distances.mean())
        res_health = face_health(X, F, (V, T), tolerance=TOLERANCE, **HEALTH)
        healthy, coverage, violations = res_health.healthy, res_health.coverage, list(res_health.violations)
        is_conical = max_pl <= TOLERANCE and max_crit <= TOLERANCE and healthy
    L = _mean_edge(X, F)
    t3 = time.perf_counter()
    dn = d / fr.scale
    if d != 0:
        off = face_offset(X, F, dn)
        Xo = off.V
        max_off = float(off.face_error.max()) * fr.scale
        cop = float(off.axis_coplanarity.max()) if len(off.axis_coplanarity) else 0.0
        axes = off.axes
        if max_off > 1e-6 * abs(d):
            warnings.append(_offset_warning(X, F, off, d, max_off, optimize))
    else:
        Xo = X
        max_off, cop = 0.0, 0.0
        axes = np.stack([X, X + L * cone_fit(X, F).axis], axis=1)
    t["offset"] = time.perf_counter() - t3
    if not healthy and not any(w.startswith("panels not healthy") for w in warnings):
        warnings.append("panels not healthy: " + "; ".join(violations))
    t["total"] = time.perf_counter() - t0
    Vc = fr.back(rb.V)
    Xb = Vc if X is rb.V else fr.back(X)
    return CurvaturePipelineResult(
        candidate=(Vc, rb.F),
        quad_fraction=rb.quad_fraction,
        mean_angle_error=err.mean_away_from_umbilics,
        candidate_max_planarity=cand_pl,
        candidate_max_criterion=cand_crit,
        optimized=(Xb, F),
        max_planarity=max_pl,
        max_criterion=max_crit,
        max_cone_deviation=max_dev,
        mean_closeness=close * fr.scale,
        relative_closeness=close / max(L, 1e-300),
        is_conical=bool(is_conical),
        offset_mesh=(fr.back(Xo) if d != 0 else Xb, F),
        max_offset_error=max_off,
        max_axis_coplanarity=cop,
        node_axes=fr.back(axes),
        lines_1=[fr.back(q) for q in net.lines_1],
        lines_2=[fr.back(q) for q in net.lines_2],
        healthy=bool(healthy),
        coverage=float(coverage),
        violations=violations,
        warnings=warnings,
    )


def _mean_edge(X, F) -> float:
    E = edge_topology(F).E
    return float(np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1).mean()) if len(E) else 0.0


def _offset_warning(X, F, off, d, max_off, optimize) -> str:
    """Where and why the face offset is not exact: vertices with five or more faces (four on the boundary) are not
    constrained by the conical criterion."""
    n = len(X)
    faces_at = np.bincount(face_corners(F).v, minlength=n)
    bnd = boundary_vertex_mask(F, n)
    irregular = int(np.count_nonzero(np.where(bnd, faces_at >= 4, faces_at >= 5)))
    where = (f"; {irregular} vertex(es) have five or more faces (four on the boundary), where the conical angle "
             "criterion does not apply and the offset planes meet only approximately") if irregular else ""
    hint = "; run with optimize=True" if not optimize else ""
    return (f"face offset: face planes are up to {max_off:.2e} from the distance {d:g} (the mesh is not exactly "
            f"conical{where}{hint})")


def pq_from_curvature_network(mesh: Mesh, panel_size: float, optimize: bool = True, offset: float = 0.0,
                              umbilic_threshold: float = 0.05, boundary_cells: str = "extend",
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
        ``"extend"``: the panels reach the design boundary (boundary cells kept, short edges collapsed, flat corners
        and holes split, so the panels are healthy and cover the surface); ``"trim"``: boundary triangles/pentagons
        dropped (nearly all quads, up to one panel short of the boundary); ``"keep"``: kept as traced.
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
        The conical mesh (the candidate when ``optimize`` is off, or when the optimization would fold it).
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
        Planarity and angle criterion within 1e-4, and the panels healthy.
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
    healthy : bool
        The optimized panels are fabricable: corners of 20° to 160°, edges over 0.2 × the median, faces over 0.1 ×
        the median area, no folds or crossings, planarity within 1e-4, at least 85% of the design surface covered.
    coverage : float
        Share of the design surface covered by the optimized mesh, 0..1.
    violations : Texts
        One line per failed health check, with the count and the worst value (empty when healthy).

    Raises
    ------
    MeshError
        Malformed mesh, no boundary or not a topological disk (named ``mesh``).
    InputError
        Non-positive panel size, bad options, a surface umbilic almost everywhere, a curvature network that folds
        (umbilics or flat points) at the panel size and at 1.5 and 2 times it (named ``mesh``).

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
