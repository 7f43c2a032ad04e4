"""Scenario files: the good fixture, one bad fixture per error kind, size limits, safety."""

import json
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from evmap import configs
from evmap.sources.loading import InputError
from evmap.sources.params import LslParams, SonarParams
from evmap.sources.sim.scenario import (
    BUILTIN_MATERIALS,
    MAX_CYLINDERS,
    MAX_POSES,
    MAX_SUNLIGHT_LINES,
    MAX_WALL_SEGMENTS,
    Scenario,
    Sunlight,
    default_scenario,
    load_scenario,
    parse_scenario,
)

HERE = Path(__file__).parent / "scenarios"


def minimal(**extra: object) -> dict:
    data = {"version": 1, "name": "t", "world": {"walls": []}, "robot": {"poses": [[0, 0, 0]]}}
    return {**data, **extra}


def test_room_fixture_loads() -> None:
    s = load_scenario(HERE / "room.yaml")
    assert (s.name, s.seed, len(s.world.walls), len(s.world.sunlight), len(s.robot.poses)) == ("room", 11, 4, 2, 2)
    assert s.world.walls[0].material == "wall"  # the default material
    materials = s.resolved_materials()
    assert materials["felt"].sonar == "absorbing"
    assert materials["glass"].sonar == "absorbing"  # a built-in overridden
    assert materials["mirror"] == BUILTIN_MATERIALS["mirror"]


def test_sensor_overrides_apply_only_the_keys_written() -> None:
    s = load_scenario(HERE / "room.yaml")
    sonar, lsl = s.sensor_params(SonarParams(max_range=7.0, step_deg=1.5), LslParams(split_threshold=0.03))
    assert (sonar.step_deg, sonar.max_range) == (2.0, 7.0)
    assert (lsl.max_range, lsl.range_noise, lsl.split_threshold) == (6.0, 0.004, 0.03)
    bare = Scenario.model_validate(minimal())
    assert bare.sensor_params(SonarParams(), LslParams(fov_deg=30)) == (SonarParams(), LslParams(fov_deg=30))


def test_default_scenario_is_the_papers_corridor() -> None:
    s = default_scenario()
    assert s.name == "corridor"
    assert len(s.robot.poses) == 1
    assert [region.lines for region in s.world.sunlight] == [28]
    assert s.world.sunlight[0].length == (0.05, 0.35)
    assert {"glass"} <= {wall.material for wall in s.world.walls}
    assert load_scenario(configs.path("scenarios/corridor.yaml")) == s


BAD = [
    ("unknown_key.yaml", "world.walls[0].colour", "unknown key"),
    ("unknown_material.yaml", "world.walls[1].material", "unknown material"),
    ("one_point.yaml", "world.walls[0].points", "at least 2 items"),
    ("zero_length.yaml", "world.walls[0].points", "segment 1 from [1.0, 0.0] to [1.0, 0.0] has zero length"),
    ("non_finite.yaml", "world.walls[0].points[1][0]", "finite number"),
    ("pose_in_cylinder.yaml", "robot.poses[1]", "pose inside cylinder 'pillar'"),
    ("duplicate_id.yaml", "world.cylinders[0].id", "duplicate id, also world.walls[0]"),
    ("colon_id.yaml", "world.walls[0].id", "must not contain ':'"),
    ("sunlight_range.yaml", "world.sunlight[0].length", "need 1e-06 m <= min <= max, got min 0.4 and max 0.2"),
    ("sunlight_tiny.yaml", "world.sunlight[0].length", "need 1e-06 m <= min <= max, got min 1e-16"),
    ("sunlight_too_long.yaml", "world.sunlight[0].length", "too long for the polygon"),
    ("sunlight_polygon.yaml", "world.sunlight[0].polygon", "not a simple polygon: self-intersection at (1, 1)"),
    ("sensor_key.yaml", "sensors.lsl.fov", "unknown key"),
    ("sonar_step.yaml", "sensors.sonar.step_deg", "greater than or equal to 0.1"),
    ("version.yaml", "version", "unsupported version: this program reads version 1"),
    ("syntax.yaml", "line 5, column 1", "expected ',' or ']'"),
    ("duplicate_key.yaml", "line 6, column 1", "duplicate key 'robot'"),
]


