"""Hostile and careless input: bombs, endless files, deep nesting, disguised counts, coercions, far coordinates.

Every case must end quickly with an InputError that names the file, the key path (or line
and column), the limit or the rule, and the value; none may run away in time or memory.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np
import pytest
import yaml

from evmap import configs
from evmap.sources.config import check_simulated_run, config_from_data, load_config
from evmap.sources.detector import MAX_FALSE_ALARMS
from evmap.sources.loading import MAX_DEPTH, MAX_FILE_BYTES, MAX_NODES, InputError, parse_document, read_document
from evmap.sources.params import MAX_STRIPE_POINTS, LslParams, SonarParams
from evmap.sources.range_sensor import MAX_RANGE_RAYS
from evmap.sources.sim.lsl import observe_lsl_all
from evmap.sources.sim.scenario import MAX_PHANTOMS_PER_RUN, MAX_SUNLIGHT_LINES, load_scenario, parse_scenario
from evmap.sources.sim.world import World

CORRIDOR = configs.path("scenarios/corridor.yaml")
PAPER = configs.path("paper.yaml")

BOMB = """\
a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
version: 1
name: *i
"""


def scenario_text(**replace: str) -> str:
    """The corridor's text with some lines replaced (key -> new line)."""
    text = CORRIDOR.read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


def corridor_data() -> dict:
    return yaml.safe_load(CORRIDOR.read_text())


def test_alias_bomb_is_refused_before_it_is_expanded() -> None:  # its time: benchmarks/bench_loading.py
    with pytest.raises(
        InputError,
        match=rf"bomb.yaml: line \d+, column \d+: \d+ nodes once aliases are expanded, more than the limit of {MAX_NODES}",
    ):
        parse_scenario(BOMB, "bomb.yaml")


def test_recursive_alias_is_refused() -> None:
    with pytest.raises(InputError, match="loop.yaml: line 1, column 4: an alias refers to a node that contains it"):
        parse_document("a: &x [1, *x]", "loop.yaml")


