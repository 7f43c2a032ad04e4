"""The registry of combination rules: :data:`RULES`, :class:`Rule` and :func:`register_rule`.

Every rule has the signature ``rule(sources, n) -> Stack``: ``sources`` is a
sequence of :class:`~evidential.stack.Stack` (one per source, each holding the
same number ``N`` of mass functions over a frame of ``n`` elements) and the
result stacks the ``N`` combined mass functions. Rules are defined for any
number of sources (one or more) and are registered with :func:`register_rule`,
which records the properties the rule claims; the shared check suite in the
tests runs every registered rule against its claims. The engine's own rules
are in :mod:`evidential.rules`.

Adding a rule is one function and one line::

    @register_rule("mean", properties={"commutative", "idempotent"}, empty_set="conflict")
    def mean(sources, n):
        ...

A rule registered from outside the engine (``builtin=False``, the default) is
wrapped in a checker: a result that is not a stack of mass functions (negative,
NaN, total off 1, mass on ∅ from a closed-world rule) raises
:class:`~evidential.errors.MassError` naming the rule, on every path that reaches
the registry (:func:`~evidential.combine`, :func:`~evidential.combine_batch`).
The built-in rules, proven by the shared suite, run unchecked.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import wraps

import numpy as np

from evidential.errors import MassError
from evidential.stack import Stack

RuleFunction = Callable[[Sequence[Stack], int], Stack]

PROPERTIES = frozenset({"commutative", "associative", "vacuous_identity", "idempotent", "bayes_on_bayesian"})
"""Properties a rule may claim. ``bayes_on_bayesian``: equal to ``bayes`` on Bayesian masses."""

EMPTY_SET = {
    "refuse": "a source with m(∅) > 0 raises MassError naming the rule (closed-world rules)",
    "conflict": "m(∅) of a source joins the conflict K, which the rule handles as its own (normalised, moved, kept)",
    "as_set": "∅ is combined as the set it is by the rule's set operation; the result may hold m(∅) > 0",
    "required": "every source must have m(∅) > 0 (subnormal); a normal source raises MassError naming the rule",
}
"""What a rule may do with mass on the empty set in its sources (:attr:`Rule.empty_set`)."""

RESULT_TOLERANCE = 1e-9
"""Largest distance of a checked (non built-in) rule's total mass from 1, and of a negative mass from 0."""


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
    empty_set : str
        What the rule does with sources holding m(∅) > 0: a key of :data:`EMPTY_SET`.
    builtin : bool
        A rule of the engine, run unchecked; other rules' results are checked.
    """

    name: str
    function: RuleFunction
    properties: frozenset[str]
    open_world: bool = False
    nondogmatic: bool = False
    empty_set: str = "refuse"
    builtin: bool = False

    def __call__(self, sources: Sequence[Stack], n: int) -> Stack:
        return self.function(sources, n)


RULES: dict[str, Rule] = {}
"""The registry of combination rules by name."""


def register_rule(
    name: str,
    *,
    properties: Iterable[str] = (),
    open_world: bool = False,
    nondogmatic: bool = False,
    empty_set: str = "refuse",
    builtin: bool = False,
) -> Callable[[RuleFunction], RuleFunction]:
    """Decorator registering ``function(sources, n) -> Stack`` in :data:`RULES` as ``name``.

    The registered function (also returned) refuses the sources that ``empty_set``
    excludes and, unless ``builtin``, checks that the result is a stack of mass
    functions (closed world unless ``open_world``).

    Examples
    --------
    >>> @register_rule("first_source", properties={"idempotent"})
    ... def first_source(sources, n):
    ...     return sources[0]
    >>> RULES["first_source"].properties, RULES["first_source"].empty_set
    (frozenset({'idempotent'}), 'refuse')
    >>> @register_rule("broken")
    ... def broken(sources, n):
    ...     return Stack(sources[0].masks, 2 * sources[0].masses)
    >>> broken([Stack(np.array([1]), np.ones((1, 1)))], 1)
    Traceback (most recent call last):
    ...
    evidential.errors.MassError: rule 'broken' returned masses summing to 2.0 (column 0), not 1 within 1e-09
    >>> del RULES["first_source"], RULES["broken"]
    """
    claimed = frozenset(properties)
    if claimed - PROPERTIES:
        raise ValueError(
            f"rule {name!r}: unknown properties {sorted(claimed - PROPERTIES)}; known: {sorted(PROPERTIES)}"
        )
    if empty_set not in EMPTY_SET:
        raise ValueError(f"rule {name!r}: empty_set must be one of {sorted(EMPTY_SET)}, got {empty_set!r}")
    if name in RULES:
        raise ValueError(f"rule {name!r} is already registered")

    def add(function: RuleFunction) -> RuleFunction:
        if empty_set in ("refuse", "required"):
            function = _guard_empty_set(name, function, required=empty_set == "required")
        if not builtin:
            function = _check_result(name, function, open_world, empty_set)
        RULES[name] = Rule(name, function, claimed, open_world, nondogmatic, empty_set, builtin)
        return function

    return add


def _guard_empty_set(name: str, function: RuleFunction, required: bool) -> RuleFunction:
    """``function`` refusing the sources with m(∅) > 0 (or, if ``required``, with m(∅) = 0)."""

    @wraps(function)
    def guarded(sources: Sequence[Stack], n: int) -> Stack:
        for i, s in enumerate(sources):
            empty = s.masses[0] if s.masks.size and s.masks[0] == 0 else np.zeros(s.masses.shape[1])
            bad = empty <= 0 if required else empty > 0
            if bad.any():
                row = int(np.argmax(bad))
                where = f", batch row {row}" if empty.size > 1 else ""
                need = "every source with mass on the empty set" if required else "no mass on the empty set"
                raise MassError(
                    f"rule {name!r} needs {need}: source {i}{where} has m(∅) = {float(empty[row])!r} "
                    f"(empty_set={'required' if required else 'refuse'!r})"
                )
        return function(sources, n)

    return guarded


def _check_result(name: str, function: RuleFunction, open_world: bool, empty_set: str) -> RuleFunction:
    """``function`` whose result is checked to be a stack of mass functions over ``n`` elements."""

    @wraps(function)
    def checked(sources: Sequence[Stack], n: int) -> Stack:
        out = function(sources, n)
        try:
            masks, masses = (np.asarray(a) for a in out)
        except (TypeError, ValueError):
            raise MassError(f"rule {name!r} returned {type(out).__name__}, not a Stack (masks, masses)") from None
        count = sources[0].masses.shape[1]
        if masks.ndim != 1 or not masks.size or masses.shape != (masks.size, count) or masks.dtype.kind not in "iu":
            raise MassError(
                f"rule {name!r} returned masks of shape {masks.shape} and masses of shape {masses.shape}, "
                f"not (K,) integers and (K, {count}) with K >= 1"
            )
        if masks.min() < 0 or masks.max() >= 1 << n or (np.diff(masks) <= 0).any():
            raise MassError(
                f"rule {name!r} returned focal sets {masks.tolist()}: not increasing bitmasks of {n} elements"
            )
        if not masses.min() >= -RESULT_TOLERANCE:  # NaN fails too
            k, col = np.argwhere(~(masses >= -RESULT_TOLERANCE))[0]
            raise MassError(
                f"rule {name!r} returned mass {float(masses[k, col])!r} on focal set {int(masks[k])} (column {col})"
            )
        total = masses.sum(axis=0)
        off = ~(np.abs(total - 1.0) <= RESULT_TOLERANCE)
        if off.any():
            col = int(np.argmax(off))
            raise MassError(
                f"rule {name!r} returned masses summing to {float(total[col])!r} (column {col}), "
                f"not 1 within {RESULT_TOLERANCE}"
            )
        if not open_world and empty_set != "as_set" and masks[0] == 0 and masses[0].max() > RESULT_TOLERANCE:
            col = int(np.argmax(masses[0]))
            raise MassError(
                f"rule {name!r} claims a closed world but returned m(∅) = {float(masses[0, col])!r} (column {col})"
            )
        return out

    return checked
