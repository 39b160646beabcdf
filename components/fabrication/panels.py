"""Flat panels: every face of a (planar-quad) mesh laid flat in its own frame, measured, labelled and nested on sheets.

Array-level functions: :func:`outward_sign` (which side of the mesh is the outside), :func:`grid_positions` and
:func:`panel_labels` (row/column labels of a quad grid), :func:`diagonal_pairs`, :func:`flat_panels` (frames, flat
outlines and their measures), :func:`sheet_layout` (shelf packing of the outlines' bounding rectangles),
:func:`placed_outlines` and :func:`sheet_transforms` (the outlines on the sheets and each panel's 3D → sheet
transform). Published component: :func:`panels` (``fabrication/panels``).

Conventions shared by the whole stage: a panel is a face of the input mesh and its id is the face index; angles are
in degrees; lengths and areas are in model units; the *outside* of the design surface is chosen once per mesh by
:func:`outward_sign` and every frame's z axis, kink sign and node axis points to it.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Annotated, NamedTuple

import numpy as np

from components.core.checks import check_choice, check_length, check_mesh, check_number, zero_edge_error
from components.core.errors import InputError, MeshError
from components.core.measures import cross, dot, face_data, least_squares_planes, norm, unit
from components.core.mesh import (WELD_FRACTION, bounding_box_diagonal, boundary_loops, boundary_vertex_mask,
                                  edge_topology, face_sizes, halfedges, weld_map)
from components.core.types import Curves, Integers, Mesh, Numbers, Plane, Points, Texts

__all__ = [
    "Planes",
    "FlatPanels",
    "SheetLayout",
    "PanelsResult",
    "METHODS",
    "ORIENTATIONS",
    "checked_panelling",
    "unwelded_warning",
    "outward_sign",
    "grid_positions",
    "panel_labels",
    "diagonal_pairs",
    "flat_panels",
    "sheet_layout",
    "placed_outlines",
    "sheet_transforms",
    "closed_polylines",
    "panels",
]

#: a list of :class:`components.core.types.Plane` values (Grasshopper Plane list)
Planes = Annotated[list, "Plane", "list"]

#: flattening methods of :func:`flat_panels`
METHODS = ("project", "unfold")
#: frame orientations of :func:`flat_panels`
ORIENTATIONS = ("outside", "mesh")

_STEP = ((-1, 0), (0, 1), (1, 0), (0, -1))  # grid direction → (row, column) step


# ----------------------------------------------------------------------------------------------
# the input


def checked_panelling(mesh: Mesh, name: str = "mesh") -> tuple[np.ndarray, np.ndarray, int]:
    """A panelling checked for fabrication: :func:`~components.core.checks.check_mesh`, and no face with two corners
    at one point (within :data:`~components.core.mesh.WELD_FRACTION` of the bounding-box diagonal, as the planarizer
    welds): such a face's flat outline, edges and angles would describe a polygon that is not the panel, so it is
    refused, naming the face. Returns ``V, F`` and the number of vertices that lie on another vertex of other faces
    (an unwelded mesh: the panels are fine, the joints there are not seen; :func:`unwelded_warning`).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(2, 1)
    >>> F[1, 0] = len(V)  # the second panel's first corner: a copy of the vertex it shares with the first
    >>> checked_panelling((np.vstack([V, V[F[0, 1]]]), F))[2]
    1
    """
    V, F = check_mesh(mesh, name)
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    lo, hi = V[used].min(axis=0), V[used].max(axis=0)
    X = V - 0.5 * (lo + hi)  # no digit lost at site coordinates
    tol = WELD_FRACTION * float(np.linalg.norm(hi - lo))
    rep = weld_map(X, used, tol)
    if rep is None:
        return V, F, 0
    err = zero_edge_error(X, F, face_sizes(F), rep, tol, name)
    if err is not None:
        raise err
    return V, F, int(np.count_nonzero(rep[used] != np.nonzero(used)[0]))


def unwelded_warning(count: int) -> list[str]:
    """The warning for ``count`` vertices lying on others (:func:`checked_panelling`): none when 0."""
    if not count:
        return []
    what = "1 vertex lies on another vertex" if count == 1 else f"{count} vertices lie on other vertices"
    return [f"{what} (the mesh is not welded there): the joints between the panels that meet there are not "
            "measured; weld it (Rhino: _Weld) and send it again"]


# ----------------------------------------------------------------------------------------------
# orientation and labels


def outward_sign(V, F) -> float:
    """``+1.0`` when the faces' own orientation (their Newell normals) points to the outside, else ``-1.0``.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces, consistently oriented.

    Returns
    -------
    float
        ``+1.0`` or ``-1.0``.

    Notes
    -----
    A closed mesh: the side its volume is positive for (outward normals). An open mesh with one boundary loop (a
    roof, a canopy): up (+z, Rhino's up) when the summed area vector ``Σ A_f`` (the area vector of the boundary
    loop) has an upward or downward part over 1e-2 of the total area, so domes, vaults, bowls and saddles all face
    the sky; otherwise (a curved facade) the side pointing away from the boundary centroid ``G``, the sign of
    ``Σ_f (c_f − G) · A_f`` (``c_f`` face centroid) when it is over 1e-3 of ``Σ|A_f| ×`` the bounding-box
    diagonal; otherwise (a flat facade) the faces' own orientation. With several boundary loops (a tube, a
    tower's skin) the side away from ``G`` comes first, then up.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 2)
    >>> outward_sign(V, Q), outward_sign(V, Q[:, ::-1])
    (1.0, -1.0)
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if len(F) == 0:
        return 1.0
    Vc = V - 0.5 * (V.min(axis=0) + V.max(axis=0))
    fd = face_data(Vc, F)
    A = fd.area_vec
    total = float(norm(A).sum())
    if total == 0.0:
        return 1.0
    w = fd.valid.astype(np.float64)
    C = np.einsum("mk,mkj->mj", w, fd.points) / fd.sizes[:, None]
    bnd = boundary_vertex_mask(F, len(V))
    if not bnd.any():
        vol = float(dot(C, A).sum())
        return -1.0 if vol < 0 else 1.0
    up = float(A[:, 2].sum())
    away = float(dot(C - Vc[bnd].mean(axis=0), A).sum())
    try:
        loops = len(boundary_loops(F))
    except MeshError:
        loops = 1
    rules = [(away, 1e-3 * total * bounding_box_diagonal(Vc)), (up, 1e-2 * total)]
    for value, floor in (rules[::-1] if loops == 1 else rules):
        if abs(value) > floor:
            return 1.0 if value > 0 else -1.0
    return 1.0


