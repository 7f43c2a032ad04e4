"""A belief map from a whole robot log: every scan's laser segments as the contour, poses from the log.

:func:`run_log` is what ``evmap log`` computes. Each used record (every
``every``-th laser scan of the log, at most ``limit`` of them) becomes an
observation (:func:`evmap.maps.log_observation.observation_from_log`) whose
``pose_index`` is its place among the used scans, and is folded into one map.
The log's sonar readings are used where it has them, each reading once (a
record whose readings are the same object as those of the previous used scan
brings none, whatever their stamps); a log without any skips the sonar stages
and the report says ``"sonar": "none"``, and its corners are joined once, after
the last scan (:meth:`~evmap.maps.belief_map.BeliefMap.join_corners`). The scans the reader could not place
(before the first pose) are counted in the report (``scans_skipped``).
PLE's line-fit measures of the laser segments come along.

The config's declared sensors (``extra_sensors``, YAML sensors) read their
readings from ``readings``, a directory with one file per used scan,
``scan-N.npz`` (``N`` the scan's 0-based number in the log, arrays named
``SENSOR/ARRAY``, :func:`~evmap.sources.sensor_kinds.read_readings`); a config
with declared sensors needs it, one without refuses it.

Examples
--------
>>> from pathlib import Path
>>> from evmap.sources.config import load_config
>>> run = run_log(Path("tests/data/logs/intel-excerpt.log.gz"), load_config(), limit=3)
>>> run.log.scans, run.log.sonar, run.world is None, sorted(run.map.poses)
(3, 'none', True, [0, 1, 2])
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from itertools import islice
from pathlib import Path
from typing import TypeVar

import numpy as np

from evmap.maps import new_map
from evmap.maps.app.run import LogSummary, Run
from evmap.maps.log_observation import observation_from_log
from evmap.sources.config_model import Config
from evmap.sources.laser_params import NOISE_SCANS, LaserParams, range_noise
from evmap.sources.line_fit import log_fit, scan_fit
from evmap.sources.logs import LogRecord, RangeReadings, RosbagOptions, open_log
from evmap.sources.logs.scan import Unit
from evmap.sources.sensor_kinds import read_readings

__all__ = ["run_log"]

T = TypeVar("T")

Progress = Callable[[Iterable[T]], Iterable[T]]
"""Wraps the stream of records (a progress bar, say)."""


def run_log(
    path: str | Path,
    config: Config,
    *,
    every: int = 1,
    limit: int | None = None,
    laser: LaserParams | None = None,
    progress: Progress | None = None,
    readings: str | Path | None = None,
    rosbag: RosbagOptions | None = None,
    unit: Unit = "m",
) -> Run:
    """Fold every ``every``-th scan of the log at ``path`` (at most ``limit``) into one belief map.

    ``rosbag``: the topics and frames of a ROS bag (None: found in the bag); refused for another log.
    ``unit``: the unit of the log's ranges (``evmap log --unit``).

    Raises :class:`~evmap.sources.logs.LogError` (a ValueError naming the file and
    line) for what the log's reader cannot read, and a ValueError naming the file
    for readings that are missing or wrong, before anything is written.
    """
    if every < 1:
        raise ValueError(f"--every must be at least 1, got {every}")
    if limit is not None and limit < 1:
        raise ValueError(f"--limit must be at least 1, got {limit}")
    _check_readings(config, readings)
    log = open_log(path, unit, rosbag=rosbag)
    noise = range_noise(record.scan for record in islice(iter(log), NOISE_SCANS))
    laser = laser or LaserParams().for_noise(noise)
    records: Iterable[LogRecord] = islice(_every(iter(log), every), limit)
    if progress is not None:
        records = progress(records)
    bm = new_map(config)
    observations, outcomes, fits, seconds = [], [], [], []
    last_sonar: RangeReadings | None = None  # the readings of the last scan that brought new ones
    skipped = 0
    for k, record in enumerate(records):
        start = time.perf_counter()
        sonar = record.sonar if record.sonar is not last_sonar else None  # a new object: new readings
        if sonar is not None:
            last_sonar = sonar
        skipped = record.skipped
        extra = None if readings is None else _scan_readings(Path(readings), record.index)
        try:
            obs = observation_from_log(record, config, k, laser, sonar, extra)
        except ValueError as e:
            if extra is None:
                raise
            raise ValueError(f"{_readings_file(Path(readings), record.index)}: {e}") from None
        outcomes.append(bm.update(obs))
        seconds.append(time.perf_counter() - start)
        observations.append(obs)
        fits.append(scan_fit(record.scan, obs.lsl.p, obs.lsl.q))
    if not observations:
        raise ValueError(f"{path}: no laser scans to map (after --every {every})")
    start = time.perf_counter()
    bm.join_corners()  # the corners a log without sonar left to the end (evmap.maps.pipeline)
    joined = time.perf_counter() - start
    coverage, error = log_fit(fits)
    summary = LogSummary(
        source=log.source,
        scans=len(observations),
        scans_skipped=skipped,
        sonar="log" if last_sonar is not None else "none",
        coverage_mean=_finite(coverage),
        rms_error_median=_finite(error),
        per_scan_median=float(np.median(seconds)),
        laser_noise=noise,
        fits=tuple(fits),
    )
    total = float(np.sum(seconds)) + joined
    return Run(None, config, observations, outcomes, bm, {"fuse": total, "total": total}, summary)


def _check_readings(config: Config, readings: str | Path | None) -> None:
    """Refuse a config with declared sensors and no readings directory, a directory for none, or a missing one."""
    declared = sorted(config.extra_sensors)
    if declared and readings is None:
        raise ValueError(
            f"{config.name}: declares the sensors {declared}; give their readings with --readings DIR "
            "(one scan-N.npz per scan used, arrays SENSOR/ARRAY)"
        )
    if readings is not None and not declared:
        raise ValueError(f"--readings {readings}: the config {config.name} declares no sensor to read them")
    if readings is not None and not Path(readings).is_dir():
        raise ValueError(f"--readings {readings}: no such directory")


def _readings_file(directory: Path, index: int) -> Path:
    """Where the declared sensors' readings at scan ``index`` of the log are."""
    return directory / f"scan-{index}.npz"


def _scan_readings(directory: Path, index: int) -> dict[str, dict[str, np.ndarray]]:
    """The declared sensors' readings at scan ``index`` of the log (:func:`_readings_file`)."""
    path = _readings_file(directory, index)
    if path.exists() and not path.is_file():
        raise ValueError(f"{path}: not a regular file (the readings of scan {index} of the log are an .npz file)")
    if not path.is_file():
        raise ValueError(f"{path}: no readings for scan {index} of the log")
    try:
        return read_readings(path)
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: {e}") from None


def _every(records: Iterator[T], every: int) -> Iterator[T]:
    """Every ``every``-th record, the first included."""
    return islice(records, 0, None, every)


def _finite(x: float) -> float | None:
    """``x``, or None where it is NaN (JSON has no NaN)."""
    return None if np.isnan(x) else float(x)
