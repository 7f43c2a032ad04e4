"""Updates rebuild only the part of the map an observation touches: the result is the whole rebuild's."""

import dataclasses
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from evmap import configs
from evmap.maps import pipeline
from evmap.maps.app.log_run import run_log
from evmap.maps.app.run import run_scenario
from evmap.maps.belief_map import BeliefMap, new_map
from evmap.maps.corners import drawn_reach, find_corners
from evmap.maps.log_observation import observation_from_log
from evmap.maps.merging import merge_segments
from evmap.maps.noise import judge, settled
from evmap.maps.observation import Observation, observe
from evmap.maps.pipeline import touched_segments
from evmap.maps.rebuild import rebuild
from evmap.maps.sensed import LATEST_POSES, pose_sensed, remember
from evmap.sources.config import load_config
from evmap.sources.logs import open_log
from evmap.sources.logs.scan import LaserScan, LogRecord
from evmap.sources.readings import LslSegments
from evmap.sources.relation import relation
from evmap.sources.sim.scenario import default_scenario, load_scenario
from evmap.sources.sim.world import World

LOG = Path(__file__).parent / "data" / "logs" / "intel-excerpt.log.gz"
CLUTTER_LOG = Path(__file__).parent / "data" / "logs" / "freiburg-079-excerpt.log.gz"
FIRST_SCANS = Path(__file__).parent / "data" / "logs" / "freiburg-079-first146.log.gz"


@pytest.fixture(scope="module", params=["patrol", "log", "log, corners kept"])
def patrol(request):
    """A simulated patrol, and a real log (corners of three lines and more, lines refitted at them), its corners
    joined after the last scan and kept at every update."""
    if request.param == "log":
        return run_log(LOG, load_config("default"))
    if request.param == "log, corners kept":
        return corners_kept_run(LOG)
    return patrol_run()


def corners_kept_run(path):
    """The log folded scan by scan into a map whose corners are joined after the first scan, so that every later
    update keeps them up to date (as on a map with sonar, whose stages read them): the local rebuild of corners
    on a real log's clutter."""
    config = load_config("default")
    bm = new_map(config)
    for k, record in enumerate(open_log(path)):
        bm.update(observation_from_log(record, config, k))
        if k == 0:
            assert bm.corners_deferred and not bm.corners()
            bm.join_corners()
        assert not bm.corners_deferred
    return SimpleNamespace(map=bm, config=config)


def patrol_run():
    """The patrol scenario under the default config."""
    return run_scenario(load_scenario(configs.path("scenarios/patrol.yaml")), load_config())


def test_lines_are_the_merge_of_every_surviving_segment(patrol):
    store, config = patrol.map.segments, patrol.config
    assert relation(store.p, store.q, patrol.map.open_space, config.noise).tolist() == store.relation.tolist()
    assert_lines_of_the_whole_merge(patrol)


def assert_lines_of_the_whole_merge(run):
    """The map's lines are those a merge of every surviving segment makes, and their rows name them."""
    store, config = run.map.segments, run.config
    keep = np.flatnonzero(~store.eliminated & (store.role != "absorbed"))
    merged = merge_segments(store.p[keep], store.q[keep], config.merge, store.seen[keep])
    whole = sorted(tuple(keep[g].tolist()) for g in merged.groups)
    local = sorted(tuple(sorted(d["members"])) for _, _, d in run.map.graph.edges())
    assert local == whole
    for _, _, d in run.map.graph.edges():
        assert (store.line[d["members"]] == d["id"]).all()
    assert (store.line[store.eliminated] == "").all()


def test_corners_are_those_of_every_line(patrol):
    assert_corners_of_every_line(patrol)


@pytest.mark.parametrize("kept", [False, True], ids=["joined at the end", "kept"])
def test_lines_and_corners_of_a_cluttered_log_are_those_of_every_line(kept):
    """Corners of many short lines, whose ends come within the corner distance of ends of lines left as they
    are: those ends are found anew with them; and the lines are the whole merge's."""
    run = corners_kept_run(CLUTTER_LOG) if kept else run_log(CLUTTER_LOG, load_config("default"))
    assert_lines_of_the_whole_merge(run)
    assert_corners_of_every_line(run)


