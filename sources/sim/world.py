"""The simulated world of a scenario, and what its surfaces hide from a point.

A :class:`World` is a validated :class:`~evmap.sources.sim.scenario.Scenario` resolved into
arrays: materials looked up, walls joined into :class:`~evmap.sources.sim.surfaces.Surfaces`
(the ground truth the sensors measure, and what evaluation compares against),
poses in radians, sunlight regions.

Ids. Point ``k`` of wall ``W`` is vertex ``"W:pk"``; points of different walls (or
of one wall) that coincide within :data:`VERTEX_TOLERANCE` are one vertex, named
after its first occurrence in the file, so two walls that meet make a corner.
Segment ``k`` (from point ``k`` to ``k + 1``) of wall ``W`` is ``"W:k"``, or just
``"W"`` when the wall has one segment, so no vertex and segment share an id (a
sonar reading's target tells a corner from a wall). A cylinder keeps its id.
Scenario ids hold no ``:``, so :func:`wall_id` maps a segment or vertex id back to its wall.

>>> from evmap.sources.sim.scenario import parse_scenario
>>> world = World(parse_scenario('''
... version: 1
... name: corner
... world:
...   walls:
...     - {id: south, points: [[0, 0], [4, 0]]}
...     - {id: east, points: [[4, 0], [4, 3], [3, 3]], material: glass}
... robot: {poses: [[1, 1, 90]]}
... ''', "corner.yaml"))
>>> s = world.surfaces()
>>> s.segment_ids.tolist(), s.vertex_ids.tolist(), s.lsl_opaque.tolist()
(['south', 'east:0', 'east:1'], ['south:p0', 'south:p1', 'east:p1', 'east:p2'], [True, False, False])
>>> s.vertex_degree().tolist()
[1, 2, 2, 1]
>>> world.poses.round(4).tolist()
[[1.0, 1.0, 1.5708]]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.clusters import close_pairs, component_labels
from evmap.sources.geometry import crossings, point_segment_distances
from evmap.sources.sim.scenario import Material, Scenario, Sunlight
from evmap.sources.sim.surfaces import Surfaces

__all__ = ["VERTEX_TOLERANCE", "World", "visible", "wall_id"]

VERTEX_TOLERANCE = 1e-9
"""Wall points closer than this (m) are one vertex."""


def wall_id(object_id: str) -> str:
    """The id of the wall (or cylinder) a segment or vertex id belongs to.

    >>> wall_id("south:3"), wall_id("east-window"), wall_id("pillar")
    ('south', 'east-window', 'pillar')
    """
    return object_id.partition(":")[0]


class World:
    """A scenario's world as arrays.

    Attributes
    ----------
    scenario : the validated scenario.
    name : str; seed : int, the root of all randomness.
    materials : dict of material name to :class:`~evmap.sources.sim.scenario.Material`, built-ins overridden.
    poses : (P, 3) float array of ``x, y, heading`` (metres, radians).
    sunlight : tuple of the scenario's :class:`~evmap.sources.sim.scenario.Sunlight` regions.
    sunlight_centroids : (S, 2) float array, each region's polygon centroid.
    """

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.name = scenario.name
        self.seed = scenario.seed
        self.materials: dict[str, Material] = scenario.resolved_materials()
        poses = np.array(scenario.robot.poses, dtype=float).reshape(-1, 3)
        poses[:, 2] = np.radians(poses[:, 2])
        self.poses: NDArray[np.float64] = poses
        self.sunlight: tuple[Sunlight, ...] = tuple(scenario.world.sunlight)
        self.sunlight_centroids: NDArray[np.float64] = np.array(
            [_centroid(np.array(region.polygon, dtype=float)) for region in self.sunlight]
        ).reshape(-1, 2)
        self._surfaces = self._build_surfaces()

    def __repr__(self) -> str:
        s = self._surfaces
        return (
            f"World({self.name!r}: {len(s.segments)} segments, {len(s.cylinder_ids)} cylinders, "
            f"{len(self.sunlight)} sunlight regions, {len(self.poses)} poses)"
        )

    def surfaces(self) -> Surfaces:
        """The true walls and cylinders, with each one's sensor flags (see the module doc for ids)."""
        return self._surfaces

    def _build_surfaces(self) -> Surfaces:
        walls = self.scenario.world.walls
        points = np.array([xy for wall in walls for xy in wall.points], dtype=float).reshape(-1, 2)
        point_ids = np.array([f"{wall.id}:p{k}" for wall in walls for k in range(len(wall.points))], dtype=str)
        # one vertex per cluster of coinciding points, kept at its first point
        cluster = component_labels(len(points), *close_pairs(points, VERTEX_TOLERANCE))
        first_of_cluster = np.full(cluster.max(initial=-1) + 1, len(points))
        np.minimum.at(first_of_cluster, cluster, np.arange(len(points)))
        keep = np.sort(first_of_cluster)
        vertex_of_point = np.searchsorted(keep, first_of_cluster[cluster])

        # a segment starts at every point but the last of its wall
        is_last = np.zeros(len(points), dtype=bool)
        is_last[np.cumsum([len(wall.points) for wall in walls], dtype=np.intp) - 1] = True
        first = np.flatnonzero(~is_last)
        segment_ids = [
            wall.id if len(wall.points) == 2 else f"{wall.id}:{k}"
            for wall in walls
            for k in range(len(wall.points) - 1)
        ]
        segment_material = [self.materials[wall.material] for wall in walls for _ in range(len(wall.points) - 1)]
        cylinders = self.scenario.world.cylinders
        cylinder_material = [self.materials[c.material] for c in cylinders]
        return Surfaces(
            vertices=points[keep],
            vertex_ids=point_ids[keep],
            segments=np.column_stack([vertex_of_point[first], vertex_of_point[first + 1]]).reshape(-1, 2),
            segment_ids=np.array(segment_ids, dtype=str),
            lsl_opaque=np.array([m.lsl == "opaque" for m in segment_material], dtype=bool),
            sonar_reflective=np.array([m.sonar == "specular" for m in segment_material], dtype=bool),
            cylinder_centers=np.array([c.center for c in cylinders], dtype=float).reshape(-1, 2),
            cylinder_radii=np.array([c.radius for c in cylinders], dtype=float),
            cylinder_ids=np.array([c.id for c in cylinders], dtype=str),
            cylinder_lsl_opaque=np.array([m.lsl == "opaque" for m in cylinder_material], dtype=bool),
            cylinder_sonar_reflective=np.array([m.sonar == "specular" for m in cylinder_material], dtype=bool),
        )


