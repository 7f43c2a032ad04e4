"""Fast zeta and Möbius transforms (O(n 2^n)) between m, bel, pl, q on dense arrays.

A dense mass array has the focal sets on its last axis: entry ``b`` is the mass
of the set with bitmask ``b`` (bit ``i`` = frame element ``i``, entry 0 = the
empty set), so its length is ``2**n``. Leading axes are a batch.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.errors import MassError, UndefinedTransformError


def sweep(
    x: NDArray[np.float64], superset: bool, inverse: bool, out: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Zeta (sum) or Möbius (difference) transform along axis 0, in place.

    ``x`` has shape ``(2**n, ...)`` and is C-contiguous. The subset zeta gives
    ``f(A) = sum_{B <= A} x(B)``, the superset zeta ``f(A) = sum_{B >= A} x(B)``;
    ``inverse`` undoes them. With ``out`` (a C-contiguous array of ``x``'s shape),
    ``x`` is left as it is and the transform written to ``out``: the first step
    reads ``x`` and writes ``out``, the same sums as a copy swept in place, one
    pass fewer.

    Examples
    --------
    >>> x = np.array([0.0, 0.5, 0.2, 0.3])
    >>> sweep(x, superset=True, inverse=False, out=np.empty(4)).tolist(), x.tolist()
    ([1.0, 0.8, 0.5, 0.3], [0.0, 0.5, 0.2, 0.3])
    """
    size = x.shape[0]
    rest = x.shape[1:]
    start = 0
    if out is not None:
        pairs, into = x.reshape(size >> 1, 2, *rest), out.reshape(size >> 1, 2, *rest)
        step = np.subtract if inverse else np.add
        if superset:  # f(A) = x(A) + x(A + bit) for A without the bit, the others copied
            step(pairs[:, 0], pairs[:, 1], out=into[:, 0])
            into[:, 1] = pairs[:, 1]
        else:
            into[:, 0] = pairs[:, 0]
            step(pairs[:, 1], pairs[:, 0], out=into[:, 1])
        x, start = out, 1
    for i in range(start, size.bit_length() - 1):
        pairs = x.reshape(size >> (i + 1), 2, 1 << i, *rest)  # index = hi 2^(i+1) + bit 2^i + lo
        without, with_ = pairs[:, 0], pairs[:, 1]
        target, source = (without, with_) if superset else (with_, without)
        if inverse:
            target -= source
        else:
            target += source
    return x


def _dense(m: ArrayLike) -> NDArray[np.float64]:
    """``m`` as a finite float array whose last axis has length 2**n, n >= 1."""
    a = np.asarray(m, dtype=np.float64)
    size = a.shape[-1] if a.ndim else 0
    if size < 2 or size & (size - 1):
        raise MassError(f"a dense mass array needs a last axis of length 2**n (n >= 1), got shape {a.shape}")
    if not np.isfinite(a).all():
        where = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise MassError(f"a dense array must be finite: entry {where} is {float(a[where])!r}")
    return a


def _sets_first(m: ArrayLike) -> NDArray[np.float64]:
    """A C-contiguous float copy of ``m`` with the set axis moved first."""
    return np.moveaxis(_dense(m), -1, 0).copy()


def _transform(m: ArrayLike, superset: bool, inverse: bool) -> NDArray[np.float64]:
    return np.moveaxis(sweep(_sets_first(m), superset, inverse), 0, -1)


def commonality(m: ArrayLike) -> NDArray[np.float64]:
    """q(A) = sum of m(B) over B ⊇ A.

    Examples
    --------
    >>> commonality([0.0, 0.5, 0.2, 0.3]).tolist()
    [1.0, 0.8, 0.5, 0.3]
    """
    return _transform(m, superset=True, inverse=False)


def implicability(m: ArrayLike) -> NDArray[np.float64]:
    """b(A) = sum of m(B) over B ⊆ A, the empty set included (b = bel + m(∅)).

    Examples
    --------
    >>> implicability([0.1, 0.5, 0.2, 0.2]).tolist()
    [0.1, 0.6, 0.30000000000000004, 1.0]
    """
    return _transform(m, superset=False, inverse=False)


def belief(m: ArrayLike) -> NDArray[np.float64]:
    """bel(A) = sum of m(B) over non-empty B ⊆ A.

    Examples
    --------
    >>> belief([0.0, 0.5, 0.2, 0.3]).tolist()
    [0.0, 0.5, 0.2, 1.0]
    """
    b = implicability(m)
    return b - b[..., :1]


def plausibility(m: ArrayLike) -> NDArray[np.float64]:
    """pl(A) = sum of m(B) over B with B ∩ A ≠ ∅.

    Examples
    --------
    >>> plausibility([0.0, 0.5, 0.2, 0.3]).tolist()
    [0.0, 0.8, 0.5, 1.0]
    """
    b = implicability(m)
    return b[..., -1:] - b[..., ::-1]  # pl(A) = b(Θ) - b(complement of A)


