"""Refits in place: merged lines that only move a line of the map, found before the rebuild dissolves it.

A rebuild (:mod:`evmap.maps.rebuild`) dissolves the lines near a change and
merges their segments again; a merged line made of one map line's members (and
new segments of no line), close to it in direction and ends, whose ends can
follow without any corner changing, refits that line in place instead
(:func:`refits`): the line keeps its id and points, which move onto the new fit
(:func:`end_moves`). The ends near the refitted lines are found by one small
query per end (:func:`~evmap.maps.near_ends.surface_points_near`) and tested all at once by numpy; with
``corners.drawn_apart``, :func:`~evmap.maps.redrawn.redrawn_refits` keeps out the refits that would redraw a
corner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.corners import TURN_SHARE
from evmap.maps.merging import Merged
from evmap.maps.near_ends import surface_points_near
from evmap.maps.redrawn import redrawn_refits
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["NearEnds", "end_moves", "refits", "unmoved"]


def unmoved(
    bm: BeliefMap, pool: NDArray[np.intp], merged: Merged, dissolved: dict[str, tuple[str, str]]
) -> dict[int, str]:
    """The merged lines that are a line of the map as it stands (merged line -> that line): made of exactly
    that line's members, ends exactly at its fit's (either way round).

    Merging the same members gives the same line, so such a line need not be dissolved: its ends, corners
    and neighbours stay as they are (a rebuild near a corner of many short lines would otherwise take it
    apart again at every scan); only its noise-elimination evidence is taken anew.
    """
    g = bm.graph
    line = bm.segments.line[pool].tolist()
    rows = pool.tolist()
    found: dict[int, str] = {}
    for k, (group, p, q) in enumerate(zip(merged.groups, merged.p.tolist(), merged.q.tolist(), strict=True)):
        lid = line[group[0]]
        if lid not in dissolved or any(line[i] != lid for i in group.tolist()):
            continue
        data = g.edge(*dissolved[lid])
        fit, members = data["fit"], data["members"]
        same_rows = len(members) == len(group) and set(members) == {rows[i] for i in group.tolist()}
        if same_rows and [p, q] in (fit, fit[::-1]):
            found[k] = lid
    return found


def refits(
    bm: BeliefMap,
    pool: NDArray[np.intp],
    merged: Merged,
    dissolved: dict[str, tuple[str, str]],
    config: Config,
    *,
    join: bool,
) -> tuple[dict[int, str], dict[str, NDArray[np.float64]], NearEnds]:
    """The merged lines that only refit a line of the map (merged line -> the line it refits), the new
    fit of each such line (its ends in the order of the line's end points), and the line ends near them
    (for :func:`end_moves`).

    A merged line refits the map's line L when its members are all of L's
    members and segments of no line, its direction is within ``angle_deg`` of
    L's fit and its ends within ``min(merge distance, corner distance / 2)`` of
    L's, and each end of L can follow without the corners changing
    (:func:`end_moves`): a free end point meeting no other line's end, or a
    corner whose lines' ends still form one cluster as corners link ends, with no
    other end joining (the corner moves to the new centroid of the ends: the
    midpoint for two lines), and none meets, as the map stands, an end not at
    its point (one the corners' rules left out of a corner: leaving, it could
    let that corner be found), and, with ``drawn_apart``, no corner near would then draw a line related to another
    line as fitted, nor has a line near a free end that links with another's. L then stays in place, moved onto the
    merged line (by the rebuild), as a whole rebuild would find it. A rebuild
    that does not ``join`` ends into corners refits the lines with two free ends.
    """
    store = bm.segments
    g = bm.graph
    cos_tol = np.cos(np.radians(config.merge.angle_deg))
    move = min(config.merge.distance, config.corners.distance / 2)
    fits: dict[str, NDArray[np.float64]] = {}
    lines_of: dict[str, int] = {}
    line = store.line[pool].tolist()
    for k, (group, p, q) in enumerate(zip(merged.groups, merged.p.tolist(), merged.q.tolist(), strict=True)):
        owners = {line[i] for i in group.tolist()} - {""}
        if len(owners) != 1 or not owners <= dissolved.keys():
            continue
        (lid,) = owners
        data = g.edge(*dissolved[lid])
        if not set(data["members"]) <= set(pool[group].tolist()):
            continue
        a, b = data["fit"]  # plain floats: a handful of numbers per line
        if max(math.dist(p, b), math.dist(q, a)) < max(math.dist(p, a), math.dist(q, b)):
            p, q = q, p
        u, v = (b[0] - a[0], b[1] - a[1]), (q[0] - p[0], q[1] - p[1])
        cos = abs(u[0] * v[0] + u[1] * v[1]) / (math.hypot(*u) * math.hypot(*v))
        if max(math.dist(p, a), math.dist(q, b)) <= move and cos >= cos_tol:
            fits[lid], lines_of[lid] = np.array([p, q]), k
    if not join:  # no ends meet: a line with two free ends follows its new fit
        fits = {lid: fit for lid, fit in fits.items() if all(g.degree(n) == 1 for n in bm.ends(lid))}
    if not fits or not join:
        return {lines_of[lid]: lid for lid in fits}, fits, _NO_ENDS
    ends = np.concatenate(list(fits.values()))
    points = surface_points_near(bm, ends, 3 * config.corners.distance + move)
    neighbours = [(d["id"], n) for n in points for d in g.adj[n].values()]
    stored = np.array([g.edge(*bm.ends(m))["fit"] for m, _ in neighbours], dtype=float).reshape(-1, 2, 2)
    end = np.array([bm.ends(m).index(n) for m, n in neighbours], dtype=np.intp)
    rows: dict[str, list[int]] = {}
    for i, (m, _) in enumerate(neighbours):
        rows.setdefault(m, []).append(i)

    def near_ends(fits: dict[str, NDArray[np.float64]]) -> NearEnds:
        lines = stored.copy()
        for lid, fit in fits.items():
            lines[rows.get(lid, [])] = fit
        d = lines[:, 1] - lines[:, 0]
        at = np.arange(len(end))
        return NearEnds(neighbours, lines[at, end], lines[at, 1 - end], d / np.hypot(*d.T)[:, None])

    # an end that meets, as the map stands, an end not at its point was left out of a corner by the corners'
    # rules (drawn apart, one end of a line): leaving there could change that corner, so its line is rebuilt
    was = {lid: np.array(g.edge(*bm.ends(lid))["fit"], dtype=float) for lid in fits}
    for lid, move in end_moves(bm, was, near_ends({}), config).items():
        if move is None:
            del fits[lid]
    while fits:  # a line follows its new fit only if the lines its ends meet can follow theirs
        near = near_ends(fits)
        moves = end_moves(bm, fits, near, config)
        failed = {lid for lid, move in moves.items() if move is None}
        if config.corners.drawn_apart and not failed:
            failed = redrawn_refits(bm, fits, moves, config)
        if not failed:
            return {lines_of[lid]: lid for lid in fits}, fits, near
        for lid in failed:
            del fits[lid]
    return {}, fits, _NO_ENDS


@dataclass(frozen=True)
class NearEnds:
    """The (line, point) pairs near refitted lines, the fit end of each line at its point and its other fit
    end, each line's unit direction (refitted lines with their new fits)."""

    pairs: list[tuple[str, str]]
    ends: NDArray[np.float64]
    far: NDArray[np.float64]
    u: NDArray[np.float64]


_NO_ENDS = NearEnds([], np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2)))


