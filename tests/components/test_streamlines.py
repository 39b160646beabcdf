"""Streamlines: straight lines of constant fields, staying on the surface, following the field, stopping rules."""
from __future__ import annotations

import numpy as np
import pytest

from components.fields.field import conjugate_frame_field, field_curvature, smooth_frame_field
from components.core.errors import InputError, MeshError
from components.core.mesh import read_mesh, triangulate
from components.core.proximity import closest_points
from components.surfaces.samples import sample_mesh
from components.fields import streamlines as streamlines_module
from components.fields.streamlines import evenly_spaced_streamlines, streamlines, trace_streamlines
from tests.components.test_fields import _annulus, _grid_triangles, _torus
from tests.conftest import data_file


def _constant_field(T, angle):
    m = len(T)
    U = np.tile([np.cos(angle), np.sin(angle), 0.0], (m, 1))
    W = np.tile([-np.sin(angle), np.cos(angle), 0.0], (m, 1))
    return U, W


def _deviation_from_line(L, direction):
    d = L - L[0]
    t = np.asarray(direction) / np.linalg.norm(direction)
    return float(np.abs(d - np.outer(d @ t, t)).max())


@pytest.mark.parametrize("angle", [0.0, 0.3, 1.1, -0.7])
def test_constant_field_gives_straight_lines_across_the_patch(angle):
    V, T = _grid_triangles(20, 15, 4.0, 3.0, jitter=0.2)
    U, W = _constant_field(T, angle)
    seeds = np.array([[2.0, 1.5, 0.0], [0.7, 0.4, 0.0], [3.1, 2.5, 0.2]])
    for fam, d in ((0, U[0]), (1, W[0])):
        lines = trace_streamlines(V, T, U, W, seeds, family=fam)
        assert len(lines) == 3
        for L in lines:
            assert _deviation_from_line(L, d) < 1e-9
            # both ends on the boundary of the rectangle
            for p in (L[0], L[-1]):
                on = min(abs(p[0]), abs(p[0] - 4.0), abs(p[1]), abs(p[1] - 3.0))
                assert on < 1e-9
            # monotone along the direction: no back-tracking
            s = (L - L[0]) @ d
            assert np.all(np.diff(s) > 0) or np.all(np.diff(s) < 0)


def test_evenly_spaced_constant_field_is_a_family_of_parallel_lines():
    V, T = _grid_triangles(24, 24, 6.0, 6.0, jitter=0.2)
    U, W = _constant_field(T, 0.4)
    lines = evenly_spaced_streamlines(V, T, U, W, family=0, separation=0.5)
    assert len(lines) >= 12
    n = np.array([-np.sin(0.4), np.cos(0.4), 0.0])
    offsets = []
    for L in lines:
        assert _deviation_from_line(L, U[0]) < 1e-9
        offsets.append(float(L[0] @ n))
    offsets = np.sort(offsets)
    gaps = np.diff(offsets)
    assert gaps.min() > 0.5 * 0.5 - 1e-9  # never closer than the test distance
    assert np.median(gaps) == pytest.approx(0.5, rel=0.05)


def test_streamlines_stay_on_the_surface_and_follow_the_field():
    V, T, _ = sample_mesh("wave", 32)
    cv = field_curvature(V, T)
    fld = smooth_frame_field(V, T, curvature=cv)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    rng = np.random.default_rng(1)
    faces = rng.choice(len(T), 12, replace=False)
    seeds = (faces, np.full((12, 3), 1.0 / 3.0))
    for fam in (0, 1):
        lines = trace_streamlines(V, T, fld.U, fld.W, seeds, family=fam)
        assert len(lines) >= 10
        P = np.concatenate(lines)
        res = closest_points(P, V, T)
        assert res.distances.max() <= 1e-9 * diag
        # segment directions are close to one of the field directions of the triangle they lie in
        mid = np.concatenate([0.5 * (L[1:] + L[:-1]) for L in lines])
        seg = np.concatenate([np.diff(L, axis=0) for L in lines])
        ok = np.linalg.norm(seg, axis=1) > 1e-6
        f = closest_points(mid[ok], V, T).faces
        s = seg[ok] / np.linalg.norm(seg[ok], axis=1, keepdims=True)
        c = np.maximum(np.abs(np.einsum("ij,ij->i", s, fld.U[f])), np.abs(np.einsum("ij,ij->i", s, fld.W[f])))
        assert np.median(c) > 0.999
        assert np.mean(c > 0.98) > 0.95


