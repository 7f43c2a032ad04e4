"""A failed update leaves the map as it was: all or nothing."""

import json
from pathlib import Path

import pytest

from evmap import configs
from evmap.maps import BeliefMap, new_map
from evmap.maps.log_observation import observation_from_log
from evmap.maps.observation import observe
from evmap.sources.config import load_config
from evmap.sources.logs import open_log
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World


def content(bm: BeliefMap) -> str:
    """The map's content, order aside (objects put back may come last)."""
    data = bm.to_data()
    data["nodes"] = sorted(data["nodes"], key=lambda d: d["id"])
    data["edges"] = sorted(data["edges"], key=lambda d: d["id"])
    return json.dumps(data, sort_keys=True)


@pytest.mark.parametrize("config_name", ["paper", "default"])
def test_a_failure_half_way_leaves_the_map_as_it_was(monkeypatch, tmp_path, config_name):
    config = load_config(config_name)
    world = World(load_scenario(configs.path("scenarios/patrol.yaml")))
    first, second = observe(world, 0, config), observe(world, 1, config)
    bm = new_map(config)
    bm.update(first)
    before = content(bm)
    with monkeypatch.context() as m:  # fail after noise elimination and the rebuild have changed the map
        m.setattr("evmap.maps.pipeline.reinforce", lambda *a: (_ for _ in ()).throw(RuntimeError("half-way")))
        with pytest.raises(RuntimeError, match="half-way"):
            bm.update(second)
    assert content(bm) == before and bm.poses == (0,)
    again = bm.update(second)  # and the same pose folds as if the failure never happened
    direct = new_map(config)
    direct.update(first)
    direct.update(second)
    assert content(bm) == content(direct) and again.pose_index == 1
    bm.save(tmp_path / "map.json")
    assert content(BeliefMap.load(tmp_path / "map.json")) == content(direct)


def test_a_failure_half_way_through_a_log_leaves_the_map_as_it_was(monkeypatch):
    """Later in a log: consolidated lines, rows of earlier scans judged again and merged anew; what the failed
    update wrote to them (the store's journal, the sensed features') is put back, not the whole store."""
    config = load_config()
    log = Path(__file__).parent / "data" / "logs" / "intel-excerpt.log.gz"
    observations = [observation_from_log(r, config, k) for k, r in enumerate(open_log(log))][:12]
    bm = new_map(config)
    for obs in observations[:-1]:
        bm.update(obs)
    assert (bm.segments.role == "support").any()
    before = content(bm)
    with monkeypatch.context() as m:  # fail after noise elimination and the rebuild have changed the map
        m.setattr("evmap.maps.pipeline.refresh_points", lambda *a: (_ for _ in ()).throw(RuntimeError("half-way")))
        with pytest.raises(RuntimeError, match="half-way"):
            bm.update(observations[-1])
    assert content(bm) == before
    bm.update(observations[-1])
    direct = new_map(config)
    for obs in observations:
        direct.update(obs)
    assert content(bm) == content(direct)


def test_a_failure_half_way_through_the_first_scan_or_the_corners_join_leaves_the_map_as_it_was(monkeypatch):
    """The first scan of a log without sonar starts deferring the corners: failing half-way, it leaves the
    map empty, not deferring; a join of the corners that fails leaves them deferred, the ends free."""
    config = load_config()
    log = Path(__file__).parent / "data" / "logs" / "intel-excerpt.log.gz"
    first, second = [observation_from_log(r, config, k) for k, r in enumerate(open_log(log))][:2]
    bm = new_map(config)
    before = content(bm)
    with monkeypatch.context() as m:
        m.setattr("evmap.maps.pipeline.refresh_points", lambda *a: (_ for _ in ()).throw(RuntimeError("half-way")))
        with pytest.raises(RuntimeError, match="half-way"):
            bm.update(first)
    assert content(bm) == before and not bm.corners_deferred
    bm.update(first)
    bm.update(second)
    assert bm.corners_deferred
    before = content(bm)
    with monkeypatch.context() as m:
        m.setattr("evmap.maps.rebuild.refresh_points", lambda *a: (_ for _ in ()).throw(RuntimeError("half-way")))
        with pytest.raises(RuntimeError, match="half-way"):
            bm.join_corners()
    assert content(bm) == before and bm.corners_deferred and not bm.corners(min_belief=0)
    assert bm.join_corners() and bm.corners(min_belief=0) and not bm.corners_deferred


def test_nested_transactions_leave_it_to_the_outer_one():
    bm = BeliefMap(["real", "noise"])
    m = bm.vacuous()
    with pytest.raises(KeyError), bm.transaction():
        bm.add_point("A", (0, 0), "corner", m)
        with bm.transaction():
            bm.add_point("B", (1, 0), "corner", m)
        bm.add_line("L1", "A", "B", m)
        bm.fold("L1", m, {"pose": 0})
        bm.set_attrs("A", reinforced=True)
        bm.remove_line("L9")  # no such line
    assert len(bm) == 0 and not list(bm.near((-1, -1, 2, 2)))
