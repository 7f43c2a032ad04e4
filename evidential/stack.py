"""Stacks of mass functions as arrays, and the kernels shared by the rules.

A :class:`Stack` holds ``N`` mass functions over one frame that share a list of
candidate focal sets: ``masks`` (K,) distinct int64 bitmasks in increasing
order and ``masses`` (K, N), column ``j`` being mass function ``j``. One
``MassFunction`` is a stack with ``N = 1``; a dense batch ``(N, 2**n)`` is the
stack with ``masks = arange(2**n)`` and ``masses = batch.T``.
"""

from __future__ import annotations

import functools
import math
import sys
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from evidential.errors import TotalConflictError
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


def mobius_cost_wins(sources: list[Stack], n: int, margin: float = 1.0) -> bool:
    """Whether the fast-Möbius strategy is cheaper than pairwise intersections here.

    Costs in element operations: a pair costs about 4 (intersection, product,
    count, copy) per mass function, a transform pass 1 per set and mass function;
    each numpy call costs about as much as a few thousand elements. The number
    of focal sets after each step of the fold is bounded by ``min(2**n, k1 k2)``;
    where that bound says Möbius, the fold's focal sets are counted for real
    (intersections of the masks alone, stopping as soon as the fold has cost
    more than Möbius): intersections shrink, and a fold of many sources often
    stays small where the bound reaches 2**n. Möbius must be ``margin`` times
    cheaper (Dempster's rule passes 2: near total conflict, it redoes the fold).
    """
    if n > DENSE_MAX_BITS:
        return False
    size, count = 1 << n, sources[0].masses.shape[1]
    mobius = margin * mobius_cost(sources, n)
    pairwise, k = 0, sources[0].masks.size
    for s in sources[1:]:
        pairwise += 4 * k * s.masks.size * count + _CALL_COST
        k = min(size, k * s.masks.size)
    if pairwise <= mobius or len(sources) == 2:
        return pairwise > mobius
    pairwise, keys, present = 0, sources[0].masks, np.zeros(size, dtype=bool)
    for s in sources[1:]:
        pairwise += 4 * keys.size * s.masks.size * count + _CALL_COST
        if pairwise > mobius:
            return True
        present[np.bitwise_and.outer(keys, s.masks)] = True
        keys = np.flatnonzero(present)
        present[keys] = False
    return False


PAIR_TABLE_BITS = 16
"""Up to this many elements, a pair of mass functions is combined through one 2**n table."""

SCALE_FLOOR = 2.0**-969
"""Below this non-conflicting mass, a plain product may have lost digits to underflow."""


def dempster_pair(a: Stack, b: Stack, n: int) -> Stack | None:
    """Dempster's rule of two single mass functions (N = 1), ∅ dropped.

    The same sums as the rule's pairwise path (one ``bincount`` in pair order,
    the non-empty masses summed in increasing order), in fewer numpy calls: up to
    :data:`PAIR_TABLE_BITS` elements through one 2**n table. Masses are divided
    only where there is conflict. None where a product may underflow, or the
    non-conflicting mass is 0 or below :data:`SCALE_FLOOR` (total conflict, or
    underflow: see :func:`dempster_scaled`).
    """
    if a.masses.min() * b.masses.min() < sys.float_info.min:
        return None  # a product may underflow: the caller's scaled path is exact
    keys = np.bitwise_and.outer(a.masks, b.masks).ravel()
    weights = np.multiply.outer(a.masses[:, 0], b.masses[:, 0]).ravel()
    if n <= PAIR_TABLE_BITS:
        table = np.bincount(keys, weights, minlength=1 << n)
        del keys, weights  # freed before the scan: its temporaries reuse their (cached) memory
        conflict = table[0]
        table[0] = 0.0
        masks = (table != 0).nonzero()[0]  # a float array's own nonzero() is five times slower
        masses = table.take(masks)  # take: a third faster than indexing
    else:
        c = aggregate(keys, weights[:, None], n)
        empty = c.masks.size > 0 and c.masks[0] == 0
        conflict = c.masses[0, 0] if empty else 0.0
        masks, masses = c.masks[int(empty) :], c.masses[int(empty) :, 0]
    if conflict > 0:
        z = masses.sum()
        if not z >= SCALE_FLOOR:
            return None
        masses /= z
    return Stack(masks, masses[:, None])


