"""The fabrication stage: exact flat panels nested on sheets without overlap, panel types (rings of a surface of
revolution, one type for a cylinder, monotone in the tolerance), kinks against the analytic dihedral angle, torsion-free
beams on a conical mesh and twisted ones elsewhere, DXF and CSV read back, typed errors."""
from __future__ import annotations

import csv

import ezdxf
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components.conical.optimize import conical_mesh
from components.core.errors import InputError, MeshError
from components.core.measures import norm
from components.core.mesh import edge_topology, quad_grid
from components.fabrication.congruence import aligned_distances, congruence_types, panel_types
from components.fabrication.export import cutting_list, fabrication, type_layer, write_csv, write_dxf
from components.fabrication.kinks import dihedral_angles, kinks, panel_kinks
from components.fabrication.nodes import beam_frames, nodes, support_axes
from components.fabrication.panels import (diagonal_pairs, flat_panels, grid_positions, outward_sign, panels,
                                           placed_outlines, sheet_layout, sheet_transforms)
from components.harness import default_panel_size
from components.network.pipeline import curvature_pipeline
from components.surfaces.samples import sample_mesh

# ------------------------------------------------------------------------------------------------ meshes


def translation_net(n=8, m=None, span=2.0):
    """z = 0.4 x² − 0.3 y³ + 0.2 x on a grid: exactly planar quads (a translation surface), not conical."""
    V, Q = quad_grid(n, m or n, span, span)
    V[:, :2] -= span / 2
    x, y = V[:, 0] / (span / 2), V[:, 1] / (span / 2)
    V[:, 2] = (span / 2) * (0.4 * x ** 2 - 0.3 * y ** 3 + 0.2 * x)
    return V, Q


def revolution(nz=6, nt=12, closed=True, sweep=0.8 * np.pi, profile=lambda z: 1 + 0.1 * z + 0.3 * z ** 2):
    """Meridians × parallels of a surface of revolution: planar (conical) quads, one congruence class per ring."""
    z = np.linspace(-1, 1, nz + 1)
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False) if closed else np.linspace(0, sweep, nt + 1)
    Z, Th = np.meshgrid(z, th, indexing="ij")
    R = profile(Z)
    V = np.stack([R * np.cos(Th), R * np.sin(Th), Z], -1).reshape(-1, 3)
    m = len(th)
    idx = np.arange(len(V)).reshape(nz + 1, m)
    F = [[idx[i, j], idx[i, (j + 1) % m], idx[i + 1, (j + 1) % m], idx[i + 1, j]]
         for i in range(nz) for j in range(m if closed else m - 1)]
    return V, np.asarray(F, dtype=np.int64)


def cylinder(nz=5, nt=9, radius=1.3, height=0.7):
    """A regular nt-gonal prism of nz rings: equal chords, equal heights."""
    V, F = revolution(nz, nt, profile=lambda z: radius + 0 * z)
    V[:, 2] *= height * nz / 2
    return V, F


def random_rotation(seed):
    q = np.random.default_rng(seed).standard_normal(4)
    a, b, c, d = q / np.linalg.norm(q)
    return np.array([[a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
                     [2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)],
                     [2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d]])


def planar_soup(count, seed=0):
    """``count`` separate random convex planar quads (each in its own random plane): a mesh of distinct panels."""
    rng = np.random.default_rng(seed)
    Vs, Fs = [], []
    for i in range(count):
        ang = np.sort(rng.uniform(0, 2 * np.pi, 4))
        r = rng.uniform(0.6, 1.4, 4)
        P = np.stack([r * np.cos(ang), r * np.sin(ang), np.zeros(4)], axis=1)
        P = P @ random_rotation(seed * 1000 + i).T + rng.uniform(-10, 10, 3)
        Vs.append(P)
        Fs.append(np.arange(4) + 4 * i)
    return np.concatenate(Vs), np.asarray(Fs, dtype=np.int64)


def optimized_conical():
    """A perturbed surface-of-revolution net optimized back into a conical mesh (the curvature-network strategy's
    last step), polished to planarity ~1e-10."""
    V, F = revolution(6, 8, closed=False)
    Vn = V + 0.002 * np.random.default_rng(1).standard_normal(V.shape)
    res = conical_mesh(Vn, F, (V, F))
    assert res.converged and res.max_planarity < 1e-9
    return res.V, F


