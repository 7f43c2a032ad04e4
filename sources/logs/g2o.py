"""g2o pose-graph files with laser scans, as the MIT Killian Court data set: VERTEX_SE2 poses + ROBOTLASER1 lines.

A ``ROBOTLASER1`` line (CARMEN format, see :func:`evmap.sources.logs.carmen.robotlaser1`)
belongs to the ``VERTEX_SE2 id x y theta`` line before it: the vertex is the
robot's (optimised) pose, and the laser sits on the robot as the line's laser pose
sits relative to its robot pose. So the scan's world pose is
``vertex ⊕ (robot_pose⁻¹ ⊕ laser_pose)``. Edges (``EDGE_SE2``), ``FIX`` and other
lines are skipped; one record per ROBOTLASER1 line, in file order.

Checks, each a :class:`~evmap.sources.logs.scan.LogError` naming the file and
line: a VERTEX_SE2 without four fields or with a non-finite pose, a ROBOTLASER1
line before any vertex, a ROBOTLASER1 line whose robot pose lies more than
:data:`MAX_MOVE_AT_VERTEX` from that of the first scan at the same vertex (the
robot moved between them, so one vertex cannot be the pose of both: a file whose
scans do not follow their vertices, e.g. every vertex first and then every scan),
and every check of the ROBOTLASER1 reader.

Examples
--------
>>> import tempfile, pathlib
>>> tmp = tempfile.TemporaryDirectory()
>>> path = pathlib.Path(tmp.name) / "tiny.g2o"
>>> _ = path.write_text("VERTEX_SE2 0 5.0 1.0 0.0\\nROBOTLASER1 0 -0.1 0.2 0.1 50 0.01 0 3 1 2 3 0 "
...     "10.2 0 0 10 0 0 0 0 0 0 0 7.0 host 7.0\\n")
>>> [(r.scan.pose.round(6).tolist(), r.robot_pose.tolist()) for r in read_g2o(path)]
[([5.2, 1.0, 0.0], [5.0, 1.0, 0.0])]
>>> tmp.cleanup()
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from evmap.sources.logs.carmen import robotlaser1, text_lines
from evmap.sources.logs.scan import UNITS, Log, LogError, LogRecord, Unit, check_pose, compose, relative

__all__ = ["MAX_MOVE_AT_VERTEX", "read_g2o"]

MAX_MOVE_AT_VERTEX = 0.5
"""How far (m) the robot poses of the ROBOTLASER1 lines at one vertex may lie apart."""


def read_g2o(path: str | Path, unit: Unit = "m") -> Log:
    """The laser scans of a g2o file at their vertices' poses, as a stream of records (see the module doc)."""
    if unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {unit!r}")
    return Log(str(path), lambda: _records(Path(path), unit))


def _records(path: Path, unit: Unit) -> Iterator[LogRecord]:
    vertex = None
    first_robot = None  # the robot pose of the first scan at the vertex
    index = 0
    for number, line in text_lines(path):
        words = line.split()
        where = f"{path}:{number}"
        if not words:
            continue
        if words[0] == "VERTEX_SE2":
            if len(words) != 5:
                raise LogError(f"{where}: VERTEX_SE2 needs an id and x y theta, got {len(words) - 1} fields")
            try:
                values = np.array(words[2:5], dtype=float)
            except ValueError:
                raise LogError(f"{where}: VERTEX_SE2 pose {' '.join(words[2:5])!r} is not three numbers") from None
            vertex = check_pose(values, where, "vertex pose")
            vertex_line, first_robot = number, None
        elif words[0] == "ROBOTLASER1":
            if vertex is None:
                raise LogError(f"{where}: ROBOTLASER1 before any VERTEX_SE2: no pose to attach the scan to")
            scan, robot = robotlaser1(words, where, unit)
            if first_robot is None:
                first_robot = robot
            elif (moved := float(np.hypot(*(robot[:2] - first_robot[:2])))) > MAX_MOVE_AT_VERTEX:
                raise LogError(
                    f"{where}: ROBOTLASER1 robot pose {moved:.2f} m from that of the first scan at the VERTEX_SE2 of "
                    f"line {vertex_line} (more than {MAX_MOVE_AT_VERTEX} m): the scans do not follow their vertices"
                )
            laser = compose(vertex, relative(robot, scan.pose))
            yield LogRecord(index, replace(scan, pose=laser), vertex)
            index += 1
