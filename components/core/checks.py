"""Input checks: the one place where a failure of an input is worded.

Every check takes the value as received and the input's name, returns the value in canonical form and raises an
:class:`~components.core.errors.InputError` (or :class:`~components.core.errors.MeshError`) whose message starts
with that name. One wording per kind of failure (see ``docs/architecture.md``).
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Iterable

import numpy as np

from components.core.errors import InputError, MeshError
from components.core.memo import ContentCache, digest
from components.core.mesh import (STL_WELD, boundary_loops, bounding_box_diagonal, edge_topology, face_normals,
                                  face_sizes, halfedges, weld_labels)

__all__ = ["check_int", "check_number", "check_choice", "check_points", "check_mesh", "validate_mesh",
           "MESH_KINDS"]

#: the values of ``validate_mesh(kind=...)``
MESH_KINDS = ("any", "tri", "quad", "quad_dominant")

#: the costly checks of :func:`validate_mesh` a mesh passed (repeated corners, zero areas, manifold and oriented
#: edges), keyed by a digest of the arrays each check reads: one strategy validates the same 20k-triangle surface
#: several times (~20 ms each). Only passes are kept (a ``True`` per check), never the arrays, so nothing a caller
#: gets back is shared; a failing check runs again and words its error for the name it is given.
_PASSED = ContentCache("mesh checks passed", entries=16)


def check_int(value, name: str, lo: int | None = None, hi: int | None = None) -> int:
    """A whole-number input: an int, a numpy integer or an integral float (``3.0``), never a bool.

    Parameters
    ----------
    value : object
        The input as received.
    name : str
        The input's name (starts the error message).
    lo, hi : int or None
        Inclusive bounds; ``None`` leaves that side open.

    Returns
    -------
    int
        ``int(value)``.

    Raises
    ------
    InputError
        ``"<name>: must be a whole number, got …"`` or ``"<name>: must be <lo> or more, got …"`` /
        ``"must be between <lo> and <hi>, got …"`` / ``"must be <hi> or less, got …"``.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not float(value).is_integer():
        raise InputError(name, f"must be a whole number, got {value!r}")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        if hi is None:
            raise InputError(name, f"must be {lo} or more, got {v}")
        if lo is None:
            raise InputError(name, f"must be {hi} or less, got {v}")
        raise InputError(name, f"must be between {lo} and {hi}, got {v}")
    return v


def check_number(value, name: str, lo: float | None = None, hi: float | None = None, *, above: bool = False,
                 finite: bool = True) -> float:
    """A real-number input (int, float or numpy scalar, never a bool), optionally bounded below.

    Parameters
    ----------
    value : object
        The input as received.
    name : str
        The input's name (starts the error message).
    lo : float or None
        Lower bound; ``None`` for none.
    hi : float or None
        Upper bound (inclusive); ``None`` for none.
    above : bool
        ``True``: the value must be strictly greater than ``lo`` (``lo=0, above=True`` = positive).
    finite : bool
        Reject ``±inf`` (NaN is always rejected).

    Returns
    -------
    float
        ``float(value)``.

    Raises
    ------
    InputError
        ``"<name>: must be a number, got …"`` or ``"<name>: must be a finite number >= <lo>, got …"`` (``> <lo>``
        with ``above``; ``… and <= <hi>`` with an upper bound).

    Examples
    --------
    >>> check_number(0.5, "min_coverage", 0, 1)
    0.5
    >>> check_number(2, "min_coverage", 0, 1)
    Traceback (most recent call last):
    ...
    components.core.errors.InputError: min_coverage: must be a finite number >= 0 and <= 1, got 2
    """
    if isinstance(value, bool):
        raise InputError(name, f"must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a number, got {value!r}") from None
    bad = math.isnan(x) or (finite and math.isinf(x))
    if lo is not None:
        bad = bad or x < lo or (above and x == lo)
    if hi is not None:
        bad = bad or x > hi
    if bad:
        what = "a finite number" if finite else "a number"
        if lo is not None and hi is not None:
            what += f" {'>' if above else '>='} {lo:g} and <= {hi:g}"
        elif lo is not None:
            what += f" {'>' if above else '>='} {lo:g}"
        elif hi is not None:
            what += f" <= {hi:g}"
        raise InputError(name, f"must be {what}, got {value!r}")
    return x


