"""Surfaces built from curves, and NURBS surfaces tessellated into triangle meshes.

* **Translation surfaces** (:func:`translation`): a generatrix curve translated along a directrix curve.
  The net ``P(i, j) = g_i + d_j - d_0`` has faces spanned by two pairs of parallel edges (parallelograms), so
  every face is planar by construction.
* **Scale-translation surfaces** (:func:`scale_translation`): after each translation step the section is
  scaled about a centre that travels along the directrix. Every face keeps two parallel edges (a trapezoid),
  so it is still planar.
* **Presets** (:func:`paraboloid`): the architecture classics, elliptic paraboloid (parabola along
  parabola) and hyperbolic paraboloid (parabola along an opposite parabola).
* **NURBS surface → triangle mesh** (:func:`surface_mesh`): tensor-product evaluation on a parameter grid.

The sample free-form surfaces used by tests, pipelines and the demo live in :mod:`components.surfaces.samples`.

References
----------
J. Glymph, D. Shelden, C. Ceccato, J. Mussel, H. Schober, "A parametric strategy for free-form glass structures
using quadrilateral planar facets", *Automation in Construction* 13(2):187-202, 2004.
H. Schober, "Geometrie-Prinzipien für wirtschaftliche und effiziente Schalentragwerke", *Bautechnik* 79(1), 2002.
L. Piegl, W. Tiller, *The NURBS Book*, 2nd ed., Springer 1997 (A3.5/A4.3, surface evaluation).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.surfaces.curves import (
    SAMPLING_MODES,
    CurveSamples,
    as_curve,
    basis_functions,
    equal_chord_points,
    full_knots,
    sample_curve,
)
from components.core.checks import MAX_LENGTH_RATIO, check_choice, check_int, check_number, check_points
from components.core.errors import InputError
from components.core.measures import quad_planarity
from components.core.mesh import face_normals
from components.core.types import Curve, Mesh, NurbsCurve, Numbers, Point, Points, Surface

log = logging.getLogger(__name__)

TRANSLATE_MODES = ("generatrix", "directrix")
PARABOLOID_KINDS = ("elliptic", "hyperbolic")

# a corner angle below this (between the two families) is reported as a near-degenerate panel
_SLIVER_SIN = np.sin(np.radians(1.0))


# ----------------------------------------------------------------------------------------------
# nets and their quality


def grid_quads(nu: int, nv: int, closed_u: bool = False, closed_v: bool = False) -> np.ndarray:
    """Quads of a ``nu × nv`` vertex net indexed ``j * nu + i`` (optionally wrapping in u and/or v).

    Parameters
    ----------
    nu, nv : int
        Number of vertices along u (index ``i``) and v (index ``j``).
    closed_u, closed_v : bool
        Connect the last column/row back to the first.

    Returns
    -------
    Q : (m, 4) int64
        Faces ``(i, j), (i+1, j), (i+1, j+1), (i, j+1)``, row by row; ``m = mu · mv`` with
        ``mu = nu if closed_u else nu - 1`` (likewise ``mv``).
    """
    iu = np.arange(nu if closed_u else nu - 1)
    jv = np.arange(nv if closed_v else nv - 1)
    J, I = np.meshgrid(jv, iu, indexing="ij")
    I1 = (I + 1) % nu
    J1 = (J + 1) % nv
    Q = np.stack([J * nu + I, J * nu + I1, J1 * nu + I1, J1 * nu + I], axis=-1).reshape(-1, 4)
    return Q.astype(np.int64)


def _check_faces(V: np.ndarray, Q: np.ndarray, nu: int, name: str) -> list[str]:
    """Raise on zero-area faces, warn on slivers (the two families almost parallel)."""
    area = np.linalg.norm(face_normals(V, Q, unit=False), axis=1)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    zero = area <= 1e-14 * diag * diag
    if zero.any():
        f = int(np.argmax(zero))
        j, i = divmod(int(Q[f, 0]), nu)
        raise InputError(
            name, f"face {f} (u segment {i}, v segment {j}) is degenerate: the curves are parallel there"
        )
    e1 = V[Q[:, 1]] - V[Q[:, 0]]
    e2 = V[Q[:, 3]] - V[Q[:, 0]]
    s = np.linalg.norm(np.cross(e1, e2), axis=1) / (np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1))
    thin = s < _SLIVER_SIN
    if thin.any():
        return [f"{int(thin.sum())} panel(s) have corner angles below 1° (generatrix and directrix nearly parallel)"]
    return []


def translation_net(
    G: np.ndarray,
    D: np.ndarray,
    closed_u: bool = False,
    closed_v: bool = False,
    translate: str = "generatrix",
) -> tuple[np.ndarray, np.ndarray]:
    """Quad net of a translation surface from sampled generatrix and directrix points.

    Parameters
    ----------
    G : (nu, 3) float64
        Generatrix points (index ``i``, the u direction).
    D : (nv, 3) float64
        Directrix points (index ``j``, the v direction).
    closed_u, closed_v : bool
        The generatrix / directrix points form a closed loop (faces wrap around).
    translate : {"generatrix", "directrix"}
        ``"generatrix"``: ``P(i, j) = g_i + d_j - d_0`` (the generatrix stays in place and is moved along the
        directrix); ``"directrix"``: ``P(i, j) = d_j + g_i - g_0``.

    Returns
    -------
    V : (nu · nv, 3) float64
        Vertex ``(i, j)`` at index ``j * nu + i``.
    Q : (m, 4) int64
        Parallelogram faces (see :func:`grid_quads`).

    Example
    -------
    >>> V, Q = translation_net(np.array([[0., 0, 0], [1, 0, 1], [2, 0, 0]]), np.array([[0., 0, 0], [0, 1, 0]]))
    >>> V.shape, Q.tolist()
    ((6, 3), [[0, 1, 4, 3], [1, 2, 5, 4]])
    """
    translate = check_choice(translate, "translate", TRANSLATE_MODES)
    G = np.asarray(G, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64)
    if translate == "generatrix":
        V = G[None, :, :] + (D - D[0])[:, None, :]
    else:
        V = (G - G[0])[None, :, :] + D[:, None, :]
    return V.reshape(-1, 3), grid_quads(len(G), len(D), closed_u, closed_v)


def scale_translation_net(
    G: np.ndarray,
    D: np.ndarray,
    scales: np.ndarray,
    centre: np.ndarray,
    closed_u: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quad net of a scale-translation surface: section ``j`` is ``c_j + S_j (g_i - c_0)``.

    Parameters
    ----------
    G : (nu, 3) float64
        Generatrix points (the first section).
    D : (nv, 3) float64
        Directrix points; the centre follows it: ``c_j = c_0 + d_j - d_0``.
    scales : (nv,) float64
        Cumulative scale ``S_j > 0`` of every section (``S_0`` is normally 1).
    centre : (3,) float64
        Scaling centre ``c_0`` of the first section.
    closed_u : bool
        The generatrix points form a closed loop.

    Returns
    -------
    V : (nu · nv, 3) float64
    Q : (m, 4) int64
        Trapezoid faces (the u edges of rows ``j`` and ``j + 1`` are parallel).
    C : (nv, 3) float64
        Centre of every section.
    """
    G = np.asarray(G, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64)
    S = np.asarray(scales, dtype=np.float64)
    c0 = np.asarray(centre, dtype=np.float64)
    C = c0[None, :] + (D - D[0])
    V = C[:, None, :] + S[:, None, None] * (G - c0)[None, :, :]
    return V.reshape(-1, 3), grid_quads(len(G), len(D), closed_u, False), C


