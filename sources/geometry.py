"""Plane geometry over arrays of points, segments, rays and circles: distances, crossings, nearest bearings.

Every function takes numpy arrays whose last axis is (x, y) and broadcasts over
the others; a segment ``p``-``q`` with ``p == q`` is a point. Both the simulator
(``evmap.sources.sim``) and the evidence side use these, so that each formula is
written once.
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "boxes_meet",
    "cross",
    "crossings",
    "line_distances",
    "near_segments",
    "nearest_angles",
    "perpendicular_feet",
    "point_segment_distances",
    "ray_circle_distances",
    "segment_distances",
]


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


def boxes_meet(lo: ArrayLike, hi: ArrayLike, other_lo: ArrayLike, other_hi: ArrayLike) -> NDArray[np.bool_]:
    """Whether axis-aligned boxes (corners ``lo``-``hi``, (..., 2)) meet the boxes ``other_lo``-``other_hi``,
    edges touching included; the shapes broadcast (``lo[:, None]`` against ``other_lo``: every pair).

    >>> boxes_meet([[0, 0], [2, 2]], [[1, 1], [3, 3]], [1, 0], [2, 1]).tolist()  # the first touches its corner
    [True, False]
    >>> boxes_meet(np.array([[0.0, 0.0]])[:, None], np.array([[1.0, 1.0]])[:, None], [[2, 0], [0.5, 0.5]], [[3, 1], [4, 4]])
    array([[False,  True]])
    """
    lo, hi, other_lo, other_hi = (np.asarray(a) for a in (lo, hi, other_lo, other_hi))
    return (
        (lo[..., 0] <= other_hi[..., 0])
        & (hi[..., 0] >= other_lo[..., 0])
        & (lo[..., 1] <= other_hi[..., 1])
        & (hi[..., 1] >= other_lo[..., 1])
    )


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


def wrapped(angle: ArrayLike) -> NDArray[np.float64]:
    """Angles (rad) wrapped to [-pi, pi): a difference of two bearings as the signed turn between them.
    An angle already in [-pi, pi) comes back as it is, to the bit.

    >>> wrapped([0.1, np.pi, -np.pi]).tolist(), wrapped(np.radians([190.0, 540.0])).round(4).tolist()
    ([0.1, -3.141592653589793, -3.141592653589793], [-2.9671, -3.1416])
    """
    a = np.asarray(angle, dtype=float)
    turned = (a + np.pi) % (2 * np.pi) - np.pi  # pi where the remainder rounds up to 2 pi
    return np.where((a >= -np.pi) & (a < np.pi), a, np.where(turned < np.pi, turned, -np.pi))


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
    gap = np.abs(wrapped(around[[after, before]] - b))
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
