"""Unidentified objects the map comes to explain as later poses extend and confirm its lines and objects.

An object placed where the map had no believed line may find one there later: its
echo is that line's, or it lies behind the line, or at the image of a corner in it;
and a pane heard by a later pose may stand between an object and every pose that
heard it (:mod:`evmap.maps.unidentified` says what each rule takes as explained).
:func:`drop_explained` removes them after every update with sonar. Past
:data:`~evmap.maps.sensed.LATEST_POSES` poses, only the objects one of the map's
latest poses heard are judged again, each from the latest poses that heard it
(:func:`judged_objects`, :func:`~evmap.maps.sensed.heard_from`), and the map is
looked up near them only: an update costs what the robot's place holds, not the
map (a robot log passes the same place hundreds of times).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.maps.free_space import FreeSpaceParams
from evmap.maps.mirror_echoes import mirror_echoes
from evmap.maps.pane_faces import Panes, pane_faces
from evmap.maps.sensed import LATEST_POSES, Sensed, heard_from, pose_sensed
from evmap.maps.stripe_contour import stripe_bound
from evmap.maps.unidentified import BELIEVED
from evmap.sources.config_model import Config
from evmap.sources.geometry import line_distances, point_segment_distances
from evmap.sources.params import UnidentifiedParams

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["behind_panes", "behind_stripes", "drop_explained", "judged_objects"]


def drop_explained(bm: BeliefMap, config: Config, changed: Iterable[str] | None = None) -> list[str]:
    """Remove the unidentified objects a believed line now explains (within ``unidentified.explained_distance``),
    those behind another object's pane (``unidentified.pane_width``, :func:`behind_panes`), those behind the
    stripe of every pose that heard them (``unidentified.behind_depth``, :func:`behind_stripes`; the objects
    the lines ``changed`` may hide, every object when None), and the mirror images of believed corners, wall
    ends and objects in believed lines and panes (``unidentified.mirror_tolerance``,
    :func:`~evmap.maps.mirror_echoes.mirror_echoes`).

    An object placed where the map had no believed line may find one there as later
    poses extend or confirm the lines: its echo is that line's, or it lies behind the
    line, or at the image of a corner in it. A pane heard by a later pose may stand between
    an object and every pose that heard it. Only the objects the map's latest
    :data:`~evmap.maps.sensed.LATEST_POSES` poses heard are judged (:func:`judged_objects`). Nothing is removed
    when ``explained_distance``, ``pane_width``, ``behind_depth`` and ``mirror_tolerance`` are 0 (the paper's
    method). Returns the removed ids.
    """
    objects = judged_objects(bm, config)
    removed = _on_lines(bm, config.unidentified.explained_distance, objects)
    objects = _without(bm, objects, removed)
    panes = _panes(bm, config, objects)
    hidden = behind_panes(bm, config, panes, objects)
    objects = _without(bm, objects, hidden)
    behind = behind_stripes(bm, config, changed, objects)
    objects = _without(bm, objects, behind)
    glass = None  # glass heard square mirrors too: the same faces, less those of the objects removed
    if panes is not None and config.unidentified.mirror_tolerance > 0:
        kept = panes.without(hidden + behind)
        glass = kept.p, kept.q
    mirrors = mirror_echoes(bm, config, BELIEVED, glass, objects)
    _without(bm, objects, mirrors)
    return removed + hidden + behind + mirrors


def judged_objects(bm: BeliefMap, config: Config) -> list[str]:
    """The unidentified objects an update judges again (sorted ids): every one while the map has folded at most
    :data:`~evmap.maps.sensed.LATEST_POSES` poses, then those one of its latest
    :data:`~evmap.maps.sensed.LATEST_POSES` poses heard. The others are settled, kept as they are (an update
    costs what the robot's place holds, not the map): a place the robot comes back to, it hears again. Every one
    too when the map does not remember what one of those poses sensed (a map saved without it)."""
    g = bm.graph
    latest = bm.poses[-LATEST_POSES:]
    recent = [pose_sensed(bm, k) for k in latest]
    if len(bm.poses) <= LATEST_POSES or any(s is None for s in recent):
        return sorted(u.id for u in bm.unidentified())
    # an object lies within the sonar's range of a pose that heard it (the config's, or a log's own: the reach)
    reach = np.maximum([s.reach for s in recent if s is not None], config.sensors.sonar.max_range)
    reach += config.unidentified.merge_radius
    origin = np.array([s.origin for s in recent if s is not None])
    near = bm.near(np.column_stack([origin - reach[:, None], origin + reach[:, None]]), "points")
    heard = set(latest)
    return sorted(
        n
        for n in near
        if g.nodes[n]["kind"] == "unidentified" and any(r.get("pose") in heard for r in g.nodes[n].get("history", ()))
    )


def _without(bm: BeliefMap, objects: list[str], removed: list[str]) -> list[str]:
    """Remove the objects ``removed`` from the map; the ``objects`` left."""
    for uid in removed:
        bm.remove_point(uid)
    gone = set(removed)
    return [uid for uid in objects if uid not in gone]


def behind_stripes(
    bm: BeliefMap, config: Config, changed: Iterable[str] | None = None, objects: Iterable[str] | None = None
) -> list[str]:
    """The unidentified objects (of ``objects``, ids; every one when None) more than ``unidentified.behind_depth``
    beyond the stripe's contour (:func:`~evmap.maps.stripe_contour.stripe_bound` on the believed lines) of every
    pose that heard them.

    A line believed after an object was made may show it to be a multiple reflection: the
    sound came back from behind a surface the stripe measured. Only the objects that a
    believed line of ``changed`` (ids; None: every line) may hide are judged: a path from
    a pose that heard one to it passes within the contour's margin of the line, carried on
    at both ends by ``window_width`` (a chord across a pane continues the wall). An object
    a pose heard that the map does not remember the readings of is kept. None when
    ``behind_depth`` is 0.
    """
    params = config.unidentified
    if params.behind_depth <= 0:
        return []
    ids = bm.line_ids() if changed is None else (i for i in changed if i in bm and bm.is_line(i))
    p, q = _believed_ends(bm, ids)
    if not len(p):
        return []
    g, margin = bm.graph, FreeSpaceParams().margin
    d = (q - p) / np.maximum(np.hypot(*(q - p).T), 1e-12)[:, None] * params.window_width
    p, q = p - d, q + d
    far = max(config.sensors.sonar.max_range, config.sensors.lsl.max_range) + params.merge_radius
    near = bm.near(np.hstack([np.minimum(p, q) - far, np.maximum(p, q) + far]), "points")
    if objects is not None:
        near = near & set(objects)
    poses: dict[int, Sensed | None] = {}
    pairs = []  # (object, its xy, pose) of every pose that heard an object near
    for uid in sorted(near):
        if g.nodes[uid]["kind"] != "unidentified":
            continue
        heard = heard_from(bm, uid)
        for k in heard:
            if k not in poses:
                poses[k] = pose_sensed(bm, k)
        if heard and all(poses[k] is not None for k in heard):  # else a pose it cannot judge: kept
            xy = np.asarray(g.nodes[uid]["xy"], dtype=float)
            pairs.extend((uid, xy, k) for k in heard)
    if not pairs:
        return []
    paths = shapely.linestrings([[poses[k].origin, xy] for _, xy, k in pairs])
    walls = shapely.linestrings(np.stack([p, q], axis=1))
    crossing, _ = shapely.STRtree(walls).query(paths, predicate="dwithin", distance=margin)
    judged = {pairs[i][0] for i in crossing.tolist()}
    bounds: dict[int, shapely.Geometry | None] = {}
    inside: set[str] = set()
    for uid, xy, k in pairs:
        if uid not in judged or uid in inside:
            continue
        pose = poses[k]
        assert pose is not None
        if k not in bounds:
            bounds[k] = _pose_bound(bm, pose, params, far)
        to = xy - pose.origin
        n = float(np.hypot(*to))
        back = pose.origin + to * max(n - params.behind_depth - margin, 0.0) / max(n, 1e-12)
        if bounds[k] is None or shapely.contains_xy(bounds[k], *back):
            inside.add(uid)
    return sorted(judged - inside)


def _pose_bound(bm: BeliefMap, s: Sensed, params: UnidentifiedParams, far: float) -> shapely.Geometry | None:
    """The contour of the pose ``s`` on the believed lines within ``far`` of it, out to ``far``."""
    p, q = _believed_ends(bm, bm.near((*(s.origin - far), *(s.origin + far)), "lines"))
    return stripe_bound(s, p, q, params, far + 1.0)


def _believed_ends(bm: BeliefMap, ids: Iterable[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The end points p, q ((L, 2) each, in id order) of the lines ``ids`` whose Bel(real) is at least
    :data:`BELIEVED`."""
    g = bm.graph
    ends = [bm.ends(i) for i in sorted(ids) if bm.mass(i).belief("real") >= BELIEVED]
    p = np.array([g.nodes[a]["xy"] for a, _ in ends], dtype=float).reshape(-1, 2)
    q = np.array([g.nodes[b]["xy"] for _, b in ends], dtype=float).reshape(-1, 2)
    return p, q


def _panes(bm: BeliefMap, config: Config, objects: Iterable[str] | None = None) -> Panes | None:
    """The faces of the believed objects (:func:`~evmap.maps.pane_faces.pane_faces`) that may meet a path from an
    object of ``objects`` (ids; every one when None) to a pose that heard it, or the line carried on through one
    of them; None when ``pane_width`` is 0."""
    params = config.unidentified
    if params.pane_width <= 0:
        return None
    if objects is None:
        owners = [u.id for u in bm.unidentified(BELIEVED)]
    else:
        ids, xy, start = _paths(bm, objects)
        grow = params.pane_width / 2 + params.window_width
        boxes = np.column_stack([np.minimum(xy, start) - grow, np.maximum(xy, start) + grow])
        g = bm.graph
        near = sorted(bm.near(boxes, "points")) if ids else []
        owners = [n for n in near if g.nodes[n]["kind"] == "unidentified" and bm.mass(n).belief("real") >= BELIEVED]
    return pane_faces(bm, owners, params.pane_width, params.merge_radius)


def _paths(bm: BeliefMap, objects: Iterable[str] | None) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
    """The paths from the ``objects`` (ids; every one when None) to the poses that heard them and that the map
    remembers: each path's object, the object's place and the pose's origin ((n, 2) each)."""
    g = bm.graph
    ids, xy, start = [], [], []
    for uid in [u.id for u in bm.unidentified()] if objects is None else objects:
        for pose in heard_from(bm, uid):
            if (s := pose_sensed(bm, pose)) is not None:
                ids.append(uid)
                xy.append(g.nodes[uid]["xy"])
                start.append(s.origin)
    return ids, np.array(xy, dtype=float).reshape(-1, 2), np.array(start, dtype=float).reshape(-1, 2)


def behind_panes(
    bm: BeliefMap, config: Config, panes: Panes | None = None, objects: Iterable[str] | None = None
) -> list[str]:
    """The unidentified objects (of ``objects``, ids; every one when None) whose every path to the poses that heard
    them crosses another object's pane.

    A pane is a face ``unidentified.pane_width`` across, square to the bearing from a pose
    that heard the object, of each object believed at least :data:`BELIEVED` that the
    pose's stripe saw through (:func:`~evmap.maps.pane_faces.pane_faces`; ``panes``, or found anew). An object
    crosses one when the segment from a pose's sensor to it meets the face and it lies more than
    ``unidentified.merge_radius`` beyond the face's line. None when ``pane_width`` is 0.
    """
    params = config.unidentified
    panes = panes if panes is not None else _panes(bm, config, objects)
    if panes is None or not len(panes.p):
        return []
    fp, fq = panes.p, panes.q
    ids, b, a = _paths(bm, objects)
    if not ids:
        return []
    path, face = shapely.STRtree(shapely.linestrings(np.stack([fp, fq], axis=1))).query(
        shapely.linestrings(np.stack([a, b], axis=1)), predicate="intersects"
    )
    blocked = np.zeros(len(ids), dtype=bool)
    blocked[path[line_distances(b[path], fp[face], fq[face]) > params.merge_radius]] = True
    path_ids = np.array(ids)
    return sorted(set(path_ids[blocked].tolist()) - set(path_ids[~blocked].tolist()))


def _on_lines(bm: BeliefMap, distance: float, objects: Iterable[str]) -> list[str]:
    """The unidentified ``objects`` (ids) within ``distance`` of a believed map line (none when ``distance`` is 0)."""
    if distance <= 0:
        return []
    found = []
    for uid in objects:
        x, y = bm.graph.nodes[uid]["xy"]
        p, q = _believed_ends(bm, bm.near((x - distance, y - distance, x + distance, y + distance), "lines"))
        if len(p) and point_segment_distances(np.array([x, y]), p, q).min() <= distance:
            found.append(uid)
    return found