# ----------------------------------------------------------------------------------------------
# published components: translation and scale-translation surfaces


class TranslationResult(NamedTuple):
    mesh: Mesh
    face_count: int
    max_planarity: float
    generatrix_points: Points
    directrix_points: Points
    warnings: list[str]


def _sample(curve, count: int, sampling: str, name: str, equal: bool) -> CurveSamples:
    if equal:
        return equal_chord_points(curve, count, name=name)
    return sample_curve(curve, count, sampling, name=name)


def translation(
    generatrix: Curve,
    directrix: Curve,
    count_u: int = 10,
    count_v: int = 10,
    sampling: str = "arclength",
    translate: str = "generatrix",
    equal_steps: bool = False,
) -> TranslationResult:
    """Planar-quad mesh of a translation surface: a generatrix curve translated along a directrix curve.

    Parameters
    ----------
    generatrix : Curve
        The profile curve (polyline or NURBS), sampled into the u direction of the net.
    directrix : Curve
        The path curve (polyline or NURBS), sampled into the v direction of the net.
    count_u : int
        Number of segments along the generatrix (ignored with ``sampling="control"``).
    count_v : int
        Number of segments along the directrix (ignored with ``sampling="control"``).
    sampling : str
        How both curves are sampled: ``"count"`` (uniform parameter), ``"arclength"`` (equal arc length) or
        ``"control"`` (control points of a NURBS curve, vertices of a polyline).
    translate : str
        Which curve is moved: ``"generatrix"`` (``P(i, j) = g_i + d_j - d_0``: the generatrix stays in place
        and travels along the directrix) or ``"directrix"`` (``P(i, j) = d_j + g_i - g_0``).
    equal_steps : bool
        Make the translation steps equal in length: the path curve (the directrix, or the generatrix with
        ``translate="directrix"``) is divided into equal chords, so every edge of that family has the same
        length (homogeneous panels); overrides ``sampling`` for the path curve.

    Returns
    -------
    mesh : Mesh
        Quad mesh ``(V, F)`` with planar parallelogram faces; vertex ``(i, j)`` at index ``j * nu + i``.
    face_count : int
        Number of faces (``count_u · count_v`` for open curves sampled by count or arc length).
    max_planarity : float
        Largest scale-free face planarity (diagonal distance / mean diagonal; ~1e-16 by construction).
    generatrix_points : Points
        The sampled generatrix points (closed curves: the start is not repeated).
    directrix_points : Points
        The sampled directrix points.

    Raises
    ------
    InputError
        A curve with fewer than two points, coincident points, NaN, counts below 1, an unknown ``sampling`` or
        ``translate`` value, or curves parallel somewhere (a zero-area face).

    Notes
    -----
    Each face ``P(i, j), P(i+1, j), P(i+1, j+1), P(i, j+1)`` has the edges ``g_{i+1} - g_i`` twice and
    ``d_{j+1} - d_j`` twice: a parallelogram, hence planar (Glymph et al. 2004, Schober 2002). Closed curves
    wrap around (a closed generatrix gives a tube). The planarity is exact up to floating-point rounding of
    the vertex sums.

    Example
    -------
    >>> g = np.array([[0., 0, 0], [1, 0, 1], [2, 0, 0]])
    >>> d = np.array([[0., 0, 0], [0, 1, 0.5], [0, 2, 0]])
    >>> r = translation(g, d, count_u=4, count_v=4)
    >>> r.face_count, r.max_planarity < 1e-12
    (16, True)
    """
    check_choice(sampling, "sampling", SAMPLING_MODES)
    check_choice(translate, "translate", TRANSLATE_MODES)
    cu, cv = grid_counts(count_u, count_v)
    g = as_curve(generatrix, "generatrix")
    d = as_curve(directrix, "directrix")
    sg = _sample(g, cu, sampling, "generatrix", equal_steps and translate == "directrix")
    sd = _sample(d, cv, sampling, "directrix", equal_steps and translate == "generatrix")
    V, Q = translation_net(sg.points, sd.points, sg.closed, sd.closed, translate)
    warnings = _check_faces(V, Q, len(sg.points), "directrix")
    plan = quad_planarity(V, Q)
    log.debug("translation surface: %d vertices, %d faces, max planarity %.3g", len(V), len(Q), plan.max())
    return TranslationResult((V, Q), int(len(Q)), float(plan.max()), sg.points, sd.points, warnings)


