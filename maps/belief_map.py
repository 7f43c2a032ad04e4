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
:meth:`~BeliefMap.nearest_obstacle`, :meth:`~BeliefMap.is_segment_clear` (from
the grid of :meth:`~BeliefMap.near` and a cache of the obstacles' beliefs, both
kept up to date one object at a time: a query right after a change costs what
is near, not the map), the evidential occupancy grid
(:mod:`evmap.maps.occupancy`) and its ROS export, and lossless :meth:`~BeliefMap.save`
/ :meth:`~BeliefMap.load` of ``map.json`` (``docs/SCENARIO.md``).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Mapping
from itertools import chain, repeat
from numbers import Real
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import networkx as nx
import numpy as np
import orjson
import shapely
from numpy.typing import NDArray

from evidential import RULES, Frame, MassFunction, combine, conflict
from evmap.maps import map_json
from evmap.maps.occupancy import OccupancyParams, evidential_grid, occupancy_from_masses, write_atomic, write_ros_map
from evmap.maps.segments import SegmentStore
from evmap.maps.spatial import GridIndex
from evmap.sources.config import Config, config_from_data
from evmap.sources.loading import InputError

if TYPE_CHECKING:
    from evmap.maps.observation import Observation
    from evmap.maps.pipeline import PoseOutcome

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

