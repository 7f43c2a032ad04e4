"""The conformance checks every evidence source passes: its rows are mass functions, one per object.

Shared by the registration of a source kind and the build of every source
(:mod:`evmap.sources.evidence`), and by the test suite of source kinds.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential import Frame

__all__ = ["MASS_TOLERANCE", "check_masses", "check_source"]

MASS_TOLERANCE = 1e-9
"""Masses (and ramp proportions) must sum to 1 within this."""


def check_masses(masses: Any, n: int, frame: Frame) -> NDArray[np.float64]:
    """Refuse what is not ``n`` mass functions over ``frame`` as dense rows; return them as an array.

    Each row must be finite, non-negative, without mass on the empty set, and sum to 1
    within :data:`MASS_TOLERANCE`.

    >>> check_masses([[0.0, 0.5, 0.5, 0.0]], 1, Frame(["real", "noise"])).tolist()
    [[0.0, 0.5, 0.5, 0.0]]
    >>> check_masses([[0.0, 1.0, 1.0, 0.0]], 1, Frame(["real", "noise"]))
    Traceback (most recent call last):
    ...
    ValueError: row 0 sums to 2, not 1 (within 1e-09)
    """
    m = np.asarray(masses)
    if m.shape != (n, 1 << len(frame)) or not np.issubdtype(m.dtype, np.floating):
        raise ValueError(f"masses must be an ({n}, {1 << len(frame)}) float array, got {m.dtype} {m.shape}")
    bad = np.flatnonzero(~np.isfinite(m).all(axis=1) | (m < 0).any(axis=1))
    if len(bad):
        raise ValueError(f"row {bad[0]} holds a negative or non-finite mass: {m[bad[0]].tolist()}")
    bad = np.flatnonzero(m[:, 0] > 0)
    if len(bad):
        raise ValueError(f"row {bad[0]} has mass {m[bad[0], 0]:g} on the empty set")
    total = m.sum(axis=1)
    bad = np.flatnonzero(np.abs(total - 1.0) > MASS_TOLERANCE)
    if len(bad):
        raise ValueError(f"row {bad[0]} sums to {total[bad[0]]:.12g}, not 1 (within {MASS_TOLERANCE:g})")
    return m


def check_source(source: Any, values: ArrayLike) -> None:
    """The conformance checks of an evidence source (``name``, ``frame``, ``feature``, ``masses``) on feature values.

    Its masses of the values are mass functions over its frame, one row per value;
    computing them again gives the same; each row is what the value alone gives.

    Raises
    ------
    ValueError
        saying which check failed.
    """
    values = np.asarray(values)
    batch = check_masses(source.masses({source.feature: values}), len(values), source.frame)
    if not np.array_equal(batch, source.masses({source.feature: values})):
        raise ValueError("masses differ between two calls on the same values: a source must be deterministic")
    for i in range(len(values)):
        alone = check_masses(source.masses({source.feature: values[i : i + 1]}), 1, source.frame)
        if not np.allclose(alone[0], batch[i], rtol=0, atol=MASS_TOLERANCE):
            raise ValueError(
                f"value {values[i].item()!r} gives {alone[0].tolist()} alone but {batch[i].tolist()} in a batch"
            )