_ON_TARGET = 1e-9
"""Relative tolerance of :func:`visible`: a surface this close to the target does not hide it."""


def _centroid(polygon: NDArray[np.float64]) -> NDArray[np.float64]:
    """Area centroid of a simple polygon given by its vertices (shoelace formula).

    Computed relative to the first vertex: on absolute coordinates the cross products
    cancel catastrophically far from the origin (12 m off at 1e6 m for a 3 m region).

    >>> _centroid(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]) + 1e6).tolist()
    [1000001.0, 1000000.5]
    """
    origin = polygon[0]
    x, y = (polygon - origin).T
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area3 = 3 * cross.sum()
    return origin + np.array([((x + xn) * cross).sum() / area3, ((y + yn) * cross).sum() / area3])


def visible(surfaces: Surfaces, origin: ArrayLike, targets: ArrayLike) -> NDArray[np.bool_]:
    """Whether the straight line from ``origin`` to each target crosses no LSL-opaque surface.

    A surface through the origin or through the target itself (within a relative
    1e-9 of the distance or radius) does not hide it; transparent surfaces never do.

    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> world = World(parse_scenario('''
    ... {version: 1, name: v, robot: {poses: [[0, 0, 0]]},
    ...  world: {walls: [{id: a, points: [[1, -1], [1, 1]]}, {id: g, points: [[-1, -1], [-1, 1]], material: glass}]}}
    ... ''', "v.yaml"))
    >>> visible(world.surfaces(), [0, 0], [[2, 0], [-2, 0], [0.5, 0], [1, 0]]).tolist()
    [False, True, True, True]
    """
    o = np.asarray(origin, dtype=float)
    d = np.asarray(targets, dtype=float).reshape(-1, 2) - o
    opaque = surfaces.lsl_opaque
    p, q = surfaces.p[opaque], surfaces.q[opaque]
    t, s = crossings(o, d[:, None], p, q - p)  # (M, N)
    blocked = ((t > 0) & (t < 1 - _ON_TARGET) & (s >= 0) & (s <= 1)).any(axis=1)

    c = surfaces.cylinder_centers[surfaces.cylinder_lsl_opaque] - o
    r = surfaces.cylinder_radii[surfaces.cylinder_lsl_opaque]
    gap = point_segment_distances(c, np.zeros(2), d[:, None])  # (M, K): the sight line to each centre
    blocked |= (gap < r * (1 - _ON_TARGET)).any(axis=1)
    return ~blocked
