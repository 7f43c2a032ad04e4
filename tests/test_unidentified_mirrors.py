"""Unidentified objects at the mirror image of a believed corner or wall end in a believed wall (or the glass
continuing it) or in a pane are that target's echo off the surface, not objects (``unidentified.mirror_tolerance``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from pinned_worlds import former

from evidential import MassFunction
from evmap.maps import new_map
from evmap.maps.explained_objects import drop_explained
from evmap.maps.mirror_echoes import MIRROR_MIN_LENGTH, mirror_echoes
from evmap.maps.sensed import remember
from evmap.maps.unidentified import BELIEVED as BELIEF
from evmap.sources.config import config_from_data, load_config
from evmap.sources.params import SonarParams
from evmap.sources.readings import SonarScan

BELIEVED = {"real": 0.6, "real|noise": 0.4}
DOUBTED = {"real": 0.4, "real|noise": 0.6}
BEARING = np.radians(np.arange(-180.0, 180.0, 0.5))
CORNER = (2.0, 1.5)
"""A corner of two believed walls."""


def _pose(bm, k: int, xy, sonar=None) -> None:
    """A pose whose stripe sees a wall x = 5 within 40 degrees of east (nothing of the walls below)."""
    rng = np.where(np.abs(BEARING) < np.radians(40), (5.0 - xy[0]) / np.cos(BEARING), np.nan)
    rays = np.column_stack([BEARING, rng])
    remember(bm, SimpleNamespace(pose_index=k, pose=np.array([*xy, 0.0]), rays=rays, sonar=sonar, all_returns=False))


def _line(bm, name: str, p, q, mass=BELIEVED) -> None:
    for end, xy in (("p", p), ("q", q)):
        if f"{name}{end}" not in bm:
            bm.add_point(f"{name}{end}", xy, "endpoint", MassFunction(bm.frame, mass))
    bm.add_line(name, f"{name}p", f"{name}q", MassFunction(bm.frame, mass))


def _map(name: str = "default", wall: float = 2.0):
    """Poses 0 at (0, 0) and 1 at (3, -2.5), beyond y = -1; a believed wall y = -1 from x = -1 - ``wall`` to -1 (glass may
    continue it, unseen); the corner at :data:`CORNER`, of two believed lines; a believed line D."""
    bm = new_map(load_config(name))
    _pose(bm, 0, (0.0, 0.0))
    _pose(bm, 1, (3.0, -2.5))
    _line(bm, "W", (-1.0 - wall, -1.0), (-1.0, -1.0))
    bm.add_point("C", CORNER, "corner", MassFunction(bm.frame, BELIEVED))
    bm.add_point("A", (2.0, 3.5), "endpoint", MassFunction(bm.frame, BELIEVED))
    bm.add_point("B", (0.0, 1.5), "endpoint", MassFunction(bm.frame, BELIEVED))
    bm.add_line("CA", "C", "A", MassFunction(bm.frame, BELIEVED))
    bm.add_line("CB", "C", "B", MassFunction(bm.frame, BELIEVED))
    _line(bm, "D", (1.0, 0.5), (1.0, 1.0))  # its free end (1, 0.5) in sight of the wall's line
    return bm


def _object(bm, name: str, xy, poses=(0,)) -> None:
    """An object heard from ``poses``; doubted, so that it is no pane (``pane_width``)."""
    bm.add_point(name, xy, "unidentified", MassFunction(bm.frame, DOUBTED), history=[{"pose": k} for k in poses])


MIRROR = (2.0, -3.5)
"""The corner's mirror image in the line y = -1."""


