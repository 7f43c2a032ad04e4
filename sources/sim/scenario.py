"""Scenario files: the world, the robot's poses and the sensor hardware (``docs/SCENARIO.md``).

A scenario file is untrusted input. It is read with the safe YAML loader of
:mod:`evmap.sources.loading` and validated by the pydantic models below, every model
with ``extra="forbid"``; any problem raises :class:`~evmap.sources.loading.InputError`
naming the file, the key path (``world.walls[3].points``) or the line and column,
and what is wrong. Sizes are checked against the limits below before anything
else is validated, so an absurd file costs no work.

Checks beyond the types: unknown keys, unknown materials, polylines with fewer
than two points, zero-length segments, non-finite numbers, a pose inside a
cylinder, duplicate ids (walls and cylinders share one namespace, and an id
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

from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import pydantic_core
import shapely
from numpy.typing import NDArray
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from evmap import configs
from evmap.sources.loading import load_model, read_yaml, validate
from evmap.sources.params import LslParams, SonarParams

__all__ = [
    "BUILTIN_MATERIALS",
    "MAX_CYLINDERS",
    "MAX_POLYGON_VERTICES",
    "MAX_POSES",
    "MAX_SUNLIGHT_LINES",
    "MAX_SUNLIGHT_LINES_PER_REGION",
    "MAX_SUNLIGHT_REGIONS",
    "MAX_WALL_SEGMENTS",
    "MIN_FIT_RATE",
    "MIN_SEGMENT_LENGTH",
    "Cylinder",
    "Id",
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

MAX_WALL_SEGMENTS = 200_000
"""Most wall segments (consecutive point pairs, all polylines together) in a scenario."""

MAX_CYLINDERS = 1_000
"""Most cylinders in a scenario."""

MAX_SUNLIGHT_REGIONS = 100
"""Most sunlight regions in a scenario."""

MAX_SUNLIGHT_LINES_PER_REGION = 10_000
"""Most phantom lines one sunlight region makes per pose."""

MAX_SUNLIGHT_LINES = 20_000
"""Most phantom lines all sunlight regions together make per pose."""

MAX_POLYGON_VERTICES = 1_000
"""Most vertices of one sunlight polygon."""

MAX_POSES = 1_000
"""Most robot poses in a scenario."""

MIN_SEGMENT_LENGTH = 1e-6
"""Wall segments shorter than this (m) are refused as zero-length."""

MIN_FIT_RATE = 0.01
"""A sunlight line of the shortest and of the longest length of a region's range must
have both ends inside the polygon for at least this share of random placements (one
end uniform in the polygon, a uniform direction); otherwise the range is refused as
too long for the polygon. This keeps the drawing of phantom lines quick."""

_FIT_TRIALS = 4096
_PLACE_ROUNDS = 500
_PLACE_CANDIDATES = 32

Point = tuple[float, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Material(_Model):
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


Id = Annotated[str, Field(min_length=1, max_length=200), AfterValidator(_no_colon)]
"""A wall or cylinder id: 1 to 200 characters, no ``:``."""


class Wall(_Model):
    """A polyline; every consecutive pair of points is one true wall segment."""

    id: Id
    points: list[Point] = Field(min_length=2, description="[x, y] in metres")
    material: str = "wall"

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


class Cylinder(_Model):
    """A round pillar."""

    id: Id
    center: Point
    radius: float = Field(gt=0, le=1000)
    material: str = "wall"


class Sunlight(_Model):
    """A region where sunlight makes the LSL see phantom lines (drawn anew at every pose)."""

    polygon: list[Point] = Field(min_length=3, max_length=MAX_POLYGON_VERTICES)
    lines: int = Field(ge=0, le=MAX_SUNLIGHT_LINES_PER_REGION, description="phantom lines per pose")
    length: tuple[float, float] = Field(description="[min, max] length of a phantom line (m)")

    @field_validator("polygon")
    @classmethod
    def _simple_polygon(cls, polygon: list[Point]) -> list[Point]:
        shape = shapely.Polygon(polygon)
        if not shape.is_valid:
            raise ValueError(f"not a simple polygon: {shapely.is_valid_reason(shape)}")
        if shape.area <= 0:
            raise ValueError("the polygon has no area")
        return polygon

    @field_validator("length")
    @classmethod
    def _length_fits(cls, length: tuple[float, float], info: ValidationInfo) -> tuple[float, float]:
        low, high = length
        if not 0 < low <= high:
            raise ValueError(f"need 0 < min <= max, got min {low} and max {high}")
        if "polygon" in info.data:
            shape = shapely.Polygon(info.data["polygon"])
            triangles = _triangles(shape)
            rng = np.random.default_rng(0)
            for value in (low, high):
                lengths = np.full(_FIT_TRIALS, value)
                rate = _try_place(shape, triangles, lengths, rng)[2].mean()
                if rate < MIN_FIT_RATE:
                    raise ValueError(
                        f"a line of {value} m has both ends inside the polygon for only "
                        f"{rate:.2%} of placements (at least {MIN_FIT_RATE:.0%} needed): too long for the polygon"
                    )
        return length

    def draw_lines(self, rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Draw the region's phantom lines: ``(p, q)``, each ``(lines, 2)``.

        Lengths are uniform in ``length``; one end is uniform in the polygon and the
        direction uniform, redrawn until the other end is inside the polygon too.

        >>> region = Sunlight(polygon=[[0, 0], [1, 0], [1, 1], [0, 1]], lines=3, length=(0.1, 0.2))
        >>> p, q = region.draw_lines(np.random.default_rng(1))
        >>> p.shape, bool(np.all((0.1 <= np.hypot(*(q - p).T)) & (np.hypot(*(q - p).T) <= 0.2)))
        ((3, 2), True)
        """
        shape = shapely.Polygon(self.polygon)
        triangles = _triangles(shape)
        lengths = rng.uniform(self.length[0], self.length[1], self.lines)
        p = np.empty((self.lines, 2))
        q = np.empty((self.lines, 2))
        todo = np.arange(self.lines)
        for _ in range(_PLACE_ROUNDS):
            if todo.size == 0:
                break
            tries = np.repeat(todo, _PLACE_CANDIDATES)
            a, b, ok = _try_place(shape, triangles, lengths[tries], rng)
            # the first successful candidate of each line
            line, first = np.unique(tries[ok], return_index=True)
            p[line], q[line] = a[ok][first], b[ok][first]
            todo = np.setdiff1d(todo, line)
        if todo.size:
            raise RuntimeError(f"could not place {todo.size} sunlight lines inside {self.polygon}")
        return p, q


