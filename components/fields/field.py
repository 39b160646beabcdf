"""Smooth and conjugate direction fields on triangle meshes: PolyVector smoothing, Liu-style conjugate optimization,
singularities.

A direction field is, per triangle, a pair of unit tangent vectors ``U, W`` (not necessarily orthogonal) standing
for the 4-fold set ``(±U, ±W)``. Quads laid along a field are planar to first order where the two directions are
conjugate with respect to the surface's shape operator (``II(U, W) = 0``); principal directions are conjugate and
orthogonal, but they carry many singularities, so the pipeline smooths them first (:func:`smooth_frame_field`) and then
makes the smooth field conjugate (:func:`conjugate_frame_field`).

PolyVector representation (Diamanti et al. 2014): in a face's complex frame the pair ``(u, v)`` is the polynomial
``(z² − u²)(z² − v²) = z⁴ − Y z² + X`` with ``X = u² v²`` and ``Y = u² + v²``, invariant under ``±u, ±v`` and the
swap, so no matching is needed while optimizing. Carrying a field from face ``f`` to its neighbour ``g`` multiplies
``u`` by ``r = e^{iκ}`` (the connection), hence ``X`` by ``r⁴`` and ``Y`` by ``r²``: the smoothness energy
``Σ_edges w |c_g − r^k c_f|²`` is a Hermitian quadratic form, and soft alignment terms make each coefficient the
solution of one sparse linear system (``X`` and ``Y`` decouple). An orthogonal cross has ``Y = 0``.

Weights are resolution independent: per-face terms are scaled by the face's share of the total area, so the
``alignment`` knob means the same on 2k and 200k triangles. The smoothing length is about
``sqrt(area / (1000 · alignment))``: 10% of the surface's size at the default 0.1.

References
----------
O. Diamanti, A. Vaxman, D. Panozzo, O. Sorkine-Hornung, "Designing N-PolyVector fields with complex polynomials",
Computer Graphics Forum (SGP) 33(5), 2014.
Y. Liu, W. Xu, J. Wang, L. Zhu, B. Guo, F. Chen, G. Wang, "General planar quadrilateral mesh design using conjugate
direction field", ACM Trans. Graph. (SIGGRAPH Asia) 30(6), 2011.
O. Diamanti, A. Vaxman, D. Panozzo, O. Sorkine-Hornung, "Integrable PolyVector fields", SIGGRAPH 2015 (libigl's
``conjugate_frame_fields`` follows the local-global scheme of Liu et al.).
"""
from __future__ import annotations

import functools
import logging
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu

from components.core.curvature import face_principal_curvature, vertex_principal_curvature
from components.fields.frames import (
    DualGraph,
    FaceFrames,
    comb_field,
    dual_graph,
    face_frames,
    field_matching,
    field_singularities,
    from_complex,
    to_complex,
    check_field,
)
from components.core.blas import single_blas_thread
from components.core.memo import ContentCache, digest
from components.core.checks import check_int, check_mesh, check_number, validate_mesh
from components.core.errors import InputError
from components.core.measures import unit
from components.core.mesh import triangulate
from components.core.parallel import ThreadOwned, concurrently, for_each
from components.core.proximity import TriangleIndex
from components.core.types import Lines, Mesh, Numbers, Points, Vectors
from components.fields import conjugate_kernels as kernels

log = logging.getLogger(__name__)

__all__ = [
    "Field",
    "FieldCurvature",
    "closest_conjugate_pairs",
    "comb_field",
    "conjugacy_error",
    "conjugate_frame_field",
    "conjugate_field",
    "field_curvature",
    "field_matching",
    "field_singularities",
    "smooth_field",
    "smooth_frame_field",
    "transferred_field",
]

_TANGENT_WEIGHT = 10.0  # the conjugate local step's pull of a boundary face's pair towards the boundary tangent
_AREA_SCALE = 1000.0  # per-face weights: alignment · 1000 · (face area / total area)


class Field(NamedTuple):
    """A direction field on the triangles of a mesh and its diagnostics.

    ``U, W`` (m, 3) unit tangent directions (combed: ``U`` continues as ``U`` across all edges but a cut graph;
    ``W`` counter-clockwise from ``U``), ``singularities`` (k,) interior vertex indices, ``singularity_index`` (k,)
    their indices (multiples of 1/4), ``alignment_error`` (m,) angle in radians between the field and the
    principal directions (the larger of the two directions' angles to the nearest principal line),
    ``conjugacy_error`` (m,) ``|II(U, W)| / (|k1| + |k2|)`` (0 for a conjugate pair), ``anisotropy`` (m,) the
    curvature anisotropy used as alignment weight, ``released`` (m,) bool: faces a conjugate field released from
    conjugacy (``None`` for other fields). A field computed with ``diagnostics=False`` has ``None`` for the
    singularities, their indices and the two errors.
    """

    U: np.ndarray
    W: np.ndarray
    singularities: np.ndarray
    singularity_index: np.ndarray
    alignment_error: np.ndarray
    conjugacy_error: np.ndarray
    anisotropy: np.ndarray
    released: np.ndarray | None = None


class FieldCurvature(NamedTuple):
    """Per-face shape operator in principal form: unit directions ``d1, d2`` (m, 3) and curvatures ``k1 ≥ k2``."""

    d1: np.ndarray
    d2: np.ndarray
    k1: np.ndarray
    k2: np.ndarray


# ----------------------------------------------------------------------------------------------
# inputs


def field_curvature(V: np.ndarray, T: np.ndarray, radius: int = 2) -> FieldCurvature:
    """Per-face principal directions and curvatures from the quadric fit of :mod:`components.core.curvature`.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles.
    radius : int
        Ring size of the per-vertex fit.

    Returns
    -------
    FieldCurvature
        ``d1, d2`` (m, 3) in the face planes, ``k1, k2`` (m,).
    """
    PD1, PD2, PV1, PV2 = vertex_principal_curvature(V, T, radius=radius)
    return FieldCurvature(*face_principal_curvature(V, T, PD1, PD2, PV1, PV2))


def _curvature_arg(curvature, V, T, radius, m) -> FieldCurvature:
    if curvature is None:
        return field_curvature(V, T, radius)
    try:
        d1, d2, k1, k2 = (np.asarray(x, dtype=np.float64) for x in curvature)
    except (TypeError, ValueError) as exc:
        raise InputError("curvature", f"must be (d1, d2, k1, k2) per face ({exc})") from None
    if d1.shape != (m, 3) or d2.shape != (m, 3) or k1.shape != (m,) or k2.shape != (m,):
        raise InputError("curvature", f"must be (d1, d2, k1, k2) with shapes ({m}, 3), ({m}, 3), ({m},), ({m},)")
    if not all(np.isfinite(x).all() for x in (d1, d2, k1, k2)):
        raise InputError("curvature", "has NaN or infinite values")
    return FieldCurvature(d1, d2, k1, k2)


def _constraints_arg(constraints, m: int, fr: FaceFrames):
    """``(faces, directions)`` → face indices and complex ``(X, Y)`` targets; one direction fixes one root."""
    if constraints is None:
        return None
    faces, Z = _constraint_directions(constraints, m, fr)
    if Z.shape[1] == 2:
        u, v = Z[:, 0], Z[:, 1]
        return faces, u * u * v * v, u * u + v * v
    u = Z[:, 0]
    return faces, -(u ** 4), np.zeros(len(faces), dtype=complex)


