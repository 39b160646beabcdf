"""Conformal parametrization: LSCM, fixed-boundary disk/square maps, distortion, the published component."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, quad_grid, read_mesh, triangulate
from components.core.conformal import (
    conformal_distortion,
    conformal_map,
    cotan_laplacian,
    disk_map,
    lscm,
)
from tests.conftest import data_file

igl = pytest.importorskip("igl")


def _similarity_residual(A, B):
    """Max distance between B and the best similarity image (rotation/reflection-free) of A, relative to B's size."""
    a = A - A.mean(axis=0)
    b = B - B.mean(axis=0)
    za = a[:, 0] + 1j * a[:, 1]
    zb = b[:, 0] + 1j * b[:, 1]
    s = np.vdot(za, zb) / np.vdot(za, za)  # complex scale-rotation
    return float(np.abs(s * za - zb).max() / np.abs(zb).max())


def _rotation(seed=0):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _hemisphere(n_rings=10, n_seg=32, top=0.98 * np.pi / 2):
    """Triangulated spherical cap (a disk) with a pole vertex."""
    phi = np.linspace(0, top, n_rings + 1)[1:]
    th = np.linspace(0, 2 * np.pi, n_seg, endpoint=False)
    P, Th = np.meshgrid(phi, th, indexing="ij")
    V = np.r_[[[0, 0, 1.0]], np.stack([np.sin(P) * np.cos(Th), np.sin(P) * np.sin(Th), np.cos(P)], -1).reshape(-1, 3)]
    idx = 1 + np.arange(n_rings * n_seg).reshape(n_rings, n_seg)
    T = [[0, idx[0, j], idx[0, (j + 1) % n_seg]] for j in range(n_seg)]
    for i in range(n_rings - 1):
        for j in range(n_seg):
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, (j + 1) % n_seg], idx[i, (j + 1) % n_seg]
            T += [[a, b, c], [a, c, d]]
    return V, np.asarray(T, dtype=np.int64)


def _planar_patch(seed=1):
    V, Q = quad_grid(8, 6, 2.0, 1.5)
    rng = np.random.default_rng(seed)
    inner = (V[:, 0] > 0) & (V[:, 0] < 2) & (V[:, 1] > 0) & (V[:, 1] < 1.5)
    V[inner, :2] += rng.uniform(-0.06, 0.06, size=(inner.sum(), 2))
    T, _ = triangulate(Q)
    return V, T


def _octahedron():
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    T = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return V, T


# ---------------------------------------------------------------------------------------------- LSCM


@pytest.mark.parametrize("method", ["pinned", "spectral"])
def test_lscm_reproduces_a_planar_patch_up_to_similarity(method):
    V, T = _planar_patch()
    R = _rotation(3)
    W = V @ R.T + np.array([5.0, -2.0, 1.0])  # the plane in general position
    UV = lscm(W, T, method=method)
    assert _similarity_residual(V[:, :2], UV) <= 1e-10
    d = conformal_distortion(W, T, UV)
    assert np.abs(d.ratio - 1).max() <= 1e-9
    assert not d.flipped.any()


def test_lscm_pinned_default_keeps_the_model_scale_on_a_plane():
    V, T = _planar_patch()
    UV = lscm(V, T)
    # default pins at their 3D distance: the planar patch comes back congruent (rotation + translation)
    D3 = np.linalg.norm(V[:, None, :2] - V[None, :, :2], axis=2)
    D2 = np.linalg.norm(UV[:, None] - UV[None], axis=2)
    assert np.abs(D3 - D2).max() <= 1e-10


def test_lscm_is_rigid_motion_invariant():
    V, T = _hemisphere()
    V = V * [1.3, 0.8, 1.0]  # an elliptic cap: the default pinned pair (farthest boundary vertices) is unique
    UV1 = lscm(V, T)
    UV2 = lscm(V @ _rotation(7).T + np.array([10.0, 3.0, -4.0]), T)
    assert _similarity_residual(UV1, UV2) <= 1e-9
    # the spectral map too (its normalization is intrinsic up to similarity)
    S1 = lscm(V, T, method="spectral")
    S2 = lscm(V @ _rotation(8).T - 2.0, T, method="spectral")
    assert _similarity_residual(S1, S2) <= 1e-6


