"""SIGTERM as an exception: a command stops on it as on Ctrl-C, cleaning up what it started."""

from __future__ import annotations

__all__ = ["Terminated", "terminate"]


class Terminated(Exception):
    """SIGTERM arrived: the command stops as after Ctrl-C, cleaning up what it started."""


def terminate(signum: int, frame: object) -> None:
    """The SIGTERM handler: raise :class:`Terminated` where the command is."""
    raise Terminated
