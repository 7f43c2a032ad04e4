"""Random indoor worlds in the scenario format, reproducible from a seed.

:func:`generate_world` draws a floor plan with ``numpy.random.default_rng(seed)``:
a corridor (or a wider hall) with rooms on either side, each reached by a door
or a wider passage; door recesses in the bare stretches of wall; glass windows
(between sills and mullions) in the outer walls, each with a sunlight region
just inside it that makes short phantom LSL lines (0.05-0.35 m, as in the
default corridor scenario); glass or mirror partitions standing out of a wall;
pillars (cylinders); and one or more robot poses in free space, clear of walls,
partitions, pillars and sunlight, the first in sight of a sunlight region.

Walls have no thickness in the scenario format; the free space is a union of
rectangles (corridor, rooms, door openings through a wall of
:attr:`WorldGenParams.wall_thickness`) and its boundary rings are the walls,
cut into polylines where the material changes. Coordinates are multiples of
:attr:`WorldGenParams.grid` (5 cm), rounded to millimetres, so the YAML of
:func:`scenario_yaml` is short and exact. The result is validated by
:class:`evmap.sources.sim.scenario.Scenario`; the scenario's ``seed`` is the generator's seed,
so its sensor noise and sunlight lines derive from the same number.

>>> from evmap.sources.sim.scenario import parse_scenario
>>> s = generate_world(3)
>>> s.name, s.seed, len(s.robot.poses) >= 1, len(s.world.sunlight) >= 1
('world-3', 3, True, True)
>>> parse_scenario(scenario_yaml(s), "world-3.yaml") == s
True
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import pairwise
from typing import Any

import numpy as np
import shapely
import yaml
from pydantic import BaseModel, ConfigDict, Field, model_validator

from evmap.sources.loading import validate
from evmap.sources.sim.scenario import Scenario

__all__ = ["WorldGenParams", "generate_world", "scenario_yaml", "wall_segment_count", "world_seed"]

Range = tuple[float, float]
CountRange = tuple[int, int]

_CANDIDATES = 400
"""Random points tried when placing a pillar, a partition or a pose."""


class WorldGenParams(BaseModel):
    """What the generator draws from: sizes (m), counts and shares (probabilities).

    Every ``(low, high)`` pair is drawn uniformly (integers inclusive).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    grid: float = Field(0.05, gt=0, le=1, description="walls, doors and windows lie on this grid (m)")
    hall_share: float = Field(0.3, ge=0, le=1, description="probability of a hall instead of a corridor")
    corridor_length: Range = (7.0, 14.0)
    corridor_width: Range = (1.8, 3.0)
    hall_length: Range = (6.0, 10.0)
    hall_width: Range = (4.0, 6.0)
    rooms: CountRange = Field((2, 6), description="rooms along the corridor's two sides")
    room_width: Range = (2.5, 4.5)
    room_depth: Range = (2.5, 4.0)
    wall_thickness: float = Field(
        0.15, gt=0, le=1, description="between the corridor and a room, and between rooms (m)"
    )
    door_width: Range = (0.8, 1.1)
    passage_share: float = Field(0.3, ge=0, le=1, description="probability that a room opens by a passage, not a door")
    passage_width: Range = (1.5, 2.5)
    recesses: CountRange = Field((0, 3), description="door recesses in bare corridor walls")
    recess_depth: Range = (0.15, 0.3)
    window_share: float = Field(0.3, ge=0, le=1, description="probability that an outer wall long enough has windows")
    window_width: Range = (0.8, 1.5)
    sunlight_share: float = Field(0.7, ge=0, le=1, description="probability that a window has a sunlight region")
    sunlight_depth: Range = (1.0, 2.0)
    sunlight_lines: CountRange = (10, 30)
    phantom_length: Range = Field((0.05, 0.35), description="length range of the phantom lines (m)")
    partitions: CountRange = Field((0, 2), description="glass or mirror partitions standing out of a wall")
    partition_length: Range = (0.8, 2.0)
    mirror_share: float = Field(0.2, ge=0, le=1, description="probability that a partition is a mirror, not glass")
    pillars: CountRange = (0, 3)
    pillar_radius: Range = (0.1, 0.25)
    poses: CountRange = Field((1, 2), description="robot poses")
    pose_step: Range = Field((1.0, 3.0), description="distance of a later pose from the first (m)")
    clearance: float = Field(
        0.4, gt=0, le=5, description="a pose's distance from walls, partitions, pillars and sunlight (m)"
    )
    sight_range: float = Field(6.0, gt=0, le=100, description="the first pose sees a sunlight region this close (m)")

    @model_validator(mode="after")
    def _ordered(self) -> WorldGenParams:
        for name in type(self).model_fields:
            value = getattr(self, name)
            if isinstance(value, tuple) and not 0 <= value[0] <= value[1]:
                raise ValueError(f"{name}: need 0 <= low <= high, got {list(value)}")
        if self.poses[0] < 1:
            raise ValueError(f"poses: need at least 1 pose, got {list(self.poses)}")
        return self


