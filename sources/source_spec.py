"""What an evidence source is: the protocol, a source bound to its tables, the YAML section every source has, a kind.

The data of :mod:`evmap.sources.evidence`, which holds the registry of kinds
(:func:`~evmap.sources.evidence.register_kind`) and the generic kinds ``table``
and ``ramp``. A source turns a feature of N objects into an ``(N, 2**n)`` batch
of mass functions over its frame.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Annotated, Any, Protocol, TypeVar, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict, Field, Strict, StringConstraints

from evidential import Frame

__all__ = [
    "EXAMPLE_FRAME",
    "BoundSource",
    "Builder",
    "EvidenceSource",
    "FocalResolver",
    "Name",
    "SourceKind",
    "SourceSpec",
    "Spec",
    "SpecError",
    "Text",
    "example_focal",
]

EXAMPLE_FRAME = Frame(["real", "noise"])
"""The frame a kind's example section is built on at registration (``unknown`` is ``real|noise``)."""

FocalResolver = Callable[[str], int]
"""Turns a focal set as written in YAML (an element, ``a|b``, an alias, ``""``) into its bitmask."""

Text = Annotated[str, Strict()]
"""A string: not a number, not binary data (``!!binary``)."""
Name = Annotated[str, Strict(), StringConstraints(pattern=r"^[A-Za-z][A-Za-z0-9_-]{0,63}$")]
"""A name in a config (frame, source, feature, sensor): a letter, then letters, digits, ``_`` or ``-``; 64 at most."""


@runtime_checkable
class EvidenceSource(Protocol):
    """What the pipeline needs of an evidence source.

    ``name`` names it in the config; ``frame`` is the frame of its masses;
    ``feature`` is the key it reads in the features given to :meth:`masses`.
    """

    name: str
    frame: Frame
    feature: str

    def masses(self, features: Mapping[str, ArrayLike]) -> NDArray[np.float64]:
        """Mass functions of N objects, an ``(N, 2**n)`` array, from their features (arrays of N)."""
        ...


class SpecError(ValueError):
    """A source's YAML section is wrong; ``at`` is the key path inside the section."""

    def __init__(self, at: tuple[str | int, ...], problem: str) -> None:
        super().__init__(problem)
        self.at = at
        self.problem = problem


@dataclass(frozen=True, eq=False)
class BoundSource:
    """An evidence source: a plain array function bound to its validated tables.

    Attributes
    ----------
    name, frame, feature : as in :class:`EvidenceSource`.
    kind : the registered kind it was built by (``table``, ``ramp``).
    function : maps the feature's array of N values to the ``(N, 2**n)`` masses.
    examples : feature values that show what the source does (the categories of
        a table; the break points of a ramp and the midpoints between them), for
        ``evmap config check`` and ``evmap config explain``.
    summary : one line saying what the source computes.
    """

    name: str
    frame: Frame
    feature: str
    kind: str
    function: Callable[[ArrayLike], NDArray[np.float64]]
    examples: tuple[Any, ...]
    summary: str

    def masses(self, features: Mapping[str, ArrayLike]) -> NDArray[np.float64]:
        """Mass functions of N objects from ``features[self.feature]`` (an array of N values).

        Raises
        ------
        ValueError
            if the feature is missing or holds a value the source cannot judge.
        """
        if self.feature not in features:
            raise ValueError(
                f"source {self.name!r} reads feature {self.feature!r}, "
                f"which is not among the features given: {sorted(features)}"
            )
        try:
            return self.function(features[self.feature])
        except ValueError as exc:
            raise ValueError(f"source {self.name!r}, feature {self.feature!r}: {exc}") from None


class SourceSpec(BaseModel):
    """The YAML keys every source has: its kind, the frame it speaks of, the feature it reads."""

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True)

    kind: Text
    frame: Name = Field(description="name of a frame declared under `frames`")
    feature: Name = Field(description="the feature of the objects that the source reads")
    description: Text = Field("", max_length=2000, description="free text, shown by `evmap config check`")


Spec = TypeVar("Spec", bound=SourceSpec)
"""The model of a kind's YAML section."""
Builder = Callable[[str, Spec, Frame, FocalResolver], EvidenceSource]
"""Builds a source from its name, validated section, frame and focal-set resolver."""


@dataclass(frozen=True)
class SourceKind:
    """A kind of source: the model of its YAML section, its builder, and an example section.

    ``example`` is a valid section on the frame :data:`EXAMPLE_FRAME` named ``existence``
    (without ``kind``), built and checked at registration (``None``: the kind's sources are
    checked only when a config builds them); ``origin`` says where the kind comes from
    (``builtin``, or a plugin's entry point).
    """

    name: str
    spec: type[SourceSpec]
    build: Builder[Any]
    example: Mapping[str, Any] | None = None
    origin: str = "builtin"

    def build_example(self) -> EvidenceSource:
        """The source of the example section, on :data:`EXAMPLE_FRAME`."""
        if self.example is None:
            raise ValueError(f"source kind {self.name!r} has no example section")
        spec = self.spec.model_validate({"kind": self.name, **self.example})
        return self.build(f"{self.name}_example", spec, EXAMPLE_FRAME, example_focal)


def example_focal(written: str) -> int:
    """The focal-set resolver of :data:`EXAMPLE_FRAME`: elements, ``a|b``, ``unknown``, ``""``."""
    return EXAMPLE_FRAME.mask({"unknown": "real|noise"}.get(written, written))
