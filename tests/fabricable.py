"""Inputs and an independent checker for the "fabricable or it says why" sweep (issue #16).

Three kinds of open design surfaces, all as triangle meshes ``(V, T)``:

* the sample surfaces of :mod:`components.surfaces.samples` (:func:`sample_surface`);
* real meshes copied into ``tests/data`` (:data:`REAL_MESHES`, :func:`real_surface`; sources and licenses in
  ``tests/data/README.md``);
* procedural surfaces built here (:data:`PROCEDURAL`, :func:`procedural_surface`): a wavy annulus, a bent open
  tube, a spherical cap larger than a hemisphere, an L-shaped roof, a folded plate and a twisted strip.

:func:`independent_defects` is a second opinion on a result mesh, written from scratch on purpose: the checker uses
numpy and scipy only (no ``components`` code; only the input loaders do), so a bug in ``components.metrics.health``
or ``components.core.measures`` cannot hide the same bug here.
It checks short edges, small corners, folds, self-intersections and coverage of a reference surface.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, cKDTree

from components.core.mesh import read_mesh, remove_unreferenced, triangulate
from components.surfaces.samples import SAMPLE_NAMES, sample_mesh

DATA = Path(__file__).resolve().parent / "data"

# the thresholds of the issue
MIN_EDGE_RATIO = 0.2  # × median edge
MIN_CORNER_DEG = 20.0
MIN_COVERAGE = 0.85
FOLD_DEG = 150.0  # adjacent faces whose normals turn by more than this fold onto each other

# name -> file in tests/data (all open disks)
REAL_MESHES = {
    "inspired": "inspired_mesh.obj",
    "lilium": "lilium.obj",
    "minimal_surface": "compas_libigl_minimal_surface_subset.obj",
    "igloo": "compas_libigl_igloo.obj",
    "enneper": "obj_anet__enneper2.obj",
    "rhinovault": "rhinovault_mesh_0.ply",
    "botanic_bubble": "obj_equilibrium__botanic-garden-bubble-0.obj",
    "armadillo": "aag2018_armadillo_formdiagram_final.obj",
    "tri_dome": "geometrylab_test_tri_dome.obj",
}

PROCEDURAL = ("annulus", "tube", "cap240", "l_roof", "folded_plate", "twisted_strip")


# ----------------------------------------------------------------------------------------------
# inputs


def sample_surface(name: str, resolution: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """A sample surface (:data:`components.surfaces.samples.SAMPLE_NAMES`) as ``(V, T)``."""
    if name not in SAMPLE_NAMES:
        raise KeyError(name)
    V, T, _ = sample_mesh(name, resolution)
    return V, T


def largest_component(V, T) -> tuple[np.ndarray, np.ndarray]:
    """The largest edge-connected component of a triangle mesh, unused vertices dropped."""
    T = np.asarray(T, dtype=np.int64)
    m = len(T)
    E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    face = np.tile(np.arange(m), 3)
    key = E[:, 0] * (len(V) + 1) + E[:, 1]
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    a, b = face[order][:-1][same], face[order][1:][same]
    A = coo_matrix((np.ones(len(a)), (a, b)), shape=(m, m))
    _, label = connected_components(A, directed=False)
    keep = label == np.bincount(label).argmax()
    V2, T2, _ = remove_unreferenced(V, T[keep])
    return V2, T2


def real_surface(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A copied real mesh (key of :data:`REAL_MESHES`), triangulated, its largest connected piece."""
    V, F = read_mesh(DATA / REAL_MESHES[name])
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    return largest_component(V, T)


def _grid_triangles(nu: int, nv: int, periodic_v: bool = False) -> np.ndarray:
    """Triangles of an ``nu × nv`` cell grid on vertices ``i * nvv + j`` (alternating diagonals)."""
    nvv = nv if periodic_v else nv + 1
    tris = []
    for i in range(nu):
        for j in range(nv):
            a, b = i * nvv + j, (i + 1) * nvv + j
            jn = (j + 1) % nvv
            c, d = (i + 1) * nvv + jn, i * nvv + jn
            if (i + j) % 2:
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    return np.asarray(tris, dtype=np.int64)


