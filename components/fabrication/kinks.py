"""Kinks: the dihedral angle at every joint between two panels.

Array-level function: :func:`dihedral_angles`. Published component: :func:`kinks` (``fabrication/kinks``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.core.checks import check_number
from components.core.measures import cross, dot, face_data, least_squares_planes, norm
from components.core.mesh import edge_topology, halfedges
from components.core.types import Integers, Lines, Mesh, Numbers
from components.fabrication.panels import checked_panelling, outward_sign, unwelded_warning

__all__ = ["Dihedrals", "KinksResult", "dihedral_angles", "panel_kinks", "kinks"]


class Dihedrals(NamedTuple):
    """Result of :func:`dihedral_angles` for the ``e`` edges of :func:`components.core.mesh.edge_topology`."""

    E: np.ndarray  # (e, 2) int64 edges
    EF: np.ndarray  # (e, 2) int64 their faces (-1 for none)
    interior: np.ndarray  # (e,) bool, edges with two faces
    angle: np.ndarray  # (e,) degrees between the two face planes' normals, 0 = flat; NaN on boundary edges
    signed: np.ndarray  # (e,) the same, positive at a ridge seen from the outside, negative at a valley; NaN
    HE: np.ndarray  # (h,) edge of every half-edge (components.core.mesh.halfedges order)


def dihedral_angles(V, F, orientation: float | None = None) -> Dihedrals:
    """Dihedral (kink) angle at every edge: the angle between the planes of its two faces, 0 when they are flush.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces, consistently oriented.
    orientation : float, optional
        ``+1`` when the faces' order points to the outside, ``-1`` otherwise (the sign of ``signed``); default
        :func:`components.fabrication.panels.outward_sign`.

    Returns
    -------
    Dihedrals
        Per edge the unsigned angle (degrees) between the unit normals of the two faces' least-squares planes,
        ``atan2(|n1 × n2|, n1 · n2)``, and the signed one (positive where the surface turns away from its outside,
        a ridge); NaN on boundary edges.

    Notes
    -----
    The angle is the one a joint between two flat panels has to take up (0 for a flat continuation, the exterior
    angle of the polyhedron). ``atan2`` keeps small angles exact where ``acos`` of the dot product would lose them.
    Each face's normal is that of its least-squares plane, so a slightly warped panel gets one well-defined plane.

    Example
    -------
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 1], [2, 1, 1]], dtype=float)
    >>> d = dihedral_angles(V, np.array([[0, 1, 2, 3], [1, 4, 5, 2]]))
    >>> np.round(d.angle[d.interior], 9).tolist(), np.round(d.signed[d.interior], 9).tolist()
    ([45.0], [-45.0])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sigma = outward_sign(V, F) if orientation is None else (1.0 if orientation >= 0 else -1.0)
    Vc = V - 0.5 * (V.min(axis=0) + V.max(axis=0)) if len(V) else V
    fd = face_data(Vc, F)
    _, N, _ = least_squares_planes(fd, np.arange(len(F)))
    topo = edge_topology(F)
    H, HF = halfedges(F)
    interior = topo.count == 2
    e = np.nonzero(interior)[0]
    f1, f2 = topo.EF[e, 0], topo.EF[e, 1]
    # the edge's direction as it runs in its first face
    first = np.full(len(topo.E), -1, dtype=np.int64)
    first[topo.HE[::-1]] = np.arange(len(H))[::-1]
    d = Vc[H[first[e], 1]] - Vc[H[first[e], 0]]
    n1, n2 = N[f1], N[f2]
    c = cross(n1, n2)
    ang = np.degrees(np.arctan2(norm(c), dot(n1, n2)))
    L = norm(d)
    sgn = np.where(dot(c, d) * sigma >= 0, 1.0, -1.0)
    sgn = np.where(L > 0, sgn, 1.0)
    angle = np.full(len(topo.E), np.nan)
    signed = np.full(len(topo.E), np.nan)
    angle[e] = ang
    signed[e] = sgn * ang
    return Dihedrals(topo.E, topo.EF, interior, angle, signed, topo.HE)


def panel_kinks(F, dihedrals: Dihedrals, signed: bool = False) -> np.ndarray:
    """The kink at every edge of every panel: ``(m, k)`` degrees, edge i from corner i to i+1 (NaN on the boundary
    and on padding); ``signed``: positive at a ridge seen from the outside, negative at a valley.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(2, 1)
    >>> panel_kinks(Q, dihedral_angles(V, Q))[0].tolist()
    [nan, 0.0, nan, nan]
    """
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    _, HF = halfedges(F)
    out = np.full((m, k), np.nan)
    sizes = np.bincount(HF, minlength=m)
    slot = np.arange(len(HF)) - np.r_[0, np.cumsum(sizes)[:-1]][HF]
    out[HF, slot] = dihedrals.signed[dihedrals.HE]
    return out if signed else np.abs(out)


class KinksResult(NamedTuple):
    kinks: Numbers
    signed_kinks: Numbers
    edges: Lines
    max_kink: float
    mean_kink: float
    over_limit: Integers
    over_count: int
    warnings: list[str]


def kinks(mesh: Mesh, limit: float = 10.0) -> KinksResult:
    """Kink angle at every joint: the dihedral angle between neighbouring panels, and the joints over a limit.

    Parameters
    ----------
    mesh : Mesh
        The panelling ``(V, F)``, consistently oriented.
    limit : float
        Largest kink (degrees) the joint detail takes; joints over it are listed.

    Returns
    -------
    kinks : Numbers
        Kink angle at every interior edge in degrees: the angle between the two panels' planes, 0 when flush.
    signed_kinks : Numbers
        The kinks signed, in degrees: positive at a ridge (convex seen from the outside of the design surface),
        negative at a valley.
    edges : Lines
        The interior edges, in the order of the kinks.
    max_kink : float
        Largest kink (degrees).
    mean_kink : float
        Mean kink (degrees).
    over_limit : Integers
        Indices (into edges) of the joints whose kink is over the limit.
    over_count : int
        How many joints are over the limit.

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        ``limit`` negative or above 180.

    Notes
    -----
    The normal of each panel is that of its least-squares plane; the outside is chosen by
    :func:`components.fabrication.panels.outward_sign`. On a regular n-gonal prism the kink between side panels is
    360°/n.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = kinks(quad_grid(3, 3))
    >>> res.max_kink, len(res.kinks), res.over_count
    (0.0, 12, 0)
    """
    V, F, unwelded = checked_panelling(mesh)
    limit = check_number(limit, "limit", 0, 180)
    dh = dihedral_angles(V, F)
    e = np.nonzero(dh.interior)[0]
    ang = dh.angle[e]
    over = np.nonzero(ang > limit)[0]
    warnings = unwelded_warning(unwelded)
    if len(e) == 0:
        warnings.append("the mesh has no interior edge: no joint to measure")
    if len(over):
        warnings.append(f"{len(over)} joints kink more than {limit:g}° (up to {ang.max():.3g}°)")
    return KinksResult(
        kinks=ang,
        signed_kinks=dh.signed[e],
        edges=np.stack([V[dh.E[e, 0]], V[dh.E[e, 1]]], axis=1) if len(e) else np.zeros((0, 2, 3)),
        max_kink=float(ang.max()) if len(e) else 0.0,
        mean_kink=float(ang.mean()) if len(e) else 0.0,
        over_limit=over.astype(np.int64),
        over_count=int(len(over)),
        warnings=warnings,
    )
