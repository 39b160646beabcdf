"""Time the closest-point index and the panel-health check (issue #21) at 20k and 200k triangles beside libigl.

Run from the project root::

    /work/venv/bin/python benchmarks/health.py                     # 20k and 200k triangles
    /work/venv/bin/python benchmarks/health.py --sizes 20000 --trimesh

Every other stage calls these two: ``TriangleIndex(V, T).query(P)`` (closest points on the design surface) and
``face_health(V, F, reference=(Vr, Tr))`` (is a panelling fabricable). Inputs: benchmarks/fields.py's patch (a
jittered triangulated grid on z = 0.3 sin(2x) cos(3y) + 0.2 x y over [-1.5, 1.5]² with a hole) and a candidate
panelling like the conjugate pipeline's: a jittered quad grid on the same surface with the hole cut out, panels of
2.5 mean edges (1.35k quads at 20k triangles, 13.3k at 200k; warped, so coverage judges both diagonal splits).
Query points: ``0.075 ×`` the triangle count, random on the surface and moved off it by N(0, 0.1 mean edge)
(``near``: like the pipelines' queries, vertices and centroids of panellings) or N(0, 1 mean edge) (``off``).

Rows (seconds are the best of ``--repeat`` runs, CPU seconds of that run; each row runs in a fresh forked process,
so ``peak MB`` is that row's high-water mark; ``ratio`` is ours / reference in CPU seconds, below 1 = faster):

* ``TriangleIndex build``: the grid index of the surface (the reuse cache cleared first), beside ``igl.AABB.init``.
* ``TriangleIndex query, near / off``: the built index queried, beside ``igl.AABB.squared_distance``; the result
  column gives the largest difference to libigl's distances / mean edge (both exact: round-off).
* ``closest_points`` (build + query once), beside ``trimesh.proximity.closest_point`` with ``--trimesh``.
* ``face_health, no reference``: the shape and crossing checks of the candidate.
* ``face_health vs surface``: with the design surface as reference (coverage, closeness, flipped faces), first
  call (the surface's index built) and ``repeated`` (the index reused, as in a pipeline's later checks).

Measured 2026-12 on the 2-core project machine while 5 other jobs ran (CPU seconds; before = main 4d447a4 →
after issue #21's proximity / health work; every distance equal to libigl's within 3e-14 edge, every verdict,
defect count, coverage and hole count the same):

====================================  =================  =================
row                                   20k triangles      200k triangles
====================================  =================  =================
TriangleIndex build                   0.088 → 0.029      1.458 → 0.260  (igl.AABB.init 0.25)
TriangleIndex query, near             0.026 → 0.014      0.401 → 0.114  (igl 0.094; 15k points)
TriangleIndex query, off              0.064 → 0.044      0.744 → 0.507  (igl 0.167)
face_health, no reference             0.043 → 0.021      0.296 → 0.103  (13.3k quads)
face_health vs surface, first call    0.629 → 0.152      5.576 → 1.042  (index of the surface built)
face_health vs surface, repeated      0.664 → 0.070      5.775 → 0.522  (index reused)
====================================  =================  =================

Peak memory of a 200k-triangle index: about 80 MB held, 185 MB while it is built.

Session 13: the grid scan compiled with numba (the optional ``fast`` extra; the same triangles and distances bit for
bit), the numpy scan → compiled, same hour, wall seconds: 200k query near 0.033 → 0.025, off 0.190 → 0.103; 20k
near 0.004 → 0.002, off 0.015 → 0.009; builds unchanged (the per-triangle table the scan reads, 30 MB at 200k, is
made on the first scan). Peak memory rows are higher by numba's own ~100 MB.
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
sys.path.insert(0, str(Path(__file__).resolve().parent))

import components.core.proximity as proximity  # noqa: E402
from components.core.mesh import edge_topology  # noqa: E402
from components.metrics.health import face_health  # noqa: E402
from fields import patch  # noqa: E402  (benchmarks/fields.py: the shared input)
from forked import peak_mb, run_forked  # noqa: E402


def _mean_edge(V, T):
    E = edge_topology(T).E
    return float(np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1).mean())


def _surface_z(x, y):
    return 0.3 * np.sin(2 * x) * np.cos(3 * y) + 0.2 * x * y


def candidate(V, T, seed: int = 1):
    """A quad panelling of the patch like the pipeline's candidate (about one quad per 16 triangles: panels of about
    2.5 mean edges), jittered, on the surface, the faces over the hole left out."""
    n = max(2, int(round(np.sqrt(len(T) / 15.0))))
    u = np.linspace(-1.5, 1.5, n + 1)
    X, Y = np.meshgrid(u, u)
    rng = np.random.default_rng(seed)
    inner = (np.abs(X) < 1.5 - 1e-9) & (np.abs(Y) < 1.5 - 1e-9)
    X = X + inner * rng.uniform(-0.1, 0.1, X.shape) * (3.0 / n)
    Y = Y + inner * rng.uniform(-0.1, 0.1, Y.shape) * (3.0 / n)
    P = np.stack([X.ravel(), Y.ravel(), _surface_z(X, Y).ravel()], axis=1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    Q = np.stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()], axis=1)
    c = P[Q].mean(axis=1)
    Q = Q[np.hypot(c[:, 0] - 0.5, c[:, 1] - 0.3) > 0.2]
    used = np.unique(Q)
    remap = np.full(len(P), -1)
    remap[used] = np.arange(len(used))
    return P[used], remap[Q]


def query_points(V, T, off: float, seed: int = 2):
    """``0.075 ×`` the triangle count: random points of the surface, moved off it along z by N(0, ``off`` edges)."""
    rng = np.random.default_rng(seed)
    k = max(1, int(0.075 * len(T)))
    t = rng.integers(0, len(T), k)
    b = rng.dirichlet(np.ones(3), k)
    P = np.einsum("ki,kij->kj", b, V[T[t]])
    P[:, 2] += off * _mean_edge(V, T) * rng.normal(size=k)
    return P


class Row(NamedTuple):
    name: str
    ours: Callable  # (data) -> result
    reference: Callable | None = None
    reference_name: str = ""
    quality: Callable | None = None  # (data, ours result, reference result or None) -> text
    setup: Callable | None = None  # (data) -> None, before every timed run (untimed)


def _clear(_data):
    proximity._CACHE.clear()


def _igl_tree(d):
    import igl

    tree = igl.AABB()
    tree.init(d["V"], d["T"])
    return tree


def _warm(d):
    face_health(d["CV"], d["CF"], (d["V"], d["T"]))


def _health_text(d, h, _ref):
    bad = {k: v for k, v in h.counts.items() if v}
    return (f"{len(d['CF'])} quads: healthy {h.healthy}, defects {bad or 'none'}, coverage {h.coverage:.6f}, "
            f"holes {h.holes}, worst corner {h.worst_corner:.1f}°")


def _dist_text(d, res, ref):
    if ref is None:
        return f"{len(d['P'])} points, mean distance / edge {res.distances.mean() / d['L']:.4f}"
    dref = np.sqrt(np.maximum(ref[0], 0.0))
    return f"{len(d['P'])} points, max |ours - ref| / edge {np.abs(res.distances - dref).max() / d['L']:.1e}"


def _trimesh_closest(d):
    import trimesh

    m = trimesh.Trimesh(d["V"], d["T"], process=False)
    return trimesh.proximity.closest_point(m, d["P"])


def _trimesh_text(d, res, ref):
    if ref is None:
        return _dist_text(d, res, None)
    return f"{len(d['P'])} points, max |ours - ref| / edge {np.abs(res.distances - ref[1]).max() / d['L']:.1e}"


ROWS = [
    Row("TriangleIndex build", lambda d: proximity.TriangleIndex(d["V"], d["T"]),
        _igl_tree, "igl.AABB.init", setup=_clear),
    Row("TriangleIndex query, near", lambda d: d["index"].query(d["P"]),
        lambda d: d["tree"].squared_distance(d["V"], d["T"], d["P"]), "igl.AABB.squared_distance", _dist_text),
    Row("TriangleIndex query, off", lambda d: d["index"].query(d["Poff"]),
        lambda d: d["tree"].squared_distance(d["V"], d["T"], d["Poff"]), "igl.AABB.squared_distance",
        lambda d, res, ref: _dist_text(dict(d, P=d["Poff"]), res, ref)),
    Row("closest_points (build + query)", lambda d: proximity.closest_points(d["P"], d["V"], d["T"]),
        _trimesh_closest, "trimesh.proximity.closest_point", _trimesh_text, setup=_clear),
    Row("face_health, no reference", lambda d: face_health(d["CV"], d["CF"]), quality=_health_text),
    Row("face_health vs surface (first call)", lambda d: face_health(d["CV"], d["CF"], (d["V"], d["T"])),
        quality=_health_text, setup=_clear),
    Row("face_health vs surface (repeated)", lambda d: face_health(d["CV"], d["CF"], (d["V"], d["T"])),
        quality=_health_text, setup=_warm),
]


def _data(n: int) -> dict:
    V, T = patch(n)
    CV, CF = candidate(V, T)
    d = dict(V=V, T=T, CV=CV, CF=CF, P=query_points(V, T, 0.1), Poff=query_points(V, T, 1.0), L=_mean_edge(V, T))
    return d


def _one(row_index, d, repeat, which):
    row = ROWS[row_index]
    if row.name.startswith("TriangleIndex query"):  # built before the clock starts
        d["index"] = proximity.TriangleIndex(d["V"], d["T"])
        d["tree"] = _igl_tree(d) if which == "reference" else None
    fn = row.ours if which == "ours" else row.reference
    best, cpu, out = np.inf, np.nan, None
    for _ in range(repeat):
        if row.setup and which == "ours":
            row.setup(d)
        t, c = time.perf_counter(), time.process_time()
        out = fn(d)
        dt = time.perf_counter() - t
        if dt < best:
            best, cpu = dt, time.process_time() - c
    keep = row.reference is not None and row.quality is not None  # the parent compares the two outputs
    text = row.quality(d, out, None) if (row.quality and which == "ours") else ""
    return (best, cpu, peak_mb(), out if keep and which == "reference" else None, text,
            out if keep and which == "ours" else None)


def _measure(row_index, d, repeat, which="ours"):
    """Run one row in a fresh (forked) process: ``(wall s, cpu s, peak MB, reference output, text, our output)``."""
    return run_forked(_one, row_index, d, repeat, which, failed=(np.nan, np.nan, np.nan, None, "failed", None))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[20_000, 200_000])
    ap.add_argument("--rows", nargs="*", default=None, help="substrings of row names to run")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--trimesh", action="store_true", help="time trimesh.proximity.closest_point (slow at 200k)")
    args = ap.parse_args(argv)
    rows = [i for i, r in enumerate(ROWS) if not args.rows or any(k in r.name for k in args.rows)]
    print(f"{'row':38s} {'tris':>7s} {'ours s':>8s} {'cpu s':>7s} {'ref s':>8s} {'ref cpu':>7s} {'ratio':>6s} "
          f"{'peak MB':>8s}  reference / result")
    for n in args.sizes:
        d = _data(n)
        for i in rows:
            row = ROWS[i]
            wall, cpu, peak, _, text, mine = _measure(i, d, args.repeat)
            has_ref = row.reference is not None and (row.reference is not _trimesh_closest or args.trimesh)
            rw, rc, ref_out = np.nan, np.nan, None
            if has_ref:
                rw, rc, _, ref_out, _, _ = _measure(i, d, args.repeat, "reference")
                if row.quality and mine is not None:
                    text = row.quality(d, mine, ref_out)
            ratio = cpu / rc if has_ref else float("nan")
            print(f"{row.name:38s} {len(d['T']):7d} {wall:8.3f} {cpu:7.3f} {rw:8.3f} {rc:7.3f} {ratio:6.2f} "
                  f"{peak:8.0f}  {row.reference_name + '; ' if has_ref else ''}{text}", flush=True)


if __name__ == "__main__":
    main()
