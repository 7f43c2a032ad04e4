"""Shared canonical masses and hypothesis strategies for the engine tests."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from evidential import Frame, MassFunction

FRAMES = {n: Frame([f"w{i}" for i in range(n)]) for n in range(1, 5)}
PAPER = Frame(["real", "noise"])


def vacuous(frame: Frame) -> MassFunction:
    return MassFunction(frame, {frame.full: 1.0})


def categorical(frame: Frame, focal) -> MassFunction:
    return MassFunction(frame, {focal: 1.0})


def bayesian(frame: Frame, p) -> MassFunction:
    return MassFunction(frame, {1 << i: float(v) for i, v in enumerate(p)})


def total_conflict() -> tuple[MassFunction, MassFunction]:
    """Two categorical masses on disjoint sets: K = 1."""
    return categorical(PAPER, "real"), categorical(PAPER, "noise")


def assert_same(a: MassFunction, b: MassFunction, tol: float = 1e-9) -> None:
    assert a.frame == b.frame
    np.testing.assert_allclose(a.dense(), b.dense(), rtol=0, atol=tol)


def needs(rule) -> dict:
    """What a registered rule needs of its sources, as keyword arguments of ``masses``."""
    return {"nondogmatic": rule.nondogmatic, "subnormal": rule.empty_set == "required"}


@st.composite
def masses(draw, n: int, nondogmatic: bool = False, bayes: bool = False, subnormal: bool = False) -> MassFunction:
    """A random mass function over FRAMES[n] with up to 6 focal sets (and ∅ if ``subnormal``)."""
    frame = FRAMES[n]
    candidates = [1 << i for i in range(n)] if bayes else list(range(1, 1 << n))
    sets = draw(st.lists(st.sampled_from(candidates), min_size=1, max_size=min(6, len(candidates)), unique=True))
    if nondogmatic and frame.full not in sets:
        sets.append(frame.full)
    if subnormal:
        sets.append(0)
    weights = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=len(sets), max_size=len(sets))))
    return MassFunction(frame, dict(zip(sets, (weights / weights.sum()).tolist())), open_world=subnormal)


@st.composite
def sources(
    draw, count: int, nondogmatic: bool = False, bayes: bool = False, subnormal: bool = False
) -> list[MassFunction]:
    """``count`` random mass functions over one frame of 1 to 4 elements."""
    n = draw(st.integers(1, 4))
    return [draw(masses(n, nondogmatic, bayes, subnormal)) for _ in range(count)]
