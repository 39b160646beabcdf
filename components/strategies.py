"""The planar-quad (PQ) meshing strategies of the paper, as a registry of runners with one uniform result.

Every runner takes a design surface as a triangle mesh ``(V, T)`` and a target panel size (edge length, model
units) and returns a *candidate* quad mesh (what the strategy builds before any optimization) and, where the
strategy has an optimization step, the *optimized* mesh. :func:`run_strategy` wraps a runner with timings, the
full metric table of :func:`components.metrics.metrics_report` before and after (closeness measured against the
design surface) and the caveats; :func:`run_strategies` runs a list of them. A strategy whose component has not
been written yet is reported as ``status="not available"`` with the missing piece named, never faked; a strategy
that raises is reported as ``status="failed"`` with the error message.

=====================  ==========================================================================================
strategy               steps
=====================  ==========================================================================================
``translation``        exact PQ: a translation surface ``g(u) + h(v)`` fitted to the design surface (see
                       :func:`translation_candidate`); planar by construction, no optimization.
``conjugate_field``    conjugate direction field → quad extraction → planarization
                       (``components.pipelines.pq_from_conjugate_field``).
``curvature_network``  curvature-line network → conformal map → quad rebuild → conical optimization
                       (``pq_from_curvature_network``).
``subdivision``        coarse quad net on a square parametrization → Catmull-Clark → pull onto the surface →
                       planarization (:func:`subdivision_candidate`, :func:`components.planarize.planarize_mesh`).
=====================  ==========================================================================================

References
----------
Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang, "Geometric modeling with conical meshes and developable
surfaces", ACM Trans. Graph. 25(3), 2006 (subdivision + planarization, conical meshes).
J. Glymph, D. Shelden, C. Ceccato, J. Mussel, H. Schober, "A parametric strategy for free-form glass structures
using quadrilateral planar facets", Automation in Construction 13(2), 2004 (translation surfaces).
A. Vaxman et al., "Directional field synthesis, design, and processing", 2016; Liu, Xu, Wang, Wang, "Conjugate
direction fields for remeshing", 2011 (conjugate fields).
"""
from __future__ import annotations

import importlib
import inspect
import logging
import time
from typing import Callable, NamedTuple

import numpy as np
import scipy.sparse as sp

from components.mesh import (
    InputError,
    MeshError,
    boundary_loops,
    edge_topology,
    face_normals,
    remove_unreferenced,
    triangulate,
    validate_mesh,
)

log = logging.getLogger(__name__)

__all__ = [
    "STRATEGIES",
    "Strategy",
    "StrategyResult",
    "Candidate",
    "strategy_names",
    "get_strategy",
    "run_strategy",
    "run_strategies",
    "translation_candidate",
    "subdivision_candidate",
    "default_panel_size",
]

STATUS_OK = "ok"
STATUS_NOT_AVAILABLE = "not available"
STATUS_FAILED = "failed"


class StrategyResult(NamedTuple):
    """One strategy run on one design surface.

    Attributes
    ----------
    name : str
        Strategy key (e.g. ``"translation"``).
    surface : str
        Name of the design surface.
    status : str
        ``"ok"``, ``"not available"`` (the strategy's component does not exist yet) or ``"failed"``.
    candidate : (V, F) tuple or None
        The quad mesh the strategy builds before optimization.
    optimized : (V, F) tuple or None
        The optimized mesh (same faces as the candidate), or None when the strategy has no optimization step.
    timings : dict of str -> float
        Wall-clock seconds per step, plus ``"total"``.
    metrics_before, metrics_after : dict of str -> float, or None
        :func:`components.metrics.metrics_report` of the candidate / the optimized mesh, closeness against the
        design surface.
    warnings : list of str
        Non-fatal caveats of the steps.
    detail : str
        Why the strategy is not available or failed; a one-line description of what ran otherwise.
    panel_size : float
        The requested panel size (model units).
    """

    name: str
    surface: str
    status: str
    candidate: tuple | None
    optimized: tuple | None
    timings: dict
    metrics_before: dict | None
    metrics_after: dict | None
    warnings: list
    detail: str
    panel_size: float

    @property
    def final(self) -> tuple | None:
        """The optimized mesh when there is one, else the candidate."""
        return self.optimized if self.optimized is not None else self.candidate