def test_a_free_end_that_leaves_a_cluster_of_ends_lets_its_corner_be_found():
    """Freiburg 079's first 146 scans, corners kept at every update: a long line's free end lay within the
    corner distance of three short lines' ends, which the corners' rules then left free (drawn apart); its
    refit moves the end away, and the three ends make their corner, as a whole rebuild finds it (the refit in
    place left them free)."""
    run = corners_kept_run(FIRST_SCANS)
    assert len(run.map.poses) == 146
    assert_corners_of_every_line(run)


def test_a_log_without_sonar_leaves_line_ends_free_until_its_corners_are_joined(tmp_path):
    """No stage of an update without sonar reads corners: the map's ends stay free while the log is folded,
    its lines those of every update; joined at the end, the corners are the whole map's, the lines the same."""
    config = load_config("default")
    bm = new_map(config)
    for k, record in enumerate(open_log(CLUTTER_LOG)):
        bm.update(observation_from_log(record, config, k))
        assert bm.corners_deferred and not bm.corners(min_belief=0)
        assert all(bm.graph.degree(n) == 1 for n in bm.graph.nodes)
    fits = {lid: bm.graph.edge(*bm.ends(lid))["fit"] for lid in bm.line_ids()}
    run = SimpleNamespace(map=bm, config=config)
    assert_lines_of_the_whole_merge(run)
    bm.save(tmp_path / "map.json")
    loaded = BeliefMap.load(tmp_path / "map.json")
    assert loaded.corners_deferred and loaded.join_corners() == set(fits)
    joined = bm.join_corners()
    assert joined == set(fits) and not bm.corners_deferred and bm.join_corners() == set()
    assert {lid: bm.graph.edge(*bm.ends(lid))["fit"] for lid in bm.line_ids()} == fits
    assert_corners_of_every_line(run)
    assert len(bm.corners(min_belief=0)) > 30
    assert loaded.to_data()["nodes"] == bm.to_data()["nodes"]
    kept = corners_kept_run(CLUTTER_LOG).map
    assert sorted(map(tuple, fits.values())) == sorted(tuple(d["fit"]) for _, _, d in kept.graph.edges())


def test_the_first_update_with_sonar_joins_the_corners_the_map_deferred():
    """A map that began without sonar (the corridor's stripe alone) joins its corners at its first update with
    sonar, whose simulated sonar reads them: then every update keeps them."""
    config = load_config("default")
    world = World(default_scenario())
    first = observe(world, 0, config)
    bm = new_map(config)
    bm.update(dataclasses.replace(first, sonar=None, robot_pose=first.pose))
    assert bm.corners_deferred and not bm.corners(min_belief=0)
    bm.update(dataclasses.replace(first, pose_index=1))
    assert not bm.corners_deferred and bm.corners(min_belief=0)
    assert_corners_of_every_line(SimpleNamespace(map=bm, config=config))
    bm.update(dataclasses.replace(first, pose_index=2, sonar=None, robot_pose=first.pose))
    assert not bm.corners_deferred and bm.corners(min_belief=0)


