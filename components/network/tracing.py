"""Principal curvature line network: both families of curvature lines traced on a surface at an even spacing.

The lines of curvature of a surface form an orthogonal and conjugate network; quads laid along it are planar to
second order and their limit is a conical mesh (Liu et al. 2006). This module

1. estimates the principal directions per triangle (:func:`components.core.curvature.vertex_principal_curvature` then
   :func:`components.core.curvature.face_principal_curvature`, quadric fits on a ``radius``-ring),
2. marks **umbilic regions**: triangles whose curvature anisotropy ``|k1 − k2| / (|k1| + |k2| + κ0)`` is below a
   threshold (``κ0`` = 10% of the median ``|k1| + |k2|``, so nearly flat spots count as umbilic too) — the
   principal directions are undefined there,
3. traces both families with the project's streamline tracer (:func:`components.fields.streamlines.evenly_spaced_streamlines`,
   RK4 on the surface, evenly spaced seeding at the panel size) on the field ``U = PD1, W = PD2``, the first seed
   in the most central anisotropic triangle. The labels are global (PD1 is the direction of the larger curvature
   everywhere but at umbilics), so the tracer runs ``labelled``: a line never swaps into the other family (on
   mixed surfaces such as the wave sample, whose flat-point umbilics carry closed curvature lines around them,
   swapping mixed both families into one set and left crossings without nodes). Line ends stopped by the
   Jobard–Lefer separation test (half a panel) are then run on until a quarter panel from the next line
   (``EXTEND_RATIO``), which removes most interior T-junctions where lines converge, and
4. **skips** the umbilic regions (``umbilic="skip"``, the default): every polyline is cut where it enters one,
   pieces shorter than half a panel are dropped; or **fills** them (``umbilic="fill"``, the strategy's choice): every
   direction is principal on an umbilic or flat region, so the field there is the smoothest line field continuing
   the principal directions around it (:func:`filled_directions`) and the lines run on through it, leaving no hole
   in the network. What was done is said in ``warnings``; a surface that is umbilic almost everywhere (a sphere or
   plane patch) is refused with a clear error, since it has no curvature network to continue.

Array-level: :func:`principal_field`, :func:`filled_directions`, :func:`principal_network`,
:func:`principal_angle_error`, :func:`surface_index` (the design surface's closest-point index, built once for the
strategy's steps). Published:
:func:`curvature_network`.

References
----------
Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*, SIGGRAPH 2006.
Alliez, Cohen-Steiner, Devillers, Lévy, Desbrun, *Anisotropic polygonal remeshing*, SIGGRAPH 2003.
Jobard, Lefer, *Creating evenly-spaced streamlines of arbitrary density*, Visualization in Scientific Computing 1997.
"""
from __future__ import annotations

import inspect
import logging
from typing import Callable, NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from components.core.blas import single_blas_thread
from components.core.checks import check_choice, check_int, check_mesh, check_number
from components.core.conformal import cached_boundary_loops
from components.core.memo import ContentCache, digest
from components.core.curvature import face_principal_curvature, vertex_principal_curvature
from components.core.errors import InputError, MeshError
from components.core.mesh import edge_topology, triangulate
from components.core.proximity import TriangleIndex
from components.core.types import Curves, Integers, Mesh
from components.fields.frames import dual_graph, face_frames, from_complex, to_complex
from components.fields.parametrize import check_target_fits
from components.fields.streamlines import evenly_spaced_streamlines

log = logging.getLogger(__name__)

__all__ = [
    "AngleError",
    "CurvatureNetworkResult",
    "Network",
    "PrincipalField",
    "curvature_network",
    "filled_directions",
    "network_for_mesh",
    "principal_angle_error",
    "principal_field",
    "principal_network",
    "surface_index",
]

UMBILIC_MODES = ("skip", "fill")
UMBILIC_REFUSAL = "the surface is umbilic or flat almost everywhere"  # how the refusal below starts
UMBILIC_ONLY = 0.9  # refuse surfaces whose umbilic area share is above this
EXTEND_RATIO = 0.25  # separation-stopped line ends continue until a quarter panel from the next line


class PrincipalField(NamedTuple):
    """Per-triangle principal directions and the umbilic mask (see :func:`principal_field`)."""

    PD1: np.ndarray  # (t, 3) unit direction of maximal curvature
    PD2: np.ndarray  # (t, 3) unit direction of minimal curvature
    k1: np.ndarray  # (t,)
    k2: np.ndarray  # (t,)
    anisotropy: np.ndarray  # (t,) |k1 − k2| / (|k1| + |k2| + κ0), in [0, 1)
    umbilic: np.ndarray  # (t,) bool, anisotropy below the threshold


