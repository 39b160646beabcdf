"""Streamlines of a face-based 4-fold direction field: RK4 tracing on the surface, evenly spaced seeding.

A streamline of family 0 (``U``) or 1 (``W``) is integrated with the classical Runge–Kutta scheme inside each
triangle, in the triangle's own plane (2D complex coordinates), and continued across edges into the neighbour:
the point is carried over exactly (it lies on the shared edge), the direction is rotated by the edge's angle in
the two frames (unfolding, i.e. discrete parallel transport), and the family whose vector in the new triangle is
most aligned with the current direction is followed (so a line follows ``U`` into a triangle where the combing
called it ``W``). Inside a triangle the field is interpolated linearly from corner vectors (the average of the
matched vectors of the triangles around each vertex), which is what RK4 integrates; a constant field gives exactly
straight lines. Tracing stops at the boundary, within a small radius of a singular vertex, when the line closes a
loop, after ``max_length``, or (evenly spaced mode) when it comes closer than ``separation · test_ratio`` to an
earlier line of the same family.

References
----------
B. Jobard, W. Lefer, "Creating evenly-spaced streamlines of arbitrary density", Visualization in Scientific
Computing 1997 (seeding at the separation distance, stopping at the test distance).
E. Zhang, K. Mischaikow, G. Turk, "Vector field design on surfaces", ACM TOG 25(4), 2006 (tracing across
triangles by unfolding).
"""
from __future__ import annotations

import logging
import math
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from components.core.checks import check_choice, check_int, check_mesh, check_number, validate_mesh
from components.core.errors import InputError
from components.core.mesh import triangulate
from components.core.proximity import TriangleIndex, closest_points
from components.core.types import Curves, Mesh, Points
from components.fields.field import conjugate_frame_field, field_curvature, smooth_frame_field
from components.fields.frames import check_field, dual_graph, face_frames, field_singularities

log = logging.getLogger(__name__)

__all__ = ["StreamlinesResult", "evenly_spaced_streamlines", "streamlines", "trace_streamlines"]

_MAX_POINTS = 2_000_000  # total polyline points a call may produce


# ----------------------------------------------------------------------------------------------
# the tracer: per-face data as Python lists of complex numbers (2D face coordinates)


def _dot3(a, b) -> float:
    """Cosine of the angle between two 3D vectors (lists)."""
    n = math.sqrt((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]))
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / n if n > 0 else 0.0


