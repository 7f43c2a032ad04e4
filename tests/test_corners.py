"""Corners from end points: known geometry, shapes and properties."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.corners import find_corners
from evmap.maps.merging import related_pairs
from evmap.sources.params import CornerParams, MergeParams


def _polar(start, angle_deg, length):
    a = np.radians(angle_deg)
    return np.asarray(start, dtype=float) + length * np.array([np.cos(a), np.sin(a)])


def test_an_l_shape_meets_at_the_midpoint_of_the_two_ends():
    p = np.array([[2.0, 0.01], [0.0, 0.03]])
    q = np.array([[0.02, 0.0], [0.0, 2.0]])
    c = find_corners(p, q)
    np.testing.assert_allclose(c.xy, [[0.01, 0.015]])
    assert c.ends[0].tolist() == [[0, 1], [1, 0]]
    np.testing.assert_allclose([c.q[0], c.p[1]], [[0.01, 0.015]] * 2)
    np.testing.assert_array_equal([c.p[0], c.q[1]], [p[0], q[1]])  # free ends stay
    assert c.corner_of.tolist() == [[-1, 0], [0, -1]]
    assert c.free.tolist() == [[0, 0], [1, 1]]
    assert c.shape.tolist() == ["unknown"]


def _square_room():
    """Four walls of the unit square, end points a little off the corners."""
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    jitter = np.array([[0.01, -0.01], [-0.015, 0.0], [0.0, 0.02], [0.01, 0.01]])
    p = corners + jitter
    q = np.roll(corners, -1, axis=0) - jitter[[1, 2, 3, 0]] / 2
    return p, q


def test_a_square_room_has_four_concave_corners_from_inside():
    p, q = _square_room()
    c = find_corners(p, q, viewpoint=(0.4, 0.6))
    assert len(c.xy) == 4
    np.testing.assert_allclose(np.sort(np.round(c.xy)), np.sort([[0, 0], [1, 0], [1, 1], [0, 1]]), atol=0.02)
    assert c.shape.tolist() == ["concave"] * 4
    assert c.free.shape == (0, 2)
    # Each snapped wall still runs from corner to corner.
    assert np.isin(np.concatenate([c.p, c.q]).round(12), c.xy.round(12)).all()


def test_a_square_seen_from_outside():
    p, q = _square_room()
    c = find_corners(p, q, viewpoint=(-1.0, -2.0))
    near_far = np.round(c.xy).tolist()
    shapes = dict(zip(map(tuple, near_far), c.shape.tolist()))
    # The three corners in view are convex; the far one, hidden behind the walls,
    # turns its inner side toward the robot (occlusion is not considered).
    assert shapes == {(0, 0): "convex", (1, 0): "convex", (0, 1): "convex", (1, 1): "concave"}


def test_each_corner_is_seen_from_the_nearest_of_many_viewpoints():
    """Robots in the room and beside each corner outside it: each corner has the shape its nearest robot sees."""
    p, q = _square_room()
    robots = np.array([[0.4, 0.6], [-0.5, -0.5], [1.5, 1.5]])  # inside; outside (0, 0); outside (1, 1)
    c = find_corners(p, q, viewpoint=robots)
    shapes = dict(zip(map(tuple, np.round(c.xy).tolist()), c.shape.tolist()))
    assert shapes == {(0, 0): "convex", (1, 0): "concave", (1, 1): "convex", (0, 1): "concave"}
    for k, xy in enumerate(c.xy):
        nearest = robots[np.argmin(np.hypot(*(robots - xy).T))]
        assert find_corners(p, q, viewpoint=nearest).shape[k] == c.shape[k]
    assert find_corners([[0, 0]], [[1, 0]], viewpoint=robots).shape.shape == (0,)  # no corner to see
    with pytest.raises(ValueError, match="viewpoint"):
        find_corners(p, q, viewpoint=np.zeros((0, 2)))
    with pytest.raises(ValueError, match="viewpoint"):
        find_corners(p, q, viewpoint=[[0, 0], [np.nan, 1]])


def test_a_pillar_is_convex_from_all_round_and_concave_from_nowhere():
    p, q = _square_room()
    square = find_corners(p, q)
    for angle in np.linspace(0, 2 * np.pi, 13):
        robot = 0.5 + 3 * np.array([np.cos(angle), np.sin(angle)])
        shapes = find_corners(p, q, viewpoint=robot).shape
        visible = np.sum((square.xy - 0.5) * (robot - 0.5), axis=1) > -1e-9
        assert (shapes[visible] == "convex").all()


@pytest.mark.parametrize("angle", [0.0, 5.0, 9.0, 180.0, 175.0])
def test_nearly_parallel_lines_with_close_ends_make_no_corner(angle):
    p = [[0, 0], [1.02, 0]]
    q = [[1, 0], _polar([1.02, 0], angle, 1)]
    c = find_corners(p, q)
    assert len(c.xy) == 0 and len(c.free) == 4


@pytest.mark.parametrize("angle", [10.0, 11.0, 90.0, 170.0])
def test_lines_far_enough_from_parallel_make_a_corner(angle):
    c = find_corners([[0, 0], [1.02, 0]], [[1, 0], _polar([1.02, 0], angle, 1)])
    np.testing.assert_allclose(c.xy, [[1.01, 0]])


def test_a_t_junction_makes_no_corner():
    c = find_corners([[0, 0], [1, 0.01]], [[2, 0], [1, 1]], viewpoint=(0.5, 0.5))
    assert len(c.xy) == 0 and c.shape.shape == (0,)


def test_ends_farther_than_the_tolerance_make_no_corner():
    assert len(find_corners([[0, 0], [1.06, 0]], [[1, 0], [1.06, 1]]).xy) == 0
    assert len(find_corners([[0, 0], [1.06, 0]], [[1, 0], [1.06, 1]], CornerParams(distance=0.07)).xy) == 1


def test_three_lines_meet_at_the_centroid_and_shape_comes_from_the_sector_of_the_robot():
    # Lines leave the corner at about 3, 90 and 177 deg: two sectors under 180 deg, one over.
    p = np.array([[0.02, 0.0], [0.0, 0.02], [-0.02, 0.0]])
    q = np.array([[1.0, 0.06], [0.0, 1.0], [-1.0, 0.06]])
    c = find_corners(p, q, viewpoint=(1, 1))
    np.testing.assert_allclose(c.xy, [[0.0, 0.02 / 3]])
    assert len(c.ends[0]) == 3 and c.shape.tolist() == ["concave"]
    assert find_corners(p, q, viewpoint=(-1, 0.5)).shape.tolist() == ["concave"]
    assert find_corners(p, q, viewpoint=(0.3, -1)).shape.tolist() == ["convex"]


def test_single_linkage_chains_ends_into_one_corner():
    # End 0 to end 1 is 4 cm and end 1 to end 2 is 4 cm, end 0 to end 2 is 8 cm.
    p = np.array([[0.0, 0.0], [0.04, 0.0], [0.08, 0.0]])
    q = np.array([[-1.0, 0.0], [0.04, 1.0], [1.08, 1.0]])
    c = find_corners(p, q)
    assert len(c.xy) == 1 and len(c.ends[0]) == 3
    np.testing.assert_allclose(c.xy, [[0.04, 0.0]])


def test_a_line_shorter_than_the_tolerance_brings_one_end_to_a_corner():
    p = np.array([[0.0, 0.0], [0.01, 0.01]])
    q = np.array([[1.0, 0.0], [0.02, 0.04]])
    c = find_corners(p, q)
    assert c.ends[0].tolist() == [[0, 0], [1, 0]]
    assert c.corner_of.tolist() == [[0, -1], [0, -1]]
    assert not np.array_equal(c.p[1], c.q[1])


def test_a_piece_the_corner_would_fold_onto_a_wall_is_left_free_when_lines_are_drawn_apart():
    """A 7.6 cm piece 11 deg off a wall, its end 4.5 cm from the wall's: the paper's rule makes them a corner, at
    whose midpoint the piece would be drawn 8.7 deg from the wall, folded onto it; drawn apart, it stays free."""
    p, q = np.array([[0.0, 0.0], [0.045, 0.0]]), np.array([[2.0, 0.0], [0.12, 0.015]])
    paper = find_corners(p, q)
    assert paper.ends[0].tolist() == [[0, 0], [1, 0]]
    drawn = paper.q[1] - paper.p[1]
    assert np.degrees(np.arctan2(drawn[1], drawn[0])) < 10
    apart = find_corners(p, q, CornerParams(drawn_apart=True))
    assert apart.xy.shape == (0, 2) and apart.free.tolist() == [[0, 0], [0, 1], [1, 0], [1, 1]]
    np.testing.assert_array_equal([apart.p, apart.q], [p, q])


def test_a_folded_piece_leaves_the_corner_of_two_walls_as_it_is():
    """Two walls meeting at the origin and the folded piece of the test above: the piece is the line the corner
    turns most, so it leaves; the walls keep their corner, now at their own ends' midpoint."""
    p = np.array([[0.0, 0.0], [0.0, 0.0], [0.045, 0.0]])
    q = np.array([[2.0, 0.0], [0.0, 2.0], [0.12, 0.015]])
    assert find_corners(p, q).ends[0].tolist() == [[0, 0], [1, 0], [2, 0]]
    c = find_corners(p, q, CornerParams(drawn_apart=True))
    assert c.xy.tolist() == [[0.0, 0.0]] and c.ends[0].tolist() == [[0, 0], [1, 0]]
    assert c.corner_of[2].tolist() == [-1, -1]


