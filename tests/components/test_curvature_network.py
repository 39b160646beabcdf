"""Curvature network: principal field, umbilic handling, network tracing (with a private test tracer until
components.fields.streamlines lands), principal angle error, the published component and its typed errors."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from components.network.tracing import (
    _cut_umbilic,
    curvature_network,
    principal_angle_error,
    principal_field,
    principal_network,
)
from components.core.errors import InputError, MeshError
from components.core.mesh import quad_grid, triangulate
from components.network.rebuild import _Locator, plane_map, uv_to_surface
from components.surfaces.samples import sample_mesh


# ----------------------------------------------------------------------------------------------
# a minimal evenly spaced RK4 tracer, for the tests only (the project's tracer is components.fields.streamlines)


def _uv_dirs(V, T, UV, D):
    """Per-face 3D tangent directions carried to the plane by each triangle's affine map."""
    e1, e2 = V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]
    f1, f2 = UV[T[:, 1]] - UV[T[:, 0]], UV[T[:, 2]] - UV[T[:, 0]]
    G = np.stack([e1, e2], 2)
    c = np.linalg.solve(np.einsum("mki,mkj->mij", G, G), np.einsum("mki,mk->mi", G, D)[..., None])[..., 0]
    d = c[:, :1] * f1 + c[:, 1:] * f2
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return np.divide(d, n, out=np.zeros_like(d), where=n > 0)


