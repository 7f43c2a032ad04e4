"""PLE coverage and error: known answers."""

from __future__ import annotations

import numpy as np
import pytest

from evmap.sources.line_fit import log_fit, scan_fit
from evmap.sources.logs.scan import LaserScan


def scan(ranges: list[float], angles_deg: list[float], pose: tuple[float, float, float] = (0, 0, 0)) -> LaserScan:
    return LaserScan(0.0, np.array(pose, dtype=float), np.radians(angles_deg), np.array(ranges, dtype=float), 80.0)


def test_nearest_segment_counts_and_misses_are_uncovered() -> None:
    s = scan([1.0, 3.1, 2.0, np.nan], [0, 10, 80, 20])
    near, far = ([0.9, -0.1], [0.9, 0.1]), ([3.0, -1.0], [3.0, 1.0])
    fit = scan_fit(s, np.array([near[0], far[0]]), np.array([near[1], far[1]]))
    assert fit.hit.tolist() == [True, True, False]  # the NaN ray is not a returned ray
    np.testing.assert_allclose(fit.predicted[:2], [0.9, 3.0 / np.cos(np.radians(10))])
    assert fit.coverage == pytest.approx(2 / 3)
    assert fit.error == pytest.approx(np.sqrt((0.1**2 + (3.1 - 3.0 / np.cos(np.radians(10))) ** 2) / 2))


def test_segment_behind_the_sensor_misses_and_an_end_point_hits() -> None:
    looking_back = scan([1.0], [0], pose=(0, 0, np.pi))  # along -x
    assert scan_fit(looking_back, np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]])).hit.tolist() == [False]
    corner = scan([np.sqrt(2)], [45], pose=(0, 0, np.pi))  # towards (-1, -1), the segment's end
    assert scan_fit(corner, np.array([[-1.0, -1.0]]), np.array([[-1.0, 0.0]])).hit.tolist() == [True]


def test_no_segments_and_no_returns() -> None:
    fit = scan_fit(scan([1.0, 2.0], [0, 1]), np.zeros((0, 2)), np.zeros((0, 2)))
    assert fit.coverage == 0.0 and np.isnan(fit.error)
    empty = scan_fit(scan([np.nan], [0]), np.zeros((0, 2)), np.zeros((0, 2)))
    assert np.isnan(empty.coverage)
    assert log_fit([fit, empty]) == (0.0, pytest.approx(np.nan, nan_ok=True))


def test_log_fit_is_mean_coverage_and_median_error() -> None:
    s = scan([1.0, 1.0, 1.0, 1.0], [-1, 0, 1, 60])
    exact = scan_fit(s, np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]]))
    shifted = scan_fit(s, np.array([[1.1, -1.0]]), np.array([[1.1, 1.0]]))
    coverage, error = log_fit([exact, shifted, shifted])
    assert coverage == pytest.approx(0.75)
    assert error == pytest.approx(shifted.error)
