"""Sensor kinds: a new sensor declared in YAML as an instance of a generic kind.

A *sensor kind* (a range sensor, a detector, a property of the contour sensor's
points) knows three things, registered together as a :class:`SensorKind`:

- the pydantic model of a sensor's YAML section (its physics as parameters);
- the array form of its readings, ``{array name: shape}`` (``"B"`` and ``"D"`` are
  any length), checked by :func:`check_readings`: the same arrays whether the
  readings are simulated, read from a log or given from Python;
- its feature computation: from the readings and the segments ``p``-``q`` only,
  the per-segment features the config's noise-elimination sources read, each
  named ``<sensor>_<feature>`` (see :meth:`SensorKind.declares`);

and, to take part in simulated runs, a simulator of its readings from the world
(:mod:`evmap.sources.sim.sensor_models`). A config declares sensors under
``extra_sensors`` (:func:`build_sensors`); :func:`features_from_arrays` turns
one pose's readings into the features of an
:class:`~evmap.maps.observation.Observation`.

Every feature computation is checked (:func:`check_features`): one value per
segment, categories among those declared, numbers finite.
"""

from __future__ import annotations

import json
import re
import zipfile
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict, Field

from evmap.sources.conformance import check_sensor
from evmap.sources.evidence import SpecError, Text

__all__ = [
    "FEATURE_NAME",
    "MAX_SENSORS",
    "SENSOR_KINDS",
    "DeclaredSensor",
    "FeatureFunction",
    "SensorKind",
    "SensorSpec",
    "build_sensors",
    "check_features",
    "check_readings",
    "check_sensor_kind",
    "features_from_arrays",
    "read_readings",
    "register_sensor_kind",
]

FEATURE_NAME = r"[A-Za-z][A-Za-z0-9_-]{0,63}"
"""What a feature's name must match (as a source's ``feature`` key does)."""
MAX_SENSORS = 16
"""Most sensors declared under ``extra_sensors`` in one config."""

FeatureFunction = Callable[[Any, Mapping[str, NDArray[Any]], NDArray[np.float64], NDArray[np.float64]], dict[str, Any]]
"""``features(spec, readings, p, q) -> {feature suffix: (N,) values}`` of a sensor kind."""


class SensorSpec(BaseModel):
    """The YAML keys every declared sensor has: its kind and a free description."""

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True, strict=True, allow_inf_nan=False)
    # strict: ``beams: true`` was one beam, ``max_range: "10"`` ten metres; a pair of numbers is written as a
    # list, so a kind's pair types take ``Strict(False)`` on the tuple (its numbers stay strict)

    kind: Text
    description: Text = Field("", max_length=2000, description="free text, shown by `evmap sources`")

    def materials_named(self) -> dict[str, list[str]]:
        """The world materials this section names, by key; a simulated run refuses those its world lacks."""
        return {}


@dataclass(frozen=True)
class SensorKind:
    """A registered kind of sensor.

    Attributes
    ----------
    name : the ``kind:`` of a sensor's YAML section.
    spec : the pydantic model of the section (a :class:`SensorSpec`).
    arrays : the readings' array form, ``{name: shape}``; a shape entry is a number or a
        letter standing for any length (the same letter, the same length).
    features : computes ``{suffix: (N,) values}`` from ``(spec, readings, p, q)``.
    categories : ``categories(spec) -> {suffix: categories}`` (``None`` for a number): what
        ``features`` gives a sensor of this section.
    simulate : ``(world, pose_index, spec, rng, lsl) -> readings``, or ``None`` if the kind
        has no simulator (its readings then come from logs or Python only).
    example : a valid YAML section of the kind, for the conformance suite and ``evmap sources``.
    summary : one line saying what the kind senses.
    origin : where it comes from: ``builtin``, or a plugin's entry point.
    unbounded : the arrays that may hold ``inf`` (a range sensor's ranges: no echo); the others must be finite.
    """

    name: str
    spec: type[SensorSpec]
    arrays: Mapping[str, tuple[int | str, ...]]
    features: FeatureFunction
    categories: Callable[[Any], Mapping[str, tuple[str, ...] | None]]
    simulate: Callable[..., dict[str, NDArray[Any]]] | None
    example: Mapping[str, Any]
    summary: str
    origin: str = "builtin"
    unbounded: tuple[str, ...] = ()

    def declares(self, sensor: str, spec: SensorSpec) -> dict[str, tuple[str, ...] | None]:
        """The features a sensor of this kind named ``sensor`` gives: ``{sensor_suffix: categories}``."""
        return {f"{sensor}_{suffix}": categories for suffix, categories in self.categories(spec).items()}

    def describe(self) -> list[str]:
        """What ``evmap sources`` says of the kind: origin, summary, readings, features, every YAML key.

        >>> from evmap.sources.plugins import sensor_kinds
        >>> print("\\n".join(sensor_kinds()["detector"].describe()[:4]))
          detector  builtin; simulated: reports objects of some materials, with a detection probability and false alarms by range
            readings: pose (3,), points (D, 2)
            features (of the example): NAME_detection ['detected', 'missed', 'out_of_view']
            keys (example: {kind: detector, materials: [glass]}):
        """
        simulated = "simulated" if self.simulate is not None else "not simulated: readings from logs or Python"
        example = self.spec.model_validate(self.example)
        written = ", ".join(f"{k}: {_flow(v)}" for k, v in self.example.items())
        out = [
            f"  {self.name}  {self.origin}; {simulated}: {self.summary}",
            f"    readings: {', '.join(f'{a} {_shape(s)}' for a, s in self.arrays.items())}",
            f"    features (of the example): {_features(self.declares('NAME', example))}",
            f"    keys (example: {{{written}}}):",
        ]
        for key, field in self.spec.model_fields.items():
            if key == "kind":
                continue
            default = (
                "required" if field.is_required() else f"default {_flow(field.get_default(call_default_factory=True))}"
            )
            out.append(f"      {key}: {field.description or ''} ({default})")
        return out


