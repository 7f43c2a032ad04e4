"""The world built from a scenario: vertices, ids, material flags, poses, what hides what."""

from pathlib import Path

import numpy as np
import pytest

from evmap.sources.ray_casting import cast_rays
from evmap.sources.sim.scenario import Scenario, load_scenario
from evmap.sources.sim.world import World, visible, wall_id

HERE = Path(__file__).parent / "scenarios"


def world_of(walls: list, cylinders: list | None = None, **extra: object) -> World:
    data = {
        "version": 1,
        "name": "t",
        "world": {"walls": walls, "cylinders": cylinders or []},
        "robot": {"poses": [[0.5, 0.5, 0]]},
        **extra,
    }
    return World(Scenario.model_validate(data))


@pytest.fixture(scope="module")
def room() -> World:
    return World(load_scenario(HERE / "room.yaml"))


def test_room_surfaces(room: World) -> None:
    s = room.surfaces()
    assert s.segment_ids.tolist() == [
        "room:0", "room:1", "window", "north:0", "north:1", "north:2", "closet:0", "closet:1", "closet:2",
    ]  # fmt: skip
    # the room is closed and the closet shares two of its corners: (0, 0) and (0, 4) have degree 3
    assert sorted(s.vertex_degree().tolist()) == [2, 2, 2, 2, 2, 2, 3, 3]
    assert s.vertex_ids.tolist() == [
        "room:p0",
        "room:p1",
        "room:p2",
        "window:p1",
        "north:p1",
        "north:p2",
        "closet:p1",
        "closet:p2",
    ]
    assert s.lsl_opaque.tolist() == [True, True, False, True, True, True, True, True, True]
    # glass is overridden to absorbing in this scenario; felt is a new absorbing material
    assert s.sonar_reflective.tolist() == [True, True, False, True, True, True, False, False, False]
    assert s.cylinder_ids.tolist() == ["pillar"] and s.cylinder_radii.tolist() == [0.2]
    assert s.cylinder_lsl_opaque.tolist() == [True] and s.cylinder_sonar_reflective.tolist() == [True]
    np.testing.assert_allclose(room.poses, [[2, 2, 0], [3, 1, np.pi / 2]])
    np.testing.assert_allclose(room.sunlight_centroids, [[5.15, 2], [-1, 2]])
    assert repr(room) == "World('room': 9 segments, 1 cylinders, 2 sunlight regions, 2 poses)"


def test_segment_ends_are_the_wall_points(room: World) -> None:
    s = room.surfaces()
    expected = [(wall.id, a, b) for wall in room.scenario.world.walls for a, b in zip(wall.points, wall.points[1:])]
    for (wid, a, b), sid, p, q in zip(expected, s.segment_ids, s.p, s.q):
        assert wall_id(sid) == wid
        np.testing.assert_array_equal([p, q], [a, b])


def test_vertices_merge_only_within_tolerance() -> None:
    world = world_of(
        [
            {"id": "a", "points": [[0, 0], [1, 0]]},
            {"id": "b", "points": [[1 + 1e-10, 0], [1, 1]]},  # meets a: one corner
            {"id": "c", "points": [[1, 1 + 1e-6], [0, 1]]},  # 1 um from b's end: two free ends
        ]
    )
    s = world.surfaces()
    assert s.vertex_ids.tolist() == ["a:p0", "a:p1", "b:p1", "c:p0", "c:p1"]
    assert s.vertex_degree().tolist() == [1, 2, 1, 1, 1]
    assert s.segments.tolist() == [[0, 1], [1, 2], [3, 4]]


def test_foam_and_mirror_flags() -> None:
    world = world_of(
        [
            {"id": "f", "points": [[0, 1], [1, 1]], "material": "foam"},
            {"id": "m", "points": [[0, 2], [1, 2]], "material": "mirror"},
        ],
        [{"id": "c", "center": [3, 3], "radius": 0.1, "material": "glass"}],
    )
    s = world.surfaces()
    assert s.lsl_opaque.tolist() == [True, False] and s.sonar_reflective.tolist() == [False, True]
    assert s.cylinder_lsl_opaque.tolist() == [False] and s.cylinder_sonar_reflective.tolist() == [True]


def test_empty_world() -> None:
    s = world_of([]).surfaces()
    assert s.vertices.shape == (0, 2) and s.segments.shape == (0, 2) and s.cylinder_centers.shape == (0, 2)
    ranges, hit = cast_rays([0, 0], [0, 1], s.p, s.q, s.cylinder_centers, s.cylinder_radii, 5)
    assert np.isinf(ranges).all() and (hit == -1).all()
    assert visible(s, [0, 0], [[1, 1]]).tolist() == [True]


def test_visible(room: World) -> None:
    s = room.surfaces()
    targets = [[5.15, 2], [-1, 2], [4, 3], [7, 2], [4.0, 3.5], [0, 2]]
    # through glass yes, behind a wall no, the pillar's centre no, beyond the glass yes,
    # behind the pillar no, a point on the wall itself yes
    assert visible(s, [2, 2], targets).tolist() == [True, False, False, True, True, True]
    assert visible(s, [4, 2], [[4, 3.5], [4, 2.5]]).tolist() == [False, True]
