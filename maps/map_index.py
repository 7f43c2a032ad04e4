"""The spatial indexes of a map's points, lines and unidentified points, kept up to date one change at a time.

:class:`MapIndex` reads the graph (points by id with ``xy`` and ``kind``) and the
lines (id -> end points) it is given, makes its three
:class:`~evmap.maps.spatial.SpatialIndex` from them on first use, then follows
each change the map tells it of.

>>> from evmap.maps.map_graph import MapGraph
>>> g = MapGraph(); g.add_node("A", xy=(0.0, 0.0), kind="corner"); g.add_node("B", xy=(4.0, 0.0), kind="endpoint")
>>> g.add_edge("A", "B"); lines = {"L1": ("A", "B")}
>>> index = MapIndex(g, lines)
>>> sorted(index.near((3.5, -0.5, 4.5, 0.5))), sorted(index.near((1, -1, 2, 1), "lines")), index.extent()
(['B', 'L1'], ['L1'], (0.0, 0.0, 4.0, 0.0))
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from evmap.maps.map_graph import MapGraph
from evmap.maps.spatial import Bounds, SpatialIndex

__all__ = ["POINT_CELL", "MapIndex"]

POINT_CELL = 0.5
"""The grid cell (metres) of the points' indexes: finer than the lines' (a point's box is a point, and the
rebuilds look for points within a few centimetres of line ends, where clutter packs many corners)."""


class MapIndex:
    """Indexes of the points, lines and unidentified points (``targets``) of a graph and its lines."""

    def __init__(self, graph: MapGraph, lines: Mapping[str, tuple[str, str]]) -> None:
        self._graph = graph
        self._lines = lines
        self._indexes: dict[str, SpatialIndex] | None = None  # made on first use

    def near(self, bounds: Bounds | NDArray[np.float64], what: str = "all") -> set[str]:
        """Ids of the ``"points"``, ``"lines"``, ``"obstacles"`` (lines and unidentified points) or ``"all"``
        whose bounding boxes meet the box ``bounds`` (xmin, ymin, xmax, ymax), or one of the boxes of an (n, 4)
        array (:meth:`~evmap.maps.spatial.SpatialIndex.query`: one pass however many the boxes)."""
        if what not in ("all", "obstacles", "points", "lines"):
            raise ValueError(f"what must be 'points', 'lines', 'obstacles' or 'all', got {what!r}")
        ix = self._made()
        names = {"all": ("points", "lines"), "obstacles": ("lines", "targets")}.get(what, (what,))
        found = [ix[name].query(bounds) for name in names]
        return found[0] | found[1] if len(found) > 1 else found[0]

    def extent(self) -> Bounds:
        """A box holding every point the map has held (``(inf, inf, -inf, -inf)`` before the first)."""
        return self._made()["points"].extent()

    def place_point(self, id: str) -> None:
        """Put the point ``id`` (new, moved or of a new kind) at its place, with its lines if it moved."""
        if self._indexes is None:
            return
        data = self._graph.nodes[id]
        x, y = data["xy"]
        self._indexes["points"].insert(id, (x, y, x, y))
        targets = self._indexes["targets"]
        if data["kind"] == "unidentified":
            targets.insert(id, (x, y, x, y))
        elif id in targets:
            targets.remove(id)

    def place_line(self, id: str) -> None:
        """Put the line ``id`` (new, or one of its ends moved) at its place."""
        if self._indexes is not None:
            u, v = self._lines[id]
            (x0, y0), (x1, y1) = self._graph.nodes[u]["xy"], self._graph.nodes[v]["xy"]
            self._indexes["lines"].insert(id, (min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)))

    def remove_point(self, id: str) -> None:
        """Forget the point ``id``."""
        if self._indexes is not None:
            self._indexes["points"].remove(id)
            if id in self._indexes["targets"]:
                self._indexes["targets"].remove(id)

    def remove_line(self, id: str) -> None:
        """Forget the line ``id``."""
        if self._indexes is not None:
            self._indexes["lines"].remove(id)

    def reset(self) -> None:
        """Forget the indexes: they are made again from the graph when next used."""
        self._indexes = None

    def _made(self) -> dict[str, SpatialIndex]:
        """The indexes: made from the whole graph on first use, then kept."""
        if self._indexes is None:
            g = self._graph
            ids = list(g)
            xy = np.array([d.get("xy") for d in g.nodes.values()], dtype=np.float64).reshape(-1, 2)
            target = np.array([d.get("kind") == "unidentified" for d in g.nodes.values()], dtype=bool)
            row = dict(zip(ids, range(len(ids)), strict=True))
            ends = np.array([(row[u], row[v]) for u, v in self._lines.values()], dtype=np.intp).reshape(-1, 2)
            p, q = xy[ends[:, 0]], xy[ends[:, 1]]
            points = np.hstack([xy, xy])
            self._indexes = {
                "points": SpatialIndex.from_boxes(ids, points, POINT_CELL),
                "lines": SpatialIndex.from_boxes(list(self._lines), np.hstack([np.minimum(p, q), np.maximum(p, q)])),
                "targets": SpatialIndex.from_boxes(
                    [n for n, t in zip(ids, target.tolist()) if t], points[target], POINT_CELL
                ),
            }
        return self._indexes
