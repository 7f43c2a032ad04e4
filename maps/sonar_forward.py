"""The sonar forward model of a segment: had it been real, would the sonar have heard it?

A map line is simulated as the world's walls are (:mod:`evmap.sources.sim.sonar`):
an acoustic mirror that answers only along its normal, and whose free ends
diffract a weak echo. For a segment and a pose's actual scan:

- **normal incidence**: when the foot of the perpendicular from the pose lies
  inside the segment at distance ``d``, a real segment would answer at ``d``
  over the readings within the detection half-width of the normal
  (``directivity * sqrt(ln(detection_range / d) / 2)``, at most half the beam).
  A reading there within ``tolerance`` of ``d``: ``confirmed``. Every reading
  there farther than ``d + tolerance``: the sonar heard nothing where the
  segment would have answered first: ``contradicted``. Else something nearer
  answered first: no evidence.
- **free ends**: an end with no other segment within ``end_clearance`` is an
  edge that would answer with ``edge_strength``; every reading within the
  edge's detection half-width farther than its range: ``contradicted``. The
  noise-elimination stage takes for free ends only those the stripe saw as
  edges (:func:`evmap.maps.contour_free_space.stripe_edges`): where the stripe
  goes on beyond an end, or something nearer hides what lies beyond it, the
  surface need not end there, and a wall broken into pieces by what stands in
  front of it has no edges to echo.

A pose whose stripe hides the place (the farthest return of its bearing nearest the foot's
or the end's, within ``shadow_window_deg``, lies nearer than it by more than ``tolerance``;
a return on a segment of the pose judged noise, a sunlit patch, hides nothing)
contradicts nothing there: an opaque surface in between stops the sound both ways, and
the wall beside a pillar, or a pillar's far side, is in its shadow. A surface in the way
that echoes, echoes nearer: no evidence either way already. Nor does a pose contradict a
place beyond its stripe's range (``reach``), whose way the stripe cannot show clear.

Over all poses: ``confirmed`` if any pose confirms, else ``contradicted`` if any
contradicts, else ``silent`` (no evidence either way: an oblique wall is silent).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evmap.maps.sensed import Sensed
from evmap.sources.geometry import near_segments, nearest_angles, point_segment_distances, wrapped
from evmap.sources.readings import SonarScan
from evmap.sources.sim.sonar import echo_halfwidth

__all__ = ["SonarForwardParams", "free_ends", "sonar_forward"]


@dataclass(frozen=True)
class SonarForwardParams:
    """Tolerances of the forward model (metres)."""

    tolerance: float = 0.05  # an echo this close to the predicted range is the segment's
    end_margin: float = 0.02  # the foot must lie this far inside the segment
    end_clearance: float = 0.05  # an end this close to another segment is not free
    shadow_window_deg: float = 0.5  # the stripe's ray nearest a place's bearing, this close, tells if it hides it


def _half_width(scan: SonarScan, r: NDArray[np.float64], strength: float) -> NDArray[np.float64]:
    """Detection half-width (rad) of a target of ``strength`` at range r (the sonar model's,
    :func:`~evmap.sources.sim.sonar.echo_halfwidth`); NaN where it is never detected or lies beyond the
    sonar's range."""
    w = echo_halfwidth(np.full(len(r), strength), np.maximum(r, 1e-9), scan.params)
    return np.where((w >= 0) & (r <= scan.params.max_range), w, np.nan)


