"""A config's data: the structure of a config file, the stages and features it names, the built Config.

:func:`~evmap.sources.config.load_config` validates a file against
:class:`ConfigFile` (pydantic models: the structure and its limits) and builds a
:class:`Config` from it (:func:`~evmap.sources.config_build.build_config`); the
file's keys are described in :mod:`evmap.sources.config`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, StrictInt

from evidential import RULES, Frame
from evmap.sources.evidence import EvidenceSource, Name, Text
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
from evmap.sources.sensor_kinds import MAX_SENSORS, DeclaredSensor

__all__ = [
    "MAX_ALIASES",
    "MAX_FRAMES",
    "MAX_FRAME_ELEMENTS",
    "MAX_SOURCES",
    "MAX_STAGE_SOURCES",
    "PARAMETER_SECTIONS",
    "PIPELINE_FEATURES",
    "SEGMENT_STAGES",
    "STAGES",
    "Config",
    "ConfigFile",
    "Feature",
    "FrameSpec",
    "SensorsParams",
    "StagesSpec",
    "check_rule",
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


SEGMENT_STAGES = ("noise_elimination", "repeated_observation")
"""The stages that judge LSL segments: their sources may also read extra sensors' and observations' features."""

PIPELINE_FEATURES: Mapping[str, Feature] = MappingProxyType(
    {
        "relation": Feature(SEGMENT_STAGES, ("outside", "partly_inside", "inside")),
        "length": Feature(SEGMENT_STAGES, None),
        "lsl_other_poses": Feature(SEGMENT_STAGES, None),
        "contour_free": Feature(SEGMENT_STAGES, ("contradicted", "clear")),
        "lsl_persistence": Feature(SEGMENT_STAGES, ("missed", "seen", "unobserved")),
        "sonar_forward": Feature(SEGMENT_STAGES, ("contradicted", "confirmed", "silent")),
        "sonar_match": Feature(("reinforcement",), ("matched", "missed", "unobserved")),
        "rcd_type": Feature(("unidentified",), ("I", "II", "III")),
    }
)
"""The features the pipeline computes, by name. A noise-elimination (or repeated-observation)
source may also read a feature of a sensor declared under ``extra_sensors`` (simulated in
runs on scenarios), or one an observation brings."""


class _Section(BaseModel):
    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True, strict=True)


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

        >>> from evmap.sources.config import load_config
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

        >>> from evmap.sources.config import config_from_data, load_config
        >>> from evmap.sources.params import MergeParams
        >>> cfg = dataclasses.replace(load_config().with_rule("yager"), merge=MergeParams(distance=0.08))
        >>> copy = config_from_data(cfg.to_data(), "copy")
        >>> copy.rule, copy.merge.distance
        ('yager', 0.08)
        """
        sections = {name: getattr(self, name).model_dump(mode="json") for name in PARAMETER_SECTIONS}
        return {**self.spec.model_dump(mode="json"), "rule": self.rule, **sections}

    def with_rule(self, rule: str) -> Config:
        """A copy of this config that combines with another rule (a name in :data:`evidential.RULES`).

        >>> from evmap.sources.config import load_config
        >>> load_config().with_rule("yager").rule
        'yager'
        """
        check_rule(rule)
        return dataclasses.replace(self, rule=rule)


def check_rule(rule: str) -> None:
    """Refuse (``ValueError``) a rule name that is not in the engine's registry (plugins' rules loaded on first
    miss), or whose sources must all put mass on the empty set (``empty_set="required"``, as the bold rule's):
    evmap's evidence sources put none, so such a rule could fuse nothing.

    >>> check_rule("dempster")
    >>> check_rule("dempstr")
    Traceback (most recent call last):
    ...
    ValueError: unknown rule 'dempstr'; rules are: ...
    >>> check_rule("bold")
    Traceback (most recent call last):
    ...
    ValueError: rule 'bold' combines only mass functions with m(∅) > 0 (empty_set 'required'); evmap's sources put no mass on ∅: choose another rule
    """
    if isinstance(rule, str) and rule not in RULES:
        load_plugins()
    if not isinstance(rule, str) or rule not in RULES:
        problem = refusal("evmap.rules", rule) if isinstance(rule, str) else None
        raise ValueError(problem or f"unknown rule {rule!r}; rules are: {', '.join(sorted(RULES))}")
    if RULES[rule].empty_set == "required":
        raise ValueError(
            f"rule {rule!r} combines only mass functions with m(∅) > 0 (empty_set 'required'); "
            "evmap's sources put no mass on ∅: choose another rule"
        )
