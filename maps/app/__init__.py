"""The application: the command line, runs of scenarios, their artefacts, figures and comparisons."""

from __future__ import annotations

import sys

__all__ = ["main"]


def main() -> int:
    """The ``evmap`` console script: :func:`evmap.maps.app.cli.main`, a Ctrl-C while the command line loads
    included (one line and status 130, no traceback)."""
    try:
        from evmap.maps.app.cli import main as command
    except KeyboardInterrupt:
        print("evmap: interrupted", file=sys.stderr)
        return 130
    return command()
