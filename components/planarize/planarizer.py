"""Planarization of quad / polygon meshes: a guided Gauss-Newton solver with soft design goals.

Every meshing strategy ends with a candidate quad mesh whose faces are almost, but not exactly, planar. This module
moves its vertices until every face is planar (to a tolerance) while the mesh stays close to the design surface,
keeps its boundary and anchors, stays fair and keeps its panels healthy (no collapsed or non-convex quads).

Solver: a minimum-displacement Gauss-Newton / SQP method in the spirit of guided projection (Tang, Sun, Gomes,
Wallner & Pottmann 2014, "Form-finding with polyhedral meshes made simple"). The scale-free planarity residuals
(and, optionally, the conical angle criterion) are *hard* rows ``c(X) = s``, linearized exactly; the soft goals form
an objective ``½ (1 + start_weight)|X − X0|² + ½ α Σ (n·(X − C))² + ½ Σ w |r|²`` (displacement from the input,
distance to the reference's tangent planes, fairness / even edges / even areas) whose block-diagonal majorizer
``H`` is the step metric. Every iteration solves one sparse SPD system with one row per face,
``(J G Jᵀ) λ = rhs`` with ``G = H⁻¹`` restricted to the free / sliding directions, for two right-hand sides:
the feasibility step ``Δf`` (the minimum-norm correction in the metric) and the optimality step ``Δo`` (the soft
step projected on the linearized constraints). Phases: *restore* (``Δf`` steps with backtracking until the
tolerance is met: planarity converges quadratically), *optimize* (``Δf + tΔo`` while planarity stays within 30 ×
the tolerance and the objective decreases: this walks along the planar meshes toward the smallest displacement /
closest fit / fairest net; a step is only taken while the quadratic model, solved with the previous iteration's
factorization, promises at least 1 % of the objective and as much as moving every vertex 1 % of an edge),
*polish* (``Δf`` steps back below the tolerance). Faces above ``relax ×`` the tolerance are driven to that value,
not to 0, so a loose tolerance costs little displacement. An accepted step still above the tolerance gets up to two
chord corrections (the feasibility step of the new residual solved with the same factorization): the tolerance is
usually met one iteration, and one factorization, earlier. Without a reference the restore phase corrects in the
plain metric: the closeness to the start's tangent planes made in-surface moves the cheap ones, and the correction
sheared the net (a ±3 % noisy 60² grid: worst corner 87° → 62° after restore, 75° at the end, 10 iterations; now
70° after restore, 84° at the end, 4 iterations).

Panel health ("fabricable or it says why"): the solver cannot collapse, pinch or fold a panel. Corners keep at least
20° and half the input's worst, edges 0.2 × the median edge and half their input length, faces 0.1 × the median
area (a corner, edge or face that starts under its bound may lose at most 10 %); no face turns non-convex, folds
onto its neighbour, turns over against the reference or crosses a face it shares no vertex with
(:mod:`~components.planarize.guard`). Corners, edges, faces and hinges close to a bound become hard rows
(inequalities in effect: rows whose multiplier holds a value down are released, unless they lift an item still
under its target), steps are shortened otherwise;
the restore phase also takes a step that lowers the total excess over the tolerance without raising the worst
face, and stops when the worst face has not improved by 1 % in 10 iterations. ``converged`` means the tolerance
was reached **and** the result is healthy by :func:`components.metrics.health.face_health` at the same bounds
(with a reference also its coverage); when the guard and planarity cannot both be met the solver stops healthy
and a warning says how far the tolerance is (the counts, the worst planarity against the tolerance). The best
state seen is returned, never one worse than the input in planarity.

Units and placement do not matter: the mesh is centred before anything is computed (and moved back at the end) and
the solver works in units of the mean edge; every bound and epsilon is relative to the mesh's own size. Input
handling (:mod:`~components.planarize.inputs`): triangles (``(m, 3)`` or padded ``(a, b, c, c)``) are planar and
kept: they take no part in the planarity goal nor in the stopping test; duplicate vertices are welded (a warning
says so), a face with a zero-length edge or pieces that touch without being welded are refused with a
:class:`~components.core.errors.MeshError` that says what to fix.

The solver's parts: :mod:`~components.planarize.problem` (input checks, vertex roles, normalized units, static
goal data), :mod:`~components.planarize.rows` (goal rows: the soft objective, the step metric, the hard rows),
:mod:`~components.planarize.step` (one solve and its line search), :mod:`~components.planarize.guard` (panel-health
acceptance of a step), :mod:`~components.planarize.phases` (restore / optimize / polish, stopping, best state),
:mod:`~components.planarize.inputs` (centring, welding, refused inputs), :mod:`~components.planarize.verdict`
(health of the result, violations, warnings).

Public array-level function: :func:`planarize_mesh` (this module's driver). Published components:
:func:`planarize`, :func:`on_surface` (URI ``planarize/on_surface``).
"""
from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from components.core.blas import single_blas_thread
from components.core import deadline
from components.core.checks import check_mesh, validate_mesh
from components.core.measures import corner_angles, nonconvex_faces, quad_planarity, warping_height
from components.core.mesh import edge_topology, face_normals, face_sizes, triangulate
from components.core.proximity import TriangleIndex
from components.core.types import Integers, Mesh, Numbers, Points, Texts
from components.metrics.health import face_health
from components.planarize.guard import health_bounds, panel_guard
from components.planarize.inputs import centred_reference, prepared_mesh
from components.planarize.phases import final_state, iterate
from components.planarize.problem import OPT_ITERATIONS, SNAP, checked_options, setup_problem
from components.planarize.verdict import backed_off_reason, healthy_backoff, planarity_line, result_verdict

