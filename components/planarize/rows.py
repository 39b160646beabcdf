"""Goal rows of the planarization solver: the goal blocks of :mod:`components.planarize.goals` assembled into the
system of one iteration.

* the **soft goals** (displacement, closeness, fairness, even edges / areas) as a value, a gradient and a
  block-diagonal majorizer ``H (n, 3, 3)`` (:func:`soft_terms`), and the step metric ``G = H⁻¹`` restricted to
  the free and sliding directions (:func:`inverse_metric`);
* the **hard rows** ``J Δ = −(r − s)``: planarity relaxed to ``relax ×`` the tolerance, the conical criterion and
  the guard rows (corner turns, edge lengths, face areas, folds: :func:`hard_rows`);
* the sparse assembly they share (:func:`stack`, :func:`stack_rows`, :func:`times_blocks`).

Functions taking ``prob`` take a :class:`components.planarize.problem.Problem`; positions ``X (n, 3)`` are in
its normalized units.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from components.planarize import goals

__all__ = ["stack", "stack_rows", "times_blocks", "tolerance_of", "soft_terms", "inverse_metric", "hard_rows",
           "hard_residual"]


# ----------------------------------------------------------------------------------------------
# sparse assembly


def stack(blocks, ncols):
    """Stack weighted residual blocks into one sparse Jacobian ``J`` and residual ``r`` (rows scaled by √w).

    Example
    -------
    >>> import numpy as np
    >>> from components.planarize.goals import Block
    >>> blk = Block(np.array([1.0]), np.array([0]), np.array([2]), np.array([3.0]), 4.0)
    >>> J, r = stack([blk], 3)
    >>> J.toarray().tolist(), r.tolist()
    ([[0.0, 0.0, 6.0]], [2.0])
    """
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


def stack_rows(blocks, ncols):
    """:func:`stack` for blocks whose triplets come row by row (rows ascending) and vertex by vertex (three
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


def times_blocks(J, Gb):
    """``J G`` for ``J`` from :func:`stack_rows` and ``G`` block diagonal (``Gb (n, 3, 3)``): same sparsity."""
    v3 = J.data.reshape(-1, 3)
    vert = J.indices[::3] // 3
    vals = np.einsum("ki,kij->kj", v3, np.take(Gb, vert, axis=0)).ravel()  # take: a faster gather of the blocks
    return sp.csr_matrix((vals, J.indices, J.indptr), shape=J.shape)


# ----------------------------------------------------------------------------------------------
# soft goals and the step metric


def soft_terms(prob, X, value_only=False):
    """Value ``f``, gradient ``g (n, 3)`` and a block-diagonal majorizer ``H (n, 3, 3)`` of the soft objective
    (``f`` alone with ``value_only``): ``½ (1 + start_weight) |X − X0|²`` (minimal displacement) ``+ ½ α (n·(X −
    C))²`` (closeness: distance to the tangent plane of the reference at the closest point) ``+ ½ Σ w |r|²``
    (fairness, even edges / areas) ``+ ½ w_s |(I − t tᵀ)(x − q)|²`` over the boundary vertices by a staircase of the
    reference (``prob.stair_idx``: distance across the smoothed staircase, ``q`` the closest point on it, ``t`` its
    tangent; see :func:`components.planarize.problem.setup_problem`).

    Returns
    -------
    (g, H, f), or f when ``value_only``.
    """
    opts, n, close_idx, alpha = prob.opts, prob.n, prob.close_idx, prob.alpha
    g = prob.w_disp * (X - prob.X0)
    f = 0.5 * float(np.einsum("ij,ij->", g, X - prob.X0))
    if alpha > 0 and len(close_idx):
        if prob.XR is not None:
            res = prob.reference_query(X)
            C, Nc = res.points[close_idx], prob.reference_normals(res, close_idx)
        else:
            C, Nc = prob.X0[close_idx], prob.N0[close_idx]
        dist = np.einsum("ij,ij->i", X[close_idx] - C, Nc)
        f += 0.5 * alpha * float(np.square(dist).sum())
    stair = prob.stair_idx
    if len(stair):  # boundary vertices by a staircase: pulled toward its smoothed curve, free along it
        q, tang = prob.stair_index.query(X[stair])
        off = X[stair] - q
        off -= np.einsum("ij,ij->i", off, tang)[:, None] * tang
        w_stair = prob.stair_weight
        f += 0.5 * w_stair * float(np.einsum("ij,ij->", off, off))
    if opts.fairness_weight > 0:  # linear in X: the operator and its majorizer are built once
        rf = prob.fair_op @ X.ravel()
        f += 0.5 * float(np.square(rf).sum())
    soft_blocks_on = opts.edge_length_weight > 0 or opts.area_weight > 0
    if soft_blocks_on:
        blocks = []
        if opts.edge_length_weight > 0:
            blocks.append(goals.edge_length_block(X, prob.E, opts.target_edge_length / prob.scale,
                                                  opts.edge_length_weight))
        if opts.area_weight > 0:
            blocks.append(goals.area_block(X, prob.F, prob.corners, opts.target_area / prob.scale**2,
                                           opts.area_weight))
        J, r = stack(blocks, 3 * n)
        f += 0.5 * float(np.square(r).sum())
    if value_only:
        return f
    H = np.zeros((n, 3, 3))
    H[:, [0, 1, 2], [0, 1, 2]] = prob.w_disp
    if alpha > 0 and len(close_idx):
        g[close_idx] += alpha * dist[:, None] * Nc
        H[close_idx] += alpha * Nc[:, :, None] * Nc[:, None, :]
    if len(stair):
        g[stair] += w_stair * off
        H[stair] += w_stair * (np.eye(3)[None] - tang[:, :, None] * tang[:, None, :])
    if opts.fairness_weight > 0:
        g += (prob.fair_op.T @ rf).reshape(-1, 3)
        H[:, [0, 1, 2], [0, 1, 2]] += prob.fair_major
    if soft_blocks_on:
        g += (J.T @ r).reshape(-1, 3)
        Ja = abs(J)
        H[:, [0, 1, 2], [0, 1, 2]] += (Ja.T @ (Ja @ np.ones(3 * n))).reshape(-1, 3)
    return g, H, f


def _inverse_3x3(H):
    """Inverses ``(k, 3, 3)`` of symmetric positive definite blocks ``H (k, 3, 3)`` by the adjugate (a few times
    faster than ``np.linalg.inv`` on many small blocks; the blocks are the identity plus positive terms, far from
    singular)."""
    a, b, c = H[:, 0, 0], H[:, 0, 1], H[:, 0, 2]
    d, e, f = H[:, 1, 1], H[:, 1, 2], H[:, 2, 2]
    A = d * f - e * e
    B = c * e - b * f
    C = b * e - c * d
    det = a * A + b * B + c * C
    out = np.empty_like(H)
    out[:, 0, 0] = A
    out[:, 0, 1] = out[:, 1, 0] = B
    out[:, 0, 2] = out[:, 2, 0] = C
    out[:, 1, 1] = a * f - c * c
    out[:, 1, 2] = out[:, 2, 1] = b * c - a * e
    out[:, 2, 2] = a * d - b * b
    return out / det[:, None, None]


def inverse_metric(prob, H, tang):
    """``G = P (Pᵀ H P)⁻¹ Pᵀ`` as ``(n, 3, 3)`` blocks: free vertices move in 3D, sliding ones along their
    boundary tangent ``tang (s, 3)``, fixed ones not."""
    free_idx, slide_idx = prob.free_idx, prob.slide_idx
    Gb = np.zeros((prob.n, 3, 3))
    if len(free_idx):
        if prob.alpha > 0 or len(prob.stair_idx):
            Gb[free_idx] = _inverse_3x3(H[free_idx])
        else:  # diagonal metric
            Gb[free_idx, [[0], [1], [2]], [[0], [1], [2]]] = 1.0 / H[free_idx][:, [0, 1, 2], [0, 1, 2]].T
    if len(slide_idx):
        q = np.einsum("ij,ijk,ik->i", tang, H[slide_idx], tang)
        Gb[slide_idx] = tang[:, :, None] * tang[:, None, :] / q[:, None, None]
    return Gb


# ----------------------------------------------------------------------------------------------
# hard rows


def tolerance_of(prob, X) -> np.ndarray:
    """Per-row tolerance ``(q,)`` of the scale-free planarity rows (absolute mode: the warping height over the mean
    diagonal)."""
    opts = prob.opts
    if not opts.use_abs:
        return np.full(len(prob.Q4), opts.tolerance)
    a, b, c, d = (X[prob.Q4[:, i]] for i in range(4))
    md = 0.5 * (np.linalg.norm(c - a, axis=1) + np.linalg.norm(d - b, axis=1)) * prob.scale
    return opts.absolute_tolerance / np.maximum(md, 1e-300)


def _relaxed_target(prob, X, r):
    """Targets of the planarity rows: a quad row above ``relax ×`` its tolerance is driven to that value, not 0."""
    tau = prob.opts.relax * tolerance_of(prob, X)
    return np.where(prob.is_quad_row, np.clip(r, -tau, tau), 0.0)


def hard_rows(prob, X, sel, targets, flip_normals=None):
    """Hard rows ``J Δ = −(r − s)``: planarity (relaxed, see :func:`_relaxed_target`), the conical criterion when on,
    and one guard row per selected guard item ``sel`` (ascending indices into the items of
    :mod:`components.planarize.guard`: corner sharpness, corner turns, edges, faces, hinges of interior edges, faces
    against the reference's normals ``flip_normals (m, 3)``).

    A guarded item below its target (``targets``, one per selected item: a corner's sharpness or turn (about the
    face normal at ``X``, held fixed), an edge length, a face area, the normals' dot product across an edge, a face
    normal's with the reference's) is lifted to it; one above may not fall further (the row
    is an inequality in effect: rows whose multiplier would hold the value down are released by the caller, unless
    their item is still under its target).

    Returns
    -------
    J : (q, 3 n) CSR, r : (q,), n_hard : int
        The rows, their residuals, and the number of rows before the guard rows.
    """
    if prob._rows_memo[0] is not X:  # the same at every solve of one iteration (only the guard rows change)
        blk = goals.planarity_block(X, prob.Q4, 1.0)
        base = [blk._replace(r=blk.r - _relaxed_target(prob, X, blk.r))]
        if prob.conical_on:
            base.append(goals.conical_block(X, prob.corners, prob.stars, 1.0))
        prob._rows_memo = (X, base)
    blocks = list(prob._rows_memo[1])
    n_hard = sum(len(b.r) for b in blocks)
    sel = np.asarray(sel, dtype=np.int64)
    targets = np.broadcast_to(np.asarray(targets, dtype=np.float64), sel.shape)
    c, e, m = len(prob.corners.v), len(prob.E), len(prob.F)
    i = len(prob.inner_faces)
    group = np.searchsorted(np.cumsum([c, c, e, m, i]), sel, side="right")  # 0 sharpness .. 4 folds, 5 flips
    for kind in range(6):
        pick = group == kind
        if not pick.any():
            continue
        idx = sel[pick] - (0, c, 2 * c, 2 * c + e, 2 * c + e + m, 2 * c + e + m + i)[kind]
        if kind == 0:
            blk = goals.sharpness_guard_block(X, prob.corners, idx, 0.0)
        elif kind == 1:
            if prob._normals_memo[0] is not X:  # the same at every solve of one iteration
                prob._normals_memo = (X, prob.frames.normals(X))
            blk = goals.turn_block(X, prob.corners, idx, prob._normals_memo[1], 0.0)
        elif kind == 2:
            blk = goals.edge_guard_block(X, prob.E, idx, 0.0)
        elif kind == 3:
            blk = goals.area_guard_block(X, prob.F, idx, 0.0)
        elif kind == 4:
            blk = goals.fold_guard_block(X, prob.F, prob.inner_faces[idx], 0.0)
        else:
            blk = goals.flip_guard_block(X, prob.F, idx, flip_normals[idx], 0.0)
        blocks.append(blk._replace(r=blk.r - np.maximum(blk.r, targets[pick])))  # lift to the target, or hold
    J, r = stack_rows(blocks, 3 * prob.n)
    return J, r, n_hard


def hard_residual(prob, X, n_rows, n_hard):
    """Residuals ``(n_rows,)`` of the planarity and conical rows at ``X`` (guard rows zero), in :func:`hard_rows`
    order: the right-hand side of a solve with an earlier factorization."""
    rr = np.zeros(n_rows)
    res = goals.planarity_residual(X, prob.Q4)
    rr[: len(prob.Q4)] = res - _relaxed_target(prob, X, res)
    if prob.conical_on:
        rr[len(prob.Q4): n_hard] = goals.conical_residual(X, prob.corners, prob.stars)
    return rr
