"""Unidentified objects that are the mirror image of a corner or a wall end in a smooth surface: its echo off it.

A corner sends sound back the way it came, and a wall's free end sends some back
(the map's lines are simulated with weak edges). Sound that meets a smooth surface
first (a wall, or the glass that continues it, which the stripe goes through) and
then such a target comes back by the same two legs, and the sonar places the echo
at their summed range along the first leg: beyond the surface, at the target's
mirror image in it. An unidentified object is explained from a pose that heard it
when its path from the pose crosses the line through a believed map line at least
:data:`MIRROR_MIN_LENGTH` long, past the line's ends by at most
``unidentified.window_width`` and at most the line's length (glass continuing the
wall, no farther than the wall was seen), the object more than
``unidentified.merge_radius`` beyond it, and its mirror image in that line lies
within ``unidentified.mirror_tolerance`` of a believed corner or of a believed
line's free end. One explained from every pose that heard it is removed
(:func:`mirror_echoes`, called by :func:`evmap.maps.unidentified.drop_explained`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.sensed import pose_sensed
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["MIRROR_MIN_LENGTH", "heard_from", "mirror_echoes", "mirrored"]

MIRROR_MIN_LENGTH = 0.5
"""A map line shorter than this (m) is no mirror: its direction is known too loosely (a 1 cm error at
each end turns a 0.5 m line by 2.3 degrees, which moves an image 4 m beyond it by 0.3 m)."""


def mirror_echoes(bm: BeliefMap, config: Config, believed: float) -> list[str]:
    """The unidentified objects that are, from every pose that heard them, the mirror image of a believed corner
    or free end in the line through a believed map line (module doc; believed: Bel(real) at least ``believed``).
    None when ``unidentified.mirror_tolerance`` is 0."""
    params = config.unidentified
    if params.mirror_tolerance <= 0:
        return []
    g, lines = bm.graph, bm.lines(believed)
    free_ends = [xy for ln in lines for n, xy in ((ln.u, ln.p), (ln.v, ln.q)) if g.nodes[n]["kind"] == "endpoint"]
    targets = np.array([c.xy for c in bm.corners(believed)] + free_ends, dtype=float).reshape(-1, 2)
    p, q = np.array([ln.p for ln in lines], dtype=float).reshape(-1, 2), np.array([ln.q for ln in lines]).reshape(-1, 2)
    long = np.hypot(*(q - p).T) >= MIRROR_MIN_LENGTH
    p, q = p[long], q[long]
    if not len(targets) or not len(p):
        return []
    ids, start, xy = [], [], []
    for u in bm.unidentified():
        heard = [pose_sensed(bm, k) for k in sorted(heard_from(bm, u.id))]
        if heard and all(s is not None for s in heard):  # else a pose it cannot judge: kept
            ids.extend([u.id] * len(heard))
            start.extend(s.origin for s in heard if s is not None)
            xy.extend([u.xy] * len(heard))
    if not ids:
        return []
    echo = mirrored(np.array(start), np.array(xy), p, q, targets, params.merge_radius, params.window_width)
    explained = echo <= params.mirror_tolerance
    path_ids = np.array(ids)
    return sorted(set(path_ids[explained].tolist()) - set(path_ids[~explained].tolist()))


def mirrored(
    start: NDArray[np.float64],
    xy: NDArray[np.float64],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    targets: NDArray[np.float64],
    beyond: float,
    reach: float,
) -> NDArray[np.float64]:
    """For each path ``start`` -> ``xy`` ((K, 2) each), the least distance from a point of ``targets`` (T, 2)
    to the mirror image of ``xy`` in the line through a segment p-q ((L, 2) each) that the path crosses, ``xy``
    more than ``beyond`` past it and the crossing past the segment's ends by at most ``reach`` and at most the
    segment's length (a line is not carried on farther than it was seen); inf where none.

    >>> wall = np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]])  # the line y = 0, seen from above
    >>> corner = np.array([[3.0, 2.0]])
    >>> mirrored(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([[3.0, -2.0], [3.0, 2.5]]), *wall, corner, 0.3, 5.0).tolist()
    [0.0, inf]
    """
    d = q - p
    length = np.maximum(np.hypot(*d.T), 1e-12)
    u = d / length[:, None]
    n = np.column_stack([-u[:, 1], u[:, 0]])
    side_start = np.einsum("kli,li->kl", start[:, None, :] - p[None], n)
    side_xy = np.einsum("kli,li->kl", xy[:, None, :] - p[None], n)
    crosses = (side_start * side_xy < 0) & (np.abs(side_xy) > beyond)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = side_start / (side_start - side_xy)
    at = start[:, None, :] + t[..., None] * (xy - start)[:, None, :]  # (K, L, 2) where the path crosses
    along = np.einsum("kli,li->kl", at - p[None], u)
    carry = np.minimum(length, reach)
    crosses &= (along >= -carry) & (along <= length + carry)
    image = xy[:, None, :] - 2 * side_xy[..., None] * n[None]  # (K, L, 2)
    gap = np.hypot(*(image[:, :, None, :] - targets[None, None]).transpose(3, 0, 1, 2)).min(axis=2)
    return np.where(crosses, gap, np.inf).min(axis=1, initial=np.inf)


def heard_from(bm: BeliefMap, uid: str) -> set[int]:
    """The poses whose evidence the object's history records."""
    return {r["pose"] for r in bm.graph.nodes[uid].get("history", ()) if "pose" in r}
