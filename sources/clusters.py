"""Clusters of points and of graph nodes: close pairs and connected components.

Corner detection, line merging and the simulator's vertex welding each group
things that are linked pairwise. These two functions are what they share. They
use shapely's STRtree and numpy only: ``scipy.spatial`` and ``scipy.sparse``
would do the same work but cost more to import than a whole small run computes
(see ``benchmarks/bench_cli.py``).
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

__all__ = ["close_pairs", "component_labels"]


def close_pairs(points: ArrayLike, distance: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every pair ``i < j`` of points at most ``distance`` apart, sorted by ``(i, j)``.

    Parameters
    ----------
    points : (N, 2) coordinates.
    distance : the largest distance of a pair (inclusive, as ``np.hypot`` of the differences), >= 0.

    >>> close_pairs([[0, 0], [0.1, 0], [0.3, 0], [0.1, 0]], 0.1)
    (array([0, 0, 1]), array([1, 3, 3]))
    """
    xy = np.asarray(points, dtype=float).reshape(-1, 2)
    geoms = shapely.points(xy)
    slack = 8 * np.finfo(float).eps * distance  # GEOS rounds the distance its own way: decided below by hypot
    i, j = shapely.STRtree(geoms).query(geoms, predicate="dwithin", distance=distance + slack)
    keep = (i < j) & (np.hypot(*(xy[i] - xy[j]).T) <= distance)
    i, j = i[keep], j[keep]
    order = np.lexsort((j, i))
    return i[order].astype(np.intp), j[order].astype(np.intp)


def component_labels(n: int, a: ArrayLike, b: ArrayLike) -> NDArray[np.intp]:
    """The connected component of each of ``n`` nodes linked by the edges ``a[k]``-``b[k]``.

    Components are numbered 0, 1, ... in the order of their smallest node, as
    ``scipy.sparse.csgraph.connected_components`` numbers them. Each round hooks
    the larger of two linked roots under the smaller and then compresses the
    pointers until every node points at its root, so labels only decrease and
    the loop ends when no edge links two roots.

    >>> component_labels(6, [4, 0, 1], [5, 1, 2]).tolist()
    [0, 0, 0, 1, 2, 2]
    """
    a = np.asarray(a, dtype=np.intp)
    b = np.asarray(b, dtype=np.intp)
    root = np.arange(n, dtype=np.intp)
    while True:
        ra, rb = root[a], root[b]
        linked = ra != rb
        if not linked.any():
            break
        ra, rb = ra[linked], rb[linked]
        np.minimum.at(root, np.maximum(ra, rb), np.minimum(ra, rb))
        while True:
            up = root[root]
            if np.array_equal(up, root):
                break
            root = up
    return np.unique(root, return_inverse=True)[1].astype(np.intp)