class Candidate(NamedTuple):
    """What a runner returns: candidate and optimized meshes, step timings, warnings, a one-line description."""

    candidate: tuple
    optimized: tuple | None
    timings: dict
    warnings: list
    detail: str


class Strategy(NamedTuple):
    """A registered strategy: key, title, what it does, its runner and an availability check.

    ``runner(V, T, panel_size, time_budget=...) -> Candidate``; ``missing()`` returns None when the runner can run,
    else a sentence naming the missing component.
    """

    name: str
    title: str
    description: str
    runner: Callable
    missing: Callable[[], str | None]


# ----------------------------------------------------------------------------------------------
# shared helpers


def _frame(V: np.ndarray, T: np.ndarray):
    """Origin, plan axes ``e1, e2`` and up axis of a surface seen as a height field over its mean plane.

    Up is the area-weighted mean normal (the least-variance axis when the normals cancel, e.g. a closed mesh);
    ``e1`` is the major axis of the vertices projected on the plan.
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
    return origin, e1, e2, up


def _inside(P: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """Even-odd point-in-polygon of plan points ``P (p, 2)`` against several closed polygons (holes work)."""
    inside = np.zeros(len(P), dtype=bool)
    x, y = P[:, 0][:, None], P[:, 1][:, None]
    for poly in loops:
        a, b = poly, np.roll(poly, -1, axis=0)
        for s in range(0, len(a), 512):
            a0, b0 = a[s:s + 512], b[s:s + 512]
            cond = (a0[None, :, 1] > y) != (b0[None, :, 1] > y)
            dy = b0[None, :, 1] - a0[None, :, 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = a0[None, :, 0] + (y - a0[None, :, 1]) * (b0[None, :, 0] - a0[None, :, 0]) / dy
            inside ^= (np.count_nonzero(cond & (x < xc), axis=1) % 2).astype(bool)
    return inside


def _largest_component(F: np.ndarray) -> np.ndarray:
    """Indices of the faces of the largest edge-connected component."""
    from scipy.sparse.csgraph import connected_components

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


def default_panel_size(V, divisions: int = 16) -> float:
    """A panel size giving about ``divisions`` panels across the larger plan extent of a surface."""
    V = np.asarray(V, dtype=np.float64)
    ext = np.sort(V.max(axis=0) - V.min(axis=0))
    return float(ext[-1] / max(int(divisions), 1))


def _check_panel_size(panel_size, V) -> float:
    try:
        h = float(panel_size)
    except (TypeError, ValueError):
        raise InputError("panel_size", f"must be a number, got {panel_size!r}") from None
    if not np.isfinite(h) or h <= 0:
        raise InputError("panel_size", f"must be positive and finite, got {panel_size!r}")
    ext = float(np.max(V.max(axis=0) - V.min(axis=0)))
    if h > ext:
        raise InputError("panel_size", f"{h:g} is larger than the surface ({ext:g} across)")
    if ext / h > 400:
        raise InputError("panel_size", f"{h:g} would make more than 400 panels across the surface ({ext:g})")
    return h


# ----------------------------------------------------------------------------------------------
# strategy 1: translation surface fitted to the design surface


def _hat_matrix(x: np.ndarray, knots0: float, h: float, nk: int) -> sp.csr_matrix:
    """Piecewise-linear interpolation matrix of values at ``nk`` uniform knots ``knots0 + i h``."""
    t = np.clip((x - knots0) / h, 0.0, nk - 1 - 1e-12)
    i = np.floor(t).astype(np.int64)
    w = t - i
    rows = np.r_[np.arange(len(x)), np.arange(len(x))]
    return sp.csr_matrix((np.r_[1 - w, w], (rows, np.r_[i, i + 1])), shape=(len(x), nk))


def _second_differences(nk: int) -> sp.csr_matrix:
    if nk < 3:
        return sp.csr_matrix((0, nk))
    return sp.diags([np.ones(nk - 2), -2 * np.ones(nk - 2), np.ones(nk - 2)], [0, 1, 2], shape=(nk - 2, nk))


def _fit_additive(u, v, z, h, smooth):
    """Least-squares ``z ≈ g(u) + h(v)`` with piecewise-linear g, h on knots spaced ``h``; returns the fit."""
    u0, v0 = float(u.min()), float(v.min())
    nu = int(np.ceil((u.max() - u0) / h)) + 1
    nv = int(np.ceil((v.max() - v0) / h)) + 1
    # centre the knot grids on the data
    u0 -= 0.5 * ((nu - 1) * h - (u.max() - u0))
    v0 -= 0.5 * ((nv - 1) * h - (v.max() - v0))
    nu, nv = max(nu, 2), max(nv, 2)
    A = sp.hstack([_hat_matrix(u, u0, h, nu), _hat_matrix(v, v0, h, nv)]).tocsr()
    R = sp.block_diag([_second_differences(nu), _second_differences(nv)])
    gauge = sp.csr_matrix(np.r_[np.zeros(nu), np.ones(nv)][None, :])  # mean of h = 0 (g + h is ambiguous)
    M = (A.T @ A + smooth * (R.T @ R) + gauge.T @ gauge).toarray()
    c = np.linalg.solve(M, A.T @ z)
    resid = A @ c - z
    return u0, v0, nu, nv, c[:nu], c[nu:], float(np.sqrt(np.mean(resid * resid)))


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

    Notes
    -----
    A height field ``f`` is locally a translation surface along plan directions ``a, b`` exactly when
    ``f_ab = 0``, i.e. when ``a, b`` are conjugate for the Hessian: the sweep picks the orthogonal pair that is
    closest to conjugate on average (a hyperbolic paraboloid is matched exactly along its rulings' bisectors).
    Glymph et al. 2004; Schober 2002.
    """
    V, T = validate_mesh(V, T, name=name, kind="triangle")
    h = _check_panel_size(panel_size, V)
    origin, e1, e2, up = _frame(V, T)
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
        fit = _fit_additive(X @ a, X @ b, z, h, smooth)
        if best is None or fit[-1] < best[1][-1] - 1e-12:
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
    inside = _inside(cu + cv, [X[lp] for lp in loops]) if loops else np.ones(len(Q), bool)
    Q = Q[inside]
    if len(Q) == 0:
        raise InputError("panel_size", f"{h:g} is too large: no translation panel fits inside the surface outline")
    Q = Q[_largest_component(Q)]
    Vt, Qt, _ = remove_unreferenced(Vn, Q.astype(np.int64))
    # orient like the design surface
    if np.mean(face_normals(Vt, Qt) @ up) * np.mean(Nf @ up) < 0:
        Qt = Qt[:, ::-1].copy()
    return Vt, Qt, {"angle": float(np.degrees(th)), "rms": rms, "warnings": warnings}


