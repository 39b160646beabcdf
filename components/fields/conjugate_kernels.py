"""Compiled local step of the conjugate field (:mod:`components.core.compiled`): the per-face sample search of
:func:`components.fields.field._search`, or None where numba is unavailable.

Each function performs the operations of the numpy code in :mod:`components.fields.field` in the same order
(:func:`_costs` and :func:`_tangent` are :func:`components.fields.field._conjugate_cost` for one row of samples,
:func:`search` the sampling and refinement of ``_search``, :func:`swaps` its ``want_swap`` test), so the results are
the same bit for bit. The cases the numpy code settles by its own rules (two samples within the tie margin, NaN
costs) are only flagged here: the caller runs the numpy search on those faces. Transcendental functions stay in
numpy (the samples' cosines and sines and the level offsets' are inputs).

Measured on the 200k-triangle benchmark patch (one thread, a warm local step of 200,677 faces): 73 ms with numpy,
11 ms compiled (20 ms with the numpy parts around it); the same angles and assignments bit for bit.
"""
from __future__ import annotations

import numpy as np

from components.core.compiled import kernel

__all__ = ["search", "swaps"]

_ROW = "float64[::1]"
_BLOCK = f"{_ROW}, {_ROW}, {_ROW}, {_ROW}, {_ROW}, {_ROW}"  # k1, k2, ar, ai, br, bi


@kernel("UniTuple(float64, 4)(float64, float64, float64, float64)")
def _doubled(ca, sa, k1, k2):  # pragma: no cover (compiled)
    """Doubled angles ``(c2a, s2a, c2b, s2b)`` of the sample ``a`` (``ca, sa``) and of its conjugate direction
    ``b(a)`` for the curvatures ``k1, k2`` (``_conjugate_cost``'s first lines)."""
    x = sa * (-k2)
    y = ca * k1
    xx = x * x
    yy = y * y
    r2 = xx + yy
    r2 = 1.0 if r2 == 0.0 else r2
    c2b = (xx - yy) / r2
    s2b = ((x * 2.0) * y) / r2
    return ca * ca - sa * sa, (ca * 2.0) * sa, c2b, s2b


@kernel(f"void({_ROW}, {_ROW}, {_BLOCK}, float64, {_ROW}, {_ROW})")
def _costs(ca, sa, k1, k2, ar, ai, br, bi, smin2, const, D):  # pragma: no cover (compiled)
    """``D`` = twice the cost of the samples ``ca, sa`` (one per face) without the tangent term's tangent faces
    (``const``: its constant, zeros without tangents)."""
    for i in range(len(ca)):
        c2a, s2a, c2b, s2b = _doubled(ca[i], sa[i], k1[i], k2[i])
        d1 = (2.0 - (c2a * ar[i] + s2a * ai[i])) - (c2b * br[i] + s2b * bi[i])
        d2 = (2.0 - (c2a * br[i] + s2a * bi[i])) - (c2b * ar[i] + s2b * ai[i])
        d = d1 if (d1 <= d2 or d1 != d1) else d2  # np.minimum: NaN wins
        sep2 = 1.0 - (c2a * c2b + s2a * s2b)
        d = d + ((smin2 - sep2) + 8.0) if sep2 < smin2 else d
        D[i] = d + const[i]


@kernel(f"void({_ROW}, {_ROW}, {_ROW}, {_ROW}, int64[::1], {_ROW}, {_ROW}, {_ROW}, {_ROW})")
def _tangent(ca, sa, k1, k2, tf, tr, ti, tw, D):  # pragma: no cover (compiled)
    """Add the tangent term of the faces ``tf`` (with their doubled tangent ``tr, ti`` and weight ``tw``) to ``D``."""
    for q in range(len(tf)):
        i = tf[q]
        c2a, s2a, c2b, s2b = _doubled(ca[i], sa[i], k1[i], k2[i])
        ta = c2a * tr[q] + s2a * ti[q]
        tb = c2b * tr[q] + s2b * ti[q]
        m = ta if (ta >= tb or ta != ta) else tb  # np.maximum: NaN wins
        D[i] = D[i] + (1.0 - m) * tw[q]


@kernel(f"void({_ROW}, {_ROW}, float64, float64, {_ROW}, {_ROW})")
def _rotate(bc, bs, c, s, ca, sa):  # pragma: no cover (compiled)
    """``ca, sa`` = cosine and sine of the angles ``b`` (given by ``bc, bs``) turned by the angle of ``c, s``."""
    for i in range(len(bc)):
        ca[i] = bc[i] * c - bs[i] * s
        sa[i] = bs[i] * c + bc[i] * s


