"""What is near the sonar: the surfaces in its range and the paths through them, found by spatial indexes.

The sonar model (:mod:`evmap.sources.sim.sonar`) pairs paths, sources and readings only with the
surfaces, targets and echoes an index finds near them, a bounded number of pairs at a time
(:data:`PAIRS`): :func:`surfaces_near` gathers what is in range of the sensor, :func:`path_blocked`
and :func:`second_legs_blocked` test paths against the occluders their boxes or bearings meet.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.sources.geometry import crossings, perpendicular_feet, point_segment_distances
from evmap.sources.ray_casting import bearing_intervals, merge_nearest, nearest_first_pairs, ray_circle_pairs
from evmap.sources.sim.surfaces import Surfaces

__all__ = [
    "EPS",
    "FAN_LEGS",
    "PAD",
    "PAIRS",
    "PARALLEL",
    "TOUCH",
    "Fan",
    "Near",
    "box_array",
    "circle_boxes",
    "index_pairs",
    "occluder_fan",
    "path_blocked",
    "path_crossings",
    "probe_rays",
    "second_legs_blocked",
    "segment_boxes",
    "surfaces_near",
    "visible_segments",
]


EPS = 1e-7
"""Tolerance on path parameters (relative): a path touching an occluder at its own ends is not blocked."""


TOUCH = 1e-9
"""Slack on foot positions (segment parameter) and beam edges (rad), so round-off never decides an echo."""


PARALLEL = 1e-12
"""Lines whose directions' cross product is within this share of their lengths' product are parallel."""


PAIRS = 1 << 20
"""Most pairs (a path and a surface, a source and a candidate target, a reading and an echo) computed at once.

The model works through its pairs in chunks of at most this many, so its memory is bounded (about 100 MB)
whatever the number of surfaces in range; and it computes only the pairs that an index finds near each other
(a path from the sensor and the surfaces whose bearing interval holds it, nearest first; other paths and the
boxes they meet; a reading and the echoes within their half-width of it), not every surface for every path."""


PAD = 1e-6
"""Margin (m) added to every box of the spatial indexes, on top of each test's own tolerance: a box holds
every point that the exact tests can accept, round-off included, so the index never drops a pair they keep."""


FAN_LEGS = 16
"""Second legs leaving one mirror from which they are tested seen from its image, not by their boxes."""


Fan = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""Occluders seen from a point: the point, their bearing intervals' starts and widths, their least distances."""


