"""g2o pose-graph files with laser scans, as the MIT Killian Court data set: VERTEX_SE2 poses + ROBOTLASER1 lines.

A ``ROBOTLASER1`` line (CARMEN format, see :func:`evmap.sources.logs.carmen.robotlaser1`)
belongs to the ``VERTEX_SE2 id x y theta`` line before it: the vertex is the
robot's (optimised) pose, and the laser sits on the robot as the line's laser pose
sits relative to its robot pose. So the scan's world pose is
``vertex ⊕ (robot_pose⁻¹ ⊕ laser_pose)``. Edges (``EDGE_SE2``), ``FIX`` and other
lines are skipped; one record per ROBOTLASER1 line, in file order.

Checks, each a :class:`~evmap.sources.logs.scan.LogError` naming the file and
line: a VERTEX_SE2 without four fields or with a non-finite pose, a ROBOTLASER1
line before any vertex, and every check of the ROBOTLASER1 reader.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "tiny.g2o"
>>> _ = path.write_text("VERTEX_SE2 0 5.0 1.0 0.0\\nROBOTLASER1 0 -0.1 0.2 0.1 50 0.01 0 3 1 2 3 0 "
...     "10.2 0 0 10 0 0 0 0 0 0 0 7.0 host 7.0\\n")
>>> [(r.scan.pose.round(6).tolist(), r.robot_pose.tolist()) for r in read_g2o(path)]
[([5.2, 1.0, 0.0], [5.0, 1.0, 0.0])]
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from evmap.sources.logs.carmen import robotlaser1, text_lines
from evmap.sources.logs.scan import UNITS, Log, LogError, LogRecord, Unit, check_pose, compose, relative

__all__ = ["read_g2o"]


def read_g2o(path: str | Path, unit: Unit = "m") -> Log:
    """The laser scans of a g2o file at their vertices' poses, as a stream of records (see the module doc)."""
    if unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {unit!r}")
    return Log(str(path), lambda: _records(Path(path), unit))


def _records(path: Path, unit: Unit) -> Iterator[LogRecord]:
    vertex = None
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
        elif words[0] == "ROBOTLASER1":
            if vertex is None:
                raise LogError(f"{where}: ROBOTLASER1 before any VERTEX_SE2: no pose to attach the scan to")
            scan, robot = robotlaser1(words, where, unit)
            laser = compose(vertex, relative(robot, scan.pose))
            yield LogRecord(index, replace(scan, pose=laser), vertex)
            index += 1
