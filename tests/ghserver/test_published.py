"""Every published component, called over HTTP with the Python client on a real server, gives real results.

A component added to ``ghserver/endpoints.py`` must get a case here (the last test checks it).
"""
from __future__ import annotations

import numpy as np
import pytest

from components.core.mesh import quad_grid
from components.core.types import NurbsCurve, NurbsSurface
from ghserver.client import Client
from ghserver.endpoints import build_registry


def hypar():
    V, Q = quad_grid(8, 8, 2.0, 2.0)
    V[:, :2] -= 1
    V[:, 2] = 0.5 * V[:, 0] * V[:, 1]
    return V, Q


def _paraboloid(n):
    V, Q = quad_grid(n, n, 2.0, 2.0)
    V[:, :2] -= 1
    V[:, 2] = -0.25 * (V[:, 0] ** 2 + V[:, 1] ** 2)
    return V, Q


def dome_grid_tri():
    from components.core.mesh import triangulate

    V, Q = _paraboloid(24)
    return V, triangulate(Q)[0]


def bumpy_dome():
    """An 8×8 grid on an elliptic paraboloid (a translation surface, so PQ exists) with interior noise."""
    V, Q = _paraboloid(8)
    rng = np.random.default_rng(0)
    inner = (np.abs(V[:, 0]) < 0.99) & (np.abs(V[:, 1]) < 0.99)
    V[inner, 2] += 0.01 * rng.standard_normal(inner.sum())
    return V, Q


def dome_tri(n=12):
    from components.surfaces.samples import sample_mesh

    V, T, _ = sample_mesh("dome", n)
    return V, T


def _arc():
    w = np.array([1.0, np.sqrt(0.5), 1.0])
    return NurbsCurve(2, np.array([[0.0, 0, 0], [0, 5, 3], [0, 10, 0]]), w, np.array([0, 0, 1, 1.0]))


def _surface():
    P = np.zeros((4, 4, 3))
    P[..., 0], P[..., 1] = np.meshgrid(np.linspace(0, 9, 4), np.linspace(0, 6, 4), indexing="ij")
    P[1:3, 1:3, 2] = 2.0
    return NurbsSurface(3, 3, P, np.ones((4, 4)), np.array([0, 0, 0, 1, 1, 1.0]), np.array([0, 0, 0, 1, 1, 1.0]))


def saddle_tri():
    from components.surfaces.samples import sample_mesh

    V, T, _ = sample_mesh("saddle", 16)
    return V, T