class ScaleTranslationResult(NamedTuple):
    mesh: Mesh
    face_count: int
    max_planarity: float
    scales: Numbers
    centres: Points
    warnings: list[str]


def _positive_numbers(value, name: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"values are not numbers ({exc})") from None
    if not np.all(np.isfinite(a)):
        raise InputError(name, "contains NaN or infinite values")
    if np.any(a <= 0):
        k = int(np.argmax(a <= 0))
        raise InputError(name, f"value {k} is {a[k]}; scale factors must be positive")
    return a


def scale_translation(
    generatrix: Curve,
    directrix: Curve,
    scale_factors: Numbers | None = None,
    scale: float = 1.0,
    centre: Point | None = None,
    count_u: int = 10,
    count_v: int = 10,
    sampling: str = "arclength",
) -> ScaleTranslationResult:
    """Planar-quad mesh of a scale-translation surface: a section translated along a directrix and scaled.

    Parameters
    ----------
    generatrix : Curve
        The first section (polyline or NURBS), sampled into the u direction of the net.
    directrix : Curve
        The path of the scaling centre (polyline or NURBS), sampled into the v direction.
    scale_factors : Numbers, optional
        One factor per translation step (``count_v`` of them for an open directrix sampled by count or arc
        length): section ``j + 1`` is section ``j`` scaled by ``scale_factors[j]``; overrides ``scale``.
    scale : float
        Uniform factor applied at every step when ``scale_factors`` is not given (1 gives a translation surface).
    centre : Point, optional
        Scaling centre of the first section; default: the centroid of the sampled generatrix points.
    count_u : int
        Number of segments along the generatrix (ignored with ``sampling="control"``).
    count_v : int
        Number of steps along the directrix (ignored with ``sampling="control"``).
    sampling : str
        How both curves are sampled: ``"count"``, ``"arclength"`` or ``"control"``.

    Returns
    -------
    mesh : Mesh
        Quad mesh ``(V, F)`` with planar trapezoid faces; vertex ``(i, j)`` at index ``j * nu + i``.
    face_count : int
        Number of faces.
    max_planarity : float
        Largest scale-free face planarity (~1e-16 by construction).
    scales : Numbers
        Cumulative scale ``S_j`` of every section (``S_0 = 1``).
    centres : Points
        Scaling centre of every section (the centre translated along the directrix).

    Raises
    ------
    InputError
        Degenerate curves, NaN, zero or negative scales, a wrong number of scale factors, counts below 1,
        an unknown ``sampling`` value, or a zero-area face.

    Notes
    -----
    Section ``j`` is ``c_j + S_j (g_i - c_0)`` with ``c_j = c_0 + d_j - d_0`` and ``S_j`` the product of the
    first ``j`` factors: each section is the previous one scaled about its centre (a centric expansion,
    Glymph et al. 2004) and translated with the directrix. The u edges of two consecutive sections,
    ``S_j (g_{i+1} - g_i)`` and ``S_{j+1} (g_{i+1} - g_i)``, are parallel (positive factors), so every face
    is a trapezoid and exactly planar. A closed directrix is traversed once and the seam is left open (the
    last section is a scaled copy of the first).

    Example
    -------
    >>> g = np.array([[-2., 0, 0], [0, 0, 1], [2, 0, 0]])
    >>> d = np.array([[0., 0, 0], [0, 5, 0]])
    >>> r = scale_translation(g, d, scale=0.9, count_u=4, count_v=5)
    >>> r.face_count, bool(r.max_planarity < 1e-12), round(float(r.scales[-1]), 5)
    (20, True, 0.59049)
    """
    check_choice(sampling, "sampling", SAMPLING_MODES)
    cu, cv = grid_counts(count_u, count_v)
    scale = check_number(scale, "scale", 0, above=True)
    g = as_curve(generatrix, "generatrix")
    d = as_curve(directrix, "directrix")
    sg = sample_curve(g, cu, sampling, name="generatrix")
    sd = sample_curve(d, cv, sampling, name="directrix")
    warnings = []
    D = sd.points
    if sd.closed:
        D = np.vstack([D, D[:1]])
        warnings.append("the directrix is closed: it is traversed once and the seam is left open")
    steps = len(D) - 1
    if scale_factors is not None:
        factors = _positive_numbers(scale_factors, "scale_factors")
        if len(factors) != steps:
            raise InputError("scale_factors", f"{len(factors)} factors given, the directrix sampling has {steps} steps")
        if scale != 1.0:
            warnings.append("scale is ignored because scale_factors are given")
    else:
        factors = np.full(steps, scale)
    S = np.concatenate([[1.0], np.cumprod(factors)])
    if not (np.isfinite(S).all() and S.max() <= MAX_LENGTH_RATIO and S.min() >= 1.0 / MAX_LENGTH_RATIO):
        raise InputError("scale_factors" if scale_factors is not None else "scale",
                         f"the sections would be scaled from 1 to {float(np.max(S)):.3g} (smallest "
                         f"{float(np.min(S)):.3g}) over {steps} steps: more than {MAX_LENGTH_RATIO:g} times apart; "
                         "use factors nearer 1 or fewer steps")
    if centre is None:
        c0 = sg.points.mean(axis=0)
    else:
        c0 = check_points(centre, "centre", allow_empty=False)
        if len(c0) != 1:
            raise InputError("centre", f"must be one point, got {len(c0)}")
        c0 = c0[0]
    V, Q, C = scale_translation_net(sg.points, D, S, c0, sg.closed)
    warnings += _check_faces(V, Q, len(sg.points), "directrix")
    plan = quad_planarity(V, Q)
    return ScaleTranslationResult((V, Q), int(len(Q)), float(plan.max()), S, C, warnings)