def test_a_piece_the_corner_would_turn_leaves_it_when_lines_are_drawn_apart():
    """A 4 cm piece at 76 deg whose end is 4 cm past a wall's end: at their midpoint the piece would be drawn at
    53 deg, turned 23 deg; drawn apart, both stay free. Two walls at right angles keep their corner."""
    p, q = np.array([[0.0, 0.0], [1.04, 0.0]]), np.array([[1.0, 0.0], [1.05, 0.04]])
    paper = find_corners(p, q)
    assert paper.ends[0].tolist() == [[0, 1], [1, 0]]
    drawn = paper.q[1] - paper.p[1]
    assert 52 < np.degrees(np.arctan2(drawn[1], drawn[0])) < 54
    apart = find_corners(p, q, CornerParams(drawn_apart=True))
    assert apart.xy.shape == (0, 2)
    np.testing.assert_array_equal([apart.p, apart.q], [p, q])
    walls = find_corners([[0.0, 0.0], [1.02, 0.0]], [[1.0, 0.0], [1.02, 1.0]], CornerParams(drawn_apart=True))
    assert walls.ends[0].tolist() == [[0, 1], [1, 0]]


def test_a_corner_draws_no_line_related_to_another_when_lines_are_drawn_apart():
    """A wall piece B 4.8-6.4 cm below a longer piece A of the same wall, beyond merging's tolerances, meets a wall
    C going down: at their corner's midpoint B would be drawn 4.4-4.8 cm from A, a duplicate merging left apart.
    Drawn apart, given merging's tolerances, B's end leaves the corner (also when A is one of ``others``, lines
    that make no corner here)."""
    a = np.array([[0.0, 0.06], [2.0, 0.06]])
    b, c = [[0.3, 0.012], [1.3, -0.004]], [[1.3, 0.036], [1.3, -1.0]]
    p, q = np.array([a[0], b[0], c[0]]), np.array([a[1], b[1], c[1]])
    merge, params = MergeParams(), CornerParams(drawn_apart=True)
    assert related_pairs(p, q, merge)[0].size == 0  # apart as fitted
    plain = find_corners(p, q, params)
    assert plain.corner_of[1:].tolist() == [[-1, 0], [0, -1]]
    assert related_pairs(plain.p, plain.q, merge)[0].tolist() == [0]  # B drawn onto A
    for kept in (
        find_corners(p, q, params, merge=merge),
        find_corners(p[1:], q[1:], params, merge=merge, others=(a[:1], a[1:])),
    ):
        assert kept.xy.shape == (0, 2)
        np.testing.assert_array_equal([kept.p, kept.q], [p[-2:], q[-2:]] if len(kept.p) == 2 else [p, q])


