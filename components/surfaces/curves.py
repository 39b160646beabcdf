"""Curve evaluation and sampling: polylines and NURBS curves in Rhino's convention, pure numpy.

A curve value is either a polyline, an ``(n, 3) float64`` array of vertices, or a
:class:`components.core.types.NurbsCurve` ``(degree, points, weights, knots, periodic)`` whose knot vector follows
Rhino/openNURBS: ``n + degree - 1`` knots, without the two superfluous end knots of the textbook form, and the
domain ``[knots[degree - 1], knots[n - 1]]``. Periodic curves carry their ``degree`` wrapped control points,
as Rhino stores them, so they evaluate like any unclamped B-spline.

A polyline is handled as the degree-1 B-spline through its vertices with knots ``0, 1, …, n - 1``: its
parameter is Rhino's ``PolylineCurve`` parameter (vertex ``i`` at ``t = i``).

Sampling (:func:`sample_curve`) has three modes:

* ``"count"``: uniform in the curve parameter;
* ``"arclength"``: equal arc length, solved to ~1e-12 relative (adaptive Gauss-Legendre quadrature of the
  speed, then safeguarded Newton steps on the parameter);
* ``"control"``: the control points of a NURBS curve, the vertices (kinks) of a polyline.

:func:`equal_chord_points` divides a curve into segments whose chords all have the same length (the
"equal translation steps" of a translation surface).

References
----------
L. Piegl, W. Tiller, *The NURBS Book*, 2nd ed., Springer 1997: algorithms A2.1 (span), A2.2 (basis functions),
the derivative of a B-spline (§3.3) and rational curves (§4.3).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq
from scipy.sparse import csc_matrix
from scipy.sparse.linalg import spsolve

from components.core.checks import check_choice, check_int
from components.core.errors import InputError
from components.core.types import NurbsCurve

log = logging.getLogger(__name__)

SAMPLING_MODES = ("count", "arclength", "control")

# Gauss-Legendre rule used for arc lengths (exact for polynomials of degree 19)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)


# ----------------------------------------------------------------------------------------------
# B-spline basis (shared with surface evaluation)


def full_knots(knots: np.ndarray) -> np.ndarray:
    """Textbook knot vector (``n + degree + 1`` knots) from Rhino's (``n + degree - 1``).

    The two superfluous end knots never enter the evaluation on the domain; they are set to the
    neighbouring knot values.
    """
    k = np.asarray(knots, dtype=np.float64)
    return np.concatenate([k[:1], k, k[-1:]])


def find_spans(U: np.ndarray, degree: int, n: int, t: np.ndarray) -> np.ndarray:
    """Knot span index ``k`` (``degree <= k <= n - 1``, ``U[k] <= t < U[k + 1]``) of every parameter.

    Parameters
    ----------
    U : (n + degree + 1,) float64
        Full (textbook) knot vector.
    degree : int
        Degree ``d``.
    n : int
        Number of control points.
    t : (m,) float64
        Parameters; values at or beyond the domain end fall in the last span.

    Returns
    -------
    (m,) int64
    """
    k = np.searchsorted(U, t, side="right") - 1
    k = np.clip(k, degree, n - 1)
    # a parameter on the domain end: use the last non-empty span (Piegl & Tiller A2.1 special case)
    while True:
        empty = U[k + 1] <= U[k]
        if not empty.any():
            break
        k = np.where(empty, k - 1, k)
    return k.astype(np.int64)


def basis_functions(U: np.ndarray, degree: int, n: int, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-zero B-spline basis functions at many parameters (Piegl & Tiller A2.2, vectorized).

    Parameters
    ----------
    U : (n + degree + 1,) float64
        Full (textbook) knot vector (see :func:`full_knots`).
    degree : int
        Degree ``d >= 0``.
    n : int
        Number of control points.
    t : (m,) float64
        Parameters inside the domain ``[U[d], U[n]]``.

    Returns
    -------
    N : (m, d + 1) float64
        ``N[:, r]`` is the basis function of control point ``span - d + r``.
    span : (m,) int64
        Knot span of every parameter.

    Example
    -------
    >>> N, k = basis_functions(np.array([0., 0, 0, 1, 1, 1]), 2, 3, np.array([0.5]))
    >>> N
    array([[0.25, 0.5 , 0.25]])
    """
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    m = len(t)
    k = find_spans(U, degree, n, t)
    N = np.zeros((m, degree + 1))
    N[:, 0] = 1.0
    left = np.zeros((m, degree + 1))
    right = np.zeros((m, degree + 1))
    for j in range(1, degree + 1):
        left[:, j] = t - U[k + 1 - j]
        right[:, j] = U[k + j] - t
        saved = np.zeros(m)
        for r in range(j):
            temp = N[:, r] / (right[:, r + 1] + left[:, j - r])
            N[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        N[:, j] = saved
    return N, k


def _bspline_eval(U: np.ndarray, degree: int, C: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Evaluate a (non-rational, any dimension) B-spline with control points ``C`` (n, dim) at ``t``."""
    n = len(C)
    N, k = basis_functions(U, degree, n, t)
    idx = k[:, None] - degree + np.arange(degree + 1)[None, :]
    return np.einsum("mr,mrd->md", N, C[idx])


def _hodograph(U: np.ndarray, degree: int, C: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
    """Knots, degree and control points of the derivative B-spline (Piegl & Tiller eq. 3.8)."""
    den = U[degree + 1:degree + len(C)] - U[1:len(C)]
    dC = C[1:] - C[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        Q = np.where(den[:, None] > 0, degree * dC / np.where(den > 0, den, 1.0)[:, None], 0.0)
    return U[1:-1], degree - 1, Q


# ----------------------------------------------------------------------------------------------
# curve validation: everything becomes a (clean) NurbsCurve


class CurveData(NamedTuple):
    """A validated curve ready for evaluation (see :func:`as_curve`)."""

    degree: int
    U: np.ndarray  # (n + d + 1,) full knots
    Pw: np.ndarray  # (n, 4) homogeneous control points (x·w, y·w, z·w, w)
    points: np.ndarray  # (n, 3) control points (polyline vertices)
    domain: tuple  # (t0, t1)
    closed: bool
    polyline: bool
    periodic: bool
    dU: np.ndarray | None = None  # knots, degree and control points of the derivative (hodograph)
    dd: int = 0
    dQ: np.ndarray | None = None


def _finite_array(value, name: str, what: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"{what} are not numbers ({exc})") from None
    if not np.all(np.isfinite(a)):
        raise InputError(name, f"{what} contain NaN or infinite values")
    return a


def as_curve(curve, name: str = "curve") -> CurveData:
    """Validate a curve value (polyline array or :class:`NurbsCurve`) and prepare it for evaluation.

    Parameters
    ----------
    curve : (n, 3) array_like or NurbsCurve
        A polyline (``(n, 2)`` is accepted and lifted to z = 0) or a NURBS curve in Rhino's convention.
    name : str
        Name of the input, used in error messages.

    Returns
    -------
    CurveData
        Degree, full knot vector, homogeneous control points, domain and flags.

    Raises
    ------
    InputError
        Fewer than two points, NaN/inf, consecutive coincident polyline vertices, a zero-length curve,
        a bad degree, non-positive weights, or a knot vector of the wrong length or decreasing.
    """
    if isinstance(curve, NurbsCurve) or (hasattr(curve, "knots") and hasattr(curve, "degree")):
        try:
            degree = int(curve.degree)
        except (TypeError, ValueError):
            raise InputError(name, f"degree must be an integer, got {curve.degree!r}") from None
        P = _finite_array(curve.points, name, "control points")
        if P.ndim != 2 or P.shape[1] not in (2, 3):
            raise InputError(name, f"control points must have shape (n, 3), got {P.shape}")
        if P.shape[1] == 2:
            P = np.column_stack([P, np.zeros(len(P))])
        n = len(P)
        if n < 2:
            raise InputError(name, f"a curve needs at least 2 control points, got {n}")
        if degree < 1:
            raise InputError(name, f"degree must be at least 1, got {degree}")
        if n < degree + 1:
            raise InputError(name, f"a degree-{degree} curve needs at least {degree + 1} control points, got {n}")
        w = np.ones(n) if curve.weights is None else _finite_array(curve.weights, name, "weights").ravel()
        if len(w) != n:
            raise InputError(name, f"{len(w)} weights for {n} control points")
        if np.any(w <= 0):
            raise InputError(name, f"weight {int(np.argmax(w <= 0))} is not positive ({w[w <= 0][0]})")
        K = _finite_array(curve.knots, name, "knots").ravel()
        if len(K) != n + degree - 1:
            raise InputError(
                name, f"expected {n + degree - 1} knots (Rhino convention: points + degree - 1), got {len(K)}"
            )
        if np.any(np.diff(K) < 0):
            raise InputError(name, f"knots decrease at index {int(np.argmax(np.diff(K) < 0)) + 1}")
        U = full_knots(K)
        t0, t1 = float(U[degree]), float(U[n])
        if not t1 > t0:
            raise InputError(name, f"empty domain [{t0}, {t1}]")
        Pw = np.column_stack([P * w[:, None], w])
        periodic = bool(getattr(curve, "periodic", False))
        polyline = False
    else:
        P = _finite_array(curve, name, "polyline vertices")
        if P.ndim != 2 or P.shape[1] not in (2, 3):
            raise InputError(name, f"a polyline must have shape (n, 3), got {P.shape}")
        if P.shape[1] == 2:
            P = np.column_stack([P, np.zeros(len(P))])
        n = len(P)
        if n < 2:
            raise InputError(name, f"a curve needs at least 2 points, got {n}")
        seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
        size = float(np.max(np.linalg.norm(P - P[0], axis=1)))
        if size == 0.0:
            raise InputError(name, "all points coincide (zero-length curve)")
        tiny = seg <= 1e-12 * size
        if tiny.any():
            i = int(np.argmax(tiny))
            raise InputError(name, f"vertices {i} and {i + 1} coincide")
        degree = 1
        U = full_knots(np.arange(n, dtype=np.float64))
        t0, t1 = 0.0, float(n - 1)
        Pw = np.column_stack([P, np.ones(n)])
        periodic = False
        polyline = True
    size = float(np.max(np.linalg.norm(P - P[0], axis=1)))
    if size == 0.0:
        raise InputError(name, "all control points coincide (zero-length curve)")
    dU, dd, dQ = _hodograph(U, degree, Pw)
    data = CurveData(degree, U, Pw, P, (t0, t1), False, polyline, periodic, dU, dd, dQ)
    ends = _eval(data, np.array([t0, t1]))
    closed = periodic or bool(np.linalg.norm(ends[1] - ends[0]) <= 1e-10 * size)
    if polyline and closed and n < 4:
        raise InputError(name, f"a closed polyline needs at least 3 distinct vertices, got {n - 1}")
    return data._replace(closed=closed)


def _eval(c: CurveData, t: np.ndarray) -> np.ndarray:
    H = _bspline_eval(c.U, c.degree, c.Pw, np.atleast_1d(t))
    return H[:, :3] / H[:, 3:4]


def _eval_d1(c: CurveData, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and first derivatives (rational quotient rule)."""
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    H = _bspline_eval(c.U, c.degree, c.Pw, t)
    dH = _bspline_eval(c.dU, c.dd, c.dQ, t)
    w = H[:, 3:4]
    C = H[:, :3] / w
    D = (dH[:, :3] - dH[:, 3:4] * C) / w
    return C, D


# ----------------------------------------------------------------------------------------------
# public evaluation


def curve_domain(curve, name: str = "curve") -> tuple[float, float]:
    """Parameter domain ``(t0, t1)`` of a curve (polyline: ``(0, n - 1)``)."""
    return as_curve(curve, name).domain


def curve_points(curve, t, name: str = "curve") -> np.ndarray:
    """Points of a curve at parameters ``t``.

    Parameters
    ----------
    curve : (n, 3) array_like or NurbsCurve
        Polyline or NURBS curve (Rhino convention).
    t : (m,) array_like of float
        Parameters in the curve's domain (values outside are extrapolated from the end spans).
    name : str
        Input name for error messages.

    Returns
    -------
    (m, 3) float64

    Example
    -------
    >>> curve_points(np.array([[0., 0, 0], [2, 0, 0], [2, 2, 0]]), [0.5, 1.5])
    array([[1., 0., 0.],
           [2., 1., 0.]])
    """
    c = curve if isinstance(curve, CurveData) else as_curve(curve, name)
    return _eval(c, np.asarray(t, dtype=np.float64))


def curve_derivatives(curve, t, name: str = "curve") -> tuple[np.ndarray, np.ndarray]:
    """Points and first derivatives ``dC/dt`` of a curve at parameters ``t``.

    Returns
    -------
    C : (m, 3) float64
    D : (m, 3) float64
        Derivatives with respect to the curve parameter (for a polyline: the segment vector; at a vertex,
        the following segment's).
    """
    c = curve if isinstance(curve, CurveData) else as_curve(curve, name)
    return _eval_d1(c, np.asarray(t, dtype=np.float64))


def _breakpoints(c: CurveData) -> np.ndarray:
    t0, t1 = c.domain
    U = c.U
    inner = U[(U > t0) & (U < t1)]
    return np.unique(np.concatenate([[t0], inner, [t1]]))


def _gl_length(c: CurveData, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Gauss-Legendre arc length of each interval ``[a_i, b_i]``."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    half = 0.5 * (b - a)
    mid = 0.5 * (b + a)
    T = mid[:, None] + half[:, None] * _GL_X[None, :]
    _, D = _eval_d1(c, T.ravel())
    speed = np.linalg.norm(D, axis=1).reshape(T.shape)
    return half * (speed @ _GL_W)


class _LengthTable(NamedTuple):
    a: np.ndarray  # (p,) piece starts
    b: np.ndarray  # (p,) piece ends
    S: np.ndarray  # (p + 1,) cumulative length at piece boundaries


def _length_table(c: CurveData, rtol: float = 1e-14, max_rounds: int = 40) -> _LengthTable:
    """Adaptive Gauss-Legendre partition of the domain: pieces whose length is converged to ``rtol``."""
    bp = _breakpoints(c)
    # start with 4 pieces per knot span
    a = (bp[:-1, None] + (bp[1:] - bp[:-1])[:, None] * np.arange(4)[None, :] / 4).ravel()
    b = np.append(a[1:], bp[-1])
    done_a, done_b, done_L = [], [], []
    total_guess = float(np.sum(_gl_length(c, a, b)))
    for _ in range(max_rounds):
        if len(a) == 0:
            break
        m = 0.5 * (a + b)
        whole = _gl_length(c, a, b)
        halves = _gl_length(c, np.concatenate([a, m]), np.concatenate([m, b]))
        h1, h2 = halves[: len(a)], halves[len(a):]
        ok = np.abs(whole - (h1 + h2)) <= rtol * max(total_guess, 1e-300) + 1e-15 * (h1 + h2)
        done_a += [a[ok], m[ok]]
        done_b += [m[ok], b[ok]]
        done_L += [h1[ok], h2[ok]]
        a, b = np.concatenate([a[~ok], m[~ok]]), np.concatenate([m[~ok], b[~ok]])
    if len(a):  # not converged (a cusp): accept what we have
        log.debug("arc length quadrature did not converge on %d pieces", len(a))
        done_a.append(a)
        done_b.append(b)
        done_L.append(_gl_length(c, a, b))
    A = np.concatenate(done_a)
    B = np.concatenate(done_b)
    L = np.concatenate(done_L)
    order = np.argsort(A, kind="stable")
    A, B, L = A[order], B[order], L[order]
    return _LengthTable(A, B, np.concatenate([[0.0], np.cumsum(L)]))


def curve_length(curve, name: str = "curve") -> float:
    """Arc length of a curve (adaptive Gauss-Legendre quadrature, ~1e-14 relative).

    Example
    -------
    >>> round(curve_length(np.array([[0., 0, 0], [3, 4, 0]])), 12)
    5.0
    """
    c = curve if isinstance(curve, CurveData) else as_curve(curve, name)
    return float(_length_table(c).S[-1])


def _arclength_parameters(c: CurveData, s: np.ndarray, table: _LengthTable | None = None) -> np.ndarray:
    """Parameters at arc lengths ``s`` from the start (safeguarded Newton on each converged piece)."""
    tab = _length_table(c) if table is None else table
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, tab.S[-1])
    p = np.clip(np.searchsorted(tab.S, s, side="right") - 1, 0, len(tab.a) - 1)
    lo, hi = tab.a[p].copy(), tab.b[p].copy()
    target = s - tab.S[p]
    piece = tab.S[p + 1] - tab.S[p]
    frac = np.divide(target, piece, out=np.zeros_like(target), where=piece > 0)
    t = lo + frac * (hi - lo)
    tol = 1e-15 * max(tab.S[-1], 1e-300)
    for _ in range(60):
        f = _gl_length(c, tab.a[p], t) - target
        _, D = _eval_d1(c, t)
        speed = np.linalg.norm(D, axis=1)
        lo = np.where(f < 0, t, lo)
        hi = np.where(f > 0, t, hi)
        conv = np.abs(f) <= tol
        if conv.all():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            tn = t - f / speed
        bad = ~np.isfinite(tn) | (tn <= lo) | (tn >= hi)
        tn = np.where(bad, 0.5 * (lo + hi), tn)
        t = np.where(conv, t, tn)
    return t


# ----------------------------------------------------------------------------------------------
# sampling


class CurveSamples(NamedTuple):
    """Points sampled on a curve (see :func:`sample_curve`)."""

    points: np.ndarray  # (k, 3)
    parameters: np.ndarray  # (k,) curve parameters (Greville abscissae for NURBS control points)
    closed: bool  # True: the points form a closed loop; the last point is NOT repeated


def _greville(c: CurveData) -> np.ndarray:
    d = c.degree
    n = len(c.Pw)
    idx = np.arange(n)[:, None] + 1 + np.arange(d)[None, :]
    return c.U[idx].mean(axis=1)


def sample_curve(curve, count: int = 10, mode: str = "arclength", name: str = "curve") -> CurveSamples:
    """Sample a polyline or NURBS curve at a count, at equal arc length, or at its control points.

    Parameters
    ----------
    curve : (n, 3) array_like or NurbsCurve
        Polyline or NURBS curve (Rhino convention).
    count : int
        Number of segments (as Grasshopper's *Divide Curve*): ``count + 1`` points on an open curve, ``count``
        on a closed one (the start is not repeated). Ignored in ``"control"`` mode.
    mode : {"count", "arclength", "control"}
        Uniform curve parameter, equal arc length, or the control points (NURBS) / vertices (polyline).
    name : str
        Input name for error messages.

    Returns
    -------
    CurveSamples
        ``points`` (k, 3), ``parameters`` (k,), ``closed`` flag.

    Raises
    ------
    InputError
        Invalid curve (see :func:`as_curve`), ``count < 1``, an unknown mode, or two consecutive samples
        that coincide.

    Example
    -------
    >>> s = sample_curve(np.array([[0., 0, 0], [1, 0, 0], [1, 3, 0]]), 4, "arclength")
    >>> s.points[:, :2].round(12).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [1.0, 3.0]]
    """
    check_choice(mode, "sampling", SAMPLING_MODES)
    c = curve if isinstance(curve, CurveData) else as_curve(curve, name)
    t0, t1 = c.domain
    if mode == "control":
        P = c.points
        t = _greville(c) if not c.polyline else np.arange(len(P), dtype=np.float64)
        if c.closed:
            drop = c.degree if c.periodic else 1
            if not c.periodic and np.linalg.norm(P[-1] - P[0]) > 1e-10 * _size(P):
                drop = 0  # closed by its shape, not by repeated control points
            P, t = P[: len(P) - drop], t[: len(t) - drop]
        P = P.copy()
    else:
        count = check_int(count, "count", 1)
        k = count if c.closed else count + 1
        if mode == "count":
            t = t0 + (t1 - t0) * np.arange(k) / count
            t[-1] = t[-1] if c.closed else t1
        else:
            tab = _length_table(c)
            s = tab.S[-1] * np.arange(k) / count
            t = _arclength_parameters(c, s, tab)
            t[0] = t0
            if not c.closed:
                t[-1] = t1
        P = _eval(c, t)
    _check_distinct(P, c.closed, name)
    return CurveSamples(P, np.asarray(t, dtype=np.float64), c.closed)


def _size(P: np.ndarray) -> float:
    return float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))


