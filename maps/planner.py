"""What a planner asks of a belief map: objects above a belief, landmarks, the nearest obstacle, clearance.

Functions of a :class:`~evmap.maps.belief_map.BeliefMap` (whose methods of the
same names call them). The belief of an object is ``Bel({real})`` of its mass.
Obstacles are the lines and the unidentified objects; the distance to an
unidentified object is the distance to its point.

The listings read arrays of the map's state, made once per state of the map
(:func:`state`). The spatial queries read a shapely STRtree of the obstacles
above the belief asked for (:func:`obstacle_tree`), made once and then caught up
with the map through its journal of changes
(:meth:`~evmap.maps.belief_map.BeliefMap.changed_since`): the few objects changed
since the tree was made are checked one by one, and the tree is made anew only
when they grow many. A query right after a change costs what changed, not the map.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Iterable
from numbers import Real
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.sources.geometry import point_segment_distances, segment_distances
from evmap.sources.readings import MAX_COORDINATE

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = [
    "UNKNOWN_POLICIES",
    "Line",
    "MapState",
    "ObstacleTree",
    "Point",
    "belief_plausibility",
    "corners",
    "is_segment_clear",
    "landmarks",
    "lines",
    "nearest_obstacle",
    "obstacle_tree",
    "state",
    "unidentified",
]

FIRST_REACH = 2.0
"""How much farther (m) :func:`nearest_obstacle` first looks when the nearest obstacles in its tree have changed."""

UNKNOWN_POLICIES = ("blocked", "free")
"""What :func:`is_segment_clear` makes of space the map knows nothing of: an obstacle, or free."""

REBUILD_CHANGES = 256
REBUILD_SHARE = 0.02
"""An obstacle tree is made anew once more objects changed since it was made than these (count, share of it)."""


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


class MapState:
    """Arrays of one state of a map, for the listings and the occupancy grid."""

    def __init__(self, bm: BeliefMap) -> None:
        graph, real = bm.graph, bm.frame.mask("real")
        xy = {n: d.get("xy") for n, d in graph.nodes.items()}
        self.line_ids = list(bm.line_ids())
        self.ends = [bm.ends(id) for id in self.line_ids]
        self.line_mass = [graph.adj[u][v]["mass"] for u, v in self.ends]
        self.line_p = [xy[u] for u, _ in self.ends]
        self.line_q = [xy[v] for _, v in self.ends]
        self.p = np.array(self.line_p, dtype=float).reshape(-1, 2)
        self.q = np.array(self.line_q, dtype=float).reshape(-1, 2)
        self.line_bel, self.line_pl = belief_plausibility(self.line_mass, real)
        self.point_ids = list(xy)
        self.point_xy = list(xy.values())
        self.xy = np.array(self.point_xy, dtype=float).reshape(-1, 2)
        self.point_mass = [d.get("mass") for d in graph.nodes.values()]
        self.point_kind = np.array([d.get("kind") for d in graph.nodes.values()], dtype=object)
        self.point_bel, self.point_pl = belief_plausibility(self.point_mass, real)

    def line(self, i: int) -> Line:
        u, v = self.ends[i]
        bel, pl = float(self.line_bel[i]), float(self.line_pl[i])
        return Line(self.line_ids[i], u, v, self.line_p[i], self.line_q[i], self.line_mass[i], bel, pl)

    def point(self, i: int) -> Point:
        bel, pl = float(self.point_bel[i]), float(self.point_pl[i])
        return Point(self.point_ids[i], self.point_xy[i], self.point_kind[i], self.point_mass[i], bel, pl)


_states: weakref.WeakKeyDictionary[BeliefMap, tuple[int, MapState]] = weakref.WeakKeyDictionary()


def state(bm: BeliefMap) -> MapState:
    """The arrays of the map's present state: made on the first call after a change, then reused."""
    kept = _states.get(bm)
    if kept is None or kept[0] != bm.version:
        kept = _states[bm] = (bm.version, MapState(bm))
    return kept[1]


def lines(bm: BeliefMap, min_belief: float = 0.5) -> list[Line]:
    """The lines whose belief Bel(real) is at least ``min_belief``, in insertion order."""
    s = state(bm)
    return [s.line(i) for i in np.flatnonzero(s.line_bel >= belief_level(min_belief))]