__all__ = ["PlanarizeResult", "planarize", "on_surface", "planarize_mesh"]



class PlanarizeResult(NamedTuple):
    """Result of :func:`planarize` (field names are the Hops outputs)."""

    mesh: Mesh
    planarity: Numbers
    max_planarity: float
    mean_planarity: float
    max_closeness: float
    mean_closeness: float
    iterations: int
    converged: bool
    stop_reason: str
    worst_corner_angle: float
    nonconvex_faces: int
    max_warping_height: float
    max_conical: float
    history_max_planarity: Numbers
    history_mean_planarity: Numbers
    history_max_closeness: Numbers
    history_mean_closeness: Numbers
    history_time: Numbers
    healthy: bool
    coverage: float
    violations: Texts
    warnings: list[str]


def planarize_mesh(
    V, F, reference=None, *, closeness_weight: float = 1.0, start_weight: float = 0.0,
    fairness_weight: float = 0.01, fairness_mode: str = "polylines", edge_length_weight: float = 0.0,
    target_edge_length: float = 0.0, area_weight: float = 0.0, target_area: float = 0.0,
    conical_weight: float = 0.0, boundary: str = "free", anchors=None, anchor_points=None, tolerance: float = 1e-4,
    absolute_tolerance: float = 0.0, max_iterations: int = 100, time_budget: float = 30.0, angle_guard: float = 0.5,
    relax: float = 0.9, optimize_iterations: int = OPT_ITERATIONS, mesh_name: str = "mesh",
    min_angle: float = 20.0, min_edge_ratio: float = 0.2, min_area_ratio: float = 0.1, min_coverage: float = 0.85,
    relaxed_guard: float | None = None,
) -> PlanarizeResult:
    """Make every face of a polygon mesh planar while keeping it close, fair, anchored and healthy.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions (model units).
    F : (m, k) array_like of int
        Padded polygon faces (quads, n-gons; triangles, ``(m, 3)`` or padded ``(a, b, c, c)``, are planar: they take
        part in the other goals and the health guard only). Duplicate vertices are welded (see
        ``absolute_tolerance``).
    reference : tuple (Vr, Fr), optional
        Reference surface mesh to stay on (any polygons; triangulated internally). When absent, closeness is to the
        tangent planes of the start mesh at the start positions.
    closeness_weight : float
        Weight of the pull toward the reference: distance to its tangent plane at the closest point, costing
        ``20 × closeness_weight`` against a displacement of the same length (in mean edge lengths). Without a
        reference, moving along the start normals costs ``1 + closeness_weight`` times moving tangentially (in the
        optimize phase; the restore phase corrects in the plain metric).
    start_weight : float
        Weight of the pull toward the start positions (all three directions).
    fairness_weight : float
        Weight of the fairness goal (second differences along mesh polylines, or Laplacian).
    fairness_mode : {"polylines", "laplacian"}
        Fairness measure.
    edge_length_weight, target_edge_length : float
        Edge length equalization toward ``target_edge_length`` (model units; 0 = the current mean).
    area_weight, target_area : float
        Face area equalization toward ``target_area`` (model units²; 0 = the current mean).
    conical_weight : float
        Weight of the conical angle criterion at interior valence-4 vertices (a hard goal like planarity when > 0).
    boundary : {"fixed", "slide", "free"}
        Boundary vertices fixed, sliding along the reference's boundary polylines (the start boundary without a
        reference; corners, i.e. vertices of one face or sharp turns, stay fixed), or free. A reference loop that
        is a staircase (a hole cut along a triangulation's edges: over a quarter of its vertices turn by more than
        40°) is not slid on: the vertices by it move freely, pulled across the loop smoothed over half an edge at
        ``20 × max(closeness_weight, 1)`` (sliding on the steps themselves, the guard refused every step).
    anchors : (a,) array_like of int, optional
        Vertex indices that must not move.
    anchor_points : (p, 3) array_like of float, optional
        Points whose nearest vertices must not move.
    tolerance : float
        Scale-free planarity to reach (max over faces); applies when > 0.
    absolute_tolerance : float
        Warping height to reach in model units; applies only when ``tolerance <= 0``. When > 0 it is also the weld
        tolerance of duplicate vertices (at most 1 % of the median edge; else 1e-9 × the bounding-box diagonal).
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds (cut to the caller's deadline, :mod:`components.core.deadline`, with a warning).
    angle_guard : float
        In ``[0, 1]``: no corner may go below this fraction of the input's worst corner angle (nor its margin to
        180° below the same fraction), no edge below this fraction of its input length, no face below its square
        of its input area.
    relax : float
        Faces above ``relax × tolerance`` are driven to that value, not to 0 (in ``(0, 1]``; smaller values leave
        more margin, larger ones move less).
    optimize_iterations : int
        Cap of the optimize phase (walking along the planar meshes toward the smallest displacement / closest fit /
        fairest net once the tolerance is met); 0 skips it: fastest, the plain minimum-norm Gauss-Newton result.
    mesh_name : str
        Name of the mesh input used in error messages.
    min_angle : float
        Degrees: no corner may go below it (nor above 180° minus it), nor two faces sharing an edge open by less;
        when the input's worst corner is already below, that is the bound.
    min_edge_ratio : float
        No edge may get shorter than this × the input's median edge (an edge that starts shorter may lose at most
        10 %, and the solver tries to lift it over the bound).
    min_area_ratio : float
        No face may get smaller than this × the input's median face area (the same for one that starts smaller).
    min_coverage : float
        With a reference: the result must cover at least this share of it to be healthy.
    relaxed_guard : float, optional
        In ``[0, angle_guard]``: the ``angle_guard`` the solver may fall back to when the guard holds the planarity
        correction after the closeness stiffness was relaxed (``None``: never; the fabrication bounds above always
        stay). When the guard holds the correction (steps under a quarter of the Gauss-Newton step), the solver
        first lowers the closeness stiffness (÷3 at a time, to 1/100 of ``closeness_weight``) until planarity is
        restored, and pulls the planar mesh back toward the reference at the full weight in the optimize phase.

    Returns
    -------
    PlanarizeResult
        ``converged`` is true when the tolerance was reached and the result is healthy (``healthy``,
        ``violations``, ``coverage``).

    Raises
    ------
    MeshError
        Malformed, non-manifold or degenerate mesh or reference; a face with a zero-length edge; pieces that touch
        without being welded (the message says to weld).
    InputError
        Negative or non-finite weights, unknown modes, anchors out of range, a bound out of its range.
    """
    return planarize_runs(
        RUNS, V, F, reference, closeness_weight=closeness_weight, start_weight=start_weight,
        fairness_weight=fairness_weight, fairness_mode=fairness_mode, edge_length_weight=edge_length_weight,
        target_edge_length=target_edge_length, area_weight=area_weight, target_area=target_area,
        conical_weight=conical_weight, boundary=boundary, anchors=anchors, anchor_points=anchor_points,
        tolerance=tolerance, absolute_tolerance=absolute_tolerance, max_iterations=max_iterations,
        time_budget=time_budget, angle_guard=angle_guard, relax=relax, optimize_iterations=optimize_iterations,
        mesh_name=mesh_name, min_angle=min_angle, min_edge_ratio=min_edge_ratio, min_area_ratio=min_area_ratio,
        min_coverage=min_coverage, relaxed_guard=relaxed_guard)


