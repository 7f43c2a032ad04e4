"""Mass functions from data: summed focal sets, consonant (possibility) mass functions
from samples, and the imprecise Dirichlet model for multinomial counts."""

from __future__ import annotations

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
    keys = np.asarray(masks, dtype=np.int64).ravel()
    values = np.asarray(masses, dtype=np.float64).ravel()
    if keys.shape != values.shape:
        raise MassError(f"masks and masses must have one entry each per focal set, got {keys.size} and {values.size}")
    uniq, where = np.unique(keys, return_inverse=True)
    return MassFunction.from_rows(frame, uniq, [np.bincount(where, values, uniq.size)], open_world=open_world)[0]


def consonant_from_possibility(frame: Frame, possibility: Mapping[str, float]) -> MassFunction:
    """The consonant mass function of a possibility distribution π (max π = 1):
    the nested cuts {π >= π_k} get π_k - π_(k+1) (Dubois & Prade 1988, "Possibility theory").

    Examples
    --------
    >>> consonant_from_possibility(Frame(["a", "b", "c"]), {"a": 1.0, "b": 0.5, "c": 0.2}).to_dict()
    {'a': 0.5, 'a|b': 0.3, 'a|b|c': 0.2}
    """
    pi = np.array([possibility.get(name, 0.0) for name in frame.elements], dtype=np.float64)
    unknown = set(possibility) - set(frame.elements)
    if unknown or not (pi.min() >= 0 and abs(pi.max() - 1.0) <= 1e-9):
        raise MassError(f"possibility must map elements of {frame!r} to [0, 1] with maximum 1, got {possibility!r}")
    levels = np.unique(pi[pi > 0])  # increasing: the cuts {π >= level} shrink, their bitmasks decrease
    cuts = ((pi[None, :] >= levels[:, None]) << np.arange(len(frame))).sum(axis=1)
    steps = levels - np.append(0.0, levels[:-1])
    return MassFunction.from_stack(frame, Stack(cuts[::-1], (steps / steps.sum())[::-1, None]))


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
    if isinstance(s, bool) or not isinstance(s, Real) or not 0 < s < np.inf:
        raise MassError(f"s (the prior strength) must be a finite number > 0, got {s!r}")
    for name, c in counts.items():
        if isinstance(c, bool) or not isinstance(c, Real) or not 0 <= c < np.inf:
            raise MassError(f"count of {name!r} must be a finite number >= 0, got {c!r}")
    n = np.array([float(counts.get(name, 0.0)) for name in frame.elements])
    if set(counts) - set(frame.elements):
        raise MassError(f"counts name elements not in {frame!r}: {sorted(set(counts) - set(frame.elements))}")
    masses = np.append(n, s) / (n.sum() + s)
    if len(frame) == 1:
        return MassFunction(frame, {frame.full: 1.0})
    masks = np.append(np.int64(1) << np.arange(len(frame)), frame.full)  # increasing, distinct
    return MassFunction.from_stack(frame, Stack(masks, masses[:, None]))
