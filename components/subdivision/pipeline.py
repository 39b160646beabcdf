"""End-to-end subdivision strategy: coarse net → Catmull-Clark → pull onto the surface → planarization → health.

:func:`pq_from_subdivision` (published) and :func:`subdivision_pq` (array level) run the steps of the third
free-form strategy of Liu et al. 2006 on a design surface:

1. the coarse quad-dominant net: the user's (validated: manifold, consistently oriented, no degenerate face) or an
   automatic one (:func:`components.subdivision.coarse.coarse_net`, laid out on the surface centred and scaled to
   unit size: along the conjugate direction field, an O-grid in the unit-disk map, or a grid between four boundary
   corners, whichever ranks better; see :mod:`components.subdivision.coarse`);
2. ``levels`` Catmull-Clark steps with crease boundaries (:func:`components.subdivision.subdivide.subdivided_mesh`);
3. boundary vertices onto the surface boundary, spread by arc length between the coarse boundary vertices, the
   interior following smoothly, then every interior vertex to its closest point on the surface
   (:func:`components.subdivision.pull.pulled_subdivision`);
4. planarization with hard planarity, closeness to the surface, fairness and boundary vertices sliding on the
   surface boundary (:func:`components.planarize.planarizer.planarize_mesh`, with its panel-health guard options
   where it has them);
5. panel health (:func:`components.metrics.health.face_health` against the surface, bounds
   :data:`HEALTH_BOUNDS`): a planarization that collapsed, pinched or folded panels is backed off to the best
   healthy state on the way from the candidate, and the result says whether it is healthy, how much of the
   surface it covers and what is wrong (``healthy``, ``coverage``, ``violations``); ``converged`` is "planarity
   tolerance reached and healthy", anything else comes with a warning naming the counts.

All input checks, including the face count after ``levels`` against ``max_faces``, run before any of the heavy
steps.
"""
from __future__ import annotations

import inspect
import logging
import math
import time
from typing import NamedTuple

import numpy as np

from components.core.checks import boundary_gap_warning, check_choice, check_int, check_number, validate_mesh
from components.core import progress
from components.core.errors import InputError
from components.core.frame import Frame
from components.core.measures import (corner_angles, max_quad_planarity, nonconvex_faces, quad_planarity,
                                      warping_height)
from components.core.mesh import edge_topology, triangulate
from components.core.proximity import TriangleIndex
from components.core.types import Mesh, Texts
from components.metrics.health import DEFECT_BITS, PanelHealth, face_health, shape_healthy
from components.planarize.planarizer import planarize_mesh
from components.planarize.verdict import backed_off_reason
from components.subdivision.coarse import check_disk_surface, coarse_net, ogrid_size
from components.subdivision.pull import pulled_subdivision, pulled_vertices
from components.subdivision.subdivide import MAX_LEVELS, control_mesh, face_count_after, subdivided_mesh

log = logging.getLogger(__name__)

__all__ = ["SubdivisionPQ", "SubdivisionPQResult", "pq_from_subdivision", "subdivision_pq"]


#: the fabrication bounds every result is judged by (:func:`components.metrics.health.face_health`): shortest edge
#: and smallest face as fractions of the median, smallest corner (degrees), smallest covered share of the surface
HEALTH_BOUNDS = {"min_edge_ratio": 0.2, "min_angle": 20.0, "min_area_ratio": 0.1, "min_coverage": 0.85}
#: steps of the bisection for the healthy state between the candidate and the planarized mesh (1/64 of the way)
_BACKOFF_STEPS = 6
_SHAPE_DEFECTS = ~DEFECT_BITS["nonplanar"]  # every defect bit but planarity
#: defects of a candidate that planarization cannot undo (it only keeps them from getting worse)
_FOLD_DEFECTS = sum(DEFECT_BITS[d] for d in ("intersecting", "folded", "flipped", "nonconvex", "corner"))
_LAYOUTS = ("ogrid", "aligned", "grid")  # the automatic layouts tried when the first candidate folds
_FINER = (1.5, 2.0)  # ... then these × the coarse face count
#: the planarizer's ``relaxed_guard``: when its guard holds the net after the closeness stiffness was relaxed, an
#: edge may shrink below half its input length (and a corner, a turn or a fold opening below half the input's
#: worst) as long as the fabrication bounds hold (inspired_mesh's net stalls at 0.012 otherwise, edges held at
#: 0.21 × the median)
_RELAXED_GUARD = 0.05


