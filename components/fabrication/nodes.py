"""Nodes and beams: an axis at every vertex, the beam plane of every edge, its torsion, and beams to show in Rhino.

A beam of a support structure lies in the plane through its edge and the node axes at its two ends. When the two
axes are coplanar (they meet, or are parallel) that plane contains both and the beam is *torsion-free*: its two end
cuts are planar and the node is simple to build. Conical meshes have this property for their offset node axes
(Liu, Pottmann, Wallner, Yang, Wang 2006; Pottmann, Liu, Wallner, Bobenko, Wang 2007); other planar-quad meshes in
general do not, and the *torsion*, the angle between the two axes' planes through the edge, says by how much.

Array-level functions: :func:`support_axes`, :func:`beam_frames`, :func:`beam_meshes`. Published component:
:func:`nodes` (``fabrication/nodes``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.conical.cones import conical_check, face_offset
from components.core.checks import check_choice, check_length
from components.core.measures import cross, dot, face_data, least_squares_planes, norm, quad_planarity, unit
from components.core.mesh import bounding_box_diagonal, edge_topology, face_corners
from components.core.types import Lines, Mesh, Meshes, Numbers, Plane, Vectors
from components.fabrication.panels import Planes, checked_panelling, outward_sign, unwelded_warning

__all__ = ["AXES", "SupportAxes", "BeamFrames", "NodesResult", "support_axes", "beam_frames", "beam_meshes",
           "nodes"]

#: node axis constructions of :func:`support_axes`
AXES = ("auto", "offset", "normals")


class SupportAxes(NamedTuple):
    """Result of :func:`support_axes`."""

    axes: np.ndarray  # (n, 3) unit node axes, to the outside (0 for vertices used by no face)
    method: str  # "offset" or "normals"
    conical: bool  # the mesh passed components.conical.cones.conical_check


def support_axes(V, F, method: str = "auto", orientation: float | None = None) -> SupportAxes:
    """The node axis of every vertex: from the face offset of a conical mesh, else the mean face normal.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces, consistently oriented.
    method : {"auto", "offset", "normals"}
        ``"offset"``: the direction from every vertex to its offset at a constant face distance
        (:func:`components.conical.cones.face_offset`); ``"normals"``: the normalized sum of the unit normals
        of the faces at the vertex; ``"auto"``: ``"offset"`` when the mesh is conical
        (:func:`components.conical.cones.conical_check` at 1e-4 and quad planarity within 1e-4), else
        ``"normals"``.
    orientation : float, optional
        ``+1`` when the faces' order points to the outside, ``-1`` otherwise; default
        :func:`components.fabrication.panels.outward_sign`.

    Returns
    -------
    SupportAxes
        Unit axes pointing to the outside, the construction used and the conical verdict.

    Notes
    -----
    The face offset of a conical mesh moves every face plane by the same distance; the offset vertex lies on the
    node (cone) axis, and the axes at the two ends of every edge are coplanar (Liu et al. 2006, §3). The offset is
    taken at 100 mean edge lengths: the offset points move linearly with the distance along the node axes, while
    what a face that is planar only to rounding adds does not grow with it, so a far offset gives the axes'
    directions most exactly (an optimized conical mesh of planarity 1e-10 then has torsions near 5e-10 rad). The
    mean face normal is the usual node axis of a general mesh; its beams are twisted.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> sa = support_axes(*quad_grid(2, 2))
    >>> sa.method, sa.axes[4].tolist()
    ('offset', [0.0, 0.0, 1.0])
    """
    check_choice(method, "axes", AXES)
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sigma = outward_sign(V, F) if orientation is None else (1.0 if orientation >= 0 else -1.0)
    chk = conical_check(V, F, 1e-4)
    conical = bool(chk.passed.all()) and float(quad_planarity(V, F).max(initial=0.0)) <= 1e-4
    use = ("offset" if conical else "normals") if method == "auto" else method
    Vc = V - 0.5 * (V.min(axis=0) + V.max(axis=0))
    if use == "offset":
        E = edge_topology(F).E
        d = 100.0 * float(norm(Vc[E[:, 1]] - Vc[E[:, 0]]).mean()) if len(E) else 1.0
        A = unit(face_offset(Vc, F, d).V - Vc)
    else:
        _, N, _ = least_squares_planes(face_data(Vc, F), np.arange(len(F)))
        C = face_corners(F)
        S = np.zeros_like(V)
        np.add.at(S, C.v, N[C.face])
        A = unit(S)
    return SupportAxes(sigma * A, use, conical)


class BeamFrames(NamedTuple):
    """Result of :func:`beam_frames` for the ``e`` edges ``E``."""

    E: np.ndarray  # (e, 2) int64 edges (components.core.mesh.edge_topology order)
    direction: np.ndarray  # (e, 3) unit edge direction E[:, 0] → E[:, 1]
    normal: np.ndarray  # (e, 3) unit normal of the beam plane (the bisector of the two axes' planes)
    torsion: np.ndarray  # (e,) signed angle between the planes through the edge and each end's axis, degrees


def beam_frames(V, F, axes) -> BeamFrames:
    """The beam plane and the torsion of every edge for given node axes.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces.
    axes : (n, 3) float64
        Unit node axes (e.g. :func:`support_axes`).

    Returns
    -------
    BeamFrames
        Per edge ``(i, j)``: with ``t`` the unit edge direction, ``m_i = unit(t × a_i)`` and ``m_j = unit(t × a_j)``
        are the normals of the planes through the edge and each axis; the torsion is the angle from ``m_i`` to
        ``m_j`` about ``t`` (``atan2((m_i × m_j)·t, m_i·m_j)``, degrees; 0 when the axes are coplanar) and the
        beam plane's normal is ``unit(m_i + m_j)``.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(1, 1)
    >>> A = np.array([[0, 0, 1.0], [0, 0, 1.0], [0.6, 0, 0.8], [0, 0, 1.0]])
    >>> np.round(beam_frames(V, Q, A).torsion, 6).tolist()   # edges (0,1), (0,2), (1,3), (2,3); axis 2 tilted
    [0.0, 36.869898, 0.0, 0.0]
    """
    V = np.asarray(V, dtype=np.float64)
    A = np.asarray(axes, dtype=np.float64)
    E = edge_topology(np.asarray(F, dtype=np.int64)).E
    t = unit(V[E[:, 1]] - V[E[:, 0]])
    mi = unit(cross(t, A[E[:, 0]]))
    mj = unit(cross(t, A[E[:, 1]]))
    tors = np.degrees(np.arctan2(dot(cross(mi, mj), t), dot(mi, mj)))
    return BeamFrames(E, t, unit(mi + mj), tors)


def beam_meshes(V, frames: BeamFrames, axes, height: float, width: float) -> list:
    """A box mesh for every beam: ``height`` deep along the node axes (to the inside), ``width`` thick about the
    beam plane.

    Returns
    -------
    list of (V (8, 3), F (6, 4))
        One closed, outward-oriented box per edge: its top is the edge, its sides run down the node axes projected
        into the beam plane (exactly the axes when the beam is torsion-free).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(1, 1); A = np.tile([0.0, 0.0, 1.0], (4, 1))
    >>> Vb, Fb = beam_meshes(V, beam_frames(V, Q, A), A, 0.2, 0.05)[0]
    >>> Vb.shape, Fb.shape, float(Vb[:, 2].min())
    ((8, 3), (6, 4), -0.2)
    """
    V = np.asarray(V, dtype=np.float64)
    A = np.asarray(axes, dtype=np.float64)
    E, n = frames.E, frames.normal
    bi = unit(A[E[:, 0]] - dot(A[E[:, 0]], n)[:, None] * n)
    bj = unit(A[E[:, 1]] - dot(A[E[:, 1]], n)[:, None] * n)
    P = np.stack([V[E[:, 0]], V[E[:, 1]], V[E[:, 1]] - height * bj, V[E[:, 0]] - height * bi], axis=1)  # (e, 4, 3)
    w = 0.5 * width * n[:, None, :]
    B = np.concatenate([P - w, P + w], axis=1)  # (e, 8, 3)
    faces = np.array([[0, 1, 2, 3], [4, 7, 6, 5], [1, 0, 4, 5], [2, 1, 5, 6], [3, 2, 6, 7], [0, 3, 7, 4]],
                     dtype=np.int64)
    return [(b, faces.copy()) for b in B]


class NodesResult(NamedTuple):
    node_axes: Lines
    axes: Vectors
    edges: Lines
    torsion: Numbers
    max_torsion: float
    mean_torsion: float
    beam_planes: Planes
    beams: Meshes
    axis_method: str
    is_conical: bool
    warnings: list[str]


def nodes(mesh: Mesh, beam_height: float = 0.0, beam_width: float = 0.0, axes: str = "auto") -> NodesResult:
    """Node axes, beam planes, torsion and beams of a panelling's support structure.

    Parameters
    ----------
    mesh : Mesh
        The panelling ``(V, F)``, consistently oriented.
    beam_height : float
        Depth of the beams along the node axes, to the inside, in model units; 0: 0.2 × the mean edge length.
    beam_width : float
        Thickness of the beams across their plane, in model units; 0: 0.05 × the mean edge length.
    axes : str
        Node axes: ``"auto"`` (the face-offset construction where the mesh is conical, else the mean face normal),
        ``"offset"`` or ``"normals"``.

    Returns
    -------
    node_axes : Lines
        The node axis at every vertex, from the vertex one beam height to the inside.
    axes : Vectors
        Unit node axis at every vertex, pointing to the outside.
    edges : Lines
        Every edge of the mesh (the beams' top lines), in the order of the torsion.
    torsion : Numbers
        Per edge the angle between the planes through the edge and each end's node axis (degrees, unsigned; 0 for
        a torsion-free beam).
    max_torsion : float
        Largest torsion (degrees).
    mean_torsion : float
        Mean torsion (degrees).
    beam_planes : Planes
        Per edge the beam plane: origin the edge's midpoint, x along the edge, y along the axes, z its normal.
    beams : Meshes
        Per edge a box of the beam height and width in its beam plane, for display.
    axis_method : str
        The node axes used: ``"offset"`` or ``"normals"``.
    is_conical : bool
        The mesh is conical (its offset node axes give torsion-free beams).

    Raises
    ------
    MeshError
        Malformed mesh (named ``mesh``).
    InputError
        Negative beam height or width, unknown ``axes``.

    Notes
    -----
    Liu, Pottmann, Wallner, Yang, Wang, *Geometric modeling with conical meshes and developable surfaces*,
    SIGGRAPH 2006; Pottmann, Liu, Wallner, Bobenko, Wang, *Geometry of multi-layer freeform structures for
    architecture*, SIGGRAPH 2007: conical meshes have offset node axes that make every beam torsion-free.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = nodes(quad_grid(2, 2))
    >>> res.axis_method, res.max_torsion, len(res.beams)
    ('offset', 0.0, 12)
    """
    V, F, unwelded = checked_panelling(mesh)
    size = bounding_box_diagonal(V)
    h = check_length(beam_height, "beam_height", size, 0)
    w = check_length(beam_width, "beam_width", size, 0)
    check_choice(axes, "axes", AXES)
    sa = support_axes(V, F, axes)
    fr = beam_frames(V, F, sa.axes)
    L = norm(V[fr.E[:, 1]] - V[fr.E[:, 0]])
    mean_edge = float(L.mean()) if len(L) else 1.0
    h = h if h > 0 else 0.2 * mean_edge
    w = w if w > 0 else 0.05 * mean_edge
    tors = np.abs(fr.torsion)
    warnings = unwelded_warning(unwelded)
    if axes == "offset" and not sa.conical:
        warnings.append("the mesh is not conical: its offset node axes are not coplanar along every edge")
    mid = 0.5 * (V[fr.E[:, 0]] + V[fr.E[:, 1]])
    ydir = cross(fr.normal, fr.direction)
    planes = [Plane(o, x, y, z) for o, x, y, z in zip(mid, fr.direction, ydir, fr.normal)]
    return NodesResult(
        node_axes=np.stack([V, V - h * sa.axes], axis=1),
        axes=sa.axes,
        edges=np.stack([V[fr.E[:, 0]], V[fr.E[:, 1]]], axis=1),
        torsion=tors,
        max_torsion=float(tors.max(initial=0.0)),
        mean_torsion=float(tors.mean()) if len(tors) else 0.0,
        beam_planes=planes,
        beams=beam_meshes(V, fr, sa.axes, h, w),
        axis_method=sa.method,
        is_conical=sa.conical,
        warnings=warnings,
    )
