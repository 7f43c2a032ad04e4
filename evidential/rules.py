"""Combination rules: plain functions over stacked sources, in one registry.

Every rule has the signature ``rule(sources, n) -> Stack``: ``sources`` is a
sequence of :class:`~evidential.stack.Stack` (one per source, each holding the
same number ``N`` of mass functions over a frame of ``n`` elements) and the
result stacks the ``N`` combined mass functions. Rules are defined for any
number of sources (one or more) and are registered with :func:`register_rule`,
which records the properties the rule claims; the shared check suite in the
tests runs every registered rule against its claims.

Adding a rule is one function and one line::

    @register_rule("mean", properties={"commutative", "idempotent"})
    def mean(sources, n):
        ...
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import reduce

import numpy as np
from numpy.typing import NDArray

from evidential.errors import MassError, TotalConflictError
from evidential.stack import (
    DENSE_MAX_BITS,
    Stack,
    aggregate,
    full,
    mobius_cost_wins,
    pairwise,
    to_dense,
    transform_product,
)
from evidential.transforms import sweep

RuleFunction = Callable[[Sequence[Stack], int], Stack]

PROPERTIES = frozenset({"commutative", "associative", "vacuous_identity", "idempotent", "bayes_on_bayesian"})
"""Properties a rule may claim. ``bayes_on_bayesian``: equal to ``bayes`` on Bayesian masses."""

NEAR_TOTAL_CONFLICT = 1e-2
"""Below this non-conflicting mass, a normalized result is recomputed pairwise (exact sums)."""


@dataclass(frozen=True)
class Rule:
    """A registered combination rule and the properties it claims.

    Attributes
    ----------
    name : str
    function : callable
        ``function(sources, n) -> Stack``.
    properties : frozenset of str
        Subset of :data:`PROPERTIES`.
    open_world : bool
        The result keeps the conflict as mass on the empty set.
    nondogmatic : bool
        The rule needs every source non-dogmatic (m(Θ) > 0).
    """

    name: str
    function: RuleFunction
    properties: frozenset[str]
    open_world: bool = False
    nondogmatic: bool = False

    def __call__(self, sources: Sequence[Stack], n: int) -> Stack:
        return self.function(sources, n)


RULES: dict[str, Rule] = {}
"""The registry of combination rules by name."""


def register_rule(
    name: str, *, properties: Iterable[str] = (), open_world: bool = False, nondogmatic: bool = False
) -> Callable[[RuleFunction], RuleFunction]:
    """Decorator registering ``function(sources, n) -> Stack`` in :data:`RULES` as ``name``.

    Examples
    --------
    >>> @register_rule("first_source", properties={"idempotent"})
    ... def first_source(sources, n):
    ...     return sources[0]
    >>> RULES["first_source"].properties
    frozenset({'idempotent'})
    >>> del RULES["first_source"]
    """
    claimed = frozenset(properties)
    if claimed - PROPERTIES:
        raise ValueError(
            f"rule {name!r}: unknown properties {sorted(claimed - PROPERTIES)}; known: {sorted(PROPERTIES)}"
        )
    if name in RULES:
        raise ValueError(f"rule {name!r} is already registered")

    def add(function: RuleFunction) -> RuleFunction:
        RULES[name] = Rule(name, function, claimed, open_world, nondogmatic)
        return function

    return add


def _fold(sources: Sequence[Stack], n: int, op: np.ufunc) -> Stack:
    return reduce(lambda a, b: aggregate(*pairwise(a, b, op), n), sources)


def _conjunctive(sources: Sequence[Stack], n: int) -> tuple[Stack, bool]:
    """The unnormalized conjunctive combination and whether it went the Möbius way."""
    if len(sources) > 1 and mobius_cost_wins(sources, n):
        return full(transform_product(sources, n, superset=True)), True
    return _fold(sources, n, np.bitwise_and), False


def _normalize(sources: Sequence[Stack], n: int) -> Stack:
    """Dempster's rule: m(A) = m∩(A) / sum of m∩(B) over B ≠ ∅, ∅ excluded.

    Normalises by the sum of the non-empty conjunctive masses, not by 1 - K, so a
    near-total conflict keeps full relative precision. After the Möbius strategy
    the result is all 2**n sets, ∅ with mass 0, normalised in place.
    """
    c, dense = _conjunctive(sources, n)
    if c.masks[0] != 0:
        return c
    m = c.masses
    z = m[1:].sum(axis=0)
    if dense and z.min() < NEAR_TOTAL_CONFLICT:  # Möbius round-off matters: redo these exactly
        rows = np.flatnonzero(z < NEAR_TOTAL_CONFLICT)
        exact = _fold([Stack(s.masks, s.masses[:, rows]) for s in sources], n, np.bitwise_and)
        m[:, rows] = to_dense(exact, n)
        z[rows] = m[1:, rows].sum(axis=0)
    if not z.min() > 0:
        row = int(np.argmin(z))
        where = f" (batch row {row})" if z.size > 1 else ""
        raise TotalConflictError(
            f"total conflict{where}: K = {float(m[0, row])!r}, the sources share no focal element; "
            "Dempster's rule is undefined"
        )
    if dense:
        m[0] = 0.0
        m /= z
        return c
    return Stack(c.masks[1:], m[1:] / z)


@register_rule("dempster", properties={"commutative", "associative", "vacuous_identity", "bayes_on_bayesian"})
def dempster(sources: Sequence[Stack], n: int) -> Stack:
    """Dempster's rule: conjunctive, then the conflict K normalised away.

    m(A) = sum over A1 ∩ ... ∩ AS = A of prod m_i(A_i), divided by 1 - K;
    raises :class:`TotalConflictError` when K = 1.
    """
    return _normalize(sources, n)


@register_rule("conjunctive", properties={"commutative", "associative", "vacuous_identity"}, open_world=True)
def conjunctive(sources: Sequence[Stack], n: int) -> Stack:
    """The unnormalized conjunctive rule (TBM, open world): the conflict K stays on ∅."""
    return _conjunctive(sources, n)[0]


@register_rule("disjunctive", properties={"commutative", "associative"})
def disjunctive(sources: Sequence[Stack], n: int) -> Stack:
    """The disjunctive rule: m(A) = sum over A1 ∪ ... ∪ AS = A of prod m_i(A_i)."""
    if len(sources) > 1 and mobius_cost_wins(sources, n):
        return full(transform_product(sources, n, superset=False))
    return _fold(sources, n, np.bitwise_or)


def _move_empty(s: Stack, n: int, target: int) -> Stack:
    """The stack with the mass of ∅ moved onto the focal set ``target``."""
    if s.masks[0] != 0:
        return s
    keys = s.masks.copy()
    keys[0] = target
    return aggregate(keys, s.masses, n)


@register_rule("yager", properties={"commutative", "vacuous_identity"})
def yager(sources: Sequence[Stack], n: int) -> Stack:
    """Yager's rule: conjunctive combination of all sources, the conflict K given to Θ."""
    return _move_empty(_conjunctive(sources, n)[0], n, (1 << n) - 1)


