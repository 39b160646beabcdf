"""Panel-health guard of the planarization solver: which states are healthy, and which items get guard rows.

The solver may not collapse, pinch or fold a panel. :func:`panel_guard` derives the bounds from the input once
(``A = opts.min_angle``, ``g = opts.angle_guard``, medians of the input; all in the solver's normalized units, so
the bounds do not depend on the model's units or placement):

* **corners** (of every face convex in the input, triangles and n-gons included): a corner's sharpness, the
  distance of its angle to 0° or 180° (what the verdict measures, whether the face is planar or not), may not fall
  below ``lo = max(A, g·w)`` with ``w`` the quads' worst input corner: no corner under 20° (a corner that starts
  under it may lose at most 10 %), none under half the input's worst.
* **convexity**: a corner's signed turn (the sine of its angle about the face normal, negative at a reflex corner,
  :func:`~components.planarize.geometry.corner_turns`) may not fall below ``g ×`` the quads' worst input turn
  (nor below ``g ×`` its own): no watched face turns non-convex.
* **edges**: no edge shorter than ``ρe·median`` (``ρe = opts.min_edge_ratio``; one that starts shorter may lose at
  most 10 %, and has a row lifting it over ``ρe·median``) nor than ``g × `` its input length.
* **faces**: no face area under ``ρa·median`` (``ρa = opts.min_area_ratio``; one that starts smaller may lose at
  most 10 %, and has a row lifting it over the bound) nor under ``g² ×`` its input area.
* **folds**: two faces sharing an edge may not open by less than ``min(A, g × the input's smallest opening)``
  (their unit normals ``n1 · n2 ≥ −cos`` of that).
* **flips** (with an oriented reference): no face may turn its normal against the reference's normal under it
  (measured at the input, on the side most of the faces lie on), unless it was flipped in the input already: the
  verdict's "flipped" check, which a face sliding along a curved surface could otherwise fail at the end. A face
  turning within 10° of standing on edge (``n · r < sin 10°``) gets a row holding it at ``sin 5°`` (or where it
  started, if lower): without one, a step that turns it is only shortened, and on the 52k-triangle face scan
  (``face.obj``) every step along the same direction flipped the same face until the solver stopped.
* **crossings**: no face may cross or overlap a face it shares no vertex with, unless the two crossed in the
  input already (:func:`components.planarize.geometry.crossing_pairs`; tested last, only on states that pass the
  rest).

:func:`evaluate` measures a state (planarity score and health; ``State.failed`` names the failed guards). Corner
sharpness, corner turns, edges, faces, hinges (folds) and faces again (flips) are the guard's **items**, one vector
in that order (corners in :func:`components.core.mesh.face_corners` order, edges in
:func:`components.core.mesh.edge_topology` order, hinges in ``prob.inner_faces`` order): an item close to its bound
gets a hard row (:func:`components.planarize.rows.hard_rows`) that lifts it to a target just above the bound or
holds it (:func:`watched_rows`, :func:`rows_to_guard`). Crossings are only rejected: the line search shortens the
step.

:func:`health_bounds` turns the same bounds into the thresholds of the final verdict
(:func:`components.metrics.health.face_health`): ``A``, ``ρe``, ``ρa``, or 90 % of the input's worst values where
those are already worse.

Where further guards plug in: a bound derived from the input goes in :class:`PanelGuard` / :func:`panel_guard`,
its test in :func:`panel_health` (a failed test makes the state unhealthy: the line search shortens the step),
and, to correct rather than only reject, its rows as further items (:func:`rows_to_guard`,
:func:`components.planarize.rows.hard_rows`).

Example
-------
>>> from components.core.mesh import quad_grid
>>> from components.planarize.problem import checked_options, setup_problem
>>> V, F = quad_grid(3, 3, 3.0, 3.0)
>>> prob = setup_problem(V, F, None, checked_options(len(V)))
>>> guard = panel_guard(prob)
>>> round(float(np.degrees(guard.lo)), 6), bool(guard.guarded.all()), guard.n_items == 2 * 36 + 24 + 9 + 12 + 9
(45.0, True, True)
>>> st = evaluate(prob, guard, prob.X0, np.zeros((0, 3)))
>>> st.healthy, st.nonconvex, st.score, st.failed
(True, 0, 0.0, ())
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np

from components.core.measures import norm
from components.planarize.geometry import corner_turns, crossing_pairs, einsum_sum3, length3
from components.planarize.problem import planarity_excess, planarity_score

log = logging.getLogger(__name__)

__all__ = ["GUARDS", "PanelGuard", "HealthBounds", "panel_guard", "health_bounds", "State", "Health", "evaluate",
           "panel_health", "new_crossings", "crossing_checked", "watched_rows", "rows_to_guard", "log_unhealthy"]

#: the guards' names, as ``State.failed`` and the stop reason give them
GUARDS = ("corner", "convexity", "edge", "area", "fold", "flip", "crossing")
_DEGENERATE = 1e-9  # a face under this share of the input's median area is collapsed (has no normal)
_DRIFT = 0.15  # room for the result's median edge to grow over the input's before the verdict's bound is missed
_MIN_LIFT = 0.2  # a corner's row acts this share of the margin under its start, and at least as far over its bound
_WORSEN = 0.1  # an item (corner, edge, face) that starts under its bound may lose at most this share of its value
_EDGE_MARGIN = (1.10, 1.05)  # an edge below (act, target) × its bound gets a row lifting it to the target
_AREA_MARGIN = (1.20, 1.10)
_FOLD_MARGIN = (math.radians(10.0), math.radians(5.0))  # (act, target) openings above the fold bound
_FLIP_MARGIN = (math.radians(10.0), math.radians(5.0))  # (act, target) angles of a face over standing on edge


class HealthBounds(NamedTuple):
    """Thresholds of the final verdict: the options', or 90 % of the input's worst values where those are worse."""

    min_angle: float  # degrees
    min_edge_ratio: float  # × median edge
    min_area_ratio: float  # × median face area
    notes: list  # one line per threshold lowered to the input's value


class PanelGuard(NamedTuple):
    """Bounds of the panel-health guard (normalized units)."""

    quad_like: np.ndarray  # (m,) bool, faces with four or more corners
    guarded: np.ndarray  # (c,) bool, corners the guard watches (of faces convex in the input)
    turn_in: np.ndarray  # (c,) input corner turns
    angle_in: np.ndarray  # (c,) input corner angles
    n_nonconvex_in: int  # quad-like faces non-convex in the input
    lo: float  # the quads' corner bound (radians)
    angle_floor: np.ndarray  # (c,) the smallest sharpness (distance to 0° or 180°) a healthy corner may have
    turn_min: np.ndarray  # (c,) the smallest turn a healthy corner may have (convexity)
    len_in: np.ndarray  # (e,) input edge lengths (edges of ``prob.E``)
    len_min: np.ndarray  # (e,) the shortest an edge may get
    area_in: np.ndarray  # (m,) input face areas
    area_min: np.ndarray  # (m,) the smallest a face may get
    item_on: np.ndarray  # (2c + e + m + i + m,) bool, items that may get a guard row
    item_min: np.ndarray  # bound of every item's value (sharpness, turn, length, area, n1·n2 across an edge, n·r)
    item_act: np.ndarray  # an item below this value gets a guard row
    item_tgt: np.ndarray  # a guard row lifts its item to this value
    fold_faces: np.ndarray  # (i, 2) the two faces of every interior edge (``prob.inner_faces``)
    open_min: float  # the smallest opening (radians) between two faces sharing an edge
    crossings_in: np.ndarray  # (p,) int64 keys ``a · m + b`` of face pairs crossing in the input
    bounds: HealthBounds
    flip_normals: np.ndarray | None = None  # (m, 3) the reference's unit normals under the input faces (oriented
    flip_on: np.ndarray | None = None  # like the majority of the faces) and the faces not flipped in the input
    area_eps: float = 0.0  # a face with no more area than this has no normal (its fold and flip values are 0)

    @property
    def n_items(self) -> int:
        return len(self.item_on)


def panel_guard(prob) -> PanelGuard:
    """The guard's bounds for a :class:`components.planarize.problem.Problem` (see the module docstring)."""
    opts, corners, F = prob.opts, prob.corners, prob.F
    g, A = opts.angle_guard, math.radians(opts.min_angle)
    quad_like = prob.sizes >= 4
    An0 = prob.frames.normals(prob.X0, unit=False)
    area_in = np.linalg.norm(An0, axis=1)
    N0 = An0 / np.where(area_in > 0, area_in, np.inf)[:, None]
    turn_in, angle_in = corner_turns(prob.X0, corners, N0)
    ncv_in_face = np.zeros(len(F), dtype=bool)
    ncv_in_face[corners.face[turn_in <= 0]] = True
    ncv_in_face |= ~(area_in > 0)
    guarded = ~ncv_in_face[corners.face]
    ref_corners = guarded & (prob.sizes[corners.face] == 4)
    if not ref_corners.any():
        ref_corners = guarded
    sharp_in = np.minimum(angle_in, math.pi - angle_in)  # distance to 0° or 180°: what the verdict measures
    w = float(sharp_in[ref_corners].min()) if ref_corners.any() else math.pi / 2
    lo = max(A if w >= A else (1.0 - _WORSEN) * w, g * w)  # the quads' worst corner's bound
    floor = np.maximum(np.where(sharp_in >= A, A, (1.0 - _WORSEN) * sharp_in),
                       np.minimum(g * w, (1.0 - _WORSEN) * sharp_in))
    # a corner's row acts once the corner is within the margin (5°, or half its bound) of its bound and has lost a
    # fifth of the margin from where it started, and lifts it halfway from the bound to where the row acts: at
    # least a tenth of the margin over the bound (a corner that starts just over it, e.g. at 20.04°, had its target
    # 0.02° over it, under a step's second-order error: an 80k-triangle canopy crawled 49 iterations at steps of
    # 1/64), and not at the value it starts at (whether such a row acts at the first step was the round-off of
    # the input: other paths in m and in mm)
    margin = np.minimum(math.radians(5.0), 0.5 * floor)
    sharp_act = np.clip(np.maximum(sharp_in, floor) - _MIN_LIFT * margin, floor + _MIN_LIFT * margin, floor + margin)
    sharp_tgt = floor + 0.5 * (sharp_act - floor)
    # turns (convexity): a corner's turn may not fall below sin(g × the quads' worst turn), nor below g × its own
    lo_t = g * float(np.arcsin(np.clip(turn_in[ref_corners], 0.0, 1.0)).min()) if ref_corners.any() else 0.0
    margin_t = min(math.radians(5.0), 0.5 * lo_t)
    turn_min = np.minimum(math.sin(lo_t), g * np.clip(turn_in, 0.0, 1.0))
    turn_act = turn_min + (math.sin(lo_t + margin_t) - math.sin(lo_t))
    turn_tgt = turn_min + (math.sin(lo_t + 0.5 * margin_t) - math.sin(lo_t))
    len_in = np.linalg.norm(prob.X0[prob.E[:, 1]] - prob.X0[prob.E[:, 0]], axis=1)
    len_min = _item_bound(len_in, opts.min_edge_ratio * (1.0 + _DRIFT), g)
    area_min = _item_bound(area_in, opts.min_area_ratio * (1.0 + _DRIFT) ** 2, g * g)
    # an edge or face that starts under the verdict's bound gets a row lifting it over the bound (it may not lose
    # more than 10 % on the way): the verdict judges the result by the bound, not by the input
    len_lift = np.maximum(len_min, _median_bound(len_in, opts.min_edge_ratio * (1.0 + _DRIFT)))
    area_lift = np.maximum(area_min, _median_bound(area_in, opts.min_area_ratio * (1.0 + _DRIFT) ** 2))
    fold_faces = prob.inner_faces
    cos_in = np.einsum("ij,ij->i", N0[fold_faces[:, 0]], N0[fold_faces[:, 1]])
    opening_in = math.pi - np.arccos(np.clip(cos_in, -1.0, 1.0))
    open_min = min(A, g * float(opening_in.min())) if len(opening_in) else A
    fold_min = np.full(len(fold_faces), -math.cos(open_min))
    fold_act = np.full(len(fold_faces), -math.cos(open_min + _FOLD_MARGIN[0]))
    fold_tgt = np.full(len(fold_faces), -math.cos(open_min + _FOLD_MARGIN[1]))
    cross_in = _crossings(prob, prob.X0)
    on_c = guarded
    flip = _flip_watch(prob, N0, area_in)
    flip_on = flip.get("flip_on", np.zeros(len(F), dtype=bool))
    flip_in = _flip_dots(N0, flip.get("flip_normals"))
    flip_act = np.full(len(F), math.sin(_FLIP_MARGIN[0]))
    flip_tgt = np.minimum(math.sin(_FLIP_MARGIN[1]), flip_in)
    return PanelGuard(
        quad_like=quad_like, guarded=guarded, turn_in=turn_in, angle_in=angle_in,
        n_nonconvex_in=int(ncv_in_face[quad_like].sum()), lo=lo, angle_floor=floor, turn_min=turn_min,
        len_in=len_in, len_min=len_min, area_in=area_in, area_min=area_min,
        item_on=np.concatenate([on_c, on_c, np.ones(len(len_in) + len(area_in) + len(fold_faces), bool),
                                flip_on]),
        item_min=np.concatenate([floor, turn_min, len_min, area_min, fold_min, np.zeros(len(F))]),
        item_act=np.concatenate([sharp_act, turn_act, _EDGE_MARGIN[0] * len_lift, _AREA_MARGIN[0] * area_lift,
                                 fold_act, flip_act]),
        item_tgt=np.concatenate([sharp_tgt, turn_tgt, _EDGE_MARGIN[1] * len_lift, _AREA_MARGIN[1] * area_lift,
                                 fold_tgt, flip_tgt]),
        fold_faces=fold_faces, open_min=open_min, crossings_in=cross_in[:, 0] * len(F) + cross_in[:, 1],
        bounds=health_bounds(opts, angle_in, len_in, area_in),
        area_eps=_DEGENERATE * float(np.median(area_in)) if len(area_in) else 0.0, **flip)


