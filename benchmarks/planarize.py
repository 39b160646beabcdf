"""Benchmark: our planarization solver beside libigl's ``planarize_quad_mesh`` in the same run.

Meshes: regular quad grids laid on z = 0.3 sin x cos y with quads of size 0.7 (start max planarity ≈ 0.07) at 2,500,
10,000 and 100,000 quads, libigl's ``inspired_mesh_quads_Conjugate.off`` and the dos heart (start 0.12, the hardest).
Our solver runs with a free boundary and no closeness goal (what libigl solves: ShapeUp local/global, no closeness,
no fixed vertices) and, for the real meshes, also with its default goals against the input as reference and with
``on_surface`` (``planarize/on_surface``, sliding boundary).

libigl is very slow, so by default it runs a bounded number of iterations (``--igl-iters``, default 50 on 2,500
quads, scaled down for larger meshes, skipped on 100k); ``--full`` runs the long reference (2,000 iterations; many
minutes). Our times are the median of ``--repeats`` runs (wall clock, and CPU time in brackets: the machine may
be shared); "t→1e-3" / "t→1e-4" are read from the per-iteration history of the median run. The "→ ours to
libigl's" rows rerun our solver with libigl's final max planarity as the tolerance and compare time and mean
displacement at that planarity. Memory is the peak resident size of a child process that runs only our solver on the
largest mesh.

Noisy grids (issue #21): the sin-cos grid at 60² and 200² quads with every vertex lifted by a uniform random
±3 % of the edge in z (seeded; start max planarity ≈ 0.10, worst corner ≈ 86.6°), planarized with the defaults and
with the input as reference (the stiff-closeness case). Each run is a child process: its peak resident size
(``resource.getrusage``) and the number of sparse factorizations are printed beside it (best of ``--repeats``
runs by wall clock). geometrylab (guided projection, Tang et al. 2014) is an optional peer on the same grids,
loaded from a checkout given by ``--geometrylab PATH`` or the ``GEOMETRYLAB`` environment variable (skipped with a
note when absent; its code is not part of this project): as shipped (boundary gliding on) and with gliding off,
one ``optimize()`` iteration at a time until its max planarity is under 1e-4 or ``--peer-budget`` seconds.

Candidates against their surface (issue #21): the planarizer's input in ``pq_from_conjugate_field`` — the repaired
candidate of ``components.fields.candidate.candidate_mesh`` on benchmarks/fields.py's patch at 2.5 × its mean edge —
planarized with the pipeline's options (reference = the patch, tolerance 1e-4, sliding boundary, closeness weight
10, time budget 30 s; ``--candidate-budget`` on a loaded machine), plain, with every coordinate × 1000 and moved by
5e6 (the results must agree up to scale). The candidates are built here (``--candidates 20000 200000``: surface
sizes in triangles; the 200k one takes minutes) or read from saved ``.npz`` files (``--candidate-npz PATH ...``,
keys ``V``, ``T``, ``CV``, ``CF``). Each run is a child process (CPU and wall seconds, iterations / factorizations,
peak resident size).

Session 19 (2-core AMD EPYC), ``--noisy-only --repeats 1``, the code before and after the guard rows' corner margin
and the tie-free normals and tangents (benchmarks/convergence.py), one run after the other: defaults 60² 0.147 s (4
iterations), 200² 2.08 s (5 iterations, mean drift 0.175 edge, worst corner 85.9°), unchanged. With the input as
reference every vertex starts at a vertex of the reference (a tie between the faces around it, now the vertex's
normal): 60² 2.99 → 2.54 s (25 → 21 iterations, mean closeness 0.071 → 0.077 edges); 200² 29.8 s not converged
(1.38e-2, backed off to the last healthy state) → 27 s converged (9.6e-5, 13 iterations, closeness 0.108 edges).

Session 24 (another, slower 2-core machine), ``--noisy-only --repeats 3``, SuperLU → qdldl's LDLᵀ for the face-sized
systems (components/planarize/step.py ``factor_spd``), one run after the other: defaults 60² 0.128 → 0.150 s (4
iterations and 4 factorizations both: the machine's swing), 200² 2.22 → 1.85 s (5 iterations, mean drift 0.175 edge,
worst corner 85.9°, the same result); with the input as reference 60² 2.65 → 2.15 s (21 iterations, the same result),
200² 27.2 → 26.6 s (converged both: 12 → 14 iterations, 9.03e-5 → 9.49e-5, closeness 0.113 → 0.103 edges: round-off
sent the solver along another path). The default candidate rows: the same 12 iterations and result, 58 → 56
factorizations.

Usage: ``python benchmarks/planarize.py [--repeats 3] [--full] [--skip-100k] [--noisy-only] [--geometrylab PATH]
[--candidates N ...] [--candidate-npz PATH ...] [--candidate-budget S] [--candidates-only]``
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))  # forked.py, also when imported as benchmarks.planarize

from components.core.measures import corner_angles, nonconvex_faces, quad_planarity as face_planarity  # noqa: E402
from components.core.mesh import edge_lengths, edge_topology, quad_grid, read_mesh  # noqa: E402
from components.planarize import planarizer  # noqa: E402
from components.planarize.planarizer import planarize, planarize_mesh  # noqa: E402
from forked import counted_factorizations  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "meshes"


def sincos_grid(nq: int):
    L = 0.7 * nq
    V, F = quad_grid(nq, nq, L, L)
    V[:, 2] = 0.3 * np.sin(V[:, 0]) * np.cos(V[:, 1])
    return V, F


def noisy_grid(nq: int, amp: float = 0.03, seed: int = 0):
    """The sin-cos grid with every vertex lifted by a uniform random ``±amp`` × the edge (0.7) in z."""
    V, F = sincos_grid(nq)
    V[:, 2] += amp * 0.7 * np.random.default_rng(seed).uniform(-1.0, 1.0, len(V))
    return V, F


def _first_below(hist_p, hist_t, thr):
    idx = np.nonzero(np.asarray(hist_p) <= thr)[0]
    return float(hist_t[idx[0]]) if len(idx) else float("nan")


def _shortest_edge_ratio(V, F):
    L = edge_lengths(V, edge_topology(F).E)
    return float(L.min() / np.median(L))


def _row(name, m, method, t_total, t3, t4, V0, V, F, mel, closeness=float("nan"), extra=""):
    pl = face_planarity(V, F)
    d = np.linalg.norm(V - V0, axis=1) / mel
    ang = np.degrees(corner_angles(V, F).min())
    ncv = int(nonconvex_faces(V, F).sum())
    fmt = lambda x: "—" if x != x else f"{x:.3g}"  # noqa: E731
    print(f"| {name} | {m:,} | {method} | {fmt(t_total)} | {fmt(t3)} | {fmt(t4)} | {pl.max():.2e} | "
          f"{d.mean():.3f} / {d.max():.3f} | {fmt(closeness)} | {ang:.1f} | {_shortest_edge_ratio(V, F):.3g} | "
          f"{ncv} |{extra}", flush=True)
    return pl.max(), d.mean()


def run_ours(V, F, repeats, on_surface=False, array_level=False, **kw):
    runs = []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        if on_surface:
            res = planarizer.on_surface((V, F), (V, F), **kw)
        elif array_level:
            res = planarize_mesh(V, F, **kw)
        else:
            res = planarize((V, F), **kw)
        runs.append((time.perf_counter() - t, time.process_time() - c, res))
    runs.sort(key=lambda x: x[0])
    return runs[len(runs) // 2]


def _ours_row(name, m, method, run, V, F, mel, closeness=False):
    dt, cpu, res = run
    h = res.history_max_planarity
    _row(name, m, method, dt, _first_below(h, res.history_time, 1e-3), _first_below(h, res.history_time, 1e-4),
         V, res.mesh[0], F, mel, closeness=res.mean_closeness / mel if closeness else float("nan"),
         extra=f" {res.iterations} it, {res.stop_reason}, converged {res.converged}, healthy {res.healthy}, "
               f"CPU {cpu:.3g} s")
    return res


def run_igl(V, F, iters):
    import igl

    t = time.perf_counter()
    Vo = igl.planarize_quad_mesh(V, F, iters, 0.0)
    return time.perf_counter() - t, Vo


def bench_mesh(name, V, F, args, igl_iters, real=False):
    m = len(F)
    mel = float(edge_lengths(V, edge_topology(F).E).mean())
    print(f"| {name} | {m:,} | input | — | — | — | {face_planarity(V, F).max():.2e} | 0 / 0 | 0 | "
          f"{np.degrees(corner_angles(V, F).min()):.1f} | {_shortest_edge_ratio(V, F):.3g} | "
          f"{int(nonconvex_faces(V, F).sum())} |", flush=True)
    _ours_row(name, m, "ours (free, no closeness)", run_ours(V, F, args.repeats, boundary="free", closeness_weight=0.0,
                                                             tolerance=1e-4, time_budget=60.0), V, F, mel)
    if real:
        _ours_row(name, m, "ours (defaults, reference = input)",
                  run_ours(V, F, args.repeats, reference=(V, F), tolerance=1e-4), V, F, mel, closeness=True)
        _ours_row(name, m, "ours on_surface (slide)", run_ours(V, F, args.repeats, on_surface=True),
                  V, F, mel, closeness=True)
    if igl_iters:
        ti, Vi = run_igl(V, F, igl_iters)
        p_igl, d_igl = _row(name, m, f"libigl planarize_quad_mesh ({igl_iters} it)", ti, float("nan"), float("nan"),
                            V, Vi, F, mel)
        # our time and displacement at the planarity libigl reached: defaults, and without the optimize phase
        for label, kw in (("", {}), (", optimize_iterations=0", {"optimize_iterations": 0})):
            dt, cpu, res = run_ours(V, F, args.repeats, array_level=bool(kw), boundary="free", closeness_weight=0.0,
                                    tolerance=max(p_igl, 1e-12), **kw)
            d = np.linalg.norm(res.mesh[0] - V, axis=1).mean() / mel
            print(f"|  |  | → ours{label} to libigl's {p_igl:.2e}: {dt:.3g} s (CPU {cpu:.3g} s), reached "
                  f"{res.max_planarity:.2e}, speed-up ×{ti / dt:,.0f}, mean move/edge {d:.3f} vs libigl {d_igl:.3f}, "
                  f"worst corner {res.worst_corner_angle:.1f}°, shortest edge "
                  f"{_shortest_edge_ratio(res.mesh[0], F):.3g} × median, non-convex {res.nonconvex_faces} "
                  f"| | | | | | | | | |",
                  flush=True)


def child_100k():
    V, F = sincos_grid(316)
    t = time.perf_counter()
    res = planarize((V, F), boundary="free", closeness_weight=0.0, tolerance=1e-4, time_budget=120.0)
    dt = time.perf_counter() - t
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    t3 = _first_below(res.history_max_planarity, res.history_time, 1e-3)
    print(f"{dt:.3f} {t3:.3f} {res.max_planarity:.3e} {rss:.0f} {res.iterations} {res.worst_corner_angle:.1f} "
          f"{res.nonconvex_faces} {_shortest_edge_ratio(res.mesh[0], F):.3g}")


def child_noisy(nq: int, mode: str):
    """One run on the noisy grid in this (child) process: a JSON line with the result's numbers and the peak RSS."""
    count = counted_factorizations()  # count[0]: the planarizer's factorizations so far
    V, F = noisy_grid(nq)
    kw = {"reference": (V, F)} if mode == "ref" else {}
    t, c = time.perf_counter(), time.process_time()
    res = planarize((V, F), **kw)
    dt, cpu = time.perf_counter() - t, time.process_time() - c
    h = res.history_max_planarity
    print(json.dumps(dict(
        dt=dt, cpu=cpu, t3=_first_below(h, res.history_time, 1e-3), t4=_first_below(h, res.history_time, 1e-4),
        it4=int(np.nonzero(h <= 1e-4)[0][0]) if (h <= 1e-4).any() else -1, it=res.iterations, facts=count[0],
        conv=bool(res.converged), healthy=bool(res.healthy), reason=res.stop_reason,
        closeness=res.mean_closeness, V=res.mesh[0].tolist(),
        rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)))


