"""The ``range`` sensor kind: any range sensor (one beam, a ring of N, rotating), its features of segments.

A range sensor's readings are beams: the pose of the robot, each beam's world
bearing (rad) and its range (m; ``inf`` where no echo came back within
``max_range``). A beam is a cone ``cone_deg`` wide; the first echo anywhere in
the cone ends it, so the cone is free up to the range. Its free space is the
union of these sectors, each shrunk by ``margin`` (``free_space: beams``), or,
for a rotating sonar, the paper's open space from the typed RCDs of the scan
(``free_space: rcd``, :mod:`evmap.sources.open_space`), so the sonar's Table 1
is an instance of this kind. Two features per segment, for a sensor ``NAME``:

``NAME_relation``
    ``outside``, ``partly_inside`` or ``inside`` the free space, by the share of
    the segment's length in it (:func:`evmap.sources.relation.inside_fraction`,
    thresholds ``outside_fraction`` and ``inside_fraction``): Table 1's feature.
``NAME_return``
    ``echo`` if a reading ended on the segment (a point of the segment within
    the reading's cone and within ``hit_tolerance`` of its range), else ``beyond``
    if at least ``pass_fraction`` of the segment is free space (beams passed
    where it is), else ``no_return``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Literal

import numpy as np
import shapely
from numpy.typing import NDArray
from pydantic import Field, Strict, model_validator

from evmap.sources.geometry import wrapped
from evmap.sources.open_space import open_space
from evmap.sources.params import OpenSpaceParams, RcdParams, SonarParams
from evmap.sources.rcd import extract_rcds
from evmap.sources.readings import SonarScan
from evmap.sources.relation import RELATIONS, inside_fraction
from evmap.sources.sensor_kinds import SensorSpec

__all__ = ["MAX_RANGE_RAYS", "RANGE_ARRAYS", "RANGE_CATEGORIES", "RangeSpec", "free_space", "range_features"]

Material = Annotated[str, Strict(), Field(min_length=1, max_length=200)]

RANGE_ARRAYS: dict[str, tuple[int | str, ...]] = {"pose": (3,), "angles": ("B",), "ranges": ("B",)}
"""A range sensor's readings: pose (x, y, heading rad), beam bearings (rad, world), ranges (m, ``inf`` none)."""

RANGE_CATEGORIES: dict[str, tuple[str, ...] | None] = {
    "relation": RELATIONS,
    "return": ("echo", "beyond", "no_return"),
}
"""The features of a range sensor and their categories."""

SAMPLES = 9
"""Points along a segment tested against every reading for ``NAME_return``."""


MAX_RANGE_RAYS = 2_000
"""Most rays one range sensor casts per pose: ``beams`` x ``sweep_steps`` x ``rays``. One sensor of
3,600 beams of 100 rays took 5 s and 0.5 GB per pose; 16 sensors (a config may declare that many) of
10,000 rays each, 10 poses inside a ring of 1,000 wall segments, took 75 s (``benchmarks/bench_limits.py``)."""


