"""The planar-quad (PQ) meshing strategies of the paper, as a registry of runners with one uniform result.

Every runner takes a design surface as a triangle mesh ``(V, T)`` and a target panel size (edge length, model
units) and returns a *candidate* quad mesh (what the strategy builds before any optimization) and, where the
strategy has an optimization step, the *optimized* mesh. :func:`run_strategy` wraps a runner with timings, the
full metric table of :func:`components.metrics.quality.metrics_report` before and after (closeness measured against the
design surface) and the caveats; :func:`run_strategies` runs a list of them. A strategy whose component has not
been written yet is reported as ``status="not available"`` with the missing piece named, never faked; a strategy
that raises is reported as ``status="failed"`` with the error message.

=====================  ==========================================================================================
strategy               steps
=====================  ==========================================================================================
``translation``        exact PQ: a translation surface ``g(u) + h(v)`` fitted to the design surface (see
                       :func:`translation_candidate`); planar by construction, no optimization.
``conjugate_field``    conjugate direction field → quad extraction → planarization
                       (``components.fields.pipeline.pq_from_conjugate_field``).
``curvature_network``  curvature-line network → conformal map → quad rebuild → conical optimization
                       (``components.network.pipeline.pq_from_curvature_network``).
``subdivision``        automatic coarse quad net → Catmull-Clark → pull onto the surface → planarization
                       (``components.subdivision.pipeline.subdivision_pq``).
=====================  ==========================================================================================

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
import scipy.sparse as sp

from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, edge_topology, face_normals, points_in_polygons, remove_unreferenced, triangulate

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
    "translation_candidate",
    "default_panel_size",
]

STATUS_OK = "ok"
STATUS_NOT_AVAILABLE = "not available"
STATUS_FAILED = "failed"


class StrategyResult(NamedTuple):
    """One strategy run on one design surface.

    Attributes
    ----------
    name : str
        Strategy key (e.g. ``"translation"``).
    surface : str
        Name of the design surface.
    status : str
        ``"ok"``, ``"not available"`` (the strategy's component does not exist yet) or ``"failed"``.
    candidate : (V, F) tuple or None
        The quad mesh the strategy builds before optimization.
    optimized : (V, F) tuple or None
        The optimized mesh (same faces as the candidate), or None when the strategy has no optimization step.
    timings : dict of str -> float
        Wall-clock seconds per step, plus ``"total"``.
    metrics_before, metrics_after : dict of str -> float, or None
        :func:`components.metrics.quality.metrics_report` of the candidate / the optimized mesh, closeness against the
        design surface.
    warnings : list of str
        Non-fatal caveats of the steps.
    detail : str
        Why the strategy is not available or failed; a one-line description of what ran otherwise.
    panel_size : float
        The requested panel size (model units).
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

    @property
    def final(self) -> tuple | None:
        """The optimized mesh when there is one, else the candidate."""
        return self.optimized if self.optimized is not None else self.candidate


class Candidate(NamedTuple):
    """What a runner returns: candidate and optimized meshes, step timings, warnings, a one-line description."""

    candidate: tuple
    optimized: tuple | None
    timings: dict
    warnings: list
    detail: str


class Strategy(NamedTuple):
    """A registered strategy: key, title, what it does, its runner and an availability check.

    ``runner(V, T, panel_size, time_budget=...) -> Candidate``; ``missing()`` returns None when the runner can run,
    else a sentence naming the missing component.
    """

    name: str
    title: str
    description: str
    runner: Callable
    missing: Callable[[], str | None]


# ----------------------------------------------------------------------------------------------
# shared helpers


def _frame(V: np.ndarray, T: np.ndarray):
    """Origin, plan axes ``e1, e2`` and up axis of a surface seen as a height field over its mean plane.

    Up is the area-weighted mean normal (the least-variance axis when the normals cancel, e.g. a closed mesh);
    ``e1`` is the major axis of the vertices projected on the plan.
    """
    N = face_normals(V, T, unit=False)  # |N| = 2 · area
    total = np.linalg.norm(N, axis=1).sum()
    s = N.sum(axis=0)
    origin = V.mean(axis=0)
    if np.linalg.norm(s) > 0.3 * total:
        up = s / np.linalg.norm(s)
    else:
        _, _, W = np.linalg.svd(V - origin, full_matrices=False)
        up = W[2]
    P = V - origin
    P = P - np.outer(P @ up, up)
    _, _, W = np.linalg.svd(P, full_matrices=False)
    e1 = W[0] - (W[0] @ up) * up
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    return origin, e1, e2, up


def _largest_component(F: np.ndarray) -> np.ndarray:
    """Indices of the faces of the largest edge-connected component."""
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    if m == 0:
        return np.zeros(0, np.int64)
    EF = edge_topology(F).EF
    inner = EF[:, 1] >= 0
    A = sp.coo_matrix((np.ones(int(inner.sum())), (EF[inner, 0], EF[inner, 1])), shape=(m, m))
    ncomp, labels = connected_components(A, directed=False)
    if ncomp == 1:
        return np.arange(m)
    big = np.argmax(np.bincount(labels))
    return np.nonzero(labels == big)[0]


def default_panel_size(V, divisions: int = 16) -> float:
    """A panel size giving about ``divisions`` panels across the larger plan extent of a surface."""
    V = np.asarray(V, dtype=np.float64)
    ext = np.sort(V.max(axis=0) - V.min(axis=0))
    return float(ext[-1] / max(int(divisions), 1))


def _check_panel_size(panel_size, V) -> float:
    try:
        h = float(panel_size)
    except (TypeError, ValueError):
        raise InputError("panel_size", f"must be a number, got {panel_size!r}") from None
    if not np.isfinite(h) or h <= 0:
        raise InputError("panel_size", f"must be positive and finite, got {panel_size!r}")
    ext = float(np.max(V.max(axis=0) - V.min(axis=0)))
    if h > ext:
        raise InputError("panel_size", f"{h:g} is larger than the surface ({ext:g} across)")
    if ext / h > 400:
        raise InputError("panel_size", f"{h:g} would make more than 400 panels across the surface ({ext:g})")
    return h


# ----------------------------------------------------------------------------------------------
# strategy 1: translation surface fitted to the design surface


def _hat_matrix(x: np.ndarray, knots0: float, h: float, nk: int) -> sp.csr_matrix:
    """Piecewise-linear interpolation matrix of values at ``nk`` uniform knots ``knots0 + i h``."""
    t = np.clip((x - knots0) / h, 0.0, nk - 1 - 1e-12)
    i = np.floor(t).astype(np.int64)
    w = t - i
    rows = np.r_[np.arange(len(x)), np.arange(len(x))]
    return sp.csr_matrix((np.r_[1 - w, w], (rows, np.r_[i, i + 1])), shape=(len(x), nk))


def _second_differences(nk: int) -> sp.csr_matrix:
    if nk < 3:
        return sp.csr_matrix((0, nk))
    return sp.diags([np.ones(nk - 2), -2 * np.ones(nk - 2), np.ones(nk - 2)], [0, 1, 2], shape=(nk - 2, nk))


def _fit_additive(u, v, z, h, smooth):
    """Least-squares ``z ≈ g(u) + h(v)`` with piecewise-linear g, h on knots spaced ``h``; returns the fit."""
    u0, v0 = float(u.min()), float(v.min())
    nu = int(np.ceil((u.max() - u0) / h)) + 1
    nv = int(np.ceil((v.max() - v0) / h)) + 1
    # centre the knot grids on the data
    u0 -= 0.5 * ((nu - 1) * h - (u.max() - u0))
    v0 -= 0.5 * ((nv - 1) * h - (v.max() - v0))
    nu, nv = max(nu, 2), max(nv, 2)
    A = sp.hstack([_hat_matrix(u, u0, h, nu), _hat_matrix(v, v0, h, nv)]).tocsr()
    R = sp.block_diag([_second_differences(nu), _second_differences(nv)])
    gauge = sp.csr_matrix(np.r_[np.zeros(nu), np.ones(nv)][None, :])  # mean of h = 0 (g + h is ambiguous)
    M = (A.T @ A + smooth * (R.T @ R) + gauge.T @ gauge).toarray()
    c = np.linalg.solve(M, A.T @ z)
    resid = A @ c - z
    return u0, v0, nu, nv, c[:nu], c[nu:], float(np.sqrt(np.mean(resid * resid)))


def translation_candidate(V, T, panel_size: float, angles: int = 18, name: str = "surface"):
    """A translation-surface quad mesh fitted to a design surface: planar quads by construction.

    The surface is seen as a height field ``z(x, y)`` over its mean plane. For plan directions ``a`` (swept over
    ``angles`` values in [0°, 90°)) and ``b ⟂ a``, the height is fitted in the least-squares sense by
    ``g(u) + h(v)`` with ``u = x·a, v = x·b`` and ``g, h`` piecewise linear on knots spaced ``panel_size``
    (lightly smoothed). The best direction is kept. The net ``P(i, j) = u_i a + v_j b + (g_i + h_j) up``
    is a translation surface (generatrix ``(u, g(u))`` moved along directrix ``(v, h(v))``): every face is a
    parallelogram, hence exactly planar. Faces whose plan centroid lies outside the surface's plan outline are
    dropped; the largest edge-connected piece is kept.

    Parameters
    ----------
    V : (n, 3) float64
        Design surface vertices.
    T : (t, 3) int64
        Design surface triangles.
    panel_size : float
        Grid spacing in plan (model units).
    angles : int
        Number of plan directions tried.
    name : str
        Name of the surface input in error messages.

    Returns
    -------
    V : (p, 3) float64
    Q : (q, 4) int64
        The trimmed translation net.
    info : dict
        ``angle`` (degrees, of ``a`` from the plan's major axis), ``rms`` (fit residual, model units),
        ``warnings``.

    Notes
    -----
    A height field ``f`` is locally a translation surface along plan directions ``a, b`` exactly when
    ``f_ab = 0``, i.e. when ``a, b`` are conjugate for the Hessian: the sweep picks the orthogonal pair that is
    closest to conjugate on average (a hyperbolic paraboloid is matched exactly along its rulings' bisectors).
    Glymph et al. 2004; Schober 2002.
    """
    V, T = validate_mesh(V, T, name=name, kind="tri")
    h = _check_panel_size(panel_size, V)
    origin, e1, e2, up = _frame(V, T)
    P = V - origin
    X = np.column_stack([P @ e1, P @ e2])
    z = P @ up
    warnings = []
    Nf = face_normals(V, T)
    if np.any(Nf @ up <= 0):
        warnings.append(f"{int(np.sum(Nf @ up <= 0))} triangles face away from the mean plane: the surface is not "
                        "a height field there and the translation fit ignores the overhang")
    ext = float(np.max(X.max(axis=0) - X.min(axis=0)))
    smooth = 1e-3 * len(z) / max(ext / h, 1.0)
    best = None
    for k in range(int(angles)):
        th = 0.5 * np.pi * k / int(angles)
        a = np.array([np.cos(th), np.sin(th)])
        b = np.array([-np.sin(th), np.cos(th)])
        fit = _fit_additive(X @ a, X @ b, z, h, smooth)
        if best is None or fit[-1] < best[1][-1] - 1e-12:
            best = (th, fit, a, b)
    th, (u0, v0, nu, nv, g, hv, rms), a, b = best
    ui = u0 + h * np.arange(nu)
    vj = v0 + h * np.arange(nv)
    a3 = a[0] * e1 + a[1] * e2
    b3 = b[0] * e1 + b[1] * e2
    # vertex (i, j) at index j * nu + i
    Vn = (origin[None, None, :] + ui[None, :, None] * a3 + vj[:, None, None] * b3
          + (g[None, :] + hv[:, None])[..., None] * up).reshape(-1, 3)
    J, I = np.meshgrid(np.arange(nv - 1), np.arange(nu - 1), indexing="ij")
    Q = np.stack([J * nu + I, J * nu + I + 1, (J + 1) * nu + I + 1, (J + 1) * nu + I], axis=-1).reshape(-1, 4)
    # trim to the plan outline
    loops = boundary_loops(T, name=name)
    cu = (u0 + h * (I.ravel() + 0.5))[:, None] * a[None, :]
    cv = (v0 + h * (J.ravel() + 0.5))[:, None] * b[None, :]
    inside = points_in_polygons(cu + cv, [X[lp] for lp in loops]) if loops else np.ones(len(Q), bool)
    Q = Q[inside]
    if len(Q) == 0:
        raise InputError("panel_size", f"{h:g} is too large: no translation panel fits inside the surface outline")
    Q = Q[_largest_component(Q)]
    Vt, Qt, _ = remove_unreferenced(Vn, Q.astype(np.int64))
    # orient like the design surface
    if np.mean(face_normals(Vt, Qt) @ up) * np.mean(Nf @ up) < 0:
        Qt = Qt[:, ::-1].copy()
    return Vt, Qt, {"angle": float(np.degrees(th)), "rms": rms, "warnings": warnings}


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
    from components.core.mesh import boundary_loops

    loop = boundary_loops(T)[0]
    perimeter = float(np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1).sum())
    coarse_edge = panel_size * 2 ** levels
    return int(np.clip(round((perimeter / 4 / coarse_edge) ** 2 * 1.5), 12, 400))


