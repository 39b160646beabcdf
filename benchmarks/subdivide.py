"""Benchmark: Catmull-Clark subdivision and pull-to-surface, beside the reference libraries in the same run.

Run from the project root::

    /work/venv/bin/python benchmarks/subdivide.py [--quick]

Tables printed:

1. ``subdivided_mesh`` on regular grids of growing size, a mixed tri/quad/pentagon mesh and the shared real
   meshes, beside libigl's Loop subdivision (``igl.loop``, the nearest compiled subdivision in the reference
   libraries) on the fan-triangulated input with the same number of levels: time and time per output face.
2. A cross-check with COMPAS' Catmull-Clark (pure Python, ``compas.datastructures``) on closed meshes, where both
   use the same rules: largest vertex difference and time. Skipped if COMPAS is not importable; it can be put
   outside the project's environment with ``pip install --target /tmp/compas_ref compas --no-deps`` and
   ``COMPAS_PATH=/tmp/compas_ref``.
3. ``pulled_vertices`` (exact closest points via ``components.core.proximity``) of subdivided candidates onto
   ``meshes/libigl/inspired_mesh.obj``, beside ``igl.point_mesh_squared_distance`` (AABB tree) on the same query
   points: time and the largest difference between the two distances.
4. The whole strategy (``subdivision_pq``, 36 coarse faces, 2 levels) on the four sample surfaces and
   inspired_mesh, per coarse layout, against issue 8's targets (candidate on the surface ≤ 1e-9 of the diagonal,
   max planarity ≤ 1e-4, mean closeness ≤ 2% of the mean edge), with libigl's ``planarize_quad_mesh`` on the
   same candidate (no closeness term; 50 iterations) for reference.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from components.core.mesh import pad_faces, quad_grid, read_mesh, triangulate  # noqa: E402
from components.subdivision.pull import pulled_vertices  # noqa: E402
from components.subdivision.subdivide import subdivided_mesh  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "meshes"


def _best(fn, repeat=3):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _cube():
    V = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    F = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    return V, F


def _pyramid():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
    F = pad_faces([[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], k=4)
    return V, F


def _mixed(n):
    """An n × n wavy grid where every fourth quad is split into two triangles and one row is merged into pentagons."""
    V, Q = quad_grid(n, n, 10.0, 10.0, height=lambda x, y: np.sin(x) * np.cos(y))
    faces = []
    for i, q in enumerate(Q.tolist()):
        if i % 4 == 0:
            faces += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        else:
            faces.append(q)
    return V, pad_faces(faces, k=4)


def _grid(n):
    return quad_grid(n, n, 10.0, 10.0, height=lambda x, y: np.sin(x) * np.cos(y))


def table_subdivision(quick: bool):
    import igl

    cases = [("grid 20²", _grid(20), 3), ("grid 50²", _grid(50), 3), ("mixed 50²", _mixed(50), 3)]
    if not quick:
        cases += [("grid 100²", _grid(100), 3), ("grid 100²", _grid(100), 4)]
    for rel, levels in (("dos/obj_gnet__chebyshev_sphere.obj", 3), ("libigl/inspired_mesh_quads_Conjugate.off", 3),
                        ("libigl/inspired_mesh.obj", 2), ("brg/aag2018_armadillo_formdiagram_final.obj", 3)):
        path = SHARED / rel
        if path.exists():
            cases.append((rel.split("/")[-1], read_mesh(path), levels))
    print("\n1. subdivided_mesh vs igl.loop (same levels, input fan-triangulated for Loop)")
    print(f"{'mesh':38s} {'L':>2s} {'faces in':>9s} {'faces out':>10s} {'ours s':>8s} {'µs/face':>8s} "
          f"{'loop faces':>11s} {'loop s':>8s} {'µs/face':>8s} {'ratio':>6s}")
    for name, (V, F), levels in cases:
        repeat = 1 if len(F) * 4 ** levels > 300_000 else 3
        t_ours, (V1, Q1, _) = _best(lambda: subdivided_mesh(V, F, levels=levels, max_faces=4_000_000), repeat)
        T = triangulate(F)[0]
        t_loop, (VL, FL) = _best(lambda: igl.loop(V, T, levels), repeat)
        a = 1e6 * t_ours / len(Q1)
        b = 1e6 * t_loop / len(FL)
        print(f"{name:38s} {levels:2d} {len(F):9d} {len(Q1):10d} {t_ours:8.3f} {a:8.2f} {len(FL):11d} "
              f"{t_loop:8.3f} {b:8.2f} {a / b:6.2f}")


def table_compas():
    path = os.environ.get("COMPAS_PATH", "/tmp/compas_ref")
    if Path(path).exists():
        sys.path.append(path)
    try:
        from compas.datastructures import Mesh
    except Exception:  # noqa: BLE001 - optional reference
        print("\n2. COMPAS not importable: cross-check skipped")
        return
    print("\n2. cross-check with COMPAS Catmull-Clark on closed meshes (same rules)")
    print(f"{'mesh':12s} {'L':>2s} {'faces':>7s} {'max |Δv|':>10s} {'ours s':>8s} {'compas s':>9s} {'ratio':>7s}")
    sphere = subdivided_mesh(*_cube(), levels=2)[:2]
    for name, (V, F), levels in (("cube", _cube(), 4), ("pyramid", _pyramid(), 4), ("cube L2", sphere, 3)):
        t_ours, (V1, Q1, _) = _best(lambda: subdivided_mesh(V, F, levels=levels))
        faces = [list(dict.fromkeys(f)) for f in F.tolist()]
        m = Mesh.from_vertices_and_faces(V.tolist(), faces)
        t_c, sub = _best(lambda: m.subdivided("catmullclark", k=levels), 1)
        Vc = np.array([sub.vertex_coordinates(v) for v in sub.vertices()])
        # compare as point sets (vertex numbering differs)
        a = V1[np.lexsort(np.round(V1, 9).T)]
        b = Vc[np.lexsort(np.round(Vc, 9).T)]
        diff = np.abs(a - b).max() if a.shape == b.shape else float("nan")
        print(f"{name:12s} {levels:2d} {len(Q1):7d} {diff:10.2e} {t_ours:8.4f} {t_c:9.3f} {t_c / t_ours:7.0f}x")


def table_pull(quick: bool):
    import igl

    ref = SHARED / "libigl" / "inspired_mesh.obj"
    coarse = SHARED / "libigl" / "inspired_mesh_quads_Conjugate.off"
    if not (ref.exists() and coarse.exists()):
        print("\n3. shared meshes absent: pull table skipped")
        return
    Vr, Tr = read_mesh(ref)
    Vq, Fq = read_mesh(coarse)
    print("\n3. pulled_vertices onto inspired_mesh.obj (4,288 triangles) vs igl.point_mesh_squared_distance")
    print(f"{'candidate':22s} {'vertices':>9s} {'ours s':>8s} {'igl s':>8s} {'ratio':>6s} {'max |Δd|':>10s} "
          f"{'max after/diag':>15s}")
    diag = float(np.linalg.norm(Vr.max(0) - Vr.min(0)))
    for levels in (0, 1, 2) if quick else (0, 1, 2, 3):
        V, Q, _ = subdivided_mesh(Vq, Fq, levels=levels)
        t_ours, res = _best(lambda: pulled_vertices(V, Q, Vr, Tr, boundary="surface"))
        t_igl, (sq, _, _) = _best(lambda: igl.point_mesh_squared_distance(V, Vr, Tr))
        d = np.abs(res.distances_before - np.sqrt(sq)).max()
        print(f"{'conjugate quads L' + str(levels):22s} {len(V):9d} {t_ours:8.3f} {t_igl:8.3f} "
              f"{t_ours / t_igl:6.2f} {d:10.2e} {res.distances_after.max() / diag:15.2e}")


def table_strategy(quick: bool):
    import igl

    from components.core.mesh import bounding_box_diagonal
    from components.core.measures import quad_planarity as face_planarity
    from components.core.proximity import TriangleIndex
    from components.surfaces.samples import sample_mesh
    from components.subdivision.pipeline import subdivision_pq

    print("\n4. subdivision strategy (36 coarse faces, 2 levels), issue 8 targets: dist ≤ 1e-9·diag, "
          "planarity ≤ 1e-4, closeness ≤ 2% edge")
    print(f"{'surface':9s} {'layout':8s} {'quads':>6s} {'dist/diag':>9s} {'pl before':>9s} {'pl after':>9s} "
          f"{'close %':>7s} {'worst°':>6s} {'ncv':>4s} {'it':>3s} {'s':>5s}  {'igl pl':>8s} {'igl close %':>11s} "
          f"{'igl s':>6s}  stop")
    names = ["dome", "saddle", "wave", "canopy"]
    if (SHARED / "libigl" / "inspired_mesh.obj").exists():
        names.append("inspired")
    for name in names:
        if name == "inspired":
            V, T = read_mesh(SHARED / "libigl" / "inspired_mesh.obj")
        else:
            V, T, _ = sample_mesh(name, 20)
        diag = bounding_box_diagonal(V)
        for layout in ("auto",) if quick else ("auto", "ogrid", "aligned"):
            t = time.perf_counter()
            try:
                r = subdivision_pq(V, T, layout=layout)
            except ValueError as exc:
                print(f"{name:9s} {layout:8s} failed: {exc}")
                continue
            dt = time.perf_counter() - t
            p = r.planarized
            X, Q = r.candidate
            t = time.perf_counter()
            Y = igl.planarize_quad_mesh(X, Q, 50, 1e-4)
            ti = time.perf_counter() - t
            ipl = face_planarity(Y, Q).max()
            icl = TriangleIndex(V, T).query(Y).distances.mean() / r.mean_edge
            print(f"{name:9s} {r.layout:8s} {len(Q):6d} {r.candidate_distance.max() / diag:9.1e} "
                  f"{r.candidate_planarity.max():9.2e} {p.max_planarity:9.2e} {100 * p.mean_closeness / r.mean_edge:7.2f} "
                  f"{p.worst_corner_angle:6.1f} {p.nonconvex_faces:4d} {p.iterations:3d} {dt:5.1f}  {ipl:8.2e} "
                  f"{100 * icl:11.2f} {ti:6.2f}  {p.stop_reason}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smaller cases only")
    args = ap.parse_args()
    table_subdivision(args.quick)
    table_compas()
    table_pull(args.quick)
    table_strategy(args.quick)


if __name__ == "__main__":
    main()