class SubdivisionPQ(NamedTuple):
    """Result of :func:`subdivision_pq` (arrays and the planarizer's full result)."""

    coarse: tuple  # (V, F) the coarse net used
    candidate: tuple  # (V, Q) subdivided and pulled
    candidate_planarity: np.ndarray  # (q,)
    candidate_distance: np.ndarray  # (n,) distance of every candidate vertex to the surface
    planarized: object  # PlanarizeResult of the returned (healthy) state, or None without planarization
    mean_edge: float  # mean edge length of the candidate
    timings: dict
    warnings: list
    layout: str  # layout of the coarse net ("aligned", "ogrid", "patches", "grid" or "given")
    health: PanelHealth  # of the result (the planarized mesh, or the candidate without planarization)
    healthy: bool  # no defect but planarity, coverage reached
    coverage: float  # covered share of the design surface, 0..1
    violations: list  # one line per failed check of ``health`` (planarity included)
    converged: bool  # planarity tolerance reached and healthy


def _mean_edge(V, F):
    E = edge_topology(F).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


def _guard_options() -> dict:
    """The planarizer's panel-health bounds that it takes (named like :data:`HEALTH_BOUNDS`): its guard then keeps
    the same bounds the result is judged by."""
    params = inspect.signature(planarize_mesh).parameters
    return {k: v for k, v in HEALTH_BOUNDS.items() if k in params}


class _Candidate(NamedTuple):
    """A subdivided, pulled candidate and how it was made."""

    coarse: tuple  # (Vc, Fc) the coarse net
    X: np.ndarray  # the candidate's vertices (on the surface)
    Q: np.ndarray  # its quads
    layout: str  # the coarse net's layout ("given" for a user's net)
    faces: int  # the coarse face count asked for
    pulled: object  # the pull's result (distances, warnings)
    warnings: list


def _candidate(V, T, given, faces, layout, levels, max_faces, spread_boundary, timings) -> _Candidate:
    """Coarse net (``given`` or automatic) → Catmull-Clark → pulled onto the surface ``(V, T)``.

    All three run on the surface centred, at unit size and snapped to a grid (:func:`_frame`), so the same surface
    in other units gives them the same numbers bit for bit (a pull's closest points on a ridge are ties that the
    rounding of other units once broke another way: rhinovault_mesh_0 at 60 panels got candidates 1.7e-3 of its size
    apart in mm and m); the candidate is mapped back to model units."""
    warnings: list[str] = []
    frame = _frame(V)
    Vf = frame.to(V)
    t = time.perf_counter()
    if given is None:
        net = coarse_net(Vf, T, faces=faces, layout=layout, levels=levels)
        Cf, Fc, used = net.V, net.Q, net.layout
        Vc = frame.back(Cf)
        warnings += net.warnings
    else:
        (Vc, Fc), used = given, "given"
        Cf = frame.to(Vc)
    timings["coarse"] = timings.get("coarse", 0.0) + time.perf_counter() - t
    t = time.perf_counter()
    Vs, Qs, _ = subdivided_mesh(Cf, Fc, levels=levels, boundary="crease", max_faces=max_faces, name="coarse")
    timings["subdivide"] = timings.get("subdivide", 0.0) + time.perf_counter() - t
    t = time.perf_counter()
    if spread_boundary:
        pulled = pulled_subdivision(Vs, Qs, Cf, Vf, T, name="candidate", reference_name="surface")
    else:
        pulled = pulled_vertices(Vs, Qs, Vf, T, boundary="boundary", name="candidate", reference_name="surface")
    pulled = pulled._replace(V=frame.back(pulled.V), distances_before=pulled.distances_before * frame.scale,
                             distances_after=pulled.distances_after * frame.scale)
    timings["pull"] = timings.get("pull", 0.0) + time.perf_counter() - t
    return _Candidate((Vc, Fc), pulled.V, Qs, used, faces, pulled, warnings + list(pulled.warnings))