def test_a_line_drawn_between_two_corners_is_drawn_apart_with_both_ends_moved():
    """B 5.2-6 cm below A, beyond merging's tolerances, between two walls going down: either corner alone leaves
    B apart from A (its other end where it was fitted), both draw it 3.2-4 cm from A. Drawn from each corner to
    its other end where that end's corner puts it, B loses the end its corner moves farther."""
    a, b = [[0.0, 0.06], [2.0, 0.06]], [[0.3, 0.008], [1.3, 0.0]]
    c, d = [[1.3, 0.04], [1.3, -1.0]], [[0.3, 0.048], [0.3, -1.0]]
    p, q = np.array([a[0], b[0], c[0], d[0]]), np.array([a[1], b[1], c[1], d[1]])
    merge, params = MergeParams(), CornerParams(drawn_apart=True)
    plain = find_corners(p, q, params)
    assert plain.corner_of[1].tolist() == [0, 1] and related_pairs(plain.p, plain.q, merge)[0].tolist() == [0]
    for k in (0, 1):  # one corner alone
        one = plain.p.copy(), plain.q.copy()
        one[k][1] = (p, q)[k][1]
        assert related_pairs(*one, merge)[0].size == 0
    kept = find_corners(p, q, params, merge=merge)
    assert sorted(kept.corner_of[1].tolist()) == [-1, 0]  # both moved 2 cm: one leaves
    assert related_pairs(kept.p, kept.q, merge)[0].size == 0