def pairwise_3d(V, F):
    P = V[F]
    return norm(P[:, :, None, :] - P[:, None, :, :])


def pairwise_2d(U):
    D = U[:, :, None, :] - U[:, None, :, :]
    return np.hypot(D[..., 0], D[..., 1])


# ------------------------------------------------------------------------------------------------ flat panels


@pytest.mark.parametrize("mesh", [translation_net(), revolution(), revolution(closed=False)], ids=["translation",
                                                                                                   "revolution",
                                                                                                   "open"])
@pytest.mark.parametrize("scale, shift", [(1.0, 0.0), (1000.0, 0.0), (1.0, 5e6)])
@pytest.mark.parametrize("method", ["project", "unfold"])
def test_flat_outlines_keep_every_edge_and_diagonal(mesh, scale, shift, method):
    V, F = mesh
    V = V * scale + shift
    fp = flat_panels(V, F, method=method)
    d3 = pairwise_3d(V - shift, F)  # the model's own distances (exact differences)
    d2 = pairwise_2d(fp.outline)
    rel = np.abs(d2 - d3) / np.where(d3 > 0, d3, 1.0)
    # at site coordinates the input itself is only known to 1e-9 of the edge length (5e6 × 2.2e-16 / 0.5)
    assert rel.max() <= (1e-8 if shift else 1e-9)
    assert fp.length_error.max() <= (1e-8 if shift else 1e-12)
    k = np.arange(4)
    assert np.allclose(fp.edge_lengths, d3[:, k, (k + 1) % 4], rtol=1e-9)
    pairs = diagonal_pairs(4)
    assert np.allclose(fp.diagonals, d3[:, pairs[:, 0], pairs[:, 1]], rtol=1e-9)
    assert np.abs(fp.outline[:, 0]).max() == 0.0 and np.abs(fp.outline[:, 1, 1]).max() <= 1e-12 * scale
    assert np.all(fp.outline[:, 1, 0] > 0)
    assert np.allclose(fp.corner_angles.sum(axis=1), 360.0, atol=1e-9)


def test_mixed_polygons_keep_all_their_distances():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2.5, 1.5, 0], [1.5, 1.8, 0],
                  [0.5, 2, 0]], dtype=float) @ random_rotation(5).T
    F = np.array([[0, 1, 2, 3, 3], [1, 4, 5, 6, 2], [3, 2, 7, 7, 7]])  # a quad, a pentagon, a triangle
    fp = flat_panels(V, F)
    for f, s in enumerate([4, 5, 3]):
        P = V[F[f, :s]]
        d3 = norm(P[:, None] - P[None])
        assert np.allclose(pairwise_2d(fp.outline[f:f + 1, :s])[0], d3, rtol=1e-12, atol=1e-15)
    assert np.isfinite(fp.diagonals).sum(axis=1).tolist() == [2, 5, 0]
    assert np.allclose(np.nansum(fp.corner_angles, axis=1), [360.0, 540.0, 180.0])
    res = panels((V, F))
    assert res.corner_counts.tolist() == [4, 5, 3] and len(res.edge_lengths) == 12 and len(res.diagonals) == 7


def test_frame_is_orthonormal_and_maps_the_panel_onto_its_placed_outline():
    V, F = translation_net()
    V = V @ random_rotation(3).T + np.array([5e6, -2e6, 300.0])
    fp = flat_panels(V, F)
    for a in (fp.xaxis, fp.yaxis, fp.zaxis):
        assert np.allclose(norm(a), 1.0, atol=1e-14)
    assert np.abs(np.einsum("ij,ij->i", fp.xaxis, fp.zaxis)).max() < 1e-14
    lay = sheet_layout(fp, gap=0.05)
    T = sheet_transforms(fp, lay)
    placed = placed_outlines(fp, lay)
    X = np.concatenate([V[F], np.ones(F.shape + (1,))], axis=-1)
    img = np.einsum("mij,mkj->mki", T, X)
    # the 4x4 transform acts on absolute coordinates: at 5e6 it is good to ~1e-9 of the coordinates
    assert np.abs(img[..., :2] - placed).max() < 1e-8 * 5e6 * 1e-1
    assert np.abs(img[..., 2]).max() < 1e-3


