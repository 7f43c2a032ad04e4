"""Sunlight regions of a scenario: where the LSL sees phantom lines, and how they are drawn.

A region's ``length`` range is refused when its longest (or shortest) line hardly fits
in the polygon (see :data:`MIN_FIT_RATE`), so drawing the phantom lines stays quick.
The polygon is handled relative to its first vertex, so a region far from the origin
(UTM coordinates) loses no precision.
"""

from __future__ import annotations

import re

import numpy as np
import shapely
from numpy.typing import NDArray
from pydantic import Field, ValidationInfo, field_validator

from evmap.sources.sim.spec import (
    MAX_POLYGON_VERTICES,
    MAX_SUNLIGHT_LINES_PER_REGION,
    MIN_SEGMENT_LENGTH,
    Count,
    Number,
    Point,
    SpecModel,
)

__all__ = ["MIN_FIT_RATE", "Sunlight"]

MIN_FIT_RATE = 0.01
"""A sunlight line of the shortest and of the longest length of a region's range must
have both ends inside the polygon for at least this share of random placements (one
end uniform in the polygon, a uniform direction); otherwise the range is refused as
too long for the polygon. This keeps the drawing of phantom lines quick."""

_FIT_TRIALS = 4096
_PLACE_ROUNDS = 500
_PLACE_CANDIDATES = 32


class Sunlight(SpecModel):
    """A region where sunlight makes the LSL see phantom lines (drawn anew at every pose)."""

    polygon: list[Point] = Field(min_length=3, max_length=MAX_POLYGON_VERTICES)
    lines: Count = Field(ge=0, le=MAX_SUNLIGHT_LINES_PER_REGION, description="phantom lines per pose")
    length: tuple[Number, Number] = Field(description="[min, max] length of a phantom line (m)")

    @field_validator("polygon")
    @classmethod
    def _simple_polygon(cls, polygon: list[Point]) -> list[Point]:
        shape = shapely.Polygon(np.subtract(polygon, polygon[0]))  # about its first vertex: exact arithmetic
        if not shape.is_valid:
            reason = re.fullmatch(r"(.*)\[(\S+) (\S+)\]", shapely.is_valid_reason(shape))  # GEOS: "Why[x y]"
            where = (
                f" at ({float(reason[2]) + polygon[0][0]:g}, {float(reason[3]) + polygon[0][1]:g})" if reason else ""
            )
            raise ValueError(f"not a simple polygon: {reason[1].lower() if reason else 'invalid'}{where}")
        if shape.area <= 0:
            raise ValueError("the polygon has no area")
        return polygon

    @field_validator("length")
    @classmethod
    def _length_fits(cls, length: tuple[float, float], info: ValidationInfo) -> tuple[float, float]:
        low, high = length
        if not MIN_SEGMENT_LENGTH <= low <= high:
            raise ValueError(f"need {MIN_SEGMENT_LENGTH:g} m <= min <= max, got min {low} and max {high}")
        if "polygon" in info.data:
            polygon = info.data["polygon"]
            shape = shapely.Polygon(np.subtract(polygon, polygon[0]))
            triangles = _triangles(shape)
            rng = np.random.default_rng(0)
            for value in (low, high):
                lengths = np.full(_FIT_TRIALS, value)
                rate = _try_place(shape, triangles, lengths, rng)[2].mean()
                if rate < MIN_FIT_RATE:
                    raise ValueError(
                        f"a line of {value} m has both ends inside the polygon for only "
                        f"{rate:.2%} of placements (at least {MIN_FIT_RATE:.0%} needed): too long for the polygon"
                    )
        return length

    def draw_lines(self, rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Draw the region's phantom lines: ``(p, q)``, each ``(lines, 2)``.

        Lengths are uniform in ``length``; one end is uniform in the polygon and the
        direction uniform, redrawn until the other end is inside the polygon too.

        >>> region = Sunlight(polygon=[[0, 0], [1, 0], [1, 1], [0, 1]], lines=3, length=(0.1, 0.2))
        >>> p, q = region.draw_lines(np.random.default_rng(1))
        >>> p.shape, bool(np.all((0.1 <= np.hypot(*(q - p).T)) & (np.hypot(*(q - p).T) <= 0.2)))
        ((3, 2), True)
        """
        origin = np.array(self.polygon[0], dtype=float)  # drawn relative to it: no precision lost far away
        shape = shapely.Polygon(np.subtract(self.polygon, origin))
        triangles = _triangles(shape)
        lengths = rng.uniform(self.length[0], self.length[1], self.lines)
        p = np.empty((self.lines, 2))
        q = np.empty((self.lines, 2))
        todo = np.arange(self.lines)
        for _ in range(_PLACE_ROUNDS):
            if todo.size == 0:
                break
            tries = np.repeat(todo, _PLACE_CANDIDATES)
            a, b, ok = _try_place(shape, triangles, lengths[tries], rng)
            # the first successful candidate of each line
            line, first = np.unique(tries[ok], return_index=True)
            p[line], q[line] = a[ok][first], b[ok][first]
            todo = np.setdiff1d(todo, line)
        if todo.size:
            raise RuntimeError(f"could not place {todo.size} sunlight lines inside {self.polygon}")
        return p + origin, q + origin


def _triangles(shape: shapely.Polygon) -> NDArray[np.float64]:
    """(T, 3, 2) triangulation of a simple polygon."""
    parts = shapely.get_parts(shapely.constrained_delaunay_triangles(shape))
    return shapely.get_coordinates(parts).reshape(len(parts), 4, 2)[:, :3]


def _try_place(
    shape: shapely.Polygon, triangles: NDArray[np.float64], lengths: NDArray[np.float64], rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """One placement attempt per length: ends ``a`` (uniform in the polygon), ``b``, and whether ``b`` is inside."""
    a_, b_, c_ = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e, f = b_ - a_, c_ - a_
    area = np.abs(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]) / 2
    pick = rng.choice(len(triangles), size=len(lengths), p=area / area.sum())
    u, v = rng.random((2, len(lengths)))
    flip = u + v > 1
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    a = a_[pick] + u[:, None] * (b_[pick] - a_[pick]) + v[:, None] * (c_[pick] - a_[pick])
    theta = rng.uniform(0, 2 * np.pi, len(lengths))
    b = a + lengths[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    inside = shapely.contains_xy(shape, a[:, 0], a[:, 1]) & shapely.contains_xy(shape, b[:, 0], b[:, 1])
    return a, b, inside
