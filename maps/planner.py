"""What a planner asks of a belief map: objects above a belief, landmarks, the nearest obstacle, clearance.

Functions of a :class:`~evmap.maps.belief_map.BeliefMap` (whose methods of the
same names call them). The belief of an object is ``Bel({real})`` of its mass.
Obstacles are the lines and the unidentified objects; the distance to an
unidentified object is the distance to its point.

The listings read arrays of the map's state, made once per state of the map
(:func:`state`); the spatial queries read the map's spatial indexes
(:meth:`~evmap.maps.belief_map.BeliefMap.near`, shapely STRtrees kept up to date
one change at a time) and compute beliefs only of the objects found, so a query
right after a change costs what is near, not the map.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Iterable
from numbers import Real
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.sources.geometry import point_segment_distances, segment_distances

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = [
    "Line",
    "MapState",
    "Point",
    "belief_plausibility",
    "corners",
    "is_segment_clear",
    "landmarks",
    "lines",
    "nearest_obstacle",
    "state",
    "unidentified",
]

FIRST_REACH = 2.0
"""Half the side (m) of the first square :func:`nearest_obstacle` searches; it doubles until done."""


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
        xy = dict(graph.nodes(data="xy"))
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
        self.point_mass = [m for _, m in graph.nodes(data="mass")]
        self.point_kind = np.array([k for _, k in graph.nodes(data="kind")], dtype=object)
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


def nearest_obstacle(bm: BeliefMap, xy: Iterable[float], min_belief: float = 0.5) -> tuple[float, str | None]:
    """Distance from ``xy`` to the nearest obstacle with belief at least ``min_belief``, and its id.

    ``(inf, None)`` when there is none. Of equally near obstacles, the one with
    the smallest id. The search looks in squares around ``xy`` whose side
    doubles until the nearest obstacle found is nearer than the square's border,
    or the square holds every obstacle: a handful of index queries, however far
    ``xy`` is from the map.
    """
    here = np.array(point(xy, "xy"))
    level = belief_level(min_belief)
    xmin, ymin, xmax, ymax = bm.extent()
    if not xmin <= xmax:
        return math.inf, None
    reach = max(FIRST_REACH, abs(here[0] - np.clip(here[0], xmin, xmax)), abs(here[1] - np.clip(here[1], ymin, ymax)))
    seen: set[str] = set()
    best, best_id = math.inf, None
    while True:
        found = bm.near((here[0] - reach, here[1] - reach, here[0] + reach, here[1] + reach), "obstacles") - seen
        seen |= found
        ids, p, q = _obstacles(bm, found, level)
        if ids:
            distance = point_segment_distances(here, p, q)
            n = int(np.argmin(distance))  # the first of the nearest: the smallest id
            if distance[n] < best or (distance[n] == best and ids[n] < best_id):
                best, best_id = float(distance[n]), ids[n]
        covers = here[0] - reach <= xmin and here[1] - reach <= ymin and here[0] + reach >= xmax and here[1] + reach >= ymax
        if best <= reach or covers:
            return best, best_id
        reach *= 2


def is_segment_clear(
    bm: BeliefMap, a: Iterable[float], b: Iterable[float], clearance: float = 0.2, min_belief: float = 0.5
) -> bool:
    """True if every obstacle with belief at least ``min_belief`` is farther than ``clearance`` from ``a``-``b``.

    Only known obstacles count: the segment may cross space the map knows nothing of.
    """
    a, b = np.array(point(a, "a")), np.array(point(b, "b"))
    if not (isinstance(clearance, Real) and 0 <= clearance < math.inf):
        raise ValueError(f"clearance must be a finite number >= 0 (m), got {clearance!r}")
    level = belief_level(min_belief)
    lo, hi = np.minimum(a, b) - clearance, np.maximum(a, b) + clearance
    ids, p, q = _obstacles(bm, bm.near((*lo.tolist(), *hi.tolist()), "obstacles"), level)
    return not ids or bool((segment_distances(a, b, p, q) > clearance).all())


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


def belief_level(min_belief: float) -> float:
    """``min_belief`` checked: a number in [0, 1]."""
    if not (isinstance(min_belief, Real) and 0 <= min_belief <= 1):
        raise ValueError(f"min_belief must be a number in [0, 1], got {min_belief!r}")
    return float(min_belief)


def point(xy: Iterable[float], what: str) -> tuple[float, float]:
    """``xy`` as a point of two finite floats; a ValueError naming ``what`` otherwise."""
    try:
        x, y = xy
        p = (float(x), float(y))
    except (TypeError, ValueError):
        raise ValueError(f"{what}: a point must be (x, y), got {xy!r:.80}") from None
    if not (math.isfinite(p[0]) and math.isfinite(p[1])):
        raise ValueError(f"{what}: a point must have finite coordinates, got {p}")
    return p


_beliefs: weakref.WeakKeyDictionary[BeliefMap, dict[str, tuple[MassFunction, float]]] = weakref.WeakKeyDictionary()


def _obstacles(
    bm: BeliefMap, ids: Iterable[str], level: float
) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
    """Of the obstacles ``ids``, those with a belief of at least ``level`` (sorted), and their ends p, q (n, 2).

    Beliefs are remembered with the (immutable) mass they were computed of, so a
    changed mass is computed again and an unchanged one is not.
    """
    cache = _beliefs.setdefault(bm, {})
    kept = []
    for id in ids:
        mass = bm.mass(id)
        known = cache.get(id)
        if known is None or known[0] is not mass:
            known = cache[id] = (mass, mass.belief("real"))
        if known[1] >= level:
            kept.append(id)
    kept.sort()
    nodes = bm.graph.nodes
    ends = [bm.ends(id) if bm.is_line(id) else (id, id) for id in kept]
    p = np.array([nodes[u]["xy"] for u, _ in ends], dtype=float).reshape(-1, 2)
    q = np.array([nodes[v]["xy"] for _, v in ends], dtype=float).reshape(-1, 2)
    return kept, p, q


def _points(bm: BeliefMap, kind: str, min_belief: float) -> list[Point]:
    s = state(bm)
    keep = np.flatnonzero((s.point_kind == kind) & (s.point_bel >= belief_level(min_belief)))
    return [s.point(i) for i in keep]
