"""Noise elimination (paper, section III, Table 1): sonar open space and LSL length, fused.

Each segment gets a mass function from every source of the config's
``noise_elimination`` stage (by default Table 1: the sonar's judgement from the
segment's relation to the open space, and the LSL's from its length), combined
by the config's rule; a segment whose fused mass of ``{noise}`` is strictly
above ``noise.threshold`` is eliminated.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from evidential import combine_batch
from evmap.maps.contour_free_space import (
    RayParams,
    ray_features,
    ray_tally,
    segments_facing,
    stripe_edges,
    went_on,
)
from evmap.maps.merging import related_pairs
from evmap.maps.sensed import LATEST_POSES, SENSED_FEATURES, Sensed, keep_features, kept_features, sensed_near
from evmap.maps.sonar_forward import SonarForwardParams, free_ends, sonar_forward
from evmap.sources.config_model import Config
from evmap.sources.params import MergeParams
from evmap.sources.relation import relation

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap
    from evmap.maps.segments import SegmentStore

__all__ = [
    "COMPUTED",
    "NoiseEvidence",
    "judge",
    "noise_evidence",
    "other_poses",
    "settled",
    "unsettled",
]

COMPUTED = ("relation", "length", "lsl_other_poses", "contour_free", "lsl_persistence", "sonar_forward")
"""The features the pipeline computes for the noise-elimination sources (an observation brings any others)."""


@dataclass(frozen=True, eq=False)
class NoiseEvidence:
    """The noise-elimination stage's verdict on N segments.

    Attributes
    ----------
    relation : (N,) ``outside | partly_inside | inside``.
    length : (N,) segment lengths (m).
    fused : (N, 2**n) the combined mass functions (columns by bitmask).
    conflict : (N,) K, the conjunctive mass on the empty set between the stage's sources.
    eliminated : (N,) fused mass of ``{noise}`` above the threshold.
    """

    relation: NDArray[np.str_]
    length: NDArray[np.float64]
    fused: NDArray[np.float64]
    conflict: NDArray[np.float64]
    eliminated: NDArray[np.bool_]


def noise_evidence(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    open_space: shapely.Geometry,
    config: Config,
    features: Mapping[str, ArrayLike] | None = None,
) -> NoiseEvidence:
    """Judge segments p-q against the sonar open space with the config's noise-elimination sources.

    The sources read the features ``relation`` and ``length`` (computed here) and
    any others given in ``features`` (one value per segment; the pipeline gives
    ``lsl_other_poses``, see :func:`other_poses`, 0 when not given, and the
    features of the sensed rays and scans, see :func:`judge`, no evidence when not given).

    >>> from evmap.sources.config import load_config
    >>> room = shapely.box(0, 0, 4, 4)
    >>> ev = noise_evidence(np.array([[1.0, 1.0], [5.0, 0.0]]), np.array([[1.2, 1.0], [5.0, 2.0]]), room, load_config())
    >>> ev.relation.tolist(), ev.eliminated.tolist()
    (['inside', 'outside'], [True, False])
    >>> ev.fused[0].round(3).tolist()  # empty, real, noise, real|noise
    [0.0, 0.171, 0.737, 0.092]
    """
    frame = config.frame
    if "noise" not in frame.elements:
        raise ValueError(f"{config.name}: noise elimination needs an element 'noise' in the frame {frame!r}")
    features = {
        "lsl_other_poses": np.zeros(len(p), dtype=np.intp),  # seen from one pose, unless told otherwise
        **{name: np.full(len(p), none) for name, none in SENSED_FEATURES.items()},
        **(features or {}),
        "relation": relation(p, q, open_space, config.noise),
        "length": np.hypot(*(q - p).T),
    }
    batches = [source.masses(features) for source in config.stage_sources("noise_elimination")]
    fused = np.ascontiguousarray(combine_batch(*batches, rule=config.rule))
    k = combine_batch(*batches, rule="conjunctive")[:, 0] if len(batches) > 1 else np.zeros(len(p))
    again = np.flatnonzero(np.asarray(features["lsl_other_poses"]) > 0)
    repeat = config.stage_sources("repeated_observation")
    if len(again) and repeat:  # evidence of repeated observations, folded in where there is some
        picked = {name: np.asarray(values)[again] for name, values in features.items()}
        fused[again] = combine_batch(fused[again], *(s.masses(picked) for s in repeat), rule=config.rule)
    eliminated = fused[:, frame.mask("noise")] > config.noise.threshold
    return NoiseEvidence(features["relation"], features["length"], fused, np.ascontiguousarray(k), eliminated)


def judge(bm: BeliefMap, ids: NDArray[np.intp], config: Config) -> NDArray[np.intp]:
    """Noise elimination of the map's stored segments ``ids`` against the map's open space; returns those of
    them whose relation, mass, fate or sensed features it changed (what their lines' evidence is made of).

    Writes each segment's relation, fused mass, conflict and fate into the map's
    segment store; the open space and the other poses' segments are looked up
    near the segments only, the :func:`settled` ones left out. The features of the sensed readings
    (:mod:`evmap.maps.sensed`) are computed when a source reads them:
    ``contour_free`` and ``lsl_persistence`` (:mod:`evmap.maps.contour_free_space`)
    and ``sonar_forward`` (:mod:`evmap.maps.sonar_forward`), from the readings of
    the latest :data:`~evmap.maps.sensed.LATEST_POSES` poses that reach the segments.

    Rays of a sensor that reports every surface a ray lit go on beyond points on the segments judged noise
    (:func:`~evmap.maps.contour_free_space.went_on`); when this judgement finds more of them noise, the
    contour's features are computed again with those rays, and the segments judged again.
    """
    store = bm.segments
    if not len(ids):
        return ids
    before = _verdicts(bm, ids)
    p, q, pose = store.p[ids], store.q[ids], store.pose[ids]
    ends = np.concatenate([p, q])
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    space = bm.open_space_parts_near((*lo, *hi))
    near = unsettled(bm, _near_each(store, p, q, config.merge.distance + config.merge.gap))
    cp, cq = store.p[near], store.q[near]
    seen = other_poses(p, q, pose, cp, cq, store.pose[near], config.merge)
    features = {**{name: column[ids] for name, column in store.features.items()}, "lsl_other_poses": seen}
    read = {
        source.feature
        for stage in ("noise_elimination", "repeated_observation")
        for source in config.stage_sources(stage)
    }
    poses = sensed_near(bm, (*lo, *hi), config.sensors.lsl.max_range, LATEST_POSES)
    params = RayParams.of_stripe(config.sensors.lsl)
    beyond = _beyond(store, poses, params) if read & {"contour_free", "lsl_persistence"} else None
    if beyond is not None:
        features |= ray_features(ray_tally(p, q, pose, poses, params, beyond or None), params)
    if "sonar_forward" in read:
        sonar = SonarForwardParams()
        heard = [s for s in poses if s.sonar is not None]  # no sonar reading: silent, nothing to compute
        free = np.zeros((len(p), 2), dtype=bool)
        if heard:
            free = free_ends(p, q, cp, cq, sonar.end_clearance) & stripe_edges(p, q, pose, poses, params)
        sunlit = [_judged(store, s.pose_index)[0] for s in heard]
        features["sonar_forward"] = sonar_forward(p, q, free, heard, sonar, sunlit, params.max_range)
    ev = noise_evidence(p, q, space, config, features)
    if beyond and (ev.eliminated & ~store.eliminated[ids]).any():
        flipped = set(pose[ev.eliminated != store.eliminated[ids]].tolist())  # the poses whose rays went on anew
        store.write(ids, eliminated=ev.eliminated)  # a second look, through what this judgement found noise
        again = [_went_on(store, s, params) if s.pose_index in flipped else b for s, b in zip(poses, beyond)]
        ev, features = _second_look(store, ids, space, config, poses, (beyond, again), features, ev)
    keep_features(bm, ids, {name: features[name] for name in SENSED_FEATURES if name in features})
    store.write(ids, relation=ev.relation, mass=ev.fused, conflict=ev.conflict, eliminated=ev.eliminated)
    after = _verdicts(bm, ids)
    return ids[np.logical_or.reduce([(a != b).reshape(len(ids), -1).any(axis=1) for a, b in zip(before, after)])]


def _verdicts(bm: BeliefMap, ids: NDArray[np.intp]) -> list[NDArray[np.generic]]:
    """What :func:`judge` writes of the segments ``ids``: relation, mass, fate and sensed features."""
    store = bm.segments
    return [store.relation[ids], store.mass[ids], store.eliminated[ids], *kept_features(bm, ids).values()]


def settled(bm: BeliefMap, rows: NDArray[np.intp]) -> NDArray[np.bool_]:
    """Which of the map's stored segments ``rows`` are settled: eliminated, and by poses before the map's latest
    :data:`~evmap.maps.sensed.LATEST_POSES`. Noise for good: never judged again, nor evidence for the segments judged (another
    pose's segment on one, or one continuing its end, counts only if it is not settled), so that a place passed
    again and again does not pile up its phantoms in every lookup."""
    store = bm.segments
    return store.eliminated[rows] & ~np.isin(store.pose[rows], bm.poses[-LATEST_POSES:])


def unsettled(bm: BeliefMap, rows: NDArray[np.intp]) -> NDArray[np.intp]:
    """The ``rows`` that are not :func:`settled`; the settled ones the segment store's index forgets (noise for
    good: no later lookup finds them)."""
    old = settled(bm, rows)
    bm.segments.forget(rows[old])
    return rows[~old]


def _beyond(store: SegmentStore, poses: list[Sensed], params: RayParams) -> list[NDArray[np.bool_]]:
    """Per pose, the rays that went on beyond their points on the pose's segments now judged noise
    (:func:`~evmap.maps.contour_free_space.went_on`); an empty list when no pose's sensor reports every surface a
    ray lit (then no ray went on)."""
    return [_went_on(store, s, params) for s in poses] if any(s.all_returns for s in poses) else []


def _judged(store: SegmentStore, pose: int) -> tuple[tuple[NDArray[np.float64], ...], tuple[NDArray[np.float64], ...]]:
    """The ends (p, q) of the pose's segments now judged noise, and of those kept."""
    rows = store.seen_from(pose)
    noise, kept = rows[store.eliminated[rows]], rows[~store.eliminated[rows]]
    return (store.p[noise], store.q[noise]), (store.p[kept], store.q[kept])


def _went_on(store: SegmentStore, s: Sensed, params: RayParams) -> NDArray[np.bool_]:
    """:func:`~evmap.maps.contour_free_space.went_on` of the pose ``s`` through its segments now judged noise."""
    if not s.all_returns:
        return np.zeros(len(s.range), dtype=bool)
    return went_on(s, *_judged(store, s.pose_index), params)


def _second_look(
    store: SegmentStore,
    ids: NDArray[np.intp],
    space: shapely.Geometry,
    config: Config,
    poses: list[Sensed],
    beyond: tuple[list[NDArray[np.bool_]], list[NDArray[np.bool_]]],
    features: dict[str, NDArray[np.generic]],
    ev: NoiseEvidence,
) -> tuple[NoiseEvidence, dict[str, NDArray[np.generic]]]:
    """:func:`judge`'s verdict ``ev`` on the segments ``ids`` again, the rays that went on beyond their points
    (:func:`_beyond`) before and after the segments it has just found noise: only the segments whose bearings from
    a pose hold a ray of it that changed are tallied again, and only those whose features changed judged again (a
    segment's verdict is its own)."""
    params = RayParams.of_stripe(config.sensors.lsl)
    before, again = beyond
    p, q, pose = store.p[ids], store.q[ids], store.pose[ids]
    rows = segments_facing(p, q, poses, [s.bearing[a != b] for s, a, b in zip(poses, before, again, strict=True)])
    new = ray_features(ray_tally(p[rows], q[rows], pose[rows], poses, params, again), params)
    moved = rows[np.logical_or.reduce([new[k] != features[k][rows] for k in new], initial=False)]
    if not len(moved):
        return ev, features
    features = dict(features)
    for name, values in new.items():
        features[name] = features[name].copy()
        features[name][rows] = values
    part = noise_evidence(p[moved], q[moved], space, config, {k: np.asarray(v)[moved] for k, v in features.items()})
    fields = {name: getattr(ev, name).copy() for name in ("relation", "length", "fused", "conflict", "eliminated")}
    for name, values in fields.items():
        values[moved] = getattr(part, name)
    return NoiseEvidence(**fields), features


def _near_each(store: SegmentStore, p: NDArray[np.float64], q: NDArray[np.float64], reach: float) -> NDArray[np.intp]:
    """The stored segments whose boxes meet the box of one of the segments p-q grown by ``reach``, sorted."""
    lo = np.minimum(p, q) - reach
    hi = np.maximum(p, q) + reach
    found = store.near((*lo.min(axis=0), *hi.max(axis=0)))
    box = store.boxes(found)
    flo, fhi = box[:, :2], box[:, 2:]
    meets = (flo[:, None, 0] <= hi[:, 0]) & (fhi[:, None, 0] >= lo[:, 0])  # (found, ids), edges touching
    meets &= (flo[:, None, 1] <= hi[:, 1]) & (fhi[:, None, 1] >= lo[:, 1])
    return found[meets.any(axis=1)]


def other_poses(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    pose: NDArray[np.intp],
    cp: NDArray[np.float64],
    cq: NDArray[np.float64],
    cpose: NDArray[np.intp],
    params: MergeParams,
) -> NDArray[np.intp]:
    """For each segment p-q, how many other poses saw an LSL segment on it (repeated observation).

    A candidate cp-cq from another pose lies on a segment when the two are
    related as merging relates lines (:func:`evmap.maps.merging.related_pairs`:
    directions, offsets and gap within the merging tolerances). A real wall is
    seen again from the next pose; a sunlight phantom, drawn anew for every
    pose, hardly ever is.

    >>> wall = np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]]), np.array([0])
    >>> seen = np.array([[0.5, 0.01], [0.5, 0.0], [3.0, 0.0]]), np.array([[1.5, 0.01], [0.5, 1.0], [4.0, 0.0]])
    >>> other_poses(*wall, *seen, np.array([1, 2, 3]), MergeParams()).tolist()
    [1]
    """
    n = len(p)
    if n and (pose == pose[0]).all():  # then a candidate from that pose counts for none of the segments
        keep = cpose != pose[0]
        cp, cq, cpose = cp[keep], cq[keep], cpose[keep]
    if not n or not len(cp):
        return np.zeros(n, dtype=np.intp)
    i, j, _ = related_pairs(p, q, params, others=(cp, cq))
    other = cpose[j] != pose[i]
    i, seen = i[other], cpose[j[other]]
    if not len(i):
        return np.zeros(n, dtype=np.intp)
    span = seen.max() - seen.min() + 1
    return np.bincount(np.unique(i * span + seen - seen.min()) // span, minlength=n).astype(np.intp)
