"""Mass functions from data: consonant from samples, the imprecise Dirichlet model."""

import itertools

import pytest
from engine_fixtures import FRAMES
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import MassError
from evidential.construction import (
    consonant_from_possibility,
    consonant_from_samples,
    from_focal_sets,
    imprecise_dirichlet,
)

ABC = FRAMES[3]


def test_consonant_from_samples_known_answer():
    # Dubois, Prade & Sandri (1993): p = (.5, .3, .2) -> π = (1, .5, .2) -> nested {a} ⊂ {a, b} ⊂ Θ.
    m = consonant_from_samples(ABC, ["w0"] * 5 + ["w1"] * 3 + ["w2"] * 2)
    assert m.to_dict() == pytest.approx({"w0": 0.5, "w0|w1": 0.3, "w0|w1|w2": 0.2})
    # ties share one level: p = (.4, .4, .2) -> π = (1, 1, .2)
    m = consonant_from_samples(ABC, ["w0", "w0", "w1", "w1", "w2"])
    assert m.to_dict() == pytest.approx({"w0|w1": 0.8, "w0|w1|w2": 0.2})


@settings(max_examples=40)
@given(samples=st.lists(st.sampled_from(ABC.elements), min_size=1, max_size=30))
def test_consonant_mass_is_nested_and_dominates_the_frequencies(samples):
    m = consonant_from_samples(ABC, samples)
    masks = sorted(m.masks.tolist(), key=lambda k: (k).bit_count())
    assert all(a & b == a for a, b in itertools.pairwise(masks))  # nested focal sets
    for name in ABC.elements:  # pl({ω}) = π(ω) >= p(ω) >= bel({ω})
        p = samples.count(name) / len(samples)
        assert m.belief(name) - 1e-12 <= p <= m.plausibility(name) + 1e-12


def test_imprecise_dirichlet_bounds_are_walleys():
    # Walley (1996), JRSS B 58: P_(A) = n_A / (N + s), P^(A) = (n_A + s) / (N + s).
    counts = {"w0": 4, "w1": 2}
    m = imprecise_dirichlet(ABC, counts, s=2)
    assert m.to_dict() == {"w0": 0.5, "w1": 0.25, "w0|w1|w2": 0.25}
    for a, n_a in (("w0", 4), ("w1", 2), ("w2", 0), ("w0|w2", 4)):
        assert m.belief(a) == pytest.approx(n_a / 8) and m.plausibility(a) == pytest.approx((n_a + 2) / 8)


def test_construction_errors_name_the_value():
    with pytest.raises(MassError, match="s \\(the prior strength\\) must be a finite number > 0, got 0"):
        imprecise_dirichlet(ABC, {"w0": 1}, s=0)
    with pytest.raises(MassError, match="count of 'w0' must be a finite number >= 0, got -1"):
        imprecise_dirichlet(ABC, {"w0": -1})
    with pytest.raises(MassError, match="got 'w9'"):
        consonant_from_samples(ABC, ["w9"])
    with pytest.raises(MassError, match="maximum 1"):
        consonant_from_possibility(ABC, {"w0": 0.5})
    with pytest.raises(MassError, match="sum to 1"):
        from_focal_sets(ABC, [1, 2], [0.5, 0.6])
