"""The planar-quad (PQ) meshing strategies of the paper, as a registry of runners with one uniform result.

Every runner takes a design surface as a triangle mesh ``(V, T)`` and a target panel size (edge length, model
units) and returns a *candidate* quad mesh (what the strategy builds before any optimization) and, where the
strategy has an optimization step, the *optimized* mesh. :func:`run_strategy` wraps a runner with timings, the
full metric table of :func:`components.metrics.quality.metrics_report` before and after (closeness measured against the
design surface), the caveats, and an independent verdict: :func:`components.metrics.health.face_health` of the
candidate and of the final mesh against the design surface, with the planarity tolerance the strategy targets
(:attr:`Strategy.tolerance`). The harness never trusts a strategy's own claim of health; the same bounds judge every
strategy. :func:`run_strategies` runs a list of them.

=====================  ==========================================================================================
strategy               steps
=====================  ==========================================================================================
``translation``        exact PQ: a translation surface ``g(u) + h(v)`` fitted to the design surface (see
                       :func:`components.surfaces.translation_fit.translation_candidate`); planar by
                       construction, no optimization.
``conjugate_field``    conjugate direction field → quad extraction → planarization
                       (``components.fields.pipeline.pq_from_conjugate_field``).
``curvature_network``  curvature-line network → conformal map → quad rebuild → conical optimization
                       (``components.network.pipeline.pq_from_curvature_network``).
``subdivision``        automatic coarse quad net → Catmull-Clark → pull onto the surface → planarization
                       (``components.subdivision.pipeline.subdivision_pq``).
=====================  ==========================================================================================

Status (a small fixed set, :data:`STATUSES`; the words are in ``detail``)
-------------------------------------------------------------------------
======================  ========================================================================================
``"ok"``                the final mesh is healthy (no defect but planarity, coverage reached) and every panel is
                        within the planarity tolerance
``"unhealthy"``         the final mesh has a defect other than planarity (collapsed edges, sharp corners, folds,
                        small panels, crossings …) or covers too little of the design surface; ``detail`` names it
``"tolerance missed"``  healthy, but some panels are above the planarity tolerance; ``detail`` says how far
``"failed"``            the strategy raised (``detail``: the error), or its result cannot be measured
======================  ========================================================================================

References
----------
Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang, "Geometric modeling with conical meshes and developable
surfaces", ACM Trans. Graph. 25(3), 2006 (subdivision + planarization, conical meshes).
J. Glymph, D. Shelden, C. Ceccato, J. Mussel, H. Schober, "A parametric strategy for free-form glass structures
using quadrilateral planar facets", Automation in Construction 13(2), 2004 (translation surfaces).
A. Vaxman et al., "Directional field synthesis, design, and processing", 2016; Liu, Xu, Wang, Wang, "Conjugate
direction fields for remeshing", 2011 (conjugate fields).
"""
from __future__ import annotations

import logging
import time
from typing import Callable, NamedTuple

import numpy as np

from components.core.checks import check_choice, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, triangulate
from components.fields.pipeline import pq_from_conjugate_field
from components.metrics.health import PanelHealth, face_health, shape_healthy
from components.metrics.quality import metrics_report
from components.network.pipeline import pq_from_curvature_network
from components.subdivision.pipeline import subdivision_pq
from components.surfaces.translation_fit import translation_candidate

log = logging.getLogger(__name__)

__all__ = [
    "STRATEGIES",
    "Strategy",
    "StrategyResult",
    "Candidate",
    "strategy_names",
    "get_strategy",
    "run_strategy",
    "run_strategies",
    "default_panel_size",
    "STATUSES",
    "HEALTH_BOUNDS",
    "DEFAULT_TOLERANCE",
    "judge",
    "panel_verdict",
    "shape_healthy",
    "Verdict",
]

STATUS_OK = "ok"
STATUS_UNHEALTHY = "unhealthy"
STATUS_TOLERANCE = "tolerance missed"
STATUS_FAILED = "failed"
#: every status a :class:`StrategyResult` can have
STATUSES = (STATUS_OK, STATUS_UNHEALTHY, STATUS_TOLERANCE, STATUS_FAILED)

#: scale-free planarity every registered strategy targets (the planarizer's, the conical optimizer's and the
#: pipelines' default ``tolerance``; the translation surface is exact)
DEFAULT_TOLERANCE = 1e-4
#: the panel-health bounds of the verdict (:func:`components.metrics.health.face_health`'s defaults, spelled out)
HEALTH_BOUNDS = {"min_edge_ratio": 0.2, "min_angle": 20.0, "min_area_ratio": 0.1, "min_coverage": 0.85}


