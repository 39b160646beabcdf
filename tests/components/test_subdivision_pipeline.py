"""End-to-end subdivision strategy: candidate on the surface, planarized dome, typed errors before heavy work."""
from __future__ import annotations

import pytest

import components.subdivision.pipeline as pipeline_mod
from components.core.errors import InputError, MeshError
from components.core.mesh import bounding_box_diagonal, quad_grid, read_mesh
from components.core.proximity import TriangleIndex
from components.surfaces.samples import sample_mesh
from components.subdivision.pipeline import pq_from_subdivision
from components.subdivision.subdivide import face_count_after
from tests.conftest import data_file


def _surface(name):
    if name == "inspired":
        return read_mesh(data_file("inspired_mesh.obj"))
    V, T, _ = sample_mesh(name, 20)
    return V, T


@pytest.mark.parametrize("name", ["dome", "saddle", "wave", "canopy", "inspired"])
def test_candidate_on_surface(name):
    V, T = _surface(name)
    res = pq_from_subdivision((V, T), levels=2, planarize=False)
    X, Q = res.candidate
    diag = bounding_box_diagonal(V)
    assert TriangleIndex(V, T).query(X).distances.max() <= 1e-9 * diag
    assert res.candidate_max_distance <= 1e-9 * diag
    assert Q.shape[1] == 4 and len(Q) == face_count_after(res.coarse[1], 2)
    assert res.iterations == 0 and res.planarized[0] is X


@pytest.mark.parametrize("name", ["dome", "saddle", "wave", "canopy", "inspired"])
def test_reaches_planarity_and_closeness(name):
    # issue 8: max planarity <= 1e-4 on every sample and inspired_mesh; issue 16: and healthy (no collapsed, pinched
    # or folded panel, 85% of the surface covered). Keeping the edges and areas costs closeness: mean closeness
    # measured 0.2% (dome), 2.3% (saddle), 9.9% (wave), 6.7% (canopy), 7.3% (inspired) of the mean edge
    # (wave: coverage measured 82–100% for the same input at other scales or placements, so near the bound it may
    # miss it: then it is not converged and a warning says the coverage)
    V, T = _surface(name)
    res = pq_from_subdivision((V, T), levels=2)
    assert res.max_planarity <= 1e-4
    assert [v for v in res.violations if not v.startswith("coverage")] == []
    assert res.coverage >= (0.75 if name == "wave" else 0.85)
    assert res.converged == res.healthy == (res.coverage >= 0.85)
    if not res.converged:
        assert any(f"coverage {res.coverage:.0%}" in w for w in res.warnings)
    assert res.mean_closeness <= 0.15 * res.mean_edge
    assert res.nonconvex_faces == 0 and res.worst_corner_angle > 20
    assert res.max_planarity < res.candidate_max_planarity


def test_boundary_slides_on_the_surface_boundary():
    V, T = _surface("canopy")
    res = pq_from_subdivision((V, T), levels=2)
    from components.core.mesh import boundary_loops
    from components.core.proximity import PolylineIndex

    X, Q = res.planarized
    bv = boundary_loops(Q)[0]
    d = PolylineIndex(V[boundary_loops(T)[0]], closed=True).query(X[bv]).distances
    assert d.max() <= 1e-6 * bounding_box_diagonal(V)


def test_user_coarse_mesh(hypar_grid):
    V, Q = hypar_grid
    surface = (V, Q)
    coarse = quad_grid(3, 3, 2.0, 2.0)
    Vc = coarse[0].copy()
    Vc[:, :2] -= 1.0
    Vc[:, 2] = 0.5 * Vc[:, 0] * Vc[:, 1]
    res = pq_from_subdivision(surface, coarse=(Vc, coarse[1]), levels=2)
    assert len(res.candidate[1]) == 9 * 16
    assert res.coarse[0].shape == Vc.shape


@pytest.fixture
def no_heavy_work(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("heavy work started before the input checks")

    # the pipeline imports its steps at module level: patch the names it calls
    for step in ("coarse_net", "subdivided_mesh", "pulled_subdivision", "pulled_vertices", "planarize_mesh"):
        monkeypatch.setattr(pipeline_mod, step, boom)


def test_bad_input_before_heavy_work(no_heavy_work, nonmanifold_fan):
    V, T = _surface("dome")
    coarse = quad_grid(3, 3)
    with pytest.raises(InputError, match="levels"):
        pq_from_subdivision((V, T), levels=-1)
    with pytest.raises(InputError, match=r"^tolerance: must be a finite number > 0, got 0"):
        pq_from_subdivision((V, T), tolerance=0)  # was a ZeroDivisionError after the whole solve
    with pytest.raises(InputError, match="levels"):
        pq_from_subdivision((V, T), levels=1.5)
    with pytest.raises(InputError, match="levels"):
        pq_from_subdivision((V, T), levels=12)  # automatic net: 32·4¹² faces > 2 million
    with pytest.raises(InputError, match="max_faces"):
        pq_from_subdivision((V, T), coarse=coarse, levels=3, max_faces=100)
    with pytest.raises(InputError, match="levels"):
        pq_from_subdivision((V, T), coarse=coarse, levels=9)
    flipped = coarse[1].copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(MeshError, match="coarse"):
        pq_from_subdivision((V, T), coarse=(coarse[0], flipped))
    with pytest.raises(MeshError, match="coarse"):
        pq_from_subdivision((V, T), coarse=nonmanifold_fan)
    with pytest.raises(InputError, match="coarse"):
        pq_from_subdivision((V, T), coarse=coarse[0])
    with pytest.raises(MeshError, match="surface"):
        pq_from_subdivision(nonmanifold_fan, coarse=coarse)
    with pytest.raises(InputError, match="surface"):
        pq_from_subdivision(V)
    with pytest.raises(InputError, match="faces"):
        pq_from_subdivision((V, T), faces=0)
    G, Q = quad_grid(4, 4, 4.0, 4.0)  # a square with the middle quads cut out: two boundary loops
    with pytest.raises(InputError, match=r"^surface: must be a topological disk .* it has 2: fill its holes"):
        pq_from_subdivision((G, Q[[0, 1, 2, 3, 4, 7, 8, 11, 12, 13, 14, 15]]), faces=4)
    with pytest.raises(InputError, match="layout"):
        pq_from_subdivision((V, T), layout="spiral")


def test_a_degenerate_grid_net_is_not_an_error_about_the_users_mesh():
    """The grid layout of the DOS ``wein99_opt_del2bdry`` surface has a zero-area panel. The automatic layout used to
    fail with "coarse: face 15 is degenerate" (a mesh the user never gave); it now leaves the grid out, and asking
    for the grid says to use another layout."""
    from components.core.mesh import triangulate
    from components.subdivision.coarse import coarse_net

    V, F = read_mesh(data_file("obj_snet__wein99_opt_del2bdry.obj"))
    T = triangulate(F)[0]
    net = coarse_net(V, T)
    assert net.layout in ("aligned", "ogrid") and len(net.Q) > 0
    with pytest.raises(InputError) as err:
        coarse_net(V, T, layout="grid")
    assert err.value.input_name == "layout" and "use 'ogrid' or 'aligned'" in str(err.value)
