"""Curve evaluation and sampling, checked against rhino3dm (the reference) and analytic cases."""
from __future__ import annotations

import doctest

import numpy as np
import pytest
from scipy.integrate import quad

from components.surfaces import curves
from components.surfaces.curves import (
    as_curve,
    curve_derivatives,
    curve_length,
    curve_points,
    equal_chord_points,
    sample_curve,
)
from components.core.errors import InputError
from components.core.types import NurbsCurve

rhino3dm = pytest.importorskip("rhino3dm")


# ----------------------------------------------------------------------------------------------
# helpers


def to_rhino(c: NurbsCurve):
    """The rhino3dm curve built from the same data (homogeneous control points, Rhino knots)."""
    P, w, K = np.asarray(c.points), np.asarray(c.weights), np.asarray(c.knots)
    rc = rhino3dm.NurbsCurve(3, bool(np.any(w != 1)), c.degree + 1, len(P))
    for i, (p, wi) in enumerate(zip(P.tolist(), w.tolist())):
        rc.Points[i] = rhino3dm.Point4d(p[0] * wi, p[1] * wi, p[2] * wi, wi)
    for i, k in enumerate(K.tolist()):
        rc.Knots[i] = k
    assert rc.IsValid
    return rc


def from_rhino(rc) -> NurbsCurve:
    H = np.array([[rc.Points[i].X, rc.Points[i].Y, rc.Points[i].Z, rc.Points[i].W] for i in range(len(rc.Points))])
    return NurbsCurve(rc.Degree, H[:, :3] / H[:, 3:], H[:, 3], np.array(rc.Knots.ToList()), bool(rc.IsPeriodic))


def random_nurbs(rng, degree, n, rational=True, domain=(0.0, 3.0), multiple=False):
    P = rng.normal(size=(n, 3)) * 5
    w = rng.uniform(0.5, 2.0, n) if rational else np.ones(n)
    inner = np.sort(rng.uniform(*domain, n - degree - 1))
    if multiple and len(inner) >= 2:
        inner[1] = inner[0]  # a double interior knot
    K = np.concatenate([np.full(degree, domain[0]), inner, np.full(degree, domain[1])])
    return NurbsCurve(degree, P, w, K)


def rhino_points(rc, t):
    return np.array([[q.X, q.Y, q.Z] for q in (rc.PointAt(float(x)) for x in t)])


def chords(points, closed=False):
    P = np.vstack([points, points[:1]]) if closed else points
    return np.linalg.norm(np.diff(P, axis=0), axis=1)


# ----------------------------------------------------------------------------------------------
# evaluation against rhino3dm


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("rational", [False, True])
def test_points_and_derivatives_match_rhino(degree, rational):
    rng = np.random.default_rng(10 * degree + rational)
    c = random_nurbs(rng, degree, 9, rational, multiple=degree >= 2)
    rc = to_rhino(c)
    t = np.linspace(0.0, 3.0, 157)
    C, D = curve_derivatives(c, t)
    scale = np.abs(c.points).max()
    assert np.abs(C - rhino_points(rc, t)).max() <= 1e-12 * scale
    # rhino3dm evaluates derivatives from the right at a knot; use parameters off the knots
    tt = t[~np.isin(t, c.knots)]
    _, D2 = curve_derivatives(c, tt)
    ref = np.array([[d[1].X, d[1].Y, d[1].Z] for d in (rc.DerivativeAt(float(x), 1) for x in tt)])
    assert np.abs(D2 - ref).max() <= 1e-9 * max(np.abs(ref).max(), 1.0)


def test_periodic_curve_matches_rhino():
    rng = np.random.default_rng(3)
    rc = rhino3dm.NurbsCurve.Create(True, 3, [rhino3dm.Point3d(*p) for p in (rng.normal(size=(7, 3)) * 4).tolist()])
    c = from_rhino(rc)
    assert c.periodic and len(c.points) == 10  # 7 points + 3 wrapped
    t = np.linspace(rc.Domain.T0, rc.Domain.T1, 101)
    assert np.abs(curve_points(c, t) - rhino_points(rc, t)).max() <= 1e-12 * 10
    cd = as_curve(c)
    assert cd.closed and cd.domain == (rc.Domain.T0, rc.Domain.T1)
    s = sample_curve(c, 12, "arclength")
    assert s.closed and len(s.points) == 12
    ctrl = sample_curve(c, mode="control")
    assert len(ctrl.points) == 7  # the wrapped control points are dropped