def test_outside_is_up_for_roofs_and_outward_for_closed_meshes():
    V, Q = quad_grid(4, 4, height=lambda x, y: -(x - 0.5) ** 2 - (y - 0.5) ** 2)  # a dome
    assert outward_sign(V, Q) == 1.0 and outward_sign(V, Q[:, ::-1]) == -1.0
    V[:, 2] *= -1  # a bowl: still the sky side
    assert outward_sign(V, Q) == 1.0
    Vc, Fc = revolution(4, 10)  # an open tube around z: away from its axis
    fp = flat_panels(Vc, Fc)
    centre = Vc[Fc].mean(axis=1)
    radial = centre - np.array([0, 0, 1.0])[None] * centre[:, 2:3]
    assert np.all(np.einsum("ij,ij->i", fp.zaxis, radial) > 0)
    assert np.all(np.einsum("ij,ij->i", flat_panels(Vc, Fc[:, ::-1]).zaxis, radial) > 0)
    assert np.all(np.einsum("ij,ij->i", flat_panels(Vc, Fc[:, ::-1], orientation="mesh").zaxis, radial) < 0)


def test_warped_panels_are_projected_or_unfolded_as_documented():
    V, Q = quad_grid(4, 4)
    V[:, 2] = 0.05 * np.random.default_rng(2).standard_normal(len(V))
    proj = flat_panels(V, Q, method="project")
    unf = flat_panels(V, Q, method="unfold")
    d3 = pairwise_3d(V, Q)
    k = np.arange(4)
    assert np.allclose(unf.edge_lengths, d3[:, k, (k + 1) % 4], rtol=1e-12)  # edges kept
    assert np.allclose(unf.diagonals[:, 0], d3[:, 0, 2], rtol=1e-12)  # and the diagonal from the first corner
    assert proj.length_error.max() > 1e-4 and np.all(proj.edge_lengths <= d3[:, k, (k + 1) % 4] * (1 + 1e-12))
    # residuals: signed distances to the least-squares plane, summing to zero per panel
    assert np.abs(proj.residual.sum(axis=1)).max() < 1e-12 and np.abs(proj.residual).max() > 1e-3
    res = panels((V, Q))
    assert res.max_residual == pytest.approx(np.abs(proj.residual).max())
    assert any("not planar" in w for w in res.warnings)


def test_layout_has_no_overlap_and_stays_on_the_sheets():
    V, F = planar_soup(120, seed=4)
    fp = flat_panels(V, F)
    W, H, gap = 5.0, 4.0, 0.1
    lay = sheet_layout(fp, W, H, gap)
    P = placed_outlines(fp, lay)
    lo, hi = P.min(axis=1), P.max(axis=1)
    # the placed outlines' boxes are their smallest rectangles, at least a gap apart
    assert np.allclose(np.sort(hi - lo, axis=1), np.stack([fp.rect_height, fp.rect_width], 1), atol=1e-12)
    sep = np.maximum(lo[:, None, :] - hi[None, :, :], lo[None, :, :] - hi[:, None, :]).max(axis=2)
    np.fill_diagonal(sep, np.inf)
    assert sep.min() >= gap - 1e-12
    o = lay.sheet_origin[lay.sheet]
    assert np.all(lo - o >= gap - 1e-12) and np.all(hi - o <= np.array([W, H]) - gap + 1e-12)
    assert lay.sheet_count >= 2 and set(lay.sheet.tolist()) == set(range(lay.sheet_count))
    # the drawn area is at most a few times the panels' own rectangles (the packing is not wasteful)
    assert lay.sheet_count * W * H < 3.0 * float(((fp.rect_width + gap) * (fp.rect_height + gap)).sum())