def _run_translation(V, T, panel_size, time_budget=30.0):
    t0 = time.perf_counter()
    Vt, Qt, info = translation_candidate(V, T, panel_size)
    t1 = time.perf_counter()
    detail = (f"translation surface g(u)+h(v) fitted at {info['angle']:.0f}° to the plan's major axis "
              f"(height RMS {info['rms']:.3g}); exact PQ, no optimization")
    return Candidate((Vt, Qt), None, {"candidate": t1 - t0}, list(info["warnings"]), detail)


# ----------------------------------------------------------------------------------------------
# strategy 4: coarse net -> Catmull-Clark -> pull -> planarize


def _locate(UV: np.ndarray, T: np.ndarray, P: np.ndarray):
    """Triangle and barycentric coordinates of every point of ``P (p, 2)`` in the planar triangulation ``UV, T``.

    Points outside every triangle (round-off on the border) take the triangle where the smallest barycentric
    coordinate is largest, with coordinates clipped and renormalized.
    """
    from scipy.spatial import cKDTree

    A, B, C = UV[T[:, 0]], UV[T[:, 1]], UV[T[:, 2]]
    cen = (A + B + C) / 3
    tree = cKDTree(cen)
    k = min(len(T), 32)
    _, cand = tree.query(P, k=k)
    cand = np.atleast_2d(cand)
    a, b, c = A[cand], B[cand], C[cand]
    v0, v1, v2 = b - a, c - a, P[:, None, :] - a
    d = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    d = np.where(np.abs(d) > 0, d, np.finfo(float).tiny)
    l1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / d
    l2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / d
    bary = np.stack([1 - l1 - l2, l1, l2], axis=-1)
    score = bary.min(axis=-1)
    j = np.argmax(score, axis=1)
    tri = cand[np.arange(len(P)), j]
    w = np.clip(bary[np.arange(len(P)), j], 0.0, None)
    w /= w.sum(axis=1, keepdims=True)
    far = score[np.arange(len(P)), j] < -1e-6
    if far.any():  # not found among the nearest candidates: brute force (rare, tiny inputs)
        for p in np.nonzero(far)[0]:
            a, b, c = A, B, C
            v0, v1, v2 = b - a, c - a, P[p] - a
            d = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
            d = np.where(np.abs(d) > 0, d, np.finfo(float).tiny)
            l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / d
            l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / d
            bb = np.stack([1 - l1 - l2, l1, l2], axis=-1)
            t = int(np.argmax(bb.min(axis=1)))
            tri[p] = t
            w[p] = np.clip(bb[t], 0.0, None) / np.clip(bb[t], 0.0, None).sum()
    return tri, w