def end_moves(
    bm: BeliefMap, fits: dict[str, NDArray[np.float64]], near: NearEnds, config: Config
) -> dict[str, list[tuple[str, tuple[float, float]]] | None]:
    """Where the end points of each line of ``fits`` go when the lines take their new fits: a free end onto
    its fit end, a corner to the centroid of its lines' fit ends; None for a line whose corners would change
    (an end meeting an end of ``near`` not at its point, or the corner's ends no longer one cluster).
    """
    g = bm.graph
    cos_max = np.cos(np.radians(config.corners.min_angle_deg)) + 1e-9
    reach = config.corners.distance + 1e-9
    lids = list(fits)
    own = np.array([fits[lid] for lid in lids], dtype=float).reshape(-1, 2, 2)
    u = own[:, 1] - own[:, 0]
    u /= np.hypot(*u.T)[:, None]
    ends = own.reshape(-1, 2)  # line k's end e is row 2k + e
    dist = np.hypot(*(ends[:, None, :] - near.ends[None, :, :]).transpose(2, 0, 1))
    across = np.abs(np.repeat(u, 2, axis=0) @ near.u.T) <= cos_max
    meeting: dict[int, set[int]] = {}  # row of ``ends`` -> the ends of ``near`` it meets
    for row, i in zip(*np.nonzero((dist <= reach) & across), strict=True):
        meeting.setdefault(int(row), set()).add(int(i))
    at: dict[str, list[int]] = {}
    for i, (_, node) in enumerate(near.pairs):
        at.setdefault(node, []).append(i)
    xy = ends.tolist()
    corner_at: dict[str, tuple[float, float] | None] = {}  # each corner's new place, None if it would change
    moves: dict[str, list[tuple[str, tuple[float, float]]] | None] = {}
    for k, lid in enumerate(lids):
        found: list[tuple[str, tuple[float, float]]] | None = []
        for e, node in enumerate(bm.ends(lid)):
            meets = {i for i in meeting.get(2 * k + e, ()) if near.pairs[i][0] != lid}
            kind = g.nodes[node]["kind"]
            if kind == "endpoint" and not meets:
                x, y = xy[2 * k + e]
                found.append((node, (x, y)))
                continue
            if kind == "corner" and meets and meets <= set(at.get(node, ())):
                if node not in corner_at:
                    corner_at[node] = _corner_place(
                        near, at[node], g.degree(node), reach, cos_max, config.corners.drawn_apart
                    )
                if corner_at[node] is not None:
                    found.append((node, corner_at[node]))
                    continue
            found = None
            break
        moves[lid] = found
    return moves


