"""`evmap compare --configs`: configs side by side on the same scans, the ablation, and the hazards measured."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import shapely

from evmap.maps.app.cli import main
from evmap.maps.app.compare_configs import ABLATION, config_names, resolve_config
from evmap.maps.app.compare_hazards import (
    GRID_RESOLUTION,
    SPURIOUS_FAR,
    SPURIOUS_ON_LINE,
    free_behind_walls,
    free_seen_kept,
    spurious_unidentified,
    stripe_seen,
)
from evmap.maps.app.compare_metrics import fuse_rules
from evmap.maps.app.compare_runner import run_comparison
from evmap.maps.occupancy import FREE_MAX, occupancy_from_masses, occupancy_masses
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import default_scenario, parse_scenario
from evmap.sources.sim.worldgen_params import WorldGenParams

ROOM_YAML = """
version: 1
name: room
seed: 4
world:
  walls:
    - {id: room, points: [[0, 0], [6, 0], [6, 4], [0, 4], [0, 0]]}
  sunlight:
    - {polygon: [[1.5, 1.3], [3.5, 1.3], [3.5, 2.1], [1.5, 2.1]], lines: 12, length: [0.1, 0.4]}
robot:
  poses: [[2.5, 2.8, 0], [4.5, 1.0, 90]]
