"""Planarization of quad / polygon meshes: a guided Gauss-Newton solver with soft design goals.

Every meshing strategy ends with a candidate quad mesh whose faces are almost, but not exactly, planar. This module
moves its vertices until every face is planar (to a tolerance) while the mesh stays close to the design surface,
keeps its boundary and anchors, stays fair and keeps its panels healthy (no collapsed or non-convex quads).

Solver (guided projection after Tang, Sun, Gomes, Wallner & Pottmann 2014, "Form-finding with polyhedral meshes
made simple"): the scale-free planarity residuals (and, optionally, the conical angle criterion) are *hard* goals,
linearized exactly and met by a minimum-norm correction ``z = z_s + Jᵀλ``, ``(J Jᵀ + εI) λ = −(r + J z_s)``: one
sparse SPD solve per iteration in a system with one row per face. Closeness, fairness and even panels are *soft*
goals: they propose a Jacobi-preconditioned Gauss-Newton step ``z_s`` that the correction keeps feasible, damped
whenever planarity stops halving. Panel health is guarded by corner-angle rows (corners within 10° of the bounds
``0.5 ×`` the input's worst angle / its margin to 180° become hard rows) and a backtracking step that rejects small
angles and new non-convex faces; the best state seen is returned, never one worse than the input.

Public array-level functions: :func:`planarize_mesh`, and the measures re-exported from
:mod:`components.planarize_geometry` (:func:`face_planarity`, :func:`warping_height`, :func:`corner_angles`,
:func:`nonconvex_faces`). Published components: :func:`planarize`, :func:`planarize_on_surface`.
"""
from __future__ import annotations

import logging
import math
import time
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from components.mesh import (
    InputError,
    MeshError,
    boundary_loops,
    edge_topology,
    face_sizes,
    triangulate,
    validate_mesh,
)
from components.planarize_geometry import (
    _PolylineIndex,
    triangle_query,
    corner_angles,
    face_corners,
    face_planarity,
    loop_segments,
    nonconvex_faces,
    vertex_stars,
    warping_height,
)
from components import planarize_goals as goals
from components.types import Integers, Mesh, Numbers, Points

log = logging.getLogger(__name__)

__all__ = [
    "PlanarizeResult",
    "planarize",
    "planarize_on_surface",
    "planarize_mesh",
    "face_planarity",
    "warping_height",
    "corner_angles",
    "nonconvex_faces",
]

BOUNDARY_MODES = ("fixed", "slide", "free")
FAIRNESS_MODES = ("polylines", "laplacian")
CONICAL_TOLERANCE = 1e-6  # radians, criterion ω1 − ω2 + ω3 − ω4 when the conical goal is on
_NORMAL_STIFFNESS = 10.0  # with a reference: normal motion costs 1 + 10·closeness_weight times tangential motion


class PlanarizeResult(NamedTuple):
    """Result of :func:`planarize` (field names are the Hops outputs)."""

    mesh: Mesh
    planarity: Numbers
    max_planarity: float
    mean_planarity: float
    max_closeness: float
    mean_closeness: float
    iterations: int
    converged: bool
    stop_reason: str
    worst_corner_angle: float
    nonconvex_faces: int
    max_warping_height: float
    max_conical: float
    history_max_planarity: Numbers
    history_mean_planarity: Numbers
    history_max_closeness: Numbers
    history_mean_closeness: Numbers
    history_time: Numbers
    warnings: list[str]


# ----------------------------------------------------------------------------------------------
# input checks


def _check_weight(name, value):
    try:
        w = float(value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a number, got {value!r}") from None
    if not math.isfinite(w):
        raise InputError(name, f"must be finite, got {w}")
    if w < 0:
        raise InputError(name, f"must be non-negative, got {w}")
    return w


def _check_anchors(anchors, n):
    if anchors is None:
        return np.zeros(0, dtype=np.int64)
    a = np.asarray(anchors)
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a.astype(float))):
        raise InputError("anchors", "must be vertex indices (finite integers)")
    if np.any(a != np.round(a)):
        raise InputError("anchors", "must be integer vertex indices")
    a = a.astype(np.int64).ravel()
    bad = (a < 0) | (a >= n)
    if bad.any():
        raise InputError("anchors", f"vertex index {int(a[bad][0])} is out of range 0..{n - 1}")
    return np.unique(a)


