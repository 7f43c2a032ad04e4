"""The fast paths give the general paths' answers: the plain-Python Dempster fold of tiny frames,
the int32 batched queries, the unpacked-bits membership, the zeta transform into a new array."""

from functools import reduce

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, MassFunction, TotalConflictError, combine
from evidential.rules import RULES
from evidential.stack import (
    PYTHON_MAX_BITS,
    PYTHON_MAX_SETS,
    Stack,
    dempster_pair,
    dempster_python,
    element_masses,
    membership,
)
from evidential.transforms import pignistic, sweep

weight = st.one_of(st.floats(0.01, 1.0), st.sampled_from([1e-200, 1e-160, 1e-300]))


@st.composite
def tiny_sources(draw) -> tuple[int, list[Stack]]:
    """2 to 6 single mass functions (N = 1) on a frame of 1 to 3 elements, each with at most
    :data:`PYTHON_MAX_SETS` focal sets, some holding ∅ and some near-underflowing masses."""
    n = draw(st.integers(1, PYTHON_MAX_BITS))
    stacks = []
    for _ in range(draw(st.integers(2, 6))):
        sets = draw(st.lists(st.integers(0, (1 << n) - 1), min_size=1, max_size=PYTHON_MAX_SETS, unique=True))
        w = np.array(draw(st.lists(weight, min_size=len(sets), max_size=len(sets))))
        order = np.argsort(sets)
        stacks.append(Stack(np.array(sets, dtype=np.int64)[order], (w / w.sum())[order, None]))
    return n, stacks


def numpy_fold(stacks: list[Stack], n: int) -> Stack | None:
    """The numpy pair kernel folded over the sources (None as soon as a step is None)."""
    result = stacks[0]
    for s in stacks[1:]:
        result = dempster_pair(result, s, n)
        if result is None:
            return None
    return result


@given(tiny_sources())
def test_python_fold_is_the_numpy_fold_bit_for_bit(case):
    n, stacks = case
    python, fold = dempster_python(stacks, n), numpy_fold(stacks, n)
    assert (python is None) == (fold is None)
    if fold is not None:
        assert python.masks.tolist() == fold.masks.tolist()
        assert python.masses.tolist() == fold.masses.tolist()  # the same bits, not only close


@given(tiny_sources())
def test_python_fold_is_the_general_rule(case):
    n, stacks = case
    try:
        general = RULES["dempster"].function(stacks, n)
    except TotalConflictError:
        assert dempster_python(stacks, n) is None
        return
    python = dempster_python(stacks, n)
    if python is None:  # underflow: combine takes the scaled path, checked below
        return
    dense = np.zeros(1 << n)
    dense[general.masks] = general.masses[:, 0]
    assert np.abs(dense[python.masks] - python.masses[:, 0]).max() <= 1e-15
    assert dense[np.setdiff1d(np.arange(1 << n), python.masks)].max(initial=0.0) <= 1e-15


@given(tiny_sources())
def test_combine_on_tiny_frames_equals_the_rule_on_wider_ones(case):
    """The same masses on a frame of 6 elements (numpy kernels) give the same combination."""
    n, stacks = case
    small, wide = Frame([f"e{i}" for i in range(n)]), Frame([f"e{i}" for i in range(6)])
    tiny = [MassFunction(small, dict(zip(s.masks.tolist(), s.masses[:, 0].tolist())), open_world=True) for s in stacks]
    big = [MassFunction(wide, dict(zip(s.masks.tolist(), s.masses[:, 0].tolist())), open_world=True) for s in stacks]
    try:
        expected = combine(*big)
    except TotalConflictError:
        with pytest.raises(TotalConflictError):
            combine(*tiny)
        return
    got = combine(*tiny)
    assert got.masks.tolist() == expected.masks.tolist()
    np.testing.assert_allclose(got.masses, expected.masses, rtol=0, atol=1e-15)
    try:
        by_hand = reduce(lambda a, b: combine(a, b), tiny)
    except TotalConflictError:
        # a product underflowed to 0 in a step of the fold by hand (1e-200 x 1e-201), its set lost,
        # and a later step found no set in common: the n-ary call went the rescaled way
        assert dempster_python(stacks, n) is None
        return
    assert by_hand.isclose(got, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("n", [5, 31, 32, 40, 63])
def test_batched_queries_equal_the_single_ones(n):
    """bel, pl and q of many sets at once (int32 up to 31 elements) equal the one-set queries."""
    rng = np.random.default_rng(n)
    frame = Frame([f"e{i}" for i in range(n)])
    sets = np.unique(rng.integers(0, 1 << n, size=40, dtype=np.int64))
    sets[-1] = frame.full  # the top bit in use
    w = rng.dirichlet(np.ones(sets.size))
    m = MassFunction(frame, dict(zip(sets.tolist(), w.tolist())), open_world=True)
    queries = np.concatenate([sets, rng.integers(0, 1 << n, size=60, dtype=np.int64), [0, frame.full]])
    for query in (m.belief, m.plausibility, m.commonality):
        one_by_one = np.array([query(int(a)) for a in queries])
        np.testing.assert_allclose(query(queries), one_by_one, rtol=0, atol=1e-15)
        np.testing.assert_allclose(query(queries.tolist()), one_by_one, rtol=0, atol=1e-15)


@pytest.mark.parametrize("n", [1, 7, 20, 63])
def test_membership_unpacks_the_bits(n):
    masks = np.unique(np.random.default_rng(n).integers(0, 1 << n, size=50, dtype=np.int64))
    expected = [[float(int(k) >> i & 1) for i in range(n)] for k in masks]
    assert membership(masks, n).tolist() == expected
    assert membership(masks.astype(object), n).tolist() == expected


@pytest.mark.parametrize("with_empty", [False, True])
def test_sparse_pignistic_equals_the_dense_transform(with_empty):
    rng = np.random.default_rng(3)
    masks = np.unique(rng.integers(1, 1 << 10, size=200))
    if with_empty:
        masks = np.concatenate([[0], masks])
    w = rng.dirichlet(np.ones(masks.size))
    dense = np.zeros(1 << 10)
    dense[masks] = w
    sparse = element_masses(Stack(masks, w[:, None]), 10, split=True)[:, 0]
    np.testing.assert_allclose(sparse, pignistic(dense), rtol=0, atol=1e-15)


@pytest.mark.parametrize("superset", [True, False])
@pytest.mark.parametrize("inverse", [True, False])
@pytest.mark.parametrize("shape", [(2,), (16,), (8, 5), (1024, 3)])
def test_sweep_into_a_new_array_is_the_sweep_in_place(superset, inverse, shape):
    x = np.random.default_rng(shape[0]).random(shape)
    before = x.copy()
    into = sweep(x, superset, inverse, out=np.empty(shape))
    assert into.tolist() == sweep(x.copy(), superset, inverse).tolist()  # the same bits
    assert x.tolist() == before.tolist()  # the input left as it is
