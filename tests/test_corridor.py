"""The embedded default scenario reproduces the properties of the paper's experiment (Fig. 4 and 5)."""

from __future__ import annotations

import numpy as np
import pytest

from evmap.sources.params import LslParams, RcdParams, SonarParams
from evmap.sources.rcd import extract_rcds
from evmap.sources.sim.scenario import default_scenario
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.world import World, visible


@pytest.fixture(scope="module")
def corridor():
    scenario = default_scenario()
    world = World(scenario)
    sonar, lsl = scenario.sensor_params(SonarParams(), LslParams())
    return scenario, world, world.surfaces(), sonar, lsl


def _distance_to_segments(point, p, q):
    d = q - p
    t = np.clip(np.einsum("ij,ij->i", point - p, d) / np.einsum("ij,ij->i", d, d), 0, 1)
    return np.hypot(*(p + t[:, None] * d - point).T)


def test_one_pose_opaque_walls_and_two_glass_windows_in_sonar_range(corridor):
    scenario, world, s, sonar, _ = corridor
    assert scenario.name == "corridor" and len(world.poses) == 1
    windows = np.char.startswith(s.segment_ids, "east-window")
    assert windows.sum() == 2
    assert not np.any(s.lsl_opaque[windows]) and np.all(s.sonar_reflective[windows])
    assert np.all(s.lsl_opaque[~windows])  # every other wall is opaque
    pose = world.poses[0]
    assert np.all(_distance_to_segments(pose[:2], s.p[windows], s.q[windows]) < sonar.max_range)


def test_one_sunlight_region_of_28_phantoms_in_lsl_range_and_sight(corridor):
    _, world, s, _, lsl = corridor
    assert len(world.sunlight) == 1
    region = world.sunlight[0]
    assert region.lines == 28 and tuple(region.length) == (0.05, 0.35)
    pose, centroid = world.poses[0], world.sunlight_centroids[0]
    assert np.hypot(*(centroid - pose[:2])) < lsl.max_range
    assert visible(s, pose[:2], centroid[None]).tolist() == [True]


def test_noise_free_scan_has_the_paper_features(corridor):
    _, world, s, sonar, _ = corridor
    scan = simulate_scan(s, world.poses[0], sonar)
    rcds = extract_rcds(scan, RcdParams())
    # the windows, invisible to the LSL, are seen by sonar
    assert np.any((scan.target == "east-window-1") & (scan.order == 1))
    assert np.any(scan.target == "east-window-2:p1")  # the corner of the upper window and the north wall
    # a passage to another open area above the robot: a Type III RCD of direct echoes
    passage = rcds.select((rcds.type == 3) & (rcds.order == 1))
    assert len(passage) >= 1
    up = np.degrees(np.angle(np.exp(1j * (passage.direction - np.pi / 2))))
    assert np.any(np.abs(up) < 10)
    # sound reflecting more than once: long spurious readings, Type IV
    assert np.sum(scan.order == 2) >= 20
    assert np.any((rcds.type == 4) & (rcds.order == 2))
    # small extrusions and recesses: Type II
    assert np.any(rcds.type == 2)


def test_noisy_scan_keeps_types_three_and_four(corridor):
    scenario, world, s, sonar, _ = corridor
    scan = simulate_scan(s, world.poses[0], sonar, rng=np.random.default_rng([scenario.seed, 0, 1]))
    types = set(extract_rcds(scan, RcdParams()).type.tolist())
    assert {2, 3, 4} <= types