def annulus(nr: int = 7, nt: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A wavy ring: radii 5 to 12, three waves of ±1.5 around (two boundary loops)."""
    r = np.linspace(5.0, 12.0, nr + 1)
    t = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    R, Tt = np.meshgrid(r, t, indexing="ij")
    V = np.stack([R * np.cos(Tt), R * np.sin(Tt), 1.5 * np.sin(3 * Tt) + 0.04 * R ** 2], axis=-1).reshape(-1, 3)
    return V, _grid_triangles(nr, nt, periodic_v=True)


def tube(ns: int = 24, nc: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """An open cylinder of radius 3 bent along a quarter circle of radius 16 (two boundary loops)."""
    s = np.linspace(0, np.pi / 2, ns + 1)
    p = np.linspace(0, 2 * np.pi, nc, endpoint=False)
    S, P = np.meshgrid(s, p, indexing="ij")
    rho = 16.0 + 3.0 * np.cos(P)
    V = np.stack([rho * np.cos(S), rho * np.sin(S), 3.0 * np.sin(P)], axis=-1).reshape(-1, 3)
    return V, _grid_triangles(ns, nc, periodic_v=True)


def cap(angle_deg: float = 240.0, radius: float = 10.0, h: float = 1.3) -> tuple[np.ndarray, np.ndarray]:
    """A spherical cap spanning ``angle_deg`` of arc (240°: larger than a hemisphere), pole up, edge ``h``.

    Points: a ring on the rim and a Fibonacci spiral inside; triangles: Delaunay of their stereographic image (the
    map is conformal and keeps circles, so this is the convex hull on the sphere: well-shaped triangles).
    """
    phi_max = math.radians(angle_deg) / 2
    nb = max(12, int(round(2 * np.pi * radius * np.sin(phi_max) / h)))
    tb = np.linspace(0, 2 * np.pi, nb, endpoint=False)
    rim = np.column_stack([np.sin(phi_max) * np.cos(tb), np.sin(phi_max) * np.sin(tb), np.full(nb, np.cos(phi_max))])
    n_all = int(round(4 * np.pi * radius ** 2 / (np.sqrt(3) / 2 * h ** 2)))
    k = np.arange(n_all) + 0.5
    z = 1 - 2 * k / n_all
    az = np.pi * (1 + 5 ** 0.5) * k
    inner = np.column_stack([np.sqrt(1 - z ** 2) * np.cos(az), np.sqrt(1 - z ** 2) * np.sin(az), z])
    inner = inner[np.arccos(np.clip(inner[:, 2], -1, 1)) < phi_max - 0.6 * h / radius]
    U = np.vstack([rim, inner])
    T = Delaunay(U[:, :2] / (1 + U[:, 2:3])).simplices.astype(np.int64)
    return radius * U, T


def l_roof(n: int = 16, size: float = 24.0) -> tuple[np.ndarray, np.ndarray]:
    """A roof over an L-shaped plan (a ``size`` square minus its upper-right quarter), a smooth hump."""
    x = np.linspace(0, size, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = 4.0 * np.sin(np.pi * X / size) * np.sin(np.pi * Y / size) + 0.05 * X
    V = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    T = _grid_triangles(n, n)
    C = V[T].mean(axis=1)
    half = size / 2
    T = T[~((C[:, 0] > half) & (C[:, 1] > half))]
    V, T, _ = remove_unreferenced(V, T)
    return V, T


def folded_plate(folds: int = 3, fold_deg: float = 30.0, bay: float = 8.0, width: float = 16.0,
                 cells: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """A zig-zag plate: ``folds + 1`` planar bays of plan length ``bay``, the slope turning by ``fold_deg`` at every
    fold (slopes ±fold_deg/2), exact crease lines on grid lines."""
    nx = (folds + 1) * cells
    ny = int(round(width / bay * cells))
    x = np.linspace(0, (folds + 1) * bay, nx + 1)
    slope = math.tan(math.radians(fold_deg / 2))
    bay_i = np.minimum((x // bay).astype(int), folds)
    local = x - bay_i * bay
    z = np.where(bay_i % 2 == 0, local, bay - local) * slope
    y = np.linspace(0, width, ny + 1)
    X, Y = np.meshgrid(x, y, indexing="ij")
    Z = np.broadcast_to(z[:, None], X.shape)
    return np.stack([X, Y, Z], axis=-1).reshape(-1, 3), _grid_triangles(nx, ny)


def twisted_strip(length: float = 40.0, width: float = 4.0, twist_deg: float = 90.0, nu: int = 50,
                  nv: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """A 10:1 strip whose cross-section turns by ``twist_deg`` along its length (a piece of a helicoid)."""
    u = np.linspace(0, length, nu + 1)
    v = np.linspace(-width / 2, width / 2, nv + 1)
    U, W = np.meshgrid(u, v, indexing="ij")
    th = math.radians(twist_deg) * U / length
    V = np.stack([U, W * np.cos(th), W * np.sin(th)], axis=-1).reshape(-1, 3)
    return V, _grid_triangles(nu, nv)


def procedural_surface(name: str) -> tuple[np.ndarray, np.ndarray]:
    """One of :data:`PROCEDURAL` as ``(V, T)``."""
    return {"annulus": annulus, "tube": tube, "cap240": cap, "l_roof": l_roof, "folded_plate": folded_plate,
            "twisted_strip": twisted_strip}[name]()


def panel_size(V, name: str = "") -> float:
    """The sweep's panel size: 1/8 of the largest extent (a third of the width for the twisted strip)."""
    if name == "twisted_strip":
        return 4.0 / 3.0
    V = np.asarray(V, dtype=np.float64)
    return float((V.max(axis=0) - V.min(axis=0)).max() / 8)


# ----------------------------------------------------------------------------------------------
# polygon basics (written here, not taken from components)


def polygons(F) -> tuple[np.ndarray, np.ndarray]:
    """``(F, sizes)``: padded faces (trailing repeats of the last index are padding) and their corner counts."""
    F = np.asarray(F, dtype=np.int64)
    if F.ndim != 2 or len(F) == 0:
        return F.reshape(0, 3), np.zeros(0, dtype=np.int64)
    k = F.shape[1]
    sizes = np.full(len(F), k, dtype=np.int64)
    run = np.ones(len(F), dtype=bool)
    for j in range(k - 1, 0, -1):
        run &= F[:, j] == F[:, j - 1]
        sizes -= run
    return F, sizes


def _corner_table(F, sizes):
    """Per corner: face, vertex, previous vertex, next vertex (in face order)."""
    k = F.shape[1]
    face, pos = np.nonzero(np.arange(k)[None, :] < sizes[:, None])
    s = sizes[face]
    cur = F[face, pos]
    prv = F[face, (pos - 1) % s]
    nxt = F[face, (pos + 1) % s]
    return face, cur, prv, nxt


def _unit(X):
    n = np.linalg.norm(X, axis=-1, keepdims=True)
    return np.divide(X, n, out=np.zeros_like(X), where=n > 0)


def _tri_normals(V, T):
    return np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])


