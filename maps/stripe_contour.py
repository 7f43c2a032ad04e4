"""The contour a pose's stripe draws on the map's believed lines: beyond it, an echo is a multiple reflection.

The stripe points of a pose that lie on believed lines (within
:attr:`~evmap.maps.free_space.FreeSpaceParams.margin`) are opaque surfaces the
sound does not come back through; :func:`stripe_bound` is the star polygon
through them (:func:`~evmap.maps.free_space.contour_bound`), with the chords,
at most ``unidentified.window_width`` long, across the gaps between believed
lines that the chord continues (panes in a wall, :func:`in_line`). Rays whose
point lies on no believed line leave a hole in it, out to the bound's reach (a
point in front of a believed line, a sunlight phantom before a wall, too: taking
it to hide the line lost a glass partition's echo behind a short believed phantom
line, ``docs/METHOD.md``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.maps.free_space import FreeSpaceParams, contour_bound, surface_rays
from evmap.maps.object_faces import WALL_ANGLE
from evmap.maps.sensed import Sensed
from evmap.sources.geometry import point_segment_distances
from evmap.sources.params import UnidentifiedParams

__all__ = ["in_line", "stripe_bound"]


def stripe_bound(
    s: Sensed, p: NDArray[np.float64], q: NDArray[np.float64], params: UnidentifiedParams, reach: float
) -> shapely.Geometry | None:
    """The contour of the pose ``s`` on the believed lines p-q (module doc), out to ``reach``; None when no ray
    of the pose ends on one.

    >>> bearing = np.radians(np.arange(-180.0, 180.0, 1.0))
    >>> rng = np.where(np.abs(bearing) < np.radians(40), 2 / np.cos(bearing), np.nan)  # a wall x = 2
    >>> s, wall = Sensed(0, np.zeros(2), bearing, rng, None), (np.array([[2.0, -2.0]]), np.array([[2.0, 2.0]]))
    >>> bound = stripe_bound(s, *wall, UnidentifiedParams(), 10.0)
    >>> [bool(bound.contains(shapely.Point(x, 1))) for x in (1.9, 2.1)]  # in front of the wall, behind it
    [True, False]
    """
    shape = FreeSpaceParams(bridge=params.window_width)
    surfaces = surface_rays(s, p, q, shape.margin, on=True)
    return contour_bound(surfaces, shape, reach, in_line(p, q, shape.margin))


def in_line(
    p: NDArray[np.float64], q: NDArray[np.float64], margin: float
) -> Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]]:
    """Which chords a-b cross a gap in a wall: each end on a line p-q (within ``margin``) that the chord continues.

    A gap between two walls meeting at a corner is no pane: its chord would cut the corner off.
    """

    def ok(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
        if not len(p):
            return np.zeros(len(a), dtype=bool)
        chord = (b - a) / np.maximum(np.hypot(*(b - a).T), 1e-12)[:, None]
        d = (q - p) / np.maximum(np.hypot(*(q - p).T), 1e-12)[:, None]
        out = np.ones(len(a), dtype=bool)
        for end in (a, b):
            dist = point_segment_distances(end[:, None], p[None], q[None])  # (K, L)
            near = dist.argmin(axis=1)
            sin = np.abs(chord[:, 0] * d[near, 1] - chord[:, 1] * d[near, 0])
            out &= (dist[np.arange(len(end)), near] <= margin) & (sin <= np.sin(WALL_ANGLE))
        return out

    return ok
