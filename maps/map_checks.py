"""Checks of what goes into a belief map: point kinds, extra attributes, histories (JSON that reads back).

>>> checked_history([{"pose": 1, "mass": {"real": 0.5}}], "L1")
[{'pose': 1, 'mass': {'real': 0.5}}]
>>> check_extras({"members": [1]}, ("id", "mass", "members"), "L1")
Traceback (most recent call last):
...
ValueError: 'L1': attributes ['members'] are reserved
"""

from __future__ import annotations

import builtins
from collections.abc import Iterable, Mapping
from typing import Any

from evmap.maps import map_json
from evmap.maps.map_format import POINT_KINDS

__all__ = ["check_extras", "checked_history", "checked_kind"]


def checked_kind(kind: str, id: str) -> str:
    """``kind`` if it is a point kind (:data:`~evmap.maps.map_format.POINT_KINDS`), else a ValueError naming ``id``."""
    if kind not in POINT_KINDS:
        raise ValueError(f"{id!r}: kind must be one of {list(POINT_KINDS)}, got {kind!r}")
    return kind


def check_extras(attrs: Mapping[str, Any], reserved: tuple[str, ...], id: str) -> None:
    """Refuse extra attributes of ``id`` that are ``reserved`` names or not JSON."""
    clash = sorted(set(attrs) & set(reserved))
    if clash:
        raise ValueError(f"{id!r}: attributes {clash} are reserved")
    map_json.check_json(attrs, id)


def checked_history(
    history: Iterable[Mapping[str, Any]], id: str, kept: Iterable[Mapping[str, Any]] = ()
) -> list[dict[str, Any]]:
    """A copy of the records of ``id``'s history, each a JSON object; records of ``kept`` (the history the
    map holds, checked when they came) are taken as they are, not checked again."""
    known = {builtins.id(record) for record in kept}
    records = [record if builtins.id(record) in known else dict(record) for record in history]
    try:
        map_json.check_json([r for r in records if builtins.id(r) not in known], f"{id}: history")
    except ValueError:
        map_json.check_json(records, f"{id}: history")  # raises, naming the record by its place in the history
    return records
