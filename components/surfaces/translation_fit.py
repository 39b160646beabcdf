"""A translation surface fitted to a design surface: exact planar quads near a free-form shape.

The design surface (a triangle mesh) is seen as a height field over its mean plane (:func:`height_field_frame`).
Its height is fitted in the least-squares sense by ``g(u) + h(v)`` along two orthogonal plan directions
(:func:`additive_fit`, piecewise-linear ``g, h`` with light second-difference smoothing); the net
``P(i, j) = u_i a + v_j b + (g_i + h_j) up`` is a translation surface, so every face is a parallelogram and
exactly planar (:func:`translation_candidate`). This is the ``translation`` strategy of
:mod:`components.harness`.

References
----------
J. Glymph, D. Shelden, C. Ceccato, J. Mussel, H. Schober, "A parametric strategy for free-form glass structures
using quadrilateral planar facets", Automation in Construction 13(2), 2004.
H. Schober, "Geometrie-Prinzipien für wirtschaftliche und effiziente Schalentragwerke", Bautechnik 79(1), 2002.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from components.core.checks import check_number, validate_mesh
from components.core.errors import InputError
from components.core.mesh import boundary_loops, edge_topology, face_normals, points_in_polygons, remove_unreferenced

__all__ = [
    "AdditiveFit",
    "HeightFieldFrame",
    "additive_fit",
    "check_panel_size",
    "hat_matrix",
    "height_field_frame",
    "second_differences",
    "translation_candidate",
]

#: a panel size giving more panels than this across the surface is refused
MAX_PANELS_ACROSS = 400


class HeightFieldFrame(NamedTuple):
    """Origin, plan axes and up axis of a surface seen as a height field (see :func:`height_field_frame`)."""

    origin: np.ndarray  # (3,)
    e1: np.ndarray  # (3,) major plan axis
    e2: np.ndarray  # (3,) up × e1
    up: np.ndarray  # (3,) unit


class AdditiveFit(NamedTuple):
    """The least-squares fit ``z ≈ g(u) + h(v)`` of :func:`additive_fit`.

    ``g`` has values at the knots ``u0 + i·spacing`` (``i < nu``), ``h`` at ``v0 + j·spacing`` (``j < nv``);
    ``rms`` is the residual (units of ``z``).
    """

    u0: float
    v0: float
    nu: int
    nv: int
    g: np.ndarray  # (nu,)
    h: np.ndarray  # (nv,)
    rms: float


def height_field_frame(V: np.ndarray, T: np.ndarray) -> HeightFieldFrame:
    """Origin, plan axes ``e1, e2`` and up axis of a surface seen as a height field over its mean plane.

    Up is the area-weighted mean normal (the least-variance axis when the normals cancel, e.g. a closed mesh);
    ``e1`` is the major axis of the vertices projected on the plan; ``(e1, e2, up)`` is right-handed.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (t, 3) int64
        Triangles.

    Returns
    -------
    HeightFieldFrame

    Examples
    --------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 2, 4.0, 2.0)
    >>> f = height_field_frame(V, triangulate(Q)[0])
    >>> np.abs(f.up).round(6).tolist(), np.abs(f.e1).round(6).tolist()
    ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    """
    N = face_normals(V, T, unit=False)  # |N| = 2 · area
    total = np.linalg.norm(N, axis=1).sum()
    s = N.sum(axis=0)
    origin = V.mean(axis=0)
    if np.linalg.norm(s) > 0.3 * total:
        up = s / np.linalg.norm(s)
    else:
        _, _, W = np.linalg.svd(V - origin, full_matrices=False)
        up = W[2]
    P = V - origin
    P = P - np.outer(P @ up, up)
    _, _, W = np.linalg.svd(P, full_matrices=False)
    e1 = W[0] - (W[0] @ up) * up
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    return HeightFieldFrame(origin, e1, e2, up)


def hat_matrix(x: np.ndarray, knots0: float, spacing: float, nk: int) -> sp.csr_matrix:
    """Piecewise-linear interpolation matrix ``(len(x), nk)`` of values at the uniform knots ``knots0 + i·spacing``.

    Points outside the knot range take the end values.

    Examples
    --------
    >>> hat_matrix(np.array([0.0, 0.25, 1.0]), 0.0, 0.5, 3).toarray().round(9).tolist()
    [[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 1.0]]
    """
    t = np.clip((x - knots0) / spacing, 0.0, nk - 1 - 1e-12)
    i = np.floor(t).astype(np.int64)
    w = t - i
    rows = np.r_[np.arange(len(x)), np.arange(len(x))]
    return sp.csr_matrix((np.r_[1 - w, w], (rows, np.r_[i, i + 1])), shape=(len(x), nk))


def second_differences(nk: int) -> sp.csr_matrix:
    """The ``(nk - 2, nk)`` second-difference matrix (rows ``1, -2, 1``); empty for fewer than three knots.

    Examples
    --------
    >>> second_differences(4).toarray().tolist()
    [[1.0, -2.0, 1.0, 0.0], [0.0, 1.0, -2.0, 1.0]]
    """
    if nk < 3:
        return sp.csr_matrix((0, nk))
    return sp.diags([np.ones(nk - 2), -2 * np.ones(nk - 2), np.ones(nk - 2)], [0, 1, 2], shape=(nk - 2, nk))


def additive_fit(u: np.ndarray, v: np.ndarray, z: np.ndarray, spacing: float, smooth: float) -> AdditiveFit:
    """Least-squares ``z ≈ g(u) + h(v)`` with piecewise-linear ``g, h`` on knots ``spacing`` apart.

    The knot grids are centred on the data; ``smooth`` weighs the squared second differences of ``g`` and ``h``;
    the mean of ``h`` is 0 (``g + h`` is defined up to a constant shift between them).

    Parameters
    ----------
    u, v, z : (p,) float64
        Sample coordinates and values.
    spacing : float
        Knot spacing (units of ``u`` and ``v``).
    smooth : float
        Weight of the smoothing term.

    Returns
    -------
    AdditiveFit

    Examples
    --------
    >>> u, v = np.meshgrid(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    >>> fit = additive_fit(u.ravel(), v.ravel(), (u + 2 * v).ravel(), 0.5, 1e-6)
    >>> fit.nu, fit.nv, bool(fit.rms < 1e-9)
    (5, 3, True)
    """
    h = spacing
    u0, v0 = float(u.min()), float(v.min())
    nu = int(np.ceil((u.max() - u0) / h)) + 1
    nv = int(np.ceil((v.max() - v0) / h)) + 1
    # centre the knot grids on the data
    u0 -= 0.5 * ((nu - 1) * h - (u.max() - u0))
    v0 -= 0.5 * ((nv - 1) * h - (v.max() - v0))
    nu, nv = max(nu, 2), max(nv, 2)
    A = sp.hstack([hat_matrix(u, u0, h, nu), hat_matrix(v, v0, h, nv)]).tocsr()
    R = sp.block_diag([second_differences(nu), second_differences(nv)])
    gauge = sp.csr_matrix(np.r_[np.zeros(nu), np.ones(nv)][None, :])  # mean of h = 0 (g + h is ambiguous)
    M = (A.T @ A + smooth * (R.T @ R) + gauge.T @ gauge).toarray()
    c = np.linalg.solve(M, A.T @ z)
    resid = A @ c - z
    return AdditiveFit(u0, v0, nu, nv, c[:nu], c[nu:], float(np.sqrt(np.mean(resid * resid))))


def check_panel_size(panel_size, V: np.ndarray, name: str = "panel_size") -> float:
    """A panel size for a surface with vertices ``V``: a finite number > 0, at most the surface's extent and
    giving at most :data:`MAX_PANELS_ACROSS` panels across it.

    Raises
    ------
    InputError
        ``"panel_size: must be a finite number > 0, got …"``, or too large / too small for the surface.

    Examples
    --------
    >>> check_panel_size(2, np.array([[0.0, 0, 0], [10, 0, 0]]))
    2.0
    """
    h = check_number(panel_size, name, 0, above=True)
    ext = float(np.max(V.max(axis=0) - V.min(axis=0)))
    if h > ext:
        raise InputError(name, f"{h:g} is larger than the surface ({ext:g} across)")
    if ext / h > MAX_PANELS_ACROSS:
        raise InputError(name, f"{h:g} would make more than {MAX_PANELS_ACROSS} panels across the surface "
                               f"({ext:g})")
    return h


def _largest_component(F: np.ndarray) -> np.ndarray:
    """Indices of the faces of the largest edge-connected component."""
    m = len(F)
    if m == 0:
        return np.zeros(0, np.int64)
    EF = edge_topology(F).EF
    inner = EF[:, 1] >= 0
    A = sp.coo_matrix((np.ones(int(inner.sum())), (EF[inner, 0], EF[inner, 1])), shape=(m, m))
    ncomp, labels = connected_components(A, directed=False)
    if ncomp == 1:
        return np.arange(m)
    big = np.argmax(np.bincount(labels))
    return np.nonzero(labels == big)[0]


def translation_candidate(V, T, panel_size: float, angles: int = 18, name: str = "surface"):
    """A translation-surface quad mesh fitted to a design surface: planar quads by construction.

    The surface is seen as a height field ``z(x, y)`` over its mean plane. For plan directions ``a`` (swept over
    ``angles`` values in [0°, 90°)) and ``b ⟂ a``, the height is fitted in the least-squares sense by
    ``g(u) + h(v)`` with ``u = x·a, v = x·b`` and ``g, h`` piecewise linear on knots spaced ``panel_size``
    (lightly smoothed). The best direction is kept. The net ``P(i, j) = u_i a + v_j b + (g_i + h_j) up``
    is a translation surface (generatrix ``(u, g(u))`` moved along directrix ``(v, h(v))``): every face is a
    parallelogram, hence exactly planar. Faces whose plan centroid lies outside the surface's plan outline are
    dropped; the largest edge-connected piece is kept.

    Parameters
    ----------
    V : (n, 3) float64
        Design surface vertices.
    T : (t, 3) int64
        Design surface triangles.
    panel_size : float
        Grid spacing in plan (model units).
    angles : int
        Number of plan directions tried.
    name : str
        Name of the surface input in error messages.

    Returns
    -------
    V : (p, 3) float64
    Q : (q, 4) int64
        The trimmed translation net.
    info : dict
        ``angle`` (degrees, of ``a`` from the plan's major axis), ``rms`` (fit residual, model units),
        ``warnings``.

    Raises
    ------
    MeshError
        A malformed design surface (not a triangle mesh).
    InputError
        ``panel_size`` not a finite number > 0, larger than the surface or too small for it, or so large that
        no panel fits inside the outline.

    Notes
    -----
    A height field ``f`` is locally a translation surface along plan directions ``a, b`` exactly when
    ``f_ab = 0``, i.e. when ``a, b`` are conjugate for the Hessian: the sweep picks the orthogonal pair that is
    closest to conjugate on average (a hyperbolic paraboloid is matched exactly along its rulings' bisectors).
    Glymph et al. 2004; Schober 2002.

    Examples
    --------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.05 * (x - 4) ** 2 - 0.02 * (y - 4) ** 2)
    >>> Vt, Qt, info = translation_candidate(V, triangulate(Q)[0], 1.0)
    >>> Qt.shape[1], bool(info["rms"] < 0.05)
    (4, True)
    """
    V, T = validate_mesh(V, T, name=name, kind="tri")
    h = check_panel_size(panel_size, V)
    origin, e1, e2, up = height_field_frame(V, T)
    P = V - origin
    X = np.column_stack([P @ e1, P @ e2])
    z = P @ up
    warnings = []
    Nf = face_normals(V, T)
    if np.any(Nf @ up <= 0):
        warnings.append(f"{int(np.sum(Nf @ up <= 0))} triangles face away from the mean plane: the surface is not "
                        "a height field there and the translation fit ignores the overhang")
    ext = float(np.max(X.max(axis=0) - X.min(axis=0)))
    smooth = 1e-3 * len(z) / max(ext / h, 1.0)
    best = None
    for k in range(int(angles)):
        th = 0.5 * np.pi * k / int(angles)
        a = np.array([np.cos(th), np.sin(th)])
        b = np.array([-np.sin(th), np.cos(th)])
        fit = additive_fit(X @ a, X @ b, z, h, smooth)
        if best is None or fit.rms < best[1].rms - 1e-12:
            best = (th, fit, a, b)
    th, (u0, v0, nu, nv, g, hv, rms), a, b = best
    ui = u0 + h * np.arange(nu)
    vj = v0 + h * np.arange(nv)
    a3 = a[0] * e1 + a[1] * e2
    b3 = b[0] * e1 + b[1] * e2
    # vertex (i, j) at index j * nu + i
    Vn = (origin[None, None, :] + ui[None, :, None] * a3 + vj[:, None, None] * b3
          + (g[None, :] + hv[:, None])[..., None] * up).reshape(-1, 3)
    J, I = np.meshgrid(np.arange(nv - 1), np.arange(nu - 1), indexing="ij")
    Q = np.stack([J * nu + I, J * nu + I + 1, (J + 1) * nu + I + 1, (J + 1) * nu + I], axis=-1).reshape(-1, 4)
    # trim to the plan outline
    loops = boundary_loops(T, name=name)
    cu = (u0 + h * (I.ravel() + 0.5))[:, None] * a[None, :]
    cv = (v0 + h * (J.ravel() + 0.5))[:, None] * b[None, :]
    inside = points_in_polygons(cu + cv, [X[lp] for lp in loops]) if loops else np.ones(len(Q), bool)
    Q = Q[inside]
    if len(Q) == 0:
        raise InputError("panel_size", f"{h:g} is too large: no translation panel fits inside the surface outline")
    Q = Q[_largest_component(Q)]
    Vt, Qt, _ = remove_unreferenced(Vn, Q.astype(np.int64))
    # orient like the design surface
    if np.mean(face_normals(Vt, Qt) @ up) * np.mean(Nf @ up) < 0:
        Qt = Qt[:, ::-1].copy()
    return Vt, Qt, {"angle": float(np.degrees(th)), "rms": rms, "warnings": warnings}
