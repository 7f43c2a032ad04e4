"""The planner's queries (issue 6): objects above a belief, landmarks, nearest obstacle, clearance."""

import math
from unittest.mock import patch

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, MassFunction
from evmap.maps import BeliefMap, planner

FRAME = Frame(["real", "noise"])


def mass(real: float) -> MassFunction:
    return MassFunction(FRAME, {"real": real, "real|noise": 1 - real})


def random_map(seed: int, n: int = 60) -> BeliefMap:
    """Random lines (beliefs 0..1) and unidentified objects in a 10 m square, plus corners."""
    rng = np.random.default_rng(seed)
    bm = BeliefMap(FRAME)
    for i in range(n):
        p = rng.uniform(0, 10, 2)
        q = p + rng.uniform(-2, 2, 2)
        bm.add_point(f"A{i}", p, "corner" if i % 3 else "endpoint", mass(rng.uniform(0, 1)))
        bm.add_point(f"B{i}", q, "endpoint", mass(rng.uniform(0, 1)))
        bm.add_line(f"L{i}", f"A{i}", f"B{i}", mass(rng.uniform(0, 1)), reinforced=bool(i % 2))
    for i in range(n // 4):
        bm.add_point(f"U{i}", rng.uniform(0, 10, 2), "unidentified", mass(rng.uniform(0, 1)))
    return bm


def obstacles(bm: BeliefMap, min_belief: float) -> tuple[list[str], np.ndarray]:
    """Brute force: ids and shapely geometries of all lines and unidentified objects with that belief."""
    lines = [line for line in bm.lines(0.0) if line.belief >= min_belief]
    targets = [p for p in bm.unidentified() if p.belief >= min_belief]
    ids = [o.id for o in lines + targets]
    geoms = [shapely.LineString([o.p, o.q]) for o in lines] + [shapely.Point(o.xy) for o in targets]
    return ids, np.array(geoms, dtype=object)


@pytest.fixture(scope="module")
def bm() -> BeliefMap:
    return random_map(0)


def test_lines_above_a_belief_carry_their_ends_mass_belief_and_plausibility(bm):
    everything = bm.lines(0.0)
    strong = bm.lines(min_belief=0.5)
    assert len(everything) == 60 and [line.id for line in strong] == [x.id for x in everything if x.belief >= 0.5]
    for line in strong:
        assert line.belief >= 0.5 and line.belief == line.mass.belief("real")
        assert line.plausibility == line.mass.plausibility("real") == 1.0
        assert line.p == bm.graph.nodes[line.u]["xy"] and line.q == bm.graph.nodes[line.v]["xy"]
    assert bm.lines(1.0) == [] and len(bm.lines()) == len(strong)


def test_corners_unidentified_and_landmarks(bm):
    corners = bm.corners(0.3)
    assert corners and all(c.kind == "corner" and c.belief >= 0.3 for c in corners)
    assert {c.id for c in corners} == {n for n, d in bm.graph.nodes.items()
                                       if d["kind"] == "corner" and d["mass"].belief("real") >= 0.3}  # fmt: skip
    assert [u.id for u in bm.unidentified()] == [f"U{i}" for i in range(15)]
    assert all(u.belief >= 0.5 for u in bm.unidentified(0.5))
    small = BeliefMap(FRAME)
    small.add_point("C1", (0, 0), "corner", mass(0.9), reinforced=True)
    small.add_point("C2", (1, 0), "corner", mass(0.9))
    small.add_point("E1", (0, 1), "endpoint", mass(0.9), reinforced=True)
    small.add_point("U1", (5, 5), "unidentified", mass(0.9), reinforced=True)
    small.add_line("L1", "C1", "C2", mass(0.2), reinforced=True)
    small.add_line("L2", "C1", "E1", mass(0.9))
    assert [o.id for o in small.landmarks()] == ["L1", "C1"]


@pytest.mark.parametrize("min_belief", [0.0, 0.5, 0.8])
def test_nearest_obstacle_agrees_with_brute_force(bm, min_belief):
    ids, geoms = obstacles(bm, min_belief)
    for x, y in np.random.default_rng(1).uniform(-2, 12, (100, 2)):
        distance, found = bm.nearest_obstacle((x, y), min_belief=min_belief)
        d = shapely.distance(geoms, shapely.Point(x, y))
        assert distance == pytest.approx(d.min(), abs=1e-12)
        assert found in ids and d[ids.index(found)] == pytest.approx(d.min(), abs=1e-12)


@pytest.mark.parametrize("min_belief", [0.0, 0.5, 0.8])
def test_is_segment_clear_agrees_with_brute_force(bm, min_belief):
    _, geoms = obstacles(bm, min_belief)
    rng = np.random.default_rng(2)
    answers = []
    for a, b, clearance in zip(rng.uniform(0, 10, (150, 2)), rng.uniform(0, 10, (150, 2)), rng.uniform(0, 0.5, 150)):
        clear = bm.is_segment_clear(a, b, clearance=clearance, min_belief=min_belief, unknown="free")
        expected = bool((shapely.distance(geoms, shapely.LineString([a, b])) > clearance).all())
        assert clear == expected
        answers.append(clear)
    assert any(answers) and not all(answers)


def test_clearance_boundary_corners_and_degenerate_segments():
    bm = BeliefMap(FRAME)
    bm.add_point("C1", (0, 0), "corner", mass(0.9))
    bm.add_point("C2", (4, 0), "corner", mass(0.9))
    bm.add_line("L1", "C1", "C2", mass(0.9))
    bm.add_point("U1", (2, 3), "unidentified", mass(0.9))
    assert bm.is_segment_clear((0, 1), (4, 1), clearance=0.5, unknown="free")
    assert not bm.is_segment_clear((0, 1), (4, 1), clearance=1.0, unknown="free")  # exactly at the clearance: not clear
    assert not bm.is_segment_clear((2, 2.9), (2, 2.9), clearance=0.2, unknown="free")  # a point next to U1
    assert bm.nearest_obstacle((2, 2.5)) == (0.5, "U1")
    assert bm.nearest_obstacle((-1, 0)) == (1.0, "L1")  # corners are not obstacles: their lines are
    assert bm.nearest_obstacle((2, 2.5), min_belief=0.95) == (math.inf, None)
    assert bm.is_segment_clear((0, 0), (4, 0), min_belief=0.95, unknown="free")


def test_queries_follow_changes_of_the_map():
    bm = BeliefMap(FRAME)
    bm.add_point("C1", (0, 0), "corner", mass(0.9))
    bm.add_point("C2", (4, 0), "corner", mass(0.9))
    assert bm.nearest_obstacle((2, 1)) == (math.inf, None) and bm.is_segment_clear((0, 0), (4, 0), unknown="free")
    bm.add_line("L1", "C1", "C2", mass(0.4))
    assert bm.nearest_obstacle((2, 1)) == (math.inf, None)
    assert bm.nearest_obstacle((2, 1), min_belief=0.3) == (1.0, "L1")
    bm.fold("L1", mass(0.5), {"pose": 1})  # belief 0.7: now an obstacle at 0.5
    assert bm.nearest_obstacle((2, 1)) == (1.0, "L1") and not bm.is_segment_clear((2, 0.1), (2, 2), unknown="free")
    bm.set_attrs("C2", xy=(4, 4))
    assert bm.nearest_obstacle((4, 0))[0] == pytest.approx(math.sqrt(8))
    bm.remove_line("L1")
    assert bm.nearest_obstacle((2, 1), min_belief=0.0) == (math.inf, None) and bm.lines(0.0) == []


def brute_force(bm: BeliefMap, min_belief: float) -> tuple[list[str], np.ndarray]:
    """Ids and geometries of the obstacles read straight from the graph (no cache, no index of the map)."""
    g = bm.graph
    ids, geoms = [], []
    for u, v, d in g.edges():
        if d["mass"].belief("real") >= min_belief:
            ids.append(d["id"])
            geoms.append(shapely.LineString([g.nodes[u]["xy"], g.nodes[v]["xy"]]))
    for n, d in g.nodes.items():
        if d["kind"] == "unidentified" and d["mass"].belief("real") >= min_belief:
            ids.append(n)
            geoms.append(shapely.Point(d["xy"]))
    return ids, np.array(geoms, dtype=object)


def check_queries(bm: BeliefMap, min_belief: float, a: tuple[float, float], b: tuple[float, float], clearance: float):
    ids, geoms = brute_force(bm, min_belief)
    for xy in (a, b):
        distance, found = bm.nearest_obstacle(xy, min_belief)
        if not ids:
            assert (distance, found) == (math.inf, None)
            continue
        d = shapely.distance(geoms, shapely.Point(xy))
        assert distance == pytest.approx(d.min(), abs=1e-9)
        assert d[ids.index(found)] == pytest.approx(d.min(), abs=1e-9)
        assert found == min(i for i, di in zip(ids, d, strict=True) if di <= d.min() + 1e-9)  # ties: by id
    d = shapely.distance(geoms, shapely.LineString([a, b])) if ids else np.zeros(0)
    if not np.any(np.abs(d - clearance) < 1e-9):  # not on the boundary, where rounding decides
        assert bm.is_segment_clear(a, b, clearance, min_belief, unknown="free") == bool((d > clearance).all())


coordinate = st.floats(-4, 24, allow_nan=False).map(lambda v: round(v, 1))  # round: ties and touching segments
change = st.tuples(st.sampled_from(["line", "target", "remove", "drop", "fold", "move", "kind"]),
                   st.integers(0, 1000), st.tuples(coordinate, coordinate), st.tuples(coordinate, coordinate),
                   st.floats(0.01, 0.99))  # fmt: skip


@given(
    seed=st.integers(0, 1000),
    changes=st.lists(change, max_size=10),
    min_belief=st.sampled_from([0.0, 0.3, 0.6, 0.9]),
    clearance=st.sampled_from([0.0, 0.1, 0.5, 2.0, 30.0]),
)
def test_queries_right_after_changes_agree_with_brute_force(seed, changes, min_belief, clearance):
    bm = random_map(seed, n=8)
    bm.nearest_obstacle((0, 0))  # grids and belief cache made: from now on kept up to date
    bm.lines(0.0)  # the whole-map index made, to be dropped by the changes
    for n, (what, pick, a, b, real) in enumerate(changes):
        lines, points = sorted((u, v) for u, v, _ in bm.graph.edges()), sorted(bm.graph.nodes)
        if what == "line":
            bm.add_point(f"P{n}", a, "corner", mass(real))
            bm.add_point(f"Q{n}", b, "endpoint", mass(real))
            if a != b:
                bm.add_line(f"N{n}", f"P{n}", f"Q{n}", mass(real))
        elif what == "target":
            bm.add_point(f"T{n}", a, "unidentified", mass(real))
        elif what == "remove" and lines:
            bm.remove_line(bm.graph.edge(*lines[pick % len(lines)])["id"])
        elif what == "drop" and (loose := [n for n in points if not bm.graph.degree(n)]):
            bm.remove_point(loose[pick % len(loose)])
        elif what == "fold":
            ids = [bm.graph.edge(*e)["id"] for e in lines] + points
            bm.fold(ids[pick % len(ids)], mass(real), {"pose": n})
        elif what == "move":
            bm.set_attrs(points[pick % len(points)], xy=a)
        elif what == "kind":
            bm.set_attrs(points[pick % len(points)], kind=["unidentified", "corner"][pick % 2])
        with patch.object(planner, "MapState", side_effect=AssertionError("rebuilt from the whole map")):
            check_queries(bm, min_belief, a, b, clearance)  # the queries rebuild nothing from the whole map
    check_queries(bm, min_belief, (1e4, -1e4), (-1e4, 1e4), clearance)  # from far away: found, not searched forever


def test_unknown_space_blocks_a_path_unless_told_free():
    bm = BeliefMap(FRAME)
    assert not bm.is_segment_clear((0, 0), (1, 0))  # a map that saw nothing free: nothing is clear
    bm.open_space = shapely.Polygon([(0, 0), (4, 0), (4, 4), (0, 4)]).difference(shapely.box(1.5, 1.5, 2.5, 2.5))
    assert bm.is_segment_clear((0.5, 0.5), (3.5, 0.5))
    assert not bm.is_segment_clear((0.5, 0.5), (5.0, 0.5))  # leaves the building
    assert not bm.is_segment_clear((0.5, 2.0), (3.5, 2.0))  # crosses a hole no sensor saw free
    assert bm.is_segment_clear((0.5, 0.5), (5.0, 0.5), unknown="free")
    with pytest.raises(ValueError, match="unknown must be one of"):
        bm.is_segment_clear((0, 0), (1, 0), unknown="maybe")


def test_unknown_space_is_the_grid_s_on_a_run_and_on_a_log_without_sonar():
    """The free space a path must keep to is the occupancy grid's (the sensors' free space short of believed
    surfaces), not the stored sonar open space: a double bounce's sector beyond a wall is no free space, and a
    laser-only log, which stores no sonar open space, still has the free space of its rays."""
    from pathlib import Path

    from evmap.maps.app.log_run import run_log
    from evmap.maps.app.run import run_scenario
    from evmap.maps.free_space import free_space
    from evmap.sources.config import load_config
    from evmap.sources.sim.scenario import default_scenario

    corridor = run_scenario(default_scenario(), load_config()).map
    behind = ((8.3, -0.5), (8.3, -2.0))  # south of the corridor's south wall (y = 0)
    assert corridor.open_space.covers(shapely.LineString(behind))  # a sonar sector reached there
    assert not corridor.is_segment_clear(*behind) and corridor.is_segment_clear(*behind, unknown="free")
    assert free_space(corridor) is free_space(corridor)  # made once per version of the map
    log = run_log(Path(__file__).parent / "data" / "logs" / "intel-excerpt.log.gz", load_config(), limit=5).map
    assert log.open_space.is_empty
    inside = shapely.get_parts(free_space(log))
    start = max(inside, key=lambda g: g.area).representative_point()
    assert log.is_segment_clear((start.x, start.y), (start.x + 0.01, start.y), clearance=0.0)


def test_queries_without_obstacles_and_on_a_freshly_loaded_map(tmp_path):
    bm = BeliefMap(FRAME)
    assert bm.nearest_obstacle((3, 4), 0.0) == (math.inf, None) and bm.is_segment_clear(
        (0, 0), (1, 1), 1e9, unknown="free"
    )
    for i in range(50):  # a row of corners, none an obstacle, and one faint target far off
        bm.add_point(f"C{i}", (i * 3.0, 0.0), "corner", mass(0.9))
    bm.add_point("U1", (500.0, 500.0), "unidentified", mass(0.1))
    assert bm.nearest_obstacle((0, 0)) == (math.inf, None) and bm.is_segment_clear(
        (0, 0), (150, 0), 1e9, unknown="free"
    )
    assert bm.nearest_obstacle((0, 0), 0.1) == (pytest.approx(math.hypot(500, 500)), "U1")
    assert not bm.is_segment_clear((0, 0), (150, 0), 1e9, 0.1, unknown="free")
    bm.save(tmp_path / "map.json")
    loaded = BeliefMap.load(tmp_path / "map.json")
    with patch.object(planner, "MapState", side_effect=AssertionError("rebuilt from the whole map")):
        assert loaded.nearest_obstacle((499, 500), 0.1) == (1.0, "U1")
    loaded.fold("U1", mass(0.9), {"pose": 1})
    with patch.object(planner, "MapState", side_effect=AssertionError("rebuilt from the whole map")):
        assert loaded.nearest_obstacle((499, 500)) == (1.0, "U1")


def test_a_query_far_from_every_object_is_answered_not_searched_cell_by_cell():
    """The campaign's case (issue 16): one object at (30000, 30000), a query at (15000, 15000)."""
    bm = BeliefMap(FRAME)
    bm.add_point("U1", (30000.0, 30000.0), "unidentified", mass(0.9))
    assert bm.nearest_obstacle((15000, 15000)) == (pytest.approx(math.hypot(15000, 15000)), "U1")
    assert bm.nearest_obstacle((-1e7, 1e7)) == (pytest.approx(math.hypot(1e7 + 30000, 1e7 - 30000)), "U1")
    assert bm.is_segment_clear((-1e7, -1e7), (1e7, -1e7), unknown="free")


def test_nearest_obstacle_ties_are_decided_by_id():
    bm = BeliefMap(FRAME)
    for name, xy in (("U2", (1.0, 0.0)), ("U3", (-1.0, 0.0)), ("U1", (0.0, -1.0)), ("U0", (8.0, 0.0))):
        bm.add_point(name, xy, "unidentified", mass(0.9))
    assert bm.nearest_obstacle((0, 0)) == (1.0, "U1")  # U2 is in the cell of (0, 0), U1 and U3 are not


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda bm: bm.nearest_obstacle((0, math.nan)), "finite"),
        (lambda bm: bm.nearest_obstacle((0, 1, 2)), r"\(x, y\)"),
        (lambda bm: bm.nearest_obstacle((0, 0), min_belief=1.5), "min_belief"),
        (lambda bm: bm.lines(min_belief=-0.1), "min_belief"),
        (lambda bm: bm.corners(min_belief="high"), "min_belief"),
        (lambda bm: bm.is_segment_clear((0, 0), (1, 1), clearance=-1), "clearance"),
        (lambda bm: bm.is_segment_clear((0, 0), (1, math.inf)), "finite"),
        # far beyond any map (issue 16): refused, not answered wrongly by overflow nor searched for
        (lambda bm: bm.nearest_obstacle((1e300, 0)), r"xy: .*within 2e\+07 m"),
        (lambda bm: bm.is_segment_clear((1e300, 1), (-1e300, 1), unknown="free"), r"a: .*within 2e\+07 m"),
        # a bool or a string is no number (as in the scenario files)
        (lambda bm: bm.lines(min_belief=True), "min_belief"),
        (lambda bm: bm.nearest_obstacle((True, False)), r"xy: a point must be two numbers \(x, y\)"),
        (lambda bm: bm.nearest_obstacle(("1", 0)), r"xy: a point must be two numbers"),
        (lambda bm: bm.is_segment_clear((0, 0), (1, 1), clearance=False), "clearance"),
        (lambda bm: bm.occupancy_grid(resolution="0.05"), "resolution must be a positive number of metres"),
        (lambda bm: bm.occupancy_grid(resolution=None), "resolution must be a positive number of metres"),
    ],
)
def test_bad_query_arguments_are_refused(bm, call, match):
    with pytest.raises(ValueError, match=match):
        call(bm)


