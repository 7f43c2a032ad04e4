"""Decisions, measures, Monte-Carlo combination, summarisation and views: known answers."""

import math
import subprocess
import sys

import numpy as np
import pytest
from engine_fixtures import FRAMES, assert_same, masses
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import Frame, MassError, MassFunction, TotalConflictError, combine, jousselme_distance
from evidential.approximation import monte_carlo_combine, summarize
from evidential.decision import choose, expected_utilities, hurwicz, interval_dominance, maximality
from evidential.measures import (
    belief_distance,
    discord,
    liu_conflict,
    nonspecificity,
    plausibility_distance,
    strife,
    total_uncertainty,
)
from evidential.view import plot, table

ABC = FRAMES[3]
URN = Frame(["red", "black", "yellow"])
ELLSBERG = MassFunction(URN, {"red": 1 / 3, "black|yellow": 2 / 3})


def test_ellsberg_paradox_is_the_lower_expected_utility_ranking():
    # Ellsberg (1961); Denœux (2019), IJAR 109, sec. 3.2: f1 = red, f2 = black, f3 = red or
    # yellow, f4 = black or yellow. People prefer f1 to f2 and f4 to f3: E_* ranks so.
    e = expected_utilities(ELLSBERG, [[100, 0, 0], [0, 100, 0], [100, 0, 100], [0, 100, 100]])
    np.testing.assert_allclose(e.lower, [100 / 3, 0, 100 / 3, 200 / 3])
    np.testing.assert_allclose(e.upper, [100 / 3, 200 / 3, 100, 200 / 3])
    np.testing.assert_allclose(e.pignistic, [100 / 3, 100 / 3, 200 / 3, 200 / 3])
    assert e.lower[0] > e.lower[1] and e.lower[3] > e.lower[2]
    np.testing.assert_allclose(hurwicz(ELLSBERG, [[0, 100, 0]], 0.5), [100 / 3])


def test_dominance_and_maximality_known_answer():
    # Troffaes (2007), IJAR 45: maximality ⊆ interval dominance; the vacuous mass keeps
    # every act not pointwise dominated.
    u = [[1, 0], [2, 1], [0, 3], [0.5, 0.5]]
    vacuous = MassFunction(FRAMES[2], {"w0|w1": 1.0})
    # E_* = (0, 1, 0, .5), E^* = (1, 2, 3, .5): act 3 is interval-dominated by act 1 (.5 < 1),
    # act 0 is not (1 >= 1); act 1 - act 0 = (1, 1) > 0, so act 0 is not maximal.
    assert interval_dominance(vacuous, u) == [0, 1, 2]
    assert maximality(vacuous, u) == [1, 2]


def test_reject_option_known_answer():
    # Denœux (1997), Pattern Recognition 30, sec. 3: with 0-1 utilities the lower, pignistic and upper
    # expected utilities of act i are bel({ω_i}), BetP(ω_i) and pl({ω_i}); the best act is rejected
    # (abstain) when its value is below the utility of rejection.
    m = MassFunction(ABC, {"w0": 0.4, "w1": 0.2, "w0|w1|w2": 0.4})
    u = np.eye(3)
    e = expected_utilities(m, u)
    np.testing.assert_allclose(e.lower, [0.4, 0.2, 0.0])
    np.testing.assert_allclose(e.pignistic, [0.4 + 0.4 / 3, 0.2 + 0.4 / 3, 0.4 / 3])
    np.testing.assert_allclose(e.upper, [0.8, 0.6, 0.4])
    assert choose(m, u, criterion="lower", reject=0.5) is None
    assert choose(m, u, criterion="pignistic", reject=0.5) == 0
    assert choose(m, u, criterion="upper", reject=0.9) is None
    assert choose(m, u, criterion="hurwicz", pessimism=0.5, reject=0.55) == 0  # (0.4 + 0.8) / 2 = 0.6
    assert choose(m, u, criterion="hurwicz", pessimism=0.5, reject=0.65) is None
    for bad in (float("nan"), "5", True):  # nan would never abstain, "5" fails in numpy
        with pytest.raises(MassError, match="reject .* must be a finite number or None"):
            choose(m, u, reject=bad)


