"""Rebuild of lines and corners near a change (paper, section III: merging, then corners).

Every line holding a touched segment is dissolved, and its surviving segments
are merged again with the touched ones (:mod:`evmap.maps.merging`), with, in
turn, those of the lines that are merging's candidates with a merged line; the lines
meeting a dissolved line, or with an end near an end found anew (and so on, in
turn), are detached and re-attached with the new ones, so that their corners
(:mod:`evmap.maps.corners`) are found anew. A merged line's mass is recomputed from its merged length and
relation (its pieces are not independent evidence); the sonar evidence of the
lines it replaces carries over, at most one record per pose and source. A line
seen from more than :data:`~evmap.maps.segments.CONSOLIDATE_POSES` poses is
consolidated into its merged support (:meth:`~evmap.maps.segments.SegmentStore.consolidate`),
which stands for them in later rebuilds: a rebuild merges what is near the
change, a few rows per line, however long the line has been seen. A merged
line that is a map line as it stands (its members and fit) leaves it in place,
its points and neighbours untouched, and one that only moves a map line refits
it in place (:mod:`evmap.maps.refit`); either takes the merged line's evidence;
masses carry the running masses of their sonar records
(:mod:`evmap.maps.running_mass`), so nothing is folded again.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.maps.affected_points import affected_points
from evmap.maps.corners import drawn_reach, find_corners
from evmap.maps.merged_evidence import MergedEvidence, merged_evidence
from evmap.maps.merging import Merged, merge_segments, related_pairs
from evmap.maps.near_ends import SURFACE_KINDS, fits_near
from evmap.maps.refit import end_moves, refits, unmoved
from evmap.maps.running_mass import NOISE_STAGE, carried, with_running
from evmap.maps.segments import CONSOLIDATE_POSES
from evmap.maps.sensed import sensed
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["join_corners", "rebuild", "refresh_points"]

Removed = list[tuple[tuple[float, float], list[dict[str, Any]], MassFunction | None]]
"""Removed corners: position, history and running mass of each."""


@dataclass
class _Line:
    """A line about to be (re)attached: its fitted ends, the points its ends must keep, its data."""

    fit: NDArray[np.float64]  # (2, 2): the ends as merged, before corners move them
    fixed: tuple[str | None, str | None]  # the point each end stays on, None: found anew
    data: dict[str, Any]  # id, mass, history, extras
    running: MassFunction | None  # the running mass of its evidence records


def rebuild(
    bm: BeliefMap, touched: NDArray[np.intp], config: Config, viewpoint: NDArray[np.float64], *, join: bool
) -> set[str]:
    """Re-merge the surviving segments near the change and, if ``join``, re-find the corners there (their shapes
    as seen from ``viewpoint``); else the ends the rebuild touches are left free, for :func:`join_corners`.

    ``touched`` are rows of the map's segment store just judged by noise
    elimination. Returns the ids of every line (re)attached, refitted in place, or left in place with new
    evidence: the lines whose end points' masses may change.
    """
    store = bm.segments
    g = bm.graph
    dissolved, pool, merged = _merged_pool(bm, touched, config)
    evidence = merged_evidence(bm, pool, merged, config)

    stays = unmoved(bm, pool, merged, dissolved)
    new_evidence: set[str] = set()  # the lines that stay whose evidence changed
    for k, lid in stays.items():
        fit = np.array(g.edge(*dissolved.pop(lid))["fit"], dtype=float)
        if _refit_in_place(bm, lid, pool[merged.groups[k]], fit, (merged, k), evidence, config):
            new_evidence.add(lid)
    refitted, fits, near = refits(bm, pool, merged, dissolved, config, join=join)
    moves = [move for found in end_moves(bm, fits, near, config).values() for move in found or ()]
    for k, lid in refitted.items():
        _refit_in_place(bm, lid, pool[merged.groups[k]], fits[lid], (merged, k), evidence, config)
        del dissolved[lid]
    for node, xy in moves:
        if bm.graph.nodes[node]["xy"] != xy:
            bm.set_attrs(node, xy=xy)
    fresh = [k for k in range(len(merged.groups)) if k not in refitted and k not in stays]
    if join:
        affected = affected_points(bm, dissolved, merged, fresh, config)
    else:  # no corners found: the dissolved lines' ends are all the points that change
        affected = {n for points in dissolved.values() for n in points}
    histories = {lid: (g.edge(*ends)["history"], bm.running_mass(lid)) for lid, ends in dissolved.items()}
    kept, removed = _detach(bm, dissolved, affected)
    lines = kept + _new_lines(bm, pool, merged, fresh, evidence, histories, config)
    store.write(touched[store.eliminated[touched]], line="")
    return _attach(bm, lines, removed, viewpoint, config, join=join) | set(refitted.values()) | new_evidence


def join_corners(bm: BeliefMap, config: Config) -> set[str]:
    """Join the ends of every line of the map into corners, as :func:`~evmap.maps.corners.find_corners` finds
    them over the whole map's line fits (each corner's shape as seen from the nearest pose that sensed, or
    ``unknown`` if the map kept none); the lines keep their ids and evidence, and a corner the sonar records
    of the removed corners within the corner distance. Returns the ids of the lines."""
    points = {n for lid in bm.line_ids() for n in bm.ends(lid)}
    kept, removed = _detach(bm, {}, points)
    origins = [s.origin for s in sensed(bm)]
    lines = _attach(bm, kept, removed, np.array(origins) if origins else None, config, join=True)
    refresh_points(bm, lines, config)
    return lines


def _merged_pool(
    bm: BeliefMap, touched: NDArray[np.intp], config: Config
) -> tuple[dict[str, tuple[str, str]], NDArray[np.intp], Merged]:
    """The lines to dissolve (id -> end points), the surviving rows they and the ``touched`` rows make (the
    pool), and the pool merged.

    The lines holding a touched row are dissolved, and so, in turn, are the map's lines that are merging's
    candidates with a merged line (:func:`~evmap.maps.merging.related_pairs`): a line that grew toward a
    line of the same wall no update had touched joins it, as a merge of the whole map would.
    """
    store = bm.segments
    g = bm.graph
    lines = set(store.line[touched].tolist()) - {""}
    while True:
        dissolved = {lid: bm.ends(lid) for lid in sorted(lines)}
        members = [np.asarray(g.edge(*ends)["members"], dtype=np.intp) for ends in dissolved.values()]
        pool = np.union1d(touched, np.concatenate([np.zeros(0, dtype=np.intp), *members]))
        pool = pool[~store.eliminated[pool]]
        merged = merge_segments(store.p[pool], store.q[pool], config.merge, store.seen[pool])
        joining = _candidate_lines(bm, merged, lines, config)
        if not joining:
            return dissolved, pool, merged
        lines |= joining


def _candidate_lines(bm: BeliefMap, merged: Merged, dissolved: set[str], config: Config) -> set[str]:
    """The map's lines, but the ``dissolved``, that are merging's candidates with one of the ``merged`` lines."""
    reach = math.hypot(config.merge.gap, config.merge.distance)
    lo, hi = np.minimum(merged.p, merged.q) - reach, np.maximum(merged.p, merged.q) + reach
    near = bm.near(np.hstack([lo, hi]), "lines") - dissolved
    if not near:
        return set()
    ids = sorted(near)
    fits = np.array([bm.graph.edge(*bm.ends(lid))["fit"] for lid in ids], dtype=float).reshape(-1, 2, 2)
    _, b, _ = related_pairs(merged.p, merged.q, config.merge, (fits[:, 0], fits[:, 1]), mergeable=True)
    return {ids[i] for i in b.tolist()}


def refresh_points(bm: BeliefMap, line_ids: Iterable[str], config: Config) -> None:
    """Recompute the masses of the end points of these lines.

    A free end point believes what its line believes; a corner starts from its
    least believed line and folds in its own sonar evidence.
    """
    g = bm.graph
    nodes = {n for lid in line_ids if lid in bm for n in bm.ends(lid)}
    real = bm.frame.mask("real")
    belief: dict[str, float] = {}  # line id -> Bel(real), each computed once

    def weakness(line: dict[str, Any]) -> float:
        if line["id"] not in belief:
            belief[line["id"]] = line["mass"].belief(real)
        return belief[line["id"]]

    for n in sorted(nodes):
        d = g.nodes[n]
        if d["kind"] not in SURFACE_KINDS:
            continue
        lines = list(g.adj[n].values())
        weakest = (lines[0] if len(lines) == 1 else min(lines, key=weakness))["mass"] if lines else bm.vacuous()
        mass = weakest if d["kind"] == "endpoint" else with_running(weakest, bm.running_mass(n), config.rule)
        if not _same_mass(d["mass"], mass):
            bm.set_attrs(n, mass=mass)


def _refit_in_place(
    bm: BeliefMap,
    lid: str,
    members: NDArray[np.intp],
    fit: NDArray[np.float64],
    line: tuple[Merged, int],
    evidence: MergedEvidence,
    config: Config,
) -> bool:
    """The line ``lid`` takes the merged line's members, support, noise-elimination evidence and ``fit``
    (its end points are moved by the caller); its sonar records stay. Whether that changed it."""
    data = bm.graph.edge(*bm.ends(lid))
    history = data["history"]
    first, first_mass, members = _merged_line(bm, lid, members, *line, evidence)
    mass = with_running(first_mass, bm.running_mass(lid), config.rule)
    attrs = {"mass": mass, "history": [first, *history[1:]], "members": members.tolist(), "fit": fit.tolist()}
    if _same(data, attrs):
        return False
    bm.set_attrs(lid, **attrs)
    return True


def _same(data: dict[str, Any], attrs: dict[str, Any]) -> bool:
    """Whether setting ``attrs`` would leave the object's ``data`` as it is (masses compared by value)."""
    return all(
        _same_mass(data[k], v) if k == "mass" else data.get(k) == v
        for k, v in sorted(attrs.items(), key=lambda kv: kv[0] == "mass")  # the mass last: the dearest to compare
    )


