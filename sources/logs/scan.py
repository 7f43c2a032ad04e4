"""What every log reader yields: laser scans, sonar readings and per-scan records, with their geometry checks.

The readers (:mod:`~evmap.sources.logs.carmen`, :mod:`~evmap.sources.logs.g2o`,
:mod:`~evmap.sources.logs.rosbag`) turn their format into these types; nothing
downstream knows which format a scan came from.

- :class:`LaserScan`: one planar laser scan, the laser's world pose, the beam
  angles in the laser frame, the ranges in metres with NaN for no return.
- :class:`RangeReadings`: sonar (or any single-beam range sensor) readings, one
  beam or a ring, each beam with its pose on the robot and its width.
- :class:`LogRecord`: one laser scan, the robot's pose and the latest sonar
  readings seen up to the scan (None if the log has none), and how many scans
  before it the reader could not place.
- :class:`Log`: a re-iterable stream of records; each iteration reads the file
  anew, so a large log never sits in memory.
- :class:`LaserGeometry`: the declared beam layout, units and maximum range of a
  laser; :meth:`LaserGeometry.scan` checks a line's raw readings against it.
- :class:`LogError`: any malformed line or message; the message names the file
  and line (or the topic and stamp) and what is wrong.

Units: metres and radians, angles counter-clockwise. A reading at or above the
maximum range, zero, NaN or infinite is "no return" (NaN in :attr:`LaserScan.ranges`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.readings import MAX_COORDINATE

__all__ = [
    "MAX_HEADING",
    "MIN_BEAM_STEP",
    "UNITS",
    "LaserGeometry",
    "LaserScan",
    "Log",
    "LogError",
    "LogRecord",
    "RangeReadings",
    "Unit",
    "check_pose",
    "compose",
    "relative",
]

MAX_HEADING = 1e6
"""The largest heading (rad) a log's pose may state: an odometry heading may count whole turns, not this many."""

MIN_BEAM_STEP = 1e-5
"""The closest two beams of a laser may be (rad): 0.0006 deg, finer than any laser's."""

UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Range units a reader may declare, and their size in metres."""

Unit = Literal["m", "cm", "mm"]
"""A range unit's name (a key of :data:`UNITS`)."""

MIN_PLAUSIBLE_MEDIAN = 0.05
"""A scan of ten or more returns whose median range is below this (m) was surely logged in a larger unit."""

MAX_PLAUSIBLE_MEDIAN = 500.0
"""A scan of ten or more returns whose median range is beyond this (m) was surely logged in a smaller unit, its
maximum range too (a ROS bag's ``range_max`` in millimetres): no 2D laser's returns lie that far."""

MAX_PLAUSIBLE_FACTOR = 2.0
"""Readings of median above this many maximum ranges were surely logged in a smaller unit."""


class LogError(ValueError):
    """A log line or message that cannot be read; the message names where (file:line or topic@stamp) and why."""


def check_pose(pose: ArrayLike, where: str, what: str = "pose") -> NDArray[np.float64]:
    """(3,) finite x, y, theta, x and y within :data:`~evmap.sources.readings.MAX_COORDINATE` of the origin and
    theta within :data:`MAX_HEADING` radians, or a :class:`LogError` naming ``where``.

    >>> check_pose([1, 2, 0.5], "a.log:3").tolist()
    [1.0, 2.0, 0.5]
    >>> check_pose([1, float("nan"), 0.5], "a.log:3")
    Traceback (most recent call last):
    ...
    sources.logs.scan.LogError: a.log:3: pose (1.0, nan, 0.5) is not finite
    >>> check_pose([1e300, 0, 0.5], "a.log:4", "laser pose")
    Traceback (most recent call last):
    ...
    sources.logs.scan.LogError: a.log:4: laser pose (1e+300, 0.0, 0.5): x and y must be within 2e+07 m of the origin
    """
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (3,):
        raise LogError(f"{where}: {what} needs x, y, theta, got {pose.size} numbers")
    shown = ", ".join(str(float(v)) for v in pose)
    if not np.isfinite(pose).all():
        raise LogError(f"{where}: {what} ({shown}) is not finite")
    if (np.abs(pose[:2]) > MAX_COORDINATE).any():
        raise LogError(f"{where}: {what} ({shown}): x and y must be within {MAX_COORDINATE:g} m of the origin")
    if abs(pose[2]) > MAX_HEADING:
        raise LogError(f"{where}: {what} ({shown}): a heading of {pose[2]:g} rad is no angle (at most {MAX_HEADING:g})")
    return pose


