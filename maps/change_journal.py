"""Which objects of a map changed since a version: what is derived from the map catches up with them only.

>>> journal = ChangeJournal()
>>> start = journal.version
>>> journal.changed("L1"); journal.changed("C2", "L1")
>>> journal.version - start, sorted(journal.since(start)), sorted(journal.since(start + 1))
(2, ['C2', 'L1'], ['C2', 'L1'])
"""

from __future__ import annotations

import bisect
from itertools import repeat

__all__ = ["ChangeJournal"]


class ChangeJournal:
    """A version number that changes with the map, and the ids changed at each version (the newer ones)."""

    def __init__(self) -> None:
        self.version = 0
        """A number that changes whenever the map does."""
        self._journal: list[tuple[int, str]] = []  # (version, id) of every object changed, oldest first
        self._floor = 0  # the journal tells the changes since this version on

    def changed(self, *ids: str, keep: int = 4096) -> None:
        """A new version, in which the objects ``ids`` (maybe none) changed; past ``keep`` entries (and twice
        the map's size, say) the older half of the journal is forgotten."""
        self.version += 1
        if ids:
            self._journal.extend(zip(repeat(self.version), ids))
        if len(self._journal) > keep:
            half = len(self._journal) // 2
            self._floor = self._journal[half - 1][0]
            del self._journal[:half]

    def since(self, version: int) -> set[str] | None:
        """The ids changed since ``version``; None if the journal no longer goes back that far."""
        if version < self._floor:
            return None
        start = bisect.bisect_right(self._journal, (version, "\uffff"))
        return {id for _, id in self._journal[start:]}

    def forget(self) -> None:
        """A new version that tells nothing of the past: what was derived from the map is made anew."""
        self.version += 1
        self._journal.clear()
        self._floor = self.version