def _same_mass(a: MassFunction, b: MassFunction) -> bool:
    """Whether two mass functions have equal dense vectors (equal focal sets and masses, the quick test, do)."""
    if a is b or (a.masks.tolist() == b.masks.tolist() and a.masses.tolist() == b.masses.tolist()):
        return True
    x, y = a.dense(), b.dense()
    return x.shape == y.shape and bool((x == y).all())


def _detach(bm: BeliefMap, dissolved: dict[str, tuple[str, str]], affected: set[str]) -> tuple[list[_Line], Removed]:
    """Remove the dissolved lines, the lines at affected points, and those points.

    Returns the lines to re-attach (each end not at an affected point stays on
    its point) and the removed corners' positions and histories.
    """
    g = bm.graph
    kept = []
    for lid in sorted({d["id"] for n in affected for d in g.adj[n].values()} - set(dissolved)):
        u, v = bm.ends(lid)
        d = g.edge(u, v)
        fixed = (None if u in affected else u, None if v in affected else v)
        kept.append(_Line(np.array(d["fit"], dtype=float), fixed, dict(d), bm.running_mass(lid)))
    for lid in [line.data["id"] for line in kept] + list(dissolved):
        bm.remove_line(lid)
    removed = [
        (g.nodes[n]["xy"], g.nodes[n]["history"], bm.running_mass(n))
        for n in affected
        if g.nodes[n]["kind"] == "corner"
    ]
    for n in affected:
        bm.remove_point(n)
    return kept, removed


