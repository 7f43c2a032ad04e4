"""The free space of a map, from what its poses sensed, ending at the map's believed surfaces.

Each remembered pose (:mod:`evmap.maps.sensed`) gives free space twice over:

- its sonar open space (:func:`evmap.sources.open_space.open_space` of its scan,
  with the map's config), the sectors from the sensor to the first echo;
- its contour rays: the fan between neighbouring rays that both returned (at most
  ``max_gap`` apart in bearing), from the sensor to the chord between their points
  where they met one surface, and only to the nearer point's range across a jump in
  range (what lies between the two rays beyond the nearer point was not seen).

Both keep ``margin`` away from what the pose's rays met (:func:`ray_ends`: the points
and the chords between them, less the rays on segments judged noise), measured square
to the surface, not along the ray, which meets a wall at a grazing angle millimetres
from it: no grid cell a measured wall crosses is free.

The contour bounds the sonar's free space of its own pose (:func:`contour_bound`):
a stripe point at range d is an opaque surface, so a sonar sector that reaches
beyond it on that bearing did not come from a direct echo (a double bounce, or
sound through an opening the sonar cannot resolve). Where the stripe returned
nothing between two points at most ``bridge`` apart (a window: glass lets the
stripe through, and the sonar, at oblique incidence, hears a double bounce), the
chord between the two points bounds it. A ray that returned nothing bounds it at
the contour sensor's range (``sensors.lsl.max_range``): the stripe tells that
nothing opaque stands within it, and nothing tells beyond it, where a sector may
cross a wall the sonar did not hear (a specular wall is silent off its normal).
Where the sensor reports every return a ray lit (a stripe camera keeping every
pixel above its threshold), a ray went on through every return of its bearing but
the farthest (sunlit pixels: no surface stops the stripe short of one it lit), and
only the farthest bounds the sonar (:func:`~evmap.maps.sensed.farthest_returns`). The farthest bounds it
even on a segment judged noise: a sunlit patch with nothing behind it within range
and a wall look alike to the stripe, and a planner trusts what the map calls free.
With one return a ray (a camera keeping a column's brightest pixel, a laser) every
point bounds it: nothing tells what lies beyond a point.
Across a jump in range from one surface's run of bearings to another's, the bound
goes on at the nearer range to the farther one's bearing, as the fans do: the
end of a wall falls between two rays, and what lies between them beyond the
nearer point was not seen. Bearings the contour did not look at leave the sonar's
free space as it is.

A sensor sees nothing behind a surface, so each pose's free space ends at the first believed line
(``Bel(real) >= min_belief``) that it meets: the line's shadow from the pose is cut away; and at every
believed unidentified object, a face toward each pose that heard it, ``object_width`` across or the whole
window or glass wall it lies in (glass heard at normal incidence: the stripe goes through the pane, the
sonar does not; :mod:`evmap.maps.object_faces`). The map's free space is the union over poses. A map that
remembers no pose (hand-made, or from an older file) has its stored open space as it is.

The occupancy grid (:mod:`evmap.maps.occupancy`) takes its free evidence from
here; ``map.json`` keeps the sensed readings, so the grid of a loaded map is the
grid of the run.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.maps.object_faces import object_faces
from evmap.maps.planner import lines
from evmap.maps.sensed import Sensed, farthest_returns, sensed
from evmap.sources.geometry import near_segments
from evmap.sources.open_space import GRID, open_space, unite
from evmap.sources.rcd import extract_rcds

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = [
    "FreeSpaceParams",
    "contour_bound",
    "free_space",
    "ray_ends",
    "ray_fan",
    "shadows",
    "surface_points",
    "surface_rays",
]


@dataclass(frozen=True)
class FreeSpaceParams:
    """Constants of the free space (metres, radians, belief)."""

    margin: float = 0.05  # the free space keeps this far from what a ray met; a ray this close to a segment ends on it
    max_gap: float = np.radians(2.0)  # neighbouring rays farther apart than this bound no free space
    min_belief: float = 0.5  # lines believed at least this much end the free space
    bridge: float = 2.5  # a gap in the stripe between points at most this far apart (m) is bridged
    object_width: float = 0.6  # a believed unidentified object ends the free space over this width (m)
    glass_wall: float = 10.0  # ... or over the gap between believed lines in line with it on both sides, this wide
    window: float = 4.0  # ... or this wide with shorter lines in line between them (panes between mullions)
    in_line: float = 0.1  # an object this close to a believed line's own line is in line with it (m)
    wall_length: float = 0.3  # lines at least this long bound a window (not a chair leg's, nor a door jamb's)
    # neighbouring rays whose ranges differ by more than this times the arc between them met no one surface:
    # a jump in range (a wall met 6 deg or more off its face stays one surface)
    steepness: float = 10.0


def ray_fan(s: Sensed, params: FreeSpaceParams) -> shapely.Geometry:
    """The space between neighbouring rays of one pose that both returned, up to what they met (:func:`ray_ends`
    is what the free space keeps ``margin`` away from).

    >>> bearing = np.radians([-10.0, -9.0, -8.0, 30.0])
    >>> s = Sensed(0, np.zeros(2), bearing, np.array([2.0, 2.0, 2.0, 3.0]), None)
    >>> round(ray_fan(s, FreeSpaceParams()).area, 3), round(shapely.difference(ray_fan(s, FreeSpaceParams()),
    ...     ray_ends(s, FreeSpaceParams())).area, 3)  # two thin triangles, 2 m long; 5 cm short of their ends
    (0.07, 0.066)
    """
    ends = _pairs(s, params)
    if ends is None:
        return shapely.Polygon()
    pair, corners = ends
    # each run of adjacent sectors is one star polygon (a union of thousands of triangles whose edges do not
    # meet would cost a second per pose)
    breaks = np.flatnonzero(s.bearing[pair[1:]] != s.bearing[pair[:-1] + 1]) + 1
    runs = np.array([shapely.Polygon(np.vstack([s.origin, c.reshape(-1, 2)])) for c in np.split(corners, breaks)])
    # rays a hair apart in bearing at very different ranges (a camera reporting every return a ray lit, where
    # its snapshots overlap) zigzag along the rays: such a run may cross itself, and a union with it fails
    bad = ~shapely.is_valid(runs)
    runs[bad] = shapely.make_valid(runs[bad])
    return shapely.union_all(runs)


def ray_ends(s: Sensed, params: FreeSpaceParams) -> shapely.Geometry:
    """What the rays of one pose met, widened by ``margin``: a band the free space stays out of.

    Every returned ray's point, and between neighbouring rays that met one surface the chord
    between their points (across a jump in range, the arc at the nearer range that ends the
    fan). ``margin`` square to the surface, not along the ray: a ray that meets a wall at a
    grazing angle ends millimetres from the wall ``margin`` before its point, and the grid
    cells the wall crosses would be free.

    >>> s = Sensed(0, np.zeros(2), np.radians([0.0, 1.0]), np.array([2.0, 2.0]), None)
    >>> band = ray_ends(s, FreeSpaceParams())
    >>> [bool(band.contains(shapely.Point(x, 0.01))) for x in (1.9, 1.97)]
    [False, True]
    """
    ok = np.isfinite(s.range) & (s.range > 0)
    points = s.origin + s.range[ok, None] * np.column_stack([np.cos(s.bearing[ok]), np.sin(s.bearing[ok])])
    met = shapely.multipoints(points)
    ends = _pairs(s, params)
    if ends is not None:  # the chords, one polyline per run of chords that meet end to end
        corners = ends[1]
        cut = np.flatnonzero((corners[1:, 0] != corners[:-1, 1]).any(axis=1)) + 1
        runs = [np.vstack([run[0, 0], run[:, 1]]) for run in np.split(corners, cut)]
        met = shapely.union(met, shapely.MultiLineString(runs))
    return shapely.buffer(met, params.margin, quad_segs=2)


def _band(s: Sensed, params: FreeSpaceParams) -> shapely.Geometry:
    """:func:`ray_ends`, kept for the last 64 poses' readings: the rules of a comparison mostly judge a world's
    stripe points alike, and one band then serves them all (a quarter of ``evmap compare``'s CPU time)."""
    as_bytes = (np.asarray(a, dtype=np.float64).tobytes() for a in (s.origin, s.bearing, s.range))
    return _band_of(*as_bytes, params)


@functools.lru_cache(maxsize=64)
def _band_of(origin: bytes, bearing: bytes, ranges: bytes, params: FreeSpaceParams) -> shapely.Geometry:
    """:func:`ray_ends` of readings given as the bytes of their float arrays."""
    return ray_ends(Sensed(0, *(np.frombuffer(b) for b in (origin, bearing, ranges)), None), params)


def _pairs(s: Sensed, params: FreeSpaceParams) -> tuple[NDArray[np.intp], NDArray[np.float64]] | None:
    """The neighbouring rays that both returned (the first of each pair) and the fan's corners on them (P, 2, 2):
    at their points on one surface, at the nearer range across a jump; None without such rays."""
    r = s.range
    ok = np.isfinite(r) & (r > 0)
    step = np.diff(s.bearing)
    pair = np.flatnonzero(ok[:-1] & ok[1:] & (step > 0) & (step <= params.max_gap))
    if not len(pair):
        return None
    a, b = r[pair], r[pair + 1]
    jump = _jump(a, b, step[pair], params)
    a, b = np.where(jump, np.minimum(a, b), a), np.where(jump, np.minimum(a, b), b)
    u = np.column_stack([np.cos(s.bearing), np.sin(s.bearing)])
    return pair, s.origin + np.stack([a[:, None] * u[pair], b[:, None] * u[pair + 1]], axis=1)


def _jump(
    a: NDArray[np.float64], b: NDArray[np.float64], step: NDArray[np.float64], params: FreeSpaceParams
) -> NDArray[np.bool_]:
    """Whether neighbouring rays ``step`` apart (rad), at ranges ``a`` and ``b``, met no one surface (``steepness``)."""
    return np.abs(a - b) > params.steepness * np.maximum(a, b) * step


def surface_rays(s: Sensed, p: NDArray[np.float64], q: NDArray[np.float64], margin: float, *, on: bool) -> Sensed:
    """The pose's readings with only the rays that ended on surfaces still returned.

    The surfaces are the segments p-q (``on``: a ray ending within ``margin`` of one is on a
    surface) or everything but them (not ``on``: the pose's own segments judged noise, say:
    a phantom's stripe points are pixels, not a surface). The other rays return nothing.
    """
    hit = np.zeros(len(s.range), dtype=bool)
    ok = np.flatnonzero(np.isfinite(s.range))
    if len(ok) and len(p):
        hit[ok] = near_segments(s.points, p, q, margin, s.point_index)
    drop = np.isfinite(s.range) & (hit != on)
    if not drop.any():
        return s
    return replace(s, range=np.where(drop, np.nan, s.range))


def contour_bound(
    s: Sensed,
    params: FreeSpaceParams,
    reach: float,
    bridge_ok: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]] | None = None,
    unreturned: float | None = None,
    *,
    seen_only: bool = False,
) -> shapely.Geometry | None:
    """What the contour of one pose leaves possible to be free: the star polygon through its stripe points.

    Each returned ray bounds it at its point (less ``margin``); a run of rays that returned
    nothing, between two returned rays whose points ``a``, ``b`` are at most ``bridge`` apart
    (and pass ``bridge_ok(a, b)``, (K, 2) each, when given), at the chord between those points;
    other rays that returned nothing at ``unreturned`` (less ``margin``) when given, the range
    within which they tell that nothing opaque stands; those rays when it is not given, and
    bearings with no ray (more than ``max_gap`` from the nearest), at ``reach``. With ``seen_only``,
    across a jump in range between neighbouring bearings (as :func:`ray_fan` tells one) it goes on at
    the nearer range to the farther one's bearing: what lies between them beyond the nearer was not
    seen (without, the edge between the two cuts across it: the bound of what the stripe may have hidden).
    None when the pose has no returned ray.

    >>> bearing = np.radians(np.arange(-180.0, 180.0, 1.0))
    >>> rng = np.where(np.abs(bearing) < np.radians(60), 1 / np.cos(bearing), np.nan)  # a wall x = 1
    >>> rng[np.abs(bearing) < np.radians(20)] = np.nan  # a window in it: nothing returned
    >>> bound = contour_bound(Sensed(0, np.zeros(2), bearing, rng, None), FreeSpaceParams(), 10.0)
    >>> [bool(bound.contains(shapely.Point(x, 0))) for x in (0.9, 1.1)]  # bridged at the window
    [True, False]
    >>> bool(bound.contains(shapely.Point(-5, 0)))  # nothing returned behind: not bounded
    True
    >>> refuse = contour_bound(Sensed(0, np.zeros(2), bearing, rng, None), FreeSpaceParams(), 10.0,
    ...                        lambda a, b: np.zeros(len(a), dtype=bool))
    >>> bool(refuse.contains(shapely.Point(1.1, 0)))  # a gap bridge_ok refuses stays open
    True
    >>> near = contour_bound(Sensed(0, np.zeros(2), bearing, rng, None), FreeSpaceParams(), 10.0, unreturned=4.0)
    >>> [bool(near.contains(shapely.Point(-x, 0))) for x in (3.9, 4.0)]  # nothing returned within 4 m
    [True, False]
    >>> end = np.where(bearing <= 0, 2.0, 6.0)  # a wall's end between the rays at 0 and 1 deg, a far wall beyond
    >>> edge = Sensed(0, np.zeros(2), bearing, end, None)
    >>> [bool(contour_bound(edge, FreeSpaceParams(), 10.0, seen_only=s).contains(shapely.Point(3, 0.04)))
    ...  for s in (False, True)]  # 1 m behind the end, between the two rays
    [True, False]
    """
    ok = np.isfinite(s.range) & (s.range > 0)
    if not ok.any():
        return None
    theta = s.bearing
    u = np.column_stack([np.cos(theta), np.sin(theta)])
    radius = np.where(ok, s.range, reach if unreturned is None else min(unreturned, reach))
    # runs of unreturned rays between returned ones (cyclic), bridged when the points are close
    idx = np.flatnonzero(ok)
    nxt = np.roll(idx, -1)
    span = (theta[nxt] - theta[idx]) % (2 * np.pi)
    pts = s.origin + s.range[idx, None] * u[idx]
    chord = pts[np.roll(np.arange(len(idx)), -1)] - pts
    missing = (nxt - idx - 1) % len(theta)  # rays between the two that returned nothing
    bridged = (missing > 0) & (np.hypot(*chord.T) <= params.bridge) & (span < np.pi) & (span > 0)
    if bridge_ok is not None and bridged.any():
        bridged[bridged] = bridge_ok(pts[bridged], pts[bridged] + chord[bridged])
    for k in np.flatnonzero(bridged):
        run = np.arange(idx[k] + 1, idx[k] + 1 + missing[k]) % len(theta)
        a, e = pts[k] - s.origin, chord[k]
        cross = u[run, 0] * e[1] - u[run, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (a[0] * e[1] - a[1] * e[0]) / cross
        radius[run] = np.where(np.isfinite(t) & (t > 0), np.minimum(t, reach), reach)
    radius = np.maximum(radius - params.margin, 0.0)
    # bearings no ray looked at: out to reach
    gap = np.flatnonzero(np.diff(np.append(theta, theta[0] + 2 * np.pi)) > params.max_gap)
    t_all = np.concatenate([theta, theta[gap] + 1e-6, np.append(theta, theta[0] + 2 * np.pi)[gap + 1] - 1e-6])
    r_all = np.concatenate([radius, np.full(2 * len(gap), reach)])
    order = np.argsort(t_all, kind="stable")
    t_all, r_all = t_all[order], r_all[order]
    # one vertex per bearing (to a nanoradian: overlapping snapshots' rays), the nearest: a simple polygon
    angle, first = np.unique(np.round(t_all, 9), return_index=True)
    r_all = np.minimum.reduceat(r_all, first)
    if seen_only:  # a step at the nearer range, a hair short of the farther one's bearing, at every jump
        step = np.diff(np.append(angle, angle[0] + 2 * np.pi))
        r_next = np.roll(r_all, -1)
        jump = _jump(r_all, r_next, step, params)
        # an edge: one surface's run of bearings, then another's (rays alternating between a sunlit pixel and the
        # wall behind it, a camera keeping one a column, are no edge: nothing is hidden between them)
        jump &= ~np.roll(jump, 1) & ~np.roll(jump, -1)
        hair = np.minimum(1e-6, step / 4)
        out, back = jump & (r_all < r_next), jump & (r_all > r_next)
        angle = np.concatenate([angle, angle[out] + step[out] - hair[out], angle[back] + hair[back]])
        r_all = np.concatenate([r_all, r_all[out], r_next[back]])
        order = np.argsort(angle, kind="stable")
        angle, r_all = angle[order], r_all[order]
    bound = shapely.Polygon(s.origin + r_all[:, None] * np.column_stack([np.cos(angle), np.sin(angle)]))
    simple = (r_all > 0).all() and (np.diff(np.append(angle, angle[0] + 2 * np.pi)) < np.pi).all()  # a simple star
    return bound if simple or bound.is_valid else shapely.make_valid(bound)


def shadows(
    origin: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64], reach: float
) -> shapely.Geometry:
    """What lines p-q hide from ``origin``: each line's shadow, out to ``reach`` from the origin.

    >>> shade = shadows(np.zeros(2), np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]]), 10.0)
    >>> shade.contains(shapely.Point(3, 0)), shade.contains(shapely.Point(0.5, 0))
    (True, False)
    """
    a, b = p - origin, q - origin
    da, db = np.hypot(*a.T), np.hypot(*b.T)
    keep = (np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) > 1e-9) & (da > 1e-9) & (db > 1e-9)
    if not keep.any():
        return shapely.Polygon()
    a, b, da, db = a[keep], b[keep], da[keep], db[keep]
    far_a = a * (reach / np.minimum(da, reach))[:, None] * 2
    far_b = b * (reach / np.minimum(db, reach))[:, None] * 2
    rings = origin + np.stack([a, b, far_b, far_a, a], axis=1)
    return shapely.union_all(shapely.make_valid(shapely.polygons(rings)))


