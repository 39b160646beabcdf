"""Conical optimization: planarity-aware conical verdict on published meshes, optimization of a perturbed
curvature net to a conical mesh with an exact face offset, the published component and its typed errors."""
from __future__ import annotations

import numpy as np
import pytest

from components.conical.cones import conical_check, face_offset
from components.conical.optimize import conical_mesh, optimize
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, quad_grid, read_mesh
from components.core.measures import quad_planarity as face_planarity
from tests.components.test_conical import revolution_net, translation_net
from tests.conftest import data_file


def test_published_conical_mesh_passes_as_is():
    V, F = read_mesh(data_file("obj_pq__conical1.obj"))
    chk = conical_check(V, F, 1e-4)  # the cone fit judges; the angle criterion alone is perturbed by planarity 4e-5
    assert chk.passed.all() and chk.checked.sum() > 900
    assert chk.max_criterion > 1e-4  # reported beside the verdict
    assert conical_check(V, F, 0.0).passed.all()  # even with no slack but the planarity's


def test_non_conical_pq_meshes_fail():
    V, F = read_mesh(data_file("obj_pq__planarizednormalized_six_quad.obj"))
    assert face_planarity(V, F).max() < 1e-4
    assert not conical_check(V, F, 1e-4).passed.all()
    Vt, Ft = translation_net(8)  # exactly planar quads, not conical
    assert face_planarity(Vt, Ft).max() < 1e-12
    assert not conical_check(Vt, Ft, 1e-4).passed.all()


def test_planar_hypar_net_fails():
    # the hyperbolic paraboloid z = (u² − v²)/2 meshed along its parabolas (a translation net): every quad exactly
    # planar and healthy, yet not conical away from the vertex (the old version of this test planarized the
    # asymptotic grid, which the solver could only do by collapsing panels)
    V, Q = quad_grid(10, 10, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = (V[:, 0] ** 2 - V[:, 1] ** 2) / 2.0
    assert face_planarity(V, Q).max() < 1e-12
    chk = conical_check(V, Q, 1e-4)
    assert not chk.passed.all() and chk.deviation[chk.checked].max() > 0.01


def test_revolution_net_is_conical():
    V, F = revolution_net()
    chk = conical_check(V, F, 1e-6)
    assert chk.passed.all() and chk.checked.any()


def _noisy_revolution():
    V, F = revolution_net(12, 16)
    rng = np.random.default_rng(1)
    return V, F, V + 0.004 * rng.standard_normal(V.shape)


def test_conical_mesh_and_exact_face_offset():
    V, F, Vn = _noisy_revolution()
    res = conical_mesh(Vn, F, (V, F))
    assert res.converged
    assert res.max_planarity <= 1e-4 and res.max_criterion < 1e-4
    assert res.max_planarity < 1e-9  # polished
    assert res.mean_closeness <= 0.02 * res.mean_edge_length
    d = 0.3 * res.mean_edge_length
    off = face_offset(res.V, F, d)
    assert off.face_error.max() <= 1e-6 * d
    # consecutive node axes are coplanar (interior edges; boundary ones by the parallel-boundary fit)
    assert off.axis_coplanarity.max() < 1e-6
    # without the polish the offset error is planarity-limited
    res2 = conical_mesh(Vn, F, (V, F), polish=False)
    assert res2.max_planarity <= 1e-4 and res2.max_criterion < 1e-4


def test_published_component():
    res = optimize(quad_grid(3, 3))
    assert res.is_conical and res.max_planarity < 1e-12
    V, F, Vn = _noisy_revolution()
    res = optimize((Vn, F), reference=(V, F))
    assert res.is_conical and res.relative_closeness < 0.02
    assert res.criterion.shape == (len(V),)


def test_bad_inputs():
    V, F = quad_grid(3, 3)
    with pytest.raises(InputError, match="tolerance"):
        optimize((V, F), tolerance=0.0)
    with pytest.raises(MeshError, match="reference"):
        optimize((V, F), reference="surface")
    with pytest.raises(MeshError, match="mesh"):
        optimize(V)
    with pytest.raises(InputError, match="boundary"):
        optimize((V, F), boundary="round")
    with pytest.raises(InputError, match="closeness_weight"):
        optimize((V, F), closeness_weight=-1)


def test_converged_means_healthy():
    V, F, Vn = _noisy_revolution()
    res = conical_mesh(Vn, F, (V, F))
    assert res.converged and res.healthy and res.violations == [] and res.coverage >= 0.85
    # a pinched boundary edge that may not move is optimized around but not claimed conical: the violation says why
    loop = boundary_loops(F)[0]
    a, b = loop[3], loop[4]
    Vp = Vn.copy()
    Vp[b] = Vp[a] + 0.05 * (Vp[b] - Vp[a])  # edge a-b shrunk to 5 %
    bad = conical_mesh(Vp, F, (V, F), boundary="fixed")
    assert bad.max_planarity <= 1e-4 and bad.max_criterion < 1e-4
    assert not bad.healthy and not bad.converged
    assert any("shorter than" in line for line in bad.violations)
    assert any(w.startswith("panels not healthy") for w in bad.warnings)
    pub = optimize((Vp, F), reference=(V, F), boundary="fixed")
    assert not pub.is_conical and not pub.healthy and pub.violations
    assert optimize(quad_grid(3, 3)).coverage == -1.0
