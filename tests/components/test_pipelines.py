"""End-to-end: surface + panel size → candidate quad mesh (issue 6 done-when list) and its planarization."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.checks import validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import face_normals, face_sizes, read_mesh, triangulate
from components.fields.candidate import candidate_mesh, candidate_quality
from components.fields.pipeline import pq_from_conjugate_field
from components.core.proximity import closest_points
from components.surfaces.samples import sample_mesh
from tests.conftest import data_file

def target_for(V, F, quads):
    T, _ = triangulate(F)
    A = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum()
    return float(np.sqrt(A / quads))


def check_candidate(V, F, cand, h, quads=True):
    """The structural part of the done-when list; returns the edge-length share for separate checks."""
    Vc, Fc = cand.V, cand.F
    validate_mesh(Vc, Fc)  # manifold, consistently oriented, no degenerate faces
    T, _ = triangulate(F)
    # oriented with the input: normals agree with the input triangle under the first corner
    NT = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    NT /= np.linalg.norm(NT, axis=1, keepdims=True)
    N = face_normals(Vc, Fc)
    assert np.einsum("ij,ij->i", N, NT[cand.tri[Fc[:, 0]]]).min() > 0, "a candidate face is flipped"
    if quads:
        assert np.mean(face_sizes(Fc) == 4) >= 0.95
    # every vertex within 1% of the target length of the input surface
    d = closest_points(Vc, V, T).distances
    assert d.max() <= 0.01 * h
    # the candidate's boundary lies on the input boundary (no interior vertex exposed by the cleanup)
    from components.fields.extract import boundary_curve, closest_on_boundary
    from components.core.mesh import edge_topology

    topo = edge_topology(Fc)
    onb = np.unique(topo.E[topo.count == 1].ravel())
    X = closest_on_boundary(Vc[onb], boundary_curve(V, T))[0]
    assert np.linalg.norm(X - Vc[onb], axis=1).max() <= 1e-6 * h
    q = candidate_quality(Vc, Fc, h)
    return q


SAMPLES = ["dome", "saddle", "wave", "canopy"]


@pytest.mark.parametrize("name", SAMPLES)
def test_sample_candidates(name):
    V, T, _ = sample_mesh(name, 32)
    h = target_for(V, T, 300)
    cand = candidate_mesh((V, T), h, repair=True)
    q = check_candidate(V, T, cand, h, quads=False)
    assert cand.health.healthy, cand.health.violations
    assert cand.mean_angle_error < 20
    assert q.quad_ratio >= 0.95
    assert q.edge_length_within >= 0.9


REAL = [("inspired_mesh.obj", 1600), ("lilium.obj", 800),
        ("compas_libigl_minimal_surface.obj", 600), ("geometrylab_test_tri_dome.obj", 150)]


@pytest.mark.parametrize("path,quads", REAL)
def test_real_mesh_candidates(path, quads):
    V, F = read_mesh(data_file(path))
    h = target_for(V, F, quads)
    cand = candidate_mesh((V, F), h, repair=True)
    q = check_candidate(V, F, cand, h, quads=False)
    assert cand.health.healthy, cand.health.violations
    assert q.quad_ratio >= 0.95
    assert q.edge_length_within >= 0.9


def test_inspired_mesh_conjugate_beats_libigl_and_smooth():
    V, F = read_mesh(data_file("inspired_mesh.obj"))
    h = target_for(V, F, 1600)
    conj = candidate_mesh((V, F), h, field="conjugate")
    smooth = candidate_mesh((V, F), h, field="smooth")
    qc = candidate_quality(conj.V, conj.F, h)
    qs = candidate_quality(smooth.V, smooth.F, h)
    assert 1400 <= conj.quads <= 1800
    assert qc.mean_planarity < 2.8e-3  # libigl's conjugate remesh: 2.8e-3 mean
    assert qc.mean_planarity < qs.mean_planarity


def test_dome_planarizes_close_to_the_surface():
    V, T, _ = sample_mesh("dome", 32)
    h = target_for(V, T, 300)
    res = pq_from_conjugate_field((V, T), h)
    Vp, Fp = res.planarized
    assert res.planarized_max_planarity <= 1e-4
    E = np.concatenate([np.stack([Fp[:, i], Fp[:, (i + 1) % Fp.shape[1]]], 1) for i in range(Fp.shape[1])])
    E = E[E[:, 0] != E[:, 1]]
    mean_edge = np.linalg.norm(Vp[E[:, 1]] - Vp[E[:, 0]], axis=1).mean()
    assert res.mean_closeness <= 0.02 * mean_edge
    assert res.candidate_max_planarity > res.planarized_max_planarity
    assert res.quad_ratio >= 0.95 and res.time_planarize > 0
    assert res.healthy and res.violations == [] and res.coverage >= 0.85


# issue 16 (open): with the panel-health guards the planarizer holds the healthy wave candidate at max planarity
# ~1.2e-2 (a corner kept at 159.8°; closeness weight 10 makes it shear along the surface); inspired 1600 stalls at
# ~1.5e-2 on boundary quads. The result is healthy and its warning says how far (tests/components/test_fields_health.py).
@pytest.mark.parametrize("name", ["saddle", "wave", "canopy"])
def test_other_samples_planarize(name):
    V, T, _ = sample_mesh(name, 32)
    h = target_for(V, T, 300)
    res = pq_from_conjugate_field((V, T), h, time_budget=10.0)
    assert res.planarized_max_planarity <= 1e-4
    assert res.healthy, res.violations
    Vp, Fp = res.planarized
    E = np.concatenate([np.stack([Fp[:, i], Fp[:, (i + 1) % Fp.shape[1]]], 1) for i in range(Fp.shape[1])])
    E = E[E[:, 0] != E[:, 1]]
    assert res.mean_closeness <= 0.02 * np.linalg.norm(Vp[E[:, 1]] - Vp[E[:, 0]], axis=1).mean()


@pytest.mark.parametrize("path,quads", REAL)
def test_real_meshes_planarize(path, quads):
    V, F = read_mesh(data_file(path))
    h = target_for(V, F, quads)
    # a budget no machine reaches: the quality, not the speed, is tested here (timings: benchmarks/). inspired_mesh
    # at 1600 panels takes ~5 s: its best-ranked candidate stalls at 1.2e-3 in the planarizer's first run and the
    # second candidate converges in its first (benchmarks/convergence.py, sessions 22 and 23)
    res = pq_from_conjugate_field((V, F), h, time_budget=120.0)
    assert res.planarized_max_planarity <= 1e-4
    Vp, Fp = res.planarized
    E = np.concatenate([np.stack([Fp[:, i], Fp[:, (i + 1) % Fp.shape[1]]], 1) for i in range(Fp.shape[1])])
    E = E[E[:, 0] != E[:, 1]]
    assert res.mean_closeness <= 0.02 * np.linalg.norm(Vp[E[:, 1]] - Vp[E[:, 0]], axis=1).mean()


def test_without_planarization_the_candidate_is_returned():
    V, T, _ = sample_mesh("dome", 16)
    h = target_for(V, T, 80)
    res = pq_from_conjugate_field((V, T), h, planarize=False)
    Vc, Fc = res.candidate
    Vp, Fp = res.planarized
    assert np.array_equal(Vc, Vp) and np.array_equal(Fc, Fp)
    assert res.planarized_max_planarity == res.candidate_max_planarity
    assert res.time_field >= 0 and res.time_parametrize > 0 and res.time_extract > 0


def test_auto_boundary_is_at_least_as_good_as_each_mode_it_tries():
    V, T, _ = sample_mesh("canopy", 32)
    h = target_for(V, T, 300)

    def key(c):
        q = candidate_quality(c.V, c.F, h)
        return (q.quad_ratio >= 0.95, q.edge_length_within, q.quad_ratio)

    auto = candidate_mesh((V, T), h)
    for mode in ("snap", "mixed"):
        assert key(auto) >= key(candidate_mesh((V, T), h, boundary=mode))
    assert auto.param.scale > 0


def test_constraints_steer_the_field():
    V, T, _ = sample_mesh("dome", 16)
    h = target_for(V, T, 80)
    faces = np.arange(0, len(T), 7)
    dirs = np.tile([1.0, 1.0, 0.0], (len(faces), 1))
    res = candidate_mesh((V, T), h, constraint_faces=faces, constraint_directions=dirs)
    assert res.quads > 0


# ----------------------------------------------------------------------------------------------
# typed errors


@pytest.fixture
def disk():
    V, T, _ = sample_mesh("dome", 8)
    return V, T


@pytest.mark.parametrize("bad", [0, -2.0, float("nan")])
def test_bad_target(disk, bad):
    with pytest.raises(InputError, match="target_length"):
        pq_from_conjugate_field(disk, bad)


def test_constraints_on_missing_faces(disk):
    V, T = disk
    with pytest.raises(InputError, match="constraint_faces"):
        pq_from_conjugate_field(disk, 3.0, constraint_faces=np.array([len(T) + 5]),
                                constraint_directions=np.array([[1.0, 0, 0]]))
    with pytest.raises(InputError, match="constraint_directions"):
        pq_from_conjugate_field(disk, 3.0, constraint_faces=np.array([0, 1]),
                                constraint_directions=np.array([[1.0, 0, 0]]))
    with pytest.raises(InputError, match="constraint_faces"):
        pq_from_conjugate_field(disk, 3.0, constraint_faces=np.array([0]))


def test_bad_meshes(nonmanifold_fan):
    with pytest.raises(MeshError, match="mesh"):
        pq_from_conjugate_field(nonmanifold_fan, 0.2)
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], dtype=float)
    with pytest.raises(MeshError, match="degenerate"):
        pq_from_conjugate_field((V, np.array([[0, 1, 2], [0, 1, 3]])), 0.2)
    with pytest.raises(MeshError, match="mesh"):
        pq_from_conjugate_field((V, np.array([[0, 1, 7]])), 0.2)


def test_bad_options(disk):
    with pytest.raises(InputError, match="field"):
        pq_from_conjugate_field(disk, 3.0, field="wavy")
    with pytest.raises(InputError, match="tolerance"):
        pq_from_conjugate_field(disk, 3.0, tolerance=-1.0)
    with pytest.raises(InputError, match="closeness_weight"):
        pq_from_conjugate_field(disk, 3.0, closeness_weight=-1.0)


def test_closeness_weight_keeps_the_panels_nearer_the_surface():
    V, T, _ = sample_mesh("wave", 32)
    h = target_for(V, T, 300)
    loose = pq_from_conjugate_field((V, T), h, closeness_weight=1.0)
    tight = pq_from_conjugate_field((V, T), h, closeness_weight=30.0)
    assert max(loose.planarized_max_planarity, tight.planarized_max_planarity) <= 1e-4
    assert tight.mean_closeness < 0.6 * loose.mean_closeness
