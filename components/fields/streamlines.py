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
from components.core.memo import ContentCache, digest
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
        # the candidates of every pair: (p, 3) each (np.take: a row gather several times faster than U[g])
        Ug, Wg = np.take(U, g, axis=0), np.take(W, g, axis=0)
        area = np.take(fr.area, g)
        tot = np.bincount(k, weights=area, minlength=3 * m).reshape(m, 3)
        for fam, X in enumerate((U, W)):
            ref = np.take(X, f, axis=0)
            du = np.einsum("pj,pj->p", Ug, ref)
            dw = np.einsum("pj,pj->p", Wg, ref)
            pick = np.abs(dw) > np.abs(du)  # W[g] better aligned (the first one on a tie)
            sgn = np.sign(np.where(pick, dw, du))
            sgn[sgn == 0] = 1.0
            vec = np.where(pick[:, None], Wg, Ug)
            vec *= (sgn * area)[:, None]
            acc = np.zeros((3 * m, 3))
            for d in range(3):
                acc[:, d] = np.bincount(k, weights=vec[:, d], minlength=3 * m)
            acc = acc.reshape(m, 3, 3)
            z = np.einsum("fcj,fj->fc", acc, fr.e1) + 1j * np.einsum("fcj,fj->fc", acc, fr.e2)
            a = np.abs(z)
            own = np.einsum("ij,ij->i", X, fr.e1) + 1j * np.einsum("ij,ij->i", X, fr.e2)
            own = (own / np.abs(own))[:, None]
            # fall back to the face's own vector where the average cancels (around singularities)
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

        ``stop`` (a :class:`_SeparationTest`) ends the line at its first point close to a stored line;
        ``self_distance > 0`` ends it when it comes back (parallel) that close to its own earlier points (a spiral
        instead of a closed loop). ``keep_family``: the field's labels are global (principal directions ordered by
        curvature), so the line keeps family ``fam`` in every triangle and stops where that family turns by more
        than 45° from one triangle to the next (a label jump: an umbilic). The reason of the last stop is left in
        ``self.stop_reason``.

        ``self.locs`` is left with the face and face coordinate of every point (a point on an edge in the face the
        line leaves): seeds beside the line and its extensions start from them, not from a closest-point search
        whose choice between the two faces of an edge would be arbitrary. The RK4 steps run in scalar Python on
        per-face constants; the two distance tests (to the stored lines and
        to the line itself) are run vectorized on chunks of :data:`_CHUNK` points, and the line is cut at the first
        point where one fires: the same line as testing after every step.
        """
        lag = 0
        if self_distance > 0:
            lag = int(math.ceil(3.0 * self_distance / step)) + 1
        Zf, nbr, nbe, cvf, fvf, den_f = self.Zf, self.nbr, self.nbe, self.cvf, self.fvf, self.den
        of, e1f, e2f, near = self.of, self.e1f, self.e2f, self.near
        d = fvf[2 * f + fam] * sign
        start = self.point3(f, z)
        t0 = self.vector3(f, d)
        # a loop closes when the line comes back to its start within the closing radius, running the same way
        # (with a self distance, within it: a closed curvature line drifts a little after one turn)
        close_r = max(step, self_distance)
        close_r2 = close_r * close_r
        min_loop = max(3.0 * step, 4.0 * close_r)
        pts = [start]
        locs = [(f, z)]  # face and face coordinate of every point
        self.locs = locs
        f0, z0 = f, z
        length = 0.0
        closed = False
        stuck = 0
        max_iter = int(8 * max_length / step) + 10 * self.m ** 0.5 + 100
        it = 0
        self.stop_reason = "length"
        if self.near_singularity(f, start):
            self.stop_reason = "singularity"
            return pts, False
        tested = _Tested(pts, stop, self_distance, lag, t0)
        reason = "length"
        eps_stuck, eps_move = 1e-9 * step, 1e-12 * step
        cur = -1

        def slope(q: complex, ref: complex) -> complex:
            """The unit field direction at face coordinate ``q`` of the current face (the per-face constants below),
            linearly interpolated from its corners and turned to agree with ``ref``; the face's own direction where
            the interpolation vanishes."""
            qr, qi = q.real, q.imag
            b1 = (qr * z2i - qi * z2r) / den
            b2 = (z1r * qi - z1i * qr) / den
            v = (1.0 - b1 - b2) * c0 + b1 * c1 + b2 * c2
            a = abs(v)
            if a < 1e-9:
                v, a = fv, 1.0
            if (v * ref.conjugate()).real < 0:
                v = -v
            return v / a

        while length < max_length and it < max_iter:
            it += 1
            if f != cur:  # per-face constants
                cur = f
                i3 = 3 * f
                z1, z2c = Zf[i3 + 1], Zf[i3 + 2]
                z1r, z1i, z2r, z2i = z1.real, z1.imag, z2c.real, z2c.imag
                den = den_f[f]
                i6 = 6 * f + 3 * fam
                c0, c1, c2 = cvf[i6], cvf[i6 + 1], cvf[i6 + 2]
                fv = fvf[2 * f + fam]
            h = min(step, max_length - length)
            # RK4 on the linearly interpolated field
            k1 = slope(z, d)
            k2 = slope(z + 0.5 * h * k1, k1)
            k3 = slope(z + 0.5 * h * k2, k2)
            k4 = slope(z + h * k3, k3)
            delta = h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            z2 = z + delta
            # the first edge crossed by z → z2 (see exit())
            zr, zi = z2.real, z2.imag
            l1 = (zr * z2i - zi * z2r) / den
            l2 = (z1r * zi - z1i * zr) / den
            l0 = 1.0 - l1 - l2
            if not (l0 < 0.0 or l1 < 0.0 or l2 < 0.0):  # inside: no crossing
                ad = abs(delta)
                z, dnew = z2, delta / ad if ad > 0 else k1
                length += ad
                d = dnew
                x, y = z.real, z.imag
                p = [of[i3] + x * e1f[i3] + y * e2f[i3], of[i3 + 1] + x * e1f[i3 + 1] + y * e2f[i3 + 1],
                     of[i3 + 2] + x * e1f[i3 + 2] + y * e2f[i3 + 2]]
                ploc = (f, z)
                stuck = 0
            else:  # the first edge crossed (see exit())
                zr, zi = z.real, z.imag
                m1 = (zr * z2i - zi * z2r) / den
                m2 = (z1r * zi - z1i * zr) / den
                m0 = 1.0 - m1 - m2
                b0 = (m0, m1, m2)
                b1 = (l0, l1, l2)
                t, cmin = 2.0, -1
                # the corners whose barycentric goes negative, unrolled (a0 = max(b0[c], 0.0))
                if l0 < 0.0:
                    a0 = 0.0 if 0.0 > m0 else m0
                    tc = a0 / (a0 - l0)
                    if tc < t:
                        t, cmin = tc, 0
                if l1 < 0.0:
                    a0 = 0.0 if 0.0 > m1 else m1
                    tc = a0 / (a0 - l1)
                    if tc < t:
                        t, cmin = tc, 1
                if l2 < 0.0:
                    a0 = 0.0 if 0.0 > m2 else m2
                    tc = a0 / (a0 - l2)
                    if tc < t:
                        t, cmin = tc, 2
                j = (cmin + 1) % 3
                jn = (j + 1) % 3
                lj = b0[j] + t * (b1[j] - b0[j])
                lk = b0[jn] + t * (b1[jn] - b0[jn])
                s = lk / (lj + lk) if lj + lk > 0 else 0.5
                s = min(max(s, 0.0), 1.0)
                ad = abs(delta)
                moved = t * ad
                length += moved
                dd = delta / ad if ad > 0 else k1
                za = Zf[i3 + j]
                zedge = za + s * (Zf[i3 + (j + 1) % 3] - za)
                x, y = zedge.real, zedge.imag
                p = [of[i3] + x * e1f[i3] + y * e2f[i3], of[i3 + 1] + x * e1f[i3 + 1] + y * e2f[i3 + 1],
                     of[i3 + 2] + x * e1f[i3 + 2] + y * e2f[i3 + 2]]
                ploc = (f, zedge)  # on the edge: located in the face it leaves
                stuck = stuck + 1 if moved < eps_stuck else 0
                g = nbr[i3 + j]
                if g < 0:  # boundary
                    if moved > eps_stuck:
                        pts.append(p)
                        locs.append(ploc)
                    reason = "boundary"
                    break
                # carry the edge point and the direction into the neighbour (see cross_edge())
                jg = nbe[i3 + j]
                ef = Zf[i3 + (j + 1) % 3] - Zf[i3 + j]
                zga = Zf[3 * g + (jg + 1) % 3]
                eg = Zf[3 * g + jg] - zga
                r = eg / ef
                r = r / abs(r)
                f, z, d = g, zga + s * eg, dd * r
                u, w = fvf[2 * f], fvf[2 * f + 1]
                dc = d.conjugate()
                k = 0 if abs((u * dc).real) >= abs((w * dc).real) else 1
                if not keep_family:
                    fam = k
                elif fam != k:
                    pts.append(p)
                    locs.append(ploc)
                    reason = "label"
                    break
                if stuck > 8:
                    reason = "stuck"
                    break
                if moved <= eps_move:
                    continue
            pts.append(p)
            locs.append(ploc)
            if near[f] and self.near_singularity(f, p):
                reason = "singularity"
                break
            i3f = 3 * f
            x, y = d.real, d.imag
            t3 = [x * e1f[i3f] + y * e2f[i3f], x * e1f[i3f + 1] + y * e2f[i3f + 1], x * e1f[i3f + 2] + y * e2f[i3f + 2]]
            if closing and length > min_loop:
                dx, dy, dz = p[0] - start[0], p[1] - start[1], p[2] - start[2]
                if dx * dx + dy * dy + dz * dz < close_r2 and (close_r == step or _dot3(t3, t0) > 0.94):
                    tested.add(len(pts) - 1, p, t3, own=False)
                    pts.append(start)
                    locs.append((f0, z0))
                    closed = True
                    reason = "closed"
                    break
            if tested.add(len(pts) - 1, p, t3):  # a chunk is full: test it
                hit = tested.check()
                if hit is not None:
                    self.stop_reason = hit[1]
                    self.locs = locs[:hit[0] + 1]
                    return pts[:hit[0] + 1], False
        hit = tested.check()
        if hit is not None:
            self.stop_reason = hit[1]
            self.locs = locs[:hit[0] + 1]
            return pts[:hit[0] + 1], False
        self.stop_reason = reason
        return pts, closed

    def walk(self, f: int, z: complex, d: complex, length: float):
        """Straightest walk of ``length`` from ``(f, z)`` in direction ``d``; None when it leaves the mesh (the
        arithmetic of :meth:`exit` and :meth:`cross_edge`, inlined)."""
        Zf, den_f, nbr, nbe = self.Zf, self.den, self.nbr, self.nbe
        d = d / abs(d)
        left = length
        for _ in range(100000):
            z2 = z + left * d
            i3 = 3 * f
            z1, zc = Zf[i3 + 1], Zf[i3 + 2]
            den = den_f[f]
            zr, zi = z2.real, z2.imag
            l1 = (zr * zc.imag - zi * zc.real) / den
            l2 = (z1.real * zi - z1.imag * zr) / den
            l0 = 1.0 - l1 - l2
            if not (l0 < 0.0 or l1 < 0.0 or l2 < 0.0):
                return f, z2, d
            zr, zi = z.real, z.imag
            m1 = (zr * zc.imag - zi * zc.real) / den
            m2 = (z1.real * zi - z1.imag * zr) / den
            m0 = 1.0 - m1 - m2
            b0, b1 = (m0, m1, m2), (l0, l1, l2)
            tmin, cmin = 2.0, -1
            if l0 < 0.0:  # unrolled as in trace()
                a0 = 0.0 if 0.0 > m0 else m0
                t = a0 / (a0 - l0)
                if t < tmin:
                    tmin, cmin = t, 0
            if l1 < 0.0:
                a0 = 0.0 if 0.0 > m1 else m1
                t = a0 / (a0 - l1)
                if t < tmin:
                    tmin, cmin = t, 1
            if l2 < 0.0:
                a0 = 0.0 if 0.0 > m2 else m2
                t = a0 / (a0 - l2)
                if t < tmin:
                    tmin, cmin = t, 2
            j = (cmin + 1) % 3
            j1 = (j + 1) % 3
            lj = b0[j] + tmin * (b1[j] - b0[j])
            lk = b0[j1] + tmin * (b1[j1] - b0[j1])
            sj = lk / (lj + lk) if lj + lk > 0 else 0.5
            sj = min(max(sj, 0.0), 1.0)
            left -= tmin * left
            g = nbr[i3 + j]
            if g < 0:
                return None
            jg = nbe[i3 + j]
            ef = Zf[i3 + j1] - Zf[i3 + j]
            za = Zf[3 * g + (jg + 1) % 3]
            eg = Zf[3 * g + jg] - za
            r = eg / ef
            r = r / abs(r)
            f, z, d = g, za + sj * eg, d * r
            if left <= 1e-12 * length:
                return f, z, d
        return None


# ----------------------------------------------------------------------------------------------
# inputs


_VALIDATED = ContentCache("streamline meshes validated")  # the last mesh validated (both families of a net)


def _mesh_field(V, T, U, W):
    """The mesh validated (the last one kept: the two families of a network validate it once) and the field
    checked."""
    if isinstance(V, np.ndarray) and isinstance(T, np.ndarray):
        V, T = _VALIDATED.get(digest(V, T), lambda: validate_mesh(V, T, name="mesh", kind="tri"))
    else:
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


_CHUNK = 32  # points a trace runs ahead before its distance tests run (vectorized) on them
_BLOCK = 16  # consecutive stored points sharing a bounding box in _Points
_LANES = np.arange(_BLOCK)
_ALL8 = np.frombuffer(np.ones(8, bool).tobytes(), np.uint64)[0]  # eight True bytes read as one integer


class _Points:
    """Polyline points with their tangents and owners, for the separation tests: stored in blocks of
    :data:`_BLOCK` consecutive points with a bounding box each, so that a query (many points at once, vectorized)
    measures only the points of the blocks whose box comes close.

    ``parallel``: a stored point counts only when its tangent is within the angle of the query point's (``|cos|``
    above it); the query tangents are normalized, the stored ones are used as given.
    """

    def __init__(self, parallel: float):
        self.parallel = parallel
        self.n = 0
        self.nb = 0
        self.P = np.zeros((64, 3))
        self.D = np.zeros((64, 3))
        self.owner = np.zeros(64, np.int64)
        # per block (min, -max) of its points and two columns of -inf (always below): eight comparisons with a
        # query's (point + r, r - point, 0, 0) are read as one 8-byte integer (all True: the boxes come that close)
        self.box = np.zeros((8, 8))
        self.bstart = np.zeros(8, np.int64)
        self.bcount = np.zeros(8, np.int64)

    def __len__(self) -> int:
        return self.n

    @staticmethod
    def _grown(a, need):
        if need <= len(a):
            return a
        b = np.zeros((max(need, 2 * len(a)),) + a.shape[1:], a.dtype)
        b[:len(a)] = a
        return b

    def add(self, P: np.ndarray, owner: int = -1):
        """Store a polyline's points with central-difference unit tangents."""
        P = np.asarray(P, np.float64)
        D = np.zeros_like(P)
        if len(P) > 1:
            D[1:-1] = P[2:] - P[:-2]
            D[0] = P[1] - P[0]
            D[-1] = P[-1] - P[-2]
        L = np.linalg.norm(D, axis=1, keepdims=True)
        D = np.divide(D, L, out=np.zeros_like(D), where=L > 0)
        self.add_points(P, D, owner)

    def add_points(self, P, D, owner=-1):
        """Store points ``P`` (k, 3) with tangents ``D`` (k, 3) and owners (an int or (k,) ints), in that order."""
        P = np.asarray(P, np.float64).reshape(-1, 3)
        k = len(P)
        if k == 0:
            return
        n, nb = self.n, self.n + k
        self.P = self._grown(self.P, nb)
        self.D = self._grown(self.D, nb)
        self.owner = self._grown(self.owner, nb)
        self.P[n:nb] = P
        self.D[n:nb] = D
        self.owner[n:nb] = owner
        starts = np.arange(0, k, _BLOCK)
        m = len(starts)
        b0, b1 = self.nb, self.nb + m
        self.box = self._grown(self.box, b1)
        self.bstart = self._grown(self.bstart, b1)
        self.bcount = self._grown(self.bcount, b1)
        self.box[b0:b1, :3] = np.minimum.reduceat(P, starts, axis=0)
        self.box[b0:b1, 3:6] = -np.maximum.reduceat(P, starts, axis=0)
        self.box[b0:b1, 6:] = -np.inf
        self.bstart[b0:b1] = n + starts
        self.bcount[b0:b1] = np.diff(np.r_[starts, k])
        self.n, self.nb = nb, b1

    def hits(self, Q, r: float, Tq=None, exclude: int = -2, before=None, first_block: int = 0) -> np.ndarray:
        """Which query points ``Q`` (q, 3) have a stored point closer than ``r`` (whose tangent is parallel to the
        query's ``Tq``, whose owner is not ``exclude``, and, with ``before`` (q,), whose owner is below the query's
        ``before``)? ``first_block``: only the points stored in that block (an index into the blocks, ``nb`` before
        an addition) and later ones count."""
        Q = np.asarray(Q, np.float64).reshape(-1, 3)
        out = np.zeros(len(Q), bool)
        if self.nb == 0 or len(Q) == 0:
            return out
        rr = r * (1.0 + 1e-9)
        # the blocks whose box comes within rr of the query points' box: box = (lo, -hi) <= (max Q + rr, rr - min Q)
        QA = np.zeros((len(Q), 8))  # (Q + rr, rr - Q, 0, 0): a box (lo, -hi) comes within rr when box <= QA
        QA[:, :3] = Q + rr
        QA[:, 3:6] = rr - Q
        cand = first_block + np.flatnonzero((self.box[first_block:self.nb] <= QA.max(axis=0)).view(np.uint64)[:, 0]
                                            == _ALL8)
        if len(cand) == 0:
            return out
        if len(Q) > 1:  # the pairs (query point, block) within rr
            ov = (self.box[cand][None] <= QA[:, None]).view(np.uint64)[:, :, 0] == _ALL8
            qb, cb = np.nonzero(ov)
            if len(qb) == 0:
                return out
            cand = cand[cb]
        else:
            qb = np.zeros(len(cand), np.int64)
        lanes = _LANES < self.bcount[cand, None]
        pp = (self.bstart[cand, None] + _LANES)[lanes]
        qi = np.broadcast_to(qb[:, None], lanes.shape)[lanes]
        S, X = self.P[pp], Q[qi]
        dx, dy, dz = X[:, 0] - S[:, 0], X[:, 1] - S[:, 1], X[:, 2] - S[:, 2]
        m = dx * dx + dy * dy + dz * dz < r * r
        if exclude != -2:
            m &= self.owner[pp] != exclude
        if before is not None:
            m &= self.owner[pp] < np.asarray(before)[qi]
        qi, pp = qi[m], pp[m]
        if len(qi) == 0:
            return out
        if Tq is None:
            out[qi] = True
            return out
        Tq = np.asarray(Tq, np.float64).reshape(-1, 3)
        tn = np.sqrt(Tq[:, 0] * Tq[:, 0] + Tq[:, 1] * Tq[:, 1] + Tq[:, 2] * Tq[:, 2])
        tn[tn == 0] = 1.0
        A, B = Tq[qi] / tn[qi, None], self.D[pp]
        par = np.abs(A[:, 0] * B[:, 0] + A[:, 1] * B[:, 1] + A[:, 2] * B[:, 2]) > self.parallel
        out[qi[par]] = True
        return out

    def near(self, p, r: float, t=None, exclude: int = -2) -> bool:
        """Is a stored point closer than ``r`` to ``p`` (among those whose tangent is parallel to ``t``, not
        belonging to line ``exclude``)?"""
        return bool(self.hits(np.asarray(p, np.float64)[None], r, None if t is None else [t], exclude)[0])