class _Tracer:
    """Precomputed per-face data and the scalar RK4 walker."""

    def __init__(self, V, T, U, W, singular, singular_radius):
        m = len(T)
        fr = face_frames(V, T)
        self.V, self.T, self.fr = V, T, fr
        dg = dual_graph(V, T, fr)
        # corner positions in the face frame (corner 0 at the origin)
        Z = np.zeros((m, 3), dtype=complex)
        for c in (1, 2):
            D = V[T[:, c]] - V[T[:, 0]]
            Z[:, c] = np.einsum("ij,ij->i", D, fr.e1) + 1j * np.einsum("ij,ij->i", D, fr.e2)
        self.Z = Z
        # neighbours across edge j (corner j → j+1) and the edge's index in the neighbour
        nbr = np.full((m, 3), -1, dtype=np.int64)
        nbe = np.full((m, 3), -1, dtype=np.int64)
        j_of = np.argmax(T[dg.f] == dg.a[:, None], axis=1)  # edge index of a → b in f
        jg = np.argmax(T[dg.g] == dg.b[:, None], axis=1)  # edge index of b → a in g
        nbr[dg.f, j_of], nbe[dg.f, j_of] = dg.g, jg
        nbr[dg.g, jg], nbe[dg.g, jg] = dg.f, j_of
        # face field vectors and corner vectors per family, in face coordinates
        u = np.einsum("ij,ij->i", U, fr.e1) + 1j * np.einsum("ij,ij->i", U, fr.e2)
        w = np.einsum("ij,ij->i", W, fr.e1) + 1j * np.einsum("ij,ij->i", W, fr.e2)
        u, w = u / np.abs(u), w / np.abs(w)
        self.face_vec = np.stack([u, w], axis=1)  # (m, 2)
        self.corner_vec = self._corner_vectors(V, T, U, W, fr)  # (m, 2, 3)
        self.singular = np.asarray(singular, dtype=np.int64)
        self.radius = float(singular_radius)
        near = np.zeros(m, dtype=bool)
        if len(self.singular) and self.radius > 0:
            P = V[self.singular]
            # faces with a corner within radius + longest edge of a singularity
            tree = cKDTree(P)
            elen = np.linalg.norm(V[T[:, 1]] - V[T[:, 0]], axis=1)
            reach = self.radius + float(np.max(elen)) * 2.0
            d, _ = tree.query(fr.centroid, distance_upper_bound=reach)
            near = np.isfinite(d)
        # flat Python lists (one container each: fast scalar access, nothing for the garbage collector to walk)
        self.m = m
        self.Zf = Z.ravel().tolist()  # corner c of face f: Zf[3 f + c]
        self.nbr = nbr.ravel().tolist()  # neighbour across edge j of face f: nbr[3 f + j]
        self.nbe = nbe.ravel().tolist()
        self.fvf = self.face_vec.ravel().tolist()  # face vector of family k: fvf[2 f + k]
        self.cvf = self.corner_vec.ravel().tolist()  # corner c of family k: cvf[6 f + 3 k + c]
        self.near = near.tolist()
        self.sing_pts = V[self.singular].tolist() if len(self.singular) else []
        self.of = V[T[:, 0]].ravel().tolist()  # frame origin, axes: [3 f + i]
        self.e1f = fr.e1.ravel().tolist()
        self.e2f = fr.e2.ravel().tolist()
        z1, z2 = Z[:, 1], Z[:, 2]
        self.den = (z1.real * z2.imag - z1.imag * z2.real).tolist()
        self._index = None

    def corner(self, f: int, c: int) -> complex:
        """Corner ``c`` of face ``f`` in the face's coordinates."""
        return self.Zf[3 * f + c]

    def face_vector(self, f: int, k: int) -> complex:
        """The unit field vector of family ``k`` in face ``f`` (face coordinates)."""
        return self.fvf[2 * f + k]

    @property
    def index(self) -> TriangleIndex:
        """Closest-point index of the mesh, built on first use and kept (every seeding step queries it)."""
        if self._index is None:
            self._index = TriangleIndex(self.V, self.T)
        return self._index

    @staticmethod
    def _corner_vectors(V, T, U, W, fr):
        """Per face corner, the mean of the vectors of the triangles around the corner's vertex matched to each of
        the face's two directions (sign-aligned, projected into the face plane)."""
        m = len(T)
        n = len(V)
        corner_v = T.ravel()
        corner_f = np.repeat(np.arange(m), 3)
        order = np.argsort(corner_v, kind="stable")
        starts = np.searchsorted(corner_v[order], np.arange(n + 1))
        deg = np.diff(starts)
        # pairs (corner k, face g around the corner's vertex)
        k = np.repeat(np.arange(3 * m), deg[corner_v])
        first = starts[corner_v[k]]
        pos = np.arange(len(k)) - np.repeat(np.cumsum(deg[corner_v]) - deg[corner_v], deg[corner_v])
        g = corner_f[order[first + pos]]
        f = corner_f[k]
        out = np.zeros((m, 2, 3), dtype=complex)
        cands = np.stack([U[g], W[g]], axis=1)  # (p, 2, 3)
        area = fr.area[g]
        for fam, X in enumerate((U, W)):
            ref = X[f]
            dots = np.einsum("pkj,pj->pk", cands, ref)
            pick = np.argmax(np.abs(dots), axis=1)
            sgn = np.sign(dots[np.arange(len(k)), pick])
            sgn[sgn == 0] = 1.0
            vec = cands[np.arange(len(k)), pick] * (sgn * area)[:, None]
            acc = np.zeros((3 * m, 3))
            for d in range(3):
                acc[:, d] = np.bincount(k, weights=vec[:, d], minlength=3 * m)
            acc = acc.reshape(m, 3, 3)
            z = np.einsum("fcj,fj->fc", acc, fr.e1) + 1j * np.einsum("fcj,fj->fc", acc, fr.e2)
            a = np.abs(z)
            own = np.einsum("ij,ij->i", X, fr.e1) + 1j * np.einsum("ij,ij->i", X, fr.e2)
            own = (own / np.abs(own))[:, None]
            # fall back to the face's own vector where the average cancels (around singularities)
            tot = np.bincount(k, weights=area, minlength=3 * m).reshape(m, 3)
            ok = a > 0.5 * tot
            out[:, fam, :] = np.where(ok, z / np.where(a > 0, a, 1.0), own)
        return out

    # -- scalar geometry

    def point3(self, f: int, z: complex) -> list:
        i = 3 * f
        o, a, b = self.of, self.e1f, self.e2f
        x, y = z.real, z.imag
        return [o[i] + x * a[i] + y * b[i], o[i + 1] + x * a[i + 1] + y * b[i + 1],
                o[i + 2] + x * a[i + 2] + y * b[i + 2]]

    def vector3(self, f: int, d: complex) -> list:
        i = 3 * f
        a, b = self.e1f, self.e2f
        x, y = d.real, d.imag
        return [x * a[i] + y * b[i], x * a[i + 1] + y * b[i + 1], x * a[i + 2] + y * b[i + 2]]

    def bary(self, f: int, z: complex):
        i = 3 * f
        z1, z2 = self.Zf[i + 1], self.Zf[i + 2]
        den = self.den[f]
        zr, zi = z.real, z.imag
        l1 = (zr * z2.imag - zi * z2.real) / den
        l2 = (z1.real * zi - z1.imag * zr) / den
        return 1.0 - l1 - l2, l1, l2

    def field(self, f: int, fam: int, z: complex, d: complex) -> complex:
        l0, l1, l2 = self.bary(f, z)
        i = 6 * f + 3 * fam
        c = self.cvf
        v = l0 * c[i] + l1 * c[i + 1] + l2 * c[i + 2]
        a = abs(v)
        if a < 1e-9:
            v = self.fvf[2 * f + fam]
            a = 1.0
        if (v * d.conjugate()).real < 0:
            v = -v
        return v / a

    def family_in(self, f: int, d: complex) -> int:
        u, w = self.fvf[2 * f], self.fvf[2 * f + 1]
        return 0 if abs((u * d.conjugate()).real) >= abs((w * d.conjugate()).real) else 1

    def near_singularity(self, f: int, p) -> bool:
        if not self.near[f]:
            return False
        r2 = self.radius * self.radius
        for s in self.sing_pts:
            dx, dy, dz = p[0] - s[0], p[1] - s[1], p[2] - s[2]
            if dx * dx + dy * dy + dz * dz < r2:
                return True
        return False

    def exit(self, f: int, z: complex, z2: complex):
        """First edge crossed by the segment ``z → z2`` leaving face ``f``: ``(t, edge j, s along edge)`` or None."""
        b0 = self.bary(f, z)
        b1 = self.bary(f, z2)
        tmin, cmin = 2.0, -1
        for c in range(3):
            if b1[c] < 0.0:
                a0 = max(b0[c], 0.0)
                t = a0 / (a0 - b1[c])
                if t < tmin:
                    tmin, cmin = t, c
        if cmin < 0:
            return None
        j = (cmin + 1) % 3
        lj = b0[j] + tmin * (b1[j] - b0[j])
        lk = b0[(j + 1) % 3] + tmin * (b1[(j + 1) % 3] - b0[(j + 1) % 3])
        s = lk / (lj + lk) if lj + lk > 0 else 0.5
        return tmin, j, min(max(s, 0.0), 1.0)

    def cross_edge(self, f: int, j: int, s: float, d: complex):
        """Carry the edge point and the direction into the neighbour across edge ``j``; None at the boundary."""
        g = self.nbr[3 * f + j]
        if g < 0:
            return None
        jg = self.nbe[3 * f + j]
        Z = self.Zf
        ef = Z[3 * f + (j + 1) % 3] - Z[3 * f + j]  # a → b in f
        za = Z[3 * g + (jg + 1) % 3]
        eg = Z[3 * g + jg] - za  # a → b in g
        r = eg / ef
        r = r / abs(r)
        zg = za + s * eg  # a + s (b − a)
        return g, zg, d * r

    # -- one streamline

    def trace(self, f: int, z: complex, fam: int, sign: float, step: float, max_length: float,
              stop=None, closing: bool = True, self_distance: float = 0.0, keep_family: bool = False):
        """Trace from ``(f, z)`` along family ``fam`` in direction ``sign``; returns (points, closed).

        ``stop(p, t)`` ends the line at a point; ``self_distance > 0`` ends it when it comes back (parallel) that
        close to its own earlier points (a spiral instead of a closed loop). ``keep_family``: the field's labels are
        global (principal directions ordered by curvature), so the line keeps family ``fam`` in every triangle and
        stops where that family turns by more than 45° from one triangle to the next (a label jump: an umbilic).
        The reason of the last stop is left in ``self.stop_reason``.
        """
        own = None
        lag = 0
        if self_distance > 0:
            own = _Grid(self_distance, parallel=math.cos(math.radians(20.0)))
            lag = int(math.ceil(3.0 * self_distance / step)) + 1
        d = self.fvf[2 * f + fam] * sign
        start = self.point3(f, z)
        t0 = self.vector3(f, d)
        # a loop closes when the line comes back to its start within the closing radius, running the same way
        # (with a self distance, within it: a closed curvature line drifts a little after one turn)
        close_r = max(step, self_distance)
        min_loop = max(3.0 * step, 4.0 * close_r)
        pts = [start]
        length = 0.0
        closed = False
        stuck = 0
        h = step
        max_iter = int(8 * max_length / step) + 10 * self.m ** 0.5 + 100
        it = 0
        self.stop_reason = "length"
        if self.near_singularity(f, start):
            self.stop_reason = "singularity"
            return pts, False
        while length < max_length and it < max_iter:
            it += 1
            h = min(step, max_length - length)
            k1 = self.field(f, fam, z, d)
            k2 = self.field(f, fam, z + 0.5 * h * k1, k1)
            k3 = self.field(f, fam, z + 0.5 * h * k2, k2)
            k4 = self.field(f, fam, z + h * k3, k3)
            delta = h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            z2 = z + delta
            ex = self.exit(f, z, z2)
            if ex is None:
                z, dnew = z2, delta / abs(delta) if abs(delta) > 0 else k1
                length += abs(delta)
                d = dnew
                p = self.point3(f, z)
                stuck = 0
            else:
                t, j, s = ex
                moved = t * abs(delta)
                length += moved
                dd = delta / abs(delta) if abs(delta) > 0 else k1
                za = self.Zf[3 * f + j]
                zedge = za + s * (self.Zf[3 * f + (j + 1) % 3] - za)
                p = self.point3(f, zedge)
                stuck = stuck + 1 if moved < 1e-9 * step else 0
                nxt = self.cross_edge(f, j, s, dd)
                if nxt is None:  # boundary
                    if moved > 1e-9 * step:
                        pts.append(p)
                    self.stop_reason = "boundary"
                    break
                f, z, d = nxt
                if not keep_family:
                    fam = self.family_in(f, d)
                elif fam != self.family_in(f, d):
                    pts.append(p)
                    self.stop_reason = "label"
                    break
                if stuck > 8:
                    self.stop_reason = "stuck"
                    break
                if moved <= 1e-12 * step:
                    continue
            pts.append(p)
            if self.near_singularity(f, p):
                self.stop_reason = "singularity"
                break
            if stop is not None and stop(p, self.vector3(f, d)):
                self.stop_reason = "separation"
                break
            if closing and length > min_loop:
                dx, dy, dz = p[0] - start[0], p[1] - start[1], p[2] - start[2]
                if dx * dx + dy * dy + dz * dz < close_r * close_r and (
                        close_r == step or _dot3(self.vector3(f, d), t0) > 0.94):
                    pts.append(start)
                    closed = True
                    self.stop_reason = "closed"
                    break
            if own is not None:
                t3 = self.vector3(f, d)
                if own.near(p, self_distance, t3):
                    self.stop_reason = "self"
                    break
                if len(pts) > lag:
                    own.add_point(pts[-lag - 1], t3)
        return pts, closed

    def walk(self, f: int, z: complex, d: complex, length: float):
        """Straightest walk of ``length`` from ``(f, z)`` in direction ``d``; None when it leaves the mesh."""
        d = d / abs(d)
        left = length
        for _ in range(100000):
            z2 = z + left * d
            ex = self.exit(f, z, z2)
            if ex is None:
                return f, z2, d
            t, j, s = ex
            left -= t * left
            nxt = self.cross_edge(f, j, s, d)
            if nxt is None:
                return None
            f, z, d = nxt
            if left <= 1e-12 * length:
                return f, z, d
        return None


