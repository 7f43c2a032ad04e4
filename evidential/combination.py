"""Combining mass functions: objects (:func:`combine`) and dense batches (:func:`combine_batch`).

Both resolve the rule the same way and call the same kernels from
:mod:`evidential.rules`; only the packing of the inputs differs.
"""

from __future__ import annotations

from functools import reduce

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.columns import COLUMN_MAX_BITS, dempster_columns
from evidential.errors import FrameError, MassError, TotalConflictError
from evidential.mass import MassFunction
from evidential.registry import RULES, Rule, RuleFunction
from evidential.rules import conjunctive, dempster
from evidential.stack import (
    Stack,
    dempster_fold,
    dempster_scaled,
    full,
    to_dense,
)
from evidential.validation import SUM_TOLERANCE, real_array


def _resolve(rule: str | RuleFunction) -> RuleFunction:
    if isinstance(rule, str):
        try:
            return RULES[rule].function
        except KeyError:
            raise ValueError(f"rule {rule!r} is not registered; known rules: {sorted(RULES)}") from None
    if isinstance(rule, Rule):
        return rule.function
    if callable(rule):
        return rule
    raise ValueError(f"rule must be a name in RULES or a callable, got {rule!r}")


def _stacks(masses: tuple[MassFunction, ...]) -> list[Stack]:
    if not masses:
        raise ValueError("combine needs at least one mass function, got none")
    frame = masses[0].frame
    for i, m in enumerate(masses):
        if not isinstance(m, MassFunction):
            raise TypeError(f"mass {i} must be a MassFunction, got {type(m).__name__}")
        if m.frame is not frame and m.frame != frame:
            raise FrameError(f"masses on different frames combined: mass 0 is on {frame!r}, mass {i} on {m.frame!r}")
    return [m.stack for m in masses]


def combine(*masses: MassFunction, rule: str | RuleFunction = "dempster") -> MassFunction:
    """Combine mass functions over one frame by a rule.

    Parameters
    ----------
    *masses : MassFunction
        One or more mass functions over the same frame.
    rule : str or callable
        A name in :data:`~evidential.registry.RULES` or a function ``(sources, n) -> Stack``.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["real", "noise"])
    >>> m1 = MassFunction(frame, {"real": 0.8, "noise": 0.1, "real|noise": 0.1})
    >>> m2 = MassFunction(frame, {"real": 0.3, frame.full: 0.7})
    >>> {k: round(v, 6) for k, v in combine(m1, m2).to_dict().items()}
    {'real': 0.85567, 'noise': 0.072165, 'real|noise': 0.072165}
    >>> combine(m1, m2, rule="conjunctive")[""]
    0.03
    """
    stacks = _stacks(masses)
    frame = masses[0].frame
    n = len(frame)
    function = _resolve(rule)
    if function is dempster and len(stacks) > 1:
        # pair by pair (the rule's sums in fewer numpy calls) unless that costs twice the Möbius
        # strategy (which redoes the fold near total conflict)
        try:
            folded = dempster_fold(stacks, n, margin=2.0)
        except TotalConflictError:
            return MassFunction.from_stack(frame, dempster_scaled(stacks, n))
        if folded is not None:
            return MassFunction.from_stack(frame, folded, positive=True)
    return MassFunction.from_stack(frame, function(stacks, n))


def conflict(*masses: MassFunction) -> float:
    """K: the conjunctive mass on the empty set (sum of prod m_i(A_i) over empty intersections).

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b"])
    >>> round(conflict(MassFunction(frame, {"a": 0.9, "b": 0.1}), MassFunction(frame, {"b": 0.5, "a|b": 0.5})), 12)
    0.45
    """
    stacks = _stacks(masses)
    c = conjunctive(stacks, len(masses[0].frame))
    return float(c.masses[0, 0]) if c.masks.size and c.masks[0] == 0 else 0.0


SAMPLE_ROWS = 64
"""Rows in which :func:`_support` first looks for the sets a batch uses."""


