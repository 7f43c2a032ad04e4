"""Merging of collinear segments: known geometry and properties."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.merging import check_segments, merge_segments, related_pairs
from evmap.maps.noise import other_poses
from evmap.sources.params import MergeParams

DEFAULT_MERGE = MergeParams()


def _polar(start, angle_deg, length):
    start = np.asarray(start, dtype=float)
    a = np.radians(angle_deg)
    return start + length * np.array([np.cos(a), np.sin(a)])


def _cross(u, v):
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _within_tolerance(p, q, m, params=DEFAULT_MERGE):
    """Every input lies within the merge tolerances of its merged line: the root mean square distance of its points
    (evenly spread along it) and its direction."""
    u = m.q - m.p
    u /= np.linalg.norm(u, axis=1)[:, None]
    ul, pl = u[m.line_of], m.p[m.line_of]
    d = q - p
    d /= np.linalg.norm(d, axis=1)[:, None]
    t = (np.arange(1000) + 0.5) / 1000
    along = p[:, None] + t[None, :, None] * (q - p)[:, None]  # (N, 1000, 2) points evenly spread on each input
    off = np.sqrt(np.mean(((along - pl[:, None]) @ np.array([[0, 1], [-1, 0]]) * ul[:, None]).sum(-1) ** 2, axis=1))
    angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(ul * d, axis=1)), 0, 1)))
    length = np.hypot(*(q - p).T)
    allowed = np.maximum(params.angle_deg, np.degrees(np.arcsin(np.minimum(params.distance / length, 1))))
    return bool((off <= params.distance + 1e-6).all() and (angle <= allowed + 1e-6).all())


def test_two_collinear_overlapping_pieces_merge_into_their_span():
    m = merge_segments([[0, 0], [0.7, 0]], [[1, 0], [1.5, 0]])
    assert m.line_of.tolist() == [0, 0]
    np.testing.assert_allclose(m.p, [[0, 0]], atol=1e-12)
    np.testing.assert_allclose(m.q, [[1.5, 0]], atol=1e-12)


@pytest.mark.parametrize(("gap", "merged"), [(0.0, True), (0.05, True), (0.06, False)])
def test_gap_along_the_line(gap, merged):
    m = merge_segments([[0, 0], [1 + gap, 0]], [[1, 0], [2, 0]])
    assert (len(m.p) == 1) is merged


@pytest.mark.parametrize(("angle", "merged"), [(9.0, True), (10.0, True), (11.0, False)])
def test_direction_difference(angle, merged):
    # 28 cm pieces sharing an end: the turned piece's far end stays within 5 cm of the line (4.9 cm at 10 deg)
    p = [[0, 0], [0.28, 0]]
    q = [[0.28, 0], _polar([0.28, 0], angle, 0.28)]
    assert (len(merge_segments(p, q).p) == 1) is merged


@pytest.mark.parametrize(("angle", "merged"), [(14.0, True), (14.6, False)])
def test_a_short_piece_turns_as_far_as_its_ends_allow(angle, merged):
    # 20 cm pieces sharing an end: a direction within asin(5 cm / 20 cm) = 14.48 deg of the other's still
    # holds both ends within 5 cm of one line (capped at 1.5 * 10 deg)
    p = [[0, 0], [0.2, 0]]
    q = [[0.2, 0], _polar([0.2, 0], angle, 0.2)]
    assert (len(merge_segments(p, q).p) == 1) is merged
    assert len(related_pairs(np.array(p, dtype=float), np.array(q, dtype=float), DEFAULT_MERGE)[0]) == 0


def test_a_tiny_piece_turns_no_more_than_the_cap():
    # a 5 cm piece at 20 deg to a wall, its ends within 2 cm of the wall's line: a piece of another surface
    p = [[0.0, 0.0], _polar([1.0, -0.01], 20, 0.0)]
    q = [[1.0, 0.0], _polar([1.0, -0.01], 20, 0.05)]
    assert len(merge_segments(p, q).p) == 2


def test_a_member_whose_ends_part_by_more_than_the_distance_stays_while_its_points_fit():
    # a 6 m wall and two 1 m pieces of it seen from 30 poses each, 5 cm to either side at its two ends (a
    # pose's heading): the joint line leaves the wall's ends 6 cm off it, its points 3.5 cm in the mean square
    p = np.array([[0.0, 0.0], [0.0, 0.05], [5.0, -0.05]])
    q = np.array([[6.0, 0.0], [1.0, 0.05], [6.0, -0.05]])
    m = merge_segments(p, q, weights=[1, 30, 30])
    assert len(m.p) == 1 and _within_tolerance(p, q, m)
    u = (m.q[0] - m.p[0]) / np.linalg.norm(m.q[0] - m.p[0])
    ends = np.abs(_cross(np.stack([u, u]), np.stack([p[0], q[0]]) - m.p[0]))
    assert ends.max() > 0.05  # the rule before (both ends within 5 cm) kept the wall apart
    assert len(merge_segments(p, q + [[0, 0], [0, 0.02], [0, -0.02]], weights=[1, 30, 30]).p) > 1  # 7 cm: apart


def test_offset_of_the_shorter_line():
    # Parallel lines 10 or 6 cm apart stay apart; 4 cm apart they merge.
    assert len(merge_segments([[0, 0], [0, 0.1]], [[1, 0], [1, 0.1]]).p) == 2
    assert len(merge_segments([[0, 0], [0, 0.06]], [[1, 0], [1, 0.06]]).p) == 2
    m = merge_segments([[0, 0], [0.2, 0.04]], [[2, 0], [0.6, 0.04]])
    assert len(m.p) == 1
    assert _within_tolerance(np.array([[0, 0], [0.2, 0.04]]), np.array([[2, 0], [0.6, 0.04]]), m)


def test_ten_pieces_of_a_wall_become_the_wall():
    rng = np.random.default_rng(1)
    a, b = np.array([1.0, 2.0]), np.array([4.0, 3.0])
    t = np.linspace(0, 1, 11)
    starts = t[:-1] + np.r_[0, rng.uniform(-0.01, 0.01, 9)]
    ends = t[1:] + np.r_[rng.uniform(-0.01, 0.01, 9), 0]
    normal = np.array([-1.0, 3.0]) / np.sqrt(10)
    p = a + starts[:, None] * (b - a) + rng.normal(0, 0.002, (10, 1)) * normal
    q = a + ends[:, None] * (b - a) + rng.normal(0, 0.002, (10, 1)) * normal
    order = rng.permutation(10)
    m = merge_segments(p[order], q[order])
    assert len(m.p) == 1
    assert m.groups[0].tolist() == list(range(10))
    np.testing.assert_allclose(m.p[0], a, atol=0.005)
    np.testing.assert_allclose(m.q[0], b, atol=0.005)


def test_a_bending_chain_does_not_become_one_line():
    # 30 cm pieces each turned 6 deg from the last: every neighbour pair is related,
    # but one line through all of them would be 12 deg off its end pieces.
    p, q = [], []
    start = np.zeros(2)
    for k in range(5):
        end = _polar(start, 6 * k, 0.3)
        p.append(start)
        q.append(end)
        start = end
    p, q = np.array(p), np.array(q)
    m = merge_segments(p, q)
    assert 1 < len(m.p) < 5
    assert _within_tolerance(p, q, m)
    assert all(np.array_equal(g, np.arange(g[0], g[-1] + 1)) for g in m.groups)  # contiguous runs


def test_the_refit_is_total_least_squares_through_points_along_the_members():
    p = np.array([[0.0, 0.0], [0.9, 0.02], [1.5, -0.01]])
    q = np.array([[1.0, 0.01], [1.6, 0.0], [3.0, 0.03]])
    m = merge_segments(p, q)
    assert len(m.p) == 1
    # Points evenly spaced along every member (the same density on each).
    counts = np.round(10000 * np.linalg.norm(q - p, axis=1)).astype(int)
    pts = np.concatenate([a + ((np.arange(k) + 0.5) / k)[:, None] * (b - a) for a, b, k in zip(p, q, counts)])
    centre = pts.mean(axis=0)
    direction = np.linalg.svd(pts - centre, full_matrices=False)[2][0]
    u = (m.q[0] - m.p[0]) / np.linalg.norm(m.q[0] - m.p[0])
    assert abs(u[0] * direction[1] - u[1] * direction[0]) < 1e-4
    assert abs(u[0] * (centre - m.p[0])[1] - u[1] * (centre - m.p[0])[0]) < 1e-4
    # The extent spans the projections of the members' end points.
    ends = np.concatenate([p, q])
    span = np.sort((ends - m.p[0]) @ u)[[0, -1]]
    np.testing.assert_allclose(span, [0, np.linalg.norm(m.q[0] - m.p[0])], atol=1e-12)


def test_lines_unmerged_are_returned_unchanged_and_merged_ones_keep_the_longest_direction():
    p = np.array([[2.0, 0.0], [0.5, 0.0], [0.3, 1.0]])
    q = np.array([[0.0, 0.0], [1.0, 0.0], [0.1, 2.0]])
    m = merge_segments(p, q)
    assert m.line_of.tolist() == [0, 0, 1]
    assert np.array_equal(m.p[1], p[2]) and np.array_equal(m.q[1], q[2])
    np.testing.assert_allclose([m.p[0], m.q[0]], [[2, 0], [0, 0]], atol=1e-12)  # points like segment 0


def test_empty_input_and_parameters():
    m = merge_segments(np.zeros((0, 2)), np.zeros((0, 2)))
    assert m.p.shape == (0, 2) and m.groups == [] and m.line_of.shape == (0,)
    # A zero gap tolerance still merges touching pieces; zero angle tolerance keeps a 1 deg turn apart.
    assert len(merge_segments([[0, 0], [1, 0]], [[1, 0], [2, 0]], MergeParams(gap=0)).p) == 1
    turned = ([[0, 0], [0.2, 0]], [[0.2, 0], _polar([0.2, 0], 1, 0.2)])
    assert len(merge_segments(*turned, MergeParams(angle_deg=0)).p) == 2


@pytest.mark.parametrize(
    ("p", "q", "message"),
    [
        ([[0, 0]], [[1, 0], [2, 0]], "shape"),
        ([0, 0], [1, 0], "shape"),
        ([[0, np.nan]], [[1, 0]], "finite"),
        ([[0, 0], [1, 1]], [[1, 0], [1, 1]], "segment 1"),
    ],
)
def test_bad_segments_are_refused(p, q, message):
    with pytest.raises(ValueError, match=message):
        check_segments(p, q)
    with pytest.raises(ValueError, match=message):
        merge_segments(p, q)


@st.composite
def wall_pieces(draw):
    """Pieces of a few random walls, with overlaps, gaps and noise, and some clutter."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    p, q = [], []
    for _ in range(draw(st.integers(1, 4))):
        a = rng.uniform(-3, 3, 2)
        angle = rng.uniform(0, 2 * np.pi)
        u = np.array([np.cos(angle), np.sin(angle)])
        k = int(rng.integers(1, 8))
        t0 = np.sort(rng.uniform(0, 3, k))
        t1 = t0 + rng.uniform(0.05, 0.6, k)
        noise = rng.normal(0, 0.01, (k, 2, 2))
        p.append(a + t0[:, None] * u + noise[:, 0])
        q.append(a + t1[:, None] * u + noise[:, 1])
    clutter = int(rng.integers(0, 6))
    c = rng.uniform(-3, 3, (clutter, 2))
    p.append(c)
    q.append(c + rng.uniform(-0.3, 0.3, (clutter, 2)) + 0.01)
    return np.concatenate(p), np.concatenate(q)


