"""A pane in line with a believed wall, heard square in a run the paper's rule takes no object from (or gives to a wall end)."""

from __future__ import annotations

import numpy as np
import pytest

from evmap.maps import new_map
from evmap.maps.app.compare_configs import resolve_config
from evmap.maps.app.compare_metrics import fuse_configs, heard_glass
from evmap.maps.pane_echoes import pane_echoes
from evmap.maps.simulated_sonar import check_sonar
from evmap.sources.config import load_config
from evmap.sources.params import SonarParams
from evmap.sources.rcd import TYPE_IV, extract_rcds
from evmap.sources.readings import SonarScan
from evmap.sources.sim.scenario import parse_scenario

ROOM = """
version: 1
name: pane-beside-legs
world:
  walls:
    - {id: wall, points: [[3.4, 6], [0, 6], [0, 0], [8, 0], [8, 6], [4.6, 6]]}
    - {id: window, points: [[4.6, 6], [3.4, 6]], material: glass}
  cylinders: [LEGS]
robot:
  poses: [[4, 2, 0]]
"""
"""A room whose north wall holds a window 4 m square in front of the robot (LEGS: the cylinders beside the beam)."""

PILLAR = "{id: pillar, center: [4.6, 3.5], radius: 0.1}"
"""Beside the beam: the pane's run of readings jumps to it, over 1 m nearer (Type IV)."""

POST = "{id: post, center: [4.15, 3.5], radius: 0.08}"
"""In front of the pane's normal: the readings square to the pane hear it first; the pane is heard beside it, over
5 readings whose arc holds not the normal (Type IV: the post is over 1 m nearer)."""

TWO_LEGS = "{id: leg-1, center: [3.55, 4.0], radius: 0.05}, {id: leg-2, center: [4.45, 4.0], radius: 0.05}"
"""Either side of the normal: the pane is heard over 3 readings only, narrower than an RCD."""


@pytest.mark.parametrize("legs", [PILLAR, POST, TWO_LEGS])
def test_a_pane_heard_square_beside_nearer_targets_is_an_object_on_the_pane_under_the_default_config(legs) -> None:
    scenario = parse_scenario(ROOM.replace("LEGS", legs), "room.yaml")
    for name, objects in (("paper", 0), ("default", 1)):
        run = fuse_configs(scenario, {name: resolve_config(name)}, ["dempster"])[name, "dempster"]
        sonar = run.observations[0].sonar
        runs = extract_rcds(sonar, run.config.rcd, primitive=True)
        pane = runs.target == "window"
        assert pane.sum() == 1 and runs.type[pane][0] == TYPE_IV  # heard square, in a run the paper takes none from
        assert run.world.surfaces().segment_ids[heard_glass(run.world, [sonar])].tolist() == ["window"]
        on_pane = [u for u in run.map.unidentified() if abs(u.xy[1] - 6.0) < 0.05 and 3.4 < u.xy[0] < 4.6]
        assert len(on_pane) == objects
        assert all(abs(u.xy[0] - 4.0) < 0.05 for u in on_pane)  # at the foot of the perpendicular


def _check(ranges: dict[int, float], lines, config):
    """The sonar check of a scan from the origin (readings every degree, 10 m but where ``ranges`` says) against a
    map of the believed ``lines``."""
    bm = new_map(config)
    for i, ends in enumerate(lines):
        for end, xy in zip("ab", ends, strict=True):
            bm.add_point(f"E{i}{end}", xy, "endpoint", bm.vacuous())
        bm.add_line(f"L{i}", f"E{i}a", f"E{i}b", bm.vacuous())
    r = np.full(360, 10.0)
    for k, v in ranges.items():
        r[k] = v
    scan = SonarScan.from_readings(np.radians(np.arange(360.0)), r, SonarParams(), pose=(0.0, 0.0, 0.0))
    return check_sonar(bm, scan, extract_rcds(scan, config.rcd, primitive=True), config)


GAP = [((-3, 2), (-0.6, 2)), ((0.6, 2), (3, 2))]
"""A wall y = 2 with a gap from x = -0.6 to 0.6."""


def _pane_runs(ranges: dict[int, float], lines=GAP, config=None) -> list[int]:
    """The first readings of the runs :func:`pane_echoes` takes for panes."""
    config = config or load_config("default")
    check = _check(ranges, lines, config)
    runs, _ = pane_echoes(check, np.ones(len(check.surfaces.segment_ids), dtype=bool), np.zeros(3), config)
    return check.runs.start[runs].tolist()


def test_a_run_is_a_pane_only_at_the_wall_line_s_distance_square_to_it_in_a_gap_and_not_under_the_paper() -> None:
    square = {k: 2.0 for k in range(87, 94)} | {86: 1.5, 94: 1.5}  # 7 readings around 90 deg, nearer ones beside
    assert _pane_runs(square) == [87]
    assert _pane_runs({k: 2.0 + 0.15 for k in range(87, 94)} | {86: 1.5, 94: 1.5}) == []  # not the wall's distance
    assert _pane_runs({k: 2.0 for k in range(95, 102)} | {94: 1.5, 102: 1.5}) == []  # the foot is not in its arc
    assert _pane_runs(square, lines=[((-3, 2), (3, 2))]) == []  # no gap: the wall itself, and the map predicts it
    assert _pane_runs(square, config=load_config("paper")) == []  # the paper's method: no such objects
    assert _pane_runs({90: 2.0, 89: 1.5, 91: 1.5}) == []  # one reading: no constant depth
    assert _pane_runs({90: 2.0, 91: 2.0, 89: 1.5, 92: 1.5}) == [90]