def _disk_net(n: int, k: int, s: float = 0.55):
    """Coarse quad "O-grid" of the unit disk: an ``n × n`` square block ``[-s, s]²`` and ``k`` rings of quads
    around it out to the circle (``4n`` boundary nodes at equal angles).

    Every boundary node has valence 3 (no corner panels with near-straight angles); the four corners of the
    inner block are interior vertices of valence 3. Faces are counter-clockwise.
    """
    t = np.linspace(-s, s, n + 1)
    X, Y = np.meshgrid(t, t, indexing="xy")
    P = [np.column_stack([X.ravel(), Y.ravel()])]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)  # idx[j, i]
    Q = [np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], 1)]
    # the block's boundary, counter-clockwise from the corner (-s, -s)
    ring = np.r_[idx[0, :-1], idx[:-1, -1], idx[-1, :0:-1], idx[:0:-1, 0]]
    inner = P[0][ring]
    ang = np.radians(225.0) + 2 * np.pi * np.arange(4 * n) / (4 * n)
    outer = np.column_stack([np.cos(ang), np.sin(ang)])
    count = len(P[0])
    prev = ring
    for layer in range(1, k + 1):
        lam = layer / k
        P.append((1 - lam) * inner + lam * outer)
        cur = count + np.arange(4 * n)
        count += 4 * n
        Q.append(np.stack([prev, cur, np.roll(cur, -1), np.roll(prev, -1)], 1))
        prev = cur
    UV = np.vstack(P)
    Q = np.vstack(Q).astype(np.int64)
    a = UV[Q[:, 1]] - UV[Q[:, 0]]
    b = UV[Q[:, 3]] - UV[Q[:, 0]]
    flip = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    Q[flip] = Q[flip][:, ::-1]
    return UV, Q


