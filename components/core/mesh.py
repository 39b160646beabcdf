"""Mesh basics shared by every step: the canonical mesh, topology and I/O (input checks: :mod:`components.core.checks`).

The canonical mesh is ``V`` ``(n, 3) float64`` and ``F`` ``(m, k) int64``. Faces with fewer than ``k``
corners repeat their last vertex, exactly Rhino's convention (a triangle in a quad array is
``(a, b, c, c)``), so every index is valid and conversion to Rhino is free. Names carry the contract:
``V, F`` mixed polygons, ``T`` triangles only, ``Q`` quads only.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import NamedTuple

import numpy as np

from components.core.errors import MeshError

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------------------------
# face structure


def face_sizes(F: np.ndarray) -> np.ndarray:
    """Number of corners of every face (trailing repeats of the last vertex are padding).

    Parameters
    ----------
    F : (m, k) int64
        Faces, short faces padded by repeating their last vertex.

    Returns
    -------
    (m,) int64
        Corner count per face.

    Example
    -------
    >>> face_sizes(np.array([[0, 1, 2, 2], [0, 1, 2, 3]]))
    array([3, 4])
    """
    F = np.asarray(F)
    m, k = F.shape
    if m == 0:
        return np.zeros(0, dtype=np.int64)
    same = F[:, 1:] == F[:, :-1]
    # count trailing run of repeats: padding is a suffix of repeats of the last vertex
    pad = np.zeros(m, dtype=np.int64)
    run = np.ones(m, dtype=bool)
    for j in range(k - 2, -1, -1):
        run &= same[:, j]
        pad += run
    return k - pad


def pad_faces(faces: list, k: int | None = None) -> np.ndarray:
    """Turn a list of polygons (lists of vertex indices) into the canonical padded ``(m, k)`` array.

    Parameters
    ----------
    faces : list of sequences of int
        Polygons, each with at least one index.
    k : int, optional
        Width of the array; defaults to the largest polygon (and at least 3).

    Returns
    -------
    (m, k) int64
    """
    if len(faces) == 0:
        return np.zeros((0, k or 3), dtype=np.int64)
    width = max(len(f) for f in faces)
    k = max(width, 3) if k is None else k
    if width > k:
        raise ValueError(f"faces: a polygon has {width} corners, more than the width {k}")
    F = np.empty((len(faces), k), dtype=np.int64)
    for i, f in enumerate(faces):
        n = len(f)
        F[i, :n] = f
        F[i, n:] = f[-1]
    return F


def face_lists(F: np.ndarray) -> list[list[int]]:
    """The faces as Python lists of their distinct corners (padding removed)."""
    sizes = face_sizes(F)
    return [list(map(int, f[:s])) for f, s in zip(np.asarray(F), sizes)]


def triangulate(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulate polygon faces.

    Parameters
    ----------
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    T : (t, 3) int64
        Triangles (corner 0 with consecutive corner pairs of each face).
    J : (t,) int64
        Index of the face each triangle came from.
    """
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    sizes = face_sizes(F)
    Ts, Js = [], []
    for j in range(1, k - 1):
        sel = sizes > j + 1
        idx = np.nonzero(sel)[0]
        Ts.append(np.stack([F[idx, 0], F[idx, j], F[idx, j + 1]], axis=1))
        Js.append(idx)
    if not Ts:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    T = np.concatenate(Ts)
    J = np.concatenate(Js)
    order = np.argsort(J, kind="stable")
    return T[order], J[order]