def _candidate_folds(cand: _Candidate, reference) -> int:
    """Faces of the candidate with a fold defect (crossing, folded onto a neighbour, flipped, non-convex, a corner
    out of bounds): what planarization cannot undo."""
    h = face_health(cand.X, cand.Q, reference, tolerance=1e300, **HEALTH_BOUNDS, name="candidate")
    return int(np.count_nonzero(h.face_defects & _FOLD_DEFECTS))


def _other_candidate(V, T, first, n_first, faces, layout, levels, max_faces, spread_boundary, timings, warnings):
    """When the automatic net's candidate folds (a re-entrant corner pulled across itself, a net too coarse for the
    curvature): the other layouts, then finer nets (:data:`_FINER`), the first candidate without folds; else the
    one with the fewest folded faces (``n_first``: those of ``first``). A warning says what was used instead."""
    reference = (V, T)
    best, n_best = first, n_first
    tries = [(other, faces) for other in _LAYOUTS if other not in (layout, first.layout)] + \
            [(layout, math.ceil(f * faces)) for f in _FINER]
    for lay, f in tries:
        n, k = ogrid_size(f)
        if max(n * n + 4 * n * k, math.ceil(1.5 * f)) * 4 ** levels > max_faces:
            continue
        try:
            cand = _candidate(V, T, None, f, lay, levels, max_faces, spread_boundary, timings)
        except (InputError, ValueError) as exc:  # a layout that does not apply to this surface
            log.debug("subdivision: layout %s with %d faces not usable: %s", lay, f, exc)
            continue
        n_cand = _candidate_folds(cand, reference)
        if n_cand < n_best:
            best, n_best = cand, n_cand
        if n_best == 0:
            break
    if best is not first:
        warnings.append(f"the automatic coarse net ({first.layout}, {first.faces} faces) made a candidate with "
                        f"{n_first} folded or pinched faces; used the {best.layout} net with {best.faces} faces "
                        f"instead ({n_best} such faces)")
    return best


def _planarized(Xc, Qs, reference, closeness_weight, **kwargs):
    """The planarizer's result on the candidate (boundary sliding on the surface's, its guard at the fabrication
    bounds).

    The subdivision nets are far from conjugate (max planarity 0.04-0.07 on the ogrid nets of wave, canopy and
    inspired_mesh at levels 2): at the given closeness weight the guard holds the net; the planarizer then relaxes
    the closeness stiffness and its relative guard bounds (to :data:`_RELAXED_GUARD`) while it restores planarity, and pulls the planar net
    back toward the surface at the full weight afterwards (:mod:`components.planarize.phases`).
    """
    return planarize_mesh(Xc, Qs, reference=reference, closeness_weight=closeness_weight, boundary="slide",
                          mesh_name="candidate", relaxed_guard=_RELAXED_GUARD, **kwargs, **_guard_options())


def _health(X, Q, tolerance, reference=None) -> PanelHealth:
    return face_health(X, Q, reference, tolerance=tolerance, **HEALTH_BOUNDS, name="planarized")


def _healthy_state(X0, X1, Q, tolerance):
    """The best healthy point on the way ``X0 + t (X1 − X0)``, ``t`` in ``[0, 1]``, its ``t`` and the health of
    ``X1``.

    A point is healthy when it adds no defect but planarity to any face of ``X0``; ``X1`` is returned when it is.
    Otherwise the largest healthy ``t`` is found by bisection (:data:`_BACKOFF_STEPS` steps) and, of the healthy
    points seen (``t = 0`` included), the one with the smallest max planarity is returned.
    """
    h0 = _health(X0, Q, tolerance)
    base = h0.face_defects & _SHAPE_DEFECTS
    h1 = _health(X1, Q, tolerance)
    if not np.any(h1.face_defects & _SHAPE_DEFECTS & ~base):
        return X1, 1.0, h1
    best = (float(h0.planarity.max()) if len(Q) else 0.0, 0.0)
    lo, hi = 0.0, 1.0
    for _ in range(_BACKOFF_STEPS):
        t = 0.5 * (lo + hi)
        h = _health(X0 + t * (X1 - X0), Q, tolerance)
        if np.any(h.face_defects & _SHAPE_DEFECTS & ~base):
            hi = t
        else:
            lo = t
            best = min(best, (float(h.planarity.max()), t))
    t = best[1]
    return X0 + t * (X1 - X0), t, h1


