"""Belief, plausibility and commonality of one mass function's stack: of one set, or of many in one numpy pass.

The functions behind :meth:`MassFunction.belief <evidential.mass.MassFunction.belief>`,
``plausibility`` and ``commonality``: a set tested against every focal set at once,
a list or a 1-D array of sets as a (Q, K) test. One set over at most
:data:`PYTHON_MAX_SETS` focal sets is summed in plain Python over the stack's
:func:`python_pairs`, which the caller keeps.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evidential.frame import Focal, Frame
from evidential.stack import Stack
from evidential.validation import focal_masks

QUERY_INT32_BITS = 31
"""Up to this many elements, the batched queries test int32 bitmasks."""

PYTHON_MAX_SETS = 7
"""Up to this many focal sets, one set's query is summed in plain Python, left to right from 0.0:
numpy sums fewer than 8 values the same way (its pairwise sum unrolls blocks of 8), so the same bits."""

Query = Focal | list[Focal] | NDArray
"""One focal set, or a list or a 1-D array of focal sets."""

Many = list | np.ndarray
"""The types of a query of many sets (made once: ``list | np.ndarray`` written in a call costs 0.1 µs)."""

Pairs = list[tuple[int, float]]
"""A stack's focal sets (bitmasks) with their masses in its first column, as Python numbers in stack order."""


def python_pairs(stack: Stack) -> Pairs | None:
    """The stack's :data:`Pairs` where it has at most :data:`PYTHON_MAX_SETS` focal sets, else None."""
    if stack.masks.size > PYTHON_MAX_SETS:
        return None
    return list(zip(stack.masks.tolist(), stack.masses[:, 0].tolist()))


def _operands(frame: Frame, stack: Stack, focal: Query) -> tuple[NDArray, int | NDArray]:
    """The focal sets' bitmasks and the queried set: an int for one focal set, a (Q, 1)
    column for a list or a 1-D array of them, both int32 where the frame fits in 31 bits
    (half the memory a (Q, K) test goes through)."""
    masks = stack.masks
    if not isinstance(focal, Many):
        return masks, frame.mask(focal)
    sets = focal_masks(frame, focal, distinct=False)
    if len(frame) <= QUERY_INT32_BITS:
        return masks.astype(np.int32), sets.astype(np.int32)[:, None]
    return masks, sets[:, None]


def _sums(stack: Stack, selected: NDArray[np.bool_]) -> float | NDArray[np.float64]:
    """The mass of the selected focal sets: a float for (K,), an array for (Q, K)."""
    masses = stack.masses[:, 0]
    if selected.ndim == 1:
        return float(masses[selected].sum())
    return np.einsum("qk,k->q", selected, masses)  # no (Q, K) float temporary, no BLAS threads


def belief(frame: Frame, stack: Stack, focal: Query, pairs: Pairs | None = None) -> float | NDArray[np.float64]:
    """bel(A): the mass of the non-empty focal sets inside A (the first column of ``stack``).

    ``pairs``: the stack's :func:`python_pairs`, for one set summed in Python (the same float).
    """
    if pairs is not None and not isinstance(focal, Many):
        a, total = frame.mask(focal), 0.0
        for k, w in pairs:
            if k and not k & ~a:  # ∅ (k = 0) left out
                total += w
        return total
    masks, a = _operands(frame, stack, focal)
    selected = masks & ~a == 0
    if masks[0] == 0:  # increasing: ∅ can only come first
        selected[..., 0] = False
    return _sums(stack, selected)


def plausibility(frame: Frame, stack: Stack, focal: Query, pairs: Pairs | None = None) -> float | NDArray[np.float64]:
    """pl(A): the mass of the focal sets meeting A (``pairs``: see :func:`belief`)."""
    if pairs is not None and not isinstance(focal, Many):
        a, total = frame.mask(focal), 0.0
        for k, w in pairs:
            if k & a:
                total += w
        return total
    masks, a = _operands(frame, stack, focal)
    return _sums(stack, masks & a != 0)


def commonality(frame: Frame, stack: Stack, focal: Query, pairs: Pairs | None = None) -> float | NDArray[np.float64]:
    """q(A): the mass of the focal sets containing A (``pairs``: see :func:`belief`)."""
    if pairs is not None and not isinstance(focal, Many):
        a, total = frame.mask(focal), 0.0
        for k, w in pairs:
            if k & a == a:
                total += w
        return total
    masks, a = _operands(frame, stack, focal)
    return _sums(stack, masks & a == a)
