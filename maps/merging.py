"""Merging of collinear line segments into fewer, longer lines (paper, section III).

The LSL sees a wall as a series of short pieces (small camera field of view,
overlapping snapshots). Two lines are *related* when their directions differ by
at most ``angle_deg`` (undirected lines), both end points of the shorter lie
within ``distance`` of the longer one's infinite line, and the gap between them
along the longer one's direction is at most ``gap`` (overlapping: gap 0).

A member's *offset* from a line is the root mean square distance of its points
(uniformly dense, as in the refit below): ``sqrt((e1**2 + e1 e2 + e2**2) / 3)``
for signed end distances ``e1``, ``e2`` (a long member a fraction of a degree
off stays within ``distance`` where its ends part by more). Its *turn
allowance* is ``angle_deg``, or ``asin(distance / length)`` when larger (below
29 cm at the defaults): a short piece's direction is its least certain part (a
10 cm piece with 1 cm noise gives it to about 10 degrees).

Procedure, repeated until a round merges nothing:

1. Candidate pairs: related pairs, but the shorter line's direction within its
   turn allowance (at most :data:`TURN_CAP` times ``angle_deg``) of the longer
   one's. A spatial index (``shapely.STRtree``: boxes within ``hypot(gap,
   distance)``, a bound every candidate pair meets) gives a superset, tested
   with numpy.
2. The connected components of the candidate pairs are the proposed groups,
   refitted (below) from their *input* segments; a group is accepted only if
   every member's offset from the refitted line is within ``distance`` and its
   direction within its turn allowance (a gently curving wall's chain of
   pairs does not make a line that no longer fits its pieces).
3. A rejected group is rebuilt agglomeratively (Kruskal): its candidate pairs
   by increasing cost (the larger distance of the shorter line's ends from the
   longer line, plus the gap), two sets joined when their union passes the
   same member check.

A merged line can merge again in the next round: the result is a fixed point
(no two output lines are candidates and mergeable); every round removes a line
or ends the loop.

The refit is total least squares through the members taken as continuous,
uniformly dense point sets (the limit of sampling points evenly along each
member, so a member weighs by its length): centroid ``c = sum(l_k m_k) / sum(l_k)``
and scatter ``S = sum(l_k ((m_k - c)(m_k - c)^T + d_k d_k^T / 12))`` for members of
length ``l_k``, midpoint ``m_k`` and vector ``d_k = q_k - p_k``; the line's
direction is the principal axis of ``S``. Its extent is the span of the
members' end-point projections on it, and it points the way its longest member
points. A line that merged with nothing is returned unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from evmap.sources.clusters import component_labels
from evmap.sources.params import MergeParams

__all__ = ["Merged", "check_segments", "merge_segments", "related_pairs"]

# Slack on every tolerance test, so that a value exactly at the tolerance
# (5 cm, 10 deg) passes despite rounding.
_EPS = 1e-9

TURN_CAP = 1.5
"""A candidate pair's shorter line turns at most this many times ``angle_deg``: uncapped, pieces of a few
centimetres across a corner or a pillar's facet joined the line they cross (docs/METHOD.md)."""


@dataclass(frozen=True, eq=False)
class Merged:
    """Lines after merging, and which input segments make each of them.

    Attributes
    ----------
    p, q : (M, 2) float arrays, the end points of the merged lines.
    groups : list of M sorted int arrays, the input indices of each line's members.
        Lines are ordered by their smallest member index.
    line_of : (N,) int array, the merged line of each input segment.
    """

    p: NDArray[np.float64]
    q: NDArray[np.float64]
    groups: list[NDArray[np.intp]]
    line_of: NDArray[np.intp]