def mass_from_commonality(q: ArrayLike) -> NDArray[np.float64]:
    """The mass function whose commonality is ``q`` (superset Möbius inverse).

    Examples
    --------
    >>> (mass_from_commonality([1.0, 0.8, 0.5, 0.3]).round(12) + 0.0).tolist()
    [0.0, 0.5, 0.2, 0.3]
    """
    return _transform(q, superset=True, inverse=True)


def mass_from_implicability(b: ArrayLike) -> NDArray[np.float64]:
    """The mass function whose implicability is ``b`` (subset Möbius inverse).

    Examples
    --------
    >>> mass_from_implicability([0.1, 0.6, 0.3, 1.0]).round(12).tolist()
    [0.1, 0.5, 0.2, 0.2]
    """
    return _transform(b, superset=False, inverse=True)


def mass_from_belief(bel: ArrayLike) -> NDArray[np.float64]:
    """The mass function (total 1) whose belief is ``bel``; m(∅) = 1 - bel(Θ).

    Examples
    --------
    >>> mass_from_belief([0.0, 0.5, 0.2, 1.0]).round(12).tolist()
    [0.0, 0.5, 0.2, 0.3]
    """
    b = _sets_first(bel)
    b += 1.0 - b[-1]  # b = bel + m(∅)
    return np.moveaxis(sweep(b, superset=False, inverse=True), 0, -1)


def mass_from_plausibility(pl: ArrayLike) -> NDArray[np.float64]:
    """The mass function (total 1) whose plausibility is ``pl``: b(A) = 1 - pl(Ā).

    Examples
    --------
    >>> mass_from_plausibility([0.0, 0.8, 0.5, 1.0]).round(12).tolist()
    [0.0, 0.5, 0.2, 0.3]
    """
    b = 1.0 - _sets_first(pl)[::-1]
    return np.moveaxis(sweep(np.ascontiguousarray(b), superset=False, inverse=True), 0, -1)


def _normalized_sets_first(m: ArrayLike) -> NDArray[np.float64]:
    """A copy of ``m`` with the set axis first, ∅ zeroed and the rest divided by its total.

    Raises :class:`UndefinedTransformError` where every mass is on ∅. Dividing
    before anything else keeps tiny masses (such as 1e-300) away from underflow.
    """
    w = _sets_first(m)
    w[0] = 0.0
    z = w.sum(axis=0)
    if not np.all(z > 0):
        row = np.argwhere(~(z > 0))[0] if z.ndim else ()
        where = f" (batch row {tuple(int(i) for i in row)})" if z.ndim else ""
        raise UndefinedTransformError(
            f"all the mass is on the empty set (m(∅) = 1){where}: the pignistic and plausibility transforms are undefined"
        )
    w /= z
    return w


def _element_sums(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, ...) sums of ``w`` (2**n, ...) over the sets holding each element; ``w`` is consumed.

    Halves ``w`` once per element, in place: the top bit's sum is that of the upper
    half, then the upper half is added onto the lower one (about 2 * 2**n additions
    in all, no temporary larger than the result).
    """
    n = w.shape[0].bit_length() - 1
    out = np.empty((n, *w.shape[1:]))
    for i in reversed(range(n)):
        lower, upper = w[: 1 << i], w[1 << i : 2 << i]
        out[i] = upper.sum(axis=0)
        lower += upper
        w = lower
    return out


def _popcounts(n: int) -> NDArray[np.uint8]:
    """The sizes of the 2**n sets (bytes), ∅ given size 1."""
    sizes = np.zeros(1 << n, dtype=np.uint8)
    for i in range(n):
        sizes[1 << i : 2 << i] = sizes[: 1 << i] + 1
    sizes[0] = 1
    return sizes


def pignistic(m: ArrayLike) -> NDArray[np.float64]:
    """BetP(ω) = sum over A ∋ ω of m(A) / |A|, divided by 1 - m(∅); shape (..., n).

    Memory-lean: one float64 copy of ``m`` and a byte per set. Raises
    :class:`~evidential.errors.UndefinedTransformError` where m(∅) = 1.

    Examples
    --------
    >>> pignistic([0.0, 0.5, 0.2, 0.3]).tolist()
    [0.65, 0.35]
    >>> pignistic([0.5, 0.0, 0.0, 0.5]).tolist()
    [0.5, 0.5]
    """
    w = _normalized_sets_first(m)
    w /= _popcounts(w.shape[0].bit_length() - 1).reshape(-1, *(1,) * (w.ndim - 1))
    return np.moveaxis(_element_sums(w), 0, -1)


def plausibility_transform(m: ArrayLike) -> NDArray[np.float64]:
    """The singleton plausibilities normalised to sum 1 (Cobb & Shenoy); shape (..., n).

    Raises :class:`~evidential.errors.UndefinedTransformError` where m(∅) = 1.

    Examples
    --------
    >>> plausibility_transform([0.0, 0.5, 0.2, 0.3]).round(12).tolist()
    [0.615384615385, 0.384615384615]
    """
    contour = _element_sums(_normalized_sets_first(m))
    return np.moveaxis(contour / contour.sum(axis=0), 0, -1)
