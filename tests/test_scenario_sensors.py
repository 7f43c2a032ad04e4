"""A scenario's own sensors (its ``sensors`` section) are the sensors the map's evidence reads the scans with.

The scans of a scenario are simulated with the config's sensor parameters overridden by the
scenario's; the map must judge them with the same (a stripe's range noise sets how close a point
must be to a segment to end on it, its range how far a ray that returned nothing says the space
is free). Before, the map kept the config's defaults: a scenario with a noisier stripe lost real
walls to their own points (office: 2 of 49), one with a shorter stripe lost walls beyond it to
rays that returned nothing (patrol: 5 of 62).
"""

from __future__ import annotations

import pytest
import yaml

from evmap import configs
from evmap.maps import BeliefMap
from evmap.maps.app.compare_metrics import fuse_configs
from evmap.maps.app.run import report, run_scenario
from evmap.maps.map_file import write_map
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import parse_scenario


def _scenario(name: str, sensors: dict[str, dict[str, float]]):
    data = yaml.safe_load(configs.path(f"scenarios/{name}.yaml").read_text())
    for sensor, keys in sensors.items():
        data.setdefault("sensors", {}).setdefault(sensor, {}).update(keys)
    return parse_scenario(yaml.safe_dump(data), f"{name}.yaml")


@pytest.mark.parametrize(
    ("name", "lsl"), [("office", {"range_noise": 0.01}), ("patrol", {"max_range": 5.0})], ids=["noisier", "shorter"]
)
def test_walls_of_a_scenario_with_its_own_stripe_are_kept(name, lsl):
    run = run_scenario(_scenario(name, {"lsl": lsl}), load_config("default"))
    for key, value in lsl.items():
        assert getattr(run.config.sensors.lsl, key) == value
        assert getattr(run.map.config.sensors.lsl, key) == value
    assert report(run)["real_loss"] == 0.0


def test_the_map_file_keeps_the_scenario_sensors(tmp_path):
    sensors = {"lsl": {"max_range": 6.0, "range_noise": 0.004}, "sonar": {"beam_width_deg": 30.0}}
    run = run_scenario(_scenario("office", sensors), load_config("default"))
    write_map(run.map, tmp_path / "map.json")
    loaded = BeliefMap.load(tmp_path / "map.json").config.sensors
    assert (loaded.lsl.max_range, loaded.lsl.range_noise, loaded.sonar.beam_width_deg) == (6.0, 0.004, 30.0)


def test_a_comparison_judges_with_the_scenario_sensors():
    scenario = _scenario("office", {"lsl": {"range_noise": 0.01}})
    runs = fuse_configs(scenario, {"paper": load_config("paper"), "default": load_config("default")}, ["dempster"])
    assert {run.config.sensors.lsl.range_noise for run in runs.values()} == {0.01}
    assert {run.config.name for run in runs.values()} == {load_config("paper").name, load_config("default").name}
