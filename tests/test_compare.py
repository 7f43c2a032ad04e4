"""Comparing combination rules: reproducible numbers, the Dempster-Yager and Bayes cases, Dask, the command."""

from __future__ import annotations

import csv
import os

import numpy as np
import pytest
import shapely

from evmap.maps.app.cli import build_parser
from evmap.maps.app.compare_executors import executor
from evmap.maps.app.compare_metrics import COLUMNS, METRICS, fuse_rules, heard_glass, visible_glass, world_metrics
from evmap.maps.app.compare_runner import run_comparison
from evmap.maps.noise import noise_evidence
from evmap.maps.observation import observe
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import parse_scenario
from evmap.sources.sim.world import World
from evmap.sources.sim.worldgen_params import WorldGenParams

RULES = ["dempster", "yager"]
ONE_POSE = WorldGenParams(single_pose_share=1)
"""Single-pose worlds: what is tested here does not depend on the tours, which cost several times more."""

# A room whose sunlight makes long phantom lines (0.45-0.6 m, longer than the LSL ramp's 0.40 m)
# near the robot, so some of them lie inside the sonar open space.
OPEN_ROOM = parse_scenario(
    """
version: 1
name: open-room
seed: 3
world:
  walls:
    - {id: room, points: [[0, 0], [5, 0], [5, 4], [0, 4], [0, 0]]}
  sunlight:
    - {polygon: [[1.5, 1.3], [3.5, 1.3], [3.5, 2.1], [1.5, 2.1]], lines: 16, length: [0.45, 0.6]}
robot:
  poses: [[2.5, 2.7, 0]]
""",
    "open-room.yaml",
)


def _numbers(rows):
    """Every non-timing column of the rows."""
    return [{k: v for k, v in row.items() if not k.startswith("seconds")} for row in rows]


@pytest.fixture(scope="module")
def config():
    return load_config()


@pytest.fixture(scope="module")
def synchronous():
    return run_comparison(RULES, 2, 5, params=ONE_POSE, scheduler="synchronous", progress=False)


@pytest.fixture(scope="module")
def open_room(config):
    return fuse_rules(OPEN_ROOM, config, ["dempster", "yager", "bayes"])


def test_same_seed_same_numbers(synchronous):
    again = run_comparison(RULES, 2, 5, params=ONE_POSE, scheduler="threads", progress=False)
    assert _numbers(again.rows) == _numbers(synchronous.rows)
    assert _numbers(again.summary) == _numbers(synchronous.summary)
    assert all(np.array_equal(again.beliefs[v], synchronous.beliefs[v]) for v in synchronous.variants)
    assert again.scenarios == synchronous.scenarios
    other = run_comparison(RULES, 2, 6, params=ONE_POSE, scheduler="synchronous", progress=False)
    assert _numbers(other.rows) != _numbers(synchronous.rows)


def test_dask_cluster_equals_synchronous(synchronous):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        result = run_comparison(RULES, 2, 5, params=ONE_POSE, scheduler=cluster.scheduler_address, progress=False)
    assert _numbers(result.rows) == _numbers(synchronous.rows)
    assert _numbers(result.summary) == _numbers(synchronous.summary)


def _worker_settings():
    import dask

    return dask.config.get("distributed.worker.profile.enabled"), os.environ.get("MALLOC_TRIM_THRESHOLD_")


def test_local_cluster_workers_run_without_the_profiler_and_the_heap_trimming():
    """The workers of the local cluster: no statistical profiler (its history grew a worker's memory by some
    75 MB over 1,000 worlds) and no ``MALLOC_TRIM_THRESHOLD_`` from Dask's nanny (page faults)."""
    pytest.importorskip("distributed")
    with executor(None, 1) as (client, _, slots):
        client.wait_for_workers(1, timeout=60)  # the cluster starts without them (tasks queue meanwhile)
        settings = list(client.run(_worker_settings).values())
    assert slots == 1
    assert settings == [(False, os.environ.get("MALLOC_TRIM_THRESHOLD_"))]


