"""How often the conjugate-field strategy reaches its tolerance: a sweep of inputs, not one case (issue #21).

The planarization of a candidate either reaches the planarity tolerance or stops when the panel-health guard
refuses every step ("no step keeps the panels healthy", "stalled"); which one happens flips under tiny changes of
the input or the code (the 20k benchmark patch moved by +5e6, a different tie between two equally close
triangles). A change to the planarizer or to the candidate is judged here by the share of a sweep that converges,
beside its time.

Run from the project root::

    /work/venv/bin/python benchmarks/convergence.py                     # seeds 0-3 × 8k, 20k × ×1, ×1000, +5e6
    /work/venv/bin/python benchmarks/convergence.py --seeds 0 1 --sizes 8000 --placements x1
    /work/venv/bin/python benchmarks/convergence.py --saved /tmp/in/sweep/*.npz    # the planarizer alone
    /work/venv/bin/python benchmarks/convergence.py --real 60 300       # the shared meshes at 60 and 300 panels
    /work/venv/bin/python benchmarks/convergence.py --real 300 --placements x1 x1000 +5e6   # ... in mm and far away
    /work/venv/bin/python benchmarks/convergence.py --field-iterations 30    # other candidates from the same inputs

Each case runs ``pq_from_conjugate_field`` on benchmarks/fields.py's patch (jittered by ``seed``) at panels of
2.5 mean edges, in a fresh child process. Prints one row per case (faces, candidate and final max planarity,
converged = max planarity ≤ tolerance and healthy, the stop reason, seconds) and the converged share.

``--saved PATH...`` runs the planarizer alone, as the pipeline calls it (``_planarized`` of
components/fields/pipeline.py: tolerance 1e-4, sliding boundary, closeness weight 10), on saved candidates: ``.npz``
files with the surface ``V``, ``T`` and the repaired candidate ``CV``, ``CF`` (any placement). One row per file:
faces, candidate and final max planarity, converged (the planarizer's verdict: tolerance and health), healthy, the
stop reason, iterations, sparse factorizations, CPU seconds, worst corner, mean closeness / mean candidate edge.

Measured (2-core machine, session 8 of issue #21): the default sweep (seeds 0-3 × 8k, 20k × ×1, ×1000,
+5e6): 24 of 24 converged and healthy, 2.6-9.6 s a case (session 7: 6 of 12 at 8k, seeds 1 and 3 stopping at 6e-2
and 5e-3..2e-2). At 20k the +5e6 placement of seeds 0, 2 and 3 gives another candidate than ×1 (1424 / 1442 / 1421
faces against 1406 / 1241 / 1547): the direction field's local-global iterations do not converge, so the input's
rounding at +5e6 changes the field. Closeness is not the same at every scale on the 8k seed 3 (mean closeness 0.024
of an edge at ×1, 0.070 at ×1000; both converged).

Session 9, on another machine (AVX-512): the same code converged on 22 of the 24 saved candidates and on 13 of 16 more
(seeds 4-7 × 8k, 20k × ×1, +5e6) — which run reaches the tolerance flips with the CPU's round-off. With the
planarizer's extra runs (closeness relaxed less or not at all, components/planarize/planarizer.py ``RUNS``):
23 of 24 and 15 of 16; a case that needs them costs up to half the time budget (8k seed 5 ×1: 12 s).

Session 10 (same machine), ``--saved``: releasing the guard rows of far-moving vertices (components/planarize/step.py
``_FAR``) converges 24 of 24 (CPU 40.8 s in all, was 22 of 24 in 69 s) and 14 of 16 (57.2 s; was 15 of 16 in 58.5
s: 20k seed 6 +5e6 now stops with "no step lowers the planarity", as seed 6 ×1 did before). The 200k patch: seed 0
×1 and +5e6 converge with and without it, seed 1 ×1 only with it (before: 3.0e-3 at the 30 s budget, 1.8e-3 with
no budget), seed 0 ×1000 only without it (with it: stalled at 2.2e-3, ten steps of 2e-4 of Gauss-Newton's in a
row). Which case converges still flips with round-off; the release makes the crawl (steps of 0.1 % of
Gauss-Newton's for tens of iterations) rarer, not impossible.

Session 11 (same machine), ``--saved``: the planarizer's steps damped in proportion to the planarity residual
(Levenberg-Marquardt, components/planarize/step.py ``damping``) and flip guard rows: 24 of 24 in 30.1 CPU s (710
iterations, 4036 factorizations) and 16 of 16 in 20.9 s (500, 2777). The 200k patch: all four saved candidates
converge (seed 0 ×1 36 iterations, ×1000 53, +5e6 22; seed 1 ×1 42).

``--real PANELS...`` runs the pipeline on every open mesh of ``../shared/data/meshes`` under 900 KB (see its
INVENTORY.md) at panels of ``sqrt(area / PANELS)``, time budget 10 s, and prints the result's status or the typed
error (a surface with handles is refused). ``--field-iterations N`` gives the conjugate field N local-global
iterations instead of its 40: the same inputs then give other candidates, a cheap way to meet rarer ones.

Session 14 (another 2-core machine): ``--field-iterations 30`` on the 20k patch, seed 1, made a candidate whose
outline had two corners snapped onto the tip of a spike of the staircase hole; the planarizer refused it
("candidate: vertex 1305 is non-manifold"), an error about our own mesh. Panel health now flags such pinches and
the repair closes them (components/fields/repair.py). Seeds 0-9 × 8k, 0-7 × 20k, 8k seed 3 ×1000 and 20k seed 1
×0.001, each with 40, 30 and 20 field iterations: 60 of 60 converged and healthy. ``--real 60 300`` (42 meshes):
no error but the genus-1 Costa surface's (refused, typed). At 300 panels 39 converged and healthy; the tube
stops healthy at 0.16 (convexity guard) and camelhead is unhealthy (a candidate fold the repair cannot open; said
so). At 60 panels (a few panels across strongly curved surfaces) 29 converged, 11 end healthy short of the
tolerance and say how far, camelhead is unhealthy.

Session 15 (another 2-core machine), ``--real 300 --placements x1 x1000 +5e6`` (the three placements of every
shared mesh, 126 runs): 116 converged and healthy (the tube stops healthy at 0.16 everywhere, camelhead is unhealthy
everywhere, Costa is refused everywhere; DOS ``wein99`` at +5e6 only: 337 panels, unhealthy, against 399 healthy).
7 of the 42 meshes get another candidate at ×1000 or +5e6 (rhinovault_mesh_0 352 → 355 panels at ×1000; pillow_1,
heart, cmc1, wein99, wein99_opt and camelhead at +5e6): the input's rounding at site coordinates moves the direction
field's sampled local step by a sample on some faces, and the parametrization's integer rounding makes another
candidate of that (see ``benchmarks/field.py``). The default patch sweep (seeds 0-3 × 8k, 20k × the three
placements): 24 of 24 converged and healthy. The other strategies by hand at 60 panels (their own placement
handling: the curvature network snaps the panel size to a grid): the curvature network gives the same verdict at
all three placements on all 42 (one panel more or less on rhinovault_mesh_1 at ×1000 and lilium at +5e6); the
subdivision strategy the same faces everywhere, and the same verdict on all but three DOS meshes whose planarization
takes another path (heart: unhealthy at all three, planarity 0.17 / 9.5e-5 / 3.1e-2; wein99_opt: converged at ×1,
6.2e-2 / 7.2e-2 at the 10 s budget elsewhere, unhealthy at +5e6; wein99_opt_del2bdry: unhealthy at ×1 only).

Then the strategy went down its ranking of healthy candidates when the best-ranked one does not planarize
(components/fields/pipeline.py): ``--real 60`` 29 → 31 of 42 converged (rhinovault_mesh_0 with healthy candidate
2, compas_hypar with 3; the others that stop short do so at the 10 s budget, their planarity moving either way with
its split), ``--real 300`` 39 of 42 as before (the tube 0.161 → 0.110, still short); the patch sweep and the
benchmark rows are unchanged (their first candidate converges).

Session 18 (session 17's machine), after the repair's sliver collapse took longer chords and ran at the last pass
(components/fields/repair.py): the default sweep 24 of 24 converged and healthy, and again after the repair also
dropped unhealthy quads with all corners on the outline (8k seed 3 then gets another candidate, 600 panels instead
of 553 at all three placements, converged; the ``--real`` run below was before that change, which leaves the shared
meshes' candidates as they were); ``--real 60 300`` 39 of 42 at 300
panels (the tube, camelhead, Costa as before; three meshes get another candidate, all healthy: see
benchmarks/fields.py) and 30 of 42 at 60 (the same candidates as before; compas_hypar stops at the 10 s budget on
this machine, as in session 17). On the 200k patch, seeds 0-22: 22 of 23 candidates at the nominal panel count
and 22 of 23 converged and healthy (benchmarks/fields.py).

Session 19 (session 17's machine), ``--saved`` on 135 saved candidates (the patch at 8k, seeds 0-7 × ×1, ×1000,
+5e6; at 20k, seeds 0-7 × ×1, +5e6 and seeds 0-3 × ×1000; an elliptic canopy with an oval hole at 20k and 80k
triangles × the three placements; the best-ranked candidates of the 42 shared meshes at 60 and 300 panels), one run
after the other (components/planarize/guard.py, problem.py, geometry.py):
- The canopy's 80k candidate crawled 49 iterations at ×1 (64 at ×1000, 16 at +5e6) at steps of 1/64-1/32: a corner
  that started at 20.04° (bound 20°) had its guard row's target at 20.02°, and every full step's second-order error
  (-0.04°) put it under the bound again. A corner's row now acts a fifth of the margin under where it started and
  at least that far over the bound: with the ties below, 23 / 23 / 24 iterations, mean closeness 0.0049 / 0.0049 /
  0.0050 candidate edges at the three placements (0.0106 / 0.0112 / 0.0053 before).
- The same candidate at ×1 and ×1000 (equal to 1e-13) took another path from the first step on: boundary vertices
  snapped onto vertices of the outline are ties between two segments (the sliding tangent) and between the faces
  around the vertex (the closeness goal's normal), broken by round-off. Now the vertex's tangent and the vertex's or
  edge's normal: identical candidates at ×1 and ×1000 give the same result (iterations and closeness) on 14 of 15
  pairs, 3 of 15 before; then (last) a face a trial collapses to round-off gets no normal rather than a random one
  (which fold and flip rows the trial added depended on it: libigl's igloo at 300 panels): 15 of 15, and the same
  results as before that on 134 of the 135. (Normals interpolated from the vertices everywhere, tried first, left the DOS meshes at 60
  panels 1.5-4× farther from their surface: not adopted.)
- All 135: 121 converged before and after, none changed verdict; iterations 3572 → 3404; on the 121 converged
  mean closeness 0.0100 → 0.0098 edges, CPU 110 → 116 s with 2743 → 2673 iterations. The 20k benchmark candidate:
  31 → 25 iterations (closeness 0.0059 → 0.0063 edges).
- Through the pipeline, ``--real 300 --placements x1 x1000 +5e6``, the code before and after in the same hour: 117
  of 126 converged and healthy both; the same panels, max planarity and coverage at ×1 and ×1000 on 35 of the 42
  meshes (11 before; the same candidate on 41 both times, rhinovault_mesh_0 gets another at ×1000), the same panel
  count at ×1 and +5e6 on 35 (35 before: the direction field's rounding, see above). After the collapsed face's
  normal: 36 of 42 the same at ×1 and ×1000 (igloo too) and 36 the same panel count at +5e6. The default sweep: 24
  of 24, and ×1 and ×1000 now end at the same max planarity on all 8 pairs; ``--real 60 300``: 30 and 39 of 42 as in
  session 18.

Session 21 (session 17's machine), ``--saved`` on the 135 saved candidates, tried and not adopted (the machine's
speed swung 30 % within the hour, so only CPU seconds and counts are compared):
- Guard rows for the items an unhealthy trial moved towards their bound by so much that one more such move would pass
  the row's act level (components/planarize/guard.py ``rows_to_guard``), not only those already under it: the 20k
  benchmark candidate took 30-50 iterations instead of 25 (0.5, 1 and 2 moves ahead), the rows over-constrain.
- The closeness stiffness relaxed after two held restore steps instead of three (phases.py ``_HELD_STEPS``): the 20k
  benchmark candidate 25 → 23 iterations (1.18 → 0.96 s), but the 200k one 31 → 40 (12.5 → 17.1 s) and on the 124
  candidates both runs finished (the second was stopped there) 112 → 111 converged in 239 → 241 CPU s (wein99_opt at
  60 panels stalled).

Session 22 (another 2-core machine, AMD EPYC), ``--real 300 --placements x1 x1000 +5e6`` after the strategy ran on
the surface centred, at unit size and snapped to a grid (components/core/frame.py) and the planarizer snapped its
normalized coordinates (components/planarize/problem.py ``SNAP``): 118 of 126 converged and healthy; ×1 and ×1000
give identical rows (panels, max planarity, verdict, coverage) on 41 of 42 (the tube: converged in 10.2 s at ×1,
stopped by the 10 s budget at ×1000, a matter of the machine's speed), against 37 of 42 with the code before on
this machine (five meshes another panel count or planarity in mm: rhinovault_mesh_0 352 → 355 panels);
+5e6: 21 identical rows, 7 with another panel count or verdict (the tube; botanic-garden-bubble, flower_cmc1,
pillow_1, heart, wein99_opt_del2bdry and lilium another panel count, each converged and healthy as at ×1): a far
placement rounds the input itself by up to 1e-10 of its size, more than a few grid steps' worth on some vertices.
Found late and left open: libigl's inspired_mesh at 1600 panels (tests/components/test_pipelines.py) got another
best-ranked candidate from the snapped frame (1638 panels instead of 1672), which stalls at 1.17e-3 through all six
planarizer attempts (19.5 s) before the second candidate converges (1716 panels, 9.0e-5, healthy): 23 s instead of
2 s. The first candidate gets the whole budget; giving it a share when others are ranked behind it would bound this.

Session 23 (session 22's machine), each candidate gets the planarizer's first run (components/planarize/planarizer.py
``RUNS``) before any gets the other five (components/fields/pipeline.py ``_planarized_in_turn``). Logged per run on
``--real 60 300`` and inspired_mesh at 1600 panels (60 s budget), the code before and after one run after the
other. Before, where the best-ranked candidate's first run failed, a later run of it converged 3 times (wein99_opt
at 60 and 300, wein99_opt_del2bdry at 300) and another candidate 3 times (wein99 at 60, the tube at 300, inspired).
After: 73 → 76 of 85 converged and healthy (gnet1, pillow_1 and wein99_diag at 60 converge with their third to
fifth candidates; none lost), 213 → 170 s in all; inspired_mesh 17.1 → 5.4 s (1716 panels both), the tube at 300
10.3 → 2.9 s, wein99 at 60 10.8 → 3.1 s. The three that a later run converged now converge with another candidate
(second or fourth; 72 → 69, 274 → 301 and 323 → 304 panels). Then ``--real 300 --placements x1 x1000 +5e6``: 118 →
120 of 126 converged and healthy (left: Costa refused, camelhead unhealthy at every placement, said so), identical
rows at ×1 and ×1000 on 42 of 42 (the tube no longer runs into the 10 s budget), another panel count at +5e6 on 6
(botanic-garden-bubble, flower_cmc1, pillow_1, heart, wein99_opt_del2bdry, lilium; each converged and healthy); the
default sweep 24 of 24, ×1 and ×1000 identical on all 8 pairs. ``--real 60`` at ×1 and ×1000: 40 of 42 identical; the
two that differ (free_negshell_marc_anet, M2_eq_quad2_orthoEqu) stop short in both units, healthy, their best state
from a run cut by the 10 s budget at another point. Tried and not adopted: starting another planarization only while
the time left holds the shortest one so far (as the planarizer does with its own runs): 42 of 42 identical, but
gnet1, which converged with its third candidate in the last second of the budget, stopped short (70 → 68 of 84).

Session 24 (another, slower 2-core machine), the planarizer's systems factored with qdldl's LDLᵀ instead of SuperLU
(the same solutions to 1e-11; components/planarize/step.py ``factor_spd``), the code before and after one run after
the other: ``--real 60 300`` 74 → 75 of 84 converged and healthy, 3:26 → 3:15 min (gnet1 at 60, the run cut by the
10 s budget, now converges in it; the 4 other rows that differ stop short in both, healthy, cut at other points);
``--real 300 --placements x1 x1000 +5e6`` 120 of 126 as in session 23, identical rows at ×1 and ×1000 on 42 of 42,
the same 6 meshes with another panel count at +5e6 (each converged and healthy).

Session 16 (another 2-core machine), ``--saved`` on the 75 saved candidates (the patches, the benchmark rows and the
shared meshes at 300 panels), tried and not adopted:
- Guard rows *added* to a factored system solved with its factor bordered by them (a Schur complement of up to 64
  rows, with the same two steps of refinement as the released ones): factorizations 6353 → 3941, but CPU 75.9 →
  84.9 s and 73 → 72 converged (wein99 stalled at 0.196). Each bordered solve costs three back-substitutions
  (refinement) and the border ``|A|`` more, against a factorization of 2 ms on the small systems; on the 200k
  candidate (38 ms a factorization) 126 → 94 factorizations and 15.2 → 14.9 CPU s. Not worth its code.
- The restore phase never relaxing the closeness stiffness (``_HELD_STEPS`` 1000): the benchmark candidates converge
  faster (20k 28 → 22 iterations, 1.05 → 0.82 s; 200k 38 → 34, 13.4 → 12.1 s) but the sweep 73 → 72 converged
  and 71.4 → 88.0 CPU s.
- Fill-reducing orders for the planarizer's face-sized systems on the 200k candidate: a geometric nested
  dissection of the vertices (median planes, each row at the lowest tree node holding all its vertices, computed in
  3 ms) factors in 33-42 ms against the minimum-degree order's 34-48 ms, with 1.3× its fill; the minimum-degree
  order computed once and reused is 27-36 ms, but no two factorizations of a run have the same rows (125 of 125
  distinct patterns), and placing the rows added since after their neighbours in a reused order fills 1.4-1.6×.

Session 12 (same machine), ``--saved``, session-11 code → today's in the same hour, one run after the other: guard
rows released from a factored system solved with its factor (components/planarize/step.py ``_Reduced``) instead of
a new one: 24 of 24 in 22.7 → 18.9 CPU s (710 → 688 iterations, 4036 → 1981 factorizations) and 16 of 16 in 15.9 →
13.7 s (500 → 506, 2777 → 1450). Mean closeness 1.01× the session-11 results' (geometric mean over these 40 and the
20k benchmark's, face-scan and inspired candidates; 95 % interval 0.95-1.08). The four 200k candidates: 4 of 4 in
59.7 → 45.5 CPU s (214 → 106 factorizations on the benchmark's; closeness lower on all four).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from fields import _mean_edge, patch  # noqa: E402
from forked import counted_factorizations, run_forked  # noqa: E402

PLACEMENTS = {"x1": (1.0, 0.0), "x1000": (1000.0, 0.0), "+5e6": (1.0, 5e6)}
TOLERANCE = 1e-4


SHARED = ROOT.parent / "shared" / "data" / "meshes"


def _field_iterations(n: int | None):
    """Give the conjugate field ``n`` local-global iterations (in this child process) instead of its default."""
    if n is None:
        return
    import functools

    import components.fields.field as field
    import components.fields.parametrize as parametrize

    parametrize.conjugate_frame_field = functools.partial(field.conjugate_frame_field, iterations=n)


def _case(size: int, seed: int, placement: str, budget: float, iterations: int | None = None):
    from components.fields.pipeline import pq_from_conjugate_field

    _field_iterations(iterations)

    scale, offset = PLACEMENTS[placement]
    V, T = patch(size, seed=seed)
    h = 2.5 * _mean_edge(V, T)
    t = time.perf_counter()
    r = pq_from_conjugate_field((V * scale + offset, T), h * scale, tolerance=TOLERANCE, time_budget=budget)
    dt = time.perf_counter() - t
    stop = next((w.split(": ", 1)[1] for w in r.warnings if w.startswith("planarization stopped")), "")
    return len(r.planarized[1]), r.candidate_max_planarity, r.planarized_max_planarity, r.healthy, stop, dt


def run(size: int, seed: int, placement: str, budget: float, iterations: int | None = None):
    """One case in a fresh process: ``(faces, candidate max, final max, healthy, stop reason, seconds)``."""
    return run_forked(_case, size, seed, placement, budget, iterations,
                      failed=(0, float("nan"), float("nan"), False, "crashed", float("nan")))


def _real(path: str, panels: int, iterations: int | None, placement: str = "x1"):
    """The pipeline on one shared mesh at about ``panels`` panels (at ``placement``): the row's numbers, or the
    error's text."""
    import numpy as np

    from components.core.errors import InputError
    from components.core.mesh import read_mesh, triangulate
    from components.fields.pipeline import pq_from_conjugate_field

    _field_iterations(iterations)
    V, F = read_mesh(path)
    T = triangulate(F)[0]
    area = 0.5 * float(np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum())
    scale, offset = PLACEMENTS[placement]
    V, area = np.asarray(V, dtype=np.float64) * scale + offset, area * scale * scale
    t = time.perf_counter()
    try:
        r = pq_from_conjugate_field((V, F), float(np.sqrt(area / panels)), tolerance=TOLERANCE, time_budget=10.0)
    except InputError as exc:
        return (0, float("nan"), False, float("nan"), f"{type(exc).__name__}: {exc}", time.perf_counter() - t)
    stop = next((w.split(": ", 1)[1] for w in r.warnings if w.startswith("planarization stopped")), "")
    return len(r.planarized[1]), r.planarized_max_planarity, r.healthy, r.coverage, stop, time.perf_counter() - t


