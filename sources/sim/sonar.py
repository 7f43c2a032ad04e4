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
targets and echoes an index finds near them, a bounded number of pairs at a time (:data:`_PAIRS`), so
memory stays at about 100 MB and time grows with what is near, not with the square of the surfaces in
range (every path against every segment, every mirror image against every target).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import (
    bearing_intervals,
    bearing_pairs,
    crossings,
    merge_nearest,
    nearest_first_pairs,
    perpendicular_feet,
    point_segment_distances,
    ray_circle_pairs,
)
from evmap.sources.params import SonarParams
from evmap.sources.readings import ScanError, SonarScan
from evmap.sources.sim.surfaces import Surfaces

__all__ = ["simulate_scan"]

_EPS = 1e-7
"""Tolerance on path parameters (relative): a path touching an occluder at its own ends is not blocked."""

_TOUCH = 1e-9
"""Slack on foot positions (segment parameter) and beam edges (rad), so round-off never decides an echo."""

_FLAT = 1e-6
"""A vertex whose free wedge is within this of 180 deg (rad) is a point on a flat wall: no echo of its own."""


_PARALLEL = 1e-12
"""Lines whose directions' cross product is within this share of their lengths' product are parallel."""


_PAIRS = 1 << 20
"""Most pairs (a path and a surface, a source and a candidate target, a reading and an echo) computed at once.

The model works through its pairs in chunks of at most this many, so its memory is bounded (about 100 MB)
whatever the number of surfaces in range; and it computes only the pairs that an index finds near each other
(a path from the sensor and the surfaces whose bearing interval holds it, nearest first; other paths and the
boxes they meet; a reading and the echoes within their half-width of it), not every surface for every path."""

_PAD = 1e-6
"""Margin (m) added to every box of the spatial indexes, on top of each test's own tolerance: a box holds
every point that the exact tests can accept, round-off included, so the index never drops a pair they keep."""

_CONE_PIECES = 8
"""Most pieces a cone of second-order paths is cut into for the spatial index (:func:`_double_echoes`)."""

_FAN_LEGS = 16
"""Second legs leaving one mirror from which they are tested seen from its image, not by their boxes."""

_Fan = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""Occluders seen from a point: the point, their bearing intervals' starts and widths, their least distances."""

_Echoes = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]
"""Echoes as arrays: bearing from the sensor (rad), detection half-width (rad), range (m), label index."""


@dataclass(frozen=True)
class _Near:
    """The part of a Surfaces within sonar range of the sensor, with vertex wedges sorted by angle.

    Candidate targets are numbered segments first, then vertices, then reflective
    cylinders: that number indexes the label table that :func:`_near` returns.
    """

    p: NDArray[np.float64]  # (n, 2) segment ends
    q: NDArray[np.float64]
    reflective: NDArray[np.bool_]  # (n,)
    v: NDArray[np.float64]  # (nv, 2) vertices of near segments
    wedge_angle: NDArray[np.float64]  # (nv, D) directions of incident segments, sorted, padded with +inf
    wedge_seg: NDArray[np.intp]  # (nv, D) local index of those segments
    degree: NDArray[np.intp]  # (nv,)
    c: NDArray[np.float64]  # (k, 2) reflective cylinders in range
    radius: NDArray[np.float64]
    occ_c: NDArray[np.float64]  # (ko, 2) all cylinders in range (occluders)
    occ_r: NDArray[np.float64]
    occluders: shapely.STRtree  # boxes of the segments (n), then of the occluding cylinders (ko)
    fan: _Fan  # the same occluders seen from the sensor
    targets: shapely.STRtree  # boxes of the candidate targets: segments, vertices, reflective cylinders


def _boxes(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.object_]:
    """Axis-aligned boxes from their lower-left (N, 2) and upper-right (N, 2) corners."""
    return shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])


def _segment_boxes(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.object_]:
    """Boxes of segments, grown by the tests' tolerance along them (a path may cross a segment's line
    up to ``_EPS`` of its length beyond its ends) and by :data:`_PAD`."""
    pad = (2 * _EPS * np.hypot(*(q - p).T) + _PAD)[:, None]
    return _boxes(np.minimum(p, q) - pad, np.maximum(p, q) + pad)


def _circle_boxes(c: NDArray[np.float64], r: NDArray[np.float64]) -> NDArray[np.object_]:
    """Boxes of circles, grown by :data:`_PAD`."""
    return _boxes(c - (r + _PAD)[:, None], c + (r + _PAD)[:, None])


