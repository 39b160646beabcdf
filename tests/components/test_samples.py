"""Sample free-form surfaces: exact functions, curvature signs, mesh quality, determinism."""
from __future__ import annotations

import doctest

import numpy as np
import pytest

from components.surfaces import samples
from components.core.checks import validate_mesh
from components.core.errors import InputError
from components.core.mesh import boundary_loops, edge_lengths, edge_topology, face_normals
from components.surfaces.samples import SAMPLE_NAMES, sample_mesh, sample_surface_function

STATED = {"dome": "positive", "saddle": "negative", "wave": "mixed", "canopy": "mixed"}


def _angles(V, T):
    P = V[T]
    out = []
    for k in range(3):
        a, b = P[:, (k + 1) % 3] - P[:, k], P[:, (k + 2) % 3] - P[:, k]
        cos = np.sum(a * b, 1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.array(out).T


def _areas(V, T):
    return 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)


def _sign_fractions(K, w):
    return float(w[K > 0].sum() / w.sum()), float(w[K < 0].sum() / w.sum())


def _check_sign(name, positive, negative):
    if STATED[name] == "positive":
        assert positive >= 0.9
    elif STATED[name] == "negative":
        assert negative >= 0.9
    else:  # mixed: both signs over a substantial part
        assert positive >= 0.15 and negative >= 0.15


@pytest.fixture(scope="module", params=SAMPLE_NAMES)
def sample(request):
    name = request.param
    r = samples.sample(name, 32)
    return name, sample_surface_function(name), r


def test_all_four_kinds_are_available():
    assert set(SAMPLE_NAMES) >= {"dome", "saddle", "wave", "canopy"}
    for name in SAMPLE_NAMES:
        assert sample_surface_function(name).curvature == STATED[name]


def test_analytic_gaussian_curvature_sign_over_the_area(sample):
    """Area-weighted sign of the exact K over a fine polar grid of the domain (not the mesh)."""
    name, s, _ = sample
    rho = (np.arange(400) + 0.5) / 400
    th = (np.arange(720) + 0.5) / 720 * 2 * np.pi
    Rr, Th = np.meshgrid(rho, th, indexing="ij")
    Rb = s.boundary_radius(Th)
    x, y = Rr * Rb * np.cos(Th), Rr * Rb * np.sin(Th)
    w = Rr * Rb**2 * s.area_element(x, y)  # polar Jacobian × surface area element
    pos, neg = _sign_fractions(s.gaussian_curvature(x, y), w)
    _check_sign(name, pos, neg)


def test_discrete_gaussian_curvature_sign(sample):
    """Angle defect / barycentric area at interior vertices, area-weighted: the same sign statement."""
    name, _, r = sample
    V, T = r.mesh
    A = _areas(V, T)
    ang = np.radians(_angles(V, T))
    total = np.bincount(T.ravel(), weights=ang.ravel(), minlength=len(V))
    area = np.bincount(T.ravel(), weights=np.repeat(A / 3, 3), minlength=len(V))
    interior = np.ones(len(V), dtype=bool)
    interior[boundary_loops(T)[0]] = False
    K = (2 * np.pi - total[interior]) / area[interior]
    pos, neg = _sign_fractions(K, area[interior])
    _check_sign(name, pos, neg)
    # the discrete estimate follows the exact curvature
    exact = r.gaussian_curvature[interior]
    err = np.abs(K - exact)
    assert np.median(err) <= 0.15 * np.abs(exact).max()


def test_mesh_is_clean_and_well_shaped(sample):
    name, s, r = sample
    V, T = r.mesh
    validate_mesh(V, T, kind="tri")  # no degenerate or repeated-vertex triangles, manifold, oriented
    loops = boundary_loops(T)
    assert len(loops) == 1  # one boundary loop: an open disk
    assert len(V) - len(edge_topology(T).E) + len(T) == 1  # Euler characteristic of a disk
    ang = _angles(V, T)
    assert ang.min() >= 15.0 and ang.max() <= 135.0
    L = edge_lengths(V, edge_topology(T).E)
    assert L.std() / L.mean() <= 0.2 and L.max() / L.min() <= 3.5
    assert np.all(face_normals(V, T)[:, 2] > 0)  # normals up
    # vertices lie exactly on the surface, boundary vertices on the domain boundary
    assert np.abs(V[:, 2] - s.height(V[:, 0], V[:, 1])).max() == 0.0
    B = loops[0]
    rb = np.hypot(V[B, 0], V[B, 1])
    assert np.abs(rb - s.boundary_radius(np.arctan2(V[B, 1], V[B, 0]))).max() <= 1e-9
    # boundary well sampled: boundary edges close to the mean edge length
    LB = np.linalg.norm(V[np.roll(B, -1)] - V[B], axis=1)
    assert np.ptp(LB) <= 0.05 * LB.mean() and 0.7 <= LB.mean() / L.mean() <= 1.3
    # architectural scale: spans of 20-40 units
    span = np.ptp(V[:, :2], axis=0)
    assert 20 <= span.max() <= 40 and span.min() >= 20
    # outputs agree
    nb = len(r.boundary) - 1
    assert np.array_equal(np.sort(B), np.arange(nb)) and np.array_equal(r.boundary[:-1], V[:nb])
    assert np.array_equal(r.boundary[0], r.boundary[-1])
    x, y = r.boundary[:, 0], r.boundary[:, 1]
    assert np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]) > 0  # counter-clockwise from above, as the faces
    assert np.allclose(r.normals, s.normal(V[:, 0], V[:, 1]))