class StrategyResult(NamedTuple):
    """One strategy run on one design surface.

    Attributes
    ----------
    name : str
        Strategy key (e.g. ``"translation"``).
    surface : str
        Name of the design surface.
    status : str
        One of :data:`STATUSES`: ``"ok"``, ``"unhealthy"``, ``"tolerance missed"`` or ``"failed"``.
    candidate : (V, F) tuple or None
        The quad mesh the strategy builds before optimization.
    optimized : (V, F) tuple or None
        The optimized mesh (same faces as the candidate), or None when the strategy has no optimization step.
    timings : dict of str -> float
        Wall-clock seconds per step, plus ``"total"`` (the strategy's run) and ``"health"`` (the verdict, after it).
    metrics_before, metrics_after : dict of str -> float, or None
        :func:`components.metrics.quality.metrics_report` of the candidate / the optimized mesh, closeness against the
        design surface.
    warnings : list of str
        Non-fatal caveats of the steps.
    detail : str
        Why the status is not ``"ok"`` (the defect, the missed tolerance, the error); for ``"ok"`` the one-line
        description of what ran.
    panel_size : float
        The requested panel size (model units).
    description : str
        The one-line description of what ran ("" when the strategy raised).
    tolerance : float
        The planarity tolerance the result is judged by (scale-free).
    healthy : bool or None
        The final mesh has no defect but planarity and covers enough of the design surface (None: not measured).
    coverage : float
        Covered share of the design surface by the final mesh, 0..1 (NaN: not measured).
    violations : list of str
        :attr:`PanelHealth.violations` of the final mesh (planarity included).
    health, candidate_health : PanelHealth or None
        The full verdict of the final mesh and of the candidate (worst corner, shortest edge ratio, holes …).
    """

    name: str
    surface: str
    status: str
    candidate: tuple | None
    optimized: tuple | None
    timings: dict
    metrics_before: dict | None
    metrics_after: dict | None
    warnings: list
    detail: str
    panel_size: float
    description: str = ""
    tolerance: float = DEFAULT_TOLERANCE
    healthy: bool | None = None
    coverage: float = float("nan")
    violations: tuple | list = ()
    health: PanelHealth | None = None
    candidate_health: PanelHealth | None = None

    @property
    def final(self) -> tuple | None:
        """The optimized mesh when there is one, else the candidate."""
        return self.optimized if self.optimized is not None else self.candidate

    @property
    def candidate_healthy(self) -> bool | None:
        """The candidate's verdict: no defect but planarity, coverage reached (None: not measured)."""
        return None if self.candidate_health is None else shape_healthy(self.candidate_health)


class Candidate(NamedTuple):
    """What a runner returns: candidate and optimized meshes, step timings, warnings, a one-line description."""

    candidate: tuple
    optimized: tuple | None
    timings: dict
    warnings: list
    detail: str


class Strategy(NamedTuple):
    """A registered strategy: key, title, what it does, its runner and the planarity tolerance it targets.

    ``runner(V, T, panel_size, time_budget=...) -> Candidate``.
    """

    name: str
    title: str
    description: str
    runner: Callable
    tolerance: float = DEFAULT_TOLERANCE


class Verdict(NamedTuple):
    """The status of a measured result and the text that goes with it (see :func:`judge`)."""

    status: str  # "ok", "unhealthy" or "tolerance missed"
    healthy: bool  # no defect but planarity, coverage reached
    detail: str  # the defect ("" for "ok")


# ----------------------------------------------------------------------------------------------
# shared helpers


def default_panel_size(V, divisions: int = 16) -> float:
    """A panel size giving about ``divisions`` panels across the larger plan extent of a surface.

    Examples
    --------
    >>> default_panel_size(np.array([[0.0, 0, 0], [32, 8, 1]]), 16)
    2.0
    """
    V = np.asarray(V, dtype=np.float64)
    ext = np.sort(V.max(axis=0) - V.min(axis=0))
    return float(ext[-1] / max(int(divisions), 1))


# ----------------------------------------------------------------------------------------------
# strategy 1: translation surface fitted to the design surface (components.surfaces.translation_fit)


def _run_translation(V, T, panel_size, time_budget=30.0):
    t0 = time.perf_counter()
    Vt, Qt, info = translation_candidate(V, T, panel_size)
    t1 = time.perf_counter()
    detail = (f"translation surface g(u)+h(v) fitted at {info['angle']:.0f}° to the plan's major axis "
              f"(height RMS {info['rms']:.3g}); exact PQ, no optimization")
    return Candidate((Vt, Qt), None, {"candidate": t1 - t0}, list(info["warnings"]), detail)


# ----------------------------------------------------------------------------------------------
# strategy 4: coarse net -> Catmull-Clark -> pull -> planarize


