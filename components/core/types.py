"""Value types shared by components and the server.

A published component is a plain function whose **annotations** say what each input and output is. The
server (``ghserver.registry``) maps these annotations to Grasshopper parameter kinds; Python callers just
pass arrays and tuples. Plain ``float``, ``int``, ``bool`` and ``str`` are Number, Integer, Boolean and
Text items; ``X | None = None`` marks an optional input.

=================  ==============================================  =====================
annotation         Python value                                    Grasshopper param
=================  ==============================================  =====================
``float``          float                                           Number (item)
``int``            int                                             Integer (item)
``bool``           bool                                            Boolean (item)
``str``            str                                             Text (item)
``Numbers``        (n,) float64 array                              Number (list)
``Integers``       (n,) int64 array                                Integer (list)
``Booleans``       (n,) bool array                                 Boolean (list)
``Texts``          list of str                                     Text (list)
``Point``          (3,) float64                                    Point (item)
``Points``         (n, 3) float64                                  Point (list)
``Vector``         (3,) float64                                    Vector (item)
``Vectors``        (n, 3) float64                                  Vector (list)
``Plane``          :class:`Plane`                                  Plane (item)
``Line``           (2, 3) float64 (start, end)                     Line (item)
``Lines``          (n, 2, 3) float64                               Line (list)
``Curve``          (n, 3) polyline array or :class:`NurbsCurve`    Curve (item)
``Curves``         list of Curve values                            Curve (list)
``Surface``        :class:`NurbsSurface`                           Surface (item, input only)
``Mesh``           ``(V, F)``: (n, 3) float64, (m, k) int64;       Mesh (item)
                   an output may add colours ``(V, F, C)``,
                   ``C`` (n, 3) uint8 RGB per vertex
``Meshes``         list of ``(V, F)``                              Mesh (list)
``Tree[X]``        dict ``{path tuple: list of X values}``         X with tree access
=================  ==============================================  =====================

Outputs are the fields of the returned ``NamedTuple``, annotated the same way. A field named ``warnings``
(``list[str]``) is not an output: its messages become the Hops response's ``warnings``. Parameters named
``absolute_tolerance`` (float, model units), ``angle_tolerance`` (float, radians) and ``model_units``
(str, e.g. ``"Millimeters"``) are not inputs either: the server fills them from the request.
"""
from __future__ import annotations

from typing import Annotated, Generic, NamedTuple, TypeVar

import numpy as np

# kind markers read by ghserver.registry: Annotated[<python type>, "<Kind>", "<access>"]
Numbers = Annotated[np.ndarray, "Number", "list"]
Integers = Annotated[np.ndarray, "Integer", "list"]
Booleans = Annotated[np.ndarray, "Boolean", "list"]
Texts = Annotated[list, "Text", "list"]
Point = Annotated[np.ndarray, "Point", "item"]
Points = Annotated[np.ndarray, "Point", "list"]
Vector = Annotated[np.ndarray, "Vector", "item"]
Vectors = Annotated[np.ndarray, "Vector", "list"]
Line = Annotated[np.ndarray, "Line", "item"]
Lines = Annotated[np.ndarray, "Line", "list"]
Mesh = Annotated[tuple, "Mesh", "item"]
Meshes = Annotated[list, "Mesh", "list"]

T = TypeVar("T")


class Tree(Generic[T]):
    """Marker for tree access: ``Tree[float]`` is a dict ``{(0, 1): [1.0, 2.0], ...}``."""


class Plane(NamedTuple):
    """A plane with an orthonormal frame (Rhino's ``Plane``)."""

    origin: np.ndarray  # (3,)
    xaxis: np.ndarray  # (3,)
    yaxis: np.ndarray  # (3,)
    zaxis: np.ndarray  # (3,)


class NurbsCurve(NamedTuple):
    """A NURBS curve in Rhino's convention.

    ``points`` (n, 3) control points, ``weights`` (n,), ``degree`` d, ``knots`` (n + d - 1,) (Rhino/openNURBS
    knot vectors omit the two superfluous end knots of the textbook form), ``periodic`` flag.
    """

    degree: int
    points: np.ndarray
    weights: np.ndarray
    knots: np.ndarray
    periodic: bool = False


class NurbsSurface(NamedTuple):
    """A NURBS surface in Rhino's convention.

    ``points`` (nu, nv, 3), ``weights`` (nu, nv), ``knots_u`` (nu + du - 1,), ``knots_v`` (nv + dv - 1,).
    """

    degree_u: int
    degree_v: int
    points: np.ndarray
    weights: np.ndarray
    knots_u: np.ndarray
    knots_v: np.ndarray


Curve = Annotated[object, "Curve", "item"]  # (n, 3) polyline array or NurbsCurve
Curves = Annotated[list, "Curve", "list"]
Surface = Annotated[NurbsSurface, "Surface", "item"]

CONTEXT_PARAMETERS = ("absolute_tolerance", "angle_tolerance", "model_units")
