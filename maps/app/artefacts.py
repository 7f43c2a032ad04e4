"""Writing a run's artefacts (``docs/SCENARIO.md``) into a directory, all or nothing.

The directory is claimed and staged by :mod:`evmap.maps.app.staging`: checked
before the work, written beside it, moved into place at the end; ``force``
replaces only a directory evmap wrote.
"""

from __future__ import annotations

import json
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

from evmap.maps.app.figures import write_figures
from evmap.maps.app.output_layout import RUN_LAYOUT, Staging
from evmap.maps.app.run import Run, report, segment_records
from evmap.maps.app.staging import claim_output, write_text_atomic
from evmap.maps.belief_map import BeliefMap
from evmap.maps.occupancy import OccupancyParams, grid_bounds, grid_geometry

__all__ = ["ROS_RESOLUTION", "prepare_out", "ros_resolution", "write_artefacts", "write_staged"]

ROS_RESOLUTION = 0.05
"""The cell size (m) of a robot log's ROS map pair; doubled while the grid would exceed
:attr:`~evmap.maps.occupancy.OccupancyParams.max_cells` (a campus-sized log's: ``map.yaml`` says which)."""


def prepare_out(out: str | Path, force: bool) -> AbstractContextManager[Staging]:
    """Check and claim ``out`` for a run before the work starts (:func:`evmap.maps.app.staging.claim_output`).

    Use as ``with prepare_out(out, force) as staging: ... write_staged(run, staging)``;
    raises :class:`~evmap.maps.app.staging.OutputError` naming the directory if it cannot receive the run.
    """
    return claim_output(out, force=force, layout=RUN_LAYOUT)


def write_staged(run: Run, staging: Staging, *, figures: bool = True, figure_format: str = "png") -> dict[str, Any]:
    """Write ``report.json``, ``segments.json``, ``map.json`` (and for a robot log the ROS ``map.pgm`` +
    ``map.yaml``) and the figures (as ``figure_format``) into the staging; return the report."""
    summary = report(run)
    write_text_atomic(staging.path / "report.json", json.dumps(summary, indent=2) + "\n")
    write_text_atomic(staging.path / "segments.json", json.dumps(segment_records(run)) + "\n")
    run.map.save(staging.path / "map.json", sync=False)  # as the others: the staging appears whole
    if run.log is not None:  # a map of a robot log: the ROS map_server pair too
        run.map.save_ros_map(staging.path / "map", ros_resolution(run.map))
    if figures:
        write_figures(run, staging.path, figure_format)
    return summary


def ros_resolution(bm: BeliefMap) -> float:
    """The finest of :data:`ROS_RESOLUTION` times a power of two whose grid of the map fits ``max_cells``."""
    bounds, resolution = grid_bounds(bm), ROS_RESOLUTION
    while True:
        try:
            grid_geometry(bounds, resolution, OccupancyParams())
            return resolution
        except ValueError:  # more cells than max_cells
            resolution *= 2


def write_artefacts(
    run: Run, out: str | Path, *, force: bool = False, figures: bool = True, figure_format: str = "png"
) -> dict[str, Any]:
    """Write a run's artefacts into ``out``, all or nothing (claim, stage, move); return the report."""
    with prepare_out(out, force) as staging:
        return write_staged(run, staging, figures=figures, figure_format=figure_format)
