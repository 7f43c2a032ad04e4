"""Simulated readings of the sensors declared in YAML (:mod:`evmap.sources.sensor_kinds`), and the built-in kinds.

Each built-in kind has a model of its readings from the world; the model may read
the world's materials and ground truth (it is the world), the features computed
from its readings may not. Randomness: sensor ``NAME`` at pose ``k`` draws from
``numpy.random.default_rng([seed, k, SENSOR_STREAM, crc32(NAME)])``, so a sensor's
readings depend neither on the other sensors nor on the order of the poses.

The built-in kinds:

``range`` (:mod:`evmap.sources.range_sensor`)
    every beam casts ``rays`` rays across its cone; the nearest surface whose
    material is in ``echo`` or ``absorb`` stops a ray, and only ``echo``
    materials return; the beam's range is its nearest echo, with Gaussian noise
    of std ``range_noise * range``, ``inf`` beyond ``max_range``. Other materials
    let the beam pass.
``detector`` (:mod:`evmap.sources.detector`)
    every surface of its ``materials`` is cut into patches of ``patch`` metres
    (a cylinder is one patch, its nearest point); a patch in view and not hidden
    by another surface of those materials is reported with the probability
    ``detection`` at its range, displaced by ``position_noise``; false reports
    follow, Poisson in number, at the rate ``false_alarms`` by range, uniform in bearing.
``contour_property`` (:mod:`evmap.sources.contour_property`)
    points every ``spacing`` metres along each LSL segment of the pose, their
    value drawn from ``values`` of the material the segment was seen on
    (``sunlight`` for a phantom).
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evmap.sources.contour_property import CONTOUR_ARRAYS, ContourPropertySpec, contour_features
from evmap.sources.detector import DETECTOR_ARRAYS, DETECTOR_CATEGORIES, MAX_PATCHES, DetectorSpec, detector_features
from evmap.sources.geometry import wrapped
from evmap.sources.range_sensor import RANGE_ARRAYS, RANGE_CATEGORIES, RangeSpec, range_features
from evmap.sources.ray_casting import cast_rays
from evmap.sources.readings import LslSegments
from evmap.sources.sensor_kinds import SENSOR_KINDS, DeclaredSensor, SensorKind
from evmap.sources.sim.world import World, wall_id

__all__ = [
    "BUILTIN_SENSOR_KINDS",
    "SENSOR_STREAM",
    "check_materials",
    "materials",
    "sensor_rng",
    "simulate_contour",
    "simulate_detector",
    "simulate_features",
    "simulate_range",
]

SENSOR_STREAM = 201
"""Stream number of a declared sensor: ``default_rng([seed, pose_index, 201, crc32(name)])``."""


def sensor_rng(world: World, pose_index: int, name: str) -> np.random.Generator:
    """The random generator of sensor ``name`` at one pose (see the module doc)."""
    return np.random.default_rng([world.seed, pose_index, SENSOR_STREAM, zlib.crc32(name.encode())])


def materials(world: World) -> tuple[NDArray[np.str_], NDArray[np.str_]]:
    """The material names of the world's segments and of its cylinders, in the order of its surfaces.

    >>> from evmap.sources.sim.scenario import default_scenario
    >>> seg, cyl = materials(World(default_scenario()))
    >>> len(seg) == len(World(default_scenario()).surfaces().segment_ids), sorted(set(seg.tolist()))
    (True, ['glass', 'wall'])
    """
    walls = world.scenario.world.walls
    seg = [wall.material for wall in walls for _ in range(len(wall.points) - 1)]
    cyl = [c.material for c in world.scenario.world.cylinders]
    return np.array(seg, dtype=str).reshape(-1), np.array(cyl, dtype=str).reshape(-1)


def simulate_range(
    world: World, pose_index: int, spec: RangeSpec, rng: np.random.Generator, lsl: LslSegments
) -> dict[str, NDArray[np.float64]]:
    """A range sensor's beams from one pose (see the module doc); ``lsl`` is not used."""
    pose = world.poses[pose_index]
    angles = pose[2] + spec.beam_offsets()
    surfaces = world.surfaces()
    seg_mat, cyl_mat = materials(world)
    stops = spec.echo + spec.absorb
    s, c = np.isin(seg_mat, stops), np.isin(cyl_mat, stops)
    half = np.radians(spec.cone_deg) / 2
    offsets = np.linspace(-half, half, spec.rays) if spec.rays > 1 else np.zeros(1)
    ranges, hit = cast_rays(
        pose[:2],
        (angles[:, None] + offsets).ravel(),
        surfaces.p[s],
        surfaces.q[s],
        surfaces.cylinder_centers[c],
        surfaces.cylinder_radii[c],
        spec.max_range,
    )
    echoing = np.concatenate([np.isin(seg_mat[s], spec.echo), np.isin(cyl_mat[c], spec.echo), [False]])
    first = np.where(echoing[hit], ranges, np.inf).reshape(len(angles), -1).min(axis=1)
    noisy = first * (1 + spec.range_noise * rng.standard_normal(len(angles)))
    noisy[~(noisy <= spec.max_range)] = np.inf
    return {"pose": pose.copy(), "angles": wrapped(angles), "ranges": noisy}


