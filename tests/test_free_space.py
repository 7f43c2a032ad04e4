"""The map's free space ends at its believed lines; the free space a pose sees stays free."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from pinned_worlds import former

from evmap import configs
from evmap.maps import BeliefMap, new_map
from evmap.maps.free_space import free_space
from evmap.maps.observation import observe
from evmap.maps.sensed import sensed
from evmap.sources.config import load_config
from evmap.sources.geometry import segment_distances
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World


@pytest.fixture(scope="module")
def bm():
    config = load_config(configs.path("default.yaml"))
    world = World(load_scenario(configs.path("scenarios/patrol.yaml")))
    bm = new_map(config)
    for k in range(3):
        bm.update(observe(world, k, config))
    return bm


def test_no_free_point_lies_behind_a_believed_line_from_every_pose(bm):
    free = free_space(bm)
    xmin, ymin, xmax, ymax = free.bounds
    x, y = np.meshgrid(np.arange(xmin, xmax, 0.1), np.arange(ymin, ymax, 0.1))
    xy = np.column_stack([x.ravel(), y.ravel()])
    xy = xy[shapely.contains_xy(free, xy[:, 0], xy[:, 1])]
    lines = bm.lines(min_belief=0.5)
    p, q = np.array([ln.p for ln in lines]), np.array([ln.q for ln in lines])
    hidden = np.ones(len(xy), dtype=bool)
    for s in sensed(bm):
        d = xy - s.origin
        short = s.origin + d * (1 - 0.01 / np.maximum(np.hypot(*d.T), 0.01))[:, None]  # 1 cm before the point
        hidden &= (segment_distances(s.origin[None, None], short[:, None], p[None], q[None]) == 0).any(axis=1)
    assert len(xy) > 100 and not hidden.any()


def test_what_the_rays_crossed_in_front_of_the_lines_is_free(bm):
    free = free_space(bm)
    s = sensed(bm)[0]
    ok = np.isfinite(s.range) & (s.range > 0.5)
    mid = s.origin + (s.range[ok] / 2)[:, None] * np.column_stack([np.cos(s.bearing[ok]), np.sin(s.bearing[ok])])
    assert shapely.contains_xy(free, mid[:, 0], mid[:, 1]).mean() > 0.95


def test_sonar_sectors_end_at_the_stripe_and_what_the_stripe_saw_stays_free():
    """A generated tour with windows (sonar double bounces through them reached 3 m outside the building before
    the contour bounded the sonar): no free cell is hidden from every pose by opaque surfaces, and the places
    the stripe saw free stay free."""
    from evmap.maps.app.compare_hazards import free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    run = fuse_rules(generate_world(world_seed(7, 6), former()), load_config("default"), ["dempster"])["dempster"]
    behind, behind_opaque, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    # none behind glass either: its window's pane was heard between two walls in line (3,018 of 12,599 free cells before)
    assert free > 5000 and behind_opaque <= behind <= 0.001 * free
    assert kept >= 0.9 * seen


def test_a_ray_on_a_point_judged_noise_bounds_the_sonar_when_the_camera_keeps_one_pixel_a_column():
    """A room with a glass facade between 5 cm mullions, seen by a `column_max` camera from one pose (seed 132,
    world 1): a mullion's short segment was judged noise, and its rays, taken to have returned nothing, let the
    sonar's sectors (silent through the oblique glass) free the mullion's shadow outside (222 free cells behind
    opaque walls, up to 3.5 m behind). With one return a ray, nothing tells what lies beyond such a point."""
    from evmap.maps.app.compare_hazards import free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    world = generate_world(world_seed(132, 1), former(column_max_share=1.0))
    run = fuse_rules(world, load_config("default"), ["dempster"])["dempster"]
    assert not sensed(run.map)[0].all_returns  # the camera kept one pixel a column
    _, behind_opaque, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    assert free > 5000 and behind_opaque == 0
    # 0.935 of the places seen free were kept before, 0.894 now: the places behind the sunlit pixels, which the
    # geometry says the stripe saw and the camera did not report, were the sonar's alone
    assert kept >= 0.85 * seen


def test_the_farthest_return_of_a_bearing_bounds_the_sonar_though_judged_noise():
    """The lab scenario, a `threshold` camera: the foam screen's 26 cm end piece is real but judged noise (the
    sonar's forward model expects an edge echo that the absorbing screen does not give). Its rays, taken to have
    gone on through a sunlit patch, let the sonar's sectors free the screen's shadow (45 free cells behind opaque
    walls). The camera reported nothing beyond them: a patch with nothing behind it and a wall look alike."""
    from evmap.maps.app.compare_hazards import free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.compare_metrics import fuse_rules

    run = fuse_rules(load_scenario(configs.path("scenarios/lab.yaml")), load_config("default"), ["dempster"])[
        "dempster"
    ]
    store = run.map.segments
    assert sensed(run.map)[0].all_returns and (store.eliminated & (store.truth == "real")).sum() == 1
    behind, _, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    assert free > 5000 and behind == 0
    assert kept >= 0.95 * seen  # 2,093 of 2,180 places, as before


def test_free_cells_behind_walls_split_by_what_a_sensor_reported():
    """A glass facade of four windows (seed 133, world 4): the stripe sees the rooms beyond the panes free, and the
    sonar heard two of them at normal incidence. The cells behind the panes no reading heard are beyond what the
    sensors report; those behind opaque walls or heard panes are what the map could have known."""
    from evmap.maps.app.compare_hazards import free_behind_perceived, free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.compare_metrics import fuse_rules, heard_glass
    from evmap.sources.sim.worldgen import generate_world, world_seed

    world = generate_world(world_seed(133, 4), former(column_max_share=0.5))
    run = fuse_rules(world, load_config("default"), ["dempster"])["dempster"]
    behind, behind_opaque, _ = free_behind_walls(run.map, run.world)
    s = run.world.surfaces()
    heard = heard_glass(run.world, [obs.sonar for obs in run.observations])
    assert sorted(s.segment_ids[heard]) == ["window-5", "window-7"]
    perceived = free_behind_perceived(run.map, run.world, heard)
    assert behind_opaque < perceived < 0.5 * behind  # most lie behind the panes no reading heard
    # the shadow of a 35 cm stub whose end fell between two rays, 0.1-0.9 m behind it: the sonar's sector reached
    # the edge between the ray on the stub and the next ray's far wall (12 free cells behind opaque walls)
    assert behind_opaque == 0
    assert free_behind_perceived(run.map, run.world, np.zeros(0, dtype=np.intp)) == behind_opaque
    assert free_behind_perceived(run.map, run.world, np.flatnonzero(~s.lsl_opaque)) == behind
    # the pane heard lies between mullions, the facade's 15 cm end and a door: a face from the wall before the
    # facade to the one past the door (8.3 m) shut the room beyond the door, 364 of the 2,558 places seen free
    assert free_seen_kept(run.map, stripe_seen(run.world, run.config))[0] >= 2000  # 2,009 of them


def test_a_fan_through_rays_alternating_between_two_ranges_is_united():
    """A `threshold` camera reports every return a ray lit: in a generated world (seed 171, world 15) one pose's
    rays a hair apart in bearing alternated between a sunlit patch at 1.36 m and a wall at 3.1 m where two
    snapshots overlap, the fan crossed itself, and the union of its runs failed (GEOS: "unable to assign free
    hole to a shell")."""
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    world = generate_world(world_seed(171, 15), former(column_max_share=0.0))
    run = fuse_rules(world, load_config("default"), ["dempster"])["dempster"]
    assert sensed(run.map)[0].all_returns
    free = free_space(run.map)
    assert free.is_valid and free.area > 10


def test_sonar_sectors_end_at_the_stripe_s_range_where_it_returned_nothing():
    """A tour of a generated office (seed 73, world 1): sonar sectors reached 8-10 m out, beyond the stripe's 8 m,
    where it returned nothing, across oblique walls the sonar did not hear (252 free cells behind opaque walls, up to
    0.53 m behind). The stripe looks all round: no free place lies beyond its range from every pose."""
    from evmap.maps.app.compare_hazards import free_behind_walls
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    run = fuse_rules(generate_world(world_seed(73, 1), former()), load_config("default"), ["dempster"])["dempster"]
    free = free_space(run.map)
    xmin, ymin, xmax, ymax = free.bounds
    x, y = np.meshgrid(np.arange(xmin, xmax, 0.1), np.arange(ymin, ymax, 0.1))
    xy = np.column_stack([x.ravel(), y.ravel()])
    xy = xy[shapely.contains_xy(free, xy[:, 0], xy[:, 1])]
    near = np.min([np.hypot(*(xy - s.origin).T) for s in sensed(run.map)], axis=0)
    assert len(xy) > 1000 and near.max() <= run.config.sensors.lsl.max_range
    assert free_behind_walls(run.map, run.world)[1] == 0


def test_a_believed_unidentified_object_ends_the_free_space_behind_it():
    from evidential import MassFunction

    config = load_config(configs.path("default.yaml"))
    bm = new_map(config)
    bm.update(observe(World(load_scenario(configs.path("scenarios/patrol.yaml"))), 0, config))
    s = sensed(bm)[0]
    ok = np.flatnonzero(np.isfinite(s.range) & (s.range > 1.5))
    u = np.column_stack([np.cos(s.bearing[ok]), np.sin(s.bearing[ok])])
    behind = s.origin + 0.9 * s.range[ok, None] * u
    before = shapely.contains_xy(free_space(bm), behind[:, 0], behind[:, 1])
    k = np.flatnonzero(before)[len(np.flatnonzero(before)) // 2]  # a place the ray crossed: free
    pane = MassFunction(bm.frame, {"real": 0.6, "real|noise": 0.4})
    bm.add_point("pane", s.origin + 0.5 * s.range[ok[k]] * u[k], "unidentified", pane, history=[{"pose": 0}])
    assert not free_space(bm).contains(shapely.Point(behind[k]))


def _grid_free(bm, xy):
    from evmap.maps.app.compare_hazards import free_seen_kept

    return free_seen_kept(bm, xy)[0]


def test_a_pane_heard_between_two_walls_in_line_ends_the_free_space_across_the_window():
    """The office's glass partition (3 m, between the corridor's south walls): the sonar hears it square to the
    pose, the stripe sees through it. The object's 0.6 m face left 1,927 free cells in the meeting room behind
    it; the window between the walls now ends the free space, and the corridor in front stays free."""
    from evmap.maps.app.compare_hazards import free_behind_walls
    from evmap.maps.app.run import run_scenario

    run = run_scenario(load_scenario(configs.path("scenarios/office.yaml")), load_config("default"))
    x, y = np.meshgrid(np.arange(4.2, 6.8, 0.1), np.arange(0.3, 1.2, 0.1))
    front = np.column_stack([x.ravel(), y.ravel()])
    assert free_behind_walls(run.map, run.world)[0] == 0
    assert _grid_free(run.map, front) >= 0.95 * len(front)


def test_a_glass_wall_wider_than_the_generated_worlds_panes_ends_the_free_space():
    """A 6.5 m glass wall between a corridor's walls, heard square from the middle pose, seen through by all
    three: the window ended the free space up to 4 m wide only (the office's pane is 3 m, the generated worlds'
    at most 2 m), and 8,608 of the 16,213 free cells lay in the room behind it. The corridor stays as free."""
    from evmap.maps.app.compare_hazards import free_behind_walls
    from evmap.maps.app.run import run_scenario
    from evmap.sources.sim.scenario import parse_scenario

    scene = """{version: 1, name: glass-wall, seed: 3, world: {walls: [
      {id: corridor, points: [[0, 0], [0, 14]]},
      {id: room, points: [[2, 0], [2, 4], [7, 4], [7, 10.5], [2, 10.5], [2, 14]]},
      {id: pane, points: [[2, 4], [2, 10.5]], material: glass}]},
      robot: {poses: [[1, 7.2, 0], [1, 3, 1.57], [1, 12, -1.57]]}}"""
    run = run_scenario(parse_scenario(scene, "glass-wall.yaml"), load_config("default"))
    x, y = np.meshgrid(np.arange(0.3, 1.75, 0.1), np.arange(0.5, 13.5, 0.1))
    corridor = np.column_stack([x.ravel(), y.ravel()])
    assert free_behind_walls(run.map, run.world)[0] == 0
    assert _grid_free(run.map, corridor) >= 1290  # as before: 1,299 of the 1,950 places


def test_a_pane_between_a_wall_and_a_mullion_ends_the_free_space_and_a_jamb_keeps_the_door_open():
    """Two 2 m panes in a corridor's wall, a 10 cm mullion between them, the second ending at a door's 20 cm jamb,
    each heard square. The first pane's face was 0.6 m (one wall in line only): now the pane from the wall's end to
    the mullion (9,576 of 26,375 free cells behind walls -> 5,549 of 22,321). The second's, from the mullion to the
    wall past the door (3.1 m), shut the door: 106 of the 4,179 places seen free (4,027 kept); the jamb ends it."""
    from evmap.maps.app.compare_hazards import free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.run import run_scenario
    from evmap.sources.sim.scenario import parse_scenario

    scene = """{version: 1, name: panes, seed: 8, world: {walls: [
      {id: wall, points: [[0, 3], [3, 3]]}, {id: mullion-1, points: [[3, 3], [3.1, 3]]},
      {id: pane-1, points: [[3.1, 3], [5.1, 3]], material: glass}, {id: mullion-2, points: [[5.1, 3], [5.2, 3]]},
      {id: pane-2, points: [[5.2, 3], [7.2, 3]], material: glass}, {id: jamb, points: [[7.2, 3], [7.2, 3.2], [7.35, 3.2]]},
      {id: wall-2, points: [[8.3, 3.2], [8.3, 3], [14, 3]]}, {id: room, points: [[7.35, 3.2], [7.35, 7], [0, 7], [0, 3]]},
      {id: room-2, points: [[8.3, 3.2], [8.3, 7], [14, 7], [14, 3]]}, {id: south, points: [[0, 0], [14, 0]]},
      {id: west, points: [[0, 0], [0, 3]]}, {id: east, points: [[14, 0], [14, 3]]}]},
      robot: {poses: [[1.5, 1.5, 0], [4.1, 1.8, 1.57], [6.2, 1.6, 0], [7.8, 1.5, 1.57], [10.3, 2.2, -1.57]]}}"""
    run = run_scenario(parse_scenario(scene, "panes.yaml"), load_config("default"))
    behind, _, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    assert behind < 0.3 * free and kept >= 0.95 * seen


def test_a_pane_heard_between_two_mullions_ends_the_free_space_across_it():
    """A facade of four 1.5 m panes between 10 cm mullions, each heard square, whose walls do not go on in line
    with it: a door recess's jambs on one side, the wall turning 10 cm past its end on the other (as at seed 142,
    world 19 of the generator since session 43: 6,421 of its 26,608 free cells lay behind its heard panes). The
    faces were 0.6 m across (no wall in line to bound a window): 7,259 of 21,833 free cells behind the panes."""
    from evmap.maps.app.compare_hazards import free_behind_walls, free_seen_kept, stripe_seen
    from evmap.maps.app.compare_metrics import heard_glass
    from evmap.maps.app.run import run_scenario
    from evmap.sources.sim.scenario import parse_scenario

    scene = """{version: 1, name: facade, seed: 9, world: {walls: [
      {id: south, points: [[0, 0], [12, 0], [12, 3], [10, 3], [10, 6]]},
      {id: west, points: [[0, 0], [0, 3], [1.25, 3], [1.25, 3.2], [2.25, 3.2], [2.25, 3], [2.4, 3]]},
      {id: pane-1, points: [[2.4, 3], [3.9, 3]], material: glass}, {id: mullion-1, points: [[3.9, 3], [4.0, 3]]},
      {id: pane-2, points: [[4.0, 3], [5.5, 3]], material: glass}, {id: mullion-2, points: [[5.5, 3], [5.6, 3]]},
      {id: pane-3, points: [[5.6, 3], [7.1, 3]], material: glass}, {id: mullion-3, points: [[7.1, 3], [7.2, 3]]},
      {id: pane-4, points: [[7.2, 3], [8.7, 3]], material: glass}, {id: east, points: [[8.7, 3], [8.8, 3], [8.8, 6], [10, 6]]},
      {id: back, points: [[2.25, 3.2], [2.25, 6], [8.8, 6]]}]},
      robot: {poses: [[3.15, 1.5, 90], [4.75, 1.5, 90], [6.35, 1.5, 90], [7.95, 1.5, 90]]}}"""
    run = run_scenario(parse_scenario(scene, "facade.yaml"), load_config("default"))
    s = run.world.surfaces()
    assert sorted(s.segment_ids[heard_glass(run.world, [o.sonar for o in run.observations])]) == [
        "pane-1",
        "pane-2",
        "pane-3",
        "pane-4",
    ]
    behind, _, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    assert behind == 0 and free > 10000 and kept >= 0.98 * seen


def test_a_chair_leg_and_a_door_jamb_in_line_make_no_window():
    """Generated world 3 of seed 76: an object heard by a chair (4.96, 1.93) lay in line with a chair leg's short
    line and a door jamb's 15 cm stub, 2.2 m apart; taken for a window's pane, it cut 13 of the 101 places the
    stripe saw free behind it (82 free, 95 when lines shorter than ``wall_length`` bound no window; 94 with the GEOS
    of shapely 2.1.0, which rounds one place's cell the other way)."""
    from evmap.maps.app.compare_hazards import stripe_seen
    from evmap.maps.app.compare_metrics import fuse_rules
    from evmap.sources.sim.worldgen import generate_world, world_seed

    run = fuse_rules(generate_world(world_seed(76, 3), former()), load_config("default"), ["dempster"])["dempster"]
    seen = stripe_seen(run.world, run.config)
    box = seen[(seen[:, 0] > 4.2) & (seen[:, 0] < 4.9) & (seen[:, 1] > 0.3) & (seen[:, 1] < 1.9)]
    assert len(box) == 101 and _grid_free(run.map, box) >= 93


class _EveryLine:
    """A stand-in for shapely's STRtree whose every query finds every geometry."""

    def __init__(self, geometries):
        self.n = len(geometries)

    def query(self, geometry, *_, **__):
        if np.ndim(geometry) == 0:
            return np.arange(self.n)
        every = np.arange(self.n)
        return np.stack([np.repeat(np.arange(len(geometry)), self.n), np.tile(every, len(geometry))])


@pytest.mark.parametrize("kind", ["patrol", "log"])
def test_only_the_lines_that_meet_a_pose_s_free_space_shade_it(bm, kind, monkeypatch, tmp_path):
    if kind == "log":
        from evmap.maps.app.log_run import run_log

        excerpt = Path(__file__).parent / "data" / "logs" / "freiburg-079-excerpt.log.gz"
        bm = run_log(excerpt, load_config(), limit=12).map
    culled = free_space(bm)
    bm.save(tmp_path / "map.json")
    monkeypatch.setattr(shapely, "STRtree", _EveryLine)  # every believed line's shadow cut from every pose
    whole = free_space(BeliefMap.load(tmp_path / "map.json"))  # made afresh: a new map object
    assert whole.area > 1 and shapely.symmetric_difference(culled, whole).area <= 1e-6  # snapped to the micrometre


def test_free_space_of_sectors_whose_edges_nearly_touch():
    """Generated world 119 of seed 1 under Yager's rule: GEOS's floating overlay could not node the union of its
    poses' free space ("found non-noded intersection"), which stopped ``evmap compare --worlds 200 --seed 1``."""
    from evmap.maps.app.compare_configs import resolve_config
    from evmap.maps.app.compare_metrics import fuse_configs
    from evmap.sources.sim.worldgen import generate_world, world_seed

    scenario = generate_world(world_seed(1, 119), former(), name="world-0119")
    bm = fuse_configs(scenario, {"default": resolve_config("default")}, ["yager"])["default", "yager"].map
    free = free_space(bm)
    assert free.is_valid and free.area > 50
    assert np.allclose(shapely.get_coordinates(free) / 1e-6, np.round(shapely.get_coordinates(free) / 1e-6))
