"""The conformance checks every evidence source passes (its rows are mass functions, one per object), those
every sensor kind passes (one valid feature value per segment, deterministic, the same one by one), and those
every combination rule from a plugin passes (it combines two and three sources, one row or a batch, and holds
the properties it claims on probe mass functions).

Shared by the registration of a source kind and the build of every source
(:mod:`evmap.sources.evidence`), the registration of a sensor kind
(:func:`evmap.sources.sensor_kinds.register_sensor_kind`), the registration of a plugin's rule
(:mod:`evmap.sources.plugins`), and the test suites of each.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential import RULES, Frame, combine_batch

__all__ = ["MASS_TOLERANCE", "check_masses", "check_rule_function", "check_sensor", "check_source", "example_readings"]

MASS_TOLERANCE = 1e-9
"""Masses (and ramp proportions) must sum to 1 within this."""


def check_masses(masses: Any, n: int, frame: Frame) -> NDArray[np.float64]:
    """Refuse what is not ``n`` mass functions over ``frame`` as dense rows; return them as an array.

    Each row must be finite, non-negative, without mass on the empty set, and sum to 1
    within :data:`MASS_TOLERANCE`.

    >>> check_masses([[0.0, 0.5, 0.5, 0.0]], 1, Frame(["real", "noise"])).tolist()
    [[0.0, 0.5, 0.5, 0.0]]
    >>> check_masses([[0.0, 1.0, 1.0, 0.0]], 1, Frame(["real", "noise"]))
    Traceback (most recent call last):
    ...
    ValueError: row 0 sums to 2, not 1 (within 1e-09)
    """
    m = np.asarray(masses)
    if m.shape != (n, 1 << len(frame)) or not np.issubdtype(m.dtype, np.floating):
        raise ValueError(f"masses must be an ({n}, {1 << len(frame)}) float array, got {m.dtype} {m.shape}")
    bad = np.flatnonzero(~np.isfinite(m).all(axis=1) | (m < 0).any(axis=1))
    if len(bad):
        raise ValueError(f"row {bad[0]} holds a negative or non-finite mass: {m[bad[0]].tolist()}")
    bad = np.flatnonzero(m[:, 0] > 0)
    if len(bad):
        raise ValueError(f"row {bad[0]} has mass {m[bad[0], 0]:g} on the empty set")
    total = m.sum(axis=1)
    bad = np.flatnonzero(np.abs(total - 1.0) > MASS_TOLERANCE)
    if len(bad):
        raise ValueError(f"row {bad[0]} sums to {total[bad[0]]:.12g}, not 1 (within {MASS_TOLERANCE:g})")
    return m


def check_source(source: Any, values: ArrayLike) -> None:
    """The conformance checks of an evidence source (``name``, ``frame``, ``feature``, ``masses``) on feature values.

    Its masses of the values are mass functions over its frame, one row per value;
    computing them again gives the same; each row is what the value alone gives.

    Raises
    ------
    ValueError
        saying which check failed.
    """
    values = np.asarray(values)
    batch = check_masses(source.masses({source.feature: values}), len(values), source.frame)
    if not np.array_equal(batch, source.masses({source.feature: values})):
        raise ValueError("masses differ between two calls on the same values: a source must be deterministic")
    for i in range(len(values)):
        alone = check_masses(source.masses({source.feature: values[i : i + 1]}), 1, source.frame)
        if not np.allclose(alone[0], batch[i], rtol=0, atol=MASS_TOLERANCE):
            raise ValueError(
                f"value {values[i].item()!r} gives {alone[0].tolist()} alone but {batch[i].tolist()} in a batch"
            )


EXAMPLE_P = np.array([[0.5, -1.0], [1.0, 1.0], [2.0, 0.0], [-1.0, -1.0], [0.0, 2.0], [0.5, 0.5]])
EXAMPLE_Q = np.array([[0.5, 1.0], [2.0, 1.0], [2.5, 0.5], [-1.0, 1.0], [0.3, 2.2], [0.5, 0.5001]])
"""Segments (m) a sensor kind's features are checked on: crossing, near, far, short."""


def example_readings(arrays: Mapping[str, tuple[int | str, ...]], length: int = 3) -> dict[str, NDArray[np.float64]]:
    """Readings of a kind's array form, each letter ``length`` long, filled with 0.5, 1, 1.5, ... (finite, > 0).

    >>> {k: v.tolist() for k, v in example_readings({"pose": (3,), "points": ("D", 2)}, 2).items()}
    {'pose': [0.5, 1.0, 1.5], 'points': [[0.5, 1.0], [1.5, 2.0]]}
    """
    out = {}
    for name, shape in arrays.items():
        dims = tuple(length if isinstance(s, str) else s for s in shape)
        out[name] = 0.5 * (1 + np.arange(int(np.prod(dims)), dtype=float)).reshape(dims)
    return out