class ParaboloidResult(NamedTuple):
    mesh: Mesh
    face_count: int
    max_planarity: float
    generatrix: Curve
    directrix: Curve


def paraboloid(
    kind: str = "elliptic",
    span_u: float = 30.0,
    span_v: float = 20.0,
    rise_u: float = 4.0,
    rise_v: float = 3.0,
    count_u: int = 12,
    count_v: int = 8,
) -> ParaboloidResult:
    """Preset translation surface: elliptic or hyperbolic paraboloid (parabola along a parabola).

    Parameters
    ----------
    kind : str
        ``"elliptic"`` (parabola along a parabola of the same sense: a dome, K > 0) or ``"hyperbolic"``
        (parabola along an opposite parabola: a saddle, K < 0).
    span_u : float
        Span along x of the generatrix parabola, in model units.
    span_v : float
        Span along y of the directrix parabola, in model units.
    rise_u : float
        Rise of the generatrix parabola at mid-span (its ends are at z = 0).
    rise_v : float
        Rise of the directrix parabola at mid-span (a sag for ``"hyperbolic"``).
    count_u : int
        Number of panels along x.
    count_v : int
        Number of panels along y.

    Returns
    -------
    mesh : Mesh
        Quad mesh ``(V, F)`` over ``[-span_u/2, span_u/2] × [-span_v/2, span_v/2]`` with planar faces and a
        regular plan grid.
    face_count : int
        ``count_u · count_v``.
    max_planarity : float
        Largest scale-free face planarity (~1e-16).
    generatrix : Curve
        The generatrix parabola (a degree-2 NURBS curve in the plane y = -span_v/2).
    directrix : Curve
        The directrix parabola (a degree-2 NURBS curve in the plane x = -span_u/2).

    Raises
    ------
    InputError
        An unknown ``kind`` (the message lists the valid ones), non-positive spans, non-finite rises,
        counts below 1.

    Notes
    -----
    The surface is ``z = rise_u (1 - (2x/span_u)²) ± rise_v (1 - (2y/span_v)²)``, the classic translation
    shells of Schober (2002) and Glymph et al. (2004). Both parabolas are quadratic Béziers with evenly
    spaced control points, so uniform parameter sampling gives a uniform plan grid.

    Example
    -------
    >>> r = paraboloid("hyperbolic", 20.0, 10.0, 3.0, 2.0, 6, 4)
    >>> r.face_count, bool(r.max_planarity < 1e-12)
    (24, True)
    """
    check_choice(kind, "kind", PARABOLOID_KINDS)
    a = check_number(span_u, "span_u", 0, above=True)
    b = check_number(span_v, "span_v", 0, above=True)
    hu = check_number(rise_u, "rise_u")
    hv = check_number(rise_v, "rise_v")
    cu, cv = grid_counts(count_u, count_v)
    sign = 1.0 if kind == "elliptic" else -1.0
    knots = np.array([0.0, 0.0, 1.0, 1.0])
    G = NurbsCurve(
        2, np.array([[-a / 2, -b / 2, 0.0], [0.0, -b / 2, 2 * hu], [a / 2, -b / 2, 0.0]]), np.ones(3), knots.copy()
    )
    D = NurbsCurve(
        2, np.array([[-a / 2, -b / 2, 0.0], [-a / 2, 0.0, 2 * sign * hv], [-a / 2, b / 2, 0.0]]), np.ones(3),
        knots.copy(),
    )
    r = translation(G, D, cu, cv, sampling="count")
    return ParaboloidResult(r.mesh, r.face_count, r.max_planarity, G, D)


