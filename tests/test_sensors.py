"""Sensors declared in YAML: the kinds' features, the simulators, readings from arrays and logs, the examples."""

import dataclasses
import json
import re
import textwrap
from typing import Literal

import numpy as np
import pytest
import yaml
from pinned_worlds import former

from evmap import configs
from evmap.maps import new_map
from evmap.maps.app.cli import main
from evmap.maps.app.figures.sensors import sensor_features_figure
from evmap.maps.app.run import run_scenario
from evmap.maps.observation import observation_from_arrays, observe
from evmap.sources.config import config_from_data, load_config
from evmap.sources.loading import InputError
from evmap.sources.open_space import open_space
from evmap.sources.plugins import sensor_kinds
from evmap.sources.rcd import extract_rcds
from evmap.sources.relation import relation
from evmap.sources.sensor_kinds import (
    SENSOR_KINDS,
    check_sensor_kind,
    features_from_arrays,
    read_readings,
    register_sensor_kind,
)
from evmap.sources.sim.lsl import observe_lsl
from evmap.sources.sim.scenario import default_scenario
from evmap.sources.sim.sensor_models import BUILTIN_SENSOR_KINDS, sensor_rng
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.world import World
from evmap.sources.sim.worldgen import generate_world

EXAMPLES = sorted(p.name for p in configs.path("examples").glob("*.yaml"))
SONAR_AS_RANGE = {
    "kind": "range",
    "beams": 360,
    "spacing_deg": 1.0,
    "cone_deg": 25.0,
    "max_range": 10.0,
    "free_space": "rcd",
    "echo": ["wall", "glass", "mirror"],
}


def with_sensors(sensors, name="test"):
    """The infrared example with other extra_sensors."""
    data = load_config(configs.path("examples/infrared.yaml")).to_data()
    return config_from_data({**data, "extra_sensors": sensors}, name)


def test_the_sonar_as_a_range_sensor_gives_table_1s_relation():
    world, cfg = World(default_scenario()), load_config()
    scan = simulate_scan(world.surfaces(), world.poses[0], cfg.sensors.sonar, rng=np.random.default_rng(1))
    lsl = observe_lsl(world, 0, cfg.sensors.lsl)
    built_in = relation(lsl.p, lsl.q, open_space(scan, extract_rcds(scan, cfg.rcd, primitive=True), cfg.open_space))
    sonar = with_sensors({"sonar": SONAR_AS_RANGE}).extra_sensors["sonar"]
    readings = {"pose": scan.pose, "angles": scan.angles, "ranges": np.where(scan.order == 0, np.inf, scan.ranges)}
    got = sonar.features(readings, lsl.p, lsl.q)["sonar_relation"]
    assert got.tolist() == built_in.tolist()
    assert {"inside", "outside"} <= set(got.tolist())


def test_a_range_ring_sees_walls_and_lets_glass_pass():
    world = World(default_scenario())
    ir = load_config(configs.path("examples/infrared.yaml")).extra_sensors["ir"]
    lsl = observe_lsl(world, 0, load_config().sensors.lsl)
    readings = ir.kind.simulate(world, 0, ir.spec, sensor_rng(world, 0, "ir"), lsl)
    assert readings["angles"].shape == readings["ranges"].shape == (36,)
    assert np.isfinite(readings["ranges"]).any() and (readings["ranges"][np.isfinite(readings["ranges"])] <= 3).all()
    got = ir.features(readings, lsl.p, lsl.q)["ir_return"]
    real = lsl.truth == "real"
    assert (got[real] != "beyond").mean() > 0.9  # beams end on walls, not beyond them
    assert "echo" in got[real].tolist()