@single_blas_thread()  # sparse factorizations and the reduced solves' dense products: see components.core.blas
def planarize_runs(runs: tuple, V, F, reference=None, *, mesh_name: str = "mesh", **options) -> PlanarizeResult:
    """:func:`planarize_mesh` (the same keyword options) trying only the solver runs ``runs`` (a tuple of
    :data:`RUNS`' items, in turn while none converged healthy, as ``planarize_mesh`` tries them all). The conjugate
    strategy spreads the runs over its candidates: the first run of each candidate before the other runs of any
    (components/fields/pipeline.py)."""
    t0 = time.perf_counter()
    V, F = validate_mesh(V, F, name=mesh_name, allow_degenerate=True, manifold=False)  # fully checked in _solved
    opts = checked_options(len(V), **options)
    return _solved(V, F, reference, "reference", opts, mesh_name, t0, tuple(runs))


# The solver's runs, tried in turn while none has converged healthy and the time budget holds another run as long as
# the shortest so far (a run cut short by the budget rarely converges); the best is returned (:func:`_better`).
# ``(lift_rows, relax_floor)``: whether a guard row still lifting its item is kept (step.py), and how far the restore
# phase may relax the closeness stiffness (phases.py). Which run reaches the tolerance flips from candidate to
# candidate with round-off (another CPU's SIMD kernels are enough): on the 52-panel wave sample at ×1, ×0.001, ×1000
# and +5e6 (an AVX-512 machine, 2026-12) no single run converged at all four placements — the most planar states lost
# coverage and were backed off — and every placement converged with one of these; a candidate that converges at once
# costs one run, as before. (Until 2026-12 only half the budget was used: the wave sample at ×1000 converges with the
# sixth run only, which started past half of a 10 s budget on some days and not on others: the result depended on the
# machine's speed.)
RUNS = ((True, 0.01), (False, 0.01), (True, 1.0), (False, 1.0), (True, 0.1), (False, 0.1))


