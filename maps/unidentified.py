"""Unidentified objects (paper, section III, Fig. 7): what the sonar hears and the map cannot explain.

An actual RCD of Type I-III that matched no simulated RCD, and comes from a
target in sight (:func:`evmap.maps.simulated_sonar.in_sight`), becomes an
``unidentified`` point at the pose + its range along its direction, with the
``unidentified`` stage's evidence by RCD type; within ``unidentified.merge_radius``
of an existing one it reinforces that one instead, at most once per pose.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.maps.simulated_sonar import SonarCheck, in_sight
from evmap.sources.config import Config
from evmap.sources.rcd import TYPE_IV, TYPE_NAMES

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["add_unidentified"]


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
    stage = config.stage_sources("unidentified")
    rows = [source.masses({"rcd_type": np.array([TYPE_NAMES[t] for t in actual.type[keep]])}) for source in stage]
    radius = config.unidentified.merge_radius
    done: list[str] = []
    for j, k in enumerate(keep):
        xy = pose[:2] + actual.range[k] * np.array([np.cos(actual.direction[k]), np.sin(actual.direction[k])])
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
