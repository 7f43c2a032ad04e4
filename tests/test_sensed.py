"""What the poses sensed, kept in map.json: a loaded map goes on updating as the saved one (configs/default.yaml)."""

from __future__ import annotations

import numpy as np
import pytest

from evmap import configs
from evmap.maps import BeliefMap, new_map
from evmap.maps.map_file import map_data, read_map
from evmap.maps.map_format import MapFileError
from evmap.maps.observation import observe
from evmap.maps.sensed import SENSED_KEY, sensed
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World


@pytest.fixture(scope="module")
def config():
    return load_config(configs.path("default.yaml"))


@pytest.fixture(scope="module")
def observations(config):
    world = World(load_scenario(configs.path("scenarios/patrol.yaml")))
    return [observe(world, k, config) for k in range(3)]


def _state(bm: BeliefMap) -> tuple[dict[str, float], list]:
    lines = {line.id: line.belief for line in bm.lines(min_belief=0.0)}
    points = {p.id: p.belief for p in [*bm.corners(min_belief=0.0), *bm.unidentified(min_belief=0.0)]}
    return lines | points, bm.segments.eliminated.tolist()


def test_a_loaded_map_folds_the_next_poses_as_if_never_saved_under_the_default_config(config, observations, tmp_path):
    direct = new_map(config)
    for obs in observations:
        direct.update(obs)
    saved = new_map(config)
    saved.update(observations[0])
    saved.save(tmp_path / "map.json")
    loaded = BeliefMap.load(tmp_path / "map.json")
    assert [s.pose_index for s in sensed(loaded)] == [0]
    for obs in observations[1:]:
        loaded.update(obs)
    beliefs, eliminated = _state(loaded)
    want_beliefs, want_eliminated = _state(direct)
    assert eliminated == want_eliminated
    assert beliefs == pytest.approx(want_beliefs, abs=1e-12)
    assert np.array_equal(loaded.occupancy_grid(0.05), direct.occupancy_grid(0.05))


def test_a_map_file_without_sensed_readings_still_loads(config, observations):
    bm = new_map(config)
    bm.update(observations[0])
    data = map_data(bm)
    del data["graph"][SENSED_KEY]
    assert sensed(BeliefMap.from_parts(read_map(data))) == []


def test_a_broken_sensed_key_is_named(config, observations):
    bm = new_map(config)
    bm.update(observations[0])
    data = map_data(bm)
    data["graph"][SENSED_KEY]["poses"][0]["range"] = [1.0]
    with pytest.raises(MapFileError, match=r"graph\.sensed.*poses\[0\]: bearing and range"):
        read_map(data)
