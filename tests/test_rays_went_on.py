"""Rays that went on beyond a sunlit pixel: a camera that reports every stripe pixel above its threshold."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from pinned_worlds import former

from evmap.maps import noise
from evmap.maps.belief_map import new_map
from evmap.maps.contour_free_space import RayParams, ray_features, ray_tally, segments_facing, went_on
from evmap.maps.observation import observation_from_arrays, observe
from evmap.maps.pipeline import fold_observation
from evmap.maps.sensed import Sensed, sensed, sensed_from_json, sensed_json
from evmap.sources.config import load_config
from evmap.sources.params import SonarParams
from evmap.sources.readings import SonarScan
from evmap.sources.sim.scenario import parse_scenario
from evmap.sources.sim.world import World
from evmap.sources.sim.worldgen import generate_world

NONE = (np.zeros((0, 2)), np.zeros((0, 2)))


def _patch_pose(all_returns: bool) -> Sensed:
    """Pose 0 at the origin: 21 rays, 0.01 rad apart, each lighting a sunlit patch at x = 1 and nothing beyond
    but at bearings below -0.05, where a wall at x = 3 returned a second point."""
    sonar = SonarScan.from_readings([0.0], [1.0], SonarParams())
    bearing = np.linspace(-0.1, 0.1, 21)
    wall = bearing[bearing < -0.05]
    ranges = np.r_[1 / np.cos(bearing), 3 / np.cos(wall)]
    order = np.argsort(np.r_[bearing, wall], kind="stable")
    return Sensed(0, np.zeros(2), np.r_[bearing, wall][order], ranges[order], sonar, all_returns)


def test_only_the_farthest_point_of_a_bearing_on_noise_went_on_and_only_with_all_returns() -> None:
    patch = np.array([[1.0, -0.2]]), np.array([[1.0, 0.2]])
    pose = _patch_pose(all_returns=True)
    on = went_on(pose, patch, NONE, RayParams())
    x = pose.range * np.cos(pose.bearing)
    assert on.sum() == 16 and np.allclose(x[on], 1.0)  # 21 pixels on the patch, 5 with the wall behind them
    assert not on[np.abs(x - 3) < 1e-9].any()
    # a pixel on a segment still believed (a wall's piece kept, within 2 cm and three noise stds) went nowhere
    kept = np.array([[1.0, 0.0]]), np.array([[1.0, 0.2]])
    assert np.round(pose.bearing[went_on(pose, patch, kept, RayParams())], 2).tolist() == [-0.05, -0.04, -0.03]
    # one return a ray (a laser, a column's brightest pixel): nothing is known beyond it
    assert not went_on(_patch_pose(all_returns=False), patch, NONE, RayParams()).any()


def test_a_segment_behind_pixels_that_went_on_is_gone_through() -> None:
    """Pose 1's segment at x = 2 lies behind pose 0's patch: the rays that went on beyond the patch go through it
    (contradicted, and missed by pose 0); without them pose 0's rays are hidden in front of it: no evidence.
    Beyond the stripe's range, a ray that went on tells nothing."""
    patch = np.array([[1.0, -0.2]]), np.array([[1.0, 0.2]])
    p, q = np.array([[2.0, 0.0], [9.0, 0.0]]), np.array([[2.0, 0.15], [9.0, 0.7]])
    pose = np.array([1, 1])
    for all_returns, expected in ((True, ("contradicted", "missed")), (False, ("clear", "unobserved"))):
        s = _patch_pose(all_returns)
        beyond = [went_on(s, patch, NONE, RayParams())]
        tally = ray_tally(p, q, pose, [s], RayParams(), beyond)
        features = ray_features(tally, RayParams())
        assert (features["contour_free"][0], features["lsl_persistence"][0]) == expected
        assert tally.passes[1] == tally.other_misses[1, 0] == 0  # at 9 m, beyond the 8 m range
    hidden = ray_tally(p, q, pose, [_patch_pose(True)], RayParams())
    assert hidden.other_hidden[0, 0] > 0 and hidden.passes[0] == 0


SCENE = (Path(__file__).parent / "scenarios" / "sunlit_patch.yaml").read_text()  # only its pose 0 is observed


