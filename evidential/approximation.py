"""Large frames and many focal sets: Monte-Carlo combination and summarisation to at
most k focal sets, each returning the error bound of its approximation."""

from __future__ import annotations

import math
from numbers import Integral, Real
from typing import NamedTuple

import numpy as np

from evidential.construction import from_focal_sets
from evidential.errors import FrameError, MassError, TotalConflictError
from evidential.mass import MassFunction
from evidential.stack import Stack


class Estimate(NamedTuple):
    """A Monte-Carlo estimate: ``mass``, and ``error``, the half-width of a Hoeffding interval
    holding each true m(A) with probability ``confidence``, from ``samples`` accepted draws."""

    mass: MassFunction
    error: float
    samples: int


class Summary(NamedTuple):
    """A summarised mass function and ``error``, the mass moved: a bound on |bel' - bel| and
    |pl' - pl| over every set (pl' >= pl: the summary is less committed)."""

    mass: MassFunction
    error: float


def monte_carlo_combine(
    *masses: MassFunction,
    samples: int,
    rng: np.random.Generator,
    normalise: bool = True,
    confidence: float = 0.95,
) -> Estimate:
    """Estimate the conjunctive combination by sampling one focal set per source and
    intersecting (Wilson 2000, "Algorithms and complexity for Dempster-Shafer theory";
    pyds' ``combine_conjunctive(..., sample_count=...)``): the cost is linear in the
    number of sources and of samples, whatever the frame and the number of focal sets.

    Parameters
    ----------
    *masses : MassFunction
        On one frame.
    samples : int
        Number of draws; with ``normalise`` those with an empty intersection are rejected.
    rng : numpy.random.Generator
    normalise : bool
        Dempster's rule (default), or the unnormalized conjunctive rule.
    confidence : float
        Of the returned error bound, in (0, 1).

    Raises
    ------
    TotalConflictError
        When ``normalise`` and every draw has an empty intersection.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b", "c"])
    >>> m1, m2 = MassFunction(frame, {"a|b": 0.5, "a|b|c": 0.5}), MassFunction(frame, {"b|c": 1.0})
    >>> est = monte_carlo_combine(m1, m2, samples=10_000, rng=np.random.default_rng(0))
    >>> sorted(est.mass.to_dict()), abs(est.mass["b"] - 0.5) <= est.error, round(est.error, 4)
    (['b', 'b|c'], True, 0.0136)
    """
    if not masses or any(not isinstance(m, MassFunction) for m in masses):
        raise TypeError(f"monte_carlo_combine needs MassFunctions, got {[type(m).__name__ for m in masses]}")
    frame = masses[0].frame
    for i, m in enumerate(masses):
        if m.frame != frame:
            raise FrameError(f"masses on different frames: mass 0 is on {frame!r}, mass {i} on {m.frame!r}")
    if isinstance(samples, bool) or not isinstance(samples, Integral) or samples < 1:
        raise MassError(f"samples must be an integer >= 1, got {samples!r}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if not (isinstance(confidence, Real) and not isinstance(confidence, bool) and 0 < confidence < 1):
        raise MassError(f"confidence must be a number in (0, 1), got {confidence!r}")
    draws = [_draw(m, samples, rng) for m in masses]
    keys = np.bitwise_and.reduce(draws) if len(draws) > 1 else draws[0]
    if normalise:
        keys = keys[keys != 0]
        if not keys.size:
            raise TotalConflictError(f"every one of the {samples} draws has an empty intersection: K is near 1")
    bound = math.sqrt(math.log(2 / (1 - confidence)) / (2 * keys.size))
    uniq, counts = np.unique(keys, return_counts=True)
    return Estimate(MassFunction.from_stack(frame, Stack(uniq, (counts / keys.size)[:, None])), bound, keys.size)


def _draw(m: MassFunction, samples: int, rng: np.random.Generator) -> np.ndarray:
    """``samples`` focal sets of ``m`` drawn by their masses (inverse of the cumulative masses)."""
    cumulative = np.cumsum(m.masses)
    index = np.searchsorted(cumulative, rng.random(samples) * cumulative[-1], side="right")
    return m.masks[np.minimum(index, m.masks.size - 1)]


def summarize(m: MassFunction, k: int) -> Summary:
    """The summarisation of ``m`` to at most ``k`` focal sets: the k - 1 of largest mass are
    kept and the others merged into their union (Lowrance, Garvey & Strat 1986, "A framework
    for evidential-reasoning systems", AAAI): an outer approximation.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b", "c", "d"]), {"a": 0.5, "b": 0.3, "c": 0.1, "d": 0.1})
    >>> s = summarize(m, 2)
    >>> {key: round(v, 12) for key, v in s.mass.to_dict().items()}, round(s.error, 12)
    ({'a': 0.5, 'b|c|d': 0.5}, 0.5)
    """
    if isinstance(k, bool) or not isinstance(k, Integral) or k < 1:
        raise MassError(f"k must be an integer >= 1, got {k!r}")
    if len(m) <= k:
        return Summary(m, 0.0)
    order = np.argsort(-m.masses, kind="stable")
    keep, merge = order[: k - 1], order[k - 1 :]
    union = np.bitwise_or.reduce(m.masks[merge])
    keys = np.append(m.masks[keep], union)
    moved = float(m.masses[merge].sum())
    return Summary(from_focal_sets(m.frame, keys, np.append(m.masses[keep], moved), open_world=True), moved)