PYTHON_MAX_BITS = 3
"""Up to this many elements, and :data:`PYTHON_MAX_SETS` focal sets a source, :func:`dempster_fold`
runs in plain Python."""

PYTHON_MAX_SETS = 4
"""At most 4 x 7 pairs a step: beyond about 40, numpy's few calls cost less than Python's loop."""


def dempster_python(sources: list[Stack], n: int) -> Stack | None:
    """:func:`dempster_pair` folded over two or more sources in plain Python, for frames of at
    most :data:`PYTHON_MAX_BITS` elements, where one numpy call costs more than the whole sum.

    The same floating-point operations in the same order, so the same bits: products summed
    in pair order from 0 into a 2**n table, ∅ and zero sums dropped, the (at most 7, so
    summed one by one, as numpy does below 8) non-empty masses summed in increasing order,
    divided only where there is conflict. None where a step's non-conflicting mass is below
    :data:`SCALE_FLOOR` or one of its products may underflow.

    Examples
    --------
    >>> a = Stack(np.array([1, 3]), np.array([[0.5], [0.5]]))
    >>> b = Stack(np.array([2, 3]), np.array([[0.5], [0.5]]))
    >>> s = dempster_python([a, b], 2)
    >>> s.masks.tolist(), s.masses[:, 0].tolist()
    ([1, 2, 3], [0.3333333333333333, 0.3333333333333333, 0.3333333333333333])
    """
    size = 1 << n
    masks, masses = sources[0].masks.tolist(), sources[0].masses.ravel().tolist()
    for s in sources[1:]:
        ys, ws = s.masks.tolist(), s.masses.ravel().tolist()
        if min(masses) * min(ws) < sys.float_info.min:
            return None  # a product may underflow: the general path scales
        table = [0.0] * size
        for x, wx in zip(masks, masses):
            for y, wy in zip(ys, ws):
                table[x & y] += wx * wy
        masks = [k for k in range(1, size) if table[k]]
        masses = [table[k] for k in masks]
        if table[0] > 0:
            z = 0.0
            for v in masses:
                z += v
            if not z >= SCALE_FLOOR:
                return None
            masses = [v / z for v in masses]
    return Stack(_small_masks(tuple(masks)), np.array(masses)[:, None])


@functools.cache
def _small_masks(masks: tuple[int, ...]) -> NDArray[np.int64]:
    """The read-only array of ``masks``, shared (a frame of at most 3 elements has 128 lists of focal sets)."""
    array = np.array(masks, dtype=np.int64)
    array.setflags(write=False)
    return array


def dempster_fold(sources: list[Stack], n: int, margin: float = math.inf) -> Stack | None:
    """Dempster's rule of two or more single mass functions folded pair by pair (each step
    normalised, ∅ dropped): ``combine(combine(a, b), c)`` without the objects.

    None, before a step, where the rest of the fold would cost more than ``margin`` times
    the Möbius strategy (:func:`mobius_cost`; element operations, as :func:`mobius_cost_wins`
    counts them) at the current number of focal sets: the steps done are spent either
    way. On tiny frames the fold runs in plain Python (:func:`dempster_python`). Raises
    :class:`TotalConflictError` where a step is in total conflict or underflows
    (see :func:`dempster_pair`).
    """
    if (1 << n) <= PYTHON_MAX_SETS or (n <= PYTHON_MAX_BITS and all(s.masks.size <= PYTHON_MAX_SETS for s in sources)):
        result = dempster_python(sources, n)
        if result is None:
            raise TotalConflictError("total conflict or underflow in the pairwise fold")
        return result
    budget = margin * mobius_cost(sources, n)
    result, steps = sources[0], len(sources) - 1
    pairs = sum(s.masks.size for s in sources[1:])  # focal sets still to meet
    for s in sources[1:]:
        if 4 * result.masks.size * pairs + _CALL_COST * steps > budget:
            return None
        pairs, steps = pairs - s.masks.size, steps - 1
        result = dempster_pair(result, s, n)
        if result is None:
            raise TotalConflictError("total conflict or underflow in the pairwise fold")
    return result


