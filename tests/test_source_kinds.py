"""The shared check suite of evidence-source kinds: every registered kind, and a broken one that must fail it."""

from typing import Literal

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evmap import configs
from evmap.sources.config import config_from_data, load_config
from evmap.sources.conformance import check_source
from evmap.sources.evidence import KINDS, BoundSource, SourceKind, SourceSpec, register_kind
from evmap.sources.loading import InputError
from evmap.sources.plugins import load_plugins

load_plugins()
ALL = sorted(name for name, kind in KINDS.items() if kind.example is not None)
SUITE = settings(max_examples=25)


class OverfullSpec(SourceSpec):
    kind: Literal["overfull"]


def build_overfull(name, spec, frame, focal):
    """Every row: mass 1 on {real} and 1 on {noise}, a sum of 2."""
    rows = np.zeros((1, 1 << len(frame)))
    rows[0, 1:3] = 1.0
    return BoundSource(name, frame, spec.feature, "overfull", lambda v: np.repeat(rows, len(v), axis=0), ("a",), "")


OVERFULL = SourceKind("overfull", OverfullSpec, build_overfull, {"frame": "existence", "feature": "relation"})


def values_of(source):
    """Lists of the source's example values, in any order and number."""
    return st.lists(st.sampled_from(list(source.examples)), min_size=0, max_size=20).map(np.array)


@pytest.mark.parametrize("name", ALL)
@SUITE
@given(data=st.data())
def test_rows_are_mass_functions_deterministic_and_the_same_one_by_one(name, data):
    source = KINDS[name].build_example()
    values = data.draw(values_of(source))
    check_source(source, values)
    masses = source.masses({source.feature: values})
    assert masses.shape == (len(values), 1 << len(source.frame))
    assert np.all(masses >= 0) and np.allclose(masses.sum(axis=1), 1, atol=1e-9)


def test_a_kind_whose_rows_sum_to_2_fails_the_suite():
    source = OVERFULL.build_example()
    with pytest.raises(ValueError, match="row 0 sums to 2"):
        check_source(source, np.array(["a", "a"]))


def test_registration_refuses_a_kind_whose_rows_sum_to_2_by_name():
    with pytest.raises(ValueError, match="source kind 'overfull': row 0 sums to 2"):
        register_kind("overfull", OverfullSpec, OVERFULL.example)(build_overfull)
    assert "overfull" not in KINDS


def test_a_config_refuses_a_source_of_a_kind_that_was_put_in_the_registry_unchecked(monkeypatch):
    monkeypatch.setitem(KINDS, "overfull", OVERFULL)
    data = load_config(configs.path("paper.yaml")).to_data()
    data["sources"]["sonar_open_space"] = {"kind": "overfull", "frame": "existence", "feature": "relation"}
    with pytest.raises(InputError, match=r"sources\.sonar_open_space: source kind 'overfull' \(builtin\): row 0 sums"):
        config_from_data(data, "overfull.yaml")
