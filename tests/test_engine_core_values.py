"""Defects of the engine core: undefined transforms, underflow, numpy integers, values, non-finite input."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evidential import EvidentialError, Frame, MassError, MassFunction, UndefinedTransformError
from evidential import transforms as T

FRAME = Frame(["a", "b", "c"])


def test_transforms_of_all_mass_on_the_empty_set_are_undefined():
    m = MassFunction(FRAME, {"": 1.0}, open_world=True)
    for query in (m.pignistic, m.plausibility_transform, m.max_pignistic):
        with pytest.raises(UndefinedTransformError, match=r"m\(∅\) = 1"):
            query()
    assert issubclass(UndefinedTransformError, EvidentialError)
    for transform in (T.pignistic, T.plausibility_transform):
        with pytest.raises(UndefinedTransformError, match=r"m\(∅\) = 1"):
            transform(m.dense())
        with pytest.raises(UndefinedTransformError, match=r"batch row \(1,\)"):
            transform([[0.0, 1.0], [1.0, 0.0]])


@pytest.mark.parametrize("n", [3, 40, 100])
def test_pignistic_of_a_tiny_mass_normalises_before_splitting(n):
    frame = Frame([f"e{i}" for i in range(n)])
    m = MassFunction(frame, {"": 1.0, "e0|e1": 2e-162}, open_world=True)
    p = m.pignistic()
    assert p["e0"] == p["e1"] == 0.5 and sum(p.values()) == 1.0
    assert m.plausibility_transform()["e1"] == 0.5
    if n <= 20:
        assert T.pignistic(m.dense())[:2].tolist() == [0.5, 0.5]
        assert T.plausibility_transform(m.dense())[:2].tolist() == [0.5, 0.5]


def test_numpy_integers_are_focal_sets_but_bools_are_not():
    m = MassFunction(FRAME, {np.int64(3): 0.5, np.uint8(7): 0.5})
    assert m[np.int64(3)] == 0.5 and m[m.masks[1]] == 0.5 and np.int32(3) in m
    assert MassFunction(FRAME, dict(zip(m.masks, m.masses))) == m
    for bad in (True, np.True_):
        with pytest.raises(EvidentialError, match="bool"):
            MassFunction(FRAME, {bad: 1.0})
        with pytest.raises(TypeError, match="bool"):
            bad in m  # noqa: B015


def test_equality_is_by_content():
    m = MassFunction(FRAME, {"a": 0.25, "b|c": 0.75})
    same = MassFunction(FRAME, {"c|b": 0.75, 1: 0.25})
    assert m == same and hash(m) == hash(same) and len({m, same}) == 1
    assert m != MassFunction(FRAME, {"a": 0.25, "b|c": 0.7500000000000001})
    assert m != MassFunction(Frame(["a", "b", "d"]), {"a": 0.25, "b|d": 0.75})
    assert m != MassFunction(FRAME, {"a": 0.25, "b": 0.75})
    assert m != {"a": 0.25, "b|c": 0.75}


def test_isclose():
    m = MassFunction(FRAME, {"a": 0.25, "b|c": 0.75})
    assert m.isclose(MassFunction(FRAME, {"a": 0.25 + 1e-12, "b|c": 0.75 - 1e-12}))
    assert not m.isclose(MassFunction(FRAME, {"a": 0.25 + 1e-6, "b|c": 0.75 - 1e-6}))
    assert m.isclose(MassFunction(FRAME, {"a": 0.25 + 1e-6, "b|c": 0.75 - 1e-6}), atol=1e-5)
    assert not m.isclose(MassFunction(FRAME, {"a": 0.25, "b|c": 0.75 - 1e-13, "c": 1e-13}))
    assert m.isclose(MassFunction(FRAME, {"a": 0.25, "b|c": 0.75 - 1e-13, "c": 1e-13}), atol=1e-12)
    assert not m.isclose(MassFunction(Frame(["a", "b", "d"]), {"a": 0.25, "b|d": 0.75}))
    with pytest.raises(TypeError, match="MassFunction"):
        m.isclose({"a": 0.25})


def test_membership_and_iteration():
    m = MassFunction(FRAME, {"a": 0.3, "b|c": 0.7})
    assert "a" in m and "b|c" in m and "c|b" in m and ("c", "b") in m and 6 in m and np.int64(1) in m
    assert "b" not in m and "" not in m and 0 not in m and "z" not in m and 99 not in m
    for bad in (0.3, 1.0, np.float64(0.3), None):
        with pytest.raises(TypeError, match="'in' tests a focal set"):
            bad in m  # noqa: B015
    assert list(m) == ["a", "b|c"] and dict(zip(m, m.masses)) == m.to_dict()


@pytest.mark.parametrize(
    "function", [T.commonality, T.implicability, T.belief, T.plausibility, T.pignistic, T.plausibility_transform]
)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_transforms_refuse_non_finite_input(function, bad):
    with pytest.raises(MassError, match=r"finite: entry \(1, 2\) is"):
        function([[0.0, 0.5, 0.25, 0.25], [0.0, 0.5, bad, 0.5]])


@pytest.mark.parametrize(
    "function", [T.mass_from_commonality, T.mass_from_implicability, T.mass_from_belief, T.mass_from_plausibility]
)
def test_inverse_transforms_refuse_non_finite_input(function):
    with pytest.raises(MassError, match="finite"):
        function([0.0, math.nan, 0.5, 1.0])


masses = st.dictionaries(st.integers(1, 15), st.floats(0.01, 1.0), min_size=1, max_size=8)


@given(masses, st.lists(st.integers(0, 15), min_size=1, max_size=10))
def test_batched_queries_match_one_by_one(weights, sets):
    frame = Frame(["a", "b", "c", "d"])
    total = math.fsum(weights.values())
    m = MassFunction(frame, {k: v / total for k, v in weights.items()}, open_world=False)
    for query in (m.belief, m.plausibility, m.commonality):
        many = query(np.array(sets))
        assert many.shape == (len(sets),)
        np.testing.assert_allclose(many, [query(s) for s in sets], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(query([frame.label(s) for s in sets]), many)
    betp = T.pignistic(m.dense())
    np.testing.assert_allclose(list(m.pignistic().values()), betp, rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        list(m.plausibility_transform().values()), T.plausibility_transform(m.dense()), atol=1e-15
    )
