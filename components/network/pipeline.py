"""End-to-end curvature-network strategy: surface + panel size → PQ candidate → conical mesh → face offset.

Steps (project issue 7): the principal curvature network (:mod:`components.network.tracing`; umbilic regions,
where every direction is principal, are crossed along the smoothest continuation of the principal directions
around them), the quad rebuild in a conformal plane (:mod:`components.network.rebuild`, boundary and irregular
cells healed and cells under which the surface bulges split by :mod:`components.network.healing`), conical
analysis of the candidate, the conical optimization through the planarization solver
(:func:`components.conical.optimize.conical_solve`, :func:`components.conical.optimize.conical_mesh` without its
own health verdict: the result is judged once, at the bounds below) and the face offset with its node axes
(:func:`components.conical.cones.face_offset`).

Fabricable or it says why (project issue 16): the candidate and the result are measured with
:func:`components.metrics.health.face_health` against the design surface (corners of 20° to 160°, edges over 0.2 ×
the median, faces over 0.1 × the median area, no folds or crossings, 85% of the surface covered). The optimization
is guarded a little inside these bounds (:data:`GUARD`). A folded candidate (faces crossing or folded onto each
other, flipped against the surface: the curvature lines of a surface with umbilics or flat points can fold in the
plane map) is never returned: a few folded cells are dropped, else the network is traced again at a coarser panel
size. With the default ``boundary_cells="extend"`` a result that is not healthy is not the last word either:

1. the cells are healed again with a looser bulge bound (:data:`HEAL_TRIES`: fewer, larger cells) and optimized;
2. if no network candidate gives healthy panels, or the network cannot be built (a surface umbilic or flat almost
   everywhere, such as a sphere patch, where every direction is principal; a network folding at every panel size
   tried; a surface with holes or handles, whose lines the rebuild cannot intersect in one plane map of a disk),
   the candidate is a quad mesh of the fields stage on the principal directions
   (:func:`components.fields.candidate.candidate_mesh`, ``field="principal"``, repaired), optimized the same way;

the first healthy result is returned (else the one with the fewest unhealthy faces), and a warning says which
candidate it is and why. A surface that crosses itself is refused with a typed
:class:`~components.core.errors.InputError` (every panelling of it folds). ``is_conical`` is claimed only when the
tolerance is reached, every vertex with four or more faces is conical (``conical/analysis``'s verdict; the angle
criterion the optimization meets constrains the valence-4 vertices only, so a vertex with five or more faces off
its cone is named in a warning) **and** the panels are healthy; anything else comes with a warning naming the counts.

Units and placement do not matter: the surface is centred on its bounding box and scaled to unit size before anything
is computed (and every output is mapped back), so a model in millimetres, metres or placed at 5e6 gives the same
panels.

Array-level: :func:`curvature_pipeline`. Published: :func:`pq_from_curvature_network`.
"""
from __future__ import annotations

import logging
import time
from typing import Callable, NamedTuple

import numpy as np

from components.conical.cones import cone_fit, conical_criterion, face_offset
from components.conical.optimize import conical_solve
from components.core.blas import single_blas_thread
from components.core.checks import boundary_gap_warning, check_choice, check_length, check_mesh, check_number
from components.core.conformal import NOT_A_DISK_REFUSAL
from components.core import deadline, progress
from components.core.errors import InputError, MeshError
from components.core.measures import max_quad_planarity
from components.core.mesh import (boundary_vertex_mask, bounding_box_diagonal, edge_topology, face_corners, face_lists,
                                  face_sizes, pad_faces, triangulate)
from components.core.types import Curves, Lines, Mesh, Texts
from components.core.frame import IDENTITY, bounding_frame
from components.fields.candidate import checked_inputs, framed_candidate
from components.fields.parametrize import check_target_fits
from components.metrics.health import DEFECT_BITS, face_health
from components.network.healing import manifold_cells
from components.network.rebuild import BOUNDARY_CELLS, MAX_BULGE, rebuild_from_network
from components.network.tracing import (UMBILIC_REFUSAL, network_for_mesh, principal_angle_error, principal_field,
                                       surface_index)

log = logging.getLogger(__name__)

__all__ = ["CurvaturePipelineResult", "curvature_pipeline", "pq_from_curvature_network"]

