"""Unidentified objects that are the mirror image of a corner or a wall end in a smooth surface: its echo off it.

A corner sends sound back the way it came, and so does a pillar, and a wall's free
end sends some back (the map's lines are simulated with weak edges). Sound that
meets a smooth surface first (a wall, or the glass that continues it, which the
stripe goes through) and then such a target comes back by the same two legs, and
the sonar places the echo at their summed range along the first leg: beyond the
surface, at the target's mirror image in it. An unidentified object is explained
from a pose that heard it when its path from the pose crosses the line through a
mirror at least :data:`MIRROR_MIN_LENGTH` long (a believed map line, or the face
of a pane: glass some pose heard at normal incidence), past the mirror's ends by
at most ``unidentified.window_width`` and at most its length (glass continuing
the wall or the pane, no farther than the mirror was seen), the object more than
``unidentified.merge_radius`` beyond it, and its mirror image in that line lies
within ``unidentified.mirror_tolerance`` of a believed corner, a believed line's
free end or another believed object (a pillar the map holds as one); the path
meets the line off its normal by more than the sonar's detection half-width (a
surface met square answers first itself); where the mirror is carried on past
its end over the foot of the pose's perpendicular, the pose heard something there
square (a reading aimed within the half-width of the foot came back within
``merge_radius`` of its distance: glass carrying the mirror on would have
answered); and the target is in sight from where the path meets the mirror. One
explained from every pose that heard it is removed (:func:`mirror_echoes`, called
by :func:`evmap.maps.explained_objects.drop_explained`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.sensed import heard_from, pose_sensed
from evmap.sources.config_model import Config
from evmap.sources.geometry import crossings, wrapped
from evmap.sources.sim.sonar import echo_halfwidth

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["MIRROR_MIN_LENGTH", "SIGHT_MARGIN", "may_stand", "mirror_echoes", "mirrored"]

SIGHT_MARGIN = 0.05
"""A map line this close (m) to the crossing or the target does not hide the target: both lie on lines."""

MIRROR_MIN_LENGTH = 0.5
"""A map line shorter than this (m) is no mirror: its direction is known too loosely (a 1 cm error at
each end turns a 0.5 m line by 2.3 degrees, which moves an image 4 m beyond it by 0.3 m)."""


def mirror_echoes(
    bm: BeliefMap,
    config: Config,
    believed: float,
    panes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    objects: Iterable[str] | None = None,
) -> list[str]:
    """The unidentified objects (of ``objects``, ids; every one when None) that are, from every pose that heard them
    (:func:`~evmap.maps.sensed.heard_from`), the mirror image of a believed corner, free end or object in the line
    through a believed map line or a pane's face (module doc; believed: Bel(real) at least ``believed``; ``panes``:
    the faces' ends p and q, (F, 2) each). The map is looked up near the poses and the objects they heard only. None
    when ``unidentified.mirror_tolerance`` is 0."""
    params = config.unidentified
    if params.mirror_tolerance <= 0:
        return []
    ids = [u.id for u in bm.unidentified()] if objects is None else sorted(objects)
    g = bm.graph
    heard = {uid: heard_from(bm, uid) for uid in ids}
    poses = {k: s for k in {k for ks in heard.values() for k in ks} if (s := pose_sensed(bm, k)) is not None}
    # an object heard from a pose the map does not remember is kept
    image = {uid: True for uid in ids if heard[uid] and all(k in poses for k in heard[uid])}
    by_pose: dict[int, list[str]] = {}  # the objects each pose heard, of those judged
    for uid in image:
        for k in heard[uid]:
            by_pose.setdefault(k, []).append(uid)
    if not by_pose:
        return []
    # a path crosses a mirror only within the mirror's extent carried on (mirrored's reach), and a target's image
    # lies no farther from the pose than twice the path: each pose meets only the mirrors and targets so near
    reach, boxes = {}, []
    for k, mine in by_pose.items():
        origin = poses[k].origin
        xy = np.array([g.nodes[uid]["xy"] for uid in mine], dtype=float)
        reach[k] = 2 * float(np.hypot(*(xy - origin).T).max()) + params.mirror_tolerance
        boxes.append((*(origin - reach[k]), *(origin + reach[k])))
    p, q, targets = _near_map(bm, np.array(boxes), believed)
    fp, fq = panes if panes is not None else (p[:0], q[:0])
    mp, mq = np.concatenate([p, fp]), np.concatenate([q, fq])
    long = np.hypot(*(mq - mp).T) >= MIRROR_MIN_LENGTH
    mp, mq = mp[long], mq[long]
    if not len(targets) or not len(mp):
        return []
    carry = np.minimum(np.hypot(*(mq - mp).T), params.window_width)[:, None]
    u_m = (mq - mp) / np.maximum(np.hypot(*(mq - mp).T), 1e-12)[:, None]
    m_lo = np.minimum(mp - carry * u_m, mq + carry * u_m)
    m_hi = np.maximum(mp - carry * u_m, mq + carry * u_m)
    for k in sorted(by_pose):
        s = poses[k]
        mine = [uid for uid in by_pose[k] if image[uid]]  # not yet refuted by another pose
        if not mine:
            continue
        xy = np.array([g.nodes[uid]["xy"] for uid in mine], dtype=float)
        lo, hi = np.minimum(xy.min(axis=0), s.origin), np.maximum(xy.max(axis=0), s.origin)
        near = np.flatnonzero(((m_lo <= hi) & (m_hi >= lo)).all(axis=1))
        close = np.flatnonzero((np.abs(targets - s.origin) <= reach[k]).all(axis=1))
        sonar = s.sonar.params if s.sonar is not None else None
        echo = mirrored(
            np.tile(s.origin, (len(mine), 1)),
            xy,
            mp[near],
            mq[near],
            targets[close],
            params.mirror_tolerance,
            params.merge_radius,
            params.window_width,
            halfwidth=None if sonar is None else lambda r, sonar=sonar: echo_halfwidth(np.ones_like(r), r, sonar),
            walls=(p, q),
            echoes=None if s.sonar is None else (s.sonar.angles, s.sonar.ranges),
        )
        for uid, e in zip(mine, echo.tolist(), strict=True):
            image[uid] = e
    return sorted(uid for uid, found in image.items() if found)


def _near_map(
    bm: BeliefMap, boxes: NDArray[np.float64], believed: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The believed lines (ends p, q, (L, 2) each) whose boxes meet one of the ``boxes`` ((n, 4)), and the targets
    (T, 2) among them: the believed corners and objects, and the believed lines' free ends."""
    g = bm.graph
    found = sorted(bm.near(boxes))
    lines = [bm.ends(n) for n in found if bm.is_line(n) and bm.mass(n).belief("real") >= believed]
    points = [n for n in found if not bm.is_line(n) and g.nodes[n]["kind"] in ("corner", "unidentified")]
    free = [n for ends in lines for n in ends if g.nodes[n]["kind"] == "endpoint"]
    held = [n for n in points if bm.mass(n).belief("real") >= believed]
    p = np.array([g.nodes[a]["xy"] for a, _ in lines], dtype=float).reshape(-1, 2)
    q = np.array([g.nodes[b]["xy"] for _, b in lines], dtype=float).reshape(-1, 2)
    targets = np.array([g.nodes[n]["xy"] for n in held + free], dtype=float).reshape(-1, 2)
    return p, q, targets


