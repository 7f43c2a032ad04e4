"""Where a ROS bag's laser was at each scan: poses by odometry or by tf, interpolated at the scan's stamp.

The ROS bag reader (:mod:`~evmap.sources.logs.rosbag`) places each scan at its
header stamp, as tf2 does: by the odometry pose, or each dynamic transform of the
chain, interpolated between the stamps around the scan's (:class:`~evmap.sources.logs.tf.History`).
A laser driver stamps a scan when the sweep begins and publishes it when it ends, so the
poses around its stamp are usually recorded before it; where they are not yet, the scan
waits in :class:`WaitingScans` until a pose past its stamp is read, or
:data:`~evmap.sources.logs.tf.WAIT_SECONDS` of
recording time have passed (it is then placed at the latest pose before its stamp), or
the bag ends.

Examples
--------
>>> from types import SimpleNamespace as NS
>>> from evmap.sources.logs.tf import TfBuffer
>>> places = Places("odometry on /odom", TfBuffer(), bag_has_tf=False, odometry=True)
>>> def odom(x): return NS(child_frame_id="base_link", pose=NS(pose=NS(
...     position=NS(x=x, y=0.0, z=0.0), orientation=NS(x=0.0, y=0.0, z=0.0, w=1.0))))
>>> places.add_odometry(odom(1.0), 1.0, "odom@1"); places.add_odometry(odom(2.0), 2.0, "odom@2")
>>> laser, flipped, robot, base = places.scan("laser", 1.25, "scan@1.25")
>>> robot.tolist(), base, places.covers("laser", 1.25, "scan@1.25"), places.covers("laser", 2.5, "scan@2.5")
([1.25, 0.0, 0.0], 'base_link', True, False)
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evmap.sources.logs.scan import LaserScan
from evmap.sources.logs.tf import (
    WAIT_SECONDS,
    History,
    Rigid,
    TfBuffer,
    blend,
    frame_name,
    laser_pose,
    rigid,
    robot_pose,
    then,
)

__all__ = ["HeldScan", "Places", "WaitingScans"]

Placed = tuple[NDArray[np.float64], bool, NDArray[np.float64], str]
"""The laser's 2D pose, whether it is upside down, the robot's 2D pose and the robot's frame."""


class Places:
    """Where the robot and its laser were at a stamp: by odometry and tf (``odometry``), or by tf alone, from
    ``world_frame`` to ``base_frame``."""

    def __init__(
        self,
        source: str,
        tf: TfBuffer,
        bag_has_tf: bool,
        odometry: bool,
        world_frame: str = "odom",
        base_frame: str = "base_link",
    ) -> None:
        self.source = source
        self.odometry = History(_between_odometry) if odometry else None
        self.tf = tf
        self.bag_has_tf = bag_has_tf
        self.world, self.base = frame_name(world_frame), frame_name(base_frame)

    def add_odometry(self, msg: Any, stamp: float, where: str) -> None:
        """An Odometry message, checked: the robot's frame and 3D pose at its stamp."""
        p = msg.pose.pose
        pose3 = rigid(p.position, p.orientation, where, "odometry pose")
        robot_pose(pose3, where, "odometry pose")  # checked here, naming the message
        assert self.odometry is not None
        self.odometry.add(stamp, (frame_name(msg.child_frame_id), pose3))

    def scan(self, frame: str, stamp: float, where: str) -> Placed | None:
        """Where the laser ``frame`` and the robot were at ``stamp``; None if not known yet."""
        if self.odometry is not None:
            at = self.odometry.at(stamp)
            if at is None:
                return None
            base, robot3 = at
            mount = self.tf.mount(frame, base, stamp, where, self.bag_has_tf)
            if mount is None:
                return None
            laser, flipped = laser_pose(then(robot3, mount), where, frame)
            return laser, flipped, robot_pose(robot3, where, "odometry pose"), base
        placed = self.tf.pose(frame, self.world, stamp, where)
        if placed is None:
            return None
        laser, flipped = laser_pose(placed, where, frame)
        robot3 = self.tf.pose(self.base, self.world, stamp, where)
        if robot3 is None:
            return laser, flipped, laser, frame
        return laser, flipped, robot_pose(robot3, where, f"pose of the robot's frame {self.base!r}"), self.base

    def covers(self, frame: str, stamp: float, where: str) -> bool:
        """Whether the poses read hold one past ``stamp`` for the laser ``frame``: no later message can change
        where :meth:`scan` places it."""
        if self.odometry is None:
            return self.tf.covers(frame, self.world, stamp, where)
        at = self.odometry.at(stamp)
        return at is not None and self.odometry.covers(stamp) and self.tf.covers(frame, at[0], stamp, where)


@dataclass(frozen=True)
class HeldScan:
    """A scan read and not yet placed: the scan, its laser frame, stamp and place in the bag, when it was recorded
    (s), and the range readings of every topic then if a Range message came since the scan before (else None)."""

    scan: LaserScan
    frame: str
    stamp: float
    where: str
    recorded: float
    readings: dict[str, Any] | None


class WaitingScans:
    """The scans read and not yet placed, in the order read: each leaves, in turn, once its pose is known."""

    def __init__(self, places: Places) -> None:
        self.places = places
        self.scans: deque[HeldScan] = deque()

    def add(self, scan: HeldScan) -> None:
        self.scans.append(scan)

    def ready(self, recorded: float | None) -> list[HeldScan]:
        """The scans, from the first, whose poses are known by the messages recorded up to ``recorded`` (s), or
        that have waited :data:`WAIT_SECONDS`; all of them when ``recorded`` is None (the bag ended)."""
        out = []
        while self.scans:
            first = self.scans[0]
            waited = recorded is None or recorded - first.recorded > WAIT_SECONDS
            if not waited and not self.places.covers(first.frame, first.stamp, first.where):
                break
            out.append(self.scans.popleft())
        return out


def _between_odometry(a: tuple[str, Rigid], b: tuple[str, Rigid], s: float) -> tuple[str, Rigid]:
    """An odometry pose between two: blended if both are of the same robot frame, else the first."""
    return (a[0], blend(a[1], b[1], s)) if a[0] == b[0] else a