def _flip_dots(N, flip_normals) -> np.ndarray:
    """``n · r`` of every face's unit normal ``N`` with the reference's normal under it (ones without a flip guard),
    component by component (1-D gathers) in the numbers of ``np.einsum("ij,ij->i", ...)`` on the rows."""
    if flip_normals is None:
        return np.ones(len(N))
    return einsum_sum3(*(np.ascontiguousarray(N[:, j]) * flip_normals[:, j] for j in range(3)))


def _flip_watch(prob, N0, area_in) -> dict:
    """The flip guard's data (with an oriented reference): the reference's unit normal at the closest point of
    every input face's centroid (on a reference edge or vertex its normal there, not one face's), turned to the side
    most of the face area lies on (as the verdict's "flipped" check of :func:`components.metrics.health.face_health`
    does), and the faces on that side in the input. A
    face whose normal turns against its normal there is flipped: the verdict would find it so (faces slide by at
    most a few edges, where a smooth reference's normal turns little)."""
    if prob.ref_index is None or not prob.ref_index.oriented or len(prob.F) == 0:
        return {}
    C = prob.corners
    cent = np.stack([np.bincount(C.face, prob.X0[C.v, j], minlength=len(prob.F)) for j in range(3)], axis=1)
    cent /= np.bincount(C.face, minlength=len(prob.F))[:, None]
    rn = prob.reference_normals(prob.ref_index.query(cent), np.arange(len(cent)))  # ties as the closeness goal's
    side = np.einsum("ij,ij->i", N0, rn)
    good = area_in > 0
    majority = 1.0 if float(np.sum(area_in[good] * np.sign(side[good]))) >= 0.0 else -1.0
    return dict(flip_normals=majority * rn, flip_on=good & (majority * side > 0.0))


