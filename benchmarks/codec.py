"""Benchmark: numpy openNURBS mesh codec (``ghserver._onmesh``) against rhino3dm.

Run ``python benchmarks/codec.py``.  For a wavy quad grid and a random
triangle soup of about 10k and 100k vertices it prints the median time of:

* ``Encode`` / ``Decode``: rhino3dm's own ``Mesh.Encode()`` and
  ``CommonObject.Decode()`` calls (C++),
* ``slow write``: the pure rhino3dm path, a Python loop building the Mesh
  (``AddPoint3d``/``AddFace``) plus ``Encode`` plus ``json.dumps``,
* ``slow read``: ``json.loads`` plus ``Decode`` plus reading the vertices and
  faces back through rhino3dm objects,
* ``ours write``: ``write_mesh`` plus ``json.dumps``,
* ``ours read``: ``json.loads`` plus ``read_mesh``,

and the ratios *overhead beyond rhino3dm's call / rhino3dm's call*: for the
slow path the Python loops and JSON (``slow - Encode``, ``slow - Decode``);
for our path everything it does (it makes no rhino3dm call), divided by
rhino3dm's ``Encode`` or ``Decode`` time respectively.

A second table does the same for a coloured, unwelded display mesh of about
100k vertices (every triangle of a wavy grid with its own three vertices and
an RGB colour per vertex): rhino3dm's path adds a ``VertexColors.Add`` loop
(and reads the colours back item by item), ours passes ``colors=`` to
``write_mesh`` and reads with ``read_mesh_colors``.

A third table times polygon panels: pentagon grids of about 10k and 100k faces written by ``encode_mesh`` (each
pentagon as its triangle fan grouped into a Rhino n-gon) and read back by ``decode_mesh`` as pentagons, beside
rhino3dm's ``Decode`` / ``Encode`` of the same archive (which keep the n-gons). Measured 2026-12 (2-core machine):
99k pentagons written in 179 ms and read in 391 ms, where rhino3dm's Decode takes 543 ms and its Encode 1102 ms.
"""
from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import rhino3dm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ghserver.convert import arrays_to_mesh, mesh_to_arrays  # noqa: E402
from ghserver._onmesh import read_mesh, read_mesh_colors, write_mesh  # noqa: E402

REPEATS = 9
SLOW_REPEATS = 3