def check_sensor(sensor: Any, arrays: Mapping[str, tuple[int | str, ...]]) -> None:
    """The conformance checks of a sensor (``features(readings, p, q)``, checked) of a kind's array form.

    On :func:`example_readings` (of 3, and of 0, readings) and the segments :data:`EXAMPLE_P` -
    :data:`EXAMPLE_Q`: computing the features again gives the same; each segment alone gets what it gets in
    the batch; no segment gives empty features.

    Raises
    ------
    ValueError
        saying which check failed.
    """
    for length in (3, 0):
        readings = example_readings(arrays, length)
        batch = sensor.features(readings, EXAMPLE_P, EXAMPLE_Q)
        again = sensor.features(readings, EXAMPLE_P, EXAMPLE_Q)
        for name, values in batch.items():
            if not np.array_equal(values, again[name]):
                raise ValueError(f"feature {name!r} differs between two calls on the same readings")
        for i in range(len(EXAMPLE_P)):
            alone = sensor.features(readings, EXAMPLE_P[i : i + 1], EXAMPLE_Q[i : i + 1])
            for name, values in batch.items():
                same = values.dtype.kind != "f" and alone[name][0] == values[i]
                if not (same or (values.dtype.kind == "f" and np.isclose(alone[name][0], values[i]))):
                    raise ValueError(
                        f"feature {name!r} of segment {i} is {alone[name][0].item()!r} alone but "
                        f"{values[i].item()!r} in a batch ({length} readings)"
                    )
        sensor.features(readings, EXAMPLE_P[:0], EXAMPLE_Q[:0])


_PROBES = (
    np.array([[0.0, 0.6, 0.1, 0.3], [0.0, 0.2, 0.5, 0.3], [0.0, 0.1, 0.1, 0.8]]),
    np.array([[0.0, 0.5, 0.0, 0.0, 0.2, 0.0, 0.0, 0.3], [0.0, 0.1, 0.3, 0.0, 0.0, 0.0, 0.4, 0.2], [0.0] * 7 + [1.0]]),
)
"""Three mass functions (rows) on 2 and on 3 elements, each with m(Θ) > 0, the third of three elements vacuous;
read-only, so that a rule writing into its sources fails here, not later."""

_BAYESIAN = np.array([[0.0, 0.7, 0.3, 0.0], [0.0, 0.4, 0.6, 0.0]])
"""Two Bayesian mass functions on 2 elements."""


def check_rule_function(name: str) -> None:
    """The conformance checks of the registered rule ``name`` (:data:`evidential.RULES`) on probe mass functions.

    It combines two and three sources, one row and a batch of rows alike (subnormal probes, with some mass
    moved to ∅, for a rule whose ``empty_set`` is ``required``), into mass functions; and it holds the
    properties it claims (commutative, associative, idempotent, vacuous identity, Bayes' on Bayesian mass
    functions) on the probes, within :data:`MASS_TOLERANCE`. A probe cannot prove a property; it refutes a
    false claim.

    Raises
    ------
    ValueError
        saying which check failed.
    """
    rule = RULES[name]
    probes = [p.copy() for p in _PROBES]
    for p in probes:
        if rule.empty_set == "required":
            p[:, 0] = 0.1 * p[:, -1]  # a tenth of m(Θ) moved to ∅: every probe subnormal
            p[:, -1] *= 0.9
        p.flags.writeable = False
    for p in probes:
        a, b, c = p[0:1], p[1:2], p[2:3]
        two, three = combine_batch(a, b, rule=name), combine_batch(a, b, c, rule=name)
        batch = combine_batch(p[:2], p[1:], rule=name)  # rows (a, b) and (b, c) at once
        for row, alone in enumerate((two, combine_batch(b, c, rule=name))):
            if not np.allclose(batch[row], alone[0], rtol=0, atol=MASS_TOLERANCE):
                raise ValueError(f"rule {name!r} gives {batch[row].tolist()} in a batch but {alone[0].tolist()} alone")
        claims = {  # claim: (the sources to combine, what they must give, the two sides named)
            "commutative": ((b, a), two, "a ⊕ b and b ⊕ a"),
            "associative": ((two, c), three, "(a ⊕ b) ⊕ c and a ⊕ b ⊕ c"),
            "idempotent": ((a, a), a, "a ⊕ a and a"),
            "vacuous_identity": ((a, _vacuous(a)), a, "a ⊕ vacuous and a"),
        }
        if rule.empty_set == "required":
            del claims["vacuous_identity"]  # the vacuous mass function has m(∅) = 0: not one this rule takes
        for claim in sorted(rule.properties & set(claims)):
            sources, expected, what = claims[claim]
            _check_claim(name, claim, combine_batch(*sources, rule=name), expected, what)
    if "bayes_on_bayesian" in rule.properties:
        p, q = _BAYESIAN[:1], _BAYESIAN[1:]
        got, expected = combine_batch(p, q, rule=name), combine_batch(p, q, rule="bayes")
        _check_claim(name, "bayes_on_bayesian", got, expected, "it and 'bayes' on Bayesian ones")


def _check_claim(name: str, claim: str, got: NDArray[np.float64], expected: NDArray[np.float64], what: str) -> None:
    """Refuse a claim the probes refute: ``got`` and ``expected`` (the two sides ``what`` names) differ."""
    gap = float(np.abs(got - expected).max())
    if not gap <= MASS_TOLERANCE:
        raise ValueError(f"rule {name!r} claims {claim!r}, but on probe mass functions {what} differ by {gap:.3g}")


def _vacuous(rows: NDArray[np.float64]) -> NDArray[np.float64]:
    """The vacuous mass function, as many rows as ``rows``, over their frame."""
    out = np.zeros_like(rows)
    out[:, -1] = 1.0
    return out