def test_lscm_matches_igl_on_a_hemisphere():
    V, T = _hemisphere()
    UV = lscm(V, T)
    b = boundary_loops(T)[0]
    mine = conformal_distortion(V, T, UV)
    pins = np.array([b[0], b[len(b) // 2]])
    ref_uv, _ = igl.lscm(V, T, pins, np.array([[0.0, 0.0], [1.0, 0.0]]))
    ref = conformal_distortion(V, T, ref_uv)
    assert not mine.flipped.any()
    # a hemisphere is far from developable: LSCM distorts, ours must distort like libigl's
    assert mine.ratio.mean() <= 1.02 * ref.ratio.mean()
    assert 1.01 < mine.ratio.mean() < 2.0
    # with the same pins the minimizer is the same
    same = lscm(V, T, pinned=pins, pinned_uv=[[0.0, 0.0], [1.0, 0.0]])
    assert np.abs(same - ref_uv).max() <= 1e-8


def test_lscm_matches_igl_on_inspired_mesh():
    V, F = read_mesh(data_file("inspired_mesh.obj"))
    T, _ = triangulate(F)
    UV = lscm(V, T)
    d = conformal_distortion(V, T, UV)
    assert not d.flipped.any()
    b = boundary_loops(T)[0]
    pins = np.array([b[0], b[len(b) // 2]])
    ref_uv, _ = igl.lscm(V, T, pins, np.array([[0.0, 0.0], [1.0, 0.0]]))
    ref = conformal_distortion(V, T, ref_uv)
    assert d.ratio.mean() <= 1.01 * ref.ratio.mean()
    assert d.ratio.mean() < 1.01  # a gently curved roof flattens almost conformally


def test_lscm_handles_several_boundary_loops():
    V, F = read_mesh(data_file("geometrylab_test_tri_mesh.obj"))  # annulus
    T, _ = triangulate(F)
    UV = lscm(V, T)
    d = conformal_distortion(V, T, UV)
    assert np.isfinite(UV).all() and not d.flipped.any()


def test_lscm_bad_inputs():
    V, T = _octahedron()
    with pytest.raises(MeshError, match="mesh: .*closed"):
        lscm(V, T)
    V, T = _planar_patch()
    with pytest.raises(InputError, match="pinned"):
        lscm(V, T, pinned=[0, 0])
    with pytest.raises(InputError, match="pinned"):
        lscm(V, T, pinned=[0, 10_000])
    with pytest.raises(InputError, match="pinned_uv"):
        lscm(V, T, pinned=[0, 1], pinned_uv=[[0, 0]])
    with pytest.raises(InputError, match="^method: must be one of 'pinned', 'spectral', got 'magic'$"):
        lscm(V, T, method="magic")
    with pytest.raises(MeshError, match="^mesh: triangles must have shape \\(t, 3\\)"):
        lscm(V, np.c_[T, T[:, :1]])
    with pytest.raises(MeshError, match="^mesh: vertex 0 has a NaN"):
        lscm(np.r_[[[np.nan] * 3], V[1:]], T)
    two = np.r_[V, V + [10.0, 0, 0]]
    with pytest.raises(MeshError, match="2 connected pieces; map each one"):
        lscm(two, np.r_[T, T + len(V)])


# ---------------------------------------------------------------------------------------------- disk / square


def test_square_map_reproduces_a_square_grid():
    V, Q = quad_grid(5, 5)
    T, _ = triangulate(Q)
    UV, info = disk_map(V, T, shape="square")
    assert np.abs(UV - V[:, :2]).max() <= 1e-12
    assert info["weights"] == "cotan" and sorted(info["corners"].tolist()) == [0, 5, 30, 35]


def test_disk_map_boundary_on_the_unit_circle_and_no_flips():
    V, T = _hemisphere()
    UV, info = disk_map(V, T, shape="disk")
    b = boundary_loops(T)[0]
    assert np.abs(np.linalg.norm(UV[b], axis=1) - 1).max() <= 1e-12
    assert (np.linalg.norm(UV, axis=1) <= 1 + 1e-12).all()
    d = conformal_distortion(V, T, UV)
    assert not d.flipped.any()
    # the cap is rotationally symmetric, so the conformal map to the disk has an arc-length boundary: the
    # harmonic map is then the discrete conformal map, exactly as good as free-boundary LSCM
    free = conformal_distortion(V, T, lscm(V, T))
    assert d.ratio.mean() <= 1.001 * free.ratio.mean()


@pytest.mark.parametrize("shape", ["disk", "square"])
def test_disk_map_on_inspired_mesh(shape):
    V, F = read_mesh(data_file("inspired_mesh.obj"))
    T, _ = triangulate(F)
    UV, info = disk_map(V, T, shape=shape)
    d = conformal_distortion(V, T, UV)
    assert not d.flipped.any() and np.isfinite(d.ratio).all()
    # a fixed boundary shape costs conformality compared with LSCM's free boundary
    free = conformal_distortion(V, T, lscm(V, T))
    assert d.ratio.mean() > free.ratio.mean()


def test_disk_map_mean_value_fallback_on_obtuse_triangles():
    # a fan of very obtuse triangles makes cotangent weights negative
    V, T = _planar_patch()
    V = V.copy()
    V[:, 1] *= 0.05  # squash: many obtuse triangles
    UV, info = disk_map(V, T, shape="disk", weights="mean_value")
    assert not conformal_distortion(V, T, UV).flipped.any()
    UV2, info2 = disk_map(V, T, shape="disk")
    assert not conformal_distortion(V, T, UV2).flipped.any()
    if info2["weights"] == "mean_value":
        assert "mean-value" in info2["warnings"][0]


def test_disk_map_bad_inputs():
    V, T = _octahedron()
    with pytest.raises(MeshError, match="mesh: .*closed"):
        disk_map(V, T)
    V, F = read_mesh(data_file("geometrylab_test_tri_mesh.obj"))
    with pytest.raises(MeshError, match="2 boundary loops.*LSCM"):
        disk_map(V, triangulate(F)[0])
    V, T = _planar_patch()
    with pytest.raises(InputError, match="^shape: must be one of 'disk', 'square', got 'triangle'$"):
        disk_map(V, T, shape="triangle")
    with pytest.raises(InputError, match="^weights: must be one of 'auto', 'cotan', 'mean_value', got 'uniformish'$"):
        disk_map(V, T, weights="uniformish")


# ---------------------------------------------------------------------------------------------- distortion


def test_distortion_measures():
    V, T = _planar_patch()
    A = np.array([[2.0, 0.0], [0.0, 1.0]])
    d = conformal_distortion(V, T, V[:, :2] @ A.T)
    assert np.allclose(d.ratio, 2.0)
    mirrored = conformal_distortion(V, T, V[:, :2] * [1, -1])
    assert np.allclose(mirrored.ratio, 1.0) and not mirrored.flipped.any()  # a global mirror is not a flip
    UV = V[:, :2].copy()
    v = T[10, 0]
    UV[v] += 0.4 * (UV[T[10, 1]] - UV[v]) + 0.4 * (UV[T[10, 2]] - UV[v]) * 2.0  # push a vertex through
    assert conformal_distortion(V, T, UV).flipped.sum() >= 1


def test_cotan_laplacian_is_igl_cotmatrix():
    V, T = _hemisphere(4, 12)
    L = cotan_laplacian(V, T)
    assert abs(L + igl.cotmatrix(V, T)).max() <= 1e-12


# ---------------------------------------------------------------------------------------------- component


def test_conformal_map_component_on_quads(sphere_cap):
    # the sphere cap fixture is an annulus of quads: LSCM works and warns
    res = conformal_map(sphere_cap)
    V, F = sphere_cap
    assert res._fields == ("uv_mesh", "uv", "mean_ratio", "max_ratio", "mean_angle_distortion", "flipped", "warnings")
    P, F2 = res.uv_mesh
    assert np.array_equal(F2, F) and np.all(P[:, 2] == 0) and res.uv.shape == (len(V), 3)
    assert res.flipped == 0 and res.mean_ratio >= 1.0
    assert any("not a disk" in w for w in res.warnings)
    with pytest.raises(MeshError, match="mesh: .*2 boundary loops"):
        conformal_map(sphere_cap, method="disk")


@pytest.mark.parametrize("method", ["lscm", "spectral", "disk", "square"])
def test_conformal_map_component_methods(hypar_grid, method):
    res = conformal_map(hypar_grid, method=method)
    assert res.flipped == 0 and not res.warnings
    assert 1.0 <= res.mean_ratio <= res.max_ratio
    # a square patch onto the disk squeezes its corners: only the free boundaries and the square stay mild
    assert res.max_ratio < (20.0 if method == "disk" else 2.0)


def test_conformal_map_component_errors():
    with pytest.raises(MeshError, match="mesh: .*closed"):
        conformal_map(_octahedron())
    with pytest.raises(InputError, match="^method: must be one of 'lscm', 'spectral', 'disk', 'square', got 'bff'$"):
        conformal_map(quad_grid(2, 2), method="bff")
    with pytest.raises(MeshError, match="mesh"):
        conformal_map((np.zeros((3, 3)), np.array([[0, 1, 5]])))
    with pytest.raises(MeshError, match="^mesh: must be a \\(V, F\\) pair"):
        conformal_map(np.zeros((3, 3)))


def test_an_unwelded_mesh_is_told_to_weld_at_every_scale():
    # every triangle with its own corners (an STL, a mesh joined without welding): not "map each piece"
    V, Q = quad_grid(4, 4, 4.0, 4.0, height=lambda x, y: 0.1 * x * y)
    T = triangulate(Q)[0]
    soup, tris = V[T].reshape(-1, 3), np.arange(3 * len(T)).reshape(-1, 3)
    for scale, shift in ((1.0, 0.0), (1000.0, 0.0), (1.0, 5e6)):
        with pytest.raises(MeshError, match=r"^mesh: the mesh has 32 connected pieces that share \d+ vertex "
                                            r"positions: it is not welded; weld it"):
            lscm(soup * scale + shift, tris)