def _fan(
    origin: NDArray[np.float64],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    c: NDArray[np.float64],
    r: NDArray[np.float64],
) -> _Fan:
    """Occluders, segments ``p``-``q`` then cylinders ``c``, ``r``, seen from ``origin``, as :func:`_blocked` uses
    them: each one's bearing interval holds every point a path's crossing test can accept on it."""
    lo, width = bearing_intervals(origin, p, q, _EPS * np.hypot(*(q - p).T) + _PAD, c, r)
    return origin, lo, width, np.concatenate([point_segment_distances(origin, p, q), np.hypot(*(c - origin).T) - r])


def _pairs(
    tree: shapely.STRtree, boxes: NDArray[np.object_], group: NDArray[np.intp] | None = None
) -> Iterator[tuple[NDArray[np.intp], ...]]:
    """(box, tree item) index pairs whose boxes meet, ordered by box, at most :data:`_PAIRS` at a time.

    Only the boxes are compared (the exact tests that follow decide: GEOS's own predicates cost more than they
    save). With ``group`` (non-decreasing, one per box: the pieces of one shape), (group, tree item) pairs
    instead, each once, ordered by group. The boxes are queried in chunks (never splitting a group): first
    of as many as could meet :data:`_PAIRS` items if each met every one, a chunk twice as large after one that
    met few (up to 16 times the first), half as large after one that met many; so a query holds at most 16
    times :data:`_PAIRS` index pairs (with groups, that and one group's).
    """
    base = max(1, _PAIRS // max(1, len(tree)))
    step, start = base, 0
    while start < len(boxes):
        stop = min(start + step, len(boxes))
        if group is not None:
            stop = int(np.searchsorted(group, group[stop - 1], side="right"))
        i, j = tree.query(boxes[start:stop])
        found = len(i)
        i = i + start
        if group is not None:
            i = group[i]
        order = np.lexsort((j, i))
        i, j = i[order], j[order]
        if group is not None and len(i):
            once = np.r_[True, (i[1:] != i[:-1]) | (j[1:] != j[:-1])]
            i, j = i[once], j[once]
        for k in range(0, len(i), _PAIRS):
            yield i[k : k + _PAIRS], j[k : k + _PAIRS]
        start = stop
        step = min(2 * step, 16 * base) if found < _PAIRS // 4 else max(base, step // 2)


def _near(surfaces: Surfaces, s: NDArray[np.float64], reach: float) -> tuple[_Near, NDArray[np.str_]]:
    """Select segments, vertices and cylinders within ``reach`` of ``s``; build the label table."""
    p_all, q_all = surfaces.p, surfaces.q
    dist = point_segment_distances(s, p_all, q_all)
    seg = np.flatnonzero((dist <= reach) & (p_all != q_all).any(axis=1))  # a zero-length segment is nothing
    ends = surfaces.segments[seg]
    verts, local = np.unique(ends.ravel(), return_inverse=True)
    local = local.reshape(-1, 2)
    v = surfaces.vertices[verts]

    # Incidences (vertex, segment, direction away from the vertex), grouped by vertex and sorted by angle.
    inc_v = local.ravel()
    inc_s = np.repeat(np.arange(len(seg)), 2)
    other = local[:, ::-1].ravel()
    direction = v[other] - v[inc_v]
    ang = np.arctan2(direction[:, 1], direction[:, 0])
    order = np.lexsort((ang, inc_v))
    inc_v, inc_s, ang = inc_v[order], inc_s[order], ang[order]
    degree = np.bincount(inc_v, minlength=len(verts))
    width = int(degree.max()) if len(degree) else 1
    slot = np.arange(len(inc_v)) - np.repeat(np.cumsum(degree) - degree, degree)
    wedge_angle = np.full((len(verts), width), np.inf)
    wedge_seg = np.zeros((len(verts), width), dtype=np.intp)
    wedge_angle[inc_v, slot] = ang
    wedge_seg[inc_v, slot] = inc_s

    cyl_dist = np.hypot(*(surfaces.cylinder_centers - s).T) - surfaces.cylinder_radii
    cyl = np.flatnonzero(cyl_dist <= reach)
    refl_cyl = cyl[surfaces.cylinder_sonar_reflective[cyl]]

    labels = np.concatenate(
        [
            np.asarray(surfaces.segment_ids, dtype=str)[seg],
            np.asarray(surfaces.vertex_ids, dtype=str)[verts],
            np.asarray(surfaces.cylinder_ids, dtype=str)[refl_cyl],
            np.array([""]),
        ]
    )
    near = _Near(
        p=p_all[seg],
        q=q_all[seg],
        reflective=np.asarray(surfaces.sonar_reflective, dtype=bool)[seg],
        v=v,
        wedge_angle=wedge_angle,
        wedge_seg=wedge_seg,
        degree=degree,
        c=surfaces.cylinder_centers[refl_cyl],
        radius=surfaces.cylinder_radii[refl_cyl],
        occ_c=surfaces.cylinder_centers[cyl],
        occ_r=surfaces.cylinder_radii[cyl],
        occluders=shapely.STRtree(
            np.concatenate(
                [
                    _segment_boxes(p_all[seg], q_all[seg]),
                    _circle_boxes(surfaces.cylinder_centers[cyl], surfaces.cylinder_radii[cyl]),
                ]
            )
        ),
        fan=_fan(s, p_all[seg], q_all[seg], surfaces.cylinder_centers[cyl], surfaces.cylinder_radii[cyl]),
        targets=shapely.STRtree(
            np.concatenate(
                [
                    _segment_boxes(p_all[seg], q_all[seg]),
                    _boxes(v - _PAD, v + _PAD),
                    _circle_boxes(surfaces.cylinder_centers[refl_cyl], surfaces.cylinder_radii[refl_cyl]),
                ]
            )
        ),
    )
    return near, labels


def _halfwidth(strength: NDArray[np.float64], r: NDArray[np.float64], params: SonarParams) -> NDArray[np.float64]:
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
    near: _Near, vi: NDArray[np.intp], src: NDArray[np.float64], params: SonarParams
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


def _path_crossings(
    a: NDArray[np.float64], b: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Parameters (u along a->b, v along p->q) where the path a->b crosses the segment p->q's line.

    NaN where (nearly) parallel: a segment seen exactly edge-on neither crosses nor blocks a path.
    """
    return crossings(a, b - a, p, q - p, parallel=_PARALLEL)


def _blocked(a: NDArray[np.float64], b: NDArray[np.float64], near: _Near, fan: _Fan | None = None) -> NDArray[np.bool_]:
    """(K,) True where the path a->b (K, 2) is crossed by a segment or a cylinder strictly between its ends.

    Only the surfaces that may meet a path are tested, a bounded number of pairs at a time. With ``fan``,
    seen from a point on the line of every path, before ``a`` (the sensor, or the image of the sensor
    from which second legs leave a mirror): those whose bearing interval holds the path's bearing,
    nearest that point first, until the path is found blocked or the rest are beyond its end. Without:
    those whose boxes the path meets.
    """
    hit = np.zeros(len(a), dtype=bool)
    if not len(a) or not len(near.fan[1]):
        return hit
    n = len(near.p)
    if fan is not None:
        origin, lo, width, dist = fan
        rel = b - origin
        reach = np.hypot(rel[:, 0], rel[:, 1])  # a crossing is nearer than the path's end; -inf once blocked
        pairs = nearest_first_pairs(lo, width, dist, np.arctan2(rel[:, 1], rel[:, 0]), reach, _PAIRS)
    else:
        pairs = _pairs(near.occluders, _boxes(np.minimum(a, b), np.maximum(a, b)))
    for i, j in pairs:
        seg = j < n
        ii, jj = i[seg], j[seg]
        u, v = _path_crossings(a[ii], b[ii], near.p[jj], near.q[jj])
        hit[ii[(u > _EPS) & (u < 1 - _EPS) & (v >= -_EPS) & (v <= 1 + _EPS)]] = True
        ii, jj = i[~seg], j[~seg] - n
        t, foot = perpendicular_feet(near.occ_c[jj], a[ii], b[ii])  # the path's nearest points
        d = np.hypot(foot[:, 0] - near.occ_c[jj, 0], foot[:, 1] - near.occ_c[jj, 1])
        hit[ii[(t > _EPS) & (t < 1 - _EPS) & (d < near.occ_r[jj] * (1 - _EPS))]] = True
        if fan is not None:
            reach[hit] = -np.inf
    return hit


def _second_legs_blocked(
    x: NDArray[np.float64],
    point: NDArray[np.float64],
    mirror: NDArray[np.intp],
    image: NDArray[np.float64],
    near: _Near,
) -> NDArray[np.bool_]:
    """(K,) :func:`_blocked` for second legs x -> point, leaving the mirrors ``mirror`` (K,, sorted) whose sensor
    images are ``image``: a mirror with many legs has them tested from its image (they lie on lines from it),
    the others by the boxes they meet."""
    hit = np.zeros(len(x), dtype=bool)
    groups, start, count = np.unique(mirror, return_index=True, return_counts=True)
    many = count >= _FAN_LEGS
    for g, k, c in zip(groups[many], start[many], count[many], strict=True):
        hit[k : k + c] = _blocked(
            x[k : k + c], point[k : k + c], near, _fan(image[g], near.p, near.q, near.occ_c, near.occ_r)
        )
    few = np.repeat(~many, count)
    hit[few] = _blocked(x[few], point[few], near)
    return hit


def _candidates(
    near: _Near, src: NDArray[np.float64], cand: NDArray[np.intp]
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
    can[seg] = near.reflective[k] & (t >= -_TOUCH) & (t <= 1 + _TOUCH)
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


def _strength(
    near: _Near, cand: NDArray[np.intp], src: NDArray[np.float64], params: SonarParams
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
    reach = halfwidth + _TOUCH + 1e-9
    lo, width = np.mod(bearing - reach, 2 * np.pi), 2 * reach
    for rows, echo in bearing_pairs(lo, width, angles, _PAIRS):
        off = np.abs(np.mod(bearing[echo] - angles[rows] + np.pi, 2 * np.pi) - np.pi)
        covered = off <= halfwidth[echo] + _TOUCH
        np.minimum.at(best, rows[covered], r[echo[covered]])
    # among echoes of equal range (a wall's foot at its corner), the first candidate: round-off never decides
    for rows, echo in bearing_pairs(lo, width, angles, _PAIRS):
        off = np.abs(np.mod(bearing[echo] - angles[rows] + np.pi, 2 * np.pi) - np.pi)
        first = (off <= halfwidth[echo] + _TOUCH) & (r[echo] <= best[rows] + _TOUCH)
        np.minimum.at(idx, rows[first], echo[first])
    return best, np.where(idx < len(r), idx, 0)


def _echoes(near: _Near, s: NDArray[np.float64], params: SonarParams) -> _Echoes:
    """First-order echoes: bearing, half-width, range, label index of every detectable, visible target."""
    everything = np.arange(len(near.p) + len(near.v) + len(near.c))
    point, can = _candidates(near, np.broadcast_to(s, (len(everything), 2)), everything)
    r = np.hypot(*(point - s).T)
    cand = np.flatnonzero(can & (r > _EPS) & (r <= params.max_range))
    w = _halfwidth(_strength(near, cand, np.broadcast_to(s, (len(cand), 2)), params), r[cand], params)
    cand = cand[w >= 0]
    w = w[w >= 0]
    seen = ~_blocked(np.broadcast_to(s, (len(cand), 2)), point[cand], near, near.fan)
    cand, w = cand[seen], w[seen]
    rel = point[cand] - s
    return np.arctan2(rel[:, 1], rel[:, 0]), w, r[cand], cand


def _visible_segments(near: _Near, s: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(n,) True for the segments that some ray from ``s`` hits first.

    Which segment is nearest can change only at the bearing of a segment end or of a
    cylinder's tangent, so one ray through each angular interval between those
    bearings decides (exact for segments that do not cross one another). A ray is
    tested against the surfaces whose bearing interval holds it, nearest first, until
    the rest are beyond its nearest hit.
    """
    n = len(near.p)
    rel = np.concatenate([near.p, near.q]) - s
    crit = [np.arctan2(rel[:, 1], rel[:, 0])]
    if len(near.occ_c):
        rc = near.occ_c - s
        centre = np.arctan2(rc[:, 1], rc[:, 0])
        half = np.arcsin(np.clip(near.occ_r / np.hypot(rc[:, 0], rc[:, 1]), 0, 1))
        crit += [centre - half, centre + half]
    crit = np.unique(np.mod(np.concatenate(crit), 2 * np.pi))
    mid = (crit + np.append(crit[1:], crit[0] + 2 * np.pi)) / 2
    u = np.stack([np.cos(mid), np.sin(mid)], axis=1)
    best = np.full(len(mid), np.inf)
    first = np.full(len(mid), -1, dtype=np.intp)  # per ray the nearest; of equal ones the first listed
    for i, j in nearest_first_pairs(*near.fan[1:], mid, best, _PAIRS):
        seg = j < n
        t, v = crossings(s, u[i[seg]], near.p[j[seg]], near.q[j[seg]] - near.p[j[seg]], parallel=_PARALLEL)
        dist = np.empty(len(i))
        dist[seg] = np.where((t > 0) & (v >= 0) & (v <= 1), t, np.inf)
        dist[~seg] = ray_circle_pairs(s, u[i[~seg]], near.occ_c[j[~seg] - n], near.occ_r[j[~seg] - n])
        merge_nearest(best, first, i, j, dist)
    return np.isin(np.arange(n), first)


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
    near: _Near,
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
        stop = max(start + 1, int(np.searchsorted(ends, (ends[start - 1] if start else 0) + _PAIRS // 16, "right")))
        k = pieces[start:stop]
        cone = np.repeat(np.arange(start, stop), k)
        piece = np.arange(len(cone)) - np.repeat(np.cumsum(k) - k, k)
        lam = near_side[cone] + (far_side - near_side)[cone] * np.stack([piece, piece + 1]) / pieces[cone]
        at = image[cone]
        corners = np.stack([at + lam[m, :, None] * (end[cone] - at) for m in (0, 1) for end in (pa, qa)])
        yield from _pairs(near.targets, _boxes(corners.min(axis=0), corners.max(axis=0)), cone)
        start = stop


def _double_echoes(
    near: _Near, s: NDArray[np.float64], params: SonarParams, angles: NDArray[np.float64], first: NDArray[np.float64]
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
    mir = np.flatnonzero(near.reflective & _visible_segments(near, s))
    pa, qa = near.p[mir], near.q[mir]
    d = qa - pa
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    h = np.einsum("ij,ij->i", s - pa, normal)
    mir, pa, qa, normal, h = (x[np.abs(h) > _EPS] for x in (mir, pa, qa, normal, h))
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
    near_side = 1 - 2 * _PAD / np.abs(h)
    far_side = 1 + (second_leg + 2 * _PAD) / np.abs(h)
    # A long thin cone is cut across into pieces about as long as it is wide (at most _CONE_PIECES), so that the
    # index, which sees boxes, does not offer every target in the box of a long diagonal cone.
    length = (far_side - near_side) * np.hypot(*((pa + qa) / 2 - image).T)
    pieces = np.clip(np.ceil(length / (far_side * np.hypot(*(qa - pa).T))), 1, _CONE_PIECES).astype(np.intp)
    echoes: list[_Echoes] = []
    for ia, ic in _cone_pairs(near, image, pa, qa, near_side, far_side, pieces):
        point, can = _candidates(near, image[ia], ic)
        u, v = _path_crossings(image[ia], point, pa[ia], qa[ia])
        r = np.linalg.norm(point - image[ia], axis=-1)
        ok = can & (u > _EPS) & (u < 1 - _EPS) & (v >= 0) & (v <= 1) & (r <= reach_r)
        ia, ic, point, r, u = ia[ok], ic[ok], point[ok], r[ok], u[ok]
        w = _halfwidth(_strength(near, ic, image[ia], params), r, params)
        x = image[ia] + u[:, None] * (point - image[ia])
        rel = x - s
        bearing = np.arctan2(rel[:, 1], rel[:, 0])
        j = np.round((bearing - angles[0]) / step).astype(np.intp) % len(angles)
        keep = (w >= 0) & (later[j] > r)
        ia, point, r, w, x, bearing = (a[keep] for a in (ia, point, r, w, x, bearing))
        seen = ~_blocked(np.broadcast_to(s, x.shape), x, near, near.fan)
        seen[seen] = ~_second_legs_blocked(x[seen], point[seen], ia[seen], image, near)
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
    near, labels = _near(surfaces, s, params.max_range)

    bearing, w, r, label = _echoes(near, s, params)
    best, idx = _first_echo(angles, bearing, w, r)
    target = np.where(np.isfinite(best), label[idx] if len(label) else -1, -1)
    order = np.where(np.isfinite(best), 1, 0)
    if max_order == 2 and len(near.p):
        bearing2, w2, r2, label2 = _double_echoes(near, s, params, angles, best)
        best2, idx2 = _first_echo(angles, bearing2, w2, r2)
        later = best2 < best - _TOUCH
        best = np.where(later, best2, best)
        target = np.where(later, label2[idx2] if len(label2) else -1, target)
        order = np.where(later, 2, order)
    ranges = np.where(np.isfinite(best), best, params.max_range)
    if rng is not None:
        noisy = np.clip(ranges + rng.normal(0.0, params.range_noise, m), 0.0, params.max_range)
        ranges = np.where(order > 0, noisy, ranges)
    return SonarScan(pose_arr, angles, ranges, labels[target], order, params)