def compose(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """The 2D pose ``b`` (given in the frame of ``a``) in the frame ``a`` is given in: ``a ⊕ b``.

    >>> compose([1, 0, np.pi / 2], [1, 0, 0]).round(6).tolist()
    [1.0, 1.0, 1.570796]
    """
    x, y, t = np.asarray(a, dtype=float)
    bx, by, bt = np.asarray(b, dtype=float)
    c, s = np.cos(t), np.sin(t)
    return np.array([x + c * bx - s * by, y + s * bx + c * by, t + bt])


def relative(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """The pose ``b`` seen from pose ``a`` (both in one frame): ``a⁻¹ ⊕ b``.

    >>> relative([1, 1, np.pi / 2], [1, 2, np.pi / 2]).round(6).tolist()
    [1.0, 0.0, 0.0]
    """
    x, y, t = np.asarray(a, dtype=float)
    bx, by, bt = np.asarray(b, dtype=float)
    c, s = np.cos(t), np.sin(t)
    dx, dy = bx - x, by - y
    return np.array([c * dx + s * dy, -s * dx + c * dy, bt - t])


@dataclass(frozen=True, eq=False)
class LaserScan:
    """One planar laser scan.

    Attributes
    ----------
    stamp : time of the scan (s; the log's clock).
    pose : (3,) x, y (m), theta (rad) of the laser in the world.
    angles : (R,) beam angles in the laser frame (rad), increasing.
    ranges : (R,) ranges (m), NaN where the beam returned nothing.
    max_range : the laser's maximum range (m); readings at or above it were no returns.

    Examples
    --------
    >>> scan = LaserScan(0.0, np.array([1.0, 0, np.pi / 2]), np.array([0.0, 0.1]), np.array([2.0, np.nan]), 80.0)
    >>> scan.points.round(6).tolist()
    [[1.0, 2.0], [nan, nan]]
    """

    stamp: float
    pose: NDArray[np.float64]
    angles: NDArray[np.float64]
    ranges: NDArray[np.float64]
    max_range: float

    def __len__(self) -> int:
        return len(self.ranges)

    @property
    def bearings(self) -> NDArray[np.float64]:
        """(R,) world bearing of every beam (rad)."""
        return self.pose[2] + self.angles

    @property
    def points(self) -> NDArray[np.float64]:
        """(R, 2) world end point of every beam, NaN rows where no return."""
        b = self.bearings
        return self.pose[:2] + self.ranges[:, None] * np.column_stack([np.cos(b), np.sin(b)])


@dataclass(frozen=True, eq=False)
class RangeReadings:
    """Readings of single-beam range sensors (sonar): one beam, or a ring read at once.

    Attributes
    ----------
    stamp : time of the readings (s).
    offsets : (K, 3) pose of each beam's sensor on the robot: x, y (m), axis angle (rad).
    ranges : (K,) ranges (m), NaN where no echo came back within ``max_range``.
    max_range : the longest range reported (m). For
        :meth:`evmap.sources.readings.SonarScan.from_readings`, which takes no NaN,
        use ``np.nan_to_num(ranges, nan=max_range)``.
    beam_width : (K,) full opening angle of each beam (rad).

    Examples
    --------
    >>> sonar = RangeReadings(0.0, np.array([[0.1, 0, 0], [0, 0.1, np.pi / 2]]), np.array([1.0, np.nan]), 5.0,
    ...                       np.full(2, 0.4))
    >>> origins, bearings = sonar.in_world([1.0, 1.0, np.pi / 2])
    >>> origins.round(6).tolist(), bearings.round(6).tolist()
    ([[1.0, 1.1], [0.9, 1.0]], [1.570796, 3.141593])
    """

    stamp: float
    offsets: NDArray[np.float64]
    ranges: NDArray[np.float64]
    max_range: float
    beam_width: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.ranges)

    def in_world(self, robot_pose: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(K, 2) world position of each sensor and (K,) world bearing of its axis, the robot at ``robot_pose``."""
        x, y, t = np.asarray(robot_pose, dtype=float)
        c, s = np.cos(t), np.sin(t)
        ox, oy = self.offsets[:, 0], self.offsets[:, 1]
        origins = np.column_stack([x + c * ox - s * oy, y + s * ox + c * oy])
        return origins, t + self.offsets[:, 2]


@dataclass(frozen=True, eq=False)
class LogRecord:
    """One laser scan of a log, with the robot's pose and the latest sonar readings.

    Attributes
    ----------
    index : 0-based number of the scan in the log (the ``pose_index`` of the pipeline).
    scan : the laser scan (its pose is the laser's).
    robot_pose : (3,) the robot's world pose at the scan.
    sonar : the latest sonar readings up to the scan, or None. A reader hands the same
        object to the records that follow until the log brings new readings, so
        ``record.sonar is previous.sonar`` says that no reading came between two records
        (their stamps may repeat: a logger may stamp them all 0).
    skipped : how many scans of the log before this one the reader could not place (no
        pose known for them), in all.
    """

    index: int
    scan: LaserScan
    robot_pose: NDArray[np.float64]
    sonar: RangeReadings | None = None
    skipped: int = 0


@dataclass(frozen=True)
class Log:
    """A log as a re-iterable stream of :class:`LogRecord`: each ``iter()`` reads the source anew.

    Attributes
    ----------
    source : what is read (a path, with the reader's options where they matter).
    records : a function that opens the source and yields its records.
    """

    source: str
    records: Callable[[], Iterator[LogRecord]]

    def __iter__(self) -> Iterator[LogRecord]:
        return self.records()


@dataclass(frozen=True)
class LaserGeometry:
    """The declared beam layout of a laser: ``count`` beams at ``start + i * step`` (rad, laser frame).

    Attributes
    ----------
    count : number of beams.
    start, step : angle of the first beam and between two beams (rad).
    max_range : maximum range (m); a reading at or above it is a no return.
    unit : unit of the raw readings, ``"m"``, ``"cm"`` or ``"mm"``.

    Examples
    --------
    >>> g = LaserGeometry.spread(3, np.pi, 80.0)
    >>> np.degrees(g.angles).round(6).tolist()
    [-90.0, 0.0, 90.0]
    >>> g.ranges(["1.5", "81.9", "0"], "a.log:7").tolist()
    [1.5, nan, nan]
    >>> g.ranges(["1500", "2000", "1800"], "a.log:8")
    Traceback (most recent call last):
    ...
    sources.logs.scan.LogError: a.log:8: the median reading is 1800 m, over 2 times the maximum range (80 m): ...
    """

    count: int
    start: float
    step: float
    max_range: float
    unit: Unit = "m"

    def __post_init__(self) -> None:
        if self.count < 1:
            raise ValueError(f"a laser needs at least one beam, got {self.count}")
        if not (np.isfinite(self.step) and self.step > 0 and abs(self.step) * (self.count - 1) <= 2 * np.pi + 1e-6):
            raise ValueError(f"{self.count} beams {self.step} rad apart do not fit in one turn")
        if self.count > 1 and self.step < MIN_BEAM_STEP:
            raise ValueError(f"beams {self.step:g} rad apart are closer than any laser's (at least {MIN_BEAM_STEP:g})")
        if not (np.isfinite(self.start) and abs(self.start) <= 2 * np.pi):
            raise ValueError(f"first beam at {self.start:g} rad is no angle within one turn")
        if not (np.isfinite(self.max_range) and self.max_range > 0):
            raise ValueError(f"maximum range must be a positive number of metres, got {self.max_range}")
        if self.unit not in UNITS:
            raise ValueError(f"unit must be one of {sorted(UNITS)}, got {self.unit!r}")

    @classmethod
    def spread(cls, count: int, fov: float, max_range: float, unit: Unit = "m") -> LaserGeometry:
        """``count`` beams spread evenly over ``fov`` (rad), centred on the laser axis, the end beams on its edges."""
        step = fov / (count - 1) if count > 1 else fov
        return cls(count, -fov / 2 if count > 1 else 0.0, step, max_range, unit)

    @property
    def angles(self) -> NDArray[np.float64]:
        """(count,) beam angles (rad, laser frame)."""
        return self.start + self.step * np.arange(self.count)

    def ranges(self, words: ArrayLike, where: str) -> NDArray[np.float64]:
        """Raw readings (strings or numbers, in ``unit``) as metres with NaN for no return, checked.

        Refused with a :class:`LogError` naming ``where``: a wrong count, a word
        that is no number, a negative reading (``-inf``, too close to measure, is no
        return), finite readings of median over :data:`MAX_PLAUSIBLE_FACTOR` maximum
        ranges (a smaller unit than declared; a few such readings are no returns, as
        drivers report them), ten or more returns of median below
        :data:`MIN_PLAUSIBLE_MEDIAN` m (a larger unit), or beyond :data:`MAX_PLAUSIBLE_MEDIAN` m (a smaller one,
        the maximum range declared in it too).
        """
        try:
            raw = np.asarray(words, dtype=float)
        except ValueError as exc:
            raise LogError(f"{where}: a range reading is not a number ({exc})") from None
        if raw.shape != (self.count,):
            raise LogError(f"{where}: {raw.size} range readings, the laser has {self.count} beams")
        r = raw * UNITS[self.unit]
        negative = np.flatnonzero(np.isfinite(r) & (r < 0))  # -inf: too close to measure (REP 117), no return
        if len(negative):
            raise LogError(f"{where}: reading {negative[0]} is negative ({raw[negative[0]]:g} {self.unit})")
        finite = r[np.isfinite(r)]
        if len(finite) and np.median(finite) > MAX_PLAUSIBLE_FACTOR * self.max_range:
            # one far reading is a driver's "no return" (a Hokuyo's 60 m beyond its 5.6 m); most is a unit
            raise LogError(
                f"{where}: the median reading is {np.median(finite):g} m, over {MAX_PLAUSIBLE_FACTOR:g} times the "
                f"maximum range ({self.max_range:g} m): are the ranges in a smaller unit than the declared "
                f"{self.unit!r} (evmap log --unit)?"
            )
        r = np.where(np.isfinite(r) & (r > 0) & (r < self.max_range), r, np.nan)
        returned = r[~np.isnan(r)]
        if len(returned) >= 10 and not MIN_PLAUSIBLE_MEDIAN <= np.median(returned) <= MAX_PLAUSIBLE_MEDIAN:
            short = np.median(returned) < MIN_PLAUSIBLE_MEDIAN
            raise LogError(
                f"{where}: median range {np.median(returned):g} m is implausibly {'short' if short else 'long'}: "
                f"are the ranges in a {'larger' if short else 'smaller'} unit than the declared {self.unit!r} "
                "(evmap log --unit)?"
            )
        return r
