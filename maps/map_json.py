"""What a map file holds: JSON values, the open space as GeoJSON, mass functions as ``{FOCAL: float}``.

The pieces :mod:`evmap.maps.belief_map` writes and reads ``map.json`` with
(``docs/SCENARIO.md``): the check that a value JSON carries exactly (so that a
save is lossless), the open space to and from GeoJSON-like coordinates, mass
functions to and from dicts in bulk, and a pause of the garbage collector while
hundreds of thousands of records are made.
"""

from __future__ import annotations

import gc
import math
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from itertools import chain
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import Frame, MassFunction

__all__ = [
    "BadMass",
    "MassCodec",
    "as_multipolygon",
    "check_json",
    "finite",
    "gc_paused",
    "geojson",
    "json_problem",
    "multipolygon",
    "shown",
]


@contextmanager
def gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while a big map is written or read, its grids made, or an
    observation folded in.

    Each allocates hundreds of thousands of containers (an update, tens of
    thousands), hardly any of them garbage; the collector's passes over them
    would double the time (an update's, on Freiburg's first 1,000 scans: about
    4 % of it, full passes over the whole map among them). Nothing else is
    changed: moving the new containers to the oldest generation by hand
    (``gc.freeze``, ``gc.unfreeze``) kept the collector from ever making a full
    pass again in a long process (a comparison of many worlds grew without end).
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class MassCodec:
    """Mass functions to ``{FOCAL: float}`` and back, in bulk (a map file holds hundreds of thousands)."""

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    def encode(self, masses: list[MassFunction]) -> list[dict[str, float]]:
        """``{FOCAL: float}`` of each mass function, as :meth:`MassFunction.to_dict` writes it."""
        labels_of: dict[bytes, list[str]] = {}
        out = []
        for m in masses:
            masks = m.masks
            labels = labels_of.get(key := masks.tobytes())
            if labels is None:
                labels = labels_of[key] = [self.frame.label(k) for k in masks.tolist()]
            out.append(dict(zip(labels, m.masses.tolist())))  # (zip's strict=True would cost a third)
        return out

    def encode_rows(self, rows: NDArray[np.float64]) -> list[dict[str, float]]:
        """``{FOCAL: float}`` of each dense row (columns by bitmask), zero masses left out: ``{}`` for a zero row."""
        labels = [self.frame.label(k) for k in range(rows.shape[1])] if rows.ndim == 2 else []
        return [{labels[j]: v for j, v in enumerate(row) if v != 0.0} for row in rows.tolist()]

    def decode(self, dicts: list[dict[Any, Any]]) -> list[MassFunction]:
        """The mass functions of the dicts; a bad one raises ``BadMass(index, engine's message)``.

        Dicts with the same focal sets are made as one array
        (:meth:`MassFunction.from_rows`); where that fails, each dict of the
        group goes through the engine's own constructor, which either accepts
        it or says what is wrong.
        """
        if not dicts:
            return []
        keys = list(map(tuple, dicts))
        code = {k: c for c, k in enumerate(dict.fromkeys(keys))}
        group = np.fromiter(map(code.__getitem__, keys), dtype=np.intp, count=len(keys))
        members = np.split(np.argsort(group, kind="stable"), np.cumsum(np.bincount(group, minlength=len(code)))[:-1])
        out: list[Any] = [None] * len(dicts)
        for focal, rows in zip(code, members, strict=True):
            rows = rows.tolist()
            for i, m in zip(rows, self._group(focal, list(map(dicts.__getitem__, rows))), strict=True):
                if m is None:
                    try:
                        m = MassFunction.from_dict(self.frame, dicts[i], open_world=True)
                    except (ValueError, TypeError, OverflowError) as exc:
                        raise BadMass(i, str(exc)) from None
                out[i] = m
        return out

    def _group(self, keys: tuple[Any, ...], dicts: list[dict[Any, Any]]) -> Sequence[MassFunction | None]:
        """The mass functions of dicts that all have the focal sets ``keys``; None for each if one is bad."""
        flat = list(chain.from_iterable(map(dict.values, dicts)))
        if not set(map(type, flat)) <= {float, int}:  # not bool, not str: the constructor says what is wrong
            return [None] * len(dicts)
        try:
            values = np.array(flat, dtype=np.float64).reshape(len(dicts), len(keys))
            return MassFunction.from_rows(self.frame, keys, values, open_world=True)
        except (ValueError, TypeError, OverflowError):
            return [None] * len(dicts)


class BadMass(Exception):
    """The mass of record ``index`` is bad: ``problem`` says why (the engine's message)."""

    def __init__(self, index: int, problem: str) -> None:
        super().__init__(problem)
        self.index = index
        self.problem = problem


def check_json(value: Any, where: str) -> None:
    """Refuse a value that JSON cannot carry exactly (so that ``save`` is lossless)."""
    if not _is_json(value):  # the quick walk; the message's path is found only for a value that fails
        raise ValueError(f"{where}: {json_problem(value, '')}")