def _merged_line(
    bm: BeliefMap,
    lid: str,
    members: NDArray[np.intp],
    merged: Merged,
    k: int,
    evidence: MergedEvidence,
) -> tuple[dict[str, Any], MassFunction, NDArray[np.intp]]:
    """The noise-elimination record of the merged line k (rows ``members``) as the line ``lid``, its mass,
    and its members: the rows, or their consolidated support if more than :data:`CONSOLIDATE_POSES` poses
    saw them."""
    store = bm.segments
    base, seen, mass = evidence.base, evidence.seen, evidence.masses[k]  # each merged line k is taken once
    first = {
        "stage": NOISE_STAGE,
        "poses": sorted(set(store.pose[members].tolist())),
        "relation": str(base.relation[k]),
        "length": float(base.length[k]),
        "mass": evidence.dicts[k],
    }
    if any(line != lid for line in store.line[members].tolist()):
        store.write(members, line=lid)
    if seen[k] > CONSOLIDATE_POSES and len(members) > 1:
        row = store.consolidate(members, merged.p[k], merged.q[k], lid, int(seen[k]))
        store.write([row], relation=base.relation[k], mass=base.fused[k], conflict=base.conflict[k], eliminated=False)
        members = np.array([row], dtype=np.intp)
    return first, mass, members


