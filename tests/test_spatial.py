"""The grid index: made in bulk, it is what one insert after another makes."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.spatial import GridIndex

coordinate = st.floats(-50.0, 50.0, allow_nan=False)


@st.composite
def boxes(draw):
    n = draw(st.integers(0, 30))
    corners = np.array(draw(st.lists(st.tuples(*[coordinate] * 4), min_size=n, max_size=n)), dtype=float)
    corners = corners.reshape(n, 4)
    lo, hi = np.minimum(corners[:, :2], corners[:, 2:]), np.maximum(corners[:, :2], corners[:, 2:])
    return np.hstack([lo, hi])


@given(boxes(), st.sampled_from([0.7, 2.0, 10.0]))
def test_bulk_grid_is_the_grid_of_inserts(b, cell):
    keys = [f"k{i}" for i in range(len(b))]
    one_by_one = GridIndex(cell)
    for key, box in zip(keys, b.tolist(), strict=True):
        one_by_one.insert(key, tuple(box))
    bulk = GridIndex.from_boxes(cell, keys, b)
    assert bulk._where == one_by_one._where
    assert bulk._cells == one_by_one._cells
    if keys:  # and it changes as the other does
        bulk.remove(keys[0])
        one_by_one.remove(keys[0])
        assert bulk._cells == one_by_one._cells and bulk.query((-5, -5, 5, 5)) == one_by_one.query((-5, -5, 5, 5))