class _Tested:
    """The points of one trace waiting for their distance tests (to the stored lines, ``stop``, and to the line
    itself), run vectorized on :data:`_CHUNK` points at a time; see :meth:`_Tracer.trace`.

    The self test is skipped while it cannot fire (:meth:`_far`): as long as every segment of the line so far runs
    within a cone around the start tangent ``axis`` (``cos >= c > 0``), a point is at least ``c`` × the arc length
    away from every earlier point, and the points it is tested against are more than ``lag`` points back. The own
    points are then kept aside and stored (in the same order) when a test has to run."""

    def __init__(self, pts: list, stop, self_distance: float, lag: int, axis=None):
        self.pts = pts
        self.stop = stop
        self.r_self = self_distance
        self.lag = lag
        self.own = _Points(math.cos(math.radians(20.0))) if self_distance > 0 else None
        self.idx, self.P, self.T, self.self_tested = [], [], [], []
        self.seq = 0  # tested points before the pending ones
        self.waiting: list = []  # own points not stored yet: add_points arguments, in order
        self.axis = None
        if axis is not None:
            a = np.asarray(axis, np.float64)
            na = float(np.linalg.norm(a))
            self.axis = a / na if na > 0 else None
        self.arc = np.zeros(1)  # arc length of the line at its points 0, 1, ... (measured so far)
        self.cmin = np.ones(1)  # smallest cosine to the axis of the segments up to each point

    def _far(self, I: np.ndarray) -> bool:
        """No point of the line indices ``I`` can be within the self distance of a point more than ``lag`` points
        before it (the own points a test would see)."""
        if len(I) == 0:
            return True
        if self.axis is None:
            return False
        b = int(I.max()) + 1
        a = len(self.arc)
        if b > a:  # extend the arc lengths and cosines to point b - 1
            P = np.array(self.pts[a - 1:b], np.float64)
            D = P[1:] - P[:-1]
            L = np.sqrt(D[:, 0] * D[:, 0] + D[:, 1] * D[:, 1] + D[:, 2] * D[:, 2])
            c = np.ones(len(L))
            pos = L > 0
            c[pos] = (D[pos] @ self.axis) / L[pos]
            self.arc = np.concatenate([self.arc, self.arc[-1] + np.cumsum(L)])
            self.cmin = np.concatenate([self.cmin, np.minimum.accumulate(np.minimum(c, self.cmin[-1]))])
        m = I - self.lag - 1  # the latest point a test of I could see
        back = m >= 0
        if not back.any():
            return True
        I, m = I[back], m[back]
        c = self.cmin[I]
        # a margin far above the rounding of these sums: the same verdict as the distances the test measures
        return bool(np.all((c > 0) & (c * (self.arc[I] - self.arc[m]) >= self.r_self * (1.0 + 1e-6))))

    def add(self, i: int, p, t, own: bool = True) -> bool:
        """Point ``pts[i] = p`` with tangent ``t`` waits for its tests (``own``: the self test too); True when a
        chunk is full."""
        self.idx.append(i)
        self.P.append(p)
        self.T.append(t)
        self.self_tested.append(own)
        return len(self.idx) >= _CHUNK

    def check(self):
        """Run the pending tests: ``(index in the line, reason)`` of the first point where one fires, or None."""
        n = len(self.idx)
        if n == 0 or (self.stop is None and self.own is None):
            return None
        P = np.array(self.P)
        T = np.array(self.T)
        first, why = n, None
        if self.stop is not None:
            hit = self.stop.hits(P, T)
            if hit.any():
                first, why = int(np.argmax(hit)), "separation"
        if self.own is not None:
            idx = np.array(self.idx)
            own_t = np.array(self.self_tested)
            seq = self.seq + np.arange(n)
            # the own points of this chunk first (pts[i - lag] with the tangent at i, stored after the test at i:
            # a point sees those of the earlier points only)
            sel = own_t & (idx >= self.lag)
            if sel.any():
                self.waiting.append((np.array([self.pts[i] for i in (idx[sel] - self.lag).tolist()]), T[sel],
                                     seq[sel]))
            if not self._far(idx[:first][own_t[:first]]):
                for args in self.waiting:
                    self.own.add_points(*args)
                self.waiting = []
                hit = self.own.hits(P[:first], self.r_self, T[:first], before=seq[:first]) & own_t[:first]
                if hit.any():
                    first, why = int(np.argmax(hit)), "self"
        if why is not None:
            return self.idx[first], why
        self.seq += n
        self.idx, self.P, self.T, self.self_tested = [], [], [], []
        return None


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
    when no line of the family is closer than ``separation``. Distances are Euclidean in 3D (the stored points in
    blocks of consecutive points with bounding boxes; a trace runs a few steps ahead and tests them together).

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
    # a separation past the surface's size spaces one line per family, as its size does (1e300 overflowed the
    # lines' step counts)
    sep = min(sep, 4.0 * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) + h0)
    step = min(0.25 * sep, 0.5 * h0) if step is None else check_number(step, "step", 0, above=True)
    area = 0.5 * float(np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum())
    _check_point_budget(area, sep, step)
    radius = max(h0, 0.5 * sep) if singularity_radius is None else check_number(singularity_radius,
                                                                                 "singularity_radius", 0, above=True)
    tr, cover = _prepared(V, T, U, W, singularities, radius, sep)
    fr = tr.fr
    max_length = 4.0 * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) + 10 * sep
    # a line keeps its distance from lines within 45° of its direction: its own family (the other one is at 90°),
    # also where lines of one family converge at an angle (into an umbilic)
    grid = _Points(parallel=math.cos(math.radians(45.0)))
    sd = _Seeding(tr, grid, sep, ratio * sep, step, max_length, labelled, both, min_length)
    lines, reasons, line_fam, locs = _seed_lines(sd, _first_seeds(tr, fr, seeds, fam), cover, fam)
    if extend_ratio > 0 and lines:
        _extend_ends(tr, lines, reasons, line_fam, grid, extend_ratio * sep, step, max_length, labelled, locs)
    if diagnostics is not None:
        diagnostics["end_reasons"] = [tuple(r) for r in reasons]
    return lines


