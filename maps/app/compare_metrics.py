"""The figures of one world in a comparison: fuse every config and rule on the same scans, measure each map.

Every rule runs on the same scans: the world is sensed once, from all its
poses, and the same observations are folded into one belief map per config and
rule (:func:`fuse_configs`; configs that sense alike share the scans). Per world,
config and rule, :func:`world_metrics` gives the :data:`METRICS` and the
:data:`HAZARDS` (what each measures: :data:`DEFINITIONS`), the :data:`COUNTS`
and the timings. A ratio whose denominator is empty (no noise segment, no such
glass wall, no line) is ``None``.

>>> from evmap.sources.config import load_config
>>> from evmap.sources.sim.worldgen import generate_world
>>> runs = fuse_rules(generate_world(2), load_config(), ["dempster", "yager"])
>>> sorted(runs), runs["dempster"].observations is runs["yager"].observations
(['dempster', 'yager'], True)
>>> m = world_metrics(runs["dempster"])
>>> set(METRICS) <= set(m), m["noise_segments"] > 0
(True, True)
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evmap.maps import new_map
from evmap.maps.app.compare_configs import sensing_key
from evmap.maps.app.compare_hazards import (
    SEEN_STEP,
    SPURIOUS_FAR,
    SPURIOUS_ON_LINE,
    free_behind_walls,
    free_seen_kept,
    spurious_unidentified,
    stripe_seen,
    surface_distances,
)
from evmap.maps.app.metrics import share
from evmap.maps.app.run import Run
from evmap.maps.observation import observe, sensing_config
from evmap.maps.pipeline import fold_observation
from evmap.sources.config_model import Config
from evmap.sources.geometry import perpendicular_feet, point_segment_distances
from evmap.sources.ray_casting import cast_rays
from evmap.sources.readings import SonarScan
from evmap.sources.sim.scenario import Scenario
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World

__all__ = [
    "BELIEF_BINS",
    "COLUMNS",
    "COUNTS",
    "DEFINITIONS",
    "DISTANCES",
    "EXTRA_COLUMNS",
    "FIGURES",
    "FREE_HAZARDS",
    "GLASS_RADIUS",
    "HAZARDS",
    "HEARD",
    "HEARD_TOLERANCE",
    "MAP_ERROR_STEP",
    "METRICS",
    "TRUTHS",
    "WorldResult",
    "belief_histograms",
    "fuse_configs",
    "fuse_rules",
    "heard_glass",
    "line_beliefs",
    "map_error",
    "visible_glass",
    "world_metrics",
]

METRICS = ("noise_recall", "real_loss", "glass_explained", "mean_conflict", "map_error")
"""The figures per world and rule (see the module doc)."""

COUNTS = ("noise_segments", "real_segments", "lines", "unidentified")
"""Counts per world and rule: segments by truth, map lines with belief >= 0.5, unidentified objects."""

HAZARDS = ("spurious_unidentified", "free_behind_walls")
"""The figures per world, config and rule of what a planner would trip on (:mod:`~evmap.maps.app.compare_hazards`)."""

FREE_HAZARDS = ("free_behind_opaque", "free_seen_kept")
"""The free space's figures added in version 1.2 of the comparison's files: cells hidden by opaque surfaces
alone, and the share of what the stripe saw free that the grid keeps free (written after every older column)."""

HEARD = ("glass_heard_explained",)
"""The glass figure added in version 1.3 of the comparison's files: of the glass walls the sonar really heard at
normal incidence (:func:`heard_glass`), the share explained (written after every older column)."""

FIGURES = (*METRICS, *HAZARDS, *FREE_HAZARDS, *HEARD)
"""Every figure given with its interval over the worlds and compared pairwise, in the files' order."""

HEARD_TOLERANCE = 0.05
"""A direct echo of a glass wall within this (m) of the perpendicular distance to it came at normal incidence."""

DISTANCES = ("map_error",)
"""The figures of :data:`METRICS`, :data:`HAZARDS` and :data:`FREE_HAZARDS` that are distances (m, at least 0);
every other one is a share, within [0, 1]."""

COLUMNS = ("rule", *METRICS, "max_conflict", *COUNTS, "seconds_per_world", "seconds_simulate")
"""The first columns of ``summary.csv``, as older versions wrote them; ``worlds.csv`` has ``world`` first.
``seconds...`` are timings."""