def _subdivision_faces(V, T, panel_size: float, levels: int = 2) -> int:
    """Coarse face count so that after ``levels`` Catmull-Clark steps boundary panels are about ``panel_size``."""
    loop = boundary_loops(T)[0]
    perimeter = float(np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1).sum())
    coarse_edge = panel_size * 2 ** levels
    return int(np.clip(round((perimeter / 4 / coarse_edge) ** 2 * 1.5), 12, 400))


def _run_subdivision(V, T, panel_size, time_budget=30.0):
    faces = _subdivision_faces(V, T, panel_size)
    res = subdivision_pq(V, T, faces=faces, levels=2, time_budget=float(time_budget))
    opt = res.planarized
    detail = (f"automatic coarse net ({len(res.coarse[1])} faces), 2 Catmull-Clark levels, pulled onto the surface; "
              f"planarized: max planarity {opt.max_planarity:.2g} after {opt.iterations} iterations "
              f"({opt.stop_reason}), worst corner {opt.worst_corner_angle:.0f}°")
    return Candidate(tuple(res.candidate[:2]), tuple(opt.mesh[:2]), dict(res.timings), list(res.warnings), detail)


def _run_conjugate(V, T, panel_size, time_budget=30.0):
    res = pq_from_conjugate_field((V, T), target_length=float(panel_size), time_budget=float(time_budget))
    timings = {"field": res.time_field, "parametrize": res.time_parametrize, "extract": res.time_extract,
               "planarize": res.time_planarize}
    detail = (f"conjugate field ({res.singularities} singular vertices, iso-lines {res.mean_angle_error:.1f}° from "
              f"the field on average), {100 * res.quad_ratio:.0f}% quads, "
              f"{100 * res.edge_length_within:.0f}% of edges within ±30% of the panel size; planarized max "
              f"planarity {res.planarized_max_planarity:.2g}")
    return Candidate(tuple(res.candidate[:2]), tuple(res.planarized[:2]), timings, list(res.warnings), detail)


def _run_network(V, T, panel_size, time_budget=30.0):
    t = time.perf_counter()
    res = pq_from_curvature_network((V, T), panel_size=float(panel_size), optimize=True,
                                    time_budget=float(time_budget))
    timings = {"pipeline": time.perf_counter() - t}
    detail = (f"principal curvature network ({100 * res.quad_fraction:.0f}% quads, edges {res.mean_angle_error:.1f}° "
              f"from the principal directions); conical optimization: max planarity {res.max_planarity:.2g}, "
              f"max conical criterion {res.max_criterion:.2g} rad")
    return Candidate(tuple(res.candidate[:2]), tuple(res.optimized[:2]), timings, list(res.warnings), detail)


# ----------------------------------------------------------------------------------------------
# the registry


STRATEGIES: tuple[Strategy, ...] = (
    Strategy("translation", "Translation surface",
             "exact PQ: a translation surface fitted to the design surface (no optimization)",
             _run_translation),
    Strategy("conjugate_field", "Conjugate field",
             "conjugate direction field → quad extraction → planarization",
             _run_conjugate),
    Strategy("curvature_network", "Curvature network",
             "curvature-line network → conformal map → quad rebuild → conical optimization",
             _run_network),
    Strategy("subdivision", "Subdivision",
             "automatic coarse quad net → Catmull-Clark → pull onto the surface → planarization",
             _run_subdivision),
)


def strategy_names() -> tuple[str, ...]:
    """Keys of the registered strategies, in the paper's order."""
    return tuple(s.name for s in STRATEGIES)


def get_strategy(name: str) -> Strategy:
    """The registered strategy ``name``.

    Raises
    ------
    InputError
        Unknown name: ``"strategy: must be one of 'translation', …, got …"``.

    Examples
    --------
    >>> get_strategy("subdivision").title
    'Subdivision'
    """
    name = check_choice(name, "strategy", strategy_names())
    return next(s for s in STRATEGIES if s.name == name)


def _metrics(mesh, reference, name):
    return metrics_report(mesh[0], mesh[1], reference=reference, name=name)


def panel_verdict(mesh, reference, tolerance: float, name: str) -> PanelHealth:
    """:func:`components.metrics.health.face_health` of ``mesh`` against the design surface ``reference``, with the
    strategy's planarity ``tolerance`` and :data:`HEALTH_BOUNDS`."""
    return face_health(mesh[0], mesh[1], reference, tolerance=tolerance, **HEALTH_BOUNDS, name=name)


