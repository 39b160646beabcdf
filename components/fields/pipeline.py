"""The conjugate-field strategy end to end: surface mesh + panel size → candidate planar-quad mesh, planarized.

:func:`pq_from_conjugate_field` chains the field steps of the project: the candidate quad mesh
(:func:`components.fields.candidate.candidate_mesh`: a direction field on the surface, smooth then conjugate, a
seamless integer-grid parametrization following it and the quad mesh of its integer iso-lines), the quality of the
candidate before optimization, and optionally the planarization solver (:mod:`components.planarize.planarizer`)
with the input surface as the closeness reference.

Quads laid along a conjugate direction field are planar to first order (Liu et al. 2011), so the candidate starts
close to planar and the planarization only needs small moves.

References
----------
Y. Liu, W. Xu, J. Wang, L. Zhu, B. Guo, F. Chen, G. Wang, "General planar quadrilateral mesh design using conjugate
direction field", ACM Trans. Graph. (SIGGRAPH Asia) 30(6), 2011.
D. Bommes, H. Zimmer, L. Kobbelt, "Mixed-integer quadrangulation", ACM Trans. Graph. (SIGGRAPH) 28(3), 2009.
"""
from __future__ import annotations

import logging
import time
from typing import NamedTuple

import numpy as np

from components.core.blas import single_blas_thread
from components.core.checks import boundary_gap_warning, check_mesh, check_number
from components.core import deadline, progress
from components.core.errors import InputError, MeshError
from components.core.mesh import triangulate
from components.core.frame import IDENTITY, bounding_frame
from components.core.types import Integers, Mesh, Texts, Vectors
from components.fields.candidate import candidate_quality, checked_inputs, framed_candidate
from components.metrics.health import face_health, shape_healthy
from components.planarize.planarizer import RUNS, planarize_runs

log = logging.getLogger(__name__)

__all__ = ["PQResult", "pq_from_conjugate_field"]


class PQResult(NamedTuple):
    candidate: Mesh
    candidate_max_planarity: float
    candidate_mean_planarity: float
    planarized: Mesh
    planarized_max_planarity: float
    planarized_mean_planarity: float
    mean_closeness: float
    max_closeness: float
    quad_ratio: float
    edge_length_within: float
    singularities: int
    mean_angle_error: float
    time_field: float
    time_parametrize: float
    time_extract: float
    time_planarize: float
    healthy: bool
    coverage: float
    violations: Texts
    warnings: list[str]