SENSOR_KINDS: dict[str, SensorKind] = {}
"""Every kind of sensor, by the name used as ``kind:`` under ``extra_sensors``."""


def check_sensor_kind(kind: SensorKind) -> None:
    """The checks a sensor kind passes to be registered: a valid example section of its own kind, feature names
    matching :data:`FEATURE_NAME`, and a sensor of that section passing the sensor checks
    (:func:`evmap.sources.conformance.check_sensor`: one declared value per segment, deterministic, each segment
    alone as in a batch).

    Raises
    ------
    ValueError
        naming the kind and what failed.
    """
    try:
        spec = kind.spec.model_validate(kind.example)
    except ValueError as exc:
        raise ValueError(f"sensor kind {kind.name!r}: its example section is not valid: {exc}") from None
    if spec.kind != kind.name:
        raise ValueError(f"sensor kind {kind.name!r}: its example section has kind {spec.kind!r}")
    for feature in kind.declares("x", spec):
        if not re.fullmatch(FEATURE_NAME, feature):
            raise ValueError(f"sensor kind {kind.name!r}: feature {feature!r} does not match {FEATURE_NAME}")
    try:
        check_sensor(DeclaredSensor("x", kind, spec), kind.arrays)
    except Exception as exc:  # noqa: BLE001 - whatever the kind raised, it is refused, and says why
        raise ValueError(f"sensor kind {kind.name!r} fails the sensor checks: {exc}") from None


def register_sensor_kind(kind: SensorKind) -> SensorKind:
    """Register a sensor kind under a new name, after :func:`check_sensor_kind`.

    Raises
    ------
    ValueError
        naming the kind, if the name is taken or the kind fails the checks.
    """
    if kind.name in SENSOR_KINDS:
        raise ValueError(f"sensor kind {kind.name!r} is already registered")
    check_sensor_kind(kind)
    SENSOR_KINDS[kind.name] = kind
    return kind


@dataclass(frozen=True)
class DeclaredSensor:
    """A sensor declared in a config: its name, kind and validated section."""

    name: str
    kind: SensorKind
    spec: SensorSpec

    def features(self, readings: Mapping[str, ArrayLike], p: ArrayLike, q: ArrayLike) -> dict[str, NDArray[Any]]:
        """The sensor's features of the segments ``p``-``q`` from its readings, checked."""
        arrays = check_readings(self.kind, readings, self.name)
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        q = np.asarray(q, dtype=float).reshape(-1, 2)
        given = self.kind.features(self.spec, arrays, p, q)
        named = {f"{self.name}_{k}": v for k, v in given.items()}
        return check_features(f"{self.name!r} ({self.kind.name})", self.declares(), named, len(p))

    def declares(self) -> dict[str, tuple[str, ...] | None]:
        """The features this sensor gives: ``{name: categories}``, ``None`` for a number."""
        return self.kind.declares(self.name, self.spec)

    def describe(self, readers: Mapping[str, list[str]]) -> list[str]:
        """What ``evmap config check`` says of the sensor: its kind, every key's value (defaults filled in), its
        readings, and its features with the sources that read each (``readers``: feature -> source names).

        >>> from evmap import configs
        >>> from evmap.sources.config import load_config
        >>> radar = load_config(configs.path("examples/radar.yaml")).extra_sensors["radar"]
        >>> print("\\n".join(radar.describe({"radar_detection": ["radar"]})[2:]))
          readings: pose (3,), points (D, 2)
          features: radar_detection ['detected', 'missed', 'out_of_view'] read by radar
        """
        simulated = "simulated in a scenario" if self.kind.simulate is not None else "not simulated"
        written = self.spec.model_dump(mode="json")
        keys = " ".join(f"{k}={_flow(v)}" for k, v in written.items() if k not in ("kind", "description"))
        features = ", ".join(
            f"{_features({name: categories})} read by {', '.join(readers.get(name, [])) or 'no source'}"
            for name, categories in self.declares().items()
        )
        return [
            f"sensor {self.name} (kind {self.kind.name}, {self.kind.origin}; {simulated})"
            + (f": {self.spec.description}" if self.spec.description else ""),
            f"  {keys}",
            f"  readings: {', '.join(f'{a} {_shape(s)}' for a, s in self.kind.arrays.items())}",
            f"  features: {features}",
        ]


