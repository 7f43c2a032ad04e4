"""Stacks of mass functions as arrays, and the kernels shared by the rules.

A :class:`Stack` holds ``N`` mass functions over one frame that share a list of
candidate focal sets: ``masks`` (K,) distinct int64 bitmasks in increasing
order and ``masses`` (K, N), column ``j`` being mass function ``j``. One
``MassFunction`` is a stack with ``N = 1``; a dense batch ``(N, 2**n)`` is the
stack with ``masks = arange(2**n)`` and ``masses = batch.T``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from evidential.errors import UndefinedTransformError
from evidential.transforms import sweep

BINCOUNT_MAX_BITS = 22
"""Up to this many elements, focal sets are grouped by counting into a 2**n table."""

DENSE_MAX_BITS = 20
"""Largest frame the dense (Möbius) strategy and the cautious rule handle."""

_CALL_COST = 8000
"""Overhead of a few numpy calls, in element operations (strategy cost model)."""

_ROW_LOOP_MAX = 256
"""Largest number of weight rows a batch aggregates row by row."""


def _keep_temporaries_on_the_heap() -> None:
    """Free one 16 MB block, so that glibc's malloc keeps later blocks up to that size on its heap.

    Until it has freed a large block, glibc maps every block over 128 kB afresh
    and unmaps it when it is freed (its dynamic mmap threshold), so each medium
    temporary of a kernel (a 200 x 200 combination makes several of 300-500 kB)
    is paid again in page faults: five times the arithmetic on this project's
    machine. The cost is up to 32 MB of freed memory kept for reuse. No effect
    where the threshold was set by hand (``MALLOC_MMAP_THRESHOLD_``) or with
    another malloc.
    """
    np.empty(1 << 21)


_keep_temporaries_on_the_heap()


class Stack(NamedTuple):
    """N mass functions over one frame, sharing the candidate focal sets ``masks``."""

    masks: NDArray[np.int64]
    """(K,) distinct focal set bitmasks, increasing."""
    masses: NDArray[np.float64]
    """(K, N) masses: row k is the mass of ``masks[k]`` in each mass function."""


def group(keys: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.intp]]:
    """The distinct ``keys`` (increasing) and the index of each key among them."""
    if n <= BINCOUNT_MAX_BITS and (1 << n) <= max(1 << 16, 8 * keys.size):
        present = np.zeros(1 << n, dtype=bool)
        present[keys] = True
        uniq = np.flatnonzero(present)
        where = np.empty(1 << n, dtype=np.intp)
        where[uniq] = np.arange(uniq.size)
        return uniq, where[keys]
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.empty(keys.size, dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    inverse = np.empty(keys.size, dtype=np.intp)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


def aggregate(keys: NDArray[np.int64], weights: NDArray[np.float64], n: int) -> Stack:
    """Sum the rows of ``weights`` (P, N) that share a key: m(C) = sum of w over key = C.

    With ``N = 1`` focal sets of total weight 0 are dropped; a batch keeps them.
    No BLAS call: the sums stay single-threaded and exact to round-off.
    """
    count = weights.shape[1]
    if count == 1:
        w = weights[:, 0]
        if n <= BINCOUNT_MAX_BITS and (1 << n) <= max(1 << 16, 8 * keys.size):
            table = np.bincount(keys, w, minlength=1 << n)
            uniq = np.flatnonzero(table != 0)
            return Stack(uniq, table[uniq][:, None])
        uniq, inverse = group(keys, n)
        total = np.bincount(inverse, w, minlength=uniq.size)
        keep = total != 0
        return Stack(uniq[keep], total[keep][:, None])
    uniq, inverse = group(keys, n)
    if keys.size <= _ROW_LOOP_MAX:  # few rows: add whole rows, each a vector over the batch
        out = np.zeros((uniq.size, count))
        for row, k in zip(weights, inverse.tolist()):
            out[k] += row
        return Stack(uniq, out)
    cells = (inverse[:, None] * count + np.arange(count)).ravel()
    return Stack(uniq, np.bincount(cells, weights.ravel(), minlength=uniq.size * count).reshape(-1, count))


def pairwise(a: Stack, b: Stack, op: np.ufunc) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Keys ``op(A, B)`` and weights ``a(A) b(B)`` for every pair of focal sets."""
    keys = op.outer(a.masks, b.masks).ravel()
    if a.masses.shape[1] == 1:
        return keys, np.multiply.outer(a.masses[:, 0], b.masses[:, 0]).reshape(-1, 1)
    return keys, (a.masses[:, None, :] * b.masses[None, :, :]).reshape(keys.size, -1)


def to_dense(s: Stack, n: int) -> NDArray[np.float64]:
    """The stack as a C-contiguous (2**n, N) array (a copy)."""
    if s.masks.size == 1 << n:  # masks are distinct and increasing: all sets
        return np.array(s.masses, dtype=np.float64, order="C")
    dense = np.zeros((1 << n, s.masses.shape[1]))
    dense[s.masks] = s.masses
    return dense


def full(dense: NDArray[np.float64]) -> Stack:
    """The stack of a dense (2**n, N) array."""
    return Stack(np.arange(dense.shape[0], dtype=np.int64), dense)


def mobius_cost_wins(sources: list[Stack], n: int) -> bool:
    """Whether the fast-Möbius strategy is cheaper than pairwise intersections here.

    Costs in element operations: a pair costs about 4 (intersection, product,
    count, copy) per mass function, a transform pass 1 per set and mass function;
    each numpy call costs about as much as a few thousand elements.
    """
    if n > DENSE_MAX_BITS:
        return False
    size, count = 1 << n, sources[0].masses.shape[1]
    pairwise, k = 0, sources[0].masks.size
    for s in sources[1:]:
        pairwise += 4 * k * s.masks.size * count + _CALL_COST
        k = min(size, k * s.masks.size)
    return pairwise > (len(sources) + 1) * n * (size * count + _CALL_COST // 4)


def transform_product(sources: list[Stack], n: int, superset: bool) -> NDArray[np.float64]:
    """Dense m of the conjunctive (superset) or disjunctive (subset) combination via
    the product of commonalities (or implicabilities); round-off below the error
    bound is set to 0."""
    product = sweep(to_dense(sources[0], n), superset, inverse=False)
    for s in sources[1:]:
        product *= sweep(to_dense(s, n), superset, inverse=False)
    m = sweep(product, superset, inverse=True)
    small = m <= 64 * (n + len(sources)) * np.finfo(np.float64).eps
    if small.any():  # the boolean assignment costs more than the test
        m[small] = 0.0
    return m


def membership(masks: NDArray, n: int) -> NDArray[np.float64]:
    """(K, n) matrix: entry (k, i) is 1 where element ``i`` is in the focal set ``masks[k]``.

    Works for int64 masks and for the Python ints (object arrays) of wide frames.

    Examples
    --------
    >>> membership(np.array([1, 6]), 3).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]
    """
    return (masks[:, None] >> np.arange(n) & 1).astype(np.float64)


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
    member = membership(s.masks, n)
    size = member.sum(axis=1)
    w = s.masses[size > 0]
    z = w.sum(axis=0)
    if not z.min() > 0:
        where = f" (batch row {int(np.argmin(z))})" if z.size > 1 else ""
        raise UndefinedTransformError(
            f"all the mass is on the empty set (m(∅) = 1){where}: the pignistic and plausibility transforms are undefined"
        )
    w = w / z
    if split:
        w /= size[size > 0, None]
    return np.einsum("ki,kj->ij", member[size > 0], w)  # no BLAS threads
