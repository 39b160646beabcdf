"""PQ quality metrics on analytic cases, against libigl on the real meshes, and every bad input."""
from __future__ import annotations

import numpy as np
import pytest

from components.metrics import quality as M
from components.core.errors import InputError, MeshError
from components.core.mesh import face_sizes, pad_faces, quad_grid, read_mesh, triangulate
from tests.conftest import TESTDATA, data_file

# ----------------------------------------------------------------------------------------------
# small analytic meshes


def twisted_quad(h):
    """Unit square with corner 2 lifted by h: diagonal distance h / sqrt(2 h² + 4)."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, h], [0, 1, 0]])
    return V, np.array([[0, 1, 2, 3]])


def saddle_quad(a, b, c):
    """Quad centred on the saddle z = c x y: both diagonals horizontal, at heights ±c a b / 4."""
    x = np.array([-a / 2, a / 2, a / 2, -a / 2])
    y = np.array([-b / 2, -b / 2, b / 2, b / 2])
    return np.stack([x, y, c * x * y], axis=1), np.array([[0, 1, 2, 3]])


def fan(center, k, radius=1.0, z=0.0):
    """A disk of k quads around one centre vertex (centre valence k), ring of 2k boundary vertices."""
    s = np.linspace(0, 2 * np.pi, 2 * k, endpoint=False)
    r = np.where(np.arange(2 * k) % 2 == 0, radius, radius * 1.2)
    ring = np.stack([center[0] + r * np.cos(s), center[1] + r * np.sin(s), np.full(2 * k, z)], axis=1)
    V = np.vstack([center, ring])
    F = [[0, 1 + 2 * i, 1 + (2 * i + 1) % (2 * k), 1 + (2 * i + 2) % (2 * k)] for i in range(k)]
    return V, np.array(F)


@pytest.fixture
def valence_3_and_5():
    V3, F3 = fan(np.array([0.0, 0, 0]), 3)
    V5, F5 = fan(np.array([5.0, 0, 0]), 5)
    return np.vstack([V3, V5]), np.vstack([F3, F5 + len(V3)])


def lsq_normal(P):
    X = P - P.mean(axis=0)
    return np.linalg.svd(X)[2][-1]


# ----------------------------------------------------------------------------------------------
# planarity, warping, diagonals, areas


def test_planar_grid_is_zero_everywhere(planar_grid, mixed_strip):
    for mesh in (planar_grid, mixed_strip):
        for measure in ("diagonal", "angle", "warping"):
            r = M.planarity(mesh, measure)
            assert r.max_planarity == 0.0 and r.mean_planarity == 0.0 and len(r.planarity) == len(mesh[1])
        assert M.warping(mesh).max_warping == 0.0


def test_twisted_quad_diagonal_distance():
    h = 0.3
    V, F = twisted_quad(h)
    dist = h / np.sqrt(2 * h * h + 4)
    mean_diag = 0.5 * (np.sqrt(2 + h * h) + np.sqrt(2))
    np.testing.assert_allclose(M.warping_height(V, F), [dist], rtol=1e-14)
    np.testing.assert_allclose(M.quad_planarity(V, F), [dist / mean_diag], rtol=1e-14)
    r = M.planarity((V, F))
    assert r.max_planarity == pytest.approx(dist / mean_diag, rel=1e-14)
    # angle: dihedral between the triangle pairs of both diagonal splits, the larger
    a, b, c, d = V

    def ang(n1, n2):
        return np.arccos(abs(n1 @ n2) / np.linalg.norm(n1) / np.linalg.norm(n2))

    expected = max(ang(np.cross(b - a, c - a), np.cross(c - a, d - a)), ang(np.cross(c - b, d - b), np.cross(d - b, a - b)))
    np.testing.assert_allclose(M.planarity_angle(V, F), [expected], rtol=1e-12)


def test_hyperbolic_paraboloid_quads(hypar_grid):
    a, b, c = 0.4, 0.25, 0.5
    V, F = saddle_quad(a, b, c)
    np.testing.assert_allclose(M.warping_height(V, F), [c * a * b / 2], rtol=1e-14)
    np.testing.assert_allclose(M.quad_planarity(V, F), [c * a * b / 2 / np.hypot(a, b)], rtol=1e-14)
    # the fixture z = x y / 2: every quad is twisted
    V, F = hypar_grid
    w = M.warping(hypar_grid)
    assert w.min_warping > 0
    # independent check: least-squares distance between the diagonal lines of every quad
    for f, h in zip(F, w.warping):
        v0, v1, v2, v3 = V[f]
        A = np.stack([v2 - v0, -(v3 - v1)], axis=1)
        ts, *_ = np.linalg.lstsq(A, v1 - v0, rcond=None)
        gap = np.linalg.norm(v0 + ts[0] * (v2 - v0) - v1 - ts[1] * (v3 - v1))
        assert gap == pytest.approx(h, rel=1e-10)
    # a sheared copy of the saddle quad is a different quad: the diagonal gap is not affine invariant, but the
    # centred quad sampled from the fixture's surface is the analytic case
    Vc, Fc = saddle_quad(0.2, 0.2, 0.5)
    np.testing.assert_allclose(M.warping_height(Vc, Fc), [0.5 * 0.2 * 0.2 / 2], rtol=1e-14)
    assert M.planarity(hypar_grid, "angle").min_planarity > 0


def test_ngon_planarity_uses_least_squares_plane():
    s = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    z = np.array([0.1, -0.1, 0.1, -0.1, 0.1, -0.1])
    V = np.stack([np.cos(s), np.sin(s), z], axis=1)
    F = np.arange(6)[None]
    # the alternating hexagon's least-squares plane is z = 0
    np.testing.assert_allclose(M.warping_height(V, F), [0.1], rtol=1e-12)
    np.testing.assert_allclose(M.quad_planarity(V, F), [0.1 / np.sqrt(1.04)], rtol=1e-12)  # edge² = 1 + 0.2²
    assert M.planarity_angle(V, F)[0] > 0
    V[:, 2] = 0.0
    assert M.quad_planarity(V, F)[0] < 1e-15 and M.planarity_angle(V, F)[0] < 1e-12


def test_diagonal_ratio_and_lengths(mixed_strip):
    V = np.array([[0.0, 0, 0], [3, 0, 0], [3, 1, 0], [0, 1, 0], [5, 0, 0], [6, 1, 0], [4, 1, 0]])
    F = pad_faces([[0, 1, 2, 3], [1, 4, 5, 2], [4, 6, 5]], k=4)
    r = M.diagonal_ratio((V, F))
    np.testing.assert_array_equal(r.faces, [0, 1])
    assert r.diagonal_ratio[0] == pytest.approx(1.0)
    d1, d2 = np.linalg.norm(V[5] - V[1]), np.linalg.norm(V[2] - V[4])
    assert r.diagonal_ratio[1] == pytest.approx(max(d1, d2) / min(d1, d2))
    np.testing.assert_allclose([r.diagonal_1[1], r.diagonal_2[1]], [d1, d2])
    assert M.diagonal_ratio(mixed_strip).faces.tolist() == [0, 1]


def test_areas_planar_and_projected(planar_grid, mixed_strip):
    r = M.face_areas(planar_grid)
    np.testing.assert_allclose(r.areas, 0.25)
    assert r.total_area == pytest.approx(6.0) and r.variance_area == pytest.approx(0.0, abs=1e-30)
    tri = M.face_areas(mixed_strip).areas
    assert tri[2] == pytest.approx(0.5 * 1.0 * 1.0)  # triangle (2,0),(3,0),(2,1)
    V, F = twisted_quad(0.4)
    n = lsq_normal(V)
    N = 0.5 * np.cross(V[2] - V[0], V[3] - V[1])  # area vector of a quad
    np.testing.assert_allclose(M.polygon_areas(V, F), [abs(N @ n)], rtol=1e-12)


# ----------------------------------------------------------------------------------------------
# edges, angles, Verdict


def test_edge_lengths_and_angles(planar_grid, mixed_strip):
    e = M.edge_lengths(planar_grid)
    np.testing.assert_allclose(e.lengths, 0.5)
    assert e.length_ratio == pytest.approx(1.0) and len(e.lengths) == 6 * 5 + 7 * 4
    a = M.corner_angles(planar_grid)
    np.testing.assert_allclose(a.min_angle, np.pi / 2)
    np.testing.assert_allclose(a.max_angle, np.pi / 2)
    ang, HF = M.interior_angles(*mixed_strip)
    sums = np.bincount(HF, weights=ang)
    np.testing.assert_allclose(sums, (face_sizes(mixed_strip[1]) - 2) * np.pi)
    # a planar dart: one reflex corner above π, angles still sum to 2π
    V = np.array([[0.0, 0, 0], [2, 1, 0], [0, 2, 0], [0.5, 1, 0]])
    F = np.array([[0, 1, 2, 3]])
    ang, _ = M.interior_angles(V, F)
    assert ang.sum() == pytest.approx(2 * np.pi) and ang.max() > np.pi
    assert M.corner_angles((V, F)).largest_angle > np.pi


def test_verdict_reference_shapes():
    square = (np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), np.array([[0, 1, 2, 3]]))
    _, m = M.verdict_quad_quality(*square)
    expected = dict(aspect_ratio=1, skew=0, taper=0, warpage=1, stretch=1, minimum_angle=90, maximum_angle=90,
                    scaled_jacobian=1)
    for k, v in expected.items():
        assert m[k][0] == pytest.approx(v, abs=1e-12), k
    c, s = np.cos(np.pi / 3), np.sin(np.pi / 3)
    rhombus = np.array([[0.0, 0, 0], [1, 0, 0], [1 + c, s, 0], [c, s, 0]])
    _, m = M.verdict_quad_quality(rhombus, np.array([[0, 1, 2, 3]]))
    assert m["skew"][0] == pytest.approx(0.5) and m["scaled_jacobian"][0] == pytest.approx(s)
    assert m["minimum_angle"][0] == pytest.approx(60) and m["maximum_angle"][0] == pytest.approx(120)
    assert m["taper"][0] == pytest.approx(0, abs=1e-12)
    trapezoid = np.array([[0.0, 0, 0], [2, 0, 0], [1.5, 1, 0], [0.5, 1, 0]])
    _, m = M.verdict_quad_quality(trapezoid, np.array([[0, 1, 2, 3]]))
    assert m["taper"][0] == pytest.approx(0.5)
    rect = np.array([[0.0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]])
    _, m = M.verdict_quad_quality(rect, np.array([[0, 1, 2, 3]]))
    assert m["aspect_ratio"][0] == pytest.approx(1.5) and m["stretch"][0] == pytest.approx(np.sqrt(2) / np.sqrt(5))
    dart = np.array([[0.0, 0, 0], [2, 1, 0], [0, 2, 0], [0.5, 1, 0]])
    _, m = M.verdict_quad_quality(dart, np.array([[0, 1, 2, 3]]))
    assert m["scaled_jacobian"][0] < 0 and m["maximum_angle"][0] > 180
    V, F = twisted_quad(0.5)
    _, m = M.verdict_quad_quality(V, F)
    assert 0 < m["warpage"][0] < 1
    r = M.verdict_quality((rect, np.array([[0, 1, 2, 3]])), "aspect_ratio")
    assert (r.acceptable_min, r.acceptable_max) == (1.0, 1.3) and r.count_outside == 1


# ----------------------------------------------------------------------------------------------
# conical criterion, valence


def test_conical_criterion_sphere_cap_is_zero(sphere_cap, planar_grid):
    r = M.conical_criterion(sphere_cap)
    assert len(r.vertices) == 4 * 16  # interior rings of the cap
    assert r.max_criterion < 1e-12 and r.max_deviation < 1e-7
    r = M.conical_criterion(planar_grid)
    assert len(r.vertices) == 5 * 3 and r.max_criterion < 1e-12 and r.max_deviation < 1e-12


def test_conical_criterion_detects_non_conical(planar_grid):
    V, F = planar_grid
    V = V.copy()
    rng = np.random.default_rng(0)
    V[:, 2] = 0.05 * rng.normal(size=len(V))
    V[:, :2] += 0.05 * rng.normal(size=(len(V), 2))
    r = M.conical_criterion((V, F))
    assert r.max_criterion > 1e-3 and r.max_deviation > 1e-3
    # independent check at one vertex: order the four faces around it by angle in the plane
    v = int(r.vertices[0])
    faces = np.nonzero((F == v).any(axis=1))[0]
    cen = V[F[faces]].mean(axis=1)[:, :2] - V[v, :2]
    faces = faces[np.argsort(np.arctan2(cen[:, 1], cen[:, 0]))]
    om = []
    for f in faces:
        i = list(F[f]).index(v)
        a, b = V[F[f][(i + 1) % 4]] - V[v], V[F[f][(i - 1) % 4]] - V[v]
        om.append(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))
    assert r.criterion[0] == pytest.approx(abs(om[0] + om[2] - om[1] - om[3]), rel=1e-10)


def test_cone_deviation_of_a_cylinder_is_zero():
    s = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    z = np.array([0.0, 0.4, 1.0, 1.3])
    V = np.array([[np.cos(t), np.sin(t), h] for h in z for t in s])
    F = np.array([[i * 12 + j, i * 12 + (j + 1) % 12, (i + 1) * 12 + (j + 1) % 12, (i + 1) * 12 + j]
                  for i in range(3) for j in range(12)])
    r = M.conical_criterion((V, F))
    assert len(r.vertices) == 24 and r.max_criterion < 1e-12 and r.max_deviation < 1e-9


def test_valence_regular_grid_and_singularities(planar_grid, valence_3_and_5):
    r = M.valence(planar_grid)
    interior = np.array([i for i in range(35) if 0 < i % 7 < 6 and 0 < i // 7 < 4])
    assert np.all(r.valence[interior] == 4) and r.count_singularities == 0 and len(r.singularities) == 0
    assert r.valence[0] == 2 and r.valence[1] == 3
    r = M.valence(valence_3_and_5)
    np.testing.assert_array_equal(r.singularities, [0, 7])
    np.testing.assert_array_equal(r.singularity_valence, [3, 5])
    assert (r.count_singularities, r.count_valence_3, r.count_valence_5, r.count_other) == (2, 1, 1, 0)
    assert len(M.conical_criterion(valence_3_and_5).vertices) == 0  # no interior valence-4 vertex


# ----------------------------------------------------------------------------------------------
# closeness, analysis, report


def test_closeness_signed_and_unsigned(planar_grid):
    V, F = planar_grid
    ref_V, ref_Q = quad_grid(3, 3, 4.0, 3.0)
    ref_V[:, :2] -= 0.5
    lifted = (V + [0, 0, 0.1], F)
    r = M.closeness(lifted, (ref_V, ref_Q))
    assert r.signed and r.warnings == []
    np.testing.assert_allclose(r.distances, 0.1, atol=1e-14)
    r = M.closeness((V - [0, 0, 0.2], F), (ref_V, ref_Q[:, ::-1]))  # flipped reference: below is now +
    np.testing.assert_allclose(r.distances, 0.2, atol=1e-14)
    T, _ = triangulate(ref_Q)
    soup = (ref_V, np.vstack([T, T[:1, ::-1]]))  # a duplicated, flipped triangle: not oriented
    r = M.closeness(lifted, soup)
    assert not r.signed and r.warnings and r.max_distance == pytest.approx(0.1)
    d, signed = M.vertex_distances(V, ref_V, ref_Q)
    assert signed and np.allclose(d, 0)


def test_analysis_display_mesh(mixed_strip, sphere_cap):
    r = M.analysis(mixed_strip, "diagonal_ratio")
    VD, FD, C = r.display
    sizes = face_sizes(mixed_strip[1])
    assert VD.shape == (sizes.sum(), 3) and C.shape == (sizes.sum(), 3) and C.dtype == np.uint8
    assert FD.shape == mixed_strip[1].shape and face_sizes(FD).tolist() == sizes.tolist()
    np.testing.assert_allclose(VD[FD], mixed_strip[0][mixed_strip[1]])
    assert r.element == "face" and r.indices.tolist() == [0, 1]
    for f in range(len(FD)):  # one colour per face
        assert len(np.unique(C[FD[f]], axis=0)) == 1
    assert np.all(C[FD[2]] == [160, 160, 160]) and np.all(C[FD[3]] == [160, 160, 160])
    r = M.analysis(sphere_cap, "planarity_angle", legend_min=0.0, legend_max=1.0)
    assert (r.legend_min, r.legend_max) == (0.0, 1.0)
    r = M.analysis(sphere_cap, "conical")
    assert r.element == "vertex" and len(r.values) == len(r.indices) == 64
    ref = (sphere_cap[0] * 1.01, sphere_cap[1])
    r = M.analysis(sphere_cap, "closeness", reference=ref)
    assert len(r.values) == len(sphere_cap[0]) and np.all(np.isfinite(r.values))
    for measure in M.MEASURES:
        if measure != "closeness":
            out = M.analysis(sphere_cap, measure)
            assert np.all(np.isfinite(out.values)) and out.legend_min <= out.legend_max


def test_analysis_closeness_colours_are_distances_to_the_reference_surface():
    """Closeness is the distance to the nearest point of the reference *surface*: over one large flat quad every
    vertex's value is its height (a vertex-to-vertex distance would be far larger), and each display corner
    carries the colour of its vertex's value on the legend."""
    from components.core.colors import colormap

    V, F = quad_grid(8, 6, 4.0, 3.0)
    V[:, 2] = 0.02 + 0.3 * V[:, 0] / 4.0 + 0.05 * V[:, 1] / 3.0  # heights 0.02 .. 0.37, all different rows
    ref = (np.array([[-10.0, -10.0, 0.0], [14.0, -10.0, 0.0], [14.0, 13.0, 0.0], [-10.0, 13.0, 0.0]]),
           np.array([[0, 1, 2, 3]]))
    r = M.analysis((V, F), "closeness", reference=ref)
    assert r.element == "vertex" and r.indices.tolist() == list(range(len(V)))
    np.testing.assert_allclose(np.abs(r.values), V[:, 2], rtol=0, atol=1e-12)
    assert (r.legend_min, r.legend_max) == pytest.approx((r.values.min(), r.values.max()))
    VD, FD, C = r.display
    corner_vertex = F.reshape(-1)  # quads: the display's corners in face order
    np.testing.assert_allclose(VD, V[corner_vertex])
    expected = colormap(r.values, r.legend_min, r.legend_max)[corner_vertex]
    assert np.array_equal(C, expected)
    low, high = np.argmin(V[:, 2]), np.argmax(V[:, 2])
    assert not np.array_equal(expected[corner_vertex == low][0], expected[corner_vertex == high][0])


