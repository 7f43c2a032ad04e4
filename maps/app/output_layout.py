"""What evmap's output directories hold and the data of a claim: the marker, the commands' layouts, the error.

The data of :mod:`evmap.maps.app.staging` (import these names from there or from here).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["COMPARE_LAYOUT", "MARKER", "MIN_FREE_BYTES", "RUN_LAYOUT", "Layout", "OutputError", "Staging"]

MARKER = ".evmap-out"
"""The file evmap puts into every output directory it makes: JSON ``{"command": ..., "files": [...]}``."""

MIN_FREE_BYTES = 16 * 2**20
"""Free space ``--out``'s file system needs before a run starts (more when the command says so)."""


class OutputError(ValueError):
    """``--out`` cannot receive the run; the message names the directory and what is wrong."""


@dataclass(frozen=True)
class Layout:
    """What a command wrote into its output directory before evmap marked them (``docs/SCENARIO.md``).

    Attributes
    ----------
    command : the ``evmap`` subcommand.
    required : files every such directory has.
    patterns : ``fnmatch`` patterns of the other files at its top level.
    subdirs : a sub-directory name -> the pattern of the files it holds.
    """

    command: str
    required: tuple[str, ...]
    patterns: tuple[str, ...] = ()
    subdirs: dict[str, str] = field(default_factory=dict)


RUN_LAYOUT = Layout(
    "run", ("report.json", "segments.json", "map.json"), ("*.png", "*.svg", "*.pdf", "map.pgm", "map.yaml")
)
"""``evmap run``'s and ``evmap log``'s artefacts: the files, the figures in any format, a log's ROS map pair."""

COMPARE_LAYOUT = Layout("compare", ("summary.csv", "worlds.csv", "summary.md"), ("*.png",), {"worlds": "*.yaml"})
"""``evmap compare``'s tables, plots and scenarios."""


@dataclass(frozen=True)
class Staging:
    """A claimed output: write into ``path``; it becomes ``out`` when the ``with`` block ends."""

    out: Path
    path: Path