# ----------------------------------------------------------------------------------------------
# inputs


def _mesh_field(V, T, U, W):
    V, T = validate_mesh(V, T, name="mesh", kind="tri")
    U, W = check_field(U, W, len(T))
    return V, T, U, W


def _mean_edge(V, T) -> float:
    E = np.concatenate([V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 1]], V[T[:, 0]] - V[T[:, 2]]])
    return float(np.mean(np.linalg.norm(E, axis=1)))


def _seed_locations(seeds, V, T, index=None):
    """Seeds as points ``(s, 3)`` (projected to the mesh; ``index`` its closest-point index when built already) or
    ``(faces, barycentric)`` → faces, barycentrics."""
    m = len(T)
    if isinstance(seeds, tuple) and len(seeds) == 2:
        faces = np.asarray(seeds[0])
        B = np.asarray(seeds[1], dtype=np.float64)
        if faces.ndim != 1 or (faces.size and not np.issubdtype(faces.dtype, np.integer)):
            raise InputError("seeds", "seed faces must be a 1-D array of integer face indices")
        if B.shape != (len(faces), 3) or not np.isfinite(B).all():
            raise InputError("seeds", f"barycentric coordinates must have shape ({len(faces)}, 3) and be finite")
        bad = (faces < 0) | (faces >= m)
        if bad.any():
            raise InputError("seeds", f"face {int(faces[np.argmax(bad)])} does not exist (the mesh has {m} triangles)")
        if np.any(B < -1e-9) or np.any(np.abs(B.sum(axis=1) - 1.0) > 1e-6):
            raise InputError("seeds", "barycentric coordinates must be non-negative and sum to 1")
        return faces.astype(np.int64), B
    try:
        P = np.asarray(seeds, dtype=np.float64).reshape(-1, 3)
    except (TypeError, ValueError):
        raise InputError("seeds", "must be points (s, 3) or (faces, barycentric)") from None
    if not np.isfinite(P).all():
        raise InputError("seeds", "points have NaN or infinite coordinates")
    res = closest_points(P, V, T) if index is None else index.query(P)
    return res.faces.astype(np.int64), res.barycentric


