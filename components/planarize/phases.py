"""Phases and outer loop of the planarization solver: continuation, stopping, the best state.

Phases: *restore* (feasibility steps with backtracking until the tolerance is met: planarity converges
quadratically), *optimize* (``Δf + tΔo`` while planarity stays within ``κ ×`` the tolerance and the soft objective
decreases: this walks along the planar meshes toward the smallest displacement / closest fit / fairest net; a step
is only taken while the quadratic model, solved with the previous iteration's factorization, promises at least 1 %
of the objective and as much as moving every vertex 1 % of an edge), *polish* (feasibility steps back below the
tolerance). The phases switch on progress (the tolerance met, the optimize phase's tests), and on the clock only
where the time budget runs out: the optimize phase does not start, or stops, when the budget no longer holds
``_RESERVE`` more iterations as long as the latest ones (the polish needs them). A loaded machine gets the result
of a quiet one as long as the budget lasts (it used to skip the optimize phase past half of the budget). The best
state seen is kept: the returned one is never worse than the input in planarity, and when
the tolerance was met once, the state that met it with the smallest soft objective wins over a later one that
does not.

Without a reference the restore phase corrects in the plain metric (closeness stiffness 0; the optimize phase
judges closeness at the given one): the stiffness of the start's tangent planes made in-surface moves the cheap
ones, and the minimum-norm correction of a noisy net sheared it (60² grid, ±3 % noise: worst corner 87° → 62° after
restore, 75° after optimize, 10 iterations; in the plain metric 70° after restore, 84° after optimize, 4
iterations). With a reference the surface decides: its stiff metric stays (conjugate nets must move within it).

When the panel-health guard holds the restore phase (accepted steps under a quarter of the Gauss-Newton step, or no
healthy step at all), the closeness stiffness is relaxed (÷3 at a time, to 1/100 of the given one), then, where the
caller allows it (``relaxed_guard``), the guard's share of the input's own values: a stiff closeness metric leaves
the planarity correction only the directions within the surface, where it shears the net into the guard. Held at
that floor, a step that would move a few vertices far (their linearized rows nearly contradict each other) first
re-solves with their guard rows released (:mod:`components.planarize.step`): on the 200k-triangle benchmark patch,
seed 1, the restore phase crawled at β 0.001-0.04 for 100 iterations (1.8e-3) and now converges in 62. A restore or
polish iteration whose damped step (:func:`components.planarize.step.damping`) finds no acceptable trial tries the
undamped one before anything else gives way. The optimize phase runs at the full stiffness again and pulls the
planar mesh back toward the surface; an optimize step blocked by the planarity band is followed by a polish and
another optimize phase (up to ``_OPT_ROUNDS``).

Example
-------
>>> import time
>>> from components.core.mesh import quad_grid
>>> from components.planarize.guard import panel_guard
>>> from components.planarize.problem import checked_options, setup_problem
>>> V, F = quad_grid(4, 4, 4.0, 4.0)
>>> V[:, 2] = 0.05 * V[:, 0] * V[:, 1]
>>> prob = setup_problem(V, F, None, checked_options(len(V)))
>>> run = iterate(prob, panel_guard(prob), time.perf_counter())
>>> run.converged, run.stop_reason, final_state(run).score <= 1.0
(True, 'tolerance reached', True)
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from components.core import progress
from components.planarize.guard import PanelGuard, State, evaluate, panel_guard
from components.planarize.problem import closeness
from components.planarize.rows import soft_terms
from components.planarize.step import Factorization, Step, predicted_gain, solve_step

log = logging.getLogger(__name__)

__all__ = ["Run", "start", "iterate", "final_state"]

_OPT_STEP = 1e-3  # optimize phase ends when the optimality step moves no vertex more than this (mean edges)
_OPT_DECREASE = 0.01  # optimize phase ends when an iteration lowers the soft objective by less than this fraction
_OPT_MIN_MOVE = 0.01  # ... or promises less than moving every vertex this far (mean edges) would (½ d² each)
_STALL = 10  # iterations without improvement before giving up
_SLOW = 0.01  # ... or without the worst face improving by this fraction
_RESERVE = 3  # iterations of the time budget kept for the polish: the optimize phase stops (or does not start) short
_OPT_ROUNDS = 3  # optimize phases (each followed by a polish) when an optimize step is blocked by the band
_HELD_BETA = 0.25  # restore phase: an accepted step shorter than this fraction of the feasibility step is held
_HELD_STEPS = 3  # ... this many held steps in a row relax the closeness stiffness
_RELAX_CLOSENESS = 1.0 / 3.0  # factor of one relaxation


@dataclass
class Run:
    """The outer loop's state."""

    t0: float  # perf_counter at the start of the call (the time budget counts from here)
    cur: State
    best: State  # lowest score seen
    start_score: float
    sticky: np.ndarray  # (2c + e + m + i + m,) bool, guard items whose rows are kept from step to step
    hist: dict = field(default_factory=lambda: dict(maxp=[], meanp=[], maxc=[], meanc=[], t=[]))
    converged: bool = False
    stop_reason: str = ""
    it: int = 0
    phase: str = "restore"
    t_opt: float = 1.0  # fraction of the optimality step the next optimize step tries first
    opt_its: int = 0
    since_best: int = 0
    mark: float = float("inf")  # the worst-face score the next 1 % of progress is measured from
    since_mark: int = 0  # iterations since the score last dropped 1 % below the mark
    guard_reset: bool = False  # the sticky guard rows were dropped once after a failed step
    feasible_best: tuple | None = None  # (state, soft objective) of the best state that met the tolerance
    soft_cache: tuple | None = None  # (X, soft_terms(X)) of the current state, when the optimize test computed it
    last_fact: Factorization | None = None  # of the latest accepted step
    blocked_by: tuple = ()  # the guards that rejected the last trials of a failed step
    alpha_full: float = 0.0  # the closeness stiffness asked for (``prob.alpha`` is lowered while the guard holds)
    held: int = 0  # restore steps in a row shorter than ``_HELD_BETA``
    relaxed_to: float = 1.0  # the lowest share of the closeness stiffness the restore phase used
    guard: PanelGuard | None = None  # the guard in force (its relative bounds may be relaxed once)
    opt_rounds: int = 0  # optimize phases started
    opt_again: bool = False  # the last optimize phase ended on a blocked step, not on a small gain: polish, go on

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0