def test_layout_turns_a_long_panel_to_fit_and_refuses_one_too_big():
    V = np.array([[0, 0, 0], [3.0, 0, 0], [3.0, 0.5, 0], [0, 0.5, 0]])
    fp = flat_panels(V, np.array([[0, 1, 2, 3]]))
    lay = sheet_layout(fp, 1.0, 4.0, 0.1)
    P = placed_outlines(fp, lay)[0]
    assert np.allclose(P.max(axis=0) - P.min(axis=0), [0.5, 3.0])
    with pytest.raises(InputError, match="^sheet_width: panel A01 "):
        sheet_layout(fp, 1.0, 1.0, 0.1)
    with pytest.raises(InputError, match="^gap"):
        sheet_layout(fp, gap=-1)


def test_grid_labels_rows_columns_and_fallback():
    V, Q = quad_grid(3, 2)
    res = panels((V, Q))
    assert res.labels == ["A01", "A02", "A03", "B01", "B02", "B03"]
    Vc, Fc = revolution(2, 12)  # closed around: columns 01..12 from the first face
    assert grid_positions(Fc)[:, 1].tolist() == list(range(12)) * 2
    assert panels((Vc, Fc)).labels[:3] == ["A01", "A02", "A03"]
    Vt = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    assert panels((Vt, np.array([[0, 1, 2, 3], [1, 4, 2, 2]]))).labels == ["P0000", "P0001"]


def test_panels_component_outputs_agree():
    V, F = translation_net(5)
    res = panels((V, F), sheet_width=1.5, sheet_height=1.5, gap=0.02)
    m = len(F)
    assert len(res.outlines) == m and all(np.allclose(c[0], c[-1]) and c.shape == (5, 3) for c in res.outlines)
    assert res.ids.tolist() == list(range(m)) and len(res.frames) == len(res.sheet_frames) == m
    assert len(res.edge_lengths) == len(res.corner_angles) == len(res.residuals) == 4 * m
    assert len(res.diagonals) == 2 * m and res.corner_counts.tolist() == [4] * m
    assert res.max_length_error < 1e-12 and res.max_residual < 1e-12 and res.warnings == []
    assert res.sheet_count == len(res.sheet_outlines) and res.sheets.max() == res.sheet_count - 1
    # the label point is inside the outline's box
    for c, p in zip(res.outlines, res.label_points):
        assert np.all(p[:2] > c[:, :2].min(axis=0)) and np.all(p[:2] < c[:, :2].max(axis=0))
    # sheet frames: the panel's flat corner 0 is the sheet frame's origin
    assert np.allclose([pl.origin[:2] for pl in res.sheet_frames], [c[0, :2] for c in res.outlines], atol=1e-12)


# ------------------------------------------------------------------------------------------------ panel types


def test_surface_of_revolution_has_one_type_per_ring():
    nz, nt = 7, 16
    V, F = revolution(nz, nt)
    for mirror in (True, False):
        res = panel_types((V, F), tolerance=1e-9, mirror=mirror)
        assert res.type_count == nz
        ring = np.arange(len(F)) // nt
        for r in range(nz):  # every ring is one type, and no two rings share one
            assert len(set(res.types[ring == r].tolist())) == 1
        assert len(set(res.types[np.arange(nz) * nt].tolist())) == nz
        assert res.deviation.max() < 1e-12
    # a profile symmetric about z = 0: a ring below the waist is the reflection of one above, and since its
    # panels are isosceles trapezoids (symmetric themselves) even a rigid motion without a mirror matches them
    Vs, Fs = revolution(6, 16, profile=lambda z: 1 + 0.3 * z ** 2)
    assert panel_types((Vs, Fs), tolerance=1e-9, mirror=True).type_count == 3
    assert panel_types((Vs, Fs), tolerance=1e-9, mirror=False).type_count == 3


def test_cylinder_of_equal_chords_and_heights_is_one_type_anywhere():
    V, F = cylinder()
    V = V @ random_rotation(7).T + np.array([5e6, 1e6, 50.0])
    res = panel_types((V, F), tolerance=1e-9)
    assert res.type_count == 1 and res.counts.tolist() == [len(F)]
    assert res.deviation.max() < 1e-9 and res.representatives.tolist() == [0]


def test_random_panels_are_all_different_at_a_tiny_tolerance():
    V, F = planar_soup(60, seed=9)
    res = panel_types((V, F), tolerance=1e-9)
    assert res.type_count == len(F) and sorted(res.representatives.tolist()) == list(range(len(F)))
    # and all one type at a tolerance larger than any panel
    assert panel_types((V, F), tolerance=10.0).type_count == 1


