"""Canonical decompositions, decombination, contextual discounting and reinforcement,
negation, conditioning and deconditioning: known answers and properties."""

import math

import numpy as np
import pytest
from engine_fixtures import FRAMES, assert_same, masses
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import Frame, MassError, MassFunction, TotalConflictError, combine
from evidential.conditioning import condition, decondition, generalized_bayes
from evidential.decomposition import (
    conjunctive_weights,
    decombine,
    disjunctive_weights,
    from_conjunctive_weights,
    from_disjunctive_weights,
)
from evidential.discounting import contextual_discount, contextual_reinforcement, negation

ABC = FRAMES[3]


def close(m, expected, tol=1e-12):
    assert {k for k, v in m.to_dict().items() if v > tol} == set(expected)
    for k, v in expected.items():
        assert m[k] == pytest.approx(v, abs=tol)


def test_weights_of_a_non_separable_mass_function():
    # Denœux (2008), AI 172, sec. 2.3: on Θ = {a, b}, w(a) = q(Θ) / q(a), w(∅) = q(a) q(b) / q(Θ);
    # m = {a: .3, b: .3, Θ: .4}: w(a) = w(b) = 4/7, w(∅) = .49 / .4 = 1.225 > 1 (not separable).
    w = conjunctive_weights(MassFunction(FRAMES[2], {"w0": 0.3, "w1": 0.3, "w0|w1": 0.4}))
    np.testing.assert_allclose(w, [1.225, 4 / 7, 4 / 7, 1.0], rtol=1e-12)


def test_weights_of_a_separable_mass_function():
    # Smets (1995): {a}^0.3 ∩ {a, b}^0.6 has w(a) = .3, w(ab) = .6, every other weight 1.
    m = MassFunction(ABC, {"w0": 0.7, "w0|w1": 0.12, "w0|w1|w2": 0.18})
    expected = np.ones(8)
    expected[1], expected[3] = 0.3, 0.6
    np.testing.assert_allclose(conjunctive_weights(m), expected, rtol=1e-12)


@settings(max_examples=40)
@given(m=masses(3, nondogmatic=True))
def test_conjunctive_weights_round_trip(m):
    assert_same(from_conjunctive_weights(m.frame, conjunctive_weights(m)), m)


@settings(max_examples=40)
@given(m=masses(3, subnormal=True))
def test_disjunctive_weights_round_trip_and_duality(m):
    v = disjunctive_weights(m)
    assert_same(from_disjunctive_weights(m.frame, v), m)
    np.testing.assert_allclose(v, conjunctive_weights(negation(m))[::-1], rtol=1e-9)  # v(A) = w̄(Ā)


def test_weights_need_a_non_dogmatic_or_subnormal_mass_function():
    with pytest.raises(MassError, match="non-dogmatic.*m\\(Θ\\) = 0.0"):
        conjunctive_weights(MassFunction(ABC, {"w0": 1.0}))
    with pytest.raises(MassError, match="subnormal.*m\\(∅\\) = 0.0"):
        disjunctive_weights(MassFunction(ABC, {"w0": 1.0}))
    with pytest.raises(MassError, match="weights must be 8 finite positive"):
        from_conjunctive_weights(ABC, [1.0] * 7)
    w = np.ones(8)
    w[1] = w[2] = 1.5  # two weights > 1 and nothing to absorb them: m(∅) < 0
    with pytest.raises(MassError, match="not a mass function"):
        from_conjunctive_weights(ABC, w)


@settings(max_examples=40)
@given(m1=masses(3), m2=masses(3, nondogmatic=True))
def test_decombination_inverts_the_conjunctive_rule(m1, m2):
    assert_same(decombine(combine(m1, m2, rule="conjunctive"), m2), m1)


def test_decombination_known_answers():
    # Smets (1995), "The canonical decomposition of a weighted belief", IJCAI: decombination divides
    # the conjunctive weights, A^w12 ⊘ A^w2 = A^(w12 / w2), and removes a simple factor whole.
    a, ab = "w0", "w0|w1"
    close(
        decombine(MassFunction(ABC, {a: 0.7, "w0|w1|w2": 0.3}), MassFunction(ABC, {a: 0.4, "w0|w1|w2": 0.6})),
        {a: 0.5, "w0|w1|w2": 0.5},
    )
    separable = MassFunction(ABC, {a: 0.7, ab: 0.12, "w0|w1|w2": 0.18})  # {a}^0.3 ∩ {a, b}^0.6
    close(decombine(separable, MassFunction(ABC, {ab: 0.4, "w0|w1|w2": 0.6})), {a: 0.7, "w0|w1|w2": 0.3})
    with pytest.raises(MassError, match="not a mass function"):  # w = 0.6 / 0.3 = 2 > 1 with nothing to absorb it
        decombine(MassFunction(ABC, {a: 0.4, "w0|w1|w2": 0.6}), MassFunction(ABC, {a: 0.7, "w0|w1|w2": 0.3}))


