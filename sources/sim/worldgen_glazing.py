"""Glass in the outer walls of a generated world, the sunlight coming through it, and the walls cut by material.

A glass span is ``(a, b)`` on an outer edge of the free space. A facade fills one
long outer edge end to end with panes between mullions (short wall pieces);
windows are one or two spans (between sills and a mullion) on other outer edges.
A sunlight region lies just inside some spans: a rectangle from 0.15 m to
``sunlight_depth`` into the room, 0.1 m in from the span's ends, where the LSL
sees short phantom lines.

>>> a, b = np.array([0.0, 0.0]), np.array([5.0, 0.0])
>>> from evmap.sources.sim.worldgen_draw import Draws
>>> panes = facade_panes(Draws(np.random.default_rng(0), WorldGenParams()), a, b)
>>> len(panes) >= 3, all(0 < p[0][0] < p[1][0] < 5 for p in panes)
(True, True)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from evmap.sources.sim.spec import MAX_PHANTOMS_PER_RUN, MAX_SUNLIGHT_LINES, MAX_SUNLIGHT_REGIONS
from evmap.sources.sim.worldgen_draw import Draws, Edge, along, coords, normal
from evmap.sources.sim.worldgen_params import WorldGenParams

__all__ = ["Span", "cap_lines", "facade_panes", "glass_spans", "sunlight_regions", "walls_by_material"]

Span = tuple[np.ndarray, np.ndarray]
"""A glass span ``(a, b)`` on a boundary edge, in the edge's direction."""

_MARGIN = 0.3
"""Wall left at each end of an edge with windows (m)."""
_MULLION = 0.2
"""Wall between the two windows of one edge (m)."""


def glass_spans(draws: Draws, edges: list[Edge]) -> list[Span]:
    """The glass of a world: perhaps a facade on one long outer edge, and windows on other outer edges.

    The facade's edge is drawn with a probability proportional to its squared length, so it is
    most often a wall of the main space. A world without a facade gets at least one window, on its longest outer edge that fits one.
    """
    p = draws.params
    long = [e for e in edges if e[2] and np.hypot(*(e[1] - e[0])) >= p.facade_min_length]
    facade = None
    if long and draws.chance(p.facade_share):
        weight = np.array([np.sum((b - a) ** 2) for a, b, _ in long])  # the longest walls are the likeliest fronts
        facade = long[int(draws.rng.choice(len(long), p=weight / weight.sum()))]
    spans = facade_panes(draws, facade[0], facade[1]) if facade is not None else []
    fit = [e for e in edges if e[2] and e is not facade and np.hypot(*(e[1] - e[0])) >= p.window_width[0] + 2 * _MARGIN]
    chosen = [e for e in fit if draws.chance(p.window_share)]
    if not chosen and not spans and fit:
        chosen = [max(fit, key=lambda e: np.hypot(*(e[1] - e[0])))]
    for a, b, _ in chosen:
        spans += _windows(draws, a, b)
    return spans


def facade_panes(draws: Draws, a: np.ndarray, b: np.ndarray) -> list[Span]:
    """Panes filling the edge a -> b, between mullions, with a mullion at each end (at least one pane)."""
    p = draws.params
    length = float(np.hypot(*(b - a)))
    u = (b - a) / length
    pane, mullion = draws.uniform(p.pane_width), draws.uniform(p.mullion_width)
    count = max(1, math.ceil((length - mullion) / (pane + mullion)))
    width = draws.snap((length - (count + 1) * mullion) / count)
    start = draws.snap((length - count * width - (count - 1) * mullion) / 2)
    return [(a + s * u, a + (s + width) * u) for s in start + (width + mullion) * np.arange(count)]


def _windows(draws: Draws, a: np.ndarray, b: np.ndarray) -> list[Span]:
    """One or two windows on the edge a -> b, between sills and a mullion."""
    p = draws.params
    length = float(np.hypot(*(b - a)))
    u = (b - a) / length
    two = length >= 2 * p.window_width[0] + 2 * _MARGIN + _MULLION and draws.chance(0.5)
    count = 2 if two else 1
    w = min(draws.uniform(p.window_width), (length - 2 * _MARGIN - _MULLION * (count - 1)) / count)
    w = math.floor(w / p.grid) * p.grid
    total = count * w + _MULLION * (count - 1)
    s = _MARGIN + draws.snap(draws.rng.uniform(0, max(0.0, length - 2 * _MARGIN - total)))
    return [(a + (s + k * (w + _MULLION)) * u, a + (s + k * (w + _MULLION) + w) * u) for k in range(count)]


