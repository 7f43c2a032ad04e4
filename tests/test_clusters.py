"""Close pairs against brute force, connected components against scipy's (which they replace on the run's path)."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components

from evmap.sources.clusters import close_pairs, component_labels


@given(st.integers(0, 60), st.floats(0.0, 0.5), st.integers(0, 2**32 - 1))
def test_close_pairs_are_every_pair_within_the_distance(n, distance, seed):
    rng = np.random.default_rng(seed)
    points = np.round(rng.uniform(0, 2, (n, 2)), 1)  # on a grid, so that pairs sit exactly at the distance too
    i, j = close_pairs(points, distance)
    gap = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    expected = np.argwhere(np.triu(gap <= distance, k=1))  # exact distances: a pair at the distance is in
    assert np.array_equal(np.stack([i, j], axis=1).reshape(-1, 2), expected)
    assert i.dtype == j.dtype == np.intp


@given(st.integers(1, 80), st.integers(0, 120), st.integers(0, 2**32 - 1))
def test_components_are_scipys(n, edges, seed):
    rng = np.random.default_rng(seed)
    a, b = rng.integers(0, n, edges), rng.integers(0, n, edges)
    labels = component_labels(n, a, b)
    _, expected = connected_components(coo_array((np.ones(edges), (a, b)), shape=(n, n)), directed=False)
    assert labels.tolist() == expected.tolist()


def test_a_long_chain_is_one_component():
    n = 10_000
    order = np.random.default_rng(0).permutation(n)
    assert (component_labels(n, order[:-1], order[1:]) == 0).all()


def test_no_nodes_and_no_edges():
    assert component_labels(0, [], []).tolist() == []
    assert component_labels(3, [], []).tolist() == [0, 1, 2]
    i, j = close_pairs(np.empty((0, 2)), 1.0)
    assert i.size == j.size == 0
