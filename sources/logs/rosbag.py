"""ROS 1 and ROS 2 bags (through the ``rosbags`` library): laser scans, range sensors, poses from odometry or tf.

What :func:`read_rosbag` reads, in the bag's time order:

- ``sensor_msgs/LaserScan`` on ``scan_topic`` (default: the bag's only LaserScan
  topic): beam ``i`` at ``angle_min + i * angle_increment`` (checked against
  ``angle_max``; a negative increment is turned around), ranges in metres
  (REP 103; ``unit`` declares otherwise) with those outside
  ``[range_min, range_max)`` or not finite as no returns. One record per scan.
- ``sensor_msgs/Range`` on ``range_topics`` (default: every Range topic): the
  latest reading of each topic, together a ring (:class:`~evmap.sources.logs.scan.RangeReadings`,
  topics in name order), each sensor placed on the robot by tf (identity if tf
  does not link its frame to the robot's); a range outside
  ``[min_range, max_range)`` is no echo; ``field_of_view`` is the beam width.
- Poses: with ``odom_topic`` (default: the bag's only ``nav_msgs/Odometry`` topic,
  if it has one) the robot's pose is the latest odometry pose, its frame the
  odometry's ``child_frame_id``, and the laser sits on it as tf says (identity
  if tf does not link them). Without odometry the laser's pose is its frame in
  ``world_frame`` through the latest ``tf2_msgs/TFMessage`` transforms (``/tf``
  and ``/tf_static``), the robot's is ``base_frame``'s (the laser's if unknown).
  The latest pose at or before a scan is used, not interpolated; scans before the
  first pose are skipped, and a bag none of whose scans can be placed is an error.

Checks, each a :class:`~evmap.sources.logs.scan.LogError` naming the bag, topic
and stamp: a non-finite pose or transform, a beam layout that does not fit its
``angle_max``, a non-positive or non-finite ``range_max``, the range checks of
:meth:`~evmap.sources.logs.scan.LaserGeometry.ranges`, a Range of impossible
field of view or maximum range; missing or ambiguous topics; a file that is no bag,
a directory without a ROS 2 bag's ``metadata.yaml``, and a damaged bag (naming the
stamp of the last message read).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from evmap.sources.logs.scan import (
    UNITS,
    LaserGeometry,
    LaserScan,
    Log,
    LogError,
    LogRecord,
    RangeReadings,
    Unit,
    check_pose,
    compose,
)

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

__all__ = ["LASER_SCAN", "ODOMETRY", "RANGE", "TF", "RosbagOptions", "read_rosbag"]

LASER_SCAN = "sensor_msgs/msg/LaserScan"
RANGE = "sensor_msgs/msg/Range"
ODOMETRY = "nav_msgs/msg/Odometry"
TF = "tf2_msgs/msg/TFMessage"

MAX_TF_DEPTH = 64
"""Longest tf chain followed (a longer one is a loop)."""


@dataclass(frozen=True)
class RosbagOptions:
    """Which topics and frames to read; None: found in the bag (see the module doc).

    Attributes
    ----------
    scan_topic : the LaserScan topic.
    range_topics : the Range topics (an empty tuple: none).
    odom_topic : the Odometry topic; ``""``: none, poses from tf.
    world_frame : the tf frame of the world (without odometry).
    base_frame : the robot's tf frame (without odometry).
    unit : unit of the ranges.
    """

    scan_topic: str | None = None
    range_topics: tuple[str, ...] | None = None
    odom_topic: str | None = None
    world_frame: str = "odom"
    base_frame: str = "base_link"
    unit: Unit = "m"


def read_rosbag(path: str | Path, options: RosbagOptions | None = None) -> Log:
    """The bag at ``path`` (a ROS 1 ``.bag`` file or a ROS 2 bag directory) as a stream of records."""
    options = options or RosbagOptions()
    if options.unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {options.unit!r}")
    return Log(str(path), lambda: _records(Path(path), options))


def _frame(name: str) -> str:
    return name.lstrip("/")


def _stamp(msg: Any) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _yaw(q: Any) -> float:
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2)))


class _Tf:
    """The latest transform of every tf frame: child -> (parent, 2D pose of the child in the parent)."""

    def __init__(self) -> None:
        self.parent: dict[str, tuple[str, NDArray[np.float64]]] = {}

    def add(self, msg: Any, where: str) -> None:
        for t in msg.transforms:
            child = _frame(t.child_frame_id)
            pose = [t.transform.translation.x, t.transform.translation.y, _yaw(t.transform.rotation)]
            self.parent[child] = (_frame(t.header.frame_id), check_pose(pose, where, f"transform of {child!r}"))

    def pose(self, frame: str, target: str) -> NDArray[np.float64] | None:
        """Pose of ``frame`` in ``target``, or None if the transforms do not link them."""
        pose = np.zeros(3)
        for _ in range(MAX_TF_DEPTH):
            if frame == target:
                return pose
            if frame not in self.parent:
                return None
            frame, relative = self.parent[frame]
            pose = compose(relative, pose)
        return None


def _topics(reader: AnyReader, msgtype: str) -> list[str]:
    return sorted({c.topic for c in reader.connections if c.msgtype == msgtype})


def _choose(reader: AnyReader, path: Path, options: RosbagOptions) -> tuple[str, list[str], str]:
    scans = _topics(reader, LASER_SCAN)
    scan_topic = options.scan_topic
    if scan_topic is None:
        if len(scans) != 1:
            raise LogError(f"{path}: {len(scans)} LaserScan topics ({', '.join(scans) or 'none'}): name scan_topic")
        scan_topic = scans[0]
    elif scan_topic not in scans:
        raise LogError(f"{path}: no LaserScan topic {scan_topic!r} (LaserScan topics: {', '.join(scans) or 'none'})")
    ranges = _topics(reader, RANGE)
    range_topics = ranges if options.range_topics is None else list(options.range_topics)
    if missing := sorted(set(range_topics) - set(ranges)):
        raise LogError(f"{path}: no Range topic {missing[0]!r} (Range topics: {', '.join(ranges) or 'none'})")
    odoms = _topics(reader, ODOMETRY)
    odom_topic = options.odom_topic
    if odom_topic is None:
        if len(odoms) > 1:
            raise LogError(f"{path}: {len(odoms)} Odometry topics ({', '.join(odoms)}): name odom_topic")
        odom_topic = odoms[0] if odoms else ""
    elif odom_topic and odom_topic not in odoms:
        raise LogError(f"{path}: no Odometry topic {odom_topic!r} (Odometry topics: {', '.join(odoms) or 'none'})")
    return scan_topic, range_topics, odom_topic


def _records(path: Path, options: RosbagOptions) -> Iterator[LogRecord]:
    from rosbags.highlevel import AnyReader  # only when a bag is read: rosbags takes a tenth of a second to import
    from rosbags.typesys import Stores, get_typestore

    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise LogError(f"{path}: a directory, but no ROS 2 bag (it holds no metadata.yaml)")
    reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
    try:
        reader.open()
    except Exception as exc:  # noqa: BLE001 - whatever rosbags meets in a file that is no bag, or a damaged one
        raise LogError(f"{path}: not a ROS bag evmap can read ({type(exc).__name__}: {exc})") from None
    try:
        scan_topic, range_topics, odom_topic = _choose(reader, path, options)
        wanted = {scan_topic, odom_topic, *range_topics}
        connections = [c for c in reader.connections if c.topic in wanted or c.msgtype == TF]
        tf = _Tf()
        odom: tuple[str, NDArray[np.float64]] | None = None
        latest: dict[str, tuple[float, str, float, float, float]] = {}
        index = scans = 0
        for connection, msg in _messages(reader, connections, path):
            topic = connection.topic
            if connection.msgtype == TF:
                tf.add(msg, f"{path} {topic}")
                continue
            where = f"{path} {topic}@{_stamp(msg):.9f}"
            if topic == odom_topic:
                p = msg.pose.pose
                pose = check_pose([p.position.x, p.position.y, _yaw(p.orientation)], where, "odometry pose")
                odom = (_frame(msg.child_frame_id), pose)
            elif topic in range_topics:
                latest[topic] = _range(msg, where, options.unit)
            elif topic == scan_topic:
                scans += 1
                scan = _scan(msg, where, options.unit)
                frame = _frame(msg.header.frame_id)
                if odom_topic:
                    if odom is None:
                        continue
                    base, robot = odom
                    offset = tf.pose(frame, base)
                    laser = compose(robot, np.zeros(3) if offset is None else offset)
                else:
                    base = options.base_frame
                    placed = tf.pose(frame, options.world_frame)
                    if placed is None:
                        continue
                    laser = placed
                    robot = tf.pose(base, options.world_frame)
                    robot = laser if robot is None else robot
                sonar = _ring(latest, tf, base)
                yield LogRecord(
                    index, LaserScan(scan.stamp, laser, scan.angles, scan.ranges, scan.max_range), robot, sonar
                )
                index += 1
        if scans and not index:
            source = f"odometry on {odom_topic}" if odom_topic else f"tf to {options.world_frame!r}"
            raise LogError(f"{path} {scan_topic}: none of the {scans} scans could be placed in the world by {source}")
    finally:
        reader.close()


def _messages(reader: AnyReader, connections: list[Any], path: Path) -> Iterator[tuple[Any, Any]]:
    """The bag's messages on these connections, deserialized, in time order; a damaged one is a LogError."""
    messages = reader.messages(connections=connections)
    stamp = None
    while True:
        try:
            connection, stamp, raw = next(messages)
            msg = reader.deserialize(raw, connection.msgtype)
        except StopIteration:
            return
        except Exception as exc:  # noqa: BLE001 - whatever rosbags meets in a damaged bag
            after = "" if stamp is None else f" after the message of {stamp * 1e-9:.9f} s"
            raise LogError(f"{path}: damaged bag{after} ({type(exc).__name__}: {exc})") from None
        yield connection, msg