def _check_distinct(P: np.ndarray, closed: bool, name: str) -> None:
    if len(P) < 2:
        raise InputError(name, f"sampling gave {len(P)} point(s); at least 2 are needed")
    Q = np.vstack([P, P[:1]]) if closed else P
    seg = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    tiny = seg <= 1e-12 * max(_size(P), 1e-300)
    if tiny.any():
        i = int(np.argmax(tiny))
        raise InputError(name, f"sample points {i} and {(i + 1) % len(P)} coincide")


# ----------------------------------------------------------------------------------------------
# equal chords


def _dense(c: CurveData, per_span: int = 16, minimum: int = 512) -> tuple[np.ndarray, np.ndarray]:
    bp = _breakpoints(c)
    per = max(per_span, int(np.ceil(minimum / (len(bp) - 1))))
    T = (bp[:-1, None] + (bp[1:] - bp[:-1])[:, None] * np.arange(per)[None, :] / per).ravel()
    T = np.append(T, bp[-1])
    return T, _eval(c, T)


def _next_at_chord(c, T, P, t_start, p_start, chord):
    """First parameter after ``t_start`` whose point is at distance ``chord`` from ``p_start`` (or None)."""
    D = np.linalg.norm(P - p_start, axis=1)
    cand = np.nonzero((T > t_start) & (D >= chord))[0]
    if len(cand) == 0:
        return None
    k = int(cand[0])
    lo = max(t_start, T[k - 1]) if k > 0 else t_start
    hi = T[k]
    # linear guess inside the bracket, then safeguarded Newton on |C(t) - p| = chord
    d_lo = D[k - 1] if k > 0 and T[k - 1] > t_start else 0.0
    t = lo + (hi - lo) * (chord - d_lo) / max(D[k] - d_lo, 1e-300)
    span = c.domain[1] - c.domain[0]
    for _ in range(100):
        C, Dv = _eval_d1(c, np.array([t]))
        r = C[0] - p_start
        dist = float(np.linalg.norm(r))
        f = dist - chord
        if abs(f) <= 1e-14 * chord:
            return t, C[0]
        if f < 0:
            lo = t
        else:
            hi = t
        fp = float(r @ Dv[0]) / dist if dist > 0 else 0.0
        tn = t - f / fp if fp != 0 else np.nan
        if not (np.isfinite(tn) and lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) <= 1e-16 * span:
            break
        t = tn
    return t, _eval(c, np.array([t]))[0]