def corners(bm: BeliefMap, min_belief: float = 0.5) -> list[Point]:
    """The corners whose belief Bel(real) is at least ``min_belief``."""
    return _points(bm, "corner", min_belief)


def unidentified(bm: BeliefMap, min_belief: float = 0.0) -> list[Point]:
    """The unidentified sonar objects (all of them by default)."""
    return _points(bm, "unidentified", min_belief)


def landmarks(bm: BeliefMap) -> list[Line | Point]:
    """Reinforced lines and corners (attribute ``reinforced`` true): lines first."""
    s, g = state(bm), bm.graph
    found: list[Line | Point] = [s.line(i) for i, (u, v) in enumerate(s.ends) if g.adj[u][v].get("reinforced")]
    found += [s.point(i) for i in np.flatnonzero(s.point_kind == "corner") if g.nodes[s.point_ids[i]].get("reinforced")]
    return found


class ObstacleTree:
    """The obstacles of a map with belief at least ``level`` in a :class:`shapely.STRtree`, as of one version.

    Lines are LineStrings and unidentified objects Points. The objects changed
    since the tree was made (the map's journal) are ``dirty``: the queries leave
    them out of the tree and check, one by one, those of them that are obstacles
    now (``ids``, ``p``, ``q``, caught up with every change as it comes).
    """

    def __init__(self, bm: BeliefMap, level: float) -> None:
        g, real = bm.graph, bm.frame.mask("real")
        xy_of = {n: d.get("xy") for n, d in g.nodes.items()}
        edges = list(g.edges())
        targets = [n for n, d in g.nodes.items() if d.get("kind") == "unidentified"]
        lines = [d["id"] for _, _, d in edges]
        masses = [d["mass"] for _, _, d in edges] + [g.nodes[n]["mass"] for n in targets]
        keep = belief_plausibility(masses, real)[0] >= level
        ends = np.array([(xy_of[u], xy_of[v]) for u, v, _ in edges], dtype=float).reshape(-1, 2, 2)
        xy = np.array([xy_of[n] for n in targets], dtype=float).reshape(-1, 2)
        geometries = np.concatenate([shapely.linestrings(ends), shapely.points(xy)])[keep]
        self.tree_ids = np.array(lines + targets, dtype=object)[keep]
        self.tree = shapely.STRtree(geometries)
        self.level = level
        self.version = bm.version  # what the map was when the tree was made, then as far as caught up
        self.dirty: set[str] = set()
        self._row: dict[str, int] = {}  # row of each dirty obstacle in the arrays below
        self._ends = np.zeros((16, 2, 2))
        self._alive = np.zeros(16, dtype=bool)
        self._row_ids: list[str] = []

    @property
    def ids(self) -> NDArray[np.object_]:
        """The ids of the changed objects that are obstacles now."""
        return np.array(self._row_ids, dtype=object)[self._alive[: len(self._row_ids)]]

    @property
    def p(self) -> NDArray[np.float64]:
        """(n, 2) one end of each of :attr:`ids`."""
        return self._ends[: len(self._row_ids), 0][self._alive[: len(self._row_ids)]]

    @property
    def q(self) -> NDArray[np.float64]:
        """(n, 2) the other end of each of :attr:`ids` (the same point for an unidentified object)."""
        return self._ends[: len(self._row_ids), 1][self._alive[: len(self._row_ids)]]

    def catch_up(self, bm: BeliefMap) -> bool:
        """Take in the map's changes since :attr:`version`; False if they are too many (make a new tree)."""
        new = bm.changed_since(self.version)
        limit = max(REBUILD_CHANGES, REBUILD_SHARE * len(self.tree_ids))
        if new is None or len(self.dirty | new) > limit or len(self._row_ids) + len(new) > 4 * limit:
            return False
        self.dirty |= new
        nodes = bm.graph.nodes
        for id in new:
            row = self._row.pop(id, None)
            if row is not None:
                self._alive[row] = False
            obstacle = id in bm and (bm.is_line(id) or nodes[id]["kind"] == "unidentified")
            if obstacle and bm.mass(id).belief("real") >= self.level:
                u, v = bm.ends(id) if bm.is_line(id) else (id, id)
                row = self._row[id] = len(self._row_ids)
                if row == len(self._alive):
                    self._ends = np.concatenate([self._ends, np.zeros_like(self._ends)])
                    self._alive = np.concatenate([self._alive, np.zeros_like(self._alive)])
                self._ends[row] = (nodes[u]["xy"], nodes[v]["xy"])
                self._alive[row] = True
                self._row_ids.append(id)
        self.version = bm.version
        return True


