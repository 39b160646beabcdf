"""How often the conjugate-field strategy reaches its tolerance: a sweep of inputs, not one case (issue #21).

The planarization of a candidate either reaches the planarity tolerance or stops when the panel-health guard
refuses every step ("no step keeps the panels healthy", "stalled"); which one happens flips under tiny changes of
the input or the code (the 20k benchmark patch moved by +5e6, a different tie between two equally close
triangles). A change to the planarizer or to the candidate is judged here by the share of a sweep that converges,
beside its time.

Run from the project root::

    /work/venv/bin/python benchmarks/convergence.py                     # seeds 0-3 × 8k, 20k × ×1, ×1000, +5e6
    /work/venv/bin/python benchmarks/convergence.py --seeds 0 1 --sizes 8000 --placements x1

Each case runs ``pq_from_conjugate_field`` on benchmarks/fields.py's patch (jittered by ``seed``) at panels of
2.5 mean edges, in a fresh child process. Prints one row per case (faces, candidate and final max planarity,
converged = max planarity ≤ tolerance and healthy, the stop reason, seconds) and the converged share.
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
from forked import run_forked  # noqa: E402

PLACEMENTS = {"x1": (1.0, 0.0), "x1000": (1000.0, 0.0), "+5e6": (1.0, 5e6)}
TOLERANCE = 1e-4


def _case(size: int, seed: int, placement: str, budget: float):
    from components.fields.pipeline import pq_from_conjugate_field

    scale, offset = PLACEMENTS[placement]
    V, T = patch(size, seed=seed)
    h = 2.5 * _mean_edge(V, T)
    t = time.perf_counter()
    r = pq_from_conjugate_field((V * scale + offset, T), h * scale, tolerance=TOLERANCE, time_budget=budget)
    dt = time.perf_counter() - t
    stop = next((w.split(": ", 1)[1] for w in r.warnings if w.startswith("planarization stopped")), "")
    return len(r.planarized[1]), r.candidate_max_planarity, r.planarized_max_planarity, r.healthy, stop, dt


def run(size: int, seed: int, placement: str, budget: float):
    """One case in a fresh process: ``(faces, candidate max, final max, healthy, stop reason, seconds)``."""
    return run_forked(_case, size, seed, placement, budget,
                      failed=(0, float("nan"), float("nan"), False, "crashed", float("nan")))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2, 3])
    ap.add_argument("--sizes", type=int, nargs="*", default=[8000, 20000])
    ap.add_argument("--placements", nargs="*", default=list(PLACEMENTS), choices=list(PLACEMENTS))
    ap.add_argument("--budget", type=float, default=30.0, help="the planarization's time budget, s")
    args = ap.parse_args(argv)
    print("| size | seed | placement | faces | candidate max | final max | converged | healthy | stop | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    done = 0
    cases = [(s, seed, pl) for s in args.sizes for seed in args.seeds for pl in args.placements]
    for size, seed, pl in cases:
        nf, cmax, pmax, healthy, stop, dt = run(size, seed, pl, args.budget)
        ok = bool(healthy and pmax <= TOLERANCE)
        done += ok
        print(f"| {size} | {seed} | {pl} | {nf} | {cmax:.2e} | {pmax:.2e} | {'yes' if ok else 'no'} | {healthy} "
              f"| {stop or '-'} | {dt:.1f} |", flush=True)
    print(f"\nconverged and healthy: {done} of {len(cases)} ({100.0 * done / max(len(cases), 1):.0f}%)")


if __name__ == "__main__":
    main()
