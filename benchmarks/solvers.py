"""Sparse factorizations of the conjugate pipeline: SuperLU as configured against sparse LDLᵀ / Cholesky (issue #21).

Issue #21 asks to evaluate a sparse Cholesky (``cholespy``, CHOLMOD with wheels on Windows, macOS and Linux)
against SuperLU on the pipeline's systems and to use the fastest with a fallback. This script captures the first
system of each family that ``pq_from_conjugate_field`` factors on benchmarks/fields.py's patch — the direction
field's Hermitian connection Laplacians (complex; given to CHOLMOD as their real ``2n × 2n`` embedding), the seamless
parametrization's symmetric system and the planarizer's face-sized SPD system ``J G Jᵀ`` — and times, on the same
matrix in the same run: SuperLU with the options the code uses (``splu``, symmetric minimum-degree ordering,
symmetric mode), then ``qdldl.Solver`` (sparse LDLᵀ) and ``cholespy.CholeskySolverD`` (analysis and factorization
happen together at construction in both), each best of ``--repeat`` in CPU seconds with one BLAS thread, plus one
solve each and the relative difference of each solution to SuperLU's.

Run from the project root::

    /work/venv/bin/python benchmarks/solvers.py                     # the 20k patch
    /work/venv/bin/python benchmarks/solvers.py --sizes 20000 200000

``qdldl`` (the LDLᵀ column; a core dependency since session 24) and ``cholespy`` (``pip install cholespy``) are
looked up at run time; a column whose solver is missing prints NaN.

Measured 2026-12 (2-core project machine, cholespy 2.1, CPU seconds, best of 3): SuperLU is faster than CHOLMOD on
every family. CHOLMOD's solves are faster on the real systems, but each factorization is solved only a few times.

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

Session 24 (another 2-core machine; ``qdldl`` 0.1.9, the LDLᵀ of OSQP's authors: approximate minimum degree, no
pivoting, up-looking, not supernodal), this script, CPU seconds, factorization / solve:

| system | 20k: SuperLU / LDLᵀ / CHOLMOD | 200k: SuperLU / LDLᵀ / CHOLMOD |
|---|---|---|
| direction field (complex; real 2n embedding for the last two) | 0.061 / 0.072 / 0.124 s | 1.38 / 4.23 / 3.24 s |
| parametrization | 0.066 / 0.030 / 0.087 s | 1.51 / 1.67 / 1.71 s |
| planarizer J G Jᵀ (1.4k / 12.5k rows) | 2.5 / 1.9 / 3.8 ms; solve 0.072 / 0.047 / 0.038 ms | 32 / 27 / 58 ms; solve 0.89 / 0.74 / 0.43 ms |

On the planarizer's systems LDLᵀ is the fastest factorization (0.76-0.84× SuperLU's here; 0.6-0.85× on the 20
systems of one 200k planarization) and its solves are faster than SuperLU's, so
:func:`components.planarize.step.factor_spd` uses it (SuperLU stays the fallback where ``qdldl`` is missing). The
200k benchmark candidate planarized with each, one after the other (three pairs): 10.6-12.8 s → 9.0-9.8 s, the same
32 iterations and result (planarity 9.2716e-5 in both, the same closeness to 7 digits); the 20k one 0.80-1.02 s →
0.70-0.75 s, 12 iterations, the same result. The field and the parametrization keep SuperLU: supernodal, it is
faster where the fill is large (the 200k rows).
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


def _embedded(A: sp.csc_matrix, b: np.ndarray):
    """A Hermitian system as its real symmetric embedding ``[[Re, −Im], [Im, Re]]`` (a real one as it is)."""
    if np.iscomplexobj(A):
        return sp.bmat([[A.real, -A.imag], [A.imag, A.real]]).tocsc(), np.concatenate([b.real, b.imag])
    return A.tocsc(), b


def _embedded_back(y: np.ndarray, n: int, complex_: bool) -> np.ndarray:
    return y[:n] + 1j * y[n:] if complex_ else y


def _difference(x: np.ndarray, y: np.ndarray) -> float:
    """The largest difference of two solutions relative to the largest entry of the first."""
    return float(np.abs(x - y).max() / np.abs(x).max())


def _time_family(A: sp.csc_matrix, kwargs: dict, repeat: int) -> tuple:
    """``(SuperLU factor s, solve s, LDLᵀ factor s, solve s, CHOLMOD factor s, solve s, LDLᵀ / CHOLMOD relative
    difference to SuperLU)``, NaN for a solver that is not installed."""
    from scipy.sparse.linalg import splu

    from components.core.blas import single_blas_thread

    rng = np.random.default_rng(0)
    b = rng.standard_normal(A.shape[0]) + (1j * rng.standard_normal(A.shape[0]) if np.iscomplexobj(A) else 0.0)
    R, rb = _embedded(A, b)
    missing = (np.nan,) * 3  # a solver that is not installed: factor s, solve s, difference
    with single_blas_thread():
        t_lu, lu = _cpu_best(lambda: splu(A, **kwargs), repeat)
        t_lus, x = _cpu_best(lambda: lu.solve(b), repeat)
        out = [t_lu, t_lus]
        try:
            import qdldl
        except ImportError:
            out += missing
        else:
            t_q, q = _cpu_best(lambda: qdldl.Solver(R), repeat)
            t_qs, y = _cpu_best(lambda: q.solve(rb), repeat)
            y = _embedded_back(y, A.shape[0], np.iscomplexobj(A))
            out += [t_q, t_qs, _difference(x, y)]
        try:
            from cholespy import CholeskySolverD, MatrixType
        except ImportError:
            return (*out, *missing)
        C = R.tocoo()
        rows, cols = C.row.astype(np.int32), C.col.astype(np.int32)
        t_ch, ch = _cpu_best(lambda: CholeskySolverD(C.shape[0], rows, cols, C.data, MatrixType.COO), repeat)
        y = np.zeros_like(rb)
        t_chs, _ = _cpu_best(lambda: ch.solve(rb, y), repeat)
    y = _embedded_back(y, A.shape[0], np.iscomplexobj(A))
    return (*out, t_ch, t_chs, _difference(x, y))


def _run(size: int, repeat: int) -> list:
    return [(family, A.shape[0], A.nnz, *_time_family(A, kw, repeat)) for family, (A, kw) in _capture(size).items()]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[20_000])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"{'system':28s} {'input':10s} {'rows':>7s} {'nnz':>9s} {'SuperLU s':>10s} {'solve ms':>9s} "
          f"{'LDLT s':>8s} {'solve ms':>9s} {'ratio':>6s} {'rel diff':>9s} "
          f"{'CHOLMOD s':>10s} {'solve ms':>9s} {'ratio':>6s} {'rel diff':>9s}")
    for size in args.sizes:
        rows = run_forked(_run, size, args.repeat, failed=[])
        for family, n, nnz, t_lu, t_lus, t_q, t_qs, d_q, t_ch, t_chs, d_ch in rows:
            print(f"{family:28s} {f'patch {size // 1000}k':10s} {n:7d} {nnz:9d} {t_lu:10.4f} {1e3 * t_lus:9.3f} "
                  f"{t_q:8.4f} {1e3 * t_qs:9.3f} {t_q / t_lu:6.2f} {d_q:9.1e} "
                  f"{t_ch:10.4f} {1e3 * t_chs:9.3f} {t_ch / t_lu:6.2f} {d_ch:9.1e}", flush=True)


if __name__ == "__main__":
    main()
