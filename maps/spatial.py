"""A uniform grid of square cells over objects' bounding boxes, changed one object at a time.

The map changes a little at every observation; a static tree (shapely's STRtree)
would have to be rebuilt from everything after each change. The grid inserts
and removes one object in time proportional to the cells it covers, and answers
"what is near this box" in time proportional to the cells the box covers and
the objects found there, however large the map.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

__all__ = ["GridIndex"]

Bounds = tuple[float, float, float, float]


class GridIndex:
    """Keys of objects by the grid cells their bounding boxes ``(xmin, ymin, xmax, ymax)`` meet.

    >>> grid = GridIndex(cell=1.0)
    >>> grid.insert("wall", (0.0, 0.0, 5.0, 0.0))
    >>> grid.insert("pillar", (7.9, 7.9, 8.1, 8.1))
    >>> sorted(grid.query((4.5, -0.5, 5.5, 0.5))), sorted(grid.query((0, 0, 10, 10)))
    (['wall'], ['pillar', 'wall'])
    >>> grid.remove("wall")
    >>> grid.query((4.5, -0.5, 5.5, 0.5))
    set()
    """

    def __init__(self, cell: float = 1.0) -> None:
        if not cell > 0:
            raise ValueError(f"cell must be a size > 0 (m), got {cell!r}")
        self._cell = float(cell)
        self._cells: dict[tuple[int, int], set[str]] = {}
        self._where: dict[str, list[tuple[int, int]]] = {}

    @classmethod
    def from_boxes(cls, cell: float, keys: Sequence[str], boxes: NDArray[np.float64]) -> GridIndex:
        """The grid of many objects at once: what inserting each ``keys[k]`` with ``boxes[k]`` makes.

        ``keys`` are distinct; ``boxes`` is (n, 4), rows ``(xmin, ymin, xmax, ymax)``.

        >>> grid = GridIndex.from_boxes(1.0, ["wall", "pillar"], np.array([[0, 0, 5, 0], [7.9, 7.9, 8.1, 8.1]]))
        >>> sorted(grid.query((4.5, -0.5, 5.5, 0.5))), len(grid)
        (['wall'], 2)
        """
        grid = cls(cell)
        if not len(keys):
            return grid
        boxes = np.asarray(boxes, dtype=np.float64).reshape(len(keys), 4)
        lo = np.floor(boxes[:, :2] / grid._cell).astype(np.int64)  # as _span computes them, one box at a time
        hi = np.floor(boxes[:, 2:] / grid._cell).astype(np.int64)
        rows = hi[:, 1] - lo[:, 1] + 1
        count = (hi[:, 0] - lo[:, 0] + 1) * rows
        owner = np.repeat(np.arange(len(keys)), count)
        k = np.arange(owner.size) - np.repeat(np.cumsum(count) - count, count)  # each box's cells, i then j
        i, j = lo[owner, 0] + k // rows[owner], lo[owner, 1] + k % rows[owner]
        cells = list(zip(i.tolist(), j.tolist(), strict=True))
        ends = np.cumsum(count).tolist()
        grid._where = {key: cells[a:b] for key, a, b in zip(keys, [0, *ends[:-1]], ends, strict=True)}
        order = np.lexsort((j, i))  # the (box, cell) pairs by cell
        i, j = i[order], j[order]
        starts = np.flatnonzero(np.r_[True, (i[1:] != i[:-1]) | (j[1:] != j[:-1])])
        members = [keys[o] for o in owner[order].tolist()]
        grid._cells = {
            cell: set(members[a:b])
            for cell, (a, b) in zip(
                zip(i[starts].tolist(), j[starts].tolist()), pairwise([*starts.tolist(), order.size]), strict=True
            )
        }
        return grid

    def __len__(self) -> int:
        return len(self._where)

    def __contains__(self, key: object) -> bool:
        return key in self._where

    def insert(self, key: str, bounds: Bounds) -> None:
        """Add ``key`` with its bounding box (a key already present is moved)."""
        if key in self._where:
            self.remove(key)
        cells = list(self._span(bounds))
        for c in cells:
            self._cells.setdefault(c, set()).add(key)
        self._where[key] = cells

    def remove(self, key: str) -> None:
        """Forget ``key`` (a KeyError if it is not there)."""
        for c in self._where.pop(key):
            members = self._cells[c]
            members.discard(key)
            if not members:
                del self._cells[c]

    def query(self, bounds: Bounds) -> set[str]:
        """The keys whose cells meet the cells of ``bounds`` (a superset of the boxes that meet it)."""
        found: set[str] = set()
        for c in self._span(bounds):
            members = self._cells.get(c)
            if members:
                found |= members
        return found

    def _span(self, bounds: Bounds) -> Iterable[tuple[int, int]]:
        xmin, ymin, xmax, ymax = bounds
        s = self._cell
        i0, i1 = math.floor(xmin / s), math.floor(xmax / s)
        j0, j1 = math.floor(ymin / s), math.floor(ymax / s)
        return ((i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1))
