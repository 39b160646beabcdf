"""Time every step of the field pipeline (issue 6) on 10k, 50k and 200k-triangle inputs beside libigl / gpytoolbox.

Run from the project root::

    /work/venv/bin/python benchmarks/fields.py                 # all steps, all sizes
    /work/venv/bin/python benchmarks/fields.py --steps remesh --sizes 10000 50000
    /work/venv/bin/python benchmarks/fields.py --real          # also the shared 52k-triangle face scan

Each step is a :class:`Step` in :data:`STEPS`: a name, our function and, where a reference library has the step,
the reference function, both taking ``(V, T)`` of the input. To add a later field step, append a ``Step`` (keep the
functions module-level so the table stays a list). The table prints seconds (best of ``--repeat`` runs), CPU seconds
of the best run, the ratio ours / reference in CPU seconds (below 1 = faster than the reference), the peak resident
memory of the process that ran ours (each measurement runs in a fresh child process forked after the imports, so the
peak is that step's high-water mark) and, where the step has one, what the result is (face counts,
planarity, panel health, coverage: the quality a speed-up must keep). The machine's cores are shared: compare CPU
seconds and ratios measured in the same run.

Issue #21 rows::

    /work/venv/bin/python benchmarks/fields.py --steps end-to-end --sizes 20000 200000
    /work/venv/bin/python benchmarks/fields.py --steps remesh --sizes 50000 200000

Measured 2026-12 on the 2-core project machine while it was quiet, before (commit 1e6f7ba) → after issue #21's field
work, same results bit for bit (candidates, remeshes): remesh 50k 7.8 s (2.5x gpytoolbox.remesh_botsch in CPU
seconds) → 3.8 s (1.06x), 200k 2.5x → 1.3x; pq_from_conjugate_field 20k 42.8 s (field 11.9, parametrization 3.2,
extraction 8.4, planarization 18.4) → 20.0 s (4.4, 1.2, 6.9, 6.6), peak 170 MB. The field's sparse factorizations
had swung 10-100x with OpenBLAS' threads on a busy machine (components.core.blas). Session 7 (exact-closest-point
grid index, one repaired candidate, batched repair, cached cut graph): 20k 12.5 s (field 4.1, param 0.6, extract
2.3, planarize 5.0; same 1406-face candidate, 9.4e-5, healthy), peak 155 MB; 200k 317 s → 140 s (field 48.1, param
9.0, extract 51.3 — all six candidates repaired, none healthy —, planarize 29.2, not converged: the candidate's
smooth non-planarity needs larger moves than the panel-health guard allows), peak 751 MB. Issue #21's targets
(3 s, 15 s) are not met yet. Session 8 (bit-identical field local step, sliver collapse in the repair, planarizer
fixes): 20k 5.7 s (field 1.9, param 0.3, extract 1.1, planarize 2.1; same 1406-face candidate, 9.0e-5, healthy),
peak 150 MB; 200k 91.6 s wall / 62 CPU s on a loaded machine (field 29.1, param 11.1, extract 17.5 — the first
candidate is healthy now —, planarize 31.9: healthy but not converged, 5.7e-3 at the 30 s budget), peak 750 MB.
Session 9 (another 2-core machine, AVX-512; bit-identical field local step, extraction, planarizer health checks
and crossing tests), session-8 code → today's in the same hour: 20k 4.9-5.0 s → 4.2-4.3 s (field 1.5, param 0.3,
extract 0.8, planarize 1.5; same 1406-face candidate and result, 9.0e-5, healthy), peak 143 MB; 200k 60.6 s → 50.9 s
(field 19.5, param 4.9, extract 7.2, planarize 18.3; converged, 9.4e-5, healthy, coverage 1.000), peak 771 MB.
Session 10 (same machine; independent steps on two threads, components.core.parallel, bit-identical to one thread;
the planarizer's release of far-moving vertices): 20k 4.4 s → 3.8 s (field 1.2, param 0.2, extract 0.7, planarize
1.5; same 1406-face result), peak 210 MB; 200k 50.9 s → 43.2 s (field 14.9, param 3.6, extract 5.8, planarize 17.9;
converged 9.0e-5, healthy, coverage 1.000), peak 1.5 GB: the candidate's two boundary modes are parametrized and
extracted at the same time (771 MB with GHSERVER_THREADS=1).
Session 11 (same machine; the planarizer's Levenberg-Marquardt damping and flip guard rows), session-10 code → today's
in the same hour: 20k 3.7-4.1 s → 3.45-3.6 s (field 1.2-1.3, param 0.2, extract 0.7, planarize 1.5 → 1.1; same
1406-face candidate, 9.0e-5, healthy), 200k 44.0 s → 39.1-40.8 s (field 14.3-14.8, param 3.6, extract 5.5-5.9,
planarize 18.1 → 14.8-15.6; converged 9.2e-5, healthy, coverage 1.000), peak 1.5 GB. Issue #21's 3 s and 15 s are
still not met.
Session 12 (same machine; guard rows released from a factored system solved with its factor, not a new one),
session-11 code → today's in the same hour: 20k 3.16 s → 2.97-3.01 s (field 1.0, param 0.2, extract 0.6, planarize
1.0 → 1.0; same 1406-face candidate, 9.6e-5, healthy; the planarizer takes 27 iterations instead of 26 on this
candidate, 81 factorizations instead of 132), 200k 35.6 s → 32.7 s (planarize 13.4 → 10.6; converged 9.1e-5,
healthy, coverage 1.000), peak 1.5 GB. 20k is at the 3 s line, not under it with a margin; 200k is 2.2x from 15 s.
Session 13 (same machine; the conjugate field's local step and the closest-point scan compiled with numba, the
optional ``fast`` extra, components.core.compiled; the same results bit for bit, so the same candidates and meshes;
the modules are now imported before the children fork, as in a server's solver processes), the numpy code
(``GHSERVER_COMPILED=0``) → compiled, same hour: 20k 2.80-2.87 s → 2.51-2.55 s (field 1.0 → 0.7; same 1406-face
result, 9.6e-5, healthy), peak 213 → 250 MB (numba); 200k 30.7 s → 28.9 s (field 12.7 → 10.5), peak 1.56 → 1.57 GB.
The 200k row's sparse factorizations and solves (SuperLU: the field's, the parametrization's and the planarizer's)
are now 12.8 of its 28.5 s; the rest is spread over many numpy steps. Then the field's systems were put in reverse
Cuthill-McKee order before the minimum-degree ordering (a scan's face order had made libigl's face.obj take 2.9 s
per factorization instead of 0.15 s: its field 12.1 → 2.3 s, its pipeline through Hops 16.0 → 6.2 s). On the
patches this costs a few per cent of the field and changes its last bits, so the same candidates are planarized
along slightly different paths: 20k 2.50-2.55 s (same 1406-face result), 200k 30.5 s (field 11.0, planarize 11.3,
converged 9.8e-5, healthy, coverage 1.000).

Session 15 (another 2-core machine): 200k 32.2 s (field 11.5, param 3.1, extract 4.8, planarize 12.2; 12451 faces,
9.8e-5, healthy, coverage 1.000). Where a 2x could come from, measured by hand: the candidate built on a coarser
triangulation of the same surface (``patch(100000)`` / ``patch(50000)`` at the 200k row's panel size, 2.5 of its
mean edges) takes field 5.7 / 2.5 s, param 1.3 / 0.6, extract 4.5 / 13.5 (at 50k a panel is 1.25 triangle edges:
repairs), but the planarization of its 12,665 / 15,252 panels takes 15.8 / 18.5 s: 27.7 / 35.5 s in all. The
planarizer alone on the 200k row's saved candidate takes 12-14 s (38 iterations: 19 restore at β 0.12-0.5, where the
Gauss-Newton step would put hundreds of interior corners under the guard's bound, 15 optimize, 4 polish; 125
factorizations, 4.9 s). So the 15 s needs both a cheaper candidate and a planarization with fewer, longer steps;
neither alone reaches it. Its damping at 0.01 × the residual instead of 0.03 takes this candidate in 26 iterations
(10.4 s) and the 20k row's in 18 (0.79 s), but on 75 saved candidates (the patches' seeds 0-7 at 8k and 20k, seeds
0-3 at ×1000 and +5e6, the shared meshes at 300 panels) it converged 72 of 75 instead of 73 in the same CPU time
(76.5 against 75.6 s; DOS ``wein99`` stops unhealthy): tuned to the benchmark, not adopted.

Session 16 (another 2-core machine): 20k 3.02 s (1406 faces, 9.60e-5, healthy; 2.5-2.7 s by hand in the same
hour), 200k 35.0 s (field 12.2, param 3.4, extract 5.6, planarize 13.4; 12451 faces, 9.82e-5, healthy, coverage
1.000), 1.59 GB. The candidate on the project's own remesh of the 200k patch at a coarser edge, measured by hand:
the remesh itself takes 11.3-11.8 s to 81-84k triangles (1.41× the edge) and 21 s to 41-43k (2×), more than it
saves. On 81-84k the candidate takes field 4.4-4.6, param 1.1-1.2, extract 4.0-5.1 s, and its planarization 10.6 or
20.4 s for two candidates of nearly the same panels (12,484 and 12,465): the planarizer's time depends on the
candidate more than on its size. On the 43k remesh (a panel 1.24 of its edges) every one of the six candidates stayed
unhealthy after a 13-15 s repair each (88 s for the candidate; 570 triangles inverted in the parametrization): the
search now ends at the caller's deadline (components/fields/candidate.py ``_repaired``); on the same remesh at 1.5,
2, 2.5 and 3 of its edges the candidates stay unhealthy too (59, 38, 23, 15 s; 560-610 inverted triangles), where
the 80k patch remeshed to 66k or 16k triangles gives healthy candidates at 2.5 edges (4-20 inverted). That remesh
(5 iterations) was the odd one: with 10 iterations, or with the priorities' new hash (below) at 5, the 200k patch
at twice its edge gives healthy candidates at 2.5 edges in 4.2-4.5 s (8-25 inverted triangles). Not pursued.
The remesh rows in the same session: 50k 1.41x, 200k 1.65x gpytoolbox's CPU seconds before (2.42 / 12.05 s
against 1.72 / 7.29 s; the line had been 1.06x / 1.3x on session 9's machine); then the topology of a batch that
changed nothing was reused by the next operation and built with fewer passes (bit-identical remeshes): 1.87 / 9.84 s
against 1.63 / 7.06 s, **1.15x / 1.39x**. Coarsening was slower: the 200k patch at twice its mean edge took 21.8 s
(gpytoolbox 4.25 s), mostly the collapse checks, which every batch runs on every short edge (47 batches) before its
independent set takes a few per cent of them; and the first batches took only 0.3 % (1/35 expected) because the
priorities' multiplicative hash was not random on a grid's edge keys. With the splitmix64 finalizer: 14.0 s (1.41x
the edge: 11.9 → 8.0 s), the same quality (the patches; 86 remeshes of the shared meshes at 0.8 and 2 of their mean
edge: 198 triangles under 5° against 206), the rows 1.19-1.23x / 1.40-1.49x in three runs. Tried and not adopted:
the fold check on the chosen collapses only (x2 6.3 s, x1 9.7 s): with the same priorities every batch a chosen
collapse that fails it blocks its neighbourhood for good, and with priorities salted per batch libigl's camelhead
at 0.8 of its edge still gets 50 triangles under 5° and 124 under 20° against 31 and 53. The collapses chosen in three
rounds per batch (each among the candidates not next to one chosen before) moved one vertex of the hypar grid at
+5e6 by 1.4e-5 of the model's size at first (the projection took the neighbouring facet of the input on a rounding
tie; 2.4e-9 with one round); with the remesher working about the input's centre (+5e6 within 2-4e-10 of the size,
was 0.9-1.2e-9) they hold the placement test and were adopted: x2 13.0 → 8.7 s, x1.41 8.1 → 7.0 s, the shared
meshes' 86 remeshes 28.1 → 23.2 CPU s with 183 triangles under 5° against 198 (794 under 20° against 804).

Session 17 (another 2-core machine, AMD EPYC; the 20k row takes 3.4-4.2 s here where session 16's machine took
2.5-3.0 s for the same result): 20k 3.39 s (1406 faces, 9.03e-5, healthy), 200k 33.8 s (field 12.2, param 3.5,
extract 5.9, planarize 11.7; 12451 faces, 9.45e-5, healthy, coverage 1.000), 1.56 GB; 500k (new row) 86.5 s (field
17.4 from a decimated copy, param 9.6, extract 25.6, planarize 32.9: not converged, 2.0e-3 at the 30 s budget, healthy),
2.8 GB. The 200k row is a lucky seed: over 23 seeds of the 200k patch (``patch(200000, seed)``, the same call by
hand) the pipeline took 42.0 s on average (median 39.1, 31.9-59.5), one not converged; the tails are repairs (at
12-15k panels the best-ranked candidates often keep 1-5 unhealthy panels after repair, e.g. a boundary pentagon with
two 167° corners, faces folded onto a neighbour, and the next ones are repaired in turn) and planarizations that
use the whole 30 s budget. Changes: (1) after the best-ranked candidate the next ones are repaired two at a time and
the rest of the ranking relaxed at once (bit-identical; seed 3: extraction 17.3 → 12.8 s). (2) A field from a coarse
copy (components.fields.remesh.decimate to about 50k triangles in 2.3 s at 200k, then transferred_field and
closest_conjugate_pairs): the field 13-14 → 6-7 s at 200k, 41 s / 3.4 GB → 18 s at 500k. At 200k over the same 23
seeds: 34.9 s on average (median 33.2; faster on 17 of 23), but the best-ranked candidates kept the nominal
density less often (11 of 23 against 16 of 22) and 3 results fell short (2 unhealthy with one panel each, 1 not
converged) against 1, seed 0 (this row) among them: not converged at the budget in 53.5 s. So it applies above
300k triangles only (components.fields.parametrize.TWO_LEVEL_FACES), where the mesh's own field no longer fits a
request's time. Tried: a nearest-face copy smoothed by 80 damped Jacobi sweeps (3° from the mesh's own field; seeds
0-6: one planarization not converged); the interpolated transfer without the conjugate step on the mesh (seeds
7-14: planarizations 10-31 s, 2 of 8 not converged, against 9.7-36 s and 1: a field conjugate on the coarse copy is
not conjugate on the mesh); 3 local-global iterations with Jacobi global steps after the transfer (smoother, 0.00197
against 0.00232 in the connection Laplacian's energy, no closer to the mesh's own field: 2.94° against 2.95°; not
run through the pipeline); 6 or 10 selection rounds in the decimation (not faster: its batches are limited by the
checks).

Session 18 (same machine as session 17). Why the planarization of these candidates takes tens of steps, measured on
the saved 20k and 200k candidates: the restore phase's first Gauss-Newton step (the minimum-norm planarity
correction in the solver's metric) moves the median vertex 0.25 candidate edges at 20k and 0.52 at 200k, for a mean
planarity of 5.2e-3 / 1.3e-3; the same residual magnitudes with random signs need 0.065 / 0.046. The candidate's
non-planarity is systematic (smooth over many panels: the discretization of a conjugate net at finite panel size),
and the planarity rows of a quad net turn a smooth residual into a global slide of the net (their small singular
values belong to corrections smooth along one net direction), which the panel-health guard takes a quarter of at a
time (corners 15-20° past their bound at the full step, hundreds of guard rows). The metric does not change it: the
polyline fairness in the step metric (a vertex-space KKT system, fairness weight 1) 0.25 → 0.27 edges, an isotropic
metric 0.19, free boundary vertices 0.24. A coarse correction first (moves interpolated from the surface decimated
to 2.5 or 5 candidate edges, Gauss-Newton in that space) removes only 25-45 % of the linearized residual and its
full step raises the max planarity (0.060 → 0.094). A parametrization fit that weights the iso-lines' direction 10x
/ 100x over the panel size lowered the 20k candidates' mean planarity only to 4.3-4.9e-3 (from 5.1-5.5e-3), with
less even panels. Not adopted; the planarization of a 12k-panel candidate stays tens of steps.
Also measured: the seamless parametrization inverts 51-67 triangles on the 20k patches and 18-36 on the 200k ones,
almost all on the outline (the aligned boundary's constraints against the field; re-solving with their rings
stiffened 10x did not lower them); the repair and the ranking absorb them.
Changed: the repair (components/fields/repair.py). At 12-15k panels the best-ranked candidate kept one to seven
unhealthy panels after repair on a third of the seeds, all on the outline: flat quads (corners 20° / 160°) whose
short diagonal is 0.57-0.66 of their long side and cap triangles (0.52) where the sliver collapse took chords up to
half the longest side, small near-equilateral triangles (0.07 × the median area), slivers the last pass made or left
while changing something else (the collapse ran only when a pass changed nothing), and quads with all four corners
on the outline, pinched or folded in a bend of it. Now a sliver quad's short diagonal is collapsed up to 0.75 of its
longest side, a triangle's shortest edge up to 0.6 (any length under the area bound), the last pass collapses the
slivers it leaves, and an unhealthy quad with all its corners on the outline is dropped like such a triangle. Seeds
0-22 of the 200k patch: a candidate at the nominal panel count (12.2-12.7k panels) on 22 of 23 seeds (seeds 3-22: 19
of 20, against 14 of 20 before) and 22 of 23 converged and healthy (seed 13 stops at the 30 s budget, healthy,
3.8e-4); over seeds 3-22 extraction 9.5 → 6.1 s and the pipeline 42.4 → 36.6 s on average (all 23: 36.3 s, median
36.2, 29.9-58.9; runs of the same candidate vary by ±3 s on this machine; coverage at least 0.996 as before). The
20k patches' candidates (seeds 0-7) and 81 of the shared meshes' 84 (60 and 300 panels) are the same bit for bit;
inspired_mesh Conjugate / Smooth at 300 panels now keep their best-ranked candidate (no unrepaired panel; 1.3 / 1.1
s instead of 3.5 / 1.8 s), DOS wein99 at 300 gets 381 panels instead of 399 (healthy, converged; mean closeness
0.094 against 0.065). The benchmark row (seed 0) keeps its candidate: 33-35 s. Then (last change of the session) the
last repair pass also drops the unhealthy pentagons with four or five corners on the outline (a 10° or 174° corner
in a bend of it; earlier passes keep them): seed 14 ends at 12,292 panels instead of 13,575 (converged, healthy: 23
of 23 seeds at the nominal count, all but seed 13 converged); an 80k-triangle canopy of my own (an ellipse with an
oval hole) keeps its best-ranked candidate (2107 panels instead of 2545, extraction 1.6-2.0 s instead of 5.0-5.4 s,
in m, mm and at +5e6, coverage 0.998); the 20k candidates, 83 of the shared meshes' 84 and the default convergence
sweep are unchanged (DOS cmc1 at 300: 352 panels instead of 384, converged, healthy).

Session 19 (same machine): the planarizer's corner-row margin and tie-free normals (benchmarks/convergence.py) leave
the benchmark candidates' planarization about as it was: 20k 3.63 s (field 1.1, param 0.2, extract 0.8, planarize
1.4; 25 iterations instead of 31), 200k 36.0 s (field 13.0, param 3.5, extract 6.1, planarize 13.0), 1.54 GB. 200k
seeds 0-7 by hand: 33.3-39.2 s, mean 35.6, all at the nominal panel count, converged and healthy. The field of a
coarse copy (``TWO_LEVEL_FACES`` lowered to 150k, session 17's two-level field) measured again now that the repair
keeps the nominal panel count: the field 12.1-13.6 → 6.2-6.8 s and every seed still at the nominal count, but the
planarization 10.9-17.0 → 8.4-31.2 s (the coarse field is less conjugate on the mesh): 24.0-51.2 s, mean 34.4, seed
6 not converged at the 30 s budget (1.6e-4). Not adopted: the planarization, not the field, bounds the 200k row.

Session 20 (same machine): 20k 3.34 s (field 1.1, param 0.2, extract 0.7, planarize 1.2; the same result), 200k
34.3 s (field 12.2, param 3.5, extract 6.0, planarize 12.2), **peak 1.10 GB** instead of 1.54: the direction field's
SuperLU factors made on the helper thread had leaked (SciPy frees a factor only in the thread that allocated it,
scipy #15921; components.core.parallel.ThreadOwned now drops it there): the 200k run's peak address space 6.06 →
3.2-3.5 GB, and a solver process no longer grows from request to request. Tried: the field's later factorizations
on the first one's minimum-degree order (1.73 → 1.51 s each at 200k, not bit-identical: other candidates). Not
adopted.

Session 22 (another 2-core AMD EPYC machine), after the strategy ran on the surface centred, at unit size and
snapped (components/core/frame.py) and the planarizer snapped its normalized coordinates, the code before and after
one run after the other: before 20k 3.74 s (field 1.3, param 0.3, extract 0.9, planarize 1.3; 1406 faces, 9.12e-5),
200k 35.8 s (field 12.6, param 3.8, extract 6.1, planarize 12.8; 12451 faces, 9.33e-5), 1.06 GB; after 20k 2.92 and
3.27 s (field 1.1-1.2, param 0.3, extract 0.7-0.8, planarize 0.8-1.0; the same 1406 faces, 9.16e-5, healthy,
coverage 1.000), 200k 32.8 and 32.3 s (field 11.9-12.1, param 3.5, extract 5.3-5.5, planarize 11.0-11.4; 12452
faces: the snapped frame moved one panel, 9.27e-5, healthy, coverage 1.000), 1.06-1.08 GB. No step does less work
than before (the planarization takes a slightly other path from the snapped coordinates); the difference is within
this machine's swing (by hand the same 20k call ran 2.8-3.5 s with either code). 20k stays at the 3 s line, 200k
2.2x from 15 s.

Session 23 (session 22's machine), after the conjugate strategy gave every candidate the planarizer's first run
before any its other runs (the benchmark's best-ranked candidates converge at their first run: the same results):
20k 2.84 s (field 1.0, param 0.2, extract 0.7, planarize 0.9; 1406 faces, 9.16e-5, healthy), 200k 31.0 s (field
11.4, param 3.3, extract 5.4, planarize 10.3; 12452 faces, 9.27e-5, healthy), peak 1.04 GB. The two-level field at
200k (components/fields/parametrize.py ``TWO_LEVEL_FACES`` lowered to 150k, so the field comes from a 50k copy), seeds
0-2, one after the other with the default: the field 12.8-14.9 → 7.2-9.1 s, but the planarization 7.9-16.2 →
17.6-22.2 s (the coarse field's candidates planarize slower), end to end 30.3-41.3 → 36.2-41.9 s (this machine swung
30 % within the hour); all six converged and healthy. Not adopted.

Session 24 (another 2-core machine, 10-30 % slower than session 23's and swinging within the hour), the planarizer's
face-sized systems factored with qdldl's LDLᵀ instead of SuperLU (components/planarize/step.py ``factor_spd``;
benchmarks/solvers.py), the code before and after one run after the other, best of 2: 20k 3.38 → 3.54 s (field
1.2-1.3, param 0.2-0.3, extract 0.9, planarize 1.0 → 1.1: the machine's swing; alone, one after the other three times,
this candidate's planarization takes 0.80-1.02 → 0.70-0.75 s), 200k 41.8 → 37.7 s (field 13.9-14.5, param 4.5,
extract 6.7-7.1, planarize 15.6 → 11.6; the planarization alone 10.6-12.8 → 9.0-9.8 s), the same results (1406 and
12452 faces, 9.16e-5 and 9.27e-5, healthy, coverage 1.000), peak 1.0 GB. On this machine the field, the
parametrization and the extraction of the 200k row alone take 24-25 s: the 15 s needs them cheaper too.

Session 25 (session 24's machine, quieter: the 200k row 29.7-34.5 s with today's code, field 11.6-13.7, param 3.2-3.8,
extract 5.0-6.4, planarize 9.4-10.6; seeds 1-3 31.2-32.5 s). Four ways to a shorter row, measured and not adopted:
- The conjugate field's local-global iterations. 20 instead of 40: ``benchmarks/convergence.py --field-iterations
  20`` converges 24 of 24 as 40 does but is slower (8k 1.6-2.6 s against 1.5-2.1, 20k 3.0-4.7 against 2.7-4.2): the
  less conjugate candidates take longer to planarize. 80 at 200k: the candidate's mean planarity 1.32e-3 → 0.83e-3,
  but the field +5-6 s against planarizations 9.1 → 7.2 s (seed 0) and 11.8 → 11.6 s (seed 1): 29.7 → 31.1 and
  31.5 → 36.9 s. The iterations do not converge (the pairs still turn by the same amount at the 40th) and pay for
  themselves at about 40.
- A field from a coarse copy finished on the mesh: decimate to about 50k triangles, that copy's field, carried over
  (``transferred_field``), then 10 local-global iterations on the mesh itself (where session 17 only took the
  closest conjugate pairs). Seeds 0-3: field 10.2-12.8 s (decimate 2.7-3.2, coarse field 2.6-3.1, the 10 fine
  iterations 4.2-5.9: their two factorizations) against 11.7-12.4 s; end to end 29.8-36.0 s against 29.7-32.5 s
  (seed 2 got a 13,917-panel candidate: extraction 11.7 s). No gain.
- Longer restore steps: after a halving, two bisections between the accepted fraction β and the rejected 2β (a
  health evaluation each, no solve), since on the 200k candidate the trials at β 0.5 failed by one or two degrees of a
  corner. The 200k candidates of seeds 0-3 took 25 / 39 / 27 / 29 iterations instead of 32 / 38 / 34 / 36 (43.5
  against 48.1 s of planarization in all), and the 20k candidate now ran its optimize phase (mean closeness 0.0106 →
  0.0059 of an edge, in 22 iterations instead of 12). But on 171 saved candidates (``convergence.py --saved``: the
  patches' seeds 0-15 at 8k and 20k, the 20k seeds 0-3 and 8k seeds 4-7 at ×1000 and +5e6, the shared meshes at 60,
  300 and 1000 panels) 152 converged instead of 155, none gained: a step that ends right at the guard's bound leaves
  the next ones less room. With one bisection: 62 of 65 instead of 63 on the first 65.
- The reduced systems' many right-hand sides (``_Reduced``: 2,097 back-substitutions, 1.6 s of the 200k
  planarization) solved in one pass on qdldl's factors (a compiled triangular solve): 2x on 60 columns, so 0.8 s,
  and not bit-identical with the column loop.
What the 200k row is made of: the planarization of its 12.5k panels alone takes 9-12 s here (32-38 iterations, 99
factorizations at 26 ms and 2,100 back-substitutions: 4.2 of 10 s; the rest is spread over the guard's checks), and
the field, the parametrization and the extraction of the 200k-triangle input 20-25 s. Each measured variant of each
step saves 10-20 % of its step at most; together they do not approach 15 s on this machine. The row needs another
planarization (a handful of steps for thousands of panels under the panel-health guard) and a candidate built at the
panels' scale, not the input's; neither exists here yet.

Inputs: an open, disk-like free-form patch (a jittered triangulated grid on z = 0.3 sin(2x) cos(3y) + 0.2 x y over
[-1.5, 1.5]²) with a hole punched in it, so boundaries are exercised; sizes are the triangle counts.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))  # forked.py, also when imported as benchmarks.fields

from components.core.curvature import gaussian_curvature, vertex_principal_curvature  # noqa: E402
from components.core.mesh import edge_topology, read_mesh, remove_unreferenced  # noqa: E402
from components.fields.remesh import isotropic_remesh  # noqa: E402
from forked import peak_mb, run_forked  # noqa: E402

# every module the steps use, imported before the measured children fork, as a server's solver processes import
# them when they start: a row times the step, not Python's imports (numba's compiled kernels load at import)
import components.fields.pipeline  # noqa: E402,F401


class Step(NamedTuple):
    name: str
    ours: Callable
    reference: Callable | None = None
    reference_name: str = ""
    repeat: int | None = None  # override of --repeat for slow steps
    quality: Callable | None = None  # result -> short text (what the result is, beside the time)


def _mean_edge(V, T):
    E = edge_topology(T).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


# ----------------------------------------------------------------------------------------------
# steps 1–2 (remeshing, curvature); later steps append below


def remesh_ours(V, T):
    return isotropic_remesh(V, T, _mean_edge(V, T), iterations=10)


def remesh_gpytoolbox(V, T):
    import gpytoolbox

    return gpytoolbox.remesh_botsch(V, T.astype(np.int32), 10, _mean_edge(V, T), True)


def curvature2_ours(V, T):
    return vertex_principal_curvature(V, T, radius=2)


def curvature2_igl(V, T):
    import igl

    return igl.principal_curvature(V, T, 2)


def curvature5_ours(V, T):
    return vertex_principal_curvature(V, T, radius=5)


def curvature5_igl(V, T):
    import igl

    return igl.principal_curvature(V, T, 5)


def gaussian_ours(V, T):
    return gaussian_curvature(V, T, method="discrete")


def gaussian_igl(V, T):
    import igl

    return igl.gaussian_curvature(V, T)


STEPS: list[Step] = [
    Step("remesh (10 it, L = mean edge)", remesh_ours, remesh_gpytoolbox, "gpytoolbox.remesh_botsch", repeat=1),
    Step("principal curvature, radius 2", curvature2_ours, curvature2_igl, "igl.principal_curvature"),
    Step("principal curvature, radius 5", curvature5_ours, curvature5_igl, "igl.principal_curvature"),
    Step("gaussian curvature (fit + angle defect)", gaussian_ours, gaussian_igl, "igl.gaussian_curvature"),
]


# ----------------------------------------------------------------------------------------------
# steps 5, 7, 8 (parametrization, extraction, end-to-end); panels of 2.5 mean edge lengths


def _field(V, T):
    from components.fields.parametrize import direction_field

    return direction_field(V, T, field="conjugate", alignment=0.1)


def parametrize_ours(V, T):
    from components.fields.parametrize import seamless_parametrization

    U, W = _field(V, T)
    return seamless_parametrization(V, T, U, W, 2.5 * _mean_edge(V, T))


def candidate_ours(V, T):
    from components.fields.candidate import candidate_mesh

    return candidate_mesh((V, T), 2.5 * _mean_edge(V, T))


def pq_end_to_end_ours(V, T):
    from components.fields.pipeline import pq_from_conjugate_field

    return pq_from_conjugate_field((V, T), 2.5 * _mean_edge(V, T), time_budget=30.0)


def candidate_quality(c):
    return (f"{len(c.F)} faces, {c.quads} quads, {c.singularities} irregular, angle err {c.mean_angle_error:.3f}°, "
            f"healthy {c.health is None or c.health.healthy}")


def pq_quality(r):
    return (f"{len(r.planarized[1])} faces ({100 * r.quad_ratio:.1f}% quads), candidate max planarity "
            f"{r.candidate_max_planarity:.2e}, planarized max {r.planarized_max_planarity:.2e} / mean "
            f"{r.planarized_mean_planarity:.2e}, healthy {r.healthy}, coverage {r.coverage:.3f}; s: field "
            f"{r.time_field:.1f} param {r.time_parametrize:.1f} extract {r.time_extract:.1f} planarize "
            f"{r.time_planarize:.1f}")


def remesh_quality(out):
    V2, T2 = out[0], out[1]
    E = edge_topology(np.asarray(T2, np.int64)).E
    L = np.linalg.norm(V2[E[:, 1]] - V2[E[:, 0]], axis=1)
    return f"{len(T2)} triangles, edge / mean: min {L.min() / L.mean():.2f} max {L.max() / L.mean():.2f}"


STEPS[0] = STEPS[0]._replace(quality=remesh_quality)
STEPS += [
    Step("field + seamless parametrization (L=2.5e)", parametrize_ours, repeat=1),
    Step("candidate: field+param+extract (L=2.5e)", candidate_ours, repeat=1, quality=candidate_quality),
    Step("pq_from_conjugate_field end-to-end", pq_end_to_end_ours, repeat=1, quality=pq_quality),
]


# ----------------------------------------------------------------------------------------------
# steps 3, 4, 6 (smooth field, conjugate field, singularities, streamlines)


def _curv(V, T):
    from components.fields.field import field_curvature

    return field_curvature(V, T)


def smooth_field_ours(V, T):
    from components.fields.field import smooth_frame_field

    return smooth_frame_field(V, T, alignment=0.1)


def _smooth(V, T):
    from components.fields.field import smooth_frame_field

    cv = _curv(V, T)
    return cv, smooth_frame_field(V, T, alignment=0.1, curvature=cv)


def conjugate_field_ours(V, T):
    """Curvature + smooth field + conjugate field (the pipeline's field stage)."""
    from components.fields.field import conjugate_frame_field

    cv, s = _smooth(V, T)
    return conjugate_frame_field(V, T, s.U, s.W, curvature=cv)


def _principal(V, T):
    cv = _curv(V, T)
    return cv.d1, cv.d2


def singularities_ours(V, T):
    from components.fields.field import field_singularities

    return field_singularities(V, T, *_principal(V, T))


def singularities_igl(V, T):
    import igl

    return igl.find_cross_field_singularities(V, T, *_principal(V, T), False)


def comb_ours(V, T):
    from components.fields.field import comb_field

    return comb_field(V, T, *_principal(V, T))


def comb_igl(V, T):
    import igl

    return igl.comb_cross_field(V, T, *_principal(V, T))


def streamlines_ours(V, T):
    """Conjugate field, then an evenly spaced net of both families at 2.5 mean edges."""
    from components.fields.streamlines import evenly_spaced_streamlines

    from components.fields.field import conjugate_frame_field

    cv, s = _smooth(V, T)
    c = conjugate_frame_field(V, T, s.U, s.W, curvature=cv)
    return evenly_spaced_streamlines(V, T, c.U, c.W, family=2, separation=2.5 * _mean_edge(V, T))


def _polyvector_system(V, T):
    import scipy.sparse as sp

    from components.fields.field import _alignment_weights, _anisotropy, _connection_laplacian
    from components.fields.frames import dual_graph, face_frames

    fr = face_frames(V, T)
    dg = dual_graph(V, T, fr)
    w = 0.1 * 1000.0 * fr.area / fr.area.sum() * _alignment_weights(_anisotropy(_curv(V, T)))
    return sp.csc_matrix(_connection_laplacian(dg, len(T), 4) + sp.diags(w.astype(complex)))


def factor_symmetric_ours(V, T):
    """The smooth-field system factored as components.fields.field does (reverse Cuthill-McKee, then MMD on the
    AᵀA pattern, no pivoting)."""
    from components.fields.field import _factor

    return _factor(_polyvector_system(V, T))


def factor_colamd(V, T):
    from scipy.sparse.linalg import splu

    return splu(_polyvector_system(V, T), permc_spec="COLAMD")


STEPS += [
    Step("smooth field (curvature + PolyVector)", smooth_field_ours),
    Step("conjugate field (curv+smooth+conj, 40 it)", conjugate_field_ours, repeat=1),
    Step("singularities of principal dirs", singularities_ours, singularities_igl,
         "igl.find_cross_field_singularities"),
    Step("comb principal dirs", comb_ours, comb_igl, "igl.comb_cross_field"),
    Step("PolyVector factor: MMD sym vs COLAMD", factor_symmetric_ours, factor_colamd, "splu COLAMD (pivoting)"),
    Step("conjugate field + streamline net (2.5e)", streamlines_ours, repeat=1),
]


# ----------------------------------------------------------------------------------------------
# inputs


def patch(n_triangles: int, seed: int = 0):
    """Open free-form patch with one hole, about ``n_triangles`` triangles."""
    n = max(4, int(round(np.sqrt(n_triangles / 2.0 / 0.985))))
    u = np.linspace(-1.5, 1.5, n + 1)
    X, Y = np.meshgrid(u, u)
    rng = np.random.default_rng(seed)
    h = 3.0 / n
    inner = (np.abs(X) < 1.5 - 1e-9) & (np.abs(Y) < 1.5 - 1e-9)
    X = X + inner * rng.uniform(-0.25, 0.25, X.shape) * h
    Y = Y + inner * rng.uniform(-0.25, 0.25, Y.shape) * h
    Z = 0.3 * np.sin(2 * X) * np.cos(3 * Y) + 0.2 * X * Y
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    T = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    cen = V[T].mean(axis=1)
    T = T[np.hypot(cen[:, 0] - 0.5, cen[:, 1] - 0.3) > 0.2]  # the hole
    V, T, _ = remove_unreferenced(V, T)
    return V, T.astype(np.int64)


def _best(fn, V, T, repeat):
    """``(best wall seconds, its CPU seconds, last result)`` of ``repeat`` runs."""
    best, cpu, out = np.inf, np.nan, None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn(V, T)
        dt = time.perf_counter() - t
        if dt < best:
            best, cpu = dt, time.process_time() - c
    return best, cpu, out


def _one(step_index, size_or_path, repeat, which):
    step = STEPS[step_index]
    V, T = _input(size_or_path)
    fn = step.ours if which == "ours" else step.reference
    wall, cpu, out = _best(fn, V, T, repeat)
    q = step.quality(out) if (step.quality and which == "ours") else ""
    return wall, cpu, peak_mb(), q


def _measure(step_index, size_or_path, repeat, which="ours"):
    """Run one step on one input in a fresh (forked) process: ``(wall s, cpu s, peak MB, quality text)``."""
    return run_forked(_one, step_index, size_or_path, repeat, which, failed=(np.nan, np.nan, np.nan, "failed"))


def _input(size_or_path):
    if isinstance(size_or_path, int):
        return patch(size_or_path)
    return read_mesh(size_or_path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 50_000, 200_000])
    ap.add_argument("--steps", nargs="*", default=None, help="substrings of step names to run")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--real", action="store_true", help="also time the shared face scan (52k triangles)")
    args = ap.parse_args(argv)
    inputs = [(f"patch {s // 1000}k", s) for s in args.sizes]
    if args.real:
        path = ROOT.parent / "shared" / "data" / "meshes" / "libigl" / "face.obj"
        if path.exists():
            inputs.append(("face.obj", str(path)))
    steps = [i for i, s in enumerate(STEPS) if not args.steps or any(k in s.name for k in args.steps)]
    from components.core.parallel import thread_count
    print(f"threads within a step: {thread_count()} (GHSERVER_THREADS; results are the same with any count)")
    print(f"{'step':42s} {'input':10s} {'tris':>7s} {'ours s':>8s} {'cpu s':>7s} {'ref s':>8s} {'ref cpu':>7s} "
          f"{'ratio':>6s} {'peak MB':>8s}  reference / result")
    for i in steps:
        step = STEPS[i]
        for label, src in inputs:
            repeat = step.repeat or args.repeat
            ntri = len(_input(src)[1])
            wall, cpu, peak, q = _measure(i, src, repeat)
            rw, rc = (_measure(i, src, repeat, "reference")[:2] if step.reference else (np.nan, np.nan))
            # same-moment ratio: CPU seconds (the wall clock swings with the other jobs on the machine)
            ratio = cpu / rc if step.reference else float("nan")
            print(f"{step.name:42s} {label:10s} {ntri:7d} {wall:8.3f} {cpu:7.3f} {rw:8.3f} {rc:7.3f} {ratio:6.2f} "
                  f"{peak:8.0f}  {step.reference_name or '-'}{'; ' + q if q else ''}", flush=True)


if __name__ == "__main__":
    main()
