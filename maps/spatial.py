"""A spatial index of keyed bounding boxes that changes one object at a time: shapely's STRtree plus the changes.

A :class:`SpatialIndex` holds a static :class:`shapely.STRtree` over the boxes
it had when the tree was built, and beside it the few boxes added or moved
since (searched by numpy) and the keys removed since (filtered out). When the
changes outgrow a small share of the tree it is built anew, so a query costs
``O(log n + k)`` and a change costs ``O(1)`` amortised, at any size.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import NDArray

__all__ = ["Bounds", "SpatialIndex"]

Bounds = tuple[float, float, float, float]
"""A box ``(xmin, ymin, xmax, ymax)``."""

REBUILD_SHARE = 0.05
"""The tree is built anew once the changes since it was built outnumber this share of its boxes (and 64)."""


class SpatialIndex:
    """Keys of objects by their bounding boxes ``(xmin, ymin, xmax, ymax)``.

    Examples
    --------
    >>> index = SpatialIndex.from_boxes(["a", "b"], np.array([[0, 0, 1, 1], [5, 5, 6, 6]], dtype=float))
    >>> index.insert("c", (0.5, 0.5, 0.6, 0.6)); index.remove("a")
    >>> sorted(index.query((0, 0, 2, 2))), len(index), index.extent()
    (['c'], 2, (0.0, 0.0, 6.0, 6.0))
    """

    def __init__(self) -> None:
        self._keys: list[str] = []  # of the tree's boxes
        self._tree = shapely.STRtree([])
        self._boxes: dict[str, Bounds] = {}  # every key's current box
        self._fresh: dict[str, Bounds] = {}  # added or moved since the tree was built
        self._stale: set[str] = set()  # in the tree with an old box, or removed
        self._extent = [math.inf, math.inf, -math.inf, -math.inf]  # grows with the boxes, never shrinks

    @classmethod
    def from_boxes(cls, keys: Sequence[str], boxes: NDArray[np.float64]) -> SpatialIndex:
        """The index of many objects at once (``boxes`` (n, 4), one row per key)."""
        index = cls()
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        index._boxes = dict(zip(keys, map(tuple, boxes.tolist()), strict=True))
        if len(boxes):
            index._extent = [*boxes[:, :2].min(axis=0).tolist(), *boxes[:, 2:].max(axis=0).tolist()]
        index._build()
        return index

    def __len__(self) -> int:
        return len(self._boxes)

    def __contains__(self, key: object) -> bool:
        return key in self._boxes

    def insert(self, key: str, bounds: Bounds) -> None:
        """Add ``key`` with its bounding box (a key already present is moved)."""
        if key in self._boxes and key not in self._fresh:
            self._stale.add(key)
        box = self._boxes[key] = self._fresh[key] = tuple(map(float, bounds))
        e = self._extent
        self._extent = [min(e[0], box[0]), min(e[1], box[1]), max(e[2], box[2]), max(e[3], box[3])]
        self._maybe_build()

    def remove(self, key: str) -> None:
        """Forget ``key`` (a KeyError if it is not there)."""
        del self._boxes[key]
        if self._fresh.pop(key, None) is None or key in self._stale:
            self._stale.add(key)
        self._maybe_build()

    def query(self, bounds: Bounds) -> set[str]:
        """The keys whose boxes meet the box ``bounds`` (edges touching count)."""
        xmin, ymin, xmax, ymax = bounds
        found = {self._keys[i] for i in self._tree.query(shapely.box(xmin, ymin, xmax, ymax)).tolist()}
        found -= self._stale
        if self._fresh:
            fresh = list(self._fresh)
            b = np.array(list(self._fresh.values()))
            hit = (b[:, 0] <= xmax) & (b[:, 2] >= xmin) & (b[:, 1] <= ymax) & (b[:, 3] >= ymin)
            found.update(fresh[i] for i in np.flatnonzero(hit).tolist())
        return found

    def extent(self) -> Bounds:
        """A box holding every box the index has held (``(inf, inf, -inf, -inf)`` before the first)."""
        return tuple(self._extent)

    def _maybe_build(self) -> None:
        if len(self._fresh) + len(self._stale) > max(64, REBUILD_SHARE * len(self._keys)):
            self._build()

    def _build(self) -> None:
        self._keys = list(self._boxes)
        b = np.array(list(self._boxes.values()), dtype=float).reshape(-1, 4)
        self._tree = shapely.STRtree(shapely.box(b[:, 0], b[:, 1], b[:, 2], b[:, 3]))
        self._fresh.clear()
        self._stale.clear()