#: the panel-health bounds every result is judged by (components.metrics.health.face_health)
HEALTH = {"min_edge_ratio": 0.2, "min_angle": 20.0, "min_area_ratio": 0.1, "min_coverage": 0.85}
TOLERANCE = 1e-4  # planarity (scale-free) and angle criterion (radians) of a conical result
SHAPE_TOLERANCE = 10.0  # planarity bound when judging a candidate's shape (a candidate is not planar yet)
#: the bounds the conical optimization is guarded with: a margin inside HEALTH (its guard lets an edge or a corner
#: end a little under the bound it is given)
GUARD = {"min_edge_ratio": 0.22, "min_angle": 21.0, "min_area_ratio": 0.11, "min_coverage": 0.85}
HEAL_TRIES = (MAX_BULGE, 0.2)  # largest bulge of the healed cells (× median edge), per try until one is healthy
FOLDS = ("intersecting", "folded", "flipped", "nonmanifold")
FOLD_REFUSAL = "the curvature lines of this surface fold in every rebuild tried"  # how that refusal starts  # defects of a folded mesh
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


def _max_criterion(V, F):
    _, c = conical_criterion(V, F)
    return float(np.abs(c).max()) if len(c) else 0.0


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


def _candidate(Vn, Fn, hn, h, umbilic_threshold, boundary_cells, tracer, warnings, t, max_bulge=MAX_BULGE,
               networks=None):
    """Trace the network and rebuild the candidate (normalized units ``hn``; ``h`` the panel size as asked), never a
    folded one: a few folded cells are dropped, else a coarser panel size is tried, else :class:`InputError`.

    Returns ``(V, T, net, rebuild, candidate health)``; adds the seconds spent to ``t["network"]`` and
    ``t["rebuild"]`` (all tries). ``networks`` (a dict), when given, keeps the traced networks per panel size for
    the next call.
    """
    tried = []
    networks = {} if networks is None else networks
    t.setdefault("network", 0.0)
    t.setdefault("rebuild", 0.0)
    for factor in (1.0,) + COARSER:
        t0 = time.perf_counter()
        if factor not in networks:
            networks[factor] = network_for_mesh((Vn, Fn), hn * factor, umbilic_threshold, tracer=tracer,
                                                umbilic="fill", check_fit=False)  # checked as given
        V, T, net = networks[factor]
        t1 = time.perf_counter()
        rb = rebuild_from_network(V, T, net.lines_1, net.lines_2, hn * factor, boundary_cells=boundary_cells,
                                  max_bulge=max_bulge)
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
    raise InputError("mesh", FOLD_REFUSAL + " (" + "; ".join(tried)
                     + "): umbilics or flat points make the network cross itself; use fields/pq_from_conjugate_field")


class _Cand(NamedTuple):
    """A candidate (normalized units) and what building it said."""

    V: np.ndarray
    F: np.ndarray
    quad_fraction: float
    warnings: list


class _Outcome(NamedTuple):
    """One candidate optimized (or not) and judged (normalized units)."""

    X: np.ndarray
    F: np.ndarray
    max_planarity: float
    max_criterion: float
    max_deviation: float
    closeness: float
    healthy: bool
    coverage: float
    violations: list
    is_conical: bool
    warnings: list
    bad_faces: int  # faces with a health defect (ranks the unhealthy tries)
    folded: str  # the fold counts of its health ("" when nothing folds)


def _same(a: _Cand, b: _Cand) -> bool:
    return a.F.shape == b.F.shape and a.V.shape == b.V.shape and np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V)


def _judged(V, T, X, F, max_pl, max_crit, max_dev, close, warnings, reached) -> _Outcome:
    hh = face_health(X, F, (V, T), tolerance=TOLERANCE, **HEALTH)
    return _Outcome(X, F, max_pl, max_crit, max_dev, close, hh.healthy, hh.coverage, list(hh.violations),
                    bool(reached and hh.healthy), warnings, int(np.count_nonzero(hh.face_defects)),
                    _fold_counts(hh) if _fold_mask(hh).any() else "")