def _solved(V, F, reference, reference_name, opts, mesh_name, t0, runs: tuple = RUNS) -> PlanarizeResult:
    """Run the solver on a mesh (shape-checked), a reference (``(Vr, Fr)`` or ``None``, checked here as
    ``reference_name``) and checked options, trying ``runs`` (:data:`RUNS`); ``t0``: the call's start."""
    budget, cut_by = deadline.capped(opts.time_budget - (time.perf_counter() - t0))
    if cut_by is not None:  # the caller's deadline comes first: answer in time with the best state
        opts = opts._replace(time_budget=time.perf_counter() - t0 + budget)
    prep = prepared_mesh(V, F, mesh_name, opts.absolute_tolerance)
    # the solver sees the reference centred like the mesh; the result is judged against it as given, in model
    # units: the closest-point index is then the one a caller's own health check of the surface builds (by content)
    given = ref = None
    if reference is not None:
        given, ref = centred_reference(reference, prep.offset, reference_name)
    anchors = opts.anchors if prep.rep is None else np.unique(prep.rep[opts.anchors])
    opts = opts._replace(anchors=anchors, anchor_points=opts.anchor_points - prep.offset)
    if not np.any(face_sizes(prep.F) >= 4):
        return _triangles_only(V, F, prep, ref, opts, t0)
    best, shortest = None, math.inf
    out_of_time = False  # a further run was left out for the budget
    for lift_rows, relax_floor in runs:
        if best is not None and (_succeeded(best) or time.perf_counter() - t0 + shortest > opts.time_budget):
            out_of_time = not _succeeded(best)
            break
        t = time.perf_counter()
        att = _attempt(prep, ref, given, opts, mesh_name, t0, lift_rows, relax_floor)
        shortest = min(shortest, time.perf_counter() - t)
        if best is None or _better(att, best, opts.use_abs):
            best = att
    prob, guard, run, m, X = best
    pl, d, used, min_angle, n_ncv, con, warp, verdict = m
    if run.relaxed_to < 1.0 and run.opt_its == 0:
        verdict.warnings.append(
            f"closeness: the panel-health guard held the planarization at closeness weight {opts.closeness_weight:g}; "
            + (f"planarity was restored at {run.relaxed_to * opts.closeness_weight:.3g} and not optimized back "
               f"(mean closeness {float(d[used].mean()) / prob.scale:.3g} × the mean edge): the optimize phase, "
               "which pulls the planar mesh back toward the surface, found no step or was not run "
               "(optimize_iterations 0, or the time budget spent)"
               if run.converged else
               f"relaxing it to {run.relaxed_to * opts.closeness_weight:.3g} did not reach the tolerance either"))
    if cut_by is not None and (out_of_time or run.stop_reason.startswith("time budget")):  # the deadline mattered
        verdict.warnings.append(f"time budget cut to {opts.time_budget:.3g} s by {cut_by}")
    converged = bool(run.converged and verdict.healthy)
    stop_reason = run.stop_reason if converged or not run.converged else f"{run.stop_reason}; panels not healthy"
    fixed_in = prob.fixed if prep.rep is None else prob.fixed[prep.rep]
    Vout = prep.restore(X)
    Vout[fixed_in] = V[fixed_in]  # exactly unmoved, to the last bit
    hist = run.hist
    return PlanarizeResult(
        mesh=(Vout, F), planarity=pl, max_planarity=float(pl.max()), mean_planarity=float(pl.mean()),
        max_closeness=float(d[used].max()), mean_closeness=float(d[used].mean()), iterations=run.it,
        converged=converged, stop_reason=stop_reason, worst_corner_angle=math.degrees(min_angle),
        nonconvex_faces=n_ncv, max_warping_height=float(warp.max()), max_conical=con,
        history_max_planarity=np.asarray(hist["maxp"]), history_mean_planarity=np.asarray(hist["meanp"]),
        history_max_closeness=np.asarray(hist["maxc"]), history_mean_closeness=np.asarray(hist["meanc"]),
        history_time=np.asarray(hist["t"]), healthy=verdict.healthy, coverage=verdict.coverage,
        violations=verdict.violations, warnings=prep.warnings + prob.warnings + verdict.warnings)


