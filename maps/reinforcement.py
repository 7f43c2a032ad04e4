"""Belief reinforcement (paper, section III, Fig. 7): matched and missed map objects.

Every map object that a simulated direct-echo RCD comes from gets the
``reinforcement`` stage's evidence, ``matched`` or ``missed``, at most once per
pose: a line itself, a corner and its lines, a free end point's line. Multiple
reflections, max-range readings and masked RCDs reinforce nothing; objects the
sonar cannot see from the pose get no evidence and keep their mid-level belief.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from evidential import MassFunction
from evmap.maps.simulated_sonar import SonarCheck
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["reinforce", "supported"]


def reinforce(bm: BeliefMap, check: SonarCheck, pose_index: int, config: Config) -> dict[str, str]:
    """Fold the reinforcement evidence into every object a simulated direct-echo RCD came from.

    Returns map object id -> ``matched`` or ``missed``.
    """
    predicted = check.predicted
    categories: dict[str, str] = {}
    hit = np.zeros(len(predicted), dtype=bool)
    hit[check.matched[1]] = True
    for s in range(len(predicted)):
        target = str(predicted.target[s])
        if predicted.order[s] != 1 or target not in bm or (check.masked[s] and not hit[s]):
            continue  # multiple reflections, max-range readings and masked RCDs reinforce nothing
        category = "matched" if hit[s] else "missed"
        for obj in supported(bm, target):
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
            bm.fold(obj, MassFunction.from_dense(bm.frame, batch[i], open_world=True), record)
        if categories[obj] == "matched":
            bm.set_attrs(obj, reinforced=True)
    return categories


def supported(bm: BeliefMap, target: str) -> list[str]:
    """The objects a sonar target supports: a line itself; a corner and its lines; a free end's line."""
    if bm.is_line(target):
        return [target]
    kind = bm.graph.nodes[target]["kind"]
    lines = [d["id"] for d in bm.graph.adj[target].values()]
    return [target, *lines] if kind == "corner" else lines
