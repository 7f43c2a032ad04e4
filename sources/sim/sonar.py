"""A rotating Polaroid-type ultrasonic range sensor: the scan and its physical model.

The model follows the sonar simulation of Kuc & Siegel (1987, "Physically based
simulation model for acoustic sensor robot navigation", IEEE PAMI 9(6)) as used by
Leonard & Durrant-Whyte (1992, "Directed Sonar Sensing for Mobile Robot
Navigation", Kluwer), the model the paper uses (section III):

- Walls are acoustic mirrors at sonar wavelengths. A plane returns an echo only
  along its normal, so a wall answers only while the foot of the perpendicular
  from the sensor lies on the segment and within the beam.
- A concave corner (the sensor inside the wedge of less than 180 deg that its two
  walls form) is a retro-reflector: it answers wherever it is within the beam.
  A convex edge or a free end point diffracts a weak echo; a cylinder always has a
  normal-incidence point.
- The echo amplitude falls off-axis with the two-way beam pattern,
  ``exp(-2 (theta / theta0)^2)`` (``directivity_deg``), and with range,
  ``detection_range / r``, times the target's strength (1 for walls and corners,
  ``edge_strength``, ``cylinder_strength``). An echo is detected when this is at
  least 1 and ``theta`` is within half the visibility angle (``beam_width_deg``).
  Far and weak targets are thus seen over narrower angles: narrower regions of
  constant depth, as Leonard & Durrant-Whyte observe.
- The sensor reports the first echo only: the shortest detected path. Where no
  echo returns within ``max_range`` it reports ``max_range``.
- Multiple reflections by the mirror-image method: the sensor mirrored in a wall
  ``A`` is a virtual sensor that sees every target through ``A`` along paths that
  cross ``A`` (second order: wall, then a wall at normal incidence, a corner, an
  edge or a cylinder, the echo returning the same way). The beam angle is the
  angle of the first leg; the range is the whole one-way path. These are the long,
  spurious readings of specular environments.
- Absorbing segments return nothing but stop sound like any other segment.

Every reading records the object that made it (the segment, vertex or cylinder id;
for a multiple reflection the first wall) and its reflection order (0: no echo, at
max range; 1: direct; 2: a double bounce; -1: unknown, for measured data).

The same :func:`simulate_scan` runs on any :class:`~evmap.sources.sim.surfaces.Surfaces`: the
simulated world, or the line-corner map from which the fusion stage predicts a scan.

The computation is exact and bounded: paths, sources and readings are paired only with the surfaces,
targets and echoes an index finds near them, a bounded number of pairs at a time (:data:`~evmap.sources.sim.sonar_near.PAIRS`), so
memory stays at about 100 MB and time grows with what is near, not with the square of the surfaces in
range (every path against every segment, every mirror image against every target).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import perpendicular_feet, point_segment_distances
from evmap.sources.params import SonarParams
from evmap.sources.ray_casting import bearing_pairs
from evmap.sources.readings import ScanError, SonarScan
from evmap.sources.sim.sonar_near import (
    EPS,
    PAD,
    PAIRS,
    TOUCH,
    Near,
    box_array,
    index_pairs,
    path_blocked,
    path_crossings,
    second_legs_blocked,
    surfaces_near,
    visible_segments,
)
from evmap.sources.sim.surfaces import Surfaces

__all__ = ["echo_halfwidth", "simulate_scan"]


_FLAT = 1e-6
"""A vertex whose free wedge is within this of 180 deg (rad) is a point on a flat wall: no echo of its own."""


_CONE_PIECES = 8
"""Most pieces a cone of second-order paths is cut into for the spatial index (:func:`_double_echoes`)."""


_Echoes = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]
"""Echoes as arrays: bearing from the sensor (rad), detection half-width (rad), range (m), label index."""


def echo_halfwidth(strength: NDArray[np.float64], r: NDArray[np.float64], params: SonarParams) -> NDArray[np.float64]:
    """Largest off-axis angle (rad) at which an echo is detected; -1 where it never is.

    Detected iff ``strength * exp(-2 (theta / theta0)^2) * detection_range / r >= 1``
    and ``|theta| <= beam_width / 2``.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = np.log(strength * params.detection_range / r)
    theta0 = np.radians(params.directivity_deg)
    w = np.minimum(theta0 * np.sqrt(np.maximum(gain, 0) / 2), np.radians(params.beam_width_deg) / 2)
    return np.where(gain >= 0, w, -1.0)