def _median_bound(own, ratio_of_median) -> float:
    """``ratio × median`` of the items' input values (0 without items)."""
    return ratio_of_median * float(np.median(own)) if len(own) else 0.0


def _item_bound(own, ratio_of_median, own_fraction) -> np.ndarray:
    """``max(B, min(fraction, 0.9) × own)`` per item with ``B = ratio × median`` (``0.9 × own`` for an item already
    under ``B``): not under the bound, nor under the fraction of its own input value; an item that starts under the
    bound may lose at most 10 % (some slack: a guard without any cannot be met while the rest of the mesh moves)."""
    if len(own) == 0:
        return own.copy()
    B = ratio_of_median * float(np.median(own))
    return np.maximum(np.where(own >= B, B, (1.0 - _WORSEN) * own), min(own_fraction, 1.0 - _WORSEN) * own)


def health_bounds(opts, angle_in, len_in, area_in) -> HealthBounds:
    """The verdict's thresholds: ``opts.min_angle``, ``opts.min_edge_ratio``, ``opts.min_area_ratio``, each lowered
    to 90 % of the input's worst value (corner angle's distance to 0° or 180° in degrees, shortest edge / median
    edge, smallest area / median area) when that is already under the bound, with a note saying so: what the guard
    lets such an item become.

    Example
    -------
    >>> from components.planarize.problem import checked_options
    >>> hb = health_bounds(checked_options(4), np.radians([90.0, 10.0]), np.array([1.0, 1.0, 0.1]),
    ...                    np.array([1.0, 1.0]))
    >>> round(hb.min_angle, 3), round(hb.min_edge_ratio, 3), hb.min_area_ratio, len(hb.notes)
    (9.0, 0.078, 0.1, 2)
    """
    keep = 1.0 - _WORSEN
    notes = []
    worst = float(np.degrees(np.minimum(angle_in, np.pi - angle_in)).min()) if len(angle_in) else 90.0
    min_angle = opts.min_angle
    if worst < min_angle:
        min_angle = keep * worst * (1.0 - 1e-9)
        notes.append(f"the input already has corners of {worst:.3g}° (bound {opts.min_angle:g}°): they may lose at "
                     f"most {_WORSEN:.0%}, and the health check allows {min_angle:.3g}°")
    min_edge = _lowered(opts.min_edge_ratio, len_in, 1.0 + _DRIFT)
    if min_edge < opts.min_edge_ratio:
        notes.append(f"the input already has edges of {min_edge / keep * (1.0 + _DRIFT):.3g} × the median (bound "
                     f"{opts.min_edge_ratio:g}): they may lose at most {_WORSEN:.0%}, and the health check allows "
                     f"{min_edge:.3g}")
    min_area = _lowered(opts.min_area_ratio, area_in, (1.0 + _DRIFT) ** 2)
    if min_area < opts.min_area_ratio:
        notes.append(f"the input already has faces of {min_area / keep * (1.0 + _DRIFT) ** 2:.3g} × the median area "
                     f"(bound {opts.min_area_ratio:g}): they may lose at most {_WORSEN:.0%}, and the health check "
                     f"allows {min_area:.3g}")
    return HealthBounds(min_angle, min_edge, min_area, notes)


