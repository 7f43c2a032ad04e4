"""The masses of single elements: which elements each focal set holds, and its mass shared among them
(the pignistic probabilities) or given whole to each (the contour function, before normalising)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evidential.errors import UndefinedTransformError
from evidential.stack import Stack

__all__ = ["element_masses", "masks_of", "membership"]


def membership(masks: NDArray, n: int) -> NDArray[np.float64]:
    """(K, n) matrix: entry (k, i) is 1 where element ``i`` is in the focal set ``masks[k]``.

    Works for int64 masks (their bytes unpacked to bits, one numpy call) and for the
    Python ints (object arrays) of wide frames.

    Examples
    --------
    >>> membership(np.array([1, 6]), 3).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]
    """
    if masks.dtype == object:
        return (masks[:, None] >> np.arange(n) & 1).astype(np.float64)
    octets = np.ascontiguousarray(masks, dtype="<i8").view(np.uint8).reshape(-1, 8)
    return np.unpackbits(octets, axis=1, count=n, bitorder="little").astype(np.float64)


def masks_of(member: NDArray[np.bool_], dtype: np.dtype) -> NDArray:
    """The focal sets (K,) of a (K, n) membership matrix (the inverse of :func:`membership`), as int64 masks or,
    for ``dtype`` object (a wide frame), Python ints.

    Examples
    --------
    >>> masks_of(np.array([[True, False, False], [False, True, True]]), np.dtype(np.int64)).tolist()
    [1, 6]
    >>> masks_of(np.eye(70, dtype=bool)[[0, 69]], np.dtype(object)).tolist() == [1, 1 << 69]
    True
    """
    n = member.shape[1]
    if dtype == object:
        bits = np.array([1 << i for i in range(n)], dtype=object)
        return np.where(member, bits, 0).sum(axis=1).astype(object)
    return (member.astype(np.int64) << np.arange(n, dtype=np.int64)).sum(axis=1)


def element_masses(s: Stack, n: int, split: bool) -> NDArray[np.float64]:
    """(n, N) masses of the elements, the non-empty sets' masses normalised to sum 1 first.

    ``split``: each set's mass is shared equally among its elements (the pignistic
    probabilities BetP); otherwise each element gets the whole mass of every set
    holding it (the contour pl({ω}), to be normalised by the caller). Normalising
    before splitting keeps tiny masses away from underflow.

    Raises
    ------
    UndefinedTransformError
        Where all the mass is on ∅ (m(∅) = 1): there is nothing to share.

    Examples
    --------
    >>> element_masses(Stack(np.array([0, 1, 3]), np.array([[0.5], [0.25], [0.25]])), 2, split=True).tolist()
    [[0.75], [0.25]]
    """
    empty = int(s.masks.size > 0 and s.masks[0] == 0)  # increasing: ∅ can only come first
    member = membership(s.masks[empty:], n)
    w = s.masses[empty:]
    z = w.sum(axis=0)
    if not z.min() > 0:
        where = f" (batch row {int(np.argmin(z))})" if z.size > 1 else ""
        raise UndefinedTransformError(
            f"all the mass is on the empty set (m(∅) = 1){where}: the pignistic and plausibility transforms are undefined"
        )
    w = w / z
    if split:
        w /= member.sum(axis=1)[:, None]
    return np.einsum("ki,kj->ij", member, w)  # no BLAS threads