def _attempt(prep, ref, given, opts, mesh_name, t0, lift_rows: bool, relax_floor: float):
    """One run of the solver on the prepared mesh: ``(problem, guard, run, measures, X)``, backed off toward the
    input to the healthy state nearest the result when the result is not healthy (if there is one).

    ``ref``: the reference centred like ``prep`` (what the solver sees); ``given``: the reference as given (model
    units: the verdict's, see :func:`_measured`)."""
    prob = setup_problem(prep.V, prep.F, ref, opts, mesh_name)
    prob.lift_rows, prob.relax_floor = lift_rows, relax_floor
    run = iterate(prob, panel_guard(prob), t0)
    guard = run.guard  # its relative bounds may have been relaxed while the guard held the restore phase
    final = final_state(run)
    # a vertex the solver did not move is returned as given (not as its snapped copy, problem.SNAP), to the last
    # bit: an already planar mesh comes back as it came; the others at the solver's solution
    X = np.where(np.any(final.X != prob.X0, axis=1)[:, None], final.X * prob.scale + prob.center, prep.V)
    X[prob.fixed] = prep.V[prob.fixed]  # exactly unmoved
    m = _measured(prob, guard, run, X, ref, given, prep.offset)
    if not m.verdict.healthy:  # back off toward the input, to the healthy state nearest the result (if any)
        back = healthy_backoff(prob, guard, given, prep.V, X, prep.offset)
        if back is not None:
            X, t = back
            lost = "; ".join(line for line in m.verdict.violations if "planarity tolerance" not in line)
            run.converged = False
            run.stop_reason = (f"{backed_off_reason(run.stop_reason)}; backed off to the last healthy state "
                               f"({t:.0%} of the way from the input)")
            m = _measured(prob, guard, run, X, ref, given, prep.offset)
            m.verdict.warnings.append(
                f"the most planar state found was not healthy ({lost}); the healthy state {t:.0%} of the way from "
                f"the input to it was returned: max planarity {m.pl.max():.3g} = "
                f"{m.pl.max() / opts.tolerance if not opts.use_abs else m.warp.max() / opts.absolute_tolerance:.3g}"
                f" × the tolerance")
    return prob, guard, run, m, X


def _better(a, b, use_abs: bool) -> bool:
    """Whether attempt ``a`` (:func:`_attempt`) beats ``b``: converged and healthy first, then healthy, then the
    lower largest planarity (warping height with an absolute tolerance)."""
    def key(att):
        m = att[3]
        return (not _succeeded(att), not m.verdict.healthy, float(m.warp.max() if use_abs else m.pl.max()))
    return key(a) < key(b)


def _succeeded(att) -> bool:
    """Whether attempt ``att`` (:func:`_attempt`) reached the tolerance with healthy panels."""
    _, _, run, m, _ = att
    return bool(run.converged and m.verdict.healthy)


class _Measures(NamedTuple):
    pl: np.ndarray  # (m,) planarity
    d: np.ndarray  # (n,) distance to the reference (or displacement without one)
    used: np.ndarray  # vertices of faces
    min_angle: float  # radians
    n_ncv: int  # non-convex quad-like faces
    con: float  # largest conical criterion
    warp: np.ndarray  # (m,) warping height
    verdict: object  # components.planarize.verdict.Verdict


