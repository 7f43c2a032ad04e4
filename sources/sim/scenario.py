"""Scenario files: the world, the robot's poses and the sensor hardware (``docs/SCENARIO.md``).

A scenario file is untrusted input. It is read with the safe YAML loader of
:mod:`evmap.sources.loading` and validated by the pydantic models below, every model
with ``extra="forbid"``; any problem raises :class:`~evmap.sources.loading.InputError`
naming the file, the line, the key path (``world.walls[3].points``) and what is
wrong. Sizes are checked against the limits of :mod:`evmap.sources.sim.spec` before
anything else is validated, so an absurd file costs no work; types are strict (a
bool is not a number, a string not a number, binary data not a string).

Checks beyond the types: unknown keys, unknown materials, polylines with fewer
than two points, zero-length segments, non-finite numbers, coordinates and headings
out of bounds, a pose inside a cylinder or on a wall, duplicate ids (walls and cylinders share one namespace, and an id
holds no ``:``, which :mod:`evmap.sources.sim.world` uses to name a wall's segments), a
sunlight polygon that is not a simple polygon of positive area, and a sunlight
length range that is empty or too long for its polygon (see :data:`MIN_FIT_RATE`).

>>> s = parse_scenario('''
... version: 1
... name: box
... world:
...   walls: [{id: w, points: [[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]]}]
... robot: {poses: [[1, 1, 90]]}
... ''', "box.yaml")
>>> s.name, s.seed, s.world.walls[0].material
('box', 0, 'wall')
"""

from __future__ import annotations

from numbers import Real
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import pydantic_core
import shapely
from pydantic import AfterValidator, Field, field_validator, model_validator

from evmap import configs
from evmap.sources.loading import InputError, load_model, parse_document
from evmap.sources.params import LslParams, SonarParams
from evmap.sources.sim.spec import (
    MAX_COORDINATE,
    MAX_CYLINDERS,
    MAX_HEADING_DEG,
    MAX_PHANTOMS_PER_RUN,
    MAX_POLYGON_VERTICES,
    MAX_POSES,
    MAX_SUNLIGHT_LINES,
    MAX_SUNLIGHT_LINES_PER_REGION,
    MAX_SUNLIGHT_REGIONS,
    MAX_WALL_SEGMENTS,
    MIN_POSE_CLEARANCE,
    MIN_SEGMENT_LENGTH,
    Coordinate,
    Count,
    Heading,
    Number,
    Point,
    SpecModel,
    Text,
)
from evmap.sources.sim.sunlight import MIN_FIT_RATE, Sunlight

__all__ = [
    "BUILTIN_MATERIALS",
    "MAX_COORDINATE",
    "MAX_CYLINDERS",
    "MAX_HEADING_DEG",
    "MAX_PHANTOMS_PER_RUN",
    "MAX_POLYGON_VERTICES",
    "MAX_POSES",
    "MAX_SUNLIGHT_LINES",
    "MAX_SUNLIGHT_LINES_PER_REGION",
    "MAX_SUNLIGHT_REGIONS",
    "MAX_WALL_SEGMENTS",
    "MIN_FIT_RATE",
    "MIN_POSE_CLEARANCE",
    "MIN_SEGMENT_LENGTH",
    "Cylinder",
    "Id",
    "LslSensor",
    "Material",
    "Robot",
    "Scenario",
    "Sensors",
    "Sunlight",
    "Wall",
    "WorldSpec",
    "default_scenario",
    "load_scenario",
    "parse_scenario",
]


class Material(SpecModel):
    """How a surface looks to each sensor."""

    lsl: Literal["opaque", "transparent"] = Field(description="opaque surfaces return stripe points")
    sonar: Literal["specular", "absorbing"] = Field(description="specular surfaces reflect sound")


