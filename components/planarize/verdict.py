"""The planarizer's verdict on its result: converged means "tolerance reached **and** healthy".

:func:`result_verdict` measures the returned mesh with :func:`components.metrics.health.face_health` at the guard's
thresholds (:func:`components.planarize.guard.health_bounds`: 20° corners, edges 0.2 × the median, faces 0.1 × the
median area, or the input's worst where that is already worse; with a reference also its coverage, at least
``opts.min_coverage``), and words what is wrong: one violation line per failed check (planarity first, when the
tolerance was not reached), and warnings that name the counts and say how far the tolerance is.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from components.core.measures import max_quad_planarity
from components.metrics.health import face_health

__all__ = ["Verdict", "result_verdict", "planarity_line", "healthy_backoff", "backed_off_reason"]

_NO_TOLERANCE = float(np.finfo(np.float64).max)  # planarity is not judged by the back-off
_BACKOFF_STEPS = 6  # bisection steps of the back-off to the last healthy state (1/64 of the way)


class Verdict(NamedTuple):
    """Health of the result and what the caller is told."""

    healthy: bool  # no health violation (planarity aside: that is the tolerance's)
    violations: list  # planarity line (tolerance not reached) + face_health's lines
    coverage: float  # covered share of the reference, -1 without one (the Hops convention of metrics/panel_health)
    warnings: list


def planarity_line(opts, pl, warp) -> str:
    """``"N of M faces above the tolerance …, worst … = k × the tolerance (face i)"`` (warping height in absolute
    mode), or ``""`` when every face meets it.

    Example
    -------
    >>> from components.planarize.problem import checked_options
    >>> planarity_line(checked_options(4), np.array([0.0, 3e-4, 5e-5]), np.zeros(3))
    '1 of 3 faces above the planarity tolerance 0.0001 (worst 0.0003 = 3 × the tolerance, face 1)'
    """
    if opts.use_abs:
        val, tol, what = warp, opts.absolute_tolerance, "warping-height tolerance"
    else:
        val, tol, what = pl, opts.tolerance, "planarity tolerance"
    above = val > tol
    if not above.any():
        return ""
    i = int(np.argmax(val))
    return (f"{int(above.sum())} of {len(val)} face{'s' if len(val) != 1 else ''} above the {what} {tol:g} "
            f"(worst {val[i]:.3g} = {val[i] / tol:.3g} × the tolerance, face {i})")


def result_verdict(prob, guard, run, X, reference, pl, warp, con, min_angle_out, n_ncv, offset=0.0) -> Verdict:
    """The verdict on the result ``X`` (model units, centred: ``X + offset`` are the returned positions, in the
    frame of ``reference``, the reference as given; faces ``prob.F``).

    ``pl`` / ``warp``: per-face planarity and warping height; ``con``: the largest conical criterion;
    ``min_angle_out``: the smallest corner angle (radians); ``n_ncv``: non-convex quad-like faces. The health is
    measured on the returned positions against the reference as given: a caller judging the same result against
    the same surface then shares its closest-point indexes (built once per content, see
    :class:`components.core.proximity.TriangleIndex`).
    """
    opts, bounds = prob.opts, guard.bounds
    # planarity is the tolerance's (the line below)
    h = face_health(X + offset, prob.F, reference, tolerance=_NO_TOLERANCE,
                    min_edge_ratio=bounds.min_edge_ratio, min_angle=bounds.min_angle,
                    min_area_ratio=bounds.min_area_ratio, min_coverage=opts.min_coverage)
    line = planarity_line(opts, pl, warp) if not run.converged else ""
    if not run.converged and not line:  # the conical criterion, or a tolerance met only in the score's rounding
        line = f"conical criterion {con:.3g} rad above its tolerance" if prob.conical_on else ""
    violations = ([line] if line else []) + list(h.violations)
    warnings = [f"planarize: {note}" for note in bounds.notes if _still_under(note, h, opts)]
    if not run.converged:
        state = "healthy" if h.healthy else "not healthy"
        warnings.append(f"tolerance not reached ({run.stop_reason}): {line or 'see the violations'}; the best "
                        f"{state} state was returned")
        if run.best.score >= run.start_score and run.it > 0:
            warnings.append("no iteration improved on the input; the input mesh was returned")
    if not h.healthy:
        warnings.append("panels not healthy: " + "; ".join(h.violations))
        if guard.n_nonconvex_in and h.counts.get("nonconvex", 0):
            warnings.append(f"the input already has {guard.n_nonconvex_in} non-convex face(s)")
        if len(guard.crossings_in) and h.counts.get("intersecting", 0):
            warnings.append(f"the input already has {len(guard.crossings_in)} pair(s) of crossing faces")
    min_angle_in = float(guard.angle_in.min()) if len(guard.angle_in) else math.pi
    if min_angle_out < min_angle_in - 1e-9 and min_angle_out < 0.75 * min_angle_in:
        warnings.append(f"worst corner angle degraded from {math.degrees(min_angle_in):.1f}° to "
                        f"{math.degrees(min_angle_out):.1f}°")
    if n_ncv > guard.n_nonconvex_in:
        warnings.append(f"non-convex faces increased from {guard.n_nonconvex_in} to {n_ncv}")
    coverage = -1.0 if np.isnan(h.coverage) else float(h.coverage)
    return Verdict(bool(h.healthy), violations, coverage, warnings)


def _shape_healthy(prob, guard, reference, X, offset) -> bool:
    """Healthy at the verdict's thresholds, planarity aside (measured like :func:`result_verdict`)."""
    b = guard.bounds
    return bool(face_health(X + offset, prob.F, reference, tolerance=_NO_TOLERANCE,
                            min_edge_ratio=b.min_edge_ratio, min_angle=b.min_angle, min_area_ratio=b.min_area_ratio,
                            min_coverage=prob.opts.min_coverage).healthy)


