"""The random world generator: valid scenarios, reproducible, with the features asked for."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from evmap.sources.sim.scenario import parse_scenario
from evmap.sources.sim.world import World, visible
from evmap.sources.sim.worldgen import generate_world, scenario_yaml, wall_segment_count, world_seed
from evmap.sources.sim.worldgen_params import WorldGenParams

SEEDS = range(24)


@pytest.fixture(scope="module")
def worlds():
    return [generate_world(s) for s in SEEDS]


def test_same_seed_same_world_and_yaml_round_trip(worlds):
    for seed, world in zip(SEEDS, worlds):
        assert generate_world(seed) == world
        text = scenario_yaml(world)
        assert text == scenario_yaml(generate_world(seed))
        assert parse_scenario(text, f"{world.name}.yaml") == world
    assert len({scenario_yaml(w) for w in worlds}) == len(worlds)


def test_world_seeds_are_distinct_and_in_range():
    seeds = [world_seed(1, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    assert all(0 <= s < 2**63 for s in seeds)
    assert world_seed(1, 0) != world_seed(2, 0)


def test_modest_size(worlds):
    counts = [wall_segment_count(w) for w in worlds]
    assert min(counts) >= 20 and max(counts) <= 250


def test_windows_sunlight_and_phantom_lengths(worlds):
    for w in worlds:
        materials = {wall.material for wall in w.world.walls}
        assert "glass" in materials
        assert w.world.sunlight
        assert all(region.length == (0.05, 0.35) and region.lines > 0 for region in w.world.sunlight)
        # every sunlight region lies just inside a window
        glass = shapely.union_all([shapely.LineString(x.points) for x in w.world.walls if x.material == "glass"])
        assert all(glass.distance(shapely.Polygon(r.polygon)) <= 0.2 for r in w.world.sunlight)


def test_first_pose_sees_sunlight_and_poses_are_clear(worlds):
    params = WorldGenParams()
    for w in worlds:
        world = World(w)
        s = world.surfaces()
        xy = world.poses[:, :2]
        centroids = world.sunlight_centroids
        near = np.hypot(*(centroids - xy[0]).T) <= params.sight_range
        assert (near & visible(s, xy[0], centroids)).any(), w.name
        walls = shapely.MultiLineString([[tuple(a), tuple(b)] for a, b in zip(s.p, s.q)])
        for x, y in xy:
            assert walls.distance(shapely.Point(x, y)) >= params.clearance - 1e-3
            gap = np.hypot(*(s.cylinder_centers - (x, y)).T) - s.cylinder_radii
            assert (gap >= params.clearance - 1e-3).all()
            assert all(not shapely.Polygon(r.polygon).contains(shapely.Point(x, y)) for r in w.world.sunlight)


def test_features_appear_across_seeds(worlds):
    assert any(any(c.id.startswith("pillar") for c in w.world.cylinders) for w in worlds)
    assert any(any(x.id.startswith("partition") for x in w.world.walls) for w in worlds)
    assert any(len(w.robot.poses) >= 2 for w in worlds)
    many = [generate_world(s) for s in range(100, 160)]
    assert any(any(x.material == "mirror" for x in w.world.walls) for w in many)


def test_rooms_open_onto_the_corridor(worlds):
    """The free space is one region: its walls form one outer ring (doors and passages connect every room)."""
    for w in worlds:
        ring = [x for x in w.world.walls if not x.id.startswith(("partition", "box"))]
        for a, b in zip(ring, ring[1:] + ring[:1]):  # consecutive polylines of one closed ring
            assert a.points[-1] == b.points[0]
        polygon = shapely.Polygon([p for x in ring for p in x.points[:-1]])
        assert polygon.is_valid and polygon.area > 20
        assert all(polygon.contains(shapely.Point(pose[:2])) for pose in w.robot.poses)


def test_params_are_validated():
    with pytest.raises(ValueError, match="poses"):
        WorldGenParams(poses=(0, 1))
    with pytest.raises(ValueError, match="poses"):
        WorldGenParams(poses=(3, 51))
    with pytest.raises(ValueError, match="chairs"):
        WorldGenParams(chairs=(0, 250), pillars=(0, 1))
    with pytest.raises(ValueError, match="sunlight_lines"):
        WorldGenParams(sunlight_lines=(10, 201))
    with pytest.raises(ValueError, match="large_hall_share"):
        WorldGenParams(hall_share=0.6, large_hall_share=0.6)
    with pytest.raises(ValueError, match="room_width"):
        WorldGenParams(room_width=(4.0, 3.0))
    with pytest.raises(ValueError, match="seed"):
        generate_world(-1)


def test_params_change_the_world():
    w = generate_world(4, WorldGenParams(pillars=(3, 3), poses=(3, 3), single_pose_share=0, partitions=(0, 0)))
    assert len([c for c in w.world.cylinders if c.id.startswith("pillar")]) == 3
    assert len(w.robot.poses) == 3
    assert not any(x.id.startswith("partition") for x in w.world.walls)
    bare = generate_world(4, WorldGenParams(boxes=(0, 0), chairs=(0, 0), pillars=(0, 0), single_pose_share=1))
    assert not bare.world.cylinders and len(bare.robot.poses) == 1
