"""The layout of ``map.json``: its schema versions, keys, values and limits, the checked parts of a file, its error.

The data of :mod:`evmap.maps.map_file` (which writes and reads the file) and of
:mod:`evmap.maps.map_reader` (which checks a parsed file); import these names from here. The layout itself is documented in ``docs/SCENARIO.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import shapely

from evidential import Frame
from evmap.maps.segments import SegmentStore
from evmap.sources.loading import InputError

__all__ = [
    "CHECKSUM_KEY",
    "CORNERS_DEFERRED",
    "GRAPH_KEYS",
    "ID_PREFIXES",
    "LINE_KEYS",
    "LINE_KIND",
    "MAX_MAP_BYTES",
    "POINT_KEYS",
    "POINT_KINDS",
    "READABLE_VERSIONS",
    "RELATIONS",
    "SCHEMA_VERSION",
    "TRUTHS",
    "MapFileError",
    "MapParts",
]

SCHEMA_VERSION = 2
"""Version of the ``map.json`` layout that :func:`~evmap.maps.map_file.write_map` writes; :func:`~evmap.maps.map_file.read_map` reads it and version 1."""

READABLE_VERSIONS = (1, 2)
"""The schema versions :func:`~evmap.maps.map_file.read_map` reads (1: segment masses as dense rows)."""

POINT_KINDS = ("corner", "endpoint", "unidentified")
"""The kinds of points (nodes)."""

LINE_KIND = "line"
"""The kind of every line (edge)."""

GRAPH_KEYS = ("schema_version", "frame", "rule", "open_space", "segments")
"""Graph attributes the map itself keeps (no extra attribute may take these names)."""

CORNERS_DEFERRED = "corners_deferred"
"""The graph attribute, ``true`` where present, of a map whose updates without sonar left line ends free that
:meth:`~evmap.maps.belief_map.BeliefMap.join_corners` has not joined into corners since."""

POINT_KEYS = ("id", "xy", "kind", "mass", "history")
"""Attributes of a point the map itself keeps."""

LINE_KEYS = ("id", "kind", "mass", "history", "source", "target")
"""Attributes of a line the map itself keeps."""

ID_PREFIXES = ("L", "C", "E", "U")
"""The prefixes of the ids a map hands out (``graph.next_id``): lines, corners, end points, unidentified."""

TRUTHS = ("real", "noise", "")
"""The values of a segment's ``truth``: the simulator's ground truth, ``""`` where unknown (measured data)."""

RELATIONS = ("", "outside", "partly_inside", "inside")
"""The values of a segment's ``relation`` to the sonar open space (``""``: not judged)."""

MAX_MAP_BYTES = 1024 * 1024 * 1024
"""The largest map file :func:`~evmap.maps.map_file.read_file` reads, and :func:`~evmap.maps.map_file.write_map`
writes (loading takes about 7 times the file's size for a log's map, Freiburg 079's whole log 140 MB -> 994 MB
at its peak, and up to about 17 for a map of many small objects)."""

CHECKSUM_KEY = b'"checksum":"'
"""The last member of a written map file: the SHA-256 of the file without it, in hex."""


class MapFileError(InputError):
    """A map file cannot be read: truncated, of an unknown schema version, or not a map."""


@dataclass(eq=False)
class MapParts:
    """What a map file holds, checked: enough to build the map without another check.

    Attributes
    ----------
    frame, rule : the map's frame and combination rule.
    extras : the other graph attributes (JSON-able).
    segments : the segment store, or None if the file has none.
    open_space : the open space, or None if the file has none.
    nodes : the points' records (``id``, ``xy`` a tuple, ``kind``, ``mass`` a MassFunction, ``history``...).
    edges : the lines' records (``id``, ``kind``, ``mass``, ``history``...), without their ends.
    ends : (u, v) of each line.
    """

    frame: Frame
    rule: str
    extras: dict[str, Any]
    segments: SegmentStore | None
    open_space: shapely.MultiPolygon | None
    nodes: list[dict[str, Any]]
    edges: list[dict[str, Any]]
    ends: list[tuple[str, str]]