def world_seed(seed: int, index: int) -> int:
    """The seed of world ``index`` of an experiment with ``seed``: independent streams, < 2**63.

    >>> world_seed(1, 0) == world_seed(1, 0) != world_seed(1, 1)
    True
    """
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def wall_segment_count(scenario: Scenario) -> int:
    """The number of wall segments (consecutive point pairs) of a scenario.

    >>> wall_segment_count(generate_world(0)) >= 20
    True
    """
    return sum(len(w.points) - 1 for w in scenario.world.walls)


def generate_world(seed: int, params: WorldGenParams | None = None, name: str | None = None) -> Scenario:
    """A random indoor world from ``seed`` (see the module doc); the same seed gives the same scenario.

    Parameters
    ----------
    seed : int, 0 <= seed < 2**63; the generator's and the scenario's seed.
    params : what to draw from (default :class:`WorldGenParams`).
    name : the scenario's name (default ``world-SEED``).

    >>> a, b = generate_world(5), generate_world(5)
    >>> a == b, a == generate_world(6)
    (True, False)
    """
    if not isinstance(seed, int | np.integer) or not 0 <= seed < 2**63:
        raise ValueError(f"seed must be an integer with 0 <= seed < 2**63, got {seed!r}")
    return _Builder(np.random.default_rng(seed), params or WorldGenParams()).build(int(seed), name or f"world-{seed}")


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as YAML text, one wall, cylinder, region or pose a line; ``parse_scenario`` reads it back.

    Only the keys the scenario was given are written (defaults stay implicit).

    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> text = "{version: 1, name: box, world: {walls: [{id: w, points: [[0, 0], [1, 0]]}]}, "
    >>> text += "robot: {poses: [[0, 1, 0]]}}"
    >>> print(scenario_yaml(parse_scenario(text, "x")))
    version: 1
    name: box
    world:
      walls:
        - {id: w, points: [[0.0, 0.0], [1.0, 0.0]]}
    robot:
      poses:
        - [0.0, 1.0, 0.0]
    <BLANKLINE>
    """
    data = scenario.model_dump(mode="json", exclude_unset=True)
    lines: list[str] = []
    for key, value in data.items():
        if key in ("world", "robot"):
            lines.append(f"{key}:")
            for part, items in value.items():
                lines.append(f"  {part}:" if items else f"  {part}: []")
                lines += [f"    - {_flow(item)}" for item in items]
        elif isinstance(value, dict):
            lines.append(f"{key}:")
            lines += [f"  {k}: {_flow(v)}" for k, v in value.items()]
        else:
            lines.append(f"{key}: {_flow(value)}")
    return "\n".join(lines) + "\n"


def _flow(value: Any) -> str:
    return yaml.safe_dump(value, default_flow_style=True, width=math.inf, sort_keys=False).strip().removesuffix("\n...")


class _Builder:
    """One world being drawn; every random choice goes through ``rng`` in a fixed order."""

    def __init__(self, rng: np.random.Generator, params: WorldGenParams) -> None:
        self.rng = rng
        self.params = params

    # ------------------------------------------------------------------ draws

    def uniform(self, bounds: Range) -> float:
        """A uniform draw on the grid (at least one grid step)."""
        g = self.params.grid
        return max(g, round(self.rng.uniform(*bounds) / g) * g)

    def count(self, bounds: CountRange) -> int:
        return int(self.rng.integers(bounds[0], bounds[1] + 1))

    def snap(self, x: float) -> float:
        """``x`` >= 0 rounded down to the grid."""
        return math.floor(x / self.params.grid + 1e-9) * self.params.grid

    # ------------------------------------------------------------------ world

    def build(self, seed: int, name: str) -> Scenario:
        p = self.params
        hall = self.rng.random() < p.hall_share
        length = self.uniform(p.hall_length if hall else p.corridor_length)
        width = self.uniform(p.hall_width if hall else p.corridor_width)
        main = shapely.box(0, 0, length, width)
        rects, bare = self.rooms(length, width)
        rects += self.recesses(bare, width)
        free = shapely.union_all([main, *rects])
        free = shapely.simplify(shapely.set_precision(free, 1e-3), 0)
        free = shapely.orient_polygons(free)

        edges = self.edges(free)
        windows = self.windows(edges)
        walls = self.walls(free, windows)
        sunlight = self.sunlight(free, windows)
        partitions = self.partitions(free, edges, sunlight)
        pillars = self.pillars(free, sunlight, partitions)
        poses = self.poses(free, sunlight, partitions, pillars)

        data = {
            "version": 1,
            "name": name,
            "seed": seed,
            "world": {
                "walls": walls + partitions,
                "cylinders": pillars,
                "sunlight": [
                    {"polygon": _coords(poly.exterior.coords[:-1]), "lines": lines, "length": list(p.phantom_length)}
                    for poly, lines in sunlight
                ],
            },
            "robot": {"poses": poses},
        }
        return validate(Scenario, data, f"{name}.yaml")

    def rooms(self, length: float, width: float) -> tuple[list[shapely.Polygon], list[tuple[float, float, int]]]:
        """Rooms on both sides with their door openings; the bare stretches ``(x0, x1, side)`` left."""
        p = self.params
        t = p.wall_thickness
        slots = []  # (x0, x1, side): side +1 north, -1 south
        for side in (1, -1):
            x = 0.0
            while x + p.room_width[0] <= length:
                w = min(self.uniform(p.room_width), length - x)
                slots.append((x, x + w, side))
                x += w
        keep = min(len(slots), self.count(p.rooms))
        chosen = sorted(self.rng.choice(len(slots), size=keep, replace=False).tolist()) if slots else []
        rects, bare = [], []
        for k, (x0, x1, side) in enumerate(slots):
            if k not in chosen:
                bare.append((x0, x1, side))
                continue
            depth = self.uniform(p.room_depth)
            near = width + t if side > 0 else -t
            far = near + side * depth
            a, b = x0 + t / 2, x1 - t / 2
            rects.append(shapely.box(a, min(near, far), b, max(near, far)))
            door = self.uniform(p.passage_width if self.rng.random() < p.passage_share else p.door_width)
            door = min(door, b - a - 0.4)
            d = a + 0.2 + self.snap(self.rng.uniform(0, max(0.0, b - a - 0.4 - door)))
            wall = (width, width + t) if side > 0 else (-t, 0.0)
            rects.append(shapely.box(d, wall[0], d + door, wall[1]))
        return rects, bare

    def recesses(self, bare: list[tuple[float, float, int]], width: float) -> list[shapely.Polygon]:
        """Door recesses (shallow notches) in bare stretches of the corridor's walls."""
        p = self.params
        out = []
        wide = [s for s in bare if s[1] - s[0] >= p.door_width[1] + 0.6]
        for k in self.rng.permutation(len(wide))[: self.count(p.recesses)]:
            x0, x1, side = wide[k]
            w = self.uniform(p.door_width)
            d = x0 + 0.3 + self.snap(self.rng.uniform(0, max(0.0, x1 - x0 - 0.6 - w)))
            depth = self.uniform(p.recess_depth)
            y0, y1 = (width, width + depth) if side > 0 else (-depth, 0.0)
            out.append(shapely.box(d, y0, d + w, y1))
        return out

    def edges(self, free: shapely.Polygon) -> list[tuple[np.ndarray, np.ndarray, bool]]:
        """Boundary edges ``(a, b, outer)``: ``outer`` when the far side is outside the building."""
        reach = 2 * self.params.wall_thickness
        out = []
        for ring in (free.exterior, *free.interiors):
            xy = np.asarray(ring.coords)
            for a, b in pairwise(xy):
                mid, n = (a + b) / 2, _normal(a, b)
                out.append((a, b, not free.contains(shapely.Point(mid - reach * n))))
        return out

    def windows(self, edges: list[tuple[np.ndarray, np.ndarray, bool]]) -> list[tuple[np.ndarray, np.ndarray]]:
        """Glass spans ``(a, b)`` on outer edges: one or two windows, with sills and a mullion."""
        p = self.params
        margin = 0.3
        fit = [e for e in edges if e[2] and np.hypot(*(e[1] - e[0])) >= p.window_width[0] + 2 * margin]
        chosen = [e for e in fit if self.rng.random() < p.window_share]
        if not chosen and fit:  # every world has a window
            chosen = [max(fit, key=lambda e: np.hypot(*(e[1] - e[0])))]
        spans = []
        for a, b, _ in chosen:
            length = float(np.hypot(*(b - a)))
            u = (b - a) / length
            count = 2 if length >= 2 * p.window_width[0] + 2 * margin + 0.2 and self.rng.random() < 0.5 else 1
            w = min(self.uniform(p.window_width), (length - 2 * margin - 0.2 * (count - 1)) / count)
            w = math.floor(w / p.grid) * p.grid
            total = count * w + 0.2 * (count - 1)
            s = margin + self.snap(self.rng.uniform(0, max(0.0, length - 2 * margin - total)))
            for k in range(count):
                start = s + k * (w + 0.2)
                spans.append((a + start * u, a + (start + w) * u))
        return spans

    def walls(self, free: shapely.Polygon, windows: list[tuple[np.ndarray, np.ndarray]]) -> list[dict[str, Any]]:
        """The boundary rings cut into polylines of one material each (walls and glass windows)."""
        walls: list[dict[str, Any]] = []
        for ring in (free.exterior, *free.interiors):
            xy = [tuple(c) for c in np.round(np.asarray(ring.coords)[:-1], 3)]
            # insert the window ends into the ring, marking the glass pieces
            pts: list[tuple[tuple[float, float], str]] = []
            for i, a in enumerate(xy):
                b = xy[(i + 1) % len(xy)]
                pts.append((a, "wall"))
                inner = []
                for wa, wb in windows:
                    ta, tb = _along(a, b, wa), _along(a, b, wb)
                    if ta is not None and tb is not None:
                        inner += [(min(ta, tb), "glass"), (max(ta, tb), "wall")]
                for t, material in sorted(inner):
                    pts.append((tuple(np.round(np.asarray(a) + t * (np.asarray(b) - a), 3)), material))
            # a material applies from its point to the next; start the ring where a run starts
            start = next((i for i, (_, m) in enumerate(pts) if m != pts[i - 1][1]), 0)
            pts = pts[start:] + pts[:start]
            run = [pts[0][0]]
            material = pts[0][1]
            for point, m in [*pts[1:], (pts[0][0], "")]:
                run.append(point)
                if m != material:
                    walls.append({"points": run, "material": material})
                    run, material = [point], m
        counters = {"wall": 0, "glass": 0}
        for w in walls:
            counters[w["material"]] += 1
            w["id"] = f"{'wall' if w['material'] == 'wall' else 'window'}-{counters[w['material']]}"
            w["points"] = _coords(w["points"])
        return [{"id": w["id"], "points": w["points"], "material": w["material"]} for w in walls]

    def sunlight(
        self, free: shapely.Polygon, windows: list[tuple[np.ndarray, np.ndarray]]
    ) -> list[tuple[shapely.Polygon, int]]:
        """A region inside some windows (every world with a window gets at least one): ``(polygon, lines)``."""
        p = self.params
        inner = free.buffer(-0.1, join_style="mitre")
        regions = []
        for k, (a, b) in enumerate(windows):
            if self.rng.random() >= p.sunlight_share and not (k == len(windows) - 1 and not regions):
                continue
            n = _normal(a, b)
            u = (b - a) / np.hypot(*(b - a))
            depth = self.uniform(p.sunlight_depth)
            while depth >= 0.6:
                corners = [
                    a + 0.1 * u + 0.15 * n,
                    b - 0.1 * u + 0.15 * n,
                    b - 0.1 * u + depth * n,
                    a + 0.1 * u + depth * n,
                ]
                poly = shapely.Polygon(np.round(corners, 3))
                if inner.contains(poly):
                    regions.append((shapely.orient_polygons(poly), self.count(p.sunlight_lines)))
                    break
                depth -= 0.2
        return regions

    def partitions(
        self,
        free: shapely.Polygon,
        edges: list[tuple[np.ndarray, np.ndarray, bool]],
        sunlight: list[tuple[shapely.Polygon, int]],
    ) -> list[dict[str, Any]]:
        """Glass or mirror walls standing out of a wall into the free space, clear of sunlight."""
        p = self.params
        long = [e for e in edges if np.hypot(*(e[1] - e[0])) >= 1.6]
        lit = shapely.union_all([poly for poly, _ in sunlight]).buffer(0.3)
        out: list[dict[str, Any]] = []
        placed: list[shapely.LineString] = []
        for _ in range(self.count(p.partitions) if long else 0):
            for _ in range(_CANDIDATES):
                a, b, _ = long[self.rng.integers(len(long))]
                length = float(np.hypot(*(b - a)))
                start = a + (0.6 + self.snap(self.rng.uniform(0, length - 1.2))) * (b - a) / length
                end = start + self.uniform(p.partition_length) * _normal(a, b)
                line = shapely.LineString(np.round([start, end], 3))
                tip = shapely.Point(end)
                if (
                    free.buffer(1e-6).covers(line)
                    and free.exterior.distance(tip) >= 0.6
                    and all(ring.distance(tip) >= 0.6 for ring in free.interiors)
                    and not line.intersects(lit)
                    and all(line.distance(other) >= 0.6 for other in placed)
                ):
                    placed.append(line)
                    material = "mirror" if self.rng.random() < p.mirror_share else "glass"
                    out.append(
                        {"id": f"partition-{len(out) + 1}", "points": _coords(line.coords), "material": material}
                    )
                    break
        return out

    def pillars(
        self, free: shapely.Polygon, sunlight: list[tuple[shapely.Polygon, int]], partitions: list[dict[str, Any]]
    ) -> list[dict[str, Any]]:
        """Round wall-material pillars in free space, clear of walls, partitions, sunlight and each other."""
        p = self.params
        obstacles = [shapely.LineString(w["points"]) for w in partitions] + [poly for poly, _ in sunlight]
        out: list[dict[str, Any]] = []
        for _ in range(self.count(p.pillars)):
            r = round(float(self.rng.uniform(*p.pillar_radius)), 3)
            room = free.buffer(-(r + 0.5))
            for c in self.points_in(room):
                if all(o.distance(c) >= r + 0.5 for o in obstacles):
                    obstacles.append(c.buffer(r))
                    out.append({"id": f"pillar-{len(out) + 1}", "center": _coords([c.coords[0]])[0], "radius": r})
                    break
        return out

    def poses(
        self,
        free: shapely.Polygon,
        sunlight: list[tuple[shapely.Polygon, int]],
        partitions: list[dict[str, Any]],
        pillars: list[dict[str, Any]],
    ) -> list[list[float]]:
        """Poses clear of everything by ``clearance``; the first sees a sunlight centroid within ``sight_range``."""
        p = self.params
        walls = free.buffer(-p.clearance)
        lines = [shapely.LineString(w["points"]) for w in partitions]
        discs = [shapely.Point(c["center"]).buffer(c["radius"]) for c in pillars]
        clear = shapely.difference(
            walls,
            shapely.union_all(
                [
                    *(g.buffer(p.clearance) for g in (*lines, *discs)),
                    *(poly.buffer(p.clearance) for poly, _ in sunlight),
                ]
            ),
        )
        centroids = [poly.centroid for poly, _ in sunlight]
        first = None
        fallback = None
        for c in self.points_in(clear):
            fallback = fallback or c
            if any(c.distance(s) <= p.sight_range and _in_sight(free, discs, c, s) for s in centroids):
                first = c
                break
        first = first or fallback
        if first is None:
            raise RuntimeError("no free space for a pose: the world is too small for the clearance")
        chosen = [first]
        for _ in range(self.count(p.poses) - 1):
            step = self.rng.uniform(*p.pose_step)
            for _ in range(_CANDIDATES):
                angle = self.rng.uniform(0, 2 * np.pi)
                c = shapely.Point(first.x + step * np.cos(angle), first.y + step * np.sin(angle))
                if clear.contains(c) and _in_sight(free, discs, first, c):
                    chosen.append(c)
                    break
        return [[round(c.x, 3), round(c.y, 3), float(self.rng.integers(0, 360))] for c in chosen]

    def points_in(self, area: shapely.Geometry) -> Iterator[shapely.Point]:
        """Up to ``_CANDIDATES`` uniform random points of ``area``, on a millimetre grid."""
        if area.is_empty:
            return
        x0, y0, x1, y1 = area.bounds
        for _ in range(_CANDIDATES):
            c = shapely.Point(round(self.rng.uniform(x0, x1), 3), round(self.rng.uniform(y0, y1), 3))
            if area.contains(c):
                yield c


def _normal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit normal to the left of a -> b (into a counter-clockwise ring's interior)."""
    d = (b - a) / np.hypot(*(b - a))
    return np.array([-d[1], d[0]])


def _along(a: tuple[float, float], b: tuple[float, float], x: np.ndarray) -> float | None:
    """Where ``x`` lies on a -> b as a fraction in (0, 1), or None when it is not strictly on it."""
    a_, b_ = np.asarray(a), np.asarray(b)
    d = b_ - a_
    t = float(np.dot(x - a_, d) / np.dot(d, d))
    off = abs(d[0] * (x[1] - a_[1]) - d[1] * (x[0] - a_[0])) / np.hypot(*d)
    return t if off < 1e-6 and 1e-9 < t < 1 - 1e-9 else None


def _in_sight(free: shapely.Polygon, discs: list[shapely.Polygon], a: shapely.Point, b: shapely.Point) -> bool:
    """The straight line a-b stays in free space and misses every pillar."""
    line = shapely.LineString([a, b])
    return free.covers(line) and not any(line.intersects(d) for d in discs)


def _coords(points: Any) -> list[list[float]]:
    return [[round(float(x), 3) + 0.0, round(float(y), 3) + 0.0] for x, y in points]