def _check_points(P, name):
    if P is None:
        return np.zeros((0, 3))
    try:
        P = np.asarray(P, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(name, "must be points (n, 3)") from None
    if P.size == 0:
        return np.zeros((0, 3))
    P = P.reshape(-1, 3) if P.ndim == 1 and P.size % 3 == 0 else P
    if P.ndim != 2 or P.shape[1] != 3:
        raise InputError(name, f"must have shape (n, 3), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError(name, "has a NaN or infinite coordinate")
    return P


# ----------------------------------------------------------------------------------------------
# the solver


def _pseudo_quads(F, sizes):
    """Quads, plus every run of four consecutive corners of the n-gons (n ≥ 5): their planarity residuals."""
    q = np.nonzero(sizes == 4)[0]
    parts = [F[q, :4]]
    for s in np.unique(sizes[sizes > 4]):
        g = np.nonzero(sizes == s)[0]
        for i in range(s):
            parts.append(F[g][:, [(i + j) % s for j in range(4)]])
    return np.concatenate(parts).astype(np.int64) if parts else np.zeros((0, 4), np.int64)


def _vertex_normals(X, F):
    from components.mesh import face_normals

    N = face_normals(X, F, unit=False)
    C = face_corners(F)
    VN = np.zeros_like(X)
    np.add.at(VN, C.v, N[C.face])
    L = np.linalg.norm(VN, axis=1, keepdims=True)
    return VN / np.where(L > 0, L, 1.0)


def _laplacian_triplets(E, n):
    deg = np.bincount(E.ravel(), minlength=n).astype(float)
    vv = np.concatenate([E[:, 0], E[:, 1]])
    nb = np.concatenate([E[:, 1], E[:, 0]])
    return vv, nb, 1.0 / deg[vv]


def _stack(blocks, ncols):
    """Stack weighted residual blocks into one sparse Jacobian ``J`` and residual ``r`` (rows scaled by √w)."""
    rows, cols, vals, rr = [], [], [], []
    off = 0
    for blk in blocks:
        sw = math.sqrt(blk.weight)
        rows.append(blk.rows + off)
        cols.append(blk.cols)
        vals.append(sw * blk.vals)
        rr.append(sw * blk.r)
        off += len(blk.r)
    J = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(off, ncols))
    return J, np.concatenate(rr)


def _solve_spd(A, b):
    """Solve the SPD normal equations (SuperLU, symmetric mode on the symmetric minimum-degree ordering)."""
    A = A.tocsc()
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options=dict(SymmetricMode=True))
        return lu.solve(b)
    except RuntimeError:  # exactly singular: fall back to a damped solve
        d = A.diagonal()
        A = A + sp.diags(1e-9 * (np.abs(d).max() + 1.0) * np.ones(len(d)))
        return spla.spsolve(A.tocsc(), b)


class _Health(NamedTuple):
    min_angle: float
    nonconvex: int
    angles: np.ndarray


def _health(X, F, corners, nonquad_ok):
    th = corner_angles(X, F)
    return _Health(float(th.min()) if len(th) else math.pi, int(nonconvex_faces(X, F).sum()), th)


