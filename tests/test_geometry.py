"""Plane geometry: crossings, feet of perpendiculars, ray casts against segments and circles."""

import numpy as np
import pytest
import shapely
from hypothesis import assume, given
from hypothesis import strategies as st

from evmap.sources.geometry import cast_rays, cross, crossings, perpendicular_feet, ray_circle_distances

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
    if outside:
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