def mirrored(
    start: NDArray[np.float64],
    xy: NDArray[np.float64],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    targets: NDArray[np.float64],
    tolerance: float,
    beyond: float,
    reach: float,
    *,
    halfwidth: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    walls: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    echoes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> NDArray[np.bool_]:
    """Whether each path ``start`` -> ``xy`` ((K, 2) each) crosses the line through a segment p-q ((L, 2) each),
    ``xy`` more than ``beyond`` past it and the crossing past the segment's ends by at most ``reach`` and at most
    the segment's length (a line is not carried on farther than it was seen), where the mirror image of ``xy``
    lies within ``tolerance`` of a point of ``targets`` (T, 2).

    With ``halfwidth`` (the sonar's detection half-width, rad, of a wall at each range; negative where never
    detected), a path that meets the line within that angle of its normal, at its range from ``start``, is no
    mirror's: the surface would have answered first itself. With ``walls`` (segments p, q), a target behind
    one of them, seen from the crossing (more than :data:`SIGHT_MARGIN` from either), is out of the sound's
    reach. With ``halfwidth`` and ``echoes`` (the beam axes, rad, and ranges of the sonar readings taken at
    every ``start``: one pose's), a line carried past its end over the foot of the perpendicular from
    ``start`` is not there when no reading aimed within the half-width of that foot came back within
    ``beyond`` of its distance: a surface there would have been heard square.

    >>> wall = np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]])  # the line y = 0, seen from above
    >>> corner = np.array([[3.0, 2.0]])
    >>> mirrored(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([[3.0, -2.0], [3.0, 2.5]]), *wall, corner, 0.25, 0.3, 5.0)
    array([ True, False])
    >>> screen = np.array([[2.0, 0.2]]), np.array([[2.0, 3.0]])  # between the crossing (1.67, 0) and the corner
    >>> mirrored(np.array([[1.0, 1.0]]), np.array([[3.0, -2.0]]), *wall, corner, 0.25, 0.3, 5.0, walls=screen)
    array([False])
    >>> long_wall, ahead = (np.array([[0.0, 0.0]]), np.array([[4.0, 0.0]])), np.array([[3.0, 2.0]])
    >>> square = np.array([[3.0, 1.0]]), np.array([[3.0, -2.0]]), *long_wall, ahead, 0.25, 0.3, 5.0  # its normal
    >>> mirrored(*square), mirrored(*square, halfwidth=lambda r: np.full_like(r, 0.2))
    (array([ True]), array([False]))
    """
    d = q - p
    length = np.maximum(np.hypot(*d.T), 1e-12)
    u = d / length[:, None]
    n = np.column_stack([-u[:, 1], u[:, 0]])
    side_start = np.einsum("kli,li->kl", start[:, None, :] - p[None], n)
    side_xy = np.einsum("kli,li->kl", xy[:, None, :] - p[None], n)
    crosses = (side_start * side_xy < 0) & (np.abs(side_xy) > beyond)
    with np.errstate(divide="ignore", invalid="ignore"):  # a path along the line: it crosses nothing
        t = side_start / (side_start - side_xy)
        at = start[:, None, :] + t[..., None] * (xy - start)[:, None, :]  # (K, L, 2) where the path crosses
        along = np.einsum("kli,li->kl", at - p[None], u)
    carry = np.minimum(length, reach)
    crosses &= (along >= -carry) & (along <= length + carry)
    if halfwidth is not None:
        path = xy - start
        dist = np.maximum(np.hypot(*path.T), 1e-12)[:, None]
        incidence = np.arccos(np.clip(np.abs(path @ n.T) / dist, 0.0, 1.0))  # (K, L): from the line's normal
        with np.errstate(invalid="ignore"):
            half = halfwidth(np.where(crosses, t * dist, np.inf))
        crosses &= (half < 0) | (incidence > half)
        if echoes is not None:  # where carried on past an end square in front of the pose, it must be heard there
            foot = np.einsum("kli,li->kl", start[:, None, :] - p[None], u)  # the perpendicular's foot, along the line
            over = ((along < 0) & (foot < 0) & (foot >= along)) | ((along > length) & (foot > length) & (foot <= along))
            k, line = np.nonzero(crosses & over)
            toward = -np.sign(side_start[k, line])[:, None] * n[line]
            crosses[k, line] = may_stand(np.abs(side_start[k, line]), toward, halfwidth, echoes, beyond)
    k, line = np.nonzero(crosses)  # the images of the paths that cross, against every target
    image = xy[k] - 2 * side_xy[k, line][:, None] * n[line]
    hit, j = np.nonzero(np.hypot(*(image[:, None, :] - targets[None]).transpose(2, 0, 1)) <= tolerance)
    k, line = k[hit], line[hit]
    if walls is not None and len(k) and len(walls[0]):
        a, leg = at[k, line], targets[j] - at[k, line]
        s, w = crossings(a[:, None], leg[:, None], walls[0][None], (walls[1] - walls[0])[None])
        margin = SIGHT_MARGIN / np.maximum(np.hypot(*leg.T), 1e-12)[:, None]
        k = k[~((w >= 0) & (w <= 1) & (s > margin) & (s < 1 - margin)).any(axis=1)]
    found = np.zeros(len(start), dtype=bool)
    found[k] = True
    return found


def may_stand(
    d: NDArray[np.float64],
    toward: NDArray[np.float64],
    halfwidth: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    echoes: tuple[NDArray[np.float64], NDArray[np.float64]],
    margin: float,
) -> NDArray[np.bool_]:
    """Whether a surface square to the sonar, ``d`` (N,) straight ``toward`` (N, 2: unit vectors) from it, may stand
    there by its readings ``echoes`` (beam axes, rad, and ranges): it lies beyond detection range (``halfwidth``
    negative), or no reading was aimed within the half-width of it, or one of those came back within ``margin`` of
    ``d`` (from it, or from something nearer).

    >>> echoes = np.radians([0.0, 90.0]), np.array([5.0, 1.0])  # east 5 m, north 1 m
    >>> toward = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])  # east, north, west (where no reading aimed)
    >>> may_stand(np.array([2.0, 1.0, 2.0]), toward, lambda d: np.full_like(d, 0.2), echoes, 0.3)
    array([False,  True,  True])
    """
    off = np.abs(wrapped(echoes[0][None] - np.arctan2(toward[:, 1], toward[:, 0])[:, None]))
    aimed = off <= halfwidth(d)[:, None]
    return ~aimed.any(axis=1) | (aimed & (echoes[1][None] <= (d + margin)[:, None])).any(axis=1)
