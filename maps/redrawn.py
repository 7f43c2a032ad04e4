"""Which lines a change may redraw at corners, with ``corners.drawn_apart``: a corner draws no line related to
another line as fitted, and judges its lines drawn to their other ends where those ends' own corners put them
(:mod:`evmap.maps.corners`). So a line found anew, dissolved or refitted concerns the corners of the lines that
corners could draw related to it (:func:`paired_lines`), and a line drawn between two corners concerns both when
its drawing may matter to either (:func:`drawing_matters`). :mod:`evmap.maps.affected_points` finds those
corners anew; :func:`redrawn_refits` tells the refits in place (:mod:`evmap.maps.refit`) that would change one.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.corners import drawn_reach, drawn_turn, loose_merge
from evmap.maps.merging import related_pairs
from evmap.maps.near_ends import fits_near, linked
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["drawing_matters", "paired_lines", "redrawn_refits"]


def redrawn_refits(
    bm: BeliefMap,
    fits: dict[str, NDArray[np.float64]],
    moves: dict[str, list[tuple[str, tuple[float, float]]]],
    config: Config,
) -> set[str]:
    """The refitted lines of ``fits`` (new fits; their points' ``moves``) whose refits a whole rebuild would not
    leave as they are: a corner would then draw a line near them related to another line
    (:func:`_drawn_related`), or a corner of theirs that moves holds a line whose drawing to its other end's corner
    may matter there (:func:`drawing_matters`)."""
    g = bm.graph
    failed = _drawn_related(bm, fits, moves, config)
    for lid, found in moves.items():
        nodes = {node for node, _ in found}
        lines = {d["id"] for node in nodes if g.nodes[node]["kind"] == "corner" for d in g.adj[node].values()}
        if drawing_matters(bm, {(k, m) for k in lines for m in bm.ends(k) if m not in nodes}, config):
            failed.add(lid)
    return failed


def _drawn_related(
    bm: BeliefMap,
    fits: dict[str, NDArray[np.float64]],
    moves: dict[str, list[tuple[str, tuple[float, float]]]],
    config: Config,
) -> set[str]:
    """The refitted lines of ``fits`` whose refits (and corner ``moves``) a whole rebuild would not leave as they
    are with ``drawn_apart``: a corner of a line near them would draw it related to another line as fitted, or a
    line near them has a free end that links with another line's end (left free by the corners' rules, which
    may read the new fits otherwise)."""
    g = bm.graph
    reach = drawn_reach(config.corners, config.merge)
    old = np.array([g.edge(*bm.ends(lid))["fit"] for lid in fits], dtype=float)
    new = np.array(list(fits.values()), dtype=float)
    both = np.concatenate([old, new])
    at_points = {d["id"] for lid in fits for n in bm.ends(lid) for d in g.adj[n].values()}
    near = sorted(paired_lines(bm, both[:, 0], both[:, 1], config) | at_points | fits.keys())
    moved = {node: xy for found in moves.values() for node, xy in found}
    owners: dict[str, set[str]] = {}  # a point of a refitted line -> the refitted lines there
    for lid in fits:
        for node in bm.ends(lid):
            owners.setdefault(node, set()).add(lid)

    def fit(lid: str) -> NDArray[np.float64]:
        return fits[lid] if lid in fits else np.array(g.edge(*bm.ends(lid))["fit"], dtype=float)

    def place(node: str, end: NDArray[np.float64]) -> NDArray[np.float64]:  # a line's end as drawn
        corner = g.nodes[node]["kind"] == "corner"
        return np.array(moved.get(node, g.nodes[node]["xy"]), dtype=float) if corner else end

    drawn, blame, free = [], [], []  # each corner's lines as drawn, the refits that may change each; free ends
    for lid in near:
        f = fit(lid)
        ends = bm.ends(lid)
        for e, node in enumerate(ends):
            if g.nodes[node]["kind"] == "corner":
                for other in (f[1 - e], place(ends[1 - e], f[1 - e])):  # the other end as fitted, and as drawn
                    drawn.append((lid, *((place(node, f[e]), other) if e == 0 else (other, place(node, f[e])))))
                    blame.append(owners.get(node, set()) | owners.get(ends[1 - e], set()) | ({lid} & fits.keys()))
            elif lid not in fits:
                free.append(np.stack([f[e], (f[1] - f[0]) / np.hypot(*(f[1] - f[0]))]))
    failed: set[str] = set()
    if drawn:
        dp, dq = np.array([d[1] for d in drawn]), np.array([d[2] for d in drawn])
        others = sorted(set(fits_near(bm, dp, dq, reach)[0]) | fits.keys())
        fitted = np.array([fit(lid) for lid in others])
        a, b, _ = related_pairs(dp, dq, config.merge, (fitted[:, 0], fitted[:, 1]))
        for r, j in zip(a.tolist(), b.tolist(), strict=True):
            if others[j] != drawn[r][0]:  # as the map stands there is none: a refit near made it
                failed |= blame[r] | ({others[j]} & fits.keys()) or set(fits)
    if free and linked(bm, np.array(free), set(), config)[1].any():
        failed |= set(fits)
    return failed


def paired_lines(bm: BeliefMap, p: NDArray[np.float64], q: NDArray[np.float64], config: Config) -> set[str]:
    """The map's lines that corners could draw related to one of the lines p-q as fitted: those that pair with one
    by merging's tolerances widened by what corners may do to the map's line (:func:`~evmap.maps.corners.loose_merge`,
    turned by what :func:`~evmap.maps.corners.drawn_turn` allows for its length)."""
    return {lid for _, lid in _pairs(bm, p, q, config)}


def _pairs(bm: BeliefMap, p: NDArray[np.float64], q: NDArray[np.float64], config: Config) -> list[tuple[int, str]]:
    """(row of p-q, map line) of each pair of :func:`paired_lines`."""
    ids, fits = fits_near(bm, p, q, drawn_reach(config.corners, config.merge))
    if not ids:
        return []
    d = fits[:, 1] - fits[:, 0]
    turn = drawn_turn(config.corners, np.hypot(*d.T))
    a, b, _ = related_pairs(
        fits[:, 0], fits[:, 1], loose_merge(config.corners, config.merge, float(turn.max())), (p, q)
    )
    e = q[b] - p[b]
    cos = np.abs(np.sum(d[a] * e, axis=1)) / (np.hypot(*d[a].T) * np.hypot(*e.T))
    keep = np.degrees(np.arccos(np.minimum(cos, 1.0))) <= config.merge.angle_deg + turn[a] + 1e-6
    return [(j, ids[i]) for i, j in zip(a[keep].tolist(), b[keep].tolist(), strict=True)]


def drawing_matters(bm: BeliefMap, at: Iterable[tuple[str, str]], config: Config) -> set[str]:
    """The lines of ``at`` ((line, corner) pairs: a line and the corner at one of its ends) whose drawing to that
    corner from a corner at their other end may matter there (with ``drawn_apart``, :mod:`evmap.maps.corners`
    draws a line from a corner to its other end where that end's own corner puts it): lines that corners could draw
    related to another line (:func:`paired_lines`), or with another line at that corner, as drawn, within the corner
    angle and what corners may turn them (:func:`~evmap.maps.corners.drawn_turn`) of their fit."""
    g = bm.graph
    found: set[str] = set()
    for lid, node in sorted(set(at)):
        if lid in found or g.nodes[node]["kind"] != "corner":
            continue
        fit = np.array(g.edge(*bm.ends(lid))["fit"], dtype=float)
        if any(ml != lid for _, ml in _pairs(bm, fit[:1], fit[1:], config)):
            found.add(lid)
            continue
        others = [d["id"] for d in g.adj[node].values() if d["id"] != lid]
        if others:
            u = fit[1] - fit[0]
            drawn = np.array([[g.nodes[m]["xy"] for m in bm.ends(k)] for k in others], dtype=float)
            v = drawn[:, 1] - drawn[:, 0]
            cos = np.abs(v @ u) / (np.hypot(*u) * np.maximum(np.hypot(*v.T), 1e-12))
            turn = drawn_turn(config.corners, np.array([np.hypot(*u)]))[0]
            if (np.degrees(np.arccos(np.minimum(cos, 1.0))) <= config.corners.min_angle_deg + turn + 1e-6).any():
                found.add(lid)
    return found