def main_real(panel_counts, iterations: int | None, placements=("x1",)):
    """The ``--real`` table (with several placements: and the meshes whose face count or verdict differs)."""
    paths = sorted(p for p in SHARED.glob("*/*") if p.suffix in (".obj", ".off", ".ply") and p.stat().st_size < 900_000)
    print("| mesh | panels asked | placement | faces | max planarity | converged | healthy | coverage | stop or error "
          "| s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    done = total = 0
    differs = []
    for path in paths:
        for k in panel_counts:
            seen = set()
            for pl in placements:
                nf, pmax, healthy, cov, stop, dt = run_forked(
                    _real, str(path), k, iterations, pl,
                    failed=(0, float("nan"), False, float("nan"), "crashed", float("nan")))
                ok = bool(healthy and pmax <= TOLERANCE)
                total += 1
                done += ok
                seen.add((nf, ok, healthy))
                print(f"| {path.name} | {k} | {pl} | {nf} | {pmax:.2e} | {'yes' if ok else 'no'} | {healthy} | "
                      f"{cov:.3f} | {stop[:120] or '-'} | {dt:.1f} |", flush=True)
            if len(seen) > 1:
                differs.append(f"{path.name} at {k}")
    print(f"\nconverged and healthy: {done} of {total}")
    if len(placements) > 1:
        print(f"another face count or verdict at another placement: {len(differs)} ({', '.join(differs) or '-'})")


def _saved(path: str, budget: float):
    """The planarizer alone on one saved candidate (in a child process): the row's numbers."""
    import numpy as np

    from components.core.blas import single_blas_thread
    from components.core.measures import quad_planarity
    from components.core.mesh import edge_topology
    from components.planarize.planarizer import planarize_mesh

    count = counted_factorizations()  # count[0]: the planarizer's factorizations so far
    d = np.load(path)
    CV, CF = d["CV"], d["CF"]
    edges = edge_topology(CF).E
    mel = float(np.linalg.norm(CV[edges[:, 1]] - CV[edges[:, 0]], axis=1).mean())
    c = time.process_time()
    with single_blas_thread():  # as the pipeline runs it
        r = planarize_mesh(CV, CF, reference=(d["V"], d["T"]), tolerance=TOLERANCE, time_budget=budget,
                           boundary="slide", closeness_weight=10.0, mesh_name="candidate")
    cpu = time.process_time() - c
    return (len(CF), float(quad_planarity(CV, CF).max()), r.max_planarity, bool(r.converged), bool(r.healthy),
            r.stop_reason, r.iterations, count[0], cpu, r.worst_corner_angle, r.mean_closeness / mel)


def main_saved(paths, budget: float):
    """The ``--saved`` table."""
    print("| file | faces | candidate max | final max | converged | healthy | stop | iterations | factorizations "
          "| CPU s | worst corner ° | mean closeness / edge |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    done = 0
    for path in paths:
        nf, cmax, pmax, conv, healthy, stop, its, facts, cpu, corner, close = run_forked(
            _saved, path, budget, failed=(0, *[float("nan")] * 2, False, False, "crashed", 0, 0, *[float("nan")] * 3))
        done += conv
        print(f"| {Path(path).stem} | {nf} | {cmax:.2e} | {pmax:.2e} | {'yes' if conv else 'no'} | {healthy} | "
              f"{stop or '-'} | {its} | {facts} | {cpu:.2f} | {corner:.1f} | {close:.4f} |", flush=True)
    print(f"\nconverged (tolerance and healthy): {done} of {len(paths)} ({100.0 * done / max(len(paths), 1):.0f}%)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2, 3])
    ap.add_argument("--sizes", type=int, nargs="*", default=[8000, 20000])
    ap.add_argument("--placements", nargs="*", default=None, choices=list(PLACEMENTS),
                    help="x1, x1000, +5e6 (default: all three for the patches, x1 for --real)")
    ap.add_argument("--budget", type=float, default=30.0, help="the planarization's time budget, s")
    ap.add_argument("--saved", nargs="+", metavar="PATH",
                    help="run the planarizer alone on saved candidates (.npz with V, T, CV, CF)")
    ap.add_argument("--real", type=int, nargs="+", metavar="PANELS",
                    help="run the pipeline on the shared meshes (../shared/data/meshes) at these panel counts")
    ap.add_argument("--field-iterations", type=int, default=None,
                    help="the conjugate field's local-global iterations (default: its own, 40)")
    args = ap.parse_args(argv)
    if args.saved:
        main_saved(args.saved, args.budget)
        return
    if args.real:
        main_real(args.real, args.field_iterations, args.placements or ("x1",))
        return
    print("| size | seed | placement | faces | candidate max | final max | converged | healthy | stop | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    done = 0
    cases = [(s, seed, pl) for s in args.sizes for seed in args.seeds for pl in (args.placements or PLACEMENTS)]
    for size, seed, pl in cases:
        nf, cmax, pmax, healthy, stop, dt = run(size, seed, pl, args.budget, args.field_iterations)
        ok = bool(healthy and pmax <= TOLERANCE)
        done += ok
        print(f"| {size} | {seed} | {pl} | {nf} | {cmax:.2e} | {pmax:.2e} | {'yes' if ok else 'no'} | {healthy} "
              f"| {stop or '-'} | {dt:.1f} |", flush=True)
    print(f"\nconverged and healthy: {done} of {len(cases)} ({100.0 * done / max(len(cases), 1):.0f}%)")


if __name__ == "__main__":
    main()
