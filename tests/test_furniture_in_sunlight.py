"""Real things standing in the sunlight keep their segments: a planner trusts the map with a robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evmap.maps.app.run import run_scenario
from evmap.sources.config import load_config
from evmap.sources.geometry import point_segment_distances
from evmap.sources.sim.scenario import parse_scenario

SCENE = (Path(__file__).parent / "scenarios" / "furniture_in_sunlight.yaml").read_text()


@pytest.mark.parametrize("detector", ["threshold", "column_max"])
def test_furniture_in_the_sunlight_keeps_every_segment_it_has(detector: str) -> None:
    # The sunlit patch's false returns lie all around the desk, the chair's legs and the bin, and nothing but
    # the stripe sees the legs (too thin for the sonar, too few rays from another pose). A cue that took what
    # nothing confirms among segments shown false for false would remove them with the phantoms; the default
    # config removes most phantoms and keeps every piece of furniture.
    scenario = parse_scenario(SCENE + f"sensors: {{lsl: {{detector: {detector}}}}}\n", "furniture_in_sunlight.yaml")
    run = run_scenario(scenario, load_config("default"))
    store = run.map.segments
    noise, real = store.truth == "noise", store.truth == "real"
    assert noise.sum() >= 50 and store.eliminated[noise].mean() >= 0.7
    mid = (store.p + store.q) / 2
    surfaces = run.world.surfaces()
    desk = np.char.startswith(surfaces.segment_ids.astype(str), "desk")
    on = {"desk": point_segment_distances(mid[:, None], surfaces.p[desk][None], surfaces.q[desk][None]).min(axis=1)}
    on |= {c.id: np.abs(np.hypot(*(mid - c.center).T) - c.radius) for c in scenario.world.cylinders}
    seen = {name for name, d in on.items() if (real & (d <= 0.05)).any()}
    kept = {name for name, d in on.items() if (real & (d <= 0.05) & ~store.eliminated).any()}
    assert {"desk", "bin", "leg-1", "leg-2"} <= seen
    assert kept == seen
    assert not store.eliminated[real].any()