def subdivision_candidate(V, T, panel_size: float, levels: int = 2, name: str = "surface"):
    """Coarse quad net on a disk parametrization, Catmull-Clark subdivided and pulled onto the surface.

    The design surface (a topological disk) is mapped onto the unit disk (:func:`components.parametrize_conformal.
    disk_map`, boundary by arc length, harmonic interior). A coarse "O-grid" there (a square block of ``n × n``
    quads and rings of quads around it, every boundary node of valence 3, four valence-3 interior vertices), lifted
    back onto the surface by barycentric interpolation, is the coarse net: its boundary nodes lie on the surface
    boundary and no panel has a straight corner. ``n`` is chosen so that after ``levels`` Catmull-Clark steps
    (crease boundary) the boundary panels are about ``panel_size`` long; the subdivided net is then pulled onto
    the surface, its boundary onto the surface boundary (:func:`components.pull.pulled_vertices`).

    Parameters
    ----------
    V : (n, 3) float64
        Design surface vertices.
    T : (t, 3) int64
        Design surface triangles (one boundary loop).
    panel_size : float
        Target panel edge length (model units).
    levels : int
        Catmull-Clark levels (each multiplies the face count by 4).
    name : str
        Name of the surface input in error messages.

    Returns
    -------
    V : (p, 3) float64
    Q : (q, 4) int64
        Pulled subdivided quad mesh (the planarization candidate).
    info : dict
        ``coarse`` (the coarse ``(V, Q)``), ``n`` (block size), ``rings``, ``steps`` (seconds per step),
        ``warnings``.

    Notes
    -----
    The third strategy of Liu et al. 2006 (coarse net → subdivision → bring onto the surface → planarize);
    here the coarse net is generated automatically instead of drawn by a designer. A grid of the unit square
    mapped onto a smooth boundary would put four panels with a 180° corner at the square's corners, which no
    planarizer can keep healthy: the O-grid avoids them.
    """
    from components.parametrize_conformal import disk_map
    from components.pull import pulled_vertices
    from components.subdivide import catmull_clark

    V, T = validate_mesh(V, T, name=name, kind="triangle")
    h = _check_panel_size(panel_size, V)
    steps = {}
    warnings: list[str] = []
    t = time.perf_counter()
    UV, info = disk_map(V, T, shape="disk")
    warnings += info["warnings"]
    loop = boundary_loops(T, name=name)[0]
    perimeter = float(np.sum(np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)))
    n = max(2, int(round(perimeter / 4 / (h * 2 ** levels))))
    rings = max(1, int(round(0.3 * n)))
    G, Qc = _disk_net(n, rings)
    tri, w = _locate(UV, T, G)
    Vc = np.einsum("pk,pkd->pd", w, V[T[tri]])
    # same orientation as the design surface: the net is counter-clockwise in UV
    a0 = UV[T[:, 1]] - UV[T[:, 0]]
    a1 = UV[T[:, 2]] - UV[T[:, 0]]
    if np.sum(a0[:, 0] * a1[:, 1] - a0[:, 1] * a1[:, 0]) < 0:
        Qc = Qc[:, ::-1].copy()
    steps["parametrize"] = time.perf_counter() - t
    t = time.perf_counter()
    Vs, Qs, _ = catmull_clark(Vc, Qc, levels=levels, boundary="crease", name="coarse net")
    steps["subdivide"] = time.perf_counter() - t
    t = time.perf_counter()
    pulled = pulled_vertices(Vs, Qs, V, T, boundary="boundary", name="subdivided net", reference_name=name)
    warnings += pulled.warnings
    steps["pull"] = time.perf_counter() - t
    return pulled.V, Qs, {"coarse": (Vc, Qc), "n": n, "rings": rings, "steps": steps, "warnings": warnings}


def _planarize(Vc, Qc, V, T, time_budget):
    from components.planarize import planarize_mesh

    return planarize_mesh(Vc, Qc, reference=(V, T), boundary="slide", tolerance=1e-4, max_iterations=100,
                          time_budget=time_budget, mesh_name="candidate")


def _planarize_detail(res) -> str:
    return (f"planarized in {res.iterations} iterations ({res.stop_reason}), max planarity "
            f"{res.max_planarity:.2g}, worst corner {res.worst_corner_angle:.1f}°")


def _run_subdivision(V, T, panel_size, time_budget=30.0):
    Vc, Qc, info = subdivision_candidate(V, T, panel_size)
    timings = dict(info["steps"])
    warnings = list(info["warnings"])
    t = time.perf_counter()
    res = _planarize(Vc, Qc, V, T, time_budget)
    timings["planarize"] = time.perf_counter() - t
    warnings += list(res.warnings)
    if not res.converged:
        warnings.append(f"planarization did not reach 1e-4 ({res.stop_reason}); max planarity {res.max_planarity:.3g}")
    n, k = info["n"], info["rings"]
    detail = (f"coarse O-grid ({n}×{n} block + {k} ring{'s' if k > 1 else ''}) on a disk parametrization, "
              "2 Catmull-Clark levels, pulled; "
              + _planarize_detail(res))
    return Candidate((Vc, Qc), (res.mesh[0], res.mesh[1]), timings, warnings, detail)


def _missing_planarize() -> str | None:
    try:
        mod = importlib.import_module("components.planarize")
    except ImportError as exc:
        return f"components.planarize cannot be imported ({exc})"
    return None if hasattr(mod, "planarize_mesh") else "components.planarize.planarize_mesh does not exist yet"


# ----------------------------------------------------------------------------------------------
# strategies 2 and 3: pipelines written elsewhere, found by name


_PIPELINE_MODULES = ("components.pipelines", "components.curvature_network", "components.conical",
                     "components.conformal_pipeline", "components.network")


