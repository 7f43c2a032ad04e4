"""The points and lines of a belief map and their changes: checked, indexed, journalled, undoable.

:class:`MapObjects` changes the graph of a :class:`~evmap.maps.belief_map.BeliefMap`
one object at a time (the map's building methods call it): each change is
checked (:mod:`evmap.maps.map_checks`), followed by the spatial indexes
(:mod:`evmap.maps.map_index`), logged for undoing inside a transaction
(:mod:`evmap.maps.undo_log`), told to the change journal
(:mod:`evmap.maps.change_journal`) and, for folded evidence, to the running
masses (:mod:`evmap.maps.running_mass`).

>>> from evmap.maps.map_graph import MapGraph
>>> from evidential import Frame, MassFunction
>>> frame = Frame(["real", "noise"])
>>> objects = MapObjects(MapGraph(rule="dempster"), frame)
>>> m = MassFunction(frame, {"real": 0.5, "real|noise": 0.5})
>>> objects.add_point("A", (0, 0), "corner", m); objects.add_point("B", (1, 0), "endpoint", m)
>>> objects.add_line("L1", "A", "B", m)
>>> round(objects.fold("L1", m, {"pose": 0}).belief("real"), 2), len(objects), sorted(objects.index.near((0, 0, 1, 0)))
(0.75, 3, ['A', 'B', 'L1'])
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from evidential import Frame, MassFunction, combine, conflict
from evmap.maps import map_json, planner
from evmap.maps.change_journal import ChangeJournal
from evmap.maps.map_checks import check_extras, checked_history, checked_kind
from evmap.maps.map_format import CORNERS_DEFERRED, ID_PREFIXES, LINE_KEYS, LINE_KIND, POINT_KEYS
from evmap.maps.map_graph import MapGraph
from evmap.maps.map_index import MapIndex
from evmap.maps.planner import Line, Point
from evmap.maps.running_mass import RunningMasses
from evmap.maps.undo_log import ABSENT, UndoLog, undo

__all__ = ["MapObjects"]


class MapObjects:
    """The graph's points and lines (``lines``: id -> end points) with their indexes, undo log, journal and
    running masses."""

    def __init__(self, graph: MapGraph, frame: Frame) -> None:
        self.graph = graph
        self.frame = frame
        self.lines: dict[str, tuple[str, str]] = {}
        self.index = MapIndex(graph, self.lines)
        self.running = RunningMasses()
        self.undo = UndoLog()
        self.journal = ChangeJournal()

    @property
    def rule(self) -> str:
        """The combination rule of :meth:`fold` (the graph's ``rule``)."""
        return self.graph.graph["rule"]

    def __contains__(self, id: object) -> bool:
        return id in self.lines or id in self.graph

    def __len__(self) -> int:
        """The number of objects: points and lines."""
        return self.graph.number_of_nodes() + len(self.lines)

    def add_point(
        self, id: str, xy: Iterable[float], kind: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a point (node) ``id`` at ``xy`` of ``kind`` (corner, endpoint, unidentified).

        ``history`` is the list of evidence records so far (copied); ``attrs`` are
        extra JSON-able attributes (``shape="concave"``, ``reinforced=True``...).
        """
        self.check_new_id(id)
        check_extras(attrs, POINT_KEYS, id)
        self.graph.add_node(
            id,
            id=id,
            xy=planner.point(xy, id),
            kind=checked_kind(kind, id),
            mass=self.check_mass(mass, id),
            history=checked_history(history, id),
            **attrs,
        )
        self.index.place_point(id)
        self.undo.record("added point", id)
        self.changed(id)

    def add_line(
        self, id: str, u: str, v: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a line (edge) ``id`` from point ``u`` to point ``v`` (two existing, different points).

        ``history`` is the list of evidence records so far (copied); ``attrs`` are
        extra JSON-able attributes (``members=[...]``, ``reinforced=True``...).
        """
        self.check_new_id(id)
        check_extras(attrs, LINE_KEYS, id)
        for end in (u, v):
            if end not in self.graph:
                raise KeyError(f"line {id!r}: end point {end!r} is not a point of the map")
        if u == v:
            raise ValueError(f"line {id!r}: needs two different end points, got {u!r} twice")
        if self.graph.has_edge(u, v):
            other = self.graph.edge(u, v)["id"]
            raise ValueError(f"line {id!r}: points {u!r} and {v!r} are already joined by {other!r}")
        mass = self.check_mass(mass, id)
        self.graph.add_edge(u, v, id=id, kind=LINE_KIND, mass=mass, history=checked_history(history, id), **attrs)
        self.lines[id] = (u, v)
        self.index.place_line(id)
        self.undo.record("added line", id)
        self.changed(id)

    def remove_line(self, id: str) -> None:
        """Remove the line ``id`` (its end points stay)."""
        if id not in self.lines:
            raise KeyError(f"{id!r} is not a line of the map")
        u, v = self.lines[id]
        self.undo.record("removed line", id, u, v, self.graph.adj[u][v])
        self.graph.remove_edge(*self.lines.pop(id))
        self.running.drop(id)
        self.index.remove_line(id)
        self.changed(id)

    def remove_point(self, id: str) -> None:
        """Remove the point ``id``; it must end no line (remove those first)."""
        if id not in self.graph:
            raise KeyError(f"{id!r} is not a point of the map")
        ending = sorted(d["id"] for d in self.graph.adj[id].values())
        if ending:
            raise ValueError(f"point {id!r} still ends lines {ending}; remove them first")
        self.undo.record("removed point", id, self.graph.nodes[id])
        self.graph.remove_node(id)
        self.running.drop(id)
        self.index.remove_point(id)
        self.changed(id)

    def set_attrs(self, id: str, /, **attrs: Any) -> None:
        """Set attributes of the object ``id`` (``mass``, ``xy``, ``kind`` of a point, extras).

        ``id`` cannot change (remove and add instead), nor a line's kind.
        """
        data = self.data(id)
        is_line = id in self.lines
        if "id" in attrs or (is_line and ({"kind", "xy", "source", "target"} & set(attrs))):
            raise ValueError(f"{id!r}: cannot set {sorted(attrs)}: id, and a line's kind and ends, are fixed")
        checked = dict(attrs)
        map_json.check_json({k: v for k, v in attrs.items() if k not in ("mass", "xy", "history")}, id)
        if "mass" in attrs:
            checked["mass"] = self.check_mass(attrs["mass"], id)
        if "xy" in attrs:
            checked["xy"] = planner.point(attrs["xy"], id)
        if "kind" in attrs:
            checked["kind"] = checked_kind(attrs["kind"], id)
        if "history" in attrs:
            checked["history"] = checked_history(attrs["history"], id, kept=data["history"])
            self.running.history_set(id, checked["history"], data["history"])
        self.undo.record("set", id, {k: data.get(k, ABSENT) for k in checked})
        data.update(checked)
        if "xy" in checked or "kind" in checked:
            self.index.place_point(id)
        moved = [line["id"] for line in self.graph.adj[id].values()] if "xy" in checked else []
        for line in moved:  # the point's lines moved with it
            self.index.place_line(line)
        self.changed(id, *moved)

    def fold(self, id: str, mass: MassFunction, record: Mapping[str, Any]) -> MassFunction:
        """Combine new evidence into the object's mass by the map's rule; log it in the history.

        The record (JSON-able: pose, sensor, source...) is appended to the
        object's ``history`` with ``rule``, ``conflict`` (K between the stored and
        the new mass) and ``mass`` (the new evidence as ``{FOCAL: float}``).

        Returns
        -------
        The combined mass, now stored. Under Dempster's rule, evidence in total
        conflict with the stored mass raises :class:`evidential.TotalConflictError`
        and changes nothing.
        """
        data = self.data(id)
        mass = self.check_mass(mass, id)
        map_json.check_json(record, f"{id}: record")
        combined = combine(data["mass"], mass, rule=self.rule)
        self.undo.record("folded", id, data["mass"], len(data["history"]))
        data["history"].append(
            {**record, "rule": self.rule, "conflict": conflict(data["mass"], mass), "mass": mass.to_dict()}
        )
        data["mass"] = combined
        self.running.fold(id, mass, record, self.rule)
        self.changed(id)
        return combined

    def running_mass(self, id: str) -> MassFunction | None:
        """The running mass of the object's evidence records (:mod:`evmap.maps.running_mass`): their masses
        combined by the map's rule in history order; None if it has none. :meth:`fold` combines one record
        more into it; it is made from the history the first time it is asked for, then kept.

        >>> from evidential import Frame, MassFunction
        >>> frame = Frame(["real", "noise"])
        >>> objects = MapObjects(MapGraph(rule="dempster"), frame)
        >>> objects.add_point("A", (0, 0), "corner", MassFunction(frame, {"real|noise": 1.0}))
        >>> objects.running_mass("A") is None
        True
        >>> for p in (0.5, 0.4):
        ...     _ = objects.fold("A", MassFunction(frame, {"real": p, "real|noise": 1 - p}), {"pose": 0})
        >>> round(objects.running_mass("A").belief("real"), 2)
        0.7
        """
        return self.running.get(id, self.frame, self.data(id)["history"], self.rule)

    def keep_running(self, id: str, running: MassFunction | None) -> None:
        """Give the object ``id`` the running mass of its evidence records (:meth:`running_mass`), as the
        caller has it: a rebuild carries it over from the line or corner whose records a new one takes on."""
        self.data(id)
        self.running.keep(id, None if running is None else self.check_mass(running, id))

    def check_new_id(self, id: str) -> None:
        """Refuse an id that is not a non-empty string or that an object already has."""
        if not isinstance(id, str) or not id:
            raise ValueError(f"an object id must be a non-empty string, got {id!r}")
        if id in self:
            raise ValueError(f"id {id!r} is already used by an object of the map")

    def check_mass(self, mass: MassFunction, id: str) -> MassFunction:
        """``mass`` if it is a mass function over the map's frame, else an error naming ``id``."""
        if not isinstance(mass, MassFunction):
            raise TypeError(f"{id!r}: mass must be a MassFunction, got {type(mass).__name__}")
        if mass.frame != self.frame:
            raise ValueError(f"{id!r}: mass is over {mass.frame!r}, the map's frame is {self.frame!r}")
        return mass

    def data(self, id: str) -> dict[str, Any]:
        """The attributes of the point or line ``id`` (the graph's own dict)."""
        if id in self.lines:
            u, v = self.lines[id]
            return self.graph.adj[u][v]
        if id in self.graph:
            return self.graph.nodes[id]
        raise KeyError(f"{id!r} is neither a point nor a line of the map")

    def changed(self, *ids: str) -> None:
        """A new version of the map, in which the objects ``ids`` (maybe none) changed."""
        self.journal.changed(*ids, keep=2 * len(self) + 4096)

    def roll_back(self) -> None:
        """Undo the changes logged since the undo log started, newest first; the indexes, running masses and
        whatever was derived from the map are made anew."""
        undo(self.undo.stop(), self.graph, self.lines, self.data)
        self.index.reset()
        self.running.clear()
        self.journal.forget()

    def new_id(self, prefix: str) -> str:
        """A fresh id for a new object: ``prefix`` (one of :data:`ID_PREFIXES`) and the next number."""
        counters = self.graph.graph.setdefault("next_id", dict.fromkeys(ID_PREFIXES, 1))
        n = counters[prefix]
        while f"{prefix}{n}" in self:  # ids taken by hand stay taken
            n += 1
        counters[prefix] = n + 1
        return f"{prefix}{n}"

    def add_pose(self, pose_index: int) -> None:
        """Record that the observation of ``pose_index`` is folded into the map (once per pose)."""
        poses = self.graph.graph.setdefault("poses", [])
        if pose_index in poses:
            raise ValueError(f"pose {pose_index} is already folded into this map")
        poses.append(int(pose_index))
        self.changed()

    def defer_corners(self, deferred: bool) -> None:
        """Mark that updates left line ends free to be joined into corners later (``graph.corners_deferred``,
        :mod:`evmap.maps.pipeline`), or that nothing waits any more."""
        if deferred:
            self.graph.graph[CORNERS_DEFERRED] = True
        else:
            self.graph.graph.pop(CORNERS_DEFERRED, None)
        self.changed()

    def view(self, id: str) -> Line | Point:
        """The line or point ``id`` as the planner sees it (with its belief)."""
        data = self.data(id)
        mass = data["mass"]
        bel, pl = mass.belief("real"), mass.plausibility("real")
        if id in self.lines:
            u, v = self.lines[id]
            return Line(id, u, v, self.graph.nodes[u]["xy"], self.graph.nodes[v]["xy"], mass, bel, pl)
        return Point(id, data["xy"], data["kind"], mass, bel, pl)

    def fill(self, nodes: list[dict[str, Any]], ends: list[tuple[str, str]], edges: list[dict[str, Any]]) -> None:
        """Put checked points (their attributes, in this order) and lines (ends and attributes) in the graph."""
        g = self.graph
        for d in nodes:
            g.add_node(d["id"], **d)
        for (u, v), d in zip(ends, edges, strict=True):
            g.add_edge(u, v, **d)
        self.lines.update(zip([d["id"] for d in edges], ends, strict=True))