NEAR_CELL = 2.0
"""Side (m) of the grid cells of :meth:`BeliefMap.near` and :meth:`BeliefMap.open_space_near`."""


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
            open_space=map_json.geojson(shapely.MultiPolygon()),
            **attrs,
        )
        self._lines: dict[str, tuple[str, str]] = {}
        self._spaces: list[shapely.Geometry] = []  # pieces whose union is the open space
        self._space_grid: GridIndex | None = None  # their boxes; made on first use, then kept
        self._open_space: shapely.MultiPolygon | None = shapely.MultiPolygon()  # their union; None: not yet made
        self._grids: tuple[GridIndex, GridIndex, GridIndex] | None = None  # points, lines, targets; on first use
        self._extent = [math.inf, math.inf, -math.inf, -math.inf]  # with the grids: holds every point they held
        self._obstacle_bel: dict[str, float] | None = None  # lines, unidentified points: Bel(real); on first use
        self._index: _Index | None = None
        self._config: Config | None = None
        self.segments = SegmentStore.empty(frame)
        """The raw LSL segments behind the lines (:class:`evmap.maps.segments.SegmentStore`)."""

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
        """The sonar open space, a (possibly empty) shapely MultiPolygon: the union of every observation's.

        Set it with a Polygon, a MultiPolygon, an empty geometry or None (that
        replaces it), or add to it with :meth:`add_open_space`; it is stored in
        the graph (``open_space``) as GeoJSON-like coordinate lists.
        """
        if self._open_space is None:
            union = shapely.union_all(self._spaces)
            self._open_space = union if isinstance(union, shapely.MultiPolygon) else map_json.as_multipolygon(union)
            self._graph.graph["open_space"] = map_json.geojson(self._open_space)
        return self._open_space

    @open_space.setter
    def open_space(self, geometry: shapely.Geometry | None) -> None:
        geometry = map_json.as_multipolygon(geometry)
        self._spaces = list(geometry.geoms)
        self._space_grid = None
        self._graph.graph["open_space"] = map_json.geojson(geometry)
        self._open_space = geometry
        self._changed()

    def add_open_space(self, geometry: shapely.Geometry) -> None:
        """Unite a (Multi)Polygon, one observation's open space say, with the map's open space.

        Cheap however large the map: the union is made when :attr:`open_space` is read.
        """
        geometry = map_json.as_multipolygon(geometry)
        for piece in geometry.geoms:
            if self._space_grid is not None:
                self._space_grid.insert(str(len(self._spaces)), piece.bounds)
            self._spaces.append(piece)
        self._open_space = None
        self._changed()

    def open_space_near(self, bounds: tuple[float, float, float, float]) -> shapely.Geometry:
        """The open space within the box ``bounds`` (xmin, ymin, xmax, ymax), and maybe some beyond it.

        Equal to :attr:`open_space` inside the box; it costs what the box holds, not the whole map.
        """
        if self._space_grid is None:
            keys = [str(k) for k in range(len(self._spaces))]
            with map_json.gc_paused():  # a container for every cell a piece meets, none of them garbage
                self._space_grid = GridIndex.from_boxes(NEAR_CELL, keys, shapely.bounds(self._spaces))
        pieces = [self._spaces[int(k)] for k in self._space_grid.query(bounds)]
        return shapely.union_all(pieces) if pieces else shapely.MultiPolygon()

    def near(self, bounds: tuple[float, float, float, float], what: str = "all") -> set[str]:
        """Ids of the points (``what="points"``), lines (``"lines"``) or both whose boxes may meet ``bounds``.

        A superset, from a grid of :data:`NEAR_CELL` cells kept up to date as the
        map changes: the cost grows with what is near, not with the map.

        >>> from evidential import MassFunction
        >>> bm = BeliefMap(["real", "noise"])
        >>> m = MassFunction(bm.frame, {"real": 1.0})
        >>> bm.add_point("A", (0, 0), "corner", m); bm.add_point("B", (4, 0), "endpoint", m)
        >>> bm.add_line("L1", "A", "B", m)
        >>> sorted(bm.near((3.5, -0.5, 4.5, 0.5))), sorted(bm.near((3.5, -0.5, 4.5, 0.5), "lines"))
        (['B', 'L1'], ['L1'])
        """
        points, lines, _ = self._near_grids()
        if what == "points":
            return points.query(bounds)
        if what == "lines":
            return lines.query(bounds)
        if what == "all":
            return points.query(bounds) | lines.query(bounds)
        raise ValueError(f"what must be 'points', 'lines' or 'all', got {what!r}")

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
        self._grid_point(id)
        self._track(id)
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
        if self._grids is not None:
            self._grids[1].insert(id, self._line_bounds(id))
        self._track(id)
        self._changed()

    def remove_line(self, id: str) -> None:
        """Remove the line ``id`` (its end points stay)."""
        if id not in self._lines:
            raise KeyError(f"{id!r} is not a line of the map")
        self._graph.remove_edge(*self._lines.pop(id))
        if self._grids is not None:
            self._grids[1].remove(id)
        self._untrack(id)
        self._changed()

    def remove_point(self, id: str) -> None:
        """Remove the point ``id``; it must end no line (remove those first)."""
        if id not in self._graph:
            raise KeyError(f"{id!r} is not a point of the map")
        ending = sorted(d["id"] for _, _, d in self._graph.edges(id, data=True))
        if ending:
            raise ValueError(f"point {id!r} still ends lines {ending}; remove them first")
        self._graph.remove_node(id)
        if self._grids is not None:
            self._grids[0].remove(id)
            if id in self._grids[2]:
                self._grids[2].remove(id)
        self._untrack(id)
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
        map_json.check_json({k: v for k, v in attrs.items() if k not in ("mass", "xy")}, id)
        if "mass" in attrs:
            checked["mass"] = self._check_mass(attrs["mass"], id)
        if "xy" in attrs:
            checked["xy"] = _xy(attrs["xy"], id)
        if "kind" in attrs:
            checked["kind"] = _kind(attrs["kind"], id)
        if "history" in attrs:
            checked["history"] = _history(attrs["history"], id)
        data.update(checked)
        if "xy" in checked or "kind" in checked:
            self._grid_point(id)
        if "xy" in checked and self._grids is not None:  # the point's lines moved with it
            for _, _, line in self._graph.edges(id, data=True):
                self._grids[1].insert(line["id"], self._line_bounds(line["id"]))
        if "mass" in checked or "kind" in checked:
            self._track(id)
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
        map_json.check_json(record, f"{id}: record")
        combined = combine(data["mass"], mass, rule=self.rule)
        data["history"].append(
            {**record, "rule": self.rule, "conflict": conflict(data["mass"], mass), "mass": mass.to_dict()}
        )
        data["mass"] = combined
        self._track(id)
        self._changed()
        return combined

    # ----------------------------------------------------------------- observations

    @property
    def config(self) -> Config:
        """The config the map folds observations with (stored in the graph as ``config``).

        Maps made by :func:`evmap.maps.pipeline.new_map` (and so by ``evmap run``) carry one.
        """
        if self._config is None:
            if "config" not in self._graph.graph:
                raise ValueError("this map carries no config: make maps to update with maps.pipeline.new_map(config)")
            self._config = config_from_data(self._graph.graph["config"], "map config")
        return self._config

    def update(self, observation: Observation) -> PoseOutcome:
        """Fold in one pose's observation by the paper's pipeline (:func:`evmap.maps.pipeline.fold_observation`)."""
        from evmap.maps.pipeline import fold_observation  # the pipeline builds on this class

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
            ix.point(i) for i in np.flatnonzero(ix.point_kind == "corner") if g.nodes[ix.point_ids[i]].get("reinforced")
        ]
        return found

    def nearest_obstacle(self, xy: Iterable[float], min_belief: float = 0.5) -> tuple[float, str | None]:
        """Distance from ``xy`` to the nearest obstacle, and its id.

        Obstacles are the lines and the unidentified objects whose belief
        Bel(real) is at least ``min_belief``; the distance to an unidentified
        object is the distance to its point. ``(inf, None)`` when there is none.
        Of equally near obstacles, the one with the smallest id.

        The search looks at squares of :data:`NEAR_CELL` cells growing around
        ``xy`` (3, 5, 9, 17, 33... cells a side) until the nearest obstacle
        found is nearer than the square's border, or the square holds the
        whole map: its cost grows with the obstacles near ``xy``, not with the map.
        """
        x, y = _xy(xy, "xy")
        level = _belief_level(min_belief)
        points, lines, targets = self._near_grids()
        xmin, ymin, xmax, ymax = self._extent
        if not len(points):
            return math.inf, None
        s = NEAR_CELL
        i, j = math.floor(x / s), math.floor(y / s)
        e0, e1, e2, e3 = math.floor(xmin / s), math.floor(ymin / s), math.floor(xmax / s), math.floor(ymax / s)
        here = np.array([x, y])
        seen: set[str] = set()
        best, best_id = math.inf, None
        k = 1
        while True:  # the cells i - k .. i + k by j - k .. j + k, as far as the map reaches (queried at their centres)
            i0, j0, i1, j1 = max(i - k, e0), max(j - k, e1), min(i + k, e2), min(j + k, e3)
            if i0 <= i1 and j0 <= j1:
                box = ((i0 + 0.5) * s, (j0 + 0.5) * s, (i1 + 0.5) * s, (j1 + 0.5) * s)
                found = (lines.query(box) | targets.query(box)) - seen
                seen |= found
                ids, p, q = self._obstacles(found, level)
                if ids:
                    distance = _point_segment_distances(here, p, q)
                    n = int(np.argmin(distance))  # the first of the nearest: the smallest id
                    if distance[n] < best or (distance[n] == best and ids[n] < best_id):
                        best, best_id = float(distance[n]), ids[n]
            border = min(x - (i - k) * s, y - (j - k) * s, (i + k + 1) * s - x, (j + k + 1) * s - y)
            if best < border or (i - k <= e0 and j - k <= e1 and i + k >= e2 and j + k >= e3):
                return best, best_id
            k *= 2

    def is_segment_clear(
        self, a: Iterable[float], b: Iterable[float], clearance: float = 0.2, min_belief: float = 0.5
    ) -> bool:
        """True if every obstacle is farther than ``clearance`` from the segment ``a``-``b``.

        Obstacles as in :meth:`nearest_obstacle`; the candidates are those in
        the :data:`NEAR_CELL` cells of the segment's box grown by ``clearance``.
        """
        a, b = _xy(a, "a"), _xy(b, "b")
        if not (isinstance(clearance, Real) and 0 <= clearance < math.inf):
            raise ValueError(f"clearance must be a finite number >= 0 (m), got {clearance!r}")
        level = _belief_level(min_belief)
        _, lines, targets = self._near_grids()
        xmin, ymin, xmax, ymax = self._extent
        box = (
            max(min(a[0], b[0]) - clearance, xmin),
            max(min(a[1], b[1]) - clearance, ymin),
            min(max(a[0], b[0]) + clearance, xmax),
            min(max(a[1], b[1]) + clearance, ymax),
        )  # within the map's extent: a huge clearance costs no more than the map
        if not (box[0] <= box[2] and box[1] <= box[3]):
            return True
        ids, p, q = self._obstacles(lines.query(box) | targets.query(box), level)
        return not ids or bool((_segment_distances(np.array(a), np.array(b), p, q) > clearance).all())

    def occupancy_masses(
        self, resolution: float = 0.05, params: OccupancyParams | None = None
    ) -> tuple[NDArray[np.float64], tuple[float, float]]:
        """The evidential occupancy grid: masses (rows, columns, 4) and origin (x, y).

        Columns of the last axis: m(∅), m(free), m(occupied), m(free|occupied);
        row 0 is the lowest y; ``origin`` is the lower-left corner of cell (0, 0).
        Free evidence from the open space, occupied evidence from every line,
        corner and unidentified object weighted by its belief, combined by the
        map's rule (see :mod:`evmap.maps.occupancy`).
        """
        ix = self._current()
        solid = ix.point_kind != "endpoint"
        xy = ix.xy[solid]
        p = np.concatenate([ix.p, xy])
        q = np.concatenate([ix.q, xy])
        belief = np.concatenate([ix.line_bel, ix.point_bel[solid]])
        everything = np.concatenate([ix.xy, shapely.get_coordinates(self.open_space)])
        if not len(everything):
            raise ValueError("the map is empty (no points, no open space): an occupancy grid has no extent")
        bounds = (*everything.min(axis=0), *everything.max(axis=0))
        return evidential_grid(self.open_space, p, q, belief, bounds, resolution, self.rule, params)

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

        See :func:`evmap.maps.occupancy.write_ros_map`. Returns the two paths.
        """
        masses, origin = self.occupancy_masses(resolution, params)
        return write_ros_map(occupancy_from_masses(masses, params), resolution, origin, path_stem)

    # ----------------------------------------------------------------- files

    def to_data(self) -> dict[str, Any]:
        """The map as ``networkx.node_link_data(G, edges="edges")``, masses as ``{FOCAL: float}``.

        Each edge's ``source`` -> ``target`` is the line's ``u`` -> ``v``; nodes
        and edges in insertion order. The records are new dicts; their values
        (histories, extras) are the map's own.
        """
        with map_json.gc_paused():
            g = self._graph
            points = [d for _, d in g.nodes(data=True)]
            adj = dict(g.adjacency())
            lines = [adj[u][v] for u, v in self._lines.values()]
            encode = map_json.MassCodec(self._frame).encode
            nodes = [{**d, "mass": m} for d, m in zip(points, encode([d["mass"] for d in points]), strict=True)]
            edges = [
                {**d, "mass": m, "source": u, "target": v}
                for d, m, (u, v) in zip(lines, encode([d["mass"] for d in lines]), self._lines.values(), strict=True)
            ]
            graph = {**g.graph, "open_space": map_json.geojson(self.open_space), "segments": self.segments.to_json()}
            return {"directed": False, "multigraph": False, "graph": graph, "nodes": nodes, "edges": edges}

    @classmethod
    def from_data(cls, data: Any, name: str = "map") -> BeliefMap:
        """Build a map from :meth:`to_data`'s layout; :class:`MapFileError` names ``name`` and the problem."""
        with map_json.gc_paused():
            return _MapReader(name).read(data)

    def save(self, path: str | Path) -> None:
        """Write the map to ``path`` as JSON (``map.json`` of ``docs/SCENARIO.md``), atomically.

        Lossless: floats are written in their shortest round-tripping form and
        read back bit-exact; every attribute and the history round-trip (tuples
        come back as lists, except ``xy``).
        """
        map_json.check_json({k: v for k, v in self._graph.graph.items() if k not in _GRAPH_KEYS}, "graph")
        try:
            with map_json.gc_paused():
                text = orjson.dumps(self.to_data())  # the records are freed before the file is written
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
        with map_json.gc_paused():
            try:
                data = orjson.loads(text)
            except orjson.JSONDecodeError as exc:
                raise MapFileError(f"{path}: not valid JSON (truncated or corrupt?): {exc}") from None
            del text  # free the file's bytes before the map is built: a big map needs the memory
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

    def _near_grids(self) -> tuple[GridIndex, GridIndex, GridIndex]:
        """The grids of points, lines and unidentified points: made from the whole map on first use, then kept.

        With them :attr:`_extent`, a box (xmin, ymin, xmax, ymax) that holds every
        point (and so every line): it grows as points are added or moved, never shrinks.
        """
        if self._grids is None:
            with map_json.gc_paused():  # hundreds of thousands of new containers, none of them garbage
                self._grids = self._make_grids()
        return self._grids

    def _make_grids(self) -> tuple[GridIndex, GridIndex, GridIndex]:
        g = self._graph
        ids = list(g)
        xy = np.array([xy for _, xy in g.nodes(data="xy")], dtype=np.float64).reshape(-1, 2)
        target = np.array([kind == "unidentified" for _, kind in g.nodes(data="kind")], dtype=bool)
        index = dict(zip(ids, range(len(ids)), strict=True))
        ends = np.array([(index[u], index[v]) for u, v in self._lines.values()], dtype=np.intp).reshape(-1, 2)
        p, q = xy[ends[:, 0]], xy[ends[:, 1]]
        if ids:
            self._extent = [*xy.min(axis=0).tolist(), *xy.max(axis=0).tolist()]
        return (
            GridIndex.from_boxes(NEAR_CELL, ids, np.hstack([xy, xy])),
            GridIndex.from_boxes(NEAR_CELL, list(self._lines), np.hstack([np.minimum(p, q), np.maximum(p, q)])),
            GridIndex.from_boxes(
                NEAR_CELL, [n for n, t in zip(ids, target.tolist()) if t], np.hstack([xy, xy])[target]
            ),
        )

    def _grid_point(self, id: str) -> None:
        """Put the point ``id`` in the grids (if made) at its place, within the extent (new, moved or of a new kind)."""
        if self._grids is not None:
            points, _, targets = self._grids
            data = self._graph.nodes[id]
            x, y = data["xy"]
            points.insert(id, (x, y, x, y))
            if data["kind"] == "unidentified":
                targets.insert(id, (x, y, x, y))
            elif id in targets:
                targets.remove(id)
            xmin, ymin, xmax, ymax = self._extent
            self._extent = [min(xmin, x), min(ymin, y), max(xmax, x), max(ymax, y)]

    def _obstacle_beliefs(self) -> dict[str, float]:
        """Bel(real) of every obstacle (line, unidentified point) by id: made in bulk on first use, then kept."""
        if self._obstacle_bel is None:
            g = self._graph
            targets = [n for n, kind in g.nodes(data="kind") if kind == "unidentified"]
            masses = [g.adj[u][v]["mass"] for u, v in self._lines.values()] + [g.nodes[n]["mass"] for n in targets]
            belief, _ = _belief_plausibility(masses, self._frame.mask("real"))
            self._obstacle_bel = dict(zip([*self._lines, *targets], belief.tolist(), strict=True))
        return self._obstacle_bel

    def _track(self, id: str) -> None:
        """Bring the belief cache up to date with the object ``id`` (new, or its mass or kind changed)."""
        if self._obstacle_bel is not None:
            data = self._data(id)
            if id in self._lines or data["kind"] == "unidentified":
                self._obstacle_bel[id] = data["mass"].belief("real")
            else:
                self._obstacle_bel.pop(id, None)

    def _untrack(self, id: str) -> None:
        """Forget the removed object ``id`` in the belief cache."""
        if self._obstacle_bel is not None:
            self._obstacle_bel.pop(id, None)

    def _obstacles(
        self, ids: Iterable[str], level: float
    ) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
        """Of ``ids``, the obstacles with a belief of at least ``level`` (sorted), and their ends p, q (n, 2).

        An unidentified object is a segment of length zero (p = q).
        """
        belief = self._obstacle_beliefs()
        kept = sorted(id for id in ids if belief.get(id, -1.0) >= level)
        nodes, lines = self._graph.nodes, self._lines
        ends = [lines.get(id, (id, id)) for id in kept]
        p = np.array([nodes[u]["xy"] for u, _ in ends], dtype=float).reshape(-1, 2)
        q = np.array([nodes[v]["xy"] for _, v in ends], dtype=float).reshape(-1, 2)
        return kept, p, q

    def _line_bounds(self, id: str) -> tuple[float, float, float, float]:
        u, v = self._lines[id]
        (x0, y0), (x1, y1) = self._graph.nodes[u]["xy"], self._graph.nodes[v]["xy"]
        return min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)

    def _changed(self) -> None:
        self._index = None

    def _current(self) -> _Index:
        if self._index is None:
            with map_json.gc_paused():
                self._index = _Index(self._graph, self._lines, self._frame.mask("real"))
        return self._index

    def _points(self, kind: str, min_belief: float) -> list[Point]:
        ix = self._current()
        keep = np.flatnonzero((ix.point_kind == kind) & (ix.point_bel >= _belief_level(min_belief)))
        return [ix.point(i) for i in keep]


