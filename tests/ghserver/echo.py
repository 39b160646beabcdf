"""Test-only components that return their inputs: every param kind and access, both ways."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.core.errors import InputError
from components.core.types import (Curve, Curves, Integers, Line, Lines, Mesh, Meshes, NurbsSurface, Numbers, Plane,
                              Point, Points, Texts, Tree, Vector, Vectors)


class Scalars(NamedTuple):
    number: float
    integer: int
    boolean: bool
    text: str


def scalars(number: float = 0.0, integer: int = 0, boolean: bool = False, text: str = "") -> Scalars:
    """Return the scalar inputs unchanged.

    Parameters
    ----------
    number : float
        A number.
    integer : int
        An integer.
    boolean : bool
        A flag.
    text : str
        Some text.

    Returns
    -------
    number : float
        The number.
    integer : int
        The integer.
    boolean : bool
        The flag.
    text : str
        The text.
    """
    return Scalars(number, integer, boolean, text)


class Geometry(NamedTuple):
    point: Point
    vector: Vector
    plane: Plane
    line: Line
    curve: Curve
    mesh: Mesh


def geometry(point: Point, vector: Vector, plane: Plane, line: Line, curve: Curve, mesh: Mesh) -> Geometry:
    """Return the geometry inputs unchanged.

    Parameters
    ----------
    point : Point
        A point.
    vector : Vector
        A vector.
    plane : Plane
        A plane.
    line : Line
        A line.
    curve : Curve
        A curve.
    mesh : Mesh
        A mesh.

    Returns
    -------
    point : Point
        The point.
    vector : Vector
        The vector.
    plane : Plane
        The plane.
    line : Line
        The line.
    curve : Curve
        The curve.
    mesh : Mesh
        The mesh.
    """
    return Geometry(point, vector, plane, line, curve, mesh)


class Lists(NamedTuple):
    numbers: Numbers
    integers: Integers
    texts: Texts
    points: Points
    vectors: Vectors
    lines: Lines
    curves: Curves
    meshes: Meshes
    count: int


def lists(numbers: Numbers, integers: Integers | None = None, texts: Texts | None = None,
          points: Points | None = None, vectors: Vectors | None = None, lines: Lines | None = None,
          curves: Curves | None = None, meshes: Meshes | None = None) -> Lists:
    """Return list inputs unchanged and the number of numbers.

    Parameters
    ----------
    numbers : Numbers
        Numbers.
    integers : Integers
        Integers.
    texts : Texts
        Texts.
    points : Points
        Points.
    vectors : Vectors
        Vectors.
    lines : Lines
        Lines.
    curves : Curves
        Curves.
    meshes : Meshes
        Meshes.

    Returns
    -------
    numbers : Numbers
        The numbers.
    integers : Integers
        The integers.
    texts : Texts
        The texts.
    points : Points
        The points.
    vectors : Vectors
        The vectors.
    lines : Lines
        The lines.
    curves : Curves
        The curves.
    meshes : Meshes
        The meshes.
    count : int
        How many numbers.
    """
    return Lists(numbers, integers, texts, points, vectors, lines, curves, meshes, len(numbers))


class SurfaceInfo(NamedTuple):
    degree_u: int
    degree_v: int
    corner: Point


def surface_info(surface: NurbsSurface) -> SurfaceInfo:
    """Degrees and first control point of a NURBS surface.

    Parameters
    ----------
    surface : NurbsSurface
        A surface.

    Returns
    -------
    degree_u : int
        Degree in u.
    degree_v : int
        Degree in v.
    corner : Point
        First control point.
    """
    return SurfaceInfo(surface.degree_u, surface.degree_v, surface.points[0, 0])


class TreeSum(NamedTuple):
    sums: Numbers
    paths: Texts


def tree_sum(tree: Tree[float]) -> TreeSum:
    """Sum every branch of a tree.

    Parameters
    ----------
    tree : Tree[float]
        Numbers in branches.

    Returns
    -------
    sums : Numbers
        One sum per branch, in path order.
    paths : Texts
        The branch paths.
    """
    keys = sorted(tree)
    return TreeSum(np.array([sum(tree[k]) for k in keys]), [";".join(map(str, k)) for k in keys])


class Scaled(NamedTuple):
    value: float
    doubled: Numbers
    warnings: list


def scale(x: float, factor: float = 2.0, absolute_tolerance: float = 0.01, model_units: str = "") -> Scaled:
    """Multiply a number, with the document tolerance as a warning.

    Parameters
    ----------
    x : float
        Value.
    factor : float
        Multiplier; must not be negative.

    Returns
    -------
    value : float
        ``x * factor``.
    doubled : Numbers
        ``[x, x * factor]``.
    """
    if factor < 0:
        raise InputError("factor", f"must not be negative, got {factor}")
    if x == 13:
        raise RuntimeError("unlucky\nsecond line of the message")
    if x == 424242.5:  # a deliberately broken output (NaN) for the output-encoding tests
        return Scaled(float("nan"), np.array([x]), [])
    if not np.isfinite(x * factor):
        raise InputError("x", f"{x!r} times {factor!r} overflows")
    return Scaled(x * factor, np.array([x, x * factor]),
                  [f"tolerance {absolute_tolerance} {model_units}".strip()])


class FooResult(NamedTuple):
    Result: Mesh
    Area: float


def foo(Mesh: Mesh, Distance: float = 1.0) -> FooResult:
    """Offset a mesh and report its area.

    The real Hops request in ``tests/data/hops/post_solve_request.json`` targets a component with exactly these
    inputs (``Mesh``, ``Distance``) and outputs (``Result``, ``Area``).

    Parameters
    ----------
    Mesh : Mesh
        Mesh to offset.
    Distance : float
        Offset distance.

    Returns
    -------
    Result : Mesh
        The mesh moved by ``Distance`` along its average face normal.
    Area : float
        Area of the mesh.
    """
    from components.core.mesh import face_normals

    V, F = Mesh
    N = face_normals(V, F, unit=False)
    n = N.sum(axis=0)
    n = n / np.linalg.norm(n)
    return FooResult((V + Distance * n, F), float(np.linalg.norm(N, axis=1).sum()))


class Process(NamedTuple):
    value: float
    pid: int


def nap(seconds: float = 0.1) -> Process:
    """Sleep, then report the process that ran the solve.

    Parameters
    ----------
    seconds : float
        How long to sleep.

    Returns
    -------
    value : float
        The seconds slept.
    pid : int
        Process id of the solver.
    """
    import os
    import time

    time.sleep(seconds)
    return Process(seconds, os.getpid())


def until_deadline(seconds: float = 60.0) -> Process:
    """Wait until the solve's deadline (components.core.deadline) has passed, at most ``seconds``.

    Parameters
    ----------
    seconds : float
        The longest wait.

    Returns
    -------
    value : float
        The seconds waited.
    pid : int
        Process id of the solver.
    """
    import os
    import time

    from components.core import deadline

    t0 = time.monotonic()
    while not deadline.expired() and time.monotonic() - t0 < seconds:
        time.sleep(0.01)
    return Process(time.monotonic() - t0, os.getpid())


def crash(how: str = "exit") -> Process:
    """Kill the solving process in one of several ways (for isolation tests).

    Parameters
    ----------
    how : str
        ``"exit"`` (hard exit), ``"segfault"``, ``"memory"`` (allocate without bound) or ``"none"``.

    Returns
    -------
    value : float
        0 when ``how`` is ``"none"``.
    pid : int
        Process id of the solver.
    """
    import ctypes
    import os

    if how == "exit":
        os._exit(3)
    if how == "segfault":
        ctypes.string_at(0)
    if how == "memory":
        blocks = []
        while True:
            blocks.append(np.empty(50_000_000))  # address space grows until the cap stops it
    return Process(0.0, os.getpid())


def spin(n: int = 3_000_000) -> Process:
    """Burn CPU in pure Python (a CPU-bound solve for load tests).

    Parameters
    ----------
    n : int
        Loop iterations.

    Returns
    -------
    value : float
        A checksum of the loop.
    pid : int
        Process id of the solver.
    """
    import os

    total = 0
    for i in range(n):
        total = (total + i * i) % 1_000_003
    return Process(float(total), os.getpid())


ECHO = [
    ("test/nap", nap),
    ("test/until_deadline", until_deadline),
    ("test/crash", crash),
    ("test/spin", spin),
    ("echo/scalars", scalars),
    ("echo/geometry", geometry),
    ("echo/lists", lists),
    ("echo/surface", surface_info),
    ("echo/tree", tree_sum),
    ("echo/scale", scale),
    ("foo", foo),
]


def registry():
    """A registry of the echo components (ranges on foo's Distance as in the real metadata)."""
    from ghserver.registry import Registry, declare

    comps = []
    for uri, fn in ECHO:
        kw = {}
        if fn is foo:
            kw = dict(nicknames={"Mesh": "M", "Distance": "D", "Result": "R", "Area": "A"},
                      ranges={"Distance": (0.0, 100.0)})
        comps.append(declare(fn, uri, **kw))
    return Registry(comps)