def _measured(prob, guard, run, X, ref, given, offset) -> _Measures:
    """What the result reports about ``X`` (model units, centred like ``ref``); its health is judged on
    ``X + offset`` (the returned positions) against ``given``, the reference as given."""
    Fw = prob.F
    # planarity and warping of the positions as returned (rounded at the placement: at +5e6 an ulp is 1e-9), taken
    # back about the centre exactly (a difference of numbers this close is exact)
    Xr = (X + offset) - offset
    pl = quad_planarity(Xr, Fw)
    if ref is not None:  # the solver's index of the reference (normalized units): no second build
        d = prob.ref_index.query((X - prob.center) / prob.scale).distances * prob.scale
    else:
        d = np.linalg.norm(X - prob.V, axis=1)
    ang, ncv_out = prob.frames.shape(X)
    n_ncv = int(ncv_out[guard.quad_like].sum())
    min_angle = float(ang.min()) if len(ang) else math.pi
    # the conical criterion ω1 − ω2 + ω3 − ω4 from the corner angles of the stars
    stars = prob.stars
    con = float(np.abs(ang[stars.corners] @ np.array([1.0, -1.0, 1.0, -1.0])).max()) if len(stars.center) else 0.0
    warp = warping_height(Xr, Fw)
    if run.converged and planarity_line(prob.opts, pl, warp):  # met in the solver's coordinates only
        val, tol = (warp.max(), prob.opts.absolute_tolerance) if prob.opts.use_abs else (pl.max(), prob.opts.tolerance)
        run.converged = False
        run.stop_reason = (f"the solver reached the tolerance but the returned mesh does not ({val:.4g} = "
                           f"{val / tol:.4g} × the tolerance): its fixed vertices are returned exactly as given and "
                           f"its coordinates in model units are rounded, which a tolerance this fine does not absorb "
                           f"(the solver's coordinates are on a grid of {SNAP:.2g} mean edges)")
    verdict = result_verdict(prob, guard, run, X, given, pl, warp, con, min_angle, n_ncv, offset)
    return _Measures(pl, d, np.unique(Fw), min_angle, n_ncv, con, warp, verdict)


def _triangles_only(V, F, prep, ref, opts, t0) -> PlanarizeResult:
    """The result for a mesh without quads or n-gons: every face is planar, the mesh comes back unchanged (with
    its health: triangles can still be slivers)."""
    X, Fw = prep.V, prep.F
    ang = corner_angles(X, Fw)
    E = edge_topology(Fw).E
    area = np.linalg.norm(face_normals(X, Fw, unit=False), axis=1)
    bounds = health_bounds(opts, ang, np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1), area)
    h = face_health(X, Fw, ref, tolerance=0.0, min_edge_ratio=bounds.min_edge_ratio, min_angle=bounds.min_angle,
                    min_area_ratio=bounds.min_area_ratio, min_coverage=opts.min_coverage)
    used = np.unique(Fw)
    if ref is not None:
        d = TriangleIndex(ref[0], triangulate(ref[1])[0], name="reference").query(X).distances[used]
    else:
        d = np.zeros(len(used))
    zero = np.zeros(len(F))
    min_angle = float(ang.min()) if len(ang) else math.pi
    warnings = prep.warnings + [f"planarize: {note}" for note in bounds.notes]
    if not h.healthy:
        warnings.append("panels not healthy: " + "; ".join(h.violations))
    t = time.perf_counter() - t0
    return PlanarizeResult(
        mesh=(np.array(V, dtype=np.float64), F), planarity=zero, max_planarity=0.0, mean_planarity=0.0,
        max_closeness=float(d.max()), mean_closeness=float(d.mean()), iterations=0, converged=bool(h.healthy),
        stop_reason="tolerance reached (triangles only: every face is planar)" + ("" if h.healthy else
                                                                                   "; panels not healthy"),
        worst_corner_angle=math.degrees(min_angle), nonconvex_faces=int(nonconvex_faces(X, Fw).sum()),
        max_warping_height=0.0, max_conical=0.0, history_max_planarity=np.zeros(1), history_mean_planarity=np.zeros(1),
        history_max_closeness=np.array([float(d.max())]), history_mean_closeness=np.array([float(d.mean())]),
        history_time=np.array([t]), healthy=bool(h.healthy),
        coverage=-1.0 if np.isnan(h.coverage) else float(h.coverage), violations=list(h.violations),
        warnings=warnings)


# ----------------------------------------------------------------------------------------------
# published components


