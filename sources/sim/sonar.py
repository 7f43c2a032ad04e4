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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import crossings, perpendicular_feet, point_segment_distances, ray_circle_distances
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


def _blocked(a: NDArray[np.float64], b: NDArray[np.float64], near: _Near) -> NDArray[np.bool_]:
    """(K,) True where the path a->b (K, 2) is crossed by a segment or a cylinder strictly between its ends."""
    u, v = _path_crossings(a[:, None], b[:, None], near.p[None], near.q[None])
    hit = np.any((u > _EPS) & (u < 1 - _EPS) & (v >= -_EPS) & (v <= 1 + _EPS), axis=1)
    if len(near.occ_c):
        t, foot = perpendicular_feet(near.occ_c[None], a[:, None], b[:, None])  # (K, C): the path's nearest points
        d = np.hypot(foot[..., 0] - near.occ_c[:, 0], foot[..., 1] - near.occ_c[:, 1])
        hit |= np.any((t > _EPS) & (t < 1 - _EPS) & (d < near.occ_r[None] * (1 - _EPS)), axis=1)
    return hit


def _candidates(near: _Near, src: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Echo points of every candidate target seen from each source, before strength and occlusion.

    Candidates (C) are the feet of the perpendiculars on the segments, the vertices
    and the points of the cylinders nearest the source, in that order (the order of
    the label table). Returns points (S, C, 2) and whether each can answer at all
    (a reflective segment whose foot lies on it; a cylinder the source is outside of).
    """
    t, foot = perpendicular_feet(src[:, None], near.p[None], near.q[None])
    vert = np.broadcast_to(near.v[None], (len(src), len(near.v), 2))
    rel = src[:, None] - near.c[None]
    dist = np.linalg.norm(rel, axis=-1)
    outside = dist > near.radius[None]
    cyl = near.c[None] + near.radius[None, :, None] * rel / np.where(outside, dist, 1.0)[..., None]
    point = np.concatenate([foot, vert, cyl], axis=1)
    on_segment = near.reflective[None] & (t >= -_TOUCH) & (t <= 1 + _TOUCH)
    can = np.concatenate([on_segment, np.ones(vert.shape[:2], dtype=bool), outside], axis=1)
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

    Ties (within round-off) go to the echo listed first.
    """
    off = np.abs(np.mod(bearing[None] - angles[:, None] + np.pi, 2 * np.pi) - np.pi)
    cand = np.where(off <= halfwidth[None] + _TOUCH, r[None], np.inf)
    if cand.shape[1] == 0:
        return np.full(len(angles), np.inf), np.zeros(len(angles), dtype=np.intp)
    best = cand.min(axis=1)
    # among echoes of equal range (a wall's foot at its corner), the first candidate: round-off never decides
    idx = np.argmax(cand <= best[:, None] + _TOUCH, axis=1)
    return best, idx


def _echoes(near: _Near, s: NDArray[np.float64], params: SonarParams) -> _Echoes:
    """First-order echoes: bearing, half-width, range, label index of every detectable, visible target."""
    point, can = _candidates(near, s[None])
    point, can = point[0], can[0]
    r = np.hypot(*(point - s).T)
    cand = np.flatnonzero(can & (r > _EPS) & (r <= params.max_range))
    w = _halfwidth(_strength(near, cand, np.broadcast_to(s, (len(cand), 2)), params), r[cand], params)
    cand = cand[w >= 0]
    w = w[w >= 0]
    seen = ~_blocked(np.broadcast_to(s, (len(cand), 2)), point[cand], near)
    cand, w = cand[seen], w[seen]
    rel = point[cand] - s
    return np.arctan2(rel[:, 1], rel[:, 0]), w, r[cand], cand


def _visible_segments(near: _Near, s: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(n,) True for the segments that some ray from ``s`` hits first.

    Which segment is nearest can change only at the bearing of a segment end or of a
    cylinder's tangent, so one ray through each angular interval between those
    bearings decides (exact for segments that do not cross one another).
    """
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
    t, v = crossings(s, u[:, None], near.p, near.q - near.p, parallel=_PARALLEL)
    dist = np.where((t > 0) & (v >= 0) & (v <= 1), t, np.inf)
    if len(near.occ_c):
        dist = np.concatenate([dist, ray_circle_distances(s, u, near.occ_c, near.occ_r)], axis=1)
    first = np.argmin(dist, axis=1)[np.isfinite(dist.min(axis=1))]
    return np.isin(np.arange(len(near.p)), first)


def _double_echoes(
    near: _Near, s: NDArray[np.float64], params: SonarParams, angles: NDArray[np.float64], first: NDArray[np.float64]
) -> _Echoes:
    """Second-order echoes by the mirror-image method, for readings where they come before ``first``.

    The sensor mirrored in each reflective segment A is a virtual sensor; each of its
    candidate targets T gives a path sensor -> X -> T -> X -> sensor when the line from
    the image to T crosses A at X. Returns bearing (of the first leg), half-width,
    range (|image - T|) and the label index of A, for the visible, detectable paths.
    """
    mir = np.flatnonzero(near.reflective & _visible_segments(near, s))
    pa, qa = near.p[mir], near.q[mir]
    d = qa - pa
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    h = np.einsum("ij,ij->i", s - pa, normal)
    mir, pa, qa, normal, h = (x[np.abs(h) > _EPS] for x in (mir, pa, qa, normal, h))
    image = s - 2 * h[:, None] * normal
    point, can = _candidates(near, image)
    u, v = _path_crossings(image[:, None], point, pa[:, None], qa[:, None])
    r = np.linalg.norm(point - image[:, None], axis=-1)
    ok = can & (u > _EPS) & (u < 1 - _EPS) & (v >= 0) & (v <= 1) & (r <= min(params.max_range, params.detection_range))
    ia, ic = np.nonzero(ok)
    r, u = r[ia, ic], u[ia, ic]
    w = _halfwidth(_strength(near, ic, image[ia], params), r, params)
    # Only paths that could come before the first-order echo of some reading within the beam matter.
    step = 2 * np.pi / len(angles)
    reach = int(np.ceil(np.radians(params.beam_width_deg) / 2 / step)) + 1
    window = (np.arange(len(first))[:, None] + np.arange(-reach, reach + 1)) % len(first)
    later = first[window].max(axis=1)  # the longest first-order reading near each beam axis
    x = image[ia] + u[:, None] * (point[ia, ic] - image[ia])
    rel = x - s
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    j = np.round((bearing - angles[0]) / step).astype(np.intp) % len(angles)
    keep = (w >= 0) & (later[j] > r)
    ia, ic, r, w, x, bearing = (a[keep] for a in (ia, ic, r, w, x, bearing))
    seen = ~_blocked(np.broadcast_to(s, x.shape), x, near)
    seen[seen] = ~_blocked(x[seen], point[ia[seen], ic[seen]], near)
    return bearing[seen], w[seen], r[seen], mir[ia[seen]]


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
