"""The line-corner belief map and the fusion pipeline that builds it.

The public names load on first use, so that ``import evmap.maps.app.cli`` (the
command line) starts without the map's dependencies.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap, new_map
    from evmap.maps.map_format import MapFileError
    from evmap.maps.planner import Line, Point

__all__ = ["BeliefMap", "Line", "MapFileError", "Point", "new_map"]

_HOMES = {
    "BeliefMap": "evmap.maps.belief_map",
    "new_map": "evmap.maps.belief_map",
    "MapFileError": "evmap.maps.map_format",
    "Line": "evmap.maps.planner",
    "Point": "evmap.maps.planner",
}


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'evmap.maps' has no attribute {name!r}")
    value = getattr(import_module(_HOMES[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