# ----------------------------------------------------------------------------------------------
# NURBS surfaces


class SurfaceData(NamedTuple):
    """A validated NURBS surface (see :func:`as_surface`)."""

    du: int
    dv: int
    Uu: np.ndarray  # full knots in u
    Uv: np.ndarray  # full knots in v
    Pw: np.ndarray  # (nu, nv, 4) homogeneous control points
    domain_u: tuple
    domain_v: tuple


def as_surface(surface, name: str = "surface") -> SurfaceData:
    """Validate a :class:`NurbsSurface` (Rhino convention) and prepare it for evaluation.

    Raises
    ------
    InputError
        Wrong shapes, NaN, non-positive weights, bad degrees, knot vectors of the wrong length or decreasing,
        an empty domain.
    """
    try:
        du, dv = int(surface.degree_u), int(surface.degree_v)
        P = np.asarray(surface.points, dtype=np.float64)
        w = np.ones(P.shape[:2]) if surface.weights is None else np.asarray(surface.weights, dtype=np.float64)
        Ku = np.asarray(surface.knots_u, dtype=np.float64).ravel()
        Kv = np.asarray(surface.knots_v, dtype=np.float64).ravel()
    except (AttributeError, TypeError, ValueError) as exc:
        raise InputError(name, f"not a NURBS surface ({exc})") from None
    if P.ndim != 3 or P.shape[2] != 3:
        raise InputError(name, f"control points must have shape (nu, nv, 3), got {P.shape}")
    nu, nv = P.shape[:2]
    if w.shape != (nu, nv):
        raise InputError(name, f"weights must have shape {(nu, nv)}, got {w.shape}")
    for arr, what in ((P, "control points"), (w, "weights"), (Ku, "knots_u"), (Kv, "knots_v")):
        if not np.all(np.isfinite(arr)):
            raise InputError(name, f"{what} contain NaN or infinite values")
    if np.any(w <= 0):
        raise InputError(name, "weights must be positive")
    for d, n, K, axis in ((du, nu, Ku, "u"), (dv, nv, Kv, "v")):
        if d < 1:
            raise InputError(name, f"degree in {axis} must be at least 1, got {d}")
        if n < d + 1:
            raise InputError(name, f"degree {d} in {axis} needs at least {d + 1} control points, got {n}")
        if len(K) != n + d - 1:
            raise InputError(name, f"expected {n + d - 1} knots in {axis} (points + degree - 1), got {len(K)}")
        if np.any(np.diff(K) < 0):
            raise InputError(name, f"knots in {axis} decrease")
    Uu, Uv = full_knots(Ku), full_knots(Kv)
    dom_u = (float(Uu[du]), float(Uu[nu]))
    dom_v = (float(Uv[dv]), float(Uv[nv]))
    if not (dom_u[1] > dom_u[0] and dom_v[1] > dom_v[0]):
        raise InputError(name, f"empty domain {dom_u} × {dom_v}")
    Pw = np.concatenate([P * w[..., None], w[..., None]], axis=2)
    return SurfaceData(du, dv, Uu, Uv, Pw, dom_u, dom_v)


