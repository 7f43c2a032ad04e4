"""Matching actual and simulated RCDs: gates, circular angles, global optimality."""

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.matching import match_rcds
from evmap.sources.params import MatchParams

deg = np.radians
DEFAULT_MATCH = MatchParams()


def _cost(a_dir, a_rng, s_dir, s_rng, ai, si, params=DEFAULT_MATCH):
    dtheta = np.angle(np.exp(1j * (np.asarray(a_dir)[ai] - np.asarray(s_dir)[si])))
    drange = np.asarray(a_rng)[ai] - np.asarray(s_rng)[si]
    return float(np.sum((dtheta / deg(params.angle_scale_deg)) ** 2 + (drange / params.range_scale) ** 2))


def _greedy(a_dir, a_rng, s_dir, s_rng, params=DEFAULT_MATCH):
    """First-come matching: cheapest admissible pair first, then the next among the rest."""
    pairs = []
    for i, j in itertools.product(range(len(a_dir)), range(len(s_dir))):
        dtheta = abs(np.angle(np.exp(1j * (a_dir[i] - s_dir[j]))))
        if dtheta <= deg(params.angle_gate_deg) + 1e-9 and abs(a_rng[i] - s_rng[j]) <= params.range_gate + 1e-9:
            pairs.append((_cost(a_dir, a_rng, s_dir, s_rng, [i], [j]), i, j))
    used_a, used_s, ai, si = set(), set(), [], []
    for _, i, j in sorted(pairs):
        if i not in used_a and j not in used_s:
            used_a.add(i), used_s.add(j), ai.append(i), si.append(j)
    return ai, si


def test_empty_inputs_give_empty_pairs():
    for a, s in [([], []), ([1.0], []), ([], [1.0])]:
        ai, si = match_rcds(a, [2.0] * len(a), s, [2.0] * len(s))
        assert ai.shape == si.shape == (0,) and ai.dtype == si.dtype == np.intp


def test_directions_are_compared_round_the_circle():
    ai, si = match_rcds(deg([359.0, 180.0]), [1.0, 3.0], deg([-179.0, 1.0]), [3.0, 1.0])
    assert ai.tolist() == [0, 1] and si.tolist() == [1, 0]


@pytest.mark.parametrize(
    ("dtheta", "drange", "matched"),
    [
        (12.0, 0.0, True),
        (12.5, 0.0, True),
        (13.0, 0.0, False),
        (-13.0, 0.0, False),
        (0.0, 0.09, True),
        (0.0, 0.1, True),
        (0.0, 0.11, False),
    ],
)
def test_gates(dtheta, drange, matched):
    ai, _si = match_rcds(deg([30.0]), [2.0], deg([30.0 + dtheta]), [2.0 + drange])
    assert (ai.size == 1) is matched


def test_the_global_assignment_matches_more_than_greedy():
    # Greedy takes the cheapest pair (0, 0) and leaves actual 1 with nothing in its gate.
    a_dir, a_rng, s_dir, s_rng = deg([0.0, 10.0]), [2.0, 2.0], deg([4.0, -8.0]), [2.0, 2.0]
    assert _greedy(a_dir, a_rng, s_dir, s_rng) == ([0], [0])
    ai, si = match_rcds(a_dir, a_rng, s_dir, s_rng)
    assert ai.tolist() == [0, 1] and si.tolist() == [1, 0]


def test_the_global_assignment_costs_less_than_greedy():
    a_dir, a_rng, s_dir, s_rng = deg([0.0, 5.0]), [2.0, 2.03], deg([4.0, 12.0]), [2.01, 2.0]
    gi, gs = _greedy(a_dir, a_rng, s_dir, s_rng)
    ai, si = match_rcds(a_dir, a_rng, s_dir, s_rng)
    assert len(ai) == len(gi) == 2
    assert _cost(a_dir, a_rng, s_dir, s_rng, ai, si) < _cost(a_dir, a_rng, s_dir, s_rng, gi, gs) - 0.1


def test_scales_and_gates_come_from_the_parameters():
    args = deg([0.0]), [2.0], deg([20.0]), [2.3]
    assert match_rcds(*args)[0].size == 0
    assert match_rcds(*args, MatchParams(angle_gate_deg=25, range_gate=0.5))[0].tolist() == [0]


