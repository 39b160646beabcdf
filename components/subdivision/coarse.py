"""Automatic coarse quad-dominant control nets on a design surface (step 2 of the subdivision strategy).

The design surface (a topological disk) is mapped onto the unit disk (:func:`components.core.conformal.
disk_map`: boundary by arc length, harmonic interior, mean-value weights if cotangent weights flip). A quad layout is
drawn in that plane from isocurves of simple patches, and every node is lifted back onto the surface by barycentric
interpolation of the map (boundary nodes exactly onto the boundary polyline): the paper's "2D map by patches".

Layouts
-------
``"ogrid"``
    A block of ``n × n`` quads in the middle and ``k`` rings of quads around it out to the boundary. Every
    boundary node has valence 3, so no panel has a straight (180°) corner on a smooth boundary; the block's four
    corners are interior valence-3 vertices (index ``+1/4`` each; a smooth boundary without corners forces a total
    index of ``+1``, see :mod:`components.subdivision.singularities`). The block's rotation in the map plane is chosen among
    ``rotations`` candidates by the mean planarity of the subdivided net pulled onto the surface.
``"patches"``
    ``c`` quad patches (Coons patches with straight sides to the centre and circle arcs on the boundary, ``m × m``
    quads each) around one singular vertex of valence ``c = 4 − 4·index`` (3 for ``+1/4``, 5 for ``−1/4``, 4 for a
    regular grid), at a chosen singularity; ``c`` boundary corners of valence 2 keep the total index consistent.
    The corners sit on a smooth boundary, where their panels are nearly straight (≈ 180°): use it where the
    boundary has real corners, or accept those panels.
``"aligned"``
    The field pipeline's quad extraction (:func:`components.fields.candidate.candidate_mesh`) at the coarse spacing
    ``sqrt(area / faces)`` along the conjugate (or principal) direction field, boundary snapped onto the surface
    boundary; its singular vertices are the field's. A PQ mesh can stay close to a surface only if its two line
    families follow conjugate directions, and Catmull-Clark keeps the directions of its control net, so the
    subdivided net starts nearly conjugate (saddle, 36 faces, 2 levels: mean candidate planarity 2.4e-3 against
    4.3e-3 for the O-grid). At such coarse spacings the extraction can leave triangles, pentagons or a boundary
    vertex in a single face (a straight panel corner), which is why ``"auto"`` ranks it against the O-grid.
``"grid"``
    A regular ``nu × nv`` grid between the four corners of a surface whose boundary has four clear corners
    (turns over 30°), in its unit-square map (:func:`grid_layout`): no interior irregular vertex, every boundary
    corner a panel corner (strips, quadrilateral roofs).
``"auto"``
    ``"patches"`` around the first given singularity when ``singularities`` are given; otherwise the aligned net,
    the O-grid and (on a four-cornered surface) the grid compete: a net whose subdivided, pulled panels are all
    sound (no corner below 15° or above 165°, none non-convex) beats one with bad panels, since the planarization
    keeps them; among equals the aligned net is kept unless another ranks better by more than 25% (rank: mean
    planarity of the subdivided, pulled net, raised by its share of bad panels), else the lower rank wins. When
    the field pipeline fails, the others with a warning. Measured (faces 36, 2 levels): aligned on saddle, O-grid
    on dome, wave, canopy and inspired_mesh; the grid on the 10:1 twisted strip, where the aligned net had
    corners of 15° and 180°.

References
----------
Y. Liu, H. Pottmann, J. Wallner, Y.-L. Yang, W. Wang, "Geometric modeling with conical meshes and developable
surfaces", SIGGRAPH 2006 (coarse net → subdivision → surface → planarization). M. S. Floater, "Mean value
coordinates", CAGD 2003; M. Eck et al., "Multiresolution analysis of arbitrary meshes", SIGGRAPH 1995 (disk maps).
S. A. Coons, "Surfaces for computer-aided design of space forms", MIT MAC-TR-41, 1967 (transfinite patches).
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.core.checks import check_choice, check_int, check_mesh, check_points, pieces_error, shared_positions
from components.core.conformal import disk_map
from components.core.errors import InputError, MeshError
from components.core.measures import corner_angles, nonconvex_faces, quad_planarity
from components.core.mesh import (boundary_loops, edge_topology, face_normals, face_sizes, pad_faces, piece_count,
                                  triangulate)
from components.core.proximity import PolylineIndex, TriangleIndex
from components.core.types import Integers, Mesh, Numbers, Points
from components.fields.candidate import candidate_mesh
from components.fields.repair import close_pinches
from components.subdivision.pull import pulled_subdivision
from components.subdivision.singularities import integrated_gaussian_curvature
from components.subdivision.subdivide import control_mesh, subdivided_mesh

log = logging.getLogger(__name__)

__all__ = [
    "LAYOUTS",
    "CoarseNet",
    "aligned_layout",
    "CoarseMeshResult",
    "check_disk_surface",
    "coarse_mesh",
    "coarse_net",
    "grid_layout",
    "ogrid_layout",
    "ogrid_size",
    "patch_layout",
]

LAYOUTS = ("auto", "aligned", "ogrid", "patches", "grid")
ALIGNED_FIELDS = ("conjugate", "principal")
MAX_COARSE_FACES = 20_000


def _barycentric(P, A, B, C):
    v0, v1, v2 = B - A, C - A, P - A
    d = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    d = np.where(np.abs(d) > 0, d, np.finfo(float).tiny)
    l1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / d
    l2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / d
    return np.stack([1.0 - l1 - l2, l1, l2], axis=-1)


def _locate(UV, T, P, k: int = 16):
    """Triangle of a planar triangulation ``(UV, T)`` containing every point of ``P`` and its barycentric weights.

    Points outside (e.g. on a circle just outside an inscribed boundary polygon) get the triangle where they are
    least outside, with clamped, renormalized weights.
    """
    P = np.asarray(P, dtype=np.float64)
    cen = UV[T].mean(axis=1)
    k = int(min(k, len(T)))
    _, cand = cKDTree(cen).query(P, k=k)
    cand = np.asarray(cand).reshape(len(P), k)
    bary = _barycentric(P[:, None, :], UV[T[cand, 0]], UV[T[cand, 1]], UV[T[cand, 2]])
    score = bary.min(axis=-1)
    j = np.argmax(score, axis=1)
    rows = np.arange(len(P))
    tri = cand[rows, j]
    best = score[rows, j]
    w = bary[rows, j]
    miss = np.nonzero(best < -1e-9)[0]
    for p in miss:  # not among the nearest candidates: all triangles (rare: far outside or long slivers)
        bb = _barycentric(P[p][None, :], UV[T[:, 0]], UV[T[:, 1]], UV[T[:, 2]])
        t = int(np.argmax(bb.min(axis=1)))
        tri[p], w[p] = t, bb[t]
    w = np.clip(w, 0.0, None)
    w /= w.sum(axis=1, keepdims=True)
    return tri, w


def _coons_patch(C, M0, P, M1, n):
    """Grid ``(n+1)²`` of a Coons patch with corners ``C, M0, P, M1`` (``C`` the singular centre), straight sides
    ``C→M0`` and ``C→M1`` and circular-arc sides ``M0→P`` and ``M1→P`` on the unit circle.

    Returns ``X (n+1, n+1, 2)`` indexed ``[i, j]`` with ``X[0, 0] = C``, ``X[n, 0] = M0``, ``X[n, n] = P``,
    ``X[0, n] = M1``.
    """
    s = np.linspace(0.0, 1.0, n + 1)
    a0, aP, a1 = (np.arctan2(q[1], q[0]) for q in (M0, P, M1))

    def arc(a, b, t):
        d = (b - a + np.pi) % (2 * np.pi) - np.pi
        ang = a + d * t
        return np.stack([np.cos(ang), np.sin(ang)], axis=-1)

    side_j0 = C[None] + s[:, None] * (M0 - C)[None]  # X[i, 0]
    side_i0 = C[None] + s[:, None] * (M1 - C)[None]  # X[0, j]
    side_in = arc(a0, aP, s)  # X[n, j]: M0 → P
    side_jn = arc(a1, aP, s)  # X[i, n]: M1 → P
    u = s[:, None, None]
    v = s[None, :, None]
    X = ((1 - v) * side_j0[:, None] + v * side_jn[:, None] + (1 - u) * side_i0[None] + u * side_in[None]
         - ((1 - u) * (1 - v) * C + u * (1 - v) * M0 + u * v * P + (1 - u) * v * M1))
    return X


def patch_layout(c: int, n: int, center=(0.0, 0.0), phi0: float = 0.0):
    """Quad layout of the unit disk: ``c`` Coons patches of ``n × n`` quads around one centre of valence ``c``.

    Patch ``j`` has the corners centre, midpoint of arc ``j−1``, corner ``j`` (angle ``phi0 + 2πj/c`` on the
    circle) and midpoint of arc ``j``; its sides to the centre are straight, its outer sides circle arcs.

    Returns ``UV (p, 2)``, ``Q (q, 4)`` counter-clockwise, ``boundary_angle (p,)`` (angle on the circle for
    boundary nodes, NaN inside), ``corner (p,)`` bool (the ``c`` valence-2 boundary nodes), ``centre`` index.
    """
    C = np.asarray(center, dtype=np.float64)
    alpha = phi0 + 2 * np.pi * np.arange(c) / c
    beta = alpha + np.pi / c
    P = np.stack([np.cos(alpha), np.sin(alpha)], axis=1)
    M = np.stack([np.cos(beta), np.sin(beta)], axis=1)
    pts, quads = [], []
    off = 0
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    base = np.stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()], 1)
    for j in range(c):
        X = _coons_patch(C, M[j - 1], P[j], M[j], n)
        pts.append(X.reshape(-1, 2))
        quads.append(base + off)
        off += (n + 1) ** 2
    UV = np.vstack(pts)
    Q = np.vstack(quads)
    # merge shared patch sides
    tree = cKDTree(UV)
    pairs = tree.query_pairs(1e-9, output_type="ndarray")
    rep = np.arange(len(UV))
    for a, b in sorted(map(tuple, np.sort(pairs, axis=1)), key=lambda t: t[1]):
        rep[b] = rep[a]
    # resolve chains
    for _ in range(4):
        rep = rep[rep]
    keep, inv = np.unique(rep, return_inverse=True)
    UV = UV[keep]
    Q = inv[Q]
    # orientation: counter-clockwise in the plane
    a = UV[Q[:, 1]] - UV[Q[:, 0]]
    b = UV[Q[:, 3]] - UV[Q[:, 0]]
    flip = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    Q[flip] = Q[flip][:, ::-1]
    r = np.linalg.norm(UV, axis=1)
    on_circle = np.abs(r - 1.0) < 1e-9
    ang = np.where(on_circle, np.arctan2(UV[:, 1], UV[:, 0]), np.nan)
    corner = np.zeros(len(UV), dtype=bool)
    corner[cKDTree(UV).query(P)[1]] = True
    centre = int(cKDTree(UV).query(C)[1])
    return UV, Q.astype(np.int64), ang, corner, centre


def ogrid_layout(n: int, k: int, phi: float = 0.0, block: float = 0.55):
    """O-grid quad layout of the unit disk: an ``n × n`` block ``[-block, block]²`` rotated by ``phi`` and ``k``
    rings of quads out to the circle (``4n`` boundary nodes at equal angles).

    Returns ``UV (p, 2)``, ``Q (q, 4)`` counter-clockwise, ``boundary_angle (p,)`` (NaN inside). The four block
    corners are interior vertices of valence 3; every boundary node has valence 3.
    """
    t = np.linspace(-block, block, n + 1)
    X, Y = np.meshgrid(t, t, indexing="xy")
    pts = [np.column_stack([X.ravel(), Y.ravel()])]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    quads = [np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], 1)]
    ring = np.r_[idx[0, :-1], idx[:-1, -1], idx[-1, :0:-1], idx[:0:-1, 0]]  # counter-clockwise from (-b, -b)
    inner = pts[0][ring]
    ang = np.radians(225.0) + 2 * np.pi * np.arange(4 * n) / (4 * n)
    outer = np.column_stack([np.cos(ang), np.sin(ang)])
    count = len(pts[0])
    prev = ring
    for layer in range(1, k + 1):
        lam = layer / k
        pts.append((1 - lam) * inner + lam * outer)
        cur = count + np.arange(4 * n)
        count += 4 * n
        quads.append(np.stack([prev, cur, np.roll(cur, -1), np.roll(prev, -1)], 1))
        prev = cur
    UV = np.vstack(pts)
    c, s = math.cos(phi), math.sin(phi)
    UV = UV @ np.array([[c, s], [-s, c]])
    Q = np.vstack(quads).astype(np.int64)
    a = UV[Q[:, 1]] - UV[Q[:, 0]]
    b = UV[Q[:, 3]] - UV[Q[:, 0]]
    flip = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    Q[flip] = Q[flip][:, ::-1]
    on = np.zeros(len(UV), dtype=bool)
    on[count - 4 * n:] = True
    bang = np.where(on, np.arctan2(UV[:, 1], UV[:, 0]), np.nan)
    return UV, Q, bang


# ----------------------------------------------------------------------------------------------
# the map and the lift


class _SurfaceMap(NamedTuple):
    V: np.ndarray
    T: np.ndarray
    UV: np.ndarray
    loop: np.ndarray  # boundary loop, in the order of increasing angle on the circle
    loop_angle: np.ndarray  # angle of every loop vertex on the circle (increasing from 0)
    flip: bool  # the map reverses the surface's orientation
    warnings: list


def _surface_map(V, T) -> _SurfaceMap:
    UV, info = disk_map(V, T, shape="disk")
    loop = boundary_loops(T, name="surface")[0]
    ang = np.mod(np.arctan2(UV[loop, 1], UV[loop, 0]), 2 * np.pi)
    order = np.argsort(ang, kind="stable")
    a0 = UV[T[:, 1]] - UV[T[:, 0]]
    a1 = UV[T[:, 2]] - UV[T[:, 0]]
    flip = bool(np.sum(a0[:, 0] * a1[:, 1] - a0[:, 1] * a1[:, 0]) < 0)
    return _SurfaceMap(V, T, UV, loop[order], ang[order], flip, list(info["warnings"]))


def _lift(sm: _SurfaceMap, G, bang):
    """3D points of the map-plane points ``G``: barycentric inside, on the boundary polyline for ``bang`` ≥ 0."""
    tri, w = _locate(sm.UV, sm.T, G)
    X = np.einsum("pk,pkd->pd", w, sm.V[sm.T[tri]])
    on = np.isfinite(bang)
    if on.any():
        th = np.mod(bang[on], 2 * np.pi)
        A = np.r_[sm.loop_angle, sm.loop_angle[0] + 2 * np.pi]
        P = sm.V[np.r_[sm.loop, sm.loop[0]]]
        j = np.clip(np.searchsorted(A, th, side="right") - 1, 0, len(sm.loop) - 1)
        j = np.where(th < A[0], len(sm.loop) - 1, j)
        th = np.where(th < A[0], th + 2 * np.pi, th)
        f = np.clip((th - A[j]) / np.maximum(A[j + 1] - A[j], 1e-300), 0.0, 1.0)
        X[on] = (1 - f)[:, None] * P[j] + f[:, None] * P[j + 1]
    return X


def ogrid_size(faces: int) -> tuple[int, int]:
    """Block size ``n`` and ring count ``k`` of the O-grid (:func:`ogrid_layout`) whose ``n² + 4nk`` faces are
    nearest to ``faces`` (``k ≈ 0.3 n``).

    Examples
    --------
    >>> n, k = ogrid_size(36); n, k, n * n + 4 * n * k
    (4, 1, 32)
    """
    best = None
    for n in range(1, 200):
        k = max(1, int(round(0.3 * n)))
        f = n * n + 4 * n * k
        if best is None or abs(f - faces) < abs(best[2] - faces):
            best = (n, k, f)
        if f > 2 * faces:
            break
    return best[0], best[1]


def _uv_of_point(sm: _SurfaceMap, P):
    res = TriangleIndex(sm.V, sm.T, name="surface").query(np.atleast_2d(P), name="singularities")
    return np.einsum("pk,pkd->pd", res.barycentric, sm.UV[sm.T[res.faces]]), res.distances


class CoarseNet(NamedTuple):
    """Result of :func:`coarse_net`."""

    V: np.ndarray  # (p, 3) coarse vertices on the surface
    Q: np.ndarray  # (q, 4) int64 quads, oriented like the surface
    UV: np.ndarray  # (p, 2) positions in the unit-disk map
    layout: str  # "aligned", "ogrid", "patches" or "grid"
    singular: np.ndarray  # (s,) int64 interior irregular vertices
    valence: np.ndarray  # (s,) int64 their valences
    score: float  # mean planarity of the subdivided, pulled net (the selection measure)
    warnings: list


def _interior_irregular(Q, n):
    topo = edge_topology(Q)
    val = np.bincount(topo.E.ravel(), minlength=n)
    onb = np.zeros(n, dtype=bool)
    onb[topo.E[topo.count == 1].ravel()] = True
    irr = np.nonzero(~onb & (val != 4) & (val > 0))[0].astype(np.int64)
    return irr, val[irr].astype(np.int64)


def _judge(Vc, Qc, levels, index, min_angle: float = 15.0):
    """``(mean planarity, ranking score, bad panels)`` of the net after ``levels`` Catmull-Clark steps, pulled onto
    the surface.

    The ranking score is the mean planarity raised by the share of bad panels (a corner below ``min_angle``
    degrees or above ``180 − min_angle``, or non-convex): the planarizer keeps the start's worst corner as its guard, so a candidate with
    collapsed panels ends with collapsed panels whatever its planarity.
    """
    Vs, Qs, _ = subdivided_mesh(Vc, Qc, levels=levels, name="coarse")
    X = pulled_subdivision(Vs, Qs, Vc, index.V, index.T, name="coarse").V
    pl = float(quad_planarity(X, Qs).mean())
    ang = np.degrees(corner_angles(X, Qs))  # corner by corner; faces of any size (levels 0: the net's own)
    starts = np.r_[0, np.cumsum(face_sizes(Qs))[:-1]]
    bad = np.count_nonzero((np.minimum.reduceat(ang, starts) < min_angle)
                           | (np.maximum.reduceat(ang, starts) > 180.0 - min_angle) | nonconvex_faces(X, Qs))
    return pl, pl * (1.0 + 200.0 * bad / len(Qs)), bad


def _surface_area(V, T):
    return float(0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum())


def aligned_layout(V, T, faces: int = 36, field: str = "conjugate", alignment: float = 0.1):
    """Coarse net laid along a direction field: the field pipeline's quad extraction at the coarse spacing.

    The conjugate (or principal curvature) field of the surface is integrated by a seamless parametrization at
    the edge length ``sqrt(area / faces)`` and its integer iso-lines are extracted, with the boundary snapped
    onto the surface boundary (:func:`components.fields.candidate.candidate_mesh`). Catmull-Clark keeps the
    directions of its control net, so a net along conjugate directions subdivides into a net that is nearly
    conjugate too; its singular vertices are the field's.

    Parameters
    ----------
    V : (n, 3) float64
        Design surface vertices.
    T : (t, 3) int64
        Design surface triangles.
    faces : int
        Target number of coarse faces.
    field : {"conjugate", "principal"}
        Direction field followed by the net.
    alignment : float
        Weight of the field's pull toward the principal directions (smaller: smoother, fewer singularities).

    Returns
    -------
    Vc : (p, 3) float64
        Net vertices: interior ones on the surface, boundary ones on the surface boundary.
    Fc : (q, k) int64
        Padded polygon faces (mostly quads), oriented like the surface.
    warnings : list of str

    Raises
    ------
    components.core.mesh.MeshError, components.core.mesh.InputError, ValueError
        Whatever the field pipeline raises, or a net that is not a valid control mesh (the caller falls back).
    """
    length = math.sqrt(_surface_area(V, T) / max(int(faces), 1))
    # narrow conjugate pairs are kept: at the coarse spacing the net's boundary row is what the narrow pairs
    # along the boundary follow (saddle, 36 faces: 1 irregular vertex and predicted planarity 2.7e-3 with them,
    # 8 irregular vertices and 4.4e-3 when they are released to the smooth pair)
    c = candidate_mesh((V, T), length, field=field, alignment=alignment, boundary="snap", name="surface",
                       release_separation=0.0)
    if len(c.F) == 0:
        raise InputError("faces", "the field pipeline found no quads at this spacing")
    warnings = list(c.warnings)
    CV, CF, welded = close_pinches(c.V, c.F)  # the snapping can pinch the outline at a spike: not a control mesh
    if welded:
        warnings.append(f"{welded} pinched corner(s) of the net's outline were welded and their pockets closed")
    used = np.unique(CF.ravel())
    remap = np.full(len(CV), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    Vc, Fc = control_mesh(CV[used], remap[CF], name="coarse")
    # exactly on the surface, boundary exactly on the surface boundary
    Vc = TriangleIndex(V, T, name="surface").query(Vc, name="coarse").points
    loop = boundary_loops(T, name="surface")[0]
    for lp in boundary_loops(Fc, name="coarse"):
        Vc[lp] = PolylineIndex(V[loop], closed=True, name="surface").query(Vc[lp], name="coarse").points
    # orientation like the surface
    index = TriangleIndex(V, T, name="surface")
    near = index.query(Vc[Fc].mean(axis=1), name="coarse")
    if np.einsum("ij,ij->", face_normals(Vc, Fc), face_normals(V, T)[near.faces]) < 0:
        Fc = pad_faces([list(dict.fromkeys(f))[::-1] for f in Fc.tolist()], k=Fc.shape[1])
    return Vc, Fc, warnings


def _turn_at(V, loop, at):
    """Turning angle (radians) of the closed boundary polyline ``V[loop]`` at the loop positions ``at``."""
    a = V[loop[at]] - V[loop[at - 1]]
    b = V[loop[(at + 1) % len(loop)]] - V[loop[at]]
    c = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
    return np.arccos(np.clip(c, -1.0, 1.0))


def grid_layout(V, T, faces: int = 36, min_turn: float = math.pi / 6):
    """A regular ``nu × nv`` grid between the four corners of a surface whose boundary has four clear corners.

    The surface is mapped onto the unit square with its four sharpest boundary turns at the square's corners
    (:func:`components.core.conformal.disk_map`, ``shape="square"``, sides by arc length); ``nu / nv`` follows the
    ratio of the mean lengths of opposite sides and ``nu · nv ≈ faces``; the nodes are lifted back by barycentric
    interpolation (boundary nodes land on the boundary polyline). No interior irregular vertex, every boundary
    corner a panel corner: the layout of strips, quadrilateral roofs and other four-sided patches.

    Returns
    -------
    (Vc, Q, UV) or None
        None when the boundary has no four corners turning by more than ``min_turn`` (radians).
    """
    UV, info = disk_map(V, T, shape="square")
    loop = boundary_loops(T, name="surface")[0]
    corners = info["corners"]
    if corners is None or len(corners) != 4:
        return None
    at = np.nonzero(np.isin(loop, corners))[0]
    if len(at) != 4 or np.any(_turn_at(V, loop, at) <= min_turn):
        return None
    seg = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)
    ends = UV[np.c_[loop, np.roll(loop, -1)]]  # (b, 2, 2)
    side = {}
    for key, axis, value in (("bottom", 1, 0.0), ("top", 1, 1.0), ("left", 0, 0.0), ("right", 0, 1.0)):
        side[key] = float(seg[np.all(np.abs(ends[:, :, axis] - value) < 1e-9, axis=1)].sum())
    along = 0.5 * (side["bottom"] + side["top"])
    across = 0.5 * (side["left"] + side["right"])
    if not (along > 0 and across > 0):
        return None
    nv = max(1, int(round(math.sqrt(faces * across / along))))
    nu = max(1, int(round(faces / nv)))
    u, v = np.meshgrid(np.linspace(0.0, 1.0, nu + 1), np.linspace(0.0, 1.0, nv + 1), indexing="ij")
    G = np.column_stack([u.ravel(), v.ravel()])
    idx = np.arange(len(G)).reshape(nu + 1, nv + 1)
    Q = np.stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()], 1)
    tri, w = _locate(UV, T, G)
    Vc = np.einsum("pk,pkd->pd", w, V[T[tri]])
    a0 = UV[T[:, 1]] - UV[T[:, 0]]
    a1 = UV[T[:, 2]] - UV[T[:, 0]]
    if np.sum(a0[:, 0] * a1[:, 1] - a0[:, 1] * a1[:, 0]) < 0:  # the map reverses the surface's orientation
        Q = Q[:, ::-1]
    return Vc, np.ascontiguousarray(Q, dtype=np.int64), G


def _auto_pick(V, T, faces, levels, index, aligned, ogrid, field):
    """The automatic layout among the aligned net, the best O-grid and, on a four-cornered surface, the grid.

    A net whose subdivided, pulled panels are all healthy (``bad == 0``: no corner under 15° or over 165°, none
    non-convex) beats one with bad panels: the planarization keeps such panels or makes them worse. Among nets of
    the same kind the aligned one is kept unless another ranks better by more than 25%, then the lower rank wins.

    Returns ``(layout, picked)``: ``picked`` is ``(score, Vc, Q, warnings)`` for ``"aligned"``, ``(score, Vc, Q,
    UV)`` for ``"grid"`` and ``None`` for ``"ogrid"`` (the caller's O-grid).
    """
    options = []
    if aligned is not None:
        ra, pa, Va, Fa, wa, ba = aligned
        options.append(("aligned", ba > 0, ra / 1.25, (pa, Va, Fa, wa)))
    options.append(("ogrid", ogrid[5] > 0, ogrid[0], None))
    try:
        grid = grid_layout(V, T, faces=faces)
        if grid is not None:  # a grid net with a degenerate panel (a corner of the map squeezed) is no option
            pg, rg, bg = _judge(grid[0], grid[1], levels, index)
            options.append(("grid", bg > 0, rg, (pg, grid[0], grid[1], grid[2])))
    except (ValueError, np.linalg.LinAlgError) as exc:  # InputError / MeshError are ValueErrors
        log.info("auto layout: no grid (%s)", exc)
    layout, _, rank, picked = min(options, key=lambda o: (o[1], o[2]))
    log.info("auto layout: %s (rank %.3g; candidates %s, %s field)", layout, rank,
             ", ".join(f"{o[0]} {o[2]:.3g}{' with bad panels' if o[1] else ''}" for o in options), field)
    return layout, picked


def coarse_net(V, T, faces: int = 36, singularities=None, singularity_index=None, layout: str = "auto",
               levels: int = 2, rotations: int = 4, field: str = "conjugate") -> CoarseNet:
    """Coarse quad control net of a disk-like surface from patches in its unit-disk map (array level).

    Parameters
    ----------
    V : (n, 3) float64
        Design surface vertices.
    T : (t, 3) int64
        Design surface triangles (one boundary loop, consistently oriented).
    faces : int
        Target number of coarse faces.
    singularities : (s, 3) array_like of float, optional
        Singular points (e.g. from :func:`components.subdivision.singularities.singularity_analysis`); the ``"patches"``
        layout puts its centre at the first one.
    singularity_index : (s,) array_like of float, optional
        Their indices (±0.25 …); default ``+1/4`` where the surface's Gaussian curvature is positive, else ``−1/4``.
    layout : {"auto", "aligned", "ogrid", "patches", "grid"}
        See the module notes.
    levels : int
        Subdivision levels the net is meant for (used to rank the candidates).
    rotations : int
        O-grid rotations tried in ``[0, π/2)``.
    field : {"conjugate", "principal"}
        Direction field of the ``"aligned"`` layout.

    Returns
    -------
    CoarseNet
    """
    sm = _surface_map(V, T)
    warnings = list(sm.warnings)
    index = TriangleIndex(V, T, name="surface")
    pts = None if singularities is None else np.asarray(singularities, dtype=np.float64).reshape(-1, 3)
    if pts is not None and len(pts) == 0:
        pts = None
    requested = layout
    if layout == "auto":
        layout = "patches" if pts is not None else "aligned"
    aligned = None
    if layout == "aligned":
        try:
            Va, Fa, wa = aligned_layout(V, T, faces=faces, field=field)
            pa, ra, ba = _judge(Va, Fa, levels, index)
            aligned = (ra, pa, Va, Fa, wa, ba)
            log.debug("aligned (%s) net: %d faces, mean planarity %.3g, rank %.3g", field, len(Fa), pa, ra)
        except (ValueError, np.linalg.LinAlgError) as exc:  # InputError / MeshError are ValueErrors
            msg = f"the {field} field pipeline gave no usable coarse net ({exc}); used the O-grid instead"
            if requested == "aligned":
                raise InputError("layout", msg) from exc
            warnings.append(msg)
        layout = "ogrid" if aligned is None or requested == "auto" else "aligned"
    if layout == "aligned":
        ra, sc, Vc, Q, wa, _ = aligned
        warnings += wa
        G = _uv_of_point(sm, Vc)[0]
    elif layout == "grid":
        grid = grid_layout(V, T, faces=faces)
        if grid is None:
            raise InputError("layout", "'grid' needs a surface whose boundary has four corners (turns over 30°)")
        Vc, Q, G = grid
        try:
            sc = _judge(Vc, Q, levels, index)[0]
        except MeshError as exc:  # our net, not the caller's mesh: say which layout to use instead
            raise InputError("layout", f"the grid net of this surface is unusable ({exc.detail}); use 'ogrid' or "
                                       "'aligned'") from None
    elif layout == "ogrid":
        if pts is not None:
            warnings.append("singularities: the O-grid places its own four valence-3 vertices; the given points "
                            "were not used (layout='patches' builds around a singularity)")
        n, k = ogrid_size(faces)
        best = None
        for phi in np.linspace(0.0, 0.5 * np.pi, max(1, int(rotations)), endpoint=False):
            G, Q, bang = ogrid_layout(n, k, float(phi))
            if sm.flip:
                Q = Q[:, ::-1].copy()
            Vc = _lift(sm, G, bang)
            sc, rank, bad = _judge(Vc, Q, levels, index)
            log.debug("ogrid n=%d k=%d phi=%.2f: mean planarity %.3g, rank %.3g", n, k, phi, sc, rank)
            if best is None or (bad > 0, rank) < (best[5] > 0, best[0]):
                best = (rank, sc, Vc, Q, G, bad)
        rank, sc, Vc, Q, G, bad = best
        if requested == "auto":
            layout, picked = _auto_pick(V, T, faces, levels, index, aligned, best, field)
            if layout == "aligned":
                sc, Vc, Q, wa = picked
                warnings += wa
                G = _uv_of_point(sm, Vc)[0]
            elif layout == "grid":
                sc, Vc, Q, G = picked
    else:
        if pts is None:
            centre, c = np.zeros(2), 4
        else:
            if len(pts) > 1:
                warnings.append(f"singularities: the patch layout uses one singular vertex; {len(pts) - 1} more "
                                "point(s) were ignored")
            if singularity_index is not None and len(np.atleast_1d(singularity_index)):
                idx = float(np.atleast_1d(np.asarray(singularity_index, dtype=np.float64))[0])
            else:
                _, K, _ = integrated_gaussian_curvature(V, T)
                idx = 0.25 if K[int(cKDTree(V).query(pts[0])[1])] > 0 else -0.25
            c = int(round(4 - 4 * idx))
            if not 3 <= c <= 8:
                raise InputError("singularity_index", f"{idx:g} gives a centre of valence {c}; use an index "
                                 "between -1 and 0.25 (valence 3 to 8)")
            centre, dist = _uv_of_point(sm, pts[0])
            centre = centre[0]
            if np.linalg.norm(centre) > 0.8:
                warnings.append("singularities: the singular point is close to the boundary; moved inward")
                centre = centre * 0.8 / np.linalg.norm(centre)
        m = max(1, int(round(math.sqrt(faces / c))))
        best = None
        for phi in np.linspace(0.0, 2 * np.pi / c, max(1, int(rotations)), endpoint=False):
            G, Q, bang, _, _ = patch_layout(c, m, centre, float(phi))
            if sm.flip:
                Q = Q[:, ::-1].copy()
            Vc = _lift(sm, G, bang)
            sc = _judge(Vc, Q, levels, index)[0]
            if best is None or sc < best[0]:
                best = (sc, Vc, Q, G)
        sc, Vc, Q, G = best
    irr, val = _interior_irregular(Q, len(Vc))
    return CoarseNet(Vc, Q, G, layout, irr, val, sc, warnings)


# ----------------------------------------------------------------------------------------------
# published component


class CoarseMeshResult(NamedTuple):
    coarse: Mesh
    irregular_vertices: Integers
    irregular_valences: Integers
    layout: str
    face_count: int
    predicted_planarity: float
    warnings: list[str]


def check_disk_surface(surface, name: str = "surface") -> tuple[np.ndarray, np.ndarray]:
    """A design-surface input that must be a topological disk: a ``(V, F)`` pair (triangulated if it has
    polygons), manifold and consistently oriented, with one boundary loop.

    Returns
    -------
    V : (n, 3) float64
    T : (t, 3) int64

    Raises
    ------
    MeshError
        Not a ``(V, F)`` pair, or a malformed, non-manifold or inconsistently oriented mesh.
    InputError
        ``"<name>: must be a topological disk with one boundary loop, it has …"``.

    Examples
    --------
    >>> from components.core.mesh import quad_grid
    >>> V, T = check_disk_surface(quad_grid(2, 2))
    >>> T.shape
    (8, 3)
    """
    V, F = check_mesh(surface, name, manifold=True)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    loops = boundary_loops(T, name=name)
    if len(loops) > 1:  # pieces that share positions are an unwelded mesh (every face on its own: a loop each)
        pieces = piece_count(T, len(V))
        if pieces > 1 and shared_positions(V, T):
            raise pieces_error(V, T, pieces, "split it into disk-like patches", name)
    if len(loops) != 1:
        raise InputError(name, f"must be a topological disk with one boundary loop, it has {len(loops)}: fill its "
                               "holes or split it into disk-like patches, or use fields/pq_from_conjugate_field "
                               "(the conjugate strategy), which takes surfaces with holes")
    return V, T


def coarse_mesh(surface: Mesh, faces: int = 36, singularities: Points | None = None,
                singularity_index: Numbers | None = None, layout: str = "auto",
                levels: int = 2) -> CoarseMeshResult:
    """Automatic coarse quad control net of a disk-like design surface, laid out by patches in its disk map.

    Parameters
    ----------
    surface : Mesh
        The design surface as a triangle (or polygon) mesh: a topological disk (one boundary loop).
    faces : int
        Target number of coarse faces (each Catmull-Clark level multiplies it by 4).
    singularities : Points | None
        Optional singular points, e.g. the suggestions of singularity_analysis; the "patches" layout centres on the
        first one.
    singularity_index : Numbers | None
        Optional index of each singular point (0.25 for valence 3, -0.25 for valence 5); by default the sign of the
        local Gaussian curvature.
    layout : str
        "auto" (patches around the first singularity if any, else the best ranked of the aligned net, the O-grid
        and, on a surface with four boundary corners, the grid), "aligned" (along the conjugate direction field),
        "ogrid" (block and rings, every boundary node of valence 3), "patches" (c patches around one vertex of
        valence c) or "grid" (a regular grid between four boundary corners).
    levels : int
        Subdivision levels the net is meant for; the layout's rotation is chosen by the mean planarity of the
        net after these levels, pulled onto the surface.

    Returns
    -------
    coarse : Mesh
        The coarse quad net (V, F), vertices on the surface, boundary vertices on the surface boundary, faces
        oriented like the surface.
    irregular_vertices : Integers
        Interior vertices of the net whose valence is not 4 (its singularities).
    irregular_valences : Integers
        Their valences.
    layout : str
        The layout used ("aligned", "ogrid", "patches" or "grid").
    face_count : int
        Number of coarse faces.
    predicted_planarity : float
        Mean scale-free planarity of the net after levels subdivisions, pulled onto the surface.

    Raises
    ------
    MeshError
        The surface is malformed, non-manifold or inconsistently oriented.
    InputError
        The surface is not a disk; faces, levels, layout, singularities or their index are invalid.

    Notes
    -----
    Step 2 of the subdivision strategy of Liu et al., "Geometric modeling with conical meshes and developable
    surfaces", SIGGRAPH 2006 ("2D map by patches"): a fixed-boundary harmonic disk map (Eck et al. 1995, Floater
    2003 as fallback), isocurves of O-grid or Coons patches, lifted back by barycentric interpolation.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 16)
    >>> res = coarse_mesh((V, T), faces=32)
    >>> res.layout in ("aligned", "ogrid")
    True
    """
    faces = check_int(faces, "faces", 4, MAX_COARSE_FACES)
    levels = check_int(levels, "levels", 0, 8)
    layout = check_choice(layout, "layout", LAYOUTS)
    pts = check_points(singularities, "singularities")
    pts = pts if len(pts) else None
    idx = None
    if singularity_index is not None:
        try:
            idx = np.asarray(singularity_index, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise InputError("singularity_index", "must be numbers") from None
        if not np.all(np.isfinite(idx)):
            raise InputError("singularity_index", "has a NaN or infinite value")
        if pts is not None and len(idx) and len(idx) != len(pts):
            raise InputError("singularity_index", f"has {len(idx)} values for {len(pts)} singularities")
    V, T = check_disk_surface(surface)
    net = coarse_net(V, T, faces=faces, singularities=pts, singularity_index=idx, layout=layout, levels=levels)
    return CoarseMeshResult((net.V, net.Q), net.singular, net.valence, net.layout, int(len(net.Q)), net.score,
                        net.warnings)
