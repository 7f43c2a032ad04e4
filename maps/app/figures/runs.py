"""What the figures read from a run: its poses, one pose's observation and outcome, what is known of the truth.

Nothing here draws (no matplotlib). A run may come without a world (measured
data, not a simulation: no true walls) and with the ground truth of its LSL
segments unknown; the figures ask these functions rather than the world.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.maps.app.run import Run
from evmap.maps.observation import Observation
from evmap.maps.pipeline import PoseOutcome
from evmap.sources.sim.world import World

__all__ = ["check_pose", "contour_sensor", "observation", "outcome", "pose_ids", "poses", "truth_known", "world"]

TRUTHS = ("real", "noise")
"""The ground-truth labels of simulated segments; any other value (``""``, ``"unknown"``) means unknown."""


def check_pose(run: Run, pose: int) -> None:
    """Raise ValueError unless ``pose`` is an integer index of the run's poses."""
    n = len(run.observations)
    if isinstance(pose, bool) or not isinstance(pose, int | np.integer) or not 0 <= pose < n:
        raise ValueError(f"pose must be an integer index in [0, {n}), the run's poses; got {pose!r}")


def contour_sensor(run: Run) -> str:
    """What gave the run's contour segments, as the figures name it: ``"laser"`` for a robot log, else ``"LSL"``."""
    return "LSL" if run.log is None else "laser"


def observation(run: Run, pose: int) -> Observation:
    """The observation made from pose ``pose`` (checked)."""
    check_pose(run, pose)
    return run.observations[pose]


def outcome(run: Run, pose: int) -> PoseOutcome:
    """What the map update of pose ``pose`` did (checked)."""
    check_pose(run, pose)
    return run.outcomes[pose]


def poses(run: Run) -> NDArray[np.float64]:
    """(P, 3) x, y (m) and heading (rad) of every pose of the run, from its observations."""
    return np.array([obs.pose for obs in run.observations], dtype=float).reshape(-1, 3)


def pose_ids(run: Run, pose: int | None) -> NDArray[np.intp]:
    """Ids (rows of the map's segment store) of the LSL segments of one pose, or of every pose (``None``): the
    raw segments, as report.json and segments.json count them, never a line's consolidated support."""
    if pose is None:
        return np.flatnonzero(run.map.segments.raw)
    return outcome(run, pose).segments


def truth_known(truth: ArrayLike) -> bool:
    """Whether every segment's ground truth is known (``real`` or ``noise``), as in a simulated run."""
    return bool(np.isin(np.asarray(truth), TRUTHS).all())


def world(run: Run) -> World | None:
    """The simulated world of the run, or None for measured data (no true walls, no sunlight regions)."""
    return run.world
