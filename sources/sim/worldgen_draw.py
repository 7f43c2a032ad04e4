"""The random draws of the world generator, and the small plane geometry its parts share.

Every random choice of a world goes through one :class:`Draws` (one
``numpy.random.Generator``) in a fixed order, so a seed gives one world.

>>> d = Draws(np.random.default_rng(0), WorldGenParams())
>>> x = d.uniform((1.0, 2.0))
>>> 1 <= x <= 2, round(x / 0.05, 9).is_integer()
(True, True)
>>> normal(np.array([0.0, 0.0]), np.array([0.0, 2.0])).tolist()
[-1.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import shapely

from evmap.sources.sim.worldgen_params import CountRange, Range, WorldGenParams

__all__ = ["CANDIDATES", "Draws", "Edge", "along", "coords", "normal"]

CANDIDATES = 400
"""Random placements tried for a pillar, a partition, a piece of clutter or a pose."""

Edge = tuple[np.ndarray, np.ndarray, bool]
"""A boundary edge of the free space ``(a, b, outer)``: ``outer`` when its far side is outside the building."""


class Draws:
    """The random draws of one world, on the grid of ``params``."""

    def __init__(self, rng: np.random.Generator, params: WorldGenParams) -> None:
        self.rng = rng
        self.params = params

    def uniform(self, bounds: Range) -> float:
        """A uniform draw on the grid (at least one grid step)."""
        g = self.params.grid
        return max(g, round(self.rng.uniform(*bounds) / g) * g)

    def count(self, bounds: CountRange) -> int:
        """A uniform integer draw, both ends included."""
        return int(self.rng.integers(bounds[0], bounds[1] + 1))

    def chance(self, share: float) -> bool:
        """True with probability ``share``."""
        return bool(self.rng.random() < share)

    def snap(self, x: float) -> float:
        """``x`` >= 0 rounded down to the grid."""
        return math.floor(x / self.params.grid + 1e-9) * self.params.grid

    def points_in(self, area: shapely.Geometry) -> Iterator[shapely.Point]:
        """Up to :data:`CANDIDATES` uniform random points of ``area``, on a millimetre grid."""
        if area.is_empty:
            return
        x0, y0, x1, y1 = area.bounds
        for _ in range(CANDIDATES):
            c = shapely.Point(round(self.rng.uniform(x0, x1), 3), round(self.rng.uniform(y0, y1), 3))
            if area.contains(c):
                yield c


def normal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit normal to the left of a -> b (into a counter-clockwise ring's interior)."""
    d = (b - a) / np.hypot(*(b - a))
    return np.array([-d[1], d[0]])


def along(a: tuple[float, float], b: tuple[float, float], x: np.ndarray) -> np.ndarray:
    """Where each point of ``x`` (N, 2) lies on a -> b as a fraction in (0, 1); NaN where not strictly on it.

    >>> along((0, 0), (2, 0), np.array([[0.5, 0.0], [0.0, 0.0], [1.0, 0.1]])).tolist()
    [0.25, nan, nan]
    """
    a_, d = np.asarray(a, dtype=float), np.subtract(b, a, dtype=float)
    w = np.asarray(x, dtype=float).reshape(-1, 2) - a_
    t = w @ d / np.dot(d, d)
    off = np.abs(d[0] * w[:, 1] - d[1] * w[:, 0]) / np.hypot(*d)
    return np.where((off < 1e-6) & (t > 1e-9) & (t < 1 - 1e-9), t, np.nan)


def coords(points: Any) -> list[list[float]]:
    """Points as ``[[x, y], ...]`` of plain floats rounded to millimetres (no ``-0.0``).

    >>> coords([(0.12345, -0.0001)])
    [[0.123, 0.0]]
    """
    return [[round(float(x), 3) + 0.0, round(float(y), 3) + 0.0] for x, y in points]