def judge(h: PanelHealth, tolerance: float) -> Verdict:
    """The status of a result from its panel health: ``"ok"`` only when healthy and within the tolerance.

    Examples
    --------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4)
    >>> h = panel_verdict((V, Q), (V, triangulate(Q)[0]), 1e-4, "mesh"); judge(h, 1e-4)
    Verdict(status='ok', healthy=True, detail='')
    >>> V[6, 2] = 0.1  # one inner vertex lifted: its four panels twisted
    >>> judge(panel_verdict((V, Q), None, 1e-4, "mesh"), 1e-4).detail
    'max planarity 0.13 > tolerance 0.0001 (4 of 16 faces above)'
    >>> V[7, 0] = V[8, 0] - 1e-3  # and edge (7, 8) collapsed
    >>> v = judge(panel_verdict((V, Q), None, 1e-4, "mesh"), 1e-4); v.status, v.healthy
    ('unhealthy', False)
    """
    healthy = shape_healthy(h)
    nonplanar = int(h.counts["nonplanar"])
    missed = ""
    if nonplanar:
        worst = float(np.max(h.planarity))
        missed = (f"max planarity {worst:.2g} > tolerance {tolerance:g} ({nonplanar} of {len(h.planarity)} faces "
                  f"above)")
    if not healthy:
        lines = [line for line in h.violations if not (nonplanar and "not planar" in line)]
        if missed:
            lines.append("tolerance missed: " + missed)
        return Verdict(STATUS_UNHEALTHY, False, "; ".join(lines))
    if missed:
        return Verdict(STATUS_TOLERANCE, True, missed)
    return Verdict(STATUS_OK, True, "")


def run_strategy(name: str, V, T, panel_size: float, surface: str = "surface",
                 time_budget: float = 30.0) -> StrategyResult:
    """Run one strategy on a design surface and measure the result.

    Parameters
    ----------
    name : str
        Strategy key (see :func:`strategy_names`).
    V : (n, 3) array_like of float
        Design surface vertices.
    T : (t, 3) array_like of int
        Design surface triangles (polygon faces are triangulated).
    panel_size : float
        Target panel edge length, model units.
    surface : str
        Name of the surface (for the result and messages).
    time_budget : float
        Seconds the optimization step may take.

    Returns
    -------
    StrategyResult
        Never raises for a strategy's own failure: ``status`` says ``"failed"`` and ``detail`` the error. The
        status of a result comes from :func:`judge` on the final mesh's panel health (never from the strategy's
        own claims).

    Raises
    ------
    InputError / MeshError
        Unknown strategy name or a malformed design surface.
    """
    strat = get_strategy(name)
    V, F = validate_mesh(V, T, name="surface")
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    h = float(panel_size)
    t0 = time.perf_counter()
    try:
        out = strat.runner(V, T, h, time_budget=time_budget)
    except Exception as exc:  # noqa: BLE001 - a failing strategy is a row of the report, not a crash
        log.warning("strategy %s failed on %s: %s", name, surface, exc, exc_info=not isinstance(exc, ValueError))
        return StrategyResult(name, surface, STATUS_FAILED, None, None, {"total": time.perf_counter() - t0},
                              None, None, [], f"{type(exc).__name__}: {exc}", h)
    timings = dict(out.timings)
    timings["total"] = time.perf_counter() - t0
    warnings = list(out.warnings)
    reference = (V, T)
    tol = float(strat.tolerance)
    try:
        before = _metrics(out.candidate, reference, "candidate")
        after = _metrics(out.optimized, reference, "optimized") if out.optimized is not None else None
        t1 = time.perf_counter()
        cand_health = panel_verdict(out.candidate, reference, tol, "candidate")
        health = (panel_verdict(out.optimized, reference, tol, "optimized") if out.optimized is not None
                  else cand_health)
        timings["health"] = time.perf_counter() - t1
    except (InputError, MeshError) as exc:
        return StrategyResult(name, surface, STATUS_FAILED, out.candidate, out.optimized, timings, None, None,
                              warnings, f"the result cannot be measured: {exc}", h, out.detail, tol)
    verdict = judge(health, tol)
    if verdict.status != STATUS_OK:
        log.info("strategy %s on %s: %s: %s", name, surface, verdict.status, verdict.detail)
    return StrategyResult(name, surface, verdict.status, out.candidate, out.optimized, timings, before, after,
                          warnings, verdict.detail or out.detail, h, out.detail, tol, verdict.healthy,
                          float(health.coverage), list(health.violations), health, cand_health)


def run_strategies(V, T, panel_size: float, surface: str = "surface", names=None,
                   time_budget: float = 30.0) -> list[StrategyResult]:
    """Run several strategies (all by default) on one design surface; see :func:`run_strategy`."""
    return [run_strategy(n, V, T, panel_size, surface=surface, time_budget=time_budget)
            for n in (names or strategy_names())]
