"""RCD extraction and typing (paper, section II.A; DESIGN "Method choices")."""

from __future__ import annotations

import numpy as np
import pytest

from evmap.sources.params import RcdParams, SonarParams
from evmap.sources.rcd import extract_rcds
from evmap.sources.readings import SonarScan

PARAMS = RcdParams()


def full_scan(ranges, targets=None, orders=None) -> SonarScan:
    """A closed scan, one reading per degree."""
    r = np.asarray(ranges, float)
    angles = np.radians(np.arange(len(r)) * 360 / len(r))
    return SonarScan(
        np.zeros(3),
        angles,
        r,
        np.asarray(targets if targets is not None else [""] * len(r)),
        np.asarray(orders if orders is not None else [1] * len(r)),
        SonarParams(),
    )


def profile(*parts) -> np.ndarray:
    """Concatenate (value, count) pieces."""
    return np.concatenate([np.full(n, v, float) for v, n in parts])


def test_types_one_to_four_from_the_neighbouring_readings():
    # 360 readings: I (1.0, longer both sides), II (1.5: 1.0 one side, 2.0 the other),
    # III (2.5 between 2.0 and 2.2), IV by jump (4.0 next to 2.2), IV at max range.
    r = profile((1.5, 20), (1.0, 20), (1.5, 20), (2.0, 40), (2.5, 20), (2.2, 40), (4.0, 20), (2.2, 40), (10.0, 140))
    rcds = extract_rcds(full_scan(r), PARAMS, primitive=True)
    got = dict(zip(np.round(rcds.range, 3).tolist(), rcds.type.tolist()))
    assert got[1.0] == 1 and got[2.5] == 3 and got[4.0] == 4 and got[10.0] == 4
    # no echo is no target: the run at max range is not an RCD for matching and counts
    assert 10.0 not in np.round(extract_rcds(full_scan(r), PARAMS).range, 3).tolist()
    assert got[2.0] == 2  # 1.5 before (shorter), 2.5 after (longer)
    types_15 = rcds.type[np.isclose(rcds.range, 1.5)]
    assert sorted(types_15.tolist()) == [2, 2]  # 10.0 | 1.5 | 1.0 and 1.0 | 1.5 | 2.0


def test_jump_threshold_makes_type_four():
    r = profile((1.0, 100), (1.9, 30), (1.0, 230))
    # listed by first reading: the 1.9 run (100..129), then the 1.0 run wrapping from 130 to 99
    assert extract_rcds(full_scan(r), RcdParams(jump_threshold=1.0)).type.tolist() == [3, 1]
    assert extract_rcds(full_scan(r), RcdParams(jump_threshold=0.5)).type.tolist() == [4, 1]


def test_run_wraps_around_the_end_of_a_closed_scan():
    r = profile((2.0, 10), (3.0, 340), (2.0, 10))
    rcds = extract_rcds(full_scan(r), PARAMS)
    wall = rcds.select(np.isclose(rcds.range, 2.0))
    assert wall.start.tolist() == [350] and wall.end.tolist() == [9] and wall.count.tolist() == [20]
    assert np.degrees(wall.direction[0]) == pytest.approx(-0.5)
    assert np.degrees(wall.width[0]) == pytest.approx(20.0)
    assert wall.prev_range[0] == 3.0 and wall.next_range[0] == 3.0 and wall.type[0] == 1


def test_run_is_within_tolerance_of_its_median():
    # a slow drift: every reading within 2 cm of the run's median, then a reading that breaks it
    r = np.r_[1.0, 1.01, 1.02, 1.03, 1.04, np.full(355, 3.0)]
    rcds = extract_rcds(full_scan(r), PARAMS, primitive=True)
    first = rcds.select(rcds.range < 2)
    assert first.count.tolist() == [4, 1]
    for k in range(len(rcds)):
        i = (rcds.start[k] + np.arange(rcds.count[k])) % 360
        assert np.all(np.abs(r[i] - np.median(r[i])) <= PARAMS.range_tolerance + 1e-12)


def test_primitive_rcds_have_no_minimum_width():
    r = profile((1.0, 3), (2.0, 357))
    assert extract_rcds(full_scan(r), PARAMS, primitive=True).count.tolist() == [3, 357]
    assert extract_rcds(full_scan(r), PARAMS).count.tolist() == [357]
    assert extract_rcds(full_scan(r), RcdParams(min_width_deg=2)).count.tolist() == [3, 357]


def test_majority_target_and_order():
    r = profile((1.0, 10), (5.0, 350))
    targets = ["a"] * 6 + ["b"] * 4 + [""] * 350
    orders = [2] * 3 + [1] * 7 + [0] * 350
    rcds = extract_rcds(full_scan(r, targets, orders), PARAMS, primitive=True)
    assert rcds.target.tolist() == ["a", ""] and rcds.order.tolist() == [1, 0]


def test_constant_closed_scan_is_one_rcd_without_neighbours():
    rcds = extract_rcds(full_scan(np.full(360, 2.0)), PARAMS)
    assert len(rcds) == 1 and rcds.type[0] == 1 and rcds.count[0] == 360
    assert np.isnan(rcds.prev_range[0]) and np.isnan(rcds.next_range[0])
    assert np.degrees(rcds.width[0]) == pytest.approx(360.0)
    assert extract_rcds(full_scan(np.full(360, 10.0)), PARAMS, primitive=True).type.tolist() == [4]
    assert len(extract_rcds(full_scan(np.full(360, 10.0)), PARAMS)) == 0


def test_partial_scan_ends_have_no_neighbour():
    scan = SonarScan.from_readings(np.radians(np.arange(30.0)), profile((2.0, 10), (1.0, 20)), SonarParams())
    assert not scan.closed
    rcds = extract_rcds(scan, PARAMS)
    assert rcds.type.tolist() == [3, 1]  # 2.0: only neighbour 1.0 (shorter); 1.0: only neighbour 2.0
    assert np.isnan(rcds.prev_range[0]) and np.isnan(rcds.next_range[1])


def test_empty_and_single_reading_scans():
    empty = extract_rcds(SonarScan.from_readings([], [], SonarParams()), PARAMS, primitive=True)
    assert len(empty) == 0 and empty.range.dtype == float and empty.target.shape == (0,)
    one = extract_rcds(SonarScan.from_readings([0.3], [2.0], SonarParams()), PARAMS, primitive=True)
    assert one.type.tolist() == [1] and one.count.tolist() == [1]
    assert np.degrees(one.width[0]) == pytest.approx(SonarParams().step_deg)
    far = extract_rcds(SonarScan.from_readings([0.3], [12.0], SonarParams()), PARAMS, primitive=True)
    assert far.type.tolist() == [4] and far.range.tolist() == [10.0]


def test_noisy_wall_stays_one_rcd():
    rng = np.random.default_rng(0)
    r = profile((3.0, 180), (1.0, 25), (3.0, 155)) + rng.normal(0, 0.005, 360)
    rcds = extract_rcds(full_scan(r), PARAMS)
    wall = rcds.select(rcds.range < 2)
    assert wall.count.tolist() == [25] and wall.type.tolist() == [1]
