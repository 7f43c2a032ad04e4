"""Line ends near points: the corners and free ends a rebuild looks at, the lines that end there, and whether
ends found anew link with them as corners link ends (within the corner distance, at least the corner angle from
parallel). One small query per end, tested all at once by numpy."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["SURFACE_KINDS", "fits_near", "line_ends", "linked", "surface_points_near"]

SURFACE_KINDS = ("corner", "endpoint")
"""The kinds of points that end lines (an unidentified object ends none)."""


def surface_points_near(bm: BeliefMap, xy: NDArray[np.float64], reach: float) -> list[str]:
    """The corners and end points (sorted) in the boxes reaching ``reach`` around each of the points ``xy``:
    the cells of each small box, so the cost is what is near them however far apart they are."""
    g = bm.graph
    found = bm.near(np.hstack([xy - reach, xy + reach]), "points") if len(xy) else set()
    return sorted(n for n in found if g.nodes[n]["kind"] in SURFACE_KINDS)


def fits_near(
    bm: BeliefMap, p: NDArray[np.float64], q: NDArray[np.float64], reach: float
) -> tuple[list[str], NDArray[np.float64]]:
    """The map's lines (sorted ids) whose boxes meet a box of the lines p-q grown by ``reach``, and their fits
    ((L, 2, 2))."""
    ids = sorted(bm.near(np.hstack([np.minimum(p, q) - reach, np.maximum(p, q) + reach]), "lines")) if len(p) else []
    return ids, np.array([bm.graph.edge(*bm.ends(lid))["fit"] for lid in ids], dtype=float).reshape(-1, 2, 2)


def line_ends(bm: BeliefMap, points: Iterable[str], dissolved: Iterable[str]) -> tuple[list[str], NDArray[np.float64]]:
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


def linked(
    bm: BeliefMap, found: NDArray[np.float64], affected: set[str], config: Config
) -> tuple[set[str], NDArray[np.bool_]]:
    """The points not ``affected`` where a line's fit end links with one of the ends ``found`` anew (from
    :func:`line_ends`), and whether each found end links with one: within the corner distance, at least the
    corner angle from parallel."""
    none = (set(), np.zeros(len(found), dtype=bool))
    if not len(found):
        return none
    points = [n for n in surface_points_near(bm, found[:, 0], 2 * config.corners.distance) if n not in affected]
    owner, there = line_ends(bm, points, ())
    if not owner:
        return none
    close = np.hypot(*(there[:, None, 0] - found[None, :, 0]).transpose(2, 0, 1)) <= config.corners.distance + 1e-9
    across = np.abs(there[:, 1] @ found[:, 1].T) <= np.cos(np.radians(config.corners.min_angle_deg)) + 1e-9
    link = close & across
    return {owner[i] for i in np.flatnonzero(link.any(axis=1))}, link.any(axis=0)