@register_rule("dubois_prade", properties={"commutative", "vacuous_identity"})
def dubois_prade(sources: Sequence[Stack], n: int) -> Stack:
    """Dubois & Prade's rule: a combination A1, ..., AS with an empty intersection
    gives its mass to the union A1 ∪ ... ∪ AS."""
    inter, union, w = sources[0].masks, sources[0].masks, sources[0].masses
    for s in sources[1:]:
        inter, w = pairwise(Stack(inter, w), s, np.bitwise_and)
        union = np.bitwise_or.outer(union, s.masks).ravel()
        if 2 * n <= 62 and s is not sources[-1]:  # merge equal (intersection, union) pairs
            merged = aggregate(inter << n | union, w, 2 * n)
            inter, union, w = merged.masks >> n, merged.masks & ((1 << n) - 1), merged.masses
    return aggregate(np.where(inter != 0, inter, union), w, n)


@register_rule("pcr6", properties={"commutative", "vacuous_identity"})
def pcr6(sources: Sequence[Stack], n: int) -> Stack:
    """PCR6 (Martin & Osswald 2006): each combination X1, ..., XS with an empty
    intersection gives its mass prod m_j(X_j) back to every X_i in proportion to
    m_i(X_i); equal to PCR5 for two sources. Not associative: all sources at once."""
    grid = np.indices([s.masks.size for s in sources]).reshape(len(sources), -1)
    sets = [s.masks[g] for s, g in zip(sources, grid)]
    parts = [s.masses[g] for s, g in zip(sources, grid)]
    inter = np.bitwise_and.reduce(sets) if len(sets) > 1 else sets[0]
    w = reduce(np.multiply, parts)
    agree = inter != 0
    clash = ~agree
    total = reduce(np.add, [p[clash] for p in parts])
    share = np.divide(w[clash], total, out=np.zeros_like(total), where=total > 0)
    keys = np.concatenate([inter[agree], *(x[clash] for x in sets)])
    weights = np.concatenate([w[agree], *(p[clash] * share for p in parts)])
    return aggregate(keys, weights, n)