EXTRA_COLUMNS = ("config", *HAZARDS, "noise_eliminated", "real_eliminated", "sunlight_seen_twice")
"""The columns after :data:`COLUMNS` in ``worlds.csv`` (and, but ``config``, averaged in ``summary.csv``):
the config, the hazards, the eliminated segments by truth, and whether every sunlight region that a
pose sees is in sight and range of two poses or more (1) or not (0; set by the comparison, per world)."""

GLASS_RADIUS = 0.3
"""An unidentified object within this distance (m) of a glass wall explains it."""

MAP_ERROR_STEP = 0.05
"""Spacing (m) of the points along a map line whose distance to the true surfaces is measured."""

BELIEF_BINS = np.linspace(0.0, 1.0, 21)
"""Histogram bins of the line beliefs of real and phantom segments."""

DEFINITIONS = {
    "noise_recall": "noise (sunlight) segments eliminated / noise segments",
    "real_loss": "real segments eliminated / real segments",
    "glass_explained": (
        "share of the LSL-invisible, sonar-specular walls (glass, mirrors) seen at normal incidence from some pose, "
        f"unobstructed, that have an unidentified object within {GLASS_RADIUS} m"
    ),
    "mean_conflict": (
        "mean conflict K among the noise-elimination stage's sources (the paper's config: the sonar and the "
        "LSL length; the default's: its four sources) over all the segments the LSL returned (a property of "
        "each config's evidence: equal for every rule from one pose; from a tour's later poses it depends on the "
        "map each rule has built)"
    ),
    "map_error": (
        f"mean distance (m) to the nearest true surface of points every {MAP_ERROR_STEP} m along the final lines "
        "with belief at least 0.5"
    ),
    "spurious_unidentified": (
        f"unidentified objects farther than {SPURIOUS_FAR} m from every true surface or within {SPURIOUS_ON_LINE} m "
        "of a line with belief at least 0.5 / unidentified objects"
    ),
    "free_behind_walls": (
        "free cells of the occupancy grid (5 cm) behind true surfaces: every pose's sight line to the cell meets "
        "one more than a cell before it / free cells"
    ),
    "free_behind_opaque": (
        "free cells of the occupancy grid behind opaque true surfaces (glass and mirrors let the stripe through): "
        "every pose's sight line meets one more than a cell before the cell / free cells"
    ),
    "free_seen_kept": (
        f"places of a {SEEN_STEP} m lattice that a pose's stripe saw free (in front of the first surface of the ray, "
        "glass included; the ray returned) and not within a cell of any surface, that the grid marks free / such places"
    ),
    "glass_heard_explained": (
        "the same share as `glass_explained` over the glass walls some pose's sonar really heard at normal "
        f"incidence (a reading's first echo straight from the wall, within {HEARD_TOLERANCE} m of the perpendicular "
        "distance: the wide beam often hears something nearer first)"
    ),
}
"""What each of :data:`METRICS`, :data:`HAZARDS`, :data:`FREE_HAZARDS` and :data:`HEARD` measures, per world,
config and rule (``summary.md`` prints it)."""

TRUTHS = ("real", "noise")
"""The simulator's truths of a segment, in the order of the belief histograms' rows."""


def fuse_configs(scenario: Scenario, configs: Mapping[str, Config], rules: Sequence[str]) -> dict[tuple[str, str], Run]:
    """Sense the scenario once from every pose, then fold the same observations into one map per config and rule.

    Configs whose sensors differ (:func:`~evmap.maps.app.compare_configs.sensing_key`) sense
    the world anew. Each :class:`~evmap.maps.app.run.Run` shares the world and its
    observations; its ``seconds`` are ``simulate`` (shared), ``fuse`` (this config and
    rule) and ``total``.
    """
    world = World(scenario)
    sensed: dict[str, tuple[list[Any], float]] = {}
    runs = {}
    for name, given in configs.items():
        config = sensing_config(world, given)
        key = sensing_key(config)
        if key not in sensed:
            start = time.perf_counter()
            sensed[key] = [observe(world, k, config) for k in range(len(world.poses))], time.perf_counter() - start
        observations, simulate = sensed[key]
        for rule in rules:
            cfg = config.with_rule(rule)
            start = time.perf_counter()
            bm = new_map(cfg)
            outcomes = [fold_observation(bm, obs, cfg) for obs in observations]
            fuse = time.perf_counter() - start
            seconds = {"simulate": simulate, "fuse": fuse, "total": simulate + fuse}
            runs[name, rule] = Run(world, cfg, observations, outcomes, bm, seconds)
    return runs