def test_decombination_errors_where_it_does_not_exist():
    m2 = MassFunction(ABC, {"w0": 0.5, "w0|w1|w2": 0.5})
    with pytest.raises(MassError, match="not a mass function"):
        decombine(MassFunction(ABC, {"w1": 1.0}), m2)  # nothing combined with m2 is categorical on b
    with pytest.raises(MassError, match="non-dogmatic m2"):
        decombine(m2, MassFunction(ABC, {"w0": 1.0}))


# --- discounting, reinforcement, negation ---------------------------------------------------


@settings(max_examples=40)
@given(m=masses(3), rate=st.floats(0, 1))
def test_contextual_discount_on_theta_is_shafer_discounting(m, rate):
    assert_same(contextual_discount(m, {m.frame.full: rate}), m.discount(1 - rate))


@settings(max_examples=40)
@given(m=masses(3), rates=st.lists(st.floats(0, 1), min_size=3, max_size=3))
def test_contextual_discount_contour(m, rates):
    # Mercier, Quost & Denœux (2008), Information Fusion 9, prop. 5: with the singletons
    # as contexts, pl'({θ}) = 1 - (1 - α_θ)(1 - pl({θ})).
    d = contextual_discount(m, dict(zip(m.frame.elements, rates)))
    for name, a in zip(m.frame.elements, rates):
        assert d.plausibility(name) == pytest.approx(1 - (1 - a) * (1 - m.plausibility(name)), abs=1e-12)


def test_contextual_discount_known_answer():
    # m = {a: 1}, rates b: .5, c: .2: the random set {a} ∪ C, b ∈ C w.p. .5, c ∈ C w.p. .2.
    m = MassFunction(ABC, {"w0": 1.0})
    close(contextual_discount(m, {"w1": 0.5, "w2": 0.2}), {"w0": 0.4, "w0|w1": 0.4, "w0|w2": 0.1, "w0|w1|w2": 0.1})


@settings(max_examples=40)
@given(m=masses(3), rate=st.floats(0, 1), context=st.integers(1, 7))
def test_contextual_reinforcement_is_dual_to_discounting(m, rate, context):
    # Mercier, Lefèvre & Delmotte (2012), IJAR 53: reinforcement = negation ∘ discounting ∘ negation.
    out = contextual_reinforcement(m, {context: rate})
    if context == 7:  # Θ^w is vacuous
        assert_same(out, m)
    else:
        assert_same(out, negation(contextual_discount(negation(m), {7 ^ context: rate})))


def test_negation_is_an_involution_and_swaps_implicability_and_commonality():
    m = MassFunction(ABC, {"w0": 0.5, "w1|w2": 0.2, "w0|w1|w2": 0.3})
    assert_same(negation(negation(m)), m)
    close(negation(m), {"": 0.3, "w1|w2": 0.5, "w0": 0.2})
    for a in range(8):  # Dubois & Prade (1986): the implicability of m̄ is b̄(A) = q(Ā)
        assert negation(m).belief(a) + negation(m)[""] == pytest.approx(m.commonality(7 ^ a), abs=1e-12)


def test_correction_errors_name_the_parameter():
    m = MassFunction(ABC, {"w0": 1.0})
    with pytest.raises(MassError, match="rate of context 'w1' must be a number in \\[0, 1\\], got 1.5"):
        contextual_discount(m, {"w1": 1.5})
    with pytest.raises(MassError, match="non-empty"):
        contextual_reinforcement(m, {"": 0.5})
    with pytest.raises(MassError, match="at least one context"):
        contextual_discount(m, {})


# --- conditioning and deconditioning --------------------------------------------------------


def test_conditioning_known_answers():
    # Smets & Kennes (1994), the TBM: unnormalised conditioning keeps 1 - pl(A) on ∅.
    m = MassFunction(ABC, {"w0": 0.5, "w1|w2": 0.3, "w2": 0.2})
    close(condition(m, "w0|w1", normalise=False), {"": 0.2, "w0": 0.5, "w1": 0.3})
    close(condition(m, "w0|w1"), {"w0": 0.625, "w1": 0.375})
    assert_same(condition(m, "w0|w1"), m.condition("w0|w1"))
    with pytest.raises(TotalConflictError):
        condition(MassFunction(ABC, {"w2": 1.0}), "w0")


