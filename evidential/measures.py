"""Measures on mass functions: Euclidean distances on bel and pl, Liu's conflict, and
uncertainty (nonspecificity, discord, strife, total uncertainty), in bits."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from evidential.combination import conflict
from evidential.errors import FrameError
from evidential.mass import MassFunction
from evidential.transforms import belief, plausibility


def _pair(m1: MassFunction, m2: MassFunction) -> None:
    if m1.frame != m2.frame:
        raise FrameError(f"a measure between masses on different frames: {m1.frame!r} and {m2.frame!r}")


def belief_distance(m1: MassFunction, m2: MassFunction) -> float:
    """The Euclidean distance between the belief functions, sqrt(sum over A of (bel1 - bel2)(A)²),
    normalised by sqrt(2**n - 1) to lie in [0, 1] (Jousselme & Maupin 2012, "Distances in
    evidence theory: comprehensive survey and generalizations", IJAR 53).

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b"])
    >>> round(belief_distance(MassFunction(frame, {"a": 1.0}), MassFunction(frame, {"b": 1.0})), 12)
    0.816496580928
    """
    _pair(m1, m2)
    return _euclid(belief(m1.dense()) - belief(m2.dense()))


def plausibility_distance(m1: MassFunction, m2: MassFunction) -> float:
    """As :func:`belief_distance`, on the plausibility functions.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b"])
    >>> round(plausibility_distance(MassFunction(frame, {"a": 1.0}), MassFunction(frame, {"a|b": 1.0})), 12)
    0.57735026919
    """
    _pair(m1, m2)
    return _euclid(plausibility(m1.dense()) - plausibility(m2.dense()))


def _euclid(diff: NDArray[np.float64]) -> float:
    return math.sqrt(float(diff @ diff) / (diff.size - 1))


class LiuConflict(NamedTuple):
    """Liu's two-dimensional conflict: the conjunctive conflict K and difBetP = max over A of
    |BetP1(A) - BetP2(A)|; the masses conflict when both exceed a threshold."""

    mass: float
    pignistic: float


def liu_conflict(m1: MassFunction, m2: MassFunction) -> LiuConflict:
    """Liu (2006), "Analyzing the degree of conflict among belief functions", AI 170.

    K alone misleads: two equal non-categorical masses have K > 0 but difBetP = 0.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b", "c", "d", "e"])
    >>> m = MassFunction(frame, {name: 0.2 for name in frame.elements})
    >>> tuple(round(x, 12) for x in liu_conflict(m, m))  # Liu's example 1
    (0.8, 0.0)
    """
    _pair(m1, m2)
    p1, p2 = np.array(list(m1.pignistic().values())), np.array(list(m2.pignistic().values()))
    return LiuConflict(conflict(m1, m2), float(np.clip(p1 - p2, 0, None).sum()))  # max over A: the positive part


def _sizes(m: MassFunction) -> NDArray[np.float64]:
    return np.bitwise_count(m.masks).astype(np.float64)


def nonspecificity(m: MassFunction) -> float:
    """N(m) = sum over A ≠ ∅ of m(A) log2 |A| (Dubois & Prade 1985; Hartley for a set).

    Examples
    --------
    >>> from evidential import Frame
    >>> nonspecificity(MassFunction(Frame(["a", "b", "c", "d"]), {"a|b|c|d": 1.0}))
    2.0
    """
    size = _sizes(m)
    keep = size > 0
    return float(m.masses[keep] @ np.log2(size[keep]))


def _conflict_term(m: MassFunction, by_focal: bool) -> float:
    """-sum m(A) log2 sum_B m(B) |A ∩ B| / |X|, X = A (strife) or B (discord), A, B ≠ ∅."""
    keep = m.masks != 0
    masks, masses, size = m.masks[keep], m.masses[keep], _sizes(m)[keep]
    inter = np.bitwise_count(masks[:, None] & masks[None, :]).astype(np.float64)
    ratio = inter / (size[:, None] if by_focal else size[None, :])
    return float(-(masses @ np.log2(ratio @ masses)) + 0.0)


def discord(m: MassFunction) -> float:
    """Klir & Ramer's discord D(m) = -sum m(A) log2 sum_B m(B) |A ∩ B| / |B| (1990).

    Shannon's entropy on Bayesian masses.

    Examples
    --------
    >>> from evidential import Frame
    >>> discord(MassFunction(Frame(["a", "b"]), {"a": 0.5, "b": 0.5}))
    1.0
    """
    return _conflict_term(m, by_focal=False)


def strife(m: MassFunction) -> float:
    """Klir & Parviz's strife S(m) = -sum m(A) log2 sum_B m(B) |A ∩ B| / |A| (1992).

    Examples
    --------
    >>> from evidential import Frame
    >>> round(strife(MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "a|b|c": 0.5})), 12)  # -½ log2(⅔)
    0.292481250361
    """
    return _conflict_term(m, by_focal=True)


def total_uncertainty(m: MassFunction) -> float:
    """Nonspecificity plus strife, N + S, in [0, log2 n] (Klir & Wierman 1999,
    "Uncertainty-based information", ch. 5).

    Examples
    --------
    >>> from evidential import Frame
    >>> round(total_uncertainty(MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "a|b|c": 0.5})), 12)
    1.084962500721
    """
    return nonspecificity(m) + strife(m)
