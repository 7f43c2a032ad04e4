"""Unidentified objects (paper, section III, Fig. 7): what the sonar hears and the map cannot explain.

An actual RCD of Type I-III that matched no simulated RCD, and comes from a
target in sight (:func:`evmap.maps.simulated_sonar.in_sight`), becomes an
``unidentified`` point at the pose + its range along its direction, with the
``unidentified`` stage's evidence by RCD type; within ``unidentified.merge_radius``
of an existing one it reinforces that one instead, at most once per pose. An
RCD is placed on the part of its arc that the map does not explain: an arc
point within ``unidentified.explained_distance`` of a believed map line
(:data:`BELIEVED`) may be that line's echo (the matching missed it: the line's
own simulated RCD is cut differently, merged with a neighbour's, or shifted
past a gate). With ``unidentified.behind_contour``, an arc point beyond the
pose's own stripe (:func:`evmap.maps.free_space.contour_bound` of its points on
believed lines, and of the chords across gaps between believed lines that the
chord continues: panes in a wall) is explained too: sound does not come back
through the surface the stripe measured, so the echo is a multiple reflection.
An RCD whose whole arc is explained makes no object; one beside a wall (a
window in it) makes its object on the part beside the line. An object that a
believed line comes to explain as later poses extend the lines is removed
(:func:`drop_explained`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.maps.free_space import FreeSpaceParams, contour_bound, surface_rays
from evmap.maps.sensed import pose_sensed
from evmap.maps.simulated_sonar import SonarCheck, in_sight
from evmap.sources.config_model import Config
from evmap.sources.geometry import point_segment_distances
from evmap.sources.rcd import TYPE_IV, TYPE_NAMES

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["BELIEVED", "add_unidentified", "drop_explained"]

BELIEVED = 0.5
"""A map line with Bel(real) at least this explains the echoes on it (``unidentified.explained_distance``)."""


def add_unidentified(
    bm: BeliefMap, check: SonarCheck, pose: NDArray[np.float64], pose_index: int, config: Config
) -> list[str]:
    """Unmatched actual RCDs of Type I-III in sight become unidentified objects (or reinforce one near).

    Returns the ids of the objects added or reinforced, strongest evidence (Type I) first.
    """
    actual = check.actual
    unmatched = np.setdiff1d(np.arange(len(actual)), check.matched[0])
    unmatched = unmatched[in_sight(check.surfaces, pose, actual, unmatched, config)]
    g = bm.graph
    keep = unmatched[actual.type[unmatched] != TYPE_IV]
    keep = keep[np.argsort(actual.type[keep], kind="stable")]  # the strongest evidence first
    targets = pose[:2] + actual.range[keep, None] * _unit(actual.direction[keep])
    params = config.unidentified
    if (params.explained_distance > 0 or params.behind_contour) and len(keep):  # the map's own echoes are no objects
        keep, targets = _unexplained(bm, check, pose, pose_index, keep, config)
    stage = config.stage_sources("unidentified")
    rows = [source.masses({"rcd_type": np.array([TYPE_NAMES[t] for t in actual.type[keep]])}) for source in stage]
    radius = config.unidentified.merge_radius
    done: list[str] = []
    for j, (k, xy) in enumerate(zip(keep, targets, strict=True)):
        around = [
            n for n in bm.near((*(xy - radius), *(xy + radius)), "points") if g.nodes[n]["kind"] == "unidentified"
        ]
        near = [(np.hypot(*(np.asarray(g.nodes[n]["xy"]) - xy)), n) for n in around]
        near = [c for c in near if c[0] <= radius]
        records = [
            (
                {
                    "stage": "unidentified",
                    "pose": pose_index,
                    "sensor": "sonar",
                    "source": source.name,
                    "rcd_type": TYPE_NAMES[int(actual.type[k])],
                },
                MassFunction.from_dense(bm.frame, batch[j], open_world=True),
            )
            for source, batch in zip(stage, rows, strict=True)
        ]
        if near:
            node = min(near)[1]
            if node in done:
                continue  # at most once per object per pose
        else:
            node = bm.new_id("U")
            bm.add_point(node, xy, "unidentified", bm.vacuous())
        for record, mass in records:
            bm.fold(node, mass, record)
        done.append(node)
    return done


def drop_explained(bm: BeliefMap, config: Config) -> list[str]:
    """Remove the unidentified objects a believed line now explains (within ``unidentified.explained_distance``).

    An object placed where the map had no believed line may find one there as later
    poses extend or confirm the lines: its echo is that line's. Nothing is removed when
    ``explained_distance`` is 0 (the paper's method). Returns the removed ids.
    """
    distance = config.unidentified.explained_distance
    if distance <= 0:
        return []
    g = bm.graph
    removed = []
    for u in bm.unidentified():
        x, y = u.xy
        near = bm.near((x - distance, y - distance, x + distance, y + distance), "lines")
        near = [n for n in sorted(near) if bm.mass(n).belief("real") >= BELIEVED]
        if not near:
            continue
        ends = [bm.ends(n) for n in near]
        p = np.array([g.nodes[a]["xy"] for a, _ in ends], dtype=float)
        q = np.array([g.nodes[b]["xy"] for _, b in ends], dtype=float)
        if point_segment_distances(np.array([x, y]), p, q).min() <= distance:
            bm.remove_point(u.id)
            removed.append(u.id)
    return removed


ARC_SAMPLES = 9
"""Points along an RCD's arc checked against the map's lines."""


def _unexplained(
    bm: BeliefMap, check: SonarCheck, pose: NDArray[np.float64], pose_index: int, keep: NDArray[np.intp], config: Config
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The RCDs of ``keep`` whose arc the map does not explain (module doc), each with its object's place.

    The place is the arc point left unexplained nearest the RCD's direction.
    """
    actual, s, params = check.actual, check.surfaces, config.unidentified
    steps = np.linspace(-0.5, 0.5, ARC_SAMPLES)
    angles = actual.direction[keep, None] + actual.width[keep, None] * steps  # (R, ARC_SAMPLES)
    arc = pose[:2] + actual.range[keep, None, None] * _unit(angles)
    free = np.ones(angles.shape, dtype=bool)
    believed = np.array([bm.mass(line).belief("real") >= BELIEVED for line in s.segment_ids], dtype=bool)
    if params.explained_distance > 0 and believed.any():
        p, q = s.p[believed], s.q[believed]
        free &= point_segment_distances(arc[..., None, :], p, q).min(axis=-1) > params.explained_distance
    sensed = pose_sensed(bm, pose_index) if params.behind_contour else None
    if sensed is not None:
        shape = FreeSpaceParams()
        surfaces = surface_rays(sensed, s.p[believed], s.q[believed], shape.margin, on=True)
        on_wall = _in_line(s.p[believed], s.q[believed], shape.margin)
        bound = contour_bound(surfaces, shape, float(actual.range[keep].max()) + 1.0, on_wall)
        if bound is not None:  # the arc point pulled back by the margins must lie inside the stripe's bound
            back = actual.range[keep, None, None] - params.occlusion_margin - shape.margin
            inner = pose[:2] + np.maximum(back, 0.0) * _unit(angles)
            free &= shapely.contains_xy(bound, inner[..., 0], inner[..., 1])
    best = np.argmin(np.where(free, np.abs(steps), np.inf), axis=1)
    ok = free.any(axis=1)
    return keep[ok], arc[np.flatnonzero(ok), best[ok]]


WALL_ANGLE = np.radians(10.0)
"""A gap in the stripe is a pane in a wall when its chord is this parallel to the believed lines at both ends."""


def _in_line(
    p: NDArray[np.float64], q: NDArray[np.float64], margin: float
) -> Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]]:
    """Which chords a-b cross a gap in a wall: each end on a line p-q (within ``margin``) that the chord continues.

    A gap between two walls meeting at a corner is no pane: its chord would cut the corner off.
    """

    def ok(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
        if not len(p):
            return np.zeros(len(a), dtype=bool)
        chord = (b - a) / np.maximum(np.hypot(*(b - a).T), 1e-12)[:, None]
        d = (q - p) / np.maximum(np.hypot(*(q - p).T), 1e-12)[:, None]
        out = np.ones(len(a), dtype=bool)
        for end in (a, b):
            dist = point_segment_distances(end[:, None], p[None], q[None])  # (K, L)
            near = dist.argmin(axis=1)
            sin = np.abs(chord[:, 0] * d[near, 1] - chord[:, 1] * d[near, 0])
            out &= (dist[np.arange(len(end)), near] <= margin) & (sin <= np.sin(WALL_ANGLE))
        return out

    return ok


def _unit(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit vectors (..., 2) at ``angle``."""
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)
