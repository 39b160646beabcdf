"""Time every step of the field pipeline (issue 6) on 10k, 50k and 200k-triangle inputs beside libigl / gpytoolbox.

Run from the project root::

    /work/venv/bin/python benchmarks/fields.py                 # all steps, all sizes
    /work/venv/bin/python benchmarks/fields.py --steps remesh --sizes 10000 50000
    /work/venv/bin/python benchmarks/fields.py --real          # also the shared 52k-triangle face scan

Each step is a :class:`Step` in :data:`STEPS`: a name, our function and, where a reference library has the step,
the reference function, both taking ``(V, T)`` of the input. To add a later field step, append a ``Step`` (keep the
functions module-level so the table stays a list). The table prints seconds (best of ``--repeat`` runs) and the
ratio ours / reference (below 1 = faster than the reference).

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

from components.core.curvature import gaussian_curvature, vertex_principal_curvature  # noqa: E402
from components.core.mesh import edge_topology, read_mesh, remove_unreferenced  # noqa: E402
from components.fields.remesh import isotropic_remesh  # noqa: E402


class Step(NamedTuple):
    name: str
    ours: Callable
    reference: Callable | None = None
    reference_name: str = ""
    repeat: int | None = None  # override of --repeat for slow steps


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


STEPS += [
    Step("field + seamless parametrization (L=2.5e)", parametrize_ours, repeat=1),
    Step("candidate: field+param+extract (L=2.5e)", candidate_ours, repeat=1),
    Step("pq_from_conjugate_field end-to-end", pq_end_to_end_ours, repeat=1),
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
    """The smooth-field system factored as components.fields.field does (MMD on AᵀA pattern, no pivoting)."""
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
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn(V, T)
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 50_000, 200_000])
    ap.add_argument("--steps", nargs="*", default=None, help="substrings of step names to run")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--real", action="store_true", help="also time the shared face scan (52k triangles)")
    args = ap.parse_args(argv)
    inputs = [(f"patch {s // 1000}k", *patch(s)) for s in args.sizes]
    if args.real:
        path = ROOT.parent / "shared" / "data" / "meshes" / "libigl" / "face.obj"
        if path.exists():
            inputs.append(("face.obj", *read_mesh(path)))
    steps = [s for s in STEPS if not args.steps or any(k in s.name for k in args.steps)]
    print(f"{'step':42s} {'input':12s} {'tris':>8s} {'ours s':>9s} {'ref s':>9s} {'ratio':>6s}  reference")
    for step in steps:
        for label, V, T in inputs:
            repeat = step.repeat or args.repeat
            ours = _best(step.ours, V, T, repeat)
            ref = _best(step.reference, V, T, repeat) if step.reference else float("nan")
            ratio = ours / ref if step.reference else float("nan")
            print(f"{step.name:42s} {label:12s} {len(T):8d} {ours:9.3f} {ref:9.3f} {ratio:6.2f}  "
                  f"{step.reference_name or '-'}", flush=True)


if __name__ == "__main__":
    main()
