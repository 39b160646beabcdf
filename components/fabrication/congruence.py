"""Panel types: flat panels clustered into classes congruent up to a rigid motion (and optionally a mirror).

Two flat outlines with the same corner count are compared by their *alignment distance*: the largest corner
distance after the least-squares rigid alignment of one onto the other (Kabsch / Procrustes, in closed form in the
plane), minimised over the cyclic shifts of the corner correspondence and, when mirrors are allowed, over the
reflected outline with its corners reversed. A panel type at tolerance ``τ`` has a representative (the mould, the
cutting pattern) within ``τ`` of every member. Types are computed for a list of tolerances at once, smallest
first, each level grouping the types of the one before: the types at a larger tolerance are unions of those at a
smaller one, so the number of types never increases as the tolerance grows.

Array-level functions: :func:`aligned_distances`, :func:`outline_signatures`, :func:`congruence_types`.
Published component: :func:`panel_types` (``fabrication/panel_types``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.core.checks import check_choice, check_number
from components.core.types import Booleans, Curves, Integers, Mesh, Numbers
from components.fabrication.panels import (METHODS, FlatPanels, checked_panelling, closed_polylines, diagonal_pairs,
                                          flat_panels)

__all__ = [
    "DEDUPE",
    "Alignment",
    "PanelTypes",
    "PanelTypesResult",
    "aligned_distances",
    "outline_signatures",
    "congruence_types",
    "default_tolerance",
    "panel_types",
]

#: panels within this fraction of the median edge length of each other are the same panel whatever the tolerance
DEDUPE = 1e-9
_COARSE_SHARE = 0.25  # panel_types warns at a tolerance of this × the median edge or more
_CHUNK = 8192


class Alignment(NamedTuple):
    """Result of :func:`aligned_distances`."""

    distance: np.ndarray  # (p,) largest corner distance after the best alignment
    mirrored: np.ndarray  # (p,) bool, the best alignment reflects B
    shift: np.ndarray  # (p,) int64: corner i of A meets corner (shift + i) % s of B, (shift − i) % s if mirrored


def aligned_distances(A, B, mirror: bool = True) -> Alignment:
    """Largest corner distance between flat outlines after the best rigid alignment, pair by pair.

    Parameters
    ----------
    A, B : (p, s, 2) float64
        ``p`` pairs of flat outlines with ``s`` corners each, corners in order.
    mirror : bool
        Also try ``B`` reflected (its corners reversed, so that it runs the same way round as ``A``).

    Returns
    -------
    Alignment
        ``distance (p,)`` in the outlines' units, and the correspondence that gave it.

    Notes
    -----
    For every cyclic shift (and mirror) the rotation minimising the summed squared corner distances of the
    centred outlines is ``R = z / |z|`` with ``z = Σ a_i conj(b_i)`` (complex coordinates; Kabsch's solution in the
    plane); the distance of that correspondence is the largest ``|a_i − R b_i|``. The best correspondence is the
    one with the smallest largest distance. The distance is symmetric in ``A`` and ``B``.

    Example
    -------
    >>> sq = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    >>> turned = sq[:, [2, 3, 0, 1]] + 5.0                     # the same square, other corners first, moved
    >>> float(aligned_distances(sq, turned).distance[0]) < 1e-15
    True
    """
    return _aligned(_centred(A), _centred(B), mirror)


def _centred(A) -> np.ndarray:
    """Flat outlines ``(p, s, 2)`` as centred complex corners ``(p, s)``."""
    A = np.asarray(A, dtype=np.float64)
    a = A[..., 0] + 1j * A[..., 1]
    return a - a.mean(axis=1, keepdims=True)


def _aligned(a: np.ndarray, b: np.ndarray, mirror: bool) -> Alignment:
    """:func:`aligned_distances` of centred complex outlines ``a``, ``b`` (p, s)."""
    p, s = a.shape
    idx, conj = _correspondences(s, mirror)
    dist = np.empty(p)
    best = np.zeros(p, dtype=np.int64)
    for lo in range(0, p, _CHUNK):
        A = a[lo:lo + _CHUNK]
        C = b[lo:lo + _CHUNK][:, idx]  # (q, nc, s): the corners of B in every correspondence
        if mirror:
            C = np.where(conj[None, :, None], np.conj(C), C)
        z = np.einsum("qi,qci->qc", A, np.conj(C))
        az = np.abs(z)
        R = z / np.where(az > 0, az, 1.0) + (az == 0)
        diff = A[:, None, :] - R[..., None] * C
        d2 = (diff.real ** 2 + diff.imag ** 2).max(axis=2)
        j = np.argmin(d2, axis=1)
        dist[lo:lo + len(A)] = np.sqrt(d2[np.arange(len(A)), j])
        best[lo:lo + len(A)] = j
    return Alignment(dist, best >= s, (best % s).astype(np.int64))


def _correspondences(s: int, mirror: bool):
    """Corner index table ``(nc, s)`` of the cyclic shifts (then the reversed, mirrored ones) and the mirror flags."""
    shifts = (np.arange(s)[:, None] + np.arange(s)[None, :]) % s  # [r, i] -> (r + i) % s
    if not mirror:
        return shifts, np.zeros(s, dtype=bool)
    rev = (np.arange(s)[:, None] - np.arange(s)[None, :]) % s
    return np.concatenate([shifts, rev]), np.arange(2 * s) >= s


def outline_signatures(outline, s: int) -> np.ndarray:
    """Sorted edge lengths then sorted diagonals of outlines with ``s`` corners: unchanged by rigid motions,
    mirrors and the choice of the first corner.

    Parameters
    ----------
    outline : (p, s, 2) float64
        Flat outlines.
    s : int
        Their corner count.

    Returns
    -------
    (p, s + d) float64
        ``d`` the number of diagonals. When two outlines are within alignment distance ``τ`` every entry differs
        by at most ``2τ`` (each corner moves by at most ``τ``, so every corner-to-corner length by ``2τ``, and
        sorting keeps the largest difference), which makes it a safe filter for candidate pairs.

    Example
    -------
    >>> outline_signatures(np.array([[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]]), 4).round(6).tolist()
    [[1.0, 1.0, 2.0, 2.0, 2.236068, 2.236068]]
    """
    U = np.asarray(outline, dtype=np.float64)[:, :s]
    E = np.roll(U, -1, axis=1) - U
    edges = np.sort(np.hypot(E[..., 0], E[..., 1]), axis=1)
    pairs = diagonal_pairs(s)
    if len(pairs) == 0:
        return edges
    G = U[:, pairs[:, 1]] - U[:, pairs[:, 0]]
    return np.concatenate([edges, np.sort(np.hypot(G[..., 0], G[..., 1]), axis=1)], axis=1)


class PanelTypes(NamedTuple):
    """Result of :func:`congruence_types`: ``m`` panels in ``t`` types."""

    types: np.ndarray  # (m,) int64 type of every panel; types numbered by member count, largest first
    representatives: np.ndarray  # (t,) int64 the panel every member of the type is within the tolerance of
    counts: np.ndarray  # (t,) int64 panels per type
    deviation: np.ndarray  # (m,) alignment distance of every panel to its type's representative
    worst_deviation: np.ndarray  # (t,) largest deviation per type
    mirrored: np.ndarray  # (m,) bool, the panel matches its representative mirrored only
    tolerance: float
    tolerances: np.ndarray  # (q,) sorted tolerances (the tolerance among them)
    type_counts: np.ndarray  # (q,) int64 number of types at every tolerance, never increasing
    comparisons: int  # alignment distances computed


class _Level(NamedTuple):
    """Clusters of items: cluster ``c`` has representative item ``rep[c]`` and items ``items[start[c]:start[c+1]]``."""

    rep: np.ndarray  # (n,) int64
    items: np.ndarray  # (N,) int64
    start: np.ndarray  # (n + 1,) int64


def _segments(level: _Level, clusters: np.ndarray):
    """The items of some clusters, one after the other, and how many each has."""
    counts = level.start[clusters + 1] - level.start[clusters]
    offsets = np.repeat(level.start[clusters] - np.r_[0, np.cumsum(counts)[:-1]], counts)
    return level.items[offsets + np.arange(int(counts.sum()))], counts


def _pair_distances(level: _Level, Z: np.ndarray, clusters, leaders, mirror: bool) -> np.ndarray:
    """Largest alignment distance of the items of cluster ``clusters[i]`` to the representative of cluster
    ``leaders[i]``, for every i."""
    clusters = np.asarray(clusters, dtype=np.int64)
    if len(clusters) == 0:
        return np.zeros(0)
    items, counts = _segments(level, clusters)
    reps = np.repeat(level.rep[np.asarray(leaders, dtype=np.int64)], counts)
    d = _aligned(Z[items], Z[reps], mirror).distance
    return np.maximum.reduceat(d, np.r_[0, np.cumsum(counts)[:-1]])


def _leader_level(level: _Level, sig: np.ndarray, Z: np.ndarray, weight: np.ndarray, tau: float, mirror: bool,
                  tie: float = 0.0, block: int = 256):
    """Group the clusters of one level into clusters within ``tau`` of a leader's representative.

    Clusters are visited biggest first (ties: smaller first item), in blocks. A cluster joins the nearest leader
    of an earlier block whose representative is within ``tau`` of all its items; failing that, the nearest
    earlier leader of its own block; failing that, it leads a new cluster and keeps its representative. Leaders
    are found by their signatures (an item within ``tau`` of a leader has a signature within ``2 tau`` of the
    leader's; a k-d tree over the leaders, rebuilt as they grow), so the cost grows with the clusters and the
    leaders near each, not with the pairs of panels within the tolerance. Leaders nearer than ``tie`` to each other's
    distance count as equally near (a symmetric panelling's mirror-image leaders are at one distance, but in other
    units or at site coordinates their computed distances differ in the last bits): the first leader visited wins,
    so the types are the same at every scale and placement.
    """
    n = len(level.rep)
    rep = level.rep
    counts = np.diff(level.start)
    heads = level.start[:-1]
    wsum = np.add.reduceat(weight[level.items], heads)
    first = np.minimum.reduceat(level.items, heads)
    order = np.lexsort((first, -wsum))
    visit_rank = np.empty(n, dtype=np.int64)
    visit_rank[order] = np.arange(n)
    cl = np.repeat(np.arange(n), counts)
    spread = np.maximum.reduceat(np.abs(sig[level.items] - sig[rep[cl]]).max(axis=1), heads)
    radius = 2.0 * tau * (1.0 + 1e-9) + spread
    leader_of = np.full(n, -1, dtype=np.int64)  # the leading cluster of every cluster
    tree, tree_leaders, pending = None, np.zeros(0, np.int64), []
    comparisons = 0
    for b0 in range(0, n, block):
        blk = order[b0:b0 + block]
        S = sig[rep[blk]]
        pc, pl = [], []
        if tree is not None:
            hits = tree.query_ball_point(S, radius[blk], p=np.inf)
            lens = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
            if lens.sum():
                pc.append(np.repeat(blk, lens))
                pl.append(tree_leaders[np.fromiter((j for h in hits for j in h), dtype=np.int64,
                                                   count=int(lens.sum()))])
        if pending:
            pend = np.asarray(pending, dtype=np.int64)
            near = np.abs(S[:, None, :] - sig[rep[pend]][None, :, :]).max(axis=2) <= radius[blk][:, None]
            i, j = np.nonzero(near)
            pc.append(blk[i])
            pl.append(pend[j])
        if pc:
            pc, pl = np.concatenate(pc), np.concatenate(pl)
            d = _pair_distances(level, Z, pc, pl, mirror)
            comparisons += len(d)
            ok = d <= tau
            pc, pl, d = pc[ok], pl[ok], d[ok]
            leader_of[np.unique(pc)] = _nearest_first(pc, pl, d, visit_rank[pl], tie)
        rest = blk[leader_of[blk] < 0]
        if len(rest):
            R = sig[rep[rest]]
            P = cKDTree(R).query_pairs(float(radius[rest].max()), p=np.inf, output_type="ndarray")
            u, v = P.min(axis=1), P.max(axis=1)  # u visited before v
            keep = np.abs(R[u] - R[v]).max(axis=1) <= radius[rest][v]
            u, v = u[keep], v[keep]
            dist: dict = {}
            if len(v):
                d = _pair_distances(level, Z, rest[v], rest[u], mirror)
                comparisons += len(d)
                for vi, ui, di in zip(v.tolist(), u.tolist(), d.tolist()):
                    if di <= tau:
                        dist.setdefault(vi, []).append((di, ui))
            new = set()
            for vi, c in enumerate(rest.tolist()):
                cands = [x for x in dist.get(vi, ()) if x[1] in new]
                if cands:
                    near = min(x[0] for x in cands) + tie
                    leader_of[c] = rest[min(ui for di, ui in cands if di <= near)]  # ties: the first visited
                else:
                    leader_of[c] = c
                    new.add(vi)
                    pending.append(c)
        if len(pending) > 64:
            tree_leaders = np.concatenate([tree_leaders, np.asarray(pending, dtype=np.int64)])
            tree = cKDTree(sig[rep[tree_leaders]])
            pending = []
    leads = np.nonzero(leader_of == np.arange(n))[0]
    pos = np.full(n, -1, dtype=np.int64)
    pos[leads] = np.arange(len(leads))
    visit = np.empty(n, dtype=np.int64)
    visit[order] = np.arange(n)
    grouped = np.lexsort((visit, pos[leader_of]))  # clusters by their new cluster, in visiting order
    items, cnt = _segments(level, grouped)
    sizes = np.bincount(pos[leader_of], weights=counts, minlength=len(leads)).astype(np.int64)
    return _Level(rep[leads], items, np.r_[0, np.cumsum(sizes)]), comparisons


def _nearest_first(pc: np.ndarray, pl: np.ndarray, d: np.ndarray, rank: np.ndarray, tie: float) -> np.ndarray:
    """For every cluster in ``pc`` (sorted unique order) the leader ``pl`` of the candidate pairs ``(pc, pl)`` at
    distance ``d`` that is nearest, counting distances within ``tie`` of the nearest as equal and then taking the
    leader of the lowest ``rank`` (visited first)."""
    o = np.lexsort((d, pc))
    pc, pl, d, rank = pc[o], pl[o], d[o], rank[o]
    starts = np.r_[0, np.flatnonzero(pc[1:] != pc[:-1]) + 1]
    near = np.repeat(d[starts], np.diff(np.r_[starts, len(pc)])) + tie
    ok = d <= near
    o = np.lexsort((rank, ~ok, pc))  # per cluster: the candidates within the tie first, by rank
    firsts = np.r_[True, pc[o][1:] != pc[o][:-1]]
    return pl[o][firsts]


def congruence_types(outline, sizes, tolerance: float, tolerances=(), mirror: bool = True) -> PanelTypes:
    """Cluster flat outlines into types congruent within ``tolerance``, nested over a list of tolerances.

    Parameters
    ----------
    outline : (m, k, 2) float64
        Flat outlines (padding repeats the last corner), e.g. :attr:`FlatPanels.outline`.
    sizes : (m,) int64
        Corner count of every outline (outlines of different counts are never one type).
    tolerance : float
        Largest alignment distance of a panel to its type's representative, in the outlines' units (>= 0).
    tolerances : sequence of float
        More tolerances to count the types at.
    mirror : bool
        A panel and its mirror image are one type (the panel may be turned over).

    Returns
    -------
    PanelTypes
        Types at ``tolerance`` and the type counts at every tolerance.

    Notes
    -----
    Identical panels (alignment distance up to :data:`DEDUPE` × the median edge length, found by hashing their
    :func:`outline_signatures`) are merged first, so a mesh of 10,000 equal panels costs no more than one of a
    few. Then one clustering per tolerance, smallest first, each grouping the clusters of the one before (leader
    clustering, Hartigan 1975, with every member checked against the leader's representative): the types at a
    larger tolerance are unions of the types at a smaller one, so their number never increases, and every panel
    is within its level's tolerance of its type's representative (the mould or cutting pattern of Eigensatz et
    al. 2010, *Paneling architectural freeform surfaces*). Leaders are looked up by signature, so the cost grows
    with the panels and the leaders near each one, not with the pairs of panels within the tolerance. The
    tolerance's types are those of its level of this nesting, so they depend on the smaller tolerances asked
    with it.

    Example
    -------
    >>> sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> outlines = np.stack([sq, sq * 1.001, sq * 2.0])
    >>> congruence_types(outlines, np.array([4, 4, 4]), 0.01).types.tolist()
    [0, 0, 1]
    """
    tolerance = check_number(tolerance, "tolerance", 0)
    taus = np.unique(np.asarray([tolerance] + [check_number(t, "tolerances", 0) for t in tolerances], dtype=float))
    at = int(np.searchsorted(taus, tolerance))
    U = np.asarray(outline, dtype=np.float64)
    sizes = np.asarray(sizes, dtype=np.int64)
    m = len(U)
    if m == 0:
        z = np.zeros(0, dtype=np.int64)
        return PanelTypes(z, z, z, np.zeros(0), np.zeros(0), np.zeros(0, bool), tolerance, taus,
                          np.zeros(len(taus), np.int64), 0)
    E = np.roll(U, -1, axis=1) - U
    L = np.hypot(E[..., 0], E[..., 1])[np.arange(U.shape[1])[None, :] < sizes[:, None]]
    delta = DEDUPE * (float(np.median(L)) if len(L) else 1.0)
    rep_panel = np.empty(m, dtype=np.int64)  # every panel's type representative (a panel) at the tolerance
    type_counts = np.zeros(len(taus), dtype=np.int64)
    comparisons = 0
    for s in np.unique(sizes).tolist():
        idx = np.nonzero(sizes == s)[0]
        Us = U[idx, :s]
        sig = outline_signatures(Us, s)
        Zs = _centred(Us)
        key = np.round(sig / delta).astype(np.int64) if delta > 0 else sig
        _, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        lead = np.full(inv.max() + 1, -1, dtype=np.int64)
        lead[inv[::-1]] = np.arange(len(idx))[::-1]
        lead = lead[inv]
        same = _aligned(Zs, Zs[lead], mirror).distance <= delta
        comparisons += len(idx)
        own = np.where(same, lead, np.arange(len(idx)))  # a member not within delta of its key's first is alone
        heads, item = np.unique(own, return_inverse=True)
        item = item.ravel()
        weight = np.bincount(item)
        level = _Level(np.arange(len(heads)), np.arange(len(heads)), np.arange(len(heads) + 1))
        hsig, hZ = sig[heads], Zs[heads]
        for q, tau in enumerate(taus.tolist()):
            level, n_cmp = _leader_level(level, hsig, hZ, weight, tau, mirror, tie=delta)
            comparisons += n_cmp
            type_counts[q] += len(level.rep)
            if q == at:
                item_rep = np.empty(len(heads), dtype=np.int64)
                item_rep[level.items] = np.repeat(level.rep, np.diff(level.start))
                rep_panel[idx] = idx[heads[item_rep[item]]]
    # types numbered by size (largest first), then by their representative
    reps, inverse, counts = np.unique(rep_panel, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    rank = np.lexsort((reps, -counts))
    number = np.empty(len(reps), dtype=np.int64)
    number[rank] = np.arange(len(reps))
    types = number[inverse]
    reps = reps[rank]
    deviation = np.zeros(m)
    mirrored = np.zeros(m, dtype=bool)
    for s in np.unique(sizes).tolist():
        idx = np.nonzero(sizes == s)[0]
        al = aligned_distances(U[idx, :s], U[reps[types[idx]], :s], mirror)
        deviation[idx] = al.distance
        mirrored[idx] = al.mirrored
    worst = np.zeros(len(reps))
    np.maximum.at(worst, types, deviation)
    return PanelTypes(types, reps, counts[rank].astype(np.int64), deviation, worst, mirrored, float(tolerance), taus,
                      type_counts, int(comparisons))


# ----------------------------------------------------------------------------------------------
# published component


class PanelTypesResult(NamedTuple):
    types: Integers
    representatives: Integers
    counts: Integers
    deviation: Numbers
    worst_deviation: Numbers
    mirrored: Booleans
    type_count: int
    tolerance: float
    tolerances: Numbers
    type_counts: Integers
    type_outlines: Curves
    warnings: list[str]


def default_tolerance(flat: FlatPanels, tolerance: float, absolute_tolerance: float = 0.0) -> float:
    """The panel-type tolerance: ``tolerance`` when positive, else the document's absolute tolerance when known,
    else 1e-3 × the median flat edge length (model units).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> default_tolerance(flat_panels(*quad_grid(2, 2, 2.0, 2.0)), 0.0)
    0.001
    """
    if tolerance > 0:
        return float(tolerance)
    if absolute_tolerance > 0:
        return float(absolute_tolerance)
    L = flat.edge_lengths[np.isfinite(flat.edge_lengths)]
    return 1e-3 * float(np.median(L)) if len(L) else 1e-3


def panel_types(mesh: Mesh, tolerance: float = 0.0, tolerances: Numbers | None = None, mirror: bool = True,
                method: str = "project", absolute_tolerance: float = 0.0) -> PanelTypesResult:
    """Panel types: panels congruent up to a rigid motion (and a mirror) within a tolerance, and the trade-off.

    Parameters
    ----------
    mesh : Mesh
        The panelling ``(V, F)``, consistently oriented.
    tolerance : float
        Largest corner distance of a panel to its type's representative after their best alignment, in model
        units; 0: the document's absolute tolerance (from Grasshopper), else 1e-3 × the median edge length.
    tolerances : Numbers
        Tolerances (model units) to count the types at, e.g. 1, 2, 5, 10 mm; none: 1, 2, 5 and 10 × the tolerance.
    mirror : bool
        A panel and its mirror image are one type (panels may be turned over).
    method : str
        Flattening of the panels (see ``fabrication/panels``): ``"project"`` or ``"unfold"``.

    Returns
    -------
    types : Integers
        Type of every panel (0 is the type with the most panels).
    representatives : Integers
        Per type the panel (face index) every member is within the tolerance of: the mould or cutting pattern.
    counts : Integers
        Panels per type.
    deviation : Numbers
        Per panel the largest corner distance to its type's representative after the best alignment (model units).
    worst_deviation : Numbers
        Per type the largest deviation of a member.
    mirrored : Booleans
        Per panel, True when it matches its representative only turned over.
    type_count : int
        Number of types at the tolerance.
    tolerance : float
        The tolerance used (model units).
    tolerances : Numbers
        The tolerances of the trade-off, ascending.
    type_counts : Integers
        Number of types at each of them (never increasing).
    type_outlines : Curves
        Flat outline of every type's representative, in its own frame (first corner at the origin).

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        Negative tolerances, unknown ``method``.

    Notes
    -----
    Leader clustering of the alignment distance (least-squares rigid motion over the corner correspondences, the
    largest corner distance after it), nested over the sorted tolerances (see :func:`congruence_types`): every
    panel is within its tolerance of its type's representative, and the type counts never increase as the
    tolerance grows. The types at ``tolerance`` are its level of that nesting. Eigensatz, Kilian, Schiftner,
    Mitra, Pottmann, Pauly, *Paneling architectural freeform surfaces*, SIGGRAPH 2010 (panel types, moulds).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = panel_types(quad_grid(3, 2))
    >>> res.type_count, res.counts.tolist()
    (1, [6])
    """
    V, F, _ = checked_panelling(mesh)
    tolerance = check_number(tolerance, "tolerance", 0)
    check_choice(method, "method", METHODS)
    extra = [] if tolerances is None else [check_number(t, "tolerances", 0) for t in np.ravel(tolerances)]
    flat = flat_panels(V, F, method=method)
    tol = default_tolerance(flat, tolerance, check_number(absolute_tolerance, "absolute_tolerance", 0))
    warnings: list[str] = []
    if tolerances is None:
        extra = [tol, 2 * tol, 5 * tol, 10 * tol]
    L = flat.edge_lengths[np.isfinite(flat.edge_lengths)]
    floor = DEDUPE * float(np.median(L))
    if tol < floor:
        warnings.append(f"tolerance {tol:.3g} is below the numerical floor {floor:.3g} (1e-9 × the median edge): "
                        "panels that close are one type")
    median = floor / DEDUPE
    if tol >= _COARSE_SHARE * median:  # e.g. a document tolerance of 0.001 on a model of nanometre-sized panels
        source = "tolerance" if tolerance > 0 else "the document's absolute tolerance (tolerance 0)"
        warnings.append(f"{source} {tol:.3g} is {tol / median:.3g} × the median edge {median:.3g}: panels that "
                        "different are one type; give a tolerance in the model's units")
    res = congruence_types(flat.outline, flat.sizes, tol, extra, mirror=bool(mirror))
    over = res.worst_deviation > tol * (1 + 1e-9) + floor
    if over.any():
        warnings.append(f"{int(over.sum())} types have members {res.worst_deviation.max():.3g} from their "
                        f"representative, over the tolerance {tol:g}")
    ask = np.unique(np.asarray(extra, dtype=float)) if extra else res.tolerances
    counts_at = res.type_counts[np.searchsorted(res.tolerances, ask)]
    reps = res.representatives
    return PanelTypesResult(
        types=res.types,
        representatives=reps,
        counts=res.counts,
        deviation=res.deviation,
        worst_deviation=res.worst_deviation,
        mirrored=res.mirrored,
        type_count=int(len(reps)),
        tolerance=float(tol),
        tolerances=ask,
        type_counts=counts_at.astype(np.int64),
        type_outlines=closed_polylines(flat.outline[reps], flat.sizes[reps]),
        warnings=warnings,
    )