def test_mirror_images_are_one_type_only_with_mirror():
    P = np.array([[0, 0, 0], [2.0, 0, 0], [1.6, 1.0, 0], [0.3, 0.8, 0]])
    Q = P * np.array([-1.0, 1.0, 1.0]) + np.array([5.0, 0, 0])  # its reflection, re-oriented to face up
    V = np.concatenate([P, Q])
    F = np.array([[0, 1, 2, 3], [7, 6, 5, 4]])
    assert outward_sign(V, F) == 1.0
    withm = panel_types((V, F), tolerance=1e-9, mirror=True)
    assert withm.type_count == 1 and withm.mirrored.tolist() == [False, True]
    assert panel_types((V, F), tolerance=1e-9, mirror=False).type_count == 2


def test_aligned_distance_is_symmetric_and_exact_for_moved_copies():
    rng = np.random.default_rng(5)
    A = rng.uniform(-1, 1, (50, 4, 2))
    B = rng.uniform(-1, 1, (50, 4, 2))
    dab, dba = aligned_distances(A, B).distance, aligned_distances(B, A).distance
    assert np.allclose(dab, dba, rtol=1e-12)
    th = rng.uniform(0, 2 * np.pi, 50)
    R = np.stack([np.stack([np.cos(th), -np.sin(th)], 1), np.stack([np.sin(th), np.cos(th)], 1)], 1)
    moved = np.einsum("pij,pkj->pki", R, A)[:, [1, 2, 3, 0]] + rng.uniform(-9, 9, (50, 1, 2))
    assert aligned_distances(A, moved, mirror=False).distance.max() < 1e-12


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 7), noise=st.floats(1e-4, 0.2),
       taus=st.lists(st.floats(1e-5, 0.3), min_size=1, max_size=6), mirror=st.booleans())
def test_type_counts_never_increase_with_the_tolerance(seed, n, noise, taus, mirror):
    rng = np.random.default_rng(seed)
    V, Q = quad_grid(n, n)
    V[:, :2] += noise * rng.uniform(-0.2, 0.2, (len(V), 2))
    V[:, 2] = noise * rng.standard_normal(len(V))
    fp = flat_panels(V, Q)
    res = congruence_types(fp.outline, fp.sizes, taus[0], taus[1:], mirror=mirror)
    assert np.all(np.diff(res.type_counts) <= 0)
    assert res.type_counts[np.searchsorted(res.tolerances, taus[0])] == len(res.counts)
    # every panel within the tolerance of its type's representative, which belongs to the type
    assert np.all(res.deviation <= taus[0] + 1e-12)
    assert np.array_equal(res.types[res.representatives], np.arange(len(res.counts)))
    assert res.counts.sum() == len(Q) and np.all(np.diff(res.counts) <= 0)


def test_types_of_a_symmetric_panelling_are_the_same_in_mm_and_at_site_coordinates():
    # a translation surface on uneven, symmetric steps: its mirror-image panels are at one alignment distance from a
    # leader, which round-off in other units or at +5e6 used to split differently (51/47/41/21 types in m, 20 at
    # the last level in mm; found by an audit)
    s = np.linspace(-1.0, 1.0, 13)
    s = np.sign(s) * np.abs(s) ** 1.3
    t = np.linspace(-1.0, 1.0, 10)
    G = np.stack([5.0 * s, np.zeros_like(s), 2.0 * (1 - s ** 2)], 1)
    D = np.stack([np.zeros_like(t), 3.5 * t, 1.2 * (1 - t ** 2)], 1)
    V = (G[None, :, :] + D[:, None, :]).reshape(-1, 3)
    idx = np.arange(13 * 10).reshape(10, 13)
    Q = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], 1)
    for mirror in (False, True):
        for tol in np.geomspace(2e-3, 0.1, 9):
            seen = set()
            for scale, shift in ((1.0, 0.0), (1000.0, 0.0), (1.0, 5e6), (1000.0, 5e9)):
                r = panel_types((V * scale + shift, Q), tolerance=tol * scale * 10,
                                tolerances=[tol * scale * k for k in (1, 2, 5, 10)], mirror=mirror)
                seen.add((tuple(r.type_counts.tolist()), tuple(r.types.tolist())))
            assert len(seen) == 1, (mirror, tol, seen)