def _twins(F: np.ndarray) -> np.ndarray:
    """The opposite half-edge of every half-edge (in :func:`components.core.mesh.halfedges` order), -1 on the
    boundary."""
    H, _ = halfedges(F)
    n = int(F.max()) + 1
    key = H[:, 0] * n + H[:, 1]
    order = np.argsort(key, kind="stable")
    sk = key[order]
    want = H[:, 1] * n + H[:, 0]
    pos = np.minimum(np.searchsorted(sk, want), len(sk) - 1)
    return np.where(sk[pos] == want, order[pos], -1)


def grid_positions(F) -> np.ndarray | None:
    """Row and column of every face when the quad mesh is a grid (also one closed around a cylinder), else ``None``.

    Parameters
    ----------
    F : (m, 4) int64
        Quad faces, consistently oriented.

    Returns
    -------
    (m, 2) int64 or None
        ``(row, column)`` from 0: the first face's first edge runs along its row (the next column is across its
        second edge, the next row across its third); ``None`` when a face is not a quad, the mesh is not connected,
        or it has an interior singularity (a vertex that is not met by four quads, so rows and columns do not
        continue consistently).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> grid_positions(quad_grid(3, 2)[1]).tolist()
    [[0, 0], [0, 1], [0, 2], [1, 0], [1, 1], [1, 2]]
    >>> Q = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])  # a ring of four quads
    >>> grid_positions(Q)[:, 1].tolist()
    [0, 1, 2, 3]
    """
    F = np.asarray(F, dtype=np.int64)
    m = len(F)
    if m == 0 or F.shape[1] < 4 or np.any(face_sizes(F) != 4):
        return None
    F = F[:, :4]
    if np.any(edge_topology(F).count > 2):
        return None
    twin = _twins(F).reshape(m, 4).tolist()  # all quads: half-edge h is corner h % 4 of face h // 4
    rot = [-1] * m
    row = [0] * m
    col = [0] * m
    rot[0] = 0  # crossing edge e of face f steps in direction (e + rot[f]) % 4: face 0's edge 1 to the next column
    queue = deque([0])
    while queue:
        f = queue.popleft()
        rf, r, c = rot[f], row[f], col[f]
        for s, t in enumerate(twin[f]):
            if t < 0:
                continue
            g, s2 = divmod(t, 4)
            d = (s + rf) % 4
            if rot[g] < 0:
                rot[g] = (d + 2 - s2) % 4
                row[g] = r + _STEP[d][0]
                col[g] = c + _STEP[d][1]
                queue.append(g)
            elif (s2 + rot[g]) % 4 != (d + 2) % 4:
                return None  # directions turn around an interior vertex: a singularity
    if min(rot) < 0:
        return None
    pos = np.stack([np.asarray(row), np.asarray(col)], axis=1).astype(np.int64)
    pos -= pos.min(axis=0)
    # a grid closed around (a cylinder) meets itself across a seam: number around from the first face
    tw = np.asarray(twin).ravel()
    h = np.nonzero(tw >= 0)[0]
    f, g = h // 4, tw[h] // 4
    d = (h % 4 + np.asarray(rot)[f]) % 4
    step = np.asarray(_STEP)[d]
    seam = np.any(pos[g] != pos[f] + step, axis=1)
    if seam.any():
        period = pos.max(axis=0) + 1
        for axis in (0, 1):
            on = seam & (step[:, axis] != 0)
            if not on.any():
                continue
            if np.any((pos[g[on]] - pos[f[on]] - step[on]) % period != 0):
                return None
            pos[:, axis] = (pos[:, axis] - pos[0, axis]) % period[axis]
        if np.any(seam & np.all(step == 0, axis=1)):
            return None
    if len(np.unique(pos[:, 0] * (int(pos[:, 1].max()) + 1) + pos[:, 1])) != m:
        return None
    return pos


