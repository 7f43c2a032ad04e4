"""Rays cast from one origin against many segments and circles: each ray paired only with the surfaces whose
bearing interval holds its bearing, nearest first, a bounded number of pairs at a time.

The simulator's stripe and sonar, and the map's sight tests, cast with these
(:func:`cast_rays`); the sonar's model pairs its echoes and beams the same way
(:func:`bearing_pairs`, :func:`nearest_first_pairs`).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import crossings, point_segment_distances

__all__ = [
    "PAIRS",
    "bearing_intervals",
    "bearing_pairs",
    "cast_rays",
    "merge_nearest",
    "nearest_first_pairs",
    "ray_circle_pairs",
]

PAIRS = 1 << 20
"""Most (ray, surface) pairs :func:`cast_rays` computes at once: its memory is bounded by this (about 100 MB),
not by the number of rays times the number of surfaces."""

_ROUND_OFF = 1e-9
"""Margin of :func:`cast_rays`'s bearing intervals, relative to the distances involved: a ray that the exact
test hits, round-off included, is always in the interval."""


def bearing_intervals(
    origin: ArrayLike,
    p: ArrayLike,
    q: ArrayLike,
    slack: ArrayLike,
    centers: ArrayLike = (),
    radii: ArrayLike = (),
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bearings from ``origin`` of every point within ``slack`` (m, per segment) of segments ``p``-``q``, then
    within ``slack`` of circles: per surface the start of an interval in [0, 2 pi) and its width (rad).

    A surface within twice its slack of the origin, or whose interval comes near half a turn (the origin
    nearly on the segment's line between its ends), gets every bearing (width 4 pi).

    >>> lo, width = bearing_intervals([0, 0], [[1, -1], [-1, 1]], [[1, 1], [-1, 2]], 0.0, [[0, -2]], [1.0])
    >>> np.round(np.degrees(lo), 3).tolist(), np.round(np.degrees(width), 3).tolist()
    ([315.0, 116.565, 240.0], [90.0, 18.435, 60.0])
    """
    o = np.asarray(origin, dtype=float)
    p, q = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)
    slack = np.broadcast_to(np.asarray(slack, dtype=float), (len(p),))
    a, b = p - o, q - o
    start = np.arctan2(a[:, 1], a[:, 0])
    span = np.mod(np.arctan2(b[:, 1], b[:, 0]) - start + np.pi, 2 * np.pi) - np.pi
    dist = point_segment_distances(o, p, q)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a tiny distance: full, below
        pad = np.arcsin(np.minimum(1.0, 2 * slack / dist))
    full = ~(dist > 2 * slack) | (np.abs(span) + 2 * pad >= np.pi)
    lo = np.where(full, 0.0, start + np.minimum(span, 0) - pad)
    width = np.where(full, 4 * np.pi, np.abs(span) + 2 * pad)
    c = np.asarray(centers, dtype=float).reshape(-1, 2) - o
    r = np.asarray(radii, dtype=float).reshape(-1)
    dc = np.hypot(c[:, 0], c[:, 1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        half = np.arcsin(np.minimum(1.0, (r + 2 * slack.max(initial=0.0)) / dc))
    inside = ~(dc > r + 2 * slack.max(initial=0.0))
    lo = np.concatenate([lo, np.where(inside, 0.0, np.arctan2(c[:, 1], c[:, 0]) - half)])
    width = np.concatenate([width, np.where(inside, 4 * np.pi, 2 * half)])
    return np.mod(lo, 2 * np.pi), width


def bearing_pairs(
    lo: NDArray[np.float64], width: NDArray[np.float64], bearing: ArrayLike, limit: int = PAIRS
) -> Iterator[tuple[NDArray[np.intp], NDArray[np.intp]]]:
    """(ray, surface) index pairs: each surface with the rays whose ``bearing`` lies in its interval (``lo``,
    ``width`` as :func:`bearing_intervals` gives them), in chunks of at most ``limit`` pairs (or one surface's).

    >>> [pair.tolist() for pair in next(bearing_pairs(np.array([6.0, 0.5]), np.array([1.0, 4 * np.pi]), [0.2, 3.0]))]
    [[0, 1, 0], [0, 1, 1]]
    """
    bearing = np.mod(np.asarray(bearing, dtype=float).reshape(-1), 2 * np.pi)
    k = len(bearing)
    if not k or not len(lo):
        return
    order = np.argsort(bearing, kind="stable")
    twice = np.concatenate([bearing[order], bearing[order] + 2 * np.pi])
    first = np.searchsorted(twice, lo, side="left")
    count = np.minimum(np.searchsorted(twice, lo + width, side="right") - first, k)
    ends = np.cumsum(count)
    start = 0
    while start < len(count):
        done = int(ends[start - 1]) if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, done + limit, side="right")))
        n = count[start:stop]
        offset = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        yield order[(np.repeat(first[start:stop], n) + offset) % k], np.repeat(np.arange(start, stop), n)
        start = stop