def test_panel_types_component_defaults_and_tolerance_list():
    V, F = translation_net(10)
    res = panel_types((V, F))
    L = flat_panels(V, F).edge_lengths
    assert res.tolerance == pytest.approx(1e-3 * np.median(L))
    assert np.allclose(res.tolerances, res.tolerance * np.array([1, 2, 5, 10]))
    assert np.all(np.diff(res.type_counts) <= 0) and res.type_counts[0] == res.type_count
    assert np.all(res.worst_deviation <= res.tolerance * (1 + 1e-9)) and len(res.type_outlines) == res.type_count
    doc = panel_types((V, F), absolute_tolerance=0.05, tolerances=[0.01, 0.2])
    assert doc.tolerance == 0.05 and doc.tolerances.tolist() == [0.01, 0.2]
    assert doc.type_counts[0] >= doc.type_count >= doc.type_counts[1]
    # scale-free: the same types in millimetres
    mm = panel_types((V * 1000, F))
    assert mm.types.tolist() == res.types.tolist() and mm.type_counts.tolist() == res.type_counts.tolist()


# ------------------------------------------------------------------------------------------------ kinks


def test_kinks_vanish_on_a_planar_mesh():
    V, Q = quad_grid(5, 4, 3.0, 2.0)
    V = V @ random_rotation(11).T
    res = kinks((V, Q))
    assert len(res.kinks) == 31 and res.max_kink < 1e-12 and res.over_count == 0
    # at site coordinates the rotated plane's vertices are rounded to 1e-9 (5e6 × 2.2e-16): kinks of that order
    assert kinks((V + 5e6, Q)).max_kink < 1e-6


@pytest.mark.parametrize("nt", [6, 9, 24])
def test_kinks_are_the_dihedral_angles_of_a_regular_prism(nt):
    V, F = cylinder(4, nt)
    res = kinks((V, F), limit=360.0 / nt - 1e-6)
    d = res.edges[:, 1] - res.edges[:, 0]
    vertical = np.abs(d[:, 2]) > 1e-9
    assert np.allclose(res.kinks[vertical], 360.0 / nt, atol=1e-9)
    assert np.abs(res.kinks[~vertical]).max() < 1e-9
    assert np.allclose(res.signed_kinks[vertical], 360.0 / nt, atol=1e-9)  # ridges seen from outside
    assert res.over_count == int(vertical.sum())
    dh = dihedral_angles(V, F)
    pk = panel_kinks(F, dh)
    assert pk.shape == F.shape and np.nanmax(pk) == pytest.approx(360.0 / nt)
    # a valley from the inside: the faces reversed and the orientation kept as the mesh's
    assert np.allclose(dihedral_angles(V, F[:, ::-1], orientation=1.0).signed[dh.interior & (dh.angle > 1)],
                       -360.0 / nt, atol=1e-9)


# ------------------------------------------------------------------------------------------------ nodes


def test_offset_node_axes_of_an_optimized_conical_mesh_are_torsion_free():
    V, F = optimized_conical()
    res = nodes((V, F))
    assert res.axis_method == "offset" and res.is_conical
    interior = edge_topology(F).count == 2
    assert np.radians(res.torsion[interior]).max() <= 1e-9
    assert np.allclose(norm(res.axes), 1.0)
    # the beam boxes: top edge on the mesh edge, planar sides (torsion-free), the given height along the axes
    res2 = nodes((V, F), beam_height=0.1, beam_width=0.02)
    E = edge_topology(F).E
    Vb, Fb = res2.beams[0]
    assert np.allclose(Vb[[0, 1]] + Vb[[4, 5]], 2 * V[E[0]])
    assert np.allclose(norm(Vb[3] - Vb[0]), 0.1) and np.allclose(norm(Vb[4] - Vb[0]), 0.02)


