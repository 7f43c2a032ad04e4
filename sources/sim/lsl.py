"""The laser structured-light (LSL) stripe sensor: stripe points, line segments, sunlight phantoms.

Paper, section II.B: a horizontal laser stripe seen by a camera of about 27 deg
field of view on a pan unit; 15 snapshots at 24 deg steps cover the full circle.
The model, per snapshot ``k`` (centred on heading + ``k * step_deg``):

1. Stripe points (:func:`stripe_scan`): rays every ``ray_step_deg`` across the
   field of view hit the nearest LSL-opaque segment or cylinder within
   ``max_range``; transparent surfaces (glass, mirrors) return nothing and let the
   stripe pass. The range gets Gaussian noise of std ``range_noise * range``
   (``max_range`` applies to the true range).
2. Line segments (:func:`evmap.sources.polyline.fit_polylines`): the ordered stripe points are broken
   where a ray returns nothing or consecutive points are more than
   ``break_distance`` apart, then split by iterative end-point fit (a point
   further than ``split_threshold + split_sigmas * sigma`` from its piece's chord,
   sigma the point's range-noise std, splits the piece there). Pieces of fewer
   than ``min_points`` points are dropped (the sensor's own rejection of very
   short segments); each other piece is fitted by total least squares and clipped
   to its extreme points. A long wall thus arrives as several short, overlapping
   segments, one or more per snapshot, as in the paper's Fig. 4.
3. Sunlight phantoms (:func:`observe_lsl`, ``docs/SCENARIO.md``): a region
   whose centroid is within ``max_range`` of the pose and in sight (the line to
   it crosses no LSL-opaque surface) adds its ``lines`` phantom segments, drawn
   anew for the pose and delivered as they are. Each is assigned the snapshot
   whose centre is nearest to its midpoint's bearing.

Randomness: every draw comes from ``numpy.random.default_rng([seed, pose_index,
STREAM, ...])`` with the scenario's seed and a stream number per use
(:data:`LSL_NOISE_STREAM`, :data:`SUNLIGHT_STREAM`), so a pose's output does not
depend on which other poses or sensors were simulated first.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import crossings, point_segment_distances, wrapped
from evmap.sources.params import LslParams
from evmap.sources.polyline import fit_pieces, piece_members, split_pieces
from evmap.sources.ray_casting import cast_rays
from evmap.sources.readings import LslSegments, StripeScan, concat_segments
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World, visible

__all__ = [
    "LSL_NOISE_STREAM",
    "PHANTOM_BRIGHTNESS_STREAM",
    "PHANTOM_NOISE_STREAM",
    "SUNLIGHT_STREAM",
    "lsl_segments",
    "observe_lsl",
    "observe_lsl_all",
    "observe_stripe",
    "scan_segments",
    "stripe_scan",
]

LSL_NOISE_STREAM = 101
"""Stream number of the LSL range noise: ``default_rng([seed, pose_index, 101])``."""

SUNLIGHT_STREAM = 102
"""Stream number of the sunlight phantoms of region ``r``: ``default_rng([seed, pose_index, 102, r])``."""

PHANTOM_NOISE_STREAM = 103
"""Stream number of the range noise of the phantoms' stripe points: ``default_rng([seed, pose_index, 103])``."""

PHANTOM_BRIGHTNESS_STREAM = 104
"""Stream number of the sunlit patches' brightness (``column_max``): ``default_rng([seed, pose_index, 104])``."""


