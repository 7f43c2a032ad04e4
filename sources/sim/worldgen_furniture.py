"""What stands in a generated world's free space: glass or mirror partitions, pillars and small clutter.

Partitions stand out of a wall; pillars are round wall-material cylinders; both
are placed before the robot's tour, which avoids them. Clutter is small real
objects of wall material placed after the tour, clear of its poses and of the
straight paths between them: boxes (rectangles of ``box_size`` sides, any
orientation) and chairs (four thin cylinders, the legs, at the corners of a
square). Their short, isolated LSL segments are real, like a phantom's are not;
and a share of them stands in the sunlight, among the phantoms (furniture by a
window), so that lying among false returns is no proxy for a phantom either.

>>> from evmap.sources.sim.worldgen_draw import Draws
>>> from evmap.sources.sim.worldgen_params import WorldGenParams
>>> free = shapely.box(0, 0, 6, 4)
>>> walls, legs = clutter(Draws(np.random.default_rng(2), WorldGenParams(boxes=(2, 2), chairs=(1, 1))), free, [], [])
>>> [w["id"] for w in walls], len(legs), all(w["points"][0] == w["points"][-1] for w in walls)
(['box-1', 'box-2'], 4, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

from evmap.sources.sim.worldgen_draw import CANDIDATES, Draws, Edge, coords, normal

__all__ = ["CLUTTER_GAP", "clutter", "partitions", "pillars"]

CLUTTER_GAP = 0.1
"""Clutter keeps this far (m) from walls, partitions, pillars, other clutter, and sunlight regions it does not stand in."""

SUNLIT_CENTRE = 0.3
"""Clutter standing in a sunlight region keeps this far (m) from the region's centroid, where the simulator looks
from a pose to tell whether the region is in sight."""


def partitions(
    draws: Draws, free: shapely.Polygon, edges: list[Edge], sunlight: list[shapely.Polygon]
) -> list[dict[str, Any]]:
    """Glass or mirror walls standing out of a wall into the free space, clear of sunlight."""
    p = draws.params
    long = [e for e in edges if np.hypot(*(e[1] - e[0])) >= 1.6]
    lit = shapely.union_all(sunlight).buffer(0.3)
    out: list[dict[str, Any]] = []
    placed: list[shapely.LineString] = []
    for _ in range(draws.count(p.partitions) if long else 0):
        for _ in range(CANDIDATES):
            a, b, _ = long[draws.rng.integers(len(long))]
            length = float(np.hypot(*(b - a)))
            start = a + (0.6 + draws.snap(draws.rng.uniform(0, length - 1.2))) * (b - a) / length
            end = start + draws.uniform(p.partition_length) * normal(a, b)
            line = shapely.LineString(np.round([start, end], 3))
            tip = shapely.Point(end)
            if (
                free.buffer(1e-6).covers(line)
                and free.exterior.distance(tip) >= 0.6
                and all(ring.distance(tip) >= 0.6 for ring in free.interiors)
                and not line.intersects(lit)
                and all(line.distance(other) >= 0.6 for other in placed)
            ):
                placed.append(line)
                material = "mirror" if draws.chance(p.mirror_share) else "glass"
                out.append({"id": f"partition-{len(out) + 1}", "points": coords(line.coords), "material": material})
                break
    return out


def pillars(
    draws: Draws, free: shapely.Polygon, sunlight: list[shapely.Polygon], partition_walls: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Round wall-material pillars in free space, clear of walls, partitions, sunlight and each other."""
    p = draws.params
    obstacles = [shapely.LineString(w["points"]) for w in partition_walls] + list(sunlight)
    out: list[dict[str, Any]] = []
    for _ in range(draws.count(p.pillars)):
        r = round(float(draws.rng.uniform(*p.pillar_radius)), 3)
        room = free.buffer(-(r + 0.5))
        for c in draws.points_in(room):
            if all(o.distance(c) >= r + 0.5 for o in obstacles):
                obstacles.append(c.buffer(r))
                out.append({"id": f"pillar-{len(out) + 1}", "center": coords([c.coords[0]])[0], "radius": r})
                break
    return out


def clutter(
    draws: Draws, free: shapely.Polygon, keep_clear: list[shapely.Geometry], sunlit: list[shapely.Polygon]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Boxes (closed wall polylines ``box-k``) and chairs (leg cylinders ``chair-k-leg-j``) in the free space.

    Each piece keeps :data:`CLUTTER_GAP` from the walls and from the others, and stays out of
    ``keep_clear`` (the obstacles, and the tour's poses and paths already buffered by their
    clearance). With probability ``sunlit_clutter_share`` a piece stands in the ``sunlit`` regions
    (its centre in one, :data:`SUNLIT_CENTRE` from its centroid), else clear of them. A piece with
    no room left is not placed.
    """
    p = draws.params
    area = free.buffer(-CLUTTER_GAP, join_style="mitre")
    blocked = shapely.union_all([g.buffer(CLUTTER_GAP) for g in keep_clear]) if keep_clear else shapely.Polygon()
    lit = shapely.union_all(sunlit) if sunlit else shapely.Polygon()
    centres = shapely.union_all([poly.centroid.buffer(SUNLIT_CENTRE) for poly in sunlit]) if sunlit else lit
    in_sun = (shapely.intersection(area, lit).difference(centres), centres)  # where its centre lies, what it keeps off
    shade = (area, lit.buffer(CLUTTER_GAP))

    def sunny() -> bool:  # a share of 0 draws nothing: the worlds of clutter kept out of the sunlight, draw for draw
        return bool(sunlit) and p.sunlit_clutter_share > 0 and draws.chance(p.sunlit_clutter_share)

    walls: list[dict[str, Any]] = []
    legs: list[dict[str, Any]] = []
    for _ in range(draws.count(p.boxes)):
        half = np.array([draws.uniform(p.box_size), draws.uniform(p.box_size)]) / 2
        corners = _turned(half * [[-1, -1], [1, -1], [1, 1], [-1, 1]], draws.rng.uniform(0, np.pi))
        within, off = in_sun if sunny() else shade
        for c in draws.points_in(within):
            shape = shapely.Polygon(np.round(corners + c.coords[0], 3))
            if area.contains(shape) and not shape.intersects(blocked) and not shape.intersects(off):
                blocked = shapely.union(blocked, shape.buffer(CLUTTER_GAP))
                points = coords(shape.exterior.coords)
                walls.append({"id": f"box-{len(walls) + 1}", "points": points, "material": "wall"})
                break
    for _ in range(draws.count(p.chairs)):
        half = draws.uniform(p.chair_size) / 2
        radius = round(float(draws.rng.uniform(*p.leg_radius)), 3)
        square = _turned(half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]), draws.rng.uniform(0, np.pi / 2))
        within, off = in_sun if sunny() else shade
        for c in draws.points_in(within):
            at = np.round(square + c.coords[0], 3)
            shape = shapely.Polygon(at).buffer(radius)
            if area.contains(shape) and not shape.intersects(blocked) and not shape.intersects(off):
                blocked = shapely.union(blocked, shape.buffer(CLUTTER_GAP))
                chair = len(legs) // 4 + 1
                legs += [
                    {"id": f"chair-{chair}-leg-{j + 1}", "center": xy, "radius": radius}
                    for j, xy in enumerate(coords(at))
                ]
                break
    return walls, legs


def _turned(points: np.ndarray, angle: float) -> np.ndarray:
    """Points turned by ``angle`` (rad) about the origin."""
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, s], [-s, c]])
