"""The map's own graph makes every change as networkx's Graph makes it: the same dicts in the same orders."""

import networkx as nx
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.map_graph import MapGraph

NODES = st.sampled_from(["A", "B", "C", "D", "E"])
CHANGES = st.lists(
    st.one_of(
        st.tuples(st.just("add_node"), NODES, st.integers(0, 3)),
        st.tuples(st.just("add_edge"), NODES, NODES, st.integers(0, 3)),
        st.tuples(st.just("remove_node"), NODES),
        st.tuples(st.just("remove_edge"), NODES, NODES),
    ),
    max_size=40,
)


def apply(graph: MapGraph | nx.Graph, change: tuple) -> None:
    what, *args = change
    if what == "add_node":
        graph.add_node(args[0], x=args[1])
    elif what == "add_edge" and args[0] != args[1]:  # a map has no loops
        graph.add_edge(args[0], args[1], x=args[2])
    elif what == "remove_node" and args[0] in graph:
        graph.remove_node(args[0])
    elif what == "remove_edge" and graph.has_edge(args[0], args[1]):
        graph.remove_edge(args[0], args[1])


@given(CHANGES)
def test_changes_leave_the_dicts_networkx_would_leave(changes):
    ours, theirs = MapGraph(rule="dempster"), nx.Graph(rule="dempster")
    for change in changes:
        apply(ours, change)
        apply(theirs, change)
    assert list(ours.nodes.items()) == list(theirs.nodes(data=True))
    assert [(n, list(nbrs.items())) for n, nbrs in ours.adj.items()] == [
        (n, list(nbrs.items())) for n, nbrs in theirs.adjacency()
    ]
    assert list(ours.edges()) == list(theirs.edges(data=True))
    some = ["C", "A"]
    assert list(ours.edges(some)) == list(theirs.edges(some, data=True))
    assert ours.number_of_edges() == theirs.number_of_edges() and len(ours) == theirs.number_of_nodes()
    assert all(ours.degree(n) == theirs.degree(n) for n in ours)
    copy = ours.to_networkx()
    assert nx.utils.graphs_equal(copy, theirs) and list(copy.edges(data=True)) == list(theirs.edges(data=True))
