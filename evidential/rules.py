"""The engine's combination rules, each registered in :data:`~evidential.registry.RULES`.

Each is a plain function ``rule(sources, n) -> Stack`` over stacked sources (see
:mod:`evidential.registry`), built on the kernels of :mod:`evidential.stack`:
the conjunctive family (conjunctive, Dempster, Yager, Murphy, Bayes), the
disjunctive one (disjunctive, Dubois & Prade), the proportional conflict
redistributions (PCR5, PCR6) and the rules of the canonical weights (cautious,
bold). Every one runs through the shared check suite of the tests.

The registry's names (:data:`RULES`, :func:`register_rule`, :class:`Rule`,
:data:`PROPERTIES`, :data:`EMPTY_SET`) are handed on here too, where plugins
have imported them from.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import reduce

import numpy as np
from numpy.typing import NDArray

from evidential.errors import MassError, TotalConflictError
from evidential.registry import EMPTY_SET, PROPERTIES, RULES, Rule, RuleFunction, register_rule
from evidential.stack import (
    DENSE_MAX_BITS,
    SCALE_FLOOR,
    Stack,
    aggregate,
    dempster_scaled,
    full,
    mobius_cost_wins,
    pairwise,
    product_scaled,
    to_dense,
    transform_product,
)
from evidential.transforms import sweep

__all__ = [
    "EMPTY_SET",
    "NEAR_TOTAL_CONFLICT",
    "PROPERTIES",
    "RULES",
    "Rule",
    "RuleFunction",
    "bayes",
    "bold",
    "cautious",
    "conjunctive",
    "dempster",
    "disjunctive",
    "dubois_prade",
    "murphy",
    "pcr5",
    "pcr6",
    "register_rule",
    "yager",
]

NEAR_TOTAL_CONFLICT = 1e-2
"""Below this non-conflicting mass, a normalized result is recomputed pairwise (exact sums)."""


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
    low = z.min()
    if dense and low < NEAR_TOTAL_CONFLICT:  # Möbius round-off matters: redo these exactly
        rows = np.flatnonzero(z < NEAR_TOTAL_CONFLICT)
        exact = _fold([Stack(s.masks, s.masses[:, rows]) for s in sources], n, np.bitwise_and)
        m[:, rows] = to_dense(exact, n)
        z[rows] = m[1:, rows].sum(axis=0)
        low = z.min()
    if low < SCALE_FLOOR:  # products may have underflowed: fold again with exponents kept apart
        return dempster_scaled(list(sources), n)
    if not low > 0:
        row = int(np.argmin(z))
        where = f" (batch row {row})" if z.size > 1 else ""
        raise TotalConflictError(
            f"total conflict{where}: K = {float(m[0, row])!r}, the sources share no focal element; "
            "Dempster's rule is undefined"
        )
    if dense:
        m[0] = 0.0
        m[1:] /= z
        return c
    return Stack(c.masks[1:], m[1:] / z)


@register_rule(
    "dempster",
    properties={"commutative", "associative", "vacuous_identity", "bayes_on_bayesian"},
    empty_set="conflict",
    builtin=True,
)
def dempster(sources: Sequence[Stack], n: int) -> Stack:
    """Dempster's rule: conjunctive, then the conflict K normalised away.

    m(A) = sum over A1 ∩ ... ∩ AS = A of prod m_i(A_i), divided by 1 - K;
    raises :class:`TotalConflictError` when K = 1.
    """
    return _normalize(sources, n)


@register_rule(
    "conjunctive",
    properties={"commutative", "associative", "vacuous_identity"},
    open_world=True,
    empty_set="as_set",
    builtin=True,
)
def conjunctive(sources: Sequence[Stack], n: int) -> Stack:
    """The unnormalized conjunctive rule (TBM, open world): the conflict K stays on ∅."""
    return _conjunctive(sources, n)[0]


@register_rule("disjunctive", properties={"commutative", "associative"}, empty_set="as_set", builtin=True)
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


@register_rule("yager", properties={"commutative", "vacuous_identity"}, empty_set="conflict", builtin=True)
def yager(sources: Sequence[Stack], n: int) -> Stack:
    """Yager's rule: conjunctive combination of all sources, the conflict K given to Θ."""
    return _move_empty(_conjunctive(sources, n)[0], n, (1 << n) - 1)