def halfedges(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directed edges of every face in order.

    Returns
    -------
    H : (h, 2) int64
        Directed edges ``(from, to)``, face by face, corner by corner.
    HF : (h,) int64
        Face index of each half-edge.
    """
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    m, k = F.shape
    nxt = np.roll(F, -1, axis=1)
    # the closing edge of a short face goes from its last corner back to corner 0
    cols = np.arange(k)[None, :]
    last = (sizes - 1)[:, None]
    nxt = np.where(cols == last, F[:, :1], nxt)
    valid = cols < sizes[:, None]
    H = np.stack([F[valid], nxt[valid]], axis=1)
    HF = np.broadcast_to(np.arange(m)[:, None], (m, k))[valid]
    return H, HF


class Corners(NamedTuple):
    """Every corner of every face: vertex, previous and next corner vertex, face."""

    v: np.ndarray  # (c,) vertex at the corner
    prev: np.ndarray  # (c,) previous vertex of the face
    next: np.ndarray  # (c,) next vertex of the face
    face: np.ndarray  # (c,) face index
    slot: np.ndarray  # (c,) position of the corner in its face


def face_corners(F: np.ndarray) -> Corners:
    """All corners of padded polygon faces, face by face, in face order."""
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    sizes = face_sizes(F)
    cols = np.arange(k)[None, :]
    valid = cols < sizes[:, None]
    s = sizes[:, None]
    nxt_idx = (cols + 1) % s
    prv_idx = (cols - 1) % s
    rows = np.broadcast_to(np.arange(m)[:, None], (m, k))
    v = F[valid]
    nxt = F[rows, nxt_idx][valid]
    prv = F[rows, prv_idx][valid]
    return Corners(v, prv, nxt, rows[valid].copy(), np.broadcast_to(cols, (m, k))[valid].copy())


class EdgeTopology(NamedTuple):
    """Undirected edges and their incidence (see :func:`edge_topology`)."""

    E: np.ndarray  # (e, 2) unique undirected edges, E[:, 0] < E[:, 1]
    EF: np.ndarray  # (e, 2) the (up to) two faces of each edge, -1 where absent
    count: np.ndarray  # (e,) number of faces using the edge
    HE: np.ndarray  # (h,) edge index of every half-edge (in :func:`halfedges` order)


def edge_topology(F: np.ndarray) -> EdgeTopology:
    """Unique undirected edges, their faces, and the half-edge → edge map.

    Parameters
    ----------
    F : (m, k) int64
        Padded polygon faces.

    Returns
    -------
    EdgeTopology
        ``E`` (e, 2) sorted lexicographically, ``EF`` (e, 2) with -1 for a missing second face, ``count`` (e,) faces
        per edge (1 boundary, 2 interior, >2 non-manifold), ``HE`` (h,) edge of each half-edge.

    Notes
    -----
    Edges are keyed by the single integer ``min · n + max`` (``n`` = largest index + 1) and sorted once; this is
    several times faster than ``np.unique(..., axis=0)`` on rows.
    """
    H, HF = halfedges(F)
    if len(H) == 0:
        z = np.zeros(0, dtype=np.int64)
        return EdgeTopology(np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64), z, z)
    lo = np.minimum(H[:, 0], H[:, 1])
    hi = np.maximum(H[:, 0], H[:, 1])
    key = lo * np.int64(int(hi.max()) + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.ones(len(ks), dtype=bool)
    first[1:] = ks[1:] != ks[:-1]
    HE = np.empty(len(H), dtype=np.int64)
    HE[order] = np.cumsum(first) - 1
    starts = np.nonzero(first)[0]
    E = np.stack([lo[order[starts]], hi[order[starts]]], axis=1)
    count = np.diff(np.append(starts, len(ks)))
    EF = np.full((len(E), 2), -1, dtype=np.int64)
    EF[:, 0] = HF[order[starts]]
    two = count >= 2
    EF[two, 1] = HF[order[starts[two] + 1]]
    return EdgeTopology(E.astype(np.int64), EF, count.astype(np.int64), HE)


def boundary_edges(F: np.ndarray) -> np.ndarray:
    """Directed boundary edges ``(e, 2)``, oriented as in their face."""
    H, _ = halfedges(F)
    topo = edge_topology(F)
    return H[topo.count[topo.HE] == 1]


def boundary_loops(F: np.ndarray, name: str = "mesh") -> list[np.ndarray]:
    """Boundary loops as arrays of vertex indices, longest first, oriented as their faces.

    ``name`` is the input named in errors.

    Raises
    ------
    MeshError
        If the boundary is not a set of simple loops (a vertex with several boundary edges leaving it).
    """
    B = boundary_edges(F)
    if len(B) == 0:
        return []
    nxt = {}
    for a, b in B.tolist():
        if a in nxt:
            raise MeshError(name, f"vertex {a} is non-manifold (two boundary edges leave it)")
        nxt[a] = b
    loops = []
    seen = set()
    for start in nxt:
        if start in seen:
            continue
        loop = [start]
        seen.add(start)
        v = nxt[start]
        while v != start:
            if v in seen or v not in nxt:
                raise MeshError(name, f"boundary is not a simple loop at vertex {v}")
            loop.append(v)
            seen.add(v)
            v = nxt[v]
        loops.append(np.array(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def vertex_valence(F: np.ndarray, n: int) -> np.ndarray:
    """Number of edges at each of the ``n`` vertices."""
    E = edge_topology(F).E
    return np.bincount(E.ravel(), minlength=n).astype(np.int64)


def boundary_vertex_mask(F: np.ndarray, n: int) -> np.ndarray:
    """``(n,) bool``: True for vertices on a boundary edge."""
    mask = np.zeros(n, dtype=bool)
    B = boundary_edges(F)
    mask[B.ravel()] = True
    return mask


# ----------------------------------------------------------------------------------------------
# geometry


def face_normals(V: np.ndarray, F: np.ndarray, unit: bool = True) -> np.ndarray:
    """Newell normals of polygon faces (area vectors when ``unit=False``).

    The Newell vector of a planar polygon is its area vector (unit normal times area); for a non-planar
    polygon it is the area vector of the polygon projected onto the plane orthogonal to it. Exact to round-off of
    the face's size wherever the mesh is placed:

    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2, 3]])
    >>> bool(np.allclose(face_normals(V + 5e6, F, unit=False), face_normals(V, F, unit=False), atol=1e-12))
    True

    Returns
    -------
    (m, 3) float64
        Unit normals (zero for degenerate faces), or area vectors.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    # about each face's first corner (the sum does not depend on the origin; far from it, e.g. site coordinates
    # at 5e6, the products about the origin would cancel to round-off); padding repeats give zero-length closing
    # contributions except the last
    P = V[F]
    P = P - P[:, :1]
    Q = np.roll(P, -1, axis=1)
    sizes = face_sizes(F)
    k = F.shape[1]
    last = sizes - 1
    # closing edge from corner size-1 to corner 0
    Q[np.arange(len(F)), last] = P[:, 0]
    cols = np.arange(k)[None, :]
    valid = (cols < sizes[:, None])[..., None]
    N = 0.5 * np.sum(np.cross(P, Q) * valid, axis=1)
    if unit:
        L = np.linalg.norm(N, axis=1, keepdims=True)
        N = np.divide(N, L, out=np.zeros_like(N), where=L > 0)
    return N


