"""The candidate quad mesh of a surface: direction field → seamless parametrization → integer iso-line extraction.

:func:`candidate_mesh` chains the field steps up to the quad-dominant candidate (before any optimization): a
direction field on the surface (:func:`components.fields.parametrize.direction_field`), a seamless integer-grid
parametrization following it (:func:`components.fields.parametrize.seamless_parametrization`) and the quad mesh of
its integer iso-lines with the boundary treatment and clean-up of :mod:`components.fields.extract`.
:func:`candidate_quality` measures a candidate; :func:`extract_quads` is the published component
(``fields/extract_quads``). The planarization that follows is in :mod:`components.fields.pipeline`.

References
----------
D. Bommes, H. Zimmer, L. Kobbelt, "Mixed-integer quadrangulation", ACM Trans. Graph. (SIGGRAPH) 28(3), 2009.
H.-C. Ebke, D. Bommes, M. Campen, L. Kobbelt, "QEx: robust quad mesh extraction", ACM Trans. Graph. (SIGGRAPH
Asia) 32(6), 2013.
"""
from __future__ import annotations

import time
from functools import partial
from itertools import islice
from typing import Callable, NamedTuple

import numpy as np

from components.core.blas import single_blas_thread
from components.core.checks import check_choice, check_mesh, check_number
from components.core import deadline, progress
from components.core.errors import InputError
from components.core.frame import Frame, bounding_frame
from components.core.measures import cross, quad_planarity
from components.core.mesh import edge_topology, face_sizes, triangulate
from components.core.parallel import concurrently, for_each
from components.core.proximity import TriangleIndex
from components.core.types import Mesh, Texts
from components.fields.extract import (
    collapse_short_edges,
    quad_mesh_from_parametrization,
    relax_edge_lengths,
    snap_boundary,
    split_large_faces,
)
from components.fields.parametrize import (
    FIELDS,
    Parametrization,
    check_target_fits,
    direction_field,
    seamless_parametrizations,
)
from components.fields.repair import candidate_health, repaired_candidate

__all__ = ["CANDIDATE_BOUNDARY_MODES", "Candidate", "ExtractResult", "Quality", "candidate_mesh",
           "candidate_quality", "extract_quads"]


class Candidate(NamedTuple):
    """Result of :func:`candidate_mesh`.

    ``V, F`` the candidate, ``tri, bary`` where each vertex sits on the input triangles, ``quads``,
    ``other_faces``, ``quad_ratio``, ``singularities`` (interior vertices of valence ≠ 4),
    ``field_singularities`` (singular vertices of the field), ``mean_angle_error`` (degrees), ``param`` the
    :class:`~components.fields.parametrize.Parametrization`, ``T`` the triangulated input, ``warnings``, ``timings``;
    with ``repair``: ``health`` (:class:`~components.metrics.health.PanelHealth` of the candidate against the
    input surface, planarity left out) and ``repairs`` (what :func:`~components.fields.repair.repaired_candidate`
    did), else ``None``; and ``alternative``: a function that builds the next healthy candidate of the ranking
    (``None`` when there is none; each call the next one), for a caller whose optimization of this one fails.
    """

    V: np.ndarray
    F: np.ndarray
    tri: np.ndarray
    bary: np.ndarray
    quads: int
    other_faces: int
    quad_ratio: float
    singularities: int
    field_singularities: int
    mean_angle_error: float
    param: Parametrization
    T: np.ndarray
    warnings: list
    timings: dict
    health: object = None
    repairs: dict | None = None
    alternative: Callable[[], "Candidate | None"] | None = None  # with repair: the next healthy one, or None


def _irregular_vertices(V: np.ndarray, F: np.ndarray) -> int:
    topo = edge_topology(F)
    n = len(V)
    val = np.bincount(topo.E.ravel(), minlength=n)
    bnd = np.zeros(n, dtype=bool)
    bnd[topo.E[topo.count == 1].ravel()] = True
    return int(np.count_nonzero(~bnd & (val != 4) & (val > 0)))