@given(wall_pieces())
def test_merging_properties(segments):
    p, q = segments
    m = merge_segments(p, q)
    n = len(p)
    assert len(m.p) <= n
    # Every input belongs to exactly one group, and line_of agrees with the groups.
    assert sorted(np.concatenate(m.groups).tolist()) == list(range(n))
    for k, g in enumerate(m.groups):
        assert (m.line_of[g] == k).all() and (np.diff(g) > 0).all()
    assert [g[0] for g in m.groups] == sorted(g[0] for g in m.groups)
    assert _within_tolerance(p, q, m)
    # A fixed point: two output lines that would merge as lines do not fit their input
    # pieces with one line (else the last round would have merged them).
    again = merge_segments(m.p, m.q)
    for group in again.groups:
        for i, a in enumerate(group):
            for b in group[i + 1 :]:
                if len(merge_segments(m.p[[a, b]], m.q[[a, b]]).p) == 1:
                    pieces = np.concatenate([m.groups[a], m.groups[b]])
                    assert len(merge_segments(p[pieces], q[pieces]).p) > 1


@given(wall_pieces(), st.randoms(use_true_random=False))
def test_merging_does_not_depend_on_input_order(segments, random):
    p, q = segments
    order = list(range(len(p)))
    random.shuffle(order)
    flip = np.array([random.random() < 0.5 for _ in order])
    pp, qq = p[order], q[order]
    pp[flip], qq[flip] = qq[flip], pp[flip].copy()
    m1, m2 = merge_segments(p, q), merge_segments(pp, qq)
    groups1 = sorted(sorted(g.tolist()) for g in m1.groups)
    groups2 = sorted(sorted(np.asarray(order)[g].tolist()) for g in m2.groups)
    assert groups1 == groups2
    # Same lines, whichever way they point.
    for k, g in enumerate(m1.groups):
        j = m2.line_of[np.argsort(order)[g[0]]]
        same = max(np.abs(m1.p[k] - m2.p[j]).max(), np.abs(m1.q[k] - m2.q[j]).max())
        flipped = max(np.abs(m1.p[k] - m2.q[j]).max(), np.abs(m1.q[k] - m2.p[j]).max())
        assert min(same, flipped) <= 1e-9


