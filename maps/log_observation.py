"""An observation from a robot log: the laser's segments and rays as the contour, the log's sonar readings.

:func:`observation_from_log` is what ``evmap log`` folds for each scan
(:func:`evmap.maps.app.log_run.run_log`); :func:`sonar_from_readings` makes a
:class:`~evmap.sources.readings.SonarScan` of any ring of range readings. Kept
apart from :mod:`evmap.maps.observation` so that a run on a simulated scenario
does not load the log readers and the laser's line extraction.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.maps.observation import Observation
from evmap.sources.config_model import Config
from evmap.sources.laser import Rays, laser_segments
from evmap.sources.laser_params import LaserParams
from evmap.sources.logs.scan import LogRecord, RangeReadings
from evmap.sources.params import SonarParams
from evmap.sources.readings import SonarScan
from evmap.sources.sensor_kinds import features_from_arrays

__all__ = ["observation_from_log", "rays_from", "sonar_from_readings"]


def observation_from_log(
    record: LogRecord,
    config: Config,
    pose_index: int,
    laser: LaserParams | None = None,
    sonar: RangeReadings | None = None,
    readings: Mapping[str, Mapping[str, ArrayLike]] | None = None,
) -> Observation:
    """One log record as an observation: the laser's segments and rays as the contour.

    The sonar scan is made from ``sonar`` (the record's readings, if they are new
    since the last scan used; None for none: the sonar stages are skipped), with
    the config's sonar model (:func:`sonar_from_readings`). ``readings`` are those
    of the config's declared sensors at this scan (``{sensor: {array: values}}``,
    :func:`~evmap.sources.sensor_kinds.features_from_arrays`), which bring their features.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.logs.scan import LaserScan
    >>> angles = np.radians(np.arange(-45.0, 46.0))
    >>> scan = LaserScan(0.0, np.zeros(3), angles, 2.0 / np.cos(angles), 80.0)
    >>> obs = observation_from_log(LogRecord(7, scan, np.zeros(3)), load_config(), 3)
    >>> obs.pose_index, len(obs.lsl), obs.sonar is None, obs.lsl.truth.tolist(), int((~np.isnan(obs.rays[:, 1])).sum())
    (3, 1, True, [''], 91)
    """
    segs = laser_segments(record.scan, laser or LaserParams(), pose_index)
    pose = np.asarray(record.robot_pose, dtype=float)
    scan = None if sonar is None else sonar_from_readings(sonar, pose, config.sensors.sonar)
    p, q = segs.segments.p, segs.segments.q
    features = {} if readings is None else features_from_arrays(config.extra_sensors, readings, p, q)
    return Observation(pose_index, scan, segs.segments, features, rays=rays_from(segs.rays, pose), robot_pose=pose)


def rays_from(rays: Rays, pose: ArrayLike) -> NDArray[np.float64]:
    """The laser's rays as :attr:`Observation.rays`: bearing and range of each end from the robot's position,
    NaN range where the ray returned nothing."""
    rel = rays.ends - np.asarray(pose, dtype=float)[:2]
    return np.column_stack([np.arctan2(rel[:, 1], rel[:, 0]), np.where(rays.returned, np.hypot(*rel.T), np.nan)])


def sonar_from_readings(readings: RangeReadings, robot_pose: ArrayLike, params: SonarParams) -> SonarScan:
    """A log's sonar readings as a scan from the robot's centre: each echo's world point seen from there.

    Beams without an echo read the sonar model's maximum range (no echo); beams of
    the same bearing from the centre keep the first.

    >>> ring = RangeReadings(0.0, np.array([[0.1, 0, 0], [0, 0.1, np.pi / 2]]), np.array([1.0, np.nan]), 5.0,
    ...                      np.full(2, 0.4))
    >>> scan = sonar_from_readings(ring, [0.0, 0.0, 0.0], SonarParams())
    >>> scan.angles.round(6).tolist(), scan.ranges.round(6).tolist(), scan.order.tolist()
    ([0.0, 1.570796], [1.1, 10.0], [-1, 0])
    """
    pose = np.asarray(robot_pose, dtype=float)
    origins, bearings = readings.in_world(pose)
    r = np.where(np.isnan(readings.ranges), readings.max_range, readings.ranges)
    points = origins + r[:, None] * np.column_stack([np.cos(bearings), np.sin(bearings)])
    rel = points - pose[:2]
    angles = np.mod(np.arctan2(rel[:, 1], rel[:, 0]) - pose[2] + np.pi, 2 * np.pi) - np.pi + pose[2]
    ranges = np.where(np.isnan(readings.ranges), params.max_range, np.hypot(*rel.T))
    angles, first = np.unique(angles, return_index=True)
    return SonarScan.from_readings(angles, ranges[first], params, pose=pose)