def _record(prob, run: Run, st: State):
    """Append the planarity and closeness of ``st`` and the elapsed time to the history."""
    pl, cl = st.planarity, closeness(prob, st.X)
    run.hist["maxp"].append(float(pl.max()))
    run.hist["meanp"].append(float(pl.mean()))
    run.hist["maxc"].append(float(cl.max()))
    run.hist["meanc"].append(float(cl.mean()))
    run.hist["t"].append(run.elapsed())


def start(prob, guard, t0: float) -> Run:
    """The run at the input (sliding vertices put on their loops), before any step."""
    Xs, tangents = prob.project_slide(prob.X0)
    cur = evaluate(prob, guard, Xs, tangents)
    run = Run(t0=t0, cur=cur, best=cur, start_score=cur.score, sticky=np.zeros(guard.n_items, dtype=bool),
              alpha_full=prob.alpha, guard=guard)
    if prob.XR is None:  # no reference: the restore phase corrects in the plain metric (see the module docstring)
        prob.alpha = 0.0
    _record(prob, run, cur)
    run.converged = cur.score <= 1.0
    if run.converged:
        run.stop_reason = "tolerance reached (input already planar)"
    if prob.ndof == 0 and not run.converged:
        run.stop_reason = "no free vertex to move"
    return run


def _to_polish(run: Run):
    run.phase = "polish"
    run.since_best = 0
    run.converged = run.cur.score <= 1.0


def _optimize_promises_enough(prob, run: Run) -> bool:
    """Whether the next optimize step promises enough (the soft terms at the current state are cached)."""
    run.soft_cache = (run.cur.X, soft_terms(prob, run.cur.X))
    gain, f_here = predicted_gain(prob, run.cur.X, run.soft_cache[1], run.last_fact)
    log.debug("   optimize test: predicted gain %.4g of f %.6g (%.3g%%)", gain, f_here,
              100 * gain / max(f_here, 1e-300))
    if gain < 0.0:  # the model is off (the guard rows of the last step hold items that moved since): try a step
        return True
    return not (gain < _OPT_DECREASE * f_here or gain < 0.5 * _OPT_MIN_MOVE**2 * prob.ndof / 3.0)