def _run_subdivision(V, T, panel_size, time_budget=30.0):
    from components.subdivision.pipeline import subdivision_pq

    faces = _subdivision_faces(V, T, panel_size)
    res = subdivision_pq(V, T, faces=faces, levels=2, time_budget=float(time_budget))
    opt = res.planarized
    detail = (f"automatic coarse net ({len(res.coarse[1])} faces), 2 Catmull-Clark levels, pulled onto the surface; "
              f"planarized: max planarity {opt.max_planarity:.2g} after {opt.iterations} iterations "
              f"({opt.stop_reason}), worst corner {opt.worst_corner_angle:.0f}°")
    return Candidate(tuple(res.candidate[:2]), tuple(opt.mesh[:2]), dict(res.timings), list(res.warnings), detail)


def _run_conjugate(V, T, panel_size, time_budget=30.0):
    from components.fields.pipeline import pq_from_conjugate_field

    res = pq_from_conjugate_field((V, T), target_length=float(panel_size), time_budget=float(time_budget))
    timings = {"field": res.time_field, "parametrize": res.time_parametrize, "extract": res.time_extract,
               "planarize": res.time_planarize}
    detail = (f"conjugate field ({res.singularities} singular vertices, iso-lines {res.mean_angle_error:.1f}° from "
              f"the field on average), {100 * res.quad_ratio:.0f}% quads, "
              f"{100 * res.edge_length_within:.0f}% of edges within ±30% of the panel size; planarized max "
              f"planarity {res.planarized_max_planarity:.2g}")
    return Candidate(tuple(res.candidate[:2]), tuple(res.planarized[:2]), timings, list(res.warnings), detail)


