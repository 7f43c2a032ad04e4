"""A planar laser's parameters for :mod:`evmap.sources.laser`, and the range noise a log's scans show."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from evmap.sources.logs.scan import LaserScan

__all__ = ["NOISE_SCANS", "LaserParams", "range_noise"]

NOISE_SCANS = 50
"""The first scans of a log whose range noise :func:`range_noise` measures (:meth:`LaserParams.for_noise`)."""


class LaserParams(BaseModel):
    """The laser's noise model and line-extraction parameters (metres and degrees at this edge).

    The defaults are tuned on the Intel and Freiburg 079 logs (``benchmarks/bench_logs.py``), the same for both.
    """

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True)

    sigma_r: float = Field(0.01, ge=0, le=1, description="range noise std (m); SICK LMS 2xx: about 1 cm")
    lambda_deg: float = Field(
        6.0, gt=0, lt=90, description="Borges & Aldon's breakpoint angle: flattest incidence still one surface"
    )
    min_points: int = Field(3, ge=2, le=1000, description="fewest points in a segment")
    sigma_per_metre: float = Field(0.005, ge=0, le=1, description="range noise std grows by this per metre of range")
    split_threshold: float = Field(0.01, gt=0, le=1, description="split distance from a piece's chord (m)")
    split_sigmas: float = Field(1.0, ge=0, le=10, description="split distance grows by this many range noise stds")
    cluster_min_points: int = Field(
        2, ge=2, le=1000, description="fewest points of a cluster that no piece holds to be fitted whole"
    )
    join_sigmas: float = Field(
        3.0,
        ge=0,
        le=10,
        description="a point no piece holds joins a neighbouring piece's line (a cluster without a piece is fitted "
        "whole) when its range is within this many range noise stds of where its ray meets the line",
    )
    end_points: int = Field(
        2,
        ge=0,
        le=2,
        description="a run of up to this many points that no piece holds, next to a piece of its cluster, becomes "
        "a segment of its own (0: none)",
    )
    beam_step_deg: float = Field(
        0.5,
        gt=0,
        le=10,
        description="beams closer than this are taken k = round(this / step) at a time, as one beam: a group's "
        "returns that agree within 3 range noise stds give their mean, another group its middle beam (the defaults "
        "fit beams 0.5-1 deg apart; at 0.25 deg with 1 cm of noise the splits cut walls into pieces shorter than it)",
    )

    def for_noise(self, noise: float) -> LaserParams:
        """These parameters for a laser whose range noise std is ``noise`` (m, :func:`range_noise`): the noise
        model (``sigma_r``, ``sigma_per_metre``) and ``split_threshold`` scaled by ``noise / sigma_r`` when that is
        above 1 (the defaults fit lasers of 1 cm or less: with 2-3 cm the splits cut walls into pieces of a few
        points across them), unchanged otherwise.

        >>> LaserParams().for_noise(0.006) == LaserParams(), LaserParams().for_noise(0.02).split_threshold
        (True, 0.02)
        """
        scale = noise / self.sigma_r if self.sigma_r > 0 else 1.0
        if not (np.isfinite(scale) and scale > 1):
            return self
        return self.model_copy(
            update={name: getattr(self, name) * scale for name in ("sigma_r", "sigma_per_metre", "split_threshold")}
        )


def range_noise(scans: Iterable[LaserScan]) -> float:
    """The range noise std (m) the scans show: the median over the scans of a robust estimate from each scan's
    second differences of range along its beams, ``1.4826 median |r[i-1] - 2 r[i] + r[i+1]| / sqrt(6)`` (a
    surface's own curvature from beam to beam is far smaller); 0 without scans of 20 such triples.

    >>> from evmap.sources.logs.scan import LaserScan
    >>> angles = np.radians(np.arange(-45.0, 45.25, 0.25))
    >>> wall = 2.0 / np.cos(angles) + np.random.default_rng(1).normal(0.0, 0.02, len(angles))
    >>> round(range_noise([LaserScan(0.0, np.zeros(3), angles, wall, 80.0)]), 2)
    0.02
    """
    found = []
    for scan in scans:
        d2 = scan.ranges[:-2] - 2 * scan.ranges[1:-1] + scan.ranges[2:]
        d2 = d2[np.isfinite(d2)]
        if len(d2) >= 20:
            found.append(1.4826 * float(np.median(np.abs(d2))) / np.sqrt(6))
    return float(np.median(found)) if found else 0.0