def test_a_corner_s_mirror_image_in_a_wall_s_line_is_removed() -> None:
    bm = _map()
    assert bm.config.unidentified.mirror_tolerance == 0.25
    _object(bm, "ghost", (MIRROR[0] + 0.1, MIRROR[1] - 0.1))  # the path crosses y = -1 at x = 0.6: glass beside W
    _object(bm, "edge", (1.0, -2.5))  # the free end Dp's image
    _object(bm, "hidden", (2.0, -5.5))  # the free end A's image, A behind the line CB seen from y = -1
    _object(bm, "off", (MIRROR[0] + 0.5, MIRROR[1]))  # 0.5 m from the image
    _object(bm, "front", (1.0, -0.5))  # in front of the wall's line
    assert mirror_echoes(bm, bm.config, BELIEF) == ["edge", "ghost"]
    assert drop_explained(bm, bm.config, set()) == ["edge", "ghost"]
    assert sorted(u.id for u in bm.unidentified()) == ["front", "hidden", "off"]


def test_a_corner_s_mirror_image_in_a_pane_s_face_is_removed() -> None:
    """Glass heard at normal incidence (a believed object the stripe saw through: a pane, square to the bearing it
    was heard at) mirrors sound like a wall, also past the face's ends."""
    maps = {}
    for case in ("pane", "doubted", "no panes"):
        config = load_config("default")
        if case == "no panes":
            data = config.to_data()
            data["unidentified"]["pane_width"] = 0.0
            config = config_from_data(data, "no panes")
        bm = maps[case] = new_map(config)
        _pose(bm, 0, (0.0, 0.0))
        _pose(bm, 1, (-0.5, 0.0))
        bm.add_point("C", CORNER, "corner", MassFunction(bm.frame, BELIEVED))
        bm.add_point("A", (2.0, 3.5), "endpoint", MassFunction(bm.frame, BELIEVED))
        bm.add_point("B", (0.0, 1.5), "endpoint", MassFunction(bm.frame, BELIEVED))
        bm.add_line("CA", "C", "A", MassFunction(bm.frame, BELIEVED))
        bm.add_line("CB", "C", "B", MassFunction(bm.frame, BELIEVED))
        # heard straight below pose 1: the face y = -2 from x = -1.25 to 0.25 (pane_width 1.5)
        mass = DOUBTED if case == "doubted" else BELIEVED
        bm.add_point("pane", (-0.5, -2.0), "unidentified", MassFunction(bm.frame, mass), history=[{"pose": 1}])
        _object(bm, "ghost", (2.0, -5.5))  # C's image in y = -2; its path crosses it at x = 0.73, past the face
        _object(bm, "off", (2.5, -5.5))
    assert drop_explained(maps["pane"], maps["pane"].config, set()) == ["ghost"]
    assert sorted(u.id for u in maps["pane"].unidentified()) == ["off", "pane"]
    for case in ("doubted", "no panes"):
        assert drop_explained(maps[case], maps[case].config, set()) == []


def test_the_mirror_image_of_a_believed_object_is_removed() -> None:
    """A pillar the map holds as a believed object sends sound back the way it came, as a corner does; a doubted
    object is no target."""
    bm = _map()
    bm.add_point("pillar", (-4.0, 1.0), "unidentified", MassFunction(bm.frame, BELIEVED), history=[{"pose": 1}])
    _object(bm, "faint", (-5.0, 1.0))
    _object(bm, "ghost", (-4.0, -3.0))  # the pillar's image in y = -1, its path crossing W at x = -1.33
    _object(bm, "other", (-5.0, -3.0))  # the doubted object's image
    assert mirror_echoes(bm, bm.config, BELIEF) == ["ghost"]


def test_an_object_another_pose_heard_otherwise_is_kept() -> None:
    bm = _map()
    _object(bm, "ghost", MIRROR, poses=(0,))
    _object(bm, "both", MIRROR, poses=(0, 1))  # pose 1 heard it on its side of y = -1: no image
    assert mirror_echoes(bm, bm.config, BELIEF) == ["ghost"]


def test_no_mirror_met_square_to_its_normal_where_the_sonar_heard_the_pose_s_readings() -> None:
    """A path that meets the mirror's line within the sonar's half-width of its normal would have been answered by
    the mirror itself, first: the free end B's image (0, -3.5) in y = -1 is heard straight across it."""
    bm = _map()
    _object(bm, "square", (0.0, -3.5))
    assert mirror_echoes(bm, bm.config, BELIEF) == ["square"]  # no readings of the pose: geometry alone
    heard = _map()
    _pose(heard, 0, (0.0, 0.0), _scan(square=1.0))
    _object(heard, "square", (0.0, -3.5))
    _object(heard, "ghost", MIRROR)  # met 30 degrees off the normal
    assert mirror_echoes(heard, heard.config, BELIEF) == ["ghost"]


