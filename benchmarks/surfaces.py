"""Timings of curve/surface evaluation, surface construction and sample meshing, beside rhino3dm.

Run from the project root:  /work/venv/bin/python benchmarks/surfaces.py

rhino3dm (the reference evaluator) has no bulk evaluation, so it is timed with a Python loop of ``PointAt``
calls; the table prints both and the speed-up, plus the largest difference between the two results.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from components.surfaces.curves import curve_points, equal_chord_points, sample_curve  # noqa: E402
from components.surfaces.samples import sample_mesh  # noqa: E402
from components.surfaces.generators import (  # noqa: E402
    scale_translation,
    surface_mesh,
    translation,
)
from components.core.types import NurbsCurve, NurbsSurface  # noqa: E402

try:
    import rhino3dm
except ImportError:  # pragma: no cover
    rhino3dm = None


def best(fn, repeat=3):
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def random_curve(rng, n=12, degree=3):
    P = np.cumsum(rng.normal(size=(n, 3)), axis=0) * 3
    K = np.concatenate([np.zeros(degree), np.linspace(0, 1, n - degree + 1)[1:-1], np.ones(degree)])
    return NurbsCurve(degree, P, rng.uniform(0.5, 2, n), K)


def random_surface(rng, nu=12, nv=10, d=3):
    I, J = np.meshgrid(np.arange(nu) * 4.0, np.arange(nv) * 4.0, indexing="ij")
    P = np.stack([I, J, np.zeros_like(I)], -1) + rng.normal(size=(nu, nv, 3))
    Ku = np.concatenate([np.zeros(d), np.linspace(0, 1, nu - d + 1)[1:-1], np.ones(d)])
    Kv = np.concatenate([np.zeros(d), np.linspace(0, 1, nv - d + 1)[1:-1], np.ones(d)])
    return NurbsSurface(d, d, P, rng.uniform(0.5, 2, (nu, nv)), Ku, Kv)


def rhino_curve(c):
    rc = rhino3dm.NurbsCurve(3, True, c.degree + 1, len(c.points))
    for i, (p, w) in enumerate(zip(c.points.tolist(), c.weights.tolist())):
        rc.Points[i] = rhino3dm.Point4d(p[0] * w, p[1] * w, p[2] * w, w)
    for i, k in enumerate(c.knots.tolist()):
        rc.Knots[i] = k
    return rc


def rhino_surface(s):
    nu, nv = s.points.shape[:2]
    rs = rhino3dm.NurbsSurface.Create(3, True, s.degree_u + 1, s.degree_v + 1, nu, nv)
    for i in range(nu):
        for j in range(nv):
            w = float(s.weights[i, j])
            rs.Points[i, j] = rhino3dm.Point4d(*(s.points[i, j] * w).tolist(), w)
    for i, k in enumerate(s.knots_u.tolist()):
        rs.KnotsU[i] = k
    for i, k in enumerate(s.knots_v.tolist()):
        rs.KnotsV[i] = k
    return rs


def main():
    rng = np.random.default_rng(0)
    rows = []

    c = random_curve(rng)
    rc = rhino_curve(c) if rhino3dm else None
    for m in (1_000, 100_000):
        t = np.linspace(0, 1, m)
        ours, P = best(lambda: curve_points(c, t))
        if rc is not None:
            ref, R = best(lambda: np.array([[q.X, q.Y, q.Z] for q in map(rc.PointAt, t.tolist())]), repeat=1)
            rows.append((f"curve points, {m:,}", ours, ref, float(np.abs(P - R).max())))
        else:
            rows.append((f"curve points, {m:,}", ours, None, None))
    equal_chord_points(c, 5)  # warm-up: first use imports scipy.sparse.linalg
    for n in (100, 1_000):
        ours, _ = best(lambda: sample_curve(c, n, "arclength"))
        rows.append((f"arc-length division, {n:,} segments", ours, None, None))
        ours, _ = best(lambda: equal_chord_points(c, n), repeat=1)
        rows.append((f"equal-chord division, {n:,} chords", ours, None, None))

    s = random_surface(rng)
    rs = rhino_surface(s) if rhino3dm else None
    for n in (50, 200, 1000):
        ours, r = best(lambda: surface_mesh(s, n, n), repeat=1 if n >= 1000 else 3)
        V = r.mesh[0]
        name = f"surface_mesh {n}×{n} ({len(r.mesh[1]):,} tris)"
        if rs is not None and n <= 200:
            ref, R = best(lambda: np.array([[q.X, q.Y, q.Z] for q in (rs.PointAt(u, v) for u, v, _ in r.uv.tolist())]),
                          repeat=1)
            rows.append((name, ours, ref, float(np.abs(V - R).max())))
        else:
            rows.append((name, ours, None, None))

    g = random_curve(rng, 8)
    d = NurbsCurve(3, g.points[:, [1, 0, 2]] * [1, 1, 0.3], g.weights, g.knots)
    for n in (100, 500):
        ours, r = best(lambda: translation(g, d, n, n))
        rows.append((f"translation {n}×{n}", ours, None, r.max_planarity))
        ours, r = best(lambda: translation(g, d, n, n, equal_steps=True), repeat=1)
        rows.append((f"translation {n}×{n}, equal steps", ours, None, r.max_planarity))
        ours, r = best(lambda: scale_translation(g, d, scale=0.999, count_u=n, count_v=n))
        rows.append((f"scale_translation {n}×{n}", ours, None, r.max_planarity))

    for name in ("dome", "canopy"):
        for res in (32, 128, 256):
            ours, (V, T, _) = best(lambda: sample_mesh(name, res), repeat=1)
            rows.append((f"sample_mesh {name} res {res} ({len(T):,} tris)", ours, None, None))

    print(f"{'step':48s} {'ours [s]':>10s} {'rhino3dm [s]':>13s} {'speed-up':>9s} {'max diff / planarity':>21s}")
    for name, ours, ref, diff in rows:
        ref_s = f"{ref:13.4f}" if ref is not None else f"{'-':>13s}"
        ratio = f"{ref / ours:9.1f}" if ref is not None else f"{'-':>9s}"
        diff_s = f"{diff:21.2e}" if diff is not None else f"{'-':>21s}"
        print(f"{name:48s} {ours:10.4f} {ref_s} {ratio} {diff_s}")


if __name__ == "__main__":
    main()