def planarize_mesh(
    V,
    F,
    reference=None,
    *,
    closeness_weight: float = 1.0,
    start_weight: float = 0.0,
    fairness_weight: float = 0.01,
    fairness_mode: str = "polylines",
    edge_length_weight: float = 0.0,
    target_edge_length: float = 0.0,
    area_weight: float = 0.0,
    target_area: float = 0.0,
    conical_weight: float = 0.0,
    boundary: str = "free",
    anchors=None,
    anchor_points=None,
    tolerance: float = 1e-4,
    absolute_tolerance: float = 0.0,
    max_iterations: int = 100,
    time_budget: float = 30.0,
    angle_guard: float = 0.5,
    mesh_name: str = "mesh",
) -> PlanarizeResult:
    """Make every face of a polygon mesh planar while keeping it close, fair, anchored and healthy.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions (model units).
    F : (m, k) array_like of int
        Padded polygon faces (quads, n-gons; triangles are planar and only take part in the other goals).
    reference : tuple (Vr, Fr), optional
        Reference surface mesh to stay on (any polygons; triangulated internally). When absent, closeness is to the
        tangent planes of the start mesh at the start positions.
    closeness_weight : float
        Weight of the pull toward the reference (point-to-tangent-plane distance, in mean edge lengths).
    start_weight : float
        Weight of the pull toward the start positions (all three directions).
    fairness_weight : float
        Weight of the fairness goal (second differences along mesh polylines, or Laplacian).
    fairness_mode : {"polylines", "laplacian"}
        Fairness measure.
    edge_length_weight, target_edge_length : float
        Edge length equalization toward ``target_edge_length`` (model units; 0 = the current mean).
    area_weight, target_area : float
        Face area equalization toward ``target_area`` (model units²; 0 = the current mean).
    conical_weight : float
        Weight of the conical angle criterion at interior valence-4 vertices (a hard goal like planarity when > 0).
    boundary : {"fixed", "slide", "free"}
        Boundary vertices fixed, sliding along the reference's boundary polylines (the start boundary without a
        reference; corners, i.e. vertices of one face or sharp turns, stay fixed), or free.
    anchors : (a,) array_like of int, optional
        Vertex indices that must not move.
    anchor_points : (p, 3) array_like of float, optional
        Points whose nearest vertices must not move.
    tolerance : float
        Scale-free planarity to reach (max over faces); applies when > 0.
    absolute_tolerance : float
        Warping height to reach in model units; applies only when ``tolerance <= 0``.
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds.
    angle_guard : float
        Fraction of the input's worst corner angle below which no corner may go (and the same fraction of the
        input's margin to 180° above which no corner may go).
    mesh_name : str
        Name of the mesh input used in error messages.

    Returns
    -------
    PlanarizeResult

    Raises
    ------
    MeshError
        Malformed, non-manifold or degenerate mesh or reference.
    InputError
        Negative or non-finite weights, unknown modes, anchors out of range.
    """
    t0 = time.perf_counter()
    V, F = validate_mesh(V, F, name=mesh_name)
    n = len(V)
    w_close = _check_weight("closeness_weight", closeness_weight)
    w_start = _check_weight("start_weight", start_weight)
    w_fair = _check_weight("fairness_weight", fairness_weight)
    w_edge = _check_weight("edge_length_weight", edge_length_weight)
    w_area = _check_weight("area_weight", area_weight)
    w_con = _check_weight("conical_weight", conical_weight)
    t_edge = _check_weight("target_edge_length", target_edge_length)
    t_area = _check_weight("target_area", target_area)
    tol = _check_weight("tolerance", tolerance)
    atol = _check_weight("absolute_tolerance", absolute_tolerance)
    budget = _check_weight("time_budget", time_budget)
    guard = _check_weight("angle_guard", angle_guard)
    if guard >= 1:
        raise InputError("angle_guard", f"must be below 1, got {guard}")
    try:
        max_it = int(max_iterations)
    except (TypeError, ValueError):
        raise InputError("max_iterations", f"must be an integer, got {max_iterations!r}") from None
    if max_it < 0:
        raise InputError("max_iterations", f"must be non-negative, got {max_it}")
    if boundary not in BOUNDARY_MODES:
        raise InputError("boundary", f"must be one of {BOUNDARY_MODES}, got {boundary!r}")
    if fairness_mode not in FAIRNESS_MODES:
        raise InputError("fairness_mode", f"must be one of {FAIRNESS_MODES}, got {fairness_mode!r}")
    anchor_idx = _check_anchors(anchors, n)
    apts = _check_points(anchor_points, "anchor_points")
    if reference is not None:
        try:
            Vr, Fr = reference
        except (TypeError, ValueError):
            raise MeshError("reference", "must be a mesh (V, F)") from None
        Vr, Fr = validate_mesh(Vr, Fr, name="reference", manifold=False)
    use_abs = tol <= 0 and atol > 0
    if tol <= 0 and not use_abs:
        tol = 1e-4

    warnings: list[str] = []
    sizes = face_sizes(F)
    corners = face_corners(F)
    topo = edge_topology(F)
    E = topo.E

    # normalized units: centred, mean edge length 1
    center = V.mean(axis=0)
    scale = float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())
    X0 = (V - center) / scale
    X = X0.copy()

    # reference in normalized units
    if reference is not None:
        XR = (Vr - center) / scale
        TR, _ = triangulate(Fr)
        from components.mesh import face_normals

        NR = face_normals(XR, TR)
        ref_index = triangle_query(XR, TR)
        ref_loops = boundary_loops(Fr)
        ref_bnd_X = XR
    else:
        XR = TR = NR = None
        ref_loops = boundary_loops(F)
        ref_bnd_X = X0
    N0 = _vertex_normals(X0, F)

    # ------------------------------------------------------------------ variables: fixed / sliding / free
    fixed = np.zeros(n, dtype=bool)
    slide = np.zeros(n, dtype=bool)
    loops = boundary_loops(F)
    bmask = np.zeros(n, dtype=bool)
    for lp in loops:
        bmask[lp] = True
    faces_per_v = np.bincount(corners.v, minlength=n)
    if boundary == "fixed":
        fixed |= bmask
    elif boundary == "slide":
        slide |= bmask
        for lp in loops:
            p, q = X0[np.roll(lp, 1)], X0[np.roll(lp, -1)]
            a, b = X0[lp] - p, q - X0[lp]
            cosang = np.einsum("ij,ij->i", a, b) / np.maximum(
                np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
            corner = (cosang < math.cos(math.radians(40))) | (faces_per_v[lp] <= 1)
            fixed[lp[corner]] = True
        if not ref_loops:
            warnings.append("boundary: the reference has no boundary to slide on; boundary vertices were fixed")
            fixed |= bmask
        slide &= ~fixed
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    fixed |= ~used
    fixed[anchor_idx] = True
    if len(apts):
        d, i = cKDTree(V).query(apts)
        fixed[i] = True
        far = d > 0.5 * scale
        if far.any():
            warnings.append(
                f"anchor_points: {int(far.sum())} point(s) are more than half an edge from any vertex; "
                "their nearest vertices were anchored")
    slide &= ~fixed
    locked = fixed[F].all(axis=1) & (face_planarity(V, F) > (tol if tol > 0 else 0.0))
    if locked.any():
        warnings.append(f"{int(locked.sum())} non-planar face(s) have all their corners fixed (boundary, corners or "
                        f"anchors), e.g. face {int(np.argmax(locked))}: the tolerance cannot be reached there")
    slide_idx = np.nonzero(slide)[0]
    free_idx = np.nonzero(~fixed & ~slide)[0]
    bnd_index = None
    if len(slide_idx):
        SA, SB = loop_segments(ref_bnd_X, ref_loops)
        bnd_index = _PolylineIndex(SA, SB)

    def project_slide(Xc):
        if bnd_index is None:
            return Xc, None
        q, seg = bnd_index.query(Xc[slide_idx])
        Xc = Xc.copy()
        Xc[slide_idx] = q
        t = bnd_index.B[seg] - bnd_index.A[seg]
        t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
        return Xc, t

    X, tangents = project_slide(X)
    # basis P: dx = P y (free vertices 3 dof, sliding vertices 1 dof along the boundary, fixed 0)
    nf = len(free_idx)

    def basis(tang, Xc):
        """``dx = P z`` with ``|z|²`` the step metric: free vertices move freely but, with closeness on, moving
        along the surface normal costs ``1 + α`` times more (``P = M^{-1/2}``, ``M = I + α n nᵀ``)."""
        if alpha > 0 and nf:
            Nn = _vertex_normals(Xc, F)[free_idx]
            c = 1.0 - 1.0 / math.sqrt(1.0 + alpha)
            blk = np.eye(3)[None] - c * Nn[:, :, None] * Nn[:, None, :]
            rows = [np.repeat(3 * free_idx[:, None] + np.arange(3), 3, axis=1).ravel()]
            cols = [np.tile(3 * np.arange(nf)[:, None] + np.arange(3), (1, 3)).ravel()]
            vals = [blk.ravel()]
        else:
            rows = [(3 * free_idx[:, None] + np.arange(3)).ravel()]
            cols = [np.arange(3 * nf)]
            vals = [np.ones(3 * nf)]
        if len(slide_idx):
            rows.append((3 * slide_idx[:, None] + np.arange(3)).ravel())
            cols.append(np.repeat(3 * nf + np.arange(len(slide_idx)), 3))
            vals.append(tang.ravel())
        return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(3 * n, 3 * nf + len(slide_idx)))

    # ------------------------------------------------------------------ static goal data
    Q4 = _pseudo_quads(F, sizes)
    stars = vertex_stars(F, n)
    lap = _laplacian_triplets(E, n) if fairness_mode == "laplacian" else None
    close_idx = np.nonzero(~fixed)[0]
    conical_on = w_con > 0 and len(stars.center) > 0
    if w_con > 0 and not conical_on:
        warnings.append("conical_weight: the mesh has no interior valence-4 vertex; the conical goal was ignored")

    h_in = _health(X, F, corners, True)
    quad_like = sizes >= 4
    lo = guard * h_in.min_angle
    hi = math.pi - guard * (math.pi - float(h_in.angles.max()))
    margin = math.radians(10.0)
    n_nonconvex_in = h_in.nonconvex

    def measures(Xc):
        pl = face_planarity(Xc, F)
        if XR is not None:
            _, d, _ = ref_index.query(Xc)
        else:
            d = np.linalg.norm(Xc - X0, axis=1)
        return pl, d * scale

    def met(pl, Xc):
        if use_abs:
            ok = warping_height(Xc * scale, F).max() <= atol
        else:
            ok = pl.max() <= tol
        if conical_on:
            ok = ok and float(np.abs(goals.conical_residual(Xc, corners, stars)).max()) <= CONICAL_TOLERANCE
        return bool(ok)

    def score(pl, Xc):
        s = float(pl.max())
        if conical_on:
            s = max(s, float(np.abs(goals.conical_residual(Xc, corners, stars)).max()))
        return s

    pl, cl = measures(X)
    hist = dict(maxp=[float(pl.max())], meanp=[float(pl.mean())], maxc=[float(cl.max())],
                meanc=[float(cl.mean())], t=[time.perf_counter() - t0])
    best = dict(X=X.copy(), score=score(pl, X), it=0)
    start_score = best["score"]
    stop_reason = ""
    it = 0
    converged = met(pl, X)
    barrier_set = np.zeros(len(corners.v), dtype=bool)
    if converged:
        stop_reason = "tolerance reached (input already planar)"
    ndof = 3 * nf + len(slide_idx)
    alpha = _NORMAL_STIFFNESS * w_close if XR is not None else 0.0
    if ndof == 0 and not converged:
        stop_reason = "no free vertex to move"
    since_best = 0
    soft_scale = 1.0
    w_con_rows = math.sqrt(w_con) if conical_on else 0.0

    def soft_step(Xc, Pm):
        """One Jacobi-preconditioned Gauss-Newton step on the soft goals (reduced coordinates)."""
        blocks = []
        if w_close > 0 and len(close_idx):
            if XR is not None:
                C, _, fidx = ref_index.query(Xc[close_idx])
                blocks.append(goals.closeness_block(Xc, close_idx, C, NR[fidx], w_close))
            else:
                blocks.append(goals.closeness_block(Xc, close_idx, X0[close_idx], N0[close_idx], w_close))
        if w_start > 0:
            blocks.append(goals.start_block(Xc, X0, close_idx, w_start))
        if w_fair > 0:
            blocks.append(goals.fairness_block(Xc, stars, fairness_mode, w_fair, lap))
        if w_edge > 0:
            blocks.append(goals.edge_length_block(Xc, E, t_edge / scale, w_edge))
        if w_area > 0:
            blocks.append(goals.area_block(Xc, F, corners, t_area / scale**2, w_area))
        if not blocks:
            return np.zeros(Pm.shape[1])
        J, r = _stack(blocks, 3 * n)
        Jr = (J @ Pm).tocsr()
        g = Jr.T @ r
        Ja = abs(Jr)
        rowabs = Ja.T @ (Ja @ np.ones(Jr.shape[1]))
        return -g / (rowabs + 1.0)

    def hard_rows(Xc, sel):
        blocks = [goals.planarity_block(Xc, Q4, 1.0)]
        if conical_on:
            blocks.append(goals.conical_block(Xc, corners, stars, w_con_rows ** 2))
        if len(sel):
            blocks.append(goals.angle_barrier_block(Xc, corners, sel, lo + 0.5 * margin, hi - 0.5 * margin, 1.0))
        return _stack(blocks, 3 * n)

    while not converged and not stop_reason:
        if it >= max_it:
            stop_reason = f"iteration cap ({max_it}) reached"
            break
        if time.perf_counter() - t0 > budget:
            stop_reason = f"time budget ({budget:g} s) reached"
            break
        it += 1
        Pm = basis(tangents if tangents is not None else np.zeros((0, 3)), X)
        ys = soft_scale * soft_step(X, Pm)
        th = corner_angles(X, F)
        sel_mask = ((th < lo + margin) | (th > hi - margin) | barrier_set) & quad_like[corners.face]
        healthy = False
        first = None
        eps_rel = 1e-8
        for attempt in range(4):
            J, r = hard_rows(X, np.nonzero(sel_mask)[0])
            Jr = (J @ Pm).tocsr()
            S = (Jr @ Jr.T).tocsc()
            eps = eps_rel * float(S.diagonal().mean()) + 1e-14
            lam = _solve_spd(S + sp.identity(S.shape[0], format="csc") * eps, -(r + Jr @ ys))
            y = ys + Jr.T @ lam
            if not np.all(np.isfinite(y)):
                break
            step = (Pm @ y).reshape(-1, 3)
            if first is None:
                first = step
            Xn, tn = project_slide(X + step)
            hn = _health(Xn, F, corners, True)
            healthy = hn.min_angle >= lo and hn.nonconvex <= n_nonconvex_in and float(hn.angles.max()) <= hi
            if healthy:
                break
            log.debug("   attempt %d unhealthy: min angle %.1f nonconvex %d", attempt,
                      math.degrees(hn.min_angle), hn.nonconvex)
            # the corners that would leave the healthy range become hard rows; solve again
            bad = ((hn.angles < lo + margin) | (hn.angles > hi - margin)) & quad_like[corners.face]
            if hn.nonconvex > n_nonconvex_in:
                ncv = nonconvex_faces(Xn, F)
                bad |= ncv[corners.face] & quad_like[corners.face]
            if not (bad & ~sel_mask).any():
                break
            sel_mask |= bad
            barrier_set |= bad
            eps_rel *= 100.0  # guard rows may conflict with planarity: solve them in the least-squares sense
        tstep = 1.0
        if not healthy and first is not None:
            step = first
            for _ in range(6):
                tstep *= 0.5
                Xn, tn = project_slide(X + tstep * step)
                hn = _health(Xn, F, corners, True)
                healthy = hn.min_angle >= lo and hn.nonconvex <= n_nonconvex_in and float(hn.angles.max()) <= hi
                if healthy:
                    break
        if not healthy:
            stop_reason = "no step keeps the panels healthy (corner angle / convexity guard)"
            break
        X, tangents = Xn, tn
        pl, cl = measures(X)
        hist["maxp"].append(float(pl.max()))
        hist["meanp"].append(float(pl.mean()))
        hist["maxc"].append(float(cl.max()))
        hist["meanc"].append(float(cl.mean()))
        hist["t"].append(time.perf_counter() - t0)
        sc = score(pl, X)
        if sc > 0.5 * best["score"]:
            soft_scale *= 0.5
        if sc < best["score"]:
            best = dict(X=X.copy(), score=sc, it=it)
            since_best = 0
        else:
            since_best += 1
        converged = met(pl, X)
        log.debug("planarize it %d: max %.3e mean %.3e soft %.2g t %.3g attempts %d min angle %.1f",
                  it, pl.max(), pl.mean(), soft_scale, tstep, attempt, math.degrees(hn.min_angle))
        if converged:
            stop_reason = "tolerance reached"
            best = dict(X=X.copy(), score=sc, it=it)
        elif since_best >= 10:
            stop_reason = "stalled (no improvement in 10 iterations)"

    Xb = best["X"]
    Vout = Xb * scale + center
    Vout[fixed] = V[fixed]  # exactly unmoved
    pl = face_planarity(Vout, F)
    if XR is not None:
        _, d, _ = triangle_query(Vr, triangulate(Fr)[0]).query(Vout)
    else:
        d = np.linalg.norm(Vout - V, axis=1)
    hb = _health(Vout, F, corners, True)
    con = float(np.abs(goals.conical_residual(Xb, corners, stars)).max()) if len(stars.center) else 0.0
    converged = met(pl, Xb)
    if not converged:
        target = f"warping height {atol:g}" if use_abs else f"planarity {tol:g}"
        what = f"max planarity {pl.max():.3g}"
        if use_abs:
            what = f"max warping height {warping_height(Vout, F).max():.3g}"
        if conical_on:
            what += f", conical criterion {con:.3g} rad"
        warnings.append(f"tolerance not reached ({stop_reason}): best state has {what} (target {target}); "
                        f"it was returned")
    if best["score"] >= start_score and not converged and it > 0:
        warnings.append("no iteration improved on the input; the input mesh was returned")
    if hb.min_angle < h_in.min_angle - 1e-9 and math.degrees(hb.min_angle) < 0.75 * math.degrees(h_in.min_angle):
        warnings.append(f"worst corner angle degraded from {math.degrees(h_in.min_angle):.1f}° to "
                        f"{math.degrees(hb.min_angle):.1f}°")
    if hb.nonconvex > n_nonconvex_in:
        warnings.append(f"non-convex faces increased from {n_nonconvex_in} to {hb.nonconvex}")
    return PlanarizeResult(
        mesh=(Vout, F),
        planarity=pl,
        max_planarity=float(pl.max()),
        mean_planarity=float(pl.mean()),
        max_closeness=float(d.max()),
        mean_closeness=float(d.mean()),
        iterations=it,
        converged=converged,
        stop_reason=stop_reason,
        worst_corner_angle=math.degrees(hb.min_angle),
        nonconvex_faces=hb.nonconvex,
        max_warping_height=float(warping_height(Vout, F).max()),
        max_conical=con,
        history_max_planarity=np.asarray(hist["maxp"]),
        history_mean_planarity=np.asarray(hist["meanp"]),
        history_max_closeness=np.asarray(hist["maxc"]),
        history_mean_closeness=np.asarray(hist["meanc"]),
        history_time=np.asarray(hist["t"]),
        warnings=warnings,
    )


