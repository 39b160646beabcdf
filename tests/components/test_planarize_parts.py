"""Tests of the planarization solver's parts on their own: problem setup, goal rows, one step, the guard, phases."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest

from components.core.errors import InputError
from components.core.mesh import boundary_loops, quad_grid, triangulate
from components.core.proximity import ClosestPoints
from components.planarize.geometry import LoopIndex
from components.planarize.goals import planarity_residual
from components.planarize.guard import State, evaluate, panel_guard, rows_to_guard, watched_rows
from components.planarize.phases import Run, final_state, iterate
from components.planarize.problem import checked_options, setup_problem
from components.planarize.rows import hard_rows, inverse_metric, soft_terms
from components.planarize.step import solve_step


def _grid(n=4, bump=0.0):
    V, F = quad_grid(n, n, float(n), float(n))  # unit edges: normalized units are model units shifted
    V[:, 2] = bump * (V[:, 0] - n / 2) * (V[:, 1] - n / 2)
    return V, F


def _problem(V, F, reference=None, **kw):
    prob = setup_problem(V, F, reference, checked_options(len(V), **kw))
    return prob, panel_guard(prob)


def _state(prob, guard, X):
    Xs, tang = prob.project_slide(X)
    return evaluate(prob, guard, Xs, tang)


# ----------------------------------------------------------------------------------------------- problem setup


def test_options_use_the_shared_wording():
    with pytest.raises(InputError, match=r"^anchors: must be between 0 and 24, got 25$"):
        checked_options(25, anchors=[3, 25])
    with pytest.raises(InputError, match=r"^anchors: must be a whole number, got 1\.5$"):
        checked_options(25, anchors=[1.5])
    with pytest.raises(InputError, match=r"^max_iterations: must be a whole number"):
        checked_options(25, max_iterations=2.5)
    with pytest.raises(InputError, match=r"^boundary: must be one of 'fixed', 'slide', 'free', got 'glued'$"):
        checked_options(25, boundary="glued")
    with pytest.raises(InputError, match=r"^anchor_points: point 0 has a NaN"):
        checked_options(25, anchor_points=[[0.0, np.nan, 0.0]])
    assert checked_options(25, anchors=np.array([4.0, 2.0, 4.0])).anchors.tolist() == [2, 4]


def test_sliding_roles_fix_the_corners_and_slide_the_rest():
    V, F = _grid(4, bump=0.05)
    prob, _ = _problem(V, F, reference=(V, F), boundary="slide", anchors=[12])
    loop = boundary_loops(F)[0]
    corners = [0, 4, 20, 24]
    assert prob.fixed[corners].all() and prob.fixed[12]
    assert prob.slide[[v for v in loop if v not in corners]].all()
    assert not (prob.fixed & prob.slide).any()
    assert prob.ndof == 3 * 8 + 12  # 9 interior vertices minus the anchor, 12 sliding ones


# ----------------------------------------------------------------------------------------------- goal rows


def test_soft_gradient_matches_the_objective():
    # fixed targets and the start's tangent planes: the objective whose gradient soft_terms gives is exactly f
    # (with a reference or mean targets the closest points and means are held fixed, Gauss-Newton style)
    V, F = _grid(4, bump=0.1)
    prob, _ = _problem(V, F, start_weight=0.3, fairness_weight=0.5, edge_length_weight=1.0, target_edge_length=1.1,
                       area_weight=1.0, target_area=1.2)
    rng = np.random.default_rng(0)
    X = prob.X0 + 0.05 * rng.standard_normal(prob.X0.shape)
    g, H, f = soft_terms(prob, X)
    assert f == pytest.approx(soft_terms(prob, X, value_only=True))
    D = rng.standard_normal(X.shape)
    h = 1e-6
    slope = (soft_terms(prob, X + h * D, value_only=True) - soft_terms(prob, X - h * D, value_only=True)) / (2 * h)
    assert slope == pytest.approx(float((g * D).sum()), rel=1e-4)
    assert np.all(np.linalg.eigvalsh(H) > 0)  # a metric


def test_sliding_vertices_move_along_their_tangent_only():
    V, F = _grid(4, bump=0.05)
    prob, guard = _problem(V, F, reference=(V, F), boundary="slide")
    cur = _state(prob, guard, prob.X0)
    Gb = inverse_metric(prob, soft_terms(prob, cur.X)[1], cur.tangents)
    moved = np.einsum("nij,nj->ni", Gb, np.random.default_rng(1).standard_normal((prob.n, 3)))
    along = np.einsum("ij,ij->i", moved[prob.slide_idx], cur.tangents)
    assert np.allclose(moved[prob.slide_idx], along[:, None] * cur.tangents)
    assert np.all(moved[prob.fixed] == 0.0)


def test_hard_rows_are_the_planarity_residuals_plus_guard_rows():
    V, F = _grid(3, bump=0.2)
    prob, guard = _problem(V, F)
    J, r, n_hard = hard_rows(prob, prob.X0, np.zeros(0, np.int64), np.zeros(0))
    assert J.shape == (len(F), 3 * len(V)) and n_hard == len(F)
    # every quad row keeps only its excess over relax × tolerance (0.9e-4): it is driven to that value, not to 0
    res = planarity_residual(prob.X0, prob.Q4)
    assert np.abs(res).min() > 1e-3
    assert np.allclose(r, res - np.sign(res) * 0.9e-4, rtol=0, atol=1e-15)
    sel = np.array([0, 5])
    J2, r2, n2 = hard_rows(prob, prob.X0, sel, guard.item_tgt[sel])
    assert n2 == n_hard and J2.shape[0] == n_hard + 2 and np.array_equal(r2[:n_hard], r)
    assert np.all(r2[n_hard:] == 0.0)  # right angles are above the bound: the guard rows only hold them


# ----------------------------------------------------------------------------------------------- one step


def test_step_on_a_planar_grid_is_zero():
    V, F = _grid(4)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    step = solve_step(prob, guard, cur, soft_terms(prob, cur.X), np.zeros(guard.n_items, bool), 0.0)
    assert not step.singular
    assert np.all(step.df == 0.0)
    assert step.accepted is None  # nothing to improve: no trial lowers a zero score


def test_step_on_a_warped_grid_lowers_the_score_and_stays_healthy():
    V, F = _grid(4, bump=0.1)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    assert cur.score > 1.0
    step = solve_step(prob, guard, cur, soft_terms(prob, cur.X), np.zeros(guard.n_items, bool), 0.0)
    assert step.accepted is not None and step.accepted.healthy
    assert step.accepted.score < 0.1 * cur.score  # Gauss-Newton: far below, not just lower


# ----------------------------------------------------------------------------------------------- the guard


def test_a_point_at_a_loop_vertex_gets_the_vertex_tangent():
    # the corner (1, 0, 0) of a square: the segments before and after it are equally close, and which one the
    # query returns is round-off (a candidate's boundary vertex snapped onto the outline's vertex, in m or in mm)
    square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    idx = LoopIndex(square, [np.arange(4)])
    at_corner = np.array([[1.0, 0.0, 0.0], [1.0 + 2e-16, -1e-17, 0.0], [1.0 - 1e-16, 1e-16, 0.0], [1.3, -0.2, 0.0]])
    Q, T = idx.query(at_corner)
    assert np.allclose(Q, [1.0, 0.0, 0.0], atol=1e-15)
    assert np.allclose(T, np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), atol=1e-12)
    Q, T = idx.query(np.array([[0.5, -0.1, 0.0], [1.2, 0.25, 0.0]]))  # within a segment: the segment's tangent
    assert np.allclose(T, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def test_the_closeness_normal_at_a_shared_vertex_or_edge_does_not_depend_on_the_face():
    # a reference folded along its diagonal: the two triangles' normals differ by 30°; a closest point on the
    # shared edge or at a shared vertex gets one normal whichever triangle holds it (the edge's, the vertex's), a
    # point inside a triangle that triangle's
    V, F = _grid(2)
    R = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]])
    R[3, 2] = 2.0 * math.tan(math.radians(30.0)) * math.sqrt(2.0) / 2.0
    Tr = triangulate(np.array([[0, 1, 2, 3]]))[0]
    prob, _ = _problem(V, F, reference=(R, Tr))
    shared = [int(v) for v in np.intersect1d(Tr[0], Tr[1])]
    assert len(shared) == 2
    for bary in ([1.0, 0.0], [0.0, 1.0], [0.4, 0.6]):  # each shared vertex, a point on the shared edge
        normals = []
        for f in (0, 1):
            b = np.zeros(3)
            for v, w in zip(shared, bary):
                b[list(Tr[f]).index(v)] = w
            res = ClosestPoints(np.zeros((1, 3)), np.zeros(1), np.array([f]), b[None, :])
            normals.append(prob.reference_normals(res, np.array([0])))
        assert np.allclose(normals[0], normals[1], atol=1e-12)
        assert np.linalg.norm(normals[0]) == pytest.approx(1.0)
    assert not np.allclose(prob.NR[0], prob.NR[1], atol=0.1)  # the faces' own normals differ
    inside = ClosestPoints(np.zeros((2, 3)), np.zeros(2), np.array([0, 1]), np.full((2, 3), 1.0 / 3.0))
    assert np.allclose(prob.reference_normals(inside, np.arange(2)), prob.NR[[0, 1]])


def test_the_flip_guards_normal_at_a_reference_edge_does_not_depend_on_the_face():
    # a ridge along the reference's diagonal (its triangles' normals 2 × 35° apart) under a flat quad whose centroid's
    # closest point is on the ridge: the flip guard watches the ridge's normal, not one triangle's (which the query's
    # round-off would pick), as the closeness goal does
    R = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, -1.0], [2.0, 2.0, 0.0], [0.0, 2.0, -1.0]])
    Tr = np.array([[0, 1, 2], [0, 2, 3]])
    V = np.array([[0.0, 0.0, 0.3], [2.0, 0.0, 0.3], [2.0, 2.0, 0.3], [0.0, 2.0, 0.3]])
    prob, guard = _problem(V, np.array([[0, 1, 2, 3]]), reference=(R, Tr))
    ridge = prob.NR[0] + prob.NR[1]
    assert np.allclose(guard.flip_normals[0], ridge / np.linalg.norm(ridge), atol=1e-12)
    assert not np.allclose(prob.NR[0], prob.NR[1], atol=0.1)
    assert bool(guard.flip_on[0])


def test_guard_rejects_a_corner_below_the_bound():
    V, F = _grid(3)
    prob, guard = _problem(V, F, angle_guard=0.5)
    assert guard.lo == pytest.approx(math.pi / 4)  # half of the input's 90°
    X = prob.X0.copy()
    v = 5  # interior vertex: pull it toward vertex 10 until the corners at 9 and 6 close below 45°
    X[v] = prob.X0[10] + 0.2 * (prob.X0[v] - prob.X0[10]) + [0.3, 0.0, 0.0]
    bad = _state(prob, guard, X)
    assert not bad.healthy
    low = guard.guarded & (bad.angle < guard.angle_floor)
    assert low.any()
    new = rows_to_guard(guard, bad, np.zeros(guard.n_items, bool))
    assert np.all(new[: len(low)][low])  # every corner below its floor gets a guard row
    ok = X.copy()
    ok[v] = prob.X0[v] + [0.05, 0.05, 0.05]  # a small move keeps every corner well above 45°
    assert _state(prob, guard, ok).healthy


@pytest.mark.parametrize("start", [20.04, 20.5, 22.0, 30.0])
def test_a_corner_row_lifts_its_corner_clear_of_the_bound(start):
    # a sheared grid: every corner starts ``start``° from 0° or 180°, just over the 20° bound or well over it. A
    # corner pushed onto the bound gets a row lifting it to the target: at least half a degree clear of the bound,
    # so that a step's second-order error (a few hundredths of a degree at a full step on an 80k-triangle canopy's
    # candidate) does not put the corner under the bound again at every step (that canopy crawled 49 iterations at
    # steps of 1/64 when a corner starting at 20.04° had its target 0.02° over the bound)
    V, F = quad_grid(3, 3, 3.0, 3.0)
    V[:, 0] += V[:, 1] / math.tan(math.radians(start))
    prob, guard = _problem(V, F)
    c = len(prob.corners.v)
    floor, act, tgt = guard.angle_floor, guard.item_act[:c], guard.item_tgt[:c]
    assert np.degrees(floor) == pytest.approx(20.0)
    assert np.all(np.degrees(tgt - floor) >= 0.5 - 1e-9) and np.all(act > tgt)
    # a corner well over the bound keeps the 5° band: its row acts under 25° and lifts to 22.5°
    if start >= 25.0:
        assert np.degrees(act) == pytest.approx(25.0) and np.degrees(tgt) == pytest.approx(22.5)


@pytest.mark.parametrize("tilt", [1e-15, -1e-15])
def test_a_face_collapsed_to_round_off_has_no_normal(tilt):
    # a trial that collapses a face onto a line: its area is round-off, and so would be its normal's direction
    # (the fold and flip values across it, and with them which guard rows the trial adds, in m and in mm alike)
    V, F = _grid(3)
    R = (V.copy(), triangulate(F)[0])
    prob, guard = _problem(V, F, reference=R)
    X = prob.X0.copy()
    f0 = F[0]  # corners 0, 1, 5, 4: put them on the segment from corner 0 to corner 1, one a round-off off it
    X[f0] = X[f0[0]] + np.outer([0.0, 0.3, 0.6, 0.9], X[f0[1]] - X[f0[0]])
    X[f0[2], 1] += tilt
    st = evaluate(prob, guard, X, np.zeros((0, 3)), crossings=False)
    c, e, m, i = len(prob.corners.v), len(prob.E), len(prob.F), len(prob.inner_faces)
    folds, flips = st.values[2 * c + e + m: 2 * c + e + m + i], st.values[2 * c + e + m + i:]
    assert not st.healthy and "area" in st.failed
    assert flips[0] == 0.0
    touching = (prob.inner_faces == 0).any(axis=1)
    assert touching.any() and np.all(folds[touching] == 0.0)


def test_guard_rejects_a_fold():
    V, F = _grid(3)
    prob, guard = _problem(V, F, angle_guard=0.1)
    X = prob.X0.copy()
    X[5] = prob.X0[10] + (prob.X0[10] - prob.X0[5]) * 0.3  # across the diagonal: face 0 turns reflex
    st = _state(prob, guard, X)
    assert st.nonconvex > 0 and not st.healthy


def test_watched_rows_are_near_the_bound_or_sticky():
    V, F = _grid(3)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    c = len(prob.corners.v)
    sticky = np.zeros(guard.n_items, bool)
    assert not watched_rows(guard, cur.values, sticky).any()  # right angles, unit edges: far from their bounds
    values = cur.values.copy()
    values[3] = guard.angle_floor[3]  # a corner at its bound
    values[2 * c + 2] = guard.len_min[2]  # an edge at its bound (items: sharpness, turns, then edges)
    values[7] = guard.item_act[7] + 0.5 * (guard.item_act[7] - guard.item_min[7])  # just outside the margin
    assert watched_rows(guard, values, sticky).nonzero()[0].tolist() == [3, 2 * c + 2]
    sticky[[7, 8]] = True  # kept rows: 7 is still near its bound, 8 (a right angle) is not
    assert watched_rows(guard, values, sticky).nonzero()[0].tolist() == [3, 7, 2 * c + 2]


def test_a_face_turning_on_edge_gets_a_flip_row():
    V, F = _grid(3)
    prob, guard = _problem(V, F, reference=(V, F))
    m, c, e, i = len(F), len(prob.corners.v), len(prob.E), len(prob.inner_faces)
    base = 2 * c + e + m + i  # items: sharpness, turns, edges, faces, hinges, then flips
    assert guard.n_items == base + m and guard.item_on[base:].all()
    cur = _state(prob, guard, prob.X0)
    assert np.allclose(cur.values[base:], 1.0)  # flat grid on itself: every normal along the reference's
    X = prob.X0.copy()
    X[[6, 10], 2] += 6.0  # the centre face (5, 6, 10, 9) tilts by atan(6) = 80.5°: n · r = 0.164 < sin 10°
    st = _state(prob, guard, X)
    assert st.values[base + 4] == pytest.approx(math.cos(math.atan(6.0)), abs=1e-9)
    sel = np.flatnonzero(watched_rows(guard, st.values, np.zeros(guard.n_items, bool)))
    assert base + 4 in sel.tolist()
    J, r, n_hard = hard_rows(prob, X, sel, guard.item_tgt[sel], guard.flip_normals)
    k = n_hard + sel.tolist().index(base + 4)
    assert r[k] == 0.0  # above its target (sin 5°): the row holds it, it may not turn further
    assert set(J[k].indices // 3) == {5, 6, 9, 10}
    # the row's gradient points toward standing the face back up: lowering the lifted corners raises n · r
    assert float(J[k].toarray().reshape(-1, 3)[[6, 10], 2].sum()) < 0.0


# ----------------------------------------------------------------------------------------------- phases


def _fake_state(score, X):
    return State(X, np.zeros((0, 3)), score, np.zeros(0), np.zeros(0), 0, True, np.zeros(1), np.zeros(0))


def test_best_state_is_returned_when_a_later_step_is_worse():
    X = np.zeros((1, 3))
    good, worse = _fake_state(2.0, X), _fake_state(5.0, X + 1)
    run = Run(t0=0.0, cur=worse, best=good, start_score=9.0, sticky=np.zeros(0, bool), stop_reason="stalled")
    assert final_state(run) is good and not run.converged
    # a state that met the tolerance earlier wins over a later one that does not
    met = _fake_state(0.9, X + 2)
    run = Run(t0=0.0, cur=worse, best=met, start_score=9.0, sticky=np.zeros(0, bool), stop_reason="stalled",
              feasible_best=(met, 1.0))
    assert final_state(run) is met and run.converged
    assert run.stop_reason == "tolerance reached (best state that met it; then stalled)"


def test_iterate_records_one_history_entry_per_iteration_and_stops_at_the_cap():
    V, F = _grid(4, bump=0.1)
    prob, guard = _problem(V, F, max_iterations=1)
    run = iterate(prob, guard, time.perf_counter())
    assert run.it == 1 and run.stop_reason == "iteration cap (1) reached"
    assert len(run.hist["maxp"]) == 2 and run.hist["maxp"][1] < run.hist["maxp"][0]
    assert run.best.score < run.start_score


def test_einsum_sum3_sums_the_three_products_to_round_off():
    from components.planarize.geometry import einsum_sum3
    rng = np.random.default_rng(7)
    for n in (1, 3, 8, 1000, 20000):
        a = rng.standard_normal((n, 3)) * rng.lognormal(0.0, 3.0, (n, 3))
        b = rng.standard_normal((n, 3))
        exact = np.einsum("ij,ij->i", a, b)
        got = einsum_sum3(*(a * b).T)
        scale = np.abs(a * b).sum(axis=1)
        assert np.all(np.abs(got - exact) <= 4 * np.finfo(float).eps * scale)


# ----------------------------------------------------------------------------------------------- far moves


def test_far_vertices_are_the_outliers_of_the_step_over_one_edge():
    from components.planarize.step import _far_vertices

    df = np.full((200, 3), 0.01)
    df[7] = [3.0, 0.0, 0.0]  # 300 × the others, over one edge: far
    df[9] = [0.0, 0.9, 0.0]  # an outlier, but under one edge: kept
    assert _far_vertices(df).tolist() == [7]
    df[:20] = 0.5  # the 99th percentile is now 0.5: 3 edges is only 6 × it
    assert _far_vertices(df).tolist() == []
    assert _far_vertices(np.zeros((0, 3))).tolist() == []


def test_far_moving_vertices_lose_their_guard_rows_once(monkeypatch):
    """With ``release_far`` the first solve whose step moves a vertex far is repeated without the guard rows that
    involve that vertex; the other guard rows stay."""
    import components.planarize.step as step_mod

    V, F = _grid(12, bump=0.01)  # 169 vertices: one far vertex is above the 99th percentile
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    v = 84  # the middle vertex
    c = len(prob.corners.v)
    sticky = np.zeros(guard.n_items, bool)
    sticky[np.flatnonzero(prob.corners.v == v)] = True  # its corners' sharpness rows
    sticky[np.flatnonzero(prob.corners.v == 0)] = True  # and a far corner's
    real, calls = step_mod._directions, []

    def far_first(prob, guard, X, sel, *args):
        d, base = real(prob, guard, X, sel, *args)
        calls.append(np.array(sel))
        if len(calls) == 1:
            df = np.full_like(d.df, 0.01)
            df[v] = [30.0, 0.0, 0.0]
            d = d._replace(df=df, lam_f=np.abs(d.lam_f) + 1.0)  # no row is loose: only the far move releases
        return d, base

    monkeypatch.setattr(step_mod, "_directions", far_first)
    monkeypatch.setattr(step_mod, "watched_rows", lambda guard, values, sticky: sticky.copy())  # rows = the kept ones
    solve_step(prob, guard, cur, soft_terms(prob, cur.X), sticky, 0.0, release_far=True)
    first, second = calls[0], calls[1]
    corners = first[first < c]
    at_v = corners[prob.corners.v[corners] == v]
    assert len(at_v) == 4 and set(second) == set(first) - set(at_v)
    assert not sticky[at_v].any() and sticky[np.flatnonzero(prob.corners.v == 0)].all()
    assert all(set(at_v).isdisjoint(s) for s in calls[1:])


def _solve_with(step_mod, prob, guard, cur, sel, base=None):
    g, H, _ = soft_terms(prob, cur.X)
    Gb = inverse_metric(prob, H, cur.tangents)
    Ggf = np.einsum("nij,nj->ni", Gb, g).ravel()
    return step_mod._directions(prob, guard, cur.X, sel, Gb, g.ravel(), Ggf, True, True, base)


@pytest.mark.parametrize("n_drop", [1, 7, 64])
def test_released_guard_rows_are_solved_with_the_factor_they_were_released_from(monkeypatch, n_drop):
    """Guard rows released from a factored system (loose rows, far vertices) are solved with its factor, not a new
    one: the steps are those of the smaller system (with the factored system's damping), solved directly."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    import components.planarize.step as step_mod

    V, F = _grid(8, bump=0.2)
    V[:, 2] += 0.05 * np.sin(3.0 * V[:, 0]) * np.cos(2.0 * V[:, 1])
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    c, e = len(prob.corners.v), len(prob.E)
    sel = np.concatenate([np.arange(0, c, 3), 2 * c + np.arange(0, e, 2)])  # corners and edges
    full, base = _solve_with(step_mod, prob, guard, cur, sel)
    kept = np.delete(sel, np.random.default_rng(1).choice(len(sel), n_drop, replace=False))
    factored = []
    real = step_mod.factor_spd
    monkeypatch.setattr(step_mod, "factor_spd", lambda S: factored.append(S.shape) or real(S))
    reduced, base_after = _solve_with(step_mod, prob, guard, cur, kept, base)
    assert factored == [] and base_after is base
    # the smaller system solved directly: its rows from scratch, the factored system's damping
    J, r, n_hard = hard_rows(prob, cur.X, kept, guard.item_tgt[kept], guard.flip_normals)
    g, H, _ = soft_terms(prob, cur.X)
    Gb = inverse_metric(prob, H, cur.tangents)
    JG = step_mod.times_blocks(J, Gb)
    S = (JG @ J.T + base.eps * sp.identity(J.shape[0])).tocsc()
    lam_f = spla.spsolve(S, -r)
    lam_o = spla.spsolve(S, JG @ g.ravel())
    df = (JG.T @ lam_f).reshape(-1, 3)
    do = (JG.T @ lam_o).reshape(-1, 3) - np.einsum("nij,nj->ni", Gb, g)
    for a, b in ((reduced.lam_f, lam_f), (reduced.df, df), (reduced.do, do)):
        assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()
    assert np.abs(full.df - df).max() > 1e-6 * np.abs(df).max()  # the released rows did matter
    # a chord's or the next iteration's solve with the reduced factor: the smaller system's solution
    rhs = np.random.default_rng(2).normal(size=len(r))
    assert np.allclose(reduced.fact.lu.solve(rhs), spla.spsolve(S, rhs), rtol=1e-9, atol=1e-12)
    # more released rows than _REDUCE, or rows added: a new factorization
    _solve_with(step_mod, prob, guard, cur, sel[: len(sel) - step_mod._REDUCE - 1], base)
    _solve_with(step_mod, prob, guard, cur, np.append(kept, 2 * c + 1), base)
    assert len(factored) == 2


def test_the_face_sized_system_is_factored_by_ldlt_or_superlu_to_the_same_solution(monkeypatch):
    """factor_spd: qdldl's LDLᵀ where it is installed, SuperLU without it; both solve the system of a planarizer
    step (one or several right-hand sides) to round-off, and a singular system is damped, not refused; a whole
    planarization gives the same result with either."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    import components.planarize.step as step_mod
    from components.planarize.planarizer import planarize_mesh

    assert step_mod.qdldl is not None  # a core dependency
    V, F = _grid(8, bump=0.2)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    sel = np.arange(0, len(prob.corners.v), 3)
    J, r, _ = hard_rows(prob, cur.X, sel, guard.item_tgt[sel], guard.flip_normals)
    Gb = inverse_metric(prob, soft_terms(prob, cur.X)[1], cur.tangents)
    S = (step_mod.times_blocks(J, Gb) @ J.T + 1e-8 * sp.identity(J.shape[0])).tocsc()
    B = np.random.default_rng(3).normal(size=(S.shape[0], 3))
    exact = spla.spsolve(S, B)
    ldlt = step_mod.factor_spd(S)
    assert isinstance(ldlt, step_mod._LDL) and ldlt.shape == S.shape
    assert np.abs(ldlt.solve(B) - exact).max() <= 1e-9 * np.abs(exact).max()
    assert np.abs(ldlt.solve(B[:, 0]) - exact[:, 0]).max() <= 1e-9 * np.abs(exact).max()
    singular = sp.csc_matrix(np.ones((3, 3)))
    assert np.isfinite(step_mod.factor_spd(singular).solve(np.ones(3))).all()
    Vw, Fw = quad_grid(6, 6, 6.0, 6.0, height=lambda x, y: 0.05 * x * y + 0.02 * x * x)
    with_ldlt = planarize_mesh(Vw, Fw)
    monkeypatch.setattr(step_mod, "qdldl", None)
    lu = step_mod.factor_spd(S)
    assert not isinstance(lu, step_mod._LDL)
    assert np.abs(lu.solve(B) - exact).max() <= 1e-9 * np.abs(exact).max()
    assert np.isfinite(step_mod.factor_spd(singular).solve(np.ones(3))).all()
    with_lu = planarize_mesh(Vw, Fw)
    assert with_ldlt.converged and with_lu.converged and with_ldlt.iterations == with_lu.iterations
    assert np.abs(with_ldlt.mesh[0] - with_lu.mesh[0]).max() <= 1e-8 * np.ptp(Vw, axis=0).max()


def test_a_reduced_solve_whose_residual_is_not_small_is_factored_anew(monkeypatch):
    import components.planarize.step as step_mod

    V, F = _grid(6, bump=0.2)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    sel = np.arange(0, len(prob.corners.v), 2)
    _, base = _solve_with(step_mod, prob, guard, cur, sel)
    monkeypatch.setattr(step_mod, "_REDUCED_RES", 0.0)  # no residual is small enough
    factored = []
    real = step_mod.factor_spd
    monkeypatch.setattr(step_mod, "factor_spd", lambda S: factored.append(S.shape) or real(S))
    d, new_base = _solve_with(step_mod, prob, guard, cur, sel[1:], base)
    assert len(factored) == 1 and new_base is not base and isinstance(d.fact.lu, type(base.fact.lu))
    assert d.fact.J.shape[0] == base.fact.J.shape[0] - 1


def test_damping_follows_the_planarity_residual_and_vanishes_at_the_tolerance(monkeypatch):
    """The system is damped by 0.03 × the RMS planarity residual (relative to its mean diagonal): a large warp gets
    a damped step, which still lowers the score; at the tolerance the damping is the 1e-10 floor (Gauss-Newton)."""
    import components.planarize.step as step_mod

    assert step_mod.damping(np.zeros(5)) == 1e-10
    assert step_mod.damping(np.full(5, 0.1)) == pytest.approx(0.003)
    V, F = _grid(4, bump=0.3)
    prob, guard = _problem(V, F)
    cur = _state(prob, guard, prob.X0)
    seen = []
    real = step_mod.factor_spd
    monkeypatch.setattr(step_mod, "factor_spd", lambda S: seen.append(S.diagonal()) or real(S))
    soft = soft_terms(prob, cur.X)
    step = solve_step(prob, guard, cur, soft, np.zeros(guard.n_items, bool), 0.0)
    damped = seen[0]  # the first solve of each call: no guard rows yet, the same rows
    seen.clear()
    solve_step(prob, guard, cur, soft, np.zeros(guard.n_items, bool), 0.0, damped=False)
    plain = seen[0]
    _, r, n_hard = hard_rows(prob, cur.X, np.zeros(0, np.int64), np.zeros(0))
    mu = 0.03 * math.sqrt(float(np.mean(r[:n_hard] ** 2)))
    assert mu > 1e-4 and np.allclose(damped - plain, (mu - 1e-10) * plain.mean(), rtol=1e-6)
    assert step.accepted is not None and step.accepted.score < cur.score


def test_an_iteration_without_a_damped_step_tries_the_undamped_one(monkeypatch):
    import components.planarize.phases as phases_mod

    V, F = _grid(4, bump=0.1)
    prob, guard = _problem(V, F, max_iterations=1)
    real, calls = phases_mod.solve_step, []

    def refuse_damped(*args, damped=True, **kw):
        calls.append(damped)
        step = real(*args, damped=damped, **kw)
        return step._replace(accepted=None, failed=()) if damped else step

    monkeypatch.setattr(phases_mod, "solve_step", refuse_damped)
    run = iterate(prob, guard, time.perf_counter())
    assert calls == [True, False] and run.it == 1 and run.best.score < run.start_score


def test_converged_is_judged_on_the_returned_mesh_at_a_tolerance_finer_than_the_solver_resolves():
    # fixed vertices come back exactly as given, not at the solver's snapped copies (problem.SNAP, 6e-8 of a mean
    # edge): at a tolerance of 1e-9 the returned mesh measured 1.1e-8 while "converged" and "tolerance reached"
    # were claimed (an audit's on_surface run); converged must be true of what is returned
    from components.core.measures import quad_planarity
    from components.planarize.planarizer import planarize

    V, F = quad_grid(8, 8, 8.0, 8.0)
    rng = np.random.default_rng(3)
    V[:, 2] = 0.1 * np.sin(V[:, 0]) * np.cos(0.7 * V[:, 1]) + 0.02 * rng.standard_normal(len(V))
    V[:, :2] += 0.05 * rng.standard_normal((len(V), 2))
    for tol in (1e-5, 1e-9):
        r = planarize((V, F), boundary="fixed", tolerance=tol, time_budget=20.0)
        measured = float(quad_planarity(*r.mesh).max())
        assert measured == pytest.approx(r.max_planarity, rel=1e-12)
        assert r.converged == (measured <= tol)
        if not r.converged:
            assert "the returned mesh does not" in r.stop_reason or "tolerance" in r.stop_reason
            assert any("tolerance not reached" in w for w in r.warnings)
    assert planarize((V, F), boundary="fixed", tolerance=1e-5, time_budget=20.0).converged
    # far from the origin the returned coordinates are rounded (an ulp at 5e6 is 1e-9): the verdict measures them
    for tol in (1e-4, 1e-10):
        r = planarize((V + 5e6, F), tolerance=tol, time_budget=20.0)
        measured = float(quad_planarity(r.mesh[0] - 5e6, F).max())
        assert measured == pytest.approx(r.max_planarity, rel=1e-9)
        assert r.converged == (measured <= tol)