def test_report_table(hypar_grid):
    table = M.metrics_report(*hypar_grid)
    assert all(np.isfinite(v) for v in table.values())
    assert table["quads"] == 100 and table["singularities"] == 0 and table["conical_vertices"] == 81
    assert table["planarity_max"] == pytest.approx(M.planarity(hypar_grid).max_planarity)
    assert table["warping_variance"] == pytest.approx(M.warping(hypar_grid).variance_warping, abs=1e-20)
    r = M.report(hypar_grid, reference=hypar_grid)
    assert len(r.names) == len(r.values) and "closeness_max" in r.names
    assert r.values[r.names.index("closeness_max")] == pytest.approx(0.0, abs=1e-14)


def test_summary_helper():
    s = M.summary([1.0, 2.0, 3.0])
    assert (s.count, s.min, s.max, s.mean) == (3, 1.0, 3.0, 2.0)
    assert s.variance == pytest.approx(2 / 3) and s.std == pytest.approx(np.sqrt(2 / 3))
    assert M.summary([]) == (0, 0.0, 0.0, 0.0, 0.0, 0.0)


# ----------------------------------------------------------------------------------------------
# libigl agreement on the real quad meshes


def _real_quad_meshes():
    return sorted(p.name for p in TESTDATA.iterdir() if p.suffix.lower() in (".obj", ".off", ".ply"))