def _lowered(ratio, own, drift) -> float:
    """The verdict's ratio for items (lengths or areas) bounded by :func:`_item_bound` with ``ratio × drift``: the
    ratio, or 90 % of the smallest input item over the median allowed to grow by ``drift``."""
    if len(own) == 0:
        return ratio
    med = float(np.median(own))
    smallest = float(own.min())
    if smallest >= ratio * drift * med:
        return ratio
    return min(ratio, (1.0 - _WORSEN) * smallest / (drift * med) * (1.0 - 1e-9))


class State(NamedTuple):
    """A candidate state and what the acceptance tests need."""

    X: np.ndarray
    tangents: np.ndarray  # unit tangents of the boundary segments under the sliding vertices
    score: float  # max over faces of planarity / tolerance (and conical criterion / its tolerance)
    turn: np.ndarray  # corner turns (sine of the interior angle, signed)
    angle: np.ndarray  # unsigned corner angles
    nonconvex: int  # faces with a corner turning the wrong way (among the guarded faces)
    healthy: bool
    planarity: np.ndarray  # (m,) the reported scale-free planarity of every face
    values: np.ndarray | None = None  # (2c + e + m + i + m,) the items' values: sharpness, turns, lengths, areas,
    # folds, flips
    failed: tuple = ()  # the guards (of GUARDS) the state fails
    excess: float = 0.0  # Σ max(planarity / tolerance − 1, 0)² (problem.planarity_excess)


