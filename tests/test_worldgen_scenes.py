"""The scenes the generator makes for noise elimination: facades, large halls, tours, both detectors, clutter."""

from __future__ import annotations

from itertools import pairwise

import hypothesis.strategies as st
import numpy as np
import pytest
import shapely
from hypothesis import given, settings

from evmap.sources.params import SonarParams
from evmap.sources.sim.scenario import (
    MAX_PHANTOMS_PER_RUN,
    MAX_POSES,
    MAX_SUNLIGHT_LINES,
    MAX_SUNLIGHT_REGIONS,
    parse_scenario,
)
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.world import World, visible
from evmap.sources.sim.worldgen import generate_world, scenario_yaml, world_seed
from evmap.sources.sim.worldgen_furniture import CLUTTER_GAP, SUNLIT_CENTRE
from evmap.sources.sim.worldgen_params import WorldGenParams

PARAMS = WorldGenParams()


@pytest.fixture(scope="module")
def worlds():
    return [generate_world(world_seed(7, i)) for i in range(40)]


def _segments(scenario):
    """Every wall segment of the scenario as a shapely MultiLineString."""
    return shapely.MultiLineString([[a, b] for w in scenario.world.walls for a, b in zip(w.points, w.points[1:])])


def _ring(scenario):
    """The free space: the polygon of the building's walls (not partitions, not clutter)."""
    ring = [w for w in scenario.world.walls if not w.id.startswith(("partition", "box"))]
    return shapely.Polygon([p for w in ring for p in w.points[:-1]])


def test_tours_are_paths_in_sight_and_clear(worlds):
    counts = [len(w.robot.poses) for w in worlds]
    assert set(counts) <= {1, 2, 3, 4, 5, 6}
    assert 0 < counts.count(1) < len(worlds) / 2
    assert sum(3 <= c <= 6 for c in counts) >= 0.45 * len(worlds)
    for w in worlds:
        world = World(w)
        s = world.surfaces()
        walls = _segments(w)
        xy = world.poses[:, :2]
        for a, b in pairwise(xy):
            assert PARAMS.pose_step[0] - 1e-3 <= np.hypot(*(b - a)) <= PARAMS.pose_step[1] + 1e-3
            assert visible(s, a, [b])[0], w.name
            path = shapely.LineString([a, b])
            assert walls.distance(path) >= PARAMS.path_clearance - 1e-3, w.name
            for c in w.world.cylinders:
                assert shapely.Point(c.center).distance(path) - c.radius >= PARAMS.path_clearance - 1e-3


def test_long_tours_when_asked():
    params = WorldGenParams(poses=(6, 6), single_pose_share=0)
    counts = [len(generate_world(world_seed(8, i), params).robot.poses) for i in range(30)]
    assert np.mean(np.array(counts) == 6) >= 0.9


def test_facades_are_panes_between_mullions(worlds):
    facades = 0
    for w in worlds:
        walls = w.world.walls
        for a, b, c in zip(walls, walls[1:], walls[2:]):
            if a.material == c.material == "glass" and b.material == "wall" and len(b.points) == 2:
                mullion = np.hypot(*np.subtract(b.points[1], b.points[0]))
                if PARAMS.mullion_width[0] - 1e-6 <= mullion <= PARAMS.mullion_width[1] + 1e-6:
                    facades += 1
                    break
    assert facades >= 0.2 * len(worlds)


def test_large_halls_lose_most_sonar_echoes():
    """In a large specular hall most readings are at max range (oblique walls echo away); not in corridors."""

    def max_range_share(params):
        shares = []
        for i in range(6):
            world = World(generate_world(world_seed(9, i), params))
            for pose in world.poses:
                shares.append(np.mean(simulate_scan(world.surfaces(), pose, SonarParams()).ranges >= 10.0))
        return np.mean(shares)

    large = WorldGenParams(large_hall_share=1, hall_share=0)
    corridor = WorldGenParams(large_hall_share=0, hall_share=0)
    assert max_range_share(large) > 0.5 > max_range_share(corridor)
    assert all(_ring(generate_world(world_seed(9, i), large)).area >= 12 * 8 for i in range(6))


def test_both_detectors_by_share(worlds):
    detectors = [w.sensors.lsl.detector for w in worlds]
    assert 0.25 < detectors.count("column_max") / len(detectors) < 0.75
    assert "sensors:\n  lsl: {detector: " in scenario_yaml(worlds[0])
    for share, detector in ((0, "threshold"), (1, "column_max")):
        params = WorldGenParams(column_max_share=share)
        assert {generate_world(i, params).sensors.lsl.detector for i in range(8)} == {detector}