def _is_json(value: Any) -> bool:
    """Whether :func:`json_problem` finds nothing, without building paths."""
    kind = type(value)
    if value is None or kind is bool or kind is int or kind is str:
        return True
    if kind is float:
        return math.isfinite(value)
    if kind is list or kind is tuple:
        kinds = set(map(type, value))
        if kinds <= _EXACT:  # a list of scalars (a line's members): one pass in C
            return True
        if kinds <= _NUMBERS:  # numbers (a fit, a position): finite
            return all(map(math.isfinite, value))
        return all(map(_is_json, value))
    if kind is dict:
        if not set(map(type, value)) <= _STR:
            return False
        kinds = set(map(type, value.values()))
        if kinds <= _EXACT:  # scalars: one pass in C
            return True
        if kinds == _FLOAT:  # floats (a mass): finite
            return all(map(math.isfinite, value.values()))
        return all(map(_is_json, value.values()))
    return False


_EXACT = frozenset({bool, int, str, type(None)})
"""The scalar types JSON carries exactly, whatever their value."""

_NUMBERS = frozenset({bool, int, float})
"""The scalar types :func:`math.isfinite` takes."""

_FLOAT, _STR = frozenset({float}), frozenset({str})
"""The values of a mass's dict, and the keys of any dict JSON carries."""


def json_problem(value: Any, path: str) -> str | None:
    """What keeps ``value`` (at ``path``) from being JSON that reads back the same, or None."""
    kind = type(value)
    if value is None or kind is bool or kind is int or kind is str:
        return None
    if kind is float:
        return None if math.isfinite(value) else f"{path or 'value'}: {value!r} is not finite"
    if kind is list or kind is tuple:
        return next((p for i, v in enumerate(value) if (p := json_problem(v, f"{path}[{i}]"))), None)
    if kind is dict:
        for k, v in value.items():
            if type(k) is not str:
                return f"{path or 'value'}: key {k!r} is not a string"
            if p := json_problem(v, f"{path}.{k}" if path else k):
                return p
        return None
    return f"{path or 'value'}: a {kind.__name__} is not JSON (None, bool, int, finite float, str, list, dict)"


def finite(value: Any) -> bool:
    """A float that is finite, or an int that a float can hold (not a bool)."""
    if type(value) is float:
        return math.isfinite(value)
    return type(value) is int and abs(value) <= sys.float_info.max


def shown(value: Any) -> str:
    """``repr(value)``, cut to 60 characters for an error message."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def as_multipolygon(geometry: shapely.Geometry | None) -> shapely.MultiPolygon:
    """A valid Polygon, MultiPolygon, empty geometry or None as a MultiPolygon; a ValueError otherwise."""
    if geometry is None or geometry.is_empty:
        return shapely.MultiPolygon()
    if isinstance(geometry, shapely.Polygon):
        geometry = shapely.MultiPolygon([geometry])
    if not isinstance(geometry, shapely.MultiPolygon):
        raise ValueError(f"open_space must be a Polygon or MultiPolygon, got a {geometry.geom_type}")  # noqa: TRY004
    if not geometry.is_valid:
        raise ValueError(f"open_space is not a valid geometry: {shapely.is_valid_reason(geometry)}")
    return geometry


def geojson(geometry: shapely.MultiPolygon) -> dict[str, Any]:
    """GeoJSON-like dict of a MultiPolygon, coordinates as nested lists (exact floats)."""
    if geometry.is_empty:
        return {"type": "MultiPolygon", "coordinates": []}
    _, coords, (ring_end, polygon_end, _) = shapely.to_ragged_array([geometry])
    points = coords.tolist()
    rings = [points[a:b] for a, b in zip(ring_end[:-1].tolist(), ring_end[1:].tolist(), strict=True)]
    polygons = [rings[a:b] for a, b in zip(polygon_end[:-1].tolist(), polygon_end[1:].tolist(), strict=True)]
    return {"type": "MultiPolygon", "coordinates": polygons}


def multipolygon(value: Any) -> shapely.MultiPolygon:
    """The MultiPolygon of :func:`geojson`'s dict."""
    if not (
        isinstance(value, dict) and value.get("type") == "MultiPolygon" and isinstance(value.get("coordinates"), list)
    ):
        raise ValueError(f"must be {{'type': 'MultiPolygon', 'coordinates': [...]}}, got {shown(value)}")
    polygons = value["coordinates"]
    if not polygons:
        return shapely.MultiPolygon()
    if not all(isinstance(p, list) and p and all(isinstance(r, list) for r in p) for p in polygons):
        raise ValueError("coordinates must be a list of polygons, each a non-empty list of rings")
    rings = [ring for polygon in polygons for ring in polygon]
    coords = np.array([xy for ring in rings for xy in ring], dtype=np.float64)
    if coords.ndim != 2 or coords.shape[1] != 2 or not np.isfinite(coords).all():
        raise ValueError("every coordinate must be [x, y] with finite numbers")
    offsets = (
        np.cumsum([0] + [len(ring) for ring in rings]),
        np.cumsum([0] + [len(polygon) for polygon in polygons]),
        np.array([0, len(polygons)]),
    )
    return shapely.from_ragged_array(shapely.GeometryType.MULTIPOLYGON, coords, offsets)[0]
