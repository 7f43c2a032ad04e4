"""CARMEN log files (``.log``, ``.clf``, gzipped or not): laser scans with their poses, odometry, sonar.

One message per line, ``NAME fields... ipc_timestamp ipc_hostname logger_timestamp``
(CARMEN logger format). What :func:`read_carmen` reads:

- ``FLASER n r_1..r_n x y theta odom_x odom_y odom_theta`` (old front-laser format):
  ``x y theta`` is the laser's pose (the corrected one in a ``*-corrected`` log),
  the robot's is that pose less the ``robot_frontlaser_offset`` (PARAM, m, along
  the robot's axis; 0 if absent). The line does not state its beam layout: the
  beams are spread evenly, centred on the laser axis, over ``fov_deg`` if given,
  else ``(n - 1) * laser_front_laser_resolution`` (PARAM, deg) if the log has
  it, else ``laser_front_laser_fov`` (PARAM, deg), else 180 deg, the end beams on
  the edges; both PARAMs, disagreeing by more than a beam's step, are an error.
  The maximum range is ``max_range`` if given, else ``robot_front_laser_max``
  (PARAM, m), else :data:`DEFAULT_MAX_RANGE`.
- ``ROBOTLASER1 type start fov resolution max_range accuracy remission_mode n
  r_1..r_n m e_1..e_m laser_x laser_y laser_theta robot_x robot_y robot_theta
  tv rv forward_safety side_safety turn_axis``: the line states its layout
  (beam ``i`` at ``start + i * resolution``, checked against ``fov``) and range.
- ``RAWLASER1 type start fov resolution max_range accuracy remission_mode n r_1..r_n
  m e_1..e_m``: the front laser as the CARMEN logger records it, layout as in
  ROBOTLASER1 but no pose: read only from a log that has no ROBOTLASER1 nor
  FLASER line (the logger writes each scan twice, RAWLASER1 and ROBOTLASER1, in a
  log with both), placed at the ODOM pose at its stamp, interpolated between the
  ODOM lines around it (as :mod:`~evmap.sources.logs.rosbag` places its scans; a
  scan waits for the next ODOM line at most :data:`~evmap.sources.logs.tf.WAIT_SECONDS`
  of the log's stamps, and is placed at the latest before it then, or at the end of
  the log), the laser ``robot_frontlaser_offset`` ahead (as FLASER); scans stamped
  before the first ODOM line are skipped, and a log none of whose scans can be placed is an error.
- ``ODOM x y theta tv rv accel``: checked (finite numbers); the poses of RAWLASER1 scans (the other
  scans carry their own).
- ``SONAR cone_angle k s_1..s_k x_1 y_1 theta_1 .. x_k y_k theta_k``: a sonar ring
  (angles in radians, offsets on the robot in metres); the next scans carry the
  latest such readings. A reading at or above ``sonar_max_range`` is no echo.
- ``PARAM name value``: the parameters above. Comments (``#``), blank lines and
  other messages (``NEFF``, ``SYNC``, ``TRUEPOS``, ``RLASER``, ...) are skipped.

Checks, each a :class:`~evmap.sources.logs.scan.LogError` naming the file and
line: a wrong field count, a field that is no number, a non-finite pose, the
range checks of :meth:`~evmap.sources.logs.scan.LaserGeometry.ranges` (negative
readings, units implausible for the declared ``unit``), a ROBOTLASER1 layout that
does not fit its field of view; gzip data damaged or cut short, and a path that is
no regular file (:func:`text_lines`, which the g2o reader reads through too).

Examples
--------
>>> import tempfile, pathlib
>>> tmp = tempfile.TemporaryDirectory()
>>> path = pathlib.Path(tmp.name) / "tiny.log"
>>> _ = path.write_text("PARAM robot_front_laser_max 50.0 host 0\\n"
...     "FLASER 3 1.0 60.0 2.0 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0\\n")
>>> [(r.index, r.scan.ranges.tolist(), np.degrees(r.scan.angles).tolist()) for r in read_carmen(path)]
[(0, [1.0, nan, 2.0], [-90.0, 0.0, 90.0])]
>>> tmp.cleanup()
"""

