"""The line-corner belief map and the fusion pipeline that builds it."""

from evmap.maps.belief_map import BeliefMap, new_map
from evmap.maps.map_file import MapFileError
from evmap.maps.planner import Line, Point

__all__ = ["BeliefMap", "Line", "MapFileError", "Point", "new_map"]