#: :func:`check_length`: a length more than this many times the model's size is refused
MAX_LENGTH_RATIO = 1e6


def check_length(value, name: str, size: float, lo: float | None = None) -> float:
    """A length input (:func:`check_number`, bounded below by ``lo``) at most :data:`MAX_LENGTH_RATIO` × ``size``,
    the model's size (its bounding-box diagonal) in magnitude: an offset, a beam or a gap of 1e300 made coordinates
    that no float (nor Rhino's single-precision display copy) holds, and the answer failed as an internal error.

    >>> check_length(0.2, "distance", 10.0)
    0.2
    >>> check_length(1e300, "distance", 10.0)
    Traceback (most recent call last):
    ...
    components.core.errors.InputError: distance: 1e+300 is more than 1e+06 × the model's size (10); give a length in the model's units
    """
    x = check_number(value, name, lo)
    if abs(x) > MAX_LENGTH_RATIO * size:
        raise InputError(name, f"{x:g} is more than {MAX_LENGTH_RATIO:g} × the model's size ({size:.3g}); give a "
                               "length in the model's units")
    return x


def check_choice(value, name: str, choices: Iterable[str], *, casefold: bool = False) -> str:
    """A text input that must be one of a fixed set of words.

    Parameters
    ----------
    value : object
        The input as received.
    name : str
        The input's name (starts the error message).
    choices : iterable of str
        The accepted words.
    casefold : bool
        Accept any letter case (the canonical lower-case word is returned).

    Returns
    -------
    str
        The accepted word.

    Raises
    ------
    InputError
        ``"<name>: must be one of 'a', 'b', got 'x'"``.

    Examples
    --------
    >>> check_choice("Snap", "boundary", ("snap", "free"), casefold=True)
    'snap'
    """
    choices = tuple(choices)
    word = value.lower() if casefold and isinstance(value, str) else value
    if not isinstance(word, str) or word not in choices:
        raise InputError(name, f"must be one of {', '.join(repr(c) for c in choices)}, got {value!r}")
    return word