def _singular_setup(V, T, U, W, singularities, radius):
    if singularities is None:
        singularities, _ = field_singularities(V, T, U, W)
    sing = np.asarray(singularities, dtype=np.int64).reshape(-1)
    if sing.size and (sing.min() < 0 or sing.max() >= len(V)):
        raise InputError("singularities", "vertex index out of range")
    return sing


# ----------------------------------------------------------------------------------------------
# public functions


def trace_streamlines(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray, seeds, family: int = 0,
                      step: float | None = None, max_length: float | None = None, both_directions: bool = True,
                      singularities=None, singularity_radius: float | None = None) -> list[np.ndarray]:
    """Trace streamlines of one family of a face-based direction field from seed points, with RK4 on the surface.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles (oriented, edge-manifold).
    U, W : (m, 3) float64
        The field's two directions per triangle.
    seeds : (s, 3) float64 or (faces (s,) int, barycentric (s, 3) float)
        Seed points (projected to the closest point of the mesh) or their faces and barycentric coordinates.
    family : int
        0 follows ``U``, 1 follows ``W`` (at the seed; across edges the most aligned vector of the 4-fold set is
        followed).
    step : float, optional
        RK4 step length (model units); default half the mean edge length.
    max_length : float, optional
        Longest streamline (each direction); default 4 × the bounding-box diagonal.
    both_directions : bool
        Trace forwards and backwards from each seed and join the two halves.
    singularities : (k,) int, optional
        Singular vertices where lines stop (computed with :func:`~components.fields.field.field_singularities` when
        omitted).
    singularity_radius : float, optional
        Stop within this distance of a singular vertex; default one mean edge length.

    Returns
    -------
    list of (p_i, 3) float64
        One polyline per seed (seeds whose trace has fewer than two points are dropped). A closed loop repeats
        its first point at the end.

    Raises
    ------
    MeshError
        Malformed, non-triangle or non-manifold mesh.
    InputError
        Bad field arrays, seeds, family, step or lengths.

    Notes
    -----
    Classical RK4 in each triangle's plane on the linearly interpolated field, crossing edges by unfolding
    (Zhang, Mischaikow & Turk 2006); every point lies exactly on the mesh.

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(6, 6)
    >>> T = triangulate(Q)[0]
    >>> U, W = np.tile([1.0, 0.0, 0.0], (len(T), 1)), np.tile([0.0, 1.0, 0.0], (len(T), 1))
    >>> lines = trace_streamlines(V, T, U, W, seeds=[[0.5, 0.5, 0.0]], family=0)  # a constant field: straight
    >>> len(lines), lines[0][[0, -1]].round(6).tolist()
    (1, [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0]])
    """
    V, T, U, W = _mesh_field(V, T, U, W)
    fam = check_int(family, "family", 0, 1)
    h0 = _mean_edge(V, T)
    step = 0.5 * h0 if step is None else check_number(step, "step", 0, above=True)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    max_length = 4.0 * diag if max_length is None else check_number(max_length, "max_length", 0, above=True)
    if max_length / step > _MAX_POINTS:
        raise InputError("step", f"is too small for max_length ({max_length / step:.0f} steps per line)")
    radius = h0 if singularity_radius is None else check_number(singularity_radius, "singularity_radius", 0, above=True)
    faces, B = _seed_locations(seeds, V, T)
    sing = _singular_setup(V, T, U, W, singularities, radius)
    tr = _Tracer(V, T, U, W, sing, radius)
    out = []
    for f, b in zip(faces.tolist(), B.tolist()):
        z = b[1] * tr.corner(f, 1) + b[2] * tr.corner(f, 2)
        fwd, closed = tr.trace(f, z, fam, 1.0, step, max_length)
        line = fwd
        if both_directions and not closed:
            bwd, _ = tr.trace(f, z, fam, -1.0, step, max_length)
            line = bwd[::-1] + fwd[1:]
        if len(line) >= 2:
            out.append(np.asarray(line, dtype=np.float64))
    return out


