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

from components.metrics.health import face_health

__all__ = ["Verdict", "result_verdict", "planarity_line"]


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


def result_verdict(prob, guard, run, X, reference, pl, warp, con, min_angle_out, n_ncv) -> Verdict:
    """The verdict on the result ``X`` (model units, centred like ``reference``; faces ``prob.F``).

    ``pl`` / ``warp``: per-face planarity and warping height; ``con``: the largest conical criterion;
    ``min_angle_out``: the smallest corner angle (radians); ``n_ncv``: non-convex quad-like faces.
    """
    opts, bounds = prob.opts, guard.bounds
    h = face_health(X, prob.F, reference, tolerance=1.000001 * float(pl.max()) if len(pl) else 0.0,
                    min_edge_ratio=bounds.min_edge_ratio, min_angle=bounds.min_angle,
                    min_area_ratio=bounds.min_area_ratio, min_coverage=opts.min_coverage)
    line = planarity_line(opts, pl, warp) if not run.converged else ""
    if not run.converged and not line:  # the conical criterion, or a tolerance met only in the score's rounding
        line = f"conical criterion {con:.3g} rad above its tolerance" if prob.conical_on else ""
    violations = ([line] if line else []) + list(h.violations)
    warnings = [f"planarize: {note}" for note in bounds.notes]
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