def test_a_type_iv_run_is_a_pane_whose_normal_lies_beside_it_on_its_nearer_neighbour_s_side() -> None:
    beside = {k: 2.0 for k in range(95, 102)}  # the foot, at 90 deg, 8 deg below the run's middle
    assert _pane_runs(beside | {94: 0.5}) == [95]  # the readings toward the normal heard something nearer first
    assert _pane_runs(beside | {102: 0.5}) == []  # the nearer target on the other side: not this pane's echo
    assert _pane_runs({k: 2.0 for k in range(108, 115)} | {107: 0.5}) == []  # 21 deg off: no reading hears it


JAMB = [((-3, 2), (-0.6, 2)), ((0.25, 2), (3, 2))]
"""The wall y = 2 with a gap from x = -0.6 to 0.25: the map predicts the end at (0.25, 2) heard from 77 to 89 deg."""


def test_a_run_the_matching_gave_to_a_wall_end_is_a_pane_where_the_map_does_not_predict_its_readings() -> None:
    config = load_config("default")
    pane = {k: 2.0 for k in range(80, 101)}  # the pane square at 90 deg, heard from 80 to 100 deg
    check = _check(pane, JAMB, config)
    assert check.matched[0].tolist() == [0] and check.predicted.target[check.matched[1]].tolist() == ["E1a"]
    assert _pane_runs(pane, JAMB) == [80]  # 11 readings, 90 to 100 deg, the map predicts nothing at 2 m
    jamb = {k: 2.016 for k in range(77, 91)}  # the end's own echo, a reading wider than the map predicts it
    assert _pane_runs(jamb, JAMB) == []  # one reading the map does not predict: a doorway's jamb, no pane
    assert _pane_runs(pane, JAMB, config=load_config("paper")) == []


NEAR_END = [((-3, 1), (-0.6, 1)), ((0.17, 1), (3, 1))]
"""The wall y = 1 with a gap from x = -0.6 to 0.17: the map predicts the end at (0.17, 1), 10 deg off the pane's
normal, heard from 70 to 91 deg: its echo reaches the normal by the beam's width."""


def test_a_run_given_to_a_wall_end_whose_echo_reaches_the_normal_is_a_pane_if_heard_beyond_the_normal() -> None:
    config = load_config("default")
    pane = {k: 1.0 for k in range(78, 103)}  # the pane and the wall beside it heard square, 78 to 102 deg
    check = _check(pane, NEAR_END, config)
    assert check.matched[0].tolist() == [0] and check.predicted.target[check.matched[1]].tolist() == ["E1a"]
    heard = check.predicted_scan.ranges[[70, 90, 91, 92]]
    assert np.abs(heard - 1.0).round(3).tolist() == [0.014, 0.014, 0.014, 9.0]  # the end's echo at the normal
    assert _pane_runs(pane, NEAR_END) == [78]  # 11 readings beyond the normal, 92 to 102 deg, unpredicted
    end = {k: 1.014 for k in range(70, 92)}  # the end's own echo, as the map predicts it
    assert _pane_runs(end, NEAR_END) == []
    assert _pane_runs({k: 1.0 for k in range(78, 94)}, NEAR_END) == []  # two readings beyond: a jamb's, no pane
    assert _pane_runs(pane, NEAR_END, config=load_config("paper")) == []


def test_a_pane_is_in_line_only_with_a_line_long_enough_to_carry_on() -> None:
    square = {k: 2.0 for k in range(87, 94)} | {86: 1.5, 94: 1.5}
    assert _pane_runs(square, lines=[((0.6, 2), (0.75, 2))]) == []  # a 15 cm stub: its direction not known enough
    assert _pane_runs(square, lines=[((0.6, 2), (0.9, 2))]) == [87]


def _frame(x0: float, x1: float, y: float = 2.0) -> np.ndarray:
    """Stripe points every 2 cm along y from x0 to x1: a window's frame, or a mullion."""
    x = np.arange(x0, x1 + 1e-9, 0.02)
    return np.column_stack([x, np.full(len(x), y)])


def _framed_runs(ranges: dict[int, float], stripe: np.ndarray, lines=(), config=None) -> list[int]:
    """The first readings of the runs :func:`pane_echoes` takes for panes, the pose's stripe points given."""
    config = config or load_config("default")
    check = _check(ranges, list(lines), config)
    believed = np.ones(len(check.surfaces.segment_ids), dtype=bool)
    runs, places = pane_echoes(check, believed, np.zeros(3), config, stripe)
    assert np.allclose(places[:, 1], 2.0, atol=0.01)  # on the pane's line, square to the normal found
    return check.runs.start[runs].tolist()


def test_a_pane_with_no_believed_wall_in_line_is_an_object_between_frames_the_stripe_measured() -> None:
    square = {k: 2.0 for k in range(87, 94)} | {86: 1.5, 94: 1.5}
    frames = np.concatenate([_frame(-0.9, -0.6), _frame(0.6, 0.9)])  # the glass between x = -0.6 and 0.6
    assert _framed_runs(square, frames) == [87]
    assert _framed_runs(square, _frame(0.6, 0.9)) == []  # a frame on one side only: nothing bounds the pane
    assert _framed_runs(square, np.concatenate([_frame(-2.4, -2.1), _frame(0.6, 0.9)])) == []  # 2.7 m apart
    assert _framed_runs(square, np.concatenate([frames, _frame(-0.1, 0.1)])) == []  # a surface on the line: no glass
    crossing = np.column_stack([np.full(6, -0.7), np.linspace(1.93, 2.07, 6)])  # a wall across the line
    assert _framed_runs(square, np.concatenate([crossing, _frame(0.6, 0.9)])) == []
    assert _framed_runs(square, frames + [0.0, 0.2]) == []  # frames 20 cm beyond the run's range
    assert _framed_runs(square, frames, config=load_config("paper")) == []
