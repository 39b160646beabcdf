"""The optional compiled kernels (numba: the conjugate field's local step, the closest-point scan, the network
healing's diagonal tests) give the numpy / Python code's results bit for bit, and step aside when disabled."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import components.core.proximity as proximity
import components.fields.field as field_module
import components.network.healing as healing
from components.core import memo
from components.core.proximity import TriangleIndex
from components.fields import conjugate_kernels as kernels
from components.fields.field import _block, _closest_conjugate, _local_step, _search_numpy
from tests.components.test_fields import _grid_triangles, _local_inputs

ROOT = Path(__file__).resolve().parents[2]
needs_numba = pytest.mark.skipif(kernels.search is None, reason="numba is not installed (the numpy code runs)")


def _both(monkeypatch, fn):
    """``fn()`` with the kernels, then with the numpy code."""
    compiled = fn()
    with monkeypatch.context() as m:
        m.setattr(kernels, "search", None)
        m.setattr(kernels, "swaps", None)
        plain = fn()
    return compiled, plain


def _same(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


@needs_numba
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_local_step_is_the_numpy_one_bit_for_bit(monkeypatch, seed):
    # random pairs and curvatures with flat, parabolic, umbilic and minimal faces and boundary tangents; cold, warm
    # from random angles and warm from its own optimum (where the three first samples tie: the numpy rules settle)
    u, v, p, k1, k2, tau = _local_inputs(5000, seed)
    for t in (tau, None):
        ls = _local_step(p, k1, k2, np.radians(25.0), t)
        cold = _both(monkeypatch, lambda: _closest_conjugate(u, v, ls))
        start = np.random.default_rng(seed + 10).uniform(0, np.pi, len(u))
        warm = _both(monkeypatch, lambda: _closest_conjugate(u, v, ls, start=start))
        pu, pv, a = cold[0]
        own = _both(monkeypatch, lambda: _closest_conjugate(pu, pv, ls, start=a))
        for compiled, plain in (cold, warm, own):
            for x, y in zip(compiled, plain):
                assert _same(x, y)


@needs_numba
def test_ties_and_nan_are_settled_by_the_numpy_rules(monkeypatch):
    u, v, p, k1, k2, tau = _local_inputs(2000, 3)
    ls = _local_step(p, k1, k2, np.radians(25.0), tau)
    bad = u.copy()
    bad[:7] = np.nan  # NaN costs: np.argmin's rule
    for x, y in zip(*_both(monkeypatch, lambda: _closest_conjugate(bad, v, ls))):
        assert _same(x, y)
    pu, pv, a = _closest_conjugate(u, v, ls)
    zu, zv = pu * np.conj(ls.p), pv * np.conj(ls.p)  # a conjugate pair and its own angle: three equal first samples
    blk = _block(ls, 0, len(u), zu * zu, zv * zv)
    start = np.round(a / field_module._ROUND) * field_module._ROUND
    b, flag = kernels.search(blk.k1, blk.k2, blk.ar, blk.ai, blk.br, blk.bi, blk.smin, blk.const, blk.tf, blk.tr,
                             blk.ti, blk.tw, *field_module._first_samples(zu, zv, start)[:3],
                             *field_module._level_offsets(np.pi / 90.0, 2), field_module._TIE)
    assert flag.mean() > 0.9  # nearly every face ties: the numpy search decides them
    got, ref = field_module._search(blk, zu, zv, start), _search_numpy(blk, zu, zv, start)
    assert _same(got[0], ref[0]) and _same(got[1], ref[1])


@needs_numba
def test_the_conjugate_field_is_the_same_with_and_without_kernels(monkeypatch):
    V, T = _grid_triangles(24, 18, 3.0, 2.0, height=lambda x, y: 0.3 * x * x - 0.2 * y * y + 0.1 * x * y,
                           jitter=0.2, seed=4)
    s = field_module.smooth_frame_field(V, T)
    cons = (np.array([3, 40]), np.array([[1.0, 0.2, 0.0], [0.3, 1.0, 0.0]]))
    for kw in ({}, {"constraints": cons}, {"align_boundary": False, "release_angle": None}):
        compiled, plain = _both(monkeypatch, lambda: field_module.conjugate_frame_field(V, T, s.U, s.W, **kw))
        assert _same(compiled.U, plain.U) and _same(compiled.W, plain.W)
        assert _same(compiled.released, plain.released)


@needs_numba
def test_a_kernel_that_cannot_be_cached_is_compiled_all_the_same(monkeypatch):
    import numba

    from components.core.compiled import kernel

    real = numba.njit

    def njit(*args, cache=False, **kw):  # numba without a writable cache directory
        if cache:
            raise RuntimeError("cannot cache function 'twice': no locator available")
        return real(*args, cache=False, **kw)

    monkeypatch.setattr(numba, "njit", njit)

    @kernel("float64(float64)")
    def twice(x):
        return 2.0 * x

    assert twice is not None and twice(1.5) == 3.0


def test_kernels_step_aside_when_disabled():
    env = {**os.environ, "GHSERVER_COMPILED": "0", "PYTHONPATH": str(ROOT)}
    code = ("from components.core.compiled import available; from components.fields import conjugate_kernels as k; "
            "print(available(), k.search is None, k.swaps is None)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "True", "True"]


@pytest.mark.skipif(proximity._scan_compiled is None, reason="numba is not installed (the numpy code runs)")
def test_the_compiled_closest_point_scan_is_the_numpy_one_bit_for_bit(monkeypatch):
    # near and far points (far ones search the coarser grids), points on vertices and edges (ties between
    # triangles: the first listed wins either way), a mesh with degenerate triangles
    V, T = _grid_triangles(30, 20, 3.0, 2.0, height=lambda x, y: 0.3 * np.sin(2 * x) * y, jitter=0.3, seed=5)
    T = np.concatenate([T, [[0, 1, 1], [5, 5, 5]]])
    rng = np.random.default_rng(0)
    P = np.concatenate([V[rng.integers(0, len(V), 3000)] + rng.normal(scale=0.05, size=(3000, 3)), V[:200],
                        0.5 * (V[T[:200, 0]] + V[T[:200, 1]]), rng.uniform(-8, 8, size=(300, 3))])

    def run():
        memo.clear_all()  # a new index (the grids are kept per mesh)
        index = TriangleIndex(V, T)
        r = index.query(P)
        return r.points, r.distances, r.faces, r.barycentric, index.within(P, 0.02)

    compiled, plain = _both_scans(monkeypatch, run)
    for x, y in zip(compiled, plain):
        assert _same(x, y)


def _both_scans(monkeypatch, fn):
    compiled = fn()
    with monkeypatch.context() as m:
        m.setattr(proximity, "_scan_compiled", None)
        plain = fn()
    memo.clear_all()
    return compiled, plain


@pytest.mark.skipif(healing._diagonals_compiled is None, reason="numba is not installed (the Python test runs)")
def test_the_compiled_diagonal_tests_are_the_python_ones():
    # star-shaped (non-convex) cells, and cells on a coarse lattice: collinear corners and corners on diagonals
    rng = np.random.default_rng(1)
    for trial in range(120):
        k = int(rng.integers(4, 40))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        r = rng.uniform(0.3, 1.0, k) if trial % 3 else np.ones(k)
        P = np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1)
        if trial % 4 == 0:
            P = np.round(P, 1)
        table = healing._diagonals_compiled(np.ascontiguousarray(P))
        for i in range(k):
            for j in range(i + 2, k):
                if not (i == 0 and j == k - 1):
                    assert bool(table[i, j]) == healing._diagonal_inside(P.tolist(), i, j), (trial, i, j)
