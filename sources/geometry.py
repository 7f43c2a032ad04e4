"""Plane geometry over arrays of points and segments: distances and crossings.

Every function takes numpy arrays whose last axis is (x, y) and broadcasts over
the others; a segment ``p``-``q`` with ``p == q`` is a point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["cross", "point_segment_distances", "segment_distances"]


def cross(o: ArrayLike, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """The z component of (u - o) x (v - o): > 0 where o, u, v turn left, 0 where collinear.

    >>> float(cross([0, 0], [1, 0], [0, 1]))
    1.0
    """
    o, u, v = np.asarray(o, dtype=float), np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])


def point_segment_distances(xy: ArrayLike, p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Distances from points ``xy`` to segments ``p``-``q``.

    >>> point_segment_distances([1.0, 1.0], [[0.0, 0.0], [3.0, 0.0]], [[2.0, 0.0], [3.0, 0.0]]).tolist()
    [1.0, 2.23606797749979]
    """
    xy, p, q = np.asarray(xy, dtype=float), np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    d = q - p
    length2 = (d * d).sum(axis=-1)
    t = np.clip(((xy - p) * d).sum(axis=-1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    gap = p + t[..., None] * d - xy
    return np.hypot(gap[..., 0], gap[..., 1])


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
