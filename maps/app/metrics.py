"""Figures shared by the application's reports (``evmap run``'s ``report.json``, ``evmap compare``'s tables)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["share"]


def share(part: NDArray[np.bool_], whole: NDArray[np.bool_]) -> float | None:
    """The fraction ``part.sum() / whole.sum()`` of two masks; ``None`` when ``whole`` is empty (nothing to share).

    >>> share(np.array([True, False]), np.array([True, True])), share(np.array([], bool), np.array([], bool))
    (0.5, None)
    """
    n = int(whole.sum())
    return int(part.sum()) / n if n else None