def test_simulated_readings_follow_the_seed_rule():
    world = World(generate_world(3, former()))
    kind = sensor_kinds()["detector"]
    spec = kind.spec.model_validate({"kind": "detector", "materials": ["wall"], "false_alarms": [[0, 0.5], [4, 0.5]]})
    lsl = observe_lsl(world, 0, load_config().sensors.lsl)
    first = kind.simulate(world, 0, spec, sensor_rng(world, 0, "radar"), lsl)
    again = kind.simulate(world, 0, spec, sensor_rng(world, 0, "radar"), lsl)
    other = kind.simulate(world, 0, spec, sensor_rng(world, 0, "radar2"), lsl)
    assert np.array_equal(first["points"], again["points"])
    assert not np.array_equal(first["points"], other["points"])


SECTIONS = {
    "range": {"kind": "range", "beams": 8, "cone_deg": 10, "max_range": 2.0},
    "detector": {"kind": "detector", "materials": ["wall"]},
    "contour_property": {"kind": "contour_property", "property": "w", "values": {"wall": [3, 1], "sunlight": [8, 2]}},
}


@pytest.mark.parametrize("name", sorted(SECTIONS))
def test_sensor_kind_conformance(name):
    """Every simulated kind: one valid value per segment, deterministic, one segment alone as in the batch."""
    world = World(default_scenario())
    kind = sensor_kinds()[name]
    sensor = with_sensors({"s": SECTIONS[name]}).extra_sensors["s"]
    lsl = observe_lsl(world, 0, load_config().sensors.lsl)
    readings = kind.simulate(world, 0, sensor.spec, sensor_rng(world, 0, "s"), lsl)
    batch = sensor.features(readings, lsl.p, lsl.q)
    assert set(batch) == set(sensor.declares())
    for feature, values in batch.items():
        assert values.shape == (len(lsl),)
        assert np.array_equal(values, sensor.features(readings, lsl.p, lsl.q)[feature])
        for i in range(0, len(lsl), 7):
            assert sensor.features(readings, lsl.p[i : i + 1], lsl.q[i : i + 1])[feature][0] == values[i]


def test_readings_from_a_log_give_the_features_of_the_run(tmp_path):
    """The same arrays, saved as a log and read back, make the same observation features as the simulation."""
    world, cfg = World(default_scenario()), load_config(configs.path("examples/radar.yaml"))
    obs = observe(world, 0, cfg)
    radar = cfg.extra_sensors["radar"]
    readings = radar.kind.simulate(world, 0, radar.spec, sensor_rng(world, 0, "radar"), obs.lsl)
    np.savez(tmp_path / "pose0.npz", **{f"radar/{k}": v for k, v in readings.items()})
    features = features_from_arrays(cfg.extra_sensors, read_readings(tmp_path / "pose0.npz"), obs.lsl.p, obs.lsl.q)
    assert features["radar_detection"].tolist() == np.asarray(obs.features["radar_detection"]).tolist()


def test_bad_readings_and_sections_are_refused_by_name():
    cfg = load_config(configs.path("examples/radar.yaml"))
    with pytest.raises(ValueError, match=r"sensor 'radar': readings 'points' must have shape \('D', 2\)"):
        features_from_arrays(
            cfg.extra_sensors, {"radar": {"pose": np.zeros(3), "points": np.zeros(4)}}, [[0, 0]], [[1, 0]]
        )
    with pytest.raises(ValueError, match=r"missing \['radar'\]"):
        features_from_arrays(cfg.extra_sensors, {}, [[0, 0]], [[1, 0]])
    with pytest.raises(InputError, match=r"extra_sensors\.ir\.kind: unknown sensor kind 'lidar'"):
        with_sensors({"ir": {"kind": "lidar"}})
    with pytest.raises(InputError, match=r"extra_sensors\.ir\.cone_deg"):
        with_sensors({"ir": {"kind": "range", "cone_deg": -1}})
    with pytest.raises(InputError, match=r"sources\.infrared\.categories: feature 'ir_return' takes the categories"):
        data = load_config(configs.path("examples/infrared.yaml")).to_data()
        data["sources"]["infrared"]["categories"] = ["echo", "beyond"]
        data["sources"]["infrared"]["table"].pop("no_return")
        config_from_data(data, "x")