def test_deconditioning_known_answer():
    # Smets (1993), IJAR 9, ballooning extension: m'(B ∪ Ā) = m(B).
    m = MassFunction(ABC, {"w0": 0.6, "w0|w1": 0.4})
    close(decondition(m, "w0|w1"), {"w0|w2": 0.6, "w0|w1|w2": 0.4})
    with pytest.raises(MassError, match="inside it, got 'w2'"):
        decondition(MassFunction(ABC, {"w2": 1.0}), "w0")


@settings(max_examples=40)
@given(m=masses(3), a=st.integers(1, 7))
def test_deconditioning_inverts_conditioning(m, a):
    conditioned = condition(m, a, normalise=False)
    assert_same(condition(decondition(conditioned, a), a, normalise=False), conditioned)
    b = decondition(conditioned, a)  # least committed: pl' >= pl of m on every set
    for s in range(1, 8):
        assert b.plausibility(s) >= m.plausibility(s) - 1e-12 or s & a == 0


# --- the generalized Bayesian theorem ---------------------------------------------------------


def test_generalized_bayes_known_answers_and_refusals():
    # Smets (1993), IJAR 9: m(A | x) = prod over A of pl(x | θ) times prod outside A of 1 - pl(x | θ).
    close(
        generalized_bayes(ABC, {"w0": 0.8, "w1": 0.5}, normalise=False), {"": 0.1, "w0": 0.4, "w1": 0.1, "w0|w1": 0.4}
    )
    close(generalized_bayes(ABC, {"w0": 0.8, "w1": 0.5}), {"w0": 0.4 / 0.9, "w1": 0.1 / 0.9, "w0|w1": 0.4 / 0.9})
    close(generalized_bayes(ABC, {"w0": 1.0, "w1": 0.25}), {"w0": 0.75, "w0|w1": 0.25})  # pl 1: in every focal set
    with pytest.raises(TotalConflictError, match="impossible under every element"):
        generalized_bayes(ABC, {"w0": 0.0})
    assert generalized_bayes(ABC, {}, normalise=False).to_dict() == {"": 1.0}
    for bad, match in [
        ({"w9": 0.5}, "not in"),
        ({"w0": 1.5}, r"pl\(x \| w0\) must be a number in \[0, 1\], got 1.5"),
        ({"w0": float("nan")}, "must be a number in"),
        ({"w0": True}, "must be a number in"),
        ({"w0": "0.5"}, "must be a number in"),
    ]:
        with pytest.raises(MassError, match=match):
            generalized_bayes(ABC, bad)
    wide = Frame([f"e{i}" for i in range(100)])  # beyond one machine word: Python-int focal sets
    m = generalized_bayes(wide, {"e0": 0.5, "e70": 0.5, "e99": 1.0})
    assert m.to_dict() == pytest.approx({"e99": 0.25, "e0|e99": 0.25, "e70|e99": 0.25, "e0|e70|e99": 0.25})
    with pytest.raises(MassError, match=r"2\*\*21 focal sets"):
        generalized_bayes(wide, {f"e{i}": 0.5 for i in range(21)})


@settings(max_examples=40)
@given(
    pl=st.lists(st.floats(0, 1), min_size=4, max_size=4),
    prior=st.lists(st.floats(0.01, 1), min_size=4, max_size=4),
)
def test_generalized_bayes_closed_form_and_bayes_theorem(pl, prior):
    frame = FRAMES[4]
    named = dict(zip(frame.elements, pl, strict=True))
    if not any(pl):
        return
    m = generalized_bayes(frame, named)

    def some(a):  # 1 - prod over A of (1 - pl(x | θ)), exact for tiny pl
        inside = [p for i, p in enumerate(pl) if a >> i & 1]
        return 1.0 if 1.0 in inside else -math.expm1(math.fsum(math.log1p(-p) for p in inside))

    for a in range(1, 16):  # pl(A | x), normalised
        assert m.plausibility(a) == pytest.approx(some(a) / some(15), abs=1e-9)
    bayesian = MassFunction(frame, {1 << i: w / sum(prior) for i, w in enumerate(prior)})
    posterior = combine(m, bayesian, rule="dempster")  # Bayes' theorem: prior(θ) pl(x | θ), normalised
    weights = np.array(prior) * np.array(pl)
    for i, w in enumerate(weights / weights.sum()):
        assert posterior[1 << i] == pytest.approx(w, abs=1e-9)


def test_conditioning_on_the_empty_set_and_a_flag_that_is_no_bool():
    m = MassFunction(ABC, {"w0": 0.5, "w1|w2": 0.5})
    with pytest.raises(TotalConflictError):
        condition(m, "")  # as m.condition("") says
    with pytest.raises(TotalConflictError):
        m.condition("")
    assert condition(m, "", normalise=False).to_dict() == {"": 1.0}  # the TBM: everything to ∅
    with pytest.raises(TypeError, match="normalise must be True or False, got 'no'"):
        condition(m, "w0", normalise="no")
