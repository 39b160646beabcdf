"""Input handling of the planarization solver: centring, welding, zero-length edges, unwelded pieces.

The solver works on a centred copy of the mesh (the bounding-box centre subtracted before any product, added back
at the end), so that a model far from the origin (``+5e6``) loses no precision; every tolerance below is relative
to the mesh's own size. :func:`prepared_mesh` checks the mesh once, welds duplicate vertices and refuses what the
solver cannot make fabricable:

* **duplicate vertices** (an unwelded mesh, a quad soup) are welded within the request's ``absolute_tolerance``
  when one is given (at most 1 % of the median edge), else within 1e-9 × the bounding-box diagonal; a warning says
  how many. The result keeps the input's vertices and faces: welded duplicates move together.
* a face with a **zero-length edge** (two of its corners within the weld tolerance) is a :class:`MeshError` naming
  the face: as a quad it is a collapsed panel (a triangle with a fourth corner on another), its planarity is not
  defined and no guard can keep a zero edge from getting worse; the fix is the user's (weld the two corners and
  write the face as a padded triangle ``(a, b, c, c)``, which the solver keeps planar, or move them apart).
* pieces that still **touch** after welding (boundary vertices of different pieces, or of one seam, within 1 % of
  the median edge but not welded) are a :class:`MeshError` that says to weld them: planarizing the pieces apart
  would pull the touching panels open.

Example
-------
>>> from components.core.mesh import quad_grid
>>> V, F = quad_grid(2, 1)
>>> soup = np.concatenate([V[F[0]], V[F[1]]]) + 5e6  # two unwelded quads, far from the origin
>>> prep = prepared_mesh(soup, np.arange(8).reshape(2, 4))
>>> prep.F.tolist(), prep.warnings
([[0, 1, 2, 3], [1, 5, 6, 2]], ['mesh: 2 duplicate vertices were welded (within 1.41e-09, 1e-9 × the bounding-box \
diagonal); the result keeps the input vertices, welded ones moved together'])
>>> np.allclose(prep.restore(prep.V), soup)
True
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from components.core.checks import check_mesh, validate_mesh, zero_edge_error
from components.core.errors import MeshError
from components.core.mesh import WELD_FRACTION, edge_topology, face_sizes, weld_map
from components.metrics.health import TOUCH, touching_pairs

__all__ = ["WELD_FRACTION", "TOUCH_FRACTION", "Prepared", "Reference", "prepared_mesh", "centred_reference"]

_WELD_CAP = 0.01  # the request's absolute tolerance is used up to this × the median edge
TOUCH_FRACTION = TOUCH  # unwelded boundary vertices closer than this × the median edge touch


class Prepared(NamedTuple):
    """A checked, centred and welded mesh (see :func:`prepared_mesh`)."""

    V: np.ndarray  # (n, 3) vertices minus ``offset`` (the input's count; welded duplicates become unused)
    F: np.ndarray  # (m, k) faces on the welded vertices
    offset: np.ndarray  # (3,) the bounding-box centre of the input
    rep: np.ndarray | None  # (n,) welded vertex of every input vertex, None when nothing was welded
    weld_tolerance: float  # model units
    warnings: list

    def restore(self, X: np.ndarray) -> np.ndarray:
        """Model coordinates ``(n, 3)`` of centred positions ``X``, welded duplicates moved with their vertex."""
        out = X + self.offset
        if self.rep is not None:
            out = out[self.rep]
        return out


def prepared_mesh(V, F, name: str = "mesh", absolute_tolerance: float = 0.0) -> Prepared:
    """Check, centre and weld a mesh for the solver.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, k) array_like of int
        Padded polygon faces.
    name : str
        The mesh input's name in error messages.
    absolute_tolerance : float
        The request's absolute tolerance (model units); 0 for none.

    Returns
    -------
    Prepared

    Raises
    ------
    MeshError
        Malformed mesh (shape, NaN, index out of range), a face with a zero-length edge or a repeated vertex,
        pieces touching without being welded, or a mesh that is non-manifold, inconsistently oriented or has a
        zero-area face (after welding: the message says so).
    """
    V, F = validate_mesh(V, F, name=name, allow_degenerate=True, manifold=False)
    offset = 0.5 * (V.min(axis=0) + V.max(axis=0))
    X = V - offset
    used = np.zeros(len(X), dtype=bool)
    used[F.ravel()] = True
    diag = float(np.linalg.norm(X[used].max(axis=0) - X[used].min(axis=0)))
    sizes = face_sizes(F)
    median_edge = _median_edge(X, F)
    tol, how = diag * WELD_FRACTION, "1e-9 × the bounding-box diagonal"
    warnings: list[str] = []
    if absolute_tolerance > 0:
        tol, how = float(absolute_tolerance), "the absolute tolerance"
        if tol > _WELD_CAP * median_edge:
            warnings.append(f"{name}: the absolute tolerance {tol:.3g} is more than {_WELD_CAP:.0%} of the median edge "
                            f"{median_edge:.3g}; duplicate vertices were welded within {_WELD_CAP * median_edge:.3g}")
            tol, how = _WELD_CAP * median_edge, f"{_WELD_CAP:.0%} of the median edge"
    rep = weld_map(X, used, tol)
    Fw = F
    if rep is not None:
        err = zero_edge_error(X, F, sizes, rep, tol, name)
        if err is not None:
            raise err
        Fw = rep[F]
        n_welded = int(np.count_nonzero(rep[used] != np.nonzero(used)[0]))
        warnings.append(f"{name}: {n_welded} duplicate vertice{'s were' if n_welded != 1 else ' was'} welded (within "
                        f"{tol:.3g}, {how}); the result keeps the input vertices, welded ones moved together")
    try:
        X, Fw = validate_mesh(X, Fw, name=name)
    except MeshError as exc:
        if rep is None:
            raise
        raise MeshError(name, f"{exc.detail} (after welding its duplicate vertices within {tol:.3g})") from None
    _refuse_touching_pieces(X, Fw, median_edge, tol, name)
    return Prepared(X, Fw, offset, rep, tol, warnings)


class Reference(NamedTuple):
    """A checked reference mesh, as given and centred (see :func:`centred_reference`)."""

    given: tuple  # (Vr, Fr) as given (float64 / int64): what the result is judged against, in model units
    centred: tuple  # (Vr - offset, Fr): what the solver sees, centred like the prepared mesh


def centred_reference(reference, offset, name: str = "reference") -> Reference:
    """A reference mesh (a ``(Vr, Fr)`` pair) checked (zero-area faces refused, non-manifold ones allowed) and moved
    by ``-offset``. The zero-area test centres the vertices itself (no precision is lost far from the origin), so
    it runs on the arrays as given: a surface its caller checked already (the same content) is not measured again.

    Example
    -------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]) + 5e6
    >>> r = centred_reference((V, [[0, 1, 2]]), np.full(3, 5e6))
    >>> r.centred[0].tolist(), r.given[0] is r.centred[0]
    ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], False)
    """
    Vr, Fr = check_mesh(reference, name, manifold=False)
    return Reference((Vr, Fr), (Vr - offset, Fr))


def _median_edge(X, F) -> float:
    E = edge_topology(F).E
    L = np.linalg.norm(X[E[:, 1]] - X[E[:, 0]], axis=1)
    med = float(np.median(L)) if len(L) else 0.0
    return med if med > 0 else float(L.max()) if len(L) else 0.0


def _refuse_touching_pieces(X, F, median_edge, tol, name):
    """Boundary vertices closer than ``TOUCH_FRACTION × median_edge`` that share no edge are unwelded pieces."""
    reach = TOUCH_FRACTION * median_edge
    a, b = touching_pairs(X, edge_topology(F), reach).T
    if len(a) == 0:
        return
    d = np.linalg.norm(X[a] - X[b], axis=1)
    j = int(np.argmin(d))
    count = len(np.unique(np.concatenate([a, b])))
    raise MeshError(name, f"the mesh is in unwelded pieces that touch: {count} boundary vertices lie within "
                          f"{reach:.3g} ({TOUCH_FRACTION:.0%} of the median edge) of boundary vertices they are not "
                          f"welded to, e.g. vertices {int(a[j])} and {int(b[j])}, {d[j]:.3g} apart (weld tolerance "
                          f"{tol:.3g}); weld the mesh (or give an absolute_tolerance above {float(d.max()):.3g}) "
                          f"before planarizing")
