"""A planar laser as a contour sensor: line segments and rays from one scan, in the pipeline's LSL form.

:func:`laser_segments` turns a :class:`~evmap.sources.logs.scan.LaserScan` into
:class:`LaserSegments`:

0. Beams closer than ``beam_step_deg`` (0.5 deg) are taken ``k`` at a time, as one
   beam (:func:`_grouped`): their mean where their ranges agree within the noise,
   else one of them. The defaults fit lasers of 0.5-1 deg: at 0.25 deg with 1 cm of
   noise the points are closer than their noise, and the splits cut a wall into
   pieces of a few points lying across it. A log's noise is measured in its first
   scans (:func:`range_noise`); a laser noisier than ``sigma_r`` has its noise
   model scaled up to it (:meth:`LaserParams.for_noise`, ``evmap log``).
1. Points: ``pose + range * (cos, sin)`` of every beam that returned (no-return
   and maximum-range readings are NaN in the scan and dropped).
2. Clusters by the adaptive breakpoint detector of Borges & Aldon (2004, "Line
   extraction in 2D range images for mobile robotics", J. Intell. Robot. Syst.):
   two consecutive returned points ``n - 1``, ``n``, ``dphi`` apart in angle, are
   broken apart when their distance exceeds
   ``D_max = r_{n-1} * sin(dphi) / sin(lambda - dphi) + 3 * sigma_r``,
   the gap a surface seen at the grazing angle ``lambda`` would leave, plus noise.
   Two or more beams between them that returned nothing break them too: a
   surface continuing from one point to the other would have returned them
   (the formula over the widened ``dphi`` allows more, and any gap once ``dphi``
   reaches ``lambda``: on the Intel log, segments of 8-18 m across rooms); one
   such beam is a dropout, judged by the formula.
3. Split (iterative end-point fit) of each cluster by
   :func:`evmap.sources.polyline.split_pieces`: a point further than
   ``split_threshold + split_sigmas * sigma`` from its piece's chord splits it,
   ``sigma = sigma_r + sigma_per_metre * range`` the point's range noise std;
   pieces of fewer than ``min_points`` points are dropped.
4. Whole runs: a run of ``cluster_min_points`` or more points that no piece
   holds (a cluster whose split left only pieces too short to keep, or what it
   left beside or between the pieces it kept) becomes one piece when every
   point's range is within ``join_sigmas * sigma`` of where its ray meets the
   run's line (with ``cluster_min_points`` 2, the default, a cluster of two
   points is one segment between them: a chair leg, a door frame, a far wall
   at a grazing angle).
   Merge: two neighbouring pieces of a cluster whose union still fits one line
   (every point within ``split_threshold + split_sigmas * sigma_r`` of the union's
   fitted line, its range within ``join_sigmas * sigma`` of where its ray meets
   it) become one. Grow: each piece takes on the neighbouring points of
   its cluster that no piece holds (the remnants of splits too short to keep)
   while their range is within ``join_sigmas * sigma`` of where their ray meets
   its line (the noise is along the ray: a point seen at a grazing angle may lie
   near the line yet far from it in range).
   End runs: a run of one or two points (up to ``end_points``) that no piece
   holds, next to a piece of its cluster, becomes a segment of its own: a run
   of two between its points, a run of one with the piece's nearest point
   (shared, as a split point is). These are what a split leaves beyond a corner
   too few to fit, a mixed point at an edge, the start of a surface at a
   grazing angle: a ray the segments would otherwise not explain.
5. Ends: each piece's total-least-squares line is cut by the rays of its first
   and last points, so the segment spans, seen from the laser, exactly the beams
   it was fitted to; but the point's foot on the line where its ray meets the line
   farther than ``join_sigmas * sigma`` from it in range (a point off the line, as
   the next wall's first one: at a grazing angle its ray runs on past the corner).

The segments come in the pipeline's :class:`~evmap.sources.readings.LslSegments`
form (``truth`` is :data:`UNKNOWN_TRUTH`, ``snapshot`` 0, ``source`` ``""``); the
rays (origin and one end per beam, the returned ones flagged) come along so that
the free space along them can be computed.

Examples
--------
>>> from evmap.sources.laser_params import LaserParams
>>> from evmap.sources.logs.scan import LaserScan
>>> angles = np.radians(np.arange(-45.0, 46.0))
>>> wall = 2.0 / np.cos(angles)                        # a wall 2 m ahead
>>> scan = LaserScan(0.0, np.zeros(3), angles, wall, 80.0)
>>> segs = laser_segments(scan, LaserParams(), pose_index=4)
>>> segs.segments.p.round(3).tolist(), segs.segments.q.round(3).tolist(), segs.segments.pose.tolist()
([[2.0, -2.0]], [[2.0, 2.0]], [4])
>>> segs.pieces.tolist(), int(segs.returned.sum())
([[0, 90]], 91)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evmap.sources.laser_params import LaserParams
from evmap.sources.logs.scan import LaserScan
from evmap.sources.params import LslParams
from evmap.sources.polyline import fit_pieces, piece_lines, piece_members, piece_rows, split_pieces
from evmap.sources.readings import LslSegments

__all__ = ["UNKNOWN_TRUTH", "LaserSegments", "Rays", "breakpoints", "laser_segments"]

UNKNOWN_TRUTH = ""
"""``truth`` of a segment from real data: the segment store's "unknown" (fits the ``<U5`` dtype of
:class:`~evmap.sources.readings.LslSegments`; ``"unknown"`` would need ``<U7`` and a new value in
``docs/SCENARIO.md``'s ``segments.json``)."""