def _find_function(fname: str, modules=_PIPELINE_MODULES):
    """The first of ``modules`` that defines ``fname``, or None."""
    import importlib.util

    for modname in modules:
        try:
            if importlib.util.find_spec(modname) is None:
                continue
            mod = importlib.import_module(modname)
        except ImportError as exc:  # a module that exists but does not import: report it, do not hide it
            log.warning("%s does not import: %s", modname, exc)
            continue
        fn = getattr(mod, fname, None)
        if callable(fn):
            return fn
    return None


_SIZE_KEYWORDS = ("panel_size", "target_edge_length", "edge_length", "spacing", "target_length")
_CANDIDATE_FIELDS = ("candidate", "candidate_mesh", "extracted", "extracted_mesh", "quad_mesh", "rebuilt")
_OPTIMIZED_FIELDS = ("mesh", "optimized", "optimized_mesh", "planarized", "planar_mesh", "pq_mesh")


def _as_mesh(value):
    if isinstance(value, (tuple, list)) and len(value) in (2, 3):
        V = np.asarray(value[0], dtype=np.float64)
        F = np.asarray(value[1], dtype=np.int64)
        if V.ndim == 2 and V.shape[1] == 3 and F.ndim == 2:
            return V, F
    return None


def _call_pipeline(fname: str, V, T, panel_size, time_budget):
    """Call a published pipeline component ``fname(mesh, <panel size keyword>=..., ...)`` and read its meshes."""
    fn = _find_function(fname)
    if fn is None:
        raise RuntimeError(f"{fname} not found")
    sig = inspect.signature(fn)
    kwargs = {}
    for kw in _SIZE_KEYWORDS:
        if kw in sig.parameters:
            kwargs[kw] = float(panel_size)
            break
    else:
        log.info("%s has no panel-size input (%s): running with its defaults", fname, ", ".join(_SIZE_KEYWORDS))
    if "time_budget" in sig.parameters:
        kwargs["time_budget"] = float(time_budget)
    t = time.perf_counter()
    res = fn((V, T), **kwargs)
    elapsed = time.perf_counter() - t
    fields = getattr(res, "_fields", ())
    cand = next((_as_mesh(getattr(res, f)) for f in _CANDIDATE_FIELDS if f in fields
                 and _as_mesh(getattr(res, f)) is not None), None)
    opt = next((_as_mesh(getattr(res, f)) for f in _OPTIMIZED_FIELDS if f in fields
                and _as_mesh(getattr(res, f)) is not None), None)
    if cand is None and opt is None:
        raise RuntimeError(f"{fname} returned no mesh output (fields: {', '.join(fields) or type(res).__name__})")
    if cand is None:
        cand, opt = opt, None
    timings = {"pipeline": elapsed}
    for f in fields:  # pipelines may report their own step timings
        if f.startswith("time_") or f.endswith("_time") or f == "timings":
            val = getattr(res, f)
            if isinstance(val, dict):
                timings.update({str(k): float(v) for k, v in val.items()})
            elif np.isscalar(val):
                timings[f] = float(val)
    warnings = [str(w) for w in getattr(res, "warnings", []) or []]
    used = ", ".join(f"{k}={v:g}" for k, v in kwargs.items())
    return Candidate(cand, opt, timings, warnings, f"{fn.__module__}.{fname}({used})")


def _missing_function(fname: str, modules=_PIPELINE_MODULES) -> Callable[[], str | None]:
    def missing():
        if _find_function(fname, modules) is None:
            return f"{fname} is not implemented yet"
        return None

    return missing


def _run_conjugate(V, T, panel_size, time_budget=30.0):
    from components.pipelines import pq_from_conjugate_field

    res = pq_from_conjugate_field((V, T), target_length=float(panel_size), time_budget=float(time_budget))
    timings = {"field": res.time_field, "parametrize": res.time_parametrize, "extract": res.time_extract,
               "planarize": res.time_planarize}
    detail = (f"conjugate field ({res.singularities} singular vertices, iso-lines {res.mean_angle_error:.1f}° from "
              f"the field on average), {100 * res.quad_ratio:.0f}% quads, "
              f"{100 * res.edge_length_within:.0f}% of edges within ±30% of the panel size; planarized max "
              f"planarity {res.planarized_max_planarity:.2g}")
    return Candidate(tuple(res.candidate[:2]), tuple(res.planarized[:2]), timings, list(res.warnings), detail)