def check_points(P, name: str, *, allow_empty: bool = True) -> np.ndarray:
    """A list of 3D points: ``(n, 3)`` float64, finite; ``None`` or an empty list gives ``(0, 3)``.

    A single point ``(3,)`` is taken as one row.

    Raises
    ------
    InputError
        ``"<name>: must be points with shape (n, 3), got shape …"``, ``"<name>: point i has a NaN or infinite
        coordinate"`` or, with ``allow_empty=False``, ``"<name>: must not be empty"``.

    Examples
    --------
    >>> check_points([0, 0, 1], "anchors").shape
    (1, 3)
    """
    if P is None:
        A = np.zeros((0, 3))
    else:
        try:
            A = np.asarray(P, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(name, "must be points with shape (n, 3)") from None
        if A.size == 0:
            A = np.zeros((0, 3))
        elif A.ndim == 1 and A.size == 3:
            A = A[None]
    if A.ndim != 2 or A.shape[1] != 3:
        raise InputError(name, f"must be points with shape (n, 3), got shape {A.shape}")
    bad = ~np.isfinite(A).all(axis=1)
    if bad.any():
        raise InputError(name, f"point {int(np.argmax(bad))} has a NaN or infinite coordinate")
    if not allow_empty and len(A) == 0:
        raise InputError(name, "must not be empty")
    return np.ascontiguousarray(A)


def shared_positions(V, F) -> int:
    """How many of the vertices the faces ``F`` use lie on another one (within
    :data:`~components.core.mesh.STL_WELD` of the mesh's size, as :func:`~components.core.mesh.read_stl` welds: the
    same in mm, m and at 5e6); > 0 for an unwelded mesh."""
    V = np.asarray(V, dtype=np.float64)
    used = np.unique(np.asarray(F, dtype=np.int64).ravel())
    P = V[used[used < len(V)]]
    if len(P) < 2:
        return 0
    lo, hi = P.min(axis=0), P.max(axis=0)
    label = weld_labels(P - 0.5 * (lo + hi), STL_WELD * float(np.linalg.norm(hi - lo)))
    return len(P) - (int(label.max()) + 1)


def pieces_error(V, F, pieces: int, advice: str, name: str = "mesh") -> MeshError:
    """The error for a mesh of ``pieces`` connected pieces where one is needed: when its pieces share vertex
    positions (an unwelded mesh: every face or patch with its own copies of its corners, as an STL or a mesh joined
    without welding has; positions within :data:`~components.core.mesh.STL_WELD` of the mesh's size, as
    :func:`~components.core.mesh.read_stl` welds), it says to weld; else ``advice`` (e.g. "parametrize them one at a
    time").

    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(2, 1)
    >>> T = triangulate(Q)[0]
    >>> print(pieces_error(V[T].reshape(-1, 3), np.arange(12).reshape(4, 3), 4, "map each one"))
    mesh: the mesh has 4 connected pieces that share 6 vertex positions: it is not welded; weld it (Rhino: _Weld, or _Join then _Weld) and send it again
    >>> print(pieces_error(V, T[:1], 2, "map each one"))
    mesh: the mesh has 2 connected pieces; map each one
    """
    shared = shared_positions(V, F)
    if shared:
        return MeshError(name, f"the mesh has {pieces} connected pieces that share {shared} vertex positions: it is "
                               "not welded; weld it (Rhino: _Weld, or _Join then _Weld) and send it again")
    return MeshError(name, f"the mesh has {pieces} connected pieces; {advice}")


def zero_edge_error(X, F, sizes, rep, tol: float, name: str = "mesh") -> MeshError | None:
    """The error for faces two of whose corners weld into one (an edge within ``tol``; ``rep`` from
    :func:`~components.core.mesh.weld_map`), naming the first face and the shortest of its edges, or None.

    >>> from components.core.mesh import weld_map
    >>> X = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 1e-12]])
    >>> F = np.array([[0, 4, 1, 2, 3]])
    >>> print(zero_edge_error(X, F, np.array([5]), weld_map(X, np.ones(5, bool), 1e-9), 1e-9))
    mesh: face 0 [0, 4, 1, 2, 3] has a zero-length edge: vertices 4 and 1 are 1e-12 apart (within the weld tolerance 1e-09); a quad with a collapsed edge is not a panel: weld the two corners and write the face as a triangle (a, b, c, c), or move them apart
    """
    k = F.shape[1]
    valid = np.arange(k)[None, :] < sizes[:, None]
    pad = -1 - np.arange(k)[None, :]

    def repeats(G):
        Gs = np.sort(np.where(valid, G, pad), axis=1)
        return (Gs[:, 1:] == Gs[:, :-1]).any(axis=1)

    bad = repeats(rep[F]) & ~repeats(F)  # a vertex repeated in the input itself is validate_mesh's to word
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    corners = F[i, : sizes[i]].tolist()
    s = len(corners)
    lengths = [(float(np.linalg.norm(X[corners[(j + 1) % s]] - X[corners[j]])), corners[j], corners[(j + 1) % s])
               for j in range(s)]
    d, a, b = min(lengths)
    more = f" ({int(bad.sum())} faces in all)" if bad.sum() > 1 else ""
    return MeshError(name, f"face {i} {corners} has a zero-length edge: vertices {a} and {b} are {d:.3g} apart (within "
                           f"the weld tolerance {tol:.3g}){more}; a quad with a collapsed edge is not a panel: weld the "
                           f"two corners and write the face as a triangle (a, b, c, c), or move them apart")


#: boundary_gap_warning: boundary points closer than this × the panel size in space ...
GAP_SHARE = 0.25
#: ... and this many times farther apart along the boundary (a notch sharper than about 11° counts as a gap)
GAP_DETOUR = 10.0


def boundary_gap_warning(V, F, panel: float) -> str | None:
    """The warning for a surface whose boundary passes close to itself (an unwelded seam, a slit, an opening near the
    edge), or None: where two stretches of boundary are less than :data:`GAP_SHARE` × ``panel`` apart in space but far
    apart along the boundary (more than twice that and :data:`GAP_DETOUR` times their distance; or on two loops), no
    panel fits across the gap, and a seam of coincident vertices (within
    :data:`~components.core.mesh.STL_WELD` of the size) is a surface that was meant to be closed there. The panels of
    every strategy stop at such a gap (they may pinch there); the warning says where and what to do. Relative to the
    size and the panel: the same in mm, m and at +5e6.

    >>> from components.core.mesh import quad_grid
    >>> V, Q = quad_grid(8, 2, 8.0, 2.0)
    >>> boundary_gap_warning(V, Q, 1.0) is None
    True
    >>> ring = np.c_[np.cos(V[:, 0] * np.pi / 4), np.sin(V[:, 0] * np.pi / 4), V[:, 1]]  # rolled up, not welded
    >>> print(boundary_gap_warning(ring, Q, 1.0))
    the surface's boundary runs along itself: 3 pairs of boundary vertices at the same positions (a seam that is not welded, e.g. vertices 0 and 8): the panels stop at the seam; weld it (Rhino: _Weld) for panels across it
    """
    # deferred import: scipy.spatial is not needed to import this module (see components.core.mesh.weld_labels)
    from scipy.spatial import cKDTree

    try:
        loops = boundary_loops(F)
    except MeshError:  # a boundary that is not a set of loops is the validation's to word
        return None
    if not loops or not panel > 0:
        return None
    V = np.asarray(V, dtype=np.float64)
    B = np.concatenate(loops)
    loop_of = np.repeat(np.arange(len(loops)), [len(lp) for lp in loops])
    arc, total = [], []
    for lp in loops:
        seg = np.linalg.norm(V[np.roll(lp, -1)] - V[lp], axis=1)
        arc.append(np.concatenate([[0.0], np.cumsum(seg[:-1])]))
        total.append(np.full(len(lp), seg.sum()))
    arc, total = np.concatenate(arc), np.concatenate(total)
    P = V[B]
    lo, hi = P.min(axis=0), P.max(axis=0)
    P = P - 0.5 * (lo + hi)  # centred: the same pairs at +5e6
    r = GAP_SHARE * float(panel)
    pairs = cKDTree(P).query_pairs(r, output_type="ndarray")
    if not len(pairs):
        return None
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(P[i] - P[j], axis=1)
    along = np.abs(arc[i] - arc[j])
    along = np.minimum(along, total[i] - along)
    far = (loop_of[i] != loop_of[j]) | ((along > 2.0 * r) & (along > GAP_DETOUR * d))
    if not far.any():
        return None
    i, j, d = i[far], j[far], d[far]
    seam = d <= STL_WELD * bounding_box_diagonal(V)
    lo_v, hi_v = np.minimum(B[i], B[j]), np.maximum(B[i], B[j])
    # the example: the closest pair (of a seam: the one with the lowest vertices, whatever the rounding of its zeros)
    k = int(np.lexsort((hi_v, lo_v, np.where(seam, 0.0, d)))[0])
    a, b = int(lo_v[k]), int(hi_v[k])
    if seam.any():
        return (f"the surface's boundary runs along itself: {int(seam.sum())} pairs of boundary vertices at the same "
                f"positions (a seam that is not welded, e.g. vertices {a} and {b}): the panels stop at the seam; weld "
                "it (Rhino: _Weld) for panels across it")
    return (f"the surface's boundary passes within {d[k]:.3g} of itself ({d[k] / float(panel):.2g} × the panel size, "
            f"e.g. at vertices {a} and {b}; {len(d)} such pairs): no panel fits across that gap and the panels on its "
            "two sides may pinch; widen the gap, close it (join and weld), or use smaller panels")


def check_mesh(mesh, name: str = "mesh", **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """A ``Mesh`` input: a ``(V, F)`` pair, checked by :func:`validate_mesh` (keyword options passed on).

    Raises
    ------
    MeshError
        ``"<name>: must be a (V, F) pair of vertex and face arrays"`` or what :func:`validate_mesh` says.
    """
    if not isinstance(mesh, (tuple, list)) or len(mesh) < 2:
        raise MeshError(name, "must be a (V, F) pair of vertex and face arrays")
    return validate_mesh(mesh[0], mesh[1], name=name, **kwargs)


def validate_mesh(
    V,
    F,
    name: str = "mesh",
    kind: str = "any",
    allow_degenerate: bool = False,
    manifold: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Check a mesh once, at the boundary, and return it in canonical form.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, k) array_like of int
        Faces (k ≥ 3), short faces padded by repeating their last vertex.
    name : str
        Name of the input, used in every error message.
    kind : {"any", "tri", "quad", "quad_dominant"}
        ``"tri"`` requires triangles only, ``"quad"`` quads only, ``"quad_dominant"`` at least one quad.
    allow_degenerate : bool
        Accept faces with repeated corners or zero area.
    manifold : bool
        Require every edge to have at most two faces, with consistent orientation.

    Returns
    -------
    V : (n, 3) float64, C-contiguous
    F : (m, k) int64, C-contiguous

    Raises
    ------
    MeshError
        Naming the input and the first offending vertex, face or edge.
    ValueError
        ``kind`` is not one of :data:`MESH_KINDS` (a programming error, not an input error).

    Notes
    -----
    The costly checks a mesh passed (repeated corners, zero areas, manifold and oriented edges) are remembered by the
    content of the arrays they read (:data:`_PASSED`), so validating the same surface again, or the same faces on
    moved vertices, repeats only what can differ. The returned arrays are never shared through it.
    """
    if kind not in MESH_KINDS:
        raise ValueError(f"validate_mesh: kind must be one of {', '.join(MESH_KINDS)}, got {kind!r}")
    try:
        V = np.ascontiguousarray(V, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(name, f"vertices are not numbers ({exc})") from None
    try:
        F_in = np.asarray(F)
        if F_in.size and not np.issubdtype(F_in.dtype, np.integer):
            if not np.all(np.isfinite(F_in)) or np.any(F_in != np.round(F_in)):
                raise MeshError(name, "face indices must be integers")
        F = np.ascontiguousarray(F_in, dtype=np.int64)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, MeshError):
            raise
        raise MeshError(name, f"faces are not integer indices ({exc})") from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshError(name, f"vertices must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or (F.shape[0] and F.shape[1] < 3):
        raise MeshError(name, f"faces must have shape (m, k) with k >= 3, got {F.shape}")
    if len(V) == 0 or len(F) == 0:
        raise MeshError(name, f"mesh is empty ({len(V)} vertices, {len(F)} faces): send a mesh with faces")
    bad = ~np.isfinite(V).all(axis=1)
    if bad.any():
        raise MeshError(name, f"vertex {int(np.argmax(bad))} has a NaN or infinite coordinate")
    out = (F < 0) | (F >= len(V))
    if out.any():
        i = int(np.argmax(out.any(axis=1)))
        raise MeshError(name, f"face {i} has a vertex index out of range 0..{len(V) - 1}: {F[i].tolist()}")
    sizes = face_sizes(F)
    if kind == "tri" and np.any(sizes != 3):
        i = int(np.argmax(sizes != 3))
        raise MeshError(name, f"a triangle mesh is required but face {i} has {sizes[i]} corners")
    if kind == "quad" and np.any(sizes != 4):
        i = int(np.argmax(sizes != 4))
        raise MeshError(name, f"a quad mesh is required but face {i} has {sizes[i]} corners")
    if kind == "quad_dominant" and not np.any(sizes == 4):
        raise MeshError(name, "a quad or quad-dominant mesh is required but it has no quads")
    if allow_degenerate and not manifold:
        return V, F
    # each costly check runs once per content (a check that raises keeps nothing); skipping one that passed before
    # cannot change which error is raised first
    key_f = digest(F)
    if not allow_degenerate:
        if np.any(sizes < 3):
            i = int(np.argmax(sizes < 3))
            raise MeshError(name, f"face {i} is degenerate (fewer than 3 distinct corners): {F[i].tolist()}")
        _PASSED.get((key_f, "distinct corners"), lambda: _distinct_corners(F, sizes, name))
        _PASSED.get((key_f, digest(V), "areas"), lambda: _nonzero_areas(V, F, name))
    if manifold:
        _PASSED.get((key_f, len(V), "manifold"), lambda: _manifold_oriented(F, len(V), name))
    return V, F


def _distinct_corners(F, sizes, name: str) -> bool:
    k = F.shape[1]
    valid = np.arange(k)[None, :] < sizes[:, None]
    Fs = np.sort(np.where(valid, F, -1 - np.arange(k)[None, :]), axis=1)
    rep = (Fs[:, 1:] == Fs[:, :-1]).any(axis=1)
    if rep.any():
        i = int(np.argmax(rep))
        raise MeshError(name, f"face {i} repeats a vertex: {F[i].tolist()}; write a triangle as (a, b, c, c), "
                              "with the repeat last, or delete the face")
    return True


def _nonzero_areas(V, F, name: str) -> bool:
    # centred first: at site coordinates (+5e6) the corner cross products would lose the area to round-off
    area = np.linalg.norm(face_normals(V - V.mean(axis=0), F, unit=False), axis=1)
    scale = bounding_box_diagonal(V)
    tiny = area <= (1e-14 * scale * scale if scale > 0 else 0.0)
    if tiny.any():
        i = int(np.argmax(tiny))
        raise MeshError(name, f"face {i} is degenerate (zero area): {F[i].tolist()}"
                              f"{f' ({int(tiny.sum())} in all)' if tiny.sum() > 1 else ''}; delete such faces (Rhino: "
                              "_CullDegenerateMeshFaces) or move their corners apart")
    return True


def _raise_duplicate_faces(F, name: str):
    """A :class:`MeshError` naming the first face given twice (the same corners, in any order), if there is one."""
    sizes = face_sizes(F)
    key = np.sort(np.where(np.arange(F.shape[1])[None, :] < sizes[:, None], F, -1), axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    dup = np.flatnonzero(first[inverse.ravel()] != np.arange(len(F)))
    if len(dup):
        i = int(dup[0])
        raise MeshError(name, f"faces {int(first[inverse.ravel()[i]])} and {i} have the same corners "
                              f"{F[i, :sizes[i]].tolist()} (a face given twice; {len(dup)} in all): delete the "
                              "duplicates and send it again")


def _manifold_oriented(F, n: int, name: str) -> bool:
    H, _ = halfedges(F)
    topo = edge_topology(F)
    if np.any(topo.count > 2):
        _raise_duplicate_faces(F, name)  # the likely cause, said as such (an edge of 4 faces says little)
        e = int(np.argmax(topo.count > 2))
        a, b = topo.E[e].tolist()
        raise MeshError(name, f"edge ({a}, {b}) is non-manifold: it has {int(topo.count[e])} faces; split the mesh "
                              "there or delete the extra faces")
    # consistent orientation: each directed half-edge appears once (one int64 key per half-edge)
    dkey = np.sort(H[:, 0] * np.int64(n) + H[:, 1])
    twice = np.nonzero(dkey[1:] == dkey[:-1])[0]
    if len(twice):
        _raise_duplicate_faces(F, name)
        a, b = divmod(int(dkey[twice[0]]), n)
        raise MeshError(
            name, f"faces are not consistently oriented: edge ({a}, {b}) is used twice in the same direction"
        )
    return True
