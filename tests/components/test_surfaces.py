"""Translation and scale-translation surfaces, presets, and NURBS surface tessellation."""
from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from components.surfaces import generators as surfaces
from components.core.checks import validate_mesh
from components.core.errors import InputError
from components.core.measures import quad_planarity
from components.core.mesh import boundary_loops, read_mesh, vertex_valence
from components.surfaces.generators import (
    grid_quads,
    paraboloid,
    scale_translation,
    surface_mesh,
    surface_points,
    translation,
)
from components.core.types import NurbsCurve, NurbsSurface
from tests.conftest import data_file

rhino3dm = pytest.importorskip("rhino3dm")

PROPERTY = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ----------------------------------------------------------------------------------------------
# random curves


def _rotation(angles):
    a, b, c = angles
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    Ry = np.array([[np.cos(c), 0, np.sin(c)], [0, 1, 0], [-np.sin(c), 0, np.cos(c)]])
    return Rz @ Rx @ Ry


@st.composite
def curve_pair(draw):
    """A generatrix running along x and a directrix along y (never parallel), as polylines or NURBS,
    rotated and moved together to an arbitrary place up to ±50 units from the origin."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    R = _rotation(rng.uniform(0, 2 * np.pi, 3))
    shift = rng.uniform(-50, 50, 3)
    out = []
    for axis in (0, 1):
        n = draw(st.integers(2, 8))
        P = np.zeros((n, 3))
        P[:, axis] = np.cumsum(rng.uniform(2.0, 5.0, n))
        P[:, 1 - axis] = rng.uniform(-0.3, 0.3, n)
        P[:, 2] = rng.uniform(-2.0, 2.0, n)
        if axis == 1:
            P[:, 1] -= P[0, 1]
        P = P @ R.T + shift
        kind = draw(st.sampled_from(["polyline", "nurbs"]))
        if kind == "polyline" or n < 3:
            out.append(P)
        else:
            degree = draw(st.integers(1, min(3, n - 1)))
            K = np.concatenate([np.zeros(degree), np.linspace(0, 1, n - degree + 1)[1:-1], np.ones(degree)])
            w = rng.uniform(0.5, 2.0, n) if draw(st.booleans()) else np.ones(n)
            out.append(NurbsCurve(degree, P, w, K * draw(st.sampled_from([1.0, 7.5]))))
    return tuple(out)


def _n_samples(curve, count, sampling):
    if sampling == "control":
        return len(curve.points) if isinstance(curve, NurbsCurve) else len(curve)
    return count + 1


# ----------------------------------------------------------------------------------------------
# translation surfaces


@PROPERTY
@given(
    curve_pair(),
    st.integers(1, 12),
    st.integers(1, 12),
    st.sampled_from(["count", "arclength", "control"]),
    st.sampled_from(["generatrix", "directrix"]),
)
def test_translation_surface_is_planar_with_expected_faces(curves, cu, cv, sampling, translate):
    g, d = curves
    r = translation(g, d, cu, cv, sampling=sampling, translate=translate)
    V, Q = r.mesh
    nu, nv = _n_samples(g, cu, sampling), _n_samples(d, cv, sampling)
    assert V.shape == (nu * nv, 3) and Q.shape == ((nu - 1) * (nv - 1), 4)
    assert r.face_count == (nu - 1) * (nv - 1)
    assert r.max_planarity <= 1e-12
    assert quad_planarity(V, Q).max() <= 1e-12
    validate_mesh(V, Q, kind="quad")
    G, D = r.generatrix_points, r.directrix_points
    N = V.reshape(nv, nu, 3)
    if translate == "generatrix":  # the generatrix stays in place
        assert np.array_equal(N[0], G)
        assert np.allclose(N[:, 0], G[0] + D - D[0], atol=1e-12, rtol=0)
    else:  # the directrix stays in place
        assert np.array_equal(N[:, 0], D)
        assert np.allclose(N[0], D[0] + G - G[0], atol=1e-12, rtol=0)


@PROPERTY
@given(curve_pair(), st.integers(1, 10), st.integers(1, 10), st.sampled_from(["generatrix", "directrix"]))
def test_equal_steps_give_equal_translation_edges(curves, cu, cv, translate):
    g, d = curves
    r = translation(g, d, cu, cv, sampling="arclength", translate=translate, equal_steps=True)
    V, Q = r.mesh
    nu = cu + 1
    N = V.reshape(cv + 1, nu, 3)
    # the path family: edges along the directrix (translate the generatrix) or along the generatrix
    E = np.linalg.norm(np.diff(N, axis=0 if translate == "generatrix" else 1), axis=2)
    assert np.ptp(E) <= 1e-9 * E.mean()
    assert r.max_planarity <= 1e-12


def test_translation_surface_closed_generatrix_is_a_tube():
    circle = rhino3dm.NurbsCurve.CreateFromCircle(rhino3dm.Circle(3.0))
    H = np.array([[circle.Points[i].X, circle.Points[i].Y, circle.Points[i].Z, circle.Points[i].W]
                  for i in range(len(circle.Points))])
    # the circle turned into the yz plane
    g = NurbsCurve(2, (H[:, :3] / H[:, 3:])[:, [2, 0, 1]], H[:, 3], np.array(circle.Knots.ToList()))
    d = np.array([[0.0, 0, 0], [4, 0, 1], [8, 0, 0], [12, 1, 0]])
    r = translation(g, d, 16, 6)
    V, Q = r.mesh
    assert r.face_count == 16 * 6 and len(V) == 16 * 7
    validate_mesh(V, Q, kind="quad")
    assert len(boundary_loops(Q)) == 2
    assert r.max_planarity <= 1e-12
    # closed generatrix and closed directrix: a torus-like closed net, Euler characteristic 0
    square = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 2], [0, 10, 0], [0, 0, 0]])
    r = translation(g, square, 12, 8)
    V, Q = r.mesh
    validate_mesh(V, Q, kind="quad")
    assert boundary_loops(Q) == [] and len(V) - 2 * len(Q) + len(Q) == 0
    assert r.max_planarity <= 1e-12


def test_translation_surface_of_two_lines_is_a_parallelogram_grid():
    r = translation(np.array([[0.0, 0, 0], [4, 0, 0]]), np.array([[0.0, 0, 0], [1, 3, 0]]), 4, 3)
    V, Q = r.mesh
    assert np.allclose(V[:, 2], 0)
    assert r.face_count == 12 and r.max_planarity == 0.0


@pytest.mark.parametrize("path", ["rhinovault_mesh_0.ply", "rhinovault_mesh_1.ply"])
def test_translation_surface_from_real_vault_edges(path):
    """Two boundary polylines of a real RhinoVAULT vault (a 10 × 10 quad grid, planarity 8e-2) meeting at a
    corner give a translation surface with the same grid of 100 faces, planar to 1e-12."""
    V0, F0 = read_mesh(data_file(path))
    loop = boundary_loops(F0)[0]
    val = vertex_valence(F0, len(V0))
    corners = [k for k, v in enumerate(loop) if val[v] == 2]
    R = np.roll(loop, -corners[0])  # starts at a corner
    nxt, prev = corners[1] - corners[0], corners[-1] - corners[0]
    side1 = V0[R[: nxt + 1]]  # from the corner forward to the next corner
    side0 = V0[np.concatenate([R[:1], R[prev:][::-1]])]  # from the corner backward to the previous one
    r = translation(side1, side0, sampling="control")
    V, Q = r.mesh
    assert r.face_count == len(F0) == (len(side1) - 1) * (len(side0) - 1)
    assert r.max_planarity <= 1e-12 < quad_planarity(V0, F0).max()
    assert np.array_equal(V[: len(side1)], side1)
    validate_mesh(V, Q, kind="quad")


# ----------------------------------------------------------------------------------------------
# scale-translation surfaces


@PROPERTY
@given(
    curve_pair(),
    st.integers(1, 10),
    st.integers(1, 10),
    st.sampled_from(["count", "arclength", "control"]),
    st.integers(0, 2**32 - 1),
    st.booleans(),
    st.booleans(),
)
def test_scale_translation_surface_is_planar(curves, cu, cv, sampling, seed, per_step, user_centre):
    g, d = curves
    rng = np.random.default_rng(seed)
    nv = _n_samples(d, cv, sampling)
    factors = np.exp(rng.uniform(np.log(0.75), np.log(1.3), nv - 1)) if per_step else None
    scale = 1.0 if per_step else float(rng.uniform(0.8, 1.2))
    centre = rng.uniform(-60, 60, 3) if user_centre else None
    r = scale_translation(g, d, factors, scale, centre, cu, cv, sampling)
    V, Q = r.mesh
    nu = _n_samples(g, cu, sampling)
    assert r.face_count == (nu - 1) * (nv - 1) == len(Q)
    assert r.max_planarity <= 1e-12
    expected = np.concatenate([[1.0], np.cumprod(factors if per_step else np.full(nv - 1, scale))])
    assert np.allclose(r.scales, expected, rtol=1e-14, atol=0)
    # the u edges of consecutive sections are parallel, in the ratio of the step's factor
    N = V.reshape(nv, nu, 3)
    E = np.diff(N, axis=1)
    ratio = np.linalg.norm(E[1:], axis=2) / np.linalg.norm(E[:-1], axis=2)
    assert np.allclose(ratio, (r.scales[1:] / r.scales[:-1])[:, None], rtol=1e-10)
    cross = np.linalg.norm(np.cross(E[1:], E[:-1]), axis=2)
    assert np.all(cross <= 1e-12 * np.linalg.norm(E[1:], axis=2) * np.linalg.norm(E[:-1], axis=2))


def test_scale_translation_centre_follows_directrix():
    g = np.array([[-2.0, 0, 0], [0, 0, 1], [2, 0, 0]])
    d = np.array([[0.0, 0, 0], [0, 5, 1]])
    r = scale_translation(g, d, scale=0.5, centre=np.array([0.0, 0, 0]), count_u=2, count_v=2,
                                  sampling="count")
    V, _ = r.mesh
    assert np.allclose(r.centres, [[0, 0, 0], [0, 2.5, 0.5], [0, 5, 1]])
    assert np.allclose(V[6:], [[-0.5, 5, 1], [0, 5, 1.25], [0.5, 5, 1]])  # the last section at scale 1/4
    assert np.allclose(r.scales, [1, 0.5, 0.25])
    # default centre: centroid of the sampled generatrix
    r = scale_translation(g, d, scale=0.5, count_u=2, count_v=1, sampling="count")
    assert np.allclose(r.centres[0], [0, 0, 1 / 3])


def test_scale_one_reproduces_the_translation_surface():
    rng = np.random.default_rng(2)
    g = np.column_stack([np.arange(5.0), rng.uniform(-0.2, 0.2, 5), rng.uniform(-1, 1, 5)])
    d = np.column_stack([rng.uniform(-0.2, 0.2, 4), np.arange(4.0) * 2, rng.uniform(-1, 1, 4)])
    d[0] = g[0]
    a = translation(g, d, 8, 6)
    b = scale_translation(g, d, count_u=8, count_v=6)
    assert np.allclose(a.mesh[0], b.mesh[0], atol=1e-12) and np.array_equal(a.mesh[1], b.mesh[1])


# ----------------------------------------------------------------------------------------------
# presets


@pytest.mark.parametrize("kind, sign", [("elliptic", 1.0), ("hyperbolic", -1.0)])
def test_paraboloid_presets(kind, sign):
    a, b, hu, hv = 30.0, 20.0, 4.0, 3.0
    r = paraboloid(kind, a, b, hu, hv, 12, 8)
    V, Q = r.mesh
    x, y, z = V.T
    assert np.allclose(z, hu * (1 - (2 * x / a) ** 2) + sign * hv * (1 - (2 * y / b) ** 2), atol=1e-12)
    assert r.face_count == 96 and r.max_planarity <= 1e-12
    assert np.allclose(np.unique(x.round(9)), np.linspace(-a / 2, a / 2, 13))
    assert np.allclose(np.unique(y.round(9)), np.linspace(-b / 2, b / 2, 9))
    # Gaussian curvature sign of z = f(x, y): sign(f_xx f_yy) with f_xy = 0
    assert np.sign((-8 * hu / a**2) * (-8 * sign * hv / b**2)) == sign
    assert isinstance(r.generatrix, NurbsCurve) and isinstance(r.directrix, NurbsCurve)


def test_unknown_paraboloid_kind_lists_valid_ones():
    with pytest.raises(InputError, match="must be one of 'elliptic', 'hyperbolic', got 'spherical'") as info:
        paraboloid("spherical")
    assert info.value.input_name == "kind"
    for name, kwargs in (("span_u", {"span_u": 0.0}), ("span_v", {"span_v": -1.0}), ("rise_u", {"rise_u": np.nan}),
                         ("count_v", {"count_v": 0})):
        with pytest.raises(InputError) as info:
            paraboloid(**kwargs)
        assert info.value.input_name == name


# ----------------------------------------------------------------------------------------------
# typed errors of the surface components

G = np.array([[0.0, 0, 0], [1, 0, 1], [2, 0, 0]])
D = np.array([[0.0, 0, 0], [0, 1, 0.5], [0, 2, 0]])


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"generatrix": np.array([[1.0, 1, 1]])}, "generatrix"),
        ({"generatrix": np.array([[0.0, 0, 0], [0, 0, 0], [1, 0, 0]])}, "generatrix"),
        ({"directrix": np.array([[0.0, 0, 0], [np.nan, 1, 0]])}, "directrix"),
        ({"directrix": np.array([[0.0, 0, 0], [0, 0, 0]])}, "directrix"),
        ({"count_u": 0}, "count_u"),
        ({"count_v": -2}, "count_v"),
        ({"sampling": "random"}, "sampling"),
        ({"translate": "both"}, "translate"),
        # a straight generatrix parallel to a straight directrix: zero-area faces
        ({"generatrix": np.array([[0.0, 0, 0], [1, 0, 0]]), "directrix": np.array([[0.0, 0, 0], [3, 0, 0]])},
         "directrix"),
    ],
)
def test_translation_surface_errors(kwargs, name):
    args = {"generatrix": G, "directrix": D, **kwargs}
    with pytest.raises(InputError) as info:
        translation(**args)
    assert info.value.input_name == name and str(info.value).startswith(name + ":")


def test_unknown_mode_messages_list_valid_values():
    with pytest.raises(InputError, match="^sampling: must be one of 'count', 'arclength', 'control', got 'uniform'"):
        translation(G, D, sampling="uniform")
    with pytest.raises(InputError, match="^translate: must be one of 'generatrix', 'directrix', got 'profile'"):
        translation(G, D, translate="profile")


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"scale": 0.0}, "scale"),
        ({"scale": -1.0}, "scale"),
        ({"scale": np.nan}, "scale"),
        ({"scale_factors": np.array([1.0, 0.0])}, "scale_factors"),
        ({"scale_factors": np.array([1.0, -0.5])}, "scale_factors"),
        ({"scale_factors": np.array([1.0, np.nan])}, "scale_factors"),
        ({"scale_factors": np.array([1.0, 1.0, 1.0])}, "scale_factors"),
        ({"centre": np.array([0.0, np.nan, 0])}, "centre"),
        ({"centre": np.array([0.0, 1.0])}, "centre"),
        ({"generatrix": np.array([[1.0, 1, 1]])}, "generatrix"),
        ({"directrix": np.array([[0.0, 0, 0], [0, 0, 0]])}, "directrix"),
        ({"count_u": 0}, "count_u"),
        ({"sampling": "nope"}, "sampling"),
    ],
)
def test_scale_translation_errors(kwargs, name):
    args = {"generatrix": G, "directrix": D, "count_u": 4, "count_v": 2, **kwargs}
    with pytest.raises(InputError) as info:
        scale_translation(**args)
    assert info.value.input_name == name


def test_scale_factors_override_scale_with_a_warning():
    r = scale_translation(G, D, np.array([0.9, 0.8]), 1.5, None, 4, 2)
    assert np.allclose(r.scales, [1, 0.9, 0.72]) and any("ignored" in w for w in r.warnings)


# ----------------------------------------------------------------------------------------------
# NURBS surface → mesh


def to_rhino_surface(s: NurbsSurface):
    P, w = np.asarray(s.points), np.asarray(s.weights)
    nu, nv = P.shape[:2]
    rs = rhino3dm.NurbsSurface.Create(3, bool(np.any(w != 1)), s.degree_u + 1, s.degree_v + 1, nu, nv)
    for i in range(nu):
        for j in range(nv):
            rs.Points[i, j] = rhino3dm.Point4d(*(P[i, j] * w[i, j]).tolist(), float(w[i, j]))
    for i, k in enumerate(np.asarray(s.knots_u).tolist()):
        rs.KnotsU[i] = k
    for i, k in enumerate(np.asarray(s.knots_v).tolist()):
        rs.KnotsV[i] = k
    assert rs.IsValid
    return rs


def from_rhino_surface(rs) -> NurbsSurface:
    nu, nv = rs.Points.CountU, rs.Points.CountV
    H = np.array([[[rs.Points[i, j].X, rs.Points[i, j].Y, rs.Points[i, j].Z, rs.Points[i, j].W]
                   for j in range(nv)] for i in range(nu)])
    return NurbsSurface(rs.Degree(0), rs.Degree(1), H[..., :3] / H[..., 3:], H[..., 3],
                        np.array(rs.KnotsU.ToList()), np.array(rs.KnotsV.ToList()))


def random_surface(rng, du, dv, nu, nv, rational=True):
    I, J = np.meshgrid(np.arange(nu) * 4.0, np.arange(nv) * 3.0, indexing="ij")
    P = np.stack([I, J, np.zeros_like(I)], axis=-1) + rng.normal(size=(nu, nv, 3)) * 1.5
    w = rng.uniform(0.5, 2.0, (nu, nv)) if rational else np.ones((nu, nv))
    Ku = np.concatenate([np.zeros(du), np.sort(rng.uniform(0, 2, nu - du - 1)), np.full(du, 2.0)])
    Kv = np.concatenate([np.full(dv, -1.0), np.sort(rng.uniform(-1, 4, nv - dv - 1)), np.full(dv, 4.0)])
    return NurbsSurface(du, dv, P, w, Ku, Kv)


@pytest.mark.parametrize("du, dv, nu, nv, rational", [(1, 1, 2, 2, False), (3, 2, 6, 5, True), (2, 3, 4, 7, True),
                                                      (5, 1, 8, 3, True)])
def test_surface_mesh_vertices_lie_on_the_rhino_surface(du, dv, nu, nv, rational):
    rng = np.random.default_rng(du * 10 + dv)
    s = random_surface(rng, du, dv, nu, nv, rational)
    rs = to_rhino_surface(s)
    r = surface_mesh(s, 17, 11)
    V, T = r.mesh
    assert (r.segments_u, r.segments_v) == (17, 11) and V.shape == (18 * 12, 3) and T.shape == (2 * 17 * 11, 3)
    ref = np.array([[q.X, q.Y, q.Z] for q in (rs.PointAt(u, v) for u, v, _ in r.uv.tolist())])
    assert np.abs(V - ref).max() <= 1e-9
    assert np.allclose(r.uv[[0, -1], :2], [[0, -1], [2, 4]])
    validate_mesh(V, T, kind="tri")
    assert len(boundary_loops(T)) == 1
    # scattered parameter pairs
    u, v = rng.uniform(0, 2, 40), rng.uniform(-1, 4, 40)
    ref = np.array([[q.X, q.Y, q.Z] for q in (rs.PointAt(a, b) for a, b in zip(u.tolist(), v.tolist()))])
    assert np.abs(surface_points(s, u, v, grid=False) - ref).max() <= 1e-9


def test_surface_mesh_of_rhino_sphere_is_closed():
    rs = rhino3dm.NurbsSurface.CreateFromSphere(rhino3dm.Sphere(rhino3dm.Point3d(1, 2, 3), 5.0))
    r = surface_mesh(from_rhino_surface(rs), 24, 12)
    V, T = r.mesh
    validate_mesh(V, T, kind="tri")
    assert boundary_loops(T) == []
    assert len(V) - len(T) * 3 // 2 + len(T) == 2  # Euler characteristic of a sphere
    assert np.abs(np.linalg.norm(V - [1, 2, 3], axis=1) - 5.0).max() <= 1e-12
    assert r.warnings  # the seam and the poles were welded
    ref = np.array([[q.X, q.Y, q.Z] for q in (rs.PointAt(u, v) for u, v, _ in r.uv.tolist())])
    assert np.abs(V - ref).max() <= 1e-9


def test_surface_mesh_edge_length_overrides_counts():
    P = np.array([[[0.0, 0, 0], [0, 4, 0]], [[10, 0, 0], [10, 4, 0]]])
    s = NurbsSurface(1, 1, P, np.ones((2, 2)), np.array([0.0, 1]), np.array([0.0, 1]))
    r = surface_mesh(s, 3, 3, edge_length=1.0)
    assert (r.segments_u, r.segments_v) == (10, 4)
    V, T = r.mesh
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    L = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    assert np.isclose(L.min(), 1.0) and np.isclose(L.max(), np.sqrt(2))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"count_u": 0}, "count_u"),
        ({"count_v": 1.5}, "count_v"),
        ({"edge_length": -1.0}, "edge_length"),
        ({"edge_length": np.nan}, "edge_length"),
        ({"edge_length": 1e-6}, "edge_length"),
    ],
)
def test_surface_mesh_errors(kwargs, name):
    rng = np.random.default_rng(0)
    with pytest.raises(InputError) as info:
        surface_mesh(random_surface(rng, 2, 2, 4, 4), **kwargs)
    assert info.value.input_name == name


@pytest.mark.parametrize(
    "mutate, fragment",
    [
        (lambda s: s._replace(points=s.points[:, :, :2]), "shape"),
        (lambda s: s._replace(weights=-s.weights), "positive"),
        (lambda s: s._replace(knots_u=s.knots_u[:-1]), "knots in u"),
        (lambda s: s._replace(knots_v=s.knots_v[::-1]), "decrease"),
        (lambda s: s._replace(points=np.where(s.points > 5, np.nan, s.points)), "NaN"),
        (lambda s: s._replace(degree_u=0), "degree"),
        (lambda s: "not a surface", "NURBS"),
    ],
)
def test_invalid_surfaces_raise(mutate, fragment):
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match=fragment) as info:
        surface_mesh(mutate(random_surface(rng, 2, 2, 4, 4)))
    assert info.value.input_name == "surface"


# ----------------------------------------------------------------------------------------------
# form


def test_grid_quads_wraps():
    assert grid_quads(3, 2).tolist() == [[0, 1, 4, 3], [1, 2, 5, 4]]
    assert grid_quads(3, 2, closed_u=True).tolist() == [[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]]


def test_published_components_register():
    registry = pytest.importorskip("ghserver.registry")
    from components.surfaces import samples

    for fn, uri in ((translation, "surfaces/translation"),
                    (scale_translation, "surfaces/scale_translation"),
                    (paraboloid, "surfaces/paraboloid"), (surface_mesh, "surfaces/mesh"),
                    (samples.sample, "surfaces/sample")):
        comp = registry.declare(fn, uri)
        assert comp.description and all(p.description for p in comp.inputs + comp.outputs)


def test_docstring_examples():
    assert doctest.testmod(surfaces, optionflags=doctest.NORMALIZE_WHITESPACE).failed == 0