@settings(max_examples=40)
@given(m=masses(3), u=st.lists(st.lists(st.floats(-5, 5), min_size=3, max_size=3), min_size=1, max_size=4))
def test_decision_criteria_are_consistent(m, u):
    e = expected_utilities(m, u)
    assert np.all(e.lower <= e.pignistic + 1e-9) and np.all(e.pignistic <= e.upper + 1e-9)
    maximal, kept = maximality(m, u), interval_dominance(m, u)
    assert set(maximal) <= set(kept)
    best = int(np.argmax(e.pignistic))
    assert any(np.allclose(e.pignistic[a], e.pignistic[best]) for a in maximal)  # BetP is in the credal set
    np.testing.assert_allclose(hurwicz(m, u, 1.0), e.lower)
    assert choose(m, u, criterion="lower", reject=float(e.lower.max()) + 1) is None


def test_decision_errors():
    with pytest.raises(MassError, match="utility must be a finite \\(acts, 3\\) array, got shape \\(1, 2\\)"):
        expected_utilities(ELLSBERG, [[1, 2]])
    with pytest.raises(MassError, match="criterion must be one of"):
        choose(ELLSBERG, [[1, 2, 3]], criterion="best")
    with pytest.raises(MassError, match="pessimism must be a number in \\[0, 1\\], got 2"):
        hurwicz(ELLSBERG, [[1, 2, 3]], 2)


# --- measures -------------------------------------------------------------------------------


def test_uncertainty_measures_known_answers():
    # Klir & Wierman (1999), ch. 5: on Bayesian masses discord = strife = Shannon entropy and
    # N = 0; on a categorical mass on A, N = log2 |A| and S = D = 0.
    p = MassFunction(ABC, {"w0": 0.5, "w1": 0.25, "w2": 0.25})
    for f in (discord, strife, total_uncertainty):
        assert f(p) == pytest.approx(1.5)
    assert nonspecificity(p) == 0.0
    c = MassFunction(ABC, {"w0|w1|w2": 1.0})
    assert (nonspecificity(c), strife(c), discord(c)) == (pytest.approx(math.log2(3)), 0.0, 0.0)


@settings(max_examples=40)
@given(m=masses(3))
def test_total_uncertainty_is_in_range(m):
    assert -1e-12 <= total_uncertainty(m) <= math.log2(3) + 1e-12
    assert discord(m) >= -1e-12 and strife(m) >= -1e-12


def test_distances_and_conflict_known_answers():
    a, b, ab = (MassFunction(FRAMES[2], {f: 1.0}) for f in ("w0", "w1", "w0|w1"))
    assert belief_distance(a, b) == pytest.approx(math.sqrt(2 / 3))  # bel differs on {a} and {b}
    assert plausibility_distance(a, ab) == pytest.approx(math.sqrt(1 / 3))
    assert belief_distance(a, a) == plausibility_distance(a, a) == 0.0
    # Liu (2006), AI 170, example: m1 = m2 = uniform Bayesian on 5 elements has K = .8 but
    # difBetP = 0 (no conflict); categorical {a} vs {b}: K = 1, difBetP = 1.
    five = Frame(list("abcde"))
    u = MassFunction(five, {x: 0.2 for x in "abcde"})
    assert liu_conflict(u, u) == pytest.approx((0.8, 0.0))
    assert liu_conflict(a, b) == pytest.approx((1.0, 1.0))


@settings(max_examples=30)
@given(m1=masses(3), m2=masses(3))
def test_distances_are_metrics_bounded_by_one(m1, m2):
    for d in (belief_distance, plausibility_distance):
        assert 0 <= d(m1, m2) <= 1 and d(m1, m2) == pytest.approx(d(m2, m1))
    assert 0 <= jousselme_distance(m1, m2) <= 1


