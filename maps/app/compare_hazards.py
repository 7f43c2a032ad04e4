"""What a planner would trip on, measured against the generated world's truth: evaluation only.

- :func:`spurious_unidentified`: unidentified objects that explain nothing: farther
  than :data:`SPURIOUS_FAR` from every true surface (an echo placed in empty
  space), or within :data:`SPURIOUS_ON_LINE` of a believed map line (a wall the map
  already has).
- :func:`free_behind_walls`: free cells of the occupancy grid that no pose could
  have seen: every pose's sight line to the cell's centre meets a true surface more
  than one cell before it; and of those, the cells hidden by opaque surfaces alone
  (the rest the stripe saw through glass: free air, but beyond a pane that only the
  sonar hears, at normal incidence).
- :func:`free_behind_perceived`: of those, the cells hidden by the surfaces a sensor
  here reports, opaque ones and the panes the sonar heard at normal incidence: the
  rest lie behind panes neither sensor reported (free air the stripe saw through
  glass that no reading heard), beyond what the map can know.
- :func:`free_seen_kept`: of the places the stripe saw free (:func:`stripe_seen`: a
  lattice point in front of the first surface a pose's ray meets, glass included,
  the ray returning from an opaque one within the stripe's range, not within a cell
  of any surface), the share the grid marks free: safety must not be bought by
  marking nothing free. Beyond a pane the stripe sees free air, but a robot cannot
  go there: it is behind a wall (:func:`free_behind_walls`), not free space a pose saw.
- :func:`sunlight_seen_twice`: every sunlight region that a pose sees is in range and in
  sight of two poses or more (the worlds where persistence across poses can work).

Nothing here is read by the pipeline; the comparison calls it after the maps are made.
"""

from __future__ import annotations

from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import NDArray

from evmap.maps.belief_map import BeliefMap
from evmap.maps.occupancy import FREE_MAX, occupancy_from_masses, occupancy_masses
from evmap.sources.config_model import Config
from evmap.sources.geometry import point_segment_distances
from evmap.sources.ray_casting import cast_rays
from evmap.sources.sim.sightings import seen_twice
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World

__all__ = [
    "GRID_RESOLUTION",
    "SEEN_STEP",
    "SPURIOUS_FAR",
    "SPURIOUS_ON_LINE",
    "free_behind_perceived",
    "free_behind_walls",
    "free_seen_kept",
    "spurious_unidentified",
    "stripe_seen",
    "sunlight_seen_twice",
    "surface_distances",
]

SPURIOUS_FAR = 0.3
"""An unidentified object farther than this (m) from every true surface is spurious."""

SPURIOUS_ON_LINE = 0.15
"""An unidentified object within this (m) of a believed map line is spurious: the map has that surface already."""

GRID_RESOLUTION = 0.05
"""Cell size (m) of the occupancy grid whose free cells are checked."""

SEEN_STEP = 0.1
"""Spacing (m) of the lattice of places whose being seen free is checked (:func:`stripe_seen`)."""

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


def free_behind_walls(bm: BeliefMap, world: World) -> tuple[int, int, int]:
    """(free cells behind true surfaces, of those behind opaque ones, free cells) of the map's grid (module doc).

    A cell is free when the ROS export writes it free (value ``0..FREE_MAX``).
    """
    centre = _free_centres(bm)
    if not len(centre):
        return 0, 0, 0
    s = world.surfaces()
    hidden = _hidden(world, centre, s.p, s.q, s.cylinder_centers, s.cylinder_radii)
    opaque = _hidden(
        world,
        centre[hidden],
        s.p[s.lsl_opaque],
        s.q[s.lsl_opaque],
        s.cylinder_centers[s.cylinder_lsl_opaque],
        s.cylinder_radii[s.cylinder_lsl_opaque],
    )
    return int(hidden.sum()), int(opaque.sum()), len(centre)


def free_behind_perceived(bm: BeliefMap, world: World, heard: NDArray[np.intp]) -> int:
    """Free cells of the map's grid behind opaque true surfaces or the panes ``heard`` (indices into
    ``world.surfaces()``, those the sonar heard at normal incidence:
    :func:`~evmap.maps.app.compare_metrics.heard_glass`) (module doc).
    """
    centre = _free_centres(bm)
    if not len(centre):
        return 0
    s = world.surfaces()
    reported = s.lsl_opaque.copy()
    reported[np.asarray(heard, dtype=np.intp)] = True
    opaque = s.cylinder_lsl_opaque
    return int(
        _hidden(world, centre, s.p[reported], s.q[reported], s.cylinder_centers[opaque], s.cylinder_radii[opaque]).sum()
    )