class Health(NamedTuple):
    """What :func:`panel_health` measured."""

    turn: np.ndarray
    angle: np.ndarray
    sharpness: np.ndarray  # (c,) distance of every corner angle to 0° or 180°
    lengths: np.ndarray
    areas: np.ndarray
    folds: np.ndarray  # (i,) n1 · n2 across every interior edge
    flips: np.ndarray  # (m,) n · r of every face with the reference's normal under it (ones without a flip guard)
    nonconvex: int  # non-convex quad-like faces (those of the input included)
    failed: tuple


def _crossings(prob, X) -> np.ndarray:
    """:func:`~components.planarize.geometry.crossing_pairs` at ``X`` (through the problem's watch, when it has one)."""
    return crossing_pairs(X, prob.F, prob.sizes) if prob.crossings is None else prob.crossings.pairs(X)


def new_crossings(prob, guard: PanelGuard, X) -> bool:
    """Whether a face at ``X`` crosses a face it shares no vertex with (and did not cross in the input)."""
    pairs = _crossings(prob, X)
    return bool(len(pairs)) and not np.isin(pairs[:, 0] * len(prob.F) + pairs[:, 1], guard.crossings_in).all()


def panel_health(prob, guard: PanelGuard, X, crossings: bool = True) -> Health:
    """Corner turns and angles, edge lengths, face areas, the non-convex count, and the guards ``X`` fails (the
    crossing test, the costly one, only when every other guard passes, and only with ``crossings``)."""
    An = prob.frames.normals(X, unit=False)
    areas = norm(An)
    # a face collapsed to round-off has no normal: none at all, rather than one as random as its round-off (its
    # fold and flip values 0 in m and in mm alike; which guard rows a collapsing trial adds must not depend on it)
    N = An / np.where(areas > guard.area_eps, areas, np.inf)[:, None]
    turn, ang = prob.frames.turns(X, N)
    x, y, z = np.ascontiguousarray(X.T)
    E0, E1 = prob.E.T
    dx, dy, dz = x[E1] - x[E0], y[E1] - y[E0], z[E1] - z[E0]
    lengths = length3(dx, dy, dz)
    g = guard.guarded
    ncv = np.zeros(len(prob.F), dtype=bool)
    ncv[prob.corners.face[(turn <= 0) & g]] = True
    failed = []
    sharp = np.minimum(ang, math.pi - ang)
    if np.any((sharp < guard.angle_floor) & g):
        failed.append("corner")
    if ncv.any() or np.any((turn < guard.turn_min) & g):
        failed.append("convexity")
    if np.any(lengths < guard.len_min):
        failed.append("edge")
    if np.any(areas < guard.area_min):
        failed.append("area")
    # n1 · n2 across the interior edges, and n · the reference's normal, component by component (1-D gathers) in
    # the numbers of np.einsum("ij,ij->i", ...) on the rows
    Nc = [np.ascontiguousarray(N[:, j]) for j in range(3)]
    f0, f1 = (np.ascontiguousarray(guard.fold_faces[:, i]) for i in range(2))
    dots = einsum_sum3(*(n[f0] * n[f1] for n in Nc))
    if np.any(dots < -math.cos(guard.open_min)):
        failed.append("fold")
    flips = _flip_dots(N, guard.flip_normals)
    if guard.flip_on is not None and np.any((flips < 0.0) & guard.flip_on):
        failed.append("flip")
    if not failed and crossings and new_crossings(prob, guard, X):
        failed.append("crossing")
    return Health(turn, ang, sharp, lengths, areas, dots, flips,
                  int(ncv[guard.quad_like].sum()) + guard.n_nonconvex_in, tuple(failed))