@pytest.mark.parametrize(
    ("section", "where"),
    [
        ({"kind": "range", "beams": True}, r"ir\.beams: Input should be a valid integer \(got True\)"),  # was 1 beam
        ({"kind": "range", "max_range": "10"}, r"ir\.max_range: Input should be a valid number \(got '10'\)"),
        ({"kind": "range", "inside_fraction": 0.1, "outside_fraction": 0.9}, r"ir: outside_fraction \(0\.9\) must"),
        ({"kind": "range", "echo": ["wall"], "absorb": ["wall"]}, r"ir: material 'wall' is in both echo and absorb"),
        ({"kind": "detector", "materials": ["wall"], "detection": [["0", 0.9]]}, r"ir\.detection\[0\]\[0\]: Input"),
        ({"kind": "detector", "materials": ["wall"], "detection": [[1, 0.9], [0, 0.8]]}, r"ir\.detection: ranges"),
    ],
)
def test_a_sensor_section_is_read_strictly_and_its_errors_name_the_key(section, where):
    """A bool or a string as a number was taken (``beams: true``: one beam), crossed fractions and a material
    both echoing and absorbing passed, and a detector's table errors named the section, not the table."""
    with pytest.raises(InputError, match=rf"extra_sensors\.{where}"):
        with_sensors({"ir": section})
    assert with_sensors({"ir": {"kind": "detector", "materials": ["wall"], "detection": [[0, 1], [2, 0.5]]}})


def test_builtin_kinds_are_registered_once():
    assert {"range", "detector", "contour_property"} <= set(SENSOR_KINDS)


