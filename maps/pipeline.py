"""The paper's fusion pipeline (section III), folding one observation at a time into a belief map.

:func:`fold_observation` (``BeliefMap.update``) runs the stages in the paper's order:

1. Open space: the primitive RCDs of the sonar scan, typed I-IV, give this
   pose's open space, united with the map's (``evmap.maps.BeliefMap.open_space``).
2. Noise elimination: the new LSL segments, and the stored ones that the new
   open space reaches, are judged against the united open space
   (:mod:`evmap.maps.noise`); eliminated ones leave the map.
3. Merging (:mod:`evmap.maps.merging`): the surviving segments near the change, and
   every segment of a map line they touch, are merged into lines. A line's
   mass is recomputed from its merged length and relation (its pieces are not
   independent evidence); the sonar evidence of the lines it replaces carries over.
4. Corners (:mod:`evmap.maps.corners`): line ends near the change meet at corners;
   the other ends are free end points.
5. Simulated sonar from the map, with the same sonar model as the world; RCDs
   of the actual and the simulated scans with the same extractor.
6. Matching (:mod:`evmap.maps.matching`) by direction and mean range.
7. Belief reinforcement: every map object that a simulated direct-echo RCD
   comes from gets the ``reinforcement`` stage's evidence, ``matched`` or
   ``missed``, at most once per pose (a corner or free end passes it on to its
   lines, a corner keeps it too); objects sonar cannot see from the pose get
   none and keep their mid-level belief. An actual RCD of Type I-III that matched
   nothing becomes (or reinforces, within ``unidentified.merge_radius``) an
   ``unidentified`` object at its range and direction.

Only the part of the map near the new observation is rebuilt, so an update
costs what the observation touches. Rebuilding the whole map from its stored
segments gives the same lines.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import MassFunction, combine
from evmap.maps.belief_map import BeliefMap
from evmap.maps.corners import find_corners
from evmap.maps.matching import match_rcds
from evmap.maps.merging import Merged, merge_segments
from evmap.maps.noise import COMPUTED, noise_evidence, other_poses
from evmap.maps.observation import Observation
from evmap.maps.segments import SegmentStore
from evmap.sources.config import Config
from evmap.sources.open_space import open_space
from evmap.sources.rcd import Rcds, extract_rcds
from evmap.sources.sim.sonar import SonarScan, simulate_scan
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import cast_rays

__all__ = ["PoseOutcome", "fold_observation", "map_surfaces", "new_map"]

_ROMAN = {1: "I", 2: "II", 3: "III", 4: "IV"}
_SURFACE_KINDS = ("corner", "endpoint")


@dataclass(frozen=True, eq=False)
class PoseOutcome:
    """What one update did, for reports and figures.

    Attributes
    ----------
    pose_index : the observation's pose.
    segments : ids (rows of the map's segment store) of the observation's LSL segments.
    primitive : the primitive RCDs of the actual scan (they made the open space).
    open_space : this pose's open space.
    actual : the actual RCDs at least ``rcd.min_width_deg`` wide.
    predicted_scan : the scan simulated from the map.
    predicted : its RCDs at least ``rcd.min_width_deg`` wide.
    matched : (actual index, predicted index) pairs.
    categories : map object id -> ``matched`` or ``missed`` at this pose.
    unidentified : ids of the unidentified objects this pose added or reinforced.
    """

    pose_index: int
    segments: NDArray[np.intp]
    primitive: Rcds
    open_space: shapely.Geometry
    actual: Rcds
    predicted_scan: SonarScan
    predicted: Rcds
    matched: tuple[NDArray[np.intp], NDArray[np.intp]]
    categories: dict[str, str] = field(default_factory=dict)
    unidentified: list[str] = field(default_factory=list)


def new_map(config: Config) -> BeliefMap:
    """An empty belief map for a config: its frame, its rule, no segments yet.

    >>> from evmap.sources.config import load_config
    >>> new_map(load_config())
    BeliefMap(points=0, lines=0, frame=['real', 'noise'], rule='dempster')
    """
    return BeliefMap(
        config.frame, config.rule, config=config.to_data(), next_id={"L": 1, "C": 1, "E": 1, "U": 1}, poses=[]
    )


def fold_observation(bm: BeliefMap, obs: Observation, config: Config) -> PoseOutcome:
    """Fold one observation into the map by the paper's pipeline (see the module doc)."""
    if config.frame != bm.frame or config.rule != bm.rule:
        raise ValueError(
            f"{config.name}: the config's frame and rule ({list(config.frame.elements)}, {config.rule}) "
            f"are not the map's ({list(bm.frame.elements)}, {bm.rule})"
        )
    store: SegmentStore = bm.segments
    _check_observation(bm, obs, config)
    bm.graph.graph["poses"].append(int(obs.pose_index))
    pose = obs.pose

    # 1. open space of this pose, united with the map's
    primitive = extract_rcds(obs.sonar, config.rcd, primitive=True)
    space = open_space(obs.sonar, primitive, config.open_space)
    bm.add_open_space(space)

    # 2. noise elimination of the new segments and of the stored ones the new open space reaches
    new = store.append(obs.lsl.p, obs.lsl.q, np.full(len(obs.lsl), obs.pose_index), obs.lsl.truth, obs.features)
    margin = config.merge.distance + config.merge.gap
    bounds = np.array(shapely.total_bounds(space)) if not space.is_empty else np.array([*pose[:2], *pose[:2]])
    if len(new):
        ends = np.concatenate([store.p[new], store.q[new]])
        bounds = np.r_[np.minimum(bounds[:2], ends.min(axis=0)), np.maximum(bounds[2:], ends.max(axis=0))]
    touched = store.near(tuple(bounds + np.array([-margin, -margin, margin, margin])))
    _judge(bm, touched, config)

    # 3.-4. merge and find corners near the change
    touched_lines = _rebuild(bm, touched, config, pose[:2])

    # 5.-7. simulated sonar, matching, reinforcement, unidentified objects
    reach = obs.sonar.params.max_range
    surfaces = map_surfaces(bm, (pose[0] - reach, pose[1] - reach, pose[0] + reach, pose[1] + reach))
    predicted_scan = simulate_scan(surfaces, pose, obs.sonar.params)
    actual = extract_rcds(obs.sonar, config.rcd)
    predicted = extract_rcds(predicted_scan, config.rcd)
    ai, si = match_rcds(actual.direction, actual.range, predicted.direction, predicted.range, config.matching)
    masked = _masked(obs.sonar, predicted_scan, predicted, config)
    categories = _reinforce(bm, predicted, si, masked, obs.pose_index, config)
    unmatched = np.setdiff1d(np.arange(len(actual)), ai)
    in_sight = unmatched[_in_sight(surfaces, pose, actual, unmatched, config)]
    unidentified = _unidentified(bm, actual, in_sight, obs, config)
    reinforced_lines = {i for i in categories if i in bm and _is_line(bm, i)}
    _refresh_points(bm, touched_lines | reinforced_lines, config)
    return PoseOutcome(
        obs.pose_index, new, primitive, space, actual, predicted_scan, predicted, (ai, si), categories, unidentified
    )


def _check_observation(bm: BeliefMap, obs: Observation, config: Config) -> None:
    """Refuse, before the map changes, an observation the map cannot fold."""
    if obs.pose_index in bm.graph.graph["poses"]:
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


def map_surfaces(bm: BeliefMap, bounds: tuple[float, float, float, float] | None = None) -> Surfaces:
    """The map's lines and their corner and end points as surfaces for the sonar model.

    Every line is a specular, LSL-opaque surface; points are named by their ids,
    so a simulated reading names the map object that made it. With ``bounds``
    (xmin, ymin, xmax, ymax), only the lines near that box.
    """
    g = bm.graph
    lines = sorted(bm.near(bounds, "lines")) if bounds is not None else [d["id"] for _, _, d in g.edges(data=True)]
    line_ends = [_line_ends(bm, lid) for lid in lines]
    ids = sorted({n for ends in line_ends for n in ends})
    index = {n: i for i, n in enumerate(ids)}
    ends = [(index[u], index[v], lid) for (u, v), lid in zip(line_ends, lines, strict=True)]
    n = len(ends)
    return Surfaces(
        vertices=np.array([g.nodes[i]["xy"] for i in ids], dtype=float).reshape(-1, 2),
        vertex_ids=np.array(ids, dtype=str),
        segments=np.array([e[:2] for e in ends], dtype=np.intp).reshape(-1, 2),
        segment_ids=np.array([e[2] for e in ends], dtype=str),
        lsl_opaque=np.ones(n, dtype=bool),
        sonar_reflective=np.ones(n, dtype=bool),
    )


# --------------------------------------------------------------------- stages


def _judge(bm: BeliefMap, ids: NDArray[np.intp], config: Config) -> None:
    """Noise elimination of the stored segments ``ids`` against the map's open space."""
    store: SegmentStore = bm.segments
    if not len(ids):
        return
    ends = np.concatenate([store.p[ids], store.q[ids]])
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    space = bm.open_space_near((*lo, *hi))
    reach = config.merge.distance + config.merge.gap
    near = store.near((*(lo - reach), *(hi + reach)))
    seen = other_poses(
        store.p[ids], store.q[ids], store.pose[ids], store.p[near], store.q[near], store.pose[near], config.merge
    )
    features = {**{name: column[ids] for name, column in store.features.items()}, "lsl_other_poses": seen}
    ev = noise_evidence(store.p[ids], store.q[ids], space, config, features)
    store.relation[ids] = ev.relation
    store.mass[ids] = ev.fused
    store.conflict[ids] = ev.conflict
    store.eliminated[ids] = ev.eliminated


@dataclass
class _Line:
    """A line about to be (re)attached: its fitted ends, the points its ends must keep, its data."""

    fit: NDArray[np.float64]  # (2, 2): the ends as merged, before corners move them
    fixed: tuple[str | None, str | None]  # the point each end stays on, None: found anew
    data: dict[str, Any]  # id, mass, history, extras


def _rebuild(bm: BeliefMap, touched: NDArray[np.intp], config: Config, viewpoint: NDArray[np.float64]) -> set[str]:
    """Re-merge the surviving segments near the change and re-find the corners there.

    Every line holding a touched segment is dissolved, and its surviving segments
    are merged again with the touched ones; the lines meeting a dissolved line or
    a new line near its ends are detached and re-attached with the new ones, so
    their corners are found anew. Returns the ids of every line (re)attached.
    """
    store: SegmentStore = bm.segments
    g = bm.graph
    dissolved = {lid: _line_ends(bm, lid) for lid in sorted(set(store.line[touched].tolist()) - {""})}
    members = [np.asarray(g.edges[ends]["members"], dtype=np.intp) for ends in dissolved.values()]
    pool = np.union1d(touched, np.concatenate([np.zeros(0, dtype=np.intp), *members]))
    pool = pool[~store.eliminated[pool]]
    merged = merge_segments(store.p[pool], store.q[pool], config.merge)

    affected = _affected_points(bm, dissolved, merged, config)
    histories = {lid: g.edges[ends]["history"] for lid, ends in dissolved.items()}
    kept, removed = _detach(bm, dissolved, affected)
    lines = kept + _new_lines(bm, pool, merged, histories, config)
    store.line[touched[store.eliminated[touched]]] = ""
    return _attach(bm, lines, removed, viewpoint, config)


def _affected_points(bm: BeliefMap, dissolved: dict[str, tuple[str, str]], merged: Merged, config: Config) -> set[str]:
    """The points whose lines change: the dissolved lines' ends, and points near the new lines' ends."""
    g = bm.graph
    affected = {n for ends in dissolved.values() for n in ends}
    if len(merged.p):
        ends = np.concatenate([merged.p, merged.q])
        reach = 2 * config.corners.distance + 1e-9
        lo, hi = ends.min(axis=0) - reach, ends.max(axis=0) + reach
        points = [n for n in bm.near((*lo, *hi), "points") if g.nodes[n]["kind"] in _SURFACE_KINDS]
        if points:
            xy = np.array([g.nodes[n]["xy"] for n in points])
            d = np.hypot(*(xy[:, None, :] - ends[None, :, :]).transpose(2, 0, 1)).min(axis=1)
            affected |= {points[i] for i in np.flatnonzero(d <= reach)}
    return affected


def _detach(
    bm: BeliefMap, dissolved: dict[str, tuple[str, str]], affected: set[str]
) -> tuple[list[_Line], list[tuple[tuple[float, float], list[dict[str, Any]]]]]:
    """Remove the dissolved lines, the lines at affected points, and those points.

    Returns the lines to re-attach (each end not at an affected point stays on
    its point) and the removed corners' positions and histories.
    """
    g = bm.graph
    kept = []
    for lid in sorted({d["id"] for n in affected for _, _, d in g.edges(n, data=True)} - set(dissolved)):
        u, v = _line_ends(bm, lid)
        d = g.edges[u, v]
        fixed = (None if u in affected else u, None if v in affected else v)
        kept.append(_Line(np.array(d["fit"], dtype=float), fixed, dict(d)))
    for lid in [line.data["id"] for line in kept] + list(dissolved):
        bm.remove_line(lid)
    removed = [(g.nodes[n]["xy"], g.nodes[n]["history"]) for n in affected if g.nodes[n]["kind"] == "corner"]
    for n in affected:
        bm.remove_point(n)
    return kept, removed


def _new_lines(
    bm: BeliefMap, pool: NDArray[np.intp], merged: Merged, histories: dict[str, list[dict[str, Any]]], config: Config
) -> list[_Line]:
    """The merged lines: mass from their merged length and relation (other features from their
    longest member), and the sonar records of the lines they replace."""
    store: SegmentStore = bm.segments
    if not len(pool):
        return []
    length = np.hypot(*(store.q[pool] - store.p[pool]).T)
    longest = np.array([pool[group][np.argmax(length[group])] for group in merged.groups], dtype=np.intp)
    features = {name: column[longest] for name, column in store.features.items()}
    features["lsl_other_poses"] = np.array([len(np.unique(store.pose[pool[group]])) - 1 for group in merged.groups])
    ends = np.concatenate([store.p[pool], store.q[pool]])
    space = bm.open_space_near((*ends.min(axis=0), *ends.max(axis=0)))
    base = noise_evidence(merged.p, merged.q, space, config, features)
    lines = []
    for k, group in enumerate(merged.groups):
        members = pool[group]
        replaced = set(store.line[members].tolist()) & set(histories)
        records = _carried_records([histories[lid] for lid in sorted(replaced)])
        first = {
            "stage": "noise_elimination",
            "poses": sorted(set(store.pose[members].tolist())),
            "relation": str(base.relation[k]),
            "length": float(base.length[k]),
            "mass": _mass(bm, base.fused[k]).to_dict(),
        }
        history = [first, *records]
        lid = _next_id(bm, "L")
        store.line[members] = lid
        data = {
            "id": lid,
            "mass": _fold_history(bm, history, config),
            "history": history,
            "members": members.tolist(),
            "reinforced": any(r["category"] == "matched" for r in records),
        }
        lines.append(_Line(np.stack([merged.p[k], merged.q[k]]), (None, None), data))
    return lines


def _attach(
    bm: BeliefMap,
    lines: list[_Line],
    removed: list[tuple[tuple[float, float], list[dict[str, Any]]]],
    viewpoint: NDArray[np.float64],
    config: Config,
) -> set[str]:
    """Add the lines, their ends meeting at corners (a corner keeps the sonar records of a removed
    corner within the corner distance) or free; return their ids."""
    g = bm.graph
    fits = np.array([line.fit for line in lines]).reshape(-1, 2, 2)
    corners = find_corners(fits[:, 0], fits[:, 1], config.corners, viewpoint)
    end_point = {(i, e): line.fixed[e] for i, line in enumerate(lines) for e in (0, 1) if line.fixed[e] is not None}
    for k, ends in enumerate(corners.ends):
        pairs = [tuple(pair) for pair in ends.tolist()]
        if any(pair in end_point for pair in pairs):
            continue  # an end already on a point outside the change stays there
        cid = _next_id(bm, "C")
        xy = corners.xy[k]
        near = [h for pxy, h in removed if np.hypot(*(np.asarray(pxy) - xy)) <= config.corners.distance]
        history = _carried_records(near)
        reinforced = any(r["category"] == "matched" for r in history)
        bm.add_point(
            cid, xy, "corner", _vacuous(bm), history=history, shape=str(corners.shape[k]), reinforced=reinforced
        )
        for pair in pairs:
            end_point[pair] = cid
    added: set[str] = set()
    for i, line in enumerate(lines):
        nodes: list[str] = []
        for e in (0, 1):
            node = end_point.get((i, e))
            if node is None or (nodes and (nodes[0] == node or g.has_edge(nodes[0], node))):
                node = _next_id(bm, "E")  # a free end, or a second line between the same two points
                bm.add_point(node, line.fit[e], "endpoint", _vacuous(bm))
            nodes.append(node)
        data = line.data
        extras = {k: v for k, v in data.items() if k not in ("id", "kind", "mass", "history", "fit")}
        bm.add_line(data["id"], *nodes, data["mass"], history=data["history"], fit=line.fit.tolist(), **extras)
        added.add(data["id"])
    return added


def _masked(actual: SonarScan, predicted_scan: SonarScan, predicted: Rcds, config: Config) -> NDArray[np.bool_]:
    """Simulated RCDs hidden behind a nearer actual echo (the sonar hears the first echo only).

    An RCD is masked when the actual readings in its directions are, at the median,
    shorter than it by more than the matching range gate: an object the map does
    not hold (glass, say) answered first, so the sonar could not have heard this one.
    """
    masked = np.zeros(len(predicted), dtype=bool)
    if not len(actual):
        return masked
    order = np.argsort(np.mod(actual.angles, 2 * np.pi))
    around = np.mod(actual.angles[order], 2 * np.pi)
    for k in range(len(predicted)):
        i, j = int(predicted.start[k]), int(predicted.end[k])
        idx = np.arange(i, j + 1) if j >= i else np.r_[i : len(predicted_scan), 0 : j + 1]
        at = np.mod(predicted_scan.angles[idx], 2 * np.pi)
        pos = np.searchsorted(around, at) % len(around)
        before = (pos - 1) % len(around)
        gap = np.abs(np.angle(np.exp(1j * (around[[pos, before]] - at))))
        nearest = order[np.where(gap[0] <= gap[1], pos, before)]
        masked[k] = np.median(actual.ranges[nearest]) < predicted.range[k] - config.matching.range_gate
    return masked


def _in_sight(
    surfaces: Surfaces, pose: NDArray[np.float64], actual: Rcds, which: NDArray[np.intp], config: Config
) -> NDArray[np.bool_]:
    """Which RCDs could come from a target in sight: some direction of the RCD reaches its range unblocked.

    A target behind a map line across the whole RCD is a multiple reflection, not an object.
    """
    seen = np.zeros(len(which), dtype=bool)
    for n, k in enumerate(which):
        half = actual.width[k] / 2
        angles = actual.direction[k] + np.linspace(-half, half, 9)
        reach = actual.range[k] - config.unidentified.occlusion_margin
        ranges, _ = cast_rays(pose[:2], angles, surfaces.p, surfaces.q, np.zeros((0, 2)), np.zeros(0), reach)
        seen[n] = bool(np.isinf(ranges).any())
    return seen


def _reinforce(
    bm: BeliefMap,
    predicted: Rcds,
    matched: NDArray[np.intp],
    masked: NDArray[np.bool_],
    pose_index: int,
    config: Config,
) -> dict[str, str]:
    """Fold the reinforcement evidence into every object a simulated direct-echo RCD came from."""
    categories: dict[str, str] = {}
    hit = np.zeros(len(predicted), dtype=bool)
    hit[matched] = True
    for s in range(len(predicted)):
        target = str(predicted.target[s])
        if predicted.order[s] != 1 or target not in bm or (masked[s] and not hit[s]):
            continue  # multiple reflections, max-range readings and masked RCDs reinforce nothing
        category = "matched" if hit[s] else "missed"
        for obj in _supported(bm, target):
            if categories.get(obj) != "matched":
                categories[obj] = category
    stage = config.stage_sources("reinforcement")
    names = sorted(categories)
    if not names:
        return categories
    feature = np.array([categories[n] for n in names])
    rows = [source.masses({"sonar_match": feature}) for source in stage]
    for i, obj in enumerate(names):
        for source, batch in zip(stage, rows, strict=True):
            record = {
                "stage": "reinforcement",
                "pose": pose_index,
                "sensor": "sonar",
                "source": source.name,
                "category": categories[obj],
            }
            bm.fold(obj, _mass(bm, batch[i]), record)
        if categories[obj] == "matched":
            bm.set_attrs(obj, reinforced=True)
    return categories


def _unidentified(
    bm: BeliefMap, actual: Rcds, unmatched: NDArray[np.intp], obs: Observation, config: Config
) -> list[str]:
    """Unmatched actual RCDs of Type I-III become unidentified objects (or reinforce one within the radius)."""
    g = bm.graph
    pose = obs.pose
    keep = unmatched[actual.type[unmatched] != 4]
    keep = keep[np.argsort(actual.type[keep], kind="stable")]  # the strongest evidence first
    stage = config.stage_sources("unidentified")
    rows = [source.masses({"rcd_type": np.array([_ROMAN[t] for t in actual.type[keep]])}) for source in stage]
    done: list[str] = []
    for j, k in enumerate(keep):
        xy = pose[:2] + actual.range[k] * np.array([np.cos(actual.direction[k]), np.sin(actual.direction[k])])
        radius = config.unidentified.merge_radius
        around = [
            n for n in bm.near((*(xy - radius), *(xy + radius)), "points") if g.nodes[n]["kind"] == "unidentified"
        ]
        near = [(np.hypot(*(np.asarray(g.nodes[n]["xy"]) - xy)), n) for n in around]
        near = [c for c in near if c[0] <= radius]
        records = [
            (
                {
                    "stage": "unidentified",
                    "pose": obs.pose_index,
                    "sensor": "sonar",
                    "source": source.name,
                    "rcd_type": _ROMAN[int(actual.type[k])],
                },
                _mass(bm, batch[j]),
            )
            for source, batch in zip(stage, rows, strict=True)
        ]
        if near:
            node = min(near)[1]
            if node in done:
                continue  # at most once per object per pose
            for record, mass in records:
                bm.fold(node, mass, record)
        else:
            node = _next_id(bm, "U")
            bm.add_point(node, xy, "unidentified", _vacuous(bm))
            for record, mass in records:
                bm.fold(node, mass, record)
        done.append(node)
    return done


def _refresh_points(bm: BeliefMap, line_ids: Iterable[str], config: Config) -> None:
    """Recompute the masses of the end points of these lines.

    A free end point believes what its line believes; a corner starts from its
    least believed line and folds in its own sonar evidence.
    """
    g = bm.graph
    nodes = {n for lid in line_ids if lid in bm for n in _line_ends(bm, lid)}
    real = bm.frame.mask("real")
    for n in sorted(nodes):
        d = g.nodes[n]
        masses = [e["mass"] for _, _, e in g.edges(n, data=True)]
        weakest = min(masses, key=lambda m: m.belief(real)) if masses else _vacuous(bm)
        if d["kind"] == "endpoint":
            bm.set_attrs(n, mass=weakest)
        elif d["kind"] == "corner":
            bm.set_attrs(n, mass=_folded(bm, weakest, d["history"], config))


# --------------------------------------------------------------------- helpers


def _supported(bm: BeliefMap, target: str) -> list[str]:
    """The objects a sonar target supports: a line itself; a corner and its lines; a free end's line."""
    if _is_line(bm, target):
        return [target]
    kind = bm.graph.nodes[target]["kind"]
    lines = [d["id"] for _, _, d in bm.graph.edges(target, data=True)]
    return [target, *lines] if kind == "corner" else lines


def _is_line(bm: BeliefMap, obj: str) -> bool:
    return obj not in bm.graph


def _line_ends(bm: BeliefMap, lid: str) -> tuple[str, str]:
    line = bm[lid]
    return line.u, line.v


def _carried_records(histories: Iterable[list[dict[str, Any]]]) -> list[dict[str, Any]]:
    """The sonar records of replaced objects, at most one per pose and source (``matched`` first), by pose."""
    best: dict[tuple[Any, Any], dict[str, Any]] = {}
    for history in histories:
        for record in history:
            if record.get("stage") != "reinforcement":
                continue
            key = (record["pose"], record["source"])
            if key not in best or (record["category"] == "matched" and best[key]["category"] != "matched"):
                best[key] = record
    return [best[k] for k in sorted(best, key=lambda k: (k[0], str(k[1])))]


def _fold_history(bm: BeliefMap, history: list[dict[str, Any]], config: Config) -> MassFunction:
    """The mass a line's history gives: its first record's mass, the others folded in order."""
    return _folded(bm, MassFunction.from_dict(bm.frame, history[0]["mass"], open_world=True), history[1:], config)


def _folded(bm: BeliefMap, mass: MassFunction, records: list[dict[str, Any]], config: Config) -> MassFunction:
    """``mass`` with the records' masses folded in one by one by the config's rule."""
    for record in records:
        mass = combine(mass, MassFunction.from_dict(bm.frame, record["mass"], open_world=True), rule=config.rule)
    return mass


def _mass(bm: BeliefMap, row: NDArray[np.float64]) -> MassFunction:
    return MassFunction.from_dense(bm.frame, row, open_world=True)


def _vacuous(bm: BeliefMap) -> MassFunction:
    return MassFunction(bm.frame, {bm.frame.full: 1.0})


def _next_id(bm: BeliefMap, prefix: str) -> str:
    counters = bm.graph.graph["next_id"]
    n = counters[prefix]
    counters[prefix] = n + 1
    return f"{prefix}{n}"
