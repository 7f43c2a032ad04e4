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
believed lines, and of the chords, at most ``unidentified.window_width`` long,
across gaps between believed lines that the chord continues: panes in a wall)
is explained too: sound does not come back
through the surface the stripe measured, so the echo is a multiple reflection.
An RCD makes its object at the unexplained arc point nearest where the sonar
model puts its target, at most ``unidentified.merge_radius`` from it along the
arc (one beside a wall, a window in it, on the part beside the line), and none
where the arc is explained that near: farther along the arc lies no place of
that target. An object that a
believed line comes to explain as later poses extend the lines is removed
(:func:`evmap.maps.explained_objects.drop_explained`).

With ``unidentified.masked_aim``, an object is placed where the sonar model
says its target lies (:func:`reflector_bearings`), not at its RCD's direction:
the sonar reports the first echo, so a Type II RCD is cut on its shorter
neighbour's side by a nearer echo (a corner heard beside a nearer wall), and
its target lies toward that side.

With ``unidentified.pane_in_line``, a run of the actual scan the paper's rule takes
no object from (Type IV, or narrower than ``rcd.min_width_deg``: a nearer target
beside the beam; or matched to the map's wall end beside a pane) is a pane's echo
where a pane in line with a believed line, or between two frames the pose's stripe
measured on its line, would give it, and makes an object at the foot of the pose's
perpendicular on that line (:mod:`evmap.maps.pane_echoes`).

With ``unidentified.pane_width``, a believed object that a pose's stripe saw
through (no stripe point near it) is also a pane that width across, square to
the bearing that pose heard it at (a glass pane heard at normal incidence: the
stripe goes through it, the sound does not). An object
whose every path to the poses that heard it crosses another object's pane, and
lies more than ``merge_radius`` beyond it, came back through that pane: a
double bounce off the glass, placed along its first leg. It is removed
(:mod:`evmap.maps.explained_objects`).

With ``unidentified.behind_depth``, objects are judged again as lines become
believed: one lying more than that beyond the stripe's contour
(:func:`evmap.maps.stripe_contour.stripe_bound`, as ``behind_contour``) of every
pose that heard it is a multiple reflection made before the lines it lies behind
were believed, and is removed (:func:`~evmap.maps.explained_objects.behind_stripes`; only the objects the
update's changed lines may hide are judged).

With ``unidentified.mirror_tolerance``, an object at the mirror image of a
believed corner, wall end or object in the line of a believed wall or of a pane's face,
from every pose that heard it, is that target's echo off the wall or the glass,
and is removed (:mod:`evmap.maps.mirror_echoes`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.maps.free_space import FreeSpaceParams
from evmap.maps.pane_echoes import pane_echoes
from evmap.maps.sensed import pose_sensed
from evmap.maps.simulated_sonar import SonarCheck, in_sight
from evmap.maps.stripe_contour import stripe_bound
from evmap.sources.config_model import Config
from evmap.sources.geometry import point_segment_distances
from evmap.sources.params import SonarParams
from evmap.sources.rcd import TYPE_II, TYPE_IV, TYPE_NAMES, Rcds
from evmap.sources.sim.sonar import echo_halfwidth

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["BELIEVED", "add_unidentified", "reflector_bearings"]

BELIEVED = 0.5
"""A map line with Bel(real) at least this explains the echoes on it (``unidentified.explained_distance``)."""


def add_unidentified(
    bm: BeliefMap, check: SonarCheck, pose: NDArray[np.float64], pose_index: int, config: Config
) -> list[str]:
    """Unmatched actual RCDs of Type I-III in sight, and the runs that are panes' echoes
    (:func:`~evmap.maps.pane_echoes.pane_echoes`), become unidentified objects (or reinforce one near).

    Returns the ids of the objects added or reinforced, strongest evidence (Type I) first.
    """
    actual = check.actual
    unmatched = np.setdiff1d(np.arange(len(actual)), check.matched[0])
    unmatched = unmatched[in_sight(check.surfaces, pose, actual, unmatched, config)]
    g = bm.graph
    keep = unmatched[actual.type[unmatched] != TYPE_IV]
    params = config.unidentified
    sonar = check.predicted_scan.params  # the actual scan's: the prediction is simulated with them
    aim = reflector_bearings(actual, keep, sonar) if params.masked_aim else actual.direction[keep]
    targets = pose[:2] + actual.range[keep, None] * _unit(aim)
    explain = (params.explained_distance > 0 or params.behind_contour) and len(keep)
    believed = np.zeros(len(check.surfaces.segment_ids), dtype=bool)
    if explain or params.pane_in_line > 0:
        believed[:] = [bm.mass(line).belief("real") >= BELIEVED for line in check.surfaces.segment_ids]
    if explain:  # the map's own echoes are no objects
        keep, targets = _unexplained(bm, check, pose, pose_index, keep, aim, believed, config)
    sensed = pose_sensed(bm, pose_index) if params.pane_in_line > 0 else None
    panes, feet = pane_echoes(check, believed, pose, config, None if sensed is None else sensed.points)
    types = np.concatenate([actual.type[keep], check.runs.type[panes]])
    targets = np.concatenate([targets, feet])
    order = np.argsort(types, kind="stable")  # the strongest evidence first
    types, targets = types[order], targets[order]
    stage = config.stage_sources("unidentified")
    rows = [source.masses({"rcd_type": np.array([TYPE_NAMES[t] for t in types])}) for source in stage]
    radius = config.unidentified.merge_radius
    done: list[str] = []
    for j, (rcd_type, xy) in enumerate(zip(types, targets, strict=True)):
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
                    "rcd_type": TYPE_NAMES[int(rcd_type)],
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


ARC_SAMPLES = 9
"""Points along an RCD's arc checked against the map's lines (and the point it aims at)."""


def _unexplained(
    bm: BeliefMap,
    check: SonarCheck,
    pose: NDArray[np.float64],
    pose_index: int,
    keep: NDArray[np.intp],
    aim: NDArray[np.float64],
    believed: NDArray[np.bool_],
    config: Config,
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The RCDs of ``keep`` whose arc the map does not explain near their aim (module doc), each with its object's
    place.

    The place is the arc point left unexplained nearest the bearing ``aim`` (one per RCD of ``keep``), at most
    ``unidentified.merge_radius`` from it along the arc.
    """
    actual, s, params = check.actual, check.surfaces, config.unidentified
    shift = aim - actual.direction[keep]  # within the RCD's width; 0 where aimed at its direction
    offsets = np.column_stack([actual.width[keep, None] * np.linspace(-0.5, 0.5, ARC_SAMPLES), shift])
    angles = actual.direction[keep, None] + offsets  # (R, ARC_SAMPLES + 1): the arc's samples and the aim
    arc = pose[:2] + actual.range[keep, None, None] * _unit(angles)
    free = np.ones(angles.shape, dtype=bool)
    if params.explained_distance > 0 and believed.any():
        p, q = s.p[believed], s.q[believed]
        free &= point_segment_distances(arc[..., None, :], p, q).min(axis=-1) > params.explained_distance
    sensed = pose_sensed(bm, pose_index) if params.behind_contour else None
    if sensed is not None:
        bound = stripe_bound(sensed, s.p[believed], s.q[believed], params, float(actual.range[keep].max()) + 1.0)
        if bound is not None:  # the arc point pulled back by the margins must lie inside the stripe's bound
            back = actual.range[keep, None, None] - params.occlusion_margin - FreeSpaceParams().margin
            inner = pose[:2] + np.maximum(back, 0.0) * _unit(angles)
            free &= shapely.contains_xy(bound, inner[..., 0], inner[..., 1])
    # the sonar model puts the target at the aim: the object moves along the arc no farther than one object's
    # extent (merge_radius) from it; an RCD whose arc is explained that near makes no object
    off_aim = np.abs(offsets - shift[:, None])
    free &= actual.range[keep, None] * off_aim <= params.merge_radius
    best = np.argmin(np.where(free, off_aim, np.inf), axis=1)
    ok = free.any(axis=1)
    return keep[ok], arc[np.flatnonzero(ok), best[ok]]


def reflector_bearings(actual: Rcds, which: NDArray[np.intp], params: SonarParams) -> NDArray[np.float64]:
    """Where the targets of the RCDs ``which`` lie (bearings, rad), by the sonar model (``unidentified.masked_aim``).

    The sonar reports the first echo, so a Type II RCD, one neighbour shorter, is cut on that side by a
    nearer echo, and its target lies toward it: one detection half-width
    (:func:`~evmap.sources.sim.sonar.echo_halfwidth`) of the strongest target, a wall or corner, at its range
    from its free edge's beam axis, kept within the RCD, between its direction and its cut edge. Other
    RCDs are not cut: their targets lie at their directions.

    >>> from evmap.sources.params import RcdParams, SonarParams
    >>> from evmap.sources.rcd import extract_rcds
    >>> from evmap.sources.readings import SonarScan
    >>> angles = np.radians(np.arange(160.0, 190.0))  # a corner at 7.98 m, 171.7 deg; a wall, 7.9 m, from 173
    >>> ranges = np.where(angles < np.radians(165), 10.0, np.where(angles < np.radians(173), 7.98, 7.9))
    >>> rcds = extract_rcds(SonarScan.from_readings(angles, ranges, SonarParams()), RcdParams(min_width_deg=0))
    >>> rcds.type.tolist(), np.degrees(rcds.direction).round(1).tolist()  # the corner's is cut at 173 deg
    ([2, 1], [168.5, -179.0])
    >>> np.degrees(reflector_bearings(rcds, np.array([0, 1]), SonarParams())).round(1).tolist()
    [171.8, -179.0]
    """
    d, width, r = actual.direction[which], actual.width[which], actual.range[which]
    step = width / np.maximum(actual.count[which], 1)
    first, last = d - (width - step) / 2, d + (width - step) / 2  # the beam axes of its first and last readings
    half = echo_halfwidth(np.ones(len(which)), r, params)
    cut = (actual.type[which] == TYPE_II) & (half >= 0)
    low = cut & (actual.prev_range[which] < r)  # the shorter neighbour is before the first reading
    high = cut & ~low & (actual.next_range[which] < r)
    aim = d.copy()
    aim[low] = np.clip(last[low] - half[low], first[low], d[low])
    aim[high] = np.clip(first[high] + half[high], d[high], last[high])
    return aim


def _unit(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit vectors (..., 2) at ``angle``."""
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)
