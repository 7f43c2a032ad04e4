"""Plane geometry over arrays of points, segments, rays and circles: distances, crossings, ray casts.

Every function takes numpy arrays whose last axis is (x, y) and broadcasts over
the others; a segment ``p``-``q`` with ``p == q`` is a point. Both the simulator
(``evmap.sources.sim``) and the evidence side use these, so that each formula is
written once.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "bearing_intervals",
    "bearing_pairs",
    "cast_rays",
    "cross",
    "crossings",
    "line_distances",
    "merge_nearest",
    "near_segments",
    "nearest_angles",
    "nearest_first_pairs",
    "perpendicular_feet",
    "point_segment_distances",
    "ray_circle_distances",
    "ray_circle_pairs",
    "segment_distances",
]

PAIRS = 1 << 20
"""Most (ray, surface) pairs :func:`cast_rays` computes at once: its memory is bounded by this (about 100 MB),
not by the number of rays times the number of surfaces."""

_ROUND_OFF = 1e-9
"""Margin of :func:`cast_rays`'s bearing intervals, relative to the distances involved: a ray that the exact
test hits, round-off included, is always in the interval."""


def _det(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """The z component of u x v."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _dot(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """u . v over the last axis."""
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]


def cross(o: ArrayLike, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """The z component of (u - o) x (v - o): > 0 where o, u, v turn left, 0 where collinear.

    >>> float(cross([0, 0], [1, 0], [0, 1]))
    1.0
    """
    o, u, v = np.asarray(o, dtype=float), np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    return _det(u - o, v - o)


def crossings(
    a: ArrayLike, u: ArrayLike, p: ArrayLike, v: ArrayLike, *, parallel: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where the lines ``a + t u`` and ``p + s v`` cross: the parameters ``(t, s)``.

    A segment ``a``-``b`` is the line with ``u = b - a`` and ``0 <= t <= 1``; a ray
    from ``a`` along a unit ``u`` has ``t`` its distance. Where the lines are
    parallel, ``|u x v| <= parallel * |u| |v|`` (by default only exactly parallel
    ones), both parameters are NaN, so every comparison with them is False.

    >>> t, s = crossings([0.0, 0.0], [[2.0, 0.0], [1.0, 0.0]], [1.0, -1.0], [[0.0, 4.0], [2.0, 0.0]])
    >>> t.tolist(), s.tolist()
    ([0.5, nan], [0.25, nan])
    """
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    w = np.asarray(p, dtype=float) - np.asarray(a, dtype=float)
    ux, uy, vx, vy, wx, wy = u[..., 0], u[..., 1], v[..., 0], v[..., 1], w[..., 0], w[..., 1]
    den = ux * vy - uy * vx
    if parallel > 0:
        den = np.where(np.abs(den) > parallel * (np.hypot(ux, uy) * np.hypot(vx, vy)), den, np.nan)
    else:
        den = np.where(den != 0, den, np.nan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return (wx * vy - wy * vx) / den, (wx * uy - wy * ux) / den


def perpendicular_feet(xy: ArrayLike, p: ArrayLike, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Feet of the perpendiculars from points ``xy`` on the lines through ``p`` and ``q``.

    Returns the parameter ``t`` of each foot (``p + t (q - p)``; 0 where ``p == q``),
    not clipped to the segment, and the foot itself.

    >>> t, foot = perpendicular_feet([[1.0, 1.0], [4.0, 2.0]], [0.0, 0.0], [2.0, 0.0])
    >>> t.tolist(), foot.tolist()
    ([0.5, 2.0], [[1.0, 0.0], [4.0, 0.0]])
    """
    xy, p, q = np.asarray(xy, dtype=float), np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    d = q - p
    t = _parameters(xy, p, d)
    return t, p + t[..., None] * d


def _parameters(xy: NDArray[np.float64], p: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Parameters of the feet of the perpendiculars from ``xy`` on the lines ``p + t d``; 0 where ``d == 0``."""
    length2 = _dot(d, d)
    return _dot(xy - p, d) / np.where(length2 > 0, length2, 1.0)


def line_distances(xy: ArrayLike, p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Distances of points ``xy`` from the infinite lines through ``p`` and ``q`` (broadcast; from ``p`` where
    ``p == q``, almost).

    >>> line_distances([[3.0, 1.0], [-1.0, -2.0]], [0.0, 0.0], [1.0, 0.0]).tolist()
    [1.0, 2.0]
    """
    xy, p, q = np.asarray(xy, dtype=float), np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    d, r = q - p, xy - p
    return np.abs(d[..., 0] * r[..., 1] - d[..., 1] * r[..., 0]) / np.maximum(np.hypot(d[..., 0], d[..., 1]), 1e-12)


def point_segment_distances(xy: ArrayLike, p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Distances from points ``xy`` to segments ``p``-``q``.

    >>> point_segment_distances([1.0, 1.0], [[0.0, 0.0], [3.0, 0.0]], [[2.0, 0.0], [3.0, 0.0]]).tolist()
    [1.0, 2.23606797749979]
    """
    xy, p, q = np.asarray(xy, dtype=float), np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    d = q - p
    t = np.clip(_parameters(xy, p, d), 0.0, 1.0)
    gap = p + t[..., None] * d - xy
    return np.hypot(gap[..., 0], gap[..., 1])


def near_segments(
    xy: ArrayLike, p: ArrayLike, q: ArrayLike, tol: ArrayLike, index: shapely.STRtree | None = None
) -> NDArray[np.bool_]:
    """Whether each point ``xy`` (K, 2) lies within ``tol`` (a number, or one per point) of some segment ``p``-``q``.

    The same as ``point_segment_distances(xy[:, None], p[None], q[None]).min(axis=1) <= tol`` to the last bit,
    without the (K, N) matrix: a spatial index of the segments' boxes, grown by the reach, gives the pairs that
    may be within it (boxes only: GEOS's exact distances cost more than numpy's), whose distances are then
    computed as that matrix's would be. ``index``, an STRtree of ``shapely.points(xy)``, is queried with the
    boxes instead (what a caller asking again and again of the same points keeps).

    >>> near_segments([[0.5, 0.04], [0.5, 0.2], [3.0, 0.0]], [[0.0, 0.0]], [[1.0, 0.0]], [0.05, 0.05, 2.5]).tolist()
    [True, False, True]
    """
    xy, p, q = (np.asarray(a, dtype=float).reshape(-1, 2) for a in (xy, p, q))
    tol = np.broadcast_to(np.asarray(tol, dtype=float), len(xy))
    out = np.zeros(len(xy), dtype=bool)
    if not len(xy) or not len(p) or not (tol >= 0).any():
        return out
    reach = float(tol.max()) * (1 + 1e-9) + 1e-12  # a little more: every pair within tol is found
    lo, hi = np.minimum(p, q) - reach, np.maximum(p, q) + reach
    boxes = shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])
    if index is None:
        point, segment = shapely.STRtree(boxes).query(shapely.points(xy))
    else:
        segment, point = index.query(boxes)
    within = point_segment_distances(xy[point], p[segment], q[segment]) <= tol[point]
    out[point[within]] = True
    return out


def nearest_angles(angles: ArrayLike, bearings: ArrayLike) -> NDArray[np.intp]:
    """Index of the angle of ``angles`` (rad, at least one) nearest each of ``bearings`` (rad) around the circle:
    of the two angles either side of a bearing (in order around the circle), the next one when both are as near.

    >>> nearest_angles(np.radians([0.0, 90.0, 180.0, 270.0]), np.radians([10.0, 350.0, 135.0, -100.0])).tolist()
    [0, 0, 2, 3]
    """
    a = np.mod(np.asarray(angles, dtype=float).reshape(-1), 2 * np.pi)
    b = np.mod(np.asarray(bearings, dtype=float).reshape(-1), 2 * np.pi)
    order = np.argsort(a, kind="stable")
    around = a[order]
    after = np.searchsorted(around, b) % len(around)
    before = (after - 1) % len(around)
    gap = np.abs(np.angle(np.exp(1j * (around[[after, before]] - b))))
    return order[np.where(gap[0] <= gap[1], after, before)]


def segment_distances(a: ArrayLike, b: ArrayLike, p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Distances between segments ``a``-``b`` and ``p``-``q``: zero where they cross.

    Else the least of the four end-to-segment distances.

    >>> segment_distances([0.0, 0.0], [2.0, 2.0], [[0.0, 2.0], [3.0, 0.0]], [[2.0, 0.0], [4.0, 0.0]]).tolist()
    [0.0, 2.1213203435596424]
    """
    a, b, p, q = (np.asarray(x, dtype=float) for x in (a, b, p, q))
    sp, sq, sa, sb = cross(a, b, p), cross(a, b, q), cross(p, q, a), cross(p, q, b)
    crossing = (sp * sq <= 0) & (sa * sb <= 0) & ~((sp == 0) & (sq == 0))  # collinear: the ends' distances say it
    ends = np.minimum(
        np.minimum(point_segment_distances(a, p, q), point_segment_distances(b, p, q)),
        np.minimum(point_segment_distances(p, a, b), point_segment_distances(q, a, b)),
    )
    return np.where(crossing, 0.0, ends)


def ray_circle_distances(
    origin: ArrayLike, directions: ArrayLike, centers: ArrayLike, radii: ArrayLike
) -> NDArray[np.float64]:
    """(R, K) distance from ``origin`` along each unit direction (R, 2) to the near side of each circle (K).

    ``inf`` where the ray misses the circle or the circle is behind; the origin
    must be outside every circle.

    >>> ray_circle_distances([0.0, 0.0], [[1.0, 0.0], [-1.0, 0.0]], [[3.0, 0.0], [0.0, 3.0]], [1.0, 1.0]).tolist()
    [[2.0, inf], [inf, inf]]
    """
    u = np.asarray(directions, dtype=float).reshape(-1, 2)
    r = np.asarray(radii, dtype=float).reshape(-1)
    if not len(r):
        return np.empty((len(u), 0))
    c = np.asarray(centers, dtype=float).reshape(-1, 2) - np.asarray(origin, dtype=float)
    b = u[:, 0:1] * c[:, 0] + u[:, 1:2] * c[:, 1]  # (R, K)
    disc = b**2 - ((c**2).sum(axis=1) - r**2)
    with np.errstate(invalid="ignore"):
        near = b - np.sqrt(disc)
    return np.where((disc >= 0) & (near > 0), near, np.inf)


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