def child_peer(nq: int, path: str, glide: bool, budget: float):
    """geometrylab's guided projection on the noisy grid in this (child) process: a JSON line like
    :func:`child_noisy`. Its package ``__init__`` imports its GUI (mayavi): the modules are loaded from ``path``
    without it; ``pypardiso`` (imported by a fitting module it does not use here) and ``numpy.in1d`` (gone in
    numpy 2.4) are stood in for when absent, with a note."""
    import contextlib
    import io
    import types

    notes = []
    if not hasattr(np, "in1d"):
        np.in1d = np.isin
        notes.append("numpy.in1d → numpy.isin")
    if importlib.util.find_spec("pypardiso") is None:
        import scipy.sparse.linalg as spla

        stub = types.ModuleType("pypardiso")
        stub.spsolve = spla.spsolve
        sys.modules["pypardiso"] = stub
        notes.append("pypardiso absent: scipy spsolve")
    pkg = types.ModuleType("geometrylab")
    pkg.__path__ = [path]
    sys.modules["geometrylab"] = pkg
    from geometrylab.optimization.gridshell import Gridshell
    from geometrylab.optimization.guidedprojection import GuidedProjection

    class Peer(GuidedProjection):
        def set_weights(self):
            super().set_weights()
            if not glide:
                self.set_weight("gliding", 0)

    V, F = noisy_grid(nq)
    quiet = contextlib.redirect_stdout(io.StringIO())
    t, c = time.perf_counter(), time.process_time()
    with quiet:
        mesh = Gridshell()
        mesh.make_mesh(V.tolist(), F.tolist())
        mesh.initialize()
        opt = Peer()
        opt.mesh = mesh
        opt.set_weight("planarity", 1)
        opt.iterations = 1
    hist, times, X = [float(face_planarity(V, F).max())], [0.0], V
    while hist[-1] > 1e-4 and time.perf_counter() - t < budget:
        with contextlib.redirect_stdout(io.StringIO()):
            opt.optimize()
        X = np.asarray(opt.vertices(), dtype=np.float64)
        hist.append(float(face_planarity(X, F).max()))
        times.append(time.perf_counter() - t)
    dt, cpu = time.perf_counter() - t, time.process_time() - c
    print(json.dumps(dict(
        dt=dt, cpu=cpu, t3=_first_below(hist, times, 1e-3), t4=_first_below(hist, times, 1e-4),
        it=len(hist) - 1, conv=hist[-1] <= 1e-4, notes=notes, V=X.tolist(),
        rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)))


