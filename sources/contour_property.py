"""The ``contour_property`` sensor kind: a per-point property of the contour sensor, aggregated per segment.

The contour sensor (the LSL camera, a 2D laser) measures more than positions at
each point: a stripe's width or height in the image, a laser's return
intensity. Its readings are the points (m, world) and one value per point. One
feature per segment, for a sensor ``NAME`` with ``property: PROP``:

``NAME_PROP``
    the ``aggregate`` (median, mean, min or max) of the values of the points
    within ``match_distance`` of the segment; ``missing`` where there are none.

The simulation draws each point's value from a normal distribution per
material (``values: {material: [mean, std]}``), the key ``sunlight`` for the
points of sunlight phantoms.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, Strict

from evmap.sources.evidence import Name
from evmap.sources.sensor_kinds import SensorSpec

__all__ = ["AGGREGATES", "CONTOUR_ARRAYS", "ContourPropertySpec", "contour_features"]

Material = Annotated[str, Strict(), Field(min_length=1, max_length=200)]
Finite = Annotated[float, Field(allow_inf_nan=False)]

CONTOUR_ARRAYS: dict[str, tuple[int | str, ...]] = {"points": ("M", 2), "values": ("M",)}
"""A contour property's readings: the contour points (m, world) and each point's value."""

AGGREGATES = {"median": np.median, "mean": np.mean, "min": np.min, "max": np.max}
"""How the values of a segment's points become its feature."""


class ContourPropertySpec(SensorSpec):
    """``kind: contour_property``: which property, how it is aggregated, how it is simulated."""

    kind: Literal["contour_property"]
    property: Name = Field(description="the property's name; the feature is NAME_PROPERTY")
    aggregate: Literal["median", "mean", "min", "max"] = Field(
        "median", description="how the values of a segment's points make its feature"
    )
    match_distance: float = Field(0.03, gt=0, le=1, description="points this close to a segment are its (m)")
    missing: Finite = Field(0.0, description="the feature of a segment without points")
    spacing: float = Field(0.02, ge=0.001, le=1, description="between two simulated points of a segment (m)")
    values: dict[
        Material, Annotated[tuple[Finite, Annotated[float, Field(ge=0, allow_inf_nan=False)]], Strict(False)]
    ] = Field(
        default_factory=dict, max_length=100, description="simulation: material -> [mean, std] of a point's value"
    )

    def materials_named(self) -> dict[str, list[str]]:
        """The keys of ``values`` but ``sunlight`` (the phantoms' points)."""
        return {"values": [m for m in self.values if m != "sunlight"]}


def contour_features(
    spec: ContourPropertySpec,
    readings: Mapping[str, NDArray[np.float64]],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
) -> dict[str, NDArray[np.float64]]:
    """The aggregated property of every segment ``p``-``q`` (see the module doc).

    >>> spec = ContourPropertySpec(kind="contour_property", property="width")
    >>> pts = {"points": np.array([[0.0, 0], [0.5, 0], [1, 0], [3, 3]]), "values": np.array([2.0, 3, 9, 7])}
    >>> contour_features(spec, pts, np.array([[0.0, 0], [5, 5]]), np.array([[1.0, 0], [6, 5]]))
    {'width': array([3., 0.])}
    """
    points, values = readings["points"], readings["values"]
    e = q - p
    length2 = np.maximum((e**2).sum(axis=1), np.finfo(float).tiny)
    out = np.full(len(p), spec.missing)
    aggregate = AGGREGATES[spec.aggregate]
    for i in range(len(p)):  # one segment at a time: (M,) arrays, never (N, M)
        along = np.clip((points - p[i]) @ e[i] / length2[i], 0, 1)
        near = np.hypot(*(p[i] + along[:, None] * e[i] - points).T) <= spec.match_distance
        if near.any():
            out[i] = aggregate(values[near])
    return {spec.property: out}
