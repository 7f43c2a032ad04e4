"""The line-corner belief map: a networkx graph of points and lines with mass functions.

Nodes are points (``corner``, free ``endpoint``, ``unidentified`` sonar target),
edges are lines (``kind: "line"``). Every node and edge carries

- ``id``: a string unique over the map (``"C3"``, ``"E7"``, ``"U1"``, ``"L12"``);
- ``mass``: a :class:`~evidential.MassFunction` over the map's frame;
- ``history``: a list of JSON-able records, one per piece of evidence folded in
  (which pose, which sensor, which source, the rule, the mass);
- points also ``xy`` (a tuple of two floats) and ``kind``; any object may carry
  more JSON-able attributes (``shape``, ``reinforced``, ``members``...).

The graph's attributes are ``schema_version``, ``frame`` (element names),
``rule`` (the combination rule of :meth:`BeliefMap.fold`), ``open_space`` (the
sonar open space as GeoJSON-like MultiPolygon coordinates) and free JSON-able
extras that the pipeline stores (``bm.graph.graph["config"] = ...``).

Build and change the map through its methods (:meth:`~BeliefMap.add_point`,
:meth:`~BeliefMap.add_line`, :meth:`~BeliefMap.fold`,
:meth:`~BeliefMap.set_attrs`, the removals, the ``open_space`` setter): they
keep the planner's spatial index up to date. :attr:`BeliefMap.graph` is for
reading, by algorithms written as plain functions of a graph.

The planner's queries (the names of issue 6) use a belief ``Bel({real})``:
:meth:`~BeliefMap.lines`, :meth:`~BeliefMap.corners`,
:meth:`~BeliefMap.unidentified`, :meth:`~BeliefMap.landmarks`,
:meth:`~BeliefMap.nearest_obstacle`, :meth:`~BeliefMap.is_segment_clear` (a
shapely STRtree over the obstacles, built lazily per ``min_belief`` and
dropped when the map changes), the evidential occupancy grid
(:mod:`maps.occupancy`) and its ROS export, and lossless :meth:`~BeliefMap.save`
/ :meth:`~BeliefMap.load` of ``map.json`` (``shared/SCENARIO.md``).
"""

from __future__ import annotations

import gc
import math
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from itertools import chain
from numbers import Real
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import networkx as nx
import numpy as np
import orjson
import shapely
from numpy.typing import NDArray

from evidential import RULES, Frame, MassFunction, Stack, combine, conflict
from evidential.mass import SUM_TOLERANCE
from maps.occupancy import OccupancyParams, evidential_grid, occupancy_from_masses, write_atomic, write_ros_map
from maps.segments import SegmentStore
from sources.config import Config, config_from_data
from sources.loading import InputError

if TYPE_CHECKING:
    from maps.observation import Observation
    from maps.pipeline import PoseOutcome

__all__ = ["LINE_KIND", "POINT_KINDS", "SCHEMA_VERSION", "BeliefMap", "Line", "MapFileError", "Point"]

SCHEMA_VERSION = 1
"""Version of the ``map.json`` layout that :meth:`BeliefMap.save` writes and :meth:`BeliefMap.load` reads."""

POINT_KINDS = ("corner", "endpoint", "unidentified")
"""The kinds of points (nodes)."""

LINE_KIND = "line"
"""The kind of every line (edge)."""

_GRAPH_KEYS = ("schema_version", "frame", "rule", "open_space", "segments")
_POINT_KEYS = ("id", "xy", "kind", "mass", "history")
_LINE_KEYS = ("id", "kind", "mass", "history", "source", "target")
_NODE_REQUIRED = frozenset(("id", "xy", "kind", "mass"))
_EDGE_REQUIRED = frozenset(("id", "kind", "mass", "source", "target"))
_MAX_TREES = 16


@contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while a big map is written or read.

    Both allocate hundreds of thousands of containers, none of them garbage;
    the collector's passes over them would double the time.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class MapFileError(InputError):
    """A map file cannot be read: truncated, of an unknown schema version, or not a map."""


class Line(NamedTuple):
    """A line of the map as the planner sees it: ends ``p`` -> ``q`` (points ``u`` -> ``v``)."""

    id: str
    u: str
    v: str
    p: tuple[float, float]
    q: tuple[float, float]
    mass: MassFunction
    belief: float
    plausibility: float


class Point(NamedTuple):
    """A point of the map (corner, endpoint or unidentified object) as the planner sees it."""

    id: str
    xy: tuple[float, float]
    kind: str
    mass: MassFunction
    belief: float
    plausibility: float


