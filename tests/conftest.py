"""Shared fixtures: small analytic meshes and the path to the real test data in ``tests/data``."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from components.core.mesh import pad_faces, quad_grid

ROOT = Path(__file__).resolve().parents[1]
TESTDATA = Path(__file__).resolve().parent / "data"


def data_file(relative: str) -> Path:
    """Path of a file under ``tests/data`` (copied there with its source and license, see its README.md).

    A missing file is an error, not a skip: the test data ships with the repository."""
    path = TESTDATA / relative
    if not path.is_file():
        raise FileNotFoundError(f"test data missing: tests/data/{relative} (see tests/data/README.md)")
    return path


@pytest.fixture
def planar_grid():
    """A 6×4 planar quad grid on z = 0 (every face planar, valence 4 inside)."""
    return quad_grid(6, 4, 3.0, 2.0)


@pytest.fixture
def hypar_grid():
    """A 10×10 quad grid on the hyperbolic paraboloid z = x·y/2 over [-1, 1]² (non-planar quads)."""
    V, Q = quad_grid(10, 10, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = 0.5 * V[:, 0] * V[:, 1]
    return V, Q


@pytest.fixture
def sphere_cap():
    """Quads along meridians and parallels of a unit sphere cap (a conical mesh: principal curvature net)."""
    n_theta, n_phi = 16, 5
    theta = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    phi = np.linspace(0.15, 0.9, n_phi + 1)
    P, T = np.meshgrid(phi, theta, indexing="ij")
    V = np.stack([np.sin(P) * np.cos(T), np.sin(P) * np.sin(T), np.cos(P)], axis=-1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(n_phi + 1, n_theta)
    faces = []
    for i in range(n_phi):
        for j in range(n_theta):
            jn = (j + 1) % n_theta
            faces.append([idx[i, j], idx[i + 1, j], idx[i + 1, jn], idx[i, jn]])
    return V, np.asarray(faces, dtype=np.int64)


@pytest.fixture
def mixed_strip():
    """Planar (z = 0) strip of two quads, a triangle and a convex pentagon, padded to width 5."""
    V = np.array(
        [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0], [3, 1.3, 0],
         [4, 0.5, 0], [4, 1.5, 0]],
        dtype=float,
    )
    F = pad_faces([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 6], [3, 8, 9, 7, 6]], k=5)
    return V, F


@pytest.fixture
def nonmanifold_fan():
    """Three triangles sharing one edge (0, 1): a non-manifold edge."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], dtype=float)
    T = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]], dtype=np.int64)
    return V, T
