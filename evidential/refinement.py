"""Refinement and coarsening between two frames (Shafer 1976, ch. 6).

A refining ρ maps each element of a coarse frame Θ to a non-empty set of
elements of a fine frame Ω, the sets disjoint and covering Ω.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from evidential.construction import from_focal_sets
from evidential.elements import masks_of, membership
from evidential.errors import FrameError
from evidential.frame import Focal, Frame
from evidential.mass import MassFunction


def _refining(coarse: Frame, fine: Frame, refining: Mapping[str, Focal]) -> NDArray:
    """ρ({θ}) as fine bitmasks, in coarse frame order, checked to be a refining."""
    if set(refining) != set(coarse.elements):
        raise FrameError(f"refining must map every element of {coarse!r} and nothing else, got {sorted(refining)}")
    blocks = np.array([fine.mask(refining[name]) for name in coarse.elements], dtype=fine.dtype)
    seen = 0
    for name, block in zip(coarse.elements, blocks.tolist()):
        if not block or block & seen:
            raise FrameError(
                f"refining of {name!r} must be non-empty and disjoint from the others, got {refining[name]!r}"
            )
        seen |= block
    if seen != fine.full:
        raise FrameError(f"refining must cover {fine!r}: {fine.label(fine.full & ~seen)!r} is left out")
    return blocks


def refine(m: MassFunction, fine: Frame, refining: Mapping[str, Focal]) -> MassFunction:
    """The vacuous extension of ``m`` (on the coarse frame) to the fine frame: m'(ρ(A)) = m(A).

    Examples
    --------
    >>> coarse, fine = Frame(["car", "person"]), Frame(["sedan", "truck", "adult", "child"])
    >>> rho = {"car": "sedan|truck", "person": "adult|child"}
    >>> refine(MassFunction(coarse, {"car": 0.8, "car|person": 0.2}), fine, rho).to_dict()
    {'sedan|truck': 0.8, 'sedan|truck|adult|child': 0.2}
    """
    blocks = _refining(m.frame, fine, refining)
    member = membership(m.masks, blocks.size) == 1
    return from_focal_sets(fine, np.bitwise_or.reduce(np.where(member, blocks, 0), axis=1), m.masses, open_world=True)


def coarsen(m: MassFunction, coarse: Frame, refining: Mapping[str, Focal], *, outer: bool = True) -> MassFunction:
    """The mass function of ``m`` (on the fine frame) on the coarse frame.

    Parameters
    ----------
    m : MassFunction
    coarse : Frame
    refining : mapping
        Coarse element name to the fine focal set it refines to.
    outer : bool
        The outer reduction B ↦ {θ : ρ(θ) ∩ B ≠ ∅}, whose belief is bel(ρ(A)):
        the restriction of ``m`` (Shafer 1976, ch. 6); else the inner reduction
        B ↦ {θ : ρ(θ) ⊆ B}, more committed, which may put mass on ∅
        (Denœux & Ben Yaghlane 2002, "Approximating the combination of belief
        functions using the fast Möbius transform in a coarsened frame", IJAR 31).

    Examples
    --------
    >>> coarse, fine = Frame(["car", "person"]), Frame(["sedan", "truck", "adult", "child"])
    >>> rho = {"car": "sedan|truck", "person": "adult|child"}
    >>> m = MassFunction(fine, {"sedan": 0.5, "truck|adult|child": 0.5})
    >>> coarsen(m, coarse, rho).to_dict(), coarsen(m, coarse, rho, outer=False).to_dict()
    ({'car': 0.5, 'car|person': 0.5}, {'': 0.5, 'person': 0.5})
    """
    blocks = _refining(coarse, m.frame, refining)
    meets = (m.masks[:, None] & blocks[None, :]) != 0 if outer else (m.masks[:, None] & blocks[None, :]) == blocks
    return from_focal_sets(coarse, masks_of(meets, coarse.dtype), m.masses, open_world=True)
