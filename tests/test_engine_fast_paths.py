"""The fast paths give the general paths' answers: the plain-Python Dempster fold of tiny frames,
Dempster's rule of tiny dense batches by columns, the int32 batched queries, the plain-Python
one-set queries, the unpacked-bits membership, the zeta transform into a new array."""

from functools import reduce

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import Frame, MassFunction, TotalConflictError, columns, combine, combine_batch, conflict
from evidential.columns import COLUMN_MAX_BITS, dempster_columns
from evidential.elements import element_masses, membership
from evidential.queries import PYTHON_MAX_SETS as QUERY_PYTHON_MAX_SETS
from evidential.queries import belief, commonality, plausibility, python_pairs
from evidential.registry import RULES
from evidential.stack import (
    PYTHON_MAX_BITS,
    PYTHON_MAX_SETS,
    SCALE_FLOOR,
    Stack,
    aggregate,
    dempster_pair,
    dempster_python,
    dempster_scaled,
    full,
    pairwise,
    to_dense,
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


@st.composite
def tiny_batches(draw, count: int | None = None) -> tuple[int, list[np.ndarray]]:
    """``count`` (or 1 to 4) dense batches of 1 to 12 rows on a frame of 1 to :data:`COLUMN_MAX_BITS` elements,
    rows with mass on ∅ (Dempster's rule takes it as conflict), on few sets, near-underflowing masses."""
    n, rows = draw(st.integers(1, COLUMN_MAX_BITS)), draw(st.integers(1, 12))
    batches = []
    for _ in range(count or draw(st.integers(1, 4))):
        cells = st.lists(st.one_of(st.just(0.0), weight), min_size=1 << n, max_size=1 << n)
        w = np.array(draw(st.lists(cells, min_size=rows, max_size=rows)))
        w[w.sum(axis=1) == 0, -1] = 1.0
        batches.append(w / w.sum(axis=1, keepdims=True))
    return n, batches


def pairwise_sums(batches: list[np.ndarray], n: int) -> np.ndarray:
    """The rule's pairwise path written out: the dense sums of the conjunctive fold (``aggregate`` of ``pairwise``)."""
    stacks = [full(np.ascontiguousarray(b.T)) for b in batches]
    return to_dense(reduce(lambda a, b: aggregate(*pairwise(a, b, np.bitwise_and), n), stacks), n)


@given(tiny_batches())
def test_dempster_columns_are_the_pairwise_fold_bit_for_bit(case):
    n, batches = case
    views = [b.T for b in batches]
    sums = pairwise_sums(batches, n)
    z = sums[1:].sum(axis=0)  # the non-empty total, as the rule adds it
    kept = [b.copy() for b in batches]
    got = dempster_columns(views, n)
    assert all(b.tolist() == k.tolist() for b, k in zip(batches, kept))  # the sources left as they are
    if not z.min() >= SCALE_FLOOR:  # total conflict or underflow: the general path's
        assert got is None
        return
    assert got.flags.c_contiguous and not any(np.may_share_memory(got, b) for b in batches)
    assert got[0].tolist() == [0.0] * got.shape[1]
    assert got[1:].tolist() == (sums[1:] / z).tolist()  # the same bits, not only close


@pytest.mark.parametrize("n", range(1, COLUMN_MAX_BITS + 1))
@pytest.mark.parametrize("count", [2, 3])
@pytest.mark.parametrize("block", [None, 7])
def test_dempster_columns_on_random_batches_are_the_pairwise_fold_bit_for_bit(n, count, block, monkeypatch):
    """Dirichlet rows (every third without mass on ∅): one in a few three-term sums rounds
    differently in another order, which a thousand rows show; in blocks of 7 rows too."""
    if block:
        monkeypatch.setattr(columns, "COLUMN_BLOCK", block)
    rng = np.random.default_rng([n, count])
    batches = [rng.dirichlet(np.ones(1 << n), 1000) for _ in range(count)]
    for b in batches:
        b[::3, 0] = 0.0
        b /= b.sum(axis=1, keepdims=True)
    sums = pairwise_sums(batches, n)
    got = dempster_columns([b.T for b in batches], n)
    assert got[1:].tolist() == (sums[1:] / sums[1:].sum(axis=0)).tolist()


@given(tiny_batches())
def test_combine_batch_on_tiny_frames_takes_the_columns_or_the_general_path(case):
    """The columns where they apply; where a row underflows or is in total conflict, what the
    general path (Möbius or pairwise, then the rescaled fold) gives, or its error."""
    n, batches = case
    columns = dempster_columns([b.T for b in batches], n)
    if columns is not None:
        assert combine_batch(*batches).tolist() == columns.T.tolist()
        return
    stacks = [full(np.ascontiguousarray(b.T)) for b in batches]
    try:
        general = to_dense(RULES["dempster"].function(stacks, n), n).T
    except TotalConflictError as error:
        with pytest.raises(TotalConflictError, match=str(error).split(":")[0].replace("(", r"\(").replace(")", r"\)")):
            combine_batch(*batches)
        return
    assert combine_batch(*batches).tolist() == general.tolist()


@given(tiny_batches(count=2))
def test_combine_batch_on_tiny_frames_is_combine_of_each_row(case):
    """Row by row, what combine gives on the objects: the same bits where the row has conflict
    (both divide by the same total), within round-off where it has none (combine does not divide)."""
    n, (M1, M2) = case
    frame = Frame([f"e{i}" for i in range(n)])
    for r1, r2 in zip(M1, M2):
        objects = [MassFunction.from_dense(frame, r, open_world=True) for r in (r1, r2)]
        try:
            expected = combine(*objects).dense()
        except TotalConflictError:
            with pytest.raises(TotalConflictError):
                combine_batch(r1[None], r2[None])
            continue
        got = combine_batch(r1[None], r2[None])[0]
        if conflict(*objects) > 0 and dempster_python([o.stack for o in objects], n) is not None:
            assert got.tolist() == expected.tolist()
        else:
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-15)


