"""Plane geometry: crossings, feet of perpendiculars, ray casts against segments and circles."""

import tracemalloc

import numpy as np
import pytest
import shapely
from hypothesis import assume, example, given
from hypothesis import strategies as st

from evmap.sources import geometry, ray_casting
from evmap.sources.geometry import cross, crossings, perpendicular_feet, point_segment_distances, ray_circle_distances
from evmap.sources.ray_casting import cast_rays

coordinate = st.floats(-5, 5)
point = st.lists(coordinate, min_size=2, max_size=2).map(np.array)


def test_cast_rays_known_answers() -> None:
    p, q = [[1, -1], [2, -1], [-1, 1]], [[1, 1], [2, 1], [1, 1]]
    angles = [0, np.pi / 4, np.pi / 2, np.pi, -np.pi / 4, 0.0]
    ranges, hit = cast_rays([0, 0], angles, p, q, [[-3, 0]], [1.0], 10)
    np.testing.assert_allclose(ranges, [1, np.sqrt(2), 1, 2, np.sqrt(2), 1])
    assert hit.tolist() == [0, 0, 2, 3, 0, 0]  # nearest wins; a ray through an end point hits
    ranges, hit = cast_rays([0, 0], [0], p, q, [[-3, 0]], [1.0], 0.5)
    assert np.isinf(ranges).all() and hit.tolist() == [-1]


@given(
    seg=st.lists(st.floats(-5, 5), min_size=4, max_size=4),
    angle=st.floats(-np.pi, np.pi),
    origin=st.lists(st.floats(-5, 5), min_size=2, max_size=2),
)
def test_cast_rays_agrees_with_shapely(seg: list[float], angle: float, origin: list[float]) -> None:
    a, b = np.array(seg[:2]), np.array(seg[2:])
    assume(np.hypot(*(b - a)) > 1e-3)
    o = np.array(origin)
    ray = shapely.LineString([o, o + 100 * np.array([np.cos(angle), np.sin(angle)])])
    cross = ray.intersection(shapely.LineString([a, b]))
    assume(cross.geom_type in ("Point", "Empty") or cross.is_empty)  # not collinear
    # a ray through an end point (within rounding) may hit or miss
    assume(min(ray.distance(shapely.Point(a)), ray.distance(shapely.Point(b))) > 1e-9)
    ranges, hit = cast_rays(o, [angle], [a], [b], np.zeros((0, 2)), [], 100)
    if cross.is_empty:
        assert hit[0] == -1
    else:
        assume(cross.distance(shapely.Point(o)) > 1e-9)
        assert hit[0] == 0
        assert ranges[0] == pytest.approx(cross.distance(shapely.Point(o)), abs=1e-7)