def test_deep_nesting_is_refused_with_the_limit() -> None:
    for depth in (MAX_DEPTH + 1, 2000, 100_000):
        with pytest.raises(
            InputError,
            match=f"deep.yaml: line 1, column \\d+: nesting .*the limit of {MAX_DEPTH}",
        ):
            parse_document("[" * depth + "]" * depth, "deep.yaml")
    assert parse_document("[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1), "ok.yaml").data is not None


def test_a_huge_value_is_never_written_out_in_a_message() -> None:
    text = scenario_text(**{"name: corridor": "name: [" + ", ".join(["123456789"] * 50_000) + "]"})
    with pytest.raises(InputError) as err:
        parse_scenario(text, "big.yaml")
    assert len(str(err.value)) < 300 and "name: Input should be a valid string" in str(err.value)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_devices_are_refused_without_reading(device: str) -> None:
    if not Path(device).exists():
        pytest.skip(f"no {device}")
    with pytest.raises(InputError, match=f"{device}: not a regular file"):
        load_scenario(device)


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    result: list[BaseException] = []
    reader = threading.Thread(target=lambda: result.append(pytest.raises(InputError, read_document, fifo).value))
    reader.start()
    reader.join(5)
    assert not reader.is_alive(), "reading a FIFO hangs"
    assert "not a regular file" in str(result[0])


def test_a_directory_and_an_oversized_file_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a regular file"):
        load_config(tmp_path)
    big = tmp_path / "big.yaml"
    big.write_bytes(b"#" * (MAX_FILE_BYTES + 1))
    with pytest.raises(InputError, match=f"larger than the limit of {MAX_FILE_BYTES} bytes"):
        load_scenario(big)


@pytest.mark.parametrize("lines", ["20000.0", "1.0e+6", "20001"])
def test_phantom_line_counts_are_limited_whatever_their_type(lines: str) -> None:
    data = corridor_data()
    region = data["world"]["sunlight"][0]
    data["world"]["sunlight"] = [region, region, {**region, "lines": "LINES"}]
    text = yaml.safe_dump(data).replace("LINES", lines).replace("'", "")
    with pytest.raises(InputError, match=r"world\.sunlight: .* sunlight lines.*more than the limit of"):
        parse_scenario(text, "many.yaml")


def test_an_lsl_scan_of_too_many_stripe_points_is_refused_with_its_key_path() -> None:
    data = corridor_data()
    data["sensors"]["lsl"] |= {"fov_deg": 180, "ray_step_deg": 0.05, "snapshots": 2}
    with pytest.raises(
        InputError,
        match=rf"dense.yaml: sensors\.lsl: .*7202 stripe points per scan, more than the limit of {MAX_STRIPE_POINTS}",
    ):
        parse_scenario(yaml.safe_dump(data), "dense.yaml")
    data["sensors"]["lsl"]["snapshots"] = 1
    assert parse_scenario(yaml.safe_dump(data), "dense.yaml").sensors.lsl.snapshots == 1


def test_a_scenario_lsl_over_a_config_lsl_is_checked_against_the_stripe_point_limit() -> None:
    data = corridor_data()
    data["sensors"]["lsl"] = {"ray_step_deg": 0.1}
    scenario = parse_scenario(yaml.safe_dump(data), "fine.yaml")
    with pytest.raises(InputError, match=r"scenario 'corridor': sensors\.lsl \(ray_step_deg\) over the config's"):
        scenario.sensor_params(SonarParams(), LslParams(snapshots=20))


@pytest.mark.parametrize(
    ("example", "sensor", "change", "message"),
    [
        (
            "infrared",
            "ir",
            {"beams": 3600, "rays": 100},
            rf"3600 beams x 3 sweep steps x 100 rays make 1080000 rays per pose, more than the limit of {MAX_RANGE_RAYS}",
        ),
        (
            "radar",
            "radar",
            {"max_range": 100.0, "false_alarms": [[0.0, 1000.0], [100.0, 1000.0]]},
            rf"false_alarms: 100000 false reports expected per scan, more than the limit of {MAX_FALSE_ALARMS}",
        ),
    ],
)
def test_a_sensor_too_costly_to_simulate_is_refused_with_its_key_path(
    tmp_path: Path, example: str, sensor: str, change: dict, message: str
) -> None:
    data = yaml.safe_load(configs.path(f"examples/{example}.yaml").read_text())
    data["extra_sensors"][sensor] |= change
    path = tmp_path / "costly.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError, match=rf"costly.yaml: extra_sensors\.{sensor}: .*{message}"):
        load_config(path)


def test_phantoms_over_all_poses_are_limited() -> None:
    data = corridor_data()
    data["world"]["sunlight"][0]["lines"] = MAX_SUNLIGHT_LINES // 2
    data["robot"]["poses"] = [
        [1 + i * 0.01, 1.0, 0] for i in range(MAX_PHANTOMS_PER_RUN // (MAX_SUNLIGHT_LINES // 2) + 1)
    ]
    with pytest.raises(InputError, match=f"phantom lines, more than the limit of {MAX_PHANTOMS_PER_RUN} per run"):
        parse_scenario(yaml.safe_dump(data), "poses.yaml")


@pytest.mark.parametrize(
    ("old", "new", "where", "what"),
    [
        ("version: 1", "version: true", "version", "valid integer"),
        ("seed: 7", "seed: 7.0", "seed", "valid integer"),
        ("name: corridor", "name: !!binary Y29ycmlkb3I=", "name", "valid string"),
        ("name: corridor", "name: 12", "name", "valid string"),
        ("radius: 0.12", "radius: true", "world.cylinders[0].radius", "valid number"),
        ("[9.5, 1.2, 0]", '["9.5", 1.2, 0]', "robot.poses[0][0]", "valid number"),
        ("[9.5, 1.2, 0]", "[9.5, 1.2, 720]", "robot.poses[0][2]", "less than or equal to 360"),
        ("[9.5, 1.2, 0]", "[9.5, 2.0e+7, 0]", "robot.poses[0][1]", "less than or equal to 10000000"),
        ("[9.5, 1.2, 0]", "[7.0, 0, 0]", "robot.poses[0]", "pose on wall 'south'"),
    ],
)
def test_no_silent_coercion_and_no_pose_on_a_wall(old: str, new: str, where: str, what: str) -> None:
    with pytest.raises(InputError) as err:
        parse_scenario(scenario_text(**{old: new}), "c.yaml")
    message = str(err.value)
    assert message.startswith(f"c.yaml: {where}: ") and what in message, message
    assert "(line " in message


def test_merge_keys_work_in_scenarios_and_configs(tmp_path: Path) -> None:
    text = scenario_text(
        **{
            "    - {id: east-sill, points: [[14, 0], [14, 0.3]], material: wall}": (
                "    - &sill {id: east-sill, points: [[14, 0], [14, 0.3]], material: wall}\n"
                "    - {<<: *sill, id: sill-copy, points: [[14, -1], [14, -0.7]]}"
            )
        }
    )
    walls = parse_scenario(text, "merge.yaml").world.walls
    assert (walls[2].id, walls[2].material, walls[2].points[0]) == ("sill-copy", "wall", (14.0, -1.0))
    config = PAPER.read_text().replace(
        "  sonar:\n    beam_width_deg: 25.0", "  sonar: &sonar\n    beam_width_deg: 25.0"
    )
    config = config.replace("rcd_figure:\n", "rcd_figure:\n  <<: {range_tolerance: 0.5}\n")
    (tmp_path / "c.yaml").write_text(config)
    cfg = load_config(tmp_path / "c.yaml")
    assert cfg.rcd_figure.range_tolerance == 0.01  # written keys override merged ones
    with pytest.raises(InputError, match="duplicate key 'frame'"):
        parse_document("frame: a\nframe: b", "d.yaml")


def edited_config(tmp_path: Path, old: str, new: str) -> Path:
    text = PAPER.read_text()
    for before, after in zip(old.split(" && "), new.split(" && "), strict=True):
        assert before in text
        text = text.replace(before, after)
    (tmp_path / "c.yaml").write_text(text)
    return tmp_path / "c.yaml"


@pytest.mark.parametrize(
    ("old", "new", "where", "what"),
    [
        (
            "elements: [real, noise] && unknown: real|noise",
            "elements: [real, dust] && unknown: real|dust",
            "frames.existence.elements",
            "missing 'noise'",
        ),
        (
            "elements: [real, noise] && unknown: real|noise",
            "elements: [wall, noise] && unknown: wall|noise",
            "frames.existence.elements",
            "missing 'real'",
        ),
        ("jump_threshold: 1.0         #", "jump_threshold: .inf         #", "rcd.jump_threshold", "finite number"),
        ("partly_inside: {real: 0.1", "partly: {real: 0.1", "sources.sonar_open_space", "partly"),
        (
            "categories: [outside, partly_inside, inside] && partly_inside: {real: 0.1",
            "categories: [outside, partly, inside] && partly: {real: 0.1",
            "sources.sonar_open_space.categories",
            "no row for 'partly_inside'",
        ),
        ("feature: sonar_match", "feature: relation", "sources.sonar_match.feature", "only the feature 'sonar_match'"),
        ("feature: length", "feature: relation", "sources.lsl_length.kind", "read it with a table"),
        ("threshold: 0.5", "threshold: true", "noise.threshold", "valid number"),
        ("snapshots: 15 ", "snapshots: 15.0 ", "sensors.lsl.snapshots", "valid integer"),
        ("rule: dempster", "rule: !!binary ZGVtcHN0ZXI=", "rule", "valid string"),
    ],
)
def test_config_check_makes_every_check_of_a_run(tmp_path: Path, old: str, new: str, where: str, what: str) -> None:
    path = edited_config(tmp_path, old, new)
    with pytest.raises(InputError) as err:
        load_config(path)
    message = str(err.value)
    assert message.startswith(f"{path}: {where}") and what in message and "(line " in message, message


def test_a_feature_no_sensor_computes_is_a_warning_for_check_and_an_error_for_run(tmp_path: Path) -> None:
    text = configs.path("examples/infrared.yaml").read_text()  # without the sensor `ir` that gives ir_return
    path = tmp_path / "infrared.yaml"
    path.write_text(text[: text.index("extra_sensors:")] + text[text.index("\nsources:") :])
    cfg = load_config(path)
    (warning,) = cfg.warnings
    assert "sources.infrared.feature: reads feature 'ir_return', which no sensor computes" in warning
    assert warning.startswith(str(path))
    with pytest.raises(InputError, match="sources.infrared.feature"):
        check_simulated_run(cfg)
    assert load_config().warnings == ()


def shifted_corridor(dx: float, dy: float) -> dict:
    """The corridor scenario's data with every point moved by (dx, dy)."""
    data = corridor_data()

    def move(points: list) -> list:
        return [[p[0] + dx, p[1] + dy, *p[2:]] for p in points]

    for wall in data["world"]["walls"]:
        wall["points"] = move(wall["points"])
    for cylinder in data["world"].get("cylinders", []):
        cylinder["center"] = move([cylinder["center"]])[0]
    for region in data["world"]["sunlight"]:
        region["polygon"] = move(region["polygon"])
    data["robot"]["poses"] = move(data["robot"]["poses"])
    return data


@pytest.mark.parametrize(("dx", "dy"), [(1e6, -1e6), (5e6, -5e6), (-9.99e6, 9.99e6)])
def test_utm_sized_coordinates_give_the_same_observations(dx: float, dy: float) -> None:
    worlds = [World(parse_scenario(yaml.safe_dump(d), "c.yaml")) for d in (corridor_data(), shifted_corridor(dx, dy))]
    np.testing.assert_allclose(worlds[1].sunlight_centroids - [dx, dy], worlds[0].sunlight_centroids, atol=1e-6)
    original, moved = (observe_lsl_all(world, LslParams()) for world in worlds)
    assert len(moved) == len(original)
    assert (moved.truth == "noise").sum() == (original.truth == "noise").sum() > 0
    np.testing.assert_array_equal(moved.truth, original.truth)
    np.testing.assert_allclose(moved.p - [dx, dy], original.p, atol=1e-6)
    np.testing.assert_allclose(moved.q - [dx, dy], original.q, atol=1e-6)


@pytest.mark.parametrize("config_name", ["paper", "default"])
def test_a_run_at_utm_coordinates_gives_the_same_phantoms_segments_and_map(config_name: str) -> None:
    """The campaign's case (issue 16): the corridor moved by (5e6, -5e6) gave 38 LSL segments instead of 66
    and no phantoms; now every count of the report, every segment and its fused mass are the same."""
    from evmap.maps.app.run import report, run_scenario

    dx, dy = 5e6, -5e6
    config = load_config(config_name)
    runs = [
        run_scenario(parse_scenario(yaml.safe_dump(d), "c.yaml"), config)
        for d in (corridor_data(), shifted_corridor(dx, dy))
    ]
    reports = [{k: v for k, v in report(run).items() if k != "seconds"} for run in runs]
    assert reports[0] == reports[1] and reports[0]["noise_segments"] == 28 and reports[0]["lsl_segments"] == 66
    original, moved = (run.map.segments for run in runs)
    np.testing.assert_allclose(moved.p - [dx, dy], original.p, atol=1e-6)
    np.testing.assert_array_equal(moved.eliminated, original.eliminated)
    np.testing.assert_allclose(moved.mass, original.mass, atol=1e-6)


def test_a_scenario_at_the_coordinate_limit_runs_and_its_map_loads(tmp_path: Path) -> None:
    """A room touching x = 1e7 passed the scenario's checks, then its noisy stripe segments, 57 um beyond,
    failed the run: readings and maps may go twice as far as a scenario."""
    from evmap.maps import BeliefMap
    from evmap.maps.app.run import run_scenario

    text = """version: 1
name: edge
seed: 1
world:
  walls:
    - {id: room, points: [[9999994, -10000000], [10000000, -10000000], [10000000, -9999996], [9999994, -9999996],
                          [9999994, -10000000]]}
robot:
  poses:
    - [9999997, -9999998, 0]
"""
    run = run_scenario(parse_scenario(text, "edge.yaml"), load_config("default"))
    assert len(run.map.lines()) == 4 and np.abs(np.concatenate([run.map.segments.p, run.map.segments.q])).max() > 1e7
    run.map.save(tmp_path / "map.json")
    assert len(BeliefMap.load(tmp_path / "map.json").lines()) == 4


def test_a_detector_that_would_cut_the_walls_into_too_many_patches_is_refused() -> None:
    """Walls far longer than any room, in patches of 1 cm: refused before a single patch is made."""
    from evmap.maps.observation import observe
    from evmap.sources.detector import MAX_PATCHES

    config = load_config(configs.path("examples/radar.yaml"))
    world = World(
        parse_scenario(
            """
version: 1
name: long
world: {walls: [{id: w, points: [[-5000, 2], [5000, 2]]}]}
robot: {poses: [[0, 0, 0]]}
""",
            "long.yaml",
        )
    )
    data = config.to_data()
    data["extra_sensors"]["radar"]["patch"] = 0.01
    fine = config_from_data(data, "fine.yaml")
    with pytest.raises(ValueError, match=rf"into 1000000 patches, more than the limit of {MAX_PATCHES}"):
        observe(world, 0, fine)
    assert observe(world, 0, config).features  # the example's 0.2 m patches: 50,000


def test_an_empty_file_and_a_tab_are_named_as_such(tmp_path: Path) -> None:
    """An empty config said "Input should be a valid dictionary or instance of ConfigFile (got None)"; a tab
    "found character that cannot start any token"."""
    empty = tmp_path / "empty.yaml"
    empty.write_text("# nothing yet\n")
    with pytest.raises(InputError, match=r"empty.yaml: the file is empty \(or holds only comments\)"):
        load_config(empty)
    with pytest.raises(InputError, match=r"t.yaml: line 2, column 1: .* \(a tab: YAML indents with spaces only\)"):
        parse_document("a:\n\tb: 1\n", "t.yaml")


def test_a_yaml_1_1_boolean_is_refused_saying_how_yaml_1_2_writes_it(tmp_path: Path) -> None:
    text = configs.path("default.yaml").read_text().replace("drawn_apart: true", "drawn_apart: yes")
    path = tmp_path / "yes.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"corners\.drawn_apart: .* \(got 'yes': YAML 1\.2 writes true or false\)"):
        load_config(path)
