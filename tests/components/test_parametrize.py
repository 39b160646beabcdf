"""Seamless parametrization: analytic fields on planes and surfaces of revolution, seams, typed errors."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.errors import InputError, MeshError
from components.core.mesh import quad_grid, triangulate
from components.fields.parametrize import (
    _A,
    direction_field,
    field_angle_error,
    parametrize,
    seamless_parametrization,
)
from components.surfaces.samples import sample_mesh


def plane(n=12, size=6.0, jitter=0.0, seed=0):
    V, Q = quad_grid(n, n, size, size)
    if jitter:
        rng = np.random.default_rng(seed)
        inner = (V[:, 0] > 1e-9) & (V[:, 0] < size - 1e-9) & (V[:, 1] > 1e-9) & (V[:, 1] < size - 1e-9)
        V[inner, :2] += rng.uniform(-jitter, jitter, (inner.sum(), 2)) * size / n
    T, _ = triangulate(Q)
    return V, T


def annulus(r0=4.0, r1=7.0, nr=8, nt=48, height=lambda r: 0.04 * r * r):
    """Triangulated annulus on a surface of revolution z = height(r), with its meridian/parallel field."""
    r = np.linspace(r0, r1, nr + 1)
    t = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    R, TH = np.meshgrid(r, t, indexing="ij")
    V = np.stack([R * np.cos(TH), R * np.sin(TH), height(R)], axis=-1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(nr + 1, nt)
    T = []
    for i in range(nr):
        for j in range(nt):
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, (j + 1) % nt], idx[i, (j + 1) % nt]
            T += [[a, b, c], [a, c, d]]
    T = np.asarray(T, dtype=np.int64)
    C = V[T].mean(axis=1)
    N = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    rad = np.stack([C[:, 0], C[:, 1], np.zeros(len(C))], axis=1)
    U = rad - N * np.einsum("ij,ij->i", rad, N)[:, None]
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    W = np.cross(N, U)
    return V, T, U, W


def constant_field(T, d1, d2):
    m = len(T)
    return np.tile(np.asarray(d1, float), (m, 1)), np.tile(np.asarray(d2, float), (m, 1))


def per_face_gradients(V, T, UV):
    """∇u, ∇v per face (m, 3) each."""
    P = V[T]
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    A2 = np.linalg.norm(n, axis=1)
    n = n / A2[:, None]
    G = [np.cross(n, P[:, (i + 2) % 3] - P[:, (i + 1) % 3]) / A2[:, None] for i in range(3)]
    gu = sum(UV[:, i, 0:1] * G[i] for i in range(3))
    gv = sum(UV[:, i, 1:2] * G[i] for i in range(3))
    return gu, gv


def assert_seamless(T, UV, tol=1e-6):
    """Across every interior edge the two sides differ by a quarter-turn rotation and an integer shift."""
    H = np.stack([T.ravel(), np.roll(T, -1, axis=1).ravel()], axis=1)
    key = {(a, b): i for i, (a, b) in enumerate(H.tolist())}
    worst = 0.0
    for i, (a, b) in enumerate(H.tolist()):
        j = key.get((b, a))
        if j is None or j < i:
            continue
        f, g = i // 3, j // 3
        fa, fb = UV[f, i % 3], UV[f, (i + 1) % 3]
        ga, gb = UV[g, (j + 1) % 3], UV[g, j % 3]
        best = np.inf
        for A in _A:
            d = np.abs((gb - ga) - A @ (fb - fa)).max()
            if d < best:
                best, Ab = d, A
        t = ga - Ab @ fa
        worst = max(worst, best, np.abs(t - np.round(t)).max())
    assert worst < tol, f"seam mismatch {worst}"


# ----------------------------------------------------------------------------------------------
# analytic cases


def test_constant_field_on_plane_gives_the_scaled_coordinates():
    V, T = plane(jitter=0.3)
    U, W = constant_field(T, [1, 0, 0], [0, 1, 0])
    par = seamless_parametrization(V, T, U, W, target_length=0.5)
    assert len(par.singularities) == 0 and par.flipped == 0
    # u = x / h + const, v = y / h + const in every corner
    d = par.UV - V[T][:, :, :2] / 0.5
    assert np.ptp(d[..., 0]) < 1e-6 and np.ptp(d[..., 1]) < 1e-6
    assert np.max(par.angle_error) < 1e-6
    # the aligned square boundary sits on integer lines
    assert par.boundary_gap < 1e-6


def test_rotated_field_gradients_follow_the_directions():
    V, T = plane(jitter=0.2)
    a = np.radians(30)
    U, W = constant_field(T, [np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0])
    h = 0.4
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    gu, gv = per_face_gradients(V, T, par.UV)
    # gradients of the combed frame: along ±U / ±W with magnitude 1/h
    assert np.allclose(np.linalg.norm(gu, axis=1), 1 / h, rtol=1e-6)
    assert np.allclose(np.abs(gu @ U[0]) * h, 1.0, atol=1e-6) or np.allclose(np.abs(gu @ W[0]) * h, 1.0, atol=1e-6)
    assert np.degrees(par.angle_error.max()) < 1e-4


def test_non_orthogonal_frame_iso_lines_run_along_the_other_direction():
    """For a non-orthogonal pair the gradients are the dual basis: iso-u lines along W, iso-v lines along U."""
    V, T = plane(jitter=0.2)
    b = np.radians(60)
    Ud, Wd = np.array([1.0, 0, 0]), np.array([np.cos(b), np.sin(b), 0])
    U, W = constant_field(T, Ud, Wd)
    h = 0.5
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    gu, gv = per_face_gradients(V, T, par.UV)
    Uc, Wc = par.U, par.W  # combed (possibly rotated) frame actually followed
    assert np.allclose(np.einsum("ij,ij->i", gu, Wc), 0, atol=1e-9)  # u constant along W
    assert np.allclose(np.einsum("ij,ij->i", gv, Uc), 0, atol=1e-9)  # v constant along U
    assert np.allclose(np.einsum("ij,ij->i", gu, Uc) * h, 1, atol=1e-9)  # a step h along U is one unit
    assert np.allclose(np.einsum("ij,ij->i", gv, Wc) * h, 1, atol=1e-9)
    assert np.degrees(field_angle_error(V, T, par.UV, Uc, Wc).max()) < 1e-6


def test_surface_of_revolution_annulus_meridians_and_parallels():
    """Two boundary loops (a cut joins them), an analytic conjugate field: parallels stay iso-lines."""
    V, T, U, W = annulus()
    h = 0.5
    par = seamless_parametrization(V, T, U, W, target_length=h)
    assert len(par.singularities) == 0
    assert par.flipped == 0
    assert len(par.cut_edges) > 0  # the loop cut
    assert_seamless(T, par.UV)
    # meridian/parallel field: the iso-lines stay close to it (the fan of meridians is the only distortion)
    assert np.degrees(np.mean(par.angle_error)) < 3.0
    # both boundary circles are parallels: one coordinate is constant and integer along each
    r = np.hypot(V[:, 0], V[:, 1])
    for rr in (4.0, 7.0):
        on = np.isclose(r[T], rr)
        vals = par.UV[on]
        spread = [np.ptp(vals[:, 0]), np.ptp(vals[:, 1])]
        k = int(np.argmin(spread))
        assert spread[k] < 1e-9
        assert np.allclose(vals[:, k], np.round(vals[:, k]))


def test_singularities_sit_on_integer_points_and_seams_close():
    V, T, _ = sample_mesh("canopy", 24)
    U, W = direction_field(V, T, field="smooth", alignment=0.1)
    par = seamless_parametrization(V, T, U, W, target_length=2.0)
    assert len(par.singularities) > 0
    assert set(np.unique(par.singularity_turns)) <= {1, 2, 3}
    for s in par.singularities:
        uv = par.UV[T == s]
        assert np.allclose(uv, np.round(uv), atol=1e-9)
    assert_seamless(T, par.UV)
    assert par.seam_gap < 1e-3


def test_dome_mean_angle_error_is_small():
    V, T, _ = sample_mesh("dome", 24)
    U, W = direction_field(V, T, field="smooth", alignment=0.1)
    par = seamless_parametrization(V, T, U, W, target_length=2.0)
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    mean = np.degrees(np.sum(par.angle_error * area) / area.sum())
    assert mean < 6.0
    assert par.flipped == 0


def test_principal_fallback_field_is_unit_tangent():
    V, T, _ = sample_mesh("wave", 16)
    U, W = direction_field(V, T, field="principal")
    N = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(U, axis=1), 1) and np.allclose(np.linalg.norm(W, axis=1), 1)
    assert np.abs(np.einsum("ij,ij->i", U, N)).max() < 1e-9


# ----------------------------------------------------------------------------------------------
# published component


def test_parametrize_component_outputs():
    V, T, _ = sample_mesh("dome", 20)
    res = parametrize((V, T), target_length=2.5, field="smooth")
    assert len(res.iso_lines) > 0 and all(np.shape(c) == (2, 3) for c in res.iso_lines[:10])
    uvV, uvF = res.uv_mesh
    assert uvV.shape == (3 * len(T), 3) and uvF.shape == (len(T), 3)
    assert 0 <= res.mean_angle_error < 10 and res.max_angle_error >= res.mean_angle_error
    assert res.flipped_triangles == 0
    assert res.singularities.shape[1] == 3


# ----------------------------------------------------------------------------------------------
# typed errors


@pytest.fixture
def small_disk():
    V, T, _ = sample_mesh("dome", 8)
    return V, T


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), "abc", None])
def test_bad_target_length(small_disk, bad):
    with pytest.raises(InputError, match="target_length"):
        parametrize(small_disk, target_length=bad)


def test_target_larger_than_surface(small_disk):
    with pytest.raises(InputError, match="target_length"):
        parametrize(small_disk, target_length=1e6)


@pytest.mark.parametrize("kw,name", [({"field": "curly"}, "field"), ({"boundary": "round"}, "boundary"),
                                     ({"alignment": -1.0}, "alignment")])
def test_bad_options(small_disk, kw, name):
    with pytest.raises(InputError, match=name):
        parametrize(small_disk, target_length=2.0, **kw)


def test_non_manifold_mesh(nonmanifold_fan):
    with pytest.raises(MeshError, match="mesh"):
        parametrize(nonmanifold_fan, target_length=0.2)


def test_degenerate_mesh():
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], dtype=float)
    T = np.array([[0, 1, 2], [0, 1, 3]], dtype=np.int64)
    with pytest.raises(MeshError, match="mesh"):
        parametrize((V, T), target_length=0.2)


def test_closed_mesh_is_rejected():
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    T = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    with pytest.raises(MeshError, match="closed"):
        parametrize((V, T), target_length=0.3)


def test_field_shape_is_checked():
    V, T = plane(4)
    with pytest.raises(InputError, match="field"):
        seamless_parametrization(V, T, np.zeros((3, 3)), np.zeros((3, 3)), 0.5)


# ----------------------------------------------------------------------------------------------
# size centering and density


def test_centering_is_the_identity_when_the_field_is_followed_exactly():
    V, T = plane(n=10, size=5.0)
    U, W = constant_field(T, [1, 0, 0], [0, 1, 0])
    h = 0.5
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free")
    assert par.scale == 1.0
    gu, gv = per_face_gradients(V, T, par.UV)
    np.testing.assert_allclose(gu, np.tile([1 / h, 0, 0], (len(T), 1)), atol=1e-9)
    # density multiplies the gradients: 10% more iso-lines in each direction
    par = seamless_parametrization(V, T, U, W, target_length=h, boundary="free", density=1.1)
    assert par.scale == pytest.approx(1.1)
    gu, gv = per_face_gradients(V, T, par.UV)
    np.testing.assert_allclose(gv, np.tile([0, 1.1 / h, 0], (len(T), 1)), atol=1e-9)


def test_centering_scale_brings_two_spacings_within_the_band():
    from components.fields.parametrize import _centering_scale

    # half the triangles with iso-line spacing h, half with 1.5 h: only a scale in [1.2, 1.25] puts both within ±25%
    V, T = plane(n=10, size=5.0)
    h = 0.5
    P = V[T][:, :, :2]
    left = V[T][:, :, 0].mean(1) < 2.5
    UV = np.where(left[:, None, None], P / h, P / (1.5 * h))
    d1, d2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    s = _centering_scale(V, T, UV, h, area)
    assert 1.2 - 1e-9 <= s <= 1.25 + 1e-9
    for spacing in (1.0, 1.5):
        assert abs(spacing / s - 1.0) <= 0.25 + 1e-9


def test_bad_density():
    V, T = plane(n=4)
    U, W = constant_field(T, [1, 0, 0], [0, 1, 0])
    with pytest.raises(InputError, match="density"):
        seamless_parametrization(V, T, U, W, target_length=1.0, density=0.0)