def _unseen(
    s: Sensed,
    bearing: NDArray[np.float64],
    r: NDArray[np.float64],
    sunlit: tuple[NDArray[np.float64], NDArray[np.float64]],
    reach: float,
    params: SonarForwardParams,
) -> NDArray[np.bool_]:
    """Whether the pose's stripe cannot show the way to each place at ``bearing`` and range r clear (module
    doc): the place lies beyond ``reach``, or the farthest return of the stripe's bearing nearest it (within
    ``shadow_window_deg``), among those on none of the ``sunlit`` segments (ends p, q), lies nearer than r by
    more than ``tolerance``."""
    out = r > reach
    b = s.bearing  # sorted, in [-pi, pi)
    if not len(b) or not len(r):
        return out
    nearest = b[nearest_angles(b, bearing)]
    lo, hi = np.searchsorted(b, nearest, side="left"), np.searchsorted(b, nearest, side="right")
    count = hi - lo  # the rays of that bearing: one, or every return a ray lit
    target = np.repeat(np.arange(len(r)), count)
    ray = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(count.sum())
    rng = s.range[ray]
    point = s.origin + rng[:, None] * np.column_stack([np.cos(b[ray]), np.sin(b[ray])])
    returned = np.isfinite(rng)
    returned[returned] = ~near_segments(point[returned], *sunlit, params.tolerance)  # a sunlit patch hides nothing
    far = np.full(len(r), -np.inf)
    np.maximum.at(far, target[returned], rng[returned])
    close = np.abs(wrapped(nearest - bearing)) <= np.radians(params.shadow_window_deg)
    hidden = close & (far > 0) & (far < r - params.tolerance)
    return out | hidden