def test_streamlines_stop_at_the_boundary():
    V, T, B = sample_mesh("dome", 32)
    fld = smooth_frame_field(V, T)
    lines = trace_streamlines(V, T, fld.U, fld.W, V[~np.isin(np.arange(len(V)), B)][::40], family=0)
    from components.core.proximity import closest_points_on_polyline

    loop = np.vstack([V[B], V[B[:1]]])
    ends_on_boundary = 0
    for L in lines:
        for p in (L[0], L[-1]):
            d = closest_points_on_polyline(p[None], loop).distances[0]
            ends_on_boundary += d < 1e-9
    # every end is on the boundary except those stopped at a singularity or closed loops
    assert ends_on_boundary >= 0.7 * 2 * len(lines)


def test_loops_close_on_a_torus():
    V, T = _torus(60, 30)
    # the exact parallel / meridian directions per face
    C = V[T].mean(axis=1)
    par = np.stack([-C[:, 1], C[:, 0], np.zeros(len(T))], axis=1)
    N = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    par -= np.einsum("ij,ij->i", par, N)[:, None] * N / np.einsum("ij,ij->i", N, N)[:, None]
    U = par / np.linalg.norm(par, axis=1, keepdims=True)
    W = np.cross(N / np.linalg.norm(N, axis=1, keepdims=True), U)
    lines = trace_streamlines(V, T, U, W, (np.array([0, 700]), np.full((2, 3), 1 / 3)), family=0)
    lines += trace_streamlines(V, T, U, W, (np.array([0, 700]), np.full((2, 3), 1 / 3)), family=1)
    assert len(lines) == 4
    for L in lines:
        assert np.allclose(L[0], L[-1])  # closed
        r = np.hypot(L[:, 0], L[:, 1])
        # a parallel or a meridian: constant distance to the axis or to the core circle
        core = np.hypot(r - 3.0, L[:, 2])
        assert np.ptp(r) < 0.05 or np.ptp(core) < 0.05


def test_skipping_the_self_test_where_it_cannot_fire_changes_no_line(monkeypatch):
    """A trace skips its self-distance test while its segments stay in a cone around the start tangent (no point
    can be that close to one more than a lag back), and the queued seeds are tested against the newest line only:
    the same lines as with every test run in full, on a surface whose principal lines curve and end on each
    other."""
    V, T, _ = sample_mesh("canopy", 30)
    cv = field_curvature(V, T)
    kw = dict(separation=1.5, labelled=True, extend_ratio=0.25)
    fast = [evenly_spaced_streamlines(V, T, cv.d1, cv.d2, family=f, **kw) for f in (0, 1)]
    monkeypatch.setattr(streamlines_module._Tested, "_far", lambda self, idx: False)
    full_hits = streamlines_module._Points.hits
    monkeypatch.setattr(streamlines_module._Points, "hits",
                        lambda self, *a, first_block=0, **k: full_hits(self, *a, **k))
    streamlines_module._PREPARED.clear()
    slow = [evenly_spaced_streamlines(V, T, cv.d1, cv.d2, family=f, **kw) for f in (0, 1)]
    assert sum(len(a) for a in fast) > 10
    for a, b in zip(fast, slow):
        assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_lines_stop_near_singularities():
    V, T, _ = sample_mesh("canopy", 40)
    fld = smooth_frame_field(V, T)
    assert len(fld.singularities) > 0
    S = V[fld.singularities]
    step = min(0.25 * 2.0, 0.5 * np.linalg.norm(V[T[:, [1, 2, 0]]] - V[T], axis=2).mean())  # the tracing step
    nearest = {}
    for radius in (0.6, 1.2, 2.0):
        lines = evenly_spaced_streamlines(V, T, fld.U, fld.W, family=2, separation=2.0, singularity_radius=radius)
        assert max(np.linalg.norm(np.diff(L, axis=0), axis=1).max() for L in lines) <= step + 1e-9
        P = np.concatenate(lines)
        d = np.linalg.norm(P[:, None, :] - S[None], axis=2).min(axis=0)  # closest approach to each singularity
        # never deeper than one step inside the stop radius ...
        assert d.min() >= radius - step, (radius, d.min())
        # ... and the lines reaching a singularity stop because of it: every one is approached inside the radius
        assert d.max() < radius, (radius, d.max())
        nearest[radius] = d
    assert nearest[2.0].min() > nearest[0.6].max()  # a larger radius stops the lines farther out