class _Grid:
    """Uniform hash grid of 3D polyline points with their unit tangents, for the separation tests."""

    def __init__(self, cell: float, parallel: float):
        self.cell = cell
        self.parallel = parallel  # |cos| above which two tangents count as the same family
        self.cells: dict = {}

    def key(self, p):
        c = self.cell
        return (math.floor(p[0] / c), math.floor(p[1] / c), math.floor(p[2] / c))

    def add(self, P: np.ndarray, owner: int = -1):
        D = np.zeros_like(P)
        D[1:-1] = P[2:] - P[:-2]
        D[0] = P[1] - P[0]
        D[-1] = P[-1] - P[-2]
        L = np.linalg.norm(D, axis=1, keepdims=True)
        D = np.divide(D, L, out=np.zeros_like(D), where=L > 0)
        for p, t in zip(P.tolist(), D.tolist()):
            self.cells.setdefault(self.key(p), []).append((p, t, owner))

    def add_point(self, p, t, owner: int = -1):
        self.cells.setdefault(self.key(p), []).append((p, t, owner))

    def near(self, p, r: float, t=None, exclude: int = -2) -> bool:
        """Is a stored point closer than ``r`` to ``p`` (among those whose tangent is parallel to ``t``, not
        belonging to line ``exclude``)?"""
        r2 = r * r
        if t is not None:
            tn = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) or 1.0
            t = (t[0] / tn, t[1] / tn, t[2] / tn)
        # only the cells that meet the box [p - r, p + r] (widened a hair against rounding) can hold a point
        # closer than r: 1-2 cells per axis instead of 3
        c, rr = self.cell, r * (1.0 + 1e-9)
        x, y, z = p[0], p[1], p[2]
        cells = self.cells
        for i in range(math.floor((x - rr) / c), math.floor((x + rr) / c) + 1):
            for j in range(math.floor((y - rr) / c), math.floor((y + rr) / c) + 1):
                for k in range(math.floor((z - rr) / c), math.floor((z + rr) / c) + 1):
                    for q, tq, owner in cells.get((i, j, k), ()):
                        if owner == exclude:
                            continue
                        dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
                        if dx * dx + dy * dy + dz * dz < r2:
                            if t is None or abs(t[0] * tq[0] + t[1] * tq[1] + t[2] * tq[2]) > self.parallel:
                                return True
        return False


def evenly_spaced_streamlines(V: np.ndarray, T: np.ndarray, U: np.ndarray, W: np.ndarray, family: int = 0,
                              separation: float = 1.0, test_ratio: float = 0.5, step: float | None = None,
                              seeds=None, singularities=None, singularity_radius: float | None = None,
                              min_length: float = 0.0, labelled: bool = False, extend_ratio: float = 0.0,
                              diagnostics: dict | None = None) -> list[np.ndarray]:
    """Evenly spaced streamlines of one family at a given separation (Jobard–Lefer seeding on the surface).

    Parameters
    ----------
    V : (n, 3) float64
        Vertices.
    T : (m, 3) int64
        Triangles (oriented, edge-manifold).
    U, W : (m, 3) float64
        The field's two directions per triangle.
    family : int
        0 traces ``U``, 1 traces ``W``, 2 traces both (a net: the two families share the seeding and each line
        keeps its distance only from lines of its own direction). Around a singularity of index ±1/4 the two
        directions swap, so a single family's lines continue as the other direction beyond it.
    separation : float
        Distance between neighbouring streamlines (model units).
    test_ratio : float
        A line stops when it comes closer than ``test_ratio · separation`` to another line (0 < ratio ≤ 1).
    step : float, optional
        RK4 step; default ``min(separation / 4, mean edge length / 2)``.
    seeds : (s, 3) float64, optional
        First seeds (points on or near the mesh); default the triangle nearest to the mesh's centroid. Further
        seeds are placed at ``separation`` on both sides of the accepted lines, then wherever a gap remains.
    singularities : (k,) int, optional
        Singular vertices (computed when omitted).
    singularity_radius : float, optional
        Stop radius around singular vertices; default ``max(mean edge, separation / 2)``.
    min_length : float
        Drop lines shorter than this (model units).
    labelled : bool
        The labels ``U``/``W`` are global, as for principal directions ordered by curvature (not a combed 4-fold
        field): every line keeps its family in every triangle, seeds keep the family of their line, and a line
        stops where its family turns by more than 45° from one triangle to the next (a label jump at an umbilic).
        Without it a line follows the most aligned direction across edges (families may swap around ±1/4
        singularities).
    extend_ratio : float
        When positive, after the seeding every line end stopped by the separation test is continued until it
        comes closer than ``extend_ratio · separation`` to another line (or reaches the boundary, a singularity):
        fewer lines end inside the surface (fewer T-junctions in a network), lines stay evenly seeded. 0: off.
    diagnostics : dict, optional
        Filled with ``"end_reasons"``: per returned line, why its start and its end stopped (``"boundary"``,
        ``"separation"``, ``"singularity"``, ``"self"``, ``"closed"``, ``"stuck"``, ``"length"``, ``"label"``).

    Returns
    -------
    list of (p_i, 3) float64
        The polylines, in the order they were accepted.

    Raises
    ------
    MeshError
        Malformed, non-triangle or non-manifold mesh.
    InputError
        Bad field arrays, family, separation (also when it would need more than a few million points).

    Notes
    -----
    Jobard & Lefer 1997 with geodesic offsets: candidate seeds are reached from the points of an accepted line by
    a straightest walk of length ``separation`` perpendicular to the line within the surface; a candidate is used
    when no line of the family is closer than ``separation``. Distances are Euclidean in 3D (hash grid).

    Example
    -------
    >>> from components.core.mesh import quad_grid, triangulate
    >>> V, Q = quad_grid(6, 6)
    >>> T = triangulate(Q)[0]
    >>> U, W = np.tile([1.0, 0.0, 0.0], (len(T), 1)), np.tile([0.0, 1.0, 0.0], (len(T), 1))
    >>> lines = evenly_spaced_streamlines(V, T, U, W, family=0, separation=0.25)
    >>> sorted(round(float(L[0, 1]), 4) for L in lines)  # rows a separation apart
    [0.1944, 0.4444, 0.6944, 0.9444]
    """
    V, T, U, W = _mesh_field(V, T, U, W)
    fam = check_int(family, "family", 0, 2)
    both = fam == 2
    fam = 0 if both else fam
    sep = check_number(separation, "separation", 0, above=True)
    ratio, extend_ratio = _separation_ratios(test_ratio, extend_ratio)
    h0 = _mean_edge(V, T)
    step = min(0.25 * sep, 0.5 * h0) if step is None else check_number(step, "step", 0, above=True)
    fr = face_frames(V, T)
    _check_point_budget(float(fr.area.sum()), sep, step)
    radius = max(h0, 0.5 * sep) if singularity_radius is None else check_number(singularity_radius,
                                                                                 "singularity_radius", 0, above=True)
    tr = _Tracer(V, T, U, W, _singular_setup(V, T, U, W, singularities, radius), radius)
    max_length = 4.0 * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) + 10 * sep
    # a line keeps its distance from lines within 45° of its direction: its own family (the other one is at 90°),
    # also where lines of one family converge at an angle (into an umbilic)
    grid = _Grid(ratio * sep, parallel=math.cos(math.radians(45.0)))  # cells of the test distance: few points to scan
    sd = _Seeding(tr, grid, sep, ratio * sep, step, max_length, labelled, both, min_length)
    lines, reasons, line_fam = _seed_lines(sd, _first_seeds(tr, fr, seeds, fam), _cover_faces(fr, sep), fam)
    if extend_ratio > 0 and lines:
        _extend_ends(tr, lines, reasons, line_fam, grid, extend_ratio * sep, step, max_length, labelled)
    if diagnostics is not None:
        diagnostics["end_reasons"] = [tuple(r) for r in reasons]
    return lines


