"""Issue #16, "fabricable or it says why": the planarizer cannot collapse, pinch or fold a panel, ``converged`` means
"tolerance reached and healthy", results do not depend on units or placement, and inputs it cannot make fabricable
(unwelded pieces, zero-length edges) are refused with a message that says what to do."""
from __future__ import annotations

import time

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.measures import quad_planarity
from components.core.mesh import edge_topology, quad_grid, read_mesh, triangulate
from components.metrics.health import face_health
from components.planarize.geometry import corner_turns
from components.planarize.guard import evaluate, panel_guard
from components.planarize.planarizer import on_surface, planarize, planarize_mesh
from components.planarize.problem import checked_options, setup_problem
from components.planarize.rows import hard_rows
from tests.conftest import data_file
from tests.fabricable import independent_defects


def twisted_strip(n=10, rows=1, twist=np.pi / 2, length=10.0):
    """A strip twisted about its long axis (a helicoid: skew quads), ``n`` quads long and ``rows`` wide."""
    x = np.linspace(0.0, length, n + 1)
    s = np.linspace(-0.5, 0.5, rows + 1)
    X, S = np.meshgrid(x, s, indexing="xy")
    a = twist * X / length
    V = np.stack([X.ravel(), (S * np.cos(a)).ravel(), (S * np.sin(a)).ravel()], axis=1)
    return V, quad_grid(n, rows)[1]


def ribbon(turn=1.2, n=25, rows=3, tilt=0.3):
    """A strip wound ``turn`` times around a cylinder; past one turn its two layers cross each other."""
    th = np.linspace(0.0, 2 * np.pi * turn, n + 1)
    s = np.linspace(0.0, 1.0, rows + 1)
    TH, S = np.meshgrid(th, s, indexing="xy")
    r = 1.0 + tilt * (S - 0.5) * (TH / (np.pi * turn) - 1.0)
    V = np.stack([(r * np.cos(TH)).ravel(), (r * np.sin(TH)).ravel(), S.ravel()], axis=1)
    return V, quad_grid(n, rows)[1]


def height_grid(noise=0.0):
    """A 20 × 20 height-field grid (edges 0.05) on z = 0.1 sin 3x cos 2y, optionally with noise."""
    V, F = quad_grid(20, 20)
    V[:, 2] = 0.1 * np.sin(3 * V[:, 0]) * np.cos(2 * V[:, 1])
    if noise:
        V[:, 2] += noise * np.random.default_rng(7).standard_normal(len(V))
    return V, F


