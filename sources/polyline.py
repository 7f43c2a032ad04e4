"""Line segments from ordered contour points: break at gaps, split by iterative end-point fit, fit by TLS.

The ordered points of a contour sensor (one LSL snapshot, one laser scan) are
broken where a point is missing (NaN) or consecutive points are more than
``break_distance`` apart, then split by iterative end-point fit (a point further
than ``split_threshold + split_sigmas * sigma`` from its piece's chord, sigma the
point's range-noise std, splits the piece there). Pieces of fewer than
``min_points`` points are dropped; each other piece is fitted by total least
squares and clipped to its extreme points.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.params import LslParams

__all__ = ["fit_pieces", "fit_polylines", "piece_members", "split_pieces"]


def fit_polylines(
    points: ArrayLike, sigma: ArrayLike, params: LslParams
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """Line segments from one snapshot's ordered stripe points (NaN rows: no return).

    Parameters
    ----------
    points : (M, 2) stripe points in scan order.
    sigma : (M,) range-noise std of each point (m); widens the split distance.
    params : ``split_threshold``, ``split_sigmas``, ``break_distance``, ``min_points``.

    Returns
    -------
    p, q : (n, 2) fitted segment ends, ``p`` on the side of the first point.
    pieces : (n, 2) index of the first and last point of each segment's piece
        (the point where a piece was split belongs to both pieces).

    >>> wall = [[x, 2.0] for x in np.linspace(-0.5, 0.5, 21)]
    >>> side = [[0.5, y] for y in np.linspace(1.95, 1.75, 5)]
    >>> gap_then_wall = [[np.nan, np.nan]] + [[x, 1.0] for x in np.linspace(0.5, 0.7, 5)]
    >>> p, q, pieces = fit_polylines(wall + side + gap_then_wall, np.zeros(32), LslParams())
    >>> p.round(6).tolist(), q.round(6).tolist(), pieces.tolist()
    ([[-0.5, 2.0], [0.5, 2.0], [0.5, 1.0]], [[0.5, 2.0], [0.5, 1.75], [0.7, 1.0]], [[0, 20], [20, 25], [27, 31]])
    """
    points = np.asarray(points, dtype=float)
    pieces = split_pieces(points, np.asarray(sigma, dtype=float), params)
    p, q = fit_pieces(points, pieces)
    return p, q, pieces


def split_pieces(points: NDArray[np.float64], sigma: NDArray[np.float64], params: LslParams) -> NDArray[np.intp]:
    """(n, 2) first and last index of each piece: runs broken at gaps, split by iterative end-point fit."""
    tol = params.split_threshold + params.split_sigmas * sigma
    valid = np.flatnonzero(~np.isnan(points).any(axis=1))
    gap = np.hypot(*np.diff(points[valid], axis=0).T)
    cut = np.flatnonzero((np.diff(valid) != 1) | (gap > params.break_distance)) + 1
    pieces = []
    for run in np.split(valid, cut):
        stack = [(run[0], run[-1])] if len(run) >= params.min_points else []
        while stack:
            a, b = stack.pop()
            pts = points[a : b + 1]
            chord = pts[-1] - pts[0]
            normal = np.array([-chord[1], chord[0]]) / np.hypot(*chord)
            deviation = np.abs((pts - pts[0]) @ normal)
            if np.any(deviation > tol[a : b + 1]):
                m = a + int(np.argmax(deviation))
                stack += [(m, b)] if b - m + 1 >= params.min_points else []
                stack += [(a, m)] if m - a + 1 >= params.min_points else []
            else:
                pieces.append((a, b))
    return np.array(sorted(pieces), dtype=np.intp).reshape(-1, 2)


def fit_pieces(
    points: NDArray[np.float64], pieces: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Total least squares line of each piece's points, clipped to its extreme points, all pieces at once."""
    if len(pieces) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    members, owner, starts = piece_members(pieces)
    count = np.diff(np.append(starts, len(members)))
    centre = np.add.reduceat(points[members], starts, axis=0) / count[:, None]
    d = points[members] - centre[owner]
    sxx, syy, sxy = (np.add.reduceat(v, starts) for v in (d[:, 0] ** 2, d[:, 1] ** 2, d[:, 0] * d[:, 1]))
    phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)  # direction of largest spread
    u = np.column_stack([np.cos(phi), np.sin(phi)])
    u[((points[pieces[:, 1]] - points[pieces[:, 0]]) * u).sum(axis=1) < 0] *= -1  # first point to last
    t = (d * u[owner]).sum(axis=1)
    t_min, t_max = np.minimum.reduceat(t, starts), np.maximum.reduceat(t, starts)
    return centre + t_min[:, None] * u, centre + t_max[:, None] * u


def piece_members(pieces: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The point indices of all pieces one after the other, the piece of each, and where each piece starts."""
    count = pieces[:, 1] - pieces[:, 0] + 1
    starts = np.cumsum(count) - count
    members = np.repeat(pieces[:, 0] - starts, count) + np.arange(count.sum())
    return members, np.repeat(np.arange(len(pieces)), count), starts