def _run_network(V, T, panel_size, time_budget=30.0):
    return _call_pipeline("pq_from_curvature_network", V, T, panel_size, time_budget)


# ----------------------------------------------------------------------------------------------
# the registry


STRATEGIES: tuple[Strategy, ...] = (
    Strategy("translation", "Translation surface",
             "exact PQ: a translation surface fitted to the design surface (no optimization)",
             _run_translation, lambda: None),
    Strategy("conjugate_field", "Conjugate field",
             "conjugate direction field → quad extraction → planarization",
             _run_conjugate, _missing_function("pq_from_conjugate_field", ("components.pipelines",))),
    Strategy("curvature_network", "Curvature network",
             "curvature-line network → conformal map → quad rebuild → conical optimization",
             _run_network, _missing_function("pq_from_curvature_network")),
    Strategy("subdivision", "Subdivision",
             "coarse quad net → Catmull-Clark → pull onto the surface → planarization",
             _run_subdivision, _missing_planarize),
)


def strategy_names() -> tuple[str, ...]:
    """Keys of the registered strategies, in the paper's order."""
    return tuple(s.name for s in STRATEGIES)


def get_strategy(name: str) -> Strategy:
    """The registered strategy ``name``.

    Raises
    ------
    InputError
        Unknown name (the message lists the valid ones).
    """
    for s in STRATEGIES:
        if s.name == name:
            return s
    raise InputError("strategy", f"unknown strategy {name!r}; valid: {', '.join(strategy_names())}")


def _metrics(mesh, reference, name):
    from components.metrics import metrics_report

    return metrics_report(mesh[0], mesh[1], reference=reference, name=name)


def run_strategy(name: str, V, T, panel_size: float, surface: str = "surface",
                 time_budget: float = 30.0) -> StrategyResult:
    """Run one strategy on a design surface and measure the result.

    Parameters
    ----------
    name : str
        Strategy key (see :func:`strategy_names`).
    V : (n, 3) array_like of float
        Design surface vertices.
    T : (t, 3) array_like of int
        Design surface triangles (polygon faces are triangulated).
    panel_size : float
        Target panel edge length, model units.
    surface : str
        Name of the surface (for the result and messages).
    time_budget : float
        Seconds the optimization step may take.

    Returns
    -------
    StrategyResult
        Never raises for a strategy's own failure: ``status`` says ``"failed"`` and ``detail`` the error; a
        strategy whose component is missing gives ``status="not available"``.

    Raises
    ------
    InputError / MeshError
        Unknown strategy name or a malformed design surface.
    """
    strat = get_strategy(name)
    V, F = validate_mesh(V, T, name="surface")
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    h = float(panel_size)
    why = strat.missing()
    if why:
        return StrategyResult(name, surface, STATUS_NOT_AVAILABLE, None, None, {}, None, None, [], why, h)
    t0 = time.perf_counter()
    try:
        out = strat.runner(V, T, h, time_budget=time_budget)
    except Exception as exc:  # noqa: BLE001 - a failing strategy is a row of the report, not a crash
        log.warning("strategy %s failed on %s: %s", name, surface, exc, exc_info=not isinstance(exc, ValueError))
        return StrategyResult(name, surface, STATUS_FAILED, None, None, {"total": time.perf_counter() - t0},
                              None, None, [], f"{type(exc).__name__}: {exc}", h)
    timings = dict(out.timings)
    timings["total"] = time.perf_counter() - t0
    warnings = list(out.warnings)
    reference = (V, T)
    try:
        before = _metrics(out.candidate, reference, "candidate")
        after = _metrics(out.optimized, reference, "optimized") if out.optimized is not None else None
    except (InputError, MeshError) as exc:
        return StrategyResult(name, surface, STATUS_FAILED, out.candidate, out.optimized, timings, None, None,
                              warnings, f"the result cannot be measured: {exc}", h)
    return StrategyResult(name, surface, STATUS_OK, out.candidate, out.optimized, timings, before, after, warnings,
                          out.detail, h)


def run_strategies(V, T, panel_size: float, surface: str = "surface", names=None,
                   time_budget: float = 30.0) -> list[StrategyResult]:
    """Run several strategies (all by default) on one design surface; see :func:`run_strategy`."""
    return [run_strategy(n, V, T, panel_size, surface=surface, time_budget=time_budget)
            for n in (names or strategy_names())]
