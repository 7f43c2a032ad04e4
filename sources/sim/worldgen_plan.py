"""The floor plan of a generated world: a corridor, a hall or a large hall, with rooms, doors and recesses.

Walls have no thickness in the scenario format; the free space is a union of
rectangles (the main space, rooms, door openings through a wall of
:attr:`~evmap.sources.sim.worldgen_params.WorldGenParams.wall_thickness`) and its
boundary rings are the walls.

>>> from evmap.sources.sim.worldgen_draw import Draws
>>> plan = floor_plan(Draws(np.random.default_rng(1), WorldGenParams()))
>>> plan.kind in ("corridor", "hall", "large hall"), plan.free.is_valid, any(outer for _, _, outer in plan.edges)
(True, True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from typing import Literal

import numpy as np
import shapely

from evmap.sources.sim.worldgen_draw import Draws, Edge, normal
from evmap.sources.sim.worldgen_params import WorldGenParams

__all__ = ["FloorPlan", "floor_plan"]

Kind = Literal["corridor", "hall", "large hall"]


@dataclass(frozen=True)
class FloorPlan:
    """The free space of a world (one polygon, counter-clockwise) and its boundary edges."""

    kind: Kind
    free: shapely.Polygon
    edges: list[Edge]


def floor_plan(draws: Draws) -> FloorPlan:
    """Draw the main space, its rooms and recesses; the free space is their union."""
    p = draws.params
    r = draws.rng.random()
    kind: Kind = (
        "large hall" if r < p.large_hall_share else "hall" if r < p.large_hall_share + p.hall_share else "corridor"
    )
    length_range, width_range = {
        "corridor": (p.corridor_length, p.corridor_width),
        "hall": (p.hall_length, p.hall_width),
        "large hall": (p.large_hall_length, p.large_hall_width),
    }[kind]
    length, width = draws.uniform(length_range), draws.uniform(width_range)
    rects, bare = _rooms(draws, length, width)
    rects += _recesses(draws, bare, width)
    free = shapely.union_all([shapely.box(0, 0, length, width), *rects])
    free = shapely.orient_polygons(shapely.simplify(shapely.set_precision(free, 1e-3), 0))
    return FloorPlan(kind, free, _edges(free, p))


def _rooms(draws: Draws, length: float, width: float) -> tuple[list[shapely.Polygon], list[tuple[float, float, int]]]:
    """Rooms on both sides with their door openings; the bare stretches ``(x0, x1, side)`` left."""
    p = draws.params
    t = p.wall_thickness
    slots = []  # (x0, x1, side): side +1 north, -1 south
    for side in (1, -1):
        x = 0.0
        while x + p.room_width[0] <= length:
            w = min(draws.uniform(p.room_width), length - x)
            slots.append((x, x + w, side))
            x += w
    keep = min(len(slots), draws.count(p.rooms))
    chosen = sorted(draws.rng.choice(len(slots), size=keep, replace=False).tolist()) if slots else []
    rects, bare = [], []
    for k, (x0, x1, side) in enumerate(slots):
        if k not in chosen:
            bare.append((x0, x1, side))
            continue
        depth = draws.uniform(p.room_depth)
        near = width + t if side > 0 else -t
        far = near + side * depth
        a, b = x0 + t / 2, x1 - t / 2
        rects.append(shapely.box(a, min(near, far), b, max(near, far)))
        door = draws.uniform(p.passage_width if draws.chance(p.passage_share) else p.door_width)
        door = min(door, b - a - 0.4)
        d = a + 0.2 + draws.snap(draws.rng.uniform(0, max(0.0, b - a - 0.4 - door)))
        wall = (width, width + t) if side > 0 else (-t, 0.0)
        rects.append(shapely.box(d, wall[0], d + door, wall[1]))
    return rects, bare


def _recesses(draws: Draws, bare: list[tuple[float, float, int]], width: float) -> list[shapely.Polygon]:
    """Door recesses (shallow notches) in bare stretches of the main space's walls."""
    p = draws.params
    out = []
    wide = [s for s in bare if s[1] - s[0] >= p.door_width[1] + 0.6]
    for k in draws.rng.permutation(len(wide))[: draws.count(p.recesses)]:
        x0, x1, side = wide[k]
        w = draws.uniform(p.door_width)
        d = x0 + 0.3 + draws.snap(draws.rng.uniform(0, max(0.0, x1 - x0 - 0.6 - w)))
        depth = draws.uniform(p.recess_depth)
        y0, y1 = (width, width + depth) if side > 0 else (-depth, 0.0)
        out.append(shapely.box(d, y0, d + w, y1))
    return out


def _edges(free: shapely.Polygon, params: WorldGenParams) -> list[Edge]:
    """Boundary edges ``(a, b, outer)``: ``outer`` when the far side is outside the building."""
    reach = 2 * params.wall_thickness
    out = []
    for ring in (free.exterior, *free.interiors):
        xy = np.asarray(ring.coords)
        for a, b in pairwise(xy):
            mid, n = (a + b) / 2, normal(a, b)
            out.append((a, b, not free.contains(shapely.Point(mid - reach * n))))
    return out
