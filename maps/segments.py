"""The raw LSL segments behind a belief map, with their noise-elimination evidence.

Every line of the map is made of raw segments (section III: merging), and a
segment's relation to the open space can change when a later pose adds open
space, so the map keeps them all: where they are, which pose saw them, their
relation to the open space, their fused mass of the noise-elimination stage,
whether they were eliminated, the map line they belong to, and any further
per-segment features an observation brought for the config's sources. Columns
are numpy arrays, one row a segment; appending is amortised O(rows added), so
an observation costs the same however many segments the map already holds.
``to_json`` / ``from_json`` carry the store in ``map.json``.

A line seen from many poses would gather raw segments without end, and every
rebuild near it would merge them all again. So a line seen from more than
:data:`CONSOLIDATE_POSES` poses is consolidated (:meth:`SegmentStore.consolidate`):
its merged support, one row of ``role`` ``"support"`` that stands for the
``seen`` poses behind it, replaces its members in the rebuilds; the members stay
in the store (``role`` ``"absorbed"``, still naming the line they were absorbed
into, their verdict the one they last had) but leave :meth:`SegmentStore.near`.
Raw segments have ``role`` ``""`` and ``seen`` 1."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential import Frame
from evmap.maps.spatial import SpatialIndex

__all__ = ["COLUMNS", "CONSOLIDATE_POSES", "OPTIONAL_COLUMNS", "Checkpoint", "SegmentStore"]

COLUMNS: tuple[str, ...] = ("p", "q", "pose", "truth", "relation", "mass", "conflict", "eliminated", "line")
"""The columns every store has (see :class:`SegmentStore`)."""

OPTIONAL_COLUMNS: tuple[str, ...] = ("role", "seen")
"""The columns of consolidation, written always, read as ``""`` and 1 where a file has none."""

CONSOLIDATE_POSES = 3
"""A line seen from more poses than this is consolidated into its merged support."""

WRITTEN: tuple[str, ...] = ("relation", "mass", "conflict", "eliminated", "line", "role")
"""The columns written in place after a row is appended (by noise elimination, rebuilds, consolidation)."""

ROLES = ("", "absorbed", "support")
"""A raw segment, a raw segment absorbed into its line's support, a line's merged support."""


class _Column:
    """A column of :class:`SegmentStore` (the class attribute of its name): its rows, a read-only view."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __set_name__(self, owner: type, name: str) -> None:
        if name != self.name:
            raise TypeError(f"column {self.name!r} bound to the name {name!r}")

    def __get__(self, store: SegmentStore | None, owner: type | None = None) -> Any:
        if store is None:
            return self
        view = store._data[self.name][: store._n]
        view.setflags(write=False)  # the store's columns change only through the store
        return view