def _separation_ratios(test_ratio, extend_ratio) -> tuple[float, float]:
    """``test_ratio`` in ``(0, 1]`` and ``extend_ratio`` in ``[0, test_ratio]``, checked."""
    ratio = check_number(test_ratio, "test_ratio", 0, above=True)
    if ratio > 1:
        raise InputError("test_ratio", f"must be a finite number > 0 and <= 1, got {test_ratio!r}")
    extend = check_number(extend_ratio, "extend_ratio", 0)
    if extend > ratio:
        raise InputError("extend_ratio", f"must be a finite number >= 0 and <= test_ratio ({ratio:g}), got "
                                         f"{extend_ratio!r}")
    return ratio, extend


def _check_point_budget(area: float, sep: float, step: float) -> None:
    est_points = area / (sep * step)
    if est_points > _MAX_POINTS:
        raise InputError("separation", f"is too small for this surface (about {est_points:.0f} polyline points); "
                                       f"use at least {math.sqrt(area / (_MAX_POINTS * step)):.3g}")


class _Seeding(NamedTuple):
    """What the evenly spaced seeding shares (see :func:`evenly_spaced_streamlines`)."""

    tr: _Tracer
    grid: _Grid  # points of the accepted lines, for the separation tests
    sep: float  # separation
    d_test: float  # a line stops this close to another one of its family
    step: float
    max_length: float
    labelled: bool
    both: bool  # a net: seeds of the crossing family on every line
    min_length: float


class _SeparationTest:
    """``stop(p, t)`` for :meth:`_Tracer.trace`: a stored point closer than ``r`` with a parallel tangent (not of
    line end ``exclude``)."""

    def __init__(self, grid: _Grid, r: float, exclude: int = -2):
        self.grid, self.r, self.exclude = grid, r, exclude

    def __call__(self, p, t) -> bool:
        return self.grid.near(p, self.r, t, exclude=self.exclude)


def _first_seeds(tr: _Tracer, fr, seeds, fam: int) -> list:
    """The seeds given (points or faces and barycentric coordinates), or the face nearest the mesh's centroid."""
    if seeds is None:
        f0 = int(np.argmin(np.linalg.norm(fr.centroid - fr.centroid.mean(axis=0), axis=1)))
        return [(f0, (tr.corner(f0, 1) + tr.corner(f0, 2)) / 3.0, fam)]
    faces, B = _seed_locations(seeds, tr.V, tr.T, tr.index)
    return [(f, b[1] * tr.corner(f, 1) + b[2] * tr.corner(f, 2), fam) for f, b in zip(faces.tolist(), B.tolist())]


def _cover_faces(fr, sep: float) -> list:
    """Fallback seeds: face centroids on a coarse cover of the surface, used when the queue runs dry."""
    cover = []
    taken = np.zeros(len(fr.area), dtype=bool)
    tree = cKDTree(fr.centroid)
    order = np.random.default_rng(0).permutation(len(fr.area))
    for f in order.tolist():
        if taken[f]:
            continue
        cover.append(f)
        taken[tree.query_ball_point(fr.centroid[f], 0.7 * sep)] = True
    return cover


