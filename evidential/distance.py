"""Distances between mass functions."""

from __future__ import annotations

import math

import numpy as np

from evidential.errors import FrameError
from evidential.mass import MassFunction


def jousselme_distance(m1: MassFunction, m2: MassFunction) -> float:
    """Jousselme's distance sqrt(½ (m1 - m2)ᵀ D (m1 - m2)), D(A, B) = |A ∩ B| / |A ∪ B|.

    D(∅, ∅) is taken as 1. The distance is 0 for equal masses and 1 between
    categorical masses on disjoint sets.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["a", "b"])
    >>> jousselme_distance(MassFunction(frame, {"a": 1.0}), MassFunction(frame, {"b": 1.0}))
    1.0
    >>> round(jousselme_distance(MassFunction(frame, {"a": 1.0}), MassFunction(frame, {"a|b": 1.0})), 12)
    0.707106781187
    """
    if m1.frame != m2.frame:
        raise FrameError(f"distance between masses on different frames: {m1.frame!r} and {m2.frame!r}")
    masks, where = np.unique(np.concatenate([m1.masks, m2.masks]), return_inverse=True)
    diff = np.zeros(masks.size)
    np.add.at(diff, where[: m1.masks.size], m1.masses)
    np.subtract.at(diff, where[m1.masks.size :], m2.masses)
    inter = np.bitwise_count(masks[:, None] & masks[None, :]).astype(np.float64)
    union = np.bitwise_count(masks[:, None] | masks[None, :]).astype(np.float64)
    jaccard = np.divide(inter, union, out=np.ones_like(inter), where=union > 0)
    return math.sqrt(max(0.5 * float(diff @ jaccard @ diff), 0.0))