BUILTIN_MATERIALS: dict[str, Material] = {
    "wall": Material(lsl="opaque", sonar="specular"),
    "glass": Material(lsl="transparent", sonar="specular"),
    "mirror": Material(lsl="transparent", sonar="specular"),
    "foam": Material(lsl="opaque", sonar="absorbing"),
}
"""The four materials every scenario knows; its ``materials`` section may override them."""


def _no_colon(name: str) -> str:
    if ":" in name:
        raise ValueError("an id must not contain ':' (segment ids are 'WALL:k')")
    return name


Id = Annotated[Text, Field(min_length=1, max_length=200), AfterValidator(_no_colon)]
"""A wall or cylinder id: 1 to 200 characters, no ``:``."""


class Wall(SpecModel):
    """A polyline; every consecutive pair of points is one true wall segment."""

    id: Id
    points: list[Point] = Field(min_length=2, description="[x, y] in metres")
    material: Text = "wall"

    @field_validator("points")
    @classmethod
    def _no_zero_length(cls, points: list[Point]) -> list[Point]:
        length = np.hypot(*np.diff(np.asarray(points), axis=0).T)
        short = np.flatnonzero(length < MIN_SEGMENT_LENGTH)
        if short.size:
            k = int(short[0])
            raise ValueError(
                f"segment {k} from {list(points[k])} to {list(points[k + 1])} has zero length "
                f"(shorter than {MIN_SEGMENT_LENGTH} m)"
            )
        return points


class Cylinder(SpecModel):
    """A round pillar."""

    id: Id
    center: Point
    radius: Number = Field(gt=0, le=1000)
    material: Text = "wall"


class WorldSpec(SpecModel):
    """The ``world`` section: walls, cylinders and sunlight regions."""

    walls: list[Wall]
    cylinders: list[Cylinder] = Field(default_factory=list, max_length=MAX_CYLINDERS)
    sunlight: list[Sunlight] = Field(default_factory=list, max_length=MAX_SUNLIGHT_REGIONS)


class Robot(SpecModel):
    """The ``robot`` section: the poses ``[x, y, heading_deg]`` the world is observed from."""

    poses: list[tuple[Coordinate, Coordinate, Heading]] = Field(min_length=1, max_length=MAX_POSES)


class LslSensor(LslParams):
    """The scenario's ``sensors.lsl``: the LSL parameters and how the camera picks stripe points.

    ``detector``: ``threshold`` keeps every pixel above the threshold, so a sunlit
    patch adds points and the real stripe behind it is still seen; ``column_max``
    keeps the brightest pixel of each image column, so a sunlit patch's points
    replace the real stripe's in those columns.
    """

    detector: Literal["threshold", "column_max"] = Field("threshold", description="stripe pixels kept per column")


class Sensors(SpecModel):
    """The ``sensors`` section: partial overrides of the run config's sensor parameters.

    Only the keys written in the file override (pydantic's ``model_fields_set``);
    every value is checked against the parameter model's range here already.
    """

    sonar: SonarParams = Field(default_factory=SonarParams)
    lsl: LslSensor = Field(default_factory=LslSensor)