def mobius_cost(sources: list[Stack], n: int) -> float:
    """The cost of the fast-Möbius strategy in element operations (inf beyond ``DENSE_MAX_BITS``)."""
    if n > DENSE_MAX_BITS:
        return math.inf
    return (len(sources) + 1) * n * ((1 << n) * sources[0].masses.shape[1] + _CALL_COST // 4)


def dempster_scaled(sources: list[Stack], n: int) -> Stack:
    """Dempster's rule without underflow: products kept as mantissa and exponent.

    Each step of the conjunctive fold drops ∅ and rescales the pair weights by a
    power of two (exact) so that the largest is in [0.5, 1): masses as small as
    1e-200 in every source combine to the exact normalised answer where the
    plain products would underflow to a false total conflict. Raises
    :class:`~evidential.errors.TotalConflictError` only when no pair of focal
    sets meets (K = 1 exactly).

    Examples
    --------
    >>> a = Stack(np.array([1, 2]), np.array([[1e-200], [1.0]]))
    >>> b = Stack(np.array([1, 4]), np.array([[1e-200], [1.0]]))
    >>> s = dempster_scaled([a, b], 3)
    >>> s.masks.tolist(), s.masses.tolist()
    ([1], [[1.0]])
    """
    mantissa, exponent = _frexp(sources[0].masses)
    masks = sources[0].masks
    for s in sources[1:]:
        m, e = _frexp(s.masses)
        keys = np.bitwise_and.outer(masks, s.masks).ravel()
        mantissa = (mantissa[:, None, :] * m[None, :, :]).reshape(keys.size, -1)
        exponent = (exponent[:, None, :] + e[None, :, :]).reshape(keys.size, -1)
        meet = (keys != 0) & (mantissa > 0).any(axis=1)
        keys, mantissa, exponent = keys[meet], mantissa[meet], exponent[meet]
        if not keys.size:
            raise TotalConflictError(
                "total conflict: K = 1.0, the sources share no focal element; Dempster's rule is undefined"
            )
        top = np.where(mantissa > 0, exponent, np.iinfo(np.int32).min).max(axis=0)
        merged = aggregate(keys, np.ldexp(mantissa, exponent - top), n)
        masks = merged.masks
        mantissa, exponent = _frexp(merged.masses)
    total = np.ldexp(mantissa, exponent).sum(axis=0)
    if not total.min() > 0:
        row = int(np.argmin(total))
        where = f" (batch row {row})" if total.size > 1 else ""
        raise TotalConflictError(
            f"total conflict{where}: K = 1.0, the sources share no focal element; Dempster's rule is undefined"
        )
    return Stack(masks, np.ldexp(mantissa, exponent) / total)


def transform_product(sources: list[Stack], n: int, superset: bool) -> NDArray[np.float64]:
    """Dense m of the conjunctive (superset) or disjunctive (subset) combination via
    the product of commonalities (or implicabilities); round-off below the error
    bound is set to 0."""
    product = _zeta(sources[0], n, superset)
    for s in sources[1:]:
        product *= _zeta(s, n, superset)
    m = sweep(product, superset, inverse=True)
    tolerance = 64 * (n + len(sources)) * np.finfo(np.float64).eps
    if m.min() <= tolerance:  # one reduction where nothing is that small (the usual case)
        m[m <= tolerance] = 0.0
    return m


def _zeta(s: Stack, n: int, superset: bool) -> NDArray[np.float64]:
    """The zeta transform of a stack as a new dense (2**n, N) array (the stack left as it is)."""
    if s.masks.size == 1 << n:  # all the sets: the transform's first step reads them, no copy first
        return sweep(s.masses, superset, inverse=False, out=np.empty(s.masses.shape))
    return sweep(to_dense(s, n), superset, inverse=False)


def _frexp(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mantissas in [0.5, 1) and int64 exponents (room for sums of many exponents)."""
    mantissa, exponent = np.frexp(x)
    return mantissa, exponent.astype(np.int64)


def product_scaled(factors: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The product of (n, N) arrays, each column rescaled by a power of two after every factor.

    Column ``j`` is the plain product times a power of two (exact), without its
    underflow: the product of 600 factors 0.2 is 0.2**600 = 2**-1393.2, not 0.

    Examples
    --------
    >>> p = product_scaled([np.full((2, 1), 0.2)] * 600)
    >>> (p / p.sum(axis=0)).ravel().tolist()
    [0.5, 0.5]
    """
    product = factors[0].copy()
    for f in factors[1:]:
        product *= f
        top = np.frexp(product.max(axis=0))[1]
        product = np.ldexp(product, -top)
    return product