_INDEX = ContentCache("network surface indexes")  # the last surface index built (surface_index)


def surface_index(V: np.ndarray, T: np.ndarray) -> TriangleIndex:
    """The closest-point index (:class:`components.core.proximity.TriangleIndex`) of a triangle mesh; the last one
    built is kept (by the digest of the arrays), so the steps of the strategy that query the same design surface
    (network, rebuild, judging) build it once.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("saddle", 8)
    >>> surface_index(V, T) is surface_index(V.copy(), T.copy())
    True
    """
    V = np.ascontiguousarray(V, np.float64)
    T = np.ascontiguousarray(T, np.int64)
    return _INDEX.get(digest(V, T), lambda: TriangleIndex(V, T))


def principal_field(V: np.ndarray, T: np.ndarray, umbilic_threshold: float = 0.05, radius: int = 2) -> PrincipalField:
    """Principal directions per triangle, the curvature anisotropy and the umbilic triangles.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented.
    umbilic_threshold : float
        Triangles with anisotropy below this are umbilic (directions undefined).
    radius : int
        Ring radius of the curvature fit.

    Returns
    -------
    PrincipalField

    Notes
    -----
    The anisotropy ``|k1 − k2| / (|k1| + |k2| + κ0)`` with ``κ0`` one tenth of the median ``|k1| + |k2|`` is 1 on a
    saddle (``k1 k2 < 0``) away from flat spots, tends to 0 at umbilics and at flat points.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("saddle", 16)
    >>> bool(principal_field(V, T).umbilic.any())
    False
    """
    V = np.asarray(V, np.float64)
    T = np.asarray(T, np.int64)
    pc = vertex_principal_curvature(V, T, radius=radius)
    FD1, FD2, k1, k2 = face_principal_curvature(V, T, *pc)
    tot = np.abs(k1) + np.abs(k2)
    k0 = 0.1 * float(np.median(tot)) + 1e-300
    an = np.abs(k1 - k2) / (tot + k0)
    return PrincipalField(FD1, FD2, k1, k2, an, an < umbilic_threshold)


class Network(NamedTuple):
    """A curvature line network (see :func:`principal_network`)."""

    lines_1: list  # polylines (k, 3) along PD1 (maximal curvature)
    lines_2: list  # polylines (k, 3) along PD2 (minimal curvature)
    field: PrincipalField
    umbilic_fraction: float  # area share of umbilic triangles
    cut: int  # polylines cut where they entered an umbilic region
    warnings: list


def _polylines(out) -> list[np.ndarray]:
    """Polylines from a tracer's result: a list of (k, 3) arrays, or a NamedTuple carrying one."""
    if hasattr(out, "_fields"):
        for name in ("lines", "polylines", "streamlines", "curves"):
            if name in out._fields:
                out = getattr(out, name)
                break
        else:
            out = out[0]
    lines = []
    for L in out:
        L = np.asarray(L, np.float64)
        if L.ndim == 2 and L.shape[1] == 3 and len(L) >= 2:
            lines.append(L)
    return lines


def _tracer_options(tracer, V, T, fld, h) -> dict:
    """Keyword options the tracer accepts: a first seed in the most central anisotropic triangle, the shortest
    line kept (half a panel)."""
    try:
        params = inspect.signature(tracer).parameters
    except (TypeError, ValueError):
        return {}
    out = {}
    if "seeds" in params and (~fld.umbilic).any():
        cen = V[T].mean(axis=1)
        ok = np.flatnonzero(~fld.umbilic)
        i = ok[np.argmin(np.linalg.norm(cen[ok] - V.mean(axis=0), axis=1) / (0.5 + fld.anisotropy[ok]))]
        out["seeds"] = (np.array([i]), np.full((1, 3), 1.0 / 3.0))  # its centroid (face, barycentric: no search)
    if "min_length" in params:
        out["min_length"] = 0.5 * h
    if "labelled" in params:  # PD1/PD2 are ordered by curvature: a global labelling, no family swaps
        out["labelled"] = True
    if "extend_ratio" in params:  # line ends stopped by the separation test run on to a quarter panel
        out["extend_ratio"] = EXTEND_RATIO
    return out