_trees: weakref.WeakKeyDictionary[BeliefMap, dict[float, ObstacleTree]] = weakref.WeakKeyDictionary()


def obstacle_tree(bm: BeliefMap, level: float) -> ObstacleTree:
    """The map's obstacle tree at ``level``, caught up with the map: made anew when too much changed since."""
    trees = _trees.setdefault(bm, {})
    tree = trees.get(level)
    if tree is None or (tree.version != bm.version and not tree.catch_up(bm)):
        tree = trees[level] = ObstacleTree(bm, level)
    return tree


def _geometries(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.object_]:
    """Segments p-q as shapely geometries (a Point where p = q)."""
    same = (p == q).all(axis=1)
    return np.where(same, shapely.points(p), shapely.linestrings(np.stack([p, q], axis=1)))


def nearest_obstacle(bm: BeliefMap, xy: Iterable[float], min_belief: float = 0.5) -> tuple[float, str | None]:
    """Distance from ``xy`` to the nearest obstacle with belief at least ``min_belief``, and its id.

    ``(inf, None)`` when there is none. Of equally near obstacles, the one with
    the smallest id. One nearest-neighbour query of the obstacle tree (shapely's
    STRtree), plus the few obstacles changed since the tree was made.
    """
    xy = point(xy, "xy")
    here = shapely.Point(xy)
    tree = obstacle_tree(bm, belief_level(min_belief))
    candidates: list[str] = []
    geometries: list[shapely.Geometry] = []
    reach = math.inf
    if len(tree.tree_ids):
        found, distance = tree.tree.query_nearest(here, all_matches=True, return_distance=True)
        clean = [i for i in found.tolist() if tree.tree_ids[i] not in tree.dirty]
        reach = float(distance[0])
        while not clean:  # the nearest ones changed: look farther
            reach = 2 * reach + FIRST_REACH
            around = tree.tree.query(here, predicate="dwithin", distance=reach).tolist()
            clean = [i for i in around if tree.tree_ids[i] not in tree.dirty]
            if not clean and len(around) == len(tree.tree_ids):
                reach = math.inf
                break
        candidates += tree.tree_ids[clean].tolist()
        geometries += list(tree.tree.geometries.take(clean))
    if tree.dirty and len(ids := tree.ids):  # the changed obstacles that may be as near (exact distances decide)
        p, q = tree.p, tree.q
        near = np.flatnonzero(point_segment_distances(np.array(xy), p, q) <= reach + 1e-9)
        candidates += ids[near].tolist()
        geometries += list(_geometries(p[near], q[near]))
    if not candidates:
        return math.inf, None
    distance = shapely.distance(np.array(geometries, dtype=object), here)
    best = distance.min()
    return float(best), min(id for id, d in zip(candidates, distance.tolist(), strict=True) if d <= best)


