"""Corrections of a source beyond Shafer's discounting: contextual discounting and
reinforcement, and negation.

Shafer's discounting is :meth:`MassFunction.discount`; it is the contextual
discounting with the single context Θ.
"""

from __future__ import annotations

from collections.abc import Mapping
from numbers import Real

from evidential.combination import combine
from evidential.errors import MassError
from evidential.frame import Focal
from evidential.mass import MassFunction


def negation(m: MassFunction) -> MassFunction:
    """The negation m̄(A) = m(Ā) (Dubois & Prade 1986, "A set-theoretic view of belief functions").

    The negation of a normal mass function puts m(Θ) on ∅ (open world).

    Examples
    --------
    >>> from evidential import Frame
    >>> negation(MassFunction(Frame(["a", "b", "c"]), {"a": 0.7, "a|b|c": 0.3})).to_dict()
    {'': 0.3, 'b|c': 0.7}
    """
    full = m.frame.full
    return MassFunction(m.frame, {full ^ int(k): float(v) for k, v in zip(m.masks, m.masses)}, open_world=True)


def _contexts(m: MassFunction, rates: Mapping[Focal, float], name: str) -> list[tuple[int, float]]:
    if not rates:
        raise MassError(f"{name} needs at least one context and its rate, got {dict(rates)!r}")
    out = []
    for context, rate in rates.items():
        if isinstance(rate, bool) or not isinstance(rate, Real) or not 0 <= rate <= 1:
            raise MassError(f"{name}: rate of context {context!r} must be a number in [0, 1], got {rate!r}")
        mask = m.frame.mask(context)
        if not mask:
            raise MassError(f"{name}: a context must be a non-empty set, got {context!r}")
        out.append((mask, float(rate)))
    return out


def contextual_discount(m: MassFunction, rates: Mapping[Focal, float]) -> MassFunction:
    """Contextual discounting: m ∪ (∪ over contexts A of A_(1 - α_A)), A_v being m(∅) = v, m(A) = 1 - v.

    Mercier, Quost & Denœux (2008), "Refined modeling of sensor reliability in the
    belief function framework using contextual discounting", Information Fusion 9:
    ``rates[A] = α_A`` is the discount rate of the source when the truth is in A
    (contexts usually the singletons, or a partition); the contour becomes
    pl({θ}) = 1 - (1 - α_θ)(1 - pl({θ})) for singleton contexts. With the one
    context Θ it is Shafer's discounting with reliability 1 - α.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b", "c"]), {"a": 1.0})
    >>> {k: round(v, 12) for k, v in contextual_discount(m, {"b": 0.5, "c": 0.2}).to_dict().items()}
    {'a': 0.4, 'a|b': 0.4, 'a|c': 0.1, 'a|b|c': 0.1}
    """
    simple = [MassFunction(m.frame, {"": 1.0 - a, s: a}, open_world=True) for s, a in _contexts(m, rates, "rates")]
    return combine(m, *simple, rule="disjunctive")


def contextual_reinforcement(m: MassFunction, rates: Mapping[Focal, float]) -> MassFunction:
    """Contextual reinforcement: m ∩ (∩ over contexts A of A^(1 - β_A)), A^w being m(A) = 1 - w, m(Θ) = w.

    The conjunctive counterpart of :func:`contextual_discount` (Mercier, Lefèvre &
    Delmotte 2012, "Belief functions contextual discounting and canonical
    decompositions", IJAR 53): the source is told that the truth is in A with
    weight β_A; equal to ``negation(contextual_discount(negation(m), {Ā: β_A}))``.
    The result may hold m(∅) > 0 (open world).

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b", "c"]), {"a|b": 0.6, "a|b|c": 0.4})
    >>> {k: round(v, 12) for k, v in contextual_reinforcement(m, {"a|c": 0.5}).to_dict().items()}
    {'a': 0.3, 'a|b': 0.3, 'a|c': 0.2, 'a|b|c': 0.2}
    """
    full = m.frame.full
    simple = [
        MassFunction(m.frame, {s: b, full: 1.0 - b} if s != full else {full: 1.0})
        for s, b in _contexts(m, rates, "rates")
    ]
    return combine(m, *simple, rule="conjunctive")