class _Index:
    """Arrays of one state of the map, for the listings and the occupancy grid; rebuilt after a change."""

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


def _point_segment_distances(
    xy: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distances from points ``xy`` to segments ``p``-``q`` (arrays (..., 2) that broadcast; p = q: a point)."""
    d = q - p
    length2 = (d * d).sum(axis=-1)
    t = np.clip(((xy - p) * d).sum(axis=-1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    gap = p + t[..., None] * d - xy
    return np.hypot(gap[..., 0], gap[..., 1])


def _segment_distances(
    a: NDArray[np.float64], b: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distances from the segment ``a``-``b`` (points (2,)) to each segment ``p``-``q`` ((n, 2); p = q: a point).

    Zero where they cross; else the least of the four end-to-segment distances.
    """

    def side(o: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])

    sp, sq, sa, sb = side(a, b, p), side(a, b, q), side(p, q, a), side(p, q, b)
    cross = (sp * sq <= 0) & (sa * sb <= 0) & ~((sp == 0) & (sq == 0))  # collinear: the ends' distances say it
    ends = np.minimum(
        np.minimum(_point_segment_distances(a, p, q), _point_segment_distances(b, p, q)),
        np.minimum(_point_segment_distances(p, a, b), _point_segment_distances(q, a, b)),
    )
    return np.where(cross, 0.0, ends)