def check_segments(p: ArrayLike, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Segments' end points as two float (N, 2) arrays, or a ValueError.

    Examples
    --------
    >>> p, q = check_segments([[0, 0]], [[1, 0]])
    >>> p.dtype, q.shape
    (dtype('float64'), (1, 2))
    >>> check_segments([[0, 0]], [[0, 0]])
    Traceback (most recent call last):
    ...
    ValueError: segments must have positive length: segment 0 has p == q == [0.0, 0.0]
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.size == 0 and q.size == 0:
        return p.reshape(0, 2), q.reshape(0, 2)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape != q.shape:
        raise ValueError(f"p and q must both have shape (N, 2): got {p.shape} and {q.shape}")
    if not (np.isfinite(p).all() and np.isfinite(q).all()):
        raise ValueError("p and q must be finite: found NaN or infinity")
    same = np.flatnonzero((p == q).all(axis=1))
    if same.size:
        i = same[0]
        raise ValueError(f"segments must have positive length: segment {i} has p == q == {p[i].tolist()}")
    return p, q


def merge_segments(
    p: ArrayLike, q: ArrayLike, params: MergeParams | None = None, weights: ArrayLike | None = None
) -> Merged:
    """Merge collinear segments until nothing merges (see the module docstring): the lines, their member groups
    and the line of each input.

    Parameters
    ----------
    p, q : (N, 2) end points of the segments (metres).
    params : the tolerances; ``MergeParams()`` (5 cm, 10 deg, 5 cm) if omitted.
    weights : (N,) how many observations each segment stands for (default 1 each):
        in the refit a segment weighs its length times its weight (a line's
        consolidated support, seen from many poses, weighs as they all would).

    Examples
    --------
    Two overlapping pieces of the wall y = 0 and a wall 10 cm away:

    >>> m = merge_segments([[0, 0], [0.8, 0], [0, 0.1]], [[1, 0], [2, 0], [1, 0.1]])
    >>> m.line_of.tolist(), [g.tolist() for g in m.groups]
    ([0, 0, 1], [[0, 1], [2]])
    >>> np.round(m.p, 6).tolist(), np.round(m.q, 6).tolist()
    ([[0.0, 0.0], [0.0, 0.1]], [[2.0, 0.0], [1.0, 0.1]])
    """
    params = MergeParams() if params is None else params
    p, q = check_segments(p, q)
    w = np.ones(len(p)) if weights is None else np.asarray(weights, dtype=float).reshape(len(p))
    labels = np.arange(len(p))  # current line of each input segment
    lp, lq = p, q
    while len(p):
        a, b, cost = related_pairs(lp, lq, params, mergeable=True)
        if a.size == 0:
            break
        new = _group_lines(p, q, w, labels, len(lp), a, b, cost, params)
        if new.max() + 1 == len(lp):
            break
        labels = new[labels]
        lp, lq = _refit(p, q, w, labels, params)
    # Number the lines in the order of their smallest member.
    _, first = np.unique(labels, return_index=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    labels = rank[labels]
    lp, lq = lp[order], lq[order]
    return Merged(p=lp, q=lq, groups=_members(labels), line_of=labels)


def _members(labels: NDArray[np.intp]) -> list[NDArray[np.intp]]:
    """Sorted indices of each label's members (labels 0..k-1, each used)."""
    order = np.argsort(labels, kind="stable")
    bounds = np.r_[0, np.cumsum(np.bincount(labels))].tolist() if labels.size else [0]
    return [order[lo:hi] for lo, hi in pairwise(bounds)]


def related_pairs(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    params: MergeParams,
    others: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    *,
    mergeable: bool = False,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """Pairs of related lines (see the module doc), or with ``mergeable`` merging's candidate pairs, and the cost
    of merging each pair.

    The pairs (a, b), a < b, among the lines p-q; or, given ``others`` (their
    ends op, oq), the pairs of a line p[a]-q[a] and a line op[b]-oq[b].

    >>> related_pairs(np.array([[0.0, 0.0], [1.02, 0.01]]), np.array([[1.0, 0.0], [2.0, 0.0]]), MergeParams())[:2]
    (array([0]), array([1]))
    >>> far = np.array([[5.0, 0.0]]), np.array([[6.0, 0.0]])
    >>> related_pairs(np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]]), MergeParams(), far)[:2]
    (array([], dtype=int64), array([], dtype=int64))
    """
    reach = np.hypot(params.gap, params.distance) + _EPS
    op, oq = (p, q) if others is None else others
    lo, hi = np.minimum(p, q) - reach, np.maximum(p, q) + reach
    tree = shapely.STRtree(shapely.linestrings(np.stack([op, oq], axis=1)))
    a, b = tree.query(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))  # boxes meeting: a superset, cheap
    if others is None:
        keep = a < b
        a, b = a[keep], b[keep]
    return _relation(p, q, op, oq, a, b, params, mergeable)


def _relation(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    op: NDArray[np.float64],
    oq: NDArray[np.float64],
    a: NDArray[np.intp],
    b: NDArray[np.intp],
    params: MergeParams,
    mergeable: bool,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """The candidate pairs (p[a]-q[a], op[b]-oq[b]) that are related (or, ``mergeable``, merging's candidates), and
    their costs; one coordinate at a time in flat arrays, the longer and the shorter line picked by np.where."""
    px, py, qx, qy = (np.take(xy[:, i], a) for xy in (p, q) for i in (0, 1))
    ox, oy, rx, ry = (np.take(xy[:, i], b) for xy in (op, oq) for i in (0, 1))
    dx, dy, odx, ody = qx - px, qy - py, rx - ox, ry - oy
    length, other = np.hypot(dx, dy), np.hypot(odx, ody)
    longer = other > length  # the pair's second line is the longer
    ulx, uly = np.where(longer, odx / other, dx / length), np.where(longer, ody / other, dy / length)
    usx, usy = np.where(longer, dx / length, odx / other), np.where(longer, dy / length, ody / other)
    plx, ply = np.where(longer, ox, px), np.where(longer, oy, py)
    ll, ls = np.where(longer, other, length), np.where(longer, length, other)
    rpx, rpy = np.where(longer, px, ox) - plx, np.where(longer, py, oy) - ply  # the shorter's ends from pl
    rqx, rqy = np.where(longer, qx, rx) - plx, np.where(longer, qy, ry) - ply
    off = np.maximum(np.abs(ulx * rpy - uly * rpx), np.abs(ulx * rqy - uly * rqx))
    turn = float(params.angle_deg)
    if mergeable:  # the shorter line's turn allowance (module doc), capped
        allowance = np.degrees(np.arcsin(np.minimum(params.distance / ls, 1.0)))
        turn = np.clip(allowance, params.angle_deg, TURN_CAP * params.angle_deg)
    tp, tq = ulx * rpx + uly * rpy, ulx * rqx + uly * rqy  # the shorter's ends along the longer, on [0, length]
    gap = np.maximum(np.maximum(np.minimum(tp, tq) - ll, -np.maximum(tp, tq)), 0.0)
    ok = (
        (np.abs(ulx * usx + uly * usy) >= np.cos(np.radians(turn)) - _EPS)
        & (off <= params.distance + _EPS)
        & (gap <= params.gap + _EPS)
    )
    return a[ok], b[ok], (off + gap)[ok]


def _offset(e1: NDArray[np.float64], e2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Root mean square distance from a line of segments' points (uniformly dense) whose ends are ``e1`` and
    ``e2`` off it (signed)."""
    return np.sqrt((e1**2 + e1 * e2 + e2**2) / 3)


def _group_lines(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    w: NDArray[np.float64],
    labels: NDArray[np.intp],
    m: int,
    a: NDArray[np.intp],
    b: NDArray[np.intp],
    cost: NDArray[np.float64],
    params: MergeParams,
) -> NDArray[np.intp]:
    """New line of each of the m current lines: checked components of the candidate pairs."""
    comp = component_labels(m, a, b)
    group = comp[labels]  # proposed group of each input
    _, _, fits = _fit(p, q, w, group, comp.max() + 1, params)
    bad = np.flatnonzero(~fits)
    if bad.size == 0:
        return comp
    next_id = comp.max() + 1
    # Inputs of the rejected groups, by group then by current line.
    idx = np.flatnonzero(~fits[group])
    idx = idx[np.lexsort((labels[idx], group[idx]))]
    bounds = np.searchsorted(group[idx], np.r_[bad, bad[-1] + 1])
    for c, lo, hi in zip(bad, bounds[:-1], bounds[1:]):
        sel = (comp[a] == c) & (comp[b] == c)
        for root_set in _kruskal(p, q, w, idx[lo:hi], labels[idx[lo:hi]], a[sel], b[sel], cost[sel], params):
            comp[root_set] = next_id
            next_id += 1
    _, comp = np.unique(comp, return_inverse=True)
    return comp


def _kruskal(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    w: NDArray[np.float64],
    idx: NDArray[np.intp],
    line: NDArray[np.intp],
    a: NDArray[np.intp],
    b: NDArray[np.intp],
    cost: NDArray[np.float64],
    params: MergeParams,
) -> list[NDArray[np.intp]]:
    """Sets of current lines joined cheapest pair first, each union passing the member check.

    ``idx`` are the input segments of one group, sorted by ``line``, their current
    lines; ``a``, ``b`` the candidate pairs of lines. A set carries the moments of
    its inputs, so a union's line costs O(1); the check is O(size).
    """
    nodes, owner = np.unique(line, return_inverse=True)
    origin = p[idx[0]]  # moments about a nearby point: no cancellation
    pv, qv = p[idx] - origin, q[idx] - origin
    d, mid = qv - pv, (pv + qv) / 2
    length = np.hypot(d[:, 0], d[:, 1])
    weight = length * w[idx]
    terms = (
        np.ones_like(length),
        mid[:, 0],
        mid[:, 1],
        mid[:, 0] ** 2 + d[:, 0] ** 2 / 12,
        mid[:, 1] ** 2 + d[:, 1] ** 2 / 12,
        mid[:, 0] * mid[:, 1] + d[:, 0] * d[:, 1] / 12,
    )
    moments = np.stack([np.bincount(owner, weight * t, minlength=nodes.size) for t in terms], axis=1)
    rows = np.column_stack([pv, qv, length]).tolist()
    bounds = np.r_[0, np.cumsum(np.bincount(owner, minlength=nodes.size))].tolist()
    sets = {  # root -> (moments, rows (px, py, qx, qy, length) of its inputs, its current lines)
        v: (m, rows[lo:hi], [v]) for v, m, lo, hi in zip(nodes.tolist(), moments.tolist(), bounds[:-1], bounds[1:])
    }
    parent = {v: v for v in sets}

    def find(v: int) -> int:
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    cos_tol = np.cos(np.radians(params.angle_deg)) - _EPS
    for k in np.lexsort((b, a, cost)).tolist():
        ra, rb = find(int(a[k])), find(int(b[k]))
        if ra == rb:
            continue
        moments = [x + y for x, y in zip(sets[ra][0], sets[rb][0])]
        rows = sets[ra][1] + sets[rb][1]
        if _fits_one_line(moments, rows, cos_tol, params.distance + _EPS):
            parent[rb] = ra
            sets[ra] = (moments, rows, sets[ra][2] + sets.pop(rb)[2])
    return [np.array(lines) for _, _, lines in sets.values()]


def _fits_one_line(moments: list[float], rows: list[list[float]], cos_tol: float, distance: float) -> bool:
    """``_fit``'s check for one group, from its moments: every member within the tolerances."""
    w, sx, sy, sxx, syy, sxy = moments
    cx, cy = sx / w, sy / w
    phi = 0.5 * math.atan2(2 * (sxy / w - cx * cy), (sxx / w - cx * cx) - (syy / w - cy * cy))
    ux, uy = math.cos(phi), math.sin(phi)
    for px, py, qx, qy, length in rows:
        e1, e2 = uy * (px - cx) - ux * (py - cy), uy * (qx - cx) - ux * (qy - cy)  # signed end distances
        along = min(cos_tol * length, math.sqrt(max(length**2 - distance**2, 0)))  # the turn allowance
        if abs((qx - px) * ux + (qy - py) * uy) < along or e1 * e1 + e1 * e2 + e2 * e2 > 3 * distance**2:
            return False
    return True


def _fit(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    weights: NDArray[np.float64],
    g: NDArray[np.intp],
    k: int,
    params: MergeParams,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Total least squares line of each of k groups of segments (g: group of each).

    Returns the centroids (k, 2), unit directions (k, 2) and whether every member
    of the group lies within the tolerances of its line.
    """
    d = q - p
    length = np.hypot(d[:, 0], d[:, 1])
    weight = length * weights
    mid = (p + q) / 2
    w = np.bincount(g, weight, minlength=k)
    c = np.stack([np.bincount(g, weight * mid[:, i], minlength=k) for i in (0, 1)], axis=1) / w[:, None]
    rel = mid - c[g]
    # S = sum(l ((m - c)(m - c)^T + d d^T / 12)): second moment of a uniform segment.
    sxx, syy, sxy = (
        np.bincount(g, weight * (rel[:, i] * rel[:, j] + d[:, i] * d[:, j] / 12), minlength=k)
        for i, j in ((0, 0), (1, 1), (0, 1))
    )
    phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    u = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    ug, cg = u[g], c[g]
    off = _offset(_cross(ug, p - cg), _cross(ug, q - cg))
    cos_tol = np.cos(np.radians(params.angle_deg)) - _EPS
    along = np.minimum(cos_tol * length, np.sqrt(np.maximum(length**2 - params.distance**2, 0.0)))  # turn allowance
    ok = (np.abs(_dot(ug, d)) >= along) & (off <= params.distance + _EPS)
    return c, u, np.bincount(g, ~ok, minlength=k) == 0


def _refit(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    w: NDArray[np.float64],
    labels: NDArray[np.intp],
    params: MergeParams,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """End points of the line of each label: refitted groups, singletons unchanged."""
    k = labels.max() + 1
    c, u, _ = _fit(p, q, w, labels, k, params)
    d = q - p
    length = np.hypot(d[:, 0], d[:, 1])
    by_label = np.lexsort((-length, labels))
    longest = by_label[np.r_[0, np.flatnonzero(np.diff(labels[by_label])) + 1]]
    u *= np.where(_dot(u, d[longest]) < 0, -1.0, 1.0)[:, None]  # the way the longest member points
    ug, cg = u[labels], c[labels]
    tp, tq = _dot(ug, p - cg), _dot(ug, q - cg)
    tmin = np.full(k, np.inf)
    tmax = np.full(k, -np.inf)
    np.minimum.at(tmin, labels, np.minimum(tp, tq))
    np.maximum.at(tmax, labels, np.maximum(tp, tq))
    lp, lq = c + tmin[:, None] * u, c + tmax[:, None] * u
    single = np.bincount(labels, minlength=k) == 1
    lp[labels[single[labels]]] = p[single[labels]]
    lq[labels[single[labels]]] = q[single[labels]]
    return lp, lq


def _cross(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _dot(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    return u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1]
