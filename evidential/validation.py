"""The checks of a mass function's inputs: a mapping of focal sets to masses, or rows over shared focal sets.

Run once, at the entry point (:class:`~evidential.mass.MassFunction` and its
``from_rows``); what passes is handed on as a read-only
:class:`~evidential.stack.Stack`, which the kernels trust.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.errors import FrameError, MassError
from evidential.frame import Focal, Frame
from evidential.stack import Stack

SUM_TOLERANCE = 1e-9
"""Largest accepted distance of the total mass from 1."""


def read_only(masks: NDArray[np.int64], masses: NDArray[np.float64]) -> Stack:
    """A stack of read-only arrays (a mass function's arrays never change).

    ``masses`` must be the caller's own new array or view: it is made read-only in place.
    ``masks`` is viewed read-only, unless it already is read-only (shared as it is).
    """
    if masks.flags.writeable:
        masks = masks.view()
        masks.setflags(write=False)
    masses.setflags(write=False)
    return Stack(masks, masses)


def real_array(values: ArrayLike, what: str) -> NDArray[np.float64]:
    """``values`` as a float64 array, refusing (:class:`MassError` naming ``what``) bools, strings, complex
    numbers and objects, as the mapping of one mass function refuses them (a copy only if not float64 already).

    >>> real_array([[0, 1]], "rows").dtype
    dtype('float64')
    >>> real_array([["0.5", "0.5"]], "rows")
    Traceback (most recent call last):
    ...
    evidential.errors.MassError: rows must be real numbers, got an array of <U3
    """
    a = values if isinstance(values, np.ndarray) else np.asarray(values)
    if a.dtype.kind not in "fiu":
        raise MassError(f"{what} must be real numbers, got an array of {a.dtype}")
    return a.astype(np.float64, copy=False)


def _check_frame(frame: object) -> None:
    if not isinstance(frame, Frame):
        raise FrameError(f"frame must be a Frame, got {type(frame).__name__}")


def checked_mapping(frame: Frame, masses: Mapping[Focal, float], *, open_world: bool) -> Stack:
    """The read-only one-column stack of a mapping of focal sets to masses, checked.

    Masses finite and >= 0, total 1 within :data:`SUM_TOLERANCE`, focal sets inside
    the frame and given once, no mass on ∅ unless ``open_world``; zero masses dropped.
    """
    _check_frame(frame)
    found: dict[int, tuple[Focal, float]] = {}
    for focal, value in masses.items():
        mask = frame.mask(focal)
        if not isinstance(value, Real) or isinstance(value, bool) or not math.isfinite(value) or value < 0:
            raise MassError(f"mass of focal set {focal!r} must be a finite number >= 0, got {value!r}")
        if mask in found:
            raise MassError(f"focal set {frame.label(mask)!r} is given twice: as {found[mask][0]!r} and {focal!r}")
        found[mask] = (focal, float(value))
    if not open_world and found.get(0, (None, 0.0))[1] > 0:
        raise MassError(
            f"mass on the empty set '' is {found[0][1]!r}; only open-world masses (open_world=True) have it"
        )
    total = math.fsum(value for _, value in found.values())
    if abs(total - 1.0) > SUM_TOLERANCE:
        listing = ", ".join(f"{frame.label(k)!r}: {v!r}" for k, (_, v) in sorted(found.items()))
        raise MassError(f"masses must sum to 1 (within {SUM_TOLERANCE}), got {total!r} over {{{listing}}}")
    keep = sorted((k, v) for k, (_, v) in found.items() if v > 0)
    return read_only(
        np.array([k for k, _ in keep], dtype=frame.dtype), np.array([[v] for _, v in keep], dtype=np.float64)
    )


def checked_rows(
    frame: Frame, masks: ArrayLike, rows: ArrayLike, *, open_world: bool
) -> tuple[NDArray, NDArray[np.float64]]:
    """The focal sets (increasing) and the (N, K) masses of ``rows`` over ``masks``, checked, both read-only.

    Checked in bulk as :func:`checked_mapping` checks one mass function; the errors
    name the row and the focal set.
    """
    _check_frame(frame)
    keys = focal_masks(frame, masks)
    try:
        values = np.array(real_array(rows, "rows"), dtype=np.float64)  # a copy: the mass functions keep views of it
    except (TypeError, ValueError) as exc:
        if isinstance(exc, MassError):
            raise
        raise MassError(f"rows must be an (N, {keys.size}) array of numbers: {exc}") from None
    if values.ndim != 2 or values.shape[1] != keys.size:
        raise MassError(f"rows must have shape (N, {keys.size}) for {keys.size} focal sets, got {values.shape}")
    label = frame.label
    if values.size and not (values.min() >= 0 and values.max() < np.inf):
        j, k = np.argwhere(~((values >= 0) & (values < np.inf)))[0]
        value = float(values[j, k])
        raise MassError(
            f"row {j}: mass of focal set {label(int(keys[k]))!r} must be a finite number >= 0, got {value!r}"
        )
    if not open_world and (keys == 0).any() and values[:, keys == 0].max(initial=0.0) > 0:
        j = int(np.argmax(values[:, np.flatnonzero(keys == 0)[0]] > 0))
        raise MassError(f"row {j}: mass on the empty set '' needs open_world=True")
    total = values.sum(axis=1)
    off = np.abs(total - 1.0) > SUM_TOLERANCE
    if off.any():
        j = int(np.argmax(off))
        raise MassError(f"row {j}: masses must sum to 1 (within {SUM_TOLERANCE}), got {float(total[j])!r}")
    order = np.argsort(keys)
    keys, values = keys[order], values[:, order]
    keys.flags.writeable = False
    values.flags.writeable = False
    return keys, values


def focal_masks(frame: Frame, focal_sets: ArrayLike, *, distinct: bool = True) -> NDArray:
    """The focal sets as an array of bitmasks of ``frame.dtype`` (unsorted), checked against the frame.

    ``distinct``: refuse a focal set given twice.
    """
    if isinstance(focal_sets, np.ndarray) and focal_sets.dtype.kind in "iu" and frame.dtype != object:
        keys = focal_sets.astype(np.int64).ravel()
        outside = (keys < 0) | (keys > frame.full)
        if outside.any():
            raise FrameError(f"focal set {int(keys[np.argmax(outside)])} is not a subset of {frame!r}")
    else:
        keys = np.array([frame.mask(f.item() if isinstance(f, np.generic) else f) for f in focal_sets], frame.dtype)
    if distinct:
        uniq, counts = np.unique(keys, return_counts=True)
        if (counts > 1).any():
            raise MassError(f"focal set {frame.label(int(uniq[np.argmax(counts > 1)]))!r} is given twice")
    return keys
