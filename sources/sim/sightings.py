"""Which poses see which sunlight regions: ground truth of a scenario, for evaluation only.

A pose sees a region when the region's centroid is within the LSL's ``max_range``
of it and the line to the centroid crosses no LSL-opaque surface: exactly when
the LSL model (:mod:`evmap.sources.sim.lsl`) draws the region's phantom lines
from that pose. The evidence side never reads this.

>>> from evmap.sources.params import LslParams
>>> from evmap.sources.sim.scenario import parse_scenario
>>> world = World(parse_scenario('''
... version: 1
... name: two rooms
... world:
...   walls: [{id: w, points: [[0, 0], [0, 4]]}]
...   sunlight: [{polygon: [[1, 1], [2, 1], [2, 2], [1, 2]], lines: 3, length: [0.05, 0.2]}]
... robot: {poses: [[3, 1.5, 0], [5, 1.5, 0], [-1, 1.5, 0]]}
... ''', "two.yaml"))
>>> sunlight_sightings(world, LslParams()).tolist()
[[True], [True], [False]]
>>> seen_twice(world, LslParams()), seen_twice(world, LslParams(max_range=3))
(True, False)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evmap.sources.params import LslParams
from evmap.sources.sim.world import World, visible

__all__ = ["seen_twice", "sunlight_sightings"]


def sunlight_sightings(world: World, lsl: LslParams) -> NDArray[np.bool_]:
    """(P, S): whether pose ``p`` sees sunlight region ``s`` (see the module doc).

    ``lsl`` are the run's LSL parameters: the config's, overridden by the scenario's
    ``sensors.lsl`` (:meth:`~evmap.sources.sim.scenario.Scenario.sensor_params`).
    """
    centroids = world.sunlight_centroids
    out = np.zeros((len(world.poses), len(centroids)), dtype=bool)
    for k, (x, y, _) in enumerate(world.poses):
        near = np.hypot(*(centroids - (x, y)).T) <= lsl.max_range
        out[k] = near & visible(world.surfaces(), np.array([x, y]), centroids)
    return out


def seen_twice(world: World, lsl: LslParams) -> bool:
    """Whether some pose sees sunlight and every region seen at all is seen from two poses or more.

    A region no pose sees makes no phantom line, so it does not count.
    """
    views = sunlight_sightings(world, lsl).sum(axis=0)
    return bool(views.any() and (views[views > 0] >= 2).all())
