"""Lines through groups of segments: merging's refit and member check (:mod:`evmap.maps.merging`, its module doc).

:func:`group_lines` joins current lines along candidate pairs where every member fits the group's refitted
line (each member within ``distance`` by its offset and within its turn allowance), rebuilding a group that
does not agglomeratively; :func:`refit_groups` gives each group's line, total least squares through its
members taken as uniformly dense point sets, each weighing its length times its weight.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from evmap.sources.clusters import component_labels
from evmap.sources.params import MergeParams

__all__ = ["group_lines", "refit_groups"]

# Slack on every tolerance test, as in merging: a value exactly at the tolerance passes despite rounding.
_EPS = 1e-9


def _offset(e1: NDArray[np.float64], e2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Root mean square distance from a line of segments' points (uniformly dense) whose ends are ``e1`` and
    ``e2`` off it (signed)."""
    return np.sqrt((e1**2 + e1 * e2 + e2**2) / 3)


def group_lines(
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
    """New line of each of the m current lines (the lines of the input segments, ``labels``), from the candidate
    pairs ``a``-``b`` of those lines and their costs: the connected components whose members all fit their
    refitted line, the others rebuilt cheapest pair first (steps 2 and 3 of :mod:`evmap.maps.merging`)."""
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


def refit_groups(
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
