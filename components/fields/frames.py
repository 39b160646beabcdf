"""Discrete machinery of face-based direction fields: face frames, the dual graph with its Levi-Civita connection,
4-fold matching across edges, singularity indices and combing.

A direction field lives on the faces of a triangle mesh ``(V, T)``: per face a pair of unit tangent vectors
``U, W`` (not necessarily orthogonal) standing for the 4-fold set ``(U, W, −U, −W)``. In a face's orthonormal frame
``(e1, e2)`` (``e1`` along the first edge, ``e2 = n × e1``) a tangent vector is the complex number
``x·e1 + i x·e2``. Crossing an interior edge rotates face coordinates by the difference of the edge's angle in the
two frames (discrete parallel transport, exact on unfolded triangles).

This module holds the helpers shared by :mod:`components.fields.field` and :mod:`components.fields.streamlines`; its public
functions (:func:`field_matching`, :func:`field_singularities`, :func:`comb_field`) are re-exported there.

References
----------
D. Bommes, H. Zimmer, L. Kobbelt, "Mixed-integer quadrangulation", SIGGRAPH 2009 (matchings, period jumps).
O. Diamanti, A. Vaxman, D. Panozzo, O. Sorkine-Hornung, "Designing N-PolyVector fields with complex polynomials",
SGP 2014 (index of a non-orthogonal field: mean rotation of the matched vectors).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components

from components.core.errors import InputError
from components.core.measures import corner_angles, unit

log = logging.getLogger(__name__)

TWO_PI = 2.0 * np.pi


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to ``(−π, π]``."""
    return np.pi - np.mod(np.pi - a, TWO_PI)


class FaceFrames(NamedTuple):
    """Per-face orthonormal frames of a triangle mesh."""

    e1: np.ndarray  # (m, 3) unit first edge
    e2: np.ndarray  # (m, 3) n × e1
    n: np.ndarray  # (m, 3) unit normal
    area: np.ndarray  # (m,)
    centroid: np.ndarray  # (m, 3)


def face_frames(V: np.ndarray, T: np.ndarray) -> FaceFrames:
    """Orthonormal frame, area and centroid of every triangle."""
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    N = np.cross(B - A, C - A)
    area = 0.5 * np.linalg.norm(N, axis=1)
    n = unit(N)
    e1 = unit(B - A)
    e2 = np.cross(n, e1)
    return FaceFrames(e1, e2, n, area, (A + B + C) / 3.0)


def to_complex(X: np.ndarray, fr: FaceFrames, faces=None) -> np.ndarray:
    """Tangent vectors ``(m, 3)`` → complex coordinates in their face frames."""
    e1 = fr.e1 if faces is None else fr.e1[faces]
    e2 = fr.e2 if faces is None else fr.e2[faces]
    return np.einsum("ij,ij->i", X, e1) + 1j * np.einsum("ij,ij->i", X, e2)


def from_complex(z: np.ndarray, fr: FaceFrames, faces=None) -> np.ndarray:
    """Complex coordinates → 3D tangent vectors."""
    e1 = fr.e1 if faces is None else fr.e1[faces]
    e2 = fr.e2 if faces is None else fr.e2[faces]
    return z.real[:, None] * e1 + z.imag[:, None] * e2


class DualGraph(NamedTuple):
    """Interior edges as dual edges ``f → g`` with their connection, and the boundary half-edges."""

    f: np.ndarray  # (d,) face holding the half-edge a → b
    g: np.ndarray  # (d,) face holding b → a
    a: np.ndarray  # (d,) edge start (as seen from f)
    b: np.ndarray  # (d,) edge end
    kappa: np.ndarray  # (d,) angle added to a direction when carried from f's frame to g's
    weight: np.ndarray  # (d,) smoothness weight (dual length / primal length ratio, clipped)
    bface: np.ndarray  # (q,) faces with a boundary edge (one row per boundary half-edge)
    ba: np.ndarray  # (q,) boundary half-edge start
    bb: np.ndarray  # (q,) boundary half-edge end


def dual_graph(V: np.ndarray, T: np.ndarray, fr: FaceFrames) -> DualGraph:
    """Dual edges of an oriented edge-manifold triangle mesh (validated by the caller)."""
    m = len(T)
    n = len(V)
    a = T.ravel()
    b = np.roll(T, -1, axis=1).ravel()
    hf = np.repeat(np.arange(m), 3)
    key = np.minimum(a, b) * np.int64(n) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = ks[1:] == ks[:-1]
    i0 = order[:-1][same]
    i1 = order[1:][same]
    # every key appears once (boundary) or twice (interior) on a validated manifold
    paired = np.zeros(len(a), dtype=bool)
    paired[i0] = paired[i1] = True
    f, g = hf[i0], hf[i1]
    ea, eb = a[i0], b[i0]
    d = V[eb] - V[ea]
    tf = np.angle(to_complex(d, fr, f))
    tg = np.angle(to_complex(d, fr, g))
    kappa = _wrap(tg - tf)
    elen = np.linalg.norm(d, axis=1)
    clen = np.linalg.norm(fr.centroid[g] - fr.centroid[f], axis=1)
    w = np.divide(elen, clen, out=np.ones_like(elen), where=clen > 0)
    if len(w):
        med = float(np.median(w))
        w = np.clip(w, 0.1 * med, 10.0 * med) / med
    bnd = ~paired
    return DualGraph(f, g, ea, eb, kappa, w, hf[bnd], a[bnd], b[bnd])


