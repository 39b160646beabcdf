"""components.core.blas: one OpenBLAS thread inside the block, the previous counts back after it (issue #21)."""
import threading

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from components.core.blas import blas_thread_controls, single_blas_thread


def test_one_thread_inside_and_counts_restored():
    controls = blas_thread_controls()
    before = [get() for get, _ in controls]
    with single_blas_thread():
        assert all(get() == 1 for get, _ in controls)
        with single_blas_thread():  # nested: still one, and the outer exit restores
            assert all(get() == 1 for get, _ in controls)
        assert all(get() == 1 for get, _ in controls)
    assert [get() for get, _ in controls] == before


def test_restored_after_an_error_and_across_threads():
    controls = blas_thread_controls()
    before = [get() for get, _ in controls]
    try:
        with single_blas_thread():
            raise ValueError("boom")
    except ValueError:
        pass
    assert [get() for get, _ in controls] == before
    out = []

    def work():
        with single_blas_thread():
            A = sp.csc_matrix(sp.diags(np.arange(1.0, 201.0)) + sp.eye(200, k=1) * 0.1 + sp.eye(200, k=-1) * 0.1)
            out.append(np.abs(A @ splu(A).solve(np.ones(200)) - 1.0).max())

    ts = [threading.Thread(target=work) for _ in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert len(out) == 4 and max(out) < 1e-12
    assert [get() for get, _ in controls] == before


def test_finds_the_bundled_openblas():
    # the pip wheels of scipy (and numpy) ship OpenBLAS with thread controls on Windows, macOS and Linux
    assert len(blas_thread_controls()) >= 1