def _as_is(V, T, cand: _Cand, warnings=()) -> _Outcome:
    """The candidate itself, judged."""
    X, F = cand.V, cand.F
    pl, crit = max_quad_planarity(X, F), _max_criterion(X, F)
    fit = cone_fit(X, F)
    dev = float(fit.deviation.max()) if len(fit.deviation) else 0.0
    close = float(surface_index(V, T).query(X).distances.mean())
    return _judged(V, T, X, F, pl, crit, dev, close, list(warnings), pl <= TOLERANCE and crit <= TOLERANCE)


def _finished(V, T, cand: _Cand, optimize, closeness_weight, budget, t) -> _Outcome:
    """The candidate after the conical optimization (guarded a little inside the health bounds, :data:`GUARD`),
    judged with :data:`HEALTH`; never folded (a folded result gives the candidate back)."""
    if not optimize:
        return _as_is(V, T, cand)
    t2 = time.perf_counter()
    # judged once below at HEALTH (conical_mesh would judge it at GUARD too)
    try:
        opt = conical_solve(cand.V, cand.F, (V, T), closeness_weight=closeness_weight, time_budget=max(budget, 1e-3),
                            tolerance=TOLERANCE, mesh_name="candidate", **GUARD)
    except MeshError as exc:  # the solver refused our own candidate (e.g. two boundary fans pinched at a vertex)
        if exc.input_name != "candidate":
            raise
        t["optimize"] += time.perf_counter() - t2
        return _as_is(V, T, cand, [f"the conical optimization refused the candidate ({exc.detail}); it is returned "
                                   "unoptimized"])
    t["optimize"] += time.perf_counter() - t2
    warnings = list(opt.warnings)
    out = _judged(V, T, opt.V, opt.F, opt.max_planarity, opt.max_criterion, opt.max_cone_deviation,
                  opt.mean_closeness, warnings, opt.reached)
    if out.folded:  # never a folded mesh: back to the (unfolded) candidate
        warnings.append(f"the conical optimization folded the mesh ({out.folded} faces); the candidate is "
                        "returned unoptimized")
        return _as_is(V, T, cand, warnings)
    return out


def _fields_candidate(V, T, hn, why: str) -> _Cand | None:
    """The last resort: a quad candidate of the fields stage on the principal directions
    (:func:`components.fields.candidate.candidate_mesh`, ``field="principal"``, boundary snapped (one extraction:
    the "auto" search of six costs several times more, tens of seconds on a large surface at coarse panels),
    repaired), or ``None`` when it cannot be built."""
    try:
        # in the network's frame already, as computed: snapped, the rounding of a far placement straddled a grid line
        # at a few vertices, which moved them by a whole grid step (the dome of the tests: 101 or 102 panels with the
        # placement, snapped; 102 at every placement, unsnapped)
        V, T, hn, alignment, cons = checked_inputs((V, T), hn, "principal", 0.1, "snap", None, None)
        fc = framed_candidate(V, T, hn, IDENTITY, "principal", alignment, "snap", cons, repair=True)
    except (InputError, MeshError) as exc:
        log.info("curvature network: no fields fallback (%s)", exc)
        return None
    if len(fc.F) == 0:
        return None
    w = [why + ": fell back to a quad candidate of the fields stage on the principal directions "
         "(components.fields.candidate.candidate_mesh, field='principal', a smooth field where they are undefined): "
         "its edges follow the principal directions only approximately"]
    return _Cand(np.asarray(fc.V, np.float64), np.asarray(fc.F, np.int64), fc.quads / max(len(fc.F), 1),
                 w + list(fc.warnings))