def assert_corners_of_every_line(run):
    """The map's corners are those the whole map's lines make, but for two lines that would meet at both ends (a
    thin wedge; the graph cannot hold two edges between the same two points): the shorter keeps both ends free
    and its corners are placed without it, at the mean of the others' ends (a corner left with one line is none).
    And a whole rebuild of the corners (``join_corners`` on the map saved and loaded) leaves every line's points
    as they are."""
    g = run.map.graph
    ids = [d["id"] for _, _, d in g.edges()]
    fits = np.array([d["fit"] for _, _, d in g.edges()])
    whole = find_corners(fits[:, 0], fits[:, 1], run.config.corners, merge=run.config.merge)
    freed, joined = set(), set()
    for i in np.lexsort((ids, -np.hypot(*(fits[:, 1] - fits[:, 0]).T))).tolist():
        at = frozenset(whole.corner_of[i].tolist())
        if at in joined:
            freed.add(i)
        elif -1 not in at:
            joined.add(at)
    expected = set()
    for k, ends in enumerate(whole.ends):
        kept = [(i, e) for i, e in ends.tolist() if i not in freed]
        xy = whole.xy[k] if len(kept) == len(ends) else np.mean([fits[i, e] for i, e in kept], axis=0)
        if len(kept) >= 2:
            expected.add((frozenset(ids[i] for i, _ in kept), tuple(xy.round(9).tolist())))
    local = {
        (frozenset(d["id"] for d in g.adj[n].values()), tuple(np.asarray(p["xy"], dtype=float).round(9).tolist()))
        for n, p in g.nodes.items()
        if p["kind"] == "corner"
    }
    assert local == expected  # (the same to a nanometre: a corner's mean sums its ends in the lines' order)
    with tempfile.TemporaryDirectory() as tmp:
        run.map.save(Path(tmp) / "map.json")
        rebuilt = BeliefMap.load(Path(tmp) / "map.json")
    rebuilt.join_corners()
    assert line_points(rebuilt) == line_points(run.map)


def line_points(bm):
    """Each line's two points: (kind, position) of each, by line id."""
    g = bm.graph
    return {d["id"]: sorted((g.nodes[n]["kind"], tuple(g.nodes[n]["xy"])) for n in (u, v)) for u, v, d in g.edges()}


@pytest.mark.parametrize("kind", ["patrol", "log"])
def test_points_end_the_right_number_of_lines(kind):
    run = run_log(LOG, load_config("default")) if kind == "log" else patrol_run()
    g = run.map.graph
    for n, d in g.nodes.items():  # an end point ends one line, a corner two or more
        if d["kind"] == "endpoint":
            assert g.degree(n) == 1
        elif d["kind"] == "corner":
            assert g.degree(n) >= 2


def test_segments_eliminated_before_the_latest_poses_are_settled():
    """The corridor passed again and again: its old phantoms stay noise and are not judged again."""
    config = load_config("default")
    first = observe(World(default_scenario()), 0, config)
    bm = new_map(config)
    for k in range(LATEST_POSES + 2):
        bm.update(dataclasses.replace(first, pose_index=k))
    store = bm.segments
    old = np.flatnonzero(store.eliminated & (store.pose == 0))
    recent = np.flatnonzero(store.eliminated & (store.pose == LATEST_POSES + 1))
    assert len(old) and len(recent)
    new = np.flatnonzero(store.pose == LATEST_POSES + 1)
    touched = touched_segments(bm, new, bm.open_space_near(bm.extent()), config)
    assert not np.isin(old, touched).any() and np.isin(recent, touched).all()
    assert store.eliminated[old].all()  # still in the store, noise for good
    assert settled(bm, old).all() and not settled(bm, recent).any()
    # forgotten as they are found: no later lookup finds them (nor counts them as another pose's segment on one
    # judged, or one continuing its end)
    assert not np.isin(old, store.near(bm.extent())).any()
    assert np.isin(recent, store.near(bm.extent())).all()


def laser_only(pose_index, p, q):
    """A laser-only observation of the segments p-q from (1, 1)."""
    n = len(p)
    none, pose = np.full(n, ""), np.full(n, pose_index)
    lsl = LslSegments(np.array(p, dtype=float), np.array(q, dtype=float), none, np.zeros(n, int), none, pose)
    return Observation(pose_index, None, lsl, robot_pose=(1.0, 1.0, 0.0))