def pq_from_conjugate_field(mesh: Mesh, target_length: float, alignment: float = 0.1, planarize: bool = True,
                            field: str = "conjugate", boundary: str = "auto",
                            constraint_faces: Integers | None = None, constraint_directions: Vectors | None = None,
                            tolerance: float = 1e-4, time_budget: float = 30.0,
                            closeness_weight: float = 10.0) -> PQResult:
    """Planar-quad panelling of a free-form surface along a conjugate direction field.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``: an open, oriented, manifold mesh (a disk or a disk with holes).
    target_length : float
        Panel size (edge length) in model units.
    alignment : float
        Weight of the field's pull towards the principal curvature directions (smaller = smoother field, fewer
        singularities).
    planarize : bool
        Run the planarization solver on the candidate (with the input surface as the closeness reference).
    field : str
        ``"conjugate"`` (default), ``"smooth"`` (not conjugate, for comparison) or ``"principal"``.
    boundary : str
        ``"auto"`` (default: the best of ``"snap"`` and ``"mixed"`` at three grid densities, by quad share, the
        share of edges within ±30% of the target, then the mean edge nearest the target), ``"snap"`` (panel lines
        follow the field, grid vertices near the boundary are moved onto it so the boundary row is whole panels),
        ``"mixed"`` (boundary stretches along a panel direction follow a panel line, the rest snapped),
        ``"aligned"`` (every boundary stretch follows a panel line; distorts panels where the boundary is oblique
        to the field) or ``"free"`` (panel lines end on the boundary: clipped cells).
    constraint_faces : Integers | None
        Optional faces (of the triangulated input) whose field direction is prescribed.
    constraint_directions : Vectors | None
        The prescribed directions, one per constraint face.
    tolerance : float
        Planarity (scale-free) the planarization must reach.
    time_budget : float
        Seconds the planarization may take (shared with the next candidates' when the first one falls short).
    closeness_weight : float
        The planarization's pull toward the input surface. Where the candidate's net is not conjugate (released
        faces, field smoothing) the planarization must slide vertices along the surface; a higher weight keeps
        the panels closer to the surface, a lower one keeps their sizes more even. Measured on the wave sample at
        1,000 panels (20k triangles): weight 3 → mean closeness 2.8% of the mean edge, 10 → 1.5%, 30 → 0.6%.

    Returns
    -------
    candidate : Mesh
        The quad-dominant candidate before optimization; its vertices lie on the input surface.
    candidate_max_planarity : float
        Largest scale-free planarity (diagonal distance / mean diagonal) of the candidate's quads.
    candidate_mean_planarity : float
        Mean scale-free planarity of the candidate's quads.
    planarized : Mesh
        The planarized mesh (the candidate itself when ``planarize`` is off).
    planarized_max_planarity : float
        Largest planarity after planarization.
    planarized_mean_planarity : float
        Mean planarity after planarization.
    mean_closeness : float
        Mean distance (model units) of the planarized vertices from the input surface.
    max_closeness : float
        Largest such distance.
    quad_ratio : float
        Share of quads among the candidate's faces.
    edge_length_within : float
        Share of candidate edges within ±30% of the target length.
    singularities : int
        Interior vertices of the candidate whose valence is not 4.
    mean_angle_error : float
        Area-weighted mean angle (degrees) between the parametrization's iso-lines and the field.
    time_field : float
        Seconds spent on the direction field.
    time_parametrize : float
        Seconds spent on the parametrization.
    time_extract : float
        Seconds spent on the quad extraction.
    time_planarize : float
        Seconds spent on the planarization.
    healthy : bool
        Whether the planarized panels (the candidate's when ``planarize`` is off) are fabricable: every corner
        between 20° and 160°, every edge over 0.2 × the median edge, every panel over 0.1 × the median panel area,
        convex, not folded, flipped or crossing, at least 85% of the input surface covered. Planarity is the
        tolerance's, not health's: a healthy result that misses the tolerance says how far in ``violations`` and
        the warnings (as ``planarize`` does).
    coverage : float
        Share of the input surface's area the panels cover, 0..1.
    violations : Texts
        One line per failed check (:func:`components.metrics.health.face_health`), with the count and the worst
        value against its bound; empty when healthy.

    Raises
    ------
    MeshError
        Malformed, non-manifold, degenerate or closed mesh, or one with handles.
    InputError
        Non-positive target length, unknown field or boundary mode, constraints on missing faces.

    Notes
    -----
    Conjugate direction fields for PQ meshes: Liu et al. 2011; parametrization: Bommes, Zimmer & Kobbelt 2009;
    planarization: Tang et al. 2014 (see :mod:`components.planarize.planarizer`). Before the planarization the
    candidate's unhealthy panels are repaired (:func:`components.fields.repair.repaired_candidate`). When the
    best-ranked candidate does not planarize into healthy panels within the tolerance, the next healthy candidates
    of the ranking (:attr:`components.fields.candidate.Candidate.alternative`) are planarized in turn in the time
    left, and the best result is returned with a warning (the shared meshes at 60 panels: 29 → 31 of 42 converged;
    ``benchmarks/convergence.py --real 60``). Each candidate gets the planarizer's first run before any gets its
    other runs (:data:`components.planarize.planarizer.RUNS`): the shared meshes at 60 and 300 panels and
    inspired_mesh at 1600, 73 → 76 of 85 converged, in 170 s instead of 213. Success is
    claimed only for a result that reaches the tolerance and is healthy; anything else comes with a warning that
    names the counts.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    >>> res = pq_from_conjugate_field((V, F), target_length=2.0)
    >>> res.candidate_max_planarity > res.planarized_max_planarity, res.planarized_max_planarity <= 1e-4
    (True, True)
    >>> res.healthy, res.coverage > 0.85, res.violations
    (True, True, [])
    """
    tol = check_number(tolerance, "tolerance", 0)
    budget = check_number(time_budget, "time_budget", 0)
    closeness_weight = check_number(closeness_weight, "closeness_weight", 0)
    V, T, target, alignment, cons = checked_inputs(mesh, target_length, field, alignment, boundary, constraint_faces,
                                                   constraint_directions)
    # everything runs centred, at unit size, on snapped coordinates (components.core.frame): the same surface in mm
    # and in m gives the same candidate and the same planarization, bit for bit up to the scale
    frame = bounding_frame(V)
    surface, hn = (frame.to(V), T), frame.length(target)
    progress.report(0.0, "candidate mesh", until=0.5)
    cand = framed_candidate(*surface, hn, IDENTITY, field, alignment, boundary, cons, repair=True)
    if len(cand.F) == 0:
        raise InputError("target_length", f"{target:g} is too large: no panel fits on the surface")
    t = time.perf_counter()
    progress.report(0.5, "planarize", until=0.95)  # (reported here: the owner's frame names the stages)
    cands, outs = _planarized_in_turn(cand, surface, hn, tol, budget, closeness_weight, planarize, t)
    progress.report(0.95, "panel health")
    k = max(range(len(outs)), key=lambda i: outs[i].rank)  # the best outcome (the better-ranked candidate of a tie)
    cand, out = cands[k], outs[k]
    if k:
        short = "did not planarize into healthy panels" if not outs[0].healthy else "did not reach the tolerance"
        out.warnings.insert(0, f"the best-ranked candidate ({len(cands[0].F)} panels) {short} ({outs[0].why}); "
                               f"healthy candidate {k + 1} of the ranking ({len(cand.F)} panels) did better and is "
                               "returned")
    tp = time.perf_counter() - t
    q, health, healthy, warnings = out.quality, out.health, out.healthy, out.warnings
    (Vp, Fp), pmax, pmean, cmean, cmax = out.planarized
    if not healthy and any(health.counts[d] for d in ("intersecting", "folded", "flipped")):
        warnings += _surface_crossings(mesh)
    gap = boundary_gap_warning(V, T, target)  # the input's triangles: its boundary, in model units
    if gap:
        warnings.insert(0, gap)
    return PQResult((frame.back(cand.V), cand.F), q.max_planarity, q.mean_planarity, (frame.back(Vp), Fp), pmax, pmean,
                    cmean * frame.scale, cmax * frame.scale,
                    q.quad_ratio, q.edge_length_within, cand.singularities, cand.mean_angle_error,
                    cand.timings["field"], cand.timings["parametrize"], cand.timings["extract"], tp, bool(healthy),
                    float(health.coverage), list(health.violations), warnings)