def trace_evenly(V, T, U, W, family, separation, max_lines=400):
    """Jobard-Lefer style evenly spaced streamlines of ``U`` (family 0) or ``W`` (1), RK4 in the conformal plane.

    Faces with a zero direction stop lines (umbilic regions). Returns a list of (k, 3) polylines on the mesh.
    """
    UV = plane_map(V, T)[0]
    Dm = U if family == 0 else W
    D = _uv_dirs(V, T, UV, Dm)
    valid = (np.linalg.norm(Dm, axis=1) > 0.5) & (np.linalg.norm(D, axis=1) > 0.5)
    loc = _Locator(UV, T)
    a3 = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    e, g = UV[T[:, 1]] - UV[T[:, 0]], UV[T[:, 2]] - UV[T[:, 0]]
    a2 = np.abs(0.5 * (e[:, 0] * g[:, 1] - e[:, 1] * g[:, 0]))
    sc = np.sqrt(a3 / np.maximum(a2, 1e-300))
    state = {"tree": None, "pts": np.zeros((0, 2))}

    def field(p, prev):
        f, _ = loc.locate(p[None])
        if loc.bary(p[None], f)[0].min() < -1e-9 or not valid[f[0]]:
            return None, None
        d = D[f[0]]
        return (-d if prev is not None and d @ prev < 0 else d), sc[f[0]]

    def too_close(p, s, frac):
        t = state["tree"]
        return t is not None and len(t.query_ball_point(p, frac * separation / s)) > 0

    def trace(p0, d0, other):
        out, p, d = [], p0, d0
        for _ in range(3000):
            k1, s = field(p, d)
            if k1 is None:
                break
            hs = separation / 6 / s
            k2, _ = field(p + 0.5 * hs * k1, k1)
            k3, _ = field(p + 0.5 * hs * k2, k2) if k2 is not None else (None, None)
            k4, _ = field(p + hs * k3, k3) if k3 is not None else (None, None)
            if k4 is None:
                break
            dn = k1 + 2 * k2 + 2 * k3 + k4
            dn /= np.linalg.norm(dn)
            pn = p + hs * dn
            if too_close(pn, s, 0.5):
                break
            if len(out) > 12:
                own = np.array(out[:-12] + other)
                if len(own) and np.min(np.linalg.norm(own - pn, axis=1)) < 0.5 * separation / s:
                    break
            out.append(pn)
            p, d = pn, dn
        return out

    vi = np.flatnonzero(valid)
    cen = UV[T[vi]].mean(axis=1)
    cands = list(cen[np.argsort(np.linalg.norm(cen - cen.mean(axis=0), axis=1))][::max(1, len(vi) // 25)])
    lines = []
    while cands and len(lines) < max_lines:
        p0 = cands.pop(0)
        d0, s = field(p0, None)
        if d0 is None or too_close(p0, s, 0.99):
            continue
        fw = trace(p0, d0, [])
        bw = trace(p0, -d0, fw)
        L = np.array(bw[::-1] + [p0] + fw)
        if len(L) < 4:
            continue
        lines.append(L)
        state["pts"] = np.vstack([state["pts"], L])
        state["tree"] = cKDTree(state["pts"])
        for i in range(0, len(L), 3):
            j, k = min(i + 1, len(L) - 1), max(min(i + 1, len(L) - 1) - 1, 0)
            t = L[j] - L[k]
            t = t / np.linalg.norm(t)
            f, _ = loc.locate(L[i][None])
            for sg in (1, -1):
                cands.append(L[i] + sg * separation / sc[f[0]] * np.array([-t[1], t[0]]))
    return [uv_to_surface(V, T, UV, L)[0] for L in lines]


# ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def saddle():
    V, T, _ = sample_mesh("saddle", 40)
    return V, T


def test_principal_field_saddle_is_anisotropic(saddle):
    V, T = saddle
    fld = principal_field(V, T)
    assert not fld.umbilic.any()
    assert np.all(fld.k1 >= fld.k2)
    assert np.allclose(np.einsum("ij,ij->i", fld.PD1, fld.PD2), 0, atol=1e-9)


def test_principal_field_dome_has_umbilic_spots():
    V, T, _ = sample_mesh("dome", 40)
    fld = principal_field(V, T, umbilic_threshold=0.05)
    # an elliptic dome has (two) umbilics: a small low-anisotropy region, not the whole surface
    assert 0 < fld.umbilic.mean() < 0.2


@pytest.mark.parametrize("tracer", ["project", "test"])
def test_network_on_saddle(saddle, tracer):
    V, T = saddle
    if tracer == "project":
        pytest.importorskip("components.fields.streamlines")
    net = principal_network(V, T, 2.5, tracer=trace_evenly if tracer == "test" else None)
    assert len(net.lines_1) >= 5 and len(net.lines_2) >= 5
    from components.core.proximity import closest_points

    P = np.concatenate(net.lines_1 + net.lines_2)
    assert closest_points(P, V, T).distances.max() < 1e-9  # the lines lie on the surface
    # line segments follow their principal direction
    from components.core.proximity import TriangleIndex

    idx = TriangleIndex(V, T)
    for lines, D in ((net.lines_1, net.field.PD1), (net.lines_2, net.field.PD2)):
        seg = np.concatenate([np.diff(L, axis=0) for L in lines])
        mid = np.concatenate([0.5 * (L[1:] + L[:-1]) for L in lines])
        f = idx.query(mid).faces
        c = np.abs(np.einsum("ij,ij->i", seg, D[f])) / np.linalg.norm(seg, axis=1)
        assert np.degrees(np.arccos(np.clip(np.median(c), 0, 1))) < 5


def test_cut_umbilic_splits_lines():
    V, Q = quad_grid(10, 1, 10.0, 1.0)
    T = triangulate(Q)[0]
    um = np.zeros(len(T), bool)
    um[(V[T].mean(axis=1)[:, 0] > 4) & (V[T].mean(axis=1)[:, 0] < 6)] = True
    L = np.c_[np.linspace(0, 10, 101), np.full(101, 0.5), np.zeros(101)]
    out, ncut = _cut_umbilic(V, T, [L], um, 0.5)
    assert ncut == 1 and len(out) == 2
    assert out[0][:, 0].max() <= 4.1 and out[1][:, 0].min() >= 5.9


def test_umbilic_only_sphere_patch_is_refused():
    th = np.linspace(0, 0.6, 12)
    ph = np.linspace(0, 0.6, 12)
    A, B = np.meshgrid(th, ph, indexing="ij")
    V = np.stack([np.cos(A) * np.cos(B), np.sin(A) * np.cos(B), np.sin(B)], -1).reshape(-1, 3)
    _, Q = quad_grid(11, 11)
    with pytest.raises(InputError, match="umbilic") as exc:
        curvature_network((V, triangulate(Q)[0]), panel_size=0.1)
    assert exc.value.name == "mesh" if hasattr(exc.value, "name") else "mesh" in str(exc.value)


def test_principal_angle_error_of_the_principal_grid():
    # a parameter grid of a cylinder: its edges are exactly principal
    u, v = np.meshgrid(np.linspace(0, 1.2, 25), np.linspace(0, 2, 21), indexing="ij")
    V = np.stack([np.cos(u), np.sin(u), v], -1).reshape(-1, 3)
    _, Q = quad_grid(20, 24)
    Q = Q[:, ::-1]
    T = triangulate(Q)[0]
    fld = principal_field(V, T)
    err = principal_angle_error(V, Q, V, T, fld)
    assert err.mean < 1.0


def test_bad_inputs(saddle):
    V, T = saddle
    with pytest.raises(InputError, match="panel_size"):
        curvature_network((V, T), panel_size=0.0)
    with pytest.raises(InputError, match="umbilic_threshold"):
        curvature_network((V, T), panel_size=2.0, umbilic_threshold=1.5)
    with pytest.raises(InputError, match="radius"):
        curvature_network((V, T), panel_size=2.0, radius=0)
    with pytest.raises(MeshError, match="mesh"):
        curvature_network((V, np.array([[0, 1, len(V) + 5]])), panel_size=2.0)
    # a closed surface (octahedron)
    Vo = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    To = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    with pytest.raises(MeshError, match="closed"):
        curvature_network((Vo, To), panel_size=0.5)


def test_dome_umbilics_are_skipped_with_a_warning():
    pytest.importorskip("components.fields.streamlines")
    V, T, _ = sample_mesh("dome", 40)
    net = principal_network(V, T, 2.0)
    assert net.umbilic_fraction > 0 and any("umbilic regions" in w for w in net.warnings)
    from components.core.proximity import TriangleIndex

    P = np.concatenate(net.lines_1 + net.lines_2)
    assert not net.field.umbilic[TriangleIndex(V, T).query(P).faces].any()  # no line runs through an umbilic region