_DENSITIES = (0.95, 1.0, 1.05)
_FREE_ANGLE = np.radians(10.0)  # "mixed": boundary stretches within this angle of a field family follow an iso-line
CANDIDATE_BOUNDARY_MODES = ("auto", "snap", "mixed", "aligned", "free")


def _check_constraints(constraint_faces, constraint_directions, m: int):
    """Validate optional per-face direction constraints: ``(faces (c,), directions (c, 3))`` or ``None``."""
    if constraint_faces is None and constraint_directions is None:
        return None
    if constraint_faces is None or constraint_directions is None:
        raise InputError("constraint_faces", "faces and directions must be given together")
    try:
        cf = np.asarray(constraint_faces, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError("constraint_faces", "must be face indices") from None
    if len(cf) == 0:
        return None
    if not np.all(np.isfinite(cf)) or np.any(cf != np.round(cf)):
        raise InputError("constraint_faces", "must be integer face indices")
    cf = cf.astype(np.int64)
    if np.any((cf < 0) | (cf >= m)):
        i = int(cf[(cf < 0) | (cf >= m)][0])
        raise InputError("constraint_faces", f"face {i} does not exist (the mesh has {m} triangles)")
    try:
        cd = np.asarray(constraint_directions, dtype=float).reshape(-1, 3)
    except (TypeError, ValueError):
        raise InputError("constraint_directions", "must be (c, 3) vectors") from None
    if len(cd) != len(cf):
        raise InputError("constraint_directions", f"has {len(cd)} vectors for {len(cf)} constraint faces")
    if not np.all(np.isfinite(cd)) or np.any(np.linalg.norm(cd, axis=1) == 0):
        raise InputError("constraint_directions", "vectors must be finite and non-zero")
    return cf, cd


def _extracts(V, T, U, W, target: float, mode: str, densities, merge: float, index: TriangleIndex) -> list:
    """Parametrizations (one per density, sharing their factorization) and extractions with a boundary treatment
    and the short edges collapsed (see :func:`candidate_mesh`), edge lengths not yet relaxed (:func:`_relaxed`):
    ``[(extraction, parametrization), ...]``."""
    pmode = {"snap": "free", "mixed": "aligned"}.get(mode, mode)
    pars = seamless_parametrizations(V, T, U, W, target, densities, boundary=pmode,
                                     free_angle=_FREE_ANGLE if mode == "mixed" else None)
    out = []
    for par in pars:
        ex = quad_mesh_from_parametrization(V, T, par.UV, merge=merge, target_length=target)
        if mode in ("snap", "mixed"):
            Vx, Fx, trx, bax, grx = snap_boundary(V, T, ex.V, ex.F, ex.tri, ex.bary, ex.grid, target, index=index)
            ex = ex._replace(V=Vx, F=Fx, tri=trx, bary=bax, grid=grx)
        Vx, Fx, trx, bax, grx = collapse_short_edges(ex.V, split_large_faces(ex.V, ex.F), ex.tri, ex.bary, ex.grid,
                                                     target)
        out.append((ex._replace(V=Vx, F=Fx, tri=trx, bary=bax, grid=grx), par))
    return out


def _timed(fn, *args):
    """``(fn(*args), seconds it took)``."""
    t = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t


def _relaxed(V, T, ex, target: float, index: TriangleIndex):
    """The extraction with its edge lengths evened out on the surface (faces unchanged)."""
    if len(ex.F) == 0:
        return ex
    Vx, trx, bax = relax_edge_lengths(V, T, ex.V, ex.F, ex.tri, ex.bary, target, index=index)
    return ex._replace(V=Vx, tri=trx, bary=bax)


_SHIFT = 0.01  # the relaxation moves the mean edge by well under this × the target (measured: < 1e-3)


def _best_first(V, T, tried: list, target: float, index: TriangleIndex):
    """The tried extractions (not yet relaxed) relaxed and ranked by :func:`_score`, best first (the first of
    equals first), lazily: the relaxation keeps the faces (so the quad share) and moves the mean edge by well
    under :data:`_SHIFT`, so the candidates are relaxed in the order of their quad share and their mean edge's
    distance to the target until one has ≥ 95% quads and ≥ 95% of its edges within ±30% of the target: a
    candidate farther from the target by more than ``_SHIFT`` can at best tie on the edge share and loses on the
    mean edge, so the best one is known without relaxing the others. They are relaxed (and ranked) only when
    more than the best one is asked for. Yields ``(extraction, parametrization)``."""
    n = len(tried)
    pre = [_score(ex, target) for ex, _ in tried]
    order = sorted(range(n), key=lambda i: (not pre[i][0], -pre[i][2], i))
    done: dict = {}

    def finish(i):
        if i not in done:
            ex = _relaxed(V, T, tried[i][0], target, index)
            done[i] = (ex, tried[i][1], _score(ex, target))
        return done[i]

    best = None
    for i in order:
        if best is not None:
            b = done[best][2]
            if b[0] and (not pre[i][0] or (b[1] >= 0.95 and -b[2] < -pre[i][2] - _SHIFT)):
                break  # this one (and every later one) can at best tie on the edge share and is farther
        s = finish(i)[2]
        if best is None or s > done[best][2] or (s == done[best][2] and i < best):
            best = i
    yield done[best][:2]
    for_each(finish, [i for i in range(n) if i not in done])  # the others at once, on both cores (each its own)
    rest = sorted((i for i in range(n) if i != best), key=lambda i: done[i][2], reverse=True)  # stable
    for i in rest:
        yield done[i][:2]


def _score(ex, target: float) -> tuple:
    """Ranking of candidates: ≥ 95% quads first, then the share of edges within ±30% of the target (counted up
    to 95%), then the mean edge length nearest the target (the panel count the user asked for)."""
    if len(ex.F) == 0:
        return (False, 0.0, 0.0)
    quad_ratio, within, mean_edge = _shares(ex.V, ex.F, target)  # candidate_quality without the planarity
    return (quad_ratio >= 0.95, min(within, 0.95), -abs(mean_edge / target - 1.0))


@single_blas_thread()  # sparse factorizations: see components.core.blas
def candidate_mesh(mesh, target_length: float, field: str = "conjugate", alignment: float = 0.1,
                   boundary: str = "auto", constraint_faces=None, constraint_directions=None,
                   merge: float = 0.05, name: str = "mesh", release_separation: float | None = None,
                   repair: bool = False) -> Candidate:
    """Candidate quad mesh of a surface: field → seamless parametrization → integer iso-line extraction.

    Parameters
    ----------
    mesh : tuple (V, F)
        The design surface: open, oriented, manifold, a disk or a disk with holes (triangles or polygons).
    target_length : float
        Panel size in model units.
    field : {"conjugate", "smooth", "principal"}
        Direction field (see :func:`components.fields.parametrize.direction_field`).
    alignment : float
        Weight of the field's pull towards the principal directions.
    boundary : {"auto", "snap", "mixed", "aligned", "free"}
        ``"snap"``: free-boundary parametrization, then grid vertices near the boundary are snapped onto it and
        the boundary band relaxed (:func:`components.fields.extract.snap_boundary`): whole quads along the boundary
        without forcing the field to follow it. ``"mixed"``: boundary stretches within 10° of a field family
        follow an integer iso-line, the others are free, then snapped as in ``"snap"``. ``"aligned"``: every
        boundary stretch follows an iso-line (distorts the cells where the boundary is oblique to the field).
        ``"free"``: iso-lines end on the boundary (clipped cells). ``"auto"`` (default): ``"snap"`` and
        ``"mixed"`` each at 0.95, 1 and 1.05 times the centred grid density (the parametrization and extraction
        are cheap next to the field), keeping the candidate with ≥ 95% quads and the most edges within ±30% of
        the target length (counted up to 95%), then the one whose mean edge is nearest the target. Every
        candidate's short edges and degenerate corners are collapsed
        (:func:`components.fields.extract.collapse_short_edges`) and its edge lengths evened out on the surface
        (:func:`components.fields.extract.relax_edge_lengths`; lazily: only the candidates that can still win are
        relaxed, since the relaxation keeps the faces and moves the mean edge by well under 1% of the target).
    constraint_faces : (c,) int, optional
        Faces of the (triangulated) input whose field direction is prescribed.
    constraint_directions : (c, 3) float, optional
        The prescribed directions.
    merge : float
        Candidate vertices closer than ``merge · target_length`` are merged.
    name : str
        Name of the mesh input in error messages.
    release_separation : float, optional
        Conjugate field: faces whose conjugate pair is narrower than this (radians) keep the smooth pair
        (:func:`components.fields.field.conjugate_frame_field`; its default 45° when omitted, 0 never).
    repair : bool
        Repair the panels that are not healthy (:func:`components.fields.repair.repaired_candidate`: valence-2
        vertices dissolved, short edges collapsed, vertices of pinched, folded or non-convex panels smoothed on
        the surface, such panels split, slivers collapsed) and measure the candidate's health against the
        surface. With ``"auto"`` the tried candidates are repaired best score first until one is healthy (else
        the one with the fewest unhealthy panels is kept). Off by default (the subdivision strategy's coarse nets).

    Returns
    -------
    Candidate

    Raises
    ------
    MeshError
        Malformed, non-manifold, degenerate or closed mesh, or one with handles.
    InputError
        Bad target length, field, boundary mode, alignment or constraints.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    >>> cand = candidate_mesh((V, F), target_length=2.0)
    >>> cand.quads, cand.other_faces, cand.singularities
    (16, 0, 0)
    """
    V, T, target, alignment, cons = checked_inputs(mesh, target_length, field, alignment, boundary, constraint_faces,
                                                   constraint_directions, name)
    # centred, unit size, snapped: far from the origin the products would lose digits, and the same surface in other
    # units gives the same numbers bit for bit (components.core.frame), so the same candidate up to scale
    frame = bounding_frame(V)
    return framed_candidate(frame.to(V), T, frame.length(target), frame, field, alignment, boundary, cons, merge,
                            release_separation, repair)


def checked_inputs(mesh, target_length, field, alignment, boundary, constraint_faces, constraint_directions,
                   name: str = "mesh"):
    """:func:`candidate_mesh`'s inputs checked: ``(V, T, target, alignment, constraints)``, ``T`` the triangulated
    faces; :class:`~components.core.errors.InputError` / :class:`~components.core.errors.MeshError` naming the bad
    one."""
    target = check_number(target_length, "target_length", 0, above=True)
    check_choice(field, "field", FIELDS)
    alignment = check_number(alignment, "alignment", 0)
    check_choice(boundary, "boundary", CANDIDATE_BOUNDARY_MODES)
    V, F = check_mesh(mesh, name)
    T, _ = triangulate(F)
    cons = _check_constraints(constraint_faces, constraint_directions, len(T))
    check_target_fits(V, T, target)
    return V, T, target, alignment, cons


@single_blas_thread()
def framed_candidate(V, T, target: float, frame: Frame, field: str = "conjugate", alignment: float = 0.1,
                     boundary: str = "auto", cons=None, merge: float = 0.05, release_separation: float | None = None,
                     repair: bool = False) -> Candidate:
    """:func:`candidate_mesh` of checked inputs (:func:`checked_inputs`) given in the frame ``frame``
    (``V = frame.to(model V)``, ``target = frame.length(model target)``); the candidate's vertices are mapped back
    with ``frame.back`` (:data:`components.core.frame.IDENTITY` keeps them in the frame)."""
    timings = {}
    progress.report(0.0, "direction field")
    t = time.perf_counter()
    U, W = direction_field(V, T, field=field, alignment=alignment, constraints=cons,
                           release_separation=release_separation, resolution=target)
    timings["field"] = time.perf_counter() - t
    progress.report(0.3, "parametrization and quad extraction")
    t = time.perf_counter()
    index = TriangleIndex(V, T)  # one closest-point index for every extraction's relaxations
    if boundary == "auto":
        # the two boundary modes are independent: at the same time on two cores (in this order, as run one by one)
        runs = concurrently(*(partial(_timed, _extracts, V, T, U, W, target, mode, _DENSITIES, merge, index)
                              for mode in ("snap", "mixed")))
        tried = [r for rs, _ in runs for r in rs]
        # the section's seconds shared out as its work was (the runs overlap in time)
        share = sum(p.timings["total"] for _, p in tried) / max(sum(s for _, s in runs), 1e-12)
        timings["parametrize"] = min(share, 1.0) * (time.perf_counter() - t)
    else:
        tried = _extracts(V, T, U, W, target, boundary, (1.0,), merge, index)
        timings["parametrize"] = tried[0][1].timings["total"]
    ranked = _best_first(V, T, tried, target, index)
    health, repairs, alternative = None, None, None
    progress.report(0.85, "repair")
    cut: list = []  # why the repairs stopped short of the ranking's end (a deadline)
    if repair:
        repaired = _repaired(V, T, ranked, target, index, cut)
        ex, par, health, repairs = _healthiest(repaired)

        def alternative():
            """The next healthy candidate of the ranking (repaired), or None."""
            for out in repaired:
                if out[2] is not None and out[2].healthy:
                    return _candidate(V, T, *out, frame, dict(timings), alternative)
            return None
    else:
        ex, par = next(ranked)
    timings["extract"] = time.perf_counter() - t - timings["parametrize"]
    out = _candidate(V, T, ex, par, health, repairs, frame, timings, alternative)
    out.warnings.extend(cut)
    return out


def _candidate(V, T, ex, par, health, repairs, frame: Frame, timings: dict, alternative) -> Candidate:
    """The :class:`Candidate` of an extraction ``ex`` of the parametrization ``par`` (``V`` in ``frame``), in model
    units."""
    warnings = list(par.warnings)
    s = face_sizes(ex.F) if len(ex.F) else np.zeros(0, dtype=np.int64)
    quads = int(np.count_nonzero(s == 4))
    other = int(len(s) - quads)
    if len(ex.F) == 0:
        warnings.append("no quads: the target length is too large for this surface")
    area = 0.5 * np.linalg.norm(cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    mean_err = float(np.degrees(np.sum(par.angle_error * area) / area.sum()))
    ratio = quads / len(s) if len(s) else 0.0
    irregular = _irregular_vertices(ex.V, ex.F) if len(ex.F) else 0
    return Candidate(frame.back(ex.V), ex.F, ex.tri, ex.bary, quads, other, ratio, irregular, len(par.singularities),
                     mean_err, par, T, warnings, timings, health, repairs, alternative)


def _repaired(V, T, ranked, target: float, index: TriangleIndex, cut: list):
    """The ranked extractions (best score first) repaired, lazily: yields ``(ex, par, health, repairs)`` (the
    repaired extraction, its health against the surface) and, for an empty one, ``(ex, par, None, {})``. A
    candidate whose repair leaves as many unhealthy panels as the best unhealthy one so far, while none was healthy,
    is yielded with ``health`` None (not checked against the surface: it cannot win).

    The best-ranked candidate is repaired alone, the next ones two at a time (two cores; the results and their
    order are those of one at a time). Under a caller's deadline (:mod:`components.core.deadline`, e.g. the
    server's time limit per solve) the next ones are repaired only while the time left holds twice the last
    repairs (them, and as long for the planarization); else the ranking ends there and ``cut`` gets the warning.
    (A panel size near the mesh's edge length made every repair slow and none healthy: 6 × 13 s on a 43k-triangle
    patch at 1.24 mesh edges per panel, 88 s for the candidate, past the server's 90 s.)"""
    fewest = None  # unhealthy panels of the best unhealthy candidate so far
    last, k = 0.0, 0
    items = iter(ranked)

    def repair(item):
        ex = item[0]
        return None if len(ex.F) == 0 else repaired_candidate(V, T, ex.V, ex.F, ex.tri, ex.bary, ex.grid, target,
                                                               index=index)

    while True:
        # the best-ranked one alone (it is usually healthy); after it, two at a time on two cores (the same
        # repairs, in the same order: the second is wasted only when the first is healthy)
        batch = list(islice(items, 2 if k else 1))
        if not batch:
            return
        if k:
            _, why = deadline.capped(2.0 * last)
            if why is not None:
                cut.append(f"the search for a healthy candidate stopped after {k} of the ranking, cut short by {why} "
                           f"(each repair took about {last:.3g} s)")
                return
        t = time.perf_counter()
        done = concurrently(*(partial(repair, item) for item in batch))
        if any(r is not None for r in done):
            last = time.perf_counter() - t
        for (ex, par), r in zip(batch, done):
            if r is None:
                yield ex, par, None, {}
                continue
            k += 1
            fixed = ex._replace(V=r.V, F=r.F, tri=r.tri, bary=r.bary, grid=r.grid)
            # the check against the surface adds defects (flipped faces, coverage) to the shape checks the repair
            # measured last: a candidate with as many unhealthy faces as the best one already cannot win
            if fewest is not None and int(np.count_nonzero(r.health.face_defects)) >= fewest:
                yield fixed, par, None, r.actions
                continue
            health = candidate_health(r.V, r.F, (V, T))
            if not health.healthy:
                bad = _unhealthy_count(health)
                fewest = bad if fewest is None else min(fewest, bad)
            yield fixed, par, health, r.actions


def _unhealthy_count(health) -> int:
    """What ranks unhealthy candidates: their unhealthy panels, plus one when they cover under 85 % of the surface."""
    return int(np.count_nonzero(health.face_defects)) + (health.coverage < 0.85)


def _healthiest(repaired):
    """The first healthy of the repaired extractions (:func:`_repaired`, best score first); else the one with
    the fewest unhealthy faces (the first of equals). (Stopping at a nearly healthy candidate was tried: on the 20k
    benchmark patch moved to +5e6 it kept a candidate with one 167° corner where the next one was healthy.)
    Returns ``ex, par, health, repairs``."""
    best = None
    first = None
    for ex, par, health, repairs in repaired:
        first = (ex, par) if first is None else first
        if health is None:
            continue
        if health.healthy:
            return ex, par, health, repairs
        bad = _unhealthy_count(health)
        if best is None or bad < best[0]:
            best = (bad, (ex, par, health, repairs))
    if best is None:
        ex, par = first
        return ex, par, None, {}
    return best[1]


class Quality(NamedTuple):
    """Candidate quality before optimization (see :func:`candidate_quality`)."""

    max_planarity: float
    mean_planarity: float
    quad_ratio: float
    edge_length_within: float
    mean_edge_length: float


def candidate_quality(V: np.ndarray, F: np.ndarray, target_length: float, spread: float = 0.3) -> Quality:
    """Planarity of the quads, quad share and share of edges within ``±spread`` of the target length.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, k) int64
    target_length : float
    spread : float
        Relative tolerance of the edge-length check.

    Returns
    -------
    Quality

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> q = candidate_quality(*quad_grid(3, 3, 3.0, 3.0), target_length=1.0)
    >>> q.max_planarity, q.quad_ratio, q.edge_length_within
    (0.0, 1.0, 1.0)
    """
    if len(F) == 0:
        return Quality(0.0, 0.0, 0.0, 0.0, 0.0)
    q = face_sizes(F) == 4
    pl = np.abs(quad_planarity(V, F[q])) if q.any() else np.zeros(1)
    return Quality(float(pl.max()), float(pl.mean()), *_shares(V, F, target_length, spread))


def _shares(V: np.ndarray, F: np.ndarray, target_length: float, spread: float = 0.3) -> tuple:
    """Quad share, share of edges within ``±spread`` of the target length and mean edge length of a non-empty
    candidate (the planarity-free part of :func:`candidate_quality`)."""
    q = face_sizes(F) == 4
    E = edge_topology(F).E
    L = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)
    within = float(np.mean(np.abs(L / target_length - 1.0) <= spread))
    return float(q.mean()), within, float(L.mean())


# ----------------------------------------------------------------------------------------------
# published component


class ExtractResult(NamedTuple):
    mesh: Mesh
    quads: int
    other_faces: int
    singularities: int
    quad_ratio: float
    mean_angle_error: float
    healthy: bool
    violations: Texts
    warnings: list[str]


def extract_quads(mesh: Mesh, target_length: float, field: str = "conjugate", alignment: float = 0.1,
                  boundary: str = "auto") -> ExtractResult:
    """Candidate quad-dominant mesh of a surface from the integer iso-lines of a field-aligned parametrization.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``: an open, oriented, manifold mesh (a disk or a disk with holes).
    target_length : float
        Panel size (edge length) in model units.
    field : str
        ``"conjugate"`` (planar quads), ``"smooth"`` or ``"principal"`` (see
        :func:`components.fields.parametrize.parametrize`).
    alignment : float
        Weight of the field's pull towards the principal curvature directions.
    boundary : str
        ``"auto"`` (default: the best of ``"snap"`` and ``"mixed"`` at three grid densities, by quad share, the
        share of edges within ±30% of the target, then the mean edge nearest the target), ``"snap"`` (free
        parametrization, grid vertices near the boundary snapped onto it: whole quads along the boundary),
        ``"mixed"`` (boundary stretches along a field direction follow iso-lines, the rest snapped), ``"aligned"``
        (every boundary stretch follows an iso-line) or ``"free"`` (clipped cells).

    Returns
    -------
    mesh : Mesh
        The candidate ``(V, F)``: quads (and a few other polygons), every vertex on the input surface, oriented
        like the input.
    quads : int
        Number of quads.
    other_faces : int
        Number of faces that are not quads.
    singularities : int
        Interior vertices whose valence is not 4.
    quad_ratio : float
        Share of quads among the faces.
    mean_angle_error : float
        Area-weighted mean angle (degrees) between the parametrization's iso-lines and the field.
    healthy : bool
        Whether the panels are fabricable before planarization: corners between 20° and 160°, edges over 0.2 × the
        median edge, panels over 0.1 × the median panel area, convex, not folded, flipped or crossing, at least 85%
        of the surface covered (planarity is the planarization's).
    violations : Texts
        One line per failed check, with the count and the worst value against its bound; empty when healthy.

    Raises
    ------
    MeshError
        Malformed, non-manifold, degenerate or closed mesh, or one with handles.
    InputError
        Non-positive target length, unknown field or boundary mode.

    Notes
    -----
    Parametrization after Bommes, Zimmer & Kobbelt 2009, extraction after Ebke et al. 2013 (see
    :mod:`components.fields.extract`); the panels that are not healthy are repaired
    (:func:`components.fields.repair.repaired_candidate`).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    >>> res = extract_quads((V, F), target_length=2.0)
    >>> res.quads, res.quad_ratio, res.healthy
    (16, 1.0, True)
    """
    res = candidate_mesh(mesh, target_length, field=field, alignment=alignment, boundary=boundary, repair=True)
    warnings = list(res.warnings)
    healthy = bool(res.health is not None and res.health.healthy)
    violations = list(res.health.violations) if res.health is not None else ["no panel fits on the surface"]
    if not healthy:
        bad = int(np.count_nonzero(res.health.face_defects)) if res.health is not None else 0
        warnings.append(f"the candidate is not healthy ({bad} of {len(res.F)} panels with defects): "
                        + "; ".join(violations))
    return ExtractResult((res.V, res.F), res.quads, res.other_faces, res.singularities, res.quad_ratio,
                         res.mean_angle_error, healthy, violations, warnings)
