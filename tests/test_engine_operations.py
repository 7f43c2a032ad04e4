"""Discounting, conditioning, Jousselme distance and decisions."""

import pytest
from engine_fixtures import PAPER, assert_same, masses, vacuous
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import Frame, FrameError, MassError, MassFunction, TotalConflictError, combine, jousselme_distance

any_mass = st.integers(1, 4).flatmap(masses)


def test_discount_known_values():
    m = MassFunction(PAPER, {"real": 0.8, "noise": 0.2})
    assert m.discount(0.9).to_dict() == pytest.approx({"real": 0.72, "noise": 0.18, "real|noise": 0.1})
    assert m.discount(0.0).to_dict() == {"real|noise": 1.0}


@settings(max_examples=30)
@given(m=any_mass)
def test_discount_by_one_is_identity(m):
    assert_same(m.discount(1.0), m, tol=1e-15)


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), True])
def test_discount_rejects_bad_reliability(bad):
    with pytest.raises(MassError, match="reliability"):
        MassFunction(PAPER, {"real": 1.0}).discount(bad)


@settings(max_examples=30)
@given(m=any_mass)
def test_conditioning_is_dempster_with_a_categorical_mass(m):
    a = m.masks[0]
    assert_same(m.condition(int(a)), combine(m, MassFunction(m.frame, {int(a): 1.0})))
    assert_same(m.condition(m.frame.full), m)


def test_conditioning_on_an_impossible_set_raises():
    frame = Frame(["a", "b", "c"])
    with pytest.raises(TotalConflictError, match="'c'.*plausibility is 0"):
        MassFunction(frame, {"a|b": 1.0}).condition("c")


def test_jousselme_distance_known_values():
    frame = Frame(["a", "b"])
    a, b, ab = (MassFunction(frame, {s: 1.0}) for s in ("a", "b", "a|b"))
    assert jousselme_distance(a, b) == pytest.approx(1.0)
    assert jousselme_distance(a, ab) == pytest.approx(0.5**0.5)
    half = MassFunction(frame, {"a": 0.5, "b": 0.5})
    assert jousselme_distance(a, half) == pytest.approx(0.5)  # sqrt(.5 (.25 + .25))
    with pytest.raises(FrameError):
        jousselme_distance(a, vacuous(PAPER))


@settings(max_examples=30)
@given(data=st.data())
def test_jousselme_is_a_metric_sample(data):
    n = data.draw(st.integers(1, 4))
    x, y = data.draw(masses(n)), data.draw(masses(n))
    assert jousselme_distance(x, x) == pytest.approx(0.0, abs=1e-7)
    assert jousselme_distance(x, y) == pytest.approx(jousselme_distance(y, x))
    assert 0 <= jousselme_distance(x, y) <= 1 + 1e-12


def test_decisions():
    m = MassFunction(PAPER, {"noise": 0.4, "real|noise": 0.6})
    assert m.max_belief() == "noise" and m.max_pignistic() == "noise"
    m = MassFunction(PAPER, {"real": 0.3, "noise": 0.2, "real|noise": 0.5})
    assert m.max_pignistic() == "real"
    assert m.max_belief(["real", "real|noise"]) == "real|noise"
    tie = MassFunction(PAPER, {"real|noise": 1.0})
    assert tie.max_belief() == "real" and tie.max_pignistic() == "real"