def _average(sources: Sequence[Stack], n: int) -> Stack:
    keys = np.concatenate([s.masks for s in sources])
    return aggregate(keys, np.concatenate([s.masses for s in sources]) / len(sources), n)


@register_rule("murphy", properties={"commutative"})
def murphy(sources: Sequence[Stack], n: int) -> Stack:
    """Murphy's rule (2000): the average of the S sources, combined with itself by
    Dempster's rule S - 1 times."""
    mean = _average(sources, n)
    return _normalize([mean] * len(sources), n)


def _pignistic(s: Stack, n: int) -> NDArray[np.float64]:
    """(n, N) pignistic probabilities of a stack."""
    member = (s.masks[:, None] >> np.arange(n) & 1).astype(np.float64)
    size = member.sum(axis=1)
    size[size == 0] = np.inf  # ∅ shares nothing
    p = np.einsum("ki,kj->ij", member, s.masses / size[:, None])  # no BLAS threads
    z = p.sum(axis=0)  # 1 - m(∅)
    return np.divide(p, z, out=np.zeros_like(p), where=z > 0)


@register_rule("bayes", properties={"commutative", "associative", "bayes_on_bayesian"})
def bayes(sources: Sequence[Stack], n: int) -> Stack:
    """The Bayesian alternative: the product of the sources' pignistic probabilities,
    normalised; the result is Bayesian (singletons only)."""
    p = reduce(np.multiply, [_pignistic(s, n) for s in sources])
    z = p.sum(axis=0)
    if not z.min() > 0:
        row = int(np.argmin(z))
        where = f" (batch row {row})" if z.size > 1 else ""
        raise TotalConflictError(
            f"total conflict{where}: K = 1.0, the pignistic probabilities have no element in common"
        )
    return Stack(np.int64(1) << np.arange(n, dtype=np.int64), p / z)


@register_rule("cautious", properties={"commutative", "associative", "idempotent"}, nondogmatic=True)
def cautious(sources: Sequence[Stack], n: int) -> Stack:
    """Denœux's cautious rule (2008), normalised: the minimum of the conjunctive
    canonical weights, w(A) = min_i w_i(A), then ∅ normalised away.

    Every source must be non-dogmatic (m(Θ) > 0; discount it first otherwise);
    frames up to ``DENSE_MAX_BITS`` elements (the weights are dense).
    """
    if n > DENSE_MAX_BITS:
        raise MassError(f"the cautious rule needs a frame of at most {DENSE_MAX_BITS} elements, got {n}")
    log_w = None
    for i, s in enumerate(sources):
        q = sweep(to_dense(s, n), superset=True, inverse=False)
        if not q[-1].min() > 0:
            row = int(np.argmin(q[-1]))
            where = f", batch row {row}" if q.shape[1] > 1 else ""
            raise MassError(
                f"the cautious rule needs non-dogmatic sources: source {i}{where} has m(Θ) = {float(q[-1, row])!r}"
            )
        lw = -sweep(np.log(q), superset=True, inverse=True)  # ln w(A) for A ≠ Θ
        log_w = lw if log_w is None else np.minimum(log_w, lw)
    log_w[-1] = -log_w[:-1].sum(axis=0)  # so that ln q = -(superset sum of ln w)
    m = sweep(np.exp(-sweep(log_w, superset=True, inverse=False)), superset=True, inverse=True)
    m[m <= 64 * (n + len(sources)) * np.finfo(np.float64).eps] = 0.0
    return Stack(np.arange(1, 1 << n, dtype=np.int64), m[1:] / m[1:].sum(axis=0))