def is_segment_clear(
    bm: BeliefMap,
    a: Iterable[float],
    b: Iterable[float],
    clearance: float = 0.2,
    min_belief: float = 0.5,
    unknown: str = "blocked",
    free: shapely.Geometry | None = None,
    surfaces: shapely.STRtree | None = None,
) -> bool:
    """True if the straight path ``a``-``b`` is clear: no obstacle with belief at least ``min_belief``
    within ``clearance`` of it, and, with ``unknown="blocked"`` (the default), the whole path in the
    free space the map knows, ``free`` (:meth:`BeliefMap.is_segment_clear` gives the occupancy grid's,
    :func:`evmap.maps.free_space.free_space`: the sensors' free space short of believed surfaces, made once
    per version of the map; the map's stored open space when not given): a path into space no sensor saw
    free is not clear; nor is one within ``clearance`` of a point of ``surfaces``, the surfaces the sensors
    measured whether or not the map has a line there (:meth:`BeliefMap.is_segment_clear` gives the stripe's,
    :func:`evmap.maps.free_space.surface_points`).

    With ``unknown="free"`` only known obstacles count, and a path may leave the building.

    >>> from evidential import MassFunction
    >>> from evmap.maps import BeliefMap
    >>> import shapely
    >>> bm = BeliefMap(["real", "noise"])
    >>> bm.open_space = shapely.box(0, 0, 4, 4)
    >>> bm.is_segment_clear((1, 1), (3, 3)), bm.is_segment_clear((1, 1), (6, 1)), bm.is_segment_clear((1, 1), (6, 1), unknown="free")
    (True, False, True)
    """
    if unknown not in UNKNOWN_POLICIES:
        raise ValueError(f"unknown must be one of {list(UNKNOWN_POLICIES)}, got {unknown!r}")
    a, b = np.array(point(a, "a")), np.array(point(b, "b"))
    if not (is_number(clearance) and 0 <= clearance < math.inf):
        raise ValueError(f"clearance must be a finite number >= 0 (m), got {clearance!r}")
    tree = obstacle_tree(bm, belief_level(min_belief))
    path = _geometries(a[None], b[None])[0]
    if unknown == "blocked" and not (bm.open_space if free is None else free).covers(path):
        return False
    if unknown == "blocked" and surfaces is not None and len(surfaces.query(path, "dwithin", distance=clearance)):
        return False
    hits = tree.tree.query(path, predicate="dwithin", distance=clearance).tolist()
    if any(tree.tree_ids[i] not in tree.dirty for i in hits):
        return False
    if not tree.dirty:
        return True
    p, q = tree.p, tree.q
    lo, hi = np.minimum(a, b) - clearance, np.maximum(a, b) + clearance
    near = ((np.maximum(p, q) >= lo) & (np.minimum(p, q) <= hi)).all(axis=1)  # boxes that meet the path's
    return not near.any() or bool((segment_distances(a, b, p[near], q[near]) > clearance).all())


def belief_plausibility(masses: list[MassFunction], a: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bel(A) and Pl(A) of many mass functions at once (A a bitmask), as ``MassFunction.belief`` computes them."""
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


def is_number(value: object) -> bool:
    """Whether ``value`` is a real number (numpy's too), not a bool nor a string (as a scenario file's rules have it).

    >>> is_number(0.5), is_number(np.int64(2)), is_number(True), is_number("0.5")
    (True, True, False, False)
    """
    return isinstance(value, Real) and not isinstance(value, bool | np.bool_)


def belief_level(min_belief: float) -> float:
    """``min_belief`` checked: a number in [0, 1]."""
    if not (is_number(min_belief) and 0 <= min_belief <= 1):
        raise ValueError(f"min_belief must be a number in [0, 1], got {min_belief!r}")
    return float(min_belief)


def point(xy: Iterable[float], what: str) -> tuple[float, float]:
    """``xy`` as a point of two finite floats within :data:`~evmap.sources.readings.MAX_COORDINATE` of the
    origin (as every reading's); a ValueError naming ``what`` otherwise.

    >>> point((1e300, 1), "P")
    Traceback (most recent call last):
    ...
    ValueError: P: a point must be within 2e+07 m of the origin (x and y), got (1e+300, 1.0)
    """
    try:
        x, y = xy
    except (TypeError, ValueError):
        raise ValueError(f"{what}: a point must be (x, y), got {xy!r:.80}") from None
    if not (is_number(x) and is_number(y)):
        raise ValueError(f"{what}: a point must be two numbers (x, y), got {xy!r:.80}")
    p = (float(x), float(y))
    if not (math.isfinite(p[0]) and math.isfinite(p[1])):
        raise ValueError(f"{what}: a point must have finite coordinates, got {p}")
    if not (abs(p[0]) <= MAX_COORDINATE and abs(p[1]) <= MAX_COORDINATE):
        raise ValueError(f"{what}: a point must be within {MAX_COORDINATE:g} m of the origin (x and y), got {p}")
    return p


def _points(bm: BeliefMap, kind: str, min_belief: float) -> list[Point]:
    s = state(bm)
    keep = np.flatnonzero((s.point_kind == kind) & (s.point_bel >= belief_level(min_belief)))
    return [s.point(i) for i in keep]