class _MapReader:
    """Checks the node-link layout of a map file and builds the map; errors name the file and the place.

    Each part is first checked in bulk, quickly; only where that check fails
    are the records gone through one by one, to find the first problem and
    name its place.
    """

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
        codec = map_json.MassCodec(bm.frame)
        nodes = self.records(data["nodes"], "nodes", _NODE_REQUIRED, frozenset())
        xy = self.points(nodes)
        kinds = [d["kind"] for d in nodes]
        if not all(map(POINT_KINDS.__contains__, kinds)):
            i = next(i for i, kind in enumerate(kinds) if kind not in POINT_KINDS)
            raise self.fail(f"nodes[{i}].kind", f"must be one of {list(POINT_KINDS)}, got {map_json.shown(kinds[i])}")
        masses = self.masses(codec, nodes, "nodes")
        ids = [d["id"] for d in nodes]
        points = frozenset(ids)
        edges = self.records(data["edges"], "edges", _EDGE_REQUIRED, points)
        ends = self.ends(edges, points)
        for d, mass in zip(edges, self.masses(codec, edges, "edges"), strict=True):
            d["mass"] = mass
        g = bm.graph
        g.add_nodes_from(ids)
        for (_, attrs), d, point, mass in zip(g.nodes(data=True), nodes, xy, masses, strict=True):  # in this order
            attrs.update(d)
            attrs["xy"] = point
            attrs["mass"] = mass
        g.add_edges_from([(u, v, d) for (u, v), d in zip(ends, edges, strict=True)])
        bm._lines = dict(zip([d["id"] for d in edges], ends, strict=True))
        return bm

    def empty_map(self, attrs: dict[str, Any]) -> BeliefMap:
        version = attrs.get("schema_version")
        if version is None:
            raise self.fail("graph.schema_version", "missing: not a map file")
        if version != SCHEMA_VERSION or isinstance(version, bool):
            raise self.fail(
                "graph.schema_version",
                f"unknown schema version {map_json.shown(version)} (this evmap reads {SCHEMA_VERSION})",
            )
        frame = attrs.get("frame")
        if not (isinstance(frame, list) and all(isinstance(e, str) for e in frame)):
            raise self.fail("graph.frame", f"must be a list of element names, got {map_json.shown(frame)}")
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
                bm.open_space = map_json.multipolygon(attrs["open_space"])
            except (ValueError, TypeError, shapely.errors.ShapelyError) as exc:
                raise self.fail("graph.open_space", str(exc)) from None
        return bm

    def records(
        self, raw: list[Any], key: str, required: frozenset[str], taken: frozenset[str]
    ) -> list[dict[str, Any]]:
        """The records ``data[key]`` with their ``id`` (new, not in ``taken``), ``mass`` and ``history`` checked.

        Copies, unless the records are ours (``owned``); ``history`` defaults to ``[]``.
        """
        if not _records_look_right(raw, required, taken):
            self.check_records(raw, key, required, taken)
        if not self.owned:  # fold appends to a history: not to the caller's
            return [{**d, "history": [dict(r) for r in d.get("history", ())]} for d in raw]
        for d in raw:
            if "history" not in d:
                d["history"] = []
        return raw

    def check_records(self, raw: list[Any], key: str, required: frozenset[str], taken: frozenset[str]) -> None:
        """What :meth:`records` checks, record by record: raise at the first problem."""
        ids = set(taken)
        for i, d in enumerate(raw):
            if type(d) is not dict:
                raise self.fail(f"{key}[{i}]", f"must be an object, got {map_json.shown(d)}")
            if not d.keys() >= required:
                raise self.fail(f"{key}[{i}]", f"required keys {sorted(required - d.keys())} are missing")
            id = d["id"]
            if not (type(id) is str and id):
                raise self.fail(f"{key}[{i}].id", f"must be a non-empty string, got {map_json.shown(id)}")
            if id in ids:
                raise self.fail(f"{key}[{i}].id", f"id {id!r} is used twice")
            ids.add(id)
            if type(d["mass"]) is not dict:
                raise self.fail(
                    f"{key}[{i}].mass", f"must be an object {{FOCAL: mass}}, got {map_json.shown(d['mass'])}"
                )
            history = d.get("history", [])
            if not (type(history) is list and all(type(r) is dict for r in history)):
                raise self.fail(f"{key}[{i}].history", "must be a list of objects")

    def points(self, nodes: list[dict[str, Any]]) -> list[tuple[float, float]]:
        """The nodes' ``xy`` as tuples of floats; one that is not ``[x, y]`` of finite numbers fails at its place."""
        xys = [d["xy"] for d in nodes]
        if set(map(type, xys)) <= {list, tuple} and set(map(len, xys)) <= {2}:
            flat = list(chain.from_iterable(xys))
            if set(map(type, flat)) <= {float, int} and all(map(map_json.finite, flat)):
                return list(zip(map(float, flat[0::2]), map(float, flat[1::2]), strict=True))
        for i, xy in enumerate(xys):
            if not (type(xy) in (list, tuple) and len(xy) == 2 and map_json.finite(xy[0]) and map_json.finite(xy[1])):
                raise self.fail(f"nodes[{i}].xy", f"must be [x, y] with two finite numbers, got {map_json.shown(xy)}")
        return [(float(x), float(y)) for x, y in xys]

    def ends(self, edges: list[dict[str, Any]], points: frozenset[str]) -> list[tuple[str, str]]:
        """The ends ``(source, target)`` of each line, taken out of its record, checked, with the line's kind."""
        us = list(map(dict.pop, edges, repeat("source")))
        vs = list(map(dict.pop, edges, repeat("target")))
        if not (
            [d["kind"] for d in edges].count(LINE_KIND) == len(edges)
            and set(map(type, chain(us, vs))) <= {str}
            and points.issuperset(us)
            and points.issuperset(vs)
            and not any(map(operator.eq, us, vs))
            and len(set(map(frozenset, zip(us, vs, strict=True)))) == len(edges)  # one line per pair of points
        ):
            seen: set[tuple[str, str]] = set()
            for i, (d, u, v) in enumerate(zip(edges, us, vs, strict=True)):
                if d["kind"] != LINE_KIND:
                    raise self.fail(f"edges[{i}].kind", f"must be {LINE_KIND!r}, got {map_json.shown(d['kind'])}")
                for end, name in ((u, "source"), (v, "target")):
                    if not (type(end) is str and end in points):
                        problem = f"must be the id of a point of the map, got {map_json.shown(end)}"
                        raise self.fail(f"edges[{i}].{name}", problem)
                if u == v or (u, v) in seen or (v, u) in seen:
                    problem = f"line {d['id']!r} from {u!r} to {v!r}: a loop, or a second line there"
                    raise self.fail(f"edges[{i}]", problem)
                seen.add((u, v))
        return list(zip(us, vs, strict=True))

    def masses(self, codec: map_json.MassCodec, records: list[dict[str, Any]], key: str) -> list[MassFunction]:
        try:
            return codec.decode([r["mass"] for r in records])
        except map_json.BadMass as exc:
            raise self.fail(f"{key}[{exc.index}].mass", exc.problem) from None