def test_two_lines_drawn_at_a_corner_they_share_stay_apart_as_drawn_to_their_other_corners():
    """Two pieces 10.2 deg apart meeting at the origin; the second's other end meets a wall there, whose corner
    draws it down to 9.9 deg from the first: drawn to that corner, the two come within the corner angle at the
    corner they share, so one of them leaves it."""
    p = np.array([[0.0, 0.0], [0.0, 0.0], [0.3, 0.0505]])
    q = np.array([[0.3, 0.0], [0.3, 0.054], [0.3, 1.0]])
    params = CornerParams(drawn_apart=True)
    fitted = find_corners(p, q, params)
    assert len(fitted.xy) == 2 and fitted.corner_of[:2].tolist() == [[0, -1], [0, 1]]
    drawn = fitted.q[1] - fitted.p[1]
    assert np.degrees(np.arctan2(drawn[1], drawn[0])) < params.min_angle_deg  # as drawn, within the angle of L0
    kept = find_corners(p, q, params, merge=MergeParams())
    assert len(kept.xy) == 1 and kept.corner_of[:2].tolist() == [[-1, -1], [-1, 0]]


def test_empty_input_and_bad_viewpoint():
    c = find_corners(np.zeros((0, 2)), np.zeros((0, 2)), viewpoint=(0, 0))
    assert c.xy.shape == (0, 2) and c.ends == [] and c.free.shape == (0, 2) and c.shape.shape == (0,)
    with pytest.raises(ValueError, match="viewpoint"):
        find_corners([[0, 0], [1, 0]], [[1, 0], [1, 1]], viewpoint=(0, 0, 1))
    with pytest.raises(ValueError, match="positive length"):
        find_corners([[0, 0]], [[0, 0]])


def test_a_viewpoint_on_the_corner_leaves_the_shape_unknown():
    assert find_corners([[0, 0], [0, 0]], [[1, 0], [0, 1]], viewpoint=(0, 0)).shape.tolist() == ["unknown"]