def _shape(shape: tuple[int | str, ...]) -> str:
    """An array form as written in the docs: ``(3,)``, ``(D, 2)``."""
    return f"({shape[0]},)" if len(shape) == 1 else f"({', '.join(map(str, shape))})"


def _features(declared: Mapping[str, tuple[str, ...] | None]) -> str:
    """Features with their categories, ``(a number)`` for a number."""
    return ", ".join(f"{f} {list(c) if c else '(a number)'}" for f, c in declared.items())


def _flow(value: Any) -> str:
    """A value as YAML flow style: ``[wall, foam]``, ``{wall: [3, 0.5]}``, ``0.2``."""
    if isinstance(value, BaseModel):
        return _flow(value.model_dump(mode="json"))
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {_flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_flow(v) for v in value) + "]"
    if isinstance(value, str):
        return value or '""'
    return json.dumps(value) if isinstance(value, bool) or value is None else str(value)


def check_readings(kind: SensorKind, readings: Mapping[str, ArrayLike], sensor: str) -> dict[str, NDArray[Any]]:
    """The readings as float arrays of the kind's array form; refuse, naming the sensor and array, any other.

    >>> from evmap.sources.plugins import sensor_kinds
    >>> check_readings(sensor_kinds()["detector"], {"pose": [0, 0, 0], "points": [[1, 2]]}, "radar")["points"].shape
    (1, 2)
    >>> check_readings(sensor_kinds()["detector"], {"pose": [0, 0]}, "radar")
    Traceback (most recent call last):
    ...
    ValueError: sensor 'radar' (detector): readings need the arrays ['points', 'pose'], got ['pose']
    """
    if set(readings) != set(kind.arrays):
        raise ValueError(
            f"sensor {sensor!r} ({kind.name}): readings need the arrays {sorted(kind.arrays)}, got {sorted(readings)}"
        )
    sizes: dict[str, int] = {}
    out: dict[str, NDArray[Any]] = {}
    for name, shape in kind.arrays.items():
        given = np.asarray(readings[name])
        if given.dtype.kind not in "fiu" and given.size:
            raise ValueError(
                f"sensor {sensor!r}: readings {name!r} must be real numbers, got an array of {given.dtype}"
            )
        a = given.astype(float)
        if a.ndim == 1 and len(shape) == 2 and a.size == 0:
            a = a.reshape(0, *[s for s in shape[1:] if isinstance(s, int)])
        if a.ndim != len(shape):
            raise ValueError(f"sensor {sensor!r}: readings {name!r} must have shape {shape}, got {a.shape}")
        for size, want in zip(a.shape, shape):
            expected = sizes.setdefault(want, size) if isinstance(want, str) else want
            if size != expected:
                raise ValueError(f"sensor {sensor!r}: readings {name!r} must have shape {shape}, got {a.shape}")
        if np.isnan(a).any():
            raise ValueError(f"sensor {sensor!r}: readings {name!r} hold NaN")
        if name not in kind.unbounded and np.isinf(a).any():
            raise ValueError(f"sensor {sensor!r}: readings {name!r} must be finite, got an infinite value")
        out[name] = a
    return out


def check_features(
    sensor: str, declared: Mapping[str, tuple[str, ...] | None], features: Mapping[str, Any], n: int
) -> dict[str, NDArray[Any]]:
    """Refuse, naming the ``sensor``, features that are not one ``declared`` value per segment.

    >>> check_features("'radar' (detector)", {"radar_detection": ("detected", "missed")}, {"radar_detection": ["x"]}, 1)
    Traceback (most recent call last):
    ...
    ValueError: sensor 'radar' (detector): feature 'radar_detection' has value 'x' (segment 0); its categories are ['detected', 'missed']
    """
    if set(features) != set(declared):
        raise ValueError(f"sensor {sensor} gave features {sorted(features)}, not {sorted(declared)}")
    out: dict[str, NDArray[Any]] = {}
    for name, categories in declared.items():
        values = np.asarray(features[name])
        if values.shape != (n,):
            raise ValueError(
                f"sensor {sensor}: feature {name!r} needs one value per segment ({n}), got shape {values.shape}"
            )
        if categories is None:
            values = values.astype(float)
            bad = np.flatnonzero(~np.isfinite(values))
        else:
            values = values.astype(str)
            bad = np.flatnonzero(~np.isin(values, categories))
        if len(bad):
            described = f"its categories are {list(categories)}" if categories else "it must be a finite number"
            raise ValueError(
                f"sensor {sensor}: feature {name!r} has value {values[bad[0]].item()!r} (segment {bad[0]}); {described}"
            )
        out[name] = values
    return out