def _triangles(V, F, sizes):
    """Triangles of the polygons and their face: quads split along the diagonal whose halves agree best, other
    polygons fanned from corner 0."""
    tris, owner = [], []
    for s in np.unique(sizes):
        idx = np.nonzero(sizes == s)[0]
        G = F[idx, :s]
        if s == 4:
            a1, a2 = G[:, [0, 1, 2]], G[:, [0, 2, 3]]
            b1, b2 = G[:, [1, 2, 3]], G[:, [1, 3, 0]]
            da = np.einsum("ij,ij->i", _unit(_tri_normals(V, a1)), _unit(_tri_normals(V, a2)))
            db = np.einsum("ij,ij->i", _unit(_tri_normals(V, b1)), _unit(_tri_normals(V, b2)))
            use_a = da >= db
            tris += [np.where(use_a[:, None], a1, b1), np.where(use_a[:, None], a2, b2)]
            owner += [idx, idx]
        else:
            for j in range(1, s - 1):
                tris.append(G[:, [0, j, j + 1]])
                owner.append(idx)
    if not tris:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    return np.concatenate(tris), np.concatenate(owner)


def planarity(V, F) -> np.ndarray:
    """Scale-free planarity per face: distance between the diagonals / mean diagonal length for quads, the worst
    window of four consecutive corners for larger polygons, 0 for triangles."""
    V = np.asarray(V, dtype=np.float64)
    F, sizes = polygons(F)
    out = np.zeros(len(F))
    for s in np.unique(sizes):
        if s < 4:
            continue
        idx = np.nonzero(sizes == s)[0]
        worst = np.zeros(len(idx))
        for j in range(s if s > 4 else 1):
            q = F[idx][:, [(j + t) % s for t in range(4)]]
            a, b, c, d = (V[q[:, t]] for t in range(4))
            u, w = c - a, d - b
            n = np.cross(u, w)
            nn = np.linalg.norm(n, axis=1)
            dist = np.abs(np.einsum("ij,ij->i", b - a, n)) / np.where(nn > 0, nn, 1.0)
            # parallel diagonals: distance between the lines
            par = nn <= 1e-14 * (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1) + 1e-300)
            if par.any():
                uu = _unit(u[par])
                r = (b - a)[par]
                dist[par] = np.linalg.norm(r - np.einsum("ij,ij->i", r, uu)[:, None] * uu, axis=1)
            mean_diag = 0.5 * (np.linalg.norm(u, axis=1) + np.linalg.norm(w, axis=1))
            worst = np.maximum(worst, dist / np.where(mean_diag > 0, mean_diag, 1.0))
        out[idx] = worst
    return out