def _vertex_strength(
    near: Near, vi: NDArray[np.intp], src: NDArray[np.float64], params: SonarParams
) -> NDArray[np.float64]:
    """(P,) echo strength of vertices ``vi`` (P,) seen from points ``src`` (P, 2).

    The source lies in the free wedge between two angularly adjacent segments at the
    vertex: a wedge under 180 deg is a concave corner (strength 1 if both its walls
    reflect), over 180 deg a convex edge or free end (``edge_strength`` if either
    reflects), 180 deg a point on a flat wall (0).
    """
    rel = src - near.v[vi]
    psi = np.arctan2(rel[:, 1], rel[:, 0])
    angles, segs, deg = near.wedge_angle[vi], near.wedge_seg[vi], near.degree[vi]
    k = np.sum(angles < psi[:, None], axis=1)
    rows = np.arange(len(vi))
    lo, hi = (k - 1) % deg, k % deg
    gap = np.mod(angles[rows, hi] - angles[rows, lo], 2 * np.pi)
    # a free end, or a source "inside" the zero wedge of coinciding segments by round-off
    gap = np.where((deg == 1) | (gap < _FLAT), 2 * np.pi, gap)
    r_lo, r_hi = near.reflective[segs[rows, lo]], near.reflective[segs[rows, hi]]
    concave = (gap < np.pi - _FLAT) & r_lo & r_hi
    convex = (gap > np.pi + _FLAT) & (r_lo | r_hi)
    return np.where(concave, 1.0, np.where(convex, params.edge_strength, 0.0))


