"""Belief, plausibility and commonality of one mass function's stack: of one set, or of many in one numpy pass.

The functions behind :meth:`MassFunction.belief <evidential.mass.MassFunction.belief>`,
``plausibility`` and ``commonality``: a set tested against every focal set at once,
a list or a 1-D array of sets as a (Q, K) test.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evidential.frame import Focal, Frame
from evidential.stack import Stack
from evidential.validation import focal_masks

QUERY_INT32_BITS = 31
"""Up to this many elements, the batched queries test int32 bitmasks."""

Query = Focal | list[Focal] | NDArray
"""One focal set, or a list or a 1-D array of focal sets."""


def _operands(frame: Frame, stack: Stack, focal: Query) -> tuple[NDArray, int | NDArray]:
    """The focal sets' bitmasks and the queried set: an int for one focal set, a (Q, 1)
    column for a list or a 1-D array of them, both int32 where the frame fits in 31 bits
    (half the memory a (Q, K) test goes through)."""
    masks = stack.masks
    if not isinstance(focal, list | np.ndarray):
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


def belief(frame: Frame, stack: Stack, focal: Query) -> float | NDArray[np.float64]:
    """bel(A): the mass of the non-empty focal sets inside A (the first column of ``stack``)."""
    masks, a = _operands(frame, stack, focal)
    selected = masks & ~a == 0
    if masks[0] == 0:  # increasing: ∅ can only come first
        selected[..., 0] = False
    return _sums(stack, selected)


def plausibility(frame: Frame, stack: Stack, focal: Query) -> float | NDArray[np.float64]:
    """pl(A): the mass of the focal sets meeting A."""
    masks, a = _operands(frame, stack, focal)
    return _sums(stack, masks & a != 0)


def commonality(frame: Frame, stack: Stack, focal: Query) -> float | NDArray[np.float64]:
    """q(A): the mass of the focal sets containing A."""
    masks, a = _operands(frame, stack, focal)
    return _sums(stack, masks & a == a)
