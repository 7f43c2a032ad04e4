"""Writing a run's artefacts (``docs/SCENARIO.md``) into a directory, all or nothing.

Everything is written into a temporary directory beside the target and moved
into place at the end, so a failed run leaves no directory behind, and an
existing directory is only replaced (with ``force``) once the new one is complete.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from evmap.maps.app.figures import write_figures
from evmap.maps.app.run import Run, report, segment_records

__all__ = ["prepare_out", "write_artefacts"]


def prepare_out(out: str | Path, force: bool) -> Path:
    """Check that ``out`` may receive a run: absent, an empty directory, or ``force``; return it.

    Raises ValueError naming the directory otherwise, before any work starts.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise ValueError(f"--out {out}: directory is not empty (use --force to replace it)")
    return out


def write_artefacts(
    run: Run, out: str | Path, *, force: bool = False, figures: bool = True, figure_format: str = "png"
) -> dict[str, Any]:
    """Write ``report.json``, ``segments.json``, ``map.json`` and the figures (as ``figure_format``) into ``out``;
    return the report."""
    out = prepare_out(out, force)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        summary = report(run)
        (staging / "report.json").write_text(json.dumps(summary, indent=2) + "\n")
        (staging / "segments.json").write_text(json.dumps(segment_records(run)) + "\n")
        run.map.save(staging / "map.json")
        if run.log is not None:  # a map of a robot log: the ROS map_server pair too
            run.map.save_ros_map(staging / "map")
        if figures:
            write_figures(run, staging, figure_format)
        _move_into_place(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return summary


def _move_into_place(staging: Path, out: Path) -> None:
    """Rename the finished staging directory to ``out``, replacing what was there."""
    old = None
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
        os.replace(out, old / out.name)
    os.replace(staging, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