def free_space(bm: BeliefMap, params: FreeSpaceParams | None = None) -> shapely.Geometry:
    """The map's free space (module doc): sonar sectors and contour rays of every pose, short of believed lines.

    Made once per version of the map (and ``params``), prepared for queries: the occupancy grid and the
    planner's test of unknown space (:func:`evmap.maps.planner.is_segment_clear`) read the same geometry.
    """
    return _once(_MADE, bm, params or FreeSpaceParams(), _free_space)


_MADE: WeakKeyDictionary[BeliefMap, tuple[int, FreeSpaceParams, Any]] = WeakKeyDictionary()
"""Each map's free space, with the map's version and the parameters it was made for."""

_POINTS: WeakKeyDictionary[BeliefMap, tuple[int, FreeSpaceParams, Any]] = WeakKeyDictionary()
"""Each map's surface points, with the map's version and the parameters they were found with."""


def _once(
    cache: WeakKeyDictionary[BeliefMap, tuple[int, FreeSpaceParams, Any]],
    bm: BeliefMap,
    params: FreeSpaceParams,
    make: Callable[[BeliefMap, FreeSpaceParams], Any],
) -> Any:
    """``make(bm, params)``, made again only when the map's version or the parameters changed."""
    kept = cache.get(bm)
    if kept is None or kept[0] != bm.version or kept[1] != params:
        kept = cache[bm] = (bm.version, params, make(bm, params))
    return kept[2]