# ----------------------------------------------------------------------------------------------
# the independent checker


def _segments_hit_triangles(P0, P1, A, B, C, tol):
    """Row-wise: does segment ``P0 P1`` meet triangle ``A B C`` (closed, ``tol`` in model units)?"""
    n = _unit(np.cross(B - A, C - A))
    d0 = np.einsum("ij,ij->i", P0 - A, n)
    d1 = np.einsum("ij,ij->i", P1 - A, n)
    lo = np.zeros(len(A))
    hi = np.ones(len(A))
    coplanar = (np.abs(d0) <= tol) & (np.abs(d1) <= tol)
    apart = ((d0 > tol) & (d1 > tol)) | ((d0 < -tol) & (d1 < -tol))
    cross = ~coplanar & ~apart
    denom = np.where(cross, d0 - d1, 1.0)
    t = np.clip(np.where(cross, d0 / denom, 0.0), 0.0, 1.0)
    lo = np.where(cross, t, lo)
    hi = np.where(cross, t, hi)
    D = P1 - P0
    for X, Y in ((A, B), (B, C), (C, A)):
        m = _unit(np.cross(n, Y - X))  # in-plane, pointing into the triangle
        a = np.einsum("ij,ij->i", P0 - X, m) + tol
        b = np.einsum("ij,ij->i", D, m)
        flat = np.abs(b) <= 1e-300
        with np.errstate(divide="ignore", invalid="ignore"):
            tb = -a / b
        lo = np.where(~flat & (b > 0), np.maximum(lo, tb), lo)
        hi = np.where(~flat & (b < 0), np.minimum(hi, tb), hi)
        hi = np.where(flat & (a < 0), -1.0, hi)
    degenerate = np.linalg.norm(np.cross(B - A, C - A), axis=1) <= tol * tol
    return ~apart & (lo <= hi) & ~degenerate