def test_two_lines_that_meet_at_both_ends_leave_the_shorter_free():
    """A thin wedge: two lines 10.6 deg apart whose ends meet pairwise within the corner distance, and a third
    line at one end (the paper's config: corners not drawn apart). The longer keeps the corner with the third,
    placed at the mean of their ends; the shorter keeps both ends free; the wedge's other end is no corner of one
    line (it was: the shorter drawn there, the longer drawn to it)."""
    bm = new_map(load_config("paper"))
    bm.update(laser_only(0, [[0, 0], [0, 0.03], [0, 0.01]], [[0.3, 0], [0.28, -0.025], [0, 0.5]]))
    bm.join_corners()
    g = bm.graph
    points = {d["members"][0]: [(g.nodes[n]["kind"], tuple(g.nodes[n]["xy"])) for n in (u, v)] for u, v, d in g.edges()}
    corner = ("corner", (0.0, 0.005))
    assert points == {
        0: [corner, ("endpoint", (0.3, 0.0))],
        1: [("endpoint", (0.0, 0.03)), ("endpoint", (0.28, -0.025))],
        2: [corner, ("endpoint", (0.0, 0.5))],
    }
    assert_corners_of_every_line(SimpleNamespace(map=bm, config=bm.config))


def test_lines_a_scan_comes_near_but_leaves_as_they_are_stay_as_they_are():
    """A corner of two walls and a piece of clutter whose both ends are within the corner distance (one joins
    the corner, the other stays free); a later segment 25 cm from a wall, too far to merge with it or to be
    drawn related to it by a corner (:func:`~evmap.maps.corners.drawn_reach`), changes none of them: same ids,
    same points, the corner the whole map's."""
    bm = new_map(load_config("default"))
    bm.update(laser_only(0, [[0, 0], [0, 0], [0.02, 0.02]], [[2, 0], [0, 2], [0.035, 0.035]]))
    bm.join_corners()  # kept from now on
    before = sorted((d["id"], u, v, d["fit"]) for u, v, d in bm.graph.edges())
    assert [(lid, u, v) for lid, u, v, _ in before] == [("L1", "C1", "E7"), ("L2", "C1", "E8"), ("L3", "C1", "E9")]
    assert drawn_reach(bm.config.corners, bm.config.merge) < 0.25
    bm.update(laser_only(1, [[0.5, 0.25]], [[1.5, 0.25]]))
    after = sorted((d["id"], u, v, d["fit"]) for u, v, d in bm.graph.edges())
    assert after[:3] == before and [lid for lid, *_ in after[3:]] == ["L4"]
    fits = np.array([fit for *_, fit in after])
    whole = find_corners(fits[:, 0], fits[:, 1], bm.config.corners, merge=bm.config.merge)
    assert whole.xy.tolist() == [list(bm.graph.nodes["C1"]["xy"])]


def test_a_segment_the_new_rays_go_through_is_judged_again_though_nothing_is_seen_beside_it():
    """A person seen once by a laser without sonar: no open space, and the next scan sees nothing near their
    place, only the wall behind; its rays through the place contradict the person's segment."""
    config = load_config("default")
    angles = np.radians(np.arange(-30.0, 30.5, 0.5))
    wall = 4.0 / np.cos(angles)
    person = np.where(np.abs(2.0 * np.tan(angles)) <= 0.15, 2.0 / np.cos(angles), wall)
    scans = [LaserScan(float(k), np.zeros(3), angles, ranges, 80.0) for k, ranges in enumerate([person, wall])]
    first, second = (observation_from_log(LogRecord(k, s, np.zeros(3)), config, k) for k, s in enumerate(scans))
    bm = new_map(config)
    bm.update(first)
    store = bm.segments
    (there,) = np.flatnonzero(np.isclose(store.p[:, 0], 2.0, atol=0.05))
    assert store.line[there] != "" and not store.eliminated[there]
    remember(bm, second)
    new = store.append(second.lsl.p, second.lsl.q, np.full(len(second.lsl), 1), second.lsl.truth)
    assert there not in touched_segments(bm, new, shapely.MultiPolygon(), config)  # nothing near it
    assert there in touched_segments(bm, new, shapely.MultiPolygon(), config, pose_sensed(bm, 1))
    bm = new_map(config)
    bm.update(first)
    bm.update(second)
    assert bm.segments.eliminated[there] and bm.segments.line[there] == ""