def test_rows_in_world_order_and_summary_means(synchronous):
    assert [(r["world"], r["rule"]) for r in synchronous.rows] == [
        ("world-0000", "dempster"),
        ("world-0000", "yager"),
        ("world-0001", "dempster"),
        ("world-0001", "yager"),
    ]
    for line in synchronous.summary:
        mine = [r for r in synchronous.rows if r["rule"] == line["rule"]]
        for column in METRICS:
            values = [r[column] for r in mine if r[column] is not None]
            assert line[column] == (pytest.approx(np.mean(values)) if values else None)
        assert line["worlds"] == 2


def test_dempster_removes_a_long_segment_inside_the_open_space_that_yager_keeps(config):
    """Theory: inside -> sonar (0.1, 0.8, 0.1), long -> LSL real 0.6. Conjunctive: noise 0.32, K 0.48.
    Dempster normalises: m(noise) = 0.32 / 0.52 = 0.615 > 0.5, removed. Yager puts K on Θ: m(noise) = 0.32, kept."""
    room = shapely.box(0, 0, 4, 4)
    p, q = np.array([[1.0, 1.0]]), np.array([[1.5, 1.0]])  # 0.5 m, inside
    dempster = noise_evidence(p, q, room, config.with_rule("dempster"))
    yager = noise_evidence(p, q, room, config.with_rule("yager"))
    assert dempster.relation[0] == yager.relation[0] == "inside"
    assert dempster.conflict[0] == pytest.approx(0.48)
    assert dempster.fused[0].tolist() == pytest.approx([0, 0.16 / 0.52, 0.32 / 0.52, 0.04 / 0.52])
    assert yager.fused[0].tolist() == pytest.approx([0, 0.16, 0.32, 0.04 + 0.48])  # K moved to Θ = real|noise
    assert dempster.eliminated[0] and not yager.eliminated[0]


def test_dempster_and_yager_differ_on_a_world(open_room):
    stores = {rule: open_room[rule].map.segments for rule in ("dempster", "yager")}
    d, y = stores["dempster"], stores["yager"]
    long_inside = (d.truth == "noise") & (d.relation == "inside") & (d.length >= 0.4)
    assert long_inside.any()
    assert d.eliminated[long_inside].all()
    assert not y.eliminated[long_inside].any()
    theta = 3  # the mask of real|noise
    assert (y.mass[long_inside, theta] >= y.conflict[long_inside]).all()
    md, my = world_metrics(open_room["dempster"]), world_metrics(open_room["yager"])
    assert md["noise_recall"] > my["noise_recall"]
    assert md["mean_conflict"] == my["mean_conflict"]  # K is the evidence's, not the rule's


def test_bayes_cannot_hold_ignorance(open_room):
    theta = 3
    bayes, dempster = open_room["bayes"].map, open_room["dempster"].map
    assert len(bayes.segments) and (bayes.segments.mass[:, theta] == 0).all()
    assert bayes.segments.mass[:, 1:].sum(axis=1) == pytest.approx(1.0)
    assert (dempster.segments.mass[:, theta] > 0).all()
    for line in bayes.lines(min_belief=0.0):
        assert line.mass.to_dict().get("real|noise", 0.0) == 0.0
        assert line.belief == pytest.approx(line.plausibility)


GLASS_ROOM = """
version: 1
name: glass-room
world:
  walls:
    - {id: south, points: [[0, 0], [6, 0], [6, 3]]}
    - {id: window, points: [[6, 3], [6, 4]], material: glass}
    - {id: north, points: [[6, 4], [0, 4], [0, 0]]}
    - {id: pane, points: [[2, 3.9], [3, 3.9]], material: glass}
  cylinders: [CYL]
robot:
  poses: [[3, 3.5, 0]]
"""
"""A room with a window east of the robot and a glass pane whose foot is at its end (CYL: its cylinders)."""


