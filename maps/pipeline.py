"""The paper's fusion pipeline (section III): the order of the stages that fold one observation into a map.

:func:`fold_observation` (``BeliefMap.update``) runs, in the paper's order:

1. Open space: the primitive RCDs of the sonar scan, typed I-IV, give this
   pose's open space (:mod:`evmap.sources.open_space`), added to the map's.
2. Noise elimination (:mod:`evmap.maps.noise`): the new LSL segments, and the
   stored ones that the new open space reaches or the new rays go through, are
   judged against the map's open space; eliminated ones leave the map.
3.-4. Merging and corners near the change (:mod:`evmap.maps.rebuild`).
5.-6. Simulated sonar from the map, with the same sonar model as the world, and
   matching of the two scans' RCDs (:mod:`evmap.maps.simulated_sonar`).
7. Belief reinforcement of matched and missed objects
   (:mod:`evmap.maps.reinforcement`), and unidentified objects from the
   unmatched actual RCDs (:mod:`evmap.maps.unidentified`).

An observation without a sonar scan (a robot log with a laser only) skips the
sonar stages 1 and 5-7: no open space, nothing simulated, matched, reinforced
or unidentified; its outcome says so (``sonar`` None). No stage of such an
update reads the corners, so on a map that starts with one (no lines yet), the
updates without sonar leave the line ends they touch free
(:attr:`BeliefMap.corners_deferred <evmap.maps.belief_map.BeliefMap.corners_deferred>`)
until the next update with sonar, or :meth:`BeliefMap.join_corners
<evmap.maps.belief_map.BeliefMap.join_corners>` (``evmap log`` calls it after the
last scan), joins them into corners over the whole map: corners are found once,
not at every scan, and they are the whole map's.

Only the part of the map near the new observation is rebuilt, so an update
costs what the observation touches: the lines of the segments whose verdict
stage 2 changed, of the new ones and their merging candidates, and of the
lines whose relation to the open space the new open space changes.
Rebuilding the whole map from its stored segments gives the same lines and
corners on the simulated tours and the log excerpts the tests run; over a long
log a few related lines that no later update came near stay apart (they are
among the related pairs ``benchmarks/bench_logs.py`` counts), and the corners
are those of the lines (Freiburg 079's first 1,000 scans with corners found at
every update, as a log with sonar has them: after every update but 6, all 458
at the end).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.maps.contour_free_space import RayParams, ray_tally
from evmap.maps.explained_objects import drop_explained
from evmap.maps.map_json import gc_paused
from evmap.maps.merging import related_pairs
from evmap.maps.noise import COMPUTED, judge, unsettled
from evmap.maps.observation import Observation
from evmap.maps.rebuild import rebuild, refresh_points
from evmap.maps.reinforcement import reinforce
from evmap.maps.sensed import Sensed, features_checkpoint, forget, pose_sensed, remember
from evmap.maps.simulated_sonar import check_sonar
from evmap.maps.unidentified import add_unidentified
from evmap.sources.config_model import Config
from evmap.sources.open_space import open_space
from evmap.sources.rcd import Rcds, extract_rcds
from evmap.sources.readings import SonarScan
from evmap.sources.relation import relation

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["PoseOutcome", "check_observation", "fold_observation", "touched_segments"]


@dataclass(frozen=True, eq=False)
class PoseOutcome:
    """What one update did, for reports and figures.

    Attributes
    ----------
    pose_index : the observation's pose.
    segments : ids (rows of the map's segment store) of the observation's LSL segments.
    primitive : the primitive RCDs of the actual scan (they made the open space).
    open_space : this pose's open space (empty without sonar).
    actual : the actual RCDs at least ``rcd.min_width_deg`` wide.
    predicted_scan : the scan simulated from the map; None without sonar.
    predicted : its RCDs at least ``rcd.min_width_deg`` wide.
    matched : (actual index, predicted index) pairs.
    Without a sonar scan the RCDs and pairs are empty.
    categories : map object id -> ``matched`` or ``missed`` at this pose.
    unidentified : ids of the unidentified objects this pose added or reinforced.
    """

    pose_index: int
    segments: NDArray[np.intp]
    primitive: Rcds
    open_space: shapely.Geometry
    actual: Rcds
    predicted_scan: SonarScan | None
    predicted: Rcds
    matched: tuple[NDArray[np.intp], NDArray[np.intp]]
    categories: dict[str, str] = field(default_factory=dict)
    unidentified: list[str] = field(default_factory=list)


def fold_observation(bm: BeliefMap, obs: Observation, config: Config) -> PoseOutcome:
    """Fold one observation into the map by the paper's pipeline (see the module doc), all or nothing, the
    cyclic garbage collector paused (:func:`~evmap.maps.map_json.gc_paused`)."""
    check_observation(bm, obs, config)
    features = features_checkpoint(bm)
    with gc_paused(), bm.transaction():  # all or nothing: a failure half-way leaves the map as it was
        bm.add_pose(int(obs.pose_index))
        remember(bm, obs)
        try:
            return _fold(bm, obs, config)
        except BaseException:
            forget(bm, obs.pose_index, features)  # what the map does not keep itself
            raise


def _fold(bm: BeliefMap, obs: Observation, config: Config) -> PoseOutcome:
    """The stages of :func:`fold_observation`, after its checks."""
    store = bm.segments
    pose = obs.pose
    version = bm.version  # the objects this update changes: those unidentified objects may lie behind

    # 1. open space of this pose, added to the map's
    if obs.sonar is not None:
        primitive = extract_rcds(obs.sonar, config.rcd, primitive=True)
        space = open_space(obs.sonar, primitive, config.open_space)
        bm.add_open_space(space)
    else:
        primitive, space = _no_rcds(), shapely.MultiPolygon()

    # 2. noise elimination of the new segments and of the stored ones the new open space reaches
    new = store.append(obs.lsl.p, obs.lsl.q, np.full(len(obs.lsl), obs.pose_index), obs.lsl.truth, obs.features)
    touched = touched_segments(bm, new, space, config, pose_sensed(bm, obs.pose_index))
    changed = judge(bm, touched, config)

    # 3.-4. merge and find corners near the change; without sonar, on a map that has no lines yet or defers its
    # corners already, leave them to join_corners (see the module doc)
    defer = obs.sonar is None and (bm.corners_deferred or next(bm.line_ids(), None) is None)
    if defer and not bm.corners_deferred:
        bm.corners_deferred = True
    elif not defer:
        bm.join_corners()  # those a map deferred, before the stages that read them
    touched = _to_rebuild(bm, np.union1d(new, changed), space, config)
    touched_lines = rebuild(bm, touched, config, pose[:2], join=not defer)

    # 5.-7. simulated sonar, matching, reinforcement, unidentified objects
    if obs.sonar is None:
        refresh_points(bm, touched_lines, config)
        none = np.zeros(0, dtype=np.intp)
        return PoseOutcome(obs.pose_index, new, primitive, space, primitive, None, primitive, (none, none))
    check = check_sonar(bm, obs.sonar, primitive, config)
    categories = reinforce(bm, check, obs.pose_index, config)
    unidentified = add_unidentified(bm, check, pose, obs.pose_index, config)
    reinforced_lines = {i for i in categories if i in bm and bm.is_line(i)}
    refresh_points(bm, touched_lines | reinforced_lines, config)
    dropped = set(drop_explained(bm, config, bm.changed_since(version)))
    unidentified = [u for u in unidentified if u not in dropped]
    return PoseOutcome(
        obs.pose_index,
        new,
        primitive,
        space,
        check.actual,
        check.predicted_scan,
        check.predicted,
        check.matched,
        categories,
        unidentified,
    )


def touched_segments(
    bm: BeliefMap, new: NDArray[np.intp], space: shapely.Geometry, config: Config, sensed: Sensed | None = None
) -> NDArray[np.intp]:
    """The stored segments an update must judge again: near a new segment, where the new open space is, or
    where the new pose's rays (``sensed``) went through.

    A segment's verdict changes only when another pose's segment comes to lie on
    it (``lsl_other_poses``), new open space reaches it, or a new pose's rays go
    through it (``contour_free``, ``lsl_persistence``), so the rows whose boxes
    meet a new segment's box (grown by the merging reach) or a piece of the new
    open space's box, and those that at least ``min_passes`` of the new rays
    pass through, are all: what the observation touches, at any map size. A
    segment eliminated by the map's poses before the latest
    :data:`~evmap.maps.sensed.LATEST_POSES` is settled: noise for good, not judged
    again (a place passed again and again does not pile up its phantoms' work).
    """
    store = bm.segments
    margin = config.merge.distance + config.merge.gap
    boxes = [store.boxes(new)]
    if not space.is_empty:
        boxes.append(shapely.bounds(shapely.get_parts(space)))
    grown = np.concatenate(boxes).reshape(-1, 4) + np.array([-margin, -margin, margin, margin])
    found = np.unique(np.concatenate([new, store.near(grown)]))
    if sensed is not None and len(sensed.bearing):
        reach = min(sensed.reach, config.sensors.lsl.max_range)
        seen = unsettled(bm, np.setdiff1d(store.near((*(sensed.origin - reach), *(sensed.origin + reach))), found))
        params = RayParams.of_stripe(config.sensors.lsl)
        passes = ray_tally(store.p[seen], store.q[seen], store.pose[seen], [sensed], params).passes
        found = np.union1d(found, seen[passes >= params.min_passes])
    return unsettled(bm, found)


def _to_rebuild(bm: BeliefMap, changed: NDArray[np.intp], space: shapely.Geometry, config: Config) -> NDArray[np.intp]:
    """The segments whose lines an update rebuilds: the ``changed`` ones (new, or judged anew to another
    verdict), those that are merging's candidates with a changed one no line holds (new, or no longer noise:
    it may join them; the rebuild finds merging's candidates among lines), and the segments of the lines
    whose relation to the open space the new open space ``space`` changes (a line's is its own, not its
    segments'). The lines of the other segments judged again keep their evidence: it is made of their
    segments' verdicts."""
    store = bm.segments
    loose = changed[~store.eliminated[changed] & (store.line[changed] == "")]
    margin = config.merge.distance + config.merge.gap
    near = unsettled(bm, store.near(store.boxes(loose) + np.array([-margin, -margin, margin, margin])))
    near = near[~store.eliminated[near]]
    others = (store.p[near], store.q[near])
    _, joins, _ = related_pairs(store.p[loose], store.q[loose], config.merge, others, mergeable=True)
    return np.unique(np.concatenate([changed, near[joins], _members_reached(bm, space, config)]))


def _members_reached(bm: BeliefMap, space: shapely.Geometry, config: Config) -> NDArray[np.intp]:
    """The segments of the map's lines that the open space ``space`` meets and whose relation to the map's open
    space it changes."""
    if space.is_empty:
        return np.zeros(0, dtype=np.intp)
    ids = sorted(bm.near(shapely.bounds(shapely.get_parts(space)), "lines"))
    data = [bm.graph.edge(*bm.ends(lid)) for lid in ids]
    fits = np.array([d["fit"] for d in data], dtype=float).reshape(-1, 2, 2)
    met = np.flatnonzero(shapely.intersects(shapely.linestrings(fits), space))
    if not len(met):
        return np.zeros(0, dtype=np.intp)
    p, q = fits[met, 0], fits[met, 1]
    ends = np.concatenate([p, q])
    now = relation(p, q, bm.open_space_parts_near((*ends.min(axis=0), *ends.max(axis=0))), config.noise)
    was = [(data[k]["history"] or [{}])[0].get("relation") for k in met.tolist()]  # none: a line added by hand
    moved = met[now != np.array(was)].tolist()
    return np.unique(np.array([m for k in moved for m in data[k]["members"]], dtype=np.intp))


def check_observation(bm: BeliefMap, obs: Observation, config: Config) -> None:
    """Refuse, before the map changes, an observation the map cannot fold with this config."""
    if not isinstance(obs, Observation):
        raise TypeError(
            f"a map is updated with an Observation (evmap.maps.observation: observation_from_arrays, observation_from_log"
            f" or observe), got {type(obs).__name__}"
        )
    if config.frame != bm.frame or config.rule != bm.rule:
        raise ValueError(
            f"{config.name}: the config's frame and rule ({list(config.frame.elements)}, {config.rule}) "
            f"are not the map's ({list(bm.frame.elements)}, {bm.rule})"
        )
    if obs.pose_index in bm.poses:
        raise ValueError(
            f"pose {obs.pose_index} is already folded into this map: its evidence would count twice "
            "(give each observation its own pose_index)"
        )
    brought = set(obs.features)
    for source in config.stage_sources("noise_elimination"):
        if source.feature not in brought | set(COMPUTED):
            raise ValueError(
                f"source {source.name!r} reads feature {source.feature!r}, which the observation does not bring "
                f"(it brings {sorted(brought)}; the pipeline computes {', '.join(COMPUTED)})"
            )
    stored = set(bm.segments.features)
    if len(bm.segments) and brought != stored:
        raise ValueError(f"the observation brings features {sorted(brought)}, the map's segments have {sorted(stored)}")


def _no_rcds() -> Rcds:
    """The RCDs of no scan."""
    i, f = np.zeros(0, dtype=np.intp), np.zeros(0)
    return Rcds(
        i, i, i, f, f, f, f, np.zeros(0, dtype=np.int_), f, f, np.zeros(0, dtype=str), np.zeros(0, dtype=np.int_)
    )
