"""Simulated sonar from the map and matching against the actual scan (paper, section III, Fig. 6).

The map's lines and points become :class:`~evmap.sources.sim.surfaces.Surfaces`
for the same sonar model that measures the world (:func:`map_surfaces`); the
RCDs of the actual and the simulated scans are matched by direction and mean
range (:mod:`evmap.maps.matching`). A simulated RCD hidden behind a nearer actual
echo is masked (:func:`masked`): the sonar hears the first echo only. An
unmatched actual RCD comes from an object in sight only if some direction of it
reaches its range unblocked by the map (:func:`in_sight`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from evmap.maps.matching import match_rcds
from evmap.sources.config_model import Config
from evmap.sources.geometry import nearest_angles
from evmap.sources.ray_casting import cast_rays
from evmap.sources.rcd import Rcds, extract_rcds, wide_rcds
from evmap.sources.readings import SonarScan
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.surfaces import Surfaces

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["SonarCheck", "check_sonar", "in_sight", "map_surfaces", "masked"]


@dataclass(frozen=True, eq=False)
class SonarCheck:
    """The actual scan held against the scan the map predicts from the same pose.

    Attributes
    ----------
    surfaces : the map near the pose, as the sonar model sees it.
    runs : every run of constant depth of the actual scan, whatever its width (its primitive RCDs).
    actual : the actual RCDs at least ``rcd.min_width_deg`` wide, not at max range (of ``runs``).
    predicted_scan : the scan simulated from the map.
    predicted : its RCDs at least ``rcd.min_width_deg`` wide.
    matched : (actual index, predicted index) pairs.
    masked : (len(predicted),) simulated RCDs hidden behind a nearer actual echo.
    """

    surfaces: Surfaces
    runs: Rcds
    actual: Rcds
    predicted_scan: SonarScan
    predicted: Rcds
    matched: tuple[NDArray[np.intp], NDArray[np.intp]]
    masked: NDArray[np.bool_]


def check_sonar(bm: BeliefMap, sonar: SonarScan, runs: Rcds, config: Config) -> SonarCheck:
    """Simulate the scan the map predicts at the actual scan's pose and match the two scans' RCDs (``runs``: the
    actual scan's primitive ones)."""
    pose, reach = sonar.pose, sonar.params.max_range
    surfaces = map_surfaces(bm, (pose[0] - reach, pose[1] - reach, pose[0] + reach, pose[1] + reach))
    predicted_scan = simulate_scan(surfaces, pose, sonar.params)
    actual = wide_rcds(runs, reach, config.rcd)
    predicted = extract_rcds(predicted_scan, config.rcd)
    widths = (actual.width, predicted.width)
    matched = match_rcds(actual.direction, actual.range, predicted.direction, predicted.range, config.matching, widths)
    hidden = masked(sonar, predicted_scan, predicted, config)
    return SonarCheck(surfaces, runs, actual, predicted_scan, predicted, matched, hidden)


def map_surfaces(bm: BeliefMap, bounds: tuple[float, float, float, float] | None = None) -> Surfaces:
    """The map's lines and their corner and end points as surfaces for the sonar model.

    Every line is a specular, LSL-opaque surface; points are named by their ids,
    so a simulated reading names the map object that made it. With ``bounds``
    (xmin, ymin, xmax, ymax), only the lines near that box.
    """
    g = bm.graph
    lines = sorted(bm.near(bounds, "lines")) if bounds is not None else [d["id"] for _, _, d in g.edges()]
    line_ends = [bm.ends(lid) for lid in lines]
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


def masked(actual: SonarScan, predicted_scan: SonarScan, predicted: Rcds, config: Config) -> NDArray[np.bool_]:
    """Simulated RCDs hidden behind a nearer actual echo (the sonar hears the first echo only).

    An RCD is masked when the actual readings in its directions are, at the median,
    shorter than it by more than the matching range gate: an object the map does
    not hold (glass, say) answered first, so the sonar could not have heard this one.
    """
    if not len(actual) or not len(predicted):
        return np.zeros(len(predicted), dtype=bool)
    spans = [
        np.arange(i, j + 1) if j >= i else np.r_[i : len(predicted_scan), 0 : j + 1]
        for i, j in zip(predicted.start.tolist(), predicted.end.tolist(), strict=True)
    ]
    nearest = nearest_angles(actual.angles, predicted_scan.angles[np.concatenate(spans)])
    heard = np.split(actual.ranges[nearest], np.cumsum([len(idx) for idx in spans])[:-1])  # each RCD's readings
    return np.array([np.median(ranges) for ranges in heard]) < predicted.range - config.matching.range_gate


def in_sight(
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