def free_seen_kept(bm: BeliefMap, seen: NDArray[np.float64]) -> tuple[int, int]:
    """(places of ``seen`` the map's grid marks free, places of ``seen``) (module doc)."""
    if not len(seen):
        return 0, 0
    grid, origin = _grid(bm)
    col, row = np.floor((seen - np.asarray(origin)) / GRID_RESOLUTION).astype(np.intp).T
    inside = (row >= 0) & (row < grid.shape[0]) & (col >= 0) & (col < grid.shape[1])
    value = grid[row[inside], col[inside]]
    return int(((value >= 0) & (value <= FREE_MAX)).sum()), len(seen)


def stripe_seen(world: World, config: Config) -> NDArray[np.float64]:
    """The places (M, 2) of a :data:`SEEN_STEP` lattice that some pose's stripe saw free (module doc).

    A place is seen from a pose when the ray to it meets no true surface before it
    (less a cell), glass included, and meets an opaque one within the stripe's
    ``max_range`` (the ray returned); places within a cell of any true surface are
    left out.
    """
    s = world.surfaces()
    _, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    corners = np.vstack(
        [
            s.vertices.reshape(-1, 2),
            (s.cylinder_centers - s.cylinder_radii[:, None]).reshape(-1, 2),
            (s.cylinder_centers + s.cylinder_radii[:, None]).reshape(-1, 2),
        ]
    )
    if not len(corners):
        return np.zeros((0, 2))
    lo, hi = corners.min(axis=0) - 1.0, corners.max(axis=0) + 1.0
    x, y = np.meshgrid(np.arange(lo[0], hi[0], SEEN_STEP), np.arange(lo[1], hi[1], SEEN_STEP))
    xy = np.column_stack([x.ravel(), y.ravel()]) + SEEN_STEP / 2
    xy = xy[surface_distances(xy, s) > GRID_RESOLUTION]
    p, q = s.p[s.lsl_opaque], s.q[s.lsl_opaque]
    centers, radii = s.cylinder_centers[s.cylinder_lsl_opaque], s.cylinder_radii[s.cylinder_lsl_opaque]
    seen = np.zeros(len(xy), dtype=bool)
    for px, py, _ in world.poses:
        d = xy - (px, py)
        dist = np.hypot(d[:, 0], d[:, 1])
        near = np.flatnonzero(~seen & (dist <= lsl.max_range))
        for k in range(0, len(near), _CHUNK):
            chunk = near[k : k + _CHUNK]
            angles = np.arctan2(d[chunk, 1], d[chunk, 0])
            returned, _ = cast_rays((px, py), angles, p, q, centers, radii, lsl.max_range)
            first, _ = cast_rays((px, py), angles, s.p, s.q, s.cylinder_centers, s.cylinder_radii, lsl.max_range)
            seen[chunk] = np.isfinite(returned) & (dist[chunk] < first - GRID_RESOLUTION)
    return xy[seen]


_GRIDS: WeakKeyDictionary[BeliefMap, tuple[int, NDArray[np.int8], tuple[float, float]]] = WeakKeyDictionary()


def _grid(bm: BeliefMap) -> tuple[NDArray[np.int8], tuple[float, float]]:
    """The map's occupancy grid at :data:`GRID_RESOLUTION` and its origin, made once per version of the map."""
    kept = _GRIDS.get(bm)
    if kept is None or kept[0] != bm.version:
        masses, origin = occupancy_masses(bm, GRID_RESOLUTION)
        kept = _GRIDS[bm] = (bm.version, occupancy_from_masses(masses), origin)
    return kept[1], kept[2]


def _free_centres(bm: BeliefMap) -> NDArray[np.float64]:
    """Centres (N, 2) of the free cells of the map's occupancy grid."""
    grid, origin = _grid(bm)
    rows, cols = np.nonzero((grid >= 0) & (grid <= FREE_MAX))
    return np.asarray(origin) + (np.column_stack([cols, rows]) + 0.5) * GRID_RESOLUTION


def _hidden(
    world: World,
    xy: NDArray[np.float64],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    centers: NDArray[np.float64],
    radii: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Whether every pose's sight line to each point meets a surface p-q or circle more than one cell before it."""
    hidden = np.ones(len(xy), dtype=bool)
    for x, y, _ in world.poses:
        for k in range(0, len(xy), _CHUNK):  # cast_rays holds (rays, surfaces) arrays
            d = xy[k : k + _CHUNK] - (x, y)
            dist = np.hypot(d[:, 0], d[:, 1])
            angles = np.arctan2(d[:, 1], d[:, 0])
            ranges, _ = cast_rays((x, y), angles, p, q, centers, radii, float(dist.max()))
            hidden[k : k + _CHUNK] &= ranges < dist - GRID_RESOLUTION
    return hidden


def sunlight_seen_twice(world: World, config: Config) -> bool:
    """:func:`~evmap.sources.sim.sightings.seen_twice` with the run's LSL (the config's, as the scenario overrides it)."""
    _, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    return seen_twice(world, lsl)