def filled_directions(V: np.ndarray, T: np.ndarray, fld: PrincipalField) -> tuple[np.ndarray, np.ndarray]:
    """Principal directions with the umbilic regions filled: ``(U, W)`` per triangle, ``U = PD1`` and ``W = PD2``
    where the surface is anisotropic, the smoothest line field that meets them (harmonic in the Levi-Civita
    connection, a line field is a direction up to sign) in the umbilic triangles, ``W = n × U``.

    On an umbilic or flat region every tangent direction is principal (and every orthogonal net conjugate), so lines
    of the filled field are curvature lines there too; the fill only chooses the smoothest continuation of the
    network across the region. A region with no anisotropic triangle in its component keeps its (noisy) principal
    directions.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented, edge-manifold.
    fld : PrincipalField
        The principal field and its umbilic mask (:func:`principal_field`).

    Returns
    -------
    U, W : (t, 3) float64
        Unit tangent directions per triangle, orthogonal to each other.

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("dome", 16)
    >>> fld = principal_field(V, T)
    >>> U, W = filled_directions(V, T, fld)
    >>> bool(np.allclose(U[~fld.umbilic], fld.PD1[~fld.umbilic])), bool(np.allclose(np.sum(U * W, axis=1), 0.0))
    (True, True)
    """
    um = np.asarray(fld.umbilic, bool)
    U, W = fld.PD1.copy(), fld.PD2.copy()
    if not um.any() or um.all():
        return U, W
    fr = face_frames(V, T)
    dg = dual_graph(V, T, fr)
    m = len(T)
    z = to_complex(fld.PD1, fr)
    z = (z / np.maximum(np.abs(z), 1e-300)) ** 2  # a line: the direction's angle doubled
    rho = np.exp(2j * dg.kappa)
    w = dg.weight.astype(complex)
    L = sp.csr_matrix((np.concatenate([w, w, -w * rho, -w * np.conj(rho)]),
                       (np.concatenate([dg.f, dg.g, dg.g, dg.f]), np.concatenate([dg.f, dg.g, dg.f, dg.g]))),
                      shape=(m, m))
    free = np.flatnonzero(um)
    fixed = np.flatnonzero(~um)
    A = L[free][:, free].tocsc()
    b = -(L[free][:, fixed] @ z[fixed])
    # components of the free faces not touching a fixed one have a singular block: a tiny shift keeps them at 0
    A = A + sp.identity(len(free), format="csc") * (1e-9 * float(np.abs(A.diagonal()).mean() or 1.0))
    zf = np.asarray(spsolve(A, b)).reshape(-1)
    ok = np.abs(zf) > 1e-6
    d = np.sqrt(zf[ok] / np.abs(zf[ok]))
    Uf = from_complex(d, fr, free[ok])
    U[free[ok]] = Uf
    W[free[ok]] = np.cross(fr.n[free[ok]], Uf)
    return U, W