def planarize(
    mesh: Mesh,
    reference: Mesh | None = None,
    closeness_weight: float = 1.0,
    start_weight: float = 0.0,
    fairness_weight: float = 0.01,
    fairness_mode: str = "polylines",
    edge_length_weight: float = 0.0,
    target_edge_length: float = 0.0,
    area_weight: float = 0.0,
    target_area: float = 0.0,
    conical_weight: float = 0.0,
    boundary: str = "free",
    anchors: Integers | None = None,
    anchor_points: Points | None = None,
    tolerance: float = 1e-4,
    max_iterations: int = 100,
    time_budget: float = 30.0,
    absolute_tolerance: float = 0.0,
) -> PlanarizeResult:
    """Make every face of a quad or polygon mesh planar while keeping it close, fair, anchored and healthy.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)`` to planarize; triangles are kept (they are planar); duplicate vertices
        are welded (within the document's absolute tolerance).
    reference : Mesh | None
        Surface mesh to stay close to; when absent, closeness is to the tangent planes of the input mesh.
    closeness_weight : float
        Weight of the pull toward the reference (point-to-tangent-plane); 0 turns it off.
    start_weight : float
        Weight of the pull toward the start positions (all directions).
    fairness_weight : float
        Weight of fairness (second differences along the mesh polylines, or Laplacian).
    fairness_mode : str
        ``"polylines"`` (second differences along the net's polylines) or ``"laplacian"``.
    edge_length_weight : float
        Weight of edge length equalization.
    target_edge_length : float
        Target edge length in model units; 0 means the current mean.
    area_weight : float
        Weight of face area equalization.
    target_area : float
        Target face area in model units squared; 0 means the current mean.
    conical_weight : float
        Weight of the conical angle criterion (ω1 + ω3 = ω2 + ω4 at interior valence-4 vertices); 0 turns it off,
        any positive value makes it a hard goal like planarity.
    boundary : str
        ``"free"``, ``"fixed"`` (boundary vertices do not move) or ``"slide"`` (they slide along the boundary
        polylines of the reference, or of the input; boundary corners stay fixed).
    anchors : Integers | None
        Indices of vertices that must not move.
    anchor_points : Points | None
        Points whose nearest vertices must not move.
    tolerance : float
        Scale-free planarity to reach: max over faces of diagonal distance / mean diagonal; applies when > 0.
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds.
    absolute_tolerance : float
        Warping height to reach in model units (filled from the document); applies only when tolerance is 0.

    Returns
    -------
    mesh : Mesh
        The planarized mesh (same faces); the best state seen, never worse than the input in planarity.
    planarity : Numbers
        Scale-free planarity of every face.
    max_planarity : float
        Largest face planarity.
    mean_planarity : float
        Mean face planarity.
    max_closeness : float
        Largest distance to the reference (model units), or largest displacement from the start without one.
    mean_closeness : float
        Mean distance to the reference (model units), or mean displacement from the start without one.
    iterations : int
        Iterations run.
    converged : bool
        Whether the tolerance (and the conical criterion, when on) was reached and the panels are healthy.
    stop_reason : str
        Why the solver stopped: tolerance, iteration cap, time budget, stall or panel-health guard.
    worst_corner_angle : float
        Smallest corner angle of the result, in degrees.
    nonconvex_faces : int
        Number of non-convex faces of the result.
    max_warping_height : float
        Largest warping height (distance between the diagonals) in model units.
    max_conical : float
        Largest conical angle criterion |ω1 − ω2 + ω3 − ω4| in radians (0 without interior valence-4 vertices).
    history_max_planarity : Numbers
        Max planarity after every iteration (first entry: the input).
    history_mean_planarity : Numbers
        Mean planarity after every iteration.
    history_max_closeness : Numbers
        Max closeness after every iteration (model units).
    history_mean_closeness : Numbers
        Mean closeness after every iteration (model units).
    history_time : Numbers
        Elapsed seconds after every iteration.
    healthy : bool
        Whether every panel is healthy: corners of at least 20° (or the input's worst), edges of at least 0.2 × the
        median edge, faces of at least 0.1 × the median area (or the input's smallest), convex, not folded, not
        crossing; with a reference also at least 85 % of it covered.
    coverage : float
        Share of the reference's area the result covers, 0..1; -1 without a reference.
    violations : Texts
        One line per failed check, with the count and the worst value against its bound (planarity first when the
        tolerance was not reached); empty when converged.

    Raises
    ------
    MeshError
        The mesh or the reference is malformed, non-manifold, degenerate or has NaN coordinates; a face has a
        zero-length edge; the mesh is in pieces that touch without being welded (the message says to weld).
    InputError
        A weight is negative or not finite, a mode is unknown, an anchor is out of range.

    Notes
    -----
    Guided projection after Tang, Sun, Gomes, Wallner & Pottmann, "Form-finding with polyhedral meshes made
    simple", ACM TOG 33(4), 2014: planarity (and the conical criterion of Liu, Pottmann, Wallner, Yang & Wang,
    "Geometric modeling with conical meshes and developable surfaces", 2006) are hard constraints, linearized and
    met by a minimum-norm correction in the metric of the soft goals (one sparse SPD solve in the face-sized
    system per iteration); once met, the solver walks along the planar meshes toward the smallest displacement
    and closest fit to the reference, then polishes back below the tolerance. Corners, edges and faces approaching
    a collapse (corners under 20° or half the input's worst, edges under 0.2 × the median or half their length,
    faces under 0.1 × the median area) become hard rows, and steps that would still make unhealthy, folded or
    crossing panels are shortened; ``converged`` is only true for a healthy result. With ``boundary="slide"``,
    boundary corners (sharp at two scales) stay fixed and the lone corners of faces lying wholly on the boundary
    are set free (a warning says so). Which tolerance applies: ``tolerance > 0`` → scale-free planarity;
    ``tolerance == 0`` and ``absolute_tolerance > 0`` → warping height in model units; both 0 → 1e-4 scale-free.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(4, 4)
    >>> V[:, 2] = 0.2 * V[:, 0] * V[:, 1]
    >>> res = planarize((V, F))
    >>> res.converged, res.max_planarity <= 1e-4
    (True, True)
    """
    t0 = time.perf_counter()
    V, F = check_mesh(mesh, "mesh", allow_degenerate=True, manifold=False)  # fully checked in _solved
    opts = checked_options(
        len(V), closeness_weight=closeness_weight, start_weight=start_weight, fairness_weight=fairness_weight,
        fairness_mode=fairness_mode, edge_length_weight=edge_length_weight, target_edge_length=target_edge_length,
        area_weight=area_weight, target_area=target_area, conical_weight=conical_weight, boundary=boundary,
        anchors=anchors, anchor_points=anchor_points, tolerance=tolerance, absolute_tolerance=absolute_tolerance,
        max_iterations=max_iterations, time_budget=time_budget)
    return _solved(V, F, reference, "reference", opts, "mesh", t0)