def test_a_map_is_updated_with_an_observation_and_saved_to_a_file(bm, tmp_path):
    from evmap.maps import new_map
    from evmap.sources.config import load_config

    for wrong in ("hello", None):
        with pytest.raises(TypeError, match="a map is updated with an Observation"):
            new_map(load_config()).update(wrong)
    for place in (tmp_path, tmp_path / "sub"):
        place.mkdir(exist_ok=True)
        with pytest.raises(IsADirectoryError, match=f"a directory: name the file to write: '{place}'"):
            bm.save(place)
    assert [p.name for p in tmp_path.iterdir()] == ["sub"]  # nothing half-written


def test_a_path_within_clearance_of_a_surface_the_stripe_measured_but_the_map_has_no_line_for_is_not_clear():
    """The stripe met the corridor's south wall at a grazing angle and no line was fitted there; the free space
    of its rays keeps 5 cm from the wall, and a path 10 cm from it was approved with clearance 0.2."""
    from evmap.maps import planner
    from evmap.maps.app.run import run_scenario
    from evmap.maps.free_space import free_space, surface_points
    from evmap.sources.config import load_config
    from evmap.sources.sim.scenario import default_scenario

    corridor = run_scenario(default_scenario(), load_config()).map
    path = ((2.0, 1.2), (2.8, 0.1))  # ends 10 cm from the wall y = 0
    assert not [
        ln for ln in corridor.lines() if abs(ln.p[1]) < 0.1 and abs(ln.q[1]) < 0.1 and min(ln.p[0], ln.q[0]) < 2.8
    ]
    assert planner.is_segment_clear(corridor, *path, 0.2, 0.5, "blocked", free_space(corridor))  # the free space alone
    assert not corridor.is_segment_clear((2.0, 1.2), (2.8, 0.03), clearance=0.0)  # which keeps 5 cm from the wall
    assert not corridor.is_segment_clear(*path, clearance=0.2)  # its points are kept at a distance
    assert corridor.is_segment_clear((2.0, 1.2), (6.0, 1.2), clearance=0.2)  # the corridor's middle stays clear
    assert len(surface_points(corridor).geometries) > 100
