"""The free space of a map, from what its poses sensed, ending at the map's believed surfaces.

Each remembered pose (:mod:`evmap.maps.sensed`) gives free space twice over:

- its sonar open space (:func:`evmap.sources.open_space.open_space` of its scan,
  with the map's config), the sectors from the sensor to the first echo;
- its contour rays: the fan between neighbouring rays that both returned (at most
  ``max_gap`` apart in bearing), from the sensor to ``margin`` short of their points.

A sensor sees nothing behind a surface, so each pose's free space ends at the
first believed line (``Bel(real) >= min_belief``) that it meets: the line's
shadow from the pose is cut away. The map's free space is the union over poses.
A map that remembers no pose (hand-made, or from an older file) has its stored
open space as it is.

The occupancy grid (:mod:`evmap.maps.occupancy`) takes its free evidence from
here; ``map.json`` keeps the sensed readings, so the grid of a loaded map is the
grid of the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.maps.planner import lines
from evmap.maps.sensed import Sensed, sensed
from evmap.sources.open_space import open_space
from evmap.sources.rcd import extract_rcds

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["FreeSpaceParams", "free_space", "ray_fan", "shadows"]


@dataclass(frozen=True)
class FreeSpaceParams:
    """Constants of the free space (metres, radians, belief)."""

    margin: float = 0.05  # a ray's free space ends this short of its point
    max_gap: float = np.radians(2.0)  # neighbouring rays farther apart than this bound no free space
    min_belief: float = 0.5  # lines believed at least this much end the free space


def ray_fan(s: Sensed, params: FreeSpaceParams) -> shapely.Geometry:
    """The free space between neighbouring rays of one pose that both returned.

    >>> from evmap.sources.params import SonarParams
    >>> bearing = np.radians([-10.0, -9.0, -8.0, 30.0])
    >>> s = Sensed(0, np.zeros(2), bearing, np.array([2.0, 2.0, 2.0, 3.0]), None)
    >>> round(ray_fan(s, FreeSpaceParams()).area, 3)  # two thin triangles of radius 1.95, 1 deg each
    0.066
    """
    r = s.range - params.margin
    ok = np.isfinite(r) & (r > 0)
    pair = np.flatnonzero(ok[:-1] & ok[1:] & (np.diff(s.bearing) <= params.max_gap))
    if not len(pair):
        return shapely.Polygon()
    ends = s.origin + r[:, None] * np.column_stack([np.cos(s.bearing), np.sin(s.bearing)])
    o = np.broadcast_to(s.origin, (len(pair), 2))
    rings = np.stack([o, ends[pair], ends[pair + 1], o], axis=1)
    return shapely.union_all(shapely.polygons(rings))


def shadows(
    origin: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64], reach: float
) -> shapely.Geometry:
    """What lines p-q hide from ``origin``: each line's shadow, out to ``reach`` from the origin.

    >>> shade = shadows(np.zeros(2), np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]]), 10.0)
    >>> shade.contains(shapely.Point(3, 0)), shade.contains(shapely.Point(0.5, 0))
    (True, False)
    """
    a, b = p - origin, q - origin
    da, db = np.hypot(*a.T), np.hypot(*b.T)
    keep = (np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) > 1e-9) & (da > 1e-9) & (db > 1e-9)
    if not keep.any():
        return shapely.Polygon()
    a, b, da, db = a[keep], b[keep], da[keep], db[keep]
    far_a = a * (reach / np.minimum(da, reach))[:, None] * 2
    far_b = b * (reach / np.minimum(db, reach))[:, None] * 2
    rings = origin + np.stack([a, b, far_b, far_a, a], axis=1)
    return shapely.union_all(shapely.make_valid(shapely.polygons(rings)))


def free_space(bm: BeliefMap, params: FreeSpaceParams | None = None) -> shapely.Geometry:
    """The map's free space (module doc): sonar sectors and contour rays of every pose, short of believed lines."""
    params = params or FreeSpaceParams()
    poses = sensed(bm)
    if not poses:
        return bm.open_space
    config = bm.config
    believed = lines(bm, params.min_belief)
    p = np.array([ln.p for ln in believed], dtype=float).reshape(-1, 2)
    q = np.array([ln.q for ln in believed], dtype=float).reshape(-1, 2)
    pieces = []
    for s in poses:
        seen = [ray_fan(s, params)]
        if s.sonar is not None:
            seen.append(open_space(s.sonar, extract_rcds(s.sonar, config.rcd, primitive=True), config.open_space))
        free = shapely.union_all(seen)
        if len(p) and not free.is_empty:
            xmin, ymin, xmax, ymax = free.bounds
            reach = float(np.hypot(xmax - xmin, ymax - ymin)) + 1.0
            free = shapely.difference(free, shadows(s.origin, p, q, reach))
        pieces.append(free)
    union = shapely.union_all(pieces)
    polygons = [g for g in shapely.get_parts(union) if isinstance(g, shapely.Polygon) and not g.is_empty]
    return shapely.union_all(polygons) if polygons else shapely.Polygon()
