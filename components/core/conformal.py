"""Conformal parametrization of disk-like surfaces onto the plane.

Two maps, both on triangle meshes (polygon meshes are fan-triangulated first):

* :func:`lscm` — least-squares conformal maps (Lévy, Petitjean, Ray, Maillot 2002) with a free boundary, in the
  form "Dirichlet energy minus signed image area" (Hutchinson; Mullen, Tong, Alliez, Desbrun 2008), two pinned
  vertices; or the spectral variant of Mullen et al. (no pins, smallest non-trivial generalized eigenvector).
* :func:`disk_map` — a fixed-boundary map onto the unit disk or the unit square (the "unit plane" of the paper):
  the boundary is laid out by arc length (the square's corners at the sharpest boundary turns), the interior is the
  discrete harmonic (cotangent-weight) extension; when cotangent weights flip triangles it falls back to Floater's
  mean-value weights, which provably embed a mesh with a convex boundary.

:func:`conformal_distortion` measures any map: per-triangle quasi-conformal ratio σ1/σ2 of the Jacobian, the
largest corner-angle change, and flipped triangles. :func:`conformal_map` is the published component.
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from components.core.checks import check_choice, check_mesh, pieces_error, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.measures import triangle_angles
from components.core.memo import ContentCache, digest
from components.core.mesh import boundary_loops, edge_topology, triangulate
from components.core.types import Mesh, Points

log = logging.getLogger(__name__)

__all__ = [
    "ConformalDistortion",
    "ConformalMapResult",
    "cached_boundary_loops",
    "conformal_distortion",
    "conformal_map",
    "cotan_laplacian",
    "disk_map",
    "lscm",
]


# ----------------------------------------------------------------------------------------------
# building blocks


_LOOPS = ContentCache("boundary loops", entries=2)  # the last surfaces' loops (cached_boundary_loops)


def cached_boundary_loops(T: np.ndarray, name: str = "mesh") -> list[np.ndarray]:
    """:func:`components.core.mesh.boundary_loops` of ``T``, found once per content (by a digest of the array): the
    network strategy asks for the design surface's loops when it traces, plane-maps (twice) and rebuilds (~6 ms
    each at 20k triangles). Fresh copies are returned, so a caller may change them; an error is raised again for
    every call, naming ``name``.

    >>> from components.core.mesh import quad_grid, triangulate
    >>> T = triangulate(quad_grid(3, 3)[1])[0]
    >>> [loop.tolist() for loop in cached_boundary_loops(T)] == [loop.tolist() for loop in boundary_loops(T)]
    True
    >>> cached_boundary_loops(T)[0] is cached_boundary_loops(T.copy())[0]
    False
    """
    loops = _LOOPS.get(digest(T), lambda: boundary_loops(T, name))
    return [loop.copy() for loop in loops]


def _cotangents(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``(t, 3)`` cotangent of the angle at corner ``j`` of every triangle."""
    P0, P1, P2 = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    C = np.empty((len(T), 3))
    for j, (a, b, c) in enumerate(((P0, P1, P2), (P1, P2, P0), (P2, P0, P1))):
        u, w = b - a, c - a
        dot = np.einsum("ij,ij->i", u, w)
        cr = np.linalg.norm(np.cross(u, w), axis=1)
        C[:, j] = dot / np.maximum(cr, 1e-300)
    return C