def stripe_scan(
    surfaces: Surfaces, pose: ArrayLike, params: LslParams, rng: np.random.Generator | None = None
) -> StripeScan:
    """Cast the stripe of every snapshot from ``pose`` (x, y, heading in radians).

    With ``rng`` None the ranges are noise-free. One standard normal is drawn per
    ray, hit or not, so the noise of a ray does not depend on the world.

    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> world = World(parse_scenario('''{version: 1, name: w, robot: {poses: [[0, 0, 0]]},
    ...   world: {walls: [{id: w, points: [[2, -5], [2, 5]]}]}}''', "w.yaml"))
    >>> scan = stripe_scan(world.surfaces(), world.poses[0], LslParams(snapshots=2, step_deg=90))
    >>> scan.ranges.shape, round(float(np.nanmin(scan.ranges)), 4), bool(np.isnan(scan.ranges[1]).all())
    ((2, 136), 2.0, True)
    """
    x, y, heading = np.asarray(pose, dtype=float)
    origin = np.array([x, y])
    half_fov = np.radians(params.fov_deg) / 2
    rays = params.stripe_rays
    centres = heading + np.radians(params.step_deg) * np.arange(params.snapshots)
    angles = centres[:, None] + np.linspace(-half_fov, half_fov, rays)

    # opaque surfaces within range: every snapshot's rays cast at once (cast_rays pairs rays with the surfaces
    # whose bearings they cross)
    n = len(surfaces.segments)
    p, q = surfaces.p, surfaces.q
    segs = np.flatnonzero(surfaces.lsl_opaque & (point_segment_distances(origin, p, q) <= params.max_range))
    centre_distance = np.hypot(*(surfaces.cylinder_centers - origin).T)
    cyls = np.flatnonzero(
        surfaces.cylinder_lsl_opaque & (centre_distance - surfaces.cylinder_radii <= params.max_range)
    )
    r, h = cast_rays(
        origin,
        angles,
        p[segs],
        q[segs],
        surfaces.cylinder_centers[cyls],
        surfaces.cylinder_radii[cyls],
        params.max_range,
    )
    true_ranges = np.where(h >= 0, r, np.nan).reshape(angles.shape)
    hit = np.concatenate([segs, n + cyls, [-1]])[h].reshape(angles.shape)  # h = -1: no hit
    ranges = true_ranges
    if rng is not None:
        ranges = true_ranges * (1 + params.range_noise * rng.standard_normal(angles.shape))
    return StripeScan(origin=origin, angles=angles, ranges=ranges, true_ranges=true_ranges, hit=hit)


def lsl_segments(
    surfaces: Surfaces,
    pose: ArrayLike,
    params: LslParams,
    rng: np.random.Generator | None = None,
    pose_index: int = 0,
) -> LslSegments:
    """Real LSL segments (no sunlight) of one scan of any surfaces from ``pose`` (x, y, heading rad).

    With ``rng`` None the scan is noise-free; ``pose_index`` fills the ``pose`` field.

    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> world = World(parse_scenario('''{version: 1, name: w, robot: {poses: [[0, 0, 0]]},
    ...   world: {walls: [{id: w, points: [[2, -5], [2, 5]]}]}}''', "w.yaml"))
    >>> segs = lsl_segments(world.surfaces(), world.poses[0], LslParams())
    >>> len(segs), segs.source.tolist(), segs.snapshot.tolist()
    (7, ['w', 'w', 'w', 'w', 'w', 'w', 'w'], [0, 1, 2, 3, 12, 13, 14])
    """
    return scan_segments(stripe_scan(surfaces, pose, params, rng), surfaces, params, pose_index)


