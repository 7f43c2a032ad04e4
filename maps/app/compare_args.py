"""The ``evmap compare`` command's arguments: what the command line parses before it imports the comparison."""

from __future__ import annotations

import argparse
from collections.abc import Callable

__all__ = ["DEFAULT_RULES", "SYNCHRONOUS_BELOW", "add_compare_parser"]

DEFAULT_RULES = ("dempster", "yager", "dubois_prade", "pcr6", "murphy", "bayes")
"""The rules ``evmap compare`` runs when ``--rules`` is not given."""

SYNCHRONOUS_BELOW = 8
"""With the default scheduler, fewer worlds than this run in this process (a local cluster takes seconds to start)."""


def add_compare_parser(
    subparsers: argparse._SubParsersAction, handler: Callable[[argparse.Namespace], int]
) -> argparse.ArgumentParser:
    """Register ``compare`` on ``subparsers`` (``evmap``'s commands) with its ``handler`` (the command line's
    :func:`evmap.maps.app.cli.compare_command`, which imports the comparison when it runs).

    >>> parser = argparse.ArgumentParser(prog="evmap")
    >>> _ = add_compare_parser(parser.add_subparsers(), handler=print)
    >>> args = parser.parse_args(["compare", "--out", "x", "--worlds", "3"])
    >>> args.handler is print, args.rules, args.worlds, args.seed
    (True, 'dempster,yager,dubois_prade,pcr6,murphy,bayes', 3, 0)
    """
    compare = subparsers.add_parser(
        "compare",
        help="compare combination rules on generated worlds with ground truth",
        description="Run every rule (and config) on every generated world with the same scans; "
        "write tables, per-world rows and plots.",
    )
    compare.add_argument(
        "--rules", default=",".join(DEFAULT_RULES), help="comma-separated rule names (default: %(default)s)"
    )
    compare.add_argument("--worlds", type=int, default=20, help="number of generated worlds (default: %(default)s)")
    compare.add_argument("--seed", type=int, default=0, help="seed of the experiment (default: %(default)s)")
    compare.add_argument("--out", required=True, help="output directory: must not exist or be empty (see --force)")
    compare.add_argument("--force", action="store_true", help="replace --out if evmap wrote it")
    which = compare.add_mutually_exclusive_group()
    which.add_argument(
        "--config",
        default="default",
        help="config file, or a packaged config by name: default (the default: the evidence beyond the paper), "
        "paper (the paper's method)",
    )
    which.add_argument(
        "--configs",
        help="comma-separated configs to compare, each a file, a packaged name, BASE+SOURCE (BASE with a "
        "noise-elimination source of the default config added, e.g. paper+contour_free), or 'ablation' "
        "(paper, paper plus each new source, default); one row per config and rule; summary.md compares each "
        "with the first config and first rule, world by world",
    )
    compare.add_argument(
        "--scheduler",
        help="address of a Dask scheduler, or synchronous|threads|processes (default: a local cluster, "
        f"in this process below {SYNCHRONOUS_BELOW} worlds unless --workers is given)",
    )
    compare.add_argument(
        "--workers",
        type=int,
        help="processes of the local cluster, or threads|processes of a pool (default: one per CPU); "
        "refused with synchronous or a scheduler's address",
    )
    compare.add_argument("--quiet", action="store_true", help="no progress bar")
    compare.set_defaults(handler=handler)
    return compare