def build_sensors(
    sections: Mapping[str, Mapping[str, Any]], validate: Callable[..., Any], kinds: Mapping[str, SensorKind]
) -> dict[str, DeclaredSensor]:
    """Build the ``extra_sensors`` of a config; ``validate(model, data, at)`` validates one section; ``kinds`` are
    the sensor kinds by name (:func:`evmap.sources.plugins.sensor_kinds`: built in, and of plugins).

    Raises :class:`~evmap.sources.evidence.SpecError` at the key path of a problem.
    """
    if len(sections) > MAX_SENSORS:
        raise SpecError(("extra_sensors",), f"{len(sections)} sensors, more than the limit of {MAX_SENSORS}")
    out: dict[str, DeclaredSensor] = {}
    for name, data in sections.items():
        at = ("extra_sensors", name)
        kind = data.get("kind") if isinstance(data, Mapping) else None
        if not isinstance(kind, str) or kind not in kinds:
            raise SpecError((*at, "kind"), f"unknown sensor kind {kind!r}; kinds are: {', '.join(sorted(kinds))}")
        out[name] = DeclaredSensor(name, kinds[kind], validate(kinds[kind].spec, data, at))
    return out


def features_from_arrays(
    sensors: Mapping[str, DeclaredSensor],
    readings: Mapping[str, Mapping[str, ArrayLike]],
    p: ArrayLike,
    q: ArrayLike,
) -> dict[str, NDArray[Any]]:
    """The features of every declared sensor for segments ``p``-``q``, from its readings (``{sensor: arrays}``).

    This is how a log or a Python program brings a YAML sensor into a run::

        features = features_from_arrays(cfg.extra_sensors, {"ir": {"pose": ..., "angles": ..., "ranges": ...}},
                                        lsl.p, lsl.q)
        bm.update(Observation(k, sonar_scan, lsl, features))

    >>> from evmap.sources.config import load_config
    >>> from evmap import configs
    >>> cfg = load_config(configs.path("examples/radar.yaml"))
    >>> arrays = {"radar": {"pose": [0, 0, 0], "points": [[1.0, 0.0]]}}
    >>> features_from_arrays(cfg.extra_sensors, arrays, [[1, -1], [5, 5]], [[1, 1], [5, 6]])["radar_detection"].tolist()
    ['detected', 'out_of_view']
    """
    missing = sorted(set(sensors) - set(readings))
    extra = sorted(set(readings) - set(sensors))
    if missing or extra:
        raise ValueError(f"readings are needed for the sensors {sorted(sensors)}; missing {missing}, unknown {extra}")
    out: dict[str, NDArray[Any]] = {}
    for name, sensor in sensors.items():
        out.update(sensor.features(readings[name], p, q))
    return out


def read_readings(path: str | Path) -> dict[str, dict[str, NDArray[Any]]]:
    """One pose's readings of the declared sensors from a log file: an ``.npz`` with arrays ``SENSOR/ARRAY``.

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     np.savez(f"{tmp}/pose0.npz", **{"radar/pose": np.zeros(3), "radar/points": np.zeros((0, 2))})
    ...     {k: sorted(v) for k, v in read_readings(f"{tmp}/pose0.npz").items()}
    {'radar': ['points', 'pose']}
    """
    out: dict[str, dict[str, NDArray[Any]]] = {}
    try:
        loaded = np.load(path, allow_pickle=False)
        if not isinstance(loaded, np.lib.npyio.NpzFile):
            raise ValueError("a single .npy array, not an .npz archive of SENSOR/ARRAY arrays")  # noqa: TRY004 - bad input
        with loaded as log:
            for key in log.files:
                sensor, slash, array = key.partition("/")
                if not slash:
                    raise ValueError(f"array {key!r} is not named SENSOR/ARRAY")
                out.setdefault(sensor, {})[array] = log[key]
    except (zipfile.BadZipFile, EOFError, zlib.error) as exc:
        raise ValueError(f"not a readable .npz archive ({exc or type(exc).__name__})") from None
    except ValueError as exc:
        if "pickled" in str(exc):  # numpy's guess for bytes it cannot read: no .npy or .npz at all
            raise ValueError("not a readable .npz archive (neither .npz nor .npy data)") from None
        raise
    return out