def walls_by_material(free: shapely.Polygon, spans: list[Span]) -> list[dict[str, Any]]:
    """The boundary rings cut into polylines of one material each: walls (``wall-k``) and glass (``window-k``)."""
    walls: list[dict[str, Any]] = []
    starts = np.array([a for a, _ in spans]).reshape(-1, 2)
    ends = np.array([b for _, b in spans]).reshape(-1, 2)
    for ring in (free.exterior, *free.interiors):
        xy = [tuple(c) for c in np.round(np.asarray(ring.coords)[:-1], 3)]
        # insert the span ends into the ring, marking the glass pieces
        pts: list[tuple[tuple[float, float], str]] = []
        for i, a in enumerate(xy):
            b = xy[(i + 1) % len(xy)]
            pts.append((a, "wall"))
            ta, tb = along(a, b, starts), along(a, b, ends)
            on = np.flatnonzero(~np.isnan(ta) & ~np.isnan(tb))
            low, high = np.minimum(ta[on], tb[on]).tolist(), np.maximum(ta[on], tb[on]).tolist()
            inner = [(t, "glass") for t in low] + [(t, "wall") for t in high]
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
    out = []
    for w in walls:
        counters[w["material"]] += 1
        name = "wall" if w["material"] == "wall" else "window"
        out.append(
            {"id": f"{name}-{counters[w['material']]}", "points": coords(w["points"]), "material": w["material"]}
        )
    return out


def sunlight_regions(draws: Draws, free: shapely.Polygon, spans: list[Span]) -> list[tuple[shapely.Polygon, int]]:
    """A region inside some spans (a world with glass gets at least one): ``(polygon, lines)``, not overlapping.

    At most :data:`~evmap.sources.sim.spec.MAX_SUNLIGHT_REGIONS` regions.
    """
    p = draws.params
    inner = free.buffer(-0.1, join_style="mitre")
    regions: list[tuple[shapely.Polygon, int]] = []
    for k, (a, b) in enumerate(spans):
        if len(regions) == MAX_SUNLIGHT_REGIONS:
            break
        if not draws.chance(p.sunlight_share) and not (k == len(spans) - 1 and not regions):
            continue
        n = normal(a, b)
        u = (b - a) / np.hypot(*(b - a))
        depth = draws.uniform(p.sunlight_depth)
        while depth >= 0.6:
            corners = [a + 0.1 * u + 0.15 * n, b - 0.1 * u + 0.15 * n, b - 0.1 * u + depth * n, a + 0.1 * u + depth * n]
            poly = shapely.Polygon(np.round(corners, 3))
            if inner.contains(poly) and all(poly.distance(other) > 0.05 for other, _ in regions):
                regions.append((shapely.orient_polygons(poly), draws.count(p.sunlight_lines)))
                break
            depth -= 0.2
    return regions


def cap_lines(
    regions: list[tuple[shapely.Polygon, int]], params: WorldGenParams, poses: int
) -> list[tuple[shapely.Polygon, int]]:
    """The regions with their line counts scaled down to the cap: at most ``sunlight_lines_total`` per pose, and
    within the scenario limits (:data:`~evmap.sources.sim.spec.MAX_SUNLIGHT_LINES` per pose,
    :data:`~evmap.sources.sim.spec.MAX_PHANTOMS_PER_RUN` over ``poses`` poses). Every region keeps a line at
    least while the cap allows; regions beyond it are dropped.

    >>> square = shapely.box(0, 0, 1, 1)
    >>> [n for _, n in cap_lines([(square, 30), (square, 10)], WorldGenParams(sunlight_lines_total=20), 1)]
    [15, 5]
    >>> [n for _, n in cap_lines([(square, 30)] * 3, WorldGenParams(), 10)]
    [13, 13, 13]
    """
    cap = min(params.sunlight_lines_total, MAX_SUNLIGHT_LINES, MAX_PHANTOMS_PER_RUN // max(poses, 1))
    total = sum(n for _, n in regions)
    if total <= cap:
        return regions
    scaled = [(poly, max(1, n * cap // total)) for poly, n in regions]
    while sum(n for _, n in scaled) > cap:
        scaled.pop()
    return scaled