def healthy_backoff(prob, guard, reference, X0, X1, offset=0.0):
    """``(X, t)``: the healthy state ``X0 + t (X1 − X0)`` with the smallest max planarity, or ``None`` when the input
    ``X0`` is not healthy itself (then nothing healthier is on the way). ``X0``, ``X1`` and ``X`` are centred:
    their health is that of ``X + offset`` against ``reference`` (as in :func:`result_verdict`).

    The guard keeps every accepted step's panels healthy, but not the coverage of the reference (a global measure:
    a planar net pulled off a doubly curved surface by a relaxed closeness leaves parts of it uncovered) nor, at the
    last bit, every threshold of the verdict. The largest healthy ``t`` is found by bisection
    (:data:`_BACKOFF_STEPS` steps).
    """
    if not _shape_healthy(prob, guard, reference, X0, offset):
        return None
    best = (max_quad_planarity(X0, prob.F), 0.0)
    lo, hi = 0.0, 1.0
    for _ in range(_BACKOFF_STEPS):
        t = 0.5 * (lo + hi)
        X = X0 + t * (X1 - X0)
        if _shape_healthy(prob, guard, reference, X, offset):
            lo = t
            best = min(best, (max_quad_planarity(X, prob.F), t))
        else:
            hi = t
    t = best[1]
    return X0 + t * (X1 - X0), t


def backed_off_reason(stop_reason: str) -> str:
    """The stop reason of a run backed off to a healthy state: a "tolerance reached" was the unhealthy state's, not
    the returned one's.

    >>> backed_off_reason("tolerance reached"), backed_off_reason("stalled")
    ('only panels that were not healthy reached the tolerance', 'stalled')
    """
    return "only panels that were not healthy reached the tolerance" if stop_reason.startswith(
        "tolerance reached") else stop_reason


def _still_under(note: str, h, opts) -> bool:
    """Whether a note of :func:`components.planarize.guard.health_bounds` (the input was already under a bound, so
    the verdict allows less) still applies to the result ``h``: the solver lifts such items toward the bound."""
    if note.startswith("the input already has corners"):
        return bool(h.worst_corner < opts.min_angle or h.worst_corner > 180.0 - opts.min_angle)
    if note.startswith("the input already has edges"):
        return bool(h.shortest_edge_ratio < opts.min_edge_ratio)
    if note.startswith("the input already has faces"):
        return bool(len(h.area_ratio) and h.area_ratio.min() < opts.min_area_ratio)
    return True