class Scenario(SpecModel):
    """A scenario file, validated (``docs/SCENARIO.md``, version 1)."""

    version: Annotated[Count, AfterValidator(_known_version)]
    name: Text = Field(max_length=200)
    seed: Count = Field(0, ge=0, lt=2**63, description="all randomness derives from this")
    world: WorldSpec
    materials: dict[Text, Material] = Field(default_factory=dict, max_length=1000)
    robot: Robot
    sensors: Sensors = Field(default_factory=Sensors)

    @model_validator(mode="before")
    @classmethod
    def _check_sizes(cls, data: Any) -> Any:
        """Refuse absurd sizes before validating anything else, whatever the YAML type of a count."""
        world = data.get("world") if isinstance(data, dict) else None
        robot = data.get("robot") if isinstance(data, dict) else None
        walls = world.get("walls") if isinstance(world, dict) else None
        regions = world.get("sunlight") if isinstance(world, dict) else None
        poses = robot.get("poses") if isinstance(robot, dict) else None
        problems = []
        if isinstance(walls, list):
            count = sum(
                len(w["points"]) - 1 for w in walls if isinstance(w, dict) and isinstance(w.get("points"), list)
            )
            if count > MAX_WALL_SEGMENTS:
                problems.append(
                    (("world", "walls"), f"{count} wall segments, more than the limit of {MAX_WALL_SEGMENTS}", count)
                )
        if isinstance(regions, list):
            # any number counts (10000.0 too); the type is refused later, the size first
            count = sum(
                r["lines"]
                for r in regions
                if isinstance(r, dict) and isinstance(r.get("lines"), Real) and not isinstance(r["lines"], bool)
            )
            if count > MAX_SUNLIGHT_LINES:
                problems.append(
                    (
                        ("world", "sunlight"),
                        f"{count} sunlight lines, more than the limit of {MAX_SUNLIGHT_LINES}",
                        count,
                    )
                )
            elif isinstance(poses, list) and count * len(poses) > MAX_PHANTOMS_PER_RUN:
                problems.append(
                    (
                        ("world", "sunlight"),
                        (
                            f"{count} sunlight lines from each of {len(poses)} poses make {count * len(poses)} "
                            f"phantom lines, more than the limit of {MAX_PHANTOMS_PER_RUN} per run"
                        ),
                        count,
                    )
                )
        _raise(problems)
        return data

    @model_validator(mode="after")
    def _check_references(self) -> Scenario:
        """Materials exist, ids are unique, no pose is inside a cylinder or on a wall."""
        known = self.resolved_materials()
        problems = []
        seen: dict[str, str] = {}
        for kind, items in (("walls", self.world.walls), ("cylinders", self.world.cylinders)):
            for i, item in enumerate(items):
                if item.material not in known:
                    problems.append(
                        (("world", kind, i, "material"), f"unknown material (known: {', '.join(known)})", item.material)
                    )
                if item.id in seen:
                    problems.append((("world", kind, i, "id"), f"duplicate id, also {seen[item.id]}", item.id))
                seen.setdefault(item.id, f"world.{kind}[{i}]")
        problems += self._poses_on_obstacles()
        _raise(problems)
        return self

    def _poses_on_obstacles(self) -> list[tuple[tuple[str | int, ...], str, Any]]:
        """Poses inside a cylinder or on a wall segment (within :data:`MIN_POSE_CLEARANCE`)."""
        problems: list[tuple[tuple[str | int, ...], str, Any]] = []
        origin = np.array(self.robot.poses[0][:2])  # geometry relative to it: no precision lost far away
        xy = np.array(self.robot.poses)[:, :2] - origin
        if self.world.cylinders:
            centers = np.array([c.center for c in self.world.cylinders]) - origin
            radii = np.array([c.radius for c in self.world.cylinders])
            gap = np.hypot(*(xy[:, None, :] - centers[None, :, :]).transpose(2, 0, 1)) - radii
            for i, k in zip(*np.nonzero(gap <= 0)):
                problems.append(
                    (
                        ("robot", "poses", int(i)),
                        f"pose inside cylinder {self.world.cylinders[k].id!r}",
                        self.robot.poses[i],
                    )
                )
        walls = self.world.walls
        if walls:
            points = np.array([xy for wall in walls for xy in wall.points]) - origin
            lines = shapely.linestrings(
                points, indices=np.repeat(np.arange(len(walls)), [len(w.points) for w in walls])
            )
            pose_index, wall_index = shapely.STRtree(lines).query(
                shapely.points(xy), predicate="dwithin", distance=MIN_POSE_CLEARANCE
            )
            for i, k in sorted(zip(pose_index.tolist(), wall_index.tolist())):
                problems.append(
                    (
                        ("robot", "poses", i),
                        f"pose on wall {walls[k].id!r} (closer than {MIN_POSE_CLEARANCE} m to it)",
                        self.robot.poses[i],
                    )
                )
        return problems

    def resolved_materials(self) -> dict[str, Material]:
        """The built-in materials updated by the scenario's ``materials`` section."""
        return {**BUILTIN_MATERIALS, **self.materials}

    def sensor_params(self, sonar_defaults: SonarParams, lsl_defaults: LslParams) -> tuple[SonarParams, LslParams]:
        """The run's sensor parameters: the config's defaults, overridden by the scenario's keys.

        >>> s = parse_scenario('''
        ... {version: 1, name: t, world: {walls: []}, robot: {poses: [[0, 0, 0]]},
        ...  sensors: {lsl: {max_range: 5}}}''', "t.yaml")
        >>> sonar, lsl = s.sensor_params(SonarParams(max_range=4), LslParams(range_noise=0.01))
        >>> sonar.max_range, lsl.max_range, lsl.range_noise
        (4.0, 5.0, 0.01)
        >>> wide = parse_scenario('''
        ... {version: 1, name: w, world: {walls: []}, robot: {poses: [[0, 0, 0]]}, sensors: {lsl: {fov_deg: 36}}}''', "w.yaml")
        >>> wide.sensor_params(SonarParams(), LslParams(snapshots=30))
        Traceback (most recent call last):
        ...
        evmap.sources.loading.InputError: scenario 'w': sensors.lsl (fov_deg) over the config's sensors.lsl: Value error, 30 snapshots of 181 stripe points (fov_deg / ray_step_deg + 1) make 5430 stripe points per scan, more than the limit of 5000
        """
        merged = []
        for key, given, defaults in (
            ("sonar", self.sensors.sonar, sonar_defaults),
            ("lsl", self.sensors.lsl, lsl_defaults),
        ):
            overrides = given.model_dump(include=given.model_fields_set & set(type(defaults).model_fields))
            try:
                merged.append(type(defaults).model_validate({**defaults.model_dump(), **overrides}))
            except pydantic_core.ValidationError as exc:
                problems = "; ".join(e["msg"] for e in exc.errors())
                raise InputError(
                    f"scenario {self.name!r}: sensors.{key} ({', '.join(sorted(overrides)) or 'no keys'}) "
                    f"over the config's sensors.{key}: {problems}"
                ) from None
        return merged[0], merged[1]