class SegmentStore:
    """Raw segments, one row each; a segment's id is its row number.

    Columns (read-only views of length N; :meth:`write` changes the columns :data:`WRITTEN` of rows already
    appended, so that a :meth:`checkpoint` can put them back):

    - ``p``, ``q``: (N, 2) end points.
    - ``pose``: (N,) index of the pose that saw the segment.
    - ``truth``: (N,) ground truth of a simulated segment, ``"real"`` or ``"noise"`` (``""`` if unknown).
    - ``relation``: (N,) ``outside | partly_inside | inside`` against the map's open space.
    - ``mass``: (N, 2**n) fused mass of the noise-elimination stage (columns by bitmask).
    - ``conflict``: (N,) K between the noise-elimination stage's sources.
    - ``eliminated``: (N,) removed as noise.
    - ``line``: (N,) id of the map line the segment belongs to (``""`` if none).
    - ``role``: (N,) one of :data:`ROLES` (see the module doc).
    - ``seen``: (N,) the poses a row stands for: 1 for a raw segment, more for a support.
    - ``features``: name -> (N,) further features observations brought (e.g. an infrared reading).

    >>> store = SegmentStore.empty(Frame(["real", "noise"]))
    >>> store.append([[0.0, 0.0]], [[1.0, 0.0]], [0], ["real"], {"ir_return": ["echo"]}).tolist()
    [0]
    >>> len(store), store.length.tolist(), store.features["ir_return"].tolist()
    (1, [1.0], ['echo'])
    """

    # the columns (COLUMNS + OPTIONAL_COLUMNS), each read as a read-only view of its rows
    p, q, pose, truth, relation, mass, conflict, eliminated, line, role, seen = map(_Column, COLUMNS + OPTIONAL_COLUMNS)

    def __init__(self, frame: Frame) -> None:
        self._n = 0
        self._data: dict[str, NDArray[Any]] = {
            "p": np.zeros((0, 2)),
            "q": np.zeros((0, 2)),
            "pose": np.zeros(0, dtype=np.intp),
            "truth": np.zeros(0, dtype="<U5"),
            "relation": np.zeros(0, dtype="<U13"),
            "mass": np.zeros((0, 1 << len(frame))),
            "conflict": np.zeros(0),
            "eliminated": np.zeros(0, dtype=bool),
            "line": np.zeros(0, dtype=object),
            "role": np.zeros(0, dtype="<U8"),
            "seen": np.zeros(0, dtype=np.intp),
        }
        self._features: dict[str, NDArray[Any]] = {}
        self._index: SpatialIndex | None = None  # the rows not absorbed; made on first use, then kept
        self._journal: list[tuple[NDArray[np.intp], dict[str, NDArray[Any]]]] | None = None  # see checkpoint
        self._by_pose: dict[int, list[NDArray[np.intp]]] | None = None  # the rows of each pose; made on first use

    @classmethod
    def empty(cls, frame: Frame) -> SegmentStore:
        """A store with no segments, for masses over ``frame``."""
        return cls(frame)

    def __len__(self) -> int:
        return self._n

    @property
    def features(self) -> dict[str, NDArray[Any]]:
        """The further per-segment features, name -> (N,) array (read-only)."""
        return {name: _read_only(column[: self._n]) for name, column in self._features.items()}

    def write(self, rows: ArrayLike, **columns: ArrayLike) -> None:
        """Set the columns :data:`WRITTEN` (``relation=...``, ``line=...``) of the segments ``rows`` (ids).

        >>> store = SegmentStore.empty(Frame(["real", "noise"]))
        >>> ids = store.append([[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]], [0, 0], ["", ""])
        >>> store.write([1], relation=["inside"], eliminated=True)
        >>> store.relation.tolist(), store.eliminated.tolist()
        (['', 'inside'], [False, True])
        """
        rows = np.asarray(rows, dtype=np.intp).reshape(-1)
        unknown = sorted(set(columns) - set(WRITTEN))
        if unknown:
            raise ValueError(f"cannot write {unknown}: a segment's {', '.join(unknown)} never change once appended")
        if len(rows) and not (0 <= rows.min() and rows.max() < self._n):
            raise IndexError(f"rows {rows.min()}..{rows.max()} are not all among the {self._n} segments")
        if self._journal is not None:
            self._journal.append((rows, {k: self._data[k][rows].copy() for k in columns}))
        for k, values in columns.items():
            self._data[k][rows] = values

    @property
    def raw(self) -> NDArray[np.bool_]:
        """(N,) whether each row is a segment a sensor returned (``seen`` 1), not a line's consolidated support,
        standing or absorbed into a later one: the rows report.json, segments.json and the figures count."""
        return self.seen == 1

    @property
    def length(self) -> NDArray[np.float64]:
        """(N,) segment lengths."""
        return np.hypot(*(self.q - self.p).T)

    def append(
        self,
        p: ArrayLike,
        q: ArrayLike,
        pose: ArrayLike,
        truth: ArrayLike,
        features: Mapping[str, ArrayLike] | None = None,
    ) -> NDArray[np.intp]:
        """Add segments, not yet judged (relation ``""``, zero mass, no line); return their ids.

        ``features`` must name the same features as the segments already stored.
        """
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        k = len(p)
        features = dict(features or {})
        if self._n and set(features) != set(self._features):
            raise ValueError(
                f"an observation brings features {sorted(features)}, the map's segments have {sorted(self._features)}"
            )
        new = {"p": p, "q": q, "pose": pose, "truth": truth}
        for name, values in features.items():
            column = np.asarray(values)
            if column.shape != (k,):
                raise ValueError(f"feature {name!r} needs one value per segment ({k}), got shape {column.shape}")
            if name not in self._features:
                self._features[name] = np.zeros(0, dtype=column.dtype)
            new[name] = column
        self._reserve(self._n + k)
        rows = slice(self._n, self._n + k)
        for name, values in new.items():
            target = self._features[name] if name in self._features else self._data[name]
            if target.dtype.kind == "U" and np.asarray(values).dtype.itemsize > target.dtype.itemsize:
                self._widen(name, np.asarray(values).dtype)
                target = self._features[name] if name in self._features else self._data[name]
            target[rows] = values
        self._data["line"][rows] = ""
        self._data["role"][rows] = ""
        self._data["seen"][rows] = 1
        self._n += k
        ids = np.arange(rows.start, rows.stop)
        if self._index is not None:
            for i, box in zip(ids.tolist(), self.boxes(ids).tolist(), strict=True):
                self._index.insert(str(i), box)
        if self._by_pose is not None:
            _file_by_pose(self._by_pose, ids, self.pose[ids])
        return ids

    def consolidate(self, members: ArrayLike, p: ArrayLike, q: ArrayLike, line: str, seen: int) -> int:
        """Absorb ``members`` into one support row p-q of ``line`` standing for ``seen`` poses; return its id.

        The support takes the newest member pose, the members' features from the
        longest, and the members' verdict is left to be judged (relation ``""``).

        >>> store = SegmentStore.empty(Frame(["real", "noise"]))
        >>> ids = store.append([[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]], [3, 5], ["", ""])
        >>> store.consolidate(ids, [0.0, 0.0], [2.0, 0.0], "L1", 2)
        2
        >>> store.role.tolist(), store.seen.tolist(), store.pose.tolist(), store.near((0, -1, 3, 1)).tolist()
        (['absorbed', 'absorbed', 'support'], [1, 1, 2], [3, 5, 5], [2])
        """
        members = np.asarray(members, dtype=np.intp)
        longest = members[np.argmax(np.hypot(*(self.q[members] - self.p[members]).T))]
        features = {name: column[[longest]] for name, column in self.features.items()}
        pose = [int(self.pose[members].max())]
        (row,) = self.append([p], [q], pose, [""], features).tolist()
        self._data["line"][row] = line
        self._data["role"][row] = "support"
        self._data["seen"][row] = seen
        self.write(members, role="absorbed")
        if self._index is not None:
            for i in members.tolist():
                self._index.remove(str(i))
        return row

    def checkpoint(self) -> Checkpoint:
        """What :meth:`restore` needs to put the rows back as they are now (the map's all-or-nothing updates):
        their number, and from now on what each :meth:`write` overwrites (the other columns of a row never
        change once it is appended), until :meth:`release`. It costs what the writes touch, not the store's
        size."""
        self._journal = []
        return Checkpoint(self._n, self._journal)

    def restore(self, checkpoint: Checkpoint) -> None:
        """Put the rows of a :meth:`checkpoint` back, as they were then (rows appended since are dropped)."""
        for rows, old in reversed(checkpoint.journal):
            for k, values in old.items():
                self._data[k][rows] = values
        self._n = checkpoint.rows
        self._journal = None
        self._index = None
        self._by_pose = None

    def release(self, checkpoint: Checkpoint) -> None:
        """Keep what was written since the ``checkpoint``: writes are no longer recorded for it."""
        if self._journal is checkpoint.journal:
            self._journal = None

    def boxes(self, rows: ArrayLike) -> NDArray[np.float64]:
        """(n, 4) bounding boxes ``(xmin, ymin, xmax, ymax)`` of the segments ``rows`` (ids)."""
        rows = np.asarray(rows, dtype=np.intp)
        p, q = self.p[rows], self.q[rows]
        return np.hstack([np.minimum(p, q), np.maximum(p, q)]).reshape(-1, 4)

    def near(self, bounds: tuple[float, float, float, float] | NDArray[np.float64]) -> NDArray[np.intp]:
        """Ids of the segments not absorbed (nor forgotten, :meth:`forget`) whose bounding boxes meet ``bounds`` =
        (xmin, ymin, xmax, ymax), or one of the boxes of an (n, 4) array, sorted.

        A spatial index (:class:`~evmap.maps.spatial.SpatialIndex`): it costs what the box holds.
        """
        if self._index is None:
            live = np.flatnonzero(self.role != "absorbed")
            self._index = SpatialIndex.from_boxes([str(i) for i in live.tolist()], self.boxes(live))
        keys = self._index.query(bounds)
        return np.sort(np.fromiter(map(int, keys), dtype=np.intp, count=len(keys)))

    def seen_from(self, pose: int) -> NDArray[np.intp]:
        """Ids of the segments the pose ``pose`` saw (absorbed ones too), sorted.

        An index of the rows by pose: it costs the rows of the pose, at any size of the store.

        >>> store = SegmentStore.empty(Frame(["real", "noise"]))
        >>> ids = store.append([[0, 0], [1, 0], [2, 0]], [[1, 0], [2, 0], [3, 0]], [3, 5, 3], ["", "", ""])
        >>> store.seen_from(3).tolist(), store.seen_from(4).tolist()
        ([0, 2], [])
        """
        if self._by_pose is None:
            self._by_pose = {}
            _file_by_pose(self._by_pose, np.arange(self._n), self.pose)
        rows = self._by_pose.get(int(pose), [])
        if len(rows) > 1:
            rows[:] = [np.concatenate(rows)]
        return rows[0] if rows else np.zeros(0, dtype=np.intp)

    def forget(self, rows: ArrayLike) -> None:
        """Leave the rows out of :meth:`near` until the index is made anew (after a :meth:`restore` or a load):
        for rows no caller looks up again (settled noise), which the callers also leave out of what they find,
        so that what they find does not depend on when the index was made."""
        if self._index is not None:
            for i in np.asarray(rows, dtype=np.intp).tolist():
                if str(i) in self._index:
                    self._index.remove(str(i))

    def to_json(self) -> dict[str, Any]:
        """The store as JSON-able lists (floats round-trip exactly)."""
        out: dict[str, Any] = {name: getattr(self, name).tolist() for name in COLUMNS + OPTIONAL_COLUMNS}
        out["features"] = {name: column.tolist() for name, column in self.features.items()}
        return out

    @classmethod
    def from_json(cls, data: Any, frame: Frame) -> SegmentStore:
        """The store written by :meth:`to_json`; a ValueError names a missing or malformed column.

        >>> frame = Frame(["real", "noise"])
        >>> store = SegmentStore.empty(frame)
        >>> ids = store.append([[0.0, 0.0]], [[1.0, 0.0]], [0], ["real"])
        >>> SegmentStore.from_json(store.to_json(), frame).q.tolist()
        [[1.0, 0.0]]
        """
        store = cls(frame)
        if not isinstance(data, dict):
            raise ValueError("segments: expected an object of columns")  # noqa: TRY004
        columns: dict[str, NDArray[Any]] = {}
        for name in COLUMNS:
            if name not in data:
                raise ValueError(f"segments: column {name!r} is missing")
            template = store._data[name]
            try:
                column = np.array(data[name], dtype=template.dtype if template.dtype.kind != "U" else str)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"segments.{name}: {exc}") from None
            if column.size == 0:
                column = column.reshape(template.shape)
            if column.shape[1:] != template.shape[1:]:
                raise ValueError(
                    f"segments.{name}: rows of shape {template.shape[1:]} expected, got {column.shape[1:]}"
                )
            columns[name] = column
        n = len(columns["p"])
        defaults = {"role": np.full(n, ""), "seen": np.ones(n, dtype=np.intp)}
        for name in OPTIONAL_COLUMNS:
            template = store._data[name]
            try:
                column = np.array(data[name], dtype=template.dtype) if name in data else defaults[name]
            except (TypeError, ValueError) as exc:
                raise ValueError(f"segments.{name}: {exc}") from None
            columns[name] = column.reshape(-1)
        bad = sorted(set(columns["role"].tolist()) - set(ROLES))
        if bad:
            raise ValueError(f"segments.role: {bad[0]!r} is not one of {list(ROLES)}")
        features = data.get("features", {})
        if not isinstance(features, dict):
            raise ValueError("segments.features: expected an object of columns")  # noqa: TRY004
        for name, values in features.items():
            columns[name] = np.array(values)
        lengths = {name: len(c) for name, c in columns.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"segments: columns of different lengths {lengths}")
        store._data = {name: columns[name] for name in COLUMNS + OPTIONAL_COLUMNS}
        store._data["line"] = columns["line"].astype(object)
        store._features = {name: columns[name] for name in features}
        store._n = n
        return store

    def _reserve(self, rows: int) -> None:
        """Grow every column's capacity to at least ``rows``, doubling."""
        capacity = len(self._data["p"])
        if rows <= capacity:
            return
        size = max(rows, 2 * capacity, 64)
        for columns in (self._data, self._features):
            for name, column in columns.items():
                grown = np.zeros((size, *column.shape[1:]), dtype=column.dtype)
                grown[: self._n] = column[: self._n]
                columns[name] = grown

    def _widen(self, name: str, dtype: np.dtype[Any]) -> None:
        """Give a string column room for longer strings."""
        columns = self._features if name in self._features else self._data
        columns[name] = columns[name].astype(dtype)


@dataclass(frozen=True, eq=False)
class Checkpoint:
    """A :meth:`SegmentStore.checkpoint`: the rows then, and what was overwritten since (rows, old values)."""

    rows: int
    journal: list[tuple[NDArray[np.intp], dict[str, NDArray[Any]]]]


def _read_only(view: NDArray[Any]) -> NDArray[Any]:
    """The view, not writable (the store's columns change only through the store)."""
    view.flags.writeable = False
    return view


def _file_by_pose(by_pose: dict[int, list[NDArray[np.intp]]], ids: NDArray[np.intp], pose: NDArray[np.intp]) -> None:
    """File the rows ``ids`` (ascending, after every row filed before), seen from ``pose``, under their poses."""
    if not len(ids):  # an observation that saw no segment
        return
    if len(ids) == 1:  # a consolidation's support: one row, no sorting
        by_pose.setdefault(int(pose[0]), []).append(ids)
        return
    order = np.argsort(pose, kind="stable")
    values, first = np.unique(pose[order], return_index=True)
    for value, rows in zip(values.tolist(), np.split(ids[order], first[1:]), strict=True):
        by_pose.setdefault(value, []).append(rows)
