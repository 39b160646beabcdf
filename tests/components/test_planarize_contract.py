"""The planarizer's contracts on synthetic meshes (no ``../shared`` needed): the line search accepts only steps
that improve (planarity in the restore phase; the soft objective within the planarity band in the optimize
phase), the outer loop keeps and returns the best state, and every goal's Jacobian matches finite differences.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from components.core.mesh import edge_topology, face_corners, quad_grid
from components.planarize import goals
from components.planarize.geometry import vertex_stars
from components.planarize.guard import evaluate, panel_guard
from components.planarize.phases import _advance, final_state, start
from components.planarize.planarizer import planarize
from components.planarize.problem import checked_options, setup_problem
from components.planarize.rows import soft_terms
from components.planarize.step import _GUARD_ATTEMPTS, KAPPA, Directions, Step, _line_search, solve_step


def _warped(nx=5, ny=4, amp=0.15):
    V, F = quad_grid(nx, ny, float(nx), float(ny))
    V[:, 2] = amp * np.sin(1.3 * V[:, 0]) * np.cos(0.9 * V[:, 1]) + 0.05 * V[:, 0] * V[:, 1]
    return V, F


@pytest.fixture
def setup():
    V, F = _warped()
    prob = setup_problem(V, F, None, checked_options(len(V)))
    guard = panel_guard(prob)
    run = start(prob, guard, time.perf_counter())
    assert run.cur.score > 1.0 and run.cur.healthy
    return prob, guard, run


def _improves(new, old) -> bool:
    return new.score < old.score or (new.score <= old.score and new.excess < old.excess)


def _search(prob, guard, cur, df, do, t, optimize):
    sel = np.zeros(guard.n_items, dtype=bool)
    f_cur = soft_terms(prob, cur.X, value_only=True)
    out = _line_search(prob, guard, cur, Directions(None, None, df, None, do), t, optimize, f_cur, sel,
                       sel.copy(), _GUARD_ATTEMPTS)
    return out[0], f_cur, out[4]


# ----------------------------------------------------------------------------------------------- line search


def test_restore_steps_are_taken_only_when_they_improve(setup):
    prob, guard, run = setup
    cur = run.cur
    step = solve_step(prob, guard, cur, soft_terms(prob, cur.X), run.sticky.copy(), 0.0, False)
    assert step.accepted is not None and _improves(step.accepted, cur)  # the Gauss-Newton step improves ...
    zero = np.zeros_like(step.df)
    taken, _, _ = _search(prob, guard, cur, step.df, zero, 0.0, False)
    assert taken is not None and _improves(taken, cur)
    # ... its opposite makes every face less planar at every length: no trial of it may be taken
    taken, _, _ = _search(prob, guard, cur, -step.df, zero, 0.0, False)
    assert taken is None
    # a direction that changes nothing is no improvement either
    taken, _, _ = _search(prob, guard, cur, zero, zero, 0.0, False)
    assert taken is None


def _planar_state(prob, guard, run):
    """Restore steps from the start until the tolerance is met."""
    st = run.cur
    for _ in range(30):
        if st.score <= 1.0:
            return st
        st = solve_step(prob, guard, st, soft_terms(prob, st.X), run.sticky.copy(), 0.0, False).accepted
    raise AssertionError("the warped grid did not reach the tolerance in 30 restore steps")


def test_optimize_steps_are_taken_only_when_they_lower_the_objective_within_the_band(setup):
    prob, guard, run = setup
    planar = _planar_state(prob, guard, run)
    zero = np.zeros_like(planar.X)
    away = planar.X - prob.X0  # further from the start: the soft objective (closeness to it) only grows
    assert np.abs(away).max() > 0
    taken, f_cur, _ = _search(prob, guard, planar, zero, away, 1.0, True)
    assert taken is None
    # back toward the start lowers it: taken, once short enough to keep the planarity within the band
    taken, f_cur, f_new = _search(prob, guard, planar, zero, -away, 1.0, True)
    assert taken is not None and f_new < f_cur and taken.score <= KAPPA


# ----------------------------------------------------------------------------------------------- best state


def _step(state, guard) -> Step:
    return Step(state, False, None, np.zeros(guard.n_items, dtype=bool), 0.0, 1.0, None, None, None, ())


def test_the_outer_loop_keeps_the_best_state(setup):
    prob, guard, run = setup
    cur = run.cur
    good = solve_step(prob, guard, cur, soft_terms(prob, cur.X), run.sticky.copy(), 0.0, False).accepted
    worse = evaluate(prob, guard, cur.X + 0.02 * np.random.default_rng(0).normal(size=cur.X.shape), cur.tangents)
    assert good.score < cur.score < worse.score or good.score < worse.score
    f = soft_terms(prob, cur.X, value_only=True)
    _advance(prob, run, _step(good, guard), f, False)
    assert run.best is good
    _advance(prob, run, _step(worse, guard), f, False)
    assert run.cur is worse and run.best is good  # a worse state never replaces the best one
    if not good.score <= 1.0:
        assert final_state(run) is good


def test_among_states_meeting_the_tolerance_the_closest_is_returned(setup):
    prob, guard, run = setup
    cur = run.cur
    near = _planar_state(prob, guard, run)
    far = evaluate(prob, guard, near.X + [0.05, -0.03, 0.04], near.tangents)  # moved rigidly: just as planar
    assert far.score <= 1.0 and far.healthy
    f_near, f_far = (soft_terms(prob, s.X, value_only=True) for s in (near, far))
    assert f_near < f_far
    f = soft_terms(prob, cur.X, value_only=True)
    _advance(prob, run, _step(near, guard), f, False)
    _advance(prob, run, _step(far, guard), f, False)  # met the tolerance later, farther from the start
    _advance(prob, run, _step(evaluate(prob, guard, cur.X, cur.tangents), guard), f, False)  # not planar
    assert not run.converged
    assert final_state(run) is near and run.converged


@pytest.mark.parametrize("iterations", [1, 2, 5])
def test_the_result_is_never_less_planar_than_the_input(iterations):
    V, F = _warped(6, 5, 0.6)
    V += np.random.default_rng(iterations).normal(scale=0.15, size=V.shape)
    from components.core.measures import quad_planarity

    res = planarize((V, F), max_iterations=iterations)
    assert res.max_planarity <= quad_planarity(V, F).max() * (1 + 1e-12)


# ----------------------------------------------------------------------------------------------- Jacobians


def _dense(block: goals.Block, size: int) -> np.ndarray:
    J = np.zeros((len(block.r), size))
    np.add.at(J, (block.rows, block.cols), block.vals)
    return J


def _fd(fn, X: np.ndarray, h: float = 1e-6) -> np.ndarray:
    x = X.ravel()
    cols = []
    for k in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[k] += h
        xm[k] -= h
        cols.append((fn(xp.reshape(X.shape)) - fn(xm.reshape(X.shape))) / (2 * h))
    return np.stack(cols, axis=1)


def _skewed_grid():
    """A non-planar, sheared 4 × 4 quad grid: no corner near 90° (where min(θ, π − θ) has a kink), interior
    valence-4 vertices for the conical and fairness goals, a boundary for the boundary polylines."""
    V, F = quad_grid(4, 4, 4.0, 4.0)
    V[:, 0] += 0.35 * V[:, 1]
    rng = np.random.default_rng(7)
    V[:, 2] = 0.2 * np.sin(V[:, 0]) * np.cos(V[:, 1]) + rng.normal(scale=0.03, size=len(V))
    V[:, :2] += rng.normal(scale=0.03, size=(len(V), 2))
    return V, F


def _goal_cases():
    V, F = _skewed_grid()
    n = len(V)
    C = face_corners(F)
    stars = vertex_stars(F, n)
    E = edge_topology(F).E
    deg = np.bincount(E.ravel(), minlength=n).astype(float)
    vv = np.concatenate([E[:, 0], E[:, 1]])
    nb = np.concatenate([E[:, 1], E[:, 0]])
    lap = (vv, nb, 1.0 / deg[vv])
    idx = np.arange(0, n, 2)
    rng = np.random.default_rng(1)
    Cp = rng.normal(size=(len(idx), 3))
    Np = rng.normal(size=(len(idx), 3))
    Np /= np.linalg.norm(Np, axis=1)[:, None]
    X0 = V + 0.1
    Nf = np.cross(V[F[:, 2]] - V[F[:, 0]], V[F[:, 3]] - V[F[:, 1]])
    Nf /= np.linalg.norm(Nf, axis=1)[:, None]
    sel_c = np.arange(0, len(C.v), 3)
    sel_e = np.arange(0, len(E), 2)
    sel_f = np.arange(len(F))
    pairs = _face_pairs(F)
    Rf = rng.normal(size=(len(sel_f), 3))  # a fixed unit "reference normal" per face
    Rf /= np.linalg.norm(Rf, axis=1)[:, None]
    cases = {
        "planarity": lambda X: goals.planarity_block(X, F, 1.0),
        "closeness": lambda X: goals.closeness_block(X, idx, Cp, Np, 1.0),
        "start": lambda X: goals.start_block(X, X0, idx, 1.0),
        "fairness polylines": lambda X: goals.fairness_block(X, stars, "polylines", 1.0),
        "fairness laplacian": lambda X: goals.fairness_block(X, stars, "laplacian", 1.0, lap),
        "edge length": lambda X: goals.edge_length_block(X, E, 1.3, 1.0),
        "area": lambda X: goals.area_block(X, F, C, 0.9, 1.0),
        "conical": lambda X: goals.conical_block(X, C, stars, 1.0),
        "turn guard": lambda X: goals.turn_block(X, C, sel_c, Nf, 0.2),
        "sharpness guard": lambda X: goals.sharpness_guard_block(X, C, sel_c, 0.3),
        "edge guard": lambda X: goals.edge_guard_block(X, E, sel_e, 0.5),
        "area guard": lambda X: goals.area_guard_block(X, F, sel_f, 0.4),
        "fold guard": lambda X: goals.fold_guard_block(X, F, pairs, -0.5),
        "flip guard": lambda X: goals.flip_guard_block(X, F, sel_f, Rf, 0.1),
    }
    return V, cases


def _face_pairs(F):
    """Pairs of faces sharing an edge."""
    owner = {}
    pairs = []
    for f, face in enumerate(F.tolist()):
        for a, b in zip(face, face[1:] + face[:1]):
            key = (min(a, b), max(a, b))
            if key in owner:
                pairs.append((owner[key], f))
            else:
                owner[key] = f
    return np.array(pairs, dtype=np.int64)


GOALS = ["planarity", "closeness", "start", "fairness polylines", "fairness laplacian", "edge length", "area",
         "conical", "turn guard", "sharpness guard", "edge guard", "area guard", "fold guard", "flip guard"]


@pytest.mark.parametrize("goal", GOALS)
def test_goal_jacobians_match_finite_differences(goal):
    V, cases = _goal_cases()
    build = cases[goal]
    block = build(V)
    assert len(block.r) > 0 and np.all(np.isfinite(block.r))
    J = _dense(block, V.size)
    J_fd = _fd(lambda X: build(X).r, V)
    scale = max(1.0, float(np.abs(J_fd).max()))
    err = float(np.abs(J - J_fd).max()) / scale
    assert err < 1e-6, (goal, err)
    assert np.abs(J).max() > 0  # not vacuous