def _child(args):
    out = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_noisy(args):
    """The noisy-grid rows: ours (defaults, and the input as reference) and the geometrylab peer."""
    peer = args.geometrylab or os.environ.get("GEOMETRYLAB", "")
    if peer and not (Path(peer) / "optimization" / "guidedprojection.py").exists():
        print(f"|  |  | geometrylab: no optimization/guidedprojection.py under {peer}; peer skipped | | | | | | | | | |")
        peer = ""
    elif not peer:
        print("|  |  | geometrylab: not given (--geometrylab PATH or GEOMETRYLAB=PATH); peer rows skipped "
              "| | | | | | | | | |")
    for nq in args.noisy:
        V, F = noisy_grid(nq)
        m, mel = len(F), 0.7
        print(f"| noisy grid ±3 % | {m:,} | input | — | — | — | {face_planarity(V, F).max():.2e} | 0 / 0 | 0 | "
              f"{np.degrees(corner_angles(V, F).min()):.1f} | {_shortest_edge_ratio(V, F):.3g} | "
              f"{int(nonconvex_faces(V, F).sum())} |", flush=True)
        for mode, label in (("defaults", "ours (defaults)"), ("ref", "ours (defaults, reference = input)")):
            runs = sorted((_child(["--child-noisy", str(nq), mode]) for _ in range(args.repeats)),
                          key=lambda r: r["dt"])
            r = runs[0]
            _row("noisy grid ±3 %", m, label, r["dt"], r["t3"], r["t4"], V, np.asarray(r["V"]), F, mel,
                 closeness=r["closeness"] / mel if mode == "ref" else float("nan"),
                 extra=f" {r['it']} it (1e-4 at it {r['it4']}), {r['facts']} factorizations, {r['reason']}, "
                       f"converged {r['conv']}, healthy {r['healthy']}, CPU {r['cpu']:.3g} s, "
                       f"peak RSS {r['rss']:,.0f} MB (best of {len(runs)})")
        if peer:
            for glide, label in ((True, "geometrylab as shipped (gliding on)"), (False, "geometrylab, gliding off")):
                r = _child(["--child-peer", str(nq), peer, "1" if glide else "0", str(args.peer_budget)])
                _row("noisy grid ±3 %", m, label, r["dt"], r["t3"], r["t4"], V, np.asarray(r["V"]), F, mel,
                     extra=f" {r['it']} it, reached 1e-4 {r['conv']}, CPU {r['cpu']:.3g} s, peak RSS "
                           f"{r['rss']:,.0f} MB{'; ' + ', '.join(r['notes']) if r['notes'] else ''}")


