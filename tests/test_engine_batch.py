"""combine_batch on (N, 2**n) arrays agrees with combine on objects; batch errors."""

import numpy as np
import pytest
from engine_fixtures import masses, needs
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import RULES, MassError, MassFunction, TotalConflictError, combine, combine_batch


@st.composite
def batches(draw, needs):
    """3 sources x 4 rows over one frame, as objects and as dense arrays."""
    n = draw(st.integers(1, 4))
    rows = [[draw(masses(n, **needs)) for _ in range(3)] for _ in range(4)]
    return rows, [np.array([r[s].dense() for r in rows]) for s in range(3)]


@pytest.mark.parametrize("name", sorted(RULES))
@settings(max_examples=20)
@given(data=st.data())
def test_batch_equals_objects(name, data):
    rows, arrays = data.draw(batches(needs(RULES[name])))
    for k in (2, 3):
        try:
            expected = [combine(*r[:k], rule=name).dense() for r in rows]
        except TotalConflictError:
            with pytest.raises(TotalConflictError):
                combine_batch(*arrays[:k], rule=name)
            continue
        np.testing.assert_allclose(combine_batch(*arrays[:k], rule=name), expected, rtol=0, atol=1e-12)


def test_dense_path_on_full_power_sets_agrees_with_pairwise():
    # 6 elements, every focal set: the Möbius strategy; objects of a row use the same.
    rng = np.random.default_rng(3)
    M1, M2, M3 = (np.column_stack([np.zeros(50), rng.dirichlet(np.ones(63), 50)]) for _ in range(3))
    from evidential import Frame

    frame = Frame([f"e{i}" for i in range(6)])
    for name in ("dempster", "conjunctive", "disjunctive", "yager", "murphy"):
        out = combine_batch(M1, M2, M3, rule=name)
        for j in (0, 17, 49):
            # reference: a pairwise fold of the sparse objects with some zero masses
            objs = [MassFunction.from_dense(frame, M[j], open_world=True) for M in (M1, M2, M3)]
            ref = combine(*objs, rule=name).dense()
            np.testing.assert_allclose(out[j], ref, atol=1e-12)


def test_robot_case_real_noise_batch():
    rng = np.random.default_rng(0)
    M1 = np.column_stack([np.zeros(10_000), rng.dirichlet(np.ones(3), 10_000)])
    M2 = np.column_stack([np.zeros(10_000), rng.dirichlet(np.ones(3), 10_000)])
    out = combine_batch(M1, M2, rule="dempster")
    assert out.shape == (10_000, 4)
    np.testing.assert_allclose(out.sum(axis=1), 1.0, atol=1e-12)
    conj = combine_batch(M1, M2, rule="conjunctive")
    np.testing.assert_allclose(out[:, 1:], conj[:, 1:] / (1 - conj[:, :1]), atol=1e-12)
    np.testing.assert_allclose(combine_batch(out.T.T, M2), combine_batch(np.array(out), M2), atol=0)


def test_batch_near_total_conflict_is_exact():
    eps = 1e-10
    M1 = np.array([[0, 1 - eps, 0, eps]] * 3)
    M2 = np.array([[0, 0, 1 - eps, eps]] * 3)
    z = 2 * eps * (1 - eps) + eps * eps
    expected = [0, (1 - eps) * eps / z, (1 - eps) * eps / z, eps * eps / z]
    np.testing.assert_allclose(combine_batch(M1, M2), [expected] * 3, rtol=1e-12, atol=0)


