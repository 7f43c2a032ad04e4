"""The sonar open space of a map kept in pieces: added to one observation at a time, read near a box.

Every observation's open space is a piece; the union of all of them is made
only when it is read whole (:meth:`OpenSpacePieces.union`), and a spatial index
of the pieces' boxes answers what is near a box at the cost of what is there
(:meth:`OpenSpacePieces.near`): the union of the pieces there (or the pieces themselves,
:meth:`OpenSpacePieces.parts_near`), or, where more
than :data:`MANY` pieces overlap the box (a place the robot passed again and
again), the union of square tiles (:data:`TILE` metres a side) that each keep
the union of what the pieces put in them, kept up to date as pieces come: a
place seen a hundred times costs what a place seen a few times does. The map's
graph attribute ``open_space`` holds the union as GeoJSON-like coordinates,
written whenever the union is made.

>>> import shapely
>>> from evmap.maps.map_graph import MapGraph
>>> space = OpenSpacePieces(MapGraph())
>>> space.add(shapely.box(0, 0, 2, 1)); space.add(shapely.box(1, 0, 3, 1))
>>> round(space.union().area, 6), len(space), space.near((5, 5, 6, 6)).is_empty, len(space.parts_near((0, 0, 1, 1)))
(3.0, 2, True, 2)
>>> space.replace(shapely.box(0, 0, 1, 1)); space.graph.graph["open_space"]["coordinates"]
[[[[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]]]
"""

from __future__ import annotations

import math

import shapely

from evmap.maps import map_json
from evmap.maps.map_graph import MapGraph
from evmap.maps.spatial import Bounds, SpatialIndex
from evmap.sources.open_space import unite

__all__ = ["MANY", "TILE", "OpenSpacePieces"]

MANY = 12
"""A box holding more pieces than this is read from the tiles."""

TILE = 4.0
"""The side of a tile (metres)."""

Tile = tuple[int, int]


class OpenSpacePieces:
    """Pieces whose union is the open space, their boxes' index (made on first use) and their union (when read),
    mirrored in ``graph``'s attribute ``open_space``."""

    def __init__(self, graph: MapGraph) -> None:
        self.graph = graph
        self._pieces: list[shapely.Geometry] = []
        self._index: SpatialIndex | None = None
        self._union: shapely.MultiPolygon | None = shapely.MultiPolygon()  # None: not made since the last change
        self._tiles: dict[Tile, shapely.Geometry] = {}  # the tiles read so far, each the union of its part

    def __len__(self) -> int:
        return len(self._pieces)

    def union(self) -> shapely.MultiPolygon:
        """The union of the pieces, a (possibly empty) MultiPolygon; made once after each change."""
        if self._union is None:
            union = unite(self._pieces)
            self._union = union if isinstance(union, shapely.MultiPolygon) else map_json.as_multipolygon(union)
            self.graph.graph["open_space"] = map_json.geojson(self._union)
        return self._union

    def is_made(self) -> bool:
        """Whether the union is made (reading it costs nothing)."""
        return self._union is not None

    def replace(self, geometry: shapely.Geometry | None) -> None:
        """The open space is ``geometry`` (a Polygon, a MultiPolygon, an empty geometry or None) and nothing else."""
        geometry = map_json.as_multipolygon(geometry)
        self._pieces = list(geometry.geoms)
        self._index = None
        self._tiles = {}
        self._union = geometry
        self.graph.graph["open_space"] = map_json.geojson(geometry)

    def add(self, geometry: shapely.Geometry) -> None:
        """Unite a (Multi)Polygon with the open space."""
        for piece in map_json.as_multipolygon(geometry).geoms:
            if self._index is not None:
                self._index.insert(str(len(self._pieces)), piece.bounds)
            self._pieces.append(piece)
            for tile in _tiles(piece.bounds):
                if tile in self._tiles:
                    part = shapely.intersection(piece, _box(tile))
                    if not part.is_empty:
                        self._tiles[tile] = shapely.union(self._tiles[tile], part)
        self._union = None

    def near(self, bounds: Bounds) -> shapely.Geometry:
        """The open space within the box ``bounds``, and maybe some beyond it; costs what the box holds."""
        parts = self.parts_near(bounds)
        return unite(parts) if parts else shapely.MultiPolygon()

    def parts_near(self, bounds: Bounds) -> list[shapely.Geometry]:
        """Polygons, maybe overlapping, whose union is :meth:`near` (what measures the open space along lines
        needs, without the cost of uniting them)."""
        if self._index is None:
            keys = [str(k) for k in range(len(self._pieces))]
            self._index = SpatialIndex.from_boxes(keys, shapely.bounds(self._pieces))
        keys = self._index.query(bounds)
        if len(keys) > MANY:
            return [self._tile(tile, self._index) for tile in _tiles(bounds)]
        return [self._pieces[int(k)] for k in keys]

    def _tile(self, tile: Tile, index: SpatialIndex) -> shapely.Geometry:
        """The union of the pieces' parts in ``tile`` (found by ``index``), made the first time it is read."""
        if tile not in self._tiles:
            box = _box(tile)
            parts = [shapely.intersection(self._pieces[int(k)], box) for k in index.query(box.bounds)]
            self._tiles[tile] = unite(parts) if parts else shapely.MultiPolygon()
        return self._tiles[tile]

    def truncate(self, count: int, union: shapely.MultiPolygon | None) -> None:
        """Back to the first ``count`` pieces, whose union is ``union`` (None: not made)."""
        del self._pieces[count:]
        self._index = None
        self._tiles = {}
        self._union = union

    def made_union(self) -> shapely.MultiPolygon | None:
        """The union if it is made, else None (what :meth:`truncate` takes back)."""
        return self._union


def _tiles(bounds: Bounds) -> list[Tile]:
    """The tiles a box meets."""
    i0, j0, i1, j1 = (math.floor(v / TILE) for v in bounds)
    return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]


def _box(tile: Tile) -> shapely.Polygon:
    """A tile as a polygon."""
    i, j = tile
    return shapely.box(i * TILE, j * TILE, (i + 1) * TILE, (j + 1) * TILE)
