"""Unidentified objects behind another object's pane are double bounces off the glass, not objects."""

from __future__ import annotations

import numpy as np
import pytest
from pinned_worlds import former

from evidential import MassFunction
from evmap import configs
from evmap.maps import new_map
from evmap.maps.explained_objects import behind_panes, drop_explained
from evmap.maps.observation import observe
from evmap.maps.sensed import remember, sensed
from evmap.sources.config import config_from_data, load_config
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World

BELIEVED = {"real": 0.6, "real|noise": 0.4}
"""A Type I object's mass (``sonar_only``): believed."""

DOUBTED = {"real": 0.4, "real|noise": 0.6}
"""A Type II object's mass: not believed, so no pane."""


def _map(name: str, poses: int = 1):
    """A map that remembers what the patrol's first ``poses`` poses sensed, and holds no object yet."""
    config = load_config(configs.path(f"{name}.yaml"))
    world = World(load_scenario(configs.path("scenarios/patrol.yaml")))
    bm = new_map(config)
    for k in range(poses):
        remember(bm, observe(world, k, config))
    return bm


def _object(bm, name: str, xy, mass: dict, poses=(0,)) -> None:
    bm.add_point(name, xy, "unidentified", MassFunction(bm.frame, mass), history=[{"pose": k} for k in poses])


def test_an_object_behind_another_s_pane_is_removed_and_one_beside_or_on_it_is_kept() -> None:
    bm = _map("default")
    o = sensed(bm)[0].origin
    ahead, aside = np.array([1.0, 0.0]), np.array([np.cos(0.6), np.sin(0.6)])
    _object(bm, "pane", o + 2.0 * ahead, BELIEVED)
    _object(bm, "echo", o + 4.0 * ahead + [0.0, 0.5], BELIEVED)  # its path crosses the pane 0.25 m off its middle
    _object(bm, "beside", o + 4.0 * aside, BELIEVED)  # its path passes the pane by
    _object(bm, "on", o + 2.2 * ahead, BELIEVED)  # within merge_radius beyond it: that pane's own echo
    assert bm.config.unidentified.pane_width == 1.5
    assert behind_panes(bm, bm.config) == ["echo"]
    assert drop_explained(bm, bm.config) == ["echo"]
    assert sorted(u.id for u in bm.unidentified()) == ["beside", "on", "pane"]


def test_a_doubted_object_is_no_pane_and_nothing_is_removed_under_the_paper_s_method() -> None:
    for name, mass, hidden in (("default", DOUBTED, []), ("paper", BELIEVED, [])):
        bm = _map(name)
        o = sensed(bm)[0].origin
        _object(bm, "pane", o + [2.0, 0.0], mass)
        _object(bm, "echo", o + [4.0, 0.0], BELIEVED)
        assert behind_panes(bm, bm.config) == hidden
        assert drop_explained(bm, bm.config) == []


def _clear(s, xy, radius: float = 0.3) -> bool:
    """Whether no stripe point of the pose ``s`` lies within ``radius`` of ``xy``."""
    ok = np.isfinite(s.range)
    ends = s.origin + s.range[ok, None] * np.column_stack([np.cos(s.bearing[ok]), np.sin(s.bearing[ok])])
    return bool(np.hypot(*(ends - xy).T).min() > radius)


def test_an_object_another_pose_heard_past_the_pane_is_kept() -> None:
    bm = _map("default", poses=2)
    first, second = sensed(bm)
    along = (second.origin - first.origin) / np.hypot(*(second.origin - first.origin))
    side = np.array([-along[1], along[0]])
    assert np.hypot(*(second.origin - first.origin)) > 2.5  # the second pose's path passes the pane's end
    assert _clear(first, first.origin + 0.8 * side)  # the corridor's wall is 1.2 m aside
    target = first.origin + 1.15 * side
    _object(bm, "pane", first.origin + 0.8 * side, BELIEVED)  # between the first pose and the target
    _object(bm, "target", target, BELIEVED, poses=(0, 1))  # heard from both: the second pose's path is clear
    _object(bm, "echo", target + 0.4 * along, BELIEVED, poses=(0,))  # heard from the first pose only
    assert behind_panes(bm, bm.config) == ["echo"]


def test_an_object_on_the_stripe_is_no_pane() -> None:
    """A believed object where the stripe put a point (a corner, a pillar: both sensors saw it) hides nothing."""
    bm = _map("default")
    s = sensed(bm)[0]
    ok = np.flatnonzero(np.isfinite(s.range) & (s.range > 2.0))
    k = ok[len(ok) // 2]
    u = np.array([np.cos(s.bearing[k]), np.sin(s.bearing[k])])
    _object(bm, "corner", s.origin + s.range[k] * u, BELIEVED)  # on a stripe point
    _object(bm, "behind", s.origin + (s.range[k] + 1.0) * u, BELIEVED)
    assert behind_panes(bm, bm.config) == []


def test_pane_width_is_checked() -> None:
    data = load_config("default").to_data()
    data["unidentified"]["pane_width"] = -0.1
    with pytest.raises(Exception, match="pane_width"):
        config_from_data(data, "bad")


def test_an_echo_beyond_a_wide_window_in_a_wall_is_a_double_bounce() -> None:
    """A generated room whose west wall has a window 2.55 m wide (the stripe returns nothing through it): the
    sonar's double bounce off the glass, placed 3 m outside, is beyond the chord across the window with
    ``window_width`` 10 m, not with the free space's 2.5 m (mirror images left out: ``mirror_tolerance``
    removes that double bounce too)."""
    from evmap.maps.app.compare_hazards import surface_distances
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    default = load_config("default")
    data = default.to_data()
    data["unidentified"]["window_width"] = 2.5
    data["unidentified"]["mirror_tolerance"] = 0.0
    narrow = config_from_data(data, "narrow")
    scenario = generate_world(world_seed(22, 4), former(column_max_share=0.0))
    far = {}
    for name, config in (("default", default), ("narrow", narrow)):
        run = fuse_rules(scenario, config, ["dempster"])["dempster"]
        xy = np.array([u.xy for u in run.map.unidentified()]).reshape(-1, 2)
        far[name] = int((surface_distances(xy, run.world.surfaces()) > 1.0).sum())  # more than 1 m outside
    assert default.unidentified.window_width == 10.0 and far == {"default": 0, "narrow": 1}