def on_surface(
    mesh: Mesh,
    surface: Mesh,
    closeness_weight: float = 1.0,
    fairness_weight: float = 0.01,
    boundary: str = "slide",
    anchors: Integers | None = None,
    tolerance: float = 1e-4,
    max_iterations: int = 100,
    time_budget: float = 30.0,
    absolute_tolerance: float = 0.0,
) -> PlanarizeResult:
    """Planarize a quad mesh while keeping it on a design surface and its boundary on the surface's boundary.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)`` to planarize.
    surface : Mesh
        The design surface as a mesh; vertices are pulled to their closest points on it.
    closeness_weight : float
        Weight of the pull toward the surface.
    fairness_weight : float
        Weight of fairness (second differences along the mesh polylines).
    boundary : str
        ``"slide"`` (boundary vertices slide along the surface's boundary; corners fixed), ``"fixed"`` or ``"free"``.
    anchors : Integers | None
        Indices of vertices that must not move.
    tolerance : float
        Scale-free planarity to reach; applies when > 0.
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds.
    absolute_tolerance : float
        Warping height to reach in model units (filled from the document); applies only when tolerance is 0.

    Returns
    -------
    mesh : Mesh
        The planarized mesh (same faces).
    planarity : Numbers
        Scale-free planarity of every face.
    max_planarity : float
        Largest face planarity.
    mean_planarity : float
        Mean face planarity.
    max_closeness : float
        Largest distance to the surface (model units).
    mean_closeness : float
        Mean distance to the surface (model units).
    iterations : int
        Iterations run.
    converged : bool
        Whether the tolerance was reached and the panels are healthy.
    stop_reason : str
        Why the solver stopped.
    worst_corner_angle : float
        Smallest corner angle of the result, in degrees.
    nonconvex_faces : int
        Number of non-convex faces of the result.
    max_warping_height : float
        Largest warping height in model units.
    max_conical : float
        Largest conical angle criterion in radians.
    history_max_planarity : Numbers
        Max planarity after every iteration.
    history_mean_planarity : Numbers
        Mean planarity after every iteration.
    history_max_closeness : Numbers
        Max distance to the surface after every iteration.
    history_mean_closeness : Numbers
        Mean distance to the surface after every iteration.
    history_time : Numbers
        Elapsed seconds after every iteration.
    healthy : bool
        Whether every panel is healthy (see :func:`planarize`) and at least 85 % of the surface is covered.
    coverage : float
        Share of the surface's area the result covers, 0..1.
    violations : Texts
        One line per failed check, with the count and the worst value against its bound; empty when converged.

    Raises
    ------
    MeshError
        The mesh or the surface is malformed; a face has a zero-length edge; unwelded touching pieces.
    InputError
        A weight is negative, a mode is unknown or an anchor is out of range.

    Notes
    -----
    :func:`planarize` with ``reference=surface`` (see there; Tang et al. 2014).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(4, 4)
    >>> V[:, 2] = 0.2 * V[:, 0] * V[:, 1]
    >>> res = on_surface((V, F), (V.copy(), F), boundary="free")
    >>> res.max_planarity <= 1e-4
    True
    """
    t0 = time.perf_counter()
    V, F = check_mesh(mesh, "mesh", allow_degenerate=True, manifold=False)  # fully checked in _solved
    opts = checked_options(
        len(V), closeness_weight=closeness_weight, fairness_weight=fairness_weight, boundary=boundary,
        anchors=anchors, tolerance=tolerance, absolute_tolerance=absolute_tolerance, max_iterations=max_iterations,
        time_budget=time_budget)
    surface = check_mesh(surface, "surface", allow_degenerate=True, manifold=False)  # required: no None
    return _solved(V, F, surface, "surface", opts, "mesh", t0)