def _planarized_in_turn(first, surface, hn: float, tol: float, budget: float, closeness_weight: float,
                        planarize: bool, t0: float) -> tuple[list, list]:
    """The candidates planarized and judged (:func:`_judged`) until one is ok, and the best outcome of each.

    The first solver run (components.planarize.planarizer.RUNS) of the best-ranked candidate, then of the next
    healthy candidates of the ranking in turn; while none is ok, the other runs of each, in the same order. The
    first run is the one that converges on most candidates; where it does not, another candidate converges about as
    often as another run of the same one, and costs one run where the other runs cost five (libigl's inspired_mesh
    at 1600 panels: the best-ranked candidate stalled near 1e-3 through all six runs, 19.5 s, before the second
    converged at its first). Everything within ``budget`` seconds from ``t0``; the best-ranked candidate's first
    run gets the whole budget."""
    cands, outs = [], []

    def judge(i: int, runs: tuple):
        c = cands[i]
        warnings = list(c.warnings)
        left = budget - (time.perf_counter() - t0) if outs else budget  # (no outcome yet: the first call)
        planarized = (_planarized(c.V, c.F, surface, tol, left, closeness_weight, warnings, runs=runs)
                      if planarize else None)
        got = _judged(c, hn, surface, planarized, planarize, tol, warnings)
        if i == len(outs):
            outs.append(got)
        elif got.rank > outs[i].rank:
            outs[i] = got

    def more() -> bool:  # time for another planarization
        return planarize and not deadline.expired() and time.perf_counter() - t0 < budget

    nxt = first
    while nxt is not None and (nxt is first or more()):  # building the next candidate may use up the budget
        cands.append(nxt)
        judge(len(cands) - 1, RUNS[:1])
        nxt = nxt.alternative() if more() and not outs[-1].ok and nxt.alternative is not None else None
    for i in range(len(cands)):  # none was ok: the other runs
        if not more() or any(o.ok for o in outs):
            break
        judge(i, RUNS[1:])
    return cands, outs


class _Outcome(NamedTuple):
    """A candidate planarized (or not) and judged."""

    quality: object  # candidate_quality of the candidate
    planarized: tuple  # ((V, F), max planarity, mean planarity, mean closeness, max closeness)
    health: object
    healthy: bool
    warnings: list
    ok: bool  # healthy and within the tolerance
    rank: tuple  # better outcomes rank higher
    why: str  # what stopped it short (for the warning of a fallback)