def test_clutter_is_small_real_and_clear_of_the_tour(worlds):
    boxes = legs = 0
    for w in worlds:
        ring = _ring(w)
        poses = [shapely.Point(p[:2]) for p in w.robot.poses]
        for wall in w.world.walls:
            if wall.id.startswith("box"):
                boxes += 1
                box = shapely.Polygon(wall.points)
                sides = np.hypot(*np.diff(np.array(wall.points), axis=0).T)
                assert wall.material == "wall" and len(sides) == 4
                assert (sides >= PARAMS.box_size[0] - 2e-3).all() and (sides <= PARAMS.box_size[1] + 2e-3).all()
                assert ring.buffer(-CLUTTER_GAP + 1e-3).contains(box)
                assert all(box.distance(p) >= PARAMS.clearance + CLUTTER_GAP - 1e-3 for p in poses)
        for c in w.world.cylinders:
            if c.id.startswith("chair"):
                legs += 1
                assert c.material == "wall" and PARAMS.leg_radius[0] <= c.radius <= PARAMS.leg_radius[1]
                assert all(p.distance(shapely.Point(c.center)) - c.radius >= PARAMS.clearance for p in poses)
    assert boxes >= len(worlds) and legs >= len(worlds)


def test_some_clutter_stands_in_the_sunlight_off_its_centroid(worlds):
    # furniture by a window: among the phantoms, but off the point the simulator looks at to see the region
    pieces = sunlit = 0
    for w in worlds:
        regions = [shapely.Polygon(r.polygon) for r in w.world.sunlight]
        shapes = [shapely.Polygon(x.points) for x in w.world.walls if x.id.startswith("box")]
        shapes += [shapely.Point(c.center).buffer(c.radius) for c in w.world.cylinders if c.id.startswith("chair")]
        for shape in shapes:
            pieces += 1
            lit = [r for r in regions if r.intersects(shape)]
            sunlit += bool(lit)
            assert all(shape.distance(r.centroid) >= SUNLIT_CENTRE - 1e-3 for r in lit)
    assert 0.1 * pieces <= sunlit <= 0.5 * pieces
    dark = WorldGenParams(sunlit_clutter_share=0)
    for i in range(10):
        w = generate_world(world_seed(7, i), dark)
        regions = shapely.union_all([shapely.Polygon(r.polygon) for r in w.world.sunlight])
        boxes = [shapely.Polygon(x.points) for x in w.world.walls if x.id.startswith("box")]
        assert all(box.distance(regions) >= CLUTTER_GAP - 1e-3 for box in boxes)


def test_sunlight_within_limits_on_long_tours():
    """Many lit panes and many poses: the phantom lines are scaled down to the scenario limits."""
    params = WorldGenParams(
        poses=(MAX_POSES - 2, MAX_POSES),
        single_pose_share=0,
        facade_share=1,
        sunlight_share=1,
        sunlight_lines=(200, 200),
        sunlight_lines_total=MAX_SUNLIGHT_LINES,
    )
    for i in range(3):
        w = generate_world(world_seed(10, i), params)
        lines = sum(r.lines for r in w.world.sunlight)
        assert 0 < lines <= MAX_SUNLIGHT_LINES and lines * len(w.robot.poses) <= MAX_PHANTOMS_PER_RUN
        assert parse_scenario(scenario_yaml(w), "w.yaml") == w
    few = generate_world(1, WorldGenParams(sunlight_lines_total=12, sunlight_share=1))
    assert sum(r.lines for r in few.world.sunlight) <= 12


@settings(max_examples=30)
@given(
    seed=st.integers(0, 2**63 - 1),
    shares=st.tuples(*[st.floats(0, 1)] * 6),
    hall=st.floats(0, 1),
    poses=st.integers(1, 8),
    clutter=st.integers(0, 12),
)
def test_any_seed_and_shares_give_a_valid_world_with_free_poses(seed, shares, hall, poses, clutter):
    facade, window, sunlight, single, column_max, mirror = shares
    params = WorldGenParams(
        facade_share=facade,
        window_share=window,
        sunlight_share=sunlight,
        single_pose_share=single,
        column_max_share=column_max,
        mirror_share=mirror,
        large_hall_share=hall,
        hall_share=(1 - hall) / 2,
        poses=(poses, poses),
        boxes=(clutter, clutter),
        chairs=(0, clutter // 3),
    )
    w = generate_world(seed, params)
    assert parse_scenario(scenario_yaml(w), "w.yaml") == w == generate_world(seed, params)
    assert 1 <= len(w.robot.poses) <= poses
    walls = _segments(w)
    for x, y, _ in w.robot.poses:
        assert walls.distance(shapely.Point(x, y)) >= PARAMS.clearance - 1e-3
        for c in w.world.cylinders:
            assert np.hypot(x - c.center[0], y - c.center[1]) - c.radius >= PARAMS.clearance - 1e-3


def test_a_long_facade_of_narrow_panes_stays_within_the_region_limit():
    params = WorldGenParams(
        large_hall_share=1,
        hall_share=0,
        large_hall_length=(60.0, 60.0),
        large_hall_width=(40.0, 40.0),
        facade_share=1,
        facade_min_length=30,
        pane_width=(0.3, 0.3),
        sunlight_share=1,
        sunlight_depth=(0.6, 0.6),
        phantom_length=(0.02, 0.05),
        single_pose_share=1,
    )
    w = generate_world(3, params)
    assert len(w.world.sunlight) == MAX_SUNLIGHT_REGIONS
    assert sum(x.material == "glass" for x in w.world.walls) > MAX_SUNLIGHT_REGIONS