@single_blas_thread()  # sparse factorizations: see components.core.blas
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
        Anisotropy threshold of umbilic regions (crossed along the filled principal field).
    boundary_cells : {"extend", "trim", "keep"}
        Boundary cells of the rebuild (see :func:`components.network.rebuild.rebuild_from_network`); only
        ``"extend"`` retries with other candidates when the result is not healthy.
    closeness_weight : float
        Weight of the pull to the design surface in the optimization.
    time_budget : float
        Seconds for the optimization (cut to the caller's deadline, :mod:`components.core.deadline`: a further try
        starts only while the deadline leaves as much time as the last one took).
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
        Malformed mesh or no boundary; with ``boundary_cells`` "trim" or "keep", a surface that is not a
        topological disk (holes, handles; with "extend" it falls back to the fields candidate).
    InputError
        Bad numbers or options; a design surface that crosses itself; with ``boundary_cells`` "trim" or "keep", a
        surface umbilic almost everywhere or a network that folds at every panel size tried (with "extend" those
        fall back to the fields candidate).
    """
    t = {} if timings is None else timings
    t0 = time.perf_counter()
    check_choice(boundary_cells, "boundary_cells", BOUNDARY_CELLS)
    V0, F0 = check_mesh(mesh, "mesh")
    d = check_length(offset, "offset", bounding_box_diagonal(V0))
    h = check_number(panel_size, "panel_size", 0, above=True)
    T0 = F0 if F0.shape[1] == 3 else triangulate(F0)[0]
    check_target_fits(V0, T0, h, "panel_size")  # in the units given
    fr = bounding_frame(V0, SNAP)
    warnings: list[str] = []
    hn = max(round(h / fr.scale / SNAP), 1) * SNAP  # on the same grid: the same panel size in every unit
    Vn = fr.to(V0)
    networks: dict = {}
    tries: list = []
    t["optimize"] = 0.0
    extend = boundary_cells == "extend"
    try:
        last = 0.0  # seconds of the last try: another one starts only when the caller's deadline leaves as much
        for bulge in HEAL_TRIES:
            t_try = time.perf_counter()
            w_try: list[str] = []
            progress.report(0.0, "curvature network and candidate", until=0.3)
            V, T, net, rb, cand_health = _candidate(Vn, F0, hn, h, umbilic_threshold, boundary_cells, tracer, w_try,
                                                    t, max_bulge=bulge, networks=networks)
            w_try[:0] = list(net.warnings) + list(rb.warnings)
            cand_shape = [line for line in cand_health.violations if "not planar" not in line]
            if cand_shape:
                w_try.append("candidate panels not healthy: " + "; ".join(cand_shape))
            cand = _Cand(rb.V, rb.F, rb.quad_fraction, w_try)
            if tries and _same(tries[-1][0], cand):  # the looser bound changed nothing
                continue
            progress.report(0.3, "conical optimization", until=0.9)
            out = _finished(V, T, cand, optimize, closeness_weight, time_budget - t["optimize"], t)
            tries.append((cand, out, bulge))
            last = time.perf_counter() - t_try
            if out.healthy or not (optimize and extend and t["optimize"] < time_budget) or deadline.time_left() < last:
                break
        if (optimize and extend and t["optimize"] < time_budget and deadline.time_left() >= last
                and not any(o.healthy for _, o, _ in tries)):
            Vu = fr.unsnapped(V0)
            fb = _fields_candidate(Vu, T, hn, "the curvature network's candidates did not give healthy panels after "
                                              "the conical optimization (" + "; ".join(tries[0][1].violations) + ")")
            if fb is not None:
                tries.append((fb, _finished(Vu, T, fb, optimize, closeness_weight, time_budget - t["optimize"], t),
                              None))
    except InputError as exc:  # umbilic almost everywhere (every direction is principal), folding everywhere, or
        # holes or handles (the rebuild intersects the lines in one plane map of a disk; the fields stage cuts)
        if not (extend and exc.input_name == "mesh"
                and exc.detail.startswith((UMBILIC_REFUSAL, FOLD_REFUSAL, NOT_A_DISK_REFUSAL))):
            raise
        V, T, net = fr.unsnapped(V0), T0, None
        why = exc.detail
        if why.startswith(NOT_A_DISK_REFUSAL):
            why = why.split(":")[0] + "; the curvature-network rebuild needs one boundary loop and no handle"
        fb = _fields_candidate(V, T, hn, why)
        if fb is None:
            raise
        tries.append((fb, _finished(V, T, fb, optimize, closeness_weight, time_budget, t), None))
    # the first healthy try, else the one covering the surface with the smallest share of unhealthy faces
    k = min(range(len(tries)), key=lambda i: (not tries[i][1].healthy,
                                              tries[i][1].coverage < HEALTH["min_coverage"],
                                              tries[i][1].bad_faces / max(len(tries[i][1].F), 1), i))
    cand, out, bulge = tries[k]
    gap = boundary_gap_warning(V0, F0, h)
    warnings = ([gap] if gap else []) + list(cand.warnings) + list(out.warnings)
    if k > 0 and bulge is not None:
        warnings.append(f"the curvature network's cells healed to bulge at most {HEAL_TRIES[0]:g} × the median edge "
                        "did not give healthy panels after the conical optimization ("
                        + "; ".join(tries[0][1].violations) + f"); the cells were healed again with bulges up to "
                        f"{bulge:g} × the median edge")
    err = principal_angle_error(cand.V, cand.F, V, T, net if net is not None else principal_field(V, T))
    X, F = out.X, out.F
    max_pl, max_crit, max_dev, close = out.max_planarity, out.max_criterion, out.max_deviation, out.closeness
    healthy, coverage, violations, is_conical = out.healthy, out.coverage, list(out.violations), out.is_conical
    L = _mean_edge(X, F)
    progress.report(0.9, "offset")
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
    Vc = fr.back(cand.V)
    Xb = Vc if X is cand.V else fr.back(X)
    return CurvaturePipelineResult(
        candidate=(Vc, cand.F),
        quad_fraction=cand.quad_fraction,
        mean_angle_error=err.mean_away_from_umbilics,
        candidate_max_planarity=max_quad_planarity(cand.V, cand.F),
        candidate_max_criterion=_max_criterion(cand.V, cand.F),
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
        lines_1=[fr.back(q) for q in net.lines_1] if net is not None else [],
        lines_2=[fr.back(q) for q in net.lines_2] if net is not None else [],
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
        Curvature anisotropy below which a region is umbilic: every direction is principal there, and the network
        crosses it along the smoothest continuation of the principal directions around it.
    boundary_cells : str
        ``"extend"``: the panels reach the design boundary (boundary cells kept, short edges collapsed, flat corners
        and holes split, bulging cells split, so the panels are healthy and cover the surface; when they still are
        not after the optimization, the cells are healed again with fewer splits, then a fields candidate on the
        principal directions is tried, and a warning says so); ``"trim"``: boundary triangles/pentagons dropped
        (nearly all quads, up to one panel short of the boundary); ``"keep"``: kept as traced.
    closeness_weight : float
        Weight of the pull to the design surface during the optimization.
    time_budget : float
        Seconds allowed for the optimization.

    Returns
    -------
    candidate : Mesh
        The quad-dominant mesh rebuilt from the curvature network (on the surface), or the fields candidate it fell
        back to (the warnings say so).
    quad_fraction : float
        Fraction of the candidate's faces that are quads.
    mean_angle_error : float
        Mean angle (degrees) between the candidate's edges and the principal directions, away from umbilics (over
        all edges when the surface is umbilic or flat almost everywhere, where the directions are arbitrary).
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
        Planarity and angle criterion within 1e-4, the face normals on a cone at every vertex with four or more
        faces (the verdict of ``conical/analysis``: the criterion constrains only the valence-4 vertices, and a
        warning names the others that are off their cones), and the panels healthy.
    offset_mesh : Mesh
        The face offset at ``offset`` (the optimized mesh itself when ``offset`` is 0).
    max_offset_error : float
        Largest ``|distance of an offset face plane − offset|`` (model units).
    max_axis_coplanarity : float
        Largest scale-free triple product of the node axes at the ends of an edge (0: consecutive axes coplanar).
    node_axes : Lines
        Node axis of every vertex (vertex → offset vertex, or one edge long).
    lines_1 : Curves
        Lines of maximal curvature (none on a surface umbilic almost everywhere).
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
        Non-positive panel size, bad options; a design surface that crosses itself (named ``mesh``); with
        ``boundary_cells`` "trim" or "keep" also a surface umbilic almost everywhere or a curvature network that
        folds at the panel size and at 1.5 and 2 times it (named ``mesh``; "extend" falls back to a fields
        candidate there).

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
    >>> res.healthy, bool(res.max_criterion < 1e-4), res.is_conical  # every valence-4 vertex conical, not all
    (True, True, False)
    >>> [w[:47] for w in res.warnings if w.startswith("not conical")]
    ['not conical at 1 vertex with five or more faces']
    """
    return curvature_pipeline(mesh, panel_size, optimize=bool(optimize), offset=offset,
                              umbilic_threshold=umbilic_threshold, boundary_cells=boundary_cells,
                              closeness_weight=closeness_weight, time_budget=time_budget)