def hypar(n=10):
    V, F = quad_grid(n, n, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = 0.5 * V[:, 0] * V[:, 1]
    return V, F


def split_into_triangles(F, faces):
    """``F`` with the quads ``faces`` split into two padded triangles ``(a, b, c, c)``, ``(a, c, d, d)``."""
    rows = []
    for i, (a, b, c, d) in enumerate(F.tolist()):
        rows += [[a, b, c, c], [a, c, d, d]] if i in faces else [[a, b, c, d]]
    return np.array(rows, dtype=np.int64)


def assert_fabricable(res, F, reference=None):
    """The result is healthy by face_health at the default bounds (the inputs here are healthy ones)."""
    h = face_health(res.mesh[0], F, reference, tolerance=1.0)
    assert h.healthy, h.violations
    assert res.healthy
    return h


# ----------------------------------------------------------------------------------------------- the guard


def test_guard_rows_are_the_gradients_of_their_items():
    # every guard row (corner sharpness, edge length, face area, fold across an edge) is the exact derivative of
    # the value the guard tests, on a non-planar mixed mesh (quads and padded triangles); the turn rows (convexity)
    # are the derivative with the face normal held fixed
    V, F = hypar(4)
    F = split_into_triangles(F, {5})
    V = V + 0.02 * np.random.default_rng(3).standard_normal(V.shape)
    prob = setup_problem(V, F, None, checked_options(len(V)))
    guard = panel_guard(prob)
    c, e, m = len(prob.corners.v), len(prob.E), len(F)
    exact = np.array([1, 7, 30, 2 * c + 3, 2 * c + e - 1, 2 * c + e + 5, 2 * c + e + m - 1, 2 * c + e + m + 4])
    turns = np.array([c + 2, c + 40])
    sel = np.sort(np.concatenate([exact, turns]))
    X = prob.X0
    J, _, n_hard = hard_rows(prob, X, sel, np.full(len(sel), -np.inf))
    D = np.random.default_rng(4).standard_normal(X.shape)
    h = 1e-6
    slope = J[n_hard:] @ D.ravel()
    values = [evaluate(prob, guard, X + s * h * D, np.zeros((0, 3)), crossings=False).values for s in (1, -1)]
    is_exact = np.isin(sel, exact)
    assert np.allclose(slope[is_exact], ((values[0] - values[1]) / (2 * h))[sel[is_exact]], rtol=1e-6, atol=1e-8)
    N = prob.frames.normals(X)
    fixed_n = [corner_turns(X + s * h * D, prob.corners, N)[0][turns - c] for s in (1, -1)]
    assert np.allclose(slope[~is_exact], (fixed_n[0] - fixed_n[1]) / (2 * h), rtol=1e-6, atol=1e-8)


def test_guard_rejects_folded_and_crossing_faces():
    V, F = quad_grid(6, 1, 6.0, 1.0)
    prob = setup_problem(V, F, None, checked_options(len(V)))
    guard = panel_guard(prob)
    X = prob.X0.copy()
    X[[6, 13]] += [-1.5, 0.0, 0.05]  # the last quad folded back onto the one before it
    assert "fold" in evaluate(prob, guard, X, np.zeros((0, 3))).failed
    X = prob.X0.copy()
    X[[6, 13], 0] = X[3, 0] + 0.5  # the last quad laid back over quad 3, which shares no vertex with it
    st = evaluate(prob, guard, X, np.zeros((0, 3)))
    assert not st.healthy and st.failed  # caught by the cheap guards (corner, fold) or the crossing test


def test_an_edge_the_old_solver_collapsed_stays_healthy_and_the_result_says_how_far():
    # a twisted 10:1 strip held on its own surface with a sliding boundary: the solver without the health guard
    # "converged" with an edge of 2.3e-4 × the median edge (10 edges under 0.2 × median). Now no edge collapses;
    # the tolerance is out of reach without it, and the result says how far it is
    V, F = twisted_strip()
    ref = (V, triangulate(F)[0])
    res = planarize_mesh(V, F, ref, boundary="slide", closeness_weight=15.0, max_iterations=30)
    h = assert_fabricable(res, F, ref)
    assert h.shortest_edge_ratio >= 0.2 and h.worst_corner >= 20.0
    assert res.max_planarity < quad_planarity(V, F).max()
    if not res.converged:
        line = next(w for w in res.warnings if w.startswith("tolerance not reached"))
        assert "of 10 faces above the planarity tolerance 0.0001 (worst" in line and "× the tolerance" in line
        assert res.violations[0].startswith(f"{int(np.sum(res.planarity > 1e-4))} of 10 faces above")


def test_a_half_twisted_strip_converges_without_collapsed_edges():
    # the old solver converged here with an edge of 1.75e-4 × the median edge; now it converges with every edge
    # above 0.2 × the median and every corner above 20°
    V, F = twisted_strip(20, 4, np.pi)
    res = planarize((V, F))
    assert res.converged and res.max_planarity <= 1e-4, res.warnings
    h = assert_fabricable(res, F)
    assert h.shortest_edge_ratio >= 0.2 and 20.0 <= h.worst_corner <= 160.0


def test_crossing_faces_are_never_reported_converged():
    # a strip wound 1.2 times around a cylinder: its layers cross. Planarizing cannot undo that, so the result is
    # never "converged", and the violations say which faces fold over which
    V, F = ribbon(1.2)
    res = planarize((V, F))
    assert not res.converged and not res.healthy
    assert any("fold over non-adjacent faces" in v for v in res.violations)
    assert any(w.startswith("the input already has") and "crossing faces" in w for w in res.warnings)
    # short of a full turn there is nothing to cross: converged means no crossing was made
    V, F = ribbon(0.95)
    res = planarize((V, F))
    h = face_health(res.mesh[0], F)
    assert len(h.intersecting_pairs) == 0 and h.counts["folded"] == 0
    assert res.converged == (res.max_planarity <= 1e-4 and res.healthy)


def test_converged_means_tolerance_and_health():
    V, F = height_grid(0.01)
    res = planarize((V, F), reference=(V, F))
    assert res.converged and res.healthy and res.violations == []
    assert res.coverage > 0.95
    assert planarize((V, F)).coverage == -1.0  # no reference: the panel_health convention
    capped = planarize((V, F), max_iterations=1)
    assert not capped.converged and capped.healthy
    assert capped.violations[0].startswith(f"{int(np.sum(capped.planarity > 1e-4))} of 400 faces above")
    surf = on_surface((V, F), (V, triangulate(F)[0]), boundary="free")
    assert surf.converged and surf.healthy and surf.coverage > 0.95


def test_a_result_that_leaves_the_design_surface_is_never_converged():
    # the hypar with a free boundary and no pull toward the design surface: the old solver "converged" by collapsing
    # 39 edges (to 2e-4 × the median) and pulling the panels off 77 % of the design surface. Now no panel collapses;
    # the planar state leaves most of the surface uncovered (32 %), so the solver backs off toward the input to the
    # healthy state nearest it: not converged, healthy, and the violations and warnings say how far planarity is
    V, F = hypar()
    res = planarize((V, F), reference=(V, F), max_iterations=40, closeness_weight=0.0)
    assert not res.converged and res.healthy and res.coverage >= 0.85
    h = face_health(res.mesh[0], F, tolerance=1.0)
    assert h.counts["short_edge"] == h.counts["small"] == h.counts["corner"] == 0
    assert res.violations[0].startswith(f"{int(np.sum(res.planarity > 1e-4))} of 100 faces above the planarity")
    assert any(w.startswith("the most planar state found was not healthy (coverage") and
               f"max planarity {res.max_planarity:.3g}" in w for w in res.warnings), res.warnings
    assert "backed off to the last healthy state" in res.stop_reason
    # the state returned did not reach the tolerance, and nothing says it did ("tolerance not reached (tolerance
    # reached)" was the warning before)
    assert res.stop_reason.startswith("only panels that were not healthy reached the tolerance"), res.stop_reason
    assert not any("tolerance reached" in w for w in res.warnings), res.warnings
    check = independent_defects(res.mesh[0], F, reference=(V, F))
    assert check["defects"] == [] and check["coverage"] >= 0.85, check
    # with the default pull the guard holds the correction at first; the solver relaxes the closeness stiffness,
    # restores planarity and pulls the planar mesh back toward the surface: converged, and an independent check
    # agrees (the old solver stopped here at 40 iterations, unhealthy)
    res = planarize((V, F), reference=(V, F), max_iterations=40)
    assert res.converged and res.healthy and res.coverage >= 0.85
    check = independent_defects(res.mesh[0], F, reference=(V, F))
    assert check["defects"] == [] and check["coverage"] >= 0.85, check


def test_the_bounds_are_checked_with_the_shared_wording():
    V, F = hypar(3)
    with pytest.raises(InputError, match=r"^angle_guard: must be a finite number >= 0 and <= 1, got 1.5$"):
        planarize_mesh(V, F, angle_guard=1.5)
    with pytest.raises(InputError, match=r"^relax: must be a finite number >= 0 and <= 1"):
        planarize_mesh(V, F, relax=2.0)
    with pytest.raises(InputError, match=r"^min_angle: must be a finite number >= 0 and <= 60"):
        planarize_mesh(V, F, min_angle=75.0)
    with pytest.raises(InputError, match=r"^min_edge_ratio: "):
        planarize_mesh(V, F, min_edge_ratio=-0.1)


# ----------------------------------------------------------------------------------------------- units, placement


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_results_do_not_depend_on_units_or_placement(noise):
    V, F = height_grid(noise)
    runs = {}
    for label, scale, shift in (("x0.001", 1e-3, 0.0), ("x1", 1.0, 0.0), ("x1000", 1e3, 0.0), ("+5e6", 1.0, 5e6)):
        res = planarize((V * scale + shift, F))
        back = (res.mesh[0] - shift) / scale
        runs[label] = (res, back)
    ref, ref_back = runs["x1"]
    assert ref.converged and ref.healthy
    for label, (res, back) in runs.items():
        assert res.converged == ref.converged and res.healthy == ref.healthy, label
        assert abs(res.iterations - ref.iterations) <= 1, (label, res.iterations, ref.iterations)
        assert 0.5 * ref.max_planarity <= res.max_planarity <= 2.0 * ref.max_planarity, label
        assert len(res.warnings) == len(ref.warnings), (label, res.warnings)
        assert np.abs(back - ref_back).max() <= 1e-6 * 0.05, label  # the same mesh, to a millionth of an edge


def test_a_far_away_small_reference_is_not_refused():
    # the zero-area test of a reference 5e6 from the origin must not see cancellation as degenerate faces
    V, F = height_grid()
    res = planarize((V + 5e6, F), reference=(V + 5e6, F))
    assert res.converged and res.coverage > 0.99


@pytest.mark.parametrize("shift", [0.0, 5e6])
def test_the_verdict_judges_the_returned_mesh_against_the_reference_as_given(shift):
    # the verdict measures the returned positions against the reference as the caller gave it: a caller's own
    # face_health of the result at the same bounds reads the same coverage, to the last bit, at every placement
    V, F = height_grid(0.01)
    ref = (V + shift, triangulate(F)[0])
    res = planarize_mesh(V + shift, F, ref, min_coverage=0.85)
    own = face_health(res.mesh[0], F, ref, tolerance=1e300, min_edge_ratio=0.2, min_angle=20.0, min_area_ratio=0.1,
                      min_coverage=0.85)
    assert res.converged and res.healthy == own.healthy and res.violations == own.violations
    assert res.coverage == own.coverage and res.coverage > 0.95


def test_a_reference_with_a_zero_area_face_is_refused_naming_it():
    V, F = height_grid()
    T = triangulate(F)[0]
    for shift in (0.0, 5e6):
        Vr = V + shift
        Vr[T[5, 2]] = Vr[T[5, 0]]  # two corners of triangle 5 (and of its neighbour 4) coincide: zero area
        with pytest.raises(MeshError, match=r"reference: face \d+ is degenerate \(zero area\)"):
            planarize_mesh(V + shift, F, (Vr, T))


# ----------------------------------------------------------------------------------------------- input handling


def test_a_triangle_mesh_comes_back_unchanged():
    V, F = hypar()
    T = triangulate(F)[0]
    res = planarize((V, T))
    assert res.converged and res.iterations == 0 and res.healthy
    assert np.array_equal(res.mesh[0], V) and np.array_equal(res.mesh[1], T)
    assert np.all(res.planarity == 0.0) and "triangles only" in res.stop_reason


def test_padded_triangles_take_no_part_in_planarity_and_keep_their_shape():
    # corner quads of a hypar split into padded triangles: with the old solver the triangles (unguarded) collapsed
    # to 0° corners; now they stay healthy, their planarity is 0 and the quads converge
    V, F = hypar()
    F2 = split_into_triangles(F, {0, 9, 90, 99, 44})
    res = planarize((V, F2))
    assert res.converged, res.warnings
    tri = F2[:, 2] == F2[:, 3]
    assert np.all(res.planarity[tri] == 0.0)
    assert np.array_equal(res.mesh[1], F2)
    assert_fabricable(res, F2)


def test_a_quad_soup_is_welded_with_a_warning():
    V, F = hypar()
    soup, Fs = V[F.ravel()], np.arange(4 * len(F)).reshape(-1, 4)
    res = planarize((soup, Fs))
    assert res.converged and res.max_planarity <= 1e-4
    assert any("duplicate vertices were welded" in w for w in res.warnings)
    X = res.mesh[0]
    assert X.shape == soup.shape  # the input's vertices and faces come back
    for v in range(len(V)):  # the panels still touch exactly where they touched
        copies = X[F.ravel() == v]
        assert np.abs(copies - copies[0]).max() == 0.0
    # a soup whose copies are 1e-6 apart is welded within the request's absolute tolerance
    rng = np.random.default_rng(0)
    jittered = soup + 1e-6 * rng.standard_normal(soup.shape)
    assert planarize((jittered, Fs), absolute_tolerance=1e-4).converged


def test_unwelded_pieces_that_touch_are_refused_with_weld_in_the_message():
    V, F = hypar()
    soup, Fs = V[F.ravel()], np.arange(4 * len(F)).reshape(-1, 4)
    jittered = soup + 1e-6 * np.random.default_rng(0).standard_normal(soup.shape)
    with pytest.raises(MeshError, match=r"^mesh: the mesh is in unwelded pieces that touch: .* weld the mesh"):
        planarize((jittered, Fs))
    # two halves of a grid, the seam duplicated and moved 1e-5 apart
    V, F = quad_grid(4, 2, 4.0, 2.0)
    seam = np.arange(2, len(V), 5)  # the middle column of vertices
    V2 = np.vstack([V, V[seam] + [1e-5, 0.0, 0.0]])
    F2 = F.copy()
    right = F2[:, 0] % 5 >= 2  # faces right of the seam use the copies
    remap = np.arange(len(V))
    remap[seam] = len(V) + np.arange(len(seam))
    F2[right] = remap[F2[right]]
    with pytest.raises(MeshError, match="weld"):
        planarize((V2, F2))


def test_a_zero_length_edge_is_refused_naming_the_face():
    # a demanding user wants to hear about a collapsed panel before anything is computed: as a quad it has no
    # defined planarity and would be reported as a planar panel; the message says how to fix it
    V, F = hypar()
    V2 = np.vstack([V, V[5]])  # vertex 121 sits on vertex 5
    F2 = F.copy()
    F2[4] = [4, 5, 121, 15]
    with pytest.raises(MeshError, match=r"^mesh: face 4 \[4, 5, 121, 15\] has a zero-length edge: vertices 5 and "
                                        r"121 are 0 apart .* \(a, b, c, c\)"):
        planarize((V2, F2))
    with pytest.raises(MeshError, match="candidate: face 4"):
        planarize_mesh(V2, F2, mesh_name="candidate")


def test_the_final_verdict_uses_the_guards_bounds_for_an_already_bad_input():
    # the dos heart has 6.2° corners: the guard lets such a corner lose at most 10 % (instead of half, and instead
    # of calling every result unhealthy) and a warning says so
    V, F = read_mesh(data_file("obj_pq__heart.obj"))
    res = planarize((V, F))
    assert any(w.startswith("planarize: the input already has corners of 6.19°") for w in res.warnings)
    worst_in = face_health(V, F).worst_corner
    h = face_health(res.mesh[0], F, min_angle=0.9 * worst_in)
    assert min(h.worst_corner, 180 - h.worst_corner) >= 0.9 * worst_in
    assert h.shortest_edge_ratio >= 0.2  # the old solver collapsed an edge to 1e-4 × the median here
    assert res.converged and res.healthy, res.violations


def test_a_stalled_run_stops_early_with_a_reason():
    # the hypar with its boundary sliding on itself has no healthy planar solution nearby: the solver stops within
    # the iteration cap, healthy, and names why
    V, F = hypar()
    t = time.perf_counter()
    res = planarize((V, F), reference=(V, F), boundary="slide")
    assert time.perf_counter() - t < 20.0
    assert res.healthy and not res.converged and res.iterations < 100
    assert res.stop_reason.startswith(("stalled", "no step"))
    assert np.all(face_health(res.mesh[0], F).area_ratio > 0.1)


def test_an_edge_that_starts_under_the_bound_is_lifted_over_it():
    # a column of edges at 0.15 × the median: the verdict judges the result by 0.2 × the median, so the guard lifts
    # them (the old guard only kept them from shrinking, and the result could never be healthy)
    V, F = quad_grid(8, 8, 8.0, 8.0)
    V[np.isclose(V[:, 0], 1.0), 0] = 0.15
    V[:, 2] = 0.3 * np.sin(0.7 * V[:, 0]) * np.cos(0.5 * V[:, 1])
    E = edge_topology(F).E

    def shortest(X):
        L = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
        return L.min() / np.median(L)

    assert shortest(V) < 0.16
    res = planarize((V, F))
    assert res.converged and res.healthy
    assert shortest(res.mesh[0]) >= 0.2


def test_the_relaxed_guard_is_checked_against_the_angle_guard():
    V, F = hypar(3)
    with pytest.raises(InputError, match=r"^relaxed_guard: must be a finite number >= 0 and <= 0.5, got 0.7$"):
        planarize_mesh(V, F, relaxed_guard=0.7)
    res = planarize_mesh(V, F, relaxed_guard=0.05)
    assert res.converged == (res.max_planarity <= 1e-4 and res.healthy)