def _surfaces(s: Sensed, bm: BeliefMap, margin: float) -> Sensed:
    """The pose's readings less the rays ending on its segments judged noise (sunlit pixels, not surfaces)."""
    store = bm.segments
    noise = np.flatnonzero((store.pose == s.pose_index) & store.eliminated)
    return surface_rays(s, store.p[noise], store.q[noise], margin, on=False)


def _free_space(bm: BeliefMap, params: FreeSpaceParams) -> shapely.Geometry:
    """:func:`free_space`, made anew and prepared."""
    poses = sensed(bm)
    if not poses:
        shapely.prepare(bm.open_space)
        return bm.open_space
    config = bm.config
    believed = lines(bm, params.min_belief)
    p = np.array([ln.p for ln in believed], dtype=float).reshape(-1, 2)
    q = np.array([ln.q for ln in believed], dtype=float).reshape(-1, 2)
    op, oq = object_faces(bm, {s.pose_index: s.origin for s in poses}, params, (p, q))
    p, q = np.concatenate([p, op]), np.concatenate([q, oq])
    tree = shapely.STRtree(shapely.linestrings(np.stack([p, q], axis=1)))
    pieces = []
    for s in poses:
        seen = [ray_fan(s, params)]
        surfaces = _surfaces(s, bm, params.margin)
        if s.sonar is not None:
            sonar = open_space(s.sonar, extract_rcds(s.sonar, config.rcd, primitive=True), config.open_space)
            far = s.sonar.params.max_range + 1.0
            stripe = farthest_returns(s) if s.all_returns else s
            bound = contour_bound(stripe, params, far, unreturned=config.sensors.lsl.max_range, seen_only=True)
            seen.append(sonar if bound is None else shapely.intersection(sonar, bound))
        free = unite(seen)
        if len(p) and not free.is_empty:
            # the pose's free space is star-shaped from its origin (fans of rays and sonar sectors from there):
            # the segment from the origin to a free point in a line's shadow is free and crosses the line, so
            # only the lines that meet the free space shade it
            near = tree.query(free, predicate="intersects")
            xmin, ymin, xmax, ymax = free.bounds
            reach = float(np.hypot(xmax - xmin, ymax - ymin)) + 1.0
            free = shapely.difference(free, shadows(s.origin, p[near], q[near], reach))
        pieces.append(shapely.difference(free, _band(surfaces, params)))
    # snapped to the micrometre: the unions of touching sectors leave cracks of no width that a path crosses
    union = shapely.set_precision(unite(pieces), GRID)
    polygons = [g for g in shapely.get_parts(union) if isinstance(g, shapely.Polygon) and not g.is_empty]
    made = unite(polygons) if polygons else shapely.Polygon()
    shapely.prepare(made)
    return made


def surface_points(bm: BeliefMap, params: FreeSpaceParams | None = None) -> shapely.STRtree:
    """Every point the remembered poses' stripes measured on a surface, in an STRtree made once per map version.

    The rays' ends, less those on segments the pose's judgement called noise (sunlit pixels, not surfaces,
    within ``margin``). A wall the stripe met at a grazing angle may give no line; its points still say that a
    surface is there (:func:`evmap.maps.planner.is_segment_clear` keeps its clearance from them: the free space
    keeps only ``margin`` from them).
    """
    return _once(_POINTS, bm, params or FreeSpaceParams(), _surface_points)


def _surface_points(bm: BeliefMap, params: FreeSpaceParams) -> shapely.STRtree:
    """:func:`surface_points`, found anew."""
    found = [np.zeros((0, 2))]
    for s in sensed(bm):
        found.append(_surfaces(s, bm, params.margin).points)
    return shapely.STRtree(shapely.points(np.concatenate(found)))