def _triangles(shape: shapely.Polygon) -> NDArray[np.float64]:
    """(T, 3, 2) triangulation of a simple polygon."""
    parts = shapely.get_parts(shapely.constrained_delaunay_triangles(shape))
    return shapely.get_coordinates(parts).reshape(len(parts), 4, 2)[:, :3]


def _try_place(
    shape: shapely.Polygon, triangles: NDArray[np.float64], lengths: NDArray[np.float64], rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """One placement attempt per length: ends ``a`` (uniform in the polygon), ``b``, and whether ``b`` is inside."""
    a_, b_, c_ = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e, f = b_ - a_, c_ - a_
    area = np.abs(e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]) / 2
    pick = rng.choice(len(triangles), size=len(lengths), p=area / area.sum())
    u, v = rng.random((2, len(lengths)))
    flip = u + v > 1
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    a = a_[pick] + u[:, None] * (b_[pick] - a_[pick]) + v[:, None] * (c_[pick] - a_[pick])
    theta = rng.uniform(0, 2 * np.pi, len(lengths))
    b = a + lengths[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    inside = shapely.contains_xy(shape, a[:, 0], a[:, 1]) & shapely.contains_xy(shape, b[:, 0], b[:, 1])
    return a, b, inside


class WorldSpec(_Model):
    """The ``world`` section: walls, cylinders and sunlight regions."""

    walls: list[Wall]
    cylinders: list[Cylinder] = Field(default_factory=list, max_length=MAX_CYLINDERS)
    sunlight: list[Sunlight] = Field(default_factory=list, max_length=MAX_SUNLIGHT_REGIONS)


class Robot(_Model):
    """The ``robot`` section: the poses ``[x, y, heading_deg]`` the world is observed from."""

    poses: list[tuple[float, float, float]] = Field(min_length=1, max_length=MAX_POSES)


class Sensors(_Model):
    """The ``sensors`` section: partial overrides of the run config's sensor parameters.

    Only the keys written in the file override (pydantic's ``model_fields_set``);
    every value is checked against the parameter model's range here already.
    """

    sonar: SonarParams = Field(default_factory=SonarParams)
    lsl: LslParams = Field(default_factory=LslParams)


class Scenario(_Model):
    """A scenario file, validated (``docs/SCENARIO.md``, version 1)."""

    version: Literal[1]
    name: str = Field(max_length=200)
    seed: int = Field(0, ge=0, lt=2**63, description="all randomness derives from this")
    world: WorldSpec
    materials: dict[str, Material] = Field(default_factory=dict, max_length=1000)
    robot: Robot
    sensors: Sensors = Field(default_factory=Sensors)

    @model_validator(mode="before")
    @classmethod
    def _check_sizes(cls, data: Any) -> Any:
        """Refuse absurd sizes before validating anything else."""
        world = data.get("world") if isinstance(data, dict) else None
        walls = world.get("walls") if isinstance(world, dict) else None
        regions = world.get("sunlight") if isinstance(world, dict) else None
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
            count = sum(r["lines"] for r in regions if isinstance(r, dict) and type(r.get("lines")) is int)
            if count > MAX_SUNLIGHT_LINES:
                problems.append(
                    (
                        ("world", "sunlight"),
                        f"{count} sunlight lines, more than the limit of {MAX_SUNLIGHT_LINES}",
                        count,
                    )
                )
        _raise(problems)
        return data

    @model_validator(mode="after")
    def _check_references(self) -> Scenario:
        """Materials exist, ids are unique, no pose is inside a cylinder."""
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
        if self.world.cylinders:
            centers = np.array([c.center for c in self.world.cylinders])
            radii = np.array([c.radius for c in self.world.cylinders])
            xy = np.array(self.robot.poses)[:, :2]
            gap = np.hypot(*(xy[:, None, :] - centers[None, :, :]).transpose(2, 0, 1)) - radii
            for i, k in zip(*np.nonzero(gap <= 0)):
                problems.append(
                    (
                        ("robot", "poses", int(i)),
                        f"pose inside cylinder {self.world.cylinders[k].id!r}",
                        self.robot.poses[i],
                    )
                )
        _raise(problems)
        return self

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
        """
        merged = []
        for given, defaults in ((self.sensors.sonar, sonar_defaults), (self.sensors.lsl, lsl_defaults)):
            overrides = given.model_dump(include=given.model_fields_set)
            merged.append(type(defaults).model_validate({**defaults.model_dump(), **overrides}))
        return merged[0], merged[1]


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
    evmap.sources.loading.InputError: x.yaml: robot.poses: List should have at least 1 item after validation, not 0 (got [])
    """
    return validate(Scenario, read_yaml(text, name), name)


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
