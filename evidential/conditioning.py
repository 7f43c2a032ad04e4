"""Conditioning (normalised or not), deconditioning (the ballooning extension) and the generalized Bayesian
theorem."""

from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Real

import numpy as np

from evidential.combination import combine
from evidential.errors import MassError, TotalConflictError
from evidential.frame import Focal, Frame
from evidential.mass import MassFunction
from evidential.stack import Stack

MAX_UNCERTAIN = 20
""":func:`generalized_bayes` spells out the posterior for at most this many elements whose plausibility is neither
0 nor 1: 2**20 focal sets (8 MB of masses)."""


def condition(m: MassFunction, focal: Focal, *, normalise: bool = True) -> MassFunction:
    """Conditioning on A: m[A](B) = sum of m(C) over C ∩ A = B.

    Parameters
    ----------
    m : MassFunction
    focal : focal set
        The conditioning event A.
    normalise : bool
        Dempster's conditioning (the mass of ∅ normalised away; raises
        :class:`~evidential.errors.TotalConflictError` when pl(A) = 0), or the
        unnormalised conditioning of the TBM (Smets), which keeps 1 - pl(A) on ∅.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "b|c": 0.3, "c": 0.2})
    >>> condition(m, "a|b", normalise=False).to_dict()
    {'': 0.2, 'a': 0.5, 'b': 0.3}
    """
    if not isinstance(normalise, bool):
        raise TypeError(f"normalise must be True or False, got {normalise!r}")
    a = m.frame.mask(focal)
    event = MassFunction(m.frame, {a: 1.0}, open_world=a == 0)  # on ∅: all to ∅ (TBM), or total conflict
    return combine(m, event, rule="dempster" if normalise else "conjunctive")


def decondition(m: MassFunction, focal: Focal) -> MassFunction:
    """The ballooning extension: the least committed mass function whose conditioning on A
    is ``m``, m'(B ∪ Ā) = m(B) for B ⊆ A (Smets 1993, "Belief functions: the disjunctive
    rule of combination and the generalized Bayesian theorem", IJAR 9).

    Parameters
    ----------
    m : MassFunction
        Conditioned on A: every focal set inside A (∅ allowed).
    focal : focal set
        The event A.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b", "c"]), {"a": 0.6, "a|b": 0.4})
    >>> decondition(m, "a|b").to_dict()
    {'a|c': 0.6, 'a|b|c': 0.4}
    """
    a = m.frame.mask(focal)
    outside = [int(k) for k in m.masks if int(k) & ~a]
    if outside:
        raise MassError(
            f"decondition on {m.frame.label(a)!r} needs every focal set inside it, got {m.frame.label(outside[0])!r}"
        )
    rest = m.frame.full & ~a
    return MassFunction(m.frame, {int(k) | rest: float(v) for k, v in zip(m.masks, m.masses)}, open_world=True)


def generalized_bayes(frame: Frame, plausibilities: Mapping[str, float], *, normalise: bool = True) -> MassFunction:
    """Smets' generalized Bayesian theorem: the posterior on the frame Θ after an observation x, from the
    plausibility pl(x | θ) of the observation under each element θ, with no prior (Smets 1993, "Belief
    functions: the disjunctive rule of combination and the generalized Bayesian theorem", IJAR 9):

    m(A | x) = ∏_{θ ∈ A} pl(x | θ) · ∏_{θ ∉ A} (1 - pl(x | θ)),  so pl(A | x) = 1 - ∏_{θ ∈ A} (1 - pl(x | θ)).

    Combined with a Bayesian prior by Dempster's rule, it gives Bayes' theorem: posterior(θ) ∝ prior(θ) pl(x | θ).

    Parameters
    ----------
    frame : Frame
    plausibilities : mapping
        Element name to pl(x | θ) in [0, 1]; elements not named have 0 (x is impossible under them).
    normalise : bool
        Normalised (m(∅ | x) = ∏ (1 - pl(x | θ)) spread over the rest by division; raises
        :class:`~evidential.errors.TotalConflictError` when every pl(x | θ) is 0), or the unnormalised
        posterior of the TBM, which keeps it on ∅.

    Raises
    ------
    MassError
        An element not in the frame, a plausibility that is not a number in [0, 1], or more than
        :data:`MAX_UNCERTAIN` elements whose plausibility is neither 0 nor 1 (2**k focal sets; pl(A | x)
        above needs no mass function).

    Examples
    --------
    >>> m = generalized_bayes(Frame(["a", "b", "c"]), {"a": 0.8, "b": 0.5})
    >>> {k: round(v, 12) for k, v in m.to_dict().items()}
    {'a': 0.444444444444, 'b': 0.111111111111, 'a|b': 0.444444444444}
    >>> m = generalized_bayes(Frame(["a", "b", "c"]), {"a": 0.8, "b": 0.5}, normalise=False)
    >>> {k: round(v, 12) for k, v in m.to_dict().items()}
    {'': 0.1, 'a': 0.4, 'b': 0.1, 'a|b': 0.4}
    """
    positions, pl = frame.positions, [0.0] * len(frame)
    for name, value in plausibilities.items():
        i = positions.get(name)
        if i is None:
            raise MassError(f"plausibilities name elements not in {frame!r}: {name!r}")
        if not (isinstance(value, Real) and not isinstance(value, bool | np.bool_) and 0 <= value <= 1):
            raise MassError(f"pl(x | {name}) must be a number in [0, 1], got {value!r}")
        pl[i] = float(value)
    uncertain = [i for i, v in enumerate(pl) if 0 < v < 1]
    if len(uncertain) > MAX_UNCERTAIN:
        raise MassError(
            f"{len(uncertain)} elements have a plausibility strictly between 0 and 1: the posterior would have "
            f"2**{len(uncertain)} focal sets (at most 2**{MAX_UNCERTAIN}); pl(A | x) = 1 - prod over A of "
            "(1 - pl(x | θ)) needs none"
        )
    certain = sum(1 << i for i, v in enumerate(pl) if v == 1)
    masks, masses = np.array([certain], dtype=frame.dtype), np.ones(1)
    for i in uncertain:  # each element in or out of the focal set, independently; the masks stay increasing
        masks = np.concatenate([masks, masks | (1 << i)])
        masses = np.concatenate([masses * (1 - pl[i]), masses * pl[i]])
    if normalise and certain == 0:
        total = -math.expm1(math.fsum(math.log1p(-pl[i]) for i in uncertain))  # 1 - m(∅), exact near 0
        if total == 0:
            raise TotalConflictError(f"the observation is impossible under every element of {frame!r}")
        masks, masses = masks[1:], masses[1:] / total
    stack = Stack(masks, masses[:, None])
    return MassFunction.from_stack(frame, stack, positive=bool((masses > 0).all()))