_PREPARED = ContentCache("streamline tracers")  # the last tracer built (and its cover faces)


def _prepared(V, T, U, W, singularities, radius, sep):
    """The tracer of a mesh and field (:class:`_Tracer`, its singularities found when not given) and the cover faces
    at separation ``sep``: the last ones are kept, so the two families of a network (two calls on the same arrays)
    build them once."""
    key = digest(V, T, U, W, None if singularities is None else np.asarray(singularities), float(radius))
    tr, covers = _PREPARED.get(key, lambda: (
        _Tracer(V, T, U, W, _singular_setup(V, T, U, W, singularities, radius), radius), {}))
    if sep not in covers:
        covers.clear()
        covers[sep] = _cover_faces(tr.fr, sep)
    return tr, covers[sep]


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
    grid: _Points  # points of the accepted lines, for the separation tests
    sep: float  # separation
    d_test: float  # a line stops this close to another one of its family
    step: float
    max_length: float
    labelled: bool
    both: bool  # a net: seeds of the crossing family on every line
    min_length: float


class _SeparationTest:
    """The ``stop`` test of :meth:`_Tracer.trace`: which points have a stored point closer than ``r`` with a
    parallel tangent (not of line end ``exclude``)."""

    def __init__(self, grid: _Points, r: float, exclude: int = -2):
        self.grid, self.r, self.exclude = grid, r, exclude

    def hits(self, P, T) -> np.ndarray:
        return self.grid.hits(P, self.r, T, exclude=self.exclude)


