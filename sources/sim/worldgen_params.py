"""What the world generator draws from: :class:`WorldGenParams` (sizes in metres, counts, shares).

>>> p = WorldGenParams()
>>> p.poses, p.single_pose_share, p.column_max_share
((3, 6), 0.25, 0.5)
>>> WorldGenParams(hall_share=0.7, large_hall_share=0.5)
Traceback (most recent call last):
...
pydantic_core._pydantic_core.ValidationError: 1 validation error for WorldGenParams
  Value error, hall_share + large_hall_share: need at most 1, got 1.2 ...
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator

from evmap.sources.sim.spec import MAX_CYLINDERS, MAX_POSES, MAX_SUNLIGHT_LINES, MAX_SUNLIGHT_LINES_PER_REGION

__all__ = ["CountRange", "Range", "WorldGenParams"]

Range = tuple[float, float]
"""A ``(low, high)`` range of a size, drawn uniformly."""
CountRange = tuple[int, int]
"""A ``(low, high)`` range of a count, drawn uniformly, both ends included."""


class WorldGenParams(BaseModel):
    """What the generator draws from: sizes (m), counts and shares (probabilities).

    Every ``(low, high)`` pair is drawn uniformly (integers inclusive). The kind of
    floor plan is a large hall with probability ``large_hall_share``, a hall with
    ``hall_share``, a corridor otherwise.
    """

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True)

    grid: float = Field(0.05, gt=0, le=1, description="walls, doors and windows lie on this grid (m)")
    # floor plan
    hall_share: float = Field(0.25, ge=0, le=1, description="probability of a hall (instead of a corridor)")
    large_hall_share: float = Field(
        0.2,
        ge=0,
        le=1,
        description="probability of a large specular hall, wider than the sonar's reach: most echoes are lost",
    )
    corridor_length: Range = (7.0, 14.0)
    corridor_width: Range = (1.8, 3.0)
    hall_length: Range = (6.0, 10.0)
    hall_width: Range = (4.0, 6.0)
    large_hall_length: Range = Field((12.0, 20.0), description="length of a large hall (m)")
    large_hall_width: Range = Field((8.0, 14.0), description="width of a large hall (m)")
    rooms: CountRange = Field((2, 6), description="rooms along the main space's two sides")
    room_width: Range = (2.5, 4.5)
    room_depth: Range = (2.5, 4.0)
    wall_thickness: float = Field(
        0.15, gt=0, le=1, description="between the main space and a room, and between rooms (m)"
    )
    door_width: Range = (0.8, 1.1)
    passage_share: float = Field(0.3, ge=0, le=1, description="probability that a room opens by a passage, not a door")
    passage_width: Range = (1.5, 2.5)
    recesses: CountRange = Field((0, 3), description="door recesses in bare walls of the main space")
    recess_depth: Range = (0.15, 0.3)
    # glass and sunlight
    facade_share: float = Field(
        0.4,
        ge=0,
        le=1,
        description="probability that one long outer wall is a glass facade: panes between mullions, end to end",
    )
    facade_min_length: float = Field(3.0, gt=0, le=100, description="shortest outer wall made a facade (m)")
    pane_width: Range = Field((1.0, 2.0), description="width of a facade's glass pane (m)")
    mullion_width: Range = Field((0.05, 0.15), description="width of the wall between two panes of a facade (m)")
    window_share: float = Field(0.3, ge=0, le=1, description="probability that an outer wall long enough has windows")
    window_width: Range = (0.8, 1.5)
    sunlight_share: float = Field(
        0.7, ge=0, le=1, description="probability that a window or a facade pane has a sunlight region"
    )
    sunlight_depth: Range = (1.0, 2.0)
    sunlight_lines: CountRange = Field((10, 30), description="phantom lines of one sunlight region per pose")
    sunlight_lines_total: int = Field(
        150,
        ge=1,
        le=MAX_SUNLIGHT_LINES,
        description="most phantom lines of all regions together per pose (the regions' counts are scaled down; "
        "also kept within the scenario limit on phantom lines per run)",
    )
    phantom_length: Range = Field((0.05, 0.35), description="length range of the phantom lines (m)")
    partitions: CountRange = Field((0, 2), description="glass or mirror partitions standing out of a wall")
    partition_length: Range = (0.8, 2.0)
    mirror_share: float = Field(0.2, ge=0, le=1, description="probability that a partition is a mirror, not glass")
    pillars: CountRange = (0, 3)
    pillar_radius: Range = (0.1, 0.4)
    # clutter: small real objects of wall material, placed after the tour, clear of it
    boxes: CountRange = Field((0, 4), description="small boxes (rectangles of wall material, any orientation)")
    box_size: Range = Field((0.05, 0.6), description="side of a box (m)")
    chairs: CountRange = Field((0, 2), description="chairs: four thin cylinders (legs) at the corners of a square")
    chair_size: Range = Field((0.35, 0.5), description="distance between two neighbouring chair legs (m)")
    leg_radius: Range = Field((0.025, 0.05), description="radius of a chair leg (m)")
    sunlit_clutter_share: float = Field(
        0.3, ge=0, le=1, description="probability that a piece of clutter stands in a sunlight region (if any)"
    )
    # the robot's tour and sensors
    poses: CountRange = Field((3, 6), description="poses of a tour (a path, each pose in sight of the previous one)")
    single_pose_share: float = Field(
        0.25, ge=0, le=1, description="probability that the world is seen from one pose only (the tour's first)"
    )
    pose_step: Range = Field((1.0, 3.0), description="distance between consecutive poses of a tour (m)")
    clearance: float = Field(
        0.4, gt=0, le=5, description="a pose's distance from walls, partitions, pillars, clutter and sunlight (m)"
    )
    path_clearance: float = Field(
        0.25, gt=0, le=5, description="the straight path between consecutive poses keeps this far from obstacles (m)"
    )
    sight_range: float = Field(6.0, gt=0, le=100, description="the first pose sees a sunlight region this close (m)")
    column_max_share: float = Field(
        0.5,
        ge=0,
        le=1,
        description="probability that the scenario's LSL detector is column_max (else threshold); 0 or 1 fixes it",
    )

    @model_validator(mode="after")
    def _ordered(self) -> WorldGenParams:
        for name in type(self).model_fields:
            value = getattr(self, name)
            if isinstance(value, tuple) and not 0 <= value[0] <= value[1]:
                raise ValueError(f"{name}: need 0 <= low <= high, got {list(value)}")
        if not 1 <= self.poses[0] <= self.poses[1] <= MAX_POSES:
            raise ValueError(f"poses: need 1 <= low <= high <= {MAX_POSES}, got {list(self.poses)}")
        if self.sunlight_lines[1] > MAX_SUNLIGHT_LINES_PER_REGION:
            raise ValueError(
                f"sunlight_lines: at most {MAX_SUNLIGHT_LINES_PER_REGION} per region, got {list(self.sunlight_lines)}"
            )
        if self.pillars[1] + 4 * self.chairs[1] > MAX_CYLINDERS:
            raise ValueError(
                f"pillars and chairs: at most {MAX_CYLINDERS} cylinders (a chair has 4 legs), "
                f"got up to {self.pillars[1]} + 4 x {self.chairs[1]}"
            )
        if self.hall_share + self.large_hall_share > 1:
            raise ValueError(
                f"hall_share + large_hall_share: need at most 1, got {self.hall_share + self.large_hall_share:g}"
            )
        return self
