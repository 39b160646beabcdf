"""Issue #21 (planarize): a conjugate-field candidate whose design surface has a hole cut along its triangles (a
staircase boundary) is planarized as ``pq_from_conjugate_field`` does it (tolerance 1e-4, sliding boundary,
closeness weight 10) to the tolerance, healthy, the same at ×1 and ×1000. Before, the vertices by the hole slid
along the staircase itself, the projection back onto it carried them around its steps, and the guard refused every
step: "no step keeps the panels healthy (edge guard)" at 6e-2 (benchmarks/fields.py's ``patch(8000, seed=1)``, the
case of ``benchmarks/convergence.py --saved``)."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.measures import corner_angles, quad_planarity
from components.core.mesh import boundary_loops
from components.fields.candidate import candidate_mesh
from components.metrics.health import face_health
from components.planarize.planarizer import planarize_mesh
from components.planarize.problem import checked_options, setup_problem, smoothed_loops, staircase_loops

OPTIONS = dict(tolerance=1e-4, time_budget=60.0, boundary="slide", closeness_weight=10.0, mesh_name="candidate")


@pytest.fixture(scope="module")
def hole_case():
    """The surface (8076 triangles, a staircase hole) and its repaired candidate (632 faces)."""
    from benchmarks.fields import _mean_edge, patch

    V, T = patch(8000, seed=1)
    c = candidate_mesh((V, T), 2.5 * _mean_edge(V, T), repair=True)
    return V, T, c.V, c.F


def test_the_hole_is_a_staircase_and_its_vertices_are_pulled_not_slid(hole_case):
    V, T, CV, CF = hole_case
    loops = boundary_loops(T)
    stair = staircase_loops(V, loops)
    assert stair.tolist().count(True) == 1 and not stair[np.argmax([len(lp) for lp in loops])]  # the hole only
    prob = setup_problem(CV, CF, (V, T), checked_options(len(CV), boundary="slide", closeness_weight=10.0))
    assert len(prob.stair_idx) >= 5
    assert not (prob.slide[prob.stair_idx] | prob.fixed[prob.stair_idx]).any()  # free, pulled toward the curve
    hole = loops[int(np.nonzero(stair)[0][0])]
    # the vertices pulled toward the hole are the candidate's boundary vertices nearest to it
    d_hole = np.linalg.norm(CV[prob.stair_idx][:, None] - V[hole][None], axis=2).min(axis=1)
    assert d_hole.max() < np.linalg.norm(CV[prob.slide_idx][:, None] - V[hole][None], axis=2).min()
    # its smoothed curve has no step left: no vertex turns by 40° or more
    P = smoothed_loops((V - prob.center) / prob.scale, [hole])[hole]
    a, b = P - np.roll(P, 1, axis=0), np.roll(P, -1, axis=0) - P
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    assert cos.min() > np.cos(np.radians(40.0))


@pytest.mark.parametrize("scale", [1.0, 1000.0])
def test_a_candidate_by_a_staircase_hole_reaches_the_tolerance_healthy(hole_case, scale):
    V, T, CV, CF = hole_case
    assert quad_planarity(CV, CF).max() > 0.05  # far from planar: the old solver stopped at 6e-2
    res = planarize_mesh(CV * scale, CF, reference=(V * scale, T), **OPTIONS)
    assert res.converged and res.healthy, (res.stop_reason, res.violations)
    X = res.mesh[0]
    assert quad_planarity(X, CF).max() <= 1e-4
    h = face_health(X, CF, (V * scale, T), tolerance=1e-4)
    assert h.healthy, h.violations
    assert h.coverage >= 0.95
    worst_in = np.degrees(corner_angles(CV, CF).min())
    assert np.degrees(corner_angles(X, CF).min()) >= min(20.0, 0.9 * worst_in) - 1e-9
    assert res.iterations <= 60
    assert res.mean_closeness <= 0.05 * np.linalg.norm(CV[CF[:, 1]] - CV[CF[:, 0]], axis=1).mean() * scale