def evaluate(prob, guard: PanelGuard, X, tangents, crossings: bool = True) -> State:
    """The :class:`State` at positions ``X`` (normalized units; ``tangents`` of the sliding vertices); without
    ``crossings`` the crossing guard is left to :func:`crossing_checked` (the line search runs it only on the trial
    it would take)."""
    score, pl = planarity_score(prob, X)
    h = panel_health(prob, guard, X, crossings)
    return State(X, tangents, score, h.turn, h.angle, h.nonconvex, not h.failed, pl,
                 np.concatenate([h.sharpness, h.turn, h.lengths, h.areas, h.folds, h.flips]), h.failed,
                 planarity_excess(prob, X, pl))


def crossing_checked(prob, guard: PanelGuard, state: State) -> State:
    """``state`` (evaluated without the crossing test), made unhealthy when it has a new crossing."""
    if state.healthy and new_crossings(prob, guard, state.X):
        return state._replace(healthy=False, failed=("crossing",))
    return state


def watched_rows(guard: PanelGuard, values, sticky) -> np.ndarray:
    """``(2c + e + m + i + m,) bool``: the items that start a step with a guard row: close to their bound at
    ``values``, or kept (``sticky``) from earlier steps while still within twice that margin (a row held far from its
    bound only over-constrains the step)."""
    band = values < 2.0 * guard.item_act - guard.item_min  # twice the margin: a kept row far from its bound goes
    return guard.item_on & ((values < guard.item_act) | (sticky & band))


def rows_to_guard(guard: PanelGuard, trial: State, guard_sel) -> np.ndarray:
    """``(2c + e + m + i + m,) bool``: items without a guard row (``guard_sel``) that an unhealthy ``trial`` pushed
    close to or below a bound: the step is solved again with rows for them."""
    return guard.item_on & (trial.values < guard.item_act) & ~guard_sel


def log_unhealthy(guard: PanelGuard, trial: State, beta, t):
    """Debug log line of a trial the guard rejected."""
    if log.isEnabledFor(logging.DEBUG):
        c = len(guard.guarded)
        slack = (trial.values - guard.item_min)[guard.item_on]
        log.debug("   unhealthy beta %.3g t %.3g (%s): worst corner slack %.3g°, worst slack %.3g, ncv %d", beta, t,
                  ", ".join(trial.failed), math.degrees(float((trial.values[:c] - guard.angle_floor)[
                      guard.guarded].min())) if guard.guarded.any() else 0.0, float(slack.min()), trial.nonconvex)