def iterate(prob, guard, t0: float) -> Run:
    """Run the phases until a stop reason is set; see :func:`final_state` for the state to return."""
    opts = prob.opts
    run = start(prob, guard, t0)
    while not run.stop_reason:
        progress.report(run.elapsed() / max(opts.time_budget, 1e-3), f"planarize, iteration {run.it}")
        if run.converged:
            if run.phase == "restore" and opts.optimize_iterations > 0 and _time_left(run, opts, _RESERVE + 1):
                run.phase = "optimize"
                run.opt_rounds = 1
                _restore_closeness(prob, run)
            elif (run.phase == "polish" and run.opt_again and run.opt_its < opts.optimize_iterations
                  and _time_left(run, opts, _RESERVE + 1)):
                run.phase, run.opt_again, run.t_opt = "optimize", False, 1.0
                run.opt_rounds += 1
            elif run.phase != "optimize":
                run.stop_reason = "tolerance reached"
                break
        if run.phase == "optimize" and run.last_fact is not None and not _optimize_promises_enough(prob, run):
            _to_polish(run)  # the next optimize step promises too little: polish (when needed) and stop
            continue
        if run.phase == "optimize" and not _time_left(run, opts, _RESERVE):
            _to_polish(run)  # the budget would run out before the polish: polish now
            continue
        if run.it >= opts.max_iterations:
            run.stop_reason = f"iteration cap ({opts.max_iterations}) reached"
            break
        if run.elapsed() > opts.time_budget:
            run.stop_reason = f"time budget ({opts.time_budget:g} s) reached"
            break
        X = run.cur.X
        soft = run.soft_cache[1] if run.soft_cache is not None and run.soft_cache[0] is X else soft_terms(prob, X)
        run.soft_cache = None
        optimize = run.phase == "optimize"
        # the restore phase held at its closeness floor: the guard rows of far-moving vertices are released
        release_far = run.phase == "restore" and run.held >= 1 and not _can_relax_closeness(prob, run)
        step = solve_step(prob, run.guard, run.cur, soft, run.sticky, run.t_opt if optimize else 0.0, optimize,
                          release_far)
        if step.accepted is None and not step.singular and not optimize:  # no damped step: Gauss-Newton's
            step = solve_step(prob, run.guard, run.cur, soft, run.sticky, 0.0, False, release_far, damped=False)
        if step.singular:
            run.stop_reason = "the linear system is singular (coincident vertices or collapsed faces in the mesh)"
            break
        if step.accepted is None:
            run.blocked_by = step.failed
            if optimize:  # no soft progress within the tolerance band from here: polish, then optimize again
                _to_polish(run)  # (the band is measured from the polished state) while rounds remain
                run.opt_again = run.opt_rounds < _OPT_ROUNDS
                continue
            if run.sticky.any() and not run.guard_reset:  # the guard rows kept from earlier steps may be what
                run.sticky[:] = False  # blocks this one: retry once with only the corners the state needs
                run.guard_reset = True
                continue
            if _relax_closeness(prob, run):  # a softer metric gives the correction room within the guard
                continue
            if run.best.score <= 1.0:
                run.stop_reason = "no further progress"
            elif step.failed:
                run.stop_reason = f"no step keeps the panels healthy ({' / '.join(step.failed)} guard)"
            else:
                run.stop_reason = "no step lowers the planarity further"
            break
        _advance(prob, run, step, soft[2], optimize)
    return run


def _time_left(run: Run, opts, iterations: int) -> bool:
    """Whether the time budget still holds ``iterations`` more iterations as long as the longest of the last three
    (always, before any: the switch depends on progress, and on the clock only when the budget runs out)."""
    t = run.hist["t"]
    if len(t) < 2:
        return True
    longest = float(np.max(np.diff(t[-4:])))
    return run.elapsed() + iterations * longest <= opts.time_budget