# --- Monte-Carlo combination and summarisation ----------------------------------------------


def test_monte_carlo_is_within_its_bound_and_seeded():
    rng = np.random.default_rng(42)
    m1 = MassFunction(ABC, {"w0": 0.4, "w0|w1": 0.3, "w0|w1|w2": 0.3})
    m2 = MassFunction(ABC, {"w1": 0.5, "w1|w2": 0.2, "w0|w1|w2": 0.3})
    exact = combine(m1, m2)
    est = monte_carlo_combine(m1, m2, samples=20_000, rng=rng)
    assert np.abs(est.mass.dense() - exact.dense()).max() <= est.error
    again = monte_carlo_combine(m1, m2, samples=20_000, rng=np.random.default_rng(42))
    assert_same(again.mass, est.mass, tol=0)
    unnormalised = monte_carlo_combine(m1, m2, samples=20_000, rng=rng, normalise=False)
    assert unnormalised.mass[""] == pytest.approx(combine(m1, m2, rule="conjunctive")[""], abs=unnormalised.error)


def test_monte_carlo_on_a_large_frame_and_errors():
    big = Frame([f"e{i}" for i in range(60)])
    m1 = MassFunction(big, {"e0|e1|e2": 0.5, big.full: 0.5})
    m2 = MassFunction(big, {"e1|e2|e3": 0.5, big.full: 0.5})
    est = monte_carlo_combine(m1, m2, m2, samples=5000, rng=np.random.default_rng(1))
    assert abs(est.mass["e1|e2"] - combine(m1, m2, m2)["e1|e2"]) <= est.error
    with pytest.raises(TotalConflictError):
        monte_carlo_combine(
            MassFunction(ABC, {"w0": 1.0}), MassFunction(ABC, {"w1": 1.0}), samples=10, rng=np.random.default_rng()
        )
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        monte_carlo_combine(m1, samples=10, rng=1)
    with pytest.raises(MassError, match="samples must be an integer >= 1, got 0"):
        monte_carlo_combine(m1, samples=0, rng=np.random.default_rng())
    with pytest.raises(MassError, match="confidence must be a number in \\(0, 1\\), got '0.9'"):
        monte_carlo_combine(m1, samples=10, rng=np.random.default_rng(), confidence="0.9")


@settings(max_examples=40)
@given(m=masses(4), k=st.integers(1, 6))
def test_summary_has_at_most_k_focal_sets_and_bounded_error(m, k):
    s = summarize(m, k)
    assert len(s.mass) <= k
    for a in range(16):
        assert abs(s.mass.belief(a) - m.belief(a)) <= s.error + 1e-12
        assert m.plausibility(a) - 1e-12 <= s.mass.plausibility(a) <= m.plausibility(a) + s.error + 1e-12


# --- views ----------------------------------------------------------------------------------


def test_table_lists_every_focal_set():
    text = table(MassFunction(ABC, {"w0": 0.5, "w0|w1|w2": 0.5}))
    lines = text.splitlines()
    assert lines[0].split() == ["focal", "set", "m", "bel", "pl", "BetP"]
    assert lines[1].split() == ["w0", "0.5000", "0.5000", "1.0000", "0.6667"]
    assert table(MassFunction(ABC, {"": 1.0}, open_world=True)).splitlines()[1].split()[0] == "∅"


def test_plot_draws_one_interval_per_focal_set_and_imports_matplotlib_lazily():
    ax = plot(MassFunction(ABC, {"w0": 0.5, "w0|w1": 0.2, "w0|w1|w2": 0.3}))
    assert len(ax.patches) == 3 and [t.get_text() for t in ax.get_yticklabels()] == ["w0", "w0|w1", "w0|w1|w2"]
    code = "import sys, evidential.view; print('matplotlib' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "False\n"
