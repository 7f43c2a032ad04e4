"""Random indoor worlds in the scenario format, reproducible from a seed.

:func:`generate_world` draws, with ``numpy.random.default_rng(seed)`` and the
shares and ranges of :class:`WorldGenParams`:

- the LSL's detector (``sensors.lsl.detector``: ``threshold`` or ``column_max``);
- a floor plan (:mod:`~evmap.sources.sim.worldgen_plan`): a corridor, a hall or a
  large specular hall (wider than the sonar's reach) with rooms on either side,
  each reached by a door or a wider passage, and door recesses in bare walls;
- glass (:mod:`~evmap.sources.sim.worldgen_glazing`): perhaps a facade (a long
  outer wall of panes between mullions) and windows in other outer walls, with
  sunlight regions just inside some panes and windows that make short phantom
  LSL lines (0.05-0.35 m, as in the default corridor scenario);
- glass or mirror partitions standing out of a wall, and pillars
  (:mod:`~evmap.sources.sim.worldgen_furniture`);
- the robot's tour (:mod:`~evmap.sources.sim.worldgen_tour`): 3-6 poses along a
  path, each in sight of the previous one, or a single pose;
- small clutter of wall material (boxes, chair legs), clear of the tour, some of it in the sunlight.

The boundary rings of the free space are the walls, cut into polylines where the
material changes. Wall coordinates are multiples of :attr:`WorldGenParams.grid`
(5 cm), rounded to millimetres, so the YAML of :func:`scenario_yaml` is short and
exact. The result is validated by :class:`evmap.sources.sim.scenario.Scenario`;
the scenario's ``seed`` is the generator's seed, so its sensor noise and sunlight
lines derive from the same number. Whether each sunlight region is seen from two
poses or more is for the evaluation to compute from the scenario
(:func:`evmap.sources.sim.sightings.sunlight_sightings`).

>>> from evmap.sources.sim.scenario import parse_scenario
>>> s = generate_world(3)
>>> s.name, s.seed, len(s.robot.poses) >= 1, len(s.world.sunlight) >= 1
('world-3', 3, True, True)
>>> parse_scenario(scenario_yaml(s), "world-3.yaml") == s
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
import yaml

from evmap.sources.loading import validate
from evmap.sources.sim.scenario import Scenario
from evmap.sources.sim.worldgen_draw import Draws, coords
from evmap.sources.sim.worldgen_furniture import clutter, partitions, pillars
from evmap.sources.sim.worldgen_glazing import cap_lines, glass_spans, sunlight_regions, walls_by_material
from evmap.sources.sim.worldgen_params import WorldGenParams
from evmap.sources.sim.worldgen_plan import floor_plan
from evmap.sources.sim.worldgen_tour import tour

__all__ = ["generate_world", "scenario_yaml", "wall_segment_count", "world_seed"]


def world_seed(seed: int, index: int) -> int:
    """The seed of world ``index`` of an experiment with ``seed``: independent streams, < 2**63.

    >>> world_seed(1, 0) == world_seed(1, 0) != world_seed(1, 1)
    True
    """
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def wall_segment_count(scenario: Scenario) -> int:
    """The number of wall segments (consecutive point pairs) of a scenario.

    >>> wall_segment_count(generate_world(0)) >= 20
    True
    """
    return sum(len(w.points) - 1 for w in scenario.world.walls)


def generate_world(seed: int, params: WorldGenParams | None = None, name: str | None = None) -> Scenario:
    """A random indoor world from ``seed`` (see the module doc); the same seed gives the same scenario.

    Parameters
    ----------
    seed : int, 0 <= seed < 2**63; the generator's and the scenario's seed.
    params : what to draw from (default :class:`WorldGenParams`).
    name : the scenario's name (default ``world-SEED``).

    >>> a, b = generate_world(5), generate_world(5)
    >>> a == b, a == generate_world(6)
    (True, False)
    """
    if not isinstance(seed, int | np.integer) or not 0 <= seed < 2**63:
        raise ValueError(f"seed must be an integer with 0 <= seed < 2**63, got {seed!r}")
    name = name or f"world-{seed}"
    draws = Draws(np.random.default_rng(seed), params or WorldGenParams())
    return validate(Scenario, _world_data(draws, int(seed), name), f"{name}.yaml")


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as YAML text, one wall, cylinder, region or pose a line; ``parse_scenario`` reads it back.

    Only the keys the scenario was given are written (defaults stay implicit).

    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> text = "{version: 1, name: box, world: {walls: [{id: w, points: [[0, 0], [1, 0]]}]}, "
    >>> text += "robot: {poses: [[0, 1, 0]]}}"
    >>> print(scenario_yaml(parse_scenario(text, "x")))
    version: 1
    name: box
    world:
      walls:
        - {id: w, points: [[0.0, 0.0], [1.0, 0.0]]}
    robot:
      poses:
        - [0.0, 1.0, 0.0]
    <BLANKLINE>
    """
    data = scenario.model_dump(mode="json", exclude_unset=True)
    lines: list[str] = []
    for key, value in data.items():
        if key in ("world", "robot"):
            lines.append(f"{key}:")
            for part, items in value.items():
                lines.append(f"  {part}:" if items else f"  {part}: []")
                lines += [f"    - {_flow(item)}" for item in items]
        elif isinstance(value, dict):
            lines.append(f"{key}:")
            lines += [f"  {k}: {_flow(v)}" for k, v in value.items()]
        else:
            lines.append(f"{key}: {_flow(value)}")
    return "\n".join(lines) + "\n"


def _flow(value: Any) -> str:
    return yaml.safe_dump(value, default_flow_style=True, width=math.inf, sort_keys=False).strip().removesuffix("\n...")


def _world_data(draws: Draws, seed: int, name: str) -> dict[str, Any]:
    """The scenario's data; every draw goes through ``draws`` in this order."""
    p = draws.params
    detector = "column_max" if draws.chance(p.column_max_share) else "threshold"
    count = 1 if draws.chance(p.single_pose_share) else draws.count(p.poses)
    plan = floor_plan(draws)
    spans = glass_spans(draws, plan.edges)
    regions = cap_lines(sunlight_regions(draws, plan.free, spans), p, count)
    lit = [poly for poly, _ in regions]
    standing = partitions(draws, plan.free, plan.edges, lit)
    round_pillars = pillars(draws, plan.free, lit, standing)
    obstacles = [shapely.LineString(w["points"]) for w in standing] + [
        shapely.Point(c["center"]).buffer(c["radius"]) for c in round_pillars
    ]
    path = tour(draws, plan.free, obstacles, lit, count)
    boxes, legs = clutter(draws, plan.free, [*path.keep_clear, *obstacles], lit)
    return {
        "version": 1,
        "name": name,
        "seed": seed,
        "world": {
            "walls": walls_by_material(plan.free, spans) + standing + boxes,
            "cylinders": round_pillars + legs,
            "sunlight": [
                {"polygon": coords(poly.exterior.coords[:-1]), "lines": lines, "length": list(p.phantom_length)}
                for poly, lines in regions
            ],
        },
        "robot": {"poses": path.poses},
        "sensors": {"lsl": {"detector": detector}},
    }