@register_rule("dubois_prade", properties={"commutative", "vacuous_identity"}, empty_set="refuse", builtin=True)
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


def _clashes(sources: Sequence[Stack]) -> tuple[NDArray[np.int64], NDArray[np.float64], list, list]:
    """Every combination X1, ..., XS of focal sets: the non-empty intersections and their
    products, and (sets, masses) per source of the combinations whose intersection is empty."""
    grid = np.indices([s.masks.size for s in sources]).reshape(len(sources), -1)
    sets = [s.masks[g] for s, g in zip(sources, grid)]
    parts = [s.masses[g] for s, g in zip(sources, grid)]
    inter = np.bitwise_and.reduce(sets) if len(sets) > 1 else sets[0]
    w = reduce(np.multiply, parts)
    agree = inter != 0
    clash = ~agree
    return inter[agree], w[agree], [x[clash] for x in sets], [p[clash] for p in parts]


@register_rule("pcr6", properties={"commutative", "vacuous_identity"}, empty_set="refuse", builtin=True)
def pcr6(sources: Sequence[Stack], n: int) -> Stack:
    """PCR6 (Martin & Osswald 2006): each combination X1, ..., XS with an empty
    intersection gives its mass prod m_j(X_j) back to every X_i in proportion to
    m_i(X_i); equal to PCR5 for two sources. Not associative: all sources at once.
    Closed world: a source with m(∅) > 0 is refused."""
    inter, w, sets, parts = _clashes(sources)
    conflict = reduce(np.multiply, parts)
    total = reduce(np.add, parts)
    share = np.divide(conflict, total, out=np.zeros_like(total), where=total > 0)
    keys = np.concatenate([inter, *sets])
    weights = np.concatenate([w, *(p * share for p in parts)])
    return aggregate(keys, weights, n)


@register_rule("pcr5", properties={"commutative", "vacuous_identity"}, empty_set="refuse", builtin=True)
def pcr5(sources: Sequence[Stack], n: int) -> Stack:
    """PCR5 for S sources (Smarandache & Dezert 2006, DSmT vol. 2, ch. 1, eq. 1.32):
    each combination X1, ..., XS with an empty intersection gives its mass
    prod m_j(X_j) to the distinct sets Y among the X_i, in proportion to the
    product of the masses the sources naming Y give it. Equal to PCR6 for two
    sources. Not associative: all sources at once. Closed world: a source with
    m(∅) > 0 is refused.

    Examples
    --------
    >>> a = Stack(np.array([1, 4]), np.array([[0.9], [0.1]]))
    >>> b = Stack(np.array([2, 4]), np.array([[0.9], [0.1]]))
    >>> r = pcr5([a, b], 3)
    >>> r.masks.tolist(), r.masses[:, 0].round(12).tolist()  # Zadeh's example: a, b, c
    ([1, 2, 4], [0.486, 0.486, 0.028])
    """
    inter, w, sets, parts = _clashes(sources)
    conflict = reduce(np.multiply, parts)
    group = []  # the product of the masses of the sources naming X_i, and how many name it
    for x in sets:
        same = [(x == y)[:, None] for y in sets]
        product = reduce(np.multiply, [np.where(eq, p, 1.0) for eq, p in zip(same, parts)])
        group.append((product, reduce(np.add, [eq.astype(np.float64) for eq in same])))
    total = reduce(np.add, [g / c for g, c in group])  # the sum over the distinct sets
    share = np.divide(conflict, total, out=np.zeros_like(total), where=total > 0)
    keys = np.concatenate([inter, *sets])
    weights = np.concatenate([w, *(g / c * share for g, c in group)])
    return aggregate(keys, weights, n)


def _average(sources: Sequence[Stack], n: int) -> Stack:
    keys = np.concatenate([s.masks for s in sources])
    return aggregate(keys, np.concatenate([s.masses for s in sources]) / len(sources), n)


@register_rule("murphy", properties={"commutative"}, empty_set="conflict", builtin=True)
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