def face_centroids(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mean of the distinct corners of every face, ``(m, 3)``."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sizes = face_sizes(F)
    k = F.shape[1]
    valid = (np.arange(k)[None, :] < sizes[:, None])[..., None]
    return np.sum(V[F] * valid, axis=1) / sizes[:, None]


def edge_lengths(V: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Length of every edge ``(e,)``."""
    V = np.asarray(V, dtype=np.float64)
    return np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)


def points_in_polygons(P: np.ndarray, loops) -> np.ndarray:
    """Even-odd point-in-polygon test of plan points against one or several closed polygons (holes work).

    Parameters
    ----------
    P : (p, 2) float64
        Points in the plane.
    loops : (q, 2) array or list of them
        Closed polygons (the last vertex joins the first).

    Returns
    -------
    (p,) bool
        True inside an odd number of the polygons.
    """
    P = np.asarray(P, dtype=np.float64)
    if isinstance(loops, np.ndarray) and loops.ndim == 2:
        loops = [loops]
    inside = np.zeros(len(P), dtype=bool)
    x, y = P[:, 0][:, None], P[:, 1][:, None]
    for poly in loops:
        A, B = poly, np.roll(poly, -1, axis=0)
        for s in range(0, len(A), 512):  # edges in chunks: memory stays (p, 512)
            a, b = A[s:s + 512], B[s:s + 512]
            cond = (a[None, :, 1] > y) != (b[None, :, 1] > y)
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
            inside ^= (np.count_nonzero(cond & (x < xc), axis=1) % 2).astype(bool)
    return inside


def bounding_box_diagonal(V: np.ndarray) -> float:
    """Length of the axis-aligned bounding box diagonal."""
    V = np.asarray(V, dtype=np.float64)
    if len(V) == 0:
        return 0.0
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))


# ----------------------------------------------------------------------------------------------
# I/O for polygon meshes (OBJ, OFF, PLY ascii) without triangulating


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a polygon mesh from OBJ, OFF, ASCII PLY or STL, keeping quads and n-gons.

    STL triangles are welded by :func:`read_stl` (at ``STL_WELD`` × the bounding-box diagonal).

    Parameters
    ----------
    path : str or Path
        File to read.

    Returns
    -------
    V : (n, 3) float64
    F : (m, k) int64
        Padded faces (k = largest polygon, at least 3). Unused vertices are kept.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".stl":
        return read_stl(path)[:2]
    text = path.read_text(errors="replace")
    if suffix == ".obj":
        verts, faces = [], []
        for line in text.splitlines():
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(tok.split("/")[0]) for tok in line.split()[1:]]
                faces.append([i - 1 if i > 0 else len(verts) + i for i in idx])
    elif suffix == ".off":
        # token stream: faces may be wrapped over several lines
        tok = " ".join(ln.split("#")[0] for ln in text.splitlines()).split()
        if not tok or not tok[0].upper().endswith("OFF"):
            raise ValueError(f"{path}: not an OFF file")
        nv, nf = int(tok[1]), int(tok[2])
        pos = 4
        verts = np.asarray(tok[pos:pos + 3 * nv], dtype=np.float64).reshape(nv, 3).tolist()
        pos += 3 * nv
        faces = []
        for _ in range(nf):
            c = int(tok[pos])
            faces.append([int(x) for x in tok[pos + 1:pos + 1 + c]])
            pos += 1 + c
    elif suffix == ".ply":
        lines = text.splitlines()
        if not lines or lines[0].strip() != "ply" or "ascii" not in lines[1]:
            raise ValueError(f"{path}: only ASCII PLY is supported")
        nv = nf = 0
        end = 0
        for i, ln in enumerate(lines):
            if ln.startswith("element vertex"):
                nv = int(ln.split()[2])
            elif ln.startswith("element face"):
                nf = int(ln.split()[2])
            elif ln.strip() == "end_header":
                end = i + 1
                break
        verts = [[float(x) for x in ln.split()[:3]] for ln in lines[end:end + nv]]
        faces = []
        for ln in lines[end + nv:end + nv + nf]:
            vals = ln.split()
            c = int(vals[0])
            faces.append([int(x) for x in vals[1:1 + c]])
    else:
        raise ValueError(f"{path}: unsupported mesh format {suffix!r} (use .obj, .off, .ply or .stl; .3dm through "
                         "ghserver.convert.read_model)")
    return np.asarray(verts, dtype=np.float64).reshape(-1, 3), pad_faces(faces)


#: STL corners closer than this fraction of the bounding-box diagonal are welded into one vertex (an ASCII STL's
#: six significant digits and a binary STL's float32 both round far below it)
STL_WELD = 1e-6
#: vertices closer than this fraction of the bounding-box diagonal are one point (the planarizer welds them, the
#: fabrication stage refuses a face two of whose corners are one point)
WELD_FRACTION = 1e-9


def weld_labels(P: np.ndarray, tol: float) -> np.ndarray:
    """The weld group of every point ``P (k, 3)``: points closer than ``tol`` are joined, transitively (a KD-tree's
    close pairs, then connected components); ``(k,)`` labels ``0 .. groups − 1``, ``arange(k)`` when nothing is
    that close. Pass coordinates about the points' own centre at site coordinates (the tree measures as given).

    >>> weld_labels(np.array([[0.0, 0, 0], [1, 0, 0], [1 + 1e-9, 0, 0]]), 1e-6).tolist()
    [0, 1, 1]
    """
    # deferred import: scipy.spatial + csgraph took 1.5 s to import (measured), only welds need them
    from scipy.sparse import coo_matrix
    # deferred import: as above
    from scipy.sparse.csgraph import connected_components
    # deferred import: as above
    from scipy.spatial import cKDTree

    k = len(P)
    if k < 2 or not tol > 0:
        return np.arange(k)
    pairs = cKDTree(P).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return np.arange(k)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(k, k))
    return connected_components(graph, directed=False)[1]


def piece_count(F, n: int) -> int:
    """Connected pieces of the faces ``F`` (padded) over ``n`` vertices, vertices no face uses not counted.

    >>> piece_count(np.array([[0, 1, 2], [3, 4, 5]]), 7)
    2
    """
    # deferred import: as in weld_labels
    from scipy.sparse import coo_matrix
    # deferred import: as above
    from scipy.sparse.csgraph import connected_components

    F = np.asarray(F, dtype=np.int64)
    graph = coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, -1, axis=1).ravel())), shape=(n, n))
    return int(connected_components(graph, directed=False)[0]) - (n - len(np.unique(F)))


def weld_map(X: np.ndarray, used: np.ndarray, tol: float) -> np.ndarray | None:
    """``(n,)`` representative (smallest index) of every vertex of ``X (n, 3)`` after welding the ``used`` ones within
    ``tol`` (:func:`weld_labels`; pass centred coordinates); ``None`` when no two used vertices are that close.

    >>> weld_map(np.array([[0.0, 0, 0], [1, 0, 0], [1, 0, 1e-12]]), np.ones(3, bool), 1e-9).tolist()
    [0, 1, 1]
    """
    idx = np.nonzero(used)[0]
    k = len(idx)
    label = weld_labels(X[idx], tol)
    if not k or label.max() + 1 == k:  # no two that close
        return None
    first = np.full(label.max() + 1, k, dtype=np.int64)
    np.minimum.at(first, label, np.arange(k))
    rep = np.arange(len(X))
    rep[idx] = idx[first[label]]
    return rep


class StlMesh(NamedTuple):
    """A welded STL triangle mesh."""

    V: np.ndarray
    F: np.ndarray
    tolerance: float
    corners: int
    dropped: int


def _stl_triangles(data: bytes, name: str) -> np.ndarray:
    if len(data) >= 84:
        n = int.from_bytes(data[80:84], "little")
        if len(data) == 84 + 50 * n:  # binary: header, count, then 50-byte records
            rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                count=n, offset=84)
            return rec["v"].astype(np.float64)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().lower().startswith("solid"):
        raise MeshError(name, "not an STL file (neither binary with a matching triangle count nor ASCII 'solid')")
    vals = [ln.split()[1:4] for ln in text.splitlines() if ln.strip().lower().startswith("vertex")]
    try:
        P = np.asarray(vals, dtype=np.float64)
    except ValueError:
        raise MeshError(name, "an ASCII STL 'vertex' line does not hold three numbers") from None
    if P.size == 0 or len(P) % 3:
        raise MeshError(name, f"an ASCII STL needs three vertices per facet, got {len(P)} vertex lines")
    return P.reshape(-1, 3, 3)


def read_stl(path) -> StlMesh:
    """Read a binary or ASCII STL and weld its triangle corners into a shared-vertex mesh.

    STL stores every triangle with its own three corners; corners within ``STL_WELD`` × the bounding-box
    diagonal of each other become one vertex (a tolerance relative to the mesh size, so the weld is the same in
    mm or m and at site coordinates). Triangles whose corners weld together are dropped.

    Returns
    -------
    StlMesh
        ``V (n, 3)``, triangles ``F (m, 3)``, the weld ``tolerance`` in model units, the number of ``corners``
        read and of degenerate triangles ``dropped``.

    Raises
    ------
    MeshError
        Not an STL file, or no triangle in it.
    """
    path = Path(path)
    T = _stl_triangles(path.read_bytes(), path.name)
    if len(T) == 0:
        raise MeshError(path.name, "the STL file holds no triangle")
    P = T.reshape(-1, 3)
    if not np.isfinite(P).all():
        raise MeshError(path.name, "the STL file holds a non-finite coordinate")
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    tol = STL_WELD * diag
    centre = 0.5 * (P.max(axis=0) + P.min(axis=0))  # site coordinates: the KD-tree works relative to the box
    n = len(P)
    _, first, inverse = np.unique(weld_labels(P - centre, tol), return_index=True, return_inverse=True)
    V = P[first]
    F = inverse.reshape(-1, 3).astype(np.int64)
    keep = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    return StlMesh(V, F[keep], tol, n, int(np.sum(~keep)))


def write_obj(path, V: np.ndarray, F: np.ndarray) -> None:
    """Write a polygon mesh as OBJ (padding removed)."""
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in np.asarray(V, dtype=float).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in face_lists(F)]
    Path(path).write_text("\n".join(lines) + "\n")


def remove_unreferenced(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drop vertices no face uses.

    Returns
    -------
    V2 : (n2, 3) float64
    F2 : (m, k) int64
    I : (n2,) int64
        Old index of every kept vertex.
    """
    used = np.zeros(len(V), dtype=bool)
    used[np.asarray(F).ravel()] = True
    I = np.nonzero(used)[0]
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[I] = np.arange(len(I))
    return np.asarray(V, dtype=np.float64)[I], remap[np.asarray(F)], I


def quad_grid(nu: int, nv: int, size_u: float = 1.0, size_v: float = 1.0, height=None):
    """A regular ``nu × nv`` quad grid on ``[0, size_u] × [0, size_v]``, optionally lifted by ``height(x, y)``.

    Returns
    -------
    V : ((nu+1)(nv+1), 3) float64
    Q : (nu·nv, 4) int64
        Counter-clockwise quads seen from +z.
    """
    x, y = np.meshgrid(np.linspace(0, size_u, nu + 1), np.linspace(0, size_v, nv + 1), indexing="xy")
    z = np.zeros_like(x) if height is None else height(x, y)
    V = np.stack([x.ravel(), y.ravel(), np.asarray(z, dtype=float).ravel()], axis=1)
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    Q = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], axis=1)
    return V, Q.astype(np.int64)