def test_vertex_normal_axes_of_a_non_conical_pq_mesh_twist():
    V, F = translation_net(8)
    res = nodes((V, F))
    assert res.axis_method == "normals" and not res.is_conical
    assert res.max_torsion > 0.5  # degrees
    forced = nodes((V, F), axes="offset")
    assert forced.max_torsion > 0.01 and any("not conical" in w for w in forced.warnings)


def test_exact_conical_net_and_beam_frames_agree():
    V, F = revolution(5, 10, closed=False)  # exactly conical: torsion at rounding level
    sa = support_axes(V, F)
    fr = beam_frames(V, F, sa.axes)
    assert sa.method == "offset" and np.abs(fr.torsion).max() < 1e-9
    assert np.allclose(norm(fr.normal), 1.0) and np.abs(np.einsum("ij,ij->i", fr.normal, fr.direction)).max() < 1e-12


# ------------------------------------------------------------------------------------------------ export


def test_dxf_has_one_closed_polyline_and_label_per_panel(tmp_path):
    V, F = revolution(3, 8)
    fab = fabrication(V, F, tolerance=1e-9, sheet_width=4.0, sheet_height=3.0, gap=0.05)
    path = write_dxf(tmp_path / "panels.dxf", fab)
    msp = ezdxf.readfile(path).modelspace()
    polys = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer.startswith("TYPE_")]
    assert len(polys) == len(F) and all(p.closed for p in polys)
    assert sorted(p.dxf.layer for p in polys) == sorted(type_layer(t) for t in fab.types.types)
    texts = list(msp.query("TEXT"))
    assert sorted(t.dxf.text for t in texts) == sorted(fab.flat.labels)
    placed = placed_outlines(fab.flat, fab.layout)
    for f, p in enumerate(polys):  # written in panel order, corners in order
        assert np.allclose(np.array([v[:2] for v in p.get_points()]), placed[f], atol=1e-9)
    assert len(msp.query('LWPOLYLINE[layer=="SHEETS"]')) == fab.layout.sheet_count


def test_csv_cutting_list_has_one_row_per_panel(tmp_path):
    V, F = translation_net(4)
    fab = fabrication(V, F, kink_limit=1.0)
    path = write_csv(tmp_path / "cut.csv", fab)
    rows = list(csv.DictReader(path.open()))
    assert len(rows) == len(F) and [r["label"] for r in rows] == fab.flat.labels
    assert np.allclose([float(r["area"]) for r in rows], fab.flat.area, rtol=1e-9)
    assert np.allclose([float(r["edge_1"]) for r in rows], fab.flat.edge_lengths[:, 0], rtol=1e-9)
    pk = panel_kinks(F, fab.dihedrals, signed=True)
    for r, k in zip(rows, pk):
        assert [r[f"kink_{i + 1}"] == "" for i in range(4)] == np.isnan(k).tolist()
    header, _ = cutting_list(fab)
    assert header[:3] == ["id", "label", "type"] and "angle_4" in header and "diagonal_2" in header


# ------------------------------------------------------------------------------------------------ errors


def test_typed_errors_name_the_input():
    V, Q = quad_grid(2, 2)
    with pytest.raises(MeshError, match="^mesh"):
        panels((V, Q + 100))
    with pytest.raises(InputError, match="^gap"):
        panels((V, Q), gap=-0.1)
    with pytest.raises(InputError, match="^method"):
        panels((V, Q), method="peel")
    with pytest.raises(InputError, match="^tolerance"):
        panel_types((V, Q), tolerance=-1)
    with pytest.raises(InputError, match="^tolerances"):
        panel_types((V, Q), tolerances=[0.1, float("nan")])
    with pytest.raises(InputError, match="^limit"):
        kinks((V, Q), limit=200)
    with pytest.raises(InputError, match="^axes"):
        nodes((V, Q), axes="up")
    with pytest.raises(InputError, match="^beam_height"):
        nodes((V, Q), beam_height=-1)
    with pytest.raises(MeshError, match="^roof.obj"):
        fabrication(V, Q[:, [0, 1, 1, 2]], name="roof.obj")


