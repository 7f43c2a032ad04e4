"""The line-corner belief map: a graph of points and lines with mass functions.

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
sonar open space as GeoJSON-like MultiPolygon coordinates), and for maps that
fold observations ``config``, ``poses``, ``next_id`` and ``corners_deferred``.

:class:`BeliefMap` is the data: the graph, its mutation and its ids. What it
keeps beside the graph is kept by objects of their own modules: the points and
lines with their spatial indexes, undo log, change journal and running masses
(:mod:`~evmap.maps.map_objects`), the open space in pieces
(:mod:`~evmap.maps.open_space_pieces`), the raw segments
(:mod:`~evmap.maps.segments`). Change the map through its methods;
:attr:`BeliefMap.graph` (:mod:`~evmap.maps.map_graph`: networkx's layout in plain
dicts, ``to_networkx()`` for networkx's algorithms) is for reading, by algorithms
written as plain functions of a graph. Its other methods are one-line calls of the free functions around
it: the pipeline (:mod:`evmap.maps.pipeline`), the planner's queries
(:mod:`evmap.maps.planner`), the occupancy grid (:mod:`evmap.maps.occupancy`)
and the map file (:mod:`evmap.maps.map_file`, ``map.json`` of ``docs/SCENARIO.md``).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import RULES, Frame, MassFunction
from evmap.maps import map_file, map_json, occupancy, planner, rebuild
from evmap.maps.all_or_nothing import all_or_nothing
from evmap.maps.free_space import free_space, surface_points
from evmap.maps.map_checks import check_extras
from evmap.maps.map_format import CORNERS_DEFERRED, GRAPH_KEYS, ID_PREFIXES, SCHEMA_VERSION, MapParts
from evmap.maps.map_graph import MapGraph
from evmap.maps.map_objects import MapObjects
from evmap.maps.observation import Observation
from evmap.maps.occupancy import OccupancyParams
from evmap.maps.open_space_pieces import OpenSpacePieces
from evmap.maps.pipeline import PoseOutcome, fold_observation
from evmap.maps.planner import Line, Point
from evmap.maps.segments import SegmentStore
from evmap.maps.spatial import Bounds
from evmap.sources.config import config_from_data
from evmap.sources.config_model import Config

__all__ = ["BeliefMap", "new_map"]


class BeliefMap:
    """The paper's line-corner map with beliefs, on a :class:`~evmap.maps.map_graph.MapGraph`.

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
    >>> round(bm["L1"].belief, 2), bm.graph.edge("C1", "E1")["history"][0]["rule"]
    (0.8, 'dempster')
    >>> bm.open_space = shapely.box(-1, -1, 3, 2)  # what the sonar saw free
    >>> bm.is_segment_clear((0.0, 1.0), (2.0, 1.0), clearance=0.2), bm.is_segment_clear((1.0, 1.0), (1.0, 0.1))
    (True, False)
    >>> grid = bm.occupancy_grid(resolution=0.1)
    >>> grid.dtype, grid.shape, int(grid.max())
    (dtype('int8'), (35, 45), 90)
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
        check_extras(attrs, GRAPH_KEYS, "graph")
        self._frame = frame
        self._graph = MapGraph(
            schema_version=SCHEMA_VERSION,
            frame=list(frame.elements),
            rule=rule,
            open_space=map_json.geojson(shapely.MultiPolygon()),
            **attrs,
        )
        self._objects = MapObjects(self._graph, frame)
        self._lines = self._objects.lines  # id -> end points
        self._space = OpenSpacePieces(self._graph)
        self._config: Config | None = None
        self._vacuous = MassFunction(frame, {frame.full: 1.0})  # a value: one serves every vacuous point
        self.segments = SegmentStore.empty(frame)
        """The raw LSL segments behind the lines (:class:`evmap.maps.segments.SegmentStore`)."""

    def __repr__(self) -> str:
        return (
            f"BeliefMap(points={self._graph.number_of_nodes()}, lines={len(self._lines)}, "
            f"frame={list(self._frame.elements)}, rule={self.rule!r})"
        )

    # ----------------------------------------------------------------- what the map is

    @property
    def frame(self) -> Frame:
        """The frame of every mass function of the map."""
        return self._frame

    @property
    def rule(self) -> str:
        """The combination rule of :meth:`fold`."""
        return self._graph.graph["rule"]

    @property
    def graph(self) -> MapGraph:
        """The points (nodes by id) and lines (edges) as dicts; read them, change the map by its methods.
        ``bm.graph.to_networkx()`` is a :class:`networkx.Graph` of it for networkx's algorithms."""
        return self._graph

    @property
    def version(self) -> int:
        """A number that changes whenever the map does: what is derived from the map is kept by it."""
        return self._objects.journal.version

    def changed_since(self, version: int) -> set[str] | None:
        """The ids of the objects added, changed or removed since ``version``; None if the map no longer knows.
        What is derived from the map (the planner's obstacle trees) catches up with them, not made anew."""
        return self._objects.journal.since(version)

    @property
    def poses(self) -> tuple[int, ...]:
        """The indexes of the poses folded into the map, in the order they were folded."""
        return tuple(self._graph.graph.get("poses", ()))

    @property
    def corners_deferred(self) -> bool:
        """Whether updates without sonar left line ends free that :meth:`join_corners` has not joined since
        (:mod:`evmap.maps.pipeline`; ``graph.corners_deferred``); the update that starts it sets it."""
        return self._graph.graph.get(CORNERS_DEFERRED, False)

    @corners_deferred.setter
    def corners_deferred(self, deferred: bool) -> None:
        self._objects.defer_corners(deferred)

    def join_corners(self) -> set[str]:
        """If :attr:`corners_deferred`, join the line ends into corners over the whole map, all or nothing
        (:func:`evmap.maps.rebuild.join_corners`); the ids of the lines (none if nothing was deferred)."""
        if not self.corners_deferred:
            return set()
        with map_json.gc_paused(), self.transaction():
            self.corners_deferred = False
            return rebuild.join_corners(self, self.config)

    @property
    def config(self) -> Config:
        """The config the map folds observations with (stored in the graph as ``config``); maps made by
        :func:`new_map` (and so by ``evmap run``) carry one."""
        if self._config is None:
            if "config" not in self._graph.graph:
                raise ValueError("this map carries no config: make maps to update with evmap.maps.new_map(config)")
            self._config = config_from_data(self._graph.graph["config"], "map config")
        return self._config

    def __contains__(self, id: object) -> bool:
        return id in self._objects

    def __len__(self) -> int:
        """The number of objects: points and lines."""
        return len(self._objects)

    def __getitem__(self, id: str) -> Line | Point:
        """The line or point ``id`` as the planner sees it (with its belief)."""
        return self._objects.view(id)

    def is_line(self, id: str) -> bool:
        """True if ``id`` is a line of the map."""
        return id in self._lines

    def line_ids(self) -> Iterator[str]:
        """The ids of the lines, in insertion order."""
        return iter(self._lines)

    def ends(self, id: str) -> tuple[str, str]:
        """The end points ``(u, v)`` of the line ``id``."""
        try:
            return self._lines[id]
        except KeyError:
            raise KeyError(f"{id!r} is not a line of the map") from None

    def mass(self, id: str) -> MassFunction:
        """The mass function of the object ``id``."""
        return self._objects.data(id)["mass"]

    def vacuous(self) -> MassFunction:
        """The vacuous mass function over the map's frame (all mass on the whole frame)."""
        return self._vacuous

    # ----------------------------------------------------------------- open space

    @property
    def open_space(self) -> shapely.MultiPolygon:
        """The sonar open space, a (possibly empty) shapely MultiPolygon: the union of every observation's.

        Set it with a Polygon, a MultiPolygon, an empty geometry or None (that replaces it), or add to it with
        :meth:`add_open_space`; the union is made when it is read (:mod:`~evmap.maps.open_space_pieces`), and
        :meth:`open_space_near` reads pieces near a box only.
        """
        return self._space.union()

    @open_space.setter
    def open_space(self, geometry: shapely.Geometry | None) -> None:
        self._space.replace(geometry)
        self._objects.changed()

    def add_open_space(self, geometry: shapely.Geometry) -> None:
        """Unite a (Multi)Polygon, one observation's open space say, with the map's open space."""
        self._space.add(geometry)
        self._objects.changed()

    def open_space_near(self, bounds: Bounds) -> shapely.Geometry:
        """The open space within the box ``bounds``, and maybe some beyond it; costs what the box holds."""
        return self._space.near(bounds)

    def open_space_parts_near(self, bounds: Bounds) -> shapely.GeometryCollection:
        """:meth:`open_space_near` as a collection of polygons, maybe overlapping, not united (cheaper)."""
        return shapely.GeometryCollection(self._space.parts_near(bounds))

    def near(self, bounds: Bounds | NDArray[np.float64], what: str = "all") -> set[str]:
        """Ids of the ``"points"``, ``"lines"``, ``"obstacles"`` (lines and unidentified points) or ``"all"`` whose
        box meets ``bounds`` (xmin, ymin, xmax, ymax) or one of an (n, 4) array's (:mod:`evmap.maps.map_index`)."""
        return self._objects.index.near(bounds, what)

    def extent(self) -> Bounds:
        """A box holding every point the map has held (``(inf, inf, -inf, -inf)`` before the first)."""
        return self._objects.index.extent()

    # ----------------------------------------------------------------- building

    def add_point(
        self, id: str, xy: Iterable[float], kind: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a point ``id`` at ``xy`` of ``kind`` (corner, endpoint, unidentified) (:class:`MapObjects`)."""
        self._objects.add_point(id, xy, kind, mass, history, **attrs)

    def add_line(
        self, id: str, u: str, v: str, mass: MassFunction, history: Iterable[Mapping] = (), **attrs: Any
    ) -> None:
        """Add a line ``id`` from point ``u`` to point ``v`` (:class:`MapObjects`)."""
        self._objects.add_line(id, u, v, mass, history, **attrs)

    def remove_line(self, id: str) -> None:
        """Remove the line ``id`` (its end points stay) (:class:`MapObjects`)."""
        self._objects.remove_line(id)

    def remove_point(self, id: str) -> None:
        """Remove the point ``id``, which must end no line (:class:`MapObjects`)."""
        self._objects.remove_point(id)

    def set_attrs(self, id: str, /, **attrs: Any) -> None:
        """Set attributes of the object ``id`` (``mass``, ``xy``, ``kind`` of a point, extras) (:class:`MapObjects`)."""
        self._objects.set_attrs(id, **attrs)

    def fold(self, id: str, mass: MassFunction, record: Mapping[str, Any]) -> MassFunction:
        """Combine new evidence into the object's mass by the map's rule and log it (:class:`MapObjects`)."""
        return self._objects.fold(id, mass, record)

    def running_mass(self, id: str) -> MassFunction | None:
        """The running mass of the object's evidence records, ``None`` if it has none (:class:`MapObjects`)."""
        return self._objects.running_mass(id)

    def keep_running(self, id: str, running: MassFunction | None) -> None:
        """Give ``id`` the running mass of its evidence records as the caller has it (:class:`MapObjects`)."""
        self._objects.keep_running(id, running)

    def new_id(self, prefix: str) -> str:
        """A fresh id for a new object: ``prefix`` (one of :data:`ID_PREFIXES`) and the next number."""
        return self._objects.new_id(prefix)

    def add_pose(self, pose_index: int) -> None:
        """Record that the observation of ``pose_index`` is folded into the map (once per pose)."""
        self._objects.add_pose(pose_index)

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Changes that happen all or not at all (:func:`evmap.maps.all_or_nothing.all_or_nothing`): on any
        exception inside the block the map is put back as it was (its objects, their attributes and histories,
        segments, open space, ids, poses), then it is raised. :meth:`update` runs in one. Objects put back may
        come after the others in iteration order."""
        with all_or_nothing(self._objects, self._space, self.segments, self._graph):
            yield

    # ----------------------------------------------------------------- delegates

    def update(self, observation: Observation) -> PoseOutcome:
        """Fold in one pose's observation by the paper's pipeline (:func:`evmap.maps.pipeline.fold_observation`),
        all or nothing: if it fails half-way the map is as it was (:meth:`transaction`)."""
        return fold_observation(self, observation, self.config)

    def lines(self, min_belief: float = 0.5) -> list[Line]:
        """:func:`evmap.maps.planner.lines`: the lines with Bel(real) >= ``min_belief``."""
        return planner.lines(self, min_belief)

    def corners(self, min_belief: float = 0.5) -> list[Point]:
        """:func:`evmap.maps.planner.corners`: the corners with Bel(real) >= ``min_belief``."""
        return planner.corners(self, min_belief)

    def unidentified(self, min_belief: float = 0.0) -> list[Point]:
        """:func:`evmap.maps.planner.unidentified`: the unidentified sonar objects."""
        return planner.unidentified(self, min_belief)

    def landmarks(self) -> list[Line | Point]:
        """:func:`evmap.maps.planner.landmarks`: reinforced lines and corners."""
        return planner.landmarks(self)

    def nearest_obstacle(self, xy: Iterable[float], min_belief: float = 0.5) -> tuple[float, str | None]:
        """:func:`evmap.maps.planner.nearest_obstacle`: distance to the nearest obstacle, and its id."""
        return planner.nearest_obstacle(self, xy, min_belief)

    def is_segment_clear(
        self,
        a: Iterable[float],
        b: Iterable[float],
        clearance: float = 0.2,
        min_belief: float = 0.5,
        unknown: str = "blocked",
    ) -> bool:
        """:func:`evmap.maps.planner.is_segment_clear`: no obstacle near ``a``-``b``; unknown space (outside the grid's
        free space, :func:`~evmap.maps.free_space.free_space`: the first query after a change costs what the grid does,
        the next ones microseconds) blocked by default, and ``clearance`` kept from every surface the stripe met."""
        free, surfaces = (free_space(self), surface_points(self)) if unknown == "blocked" else (None, None)
        return planner.is_segment_clear(self, a, b, clearance, min_belief, unknown, free, surfaces)

    def occupancy_masses(
        self, resolution: float = 0.05, params: OccupancyParams | None = None
    ) -> tuple[NDArray[np.float64], tuple[float, float]]:
        """:func:`evmap.maps.occupancy.occupancy_masses`: the evidential grid and its origin."""
        return occupancy.occupancy_masses(self, resolution, params)

    def occupancy_grid(self, resolution: float = 0.05, params: OccupancyParams | None = None) -> NDArray[np.int8]:
        """:func:`evmap.maps.occupancy.occupancy_grid`: the ROS occupancy grid (``int8``)."""
        return occupancy.occupancy_grid(self, resolution, params)

    def save_ros_map(
        self, path_stem: str | Path, resolution: float = 0.05, params: OccupancyParams | None = None
    ) -> tuple[Path, Path]:
        """:func:`evmap.maps.occupancy.save_ros_map`: ``STEM.pgm`` + ``STEM.yaml`` for ROS map_server."""
        return occupancy.save_ros_map(self, path_stem, resolution, params)

    def to_data(self) -> dict[str, Any]:
        """:func:`evmap.maps.map_file.map_data`: the map as node-link JSON data."""
        return map_file.map_data(self)

    @classmethod
    def from_data(cls, data: Any, name: str = "map") -> BeliefMap:
        """The map of :meth:`to_data`'s layout (:func:`evmap.maps.map_file.read_map`)."""
        return cls.from_parts(map_file.read_map(data, name))

    def save(self, path: str | Path, *, sync: bool = True) -> None:
        """:func:`evmap.maps.map_file.write_map`: write ``map.json``, atomically and losslessly (``sync``: on the
        disk before it replaces the old file)."""
        map_file.write_map(self, path, sync=sync)

    @classmethod
    def load(cls, path: str | Path) -> BeliefMap:
        """Read a map written by :meth:`save` (:func:`evmap.maps.map_file.read_file`; errors are ``MapFileError``)."""
        return cls.from_parts(map_file.read_file(path))

    @classmethod
    def from_parts(cls, parts: MapParts) -> BeliefMap:
        """The map of a checked map file's parts (:func:`evmap.maps.map_file.read_map`)."""
        with map_json.gc_paused():
            bm = cls(parts.frame, parts.rule, **parts.extras)
            if parts.segments is not None:
                bm.segments = parts.segments
            if parts.open_space is not None:
                bm.open_space = parts.open_space
            bm._objects.fill(parts.nodes, parts.ends, parts.edges)
            return bm


def new_map(config: Config) -> BeliefMap:
    """An empty belief map for a config: its frame, its rule, no segments yet.

    >>> from evmap.sources.config import load_config
    >>> new_map(load_config())
    BeliefMap(points=0, lines=0, frame=['real', 'noise'], rule='dempster')
    """
    bm = BeliefMap(config.frame, config.rule, config=config.to_data(), next_id=dict.fromkeys(ID_PREFIXES, 1), poses=[])
    bm._config = config  # what the graph's copy reads back as (Config.to_data), without validating it again
    return bm