def _letters(i: int) -> str:
    s = ""
    i += 1
    while i:
        i, r = divmod(i - 1, 26)
        s = chr(65 + r) + s
    return s


def panel_labels(F) -> tuple[list[str], np.ndarray]:
    """A readable label for every face: row letter and column number on a grid (``A01``), else ``P`` and the index.

    Parameters
    ----------
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    labels : list of str
        ``"A01"``, ``"A02"``, … ``"B01"``… (row letters ``A``–``Z``, ``AA``…, columns from 1, zero-padded) when
        :func:`grid_positions` finds a grid, else ``"P0000"``, ``"P0001"``… (the face index, zero-padded).
    grid : (m, 2) int64
        Row and column of every face, -1 when the mesh is not a grid.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> panel_labels(quad_grid(2, 2)[1])[0]
    ['A01', 'A02', 'B01', 'B02']
    """
    F = np.asarray(F, dtype=np.int64)
    pos = grid_positions(F)
    if pos is None:
        w = max(4, len(str(max(len(F) - 1, 0))))
        return [f"P{i:0{w}d}" for i in range(len(F))], np.full((len(F), 2), -1, dtype=np.int64)
    w = max(2, len(str(int(pos[:, 1].max()) + 1)))
    return [f"{_letters(int(r))}{int(c) + 1:0{w}d}" for r, c in pos.tolist()], pos


# ----------------------------------------------------------------------------------------------
# flat panels


def diagonal_pairs(k: int) -> np.ndarray:
    """The corner pairs ``(i, j)``, ``i < j``, of a polygon of up to ``k`` corners that are not neighbours.

    Returns
    -------
    (p, 2) int64
        Pairs in lexicographic order; for a face of ``s < k`` corners only the pairs with ``j < s`` and
        ``(i, j) != (0, s - 1)`` are diagonals.

    Example
    -------
    >>> diagonal_pairs(4).tolist()
    [[0, 2], [1, 3]]
    """
    pairs = [(i, j) for i in range(k) for j in range(i + 2, k) if not (i == 0 and j == k - 1)]
    pairs += [(0, j) for j in range(2, k - 1) if (0, j) not in pairs]
    return np.array(sorted(set(pairs)), dtype=np.int64).reshape(-1, 2)


class FlatPanels(NamedTuple):
    """Every face of a mesh as a flat panel (see :func:`flat_panels`); ``m`` panels of up to ``k`` corners."""

    ids: np.ndarray  # (m,) int64 face index of every panel (the stable panel id)
    labels: list  # m readable labels (row/column on a grid, else the index)
    grid: np.ndarray  # (m, 2) int64 row and column, -1 when the mesh is not a grid
    sizes: np.ndarray  # (m,) int64 corner count
    origin: np.ndarray  # (m, 3) frame origin: the first corner projected onto the best-fit plane
    xaxis: np.ndarray  # (m, 3) unit, along the first edge (projected)
    yaxis: np.ndarray  # (m, 3) unit, zaxis × xaxis
    zaxis: np.ndarray  # (m, 3) unit normal of the best-fit plane, to the outside
    outline: np.ndarray  # (m, k, 2) flat corners in the frame (outline[:, 0] = 0; padding repeats the last corner)
    residual: np.ndarray  # (m, k) signed distance of every corner to the best-fit plane along zaxis (0 on padding)
    edge_lengths: np.ndarray  # (m, k) flat edge i → i+1 (NaN on padding)
    corner_angles: np.ndarray  # (m, k) flat interior angles, degrees (NaN on padding)
    diagonals: np.ndarray  # (m, p) flat diagonals in diagonal_pairs(k) order (NaN where not a diagonal)
    area: np.ndarray  # (m,) flat area
    centroid: np.ndarray  # (m, 2) area centroid of the flat outline
    rect_width: np.ndarray  # (m,) smallest-area bounding rectangle: the longer side
    rect_height: np.ndarray  # (m,) its shorter side
    rect_angle: np.ndarray  # (m,) rotation (radians) turning the outline so that the rectangle is axis-aligned
    length_error: np.ndarray  # (m,) largest |flat − 3D| / 3D over the edges and diagonals
    orientation: float  # outward_sign(V, F) (1.0 when orientation="mesh")
    method: str