@dataclass(frozen=True, eq=False)
class Rays:
    """The rays of one scan of a contour sensor, in the world frame.

    Attributes
    ----------
    origin : (2,) the sensor's position.
    ends : (R, 2) end of every ray: its point if it returned, else at the maximum range.
    returned : (R,) whether each ray returned.
    """

    origin: NDArray[np.float64]
    ends: NDArray[np.float64]
    returned: NDArray[np.bool_]


@dataclass(frozen=True, eq=False)
class LaserSegments:
    """The segments and rays of one laser scan.

    Attributes
    ----------
    segments : the line segments, in the pipeline's LSL form (world frame).
    pieces : (N, 2) index of the first and last beam of each segment's points.
    origin : (2,) the laser's position (world).
    ends : (R, 2) end of every beam: its point if it returned, else at the maximum range.
    returned : (R,) whether each beam returned.
    """

    segments: LslSegments
    pieces: NDArray[np.intp]
    origin: NDArray[np.float64]
    ends: NDArray[np.float64]
    returned: NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def rays(self) -> Rays:
        """The scan's rays (origin, ends, returned)."""
        return Rays(self.origin, self.ends, self.returned)


DROPOUT = 1
"""Beams without return between two returned ones that may still lie on one surface (a dark spot)."""


def breakpoints(scan: LaserScan, params: LaserParams) -> NDArray[np.intp]:
    """Beam indices of the returned beams that start a new cluster (the first returned beam included).

    >>> from evmap.sources.logs.scan import LaserScan
    >>> bearings = np.radians([0.0, 1, 2, 3, 4, 5])
    >>> scan = LaserScan(0.0, np.zeros(3), bearings, np.array([2, 2, 4, np.nan, 4, 4.0]), 80.0)
    >>> breakpoints(scan, LaserParams()).tolist()  # 2 m -> 4 m breaks; one beam without return is a dropout
    [0, 2]
    >>> scan = LaserScan(0.0, np.zeros(3), bearings, np.array([2, 2, 4, np.nan, np.nan, 4.0]), 80.0)
    >>> breakpoints(scan, LaserParams()).tolist()  # two beams without return: the surface did not go on
    [0, 2, 5]
    """
    beams = np.flatnonzero(~np.isnan(scan.ranges))
    if len(beams) == 0:
        return beams
    r, phi = scan.ranges[beams], scan.angles[beams]
    x, y = r * np.cos(phi), r * np.sin(phi)
    gap = np.hypot(np.diff(x), np.diff(y))
    dphi = np.diff(phi)
    lam = np.radians(params.lambda_deg)
    with np.errstate(divide="ignore"):
        room = np.where(dphi < lam, np.sin(lam - dphi), 0.0)
        d_max = np.where(room > 0, r[:-1] * np.sin(dphi) / room, np.inf) + 3 * params.sigma_r
    return np.concatenate([beams[:1], beams[1:][(gap > d_max) | (np.diff(beams) > 1 + DROPOUT)]])