def _judged(cand, target: float, surface, planarized, planarize: bool, tol: float, warnings: list) -> _Outcome:
    """The candidate and its planarization (``None``: not asked for, or the solver failed) judged."""
    V, F = cand.V, cand.F
    q = candidate_quality(V, F, target)
    solved = planarized is not None
    # not asked for, or the solver failed: the candidate itself
    planarized = planarized or ((V, F), q.max_planarity, q.mean_planarity, 0.0, 0.0)
    (Vp, Fp), pmax = planarized[0], planarized[1]
    if q.quad_ratio < 0.95:
        warnings.append(f"only {100 * q.quad_ratio:.1f}% of the candidate's faces are quads")
    health = face_health(Vp, Fp, surface, tolerance=tol if planarize else 1e300, name="planarized")
    healthy = shape_healthy(health)
    warnings += _health_warnings(health, healthy, cand, solved)
    ok = bool(healthy and pmax <= tol)
    why = (f"max planarity {pmax:.2e}" if healthy else
           f"{int(np.count_nonzero(health.face_defects))} unhealthy panels, coverage {health.coverage:.0%}")
    return _Outcome(q, planarized, health, bool(healthy), warnings, ok, (ok, bool(healthy), -pmax), why)


def _health_warnings(health, healthy: bool, cand, planarized: bool) -> list:
    """The warnings that say why a result is not fabricable (the candidate's health first when it was not)."""
    out = []
    if cand.health is not None and not cand.health.healthy:
        out.append(f"the candidate has panels that could not be repaired ({len(cand.health.violations)} "
                   f"violation(s)): " + "; ".join(cand.health.violations))
    if not healthy:
        what = "planarized panels" if planarized else "candidate's panels (not planarized)"
        bad = int(np.count_nonzero(health.face_defects))
        out.append(f"the {what} are not healthy: {bad} of {len(health.face_defects)} panels with defects, "
                   f"coverage {health.coverage:.0%}: " + "; ".join(health.violations))
    return out


def _surface_crossings(mesh) -> list[str]:
    """The warning that the design surface crosses itself (so every panelling of it folds), or none: checked only
    when the panels fold or cross, to say why."""
    V, F = check_mesh(mesh)
    T, J = triangulate(F)
    own = face_health(V, T, tolerance=1e300, min_edge_ratio=0.0, min_angle=0.0, min_area_ratio=0.0).intersecting_pairs
    pairs = np.unique(np.sort(J[own], axis=1), axis=0) if len(own) else own
    pairs = pairs[pairs[:, 0] != pairs[:, 1]] if len(pairs) else pairs
    if not len(pairs):
        return []
    a, b = pairs[0].tolist()
    return [f"the design surface crosses itself ({len(pairs)} pair{'s' if len(pairs) != 1 else ''} of crossing faces, "
            f"e.g. faces {a} and {b} of the mesh): panels that follow it cross there too; repair the surface first"]


@single_blas_thread()  # sparse factorizations: see components.core.blas
def _planarized(V: np.ndarray, F: np.ndarray, reference: tuple, tol: float, budget: float, closeness_weight: float,
                warnings: list, runs: tuple = RUNS):
    """Planarize the candidate against the input surface ``reference`` with the solver runs ``runs``: ``((V, F), max
    planarity, mean planarity, mean closeness, max closeness)``, or ``None`` when the solver fails. Adds the solver's
    warnings."""
    try:
        res = planarize_runs(runs, V, F, reference=reference, tolerance=tol, time_budget=budget, boundary="slide",
                             closeness_weight=closeness_weight, mesh_name="candidate")
    except (RuntimeError, np.linalg.LinAlgError) as exc:  # a solver failure must not lose the candidate
        log.warning("planarization failed on the candidate: %s", exc)
        warnings.append(f"planarization failed ({exc}); the candidate is returned unplanarized")
        return None
    except MeshError as exc:  # the solver refused our own candidate (a defect the repair left): not the user's input
        log.warning("the planarizer refused the candidate: %s", exc)
        warnings.append(f"the planarizer refused the candidate ({exc.detail}); it is returned unplanarized")
        return None
    warnings += list(res.warnings)
    if res.max_planarity > tol:  # health (the planarizer's converged includes it) is worded by the caller
        warnings.append(f"planarization stopped before reaching {tol:g}: {res.stop_reason}")
    return (res.mesh, float(res.max_planarity), float(res.mean_planarity), float(res.mean_closeness),
            float(res.max_closeness))
