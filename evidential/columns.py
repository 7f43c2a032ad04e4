"""Dempster's rule of dense batches on frames of one or two elements, as sums of products of their columns.

On {r, n}: m(r) ∝ m1(r) m2(r) + m1(r) m2(Θ) + m1(Θ) m2(r), m(n) likewise,
m(Θ) ∝ m1(Θ) m2(Θ): a handful of products over (N,) columns read in place,
where the general batch path transposes, transforms and transforms back.
:func:`~evidential.combination.combine_batch` takes this path for Dempster's rule
on such frames.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from evidential.stack import SCALE_FLOOR

__all__ = ["COLUMN_BLOCK", "COLUMN_MAX_BITS", "dempster_columns"]


COLUMN_MAX_BITS = 2
"""Up to this many elements, a dense batch is read in place and Dempster's rule sums its columns
(:func:`dempster_columns`)."""

COLUMN_BLOCK = 1 << 14
"""Rows that :func:`dempster_columns` sums at a time: their columns stay in the cache between passes."""


@functools.cache
def _meeting_pairs(n: int) -> tuple[tuple[int, int, int], ...]:
    """(C, A, B) for the pairs of sets A, B of ``n`` elements that meet in a set C ≠ ∅, in pair order."""
    return tuple((a & b, a, b) for a in range(1 << n) for b in range(1 << n) if a & b)


def dempster_columns(sources: list[NDArray[np.float64]], n: int) -> NDArray[np.float64] | None:
    """Dempster's rule of dense (2**n, N) batches on frames of at most :data:`COLUMN_MAX_BITS`
    elements, as sums of products of their rows (columns of the (N, 2**n) batches): on {r, n},
    m(r) ∝ m1(r) m2(r) + m1(r) m2(Θ) + m1(Θ) m2(r), m(n) likewise, m(Θ) ∝ m1(Θ) m2(Θ).

    Each step of the fold adds the products of the pairs meeting in each non-empty set in
    pair order, as the rule's pairwise fold (``aggregate`` of ``pairwise``) adds them, so
    to the same bits, without its (pairs, N) array; the pairs meeting in ∅ are skipped
    (they only make the conflict). Normalised in every row by the sum of the non-empty
    masses in increasing order, as the rule does. :data:`COLUMN_BLOCK` rows at a time. The
    sources may be any views (the transposes of (N, 2**n) batches are read in place) and
    are left as they are.

    Returns a new C-contiguous (2**n, N) array, row 0 (∅) zero; None where a row's
    non-conflicting mass is below :data:`SCALE_FLOOR` (total conflict or underflow: the
    rule's general path raises or rescales).

    Examples
    --------
    >>> m1 = np.array([[0.0, 0.8, 0.1, 0.1]]).T
    >>> m2 = np.array([[0.0, 0.3, 0.0, 0.7]]).T
    >>> dempster_columns([m1, m2], 2)[:, 0].round(6).tolist()
    [0.0, 0.85567, 0.072165, 0.072165]
    """
    size, count = 1 << n, sources[0].shape[1]
    out = np.empty((size, count))
    scratch = np.empty(min(count, COLUMN_BLOCK))
    for start in range(0, count, COLUMN_BLOCK):
        block = slice(start, start + COLUMN_BLOCK)
        m = sources[0][:, block]
        for i, s in enumerate(sources[1:], 2):
            into = out[:, block] if i == len(sources) else np.empty(m.shape)
            started = [False] * size
            for c, a, b in _meeting_pairs(n):
                if started[c]:
                    into[c] += np.multiply(m[a], s[b, block], out=scratch[: m.shape[1]])
                else:
                    np.multiply(m[a], s[b, block], out=into[c])
                    started[c] = True
            m = into
        z = functools.reduce(np.add, m[1:])
        if not z.min() >= SCALE_FLOOR:
            return None
        np.divide(m[1:], z, out=out[1:, block])
    out[0] = 0.0
    return out
