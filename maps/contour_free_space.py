"""Evidence from the contour sensor's rays: free space through a segment, and poses that should have seen it.

Every stripe point is a ray, free from the sensor to the point. For a segment
and a pose's rays that cross the segment's interior (its bearing interval from
the pose), each ray is one of:

- **ends**: its point lies on the segment (within ``tolerance`` plus three
  range-noise stds, measured across the segment);
- **passes**: its point lies beyond the segment: the ray went through it;
- **short**: its point lies in front: something nearer hid the segment;
- **none**: nothing returned although the segment is within the sensor's range:
  an opaque surface there would have returned a point, so the ray went through
  it as a passing one did. So too a ray that went on beyond its point
  (:func:`went_on`: a sensor that reports every surface a ray lit, whose point
  lies on a segment judged noise, the farthest of its bearing), for the
  segments behind that point.

The poses are those whose readings reach the segment, the latest
:data:`~evmap.maps.sensed.LATEST_POSES` of them (:func:`evmap.maps.noise.judge`).
Two features come of it (:func:`ray_features`):

- ``contour_free``: ``contradicted`` when rays of any pose, the segment's own
  included, go through it (pass, or return nothing within range; at least
  ``min_passes``, and at least ``pass_share`` of the rays that end on it or go
  through), else ``clear``. A sunlit patch seen with the ``threshold`` detector
  has the real stripe behind it, and another pose's stripe may cross its place;
  a wall stops every ray that meets it. One ray is enough: a point beyond the
  segment by more than the tolerance and three noise stds is no noise of a
  surface there.
- ``lsl_persistence``: per other pose whose rays reach the segment unhidden
  (at least ``min_rays`` of them): missed if fewer than ``seen_share`` of them
  end on it; seen if at least ``seen_share`` of them end on it and these are at
  least ``seen_cover`` of all its rays that cross the segment, the hidden ones
  included (the pose saw most of it; a few rays that end on it amid hidden ones
  may end on whatever hides the rest, as another pose's phantoms in the same
  sunlight do). ``seen`` if any other pose saw it, ``missed`` if one missed it
  and none saw it, else ``unobserved``. A sunlight phantom, drawn anew per pose,
  is missed by the poses that look at its place; a wall is seen again.

:func:`stripe_edges` tells which ends of a segment the stripe saw as edges (the
sonar forward model gives such an end an echo): the segment's own pose's next
ray beyond the end returned farther, or nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evmap.maps.sensed import Sensed, farthest_returns, laid_out, rays_within
from evmap.sources.geometry import crossings, near_segments, wrapped
from evmap.sources.params import LslParams

__all__ = ["RayParams", "RayTally", "ray_features", "ray_tally", "segments_facing", "stripe_edges", "went_on"]


@dataclass(frozen=True)
class RayParams:
    """Tolerances of the ray tests (metres, shares)."""

    tolerance: float = 0.02  # a point this close to the segment (plus 3 noise stds) ends on it
    range_noise: float = 0.003  # the stripe's range-noise std per metre of range
    max_range: float = 8.0  # the contour sensor's range: beyond it, no return is no evidence
    end_margin: float = 0.03  # rays this close to an end of the segment (a quarter of it at most) are not counted
    min_rays: int = 3  # rays of another pose that reach the segment unhidden, for it to have looked
    min_passes: int = 1  # rays through the segment that contradict it
    pass_share: float = 0.25
    seen_share: float = 0.7
    seen_cover: float = 0.6  # the share of another pose's rays crossing the segment that end on it, to have seen it
    edge_step: float = 0.05  # an end is an edge when the next ray beyond it returns this much farther (3 stds more)
    edge_window_deg: float = 1.0  # the next ray beyond an end is looked for this far beyond it

    @classmethod
    def of_stripe(cls, lsl: LslParams) -> RayParams:
        """The tolerances for a contour sensor: its range noise and range, the rest the defaults."""
        return cls(range_noise=lsl.range_noise, max_range=lsl.max_range)


@dataclass(frozen=True, eq=False)
class RayTally:
    """Counts of rays per segment (N,) and, for other poses, per pose (N, P).

    ``ends`` and ``passes`` count every pose's rays; ``other_*`` count each other pose's.
    """

    ends: NDArray[np.intp]
    passes: NDArray[np.intp]  # rays that went through: passes and no returns
    other_ends: NDArray[np.intp]
    other_misses: NDArray[np.intp]  # passes and no returns
    other_hidden: NDArray[np.intp]  # rays that end in front of the segment


def went_on(
    s: Sensed,
    noise: tuple[NDArray[np.float64], NDArray[np.float64]],
    kept: tuple[NDArray[np.float64], NDArray[np.float64]],
    params: RayParams,
) -> NDArray[np.bool_]:
    """(K,) the rays of one pose that went on beyond their point and returned nothing more within range.

    Only a sensor that reports every surface a ray lit (:attr:`Sensed.all_returns`: a camera keeping every
    stripe pixel above its threshold) tells this: a ray whose point lies on one of the pose's segments judged
    noise (``noise``: their ends p, q; within ``tolerance`` and three range-noise stds), on none of those kept
    (``kept``), and is the farthest point of its bearing, lit no opaque surface beyond it within range, or the
    sensor would have reported that point too. A sunlit patch is no surface: the ray goes on through it. A
    sensor with one return a ray (a laser; a camera keeping a column's brightest pixel) tells nothing of what
    lies beyond its point: no ray of it went on.

    >>> bearing = np.array([0.0, 0.0, 0.1, 0.2])  # two points at bearing 0: a patch at 1 m, a wall at 3 m
    >>> s = Sensed(0, np.zeros(2), bearing, np.array([1.0, 3.0, 1.0, 0.9]), None, all_returns=True)
    >>> patch = np.array([[1.0, -0.5]]), np.array([[1.0, 0.5]])  # judged noise
    >>> went_on(s, patch, (np.zeros((0, 2)), np.zeros((0, 2))), RayParams()).tolist()
    [False, False, True, False]

    The first ray's point on the patch has the wall beyond it; the last ray's point is off the patch.
    """
    out = np.zeros(len(s.range), dtype=bool)
    if not s.all_returns or not len(noise[0]):
        return out
    returned = np.flatnonzero(np.isfinite(s.range))  # the rays of s.points
    tol = params.tolerance + 3 * params.range_noise * s.range[returned]
    on = near_segments(s.points, *noise, tol, s.point_index) & np.isfinite(farthest_returns(s).range[returned])
    if len(kept[0]) and on.any():
        on[on] = ~near_segments(s.points[on], *kept, tol[on])
    out[returned[on]] = True
    return out


def _crossings(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    poses: Sequence[Sensed],
    params: RayParams,
    beyond: Sequence[NDArray[np.bool_]] | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """(segment, pose, kind) of every ray of the ``poses`` (their positions in the sequence) crossing a segment's
    interior; kind 0 ends, 1 passes, 2 short, 3 none. ``beyond``: per pose, the rays that went on beyond their
    point (:func:`went_on`): none, where they cross a segment behind their point within range.

    All (segment, pose) pairs at once (:func:`~evmap.maps.sensed.rays_within`).
    """
    n, m = len(p), len(poses)
    origin = np.array([s.origin for s in poses], dtype=float).reshape(-1, 2)
    _, _, bearing, rng = laid_out(poses)
    a = (p[None] - origin[:, None]).reshape(-1, 2)  # (pose, segment) pairs, pose-major
    b = (q[None] - origin[:, None]).reshape(-1, 2)
    lo, width = _spans(a, b)
    pair, ray = rays_within(poses, np.repeat(np.arange(m), n), lo, width)
    k, seg = pair // n, pair % n
    r = rng[ray]
    u = np.take(np.column_stack([np.cos(bearing), np.sin(bearing)]), ray, axis=0)  # u[ray], faster
    e = b - a
    length = np.maximum(np.hypot(*e.T), 1e-12)
    a, e, length = (np.take(x, pair, axis=0) for x in (a, e, length))
    t, along = crossings(np.zeros(2), u, a, e)  # the crossing's range along the ray, its place on the segment
    along = along * length  # in metres
    cross = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
    sin = np.abs(cross) / length
    margin = np.minimum(params.end_margin, length / 4)  # a short segment keeps the middle half of it
    inside = (np.abs(cross) > 1e-12) & (t > 0) & (along >= margin) & (along <= length - margin)
    across = (r - t) * sin  # the point's distance beyond the segment, across it
    tol = params.tolerance + 3 * params.range_noise * t * sin
    short = across < -tol
    none = np.isnan(r)
    if beyond:
        none |= short & np.concatenate(beyond)[ray]  # it went on beyond its point, through the segment
    kind = np.where(none, 3, np.where(across > tol, 1, np.where(short, 2, 0)))
    keep = inside & ~(none & (t > params.max_range))  # out of range: not counted
    return seg[keep], k[keep], kind[keep]


def ray_tally(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    pose: NDArray[np.intp],
    poses: Sequence[Sensed],
    params: RayParams,
    beyond: Sequence[NDArray[np.bool_]] | None = None,
) -> RayTally:
    """Count, for segments p-q seen from ``pose``, the rays of every sensed pose by kind (module doc).

    ``beyond``: per pose of ``poses``, the rays that went on beyond their point (:func:`went_on`); none if not given.

    >>> from evmap.sources.readings import SonarScan
    >>> from evmap.sources.params import SonarParams
    >>> sonar = SonarScan.from_readings([0.0], [1.0], SonarParams())
    >>> bearing = np.linspace(-0.2, 0.2, 41)
    >>> wall = Sensed(0, np.zeros(2), bearing, 2 / np.cos(bearing), sonar)  # rays ending on x = 2
    >>> p, q = np.array([[1.0, -0.1], [2.0, -0.1]]), np.array([[1.0, 0.1], [2.0, 0.1]])
    >>> tally = ray_tally(p, q, np.array([1, 1]), [wall], RayParams())
    >>> tally.passes.tolist(), tally.ends.tolist(), tally.other_misses[:, 0].tolist()
    ([13, 0], [0, 7], [13, 0])
    """
    n, m = len(p), len(poses)
    by_kind = np.zeros((n, m, 4), dtype=np.intp)
    if n and m:
        seg, k, kind = _crossings(p, q, poses, params, beyond)
        by_kind = np.bincount((seg * m + k) * 4 + kind, minlength=n * m * 4).reshape(n, m, 4)
    other = pose[:, None] != np.array([s.pose_index for s in poses], dtype=np.intp)[None, :]
    through = by_kind[:, :, 1] + by_kind[:, :, 3]
    return RayTally(
        by_kind[:, :, 0].sum(axis=1),
        through.sum(axis=1),
        np.where(other, by_kind[:, :, 0], 0),
        np.where(other, through, 0),
        np.where(other, by_kind[:, :, 2], 0),
    )


def ray_features(tally: RayTally, params: RayParams) -> dict[str, NDArray[np.str_]]:
    """The features ``contour_free`` and ``lsl_persistence`` of the tallied segments (module doc).

    >>> tally = RayTally(np.array([10, 10, 10, 10]), np.array([8, 0, 0, 1]), np.array([[0], [6], [0], [4]]),
    ...                  np.array([[0], [0], [9], [0]]), np.array([[0], [2], [0], [6]]))
    >>> {k: v.tolist() for k, v in ray_features(tally, RayParams()).items()}  # doctest: +NORMALIZE_WHITESPACE
    {'contour_free': ['contradicted', 'clear', 'clear', 'clear'],
     'lsl_persistence': ['unobserved', 'seen', 'missed', 'unobserved']}
    """
    through = tally.passes
    contradicted = (through >= params.min_passes) & (through >= params.pass_share * (through + tally.ends))
    looked = tally.other_ends + tally.other_misses
    in_view = looked >= params.min_rays
    ends_most = in_view & (tally.other_ends >= params.seen_share * looked)
    saw = ends_most & (tally.other_ends >= params.seen_cover * (looked + tally.other_hidden))
    seen, missed = saw.any(axis=1), (in_view & ~ends_most).any(axis=1)
    return {
        "contour_free": np.where(contradicted, "contradicted", "clear"),
        "lsl_persistence": np.select([seen, missed], ["seen", "missed"], "unobserved"),
    }


def stripe_edges(
    p: NDArray[np.float64], q: NDArray[np.float64], pose: NDArray[np.intp], poses: Sequence[Sensed], params: RayParams
) -> NDArray[np.bool_]:
    """(N, 2) whether the stripe saw each end (p, q) of segments p-q, seen from ``pose``, as an edge.

    Beyond the end, in bearing, the segment's own pose's next ray (within ``edge_window_deg``, the rays
    that end on the segment's end itself skipped) returned farther than the end by more than ``edge_step``
    and three noise stds, or nothing: the surface ends there. Where it returned as near, the surface goes
    on (in a piece too short for a segment); nearer, something hides what lies beyond: neither is an
    edge. An end the pose's rays tell nothing about (no ray in the window, the pose not among ``poses``)
    is taken for an edge.

    >>> from evmap.sources.readings import SonarScan
    >>> from evmap.sources.params import SonarParams
    >>> sonar = SonarScan.from_readings([0.0], [1.0], SonarParams())
    >>> bearing = np.radians(np.arange(-10.0, 10.01, 0.2))
    >>> ranges = np.where(bearing < 0, 2 / np.cos(bearing), 4 / np.cos(bearing))  # a wall x = 2, then x = 4
    >>> ranges[np.abs(np.degrees(bearing) - 5) < 1.3] = 1.0  # something near hides the far wall from 3.8 deg
    >>> pose = Sensed(0, np.zeros(2), bearing, ranges, sonar)
    >>> p = np.array([[2.0, -2 * np.tan(np.radians(6))], [4.0, 4 * np.tan(np.radians(1))]])
    >>> q = np.array([[2.0, 0.0], [4.0, 4 * np.tan(np.radians(3.6))]])
    >>> stripe_edges(p, q, np.array([0, 0]), [pose], RayParams()).tolist()  # ends at -6, 0 deg; 1, 3.6 deg
    [[False, True], [False, False]]

    The first segment's wall goes on at -6 deg and ends at 0 deg (the far wall beyond); the second's goes
    on at 1 deg and is hidden beyond 3.6 deg.
    """
    out = np.ones((len(p), 2), dtype=bool)
    k = _positions(pose, poses)
    sizes, starts, bearing, rng = laid_out(poses)
    rows = np.flatnonzero(k >= 0)
    rows = rows[np.argsort(k[rows], kind="stable")]  # by pose: each pose's ends are searched in its own rays
    rows = rows[sizes[k[rows]] > 0]
    if not len(rows):
        return out
    # the ends, p and q of each row in turn, relative to their pose's origin
    origin = np.array([s.origin for s in poses], dtype=float)[k[rows]]
    a, b = p[rows] - origin, q[rows] - origin
    ba, bb = np.arctan2(a[:, 1], a[:, 0]), np.arctan2(b[:, 1], b[:, 0])
    outward = np.where(wrapped(bb - ba) >= 0, 1.0, -1.0)  # from p towards q
    end = np.stack([a, b], axis=1).reshape(-1, 2)
    end_bearing = np.column_stack([ba, bb]).ravel()
    sign = np.column_stack([-outward, outward]).ravel()
    end_pose = np.repeat(k[rows], 2)
    r = np.hypot(*end.T)
    # each end's rays within the window, in its pose's bearings over three turns (``tripled``, pose after pose)
    window = np.radians(params.edge_window_deg)
    tripled = np.concatenate([t for s in poses for t in (s.bearing - 2 * np.pi, s.bearing, s.bearing + 2 * np.pi)])
    lo, hi = np.zeros(len(end), dtype=np.intp), np.zeros(len(end), dtype=np.intp)
    bounds = np.searchsorted(end_pose, np.arange(len(poses) + 1))
    for j in np.flatnonzero(np.diff(bounds)).tolist():
        ends, base = slice(bounds[j], bounds[j + 1]), 3 * starts[j]
        turns = tripled[base : base + 3 * sizes[j]]
        lo[ends] = base + np.searchsorted(turns, end_bearing[ends] - window, side="left")
        hi[ends] = base + np.searchsorted(turns, end_bearing[ends] + window, side="right")
    count = hi - lo
    pair = np.repeat(np.arange(len(end)), count)
    at = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(count.sum())  # in ``tripled``
    kp = end_pose[pair]
    ray = starts[kp] + (at - 3 * starts[kp]) % sizes[kp]
    gap = (tripled[at] - end_bearing[pair]) * sign[pair]  # how far beyond the end, in bearing
    tol = params.tolerance + 3 * params.range_noise * r[pair]
    points = rng[ray, None] * np.column_stack([np.cos(bearing[ray]), np.sin(bearing[ray])])
    away = np.hypot(*(points - np.repeat(end, count, axis=0)).T)  # end[pair]
    away[np.isnan(away)] = np.inf
    # the end's own ray: the one whose point is nearest the end, if on it; the next ray lies beyond it
    nearest = np.full(len(end), np.inf)
    np.minimum.at(nearest, pair, away)
    own = np.full(len(end), -np.inf)
    is_own = (away == nearest[pair]) & (away <= tol)
    np.maximum.at(own, pair[is_own], gap[is_own])
    beyond_end = np.flatnonzero(gap > np.maximum(own[pair], 0.0))
    order = beyond_end[np.lexsort((gap[beyond_end], pair[beyond_end]))]
    first = order[np.diff(pair[order], prepend=-1) != 0]  # each end's next ray
    back = rng[ray[first]]
    e = pair[first]
    near = back <= r[e] + params.edge_step + 3 * params.range_noise * r[e]  # NaN: False
    out[rows[e[near] // 2], e[near] % 2] = False
    return out


def _positions(pose: NDArray[np.intp], poses: Sequence[Sensed]) -> NDArray[np.intp]:
    """Per segment seen from ``pose``, its pose's position in ``poses`` (-1 if not there)."""
    index = np.array([s.pose_index for s in poses], dtype=np.intp)
    k = np.full(len(pose), -1, dtype=np.intp)
    if len(index):
        order = np.argsort(index)
        at = np.minimum(np.searchsorted(index[order], pose), len(index) - 1)
        k = np.where(index[order][at] == pose, order[at], -1)
    return k


def segments_facing(
    p: NDArray[np.float64], q: NDArray[np.float64], poses: Sequence[Sensed], bearings: Sequence[NDArray[np.float64]]
) -> NDArray[np.intp]:
    """The segments p-q (their rows) whose span of bearings from some pose of ``poses`` (ends included) holds one of
    that pose's ``bearings`` (in [-pi, pi), one array a pose): the only ones its rays of those bearings can cross
    (:func:`ray_tally` pairs a segment with the rays of its span).

    >>> s = Sensed(0, np.zeros(2), np.array([0.0, 0.7]), np.ones(2), None)
    >>> p, q = np.array([[2.0, -1.0], [2.0, 1.0]]), np.array([[2.0, 1.0], [2.0, 3.0]])
    >>> segments_facing(p, q, [s], [np.array([0.0])]).tolist(), segments_facing(p, q, [s], [np.array([0.7])]).tolist()
    ([0], [1])
    """
    hit = np.zeros(len(p), dtype=bool)
    for s, b in zip(poses, bearings, strict=True):
        if not len(b):
            continue
        lo, width = _spans(p - s.origin, q - s.origin)
        twice = np.sort(np.concatenate([b, b + 2 * np.pi]))
        hit |= np.searchsorted(twice, lo + width, side="right") > np.searchsorted(twice, lo, side="left")
    return np.flatnonzero(hit)


def _spans(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bearings of segments seen from the origin, their ends at ``a`` and ``b`` (N, 2): where each span of
    bearings starts, in [-pi, pi), and how wide it is (under pi)."""
    a1, a2 = np.arctan2(a[:, 1], a[:, 0]), np.arctan2(b[:, 1], b[:, 0])
    span = wrapped(a2 - a1)
    return wrapped(np.where(span >= 0, a1, a2)), np.abs(span)