def test_hole_and_real_mesh():
    V, T = _annulus()
    fld = smooth_frame_field(V, T)
    lines = evenly_spaced_streamlines(V, T, fld.U, fld.W, family=2, separation=0.3)
    assert len(lines) > 10
    Vr, F = read_mesh(data_file("inspired_mesh.obj"))
    Tr, _ = triangulate(F)
    cv = field_curvature(Vr, Tr)
    s = smooth_frame_field(Vr, Tr, curvature=cv)
    c = conjugate_frame_field(Vr, Tr, s.U, s.W, curvature=cv)
    net = evenly_spaced_streamlines(Vr, Tr, c.U, c.W, family=2, separation=1.5)
    assert len(net) > 20
    P = np.concatenate(net)
    diag = float(np.linalg.norm(Vr.max(0) - Vr.min(0)))
    assert closest_points(P, Vr, Tr).distances.max() <= 1e-9 * diag


def test_published_component():
    V, T, _ = sample_mesh("saddle", 24)
    res = streamlines((V, T), 2, 3.0)
    assert res.curve_count == len(res.curves) > 5
    assert res.point_count == sum(len(c) for c in res.curves)
    seeded = streamlines((V, T), 0, 3.0, seeds=V[[100, 200]], field="smooth")
    assert seeded.curve_count == 2
    principal = streamlines((V, T), 1, 3.0, field="principal")
    assert principal.curve_count > 0


def test_bad_input(nonmanifold_fan):
    V, T = _grid_triangles(4, 4)
    U, W = _constant_field(T, 0.0)
    with pytest.raises(MeshError, match="mesh"):
        trace_streamlines(*nonmanifold_fan, U[:3], W[:3], seeds=np.zeros((1, 3)))
    with pytest.raises(InputError, match="U"):
        trace_streamlines(V, T, U[:-1], W, seeds=np.zeros((1, 3)))
    with pytest.raises(InputError, match="family"):
        trace_streamlines(V, T, U, W, seeds=np.zeros((1, 3)), family=2)
    with pytest.raises(InputError, match="seeds"):
        trace_streamlines(V, T, U, W, seeds=(np.array([99]), np.array([[1.0, 0, 0]])))
    with pytest.raises(InputError, match="step"):
        trace_streamlines(V, T, U, W, seeds=np.zeros((1, 3)), step=-1.0)
    with pytest.raises(InputError, match="separation"):
        evenly_spaced_streamlines(V, T, U, W, separation=0.0)
    with pytest.raises(InputError, match="separation"):
        evenly_spaced_streamlines(V, T, U, W, separation=1e-5)
    with pytest.raises(InputError, match="field"):
        streamlines((V, T), field="random")
    with pytest.raises(MeshError, match="mesh"):
        streamlines(nonmanifold_fan)


# ----------------------------------------------------------------------------------------------
# labelled (principal) fields: the mixed wave sample, with closed curvature lines around flat-point umbilics


