"""The laser as a contour sensor: breakpoints, segments, rays, on synthetic scans and the log excerpts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from evmap.sources.laser import UNKNOWN_TRUTH, breakpoints, laser_segments
from evmap.sources.laser_params import LaserParams, range_noise
from evmap.sources.line_fit import scan_fit
from evmap.sources.logs.carmen import read_carmen
from evmap.sources.logs.scan import LaserScan
from evmap.sources.readings import concat_segments

DATA = Path(__file__).parent / "data" / "logs"


def room_scan(noise: float = 0.0, seed: int = 0) -> LaserScan:
    """A corner 2 m ahead and 1.5 m to the left, seen from (1, 1) heading +x, 1 deg beams over 180 deg."""
    angles = np.radians(np.arange(-90.0, 90.5, 1.0))
    with np.errstate(divide="ignore"):
        front = np.where(np.cos(angles) > 1e-9, 2.0 / np.cos(angles), np.inf)
        left = np.where(np.sin(angles) > 1e-9, 1.5 / np.sin(angles), np.inf)
    ranges = np.minimum(front, left)
    ranges = np.where(ranges < 80, ranges, np.nan)
    ranges = ranges + noise * np.random.default_rng(seed).standard_normal(len(ranges))
    return LaserScan(0.0, np.array([1.0, 1.0, 0.0]), angles, ranges, 80.0)


def test_corner_gives_two_walls_meeting_at_the_corner() -> None:
    segs = laser_segments(room_scan(), LaserParams(), pose_index=3)
    assert len(segs) == 2
    near_corner = np.hypot(*(np.concatenate([segs.segments.p, segs.segments.q]) - [3.0, 2.5]).T)
    assert (near_corner < 0.05).sum() == 2  # the corner lies between two beams 4.4 cm apart
    assert segs.segments.truth.tolist() == [UNKNOWN_TRUTH] * 2 and segs.segments.pose.tolist() == [3, 3]
    assert segs.segments.snapshot.tolist() == [0, 0] and segs.segments.source.tolist() == ["", ""]


def test_a_wall_seen_at_a_grazing_angle_ends_at_its_corner_not_where_the_cross_wall_s_ray_meets_it() -> None:
    """A wall 2 m to the right, seen out to 18.6 m, its last beam (6 deg) on the cross wall 5 cm off the wall's
    line: that point's ray meets the wall's line 0.35 m past the corner; the segment ends at the point's foot."""
    angles = np.radians(np.arange(-60.0, -5.0, 1.0))
    corner = 1.95 / np.tan(np.radians(6.0))
    ranges = np.where(angles < np.radians(-6.5), 2.0 / np.sin(-angles), corner / np.cos(angles))
    segs = laser_segments(LaserScan(0.0, np.zeros(3), angles, ranges, 80.0), LaserParams())
    assert segs.pieces.tolist() == [[0, 54]]
    assert segs.segments.q[0][0] == pytest.approx(corner, abs=0.01)
    assert segs.segments.p[0][0] == pytest.approx(2.0 / np.tan(np.radians(60.0)), abs=0.01)  # its first ray


def test_rays_start_at_the_laser_and_end_at_the_points_or_max_range() -> None:
    scan = room_scan()
    scan.ranges[10] = np.nan
    segs = laser_segments(scan, LaserParams())
    np.testing.assert_allclose(segs.origin, [1.0, 1.0])
    np.testing.assert_allclose(segs.ends[segs.returned], scan.points[~np.isnan(scan.ranges)])
    assert not segs.returned[10]
    assert np.hypot(*(segs.ends[10] - segs.origin)) == pytest.approx(80.0)


def test_breakpoint_separates_an_object_in_front_of_a_wall() -> None:
    scan = room_scan()
    scan.ranges[100:106] = 0.8
    starts = breakpoints(scan, LaserParams()).tolist()
    assert 100 in starts and 106 in starts


def test_noisy_corner_is_covered_within_the_noise() -> None:
    scan = room_scan(noise=0.01)
    segs = laser_segments(scan, LaserParams())
    fit = scan_fit(scan, segs.segments.p, segs.segments.q)
    assert fit.coverage > 0.95 and fit.error < 0.015


def wall_scan() -> LaserScan:
    """A wall 2 m ahead seen from the origin over -20 to 20 deg, 1 deg beams."""
    angles = np.radians(np.arange(-20.0, 21.0))
    return LaserScan(0.0, np.zeros(3), angles, 2.0 / np.cos(angles), 80.0)