_NO_HISTORY: list[Any] = []
"""What :func:`_records_look_right` reads as the history of a record without one (never stored)."""


def _records_look_right(raw: list[Any], required: frozenset[str], taken: frozenset[str]) -> bool:
    """True if :meth:`_MapReader.check_records` would find no problem; a quick check in bulk (False: look closer)."""
    if not (set(map(type, raw)) <= {dict} and all(map(operator.le, repeat(required), map(dict.keys, raw)))):
        return False
    ids = [d["id"] for d in raw]
    if not set(map(type, ids)) <= {str} or "" in ids:
        return False
    unique = set(ids)
    histories = [d.get("history", _NO_HISTORY) for d in raw]
    return (
        len(unique) == len(ids)
        and unique.isdisjoint(taken)
        and set(map(type, [d["mass"] for d in raw])) <= {dict}
        and set(map(type, histories)) <= {list}
        and set(map(type, chain.from_iterable(histories))) <= {dict}
    )


def _belief_level(min_belief: float) -> float:
    if not (isinstance(min_belief, Real) and 0 <= min_belief <= 1):
        raise ValueError(f"min_belief must be a number in [0, 1], got {min_belief!r}")
    return float(min_belief)


def _xy(xy: Iterable[float], what: str) -> tuple[float, float]:
    try:
        x, y = xy
        point = (float(x), float(y))
    except (TypeError, ValueError):
        raise ValueError(f"{what}: a point must be (x, y), got {map_json.shown(xy)}") from None
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
    map_json.check_json(attrs, id)


def _history(history: Iterable[Mapping[str, Any]], id: str) -> list[dict[str, Any]]:
    records = [dict(record) for record in history]
    map_json.check_json(records, f"{id}: history")
    return records