def _march(c, T, P, chord, steps, t_end):
    """Place ``steps`` points at successive chords; return (params, residual of the closing chord)."""
    t = c.domain[0]
    p = P[0]
    ts = [t]
    end = _eval(c, np.array([t_end]))[0]
    for j in range(steps):
        nxt = _next_at_chord(c, T, P, t, p, chord)
        if nxt is None:
            # ran out of curve: a negative residual that keeps the function monotone and continuous
            return ts, float(np.linalg.norm(end - p)) - chord - (steps - j) * chord
        t, p = nxt
        ts.append(t)
    return ts, float(np.linalg.norm(end - p)) - chord


def _chords_equal(c: CurveData, t: np.ndarray, rtol: float = 1e-12) -> bool:
    if not np.all(np.diff(t) > 0):
        return False
    ch = np.linalg.norm(np.diff(_eval(c, t), axis=0), axis=1)
    return bool(np.ptp(ch) <= rtol * ch.mean())


def _equal_chords_newton(c: CurveData, t_init: np.ndarray, iterations: int = 60) -> np.ndarray | None:
    """Newton's method on ``|C(t_{k+1}) - C(t_k)| = chord`` (unknowns: inner parameters and the chord).

    Starts from equal arc length; returns the parameters (ends included) or None when it does not converge.
    """
    t = np.array(t_init, dtype=np.float64)
    n = len(t) - 1  # number of chords = number of unknowns (n - 1 inner parameters + chord)
    ch = float(np.mean(np.linalg.norm(np.diff(_eval(c, t), axis=0), axis=1)))
    rows = np.arange(n)

    def residual(tt, cc):
        return np.linalg.norm(np.diff(_eval(c, tt), axis=0), axis=1) - cc

    F = residual(t, ch)
    scale = float(np.max(np.abs(c.points)))
    for _ in range(iterations):
        if np.max(np.abs(F)) <= 1e-14 * ch + 1e-15 * scale:
            return t
        C, D = _eval_d1(c, t)
        R = np.diff(C, axis=0)
        U = R / np.linalg.norm(R, axis=1)[:, None]
        d_next = np.einsum("ij,ij->i", U, D[1:])  # dF_k / dt_{k+1}
        d_prev = -np.einsum("ij,ij->i", U, D[:-1])  # dF_k / dt_k
        r_ = np.concatenate([rows[:-1], rows[1:], rows])
        c_ = np.concatenate([rows[:-1], rows[1:] - 1, np.full(n, n - 1)])
        v_ = np.concatenate([d_next[:-1], d_prev[1:], -np.ones(n)])
        J = csc_matrix((v_, (r_, c_)), shape=(n, n))
        with np.errstate(all="ignore"):
            dx = spsolve(J, -F)
        if not np.all(np.isfinite(dx)):
            return None
        step, norm0 = 1.0, np.linalg.norm(F)
        while step > 1e-6:
            tn = t.copy()
            tn[1:-1] += step * dx[:-1]
            cn = ch + step * dx[-1]
            if cn > 0 and np.all(np.diff(tn) > 0):
                Fn = residual(tn, cn)
                if np.linalg.norm(Fn) < norm0:
                    break
            step *= 0.5
        else:  # no more progress: accept if already equal to well within the promise
            break
        t, ch, F = tn, cn, Fn
    return t if np.max(np.abs(F)) <= 1e-12 * ch else None