@pytest.mark.parametrize(("extra", "joins"), [(0.05, True), (0.06, True), (0.07, False), (0.12, False)])
def test_a_cluster_end_joins_the_wall_while_its_range_is_within_the_noise(extra: float, joins: bool) -> None:
    # the last point, farther by `extra` along its ray, splits off the wall as a piece too short to keep;
    # its noise std at 2.13 m is 0.01 + 0.005 * 2.13 = 2.06 cm, so 3 stds reach 6.2 cm; a point that does not
    # join is a segment of its own with the wall's last point (end_points), else left out
    scan = wall_scan()
    scan.ranges[-1] += extra
    alone = LaserParams(end_points=0)
    assert laser_segments(scan, alone).pieces.tolist() == [[0, 40 if joins else 39]]
    assert scan_fit(scan, *_ends(laser_segments(scan, alone))).hit[-1] == joins
    assert laser_segments(scan, LaserParams(join_sigmas=0, end_points=0)).pieces.tolist() == [[0, 39]]
    segs = laser_segments(scan, LaserParams())
    assert segs.pieces.tolist() == ([[0, 40]] if joins else [[0, 39], [39, 40]])
    assert scan_fit(scan, *_ends(segs)).hit[-1]


@pytest.mark.parametrize(
    ("extra", "pieces"),
    [([0.12], [[0, 39], [39, 40]]), ([0.3, 0.1], [[0, 38], [39, 40]])],
)
def test_a_run_of_one_or_two_points_next_to_a_piece_is_a_segment_of_its_own(
    extra: list[float], pieces: list[list[int]]
) -> None:
    # the last points, farther than the noise allows, are left by the split: one of them makes a segment with
    # the wall's last point (shared, as a split point is), two make one of their own (a whole run of two points
    # too, by default)
    scan = wall_scan()
    scan.ranges[-len(extra) :] += extra
    for params in (LaserParams(), LaserParams(cluster_min_points=3)):
        segs = laser_segments(scan, params)
        assert segs.pieces.tolist() == pieces
        np.testing.assert_allclose(segs.segments.p[1], scan.points[pieces[1][0]], atol=1e-12)
        np.testing.assert_allclose(segs.segments.q[1], scan.points[40], atol=1e-12)
    fewer = LaserParams(end_points=len(extra) - 1, cluster_min_points=3)
    assert laser_segments(scan, fewer).pieces.tolist() == pieces[:1]


def test_a_point_off_the_wall_between_two_pieces_makes_a_segment_with_the_piece_before_it() -> None:
    scan = wall_scan()
    scan.ranges[20] += 0.12
    assert laser_segments(scan, LaserParams()).pieces.tolist() == [[0, 19], [19, 20], [21, 40]]
    assert laser_segments(scan, LaserParams(end_points=0)).pieces.tolist() == [[0, 19], [21, 40]]


@pytest.mark.parametrize(
    ("first", "at", "bulge", "pieces"),
    [
        # the last three points 2.3 m away along their rays: the split leaves them no piece; the line of all
        # three is off by 2/3 and 1/3 of the bulge, within 3 noise stds (6.6 cm) for 4 cm, not 10
        (38, 2.3, 0.04, [[0, 37], [38, 40]]),
        (38, 2.3, 0.10, [[0, 37]]),
        # three points 1 m ahead of the wall: the split leaves the cluster two 2-point pieces, too short to
        # keep; within 3 noise stds (4.5 cm) for 3 cm, not 10
        (10, 1.0, 0.03, [[0, 9], [10, 12], [13, 40]]),
        (10, 1.0, 0.10, [[0, 9], [13, 40]]),
    ],
)
def test_three_points_no_piece_holds_are_one_segment_where_one_line_fits_them_within_the_noise(
    first: int, at: float, bulge: float, pieces: list[list[int]]
) -> None:
    # the middle of the three points is nearer by `bulge`
    scan = wall_scan()
    scan.ranges[first : first + 3] = [at, at - bulge, at]
    assert laser_segments(scan, LaserParams()).pieces.tolist() == pieces


def test_pieces_stay_apart_where_one_line_would_miss_the_grazing_ranges() -> None:
    # a wall 0.5 m to the left seen from 10 to 60 deg, bending away by 5 cm a metre beyond x = 1 m (beam 16):
    # one line passes within 2 cm of every point, yet the grazing beams' ranges are off by more than 3 stds
    angles = np.radians(np.arange(10.0, 61.0))
    c, s = np.cos(angles), np.sin(angles)
    bent = (0.5 - 0.05 * 1.0) / (s - 0.05 * c)
    scan = LaserScan(0.0, np.zeros(3), angles, np.where(bent * c > 1.0, bent, 0.5 / s), 80.0)
    assert laser_segments(scan, LaserParams()).pieces.tolist() == [[0, 16], [16, 50]]
    assert laser_segments(scan, LaserParams(join_sigmas=10)).pieces.tolist() == [[0, 50]]


def test_a_cluster_of_two_points_is_one_segment_between_them() -> None:
    scan = wall_scan()
    scan.ranges[10:12] = [1.0, 1.01]
    segs = laser_segments(scan, LaserParams(cluster_min_points=2))
    assert segs.pieces.tolist() == [[0, 9], [10, 11], [12, 40]]
    np.testing.assert_allclose(segs.segments.p[1], scan.points[10], atol=1e-12)
    np.testing.assert_allclose(segs.segments.q[1], scan.points[11], atol=1e-12)
    assert laser_segments(scan, LaserParams(cluster_min_points=3)).pieces.tolist() == [[0, 9], [12, 40]]