from __future__ import annotations

import gzip
import io
import os
import stat
import zlib
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import chain
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evmap.sources.geometry import wrapped
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
from evmap.sources.logs.tf import WAIT_SECONDS, History

__all__ = [
    "DEFAULT_FOV_DEG",
    "DEFAULT_MAX_RANGE",
    "DEFAULT_SONAR_MAX_RANGE",
    "CarmenOptions",
    "read_carmen",
    "robotlaser1",
    "text_lines",
]

DEFAULT_MAX_RANGE = 80.0
"""Maximum range (m) of a FLASER laser when neither the caller nor the log says: the SICK LMS's 80 m
(its overflow codes, 81.83 m and up, are then no returns)."""

DEFAULT_FOV_DEG = 180.0
"""Field of view of a FLASER laser when neither the caller nor the log says (deg)."""

DEFAULT_SONAR_MAX_RANGE = 5.0
"""Longest sonar range (m) when the caller does not say: a Pioneer ring's usable range."""


@dataclass(frozen=True)
class CarmenOptions:
    """What a CARMEN log does not say about its sensors; None: from the log's PARAM lines or the defaults.

    Attributes
    ----------
    unit : unit of the range readings (laser and sonar).
    max_range : laser maximum range (m) for FLASER lines.
    fov_deg : laser field of view for FLASER lines (deg).
    sonar_max_range : sonar maximum range (m).
    sonar_beam_width_deg : sonar beam width (deg); None: the SONAR line's cone angle.
    """

    unit: Unit = "m"
    max_range: float | None = None
    fov_deg: float | None = None
    sonar_max_range: float = DEFAULT_SONAR_MAX_RANGE
    sonar_beam_width_deg: float | None = None


def text_lines(path: str | Path) -> Iterator[tuple[int, str]]:
    """The lines of a text file, numbered from 1, gunzipped if it starts with the gzip magic bytes.

    The file is opened without blocking and refused unless it is a regular file (a
    directory, or a FIFO that might never end); gzip data that is damaged or cut short,
    or a file that cannot be read, is a :class:`LogError` naming the file and the line reached.
    """
    number = 0
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            raise LogError(f"{path}: not a regular file (a directory, FIFO, socket or device is no log)")
        with os.fdopen(fd, "rb") as f:
            gzipped = f.read(2) == b"\x1f\x8b"
            f.seek(0)
            raw = gzip.GzipFile(fileobj=f) if gzipped else f
            with io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace") as text:  # U+FFFD for a bad byte
                for number, line in enumerate(text, start=1):
                    yield number, line
    except (EOFError, zlib.error, gzip.BadGzipFile) as exc:
        raise LogError(f"{path}:{number + 1}: gzip data damaged or cut short ({exc})") from None
    except OSError as exc:
        raise LogError(f"{path}: cannot read the log: {exc.strerror or exc}") from None


def read_carmen(path: str | Path, options: CarmenOptions | None = None) -> Log:
    """The CARMEN log at ``path`` as a stream of records, one per FLASER or ROBOTLASER1 line, or RAWLASER1 line
    in a log with neither (see the module doc)."""
    options = options or CarmenOptions()
    if options.unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {options.unit!r}")
    return Log(str(path), lambda: _records(Path(path), options))


def _numbers(words: list[str], where: str, what: str) -> NDArray[np.float64]:
    try:
        return np.array(words, dtype=float)
    except ValueError:
        bad = next(w for w in words if not _is_number(w))
        raise LogError(f"{where}: {what}: {bad!r} is not a number") from None


def _stamp(words: list[str], where: str, kind: str) -> float:
    """The line's ``ipc_timestamp`` (the third field from the end): a finite number of seconds."""
    stamp = float(_numbers(words[-3:-2], where, f"{kind} timestamp")[0])
    if not np.isfinite(stamp):
        raise LogError(f"{where}: {kind} timestamp {stamp} is not finite")
    return stamp


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def _count(word: str, where: str, what: str) -> int:
    try:
        n = int(word)
    except ValueError:
        raise LogError(f"{where}: {what} {word!r} is not an integer") from None
    if n < 0:
        raise LogError(f"{where}: {what} {n} is negative")
    return n


