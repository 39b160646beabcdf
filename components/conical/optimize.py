"""Conical optimization: planarity + conical angle criterion + closeness through the planarization solver.

A candidate quad mesh laid along the curvature lines is nearly conical already; this module makes it exactly conical
(Liu et al. 2006) with :func:`components.planarize.planarizer.planarize_mesh`, whose hard rows are the face
planarity residuals and, with ``conical_weight > 0``, the angle criterion ``ω1 − ω2 + ω3 − ω4`` at every interior
valence-4 vertex, while its soft goals keep the mesh close to the design surface and fair. By default the solve is
**polished** to near machine precision (planarity ~1e-10): a face offset at distance ``d`` needs the face planes to
be exact, since a planarity ``p`` shows up as an offset error of about ``p`` × edge length, independent of ``d``.
The Gauss-Newton steps converge quadratically, so the polish costs a few more iterations.

The conical verdict is :func:`components.conical.cones.conical_check` (cone fit of the face normals, tolerance widened
by the local planarity; the angle criterion reported beside it). "Converged" is a claim about fabricable panels too:
the tolerance reached **and** the panels healthy by :func:`components.metrics.health.face_health` at the given bounds
(20° corners, edges 0.2 × the median, faces 0.1 × the median area, no folds or crossings; with a reference also 85%
coverage of it); otherwise a warning names what is wrong.

Array-level: :func:`conical_mesh` (and :func:`conical_solve`, the same without the health verdict, for a caller
that judges the result itself). Published: :func:`optimize` (``conical/optimize``).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from components.conical.cones import conical_check, conical_criterion
from components.core.checks import check_mesh, check_number, validate_mesh
from components.core.mesh import edge_topology
from components.core.types import Mesh, Numbers, Texts
from components.metrics.health import face_health
from components.planarize.planarizer import planarize_mesh

log = logging.getLogger(__name__)

__all__ = [
    "ConicalMesh",
    "ConicalSolve",
    "OptimizeResult",
    "conical_mesh",
    "conical_solve",
    "optimize",
]


class ConicalMesh(NamedTuple):
    """Result of :func:`conical_mesh`: the conical mesh and how well it is conical."""

    V: np.ndarray  # (n, 3) optimized vertices
    F: np.ndarray  # (m, k) faces (unchanged)
    max_planarity: float
    max_criterion: float  # max |ω1 − ω2 + ω3 − ω4| over interior valence-4 vertices, radians
    max_cone_deviation: float  # over checked vertices, radians
    mean_closeness: float  # model units: to the reference, else to the start positions
    max_closeness: float
    mean_edge_length: float
    iterations: int
    converged: bool  # planarity and criterion within the tolerance, and the panels healthy
    worst_corner_angle: float  # degrees
    healthy: bool  # face_health at the bounds (planarity at the tolerance)
    coverage: float  # covered share of the reference, 0..1 (NaN without one)
    violations: list  # face_health's lines
    warnings: list


def conical_mesh(V, F, reference=None, *, closeness_weight: float = 1.0, fairness_weight: float = 0.01,
                 tolerance: float = 1e-4, polish: bool = True, boundary: str = "free",
                 max_iterations: int = 100, time_budget: float = 30.0, mesh_name: str = "mesh",
                 min_angle: float = 20.0, min_edge_ratio: float = 0.2, min_area_ratio: float = 0.1,
                 min_coverage: float = 0.85) -> ConicalMesh:
    """Make a quad mesh conical and planar while it stays close to a reference surface.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices of a (near-)curvature-line quad mesh.
    F : (m, k) int64
        Faces, consistently oriented (quads, with some other polygons).
    reference : tuple (Vr, Fr), optional
        Design surface to stay close to; without it, closeness is to the start mesh.
    closeness_weight : float
        Weight of the pull to the reference (see :func:`components.planarize.planarizer.planarize_mesh`).
    fairness_weight : float
        Weight of the fairness goal.
    tolerance : float
        Largest accepted planarity (scale-free) and angle criterion (radians) for ``converged``.
    polish : bool
        Drive planarity to ~1e-10 (and the criterion with it) so that face offsets are exact; otherwise stop at
        ``tolerance``.
    boundary : {"free", "slide", "fixed"}
        Boundary vertices free, sliding on the reference's boundary, or fixed.
    max_iterations : int
        Iteration cap of the solver.
    time_budget : float
        Wall-clock budget in seconds.
    mesh_name : str
        Name of the mesh in error messages.
    min_angle, min_edge_ratio, min_area_ratio, min_coverage : float
        Panel-health bounds (:func:`components.metrics.health.face_health`), guarded by the solver and checked on
        the result.

    Returns
    -------
    ConicalMesh
        ``converged`` when planarity and criterion are within ``tolerance`` and the panels are ``healthy``.

    Raises
    ------
    MeshError
        Malformed mesh or reference.
    InputError
        Bad weights or options.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006 (the angle criterion as a constraint); Tang, Sun, Gomes, Wallner, Pottmann, *Form-finding with
    polyhedral meshes made simple*, SIGGRAPH 2014 (the guided projection solver of
    :mod:`components.planarize.planarizer`).
    """
    tol = check_number(tolerance, "tolerance", 0, above=True)
    sol = conical_solve(V, F, reference, closeness_weight=closeness_weight, fairness_weight=fairness_weight,
                        tolerance=tol, polish=polish, boundary=boundary, max_iterations=max_iterations,
                        time_budget=time_budget, mesh_name=mesh_name, min_angle=min_angle,
                        min_edge_ratio=min_edge_ratio, min_area_ratio=min_area_ratio, min_coverage=min_coverage)
    health = face_health(sol.V, sol.F, reference, tolerance=tol, min_coverage=min_coverage, name=mesh_name,
                         min_angle=min_angle, min_edge_ratio=min_edge_ratio, min_area_ratio=min_area_ratio)
    warnings = list(sol.warnings)
    shape = [line for line in health.violations if "not planar" not in line]
    if shape:
        warnings.append("panels not healthy: " + "; ".join(shape))
    return ConicalMesh(sol.V, sol.F, sol.max_planarity, sol.max_criterion, sol.max_cone_deviation,
                       sol.mean_closeness, sol.max_closeness, sol.mean_edge_length, sol.iterations,
                       bool(sol.reached and health.healthy), sol.worst_corner_angle, bool(health.healthy),
                       float(health.coverage), list(health.violations), warnings)


class ConicalSolve(NamedTuple):
    """Result of :func:`conical_solve`: the solver's mesh and how well it is conical (no health verdict)."""

    V: np.ndarray  # (n, 3) optimized vertices
    F: np.ndarray  # (m, k) faces (unchanged)
    max_planarity: float
    max_criterion: float  # max |ω1 − ω2 + ω3 − ω4| over interior valence-4 vertices, radians
    max_cone_deviation: float  # over checked vertices, radians
    mean_closeness: float  # model units: to the reference, else to the start positions
    max_closeness: float
    mean_edge_length: float
    iterations: int
    reached: bool  # planarity and criterion within the tolerance
    worst_corner_angle: float  # degrees
    warnings: list