def _ends(segs):
    return segs.segments.p, segs.segments.q


def test_no_return_scan_gives_no_segments() -> None:
    scan = LaserScan(0.0, np.zeros(3), np.linspace(-1, 1, 5), np.full(5, np.nan), 80.0)
    segs = laser_segments(scan, LaserParams())
    assert len(segs) == 0 and segs.pieces.shape == (0, 2) and not segs.returned.any()


def test_segments_concatenate_with_simulated_ones() -> None:
    a = laser_segments(room_scan(), LaserParams(), 0).segments
    b = laser_segments(room_scan(), LaserParams(), 1).segments
    both = concat_segments([a, b])
    assert len(both) == 4 and both.pose.tolist() == [0, 0, 1, 1]


def test_params_are_checked() -> None:
    with pytest.raises(ValidationError):
        LaserParams(lambda_deg=95)
    with pytest.raises(ValidationError):
        LaserParams(colour="red")


@pytest.mark.parametrize("name", ["intel-excerpt.log.gz", "freiburg-079-excerpt.log.gz"])
def test_log_excerpts_are_mostly_covered(name: str) -> None:
    fits = []
    for record in read_carmen(DATA / name):
        segs = laser_segments(record.scan, LaserParams(), record.index)
        fits.append(scan_fit(record.scan, segs.segments.p, segs.segments.q))
    assert np.mean([f.coverage for f in fits]) > 0.85
    assert np.median([f.error for f in fits]) < 0.025


@pytest.mark.parametrize(("silent", "joined"), [(1, True), (2, False), (6, False)])
def test_beams_that_returned_nothing_break_a_surface_but_one_dropout(silent: int, joined: bool) -> None:
    # the wall 2 m ahead with `silent` beams from beam 20 on returning nothing; with six (6 deg, lambda's angle)
    # the breakpoint formula alone allowed any gap, here a jump to 12 m on the last three beams
    scan = wall_scan()
    scan.ranges[20 : 20 + silent] = np.nan
    assert (20 + silent in breakpoints(scan, LaserParams()).tolist()) != joined
    far = wall_scan()
    far.ranges[20:26] = np.nan
    far.ranges[26:] = 12.0
    pieces = laser_segments(far, LaserParams()).pieces
    assert ((pieces[:, 0] >= 26) | (pieces[:, 1] <= 19)).all()  # no segment spans the silent beams


DENSE = np.radians(np.arange(-45.0, 45.25, 0.25))  # a Hokuyo UTM-30LX's spacing


@pytest.mark.parametrize("seed", range(5))
def test_beams_closer_than_half_a_degree_are_taken_two_at_a_time(seed: int) -> None:
    """A wall 2 m ahead seen by 361 beams 0.25 deg apart with 1 cm of noise: the splits made up to 24 pieces of
    a few points (seed 0), across the wall; two beams at a time, one segment spanning every beam."""
    wall = 2.0 / np.cos(DENSE) + np.random.default_rng(seed).normal(0.0, 0.01, len(DENSE))
    scan = LaserScan(0.0, np.zeros(3), DENSE, wall, 30.0)
    segs = laser_segments(scan, LaserParams(), 0)
    assert segs.pieces.tolist() == [[0, 360]] and int(segs.returned.sum()) == len(segs.ends) == 361
    np.testing.assert_allclose(segs.segments.p[:, 0], 2.0, atol=0.01)


def test_a_group_across_an_edge_keeps_a_beam_not_a_range_in_the_air() -> None:
    ranges = np.where(np.arange(len(DENSE)) < 181, 2.0, 4.0) / np.cos(DENSE)  # a step at beam 181, inside a group
    scan = LaserScan(0.0, np.zeros(3), DENSE, ranges, 30.0)
    segs = laser_segments(scan, LaserParams(), 0).segments
    x = np.concatenate([segs.p, segs.q])[:, 0]
    assert len(segs) == 2 and not ((x > 2.1) & (x < 3.9)).any()


@pytest.mark.parametrize("seed", range(5))
def test_a_noisier_laser_than_the_model_is_fitted_with_the_noise_its_scans_show(seed: int) -> None:
    """3 cm of noise (the model says 1 cm): 33-47 pieces of the one wall; with the measured noise, one."""
    wall = 2.0 / np.cos(DENSE) + np.random.default_rng(seed).normal(0.0, 0.03, len(DENSE))
    scan = LaserScan(0.0, np.zeros(3), DENSE, wall, 30.0)
    noise = range_noise([scan])
    assert noise == pytest.approx(0.03, abs=0.004)
    assert len(laser_segments(scan, LaserParams(), 0)) > 30
    assert len(laser_segments(scan, LaserParams().for_noise(noise), 0)) == 1