def test_an_actual_rcd_much_wider_than_the_simulated_one_is_not_its_echo():
    """``width_gate_deg`` (default config 8, the paper's 0): a pane's echo 25 deg wide does not match the 9 deg
    echo the map predicts from a wall end beside it; it takes another simulated RCD it fits, and widths within
    the gate, or a narrower actual RCD, still match."""
    from evmap.sources.config import load_config

    assert load_config("default").matching.width_gate_deg == 8.0 and load_config("paper").matching.width_gate_deg == 0
    gate = MatchParams(width_gate_deg=8.0)
    args = deg([0.0]), [2.5], deg([2.0]), [2.52]
    assert match_rcds(*args, gate, (deg([25.0]), deg([9.0])))[0].tolist() == []
    assert match_rcds(*args, MatchParams(), (deg([25.0]), deg([9.0])))[0].tolist() == [0]  # the paper's method
    assert match_rcds(*args, gate)[0].tolist() == [0]  # no widths given: not compared
    assert match_rcds(*args, gate, (deg([17.0]), deg([9.0])))[0].tolist() == [0]  # exactly at the gate
    assert match_rcds(*args, gate, (deg([9.0]), deg([25.0])))[0].tolist() == [0]  # narrower: masked, say
    two = deg([0.0]), [2.5], deg([2.0, -6.0]), [2.52, 2.5]
    assert match_rcds(*two, gate, (deg([25.0]), deg([9.0, 24.0])))[1].tolist() == [1]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([0.0, 1.0], [2.0], [0.0], [2.0]), "actual_dir and actual_range"),
        (([0.0], [2.0], [[0.0]], [[2.0]]), "sim_dir and sim_range must be 1-D"),
        (([np.nan], [2.0], [0.0], [2.0]), "finite"),
    ],
)
def test_bad_inputs_are_refused(args, message):
    with pytest.raises(ValueError, match=message):
        match_rcds(*args)


def _best_by_enumeration(a_dir, a_rng, s_dir, s_rng, params=DEFAULT_MATCH):
    """Most admissible pairs, then least cost, over every one-to-one partial matching."""
    n, m = len(a_dir), len(s_dir)
    admissible = {
        (i, j)
        for i in range(n)
        for j in range(m)
        if abs(np.angle(np.exp(1j * (a_dir[i] - s_dir[j])))) <= deg(params.angle_gate_deg) + 1e-9
        and abs(a_rng[i] - s_rng[j]) <= params.range_gate + 1e-9  # at the gate is in
    }
    best = (0, 0.0)
    for k in range(1, min(n, m) + 1):
        for rows in itertools.combinations(range(n), k):
            for cols in itertools.permutations(range(m), k):
                if all(pair in admissible for pair in zip(rows, cols)):
                    cost = _cost(a_dir, a_rng, s_dir, s_rng, list(rows), list(cols))
                    if (-k, cost) < (-best[0], best[1]):
                        best = (k, cost)
    return best


# Directions in a 46 deg fan, written with any number of turns, so that many pairs are in the gates.
rcds = st.lists(st.tuples(st.floats(-0.4, 0.4), st.integers(-1, 1), st.floats(1.0, 1.2)), min_size=0, max_size=5).map(
    lambda xs: (np.array([x + 2 * np.pi * k for x, k, _ in xs]), np.array([r for *_, r in xs]))
)


@given(rcds, rcds)
def test_matching_is_one_to_one_gated_and_optimal(actual, sim):
    (a_dir, a_rng), (s_dir, s_rng) = actual, sim
    ai, si = match_rcds(a_dir, a_rng, s_dir, s_rng)
    assert len(set(ai.tolist())) == len(ai) and len(set(si.tolist())) == len(si)
    assert (np.diff(ai) > 0).all()
    dtheta = np.abs(np.angle(np.exp(1j * (a_dir[ai] - s_dir[si]))))
    assert (dtheta <= deg(12.5) + 1e-9).all() and (np.abs(a_rng[ai] - s_rng[si]) <= 0.1 + 1e-9).all()
    k, cost = _best_by_enumeration(a_dir, a_rng, s_dir, s_rng)
    assert len(ai) == k
    assert _cost(a_dir, a_rng, s_dir, s_rng, ai, si) == pytest.approx(cost, abs=1e-9)
    again = match_rcds(a_dir, a_rng, s_dir, s_rng)
    assert np.array_equal(again[0], ai) and np.array_equal(again[1], si)


@given(st.integers(0, 25), st.integers(0, 25), st.integers(0, 2**32 - 1))
def test_matching_agrees_with_scipy_on_larger_scans(n, m, seed):
    """Scans of up to 25 RCDs, crowded into the gates: as many pairs and the same least cost as scipy's solver."""
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(seed)
    a_dir, s_dir = rng.uniform(0, deg(40), n), rng.uniform(0, deg(40), m)
    a_rng, s_rng = rng.uniform(1.0, 1.15, n), rng.uniform(1.0, 1.15, m)
    ai, si = match_rcds(a_dir, a_rng, s_dir, s_rng)
    dtheta = np.angle(np.exp(1j * (a_dir[:, None] - s_dir[None, :])))
    drange = a_rng[:, None] - s_rng[None, :]
    ok = (np.abs(dtheta) <= deg(12.5) + 1e-9) & (np.abs(drange) <= 0.1 + 1e-9)
    cost = np.where(ok, (dtheta / deg(10)) ** 2 + (drange / 0.05) ** 2, 1e6)
    r, c = linear_sum_assignment(cost)
    r, c = r[ok[r, c]], c[ok[r, c]]
    assert len(ai) == len(r)
    assert _cost(a_dir, a_rng, s_dir, s_rng, ai, si) == pytest.approx(cost[r, c].sum(), abs=1e-9)
