"""The shared check suite: every registered rule against the properties it claims."""

import itertools

import numpy as np
import pytest
from engine_fixtures import assert_same, needs, sources, vacuous
from hypothesis import given, reject, settings
from hypothesis import strategies as st

from evidential import RULES, MassFunction, TotalConflictError, combine

ALL = sorted(RULES)
SUITE = settings(max_examples=25)


def claims(prop):
    return [name for name in ALL if prop in RULES[name].properties]


def run(name, *ms):
    try:
        return combine(*ms, rule=name)
    except TotalConflictError:
        reject()


@pytest.mark.parametrize("name", ALL)
@SUITE
@given(data=st.data())
def test_result_is_a_valid_mass_function(name, data):
    rule = RULES[name]
    ms = data.draw(sources(3, **needs(rule)))
    for k in (1, 2, 3):
        m = run(name, *ms[:k])
        assert np.all(m.masses > 0)
        assert abs(m.masses.sum() - 1) < 1e-9
        if not rule.open_world:
            assert m[""] == 0.0


@pytest.mark.parametrize("name", ALL)
@SUITE
@given(data=st.data())
def test_bel_betp_pl_ordering_on_results(name, data):
    ms = data.draw(sources(3, **needs(RULES[name])))
    m = run(name, *ms)
    if m[""] > 0:
        return
    betp = m.pignistic()
    frame = m.frame
    for mask in range(1, frame.full + 1):
        p = sum(v for i, v in enumerate(betp.values()) if mask >> i & 1)
        assert m.belief(mask) - 1e-9 <= p <= m.plausibility(mask) + 1e-9


@pytest.mark.parametrize("name", claims("commutative"))
@SUITE
@given(data=st.data())
def test_commutative(name, data):
    ms = data.draw(sources(3, **needs(RULES[name])))
    first = run(name, *ms)
    for order in itertools.permutations(ms):
        assert_same(combine(*order, rule=name), first)


@pytest.mark.parametrize("name", claims("associative"))
@SUITE
@given(data=st.data())
def test_associative(name, data):
    a, b, c = data.draw(sources(3, **needs(RULES[name])))
    left = run(name, run(name, a, b), c)
    assert_same(left, combine(a, combine(b, c, rule=name), rule=name))
    assert_same(left, combine(a, b, c, rule=name))


@pytest.mark.parametrize("name", claims("vacuous_identity"))
@SUITE
@given(data=st.data())
def test_vacuous_identity(name, data):
    (m,) = data.draw(sources(1, **needs(RULES[name])))
    assert_same(combine(m, vacuous(m.frame), rule=name), m)
    assert_same(combine(vacuous(m.frame), m, rule=name), m)


@pytest.mark.parametrize("name", claims("idempotent"))
@SUITE
@given(data=st.data())
def test_idempotent(name, data):
    (m,) = data.draw(sources(1, **needs(RULES[name])))
    assert_same(combine(m, m, rule=name), m)
    assert_same(combine(m, m, m, rule=name), m)


@pytest.mark.parametrize("name", claims("bayes_on_bayesian"))
@SUITE
@given(ms=sources(3, bayes=True))
def test_equals_bayes_on_bayesian_masses(name, ms):
    assert_same(run(name, *ms), combine(*ms, rule="bayes"))


def test_every_rule_claims_only_known_properties_and_dempster_claims_bayes():
    assert "bayes_on_bayesian" in RULES["dempster"].properties
    assert RULES["conjunctive"].open_world and not RULES["dempster"].open_world
    assert RULES["cautious"].nondogmatic


@given(ms=sources(2))
def test_conjunctive_keeps_conflict_on_empty_set(ms):
    from evidential import conflict

    m = combine(*ms, rule="conjunctive")
    assert m[""] == pytest.approx(conflict(*ms), abs=1e-12)
    agreed = sum(v for mask, v in zip(m.masks, m.masses) if mask)  # 1 - K, without K's rounding
    if agreed > 0:  # else total conflict, though K may round to a hair under 1
        d = combine(*ms, rule="dempster")
        for mask, v in zip(d.masks, d.masses):
            assert v == pytest.approx(m[int(mask)] / agreed, abs=1e-9)


@given(ms=sources(3))
def test_murphy_is_dempster_of_the_average(ms):
    frame = ms[0].frame
    mean = MassFunction.from_dense(frame, sum(m.dense() for m in ms) / 3)
    assert_same(combine(*ms, rule="murphy"), combine(mean, mean, mean, rule="dempster"))
