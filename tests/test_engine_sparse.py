"""Large frames through the sparse path: exact combination on 40 and 63 elements."""

import itertools

import numpy as np
import pytest

from evidential import RULES, Frame, MassError, MassFunction, combine, conflict

BIG = Frame([f"e{i}" for i in range(40)])


def reference(m1, m2):
    """Dempster's rule from the definition, with Python ints and dicts."""
    out = {}
    for (a, x), (b, y) in itertools.product(zip(m1.masks.tolist(), m1.masses), zip(m2.masks.tolist(), m2.masses)):
        out[a & b] = out.get(a & b, 0.0) + x * y
    k = out.pop(0, 0.0)
    return {s: v / (1 - k) for s, v in out.items()}, k


def random_mass(frame, rng, k):
    masks = (
        {int(v) for v in rng.integers(1, 1 << 62, size=k)}
        if len(frame) == 63
        else {int(v) & frame.full for v in rng.integers(1, 1 << 40, size=k)}
    )
    masks.discard(0)
    w = rng.dirichlet(np.ones(len(masks)))
    return MassFunction(frame, dict(zip(sorted(masks), w.tolist())))


@pytest.mark.parametrize("frame", [BIG, Frame([f"e{i}" for i in range(63)])])
def test_large_frame_dempster_is_exact(frame):
    rng = np.random.default_rng(7)
    m1, m2 = random_mass(frame, rng, 5), random_mass(frame, rng, 6)
    expected, k = reference(m1, m2)
    got = combine(m1, m2)
    assert dict(zip(got.masks.tolist(), got.masses)) == pytest.approx(expected, abs=1e-12)
    assert conflict(m1, m2) == pytest.approx(k, abs=1e-15)


def test_forty_elements_named_sets():
    m1 = MassFunction(BIG, {"e0|e1|e39": 0.6, BIG.full: 0.4})
    m2 = MassFunction(BIG, {"e39": 0.5, ("e0", "e2"): 0.5})
    m = combine(m1, m2)
    assert m.to_dict() == pytest.approx({"e0": 0.3, "e39": 0.5, "e0|e2": 0.2})
    assert m.belief("e0|e2|e39") == pytest.approx(1.0)
    assert m.pignistic()["e0"] == pytest.approx(0.4)


@pytest.mark.parametrize("name", sorted(set(RULES) - {"cautious", "bold"}))  # dense rules
def test_every_sparse_rule_runs_on_40_elements(name):
    rng = np.random.default_rng(11)
    ms = [MassFunction(BIG, {"e1|e2": 0.5, "e2|e3": 0.25, BIG.full: 0.25}), random_mass(BIG, rng, 4)]
    m = combine(*ms, rule=name)
    assert m.masses.sum() == pytest.approx(1.0, abs=1e-12)


def test_cautious_needs_a_dense_frame():
    m = MassFunction(BIG, {BIG.full: 1.0})
    with pytest.raises(MassError, match="at most 20"):
        combine(m, m, rule="cautious")