def _equal_chords_shooting(c: CurveData, count: int, length: float, scan: int = 64) -> np.ndarray | None:
    """Fallback: march at a trial chord and adjust it (Brent) until the closing chord matches.

    The closing-chord residual jumps where the "first point at distance c" switches branch (a curve that
    turns sharply), so the chord range is scanned and every sign change is tried, longest chords first,
    until one verifies (a jump is polished by Newton's method from the marched points).
    """
    t0, t1 = c.domain
    T, P = _dense(c)
    steps = count - 1
    hi = length / count * (1 + 1e-9)  # a chord is never longer than its arc

    def g(ch):
        return _march(c, T, P, ch, steps, t1)[1]

    grid = hi * np.linspace(1.0, 0.02, scan)
    vals = [g(x) for x in grid]
    for k in range(scan - 1):
        a, b = grid[k + 1], grid[k]  # a < b
        ga, gb = vals[k + 1], vals[k]
        if not (ga > 0 >= gb):
            continue
        chord = brentq(g, a, b, xtol=1e-15 * hi, rtol=1e-15, maxiter=200)
        ts, _ = _march(c, T, P, chord, steps, t1)
        if len(ts) != count:
            continue
        t = np.array(ts + [t1], dtype=np.float64)
        if _chords_equal(c, t):
            return t
        t = _equal_chords_newton(c, t)  # a jump, not a root: polish from there
        if t is not None and _chords_equal(c, t):
            return t
    return None


