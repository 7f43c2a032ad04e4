"""How to undo a map's changes: the log a transaction keeps, and its undoing (:meth:`BeliefMap.transaction`).

Each change is a tuple ``(what, id, *before)``: ``"added line"``, ``"added
point"``, ``"removed line"`` (with its ends and data), ``"removed point"`` (with
its data), ``"set"`` (with the attributes' values before, :data:`ABSENT` where
there was none) and ``"folded"`` (with the mass before and the history's length).

>>> from evmap.maps.map_graph import MapGraph
>>> g = MapGraph(); g.add_node("A", kind="corner"); lines = {}
>>> log = UndoLog(); log.start()
>>> log.record("set", "A", {"kind": "corner", "shape": ABSENT}); g.nodes["A"].update(kind="endpoint", shape="x")
>>> g.add_node("B"); log.record("added point", "B")
>>> undo(log.stop(), g, lines, lambda id: g.nodes[id])
>>> list(g.nodes.items())
[('A', {'kind': 'corner'})]
"""

from __future__ import annotations

from collections.abc import Callable, MutableMapping
from typing import Any

from evmap.maps.map_graph import MapGraph

__all__ = ["ABSENT", "UndoLog", "undo"]

ABSENT = object()
"""What an attribute that a transaction set had been: absent (undo deletes it)."""


class UndoLog:
    """The changes made since :meth:`start`, while a transaction runs; nothing is kept outside one."""

    def __init__(self) -> None:
        self._changes: list[tuple[Any, ...]] | None = None

    @property
    def active(self) -> bool:
        """Whether a transaction runs (changes are logged)."""
        return self._changes is not None

    def start(self) -> None:
        """Log the changes from now on."""
        self._changes = []

    def stop(self) -> list[tuple[Any, ...]]:
        """Stop logging; the changes logged, oldest first."""
        changes, self._changes = self._changes or [], None
        return changes

    def record(self, *change: Any) -> None:
        """Log one change (see the module doc), if a transaction runs."""
        if self._changes is not None:
            self._changes.append(change)


def undo(
    changes: list[tuple[Any, ...]],
    graph: MapGraph,
    lines: MutableMapping[str, tuple[str, str]],
    data_of: Callable[[str], dict[str, Any]],
) -> None:
    """Undo ``changes`` newest first on the graph and its lines (id -> ends); ``data_of`` finds an object's data."""
    for change, id, *args in reversed(changes):
        if change == "added line":
            graph.remove_edge(*lines.pop(id))
        elif change == "added point":
            graph.remove_node(id)
        elif change == "removed line":
            u, v, data = args
            graph.add_edge(u, v)
            graph.adj[u][v].update(data)
            lines[id] = (u, v)
        elif change == "removed point":
            graph.add_node(id)
            graph.nodes[id].update(args[0])
        elif change == "set":
            data = data_of(id)
            for key, value in args[0].items():
                if value is ABSENT:
                    data.pop(key, None)
                else:
                    data[key] = value
        elif change == "folded":
            data = data_of(id)
            data["mass"] = args[0]
            del data["history"][args[1] :]
