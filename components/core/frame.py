"""The centred, unit-size frame a computation runs in, so that units and placement do not change its result.

A model in millimetres is the model in metres times 1000, rounded; a model at site coordinates is the model moved
by millions, rounded. The rounding is a relative 1e-16 of each coordinate (of the size, for a unit change; of the
offset, for a far placement) and a computation with discrete choices (which candidate ranks first, which pair of
directions is closest, which corner is reflex) amplifies it wherever two choices are nearly tied: a surface in mm
gave other panels than in m on six of the 42 shared meshes. :func:`bounding_frame` maps every model to the same
centred, unit-size coordinates and :meth:`Frame.to` snaps them to a fine grid (``GRID``, about a billionth of the
size, far below any modelling tolerance), so the few-ulp differences of other units vanish and the computation
sees the same numbers bit for bit; :meth:`Frame.back` maps results back to model units. A far placement rounds
the model itself by up to 1e-9 of its offset, which no grid can undo where it straddles a grid line; such models
get the same numbers except at a few vertices, by a grid step.

Example
-------
>>> V = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.1], [0.0, 0.7, 0.2]])
>>> a, b = bounding_frame(V), bounding_frame(V * 1000.0 + 5e3)
>>> bool(np.array_equal(a.to(V), b.to(V * 1000.0 + 5e3))), a.length(0.1) == b.length(100.0)
(True, True)
>>> bool(np.allclose(b.back(b.to(V * 1000.0 + 5e3)), V * 1000.0 + 5e3, rtol=0, atol=1e-6))
True
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["GRID", "LENGTH_BITS", "IDENTITY", "Frame", "bounding_frame", "snapped", "snapped_length"]

GRID = 2.0 ** -30  # coordinates snapped to this fraction of the model's largest extent
LENGTH_BITS = 30  # lengths (a panel size) rounded to this many significant bits


class Frame(NamedTuple):
    """``x → (x − centre) / scale`` on a grid of ``grid`` (see the module's text)."""

    centre: np.ndarray
    scale: float
    grid: float = GRID

    def unsnapped(self, X) -> np.ndarray:
        """``(X − centre) / scale`` as computed."""
        return (np.asarray(X, np.float64) - self.centre) / self.scale

    def to(self, X) -> np.ndarray:
        """``(X − centre) / scale`` snapped to the grid."""
        return snapped(self.unsnapped(X), self.grid)

    def back(self, X) -> np.ndarray:
        """Model coordinates of frame coordinates ``X``."""
        return np.asarray(X, np.float64) * self.scale + self.centre

    def length(self, x: float) -> float:
        """A length in model units in the frame's units, rounded (:func:`snapped_length`) so that the same length
        in other units gives the same number."""
        return snapped_length(float(x) / self.scale)


IDENTITY = Frame(np.zeros(3), 1.0)  # ``back`` returns coordinates unchanged, bit for bit


def bounding_frame(V, grid: float = GRID) -> Frame:
    """The frame of the bounding box of ``V``: its centre, its largest extent as the unit (1 for a point).

    >>> bounding_frame([[1.0, 2.0, 3.0], [3.0, 2.0, 4.0]])
    Frame(centre=array([2. , 2. , 3.5]), scale=2.0, grid=9.313225746154785e-10)
    """
    V = np.asarray(V, np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    ext = float((hi - lo).max())
    return Frame(0.5 * (lo + hi), ext if ext > 0 and math.isfinite(ext) else 1.0, grid)


def snapped(X, grid: float = GRID) -> np.ndarray:
    """``X`` rounded to the nearest multiple of ``grid``: values a few ulps apart become equal (but where they
    straddle a grid line).

    >>> snapped(np.array([0.1, 0.1 * (1 + 1e-15)]), 2.0 ** -20).tolist()
    [0.10000038146972656, 0.10000038146972656]
    """
    return np.round(X / grid) * grid


def snapped_length(x: float, bits: int = LENGTH_BITS) -> float:
    """``x`` rounded to ``bits`` significant bits: lengths that differ by a few ulps become equal.

    >>> snapped_length(0.1) == snapped_length(0.1 * (1 + 1e-15)), snapped_length(0.0)
    (True, 0.0)
    """
    m, e = math.frexp(float(x))
    return math.ldexp(round(m * 2.0 ** bits) / 2.0 ** bits, e)
