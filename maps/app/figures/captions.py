"""Pieces of figure titles: which poses a figure shows, what makes its RCDs, how many of each type.

The numbers a figure states are part of its title (tests read them back and
compare them with ``report.json``).
"""

from __future__ import annotations

from evmap.maps.app.figures.runs import check_pose
from evmap.maps.app.figures.style import TYPE_COLOURS
from evmap.maps.app.run import Run
from evmap.sources.params import RcdParams
from evmap.sources.rcd import TYPE_NAMES, Rcds

__all__ = ["every_pose", "pose_of", "pose_span", "tolerance", "type_counts"]


def pose_of(run: Run, pose: int) -> str:
    """One pose among the run's: ``pose 1 of 3`` (``pose 0`` for a run of one pose)."""
    check_pose(run, pose)
    n = len(run.observations)
    return f"pose {pose} of {n}" if n > 1 else f"pose {pose}"


def pose_span(run: Run, pose: int | None) -> str:
    """What a figure of segments shows: one pose (:func:`pose_of`), or every pose (``None``): :func:`every_pose`."""
    if pose is not None:
        return pose_of(run, pose)
    return "pose 0" if len(run.observations) == 1 else every_pose(run)


def every_pose(run: Run) -> str:
    """``both poses``, ``all 3 poses``."""
    n = len(run.observations)
    return "both poses" if n == 2 else f"all {n} poses"


def tolerance(params: RcdParams) -> str:
    """What makes an RCD under ``params``: ``of readings within 1 cm over at least 10°``."""
    return f"of readings within {params.range_tolerance * 100:g} cm over at least {params.min_width_deg:g}°"


def type_counts(rcds: Rcds) -> str:
    """RCDs by type: ``3 I, 5 II, 2 III, 1 IV``."""
    return ", ".join(f"{int((rcds.type == t).sum())} {TYPE_NAMES[t]}" for t in TYPE_COLOURS)