def conical_solve(V, F, reference=None, *, closeness_weight: float = 1.0, fairness_weight: float = 0.01,
                  tolerance: float = 1e-4, polish: bool = True, boundary: str = "free",
                  max_iterations: int = 100, time_budget: float = 30.0, mesh_name: str = "mesh",
                  min_angle: float = 20.0, min_edge_ratio: float = 0.2, min_area_ratio: float = 0.1,
                  min_coverage: float = 0.85) -> ConicalSolve:
    """:func:`conical_mesh` without its health verdict on the result (for a caller that judges the result at its
    own bounds anyway: one :func:`components.metrics.health.face_health` less). Same parameters; the bounds guard
    the solver.

    Returns
    -------
    ConicalSolve
        ``reached`` when planarity and criterion are within ``tolerance``; the warnings of :func:`conical_mesh`
        but the health line.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(5, 5, 4.0, 4.0, height=lambda x, y: 0.03 * (x - 2) ** 2 + 0.02 * (y - 2) ** 2)
    >>> sol = conical_solve(V, F)  # the grid lines of this paraboloid are nearly its curvature lines
    >>> sol.reached, sol.max_planarity < 1e-8, sol.max_criterion < 1e-8
    (True, True, True)
    """
    tol = check_number(tolerance, "tolerance", 0, above=True)
    V, F = validate_mesh(V, F, name=mesh_name)
    bounds = dict(min_angle=min_angle, min_edge_ratio=min_edge_ratio, min_area_ratio=min_area_ratio)
    res = planarize_mesh(V, F, reference, closeness_weight=closeness_weight, fairness_weight=fairness_weight,
                         conical_weight=1.0, boundary=boundary, tolerance=min(tol, 1e-10) if polish else tol,
                         max_iterations=max_iterations, time_budget=time_budget, mesh_name=mesh_name,
                         min_coverage=min_coverage, **bounds)
    X = res.mesh[0]
    # the solver's verdict is at the polish tolerance: the health verdict of conical_mesh is at ``tolerance``
    warnings = [w for w in res.warnings
                if not (polish and w.startswith("tolerance not reached")) and not w.startswith("panels not healthy")]
    _, crit = conical_criterion(X, F)
    max_crit = float(np.abs(crit).max()) if len(crit) else 0.0
    chk = conical_check(X, F, tol)
    max_dev = float(chk.deviation[chk.checked].max()) if chk.checked.any() else 0.0
    E = edge_topology(F).E
    L = float(np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1).mean())
    met = res.max_planarity <= tol and max_crit <= tol
    off_cone = np.flatnonzero(chk.checked & ~chk.passed)  # the verdict of components.conical.cones.analysis
    reached = met and not len(off_cone)
    if not len(crit):
        warnings.append("no interior valence-4 vertex: the conical criterion constrains nothing")
    if not met:
        warnings.append(f"conical optimization did not reach {tol:g} ({res.stop_reason}): max planarity "
                        f"{res.max_planarity:.2e}, max angle criterion {max_crit:.2e} rad")
    elif len(off_cone):
        warnings.append(f"not conical at {len(off_cone)} vert{'ex' if len(off_cone) == 1 else 'ices'} with five or "
                        f"more faces (face normals up to "
                        f"{float(chk.deviation[off_cone].max()):.2e} rad off their best cone; the angle criterion "
                        "constrains the valence-4 vertices only): node axes and face offsets are exact at the others")
    elif polish and (res.max_planarity > 1e-8 or max_crit > 1e-7):
        warnings.append(f"the polish stopped at planarity {res.max_planarity:.1e} / criterion {max_crit:.1e} "
                        f"({res.stop_reason}): face offsets are exact only to about planarity × edge length")
    return ConicalSolve(X, F, res.max_planarity, max_crit, max_dev, res.mean_closeness, res.max_closeness, L,
                        res.iterations, bool(reached), res.worst_corner_angle, warnings)