def cotan_laplacian(V: np.ndarray, T: np.ndarray) -> sp.csr_matrix:
    """Positive semi-definite cotangent Laplacian ``L`` with ``½ uᵀ L u`` the Dirichlet energy of ``u``.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles.

    Returns
    -------
    (n, n) scipy.sparse.csr_matrix
        ``L_ij = -½ (cot α_ij + cot β_ij)`` off the diagonal, rows summing to zero.

    Notes
    -----
    Pinkall & Polthier 1993; the sign convention is the positive one (libigl's ``cotmatrix`` is ``-L``).
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    n = len(V)
    C = _cotangents(V, T)
    # the angle at corner j is opposite the edge (j+1, j+2)
    I = np.concatenate([T[:, 1], T[:, 2], T[:, 0]])
    J = np.concatenate([T[:, 2], T[:, 0], T[:, 1]])
    w = 0.5 * np.concatenate([C[:, 0], C[:, 1], C[:, 2]])
    W = sp.coo_matrix((w, (I, J)), shape=(n, n)).tocsr()
    W = W + W.T
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()


def _mean_value_weights(V: np.ndarray, T: np.ndarray) -> sp.csr_matrix:
    """Floater's mean-value weights ``w_ij = (tan(α/2) + tan(β/2)) / |p_i − p_j|`` (not symmetric, all positive)."""
    n = len(V)
    Is, Js, Ws = [], [], []
    for j in range(3):
        i, a, b = T[:, j], T[:, (j + 1) % 3], T[:, (j + 2) % 3]
        ea, eb = V[a] - V[i], V[b] - V[i]
        la, lb = np.linalg.norm(ea, axis=1), np.linalg.norm(eb, axis=1)
        cosang = np.clip(np.einsum("ij,ij->i", ea, eb) / np.maximum(la * lb, 1e-300), -1.0, 1.0)
        t = np.tan(0.5 * np.arccos(cosang))
        Is += [i, i]
        Js += [a, b]
        Ws += [t / np.maximum(la, 1e-300), t / np.maximum(lb, 1e-300)]
    W = sp.coo_matrix((np.concatenate(Ws), (np.concatenate(Is), np.concatenate(Js))), shape=(n, n)).tocsr()
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()


def _factor(A: sp.spmatrix):
    """Factor a sparse square system once; SuperLU with the ordering measured best for these systems.

    ``MMD_AT_PLUS_A`` in symmetric mode (no pivoting: the systems are SPD) was the fastest on the cotangent
    and LSCM systems measured in ``benchmarks/conformal.py``; COLAMD was ~2× slower, and MMD_AT_PLUS_A *without*
    symmetric mode did not finish in minutes on a 100k-unknown LSCM system (the sparse-solver trap).
    """
    A = sp.csc_matrix(A)
    return spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True}).solve


def _solve_refined(A: sp.spmatrix, b: np.ndarray, steps: int = 2) -> np.ndarray:
    """Solve with :func:`_factor` plus a couple of steps of iterative refinement (no pivoting in symmetric mode)."""
    A = sp.csr_matrix(A)
    solve = _factor(A)
    x = solve(b)
    for _ in range(steps):
        r = b - A @ x
        if np.linalg.norm(r) <= 1e-15 * max(np.linalg.norm(b), 1e-300):
            break
        x += solve(r)
    return x