@kernel(f"void({_BLOCK}, float64, {_ROW}, int64[::1], {_ROW}, {_ROW}, {_ROW}, {_ROW}, {_ROW}, {_ROW})")
def _row_costs(k1, k2, ar, ai, br, bi, smin2, const, tf, tr, ti, tw, ca, sa, D):  # pragma: no cover (compiled)
    """``D`` = twice the cost of one row of samples, tangent term included."""
    _costs(ca, sa, k1, k2, ar, ai, br, bi, smin2, const, D)
    _tangent(ca, sa, k1, k2, tf, tr, ti, tw, D)


@kernel(f"Tuple((float64[::1], boolean[::1]))({_BLOCK}, float64, {_ROW}, int64[::1], {_ROW}, {_ROW}, {_ROW}, "
        "float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], "
        "float64)")
def search(k1, k2, ar, ai, br, bi, smin, const, tf, tr, ti, tw, a, ca, sa, dd, cd, sd,
           tie):  # pragma: no cover (compiled)
    """The best angle per face: the best of the first samples ``a`` (rows; ``ca, sa`` their cosines and sines),
    refined level by level by the offsets ``dd`` (levels, k) (``cd, sd`` their cosines and sines) around the best
    so far; and the faces to settle by the numpy search (``flag``: two samples within ``tie`` of the best, or a NaN
    cost). Returns ``(angles, flag)``."""
    n = len(k1)
    smin2 = 2.0 * smin
    flag = np.zeros(n, dtype=np.bool_)
    rows = a.shape[0]
    D = np.empty((rows, n))
    for r in range(rows):
        _row_costs(k1, k2, ar, ai, br, bi, smin2, const, tf, tr, ti, tw, ca[r], sa[r], D[r])
    b, bc, bs, bD = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):  # the first lowest row (np.argmin in row order) and whether another is within the margin
        low, j, bad = np.inf, 0, False
        for r in range(rows):
            v = D[r, i]
            bad = bad or v != v
            if v < low:
                low, j = v, r
        near = 0
        for r in range(rows):
            if D[r, i] <= low + tie:
                near += 1
        flag[i] = bad or near > 1
        b[i], bc[i], bs[i], bD[i] = a[j, i], ca[j, i], sa[j, i], low
    levels, k = dd.shape
    Dk, CA, SA = np.empty((k, n)), np.empty((k, n)), np.empty((k, n))
    for lev in range(levels):
        for r in range(k):
            _rotate(bc, bs, cd[lev, r], sd[lev, r], CA[r], SA[r])
            _row_costs(k1, k2, ar, ai, br, bi, smin2, const, tf, tr, ti, tw, CA[r], SA[r], Dk[r])
        for i in range(n):  # the best of the k samples and the current best (kept on equal costs: flagged)
            low, j, bad = bD[i], -1, False
            for r in range(k):
                v = Dk[r, i]
                bad = bad or v != v
                if v < low:
                    low, j = v, r
            near = 1 if bD[i] <= low + tie else 0
            for r in range(k):
                if Dk[r, i] <= low + tie:
                    near += 1
            flag[i] = flag[i] or bad or near > 1
            if j >= 0:
                b[i], bc[i], bs[i], bD[i] = b[i] + dd[lev, j], CA[j, i], SA[j, i], low
    return b, flag


@kernel(f"boolean[::1]({_ROW}, {_ROW}, {_BLOCK})")
def swaps(cb, sb, k1, k2, ar, ai, br, bi):  # pragma: no cover (compiled)
    """Per face, whether the second assignment of the pair of the angle ``b`` (``cb, sb``) to ``(u, v)`` costs
    less (``_conjugate_cost(..., want_swap=True)``)."""
    n = len(cb)
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        c2a, s2a, c2b, s2b = _doubled(cb[i], sb[i], k1[i], k2[i])
        d1 = (2.0 - (c2a * ar[i] + s2a * ai[i])) - (c2b * br[i] + s2b * bi[i])
        d2 = (2.0 - (c2a * br[i] + s2a * bi[i])) - (c2b * ar[i] + s2b * ai[i])
        out[i] = d2 < d1
    return out


if search is None or swaps is None:  # numba unavailable, or a kernel failed to compile: none of them
    search = swaps = None