def _corner_index(sizes: np.ndarray, k: int):
    cols = np.arange(k)[None, :]
    s = sizes[:, None]
    valid = cols < s
    nxt = np.where(cols >= s - 1, 0, cols + 1)
    prv = np.where(cols == 0, s - 1, np.minimum(cols - 1, s - 1))
    return valid, nxt, prv


def _take(A: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``A[f, idx[f, j]]`` for ``A (m, k, ...)`` and ``idx (m, q)``."""
    return np.take_along_axis(A, idx.reshape(idx.shape + (1,) * (A.ndim - 2)), axis=1)


def _unfolded(D: np.ndarray, sizes: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """Triangle-fan development from corner 0: every edge and every diagonal from corner 0 keeps its 3D length."""
    m, k, _ = D.shape
    U = np.zeros((m, k, 2))
    U[:, 1, 0] = norm(D[:, 1])
    for i in range(2, k):
        a = U[:, i - 1]
        d = norm(np.concatenate([a, np.zeros((m, 1))], axis=1))
        r0 = norm(D[:, i])
        r1 = norm(D[:, i] - D[:, i - 1])
        ds = np.where(d > 0, d, 1.0)
        t = (r0 * r0 - r1 * r1 + d * d) / (2.0 * ds)
        h = np.sqrt(np.maximum(r0 * r0 - t * t, 0.0))
        side = np.where(dot(cross(D[:, i - 1], D[:, i]), Z) < 0, -1.0, 1.0)
        ua = a / ds[:, None]
        perp = np.stack([-ua[:, 1], ua[:, 0]], axis=1)
        P = t[:, None] * ua + (side * h)[:, None] * perp
        U[:, i] = np.where((i < sizes)[:, None], P, U[:, i - 1])
    return U


def _rectangles(U: np.ndarray, valid: np.ndarray, nxt: np.ndarray):
    """Smallest-area bounding rectangle of every outline (a side lies along an outline edge)."""
    m, k, _ = U.shape
    E = _take(U, nxt) - U
    L = np.hypot(E[..., 0], E[..., 1])
    ok = valid & (L > 0)
    first = E[:, :1] / np.maximum(L[:, :1], 1e-300)[..., None]  # a degenerate edge takes the first edge's direction
    Dn = np.where(ok[..., None], E / np.where(L > 0, L, 1.0)[..., None], first)
    best_area = np.full(m, np.inf)
    width = np.zeros(m)
    height = np.zeros(m)
    angle = np.zeros(m)
    for j in range(k):
        d = Dn[:, j]
        u = U[..., 0] * d[:, None, 0] + U[..., 1] * d[:, None, 1]
        v = -U[..., 0] * d[:, None, 1] + U[..., 1] * d[:, None, 0]
        w = u.max(axis=1) - u.min(axis=1)
        h = v.max(axis=1) - v.min(axis=1)
        area = w * h
        better = area < best_area * (1.0 - 1e-12)
        best_area = np.where(better, area, best_area)
        width = np.where(better, w, width)
        height = np.where(better, h, height)
        angle = np.where(better, -np.arctan2(d[:, 1], d[:, 0]), angle)
    turn = height > width
    width, height = np.where(turn, height, width), np.where(turn, width, height)
    angle = np.where(turn, angle + 0.5 * np.pi, angle)
    return width, height, angle


def flat_panels(V, F, method: str = "project", orientation: str = "outside") -> FlatPanels:
    """Lay every face flat in its own frame and measure it as it will be cut.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces, consistently oriented.
    method : {"project", "unfold"}
        ``"project"``: the corners projected onto the face's least-squares plane (exact for a planar face; a
        warped face's distances shrink by second-order terms in its residual). ``"unfold"``: a triangle fan from
        the first corner developed into the plane, which keeps every edge length and the diagonals from the first
        corner exactly even for a warped face (the other diagonals then differ).
    orientation : {"outside", "mesh"}
        Frame normals to the outside of the design surface (:func:`outward_sign`) or along the faces' own order.

    Returns
    -------
    FlatPanels
        Frames, flat outlines and their measures (see the fields of :class:`FlatPanels`).

    Notes
    -----
    The frame of a panel: ``zaxis`` the unit normal of the least-squares plane of its corners (to the outside),
    ``origin`` the first corner projected onto that plane, ``xaxis`` the first edge projected onto it, ``yaxis =
    zaxis × xaxis``; a corner's flat position is ``((p − origin)·xaxis, (p − origin)·yaxis)`` and its
    ``residual`` is ``(p − origin)·zaxis``. For a planar face the flat outline has the 3D edge lengths and
    diagonals to rounding (relative 1e-15); ``length_error`` reports the largest relative difference for every
    face. Everything is computed from corner differences, so models far from the origin (site coordinates) lose no
    digits.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> fp = flat_panels(*quad_grid(1, 1, 2.0, 1.0))
    >>> fp.outline[0].tolist(), fp.area.tolist(), fp.corner_angles[0].tolist()
    ([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]], [2.0], [90.0, 90.0, 90.0, 90.0])
    """
    check_choice(method, "method", METHODS)
    check_choice(orientation, "orientation", ORIENTATIONS)
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0)) if len(V) else np.zeros(3)
    Vc = V - centre
    fd = face_data(Vc, F)
    sizes = fd.sizes
    _, N, dist = least_squares_planes(fd, np.arange(m))
    sigma = outward_sign(V, F) if orientation == "outside" else 1.0
    Z = sigma * N
    P = fd.points
    D = P - P[:, :1]
    e0 = D[:, 1]
    X = unit(e0 - dot(e0, Z)[:, None] * Z)
    Y = cross(Z, X)
    residual = sigma * dist  # 0 on padding corners
    origin = P[:, 0] - residual[:, :1] * Z + centre
    if method == "project":
        U = np.stack([np.einsum("mkj,mj->mk", D, X), np.einsum("mkj,mj->mk", D, Y)], axis=-1)
        U[:, 0] = 0.0
    else:
        U = _unfolded(D, sizes, Z)
    valid, nxt, prv = _corner_index(sizes, k)
    # lengths: flat and 3D
    E2 = _take(U, nxt) - U
    E3 = _take(D, nxt) - D
    L2 = np.hypot(E2[..., 0], E2[..., 1])
    L3 = norm(E3)
    pairs = diagonal_pairs(k)
    if len(pairs):
        closing = (pairs[None, :, 0] == 0) & (pairs[None, :, 1] == sizes[:, None] - 1)  # an edge, not a diagonal
        dvalid = (pairs[None, :, 1] < sizes[:, None]) & ~closing
        G2 = U[:, pairs[:, 1]] - U[:, pairs[:, 0]]
        G3 = D[:, pairs[:, 1]] - D[:, pairs[:, 0]]
        dg2 = np.hypot(G2[..., 0], G2[..., 1])
        dg3 = norm(G3)
    else:
        dvalid = np.zeros((m, 0), dtype=bool)
        dg2 = dg3 = np.zeros((m, 0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel_e = np.where(valid & (L3 > 0), np.abs(L2 - L3) / np.where(L3 > 0, L3, 1.0), 0.0)
        rel_d = np.where(dvalid & (dg3 > 0), np.abs(dg2 - dg3) / np.where(dg3 > 0, dg3, 1.0), 0.0)
    length_error = np.maximum(rel_e.max(axis=1, initial=0.0), rel_d.max(axis=1, initial=0.0))
    # signed area, centroid, interior angles of the flat outline
    Un = _take(U, nxt)
    cr = (U[..., 0] * Un[..., 1] - U[..., 1] * Un[..., 0]) * valid
    A2 = 0.5 * cr.sum(axis=1)
    As = np.where(A2 != 0, A2, 1.0)
    cen = np.stack([((U[..., 0] + Un[..., 0]) * cr).sum(axis=1), ((U[..., 1] + Un[..., 1]) * cr).sum(axis=1)], 1)
    cen = np.where((A2 != 0)[:, None], cen / (6.0 * As[:, None]),
                   (U * valid[..., None]).sum(axis=1) / sizes[:, None])
    a = U - _take(U, prv)
    b = E2
    turn = np.arctan2(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1])
    interior = np.degrees(np.pi - np.where(A2 < 0, -1.0, 1.0)[:, None] * turn)
    width, height, angle = _rectangles(U, valid, nxt)
    labels, grid = panel_labels(F)
    nan = np.nan
    return FlatPanels(
        ids=np.arange(m, dtype=np.int64), labels=labels, grid=grid, sizes=sizes.astype(np.int64), origin=origin,
        xaxis=X, yaxis=Y, zaxis=Z, outline=U, residual=np.where(valid, residual, 0.0),
        edge_lengths=np.where(valid, L2, nan), corner_angles=np.where(valid, interior, nan),
        diagonals=np.where(dvalid, dg2, nan), area=np.abs(A2), centroid=cen, rect_width=width, rect_height=height,
        rect_angle=angle, length_error=length_error, orientation=float(sigma), method=method,
    )


# ----------------------------------------------------------------------------------------------
# sheets


class SheetLayout(NamedTuple):
    """Where every flat outline goes (see :func:`sheet_layout`)."""

    sheet: np.ndarray  # (m,) int64 sheet of every panel
    angle: np.ndarray  # (m,) rotation (radians) applied to the panel's flat outline
    offset: np.ndarray  # (m, 2) translation applied after the rotation (drawing coordinates, sheet origin included)
    sheet_origin: np.ndarray  # (s, 2) lower-left corner of every sheet in the drawing
    sheet_width: float
    sheet_height: float
    sheet_count: int
    gap: float


def _rotate(U: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return np.stack([c * U[..., 0] - s * U[..., 1], s * U[..., 0] + c * U[..., 1]], axis=-1)


def sheet_layout(flat: FlatPanels, sheet_width: float = 0.0, sheet_height: float = 0.0,
                 gap: float = 0.0) -> SheetLayout:
    """Nest the flat outlines on rectangular sheets: shelf packing of their smallest bounding rectangles.

    Parameters
    ----------
    flat : FlatPanels
        From :func:`flat_panels`.
    sheet_width : float
        Sheet width in model units; 0 or less: one sheet about as wide as it is high (the square root of the
        rectangles' total area, at least the widest panel).
    sheet_height : float
        Sheet height in model units; 0 or less: unlimited (one sheet, as high as needed).
    gap : float
        Clear distance between the bounding rectangles, and to the sheet's edges, in model units (>= 0).

    Returns
    -------
    SheetLayout
        The sheet, rotation and translation of every panel; sheets lie side by side along x in the drawing.

    Raises
    ------
    InputError
        ``sheet_width`` when a panel fits on the sheet in neither direction; ``gap`` when negative.

    Notes
    -----
    First-fit decreasing height (Coffman, Garey, Johnson, Tarjan 1980): rectangles (long side along x, turned a
    quarter when only that fits) sorted by height, each put on the first shelf with room, a new shelf opened on
    the first sheet with height left, else on a new sheet. Rectangles never overlap and keep ``gap`` between each
    other, so neither do the outlines inside them.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> lay = sheet_layout(flat_panels(*quad_grid(3, 1, 3.0, 1.0)), sheet_width=2.5, gap=0.1)
    >>> lay.sheet.tolist(), lay.sheet_count
    ([0, 0, 0], 1)
    """
    gap = check_number(gap, "gap", 0)
    W = check_number(sheet_width, "sheet_width", 0)
    H = check_number(sheet_height, "sheet_height", 0)
    m = len(flat.ids)
    w = flat.rect_width.copy()
    h = flat.rect_height.copy()
    angle = flat.rect_angle.copy()
    if W <= 0:
        W = max(float(w.max(initial=0.0)), math.sqrt(float(((w + gap) * (h + gap)).sum()))) + 2.0 * gap
    Wu = W - 2.0 * gap
    Hu = H - 2.0 * gap if H > 0 else np.inf
    slack = 1e-12 * max(W, float(w.max(initial=0.0)))
    fits = (w <= Wu + slack) & (h <= Hu + slack)
    turned = ~fits & (h <= Wu + slack) & (w <= Hu + slack)
    bad = ~fits & ~turned
    if bad.any():
        i = int(np.argmax(bad))
        size = f"{W:g} × {H:g}" if H > 0 else f"{W:g} wide"
        raise InputError("sheet_width", f"panel {flat.labels[i]} ({w[i]:.4g} × {h[i]:.4g}) does not fit on a {size} "
                                        f"sheet with a gap of {gap:g}: use larger sheets (or a smaller gap)")
    w, h = np.where(turned, h, w), np.where(turned, w, h)
    angle = np.where(turned, angle + 0.5 * np.pi, angle)
    order = np.lexsort((np.arange(m), -w, -h))
    pos = np.zeros((m, 2))
    sheet = np.zeros(m, dtype=np.int64)
    free = np.empty(m)  # room left on every shelf (x of its next item)
    shelf_x = np.empty(m)
    shelf_y = np.empty(m)
    shelf_sheet = np.empty(m, dtype=np.int64)
    n_shelves = 0
    used = []  # per sheet: y of the next shelf
    for i in order.tolist():
        wi, hi = w[i], h[i]
        hit = np.flatnonzero(free[:n_shelves] >= wi - slack)
        if len(hit):
            s = int(hit[0])
        else:
            for sh, y in enumerate(used):
                if y + hi <= H - gap + slack or H <= 0:
                    break
            else:
                sh = len(used)
                used.append(gap)
            s = n_shelves
            n_shelves += 1
            shelf_sheet[s], shelf_y[s], shelf_x[s] = sh, used[sh], gap
            free[s] = W - 2.0 * gap
            used[sh] += hi + gap
        pos[i] = (shelf_x[s], shelf_y[s])
        sheet[i] = shelf_sheet[s]
        shelf_x[s] += wi + gap
        free[s] -= wi + gap
    n_sheets = max(len(used), 1)
    height = H if H > 0 else (max(used) if used else 2.0 * gap)
    spacing = max(2.0 * gap, 0.05 * W)
    origins = np.stack([np.arange(n_sheets) * (W + spacing), np.zeros(n_sheets)], axis=1)
    R = _rotate(flat.outline, angle)
    lo = R.min(axis=1)
    offset = origins[sheet] + pos - lo
    return SheetLayout(sheet, angle, offset, origins, float(W), float(height), int(n_sheets), float(gap))


def placed_outlines(flat: FlatPanels, layout: SheetLayout) -> np.ndarray:
    """The flat outlines where :func:`sheet_layout` put them: ``(m, k, 2)`` drawing coordinates.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> fp = flat_panels(*quad_grid(1, 1)); placed_outlines(fp, sheet_layout(fp, gap=0.5))[0].min(axis=0).tolist()
    [0.5, 0.5]
    """
    return _rotate(flat.outline, layout.angle) + layout.offset[:, None, :]


def sheet_transforms(flat: FlatPanels, layout: SheetLayout) -> np.ndarray:
    """The rigid 3D → drawing transform of every panel: ``(m, 4, 4)`` matrices acting on ``(x, y, z, 1)``.

    A panel's corner ``p`` goes to ``T @ (p, 1) = (u, v, residual, 1)`` with ``(u, v)`` its place on the sheets
    (:func:`placed_outlines`, exactly for ``method="project"``) and ``residual`` its distance to the panel's plane.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> fp = flat_panels(*quad_grid(1, 1)); T = sheet_transforms(fp, sheet_layout(fp))
    >>> (T[0] @ [1.0, 1.0, 0.0, 1.0]).round(12).tolist()
    [1.0, 1.0, 0.0, 1.0]
    """
    m = len(flat.ids)
    L = np.stack([flat.xaxis, flat.yaxis, flat.zaxis], axis=1)  # rows: the local axes
    to_local = np.zeros((m, 4, 4))
    to_local[:, :3, :3] = L
    to_local[:, :3, 3] = -np.einsum("mij,mj->mi", L, flat.origin)
    to_local[:, 3, 3] = 1.0
    c, s = np.cos(layout.angle), np.sin(layout.angle)
    place = np.zeros((m, 4, 4))
    place[:, 0, 0], place[:, 0, 1], place[:, 1, 0], place[:, 1, 1] = c, -s, s, c
    place[:, 2, 2] = place[:, 3, 3] = 1.0
    place[:, :2, 3] = layout.offset
    return place @ to_local


def closed_polylines(points: np.ndarray, sizes: np.ndarray) -> list[np.ndarray]:
    """Closed polylines ``(s + 1, 3)`` (the first point repeated at the end) from padded ``(m, k, 2 or 3)`` corners.

    Example
    -------
    >>> closed_polylines(np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]), np.array([3]))[0].shape
    (4, 3)
    """
    P = np.asarray(points, dtype=np.float64)
    if P.shape[-1] == 2:
        P = np.concatenate([P, np.zeros(P.shape[:-1] + (1,))], axis=-1)
    return [np.concatenate([p[:s], p[:1]], axis=0) for p, s in zip(P, np.asarray(sizes).tolist())]


# ----------------------------------------------------------------------------------------------
# published component


class PanelsResult(NamedTuple):
    outlines: Curves
    labels: Texts
    label_points: Points
    ids: Integers
    sheets: Integers
    sheet_outlines: Curves
    frames: Planes
    sheet_frames: Planes
    corner_counts: Integers
    edge_lengths: Numbers
    corner_angles: Numbers
    diagonals: Numbers
    areas: Numbers
    rectangle_width: Numbers
    rectangle_height: Numbers
    residuals: Numbers
    max_residual: float
    max_length_error: float
    sheet_count: int
    warnings: list[str]


def panels(mesh: Mesh, sheet_width: float = 0.0, sheet_height: float = 0.0, gap: float = 0.0,
           method: str = "project", orientation: str = "outside") -> PanelsResult:
    """Flat panels of a planar-quad mesh: outlines laid out on sheets, labels, frames and dimensions.

    Parameters
    ----------
    mesh : Mesh
        The panelling ``(V, F)``: quads (or any polygons), consistently oriented.
    sheet_width : float
        Sheet width in model units; 0: one sheet about as wide as high.
    sheet_height : float
        Sheet height in model units; 0: unlimited.
    gap : float
        Clear distance between the panels' bounding rectangles and to the sheet edges, in model units.
    method : str
        ``"project"``: corners projected onto each panel's least-squares plane (exact for planar panels);
        ``"unfold"``: a warped panel developed so that its edge lengths stay exact.
    orientation : str
        ``"outside"``: every frame's z axis to the outside of the design surface; ``"mesh"``: along the faces' order.

    Returns
    -------
    outlines : Curves
        Closed flat outline of every panel on the sheets (z = 0), corner i of the panel at point i.
    labels : Texts
        Readable label of every panel: row letter and column on a grid (``A01``), else ``P`` and the face index.
    label_points : Points
        Where each label goes on the sheets (the outline's area centroid).
    ids : Integers
        The face index of every panel (its stable id).
    sheets : Integers
        Sheet of every panel.
    sheet_outlines : Curves
        The sheets' rectangles.
    frames : Planes
        Local frame of every panel in 3D: origin at the first corner, x along the first edge, z to the outside.
    sheet_frames : Planes
        Where every panel's frame lands on the sheets: Orient from frames to sheet_frames lays the panel down.
    corner_counts : Integers
        Corners of every panel (the list lengths below per panel).
    edge_lengths : Numbers
        Flat edge lengths, panel by panel, edge i from corner i to corner i+1 (model units).
    corner_angles : Numbers
        Flat interior corner angles, panel by panel, corner by corner (degrees).
    diagonals : Numbers
        Flat diagonals, panel by panel (two per quad: corners 0–2 and 1–3).
    areas : Numbers
        Flat area of every panel (model units²).
    rectangle_width : Numbers
        Longer side of every panel's smallest bounding rectangle (the stock to cut it from).
    rectangle_height : Numbers
        Shorter side of that rectangle.
    residuals : Numbers
        Signed distance of every corner to its panel's plane, panel by panel (model units; 0 for a planar panel).
    max_residual : float
        Largest absolute residual (model units).
    max_length_error : float
        Largest relative difference between a flat edge or diagonal and the 3D one (1e-15 for planar panels).
    sheet_count : int
        Number of sheets used.

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        Negative ``gap``, a panel larger than the sheet (``sheet_width``), unknown ``method`` or ``orientation``.

    Notes
    -----
    The flattening keeps the panel exactly when it is planar: the flat outline has the 3D edge lengths and
    diagonals to rounding. A warped panel cannot keep all of them; ``"project"`` keeps its shape as seen along its
    normal and reports each corner's out-of-plane residual, ``"unfold"`` keeps its edges. Lay-out: first-fit
    decreasing-height shelf packing of the smallest bounding rectangles (no overlap, ``gap`` apart).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = panels(quad_grid(2, 1, 2.0, 1.0), gap=0.1)
    >>> res.labels, res.sheet_count, res.areas.tolist()
    (['A01', 'A02'], 1, [1.0, 1.0])
    """
    V, F, _ = checked_panelling(mesh)
    size = bounding_box_diagonal(V)
    gap = check_length(gap, "gap", size, 0)
    sheet_width = check_length(sheet_width, "sheet_width", size, 0)
    sheet_height = check_length(sheet_height, "sheet_height", size, 0)
    flat = flat_panels(V, F, method=method, orientation=orientation)
    layout = sheet_layout(flat, sheet_width, sheet_height, gap)
    warnings: list[str] = []
    placed = placed_outlines(flat, layout)
    sizes = flat.sizes
    valid = np.arange(F.shape[1])[None, :] < sizes[:, None]
    dvalid = np.isfinite(flat.diagonals)
    scale = float(np.nanmedian(flat.edge_lengths)) if len(F) else 1.0
    max_res = float(np.abs(flat.residual).max(initial=0.0))
    if max_res > 1e-6 * scale:
        worst = int(np.argmax(np.abs(flat.residual).max(axis=1)))
        kept = "keep the edge lengths" if method == "unfold" else "are their projections"
        warnings.append(f"panels are not planar: corners up to {max_res:.3g} off their panel's plane (panel "
                        f"{flat.labels[worst]}); the flat outlines {kept}")
    lab = _rotate(flat.centroid[:, None, :], layout.angle)[:, 0] + layout.offset
    frames = [Plane(o, x, y, z) for o, x, y, z in zip(flat.origin, flat.xaxis, flat.yaxis, flat.zaxis)]
    c, s = np.cos(layout.angle), np.sin(layout.angle)
    ez = np.array([0.0, 0.0, 1.0])
    sheet_frames = [Plane(np.array([ox, oy, 0.0]), np.array([ci, si, 0.0]), np.array([-si, ci, 0.0]), ez.copy())
                    for (ox, oy), ci, si in zip(layout.offset.tolist(), c.tolist(), s.tolist())]
    W, H = layout.sheet_width, layout.sheet_height
    rect = np.array([[0.0, 0.0, 0.0], [W, 0.0, 0.0], [W, H, 0.0], [0.0, H, 0.0], [0.0, 0.0, 0.0]])
    sheet_lines = [rect + np.array([ox, oy, 0.0]) for ox, oy in layout.sheet_origin.tolist()]
    return PanelsResult(
        outlines=closed_polylines(placed, sizes),
        labels=list(flat.labels),
        label_points=np.concatenate([lab, np.zeros((len(lab), 1))], axis=1),
        ids=flat.ids,
        sheets=layout.sheet,
        sheet_outlines=sheet_lines,
        frames=frames,
        sheet_frames=sheet_frames,
        corner_counts=sizes,
        edge_lengths=flat.edge_lengths[valid],
        corner_angles=flat.corner_angles[valid],
        diagonals=flat.diagonals[dvalid],
        areas=flat.area,
        rectangle_width=flat.rect_width,
        rectangle_height=flat.rect_height,
        residuals=flat.residual[valid],
        max_residual=max_res,
        max_length_error=float(flat.length_error.max(initial=0.0)),
        sheet_count=layout.sheet_count,
        warnings=warnings,
    )