def _first_seeds(tr: _Tracer, fr, seeds, fam: int) -> list:
    """The seeds given (points or faces and barycentric coordinates), or the face nearest the mesh's centroid."""
    if seeds is None:
        f0 = int(np.argmin(np.linalg.norm(fr.centroid - fr.centroid.mean(axis=0), axis=1)))
        return [(f0, (tr.corner(f0, 1) + tr.corner(f0, 2)) / 3.0, fam)]
    located = isinstance(seeds, tuple) and len(seeds) == 2  # faces and barycentric coordinates: no search
    faces, B = _seed_locations(seeds, tr.V, tr.T, None if located else tr.index)
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

    The queue is kept free of seeds too close to an accepted line (tested together, vectorized, whenever a line
    is accepted: lines are only ever added, so a seed too close once stays too close).

    Returns the lines, why each line's start and end stopped, the family at each line's seed and the face and face
    coordinate of every line point.
    """
    tr, grid, sep = sd.tr, sd.grid, sd.sep
    stop = _SeparationTest(grid, sd.d_test)
    r_seed = sep * 0.999
    lines: list[np.ndarray] = []
    reasons: list[list[str]] = []
    line_fam: list[int] = []
    line_locs: list[list] = []

    def entries(seeds):  # (f, z, k, point, tangent), seeds near a singularity left out
        out = []
        for f, z, k in seeds:
            p0 = tr.point3(f, z)
            if not tr.near_singularity(f, p0):
                out.append((f, z, k, p0, tr.vector3(f, tr.face_vector(f, k))))
        return out

    def usable(q, since: int = 0):  # the seeds not too close to an accepted line (stored from block ``since`` on)
        if not q or not len(grid):
            return q
        near = grid.hits([e[3] for e in q], r_seed, [e[4] for e in q], first_block=since).tolist()
        return [e for e, n in zip(q, near) if not n]

    queue = usable(entries(queue))
    head = 0
    u = tr.face_vec[:, fam]
    cover_tan = tr.fr.e1 * u.real[:, None] + tr.fr.e2 * u.imag[:, None]  # = vector3(f, face_vector(f, fam))
    cover = np.asarray(cover, np.int64)
    cover_pos = 0
    total = 0
    while True:
        if head >= len(queue):
            queue, head = [], 0
            while cover_pos < len(cover):  # the next cover face with no accepted line within sep
                fs = cover[cover_pos:cover_pos + 256]
                near = grid.hits(tr.fr.centroid[fs], sep, cover_tan[fs])
                if near.all():
                    cover_pos += len(fs)
                    continue
                i = int(np.argmin(near))
                cover_pos += i + 1
                f = int(fs[i])
                queue = usable(entries([(f, (tr.corner(f, 1) + tr.corner(f, 2)) / 3.0, fam)]))
                break
            if not queue:
                if cover_pos >= len(cover):
                    break
                continue
        f, z, k = queue[head][:3]
        head += 1
        line, why, locs = _trace_both_ways(sd, f, z, k, stop)
        if len(line) < 2:
            continue
        arr = np.asarray(line)
        seg = np.linalg.norm(np.diff(arr, axis=0), axis=1)
        if seg.sum() < max(sd.min_length, 1e-12 * sep):  # relative: the same at any scale
            continue
        nb = grid.nb  # the blocks of the lines before this one (the queued seeds were tested against them)
        lines.append(arr)
        line_locs.append(locs)
        reasons.append(list(why))
        line_fam.append(k)
        _add_line(grid, arr, len(lines) - 1, 3.0 * sd.d_test)
        total += len(line)
        if total > _MAX_POINTS:
            log.warning("evenly_spaced_streamlines: point budget reached, stopping")
            break
        # the queued seeds, tested against the earlier lines already, only against the new one
        queue = usable(queue[head:], since=nb) + usable(entries(_offset_seeds(sd, arr, seg, k, locs)))
        head = 0
    return lines, reasons, line_fam, line_locs


def _trace_both_ways(sd: _Seeding, f: int, z: complex, k: int, stop):
    """One line through a seed, forwards then backwards, why its start and end stopped, and the face and face
    coordinate of its points."""
    tr = sd.tr
    fwd, closed = tr.trace(f, z, k, 1.0, sd.step, sd.max_length, stop=stop, self_distance=sd.d_test,
                           keep_family=sd.labelled)
    why = (tr.stop_reason, tr.stop_reason)
    line, locs = fwd, tr.locs
    if not closed:
        floc = locs
        bwd, bclosed = tr.trace(f, z, k, -1.0, sd.step, sd.max_length, stop=stop, self_distance=sd.d_test,
                                keep_family=sd.labelled)
        if bclosed:  # the backward half went round the loop alone: it is the whole line
            line, locs = bwd[::-1], tr.locs[::-1]
            why = ("closed", "closed")
        else:
            line, locs = bwd[::-1] + fwd[1:], tr.locs[::-1] + floc[1:]
            why = (tr.stop_reason, why[1])
    return line, why, locs


def _offset_seeds(sd: _Seeding, arr: np.ndarray, seg: np.ndarray, k: int, line_locs: list) -> list:
    """Candidate seeds at the separation on both sides of a new line, every ~separation/2 along it (and for a net
    the crossing family's seeds on the line itself); ``line_locs`` the face and face coordinate of its points."""
    tr, sep = sd.tr, sd.sep
    out = []
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    picks = np.searchsorted(cum, np.arange(0.0, cum[-1] + 1e-12 * sep, 0.5 * sep))
    picks = np.unique(np.minimum(picks, len(arr) - 1))
    starts = []  # (face, face coordinate, direction along the line) at the picked points
    for i in picks.tolist():
        lf, lz = line_locs[i]
        j = min(i + 1, len(arr) - 1)
        i0 = j - 1 if j > 0 else 0
        t3 = arr[j] - arr[i0]
        dz = complex(float(t3 @ tr.fr.e1[lf]), float(t3 @ tr.fr.e2[lf]))
        if abs(dz) == 0:
            continue
        starts.append((lf, lz, dz))
    for lf, lz, dz in starts:
        for side in (1j, -1j):
            res = tr.walk(lf, lz, dz * side, sep)
            if res is not None:
                wf, wz, wd = res
                # the seed continues the family of the line it was offset from
                out.append((wf, wz, k if sd.labelled else tr.family_in(wf, wd * (-side))))
        if sd.both:  # the crossing family starts on the line itself
            out.append((lf, lz, 1 - k if sd.labelled else 1 - tr.family_in(lf, dz)))
    return out


def _extend_ends(tr, lines, reasons, line_fam, grid, d_ext, step, max_length, labelled, line_locs):
    """Continue every line end stopped by the separation test until it comes within ``d_ext`` of another line
    (or meets the boundary, a singularity, ...). Updates ``lines``, ``reasons``, ``grid`` and ``line_locs`` (the
    face and face coordinate of every line point) in place."""
    for i in range(len(lines)):
        for end in (0, 1):
            if reasons[i][end] != "separation":
                continue
            arr = lines[i]
            pts = arr if end == 1 else arr[::-1]
            tan = pts[-1] - pts[max(len(pts) - 3, 0)]
            if not np.any(tan):
                continue
            lf, lz = line_locs[i][-1] if end == 1 else line_locs[i][0]
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
            line_locs[i] = line_locs[i] + tr.locs[1:] if end == 1 else tr.locs[:0:-1] + line_locs[i]
            grid.add(np.vstack([pts[-1:], E]), owner=2 * i + end)


def _add_line(grid, arr, i, reach):
    """Add a line to the separation grid; its points within arc length ``reach`` of its start (end) are owned by
    ``2 i`` (``2 i + 1``) so that an extension of that end ignores them, the others by nobody."""
    seg = np.linalg.norm(np.diff(arr, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    own = np.full(len(arr), -1, dtype=np.int64)
    own[cum >= cum[-1] - reach] = 2 * i + 1
    own[cum <= reach] = 2 * i
    D = np.zeros_like(arr)  # central-difference unit tangents (one-sided at the ends)
    if len(arr) > 1:
        D[1:-1] = arr[2:] - arr[:-2]
        D[0] = arr[1] - arr[0]
        D[-1] = arr[-1] - arr[-2]
    L = np.linalg.norm(D, axis=1, keepdims=True)
    D = np.divide(D, L, out=np.zeros_like(D), where=L > 0)
    for o in np.unique(own).tolist():
        sel = own == o
        grid.add_points(arr[sel], D[sel], owner=o)


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
