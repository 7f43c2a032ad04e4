"""A plugin package for evmap: two rules, two source kinds and a sensor kind (one rule and one kind broken)."""

from typing import Literal

import numpy as np
from pydantic import Field

from evidential.stack import Stack
from evmap.sources.evidence import BoundSource, SourceKind, SourceSpec
from evmap.sources.sensor_kinds import SensorKind, SensorSpec


def average(sources, n):
    """The average of the mass functions: a rule that is commutative and idempotent."""
    masks = np.unique(np.concatenate([s.masks for s in sources]))
    masses = np.zeros((len(masks), sources[0].masses.shape[1]))
    for s in sources:
        masses[np.searchsorted(masks, s.masks)] += s.masses
    return Stack(masks, masses / len(sources))


average.rule_options = {"properties": ["commutative", "idempotent"]}


def doubled(sources, n):
    """A broken rule: its masses sum to 2."""
    return Stack(sources[0].masks, 2 * sources[0].masses)


class LogisticSpec(SourceSpec):
    """``kind: logistic``: m(focal) = top / (1 + exp(-(x - middle) / scale)), the rest unknown."""

    kind: Literal["logistic"]
    focal: str
    top: float = Field(ge=0, le=1)
    middle: float
    scale: float = Field(gt=0)


def build_logistic(name, spec, frame, focal):
    """A source whose mass on ``focal`` rises smoothly with the feature."""
    mask, full = focal(spec.focal), (1 << len(frame)) - 1

    def masses(values):
        x = np.asarray(values, dtype=float)
        out = np.zeros((len(x), 1 << len(frame)))
        out[:, mask] = spec.top / (1 + np.exp(-(x - spec.middle) / spec.scale))
        out[:, full] += 1 - out[:, mask]
        return out

    examples = (spec.middle - 2 * spec.scale, spec.middle, spec.middle + 2 * spec.scale)
    return BoundSource(name, frame, spec.feature, "logistic", masses, examples, f"logistic m({spec.focal})")


LOGISTIC = SourceKind(
    name="logistic",
    spec=LogisticSpec,
    build=build_logistic,
    example={"frame": "existence", "feature": "length", "focal": "real", "top": 0.6, "middle": 0.2, "scale": 0.05},
)


class OverfullSpec(SourceSpec):
    """``kind: overfull``: a broken kind, every row sums to 2."""

    kind: Literal["overfull"]


def build_overfull(name, spec, frame, focal):
    """Rows of mass 1 on {real} and 1 on {noise}: they sum to 2."""

    def masses(values):
        out = np.zeros((len(values), 1 << len(frame)))
        out[:, 1:3] = 1.0
        return out

    return BoundSource(name, frame, spec.feature, "overfull", masses, (0,), "sums to 2")


OVERFULL = SourceKind(
    name="overfull", spec=OverfullSpec, build=build_overfull, example={"frame": "existence", "feature": "x"}
)


class BumperSpec(SensorSpec):
    """``kind: bumper``: contact switches; a segment within ``reach`` of a pressed bumper is touched."""

    kind: Literal["bumper"]
    reach: float = Field(0.3, gt=0)


def bumper_features(spec, readings, p, q):
    """``touched`` (``yes`` / ``no``): a segment's midpoint within ``reach`` of a contact point."""
    contacts = readings["contacts"]
    middle = (p + q) / 2
    gap = np.hypot(*(middle[:, None, :] - contacts[None, :, :]).transpose(2, 0, 1))
    near = (gap <= spec.reach).any(axis=1) if len(contacts) else np.zeros(len(p), dtype=bool)
    return {"touched": np.where(near, "yes", "no")}


BUMPER = SensorKind(
    name="bumper",
    spec=BumperSpec,
    arrays={"contacts": ("C", 2)},
    features=bumper_features,
    categories=lambda spec: {"touched": ("yes", "no")},
    simulate=None,
    example={"kind": "bumper"},
    summary="contact switches: which segments the robot touched",
)