# ----------------------------------------------------------------------------------------------
# published components


def planarize(
    mesh: Mesh,
    reference: Mesh | None = None,
    closeness_weight: float = 1.0,
    start_weight: float = 0.0,
    fairness_weight: float = 0.01,
    fairness_mode: str = "polylines",
    edge_length_weight: float = 0.0,
    target_edge_length: float = 0.0,
    area_weight: float = 0.0,
    target_area: float = 0.0,
    conical_weight: float = 0.0,
    boundary: str = "free",
    anchors: Integers | None = None,
    anchor_points: Points | None = None,
    tolerance: float = 1e-4,
    max_iterations: int = 100,
    time_budget: float = 30.0,
    absolute_tolerance: float = 0.0,
) -> PlanarizeResult:
    """Make every face of a quad or polygon mesh planar while keeping it close, fair, anchored and healthy.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)`` to planarize; triangles are kept (they are planar).
    reference : Mesh | None
        Surface mesh to stay close to; when absent, closeness is to the tangent planes of the input mesh.
    closeness_weight : float
        Weight of the pull toward the reference (point-to-tangent-plane); 0 turns it off.
    start_weight : float
        Weight of the pull toward the start positions (all directions).
    fairness_weight : float
        Weight of fairness (second differences along the mesh polylines, or Laplacian).
    fairness_mode : str
        ``"polylines"`` (second differences along the net's polylines) or ``"laplacian"``.
    edge_length_weight : float
        Weight of edge length equalization.
    target_edge_length : float
        Target edge length in model units; 0 means the current mean.
    area_weight : float
        Weight of face area equalization.
    target_area : float
        Target face area in model units squared; 0 means the current mean.
    conical_weight : float
        Weight of the conical angle criterion (ω1 + ω3 = ω2 + ω4 at interior valence-4 vertices); 0 turns it off,
        any positive value makes it a hard goal like planarity.
    boundary : str
        ``"free"``, ``"fixed"`` (boundary vertices do not move) or ``"slide"`` (they slide along the boundary
        polylines of the reference, or of the input; boundary corners stay fixed).
    anchors : Integers | None
        Indices of vertices that must not move.
    anchor_points : Points | None
        Points whose nearest vertices must not move.
    tolerance : float
        Scale-free planarity to reach: max over faces of diagonal distance / mean diagonal; applies when > 0.
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds.
    absolute_tolerance : float
        Warping height to reach in model units (filled from the document); applies only when tolerance is 0.

    Returns
    -------
    mesh : Mesh
        The planarized mesh (same faces); the best state seen, never worse than the input in planarity.
    planarity : Numbers
        Scale-free planarity of every face.
    max_planarity : float
        Largest face planarity.
    mean_planarity : float
        Mean face planarity.
    max_closeness : float
        Largest distance to the reference (model units), or largest displacement from the start without one.
    mean_closeness : float
        Mean distance to the reference (model units), or mean displacement from the start without one.
    iterations : int
        Iterations run.
    converged : bool
        Whether the tolerance (and the conical criterion, when on) was reached.
    stop_reason : str
        Why the solver stopped: tolerance, iteration cap, time budget, stall or panel-health guard.
    worst_corner_angle : float
        Smallest corner angle of the result, in degrees.
    nonconvex_faces : int
        Number of non-convex faces of the result.
    max_warping_height : float
        Largest warping height (distance between the diagonals) in model units.
    max_conical : float
        Largest conical angle criterion |ω1 − ω2 + ω3 − ω4| in radians (0 without interior valence-4 vertices).
    history_max_planarity : Numbers
        Max planarity after every iteration (first entry: the input).
    history_mean_planarity : Numbers
        Mean planarity after every iteration.
    history_max_closeness : Numbers
        Max closeness after every iteration (model units).
    history_mean_closeness : Numbers
        Mean closeness after every iteration (model units).
    history_time : Numbers
        Elapsed seconds after every iteration.

    Raises
    ------
    MeshError
        The mesh or the reference is malformed, non-manifold, degenerate or has NaN coordinates.
    InputError
        A weight is negative or not finite, a mode is unknown, an anchor is out of range.

    Notes
    -----
    Guided projection after Tang, Sun, Gomes, Wallner & Pottmann, "Form-finding with polyhedral meshes made
    simple", ACM TOG 33(4), 2014: planarity (and the conical criterion of Liu, Pottmann, Wallner, Yang & Wang,
    "Geometric modeling with conical meshes and developable surfaces", 2006) are hard constraints, linearized and
    met by a minimum-norm correction (one sparse SPD solve in the face-sized system per iteration); the soft goals
    contribute a preconditioned Gauss-Newton step that the correction keeps feasible. Corners approaching a
    collapse (below ``0.5 ×`` the input's worst angle) or a fold become hard rows, and steps that would still make
    unhealthy panels are shortened. Which tolerance applies: ``tolerance > 0`` → scale-free planarity;
    ``tolerance == 0`` and ``absolute_tolerance > 0`` → warping height in model units; both 0 → 1e-4 scale-free.

    Example
    -------
    >>> from components.mesh import quad_grid
    >>> V, F = quad_grid(4, 4)
    >>> V[:, 2] = 0.2 * V[:, 0] * V[:, 1]
    >>> res = planarize((V, F))
    >>> res.converged, res.max_planarity <= 1e-4
    (True, True)
    """
    V, F = _unpack(mesh, "mesh")
    return planarize_mesh(
        V, F, reference,
        closeness_weight=closeness_weight, start_weight=start_weight, fairness_weight=fairness_weight,
        fairness_mode=fairness_mode, edge_length_weight=edge_length_weight, target_edge_length=target_edge_length,
        area_weight=area_weight, target_area=target_area, conical_weight=conical_weight, boundary=boundary,
        anchors=anchors, anchor_points=anchor_points, tolerance=tolerance, absolute_tolerance=absolute_tolerance,
        max_iterations=max_iterations, time_budget=time_budget,
    )