def _seed_lines(sd: _Seeding, queue: list, cover: list, fam: int):
    """Jobard–Lefer seeding: trace a line from every queued seed that is not too close to an accepted line, queue
    new seeds beside each accepted line, fall back to the cover faces when the queue runs dry.

    Returns the lines, why each line's start and end stopped, and the family at each line's seed.
    """
    tr, grid, sep = sd.tr, sd.grid, sd.sep
    stop = _SeparationTest(grid, sd.d_test)
    lines: list[np.ndarray] = []
    reasons: list[list[str]] = []
    line_fam: list[int] = []
    cover_pos = 0
    total = 0
    while True:
        if not queue:
            while cover_pos < len(cover):
                f = cover[cover_pos]
                cover_pos += 1
                if not grid.near(tr.fr.centroid[f].tolist(), sep, tr.vector3(f, tr.face_vector(f, fam))):
                    queue.append((f, (tr.corner(f, 1) + tr.corner(f, 2)) / 3.0, fam))
                    break
            if not queue:
                break
        f, z, k = queue.pop(0)
        p0 = tr.point3(f, z)
        if grid.near(p0, sep * 0.999, tr.vector3(f, tr.face_vector(f, k))) or tr.near_singularity(f, p0):
            continue
        line, why = _trace_both_ways(sd, f, z, k, stop)
        if len(line) < 2:
            continue
        arr = np.asarray(line)
        seg = np.linalg.norm(np.diff(arr, axis=0), axis=1)
        if seg.sum() < max(sd.min_length, 1e-12 * sep):  # relative: the same at any scale
            continue
        lines.append(arr)
        reasons.append(list(why))
        line_fam.append(k)
        _add_line(grid, arr, len(lines) - 1, 3.0 * sd.d_test)
        total += len(line)
        if total > _MAX_POINTS:
            log.warning("evenly_spaced_streamlines: point budget reached, stopping")
            break
        queue += _offset_seeds(sd, arr, seg, k)
    return lines, reasons, line_fam


def _trace_both_ways(sd: _Seeding, f: int, z: complex, k: int, stop):
    """One line through a seed, forwards then backwards, and why its start and end stopped."""
    tr = sd.tr
    fwd, closed = tr.trace(f, z, k, 1.0, sd.step, sd.max_length, stop=stop, self_distance=sd.d_test,
                           keep_family=sd.labelled)
    why = (tr.stop_reason, tr.stop_reason)
    line = fwd
    if not closed:
        bwd, bclosed = tr.trace(f, z, k, -1.0, sd.step, sd.max_length, stop=stop, self_distance=sd.d_test,
                                keep_family=sd.labelled)
        if bclosed:  # the backward half went round the loop alone: it is the whole line
            line = bwd[::-1]
            why = ("closed", "closed")
        else:
            line = bwd[::-1] + fwd[1:]
            why = (tr.stop_reason, why[1])
    return line, why


def _offset_seeds(sd: _Seeding, arr: np.ndarray, seg: np.ndarray, k: int) -> list:
    """Candidate seeds at the separation on both sides of a new line, every ~separation/2 along it (and for a net
    the crossing family's seeds on the line itself)."""
    tr, sep = sd.tr, sd.sep
    out = []
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    picks = np.searchsorted(cum, np.arange(0.0, cum[-1] + 1e-12 * sep, 0.5 * sep))
    picks = np.unique(np.minimum(picks, len(arr) - 1))
    locs = _locate_on_line(tr, arr[picks])
    for (lf, lz), i in zip(locs, picks.tolist()):
        if lf < 0:
            continue
        j = min(i + 1, len(arr) - 1)
        i0 = j - 1 if j > 0 else 0
        t3 = arr[j] - arr[i0]
        dz = complex(float(t3 @ tr.fr.e1[lf]), float(t3 @ tr.fr.e2[lf]))
        if abs(dz) == 0:
            continue
        for side in (1j, -1j):
            res = tr.walk(lf, lz, dz * side, sep)
            if res is not None:
                wf, wz, wd = res
                # the seed continues the family of the line it was offset from
                out.append((wf, wz, k if sd.labelled else tr.family_in(wf, wd * (-side))))
        if sd.both:  # the crossing family starts on the line itself
            out.append((lf, lz, 1 - k if sd.labelled else 1 - tr.family_in(lf, dz)))
    return out


def _extend_ends(tr, lines, reasons, line_fam, grid, d_ext, step, max_length, labelled):
    """Continue every line end stopped by the separation test until it comes within ``d_ext`` of another line
    (or meets the boundary, a singularity, ...). Updates ``lines``, ``reasons`` and ``grid`` in place."""
    for i in range(len(lines)):
        for end in (0, 1):
            if reasons[i][end] != "separation":
                continue
            arr = lines[i]
            pts = arr if end == 1 else arr[::-1]
            tan = pts[-1] - pts[max(len(pts) - 3, 0)]
            if not np.any(tan):
                continue
            (lf, lz), = _locate_on_line(tr, pts[-1:])
            dz = complex(float(tan @ tr.fr.e1[lf]), float(tan @ tr.fr.e2[lf]))
            if abs(dz) == 0:
                continue
            kk = line_fam[i] if labelled else tr.family_in(lf, dz)
            sgn = 1.0 if (tr.face_vector(lf, kk) * dz.conjugate()).real >= 0 else -1.0

            stop = _SeparationTest(grid, d_ext, exclude=2 * i + end)
            ext, _ = tr.trace(lf, lz, kk, sgn, step, max_length, stop=stop, closing=False, self_distance=d_ext,
                              keep_family=labelled)
            reasons[i][end] = "extended:" + tr.stop_reason
            if len(ext) < 2:
                continue
            E = np.asarray(ext[1:])
            new = np.vstack([pts, E])
            lines[i] = new if end == 1 else new[::-1]
            grid.add(np.vstack([pts[-1:], E]), owner=2 * i + end)