@pytest.mark.parametrize("relative", _real_quad_meshes())
def test_planarity_matches_libigl_on_real_meshes(relative):
    igl = pytest.importorskip("igl")
    V, F = read_mesh(data_file(relative))
    if F.shape[1] != 4 or np.any(face_sizes(F) != 4):
        pytest.skip("not a pure quad mesh")
    ours = M.quad_planarity(V, F)
    ref = np.abs(igl.quad_planarity(V, F))
    D1, D2 = V[F[:, 2]] - V[F[:, 0]], V[F[:, 3]] - V[F[:, 1]]
    denom = np.linalg.norm(np.cross(D1, D2), axis=1) * 0.5 * (np.linalg.norm(D1, axis=1) + np.linalg.norm(D2, axis=1))
    keep = denom >= 1e-8  # libigl returns 0 below this absolute threshold
    np.testing.assert_allclose(ours[keep], ref[keep], atol=1e-12, rtol=0)
    table = M.metrics_report(V, F)
    assert all(np.isfinite(v) for v in table.values())


# ----------------------------------------------------------------------------------------------
# bad input: typed errors naming the input, never NaN


COMPONENTS = [M.planarity, M.warping, M.diagonal_ratio, M.face_areas, M.edge_lengths, M.corner_angles,
              M.verdict_quality, M.conical_criterion, M.valence, M.analysis, M.report]


