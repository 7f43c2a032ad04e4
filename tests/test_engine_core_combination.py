"""Combination without false total conflict from underflow, and the n-ary call equal to the fold."""

from functools import reduce

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, MassFunction, TotalConflictError, combine, combine_batch

FRAME = Frame(["a", "b", "c"])


@pytest.mark.parametrize("tiny", [1e-200, 1e-160, 1e-155])
@pytest.mark.parametrize("frame", [FRAME, Frame([f"e{i}" for i in range(20)]), Frame([f"e{i}" for i in range(70)])])
def test_dempster_of_tiny_agreeing_masses_is_exact(tiny, frame):
    a, b, c = frame.elements[:3]
    m1 = MassFunction(frame, {a: tiny, b: 1.0 - tiny})
    m2 = MassFunction(frame, {a: tiny, c: 1.0 - tiny})
    assert combine(m1, m2).to_dict() == {a: 1.0}
    m3 = MassFunction(frame, {f"{a}|{b}": tiny, c: 1.0 - tiny})
    assert combine(m1, m2, m3).to_dict() == {a: 1.0}


def test_dempster_tiny_mixture_keeps_its_ratio():
    frame = Frame(["a", "b", "c", "d"])
    m1 = MassFunction(frame, {"a": 3e-200, "b": 1e-200, "c": 1.0 - 4e-200})
    m2 = MassFunction(frame, {"a|b": 1e-200, "d": 1.0 - 1e-200})
    m3 = MassFunction(frame, {"a|b|c": 1.0})
    want = MassFunction(frame, {"a": 0.75, "b": 0.25})
    assert combine(m1, m2).isclose(want, rtol=1e-15) and combine(m1, m2, m3).isclose(want, rtol=1e-15)


def test_batch_dempster_of_tiny_agreeing_masses():
    M1 = np.array([[0, 1e-200, 1 - 1e-200, 0, 0, 0, 0, 0], [0, 0.5, 0.5, 0, 0, 0, 0, 0]])
    M2 = np.array([[0, 1e-200, 0, 0, 1 - 1e-200, 0, 0, 0], [0, 0.5, 0, 0, 0, 0, 0, 0.5]])
    np.testing.assert_array_equal(combine_batch(M1, M2)[0], [0, 1, 0, 0, 0, 0, 0, 0])


def test_true_total_conflict_still_raises():
    m1, m2 = MassFunction(FRAME, {"a": 1.0}), MassFunction(FRAME, {"b|c": 1.0})
    with pytest.raises(TotalConflictError, match=r"K = 1\.0"):
        combine(m1, m2)
    with pytest.raises(TotalConflictError, match=r"K = 1\.0"):
        combine(m1, MassFunction(FRAME, {"a|b|c": 1.0}), m2)
    with pytest.raises(TotalConflictError):
        combine(m1, m2, rule="bayes")


def test_bayes_over_600_sources():
    frame = Frame([f"e{i}" for i in range(5)])
    m = MassFunction(frame, {f"e{i}": 0.2 for i in range(5)})
    assert combine(*[m] * 600, rule="bayes").to_dict() == {f"e{i}": 0.2 for i in range(5)}
    skew = MassFunction(frame, {"e0": 0.1, "e1": 0.2, "e2": 0.3, "e3": 0.4})
    p = combine(*[skew] * 600, rule="bayes")
    assert p["e3"] == 1.0 and p["e2"] == pytest.approx(0.75**600, rel=1e-12) and p["e1"] == pytest.approx(0.5**600)


focal = st.integers(1, 15)
masses = st.dictionaries(focal, st.floats(0.05, 1.0), min_size=1, max_size=5)


@given(st.lists(masses, min_size=2, max_size=12))
def test_n_ary_dempster_is_the_fold(weights):
    frame = Frame(["a", "b", "c", "d"])
    ms = [MassFunction(frame, {k: v / sum(w.values()) for k, v in w.items()}) for w in weights]
    try:
        folded = reduce(lambda a, b: combine(a, b), ms)
    except TotalConflictError:
        with pytest.raises(TotalConflictError):
            combine(*ms)
        return
    assert combine(*ms).isclose(folded, rtol=1e-12, atol=1e-15)
    assert combine(*ms).isclose(combine(*ms, rule="conjunctive").condition("a|b|c|d"), rtol=1e-9, atol=1e-15)