def test_the_threshold_camera_reports_all_returns_and_the_map_keeps_it() -> None:
    config = load_config("default")
    for detector, every in (("threshold", True), ("column_max", False)):
        world = World(parse_scenario(SCENE + f"sensors: {{lsl: {{detector: {detector}}}}}\n", "patch.yaml"))
        obs = observe(world, 0, config)
        assert obs.all_returns is every
        bm = new_map(config)
        fold_observation(bm, obs, config)
        data = sensed_json(bm)
        assert ("all_returns" in data["poses"][0]) is every
        (back,), _ = sensed_from_json(data)
        assert back.all_returns is every and sensed(bm)[0].all_returns is every
    data["poses"][0]["all_returns"] = "yes"
    with pytest.raises(ValueError, match="all_returns"):
        sensed_from_json(data)
    assert not observation_from_arrays(config, 0, [0, 0, 0], np.zeros((0, 2, 2))).all_returns


def test_a_tour_seen_by_a_threshold_camera_loses_more_phantoms_and_no_wall() -> None:
    """A generated 4-pose tour: the same observations folded with and without what the rays beyond the
    phantoms' pixels say."""
    config = load_config("default")
    world = World(generate_world(0, former(column_max_share=0.0)))
    observations = [observe(world, k, config) for k in range(len(world.poses))]
    assert len(observations) == 4 and all(obs.all_returns for obs in observations)
    out = {}
    for every in (True, False):
        bm = new_map(config)
        for obs in observations:
            fold_observation(bm, dataclasses.replace(obs, all_returns=every), config)
        store = bm.segments
        out[every] = [int((store.eliminated & (store.truth == truth)).sum()) for truth in ("noise", "real")]
    assert out[True][0] >= out[False][0] + 5
    assert out[True][1] <= out[False][1]


def test_the_second_look_judges_again_what_the_rays_that_went_on_anew_change_as_a_whole_judgement_would(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """judge's second look tallies again only the segments facing a ray that went on anew (segments_facing), and
    judges again only those whose features changed: on generated tours seen by a threshold camera, the same map to
    the bit as tallying every segment again."""
    config = load_config("default")
    looks = []

    def every(p, q, poses, bearings):  # every segment tallied again
        looks.append(sum(len(b) for b in bearings))
        return np.arange(len(p))

    for seed in (0, 3):
        world = World(generate_world(seed, former(column_max_share=0.0)))
        observations = [observe(world, k, config) for k in range(len(world.poses))]
        maps = []
        for facing in (noise.segments_facing, every):
            monkeypatch.setattr(noise, "segments_facing", facing)
            bm = new_map(config)
            for obs in observations:
                fold_observation(bm, obs, config)
            maps.append(bm)
        a, b = (bm.segments for bm in maps)
        assert np.array_equal(a.eliminated, b.eliminated) and np.array_equal(a.mass, b.mass)
        assert np.array_equal(a.relation, b.relation)
        assert sorted(maps[0].line_ids()) == sorted(maps[1].line_ids())
    assert looks and max(looks) > 0  # second looks were taken, rays went on anew


@pytest.mark.parametrize("seed", range(20))
def test_segments_facing_holds_every_segment_a_ray_of_those_bearings_crosses(seed: int) -> None:
    """Random segments and rays from two poses: every segment that ray_tally finds a ray of the given bearings
    crossing (a tally of those rays alone) is among those segments_facing gives."""
    rng = np.random.default_rng([39, seed])
    poses = []
    for k in range(2):
        bearing = np.sort(rng.uniform(-np.pi, np.pi, 60))
        poses.append(Sensed(k, rng.normal(0, 1, 2), bearing, rng.uniform(0.5, 6, 60), None))
    p = rng.normal(0, 3, (40, 2))
    q = p + rng.normal(0, 1.5, (40, 2))
    chosen = [rng.random(60) < 0.2 for _ in poses]
    alone = [Sensed(s.pose_index, s.origin, s.bearing[c], s.range[c], None) for s, c in zip(poses, chosen)]
    tally = ray_tally(p, q, np.full(40, 9), alone, RayParams())
    crossed = np.flatnonzero((tally.ends + tally.passes + tally.other_hidden.sum(axis=1)) > 0)
    facing = segments_facing(p, q, poses, [s.bearing for s in alone])
    assert len(crossed) and set(crossed.tolist()) <= set(facing.tolist())
