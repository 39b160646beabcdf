"""The strategies and the planarizer report their stages through components.core.progress (in-process)."""
from __future__ import annotations

import numpy as np
import pytest

from components.core import progress
from components.core.mesh import quad_grid
from components.fields.pipeline import pq_from_conjugate_field
from components.planarize.planarizer import planarize
from components.subdivision.pipeline import pq_from_subdivision
from components.surfaces.samples import sample_mesh


def _seen(fn):
    seen = []
    with progress.reporting(lambda f, s: seen.append((f, s))):
        result = fn()
    return seen, result


def _grid():
    return quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)


@pytest.mark.parametrize("run, stages", [
    (lambda: pq_from_conjugate_field(_grid(), target_length=2.0),
     ["candidate mesh", "candidate mesh: direction field", "planarize", "planarize: planarize, iteration 0",
      "panel health"]),
    (lambda: pq_from_subdivision(sample_mesh("dome", 12)[:2], faces=24, levels=1),
     ["coarse net, subdivision, pull", "planarize", "panel health"]),
])
def test_strategies_report_rising_progress_through_their_stages(run, stages):
    seen, _ = _seen(run)
    fractions = [f for f, _ in seen]
    names = [s for _, s in seen]
    assert fractions == sorted(fractions) and 0.0 <= fractions[0] and fractions[-1] < 1.0
    assert all(s in names for s in stages), names
    assert len(set(fractions)) >= 4


def test_planarizer_reports_its_iterations_as_owner():
    V, F = quad_grid(6, 6, 2.0, 2.0)
    V[:, 2] = 0.3 * (V[:, 0] - 1) * (V[:, 1] - 1)
    seen, res = _seen(lambda: planarize((V, F)))
    assert res.max_planarity <= 1e-4
    assert [s for _, s in seen][:2] == ["planarize, iteration 0", "planarize, iteration 1"]
    assert all(0.0 <= f < 1.0 for f, _ in seen)


def test_no_listener_no_effect_and_a_failing_listener_is_ignored():
    V, F = _grid()
    quiet = pq_from_conjugate_field((V, F), target_length=2.0)

    def broken(f, s):
        raise RuntimeError("listener bug")

    with progress.reporting(broken):
        loud = pq_from_conjugate_field((V, F), target_length=2.0)
    assert np.array_equal(quiet.planarized[0], loud.planarized[0])


def test_a_cancelling_listener_stops_the_computation():
    def cancel(f, s):
        if s.startswith("planarize"):
            raise progress.Cancelled()

    with pytest.raises(progress.Cancelled), progress.reporting(cancel):
        pq_from_conjugate_field(_grid(), target_length=2.0)
