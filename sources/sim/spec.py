"""What every scenario model shares: the limits on a scenario, strict scalar types, the base model.

The limits are stated in ``docs/SCENARIO.md`` (section *Limits*) and checked before any
work begins (see :mod:`evmap.sources.sim.scenario`). Scalars are strict: a bool is not a
number, a string is not a number, binary data (``!!binary``) is not a string, and a
count must be an integer (``10000.0`` is refused).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, Strict

__all__ = [
    "MAX_COORDINATE",
    "MAX_CYLINDERS",
    "MAX_HEADING_DEG",
    "MAX_PHANTOMS_PER_RUN",
    "MAX_POLYGON_VERTICES",
    "MAX_POSES",
    "MAX_SUNLIGHT_LINES",
    "MAX_SUNLIGHT_LINES_PER_REGION",
    "MAX_SUNLIGHT_REGIONS",
    "MAX_WALL_SEGMENTS",
    "MIN_POSE_CLEARANCE",
    "MIN_SEGMENT_LENGTH",
    "Coordinate",
    "Count",
    "Heading",
    "Number",
    "Point",
    "SpecModel",
    "Text",
]

MAX_WALL_SEGMENTS = 15_000
"""Most wall segments (consecutive point pairs, all polylines together) in a scenario. The sonar model's
memory no longer grows with them (it was their square: 4,000 around a pose needed 2.6 GB); its time grows
with the paths it must try. The worst arrangement found, a zigzag ring of short facets nearly edge-on to
the poses (most readings without a first-order echo, so every second-order path is tried), seen by the
densest sensors from 10 poses, took 38 s and 0.2 GB on a loaded 2-core machine; 20,000 segments took up
to 50 s (``benchmarks/bench_limits.py``)."""
MAX_CYLINDERS = 100
"""Most cylinders in a scenario. The run's figures draw every cylinder in every pose's figures, as one
collection: 1,000 cylinders seen from 10 poses took 27 s with png figures (101 s drawn one by one)."""
MAX_SUNLIGHT_REGIONS = 100
"""Most sunlight regions in a scenario."""
MAX_SUNLIGHT_LINES_PER_REGION = 200
"""Most phantom lines one sunlight region makes per pose."""
MAX_SUNLIGHT_LINES = 400
"""Most phantom lines all sunlight regions together make per pose."""
MAX_PHANTOMS_PER_RUN = 400
"""Most phantom lines over the whole run: poses times the phantom lines of all regions. Every pose's
segments are judged against the readings of all poses, so the cost grows with poses times phantoms:
2,000 phantoms seen from 10 poses took over 100 s under the default config."""
MAX_POLYGON_VERTICES = 100
"""Most vertices of one sunlight polygon (100 regions of 1,000 vertices took over 20 s to load)."""
MAX_POSES = 10
"""Most robot poses in a scenario. Every pose's segments are judged against the open space and readings of
all poses: 50 poses around one sunlit patch took over 150 s under the default config, 20 poses inside a
ring of 1,000 wall segments 46 s."""
MAX_COORDINATE = 1e7
"""Largest absolute x or y (m): any UTM easting or northing."""
MAX_HEADING_DEG = 360.0
"""Largest absolute pose heading (degrees)."""
MIN_SEGMENT_LENGTH = 1e-6
"""Wall segments shorter than this (m) are refused as zero-length."""
MIN_POSE_CLEARANCE = 1e-6
"""A pose closer than this (m) to a wall segment is refused as standing on the wall."""

Number = Annotated[float, Strict()]
"""A finite number: an int or a float, not a bool or a string."""
Count = Annotated[int, Strict()]
"""An integer: not a bool, not a float such as ``10000.0``."""
Text = Annotated[str, Strict()]
"""A string: not a number, not binary data."""
Coordinate = Annotated[float, Strict(), Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
"""An x or y in metres, within :data:`MAX_COORDINATE`."""
Heading = Annotated[float, Strict(), Field(ge=-MAX_HEADING_DEG, le=MAX_HEADING_DEG)]
"""A heading in degrees, within :data:`MAX_HEADING_DEG`."""
Point = tuple[Coordinate, Coordinate]
"""``[x, y]`` in metres."""


class SpecModel(BaseModel):
    """Base of the scenario models: unknown keys refused, immutable, finite numbers only."""

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True, allow_inf_nan=False)