class BeliefMap:
    """The paper's line-corner map with beliefs, on a :class:`networkx.Graph`.

    Parameters
    ----------
    frame : the frame of every mass function (a :class:`~evidential.Frame` or
        element names); it must contain ``"real"``, whose belief the queries use.
    rule : name of the combination rule (a key of :data:`evidential.RULES`) by
        which :meth:`fold` combines new evidence with what is stored.
    **attrs : JSON-able extra graph attributes.

    Examples
    --------
    >>> from evidential import MassFunction
    >>> bm = BeliefMap(["real", "noise"])
    >>> m = MassFunction(bm.frame, {"real": 0.6, "real|noise": 0.4})
    >>> bm.add_point("C1", (0.0, 0.0), "corner", m)
    >>> bm.add_point("E1", (2.0, 0.0), "endpoint", m)
    >>> bm.add_line("L1", "C1", "E1", m, members=[3, 4])
    >>> [line.id for line in bm.lines(min_belief=0.5)], bm.nearest_obstacle((1.0, 0.5))
    (['L1'], (0.5, 'L1'))
    >>> new = bm.fold("L1", MassFunction(bm.frame, {"real": 0.5, "real|noise": 0.5}), {"pose": 0})
    >>> round(bm["L1"].belief, 2), bm.graph.edges["C1", "E1"]["history"][0]["rule"]
    (0.8, 'dempster')
    >>> bm.is_segment_clear((0.0, 1.0), (2.0, 1.0), clearance=0.2), bm.is_segment_clear((1.0, 1.0), (1.0, 0.1))
    (True, False)
    >>> grid = bm.occupancy_grid(resolution=0.1)
    >>> grid.dtype, grid.shape, int(grid.max())
    (dtype('int8'), (5, 25), 90)
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     bm.save(pathlib.Path(tmp) / "map.json")
    ...     BeliefMap.load(pathlib.Path(tmp) / "map.json").to_data() == bm.to_data()
    True
    """

    def __init__(self, frame: Frame | Iterable[str], rule: str = "dempster", **attrs: Any) -> None:
        frame = frame if isinstance(frame, Frame) else Frame(frame)
        if "real" not in frame.elements:
            raise ValueError(f"frame must contain the element 'real' (beliefs are Bel({{real}})), got {frame!r}")
        if not isinstance(rule, str) or rule not in RULES:
            raise ValueError(f"rule must be one of {sorted(RULES)}, got {rule!r}")
        _check_extras(attrs, _GRAPH_KEYS, "graph")
        self._frame = frame
        self._graph = nx.Graph(
            schema_version=SCHEMA_VERSION,
            frame=list(frame.elements),
            rule=rule,
            open_space=_geojson(shapely.MultiPolygon()),
            **attrs,
        )
        self._lines: dict[str, tuple[str, str]] = {}
        self._open_space: shapely.MultiPolygon = shapely.MultiPolygon()
        self._index: _Index | None = None
        self._config: Config | None = None
        self.segments = SegmentStore.empty(frame)
        """The raw LSL segments behind the lines (:class:`maps.segments.SegmentStore`)."""

    def __repr__(self) -> str:
        return (
            f"BeliefMap(points={self._graph.number_of_nodes()}, lines={len(self._lines)}, "
            f"frame={list(self._frame.elements)}, rule={self.rule!r})"
        )

    # ----------------------------------------------------------------- properties

    @property
    def frame(self) -> Frame:
        """The frame of every mass function of the map."""
        return self._frame

    @property
    def rule(self) -> str:
        """The combination rule of :meth:`fold`."""
        return self._graph.graph["rule"]

    @property
    def graph(self) -> nx.Graph:
        """The networkx graph (nodes: points by id; edges: lines). Read it; change the map by the methods."""
        return self._graph

    @property
    def open_space(self) -> shapely.MultiPolygon:
        """The sonar open space, a (possibly empty) shapely MultiPolygon.

        Set it with a Polygon, a MultiPolygon, an empty geometry or None; it is
        stored in the graph (``open_space``) as GeoJSON-like coordinate lists.
        """
        return self._open_space

    @open_space.setter
    def open_space(self, geometry: shapely.Geometry | None) -> None:
        if geometry is None or geometry.is_empty:
            geometry = shapely.MultiPolygon()
        elif isinstance(geometry, shapely.Polygon):
            geometry = shapely.MultiPolygon([geometry])
        if not isinstance(geometry, shapely.MultiPolygon):
            raise ValueError(f"open_space must be a Polygon or MultiPolygon, got a {geometry.geom_type}")
        if not geometry.is_valid:
            raise ValueError(f"open_space is not a valid geometry: {shapely.is_valid_reason(geometry)}")
        self._graph.graph["open_space"] = _geojson(geometry)
        self._open_space = geometry

    # ----------------------------------------------------------------- building

    def add_point(
        self, id: str, xy: Iterable[float], kind: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a point (node) ``id`` at ``xy`` of ``kind`` (corner, endpoint, unidentified).

        ``history`` is the list of evidence records so far (copied); ``attrs`` are
        extra JSON-able attributes (``shape="concave"``, ``reinforced=True``...).
        """
        self._check_new_id(id)
        _check_extras(attrs, _POINT_KEYS, id)
        self._graph.add_node(
            id,
            id=id,
            xy=_xy(xy, id),
            kind=_kind(kind, id),
            mass=self._check_mass(mass, id),
            history=_history(history, id),
            **attrs,
        )
        self._changed()

    def add_line(
        self, id: str, u: str, v: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a line (edge) ``id`` from point ``u`` to point ``v`` (two existing, different points).

        ``history`` is the list of evidence records so far (copied); ``attrs`` are
        extra JSON-able attributes (``members=[...]``, ``reinforced=True``...).
        """
        self._check_new_id(id)
        _check_extras(attrs, _LINE_KEYS, id)
        for end in (u, v):
            if end not in self._graph:
                raise KeyError(f"line {id!r}: end point {end!r} is not a point of the map")
        if u == v:
            raise ValueError(f"line {id!r}: needs two different end points, got {u!r} twice")
        if self._graph.has_edge(u, v):
            other = self._graph.edges[u, v]["id"]
            raise ValueError(f"line {id!r}: points {u!r} and {v!r} are already joined by {other!r}")
        mass = self._check_mass(mass, id)
        self._graph.add_edge(u, v, id=id, kind=LINE_KIND, mass=mass, history=_history(history, id), **attrs)
        self._lines[id] = (u, v)
        self._changed()

    def remove_line(self, id: str) -> None:
        """Remove the line ``id`` (its end points stay)."""
        if id not in self._lines:
            raise KeyError(f"{id!r} is not a line of the map")
        self._graph.remove_edge(*self._lines.pop(id))
        self._changed()

    def remove_point(self, id: str) -> None:
        """Remove the point ``id``; it must end no line (remove those first)."""
        if id not in self._graph:
            raise KeyError(f"{id!r} is not a point of the map")
        ending = sorted(d["id"] for _, _, d in self._graph.edges(id, data=True))
        if ending:
            raise ValueError(f"point {id!r} still ends lines {ending}; remove them first")
        self._graph.remove_node(id)
        self._changed()

    def set_attrs(self, id: str, /, **attrs: Any) -> None:
        """Set attributes of the object ``id`` (``mass``, ``xy``, ``kind`` of a point, extras).

        ``id`` cannot change (remove and add instead), nor a line's kind.
        """
        data = self._data(id)
        is_line = id in self._lines
        if "id" in attrs or (is_line and ({"kind", "xy", "source", "target"} & set(attrs))):
            raise ValueError(f"{id!r}: cannot set {sorted(attrs)}: id, and a line's kind and ends, are fixed")
        checked = dict(attrs)
        _check_json({k: v for k, v in attrs.items() if k not in ("mass", "xy")}, id)
        if "mass" in attrs:
            checked["mass"] = self._check_mass(attrs["mass"], id)
        if "xy" in attrs:
            checked["xy"] = _xy(attrs["xy"], id)
        if "kind" in attrs:
            checked["kind"] = _kind(attrs["kind"], id)
        if "history" in attrs:
            checked["history"] = _history(attrs["history"], id)
        data.update(checked)
        self._changed()

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
        data = self._data(id)
        mass = self._check_mass(mass, id)
        _check_json(record, f"{id}: record")
        combined = combine(data["mass"], mass, rule=self.rule)
        data["history"].append(
            {**record, "rule": self.rule, "conflict": conflict(data["mass"], mass), "mass": mass.to_dict()}
        )
        data["mass"] = combined
        self._changed()
        return combined

    # ----------------------------------------------------------------- observations

    @property
    def config(self) -> Config:
        """The config the map folds observations with (stored in the graph as ``config``).

        Maps made by :func:`maps.pipeline.new_map` (and so by ``evmap run``) carry one.
        """
        if self._config is None:
            if "config" not in self._graph.graph:
                raise ValueError("this map carries no config: make maps to update with maps.pipeline.new_map(config)")
            self._config = config_from_data(self._graph.graph["config"], "map config")
        return self._config

    def update(self, observation: Observation) -> PoseOutcome:
        """Fold in one pose's observation by the paper's pipeline (:func:`maps.pipeline.fold_observation`)."""
        from maps.pipeline import fold_observation  # the pipeline builds on this class

        return fold_observation(self, observation, self.config)

    # ----------------------------------------------------------------- lookup

    def __contains__(self, id: object) -> bool:
        return id in self._lines or id in self._graph

    def __getitem__(self, id: str) -> Line | Point:
        """The line or point ``id`` as the planner sees it (with its belief)."""
        data = self._data(id)
        mass = data["mass"]
        bel, pl = mass.belief("real"), mass.plausibility("real")
        if id in self._lines:
            u, v = self._lines[id]
            return Line(id, u, v, self._graph.nodes[u]["xy"], self._graph.nodes[v]["xy"], mass, bel, pl)
        return Point(id, data["xy"], data["kind"], mass, bel, pl)

    # ----------------------------------------------------------------- planner queries

    def lines(self, min_belief: float = 0.5) -> list[Line]:
        """The lines whose belief Bel(real) is at least ``min_belief``, in insertion order."""
        ix = self._current()
        keep = np.flatnonzero(ix.line_bel >= _belief_level(min_belief))
        return [ix.line(i) for i in keep]

    def corners(self, min_belief: float = 0.5) -> list[Point]:
        """The corners whose belief Bel(real) is at least ``min_belief``."""
        return self._points("corner", min_belief)

    def unidentified(self, min_belief: float = 0.0) -> list[Point]:
        """The unidentified sonar objects (all of them by default)."""
        return self._points("unidentified", min_belief)

    def landmarks(self) -> list[Line | Point]:
        """Reinforced lines and corners (attribute ``reinforced`` true): lines first."""
        ix = self._current()
        g = self._graph
        found: list[Line | Point] = [ix.line(i) for i, (u, v) in enumerate(ix.ends) if g.adj[u][v].get("reinforced")]
        found += [
            ix.point(i)
            for i in np.flatnonzero(ix.point_kind == "corner")
            if g.nodes[ix.point_ids[i]].get("reinforced")
        ]
        return found

    def nearest_obstacle(self, xy: Iterable[float], min_belief: float = 0.5) -> tuple[float, str | None]:
        """Distance from ``xy`` to the nearest obstacle, and its id.

        Obstacles are the lines and the unidentified objects whose belief
        Bel(real) is at least ``min_belief``; the distance to an unidentified
        object is the distance to its point. ``(inf, None)`` when there is none.
        """
        x, y = _xy(xy, "xy")
        tree, ids = self._tree(min_belief)
        if tree is None:
            return math.inf, None
        index, distance = tree.query_nearest(shapely.Point(x, y), return_distance=True, all_matches=False)
        return float(distance[0]), ids[index[0]]

    def is_segment_clear(
        self, a: Iterable[float], b: Iterable[float], clearance: float = 0.2, min_belief: float = 0.5
    ) -> bool:
        """True if every obstacle is farther than ``clearance`` from the segment ``a``-``b``.

        Obstacles as in :meth:`nearest_obstacle`.
        """
        a, b = _xy(a, "a"), _xy(b, "b")
        if not (isinstance(clearance, Real) and 0 <= clearance < math.inf):
            raise ValueError(f"clearance must be a finite number >= 0 (m), got {clearance!r}")
        tree, _ = self._tree(min_belief)
        if tree is None:
            return True
        hits = tree.query(shapely.LineString((a, b)), predicate="dwithin", distance=clearance)
        return hits.size == 0

    def occupancy_masses(
        self, resolution: float = 0.05, params: OccupancyParams | None = None
    ) -> tuple[NDArray[np.float64], tuple[float, float]]:
        """The evidential occupancy grid: masses (rows, columns, 4) and origin (x, y).

        Columns of the last axis: m(∅), m(free), m(occupied), m(free|occupied);
        row 0 is the lowest y; ``origin`` is the lower-left corner of cell (0, 0).
        Free evidence from the open space, occupied evidence from every line,
        corner and unidentified object weighted by its belief, combined by the
        map's rule (see :mod:`maps.occupancy`).
        """
        ix = self._current()
        solid = ix.point_kind != "endpoint"
        xy = ix.xy[solid]
        p = np.concatenate([ix.p, xy])
        q = np.concatenate([ix.q, xy])
        belief = np.concatenate([ix.line_bel, ix.point_bel[solid]])
        everything = np.concatenate([ix.xy, shapely.get_coordinates(self._open_space)])
        if not len(everything):
            raise ValueError("the map is empty (no points, no open space): an occupancy grid has no extent")
        bounds = (*everything.min(axis=0), *everything.max(axis=0))
        return evidential_grid(self._open_space, p, q, belief, bounds, resolution, self.rule, params)

    def occupancy_grid(self, resolution: float = 0.05, params: OccupancyParams | None = None) -> NDArray[np.int8]:
        """The ROS occupancy grid (``int8``: -1 unknown, 0..100 = 100 BetP(occupied); row 0 = lowest y).

        Its origin is that of :meth:`occupancy_masses` (the lower-left corner of
        the map's points and open space, less ``params.padding``).
        """
        masses, _ = self.occupancy_masses(resolution, params)
        return occupancy_from_masses(masses, params)

    def save_ros_map(
        self, path_stem: str | Path, resolution: float = 0.05, params: OccupancyParams | None = None
    ) -> tuple[Path, Path]:
        """Write the occupancy grid as ``STEM.pgm`` + ``STEM.yaml`` for ROS map_server.

        See :func:`maps.occupancy.write_ros_map`. Returns the two paths.
        """
        masses, origin = self.occupancy_masses(resolution, params)
        return write_ros_map(occupancy_from_masses(masses, params), resolution, origin, path_stem)

    # ----------------------------------------------------------------- files

    def to_data(self) -> dict[str, Any]:
        """The map as ``networkx.node_link_data(G, edges="edges")``, masses as ``{FOCAL: float}``.

        Each edge's ``source`` -> ``target`` is the line's ``u`` -> ``v``; nodes
        and edges in insertion order.
        """
        return self._node_link(_MassCodec(self._frame).encode)

    def _node_link(self, encode: Callable[[MassFunction], dict[str, float]] | None) -> dict[str, Any]:
        """:meth:`to_data`; with ``encode`` None, the nodes are the graph's own attribute dicts, masses unencoded."""
        g, adj = self._graph, self._graph.adj
        if encode is None:
            nodes = list(g.nodes.values())
            edges = [{**adj[u][v], "source": u, "target": v} for u, v in self._lines.values()]
        else:
            nodes = [{**d, "mass": encode(d["mass"])} for d in g.nodes.values()]
            edges = [
                {**adj[u][v], "mass": encode(adj[u][v]["mass"]), "source": u, "target": v}
                for u, v in self._lines.values()
            ]
        graph = {**g.graph, "segments": self.segments.to_json()}
        return {"directed": False, "multigraph": False, "graph": graph, "nodes": nodes, "edges": edges}

    @classmethod
    def from_data(cls, data: Any, name: str = "map") -> BeliefMap:
        """Build a map from :meth:`to_data`'s layout; :class:`MapFileError` names ``name`` and the problem."""
        with _gc_paused():
            return _MapReader(name).read(data)

    def save(self, path: str | Path) -> None:
        """Write the map to ``path`` as JSON (``map.json`` of ``shared/SCENARIO.md``), atomically.

        Lossless: floats are written in their shortest round-tripping form and
        read back bit-exact; every attribute and the history round-trip (tuples
        come back as lists, except ``xy``).
        """
        _check_json({k: v for k, v in self._graph.graph.items() if k not in _GRAPH_KEYS}, "graph")
        codec = _MassCodec(self._frame)
        try:
            with _gc_paused():
                text = orjson.dumps(self._node_link(None), default=codec.default)
        except TypeError as exc:  # an attribute changed in the graph directly, bypassing the checks
            raise ValueError(f"cannot save the map to {path}: {exc}") from None
        write_atomic(path, text)

    @classmethod
    def load(cls, path: str | Path) -> BeliefMap:
        """Read a map written by :meth:`save`.

        Raises
        ------
        MapFileError
            If the file cannot be read, is not valid JSON (truncated), has an
            unknown schema version, or is not a map; the message names the file,
            the place (``nodes[3].xy``) and the problem.
        """
        try:
            text = Path(path).read_bytes()
        except OSError as exc:
            raise MapFileError(f"{path}: cannot read file: {exc}") from None
        with _gc_paused():
            try:
                data = orjson.loads(text)
            except orjson.JSONDecodeError as exc:
                raise MapFileError(f"{path}: not valid JSON (truncated or corrupt?): {exc}") from None
            return _MapReader(str(path), owned=True).read(data)

    # ----------------------------------------------------------------- internals

    def _check_new_id(self, id: str) -> None:
        if not isinstance(id, str) or not id:
            raise ValueError(f"an object id must be a non-empty string, got {id!r}")
        if id in self:
            raise ValueError(f"id {id!r} is already used by an object of the map")

    def _check_mass(self, mass: MassFunction, id: str) -> MassFunction:
        if not isinstance(mass, MassFunction):
            raise TypeError(f"{id!r}: mass must be a MassFunction, got {type(mass).__name__}")
        if mass.frame != self._frame:
            raise ValueError(f"{id!r}: mass is over {mass.frame!r}, the map's frame is {self._frame!r}")
        return mass

    def _data(self, id: str) -> dict[str, Any]:
        if id in self._lines:
            u, v = self._lines[id]
            return self._graph.adj[u][v]
        if id in self._graph:
            return self._graph.nodes[id]
        raise KeyError(f"{id!r} is neither a point nor a line of the map")

    def _changed(self) -> None:
        self._index = None

    def _current(self) -> _Index:
        if self._index is None:
            with _gc_paused():
                self._index = _Index(self._graph, self._lines, self._frame.mask("real"))
        return self._index

    def _points(self, kind: str, min_belief: float) -> list[Point]:
        ix = self._current()
        keep = np.flatnonzero((ix.point_kind == kind) & (ix.point_bel >= _belief_level(min_belief)))
        return [ix.point(i) for i in keep]

    def _tree(self, min_belief: float) -> tuple[shapely.STRtree | None, NDArray[np.object_]]:
        ix = self._current()
        level = _belief_level(min_belief)
        found = ix.trees.get(level)
        if found is None:
            keep = np.flatnonzero(ix.obstacle_bel >= level)
            found = (shapely.STRtree(ix.obstacles[keep]) if len(keep) else None, ix.obstacle_ids[keep])
            if len(ix.trees) >= _MAX_TREES:
                ix.trees.clear()
            ix.trees[level] = found
        return found


class _Index:
    """Arrays of one state of the map, for the queries; rebuilt after every change."""

    def __init__(self, graph: nx.Graph, lines: dict[str, tuple[str, str]], real: int) -> None:
        xy = dict(graph.nodes(data="xy"))
        line_mass = {d["id"]: d["mass"] for _, _, d in graph.edges(data=True)}
        self.line_ids = list(lines)
        self.ends = list(lines.values())
        self.line_mass = [line_mass[id] for id in self.line_ids]
        self.line_p = [xy[u] for u, _ in self.ends]
        self.line_q = [xy[v] for _, v in self.ends]
        self.p = np.array(self.line_p, dtype=float).reshape(-1, 2)
        self.q = np.array(self.line_q, dtype=float).reshape(-1, 2)
        self.line_bel, self.line_pl = _belief_plausibility(self.line_mass, real)
        self.point_ids = list(xy)
        self.point_xy = list(xy.values())
        self.xy = np.array(self.point_xy, dtype=float).reshape(-1, 2)
        self.point_mass = [m for _, m in graph.nodes(data="mass")]
        self.point_kind = np.array([k for _, k in graph.nodes(data="kind")], dtype=object)
        self.point_bel, self.point_pl = _belief_plausibility(self.point_mass, real)
        target = np.flatnonzero(self.point_kind == "unidentified")
        self.obstacles = np.concatenate(
            [
                shapely.linestrings(np.stack([self.p, self.q], axis=1)),
                shapely.points(self.xy[target]),
            ]
        )
        self.obstacle_ids = np.array(self.line_ids + [self.point_ids[i] for i in target], dtype=object)
        self.obstacle_bel = np.concatenate([self.line_bel, self.point_bel[target]])
        self.trees: dict[float, tuple[shapely.STRtree | None, NDArray[np.object_]]] = {}

    def line(self, i: int) -> Line:
        u, v = self.ends[i]
        bel, pl = float(self.line_bel[i]), float(self.line_pl[i])
        return Line(self.line_ids[i], u, v, self.line_p[i], self.line_q[i], self.line_mass[i], bel, pl)

    def point(self, i: int) -> Point:
        bel, pl = float(self.point_bel[i]), float(self.point_pl[i])
        return Point(self.point_ids[i], self.point_xy[i], self.point_kind[i], self.point_mass[i], bel, pl)


def _belief_plausibility(masses: list[MassFunction], a: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bel(A) and Pl(A) of many mass functions at once (A a bitmask), as MassFunction.belief computes them."""
    n = len(masses)
    if not n:
        return np.zeros(0), np.zeros(0)
    masks = [m.masks for m in masses]
    owner = np.repeat(np.arange(n), [len(k) for k in masks])
    masks = np.concatenate(masks)
    values = np.concatenate([m.masses for m in masses])
    inside = (masks & ~a == 0) & (masks != 0)  # bel(A): non-empty focal sets inside A
    meets = masks & a != 0  # pl(A): focal sets meeting A
    return (
        np.bincount(owner, weights=np.where(inside, values, 0.0), minlength=n),
        np.bincount(owner, weights=np.where(meets, values, 0.0), minlength=n),
    )


class _MassCodec:
    """Mass functions to ``{FOCAL: float}`` and back, many at a time (a map file holds thousands)."""

    def __init__(self, frame: Frame) -> None:
        self.frame = frame
        self.labels: dict[int, str] = {}

    def encode(self, mass: MassFunction) -> dict[str, float]:
        labels, out = self.labels, {}
        for mask, value in zip(mass.masks.tolist(), mass.masses.tolist(), strict=True):
            label = labels.get(mask)
            if label is None:
                label = labels[mask] = self.frame.label(mask)
            out[label] = value
        return out

    def default(self, value: Any) -> dict[str, float]:
        """orjson's hook for the types it does not know: a MassFunction is written as ``{FOCAL: float}``."""
        if isinstance(value, MassFunction):
            return self.encode(value)
        raise TypeError(f"a {type(value).__name__} is not JSON")

    def decode(self, dicts: list[dict[Any, Any]]) -> list[MassFunction]:
        """The mass functions of the dicts; a bad one raises ``_BadMass(index, engine's message)``.

        Dicts with the same focal sets are checked and stacked as one array; a
        dict that fails the array check goes through the engine's own
        constructor, which either accepts it or says what is wrong.
        """
        groups: dict[tuple[Any, ...], list[int]] = {}
        for i, d in enumerate(dicts):
            groups.setdefault(tuple(d), []).append(i)
        out: list[MassFunction | None] = [None] * len(dicts)
        for keys, rows in groups.items():
            fast = self._stacked(keys, [dicts[i] for i in rows])
            for i, m in zip(rows, fast, strict=True):
                if m is None:
                    try:
                        m = MassFunction.from_dict(self.frame, dicts[i], open_world=True)
                    except (ValueError, TypeError) as exc:
                        raise _BadMass(i, str(exc)) from None
                out[i] = m
        return out  # type: ignore[return-value]

    def _stacked(self, keys: tuple[Any, ...], dicts: list[dict[Any, Any]]) -> list[MassFunction | None]:
        try:
            masks = np.array([self.frame.mask(k) for k in keys], dtype=np.int64)
            rows = [list(d.values()) for d in dicts]
            numbers = set(map(type, chain.from_iterable(rows))) <= {float, int}  # not bool, not str
            values = np.array(rows, dtype=np.float64).reshape(len(rows), len(keys)) if numbers else None
        except (ValueError, TypeError, OverflowError):
            values = None
        if values is None or len(set(masks.tolist())) != len(keys):
            return [None] * len(dicts)
        order = np.argsort(masks)
        stack = Stack(masks[order], np.ascontiguousarray(values[:, order].T))
        good = np.isfinite(values).all(axis=1) & (values >= 0).all(axis=1)
        good &= np.abs(values.sum(axis=1) - 1.0) <= SUM_TOLERANCE
        return [MassFunction.from_stack(self.frame, stack, j) if ok else None for j, ok in enumerate(good.tolist())]


class _BadMass(Exception):
    def __init__(self, index: int, problem: str) -> None:
        super().__init__(problem)
        self.index = index
        self.problem = problem


class _MapReader:
    """Checks the node-link layout of a map file and builds the map; errors name the file and place."""

    def __init__(self, name: str, owned: bool = False) -> None:
        self.name = name
        self.owned = owned  # the parsed records are ours to change (read from a file), else copied

    def fail(self, where: str, problem: str) -> MapFileError:
        return MapFileError(f"{self.name}: {where}: {problem}" if where else f"{self.name}: {problem}")

    def read(self, data: Any) -> BeliefMap:
        if not isinstance(data, dict) or not isinstance(data.get("graph"), dict):
            raise self.fail("", "not a map file (expected a JSON object with 'graph', 'nodes' and 'edges')")
        for key in ("nodes", "edges"):
            if not isinstance(data.get(key), list):
                raise self.fail(key, "required list is missing" if key not in data else "must be a list")
        if data.get("directed", False) is not False or data.get("multigraph", False) is not False:
            raise self.fail("", "a map is an undirected simple graph ('directed' and 'multigraph' false)")
        bm = self.empty_map(data["graph"])
        codec = _MassCodec(bm.frame)
        nodes = [self.record(d, "nodes", i, _NODE_REQUIRED) for i, d in enumerate(data["nodes"])]
        ids: set[str] = set()
        for i, (record, mass) in enumerate(zip(nodes, self.masses(codec, nodes, "nodes"), strict=True)):
            id, xy, kind = record["id"], record["xy"], record["kind"]
            if id in ids:
                raise self.fail(f"nodes[{i}].id", f"id {id!r} is used twice")
            ids.add(id)
            if not (type(xy) in (list, tuple) and len(xy) == 2 and _finite(xy[0]) and _finite(xy[1])):
                raise self.fail(f"nodes[{i}].xy", f"must be [x, y] with two finite numbers, got {_shown(xy)}")
            if kind not in POINT_KINDS:
                raise self.fail(f"nodes[{i}].kind", f"must be one of {list(POINT_KINDS)}, got {_shown(kind)}")
            record["xy"] = (float(xy[0]), float(xy[1]))
            record["mass"] = mass
        points = frozenset(ids)
        edges = [self.record(d, "edges", i, _EDGE_REQUIRED) for i, d in enumerate(data["edges"])]
        ends: set[tuple[str, str]] = set()
        for i, (record, mass) in enumerate(zip(edges, self.masses(codec, edges, "edges"), strict=True)):
            id, u, v = record["id"], record.pop("source"), record.pop("target")
            if id in ids:
                raise self.fail(f"edges[{i}].id", f"id {id!r} is used twice")
            ids.add(id)
            if record["kind"] != LINE_KIND:
                raise self.fail(f"edges[{i}].kind", f"must be {LINE_KIND!r}, got {_shown(record['kind'])}")
            for key, end in (("source", u), ("target", v)):
                if type(end) is not str or end not in points:
                    raise self.fail(f"edges[{i}].{key}", f"must be the id of a point of the map, got {_shown(end)}")
            if u == v or (u, v) in ends or (v, u) in ends:
                raise self.fail(f"edges[{i}]", f"line {id!r} from {u!r} to {v!r}: a loop, or a second line there")
            ends.add((u, v))
            record["mass"] = mass
            bm._lines[id] = (u, v)
        g = bm.graph
        g.add_nodes_from(record["id"] for record in nodes)  # new, distinct: their attribute dicts come in this order
        for attrs, record in zip(g.nodes.values(), nodes, strict=True):
            attrs.update(record)
        add_edge = g.add_edge
        for (u, v), record in zip(bm._lines.values(), edges, strict=True):
            add_edge(u, v, **record)
        return bm

    def empty_map(self, attrs: dict[str, Any]) -> BeliefMap:
        version = attrs.get("schema_version")
        if version is None:
            raise self.fail("graph.schema_version", "missing: not a map file")
        if version != SCHEMA_VERSION or isinstance(version, bool):
            raise self.fail(
                "graph.schema_version", f"unknown schema version {_shown(version)} (this evmap reads {SCHEMA_VERSION})"
            )
        frame = attrs.get("frame")
        if not (isinstance(frame, list) and all(isinstance(e, str) for e in frame)):
            raise self.fail("graph.frame", f"must be a list of element names, got {_shown(frame)}")
        extras = {k: v for k, v in attrs.items() if k not in _GRAPH_KEYS}
        try:
            bm = BeliefMap(frame, attrs.get("rule"), **extras)
        except ValueError as exc:
            raise self.fail("graph", str(exc)) from None
        if "segments" in attrs:
            try:
                bm.segments = SegmentStore.from_json(attrs["segments"], bm.frame)
            except ValueError as exc:
                raise self.fail("graph.segments", str(exc)) from None
        if "open_space" in attrs:
            try:
                bm.open_space = _multipolygon(attrs["open_space"])
            except (ValueError, TypeError, shapely.errors.ShapelyError) as exc:
                raise self.fail("graph.open_space", str(exc)) from None
        return bm

    def record(self, d: Any, key: str, i: int, required: frozenset[str]) -> dict[str, Any]:
        """A shallow copy of one node or edge record (``data[key][i]``) with its common keys checked."""
        if type(d) is not dict:
            raise self.fail(f"{key}[{i}]", f"must be an object, got {_shown(d)}")
        if not d.keys() >= required:
            raise self.fail(f"{key}[{i}]", f"required keys {sorted(required - d.keys())} are missing")
        if not (type(d["id"]) is str and d["id"]):
            raise self.fail(f"{key}[{i}].id", f"must be a non-empty string, got {_shown(d['id'])}")
        if type(d["mass"]) is not dict:
            raise self.fail(f"{key}[{i}].mass", f"must be an object {{FOCAL: mass}}, got {_shown(d['mass'])}")
        history = d.get("history", [])
        if not (type(history) is list and all(type(r) is dict for r in history)):
            raise self.fail(f"{key}[{i}].history", "must be a list of objects")
        if self.owned:
            d["history"] = history
            return d
        return {**d, "history": [dict(r) for r in history]}  # fold appends to the history: not to the caller's

    def masses(self, codec: _MassCodec, records: list[dict[str, Any]], key: str) -> list[MassFunction]:
        try:
            return codec.decode([r["mass"] for r in records])
        except _BadMass as exc:
            raise self.fail(f"{key}[{exc.index}].mass", exc.problem) from None


def _belief_level(min_belief: float) -> float:
    if not (isinstance(min_belief, Real) and 0 <= min_belief <= 1):
        raise ValueError(f"min_belief must be a number in [0, 1], got {min_belief!r}")
    return float(min_belief)


def _xy(xy: Iterable[float], what: str) -> tuple[float, float]:
    try:
        x, y = xy
        point = (float(x), float(y))
    except (TypeError, ValueError):
        raise ValueError(f"{what}: a point must be (x, y), got {_shown(xy)}") from None
    if not (math.isfinite(point[0]) and math.isfinite(point[1])):
        raise ValueError(f"{what}: a point must have finite coordinates, got {point}")
    return point


def _kind(kind: str, id: str) -> str:
    if kind not in POINT_KINDS:
        raise ValueError(f"{id!r}: kind must be one of {list(POINT_KINDS)}, got {kind!r}")
    return kind


def _check_extras(attrs: Mapping[str, Any], reserved: tuple[str, ...], id: str) -> None:
    clash = sorted(set(attrs) & set(reserved))
    if clash:
        raise ValueError(f"{id!r}: attributes {clash} are reserved")
    _check_json(attrs, id)


def _history(history: Iterable[Mapping[str, Any]], id: str) -> list[dict[str, Any]]:
    records = [dict(record) for record in history]
    _check_json(records, f"{id}: history")
    return records


def _check_json(value: Any, where: str) -> None:
    """Refuse a value that JSON cannot carry exactly (so that ``save`` is lossless)."""
    problem = _json_problem(value, "")
    if problem:
        raise ValueError(f"{where}: {problem}")


def _json_problem(value: Any, path: str) -> str | None:
    kind = type(value)
    if value is None or kind is bool or kind is int or kind is str:
        return None
    if kind is float:
        return None if math.isfinite(value) else f"{path or 'value'}: {value!r} is not finite"
    if kind is list or kind is tuple:
        return next((p for i, v in enumerate(value) if (p := _json_problem(v, f"{path}[{i}]"))), None)
    if kind is dict:
        for k, v in value.items():
            if type(k) is not str:
                return f"{path or 'value'}: key {k!r} is not a string"
            if p := _json_problem(v, f"{path}.{k}" if path else k):
                return p
        return None
    return f"{path or 'value'}: a {kind.__name__} is not JSON (None, bool, int, finite float, str, list, dict)"


def _finite(value: Any) -> bool:
    return (type(value) is float or type(value) is int) and math.isfinite(value)


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _geojson(geometry: shapely.MultiPolygon) -> dict[str, Any]:
    """GeoJSON-like dict of a MultiPolygon, coordinates as nested lists (exact floats)."""
    if geometry.is_empty:
        return {"type": "MultiPolygon", "coordinates": []}
    _, coords, (ring_end, polygon_end, _) = shapely.to_ragged_array([geometry])
    rings = [ring.tolist() for ring in np.split(coords, ring_end[1:-1])]
    polygons = [rings[a:b] for a, b in zip(polygon_end[:-1].tolist(), polygon_end[1:].tolist(), strict=True)]
    return {"type": "MultiPolygon", "coordinates": polygons}


def _multipolygon(value: Any) -> shapely.MultiPolygon:
    """The MultiPolygon of :func:`_geojson`'s dict."""
    if not (
        isinstance(value, dict) and value.get("type") == "MultiPolygon" and isinstance(value.get("coordinates"), list)
    ):
        raise ValueError(f"must be {{'type': 'MultiPolygon', 'coordinates': [...]}}, got {_shown(value)}")
    polygons = value["coordinates"]
    if not polygons:
        return shapely.MultiPolygon()
    if not all(isinstance(p, list) and p and all(isinstance(r, list) for r in p) for p in polygons):
        raise ValueError("coordinates must be a list of polygons, each a non-empty list of rings")
    rings = [ring for polygon in polygons for ring in polygon]
    coords = np.array([xy for ring in rings for xy in ring], dtype=np.float64)
    if coords.ndim != 2 or coords.shape[1] != 2 or not np.isfinite(coords).all():
        raise ValueError("every coordinate must be [x, y] with finite numbers")
    offsets = (
        np.cumsum([0] + [len(ring) for ring in rings]),
        np.cumsum([0] + [len(polygon) for polygon in polygons]),
        np.array([0, len(polygons)]),
    )
    return shapely.from_ragged_array(shapely.GeometryType.MULTIPOLYGON, coords, offsets)[0]