def test_no_mirror_carried_past_a_line_s_end_square_in_front_of_a_pose_that_heard_nothing_there() -> None:
    """Glass carrying the wall y = -1 on past its end (x = -1) to the ghost's crossing (x = 0.6) passes 1 m straight
    below pose 0, where the pose would have heard it square: readings that came back from 3.5 m there say that
    nothing stands there. Readings from 1 m say something does (the test above)."""
    bm = _map()
    _pose(bm, 0, (0.0, 0.0), _scan(square=None))
    _object(bm, "ghost", MIRROR)
    assert mirror_echoes(bm, bm.config, BELIEF) == []


def _scan(square: float | None) -> SonarScan:
    """A full turn of readings from 3.5 m, but from ``square`` m within 20 degrees of straight down."""
    angles = np.radians(np.arange(0.0, 360.0, 1.8))
    ranges = np.full(len(angles), 3.5)
    if square is not None:
        ranges[np.abs(angles - np.radians(270.0)) <= np.radians(20.0)] = square
    return SonarScan.from_readings(angles, ranges, SonarParams())


def test_no_mirror_in_a_short_or_doubted_line_nor_past_its_end_farther_than_it_is_long_or_than_a_window() -> None:
    short = _map(wall=MIRROR_MIN_LENGTH - 0.1)
    doubted = _map()
    doubted.set_attrs("W", mass=MassFunction(doubted.frame, DOUBTED))
    carried = _map(wall=1.5)  # the crossing at x = 0.6 lies 1.6 m past the end of a line 1.5 m long
    far = _map()
    far.set_attrs("Wp", xy=(-23.0, -1.0))
    far.set_attrs("Wq", xy=(-11.0, -1.0))  # 12 m long, the crossing 11.6 m past its end: beyond window_width
    paper = _map("paper")
    for bm in (short, doubted, carried, far, paper):
        _object(bm, "ghost", MIRROR)
        assert mirror_echoes(bm, bm.config, BELIEF) == []
    assert far.config.unidentified.window_width == 10.0 and paper.config.unidentified.mirror_tolerance == 0


def test_mirror_tolerance_is_checked() -> None:
    data = load_config("default").to_data()
    data["unidentified"]["mirror_tolerance"] = -0.1
    with pytest.raises(Exception, match="mirror_tolerance"):
        config_from_data(data, "bad")


@pytest.mark.parametrize("seed, index", [(41, 25), (42, 20)])
def test_a_corner_s_image_behind_a_glass_facade_is_removed_in_a_generated_world(seed: int, index: int) -> None:
    """Generated worlds where a pose hears a room's corner off the glass facade that continues a believed wall:
    the echo, placed 2.6-2.9 m outside the building, is the only object farther than 1 m from every true surface,
    and it goes with ``mirror_tolerance``; the other objects stay."""
    from evmap.maps.app.compare_hazards import surface_distances
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    scenario = generate_world(world_seed(seed, index), former(column_max_share=0.0))
    data = load_config("default").to_data()
    data["unidentified"]["mirror_tolerance"] = 0.0
    kept = {}
    for name, config in (("default", load_config("default")), ("off", config_from_data(data, "off"))):
        run = fuse_rules(scenario, config, ["dempster"])["dempster"]
        xy = np.array([u.xy for u in run.map.unidentified()]).reshape(-1, 2)
        kept[name] = surface_distances(xy, run.world.surfaces())
    assert (kept["off"] > 1.0).sum() == 1 and (kept["default"] > 1.0).sum() == 0
    assert sorted(kept["off"][kept["off"] <= 1.0].tolist()) == sorted(kept["default"].tolist())
