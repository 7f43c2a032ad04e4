"""3D poses of tf frames and a tf buffer: what the ROS bag reader (:mod:`~evmap.sources.logs.rosbag`) places its
sensors with.

- :func:`rigid`: a ROS translation and quaternion as a 3D pose (:data:`Rigid`), checked.
- :func:`robot_pose`, :func:`laser_pose`, :func:`sensor_pose`: a 3D pose as the 2D pose
  evmap maps with, refused where it leans more than :data:`MAX_TILT_DEG` out of the
  horizontal plane; a laser upside down is told apart (its beams sweep clockwise).
- :func:`blend`: a 3D pose between two, as tf2 interpolates (translation linearly, rotation by slerp).
- :class:`History`: stamped values of one source, the value at a stamp interpolated between
  the two stamps around it (the latest at or before it where none is held after),
  at least the last :data:`HISTORY_SECONDS` of stamps kept.
- :class:`TfBuffer`: static transforms (at every stamp) and the history of the
  dynamic ones; the pose of one frame in another at a stamp, each dynamic transform
  of the chain interpolated, and whether every one of them is held past the stamp.

Examples
--------
>>> from types import SimpleNamespace as NS
>>> quarter = rigid(NS(x=1.0, y=0.0, z=0.0), NS(x=0.0, y=0.0, z=np.sin(np.pi / 4), w=np.cos(np.pi / 4)), "a.bag", "tf")
>>> robot_pose(then(quarter, (np.eye(3), np.array([1.0, 0.0, 0.0]))), "a.bag", "pose").round(6).tolist()
[1.0, 1.0, 1.570796]
>>> upside_down = rigid(NS(x=0.0, y=0.0, z=0.0), NS(x=1.0, y=0.0, z=0.0, w=0.0), "a.bag", "tf")
>>> pose, flipped = laser_pose(upside_down, "a.bag", "laser")
>>> pose.tolist(), bool(flipped)
([0.0, 0.0, 0.0], True)
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evmap.sources.logs.scan import LogError, check_pose

__all__ = [
    "HISTORY_SECONDS",
    "IDENTITY",
    "MAX_QUATERNION_ERROR",
    "MAX_TF_DEPTH",
    "MAX_TILT_DEG",
    "WAIT_SECONDS",
    "History",
    "Rigid",
    "TfBuffer",
    "blend",
    "frame_name",
    "header_stamp",
    "inverse",
    "laser_pose",
    "rigid",
    "robot_pose",
    "sensor_pose",
    "then",
]

MAX_TF_DEPTH = 64
"""Longest tf chain followed (a longer one is a loop)."""

MAX_TILT_DEG = 10.0
"""How far (deg) a laser's scan plane, a range sensor's axis or the robot may lean out of the horizontal plane."""

HISTORY_SECONDS = 10.0
"""Stamps (s) of odometry and of each dynamic transform kept at least (tf2's buffer keeps 10 s too)."""

WAIT_SECONDS = 1.0
"""How long (s, by the log's clock) a scan waits for a pose past its stamp before it is placed at the latest
pose before it."""

MAX_QUATERNION_ERROR = 0.01
"""How far the squared norm of a rotation's quaternion may be from 1 (tf2's bound); it is normalised."""

Rigid = tuple[NDArray[np.float64], NDArray[np.float64]]
"""A 3D pose: (3, 3) rotation and (3,) translation of a frame in its parent."""

IDENTITY: Rigid = (np.eye(3), np.zeros(3))


def frame_name(name: str) -> str:
    """A tf frame's name without its leading slashes (ROS 1 names may have them, tf2 drops them)."""
    return name.lstrip("/")


def header_stamp(msg: Any) -> float:
    """A message's header stamp (s)."""
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def rigid(translation: Any, rotation: Any, where: str, what: str) -> Rigid:
    """A translation and a quaternion (ROS messages) as a 3D pose, checked: finite, a unit quaternion."""
    t = np.array([translation.x, translation.y, translation.z], dtype=float)
    q = np.array([rotation.x, rotation.y, rotation.z, rotation.w], dtype=float)
    if not (np.isfinite(t).all() and np.isfinite(q).all()):
        position, quaternion = (", ".join(f"{v:g}" for v in values) for values in (t, q))
        raise LogError(f"{where}: {what} (position {position}; quaternion {quaternion}) is not finite")
    norm = float(q @ q)
    if abs(norm - 1) > MAX_QUATERNION_ERROR:
        shown = ", ".join(f"{v:g}" for v in q)
        raise LogError(f"{where}: {what} has the rotation (x, y, z, w) = ({shown}), not a unit quaternion")
    x, y, z, w = q / np.sqrt(norm)
    rotation_matrix = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return rotation_matrix, t


def then(a: Rigid, b: Rigid) -> Rigid:
    """The pose ``b`` (given in the frame of ``a``) in the frame ``a`` is given in."""
    return a[0] @ b[0], a[0] @ b[1] + a[1]


def inverse(a: Rigid) -> Rigid:
    """The pose of the parent in the frame of ``a``."""
    return a[0].T, -a[0].T @ a[1]


def _heading(pose: Rigid) -> float:
    """Direction (rad) of the frame's x axis projected on the horizontal plane."""
    return float(np.arctan2(pose[0][1, 0], pose[0][0, 0]))


def blend(a: Rigid, b: Rigid, s: float) -> Rigid:
    """The pose the share ``s`` (0 to 1) of the way from ``a`` to ``b``: the translation linearly, the rotation
    about the single axis that turns ``a`` into ``b`` (slerp), as tf2 interpolates two transforms.

    >>> a, b = (np.eye(3), np.zeros(3)), (np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]), np.array([2.0, 0, 0]))
    >>> r, t = blend(a, b, 0.5)
    >>> round(float(np.degrees(np.arctan2(r[1, 0], r[0, 0]))), 6), t.tolist()  # a quarter turn, halfway
    (45.0, [1.0, 0.0, 0.0])
    """
    relative = a[0].T @ b[0]
    cos = np.clip((np.trace(relative) - 1) / 2, -1.0, 1.0)
    angle = float(np.arccos(cos))
    axis = np.array([relative[2, 1] - relative[1, 2], relative[0, 2] - relative[2, 0], relative[1, 0] - relative[0, 1]])
    if angle > np.pi - 1e-6:  # half a turn: the axis from the symmetric part
        axis = np.sqrt(np.maximum((np.diag(relative) + 1) / 2, 0.0))  # |k|, from R = 2 k k^T - I
        i = int(np.argmax(axis))
        sign = np.where(relative[i] < 0, -1.0, 1.0)  # the signs of the k_j against the largest, k_i > 0
        sign[i] = 1.0
        axis *= sign
    norm = float(np.hypot.reduce(axis))
    turn = np.eye(3)
    if norm > 1e-12 and angle > 0:
        k = axis / norm
        cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        turn = np.eye(3) + np.sin(s * angle) * cross + (1 - np.cos(s * angle)) * cross @ cross
    return a[0] @ turn, a[1] + s * (b[1] - a[1])


def robot_pose(pose: Rigid, where: str, what: str) -> NDArray[np.float64]:
    """The robot's 2D pose from its 3D one: x, y and heading, the rotation checked to be about the vertical."""
    tilt = np.degrees(np.arccos(np.clip(pose[0][2, 2], -1.0, 1.0)))
    if tilt > MAX_TILT_DEG:
        raise LogError(
            f"{where}: {what} leans {tilt:.1f} deg out of the horizontal plane (at most {MAX_TILT_DEG:g}): "
            "a robot pose is a rotation about the vertical"
        )
    return check_pose([pose[1][0], pose[1][1], _heading(pose)], where, what)


def laser_pose(pose: Rigid, where: str, frame: str) -> tuple[NDArray[np.float64], bool]:
    """The laser's 2D pose in the world and whether it is upside down (its z axis pointing down).

    Upside down, a beam at angle ``a`` in the laser frame points at ``heading - a``:
    the caller turns the beams around.
    """
    up = pose[0][2, 2]
    tilt = np.degrees(np.arccos(min(1.0, abs(up))))
    if tilt > MAX_TILT_DEG:
        raise LogError(
            f"{where}: the scan plane of the laser frame {frame!r} is tilted {tilt:.1f} deg from the horizontal "
            f"(at most {MAX_TILT_DEG:g}): evmap maps horizontal scans only"
        )
    return check_pose([pose[1][0], pose[1][1], _heading(pose)], where, f"pose of the laser frame {frame!r}"), up < 0


def sensor_pose(pose: Rigid, where: str, frame: str) -> NDArray[np.float64]:
    """A range sensor's 2D pose on the robot, its axis (x) checked to be near the horizontal plane."""
    elevation = np.degrees(np.arcsin(min(1.0, abs(pose[0][2, 0]))))
    if elevation > MAX_TILT_DEG:
        raise LogError(
            f"{where}: the axis of the range sensor frame {frame!r} points {elevation:.1f} deg out of the "
            f"horizontal plane (at most {MAX_TILT_DEG:g})"
        )
    return check_pose([pose[1][0], pose[1][1], _heading(pose)], where, f"pose of the range sensor {frame!r}")


class History:
    """Stamped values of one source in stamp order: the value at a stamp, interpolated.

    ``between(a, b, s)`` gives the value the share ``s`` of the way from the value ``a``
    to the next one ``b``; a stamp past the latest held gets the latest value.
    Keeps at least the last :data:`HISTORY_SECONDS` of stamps, at most twice that:
    entries are dropped in batches, the latest at or before the cut kept, so what
    :meth:`at` finds is always what it would find among all the values added.

    >>> h = History(lambda a, b, s: a + s * (b - a))
    >>> h.add(1.0, 10.0); h.add(2.0, 20.0)
    >>> h.at(0.5), h.at(1.25), h.at(3.0), h.covers(1.5), h.covers(2.5)
    (None, 12.5, 20.0, True, False)
    """

    def __init__(self, between: Callable[[Any, Any, float], Any]) -> None:
        self.between = between
        self.stamps: list[float] = []
        self.values: list[Any] = []

    def add(self, stamp: float, value: Any) -> None:
        """Hold ``value`` at ``stamp``, in stamp order (an older stamp than those held goes before them)."""
        i = bisect_right(self.stamps, stamp)
        self.stamps.insert(i, stamp)
        self.values.insert(i, value)
        cut = self.stamps[-1] - HISTORY_SECONDS
        if self.stamps[0] < cut - HISTORY_SECONDS:
            keep = bisect_right(self.stamps, cut) - 1
            del self.stamps[:keep], self.values[:keep]

    def at(self, stamp: float) -> Any:
        """The value at ``stamp``: between the values of the stamps around it; past the latest, the latest; None
        before the first."""
        i = bisect_right(self.stamps, stamp)
        if not i:
            return None
        if i == len(self.stamps) or self.stamps[i - 1] == stamp:
            return self.values[i - 1]
        t0, t1 = self.stamps[i - 1], self.stamps[i]
        return self.between(self.values[i - 1], self.values[i], (stamp - t0) / (t1 - t0))

    def covers(self, stamp: float) -> bool:
        """Whether a value at or after ``stamp`` is held: the value there is interpolated, not the latest."""
        return bool(self.stamps) and self.stamps[-1] >= stamp


class TfBuffer:
    """The transforms read: static ones (at every stamp) and a history of the dynamic ones, per child frame."""

    def __init__(self) -> None:
        self.static: dict[str, tuple[str, Rigid]] = {}
        self.dynamic: dict[str, History] = {}

    def add(self, msg: Any, where: str, static: bool) -> None:
        """Hold the transforms of a TFMessage: ``static`` ones at every stamp, the others at their header stamps."""
        for t in msg.transforms:
            child, parent = frame_name(t.child_frame_id), frame_name(t.header.frame_id)
            link = (parent, rigid(t.transform.translation, t.transform.rotation, where, f"transform of {child!r}"))
            if static:
                self.static[child] = link
            else:
                self.dynamic.setdefault(child, History(_between_links)).add(header_stamp(t), link)

    def roots(self) -> str:
        """The frames that are a parent and never a child, in name order: the tops of the tf trees; or 'none'."""
        links = [*self.static.values(), *(link for h in self.dynamic.values() for link in h.values)]
        children = {*self.static, *self.dynamic}
        return ", ".join(sorted({parent for parent, _ in links} - children)) or "none"

    def _root(self, frame: str, stamp: float, where: str) -> tuple[str, Rigid, bool]:
        """The farthest ancestor of ``frame`` tf knows at ``stamp``, the frame's pose in it, and whether every
        dynamic transform on the way is held past ``stamp``."""
        pose, covered = IDENTITY, True
        for _ in range(MAX_TF_DEPTH):
            link = self.static.get(frame)
            if link is None and frame in self.dynamic:
                link = self.dynamic[frame].at(stamp)
                covered = covered and self.dynamic[frame].covers(stamp)
            if link is None:
                return frame, pose, covered
            frame, relative = link
            pose = then(relative, pose)
        raise LogError(f"{where}: the tf frames form a loop through {frame!r}")

    def pose(self, frame: str, target: str, stamp: float, where: str) -> Rigid | None:
        """Pose of ``frame`` in ``target`` at ``stamp``, or None if the transforms do not link them then."""
        root, pose, _ = self._root(frame, stamp, where)
        target_root, target_pose, _ = self._root(target, stamp, where)
        return then(inverse(target_pose), pose) if root == target_root else None

    def covers(self, frame: str, target: str, stamp: float, where: str) -> bool:
        """Whether every dynamic transform between ``frame`` and ``target`` is held at or after ``stamp``: their
        pose there is interpolated, no later transform can change it."""
        return self._root(frame, stamp, where)[2] and self._root(target, stamp, where)[2]

    def mount(self, frame: str, base: str, stamp: float, where: str, bag_has_tf: bool) -> Rigid | None:
        """Pose of a sensor's ``frame`` on the robot's ``base`` at ``stamp``; None if tf links them only later.

        The robot's centre in a bag without tf; a LogError if tf never linked them.
        """
        pose = self.pose(frame, base, stamp, where)
        if pose is not None or not bag_has_tf:
            return IDENTITY if pose is None else pose
        if self.pose(frame, base, np.inf, where) is not None:
            return None
        raise LogError(
            f"{where}: tf does not link the frame {frame!r} to the robot's frame {base!r} "
            "(neither /tf nor /tf_static has a chain between them)"
        )


def _between_links(a: tuple[str, Rigid], b: tuple[str, Rigid], s: float) -> tuple[str, Rigid]:
    """A dynamic transform between two of a child frame: blended if both have the same parent, else the first."""
    return (a[0], blend(a[1], b[1], s)) if a[0] == b[0] else a
