"""Frames of discernment: ordered, named elements; focal sets as int bitmasks."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from collections.abc import Set as AbstractSet
from types import MappingProxyType

import numpy as np

from evidential.errors import FrameError

WORD_BITS = 63
"""Largest frame whose focal sets are one machine word (a signed 64-bit integer).

Larger frames (any size) hold their focal sets as Python ints in object arrays:
the sparse operations work on them, slower; dense views stay limited to small frames.
"""

Focal = int | np.integer | str | Iterable[str]
"""A focal set as the user writes it: a bitmask, a name, ``"a|b"``, ``""`` or names."""

LABEL_CACHE_SIZE = 4096
"""Most labels a frame keeps the bitmask of (the first ones read: labels are few in practice)."""


class Frame:
    """An ordered frame of discernment; element ``i`` is bit ``i`` of a focal set.

    Parameters
    ----------
    elements : iterable of str
        Distinct, non-empty names without ``"|"`` and without surrounding blanks.

    Examples
    --------
    >>> frame = Frame(["real", "noise"])
    >>> frame.full, frame.mask("noise"), frame.mask("noise|real"), frame.label(3)
    (3, 2, 3, 'real|noise')
    >>> frame == Frame(["real", "noise"])
    True
    >>> Frame(["real", "noise"]).dtype, Frame([f"e{i}" for i in range(100)]).dtype
    (dtype('int64'), dtype('O'))
    """

    __slots__ = ("_elements", "_index", "_labels", "dtype", "full")

    def __init__(self, elements: Iterable[str]) -> None:
        if isinstance(elements, str):
            raise FrameError(f"frame elements must be an iterable of names, got the string {elements!r}")
        if isinstance(elements, AbstractSet):  # no order of its own: bit i would depend on the hash seed
            raise FrameError(f"frame elements must be in an order (a list or tuple), got a {type(elements).__name__}")
        names = tuple(elements)
        if not names:
            raise FrameError("a frame needs at least one element, got none")
        for name in names:
            if not isinstance(name, str) or not name or "|" in name or name != name.strip():
                raise FrameError(f"frame element {name!r} must be a non-empty string without '|' or surrounding blanks")
        index = {name: i for i, name in enumerate(names)}
        if len(index) != len(names):
            dup = next(name for name in names if names.count(name) > 1)
            raise FrameError(f"frame element {dup!r} is given twice in {list(names)}")
        self._elements = names
        self._index = index
        self._labels: dict[str, int] = {}
        self.full = (1 << len(names)) - 1
        """The bitmask of the whole frame (Θ)."""
        self.dtype = np.dtype(np.int64 if len(names) <= WORD_BITS else object)
        """The dtype of focal set arrays: int64 up to :data:`WORD_BITS` elements, Python ints beyond."""

    @property
    def elements(self) -> tuple[str, ...]:
        """The element names, in frame order."""
        return self._elements

    @property
    def positions(self) -> Mapping[str, int]:
        """Element name to its position ``i`` (its bit is ``1 << i``), read-only.

        Examples
        --------
        >>> Frame(["a", "b"]).positions["b"], "c" in Frame(["a", "b"]).positions
        (1, False)
        """
        return MappingProxyType(self._index)

    def __len__(self) -> int:
        return len(self._elements)

    def __iter__(self) -> Iterator[str]:
        return iter(self._elements)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Frame) and self._elements == other._elements

    def __hash__(self) -> int:
        return hash(self._elements)

    def __repr__(self) -> str:
        return f"Frame({list(self._elements)!r})"

    def mask(self, focal: Focal) -> int:
        """The bitmask of a focal set.

        Parameters
        ----------
        focal : int, str or iterable of str
            A bitmask (a Python or numpy integer, not a bool), an element name,
            names joined by ``"|"`` (``""`` is the empty set), or an iterable of names.

        Examples
        --------
        >>> Frame(["a", "b", "c"]).mask(("a", "c")), Frame(["a", "b", "c"]).mask(np.int64(5))
        (5, 5)
        """
        if isinstance(focal, str):  # a label: parsed once, then looked up (the frame never changes)
            mask = self._labels.get(focal)
            if mask is None:
                mask = self._names_mask(focal, focal.split("|") if focal else [])
                if len(self._labels) < LABEL_CACHE_SIZE:
                    self._labels[focal] = mask
            return mask
        if isinstance(focal, bool | np.bool_):
            raise FrameError(f"focal set {focal!r} must be a bitmask, a name or names, got a bool")
        if isinstance(focal, int | np.integer):
            focal = int(focal)
            if not 0 <= focal <= self.full:
                raise FrameError(f"focal set bitmask {focal} is outside 0..{self.full} of {self!r}")
            return focal
        if not isinstance(focal, Iterable):
            raise FrameError(f"focal set {focal!r} must be a bitmask, a name or names, got a {type(focal).__name__}")
        return self._names_mask(focal, focal)

    def _names_mask(self, focal: Focal, names: Iterable[str]) -> int:
        """The bitmask of ``names``; the error names ``focal``, the set as the user wrote it."""
        mask = 0
        for name in names:
            i = self._index.get(name.strip() if isinstance(name, str) else name)
            if i is None:
                raise FrameError(f"focal set {focal!r}: element {name!r} is not in {self!r}")
            mask |= 1 << i
        return mask

    def label(self, mask: int) -> str:
        """The focal set ``mask`` written as names in frame order joined by ``"|"``.

        Examples
        --------
        >>> Frame(["a", "b"]).label(0), Frame(["a", "b"]).label(2)
        ('', 'b')
        """
        return "|".join(name for i, name in enumerate(self._elements) if mask >> i & 1)
