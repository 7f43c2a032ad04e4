"""What each pose of a map sensed, kept for the evidence that other poses' segments need.

The noise-elimination features of :mod:`evmap.maps.contour_free_space` and
:mod:`evmap.maps.sonar_forward` test a segment against the readings of every
pose: the stripe's rays (free from the sensor to their point) and the sonar
scan. :func:`remember` keeps them per map as the map's observations are folded.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING
from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import NDArray

from evmap.sources.readings import SonarScan

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap
    from evmap.maps.observation import Observation

__all__ = ["SENSED_FEATURES", "Sensed", "keep_features", "kept_features", "remember", "sensed"]

SENSED_FEATURES = {"contour_free": "clear", "lsl_persistence": "unobserved", "sonar_forward": "silent"}
"""The features computed from the sensed readings, and the value that is no evidence."""


@dataclass(frozen=True, eq=False)
class Sensed:
    """One pose's readings, ready for ray queries.

    Attributes
    ----------
    pose_index : the pose.
    origin : (2,) the sensors' position.
    bearing : (K,) world bearing of every stripe ray, wrapped to [-pi, pi), sorted.
    range : (K,) its measured range (m), NaN where nothing returned.
    sonar : the pose's sonar scan.
    """

    pose_index: int
    origin: NDArray[np.float64]
    bearing: NDArray[np.float64]
    range: NDArray[np.float64]
    sonar: SonarScan


_MEMORY: WeakKeyDictionary[BeliefMap, dict[int, Sensed]] = WeakKeyDictionary()
_FEATURES: WeakKeyDictionary[BeliefMap, dict[str, NDArray[np.str_]]] = WeakKeyDictionary()


def remember(bm: BeliefMap, obs: Observation) -> Sensed:
    """Keep what the observation sensed with the map (an observation without rays keeps no rays).

    >>> from evmap.maps.belief_map import new_map
    >>> from evmap.maps.observation import observe
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.sources.sim.world import World
    >>> bm = new_map(load_config())
    >>> kept = remember(bm, observe(World(default_scenario()), 0, load_config()))
    >>> [s.pose_index for s in sensed(bm)], bool(np.all(np.diff(kept.bearing) >= 0))
    ([0], True)
    """
    rays = np.zeros((0, 2)) if obs.rays is None else np.asarray(obs.rays, dtype=float).reshape(-1, 2)
    bearing = (rays[:, 0] + np.pi) % (2 * np.pi) - np.pi
    order = np.argsort(bearing, kind="stable")
    kept = Sensed(int(obs.pose_index), np.array(obs.pose[:2]), bearing[order], rays[order, 1], obs.sonar)
    _MEMORY.setdefault(bm, {})[kept.pose_index] = kept
    return kept


def sensed(bm: BeliefMap) -> list[Sensed]:
    """The readings of every pose remembered for this map, by pose index."""
    memory = _MEMORY.get(bm, {})
    return [memory[k] for k in sorted(memory)]


def keep_features(bm: BeliefMap, ids: NDArray[np.intp], features: dict[str, NDArray[np.str_]]) -> None:
    """Keep the sensed features last computed for the map's segments ``ids`` (rows of its segment store)."""
    kept = _FEATURES.setdefault(bm, {})
    rows = len(bm.segments)
    for name, values in features.items():
        column = kept.get(name, np.zeros(0, dtype="<U12"))
        if len(column) < rows:
            column = np.concatenate([column, np.full(rows - len(column), SENSED_FEATURES[name], dtype="<U12")])
        column[ids] = values
        kept[name] = column


def kept_features(bm: BeliefMap, ids: NDArray[np.intp]) -> dict[str, NDArray[np.str_]]:
    """The sensed features last computed for segments ``ids``; no evidence for those never computed."""
    kept = _FEATURES.get(bm, {})
    ids = np.asarray(ids, dtype=np.intp)
    out = {}
    for name, none in SENSED_FEATURES.items():
        column = np.append(kept.get(name, np.zeros(0, dtype="<U12")), none)  # the last: never computed
        out[name] = column[np.minimum(ids, len(column) - 1)]
    return out
