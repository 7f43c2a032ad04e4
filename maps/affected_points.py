"""The points a rebuild finds anew: those whose corners a whole rebuild of the map could make otherwise.

A rebuild (:mod:`evmap.maps.rebuild`) detaches the lines at these points and finds their corners again; every
other point stays as it is. So the set must hold every point whose corner could change with the lines that
change: the ends of the lines dissolved, the points where an end of a line found anew would link (as corners
link ends: within the corner distance, at least the corner angle from parallel), and, in turn, those where one
would link with an end at a point found anew. A line left free at a corner's end by a rule that looks at its
other end too (two lines meeting at both ends, :func:`~evmap.maps.rebuild.rebuild`) is found anew at both:
the free far end of a line at an affected point is affected where it would link with another line's end, and
so is a point where two lines from affected points end. With ``corners.drawn_apart``, a corner draws no line
related to another line as fitted (:mod:`evmap.maps.corners`): the ends of the lines that a line found anew or
dissolved pairs with by merging's tolerances widened by what corners may do
(:func:`~evmap.maps.corners.loose_merge`, :func:`~evmap.maps.redrawn.paired_lines`) are affected too.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from evmap.maps.merging import Merged
from evmap.maps.near_ends import line_ends, linked
from evmap.maps.redrawn import drawing_matters, paired_lines
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
    freed = affected | linked(bm, found, affected, config)[0]
    if config.corners.drawn_apart and len(p):  # a corner there may draw one of its lines related to a changed line
        freed |= {n for lid in paired_lines(bm, p, q, config) - dissolved.keys() for n in bm.ends(lid)}
    affected |= freed
    lines_to: dict[str, set[str]] = {}  # a point -> the lines from affected points that end there
    while freed:
        at = line_ends(bm, freed, dissolved)[1]
        reached, redrawn = set(), set()  # the far points reached anew (those reached before were checked then)
        far_points = _far_points(bm, freed, dissolved)
        sensitive = drawing_matters(bm, far_points, config) if config.corners.drawn_apart else set()
        for lid, point in far_points:
            if point not in affected:
                lines_to.setdefault(point, set()).add(lid)
                reached.add(point)
                if lid in sensitive:  # drawn to its end here anew, which may matter to this corner
                    redrawn.add(point)
        free_ends = sorted(n for n in reached if bm.graph.nodes[n]["kind"] == "endpoint")
        far, far_ends = line_ends(bm, free_ends, ())
        joined, links = linked(bm, np.concatenate([at, far_ends]), affected, config)
        shared = {n for n in reached if len(lines_to[n]) > 1}  # two lines that may meet at both ends
        freed = (joined | {far[i] for i in np.flatnonzero(links[len(at) :])} | shared | redrawn) - affected
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
