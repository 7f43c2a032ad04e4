"""The ``detector`` sensor kind: reports objects of some materials, with a detection probability and false alarms.

A detector (a radar reporting solid walls, a glass detector, a door detector)
reports, from one pose, the positions of the parts of objects of its
``materials`` that it detected: one report per ``patch`` of surface, each
detected with the probability ``detection`` at its range (piecewise linear
through ``[range, probability]`` points), plus false reports at the rate
``false_alarms`` (expected reports per metre of range per scan, piecewise linear
in range). Its readings are the pose and the reported points. One feature per
segment, for a sensor ``NAME``:

``NAME_detection``
    ``out_of_view`` if the segment's midpoint is beyond ``max_range`` or outside
    the field of view; else ``detected`` if a report lies within
    ``match_distance`` of the segment; else ``missed``.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, Strict, ValidationInfo, field_validator, model_validator

from evmap.sources.geometry import wrapped
from evmap.sources.sensor_kinds import SensorSpec

__all__ = [
    "DETECTOR_ARRAYS",
    "DETECTOR_CATEGORIES",
    "MAX_FALSE_ALARMS",
    "MAX_PATCHES",
    "DetectorSpec",
    "detector_features",
]

MAX_FALSE_ALARMS = 1_000
"""Most false reports a detector expects per scan (``false_alarms`` over its range and field of view).
100,000 per scan (1,000 per metre up to 100 m) took 40 s over 10 poses (``benchmarks/bench_limits.py``)."""

MAX_PATCHES = 200_000
"""Most surface patches a simulated detector cuts a world's walls into (``patch`` metres each): 1,000 wall
segments of 1e7 m in patches of 1 cm would be 1e12 points; 200,000 take about 10 MB a pose."""

Material = Annotated[str, Strict(), Field(min_length=1, max_length=200)]
Point = Annotated[tuple[Annotated[float, Field(ge=0, le=100)], Annotated[float, Field(ge=0, le=1000)]], Strict(False)]

DETECTOR_ARRAYS: dict[str, tuple[int | str, ...]] = {"pose": (3,), "points": ("D", 2)}
"""A detector's readings: the pose (x, y, heading rad) and the reported points (m, world)."""

DETECTOR_CATEGORIES: dict[str, tuple[str, ...] | None] = {"detection": ("detected", "missed", "out_of_view")}
"""The feature of a detector and its categories."""


class DetectorSpec(SensorSpec):
    """``kind: detector``: what a detector reports, how well, and how its reports are matched to segments."""

    kind: Literal["detector"]
    materials: list[Material] = Field(min_length=1, max_length=100, description="materials of the objects reported")
    max_range: float = Field(4.0, gt=0, le=100, description="nothing is reported beyond this (m)")
    fov_deg: float = Field(360.0, gt=0, le=360, description="field of view, centred on facing_deg")
    facing_deg: float = Field(0.0, ge=-360, le=360, description="centre of the field of view from the heading")
    detection: list[Point] = Field(
        [(0.0, 0.9), (4.0, 0.6)], min_length=1, max_length=100, description="[range, P(detect)], range increasing"
    )
    false_alarms: list[Point] = Field(
        [(0.0, 0.0), (4.0, 0.5)], min_length=1, max_length=100, description="[range, false reports per m], increasing"
    )
    patch: float = Field(0.2, ge=0.01, le=10, description="one report per this much surface (m)")
    position_noise: float = Field(0.02, ge=0, le=1, description="std of a report's position (m)")
    match_distance: float = Field(0.1, gt=0, le=10, description="a report this close to a segment detects it (m)")

    def materials_named(self) -> dict[str, list[str]]:
        """``materials``."""
        return {"materials": list(self.materials)}

    @field_validator("detection", "false_alarms")
    @classmethod
    def _increasing(cls, points: list[tuple[float, float]], info: ValidationInfo) -> list[tuple[float, float]]:
        """A table's ranges strictly increase; a detection probability is in [0, 1] (errors at the table's line)."""
        ranges = [r for r, _ in points]
        if any(b <= a for a, b in itertools.pairwise(ranges)):
            raise ValueError("ranges must be strictly increasing")
        if info.field_name == "detection" and any(not 0 <= prob <= 1 for _, prob in points):
            raise ValueError("probabilities must be in [0, 1]")
        return points

    @model_validator(mode="after")
    def _few_false_alarms(self) -> DetectorSpec:
        expected = float(self.false_alarm_bins()[1].sum())
        if expected > MAX_FALSE_ALARMS:
            raise ValueError(
                f"false_alarms: {expected:.0f} false reports expected per scan, more than the limit of {MAX_FALSE_ALARMS}"
            )
        return self

    def false_alarm_bins(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The 201 range bin edges from 0 to ``max_range`` and the expected false reports per scan in each bin.

        >>> edges, rate = DetectorSpec(kind="detector", materials=["wall"]).false_alarm_bins()
        >>> len(edges), len(rate), round(float(rate.sum()), 3)  # 0 to 0.5 per metre over 4 m
        (201, 200, 1.0)
        """
        edges = np.linspace(0, self.max_range, 201)
        mid, width = (edges[1:] + edges[:-1]) / 2, np.diff(edges)
        rate = np.maximum(np.interp(mid, *np.array(self.false_alarms).T), 0) * width * self.fov_deg / 360
        return edges, rate

    def in_view(self, pose: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """(M,) whether each point is within range and field of view of the pose."""
        d = points - pose[:2]
        bearing = np.arctan2(d[:, 1], d[:, 0]) - pose[2] - np.radians(self.facing_deg)
        off = np.abs(wrapped(bearing))
        return (np.hypot(d[:, 0], d[:, 1]) <= self.max_range) & (off <= np.radians(self.fov_deg) / 2 + 1e-12)


def detector_features(
    spec: DetectorSpec, readings: Mapping[str, NDArray[np.float64]], p: NDArray[np.float64], q: NDArray[np.float64]
) -> dict[str, NDArray[np.str_]]:
    """``detection`` of every segment ``p``-``q`` (see the module doc).

    >>> spec = DetectorSpec(kind="detector", materials=["glass"], max_range=3)
    >>> seen = {"pose": np.zeros(3), "points": np.array([[1.0, 0.05]])}
    >>> detector_features(spec, seen, np.array([[1.0, -1], [0, 1], [5, 0]]), np.array([[1, 1], [0.2, 1], [5, 1]]))
    {'detection': array(['detected', 'missed', 'out_of_view'], dtype='<U11')}
    """
    pose, points = readings["pose"], readings["points"]
    e = q - p
    length2 = np.maximum((e**2).sum(axis=1), np.finfo(float).tiny)
    along = np.clip(((points[None, :, :] - p[:, None, :]) * e[:, None, :]).sum(axis=2) / length2[:, None], 0, 1)
    gap = np.hypot(*(p[:, None, :] + along[..., None] * e[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    detected = (gap <= spec.match_distance).any(axis=1) if points.size else np.zeros(len(p), dtype=bool)
    visible = spec.in_view(pose, (p + q) / 2)
    answer = np.where(~visible, "out_of_view", np.where(detected, "detected", "missed"))
    return {"detection": answer.astype("<U11")}