def _corner_place(
    near: NearEnds, rows: list[int], degree: int, reach: float, cos_max: float, drawn_apart: bool
) -> tuple[float, float] | None:
    """The centroid of the ends ``rows`` of ``near`` if they are the ends of all ``degree`` lines of their
    corner, one each, still one single-linkage cluster as corners link ends (within ``reach``, lines at least
    the corner angle from parallel) and, if ``drawn_apart``, drawn from there still that far from parallel
    (:class:`~evmap.sources.params.CornerParams`); else None (the corner would change: it is found anew)."""
    if len(rows) != degree or len({near.pairs[i][0] for i in rows}) != degree:
        return None
    xy, u = near.ends[rows].tolist(), near.u[rows].tolist()  # a handful of ends: plain floats
    reached, frontier = {0}, [0]
    while frontier:  # the cluster grown from the first end
        a = frontier.pop()
        for b in range(degree):
            linked = math.dist(xy[a], xy[b]) <= reach and abs(u[a][0] * u[b][0] + u[a][1] * u[b][1]) <= cos_max
            if b not in reached and linked:
                reached.add(b)
                frontier.append(b)
    if len(reached) < degree:
        return None
    place = sum(x for x, _ in xy) / degree, sum(y for _, y in xy) / degree
    if drawn_apart and _drawn_close(place, xy, near.far[rows].tolist(), cos_max):
        return None
    return place


def _drawn_close(place: tuple[float, float], ends: list[list[float]], far: list[list[float]], cos_max: float) -> bool:
    """Whether two lines drawn from ``place`` to their ``far`` ends come within the corner angle of parallel
    (``cos_max``), or one is drawn turned from its own direction (from its end at the corner, ``ends``, to its far
    end) by more than :data:`~evmap.maps.corners.TURN_SHARE` of that angle, or to no length."""
    drawn = [(x - place[0], y - place[1]) for x, y in far]
    if not all(math.hypot(*d) > 0 for d in drawn):
        return True
    w = [(dx / math.hypot(dx, dy), dy / math.hypot(dx, dy)) for dx, dy in drawn]
    own = [(fx - ex, fy - ey) for (ex, ey), (fx, fy) in zip(ends, far, strict=True)]
    cos_turn = math.cos(TURN_SHARE * math.acos(min(cos_max, 1.0)))
    turned = any((a[0] * o[0] + a[1] * o[1]) / math.hypot(*o) < cos_turn - 2e-9 for a, o in zip(w, own, strict=True))
    return turned or any(abs(a[0] * b[0] + a[1] * b[1]) > cos_max for i, a in enumerate(w) for b in w[i + 1 :])