@pytest.mark.parametrize("component", COMPONENTS, ids=lambda c: c.__name__)
def test_bad_meshes_raise_typed_errors(component, nonmanifold_fan):
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]])
    bad = {
        "nan": (np.where(np.arange(18).reshape(6, 3) == 4, np.nan, V), np.array([[0, 1, 2, 3]])),
        "zero area": (V, np.array([[0, 1, 4, 4]])),
        "repeated vertex": (V, np.array([[0, 1, 2, 1]])),
        "zero-length edge": (np.vstack([V, V[1]]), np.array([[0, 1, 6, 3]])),
        "non-manifold": nonmanifold_fan,
        "flipped neighbour": (V, np.array([[0, 1, 2, 3], [1, 2, 5, 4]])),
        "index out of range": (V, np.array([[0, 1, 2, 9]])),
        "not a mesh": np.zeros((4, 3)),
    }
    for what, mesh in bad.items():
        with pytest.raises(MeshError, match="^mesh") as err:
            component(mesh)
        if what == "not a mesh":
            assert str(err.value) == "mesh: must be a (V, F) pair of vertex and face arrays"


def test_zero_length_diagonal_and_edge_messages():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    with pytest.raises(MeshError, match="zero-length edge"):
        M.planarity((np.vstack([V, V[1]]), np.array([[0, 1, 4, 3]])))
    with pytest.raises(MeshError, match="^mesh"):
        M.diagonal_ratio((np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2, 3]])))