def _revolution_net():
    """Meridians × parallels of a paraboloid of revolution (a conical net), slightly perturbed."""
    n_t, n_r = 16, 5
    th = np.linspace(0, 2 * np.pi, n_t, endpoint=False)
    r = np.linspace(1.0, 3.0, n_r + 1)
    R, TH = np.meshgrid(r, th, indexing="ij")
    V = np.stack([R * np.cos(TH), R * np.sin(TH), 0.2 * R ** 2], axis=-1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(n_r + 1, n_t)
    F = [[idx[i, j], idx[i + 1, j], idx[i + 1, (j + 1) % n_t], idx[i, (j + 1) % n_t]]
         for i in range(n_r) for j in range(n_t)]
    V = V + 0.003 * np.random.default_rng(1).standard_normal(V.shape)
    return V, np.array(F)


def check_planarity(r):
    assert r.planarity.shape == (64,) and r.max_planarity > 0.01 and np.isclose(r.max_planarity, r.planarity.max())


CASES = {
    "fabrication/panels": (lambda: dict(mesh=quad_grid(4, 3, 4.0, 3.0), gap=0.1),
                           lambda r: r.labels[:2] == ["A01", "A02"] and np.allclose(r.areas, 1.0)
                           and r.max_length_error < 1e-12 and len(r.outlines) == 12),
    "fabrication/panel_types": (lambda: dict(mesh=hypar(), tolerance=1e-6),
                                lambda r: r.type_count == len(r.counts) and r.counts.sum() == 64
                                and np.all(np.diff(r.type_counts) <= 0)),
    "fabrication/kinks": (lambda: dict(mesh=hypar()), lambda r: len(r.kinks) == 112 and r.max_kink > 1.0),
    "fabrication/nodes": (lambda: dict(mesh=quad_grid(4, 4)),
                          lambda r: r.axis_method == "offset" and r.max_torsion < 1e-9 and len(r.beams) == 40),
    "metrics/planarity": (lambda: dict(mesh=hypar()), check_planarity),
    "metrics/warping": (lambda: dict(mesh=hypar()), lambda r: np.isclose(r.max_warping, r.warping.max())),
    "metrics/diagonal_ratio": (lambda: dict(mesh=hypar()), lambda r: np.all(r.diagonal_ratio >= 1.0)),
    "metrics/face_areas": (lambda: dict(mesh=quad_grid(3, 2, 3.0, 2.0)), lambda r: np.isclose(r.total_area, 6.0)),
    "metrics/edge_lengths": (lambda: dict(mesh=quad_grid(2, 2)), lambda r: np.allclose(r.lengths, 0.5)),
    "metrics/corner_angles": (lambda: dict(mesh=quad_grid(2, 2)), lambda r: np.allclose(r.min_angle, np.pi / 2)),
    "metrics/verdict_quality": (lambda: dict(mesh=quad_grid(2, 2)), lambda r: np.allclose(r.values, 1.0)),
    "metrics/conical_criterion": (lambda: dict(mesh=quad_grid(4, 4)), lambda r: r.max_criterion < 1e-12),
    "metrics/valence": (lambda: dict(mesh=quad_grid(4, 4)), lambda r: r.count_singularities == 0),
    "metrics/closeness": (lambda: dict(mesh=quad_grid(2, 2), reference=quad_grid(2, 2)),
                          lambda r: r.max_distance < 1e-12),
    "metrics/analysis": (lambda: dict(mesh=hypar(), measure="planarity"),
                         lambda r: len(r.display[0]) == 4 * 64 and r.legend_max >= r.values.max() - 1e-12),
    "metrics/report": (lambda: dict(mesh=hypar()),
                       lambda r: len(r.names) == len(r.values) and r.values[r.names.index("planarity_max")] > 0.01),
    "metrics/panel_health": (lambda: dict(mesh=quad_grid(4, 4), reference=quad_grid(4, 4)),
                             lambda r: r.healthy and r.coverage > 0.99 and len(r.unhealthy_faces) == 0),
    "surfaces/translation": (lambda: dict(generatrix=np.array([[0, 0, 0], [4, 0, 1], [8, 0, 0.5], [12, 0, 0.0]]),
                                          directrix=_arc(), count_u=6, count_v=5),
                             lambda r: r.face_count == 30 and r.max_planarity < 1e-12),
    "surfaces/scale_translation": (lambda: dict(generatrix=np.array([[0, 0, 0], [4, 0, 1], [8, 0, 0.0]]),
                                                directrix=_arc(), scale=0.95, count_u=4, count_v=5),
                                   lambda r: r.max_planarity < 1e-12),
    "surfaces/paraboloid": (lambda: dict(kind="hyperbolic"), lambda r: r.max_planarity < 1e-12),
    "surfaces/surface_mesh": (lambda: dict(surface=_surface(), count_u=6, count_v=5),
                              lambda r: len(r.mesh[0]) == 7 * 6),
    "surfaces/sample": (lambda: dict(name="saddle", resolution=10), lambda r: np.mean(r.gaussian_curvature < 0) > 0.9),
    "fields/remesh": (lambda: dict(mesh=dome_tri(), target_length=3.0),
                      lambda r: 2.0 < r.mean_edge < 4.0 and r.max_deviation < 0.03),
    "fields/smooth_field": (lambda: dict(mesh=dome_tri(16)), lambda r: r.u.shape == r.w.shape and r.u.shape[1] == 3),
    "fields/conjugate_field": (lambda: dict(mesh=dome_tri(16)),
                               lambda r: r.mean_conjugacy_error < r.smooth_mean_conjugacy_error),
    "fields/streamlines": (lambda: dict(mesh=dome_tri(16), separation=3.0), lambda r: r.curve_count > 3),
    "fields/parametrize": (lambda: dict(mesh=dome_tri(16), target_length=3.0),
                           lambda r: r.flipped_triangles == 0 and r.mean_angle_error < 10 and len(r.iso_lines) > 4),
    "fields/extract_quads": (lambda: dict(mesh=dome_tri(16), target_length=3.0),
                             lambda r: r.quad_ratio > 0.9 and r.quads > 20),
    "fields/pq_from_conjugate_field": (lambda: dict(mesh=dome_tri(16), target_length=3.0),
                                       lambda r: r.planarized_max_planarity <= 1e-4 and r.quad_ratio > 0.9),
    "fields/principal_curvature": (lambda: dict(mesh=dome_tri()), lambda r: np.median(r.gaussian) > 0),
    "network/curvature_network": (lambda: dict(mesh=saddle_tri(), panel_size=3.0),
                                  lambda r: r.count_1 > 3 and r.count_2 > 3 and len(r.lines_1) == r.count_1),
    "network/quad_rebuild": (lambda: dict(mesh=saddle_tri(), panel_size=3.0), lambda r: r.quad_fraction > 0.9),
    "conical/optimize": (lambda: dict(mesh=_revolution_net()), lambda r: r.max_planarity <= 1e-4 and r.is_conical),
    "network/pq_from_curvature_network": (lambda: dict(mesh=saddle_tri(), panel_size=3.0, offset=0.2),
                                          lambda r: r.max_planarity <= 1e-4 and r.max_criterion < 1e-4
                                          and r.healthy and r.coverage > 0.85
                                          and (r.is_conical or any(w.startswith("not conical at")
                                                                   for w in r.warnings))),
    "parametrize/conformal_map": (lambda: dict(mesh=dome_tri()), lambda r: r.flipped == 0 and r.mean_ratio < 1.2),
    "conical/analysis": (lambda: dict(mesh=quad_grid(4, 4)), lambda r: r.is_conical and r.max_criterion < 1e-12),
    "conical/offset": (lambda: dict(mesh=quad_grid(4, 4), distance=0.5),
                       lambda r: np.allclose(r.offset[0][:, 2], 0.5) and r.max_face_error < 1e-12),
    "planarize/planarize": (lambda: dict(mesh=hypar()), lambda r: r.max_planarity <= 1e-4 and r.converged),
    "planarize/on_surface": (lambda: dict(mesh=bumpy_dome(), surface=dome_grid_tri()),
                             lambda r: r.max_planarity <= 1e-4),
    "subdivision/singularity_analysis": (lambda: dict(surface=dome_tri(16)),
                                         lambda r: r.positive_count >= 1 and r.negative_count == 0),
    "subdivision/coarse_mesh": (lambda: dict(surface=dome_tri(16), faces=24), lambda r: r.face_count >= 12),
    "subdivision/pq_from_subdivision": (lambda: dict(surface=dome_tri(16), faces=24, levels=1),
                                        lambda r: r.max_planarity < r.candidate_max_planarity and r.nonconvex_faces == 0),
    "subdivision/catmull_clark": (lambda: dict(mesh=quad_grid(3, 3), levels=2), lambda r: r.face_count == 9 * 16),
    "subdivision/pull_to_surface": (lambda: dict(mesh=quad_grid(3, 3, 1.0, 1.0, lambda x, y: 0.1 + 0 * x),
                                                 surface=quad_grid(3, 3)),
                                    lambda r: r.max_after < 1e-12 and np.isclose(r.max_before, 0.1)),
}


@pytest.fixture(scope="module")
def client():
    from ghserver.app import Config, create_app
    from tests.ghserver.conftest import LiveServer

    with LiveServer(create_app(Config(cache_size=0))) as srv:
        yield Client(srv.url)


@pytest.mark.parametrize("uri", sorted(CASES))
def test_published_component_over_http(client, uri):
    make_inputs, check = CASES[uri]
    result = client.call(uri, **make_inputs())
    outcome = check(result)
    assert outcome is None or bool(outcome), f"{uri}: property check failed"


def test_every_published_component_has_a_case():
    missing = sorted(c.uri for c in build_registry() if c.uri not in CASES)
    assert not missing, f"add HTTP cases for {missing}"