def _known_version(version: int) -> int:
    if version != 1:
        raise ValueError("unsupported version: this program reads version 1")
    return version


def _raise(problems: list[tuple[tuple[str | int, ...], str, Any]]) -> None:
    """Raise the problems as one pydantic error, each at its own key path."""
    if problems:
        raise pydantic_core.ValidationError.from_exception_data(
            "Scenario",
            [
                {"type": pydantic_core.PydanticCustomError("scenario", message), "loc": loc, "input": value}
                for loc, message, value in problems
            ],
        )


def parse_scenario(text: str, name: str) -> Scenario:
    """Validate scenario YAML text; ``name`` (a file name) is used in error messages.

    Raises
    ------
    InputError
        Naming ``name``, the key path or line and column, and the problem.

    >>> parse_scenario("version: 1\\nname: x\\nworld: {walls: []}\\nrobot: {poses: []}", "x.yaml")
    Traceback (most recent call last):
    ...
    evmap.sources.loading.InputError: x.yaml: robot.poses: List should have at least 1 item after validation, not 0 (got []) (line 4)
    """
    return parse_document(text, name).validate(Scenario)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file.

    Raises
    ------
    InputError
        If the file cannot be read or is not a valid scenario.
    """
    return load_model(Scenario, path)


def default_scenario() -> Scenario:
    """The embedded scenario: the paper's corridor (Fig. 4 and 5), observed from one pose.

    >>> default_scenario().name
    'corridor'
    """
    return load_scenario(configs.path("scenarios/corridor.yaml"))