def _intersecting_pairs(V, T, owner, tol) -> set:
    """Pairs of faces (owners) with triangles that share no vertex and still meet."""
    if len(T) < 2:
        return set()
    P = V[T]
    cen = P.mean(axis=1)
    reach = float(np.linalg.norm(P - cen[:, None], axis=2).max())
    pairs = cKDTree(cen).query_pairs(2 * reach + 2 * tol, output_type="ndarray")
    if len(pairs) == 0:
        return set()
    i, j = pairs[:, 0], pairs[:, 1]
    share = (T[i][:, :, None] == T[j][:, None, :]).any(axis=(1, 2))
    i, j = i[~share], j[~share]
    lo_i, hi_i = P[i].min(axis=1), P[i].max(axis=1)
    lo_j, hi_j = P[j].min(axis=1), P[j].max(axis=1)
    box = ((lo_i <= hi_j + tol) & (lo_j <= hi_i + tol)).all(axis=1)
    i, j = i[box], j[box]
    hit = np.zeros(len(i), dtype=bool)
    for a, b in ((i, j), (j, i)):
        A, B, C = V[T[b, 0]], V[T[b, 1]], V[T[b, 2]]
        for e0, e1 in ((0, 1), (1, 2), (2, 0)):
            hit |= _segments_hit_triangles(V[T[a, e0]], V[T[a, e1]], A, B, C, tol)
    return {tuple(sorted((int(owner[x]), int(owner[y])))) for x, y in zip(i[hit], j[hit])}


def _subdivision_barycentrics(s: int) -> np.ndarray:
    """Barycentric centroids of the ``s²`` triangles of a regular ``s``-subdivision."""
    pts = []
    for a in range(s):
        for b in range(s - a):
            pts.append(((a + 1 / 3) / s, (b + 1 / 3) / s))
            if a + b <= s - 2:
                pts.append(((a + 2 / 3) / s, (b + 2 / 3) / s))
    uv = np.asarray(pts)
    return np.column_stack([1 - uv.sum(axis=1), uv])


