"""The conformance checks every evidence source passes (its rows are mass functions, one per object), and
those every sensor kind passes (one valid feature value per segment, deterministic, the same one by one).

Shared by the registration of a source kind and the build of every source
(:mod:`evmap.sources.evidence`), the registration of a sensor kind
(:func:`evmap.sources.sensor_kinds.register_sensor_kind`), and the test suites of both.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential import Frame

__all__ = ["MASS_TOLERANCE", "check_masses", "check_sensor", "check_source", "example_readings"]

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