def simulate_detector(
    world: World, pose_index: int, spec: DetectorSpec, rng: np.random.Generator, lsl: LslSegments
) -> dict[str, NDArray[np.float64]]:
    """A detector's reports from one pose (see the module doc); ``lsl`` is not used."""
    pose = world.poses[pose_index]
    surfaces = world.surfaces()
    seg_mat, cyl_mat = materials(world)
    s, c = np.isin(seg_mat, spec.materials), np.isin(cyl_mat, spec.materials)
    p, q = surfaces.p[s], surfaces.q[s]
    count = np.maximum(np.ceil(np.hypot(*(q - p).T) / spec.patch).astype(np.intp), 1)
    if count.sum() > MAX_PATCHES:
        raise ValueError(
            f"a detector's patch of {spec.patch} m cuts the walls of {sorted(spec.materials)} into {int(count.sum())} "
            f"patches, more than the limit of {MAX_PATCHES}: use a larger patch"
        )
    owner = np.repeat(np.arange(len(p)), count)
    t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + 0.5) / np.repeat(count, count)
    patches = p[owner] + t[:, None] * (q - p)[owner]
    centers, radii = surfaces.cylinder_centers[c], surfaces.cylinder_radii[c]
    towards = pose[:2] - centers
    nearest = centers + radii[:, None] * towards / np.maximum(np.hypot(*towards.T), 1e-12)[:, None]
    points = np.concatenate([patches, nearest]).reshape(-1, 2)
    d = points - pose[:2]
    distance = np.hypot(d[:, 0], d[:, 1])
    ranges, _ = cast_rays(pose[:2], np.arctan2(d[:, 1], d[:, 0]), p, q, centers, radii, spec.max_range + 1)
    seen = spec.in_view(pose, points) & (ranges >= distance * (1 - 1e-9) - 1e-9)
    prob = np.interp(distance, *np.array(spec.detection).T)
    detected = seen & (rng.random(len(points)) < prob)
    shift = spec.position_noise * rng.standard_normal((len(points), 2))
    reports = points[detected] + shift[detected]

    grid, rate = spec.false_alarm_bins()
    n_false = rng.poisson(rate.sum())
    if n_false:
        r = grid[rng.choice(len(rate), size=n_false, p=rate / rate.sum())] + (grid[1] - grid[0]) * rng.random(n_false)
        bearing = pose[2] + np.radians(spec.facing_deg + spec.fov_deg * (rng.random(n_false) - 0.5))
        reports = np.concatenate([reports, pose[:2] + r[:, None] * np.column_stack([np.cos(bearing), np.sin(bearing)])])
    return {"pose": pose.copy(), "points": reports.reshape(-1, 2)}


def simulate_contour(
    world: World, pose_index: int, spec: ContourPropertySpec, rng: np.random.Generator, lsl: LslSegments
) -> dict[str, NDArray[np.float64]]:
    """The contour points of the pose's LSL segments and their values (see the module doc)."""
    seg_mat, cyl_mat = materials(world)
    surfaces = world.surfaces()
    of_id = dict(zip(surfaces.segment_ids.tolist(), seg_mat.tolist()))
    of_id.update(zip(surfaces.cylinder_ids.tolist(), cyl_mat.tolist()))
    material = [
        "sunlight" if truth == "noise" else of_id.get(source, of_id.get(wall_id(source), ""))
        for truth, source in zip(lsl.truth.tolist(), lsl.source.tolist())
    ]
    unknown = sorted(set(material) - set(spec.values))
    if unknown:
        raise ValueError(f"values: no [mean, std] for the materials {unknown} that the stripe saw")
    count = np.maximum(np.ceil(lsl.length / spec.spacing).astype(np.intp) + 1, 2)
    owner = np.repeat(np.arange(len(lsl)), count)
    t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
    points = lsl.p[owner] + t[:, None] * (lsl.q - lsl.p)[owner]
    mean_std = np.array([spec.values[m] for m in material]).reshape(-1, 2)[owner]
    values = mean_std[:, 0] + mean_std[:, 1] * rng.standard_normal(len(points))
    return {"points": points.reshape(-1, 2), "values": values}