def equal_chord_points(curve, count: int = 10, name: str = "curve") -> CurveSamples:
    """Divide a curve into ``count`` segments whose chords all have the same length.

    Parameters
    ----------
    curve : (n, 3) array_like or NurbsCurve
        Polyline or NURBS curve (Rhino convention). On a closed curve the last chord returns to the start.
    count : int
        Number of chords (``count + 1`` points on an open curve, ``count`` on a closed one).
    name : str
        Input name for error messages.

    Returns
    -------
    CurveSamples
        Points (start and end of the curve included) whose consecutive distances agree to ~1e-13 relative.

    Raises
    ------
    InputError
        Invalid curve or count, or no equal-chord division exists (a curve that folds back on itself).

    Notes
    -----
    Newton's method on the ``count`` equations ``|C(t_{k+1}) - C(t_k)| = c`` (unknowns: the inner parameters
    and ``c``; a sparse bidiagonal-plus-column Jacobian), started from equal arc length and damped to keep the
    parameters increasing. If it fails (kinks of a polyline can stall it), a shooting method takes over: for a
    trial chord the points are placed one after another at the first curve point at distance ``c`` from the
    previous one, and Brent's method adjusts ``c`` until the closing chord has the same length. This gives
    translation surfaces with equal translation steps (Glymph et al. 2004).

    Example
    -------
    >>> s = equal_chord_points(np.array([[0., 0, 0], [4, 0, 0], [4, 3, 0]]), 2)
    >>> np.round(np.linalg.norm(np.diff(s.points, axis=0), axis=1), 12).tolist()
    [3.125, 3.125]
    """
    c = curve if isinstance(curve, CurveData) else as_curve(curve, name)
    count = check_int(count, "count", 1)
    t0, t1 = c.domain
    if count == 1 and not c.closed:
        P = _eval(c, np.array([t0, t1]))
        _check_distinct(P, False, name)
        return CurveSamples(P, np.array([t0, t1]), False)
    if c.closed and count < 3:
        raise InputError("count", f"a closed curve needs at least 3 chords, got {count}")
    tab = _length_table(c)
    t_arc = _arclength_parameters(c, tab.S[-1] * np.arange(count + 1) / count, tab)
    t_arc[0], t_arc[-1] = t0, t1
    t = _equal_chords_newton(c, t_arc)
    if t is None:
        t = _equal_chords_shooting(c, count, tab.S[-1])
    if t is None:
        raise InputError(name, f"no division into {count} equal chords was found (the curve folds back?)")
    if c.closed:
        t = t[:-1]
    pts = _eval(c, t)
    _check_distinct(pts, c.closed, name)
    return CurveSamples(pts, t, c.closed)