def _signed_areas_2d(UV: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c = UV[T[:, 0]], UV[T[:, 1]], UV[T[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _triangle_mesh(V, T, name):
    """``V (n, 3)`` float64 and ``T (t, 3)`` int64 of an array-level call (degenerate triangles allowed)."""
    V, T = validate_mesh(V, T, name, allow_degenerate=True, manifold=False)
    if T.shape[1] != 3:
        raise MeshError(name, f"triangles must have shape (t, 3), got {T.shape}")
    return V, T


def _used_vertices(T, n):
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    return used


def _components(T, n):
    """Connected-component label of every vertex (through triangles)."""
    A = sp.coo_matrix((np.ones(2 * len(T)), (np.r_[T[:, 0], T[:, 1]], np.r_[T[:, 1], T[:, 2]])), shape=(n, n))
    return sp.csgraph.connected_components(A, directed=False)


def _farthest_pair(P: np.ndarray) -> tuple[int, int]:
    """Indices of the two points of ``P`` farthest apart (exact up to 20,000 points, double sweep beyond)."""
    P = P - P.mean(axis=0)
    if len(P) > 20000:
        i = int(np.argmax(np.linalg.norm(P - P[0], axis=1)))
        j = int(np.argmax(np.linalg.norm(P - P[i], axis=1)))
        return i, j
    sq = np.einsum("ij,ij->i", P, P)
    best, pair = -1.0, (0, 0)
    for s in range(0, len(P), 1024):
        D = sq[s:s + 1024, None] + sq[None, :] - 2.0 * P[s:s + 1024] @ P.T
        k = int(np.argmax(D))
        i, j = divmod(k, len(P))
        if D[i, j] > best:
            best, pair = float(D[i, j]), (s + i, j)
    return pair


# ----------------------------------------------------------------------------------------------
# LSCM


def _lscm_matrix(V: np.ndarray, T: np.ndarray) -> sp.csr_matrix:
    """``Q`` (2n, 2n) with ``½ xᵀ Q x`` = conformal energy of ``x = [u; v]`` (Dirichlet energy − signed area)."""
    n = len(V)
    L = cotan_laplacian(V, T)
    H, _ = _tri_halfedges(T)
    topo_count = _edge_counts(H)
    B_edges = H[topo_count == 1]  # boundary half-edges, oriented as their triangle
    # signed area A(u, v) = ½ Σ_(i→j) (u_i v_j − u_j v_i) = uᵀ B v
    B = sp.coo_matrix(
        (np.r_[np.full(len(B_edges), 0.5), np.full(len(B_edges), -0.5)],
         (np.r_[B_edges[:, 0], B_edges[:, 1]], np.r_[B_edges[:, 1], B_edges[:, 0]])),
        shape=(n, n),
    ).tocsr()
    return sp.bmat([[L, -B], [-B.T, L]], format="csr")


def _tri_halfedges(T):
    H = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    HF = np.tile(np.arange(len(T)), 3)
    return H, HF


def _edge_counts(H):
    """Number of half-edges on the undirected edge of every half-edge (1-D integer keys: ~10× faster than
    ``np.unique(axis=0)``)."""
    lo, hi = np.minimum(H[:, 0], H[:, 1]), np.maximum(H[:, 0], H[:, 1])
    key = lo * (int(H.max()) + 1) + hi
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    return cnt[inv]


def lscm(V: np.ndarray, T: np.ndarray, pinned=None, pinned_uv=None, method: str = "pinned") -> np.ndarray:
    """Least-squares conformal map of a triangle mesh with a free boundary.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented, with at least one boundary loop.
    pinned : (2,) int array_like, optional
        Two vertices to pin. Default: the two vertices of the longest boundary loop that are farthest apart in 3D.
    pinned_uv : (2, 2) float array_like, optional
        Their parameter positions. Default: ``(0, 0)`` and ``(|p1 − p0|, 0)``, so the map keeps the 3D scale
        (a planar patch comes back congruent).
    method : {"pinned", "spectral"}
        ``"pinned"``: minimize the conformal energy with two pinned vertices (one sparse solve).
        ``"spectral"``: no pins, the generalized eigenvector of smallest non-zero eigenvalue of the conformal
        energy against the boundary mass (Mullen et al. 2008), scaled to the 3D boundary length and rotated so
        that the default pinned pair lies along +u.

    Returns
    -------
    UV : (n, 2) float64
        Parameter coordinates (vertices no triangle uses get 0).

    Raises
    ------
    MeshError
        If the mesh has no boundary (a closed surface cannot be flattened by LSCM without a cut), if it has
        several connected components, or if the inputs have the wrong shapes.
    InputError
        For bad ``pinned`` / ``pinned_uv`` / ``method``.

    Notes
    -----
    Lévy, Petitjean, Ray, Maillot, *Least squares conformal maps for automatic texture atlas generation*,
    SIGGRAPH 2002. The energy is written as ``E_D(u) + E_D(v) − A(u, v)`` (cotangent Dirichlet energy minus the
    signed area of the image, a boundary sum), which is the LSCM energy (Mullen, Tong, Alliez, Desbrun,
    *Spectral conformal parameterization*, SGP 2008). Several boundary loops are fine for LSCM.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4)
    >>> UV = lscm(V, triangulate(Q)[0])
    >>> bool(np.allclose(np.linalg.norm(UV[1] - UV[0]), 0.25))
    True
    """
    V, T = _triangle_mesh(V, T, "mesh")
    n = len(V)
    check_choice(method, "method", ("pinned", "spectral"))
    loops = cached_boundary_loops(T)
    if not loops:
        raise MeshError("mesh", "the surface is closed (no boundary): cut it open before a conformal map")
    used = _used_vertices(T, n)
    _, labels = _components(T, n)
    if len(np.unique(labels[used])) > 1:
        raise pieces_error(V, T, len(np.unique(labels[used])), "map each one")
    Q = _lscm_matrix(V, T)
    if method == "spectral":
        return _lscm_spectral(V, T, Q, loops, used)
    if pinned is None:
        b = loops[0]
        i, j = _farthest_pair(V[b])
        pinned = np.array([b[i], b[j]], dtype=np.int64)
    else:
        try:
            pinned = np.asarray(pinned, dtype=np.int64).ravel()
        except (TypeError, ValueError):
            raise InputError("pinned", "must be two vertex indices") from None
        if len(pinned) < 2 or np.any((pinned < 0) | (pinned >= n)) or len(np.unique(pinned)) != len(pinned):
            raise InputError("pinned", f"needs at least two distinct vertex indices in 0..{n - 1}, got {pinned.tolist()}")
        if not np.all(used[pinned]):
            raise InputError("pinned", "a pinned vertex is not used by any triangle")
    if pinned_uv is None:
        if len(pinned) != 2:
            raise InputError("pinned_uv", "give the parameter positions when pinning more than two vertices")
        dist = float(np.linalg.norm(V[pinned[1]] - V[pinned[0]]))
        pinned_uv = np.array([[0.0, 0.0], [dist, 0.0]])
    else:
        pinned_uv = np.asarray(pinned_uv, dtype=np.float64)
        if pinned_uv.shape != (len(pinned), 2) or not np.all(np.isfinite(pinned_uv)):
            raise InputError("pinned_uv", f"must have shape ({len(pinned)}, 2) and be finite")
    # unknowns interleaved (u0, v0, u1, v1, ...): the minimum-degree ordering then sees the 2×2 vertex blocks
    # and the factorization is 2-3× faster than with [u; v] stacked (benchmarks/conformal.py)
    perm = np.arange(2 * n).reshape(2, n).T.ravel()
    Q = Q.tocsr()[perm][:, perm]
    fixed = np.zeros((n, 2), dtype=bool)
    fixed[pinned] = True
    fixed[~used] = True  # unused vertices: stay at 0
    fixed = fixed.ravel()
    x = np.zeros((n, 2))
    x[pinned] = pinned_uv
    x = x.ravel()
    free = ~fixed
    Qf = Q[free]
    rhs = -(Qf[:, fixed] @ x[fixed])
    x[free] = _solve_refined(Qf[:, free], rhs)
    return x.reshape(n, 2)


def _lscm_spectral(V, T, Q, loops, used):
    """Smallest non-trivial generalized eigenvector of ``Q x = λ B x`` (B: boundary lumped mass, both coords)."""
    n = len(V)
    idx = np.nonzero(used)[0]
    remap = np.full(n, -1)
    remap[idx] = np.arange(len(idx))
    m = len(idx)
    sel = np.r_[idx, idx + n]
    Qr = Q.tocsr()[sel][:, sel]
    mass = np.zeros(n)
    for loop in loops:
        seg = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)
        np.add.at(mass, loop, 0.5 * seg)
        np.add.at(mass, np.roll(loop, -1), 0.5 * seg)
    mass = mass[idx]
    Bm = sp.diags(np.r_[mass, mass]).tocsc()
    # shift-invert just below 0 (the kernel holds the two translations), with our own factorization of the
    # interleaved system: scipy's default ordering inside eigsh was 5-10x slower
    scale = float(abs(Qr.diagonal()).mean())
    sigma = -1e-6 * scale / max(mass.mean(), 1e-300)
    perm = np.arange(2 * m).reshape(2, m).T.ravel()
    inv = np.argsort(perm)
    A = (Qr - sigma * Bm).tocsr()[perm][:, perm]
    solve = _factor(A)

    def opinv(y):
        y = np.asarray(y).reshape(-1)
        return solve(y[perm])[inv]

    OPinv = spla.LinearOperator(Qr.shape, matvec=opinv, dtype=np.float64)
    vals, vecs = spla.eigsh(Qr.tocsc(), k=4, M=Bm, sigma=sigma, which="LM", OPinv=OPinv, tol=1e-10)
    ones_u = np.r_[np.ones(m), np.zeros(m)]
    ones_v = np.r_[np.zeros(m), np.ones(m)]
    best = None
    for k in np.argsort(vals):
        x = vecs[:, k]
        # discard the translation kernel: x must not be (nearly) constant in u and v
        xc = x - (x @ (Bm @ ones_u)) / (ones_u @ (Bm @ ones_u)) * ones_u
        xc = xc - (xc @ (Bm @ ones_v)) / (ones_v @ (Bm @ ones_v)) * ones_v
        if np.linalg.norm(xc) > 1e-6 * np.linalg.norm(x):
            best = xc
            break
    if best is None:  # pragma: no cover - eigsh returned only kernel vectors
        raise MeshError("mesh", "spectral LSCM found no non-trivial eigenvector")
    UVr = np.stack([best[:m], best[m:]], axis=1)
    UV = np.zeros((n, 2))
    UV[idx] = UVr
    # orientation: make the total signed area positive (the eigenvector may be the mirror of a conformal map)
    if _signed_areas_2d(UV, T).sum() < 0:
        UV[:, 1] = -UV[:, 1]
    # scale to the 3D boundary length, rotate the farthest boundary pair onto +u, first pinned to the origin
    b = loops[0]
    len3 = np.linalg.norm(V[np.roll(b, -1)] - V[b], axis=1).sum()
    len2 = np.linalg.norm(UV[np.roll(b, -1)] - UV[b], axis=1).sum()
    UV *= len3 / max(len2, 1e-300)
    i, j = _farthest_pair(V[b])
    d = UV[b[j]] - UV[b[i]]
    ang = np.arctan2(d[1], d[0])
    R = np.array([[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]])
    UV = (UV - UV[b[i]]) @ R.T
    UV[~used] = 0.0
    return UV


# ----------------------------------------------------------------------------------------------
# fixed-boundary map onto the unit disk or square


def _turning_angles(V: np.ndarray, T: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Geodesic turning ``π − (sum of the triangle angles at the vertex)`` at every boundary vertex of ``loop``."""
    n = len(V)
    angsum = np.zeros(n)
    for j in range(3):
        i, a, b = T[:, j], T[:, (j + 1) % 3], T[:, (j + 2) % 3]
        ea, eb = V[a] - V[i], V[b] - V[i]
        c = np.einsum("ij,ij->i", ea, eb) / np.maximum(np.linalg.norm(ea, axis=1) * np.linalg.norm(eb, axis=1), 1e-300)
        np.add.at(angsum, i, np.arccos(np.clip(c, -1.0, 1.0)))
    return np.pi - angsum[loop]


def _boundary_positions(V, T, loop, shape):
    """Parameter positions of the loop's vertices on the unit circle or the unit square, by arc length."""
    seg = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)
    s = np.r_[0.0, np.cumsum(seg)[:-1]]
    total = seg.sum()
    if shape == "disk":
        t = 2 * np.pi * s / total
        return np.stack([np.cos(t), np.sin(t)], axis=1), None
    # square: four corners; the sharpest turns if the boundary has four clear corners, else arc-length quarters
    b = len(loop)
    turn = _turning_angles(V, T, loop)
    cand = np.argsort(-turn)[:4]
    corners = np.sort(cand)
    clear = b >= 8 and np.all(turn[cand] > np.pi / 6) and np.all(np.diff(np.r_[corners, corners[0] + b]) >= 2)
    if not clear:
        start = int(np.argmax(turn))
        ss = (s - s[start]) % total
        corners = np.sort([start] + [int(np.argmin(np.abs(ss - q * total))) for q in (0.25, 0.5, 0.75)])
        corners = np.unique(corners)
        if len(corners) < 4:
            raise MeshError("mesh", f"the boundary has only {b} vertices: too few for a square map")
    squares = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    P = np.empty((b, 2))
    for k in range(4):
        c0, c1 = corners[k], corners[(k + 1) % 4]
        run = np.arange(c0, c1 if c1 > c0 else c1 + b) % b
        arc = np.r_[0.0, np.cumsum(seg[run])]
        w = arc[:-1] / arc[-1]
        P[run] = (1 - w)[:, None] * squares[k] + w[:, None] * squares[(k + 1) % 4]
    return P, loop[corners]


def disk_map(V: np.ndarray, T: np.ndarray, shape: str = "disk", weights: str = "auto"):
    """Fixed-boundary map of a disk-like triangle mesh onto the unit disk or the unit square.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles of a topological disk (exactly one boundary loop).
    shape : {"disk", "square"}
        Target domain: unit disk centred at the origin, or ``[0, 1]²``. The boundary is laid out by arc length;
        the square's corners are the four sharpest boundary turns when the boundary has four clear corners
        (turning > 30°), else the arc-length quarter points starting at the sharpest turn.
    weights : {"auto", "cotan", "mean_value"}
        Interior extension. ``"cotan"``: discrete harmonic (conformal in the limit; can flip triangles where
        cotangent weights are negative); ``"mean_value"``: Floater's weights, an embedding for a convex target;
        ``"auto"``: cotangent, falling back to mean-value when any triangle flips.

    Returns
    -------
    UV : (n, 2) float64
        Parameter coordinates.
    info : dict
        ``{"weights": used weights, "corners": (4,) corner vertices or None, "warnings": [str]}``.

    Raises
    ------
    MeshError
        No boundary (closed surface) or several boundary loops / handles (not a disk), several components.
    InputError
        Unknown ``shape`` or ``weights``.

    Notes
    -----
    Tutte 1963; Floater, *Mean value coordinates*, CAGD 2003; Eck et al., *Multiresolution analysis of arbitrary
    meshes*, SIGGRAPH 1995 (harmonic maps with cotangent weights).

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(4, 4)
    >>> UV, info = disk_map(V, triangulate(Q)[0], shape="square")
    >>> bool(np.allclose(UV, V[:, :2]))
    True
    """
    V, T = _triangle_mesh(V, T, "mesh")
    check_choice(shape, "shape", ("disk", "square"))
    check_choice(weights, "weights", ("auto", "cotan", "mean_value"))
    n = len(V)
    loops = cached_boundary_loops(T)
    check_disk(V, T, loops)
    loop = loops[0]
    P, corners = _boundary_positions(V, T, loop, shape)
    used = _used_vertices(T, n)
    fixed = np.zeros(n, dtype=bool)
    fixed[loop] = True
    fixed |= ~used
    free = ~fixed
    X = np.zeros((n, 2))
    X[loop] = P
    warnings = []

    def solve(W, symmetric):
        Wr = W.tocsr()
        A = Wr[free][:, free]
        rhs = -(Wr[free][:, fixed] @ X[fixed])
        Y = X.copy()
        # mean-value weights are not symmetric: general LU with a column ordering
        if symmetric:
            Y[free] = _solve_refined(A, rhs)
        else:
            Y[free] = spla.splu(sp.csc_matrix(A), permc_spec="COLAMD").solve(rhs)
        return Y

    kind = "mean_value" if weights == "mean_value" else "cotan"
    UV = solve(cotan_laplacian(V, T), True) if kind == "cotan" else solve(_mean_value_weights(V, T), False)
    if weights == "auto":
        nflip = int(np.sum(_signed_areas_2d(UV, T) <= 0))
        if nflip:
            warnings.append(
                f"cotangent weights flipped {nflip} triangles (obtuse angles); used mean-value weights instead"
            )
            kind = "mean_value"
            UV = solve(_mean_value_weights(V, T), False)
    if shape == "square":
        S = _signed_areas_2d(UV, T)
        deg = int(np.sum(np.abs(S) <= 1e-14))
        if deg:
            warnings.append(f"{deg} triangles have all three corners on one side of the square (zero area)")
    return UV, {"weights": kind, "corners": corners, "warnings": warnings}


#: how the refusal of a mesh with several boundary loops or a handle starts (:func:`check_disk`)
NOT_A_DISK_REFUSAL = "not a topological disk"
#: what to do about a mesh that is not a disk, for the disk and square maps (LSCM takes several loops)
DISK_ADVICE = ("a disk/square map needs exactly one boundary loop; use LSCM (method='lscm'), which handles several "
               "boundary loops")


def check_disk(V, T, loops, advice: str = DISK_ADVICE):
    """Refuse a triangle mesh that is not one topological disk (one component, one boundary loop, Euler
    characteristic 1) with a typed error naming ``mesh``.

    Parameters
    ----------
    V : (n, 3) float64
    T : (t, 3) int64
    loops : list of (b,) int64
        Its boundary loops (:func:`components.core.mesh.boundary_loops`).

    Raises
    ------
    MeshError
        Closed, several components, or not a disk.

    Examples
    --------
    >>> from components.core.mesh import boundary_loops, quad_grid, triangulate
    >>> V, Q = quad_grid(2, 2)
    >>> T = triangulate(Q)[0]
    >>> check_disk(V, T, boundary_loops(T)) is None
    True
    """
    n = len(V)
    if not loops:
        raise MeshError("mesh", "the surface is closed (no boundary): a disk map needs exactly one boundary loop")
    used = _used_vertices(T, n)
    _, labels = _components(T, n)
    comps = len(np.unique(labels[used]))
    if comps > 1:
        raise pieces_error(V, T, comps, "map each one")
    E = len(edge_topology(T).E)
    chi = int(used.sum()) - E + len(T)
    if len(loops) != 1 or chi != 1:
        genus = (2 - chi - len(loops)) // 2
        raise MeshError(
            "mesh",
            f"{NOT_A_DISK_REFUSAL} ({len(loops)} boundary loops, genus {genus}, Euler characteristic {chi}): "
            + advice,
        )


# ----------------------------------------------------------------------------------------------
# distortion


class ConformalDistortion(NamedTuple):
    """Per-triangle distortion of a parametrization (see :func:`conformal_distortion`)."""

    ratio: np.ndarray  # (t,) quasi-conformal ratio σ1/σ2 ≥ 1 (inf for a degenerate image)
    angle: np.ndarray  # (t,) largest |corner angle in UV − corner angle in 3D|, radians
    flipped: np.ndarray  # (t,) bool, orientation opposite to the majority


def conformal_distortion(V: np.ndarray, T: np.ndarray, UV: np.ndarray) -> ConformalDistortion:
    """Quasi-conformal ratio, angle distortion and flips of a map ``V → UV`` on every triangle.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles.
    UV : (n, 2) float64
        Parameter coordinates.

    Returns
    -------
    ConformalDistortion
        ``ratio`` (t,) σ1/σ2 of the per-triangle Jacobian (1 = conformal; ``inf`` where the image is degenerate),
        ``angle`` (t,) largest change of a corner angle in radians, ``flipped`` (t,) bool where the image
        orientation is opposite to the mesh's majority (a globally mirrored map counts no flips).

    Notes
    -----
    The Jacobian maps the triangle's local orthonormal frame to the plane; its singular values σ1 ≥ σ2 are the
    largest/smallest stretch (Sander et al. 2001), σ1/σ2 is the quasi-conformal distortion (Hormann & Greiner).

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(2, 2)
    >>> T = triangulate(Q)[0]
    >>> round(float(conformal_distortion(V, T, 3 * V[:, :2]).ratio.max()), 9)
    1.0
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    UV = np.asarray(UV, dtype=np.float64)
    P0, P1, P2 = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    e1, e2 = P1 - P0, P2 - P0
    l1 = np.linalg.norm(e1, axis=1)
    x = e1 / np.maximum(l1, 1e-300)[:, None]
    nrm = np.cross(e1, e2)
    y = np.cross(nrm / np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None], x)
    # local 2D coordinates of the corners: (0,0), (l1, 0), (e2·x, e2·y)
    a2, b2 = np.einsum("ij,ij->i", e2, x), np.einsum("ij,ij->i", e2, y)
    f1 = UV[T[:, 1]] - UV[T[:, 0]]
    f2 = UV[T[:, 2]] - UV[T[:, 0]]
    # J @ [[l1, a2], [0, b2]] = [f1 f2]
    inv_b2 = 1.0 / np.where(np.abs(b2) > 0, b2, np.inf)
    inv_l1 = 1.0 / np.maximum(l1, 1e-300)
    J = np.empty((len(T), 2, 2))
    J[:, :, 0] = f1 * inv_l1[:, None]
    J[:, :, 1] = (f2 - J[:, :, 0] * a2[:, None]) * inv_b2[:, None]
    s = np.linalg.svd(J, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(s[:, 1] > 1e-14 * np.maximum(s[:, 0], 1e-300), s[:, 0] / s[:, 1], np.inf)
    det = np.linalg.det(J)
    major = 1.0 if np.sum(np.abs(det) * (det > 0)) >= np.sum(np.abs(det) * (det < 0)) else -1.0
    flipped = det * major <= 0
    ang3 = triangle_angles(V, T)
    ang2 = triangle_angles(np.concatenate([UV, np.zeros((len(UV), 1))], axis=1), T)
    angle = np.abs(ang2 - ang3).max(axis=1)
    return ConformalDistortion(ratio, angle, flipped)


# ----------------------------------------------------------------------------------------------
# published component


class ConformalMapResult(NamedTuple):
    uv_mesh: Mesh
    uv: Points
    mean_ratio: float
    max_ratio: float
    mean_angle_distortion: float
    flipped: int
    warnings: list[str]


def conformal_map(mesh: Mesh, method: str = "lscm") -> ConformalMapResult:
    """Flatten a disk-like surface mesh onto the plane with a conformal (angle-preserving) map.

    Parameters
    ----------
    mesh : Mesh
        The triangle, quad or polygon mesh ``(V, F)`` of an open surface (polygons are fan-triangulated for the map).
    method : str
        ``"lscm"`` free-boundary least-squares conformal map (default, keeps the model scale), ``"spectral"``
        free-boundary spectral conformal map (no pinned vertices), ``"disk"`` fixed boundary on the unit disk,
        ``"square"`` fixed boundary on the unit square.

    Returns
    -------
    uv_mesh : Mesh
        The flattened mesh: the parameter points with z = 0 and the input faces.
    uv : Points
        Parameter point ``(u, v, 0)`` of every vertex.
    mean_ratio : float
        Mean quasi-conformal ratio σ1/σ2 over the triangles (1 = perfectly conformal).
    max_ratio : float
        Largest quasi-conformal ratio.
    mean_angle_distortion : float
        Mean over triangles of the largest corner-angle change, in radians.
    flipped : int
        Number of triangles whose image is flipped (0 for a valid map).

    Raises
    ------
    MeshError
        Closed surface (no boundary), several connected components, or — for ``"disk"``/``"square"`` — not a
        topological disk.
    InputError
        Unknown ``method``.

    Notes
    -----
    Lévy et al., *Least squares conformal maps*, SIGGRAPH 2002; Mullen et al., *Spectral conformal
    parameterization*, SGP 2008; Floater, *Mean value coordinates*, 2003. The paper's curvature-line workflow maps
    the surface conformally onto a "unit plane" (Liu et al. 2006; Bommes et al. 2009).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = conformal_map(quad_grid(3, 3), method="lscm")
    >>> res.flipped, round(res.max_ratio, 6)
    (0, 1.0)
    """
    V, F = check_mesh(mesh, "mesh")
    check_choice(method, "method", ("lscm", "spectral", "disk", "square"))
    T, _ = triangulate(F)
    warnings: list[str] = []
    used = _used_vertices(T, len(V))
    if not used.all():
        warnings.append(f"{int((~used).sum())} vertices are not used by any face; they are placed at (0, 0)")
    loops = cached_boundary_loops(T)
    if not loops:
        raise MeshError("mesh", "the surface is closed (no boundary): cut it open before a conformal map")
    if method in ("lscm", "spectral"):
        E = len(edge_topology(T).E)
        chi = int(used.sum()) - E + len(T)
        if len(loops) > 1 or chi != 1:
            warnings.append(
                f"the surface is not a disk ({len(loops)} boundary loops, Euler characteristic {chi}); LSCM mapped "
                "it with all boundaries free, holes stay holes in the plane"
            )
        UV = lscm(V, T, method="pinned" if method == "lscm" else "spectral")
    else:
        UV, info = disk_map(V, T, shape=method)
        warnings += info["warnings"]
    dist = conformal_distortion(V, T, UV)
    finite = np.isfinite(dist.ratio)
    flipped = int(dist.flipped.sum())
    if flipped:
        warnings.append(f"{flipped} triangles are flipped in the parameter domain")
    if not finite.all():
        warnings.append(f"{int((~finite).sum())} triangles are degenerate in the parameter domain")
    P = np.concatenate([UV, np.zeros((len(V), 1))], axis=1)
    return ConformalMapResult(
        uv_mesh=(P, F),
        uv=P,
        mean_ratio=float(dist.ratio[finite].mean()) if finite.any() else float("inf"),
        max_ratio=float(dist.ratio.max()),
        mean_angle_distortion=float(dist.angle.mean()),
        flipped=flipped,
        warnings=warnings,
    )
