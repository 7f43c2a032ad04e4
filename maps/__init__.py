"""The line-corner belief map and the fusion pipeline that builds it."""

from evmap.maps.belief_map import BeliefMap, Line, MapFileError, Point

__all__ = ["BeliefMap", "Line", "MapFileError", "Point"]
