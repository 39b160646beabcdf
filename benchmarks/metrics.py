"""Time the full metric report and the closest-point index, beside libigl and trimesh in the same run.

Run from the project root::

    /work/venv/bin/python benchmarks/metrics.py            # 10k and 100k quads, 50k triangles / 100k points
    /work/venv/bin/python benchmarks/metrics.py --quick    # smaller sizes

Targets: the full report of 100k quads under 1 s on one core. Times are the median of ``--repeat`` runs; both wall
time and process CPU time are printed (on a shared machine the CPU time is the fairer one-core number).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from components.metrics import quality as metrics  # noqa: E402
from components.core.mesh import quad_grid, triangulate  # noqa: E402
from components.core.proximity import TriangleIndex  # noqa: E402


def timed(fn, repeat):
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return float(np.median(walls)), float(np.median(cpus)), out


def wavy_grid(n):
    return quad_grid(n, n, 10.0, 10.0, height=lambda x, y: 0.8 * np.sin(0.7 * x) * np.cos(0.5 * y) + 0.05 * x * y)


def row(name, wall, cpu, note=""):
    print(f"| {name:<52} | {wall:8.3f} | {cpu:8.3f} | {note} |")


def bench_report(sizes, repeat):
    print("\n## Full metric report (metrics_report: validation + every measure)\n")
    print(f"| {'case':<52} | {'wall s':>8} | {'cpu s':>8} | note |")
    print(f"|{'-' * 54}|{'-' * 10}|{'-' * 10}|------|")
    try:
        import igl
    except ImportError:  # pragma: no cover
        igl = None
    for n in sizes:
        V, Q = wavy_grid(n)
        m = len(Q)
        wall, cpu, table = timed(lambda: metrics.metrics_report(V, Q), repeat)
        target = "target < 1 s (100k)" if m >= 100_000 else ""
        row(f"metrics_report, {m:,} quads ({len(table)} numbers)", wall, cpu, target)
        w2, c2, ours = timed(lambda: metrics.quad_planarity(V, Q), repeat)
        row(f"  quad_planarity only, {m:,} quads", w2, c2)
        if igl is not None:
            w3, c3, ref = timed(lambda: igl.quad_planarity(V, Q), repeat)
            err = float(np.max(np.abs(np.abs(ref) - ours)))
            row(f"  igl.quad_planarity, {m:,} quads", w3, c3, f"max |diff| {err:.1e}, ratio {w2 / w3:.2f}")
        for name in ("planarity", "area", "min_angle", "verdict_scaled_jacobian", "conical", "valence"):
            w4, c4, _ = timed(lambda: metrics.measure_values(V, Q, name), repeat)
            row(f"  measure {name!r}", w4, c4)
        w5, c5, _ = timed(lambda: metrics.analysis((V, Q), "planarity"), repeat)
        row(f"  analysis(planarity) incl. validation + display mesh", w5, c5)


def bench_proximity(n_tri_quads, n_points, repeat):
    print("\n## Closest points on a triangle mesh (TriangleIndex vs trimesh + rtree)\n")
    print(f"| {'case':<52} | {'wall s':>8} | {'cpu s':>8} | note |")
    print(f"|{'-' * 54}|{'-' * 10}|{'-' * 10}|------|")
    V, Q = wavy_grid(n_tri_quads)
    T, _ = triangulate(Q)
    rng = np.random.default_rng(0)
    edge = 10.0 / n_tri_quads
    near = V[rng.integers(0, len(V), n_points)] + edge * rng.normal(size=(n_points, 3))
    lo, hi = V.min(axis=0) - 1.0, V.max(axis=0) + 1.0
    box = rng.uniform(lo, hi, size=(n_points // 10, 3))
    wall, cpu, index = timed(lambda: TriangleIndex(V, T), repeat)
    row(f"build TriangleIndex, {len(T):,} triangles", wall, cpu)
    try:
        import trimesh

        mesh = trimesh.Trimesh(V, T, process=False)
        import rtree  # noqa: F401
    except ImportError:  # pragma: no cover
        mesh = None
    for label, P in (("near surface (±1 edge)", near), ("uniform in bbox+1", box)):
        wall, cpu, res = timed(lambda: index.query(P), repeat)
        row(f"query {len(P):,} points {label}", wall, cpu)
        ws, cs, _ = timed(lambda: index.query(P, signed=True), repeat)
        row(f"query {len(P):,} points {label}, signed", ws, cs)
        if mesh is not None:
            def tm():
                m2 = trimesh.Trimesh(V, T, process=False)  # fresh: trimesh caches its r-tree on the mesh
                return trimesh.proximity.closest_point(m2, P)

            wt, ct, (_, dist, _) = timed(tm, 1)
            diff = res.distances - dist
            worse = int(np.count_nonzero(dist > res.distances + 1e-12))
            row(f"  trimesh.proximity.closest_point (rtree, incl. build)", wt, ct,
                f"ours/trimesh {wall / wt:.2f}; trimesh farther at {worse} pts (max {np.max(-diff):.1e}); "
                f"never closer: {bool(np.all(diff <= 1e-12))}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    if args.quick:
        bench_report([100], args.repeat)
        bench_proximity(50, 10_000, args.repeat)
    else:
        bench_report([100, 316], args.repeat)  # 10,000 and 99,856 quads
        bench_proximity(158, 100_000, args.repeat)  # 49,928 triangles
    print(f"\nload average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