# ----------------------------------------------------------------------------------------------
# candidates of the conjugate pipeline against their design surface (issue #21)


def _bench_fields():
    """benchmarks/fields.py as a module (its ``patch``: the pipeline benchmark's surface)."""
    spec = importlib.util.spec_from_file_location("bench_fields", ROOT / "benchmarks" / "fields.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _mean_edge_length(V, F):
    E = edge_topology(F).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


def make_candidate(n: int, path: str):
    """The planarizer's input in ``pq_from_conjugate_field`` on benchmarks/fields.py's ``patch(n)``: the repaired
    candidate of :func:`components.fields.candidate.candidate_mesh` at 2.5 × the surface's mean edge, saved with
    the surface to ``path`` (keys ``V``, ``T``, ``CV``, ``CF``, as /tmp/in/patch*.npz of the #21 helpers)."""
    from components.fields.candidate import candidate_mesh

    V, T = _bench_fields().patch(n)
    t = time.perf_counter()
    c = candidate_mesh((V, T), 2.5 * _mean_edge_length(V, T), repair=True)
    np.savez(path, V=V, T=T, CV=c.V, CF=c.F)
    return time.perf_counter() - t


def child_candidate(path: str, variant: str, budget: str = "30"):
    """One planarization of a saved candidate in this (child) process with the pipeline's options (``_planarized``
    of components/fields/pipeline.py): a JSON line. ``variant``: ``plain``, ``x1000`` (every coordinate × 1000) or
    ``moved`` (+5e6 in x and z, −3e6 in y): the results must be the same up to scale."""
    count = counted_factorizations()  # count[0]: the planarizer's factorizations so far
    d = np.load(path)
    V, T, CV, CF = d["V"], d["T"], d["CV"], d["CF"]
    s, off = (1000.0, 0.0) if variant == "x1000" else (1.0, np.array([5e6, -3e6, 5e6]) if variant == "moved" else 0.0)
    V, CV = V * s + off, CV * s + off
    mel = _mean_edge_length(CV, CF)
    t, c = time.perf_counter(), time.process_time()
    res = planarize_mesh(CV, CF, reference=(V, T), tolerance=1e-4, time_budget=float(budget), boundary="slide",
                         closeness_weight=10.0, mesh_name="candidate")
    dt, cpu = time.perf_counter() - t, time.process_time() - c
    drift = np.linalg.norm(res.mesh[0] - CV, axis=1) / mel
    print(json.dumps(dict(
        dt=dt, cpu=cpu, it=res.iterations, facts=count[0], maxp=res.max_planarity, meanp=res.mean_planarity,
        conv=bool(res.converged), healthy=bool(res.healthy), coverage=res.coverage,
        close_mean=res.mean_closeness / mel, close_max=res.max_closeness / mel, drift_mean=float(drift.mean()),
        drift_max=float(drift.max()), corner_in=float(np.degrees(corner_angles(CV, CF).min())),
        corner=res.worst_corner_angle, ncv=res.nonconvex_faces, m=len(CF), reason=res.stop_reason,
        rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)))


def bench_candidates(args):
    """The candidate rows: each candidate (built here from ``--candidates`` sizes, or read from ``--candidate-npz``
    files) planarized against its surface as the conjugate pipeline does, plain, × 1000 and moved by 5e6."""
    import tempfile

    print()
    print("| candidate (patch) | faces | variant | CPU s | wall s | it / factorizations | max / mean planarity | "
          "converged / healthy | coverage | closeness mean / max (edges) | drift mean / max (edges) | "
          "worst corner ° (input) | peak RSS MB | stop |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        specs = [(f"{n:,} triangles", None, n) for n in args.candidates]
        specs += [(Path(p).name, p, None) for p in args.candidate_npz]
        for label, path, n in specs:
            if path is None:
                path = str(Path(tmp) / f"candidate{n}.npz")
                tc = make_candidate(n, path)
                label += f" (built in {tc:.1f} s)"
            for variant in args.candidate_variants:
                r = _child(["--child-candidate", path, variant, str(args.candidate_budget)])
                print(f"| {label} | {r['m']:,} | {variant} | {r['cpu']:.3g} | {r['dt']:.3g} | "
                      f"{r['it']} / {r['facts']} | "
                      f"{r['maxp']:.3g} / {r['meanp']:.3g} | {r['conv']} / {r['healthy']} | {r['coverage']:.4f} | "
                      f"{r['close_mean']:.4f} / {r['close_max']:.4f} | {r['drift_mean']:.4f} / {r['drift_max']:.3f} | "
                      f"{r['corner']:.2f} ({r['corner_in']:.2f}) | {r['rss']:,.0f} | {r['reason']} |", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--full", action="store_true", help="run libigl for 2,000 / 200 iterations (very long)")
    ap.add_argument("--skip-100k", action="store_true")
    ap.add_argument("--noisy-only", action="store_true", help="only the noisy-grid rows")
    ap.add_argument("--noisy", type=int, nargs="*", default=[60, 200], help="noisy grid sizes (quads per side)")
    ap.add_argument("--geometrylab", default="", help="path of a geometrylab checkout (optional peer)")
    ap.add_argument("--peer-budget", type=float, default=60.0, help="seconds per geometrylab run")
    ap.add_argument("--candidates", type=int, nargs="*", default=[20000],
                    help="candidate rows: surface sizes (triangles) of benchmarks/fields.py's patch to build")
    ap.add_argument("--candidate-npz", nargs="*", default=[],
                    help="candidate rows from saved .npz files (keys V, T: the surface; CV, CF: the candidate)")
    ap.add_argument("--candidate-variants", nargs="*", default=["plain", "x1000", "moved"],
                    choices=["plain", "x1000", "moved"], help="plain, every coordinate × 1000, moved by 5e6")
    ap.add_argument("--candidates-only", action="store_true", help="only the candidate rows")
    ap.add_argument("--candidate-budget", type=float, default=30.0,
                    help="time budget of the candidate runs (the pipeline's: 30 s; a loaded machine may need more)")
    ap.add_argument("--child-candidate", nargs=3, help=argparse.SUPPRESS)
    ap.add_argument("--child-100k", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--child-noisy", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("--child-peer", nargs=4, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_100k:
        child_100k()
        return
    if args.child_noisy:
        child_noisy(int(args.child_noisy[0]), args.child_noisy[1])
        return
    if args.child_peer:
        nq, path, glide, budget = args.child_peer
        child_peer(int(nq), path, glide == "1", float(budget))
        return
    if args.child_candidate:
        child_candidate(*args.child_candidate)
        return
    if args.candidates_only:
        bench_candidates(args)
        return
    print("| mesh | quads | method | time s | t→1e-3 | t→1e-4 | final max planarity | mean / max move (edges) |"
          " mean closeness (edges) | worst corner ° | shortest edge / median | non-convex |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    bench_noisy(args)
    if args.noisy_only:
        return
    bench_mesh("sin-cos grid", *sincos_grid(50), args, 2000 if args.full else 50)
    bench_mesh("sin-cos grid", *sincos_grid(100), args, 200 if args.full else 10)
    conj = SHARED / "libigl" / "inspired_mesh_quads_Conjugate.off"
    if conj.exists():
        bench_mesh("inspired Conjugate", *read_mesh(conj), args, 300 if args.full else 50, real=True)
    heart = SHARED / "dos" / "obj_pq__heart.obj"
    if heart.exists():
        bench_mesh("dos heart", *read_mesh(heart), args, 300 if args.full else 50, real=True)
    if not args.skip_100k:
        out = subprocess.run([sys.executable, __file__, "--child-100k"], capture_output=True, text=True, check=True)
        dt, t3, p, rss, it, ang, ncv, short = out.stdout.split()
        print(f"| sin-cos grid | 99,856 | ours (free, no closeness), child process | {float(dt):.3g} | "
              f"{float(t3):.3g} | — | {float(p):.2e} | — | — | {ang} | {short} | {ncv} | "
              f"peak RSS {float(rss):,.0f} MB, {it} it |")
    bench_candidates(args)


if __name__ == "__main__":
    main()
