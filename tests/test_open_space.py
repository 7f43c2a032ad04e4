"""Open space from typed primitive RCDs (paper, section II.A)."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given
from hypothesis import strategies as st

from evmap.sources.open_space import open_space
from evmap.sources.params import OpenSpaceParams, RcdParams, SonarParams
from evmap.sources.rcd import extract_rcds
from evmap.sources.readings import SonarScan
from evmap.sources.sim.scenario import parse_scenario
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World

NO_FOOT = OpenSpaceParams(footprint_radius=0.0)


def scan_of(ranges, pose=(0.0, 0.0, 0.0)) -> SonarScan:
    r = np.asarray(ranges, float)
    return SonarScan.from_readings(pose[2] + np.radians(np.arange(360.0)), r, SonarParams(), pose=pose)


def polar(r, deg):
    return shapely.Point(r * np.cos(np.radians(deg)), r * np.sin(np.radians(deg)))


def space(scan, params=NO_FOOT):
    return open_space(scan, extract_rcds(scan, RcdParams(), primitive=True), params)


def test_type_one_sector_reaches_its_shortest_reading_minus_the_margin():
    r = np.full(360, 10.0)
    r[80:101] = 2.0
    r[90] = 1.99  # within the tolerance: same RCD, shortest reading 1.99
    area = space(scan_of(r))
    assert area.contains(polar(1.95, 90)) and not area.contains(polar(1.97, 90))
    # over its beam-axis angles plus half a step each side, nothing beyond
    assert area.contains(polar(1.0, 79.6)) and not area.contains(polar(1.0, 79.4))
    assert area.contains(polar(1.0, 100.4)) and not area.contains(polar(1.0, 100.6))


def test_types_two_and_three_reach_the_shorter_neighbour_and_type_four_nothing():
    # I: 1.0; II: 2.0 (1.0 before, 2.5 after); III: 2.5 (2.0, 2.2); I: 2.2 (2.5, 4.0); IV: 4.0 (jump), max range
    r = np.full(360, 10.0)
    r[0:20], r[20:40], r[40:60], r[60:80], r[80:100], r[100:120] = 1.0, 2.0, 2.5, 2.2, 4.0, 2.2
    rcds = extract_rcds(scan_of(r), RcdParams(), primitive=True)
    assert rcds.type.tolist() == [1, 2, 3, 1, 4, 1, 4]
    area = open_space(scan_of(r), rcds, NO_FOOT)
    assert area.contains(polar(0.96, 30)) and not area.contains(polar(0.98, 30))  # II: up to 1.0 - 3 cm
    assert area.contains(polar(1.96, 50)) and not area.contains(polar(1.98, 50))  # III: up to 2.0 - 3 cm
    assert not area.contains(polar(0.1, 90))  # IV: nothing
    assert not area.contains(polar(0.1, 200))  # max range: nothing


def test_widening_by_half_the_beam_and_the_footprint():
    r = np.full(360, 10.0)
    r[80:101] = 2.0
    plain = space(scan_of(r))
    wide = space(scan_of(r), OpenSpaceParams(footprint_radius=0.0, widen_by_half_beam=True))
    assert not plain.contains(polar(1.0, 70)) and wide.contains(polar(1.0, 70))
    assert wide.contains(polar(1.0, 67.1)) and not wide.contains(polar(1.0, 66.9))  # 80 - 0.5 - 12.5
    foot = space(scan_of(r), OpenSpaceParams())
    assert foot.contains(polar(0.19, 200)) and not foot.contains(polar(0.21, 200))


def test_nothing_open_and_a_full_turn():
    assert space(scan_of(np.full(360, 10.0))).is_empty
    disc = space(scan_of(np.full(360, 3.0)))
    assert abs(disc.area - np.pi * 2.97**2) < 1e-3 * disc.area


def test_empty_scan_is_the_footprint_only():
    scan = SonarScan.from_readings([], [], SonarParams(), pose=(1.0, 2.0, 0.0))
    area = open_space(scan, extract_rcds(scan, RcdParams(), primitive=True), OpenSpaceParams())
    assert abs(area.area - np.pi * 0.2**2) < 1e-3 and area.contains(shapely.Point(1, 2))


def test_square_room_open_space_reaches_each_wall_seen_and_no_further():
    room_yaml = (
        "{version: 1, name: room, robot: {poses: [[1.5, 2.2, 0]]},"
        " world: {walls: [{id: room, points: [[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]]}]}}"
    )
    square = World(parse_scenario(room_yaml, "room.yaml")).surfaces()
    pose = np.array([1.5, 2.2, 0.1])
    scan = simulate_scan(square, pose, SonarParams())
    rcds = extract_rcds(scan, RcdParams(), primitive=True)
    area = open_space(scan, rcds, OpenSpaceParams())
    # the walls are 1.5, 2.5, 2.2 and 1.8 m away; corners are further
    walls = rcds.select(np.isin(np.round(rcds.range, 6), [1.5, 2.5, 2.2, 1.8]))
    assert len(walls) == 4 and set(walls.type.tolist()) == {1}
    for direction, r in zip(walls.direction, walls.range):
        u = np.array([np.cos(direction), np.sin(direction)])
        assert area.contains(shapely.Point(pose[:2] + (r - 0.04) * u))
        assert not area.contains(shapely.Point(pose[:2] + (r - 0.02) * u))


@given(
    st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-np.pi, np.pi)),
    st.integers(0, 2**32 - 1),
    st.lists(st.tuples(st.floats(-6, 6), st.floats(-6, 6), st.floats(-6, 6), st.floats(-6, 6)), min_size=1, max_size=6),
)
def test_open_space_always_contains_the_sensor(pose, seed, walls):
    ends = np.array(walls, float).reshape(-1, 2)
    n = len(walls)
    world = Surfaces(
        vertices=ends,
        vertex_ids=np.array([f"v{i}" for i in range(2 * n)]),
        segments=np.arange(2 * n).reshape(-1, 2),
        segment_ids=np.array([f"w{i}" for i in range(n)]),
        lsl_opaque=np.ones(n, bool),
        sonar_reflective=np.ones(n, bool),
    )
    scan = simulate_scan(world, pose, SonarParams(), rng=np.random.default_rng(seed))
    area = open_space(scan, extract_rcds(scan, RcdParams(), primitive=True), OpenSpaceParams())
    assert area.contains(shapely.Point(pose[:2]))
