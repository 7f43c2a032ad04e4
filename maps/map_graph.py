"""The belief map's points and lines: plain dicts in networkx's layout, and networkx's Graph made of them.

A map is an undirected graph, points as nodes and lines as edges, and the map
needs of a graph only its dicts: ``nodes`` (id -> attributes), ``adj`` (id ->
neighbour -> the line's attributes, one dict shared by both ends) and ``graph``
(the map's own attributes). :class:`MapGraph` is those dicts and the few changes
the map makes to them, exactly as :class:`networkx.Graph` makes them (the same
insertion orders, so the same files); :meth:`MapGraph.to_networkx` copies them
into a :class:`networkx.Graph` for networkx's algorithms.
Importing networkx costs a command-line run 0.1 s, a fifth of its wall time
(``benchmarks/bench_cli.py``): a run that never calls networkx never imports it.

>>> g = MapGraph(rule="dempster")
>>> g.add_node("C1", xy=(0.0, 0.0)); g.add_edge("C1", "E2", id="L3")
>>> g.nodes["E2"], g.adj["C1"]["E2"] is g.adj["E2"]["C1"], list(g.edges())
({}, True, [('C1', 'E2', {'id': 'L3'})])
>>> copy = g.to_networkx()
>>> copy.edges["C1", "E2"]["id"], copy.graph["rule"]
('L3', 'dempster')
>>> g.remove_node("E2"); len(g), copy.number_of_nodes()
(1, 2)
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import networkx as nx

__all__ = ["MapGraph"]


class MapGraph:
    """Points (``nodes``) and lines (``adj``) of a map with its attributes (``graph``); see the module."""

    __slots__ = ("adj", "graph", "nodes")

    def __init__(self, **attrs: Any) -> None:
        self.graph: dict[str, Any] = dict(attrs)
        self.nodes: dict[str, dict[str, Any]] = {}
        self.adj: dict[str, dict[str, dict[str, Any]]] = {}

    def __contains__(self, node: object) -> bool:
        return node in self.nodes

    def __iter__(self) -> Iterator[str]:
        return iter(self.nodes)

    def __len__(self) -> int:
        return len(self.nodes)

    def number_of_nodes(self) -> int:
        return len(self.nodes)

    def number_of_edges(self) -> int:
        return sum(map(len, self.adj.values())) // 2  # the map has no loops

    def has_edge(self, u: str, v: str) -> bool:
        return v in self.adj.get(u, ())

    def degree(self, node: str) -> int:
        return len(self.adj[node])

    def edge(self, u: str, v: str) -> dict[str, Any]:
        """The attributes of the line between ``u`` and ``v``."""
        return self.adj[u][v]

    def edges(self, nbunch: Iterable[str] | None = None) -> Iterator[tuple[str, str, dict[str, Any]]]:
        """``(u, v, attributes)`` of every line (of those at the points ``nbunch``), each once, in networkx's order."""
        seen: set[str] = set()
        for u in self.adj if nbunch is None else [n for n in nbunch if n in self.adj]:
            for v, data in self.adj[u].items():
                if v not in seen:
                    yield u, v, data
            seen.add(u)

    def add_node(self, node: str, **attrs: Any) -> None:
        if node not in self.nodes:
            self.adj[node] = {}
            self.nodes[node] = {}
        self.nodes[node].update(attrs)

    def add_edge(self, u: str, v: str, **attrs: Any) -> None:
        for node in (u, v):
            self.add_node(node)
        data = self.adj[u].get(v, {})
        data.update(attrs)
        self.adj[u][v] = self.adj[v][u] = data

    def remove_node(self, node: str) -> None:
        for v in self.adj.pop(node):
            del self.adj[v][node]
        del self.nodes[node]

    def remove_edge(self, u: str, v: str) -> None:
        del self.adj[u][v]
        del self.adj[v][u]

    def to_networkx(self) -> nx.Graph:
        """A :class:`networkx.Graph` of the map as it is now, for networkx's algorithms: a copy of the dicts' layout
        (a later change to the map is not in it) holding the same attribute values."""
        import networkx as nx

        copy = nx.Graph(**self.graph)
        copy.add_nodes_from(self.nodes.items())
        copy.add_edges_from(self.edges())
        return copy