def _wave_principal():
    from components.network.tracing import principal_field

    V, T, _ = sample_mesh("wave", 40)
    fld = principal_field(V, T)
    return V, T, fld


def _same_family_crossings(lines):
    from components.network.rebuild import network_crossings

    L2 = [L[:, :2] for L in lines]  # a height field: the plan view keeps crossings
    ia, _, ib, _, _ = network_crossings(L2, L2)
    return int(np.sum(ia != ib))


def test_labelled_lines_keep_their_family_and_loops_close_once():
    V, T, fld = _wave_principal()
    seed = V[T].mean(axis=1)[[int(np.argmax(fld.anisotropy))]]
    for fam, D in ((0, fld.PD1), (1, fld.PD2)):
        diag = {}
        lines = evenly_spaced_streamlines(V, T, fld.PD1, fld.PD2, family=fam, separation=2.0, seeds=seed,
                                          labelled=True, diagnostics=diag)
        assert len(diag["end_reasons"]) == len(lines)
        # every segment follows its own family (the labels are global: no swap into the other one)
        res = closest_points(np.concatenate([0.5 * (L[1:] + L[:-1]) for L in lines]), V, T)
        seg = np.concatenate([np.diff(L, axis=0) for L in lines])
        seg /= np.linalg.norm(seg, axis=1, keepdims=True)
        assert np.mean(np.abs(np.einsum("ij,ij->i", seg, D[res.faces])) > np.cos(np.radians(30))) > 0.97
        # lines of one family never cross each other
        assert _same_family_crossings(lines) == 0
        # a closed curvature line is traced once (no doubled loop): its points are not revisited
        for L, why in zip(lines, diag["end_reasons"]):
            if why == ("closed", "closed"):
                assert np.allclose(L[0], L[-1])
                d = np.linalg.norm(L[1:-1, None, :] - L[None, 1:-1, :], axis=2)
                far = np.abs(np.arange(len(L) - 2)[:, None] - np.arange(len(L) - 2)[None, :]) > 20
                far &= np.minimum.outer(np.arange(len(L) - 2), np.arange(len(L) - 2)) > 5
                assert d[far].min() > 0.3


def test_extension_runs_separation_stops_on():
    V, T, fld = _wave_principal()
    counts = {}
    for ext in (0.0, 0.25):
        diag = {}
        lines = evenly_spaced_streamlines(V, T, fld.PD1, fld.PD2, family=0, separation=2.0, labelled=True,
                                          extend_ratio=ext, diagnostics=diag)
        ends = [r for pair in diag["end_reasons"] for r in pair]
        counts[ext] = sum(r == "separation" for r in ends)
        if ext:
            assert counts[0.0] == sum(r.startswith("extended:") for r in ends)
            assert _same_family_crossings(lines) == 0
            # an extended end stops about a quarter separation from the side of the next line (two ends running
            # head-on into each other may come closer: the quad rebuild joins them)
            P = np.concatenate(lines)
            lid = np.concatenate([np.full(len(L), i) for i, L in enumerate(lines)])
            pos = np.concatenate([np.arange(len(L)) for L in lines])
            end_zone = (pos < 4) | (pos >= np.concatenate([np.full(len(L), len(L) - 4) for L in lines]))
            for i, L in enumerate(lines):
                if diag["end_reasons"][i][1] != "extended:separation":
                    continue
                side = (lid != i) & ~end_zone
                assert np.linalg.norm(P[side] - L[-1], axis=1).min() > 0.2 * 2.0
    assert counts[0.0] > 0


def test_extend_ratio_is_checked():
    V, T = _grid_triangles(6, 6, 2.0, 2.0)
    U, W = _constant_field(T, 0.0)
    with pytest.raises(InputError, match="extend_ratio"):
        evenly_spaced_streamlines(V, T, U, W, separation=0.5, test_ratio=0.5, extend_ratio=0.7)