def surface_points(surface, u, v, grid: bool = True, name: str = "surface") -> np.ndarray:
    """Evaluate a NURBS surface (Rhino convention) on a parameter grid or at parameter pairs.

    Parameters
    ----------
    surface : NurbsSurface
        The surface.
    u : (a,) array_like of float
        Parameters in the u domain.
    v : (b,) array_like of float
        Parameters in the v domain (with ``grid=False``: same length as ``u``).
    grid : bool
        True: evaluate the tensor grid, returning ``(a, b, 3)``; False: the pairs ``(u_k, v_k)``, ``(a, 3)``.
    name : str
        Input name for error messages.

    Returns
    -------
    (a, b, 3) or (a, 3) float64

    Notes
    -----
    Tensor-product de Boor evaluation of the homogeneous control net followed by the rational division
    (Piegl & Tiller A4.3); the grid form contracts u first, then v, so its cost is ``O(a·nv + a·b)``.
    """
    s = surface if isinstance(surface, SurfaceData) else as_surface(surface, name)
    u = np.atleast_1d(np.asarray(u, dtype=np.float64))
    v = np.atleast_1d(np.asarray(v, dtype=np.float64))
    nu, nv = s.Pw.shape[:2]
    Nu, ku = basis_functions(s.Uu, s.du, nu, u)
    Nv, kv = basis_functions(s.Uv, s.dv, nv, v)
    iu = ku[:, None] - s.du + np.arange(s.du + 1)[None, :]
    iv = kv[:, None] - s.dv + np.arange(s.dv + 1)[None, :]
    if grid:
        R = np.einsum("ar,arjd->ajd", Nu, s.Pw[iu])  # (a, nv, 4)
        H = np.einsum("bs,absd->abd", Nv, R[:, iv])  # (a, b, 4)
    else:
        if len(u) != len(v):
            raise InputError("v", f"{len(v)} v parameters for {len(u)} u parameters")
        Pk = s.Pw[iu[:, :, None], iv[:, None, :]]  # (a, du+1, dv+1, 4)
        H = np.einsum("ar,as,arsd->ad", Nu, Nv, Pk)
    return H[..., :3] / H[..., 3:4]