def _backed_off(res, X, Q, t, h1, reference, tolerance):
    """The planarizer's result ``res`` moved to the healthy state ``X`` (``t`` of the way from the candidate), with
    its measures recomputed, and the warning that says why and how far planarity is."""
    Vr, Tr = reference
    pl = quad_planarity(X, Q)
    d = TriangleIndex(Vr, Tr, name="surface").query(X, name="planarized").distances
    ang = corner_angles(X, Q)
    lines = [line for line in h1.violations if "not planar" not in line]
    kept = (f"kept the healthy state {t:.0%} of the way from the candidate" if t > 0 else
            "kept the candidate (no healthy state on the way planarizes better)")
    warning = (f"the planarization made unhealthy panels ({'; '.join(lines)}); {kept}: max planarity {pl.max():.3g} "
               f"= {pl.max() / tolerance:.3g} × the tolerance {tolerance:g}")
    fields = {"mesh": (X, Q), "planarity": pl, "max_planarity": float(pl.max()), "mean_planarity": float(pl.mean()),
              "max_closeness": float(d.max()), "mean_closeness": float(d.mean()), "converged": False,
              "stop_reason": (f"{backed_off_reason(res.stop_reason)}; backed off to the last healthy state "
                              f"({t:.0%} of the way)"),
              "worst_corner_angle": float(np.degrees(ang.min())), "nonconvex_faces": int(nonconvex_faces(X, Q).sum()),
              "max_warping_height": float(warping_height(X, Q).max())}
    fields = {k: v for k, v in fields.items() if k in res._fields}
    return res._replace(**fields, warnings=list(res.warnings) + [warning]), warning


def _verdict_warnings(h: PanelHealth, planarity: float, tolerance: float, planarized: bool) -> list[str]:
    """Warnings naming what keeps the result from being fabricable (counts and worst values)."""
    out = []
    shape = [line for line in h.violations if "not planar" not in line]
    if shape:
        out.append("not fabricable: " + "; ".join(shape))
    if planarity > tolerance:
        what = "planarized mesh" if planarized else "candidate (not planarized)"
        out.append(f"the {what} misses the planarity tolerance {tolerance:g}: max planarity {planarity:.3g} = "
                   f"{planarity / tolerance:.3g} × the tolerance")
    return out


def _frame(V) -> Frame:
    """The surface's frame (:class:`components.core.frame.Frame`, whose ``to`` snaps to its grid): centred on the
    bounding box, the box's diagonal the unit (1 for a single point)."""
    center = 0.5 * (V.min(axis=0) + V.max(axis=0))
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    return Frame(center, size)