@given(a=point, b=point, p=point, q=point)
def test_crossings_agree_with_shapely(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> None:
    assume(np.hypot(*(b - a)) > 1e-3 and np.hypot(*(q - p)) > 1e-3)
    t, s = crossings(a, b - a, p, q - p)
    if np.isnan(t):
        assert cross([0.0, 0.0], b - a, q - p) == 0
        return
    np.testing.assert_allclose(a + t * (b - a), p + s * (q - p), atol=1e-6)
    inside = 1e-9 < t < 1 - 1e-9 and 1e-9 < s < 1 - 1e-9
    outside = not (-1e-9 <= t <= 1 + 1e-9 and -1e-9 <= s <= 1 + 1e-9)
    meets = shapely.LineString([a, b]).intersects(shapely.LineString([p, q]))
    if inside:
        assert meets
    nearly_parallel = abs(cross([0.0, 0.0], b - a, q - p)) < 1e-6 * np.hypot(*(b - a)) * np.hypot(*(q - p))
    if outside and not nearly_parallel:  # nearly parallel lines cross far off by round-off, even touching ones
        assert not meets


def test_crossings_parallel_tolerance() -> None:
    t, s = crossings([0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1e-13], parallel=1e-12)
    assert np.isnan(t) and np.isnan(s)
    t, s = crossings([0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1e-13])
    assert t == pytest.approx(-1e13) and s == pytest.approx(-1e13)


@given(xy=point, p=point, q=point)
def test_perpendicular_feet_are_nearest_on_the_line(xy: np.ndarray, p: np.ndarray, q: np.ndarray) -> None:
    assume(np.hypot(*(q - p)) > 1e-3)
    t, foot = perpendicular_feet(xy, p, q)
    np.testing.assert_allclose(foot, p + t * (q - p))
    assert abs(np.dot(xy - foot, q - p)) <= 1e-9 * (1 + np.hypot(*(xy - p)) * np.hypot(*(q - p)))


def test_perpendicular_feet_of_a_point_segment() -> None:
    t, foot = perpendicular_feet([[3.0, 4.0]], [1.0, 1.0], [1.0, 1.0])
    assert t.tolist() == [0.0] and foot.tolist() == [[1.0, 1.0]]


@given(origin=point, angle=st.floats(-np.pi, np.pi), centre=point, radius=st.floats(0.1, 2))
def test_ray_circle_distances_agree_with_shapely(
    origin: np.ndarray, angle: float, centre: np.ndarray, radius: float
) -> None:
    assume(np.hypot(*(centre - origin)) > radius + 1e-3)
    u = np.array([np.cos(angle), np.sin(angle)])
    d = ray_circle_distances(origin, [u], [centre], [radius])
    ray = shapely.LineString([origin, origin + 100 * u])
    gap = ray.distance(shapely.Point(centre))
    assume(abs(gap - radius) > 1e-6)  # not tangent within rounding
    if gap > radius:
        assert d.tolist() == [[np.inf]]
    else:
        assert np.hypot(*(origin + d[0, 0] * u - centre)) == pytest.approx(radius, abs=1e-9)


def test_ray_circle_distances_without_circles() -> None:
    assert ray_circle_distances([0.0, 0.0], [[1.0, 0.0]], np.zeros((0, 2)), []).shape == (1, 0)


def dense_cast_rays(origin, angles, p, q, centers, radii, max_range):
    """cast_rays as it was: every ray against every surface at once (the reference; issue 16)."""
    o = np.asarray(origin, dtype=float)
    angles = np.asarray(angles, dtype=float)
    u = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    p, q = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)
    t, s = crossings(o, u[:, None], p, q - p)
    t_segments = np.where((t > 0) & (s >= 0) & (s <= 1), t, np.inf)
    t_all = np.concatenate([t_segments, ray_circle_distances(o, u, centers, radii)], axis=1)
    if t_all.shape[1] == 0:
        return np.full(len(angles), np.inf), np.full(len(angles), -1, dtype=np.intp)
    hit = np.argmin(t_all, axis=1)
    ranges = t_all[np.arange(len(angles)), hit]
    found = ranges <= max_range
    return np.where(found, ranges, np.inf), np.where(found, hit, -1).astype(np.intp)