def _constraint_directions(constraints, m: int, fr: FaceFrames):
    """``(faces, directions)`` → face indices ``(c,)`` and unit complex directions ``(c, 1 or 2)``."""
    try:
        faces, dirs = constraints
        faces = np.asarray(faces)
        dirs = np.asarray(dirs, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError("constraints", f"must be (faces, directions) ({exc})") from None
    if faces.ndim != 1 or (faces.size and not np.issubdtype(faces.dtype, np.integer)):
        raise InputError("constraints", "faces must be a 1-D array of integer face indices")
    faces = faces.astype(np.int64)
    c = len(faces)
    if dirs.shape == (c, 6):
        dirs = dirs.reshape(c, 2, 3)
    if dirs.shape not in ((c, 3), (c, 2, 3)):
        raise InputError("constraints", f"directions must have shape ({c}, 3), ({c}, 2, 3) or ({c}, 6), got "
                                        f"{dirs.shape}")
    bad = (faces < 0) | (faces >= m)
    if bad.any():
        raise InputError("constraints", f"face {int(faces[np.argmax(bad)])} does not exist (the mesh has {m} "
                                        "triangles)")
    if len(np.unique(faces)) != c:
        raise InputError("constraints", "a face is constrained twice")
    if not np.isfinite(dirs).all():
        raise InputError("constraints", "directions have NaN or infinite values")
    two = dirs.ndim == 3
    D = dirs if two else dirs[:, None, :]
    zs = []
    for j in range(D.shape[1]):
        z = to_complex(D[:, j], fr, faces)
        tangential = np.abs(z) > 1e-6 * np.maximum(np.linalg.norm(D[:, j], axis=1), 1e-300)
        if not tangential.all():
            raise InputError("constraints", f"direction for face {int(faces[np.argmax(~tangential)])} is zero or "
                                            "normal to the face")
        zs.append(z / np.abs(z))
    return faces, np.stack(zs, axis=1)


# ----------------------------------------------------------------------------------------------
# the linear solves


def _connection_laplacian(dg: DualGraph, m: int, degree: int) -> sp.csr_matrix:
    """Hermitian form of ``Σ w |c_g − r^degree c_f|²``."""
    rho = np.exp(1j * degree * dg.kappa)
    w = dg.weight
    rows = np.concatenate([dg.f, dg.g, dg.g, dg.f])
    cols = np.concatenate([dg.f, dg.g, dg.f, dg.g])
    vals = np.concatenate([w.astype(complex), w.astype(complex), -w * rho, -w * np.conj(rho)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(m, m))


class _Preordered(NamedTuple):
    """A factorization of ``A[perm][:, perm]`` that solves ``A x = b``."""

    lu: object
    perm: np.ndarray

    def solve(self, b: np.ndarray) -> np.ndarray:
        x = np.empty_like(b, dtype=np.result_type(b, complex))
        x[self.perm] = self.lu.solve(b[self.perm])
        return x


def _factor(A: sp.spmatrix) -> _Preordered:
    """Sparse LU of a Hermitian positive definite matrix: the faces put in reverse Cuthill–McKee order, then the
    symmetric minimum-degree ordering, no pivoting.

    The systems are Hermitian positive definite, so diagonal pivots are stable; forbidding row exchanges keeps the
    symmetric ordering's fill (about half of COLAMD's on these meshes, see ``benchmarks/fields.py``), while SuperLU's
    default partial pivoting made the factor time swing by 10–100× between runs. The minimum-degree ordering breaks
    its ties by the input's order, and some orders of a mesh's faces lead it to an elimination with the same fill
    but many times the work: libigl's ``face.obj`` (52k triangles, a scan's face order) took 2.9 s per factorization
    and 24 ms per solve, 0.15 s and 5.6 ms with its faces shuffled or put in reverse Cuthill–McKee order first (the
    benchmark patches, camelhead, lilium: within ±10 % either way). The preorder is the mesh's own (topological), so
    a model in other units or elsewhere gets the same one.
    """
    A = sp.csr_matrix(A)
    perm = reverse_cuthill_mckee(A, symmetric_mode=True).astype(np.int64)
    lu = splu(A[perm][:, perm].tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    return _Preordered(ThreadOwned(lu), perm)  # made on a helper thread, it is freed there (core.parallel)


def _pinned_solver(A, free: np.ndarray, c: np.ndarray):
    """Factor ``A`` on the ``free`` faces once; returns ``b ↦`` the solution with the other entries kept at ``c``."""
    if free.all():
        return _factor(A).solve  # nothing pinned: the solution itself
    lu, fixed = _factor(A[free][:, free]), A[free][:, ~free] @ c[~free]

    def solve(b: np.ndarray) -> np.ndarray:
        out = c.copy()
        out[free] = lu.solve(b[free] - fixed)
        return out

    return solve


def _pinned_values(m: int, pinned) -> tuple[np.ndarray, np.ndarray]:
    """``free (m,) bool`` and ``c (m,) complex``: the entries not pinned, and the pinned values in place (0
    elsewhere), of ``pinned = (faces, values)`` or None."""
    free = np.ones(m, dtype=bool)
    c = np.zeros(m, dtype=complex)
    if pinned is not None and len(pinned[0]):
        free[pinned[0]] = False
        c[pinned[0]] = pinned[1]
    return free, c


def _solve_coefficient(L, wface: np.ndarray, target: np.ndarray, pinned=None, guess=None):
    """Minimize ``cᴴ L c + Σ w |c − t|²`` with optional pinned values; returns the coefficient per face.

    Without any positive weight or pin the minimizer is zero; then the smoothest unit field (the eigenvector of the
    smallest eigenvalue) is returned, found by inverse iteration.
    """
    m = L.shape[0]
    free, c = _pinned_values(m, pinned)
    A = (L + sp.diags(wface.astype(complex))).tocsr()
    if np.any(wface[free] > 0) or not free.all():
        return _pinned_solver(A, free, c)(wface * target)
    # no data at all: inverse iteration on the (slightly shifted) Laplacian
    scale = float(np.abs(L.diagonal()).mean()) or 1.0
    lu = _factor(A + sp.identity(m, format="csr") * (1e-8 * scale))
    rng = np.random.default_rng(0)
    x = rng.standard_normal(m) + 1j * rng.standard_normal(m) if guess is None else guess.astype(complex)
    for _ in range(30):
        x = lu.solve(x)
        x /= np.linalg.norm(x)
    return x


def _spread_solver(L, w: np.ndarray, pinned, area: np.ndarray, core: float = 3.0):
    """The factored system of :func:`_spread_singularities` and its ``μ`` (it does not depend on the field, so it
    can be factored while the field is solved): ``(solve, μ)``, pinned entries kept at their values."""
    eps = core * float(np.sqrt(2.0 * area.mean()))
    mu = area / (eps * eps)
    return _pinned_solver((L + sp.diags((w + mu).astype(complex))).tocsr(), *_pinned_values(L.shape[0], pinned)), mu


def _spread_singularities(w: np.ndarray, t: np.ndarray, X: np.ndarray, iterations: int, spread) -> np.ndarray:
    """Normalize-and-diffuse iterations on a coefficient field ``X`` (one factorization for all: ``spread`` from
    :func:`_spread_solver`; ``X`` holds the pinned values there).

    Each step minimizes ``Xᴴ L X + Σ w |X − t|² + Σ μ |X − X̂|²`` with ``X̂ = X / |X|`` the normalized previous
    field and ``μ_f = A_f / ε²``, ``ε`` = ``core`` mean triangle sizes: the Ginzburg–Landau core radius, so the
    magnitude may only vanish within about ``ε`` of a singularity.
    """
    solve, mu = spread
    wt = w * t
    for _ in range(iterations):
        a = np.abs(X)
        X = solve(wt + mu * np.divide(X, a, out=np.ones_like(X), where=a > 0))
    return X


def _roots(X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit complex ``u, v`` with ``(z² − u²)(z² − v²) ∝ z⁴ − Y z² + X``."""
    disc = np.sqrt(Y * Y - 4.0 * X)
    t1 = 0.5 * (Y + disc)
    t2 = 0.5 * (Y - disc)
    u = np.sqrt(t1)
    v = np.sqrt(t2)
    # degenerate coefficients (both zero): any orthogonal pair
    zu = u == 0
    if zu.any():
        u = np.where(zu, 1.0, u)
    zv = v == 0
    if zv.any():
        v = np.where(zv, 1j * u, v)
    return u / np.abs(u), v / np.abs(v)


def _poly(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u2, v2 = u * u, v * v
    return u2 * v2, u2 + v2


# ----------------------------------------------------------------------------------------------
# diagnostics


def _principal_complex(cv: FieldCurvature, fr: FaceFrames) -> np.ndarray:
    z = to_complex(cv.d1, fr)
    a = np.abs(z)
    return np.where(a > 0, z / np.where(a > 0, a, 1.0), 1.0)


def _anisotropy(cv: FieldCurvature) -> np.ndarray:
    s = np.abs(cv.k1) + np.abs(cv.k2)
    eps = 0.05 * float(np.mean(s)) if len(s) else 0.0
    den = s + eps
    return np.divide(np.abs(cv.k1 - cv.k2), den, out=np.zeros_like(s), where=den > 0)


_ANISOTROPY_FLOOR = 0.1  # below this the principal directions are noise: no alignment at all


def _alignment_weights(aniso: np.ndarray) -> np.ndarray:
    return np.clip((aniso - _ANISOTROPY_FLOOR) / (1.0 - _ANISOTROPY_FLOOR), 0.0, 1.0)


def conjugacy_error(U: np.ndarray, W: np.ndarray, curvature: FieldCurvature) -> np.ndarray:
    """``|II(U, W)| / (|k1| + |k2|)`` per face for unit ``U, W`` (0 = conjugate; 0.5 at most for unit vectors).

    Parameters
    ----------
    U, W : (m, 3) float64
        Field directions.
    curvature : FieldCurvature
        Per-face shape operator (:func:`field_curvature`).

    Returns
    -------
    (m,) float64
        Scale-free conjugacy error; 0 on faces with zero curvature.
    """
    U = U / np.linalg.norm(U, axis=1, keepdims=True)
    W = W / np.linalg.norm(W, axis=1, keepdims=True)
    d1, d2, k1, k2 = curvature
    II = (k1 * np.einsum("ij,ij->i", U, d1) * np.einsum("ij,ij->i", W, d1)
          + k2 * np.einsum("ij,ij->i", U, d2) * np.einsum("ij,ij->i", W, d2))
    s = np.abs(k1) + np.abs(k2)
    return np.divide(np.abs(II), s, out=np.zeros_like(s), where=s > 0)


def _alignment_error(U, W, cv: FieldCurvature, fr: FaceFrames) -> np.ndarray:
    p = _principal_complex(cv, fr)
    out = np.zeros(len(U))
    for X in (U, W):
        z = to_complex(X, fr) * np.conj(p)
        a = np.mod(np.angle(z), 0.5 * np.pi)  # angle to the nearest principal line (cross symmetry)
        out = np.maximum(out, np.minimum(a, 0.5 * np.pi - a))
    return out


def _finish(V, T, u, v, fr, dg, cv, aniso, diagnostics: bool = True) -> Field:
    """The combed field of the pair ``u, v`` with its diagnostics (singularities, errors) or without them."""
    U = from_complex(u, fr)
    W = from_complex(v, fr)
    U, W, _ = comb_field(V, T, U, W, fr, dg)
    if not diagnostics:
        return Field(U, W, None, None, None, None, aniso)
    sing, index = field_singularities(V, T, U, W, fr, dg)
    return Field(U, W, sing, index, _alignment_error(U, W, cv, fr), conjugacy_error(U, W, cv), aniso)


_FRAMES = ContentCache("field frames")  # the last mesh's face frames and dual graph (for the smooth, then the conjugate
# field on it)


def _frames(V: np.ndarray, T: np.ndarray) -> tuple[FaceFrames, DualGraph]:
    """Face frames and dual graph of a validated mesh, kept for the next field on the same mesh."""
    def build():
        fr = face_frames(V, T)
        return fr, dual_graph(V, T, fr)

    return _FRAMES.get(digest(V, T), build)


# ----------------------------------------------------------------------------------------------
# smooth field


@single_blas_thread()  # sparse factorizations: see components.core.blas
def smooth_frame_field(V: np.ndarray, T: np.ndarray, alignment: float = 0.1, constraints=None,
                 constraint_weight: float | None = None, align_boundary: bool = True, boundary_weight: float = 10.0,
                 curvature: FieldCurvature | None = None, curvature_radius: int = 2,
                 normalize_iterations: int = 20, diagnostics: bool = True) -> Field:
    """Smooth 4-PolyVector field softly aligned to the principal curvature directions.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles: oriented, edge-manifold, open boundaries and holes allowed.
    alignment : float
        Weight of the pull towards the principal directions (≥ 0; each face weighted by its curvature
        anisotropy and area share). Small = smoother, fewer singularities; large = closer to the principal
        directions. 0 gives the smoothest field satisfying the constraints.
    constraints : (faces, directions), optional
        ``faces (c,) int`` and ``directions (c, 3)`` (one direction of the cross prescribed) or ``(c, 2, 3)``
        (both directions prescribed; they may be non-orthogonal, the field then bends to a non-orthogonal
        PolyVector near them).
    constraint_weight : float, optional
        ``None`` (default): hard constraints. A number: soft constraints with this weight per face (1 ≈ the
        coupling of two neighbouring faces).
    align_boundary : bool
        Softly align one direction with the boundary on faces with a boundary edge.
    boundary_weight : float
        Weight per boundary edge of that alignment (relative to the coupling of two neighbouring faces).
    curvature : FieldCurvature, optional
        Per-face principal directions and curvatures (computed with :func:`field_curvature` when omitted).
    curvature_radius : int
        Ring size of the curvature fit when ``curvature`` is omitted.
    normalize_iterations : int
        Normalize-and-diffuse iterations after the linear solve (0 to 200; 0 = the plain linear field). The
        linear solve lets the field's magnitude vanish over whole regions, so its singularities merge (on a dome
        with an aligned boundary the four quarter-turn singularities fuse into one polar point with wedge-shaped
        panels); each iteration re-solves with a pull of the face's mass towards the normalized field, which
        separates them (Ginzburg–Landau / MBO scheme, Viertel & Osting 2019).
    diagnostics : bool
        Compute the singularities and the alignment and conjugacy errors (False: ``None``, for callers that only
        use the directions).

    Returns
    -------
    Field
        Combed ``U, W``, singular vertices with their indices, alignment error, conjugacy error, anisotropy.

    Raises
    ------
    MeshError
        Non-triangle, degenerate or non-manifold mesh.
    InputError
        Bad weights, constraints on missing faces, constraint directions normal to their face.

    Notes
    -----
    Energy ``Σ_edges w_e |c_g − r_e^k c_f|² + Σ_f ω_f |c_f − t_f|²`` for ``X`` (``k = 4``) and ``Y``
    (``k = 2``), with ``ω_f = alignment · 1000 · (A_f / A) · a_f``; ``a_f`` ramps from 0 to 1 as the anisotropy
    ``|k1 − k2| / (|k1| + |k2| + ε)`` goes from 0.1 to 1 (near-umbilic faces have noise for principal directions), and the principal target ``t = −d1⁴`` (the cross along ``d1, d2``; ``Y = 0``), plus the boundary and user
    terms (Diamanti et al. 2014). Both are single sparse Hermitian solves.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(6, 6, height=lambda x, y: 0.3 * x * y)
    >>> T = triangulate(Q)[0]
    >>> fld = smooth_frame_field(V, T, alignment=0.1)
    >>> fld.U.shape == (len(T), 3), bool(np.allclose(np.linalg.norm(fld.W, axis=1), 1.0))
    (True, True)
    """
    V, T = validate_mesh(V, T, name="mesh", kind="tri")
    alignment = check_number(alignment, "alignment", 0)
    boundary_weight = check_number(boundary_weight, "boundary_weight", 0)
    normalize_iterations = check_int(normalize_iterations, "normalize_iterations", 0, 200)
    if constraint_weight is not None:
        constraint_weight = check_number(constraint_weight, "constraint_weight", 0, above=True)
    m = len(T)
    fr, dg = _frames(V, T)
    cv = _curvature_arg(curvature, V, T, check_int(curvature_radius, "curvature_radius", 1, 6), m)
    cons = _constraints_arg(constraints, m, fr)
    aniso = _anisotropy(cv)
    p = _principal_complex(cv, fr)
    wX, accX, wY, accY, pinX, pinY = _smooth_terms(V, fr, dg, p, aniso, alignment, align_boundary, boundary_weight,
                                                   cons, constraint_weight)
    tX = np.divide(accX, wX, out=np.zeros(m, dtype=complex), where=wX > 0)
    LX = _connection_laplacian(dg, m, 4)

    def solve_y():
        if np.any(accY != 0) or (pinY is not None and np.any(pinY[1] != 0)):
            tY = np.divide(accY, wY, out=np.zeros(m, dtype=complex), where=wY > 0)
            return _solve_coefficient(_connection_laplacian(dg, m, 2), wY, tY, pinY)
        return np.zeros(m, dtype=complex)

    # three independent systems: X, the spreading of its singularities (factored before X is known) and Y
    X, spread, Y = concurrently(lambda: _solve_coefficient(LX, wX, tX, pinX),
                                lambda: _spread_solver(LX, wX, pinX, fr.area) if normalize_iterations else None,
                                solve_y)
    if normalize_iterations:
        X = _spread_singularities(wX, tX, X, normalize_iterations, spread)
    u, v = _roots(X, Y)
    fld = _finish(V, T, u, v, fr, dg, cv, aniso, diagnostics)
    if diagnostics:
        log.debug("smooth_frame_field: %d faces, %d singularities", m, len(fld.singularities))
    return fld


def _smooth_terms(V, fr: FaceFrames, dg: DualGraph, p: np.ndarray, aniso: np.ndarray, alignment: float,
                  align_boundary: bool, boundary_weight: float, cons, constraint_weight: float | None):
    """Per-face weights and weighted targets of the ``X`` and ``Y`` systems of :func:`smooth_frame_field`
    (principal alignment, boundary alignment, soft constraints) and the pinned values of hard constraints:
    ``wX, accX, wY, accY, pinX, pinY``."""
    m = len(fr.area)
    share = fr.area / float(fr.area.sum())
    wX = alignment * _AREA_SCALE * share * _alignment_weights(aniso)
    tX = -(p ** 4)
    wY = wX.copy()
    tY = np.zeros(m, dtype=complex)
    accX = wX * tX
    if align_boundary and len(dg.bface):
        t = to_complex(V[dg.bb] - V[dg.ba], fr, dg.bface)
        t = t / np.abs(t)
        wb = np.full(len(t), boundary_weight)
        wX = wX + np.bincount(dg.bface, weights=wb, minlength=m)
        wY = wY + np.bincount(dg.bface, weights=wb, minlength=m)
        bt = -(t ** 4) * wb
        accX = accX + np.bincount(dg.bface, weights=bt.real, minlength=m) + 1j * np.bincount(
            dg.bface, weights=bt.imag, minlength=m)
    pinX = pinY = None
    accY = wY * tY
    if cons is not None:
        cf, cX, cY = cons
        if constraint_weight is None:
            pinX, pinY = (cf, cX), (cf, cY)
        else:
            wX[cf] += constraint_weight
            wY[cf] += constraint_weight
            accX[cf] += constraint_weight * cX
            accY[cf] += constraint_weight * cY
    return wX, accX, wY, accY, pinX, pinY


# ----------------------------------------------------------------------------------------------
# conjugate field

_GRID = 24  # samples of the first direction's angle in a cold local step (7.5°), then refinements
_CHUNK = 8192  # faces per block in the local step (bounds the temporaries: 2 MB arrays, fastest at 20k and 200k)
_OFFSETS = np.linspace(-1.0, 1.0, 7)  # refinement samples around the best one, in steps of the level
_MID = 3  # the offset 0: the best sample itself, stored last in a refinement (its cost is known)
_AROUND = np.delete(_OFFSETS, _MID)  # the other offsets, stored first
_LEVEL_ORDER = np.argsort(np.append(_AROUND, _OFFSETS[_MID]), kind="stable")  # the stored rows in the order of
# _OFFSETS
_ROUND = 1e-10  # the local step's inputs are rounded to this (see _local_step)


def _round_unit(z: np.ndarray) -> np.ndarray:
    """Complex numbers with both parts rounded to :data:`_ROUND`."""
    return np.round(z.real / _ROUND) * _ROUND + 1j * (np.round(z.imag / _ROUND) * _ROUND)


class _LocalStep(NamedTuple):
    """What the local step keeps over the iterations (rounded, see :func:`_local_step`)."""

    p: np.ndarray  # (m,) unit complex principal direction d1
    k1: np.ndarray  # (m,) principal curvatures divided by the larger magnitude
    k2: np.ndarray
    smin: float  # sin² of the smallest angle allowed between the two directions
    tface: np.ndarray  # (t,) faces with a tangent (boundary or constraint) term
    T2: np.ndarray  # (t,) the tangent's doubled angle relative to p (unit complex)
    tw: np.ndarray  # (t,) weight of the tangent term
    const: np.ndarray | None  # (m,) twice the tangent term on faces without a tangent (a constant); None: no term


def _local_step(p, k1, k2, min_angle: float, tau=None, tau_weight=10.0) -> _LocalStep:
    """The local step's fixed inputs, rounded to :data:`_ROUND`: unit complex directions, curvatures divided by the
    larger of the two first (the step only uses their ratio).

    The step samples the first direction's angle and keeps the best sample; two angles (``a`` and ``b(a)``)
    reach the same pair, and near an umbilic their costs tie to the last bits. Unrounded, the same surface
    scaled by 1000 or moved by 5e6 picked the other sample on ~2 % of the faces: pairs up to 3° apart, a
    different candidate. Rounded, the inputs (and so the samples and the winner) are the same; the varying inputs
    (the current pair and the previous angles) are rounded by :func:`_closest_conjugate`.
    """
    m = len(p)
    kmax = np.maximum(np.abs(k1), np.abs(k2))
    safe = np.where(kmax > 0, kmax, 1.0)
    k1 = np.round(k1 / safe / _ROUND) * _ROUND
    k2 = np.round(k2 / safe / _ROUND) * _ROUND
    p = _round_unit(p)
    tau_weight = np.broadcast_to(np.asarray(tau_weight, dtype=np.float64), (m,))
    tface = np.zeros(0, dtype=np.int64)
    T2 = np.zeros(0, dtype=complex)
    const = None
    if tau is not None:
        has = np.isfinite(tau)
        tface = np.flatnonzero(has)
        # on the whole arrays, as the step always did (a complex product of a subset can differ by an ulp)
        T2 = np.where(has, (np.where(has, _round_unit(np.where(has, tau, 0.0)), 0.0) * np.conj(p)) ** 2, 0.0)[has]
        # without a tangent the term is tau_weight · ½ (1 − max(0, 0)): the same constant for every sample (doubled,
        # as the costs, see _conjugate_cost)
        const = np.where(has, 0.0, tau_weight)
    return _LocalStep(p, k1, k2, float(np.sin(min_angle) ** 2), tface, T2,
                      np.ascontiguousarray(tau_weight[tface]), const)


class _Block(NamedTuple):
    """One block of faces of a local step: contiguous per-face inputs of :func:`_conjugate_cost`."""

    k1: np.ndarray
    k2: np.ndarray
    ar: np.ndarray  # doubled angle of the current first direction relative to p: real, imaginary part
    ai: np.ndarray
    br: np.ndarray  # the same for the second direction
    bi: np.ndarray
    smin: float
    const: np.ndarray | None  # twice the tangent term on faces without a tangent
    tf: np.ndarray  # block-local indices of the faces with a tangent
    tr: np.ndarray  # their doubled tangent angle (real, imaginary part) and weight
    ti: np.ndarray
    tw: np.ndarray


def _conjugate_cost(ca, sa, blk: _Block, want_swap: bool = False, out=None):
    """Twice the local-step cost of the pairs ``(a, b(a))`` for angles given by ``cos a, sin a`` ``(k, n)`` (``k``
    samples of the ``n`` faces of a block) (into ``out`` if given), or with ``want_swap`` only where the second
    assignment of the pair to ``(u, v)`` wins: ``cost, None`` or ``None, swap``.

    Written with in-place operations on a few ``(k, n)`` buffers (the step runs it tens of times on every face);
    every value is computed with the same operations in the same order as the plain formulas in the comments. The
    cost is doubled (its halvings left out: a doubling is exact, so the sums round alike and the doubled costs
    compare as the costs do, bit for bit).
    """
    x = np.multiply(sa, -blk.k2)  # x, y = −k2 sin a, k1 cos a
    y = np.multiply(ca, blk.k1)
    xx = x * x
    yy = y * y
    r2 = xx + yy
    if not r2.all():  # r2 = where(r2 > 0, r2, 1) (a sum of squares: 0 or more)
        np.copyto(r2, 1.0, where=r2 == 0.0)
    c2b = np.subtract(xx, yy, out=xx)  # doubled angle of b: (x² − y²) / r2, 2 x y / r2
    c2b /= r2
    s2b = np.multiply(x, 2.0, out=x)
    s2b *= y
    s2b /= r2
    c2a = np.multiply(ca, ca, out=yy)  # c2a, s2a = cos² a − sin² a, 2 cos a sin a
    t = np.multiply(sa, sa, out=r2)
    c2a -= t
    s2a = np.multiply(ca, 2.0, out=y)
    s2a *= sa
    u = np.empty_like(c2a)

    def pair(p, q, out):  # c2a p + s2a q
        np.multiply(c2a, p, out=out)
        np.multiply(s2a, q, out=u)
        out += u
        return out

    # 2 sin² of line angles = 1 − cos of doubled angles; both assignments of (a, b) to (α, β):
    # d1 = 2 − (c2a ar + s2a ai) − (c2b br + s2b bi), d2 = 2 − (c2a br + s2a bi) − (c2b ar + s2b ai)
    d1 = pair(blk.ar, blk.ai, np.empty_like(c2a) if out is None else out)
    np.subtract(2.0, d1, out=d1)
    e = np.multiply(c2b, blk.br)
    np.multiply(s2b, blk.bi, out=u)
    e += u
    d1 -= e
    d2 = pair(blk.br, blk.bi, e)
    np.subtract(2.0, d2, out=d2)
    np.multiply(c2b, blk.ar, out=t)
    np.multiply(s2b, blk.ai, out=u)
    t += u
    d2 -= t
    if want_swap:
        return None, np.less(d2, d1)
    D = np.minimum(d1, d2, out=d1)  # D = 2 · ½ min(d1, d2)
    # sep2 = 2 sep = 1 − (c2a c2b + s2a s2b); D += where(sep < smin, 2 (4 + (smin − sep)), 0)
    sep2 = np.multiply(c2a, c2b, out=d2)
    np.multiply(s2a, s2b, out=u)
    sep2 += u
    np.subtract(1.0, sep2, out=sep2)
    smin2 = 2.0 * blk.smin
    close = np.nonzero(sep2 < smin2)  # few samples (~1 %): the penalty on them only
    if len(close[0]):
        D[close] += (smin2 - sep2[close]) + 8.0
    if blk.const is not None:
        # tb = 0.5 (1 − max(c2a tr + s2a ti, c2b tr + s2b ti)); D += 2 tau_weight tb, on the faces with a tangent
        # (elsewhere the term is the constant 2 tau_weight / 2)
        D += blk.const
        if len(blk.tf):
            f = blk.tf
            ta = c2a[:, f] * blk.tr + s2a[:, f] * blk.ti
            tb = c2b[:, f] * blk.tr + s2b[:, f] * blk.ti
            np.maximum(ta, tb, out=ta)
            np.subtract(1.0, ta, out=ta)
            ta *= blk.tw
            D[:, f] += ta
    return D, None


def _block(ls: _LocalStep, lo: int, hi: int, A2: np.ndarray, B2: np.ndarray) -> _Block:
    """The faces ``lo:hi`` of a local step as a :class:`_Block` (``A2, B2``: the current pair's doubled angles on
    these faces)."""
    sel = (ls.tface >= lo) & (ls.tface < hi)
    T2 = ls.T2[sel]
    c = np.ascontiguousarray
    return _Block(ls.k1[lo:hi], ls.k2[lo:hi], c(A2.real), c(A2.imag), c(B2.real), c(B2.imag), ls.smin,
                  None if ls.const is None else ls.const[lo:hi], ls.tface[sel] - lo, c(T2.real), c(T2.imag),
                  ls.tw[sel])


def _columns(blk: _Block, cols: np.ndarray) -> _Block:
    """The faces ``cols`` (block-local indices) of a block."""
    pos = np.full(len(blk.k1), -1)
    pos[cols] = np.arange(len(cols))
    keep = pos[blk.tf] >= 0
    return _Block(blk.k1[cols], blk.k2[cols], blk.ar[cols], blk.ai[cols], blk.br[cols], blk.bi[cols], blk.smin,
                  None if blk.const is None else blk.const[cols], pos[blk.tf][keep], blk.tr[keep], blk.ti[keep],
                  blk.tw[keep])


_TIE = 2e-12  # doubled sample costs closer than this (costs within 1e-12) are recomputed from exact cosines
# (see _best_sample)


def _best_sample(a, ca, sa, D, blk: _Block, order=None) -> tuple[np.ndarray, np.ndarray]:
    """Per face (column), the row of the lowest-cost sample and its cost (``order``: the rows in sample order, which
    decides between equal costs as ``np.argmin`` over the rows in that order; None: as stored).

    The samples' cosines and sines are rotations (an ulp off ``np.cos``/``np.sin`` of the angles), and so are their
    costs. Two samples can tie exactly (``a`` and ``b(a)`` are the same pair), and then the last bit decides: on
    the faces whose two best (doubled) costs are within :data:`_TIE` the samples are recomputed from
    ``np.cos(a), np.sin(a)`` (in place), so the winner is the one exact cosines give (the margin is far above the few
    ulps, ~1e-15, by which a rotation moves a cost): the step picks the same samples as with ``np.cos`` everywhere,
    bit for bit.
    """
    order = np.arange(len(D)) if order is None else order
    j, low = _first_min(D, order)
    near = np.less_equal(D, low + _TIE).view(np.int8)
    tie = np.flatnonzero(near.sum(axis=0, dtype=np.int8) > 1)  # two or more samples within the margin
    if len(tie):
        at = a[:, tie]
        ca[:, tie] = np.cos(at)
        sa[:, tie] = np.sin(at)
        D[:, tie] = _conjugate_cost(ca[:, tie], sa[:, tie], _columns(blk, tie))[0]
        j[tie], low[tie] = _first_min(D[:, tie], order)
    return j, low


def _first_min(D: np.ndarray, order: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column of ``D`` (k, n), the row of the smallest value (the first in ``order`` among equal ones) and that
    value: ``np.argmin`` over the rows in ``order``, without its per-column loop (a column-wise minimum, then the
    equal rows ranked by weights)."""
    k = len(D)
    low = D.min(axis=0)
    if np.isnan(low).any():  # NaN costs (from NaN input): np.argmin's own rule
        j = order[np.argmin(D[order], axis=0)]
        return j, D[j, np.arange(D.shape[1])]
    rank = np.empty(k, dtype=np.uint8)
    rank[order] = np.arange(k, 0, -1)  # the first row in order weighs most
    row = np.empty(k + 1, dtype=np.intp)
    row[rank] = np.arange(k)
    top = (np.equal(D, low).view(np.uint8) * rank[:, None]).max(axis=0)
    return row.take(top), low


def _closest_conjugate(u, v, ls: _LocalStep, start=None):
    """Per face, the conjugate pair closest to the line pair ``(u, v)`` (unit complex in the face frame).

    The conjugate direction of ``a`` (angle from the principal direction ``p``) is ``b(a) = arg(−k2 sin a +
    i k1 cos a)``; the pair ``(a, b(a))`` minimizing ``sin²(a − α) + sin²(b − β)`` (either assignment) over pairs
    at least ``min_angle`` apart is found by sampling ``a`` and refining (the samples' cosines and sines are
    rotations of the best sample's, no trigonometric call per sample). ``start`` (previous optimum angles)
    replaces the coarse sampling by three candidates (the previous optimum and the two current directions). The
    tangent term of :func:`_local_step` adds ``tau_weight · sin²`` of the nearer direction's angle to a boundary
    tangent. Returns the pair and the optimal angles.

    The search runs on blocks of :data:`_CHUNK` faces (real arithmetic only); the complex products stay on whole
    arrays: numpy's complex product of a block can differ by an ulp from the same product in a whole-array
    operation, and the stages after the field turn such ulps into a different candidate.
    """
    m = len(u)
    u, v = _round_unit(u), _round_unit(v)
    p = ls.p
    pc = np.conj(p)
    zu = u * pc
    zv = v * pc
    A2 = zu ** 2  # doubled angles relative to the principal direction
    B2 = zv ** 2
    best = np.empty(m)
    swap = np.empty(m, dtype=bool)
    if start is not None:
        start = np.round(start / _ROUND) * _ROUND

    def search(lo):  # the blocks are independent: shared out among the threads
        hi = min(m, lo + _CHUNK)
        blk = _block(ls, lo, hi, A2[lo:hi], B2[lo:hi])
        best[lo:hi], swap[lo:hi] = _search(blk, zu[lo:hi], zv[lo:hi], None if start is None else start[lo:hi])

    for_each(search, range(0, m, _CHUNK))
    bcos, bsin = np.cos(best), np.sin(best)  # the pair from the optimal angle itself, not from a rotated sample
    ua = p * np.exp(1j * best)
    x, y = -ls.k2 * bsin, ls.k1 * bcos
    vb = p * (x + 1j * y)
    nb = np.abs(vb)
    vb = vb / np.where(nb > 0, nb, 1.0)
    if not (nb > 0).all():
        vb = np.where(nb > 0, vb, 1j * ua)
    pu = np.where(swap, vb, ua)
    pv = np.where(swap, ua, vb)
    # keep the orientation of the input vectors
    np.negative(pu, out=pu, where=(pu * np.conj(u)).real < 0)
    np.negative(pv, out=pv, where=(pv * np.conj(v)).real < 0)
    return pu, pv, np.mod(best, np.pi)


def _first_samples(zu, zv, start):
    """The first samples of a block's search: angles ``a`` (rows of samples, one column per face), their cosines
    and sines, and the first refinement step and level count. Cold (``start`` None): :data:`_GRID` angles over
    ``[0, π)``; warm: the previous best angle and the current pair's (``arg zu``, ``arg zv``)."""
    n = len(zu)
    if start is None:
        a = np.repeat((np.arange(_GRID) * (np.pi / _GRID))[:, None], n, axis=1)
        return a, np.cos(a), np.sin(a), np.pi / _GRID, 3
    # the rows start, arg zu, arg zv (np.angle is this arctan2), their cosines and sines
    a, ca, sa = (np.empty((3, n)) for _ in range(3))
    a[0] = start
    np.cos(start, out=ca[0])
    np.sin(start, out=sa[0])
    for r, z in ((1, zu), (2, zv)):
        np.arctan2(z.imag, z.real, out=a[r])
        az = np.abs(z)
        np.divide(z.real, az, out=ca[r])
        np.divide(z.imag, az, out=sa[r])
    return a, ca, sa, np.pi / 90.0, 2


@functools.lru_cache(maxsize=4)
def _level_offsets(step: float, levels: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The refinement offsets ``(levels, k)`` of the search from its first step (each level a third of the one
    before), and their cosines and sines."""
    out = np.empty((3, levels, len(_AROUND)))
    for lev in range(levels):
        d = (step * _AROUND)[:, None]
        out[0, lev], out[1, lev], out[2, lev] = d[:, 0], np.cos(d)[:, 0], np.sin(d)[:, 0]
        step /= 3.0
    return out[0], out[1], out[2]


def _search(blk: _Block, zu, zv, start):
    """The best angle ``a`` of a block's faces and whether the pair's second assignment wins (``zu, zv``: the
    current pair relative to ``p``; ``start``: the previous best angles or None): compiled where numba is
    installed (:mod:`components.fields.conjugate_kernels`, the same results bit for bit), else
    :func:`_search_numpy`."""
    if kernels.search is None:
        return _search_numpy(blk, zu, zv, start)
    a, ca, sa, step, levels = _first_samples(zu, zv, start)
    f8 = functools.partial(np.ascontiguousarray, dtype=np.float64)  # the kernels' types (no copy: they are)
    const = np.zeros(len(zu)) if blk.const is None else f8(blk.const)
    faces = tuple(f8(x) for x in (blk.k1, blk.k2, blk.ar, blk.ai, blk.br, blk.bi))
    b, odd = kernels.search(*faces, float(blk.smin), const, np.ascontiguousarray(blk.tf, dtype=np.int64),
                            f8(blk.tr), f8(blk.ti), f8(blk.tw), f8(a), f8(ca), f8(sa), *_level_offsets(step, levels),
                            _TIE)
    swap = kernels.swaps(np.cos(b), np.sin(b), *faces)
    odd = np.flatnonzero(odd)
    if len(odd):  # samples within the tie margin, or NaN costs: the numpy search's own rules settle them
        b[odd], swap[odd] = _search_numpy(_columns(blk, odd), zu[odd], zv[odd], None if start is None else start[odd])
    return b, swap


def _search_numpy(blk: _Block, zu, zv, start):
    """:func:`_search` in numpy (the reference of the compiled kernels)."""
    n = len(zu)
    cols = np.arange(n)
    a, ca, sa, step, levels = _first_samples(zu, zv, start)
    D, _ = _conjugate_cost(ca, sa, blk)
    j, bD = _best_sample(a, ca, sa, D, blk)
    at = j * n + cols  # the best sample's flat index
    b, bc, bs = a.take(at), ca.take(at), sa.take(at)
    a, ca, sa, D = (np.empty((len(_OFFSETS), n)) for _ in range(4))
    k = len(_AROUND)
    for d, cd, sd in zip(*(x[:, :, None] for x in _level_offsets(step, levels))):
        # the samples b + step · offset in the first rows; the last row is b itself (offset 0), its cost is known
        np.add(b[None, :], d, out=a[:k])
        np.subtract(np.multiply(bc, cd, out=ca[:k]), bs * sd, out=ca[:k])  # cos, sin of b + d
        np.add(np.multiply(bs, cd, out=sa[:k]), bc * sd, out=sa[:k])
        a[k], ca[k], sa[k] = b, bc, bs
        _conjugate_cost(ca[:k], sa[:k], blk, out=D[:k])
        D[k] = bD
        j, bD = _best_sample(a, ca, sa, D, blk, _LEVEL_ORDER)
        at = j * n + cols
        b, bc, bs = a.take(at), ca.take(at), sa.take(at)
    swap = _conjugate_cost(np.cos(b)[None, :], np.sin(b)[None, :], blk, want_swap=True)[1][0]
    return b, swap


def _line_angle(a, b) -> np.ndarray:
    """Angle (radians, in ``[0, π/2]``) between the lines of unit complex directions ``a`` and ``b``."""
    return np.abs(np.angle((a * np.conj(b)) ** 2)) / 2.0


def _pair_deviation(pu, pv, u, v) -> np.ndarray:
    """Largest angle (radians) between the lines of a pair ``(pu, pv)`` and the nearer lines of ``(u, v)``."""
    line = _line_angle
    return np.maximum(np.minimum(line(pu, u), line(pu, v)), np.minimum(line(pv, v), line(pv, u)))


def _boundary_tangents(V, dg: DualGraph, fr: FaceFrames, m: int) -> np.ndarray:
    """Unit complex tangent of a boundary edge per face (NaN where none; the last edge wins at corners)."""
    tau = np.full(m, np.nan + 0j)
    if len(dg.bface):
        t = to_complex(V[dg.bb] - V[dg.ba], fr, dg.bface)
        tau[dg.bface] = t / np.abs(t)
    return tau


def _conjugacy_weights(cv: FieldCurvature) -> np.ndarray:
    """Importance of conjugacy per face: curvature magnitude squared relative to its mean, capped at 1."""
    s = np.abs(cv.k1) + np.abs(cv.k2)
    ref = float(np.mean(s * s)) if len(s) else 0.0
    if ref <= 0:
        return np.zeros_like(s)
    return np.minimum(1.0, s * s / ref)


@single_blas_thread()  # sparse factorizations: see components.core.blas
def conjugate_frame_field(V: np.ndarray, T: np.ndarray, U0: np.ndarray, W0: np.ndarray, smoothness: float = 1.0,
                    iterations: int = 40, conjugacy_weight: float = 3.0, closeness: float = 0.01,
                    min_angle: float = np.radians(25.0), align_boundary: bool = True, constraints=None,
                    curvature: FieldCurvature | None = None, curvature_radius: int = 2,
                    release_angle: float | None = np.radians(20.0),
                    release_separation: float = np.radians(45.0), diagnostics: bool = True) -> Field:
    """Conjugate direction field near a given field: local-global alternation of Liu et al. 2011.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles: oriented, edge-manifold, open boundaries and holes allowed.
    U0, W0 : (m, 3) float64
        Starting field per face (typically :func:`smooth_frame_field`'s ``U, W``).
    smoothness : float
        Weight of the PolyVector smoothness energy (> 0). Larger = smoother, fewer singularities, less conjugate.
    iterations : int
        Number of local-global iterations (1 to 200). The alternation converges slowly; on ``inspired_mesh.obj``
        the extracted quads' mean planarity went 2.6e-3 → 2.5e-3 from 20 to 40 iterations.
    conjugacy_weight : float
        Weight of the pull towards the per-face closest conjugate pairs (area-share weighted, × curvature
        importance, as ``alignment`` in :func:`smooth_frame_field`).
    closeness : float
        Weight of the pull towards the starting field (area-share weighted).
    min_angle : float
        Smallest angle (radians) allowed between the two directions of a face (conjugate pairs can collapse
        onto an asymptotic direction on saddles).
    align_boundary : bool
        On faces with a boundary edge prefer the conjugate pair one of whose directions follows the boundary.
    constraints : (faces, directions), optional
        As in :func:`smooth_frame_field`: with one direction per face ``(c, 3)`` the face keeps the conjugate pair
        containing it (when the angle bound allows); with two ``(c, 2, 3)`` the face keeps the given pair.
    curvature : FieldCurvature, optional
        Per-face shape operator (:func:`field_curvature`), computed when omitted.
    curvature_radius : int
        Ring size of the curvature fit when ``curvature`` is omitted.
    release_angle : float or None
        After the iterations, faces whose closest conjugate pair lies more than this angle (radians) from the
        smoothed pair are released from conjugacy (keep the smoothed pair) and ``iterations // 4`` more
        iterations run without them. Near parabolic lines every conjugate pair collapses towards the asymptotic
        direction and the pair there is either squeezed to ``min_angle`` or jumps to the other branch; forcing it
        folds the field and the parametrization (inverted triangles, stretched panels). ``None``: never release.
        The released faces are returned in ``Field.released``.
    release_separation : float
        With ``release_angle`` set, faces whose closest conjugate pair is narrower than this angle (radians) are
        released too. Where a pair narrows (towards a parabolic line, conjugate partners close in on the
        asymptotic direction) the pair turns quickly from face to face: the field is far from integrable there
        and the parametrization compresses or folds (on the ``wave`` sample: pairs down to the 25° bound, eight
        singularities instead of two, stretched rows of panels along the boundary; 0 disables).
    diagnostics : bool
        Compute the singularities and the alignment and conjugacy errors (False: ``None``, for callers that only
        use the directions).

    Returns
    -------
    Field
        Combed conjugate ``U, W`` (each face's pair is the closest conjugate pair to the smoothed PolyVector),
        singularities, alignment and conjugacy errors.

    Raises
    ------
    MeshError
        Non-triangle, degenerate or non-manifold mesh.
    InputError
        ``U0, W0`` of the wrong shape or with zero vectors; weights or counts out of range.

    Notes
    -----
    Liu et al. 2011 (and libigl's ``conjugate_frame_fields``): the local step replaces every face's pair by the
    closest pair conjugate w.r.t. the face's shape operator (``II(u, v) = 0``, here a 1-D search over the first
    direction, the second being ``S u``'s orthogonal); the global step minimizes the PolyVector smoothness energy
    plus the pull towards those pairs and towards the start field — one factorization for all iterations. The
    faces whose curvature is small get a small conjugacy weight (conjugacy does not matter there). The conjugacy
    error reported is ``|II(U, W)| / (|k1| + |k2|)``.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(8, 8, height=lambda x, y: 0.5 * x * x - 0.2 * y * y + 0.3 * x * y)
    >>> T = triangulate(Q)[0]
    >>> s = smooth_frame_field(V, T)
    >>> c = conjugate_frame_field(V, T, s.U, s.W)
    >>> float(c.conjugacy_error.mean()) < float(s.conjugacy_error.mean())
    True
    """
    V, T = validate_mesh(V, T, name="mesh", kind="tri")
    m = len(T)
    U0, W0 = check_field(U0, W0, m, names=("U0", "W0"))
    smoothness, iterations, conjugacy_weight, closeness, min_angle, release_angle, release_separation = \
        _conjugate_options(smoothness, iterations, conjugacy_weight, closeness, min_angle, release_angle,
                           release_separation)
    fr, dg = _frames(V, T)
    cv = _curvature_arg(curvature, V, T, check_int(curvature_radius, "curvature_radius", 1, 6), m)
    pb = _conjugate_problem(V, U0, W0, fr, dg, cv, smoothness, closeness, min_angle, align_boundary, constraints)
    wc = conjugacy_weight * _AREA_SCALE * (fr.area / float(fr.area.sum())) * _conjugacy_weights(cv)
    active = _conjugacy_weights(cv) > 0
    u, v, step = _local_global(pb, pb.u0, pb.v0, None, wc, active, iterations)
    released = np.zeros(m, dtype=bool)
    if release_angle is not None:
        released, active, u, v, step = _release(pb, u, v, step, wc, active, max(1, iterations // 4),
                                                release_angle, release_separation)
    pu, pv, _ = step
    u = np.where(active, pu, u)
    v = np.where(active, pv, v)
    if pb.fixed is not None:
        u[pb.fixed[0]], v[pb.fixed[0]] = pb.fixed[1], pb.fixed[2]
    fld = _finish(V, T, u, v, fr, dg, cv, pb.aniso, diagnostics)._replace(released=released)
    if diagnostics:
        log.debug("conjugate_frame_field: %d faces, %d singularities, mean conjugacy error %.2e, %d released", m,
                  len(fld.singularities), float(fld.conjugacy_error.mean()), int(released.sum()))
    return fld


def _conjugate_options(smoothness, iterations, conjugacy_weight, closeness, min_angle, release_angle,
                       release_separation):
    """The numeric options of :func:`conjugate_frame_field`, checked."""
    smoothness = check_number(smoothness, "smoothness", 0, above=True)
    iterations = check_int(iterations, "iterations", 1, 200)
    conjugacy_weight = check_number(conjugacy_weight, "conjugacy_weight", 0, above=True)
    closeness = check_number(closeness, "closeness", 0)
    min_angle = check_number(min_angle, "min_angle", 0)
    if release_angle is not None:
        release_angle = check_number(release_angle, "release_angle", 0)
    release_separation = check_number(release_separation, "release_separation", 0)
    if min_angle >= 0.5 * np.pi:
        raise InputError("min_angle", f"must be below π/2, got {min_angle!r}")
    return smoothness, iterations, conjugacy_weight, closeness, min_angle, release_angle, release_separation


class _ConjugateProblem(NamedTuple):
    """What the local-global iterations of :func:`conjugate_frame_field` share."""

    aniso: np.ndarray  # (m,) curvature anisotropy
    ls: _LocalStep  # the local step's fixed inputs: principal directions and curvatures, angle bound, tangents
    fixed: tuple | None  # (faces, u, v): faces whose pair is prescribed
    u0: np.ndarray  # (m,) unit complex start pair
    v0: np.ndarray
    X0: np.ndarray  # (m,) PolyVector coefficients of the start pair
    Y0: np.ndarray
    w0: np.ndarray  # (m,) pull to the start field
    LX: sp.csr_matrix  # smoothness-weighted connection Laplacians of X (degree 4) and Y (degree 2)
    LY: sp.csr_matrix


def _conjugate_problem(V, U0, W0, fr: FaceFrames, dg: DualGraph, cv: FieldCurvature, smoothness: float,
                       closeness: float, min_angle: float, align_boundary: bool, constraints) -> _ConjugateProblem:
    """Boundary tangents, constraints, start pair and smoothness operators of :func:`conjugate_frame_field`."""
    m = len(fr.area)
    tau = _boundary_tangents(V, dg, fr, m) if align_boundary else None
    tau_w = np.full(m, _TANGENT_WEIGHT)
    fixed = None
    if constraints is not None:
        cf, cdir = _constraint_directions(constraints, m, fr)
        if cdir.shape[1] == 1:
            tau = np.full(m, np.nan + 0j) if tau is None else tau
            tau[cf] = cdir[:, 0]
            tau_w[cf] = 1000.0
        else:
            fixed = (cf, cdir[:, 0], cdir[:, 1])
    u0 = to_complex(U0, fr)
    v0 = to_complex(W0, fr)
    u0, v0 = u0 / np.abs(u0), v0 / np.abs(v0)
    if np.any(np.abs(u0) == 0) or np.any(np.abs(v0) == 0) or not np.isfinite(u0).all():
        raise InputError("U0", "vectors must not be normal to their faces")
    X0, Y0 = _poly(u0, v0)
    w0 = closeness * _AREA_SCALE * (fr.area / float(fr.area.sum()))
    LX = smoothness * _connection_laplacian(dg, m, 4)
    LY = smoothness * _connection_laplacian(dg, m, 2)
    ls = _local_step(_principal_complex(cv, fr), cv.k1, cv.k2, min_angle, tau, tau_w)
    return _ConjugateProblem(_anisotropy(cv), ls, fixed, u0, v0, X0, Y0, w0, LX, LY)


def _local_global(pb: _ConjugateProblem, u, v, step, wc: np.ndarray, active: np.ndarray, count: int):
    """``count`` alternations: closest conjugate pairs on the active faces, then the smoothing solve.

    ``step`` is the local step at ``u, v`` (pairs and angles, as :func:`_closest_conjugate` returns them) when known,
    None for a cold start. Returns the final ``u, v`` and the local step at them (the first of a next run).
    """
    d = sp.diags((wc + pb.w0).astype(complex))
    luX, luY = concurrently(lambda: _factor(pb.LX + d), lambda: _factor(pb.LY + d))
    bX, bY = pb.w0 * pb.X0, pb.w0 * pb.Y0  # the start field's pull, the same in every solve
    every = bool(active.all())
    for _ in range(count):
        pu, pv, a = _closest_conjugate(u, v, pb.ls) if step is None else step
        if not every:
            pu = np.where(active, pu, u)
            pv = np.where(active, pv, v)
        if pb.fixed is not None:
            pu[pb.fixed[0]], pv[pb.fixed[0]] = pb.fixed[1], pb.fixed[2]
        Xp, Yp = _poly(pu, pv)
        X, Y = concurrently(lambda: luX.solve(wc * Xp + bX), lambda: luY.solve(wc * Yp + bY))
        u, v = _roots(X, Y)
        step = _closest_conjugate(u, v, pb.ls, start=a)
    return u, v, step


def _release(pb: _ConjugateProblem, u, v, step, wc: np.ndarray, active: np.ndarray, count: int,
             release_angle: float, release_separation: float):
    """Release the faces whose closest conjugate pair (of the local ``step`` at ``u, v``) is far from the smoothed
    pair and re-run ``count`` iterations without them: ``released, active, u, v, step``.

    Such faces (parabolic lines, where conjugate pairs collapse onto the asymptotic direction, or a jump to the
    other branch) would fold the field: they are released from conjugacy and the global step re-run so the field
    passes them smoothly; faces that are far after the re-run are released too.
    """
    released = _far_faces(pb, step[0], step[1], u, v, active, release_angle, release_separation)
    if released.any():
        wc = np.where(released, 0.0, wc)
        active = active & ~released
        u, v, step = _local_global(pb, u, v, step, wc, active, count)
        late = _far_faces(pb, step[0], step[1], u, v, active, release_angle, release_separation)
        released |= late
        active = active & ~late
    return released, active, u, v, step


def _far(pu, pv, u, v, release_angle: float, release_separation: float) -> np.ndarray:
    """Faces whose closest conjugate pair ``pu, pv`` is beyond the release angle from the pair ``u, v`` or narrower
    than the release separation."""
    return (_pair_deviation(pu, pv, u, v) > release_angle) | (_line_angle(pu, pv) < release_separation)


def _far_faces(pb: _ConjugateProblem, pu, pv, u, v, active: np.ndarray, release_angle: float,
               release_separation: float) -> np.ndarray:
    """Active faces (not user-fixed) whose closest conjugate pair is beyond the release angle or narrower than the
    release separation."""
    out = active & _far(pu, pv, u, v, release_angle, release_separation)
    if pb.fixed is not None:
        out[pb.fixed[0]] = False
    return out


# ----------------------------------------------------------------------------------------------
# a field computed on a coarser mesh of the same surface

def transferred_field(V: np.ndarray, T: np.ndarray, Vc: np.ndarray, Tc: np.ndarray, Uc: np.ndarray,
                      Wc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A field ``Uc, Wc`` of a coarse mesh ``(Vc, Tc)`` carried to a finer mesh ``(V, T)`` of the same surface.

    The coarse pairs' PolyVector coefficients are averaged at the coarse vertices (area-weighted, each face's
    turned into the vertex's tangent frame), then every fine face takes the linear interpolation of its closest
    coarse point's three vertex coefficients, turned into its own frame. The result is continuous over the coarse
    mesh: a fine face whose closest point lies on a coarse edge gets the same pair from either side (a nearest-face
    copy made a rounding tie between the two faces a visible choice: the same mesh in mm and m got fields 1.5°
    apart). Returns the combed unit ``U, W`` per fine face. Both meshes validated.
    """
    frc = face_frames(Vc, Tc)
    u, v = to_complex(Uc, frc), to_complex(Wc, frc)
    au, av = np.abs(u), np.abs(v)
    u, v = np.where(au > 0, u / np.where(au > 0, au, 1.0), 1.0), np.where(av > 0, v / np.where(av > 0, av, 1.0), 1j)
    Xc, Yc = _poly(u, v)
    # vertex frames: the area-weighted normal, and the first incident face's first axis laid into its plane
    nc, mc = len(Vc), len(Tc)
    N = np.zeros((nc, 3))
    for j in range(3):
        np.add.at(N, Tc[:, j], frc.n * frc.area[:, None])
    n_v = unit(N)
    first = np.full(nc, mc, dtype=np.int64)
    for j in range(3):
        np.minimum.at(first, Tc[:, j], np.arange(mc))
    e1_v = unit(_in_plane(frc.e1[first], n_v))
    e2_v = np.cross(n_v, e1_v)
    # the faces' coefficients averaged at their corners' vertices, each turned by its axis's angle there
    corner_v = Tc.ravel()
    corner_f = np.repeat(np.arange(mc), 3)
    p = _in_plane(frc.e1[corner_f], n_v[corner_v])
    turn = np.exp(1j * np.arctan2(np.einsum("ij,ij->i", p, e2_v[corner_v]), np.einsum("ij,ij->i", p, e1_v[corner_v])))
    w = frc.area[corner_f] / np.bincount(corner_v, frc.area[corner_f], nc)[corner_v]  # the weights sum to 1
    Xv, Yv = (np.bincount(corner_v, (w * Z).real, nc) + 1j * np.bincount(corner_v, (w * Z).imag, nc)
              for Z in (Xc[corner_f] * turn ** 4, Yc[corner_f] * turn ** 2))  # (X, Y scaled alike move the roots)
    # every fine face: the coarse vertices' coefficients at its centroid's closest point, in its frame
    fr, dg = _frames(V, T)
    q = TriangleIndex(Vc, Tc).query(fr.centroid)
    X = np.zeros(len(T), dtype=complex)
    Y = np.zeros(len(T), dtype=complex)
    for j in range(3):
        vj = Tc[q.faces, j]
        p = _in_plane(e1_v[vj], fr.n)
        turn = np.exp(1j * np.arctan2(np.einsum("ij,ij->i", p, fr.e2), np.einsum("ij,ij->i", p, fr.e1)))
        X += q.barycentric[:, j] * Xv[vj] * turn ** 4
        Y += q.barycentric[:, j] * Yv[vj] * turn ** 2
    u, v = _roots(X, Y)
    fld = _finish(V, T, u, v, fr, dg, None, None, diagnostics=False)
    return np.asarray(fld.U, dtype=np.float64), np.asarray(fld.W, dtype=np.float64)


def closest_conjugate_pairs(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray,
                            curvature: FieldCurvature | None = None, min_angle: float = np.radians(25.0),
                            align_boundary: bool = True, release_angle: float = np.radians(20.0),
                            release_separation: float = np.radians(45.0)) -> tuple[np.ndarray, np.ndarray]:
    """Every face's closest conjugate pair to the field ``U, W`` (the last local step of
    :func:`conjugate_frame_field`, its options alike), where conjugacy matters (curved faces) and the pair is
    within ``release_angle`` of the field and ``release_separation`` wide; elsewhere the field's own pair. A
    smooth field made conjugate face by face, as :func:`conjugate_frame_field` returns its last smoothed field
    (here: a coarse copy's conjugate field carried over by :func:`transferred_field`). Returns unit ``U, W``."""
    V, T = validate_mesh(V, T, name="mesh", kind="tri")
    m = len(T)
    U, W = check_field(U, W, m)
    fr, dg = _frames(V, T)
    cv = _curvature_arg(curvature, V, T, 2, m)
    ls = _local_step(_principal_complex(cv, fr), cv.k1, cv.k2, min_angle,
                     _boundary_tangents(V, dg, fr, m) if align_boundary else None, np.full(m, _TANGENT_WEIGHT))
    u, v = to_complex(U, fr), to_complex(W, fr)
    u, v = u / np.abs(u), v / np.abs(v)
    pu, pv, _ = _closest_conjugate(u, v, ls)
    keep = (_conjugacy_weights(cv) > 0) & ~_far(pu, pv, u, v, release_angle, release_separation)
    fld = _finish(V, T, np.where(keep, pu, u), np.where(keep, pv, v), fr, dg, cv, None, diagnostics=False)
    return np.asarray(fld.U, dtype=np.float64), np.asarray(fld.W, dtype=np.float64)


def _in_plane(X: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Rows of ``X`` with their components along the unit rows of ``n`` removed."""
    return X - np.einsum("ij,ij->i", X, n)[:, None] * n


# ----------------------------------------------------------------------------------------------
# published components


def _display_lines(V, T, U, W):
    C = (V[T[:, 0]] + V[T[:, 1]] + V[T[:, 2]]) / 3.0
    E = np.concatenate([V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 1]], V[T[:, 0]] - V[T[:, 2]]])
    h = 0.25 * float(np.mean(np.linalg.norm(E, axis=1)))
    return np.stack([C - h * U, C + h * U], axis=1), np.stack([C - h * W, C + h * W], axis=1)


def _published_mesh(mesh) -> tuple[np.ndarray, np.ndarray]:
    V, F = check_mesh(mesh)
    T, _ = triangulate(F)
    return V, T


def _singularity_warnings(fld: Field, m: int) -> list[str]:
    out = []
    k = len(fld.singularities)
    if k > max(20, m // 500):
        out.append(f"the field has {k} singularities: lower 'alignment' for a smoother field")
    return out


class SmoothFieldResult(NamedTuple):
    u: Vectors
    w: Vectors
    singularities: Points
    singularity_index: Numbers
    lines_u: Lines
    lines_w: Lines
    alignment_error: Numbers
    singularity_count: int
    mean_alignment_error: float
    warnings: list[str]


def smooth_field(mesh: Mesh, alignment: float = 0.1, align_boundary: bool = True) -> SmoothFieldResult:
    """Smooth cross field on a mesh, softly aligned to the principal curvature directions (4-PolyVector).

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``; polygons are fan-triangulated, open boundaries and holes are allowed. The
        field lives on the triangles.
    alignment : float
        Pull towards the principal curvature directions where the curvature is anisotropic (≥ 0). Lower =
        smoother with fewer singularities (0.01), higher = closer to the principal directions (1–10).
    align_boundary : bool
        Align one field direction with the boundary on boundary triangles.

    Returns
    -------
    u : Vectors
        First field direction per triangle (unit, combed).
    w : Vectors
        Second field direction per triangle (unit, counter-clockwise from ``u``).
    singularities : Points
        Singular vertices of the field.
    singularity_index : Numbers
        Index of each singularity (multiples of 1/4: +1/4 behaves like a valence-3 vertex, −1/4 like valence 5).
    lines_u : Lines
        Short segments along ``u`` at the triangle centroids, for display.
    lines_w : Lines
        Short segments along ``w`` at the triangle centroids.
    alignment_error : Numbers
        Per triangle, angle (radians) between the field and the principal directions.
    singularity_count : int
        Number of singular vertices.
    mean_alignment_error : float
        Mean of ``alignment_error`` over the triangles whose curvature is clearly anisotropic (anisotropy > 0.5),
        radians (0 when there are none).

    Raises
    ------
    MeshError
        The mesh is malformed, degenerate or non-manifold.
    InputError
        ``alignment`` is negative or not a number.

    Notes
    -----
    Diamanti, Vaxman, Panozzo & Sorkine-Hornung 2014 (N-PolyVector fields); see :func:`smooth_frame_field`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = smooth_field(quad_grid(6, 6, height=lambda x, y: 0.3 * x * y), alignment=0.1)
    >>> res.u.shape, res.lines_u.shape
    ((72, 3), (72, 2, 3))
    """
    V, T = _published_mesh(mesh)
    fld = smooth_frame_field(V, T, alignment=alignment, align_boundary=bool(align_boundary))
    lu, lw = _display_lines(V, T, fld.U, fld.W)
    sel = fld.anisotropy > 0.5
    mean_err = float(fld.alignment_error[sel].mean()) if sel.any() else 0.0
    return SmoothFieldResult(fld.U, fld.W, V[fld.singularities], fld.singularity_index, lu, lw, fld.alignment_error,
                             len(fld.singularities), mean_err, _singularity_warnings(fld, len(T)))


class ConjugateFieldResult(NamedTuple):
    u: Vectors
    w: Vectors
    singularities: Points
    singularity_index: Numbers
    lines_u: Lines
    lines_w: Lines
    conjugacy_error: Numbers
    max_conjugacy_error: float
    mean_conjugacy_error: float
    singularity_count: int
    smooth_mean_conjugacy_error: float
    warnings: list[str]


def conjugate_field(mesh: Mesh, alignment: float = 0.1, smoothness: float = 1.0,
                              iterations: int = 20) -> ConjugateFieldResult:
    """Smooth conjugate direction field on a mesh: quads along it are planar to first order (Liu et al. 2011).

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``; polygons are fan-triangulated, open boundaries and holes are allowed. The
        field lives on the triangles.
    alignment : float
        Alignment of the starting smooth field to the principal directions (see the smooth field component).
    smoothness : float
        Weight of smoothness against conjugacy (> 0): higher = smoother field with fewer singularities.
    iterations : int
        Local-global iterations (1 to 200).

    Returns
    -------
    u : Vectors
        First field direction per triangle (unit, combed).
    w : Vectors
        Second field direction per triangle, conjugate to ``u`` (not orthogonal in general).
    singularities : Points
        Singular vertices of the field.
    singularity_index : Numbers
        Index of each singularity (multiples of 1/4).
    lines_u : Lines
        Short segments along ``u`` at the triangle centroids, for display.
    lines_w : Lines
        Short segments along ``w`` at the triangle centroids.
    conjugacy_error : Numbers
        Per triangle ``|II(u, w)| / (|k1| + |k2|)`` (scale-free, 0 = conjugate).
    max_conjugacy_error : float
        Largest ``conjugacy_error``.
    mean_conjugacy_error : float
        Mean ``conjugacy_error``.
    singularity_count : int
        Number of singular vertices.
    smooth_mean_conjugacy_error : float
        Mean conjugacy error of the starting smooth field, for comparison.

    Raises
    ------
    MeshError
        The mesh is malformed, degenerate or non-manifold.
    InputError
        A weight or the iteration count is out of range.

    Notes
    -----
    Y. Liu et al., "General planar quadrilateral mesh design using conjugate direction field", SIGGRAPH Asia 2011:
    local-global alternation between the closest conjugate pair per triangle and a PolyVector smoothing solve
    (Diamanti et al. 2014); see :func:`conjugate_frame_field`.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> res = conjugate_field(quad_grid(8, 8, height=lambda x, y: 0.5 * x * x - 0.2 * y * y + 0.3 * x * y))
    >>> res.mean_conjugacy_error < res.smooth_mean_conjugacy_error
    True
    """
    V, T = _published_mesh(mesh)
    smoothness = check_number(smoothness, "smoothness", 0, above=True)
    iterations = check_int(iterations, "iterations", 1, 200)
    cv = field_curvature(V, T)
    s = smooth_frame_field(V, T, alignment=alignment, curvature=cv)
    fld = conjugate_frame_field(V, T, s.U, s.W, smoothness=smoothness, iterations=iterations, curvature=cv)
    lu, lw = _display_lines(V, T, fld.U, fld.W)
    err = fld.conjugacy_error
    return ConjugateFieldResult(fld.U, fld.W, V[fld.singularities], fld.singularity_index, lu, lw, err,
                                float(err.max()), float(err.mean()), len(fld.singularities),
                                float(s.conjugacy_error.mean()), _singularity_warnings(fld, len(T))
                                + _release_warnings(fld, len(T)))


def _release_warnings(fld: Field, m: int) -> list[str]:
    k = 0 if fld.released is None else int(np.count_nonzero(fld.released))
    if not k:
        return []
    return [f"{k} of {m} triangles keep the smooth pair instead of a conjugate one (their closest conjugate pair "
            f"would fold the field or be too narrow: parabolic lines or a branch jump); conjugacy_error shows them"]
