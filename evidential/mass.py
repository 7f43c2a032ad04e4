"""Mass functions: sparse arrays of focal set bitmasks and masses over a frame."""

from __future__ import annotations

import math
from collections.abc import Mapping
from itertools import repeat
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.errors import FrameError, MassError, TotalConflictError
from evidential.frame import Focal, Frame
from evidential.rules import dempster
from evidential.stack import DENSE_MAX_BITS, Stack

SUM_TOLERANCE = 1e-9
"""Largest accepted distance of the total mass from 1."""


class MassFunction:
    """A mass function (basic belief assignment) over a frame.

    Stored sparse: the focal sets (bitmasks, increasing) and their positive
    masses; :meth:`dense` gives the 2**n vector. Validated on construction:
    masses finite and >= 0, total 1 within 1e-9, focal sets inside the frame,
    no mass on the empty set ``""`` unless ``open_world=True``.

    Parameters
    ----------
    frame : Frame
    masses : mapping
        Focal set (a name, ``"a|b"``, an iterable of names, or a bitmask such as
        ``frame.full``) to mass. Zero masses are dropped.
    open_world : bool
        Allow mass on the empty set (the unnormalized, open-world reading).

    Examples
    --------
    >>> frame = Frame(["real", "noise"])
    >>> m = MassFunction(frame, {"real": 0.8, "noise": 0.1, "real|noise": 0.1})
    >>> m["real"], m[frame.full], m[""]
    (0.8, 0.1, 0.0)
    >>> round(m.belief("real"), 12), round(m.plausibility("real"), 12), round(m.commonality("real"), 12)
    (0.8, 0.9, 0.9)
    >>> m.pignistic()
    {'real': 0.8500000000000001, 'noise': 0.15000000000000002}
    """

    __slots__ = ("_stack", "frame")

    def __init__(self, frame: Frame, masses: Mapping[Focal, float], *, open_world: bool = False) -> None:
        if not isinstance(frame, Frame):
            raise FrameError(f"frame must be a Frame, got {type(frame).__name__}")
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
        self.frame = frame
        self._stack = _read_only(
            np.array([k for k, _ in keep], dtype=np.int64), np.array([[v] for _, v in keep], dtype=np.float64)
        )

    @classmethod
    def from_stack(cls, frame: Frame, stack: Stack, column: int = 0) -> MassFunction:
        """Column ``column`` of a rule's result, trusted as valid (zero masses dropped)."""
        values = stack.masses[:, column]
        keep = values > 0
        if keep.all():
            return cls._new(frame, _read_only(stack.masks, stack.masses[:, column : column + 1]))
        return cls._new(frame, _read_only(stack.masks[keep], values[keep][:, None]))

    @classmethod
    def _new(cls, frame: Frame, stack: Stack) -> MassFunction:
        m = cls.__new__(cls)
        m.frame = frame
        m._stack = stack
        return m

    @classmethod
    def from_rows(
        cls, frame: Frame, masks: ArrayLike, rows: ArrayLike, *, open_world: bool = False
    ) -> list[MassFunction]:
        """One mass function per row of ``rows`` (N, K), over the K focal sets ``masks``.

        Checked in bulk as the constructor checks one mass function, and many
        times faster than N constructor calls: for many mass functions over the
        same focal sets, such as the rows of a :func:`~evidential.combine_batch`
        result (``masks = range(2**n)``) or a file's records. Zero masses are
        dropped.

        Parameters
        ----------
        frame : Frame
        masks : array_like of int, or sequence of focal sets
            K distinct focal sets: bitmasks, or anything :meth:`Frame.mask` reads.
        rows : array_like, shape (N, K)
            Row ``j`` holds the masses of mass function ``j``.
        open_world : bool
            Allow mass on the empty set.

        Raises
        ------
        MassError
            Naming the row and the focal set: a negative, NaN or infinite mass,
            a row whose sum is off 1 by more than 1e-9, mass on the empty set of
            a closed world, a focal set given twice, or a shape that does not fit.

        Examples
        --------
        >>> frame = Frame(["a", "b"])
        >>> [m.to_dict() for m in MassFunction.from_rows(frame, ["a", "a|b"], [[0.25, 0.75], [1.0, 0.0]])]
        [{'a': 0.25, 'a|b': 0.75}, {'a': 1.0}]
        """
        if not isinstance(frame, Frame):
            raise FrameError(f"frame must be a Frame, got {type(frame).__name__}")
        keys = _masks(frame, masks)
        try:
            values = np.array(rows, dtype=np.float64)  # a copy: the mass functions keep views of it
        except (TypeError, ValueError) as exc:
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
        positive = (values > 0).all(axis=1).tolist()
        stacks = map(Stack, repeat(keys), values[:, :, None])  # row j as the (K, 1) masses of a Stack
        new, checked = cls._new, cls.from_stack
        return [new(frame, s) if ok else checked(frame, s) for s, ok in zip(stacks, positive, strict=True)]

    @classmethod
    def from_dict(cls, frame: Frame, masses: Mapping[Focal, float], *, open_world: bool = False) -> MassFunction:
        """The mass function of a mapping such as :meth:`to_dict` writes.

        Examples
        --------
        >>> frame = Frame(["a", "b"])
        >>> MassFunction.from_dict(frame, {"a": 0.25, "a|b": 0.75}).to_dict()
        {'a': 0.25, 'a|b': 0.75}
        """
        return cls(frame, masses, open_world=open_world)

    @classmethod
    def from_dense(cls, frame: Frame, vector: ArrayLike, *, open_world: bool = False) -> MassFunction:
        """The mass function of a dense vector of length 2**n (entry b = set with bitmask b).

        Examples
        --------
        >>> MassFunction.from_dense(Frame(["a", "b"]), [0, 0.5, 0, 0.5]).to_dict()
        {'a': 0.5, 'a|b': 0.5}
        """
        v = np.asarray(vector, dtype=np.float64)
        if v.shape != (1 << len(frame),):
            raise MassError(f"a dense mass vector over {frame!r} has shape ({1 << len(frame)},), got {v.shape}")
        return cls(frame, {int(b): float(v[b]) for b in np.flatnonzero(v != 0)}, open_world=open_world)

    @property
    def masks(self) -> NDArray[np.int64]:
        """The focal sets as bitmasks, increasing (read-only)."""
        return self._stack.masks

    @property
    def masses(self) -> NDArray[np.float64]:
        """The masses of :attr:`masks` (read-only)."""
        return self._stack.masses[:, 0]

    def __len__(self) -> int:
        return self._stack.masks.size

    def __getitem__(self, focal: Focal) -> float:
        mask = self.frame.mask(focal)
        masks = self._stack.masks
        i = np.searchsorted(masks, mask)
        return float(self._stack.masses[i, 0]) if i < masks.size and masks[i] == mask else 0.0

    def __repr__(self) -> str:
        return f"MassFunction({self.frame!r}, {self.to_dict()!r})"

    def to_dict(self) -> dict[str, float]:
        """Focal set labels (names in frame order joined by ``"|"``, ``""`` for ∅) to masses."""
        label = self.frame.label
        return {label(int(k)): float(v) for k, v in zip(self._stack.masks, self._stack.masses[:, 0])}

    def dense(self) -> NDArray[np.float64]:
        """The 2**n vector of masses (entry b = focal set with bitmask b).

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"b": 1.0}).dense().tolist()
        [0.0, 0.0, 1.0, 0.0]
        """
        n = len(self.frame)
        if n > DENSE_MAX_BITS:
            raise FrameError(f"a dense view needs a frame of at most {DENSE_MAX_BITS} elements, got {n}")
        out = np.zeros(1 << n)
        out[self._stack.masks] = self._stack.masses[:, 0]
        return out

    def _sum(self, selected: NDArray[np.bool_]) -> float:
        return float(self._stack.masses[selected, 0].sum())

    def belief(self, focal: Focal) -> float:
        """bel(A): the mass of the non-empty focal sets inside A."""
        a, masks = self.frame.mask(focal), self._stack.masks
        return self._sum((masks & ~a == 0) & (masks != 0))

    def plausibility(self, focal: Focal) -> float:
        """pl(A): the mass of the focal sets meeting A."""
        return self._sum(self._stack.masks & self.frame.mask(focal) != 0)

    def commonality(self, focal: Focal) -> float:
        """q(A): the mass of the focal sets containing A."""
        a = self.frame.mask(focal)
        return self._sum(self._stack.masks & a == a)

    def _singletons(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(K, n) membership of the focal sets, and their sizes."""
        member = (self._stack.masks[:, None] >> np.arange(len(self.frame)) & 1).astype(np.float64)
        return member, member.sum(axis=1)

    def pignistic(self) -> dict[str, float]:
        """The pignistic probabilities BetP(ω) = sum over A ∋ ω of m(A) / |A| / (1 - m(∅))."""
        member, size = self._singletons()
        size[size == 0] = np.inf
        p = (self._stack.masses[:, 0] / size) @ member
        return dict(zip(self.frame.elements, (p / p.sum()).tolist()))

    def plausibility_transform(self) -> dict[str, float]:
        """The singleton plausibilities pl({ω}), normalised to sum 1 (Cobb & Shenoy).

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"a": 0.5, "a|b": 0.5}).plausibility_transform()
        {'a': 0.6666666666666666, 'b': 0.3333333333333333}
        """
        member, _ = self._singletons()
        contour = self._stack.masses[:, 0] @ member
        return dict(zip(self.frame.elements, (contour / contour.sum()).tolist()))

    def discount(self, reliability: float) -> MassFunction:
        """Shafer's discounting: m'(A) = r m(A) for A ≠ Θ, m'(Θ) = r m(Θ) + 1 - r.

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"a": 1.0}).discount(0.75).to_dict()
        {'a': 0.75, 'a|b': 0.25}
        """
        if isinstance(reliability, bool) or not isinstance(reliability, Real) or not 0 <= reliability <= 1:
            raise MassError(f"reliability must be a number in [0, 1], got {reliability!r}")
        masks, full = self._stack.masks, self.frame.full
        masses = self._stack.masses[:, 0] * reliability
        if masks[-1] == full:
            masses[-1] += 1.0 - reliability
        else:
            masks, masses = np.append(masks, full), np.append(masses, 1.0 - reliability)
        return MassFunction.from_stack(self.frame, Stack(masks, masses[:, None]))

    def condition(self, focal: Focal) -> MassFunction:
        """Dempster's conditioning on A: m(B | A) = sum of m(C) over C ∩ A = B, normalised.

        Raises :class:`~evidential.errors.TotalConflictError` when pl(A) = 0.

        Examples
        --------
        >>> m = MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "b|c": 0.3, "c": 0.2})
        >>> {k: round(v, 12) for k, v in m.condition("a|b").to_dict().items()}
        {'a': 0.625, 'b': 0.375}
        """
        a = self.frame.mask(focal)
        if self.plausibility(a) == 0:
            raise TotalConflictError(f"cannot condition on {self.frame.label(a)!r}: its plausibility is 0 (K = 1)")
        return MassFunction.from_stack(
            self.frame, dempster([self._stack, Stack(np.array([a]), np.ones((1, 1)))], len(self.frame))
        )

    def max_belief(self, candidates: list[Focal] | None = None) -> str:
        """The label of the candidate with the largest belief (first in order on ties).

        Parameters
        ----------
        candidates : list of focal sets, optional
            Default: the singletons, in frame order.

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"b": 0.4, "a|b": 0.6}).max_belief()
        'b'
        """
        sets = (
            [1 << i for i in range(len(self.frame))] if candidates is None else [self.frame.mask(c) for c in candidates]
        )
        scores = [self.belief(s) for s in sets]
        return self.frame.label(sets[int(np.argmax(scores))])

    def max_pignistic(self) -> str:
        """The element with the largest pignistic probability (first in frame order on ties).

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"b": 0.4, "a": 0.5, "a|b": 0.1}).max_pignistic()
        'a'
        """
        p = self.pignistic()
        return max(p, key=p.__getitem__)


def _read_only(masks: NDArray[np.int64], masses: NDArray[np.float64]) -> Stack:
    """A stack of read-only views of the arrays (a mass function's arrays never change)."""
    masks, masses = masks.view(), masses.view()
    masks.flags.writeable = False
    masses.flags.writeable = False
    return Stack(masks, masses)


def _masks(frame: Frame, focal_sets: ArrayLike) -> NDArray[np.int64]:
    """The distinct focal sets as an int64 array of bitmasks (unsorted), checked against the frame."""
    if isinstance(focal_sets, np.ndarray) and focal_sets.dtype.kind in "iu":
        keys = focal_sets.astype(np.int64).ravel()
        outside = (keys < 0) | (keys > frame.full)
        if outside.any():
            raise FrameError(f"focal set {int(keys[np.argmax(outside)])} is not a subset of {frame!r}")
    else:
        keys = np.array([frame.mask(f.item() if isinstance(f, np.generic) else f) for f in focal_sets], dtype=np.int64)
    uniq, counts = np.unique(keys, return_counts=True)
    if (counts > 1).any():
        raise MassError(f"focal set {frame.label(int(uniq[np.argmax(counts > 1)]))!r} is given twice")
    return keys