@pytest.mark.parametrize(("name", "where", "what"), BAD, ids=[b[0] for b in BAD])
def test_bad_file_names_file_place_and_problem(name: str, where: str, what: str) -> None:
    path = HERE / name
    with pytest.raises(InputError) as err:
        load_scenario(path)
    message = str(err.value)
    assert message.startswith(f"{path}: {where}: ")
    assert what in message
    assert "Traceback" not in message and "\n" not in message


def test_a_pose_without_its_heading_names_the_missing_item(tmp_path: Path) -> None:
    path = tmp_path / "no_heading.yaml"
    path.write_text("version: 1\nname: t\nworld:\n  walls: []\nrobot: {poses: [[1, 1]]}\n")
    with pytest.raises(InputError, match=r"no_heading.yaml: robot.poses\[0\]\[2\]: required item is missing"):
        load_scenario(path)


def test_numbers_are_read_as_yaml_1_2_has_them() -> None:
    """YAML 1.1 (PyYAML's default) read a zero-padded heading ``045`` as octal (37 degrees), ``8_0`` as 80 and
    ``yes`` as true, and the run went on; YAML 1.2 reads 45 and keeps the others strings, refused here."""
    s = parse_scenario("version: 1\nname: t\nworld: {walls: []}\nrobot: {poses: [[010, 1.5, 045]]}\n", "p.yaml")
    assert tuple(s.robot.poses[0]) == (10.0, 1.5, 45.0)  # degrees, as written
    for text, where in (("[8_0, 0, 0]", r"robot.poses\[0\]\[0\]"), ("[0, 0b1, 0]", r"robot.poses\[0\]\[1\]")):
        with pytest.raises(InputError, match=rf"p.yaml: {where}: .*valid number"):
            parse_scenario(f"version: 1\nname: t\nworld: {{walls: []}}\nrobot: {{poses: [{text}]}}\n", "p.yaml")
    assert parse_scenario("version: 1\nname: yes\nworld: {walls: []}\nrobot: {poses: [[0, 0, 0]]}\n", "y").name == "yes"


def test_missing_file_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read file"):
        load_scenario(tmp_path / "nowhere.yaml")