def _new_lines(
    bm: BeliefMap,
    pool: NDArray[np.intp],
    merged: Merged,
    fresh: list[int],
    evidence: MergedEvidence,
    histories: dict[str, tuple[list[dict[str, Any]], MassFunction | None]],
    config: Config,
) -> list[_Line]:
    """The ``fresh`` merged lines: their noise-elimination evidence, and the sonar records of the lines they
    replace (history and running mass of each)."""
    store = bm.segments
    lines = []
    for k in fresh:
        members = pool[merged.groups[k]]
        replaced = set(store.line[members].tolist()) & set(histories)
        records, running = carried(bm.frame, [histories[lid] for lid in sorted(replaced)], config.rule)
        lid = bm.new_id("L")
        first, first_mass, members = _merged_line(bm, lid, members, merged, k, evidence)
        data = {
            "id": lid,
            "mass": with_running(first_mass, running, config.rule),
            "history": [first, *records],
            "members": members.tolist(),
            "reinforced": any(r["category"] == "matched" for r in records),
        }
        lines.append(_Line(np.stack([merged.p[k], merged.q[k]]), (None, None), data, running))
    return lines


def _attach(
    bm: BeliefMap,
    lines: list[_Line],
    removed: Removed,
    viewpoint: NDArray[np.float64] | None,
    config: Config,
    *,
    join: bool,
) -> set[str]:
    """Add the lines, their ends meeting at corners if ``join`` (a corner keeps the sonar records of a removed
    corner within the corner distance; its shape as seen from ``viewpoint``, :func:`find_corners`) or free;
    return their ids. A line that would join the same two points as a longer one (two pieces of one surface, a
    thin wedge between them) keeps both ends free, and its corners are placed without it (a corner left with one
    line is none)."""
    fits = np.array([line.fit for line in lines]).reshape(-1, 2, 2)
    corners = None
    if join:
        others = None
        if config.corners.drawn_apart:  # the lines near that a corner here may draw one of these related to
            near = fits_near(bm, fits[:, 0], fits[:, 1], drawn_reach(config.corners, config.merge))[1]
            others = near[:, 0], near[:, 1]
        placed = np.array([[bm.graph.nodes[n]["xy"] if n else (np.nan, np.nan) for n in line.fixed] for line in lines])
        corners = find_corners(
            fits[:, 0], fits[:, 1], config.corners, viewpoint, merge=config.merge, others=others, placed=placed
        )
    end_point: dict[tuple[int, int], str | int] = {
        (i, e): point for i, line in enumerate(lines) for e, point in enumerate(line.fixed) if point is not None
    }
    for k, ends in enumerate(corners.ends if corners else ()):
        pairs = [tuple(pair) for pair in ends.tolist()]
        if not any(pair in end_point for pair in pairs):  # an end already on a point outside the change stays
            end_point.update(dict.fromkeys(pairs, k))
    joined: set[frozenset[str | int]] = set()
    for i in np.lexsort(([line.data["id"] for line in lines], -np.hypot(*(fits[:, 1] - fits[:, 0]).T))).tolist():
        ends = end_point.get((i, 0)), end_point.get((i, 1))
        if None not in ends:
            if set(ends) in joined:
                del end_point[i, 0], end_point[i, 1]
            else:
                joined.add(frozenset(ends))
    members: dict[int, list[tuple[int, int]]] = {}
    for pair, point in end_point.items():
        if isinstance(point, int):
            members.setdefault(point, []).append(pair)
    removed_xy = np.array([pxy for pxy, _, _ in removed], dtype=float).reshape(-1, 2)
    for k, pairs in sorted(members.items()):
        if len(pairs) < 2:
            del end_point[pairs[0]]
            continue
        cid = bm.new_id("C")
        xy = corners.xy[k] if len(pairs) == len(corners.ends[k]) else np.mean([fits[pair] for pair in pairs], axis=0)
        close = np.hypot(*(removed_xy - xy).T) <= config.corners.distance
        near = [removed[j][1:] for j in np.flatnonzero(close).tolist()]
        history, running = carried(bm.frame, near, config.rule)
        reinforced = any(r["category"] == "matched" for r in history)
        bm.add_point(
            cid, xy, "corner", bm.vacuous(), history=history, shape=str(corners.shape[k]), reinforced=reinforced
        )
        bm.keep_running(cid, running)
        end_point.update(dict.fromkeys(pairs, cid))
    added: set[str] = set()
    for i, line in enumerate(lines):
        nodes: list[str] = []
        for e in (0, 1):
            node = end_point.get((i, e))
            if node is None:
                node = bm.new_id("E")
                bm.add_point(node, line.fit[e], "endpoint", line.data["mass"])  # what its line believes
            nodes.append(node)
        data = line.data
        extras = {k: v for k, v in data.items() if k not in ("id", "kind", "mass", "history", "fit")}
        bm.add_line(data["id"], *nodes, data["mass"], history=data["history"], fit=line.fit.tolist(), **extras)
        bm.keep_running(data["id"], line.running)
        added.add(data["id"])
    return added