@register_rule(
    "bayes", properties={"commutative", "associative", "bayes_on_bayesian"}, empty_set="conflict", builtin=True
)
def bayes(sources: Sequence[Stack], n: int) -> Stack:
    """The Bayesian alternative: the product of the sources' pignistic probabilities,
    normalised; the result is Bayesian (singletons only)."""
    p = product_scaled([_pignistic(s, n) for s in sources])
    z = p.sum(axis=0)
    if not z.min() > 0:
        row = int(np.argmin(z))
        where = f" (batch row {row})" if z.size > 1 else ""
        raise TotalConflictError(
            f"total conflict{where}: K = 1.0, the pignistic probabilities have no element in common"
        )
    return Stack(np.int64(1) << np.arange(n, dtype=np.int64), p / z)


def _min_weights(dense: list[NDArray[np.float64]], n: int, rule: str, need: str) -> NDArray[np.float64]:
    """The unnormalized mass function whose conjunctive weights are the minimum of those of
    the dense (2**n, N) sources (Denœux 2008); every source needs m(Θ) > 0: ``need`` says
    what that is for the caller's ``rule``."""
    log_w = None
    for i, m in enumerate(dense):
        q = sweep(m, superset=True, inverse=False)
        if not q[-1].min() > 0:
            row = int(np.argmin(q[-1]))
            where = f", batch row {row}" if q.shape[1] > 1 else ""
            raise MassError(f"the {rule} rule needs {need}: source {i}{where} has {float(q[-1, row])!r}")
        lw = -sweep(np.log(q), superset=True, inverse=True)  # ln w(A) for A ≠ Θ
        log_w = lw if log_w is None else np.minimum(log_w, lw)
    log_w[-1] = -log_w[:-1].sum(axis=0)  # so that ln q = -(superset sum of ln w)
    m = sweep(np.exp(-sweep(log_w, superset=True, inverse=False)), superset=True, inverse=True)
    m[m <= 64 * (n + len(dense)) * np.finfo(np.float64).eps] = 0.0
    return m


@register_rule(
    "cautious",
    properties={"commutative", "associative", "idempotent"},
    nondogmatic=True,
    empty_set="conflict",
    builtin=True,
)
def cautious(sources: Sequence[Stack], n: int) -> Stack:
    """Denœux's cautious rule (2008), normalised: the minimum of the conjunctive
    canonical weights, w(A) = min_i w_i(A), then ∅ normalised away.

    Every source must be non-dogmatic (m(Θ) > 0; discount it first otherwise);
    frames up to ``DENSE_MAX_BITS`` elements (the weights are dense).
    """
    if n > DENSE_MAX_BITS:
        raise MassError(f"the cautious rule needs a frame of at most {DENSE_MAX_BITS} elements, got {n}")
    m = _min_weights([to_dense(s, n) for s in sources], n, "cautious", "non-dogmatic sources, m(Θ) > 0")
    return Stack(np.arange(1, 1 << n, dtype=np.int64), m[1:] / m[1:].sum(axis=0))


@register_rule(
    "bold",
    properties={"commutative", "associative", "idempotent"},
    open_world=True,
    empty_set="required",
    builtin=True,
)
def bold(sources: Sequence[Stack], n: int) -> Stack:
    """Denœux's bold disjunctive rule (2008): the minimum of the disjunctive canonical
    weights, v(A) = min_i v_i(A), the dual of the unnormalized cautious rule.

    Computed as the negation (m̄(A) = m(Ā)) of the unnormalized cautious
    combination of the negated sources. Every source must be subnormal
    (m(∅) > 0): the disjunctive weights exist only then. The result is subnormal
    (open world); frames up to ``DENSE_MAX_BITS`` elements.

    Examples
    --------
    >>> s = Stack(np.array([0, 1, 3]), np.array([[0.2], [0.5], [0.3]]))
    >>> bold([s, s], 2).masses[:, 0].round(12).tolist()  # idempotent
    [0.2, 0.5, 0.0, 0.3]
    """
    if n > DENSE_MAX_BITS:
        raise MassError(f"the bold rule needs a frame of at most {DENSE_MAX_BITS} elements, got {n}")
    m = _min_weights([to_dense(s, n)[::-1].copy() for s in sources], n, "bold", "subnormal sources, m(∅) > 0")
    return full(np.ascontiguousarray(m[::-1]))