def robotlaser1(words: list[str], where: str, unit: Unit = "m") -> tuple[LaserScan, NDArray[np.float64]]:
    """A ROBOTLASER1 line split into words: the scan (at the line's laser pose) and the line's robot pose.

    >>> line = "ROBOTLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 host 5.0"
    >>> scan, robot = robotlaser1(line.split(), "x.log:1")
    >>> scan.ranges.tolist(), scan.pose.tolist(), scan.stamp
    ([1.0, 2.0, 3.0], [1.0, 2.0, 0.1], 5.0)
    """
    scan, tail = _laser_line(words, where, unit, 6 + 5)
    poses = _numbers(words[tail : tail + 6], where, "ROBOTLASER1 poses")
    laser = check_pose(poses[:3], where, "laser pose")
    robot = check_pose(poses[3:], where, "robot pose")
    return LaserScan(scan.stamp, laser, scan.angles, scan.ranges, scan.max_range), robot


def _laser_line(words: list[str], where: str, unit: Unit, after: int) -> tuple[LaserScan, int]:
    """The scan of a ROBOTLASER1 or RAWLASER1 line (at pose 0) and where the fields after its remissions start;
    ``after``: how many fields come between those and the 3 stamps."""
    kind = words[0]
    if len(words) < 9:
        raise LogError(f"{where}: {kind} needs at least 9 fields, got {len(words)}")
    n = _count(words[8], where, f"{kind} beam count")
    if len(words) < 10 + n:
        raise LogError(f"{where}: {kind} states {n} beams but the line ends after {len(words) - 9} fields")
    m = _count(words[9 + n], where, f"{kind} remission count")
    expected = 9 + n + 1 + m + after + 3
    if len(words) != expected:
        raise LogError(f"{where}: {kind} with {n} beams and {m} remissions needs {expected} fields, got {len(words)}")
    start, fov, step, max_range = _numbers(words[2:6], where, f"{kind} layout")
    if not (n >= 1 and step > 0 and fov > 0 and max_range > 0):
        raise LogError(
            f"{where}: {kind} layout start {start:g}, fov {fov:g}, resolution {step:g}, "
            f"max range {max_range:g} is not a laser's"
        )
    if n > 1 and abs((n - 1) * step - fov) > step * 1.01 + 1e-6:
        raise LogError(
            f"{where}: {kind} states {n} beams {step:g} rad apart, which do not fit its field of view {fov:g} rad"
        )
    try:
        geometry = LaserGeometry(n, float(start), float(step), float(max_range) * UNITS[unit], unit)
    except ValueError as exc:
        raise LogError(f"{where}: {kind} {exc}") from None
    ranges = geometry.ranges(words[9 : 9 + n], where)
    stamp = _stamp(words, where, kind)
    return LaserScan(stamp, np.zeros(3), geometry.angles, ranges, geometry.max_range), 10 + n + m


class _State:
    """What a CARMEN log has said so far: its parameters, the FLASER layouts, the latest sonar readings."""

    def __init__(self, options: CarmenOptions) -> None:
        self.options = options
        self.params: dict[str, str] = {}
        self.layouts: dict[int, LaserGeometry] = {}
        self.sonar: RangeReadings | None = None

    def param(self, name: str, where: str, positive: bool = True) -> float | None:
        if name not in self.params:
            return None
        value = self.params[name]
        if not _is_number(value) or not np.isfinite(float(value)) or (positive and float(value) <= 0):
            raise LogError(f"{where}: PARAM {name} {value!r} is not a {'positive ' if positive else ''}number")
        return float(value)

    def flaser_geometry(self, n: int, where: str) -> LaserGeometry:
        if n not in self.layouts:
            o = self.options
            max_range = o.max_range or self.param("robot_front_laser_max", where) or DEFAULT_MAX_RANGE
            resolution = self.param("laser_front_laser_resolution", where)
            fov = self.param("laser_front_laser_fov", where)
            if o.fov_deg is not None:
                fov = o.fov_deg
            elif resolution is not None:
                if fov is not None and n > 1 and abs(resolution * (n - 1) - fov) > resolution * 1.01 + 1e-6:
                    raise LogError(
                        f"{where}: FLASER with {n} beams: PARAM laser_front_laser_resolution {resolution:g} deg "
                        f"spreads them over {resolution * (n - 1):g} deg, PARAM laser_front_laser_fov says {fov:g} "
                        "deg: one of the two is wrong (fix it, or give CarmenOptions.fov_deg)"
                    )
                fov = resolution * (n - 1)
            try:
                self.layouts[n] = LaserGeometry.spread(n, np.radians(fov or DEFAULT_FOV_DEG), max_range, o.unit)
            except ValueError as exc:
                raise LogError(f"{where}: FLASER with {n} beams: {exc}") from None
        return self.layouts[n]


