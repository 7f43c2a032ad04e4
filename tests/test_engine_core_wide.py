"""Frames beyond one machine word (more than 63 elements): the sparse path on Python int masks."""

import math
from itertools import product

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, FrameError, MassFunction, combine

WIDE = Frame([f"e{i}" for i in range(130)])


def reference(m1: dict[int, float], m2: dict[int, float], normalize: bool) -> dict[int, float]:
    """The conjunctive (or Dempster) combination by Python dicts."""
    out: dict[int, list[float]] = {}
    for (a, x), (b, y) in product(m1.items(), m2.items()):
        out.setdefault(a & b, []).append(x * y)
    sums = {k: math.fsum(v) for k, v in out.items()}
    if normalize:
        z = math.fsum(v for k, v in sums.items() if k)
        sums = {k: v / z for k, v in sums.items() if k}
    return sums


focal = st.integers(1, WIDE.full)
masses = st.dictionaries(focal, st.floats(0.01, 1.0), min_size=1, max_size=6)


def mass(weights: dict[int, float]) -> MassFunction:
    total = math.fsum(weights.values())
    return MassFunction(WIDE, {k: v / total for k, v in weights.items()})


@given(masses, masses)
def test_wide_combination_matches_python_ints(w1, w2):
    m1, m2 = mass(w1), mass(w2)
    assert m1.masks.dtype == object and len(WIDE) == 130
    d1, d2 = dict(zip(m1.masks.tolist(), m1.masses.tolist())), dict(zip(m2.masks.tolist(), m2.masses.tolist()))
    conj = combine(m1, m2, rule="conjunctive")
    want = reference(d1, d2, normalize=False)
    assert conj.masks.tolist() == sorted(k for k, v in want.items() if v > 0)
    np.testing.assert_allclose(conj.masses, [want[k] for k in conj.masks.tolist()], rtol=1e-12)
    if any(k for k in want if want[k] > 0):
        dem = combine(m1, m2)
        want = reference(d1, d2, normalize=True)
        np.testing.assert_allclose(dem.masses, [want[k] for k in dem.masks.tolist()], rtol=1e-12)


def test_wide_queries():
    m = MassFunction(WIDE, {"e0|e129": 0.5, "e100": 0.25, WIDE.full: 0.25})
    assert m.belief("e0|e100|e129") == 0.75 and m.plausibility("e129") == 0.75 and m["e100"] == 0.25
    assert m.belief(["e100", "e0|e129", 1 << 129]).tolist() == [0.25, 0.5, 0.0]
    assert m.plausibility(np.array([1 << 129, 1 << 5], dtype=object)).tolist() == [0.75, 0.25]
    p = m.pignistic()
    assert p["e129"] == pytest.approx(0.25 + 0.25 / 130) and math.fsum(p.values()) == pytest.approx(1.0)
    assert m.to_dict() == {"e0|e129": 0.5, "e100": 0.25, "|".join(WIDE.elements): 0.25}
    assert "e100" in m and 1 << 100 in m and "e99" not in m
    assert m == MassFunction(WIDE, m.to_dict()) and m.discount(0.5)[WIDE.full] == 0.625
    assert m.condition("e129").to_dict() == {"e129": 1.0}
    with pytest.raises(FrameError, match="at most 20 elements, got 130; the sparse queries"):
        m.dense()


def test_word_frames_keep_int64():
    assert MassFunction(Frame([f"e{i}" for i in range(63)]), {"e62": 1.0}).masks.dtype == np.int64
    assert MassFunction(Frame([f"e{i}" for i in range(64)]), {"e63": 1.0}).masks.tolist() == [1 << 63]


def test_wide_construction_summarisation_refinement_and_coarsening():
    from evidential import coarsen, from_focal_sets, refine, summarize

    word_edge = Frame([f"e{i}" for i in range(64)])  # the first frame beyond one machine word
    m = MassFunction(word_edge, {"e63": 0.5, "e0|e63": 0.3, word_edge.full: 0.2})
    summary = summarize(m, 2)
    assert summary.mass.to_dict() == {"e63": 0.5, word_edge.label(word_edge.full): 0.5} and summary.error == 0.5
    assert from_focal_sets(word_edge, [1 << 63, 1 << 63, word_edge.full], [0.25, 0.25, 0.5]).to_dict() == {
        "e63": 0.5,
        word_edge.label(word_edge.full): 0.5,
    }
    coarse = Frame([f"c{i}" for i in range(70)])  # wide on both sides: 70 coarse elements, 140 fine
    fine = Frame([f"x{i}" for i in range(140)])
    rho = {f"c{i}": f"x{2 * i}|x{2 * i + 1}" for i in range(70)}
    m = MassFunction(coarse, {"c0|c69": 0.5, "c69": 0.2, coarse.full: 0.3})
    refined = refine(m, fine, rho)
    assert refined.to_dict() == {"x138|x139": 0.2, "x0|x1|x138|x139": 0.5, fine.label(fine.full): 0.3}
    assert coarsen(refined, coarse, rho) == m and coarsen(refined, coarse, rho, outer=False) == m
    inner = coarsen(MassFunction(fine, {"x0|x139": 1.0}), coarse, rho, outer=False)  # no block inside: ∅
    assert inner.to_dict() == {"": 1.0}
    assert coarsen(MassFunction(fine, {"x0|x139": 1.0}), coarse, rho).to_dict() == {"c0|c69": 1.0}