def test_python_tags_are_refused_not_run(tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    text = f"version: 1\nname: !!python/object/apply:os.system ['touch {marker}']\n"
    with pytest.raises(InputError, match=r"evil.yaml: line 2, column 7: .*python/object/apply"):
        parse_scenario(text, "evil.yaml")
    assert not marker.exists()


def test_cross_checks_report_all_problems_at_once() -> None:
    data = minimal(
        world={
            "walls": [
                {"id": "a", "points": [[0, 0], [1, 0]], "material": "x"},
                {"id": "a", "points": [[0, 1], [1, 1]]},
            ],
            "cylinders": [{"id": "c", "center": [0, 0], "radius": 0.5}],
        }
    )
    with pytest.raises(Exception) as err:
        Scenario.model_validate(data)
    locations = {e["loc"] for e in err.value.errors()}
    assert locations == {("world", "walls", 0, "material"), ("world", "walls", 1, "id"), ("robot", "poses", 0)}


# absurd sizes: refused by the size check before anything else is validated (the
# items below are all invalid, yet the only error is the limit)


def test_too_many_wall_segments_refused_first() -> None:
    walls = [{"id": "w", "points": [["x", None]] * (MAX_WALL_SEGMENTS + 2)}]
    with pytest.raises(Exception) as err:
        Scenario.model_validate(minimal(world={"walls": walls}))
    (only,) = err.value.errors()
    assert only["loc"] == ("world", "walls")
    assert f"more than the limit of {MAX_WALL_SEGMENTS}" in only["msg"]


def test_too_many_sunlight_lines_refused_first() -> None:
    region = {"polygon": "junk", "lines": MAX_SUNLIGHT_LINES // 2, "length": "junk"}
    with pytest.raises(Exception) as err:
        Scenario.model_validate(minimal(world={"walls": [], "sunlight": [region] * 3}))
    (only,) = err.value.errors()
    assert only["loc"] == ("world", "sunlight")
    assert "sunlight lines" in only["msg"]


@pytest.mark.parametrize(
    ("lines", "where"),
    [
        (1_000_000, r"world\.sunlight: 1000000 sunlight lines, more than the limit of 400"),
        (300, r"world\.sunlight\[0\]\.lines: Input should be less than or equal to 200"),
    ],
)
def test_too_many_lines_in_one_region_refused(lines: int, where: str) -> None:
    region = {"polygon": [[0, 0], [1, 0], [1, 1]], "lines": lines, "length": [0.1, 0.2]}
    with pytest.raises(InputError, match=where):
        parse_scenario(json.dumps(minimal(world={"walls": [], "sunlight": [region]})), "big.yaml")


@pytest.mark.parametrize(
    ("section", "limit"),
    [(("robot", "poses"), MAX_POSES), (("world", "cylinders"), MAX_CYLINDERS)],
)
def test_too_many_poses_or_cylinders_refused(section: tuple[str, str], limit: int) -> None:
    data = minimal()
    data[section[0]] = {**data[section[0]], section[1]: ["junk"] * (limit + 1)}
    with pytest.raises(Exception) as err:
        Scenario.model_validate(data)
    (only,) = err.value.errors()
    assert only["loc"] == section
    assert f"at most {limit} items" in only["msg"]


@given(
    width=st.floats(0.2, 5),
    height=st.floats(0.2, 5),
    lines=st.integers(0, 40),
    low=st.floats(0.01, 0.5),
    extra=st.floats(0, 0.5),
    seed=st.integers(0, 2**32),
)
def test_sunlight_lines_count_length_and_inside(
    width: float, height: float, lines: int, low: float, extra: float, seed: int
) -> None:
    polygon = [[1, 1], [1 + width, 1], [1 + width, 1 + height], [1, 1 + height]]
    try:
        region = Sunlight(polygon=polygon, lines=lines, length=(low, low + extra))
    except ValueError as exc:  # refused only when the longest line hardly fits
        assert "too long for the polygon" in str(exc)
        assert low + extra > 0.8 * min(width, height)
        return
    p, q = region.draw_lines(np.random.default_rng(seed))
    length = np.hypot(*(q - p).T)
    assert p.shape == q.shape == (lines, 2)
    assert np.all((length >= low - 1e-12) & (length <= low + extra + 1e-12))
    shape = shapely.Polygon(polygon)
    assert shapely.contains_xy(shape, p[:, 0], p[:, 1]).all()
    assert shapely.contains_xy(shape, q[:, 0], q[:, 1]).all()


def test_sunlight_in_a_concave_polygon() -> None:
    l_shape = [[0, 0], [3, 0], [3, 0.5], [0.5, 0.5], [0.5, 3], [0, 3]]
    region = Sunlight(polygon=l_shape, lines=200, length=(0.5, 1.5))
    p, q = region.draw_lines(np.random.default_rng(3))
    shape = shapely.Polygon(l_shape)
    assert shapely.contains_xy(shape, p[:, 0], p[:, 1]).all() and shapely.contains_xy(shape, q[:, 0], q[:, 1]).all()
    # only the ends must be inside: some lines cross the notch
    lines = shapely.linestrings(np.stack([p, q], axis=1))
    assert not shapely.contains(shape, lines).all()