def _scan(msg: Any, where: str, unit: Unit) -> LaserScan:
    n = len(msg.ranges)
    start, end, step, max_range = (float(v) for v in (msg.angle_min, msg.angle_max, msg.angle_increment, msg.range_max))
    if n == 0:
        raise LogError(f"{where}: LaserScan has no ranges")
    if not all(np.isfinite([start, end, step])) or (n > 1 and step == 0):
        raise LogError(f"{where}: LaserScan angles min {start:g}, max {end:g}, increment {step:g} are no layout")
    if n > 1 and abs(start + (n - 1) * step - end) > abs(step) * 1.01 + 1e-6:
        raise LogError(
            f"{where}: LaserScan of {n} beams from {start:g} rad by {step:g} rad ends at "
            f"{start + (n - 1) * step:g} rad, not at angle_max {end:g} rad"
        )
    if not (np.isfinite(max_range) and max_range > 0):
        raise LogError(f"{where}: LaserScan range_max {max_range:g} is not a positive number")
    raw = np.asarray(msg.ranges, dtype=float)
    if step < 0:
        start, step, raw = end, -step, raw[::-1]
    try:
        geometry = LaserGeometry(n, start, step if n > 1 else 1.0, max_range * UNITS[unit], unit)
    except ValueError as exc:
        raise LogError(f"{where}: LaserScan {exc}") from None
    ranges = geometry.ranges(raw, where)
    ranges[ranges < float(msg.range_min) * UNITS[unit]] = np.nan
    return LaserScan(_stamp(msg), np.zeros(3), geometry.angles, ranges, geometry.max_range)


