"""A spatial index of keyed bounding boxes that changes one object at a time: a uniform grid of cells.

A :class:`SpatialIndex` files each key under the square cells (``cell`` metres
a side) that its box meets; a query gathers the keys of the cells its box meets
and keeps those whose boxes meet it. An insert, move or removal costs the cells
of one box and a query the cells of its box and the keys there: what they
touch, at any size of the index, with nothing ever built anew. A box meeting
more than :data:`WIDE_CELLS` cells is kept apart, in a short list every query
looks through (few objects are that wide), so that no box files too many cells.
The cells and the wide list hold the keys' rows of one array of boxes, which a
query tests the keys it gathers against in one array operation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["CELL", "FEW", "QUERY_PAIRS", "WIDE_CELLS", "Bounds", "SpatialIndex"]

Bounds = tuple[float, float, float, float]
"""A box ``(xmin, ymin, xmax, ymax)``."""

CELL = 2.0
"""The side of a grid cell (metres)."""

WIDE_CELLS = 64
"""A box meeting more cells than this is kept in the wide list instead of the grid."""

QUERY_PAIRS = 1 << 18
"""How many key-box tests :meth:`SpatialIndex.query` of many boxes makes in one array operation, at most about."""

FEW = 32
"""Candidates of a query of one box up to this many are tested one by one, more in one array operation."""


class SpatialIndex:
    """Keys of objects by their bounding boxes ``(xmin, ymin, xmax, ymax)``.

    Examples
    --------
    >>> index = SpatialIndex.from_boxes(["a", "b"], np.array([[0, 0, 1, 1], [5, 5, 6, 6]], dtype=float))
    >>> index.insert("c", (0.5, 0.5, 0.6, 0.6)); index.remove("a")
    >>> sorted(index.query((0, 0, 2, 2))), len(index), index.extent()
    (['c'], 2, (0.0, 0.0, 6.0, 6.0))
    """

    def __init__(self, cell: float = CELL) -> None:
        if not cell > 0:
            raise ValueError(f"cell must be a positive size, got {cell!r}")
        self._cell = float(cell)
        self._boxes: dict[str, Bounds] = {}  # every key's current box
        self._spans: dict[str, list[tuple[int, int]] | None] = {}  # the cells of each key's box, None: wide
        self._rows: dict[str, int] = {}  # every key's row of ``_held``
        self._keys: list[str] = []  # the key of each row (of a freed row, its last)
        self._held = np.zeros((0, 4))  # each row's box, for the queries' array tests
        self._free: list[int] = []  # the rows freed by removals, taken again by inserts
        self._cells: dict[tuple[int, int], set[int]] = {}  # the rows filed under each cell
        self._wide: set[int] = set()  # the rows whose boxes meet too many cells
        self._extent = [math.inf, math.inf, -math.inf, -math.inf]  # grows with the boxes, never shrinks

    @classmethod
    def from_boxes(cls, keys: Sequence[str], boxes: NDArray[np.float64], cell: float = CELL) -> SpatialIndex:
        """The index of many objects at once (``boxes`` (n, 4), one row per key)."""
        index = cls(cell)
        for key, box in zip(keys, np.asarray(boxes, dtype=float).reshape(-1, 4).tolist(), strict=True):
            index.insert(key, box)
        return index

    def __len__(self) -> int:
        return len(self._boxes)

    def __contains__(self, key: object) -> bool:
        return key in self._boxes

    def insert(self, key: str, bounds: Bounds) -> None:
        """Add ``key`` with its bounding box (a key already present is moved)."""
        box = (float(bounds[0]), float(bounds[1]), float(bounds[2]), float(bounds[3]))
        if key in self._boxes:
            if self._boxes[key] == box:
                return  # where it is already
            self.remove(key)
        self._boxes[key] = box
        e = self._extent
        if box[0] < e[0] or box[1] < e[1] or box[2] > e[2] or box[3] > e[3]:  # the extent grows
            self._extent = [min(e[0], box[0]), min(e[1], box[1]), max(e[2], box[2]), max(e[3], box[3])]
        row = self._row_for(key, box)
        cells = self._spans[key] = self._span(box)
        if cells is None:
            self._wide.add(row)
            return
        for cell in cells:
            self._cells.setdefault(cell, set()).add(row)

    def remove(self, key: str) -> None:
        """Forget ``key`` (a KeyError if it is not there)."""
        del self._boxes[key]
        row = self._rows.pop(key)
        self._free.append(row)
        cells = self._spans.pop(key)
        if cells is None:
            self._wide.discard(row)
            return
        for cell in cells:
            rows = self._cells[cell]
            rows.discard(row)
            if not rows:
                del self._cells[cell]

    def query(self, bounds: Bounds | NDArray[np.float64]) -> set[str]:
        """The keys whose boxes meet the box ``bounds`` (edges touching count), or one of the boxes of an (n, 4)
        array (the union of a query of each, each key tested once against all the boxes in one array operation).

        >>> index = SpatialIndex.from_boxes(["a", "b", "c"], np.array([[0, 0, 1, 1], [5, 5, 6, 6], [9, 9, 9, 9]]))
        >>> sorted(index.query(np.array([[0.5, 0.5, 0.6, 0.6], [6, 6, 7, 7]])))
        ['a', 'b']
        """
        if isinstance(bounds, np.ndarray) and bounds.ndim == 2:
            return self._query_many(bounds)
        xmin, ymin, xmax, ymax = bounds
        cells = self._span(bounds, len(self._cells))
        candidates = set(self._wide)
        for rows in self._cells.values() if cells is None else (self._cells.get(c) for c in cells):
            if rows:
                candidates |= rows
        if len(candidates) > FEW:  # one array test
            found = np.fromiter(candidates, dtype=np.intp, count=len(candidates))
            held = self._held[found]
            meets = (held[:, 0] <= xmax) & (held[:, 2] >= xmin) & (held[:, 1] <= ymax) & (held[:, 3] >= ymin)
            return set(map(self._keys.__getitem__, found[meets].tolist()))
        boxes, keys = self._boxes, [self._keys[row] for row in candidates]
        return {k for k in keys if (b := boxes[k])[0] <= xmax and b[2] >= xmin and b[1] <= ymax and b[3] >= ymin}

    def _query_many(self, boxes: NDArray[np.float64]) -> set[str]:
        """:meth:`query` of the boxes (n, 4)."""
        boxes = boxes.astype(np.float64, copy=False)
        candidates = set(self._wide)
        cells = self._cells
        boxes_to_gather = boxes.tolist()
        if len(boxes) > 1:
            lo, hi = np.floor(boxes[:, :2] / self._cell), np.floor(boxes[:, 2:] / self._cell)
            if np.prod(hi.max(axis=0) - lo.min(axis=0) + 1) <= np.sum(np.prod(hi - lo + 1, axis=1)):
                # the boxes crowd together: the cells of the box holding them all
                boxes_to_gather = [[*boxes[:, :2].min(axis=0).tolist(), *boxes[:, 2:].max(axis=0).tolist()]]
        for box in boxes_to_gather:
            span = self._span(box, len(cells))
            if span is None:
                candidates = set(self._rows.values())
                break
            for cell in span:
                rows = cells.get(cell)
                if rows:
                    candidates |= rows
        if not candidates:
            return set()
        found = np.fromiter(candidates, dtype=np.intp, count=len(candidates))
        held = self._held[found]
        meets = np.zeros(len(found), dtype=bool)
        step = max(1, QUERY_PAIRS // len(found))  # at most about QUERY_PAIRS tests at a time
        for i in range(0, len(boxes), step):
            b = boxes[i : i + step]
            meets |= (
                (held[:, None, 0] <= b[:, 2])
                & (held[:, None, 2] >= b[:, 0])
                & (held[:, None, 1] <= b[:, 3])
                & (held[:, None, 3] >= b[:, 1])
            ).any(axis=1)
        return set(map(self._keys.__getitem__, found[meets].tolist()))

    def _row_for(self, key: str, box: Bounds) -> int:
        """A row of ``_held`` for ``key``, holding its box: a freed one, else a new one (the rows double)."""
        if self._free:
            row = self._free.pop()
            self._keys[row] = key
        else:
            row = len(self._keys)
            self._keys.append(key)
            if row == len(self._held):
                grown = np.zeros((max(64, 2 * row), 4))
                grown[:row] = self._held
                self._held = grown
        self._rows[key] = row
        self._held[row] = box
        return row

    def extent(self) -> Bounds:
        """A box holding every box the index has held (``(inf, inf, -inf, -inf)`` before the first)."""
        return tuple(self._extent)

    def _span(self, box: Bounds, limit: int = WIDE_CELLS) -> list[tuple[int, int]] | None:
        """The cells the box meets, or None if they are more than ``limit`` (or the box is not finite)."""
        if not all(map(math.isfinite, box)):
            return None
        c = self._cell
        i0, j0, i1, j1 = math.floor(box[0] / c), math.floor(box[1] / c), math.floor(box[2] / c), math.floor(box[3] / c)
        if (i1 - i0 + 1) * (j1 - j0 + 1) > limit:
            return None
        return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]