@pytest.mark.parametrize("example", EXAMPLES)
def test_every_example_config_runs_end_to_end(example, tmp_path, capsys):
    """Each example passes config check, runs, and its sensor takes part: the report and segments.json carry
    its features, which tell segments apart, and the masses of noise elimination differ from the paper's."""
    path = configs.path(f"examples/{example}")
    assert main(["config", "check", str(path)]) == 0  # what check passes, run can use (issue 16)
    capsys.readouterr()
    assert main(["run", "--config", str(path), "--out", str(tmp_path), "--no-figures", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["noise_eliminated"] == summary["noise_segments"] == 28 and summary["real_eliminated"] == 0
    cfg = load_config(path)
    read = {cfg.sources[name].feature for name in cfg.stages["noise_elimination"]}
    assert set(summary["sensors"]) == set(cfg.extra_sensors)
    for name, sensor in cfg.extra_sensors.items():
        assert summary["sensors"][name]["kind"] == sensor.kind.name
        for feature, categories in sensor.declares().items():
            tally = summary["sensors"][name]["features"][feature]
            if categories:
                assert sum(tally["segments"].values()) == summary["lsl_segments"]
                assert sum(tally["phantoms"].values()) == 28
                distinct = sum(count > 0 for count in tally["segments"].values())
            else:
                distinct = 2 if tally["segments"]["min"] < tally["segments"]["max"] else 1
            if feature in read:
                assert distinct >= 2, f"{feature} says the same of every segment: it cannot take part"
    records = json.loads((tmp_path / "segments.json").read_text())
    declared = {f for sensor in cfg.extra_sensors.values() for f in sensor.declares()}
    assert all(set(r["features"]) == declared for r in records)
    paper = run_scenario(default_scenario(), load_config("paper")).map.segments
    mass = np.array([[r["mass"].get(k, 0.0) for k in ("real", "noise", "real|noise")] for r in records])
    assert mass.shape == (len(paper), 3) and not np.allclose(mass, paper.mass[:, 1:])


def test_the_sensor_figure_shows_each_feature_with_the_reports_counts(tmp_path, capsys):
    path = str(configs.path("examples/radar.yaml"))
    assert main(["run", "--config", path, "--out", str(tmp_path / "radar"), "--json", "--figures", "png"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (tmp_path / "radar" / "fig8_sensor_features.png").stat().st_size > 10_000
    fig = sensor_features_figure(run_scenario(default_scenario(), load_config(path)))
    counts = summary["sensors"]["radar"]["features"]["radar_detection"]["segments"]
    written = ", ".join(f"{category} {n}" for category, n in counts.items())
    assert fig.axes[0].get_title(loc="left").splitlines()[1] == f"of {summary['lsl_segments']} segments: {written}"
    assert {c.get_gid() for c in fig.axes[0].collections} >= {"radar_detection-detected", "radar_detection-missed"}
    assert main(["run", "--out", str(tmp_path / "plain"), "--figures", "png"]) == 0
    assert not (tmp_path / "plain" / "fig8_sensor_features.png").exists()  # no YAML sensor, no such figure


@pytest.mark.parametrize("example", ["infrared.yaml", "stripe_width.yaml"])
def test_an_example_sensor_changes_noise_elimination_on_a_generated_world(example):
    world = generate_world(1016, former())  # its tour passes sunlight within the infrared ring's 3 m
    paper = run_scenario(world, load_config()).map.segments
    extra = run_scenario(world, load_config(configs.path(f"examples/{example}"))).map.segments
    noise = paper.truth == "noise"
    assert (extra.eliminated & noise).sum() > (paper.eliminated & noise).sum()


def test_one_call_builds_an_observation_from_arrays_with_the_features_of_the_simulation():
    """The readings a run simulates, given as arrays to observation_from_arrays, give the run's features."""
    world, cfg = World(default_scenario()), load_config(configs.path("examples/radar.yaml"))
    obs = observe(world, 0, cfg)
    radar = cfg.extra_sensors["radar"]
    readings = radar.kind.simulate(world, 0, radar.spec, sensor_rng(world, 0, "radar"), obs.lsl)
    segments = np.stack([obs.lsl.p, obs.lsl.q], axis=1)
    sonar = (obs.sonar.angles, obs.sonar.ranges)
    again = observation_from_arrays(cfg, 0, obs.pose, segments, sensors={"radar": readings}, sonar=sonar)
    assert again.features["radar_detection"].tolist() == np.asarray(obs.features["radar_detection"]).tolist()
    assert {"detected", "missed"} <= set(again.features["radar_detection"].tolist())
    assert np.array_equal(again.sonar.ranges, obs.sonar.ranges) and np.array_equal(again.pose, obs.pose)
    assert set(again.lsl.truth.tolist()) == {""}  # arrays carry no ground truth
    outcome = new_map(cfg).update(again)
    assert len(outcome.segments) == len(obs.lsl)


def test_observation_from_arrays_refuses_wrong_arrays_by_name():
    cfg = load_config(configs.path("examples/infrared.yaml"))
    wall = [[[3.0, -0.5], [3.0, 2.5]]]
    ir = {"pose": [1, 1, 0], "angles": [0.0, 0.1], "ranges": [2.0, np.inf]}
    with pytest.raises(ValueError, match=r"missing \['ir'\]"):
        observation_from_arrays(cfg, 0, [1, 1, 0], wall)
    with pytest.raises(ValueError, match=r"sensor 'ir': readings 'ranges' must have shape \('B',\), got \(1,\)"):
        observation_from_arrays(cfg, 0, [1, 1, 0], wall, sensors={"ir": {**ir, "ranges": [2.0]}})
    for ranges, dtype in [(["2.0", "inf"], "<U3"), ([True, False], "bool"), ([2 + 0j, 1j], "complex128")]:
        with pytest.raises(
            ValueError, match=f"sensor 'ir': readings 'ranges' must be real numbers, got an array of {dtype}"
        ):
            observation_from_arrays(cfg, 0, [1, 1, 0], wall, sensors={"ir": {**ir, "ranges": ranges}})
    with pytest.raises(ValueError, match=r"segments must be an \(N, 2, 2\) array"):
        observation_from_arrays(cfg, 0, [1, 1, 0], wall[0], sensors={"ir": ir})
    with pytest.raises(ValueError, match=r"sonar: angles \(3,\) and ranges \(2,\)"):
        observation_from_arrays(cfg, 0, [1, 1, 0], wall, sensors={"ir": ir}, sonar=([0, 1, 2], [1, 1]))
    with pytest.raises(ValueError, match=r"robot_pose must be three finite numbers"):
        observation_from_arrays(cfg, 0, [1, np.nan, 0], wall, sensors={"ir": ir})
    with pytest.raises(ValueError, match=r"segment 0 has zero length: p == q == \[3.0, 1.0\]"):
        observation_from_arrays(cfg, 0, [1, 1, 0], [[[3.0, 1.0], [3.0, 1.0]]], sensors={"ir": ir})
    for rays, problem in [
        ([[0.0, -1.0]], r"rays\[0\] = \[0.0, -1.0\]: a finite bearing and a range >= 0 m, or NaN"),
        ([[0.0, 1.0], [np.nan, 1.0]], r"rays\[1\] = \[nan, 1.0\]"),
        ([[0.0, 1.0, 2.0]], r"rays must be a \(K, 2\) array of \[bearing \(rad\), range \(m\)\], got shape \(1, 3\)"),
    ]:
        with pytest.raises(ValueError, match=problem):
            observation_from_arrays(cfg, 0, [1, 1, 0], wall, sensors={"ir": ir}, rays=rays)
    alone = observation_from_arrays(cfg, 0, [1, 1, 0], wall, sensors={"ir": ir}, rays=[[0.0, np.nan], [0.1, 2.0]])
    assert alone.sonar is None and alone.features["ir_return"].tolist() == ["echo"]
    assert alone.rays is not None and alone.rays.shape == (2, 2)


def test_the_python_examples_of_the_sensor_readme_run_as_written():
    """Every ```python block of configs/examples/README.md runs (the arrays example asserts its own results)."""
    text = configs.path("examples/README.md").read_text()
    blocks = [textwrap.dedent(b) for b in re.findall(r"^ *```python\n(.*?)^ *```", text, re.DOTALL | re.MULTILINE)]
    assert any("observation_from_arrays" in b for b in blocks)
    for block in blocks:
        exec(compile(block, "configs/examples/README.md", "exec"), {"__name__": "readme_example"})  # noqa: S102 - the README's own code


def test_a_material_the_world_lacks_is_refused_naming_the_file_and_key_path(tmp_path, capsys):
    """A misspelt material (`echo: [glas]`) would be a material nothing is made of: the run refuses it."""
    text = configs.path("examples/infrared.yaml").read_text()
    (tmp_path / "typo.yaml").write_text(text.replace("echo: [wall, foam]", "echo: [wall, fome]"))
    assert main(["run", "--config", str(tmp_path / "typo.yaml"), "--out", str(tmp_path / "o"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert (
        f"{tmp_path / 'typo.yaml'}: extra_sensors.ir.echo: 'fome' is not a material of the scenario 'corridor'" in err
    )
    assert not (tmp_path / "o").exists()
    data = load_config(configs.path("examples/stripe_width.yaml")).to_data()
    values = data["extra_sensors"]["stripe"]["values"]
    assert "wall" in values and "sunlight" in values  # the example states a distribution per material
    data["extra_sensors"]["stripe"]["values"] = {k: v for k, v in values.items() if k != "wall"}
    with pytest.raises(ValueError, match=r"^x: extra_sensors\.stripe: values: no \[mean, std\] for the materials"):
        observe(World(default_scenario()), 0, config_from_data(data, "x"))


def test_config_check_prints_each_sensor_as_understood(capsys):
    """Every key with its default filled in, the readings it needs, and which source reads each feature."""
    assert main(["config", "check", str(configs.path("examples/infrared.yaml"))]) == 0
    out = capsys.readouterr().out
    assert "\nsensor ir (kind range, builtin; simulated in a scenario): ring of 12 IR rangers" in out
    assert " beams=12 " in out and " rays=5 " in out and " echo=[wall, foam] absorb=[] " in out  # rays: a default
    assert "  readings: pose (3,), angles (B,), ranges (B,)\n" in out
    assert "ir_relation ['outside', 'partly_inside', 'inside'] read by no source" in out
    assert "ir_return ['echo', 'beyond', 'no_return'] read by infrared\n" in out


def test_evmap_sources_lists_each_sensor_kinds_readings_and_keys(capsys):
    assert main(["sources"]) == 0
    out = capsys.readouterr().out
    assert "    readings: pose (3,), points (D, 2)\n" in out
    assert "      materials: materials of the objects reported (required)\n" in out
    assert "      detection: [range, P(detect)], range increasing (default [[0.0, 0.9], [4.0, 0.6]])\n" in out
    assert "      echo: materials that return an echo (default [wall, foam])\n" in out
    assert "      property: the property's name; the feature is NAME_PROPERTY (required)\n" in out
    for kind in sensor_kinds().values():  # every key of every kind is listed
        for key in set(kind.spec.model_fields) - {"kind"}:
            assert f"\n      {key}: " in out


def _kind_with(features, name="flaky"):
    """The detector kind under another name, with other features."""
    detector = sensor_kinds()["detector"]
    spec = type("FlakySpec", (detector.spec,), {"__annotations__": {"kind": Literal[name]}})
    example = {**detector.example, "kind": name}
    return dataclasses.replace(detector, name=name, spec=spec, features=features, example=example)


@pytest.mark.parametrize("kind", BUILTIN_SENSOR_KINDS, ids=lambda kind: kind.name)
def test_every_built_in_sensor_kind_passes_the_checks_a_registered_kind_passes(kind):
    check_sensor_kind(kind)  # registered at import without them, so that evmap starts fast
    assert SENSOR_KINDS[kind.name] is kind


def test_a_sensor_kind_that_fails_the_sensor_checks_is_refused_at_registration_by_name():
    rng = np.random.default_rng(0)
    flaky = _kind_with(lambda spec, readings, p, q: {"detection": rng.choice(["detected", "missed"], len(p))})
    with pytest.raises(ValueError, match=r"sensor kind 'flaky' fails the sensor checks: feature 'x_detection' differs"):
        register_sensor_kind(flaky)
    wrong = _kind_with(lambda spec, readings, p, q: {"detection": np.full(len(p), "seen")}, "wrong")
    with pytest.raises(
        ValueError, match=r"sensor kind 'wrong' fails .* has value 'seen' \(segment 0\); its categories"
    ):
        register_sensor_kind(wrong)

    def batch_only(spec, readings, p, q):
        return {"detection": np.where(np.arange(len(p)) == 0, "detected", "missed")}

    with pytest.raises(ValueError, match=r"feature 'x_detection' of segment 1 is 'detected' alone but 'missed'"):
        register_sensor_kind(_kind_with(batch_only, "batchy"))
    assert not {"flaky", "wrong", "batchy"} & set(SENSOR_KINDS)


def test_config_check_warns_of_a_source_in_no_stage(tmp_path, capsys):
    """Defined and never combined, a source took no part in runs, and `config check` said "valid" alone."""
    data = load_config(configs.path("examples/infrared.yaml")).to_data()
    data["stages"] = {stage: [n for n in names if n != "infrared"] for stage, names in data["stages"].items()}
    path = tmp_path / "unused.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["config", "check", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"warning: {path}: sources.infrared: in no stage, so it takes no part in a run" in out
    assert main(["config", "check", str(configs.path("examples/infrared.yaml"))]) == 0
    assert "in no stage" not in capsys.readouterr().out