def _run_network(V, T, panel_size, time_budget=30.0):
    from components.network.pipeline import pq_from_curvature_network

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
             _run_translation, lambda: None),
    Strategy("conjugate_field", "Conjugate field",
             "conjugate direction field → quad extraction → planarization",
             _run_conjugate, lambda: None),
    Strategy("curvature_network", "Curvature network",
             "curvature-line network → conformal map → quad rebuild → conical optimization",
             _run_network, lambda: None),
    Strategy("subdivision", "Subdivision",
             "automatic coarse quad net → Catmull-Clark → pull onto the surface → planarization",
             _run_subdivision, lambda: None),
)


def strategy_names() -> tuple[str, ...]:
    """Keys of the registered strategies, in the paper's order."""
    return tuple(s.name for s in STRATEGIES)


def get_strategy(name: str) -> Strategy:
    """The registered strategy ``name``.

    Raises
    ------
    InputError
        Unknown name (the message lists the valid ones).
    """
    for s in STRATEGIES:
        if s.name == name:
            return s
    raise InputError("strategy", f"unknown strategy {name!r}; valid: {', '.join(strategy_names())}")


def _metrics(mesh, reference, name):
    from components.metrics.quality import metrics_report

    return metrics_report(mesh[0], mesh[1], reference=reference, name=name)


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
        Never raises for a strategy's own failure: ``status`` says ``"failed"`` and ``detail`` the error; a
        strategy whose component is missing gives ``status="not available"``.

    Raises
    ------
    InputError / MeshError
        Unknown strategy name or a malformed design surface.
    """
    strat = get_strategy(name)
    V, F = validate_mesh(V, T, name="surface")
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    h = float(panel_size)
    why = strat.missing()
    if why:
        return StrategyResult(name, surface, STATUS_NOT_AVAILABLE, None, None, {}, None, None, [], why, h)
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
    try:
        before = _metrics(out.candidate, reference, "candidate")
        after = _metrics(out.optimized, reference, "optimized") if out.optimized is not None else None
    except (InputError, MeshError) as exc:
        return StrategyResult(name, surface, STATUS_FAILED, out.candidate, out.optimized, timings, None, None,
                              warnings, f"the result cannot be measured: {exc}", h)
    return StrategyResult(name, surface, STATUS_OK, out.candidate, out.optimized, timings, before, after, warnings,
                          out.detail, h)


def run_strategies(V, T, panel_size: float, surface: str = "surface", names=None,
                   time_budget: float = 30.0) -> list[StrategyResult]:
    """Run several strategies (all by default) on one design surface; see :func:`run_strategy`."""
    return [run_strategy(n, V, T, panel_size, surface=surface, time_budget=time_budget)
            for n in (names or strategy_names())]