def laser_segments(scan: LaserScan, params: LaserParams, pose_index: int = 0) -> LaserSegments:
    """Line segments and rays of one scan (see the module doc); ``pose_index`` fills the segments' ``pose``.

    Beams closer than ``beam_step_deg`` are first taken ``k`` at a time (:func:`_grouped`): the segments are
    fitted to the groups, each spanning its groups' beams; the rays are every beam's.
    """
    grouped, k = _grouped(scan, params)
    segments, pieces = _segments(grouped, params, pose_index)
    pieces = np.column_stack([pieces[:, 0] * k, np.minimum(pieces[:, 1] * k + k - 1, len(scan.ranges) - 1)])
    returned = ~np.isnan(scan.ranges)
    origin = scan.pose[:2].copy()
    return LaserSegments(segments, pieces.reshape(-1, 2), origin, _local(scan) + origin, returned)


def _local(scan: LaserScan) -> NDArray[np.float64]:
    """(R, 2) each beam's return, or its maximum range where it returned nothing, from the laser (world axes)."""
    b = scan.bearings
    r = np.where(np.isnan(scan.ranges), scan.max_range, scan.ranges)
    return r[:, None] * np.column_stack([np.cos(b), np.sin(b)])


def _grouped(scan: LaserScan, params: LaserParams) -> tuple[LaserScan, int]:
    """The scan with its beams taken ``k = round(beam_step_deg / step)`` at a time when that is 2 or more (the
    last group filled with beams that returned nothing), and ``k``: a group whose ranges agree within 3 range
    noise stds is one beam at their mean range and angle (the noise less by sqrt(k)); another, one of its beams,
    the middle one (the first of two: an edge between two surfaces, no mean range in the air between them)."""
    step = float(np.median(np.diff(scan.angles))) if len(scan.angles) > 1 else 0.0
    k = round(float(np.radians(params.beam_step_deg)) / step) if step > 0 else 1
    if k < 2:
        return scan, 1
    m = -(-len(scan.angles) // k)
    pad = m * k - len(scan.angles)
    r = np.concatenate([scan.ranges, np.full(pad, np.nan)]).reshape(m, k)
    a = np.concatenate([scan.angles, scan.angles[-1] + step * np.arange(1, pad + 1)]).reshape(m, k)
    middle = (k - 1) // 2  # the first of two: the last group's padding is no beam
    sigma = params.sigma_r + params.sigma_per_metre * r[:, middle]
    with np.errstate(invalid="ignore"):
        agree = np.ptp(r, axis=1) <= 3 * sigma  # False where a beam returned nothing (NaN)
    ranges = np.where(agree, r.mean(axis=1), r[:, middle])
    angles = np.where(agree, a.mean(axis=1), a[:, middle])
    return LaserScan(scan.stamp, scan.pose, angles, ranges, scan.max_range), k


def _segments(scan: LaserScan, params: LaserParams, pose_index: int) -> tuple[LslSegments, NDArray[np.intp]]:
    """The segments of a scan whose beams are taken one at a time, and (N, 2) the first and last beam of each."""
    returned = ~np.isnan(scan.ranges)
    origin = scan.pose[:2].copy()
    local = _local(scan)
    starts = breakpoints(scan, params)
    beams = np.flatnonzero(returned)
    # returned points in scan order, a NaN row before every cluster but the first: no piece spans two clusters
    cluster_start = np.zeros(len(returned), dtype=bool)
    cluster_start[starts[1:]] = True
    cluster_start = cluster_start[beams]
    order = np.arange(len(beams)) + np.cumsum(cluster_start)
    points = np.full((len(beams) + int(cluster_start.sum()), 2), np.nan)
    points[order] = local[beams]
    fit_params = LslParams(
        split_threshold=params.split_threshold,
        split_sigmas=params.split_sigmas,
        min_points=params.min_points,
        break_distance=10.0,  # its largest: the clusters are already broken by the breakpoint detector
    )
    sigma = params.sigma_r + params.sigma_per_metre * np.nan_to_num(np.hypot(*points.T))
    pieces = split_pieces(points, sigma, fit_params)
    beam_of_row = np.full(len(points), -1)
    beam_of_row[order] = beams
    tolerance = params.split_threshold + params.split_sigmas * params.sigma_r
    limit = params.join_sigmas * sigma
    pieces = _whole_runs(points, pieces, limit, params.cluster_min_points)
    pieces = _grow(points, _merge(points, pieces, tolerance, limit), limit)
    pieces = _end_runs(points, pieces, params.end_points) if params.end_points else pieces
    p, q = _cut_by_end_rays(points, pieces, limit)
    n = len(pieces)
    segments = LslSegments(
        p=p + origin,
        q=q + origin,
        truth=np.full(n, UNKNOWN_TRUTH, dtype="<U5"),
        snapshot=np.zeros(n, dtype=np.intp),
        source=np.full(n, "", dtype="<U1"),
        pose=np.full(n, pose_index, dtype=np.intp),
    )
    return segments, beam_of_row[pieces].reshape(-1, 2)


def _merge(
    points: NDArray[np.float64], pieces: NDArray[np.intp], tolerance: float, limit: NDArray[np.float64]
) -> NDArray[np.intp]:
    """Neighbouring pieces (sharing a point or on adjacent rows) merged while one line still fits: every point of
    the union within ``tolerance`` of its line, and its range within ``limit`` of where its ray meets the line."""
    first, last = pieces.T
    joins = np.r_[False, first[1:] - last[:-1] <= 1]  # whether each piece neighbours the one before
    # whether a span's points (first and last row) fit one line: found at once for each piece that joins with the
    # one or two before it (the unions a merge most often needs), for the others when needed
    one, two = np.flatnonzero(joins), np.flatnonzero(joins[2:] & joins[1:-1]) + 2
    spans = np.column_stack([first[np.r_[one - 1, two - 2]], last[np.r_[one, two]]])
    fits = dict(zip(map(tuple, spans.tolist()), _fits_one_line(points, spans, tolerance, limit).tolist()))
    merged: list[list[int]] = []
    for k, (a, b) in enumerate(pieces.tolist()):
        span = (merged[-1][0], b) if joins[k] else None
        if span is not None and span not in fits:
            fits[span] = bool(_fits_one_line(points, np.array([span]), tolerance, limit)[0])
        if span is not None and fits[span]:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return np.array(merged, dtype=np.intp).reshape(-1, 2)


def _fits_one_line(
    points: NDArray[np.float64], spans: NDArray[np.intp], tolerance: float, limit: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Whether every point of each span (first and last row) lies within ``tolerance`` of the span's line and its
    range within ``limit``."""
    if len(spans) == 0:
        return np.zeros(0, dtype=bool)
    centre, u = piece_lines(points, spans)
    rows = piece_rows(spans)  # padded with a span's last point: the same maximum, the same all
    each = np.take(points, rows, axis=0)  # each span's points in a row
    normal = u[:, ::-1] * [-1, 1]  # u turned a quarter left
    # a matrix product per span (stacked), rounded as one span's was: BLAS may fuse the multiply-add
    distance = np.abs(np.matmul(each - centre[:, None], normal[:, :, None])[..., 0])
    ranges = _range_misfit(each, centre[:, None], u[:, None]) <= limit[rows]
    return (distance.max(axis=1) <= tolerance) & ranges.all(axis=1)


def _free_runs(
    points: NDArray[np.float64], pieces: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """First and last row of each run of points that no piece holds (a run ends at a NaN row or a held point), and
    whether each row is held (one entry more, False: ``held[-1]`` and ``held[len(points)]`` stand for no row)."""
    held = np.zeros(len(points) + 1, dtype=bool)
    held[piece_members(pieces)[0]] = True
    edges = np.diff(np.r_[0, (~np.isnan(points[:, 0]) & ~held[:-1]).astype(np.int8), 0])
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, held


def _whole_runs(
    points: NDArray[np.float64], pieces: NDArray[np.intp], limit: NDArray[np.float64], min_points: int
) -> NDArray[np.intp]:
    """The pieces, and each run of ``min_points`` or more points that no piece holds (a cluster without a piece,
    or what a split left of one) as one more piece when every point's range is within ``limit`` of the run's line
    (along its ray)."""
    first, last, _ = _free_runs(points, pieces)
    whole = np.column_stack([first, last])[last - first + 1 >= min_points]
    if len(whole):
        p, q = fit_pieces(points, whole)  # a point of each run's line and another
        members, owner, starts = piece_members(whole)
        with np.errstate(invalid="ignore"):
            u = (q - p) / np.hypot(*(q - p).T)[:, None]
        fits = _range_misfit(points[members], p[owner], u[owner]) <= limit[members]
        whole = whole[np.logical_and.reduceat(fits, starts)]
    both = np.concatenate([pieces, whole])
    return both[np.lexsort(both.T[::-1])]


def _range_misfit(
    points: NDArray[np.float64], centre: NDArray[np.float64], u: NDArray[np.float64]
) -> NDArray[np.float64]:
    """How far the range of each point (x, y on the last axis) is from where its ray (from the origin) meets the
    line ``centre + s u`` (one line, or lines broadcast against the points).

    Infinite where the ray runs along the line or meets it behind the origin; NaN for NaN points.
    """
    r = np.hypot(points[..., 0], points[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        meet = (
            r
            * (centre[..., 0] * u[..., 1] - centre[..., 1] * u[..., 0])
            / (points[..., 0] * u[..., 1] - points[..., 1] * u[..., 0])
        )
        return np.where(np.isnan(r) | (meet > 0), np.abs(r - meet), np.inf)


def _grow(points: NDArray[np.float64], pieces: NDArray[np.intp], limit: NDArray[np.float64]) -> NDArray[np.intp]:
    """Each piece extended over the neighbouring points of its cluster that no piece holds, while their range is
    within ``limit`` (per point) of where their ray meets the piece's line: after it up to the next piece, before it
    down to what the piece before took."""
    p, q = fit_pieces(points, pieces)  # a point of each piece's line and another
    with np.errstate(invalid="ignore"):
        u = (q - p) / np.hypot(*(q - p).T)[:, None]
    first, last = pieces.T
    after = np.r_[first[1:], len(points)] - last - 1  # rows between each piece and the next
    end = last + _runs_within(points, limit, last + 1, after, 1, p, u)
    before = first - np.r_[0, end[:-1] + 1]  # rows between the piece before (as grown) and each piece
    return np.column_stack([first - _runs_within(points, limit, first - 1, before, -1, p, u), end])


def _runs_within(
    points: NDArray[np.float64],
    limit: NDArray[np.float64],
    start: NDArray[np.intp],
    count: NDArray[np.intp],
    step: int,
    centre: NDArray[np.float64],
    u: NDArray[np.float64],
) -> NDArray[np.intp]:
    """For each line ``centre + s u``, how many of the ``count`` points from row ``start`` on (``step`` 1: up, -1:
    down; a negative count: none) lie in a row within ``limit`` of it (range along the ray); a NaN point ends the
    row."""
    count = np.maximum(count, 0)
    owner = np.repeat(np.arange(len(count)), count)
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    rows = start[owner] + step * offset
    misfit = ~(_range_misfit(points[rows], centre[owner], u[owner]) <= limit[rows])
    within = count.copy()
    np.minimum.at(within, owner[misfit], offset[misfit])  # up to each line's first misfit
    return within


def _cut_by_end_rays(
    points: NDArray[np.float64], pieces: NDArray[np.intp], limit: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each piece's fitted line cut by the rays (from the origin) of its first and last points; by the point's
    foot where the ray nearly runs along the line or meets it farther than ``limit`` (per point) in range."""
    centre, u = piece_lines(points, pieces)
    c, u, ends = centre[:, None], u[:, None], points[pieces]  # ends: (n, 2, 2), each piece's first and last point
    cross = ends[..., 0] * u[..., 1] - ends[..., 1] * u[..., 0]  # ray direction (end) x line direction
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(
            np.abs(cross) > 1e-3 * np.hypot(ends[..., 0], ends[..., 1]),
            (c[..., 0] * u[..., 1] - c[..., 1] * u[..., 0]) / cross,
            np.nan,
        )
    along = (ends[..., 0] - c[..., 0]) * u[..., 0] + (ends[..., 1] - c[..., 1]) * u[..., 1]
    ray = np.isfinite(t) & (t > 0)
    foot = c + along[..., None] * u
    cut = np.where(ray[..., None], ends * t[..., None], foot)
    off = np.abs(t - 1) * np.hypot(ends[..., 0], ends[..., 1])  # how far in range the ray meets the line
    feet = np.where((ray & (off <= limit[pieces]))[..., None], cut, foot)
    kept = np.hypot(*(feet[:, 1] - feet[:, 0]).T) > 1e-3  # a blob of a few points whose feet meet keeps its rays
    cut[kept] = feet[kept]
    return cut[:, 0], cut[:, 1]


def _end_runs(points: NDArray[np.float64], pieces: NDArray[np.intp], longest: int) -> NDArray[np.intp]:
    """The pieces, and each run of at most ``longest`` (1 or 2) points that no piece holds, next to a piece in its
    cluster, as one more piece: a run of two on its own, a run of one with the piece's nearest point (shared, as a
    split point is)."""
    first, last, held = _free_runs(points, pieces)
    left, right = held[first - 1], held[last + 1]
    single = first == last
    runs = np.column_stack([np.where(single & left, first - 1, first), np.where(single & ~left, last + 1, last)])
    both = np.concatenate([pieces, runs[(last - first < longest) & (left | right)]])
    return both[np.lexsort(both.T[::-1])]