def _cut_umbilic(V, T, lines, umbilic, min_length):
    """Split polylines where they run through umbilic triangles; drop pieces shorter than ``min_length``."""
    if not umbilic.any() or not lines:
        return lines, 0
    P = np.concatenate(lines)
    inside = umbilic[surface_index(V, T).query(P).faces]
    out, ncut, start = [], 0, 0
    for L in lines:
        bad = inside[start:start + len(L)]
        start += len(L)
        if not bad.any():
            out.append(L)
            continue
        ncut += 1
        good = ~bad
        edges = np.flatnonzero(np.diff(np.r_[0, good.astype(np.int8), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            piece = L[a:b]
            if len(piece) >= 2 and np.linalg.norm(np.diff(piece, axis=0), axis=1).sum() >= min_length:
                out.append(piece)
    return out, ncut


@single_blas_thread()  # sparse factorizations: see components.core.blas
def principal_network(V: np.ndarray, T: np.ndarray, panel_size: float, umbilic_threshold: float = 0.05,
                      radius: int = 2, tracer: Callable | None = None, umbilic: str = "skip") -> Network:
    """Both families of principal curvature lines at an even spacing, umbilic regions skipped (or filled).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    T : (t, 3) int64
        Triangles, consistently oriented.
    panel_size : float
        Spacing of neighbouring lines of one family, model units.
    umbilic_threshold : float
        Anisotropy below which a triangle is umbilic (see :func:`principal_field`).
    radius : int
        Ring radius of the curvature fit.
    tracer : callable, optional
        ``tracer(V, T, U, W, family, separation, [seeds=(faces, barycentric), min_length=]) -> list of (k, 3)
        polylines``; default the project's :func:`components.fields.streamlines.evenly_spaced_streamlines`.
    umbilic : {"skip", "fill"}
        ``"skip"``: no line is seeded in an umbilic region and lines are cut where they enter one; ``"fill"``: the
        umbilic regions get the smoothest continuation of the principal directions around them
        (:func:`filled_directions`, every direction is principal there) and the lines run on through them.

    Returns
    -------
    Network

    Raises
    ------
    InputError
        Non-positive panel size; a surface that is umbilic (or flat) almost everywhere (named ``mesh``).
    """
    V = np.asarray(V, np.float64)
    T = np.asarray(T, np.int64)
    h = check_number(panel_size, "panel_size", 0, above=True)
    check_choice(umbilic, "umbilic", UMBILIC_MODES)
    warnings: list[str] = []
    fld = principal_field(V, T, umbilic_threshold=umbilic_threshold, radius=radius)
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1)
    frac = float(area[fld.umbilic].sum() / max(area.sum(), 1e-300))
    if frac > UMBILIC_ONLY:
        raise InputError("mesh", f"{UMBILIC_REFUSAL} ({100 * frac:.0f}% of its area has "
                                 f"curvature anisotropy below {umbilic_threshold:g}; a sphere or plane patch): its "
                                 "principal directions are undefined, so it has no curvature network")
    if tracer is None:
        tracer = evenly_spaced_streamlines
    fill = umbilic == "fill" and frac > 0
    U, W = filled_directions(V, T, fld) if fill else (fld.PD1, fld.PD2)
    kwargs = _tracer_options(tracer, V, T, fld, h)
    fams, ncut = [], 0
    for family in (0, 1):
        lines = _polylines(tracer(V, T, U, W, family, h, **kwargs))
        if not fill:
            lines, c = _cut_umbilic(V, T, lines, fld.umbilic, 0.5 * h)
            ncut += c
        fams.append(lines)
    if fill:
        warnings.append(f"umbilic regions ({100 * frac:.1f}% of the area, anisotropy < {umbilic_threshold:g}; every "
                        "direction is principal there) were crossed along the smoothest continuation of the "
                        "principal directions around them")
    elif frac > 0:
        warnings.append(f"umbilic regions ({100 * frac:.1f}% of the area, anisotropy < {umbilic_threshold:g}) were "
                        f"skipped: no lines were seeded there and {ncut} line(s) were cut where they entered them")
    if not fams[0] or not fams[1]:
        warnings.append(f"the network has {len(fams[0])} and {len(fams[1])} lines: panel size {h:g} is too large "
                        "for the surface")
    return Network(fams[0], fams[1], fld, frac, ncut, warnings)


def network_for_mesh(mesh, panel_size, umbilic_threshold: float = 0.05, radius: int = 2, tracer=None,
                     umbilic: str = "skip", check_fit: bool = True):
    """Validate a ``(V, F)`` surface (triangulated) and trace its network: ``(V, T, Network)``. ``check_fit``: refuse
    a panel size larger than the surface or giving more than about two million panels, naming ``panel_size`` (a
    caller working in other units checks the size as given first)."""
    V, F = check_mesh(mesh, "mesh")
    check_number(panel_size, "panel_size", 0, above=True)
    t = check_number(umbilic_threshold, "umbilic_threshold", 0)
    if t >= 1:
        raise InputError("umbilic_threshold", f"must be below 1, got {umbilic_threshold!r}")
    T = triangulate(F)[0] if F.shape[1] != 3 else F
    if check_fit:
        check_target_fits(V, T, float(panel_size), "panel_size")
    if not cached_boundary_loops(T):
        raise MeshError("mesh", "the surface is closed (no boundary): the curvature network is rebuilt in a disk "
                                "parametrization, so cut the surface open first")
    return V, T, principal_network(V, T, panel_size, umbilic_threshold, radius, tracer, umbilic)


class AngleError(NamedTuple):
    """Angles between mesh edges and the principal directions (see :func:`principal_angle_error`)."""

    angle: np.ndarray  # (e,) degrees, in [0, 45]
    away: np.ndarray  # (e,) bool, the edge's midpoint is away from umbilic regions
    mean: float
    mean_away_from_umbilics: float


def principal_angle_error(Vq: np.ndarray, Fq: np.ndarray, V: np.ndarray, T: np.ndarray, net_or_field,
                          away_factor: float = 2.0) -> AngleError:
    """Angle between every edge of a mesh and the nearest principal direction of the surface under it.

    Parameters
    ----------
    Vq : (q, 3) float64
        Mesh (candidate) vertices.
    Fq : (m, k) int64
        Its faces.
    V : (n, 3) float64
        The surface's vertices.
    T : (t, 3) int64
        The surface's triangles.
    net_or_field : Network or PrincipalField
        Principal directions and umbilic data of the surface.
    away_factor : float
        An edge is "away from umbilics" when the anisotropy under its midpoint is at least ``away_factor`` times
        the smallest non-umbilic anisotropy used (the umbilic threshold), i.e. its triangle and its neighbourhood
        are clearly anisotropic.

    Returns
    -------
    AngleError
        Per-edge angles in degrees (edge projected into the tangent plane), the mask of edges away from umbilics
        and the two means (the second is the first when no edge is away from umbilics).
    """
    fld = net_or_field.field if hasattr(net_or_field, "field") else net_or_field
    E = edge_topology(Fq).E
    mid = 0.5 * (Vq[E[:, 0]] + Vq[E[:, 1]])
    f = surface_index(V, T).query(mid).faces
    d = Vq[E[:, 1]] - Vq[E[:, 0]]
    N = np.cross(fld.PD1[f], fld.PD2[f])
    d = d - np.einsum("ij,ij->i", d, N)[:, None] * N
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    c1 = np.abs(np.einsum("ij,ij->i", d, fld.PD1[f]))
    c2 = np.abs(np.einsum("ij,ij->i", d, fld.PD2[f]))
    ang = np.degrees(np.arccos(np.clip(np.maximum(c1, c2), 0.0, 1.0)))
    thr = float(fld.anisotropy[fld.umbilic].max()) if fld.umbilic.any() else 0.0
    away = fld.anisotropy[f] >= max(away_factor * thr, 1e-12)
    mean = float(ang.mean()) if len(ang) else 0.0
    # no edge away from umbilics (an umbilic or flat surface): the mean over all edges, never NaN
    return AngleError(ang, away, mean, float(ang[away].mean()) if away.any() else mean)


# ----------------------------------------------------------------------------------------------
# published component


class CurvatureNetworkResult(NamedTuple):
    lines_1: Curves
    lines_2: Curves
    count_1: int
    count_2: int
    umbilic_faces: Integers
    umbilic_fraction: float
    warnings: list[str]


def curvature_network(mesh: Mesh, panel_size: float, umbilic_threshold: float = 0.05,
                      radius: int = 2) -> CurvatureNetworkResult:
    """Principal curvature line network of a surface: both families traced at an even spacing.

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``, a triangle (or polygon) mesh with a boundary.
    panel_size : float
        Spacing between neighbouring lines of one family, in model units.
    umbilic_threshold : float
        Curvature anisotropy ``|k1 − k2| / (|k1| + |k2| + κ0)`` below which a region counts as umbilic: no lines
        are seeded there and lines entering it are cut.
    radius : int
        Ring radius of the curvature fit (larger smooths more).

    Returns
    -------
    lines_1 : Curves
        Lines of maximal curvature (polylines on the surface).
    lines_2 : Curves
        Lines of minimal curvature.
    count_1 : int
        Number of lines of maximal curvature.
    count_2 : int
        Number of lines of minimal curvature.
    umbilic_faces : Integers
        Triangles of the (triangulated) surface in umbilic regions.
    umbilic_fraction : float
        Area share of the umbilic regions.

    Raises
    ------
    MeshError
        Malformed or closed mesh (named ``mesh``).
    InputError
        Non-positive panel size, threshold out of ``[0, 1)``; a surface umbilic almost everywhere (sphere or
        plane patch).

    Notes
    -----
    Liu et al., *Geometric modeling with conical meshes and developable surfaces*, SIGGRAPH 2006; Alliez et al.,
    *Anisotropic polygonal remeshing*, SIGGRAPH 2003; Jobard & Lefer 1997 (evenly spaced streamlines).

    Example
    -------
    >>> from components.surfaces.samples import sample_mesh
    >>> V, T, _ = sample_mesh("saddle", 24)
    >>> res = curvature_network((V, T), panel_size=3.0)
    >>> res.count_1 > 3 and res.count_2 > 3
    True
    """
    radius = check_int(radius, "radius", 1, 6)  # as fields/principal_curvature: a wider ring is all of the mesh
    V, T, net = network_for_mesh(mesh, panel_size, umbilic_threshold, radius)
    return CurvatureNetworkResult(
        lines_1=net.lines_1,
        lines_2=net.lines_2,
        count_1=len(net.lines_1),
        count_2=len(net.lines_2),
        umbilic_faces=np.flatnonzero(net.field.umbilic).astype(np.int64),
        umbilic_fraction=net.umbilic_fraction,
        warnings=list(net.warnings),
    )