def _records(path: Path, options: CarmenOptions) -> Iterator[LogRecord]:
    state = _State(options)
    index = raw_scans = skipped = 0
    raw = None  # whether RAWLASER1 lines are the scans: the log has no ROBOTLASER1 nor FLASER line
    odometry = History(_between_poses)  # the ODOM poses by stamp
    held: deque[tuple[LaserScan, str, RangeReadings | None]] = deque()  # RAWLASER1 scans waiting for their poses
    now = -np.inf  # the stamp of the latest ODOM or RAWLASER1 line
    for number, line in chain(text_lines(path), [(None, "END")]):  # at the end, every scan waiting is placed
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        where = f"{path}:{number}"
        name = words[0] if number is not None else ""
        if name == "PARAM":
            if len(words) < 3:
                raise LogError(f"{where}: PARAM needs a name and a value")
            state.params[words[1]] = words[2]
            state.layouts.clear()
        elif name == "FLASER":
            yield _flaser(words, where, state, index)
            index += 1
        elif name == "ROBOTLASER1":
            scan, robot = robotlaser1(words, where, options.unit)
            yield LogRecord(index, scan, robot, state.sonar)
            index += 1
        elif name == "RAWLASER1":
            raw = _only_raw_scans(path) if raw is None else raw
            if raw:
                raw_scans += 1
                scan, _ = _laser_line(words, where, options.unit, 0)
                held.append((scan, where, state.sonar))
                now = scan.stamp
        elif name == "ODOM":
            if len(words) != 10:
                raise LogError(f"{where}: ODOM needs 10 fields (x y theta tv rv accel and 3 stamps), got {len(words)}")
            pose = check_pose(_numbers(words[1:4], where, "ODOM pose"), where, "odometry pose")
            stamp = _stamp(words, where, "ODOM")
            if raw and odometry.stamps and stamp < odometry.stamps[-1]:  # the scans' poses would mix two periods
                raise LogError(
                    f"{where}: ODOM stamp {stamp:.6f} is {odometry.stamps[-1] - stamp:.6f} s before an earlier line's: "
                    "the log's clock stepped back, and its RAWLASER1 scans are placed by their stamps"
                )
            odometry.add(stamp, pose)
            now = odometry.stamps[-1]
        elif name == "SONAR":
            state.sonar = _sonar(words, where, options)
        while held and (number is None or odometry.covers(held[0][0].stamp) or now - held[0][0].stamp > WAIT_SECONDS):
            if (record := _placed(*held.popleft(), odometry, state, index, skipped)) is None:
                skipped += 1
            else:
                yield record
                index += 1
    if raw_scans and not index:
        raise LogError(
            f"{path}: none of the {raw_scans} RAWLASER1 scans could be placed: the log has no ODOM line before them"
        )


def _only_raw_scans(path: Path) -> bool:
    """Whether the log has no ROBOTLASER1 nor FLASER line (read through once, at its first RAWLASER1 line)."""
    return not any(line.startswith(("ROBOTLASER1 ", "FLASER ")) for _, line in text_lines(path))


