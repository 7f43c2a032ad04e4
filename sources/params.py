"""Parameters of the sensor models and of every pipeline stage, as pydantic models.

Each model's defaults are the paper's values, or the defaults that
``docs/METHOD.md`` gives where the paper leaves a method open. The config file
(``configs/paper.yaml``) and a scenario's ``sensors`` section are validated by
these same models, so a value has one name and one range everywhere. Degrees
and metres at this edge; the code converts to radians where it uses them.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = [
    "MAX_STRIPE_POINTS",
    "CornerParams",
    "LslParams",
    "MatchParams",
    "MergeParams",
    "NoiseParams",
    "OpenSpaceParams",
    "RcdParams",
    "SonarParams",
    "UnidentifiedParams",
]


MAX_STRIPE_POINTS = 5_000
"""Most stripe points of one LSL scan: ``snapshots`` times the rays of one snapshot
(``fov_deg / ray_step_deg + 1``); the paper's sensor has 2,040. One scan of 1.3 million
points (360 snapshots of 180 degrees every 0.05 degree) took 30 s; under the default config, 10 poses
of 18,000 points inside a ring of 1,000 wall segments took up to 109 s (``benchmarks/bench_limits.py``)."""


class _Params(BaseModel):
    """Unknown keys refused; strict types (a bool or a string is not a number, 5.0 is not a count); finite."""

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class SonarParams(_Params):
    """A rotating Polaroid-type ultrasonic transducer."""

    beam_width_deg: float = Field(25.0, gt=0, le=90, description="visibility angle of the sonic cone")
    step_deg: float = Field(1.0, ge=0.1, le=30, description="rotation between two readings")
    max_range: float = Field(10.0, gt=0, le=100, description="longest range the timing circuit reports (m)")
    range_noise: float = Field(0.005, ge=0, le=1, description="standard deviation of range noise (m)")
    directivity_deg: float = Field(
        15.0, gt=0, le=90, description="two-way beam pattern: echo amplitude falls as exp(-2 (angle / this)^2)"
    )
    detection_range: float = Field(
        12.0, gt=0, le=1000, description="range at which an on-axis echo of a wall or corner falls to the threshold (m)"
    )
    edge_strength: float = Field(0.25, ge=0, le=1, description="echo of a convex edge or free end, relative to a wall")
    cylinder_strength: float = Field(0.5, ge=0, le=1, description="echo of a cylinder, relative to a wall")


class LslParams(_Params):
    """A laser structured-light stripe sensor on a rotating pan unit."""

    fov_deg: float = Field(27.0, gt=0, le=180, description="camera field of view")
    snapshots: int = Field(15, ge=1, le=360, description="snapshots per rotational scan")
    step_deg: float = Field(24.0, gt=0, le=360, description="rotation between snapshots")
    max_range: float = Field(8.0, gt=0, le=100, description="farthest stripe point seen (m)")
    range_noise: float = Field(0.003, ge=0, le=1, description="range noise std per metre of range")
    split_threshold: float = Field(0.02, gt=0, le=1, description="polyline split distance (m)")
    min_points: int = Field(5, ge=2, le=1000, description="fewest stripe points in a segment")
    ray_step_deg: float = Field(0.2, ge=0.05, le=5, description="angle between two stripe points seen")
    split_sigmas: float = Field(3.0, ge=0, le=10, description="split distance grows by this many range-noise stds")
    break_distance: float = Field(0.1, gt=0, le=10, description="stripe points further apart break a polyline (m)")

    @model_validator(mode="after")
    def _few_enough_points(self) -> LslParams:
        """Refuse a scan of more than :data:`MAX_STRIPE_POINTS` stripe points.

        >>> LslParams(snapshots=360, fov_deg=180, ray_step_deg=0.05)
        Traceback (most recent call last):
        ...
        pydantic_core._pydantic_core.ValidationError: 1 validation error for LslParams
          Value error, 360 snapshots of 3601 stripe points (fov_deg / ray_step_deg + 1) make 1296360 stripe points per scan, more than the limit of 5000 [...]
        ...
        """
        points = self.snapshots * self.stripe_rays
        if points > MAX_STRIPE_POINTS:
            raise ValueError(
                f"{self.snapshots} snapshots of {self.stripe_rays} stripe points (fov_deg / ray_step_deg + 1) "
                f"make {points} stripe points per scan, more than the limit of {MAX_STRIPE_POINTS}"
            )
        return self

    @property
    def stripe_rays(self) -> int:
        """Stripe points (rays) of one snapshot.

        >>> LslParams().stripe_rays
        136
        """
        return int(self.fov_deg / self.ray_step_deg + 1e-9) + 1


class RcdParams(_Params):
    """Regions of constant depth: extraction and typing (section II.A)."""

    range_tolerance: float = Field(0.02, gt=0, le=1, description="readings within this of the run's median (m)")
    min_width_deg: float = Field(8.0, ge=0, le=360, description="narrowest RCD used for matching and counts")
    jump_threshold: float = Field(1.0, gt=0, description="range jump to a neighbour that marks Type IV (m)")


class OpenSpaceParams(_Params):
    """Open space from typed primitive RCDs."""

    margin: float = Field(0.03, ge=0, le=1, description="each sector's radius is shrunk by this (m)")
    widen_by_half_beam: bool = Field(False, description="widen each sector by half the beam angle")
    footprint_radius: float = Field(0.2, ge=0, le=5, description="the robot's own disc of open space (m)")
    arc_step_deg: float = Field(0.5, ge=0.01, le=10, description="angle between two vertices of a sector's arc")


class NoiseParams(_Params):
    """Noise elimination: relation of a segment to the open space and the threshold."""

    threshold: float = Field(0.5, ge=0, le=1, description="a segment whose fused Noise mass is above this is removed")
    inside_fraction: float = Field(0.99, gt=0, le=1, description="inside if this share of the length is in open space")
    outside_fraction: float = Field(0.01, ge=0, lt=1, description="outside if at most this share is in open space")

    @model_validator(mode="after")
    def _fractions_in_order(self) -> NoiseParams:
        """Refuse an ``outside_fraction`` not below ``inside_fraction`` (a segment cannot be both).

        >>> NoiseParams(inside_fraction=0.001)
        Traceback (most recent call last):
        ...
        pydantic_core._pydantic_core.ValidationError: 1 validation error for NoiseParams
          Value error, outside_fraction (0.01) must be below inside_fraction (0.001) [...]
        ...
        """
        if self.outside_fraction >= self.inside_fraction:
            raise ValueError(
                f"outside_fraction ({self.outside_fraction}) must be below inside_fraction ({self.inside_fraction})"
            )
        return self


class MergeParams(_Params):
    """Merging collinear segments."""

    distance: float = Field(0.05, ge=0, le=1, description="end points within this of the other line (m)")
    angle_deg: float = Field(10.0, ge=0, le=90, description="directions within this")
    gap: float = Field(0.05, ge=0, le=1, description="largest gap along the line between the two (m)")


class CornerParams(_Params):
    """Corners from end points of non-parallel lines."""

    distance: float = Field(0.05, ge=0, le=1, description="end points within this meet at their centroid (m)")
    min_angle_deg: float = Field(10.0, ge=0, le=90, description="lines closer than this to parallel make no corner")
    drawn_apart: bool = Field(
        False,
        description="lines drawn from their corner must stay min_angle_deg from parallel, within half of "
        "min_angle_deg of their own directions, and unrelated (merging's tolerances) to every other line as "
        "fitted, else the end of the one it turns most is left free",
    )


class MatchParams(_Params):
    """Matching actual and simulated RCDs (a gated global assignment)."""

    angle_scale_deg: float = Field(10.0, gt=0, description="direction difference of unit cost")
    range_scale: float = Field(0.05, gt=0, description="range difference of unit cost (m)")
    angle_gate_deg: float = Field(12.5, gt=0, description="pairs further apart in direction never match")
    range_gate: float = Field(0.10, gt=0, description="pairs further apart in range never match (m)")
    width_gate_deg: float = Field(
        0.0,
        ge=0,
        le=360,
        description="an actual RCD wider than the simulated one by more than this never matches it: a stronger "
        "target than the map's answered there; 0, the paper's method: widths are not compared",
    )


class UnidentifiedParams(_Params):
    """Unidentified objects from unmatched actual RCDs."""

    merge_radius: float = Field(0.3, ge=0, description="unidentified objects closer than this are one (m)")
    occlusion_margin: float = Field(
        0.1, ge=0, description="a map line this much nearer than an RCD's range hides its target (m)"
    )
    explained_distance: float = Field(
        0.0,
        ge=0,
        le=1,
        description="an unmatched RCD whose target lies this close to a map line is that line's echo, not an "
        "object (m); 0, the paper's method: every unmatched RCD in sight is an object",
    )
    masked_aim: bool = Field(
        False,
        description="a Type II RCD is cut on its shorter neighbour's side by a nearer echo (the sonar reports the "
        "first one): its object is placed toward that side, one detection half-width of a wall or corner at its "
        "range from its free edge; false, the paper's method: at the RCD's direction",
    )
    pane_in_line: float = Field(
        0.0,
        ge=0,
        le=1,
        description="a run of the actual scan the paper's rule makes no object of (Type IV, or narrower than "
        "rcd.min_width_deg; or matched to the map's prediction, then with more than two readings the map's scan "
        "does not hear at its range) is a pane's echo, an object at the foot of the pose's perpendicular on a "
        "believed line at least 0.2 m long, when its range is within this (m) of that perpendicular's length, the "
        "foot within its arc (or, Type IV, on its nearer neighbour's side within a wall's detection half-width of "
        "its readings), in a gap of the believed lines and not predicted by the map's scan; with no believed line in "
        "line, at the foot on a line square to such a normal at its range between two frames of the pose's stripe "
        "points on it, at most 2.5 m apart; 0, the paper's method: no such objects",
    )
    behind_contour: bool = Field(
        False,
        description="an unmatched RCD whose target lies beyond the pose's own stripe (its points, and the chords "
        "across gaps in it) is a multiple reflection, not an object: sound does not come back through the surface "
        "the stripe measured; false, the paper's method",
    )
    window_width: float = Field(
        2.5,
        gt=0,
        description="with behind_contour, a gap in the stripe at most this wide (m) between stripe points on "
        "believed lines that its chord continues is a window in a wall: an echo beyond its chord came back "
        "through the glass",
    )
    pane_width: float = Field(
        0.0,
        ge=0,
        description="a believed unidentified object is a pane this wide (m), square to the bearing it was heard "
        "at: an object whose every path to the poses that heard it crosses another's pane, and lies more than "
        "merge_radius beyond it, is a multiple reflection and is removed; 0, the paper's method: no panes",
    )
    mirror_tolerance: float = Field(
        0.0,
        ge=0,
        description="an unidentified object whose mirror image in the line of a believed map line or a pane's face "
        "(its path from each pose that heard it crossing the line, more than merge_radius beyond it, past the "
        "mirror's ends by at most window_width and its length and, where carried on square in front of the pose, "
        "heard there; off its normal by more than the sonar's half-width) lies within this (m) of a believed "
        "corner, line end or object in sight is that target's echo off the wall, or the glass, and is removed; "
        "0, the paper's method: no mirror images",
    )
    behind_depth: float = Field(
        0.0,
        ge=0,
        description="an unidentified object lying more than this (m) beyond the stripe's contour on believed lines "
        "(as behind_contour) of every pose that heard it is a multiple reflection and is removed, judged again as "
        "lines become believed; 0, the paper's method: objects are judged when made only",
    )