class RangeSpec(SensorSpec):
    """``kind: range``: the geometry, physics and feature thresholds of a range sensor."""

    kind: Literal["range"]
    beams: int = Field(1, ge=1, le=3600, description="beams of the ring (1: a single beam)")
    first_deg: float = Field(0.0, ge=-360, le=360, description="bearing of the first beam from the heading")
    spacing_deg: float | None = Field(None, gt=0, le=360, description="between beams (default: 360 / beams)")
    sweep_steps: int = Field(1, ge=1, le=3600, description="a rotating sensor: readings per beam per pose")
    sweep_step_deg: float = Field(0.0, ge=0, le=360, description="rotation between two sweep steps")
    cone_deg: float = Field(10.0, gt=0, le=180, description="width of each beam's cone")
    max_range: float = Field(2.0, gt=0, le=100, description="no echo beyond this (m)")
    range_noise: float = Field(0.01, ge=0, le=1, description="range noise std per metre of range")
    echo: list[Material] = Field(["wall", "foam"], max_length=100, description="materials that return an echo")
    absorb: list[Material] = Field([], max_length=100, description="materials that stop the beam without echo")
    rays: int = Field(5, ge=1, le=100, description="rays across the cone in the simulation")
    free_space: Literal["beams", "rcd"] = Field("beams", description="sectors of the beams, or the paper's RCDs")
    margin: float = Field(0.03, ge=0, le=1, description="each free sector is shrunk by this (m)")
    hit_tolerance: float = Field(0.05, gt=0, le=1, description="a reading ends on a segment this close (m)")
    pass_fraction: float = Field(0.5, gt=0, le=1, description="`beyond` if this share of a segment is free")
    inside_fraction: float = Field(0.99, gt=0, le=1, description="`inside` if this share is free")
    outside_fraction: float = Field(0.01, ge=0, lt=1, description="`outside` if at most this share is free")
    rcd: RcdParams = Field(RcdParams(), description="`free_space: rcd`: how RCDs are extracted (as `rcd:`)")
    open_space: OpenSpaceParams = Field(
        OpenSpaceParams(), description="`free_space: rcd`: how RCDs make open space (as `open_space:`)"
    )

    def materials_named(self) -> dict[str, list[str]]:
        """``echo`` and ``absorb``."""
        return {"echo": list(self.echo), "absorb": list(self.absorb)}

    @model_validator(mode="after")
    def _few_enough_rays(self) -> RangeSpec:
        """Refuse a sensor casting more than :data:`MAX_RANGE_RAYS` rays per pose.

        >>> RangeSpec(kind="range", beams=360, sweep_steps=10, rays=5)
        Traceback (most recent call last):
        ...
        pydantic_core._pydantic_core.ValidationError: 1 validation error for RangeSpec
          Value error, 360 beams x 10 sweep steps x 5 rays make 18000 rays per pose, more than the limit of 2000 [...]
        ...
        """
        rays = self.beams * self.sweep_steps * self.rays
        if rays > MAX_RANGE_RAYS:
            raise ValueError(
                f"{self.beams} beams x {self.sweep_steps} sweep steps x {self.rays} rays make {rays} rays per pose, "
                f"more than the limit of {MAX_RANGE_RAYS}"
            )
        return self

    @model_validator(mode="after")
    def _consistent(self) -> RangeSpec:
        """Refuse crossed relation fractions (as ``noise:`` does) and a material both echoing and absorbing.

        >>> RangeSpec(kind="range", echo=["wall", "glass"], absorb=["glass"])
        Traceback (most recent call last):
        ...
        pydantic_core._pydantic_core.ValidationError: 1 validation error for RangeSpec
          Value error, material 'glass' is in both echo and absorb: say which it does [...]
        ...
        """
        if self.outside_fraction >= self.inside_fraction:
            raise ValueError(
                f"outside_fraction ({self.outside_fraction}) must be below inside_fraction ({self.inside_fraction})"
            )
        if both := sorted(set(self.echo) & set(self.absorb)):
            raise ValueError(f"material {both[0]!r} is in both echo and absorb: say which it does")
        return self

    def beam_offsets(self) -> NDArray[np.float64]:
        """(B,) bearing of every reading from the heading (rad): beams times sweep steps, in reading order."""
        spacing = self.spacing_deg if self.spacing_deg is not None else 360.0 / self.beams
        beams = self.first_deg + spacing * np.arange(self.beams)
        return np.radians((beams[:, None] + self.sweep_step_deg * np.arange(self.sweep_steps)).ravel())