def _range(msg: Any, where: str, unit: Unit) -> tuple[float, str, float, float, float]:
    """Stamp, frame, range (m, NaN for no echo), maximum range (m) and field of view (rad) of a Range message."""
    fov, low, high, value = (float(v) for v in (msg.field_of_view, msg.min_range, msg.max_range, msg.range))
    scale = UNITS[unit]
    if not (np.isfinite(fov) and 0 < fov < np.pi):
        raise LogError(f"{where}: Range field_of_view {fov:g} rad is not a beam width")
    if not (np.isfinite(high) and high > 0):
        raise LogError(f"{where}: Range max_range {high:g} is not a positive number")
    if np.isfinite(value) and (value < 0 or value > 2 * high):
        raise LogError(
            f"{where}: Range reading {value:g} {unit} is negative or over twice max_range {high:g}: "
            f"is the unit {unit!r} right?"
        )
    echo = value * scale if np.isfinite(value) and low <= value < high else np.nan
    return _stamp(msg), _frame(msg.header.frame_id), echo, high * scale, fov


def _ring(latest: dict[str, tuple[float, str, float, float, float]], tf: _Tf, base: str) -> RangeReadings | None:
    """The latest reading of every range topic, in topic order, as one ring on the robot."""
    if not latest:
        return None
    rows = [latest[t] for t in sorted(latest)]
    placed = [tf.pose(frame, base) for _, frame, _, _, _ in rows]
    offsets = np.array([np.zeros(3) if pose is None else pose for pose in placed])
    return RangeReadings(
        stamp=max(r[0] for r in rows),
        offsets=offsets,
        ranges=np.array([r[2] for r in rows]),
        max_range=max(r[3] for r in rows),
        beam_width=np.array([r[4] for r in rows]),
    )
