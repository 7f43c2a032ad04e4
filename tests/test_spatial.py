"""The spatial index: after any changes, a query finds exactly the boxes that meet it, and a query of many
boxes the union of their queries."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from evmap.maps.spatial import SpatialIndex

coordinate = st.floats(-50.0, 50.0, allow_nan=False).map(lambda v: round(v, 1))
box = st.tuples(coordinate, coordinate, coordinate, coordinate).map(
    lambda c: (min(c[0], c[2]), min(c[1], c[3]), max(c[0], c[2]), max(c[1], c[3]))
)
change = st.tuples(st.sampled_from(["insert", "remove"]), st.integers(0, 300), box)


def meets(a, b) -> bool:
    return a[0] <= b[2] and a[2] >= b[0] and a[1] <= b[3] and a[3] >= b[1]


@given(st.lists(box, max_size=40), st.lists(change, max_size=150), st.lists(box, min_size=1, max_size=5))
def test_queries_find_exactly_the_boxes_that_meet_them(start, changes, queries):
    boxes = {f"k{i}": b for i, b in enumerate(start)}
    index = SpatialIndex.from_boxes(list(boxes), np.array(list(boxes.values())))
    for what, key, b in changes:  # enough changes to make the tree be built anew, with moves and removals
        key = f"k{key % 60}"
        if what == "insert":
            index.insert(key, b)
            boxes[key] = b
        elif key in boxes:
            index.remove(key)
            del boxes[key]
        assert len(index) == len(boxes) and all(k in index for k in boxes)
    for q in queries:
        assert index.query(q) == {k for k, b in boxes.items() if meets(b, q)}
    assert index.query(np.array(queries).reshape(-1, 4)) == set().union(*(index.query(q) for q in queries))
    assert index.query(np.zeros((0, 4))) == set()
    if boxes:
        lo = np.array(list(boxes.values())).min(axis=0)
        hi = np.array(list(boxes.values())).max(axis=0)
        xmin, ymin, xmax, ymax = index.extent()
        assert xmin <= lo[0] and ymin <= lo[1] and xmax >= hi[2] and ymax >= hi[3]


def test_many_boxes_are_tested_in_steps_as_in_one():
    rng = np.random.default_rng(3)
    lo = rng.uniform(-100, 100, (500, 2))
    held = np.hstack([lo, lo + rng.uniform(0, 30, (500, 2))])  # some wide enough for the wide list
    index = SpatialIndex.from_boxes([f"k{i}" for i in range(500)], held)
    qlo = rng.uniform(-100, 100, (2000, 2))
    queries = np.hstack([qlo, qlo + rng.uniform(0, 3, (2000, 2))])  # 500 x 2000 tests: more than one step
    assert index.query(queries) == set().union(*(index.query(tuple(q)) for q in queries.tolist()))
