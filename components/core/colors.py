"""Colour map and unwelded display meshes for the metric analysis (numpy only, no matplotlib at runtime).

Display meshes are ``(V, F, C)``: every face gets its own copies of its corners (the mesh is *unwelded*), so a
face can carry one flat colour; ``C`` is ``(n, 3) uint8`` RGB, one colour per display vertex. The server writes
``C`` into the Rhino mesh's vertex colours.
"""
from __future__ import annotations

import numpy as np

from components.core.mesh import face_sizes

# Nine samples of the perceptually uniform "viridis" map (S. van der Walt, N. Smith, 2015; CC0), in 0..255 RGB,
# interpolated linearly in between.
_VIRIDIS = np.array(
    [[68, 1, 84], [71, 45, 123], [59, 82, 139], [44, 114, 142], [33, 145, 140], [40, 174, 128], [94, 201, 98],
     [173, 220, 48], [253, 231, 37]],
    dtype=np.float64,
)

UNDEFINED_COLOR = np.array([160, 160, 160], dtype=np.uint8)


def colormap(values, low: float, high: float) -> np.ndarray:
    """Map values to viridis colours.

    Parameters
    ----------
    values : (q,) float64
        Values to colour (finite).
    low, high : float
        Legend range: ``low`` maps to dark purple, ``high`` to yellow; values outside are clamped. When
        ``high <= low`` everything gets the middle colour.

    Returns
    -------
    (q, 3) uint8
        RGB colours.
    """
    values = np.asarray(values, dtype=np.float64)
    if high > low:
        s = np.clip((values - low) / (high - low), 0.0, 1.0)
    else:
        s = np.full(values.shape, 0.5)
    x = s * (len(_VIRIDIS) - 1)
    i = np.minimum(np.floor(x).astype(np.int64), len(_VIRIDIS) - 2)
    f = (x - i)[:, None]
    rgb = (1.0 - f) * _VIRIDIS[i] + f * _VIRIDIS[i + 1]
    return np.clip(np.round(rgb), 0, 255).astype(np.uint8)


def unweld(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Give every face its own copies of its corners.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, k) int64
        Padded faces.

    Returns
    -------
    VD : (c, 3) float64
        Display vertices, one per face corner (padding excluded), face by face.
    FD : (m, k) int64
        Faces of the display mesh (padded like ``F``).
    corner_face : (c,) int64
        Face of every display vertex.
    corner_vertex : (c,) int64
        Original vertex of every display vertex.
    """
    F = np.asarray(F, dtype=np.int64)
    m, k = F.shape
    sizes = face_sizes(F)
    valid = np.arange(k)[None, :] < sizes[:, None]
    corner_vertex = F[valid]
    corner_face = np.repeat(np.arange(m), sizes)
    start = np.cumsum(sizes) - sizes
    cols = np.minimum(np.arange(k)[None, :], (sizes - 1)[:, None])
    FD = start[:, None] + cols
    return np.asarray(V, dtype=np.float64)[corner_vertex], FD.astype(np.int64), corner_face, corner_vertex
