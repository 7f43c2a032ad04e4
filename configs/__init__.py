"""The packaged configuration files: the paper's parameters, worked examples, scenarios."""

from importlib.resources import files
from pathlib import Path

__all__ = ["path"]


def path(name: str) -> Path:
    """Return the path of a packaged config file, e.g. ``path("paper.yaml")``.

    >>> path("paper.yaml").name
    'paper.yaml'
    """
    return Path(str(files(__name__).joinpath(name)))
