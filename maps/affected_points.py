"""The points a rebuild finds anew: those whose corners a whole rebuild of the map could make otherwise.

A rebuild (:mod:`evmap.maps.rebuild`) detaches the lines at these points and finds their corners again; every
other point stays as it is. So the set must hold every point whose corner could change with the lines that
change: the ends of the lines dissolved, the points where an end of a line found anew would link (as corners
link ends: within the corner distance, at least the corner angle from parallel), and, in turn, those where one
would link with an end at a point found anew. A line left free at a corner's end by a rule that looks at its
other end too (two lines meeting at both ends, :func:`~evmap.maps.rebuild.rebuild`) is found anew at both:
the free far end of a line at an affected point is affected where it would link with another line's end, and
so is a point where two lines from affected points end.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.merging import Merged
from evmap.maps.refit import surface_points_near
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["affected_points"]


def affected_points(
    bm: BeliefMap, dissolved: dict[str, tuple[str, str]], merged: Merged, fresh: list[int], config: Config
) -> set[str]:
    """The points whose lines change: the dissolved lines' ends, the points where a line's end would link with an
    end of the ``fresh`` merged lines (those not refitted in place) or of a dissolved line, and, in turn, those
    where one would link with an end found anew at an affected point, the free far ends of the lines at an
    affected point that would link with a line's end, and the points where two such lines end."""
    affected = {n for ends in dissolved.values() for n in ends}
    old = np.array([bm.graph.edge(*ends)["fit"] for ends in dissolved.values()], dtype=float).reshape(-1, 2, 2)
    p, q = np.concatenate([merged.p[fresh], old[:, 0]]), np.concatenate([merged.q[fresh], old[:, 1]])
    ends, u = np.concatenate([p, q]), np.concatenate([q - p] * 2)
    found = np.stack([ends, u / np.hypot(*u.T)[:, None]], axis=1)
    freed = affected | _linked(bm, found, affected, config)[0]
    affected |= freed
    lines_to: dict[str, set[str]] = {}  # a point -> the lines from affected points that end there
    while freed:
        at = _line_ends(bm, freed, dissolved)[1]
        reached = set()  # the far points reached anew (those reached before were checked then)
        for lid, point in _far_points(bm, freed, dissolved):
            if point not in affected:
                lines_to.setdefault(point, set()).add(lid)
                reached.add(point)
        free_ends = sorted(n for n in reached if bm.graph.nodes[n]["kind"] == "endpoint")
        far, far_ends = _line_ends(bm, free_ends, ())
        linked, links = _linked(bm, np.concatenate([at, far_ends]), affected, config)
        shared = {n for n in reached if len(lines_to[n]) > 1}  # two lines that may meet at both ends
        freed = (linked | {far[i] for i in np.flatnonzero(links[len(at) :])} | shared) - affected
        affected |= freed
    return affected


def _far_points(bm: BeliefMap, points: Iterable[str], dissolved: Iterable[str]) -> list[tuple[str, str]]:
    """(line id, the point at its other end) of each line at these points but the dissolved."""
    g = bm.graph
    return [
        (d["id"], next(m for m in bm.ends(d["id"]) if m != n))
        for n in points
        for d in g.adj[n].values()
        if d["id"] not in dissolved
    ]


def _line_ends(bm: BeliefMap, points: Iterable[str], dissolved: Iterable[str]) -> tuple[list[str], NDArray[np.float64]]:
    """The lines at these points but the ``dissolved``, one row each: the point, and (k, 2, 2) the line's fit end
    there and its unit direction."""
    g = bm.graph
    at, rows = [], []
    for n in sorted(points):
        for d in g.adj[n].values():
            if d["id"] not in dissolved:
                fit = d["fit"]
                e = bm.ends(d["id"]).index(n)
                at.append(n)
                rows.append((fit[e], (fit[1][0] - fit[0][0], fit[1][1] - fit[0][1])))
    ends = np.array(rows, dtype=float).reshape(-1, 2, 2)
    ends[:, 1] /= np.hypot(*ends[:, 1].T)[:, None]
    return at, ends


def _linked(
    bm: BeliefMap, found: NDArray[np.float64], affected: set[str], config: Config
) -> tuple[set[str], NDArray[np.bool_]]:
    """The points not ``affected`` where a line's fit end links with one of the ends ``found`` anew (from
    :func:`_line_ends`), and whether each found end links with one: within the corner distance, at least the
    corner angle from parallel."""
    none = (set(), np.zeros(len(found), dtype=bool))
    if not len(found):
        return none
    points = [n for n in surface_points_near(bm, found[:, 0], 2 * config.corners.distance) if n not in affected]
    owner, there = _line_ends(bm, points, ())
    if not owner:
        return none
    close = np.hypot(*(there[:, None, 0] - found[None, :, 0]).transpose(2, 0, 1)) <= config.corners.distance + 1e-9
    across = np.abs(there[:, 1] @ found[:, 1].T) <= np.cos(np.radians(config.corners.min_angle_deg)) + 1e-9
    link = close & across
    return {owner[i] for i in np.flatnonzero(link.any(axis=1))}, link.any(axis=0)