def scan_segments(scan: StripeScan, surfaces: Surfaces, params: LslParams, pose_index: int = 0) -> LslSegments:
    """The line segments fitted to a stripe scan's points, each labelled with the surface that made most of them."""
    snapshots, rays = scan.ranges.shape
    # snapshots side by side, each followed by a NaN row so that no piece spans two
    points = np.concatenate([scan.points - scan.origin, np.full((snapshots, 1, 2), np.nan)], axis=1)
    sigma = params.range_noise * np.nan_to_num(np.pad(scan.ranges, ((0, 0), (0, 1))))
    hit = np.pad(scan.hit, ((0, 0), (0, 1)), constant_values=-1).ravel()
    points = points.reshape(-1, 2)
    pieces = split_pieces(points, sigma.ravel(), params)
    p, q = fit_pieces(points, pieces)
    # the object that made most of each piece's points
    members, owner, _ = piece_members(pieces)
    ids = np.concatenate([surfaces.segment_ids, surfaces.cylinder_ids]).astype(str)
    pairs, votes = np.unique(owner * len(ids) + hit[members], return_counts=True)
    best = np.lexsort((-votes, pairs // len(ids)))  # by piece, most votes first
    first_of_piece = best[np.searchsorted(pairs[best] // len(ids), np.arange(len(pieces)))]
    n = len(pieces)
    return LslSegments(
        p=p + scan.origin,
        q=q + scan.origin,
        truth=np.full(n, "real", dtype="<U5"),
        snapshot=(pieces[:, 0] // (rays + 1)).astype(np.intp),
        source=ids[pairs[first_of_piece] % len(ids)] if n else np.zeros(0, dtype=str),
        pose=np.full(n, pose_index, dtype=np.intp),
    )


def _phantom_lines(world: World, pose_index: int, params: LslParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The phantom lines of every sunlight region in range and in sight of the pose, drawn anew for it."""
    origin = world.poses[pose_index, :2]
    near = np.hypot(*(world.sunlight_centroids - origin).T) <= params.max_range
    seen = near & visible(world.surfaces(), origin, world.sunlight_centroids)
    ps, qs = [np.zeros((0, 2))], [np.zeros((0, 2))]
    for r in np.flatnonzero(seen):
        p, q = world.sunlight[r].draw_lines(np.random.default_rng([world.seed, pose_index, SUNLIGHT_STREAM, r]))
        ps.append(p)
        qs.append(q)
    return np.concatenate(ps), np.concatenate(qs)


def _phantom_hits(
    scan: StripeScan, p: NDArray[np.float64], q: NDArray[np.float64], snapshot: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """(phantom, ray, true range) of every ray of a phantom's snapshot that meets it nearer than the real stripe."""
    angles = scan.angles[snapshot]  # (P, R)
    u = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    # t: range along the ray; s: place along the phantom; NaN where parallel
    t, s = crossings(scan.origin, u, p[:, None, :], (q - p)[:, None, :], parallel=1e-12)
    behind = scan.true_ranges[snapshot]
    ok = (t > 0) & (s >= 0) & (s <= 1) & ~(t >= behind)
    phantom, ray = np.nonzero(ok)
    return phantom, ray, t[phantom, ray]


def _brightest_per_column(column: NDArray[np.intp], brightness: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(H,) whether each hit is the brightest of its column's (ties: the first), in the hits' order."""
    order = np.lexsort((-brightness, column))
    first = np.ones(len(order), dtype=bool)
    first[1:] = column[order][1:] != column[order][:-1]
    keep = np.zeros(len(order), dtype=bool)
    keep[order[first]] = True
    return keep


def observe_stripe(world: World, pose_index: int, params: LslParams) -> tuple[LslSegments, NDArray[np.float64]]:
    """All LSL segments seen from one of the world's poses (real ones, then sunlight phantoms) and the stripe's rays.

    A sunlit patch is seen by the camera like the stripe: each phantom line
    (:class:`~evmap.sources.sim.sunlight.Sunlight`) gives a point on every ray of
    its snapshot (the one whose centre is nearest to its midpoint's bearing) that
    meets it nearer than the real stripe, triangulated with the same range noise,
    and its segment is fitted to those points as a wall's is. With the scenario's
    ``sensors.lsl.detector`` ``threshold`` the real stripe behind the patch is seen
    too; with ``column_max`` the camera keeps one point a column in place of the
    real stripe, the brightest patch's of those the ray meets (each phantom line
    has a brightness, uniform in [0, 1) and drawn anew for the pose), and the real
    segments are fitted to what is left. A phantom met by fewer than two rays (or,
    with ``column_max``, keeping fewer than two points) keeps the line it was drawn as.

    Returns the segments and the rays, (K, 2): the world bearing (rad) and the
    measured range (m; NaN: no return) of every stripe point the camera kept.

    >>> from evmap.sources.sim.scenario import default_scenario
    >>> segs, rays = observe_stripe(World(default_scenario()), 0, LslParams())
    >>> int((segs.truth == "noise").sum()), rays.shape[1], bool(np.isfinite(rays[:, 1]).any())
    (28, 2, True)
    """
    surfaces = world.surfaces()
    pose = world.poses[pose_index]
    rng = np.random.default_rng([world.seed, pose_index, LSL_NOISE_STREAM])
    scan = stripe_scan(surfaces, pose, params, rng)
    p, q = _phantom_lines(world, pose_index, params)
    middle = (p + q) / 2 - scan.origin
    bearing = np.arctan2(middle[:, 1], middle[:, 0])
    snapshot = np.abs(wrapped(bearing[:, None] - scan.angles.mean(axis=1))).argmin(axis=1).astype(np.intp)
    phantom, ray, true_range = _phantom_hits(scan, p, q, snapshot)
    noise = np.random.default_rng([world.seed, pose_index, PHANTOM_NOISE_STREAM]).standard_normal(len(ray))
    column_max = world.scenario.sensors.lsl.detector == "column_max"
    if column_max:  # one pixel a column: of the sunlit patches a ray meets, the camera keeps the brightest
        brightness = np.random.default_rng([world.seed, pose_index, PHANTOM_BRIGHTNESS_STREAM]).random(len(p))
        top = _brightest_per_column(snapshot[phantom] * scan.angles.shape[1] + ray, brightness[phantom])
        phantom, ray, true_range, noise = phantom[top], ray[top], true_range[top], noise[top]
    measured = true_range * (1 + params.range_noise * noise)
    angle = scan.angles[snapshot[phantom], ray]
    points = scan.origin + measured[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    count = np.bincount(phantom, minlength=len(p))
    fitted = np.flatnonzero(count >= 2)
    starts = np.cumsum(count) - count  # phantom hits come grouped by phantom (np.nonzero order)
    fp, fq = fit_pieces(points, np.column_stack([starts[fitted], starts[fitted] + count[fitted] - 1]))
    p, q = p.copy(), q.copy()
    p[fitted], q[fitted] = fp, fq
    replaced = np.zeros(scan.ranges.shape, dtype=bool)
    if column_max:  # the brightest pixel of a column is the sunlit one
        replaced[snapshot[phantom], ray] = True
        scan = StripeScan(scan.origin, scan.angles, np.where(replaced, np.nan, scan.ranges), scan.true_ranges, scan.hit)
    real = scan_segments(scan, surfaces, params, pose_index)
    phantoms = LslSegments(
        p=p,
        q=q,
        truth=np.full(len(p), "noise", dtype="<U5"),
        snapshot=snapshot,
        source=np.full(len(p), "", dtype=str),
        pose=np.full(len(p), pose_index, dtype=np.intp),
    )
    # a column where the camera kept a sunlit pixel and nothing else has that point only
    kept = ~replaced
    kept[snapshot[phantom], ray] &= ~np.isnan(scan.ranges[snapshot[phantom], ray])
    rays = np.concatenate([np.column_stack([scan.angles[kept], scan.ranges[kept]]), np.column_stack([angle, measured])])
    return concat_segments([real, phantoms]), rays


def observe_lsl(world: World, pose_index: int, params: LslParams) -> LslSegments:
    """All LSL segments seen from one of the world's poses: real ones, then sunlight phantoms (:func:`observe_stripe`).

    >>> from evmap.sources.sim.scenario import default_scenario
    >>> segs = observe_lsl(World(default_scenario()), 0, LslParams())
    >>> int((segs.truth == "noise").sum()), bool((segs.length[segs.truth == "noise"] <= 0.36).all())
    (28, True)
    """
    return observe_stripe(world, pose_index, params)[0]


def observe_lsl_all(world: World, params: LslParams) -> LslSegments:
    """The LSL segments of every pose of the world, concatenated (``pose`` tells them apart)."""
    return concat_segments([observe_lsl(world, i, params) for i in range(len(world.poses))])
