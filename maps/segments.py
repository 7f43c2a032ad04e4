"""The raw LSL segments behind a belief map, with their noise-elimination evidence.

Every line of the map is made of raw segments (section III: merging), and a
segment's relation to the open space can change when a later pose adds open
space, so the map keeps them all: where they are, which pose saw them, their
relation to the open space, their fused mass of the noise-elimination stage,
whether they were eliminated, and the map line they belong to. Arrays, one row
a segment, appended to as observations arrive; ``to_json`` / ``from_json``
carry them in ``map.json``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evidential import Frame

__all__ = ["SegmentStore"]


@dataclass(eq=False)
class SegmentStore:
    """Raw segments, one row each; ids are row numbers.

    Attributes
    ----------
    p, q : (N, 2) end points.
    pose : (N,) index of the pose that saw the segment.
    truth : (N,) ground truth of a simulated segment, ``"real"`` or ``"noise"`` (``""`` if unknown).
    relation : (N,) ``outside | partly_inside | inside`` against the map's open space.
    mass : (N, 2**n) fused mass of the noise-elimination stage (columns by bitmask).
    conflict : (N,) K between the noise-elimination stage's sources.
    eliminated : (N,) removed as noise.
    line : (N,) id of the map line the segment belongs to (``""`` if eliminated).
    """

    p: NDArray[np.float64]
    q: NDArray[np.float64]
    pose: NDArray[np.intp]
    truth: NDArray[np.str_]
    relation: NDArray[np.str_]
    mass: NDArray[np.float64]
    conflict: NDArray[np.float64]
    eliminated: NDArray[np.bool_]
    line: NDArray[np.object_]

    @classmethod
    def empty(cls, frame: Frame) -> SegmentStore:
        """A store with no segments, for masses over ``frame``.

        >>> len(SegmentStore.empty(Frame(["real", "noise"])))
        0
        """
        return cls(
            p=np.zeros((0, 2)),
            q=np.zeros((0, 2)),
            pose=np.zeros(0, dtype=np.intp),
            truth=np.zeros(0, dtype="<U5"),
            relation=np.zeros(0, dtype="<U13"),
            mass=np.zeros((0, 1 << len(frame))),
            conflict=np.zeros(0),
            eliminated=np.zeros(0, dtype=bool),
            line=np.zeros(0, dtype=object),
        )

    def __len__(self) -> int:
        return len(self.p)

    @property
    def length(self) -> NDArray[np.float64]:
        """(N,) segment lengths."""
        return np.hypot(*(self.q - self.p).T)

    def append(self, p: NDArray[np.float64], q: NDArray[np.float64], pose: NDArray[np.intp], truth: NDArray[np.str_]) -> NDArray[np.intp]:
        """Add segments, not yet judged (relation ``""``, zero mass); return their ids."""
        k = len(p)
        start = len(self)
        self.p = np.concatenate([self.p, p])
        self.q = np.concatenate([self.q, q])
        self.pose = np.concatenate([self.pose, pose]).astype(np.intp)
        self.truth = np.concatenate([self.truth, truth]).astype("<U5")
        self.relation = np.concatenate([self.relation, np.full(k, "", dtype="<U13")])
        self.mass = np.concatenate([self.mass, np.zeros((k, self.mass.shape[1]))])
        self.conflict = np.concatenate([self.conflict, np.zeros(k)])
        self.eliminated = np.concatenate([self.eliminated, np.zeros(k, dtype=bool)])
        self.line = np.concatenate([self.line, np.full(k, "", dtype=object)])
        return np.arange(start, start + k)

    def near(self, bounds: tuple[float, float, float, float]) -> NDArray[np.intp]:
        """Ids of the segments whose bounding boxes meet ``bounds`` = (xmin, ymin, xmax, ymax)."""
        xmin, ymin, xmax, ymax = bounds
        lo = np.minimum(self.p, self.q)
        hi = np.maximum(self.p, self.q)
        hit = (lo[:, 0] <= xmax) & (hi[:, 0] >= xmin) & (lo[:, 1] <= ymax) & (hi[:, 1] >= ymin)
        return np.flatnonzero(hit)

    def to_json(self) -> dict[str, Any]:
        """The store as JSON-able lists (floats round-trip exactly)."""
        return {f.name: getattr(self, f.name).tolist() for f in fields(self)}

    @classmethod
    def from_json(cls, data: dict[str, Any], frame: Frame) -> SegmentStore:
        """The store written by :meth:`to_json`; a ValueError names a missing or malformed column.

        >>> frame = Frame(["real", "noise"])
        >>> store = SegmentStore.empty(frame)
        >>> ids = store.append(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]]), np.array([0]), np.array(["real"]))
        >>> SegmentStore.from_json(store.to_json(), frame).q.tolist()
        [[1.0, 0.0]]
        """
        empty = cls.empty(frame)
        columns = {}
        for f in fields(cls):
            if not isinstance(data, dict) or f.name not in data:
                raise ValueError(f"segments: column {f.name!r} is missing")
            template = getattr(empty, f.name)
            try:
                column = np.array(data[f.name], dtype=template.dtype)
                if len(column) == 0:
                    column = column.reshape(template.shape)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"segments.{f.name}: {exc}") from None
            if column.shape[1:] != template.shape[1:]:
                raise ValueError(f"segments.{f.name}: rows of shape {template.shape[1:]} expected, got {column.shape[1:]}")
            columns[f.name] = column
        lengths = {name: len(c) for name, c in columns.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"segments: columns of different lengths {lengths}")
        return cls(**columns)
