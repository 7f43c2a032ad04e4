"""Real robot logs as streams of laser scans, poses and sonar readings.

The data types and geometry checks are in :mod:`evmap.sources.logs.scan`; one
reader per format: :func:`~evmap.sources.logs.carmen.read_carmen` (CARMEN
``.log``/``.clf``, gzipped or not), :func:`~evmap.sources.logs.g2o.read_g2o`
(g2o with ROBOTLASER1 scans, as MIT Killian), :func:`~evmap.sources.logs.rosbag.read_rosbag`
(ROS 1 ``.bag``, ROS 2 bag directory). :func:`open_log` picks the reader by the
path. Every reader returns a :class:`~evmap.sources.logs.scan.Log`, a stream of
:class:`~evmap.sources.logs.scan.LogRecord` read anew on each iteration, and
raises :class:`~evmap.sources.logs.scan.LogError` (a ValueError) naming the
file and line, or the topic and stamp, of anything it cannot read.

Examples
--------
>>> import tempfile, pathlib
>>> tmp = tempfile.TemporaryDirectory()
>>> path = pathlib.Path(tmp.name) / "tiny.g2o"
>>> _ = path.write_text("VERTEX_SE2 0 0 0 0\\n")
>>> open_log(path).source == str(path), list(open_log(path))
(True, [])
>>> tmp.cleanup()
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from evmap.sources.logs.carmen import CarmenOptions, read_carmen
from evmap.sources.logs.g2o import read_g2o
from evmap.sources.logs.rosbag import RosbagOptions, read_rosbag
from evmap.sources.logs.scan import LaserScan, Log, LogError, LogRecord, RangeReadings, Unit

__all__ = [
    "CarmenOptions",
    "LaserScan",
    "Log",
    "LogError",
    "LogRecord",
    "RangeReadings",
    "RosbagOptions",
    "open_log",
    "read_carmen",
    "read_g2o",
    "read_rosbag",
]


def open_log(path: str | Path, unit: Unit = "m", rosbag: RosbagOptions | None = None) -> Log:
    """The log at ``path`` with the reader its name calls for, every other option at its default.

    ``*.g2o``: g2o; ``*.bag``, ``*.mcap``, ``*.db3`` or a directory (a ROS 2
    bag): ROS bag, read with ``rosbag``'s topics and frames if given (its unit
    is ``unit``); anything else (``*.log``, ``*.clf``, ``*.gz``): CARMEN.
    ``rosbag`` for a log that is no ROS bag is a :class:`LogError`.
    """
    path = Path(path)
    if not path.exists():
        raise LogError(f"{path}: no such log")
    is_bag = path.is_dir() or path.suffix in {".bag", ".mcap", ".db3"}
    if rosbag is not None and not is_bag:
        raise LogError(
            f"{path}: ROS bag topics and frames (--scan-topic, --odom-topic, --range-topics, --world-frame, "
            "--base-frame) given for a log that is no ROS bag (*.bag, *.mcap, *.db3 or a ROS 2 bag directory)"
        )
    if path.suffix == ".g2o":
        return read_g2o(path, unit)
    if is_bag:
        return read_rosbag(path, replace(rosbag or RosbagOptions(), unit=unit))
    return read_carmen(path, CarmenOptions(unit=unit))