def simulate_features(
    world: World, pose_index: int, sensors: dict[str, DeclaredSensor], lsl: LslSegments, where: str = ""
) -> dict[str, NDArray[Any]]:
    """The features of every declared sensor for the pose's LSL segments, from readings simulated in the world.

    ``where`` (the config's name) begins an error about a sensor's section: a material the world does not
    have (a misspelt ``echo: [glas]`` would otherwise be a material that nothing is made of), or a
    simulator's refusal.

    >>> from evmap import configs
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.params import LslParams
    >>> from evmap.sources.sim.lsl import observe_lsl
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> world, cfg = World(default_scenario()), load_config(configs.path("examples/infrared.yaml"))
    >>> lsl = observe_lsl(world, 0, LslParams())
    >>> sorted(simulate_features(world, 0, cfg.extra_sensors, lsl))
    ['ir_relation', 'ir_return']
    """
    out: dict[str, NDArray[Any]] = {}
    check_materials(world, sensors, where)
    for name, sensor in sensors.items():
        if sensor.kind.simulate is None:
            raise ValueError(
                f"sensor {name!r} ({sensor.kind.name}): its kind has no simulator; bring its readings from a log "
                "or from Python (evmap.sources.sensor_kinds.features_from_arrays)"
            )
        try:
            readings = sensor.kind.simulate(world, pose_index, sensor.spec, sensor_rng(world, pose_index, name), lsl)
        except ValueError as exc:
            raise ValueError(f"{where + ': ' if where else ''}extra_sensors.{name}: {exc}") from None
        out.update(sensor.features(readings, lsl.p, lsl.q))
    return out


def check_materials(world: World, sensors: dict[str, DeclaredSensor], where: str = "") -> None:
    """Refuse a sensor section naming a material the world does not have, at its key path.

    >>> import dataclasses
    >>> from evmap import configs
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> ir = load_config(configs.path("examples/infrared.yaml")).extra_sensors["ir"]
    >>> typo = {"ir": dataclasses.replace(ir, spec=RangeSpec(kind="range", echo=["glas"]))}
    >>> check_materials(World(default_scenario()), typo, "my.yaml")
    Traceback (most recent call last):
    ...
    ValueError: my.yaml: extra_sensors.ir.echo: 'glas' is not a material of the scenario 'corridor' (its materials: foam, glass, mirror, wall)
    """
    known = set(world.materials)
    for name, sensor in sensors.items():
        for key, named in sensor.spec.materials_named().items():
            unknown = [m for m in named if m not in known]
            if unknown:
                listed = ", ".join(repr(m) for m in unknown)
                raise ValueError(
                    f"{where + ': ' if where else ''}extra_sensors.{name}.{key}: {listed} "
                    f"{'is not a material' if len(unknown) == 1 else 'are not materials'} of the scenario "
                    f"{world.scenario.name!r} (its materials: {', '.join(sorted(known))})"
                )


BUILTIN_SENSOR_KINDS: tuple[SensorKind, ...] = (
    SensorKind(
        name="range",
        spec=RangeSpec,
        arrays=RANGE_ARRAYS,
        features=range_features,
        categories=lambda spec: RANGE_CATEGORIES,
        simulate=simulate_range,
        example={"kind": "range", "beams": 8, "cone_deg": 10, "max_range": 2.0},
        summary="a range sensor (one beam, a ring, rotating): free space and echoes",
        unbounded=("ranges",),
    ),
    SensorKind(
        name="detector",
        spec=DetectorSpec,
        arrays=DETECTOR_ARRAYS,
        features=detector_features,
        categories=lambda spec: DETECTOR_CATEGORIES,
        simulate=simulate_detector,
        example={"kind": "detector", "materials": ["glass"]},
        summary="reports objects of some materials, with a detection probability and false alarms by range",
    ),
    SensorKind(
        name="contour_property",
        spec=ContourPropertySpec,
        arrays=CONTOUR_ARRAYS,
        features=contour_features,
        categories=lambda spec: {spec.property: None},
        simulate=simulate_contour,
        example={"kind": "contour_property", "property": "width", "values": {"wall": [3.0, 0.5]}},
        summary="a per-point property of the contour sensor (intensity, stripe width), aggregated per segment",
    ),
)
"""The built-in sensor kinds, registered when this module is first imported; they pass
:func:`~evmap.sources.sensor_kinds.check_sensor_kind` (a test says so), which every start of evmap need not repeat."""

for _kind in BUILTIN_SENSOR_KINDS:
    SENSOR_KINDS.setdefault(_kind.name, _kind)  # once, whichever name this module was imported by