def nearest_first_pairs(
    lo: NDArray[np.float64],
    width: NDArray[np.float64],
    distance: NDArray[np.float64],
    bearing: ArrayLike,
    reach: NDArray[np.float64],
    limit: int = PAIRS,
) -> Iterator[tuple[NDArray[np.intp], NDArray[np.intp]]]:
    """(ray, surface) index pairs as :func:`bearing_pairs` gives them, the surfaces nearest the origin first.

    ``distance`` is each surface's least distance from the origin; ``reach`` (one per ray) how far a surface
    may still matter to the ray, an array the caller lowers between chunks (to the nearest hit found, or
    to -inf once a path is known blocked): a chunk pairs its surfaces only with the rays whose reach is at
    least the distance of its nearest surface (less a relative 1e-9 for round-off). So a ray stops being
    tried once everything left is beyond what it has found, and a dense world costs what its near part does.
    At most ``limit`` pairs a chunk (or one surface's).

    >>> reach = np.array([np.inf, np.inf])
    >>> chunks = nearest_first_pairs(np.zeros(3), np.full(3, 4 * np.pi), np.array([3.0, 1.0, 2.0]), [0, 1], reach, 2)
    >>> [pair.tolist() for pair in next(chunks)]
    [[0, 1], [1, 1]]
    >>> reach[0] = 1.5  # ray 0 found something at 1.5: surfaces 2 and 0, further, no longer matter to it
    >>> [[pair.tolist() for pair in chunk] for chunk in chunks]
    [[[1, 1], [2, 0]]]
    """
    bearing = np.mod(np.asarray(bearing, dtype=float).reshape(-1), 2 * np.pi)
    by_bearing = np.argsort(bearing, kind="stable")
    nearest = np.argsort(distance, kind="stable")
    least = distance - 1e-9 * (1 + np.abs(distance))
    block, start = 256, 0
    while start < len(nearest):
        rays = by_bearing[reach[by_bearing] >= least[nearest[start]]]
        k = len(rays)
        if not k:
            return
        twice = np.concatenate([bearing[rays], bearing[rays] + 2 * np.pi])
        surfaces = nearest[start : start + block]
        first = np.searchsorted(twice, lo[surfaces], side="left")
        count = np.minimum(np.searchsorted(twice, lo[surfaces] + width[surfaces], side="right") - first, k)
        take = max(1, int(np.searchsorted(np.cumsum(count), limit, side="right")))
        block = min(2 * block, 1 << 16) if take == len(surfaces) else block
        surfaces, first, count = surfaces[:take], first[:take], count[:take]
        offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        yield rays[(np.repeat(first, count) + offset) % k], np.repeat(surfaces, count)
        start += take


def merge_nearest(
    best: NDArray[np.float64], hit: NDArray[np.intp], ray: NDArray[np.intp], item: NDArray[np.intp], dist: ArrayLike
) -> None:
    """Fold (ray, item, distance) hits into each ray's nearest ``best`` and its ``hit`` (in place); of equal
    distances the smaller item wins, as ``argmin`` over items in order would choose.

    >>> best, hit = np.full(2, np.inf), np.full(2, -1)
    >>> merge_nearest(best, hit, np.array([0, 0, 1]), np.array([4, 2, 3]), np.array([1.0, 1.0, np.inf]))
    >>> best.tolist(), hit.tolist()
    ([1.0, inf], [2, -1])
    """
    dist = np.asarray(dist, dtype=float)
    found = np.isfinite(dist)
    ray, item, dist = ray[found], item[found], dist[found]
    nearest = best.copy()
    np.minimum.at(nearest, ray, dist)
    hit[nearest < best] = np.iinfo(hit.dtype).max  # a nearer hit: the old one is out of the running
    tie = dist == nearest[ray]
    np.minimum.at(hit, ray[tie], item[tie])
    best[:] = nearest