def fuse_rules(scenario: Scenario, config: Config, rules: Sequence[str]) -> dict[str, Run]:
    """:func:`fuse_configs` of one config: the runs by rule."""
    return {rule: run for (_, rule), run in fuse_configs(scenario, {config.name: config}, rules).items()}


def world_metrics(
    run: Run,
    glass: NDArray[np.intp] | None = None,
    seen: NDArray[np.float64] | None = None,
    heard: NDArray[np.intp] | None = None,
) -> dict[str, float | int | None]:
    """The figures of one rule on one world (module doc); ``None`` where a ratio has no denominator.

    ``glass`` and ``heard``: the indices of :func:`visible_glass` and :func:`heard_glass` in the world's
    surfaces, and ``seen``: the places of :func:`~evmap.maps.app.compare_hazards.stripe_seen`, if already
    computed (they do not depend on the rule).
    """
    store = run.map.segments
    noise = store.truth == "noise"
    real = store.truth == "real"
    conflict = store.conflict[store.raw]  # of the segments the LSL returned, no line's support
    surfaces = run.world.surfaces()
    if glass is None:
        glass = visible_glass(run.world, run.config)
    if heard is None:
        heard = heard_glass(run.world, [obs.sonar for obs in run.observations])
    lines = run.map.lines(min_belief=0.5)
    unidentified = np.array([u.xy for u in run.map.unidentified()], dtype=float).reshape(-1, 2)
    explained, heard_explained = (_explained(unidentified, surfaces, walls) for walls in (glass, heard))
    spurious, objects = spurious_unidentified(run.map, run.world)
    if seen is None:
        seen = stripe_seen(run.world, run.config)
    behind, behind_opaque, free = free_behind_walls(run.map, run.world)
    kept, seen_free = free_seen_kept(run.map, seen)
    return {
        "noise_recall": share(store.eliminated & noise, noise),
        "real_loss": share(store.eliminated & real, real),
        "glass_explained": explained,
        "mean_conflict": float(conflict.mean()) if len(conflict) else None,
        "map_error": map_error([line.p for line in lines], [line.q for line in lines], surfaces),
        "max_conflict": float(conflict.max()) if len(conflict) else None,
        "noise_segments": int(noise.sum()),
        "real_segments": int(real.sum()),
        "lines": len(lines),
        "unidentified": len(unidentified),
        "seconds_per_world": run.seconds["fuse"],
        "seconds_simulate": run.seconds["simulate"],
        "spurious_unidentified": spurious / objects if objects else None,
        "free_behind_walls": behind / free if free else None,
        "noise_eliminated": int((store.eliminated & noise).sum()),
        "real_eliminated": int((store.eliminated & real).sum()),
        "free_behind_opaque": behind_opaque / free if free else None,
        "free_seen_kept": kept / seen_free if seen_free else None,
        "glass_heard_explained": heard_explained,
    }


def _explained(objects: NDArray[np.float64], surfaces: Surfaces, walls: NDArray[np.intp]) -> float | None:
    """The share of the ``walls`` (indices into the surfaces) with an object within :data:`GLASS_RADIUS`;
    None without walls."""
    if not len(walls):
        return None
    if not len(objects):
        return 0.0
    d = point_segment_distances(objects[:, None], surfaces.p[walls], surfaces.q[walls])  # (U, W)
    return float((d <= GLASS_RADIUS).any(axis=0).mean())


def heard_glass(world: World, scans: Sequence[SonarScan | None]) -> NDArray[np.intp]:
    """Indices (into ``world.surfaces()``) of the LSL-transparent, sonar-specular walls some scan really heard at
    normal incidence: a reading whose first echo came straight from the wall (the simulator's labels), within
    :data:`HEARD_TOLERANCE` of the perpendicular distance from the scan's pose, the foot inside the wall.

    >>> from evmap.maps.app.run import run_scenario
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> run = run_scenario(default_scenario(), load_config())
    >>> run.world.surfaces().segment_ids[heard_glass(run.world, [o.sonar for o in run.observations])].tolist()
    ['east-window-1']
    """
    s = world.surfaces()
    candidates = np.flatnonzero(~s.lsl_opaque & s.sonar_reflective)
    heard = np.zeros(len(candidates), dtype=bool)
    for scan in scans:
        if scan is None or not len(candidates):
            continue
        t, foot = perpendicular_feet(scan.pose[:2], s.p[candidates], s.q[candidates])
        dist = np.hypot(*(foot - scan.pose[:2]).T)
        direct = scan.order == 1
        for j in np.flatnonzero((t > 0) & (t < 1) & ~heard):
            echo = direct & (scan.target == s.segment_ids[candidates[j]])
            heard[j] = bool((np.abs(scan.ranges[echo] - dist[j]) <= HEARD_TOLERANCE).any())
    return candidates[heard]