def _placed(
    scan: LaserScan,
    where: str,
    sonar: RangeReadings | None,
    odometry: History,
    state: _State,
    index: int,
    skipped: int,
) -> LogRecord | None:
    """A RAWLASER1 scan at the odometry pose at its stamp, the laser ``robot_frontlaser_offset`` ahead of the robot;
    None before the first ODOM stamp."""
    robot = odometry.at(scan.stamp)
    if robot is None:
        return None
    offset = state.param("robot_frontlaser_offset", where, positive=False) or 0.0
    laser = check_pose(compose(robot, [offset, 0.0, 0.0]), where, "laser pose (robot_frontlaser_offset ahead)")
    moved = LaserScan(scan.stamp, laser, scan.angles, scan.ranges, scan.max_range)
    return LogRecord(index, moved, robot, sonar, skipped=skipped)


def _between_poses(a: NDArray[np.float64], b: NDArray[np.float64], s: float) -> NDArray[np.float64]:
    """The 2D pose the share ``s`` of the way from ``a`` to ``b``, turning the short way."""
    turn = wrapped(b[2] - a[2])
    return np.array([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), a[2] + s * turn])


def _flaser(words: list[str], where: str, state: _State, index: int) -> LogRecord:
    if len(words) < 2:
        raise LogError(f"{where}: FLASER needs a beam count")
    n = _count(words[1], where, "FLASER beam count")
    if n == 0 or len(words) != n + 11:
        raise LogError(
            f"{where}: FLASER with {n} beams needs {n + 11} fields (readings, two poses, 3 stamps), got {len(words)}"
        )
    geometry = state.flaser_geometry(n, where)
    ranges = geometry.ranges(words[2 : 2 + n], where)
    laser = check_pose(_numbers(words[2 + n : 5 + n], where, "FLASER pose"), where, "laser pose")
    offset = state.param("robot_frontlaser_offset", where, positive=False) or 0.0
    robot = check_pose(compose(laser, [-offset, 0.0, 0.0]), where, "robot pose (robot_frontlaser_offset behind)")
    stamp = _stamp(words, where, "FLASER")
    return LogRecord(index, LaserScan(stamp, laser, geometry.angles, ranges, geometry.max_range), robot, state.sonar)


def _sonar(words: list[str], where: str, options: CarmenOptions) -> RangeReadings:
    if len(words) < 3:
        raise LogError(f"{where}: SONAR needs a cone angle and a sensor count")
    cone = float(_numbers(words[1:2], where, "SONAR cone angle")[0])
    k = _count(words[2], where, "SONAR sensor count")
    if len(words) != 3 + 4 * k + 3:
        raise LogError(
            f"{where}: SONAR with {k} sensors needs {3 + 4 * k + 3} fields (readings, x y theta offsets, "
            f"3 stamps), got {len(words)}"
        )
    raw = _numbers(words[3 : 3 + k], where, "SONAR readings") * UNITS[options.unit]
    offsets = _numbers(words[3 + k : 3 + 4 * k], where, "SONAR offsets").reshape(k, 3)
    for i, offset in enumerate(offsets):
        check_pose(offset, where, f"SONAR offset of sensor {i}")
    if (raw < 0).any():
        raise LogError(f"{where}: SONAR reading {int(np.argmax(raw < 0))} is negative")
    if np.median(raw) > 2 * options.sonar_max_range:  # most readings: a unit; a few, glitches: no echo (as ROS)
        raise LogError(
            f"{where}: the SONAR readings' median {np.median(raw):g} m is over twice "
            f"the sonar maximum range ({options.sonar_max_range:g} m): is the unit {options.unit!r} right?"
        )
    width = np.radians(options.sonar_beam_width_deg) if options.sonar_beam_width_deg is not None else cone
    if not (np.isfinite(width) and 0 < width < np.pi):
        raise LogError(f"{where}: SONAR cone angle {cone:g} rad is not a beam width")
    ranges = np.where(raw < options.sonar_max_range, raw, np.nan)
    stamp = _stamp(words, where, "SONAR")
    return RangeReadings(stamp, offsets, ranges, options.sonar_max_range, np.full(k, width))
