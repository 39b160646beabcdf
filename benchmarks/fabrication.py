"""Benchmark: flat panels and panel types of 10,000 panels (issue 17's target: both together under 2 s).

Run from the project root::

    /work/venv/bin/python benchmarks/fabrication.py            # 10,000 panels per case
    /work/venv/bin/python benchmarks/fabrication.py --quick    # 2,500

Tables printed:

1. ``flat_panels`` (frames, flat outlines and their measures) and ``congruence_types`` (panel types at a tolerance
   with the counts at 1, 2, 5 and 10 × it) on five meshes of the same size: a surface of revolution (one type per
   ring), a cylinder (one type), a gently curved barrel of 1.5 m panels at 1 mm (few types, many nearly equal
   panels: the case where comparing every pair within the tolerance would explode), a strongly curved
   translation surface (thousands of types) and a soup of random quads (every panel its own type). Wall and process
   CPU time (median of ``--repeat`` runs; on a shared machine the CPU time is the fairer one-core number), the type
   counts and the worst deviation of a panel from its type's representative (never above the tolerance).
2. The rest of the stage on the same meshes: sheet layout, kinks, node axes and torsion, for scale.

There is no reference library for panel types (Evolute is closed; Kangaroo, libigl and COMPAS stop at planarity),
so the table checks itself: counts never increase with the tolerance and every deviation is within it.
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

from components.core.mesh import quad_grid  # noqa: E402
from components.fabrication.congruence import congruence_types  # noqa: E402
from components.fabrication.kinks import dihedral_angles  # noqa: E402
from components.fabrication.nodes import beam_frames, support_axes  # noqa: E402
from components.fabrication.panels import flat_panels, sheet_layout  # noqa: E402


def timed(fn, repeat):
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return float(np.median(walls)), float(np.median(cpus)), out


def revolution(nz, nt, profile=lambda z: 10 + 1.0 * z + 3.0 * z ** 2):
    z = np.linspace(-1, 1, nz + 1)
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    Z, Th = np.meshgrid(z, th, indexing="ij")
    R = profile(Z)
    V = np.stack([R * np.cos(Th), R * np.sin(Th), 10 * Z], -1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(nz + 1, nt)
    i, j = np.meshgrid(np.arange(nz), np.arange(nt), indexing="ij")
    i, j = i.ravel(), j.ravel()
    F = np.stack([idx[i, j], idx[i, (j + 1) % nt], idx[i + 1, (j + 1) % nt], idx[i + 1, j]], axis=1)
    return V, F


def barrel(n):
    """1.5 m panels on a 150 m barrel vault of 15 m rise: planar quads, nearly all alike at 1 mm."""
    V, Q = quad_grid(n, n, 1.5 * n, 1.5 * n)
    x = V[:, 0] / (1.5 * n) - 0.5
    V[:, 2] = 15.0 * (1 - 4 * x ** 2)
    return V, Q


def translation(n):
    """z = 0.4 x² − 0.3 y³ + 0.2 x on a 2 × 2 patch: planar quads, thousands of different ones."""
    V, Q = quad_grid(n, n, 2.0, 2.0)
    V[:, :2] -= 1
    V[:, 2] = 0.4 * V[:, 0] ** 2 - 0.3 * V[:, 1] ** 3 + 0.2 * V[:, 0]
    return V, Q


def soup(count, seed=0):
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0, 2 * np.pi, (count, 4)), axis=1)
    r = rng.uniform(0.6, 1.4, (count, 4))
    P = np.stack([r * np.cos(ang), r * np.sin(ang), np.zeros((count, 4))], axis=-1)
    P += np.stack([np.arange(count) * 3.0, np.zeros(count), np.zeros(count)], axis=1)[:, None, :]
    return P.reshape(-1, 3), np.arange(4 * count).reshape(count, 4)


def cases(n):
    return [
        ("surface of revolution", revolution(n, n), 1e-6),
        ("cylinder", revolution(n, n, profile=lambda z: 10 + 0 * z), 1e-6),
        ("barrel vault, 1.5 m panels", barrel(n), 1e-3),
        ("translation surface", translation(n), 1e-5),
        ("random quads", soup(n * n), 1e-3),
    ]


def row(cells):
    print("| " + " | ".join(cells) + " |")


def bench_types(n, repeat):
    print(f"\n## Flat panels + panel types, {n * n:,} panels (target: together under 2 s)\n")
    row(["mesh", "tolerance", "flat wall s", "flat cpu s", "types wall s", "types cpu s", "total wall s",
         "types at 1/2/5/10 × tol", "worst dev / tol", "under 2 s"])
    print("|" + "---|" * 10)
    for name, (V, F), tol in cases(n):
        wf, cf, fp = timed(lambda: flat_panels(V, F), repeat)
        wt, ct, res = timed(lambda: congruence_types(fp.outline, fp.sizes, tol, [2 * tol, 5 * tol, 10 * tol]),
                            repeat)
        assert np.all(np.diff(res.type_counts) <= 0)
        worst = float(res.worst_deviation.max()) / tol
        row([name, f"{tol:g}", f"{wf:.3f}", f"{cf:.3f}", f"{wt:.3f}", f"{ct:.3f}", f"{wf + wt:.3f}",
             "/".join(str(c) for c in res.type_counts.tolist()), f"{worst:.3f}", "yes" if wf + wt < 2.0 else "NO"])


def bench_rest(n, repeat):
    print(f"\n## The rest of the stage, {n * n:,} panels\n")
    row(["mesh", "sheet layout s", "kinks s", "node axes s", "torsion s", "axes", "max torsion °"])
    print("|" + "---|" * 7)
    for name, (V, F), _ in cases(n)[:4]:
        fp = flat_panels(V, F)
        wl, _, _ = timed(lambda: sheet_layout(fp, gap=0.01 * float(np.median(fp.rect_height))), repeat)
        wk, _, _ = timed(lambda: dihedral_angles(V, F), repeat)
        wa, _, sa = timed(lambda: support_axes(V, F), repeat)
        wb, _, fr = timed(lambda: beam_frames(V, F, sa.axes), repeat)
        row([name, f"{wl:.3f}", f"{wk:.3f}", f"{wa:.3f}", f"{wb:.3f}", sa.method,
             f"{np.abs(fr.torsion).max():.2e}"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2,500 panels per case (smoke run)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    n = 50 if args.quick else 100
    bench_types(n, args.repeat)
    bench_rest(n, args.repeat)
    print(f"\nload average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
