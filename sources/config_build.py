"""Building a :class:`~evmap.sources.config_model.Config` from a validated config file.

:func:`build_config` builds the frames, checks the rule, builds and checks every
evidence source (:data:`~evmap.sources.evidence.KINDS`, plugins' kinds loaded on
first miss), the extra sensors and the stages, and checks that each stage's
sources read features it gives. The first problem is raised as an
:class:`~evmap.sources.loading.InputError` naming the file, its line and the key path.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from evidential import Frame
from evmap.sources.config_model import (
    PARAMETER_SECTIONS,
    PIPELINE_FEATURES,
    SEGMENT_STAGES,
    STAGES,
    Config,
    ConfigFile,
    Feature,
    check_rule,
)
from evmap.sources.conformance import check_source
from evmap.sources.evidence import KINDS, EvidenceSource, SpecError
from evmap.sources.loading import Document, InputError, key_path, validate
from evmap.sources.plugins import load_plugins, refusal, sensor_kinds
from evmap.sources.sensor_kinds import build_sensors

__all__ = ["build_config"]


def build_config(spec: ConfigFile, name: str, document: Document | None = None) -> Config:
    """Build the config ``spec`` read from ``name`` (``document``: the parsed file, to name lines in errors).

    Raises
    ------
    InputError
        at the first problem, naming the file (and line), the key path and the problem.
    """
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
        check_rule(spec.rule)
    except ValueError as exc:
        raise SpecError(("rule",), str(exc)) from None

    wanted = [data.get("kind") if isinstance(data, Mapping) else None for data in spec.extra_sensors.values()]
    sensors = build_sensors(
        spec.extra_sensors, lambda model, data, at: validate(model, data, name, at, document), sensor_kinds(wanted)
    )
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
        known = Feature(SEGMENT_STAGES, declared[feature])
    if known is None or stage not in known.stages:
        given = [f for f, spec_ in PIPELINE_FEATURES.items() if stage in spec_.stages]
        if stage not in SEGMENT_STAGES:
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