"""
ROOM = parse_scenario(ROOM_YAML, "room.yaml")


def test_config_names_expand_the_ablation_and_refuse_what_cannot_be_built():
    assert config_names("ablation") == ABLATION
    assert config_names("default,paper+contour_free+lsl_persistence")[1] == "paper+contour_free+lsl_persistence"
    with pytest.raises(ValueError, match="named twice"):
        config_names("paper,ablation")
    with pytest.raises(ValueError, match="no source 'sunshine'"):
        config_names("paper+sunshine")
    with pytest.raises(ValueError, match="one or more"):
        config_names("paper,,default")
    with pytest.raises(ValueError, match="nowhere"):
        config_names("nowhere")


def test_a_source_added_to_the_paper_is_the_default_configs_source():
    added = resolve_config("paper+sonar_forward")
    assert added.stages["noise_elimination"] == (*load_config("paper").stages["noise_elimination"], "sonar_forward")
    assert added.to_data()["sources"]["sonar_forward"] == load_config("default").to_data()["sources"]["sonar_forward"]


def test_configs_side_by_side_give_what_each_gives_alone():
    one_pose = WorldGenParams(single_pose_share=1)
    both = run_comparison(
        ["dempster"], 2, 3, configs=("paper", "default"), params=one_pose, scheduler="synchronous", progress=False
    )
    assert [(r["config"], r["rule"]) for r in both.summary] == [("paper", "dempster"), ("default", "dempster")]
    for name in ("paper", "default"):
        alone = run_comparison(
            ["dempster"], 2, 3, configs=(name,), params=one_pose, scheduler="synchronous", progress=False
        )
        mine = [_untimed(r) for r in both.rows if r["config"] == name]
        assert mine == [_untimed(r) for r in alone.rows]


def test_the_command_writes_one_row_per_config_and_rule_with_pooled_ratios(tmp_path, capsys):
    out = tmp_path / "cmp"
    argv = ["compare", "--configs", "paper,paper+contour_free", "--rules", "dempster,yager", "--worlds", "1"]
    assert main([*argv, "--seed", "1", "--out", str(out), "--scheduler", "synchronous", "--quiet"]) == 0
    assert "| paper+contour_free | yager |" in capsys.readouterr().out
    summary = list(csv.DictReader((out / "summary.csv").open()))
    worlds = list(csv.DictReader((out / "worlds.csv").open()))
    assert [(r["config"], r["rule"]) for r in summary] == [
        ("paper", "dempster"),
        ("paper", "yager"),
        ("paper+contour_free", "dempster"),
        ("paper+contour_free", "yager"),
    ]
    for row in summary:
        mine = [w for w in worlds if (w["config"], w["rule"]) == (row["config"], row["rule"])]
        eliminated = sum(int(w["noise_eliminated"]) for w in mine)
        assert float(row["noise_recall_pooled"]) == pytest.approx(
            eliminated / sum(int(w["noise_segments"]) for w in mine)
        )
    assert main([*argv, "--config", "paper", "--out", str(tmp_path / "x")]) == 2  # one or the other
    assert "not allowed with argument" in capsys.readouterr().err


def test_free_cells_behind_the_walls_of_a_closed_room_are_those_outside_it():
    run = fuse_rules(ROOM, load_config("paper"), ["dempster"])["dempster"]
    behind, behind_opaque, free = free_behind_walls(run.map, run.world)
    masses, origin = occupancy_masses(run.map, GRID_RESOLUTION)
    grid = occupancy_from_masses(masses)
    rows, cols = np.nonzero((grid >= 0) & (grid <= FREE_MAX))
    centres = shapely.points(np.asarray(origin) + (np.column_stack([cols, rows]) + 0.5) * GRID_RESOLUTION)
    room = shapely.box(0, 0, 6, 4)
    outside = int((~shapely.contains(room, centres)).sum())
    far_outside = int((~shapely.contains(room.buffer(2 * GRID_RESOLUTION), centres)).sum())
    assert free == len(centres) > 0
    assert far_outside <= behind <= outside  # the room is convex: nothing inside it is hidden from a pose in it
    assert behind_opaque == behind  # its walls are opaque


def test_what_the_stripe_saw_through_glass_is_not_behind_opaque_surfaces():
    scenario = parse_scenario(
        ROOM_YAML.replace(
            "[0, 4], [0, 0]]}", "[0, 4], [0, 0]]}\n    - {id: pane, points: [[4, 0], [4, 4]], material: glass}"
        ).replace(", [4.5, 1.0, 90]]", "]"),  # one pose, left of the pane
        "glazed.yaml",
    )
    run = fuse_rules(scenario, load_config("default"), ["dempster"])["dempster"]
    behind, behind_opaque, free = free_behind_walls(run.map, run.world)
    assert behind_opaque < behind < free  # the pose at x = 2.5 sees the far side of the pane through it


def test_the_places_the_stripe_saw_free_are_in_the_room_and_the_grid_keeps_them_free():
    run = fuse_rules(ROOM, load_config("default"), ["dempster"])["dempster"]
    seen = stripe_seen(run.world, run.config)
    assert len(seen) > 1000
    assert shapely.contains_xy(shapely.box(0, 0, 6, 4).buffer(-GRID_RESOLUTION), seen[:, 0], seen[:, 1]).all()
    kept, total = free_seen_kept(run.map, seen)
    assert total == len(seen) and kept / total > 0.9


def test_spurious_unidentified_objects_by_their_definition():
    run = fuse_rules(default_scenario(), load_config("default"), ["dempster"])["dempster"]
    spurious, objects = spurious_unidentified(run.map, run.world)
    xy = shapely.points(np.array([u.xy for u in run.map.unidentified()]).reshape(-1, 2))
    assert objects == len(xy) > 0
    s = run.world.surfaces()
    walls = shapely.multilinestrings([[p, q] for p, q in zip(s.p, s.q, strict=True)])
    pillars = shapely.boundary(shapely.buffer(shapely.points(s.cylinder_centers), s.cylinder_radii, quad_segs=256))
    truth = shapely.union_all([walls, *pillars])
    lines = shapely.multilinestrings([[ln.p, ln.q] for ln in run.map.lines(min_belief=0.5)])
    far = shapely.distance(xy, truth) > SPURIOUS_FAR
    assert spurious == int((far | (shapely.distance(xy, lines) <= SPURIOUS_ON_LINE)).sum())


def _untimed(row):
    return {k: v for k, v in row.items() if not k.startswith("seconds")}


def test_the_contract_lists_every_column_of_the_comparisons_tables():
    from pathlib import Path

    from evmap.maps.app.compare_tables import SUMMARY_COLUMNS, WORLD_COLUMNS

    contract = (Path(__file__).parents[1] / "docs" / "SCENARIO.md").read_text()
    section = contract[contract.index("## Comparisons") :]
    for column in {*WORLD_COLUMNS, *SUMMARY_COLUMNS} - {c for c in SUMMARY_COLUMNS if c.endswith(("_lo", "_hi"))}:
        assert f"`{column}`" in section, column


def test_a_config_whose_source_reads_a_feature_no_sensor_computes_is_refused_by_file_and_key(tmp_path):
    """`evmap run` refused it by file, key path and line; compare failed later with neither."""
    import yaml

    from evmap import configs
    from evmap.sources.loading import InputError

    data = load_config(configs.path("examples/infrared.yaml")).to_data()
    data["sources"]["infrared"]["feature"] = "ir_returns"  # a typo
    path = tmp_path / "typo.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError, match=rf"{path}: sources\.infrared\.feature: reads feature 'ir_returns'"):
        resolve_config(str(path))


def test_a_config_s_figures_do_not_depend_on_the_configs_it_is_compared_with(tmp_path):
    """The glass, the stripe's sight and the sunlight seen twice were judged with the first config's sensors for
    every config: a config with a shorter-sighted stripe got the paper's."""
    import yaml

    from evmap import configs
    from evmap.maps.app.compare_runner import compare_world

    data = yaml.safe_load(configs.path("paper.yaml").read_text())
    data["sensors"]["lsl"]["max_range"] = 3.0
    short = tmp_path / "short.yaml"
    short.write_text(yaml.safe_dump(data))
    params = WorldGenParams(single_pose_share=0)
    alone = compare_world(2, 7, ["dempster"], [str(short)], params).rows
    beside = [
        r for r in compare_world(2, 7, ["dempster"], ["paper", str(short)], params).rows if r["config"] == str(short)
    ]
    drop = ("seconds_per_world", "seconds_simulate")
    assert [{k: v for k, v in r.items() if k not in drop} for r in beside] == [
        {k: v for k, v in r.items() if k not in drop} for r in alone
    ]
