"""Panel health (components.metrics.health): every defect that made "planar and converged" results unfabricable is
caught, clean curved surfaces raise no false alarm, and the verdict does not depend on units or placement."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import quad_grid, triangulate
from components.metrics.health import DEFECT_BITS, face_health, panel_health


def grid(n=10, size=10.0, height=None):
    return quad_grid(n, n, size, size, height)


def own_reference(V, F):
    return V.copy(), triangulate(F)[0]


def ribbon(turn=1.2, n=25, rows=3, tilt=0.3):
    """A strip wound around a cylinder ``turn`` times; its radius tilts across the strip one way at the start and the
    other way at the end, so that where it overlaps itself (turn > 1) the two layers cross each other."""
    th = np.linspace(0.0, 2 * np.pi * turn, n + 1)
    s = np.linspace(0.0, 1.0, rows + 1)
    TH, S = np.meshgrid(th, s, indexing="xy")
    r = 1.0 + tilt * (S - 0.5) * (TH / (np.pi * turn) - 1.0)
    V = np.stack([(r * np.cos(TH)).ravel(), (r * np.sin(TH)).ravel(), S.ravel()], axis=1)
    return V, quad_grid(n, rows)[1]


def twisted_strip(n=10, rows=1, twist=np.pi / 2):
    """A 10:1 strip twisted by ``twist`` about its long axis (a helicoid: skew quads)."""
    x = np.linspace(0.0, 10.0, n + 1)
    s = np.linspace(-0.5, 0.5, rows + 1)
    X, S = np.meshgrid(x, s, indexing="xy")
    a = twist * X / 10.0
    V = np.stack([X.ravel(), (S * np.cos(a)).ravel(), (S * np.sin(a)).ravel()], axis=1)
    return V, quad_grid(n, rows)[1]


# ----------------------------------------------------------------------------------------------
# the cases (mesh, reference) used by the defect tests and, transformed, by the invariance test


def case_flat():
    V, Q = grid()
    return V, Q, own_reference(V, Q)


def case_collapsed():
    V, Q = grid()
    ref = own_reference(V, Q)
    V[56] = V[55] + [1e-6, 0.0, 0.0]  # edge (55, 56): 1 → 1e-6
    return V, Q, ref


def case_pushed():
    V, Q = grid()
    ref = own_reference(V, Q)
    V[60] += [2.5, 0.0, 0.0]  # its faces are stretched over faces two columns away
    return V, Q, ref


def case_half():
    V, Q = grid()
    ref = own_reference(V, Q)
    Vh, Qh = quad_grid(5, 10, 5.0, 10.0)
    return Vh, Qh, ref


def case_sharp_corner():
    V, Q = grid()
    ref = own_reference(V, Q)
    a = np.radians(0.5)  # vertex 56 on a ray 0.5° off the edge from vertex 45 back to vertex 44
    V[56] = V[45] + 0.5 * np.array([-np.cos(a), np.sin(a), 0.0])
    return V, Q, ref


def case_flipped():
    V, Q = grid()
    F = Q.copy()
    F[44] = F[44, ::-1]
    return V, F, own_reference(V, Q)


def case_crossing_ribbon():
    V, Q = ribbon(1.2)
    return V, Q, None


CASES = {
    "flat": case_flat,
    "collapsed": case_collapsed,
    "pushed": case_pushed,
    "half": case_half,
    "sharp_corner": case_sharp_corner,
    "flipped": case_flipped,
    "crossing_ribbon": case_crossing_ribbon,
}


def health(case):
    V, F, ref = case
    return face_health(V, F, ref)


# ----------------------------------------------------------------------------------------------
# defects


def test_flat_grid_is_healthy_and_covers_its_own_triangulation():
    h = health(case_flat())
    assert h.healthy and h.violations == []
    assert h.coverage == pytest.approx(1.0, abs=1e-12) and h.holes == 0
    assert h.worst_corner == pytest.approx(90.0) and h.shortest_edge_ratio == pytest.approx(1.0)
    assert not h.face_defects.any() and len(h.intersecting_pairs) == 0
    assert h.max_distance == pytest.approx(0.0, abs=1e-12) and not h.reversed


def test_collapsed_edge_is_named():
    V, Q = grid()
    V[56] = V[55] + [1e-9, 0.0, 0.0]
    h = face_health(V, Q, own_reference(*grid()))
    assert not h.healthy
    assert h.shortest_edge_ratio == pytest.approx(1e-9, rel=1e-6)
    assert h.short_edges.tolist() == [[55, 56]]
    assert h.violations[0].startswith("1 edge shorter than 0.2 × median edge (shortest 1e-09 × median: edge (55, 56))")
    faces = np.nonzero(h.face_defects & DEFECT_BITS["short_edge"])[0]
    assert sorted(faces.tolist()) == [40, 50]  # the two faces on edge (55, 56)
    V[56] = V[55]  # coincident corners: degenerate
    h = face_health(V, Q)
    assert h.counts["degenerate"] == 2 and any("degenerate" in line for line in h.violations)


def test_pushed_vertex_folds_over_non_adjacent_faces():
    V, Q, ref = case_pushed()
    h = face_health(V, Q, ref)
    assert not h.healthy
    pairs = {tuple(p) for p in h.intersecting_pairs.tolist()}
    assert (44, 46) in pairs and (55, 57) in pairs
    for a, b in pairs:  # reported pairs share no vertex
        assert not set(Q[a]) & set(Q[b])
    moved = {f for f in range(len(Q)) if 60 in Q[f]}
    assert all(a in moved or b in moved for a, b in pairs)
    assert any("fold over non-adjacent faces" in line for line in h.violations)
    assert h.counts["intersecting"] == len({f for p in pairs for f in p})


def test_crossing_layers_of_a_curved_ribbon_are_found_and_clean_curved_surfaces_are_not():
    V, Q = ribbon(1.2)
    h = face_health(V, Q)
    assert len(h.intersecting_pairs) > 0
    i, j = h.intersecting_pairs.T
    assert np.all(np.abs(i - j) >= 20)  # start and end of the strip (25 faces a row), never neighbours
    # the same ribbon short of a full turn, a tight cylinder strip and a saddle: curved, clean
    for V, Q in (ribbon(0.9), _cylinder_strip(), quad_grid(20, 20, 2.0, 2.0, lambda x, y: (x - 1) * (y - 1))):
        h = face_health(V, Q, own_reference(V, Q))
        assert len(h.intersecting_pairs) == 0
        assert h.counts["folded"] == h.counts["flipped"] == h.counts["nonconvex"] == 0
        assert h.coverage == pytest.approx(1.0, abs=1e-9)


def _cylinder_strip(segments=12, turn=0.95):
    th = np.linspace(0.0, 2 * np.pi * turn, segments + 1)
    TH, Z = np.meshgrid(th, np.linspace(0.0, 1.0, 3), indexing="xy")
    V = np.stack([np.cos(TH).ravel(), np.sin(TH).ravel(), Z.ravel()], axis=1)
    return V, quad_grid(segments, 2)[1]


def test_twisted_strip_is_only_non_planar_and_planarized_it_is_healthy():
    from components.planarize.planarizer import planarize

    V, Q = twisted_strip()
    ref = own_reference(V, Q)
    h = face_health(V, Q, ref)
    assert h.counts["nonplanar"] == 10 and len(h.violations) == 1
    assert h.violations[0].startswith("10 faces not planar: planarity above 0.001")
    assert h.planarity.max() == pytest.approx(0.0556, abs=1e-3)
    r = planarize((V, Q))
    assert r.converged
    h = face_health(r.mesh[0], Q, ref)
    assert h.healthy, h.violations
    assert h.planarity.max() <= 1e-4 + 1e-12


def test_half_cover_reports_half_coverage_and_one_hole():
    h = health(case_half())
    assert h.coverage == pytest.approx(0.5, abs=0.01)
    assert h.holes == 1
    assert any(line.startswith("coverage 50% of the design surface < 85% (1 hole") for line in h.violations)
    assert health(case_half())._replace(violations=[]).counts == {k: 0 for k in DEFECT_BITS}
    assert face_health(*case_half()[:2], case_half()[2], min_coverage=0.4).healthy


def test_half_a_dome_missing_is_one_hole_against_a_coarse_reference():
    # reference: 4 big triangles; mesh: a 12 x 12 grid with a 4 x 4 block of faces removed in the middle
    Vr = np.array([[0, 0, 0], [12, 0, 0], [12, 12, 0], [0, 12, 0], [6, 6, 0]], dtype=float)
    Tr = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    V, Q = quad_grid(12, 12, 12.0, 12.0)
    keep = [f for f in range(len(Q)) if not (4 <= f % 12 < 8 and 4 <= f // 12 < 8)]
    h = face_health(V, Q[keep], (Vr, Tr))
    assert h.holes == 1
    assert h.coverage == pytest.approx(1.0 - 16.0 / 144.0, abs=0.01)


def test_sharp_corner_is_found():
    h = health(case_sharp_corner())
    assert h.worst_corner == pytest.approx(0.5, abs=1e-9)
    assert h.face_defects[40] & DEFECT_BITS["corner"]
    assert any("corners under 20° or over 160° (worst 0.5° at face 40)" in line for line in h.violations)


def test_flipped_face_is_found_and_a_reversed_mesh_is_not_a_defect():
    h = health(case_flipped())
    assert np.nonzero(h.face_defects & DEFECT_BITS["flipped"])[0].tolist() == [44]
    assert h.counts["nonmanifold"] == 5  # the face and its 4 edge neighbours: edges used twice the same way
    V, Q = grid()
    h = face_health(V, Q[:, ::-1], own_reference(V, Q))
    assert h.healthy and h.reversed


def test_closeness_is_relative_to_the_median_edge():
    V, Q = grid()
    T = triangulate(Q)[0]
    ref = (V.copy(), T)
    V[60, 2] += 0.3  # triangles stay planar
    h = face_health(V, T, ref)
    assert h.max_distance == pytest.approx(0.3) and h.healthy
    h = face_health(V, T, ref, closeness_limit=0.2)
    assert not h.healthy and h.counts["far"] == int(np.sum(T == 60))
    assert h.violations == [f"{h.counts['far']} faces with corners farther than 0.2 × median edge from the reference "
                            "(farthest 0.3 × median edge)"]


def test_folded_neighbours_are_found():
    V, Q = quad_grid(3, 1)  # three faces in a row; fold the last one back over the middle one
    V = V.copy()
    V[[3, 7], 0] = 1.0 / 3.0 + 0.01
    V[[3, 7], 2] = 0.05
    h = face_health(V, Q)
    assert h.face_defects[1] & DEFECT_BITS["folded"] and h.face_defects[2] & DEFECT_BITS["folded"]
    assert any("folded onto an edge neighbour" in line for line in h.violations)


# ----------------------------------------------------------------------------------------------
# unit and placement invariance


TRANSFORMS = {
    "x0.001": (1e-3, 0.0),
    "x1000": (1e3, 0.0),
    "+5e6": (1.0, 5e6),
}


@pytest.mark.parametrize("transform", sorted(TRANSFORMS))
@pytest.mark.parametrize("name", sorted(CASES))
def test_same_verdict_and_numbers_at_any_scale_and_placement(name, transform):
    scale, shift = TRANSFORMS[transform]
    V, F, ref = CASES[name]()
    base = face_health(V, F, ref)
    move = (lambda X: X * scale + shift)
    h = face_health(move(V), F, None if ref is None else (move(ref[0]), ref[1]))
    assert h.healthy == base.healthy
    assert h.counts == base.counts
    assert len(h.violations) == len(base.violations)
    assert np.array_equal(h.face_defects, base.face_defects)
    assert np.array_equal(h.intersecting_pairs, base.intersecting_pairs)
    assert np.array_equal(h.short_edges, base.short_edges)
    assert h.holes == base.holes
    assert h.shortest_edge_ratio == pytest.approx(base.shortest_edge_ratio, rel=1e-3)
    assert h.worst_corner == pytest.approx(base.worst_corner, abs=1e-4)
    assert np.allclose(h.planarity, base.planarity, atol=1e-7)
    if ref is not None:
        assert h.coverage == pytest.approx(base.coverage, abs=1e-9)
        assert h.max_distance == pytest.approx(base.max_distance, abs=1e-6)
    assert h.median_edge == pytest.approx(base.median_edge * scale, rel=1e-6)


# ----------------------------------------------------------------------------------------------
# size, errors, the published component


def test_100_by_100_wavy_grid():
    V, Q = quad_grid(100, 100, 10.0, 10.0, lambda x, y: 0.3 * np.sin(x) * np.cos(1.3 * y))
    h = face_health(V, Q, own_reference(V, Q))
    assert len(h.intersecting_pairs) == 0 and h.counts["folded"] == 0 and h.counts["flipped"] == 0
    assert h.coverage == pytest.approx(1.0, abs=1e-9) and h.holes == 0
    assert h.counts["nonplanar"] > 0  # a grid on a wavy surface is not planar: found, and nothing else
    assert all(line.endswith(")") and "not planar" in line for line in h.violations)


@pytest.mark.parametrize("make, name", [
    (lambda: face_health(np.zeros((0, 3)), np.zeros((0, 4), dtype=np.int64)), "mesh"),
    (lambda: face_health(np.array([[0, 0, 0], [1, 0, 0], [1, np.nan, 0], [0, 1, 0]]), [[0, 1, 2, 3]]), "mesh"),
    (lambda: face_health(np.zeros((4, 3)), [[0, 1, 2, 3]]), "mesh"),  # all vertices coincide
    (lambda: face_health(*grid(2), (np.full((3, 3), np.nan), [[0, 1, 2]])), "reference"),
    (lambda: panel_health(None), "mesh"),
])
def test_degenerate_inputs_raise_mesh_errors(make, name):
    with pytest.raises(MeshError) as err:
        make()
    assert str(err.value).startswith(name + ":")


@pytest.mark.parametrize("option, value", [("min_angle", 90.0), ("min_angle", -1.0), ("min_coverage", 1.5),
                                           ("tolerance", float("nan")), ("min_edge_ratio", "x")])
def test_bad_bounds_raise_input_errors(option, value):
    with pytest.raises(InputError) as err:
        panel_health(grid(2), **{option: value})
    assert str(err.value).startswith(option + ":")


def test_published_component():
    V, Q, ref = case_pushed()
    r = panel_health((V, Q), ref)
    assert not r.healthy and r.violations
    assert {44, 46, 55, 57} <= set(r.intersecting_faces.tolist())
    assert set(r.intersecting_faces.tolist()) <= set(r.unhealthy_faces.tolist())
    assert np.all(r.face_defects[r.intersecting_faces] & DEFECT_BITS["intersecting"])
    assert np.array_equal(np.nonzero(r.face_defects)[0], r.unhealthy_faces)
    assert r.coverage == pytest.approx(face_health(V, Q, ref).coverage)
    r = panel_health(grid(4))
    assert r.healthy and r.coverage == -1.0 and r.holes == 0 and len(r.unhealthy_faces) == 0


def test_a_triangle_index_is_a_reference_too():
    from components.core.proximity import TriangleIndex

    V, F, ref = case_half()
    a = face_health(V, F, ref)
    b = face_health(V, F, TriangleIndex(*ref))
    assert (a.coverage, a.holes, a.violations, a.max_distance) == (b.coverage, b.holes, b.violations, b.max_distance)
    assert np.array_equal(a.face_defects, b.face_defects)


def test_crossing_pairs_match_every_pair_tested():
    """The broad phase (face spheres, then triangle spheres) loses no crossing: two crumpled layers crossing each
    other, against the check of every pair of faces on its own."""
    rng = np.random.default_rng(5)
    V1, Q1 = grid(4, 4.0)
    V2 = V1 @ np.array([[1.0, 0.0, 0.0], [0.0, 0.8, 0.6], [0.0, -0.6, 0.8]]) + [0.3, 0.2, -1.2]
    V = np.concatenate([V1, V2]) + rng.normal(size=(2 * len(V1), 3)) * 0.2
    Q = np.concatenate([Q1, Q1 + len(V1)])
    bounds = dict(min_edge_ratio=0.0, min_angle=0.0, min_area_ratio=0.0, intersection_tolerance=0.0)
    found = face_health(V, Q, **bounds).intersecting_pairs
    expected = [(a, b) for a in range(len(Q)) for b in range(a + 1, len(Q)) if not set(Q[a]) & set(Q[b]) and
                len(face_health(V, Q[[a, b]], **bounds).intersecting_pairs)]
    assert len(expected) >= 5
    assert found.tolist() == [list(e) for e in expected]