def planarize_on_surface(
    mesh: Mesh,
    surface: Mesh,
    closeness_weight: float = 1.0,
    fairness_weight: float = 0.01,
    boundary: str = "slide",
    anchors: Integers | None = None,
    tolerance: float = 1e-4,
    max_iterations: int = 100,
    time_budget: float = 30.0,
    absolute_tolerance: float = 0.0,
) -> PlanarizeResult:
    """Planarize a quad mesh while keeping it on a design surface and its boundary on the surface's boundary.

    Parameters
    ----------
    mesh : Mesh
        The quad or polygon mesh ``(V, F)`` to planarize.
    surface : Mesh
        The design surface as a mesh; vertices are pulled to their closest points on it.
    closeness_weight : float
        Weight of the pull toward the surface.
    fairness_weight : float
        Weight of fairness (second differences along the mesh polylines).
    boundary : str
        ``"slide"`` (boundary vertices slide along the surface's boundary; corners fixed), ``"fixed"`` or ``"free"``.
    anchors : Integers | None
        Indices of vertices that must not move.
    tolerance : float
        Scale-free planarity to reach; applies when > 0.
    max_iterations : int
        Iteration cap.
    time_budget : float
        Wall-clock budget in seconds.
    absolute_tolerance : float
        Warping height to reach in model units (filled from the document); applies only when tolerance is 0.

    Returns
    -------
    mesh : Mesh
        The planarized mesh (same faces).
    planarity : Numbers
        Scale-free planarity of every face.
    max_planarity : float
        Largest face planarity.
    mean_planarity : float
        Mean face planarity.
    max_closeness : float
        Largest distance to the surface (model units).
    mean_closeness : float
        Mean distance to the surface (model units).
    iterations : int
        Iterations run.
    converged : bool
        Whether the tolerance was reached.
    stop_reason : str
        Why the solver stopped.
    worst_corner_angle : float
        Smallest corner angle of the result, in degrees.
    nonconvex_faces : int
        Number of non-convex faces of the result.
    max_warping_height : float
        Largest warping height in model units.
    max_conical : float
        Largest conical angle criterion in radians.
    history_max_planarity : Numbers
        Max planarity after every iteration.
    history_mean_planarity : Numbers
        Mean planarity after every iteration.
    history_max_closeness : Numbers
        Max distance to the surface after every iteration.
    history_mean_closeness : Numbers
        Mean distance to the surface after every iteration.
    history_time : Numbers
        Elapsed seconds after every iteration.

    Raises
    ------
    MeshError
        The mesh or the surface is malformed.
    InputError
        A weight is negative, a mode is unknown or an anchor is out of range.

    Notes
    -----
    :func:`planarize` with ``reference=surface`` (see there; Tang et al. 2014).

    Example
    -------
    >>> from components.mesh import quad_grid
    >>> V, F = quad_grid(4, 4)
    >>> V[:, 2] = 0.2 * V[:, 0] * V[:, 1]
    >>> res = planarize_on_surface((V, F), (V.copy(), F), boundary="free")
    >>> res.max_planarity <= 1e-4
    True
    """
    V, F = _unpack(mesh, "mesh")
    if surface is None:
        raise MeshError("surface", "a surface mesh is required")
    return planarize_mesh(
        V, F, surface, closeness_weight=closeness_weight, fairness_weight=fairness_weight, boundary=boundary,
        anchors=anchors, tolerance=tolerance, absolute_tolerance=absolute_tolerance,
        max_iterations=max_iterations, time_budget=time_budget,
    )


def _unpack(mesh, name):
    try:
        V, F = mesh
    except (TypeError, ValueError):
        raise MeshError(name, "must be a mesh (V, F)") from None
    return V, F
