"""Conditioning (normalised or not) and deconditioning (the ballooning extension)."""

from __future__ import annotations

from evidential.combination import combine
from evidential.errors import MassError
from evidential.frame import Focal
from evidential.mass import MassFunction


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
    event = MassFunction(m.frame, {focal: 1.0})
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
