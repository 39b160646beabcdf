"""Curvature regions and suggested singularities: sign rule on the dome and saddle, Gauss-Bonnet, typed errors."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import read_mesh, triangulate
from components.surfaces.samples import sample_mesh, sample_surface_function
from components.subdivision.singularities import integrated_gaussian_curvature, singularity_analysis
from tests.conftest import data_file


@pytest.mark.parametrize("name, sign", [("dome", 1), ("saddle", -1)])
def test_sign_rule_on_dome_and_saddle(name, sign):
    V, T, _ = sample_mesh(name, 24)
    res = singularity_analysis((V, T))
    assert len(res.singularity_index) >= 1
    # every suggestion has the sign of the surface's curvature: no wrong-signed singularity
    assert np.all(np.sign(res.singularity_index) == sign)
    assert np.allclose(np.abs(res.singularity_index), 0.25)
    exact = sample_surface_function(name).gaussian_curvature(res.singularities[:, 0], res.singularities[:, 1])
    assert np.all(np.sign(exact) == sign)
    # the suggestions are surface vertices
    d = np.min(np.linalg.norm(res.singularities[:, None, :] - V[None], axis=2), axis=1)
    assert d.max() == 0.0
    assert (res.positive_count, res.negative_count) == ((len(res.singularity_index), 0) if sign > 0
                                                        else (0, len(res.singularity_index)))
    # one region of one sign; corners make the indices consistent with χ = 1
    assert np.all(np.sign(res.region_curvature) == sign)
    assert res.boundary_corners == round(4 * (1 - res.total_index))


def test_curvature_values_and_gauss_bonnet():
    V, T, _b = sample_mesh("dome", 24)
    s = sample_surface_function("dome")
    res = singularity_analysis((V, T))
    K = s.gaussian_curvature(V[:, 0], V[:, 1])
    assert np.corrcoef(res.gaussian, K)[0, 1] > 0.9
    assert np.all(res.mean < 0) or np.all(res.mean > 0)  # a dome bends one way everywhere
    KA, _, _ = integrated_gaussian_curvature(V, T)
    # discrete Gauss-Bonnet: interior curvature + boundary turning = 2π χ
    assert res.boundary_turning + KA.sum() == pytest.approx(2 * np.pi, abs=1e-9)
    assert len(res.positive_region) + len(res.negative_region) <= len(V)


def test_mixed_surface_has_both_signs_and_correct_local_sign():
    V, T, _ = sample_mesh("canopy", 24)
    res = singularity_analysis((V, T))
    s = sample_surface_function("canopy")
    K = s.gaussian_curvature(res.singularities[:, 0], res.singularities[:, 1])
    assert np.all(np.sign(K) == np.sign(res.singularity_index))
    assert (res.region_curvature > 0).any() and (res.region_curvature < 0).any()


def test_flat_grid_suggests_nothing(planar_grid):
    V, Q = planar_grid
    res = singularity_analysis((V, triangulate(Q)[0]))
    assert len(res.singularities) == 0
    assert res.boundary_corners == 4


def test_threshold_controls_suggestions():
    V, T, _ = sample_mesh("saddle", 16)
    assert len(singularity_analysis((V, T), threshold=10.0).singularities) == 0
    assert len(singularity_analysis((V, T), threshold=0.0).singularities) >= 1


def test_inspired_mesh_runs():
    V, F = read_mesh(data_file("inspired_mesh.obj"))
    res = singularity_analysis((V, F))
    assert len(res.gaussian) == len(V)
    assert res.positive_count + res.negative_count == len(res.singularities)


def test_bad_input(nonmanifold_fan):
    with pytest.raises(MeshError, match="surface"):
        singularity_analysis(nonmanifold_fan)
    V, T, _ = sample_mesh("dome", 8)
    with pytest.raises(InputError, match="threshold"):
        singularity_analysis((V, T), threshold=-1)
    with pytest.raises(InputError, match="flat_tolerance"):
        singularity_analysis((V, T), flat_tolerance=2.0)
    with pytest.raises(InputError, match="radius"):
        singularity_analysis((V, T), radius=0)
    with pytest.raises(InputError, match="surface"):
        singularity_analysis(V)
    Tf = T.copy()
    Tf[0] = Tf[0, ::-1]
    with pytest.raises(MeshError, match="surface"):
        singularity_analysis((V, Tf))
