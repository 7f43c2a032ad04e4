"""Corners where end points of different lines meet (paper, section III).

End points of two different lines that are at least ``min_angle_deg`` from
parallel and lie within ``distance`` of each other are linked. A corner is a
connected set of linked end points (single linkage), placed at their
centroid: for exactly two end points, their midpoint, as the paper says. The
lines' end points are moved onto their corner. Each end point belongs to at
most one corner; a corner holds at most one end of each line (were a line
shorter than the tolerance to bring both its ends, the one nearer the
corner's first centroid stays and the other is left free).

With ``drawn_apart`` (:class:`~evmap.sources.params.CornerParams`), the lines
drawn from a corner to their other ends must stay ``min_angle_deg`` from
parallel too, and each within :data:`TURN_SHARE` of ``min_angle_deg`` of its own
direction (a line has two ends: turned at both, it stays within the corner
angle), and, given merging's tolerances, unrelated to every other line as fitted
(:func:`~evmap.maps.merging.related_pairs`: a corner must not draw a line onto a
neighbouring piece of the same wall that merging left apart): where two come
closer (a short piece folded onto a wall, a bending wall drawn straight), a
corner turns a line further (a piece of a few centimetres drawn across or back
along itself), or draws it within merging's tolerances of another line, the end
of the line the corner turns most from its own direction leaves it, and the
corner is found again without it. Given merging's tolerances, the lines are also
drawn to their other ends where those ends' own corners put them (a line moved
at both ends): two that then come within the corner angle, or one then related
to another line (whose end moved farther leaves: end 0 if as far), are judged
as above.

Only end points are compared: an end point near the middle of another line
(a T-junction) makes no corner, and parallel lines whose ends touch make none
(merging is where collinear pieces join).

Shape, as seen from a viewpoint (the robot) ``v``: the lines leave the corner
``c`` in outward directions; they cut the plane round ``c`` into sectors, and
``v - c`` lies in one of them. The corner is ``concave`` if that sector is
narrower than 180 deg (it opens toward the robot, whose sound the two walls
send back), else ``convex``. For two lines this is: concave if ``v`` lies
inside the wedge the two lines span. Occlusion is not considered: from
outside a square room, the far corner faces the robot with its inner side and
is concave, though the walls hide it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from evmap.maps.merging import check_segments, related_pairs
from evmap.sources.clusters import close_pairs, component_labels
from evmap.sources.params import CornerParams, MergeParams

__all__ = ["TURN_SHARE", "Corners", "drawn_reach", "drawn_turn", "find_corners", "loose_merge"]

_EPS = 1e-9

TURN_SHARE = 0.5
"""With ``drawn_apart``, a corner turns a line from its own direction by at most this share of the corner angle:
a line has two ends, and turned at both it stays within the angle (with the whole angle at each end, lines turned
at both came within the angle of a neighbour: related pairs of believed lines on Freiburg's first 1,000 scans
7 -> 5 with half, on its whole log 15 -> 8)."""


@dataclass(frozen=True, eq=False)
class Corners:
    """Corners of a set of lines, and the lines snapped onto them.

    Attributes
    ----------
    xy : (K, 2) float array, the corner points, ordered by their smallest end (2 * line + end).
    ends : list of K int arrays of shape (m, 2), the (line index, end 0|1) pairs of
        each corner, by line index. End 0 is a line's ``p``, end 1 its ``q``.
    p, q : (N, 2) float arrays, copies of the lines with their corner ends moved onto the corner.
    corner_of : (N, 2) int array, the corner of each line's end 0 and end 1, -1 if none.
    free : (F, 2) int array, the (line index, end) pairs that belong to no corner.
    shape : (K,) str array, "concave" or "convex" as seen from the viewpoint, or
        "unknown" without one (or for a viewpoint exactly on the corner).
    """

    xy: NDArray[np.float64]
    ends: list[NDArray[np.intp]]
    p: NDArray[np.float64]
    q: NDArray[np.float64]
    corner_of: NDArray[np.intp]
    free: NDArray[np.intp]
    shape: NDArray[np.str_]


def find_corners(
    p: ArrayLike,
    q: ArrayLike,
    params: CornerParams | None = None,
    viewpoint: ArrayLike | None = None,
    *,
    merge: MergeParams | None = None,
    others: tuple[ArrayLike, ArrayLike] | None = None,
    placed: ArrayLike | None = None,
) -> Corners:
    """Find the corners of lines p-q and snap their end points onto them.

    Parameters
    ----------
    p, q : (N, 2) end points of the lines (metres).
    params : the tolerances; ``CornerParams()`` (5 cm, 10 deg) if omitted.
    viewpoint : (x, y) of the robot, for the corners' shapes, or (M, 2) robot positions, each corner seen
        from the nearest of them; None for "unknown".
    merge : merging's tolerances: with ``params.drawn_apart``, no line is drawn related to another line (of p-q,
        or of ``others``: the ends of lines that make no corner here, (K, 2) each).
    placed : (N, 2, 2) where the ends of p-q already stand on points that stay (a map's points outside a
        rebuild), NaN where they are found here: a line is drawn to such an end there.

    Returns
    -------
    Corners

    Examples
    --------
    An L whose two ends are 2 cm apart, seen from inside the L, and from outside:

    >>> p, q = [[1, 0], [0.02, 0]], [[0, 0], [0.02, 1]]
    >>> c = find_corners(p, q, viewpoint=(0.5, 0.5))
    >>> c.xy.tolist(), c.ends[0].tolist(), c.shape.tolist()
    ([[0.01, 0.0]], [[0, 1], [1, 0]], ['concave'])
    >>> c.q[0].tolist(), c.p[1].tolist(), c.free.tolist()
    ([0.01, 0.0], [0.01, 0.0], [[0, 0], [1, 1]])
    >>> find_corners(p, q, viewpoint=(-1, -1)).shape.tolist()
    ['convex']
    """
    params = CornerParams() if params is None else params
    p, q = check_segments(p, q)
    n = len(p)
    ends = np.stack([p, q], axis=1).reshape(-1, 2)  # end e is line e // 2, end e % 2
    d = q - p
    u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
    e1, e2 = close_pairs(ends, params.distance + _EPS)
    l1, l2 = e1 // 2, e2 // 2
    cos_max = np.cos(np.radians(params.min_angle_deg)) + _EPS
    link = (l1 != l2) & (np.abs(np.sum(u[l1] * u[l2], axis=1)) <= cos_max)
    e1, e2 = e1[link], e2[link]
    member, comp = _clusters(ends, e1, e2)
    apart = None
    if merge is not None:
        op, oq = (np.zeros((0, 2)), np.zeros((0, 2))) if others is None else check_segments(*others)
        apart = merge, np.concatenate([p, op]), np.concatenate([q, oq])
    fixed = None if placed is None else np.asarray(placed, dtype=float).reshape(-1, 2)
    while params.drawn_apart and (folded := _folded(ends, member, comp, u, cos_max, apart, fixed)).size:
        kept = ~(np.isin(e1, folded) | np.isin(e2, folded))
        e1, e2 = e1[kept], e2[kept]
        member, comp = _clusters(ends, e1, e2)
    # Corners numbered by their smallest end.
    _, first, corner = np.unique(comp[member], return_index=True, return_inverse=True)
    corner = np.argsort(np.argsort(first))[corner]
    k = first.size
    xy = _group_mean(ends[member], corner, k)
    corner_of = np.full(2 * n, -1)
    corner_of[member] = corner
    snapped = ends.copy()
    snapped[member] = xy[corner]
    by_corner = np.argsort(corner, kind="stable")
    split = np.flatnonzero(np.diff(corner[by_corner])) + 1
    corner_ends = [np.stack([e // 2, e % 2], axis=1) for e in np.split(member[by_corner], split)] if k else []
    free = np.flatnonzero(corner_of < 0)
    snapped = snapped.reshape(n, 2, 2)
    return Corners(
        xy=xy,
        ends=corner_ends,
        p=snapped[:, 0],
        q=snapped[:, 1],
        corner_of=corner_of.reshape(n, 2),
        free=np.stack([free // 2, free % 2], axis=1),
        shape=_shapes(snapped.reshape(-1, 2), member, corner, xy, viewpoint),
    )


def loose_merge(params: CornerParams, merge: MergeParams, turn_deg: float) -> MergeParams:
    """Merging's tolerances widened by what corners may do to a line (with ``drawn_apart``): its ends moved by up to
    three corner distances (a corner's ends lie each within the corner distance of another, most often two of
    them), the line turned by up to ``turn_deg`` (:func:`drawn_turn`). A line that corners could draw related to
    another line pairs with it by these as fitted."""
    return MergeParams(
        distance=min(merge.distance + 3 * params.distance, 1.0),
        angle_deg=min(merge.angle_deg + turn_deg + 1e-6, 90.0),
        gap=min(merge.gap + 3 * params.distance, 1.0),
    )


def drawn_turn(params: CornerParams, length: NDArray[np.float64]) -> NDArray[np.float64]:
    """The most (degrees) corners may turn lines of these lengths (m) from their fits as drawn (with
    ``drawn_apart``): both ends moved across by up to three corner distances (a corner's ends lie each within the
    corner distance of another, most often two of them). One end moved turns a line less, and never by more than
    :data:`TURN_SHARE` of the corner angle (a corner that would drops the end it turns most, whatever else it
    finds)."""
    return np.degrees(np.arcsin(np.minimum(6 * params.distance / np.maximum(length, 1e-12), 1.0)))


def drawn_reach(params: CornerParams, merge: MergeParams) -> float:
    """How far (m) from a line as drawn another line's fit may lie that a corner could draw related to it (with
    ``drawn_apart``): merging's reach (its gap and distance), and three corner distances for the moves of the
    ends of both (a corner's ends lie each within the corner distance of another, most often two of them)."""
    return float(np.hypot(merge.gap, merge.distance)) + 3 * params.distance


def _clusters(
    ends: NDArray[np.float64], e1: NDArray[np.intp], e2: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The ends that meet at corners (sorted) and the cluster of every end: the connected sets of linked ends
    ``e1``-``e2``, at most one end of a line in each (the one nearest the cluster's centroid)."""
    comp = component_labels(len(ends), e1, e2)
    member = np.flatnonzero(np.bincount(comp)[comp] > 1)
    groups, cm = np.unique(comp[member], return_inverse=True)
    centroid = _group_mean(ends[member], cm, groups.size)
    dist = np.hypot(*(ends[member] - centroid[cm]).T)
    order = np.lexsort((dist, member // 2, cm))
    keep = np.ones(order.size, dtype=bool)  # the first end of each (corner, line)
    keep[1:] = (np.diff(cm[order]) != 0) | (np.diff(member[order] // 2) != 0)
    return np.sort(member[order[keep]]), comp


def _folded(
    ends: NDArray[np.float64],
    member: NDArray[np.intp],
    comp: NDArray[np.intp],
    u: NDArray[np.float64],
    cos_max: float,
    apart: tuple[MergeParams, NDArray[np.float64], NDArray[np.float64]] | None,
    fixed: NDArray[np.float64] | None = None,
) -> NDArray[np.intp]:
    """One end of each corner whose lines, drawn from it (at the centroid of its ``member`` ends) to their other
    ends, come within the corner angle of parallel (``cos_max``), or one of which is drawn turned from its own
    direction ``u`` by more than :data:`TURN_SHARE` of the corner angle, or (``apart``: merging's tolerances and
    every line's ends p, q, the corners' lines first) related to another line; with ``apart``, also with each
    line drawn to its other end where that end's own corner puts it: the end of the line the corner turns most.
    A line drawn to no length turns most."""
    cos_turn = np.cos(TURN_SHARE * np.arccos(min(cos_max, 1.0)))
    _, corner = np.unique(comp[member], return_inverse=True)
    xy = _group_mean(ends[member], corner, corner.max(initial=-1) + 1)
    drawn = ends[member ^ 1] - xy[corner]
    length = np.hypot(*drawn.T)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = drawn / length[:, None]
    along = np.sum(w * u[member // 2], axis=1) * np.where(member % 2, -1, 1)  # drawn from end p toward q: +u
    turn = np.where(length > 0, 1 - along, np.inf)
    order = np.argsort(corner, kind="stable")  # a corner's ends in a row
    bad = ~(along >= cos_turn - 2 * _EPS)  # turned by more than its share (a line drawn to no length too)
    directions = [w]
    if apart is not None:  # drawn related to another line as fitted (a piece of the same wall)
        of = np.full(len(ends), -1)
        of[member] = np.arange(len(member))
        partner = of[member ^ 1]  # the row of the line's other end where it meets a corner, else -1
        move = np.hypot(*(xy[corner] - ends[member]).T)
        far, far_move, placed = ends[member ^ 1].copy(), np.zeros(len(member)), partner >= 0
        far[placed], far_move[placed] = xy[corner[partner[placed]]], move[partner[placed]]
        if fixed is not None:  # the other end stands on a point that stays: drawn to it there
            there = fixed[member ^ 1]
            kept = ~np.isnan(there[:, 0])
            far[kept], far_move[kept] = there[kept], np.hypot(*(there[kept] - ends[member[kept] ^ 1]).T)
            placed |= kept
        both = far - xy[corner]
        with np.errstate(invalid="ignore", divide="ignore"):
            directions.append(both / np.hypot(*both.T)[:, None])
        for other_end, one in ((ends[member ^ 1], False), (far, True)):
            rows = np.flatnonzero((length > 0) & placed & np.any(both != 0, axis=1) if one else length > 0)
            at = np.where((member[rows] % 2 == 0)[:, None], xy[corner[rows]], other_end[rows])  # end 0 first
            to = np.where((member[rows] % 2 == 1)[:, None], xy[corner[rows]], other_end[rows])
            a, b, _ = related_pairs(at, to, apart[0], (apart[1], apart[2]))
            hit = rows[a[b != member[rows[a]] // 2]]
            if one:  # drawn between its two corners: the end moved farther (end 0 if as far)
                mine, theirs = move[hit], far_move[hit]
                hit = hit[(mine > theirs) | ((mine == theirs) & (member[hit] % 2 == 0))]
            bad[hit] = True
    for step in range(1, len(order)):
        a, b = order[:-step], order[step:]
        same = corner[a] == corner[b]
        if not same.any():
            break
        for d in directions:  # a line drawn to no length is close
            close = same & ~(np.abs(np.sum(d[a] * d[b], axis=1)) <= cos_max)
            bad[a[close]] = bad[b[close]] = True
    folded = np.flatnonzero(bad)
    first = np.lexsort((-turn[folded], corner[folded]))
    take = np.ones(len(first), dtype=bool)
    take[1:] = np.diff(corner[folded][first]) != 0
    return member[folded[first[take]]]


def _group_mean(x: NDArray[np.float64], g: NDArray[np.intp], k: int) -> NDArray[np.float64]:
    count = np.bincount(g, minlength=k)
    return np.stack([np.bincount(g, x[:, i], minlength=k) for i in (0, 1)], axis=1) / count[:, None]


def _shapes(
    ends: NDArray[np.float64],
    member: NDArray[np.intp],
    corner: NDArray[np.intp],
    xy: NDArray[np.float64],
    viewpoint: ArrayLike | None,
) -> NDArray[np.str_]:
    """Concave or convex from the viewpoint: the width of the sector round each corner holding it."""
    k = len(xy)
    if viewpoint is None:
        return np.full(k, "unknown")
    v = np.asarray(viewpoint, dtype=float)
    if v.shape[-1:] != (2,) or v.ndim > 2 or not len(v) or not np.isfinite(v).all():
        raise ValueError(f"viewpoint must be a finite (x, y) pair or (M, 2) of them: got {viewpoint!r}")
    if v.ndim == 2:  # each corner seen from the nearest
        v = v[cKDTree(v).query(xy)[1]] if k else v[:0]
    w = v - xy
    out = ends[member ^ 1] - xy[corner]  # each line's other end: its outward direction
    # Angle of each line counter-clockwise from the viewpoint's direction, in [0, 2 pi).
    rel = np.mod(np.arctan2(out[:, 1], out[:, 0]) - np.arctan2(w[corner, 1], w[corner, 0]), 2 * np.pi)
    first_ccw = np.full(k, np.inf)
    first_cw = np.full(k, -np.inf)
    np.minimum.at(first_ccw, corner, rel)
    np.maximum.at(first_cw, corner, rel)
    width = first_ccw + 2 * np.pi - first_cw
    shape = np.where(width < np.pi, "concave", "convex")
    shape[(w == 0).all(axis=1)] = "unknown"
    return shape