def coverage(V, T, reference, h, radius: float = 0.25, slack: float = 0.05, hinges=None) -> float:
    """Share of the reference's area whose sample points are within ``radius·h`` of a result triangle's plane and
    project inside that triangle (``slack·h`` tolerance across its edges), or are within ``radius·h`` of an edge
    two panels share (``hinges``, vertex pairs: on the convex side of a kink a point near the joint projects into
    neither panel); ``h`` is the median edge.

    The slack is the contract's boundary margin (issue 16: a straight panel edge between two points of a curved
    boundary cuts off a sliver of the design surface; within 0.05 × the median edge of the panelling it counts as
    covered); across interior edges it changes nothing (the neighbour covers the point)."""
    Vr = np.asarray(reference[0], dtype=np.float64)
    Fr, sr = polygons(reference[1])
    Tr = np.concatenate([Fr[sr >= j + 2][:, [0, j, j + 1]] for j in range(1, int(sr.max()) - 1)])
    Pr = Vr[Tr]
    area_r = 0.5 * np.linalg.norm(np.cross(Pr[:, 1] - Pr[:, 0], Pr[:, 2] - Pr[:, 0]), axis=1)
    ref_edge = float(np.median(np.linalg.norm(Pr - np.roll(Pr, 1, axis=1), axis=2)))
    s = int(np.clip(math.ceil(ref_edge / (0.5 * h)), 2, 8))
    W = _subdivision_barycentrics(s)
    S = np.einsum("sk,tkd->tsd", W, Pr).reshape(-1, 3)
    w = np.repeat(area_r / len(W), len(W))
    P = V[T]
    nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    good = np.linalg.norm(nrm, axis=1) > 1e-12 * h * h
    P, nrm = P[good], _unit(nrm[good])
    if len(P) == 0 or w.sum() <= 0:
        return 0.0
    cen = P.mean(axis=1)
    reach = float(np.linalg.norm(P - cen[:, None], axis=2).max())
    lists = cKDTree(cen).query_ball_point(S, radius * h + reach)
    counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(S))
    si = np.repeat(np.arange(len(S)), counts)
    ti = np.fromiter((t for x in lists for t in x), dtype=np.int64, count=int(counts.sum()))
    covered = np.zeros(len(S), dtype=bool)
    for lo in range(0, len(si), 200_000):
        a, b = si[lo:lo + 200_000], ti[lo:lo + 200_000]
        X, n = S[a], nrm[b]
        ok = np.abs(np.einsum("ij,ij->i", X - P[b, 0], n)) <= radius * h
        for e in range(3):
            A, B = P[b, e], P[b, (e + 1) % 3]
            m = _unit(np.cross(n, B - A))
            ok &= np.einsum("ij,ij->i", X - A, m) >= -slack * h
        covered[a[ok]] = True
    if hinges is not None and len(hinges) and not covered.all():
        A, B = V[hinges[:, 0]], V[hinges[:, 1]]
        half = 0.5 * float(np.linalg.norm(B - A, axis=1).max())
        rest = np.nonzero(~covered)[0]
        near = cKDTree(0.5 * (A + B)).query_ball_point(S[rest], radius * h + half)
        for k, hs in zip(rest, near):
            if hs:
                a_, b_ = A[hs], B[hs]
                d = b_ - a_
                t = np.einsum("ij,ij->i", S[k] - a_, d) / np.einsum("ij,ij->i", d, d)
                inside = (t > 0.0) & (t < 1.0)  # beside the joint, not beyond its ends (the boundary's side)
                near_j = np.linalg.norm(a_ + t[:, None] * d - S[k], axis=1) <= radius * h
                covered[k] = bool((inside & near_j).any())
    return float(w[covered].sum() / w.sum())


