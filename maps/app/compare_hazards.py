"""What a planner would trip on, measured against the generated world's truth: evaluation only.

- :func:`spurious_unidentified`: unidentified objects that explain nothing: farther
  than :data:`SPURIOUS_FAR` from every true surface (an echo placed in empty
  space), or within :data:`SPURIOUS_ON_LINE` of a believed map line (a wall the map
  already has).
- :func:`free_behind_walls`: free cells of the occupancy grid that no pose could
  have seen: every pose's sight line to the cell's centre meets a true surface more
  than one cell before it.
- :func:`sunlight_seen_twice`: every sunlight region that a pose sees is in range and in
  sight of two poses or more (the worlds where persistence across poses can work).

Nothing here is read by the pipeline; the comparison calls it after the maps are made.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evmap.maps.belief_map import BeliefMap
from evmap.maps.occupancy import FREE_MAX, occupancy_from_masses, occupancy_masses
from evmap.sources.config import Config
from evmap.sources.geometry import cast_rays, point_segment_distances
from evmap.sources.sim.sightings import seen_twice
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World

__all__ = [
    "GRID_RESOLUTION",
    "SPURIOUS_FAR",
    "SPURIOUS_ON_LINE",
    "free_behind_walls",
    "spurious_unidentified",
    "sunlight_seen_twice",
    "surface_distances",
]

SPURIOUS_FAR = 0.3
"""An unidentified object farther than this (m) from every true surface is spurious."""

SPURIOUS_ON_LINE = 0.15
"""An unidentified object within this (m) of a believed map line is spurious: the map has that surface already."""

GRID_RESOLUTION = 0.05
"""Cell size (m) of the occupancy grid whose free cells are checked."""

_CHUNK = 4096


def spurious_unidentified(bm: BeliefMap, world: World) -> tuple[int, int]:
    """(spurious, all) unidentified objects of the map (module doc)."""
    xy = np.array([u.xy for u in bm.unidentified()], dtype=float).reshape(-1, 2)
    if not len(xy):
        return 0, 0
    spurious = surface_distances(xy, world.surfaces()) > SPURIOUS_FAR
    lines = bm.lines(min_belief=0.5)
    if lines:
        p, q = np.array([ln.p for ln in lines]), np.array([ln.q for ln in lines])
        spurious |= point_segment_distances(xy[:, None, :], p[None], q[None]).min(axis=1) <= SPURIOUS_ON_LINE
    return int(spurious.sum()), len(xy)


def surface_distances(xy: NDArray[np.float64], s: Surfaces) -> NDArray[np.float64]:
    """Distance (m) from each point (N, 2) to the nearest true surface: a wall, or a cylinder's rim."""
    d = np.full(len(xy), np.inf)
    if len(s.p):
        d = point_segment_distances(xy[:, None, :], s.p[None], s.q[None]).min(axis=1)
    if len(s.cylinder_radii):
        rim = np.abs(np.hypot(*(xy[:, None, :] - s.cylinder_centers[None]).transpose(2, 0, 1)) - s.cylinder_radii)
        d = np.minimum(d, rim.min(axis=1))
    return d


def free_behind_walls(bm: BeliefMap, world: World) -> tuple[int, int]:
    """(free cells behind true surfaces, free cells) of the map's occupancy grid (module doc).

    A cell is free when the ROS export writes it free (value ``0..FREE_MAX``).
    """
    masses, origin = occupancy_masses(bm, GRID_RESOLUTION)
    grid = occupancy_from_masses(masses)
    rows, cols = np.nonzero((grid >= 0) & (grid <= FREE_MAX))
    if not len(rows):
        return 0, 0
    centre = np.asarray(origin) + (np.column_stack([cols, rows]) + 0.5) * GRID_RESOLUTION
    return int(_hidden(world, centre).sum()), len(centre)


def _hidden(world: World, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether every pose's sight line to each point meets a surface more than one cell before the point."""
    s = world.surfaces()
    hidden = np.ones(len(xy), dtype=bool)
    for x, y, _ in world.poses:
        for k in range(0, len(xy), _CHUNK):  # cast_rays holds (rays, surfaces) arrays
            d = xy[k : k + _CHUNK] - (x, y)
            dist = np.hypot(d[:, 0], d[:, 1])
            angles = np.arctan2(d[:, 1], d[:, 0])
            ranges, _ = cast_rays((x, y), angles, s.p, s.q, s.cylinder_centers, s.cylinder_radii, float(dist.max()))
            hidden[k : k + _CHUNK] &= ranges < dist - GRID_RESOLUTION
    return hidden


def sunlight_seen_twice(world: World, config: Config) -> bool:
    """:func:`~evmap.sources.sim.sightings.seen_twice` with the run's LSL (the config's, as the scenario overrides it)."""
    _, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    return seen_twice(world, lsl)
