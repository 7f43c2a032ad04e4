"""A belief map from a whole robot log: every scan's laser segments as the contour, poses from the log.

:func:`run_log` is what ``evmap log`` computes. Each used record (every
``every``-th laser scan of the log, at most ``limit`` of them) becomes an
observation (:func:`evmap.maps.observation.observation_from_log`) whose
``pose_index`` is its place among the used scans, and is folded into one map.
The log's sonar readings are used where it has them, each reading once (a
record whose readings are those of the previous used scan brings none); a log
without any skips the sonar stages and the report says ``"sonar": "none"``.
PLE's line-fit measures of the laser segments come along.

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
from evmap.maps.observation import observation_from_log
from evmap.sources.config import Config
from evmap.sources.laser import LaserParams
from evmap.sources.line_fit import log_fit, scan_fit
from evmap.sources.logs import LogRecord, open_log

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
) -> Run:
    """Fold every ``every``-th scan of the log at ``path`` (at most ``limit``) into one belief map.

    Raises :class:`~evmap.sources.logs.LogError` (a ValueError naming the file and
    line) for what the log's reader cannot read, before anything is written.
    """
    if every < 1:
        raise ValueError(f"--every must be at least 1, got {every}")
    if limit is not None and limit < 1:
        raise ValueError(f"--limit must be at least 1, got {limit}")
    laser = laser or LaserParams()
    log = open_log(path)
    records: Iterable[LogRecord] = islice(_every(iter(log), every), limit)
    if progress is not None:
        records = progress(records)
    bm = new_map(config)
    observations, outcomes, fits, seconds = [], [], [], []
    last_sonar: float | None = None
    for k, record in enumerate(records):
        start = time.perf_counter()
        sonar = record.sonar if record.sonar is not None and record.sonar.stamp != last_sonar else None
        if sonar is not None:
            last_sonar = sonar.stamp
        obs = observation_from_log(record, config, k, laser, sonar)
        outcomes.append(bm.update(obs))
        seconds.append(time.perf_counter() - start)
        observations.append(obs)
        fits.append(scan_fit(record.scan, obs.lsl.p, obs.lsl.q))
    if not observations:
        raise ValueError(f"{path}: no laser scans to map (after --every {every})")
    coverage, error = log_fit(fits)
    summary = LogSummary(
        source=log.source,
        scans=len(observations),
        sonar="log" if last_sonar is not None else "none",
        coverage_mean=_finite(coverage),
        rms_error_median=_finite(error),
        per_scan_median=float(np.median(seconds)),
    )
    total = float(np.sum(seconds))
    return Run(None, config, observations, outcomes, bm, {"fuse": total, "total": total}, summary)


def _every(records: Iterator[T], every: int) -> Iterator[T]:
    """Every ``every``-th record, the first included."""
    return islice(records, 0, None, every)


def _finite(x: float) -> float | None:
    """``x``, or None where it is NaN (JSON has no NaN)."""
    return None if np.isnan(x) else float(x)
