"""The robot's tour through a generated world: poses along a path, each in sight of the previous one.

The first pose is in free space and sees a sunlight region (its centroid within
``sight_range``, the line to it in free space and clear of pillars). Each next
pose is ``pose_step`` from the previous one, mostly ahead of the direction
travelled so far (within 60 degrees for the first half of the tries), at least
half the shortest step from every earlier pose, and the straight path to it keeps
``path_clearance`` from walls, partitions and pillars. Every pose keeps
``clearance`` from walls, partitions, pillars and sunlight regions. A tour stops
early when no next pose fits (a small world can hold fewer poses).

>>> from evmap.sources.sim.worldgen_draw import Draws
>>> from evmap.sources.sim.worldgen_params import WorldGenParams
>>> free, lit = shapely.box(0, 0, 10, 3), shapely.box(4, 0.2, 5, 1)
>>> t = tour(Draws(np.random.default_rng(0), WorldGenParams()), free, [], [lit], 4)
>>> len(t.poses), len(t.keep_clear) == 2 * len(t.poses)
(4, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from evmap.sources.sim.worldgen_draw import CANDIDATES, Draws

__all__ = ["Tour", "tour"]

_AHEAD = np.pi / 3
"""Half-angle (rad) about the direction travelled in which the first half of the tries for a next pose lie."""


@dataclass(frozen=True)
class Tour:
    """The poses ``[x, y, heading_deg]`` and what later placements must keep clear of.

    ``keep_clear``: each pose buffered by ``clearance``, each path between
    consecutive poses buffered by ``path_clearance``, and the first pose's sight line
    to its sunlight region.
    """

    poses: list[list[float]]
    keep_clear: list[shapely.Geometry]


def tour(
    draws: Draws, free: shapely.Polygon, obstacles: list[shapely.Geometry], sunlight: list[shapely.Polygon], count: int
) -> Tour:
    """Up to ``count`` poses (see the module doc); ``obstacles`` are partitions (lines) and pillars (discs).

    Raises
    ------
    RuntimeError
        When no point of the free space is clear for a first pose.
    """
    p = draws.params
    clear = shapely.difference(
        free.buffer(-p.clearance), shapely.union_all([g.buffer(p.clearance) for g in (*obstacles, *sunlight)])
    )
    lane = shapely.difference(
        free.buffer(-p.path_clearance), shapely.union_all([g.buffer(p.path_clearance) for g in obstacles])
    )
    shapely.prepare(clear)
    shapely.prepare(lane)
    discs = [g for g in obstacles if isinstance(g, shapely.Polygon)]
    centroids = [poly.centroid for poly in sunlight]
    first, sight, fallback = None, None, None
    for c in draws.points_in(clear):
        fallback = fallback or c
        seen = [s for s in centroids if c.distance(s) <= p.sight_range and _in_sight(free, discs, c, s)]
        if seen:
            first, sight = c, shapely.LineString([c, seen[0]])
            break
    first = first or fallback
    if first is None:
        raise RuntimeError("no free space for a pose: the world is too small for the clearance")
    chosen = [first]
    paths = []
    travel = draws.rng.uniform(0, 2 * np.pi)
    spread = np.where(np.arange(CANDIDATES) < CANDIDATES // 2, _AHEAD, np.pi)
    for _ in range(count - 1):
        prev = chosen[-1]
        angle = travel + spread * draws.rng.uniform(-1, 1, CANDIDATES)
        step = draws.rng.uniform(*p.pose_step, CANDIDATES)
        x = np.round(prev.x + step * np.cos(angle), 3)
        y = np.round(prev.y + step * np.sin(angle), 3)
        earlier = np.array([c.coords[0] for c in chosen])
        gap = np.hypot(x[:, None] - earlier[:, 0], y[:, None] - earlier[:, 1]).min(axis=1)
        fits = np.flatnonzero(shapely.contains_xy(clear, x, y) & (gap >= p.pose_step[0] / 2))
        k = next((j for j in fits if lane.covers(shapely.LineString([prev, (x[j], y[j])]))), None)
        if k is None:
            break
        c = shapely.Point(x[k], y[k])
        paths.append(shapely.LineString([prev, c]))
        chosen.append(c)
        travel = angle[k]
    poses = [[c.x, c.y, float(draws.rng.integers(0, 360))] for c in chosen]
    keep_clear = [c.buffer(p.clearance) for c in chosen] + [path.buffer(p.path_clearance) for path in paths]
    return Tour(poses, keep_clear + ([sight] if sight is not None else []))


def _in_sight(free: shapely.Polygon, discs: list[shapely.Polygon], a: shapely.Point, b: shapely.Point) -> bool:
    """The straight line a-b stays in free space and misses every pillar."""
    line = shapely.LineString([a, b])
    return free.covers(line) and not any(line.intersects(d) for d in discs)
