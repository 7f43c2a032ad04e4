"""Unidentified objects behind the stripe of every pose that heard them are multiple reflections: judged again as
lines become believed (``unidentified.behind_depth``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from evidential import MassFunction
from evmap.maps import new_map
from evmap.maps.explained_objects import behind_stripes, drop_explained, judged_objects
from evmap.maps.sensed import LATEST_POSES, Sensed, heard_from, remember, sensed
from evmap.maps.stripe_contour import stripe_bound
from evmap.sources.config import config_from_data, load_config

BELIEVED = {"real": 0.6, "real|noise": 0.4}
DOUBTED = {"real": 0.4, "real|noise": 0.6}
BEARING = np.radians(np.arange(-180.0, 180.0, 0.5))


def _wall_rays(origin, x: float, phantom: float | None = None) -> np.ndarray:
    """(K, 2) bearing, range of a stripe from ``origin`` that sees the wall at ``x`` within 40 degrees of east,
    with a phantom ``phantom`` m off in front of its left half when given (the gap it leaves in the wall's points
    is no window: it reaches the stripe's end)."""
    rng = np.where(np.abs(BEARING) < np.radians(40), (x - origin[0]) / np.cos(BEARING), np.nan)
    if phantom is not None:
        rng[(BEARING >= 0) & (BEARING < np.radians(40))] = phantom
    return np.column_stack([BEARING, rng])


def _map(name: str = "default"):
    """A map with a wall x = 2 (a line L, doubted) seen by the stripe of pose 0 at the origin."""
    bm = new_map(load_config(name))
    _pose(bm, 0, (0.0, 0.0), _wall_rays((0.0, 0.0), 2.0))
    sure = MassFunction(bm.frame, {"real": 1.0})
    bm.add_point("A", (2.0, -3.0), "endpoint", sure)
    bm.add_point("B", (2.0, 3.0), "endpoint", sure)
    bm.add_line("L", "A", "B", MassFunction(bm.frame, DOUBTED))
    return bm


def _pose(bm, k: int, xy, rays) -> None:
    remember(bm, SimpleNamespace(pose_index=k, pose=np.array([*xy, 0.0]), rays=rays, sonar=None, all_returns=False))


def _object(bm, name: str, xy, poses=(0,)) -> None:
    """An object heard from ``poses``; doubted, so that it is no pane (``pane_width``) hiding the others."""
    bm.add_point(name, xy, "unidentified", MassFunction(bm.frame, DOUBTED), history=[{"pose": k} for k in poses])


def _believe(bm, line: str = "L") -> None:
    bm.set_attrs(line, mass=MassFunction(bm.frame, BELIEVED))


def test_an_object_behind_a_wall_the_stripe_saw_is_removed_once_the_wall_is_believed() -> None:
    bm = _map()
    assert bm.config.unidentified.behind_depth == 1.0
    _object(bm, "behind", (4.0, 0.5))  # 2 m beyond the wall the stripe saw
    _object(bm, "near", (2.6, 0.0))  # 0.6 m beyond: within behind_depth, may be the wall's own echo
    _object(bm, "front", (1.5, 0.3))
    _object(bm, "aside", (-3.0, 0.0))  # behind the pose, where the stripe saw nothing
    assert behind_stripes(bm, bm.config, None) == []  # the wall is not believed yet
    _believe(bm)
    assert behind_stripes(bm, bm.config, set()) == []  # judged only near the lines an update changed
    assert behind_stripes(bm, bm.config, {"L"}) == ["behind"]
    assert drop_explained(bm, bm.config, {"L"}) == ["behind"]
    assert sorted(u.id for u in bm.unidentified()) == ["aside", "front", "near"]


def test_an_object_another_pose_heard_from_in_front_is_kept() -> None:
    bm = _map()
    _pose(bm, 1, (3.0, 0.0), np.column_stack([BEARING, np.full(len(BEARING), np.nan)]))  # beyond the wall
    _object(bm, "both", (4.0, 0.5), poses=(0, 1))
    _object(bm, "first", (4.0, -0.5), poses=(0,))
    _object(bm, "unknown", (4.0, 1.5), poses=(0, 7))  # pose 7: readings the map does not remember
    _believe(bm)
    assert [s.pose_index for s in sensed(bm)] == [0, 1]
    assert behind_stripes(bm, bm.config, {"L"}) == ["first"]


def test_nothing_is_judged_again_under_the_paper_s_method() -> None:
    bm = _map("paper")
    _object(bm, "behind", (4.0, 0.5))
    _believe(bm)
    assert bm.config.unidentified.behind_depth == 0
    assert behind_stripes(bm, bm.config, {"L"}) == [] and drop_explained(bm, bm.config, {"L"}) == []


def test_a_phantom_in_front_of_the_wall_leaves_a_hole_in_the_contour() -> None:
    rays = _wall_rays((0.0, 0.0), 2.0, phantom=1.0)
    s = Sensed(0, np.zeros(2), rays[:, 0], rays[:, 1], None)
    p, q = np.array([[2.0, -3.0]]), np.array([[2.0, 3.0]])
    bound = stripe_bound(s, p, q, load_config("default").unidentified, 10.0)
    assert bound.contains(shapely.Point(3.0, 1.0))  # behind the phantom: the stripe did not measure the wall there
    assert not bound.contains(shapely.Point(3.0, -1.0))  # behind the wall it measured


def test_behind_depth_is_checked() -> None:
    data = load_config("default").to_data()
    data["unidentified"]["behind_depth"] = -1.0
    with pytest.raises(Exception, match="behind_depth"):
        config_from_data(data, "bad")


def test_objects_the_latest_poses_did_not_hear_are_settled() -> None:
    """Past :data:`LATEST_POSES` poses, an update judges only the objects one of the latest poses heard, each from
    the latest poses that heard it: an update costs what the robot's place holds, not the map."""
    bm = _map()
    for k in range(LATEST_POSES + 2):
        bm.add_pose(k)
        if k:
            _pose(bm, k, (0.0, 0.0), _wall_rays((0.0, 0.0), 2.0))
    _object(bm, "old", (4.0, 0.5), poses=(0,))  # behind the wall, heard before the latest poses
    _object(bm, "new", (4.0, -0.5), poses=(0, LATEST_POSES + 1))
    _object(bm, "often", (4.0, 1.0), poses=range(LATEST_POSES + 2))
    assert heard_from(bm, "often") == list(range(2, LATEST_POSES + 2))
    assert judged_objects(bm, bm.config) == ["new", "often"]
    _believe(bm)
    assert drop_explained(bm, bm.config, {"L"}) == ["new", "often"]
    assert [u.id for u in bm.unidentified()] == ["old"]  # settled: kept as it is
    bm.fold("old", MassFunction(bm.frame, DOUBTED), {"pose": LATEST_POSES + 1})  # heard again: judged again
    assert drop_explained(bm, bm.config, {"L"}) == ["old"]
