"""A surface whose boundary passes close to itself (an unwelded seam, a slit, an opening near the edge): the strategies
say where and what to do (components.core.checks.boundary_gap_warning), the same in every unit and place."""
from __future__ import annotations

import numpy as np
import pytest

from components.core.checks import boundary_gap_warning
from components.core.mesh import quad_grid, triangulate
from components.fields.pipeline import pq_from_conjugate_field
from components.network.pipeline import pq_from_curvature_network
from components.subdivision.pipeline import pq_from_subdivision

PLACES = [(1.0, 0.0), (1000.0, 0.0), (1.0, 5e6)]


def _ring(turn: float, n: int = 40, m: int = 6):
    """A wavy ring band (radius 4, width 2) over ``turn`` × 2π: 1 closes it without welding (a seam of coincident
    vertices), just under 1 leaves a slit."""
    V, Q = quad_grid(n, m, 1.0, 1.0)
    w, u = 2 * np.pi * turn * V[:, 0], 2.0 * V[:, 1] - 1.0
    X = np.c_[(4 + u) * np.cos(w), (4 + u) * np.sin(w), 0.5 * np.sin(3 * w) * (1 + 0.3 * u)]
    return X, triangulate(Q)[0]


def _notched(kind: str):
    """A 4 × 4 square cut from the middle of one side to its centre: a 30° V-notch, or a straight slit 0.1 wide."""
    V, Q = quad_grid(40, 40, 4.0, 4.0)
    T = triangulate(Q)[0]
    c = V[T].mean(axis=1)
    if kind == "notch":
        cut = (c[:, 1] > 2.0) & (np.abs(c[:, 0] - 2.0) < (c[:, 1] - 2.0) * np.tan(np.radians(15.0)))
    else:
        cut = (c[:, 1] > 2.0) & (np.abs(c[:, 0] - 2.05) < 0.05)
    T = T[~cut]
    used = np.unique(T)
    new = np.full(len(V), -1)
    new[used] = np.arange(len(used))
    return V[used], new[T]


@pytest.mark.parametrize("scale, shift", PLACES)
def test_an_unwelded_seam_is_named_with_the_same_words_everywhere(scale, shift):
    V, T = _ring(1.0)
    text = boundary_gap_warning(V * scale + shift, T, 0.5 * scale)
    assert text == boundary_gap_warning(V, T, 0.5)
    assert text.startswith("the surface's boundary runs along itself: 7 pairs of boundary vertices at the same "
                           "positions (a seam that is not welded, e.g. vertices ")
    assert "weld it (Rhino: _Weld)" in text


@pytest.mark.parametrize("scale, shift", PLACES)
def test_a_slit_says_how_narrow_it_is_in_the_units_given(scale, shift):
    V, T = _ring(0.995)
    G = quad_grid(40, 6, 1.0, 1.0)[0]
    gap = float(np.linalg.norm(V[G[:, 0] == 0.0] - V[G[:, 0] == 1.0], axis=1).min())  # the slit's two sides
    text = boundary_gap_warning(V * scale + shift, T, 0.5 * scale)
    width = float(text.split("passes within ")[1].split(" of itself")[0])
    assert width == pytest.approx(gap * scale, rel=1e-3)
    assert f"({width / (0.5 * scale):.2g} × the panel size" in text and "widen the gap" in text
    assert boundary_gap_warning(V * scale + shift, T, 3.0 * gap * scale) is None  # wider than a quarter panel


def test_open_surfaces_and_blunt_notches_are_not_gaps():
    V, Q = quad_grid(10, 6, 5.0, 3.0, height=lambda x, y: 0.1 * x * y)
    assert boundary_gap_warning(V, Q, 0.5) is None
    assert boundary_gap_warning(*_notched("notch"), 1.0) is None  # a notch blunter than about 11°
    assert boundary_gap_warning(*_notched("slit"), 1.0).startswith("the surface's boundary passes within 0.1 of "
                                                                    "itself (0.1 × the panel size")


def test_the_strategies_say_it():
    V, T = _ring(1.0)
    net = pq_from_curvature_network((V, T), panel_size=0.8)
    assert net.warnings[0].startswith("the surface's boundary runs along itself")
    fld = pq_from_conjugate_field((V, T), 0.8, planarize=False)
    assert fld.warnings[0].startswith("the surface's boundary runs along itself")
    sub = pq_from_subdivision((V, T), faces=24, planarize=False)
    assert sub.warnings[0].startswith("the surface's boundary runs along itself")