def ray_circle_pairs(
    origin: ArrayLike, directions: ArrayLike, centers: ArrayLike, radii: ArrayLike
) -> NDArray[np.float64]:
    """:func:`ray_circle_distances` for pairs: (P,) distance along each unit direction (P, 2) to circle (P).

    >>> ray_circle_pairs([0.0, 0.0], [[1.0, 0.0], [-1.0, 0.0]], [[3.0, 0.0], [0.0, 3.0]], [1.0, 1.0]).tolist()
    [2.0, inf]
    """
    u = np.asarray(directions, dtype=float).reshape(-1, 2)
    c = np.asarray(centers, dtype=float).reshape(-1, 2) - np.asarray(origin, dtype=float)
    r = np.asarray(radii, dtype=float).reshape(-1)
    b = u[:, 0] * c[:, 0] + u[:, 1] * c[:, 1]
    disc = b**2 - ((c**2).sum(axis=1) - r**2)
    with np.errstate(invalid="ignore"):
        near = b - np.sqrt(disc)
    return np.where((disc >= 0) & (near > 0), near, np.inf)


def cast_rays(
    origin: ArrayLike,
    angles: ArrayLike,
    p: ArrayLike,
    q: ArrayLike,
    centers: ArrayLike,
    radii: ArrayLike,
    max_range: float,
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Nearest hit of each ray from ``origin`` among segments ``p``-``q`` and circles.

    Parameters
    ----------
    origin : (2,) ray origin.
    angles : (R,) ray directions (radians, counter-clockwise from +x).
    p, q : (N, 2) segment ends. centers : (K, 2), radii : (K,) circles.
    max_range : hits further than this are no hits.

    Returns
    -------
    ranges : (R,) distance to the nearest hit, ``inf`` where none.
    hit : (R,) index of what was hit: ``0..N-1`` a segment, ``N..N+K-1`` a circle, -1 none.

    Rays grazing a segment along its own line do not hit it; a circle is hit on its
    near side (the origin must be outside every circle).

    >>> ranges, hit = cast_rays([0, 0], [0, np.pi / 2, np.pi], [[2, -1]], [[2, 1]], [[0, 3]], [0.5], 10)
    >>> ranges.tolist(), hit.tolist()
    ([2.0, 2.5, inf], [0, 1, -1])
    """
    o = np.asarray(origin, dtype=float)
    angles = np.asarray(angles, dtype=float).reshape(-1)
    u = np.empty((len(angles), 2))  # the rays' unit directions
    u[:, 0], u[:, 1] = np.cos(angles), np.sin(angles)
    p, q = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)
    centers, radii = np.asarray(centers, dtype=float).reshape(-1, 2), np.asarray(radii, dtype=float).reshape(-1)
    n = len(p)
    # Only the surfaces whose bearing interval holds a ray's bearing can be hit by it, and only those no
    # further than the ray's nearest hit so far (nor than max_range: a hit beyond it is no hit).
    slack = _ROUND_OFF * (1 + np.hypot(*(p - o).T) + np.hypot(*(q - o).T))
    lo, width = bearing_intervals(o, p, q, slack, centers, radii)
    distance = np.concatenate([point_segment_distances(o, p, q), np.hypot(*(centers - o).T) - radii])
    best = np.full(len(angles), np.inf)
    hit = np.full(len(angles), -1, dtype=np.intp)
    reach = np.full(len(angles), float(max_range))
    d = q - p
    for i, j in nearest_first_pairs(lo, width, distance, angles, reach, PAIRS):
        if len(radii):
            seg = j < n
            dist = np.empty(len(i))
            dist[~seg] = ray_circle_pairs(o, u[i[~seg]], centers[j[~seg] - n], radii[j[~seg] - n])
            t, s = crossings(o, u[i[seg]], p[j[seg]], d[j[seg]])
            dist[seg] = np.where((t > 0) & (s >= 0) & (s <= 1), t, np.inf)
        else:
            t, s = crossings(o, u[i], p[j], d[j])
            dist = np.where((t > 0) & (s >= 0) & (s <= 1), t, np.inf)
        merge_nearest(best, hit, i, j, dist)
        np.minimum(reach, best, out=reach)
    found = best <= max_range
    return np.where(found, best, np.inf), np.where(found, hit, -1).astype(np.intp)
