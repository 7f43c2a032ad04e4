"""Evidence sources: one protocol, a registry of kinds, and the two generic kinds.

An evidence source turns a feature of many objects (one array entry per object)
into their mass functions over the source's frame: a batch, an ``(N, 2**n)``
float array whose column ``b`` is the focal set with bitmask ``b`` (column 0 is
the empty set), ready for :func:`evidential.combine_batch`.

Sources are built from YAML (see :mod:`evmap.sources.config`); the protocol and the
data of a source and of a kind are in :mod:`evmap.sources.source_spec`. Each *kind* of source is
registered by name with :func:`register_kind`: a pydantic model of its YAML
section, a builder that binds a plain array function to its validated tables
(``functools.partial``), and an example section. Registration builds the example
and runs it through :func:`check_source` (rows are mass functions, one per
object, deterministic, the same one by one as in a batch), and every source a
config builds is checked the same way on its example values: a kind whose rows
are not mass functions is refused with its name. Two kinds need no Python at all:

``table``
    a categorical feature (``outside``, ``partly_inside``, ``inside``) mapped to
    one mass function per category (the paper's Table 1);
``ramp``
    a continuous feature mapped to the mass of one focal set by a piecewise-linear
    function through break points, constant beyond the ends, the rest of the mass
    on chosen focal sets in fixed proportions (the paper's LSL length source,
    ``m(real) = c * min(l / L, 1)``).

Limits on untrusted input: at most :data:`MAX_CATEGORIES` categories per table,
:data:`MAX_BREAK_POINTS` break points per ramp, and :data:`MAX_TABLE_CELLS`
dense cells (categories times ``2**n``) per table.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from functools import partial
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, Strict, StringConstraints

from evidential import Frame
from evmap.sources.conformance import MASS_TOLERANCE, check_source
from evmap.sources.source_spec import (
    EXAMPLE_FRAME,
    BoundSource,
    Builder,
    EvidenceSource,
    FocalResolver,
    Name,
    SourceKind,
    SourceSpec,
    Spec,
    SpecError,
    Text,
    example_focal,
)

__all__ = [
    "EXAMPLE_FRAME",
    "KINDS",
    "MASS_TOLERANCE",
    "MAX_BREAK_POINTS",
    "MAX_CATEGORIES",
    "MAX_TABLE_CELLS",
    "BoundSource",
    "EvidenceSource",
    "FocalResolver",
    "Name",
    "RampSpec",
    "SourceKind",
    "SourceSpec",
    "SpecError",
    "TableSpec",
    "Text",
    "example_focal",
    "mass_row",
    "ramp_masses",
    "register_kind",
    "table_masses",
]

MAX_CATEGORIES = 1000
"""Most categories in one table source."""
MAX_BREAK_POINTS = 1000
"""Most break points in one ramp source."""
MAX_TABLE_CELLS = 1 << 16
"""Most dense cells (categories times ``2**n``) in one table source."""
Category = Annotated[str, Strict(), StringConstraints(pattern=r"^[^\x00-\x1f]{1,100}$")]
Mass = Annotated[float, Field(strict=True, allow_inf_nan=False)]


def _width(frame: Frame) -> int:
    """Number of focal sets (columns of a dense batch) of a frame: ``2**n``."""
    return 1 << len(frame)


KINDS: dict[str, SourceKind] = {}
"""Every kind of source, by the name used as ``kind:`` in YAML."""


def register_kind(
    name: str, spec: type[Spec], example: Mapping[str, Any] | None = None, origin: str = "builtin"
) -> Callable[[Builder[Spec]], Builder[Spec]]:
    """Register a kind of source under ``name`` (a decorator of its builder), after checking it.

    The builder is called as ``build(name, spec, frame, focal)`` with the source's
    name, its validated ``spec`` (an instance of ``spec``), its frame, and a
    resolver of focal-set names to bitmasks; it returns an :class:`EvidenceSource`
    and reports a bad section by raising :class:`SpecError`. ``example`` is a
    section on the frame ``existence`` (:data:`EXAMPLE_FRAME`): it is built, and
    its source run through :func:`check_source`, before the kind is registered
    (without one, the kind's sources are checked when a config builds them).

    Raises
    ------
    ValueError
        naming the kind, if the name is taken or its example fails the checks.

    Examples
    --------
    >>> {"table", "ramp"} <= set(KINDS)
    True

    A kind whose rows sum to 2 is refused:

    >>> @register_kind("doubled", SourceSpec, {"frame": "existence", "feature": "x"})
    ... def build_doubled(name, spec, frame, focal):
    ...     twice = lambda values: np.tile([0.0, 1.0, 1.0, 0.0], (len(values), 1))
    ...     return BoundSource(name, frame, spec.feature, "doubled", twice, ("a",), "sums to 2")
    Traceback (most recent call last):
    ...
    ValueError: source kind 'doubled': row 0 sums to 2, not 1 (within 1e-09)
    """

    def decorate(build: Builder[Spec]) -> Builder[Spec]:
        if name in KINDS:
            raise ValueError(f"source kind {name!r} is already registered")
        kind = SourceKind(name, spec, build, example, origin)
        try:
            if example is not None:
                source = kind.build_example()
                check_source(source, getattr(source, "examples", ()))
        except (ValueError, TypeError) as exc:
            raise ValueError(f"source kind {name!r}: {exc}") from None
        KINDS[name] = kind
        return build

    return decorate


def mass_row(
    entries: Mapping[str, float], frame: Frame, focal: FocalResolver, at: tuple[str | int, ...] = ()
) -> NDArray[np.float64]:
    """One mass function as a dense row of ``2**n`` masses, from ``{focal set: mass}``.

    Refuses (with :class:`SpecError` naming the key) a focal set not in the frame,
    the same focal set twice, a negative or non-finite mass, mass on the empty set,
    and masses that do not sum to 1 within :data:`MASS_TOLERANCE`.

    Examples
    --------
    >>> from evidential import Frame
    >>> frame = Frame(["real", "noise"])
    >>> mass_row({"real": 0.8, "noise": 0.1, "real|noise": 0.1}, frame, frame.mask).tolist()
    [0.0, 0.8, 0.1, 0.1]
    """
    row = np.zeros(_width(frame))
    named: dict[int, str] = {}
    for key, mass in entries.items():
        try:
            mask = focal(key)
        except ValueError as exc:
            raise SpecError((*at, key), str(exc)) from None
        if mask in named:
            raise SpecError((*at, key), f"{key!r} names the same focal set as {named[mask]!r}")
        named[mask] = key
        if not math.isfinite(mass) or mass < 0:
            raise SpecError((*at, key), f"mass {mass:g} is negative or not finite; masses must be >= 0")
        if mask == 0 and mass > 0:
            raise SpecError((*at, key), f"mass {mass:g} on the empty set; a source's masses must be normalized")
        row[mask] = mass
    total = math.fsum(row)
    if abs(total - 1.0) > MASS_TOLERANCE:
        raise SpecError(at, f"masses sum to {total:.12g}, not 1 (within {MASS_TOLERANCE:g})")
    return row


def table_masses(values: ArrayLike, *, categories: NDArray[np.str_], rows: NDArray[np.float64]) -> NDArray[np.float64]:
    """Masses of N objects from their categories: row ``rows[i]`` for category ``categories[i]``.

    ``categories`` must be sorted (they are searched); every value must be one of them.

    Examples
    --------
    >>> import numpy as np
    >>> rows = np.array([[0, 0.1, 0.8, 0.1], [0, 0.8, 0.1, 0.1]])
    >>> table_masses(["outside", "inside"], categories=np.array(["inside", "outside"]), rows=rows)
    array([[0. , 0.8, 0.1, 0.1],
           [0. , 0.1, 0.8, 0.1]])
    """
    v = np.asarray(values)
    if v.ndim != 1:
        raise ValueError(f"expected a 1-D array of categories, got shape {v.shape}")
    v = v.astype(np.str_)
    index = np.minimum(np.searchsorted(categories, v), len(categories) - 1)
    unknown = categories[index] != v
    if unknown.any():
        raise ValueError(
            f"unknown category {str(v[unknown][0])!r}; the table has {', '.join(map(repr, categories.tolist()))}"
        )
    return rows[index]


def ramp_masses(
    values: ArrayLike,
    *,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    focal: int,
    rest: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Masses of N objects from a continuous feature through a piecewise-linear ramp.

    ``m(focal) = r``, with ``r`` interpolated linearly between the break points
    ``(x[i], y[i])`` and constant beyond the ends; the remaining ``1 - r`` goes to
    the focal sets of ``rest`` (a row of proportions summing to 1).

    Examples
    --------
    The paper's LSL source, ``m(real) = 0.6 * min(l / 0.4, 1)``, the rest unknown:

    >>> import numpy as np
    >>> ramp_masses([0.2, 1.0], x=np.array([0.0, 0.4]), y=np.array([0.0, 0.6]),
    ...             focal=1, rest=np.array([0.0, 0.0, 0.0, 1.0]))
    array([[0. , 0.3, 0. , 0.7],
           [0. , 0.6, 0. , 0.4]])
    """
    try:
        v = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"expected numbers, got {values!r}") from None
    if v.ndim != 1:
        raise ValueError(f"expected a 1-D array of numbers, got shape {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError(f"expected finite numbers, got {float(v[~np.isfinite(v)][0])}")
    r = np.interp(v, x, y)
    out = np.multiply.outer(1.0 - r, rest)
    out[:, focal] += r  # m(focal) = r, m(A) = (1 - r) * rest(A)
    return out


class TableSpec(SourceSpec):
    """``kind: table``: one mass function per category of a categorical feature."""

    kind: Literal["table"]
    categories: list[Category] = Field(
        min_length=1, max_length=MAX_CATEGORIES, description="every category the feature can take"
    )
    table: dict[Category, dict[Text, Mass]] = Field(
        max_length=MAX_CATEGORIES, description="category -> {focal set: mass}"
    )


@register_kind(
    "table",
    TableSpec,
    {
        "frame": "existence",
        "feature": "relation",
        "categories": ["outside", "inside"],
        "table": {"outside": {"real": 0.8, "unknown": 0.2}, "inside": {"noise": 0.8, "unknown": 0.2}},
    },
)
def build_table(name: str, spec: TableSpec, frame: Frame, focal: FocalResolver) -> BoundSource:
    """Build a table source; every declared category needs a row, and only those."""
    width = _width(frame)
    if len(spec.categories) * width > MAX_TABLE_CELLS:
        raise SpecError(
            ("categories",),
            f"{len(spec.categories)} categories on a frame of {width} focal sets exceed the limit of "
            f"{MAX_TABLE_CELLS} table cells",
        )
    seen: set[str] = set()
    for i, category in enumerate(spec.categories):
        if category in seen:
            raise SpecError(("categories", i), f"category {category!r} is listed twice")
        seen.add(category)
    missing = [c for c in spec.categories if c not in spec.table]
    extra = [c for c in spec.table if c not in seen]
    if extra:  # at the row's own line; a misspelt row is one of the missing categories
        hint = f": is it {missing[0]!r}, which the table lacks?" if len(missing) == 1 else ""
        raise SpecError(("table", extra[0]), f"category {extra[0]!r} is not in `categories`{hint}")
    if missing:
        raise SpecError(("table",), f"category {missing[0]!r} is missing from the table")
    rows = np.array([mass_row(spec.table[c], frame, focal, ("table", c)) for c in spec.categories])
    order = np.argsort(spec.categories)  # table_masses searches the categories: sort them
    return BoundSource(
        name=name,
        frame=frame,
        feature=spec.feature,
        kind="table",
        function=partial(table_masses, categories=np.array(spec.categories)[order], rows=rows[order]),
        examples=tuple(spec.categories),
        summary=f"table on the categorical feature {spec.feature!r}: one mass function per category",
    )


class RampSpec(SourceSpec):
    """``kind: ramp``: the mass of one focal set piecewise-linear in a continuous feature."""

    kind: Literal["ramp"]
    focal: Text = Field(description="the focal set whose mass the ramp gives")
    points: list[tuple[Mass, Mass]] = Field(
        min_length=1, max_length=MAX_BREAK_POINTS, description="break points [x, mass], x strictly increasing"
    )
    rest: dict[Text, Mass] = Field(
        min_length=1, max_length=64, description="focal set -> share of the remaining mass; shares sum to 1"
    )


@register_kind(
    "ramp",
    RampSpec,
    {
        "frame": "existence",
        "feature": "length",
        "focal": "real",
        "points": [[0, 0], [0.4, 0.6]],
        "rest": {"unknown": 1},
    },
)
def build_ramp(name: str, spec: RampSpec, frame: Frame, focal: FocalResolver) -> BoundSource:
    """Build a ramp source; break points strictly increasing in x, masses in [0, 1]."""
    try:
        mask = focal(spec.focal)
    except ValueError as exc:
        raise SpecError(("focal",), str(exc)) from None
    if mask == 0:
        raise SpecError(("focal",), "the ramp's focal set is the empty set; a source's masses must be normalized")
    x, y = np.array(spec.points).T
    for i in range(len(x)):
        if not 0.0 <= y[i] <= 1.0:
            raise SpecError(("points", i), f"mass {y[i]:g} is outside [0, 1]")
        if i and x[i] <= x[i - 1]:
            raise SpecError(
                ("points", i),
                f"x = {x[i]:g} is not above the previous break point's x = {x[i - 1]:g}; "
                "break points must be strictly increasing in x",
            )
    rest = mass_row(spec.rest, frame, focal, ("rest",))
    shown = ", ".join(f"({a:g}, {b:g})" for a, b in zip(x, y))
    return BoundSource(
        name=name,
        frame=frame,
        feature=spec.feature,
        kind="ramp",
        function=partial(ramp_masses, x=x, y=y, focal=mask, rest=rest),
        examples=tuple(np.sort(np.concatenate([x, (x[1:] + x[:-1]) / 2])).tolist()),
        summary=(
            f"ramp on the continuous feature {spec.feature!r}: m({spec.focal}) piecewise linear through "
            f"(x, m) = {shown}, constant beyond the ends; 1 - m({spec.focal}) shared as "
            + ", ".join(f"{k} {v:g}" for k, v in spec.rest.items())
        ),
    )