def _batch(i: int, array: ArrayLike, shape: tuple[int, ...] | None, columns: bool) -> NDArray[np.float64]:
    """Validated (2**n, N) C-contiguous copy of a (N, 2**n) batch; with ``columns``, up to
    2**:data:`~evidential.stack.COLUMN_MAX_BITS` sets, its transposed view (validated column
    by column, for :func:`~evidential.stack.dempster_columns` to read in place)."""
    a = real_array(array, f"batch {i}")
    size = a.shape[-1] if a.ndim == 2 else 0
    if size < 2 or size & (size - 1) or (shape is not None and a.shape != shape):
        want = "(N, 2**n) with n >= 1" if shape is None else f"{shape} like batch 0"
        raise MassError(f"batch {i} must have shape {want}, got {a.shape}")
    narrow = columns and size <= 1 << COLUMN_MAX_BITS
    t = a.T if narrow else np.ascontiguousarray(a.T)
    if t.size and not t.min() >= 0:
        col, row = np.argwhere(~(t >= 0))[0]
        raise MassError(
            f"batch {i}, row {row}: mass of focal set {col} must be finite and >= 0, got {float(t[col, row])!r}"
        )
    total = reduce(np.add, t) if narrow else t.sum(axis=0)  # the same sums, set by set
    if total.size and not (total.min() >= 1.0 - SUM_TOLERANCE and total.max() <= 1.0 + SUM_TOLERANCE):
        row = int(np.argmax(np.abs(total - 1.0)))
        raise MassError(
            f"batch {i}, row {row}: masses must sum to 1 (within {SUM_TOLERANCE}), got {float(total[row])!r}"
        )
    return t


def combine_batch(*batches: ArrayLike, rule: str | RuleFunction = "dempster") -> NDArray[np.float64]:
    """Combine N independent tuples of mass functions, stacked as dense arrays.

    Parameters
    ----------
    *batches : array_like, shape (N, 2**n)
        One array per source; column ``b`` is the mass of the focal set with
        bitmask ``b`` (bit i = frame element i, column 0 = the empty set), row
        ``j`` of every array belongs to combination ``j``.
    rule : str or callable
        As for :func:`combine`; ``"conjunctive"`` leaves K in column 0.

    Returns
    -------
    ndarray, shape (N, 2**n)
        Row ``j`` is the combination of the rows ``j`` (a transposed view of a
        C-contiguous (2**n, N) array); N may be 0.

    Examples
    --------
    >>> M1 = np.array([[0, 0.8, 0.1, 0.1], [0, 0.5, 0.5, 0]])
    >>> M2 = np.array([[0, 0.3, 0, 0.7], [0, 0, 0, 1.0]])
    >>> combine_batch(M1, M2).round(6).tolist()
    [[0.0, 0.85567, 0.072165, 0.072165], [0.0, 0.5, 0.5, 0.0]]
    """
    if not batches:
        raise ValueError("combine_batch needs at least one batch, got none")
    function = _resolve(rule)  # first: Dempster's rule reads narrow batches in place
    columns = function is dempster
    first = _batch(0, batches[0], None, columns)
    shape = (first.shape[1], first.shape[0])
    arrays = [first] + [_batch(i, b, shape, columns) for i, b in enumerate(batches[1:], 1)]
    n = first.shape[0].bit_length() - 1
    if not shape[0]:  # no rows: nothing to combine
        return np.zeros((1 << n, 0)).T
    if columns and n <= COLUMN_MAX_BITS:
        dense = dempster_columns(arrays, n)
        if dense is not None:
            return dense.T
        arrays = [np.ascontiguousarray(a) for a in arrays]  # underflow or total conflict: the general path
    result = function([_support(a) for a in arrays], n)
    out = result.masses if result.masks.size == 1 << n else to_dense(result, n)
    if any(np.may_share_memory(out, a) for a in arrays):  # a rule that returned a source as it is
        out = out.copy()
    return out.T


def _support(dense: NDArray[np.float64]) -> Stack:
    """The stack of a dense (2**n, N) batch (masses >= 0), without the sets of mass 0 in every
    row where they are half of the sets or more (fewer sets, fewer pairs; below that, the
    copy costs more than the pairs it saves). Where the first :data:`SAMPLE_ROWS` rows
    already use over half of the sets, the rest is not read."""
    size = dense.shape[0]
    if 2 * np.count_nonzero(dense[:, :SAMPLE_ROWS].max(axis=1)) > size:
        return full(dense)
    used = dense.max(axis=1) > 0
    if 2 * np.count_nonzero(used) > size:
        return full(dense)
    return Stack(np.flatnonzero(used), dense[used])
