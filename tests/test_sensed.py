"""What the poses sensed, kept in map.json: a loaded map goes on updating as the saved one (configs/default.yaml)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from evmap import configs
from evmap.maps import BeliefMap, new_map
from evmap.maps.map_file import map_data, read_map
from evmap.maps.map_format import MapFileError
from evmap.maps.observation import observe
from evmap.maps.sensed import (
    SENSED_KEY,
    features_checkpoint,
    forget,
    keep_features,
    kept_features,
    remember,
    sensed,
    sensed_near,
)
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


def test_a_segment_is_judged_by_the_latest_poses_that_reach_it(config):
    """``sensed_near``: poses whose stripe or sonar reaches the box, the latest ``latest`` of them, by pose."""
    bm = new_map(config)
    for k, x in enumerate([0.0, 1.0, 30.0, 2.0, 3.0]):  # pose 2 is 30 m away: its 5 m rays reach nothing here
        rays = np.column_stack([np.linspace(-1, 1, 5), np.full(5, 5.0)])
        remember(
            bm, SimpleNamespace(pose_index=k, pose=np.array([x, 0.0, 0.0]), rays=rays, sonar=None, all_returns=False)
        )
    box = (0.0, -1.0, 4.0, 1.0)
    assert [s.pose_index for s in sensed_near(bm, box, 0.0, latest=10)] == [0, 1, 3, 4]
    assert [s.pose_index for s in sensed_near(bm, box, 0.0, latest=2)] == [3, 4]
    assert [s.pose_index for s in sensed_near(bm, box, 40.0, latest=10)] == [0, 1, 2, 3, 4]


def test_kept_features_follow_the_store_as_it_grows_and_go_back_with_a_checkpoint(config):
    """``keep_features`` and ``kept_features``: no evidence for rows never judged, as many rows as the store."""
    bm = new_map(config)
    store = bm.segments
    expected = []
    for k in range(40):  # a store growing a few rows at a time, each update judging some rows again
        store.append([[0.0, 0.0]] * 3, [[1.0, 0.0]] * 3, [k] * 3, [""] * 3)
        ids = np.arange(max(0, len(store) - 5), len(store) - 1)
        keep_features(bm, ids, {"sonar_forward": np.full(len(ids), f"c{k}")})
        expected[len(expected) :] = ["silent"] * (len(store) - len(expected))
        expected[ids[0] : ids[-1] + 1] = [f"c{k}"] * len(ids)
    checkpoint = features_checkpoint(bm)
    assert kept_features(bm, np.arange(len(store) + 2))["sonar_forward"].tolist() == [*expected, "silent", "silent"]
    assert kept_features(bm, np.array([1]))["contour_free"].tolist() == ["clear"]
    assert checkpoint[0] == len(store)
    store.append([[0.0, 0.0]], [[1.0, 0.0]], [40], [""])
    keep_features(bm, np.array([0, len(store) - 1]), {"sonar_forward": np.array(["x", "y"])})
    forget(bm, 40, checkpoint)
    assert kept_features(bm, np.arange(len(store)))["sonar_forward"].tolist() == [*expected, "silent"]
