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

__all__ = ["fit_pieces", "fit_polylines", "piece_lines", "piece_members", "piece_rows", "split_pieces"]


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
    """(n, 2) first and last index of each piece: runs broken at gaps, split by iterative end-point fit (all the
    pieces of a round at once)."""
    tol = params.split_threshold + params.split_sigmas * sigma
    valid = np.flatnonzero(~np.isnan(points).any(axis=1))
    if len(valid) == 0:
        return np.zeros((0, 2), dtype=np.intp)
    gap = np.hypot(*np.diff(points[valid], axis=0).T)
    cut = np.flatnonzero((np.diff(valid) != 1) | (gap > params.break_distance)) + 1
    runs = np.column_stack([valid[np.r_[0, cut]], valid[np.r_[cut - 1, len(valid) - 1]]])
    todo, pieces = runs[runs[:, 1] - runs[:, 0] + 1 >= params.min_points], np.zeros((0, 2), dtype=np.intp)
    while len(todo):
        far, split = _farthest_from_chord(points, todo, tol)
        pieces = np.concatenate([pieces, todo[~split]])
        halves = np.repeat(todo[split], 2, axis=0)  # each split piece twice, cut at its farthest point
        halves[::2, 1] = halves[1::2, 0] = far[split]
        todo = halves[halves[:, 1] - halves[:, 0] + 1 >= params.min_points]
    return pieces[np.lexsort(pieces.T[::-1])]


def _farthest_from_chord(
    points: NDArray[np.float64], pieces: NDArray[np.intp], tol: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Index of each piece's point farthest from its chord (the first of equals), and whether any point of the piece
    is further than its ``tol`` from the chord."""
    rows = piece_rows(pieces)
    start, chord = points[pieces[:, 0]], points[pieces[:, 1]] - points[pieces[:, 0]]
    normal = chord[:, ::-1] * [-1, 1] / np.hypot(*chord.T)[:, None]  # the chord turned a quarter left, unit length
    # a matrix product per piece (stacked), rounded as one piece's was: BLAS may fuse the multiply-add
    deviation = np.abs(np.matmul(np.take(points, rows, axis=0) - start[:, None], normal[:, :, None])[..., 0])
    return pieces[:, 0] + deviation.argmax(axis=1), (deviation > tol[rows]).any(axis=1)


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


def piece_lines(
    points: NDArray[np.float64], pieces: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Total least squares line of each piece's points, centre and unit direction: to the last bit the line numpy
    gives for the piece's points alone (the centre summed point after point, as ``mean(axis=0)`` sums; the moments
    pairwise, as ``sum`` sums; :func:`fit_pieces` sums in another order).

    >>> pts = np.random.default_rng(1).normal(size=(30, 2))
    >>> centre, u = piece_lines(pts, np.array([[0, 11], [11, 29]]))
    >>> d = pts[11:] - pts[11:].mean(axis=0)
    >>> phi = 0.5 * np.arctan2(2 * (d[:, 0] * d[:, 1]).sum(), (d[:, 0] ** 2).sum() - (d[:, 1] ** 2).sum())
    >>> bool((centre[1] == pts[11:].mean(axis=0)).all() and (u[1] == [np.cos(phi), np.sin(phi)]).all())
    True
    """
    if len(pieces) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    members, owner, starts = piece_members(pieces)
    count = pieces[:, 1] - pieces[:, 0] + 1
    rows = piece_rows(pieces)
    past_end = np.arange(rows.shape[1]) >= count[:, None]
    # one piece a column, -0.0 past its end, summed over the first axis: point after point
    padded = np.take(np.append(points, [[-0.0, -0.0]], axis=0), np.where(past_end, len(points), rows).T, axis=0)
    centre = padded.sum(axis=0) / count[:, None]
    d = points[members] - centre[owner]
    sxx, syy, sxy = _piece_sums(np.column_stack([d[:, 0] ** 2, d[:, 1] ** 2, d[:, 0] * d[:, 1]]), starts).T
    phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return centre, np.column_stack([np.cos(phi), np.sin(phi)])


def _piece_sums(values: NDArray[np.float64], starts: NDArray[np.intp]) -> NDArray[np.float64]:
    """Sum of each piece's values (rows; the pieces one after the other, from ``starts``), each summed as ``sum``
    sums it alone (pairwise): ``np.add.reduceat`` starts from a piece's first value and sums the rest pairwise, so
    a -0.0 goes first."""
    return np.add.reduceat(np.insert(values, starts, -0.0, axis=0), starts + np.arange(len(starts)), axis=0)


def piece_rows(pieces: NDArray[np.intp]) -> NDArray[np.intp]:
    """(n, m) the point indices of each piece in a row, ``m`` the longest piece's count, a shorter piece's row
    padded with its last index (the row's maximum, first arg-maximum, any and all are those of the piece).

    >>> piece_rows(np.array([[0, 3], [3, 4], [6, 8]])).tolist()
    [[0, 1, 2, 3], [3, 4, 4, 4], [6, 7, 8, 8]]
    """
    count = pieces[:, 1] - pieces[:, 0] + 1
    return pieces[:, :1] + np.minimum(np.arange(count.max(initial=0)), count[:, None] - 1)


def piece_members(pieces: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The point indices of all pieces one after the other, the piece of each, and where each piece starts."""
    count = pieces[:, 1] - pieces[:, 0] + 1
    starts = np.cumsum(count) - count
    members = np.repeat(pieces[:, 0] - starts, count) + np.arange(count.sum())
    return members, np.repeat(np.arange(len(pieces)), count), starts
