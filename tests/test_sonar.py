"""The sonar model: known geometries, scan validation, and properties of the noise-free model."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
import shapely
from hypothesis import assume, given
from hypothesis import strategies as st

from evmap.sources.params import RcdParams, SonarParams
from evmap.sources.rcd import extract_rcds
from evmap.sources.readings import LslSegments, ScanError, SonarScan
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.surfaces import Surfaces

PARAMS = SonarParams()


def make_surfaces(walls, cylinders=()) -> Surfaces:
    """Surfaces from ``(id, points, reflective)`` polylines (coinciding points are one vertex)
    and ``(id, center, radius)`` reflective cylinders. Segment k of wall W is "W:k"; vertices "v<i>"."""
    pts, segs, ids, refl = [], [], [], []
    for wall_id, points, reflective in walls:
        for k in range(len(points) - 1):
            segs.append((len(pts), len(pts) + 1))
            pts += [points[k], points[k + 1]]
            ids.append(f"{wall_id}:{k}")
            refl.append(reflective)
    vertices, inverse = np.unique(np.round(np.array(pts, float).reshape(-1, 2), 9), axis=0, return_inverse=True)
    k = len(cylinders)
    return Surfaces(
        vertices=vertices,
        vertex_ids=np.array([f"v{i}" for i in range(len(vertices))], dtype=str),
        segments=inverse.reshape(-1)[np.array(segs, dtype=np.intp).reshape(-1, 2)],
        segment_ids=np.array(ids, dtype=str),
        lsl_opaque=np.ones(len(segs), bool),
        sonar_reflective=np.array(refl, bool),
        cylinder_centers=np.array([c[1] for c in cylinders], float).reshape(-1, 2),
        cylinder_radii=np.array([c[2] for c in cylinders], float),
        cylinder_ids=np.array([c[0] for c in cylinders], dtype=str),
        cylinder_lsl_opaque=np.ones(k, bool),
        cylinder_sonar_reflective=np.ones(k, bool),
    )


SQUARE = make_surfaces([("room", [(0, 0), (4, 0), (4, 4), (0, 4), (0, 0)], True)])


# ---------------------------------------------------------------- known geometry


def test_square_room_four_wall_rcds_of_type_one_and_four_corner_rcds():
    scan = simulate_scan(SQUARE, (2.0, 2.0, 0.3), PARAMS)
    rcds = extract_rcds(scan, RcdParams())
    direct = rcds.select(rcds.order == 1)
    walls = direct.select(np.char.startswith(direct.target, "room:"))
    corners = direct.select(np.char.startswith(direct.target, "v"))
    assert sorted(walls.target.tolist()) == ["room:0", "room:1", "room:2", "room:3"]
    assert walls.type.tolist() == [1, 1, 1, 1]
    np.testing.assert_allclose(walls.range, 2.0)
    np.testing.assert_allclose(np.degrees(walls.width), 25.0)  # full visibility angle at 2 m
    assert sorted(corners.target.tolist()) == ["v0", "v1", "v2", "v3"]
    np.testing.assert_allclose(corners.range, np.hypot(2, 2))
    # the rest are double bounces (Type IV: long jumps) and max-range gaps
    rest = rcds.select(rcds.order != 1)
    assert len(rest) and set(rest.type.tolist()) == {4}


def test_wall_is_seen_only_near_normal_incidence():
    wall = make_surfaces([("w", [(1.5, -20), (1.5, 20)], True)])
    scan = simulate_scan(wall, (0.0, 0.0, 0.0), PARAMS)
    seen = np.flatnonzero(scan.order == 1)
    off_axis = np.degrees(np.angle(np.exp(1j * scan.angles[seen])))
    assert np.all(np.abs(off_axis) <= PARAMS.beam_width_deg / 2)
    np.testing.assert_allclose(scan.ranges[seen], 1.5)
    assert len(seen) == 25
    assert np.all(scan.ranges[scan.order == 0] == PARAMS.max_range)


def test_far_and_weak_targets_give_narrower_regions():
    def width(surfaces, x):
        scan = simulate_scan(surfaces, (0.0, 0.0, 0.0), PARAMS, max_order=1)
        return int(np.sum(np.isclose(scan.ranges, x)))

    assert width(make_surfaces([("w", [(1, -9), (1, 9)], True)]), 1) == 25
    assert 0 < width(make_surfaces([("w", [(8, -9), (8, 9)], True)]), 8) < 25
    # a free end point 1 m away: a weak edge, narrower than a wall at the same range
    edge = width(make_surfaces([("w", [(1, 0), (3, 0)], True)]), 1)
    assert 0 < edge < 25


def test_glass_wall_is_seen_and_absorbing_wall_gives_max_range_and_occludes():
    glass = make_surfaces([("glass", [(2, -3), (2, 3)], True)])
    scan = simulate_scan(glass, (0.0, 0.0, 0.0), PARAMS)
    assert scan.target[0] == "glass:0" and scan.ranges[0] == pytest.approx(2.0)

    foam_before_wall = make_surfaces([("foam", [(1, -3), (1, 3)], False), ("wall", [(2, -3), (2, 3)], True)])
    scan = simulate_scan(foam_before_wall, (0.0, 0.0, 0.0), PARAMS)
    assert np.all(scan.ranges == PARAMS.max_range)
    assert np.all(scan.order == 0) and np.all(scan.target == "")


def test_mirror_image_double_bounce_gives_the_predicted_long_range():
    # Wall A on y = 1 (x from 1 to 5; its foot (0, 1) is off the segment: no direct echo),
    # a pillar at (3, 0). The sensor's image in A is (0, 2): the path crosses A at (1.5, 1).
    world = make_surfaces([("A", [(1, 1), (5, 1)], True)], [("pillar", (3.0, 0.0), 0.2)])
    scan = simulate_scan(world, (0.0, 0.0, 0.0), PARAMS)
    bounce = scan.order == 2
    assert np.all(scan.target[bounce] == "A:0")
    np.testing.assert_allclose(scan.ranges[bounce], np.hypot(3, 2) - 0.2)
    axis = np.degrees(scan.angles[bounce])
    assert axis.min() <= np.degrees(np.arctan2(1, 1.5)) <= axis.max()
    pillar = scan.target == "pillar"
    assert np.all(scan.order[pillar] == 1) and np.allclose(scan.ranges[pillar], 2.8)
    assert not np.any(simulate_scan(world, (0.0, 0.0, 0.0), PARAMS, max_order=1).order == 2)


def test_blocked_double_bounce_is_not_returned():
    # An absorbing screen across the second leg (from (1.5, 1) to the pillar) stops it.
    world = make_surfaces(
        [("A", [(1, 1), (5, 1)], True), ("screen", [(2.2, 0.2), (2.2, 0.9)], False)], [("pillar", (3.0, 0.0), 0.2)]
    )
    scan = simulate_scan(world, (0.0, 0.0, 0.0), PARAMS)
    assert not np.any(scan.order == 2)


def test_convex_corner_is_weak_and_concave_corner_strong():
    # The same right-angle corner at (1, 1) seen from inside its wedge and from outside it.
    corner = make_surfaces([("c", [(1, 4), (1, 1), (4, 1)], True)])
    inside = simulate_scan(corner, (3.0, 3.0, 0.0), PARAMS, max_order=1)
    outside = simulate_scan(corner, (-1.0, -1.0, 0.0), PARAMS, max_order=1)
    r = np.hypot(2, 2)
    n_in = int(np.sum(np.isclose(inside.ranges, r) & (inside.target == "v0")))
    n_out = int(np.sum(np.isclose(outside.ranges, r) & (outside.target == "v0")))
    assert n_in == 25 and 0 < n_out < n_in


def test_cylinder_is_always_seen_at_normal_incidence():
    scan = simulate_scan(make_surfaces([], [("p", (2.0, 1.0), 0.3)]), (0.0, 0.0, 1.0), PARAMS)
    assert set(scan.target[scan.order == 1].tolist()) == {"p"}
    np.testing.assert_allclose(scan.ranges[scan.order == 1], np.hypot(2, 1) - 0.3)


def test_empty_world_gives_max_range_everywhere():
    scan = simulate_scan(make_surfaces([]), (0.0, 0.0, 0.0), PARAMS)
    assert len(scan) == 360 and np.all(scan.ranges == PARAMS.max_range) and np.all(scan.order == 0)


def test_noise_is_seeded_gaussian_and_leaves_max_range_exact():
    wall = make_surfaces([("w", [(2, -50), (2, 50)], True)])
    params = SonarParams(range_noise=0.01, step_deg=0.2)
    a = simulate_scan(wall, (0.0, 0.0, 0.0), params, rng=np.random.default_rng([7, 0, 1]))
    b = simulate_scan(wall, (0.0, 0.0, 0.0), params, rng=np.random.default_rng([7, 0, 1]))
    np.testing.assert_array_equal(a.ranges, b.ranges)
    echo = a.order == 1
    err = a.ranges[echo] - 2.0
    assert 0.006 < err.std() < 0.014 and abs(err.mean()) < 0.004
    assert np.all(a.ranges[a.order == 0] == params.max_range)


def test_step_and_start_angle():
    scan = simulate_scan(SQUARE, (1.0, 1.0, 0.5), SonarParams(step_deg=0.7))
    assert len(scan) == round(360 / 0.7)
    assert scan.angles[0] == 0.5 and scan.closed
    np.testing.assert_allclose(np.diff(scan.angles), 2 * np.pi / len(scan))


@pytest.mark.parametrize("pose", [(0, 0), (0, 0, np.nan), (np.inf, 0, 0)])
def test_bad_pose_is_refused(pose):
    with pytest.raises(ScanError, match="pose"):
        simulate_scan(SQUARE, pose, PARAMS)


def test_bad_max_order_is_refused():
    with pytest.raises(ValueError, match="max_order"):
        simulate_scan(SQUARE, (1, 1, 0), PARAMS, max_order=3)


# ---------------------------------------------------------------- validation of raw readings


def test_from_readings_validation():
    p = PARAMS
    with pytest.raises(ScanError, match=r"ranges\[1\] = nan"):
        SonarScan.from_readings([0, 1], [1, np.nan], p)
    with pytest.raises(ScanError, match=r"ranges\[0\] = -0.5"):
        SonarScan.from_readings([0, 1], [-0.5, 1], p)
    with pytest.raises(ScanError, match=r"angles\[2\].*strictly increasing"):
        SonarScan.from_readings([0, 1, 0.5], [1, 1, 1], p)
    with pytest.raises(ScanError, match=r"angles\[1\].*strictly increasing"):
        SonarScan.from_readings([0, 0], [1, 1], p)
    with pytest.raises(ScanError, match=r"angles\[0\] = nan is not finite"):
        SonarScan.from_readings([np.nan], [1], p)
    with pytest.raises(ScanError, match="full turn"):
        SonarScan.from_readings([0, 2 * np.pi], [1, 1], p)
    with pytest.raises(ScanError, match="ranges has 1 entries but angles has 2"):
        SonarScan.from_readings([0, 1], [1], p)


def test_from_readings_clips_beyond_max_range_and_marks_no_echo():
    scan = SonarScan.from_readings([0, 1, 2], [1.0, 10.0, 12.0], PARAMS)
    assert scan.ranges.tolist() == [1.0, 10.0, 10.0]
    assert scan.order.tolist() == [-1, 0, 0]
    with pytest.raises(ValueError):
        scan.ranges[0] = 3.0  # read-only


def test_a_reading_in_millimetres_is_refused_not_clipped():
    with pytest.raises(ScanError, match=r"ranges\[1\] = 3000: more than 1.5 times max_range \(10 m\)"):
        SonarScan.from_readings([0, 1], [1.0, 3000.0], PARAMS)


def test_lsl_segments_refuse_non_finite_far_and_unknown_truth():
    one = {"snapshot": np.zeros(1, int), "source": np.array([""]), "pose": np.zeros(1, int)}
    with pytest.raises(ScanError, match=r"p\[0\].*finite"):
        LslSegments(np.array([[np.nan, 0.0]]), np.array([[1.0, 0.0]]), np.array(["real"]), **one)
    with pytest.raises(ScanError, match=r"q\[0\].*beyond 2e\+07 m"):
        LslSegments(np.array([[1.0, 1.0]]), np.array([[-1e300, 1.0]]), np.array(["real"]), **one)
    with pytest.raises(ScanError, match=r"truth\[0\] = 'banana'"):
        LslSegments(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]]), np.array(["banana"]), **one)
    assert len(LslSegments(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]]), np.array([""]), **one)) == 1


def test_empty_and_single_reading_scans():
    empty = SonarScan.from_readings([], [], PARAMS)
    assert len(empty) == 0 and not empty.closed
    one = SonarScan.from_readings([0.2], [3.0], PARAMS)
    assert len(one) == 1 and one.step == pytest.approx(np.radians(PARAMS.step_deg))


# ---------------------------------------------------------------- properties (noise-free)

coord = st.floats(-6, 6, allow_nan=False)


@st.composite
def worlds(draw):
    """A few random walls (some absorbing, some joined at corners) and pillars, and a free pose."""
    walls = []
    for i in range(draw(st.integers(1, 5))):
        n = draw(st.integers(2, 4))
        pts = [(draw(coord), draw(coord)) for _ in range(n)]
        walls.append((f"w{i}", pts, draw(st.booleans()) or i == 0))
    cylinders = [
        (f"c{i}", (draw(coord), draw(coord)), draw(st.floats(0.05, 0.5))) for i in range(draw(st.integers(0, 2)))
    ]
    pose = (draw(coord), draw(coord), draw(st.floats(-np.pi, np.pi)))
    # keep the sensor off the walls and outside the pillars, and segments non-degenerate
    geoms = [shapely.LineString(pts) for _, pts, _ in walls]
    for _, pts, _ in walls:
        for a, b in pairwise(pts):
            assume(np.hypot(a[0] - b[0], a[1] - b[1]) >= 0.05)
    # no two surfaces overlap: coinciding surfaces leave the first echo to round-off
    pieces = [shapely.LineString([a, b]) for _, pts, _ in walls for a, b in pairwise(pts)]
    assume(all(x.intersection(y.buffer(1e-6)).length < 1e-3 for i, x in enumerate(pieces) for y in pieces[:i]))
    discs = [shapely.Point(c).buffer(r) for _, c, r in cylinders]
    assume(not any(d.intersects(g) for d in discs for g in geoms))
    assume(not any(x.intersects(y) for i, x in enumerate(discs) for y in discs[:i]))
    sensor = shapely.Point(pose[:2])
    assume(all(g.distance(sensor) >= 0.05 for g in geoms))
    # nor on a wall's line: seen edge-on, which side of it the sensor is on would be round-off
    for a, b in (pair for _, pts, _ in walls for pair in pairwise(pts)):
        cross = (b[0] - a[0]) * (pose[1] - a[1]) - (b[1] - a[1]) * (pose[0] - a[0])
        assume(abs(cross) / np.hypot(b[0] - a[0], b[1] - a[1]) >= 1e-3)
    assume(all(np.hypot(pose[0] - c[0], pose[1] - c[1]) >= r + 0.05 for _, c, r in cylinders))
    return make_surfaces(walls, cylinders), np.array(pose)


def _cone(pose, axis, half, radius):
    t = np.linspace(axis - half, axis + half, 200)
    return shapely.Polygon(np.vstack([pose[:2], pose[:2] + radius * np.column_stack([np.cos(t), np.sin(t)])]))


@given(worlds())
def test_no_reading_is_shorter_than_the_nearest_surface_in_its_cone(world):
    surfaces, pose = world
    scan = simulate_scan(surfaces, pose, PARAMS)
    lines = [shapely.LineString([p, q]) for p, q in zip(surfaces.p, surfaces.q)]
    circles = zip(surfaces.cylinder_centers, surfaces.cylinder_radii)
    lines += [shapely.Point(c).buffer(r, quad_segs=64).exterior for c, r in circles]
    everything = shapely.union_all(lines)
    sensor = shapely.Point(pose[:2])
    half = np.radians(PARAMS.beam_width_deg) / 2
    for j in np.flatnonzero(scan.order > 0):
        seen = everything.intersection(_cone(pose, scan.angles[j], half, 2 * PARAMS.max_range))
        assert not seen.is_empty
        assert scan.ranges[j] >= seen.distance(sensor) - 1e-3 * (1 + scan.ranges[j])


def _transform(surfaces: Surfaces, angle: float, shift) -> Surfaces:
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return Surfaces(
        vertices=surfaces.vertices @ rot.T + shift,
        vertex_ids=surfaces.vertex_ids,
        segments=surfaces.segments,
        segment_ids=surfaces.segment_ids,
        lsl_opaque=surfaces.lsl_opaque,
        sonar_reflective=surfaces.sonar_reflective,
        cylinder_centers=surfaces.cylinder_centers @ rot.T + shift,
        cylinder_radii=surfaces.cylinder_radii,
        cylinder_ids=surfaces.cylinder_ids,
        cylinder_lsl_opaque=surfaces.cylinder_lsl_opaque,
        cylinder_sonar_reflective=surfaces.cylinder_sonar_reflective,
    )


@given(worlds(), st.floats(-np.pi, np.pi), st.tuples(st.floats(-50, 50), st.floats(-50, 50)))
def test_moving_world_and_robot_together_changes_nothing(world, angle, shift):
    surfaces, pose = world
    moved_pose = np.r_[
        np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]) @ pose[:2] + shift, pose[2] + angle
    ]
    a = simulate_scan(surfaces, pose, PARAMS)
    b = simulate_scan(_transform(surfaces, angle, np.array(shift)), moved_pose, PARAMS)
    same = np.isclose(a.ranges, b.ranges, atol=1e-6) & (a.target == b.target) & (a.order == b.order)
    # readings can differ only where an echo sits on a detection threshold (round-off)
    assert same.mean() >= 0.97
    if same.all():
        ra, rb = extract_rcds(a, RcdParams(), primitive=True), extract_rcds(b, RcdParams(), primitive=True)
        assert ra.start.tolist() == rb.start.tolist() and ra.type.tolist() == rb.type.tolist()
        np.testing.assert_allclose(ra.range, rb.range, atol=1e-6)