def test_batch_total_conflict_names_the_row():
    M1 = np.array([[0, 0.5, 0.5, 0], [0, 1.0, 0, 0]])
    M2 = np.array([[0, 0.5, 0.5, 0], [0, 0, 1.0, 0]])
    with pytest.raises(TotalConflictError, match="row 1.*K = 1.0"):
        combine_batch(M1, M2)


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.array([[0, 0.5, 0.6, -0.1]]), r"row 0: mass of focal set 3.*-0\.1"),
        (np.array([[0, 0.5, np.nan, 0.5]]), "nan"),
        (np.array([[0, 0.5, 0.6, 0.0]]), r"row 0: masses must sum to 1.*1\.1"),
        (np.array([[0.5, 0.25, 0.25]]), "shape"),
        (np.array([0, 1.0, 0, 0]), "shape"),
    ],
)
def test_batch_errors(bad, match):
    good = np.array([[0, 0, 0, 1.0]])
    with pytest.raises(MassError, match=match):
        combine_batch(good, bad)


def test_batch_shapes_must_match():
    with pytest.raises(MassError, match="like batch 0"):
        combine_batch(np.array([[0, 0, 0, 1.0]]), np.array([[0, 0, 0, 1.0]] * 2))


def test_total_conflict_in_a_large_batch_names_the_row_and_k():
    # 5,000 rows: the Möbius strategy, whose near-conflict rows are recomputed exactly
    rng = np.random.default_rng(5)
    M1 = np.column_stack([np.zeros(5000), rng.dirichlet(np.ones(3), 5000)])
    M2 = np.column_stack([np.zeros(5000), rng.dirichlet(np.ones(3), 5000)])
    M1[4321], M2[4321] = [0, 1.0, 0, 0], [0, 0, 1.0, 0]
    with pytest.raises(TotalConflictError, match=r"row 4321\).*K = 1\.0"):
        combine_batch(M1, M2)
    M2[4321] = [0, 1e-12, 1 - 1e-12, 0]
    out = combine_batch(M1, M2)
    np.testing.assert_allclose(out[4321], [0, 1.0, 0, 0], rtol=0, atol=0)
    np.testing.assert_allclose(out[:, 0], 0.0, atol=0)


@pytest.mark.parametrize("name", sorted(RULES))
@pytest.mark.parametrize("order", ["C", "F"])
def test_batch_result_never_shares_memory_with_the_inputs(name, order):
    rng = np.random.default_rng(6)
    subnormal = RULES[name].empty_set == "required"  # sources with mass on ∅ too
    draws = rng.dirichlet(np.ones(4 if subnormal else 3), 3000)
    inputs = [np.asarray(draws if subnormal else np.column_stack([np.zeros(3000), draws]), order=order)]
    inputs.append(np.array(inputs[0][::-1], order=order))
    kept = [a.copy() for a in inputs]
    for sources in (inputs[:1], inputs):
        out = combine_batch(*sources, rule=name)
        assert not any(np.may_share_memory(out, a) for a in inputs)
        out[...] = -1.0
    for a, b in zip(inputs, kept):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("n", [2, 5])
def test_sets_used_only_after_the_sampled_rows_are_combined(n):
    # the first 100 rows use one set: the full scan finds the sets of row 150
    from evidential import Frame

    frame = Frame([f"e{i}" for i in range(n)])
    full = (1 << n) - 1
    M1 = np.zeros((200, 1 << n))
    M1[:, full] = 1.0
    M2 = np.zeros((200, 1 << n))
    M2[:, 1] = 1.0
    M2[150, [1, 2, full]] = [0.0, 0.25, 0.75]
    M1[150, [1, full]] = [0.5, 0.5]
    out = combine_batch(M1, M2)
    for j in (0, 150):
        objs = [MassFunction.from_dense(frame, M[j]) for M in (M1, M2)]
        np.testing.assert_allclose(out[j], combine(*objs).dense(), rtol=0, atol=1e-15)
    assert out[150, 1] > 0 and out[150, 2] > 0


@pytest.mark.parametrize("rule", sorted(RULES))
def test_batches_of_no_rows_combine_to_no_rows(rule):
    out = combine_batch(np.zeros((0, 4)), np.zeros((0, 4)), rule=rule)
    assert out.shape == (0, 4)
    with pytest.raises(MassError, match="batch 1 must have shape"):
        combine_batch(np.zeros((0, 4)), np.zeros((0, 8)), rule=rule)