def wavy_grid(n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Quad grid of about ``n_vertices`` vertices on a wavy surface, coordinates ~5e4."""
    k = int(round(np.sqrt(n_vertices)))
    u, v = np.meshgrid(np.linspace(0.0, 1.0, k), np.linspace(0.0, 1.0, k), indexing="ij")
    V = np.stack([5e4 + 1e3 * u, 5e4 + 1e3 * v, 20.0 * np.sin(7 * u) * np.cos(5 * v)], axis=-1).reshape(-1, 3)
    idx = np.arange(k * k).reshape(k, k)
    F = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
    return V, F


def triangle_soup(n_vertices: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Random triangles, each with its own three random vertices (shuffled order)."""
    rng = np.random.default_rng(seed)
    m = n_vertices // 3
    V = rng.uniform(-5e4, 5e4, size=(3 * m, 3))
    T = rng.permutation(3 * m).reshape(m, 3)
    return V, np.concatenate([T, T[:, 2:3]], axis=1)


def unwelded_display_mesh(n_vertices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wavy grid split into triangles that do not share vertices, coloured by height (RGB uint8)."""
    Vg, Q = wavy_grid(int((np.sqrt(n_vertices / 6) + 1) ** 2))  # 2 triangles = 6 vertices per quad
    T = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]])
    V = Vg[T.reshape(-1)]
    m = len(T)
    F = np.arange(3 * m).reshape(m, 3)
    F = np.concatenate([F, F[:, 2:3]], axis=1)
    t = (V[:, 2] - V[:, 2].min()) / np.ptp(V[:, 2])
    C = np.stack([255 * t, 255 * (1 - np.abs(2 * t - 1)), 255 * (1 - t)], axis=-1).round().astype(np.uint8)
    return V, F, C


def build_slow(V: np.ndarray, F: np.ndarray, C: np.ndarray | None = None) -> rhino3dm.Mesh:
    """rhino3dm Mesh built vertex by vertex (double precision), optionally with vertex colours: the server's
    fallback path (:func:`ghserver.convert.arrays_to_mesh`)."""
    return arrays_to_mesh(V, F, C)


def read_slow(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces read back through rhino3dm objects (:func:`ghserver.convert.mesh_to_arrays`)."""
    return mesh_to_arrays(mesh)


def read_slow_colors(mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, faces and RGBA vertex colours read back through rhino3dm objects."""
    V, F = read_slow(mesh)
    vc = mesh.VertexColors
    C = np.array([vc[i] for i in range(len(vc))], dtype=np.uint8)
    return V, F, C


def median_times(fns: dict, repeats: int) -> dict:
    """Median wall time of each callable; runs are interleaved so that load
    from other processes affects every entry alike."""
    times: dict = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: statistics.median(ts) for name, ts in times.items()}


def bench(name: str, V: np.ndarray, F: np.ndarray) -> dict:
    mesh = build_slow(V, F)
    encoded = mesh.Encode()
    text_rh = json.dumps(encoded)
    ours = write_mesh(V, F)
    text_ours = json.dumps(ours)

    # correctness guard: both paths agree exactly
    Vr, Fr = read_slow(rhino3dm.CommonObject.Decode(ours))
    Vo, Fo = read_mesh(json.loads(text_rh))
    assert np.array_equal(Vr, V) and np.array_equal(Fr, F)
    assert np.array_equal(Vo, V) and np.array_equal(Fo, F)

    row = {"name": name, "nv": len(V), "nf": len(F)}
    row.update(median_times({
        "encode": mesh.Encode,
        "decode": lambda: rhino3dm.CommonObject.Decode(encoded),
        "ours_write": lambda: json.dumps(write_mesh(V, F)),
        "ours_read": lambda: read_mesh(json.loads(text_ours)),
        "ours_read_rh": lambda: read_mesh(json.loads(text_rh)),
        "ours_write_z1": lambda: json.dumps(write_mesh(V, F, compress_level=1)),
    }, REPEATS))
    row.update(median_times({
        "slow_write": lambda: json.dumps(build_slow(V, F).Encode()),
        "slow_read": lambda: read_slow(rhino3dm.CommonObject.Decode(json.loads(text_rh))),
    }, SLOW_REPEATS))
    row["kb_rh"] = len(text_rh) / 1024
    row["kb_ours"] = len(text_ours) / 1024
    return row


def bench_colors(name: str, V: np.ndarray, F: np.ndarray, C: np.ndarray) -> dict:
    mesh = build_slow(V, F, C)
    encoded = mesh.Encode()
    text_rh = json.dumps(encoded)
    text_ours = json.dumps(write_mesh(V, F, C))
    C4 = np.concatenate([C, np.full((len(C), 1), 255, np.uint8)], axis=1)

    # correctness guard: byte identity at rhino3dm's level, exact colours both ways
    assert write_mesh(V, F, C, compress_level=9)["data"] == encoded["data"]
    Vr, Fr, Cr = read_slow_colors(rhino3dm.CommonObject.Decode(json.loads(text_ours)))
    assert np.array_equal(Vr, V) and np.array_equal(Fr, F) and np.array_equal(Cr, C4)
    Vo, Fo, Co = read_mesh_colors(json.loads(text_rh))
    assert np.array_equal(Vo, V) and np.array_equal(Fo, F) and np.array_equal(Co, C4)

    def color_loop():
        m = rhino3dm.Mesh()
        addc = m.VertexColors.Add
        for r, g, b in C.tolist():
            addc(r, g, b)

    row = {"name": name, "nv": len(V), "nf": len(F)}
    row.update(median_times({
        "encode": mesh.Encode,
        "decode": lambda: rhino3dm.CommonObject.Decode(encoded),
        "ours_write": lambda: json.dumps(write_mesh(V, F, C)),
        "ours_write_z9": lambda: json.dumps(write_mesh(V, F, C, compress_level=9)),
        "ours_read": lambda: read_mesh_colors(json.loads(text_ours)),
        "ours_read_rh": lambda: read_mesh_colors(json.loads(text_rh)),
    }, REPEATS))
    row.update(median_times({
        "color_loop": color_loop,
        "slow_write": lambda: json.dumps(build_slow(V, F, C).Encode()),
        "slow_read": lambda: read_slow_colors(rhino3dm.CommonObject.Decode(json.loads(text_rh))),
    }, SLOW_REPEATS))
    row["kb_rh"] = len(text_rh) / 1024
    row["kb_ours"] = len(text_ours) / 1024
    return row


def main() -> None:
    rows = []
    for n in (10_000, 100_000):
        rows.append(bench("wavy quad grid", *wavy_grid(n)))
        rows.append(bench("triangle soup", *triangle_soup(n)))
    ms = 1e3
    print(f"median of {REPEATS} interleaved runs (slow paths: {SLOW_REPEATS}), times in ms\n")
    head = (f"{'mesh':<15} {'verts':>6} {'faces':>6} | {'Encode':>6} {'Decode':>6} | {'slow wr':>7} {'slow rd':>7} | "
            f"{'ours wr':>7} {'ours rd':>7} {'rd(rh)':>6} {'wr z1':>6} | {'slow/Enc':>8} {'slow/Dec':>8} | "
            f"{'wr/Enc':>6} {'rd/Dec':>6} {'rd(rh)/Dec':>10} | {'KB rh':>5} {'KB ours':>7}")
    print(head)
    print("-" * len(head))
    for r in rows:
        enc, dec = r["encode"], r["decode"]
        print(f"{r['name']:<15} {r['nv']:>6} {r['nf']:>6} | {enc * ms:6.1f} {dec * ms:6.1f} | "
              f"{r['slow_write'] * ms:7.1f} {r['slow_read'] * ms:7.1f} | {r['ours_write'] * ms:7.1f} "
              f"{r['ours_read'] * ms:7.1f} {r['ours_read_rh'] * ms:6.1f} {r['ours_write_z1'] * ms:6.1f} | "
              f"{(r['slow_write'] - enc) / enc:8.2f} {(r['slow_read'] - dec) / dec:8.2f} | "
              f"{r['ours_write'] / enc:6.3f} {r['ours_read'] / dec:6.3f} {r['ours_read_rh'] / dec:10.3f} | "
              f"{r['kb_rh']:5.0f} {r['kb_ours']:7.0f}")
    print("""
Encode/Decode   rhino3dm's own Mesh.Encode() / CommonObject.Decode() calls
slow wr/rd      pure rhino3dm: Python loop building the Mesh + Encode + json.dumps /
                json.loads + Decode + Python loop reading vertices and faces
ours wr/rd      write_mesh (uncompressed buffers) + json.dumps / json.loads + read_mesh of that output
rd(rh)          json.loads + read_mesh of rhino3dm's compressed output (what Rhino/Hops sends)
wr z1           write_mesh(compress_level=1) + json.dumps, for comparison
slow/Enc, /Dec  overhead of the slow path beyond rhino3dm's call, relative to that call
wr/Enc, rd/Dec  our whole path (it makes no rhino3dm call, JSON included) relative to rhino3dm's call""")

    r = bench_colors("unwelded+RGB", *unwelded_display_mesh(100_000))
    enc, dec = r["encode"], r["decode"]
    print("\nvertex colours (RGB per vertex), times in ms\n")
    head = (f"{'mesh':<15} {'verts':>6} {'faces':>6} | {'Encode':>6} {'Decode':>6} | {'Add loop':>8} "
            f"{'slow wr':>7} {'slow rd':>7} | {'ours wr':>7} {'wr z9':>6} {'ours rd':>7} {'rd(rh)':>6} | "
            f"{'slow/Enc':>8} {'slow/Dec':>8} | {'wr/Enc':>6} {'rd/Dec':>6} {'rd(rh)/Dec':>10} | "
            f"{'KB rh':>5} {'KB ours':>7}")
    print(head)
    print("-" * len(head))
    print(f"{r['name']:<15} {r['nv']:>6} {r['nf']:>6} | {enc * ms:6.1f} {dec * ms:6.1f} | {r['color_loop'] * ms:8.1f} "
          f"{r['slow_write'] * ms:7.1f} {r['slow_read'] * ms:7.1f} | {r['ours_write'] * ms:7.1f} "
          f"{r['ours_write_z9'] * ms:6.1f} {r['ours_read'] * ms:7.1f} {r['ours_read_rh'] * ms:6.1f} | "
          f"{(r['slow_write'] - enc) / enc:8.2f} {(r['slow_read'] - dec) / dec:8.2f} | "
          f"{r['ours_write'] / enc:6.3f} {r['ours_read'] / dec:6.3f} {r['ours_read_rh'] / dec:10.3f} | "
          f"{r['kb_rh']:5.0f} {r['kb_ours']:7.0f}")
    print("""
Add loop        the VertexColors.Add(r, g, b) loop alone (part of slow wr)
slow wr/rd      as above, plus the VertexColors.Add loop / reading mesh.VertexColors[i] item by item
ours wr, wr z9  write_mesh(V, F, colors) + json.dumps, uncompressed / compress_level=9 (rhino3dm's bytes)
ours rd, rd(rh) json.loads + read_mesh_colors of our uncompressed / rhino3dm's compressed output""")
    polygon_table()


def pentagon_grid(n_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """A wavy quad grid whose every quad gets a fifth corner in the middle of its first edge: pentagons only."""
    V, F = wavy_grid(n_faces)
    mid = 0.5 * (V[F[:, 0]] + V[F[:, 1]])
    P = np.stack([F[:, 0], len(V) + np.arange(len(F)), F[:, 1], F[:, 2], F[:, 3]], axis=1)
    return np.vstack([V, mid]), P


def polygon_table() -> None:
    """Polygon panels (the curvature network's pentagons) as Rhino n-gons: ``encode_mesh`` writes each one's
    triangle fan and the n-gon that groups it, ``decode_mesh`` gives the polygon back (rhino3dm has no n-gon API:
    only its Decode / Encode of our archive, which keeps the n-gons, are timed beside)."""
    from ghserver.convert import decode_mesh, encode_mesh

    ms = 1e3
    print("\npolygon faces (pentagons as n-gons of triangle fans), times in ms\n")
    head = f"{'mesh':<15} {'verts':>6} {'faces':>6} | {'ours wr':>7} {'ours rd':>7} | {'Decode':>6} {'Encode':>6} | exact"
    print(head)
    print("-" * len(head))
    for n in (10_000, 100_000):
        V, P = pentagon_grid(n)
        text = encode_mesh(V, P)
        blob = json.loads(text)
        mesh = rhino3dm.CommonObject.Decode(blob)
        t = median_times({"wr": lambda: encode_mesh(V, P), "rd": lambda: decode_mesh(text),
                          "Decode": lambda: rhino3dm.CommonObject.Decode(blob), "Encode": lambda: mesh.Encode()},
                         REPEATS)
        V2, P2 = decode_mesh(text)
        exact = np.array_equal(V2, V) and np.array_equal(P2, P)
        print(f"{'pentagons':<15} {len(V):>6} {len(P):>6} | {t['wr'] * ms:7.1f} {t['rd'] * ms:7.1f} | "
              f"{t['Decode'] * ms:6.1f} {t['Encode'] * ms:6.1f} | {exact}")


if __name__ == "__main__":
    main()