def independent_defects(V, F, reference=None) -> dict:
    """A second opinion on a panel mesh: the defects of issue #16, counted from scratch.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, k) array_like of int
        Padded polygon faces (``(a, b, c, c)`` is a triangle).
    reference : (Vr, Fr), optional
        The design surface; coverage is measured against it.

    Returns
    -------
    dict
        ``faces``, ``median_edge``; ``short_edges`` (edges under 0.2 × median) and ``min_edge_ratio``;
        ``small_corners`` (polygon corners under 20°) and ``min_corner`` (degrees); ``folded_faces`` (quads whose
        halves face opposite ways along both diagonals), ``folded_edges`` (adjacent faces whose normals turn by more
        than 150°), ``nonmanifold_edges`` (edges of more than two faces), ``intersecting_pairs`` (face pairs whose
        triangles share no vertex and still meet); ``coverage`` (0..1, None without a reference);
        ``nonconvex_faces`` and ``max_planarity`` (information only: not criteria of the issue); ``defects`` (one
        line per failed criterion, empty when fabricable).

    Example
    -------
    >>> V = np.array([[x, y, 0.0] for y in range(3) for x in range(3)])
    >>> F = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
    >>> r = independent_defects(V, F, (V, F)); r["defects"], round(r["coverage"], 3), r["min_corner"]
    ([], 1.0, 90.0)
    """
    V = np.asarray(V, dtype=np.float64)
    F, sizes = polygons(F)
    out = {"faces": int(len(F))}
    if len(F) == 0:
        out.update(defects=["no faces"], coverage=0.0 if reference is not None else None)
        return out
    face, cur, prv, nxt = _corner_table(F, sizes)
    # edges
    E = np.sort(np.column_stack([cur, nxt]), axis=1)
    Eu, e_count = np.unique(E, axis=0, return_counts=True)
    L = np.linalg.norm(V[Eu[:, 0]] - V[Eu[:, 1]], axis=1)
    h = float(np.median(L))
    out["median_edge"] = h
    scale = h if h > 0 else 1.0
    out["short_edges"] = int((L < MIN_EDGE_RATIO * h).sum()) if h > 0 else len(L)
    out["min_edge_ratio"] = float(L.min() / h) if h > 0 else 0.0
    # corners
    a, b = V[prv] - V[cur], V[nxt] - V[cur]
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    ok = (na > 1e-12 * scale) & (nb > 1e-12 * scale)
    cosang = np.where(ok, np.einsum("ij,ij->i", a, b) / np.where(ok, na * nb, 1.0), 1.0)
    ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    out["small_corners"] = int((ang < MIN_CORNER_DEG).sum())
    out["min_corner"] = float(ang.min())
    # face normals (Newell) and convexity
    N = np.zeros((len(F), 3))
    np.add.at(N, face, np.cross(V[cur], V[nxt]))
    turn = np.einsum("ij,ij->i", np.cross(V[cur] - V[prv], V[nxt] - V[cur]), N[face])
    out["nonconvex_faces"] = int(len(np.unique(face[turn < 0])))
    quad = np.nonzero(sizes == 4)[0]
    folded = 0
    if len(quad):
        G = F[quad, :4]

        def halves_disagree(p, q):
            return np.einsum("ij,ij->i", _tri_normals(V, p), _tri_normals(V, q)) < 0

        folded = int((halves_disagree(G[:, [0, 1, 2]], G[:, [0, 2, 3]])
                      & halves_disagree(G[:, [1, 2, 3]], G[:, [1, 3, 0]])).sum())
    out["folded_faces"] = folded
    # folds across edges: compare the normals of the two faces of every interior edge
    key = E[:, 0] * (len(V) + 1) + E[:, 1]
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.nonzero(ks[1:] == ks[:-1])[0]
    f1, f2 = face[order][pair], face[order][pair + 1]
    same_dir = cur[order][pair] == cur[order][pair + 1]  # the edge runs the same way in both faces
    dot = np.einsum("ij,ij->i", _unit(N[f1]), _unit(N[f2])) * np.where(same_dir, -1.0, 1.0)
    out["folded_edges"] = int((dot < math.cos(math.radians(FOLD_DEG))).sum())
    out["nonmanifold_edges"] = int((e_count > 2).sum())
    # self-intersections
    T, owner = _triangles(V, F, sizes)
    out["intersecting_pairs"] = len(_intersecting_pairs(V, T, owner, 1e-7 * scale))
    hinges = E[order][pair]  # the edges two panels share
    out["coverage"] = None if reference is None else coverage(V, T, reference, scale, hinges=hinges)
    out["max_planarity"] = float(planarity(V, F).max())  # information only: the criteria below leave it out
    out["defects"] = defect_lines(out)
    return out


def defect_lines(r: dict) -> list[str]:
    """The failed criteria of an :func:`independent_defects` report, in words."""
    lines = []
    if r["short_edges"]:
        lines.append(f"{r['short_edges']} edges under {MIN_EDGE_RATIO}× the median "
                     f"(shortest {r['min_edge_ratio']:.3f}×)")
    if r["small_corners"]:
        lines.append(f"{r['small_corners']} corners under {MIN_CORNER_DEG:.0f}° (smallest {r['min_corner']:.1f}°)")
    folds = r["folded_faces"] + r["folded_edges"]
    if folds:
        lines.append(f"folded: {r['folded_faces']} faces, {r['folded_edges']} edges")
    if r["nonmanifold_edges"]:
        lines.append(f"{r['nonmanifold_edges']} non-manifold edges")
    if r["intersecting_pairs"]:
        lines.append(f"self-intersecting: {r['intersecting_pairs']} face pairs")
    if r["coverage"] is not None and r["coverage"] < MIN_COVERAGE:
        lines.append(f"coverage {100 * r['coverage']:.1f}% < {100 * MIN_COVERAGE:.0f}%")
    return lines