class SurfaceMeshResult(NamedTuple):
    mesh: Mesh
    segments_u: int
    segments_v: int
    uv: Points
    warnings: list[str]


_MAX_GRID_VERTICES = 4_000_000


def grid_counts(count_u, count_v) -> tuple[int, int]:
    """``count_u`` and ``count_v`` checked: whole numbers of at least 1 whose grid has at most
    :data:`_MAX_GRID_VERTICES` vertices (refused before any sampling, naming the larger count).

    >>> grid_counts(4, 5)
    (4, 5)
    """
    cu = check_int(count_u, "count_u", 1)
    cv = check_int(count_v, "count_v", 1)
    if (cu + 1) * (cv + 1) > _MAX_GRID_VERTICES:
        raise InputError("count_u" if cu >= cv else "count_v",
                         f"{cu} × {cv} cells make {(cu + 1) * (cv + 1):,} vertices, more than the limit of "
                         f"{_MAX_GRID_VERTICES:,}; use fewer cells")
    return cu, cv


def _weld(V: np.ndarray, tol: float) -> np.ndarray:
    """Map every point to the lowest-index point of its cluster of coincident points (within ``tol``)."""
    n = len(V)
    parent = np.arange(n)
    pairs = cKDTree(V).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return parent

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs.tolist():
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([root(i) for i in range(n)], dtype=np.int64)