def test_rational_circle_length_and_arclength_samples():
    r = 3.0
    c = from_rhino(rhino3dm.NurbsCurve.CreateFromCircle(rhino3dm.Circle(rhino3dm.Point3d(1, 2, 0), r)))
    assert abs(curve_length(c) - 2 * np.pi * r) <= 1e-12 * 2 * np.pi * r
    for n in (3, 7, 40):
        s = sample_curve(c, n, "arclength")
        assert s.closed and len(s.points) == n
        assert np.abs(chords(s.points, True) - 2 * r * np.sin(np.pi / n)).max() <= 1e-12 * r
        assert np.abs(np.linalg.norm(s.points - [1, 2, 0], axis=1) - r).max() <= 1e-12 * r


def test_arclength_sampling_is_equal_arc_length():
    rng = np.random.default_rng(5)
    for degree in (2, 3, 5):
        c = random_nurbs(rng, degree, 8, rational=True)
        s = sample_curve(c, 17, "arclength")

        def speed(t):
            return float(np.linalg.norm(curve_derivatives(c, [t])[1]))

        breaks = np.unique(c.knots)
        arcs = []
        for a, b in zip(s.parameters[:-1], s.parameters[1:]):
            pts = breaks[(breaks > a) & (breaks < b)]
            arcs.append(quad(speed, a, b, points=pts if len(pts) else None, epsabs=0, epsrel=1e-13, limit=200)[0])
        arcs = np.array(arcs)
        assert np.ptp(arcs) <= 1e-9 * arcs.mean()
        assert abs(arcs.sum() - curve_length(c)) <= 1e-10 * arcs.sum()
        assert s.parameters[0] == 0.0 and s.parameters[-1] == 3.0


def test_count_sampling_is_uniform_in_parameter():
    rng = np.random.default_rng(6)
    c = random_nurbs(rng, 3, 7)
    s = sample_curve(c, 6, "count")
    assert np.allclose(s.parameters, np.linspace(0, 3, 7), atol=0, rtol=0)
    assert np.abs(s.points - rhino_points(to_rhino(c), s.parameters)).max() <= 1e-12 * 20


def test_control_sampling_gives_control_points_and_greville_parameters():
    rng = np.random.default_rng(7)
    c = random_nurbs(rng, 3, 6, rational=False)
    s = sample_curve(c, mode="control")
    assert np.array_equal(s.points, c.points)
    rc = to_rhino(c)
    assert np.allclose(s.parameters, [rc.GrevilleParameter(i) for i in range(6)], atol=1e-14)


# ----------------------------------------------------------------------------------------------
# polylines


def test_polyline_parameter_is_vertex_index():
    P = np.array([[0.0, 0, 0], [2, 0, 0], [2, 4, 0], [5, 4, 4]])
    assert np.allclose(curve_points(P, [0, 0.5, 1, 1.25, 3]), [[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [5, 4, 4]])
    assert curve_length(P) == pytest.approx(2 + 4 + 5, abs=1e-13)
    rc = rhino3dm.PolylineCurve([rhino3dm.Point3d(*p) for p in P.tolist()])
    t = np.linspace(0, 3, 31)
    assert np.abs(curve_points(P, t) - rhino_points(rc, t)).max() <= 1e-14


def test_polyline_sampling_modes():
    P = np.array([[0.0, 0, 0], [1, 0, 0], [1, 3, 0]])
    s = sample_curve(P, 4, "arclength")
    assert np.allclose(s.points, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 2, 0], [1, 3, 0]], atol=1e-13)
    s = sample_curve(P, 4, "count")
    assert np.allclose(s.points, [[0, 0, 0], [0.5, 0, 0], [1, 0, 0], [1, 1.5, 0], [1, 3, 0]], atol=1e-14)
    s = sample_curve(P, 99, "control")
    assert np.array_equal(s.points, P) and not s.closed


def test_closed_polyline_is_detected():
    square = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0]])
    s = sample_curve(square, 8, "arclength")
    assert s.closed and len(s.points) == 8
    assert np.allclose(chords(s.points, True), 0.5, atol=1e-13)
    assert len(sample_curve(square, mode="control").points) == 4


def test_two_dimensional_polyline_is_lifted():
    s = sample_curve(np.array([[0.0, 0], [3, 4]]), 5)
    assert s.points.shape == (6, 3) and np.all(s.points[:, 2] == 0)


# ----------------------------------------------------------------------------------------------
# equal chords