def interior_vertex_mask(T: np.ndarray, n: int, dg: DualGraph) -> np.ndarray:
    """``(n,) bool``: vertices used by a face and not on the boundary."""
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    used[dg.ba] = False
    used[dg.bb] = False
    return used


def angle_defect(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``2π − Σ corner angles`` at every vertex (meaningful at interior vertices)."""
    ang = corner_angles(V, T)  # triangles: corner 3f + i is T[f, i]
    s = np.bincount(T.ravel(), weights=ang, minlength=len(V))
    return TWO_PI - s


# ----------------------------------------------------------------------------------------------
# matching and singularities


def canonical_pair(U: np.ndarray, W: np.ndarray, fr: FaceFrames) -> tuple[np.ndarray, np.ndarray]:
    """Angles ``(θu, θw)`` in the face frames with ``θw − θu ∈ [0, π)``: the 4-fold set in counter-clockwise order
    is ``U, W, −U, −W``."""
    tu = np.angle(to_complex(U, fr))
    tw = np.angle(to_complex(W, fr))
    dw = np.mod(tw - tu, TWO_PI)
    flip = dw >= np.pi
    dw = np.where(flip, dw - np.pi, dw)
    return tu, tu + dw


def _matching(tu: np.ndarray, tw: np.ndarray, dg: DualGraph) -> tuple[np.ndarray, np.ndarray]:
    """Best cyclic shift ``k`` (f's ``P[j]`` ↔ g's ``P[j + k]``) and mean rotation of every dual edge.

    ``P = (U, W, −U, −W)`` in counter-clockwise order. The rotation is the mean signed angle from the transported
    vectors of ``f`` to their partners in ``g``.
    """
    f, g = dg.f, dg.g
    su = tu[f] + dg.kappa
    sw = tw[f] + dg.kappa
    Pg = np.stack([tu[g], tw[g], tu[g] + np.pi, tw[g] + np.pi], axis=1)
    best_cost = np.full(len(f), np.inf)
    shift = np.zeros(len(f), dtype=np.int64)
    rot = np.zeros(len(f))
    for k in range(4):
        d0 = _wrap(Pg[:, k] - su)
        d1 = _wrap(Pg[:, (k + 1) % 4] - sw)
        cost = d0 * d0 + d1 * d1
        better = cost < best_cost
        best_cost = np.where(better, cost, best_cost)
        shift = np.where(better, k, shift)
        rot = np.where(better, 0.5 * (d0 + d1), rot)
    return shift, rot


def field_matching(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray,
                   fr: FaceFrames | None = None, dg: DualGraph | None = None):
    """Matching of a 4-fold direction field across every interior edge.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles (oriented, edge-manifold; validate first).
    U, W : (m, 3) float64
        The two field directions of every face.
    fr, dg : optional
        Precomputed :func:`face_frames` and :func:`dual_graph`.

    Returns
    -------
    EF : (d, 2) int64
        The two faces ``(f, g)`` of every interior edge.
    shift : (d,) int64
        Cyclic shift ``k ∈ {0, 1, 2, 3}``: the vector ``P_f[j]`` of ``P = (U, W', −U, −W')`` (``W'`` = ``±W``
        counter-clockwise from ``U``) continues as ``P_g[j + k]``. ``k`` odd means the families swap (``U → ±W``).
    rotation : (d,) float64
        Mean rotation (radians) of the matched vectors relative to parallel transport.
    """
    fr = face_frames(V, T) if fr is None else fr
    dg = dual_graph(V, T, fr) if dg is None else dg
    tu, tw = canonical_pair(U, W, fr)
    shift, rot = _matching(tu, tw, dg)
    return np.stack([dg.f, dg.g], axis=1), shift, rot


def field_singularities(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray,
                        fr: FaceFrames | None = None, dg: DualGraph | None = None):
    """Singular vertices of a 4-fold direction field and their indices.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles (oriented, edge-manifold).
    U, W : (m, 3) float64
        The two field directions of every face.
    fr, dg : optional
        Precomputed :func:`face_frames` and :func:`dual_graph`.

    Returns
    -------
    vertices : (k,) int64
        Interior vertices whose index is not zero.
    index : (k,) float64
        Their index, a multiple of 1/4 (−1/4 for a valence-5-like, +1/4 for a valence-3-like singularity).

    Notes
    -----
    Around an interior vertex ``v``, the index is ``(Σ rotations + K_v) / 2π`` where the rotations are the mean
    angles by which the matched field vectors turn relative to parallel transport across the ring's edges
    (counter-clockwise) and ``K_v`` is the angle defect (the holonomy of the ring). On a closed surface the indices
    sum to the Euler characteristic (Poincaré–Hopf). Boundary vertices are not reported.
    """
    fr = face_frames(V, T) if fr is None else fr
    dg = dual_graph(V, T, fr) if dg is None else dg
    tu, tw = canonical_pair(U, W, fr)
    _, rot = _matching(tu, tw, dg)
    n = len(V)
    s = np.bincount(dg.b, weights=rot, minlength=n) - np.bincount(dg.a, weights=rot, minlength=n)
    idx = (s + angle_defect(V, T)) / TWO_PI
    q = np.round(4.0 * idx) / 4.0
    inner = interior_vertex_mask(T, n, dg)
    sing = np.nonzero(inner & (np.abs(q) > 0.1))[0]
    return sing.astype(np.int64), q[sing]


def comb_field(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray,
               fr: FaceFrames | None = None, dg: DualGraph | None = None):
    """Relabel every face's 4-fold set so that ``U`` continues as ``U`` across as many edges as possible.

    Parameters
    ----------
    V, T, U, W
        Mesh and field as in :func:`field_matching`.
    fr, dg : optional
        Precomputed frames and dual graph.

    Returns
    -------
    U2, W2 : (m, 3) float64
        The combed field: the same 4-fold sets, ``W2`` counter-clockwise from ``U2``, with zero shift across the
        edges of a breadth-first spanning tree of the dual graph (one tree per connected component).
    shift : (d,) int64
        Remaining cyclic shift of every dual edge (``dg`` order; non-zero only on a cut graph that ends at the
        singularities and the boundary).
    """
    fr = face_frames(V, T) if fr is None else fr
    dg = dual_graph(V, T, fr) if dg is None else dg
    m = len(T)
    tu, tw = canonical_pair(U, W, fr)
    shift, _ = _matching(tu, tw, dg)
    # shift of the dual edge in both directions, as a sparse lookup
    rows = np.concatenate([dg.f, dg.g])
    cols = np.concatenate([dg.g, dg.f])
    vals = np.concatenate([shift, (-shift) % 4])
    G = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(m, m))
    ncomp, label = connected_components(G, directed=False)
    pred = np.full(m, -1, dtype=np.int64)
    for c in range(ncomp):
        root = int(np.argmax(label == c))
        _, p = breadth_first_order(G, root, directed=False, return_predecessors=True)
        sel = label == c
        pred[sel] = p[sel]
    roots = pred < 0
    pred[roots] = np.nonzero(roots)[0]
    # shift of the tree edge pred → face: look up the (pred, face) dual edge
    key_all = rows * np.int64(m) + cols
    order = np.argsort(key_all)
    key_tree = pred * np.int64(m) + np.arange(m)
    pos = np.searchsorted(key_all[order], key_tree)
    pos = np.minimum(pos, len(order) - 1)
    s = np.where(roots, 0, vals[order[pos]] if len(order) else 0).astype(np.int64)
    # pointer jumping: cumulative shift along the root path
    p = pred.copy()
    while True:
        s = (s + s[p]) % 4
        p_new = p[p]
        if np.array_equal(p_new, p):
            break
        p = p_new
    P = np.stack([tu, tw, tu + np.pi, tw + np.pi], axis=1)
    ar = np.arange(m)
    cu = P[ar, s]
    cw = P[ar, (s + 1) % 4]
    U2 = from_complex(np.exp(1j * cu), fr)
    W2 = from_complex(np.exp(1j * cw), fr)
    remaining = (shift + s[dg.f] - s[dg.g]) % 4
    return U2, W2, remaining


def check_field(U, W, m: int, names=("U", "W")) -> tuple[np.ndarray, np.ndarray]:
    """Validate per-face direction arrays ``(m, 3)``: finite, non-zero."""
    out = []
    for X, name in zip((U, W), names):
        try:
            X = np.ascontiguousarray(X, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(name, f"directions are not numbers ({exc})") from None
        if X.shape != (m, 3):
            raise InputError(name, f"must have shape ({m}, 3) (one vector per triangle), got {X.shape}")
        if not np.isfinite(X).all():
            raise InputError(name, f"vector {int(np.argmax(~np.isfinite(X).all(axis=1)))} is not finite")
        L = np.linalg.norm(X, axis=1)
        if np.any(L == 0):
            raise InputError(name, f"vector {int(np.argmax(L == 0))} is zero")
        out.append(X)
    return out[0], out[1]