@pytest.mark.parametrize("scale, shift", [(1.0, 0.0), (1000.0, 0.0), (1.0, 5e6)])
def test_a_face_with_two_corners_at_one_point_is_refused_and_an_unwelded_joint_is_said(scale, shift):
    V, Q = translation_net(4)
    V = V * scale + shift
    # face 0 with a copy of its second corner inserted after it: a zero-length edge (the outline, the cutting list's
    # edges and angles would describe a pentagon that is not the panel; with the copy first, a panel of area 0)
    for pos in (0, 1):
        F = np.concatenate([Q, Q[:, -1:]], axis=1)
        F[0] = np.insert(Q[0], pos + 1, len(V))
        for call in (lambda m: panels(m), lambda m: panel_types(m), lambda m: kinks(m), lambda m: nodes(m),
                     lambda m: fabrication(*m)):
            with pytest.raises(MeshError, match=r"^mesh: face 0 .* zero-length edge: .*weld the two corners"):
                call((np.vstack([V, V[Q[0, pos]]]), F))
    # a panel with its own copy of a shared corner: the panels are exact, the joints there are missing and said
    F = Q.copy()
    F[1, 0] = len(V)
    Vu = np.vstack([V, V[Q[1, 0]]])
    assert np.allclose(panels((Vu, F)).areas, panels((V, Q)).areas, rtol=1e-12)
    for res in (kinks((Vu, F)), nodes((Vu, F)), fabrication(Vu, F)):
        assert any(w.startswith("1 vertex lies on another vertex (the mesh is not welded there)") and "weld" in w
                   for w in res.warnings)
    assert len(kinks((Vu, F)).kinks) < len(kinks((V, Q)).kinks)
    assert not any("welded" in w for w in kinks((V, Q)).warnings)


def test_network_strategy_result_has_torsion_free_interior_beams():
    V, T, _ = sample_mesh("dome", 20)
    res = curvature_pipeline((V, T), default_panel_size(V, 8))
    assert res.is_conical
    Vo, Fo = res.optimized[:2]
    out = nodes((Vo, Fo))
    interior = edge_topology(Fo).count == 2
    assert out.axis_method == "offset" and np.radians(out.torsion[interior]).max() <= 1e-9


def test_absurd_lengths_and_counts_are_typed_errors_before_any_work():
    # an audit's 500s: a length of 1e300 made coordinates no float holds, a billion levels a face count of 600
    # million digits, a billion cells an out-of-memory; each is now refused naming its input, in a millisecond
    import time

    from components.conical.cones import offset
    from components.network.tracing import curvature_network
    from components.subdivision.subdivide import catmull_clark
    from components.surfaces.generators import paraboloid

    V, Q = translation_net(4)
    cases = [
        (lambda: offset((V, Q), distance=1e300), "distance"),
        (lambda: nodes((V, Q), beam_height=1e300), "beam_height"),
        (lambda: panels((V, Q), gap=1e300), "gap"),
        (lambda: panels((V, Q), sheet_width=-1.0), "sheet_width"),
        (lambda: fabrication(V, Q, beam_width=1e300), "beam_width"),
        (lambda: catmull_clark((V, Q), levels=10**9), "levels"),
        (lambda: paraboloid(count_v=10**9), "count_v"),
        (lambda: curvature_network(sample_mesh("wave", 8)[:2], panel_size=1.0, radius=10**9), "radius"),
    ]
    for call, name in cases:
        t = time.perf_counter()
        with pytest.raises(InputError, match=f"^{name}: "):
            call()
        assert time.perf_counter() - t < 1.0, name
    assert len(offset((V, Q), distance=0.1).offset[0]) == len(V)  # a sensible length passes


def test_a_tolerance_near_the_panel_size_is_said():
    # an audit: Hops sends the document's tolerance (0.001) with tolerance 0; on a model of nanometre panels every
    # panel became one type without a word
    V, Q = translation_net(5)
    quiet = panel_types((V, Q), absolute_tolerance=0.001)
    assert quiet.type_count > 1 and not any("median edge" in w for w in quiet.warnings)
    tiny = panel_types((V * 1e-9, Q), absolute_tolerance=0.001)
    assert tiny.type_count == 1
    assert any(w.startswith("the document's absolute tolerance (tolerance 0) 0.001 is ") and "model's units" in w
               for w in tiny.warnings)