def test_bad_options_raise_typed_errors(planar_grid):
    with pytest.raises(InputError, match="^measure: must be one of 'diagonal', 'angle', 'warping', got 'flatness'$"):
        M.planarity(planar_grid, "flatness")
    with pytest.raises(InputError, match="^metric: must be one of 'aspect_ratio', .*, got 'oddy'$"):
        M.verdict_quality(planar_grid, "oddy")
    with pytest.raises(InputError, match="^measure: must be one of 'planarity', .*, got 'beauty'$"):
        M.analysis(planar_grid, "beauty")
    with pytest.raises(InputError, match="^measure: must be one of"):
        M.measure_values(*planar_grid, "beauty")
    with pytest.raises(InputError, match="^reference"):
        M.analysis(planar_grid, "closeness")
    with pytest.raises(MeshError, match="^reference: must be a \\(V, F\\) pair"):
        M.closeness(planar_grid, np.zeros(3))
    with pytest.raises(MeshError, match="^mesh: must be a \\(V, F\\) pair"):
        M.report(np.zeros((4, 3)))
    with pytest.raises(MeshError, match="^reference"):
        M.closeness(planar_grid, (np.full((3, 3), np.nan), np.array([[0, 1, 2]])))


def test_components_register_with_the_server():
    registry = pytest.importorskip("ghserver.registry")
    for fn in COMPONENTS + [M.closeness]:
        comp = registry.declare(fn, f"metrics/{fn.__name__}")
        assert comp.outputs
    comp = registry.declare(M.planarity, "metrics/planarity")
    assert [p.name for p in comp.outputs][:3] == ["planarity", "max_planarity", "mean_planarity"]


def test_conical_criterion_on_a_real_conical_mesh():
    conical = M.conical_criterion(read_mesh(data_file("obj_pq__conical1.obj")))
    other = M.conical_criterion(read_mesh(data_file("obj_pq__planarizednormalized_six_quad.obj")))
    assert len(conical.vertices) > 1000
    assert conical.max_criterion < 1e-2 and conical.mean_criterion < 1e-3 and conical.max_deviation < 1e-3
    assert other.mean_criterion > 10 * conical.max_criterion
