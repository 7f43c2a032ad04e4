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

4. At a fixed point of 1-3, the lines still related (the paper's pair rule:
   a related pair is one wall) are grouped and checked as in 2 and 3, each
   *line* taken as one member (its fitted segment, weighing what its members
   weigh); a group that passes is refitted from all its members. So a line of
   short pieces each turned across a wall, which together lie along it (the
   laser's zig-zag on a wall, a slanted piece beside it), joins the wall where
   it fits the union as a whole, though its pieces alone are beyond their
   turn allowance. Then 1-3 again.

A merged line can merge again in the next round: the result is a fixed point
(no two output lines are candidates and mergeable, nor related and fitting their
union as lines); every round removes a line or ends the loop.

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

from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from evmap.maps.group_fit import group_lines, refit_groups
from evmap.sources.geometry import boxes_meet
from evmap.sources.params import MergeParams

__all__ = ["Merged", "check_segments", "merge_segments", "related_pairs"]

# Slack on every tolerance test, so that a value exactly at the tolerance
# (5 cm, 10 deg) passes despite rounding.
_EPS = 1e-9

TURN_CAP = 1.5
"""A candidate pair's shorter line turns at most this many times ``angle_deg``: uncapped, pieces of a few
centimetres across a corner or a pillar's facet joined the line they cross (docs/METHOD.md)."""

DENSE_PAIRS = 4096
""":func:`related_pairs` of at most this many (line, line) pairs tests their boxes all at once, more through a
spatial index (most calls pair a few lines near a change: building an index costs more than the tests)."""


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
        new = group_lines(p, q, w, labels, len(lp), a, b, cost, params) if a.size else None
        if new is None or new.max() + 1 == len(lp):  # a fixed point of steps 1-3
            new = _related_joined(p, q, w, labels, lp, lq, params)
            if new is None:
                break
        labels = new[labels]
        lp, lq = refit_groups(p, q, w, labels, params)
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
    if len(p) * len(op) <= DENSE_PAIRS:  # boxes meeting: a superset, cheap
        a, b = np.nonzero(boxes_meet(lo[:, None], hi[:, None], np.minimum(op, oq), np.maximum(op, oq)))
    else:
        tree = shapely.STRtree(shapely.linestrings(np.stack([op, oq], axis=1)))
        a, b = tree.query(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))
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


def _related_joined(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    w: NDArray[np.float64],
    labels: NDArray[np.intp],
    lp: NDArray[np.float64],
    lq: NDArray[np.float64],
    params: MergeParams,
) -> NDArray[np.intp] | None:
    """Step 4 (module doc): the new line of each current line lp-lq, its related lines grouped and checked with
    each line as one member (weighing what its members weigh); None if no two join."""
    a, b, cost = related_pairs(lp, lq, params)
    if a.size == 0:
        return None
    weight = np.bincount(labels, np.hypot(*(q - p).T) * w, minlength=len(lp)) / np.hypot(*(lq - lp).T)
    new = group_lines(lp, lq, weight, np.arange(len(lp)), len(lp), a, b, cost, params)
    return None if new.max() + 1 == len(lp) else new
