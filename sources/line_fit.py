"""How well line segments explain a laser scan, without labels: the measures of Schaefer et al. (IROS 2018, PLE).

Per scan (:func:`scan_fit`): each returned ray is intersected with the segments
extracted from that scan; a segment is hit when its span, seen from the sensor,
holds the ray (the intersection lies on the segment, ends included) in front of
the sensor. Where several segments are hit, the nearest counts (the surface the
ray would have stopped at).

- coverage: the share of returned rays that hit a segment;
- error: the root mean square of (measured range - range of the hit) over the
  rays that hit (NaN if none does).

Per log (:func:`log_fit`): the mean of the scans' coverages and the median of
their errors (scans without any hit left out of the median).

Examples
--------
>>> from evmap.sources.logs.scan import LaserScan
>>> scan = LaserScan(0.0, np.zeros(3), np.radians([-10.0, 0, 10, 60]), np.array([2.03, 2.0, 2.03, 1.0]), 80.0)
>>> fit = scan_fit(scan, np.array([[2.0, -1.0]]), np.array([[2.0, 1.0]]))
>>> fit.coverage, round(fit.error, 4), fit.hit.tolist()
(0.75, 0.0007, [True, True, True, False])
>>> log_fit([fit, fit])
(0.75, 0.00069...)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evmap.sources.geometry import crossings
from evmap.sources.logs.scan import LaserScan

__all__ = ["ScanFit", "log_fit", "scan_fit"]

SPAN_SLACK = 1e-9
"""Slack on the segment parameter (relative), so a ray through a segment's end point hits it."""


@dataclass(frozen=True, eq=False)
class ScanFit:
    """How the segments of one scan fit its returned rays.

    Attributes
    ----------
    coverage : share of returned rays that hit a segment (NaN if no ray returned).
    error : RMS range difference over the rays that hit (m; NaN if none hit).
    hit : (M,) per returned ray, whether it hit a segment.
    predicted : (M,) range of the hit (m), NaN where none.
    points : (M, 2) where each returned ray ended (world frame, m).
    """

    coverage: float
    error: float
    hit: NDArray[np.bool_]
    predicted: NDArray[np.float64]
    points: NDArray[np.float64]


def scan_fit(scan: LaserScan, p: NDArray[np.float64], q: NDArray[np.float64]) -> ScanFit:
    """Coverage and error of the segments ``p``-``q`` ((N, 2) world ends) for the returned rays of ``scan``."""
    returned = ~np.isnan(scan.ranges)
    b = scan.bearings[returned]
    d = np.column_stack([np.cos(b), np.sin(b)])  # (M, 2)
    p = np.asarray(p, dtype=float).reshape(-1, 2)
    e = np.asarray(q, dtype=float).reshape(-1, 2) - p  # (N, 2)
    t, s = crossings(scan.pose[:2], d[:, None], p[None], e[None])  # (M, N): range along the ray, place on the segment
    on = (t > 0) & (s >= -SPAN_SLACK) & (s <= 1 + SPAN_SLACK)  # NaN where parallel: never on
    predicted = np.where(on, t, np.inf).min(axis=1, initial=np.inf)
    hit = np.isfinite(predicted)
    predicted = np.where(hit, predicted, np.nan)
    measured = scan.ranges[returned]
    coverage = float(hit.mean()) if len(hit) else float("nan")
    error = float(np.sqrt(np.mean((measured[hit] - predicted[hit]) ** 2))) if hit.any() else float("nan")
    return ScanFit(coverage, error, hit, predicted, scan.pose[:2] + measured[:, None] * d)


def log_fit(fits: Iterable[ScanFit]) -> tuple[float, float]:
    """Mean coverage and median error of a log's scans (scans without rays or hits left out of each)."""
    coverage, error = np.array([(f.coverage, f.error) for f in fits], dtype=float).reshape(-1, 2).T
    coverage, error = coverage[~np.isnan(coverage)], error[~np.isnan(error)]
    return (
        float(coverage.mean()) if len(coverage) else float("nan"),
        float(np.median(error)) if len(error) else float("nan"),
    )
