"""``evmap compare``: combination rules and configs compared on many generated worlds with ground truth.

The parts, by concern: :mod:`~evmap.maps.app.compare_configs` (which configs),
:mod:`~evmap.maps.app.compare_metrics` (one world: the configs and rules fused
on the same scans, the figures of each map), :mod:`~evmap.maps.app.compare_hazards`
(what a planner would trip on),
:mod:`~evmap.maps.app.compare_runner` (many worlds, in parallel with Dask),
:mod:`~evmap.maps.app.compare_tables` (the running summary, CSV and Markdown),
:mod:`~evmap.maps.app.compare_plots`, and the command's arguments
(:mod:`~evmap.maps.app.compare_args`). This module is the command
(:func:`compare_command`); import the parts' names from the parts.

The command claims ``--out`` first (:mod:`evmap.maps.app.staging`), then streams:
each world's rows go to ``worlds.csv`` and its scenario to ``worlds/`` as it is
done, the summary is updated world by world, and the tables and plots are
written at the end; the directory appears only when everything is written.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from evmap.maps.app.compare_runner import check_rules, check_run, iter_results
from evmap.maps.app.compare_tables import (
    WORLD_COLUMNS,
    Comparison,
    Tally,
    WorldsWriter,
    summary_markdown,
    write_csv,
    write_summary,
)
from evmap.maps.app.output_layout import COMPARE_LAYOUT, MIN_FREE_BYTES
from evmap.maps.app.staging import claim_output
from evmap.maps.app.termination import Terminated

__all__ = ["BYTES_PER_WORLD", "compare_command", "write_comparison"]

BYTES_PER_WORLD = 8192
"""Disk space a world's rows and scenario take at most, for the free-space check before the run."""


def write_comparison(comparison: Comparison, out: str | Path) -> None:
    """Write a gathered comparison's files (``summary.csv``, ``worlds.csv``, ``summary.md``, plots, ``worlds/``).

    ``out`` must exist; ``comparison`` must hold its rows and scenarios (:func:`run_comparison`).
    """
    from evmap.maps.app.compare_plots import write_plots  # matplotlib: only once there is something to plot

    out = Path(out)
    write_csv(out / "worlds.csv", WORLD_COLUMNS, comparison.rows)
    (out / "worlds").mkdir()
    for name, text in comparison.scenarios.items():
        (out / "worlds" / f"{name}.yaml").write_text(text)
    write_summary(comparison, out)
    write_plots(comparison, out)


def compare_command(args: argparse.Namespace) -> int:
    """``evmap compare``: claim ``--out``, stream the comparison into it, print the summary table.

    Returns 0; 130 after Ctrl-C, 143 after SIGTERM (the workers shut down, nothing written). Raises
    ValueError (``evmap: error: ...``, exit 2) on bad input or output, before the work.
    """
    rules = check_rules(args.rules)
    configs = check_run(args.worlds, args.seed, args.workers, args.configs or args.config, args.scheduler)
    space = MIN_FREE_BYTES + BYTES_PER_WORLD * args.worlds
    try:
        with claim_output(args.out, force=args.force, layout=COMPARE_LAYOUT, free_bytes=space) as staging:
            tally = Tally(configs, rules)
            with WorldsWriter(staging.path) as writer:
                for result in iter_results(
                    rules,
                    args.worlds,
                    args.seed,
                    configs=configs,
                    scheduler=args.scheduler,
                    workers=args.workers,
                    progress=not args.quiet,
                ):
                    tally.add(result)
                    writer.add(result)
            comparison = tally.comparison(args.seed)
            from evmap.maps.app.compare_plots import write_plots  # matplotlib: not before the worlds are done

            write_summary(comparison, staging.path)
            write_plots(comparison, staging.path)
    except (KeyboardInterrupt, Terminated) as stop:
        how, status = ("terminated", 143) if isinstance(stop, Terminated) else ("interrupted", 130)
        print(f"evmap: {how}; nothing written to {args.out}", file=sys.stderr)
        return status
    print(summary_markdown(comparison), end="")
    print(f"written to {args.out}", file=sys.stderr)
    return 0