@pytest.mark.parametrize("seed", range(30))
def test_cast_rays_gives_the_dense_computations_hits(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Random polylines (sharing end points, some axis-aligned), circles and rays, some through end points
    and along walls, far from (0, 0) too, in chunks of any size: the same ranges and hits as every ray
    against every surface."""
    rng = np.random.default_rng([16, 7, seed])
    if seed % 3 == 0:
        monkeypatch.setattr(ray_casting, "PAIRS", 1 + seed)
    shift = rng.choice([0.0, 1e6, -5e6])
    steps = rng.normal(0, 2, (int(rng.integers(2, 60)), 2))
    steps[::3, 0] = 0.0  # some walls along an axis
    points = np.cumsum(steps, axis=0)
    p, q = points[:-1] + shift, points[1:] + shift
    keep = np.hypot(*(q - p).T) > 0
    p, q = p[keep], q[keep]
    k = int(rng.integers(0, 6))
    centers, radii = rng.normal(0, 4, (k, 2)) + shift, rng.uniform(0.05, 1.0, k)
    origin = rng.normal(0, 3, 2) + shift
    assume_outside = np.hypot(*(centers - origin).T) > radii
    centers, radii = centers[assume_outside], radii[assume_outside]
    to_ends = np.concatenate([p, q]) - origin
    angles = np.concatenate(
        [rng.uniform(-np.pi, np.pi, 200), np.arctan2(to_ends[:, 1], to_ends[:, 0]), np.linspace(0, 2 * np.pi, 181)]
    )
    max_range = float(rng.choice([3.0, 10.0, 100.0]))
    got = cast_rays(origin, angles, p, q, centers, radii, max_range)
    want = dense_cast_rays(origin, angles, p, q, centers, radii, max_range)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])


def test_cast_rays_memory_grows_with_rays_plus_surfaces() -> None:
    """200,000 rays (a detector's patches) against 5,000 segments of a ring around the origin: the dense
    computation held several (rays x segments) arrays, 8 GB each; the bearing intervals pair each ray with
    the few segments around its bearing."""
    n = 5000
    a = 2 * np.pi * np.arange(n + 1) / n
    ring = 5 * np.stack([np.cos(a), np.sin(a)], axis=1)
    angles = np.linspace(-np.pi, np.pi, 200_000, endpoint=False)
    tracemalloc.start()
    try:
        ranges, hit = cast_rays([0.5, 0.2], angles, ring[:-1], ring[1:], np.zeros((0, 2)), [], 10)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert np.all(hit >= 0) and np.all((ranges > 4.4) & (ranges < 5.6))
    assert peak < 300e6


@given(st.integers(0, 2**32 - 1), st.integers(0, 80), st.integers(0, 30))
def test_near_segments_is_the_dense_test_to_the_last_bit(seed: int, k: int, n: int) -> None:
    """The spatial index gives what the (K, N) distance matrix gives, tolerances one per point or one for all,
    points exactly at a tolerance and segments of no length included."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-3, 3, (k, 2))
    p = rng.uniform(-3, 3, (n, 2))
    q = p + rng.normal(0, 1, (n, 2)) * rng.choice([0.0, 1e-7, 1.0], (n, 1))
    tol = rng.uniform(0, 0.6, k) if seed % 2 else 0.25
    if k and n:  # a point exactly at its tolerance from a segment's end
        xy[0] = q[0] + [0.0, tol[0] if seed % 2 else tol]
    dense = point_segment_distances(xy[:, None], p[None], q[None]).min(axis=1) <= tol if k and n else np.zeros(k, bool)
    assert np.array_equal(geometry.near_segments(xy, p, q, tol), dense)
    index = shapely.STRtree(shapely.points(xy))  # a caller's index of the points: the same answer
    assert np.array_equal(geometry.near_segments(xy, p, q, tol, index), dense)


@given(st.integers(0, 2**32 - 1), st.integers(1, 400), st.integers(0, 50))
def test_nearest_angles_is_the_dense_search(seed: int, n: int, k: int) -> None:
    """Around the circle, angles in any order and of any turn, as the (K, N) matrix of circular gaps finds them."""
    rng = np.random.default_rng(seed)
    angles = rng.uniform(-4 * np.pi, 4 * np.pi, n)
    bearings = rng.uniform(-4 * np.pi, 4 * np.pi, k)
    got = geometry.nearest_angles(angles, bearings)
    gap = np.abs(np.angle(np.exp(1j * (bearings[:, None] - angles[None]))))
    assert np.array_equal(gap[np.arange(k), got], gap.min(axis=1))


@given(st.floats(-1e3, 1e3, allow_nan=False))
@example(float(np.nextafter(-np.pi, -4)))  # the remainder rounds to 2 pi
def test_wrapped_is_the_same_direction_in_minus_pi_to_pi(angle: float) -> None:
    got = float(geometry.wrapped(angle))
    assert -np.pi <= got < np.pi
    assert np.hypot(np.cos(got) - np.cos(angle), np.sin(got) - np.sin(angle)) < 1e-9
    if -np.pi <= angle < np.pi:
        assert got == angle  # to the bit
