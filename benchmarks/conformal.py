"""Benchmark: conformal maps (LSCM, spectral, disk/square) beside libigl, and conical face offsets.

Run from the project root:  ``/work/venv/bin/python benchmarks/conformal.py [--quick] [--pipeline]``
(``--pipeline``: only the curvature-network table; ``--pipeline --quick``: only its ~5k-triangle rows).

Prints three tables:
1. LSCM (two pinned vertices, the same pins for both) and fixed-boundary disk maps: ours vs ``igl.lscm`` /
   ``igl.harmonic`` on the shared real meshes and on generated height-field grids of growing size: time (best of 3),
   time ratio, mean/max quasi-conformal ratio σ1/σ2, flipped triangles, max |UV_ours − UV_igl| / UV extent.
2. Sparse factorization of the reduced LSCM system for the orderings considered (why ``_factor`` uses
   MMD_AT_PLUS_A in symmetric mode on interleaved unknowns). SuperLU MMD_AT_PLUS_A *without* symmetric mode is
   left out: it did not finish in minutes on face.obj (the sparse-solver trap of geometry-notes.md).
3. Face offset of conical meshes: time and errors.

Measured on the 2-core project machine (shared with other jobs; igl 2.6 bindings): LSCM with the same pins
reproduces ``igl.lscm`` to 4e-12 (relative) with identical distortion and no flips; time 1.1-1.6x igl from 5k
to 80k triangles, 3-4.6x on the smallest real meshes (Python overhead around a 10 ms solve). Interleaving the
unknowns made the factorization 4x faster than the stacked [u; v] layout with the same ordering (0.15 s vs 0.65 s
on face.obj). The spectral variant costs 3-10x the pinned one (ARPACK shift-invert iterations).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from components.conical.cones import conical_check, face_offset  # noqa: E402
from forked import best_of, peak_mb, run_forked  # noqa: E402
from components.core.mesh import boundary_loops, quad_grid, read_mesh, triangulate  # noqa: E402
from components.core.conformal import (  # noqa: E402
    _farthest_pair,
    _lscm_matrix,
    conformal_distortion,
    disk_map,
    lscm,
)

try:
    import igl
except ImportError:  # pragma: no cover
    igl = None

SHARED = ROOT.parent / "shared" / "data" / "meshes"


def height_grid(n):
    V, Q = quad_grid(n, n, 6.0, 6.0, height=lambda x, y: 0.8 * np.sin(x) * np.cos(y))
    return V, triangulate(Q)[0]


def meshes(quick):
    names = ["libigl/inspired_mesh.obj", "libigl/camelhead.off"] + ([] if quick else ["libigl/face.obj"])
    for name in names:
        p = SHARED / name
        if p.exists():
            V, F = read_mesh(p)
            yield name.split("/")[-1], V, triangulate(F)[0]
    for n in ([50, 100] if quick else [50, 100, 200]):
        V, T = height_grid(n)
        yield f"sin·cos grid {n}²", V, T


def stats(V, T, UV):
    d = conformal_distortion(V, T, UV)
    return d.ratio.mean(), d.ratio.max(), int(d.flipped.sum())


def table_maps(quick):
    print("\n## 1. Conformal maps vs libigl (time: best of 3, seconds)\n")
    print("| mesh | tris | map | ours s | igl s | ours/igl | ratio mean ours | ratio mean igl | ratio max ours "
          "| flips ours/igl | max UV diff |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, V, T in meshes(quick):
        b = boundary_loops(T)[0]
        i, j = _farthest_pair(V[b])
        pins = np.array([b[i], b[j]])
        bc = np.array([[0.0, 0.0], [np.linalg.norm(V[pins[1]] - V[pins[0]]), 0.0]])
        t_ours, UV = best_of(lambda: lscm(V, T, pinned=pins, pinned_uv=bc))
        mo, xo, fo = stats(V, T, UV)
        if igl is not None:
            t_igl, (UVi, _) = best_of(lambda: igl.lscm(V, T, pins, bc))
            mi, _, fi = stats(V, T, UVi)
            diff = np.abs(UV - UVi).max() / np.ptp(UVi)
        else:
            t_igl, mi, fi, diff = np.nan, np.nan, -1, np.nan
        print(f"| {name} | {len(T)} | LSCM pinned | {t_ours:.3f} | {t_igl:.3f} | {t_ours / t_igl:.2f} | {mo:.5f} | "
              f"{mi:.5f} | {xo:.3f} | {fo}/{fi} | {diff:.1e} |")
        t_sp, UVs = best_of(lambda: lscm(V, T, method="spectral"), repeat=1)
        ms, xs, fs = stats(V, T, UVs)
        print(f"| {name} | {len(T)} | LSCM spectral | {t_sp:.3f} | — | — | {ms:.5f} | — | {xs:.3f} | {fs}/— | — |")
        t_d, (UVd, info) = best_of(lambda: disk_map(V, T, shape="disk"))
        md, xd, fd = stats(V, T, UVd)
        if igl is not None:
            bnd = igl.boundary_loop(T)
            t_h, UVh = best_of(lambda: igl.harmonic(V, T, bnd, igl.map_vertices_to_circle(V, bnd), 1))
            mh, _, fh = stats(V, T, UVh)
        else:
            t_h, mh, fh = np.nan, np.nan, -1
        print(f"| {name} | {len(T)} | disk ({info['weights']}) vs igl.harmonic | {t_d:.3f} | {t_h:.3f} | "
              f"{t_d / t_h:.2f} | {md:.5f} | {mh:.5f} | {xd:.3f} | {fd}/{fh} | — |")
        t_q, (UVq, info) = best_of(lambda: disk_map(V, T, shape="square"), repeat=1)
        mq, xq, fq = stats(V, T, UVq)
        print(f"| {name} | {len(T)} | square ({info['weights']}) | {t_q:.3f} | — | — | {mq:.5f} | — | {xq:.3f} | "
              f"{fq}/— | — |")


def table_orderings(quick):
    print("\n## 2. Factorizing the reduced LSCM system (SuperLU), seconds\n")
    name = "libigl/camelhead.off" if quick else "libigl/face.obj"
    p = SHARED / name
    if not p.exists():
        print("(shared data absent)")
        return
    V, F = read_mesh(p)
    T = triangulate(F)[0]
    n = len(V)
    Q = _lscm_matrix(V, T).tocsr()
    b = boundary_loops(T)[0]
    free_v = np.ones(n, dtype=bool)
    free_v[[b[0], b[len(b) // 2]]] = False
    stacked = np.r_[free_v, free_v]
    perm = np.arange(2 * n).reshape(2, n).T.ravel()
    Qi = Q[perm][:, perm]
    inter = stacked[perm]
    print(f"{name}: {2 * n} unknowns\n")
    print("| unknowns | ordering | symmetric mode | factor s | nnz(L+U) |")
    print("|---|---|---|---|---|")
    for label, A in (("stacked [u; v]", Q[stacked][:, stacked]), ("interleaved", Qi[inter][:, inter])):
        A = A.tocsc()
        for spec, sym in (("MMD_AT_PLUS_A", True), ("COLAMD", True), ("COLAMD", False)):
            kw = dict(diag_pivot_thresh=0.0, options={"SymmetricMode": True}) if sym else {}
            t, lu = best_of(lambda: spla.splu(A, permc_spec=spec, **kw), repeat=2)
            print(f"| {label} | {spec} | {sym} | {t:.3f} | {lu.L.nnz + lu.U.nnz} |")


def revolution_net(nz, nt):
    z = np.linspace(-1, 1, nz + 1)
    th = np.linspace(0, 0.8 * np.pi, nt + 1)
    Z, Th = np.meshgrid(z, th, indexing="ij")
    R = 1 + 0.1 * Z + 0.3 * Z**2
    V = np.stack([R * np.cos(Th), R * np.sin(Th), Z], -1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(nz + 1, nt + 1)
    F = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], 1)
    return V, F


def table_offsets(quick):
    print("\n## 3. Face offsets of conical meshes (d = 0.1 · mean edge length unless stated)\n")
    print("| mesh | quads | d | time s | max |dist − d| | max vertex residual | axis coplanarity max / median "
          "| max angle criterion |")
    print("|---|---|---|---|---|---|---|---|")
    cases = []
    p = SHARED / "dos/obj_pq__conical1.obj"
    if p.exists():
        V, F = read_mesh(p)
        cases += [("dos conical1", V, F, 0.1), ("dos conical1", V, F, 1.0)]
    for nz, nt in ((40, 40), (100, 100)) if quick else ((40, 40), (100, 100), (300, 300)):
        V, F = revolution_net(nz, nt)
        cases.append((f"revolution net {nz}×{nt}", V, F, 0.01))
    for name, V, F, d in cases:
        t, off = best_of(lambda: face_offset(V, F, d))
        crit = conical_check(V, F).max_criterion
        print(f"| {name} | {len(F)} | {d:g} | {t:.3f} | {off.face_error.max():.1e} | {off.vertex_residual.max():.1e} "
              f"| {off.axis_coplanarity.max():.1e} / {np.median(off.axis_coplanarity):.1e} | {crit:.1e} |")


def _pipeline_case(case, tracer):
    """One curvature-network case in a fresh (forked) process: its numbers, CPU seconds and peak memory."""
    from components.network.pipeline import curvature_pipeline
    from components.surfaces.samples import sample_mesh

    name, res, h, scale, shift = case
    if res:
        V, T, _ = sample_mesh(name, res)
    else:
        V, T = read_mesh(SHARED / "libigl/inspired_mesh.obj")
        T = triangulate(T)[0]
    V, h = V * scale + shift, h * scale
    tm = {}
    c = time.process_time()
    r = curvature_pipeline((V, T), h, offset=0.1 * h, tracer=tracer, timings=tm)
    cpu = time.process_time() - c
    return (len(T), tm, cpu, peak_mb(), len(r.optimized[1]), r.quad_fraction, r.mean_angle_error,
            r.max_planarity, r.max_criterion, r.relative_closeness, r.max_offset_error / (0.1 * h), r.healthy,
            r.coverage)


def table_curvature_pipeline(quick):
    """pq_from_curvature_network step timings on ~5k and ~20k triangles, and on a ×1000 scaled and a +5e6 translated
    copy of the 5k wave (the same numbers up to scale: closeness / edge and offset error / d are scale-free). The
    network is traced by components.fields.streamlines when present, else by the private test tracer of
    tests/components; each case runs in a fresh process (peak memory is its high-water mark; CPU seconds are steadier
    than the wall clock on a shared machine)."""
    tracer = None
    try:
        import components.fields.streamlines  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from tests.components.test_curvature_network import trace_evenly as tracer
    print("\n### pq_from_curvature_network (tracer: " + ("components.fields.streamlines" if tracer is None else
                                                         "private test tracer") + ")\n")
    print("| surface | triangles | panel | faces | quads % | angle err ° | network s | rebuild s | optimize s "
          "| total s | cpu s | peak MB | max planarity | max criterion | closeness / edge | offset err / d | healthy "
          "| coverage |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    names = ("saddle", "dome", "wave", "canopy")
    cases = [(n, 60, 2.0, 1.0, 0.0) for n in names] + ([] if quick else [(n, 120, 1.5, 1.0, 0.0) for n in names])
    # the same result at every scale and placement (numbers up to scale: closeness / edge, offset error / d)
    cases += [("wave", 60, 2.0, 1000.0, 0.0), ("wave", 60, 2.0, 1.0, 5e6)]
    if (SHARED / "libigl/inspired_mesh.obj").exists():
        cases.append(("inspired_mesh", 0, 2.0, 1.0, 0.0))
    for case in cases:
        res = run_forked(_pipeline_case, case, tracer)
        if res is None:
            raise RuntimeError(f"the pipeline case {case} crashed its process")
        nt, tm, cpu, peak, nf, qf, ang, pl, crit, close, off, healthy, cov = res
        name, _, h, scale, shift = case
        name += f" ×{scale:g}" if scale != 1 else ""
        name += f" +{shift:g}" if shift else ""
        print(f"| {name} | {nt} | {h * scale:g} | {nf} | {100 * qf:.1f} | {ang:.2f} "
              f"| {tm['network']:.2f} | {tm['rebuild']:.2f} | {tm.get('optimize', 0):.2f} | {tm['total']:.2f} "
              f"| {cpu:.2f} | {peak:.0f} | {pl:.1e} | {crit:.1e} | {close:.3f} | {off:.1e} | {healthy} | {cov:.3f} |",
              flush=True)


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    if "--pipeline" in sys.argv:  # only the curvature-network table
        table_curvature_pipeline(quick)
        sys.exit(0)
    table_maps(quick)
    table_orderings(quick)
    table_offsets(quick)
    table_curvature_pipeline(quick)