def free_space(spec: RangeSpec, readings: Mapping[str, NDArray[np.float64]]) -> shapely.Geometry:
    """The free space the readings show: the union of the beams' sectors, or the RCD open space.

    >>> spec = RangeSpec(kind="range", beams=1, cone_deg=10, margin=0.0)
    >>> area = free_space(spec, {"pose": np.zeros(3), "angles": np.zeros(1), "ranges": np.ones(1)})
    >>> round(area.area, 3)  # pi * 1^2 * 10 / 360
    0.087
    """
    pose, angles = readings["pose"], readings["angles"]
    ranges = np.minimum(readings["ranges"], spec.max_range)
    if spec.free_space == "rcd":
        turned = angles[0] + np.mod(angles - angles[0], 2 * np.pi) if len(angles) else angles
        order = np.argsort(turned, kind="stable")  # a scan's bearings increase within one turn
        step = (spec.sweep_step_deg if spec.sweep_steps > 1 else spec.spacing_deg) or 360.0 / spec.beams
        params = SonarParams(max_range=spec.max_range, beam_width_deg=min(spec.cone_deg, 90.0), step_deg=step)
        scan = SonarScan.from_readings(turned[order], ranges[order], params, pose=pose)
        return open_space(scan, extract_rcds(scan, spec.rcd, primitive=True), spec.open_space)
    half = np.radians(spec.cone_deg) / 2
    radius = ranges - spec.margin
    keep = radius > 0
    t = np.linspace(-half, half, max(2, int(np.ceil(np.degrees(2 * half) / 2)) + 1))
    a = angles[keep][:, None] + t  # (K, T) arc bearings
    arcs = pose[:2] + radius[keep][:, None, None] * np.stack([np.cos(a), np.sin(a)], axis=-1)
    rings = np.concatenate([np.broadcast_to(pose[:2], (len(a), 1, 2)), arcs], axis=1)
    return shapely.union_all(shapely.polygons(rings)) if len(rings) else shapely.Polygon()


def range_features(
    spec: RangeSpec, readings: Mapping[str, NDArray[np.float64]], p: NDArray[np.float64], q: NDArray[np.float64]
) -> dict[str, NDArray[np.str_]]:
    """``relation`` and ``return`` of every segment ``p``-``q`` (see the module doc).

    >>> spec = RangeSpec(kind="range", beams=4, cone_deg=10, max_range=3)
    >>> beams = {"pose": np.zeros(3), "angles": np.radians([0.0, 90, 180, 270]), "ranges": np.array([1, 2, np.inf, 1])}
    >>> f = range_features(spec, beams, np.array([[1.0, -0.1], [0, 1], [-5, 0]]), np.array([[1, 0.1], [0, 1.1], [-5, 1]]))
    >>> f["return"].tolist(), f["relation"].tolist()
    (['echo', 'beyond', 'no_return'], ['outside', 'inside', 'outside'])
    """
    space = free_space(spec, readings)
    share = inside_fraction(p, q, space)
    code = (share > spec.outside_fraction).astype(np.intp) + (share >= spec.inside_fraction)
    relation = np.asarray(RELATIONS)[code]

    pose, angles, ranges = readings["pose"], readings["angles"], readings["ranges"]
    found = np.isfinite(ranges) & (ranges <= spec.max_range)
    t = np.linspace(0.0, 1.0, SAMPLES)
    points = p[:, None, :] + t[:, None] * (q - p)[:, None, :] - pose[:2]  # (N, S, 2)
    bearing = np.arctan2(points[..., 1], points[..., 0])
    distance = np.hypot(points[..., 0], points[..., 1])
    off = np.abs(wrapped(bearing[..., None] - angles[found]))  # (N, S, B)
    in_cone = off <= np.radians(spec.cone_deg) / 2
    ended = in_cone & (np.abs(distance[..., None] - ranges[found]) <= spec.hit_tolerance)
    echo = ended.any(axis=(1, 2)) if len(p) else np.zeros(0, dtype=bool)
    answer = np.where(echo, "echo", np.where(share >= spec.pass_fraction, "beyond", "no_return"))
    return {"relation": relation, "return": answer.astype(str)}
