"""Planarization of quad / polygon meshes: a guided Gauss-Newton solver with soft design goals.

Every meshing strategy ends with a candidate quad mesh whose faces are almost, but not exactly, planar. This module
moves its vertices until every face is planar (to a tolerance) while the mesh stays close to the design surface,
keeps its boundary and anchors, stays fair and keeps its panels healthy (no collapsed or non-convex quads).

Solver: a minimum-displacement Gauss-Newton / SQP method in the spirit of guided projection (Tang, Sun, Gomes,
Wallner & Pottmann 2014, "Form-finding with polyhedral meshes made simple"). The scale-free planarity residuals
(and, optionally, the conical angle criterion) are *hard* rows ``c(X) = s``, linearized exactly; the soft goals form
an objective ``½ (1 + start_weight)|X − X0|² + ½ α Σ (n·(X − C))² + ½ Σ w |r|²`` (displacement from the input,
distance to the reference's tangent planes, fairness / even edges / even areas) whose block-diagonal majorizer
``H`` is the step metric. Every iteration solves one sparse SPD system with one row per face,
``(J G Jᵀ) λ = rhs`` with ``G = H⁻¹`` restricted to the free / sliding directions, for two right-hand sides:
the feasibility step ``Δf`` (the minimum-norm correction in the metric) and the optimality step ``Δo`` (the soft
step projected on the linearized constraints). Phases: *restore* (``Δf`` steps with backtracking until the
tolerance is met: planarity converges quadratically), *optimize* (``Δf + tΔo`` while planarity stays within 30 ×
the tolerance and the objective decreases: this walks along the planar meshes toward the smallest displacement /
closest fit / fairest net; a step is only taken while the quadratic model, solved with the previous iteration's
factorization, promises at least 1 % of the objective and as much as moving every vertex 1 % of an edge),
*polish* (``Δf`` steps back below the tolerance). Faces above ``relax ×`` the tolerance are driven to that value,
not to 0, so a loose tolerance costs little displacement.

Panel health: the signed turn of every corner (sine of the interior angle, negative at a reflex corner) may not fall
below half of the quads' worst input value (nor below half of its own): corners that a trial step would push below
become hard rows (inequalities in effect: rows whose multiplier holds a turn down are released), steps are
shortened otherwise, and no face may turn non-convex. The best state seen is returned, never one worse than the
input in planarity; when the tolerance is not reached a warning says how far it is.

Public array-level functions: :func:`planarize_mesh`, and the measures re-exported from
:mod:`components.planarize.geometry` (:func:`face_planarity`, :func:`warping_height`, :func:`corner_angles`,
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

from components.core.checks import check_number, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import boundary_loops, edge_topology, face_normals, face_sizes, triangulate
from components.planarize.geometry import (
    FaceFrames,
    LoopIndex,
    corner_angles,
    corner_turns,
    face_corners,
    face_planarity,
    nonconvex_faces,
    vertex_stars,
    warping_height,
)
from components.core.proximity import TriangleIndex
from components.planarize import goals
from components.core.types import Integers, Mesh, Numbers, Points

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
_NORMAL_STIFFNESS = 20.0  # closeness (with a reference): distance to its tangent plane costs 20·closeness_weight
_KAPPA = 30.0  # optimize phase: planarity may rise to κ × tolerance while the displacement is minimized
_OPT_ITERATIONS = 20  # optimize phase: iteration cap
_OPT_STEP = 1e-3  # optimize phase ends when the optimality step moves no vertex more than this (mean edges)
_OPT_DECREASE = 0.01  # optimize phase ends when an iteration lowers the soft objective by less than this fraction
_OPT_MIN_MOVE = 0.01  # ... or promises less than moving every vertex this far (mean edges) would (½ d² each)
_TRUST = 1.0  # no vertex moves more than this (mean edges) in one iteration
_GUARD_ATTEMPTS = 6  # re-solves per iteration that add corner-guard rows
_BACKTRACKS = 10  # step halvings per solve
_STALL = 10  # iterations without improvement before giving up


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


def _vertex_normals(X, corners, N):
    VN = np.zeros_like(X)
    np.add.at(VN, corners.v, N[corners.face])
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


def _factor_spd(S):
    """Factor the SPD face-sized system (SuperLU in symmetric mode on the symmetric minimum-degree ordering; the
    orderings were benchmarked: COLAMD is 2–10× slower on these systems)."""
    S = S.tocsc()
    try:
        return spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    except RuntimeError:  # exactly singular: damp
        d = S.diagonal()
        S = S + sp.identity(S.shape[0], format="csc") * (1e-9 * (np.abs(d).max() + 1.0))
        return spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))


def _stack_rows(blocks, ncols):
    """:func:`_stack` for blocks whose triplets come row by row (rows ascending) and vertex by vertex (three
    consecutive columns ``3v, 3v+1, 3v+2``), as the hard rows do: the CSR matrix is built directly, unweighted."""
    counts, vals, cols, rr = [], [], [], []
    for blk in blocks:
        q = len(blk.r)
        counts.append(np.bincount(blk.rows, minlength=q) if q else np.zeros(0, np.int64))
        vals.append(blk.vals)
        cols.append(blk.cols)
        rr.append(blk.r)
    indptr = np.concatenate([[0], np.cumsum(np.concatenate(counts))])
    J = sp.csr_matrix((np.concatenate(vals), np.concatenate(cols), indptr), shape=(len(indptr) - 1, ncols))
    return J, np.concatenate(rr)


def _times_blocks(J, Gb):
    """``J G`` for ``J`` from :func:`_stack_rows` and ``G`` block diagonal (``Gb (n, 3, 3)``): same sparsity."""
    v3 = J.data.reshape(-1, 3)
    vert = J.indices[::3] // 3
    vals = np.einsum("ki,kij->kj", v3, Gb[vert]).ravel()
    return sp.csr_matrix((vals, J.indices, J.indptr), shape=J.shape)


class _State(NamedTuple):
    """A candidate state and what the acceptance tests need."""

    X: np.ndarray
    tangents: np.ndarray  # unit tangents of the boundary segments under the sliding vertices
    score: float  # max over faces of planarity / tolerance (and conical criterion / its tolerance)
    turn: np.ndarray  # corner turns (sine of the interior angle, signed)
    angle: np.ndarray  # unsigned corner angles
    nonconvex: int  # faces with a corner turning the wrong way (among the guarded faces)
    healthy: bool
    planarity: np.ndarray  # (m,) the reported scale-free planarity of every face


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
    relax: float = 0.9,
    optimize_iterations: int = _OPT_ITERATIONS,
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
        Weight of the pull toward the reference: distance to its tangent plane at the closest point, costing
        ``20 × closeness_weight`` against a displacement of the same length (in mean edge lengths). Without a
        reference, moving along the start normals costs ``1 + closeness_weight`` times moving tangentially.
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
    relax : float
        Faces above ``relax × tolerance`` are driven to that value, not to 0 (in ``(0, 1]``; smaller values leave
        more margin, larger ones move less).
    optimize_iterations : int
        Cap of the optimize phase (walking along the planar meshes toward the smallest displacement / closest fit /
        fairest net once the tolerance is met); 0 skips it: fastest, the plain minimum-norm Gauss-Newton result.
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
    w_close = check_number(closeness_weight, "closeness_weight", 0)
    w_start = check_number(start_weight, "start_weight", 0)
    w_fair = check_number(fairness_weight, "fairness_weight", 0)
    w_edge = check_number(edge_length_weight, "edge_length_weight", 0)
    w_area = check_number(area_weight, "area_weight", 0)
    w_con = check_number(conical_weight, "conical_weight", 0)
    t_edge = check_number(target_edge_length, "target_edge_length", 0)
    t_area = check_number(target_area, "target_area", 0)
    tol = check_number(tolerance, "tolerance", 0)
    atol = check_number(absolute_tolerance, "absolute_tolerance", 0)
    budget = check_number(time_budget, "time_budget", 0)
    guard = check_number(angle_guard, "angle_guard", 0)
    if guard >= 1:
        raise InputError("angle_guard", f"must be below 1, got {guard}")
    relax = check_number(relax, "relax", 0)
    if relax > 1:
        raise InputError("relax", f"must be at most 1, got {relax}")
    try:
        max_it = int(max_iterations)
    except (TypeError, ValueError):
        raise InputError("max_iterations", f"must be an integer, got {max_iterations!r}") from None
    if max_it < 0:
        raise InputError("max_iterations", f"must be non-negative, got {max_it}")
    try:
        opt_cap = int(optimize_iterations)
    except (TypeError, ValueError):
        raise InputError("optimize_iterations", f"must be an integer, got {optimize_iterations!r}") from None
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

    if reference is not None:
        XR = (Vr - center) / scale
        TR, _ = triangulate(Fr)
        NR = face_normals(XR, TR)
        ref_index = TriangleIndex(XR, TR, name="reference")
        ref_loops = boundary_loops(Fr, name="reference")
        ref_bnd_X = XR
    else:
        XR = None
        ref_loops = None  # the mesh's own loops, below
        ref_bnd_X = X0
    frames = FaceFrames(F, corners)
    area0 = frames.normals(X0, unit=False)
    N0 = _vertex_normals(X0, corners, area0)

    # ------------------------------------------------------------------ variables: fixed / sliding / free
    fixed = np.zeros(n, dtype=bool)
    slide = np.zeros(n, dtype=bool)
    loops = boundary_loops(F, name=mesh_name)
    if ref_loops is None:
        ref_loops = loops
    bmask = np.zeros(n, dtype=bool)
    for lp in loops:
        bmask[lp] = True
    pl_in = face_planarity(V, F)
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    user_fixed = ~used
    user_fixed[anchor_idx] = True
    if len(apts):
        d, i = cKDTree(V).query(apts)
        user_fixed[i] = True
        far = d > 0.5 * scale
        if far.any():
            warnings.append(
                f"anchor_points: {int(far.sum())} point(s) are more than half an edge from any vertex; "
                "their nearest vertices were anchored")
    if boundary == "fixed":
        fixed |= bmask
    elif boundary == "slide":
        if not ref_loops:
            warnings.append("boundary: the reference has no boundary to slide on; boundary vertices were fixed")
            fixed |= bmask
        else:
            slide |= bmask
            faces_per_v = np.bincount(corners.v, minlength=n)
            # corners of the boundary stay fixed: vertices where the boundary turns by more than 40°, both at the
            # next vertices and over three vertices each way (a staircase boundary along a smooth curve, as remeshing
            # leaves, turns sharply at every step but not at the larger scale)
            corner = np.zeros(n, dtype=bool)
            for lp in loops:
                sharp = np.ones(len(lp), dtype=bool)
                for k in (1, min(3, max(1, len(lp) // 4))):
                    a = X0[lp] - X0[np.roll(lp, k)]
                    b = X0[np.roll(lp, -k)] - X0[lp]
                    cosang = np.einsum("ij,ij->i", a, b) / np.maximum(
                        np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
                    sharp &= cosang < math.cos(math.radians(40))
                corner[lp[sharp]] = True
            fixed |= corner
            # a face with every corner on the boundary (fixed or sliding), as the protruding quads of a jagged
            # remeshed boundary are, can rarely be made planar by sliding: its vertices that belong to no other
            # face (or, failing those, its boundary corners) are set free to leave the boundary
            locked = (fixed | slide | user_fixed)[F].all(axis=1) & (pl_in > tol)
            if locked.any():
                lone = np.zeros(n, dtype=bool)
                lone[F[locked].ravel()] = True
                release = lone & (faces_per_v <= 1) & ~user_fixed
                still = locked & ~release[F].any(axis=1)
                lone[:] = False
                lone[F[still].ravel()] = True
                release |= lone & corner & ~user_fixed
                fixed &= ~release
                slide &= ~release
                if release.any():
                    warnings.append(
                        f"boundary: {int(release.sum())} boundary vertice(s) of faces lying wholly on the boundary "
                        "were set free (no sliding on the boundary could make those faces planar)")
    fixed |= user_fixed
    slide &= ~fixed
    locked = fixed[F].all(axis=1) & (pl_in > (tol if tol > 0 else 0.0))
    if locked.any():
        warnings.append(f"{int(locked.sum())} non-planar face(s) have all their corners fixed (boundary, corners or "
                        f"anchors), e.g. face {int(np.argmax(locked))}: the tolerance cannot be reached there")
    slide_idx = np.nonzero(slide)[0]
    free_idx = np.nonzero(~fixed & ~slide)[0]
    bnd_index = LoopIndex(ref_bnd_X, ref_loops) if len(slide_idx) else None

    def project_slide(Xc):
        if bnd_index is None:
            return Xc, np.zeros((0, 3))
        q, tang = bnd_index.query(Xc[slide_idx])
        Xc = Xc.copy()
        Xc[slide_idx] = q
        return Xc, tang

    # ------------------------------------------------------------------ static goal data
    Q4 = _pseudo_quads(F, sizes)
    is_quad_row = np.zeros(len(Q4), dtype=bool)
    is_quad_row[: int((sizes == 4).sum())] = True
    ngons = np.nonzero(sizes > 4)[0]
    quads = np.nonzero(sizes == 4)[0]
    stars = vertex_stars(F, n)
    lap = _laplacian_triplets(E, n) if fairness_mode == "laplacian" else None
    conical_on = w_con > 0 and len(stars.center) > 0
    if w_con > 0 and not conical_on:
        warnings.append("conical_weight: the mesh has no interior valence-4 vertex; the conical goal was ignored")
    alpha = (_NORMAL_STIFFNESS if reference is not None else 1.0) * w_close
    w_disp = 1.0 + w_start
    soft_blocks_on = w_edge > 0 or w_area > 0
    fair_op, fair_major = None, None
    if w_fair > 0:
        fair_op, _ = _stack([goals.fairness_block(X0, stars, fairness_mode, w_fair, lap)], 3 * n)
        fa = abs(fair_op)
        # |J|ᵀ|J|1 bounds JᵀJ from above (Gershgorin): the preconditioned soft step never overshoots
        fair_major = (fa.T @ (fa @ np.ones(3 * n))).reshape(-1, 3)
    close_idx = np.nonzero(~fixed)[0]

    # ------------------------------------------------------------------ panel health
    quad_like = sizes >= 4
    turn_in, angle_in = corner_turns(X0, corners, frames.normals(X0))
    ncv_in_face = np.zeros(len(F), dtype=bool)
    ncv_in_face[corners.face[turn_in <= 0]] = True
    ncv_in_face |= ~np.any(area0 != 0.0, axis=1)
    guarded = quad_like[corners.face] & ~ncv_in_face[corners.face]  # corners the guard watches
    n_nonconvex_in = int(ncv_in_face[quad_like].sum())
    # bounds from the quads' worst corner (n-gons have natural corners near 180°): a corner may not fall below half
    # of it, nor below half of its own input value (the worst quad corner and n-gon corners keep their shape)
    ref_corners = guarded & (sizes[corners.face] == 4)
    if not ref_corners.any():
        ref_corners = guarded
    if ref_corners.any():
        lo = guard * float(np.arcsin(np.clip(turn_in[ref_corners], 0.0, 1.0)).min())
        floor_all = guard * float(angle_in[ref_corners].min())
    else:
        lo, floor_all = guard * math.pi / 2, 0.0
    margin = min(math.radians(5.0), 0.5 * lo)
    sigma_min = np.minimum(math.sin(lo), guard * np.clip(turn_in, 0.0, 1.0))  # per corner
    sigma_act = sigma_min + (math.sin(lo + margin) - math.sin(lo))
    sigma_tgt = sigma_min + (math.sin(lo + 0.5 * margin) - math.sin(lo))
    angle_floor = np.minimum(floor_all, guard * angle_in)

    # ------------------------------------------------------------------ tolerances and measures
    def tolerance_of(Xc):
        """Per-row tolerance of the scale-free residuals (absolute mode: warping height over the mean diagonal)."""
        if not use_abs:
            return np.full(len(Q4), tol)
        a, b, c, d = (Xc[Q4[:, i]] for i in range(4))
        md = 0.5 * (np.linalg.norm(c - a, axis=1) + np.linalg.norm(d - b, axis=1)) * scale
        return atol / np.maximum(md, 1e-300)

    def evaluate(Xc, tang):
        r = np.abs(goals.planarity_residual(Xc, Q4))
        pl = np.zeros(len(F))
        pl[quads] = r[is_quad_row]  # the diagonal distance over the mean diagonal: the reported quad measure
        sc = float(np.max(r[is_quad_row] / tolerance_of(Xc)[is_quad_row])) if is_quad_row.any() else 0.0
        if len(ngons):  # the reported n-gon measure (least-squares plane), not the pseudo-quad rows
            pl[ngons] = face_planarity(Xc, F[ngons])
            if use_abs:
                sc = max(sc, float(warping_height(Xc * scale, F[ngons]).max()) / atol)
            else:
                sc = max(sc, float(pl[ngons].max()) / tol)
        if conical_on:
            sc = max(sc, float(np.abs(goals.conical_residual(Xc, corners, stars)).max()) / CONICAL_TOLERANCE)
        turn, ang = corner_turns(Xc, corners, frames.normals(Xc))
        bad = turn <= 0
        ncv = np.zeros(len(F), dtype=bool)
        ncv[corners.face[bad & guarded]] = True
        nconv = int(ncv.sum()) + n_nonconvex_in
        healthy = True
        if guarded.any():
            healthy = bool(np.all(turn[guarded] >= sigma_min[guarded]) and np.all(ang[guarded] >= angle_floor[guarded])
                           and not ncv.any())
        return _State(Xc, tang, sc, turn, ang, nconv, healthy, pl)

    def met(st):
        """Tolerance reached (the score holds the reported n-gon measure, and the conical criterion when on)."""
        return st.score <= 1.0

    last_query = [None, None]  # the latest closest-point query (positions, result): trial → accepted → next step

    def ref_query(Xc):
        if last_query[0] is not Xc:
            last_query[:] = [Xc, ref_index.query(Xc)]
        return last_query[1]

    def measures(st):
        if XR is not None:
            d = ref_query(st.X).distances
        else:
            d = np.linalg.norm(st.X - X0, axis=1)
        return st.planarity, d * scale

    # ------------------------------------------------------------------ one step
    def soft_terms(Xc, value_only=False):
        """Value, gradient ``g (n, 3)`` and a block-diagonal majorizer ``H (n, 3, 3)`` of the soft objective:
        ``½ (1 + start_weight) |X − X0|²`` (minimal displacement) ``+ ½ α (n·(X − C))²`` (closeness: distance to the
        tangent plane of the reference at the closest point) ``+ ½ Σ w |r|²`` (fairness, even edges / areas)."""
        g = w_disp * (Xc - X0)
        f = 0.5 * float(np.einsum("ij,ij->", g, Xc - X0))
        if alpha > 0 and len(close_idx):
            if XR is not None:
                res = ref_query(Xc)
                C, Nc = res.points[close_idx], NR[res.faces[close_idx]]
            else:
                C, Nc = X0[close_idx], N0[close_idx]
            dist = np.einsum("ij,ij->i", Xc[close_idx] - C, Nc)
            f += 0.5 * alpha * float(np.square(dist).sum())
        if w_fair > 0:  # linear in X: the operator and its majorizer are built once
            rf = fair_op @ Xc.ravel()
            f += 0.5 * float(np.square(rf).sum())
        if soft_blocks_on:
            blocks = []
            if w_edge > 0:
                blocks.append(goals.edge_length_block(Xc, E, t_edge / scale, w_edge))
            if w_area > 0:
                blocks.append(goals.area_block(Xc, F, corners, t_area / scale**2, w_area))
            J, r = _stack(blocks, 3 * n)
            f += 0.5 * float(np.square(r).sum())
        if value_only:
            return f
        H = np.zeros((n, 3, 3))
        H[:, [0, 1, 2], [0, 1, 2]] = w_disp
        if alpha > 0 and len(close_idx):
            g[close_idx] += alpha * dist[:, None] * Nc
            H[close_idx] += alpha * Nc[:, :, None] * Nc[:, None, :]
        if w_fair > 0:
            g += (fair_op.T @ rf).reshape(-1, 3)
            H[:, [0, 1, 2], [0, 1, 2]] += fair_major
        if soft_blocks_on:
            g += (J.T @ r).reshape(-1, 3)
            Ja = abs(J)
            H[:, [0, 1, 2], [0, 1, 2]] += (Ja.T @ (Ja @ np.ones(3 * n))).reshape(-1, 3)
        return g, H, f

    def inverse_metric(H, tang):
        """``G = P (Pᵀ H P)⁻¹ Pᵀ`` as ``(n, 3, 3)`` blocks: free vertices move in 3D, sliding ones along their
        boundary tangent, fixed ones not."""
        Gb = np.zeros((n, 3, 3))
        if len(free_idx):
            if alpha > 0:
                Gb[free_idx] = np.linalg.inv(H[free_idx])
            else:  # diagonal metric
                Gb[free_idx, [[0], [1], [2]], [[0], [1], [2]]] = 1.0 / H[free_idx][:, [0, 1, 2], [0, 1, 2]].T
        if len(slide_idx):
            q = np.einsum("ij,ijk,ik->i", tang, H[slide_idx], tang)
            Gb[slide_idx] = tang[:, :, None] * tang[:, None, :] / q[:, None, None]
        return Gb

    def hard_rows(Xc, guard_sel, Nf):
        """Hard rows ``J Δ = −(r − s)``: planarity (relaxed to ``0.9 ×`` the tolerance where above it), conical
        criterion, corner-turn guard."""
        blk = goals.planarity_block(Xc, Q4, 1.0)
        tau = relax * tolerance_of(Xc)
        target = np.where(is_quad_row, np.clip(blk.r, -tau, tau), 0.0)
        blocks = [blk._replace(r=blk.r - target)]
        if conical_on:
            blocks.append(goals.conical_block(Xc, corners, stars, 1.0))
        n_guard_from = sum(len(b.r) for b in blocks)
        if len(guard_sel):
            # a guarded corner below the bound is lifted to it; one above may not turn further (the row is an
            # inequality in effect: rows whose multiplier would hold the turn down are released by the caller)
            turn_now = corner_turns(Xc, corners, Nf)[0][guard_sel]
            blocks.append(goals.turn_block(Xc, corners, guard_sel, Nf, np.maximum(turn_now, sigma_tgt[guard_sel])))
        J, r = _stack_rows(blocks, 3 * n)
        return J, r, n_guard_from

    # ------------------------------------------------------------------ iterate
    Xs, tangents = project_slide(X0)
    cur = evaluate(Xs, tangents)
    start_score = cur.score
    pl, cl = measures(cur)
    hist = dict(maxp=[float(pl.max())], meanp=[float(pl.mean())], maxc=[float(cl.max())],
                meanc=[float(cl.mean())], t=[time.perf_counter() - t0])
    best = cur
    stop_reason = ""
    it = 0
    converged = met(cur)
    if converged:
        stop_reason = "tolerance reached (input already planar)"
    ndof = 3 * len(free_idx) + len(slide_idx)
    if ndof == 0 and not converged:
        stop_reason = "no free vertex to move"
    # phases: "restore" (minimum-norm Gauss-Newton steps in the metric of the soft goals until the tolerance is
    # met), "optimize" (those steps plus t × the soft goals' step projected on the constraints, i.e. toward the
    # minimum displacement / soft objective on the planar meshes, while planarity stays within κ × tolerance),
    # "polish" (restore steps again until the tolerance is met)
    phase = "restore"
    t_opt = 1.0
    opt_its = 0
    since_best = 0
    sticky = np.zeros(len(corners.v), dtype=bool)
    guard_reset = False  # the sticky guard rows were dropped once after a failed step
    feasible_best = None  # (state, soft objective) of the best state that met the tolerance

    def f_of(st):
        return soft_terms(st.X, value_only=True)

    def predicted_gain(Xc, soft, last):
        """Decrease of the soft objective that the next optimize step promises, from the quadratic model at ``Xc``
        with the previous iteration's factorization (one more solve, no new factor): ``f − m(Δf + Δo)``."""
        g_, H_, f_ = soft
        J_, JG_, lu_, Gb_, n_hard = last
        rr = np.zeros(J_.shape[0])
        res = goals.planarity_residual(Xc, Q4)
        tau = relax * tolerance_of(Xc)
        rr[: len(Q4)] = res - np.where(is_quad_row, np.clip(res, -tau, tau), 0.0)
        if conical_on:
            rr[len(Q4): n_hard] = goals.conical_residual(Xc, corners, stars)
        gf_ = g_.ravel()
        lam = lu_.solve(JG_ @ gf_ - rr)
        step = (JG_.T @ lam).reshape(-1, 3) - np.einsum("nij,nj->ni", Gb_, g_)
        gain = -float(np.einsum("ij,ij->", g_, step)) - 0.5 * float(np.einsum("ni,nij,nj->", step, H_, step))
        return gain, f_

    soft_cache = None  # (X, soft_terms(X)) of the current state, when the optimize test computed it
    last_fact = None  # (J, JG, lu, G blocks, hard rows without guards) of the latest accepted step

    while not stop_reason:
        if converged:
            if phase == "restore" and opt_cap > 0 and time.perf_counter() - t0 < 0.5 * budget:
                phase = "optimize"
            elif phase != "optimize":
                stop_reason = "tolerance reached"
                break
        if phase == "optimize" and last_fact is not None:
            soft_cache = (cur.X, soft_terms(cur.X))
            gain, f_here = predicted_gain(cur.X, soft_cache[1], last_fact)
            log.debug("   optimize test: predicted gain %.4g of f %.6g (%.3g%%)", gain, f_here,
                      100 * gain / max(f_here, 1e-300))
            if gain < _OPT_DECREASE * f_here or gain < 0.5 * _OPT_MIN_MOVE**2 * ndof / 3.0:
                # the next optimize step promises too little: polish (when needed) and stop
                phase = "polish"
                since_best = 0
                converged = met(cur)
                continue
        if it >= max_it:
            stop_reason = f"iteration cap ({max_it}) reached"
            break
        if time.perf_counter() - t0 > budget:
            stop_reason = f"time budget ({budget:g} s) reached"
            break
        X = cur.X
        g, H, f_cur = soft_cache[1] if soft_cache is not None and soft_cache[0] is X else soft_terms(X)
        soft_cache = None
        Gb = inverse_metric(H, cur.tangents)
        gf = g.ravel()
        Ggf = np.einsum("nij,nj->ni", Gb, g).ravel()
        Nf = frames.normals(X)
        guard_sel = guarded & ((cur.turn < sigma_act) | sticky)
        optimize = phase == "optimize"
        t = t_opt if optimize else 0.0
        accepted = None
        singular = False
        for attempt in range(_GUARD_ATTEMPTS):
            sel = np.nonzero(guard_sel)[0]
            J, r, g0 = hard_rows(X, sel, Nf)
            JG = _times_blocks(J, Gb)
            S = (JG @ J.T).tocsc()
            eps = 1e-10 * float(S.diagonal().mean()) + 1e-14
            try:
                lu = _factor_spd(S + sp.identity(S.shape[0], format="csc") * eps)
            except RuntimeError:  # singular even when damped (coincident vertices, collapsed faces)
                singular = True
                break
            lam_f = lu.solve(-r)
            df = (JG.T @ lam_f).reshape(-1, 3)
            if optimize:
                lam_o = lu.solve(JG @ gf)
                do = (JG.T @ lam_o - Ggf).reshape(-1, 3)
            else:
                lam_o, do = np.zeros_like(lam_f), np.zeros_like(df)
            if not (np.all(np.isfinite(df)) and np.all(np.isfinite(do))):
                break
            if len(sel) and attempt == 0:
                # the guard rows are inequalities: a row whose multiplier pushes its turn down is not binding
                loose = lam_f[g0:] + t * lam_o[g0:] < 0
                if loose.any():
                    guard_sel[sel[loose]] = False
                    sticky[sel[loose]] = False
                    continue
            move = float(np.linalg.norm(df, axis=1).max())
            beta = min(1.0, _TRUST / move) if move > 0 else 1.0
            need_resolve = False
            for _ in range(_BACKTRACKS):
                Xt, tt = project_slide(X + beta * df + t * do)
                trial = evaluate(Xt, tt)
                if not trial.healthy:
                    log.debug("   unhealthy beta %.3g t %.3g: min turn %.3g (>= %.3g) min angle %.1f (>= %.1f) "
                              "ncv %d", beta, t, trial.turn[guarded].min(), math.sin(lo),
                              math.degrees(trial.angle[guarded].min()), math.degrees(floor_all), trial.nonconvex)
                    new = guarded & ((trial.turn < sigma_act) | (trial.angle < angle_floor)) & ~guard_sel
                    if new.any() and attempt < _GUARD_ATTEMPTS - 1:
                        guard_sel |= new
                        sticky |= new
                        need_resolve = True
                        break
                elif optimize:
                    f_new = soft_terms(trial.X, value_only=True)
                    log.debug("   optimize trial t %.3g: score %.3g f %.6g -> %.6g", t, trial.score, f_cur, f_new)
                    if trial.score <= _KAPPA and f_new < f_cur:
                        accepted = trial
                        break
                elif trial.score < cur.score:
                    accepted = trial
                    break
                if optimize:
                    t *= 0.5
                    if t < 1.0 / 64:
                        break
                else:
                    beta *= 0.5
            if accepted is not None or not need_resolve:
                break
        if singular:
            stop_reason = "the linear system is singular (coincident vertices or collapsed faces in the mesh)"
            break
        if accepted is None:
            if optimize:  # no soft progress left within the tolerance band: polish
                phase = "polish"
                since_best = 0
                converged = met(cur)
                continue
            if sticky.any() and not guard_reset:  # the guard rows kept from earlier steps may be what blocks
                sticky[:] = False  # this one: retry once with only the corners the current state needs
                guard_reset = True
                continue
            stop_reason = ("no step keeps the panels healthy (corner angle / convexity guard)"
                           if best.score > 1.0 else "no further progress")
            break
        guard_reset = False
        it += 1
        cur = accepted
        last_fact = (J, JG, lu, Gb, g0)
        pl, cl = measures(cur)
        hist["maxp"].append(float(pl.max()))
        hist["meanp"].append(float(pl.mean()))
        hist["maxc"].append(float(cl.max()))
        hist["meanc"].append(float(cl.mean()))
        hist["t"].append(time.perf_counter() - t0)
        step_opt = t * float(np.abs(do).max()) if optimize else 0.0
        log.debug("planarize it %d (%s): score %.3g max %.3e t %.3g beta %.3g opt step %.2e guard rows %d",
                  it, phase, cur.score, pl.max(), t, beta, step_opt, int(guard_sel.sum()))
        if cur.score < best.score:
            best = cur
            since_best = 0
        else:
            since_best += 1
        converged = met(cur)
        if converged and (feasible_best is None or f_of(cur) < feasible_best[1]):
            feasible_best = (cur, f_of(cur))
        if optimize:
            opt_its += 1
            t_opt = min(1.0, 2.0 * t)
            if (opt_its >= opt_cap or step_opt < _OPT_STEP or f_cur - f_new < _OPT_DECREASE * f_cur
                    or time.perf_counter() - t0 > 0.5 * budget):
                phase = "polish"
                since_best = 0
        elif since_best >= _STALL and not converged:
            stop_reason = f"stalled (no improvement in {_STALL} iterations)"

    if not converged and feasible_best is not None:  # an earlier state met the tolerance: return the best of them
        cur, converged = feasible_best[0], True
        stop_reason = f"tolerance reached (best state that met it; then {stop_reason})"
    final = cur if converged else best
    Xb = final.X
    Vout = Xb * scale + center
    Vout[fixed] = V[fixed]  # exactly unmoved
    pl = face_planarity(Vout, F)
    if XR is not None:
        d = TriangleIndex(Vr, triangulate(Fr)[0], name="reference").query(Vout).distances
    else:
        d = np.linalg.norm(Vout - V, axis=1)
    ang, ncv_out = frames.shape(Vout)
    n_ncv = int(ncv_out[quad_like].sum())
    min_angle = float(ang.min()) if len(ang) else math.pi
    # the conical criterion ω1 − ω2 + ω3 − ω4 from the corner angles of the stars
    con = float(np.abs(ang[stars.corners] @ np.array([1.0, -1.0, 1.0, -1.0])).max()) if len(stars.center) else 0.0
    max_warp = float(warping_height(Vout, F).max()) if len(F) else 0.0
    if not converged:
        target = f"warping height {atol:g}" if use_abs else f"planarity {tol:g}"
        what = f"max planarity {pl.max():.3g}"
        if use_abs:
            what = f"max warping height {max_warp:.3g}"
        if conical_on:
            what += f", conical criterion {con:.3g} rad"
        warnings.append(f"tolerance not reached ({stop_reason}): best state has {what} (target {target}); "
                        f"it was returned")
        if best.score >= start_score and it > 0:
            warnings.append("no iteration improved on the input; the input mesh was returned")
    min_angle_in = float(angle_in.min()) if len(angle_in) else math.pi
    if min_angle < min_angle_in - 1e-9 and min_angle < 0.75 * min_angle_in:
        warnings.append(f"worst corner angle degraded from {math.degrees(min_angle_in):.1f}° to "
                        f"{math.degrees(min_angle):.1f}°")
    if n_ncv > n_nonconvex_in:
        warnings.append(f"non-convex faces increased from {n_nonconvex_in} to {n_ncv}")
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
        worst_corner_angle=math.degrees(min_angle),
        nonconvex_faces=n_ncv,
        max_warping_height=max_warp,
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
    met by a minimum-norm correction in the metric of the soft goals (one sparse SPD solve in the face-sized
    system per iteration); once met, the solver walks along the planar meshes toward the smallest displacement
    and closest fit to the reference, then polishes back below the tolerance. Corners approaching a collapse
    (below half the input's worst corner) or a fold become hard rows, and steps that would still make unhealthy
    panels are shortened. With ``boundary="slide"``, boundary corners (sharp at two scales) stay fixed and the
    lone corners of faces lying wholly on the boundary are set free (a warning says so). Which tolerance applies: ``tolerance > 0`` → scale-free planarity;
    ``tolerance == 0`` and ``absolute_tolerance > 0`` → warping height in model units; both 0 → 1e-4 scale-free.

    Example
    -------
    >>> from components.core.mesh import quad_grid
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
    >>> from components.core.mesh import quad_grid
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
