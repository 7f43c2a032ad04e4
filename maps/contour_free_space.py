"""Evidence from the contour sensor's rays: free space through a segment, and poses that should have seen it.

Every stripe point is a ray, free from the sensor to the point. For a segment
and a pose's rays that cross the segment's interior (its bearing interval from
the pose), each ray is one of:

- **ends**: its point lies on the segment (within ``tolerance`` plus three
  range-noise stds, measured across the segment);
- **passes**: its point lies beyond the segment: the ray went through it;
- **short**: its point lies in front: something nearer hid the segment;
- **none**: nothing returned although the segment is within the sensor's range.

The poses are those whose readings reach the segment, the latest
:data:`~evmap.maps.noise.LATEST_POSES` of them (:func:`evmap.maps.noise.judge`).
Two features come of it (:func:`ray_features`):

- ``contour_free``: ``contradicted`` when rays of any pose, the segment's own
  included, pass through it (at least ``min_rays``, and at least
  ``pass_share`` of the rays that end on it or pass), else ``clear``. A sunlit
  patch seen with the ``threshold`` detector has the real stripe behind it; a
  wall has nothing behind it.
- ``lsl_persistence``: per other pose whose rays reach the segment unhidden
  (at least ``min_rays`` of them): seen if at least ``seen_share`` of them end on
  it, else missed. ``seen`` if any other pose saw it, ``missed`` if one missed it
  and none saw it, else ``unobserved``. A sunlight phantom, drawn anew per pose,
  is missed by the poses that look at its place; a wall is seen again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evmap.maps.sensed import Sensed
from evmap.sources.geometry import crossings

__all__ = ["RayParams", "RayTally", "ray_features", "ray_tally"]


@dataclass(frozen=True)
class RayParams:
    """Tolerances of the ray tests (metres, shares)."""

    tolerance: float = 0.02  # a point this close to the segment (plus 3 noise stds) ends on it
    range_noise: float = 0.003  # the stripe's range-noise std per metre of range
    max_range: float = 8.0  # the contour sensor's range: beyond it, no return is no evidence
    end_margin: float = 0.03  # rays this close to an end of the segment (a quarter of it at most) are not counted
    min_rays: int = 3
    pass_share: float = 0.25
    seen_share: float = 0.7


@dataclass(frozen=True, eq=False)
class RayTally:
    """Counts of rays per segment (N,) and, for other poses, per pose (N, P).

    ``ends`` and ``passes`` count every pose's rays; ``other_*`` count each other pose's.
    """

    ends: NDArray[np.intp]
    passes: NDArray[np.intp]
    other_ends: NDArray[np.intp]
    other_misses: NDArray[np.intp]  # passes and no returns


def _crossings(
    p: NDArray[np.float64], q: NDArray[np.float64], poses: Sequence[Sensed], params: RayParams
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """(segment, pose, kind) of every ray of the ``poses`` (their positions in the sequence) crossing a segment's
    interior; kind 0 ends, 1 passes, 2 short, 3 none.

    All poses at once: each pose's bearings, doubled over two turns, are laid end to end ``4 pi`` apart, so that
    one sorted array and one ``searchsorted`` find every (segment, pose) pair's rays.
    """
    n, m = len(p), len(poses)
    origin = np.array([s.origin for s in poses], dtype=float).reshape(-1, 2)
    sizes = np.array([len(s.bearing) for s in poses], dtype=np.intp)
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    bearing = np.concatenate([np.zeros(0), *(s.bearing for s in poses)])
    rng = np.concatenate([np.zeros(0), *(s.range for s in poses)])
    shift = 4 * np.pi * np.arange(m)
    doubled = np.concatenate(
        [np.zeros(0), *(np.r_[s.bearing, s.bearing + 2 * np.pi] + shift[k] for k, s in enumerate(poses))]
    )
    a = (p[None] - origin[:, None]).reshape(-1, 2)  # (pose, segment) pairs, pose-major
    b = (q[None] - origin[:, None]).reshape(-1, 2)
    a1, a2 = np.arctan2(a[:, 1], a[:, 0]), np.arctan2(b[:, 1], b[:, 0])
    span = (a2 - a1 + np.pi) % (2 * np.pi) - np.pi
    lo = np.where(span >= 0, a1, a2)
    lo = (lo + np.pi) % (2 * np.pi) - np.pi + np.repeat(shift, n)
    first = np.searchsorted(doubled, lo)
    last = np.searchsorted(doubled, lo + np.abs(span))
    count = np.maximum(last - first, 0)
    pair = np.repeat(np.arange(n * m), count)
    k, seg = pair // n, pair % n
    at = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())  # in ``doubled``
    size = np.maximum(sizes[k], 1)
    ray = starts[k] + (at - 2 * starts[k]) % size  # ``doubled`` holds 2 * size entries a pose, in order
    theta, r = bearing[ray], rng[ray]
    u = np.column_stack([np.cos(theta), np.sin(theta)])
    a, b = a[pair], b[pair]
    e = b - a
    length = np.maximum(np.hypot(*e.T), 1e-12)
    t, along = crossings(np.zeros(2), u, a, e)  # the crossing's range along the ray, its place on the segment
    along = along * length  # in metres
    cross = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
    sin = np.abs(cross) / length
    margin = np.minimum(params.end_margin, length / 4)  # a short segment keeps the middle half of it
    inside = (np.abs(cross) > 1e-12) & (t > 0) & (along >= margin) & (along <= length - margin)
    across = (r - t) * sin  # the point's distance beyond the segment, across it
    tol = params.tolerance + 3 * params.range_noise * t * sin
    kind = np.select([np.isnan(r), across > tol, across < -tol], [3, 1, 2], 0)
    kind[np.isnan(r) & (t > params.max_range)] = 4  # out of range: not counted
    keep = inside & (kind < 4)
    return seg[keep], k[keep], kind[keep]


def ray_tally(
    p: NDArray[np.float64], q: NDArray[np.float64], pose: NDArray[np.intp], poses: Sequence[Sensed], params: RayParams
) -> RayTally:
    """Count, for segments p-q seen from ``pose``, the rays of every sensed pose by kind (module doc).

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
        seg, k, kind = _crossings(p, q, poses, params)
        np.add.at(by_kind, (seg, k, kind), 1)
    other = pose[:, None] != np.array([s.pose_index for s in poses], dtype=np.intp)[None, :]
    return RayTally(
        by_kind[:, :, 0].sum(axis=1),
        by_kind[:, :, 1].sum(axis=1),
        np.where(other, by_kind[:, :, 0], 0),
        np.where(other, by_kind[:, :, 1] + by_kind[:, :, 3], 0),
    )


def ray_features(tally: RayTally, params: RayParams) -> dict[str, NDArray[np.str_]]:
    """The features ``contour_free`` and ``lsl_persistence`` of the tallied segments (module doc).

    >>> tally = RayTally(np.array([10, 10, 10]), np.array([8, 0, 0]), np.array([[0], [6], [0]]),
    ...                  np.array([[0], [0], [9]]))
    >>> {k: v.tolist() for k, v in ray_features(tally, RayParams()).items()}
    {'contour_free': ['contradicted', 'clear', 'clear'], 'lsl_persistence': ['unobserved', 'seen', 'missed']}
    """
    contradicted = (tally.passes >= params.min_rays) & (tally.passes >= params.pass_share * (tally.passes + tally.ends))
    looked = tally.other_ends + tally.other_misses
    in_view = looked >= params.min_rays
    saw = in_view & (tally.other_ends >= params.seen_share * looked)
    seen, missed = saw.any(axis=1), (in_view & ~saw).any(axis=1)
    return {
        "contour_free": np.where(contradicted, "contradicted", "clear"),
        "lsl_persistence": np.select([seen, missed], ["seen", "missed"], "unobserved"),
    }