def test_glass_seen_at_normal_incidence_unless_obstructed(config):
    free = World(parse_scenario(GLASS_ROOM.replace("CYL", ""), "a.yaml"))
    ids = free.surfaces().segment_ids
    assert ids[visible_glass(free, config)].tolist() == ["window"]  # the pane's foot is at its end: not inside
    blocked = World(parse_scenario(GLASS_ROOM.replace("CYL", "{id: c, center: [4.5, 3.5], radius: 0.2}"), "b.yaml"))
    assert visible_glass(blocked, config).tolist() == []


def test_glass_heard_is_glass_whose_direct_echo_came_at_normal_incidence(config):
    """Two legs either side of the sight line to a window leave the line clear, so the window is seen at
    normal incidence, but every beam that holds the window's foot holds a leg, which echoes first."""
    legs = "{id: a, center: [4.0, 3.3], radius: 0.1}, {id: b, center: [4.0, 3.7], radius: 0.1}"
    for cylinders, heard in (("", ["window"]), (legs, [])):
        world = World(parse_scenario(GLASS_ROOM.replace("CYL", cylinders), "a.yaml"))
        scans = [observe(world, i, config).sonar for i in range(len(world.poses))]
        ids = world.surfaces().segment_ids
        assert ids[visible_glass(world, config)].tolist() == ["window"]
        assert ids[heard_glass(world, scans)].tolist() == heard


def test_compare_command_writes_the_contract_files(tmp_path, capsys):
    parser = build_parser()
    out = tmp_path / "cmp"
    argv = [
        "compare",
        "--rules",
        "dempster,bayes",
        "--worlds",
        "2",
        "--seed",
        "1",
        "--out",
        str(out),
        "--scheduler",
        "synchronous",
        "--quiet",
    ]
    args = parser.parse_args(argv)
    assert args.handler(args) == 0
    assert "| dempster |" in capsys.readouterr().out
    summary = list(csv.DictReader((out / "summary.csv").open()))
    worlds = list(csv.DictReader((out / "worlds.csv").open()))
    assert [r["rule"] for r in summary] == ["dempster", "bayes"]
    assert set(COLUMNS) <= set(summary[0]) and {"world", *COLUMNS} <= set(worlds[0])
    assert [r["world"] for r in worlds] == ["world-0000", "world-0000", "world-0001", "world-0001"]
    assert (
        "| rule | noise_recall | real_loss | glass_explained | mean_conflict | map_error"
        in (out / "summary.md").read_text()
    )
    assert sorted(p.name for p in (out / "worlds").iterdir()) == ["world-0000.yaml", "world-0001.yaml"]
    assert (out / "noise_recall_vs_real_loss.png").stat().st_size > 0 and (out / "line_beliefs.png").stat().st_size > 0
    parse_scenario((out / "worlds" / "world-0001.yaml").read_text(), "world-0001.yaml")

    args = parser.parse_args(argv)
    with pytest.raises(ValueError, match="not empty"):
        args.handler(args)
    args = parser.parse_args([*argv[:2], "dempster,nope", *argv[3:], "--force"])
    with pytest.raises(ValueError, match="unknown rule 'nope'"):
        args.handler(args)
    assert (out / "summary.csv").exists()  # a failed run leaves the old results alone


@pytest.mark.parametrize(
    ("scheduler", "where"),
    [("synchronous", "the worlds run in this process"), ("tcp://127.0.0.1:9", "the cluster has its own workers")],
)
def test_workers_with_a_scheduler_they_do_not_set_is_refused_before_any_work(scheduler, where):
    with pytest.raises(ValueError, match=f"workers 2 has no effect with scheduler {scheduler}: {where}"):
        run_comparison(["dempster"], 2, 1, scheduler=scheduler, workers=2, progress=False)
    assert len(run_comparison(["dempster"], 1, 1, scheduler="threads", workers=1, progress=False).rows) == 1