@st.composite
def line_sets(draw):
    """Lines, many of whose ends sit near another's."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 25))
    p = rng.uniform(0, 2, (n, 2))
    snap = rng.random(n) < 0.6
    p[snap] = p[rng.integers(0, n, n)][snap] + rng.normal(0, 0.02, (snap.sum(), 2))
    angle = rng.uniform(0, 2 * np.pi, n)
    q = p + rng.uniform(0.12, 1.0, n)[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    flip = rng.random(n) < 0.5
    p[flip], q[flip] = q[flip], p[flip].copy()
    return p, q, rng.uniform(-1, 3, 2)


@given(line_sets(), st.booleans())
def test_corner_properties(lines, drawn_apart):
    p, q, robot = lines
    params = CornerParams(drawn_apart=drawn_apart)
    c = find_corners(p, q, params, viewpoint=robot)
    n, k = len(p), len(c.xy)
    ends = np.stack([p, q], axis=1)
    snapped = np.stack([c.p, c.q], axis=1)
    # Every end is in at most one corner: the corners' ends and the free ends partition them.
    listed = [tuple(e) for pairs in c.ends for e in pairs.tolist()] + [tuple(e) for e in c.free.tolist()]
    assert sorted(listed) == [(i, e) for i in range(n) for e in (0, 1)]
    for j, pairs in enumerate(c.ends):
        lines_j, which = pairs[:, 0], pairs[:, 1]
        assert len(set(lines_j.tolist())) == len(lines_j) >= 2
        assert (c.corner_of[lines_j, which] == j).all()
        np.testing.assert_allclose(c.xy[j], ends[lines_j, which].mean(axis=0))
        assert (snapped[lines_j, which] == c.xy[j]).all()
    free = c.corner_of < 0
    assert (snapped[free] == ends[free]).all()
    assert set(c.shape.tolist()) <= {"concave", "convex"} and len(c.shape) == k
    # Ends of different non-parallel lines within the tolerance share a corner, unless
    # one of them is left free because the other end of its line is in that corner.
    u = (q - p) / np.linalg.norm(q - p, axis=1)[:, None]
    flat = ends.reshape(-1, 2)
    close = np.linalg.norm(flat[:, None] - flat[None, :], axis=2) <= params.distance
    i, j = np.nonzero(np.triu(close, 1))
    li, lj = i // 2, j // 2
    linked = (li != lj) & (np.abs(np.sum(u[li] * u[lj], axis=1)) < np.cos(np.radians(params.min_angle_deg)) - 1e-6)
    corner = c.corner_of.ravel()
    i, j = i[linked], j[linked]
    shared = (corner[i] == corner[j]) & (corner[i] >= 0)
    dropped = ((corner[i] < 0) & (corner[i ^ 1] == corner[j])) | ((corner[j] < 0) & (corner[j ^ 1] == corner[i]))
    if not drawn_apart:
        assert (shared | dropped).all()
        return
    # Drawn apart: the lines drawn from each corner to their other ends stay at least the corner angle from
    # parallel, and within it of their own directions.
    for j, pairs in enumerate(c.ends):
        far = ends[pairs[:, 0], 1 - pairs[:, 1]] - c.xy[j]
        w = far / np.linalg.norm(far, axis=1)[:, None]
        cos = np.abs(w @ w.T)[np.triu_indices(len(w), 1)]
        assert (cos <= np.cos(np.radians(params.min_angle_deg)) + 1e-9).all()
        own = ends[pairs[:, 0], 1 - pairs[:, 1]] - ends[pairs[:, 0], pairs[:, 1]]
        along = np.sum(w * own, axis=1) / np.linalg.norm(own, axis=1)
        assert (along >= np.cos(np.radians(params.min_angle_deg)) - 1e-9).all()


@given(line_sets(), st.randoms(use_true_random=False), st.booleans())
def test_corners_do_not_depend_on_line_order(lines, random, drawn_apart):
    p, q, robot = lines
    order = list(range(len(p)))
    random.shuffle(order)
    params = CornerParams(drawn_apart=drawn_apart)
    c1 = find_corners(p, q, params, viewpoint=robot)
    c2 = find_corners(p[order], q[order], params, viewpoint=robot)
    key1 = sorted((tuple(np.round(xy, 9)), s) for xy, s in zip(c1.xy, c1.shape))
    key2 = sorted((tuple(np.round(xy, 9)), s) for xy, s in zip(c2.xy, c2.shape))
    assert key1 == key2