@given(wall_pieces(), st.integers(0, 40))
def test_related_pairs_between_two_sets_are_the_cross_pairs_of_their_union(segments, split):
    p, q = segments
    k = min(split, len(p))
    a, b, cost = related_pairs(p, q, MergeParams())
    cross = (a < k) & (b >= k)  # a < b: the first set's line comes first
    i, j, c = related_pairs(p[:k], q[:k], MergeParams(), others=(p[k:], q[k:]))
    found = sorted(zip(i.tolist(), j.tolist(), c.tolist()))
    assert [(x, y) for x, y, _ in found] == sorted(zip(a[cross].tolist(), (b[cross] - k).tolist()))
    expected = dict(zip(zip(a[cross].tolist(), (b[cross] - k).tolist()), cost[cross].tolist()))
    assert all(abs(expected[x, y] - z) <= 1e-12 for x, y, z in found)


@given(wall_pieces(), st.randoms(use_true_random=False))
def test_other_poses_counts_the_other_poses_that_saw_a_segment(segments, random):
    p, q = segments
    k = len(p)
    cp, cq = p + 1e-3, q - 1e-3  # every wall piece seen again, and each related to its copy
    pose = np.array([random.randrange(3) for _ in range(k)])
    cpose = np.array([random.randrange(3) for _ in range(k)])
    a, b, _ = related_pairs(np.concatenate([p, cp]), np.concatenate([q, cq]), MergeParams())
    sets = [set() for _ in range(k)]
    for x, y in zip(a.tolist(), b.tolist()):
        if x < k <= y and cpose[y - k] != pose[x]:
            sets[x].add(cpose[y - k])
    expected = [len(s) for s in sets]
    assert any(expected) or not k or (pose == cpose).all()
    assert other_poses(p, q, pose, cp, cq, cpose, MergeParams()).tolist() == expected
    one = np.zeros(k, dtype=np.intp)  # one pose judged: its own candidates never count
    assert not other_poses(p, q, one, cp, cq, one, MergeParams()).any()


def test_a_line_of_pieces_turned_across_a_wall_joins_it_where_it_fits_as_a_whole():
    """Two pieces 20-24 deg off a wall and within 3 cm of it (laser pieces on the Intel log): each is beyond its
    turn allowance from the wall, so steps 1-3 leave the two a line of their own; that line is related to the
    wall (the paper's pair rule) and, as one member, fits their union: they join."""
    p = np.array([[0.29, 0.02], [0.38, 0.02], [0.04, 0.03]])
    q = np.array([[0.47, 0.10], [0.54, 0.08], [1.82, 0.11]])
    for k in (0, 1):
        assert len(merge_segments(p[[k, 2]], q[[k, 2]]).p) == 2
    pieces = merge_segments(p[:2], q[:2])
    assert len(pieces.p) == 1 and len(related_pairs(np.r_[pieces.p, p[2:]], np.r_[pieces.q, q[2:]], MergeParams())[0])
    m = merge_segments(p, q)
    assert [g.tolist() for g in m.groups] == [[0, 1, 2]]
    np.testing.assert_allclose([m.p[0], m.q[0]], [p[2], q[2]], atol=0.005)