def _advance(prob, run: Run, step: Step, f_cur: float, optimize: bool):
    """Take the accepted step: history, best states, phase change or stall."""
    opts = prob.opts
    run.guard_reset = False
    run.it += 1
    run.cur = cur = step.accepted
    run.last_fact = step.fact
    _record(prob, run, cur)
    step_opt = step.t * float(np.abs(step.do).max()) if optimize else 0.0
    log.debug("planarize it %d (%s): score %.3g max %.3e t %.3g beta %.3g opt step %.2e guard rows %d",
              run.it, run.phase, cur.score, run.hist["maxp"][-1], step.t, step.beta, step_opt,
              int(step.guard_sel.sum()))
    if cur.score < run.best.score or (cur.score <= run.best.score and cur.excess < run.best.excess):
        run.best = cur
        run.since_best = 0
    else:
        run.since_best += 1
    run.converged = cur.score <= 1.0
    if run.converged:
        f = soft_terms(prob, cur.X, value_only=True)
        if run.feasible_best is None or f < run.feasible_best[1]:
            run.feasible_best = (cur, f)
    if optimize:
        run.opt_its += 1
        run.t_opt = min(1.0, 2.0 * step.t)
        if (run.opt_its >= opts.optimize_iterations or step_opt < _OPT_STEP
                or f_cur - step.f_new < _OPT_DECREASE * f_cur):
            run.phase = "polish"
            run.since_best = 0
    elif run.phase == "restore" and not run.converged:
        run.held = run.held + 1 if step.beta < _HELD_BETA else 0
        if run.held >= _HELD_STEPS and _relax_closeness(prob, run):
            run.mark, run.since_mark, run.since_best = cur.score, 0, 0
    if run.since_best >= _STALL and not run.converged and not optimize:
        run.stop_reason = f"stalled (no improvement in {_STALL} iterations)"
    if cur.score < (1.0 - _SLOW) * run.mark or run.phase != "restore":
        run.mark, run.since_mark = cur.score, 0
    else:
        run.since_mark += 1
        if run.since_mark >= _STALL and not run.converged and not run.stop_reason:
            run.stop_reason = (f"stalled (the worst face improved less than {_SLOW:.0%} in {_STALL} iterations: "
                               "the panel-health guard holds it)")


def _relax_closeness(prob, run: Run) -> bool:
    """Lower the closeness stiffness by ``_RELAX_CLOSENESS`` (not below ``prob.relax_floor`` of the given one) when the
    panel-health guard holds the restore phase; whether it was lowered.

    A stiff closeness metric leaves the planarity correction only the directions within the surface, where it
    shears the net into the guard's bounds (corners at 20°, edges at 0.2 × the median; measured on conjugate-field
    candidates of the wave sample: 100 iterations to 1.2e-2 at closeness weight 10, 19 iterations to 1e-4 at
    0.33). The optimize phase, once the tolerance is met, runs at the full stiffness again and pulls the planar
    mesh back toward the surface (:func:`_restore_closeness`).
    """
    if run.phase != "restore":
        return False
    if _can_relax_closeness(prob, run):
        prob.alpha = max(prob.alpha * _RELAX_CLOSENESS, run.alpha_full * prob.relax_floor)
        run.relaxed_to = min(run.relaxed_to, prob.alpha / run.alpha_full)
        log.debug("planarize: the guard holds the restore phase; closeness stiffness relaxed to %.3g of the given",
                  prob.alpha / run.alpha_full)
    elif prob.opts.angle_guard > prob.opts.relaxed_guard:  # then the guard's share of the input's own values
        prob.opts = prob.opts._replace(angle_guard=prob.opts.relaxed_guard)
        run.guard = panel_guard(prob)
        run.cur = evaluate(prob, run.guard, run.cur.X, run.cur.tangents)
        log.debug("planarize: the guard holds the restore phase; its share of the input's values relaxed to %g",
                  prob.opts.angle_guard)
    else:
        return False
    run.held = 0
    run.sticky[:] = False
    run.guard_reset = False
    run.soft_cache = None
    return True


def _can_relax_closeness(prob, run: Run) -> bool:
    """Whether the closeness stiffness is still above the share the restore phase may relax it to."""
    return run.alpha_full > 0.0 and prob.alpha > run.alpha_full * prob.relax_floor * (1.0 + 1e-9)


def _restore_closeness(prob, run: Run):
    """Back to the given closeness stiffness (the optimize phase judges closeness by it); the best feasible state
    is measured again by it."""
    if prob.alpha == run.alpha_full:
        return
    prob.alpha = run.alpha_full
    run.soft_cache = None
    run.last_fact = None  # its metric is the relaxed one: the first optimize step solves afresh
    if run.feasible_best is not None:
        st = run.feasible_best[0]
        run.feasible_best = (st, soft_terms(prob, st.X, value_only=True))


def final_state(run: Run) -> State:
    """The state to return: the current one when it meets the tolerance, else the earlier state that met it with
    the smallest soft objective, else the best state seen (``run.converged`` and ``run.stop_reason`` updated)."""
    if not run.converged and run.feasible_best is not None:
        run.cur, run.converged = run.feasible_best[0], True
        run.stop_reason = f"tolerance reached (best state that met it; then {run.stop_reason})"
    return run.cur if run.converged else run.best