def test_a_line_that_grows_toward_a_line_no_update_touched_joins_it():
    """A wall seen as two pieces 6-7 cm apart across, too far to merge; a later piece beyond the first's other
    end, which comes nowhere near the second, tilts the first's line toward it: the second is merged again with
    them, as a merge of the whole map would."""
    bm = new_map(load_config("default"))
    bm.update(laser_only(0, [[0, 0], [1.03, 0.06]], [[1, 0], [2, 0.07]]))
    assert sorted(d["members"] for _, _, d in bm.graph.edges()) == [[0], [1]]
    bm.update(laser_only(1, [[-1, -0.045]], [[-0.02, -0.005]]))
    store = bm.segments
    whole = merge_segments(store.p, store.q, bm.config.merge)
    assert [g.tolist() for g in whole.groups] == [[0, 1, 2]]
    assert [d["members"] for _, _, d in bm.graph.edges()] == [[0, 1, 2]]


def test_lines_whose_segments_keep_their_verdict_are_not_rebuilt(monkeypatch):
    """A segment 8 cm from a wall, too far to merge with it: the wall's segment is judged again (it is near), keeps
    its verdict, and its line is left out of the rebuild; judging the same segments again changes nothing."""
    config = load_config("default")
    bm = new_map(config)
    bm.update(laser_only(0, [[0, 0]], [[2, 0]]))
    judged, rebuilt = [], []
    monkeypatch.setattr(pipeline, "judge", lambda bm, ids, config: judged.append(ids) or judge(bm, ids, config))
    monkeypatch.setattr(
        pipeline, "rebuild", lambda bm, rows, *a, **k: rebuilt.append(rows) or rebuild(bm, rows, *a, **k)
    )
    bm.update(laser_only(1, [[0.5, 0.08]], [[1.5, 0.08]]))
    assert judged[0].tolist() == [0, 1] and rebuilt[0].tolist() == [1]
    assert judge(bm, np.array([0, 1]), config).tolist() == []
    assert sorted(d["members"] for _, _, d in bm.graph.edges()) == [[0], [1]]


def test_a_segment_that_joins_a_line_brings_the_line_into_the_rebuild(monkeypatch):
    """A second piece of the wall, merging's candidate with the first: its line is rebuilt with it."""
    bm = new_map(load_config("default"))
    bm.update(laser_only(0, [[0, 0]], [[1, 0]]))
    rebuilt = []
    monkeypatch.setattr(
        pipeline, "rebuild", lambda bm, rows, *a, **k: rebuilt.append(rows) or rebuild(bm, rows, *a, **k)
    )
    bm.update(laser_only(1, [[0.9, 0.01], [0.5, 0.5]], [[2, 0.01], [0.5, 1.5]]))
    assert rebuilt[0].tolist() == [0, 1, 2]
    assert sorted(d["members"] for _, _, d in bm.graph.edges()) == [[0, 1], [2]]


def test_open_space_that_changes_no_line_relation_rebuilds_no_line(monkeypatch):
    """The corridor's sonar heard again from the same place, the stripe seeing nothing: the new open space meets
    the map's lines but changes the relation of none, and no segment's verdict changes: nothing is rebuilt."""
    config = load_config("default")
    first = observe(World(default_scenario()), 0, config)
    bm = new_map(config)
    bm.update(first)
    lines = {lid: list(bm.graph.edge(*bm.ends(lid))["fit"]) for lid in bm.line_ids()}
    rebuilt = []
    monkeypatch.setattr(
        pipeline, "rebuild", lambda bm, rows, *a, **k: rebuilt.append(rows) or rebuild(bm, rows, *a, **k)
    )
    none, nothing = np.zeros((0, 2)), np.zeros(0, dtype=np.intp)
    lsl = LslSegments(none, none, np.zeros(0, dtype=str), nothing, np.zeros(0, dtype=str), nothing)
    features = {name: np.asarray(values)[:0] for name, values in first.features.items()}
    bm.update(dataclasses.replace(first, pose_index=1, lsl=lsl, features=features, rays=None))
    fits = shapely.linestrings(np.array(list(lines.values())))
    assert shapely.intersects(fits, bm.open_space).sum() >= 10  # the open space meets the corridor's lines
    assert rebuilt[0].tolist() == []
    assert {lid: list(bm.graph.edge(*bm.ends(lid))["fit"]) for lid in bm.line_ids()} == lines