def test_combine_batch_rescales_rows_that_underflow():
    """Products of 1e-160 masses are subnormal (1e-320, few digits): the batch goes the rescaled way."""
    M1 = np.array([[1 - 4e-160, 3e-160, 1e-160, 0.0], [0.0, 0.5, 0.5, 0.0]])
    M2 = np.array([[1 - 2e-160, 1e-160, 1e-160, 0.0], [0.0, 0.5, 0.0, 0.5]])
    assert dempster_columns([M1.T, M2.T], 2) is None
    stacks = [Stack(np.arange(4), M.T.copy()) for M in (M1, M2)]
    assert combine_batch(M1, M2).tolist() == to_dense(dempster_scaled(stacks, 2), 2).T.tolist()
    np.testing.assert_allclose(combine_batch(M1, M2), [[0, 0.75, 0.25, 0], [0, 2 / 3, 1 / 3, 0]], rtol=1e-15, atol=0)


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


QUERIES = (belief, plausibility, commonality)


@st.composite
def small_stacks(draw) -> tuple[Frame, Stack, list[int]]:
    """One mass function of 1 to :data:`~evidential.queries.PYTHON_MAX_SETS` focal sets (increasing, ∅
    first in some) with positive masses of any size (not summing to 1), on a frame of 1 to 4 elements or
    of 64 (Python int bitmasks); and the sets to query: all of them, or the focal sets and random ones."""
    n = draw(st.sampled_from([1, 2, 3, 4, 64]))
    frame = Frame([f"e{i}" for i in range(n)])
    sets = sorted(draw(st.lists(st.integers(0, frame.full), min_size=1, max_size=QUERY_PYTHON_MAX_SETS, unique=True)))
    w = draw(st.lists(st.floats(1e-300, 1.0), min_size=len(sets), max_size=len(sets)))
    stack = Stack(np.array(sets, dtype=frame.dtype), np.array(w)[:, None])
    asked = range(frame.full + 1) if n <= 4 else [0, frame.full, *sets, *draw(st.lists(st.integers(0, frame.full)))]
    return frame, stack, list(asked)


@settings(max_examples=500)
@given(small_stacks())
def test_one_set_queries_in_python_are_the_numpy_ones_bit_for_bit(case):
    """bel, pl and q of one set summed in Python, left to right, are numpy's floats (fewer than 8 values)."""
    frame, stack, asked = case
    pairs = python_pairs(stack)
    assert pairs == list(zip(stack.masks.tolist(), stack.masses[:, 0].tolist()))
    m = MassFunction.from_stack(frame, stack, positive=True)
    for query, method in zip(QUERIES, (m.belief, m.plausibility, m.commonality)):
        for a in asked:
            expected = query(frame, stack, a)  # the numpy path
            assert query(frame, stack, a, pairs) == expected
            assert method(a) == expected and method(frame.label(a)) == expected


def test_one_set_queries_in_python_on_many_random_stacks():
    """The same on 3000 random stacks of 1 to 7 focal sets on 3 elements, ∅ first in some, masses 1e-20 to 100."""
    rng = np.random.default_rng(41)
    frame = Frame(["a", "b", "c"])
    for _ in range(3000):
        sets = np.sort(rng.choice(8, size=rng.integers(1, 8), replace=False))
        sets[0] = 0 if rng.random() < 1 / 3 else sets[0]
        sets = np.unique(sets)
        stack = Stack(sets, (rng.random(sets.size) * 10.0 ** rng.integers(-20, 3, sets.size))[:, None])
        pairs = python_pairs(stack)
        for query in QUERIES:
            assert [query(frame, stack, a, pairs) for a in range(8)] == [query(frame, stack, a) for a in range(8)]


def test_python_pairs_only_up_to_seven_focal_sets():
    """From 8 values numpy sums in blocks of 8 (pairwise), not left to right: those stacks stay with numpy."""
    for k in (QUERY_PYTHON_MAX_SETS, QUERY_PYTHON_MAX_SETS + 1):
        stack = Stack(np.arange(1, k + 1), np.full((k, 1), 1 / k))
        assert (python_pairs(stack) is None) == (k > QUERY_PYTHON_MAX_SETS)
    eights = np.random.default_rng(8).random((100, 8))
    assert any(float(row.sum()) != reduce(lambda total, w: total + w, row.tolist(), 0.0) for row in eights)


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