def subdivision_pq(V, T, coarse=None, levels: int = 2, planarize: bool = True, faces: int = 36,
                   closeness_weight: float = 15.0, fairness_weight: float = 0.01, tolerance: float = 1e-4,
                   max_iterations: int = 100, time_budget: float = 30.0,
                   max_faces: int = 2_000_000, layout: str = "auto",
                   spread_boundary: bool = True) -> SubdivisionPQ:
    """Subdivision strategy on arrays: coarse net → Catmull-Clark → pull → planarize → panel health.

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
    layout : {"auto", "aligned", "ogrid", "grid"}
        Layout of the automatic coarse net (:func:`components.subdivision.coarse.coarse_net`).
    spread_boundary : bool
        Pull with :func:`components.subdivision.pull.pulled_subdivision` (boundary by arc length between the coarse boundary
        vertices); False: plain closest points (:func:`components.subdivision.pull.pulled_vertices`).

    Returns
    -------
    SubdivisionPQ
        ``planarized`` is the planarizer's result, moved back to the last healthy state when the planarization
        collapsed, pinched or folded panels (see Notes); ``health`` judges the returned mesh against the surface
        (:func:`components.metrics.health.face_health` with :data:`HEALTH_BOUNDS`), ``converged`` is "planarity
        tolerance reached and healthy".

    Raises
    ------
    MeshError
        Malformed surface, or a coarse net with flipped faces, non-manifold edges or degenerate faces.
    InputError
        ``levels`` negative / not whole / too large for ``max_faces``, bad ``faces`` or ``max_faces``.

    Notes
    -----
    The planarization never returns unhealthy panels: when its result has a defect other than planarity (edge under
    0.2 × the median, face under 0.1 × the median area, corner under 20° or over 160°, non-convex, folded or
    crossing faces) that the candidate did not have on that face, the returned state is the farthest point on the
    way from the candidate to the planarized mesh that adds none (bisection), and a warning gives its planarity.
    The automatic coarse net is laid out on the surface centred and scaled to unit size, so the result does not
    depend on units or placement.
    """
    # ---- every check first (cheap)
    levels = check_int(levels, "levels", 0, MAX_LEVELS)  # (more: a count of hundreds of millions of digits)
    tolerance = check_number(tolerance, "tolerance", 0.0, above=True)
    max_faces = check_int(max_faces, "max_faces", 1)
    faces = check_int(faces, "faces", 4)
    layout = check_choice(layout, "layout", ("auto", "aligned", "ogrid", "grid"))
    V, F = validate_mesh(V, T, name="surface", manifold=True)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    if coarse is not None:
        if not isinstance(coarse, (tuple, list)) or len(coarse) < 2:
            raise InputError("coarse", "must be a (V, F) pair")
        Vc, Fc = control_mesh(coarse[0], coarse[1], name="coarse")
        total = face_count_after(Fc, levels)
    else:
        check_disk_surface((V, T))
        n, k = ogrid_size(faces)
        # the aligned net's face count is known only after the field pipeline: bound it by 1.5 × the target
        total = max(n * n + 4 * n * k, math.ceil(1.5 * faces)) * 4 ** levels
    if total > max_faces:
        if coarse is None and total // 4 ** levels > max_faces:  # the net alone is too fine
            raise InputError("faces", f"a coarse net of {faces:,} faces is more than the limit of {max_faces:,} "
                                      "(max_faces); ask for fewer faces")
        raise InputError("levels", f"{levels} levels would make {total:,} faces, more than the limit of "
                         f"{max_faces:,} (max_faces); use fewer levels or a coarser net")
    # ---- heavy work
    timings: dict = {}
    warnings: list[str] = []
    progress.report(0.0, "coarse net, subdivision, pull", until=0.3)
    cand = _candidate(V, T, None if coarse is None else (Vc, Fc), faces, layout, levels, max_faces, spread_boundary, timings)
    n_folds = 0 if coarse is not None else _candidate_folds(cand, (V, T))
    if n_folds:
        cand = _other_candidate(V, T, cand, n_folds, faces, layout, levels, max_faces, spread_boundary, timings,
                                warnings)
    (Vc, Fc), Xc, Qs, used_layout, pulled = cand.coarse, cand.X, cand.Q, cand.layout, cand.pulled
    warnings += cand.warnings
    cand_dist = pulled.distances_after
    cand_pl = quad_planarity(Xc, Qs)
    mean_edge = _mean_edge(Xc, Qs)
    res = None
    X = Xc
    progress.report(0.3, "planarize", until=0.9)
    if planarize:
        t = time.perf_counter()
        res = _planarized(Xc, Qs, (V, T), closeness_weight, fairness_weight=fairness_weight,
                          tolerance=tolerance, max_iterations=max_iterations, time_budget=time_budget)
        timings["planarize"] = time.perf_counter() - t
        warnings += list(res.warnings)
        t = time.perf_counter()
        X, frac, h1 = _healthy_state(Xc, res.mesh[0], Qs, tolerance)
        if frac < 1.0:
            res, warning = _backed_off(res, X, Qs, frac, h1, (V, T), tolerance)
            warnings.append(warning)
        timings["health"] = time.perf_counter() - t
    progress.report(0.9, "panel health")
    t = time.perf_counter()
    health = _health(X, Qs, tolerance, (V, T))
    timings["health"] = timings.get("health", 0.0) + time.perf_counter() - t
    healthy = shape_healthy(health, HEALTH_BOUNDS["min_coverage"])
    planarity = max_quad_planarity(X, Qs)
    reached = planarity <= tolerance
    if res is not None:  # the planarizer's own verdict (where it gives one) said of the returned state
        verdict = {"healthy": healthy, "coverage": float(health.coverage), "violations": list(health.violations),
                   "converged": bool(reached and healthy)}
        res = res._replace(**{k: v for k, v in verdict.items() if k in res._fields})
    said = "\n".join(warnings)  # what the planarizer (or the back-off) said already is not said twice
    warnings += [w for w in _verdict_warnings(health, planarity, tolerance, res is not None)
                 if w.split(': ', 1)[1] not in said and not ("planarity tolerance" in w and "× the tolerance" in said)]
    gap = boundary_gap_warning(V, T, mean_edge)  # a seam or a slit in the surface, at the size of the panels
    if gap:
        warnings.insert(0, gap)
    return SubdivisionPQ((Vc, Fc), (Xc, Qs), cand_pl, cand_dist, res, mean_edge, timings, warnings, used_layout,
                         health, healthy, float(health.coverage), list(health.violations), bool(reached and healthy))


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
    healthy: bool
    coverage: float
    violations: Texts
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
        map), "grid" (a regular grid between four boundary corners) or "auto" (the best ranked of them; the others
        with a warning if the field pipeline fails).

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
        Whether the planarity tolerance was reached and the result is healthy.
    coarse : Mesh
        The coarse net used (the given one, validated, or the automatic one).
    healthy : bool
        Whether the result is fabricable apart from planarity: no edge under 0.2 × the median edge, no face under
        0.1 × the median face area, no corner under 20° or over 160°, no non-convex, folded or crossing faces, and
        at least 85% of the surface covered.
    coverage : float
        Share of the design surface's area covered by the result, 0..1.
    violations : Texts
        One line per failed check of the result (planarity included), with the count and the worst value.

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
    the surface. The planarizer's guard keeps every edge over 0.2 × the median and every face over 0.1 × the
    median area, which costs closeness where the net is far from conjugate (measured, faces 36, 2 levels,
    resolution 20: converged and healthy on dome, saddle, wave, canopy and inspired_mesh, mean closeness 0.2%,
    2.3%, 9.9%, 6.7% and 7.3% of the mean edge, coverage 87–100%). A result that is not healthy (or covers less
    than 85% of the surface) is never reported converged: a warning names what is wrong.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 24)
    >>> res = pq_from_subdivision((V, T), levels=2)
    >>> res.converged, res.healthy, res.coverage > 0.85, res.violations
    (True, True, True, [])
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
    verdict = (out.healthy, out.coverage, out.violations, out.warnings)
    if res is None:
        ang = corner_angles(Xc, Q)
        return SubdivisionPQResult(
            (Xc, Q), float(cp.max()), float(cp.mean()), float(cd.max()), (Xc, Q), float(cp.max()), float(cp.mean()),
            float(cd.mean()), float(cd.max()), out.mean_edge, float(np.degrees(ang.min())),
            int(nonconvex_faces(Xc, Q).sum()), 0, out.converged, out.coarse, *verdict)
    return SubdivisionPQResult(
        (Xc, Q), float(cp.max()), float(cp.mean()), float(cd.max()), res.mesh, res.max_planarity,
        res.mean_planarity, res.mean_closeness, res.max_closeness, out.mean_edge, res.worst_corner_angle,
        res.nonconvex_faces, res.iterations, out.converged, out.coarse, *verdict)
