"""The faces of the map's believed unidentified objects, where each ends the free space of the poses that heard it.

An unidentified object is something the sonar heard that no line of the map explains:
glass heard at normal incidence, mostly, which the stripe goes through. Its face toward
a pose that heard it is square to the pose's bearing (a specular surface echoes back
along its normal), ``object_width`` across: the free space (:mod:`evmap.maps.free_space`)
ends there. A face in line with believed walls on both sides of it (the object within
``in_line`` of each wall's own line, their directions within :data:`WALL_ANGLE` of the
face, each at least ``wall_length`` long) whose nearest ends are at most ``glass_wall``
apart is the chord between those ends instead: the pane of a window or a glass wall, of
which the sonar hears only the part square to the pose, and the stripe nothing. Lines
shorter than ``wall_length`` (a chair leg's, a door jamb's stub, a mullion) make no wall:
a door is a gap in a wall too, and something heard in it is no pane. With such a line in
line between the two walls (panes between mullions) the chord is at most ``window``
long, and no short line between them crosses the face's line or ends on it away from the
walls' ends (a door's jamb, the wall turning: the pane beside a door ends there; a room's
wall behind the glass is longer). Else the nearest lines in line on either side, walls or
mullions, with no line meeting the face's line nearer, bound it up to ``window``: the pane
at a facade's end, between its wall and the first mullion, or between two mullions (a facade
whose walls turn at its ends, or go on beyond a door's jamb, has no wall in line to span it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.sources.geometry import crossings, line_distances

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap
    from evmap.maps.free_space import FreeSpaceParams

__all__ = ["WALL_ANGLE", "object_faces"]

WALL_ANGLE = np.radians(10.0)
"""A pane is in a wall when it is this parallel to the believed lines on both sides of it: a gap in the
stripe whose chord is (:func:`evmap.maps.stripe_contour.in_line`), an object's face (module doc)."""


def object_faces(
    bm: BeliefMap,
    origins: dict[int, NDArray[np.float64]],
    params: FreeSpaceParams,
    walls: tuple[NDArray[np.float64], NDArray[np.float64]],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A face of every believed unidentified object toward each pose that heard it: ``object_width`` across, or
    the window between the believed lines ``walls`` (their ends p, q) in line with it on both sides (module doc)."""
    p, q = [], []
    for u in bm.unidentified(params.min_belief):
        xy = np.asarray(u.xy, dtype=float)
        for pose in {r["pose"] for r in bm.graph.nodes[u.id].get("history", ()) if "pose" in r}:
            if pose not in origins:
                continue
            d = xy - origins[pose]
            n = np.hypot(*d)
            if n <= 0:
                continue
            side = np.array([-d[1], d[0]]) / n
            a, b = _window(xy, side, walls, params)
            p.append(a)
            q.append(b)
    return np.array(p, dtype=float).reshape(-1, 2), np.array(q, dtype=float).reshape(-1, 2)


def _window(
    xy: NDArray[np.float64],
    side: NDArray[np.float64],
    walls: tuple[NDArray[np.float64], NDArray[np.float64]],
    params: FreeSpaceParams,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ends of the face of an object at ``xy`` square to a pose (``side``: a unit vector along it): the
    nearest ends of the walls (``wall_length`` long at least) in line with it on either side, when they are at
    most ``glass_wall`` apart (``window`` with shorter lines in line between them: mullions) and no jamb lies
    between them; else those of the nearest lines in line with it on either side (walls or mullions), when no
    line meets the face's line nearer and they are at most ``window`` apart; else ``object_width`` across."""
    half = side * params.object_width / 2
    wp, wq = walls
    if not len(wp):
        return xy - half, xy + half
    d = wq - wp
    length = np.hypot(*d.T)
    in_line = (np.abs(d @ side) >= np.cos(WALL_ANGLE) * length) & (line_distances(xy, wp, wq) <= params.in_line)
    ok = in_line & (length >= params.wall_length)
    sp, sq = (wp - xy) @ side, (wq - xy) @ side
    normal = np.array([side[1], -side[0]])
    dp, dq = np.abs((wp - xy) @ normal), np.abs((wq - xy) @ normal)  # off the face's line
    t, s = crossings(xy, side, wp, d)
    crossing = (s > 0) & (s < 1)
    meets = ~in_line & (crossing | (np.minimum(dp, dq) <= params.in_line))  # crosses or ends on it
    at = np.where(crossing, t, np.where(dp < dq, sp, sq))  # where along the face
    lo = np.where(meets, at, np.minimum(sp, sq))  # each line's extent along the face, the object at 0
    hi = np.where(meets, at, np.maximum(sp, sq))
    for bounds, widest in ((ok, params.glass_wall), (in_line | meets, params.window)):
        left, right = bounds & (hi < 0), bounds & (lo > 0)
        if not left.any() or not right.any():
            continue
        l_, r = np.flatnonzero(left)[np.argmax(hi[left])], np.flatnonzero(right)[np.argmin(lo[right])]
        between = (lo > hi[l_]) & (hi < lo[r])
        # a short line meeting the face's line away from the walls' ends: a jamb, the wall turning at a door
        jambs = meets & (length < params.wall_length) & (lo > hi[l_] + params.in_line) & (hi < lo[r] - params.in_line)
        if meets[l_] or meets[r] or jambs.any():
            continue
        a, b = (wq if sp[l_] < sq[l_] else wp)[l_], (wp if sp[r] < sq[r] else wq)[r]  # the nearer ends
        if np.hypot(*(b - a)) <= (params.window if (in_line & between).any() else widest):
            return a, b
    return xy - half, xy + half