def surface_mesh(
    surface: Surface,
    count_u: int = 20,
    count_v: int = 20,
    edge_length: float = 0.0,
) -> SurfaceMeshResult:
    """Triangle mesh of an untrimmed NURBS surface, its vertices evaluated exactly on the surface.

    Parameters
    ----------
    surface : Surface
        The NURBS surface (trims are ignored: the whole parameter rectangle is meshed).
    count_u : int
        Number of grid segments along u.
    count_v : int
        Number of grid segments along v.
    edge_length : float
        Target edge length in model units; when positive it overrides the counts, using the lengths of the
        surface's longest u and v iso-curves.

    Returns
    -------
    mesh : Mesh
        Triangle mesh ``(V, T)``: two triangles per grid cell split along the shorter diagonal; coincident
        grid points on the border of the parameter rectangle (a closed seam, a collapsed edge or pole) are
        welded and the collapsed triangles dropped.
    segments_u : int
        Number of grid segments used along u (``count_u``, or derived from ``edge_length``).
    segments_v : int
        Number of grid segments used along v.
    uv : Points
        Surface parameters ``(u, v, 0)`` of every vertex.

    Raises
    ------
    InputError
        An invalid surface (see :func:`as_surface`), counts below 1, a negative or NaN ``edge_length``, or
        a grid that would exceed 4 million vertices.

    Notes
    -----
    Points come from tensor-product de Boor evaluation of the rational control net (Piegl & Tiller 1997), so
    they lie on the surface to rounding (checked against rhino3dm's ``PointAt``). The grid is uniform in
    the parameters; for strongly non-uniform parametrizations prefer ``edge_length`` with a fine count.

    Example
    -------
    >>> from components.core.types import NurbsSurface
    >>> P = np.array([[[0., 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]])
    >>> s = NurbsSurface(1, 1, P, np.ones((2, 2)), np.array([0., 1]), np.array([0., 1]))
    >>> r = surface_mesh(s, 2, 2)
    >>> r.mesh[0].shape, r.mesh[1].shape
    ((9, 3), (8, 3))
    """
    s = as_surface(surface, "surface")
    h = check_number(edge_length, "edge_length", 0)
    warnings: list[str] = []
    if h > 0:
        nu_c, nv_c = s.Pw.shape[:2]
        a = max(33, 4 * nu_c + 1)
        b = max(33, 4 * nv_c + 1)
        G = surface_points(s, np.linspace(*s.domain_u, a), np.linspace(*s.domain_v, b))
        len_u = float(np.linalg.norm(np.diff(G, axis=0), axis=2).sum(axis=0).max())
        len_v = float(np.linalg.norm(np.diff(G, axis=1), axis=2).sum(axis=1).max())
        cu = max(1, int(np.ceil(len_u / h - 1e-9)))
        cv = max(1, int(np.ceil(len_v / h - 1e-9)))
        if (cu + 1) * (cv + 1) > _MAX_GRID_VERTICES:
            raise InputError(
                "edge_length", f"{h} is too small for a {len_u:.4g} × {len_v:.4g} surface ({cu} × {cv} cells)"
            )
    else:
        cu, cv = grid_counts(count_u, count_v)
    u = np.linspace(*s.domain_u, cu + 1)
    v = np.linspace(*s.domain_v, cv + 1)
    P = surface_points(s, u, v)  # (cu+1, cv+1, 3)
    # vertex (i, j) at index j * (cu + 1) + i, as the translation nets
    V = np.ascontiguousarray(P.transpose(1, 0, 2).reshape(-1, 3))
    UU, VV = np.meshgrid(u, v, indexing="xy")
    UV = np.column_stack([UU.ravel(), VV.ravel(), np.zeros(UU.size)])
    Q = grid_quads(cu + 1, cv + 1)
    a, b, c, d = Q.T
    diag_ac = np.linalg.norm(V[c] - V[a], axis=1)
    diag_bd = np.linalg.norm(V[d] - V[b], axis=1)
    split_ac = diag_ac <= diag_bd
    T = np.concatenate(
        [
            np.where(split_ac[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1)),
            np.where(split_ac[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1)),
        ]
    )
    T = T.reshape(2, -1, 3).transpose(1, 0, 2).reshape(-1, 3)  # the two triangles of a cell together
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    if size == 0:
        raise InputError("surface", "the surface collapses to a point")
    # seams and collapsed edges of an untrimmed surface lie on the border of the parameter grid: weld there
    # only (interior points that touch are a self-intersection, not a seam)
    border = np.zeros((cv + 1, cu + 1), dtype=bool)
    border[[0, -1], :] = True
    border[:, [0, -1]] = True
    border = np.nonzero(border.ravel())[0]
    rep = np.arange(len(V))
    rep[border] = border[_weld(V[border], 1e-12 * size)]
    welded = int(np.sum(rep != np.arange(len(V))))
    T = rep[T]
    keep = (T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    keep &= area > 1e-14 * size * size
    dropped = int(np.sum(~keep))
    T = T[keep]
    used = np.zeros(len(V), dtype=bool)
    used[T.ravel()] = True
    remap = np.cumsum(used) - 1
    V2, UV2, T2 = V[used], UV[used], remap[T].astype(np.int64)
    if welded:
        warnings.append(f"{welded} coincident grid points welded (closed seam or collapsed edge)")
    if dropped:
        log.debug("surface_mesh: dropped %d degenerate triangles", dropped)
    if len(T2) == 0:
        raise InputError("surface", "the surface is degenerate (no triangle of positive area)")
    return SurfaceMeshResult((V2, T2), cu, cv, UV2, warnings)
