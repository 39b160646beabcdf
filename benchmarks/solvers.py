"""Sparse factorizations of the conjugate pipeline: SuperLU as configured against a sparse Cholesky (issue #21).

Issue #21 asks to evaluate a sparse Cholesky (``cholespy``, CHOLMOD with wheels on Windows, macOS and Linux)
against SuperLU on the pipeline's systems and to use the fastest with a fallback. This script captures the first
system of each family that ``pq_from_conjugate_field`` factors on benchmarks/fields.py's patch — the direction
field's Hermitian connection Laplacians (complex; given to CHOLMOD as their real ``2n × 2n`` embedding), the seamless
parametrization's symmetric system and the planarizer's face-sized SPD system ``J G Jᵀ`` — and times, on the same
matrix in the same run: SuperLU with the options the code uses (``splu``, symmetric minimum-degree ordering,
symmetric mode), then ``cholespy.CholeskySolverD`` (analysis and factorization happen together at construction),
each best of ``--repeat`` in CPU seconds with one BLAS thread, plus one solve each and the relative difference of
the two solutions.

Run from the project root::

    /work/venv/bin/python benchmarks/solvers.py                     # the 20k patch
    /work/venv/bin/python benchmarks/solvers.py --sizes 20000 200000

``cholespy`` is optional (``pip install cholespy``); without it only SuperLU's column is printed.

Measured 2026-12 (2-core project machine, cholespy 2.1, CPU seconds, best of 3): SuperLU is faster on every
family, so the code keeps it (there is no faster solver to make optional). CHOLMOD's solves are faster on the real
systems, but each factorization is solved only a few times.

| system | 20k: SuperLU / CHOLMOD s | 200k: SuperLU / CHOLMOD s |
|---|---|---|
| direction field (complex, 20k / 200k rows) | 0.041 / 0.122 | 1.02 / 2.95 |
| parametrization (20k / 200k rows) | 0.047 / 0.087 | 1.21 / 1.60 |
| planarizer J G Jᵀ (1.4k / 12.5k rows) | 0.0023 / 0.0040 | 0.034 / 0.060 |

Session 14 (another 2-core machine, by hand on the 200k patch's captured systems, CPU seconds of one thread; not
in this script, whose columns stay SuperLU and CHOLMOD): the field's complex system (200,677 rows, 9.5M entries in
SuperLU's L + U) takes SuperLU 1.31-1.52 s per factorization and 40 ms per solve. MKL PARDISO through
``pypardiso`` (its real ``2n`` embedding, symmetric positive definite): 1.00 s, but 108 ms per solve (71 ms on two
threads), and MKL is a 229 MB wheel with none for macOS on ARM. The same system in single precision (complex64):
1.16-1.27 s, the same 40 ms solves. With a nested-dissection order instead of the minimum-degree one, SuperLU takes
1.02 s (METIS through ``pymetis``, whose ordering itself takes 0.97 s; fill 8.75M) or 1.06 s (a recursive
coordinate bisection of the face centroids, 0.5 s to order); the solves stay at 41-47 ms. The planarizer's systems
(12.5-14.5k rows): 34-43 ms with the minimum-degree order, 21-27 ms with METIS's (64-85 ms to order). Reusing the
minimum-degree order of a first factorization for the next ones with the same pattern saves its 0.17-0.3 s. None
of these halves the field's linear algebra (6 factorizations and about 120 solves at 200k): what would is fewer of
them, and the field's local-global iterations do not converge (their mean change stays 0.14-0.2° per iteration
from the 20th on), so fewer iterations give other candidates, not cheaper ones: 20 or 30 instead of 40 on 21
patches gave no faster pipeline on the whole (the field 15-30 % faster, the planarization as often slower) and a
mean field angle error 0.1-0.8° larger.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from fields import _mean_edge, patch  # noqa: E402
from forked import best_of, run_forked  # noqa: E402


def _capture(size: int) -> dict:
    """Run the pipeline on the patch and keep the first system of each family: ``{family: (matrix, splu kwargs)}``."""
    import components.fields.field as field
    import components.fields.parametrize as parametrize
    import components.planarize.step as step
    from components.fields.pipeline import pq_from_conjugate_field

    got: dict = {}

    def wrap(module, attr: str, family: str, kwargs=None):
        original = getattr(module, attr)

        def captured(A, *args, **kw):
            if family not in got:
                got[family] = (sp.csc_matrix(A).copy(), kwargs if kwargs is not None else kw)
            return original(A, *args, **kw)

        setattr(module, attr, captured)

    wrap(field, "splu", "direction field (complex)")
    wrap(parametrize, "splu", "parametrization")
    wrap(step, "factor_spd", "planarizer J G Jᵀ", dict(permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                                       options=dict(SymmetricMode=True)))
    V, T = patch(size)
    pq_from_conjugate_field((V, T), 2.5 * _mean_edge(V, T), time_budget=30.0)
    return got


def _cpu_best(fn, repeat: int):
    return best_of(fn, repeat, clock=time.process_time)


def _time_family(A: sp.csc_matrix, kwargs: dict, repeat: int) -> tuple:
    """``(SuperLU factor s, solve s, CHOLMOD factor s, solve s, relative difference)``, NaN without cholespy."""
    from scipy.sparse.linalg import splu

    from components.core.blas import single_blas_thread

    rng = np.random.default_rng(0)
    b = rng.standard_normal(A.shape[0]) + (1j * rng.standard_normal(A.shape[0]) if np.iscomplexobj(A) else 0.0)
    with single_blas_thread():
        t_lu, lu = _cpu_best(lambda: splu(A, **kwargs), repeat)
        t_lus, x = _cpu_best(lambda: lu.solve(b), repeat)
        try:
            from cholespy import CholeskySolverD, MatrixType
        except ImportError:
            return t_lu, t_lus, np.nan, np.nan, np.nan
        if np.iscomplexobj(A):  # Hermitian: the real symmetric embedding [[Re, −Im], [Im, Re]]
            R, rb = sp.bmat([[A.real, -A.imag], [A.imag, A.real]]).tocoo(), np.concatenate([b.real, b.imag])
        else:
            R, rb = A.tocoo(), b
        rows, cols = R.row.astype(np.int32), R.col.astype(np.int32)
        t_ch, ch = _cpu_best(lambda: CholeskySolverD(R.shape[0], rows, cols, R.data, MatrixType.COO), repeat)
        y = np.zeros_like(rb)
        t_chs, _ = _cpu_best(lambda: ch.solve(rb, y), repeat)
    if np.iscomplexobj(A):
        y = y[: A.shape[0]] + 1j * y[A.shape[0]:]
    return t_lu, t_lus, t_ch, t_chs, float(np.abs(x - y).max() / np.abs(x).max())


def _run(size: int, repeat: int) -> list:
    return [(family, A.shape[0], A.nnz, *_time_family(A, kw, repeat)) for family, (A, kw) in _capture(size).items()]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[20_000])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"{'system':28s} {'input':10s} {'rows':>7s} {'nnz':>9s} {'SuperLU s':>10s} {'solve ms':>9s} "
          f"{'CHOLMOD s':>10s} {'solve ms':>9s} {'ratio':>6s} {'rel diff':>9s}")
    for size in args.sizes:
        rows = run_forked(_run, size, args.repeat, failed=[])
        for family, n, nnz, t_lu, t_lus, t_ch, t_chs, diff in rows:
            print(f"{family:28s} {f'patch {size // 1000}k':10s} {n:7d} {nnz:9d} {t_lu:10.4f} {1e3 * t_lus:9.3f} "
                  f"{t_ch:10.4f} {1e3 * t_chs:9.3f} {t_ch / t_lu:6.2f} {diff:9.1e}", flush=True)


if __name__ == "__main__":
    main()
