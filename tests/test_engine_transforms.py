"""Dense transforms: known values, round trips, and agreement with the object API."""

import numpy as np
import pytest
from engine_fixtures import masses
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import MassError
from evidential import transforms as T

any_mass = st.integers(1, 4).flatmap(masses)


@settings(max_examples=40)
@given(m=any_mass)
def test_round_trips(m):
    d = m.dense()
    for forward, back in [
        (T.commonality, T.mass_from_commonality),
        (T.implicability, T.mass_from_implicability),
        (T.belief, T.mass_from_belief),
        (T.plausibility, T.mass_from_plausibility),
    ]:
        np.testing.assert_allclose(back(forward(d)), d, atol=1e-12)


@settings(max_examples=40)
@given(m=any_mass)
def test_dense_transforms_agree_with_object_queries(m):
    d = m.dense()
    bel, pl, q = T.belief(d), T.plausibility(d), T.commonality(d)
    for mask in range(1 << len(m.frame)):
        assert bel[mask] == pytest.approx(m.belief(mask), abs=1e-12)
        assert pl[mask] == pytest.approx(m.plausibility(mask), abs=1e-12)
        assert q[mask] == pytest.approx(m.commonality(mask), abs=1e-12)
    np.testing.assert_allclose(T.pignistic(d), list(m.pignistic().values()), atol=1e-12)
    np.testing.assert_allclose(T.plausibility_transform(d), list(m.plausibility_transform().values()), atol=1e-12)


@settings(max_examples=40)
@given(m=any_mass)
def test_bel_betp_pl_ordering(m):
    betp = np.array(list(m.pignistic().values()))
    for mask in range(1, 1 << len(m.frame)):
        p = betp[[i for i in range(len(m.frame)) if mask >> i & 1]].sum()
        assert m.belief(mask) - 1e-12 <= p <= m.plausibility(mask) + 1e-12


def test_batched_leading_axes():
    m = np.array([[[0, 0.5, 0.2, 0.3]], [[0, 0, 0, 1.0]]])
    assert T.commonality(m).shape == (2, 1, 4)
    np.testing.assert_allclose(T.pignistic(m)[1, 0], [0.5, 0.5])


def test_fast_transform_matches_the_definition_on_a_5_element_frame():
    rng = np.random.default_rng(1)
    m = rng.dirichlet(np.ones(32))
    q = [sum(m[b] for b in range(32) if b & a == a) for a in range(32)]
    np.testing.assert_allclose(T.commonality(m), q, atol=1e-14)


def test_bad_length_refused():
    with pytest.raises(MassError, match="2\\*\\*n"):
        T.commonality([0.5, 0.25, 0.25])