# ----------------------------------------------------------------------------------------------
# published component


class OptimizeResult(NamedTuple):
    optimized: Mesh
    max_planarity: float
    max_criterion: float
    max_cone_deviation: float
    criterion: Numbers
    mean_closeness: float
    relative_closeness: float
    is_conical: bool
    iterations: int
    healthy: bool
    coverage: float
    violations: Texts
    warnings: list[str]


def optimize(mesh: Mesh, reference: Mesh | None = None, closeness_weight: float = 1.0,
             fairness_weight: float = 0.01, tolerance: float = 1e-4, polish: bool = True,
             boundary: str = "free", max_iterations: int = 100, time_budget: float = 30.0) -> OptimizeResult:
    """Optimize a quad mesh into a conical mesh: planar faces, angle criterion at every vertex, close to the surface.

    Parameters
    ----------
    mesh : Mesh
        The quad-dominant mesh ``(V, F)``, ideally laid along the curvature lines (nearly conical already).
    reference : Mesh | None
        The design surface to stay close to (optional; without it the start mesh is the reference).
    closeness_weight : float
        Weight of the pull towards the reference.
    fairness_weight : float
        Weight of the fairness goal (smooth mesh polylines).
    tolerance : float
        Largest accepted planarity (scale-free) and angle criterion ``|ω1 − ω2 + ω3 − ω4|`` (radians).
    polish : bool
        Drive planarity and the criterion to about 1e-10 so that face offsets are exact.
    boundary : str
        Boundary vertices ``"free"``, ``"slide"`` (on the reference's boundary) or ``"fixed"``.
    max_iterations : int
        Iteration cap of the solver.
    time_budget : float
        Wall-clock budget in seconds.

    Returns
    -------
    optimized : Mesh
        The conical mesh.
    max_planarity : float
        Largest face planarity (scale-free).
    max_criterion : float
        Largest angle criterion at interior valence-4 vertices (radians).
    max_cone_deviation : float
        Largest cone-normal deviation at interior vertices with four or more faces (radians).
    criterion : Numbers
        Per vertex ``|ω1 − ω2 + ω3 − ω4|`` (0 where not applicable).
    mean_closeness : float
        Mean distance of the vertices to the reference (model units).
    relative_closeness : float
        Mean closeness divided by the mean edge length.
    is_conical : bool
        Planarity and criterion within the tolerance, the face normals on a cone at every vertex with four or more
        faces (the verdict of ``conical/analysis``; a warning names the vertices with five or more faces off their
        cones, which the criterion does not constrain), and the panels healthy.
    iterations : int
        Solver iterations.
    healthy : bool
        No panel defect (corners of 20° to 160°, edges over 0.2 × the median, faces over 0.1 × the median area, no
        folds or crossings, planarity within the tolerance; with a reference 85% of it covered).
    coverage : float
        Share of the reference covered by the result, 0..1; -1 without a reference.
    violations : Texts
        One line per failed health check, with the count and the worst value.

    Raises
    ------
    MeshError
        Malformed mesh or reference (named).
    InputError
        Bad weights, tolerance or boundary mode.

    Notes
    -----
    Liu et al. 2006 (conical meshes); Tang et al. 2014 (guided projection). The face offset of the result at a
    distance ``d`` keeps every face plane at ``d`` (see :func:`components.conical.cones.offset`).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> optimize(quad_grid(3, 3)).is_conical
    True
    """
    V, F = check_mesh(mesh, "mesh")
    ref = None if reference is None else check_mesh(reference, "reference", manifold=False)
    res = conical_mesh(V, F, ref, closeness_weight=closeness_weight, fairness_weight=fairness_weight,
                       tolerance=tolerance, polish=bool(polish), boundary=boundary, max_iterations=max_iterations,
                       time_budget=time_budget)
    verts, crit = conical_criterion(res.V, res.F)
    c = np.zeros(len(res.V))
    c[verts] = np.abs(crit)
    return OptimizeResult(
        optimized=(res.V, res.F),
        max_planarity=res.max_planarity,
        max_criterion=res.max_criterion,
        max_cone_deviation=res.max_cone_deviation,
        criterion=c,
        mean_closeness=res.mean_closeness,
        relative_closeness=res.mean_closeness / max(res.mean_edge_length, 1e-300),
        is_conical=res.converged,
        iterations=res.iterations,
        healthy=res.healthy,
        coverage=-1.0 if np.isnan(res.coverage) else res.coverage,
        violations=list(res.violations),
        warnings=res.warnings,
    )
