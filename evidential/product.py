"""Several variables: product frames, vacuous extension and marginalisation.

The product of the frames Ω1, ..., Ωk has one element per tuple (ω1, ..., ωk),
named ``"ω1,...,ωk"``, in row-major order (the last variable varies fastest);
the product has at most :data:`MAX_PRODUCT` elements (one machine word of focal-set bits).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product as tuples

import numpy as np
from numpy.typing import NDArray

from evidential.construction import from_focal_sets
from evidential.errors import FrameError
from evidential.frame import Frame
from evidential.mass import MassFunction

MAX_PRODUCT = 63
"""The most elements a product frame may have: its focal sets are computed as one int64 word."""


def product_frame(*frames: Frame) -> Frame:
    """The product frame Ω1 × ... × Ωk.

    Examples
    --------
    >>> product_frame(Frame(["x1", "x2"]), Frame(["y1", "y2"])).elements
    ('x1,y1', 'x1,y2', 'x2,y1', 'x2,y2')
    """
    if not frames or not all(isinstance(f, Frame) for f in frames):
        raise FrameError(f"product_frame needs one or more Frames, got {frames!r}")
    size = int(np.prod([len(f) for f in frames]))
    if size > MAX_PRODUCT:
        raise FrameError(f"a product frame has at most {MAX_PRODUCT} elements here, got {size}")
    return Frame(",".join(names) for names in tuples(*(f.elements for f in frames)))


def _axes(frames: Sequence[Frame], axes: int | Sequence[int]) -> tuple[int, ...]:
    picked = (axes,) if isinstance(axes, int) else tuple(axes)
    if not picked or len(set(picked)) != len(picked) or not all(0 <= a < len(frames) for a in picked):
        raise FrameError(f"axes must be distinct variables in 0..{len(frames) - 1}, got {axes!r}")
    return picked


def _sub_index(frames: Sequence[Frame], axes: tuple[int, ...]) -> NDArray[np.int64]:
    """For each element of the product, its index in the product of the frames ``axes``."""
    coords = np.unravel_index(np.arange(int(np.prod([len(f) for f in frames]))), [len(f) for f in frames])
    return np.ravel_multi_index([coords[a] for a in axes], [len(frames[a]) for a in axes]).astype(np.int64)


def vacuous_extension(m: MassFunction, frames: Sequence[Frame], axes: int | Sequence[int]) -> MassFunction:
    """The vacuous extension of ``m`` on the variables ``axes`` to the product of ``frames``:
    each focal set A becomes its cylinder A × (the other variables) (Shafer 1976, ch. 6).

    Parameters
    ----------
    m : MassFunction
        On ``frames[axes]`` (one axis) or on ``product_frame(*frames[axes])``.
    frames : sequence of Frame
    axes : int or sequence of int

    Examples
    --------
    >>> x, y = Frame(["x1", "x2"]), Frame(["y1", "y2"])
    >>> vacuous_extension(MassFunction(y, {"y1": 0.7, "y1|y2": 0.3}), [x, y], 1).to_dict()
    {'x1,y1|x2,y1': 0.7, 'x1,y1|x1,y2|x2,y1|x2,y2': 0.3}
    """
    picked = _axes(frames, axes)
    _same(m, [frames[a] for a in picked])
    sub = _sub_index(frames, picked)
    bits = (m.masks[:, None] >> sub[None, :]) & 1
    return from_focal_sets(product_frame(*frames), (bits << np.arange(sub.size)).sum(axis=1), m.masses, open_world=True)


def marginalize(m: MassFunction, frames: Sequence[Frame], axes: int | Sequence[int]) -> MassFunction:
    """The marginal of ``m`` (on the product of ``frames``) on the variables ``axes``:
    each focal set goes to its projection (Shafer 1976, ch. 6).

    Examples
    --------
    >>> x, y = Frame(["x1", "x2"]), Frame(["y1", "y2"])
    >>> m = MassFunction(product_frame(x, y), {"x1,y1|x2,y2": 0.5, "x1,y2": 0.5})
    >>> marginalize(m, [x, y], 0).to_dict(), marginalize(m, [x, y], 1).to_dict()
    ({'x1': 0.5, 'x1|x2': 0.5}, {'y2': 0.5, 'y1|y2': 0.5})
    """
    picked = _axes(frames, axes)
    _same(m, frames)
    sub = _sub_index(frames, picked)
    member = (m.masks[:, None] >> np.arange(sub.size)) & 1
    keys = np.bitwise_or.reduce(np.where(member == 1, np.int64(1) << sub, 0), axis=1)
    return from_focal_sets(
        product_frame(*(frames[a] for a in picked)) if len(picked) > 1 else frames[picked[0]],
        keys,
        m.masses,
        open_world=True,
    )


def _same(m: MassFunction, frames: Sequence[Frame]) -> None:
    expected = frames[0] if len(frames) == 1 else product_frame(*frames)
    if m.frame != expected:
        raise FrameError(f"the mass function is on {m.frame!r}, expected {expected!r}")
