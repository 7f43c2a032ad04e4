"""ROS 1 and ROS 2 bags (through the ``rosbags`` library): laser scans, range sensors, poses from odometry or tf.

What :func:`read_rosbag` reads, in the bag's record order, each message placed by its header stamp:

- ``sensor_msgs/LaserScan`` on ``scan_topic`` (default: the bag's only LaserScan
  topic): beam ``i`` at ``angle_min + i * angle_increment`` (checked against
  ``angle_max``; a negative increment is turned around), ranges in metres
  (REP 103; ``unit`` declares otherwise) with those outside
  ``[range_min, range_max)`` or not finite as no returns. One record per scan.
- ``sensor_msgs/Range`` on ``range_topics`` (default: every Range topic): the
  latest reading of each topic, together a ring (:class:`~evmap.sources.logs.scan.RangeReadings`,
  topics in name order), each sensor placed on the robot by tf; a new ring (a new
  object) only when a Range message came since the previous record. A range at or
  above ``max_range``, ``+inf`` or NaN is no echo; ``-inf`` (REP 117: too close to
  measure) and a reading below ``min_range`` are an echo at ``min_range`` (an
  obstacle closer than the sensor can measure); ``field_of_view`` is the beam width.
  A reading that is negative or over twice ``max_range`` is no echo too (a driver's
  glitch), but a topic most of whose readings are so (among its first
  :data:`RANGE_SAMPLE`, or all of them in a shorter bag) is an error: the unit is wrong.
- Poses: with ``odom_topic`` (default: the bag's only ``nav_msgs/Odometry`` topic,
  if it has one) the robot's pose is the odometry pose, its frame the
  odometry's ``child_frame_id``, and the laser sits on it as tf says. Without
  odometry the laser's pose is its frame in ``world_frame`` through the
  ``tf2_msgs/TFMessage`` transforms, the robot's is ``base_frame``'s (the
  laser's if tf does not link ``base_frame`` to the world).

Time: a scan is placed at its header stamp, as tf2 places it (:mod:`~evmap.sources.logs.placing`): the
odometry pose, and each dynamic (``/tf``) transform of the chain, interpolated between
the stamps around it (translation linearly, rotation by slerp). A scan read before a
pose past its stamp waits for one, at most :data:`~evmap.sources.logs.tf.WAIT_SECONDS`
of the bag's recording time (it is then placed at the latest pose before its stamp,
as it is at the end of the bag); the scans leave in the order they were read, each with
the Range readings read before it. Messages recorded out of stamp
order are kept in stamp order. Each source keeps at least the last
:data:`~evmap.sources.logs.tf.HISTORY_SECONDS` of stamps (at most twice that), so memory stays bounded.
Static transforms (a topic named ``tf_static``) are read first and hold at every
stamp. Scans before the first one that can be placed are skipped and counted
(:attr:`~evmap.sources.logs.scan.LogRecord.skipped`); a later scan that cannot be
placed, and a bag none of whose scans can be, is an error.

Geometry: transforms and odometry orientations are full 3D rotations. A beam at
angle ``a`` in the laser's frame points along ``R (cos a, sin a, 0)`` in the
world: a laser mounted upside down (its z axis pointing down) sweeps clockwise,
and its beams are turned around. A laser whose scan plane, a range sensor whose
axis, or a robot pose that leans more than :data:`~evmap.sources.logs.tf.MAX_TILT_DEG` out of the
horizontal plane is refused. A laser or range sensor frame that tf does not link
to the robot's frame sits on the robot's centre only in a bag without any tf
topic; in a bag with tf it is an error naming the frames.

Checks, each a :class:`~evmap.sources.logs.scan.LogError` naming the bag, topic
and stamp: a non-finite pose or transform, a rotation that is no unit quaternion,
a beam layout that does not fit its ``angle_max``, a non-positive or non-finite
``range_max``, the range checks of
:meth:`~evmap.sources.logs.scan.LaserGeometry.ranges`, a Range of impossible
field of view, minimum or maximum range; missing or ambiguous topics (a topic given without its leading
slash, ``scan``, is the bag's ``/scan`` as ROS resolves it, where the bag has no ``scan``); a file that is no bag,
a directory without a ROS 2 bag's ``metadata.yaml``, and a damaged bag (naming the
stamp of the last message read). The errors name the options as ``evmap log``'s
flags (``--scan-topic``, ``--odom-topic``, ...; :class:`RosbagOptions`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import chain
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from evmap.sources.logs.placing import HeldScan, Places, WaitingScans
from evmap.sources.logs.scan import (
    UNITS,
    LaserGeometry,
    LaserScan,
    Log,
    LogError,
    LogRecord,
    RangeReadings,
    Unit,
)
from evmap.sources.logs.tf import HISTORY_SECONDS, TfBuffer, frame_name, header_stamp, sensor_pose

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

__all__ = [
    "LASER_SCAN",
    "ODOMETRY",
    "RANGE",
    "RANGE_SAMPLE",
    "TF",
    "RosbagOptions",
    "read_rosbag",
]

RANGE_SAMPLE = 10
"""The Range readings of a topic that decide whether its unit is wrong (see the module doc)."""

LASER_SCAN = "sensor_msgs/msg/LaserScan"
RANGE = "sensor_msgs/msg/Range"
ODOMETRY = "nav_msgs/msg/Odometry"
TF = "tf2_msgs/msg/TFMessage"


@dataclass(frozen=True)
class RosbagOptions:
    """Which topics and frames to read; None: found in the bag (see the module doc).

    Attributes
    ----------
    scan_topic : the LaserScan topic (``evmap log --scan-topic``).
    range_topics : the Range topics, an empty tuple: none (``--range-topics``).
    odom_topic : the Odometry topic; ``""``: none, poses from tf (``--odom-topic``).
    world_frame : the tf frame of the world, without odometry (``--world-frame``).
    base_frame : the robot's tf frame, without odometry (``--base-frame``).
    unit : unit of the ranges.
    """

    scan_topic: str | None = None
    range_topics: tuple[str, ...] | None = None
    odom_topic: str | None = None
    world_frame: str = "odom"
    base_frame: str = "base_link"
    unit: Unit = "m"

    @classmethod
    def from_flags(
        cls,
        scan_topic: str | None = None,
        odom_topic: str | None = None,
        range_topics: str | None = None,
        world_frame: str | None = None,
        base_frame: str | None = None,
    ) -> RosbagOptions | None:
        """``evmap log``'s flags as options (``range_topics`` comma-separated); None where none is given.

        >>> RosbagOptions.from_flags(odom_topic="", range_topics="/a,/b").range_topics
        ('/a', '/b')
        >>> RosbagOptions.from_flags() is None
        True
        """
        names = ("scan_topic", "odom_topic", "range_topics", "world_frame", "base_frame")
        values = (scan_topic, odom_topic, range_topics, world_frame, base_frame)
        given = {name: value for name, value in zip(names, values, strict=True) if value is not None}
        if not given:
            return None
        for name in ("scan_topic", "world_frame", "base_frame"):
            if name in given and not given[name].strip("/"):
                raise ValueError(f"--{name.replace('_', '-')} needs a name")
        if "range_topics" in given:
            given["range_topics"] = tuple(topic for topic in given["range_topics"].split(",") if topic)
        return cls(**given)


def read_rosbag(path: str | Path, options: RosbagOptions | None = None) -> Log:
    """The bag at ``path`` (a ROS 1 ``.bag`` file or a ROS 2 bag directory) as a stream of records."""
    options = options or RosbagOptions()
    if options.unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {options.unit!r}")
    return Log(str(path), lambda: _records(Path(path), options))


def _is_static(topic: str) -> bool:
    """Whether a tf topic holds static transforms (``/tf_static``, or a namespaced ``.../tf_static``)."""
    return topic.rstrip("/").rsplit("/", 1)[-1] == "tf_static"


def _topics(reader: AnyReader, msgtype: str) -> list[str]:
    return sorted({c.topic for c in reader.connections if c.msgtype == msgtype})


def _named(name: str, topics: list[str]) -> str:
    """The topic a name stands for: a relative name (``scan``) is the global one (``/scan``) where the bag has no
    ``scan``."""
    return "/" + name if name not in topics and "/" + name in topics else name


def _choose(reader: AnyReader, path: Path, options: RosbagOptions) -> tuple[str, list[str], str]:
    scans = _topics(reader, LASER_SCAN)
    scan_topic = options.scan_topic
    if scan_topic is None:
        if not scans:
            raise LogError(f"{path}: no LaserScan topic (a {LASER_SCAN} topic is what evmap maps)")
        if len(scans) > 1:
            raise LogError(f"{path}: {len(scans)} LaserScan topics ({', '.join(scans)}): name one with --scan-topic")
        scan_topic = scans[0]
    elif (scan_topic := _named(scan_topic, scans)) not in scans:
        raise LogError(f"{path}: no LaserScan topic {scan_topic!r} (LaserScan topics: {', '.join(scans) or 'none'})")
    ranges = _topics(reader, RANGE)
    range_topics = ranges if options.range_topics is None else [_named(topic, ranges) for topic in options.range_topics]
    if missing := sorted(set(range_topics) - set(ranges)):
        raise LogError(
            f"{path}: no Range topic {missing[0]!r} (Range topics: {', '.join(ranges) or 'none'}; "
            "--range-topics '' for none)"
        )
    odoms = _topics(reader, ODOMETRY)
    odom_topic = options.odom_topic
    if odom_topic is None:
        if len(odoms) > 1:
            raise LogError(
                f"{path}: {len(odoms)} Odometry topics ({', '.join(odoms)}): name one with --odom-topic "
                "(or --odom-topic '' for poses from tf)"
            )
        odom_topic = odoms[0] if odoms else ""
    elif odom_topic and (odom_topic := _named(odom_topic, odoms)) not in odoms:
        raise LogError(f"{path}: no Odometry topic {odom_topic!r} (Odometry topics: {', '.join(odoms) or 'none'})")
    return scan_topic, range_topics, odom_topic


Reading = tuple[float, str, float, float, float]
"""A Range message: stamp, frame, range (m, NaN for no echo), maximum range (m), field of view (rad)."""


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
        tf_connections = [c for c in reader.connections if c.msgtype == TF]
        tf = TfBuffer()
        for connection, _, msg in _messages(reader, [c for c in tf_connections if _is_static(c.topic)], path):
            tf.add(msg, f"{path} {connection.topic}", static=True)
        wanted = {scan_topic, odom_topic, *range_topics}
        connections = [c for c in reader.connections if c.topic in wanted and c.msgtype != TF]
        connections += [c for c in tf_connections if not _is_static(c.topic)]
        source = f"odometry on {odom_topic}" if odom_topic else f"tf to {frame_name(options.world_frame)!r}"
        places = Places(source, tf, bool(tf_connections), bool(odom_topic), options.world_frame, options.base_frame)
        waiting = WaitingScans(places)
        latest: dict[str, Reading] = {}
        fresh = False  # a Range message came since the last scan read
        implausible = _Implausible(options.unit)
        ring: RangeReadings | None = None
        carried: dict[str, Reading] | None = None  # the readings of scans that could not be placed
        index = skipped = 0
        for connection, recorded, msg in chain(_messages(reader, connections, path), [(None, None, None)]):
            if connection is None:
                pass  # the bag ended: every scan still waiting is placed
            elif connection.msgtype == TF:
                tf.add(msg, f"{path} {connection.topic}", static=False)
            else:
                topic, stamp = connection.topic, header_stamp(msg)
                where = f"{path} {topic}@{stamp:.9f}"
                if topic == odom_topic:
                    places.add_odometry(msg, stamp, where)
                elif topic in range_topics:
                    latest[topic], fresh = _range(msg, where, options.unit), True
                    implausible.add(topic, msg, where)
                elif topic == scan_topic:
                    scan = _scan(msg, where, options.unit)
                    readings = dict(latest) if fresh else None
                    waiting.add(HeldScan(scan, frame_name(msg.header.frame_id), stamp, where, recorded, readings))
                    fresh = False
            for held in waiting.ready(recorded):
                placed = places.scan(held.frame, held.stamp, held.where)
                readings = held.readings or carried
                if placed is None:
                    carried = readings
                    if index:
                        raise LogError(
                            f"{held.where}: no pose at or before the scan's stamp by {places.source} (kept: at least "
                            f"the last {HISTORY_SECONDS:g} s of stamps), though the scans before it were placed: "
                            "are the stamps out of order?"
                        )
                    skipped += 1
                    continue
                laser, flipped, robot, base = placed
                scan = held.scan
                angles, ranges = (-scan.angles[::-1], scan.ranges[::-1]) if flipped else (scan.angles, scan.ranges)
                if readings:
                    ring = _ring(readings, tf, base, held.stamp, held.where, bool(tf_connections))
                    carried = None
                yield LogRecord(
                    index, LaserScan(held.stamp, laser, angles, ranges, scan.max_range), robot, ring, skipped=skipped
                )
                index += 1
        implausible.check()
        if skipped and not index:
            hint = "" if odom_topic else f" (the world frame: --world-frame; tf's topmost frames: {tf.roots()})"
            raise LogError(
                f"{path} {scan_topic}: none of the {skipped} scans could be placed in the world by {places.source}{hint}"
            )
    finally:
        reader.close()


def _messages(reader: AnyReader, connections: list[Any], path: Path) -> Iterator[tuple[Any, float, Any]]:
    """The bag's messages on these connections in recording order: the connection, when it was recorded (s) and
    the message, deserialized; a damaged one is a LogError."""
    if not connections:  # rosbags reads every connection when given none
        return
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
        yield connection, stamp * 1e-9, msg


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
    return LaserScan(header_stamp(msg), np.zeros(3), geometry.angles, ranges, geometry.max_range)


def _range(msg: Any, where: str, unit: Unit) -> Reading:
    """A Range message: its stamp, frame, range (m; NaN for no echo, ``min_range`` for too close), maximum range
    (m) and field of view (rad)."""
    fov, low, high, value = (float(v) for v in (msg.field_of_view, msg.min_range, msg.max_range, msg.range))
    scale = UNITS[unit]
    if not (np.isfinite(fov) and 0 < fov < np.pi):
        raise LogError(f"{where}: Range field_of_view {fov:g} rad is not a beam width")
    if not (np.isfinite(high) and high > 0):
        raise LogError(f"{where}: Range max_range {high:g} is not a positive number")
    if not (np.isfinite(low) and 0 <= low < high):
        raise LogError(f"{where}: Range min_range {low:g} is not a number from 0 to max_range {high:g}")
    if _implausible(value, high):  # no echo; the caller counts them (_Implausible)
        return header_stamp(msg), frame_name(msg.header.frame_id), np.nan, high * scale, fov
    if value == -np.inf or value < low:  # REP 117: an obstacle closer than the sensor can measure
        echo = low * scale
    elif value < high:
        echo = value * scale
    else:  # +inf, NaN, at or beyond max_range: no echo
        echo = np.nan
    return header_stamp(msg), frame_name(msg.header.frame_id), echo, high * scale, fov


def _implausible(value: float, high: float) -> bool:
    """Whether a Range reading is negative or over twice its ``max_range``."""
    return bool(np.isfinite(value) and (value < 0 or value > 2 * high))


class _Implausible:
    """Range readings negative or over twice their ``max_range``, per topic: a glitch now and then is no echo, most
    of a topic's readings so (of its first :data:`RANGE_SAMPLE`, or of all in a shorter bag) a wrong unit."""

    def __init__(self, unit: Unit) -> None:
        self.unit = unit
        self.counts: dict[str, list[int]] = {}  # topic -> [implausible, readings]
        self.first: dict[str, str] = {}  # topic -> what its first implausible reading was, and where

    def add(self, topic: str, msg: Any, where: str) -> None:
        value, high = float(msg.range), float(msg.max_range)
        odd = _implausible(value, high)
        count = self.counts.setdefault(topic, [0, 0])
        if count[1] == RANGE_SAMPLE:  # decided
            return
        count[0] += odd
        count[1] += 1
        if odd and topic not in self.first:
            self.first[topic] = (
                f"{where}: Range reading {value:g} {self.unit} is negative or over twice max_range {high:g}"
            )
        if count[1] == RANGE_SAMPLE:
            self.check(topic)

    def check(self, *topics: str) -> None:
        """Refuse the first of the ``topics`` (all, if none named) most of whose readings are implausible."""
        for topic in topics or sorted(self.counts):
            odd, total = self.counts[topic]
            if 2 * odd > total:
                raise LogError(
                    f"{self.first[topic]} ({odd} of the first {total} readings on {topic} are): "
                    f"is the unit {self.unit!r} right?"
                )


def _ring(
    latest: dict[str, Reading], tf: TfBuffer, base: str, stamp: float, where: str, bag_has_tf: bool
) -> RangeReadings:
    """The latest reading of every range topic, in topic order, as one ring on the robot's ``base`` frame."""
    rows = [latest[t] for t in sorted(latest)]
    offsets = []
    for _, frame, _, _, _ in rows:
        mount = tf.mount(frame, base, stamp, where, bag_has_tf)
        if mount is None:
            raise LogError(f"{where}: tf links the range sensor frame {frame!r} to {base!r} only after this scan")
        offsets.append(sensor_pose(mount, where, frame))
    return RangeReadings(
        stamp=max(r[0] for r in rows),
        offsets=np.array(offsets),
        ranges=np.array([r[2] for r in rows]),
        max_range=max(r[3] for r in rows),
        beam_width=np.array([r[4] for r in rows]),
    )