def _candidates(
    near: Near, src: NDArray[np.float64], cand: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Echo points of candidate targets ``cand`` (P,) seen from sources ``src`` (P, 2), before strength and occlusion.

    Candidates are numbered as the label table: the feet of the perpendiculars on the
    segments, the vertices and the points of the cylinders nearest the source, in that
    order. Returns points (P, 2) and whether each can answer at all (a reflective
    segment whose foot lies on it; a cylinder the source is outside of).
    """
    n, nv = len(near.p), len(near.v)
    point = np.empty((len(cand), 2))
    can = np.ones(len(cand), dtype=bool)
    seg = cand < n
    k = cand[seg]
    t, point[seg] = perpendicular_feet(src[seg], near.p[k], near.q[k])
    can[seg] = near.reflective[k] & (t >= -TOUCH) & (t <= 1 + TOUCH)
    vert = (cand >= n) & (cand < n + nv)
    point[vert] = near.v[cand[vert] - n]
    cyl = cand >= n + nv
    k = cand[cyl] - n - nv
    rel = src[cyl] - near.c[k]
    dist = np.linalg.norm(rel, axis=-1)
    outside = dist > near.radius[k]
    point[cyl] = near.c[k] + near.radius[k][:, None] * rel / np.where(outside, dist, 1.0)[:, None]
    can[cyl] = outside
    return point, can


def target_strength(
    near: Near, cand: NDArray[np.intp], src: NDArray[np.float64], params: SonarParams
) -> NDArray[np.float64]:
    """(P,) echo strength of candidates ``cand`` (indices as in :func:`_candidates`) seen from ``src`` (P, 2)."""
    n, nv = len(near.p), len(near.v)
    strength = np.where(cand < n, 1.0, params.cylinder_strength)
    is_v = (cand >= n) & (cand < n + nv)
    strength[is_v] = _vertex_strength(near, cand[is_v] - n, src[is_v], params)
    return strength


def _first_echo(
    angles: NDArray[np.float64], bearing: NDArray[np.float64], halfwidth: NDArray[np.float64], r: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Per beam axis, the shortest echo within its detection half-width: (range or inf, echo index).

    Ties (within round-off) go to the echo listed first. Each echo is paired only with the beam axes
    within its half-width (and a margin for round-off), a bounded number of pairs at a time.
    """
    best = np.full(len(angles), np.inf)
    idx = np.full(len(angles), len(r), dtype=np.intp)
    reach = halfwidth + TOUCH + 1e-9
    lo, width = np.mod(bearing - reach, 2 * np.pi), 2 * reach
    for rows, echo in bearing_pairs(lo, width, angles, PAIRS):
        off = np.abs(np.mod(bearing[echo] - angles[rows] + np.pi, 2 * np.pi) - np.pi)
        covered = off <= halfwidth[echo] + TOUCH
        np.minimum.at(best, rows[covered], r[echo[covered]])
    # among echoes of equal range (a wall's foot at its corner), the first candidate: round-off never decides
    for rows, echo in bearing_pairs(lo, width, angles, PAIRS):
        off = np.abs(np.mod(bearing[echo] - angles[rows] + np.pi, 2 * np.pi) - np.pi)
        first = (off <= halfwidth[echo] + TOUCH) & (r[echo] <= best[rows] + TOUCH)
        np.minimum.at(idx, rows[first], echo[first])
    return best, np.where(idx < len(r), idx, 0)


def _echoes(near: Near, s: NDArray[np.float64], params: SonarParams) -> _Echoes:
    """First-order echoes: bearing, half-width, range, label index of every detectable, visible target."""
    everything = np.arange(len(near.p) + len(near.v) + len(near.c))
    point, can = _candidates(near, np.broadcast_to(s, (len(everything), 2)), everything)
    r = np.hypot(*(point - s).T)
    cand = np.flatnonzero(can & (r > EPS) & (r <= params.max_range))
    w = echo_halfwidth(target_strength(near, cand, np.broadcast_to(s, (len(cand), 2)), params), r[cand], params)
    cand = cand[w >= 0]
    w = w[w >= 0]
    seen = ~path_blocked(np.broadcast_to(s, (len(cand), 2)), point[cand], near, near.fan)
    cand, w = cand[seen], w[seen]
    rel = point[cand] - s
    return np.arctan2(rel[:, 1], rel[:, 0]), w, r[cand], cand


def _circular_max(values: NDArray[np.float64], start: NDArray[np.intp], count: NDArray[np.intp]) -> NDArray[np.float64]:
    """Per query, the largest of ``count`` (>= 1) consecutive ``values`` from ``start``, wrapping around (a sparse
    table: every query in constant time).

    >>> _circular_max(np.array([1.0, 5.0, 2.0, 0.0]), np.array([2, 3, 0]), np.array([2, 2, 9])).tolist()
    [2.0, 1.0, 5.0]
    """
    m = len(values)
    count = np.minimum(count, m)
    start = np.mod(start, m)
    table = [np.concatenate([values, values])]
    while 1 << len(table) <= m:
        half = 1 << (len(table) - 1)
        table.append(np.maximum(table[-1][:-half], table[-1][half:]))
    level = np.floor(np.log2(count)).astype(np.intp)
    out = np.empty(len(start))
    for k in np.unique(level):
        rows = level == k
        s, e = start[rows], start[rows] + count[rows] - (1 << k)
        out[rows] = np.maximum(table[k][s], table[k][e])
    return out


def _cone_pairs(
    near: Near,
    image: NDArray[np.float64],
    pa: NDArray[np.float64],
    qa: NDArray[np.float64],
    near_side: NDArray[np.float64],
    far_side: NDArray[np.float64],
    pieces: NDArray[np.intp],
) -> Iterator[tuple[NDArray[np.intp], ...]]:
    """(cone, target) pairs: the targets whose boxes meet the part of each cone from ``image`` through
    ``pa``-``qa`` between ``near_side`` and ``far_side`` times the way to the mirror, cut into ``pieces``; the
    pieces made for a bounded number of cones at a time."""
    ends = np.cumsum(pieces)
    start = 0
    while start < len(pieces):
        stop = max(start + 1, int(np.searchsorted(ends, (ends[start - 1] if start else 0) + PAIRS // 16, "right")))
        k = pieces[start:stop]
        cone = np.repeat(np.arange(start, stop), k)
        piece = np.arange(len(cone)) - np.repeat(np.cumsum(k) - k, k)
        lam = near_side[cone] + (far_side - near_side)[cone] * np.stack([piece, piece + 1]) / pieces[cone]
        at = image[cone]
        corners = np.stack([at + lam[m, :, None] * (end[cone] - at) for m in (0, 1) for end in (pa, qa)])
        yield from index_pairs(near.targets, box_array(corners.min(axis=0), corners.max(axis=0)), cone)
        start = stop


def _double_echoes(
    near: Near, s: NDArray[np.float64], params: SonarParams, angles: NDArray[np.float64], first: NDArray[np.float64]
) -> _Echoes:
    """Second-order echoes by the mirror-image method, for readings where they come before ``first``.

    The sensor mirrored in each reflective segment A is a virtual sensor; each of its
    candidate targets T gives a path sensor -> X -> T -> X -> sensor when the line from
    the image to T crosses A at X. Returns bearing (of the first leg), half-width,
    range (|image - T|) and the label index of A, for the visible, detectable paths.

    Only the targets whose boxes meet the part of the cone from the image through A beyond
    A are tried, out to the longest path that could still come first: T lies beyond A on a
    line from the image through A, no further than that from the image.
    """
    mir = np.flatnonzero(near.reflective & visible_segments(near, s))
    mir = mir[np.hypot(*(near.q[mir] - near.p[mir]).T) > 0]  # a wall of no length mirrors nothing
    pa, qa = near.p[mir], near.q[mir]
    d = qa - pa
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    h = np.einsum("ij,ij->i", s - pa, normal)
    mir, pa, qa, normal, h = (x[np.abs(h) > EPS] for x in (mir, pa, qa, normal, h))
    image = s - 2 * h[:, None] * normal
    reach_r = min(params.max_range, params.detection_range)
    # Only paths that could come before the first-order echo of some reading within the beam matter.
    step = 2 * np.pi / len(angles)
    reach = int(np.ceil(np.radians(params.beam_width_deg) / 2 / step)) + 1
    window = (np.arange(len(first))[:, None] + np.arange(-reach, reach + 1)) % len(first)
    later = first[window].max(axis=1)  # the longest first-order reading near each beam axis
    # A path through A leaves the sensor at a bearing within A's (the readings of those bearings, one more
    # each side for round-off): it is kept only if shorter than the longest of their later readings.
    a0 = (np.arctan2(pa[:, 1] - s[1], pa[:, 0] - s[0]) - angles[0]) / step
    span = np.mod((np.arctan2(qa[:, 1] - s[1], qa[:, 0] - s[0]) - angles[0]) / step - a0 + len(angles) / 2, len(angles))
    lo = a0 + np.minimum(span - len(angles) / 2, 0)
    first_j = np.floor(lo).astype(np.intp) - 1
    count = np.ceil(lo + np.abs(span - len(angles) / 2)).astype(np.intp) + 2 - first_j
    bound = np.minimum(reach_r, _circular_max(later, first_j, count))
    # The target lies beyond A from the image (which is |h| from A's line), in the cone from the image through A,
    # and the path's second leg X -> T is at most that bound less the first, |s - X| >= |s - A|: T is no further
    # than that from A's line, between A and a side parallel to it.
    second_leg = np.maximum(bound - point_segment_distances(s, pa, qa), 0)
    near_side = 1 - 2 * PAD / np.abs(h)
    far_side = 1 + (second_leg + 2 * PAD) / np.abs(h)
    # A long thin cone is cut across into pieces about as long as it is wide (at most _CONE_PIECES), so that the
    # index, which sees boxes, does not offer every target in the box of a long diagonal cone.
    length = (far_side - near_side) * np.hypot(*((pa + qa) / 2 - image).T)
    pieces = np.clip(np.ceil(length / (far_side * np.hypot(*(qa - pa).T))), 1, _CONE_PIECES).astype(np.intp)
    echoes: list[_Echoes] = []
    for ia, ic in _cone_pairs(near, image, pa, qa, near_side, far_side, pieces):
        point, can = _candidates(near, image[ia], ic)
        u, v = path_crossings(image[ia], point, pa[ia], qa[ia])
        r = np.linalg.norm(point - image[ia], axis=-1)
        ok = can & (u > EPS) & (u < 1 - EPS) & (v >= 0) & (v <= 1) & (r <= reach_r)
        ia, ic, point, r, u = ia[ok], ic[ok], point[ok], r[ok], u[ok]
        w = echo_halfwidth(target_strength(near, ic, image[ia], params), r, params)
        x = image[ia] + u[:, None] * (point - image[ia])
        rel = x - s
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        j = np.round((bearing - angles[0]) / step).astype(np.intp) % len(angles)
        keep = (w >= 0) & (later[j] > r)
        ia, point, r, w, x, bearing = (a[keep] for a in (ia, point, r, w, x, bearing))
        seen = ~path_blocked(np.broadcast_to(s, x.shape), x, near, near.fan)
        seen[seen] = ~second_legs_blocked(x[seen], point[seen], ia[seen], image, near)
        echoes.append((bearing[seen], w[seen], r[seen], mir[ia[seen]]))
    if not echoes:
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.intp)
    bearing, w, r, label = (np.concatenate(column) for column in zip(*echoes, strict=True))
    return bearing, w, r, label


def simulate_scan(
    surfaces: Surfaces,
    pose: ArrayLike,
    params: SonarParams,
    *,
    rng: np.random.Generator | None = None,
    max_order: int = 2,
) -> SonarScan:
    """Simulate one rotational sonar scan of ``surfaces`` from ``pose`` (Kuc & Siegel 1987).

    Parameters
    ----------
    surfaces : the world (or a map) as segments, vertices and cylinders.
    pose : (x, y, heading) of the sensor, metres and radians, world frame. The
        first reading looks along the heading; the others follow counter-clockwise.
    params : the sensor. ``round(360 / step_deg)`` readings are taken, evenly over a
        full turn (the actual step is ``360 / round(360 / step_deg)`` degrees).
    rng : Gaussian range noise (``params.range_noise`` metres) is drawn from it for
        every reading (results clipped to ``[0, max_range]``; max-range readings stay
        exact); ``None``: noise-free. Convention: ``np.random.default_rng([seed, pose_index, 1])``.
    max_order : 1 for direct echoes only, 2 to add double bounces (mirror images).

    Returns
    -------
    SonarScan with the ground-truth object and reflection order of every reading.

    Examples
    --------
    A robot 1 m from a single wall sees it at normal incidence, over a 25 deg beam:

    >>> wall = Surfaces(vertices=np.array([[1.0, -5.0], [1.0, 5.0]]), vertex_ids=np.array(["a", "b"]),
    ...     segments=np.array([[0, 1]]), segment_ids=np.array(["wall"]),
    ...     lsl_opaque=np.array([True]), sonar_reflective=np.array([True]))
    >>> scan = simulate_scan(wall, (0.0, 0.0, 0.0), SonarParams())
    >>> scan.ranges[:3].tolist(), str(scan.target[0]), int(scan.order[0])
    ([1.0, 1.0, 1.0], 'wall', 1)
    >>> int((scan.order == 1).sum()), float(scan.ranges[180])
    (25, 10.0)
    """
    pose_arr = np.asarray(pose, dtype=float)
    if pose_arr.shape != (3,) or not np.all(np.isfinite(pose_arr)):
        raise ScanError(f"pose must be three finite numbers (x, y, heading); got {pose!r}")
    if max_order not in (1, 2):
        raise ValueError(f"max_order must be 1 or 2; got {max_order!r}")
    s = pose_arr[:2]
    m = max(1, round(360 / params.step_deg))
    angles = pose_arr[2] + np.arange(m) * (2 * np.pi / m)
    near, labels = surfaces_near(surfaces, s, params.max_range)

    bearing, w, r, label = _echoes(near, s, params)
    best, idx = _first_echo(angles, bearing, w, r)
    target = np.where(np.isfinite(best), label[idx] if len(label) else -1, -1)
    order = np.where(np.isfinite(best), 1, 0)
    if max_order == 2 and len(near.p):
        bearing2, w2, r2, label2 = _double_echoes(near, s, params, angles, best)
        best2, idx2 = _first_echo(angles, bearing2, w2, r2)
        later = best2 < best - TOUCH
        best = np.where(later, best2, best)
        target = np.where(later, label2[idx2] if len(label2) else -1, target)
        order = np.where(later, 2, order)
    ranges = np.where(np.isfinite(best), best, params.max_range)
    if rng is not None:
        noisy = np.clip(ranges + rng.normal(0.0, params.range_noise, m), 0.0, params.max_range)
        ranges = np.where(order > 0, noisy, ranges)
    return SonarScan(pose_arr, angles, ranges, labels[target], order, params)