def _add_line(grid, arr, i, reach):
    """Add a line to the separation grid; its points within arc length ``reach`` of its start (end) are owned by
    ``2 i`` (``2 i + 1``) so that an extension of that end ignores them, the others by nobody."""
    seg = np.linalg.norm(np.diff(arr, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    own = np.full(len(arr), -1, dtype=np.int64)
    own[cum >= cum[-1] - reach] = 2 * i + 1
    own[cum <= reach] = 2 * i
    for o in np.unique(own).tolist():
        sel = np.flatnonzero(own == o)
        a, b = max(sel[0] - 1, 0), min(sel[-1] + 2, len(arr))  # neighbours give the end tangents
        P = arr[a:b]
        keep = np.isin(np.arange(a, b), sel)
        D = np.zeros_like(P)
        if len(P) > 1:
            D[1:-1] = P[2:] - P[:-2]
            D[0] = P[1] - P[0]
            D[-1] = P[-1] - P[-2]
        L = np.linalg.norm(D, axis=1, keepdims=True)
        D = np.divide(D, L, out=np.zeros_like(D), where=L > 0)
        for p, t in zip(P[keep].tolist(), D[keep].tolist()):
            grid.add_point(p, t, owner=o)


def _locate_on_line(tr: _Tracer, P: np.ndarray):
    """Faces and face coordinates of points lying on the mesh (closest-point query)."""
    res = tr.index.query(P)
    out = []
    for f, b in zip(res.faces.tolist(), res.barycentric.tolist()):
        out.append((f, b[1] * tr.corner(f, 1) + b[2] * tr.corner(f, 2)))
    return out


# ----------------------------------------------------------------------------------------------
# published component


class StreamlinesResult(NamedTuple):
    curves: Curves
    curve_count: int
    point_count: int
    singularities: Points
    warnings: list[str]


def streamlines(mesh: Mesh, family: int = 0, separation: float = 1.0, seeds: Points | None = None,
                alignment: float = 0.1, field: str = "conjugate") -> StreamlinesResult:
    """Streamlines of a direction field on a mesh, evenly spaced or from seed points (RK4 on the surface).

    Parameters
    ----------
    mesh : Mesh
        The design surface ``(V, F)``; polygons are fan-triangulated, open boundaries and holes are allowed.
    family : int
        0 or 1: one of the field's two directions; 2: both (a curve network).
    separation : float
        Distance between neighbouring curves of a family, model units (evenly spaced mode; with seeds it sets
        the integration step to a quarter of it at most).
    seeds : Points, optional
        Start points (projected onto the mesh): one curve through each instead of evenly spaced curves.
    alignment : float
        Alignment of the smooth field to the principal curvature directions (see the smooth field component).
    field : str
        ``"conjugate"`` (the smooth field made conjugate: curves of a planar-quad network), ``"smooth"`` (the
        smooth cross field) or ``"principal"`` (raw principal curvature directions: curvature lines, stopped at
        umbilics).

    Returns
    -------
    curves : Curves
        Polylines on the surface.
    curve_count : int
        Number of curves.
    point_count : int
        Total number of polyline points.
    singularities : Points
        Singular vertices of the field, where curves stop.

    Raises
    ------
    MeshError
        The mesh is malformed, degenerate or non-manifold.
    InputError
        Unknown ``field`` or ``family``; non-positive or too small ``separation``; bad seeds.

    Notes
    -----
    RK4 tracing across triangles by unfolding (Zhang, Mischaikow & Turk 2006); even spacing after Jobard & Lefer
    1997; fields from Diamanti et al. 2014 and Liu et al. 2011 (see :mod:`components.fields.field`).

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> V, F = quad_grid(8, 8, 8.0, 8.0, height=lambda x, y: 0.02 * (x - 4) ** 2 - 0.01 * (y - 4) ** 2)
    >>> res = streamlines((V, F), family=2, separation=2.0)
    >>> res.curve_count > 0, len(res.singularities)
    (True, 0)
    """
    check_choice(field, "field", ("conjugate", "smooth", "principal"))
    fam = check_int(family, "family", 0, 2)
    sep = check_number(separation, "separation", 0, above=True)
    V, F = check_mesh(mesh)
    T, _ = triangulate(F)
    cv = field_curvature(V, T)
    if field == "principal":
        U, W = cv.d1, cv.d2
    else:
        fld = smooth_frame_field(V, T, alignment=alignment, curvature=cv)
        if field == "conjugate":
            fld = conjugate_frame_field(V, T, fld.U, fld.W, curvature=cv)
        U, W = fld.U, fld.W
    sing, _ = field_singularities(V, T, U, W)
    warnings: list[str] = []
    if seeds is None:
        lines = evenly_spaced_streamlines(V, T, U, W, family=fam, separation=sep, singularities=sing,
                                          labelled=field == "principal")
    else:
        step = min(0.25 * sep, 0.5 * _mean_edge(V, T))
        fams = (0, 1) if fam == 2 else (fam,)
        lines = []
        for k in fams:
            lines += trace_streamlines(V, T, U, W, seeds, family=k, step=step, singularities=sing)
    if not lines:
        warnings.append("no streamline was traced: the separation may be larger than the surface")
    if field == "principal" and len(sing) > max(20, len(T) // 500):
        warnings.append(f"the principal directions have {len(sing)} singular vertices (umbilics and noise): "
                        "use field='smooth' or 'conjugate' for long curves")
    return StreamlinesResult(lines, len(lines), int(sum(len(L) for L in lines)), V[sing], warnings)