def visible_glass(world: World, config: Config) -> NDArray[np.intp]:
    """Indices (into ``world.surfaces()``) of the LSL-transparent, sonar-specular walls seen at normal incidence.

    A wall is seen at normal incidence from a pose when the foot of the
    perpendicular from the pose lies strictly inside the wall, within the
    sonar's ``max_range`` (the scenario's, else the config's), and the sight
    line to it crosses no other surface (wall or cylinder, whatever its material).

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> world = World(default_scenario())
    >>> world.surfaces().segment_ids[visible_glass(world, load_config())].tolist()  # window 2 is beside the pose
    ['east-window-1']
    """
    s = world.surfaces()
    sonar, _ = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    candidates = np.flatnonzero(~s.lsl_opaque & s.sonar_reflective)
    if not len(candidates):
        return candidates
    p, q = s.p[candidates], s.q[candidates]
    seen = np.zeros(len(candidates), dtype=bool)
    for x, y, _ in world.poses:
        t, foot = perpendicular_feet([x, y], p, q)
        dist = np.hypot(foot[:, 0] - x, foot[:, 1] - y)
        ok = (t > 0) & (t < 1) & (dist > 0) & (dist <= sonar.max_range)
        if not ok.any():
            continue
        angles = np.arctan2(foot[ok, 1] - y, foot[ok, 0] - x)
        _, hit = cast_rays((x, y), angles, s.p, s.q, s.cylinder_centers, s.cylinder_radii, sonar.max_range)
        seen[np.flatnonzero(ok)[hit == candidates[ok]]] = True
    return candidates[seen]


def map_error(p: Sequence[Any], q: Sequence[Any], surfaces: Surfaces) -> float | None:
    """Mean distance (m) from points every :data:`MAP_ERROR_STEP` along lines p-q to the nearest true surface.

    Each line gives ``ceil(length / step) + 1`` evenly spaced points, both ends
    included; ``None`` when there are no lines.

    >>> from evmap.sources.sim.scenario import default_scenario
    >>> s = World(default_scenario()).surfaces()
    >>> round(map_error([(1.0, 0.1)], [(2.0, 0.1)], s), 6)
    0.1
    """
    if not len(p):
        return None
    p, q = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)
    count = np.ceil(np.hypot(*(q - p).T) / MAP_ERROR_STEP).astype(int) + 1
    line = np.repeat(np.arange(len(p)), count)
    t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
    points = p[line] + t[:, None] * (q - p)[line]
    return float(surface_distances(points, surfaces).mean())


def line_beliefs(run: Run) -> tuple[NDArray[np.float64], NDArray[np.str_]]:
    """Per segment: Bel(real) of the map line it ended in (0 if eliminated), and its truth.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.worldgen import generate_world
    >>> belief, truth = line_beliefs(fuse_rules(generate_world(2), load_config(), ["dempster"])["dempster"])
    >>> belief.shape == truth.shape, bool(((belief >= 0) & (belief <= 1)).all())
    (True, True)
    """
    store = run.map.segments
    by_line = {line.id: line.belief for line in run.map.lines(min_belief=0.0)}
    ids, which = np.unique(store.line.astype(str), return_inverse=True)
    belief = np.array([by_line.get(i, 0.0) for i in ids], dtype=float)[which.reshape(-1)]
    belief[store.eliminated] = 0.0
    return belief.reshape(-1), store.truth.copy()


def belief_histograms(run: Run) -> NDArray[np.int64]:
    """(2, len(BELIEF_BINS) - 1) segment counts per bin of :func:`line_beliefs`: real segments, then noise ones."""
    belief, truth = line_beliefs(run)
    return np.stack([np.histogram(belief[truth == t], BELIEF_BINS)[0] for t in TRUTHS])


@dataclass(frozen=True)
class WorldResult:
    """One world's outcome: its name and YAML, a row per config and rule, and belief histograms.

    ``beliefs[config, rule]`` is an int array (2, len(BELIEF_BINS) - 1): segment counts per
    belief bin, real segments then noise segments.
    """

    world: str
    yaml: str
    rows: tuple[dict[str, Any], ...]
    beliefs: dict[tuple[str, str], NDArray[np.int64]]
