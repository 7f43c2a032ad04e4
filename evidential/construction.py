"""Mass functions from data: summed focal sets, consonant (possibility) mass functions
from samples, and the imprecise Dirichlet model for multinomial counts."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike

from evidential.errors import MassError
from evidential.frame import Frame
from evidential.mass import MassFunction
from evidential.stack import Stack


def from_focal_sets(frame: Frame, masks: ArrayLike, masses: ArrayLike, *, open_world: bool = False) -> MassFunction:
    """The mass function m(A) = sum of ``masses`` over the entries of ``masks`` equal to A.

    Checked as :meth:`MassFunction.from_rows` checks a row (masses >= 0, total 1).

    Examples
    --------
    >>> from_focal_sets(Frame(["a", "b"]), [1, 3, 1], [0.25, 0.5, 0.25]).to_dict()
    {'a': 0.5, 'a|b': 0.5}
    """
    keys = np.asarray(masks, dtype=frame.dtype).ravel()  # Python ints beyond 63 elements
    values = np.asarray(masses, dtype=np.float64).ravel()
    if keys.shape != values.shape:
        raise MassError(f"masks and masses must have one entry each per focal set, got {keys.size} and {values.size}")
    uniq, where = np.unique(keys, return_inverse=True)
    return MassFunction.from_rows(frame, uniq, [np.bincount(where, values, uniq.size)], open_world=open_world)[0]


def consonant_from_possibility(frame: Frame, possibility: Mapping[str, float]) -> MassFunction:
    """The consonant mass function of a possibility distribution π (max π = 1):
    the nested cuts {π >= π_k} get π_k - π_(k+1) (Dubois & Prade 1988, "Possibility theory").

    Plain Python: the elements sorted by π, the cuts grown one level at a time (at most n
    focal sets, where numpy's calls would cost more than the work).

    Examples
    --------
    >>> consonant_from_possibility(Frame(["a", "b", "c"]), {"a": 1.0, "b": 0.5, "c": 0.2}).to_dict()
    {'a': 0.5, 'a|b': 0.3, 'a|b|c': 0.2}
    """

    def refused() -> MassError:
        return MassError(f"possibility must map elements of {frame!r} to [0, 1] with maximum 1, got {possibility!r}")

    positions, pi = frame.positions, [0.0] * len(frame)
    for name, value in possibility.items():
        i = positions.get(name)
        if i is None or not ((type(value) is float or _is_number(value)) and value >= 0):
            raise refused()
        pi[i] = float(value)
    if not abs(max(pi) - 1.0) <= 1e-9:
        raise refused()
    ranked = sorted([(v, 1 << i) for i, v in enumerate(pi) if v > 0], reverse=True)
    masks, steps, cut = [], [], 0
    for (level, bit), (lower, _) in zip(ranked, [*ranked[1:], (0.0, 0)]):
        cut |= bit
        if lower < level:  # the last element of its level: the cut {π >= level} is complete
            masks.append(cut)
            steps.append(level - lower)
    masses = np.array(steps) / math.fsum(steps)
    stack = Stack(np.array(masks, dtype=frame.dtype), masses[:, None])
    return MassFunction.from_stack(frame, stack, positive=True)  # steps > 0, total <= 1 + 1e-9


def _is_number(value: object) -> bool:
    """A real number and not a bool (int and float checked first: the ABC check is slow)."""
    return type(value) in (int, float) or (isinstance(value, Real) and not isinstance(value, bool))


def consonant_from_samples(frame: Frame, samples: Iterable[str]) -> MassFunction:
    """The consonant mass function of observed samples by the Dubois-Prade-Sandri transform
    π(ω) = sum of p(ω') over p(ω') <= p(ω), p the relative frequencies (Dubois, Prade &
    Sandri 1993, "On possibility/probability transformations"): the most specific
    possibility distribution dominating p.

    Examples
    --------
    >>> m = consonant_from_samples(Frame(["a", "b", "c"]), ["a"] * 5 + ["b"] * 3 + ["c"] * 2)
    >>> {k: round(v, 12) for k, v in m.to_dict().items()}
    {'a': 0.5, 'a|b': 0.3, 'a|b|c': 0.2}
    """
    p = _counts(frame, samples, "samples")
    p = p / p.sum()
    pi = np.array([p[p <= x].sum() for x in p])
    return consonant_from_possibility(frame, dict(zip(frame.elements, pi.tolist())))


def _counts(frame: Frame, samples: Iterable[str], name: str) -> np.ndarray:
    index = {element: i for i, element in enumerate(frame.elements)}
    counts = np.zeros(len(frame))
    for sample in samples:
        if sample not in index:
            raise MassError(f"{name}: a sample must be one element name of {frame!r}, got {sample!r}")
        counts[index[sample]] += 1
    if not counts.sum() > 0:
        raise MassError(f"{name} must hold at least one element of {frame!r}, got none")
    return counts


def imprecise_dirichlet(frame: Frame, counts: Mapping[str, float], s: float = 2.0) -> MassFunction:
    """The imprecise Dirichlet model of multinomial counts n_ω (N = sum): m({ω}) = n_ω / (N + s),
    m(Θ) = s / (N + s), whose bel and pl are Walley's lower and upper probabilities
    n_A / (N + s) and (n_A + s) / (N + s) (Walley 1996, "Inferences from multinomial data:
    learning about a bag of marbles", JRSS B 58).

    Parameters
    ----------
    frame : Frame
    counts : mapping
        Element name to its count (>= 0); missing elements count 0.
    s : float
        Walley's prior strength, > 0 (1 or 2 advised).

    Examples
    --------
    >>> imprecise_dirichlet(Frame(["a", "b", "c"]), {"a": 4, "b": 2}).to_dict()
    {'a': 0.5, 'b': 0.25, 'a|b|c': 0.25}
    """
    if not (_is_number(s) and 0 < s < math.inf):
        raise MassError(f"s (the prior strength) must be a finite number > 0, got {s!r}")
    # plain Python: n + 1 focal sets at most, fewer calls than numpy would make
    positions, n = frame.positions, [0.0] * len(frame)
    for name, c in counts.items():
        if not ((type(c) is int or _is_number(c)) and 0 <= c < math.inf):
            raise MassError(f"count of {name!r} must be a finite number >= 0, got {c!r}")
        i = positions.get(name)
        if i is None:
            raise MassError(f"counts name elements not in {frame!r}: {sorted(set(counts) - set(frame.elements))}")
        n[i] = float(c)
    if len(frame) == 1:
        return MassFunction(frame, {frame.full: 1.0})
    total = math.fsum(n) + s
    masks, masses = [], []
    for i, c in enumerate(n):
        share = c / total
        if share > 0:  # not a zero count, nor a tiny one lost to underflow
            masks.append(1 << i)
            masses.append(share)
    masks.append(frame.full)  # increasing, distinct
    masses.append(s / total)
    stack = Stack(np.array(masks, dtype=frame.dtype), np.array(masses)[:, None])
    return MassFunction.from_stack(frame, stack, positive=masses[-1] > 0)
