"""A whole config file: frames, the combination rule, evidence sources, stages, parameters.

:func:`load_config` reads a YAML config (by default the packaged
``configs/paper.yaml``), validates it and builds every evidence source, and
returns an immutable :class:`Config`. A config is self-contained: no includes,
and no meaning in the order of keys. Its top-level keys:

``version``
    ``1`` (optional).
``frames``
    frame name -> ``{elements: [...], aliases: {alias: focal set}}``. A focal set
    is written as an element, elements joined by ``|`` (``real|noise``), an
    alias (``unknown: real|noise``), or ``""`` for the empty set.
``frame``
    the name of the frame of the map's beliefs; every stage's sources are on it.
``rule``
    the combination rule, a name in :data:`evidential.RULES` (default ``dempster``).
``sources``
    source name -> a section with ``kind`` (a name in :data:`evmap.sources.evidence.KINDS`:
    ``table``, ``ramp``, or a plugin's), ``frame``, ``feature`` and the kind's own keys.
``extra_sensors``
    sensor name -> a section with ``kind`` (a name in
    :data:`evmap.sources.sensor_kinds.SENSOR_KINDS`: ``range``, ``detector``,
    ``contour_property``, or a plugin's) and the kind's parameters: sensors beyond the
    sonar and the LSL, whose features (``NAME_...``) noise-elimination sources read.
``stages``
    which sources each stage of the pipeline combines: ``noise_elimination``,
    ``reinforcement``, ``unidentified`` (lists of source names).
``sensors``, ``rcd``, ``rcd_figure``, ``open_space``, ``noise``, ``merge``, ``corners``, ``matching``, ``unidentified``
    the parameters of the sensor models and of each stage, validated by the
    models of :mod:`evmap.sources.params`; a missing section takes the models' defaults.

Config files are untrusted input. Limits: at most :data:`MAX_FRAMES` frames of at
most :data:`MAX_FRAME_ELEMENTS` elements and :data:`MAX_ALIASES` aliases each,
:data:`MAX_SOURCES` sources, :data:`MAX_STAGE_SOURCES` sources per stage, plus the
per-source limits of :mod:`evmap.sources.evidence` and the file size limit of
:mod:`evmap.sources.loading`. Every error is an :class:`~evmap.sources.loading.InputError`
naming the file, the key path and the problem; nothing is returned unless the
whole file is valid.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, StrictInt

from evidential import RULES, Frame
from evmap import configs
from evmap.sources.conformance import check_source
from evmap.sources.evidence import KINDS, EvidenceSource, Name, SpecError, Text
from evmap.sources.loading import Document, InputError, key_path, read_document, validate
from evmap.sources.params import (
    CornerParams,
    LslParams,
    MatchParams,
    MergeParams,
    NoiseParams,
    OpenSpaceParams,
    RcdParams,
    SonarParams,
    UnidentifiedParams,
)
from evmap.sources.plugins import load_plugins, refusal
from evmap.sources.sensor_kinds import MAX_SENSORS, DeclaredSensor, build_sensors

__all__ = [
    "MAX_ALIASES",
    "MAX_FRAMES",
    "MAX_FRAME_ELEMENTS",
    "MAX_SOURCES",
    "MAX_STAGE_SOURCES",
    "PACKAGED_CONFIGS",
    "PARAMETER_SECTIONS",
    "PIPELINE_FEATURES",
    "STAGES",
    "Config",
    "ConfigFile",
    "Feature",
    "FrameSpec",
    "SensorsParams",
    "StagesSpec",
    "check_simulated_run",
    "config_from_data",
    "config_path",
    "load_config",
]

MAX_FRAMES = 16
"""Most frames in one config."""
MAX_FRAME_ELEMENTS = 8
"""Most elements in one frame of a config: a dense mass function has ``2**n`` entries, one per
segment and source in a run (20,000 phantom lines on 16 elements needed more than 4 GB)."""
MAX_ALIASES = 64
"""Most aliases in one frame."""
MAX_SOURCES = 64
"""Most sources in one config."""
MAX_STAGE_SOURCES = 64
"""Most sources combined by one stage."""

STAGES: tuple[str, ...] = ("noise_elimination", "repeated_observation", "reinforcement", "unidentified")
"""The stages of the pipeline that combine evidence sources, in the paper's order
(``repeated_observation``, optional, is folded into a segment's noise-elimination
mass only when other poses saw it: the paper's future work)."""

PARAMETER_SECTIONS: tuple[str, ...] = (
    "sensors",
    "rcd",
    "rcd_figure",
    "open_space",
    "noise",
    "merge",
    "corners",
    "matching",
    "unidentified",
)
"""The top-level keys holding parameter models, in the order ``evmap config check`` prints them."""


@dataclasses.dataclass(frozen=True)
class Feature:
    """A feature the pipeline gives the sources of some stages.

    Attributes
    ----------
    stages : the stages whose sources are given it.
    categories : the categories it takes (a table must have a row for each), or ``None``
        for a number (read by a ramp).
    """

    stages: tuple[str, ...]
    categories: tuple[str, ...] | None


_SEGMENT_STAGES = ("noise_elimination", "repeated_observation")

PIPELINE_FEATURES: Mapping[str, Feature] = MappingProxyType(
    {
        "relation": Feature(_SEGMENT_STAGES, ("outside", "partly_inside", "inside")),
        "length": Feature(_SEGMENT_STAGES, None),
        "lsl_other_poses": Feature(_SEGMENT_STAGES, None),
        "contour_free": Feature(_SEGMENT_STAGES, ("contradicted", "clear")),
        "lsl_persistence": Feature(_SEGMENT_STAGES, ("missed", "seen", "unobserved")),
        "sonar_forward": Feature(_SEGMENT_STAGES, ("contradicted", "confirmed", "silent")),
        "sonar_match": Feature(("reinforcement",), ("matched", "missed", "unobserved")),
        "rcd_type": Feature(("unidentified",), ("I", "II", "III")),
    }
)
"""The features the pipeline computes, by name. A noise-elimination (or repeated-observation)
source may also read a feature of a sensor declared under ``extra_sensors`` (simulated in
runs on scenarios), or one an observation brings."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class FrameSpec(_Section):
    """A frame: its ordered elements and aliases of focal sets."""

    elements: list[Name] = Field(min_length=1, max_length=MAX_FRAME_ELEMENTS)
    aliases: dict[Name, Text] = Field(default_factory=dict, max_length=MAX_ALIASES)


class SensorsParams(_Section):
    """The sensor models."""

    sonar: SonarParams = SonarParams()
    lsl: LslParams = LslParams()


class StagesSpec(_Section):
    """The sources each stage combines (names under ``sources``)."""

    noise_elimination: list[Name] = Field(min_length=1, max_length=MAX_STAGE_SOURCES)
    repeated_observation: list[Name] = Field(default_factory=list, max_length=MAX_STAGE_SOURCES)
    reinforcement: list[Name] = Field(min_length=1, max_length=MAX_STAGE_SOURCES)
    unidentified: list[Name] = Field(min_length=1, max_length=MAX_STAGE_SOURCES)


def _known_version(version: int) -> int:
    if version != 1:
        raise ValueError("unsupported version: this program reads version 1")
    return version


class ConfigFile(_Section):
    """The structure of a config file, before its sources are built."""

    version: Annotated[StrictInt, AfterValidator(_known_version)] = 1
    frames: dict[Name, FrameSpec] = Field(min_length=1, max_length=MAX_FRAMES)
    frame: Name
    rule: Text = "dempster"
    sources: dict[Name, dict[str, Any]] = Field(min_length=1, max_length=MAX_SOURCES)
    extra_sensors: dict[Name, dict[str, Any]] = Field(default_factory=dict, max_length=MAX_SENSORS)
    stages: StagesSpec
    sensors: SensorsParams = SensorsParams()
    rcd: RcdParams = RcdParams()
    rcd_figure: RcdParams = RcdParams(range_tolerance=0.01, min_width_deg=10.0)
    open_space: OpenSpaceParams = OpenSpaceParams()
    noise: NoiseParams = NoiseParams()
    merge: MergeParams = MergeParams()
    corners: CornerParams = CornerParams()
    matching: MatchParams = MatchParams()
    unidentified: UnidentifiedParams = UnidentifiedParams()


@dataclasses.dataclass(frozen=True, eq=False)
class Config:
    """A validated config with its sources built. Immutable; see :func:`load_config`.

    Attributes
    ----------
    name : where it was read from (used in messages).
    spec : the validated file as written (:meth:`to_data` writes it back).
    frames : frame name -> :class:`evidential.Frame`.
    aliases : frame name -> {alias: the focal set it names, as written}.
    frame_name : the name of the map's frame, :attr:`frame`.
    rule : the combination rule, a name in :data:`evidential.RULES`.
    sources : source name -> built :class:`~evmap.sources.evidence.EvidenceSource`.
    stages : stage name -> the names of the sources it combines.
    sensors, rcd, rcd_figure, open_space, noise, merge, corners, matching, unidentified :
        the parameter models of :mod:`evmap.sources.params`.
    warnings : what a valid config does that may not work: a source reading a feature no
        sensor computes (``evmap config check`` prints them, see :func:`check_simulated_run`).
    extra_sensors : sensor name -> :class:`~evmap.sources.sensor_kinds.DeclaredSensor`, the
        sensors declared in YAML; simulated runs simulate them, logs and Python bring their readings.
    """

    name: str
    spec: ConfigFile
    frames: Mapping[str, Frame]
    aliases: Mapping[str, Mapping[str, str]]
    frame_name: str
    rule: str
    sources: Mapping[str, EvidenceSource]
    stages: Mapping[str, tuple[str, ...]]
    sensors: SensorsParams
    rcd: RcdParams
    rcd_figure: RcdParams
    open_space: OpenSpaceParams
    noise: NoiseParams
    merge: MergeParams
    corners: CornerParams
    matching: MatchParams
    unidentified: UnidentifiedParams
    warnings: tuple[str, ...] = ()
    extra_sensors: Mapping[str, DeclaredSensor] = dataclasses.field(default_factory=lambda: MappingProxyType({}))

    @property
    def frame(self) -> Frame:
        """The frame of the map's beliefs and of every stage's sources."""
        return self.frames[self.frame_name]

    def stage_sources(self, stage: str) -> tuple[EvidenceSource, ...]:
        """The sources a stage combines, in the order the config lists them.

        >>> cfg = load_config()
        >>> [s.name for s in cfg.stage_sources("noise_elimination")]
        ['sonar_open_space', 'lsl_length']
        """
        if stage not in self.stages:
            raise ValueError(f"unknown stage {stage!r}; stages are: {', '.join(self.stages)}")
        return tuple(self.sources[name] for name in self.stages[stage])

    def to_data(self) -> dict[str, Any]:
        """The config as JSON-able data, as it is now; :func:`config_from_data` reads it back.

        The rule and the parameter sections are the config's own (changed by
        :meth:`with_rule` or :func:`dataclasses.replace`); frames, sources and
        stages are those of the file.

        >>> cfg = dataclasses.replace(load_config().with_rule("yager"), merge=MergeParams(distance=0.08))
        >>> copy = config_from_data(cfg.to_data(), "copy")
        >>> copy.rule, copy.merge.distance
        ('yager', 0.08)
        """
        sections = {name: getattr(self, name).model_dump(mode="json") for name in PARAMETER_SECTIONS}
        return {**self.spec.model_dump(mode="json"), "rule": self.rule, **sections}

    def with_rule(self, rule: str) -> Config:
        """A copy of this config that combines with another rule (a name in :data:`evidential.RULES`).

        >>> load_config().with_rule("yager").rule
        'yager'
        """
        _check_rule(rule)
        return dataclasses.replace(self, rule=rule)


PACKAGED_CONFIGS = ("paper", "default")
"""The configs evmap ships, by name: ``paper`` (the paper's method) and ``default`` (with the evidence beyond it)."""


def config_path(name: str | Path) -> Path:
    """The file of a config given by path, or by the name of a packaged config (:data:`PACKAGED_CONFIGS`).

    >>> config_path("paper").name, config_path("configs/paper.yaml").as_posix()
    ('paper.yaml', 'configs/paper.yaml')
    """
    path = Path(name)
    if isinstance(name, str) and name in PACKAGED_CONFIGS and not path.exists():
        return configs.path(f"{name}.yaml")
    if not path.exists() and not path.suffix:
        raise InputError(
            f"{name}: no such config file, nor a packaged config (those are {', '.join(PACKAGED_CONFIGS)})"
        )
    return path


def load_config(path: str | Path | None = None) -> Config:
    """Read, validate and build a config file (a path, or a packaged config's name: ``paper``, ``default``);
    ``None`` reads the packaged ``configs/paper.yaml``.

    Raises
    ------
    evmap.sources.loading.InputError
        naming the file, the key path and the problem, if anything in the file is wrong.

    Examples
    --------
    >>> cfg = load_config()
    >>> cfg.rule, cfg.noise.threshold, cfg.merge.distance
    ('dempster', 0.5, 0.05)
    >>> cfg.sources["lsl_length"].masses({"length": [0.2]}).round(3).tolist()
    [[0.0, 0.3, 0.0, 0.7]]
    >>> sorted(load_config("default").stages) == sorted(cfg.stages)
    True
    """
    document = read_document(configs.path("paper.yaml") if path is None else config_path(path))
    return _build_checked(document.validate(ConfigFile), document.name, document)


def config_from_data(data: Any, name: str) -> Config:
    """Validate and build a config from parsed data (a YAML file's content, or :meth:`Config.to_data`)."""
    return _build_checked(validate(ConfigFile, data, name), name)


def check_simulated_run(config: Config) -> None:
    """Refuse a config that ``evmap run`` cannot use on a simulated scenario.

    A source of the noise-elimination (or repeated-observation) stage may read a feature
    that an observation brings; no built-in sensor computes one, so a run on a simulated
    scenario would fail half-way. :attr:`Config.warnings` says the same for ``config check``.

    Raises
    ------
    InputError
        naming the file, the key path of the source's ``feature`` and the feature.

    >>> check_simulated_run(load_config())
    >>> check_simulated_run(load_config(configs.path("examples/infrared.yaml")))  # the sensor `ir` gives ir_return
    >>> data = load_config(configs.path("examples/infrared.yaml")).to_data()
    >>> check_simulated_run(config_from_data({**data, "extra_sensors": {}}, "no_ir"))
    Traceback (most recent call last):
    ...
    evmap.sources.loading.InputError: no_ir: sources.infrared.feature: reads feature 'ir_return', ...
    """
    if config.warnings:
        raise InputError(config.warnings[0])


def _build_checked(spec: ConfigFile, name: str, document: Document | None = None) -> Config:
    """:func:`_build`, its first problem raised as an InputError naming the file, line and key path."""
    try:
        return _build(spec, name, document)
    except SpecError as exc:
        if document is not None:
            raise document.error(exc.at, exc.problem) from None
        raise InputError(f"{name}: {key_path(exc.at)}: {exc.problem}") from None


def _build(spec: ConfigFile, name: str, document: Document | None) -> Config:
    """Build frames, check the rule, build sources and check stages; raise SpecError at the first problem."""
    frames: dict[str, Frame] = {}
    for frame_name, fspec in spec.frames.items():
        try:
            frames[frame_name] = Frame(fspec.elements)
        except ValueError as exc:
            raise SpecError(("frames", frame_name, "elements"), str(exc)) from None
        for alias, written in fspec.aliases.items():
            at = ("frames", frame_name, "aliases", alias)
            if alias in fspec.elements:
                raise SpecError(at, f"alias {alias!r} is also an element of the frame")
            try:
                frames[frame_name].mask(written)
            except ValueError as exc:
                raise SpecError(at, str(exc)) from None
    if spec.frame not in frames:
        raise SpecError(("frame",), f"unknown frame {spec.frame!r}; frames are: {', '.join(frames)}")
    _check_map_frame(spec)
    try:
        _check_rule(spec.rule)
    except ValueError as exc:
        raise SpecError(("rule",), str(exc)) from None

    sensors = build_sensors(spec.extra_sensors, lambda model, data, at: validate(model, data, name, at, document))
    built: dict[str, EvidenceSource] = {}
    for source_name, data in spec.sources.items():
        at = ("sources", source_name)
        kind = data.get("kind")
        if kind is None:
            raise SpecError((*at, "kind"), f"required key is missing; kinds are: {', '.join(sorted(KINDS))}")
        if isinstance(kind, str) and kind not in KINDS:
            load_plugins()  # a kind of an installed package, registered on first use
        if not isinstance(kind, str) or kind not in KINDS:
            problem = refusal("evmap.source_kinds", kind) if isinstance(kind, str) else None
            raise SpecError(
                (*at, "kind"), problem or f"unknown source kind {kind!r}; kinds are: {', '.join(sorted(KINDS))}"
            )
        source_spec = validate(KINDS[kind].spec, data, name, at, document)
        if source_spec.frame not in frames:
            raise SpecError((*at, "frame"), f"unknown frame {source_spec.frame!r}; frames are: {', '.join(frames)}")
        frame = frames[source_spec.frame]
        aliases = spec.frames[source_spec.frame].aliases

        def focal(written: str, frame: Frame = frame, aliases: Mapping[str, str] = aliases) -> int:
            return frame.mask(aliases.get(written, written))

        try:
            built[source_name] = KINDS[kind].build(source_name, source_spec, frame, focal)
        except SpecError as exc:
            raise SpecError((*at, *exc.at), exc.problem) from None
        try:  # the conformance checks, once, on the source's own example values
            check_source(built[source_name], getattr(built[source_name], "examples", ()))
        except ValueError as exc:
            raise SpecError(at, f"source kind {kind!r} ({KINDS[kind].origin}): {exc}") from None

    stages: dict[str, tuple[str, ...]] = {}
    for stage in STAGES:
        names: list[str] = getattr(spec.stages, stage)
        for i, source_name in enumerate(names):
            at = ("stages", stage, i)
            if source_name not in built:
                raise SpecError(at, f"unknown source {source_name!r}; sources are: {', '.join(built)}")
            if source_name in names[:i]:
                raise SpecError(at, f"source {source_name!r} is listed twice")
            source_frame = spec.sources[source_name]["frame"]
            if built[source_name].frame != frames[spec.frame]:
                raise SpecError(
                    at,
                    f"source {source_name!r} is on frame {source_frame!r}, not on the config's frame {spec.frame!r}",
                )
        stages[stage] = tuple(names)
    declared: dict[str, tuple[str, ...] | None] = {}
    for sensor_name, sensor in sensors.items():
        for feature, categories in sensor.declares().items():
            if feature in PIPELINE_FEATURES or feature in declared:
                raise SpecError(("extra_sensors", sensor_name), f"its feature {feature!r} is already given")
            declared[feature] = categories
    warnings = [_check_feature(spec, stage, source_name, declared) for stage in STAGES for source_name in stages[stage]]
    return Config(
        name=name,
        spec=spec,
        frames=MappingProxyType(frames),
        aliases=MappingProxyType({k: MappingProxyType(dict(v.aliases)) for k, v in spec.frames.items()}),
        frame_name=spec.frame,
        rule=spec.rule,
        sources=MappingProxyType(built),
        stages=MappingProxyType(stages),
        **{section: getattr(spec, section) for section in PARAMETER_SECTIONS},
        warnings=tuple(
            str(document.error(at, problem) if document is not None else f"{name}: {key_path(at)}: {problem}")
            for at, problem in dict.fromkeys(w for w in warnings if w is not None)
        ),
        extra_sensors=MappingProxyType(sensors),
    )


def _check_map_frame(spec: ConfigFile) -> None:
    """The map's frame holds ``real`` (the map's beliefs) and ``noise`` (noise elimination)."""
    elements = spec.frames[spec.frame].elements
    missing = [e for e in ("real", "noise") if e not in elements]
    if missing:
        raise SpecError(
            ("frames", spec.frame, "elements"),
            f"the map's frame needs the elements 'real' (beliefs are Bel(real)) and 'noise' (noise elimination); "
            f"missing {', '.join(map(repr, missing))} in {elements}",
        )


def _check_feature(
    spec: ConfigFile, stage: str, source_name: str, declared: Mapping[str, tuple[str, ...] | None]
) -> tuple[tuple[str, ...], str] | None:
    """Raise SpecError if a stage's source reads a feature the stage never gives, or cannot judge its values.

    ``declared`` are the features of the config's ``extra_sensors``. Returns a warning
    (key path, text) for a feature no sensor computes but an observation may bring, else ``None``.
    """
    data = spec.sources[source_name]
    feature, at = data["feature"], ("sources", source_name)
    known = PIPELINE_FEATURES.get(feature)
    if known is None and feature in declared:
        known = Feature(_SEGMENT_STAGES, declared[feature])
    if known is None or stage not in known.stages:
        given = [f for f, spec_ in PIPELINE_FEATURES.items() if stage in spec_.stages]
        if stage not in _SEGMENT_STAGES:
            raise SpecError(
                (*at, "feature"),
                f"stage {stage} gives its sources only the feature {', '.join(map(repr, given))}, not {feature!r}",
            )
        return (
            (*at, "feature"),
            (
                f"reads feature {feature!r}, which no sensor computes (stage {stage} computes "
                f"{', '.join([*given, *declared])}); `evmap run` on a simulated scenario cannot use this source, "
                f"only observations that bring {feature!r} (declare a sensor under `extra_sensors` that gives it)"
            ),
        )
    if known.categories is None and data["kind"] == "table":
        raise SpecError((*at, "kind"), f"feature {feature!r} is a number: read it with a ramp, not a table")
    if known.categories is not None and data["kind"] == "ramp":
        raise SpecError(
            (*at, "kind"), f"feature {feature!r} takes categories {list(known.categories)}: read it with a table"
        )
    if known.categories is not None and data["kind"] == "table":
        missing = [c for c in known.categories if c not in data["categories"]]
        if missing:
            raise SpecError(
                (*at, "categories"),
                f"feature {feature!r} takes the categories {list(known.categories)}; "
                f"the table has no row for {', '.join(map(repr, missing))}",
            )
    return None


def _check_rule(rule: str) -> None:
    """Refuse a rule name that is not in the engine's registry (plugins' rules loaded on first miss)."""
    if isinstance(rule, str) and rule not in RULES:
        load_plugins()
    if not isinstance(rule, str) or rule not in RULES:
        problem = refusal("evmap.rules", rule) if isinstance(rule, str) else None
        raise ValueError(problem or f"unknown rule {rule!r}; rules are: {', '.join(sorted(RULES))}")