def _readings(
    scan: SonarScan, bearing: NDArray[np.float64], r: NDArray[np.float64], w: NDArray[np.float64], tolerance: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Per target: an actual reading within ``tolerance`` of r in the window, and every reading beyond it."""
    near, beyond = np.zeros(len(r), dtype=bool), np.zeros(len(r), dtype=bool)
    valid = np.flatnonzero(~np.isnan(w))  # targets the sonar could hear at all
    if not len(valid):
        return near, beyond
    bearing, r, w = bearing[valid], r[valid], w[valid]
    diff = np.abs(wrapped(scan.angles[None, :] - bearing[:, None]))
    window = diff <= np.maximum(w, scan.step / 2)[:, None]
    ranges = scan.ranges[None, :]
    near[valid] = (window & (np.abs(ranges - r[:, None]) <= tolerance)).any(axis=1)
    beyond[valid] = (
        window.any(axis=1)
        & ~(window & (ranges <= r[:, None] + tolerance)).any(axis=1)
        & (r + tolerance < scan.params.max_range)
    )
    return near, beyond


def free_ends(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    op: NDArray[np.float64],
    oq: NDArray[np.float64],
    clearance: float,
    angle_deg: float = 15.0,
) -> NDArray[np.bool_]:
    """(N, 2) whether each end (p, q) of each segment is free: an edge that echoes.

    An end is not free when another segment (of ``op``-``oq``; the segment itself may
    be among them) continues it (within ``clearance`` of the end and within
    ``angle_deg`` of its direction) or meets it at a corner (an end of the other
    within ``clearance``).

    >>> p, q = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, -0.5]]), np.array([[1.0, 0.0], [1.0, 1.0], [0.5, 0.5]])
    >>> free_ends(p, q, p, q, 0.05).tolist()
    [[True, False], [False, True], [True, True]]
    """
    n = len(p)
    out = np.ones((n, 2), dtype=bool)
    if not len(op) or not n:
        return out
    point = np.concatenate([p, q])  # every end: the ends p, then the ends q
    # pairs (end, other segment) within the clearance: the only ones that can hold the end
    by_x = np.argsort(point[:, 0], kind="stable")
    lo, hi = point[by_x] - clearance, point[by_x] + clearance  # the ends' boxes, sorted by both lo[:, 0] and hi[:, 0]
    olo, ohi = np.minimum(op, oq), np.maximum(op, oq)
    first = np.searchsorted(hi[:, 0], olo[:, 0], side="left")  # each other segment's ends whose boxes meet its box
    count = np.maximum(np.searchsorted(lo[:, 0], ohi[:, 0], side="right") - first, 0)  # in x, edges touching
    j = np.repeat(np.arange(len(op)), count)
    at = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())
    meets = (lo[at, 1] <= ohi[j, 1]) & (hi[at, 1] >= olo[j, 1])
    end, j = by_x[at[meets]], j[meets]
    # rows by np.take: x[rows] of a 2-D x is much slower
    away = point_segment_distances(*(np.take(x, rows, axis=0) for x, rows in ((point, end), (op, j), (oq, j))))
    close = away <= clearance
    end, j = end[close], j[close]
    i = end % n  # the segment of the end
    xy, pi, qi, pj, qj = (np.take(x, rows, axis=0) for x, rows in ((point, end), (p, i), (q, i), (op, j), (oq, j)))
    same = (np.abs(pj - pi).sum(axis=1) < 1e-12) & (np.abs(qj - qi).sum(axis=1) < 1e-12)
    e, d = qi - pi, qj - pj
    cos = np.abs((e * d).sum(axis=1)) / np.maximum(np.hypot(*e.T) * np.hypot(*d.T), 1e-300)
    corner = np.minimum(np.hypot(*(xy - pj).T), np.hypot(*(xy - qj).T)) <= clearance
    held = ((cos >= np.cos(np.radians(angle_deg))) | corner) & ~same
    out[i[held], end[held] // n] = False
    return out


def sonar_forward(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    free: NDArray[np.bool_],
    poses: Sequence[Sensed],
    params: SonarForwardParams,
    sunlit: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None,
    reach: float = np.inf,
) -> NDArray[np.str_]:
    """The feature ``sonar_forward`` of segments p-q with free ends ``free`` (N, 2) (module doc).

    ``sunlit``: per pose, the ends (p, q) of its segments judged noise (none if not given): a stripe point on one
    hides nothing. ``reach``: the stripe's range (m).

    >>> from evmap.sources.params import SonarParams
    >>> angles = np.radians(np.arange(-180, 180))
    >>> scan = SonarScan.from_readings(angles, np.full(360, 3.0), SonarParams())  # a round room, r = 3
    >>> pose = Sensed(0, np.zeros(2), np.zeros(0), np.zeros(0), scan)
    >>> p, q = np.array([[1.0, -0.2], [3.0, -0.2], [0.5, 1.0]]), np.array([[1.0, 0.2], [3.0, 0.2], [2.5, 3.0]])
    >>> sonar_forward(p, q, np.zeros((3, 2), bool), [pose], SonarForwardParams()).tolist()
    ['contradicted', 'confirmed', 'silent']
    """
    n = len(p)
    confirmed, contradicted = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    e = q - p
    length = np.maximum(np.hypot(*e.T), 1e-12)
    no_patches = np.zeros((0, 2)), np.zeros((0, 2))
    for s, patches in zip(poses, sunlit or [no_patches] * len(poses), strict=True):
        scan = s.sonar
        if scan is None:
            continue
        edge = scan.params.edge_strength
        o = scan.pose[:2]
        t = ((o - p) * e).sum(axis=1) / length**2
        foot = p + t[:, None] * e
        d = np.hypot(*(foot - o).T)
        inside = (t * length >= params.end_margin) & ((1 - t) * length >= params.end_margin) & (d > 1e-6)
        w = np.where(inside, _half_width(scan, d, 1.0), np.nan)
        bearing = np.arctan2(foot[:, 1] - o[1], foot[:, 0] - o[0])
        near, beyond = _readings(scan, bearing, d, w, params.tolerance)
        confirmed |= near
        places = [(beyond, bearing, d)]  # where a real segment would have answered first: its foot, its free ends
        for k, end in enumerate((p, q)):
            r = np.hypot(*(end - o).T)
            w = np.where(free[:, k], _half_width(scan, r, edge), np.nan)
            bearing = np.arctan2(end[:, 1] - o[1], end[:, 0] - o[0])
            places.append((_readings(scan, bearing, r, w, params.tolerance)[1], bearing, r))
        rows = np.concatenate([np.flatnonzero(b) for b, _, _ in places])
        if len(rows):  # one look at the pose's stripe for all of them
            bearings = np.concatenate([x[b] for b, x, _ in places])
            ranges = np.concatenate([x[b] for b, _, x in places])
            contradicted[rows[~_unseen(s, bearings, ranges, patches, reach, params)]] = True
    return np.select([confirmed, contradicted], ["confirmed", "contradicted"], "silent")