def test_deterministic():
    for name in SAMPLE_NAMES:
        a = sample_mesh(name, 20)
        b = sample_mesh(name, 20)
        assert all(np.array_equal(x, y) for x, y in zip(a, b))


@pytest.mark.parametrize("name", SAMPLE_NAMES)
@pytest.mark.parametrize("resolution", [4, 9, 64])
def test_resolutions_give_valid_meshes(name, resolution):
    V, T, B = sample_mesh(name, resolution)
    validate_mesh(V, T, kind="tri")
    assert len(boundary_loops(T)) == 1 and _angles(V, T).min() >= 10.0


def test_resolution_controls_edge_length():
    coarse = sample_mesh("dome", 16)
    fine = sample_mesh("dome", 64)
    lc = edge_lengths(coarse[0], edge_topology(coarse[1]).E).mean()
    lf = edge_lengths(fine[0], edge_topology(fine[1]).E).mean()
    assert 3.5 <= lc / lf <= 4.5
    assert abs(lf - 30.0 / 64) <= 0.25 * lf  # the dome spans 30 units along x


@pytest.mark.parametrize("name", SAMPLE_NAMES)
def test_exact_derivatives_match_finite_differences(name):
    s = sample_surface_function(name)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-10, 10, 50), rng.uniform(-8, 8, 50)
    f, fx, fy, fxx, fxy, fyy = s.derivatives(x, y)
    h = 1e-5
    assert np.allclose(fx, (s.height(x + h, y) - s.height(x - h, y)) / (2 * h), atol=1e-7)
    assert np.allclose(fy, (s.height(x, y + h) - s.height(x, y - h)) / (2 * h), atol=1e-7)
    g = 1e-4
    d = s.derivatives
    assert np.allclose(fxx, (d(x + g, y)[1] - d(x - g, y)[1]) / (2 * g), atol=1e-7)
    assert np.allclose(fxy, (d(x, y + g)[1] - d(x, y - g)[1]) / (2 * g), atol=1e-7)
    assert np.allclose(fyy, (d(x, y + g)[2] - d(x, y - g)[2]) / (2 * g), atol=1e-7)


@pytest.mark.parametrize("name", SAMPLE_NAMES)
def test_distance_to_exact_surface(name):
    s = sample_surface_function(name)
    V, T, _ = sample_mesh(name, 16)
    N = s.normal(V[:, 0], V[:, 1])
    rng = np.random.default_rng(2)
    off = rng.uniform(-0.3, 0.3, len(V))
    d = s.distance(V + off[:, None] * N)
    assert np.abs(d - np.abs(off)).max() <= 1e-9
    assert s.distance(V).max() <= 1e-12
    C, XY = s.closest_point(V + off[:, None] * N)
    assert np.allclose(C, V, atol=1e-9) and np.allclose(XY, V[:, :2], atol=1e-9)


def test_analytic_sample_values():
    dome = sample_surface_function("dome")
    assert dome.height(0.0, 0.0) == 7.0 and dome.gaussian_curvature(0.0, 0.0) > 0
    saddle = sample_surface_function("saddle")
    assert saddle.gaussian_curvature(3.0, -2.0) < 0
    assert np.isclose(saddle.mean_curvature(0.0, 0.0), 0.0)
    assert dome.contains(0.0, 0.0) and not dome.contains(16.0, 0.0)


@pytest.mark.parametrize("bad", ["sphere", "", "Dome"])
def test_unknown_name_lists_valid_ones(bad):
    with pytest.raises(InputError, match="^name: must be one of 'dome', 'saddle', 'wave', 'canopy', got ") as info:
        samples.sample(bad)
    assert info.value.input_name == "name"


@pytest.mark.parametrize("bad", [3, 0, -5, 513, 2.5, True])
def test_bad_resolution(bad):
    with pytest.raises(InputError) as info:
        samples.sample("dome", bad)
    assert info.value.input_name == "resolution"


def test_docstring_examples():
    assert doctest.testmod(samples, optionflags=doctest.NORMALIZE_WHITESPACE).failed == 0
