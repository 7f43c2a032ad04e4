"""Which poses see which sunlight regions: the same rule as the LSL's phantom lines."""

from __future__ import annotations

import numpy as np

from evmap.sources.params import LslParams
from evmap.sources.sim.lsl import observe_lsl
from evmap.sources.sim.sightings import seen_twice, sunlight_sightings
from evmap.sources.sim.world import World
from evmap.sources.sim.worldgen import generate_world, world_seed


def test_a_pose_sees_a_region_exactly_when_it_gets_its_phantom_lines():
    lsl = LslParams()
    twice = []
    for i in range(12):
        world = World(generate_world(world_seed(11, i)))
        sightings = sunlight_sightings(world, lsl)
        lines = np.array([region.lines for region in world.sunlight])
        assert sightings.shape == (len(world.poses), len(world.sunlight))
        assert sightings[0].any()  # the first pose sees a region
        for k in range(len(world.poses)):
            phantoms = int((observe_lsl(world, k, lsl).truth == "noise").sum())
            assert phantoms == lines[sightings[k]].sum(), (world.name, k)
        twice.append(seen_twice(world, lsl))
        views = sightings.sum(axis=0)
        assert twice[-1] == bool(((views >= 2) | (views == 0)).all())
    assert any(twice) and not all(twice)
