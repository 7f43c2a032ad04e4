"""Mass functions: sparse arrays of focal set bitmasks and masses over a frame.

The value type; its inputs are checked by :mod:`evidential.validation`, its belief,
plausibility and commonality queries are the functions of :mod:`evidential.queries`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from itertools import repeat
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential import queries
from evidential.elements import element_masses
from evidential.errors import FrameError, MassError, TotalConflictError
from evidential.frame import Focal, Frame
from evidential.queries import Query
from evidential.rules import dempster
from evidential.stack import DENSE_MAX_BITS, Stack
from evidential.validation import checked_mapping, checked_rows, read_only, real_array


class MassFunction:
    """A mass function (basic belief assignment) over a frame.

    Stored sparse: the focal sets (bitmasks, increasing) and their positive
    masses; :meth:`dense` gives the 2**n vector. Validated on construction:
    masses finite and >= 0, total 1 within 1e-9, focal sets inside the frame,
    no mass on the empty set ``""`` unless ``open_world=True``. Frames of more
    than 63 elements hold their focal sets as Python ints (slower, same API).

    A mass function is a value: ``==`` compares the frame and the focal sets
    with their masses exactly (:meth:`isclose` within a tolerance), and equal
    mass functions hash alike. Iterating gives the focal sets' labels (in
    bitmask order); ``focal in m`` tells whether a focal set, written any way
    :meth:`Frame.mask` reads, has mass.

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
    >>> list(m), "real" in m, "noise|real" in m, 0 in m
    (['real', 'noise', 'real|noise'], True, True, False)
    >>> m == MassFunction(frame, {"real|noise": 0.1, "noise": 0.1, "real": 0.8})
    True
    """

    __slots__ = ("_pairs", "_stack", "frame")

    def __init__(self, frame: Frame, masses: Mapping[Focal, float], *, open_world: bool = False) -> None:
        self._stack = checked_mapping(frame, masses, open_world=open_world)
        self.frame = frame

    @classmethod
    def from_stack(cls, frame: Frame, stack: Stack, column: int = 0, *, positive: bool = False) -> MassFunction:
        """Column ``column`` of a rule's result, trusted as valid (zero masses dropped).

        ``positive``: the masses are known to be > 0 (a kernel's output), not even that is checked.
        """
        if positive:
            return cls._new(frame, read_only(stack.masks, stack.masses[:, column : column + 1]))
        values = stack.masses[:, column]
        keep = values > 0
        if keep.all():
            return cls._new(frame, read_only(stack.masks, stack.masses[:, column : column + 1]))
        return cls._new(frame, read_only(stack.masks[keep], values[keep][:, None]))

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
        keys, values = checked_rows(frame, masks, rows, open_world=open_world)
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
        v = real_array(vector, "a dense mass vector")
        if v.shape != (1 << len(frame),):
            raise MassError(f"a dense mass vector over {frame!r} has shape ({1 << len(frame)},), got {v.shape}")
        return cls(frame, {int(b): float(v[b]) for b in np.flatnonzero(v != 0)}, open_world=open_world)

    @property
    def masks(self) -> NDArray:
        """The focal sets as bitmasks, increasing (read-only; int64, or Python ints beyond 63 elements)."""
        return self._stack.masks

    @property
    def stack(self) -> Stack:
        """The focal sets and masses as a one-column :class:`~evidential.stack.Stack` (read-only arrays)."""
        return self._stack

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

    def __iter__(self) -> Iterator[str]:
        """The labels of the focal sets, in bitmask order (``""`` for ∅)."""
        return map(self.frame.label, self._stack.masks.tolist())

    def __contains__(self, focal: object) -> bool:
        """Whether ``focal`` (a bitmask, a name, ``"a|b"`` or names) is a focal set; False outside the frame."""
        if isinstance(focal, bool | np.bool_) or not isinstance(focal, int | np.integer | str | Iterable):
            raise TypeError(
                f"'in' tests a focal set (a bitmask, a name, 'a|b' or names), got {type(focal).__name__} {focal!r}"
            )
        try:
            mask = self.frame.mask(focal)
        except FrameError:
            return False
        masks = self._stack.masks
        i = np.searchsorted(masks, mask)
        return bool(i < masks.size and masks[i] == mask)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MassFunction):
            return NotImplemented
        return self is other or (
            self.frame == other.frame
            and np.array_equal(self._stack.masks, other._stack.masks)
            and np.array_equal(self._stack.masses[:, 0], other._stack.masses[:, 0])
        )

    def __hash__(self) -> int:
        return hash((self.frame, tuple(self._stack.masks.tolist()), tuple(self._stack.masses[:, 0].tolist())))

    def isclose(self, other: MassFunction, rtol: float = 1e-9, atol: float = 0.0) -> bool:
        """Whether ``other`` is on the same frame with masses within tolerance, set by set.

        As :func:`math.isclose` on every focal set of either (a missing set has
        mass 0): ``|a - b| <= max(rtol * max(|a|, |b|), atol)``.

        Examples
        --------
        >>> frame = Frame(["a", "b"])
        >>> m = MassFunction(frame, {"a": 0.3, "b": 0.7})
        >>> m.isclose(MassFunction(frame, {"a": 0.1 + 0.2, "b": 0.7})), m.isclose(MassFunction(frame, {"a": 1.0}))
        (True, False)
        """
        if not isinstance(other, MassFunction):
            raise TypeError(f"other must be a MassFunction, got {type(other).__name__}")
        if self.frame != other.frame:
            return False
        keys = np.union1d(self.masks, other.masks)
        a, b = np.zeros(keys.size), np.zeros(keys.size)
        a[np.searchsorted(keys, self.masks)] = self.masses
        b[np.searchsorted(keys, other.masks)] = other.masses
        return bool(np.all(np.abs(a - b) <= np.maximum(rtol * np.maximum(a, b), atol)))

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
            raise FrameError(
                f"a dense view (2**n masses) needs a frame of at most {DENSE_MAX_BITS} elements, got {n}; "
                "the sparse queries (belief, plausibility, pignistic, to_dict) work on any frame"
            )
        out = np.zeros(1 << n)
        out[self._stack.masks] = self._stack.masses[:, 0]
        return out

    def belief(self, focal: Query) -> float | NDArray[np.float64]:
        """bel(A): the mass of the non-empty focal sets inside A.

        Parameters
        ----------
        focal : focal set, or list or array of focal sets
            One focal set gives a float; a list or a 1-D array of focal sets
            (bitmasks or labels) gives an array, one numpy pass over the focal
            sets for all of them. (A tuple of names is one focal set.)

        Examples
        --------
        >>> m = MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "a|b": 0.25, "c": 0.25})
        >>> m.belief("a|b"), m.belief(["a", "a|b", 7]).tolist(), m.belief(np.array([4, 0])).tolist()
        (0.75, [0.5, 0.75, 1.0], [0.25, 0.0])
        """
        return queries.belief(self.frame, self._stack, focal, self._python_pairs())

    def plausibility(self, focal: Query) -> float | NDArray[np.float64]:
        """pl(A): the mass of the focal sets meeting A; a list or array of sets gives an array (see :meth:`belief`).

        Examples
        --------
        >>> MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "a|b": 0.25, "c": 0.25}).plausibility([2, 6]).tolist()
        [0.25, 0.5]
        """
        return queries.plausibility(self.frame, self._stack, focal, self._python_pairs())

    def commonality(self, focal: Query) -> float | NDArray[np.float64]:
        """q(A): the mass of the focal sets containing A; a list or array of sets gives an array (see :meth:`belief`).

        Examples
        --------
        >>> MassFunction(Frame(["a", "b", "c"]), {"a": 0.5, "a|b": 0.25, "c": 0.25}).commonality(["a", ""]).tolist()
        [0.75, 1.0]
        """
        return queries.commonality(self.frame, self._stack, focal, self._python_pairs())

    def _python_pairs(self) -> queries.Pairs | None:
        """The stack's :func:`~evidential.queries.python_pairs`, made by the first query (the stack never changes)."""
        try:
            return self._pairs
        except AttributeError:  # the slot stays empty until then
            self._pairs = queries.python_pairs(self._stack)
            return self._pairs

    def pignistic(self) -> dict[str, float]:
        """The pignistic probabilities BetP(ω) = sum over A ∋ ω of m(A) / |A| / (1 - m(∅)).

        Computed on the focal sets alone (never a 2**n vector), the non-empty masses normalised first.
        Raises :class:`~evidential.errors.UndefinedTransformError` when m(∅) = 1.
        """
        p = element_masses(self._stack, len(self.frame), split=True)[:, 0]
        return dict(zip(self.frame.elements, p.tolist()))

    def plausibility_transform(self) -> dict[str, float]:
        """The singleton plausibilities pl({ω}), normalised to sum 1 (Cobb & Shenoy).

        Raises :class:`~evidential.errors.UndefinedTransformError` when m(∅) = 1.

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"a": 0.5, "a|b": 0.5}).plausibility_transform()
        {'a': 0.6666666666666666, 'b': 0.3333333333333333}
        """
        contour = element_masses(self._stack, len(self.frame), split=False)[:, 0]
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
            self.frame,
            dempster([self._stack, Stack(np.array([a], dtype=self.frame.dtype), np.ones((1, 1)))], len(self.frame)),
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
        sets = [1 << i for i in range(len(self.frame))] if candidates is None else list(candidates)
        return self.frame.label(self.frame.mask(sets[int(np.argmax(self.belief(sets)))]))

    def max_pignistic(self) -> str:
        """The element with the largest pignistic probability (first in frame order on ties).

        Raises :class:`~evidential.errors.UndefinedTransformError` when m(∅) = 1.

        Examples
        --------
        >>> MassFunction(Frame(["a", "b"]), {"b": 0.4, "a": 0.5, "a|b": 0.1}).max_pignistic()
        'a'
        """
        p = self.pignistic()
        return max(p, key=p.__getitem__)
