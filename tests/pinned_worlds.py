"""The generated worlds that regression tests name by seed, drawn as they were when the tests were written."""

from __future__ import annotations

from typing import Any

from evmap.sources.sim.worldgen_params import WorldGenParams


def former(**params: Any) -> WorldGenParams:
    """The generator's parameters before its clutter could stand in the sunlight and its pillars reach 0.4 m
    (session 43), the others as given: every world the same as then, draw for draw."""
    return WorldGenParams(sunlit_clutter_share=0, pillar_radius=(0.1, 0.25), **params)