@pytest.mark.parametrize("count", [1, 2, 5, 23])
def test_equal_chords_open_nurbs(count):
    rng = np.random.default_rng(count)
    c = random_nurbs(rng, 3, 8)
    s = equal_chord_points(c, count)
    ch = chords(s.points)
    assert len(s.points) == count + 1
    assert np.ptp(ch) <= 1e-9 * ch.mean()
    ends = curve_points(c, [0.0, 3.0])
    assert np.allclose(s.points[[0, -1]], ends, atol=1e-13, rtol=0)
    assert np.all(np.diff(s.parameters) > 0)


def test_equal_chords_polyline_analytic():
    s = equal_chord_points(np.array([[0.0, 0, 0], [4, 0, 0], [4, 3, 0]]), 2)
    assert np.allclose(chords(s.points), 25 / 8, atol=1e-13)


def test_equal_chords_closed_curves():
    circle = from_rhino(rhino3dm.NurbsCurve.CreateFromCircle(rhino3dm.Circle(rhino3dm.Point3d(0, 0, 1), 2.0)))
    s = equal_chord_points(circle, 9)
    assert s.closed and len(s.points) == 9
    assert np.abs(chords(s.points, True) - 4 * np.sin(np.pi / 9)).max() <= 1e-12
    rng = np.random.default_rng(11)
    rc = rhino3dm.NurbsCurve.Create(True, 3, [rhino3dm.Point3d(*p) for p in (rng.normal(size=(6, 3)) * 5).tolist()])
    s = equal_chord_points(from_rhino(rc), 25)
    ch = chords(s.points, True)
    assert np.ptp(ch) <= 1e-9 * ch.mean()


# ----------------------------------------------------------------------------------------------
# typed errors


@pytest.mark.parametrize(
    "curve, fragment",
    [
        (np.array([[1.0, 2, 3]]), "at least 2"),
        (np.array([[0.0, 0, 0], [0, 0, 0], [1, 0, 0]]), "coincide"),
        (np.array([[0.0, 0, 0], [0, 0, 0]]), "coincide"),
        (np.array([[0.0, 0, 0], [np.nan, 0, 0]]), "NaN"),
        (np.array([[0.0, 0, 0], [np.inf, 0, 0]]), "NaN"),
        (np.zeros((3, 4)), "shape"),
        ("abc", "not numbers"),
        (NurbsCurve(3, np.zeros((4, 3)), np.ones(4), np.array([0, 0, 0, 1, 1, 1.0])), "coincide"),
        (NurbsCurve(3, np.eye(4, 3), np.ones(4), np.array([0, 0, 1, 1, 1.0])), "knots"),
        (NurbsCurve(3, np.eye(4, 3), np.ones(4), np.array([0, 0, 1, 0, 1, 1.0])), "decrease"),
        (NurbsCurve(3, np.eye(4, 3), np.array([1, 0, 1, 1.0]), np.array([0, 0, 0, 1, 1, 1.0])), "weight"),
        (NurbsCurve(3, np.eye(4, 3), np.array([1, np.nan, 1, 1.0]), np.array([0, 0, 0, 1, 1, 1.0])), "NaN"),
        (NurbsCurve(0, np.eye(4, 3), np.ones(4), np.array([0, 1, 2.0])), "degree"),
        (NurbsCurve(3, np.eye(3), np.ones(3), np.array([0, 0, 1, 1.0])), "control points"),
        (NurbsCurve(2, np.eye(3), np.ones(3), np.array([1.0, 1, 1, 1])), "domain"),
        (NurbsCurve(1, np.array([[1.0, 2, 3]]), np.ones(1), np.array([0.0])), "at least 2"),
    ],
)
def test_degenerate_curves_raise_named_input_error(curve, fragment):
    with pytest.raises(InputError, match=fragment) as info:
        sample_curve(curve, 4, name="generatrix")
    assert info.value.input_name == "generatrix"
    assert str(info.value).startswith("generatrix:")


def test_bad_count_and_mode():
    P = np.array([[0.0, 0, 0], [1, 0, 0]])
    for bad in (0, -3, 2.5, True):
        with pytest.raises(InputError, match="count"):
            sample_curve(P, bad)
    with pytest.raises(InputError, match="^sampling: must be one of 'count', 'arclength', 'control', got 'random'"):
        sample_curve(P, 3, "random")
    with pytest.raises(InputError, match="count"):
        equal_chord_points(P, 0)


def test_docstring_examples():
    assert doctest.testmod(curves, optionflags=doctest.NORMALIZE_WHITESPACE).failed == 0