@dataclass(frozen=True)
class Near:
    """The part of a Surfaces within sonar range of the sensor, with vertex wedges sorted by angle.

    Candidate targets are numbered segments first, then vertices, then reflective
    cylinders: that number indexes the label table that :func:`surfaces_near` returns.
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
    fan: Fan  # the same occluders seen from the sensor
    targets: shapely.STRtree  # boxes of the candidate targets: segments, vertices, reflective cylinders


def box_array(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.object_]:
    """Axis-aligned boxes from their lower-left (N, 2) and upper-right (N, 2) corners."""
    return shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])


def segment_boxes(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.object_]:
    """Boxes of segments, grown by the tests' tolerance along them (a path may cross a segment's line
    up to ``EPS`` of its length beyond its ends) and by :data:`PAD`."""
    pad = (2 * EPS * np.hypot(*(q - p).T) + PAD)[:, None]
    return box_array(np.minimum(p, q) - pad, np.maximum(p, q) + pad)


def circle_boxes(c: NDArray[np.float64], r: NDArray[np.float64]) -> NDArray[np.object_]:
    """Boxes of circles, grown by :data:`PAD`."""
    return box_array(c - (r + PAD)[:, None], c + (r + PAD)[:, None])


def occluder_fan(
    origin: NDArray[np.float64],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    c: NDArray[np.float64],
    r: NDArray[np.float64],
) -> Fan:
    """Occluders, segments ``p``-``q`` then cylinders ``c``, ``r``, seen from ``origin``, as :func:`path_blocked` uses
    them: each one's bearing interval holds every point a path's crossing test can accept on it."""
    lo, width = bearing_intervals(origin, p, q, EPS * np.hypot(*(q - p).T) + PAD, c, r)
    return origin, lo, width, np.concatenate([point_segment_distances(origin, p, q), np.hypot(*(c - origin).T) - r])


def index_pairs(
    tree: shapely.STRtree, boxes: NDArray[np.object_], group: NDArray[np.intp] | None = None
) -> Iterator[tuple[NDArray[np.intp], ...]]:
    """(box, tree item) index pairs whose boxes meet, ordered by box, at most :data:`PAIRS` at a time.

    Only the boxes are compared (the exact tests that follow decide: GEOS's own predicates cost more than they
    save). With ``group`` (non-decreasing, one per box: the pieces of one shape), (group, tree item) pairs
    instead, each once, ordered by group. The boxes are queried in chunks (never splitting a group): first
    of as many as could meet :data:`PAIRS` items if each met every one, a chunk twice as large after one that
    met few (up to 16 times the first), half as large after one that met many; so a query holds at most 16
    times :data:`PAIRS` index pairs (with groups, that and one group's).
    """
    base = max(1, PAIRS // max(1, len(tree)))
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
        for k in range(0, len(i), PAIRS):
            yield i[k : k + PAIRS], j[k : k + PAIRS]
        start = stop
        step = min(2 * step, 16 * base) if found < PAIRS // 4 else max(base, step // 2)


def surfaces_near(surfaces: Surfaces, s: NDArray[np.float64], reach: float) -> tuple[Near, NDArray[np.str_]]:
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
    near = Near(
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
                    segment_boxes(p_all[seg], q_all[seg]),
                    circle_boxes(surfaces.cylinder_centers[cyl], surfaces.cylinder_radii[cyl]),
                ]
            )
        ),
        fan=occluder_fan(s, p_all[seg], q_all[seg], surfaces.cylinder_centers[cyl], surfaces.cylinder_radii[cyl]),
        targets=shapely.STRtree(
            np.concatenate(
                [
                    segment_boxes(p_all[seg], q_all[seg]),
                    box_array(v - PAD, v + PAD),
                    circle_boxes(surfaces.cylinder_centers[refl_cyl], surfaces.cylinder_radii[refl_cyl]),
                ]
            )
        ),
    )
    return near, labels


def path_crossings(
    a: NDArray[np.float64], b: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Parameters (u along a->b, v along p->q) where the path a->b crosses the segment p->q's line.

    NaN where (nearly) parallel: a segment seen exactly edge-on neither crosses nor blocks a path.
    """
    return crossings(a, b - a, p, q - p, parallel=PARALLEL)


def path_blocked(
    a: NDArray[np.float64], b: NDArray[np.float64], near: Near, fan: Fan | None = None
) -> NDArray[np.bool_]:
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
        pairs = nearest_first_pairs(lo, width, dist, np.arctan2(rel[:, 1], rel[:, 0]), reach, PAIRS)
    else:
        pairs = index_pairs(near.occluders, box_array(np.minimum(a, b), np.maximum(a, b)))
    for i, j in pairs:
        seg = j < n
        ii, jj = i[seg], j[seg]
        u, v = path_crossings(a[ii], b[ii], near.p[jj], near.q[jj])
        hit[ii[(u > EPS) & (u < 1 - EPS) & (v >= -EPS) & (v <= 1 + EPS)]] = True
        ii, jj = i[~seg], j[~seg] - n
        t, foot = perpendicular_feet(near.occ_c[jj], a[ii], b[ii])  # the path's nearest points
        d = np.hypot(foot[:, 0] - near.occ_c[jj, 0], foot[:, 1] - near.occ_c[jj, 1])
        hit[ii[(t > EPS) & (t < 1 - EPS) & (d < near.occ_r[jj] * (1 - EPS))]] = True
        if fan is not None:
            reach[hit] = -np.inf
    return hit


def second_legs_blocked(
    x: NDArray[np.float64],
    point: NDArray[np.float64],
    mirror: NDArray[np.intp],
    image: NDArray[np.float64],
    near: Near,
) -> NDArray[np.bool_]:
    """(K,) :func:`path_blocked` for second legs x -> point, leaving the mirrors ``mirror`` (K,, sorted) whose sensor
    images are ``image``: a mirror with many legs has them tested from its image (they lie on lines from it),
    the others by the boxes they meet."""
    hit = np.zeros(len(x), dtype=bool)
    groups, start, count = np.unique(mirror, return_index=True, return_counts=True)
    many = count >= FAN_LEGS
    for g, k, c in zip(groups[many], start[many], count[many], strict=True):
        hit[k : k + c] = path_blocked(
            x[k : k + c], point[k : k + c], near, occluder_fan(image[g], near.p, near.q, near.occ_c, near.occ_r)
        )
    few = np.repeat(~many, count)
    hit[few] = path_blocked(x[few], point[few], near)
    return hit


def probe_rays(near: Near, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One ray from ``s`` through each angular interval between the bearings of the segment ends and the
    cylinders' tangents: its bearing (rad, in [0, 2 pi) and a turn past the last) and unit direction."""
    rel = np.concatenate([near.p, near.q]) - s
    crit = [np.arctan2(rel[:, 1], rel[:, 0])]
    if len(near.occ_c):
        rc = near.occ_c - s
        centre = np.arctan2(rc[:, 1], rc[:, 0])
        half = np.arcsin(np.clip(near.occ_r / np.hypot(rc[:, 0], rc[:, 1]), 0, 1))
        crit += [centre - half, centre + half]
    crit = np.unique(np.mod(np.concatenate(crit), 2 * np.pi))
    mid = (crit + np.append(crit[1:], crit[0] + 2 * np.pi)) / 2
    return mid, np.stack([np.cos(mid), np.sin(mid)], axis=1)


def visible_segments(near: Near, s: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(n,) True for the segments that some ray from ``s`` hits first.

    Which segment is nearest can change only at the bearing of a segment end or of a
    cylinder's tangent, so one ray through each angular interval between those
    bearings decides (exact for segments that do not cross one another). A ray is
    tested against the surfaces whose bearing interval holds it, nearest first, until
    the rest are beyond its nearest hit.
    """
    n = len(near.p)
    mid, u = probe_rays(near, s)
    best = np.full(len(mid), np.inf)
    first = np.full(len(mid), -1, dtype=np.intp)  # per ray the nearest; of equal ones the first listed
    for i, j in nearest_first_pairs(*near.fan[1:], mid, best, PAIRS):
        seg = j < n
        t, v = crossings(s, u[i[seg]], near.p[j[seg]], near.q[j[seg]] - near.p[j[seg]], parallel=PARALLEL)
        dist = np.empty(len(i))
        dist[seg] = np.where((t > 0) & (v >= 0) & (v <= 1), t, np.inf)
        dist[~seg] = ray_circle_pairs(s, u[i[~seg]], near.occ_c[j[~seg] - n], near.occ_r[j[~seg] - n])
        merge_nearest(best, first, i, j, dist)
    return np.isin(np.arange(n), first)
